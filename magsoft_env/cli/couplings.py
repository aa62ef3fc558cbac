"""``magsoft couplings``: the two magnetic couplings compared on the jig beams of Fig. 4b-d.

``coupling="rotated"`` lets the magnetization turn with the cross-section (couple per length
``m B sin(alpha - beta - theta)``); ``coupling="paper"`` is eq. 10 verbatim, where only the
axial component ``m cos(beta)`` couples (``m B cos(beta) sin(alpha - theta)``). They agree for
beta = 0 or pi and differ for continuously varying profiles; this command shows by how much.
Writes ``couplings.png`` (shapes overlaid: solid rotated, dashed paper), ``couplings.csv`` and
``couplings_config.json``, and prints the tip differences.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from ..io import format_table, write_csv
from ..units import MM
from .output import DEFAULT_OUT, out_dir, write_json
from .solve import MAX_GRAVITY, _check_flag, add_planar_only_flags, metrics_row, refuse_3d

JIG_PRESETS = ("fig4b_quadratic", "fig4c_sinusoidal", "fig4d_piecewise")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "couplings",
        help="compare coupling='rotated' and 'paper' on the Fig. 4b-d jig beams (figure and tip table)",
        description="Solve each jig beam's loading path with both magnetic couplings and overlay the shapes at "
        "a few field levels; print the tip position and tip angle differences.",
    )
    p.add_argument("--presets", "--preset", nargs="+", default=list(JIG_PRESETS), metavar="NAME",
                   help=f"presets to compare (default: {' '.join(JIG_PRESETS)})")
    p.add_argument("--levels", type=int, default=3, help="field levels overlaid per beam (default 3)")
    p.add_argument("--steps", type=int, default=None, help="states per ramp (default: the presets')")
    p.add_argument("--gravity", type=float, default=None, help="m/s^2 (default: the presets')")
    p.add_argument("--extensible", action=argparse.BooleanOptionalAction, default=None,
                   help="include axial strain (default: the presets')")
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT}/)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    add_planar_only_flags(p)
    p.set_defaults(run=run)


def build_presets(args) -> list:
    from magsoft_env.cases import load_preset

    refuse_3d(args, "couplings")
    _check_flag("--levels", args.levels, lo=1, hi=20, integer=True)
    _check_flag("--steps", args.steps, lo=2, hi=10_000, integer=True)
    if args.gravity is not None:
        _check_flag("--gravity", args.gravity, lo=0.0, hi=MAX_GRAVITY)
    if len(args.presets) > 100:
        raise ValueError(f"--presets takes at most 100 names, got {len(args.presets)}.")
    presets = []
    for name in dict.fromkeys(args.presets):
        p = load_preset(name)
        if args.steps is not None:
            p = p.with_steps(args.steps)
        changes = {k: getattr(args, k) for k in ("gravity", "extensible") if getattr(args, k) is not None}
        presets.append(p.replace(**changes) if changes else p)
    refuse_3d(args, "couplings", presets)
    return presets


def _levels(n_states: int, levels: int) -> list[int]:
    """Indices of ``levels`` states spread over the path, ending at the last (the zero-field state skipped)."""
    if levels >= n_states - 1:
        return list(range(1, n_states)) if n_states > 1 else [0]
    return sorted({round(n_states - 1 - k * (n_states - 1) / levels) for k in range(levels)})


def run(args) -> int:
    from magsoft_env.theory import solve_path

    out = out_dir(args.out)
    presets = build_presets(args)
    rows, cases = [], []
    failed = 0
    for preset in presets:
        rot = solve_path(preset.beam, preset.fields, **{**preset.solver_options(), "coupling": "rotated"})
        pap = solve_path(preset.beam, preset.fields, **{**preset.solver_options(), "coupling": "paper"})
        idx = _levels(len(rot), args.levels)
        s_fine = np.linspace(0.0, preset.beam.length, 801)
        cases.append({
            "title": f"{preset.name} (L = {preset.beam.length / MM:.1f} mm)",
            "length": preset.beam.length,
            "reference": ([0.0, preset.beam.length], [0.0, 0.0]),
            "rotated": [rot[i] for i in idx],
            "paper": [pap[i] for i in idx],
            "beta": (s_fine, preset.beam.beta(s_fine)),
        })
        for i in idx:
            mr = metrics_row(rot[i], preset.beam, axis=preset.sweep_axis)
            mp = metrics_row(pap[i], preset.beam, axis=preset.sweep_axis)
            failed += (not mr["success"]) + (not mp["success"])
            rows.append({
                "preset": preset.name,
                "length_mm": preset.beam.length / MM,
                "Bx_mT": mr["Bx_mT"],
                "Bz_mT": mr["Bz_mT"],
                "tip_x_rotated_mm": mr["tip_x_mm"],
                "tip_z_rotated_mm": mr["tip_z_mm"],
                "tip_x_paper_mm": mp["tip_x_mm"],
                "tip_z_paper_mm": mp["tip_z_mm"],
                "tip_distance_mm": math.hypot(mr["tip_x_mm"] - mp["tip_x_mm"], mr["tip_z_mm"] - mp["tip_z_mm"]),
                "tip_distance_over_L": math.hypot(mr["tip_x_mm"] - mp["tip_x_mm"], mr["tip_z_mm"] - mp["tip_z_mm"])
                / (preset.beam.length / MM),
                "tip_angle_rotated_deg": mr["tip_angle_deg"],
                "tip_angle_paper_deg": mp["tip_angle_deg"],
                "tip_angle_difference_deg": mr["tip_angle_deg"] - mp["tip_angle_deg"],
                "success_rotated": mr["success"],
                "success_paper": mp["success"],
                "stable_rotated": mr["stable"],
                "stable_paper": mp["stable"],
            })

    files = []
    if not args.no_plot:
        from magsoft_env.render.figures import couplings_figure

        files.append(couplings_figure(cases, out / "couplings.png"))
    files.append(write_csv(out / "couplings.csv", rows))
    files.append(write_json(out / "couplings_config.json", {
        "presets": [{"name": p.name, "description": p.description, "config": p.config,
                     "solver_options": {k: v for k, v in p.solver_options().items() if k != "coupling"}}
                    for p in presets],
        "levels": args.levels,
    }))
    print(format_table(rows, [
        ("preset", "preset", ""), ("Bx_mT", "Bx mT", ".3g"), ("Bz_mT", "Bz mT", ".3g"),
        ("tip_x_rotated_mm", "tip x rot", ".2f"), ("tip_z_rotated_mm", "tip z rot", ".2f"),
        ("tip_x_paper_mm", "tip x paper", ".2f"), ("tip_z_paper_mm", "tip z paper", ".2f"),
        ("tip_distance_mm", "|dtip| mm", ".2f"), ("tip_distance_over_L", "|dtip|/L", ".3f"),
        ("tip_angle_difference_deg", "dtheta_l deg", ".2f"),
    ]))
    for f in files:
        print(f"wrote {f}")
    if failed:
        print(f"warning: {failed} equilibria did not converge (see the success columns of couplings.csv).")
        return 1
    return 0

"""``magsoft sweep``: Fig. 3-style load curves (v/L, tip angle, rotation angle against P) for the validation beams.

For each beam length and each loading path (a: B_z 0 -> 13 mT; b: B_z held at 13 mT, B_x
0 -> -22 mT) the path is solved with gravity and without; P = A M B L^2 / (E I) of the
ramped component (B_z on path a, |B_x| on path b). Writes ``sweep.csv``, ``sweep.png`` and
the resolved configuration ``sweep_config.json``.
"""

from __future__ import annotations

from ..io import format_table, write_csv
from ..units import MM
from .output import DEFAULT_OUT, out_dir, write_json
from .solve import (
    _check_flag,
    add_planar_only_flags,
    add_solver_flags,
    apply_overrides,
    metrics_row,
    refuse_3d,
)

PATHS = {"a": "fig3a_L{L}", "b": "fig3b_L{L}"}
BASE_LENGTH_MM = 25  # preset whose path and beam are used for lengths without their own preset


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "sweep",
        help="Fig. 3-style curves of v/L, tip and rotation angle against P, with and without gravity (PNG, CSV)",
        description="Solve the paper's validation paths (Fig. 3a: B_z 0 -> 13 mT; Fig. 3b: B_z = 13 mT held, "
        "B_x 0 -> -22 mT) for beams of several lengths (h = 1.13 mm, w = 5 mm, phi = 0.2), with gravity and "
        "without, and plot the metrics against the normalized field P.",
    )
    p.add_argument("--lengths-mm", type=float, nargs="+", default=[20.0, 25.0, 30.0],
                   help="beam lengths in mm (default 20 25 30, i.e. l/h = 17.7, 22.1, 26.5)")
    p.add_argument("--paths", nargs="+", choices=sorted(PATHS), default=sorted(PATHS),
                   help="loading paths to run (default: a b)")
    p.add_argument("--steps", type=int, default=None,
                   help="states per ramp (default: the presets', 27 on path a and 23 on path b)")
    add_solver_flags(p, preset_defaults=False, support=False)  # the Fig. 3 beams are cantilevers
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT}/)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_planar_only_flags(p)
    p.set_defaults(run=run)


def build_cases(args) -> list[tuple[str, float, object]]:
    """(path name, length in mm, preset) for every curve; all input checks happen here."""
    from magsoft_env.cases import list_presets, load_preset

    refuse_3d(args, "sweep")
    _check_flag("--steps", args.steps, lo=2, hi=10_000, integer=True)
    if len(args.lengths_mm) > 100:
        raise ValueError(f"--lengths-mm takes at most 100 lengths, got {len(args.lengths_mm)}.")
    lengths = []
    for L in args.lengths_mm:
        _check_flag("--lengths-mm", L, lo=0.0, hi=1000.0, open_lo=True)
        if L not in lengths:
            lengths.append(L)
    names = set(list_presets())
    cases = []
    for path in args.paths:
        for L in lengths:
            name = PATHS[path].format(L=f"{L:g}")
            if name in names:
                preset = load_preset(name)
            else:
                base = load_preset(PATHS[path].format(L=BASE_LENGTH_MM))
                preset = base.replace(name=name, beam=base.beam.replace(length=L * MM))
            if args.steps is not None:
                preset = preset.with_steps(args.steps)
            preset = apply_overrides(preset, args)
            # with the preset's (or --gravity's) gravity, and without; once if that is already 0
            for gravity in dict.fromkeys((preset.gravity, 0.0)):
                cases.append((path, L, preset.replace(gravity=gravity)))
    return cases


def run(args) -> int:
    from tqdm.auto import tqdm

    from magsoft_env.theory import solve_path

    out = out_dir(args.out)
    cases = build_cases(args)
    rows = []
    failed = 0
    with tqdm(total=sum(len(p.fields) for *_, p in cases), desc="sweep", unit="eq", disable=args.quiet) as bar:
        for path, L, preset in cases:
            bar.set_postfix_str(f"path {path}, L = {L:g} mm, g = {preset.gravity:g}")
            results = solve_path(preset.beam, preset.fields, **preset.solver_options())
            for r in results:
                row = {"path": path, "preset": preset.name, "length_mm": L, "l_over_h": preset.beam.slenderness,
                       "gravity_m_per_s2": preset.gravity}
                row.update(metrics_row(r, preset.beam, axis=preset.sweep_axis))
                failed += not row["success"]
                rows.append(row)
            bar.update(len(results))

    files = []
    if not args.no_plot:
        from magsoft_env.render.figures import sweep_figure

        files.append(sweep_figure(rows, out / "sweep.png"))
    files.append(write_csv(out / "sweep.csv", rows))
    config = {
        "lengths_mm": sorted({c[1] for c in cases}),
        "cases": [{"path": path, "length_mm": L, "preset": p.name, "gravity_m_per_s2": p.gravity,
                   "solver_options": p.solver_options(), "states": len(p.fields)} for path, L, p in cases],
    }
    files.append(write_json(out / "sweep_config.json", config))

    _print_summary(rows)
    for f in files:
        print(f"wrote {f}")
    if failed:
        print(f"warning: {failed} of {len(rows)} equilibria did not converge (see the 'success' column).")
        return 1
    return 0


def _print_summary(rows: list[dict]) -> None:
    """Last state of every curve: one line each."""

    last = {}
    for r in rows:
        last[(r["path"], r["length_mm"], r["gravity_m_per_s2"])] = r
    table = [dict(r, g=r["gravity_m_per_s2"]) for r in last.values()]
    print(format_table(table, [
        ("path", "path", ""), ("length_mm", "L mm", "g"), ("g", "g m/s2", "g"), ("Bx_mT", "Bx mT", ".3g"),
        ("Bz_mT", "Bz mT", ".3g"), ("P", "P", ".3g"), ("v_over_L", "v/L", ".4f"),
        ("tip_angle_deg", "tip deg", ".2f"), ("rotation_angle_deg", "rot deg", ".2f"), ("stable", "stable", ""),
        ("success", "success", ""),
    ]))

"""``magsoft crosscheck``: the paper's Fig. 3 and Fig. 4 beams in the analytical model and in MuJoCo."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..io import write_text_atomic
from .output import out_dir
from .solve import _check_flag, field_mT_flag, refuse_3d, robot_preset

DEFAULT_PRESETS = (
    "fig3a_L20", "fig3a_L25", "fig3a_L30", "fig3b_L20", "fig3b_L25", "fig3b_L30",
    "fig4b_quadratic", "fig4c_sinusoidal", "fig4d_piecewise",
)


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "crosscheck",
        help="compare the analytical solver with the MuJoCo rod (tip error / L vs segments)",
        description=(
            "Solve each preset's loading path with the analytical solver (rotated coupling, inextensible) and "
            "with the MuJoCo hinge chain at several segment counts; print tip-position error / L and wall "
            "times; optionally write overlay figures."
        ),
    )
    p.add_argument("presets", nargs="*", metavar="PRESET",
                   help="preset names (default: Fig. 3 and 4b-d); or give them with --preset")
    p.add_argument("--preset", "--presets", dest="preset_names", nargs="+", metavar="NAME", default=None,
                   help="preset names, as with the other commands (added to any given positionally)")
    p.add_argument("--robot", nargs="+", metavar="PATH", default=None,
                   help="robot files (or built-in names): each beam as a cantilever, field ramped from zero to "
                        "--field-mT (instead of the default presets)")
    p.add_argument("--field-mT", type=float, nargs="+", metavar=("BX", "BZ"), default=None,
                   help="final field for --robot, mT (default 0 13)")
    p.add_argument("--segments", type=int, nargs="+", default=[10, 20, 40], help="segment counts (default 10 20 40)")
    p.add_argument("--grading", type=float, default=None,
                   help="last/first cell length ratio (default: the rod's cantilever default, 1.5; 1 = equal cells)")
    p.add_argument("--steps", type=int, default=None, help="resample every ramp of the path to this many states")
    p.add_argument("--out", type=Path, default=None, help="folder for overlay figures (PNG) and a CSV table")
    p.set_defaults(run=run)
    return p


def run(args) -> int:
    from magsoft_env.cases import load_preset

    if len(args.segments) > 20:
        raise ValueError(f"--segments takes at most 20 counts, got {len(args.segments)}.")
    for n in args.segments:
        if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= 1000:
            raise ValueError(f"--segments must be integers in [2, 1000], got {n}.")
    _check_flag("--grading", args.grading, lo=0.1, hi=10.0)
    _check_flag("--steps", args.steps, lo=2, hi=10_000, integer=True)
    if args.out is not None:
        args.out = out_dir(args.out)
    given = list(dict.fromkeys([*(args.presets or ()), *(args.preset_names or ())]))
    names = given or ([] if args.robot else list(DEFAULT_PRESETS))
    if len(names) + len(args.robot or ()) > 100:
        raise ValueError(f"crosscheck takes at most 100 presets and robots, got {len(names) + len(args.robot)}.")
    if args.field_mT is not None and not args.robot:
        raise ValueError("--field-mT applies to --robot (a preset has its own loading path).")
    field = None
    if args.field_mT is not None:
        field = field_mT_flag(args.field_mT)
    cases = []
    for nm in names:
        cases.append(load_preset(nm))  # an unknown name: the closest one suggested
    for src in args.robot or ():
        cases.append(robot_preset(src, field, args.steps))  # a bad file: its key named, before any work
        _note_ignored_source(src)
    refuse_3d(None, "crosscheck", cases)  # the MuJoCo rod is planar: a 3D robot is refused before any output
    from magsoft_env.compare.crosscheck import crosscheck_preset  # after the checks: imports mujoco
    from magsoft_env.render.figures import crosscheck_figure

    rows_all = []
    print(f"{'preset':<18} {'N':>4} {'max err/L %':>12} {'mean err/L %':>13} {'MuJoCo s':>9} {'theory s':>9}  ok")
    for preset in cases:
        nm = preset.name
        if preset.support != "cantilever":
            print(f"{nm:<18} skipped: support={preset.support!r} (the MuJoCo rod is clamped only)")
            continue
        if args.steps is not None:
            preset = preset.with_steps(args.steps)
        rows, th, sims = crosscheck_preset(preset, args.segments, grading=args.grading)
        for r in rows:
            print(
                f"{nm:<18} {r.segments:>4} {100 * r.max_tip_error:>12.3f} {100 * r.mean_tip_error:>13.3f} "
                f"{r.sim_seconds:>9.3f} {r.theory_seconds:>9.3f}  {'yes' if r.success else 'NO'}"
            )
        sys.stdout.flush()
        rows_all.extend(rows)
        if args.out is not None:
            crosscheck_figure(preset.name, th, sims, args.out / f"crosscheck_{preset.name}.png")
    if args.out is not None:
        lines = ["preset,segments,grading,max_tip_error_over_L,mean_tip_error_over_L,mujoco_s,theory_s,success\n"]
        lines += [
            f"{r.preset},{r.segments},{r.grading},{r.max_tip_error:.6g},{r.mean_tip_error:.6g},"
            f"{r.sim_seconds:.4g},{r.theory_seconds:.4g},{r.success}\n"
            for r in rows_all
        ]
        write_text_atomic(args.out / "crosscheck.csv", "".join(lines))
        print(f"wrote {args.out}/crosscheck.csv and overlay figures")
    return 0 if all(r.success for r in rows_all) else 1


def _note_ignored_source(src) -> None:
    """Say on stderr that a robot file's ``field_source`` block plays no part here (the crosscheck ramps a uniform
    field on both models); silently dropping it would read as a check in that source."""
    from magsoft_env.cases.robots import load_robot

    robot = load_robot(src)
    if robot.field_source is not None:
        kind = (robot.field_source or {}).get("type", "a field source")
        print(f"note: robot {robot.name!r} has a field_source ({kind}) that magsoft crosscheck does not use: both "
              "models are ramped in a uniform field (magsoft solve --robot runs the analytical model in the source).",
              file=sys.stderr)

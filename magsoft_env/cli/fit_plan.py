"""``magsoft fit-plan``: which fields to apply so that ``magsoft fit`` pins the parameters down, before measuring.

Prints the planned fields and the 1-sigma each parameter is predicted to reach from the robot's tip tracked with
the given noise (:func:`magsoft_env.plan_measurements`); ``--csv`` writes the fields as a CSV for ``magsoft fit``
with the position columns left empty, to fill in with the tracked tip::

    magsoft fit-plan --robot paper-5c --n 8 --noise-mm 0.1 --csv plan.csv
    # measure, fill tip_x_mm and tip_z_mm, then
    magsoft fit plan.csv --robot paper-5c --params E0,particle_magnetization
"""

from __future__ import annotations

import csv
import math

from .output import dumps_json, out_file


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "fit-plan",
        help="plan the fields of a fit: the most informative ones and the precision they predict",
        description="Choose the uniform fields whose tracked tip positions fit the parameters most precisely "
                    "(exact sensitivities at the robot's values, fields kept away from folds), and predict the "
                    "1-sigma of each parameter.",
    )
    p.add_argument("--robot", default="paper-5c", help="robot name or YAML file: the guess of your robot")
    p.add_argument("--params", default="E0,particle_magnetization",
                   help="comma-separated parameters to fit: E0, particle_magnetization, density, thickness, "
                        "volume_fraction, clamp_angle; with --model 3d also width, poisson_ratio (default "
                        "E0,particle_magnetization)")
    p.add_argument("--n", type=int, default=8, help="measurements to plan, gravity alone included (default 8)")
    p.add_argument("--noise-mm", type=float, default=0.1, help="tracking noise, 1 sigma per coordinate (mm, "
                                                                "default 0.1)")
    p.add_argument("--max-field-mT", type=float, default=4.0, help="largest field your set-up makes (mT, default 4)")
    p.add_argument("--spread", type=float, default=0.3,
                   help="prior relative uncertainty of each parameter: fields stay clear of folds over it "
                        "(default 0.3)")
    p.add_argument("--model", choices=("planar", "3d"), default="planar",
                   help="planar (fields in the x-z plane, x and z tracked; default) or 3d (fields with B_y, x, y and "
                        "z tracked: needed for width and poisson_ratio)")
    p.add_argument("--directions", type=int, default=24,
                   help="candidate directions: every 360/N degrees (planar) or N over the sphere (3d); default 24")
    p.add_argument("--magnitudes", type=int, default=8,
                   help="candidate magnitudes: max-field x k/N, k = 1..N (default 8)")
    p.add_argument("--both-directions", action="store_true",
                   help="plan the fields in pairs B and -B (--n less the gravity measurement must be even)")
    p.add_argument("--gravity", type=float, default=9.81, help="gravity during the measurements (m/s^2)")
    p.add_argument("--csv", default=None, help="write the planned fields as a CSV for magsoft fit (positions empty)")
    p.add_argument("--plot", default=None, help="write a figure of the plan (PNG): the shapes under each field")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.set_defaults(run=run)


def run(args) -> int:
    import magsoft_env as ms
    from magsoft_env.cases.robots import resolve_robot

    if not (math.isfinite(args.noise_mm) and args.noise_mm > 0):
        raise ValueError(f"--noise-mm must be a positive length (mm), got {args.noise_mm!r}.")
    if not (math.isfinite(args.max_field_mT) and 0 < args.max_field_mT <= 1000):
        raise ValueError(f"--max-field-mT must lie in (0, 1000] mT, got {args.max_field_mT!r}.")
    if args.csv is not None:
        out_file(args.csv, flag="--csv", suffixes=(".csv",))
    if args.plot is not None:
        out_file(args.plot, flag="--plot", suffixes=(".png",))
    robot = resolve_robot(args.robot, name="--robot")
    params = tuple(p.strip() for p in args.params.split(",") if p.strip())
    plan = ms.plan_measurements(robot.beam, params, n=args.n, noise=args.noise_mm * 1e-3,
                                gravity=args.gravity, max_field=args.max_field_mT * 1e-3, spread=args.spread,
                                both_directions=args.both_directions, model=args.model, directions=args.directions,
                                magnitudes=args.magnitudes, progress=_progress())
    out = {"robot": robot.name, "params": list(params), "noise_mm": args.noise_mm,
           "model": args.model, "fields_mT": [[b * 1e3 for b in f] for f in plan.fields],
           "min_eigenvalue": plan.min_eigenvalue, "sigma": plan.sigma, "relative_sigma": plan.relative_sigma,
           "correlation": plan.correlation.tolist(), "candidates": plan.candidates, "rejected": plan.rejected}
    if args.csv:
        with open(args.csv, "w", newline="") as fh:
            w = csv.writer(fh)
            if args.model == "3d":
                w.writerow(["Bx_mT", "By_mT", "Bz_mT", "tip_x_mm", "tip_y_mm", "tip_z_mm"])
            else:
                w.writerow(["Bx_mT", "Bz_mT", "tip_x_mm", "tip_z_mm"])
            for f in plan.fields:
                w.writerow([f"{b * 1e3:.6g}" for b in f] + [""] * len(f))
        out["csv"] = str(args.csv)
    if args.plot:
        from magsoft_env.render.fit import plot_plan

        plot_plan(plan, robot.beam, gravity=args.gravity, path=args.plot)
        out["plot"] = str(args.plot)
    if args.json:
        print(dumps_json(out))
        return 0
    print(f"fit plan for {', '.join(params)} of robot {robot.name}: {len(plan.fields)} measurements, tip tracked "
          f"to {args.noise_mm:g} mm, fields up to {args.max_field_mT:g} mT, clear of folds over "
          f"+-{args.spread:.0%} ({plan.candidates} candidates, {plan.rejected} refused)")
    print(plan.table())
    if args.csv:
        print(f"fields written to {args.csv}: fill the tip columns with the tracked tip, then run "
              f"magsoft fit {args.csv} --robot {args.robot} --params {','.join(params)}")
    if args.plot:
        print(f"figure written to {args.plot}")
    return 0


def _progress():
    """A progress reporter for the candidates' evaluation: a line on stderr at every tenth (a 3D plan takes a
    minute or more), nothing for plans done within two seconds."""
    import sys
    import time

    t0 = time.perf_counter()
    shown = [0]

    def report(done: int, total: int) -> None:
        tenth = (10 * done) // total
        if tenth > shown[0] and time.perf_counter() - t0 > 2.0:
            shown[0] = tenth
            print(f"fit-plan: {done}/{total} candidate fields evaluated ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr, flush=True)

    return report

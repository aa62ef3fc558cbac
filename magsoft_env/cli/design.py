"""``magsoft design``: magnetization profile, jig and field for a target shape (paper Fig. 6)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..units import MM, MT
from .output import out_dir, write_json
from .solve import MAX_GRAVITY, _check_flag, add_planar_only_flags, refuse_3d, warn_tiny_mT


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "design",
        help="inverse design: profile, jig and field that make a beam follow a target curve",
        description="Design the magnetization profile (and its jig, eq. 1) and the field that bend a cantilever "
        "into a target curve (eq. 18). The beam length is set to the curve length, as in the paper. Writes "
        "profile.csv, field.csv, jig.csv/jig.svg, target/prediction/ramp CSV, summary.json, fit.png and "
        "ramp.png to --out.",
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--target", metavar="NAME", help="built-in object contour: ball, vase, calabash, dumbbell")
    src.add_argument("--target-csv", metavar="FILE", help="CSV with columns x_mm,z_mm (or x_m,z_m), clamp first")
    src.add_argument("--letters", metavar="TEXT",
                     help="design one beam per letter of TEXT (from S, J, T, U; the paper's Fig. 4e is SJTU) and "
                     "write letters.png plus one folder per letter")
    p.add_argument("--width-mm", type=float, default=5.0,
                   help="beam width in mm, in (0, 1000] (default 5)")
    p.add_argument("--thickness-mm", type=float, default=1.13,
                   help="beam thickness in mm, in (0, 1000] (default 1.13)")
    p.add_argument("--volume-fraction", type=float, default=0.2,
                   help="particle volume fraction, in (0, 0.5] (default 0.2)")
    p.add_argument("--field-min-mT", type=float, default=1.0,
                   help="smallest field magnitude in mT, in [0, 1000] (default 1)")
    p.add_argument("--field-max-mT", type=float, default=None,
                   help="largest field magnitude in mT, in (0, 1000] (default 20; 40 for --letters)")
    p.add_argument("--free-direction", action="store_true",
                   help="let the field angle vary too (default: along +z, perpendicular to the beam)")
    p.add_argument("--family", choices=("spline", "polynomial", "fourier", "piecewise_linear"), default="spline",
                   help="profile family (default spline)")
    p.add_argument("--size", type=int, default=None,
                   help="number of profile parameters, in [1, 40] (default per family)")
    p.add_argument("--points", type=int, default=50, help="target points N, in [4, 100000] (default 50)")
    p.add_argument("--starts", type=int, default=4, help="local starts at most, in [1, 1000] (default 4)")
    p.add_argument("--max-nfev", type=int, default=60, help="evaluations per start, in [2, 100000] (default 60)")
    p.add_argument("--global", dest="global_stage", action="store_true",
                   help="add a differential-evolution stage if the local starts miss the tolerance")
    p.add_argument("--rms-tol-percent", type=float, default=0.25,
                   help="RMS error in %% of L that counts as a fit, in [0, 100] (default 0.25)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random starts, in [0, 2^32 - 1] (default 0)")
    p.add_argument("--gravity", type=float, default=9.81, help="m/s^2 along -z, in [0, 1000] (default 9.81)")
    p.add_argument("--coupling", choices=("rotated", "paper"), default="rotated", help="magnetic coupling")
    p.add_argument("--mujoco", action="store_true",
                   help="also simulate the designed beam under the designed field in MuJoCo (20 segments) and "
                   "report its distance to the analytical shape")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--out", default="magsoft_out/design", help="output folder (default magsoft_out/design)")
    add_planar_only_flags(p)
    p.set_defaults(run=run)


def run(args) -> int:
    import magsoft_env as ms
    from magsoft_env.design import builtin_target, read_curve_csv, validate_target
    from magsoft_env.render.design import write_design


    check_flags(args)
    out = out_dir(args.out)
    if args.letters is not None:
        return _run_letters(args, out)
    if args.target is not None:
        name, target = args.target, builtin_target(args.target)
    else:
        name, target = Path(args.target_csv).stem, read_curve_csv(args.target_csv)
    target = validate_target(target, name="target")
    beam = ms.Beam(length=1.0, width=args.width_mm * MM, thickness=args.thickness_mm * MM,
                   volume_fraction=args.volume_fraction)
    res = ms.design_profile(
        target, beam, field_bounds=(args.field_min_mT * MT, args.field_max_mT * MT), family=args.family,
        size=args.size, field_direction="free" if args.free_direction else "perpendicular", n_points=args.points,
        n_starts=args.starts, seed=args.seed, rms_tol=args.rms_tol_percent / 100.0, max_nfev=args.max_nfev,
        global_stage=args.global_stage, gravity=args.gravity, coupling=args.coupling, progress=not args.quiet,
    )
    files = write_design(res, out, name=name, figures=not args.no_figures)
    robot_file, tip_change = write_robot(res, out / "robot.yml", name)
    files.append(robot_file)
    f = res.field
    print(f"target {name}: beam length {res.beam.length / MM:.2f} mm (= curve length), "
          f"{res.family.kind} profile with {res.family.size} parameters")
    print(f"field: Bx = {f.Bx / MT:.3f} mT, Bz = {f.Bz / MT:.3f} mT (|B| = {f.magnitude / MT:.3f} mT)")
    print(f"fit error: RMS {res.rms_error / MM:.4f} mm ({res.rms_error_percent:.3f}% of L), "
          f"max {res.max_error / MM:.4f} mm ({res.max_error_percent:.3f}% of L)")
    print(f"{res.nfev} equilibrium solves in {res.wall_time:.1f} s; {res.message}")
    if args.mujoco:
        from magsoft_env.compare import mujoco_check

        chk = mujoco_check(res, segments=20)
        print(f"MuJoCo (20 segments): max distance to the analytical shape {chk['max_to_analytical'] / MM:.4f} mm, "
              f"RMS to target {100 * chk['rms_to_target'] / res.beam.length:.3f}% of L; settled: {chk['success']}")
        files.append(write_json(out / "mujoco_check.json", {
            "segments": chk["segments"], "success": chk["success"], "message": chk["message"],
            "max_to_analytical_mm": chk["max_to_analytical"] / MM,
            "rms_to_analytical_mm": chk["rms_to_analytical"] / MM,
            "rms_to_target_mm": chk["rms_to_target"] / MM, "sim_xz_mm": (chk["sim_xz"] / MM).tolist(),
        }))
    print(f"robot.yml: the designed beam as a robot file (load_robot, --robot); reloaded, its tip under the design "
          f"field moves {tip_change / MM:.2e} mm from the design's")
    print(f"wrote {len(files)} files to {out}/")
    return 0 if res.success else 1


def write_robot(res, path, name: str):
    """Write the designed beam as a robot file and check it: reload it and solve its equilibrium under the design
    field; returns (path, distance in m between that tip and the design's predicted tip)."""
    from magsoft_env.cases.robots import Robot, load_robot
    from magsoft_env.theory import solve_path

    f, st = res.field, res.settings
    robot = Robot(
        name=f"design-{name}", beam=res.beam, source="magsoft design", design_field=f,
        description=(f"Designed by magsoft design for the target {name!r}: {res.family.kind} magnetization profile "
                     f"with {res.family.size} parameters, beam length {res.beam.length / MM:.3f} mm (the curve's), "
                     f"held field Bx = {f.Bx / MT:.4g} mT, Bz = {f.Bz / MT:.4g} mT (field.csv), fit RMS "
                     f"{res.rms_error_percent:.3f} % of L. No drive: the design field is static (design_field_mT; "
                     "magsoft solve --robot ramps to it)."),
    )
    written = robot.save(path, sample_functions=True)  # a polynomial or Fourier profile is stored as samples
    back = load_robot(written)
    if back.design_field != f:
        raise RuntimeError(f"the robot file {written} does not keep the design field: {back.design_field} != {f}")
    fields = [(f.Bx * t, f.Bz * t) for t in np.linspace(0.0, 1.0, 9)[1:]]
    last = solve_path(back.beam, fields, gravity=st["gravity_m_s2"], coupling=st["coupling"],
                      extensible=st["extensible"], clamp_angle=st["clamp_angle_rad"])[-1]
    if not last.success:
        raise RuntimeError(f"the robot file {written} does not reproduce the design: {last.message}")
    tip = np.array([last.x[-1], last.z[-1]])
    return written, float(np.hypot(*(tip - np.asarray(res.predicted_xz[-1], dtype=float))))


def check_flags(args) -> None:
    """Every numeric flag, by its name, before any work (ranges as in ``magsoft design --help``)."""
    refuse_3d(args, "design")
    _check_flag("--width-mm", args.width_mm, lo=0.0, hi=1000.0, open_lo=True)
    _check_flag("--thickness-mm", args.thickness_mm, lo=0.0, hi=1000.0, open_lo=True)
    _check_flag("--volume-fraction", args.volume_fraction, lo=0.0, hi=0.5, open_lo=True)
    _check_flag("--field-min-mT", args.field_min_mT, lo=0.0, hi=1000.0)
    if args.field_max_mT is None:
        args.field_max_mT = 40.0 if args.letters is not None else 20.0
    _check_flag("--field-max-mT", args.field_max_mT, lo=0.0, hi=1000.0, open_lo=True)
    warn_tiny_mT("--field-max-mT", [args.field_max_mT])  # the largest field: tesla typed in mT if this small
    _check_flag("--size", args.size, lo=1, hi=40, integer=True)
    _check_flag("--points", args.points, lo=4, hi=100_000, integer=True)
    _check_flag("--starts", args.starts, lo=1, hi=1000, integer=True)
    _check_flag("--max-nfev", args.max_nfev, lo=2, hi=100_000, integer=True)
    _check_flag("--rms-tol-percent", args.rms_tol_percent, lo=0.0, hi=100.0)
    _check_flag("--seed", args.seed, lo=0, hi=2**32 - 1, integer=True)
    _check_flag("--gravity", args.gravity, lo=0.0, hi=MAX_GRAVITY)


def _run_letters(args, out) -> int:
    from magsoft_env.design.letters import LETTERS, design_letters
    from magsoft_env.render.design import write_design
    from magsoft_env.render.figures import letters_figure

    text = args.letters.upper()
    bad = sorted(set(text) - set(LETTERS))
    if not text or bad:
        raise ValueError(f"--letters must use only {''.join(LETTERS)}, got {args.letters!r}.")
    results = design_letters(
        text, field_bounds=(args.field_min_mT * MT, args.field_max_mT * MT), width=args.width_mm * MM,
        thickness=args.thickness_mm * MM, seed=args.seed, gravity=args.gravity, coupling=args.coupling,
        progress=not args.quiet,
    )
    ok = True
    for ch, res in results.items():
        write_design(res, out / ch, name=f"letter {ch}", figures=not args.no_figures)
        ok &= res.success
        print(f"{ch}: L {res.beam.length / MM:.2f} mm, |B| {res.field.magnitude / MT:.2f} mT, RMS "
              f"{res.rms_error / MM:.4f} mm ({res.rms_error_percent:.3f}% of L), {res.wall_time:.1f} s; {res.message}")
    if not args.no_figures:
        letters_figure(results, out / "letters.png")
    print(f"wrote {out}/")
    return 0 if ok else 1

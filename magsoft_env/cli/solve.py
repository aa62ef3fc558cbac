"""``magsoft solve``: equilibrium shapes along a loading path, from a preset or from parameters in mm and mT.

Also holds what the other subcommands share: metrics rows, solver flags, flag checks (the output folder and
file checks and the JSON writers are :mod:`~magsoft_env.cli.output`, re-exported here).
"""

from __future__ import annotations

import argparse
import math
import sys
import textwrap

from ..io import format_table
from ..spec.loading import MAX_GRAVITY  # largest --gravity (m/s^2) every command accepts: 100 g
from ..units import MM, MT

# the output helpers, re-exported under their old home
from .output import DEFAULT_OUT, dumps_json, out_dir, out_file, tidy, tidy_float, write_json  # noqa: F401

# beam flags of ``magsoft solve``: (flag, default, help); defaults are the paper's 25 mm beam
BEAM_FLAGS = (
    ("--length-mm", 25.0, "beam length L in mm"),
    ("--width-mm", 5.0, "width w in mm"),
    ("--thickness-mm", 1.13, "thickness h in mm"),
    ("--phi", 0.2, "particle volume fraction in [0, 0.5]"),
    ("--beta-deg", 0.0, "uniform magnetization angle in deg, from +x toward +z"),
    ("--density-kg-per-m3", 1940.0, "composite density in kg/m^3, in [100, 30000]"),
    ("--poisson", 0.49, "Poisson's ratio nu in [0, 0.5]: the shear modulus G = E / (2 (1 + nu)) of the torsion (3D)"),
)
def add_solver_flags(p, *, preset_defaults: bool, support: bool = True) -> None:
    """Flags that override solver options; ``None`` means "the preset's (or the default) value"."""
    p.add_argument("--gravity", type=float, default=None, metavar="G",
                   help="gravitational acceleration in m/s^2 along -z; 0 switches gravity off"
                   + (" (default: the preset's)" if preset_defaults else " (default 9.81)"))
    p.add_argument("--coupling", choices=("rotated", "paper"), default=None,
                   help="magnetic coupling: 'rotated' (magnetization turns with the section, default) or "
                   "'paper' (eq. 10 verbatim)")
    p.add_argument("--extensible", action=argparse.BooleanOptionalAction, default=None,
                   help="include axial strain (paper eq. 14); --no-extensible for the inextensible beam")
    if support:
        p.add_argument("--support", choices=("cantilever", "free"), default=None,
                       help="cantilever (clamped at s = 0) or free-free (needs --gravity 0)")


def add_planar_only_flags(p) -> None:
    """Hidden ``--field-mT`` and ``--magnetization`` flags of a planar command, so that a field or a 3D
    magnetization given to it is answered by :func:`refuse_3d` rather than "unrecognized arguments"."""
    p.add_argument("--field-mT", type=float, nargs="*", default=None, help=argparse.SUPPRESS)
    p.add_argument("--magnetization", type=float, nargs="*", default=None, help=argparse.SUPPRESS)


def refuse_3d(args, command: str, presets=()) -> None:
    """A ValueError naming ``magsoft COMMAND`` if ``args`` give a field or a magnetization (hidden flags of
    :func:`add_planar_only_flags`) or a preset's beam or fields leave the x-z plane: the command is planar,
    ``magsoft solve`` takes 3D."""
    where = ("magsoft solve takes 3D fields (--field-mT BX BY BZ) and magnetizations (--magnetization AXIAL WIDTH "
             "THICKNESS).")
    field = getattr(args, "field_mT", None)
    if field is not None:
        what = "a 3D field" if len(field) == 3 else "a field"
        raise ValueError(f"magsoft {command} is planar (x-z plane) and has no --field-mT flag, got --field-mT "
                         f"{' '.join(f'{v:g}' for v in field)} ({what}); {where}")
    mag = getattr(args, "magnetization", None)
    if mag is not None:
        raise ValueError(f"magsoft {command} is planar (x-z plane) and has no --magnetization flag, got "
                         f"--magnetization {' '.join(f'{v:g}' for v in mag)}; {where}")
    for preset in presets:
        if not preset.beam.is_planar:
            raise ValueError(f"magsoft {command} is planar (x-z plane), but {preset.name!r} has a "
                             f"magnetization with a component across the width; {where}")
        if any(not f.is_planar for seg in preset.path for f in (seg.start, seg.end)):
            raise ValueError(f"magsoft {command} is planar (x-z plane), but {preset.name!r} has a field "
                             f"with a B_y component; {where}")


def load_parameter(beam, field, axis: str = "magnitude") -> float:
    """The normalized field P = A M B L^2 / (E I) of one field component (``Bx``, ``Bz``) or of |B|."""
    from magsoft_env.spec import Field

    if axis == "Bx":
        f = Field(abs(field.Bx), 0.0)
    elif axis == "Bz":
        f = Field(0.0, abs(field.Bz))
    else:
        f = field
    return float(beam.nondimensional_groups(f, gravity=0.0)["Lambda"])


def metrics_row(result, beam, *, axis: str = "magnitude") -> dict:
    """The reported metrics of one equilibrium (SI converted to mm, mT, deg for people)."""
    f = result.field
    L = beam.length
    return {
        "Bx_mT": f.Bx / MT,
        "Bz_mT": f.Bz / MT,
        "P": load_parameter(beam, f, axis),
        "Lambda": float(beam.nondimensional_groups(f, gravity=0.0)["Lambda"]),
        "v_over_L": float(result.tip_deflection) / L,
        "tip_x_mm": float(result.x[-1]) / MM,
        "tip_z_mm": float(result.z[-1]) / MM,
        "tip_angle_deg": math.degrees(float(result.tip_angle)),
        "rotation_angle_deg": math.degrees(float(result.rotation_angle)),
        "max_curvature_per_mm": float(result.max_curvature) * MM,
        "stable": bool(result.stable),
        "snap_through": bool(result.snap_through),
        "success": bool(result.success),
        "status": int(result.status),
        "message": str(result.message),
    }


METRIC_COLUMNS = [
    ("Bx_mT", "Bx mT", ".3g"),
    ("Bz_mT", "Bz mT", ".4g"),
    ("P", "P", ".3g"),
    ("v_over_L", "v/L", ".4f"),
    ("tip_angle_deg", "tip deg", ".2f"),
    ("rotation_angle_deg", "rot deg", ".2f"),
    ("stable", "stable", ""),
    ("success", "success", ""),
]


def apply_overrides(preset, args):
    """The preset with the solver flags of ``args`` applied (``None``: keep); checked again by Preset."""
    changed = {k: getattr(args, k, None) for k in ("gravity", "coupling", "extensible", "support")}
    changed = {k: v for k, v in changed.items() if v is not None}
    if changed.get("gravity") is not None:
        _check_flag("--gravity", changed["gravity"], lo=0.0, hi=MAX_GRAVITY)
    return preset.replace(**changed) if changed else preset


# ---------------------------------------------------------------------------------------------
# the subcommand


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "solve",
        help="equilibrium shape(s) of a preset or a uniform beam; prints metrics, writes JSON and PNG",
        description="Solve the equilibrium along a loading path (gravity first, then the field ramped from zero). "
        "Give --preset NAME (see --list), --robot PATH or the beam's parameters. Metrics: v/L (tip z over length), "
        "tip angle, rotation angle (chord angle atan2(Z_tip, X_tip)).",
    )
    src = p.add_argument_group("case")
    src.add_argument("--preset", metavar="NAME", help="a shipped preset (or a path to a preset .json file)")
    src.add_argument("--robot", metavar="PATH",
                     help="a robot (file .yml/.yaml/.json or built-in name): its beam as a cantilever, field ramped "
                          "from zero to --field-mT (default: the robot's design field, as magsoft design writes it, "
                          "else 0 13)")
    src.add_argument("--list", action="store_true", help="list the presets and exit")
    for flag, default, text in BEAM_FLAGS:
        src.add_argument(flag, type=float, default=None, help=f"{text} (default {default:g})")
    src.add_argument("--magnetization", type=float, nargs=3, metavar=("AXIAL", "WIDTH", "THICKNESS"), default=None,
                     help="uniform magnetization direction in the strip's frame (along it, across its width, through "
                          "its thickness), instead of --beta-deg; a width component solves in 3D")
    src.add_argument("--field-mT", type=float, nargs="+", metavar="B", default=None,
                     help="final applied field in mT: BX BZ (default 0 13), or BX BY BZ, which solves in 3D; with "
                          "--preset, replaces its path")
    src.add_argument("--steps", type=int, default=None,
                     help="states along each ramp of the path (default: the preset's; 14 for parameters)")
    add_solver_flags(p, preset_defaults=True)
    p.add_argument("--critical", action="store_true",
                   help="solve in 3D and report the first loss of stability along the ramp from zero (critical field "
                        "in mT, its discretization error, bifurcation or fold; Prandtl's estimate beside it for a "
                        "uniform, axially magnetized strip)")
    from .sources import add_source_flags

    add_source_flags(p, what="solves the cantilever (clamped at the origin along +x) in its field with gravity, "
                              "planar and inextensible, the source switched on from zero in --steps states (default "
                              "1); --field-mT is then a uniform field added to it")
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT}/)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    p.set_defaults(run=run)


def build_case(args):
    """(preset, overrides) from parsed arguments; every check happens here, before any solving."""
    from magsoft_env.cases import PathSegment, Preset, load_preset
    from magsoft_env.spec import Beam, Field, Material

    _check_flag("--steps", args.steps, lo=2, hi=10_000, integer=True)
    field = None
    if args.field_mT is not None:
        field = field_mT_flag(args.field_mT, three=True)
    three = args.field_mT is not None and len(args.field_mT) == 3
    given = [flag for flag, _, _ in BEAM_FLAGS if getattr(args, _dest(flag)) is not None]
    if getattr(args, "magnetization", None) is not None:
        if args.beta_deg is not None:
            raise ValueError("give --beta-deg (an angle in the x-z plane) or --magnetization AXIAL WIDTH THICKNESS "
                             "(a direction), not both.")
        given.append("--magnetization")
    if args.preset and given:
        raise ValueError(f"give --preset or beam parameters, not both: got --preset {args.preset} and {given}.")
    robot = getattr(args, "robot", None)
    if robot is not None and (args.preset or given):
        raise ValueError(f"give --robot, --preset or beam parameters, one of them: got --robot {robot} and "
                         f"{'--preset ' + args.preset if args.preset else given}.")
    if robot is not None:
        return apply_overrides(robot_preset(robot, field, args.steps, three=three), args)
    for flag, default, _ in BEAM_FLAGS:
        if getattr(args, _dest(flag)) is None:
            setattr(args, _dest(flag), default)
    if args.preset:
        preset = load_preset(args.preset)
        if field is not None:
            preset = preset.replace(path=(PathSegment(Field(), field, args.steps or 14),))
    else:
        _check_flag("--length-mm", args.length_mm, lo=0.0, hi=1000.0, open_lo=True)
        _check_flag("--width-mm", args.width_mm, lo=0.0, hi=1000.0, open_lo=True)
        _check_flag("--thickness-mm", args.thickness_mm, lo=0.0, hi=1000.0, open_lo=True)
        _check_flag("--phi", args.phi, lo=0.0, hi=0.5)
        _check_flag("--beta-deg", args.beta_deg, lo=-360.0, hi=360.0)
        _check_flag("--density-kg-per-m3", args.density_kg_per_m3, lo=100.0, hi=30000.0)
        _check_flag("--poisson", args.poisson, lo=0.0, hi=0.5)
        mag = magnetization_flag(args.magnetization)
        beam = Beam(
            length=args.length_mm * MM,
            width=args.width_mm * MM,
            thickness=args.thickness_mm * MM,
            material=Material(density=args.density_kg_per_m3, poisson_ratio=args.poisson),
            volume_fraction=args.phi,
            magnetization=math.radians(args.beta_deg) if mag is None else mag,
        )
        field = field if field is not None else Field.from_mT(0.0, 13.0)
        description = (f"uniform beam L = {args.length_mm:g} mm, w = {args.width_mm:g} mm, "
                       f"h = {args.thickness_mm:g} mm, phi = {args.phi:g}")
        config = {"length_mm": args.length_mm, "width_mm": args.width_mm, "thickness_mm": args.thickness_mm,
                  "phi": args.phi}
        if mag is None:
            description += f", beta = {args.beta_deg:g} deg"
            config["beta_deg"] = args.beta_deg
        else:
            description += f", magnetization ({' '.join(f'{v:g}' for v in mag)})"
            config["magnetization"] = list(mag)
        if "--poisson" in given:
            description += f", nu = {args.poisson:g}"
            config["poisson"] = args.poisson
        config["density_kg_per_m3"] = args.density_kg_per_m3
        config["field_mT"] = field_list_mT(field, three)
        preset = Preset(name="custom", description=description, beam=beam,
                        path=(PathSegment(Field(), field, args.steps or 14),), config=config)
    if args.steps is not None and field is None:
        preset = preset.with_steps(args.steps)
    return apply_overrides(preset, args)


#: Field a robot's beam is solved under when none is given (mT): the paper's Fig. 3a ramp end.
ROBOT_FIELD_MT = (0.0, 13.0)


def robot_preset(source, field=None, steps: int | None = None, *, three: bool = False):
    """A cantilever :class:`~magsoft_env.cases.Preset` of a robot's beam (a robot file, name or Robot): the field
    ramped from zero to ``field`` in ``steps`` states (default 14). Without ``field``: the robot's design field
    (``design_field_mT`` in its file, written by ``magsoft design``), else :data:`ROBOT_FIELD_MT`. ``three``:
    the config names the field by three components (it was given so)."""
    from magsoft_env.cases import PathSegment, Preset
    from magsoft_env.cases.robots import load_robot
    from magsoft_env.spec import Field

    robot = load_robot(source)
    if field is None:
        field = robot.design_field if robot.design_field is not None else Field.from_mT(*ROBOT_FIELD_MT)
    return Preset(name=robot.name, description=robot.description or f"robot {robot.name}", beam=robot.beam,
                  path=(PathSegment(Field(), field, steps or 14),), source=str(source),
                  config={"robot": str(source), "field_mT": field_list_mT(field, three)})


def field_list_mT(field, three: bool = False) -> list[float]:
    """A field in mT as written in configs: [B_x, B_z] for a planar one, [B_x, B_y, B_z] otherwise (or if ``three``)."""
    if three or not field.is_planar:
        return [field.Bx / MT, field.By / MT, field.Bz / MT]
    return [field.Bx / MT, field.Bz / MT]


def magnetization_flag(values, flag: str = "--magnetization"):
    """The direction (axial, width, thickness) of a ``--magnetization`` flag (None: not given), each component
    checked; only the direction counts, so it must not be (0, 0, 0)."""
    if values is None:
        return None
    if len(values) != 3:
        raise ValueError(f"{flag} takes three numbers, AXIAL WIDTH THICKNESS, got {len(values)}.")
    for name, v in zip(("AXIAL", "WIDTH", "THICKNESS"), values, strict=True):
        _check_flag(f"{flag} {name}", v, lo=-1e6, hi=1e6)
    if not any(values):
        raise ValueError(f"{flag} gives a direction and must not be 0 0 0.")
    return tuple(float(v) for v in values)


def field_mT_flag(values, flag: str = "--field-mT", *, three: bool = False):
    """The Field of a ``--field-mT BX BZ`` flag (taken as ``nargs="+"`` so that three numbers get this message,
    not argparse's "unrecognized arguments"), each component checked by name. ``three``: ``BX BY BZ`` is
    accepted too (the 3D solve)."""
    from magsoft_env.spec import Field
    from magsoft_env.spec.field import PLANAR_FIELD_NOTE

    if three and len(values) == 3:
        for name, v in zip(("BX", "BY", "BZ"), values, strict=True):
            _check_flag(f"{flag} {name}", v, lo=-1000.0, hi=1000.0)
        warn_tiny_mT(flag, values)
        return Field.from_mT(*values)
    if three and len(values) != 2:
        raise ValueError(f"{flag} takes two numbers, BX BZ, or three, BX BY BZ, in mT, got {len(values)}: "
                         f"{' '.join(f'{v:g}' for v in values)}.")
    if len(values) != 2:
        note = f" {PLANAR_FIELD_NOTE} magsoft solve takes {flag} BX BY BZ." if len(values) == 3 else ""
        raise ValueError(f"{flag} takes two numbers, BX BZ in mT, got {len(values)}: "
                         f"{' '.join(f'{v:g}' for v in values)}.{note}")
    bx, bz = values
    _check_flag(f"{flag} BX", bx, lo=-1000.0, hi=1000.0)
    _check_flag(f"{flag} BZ", bz, lo=-1000.0, hi=1000.0)
    warn_tiny_mT(flag, values)
    return Field.from_mT(bx, bz)


#: A nonzero field below this magnitude (mT) given to an mT flag is taken for tesla typed in mT: the robots
#: here need a few mT to bend at all (the paper's ramps end at 13-22 mT).
TINY_MT = 0.1


def warn_tiny_mT(flag: str, values) -> bool:
    """Print a warning on stderr when the nonzero field ``values`` given to ``flag`` (in mT) has a magnitude below
    :data:`TINY_MT`, with the value it likely meant (the numbers x 1000: tesla typed in mT). A warning, not an
    error: the field is used as given. Returns whether it warned."""
    mag = math.sqrt(sum(float(v) ** 2 for v in values))
    if not 0.0 < mag < TINY_MT:
        return False
    meant = " ".join(f"{float(v) * 1e3:g}" for v in values)
    given = " ".join(f"{float(v):g}" for v in values)
    print(f"warning: {flag} {given} is a field of {mag:.3g} mT, too small to bend these robots (they take a few mT "
          f"and up); the flag is in mT: did you give tesla? {flag} {meant} is {mag * 1e3:.3g} mT.", file=sys.stderr)
    return True


def _dest(flag: str) -> str:
    return flag.lstrip("-").replace("-", "_")


def _check_flag(flag, value, *, lo, hi, open_lo=False, integer=False):
    """Raise ValueError unless ``value`` (None: not given) is a number in [lo, hi] (or (lo, hi]); an int if asked."""
    if value is None:
        return
    if integer and (not isinstance(value, int) or isinstance(value, bool)):
        raise ValueError(f"{flag} must be an integer in [{lo}, {hi}], got {value!r}.")
    if isinstance(value, (str, bytes, bool)) or not isinstance(value, (int, float)):
        raise ValueError(f"{flag} must be a number in [{lo:g}, {hi:g}], got {value!r}.")
    if not math.isfinite(value) or value > hi or value < lo or (open_lo and value == lo):
        rng = f"({lo:g}, {hi:g}]" if open_lo else f"[{lo:g}, {hi:g}]"
        raise ValueError(f"{flag} must lie in {rng}, got {value!r}.")


def run(args) -> int:
    from magsoft_env.cases import list_presets, load_preset
    from magsoft_env.theory import solve_path

    if args.list:
        for name in list_presets():
            print(f"{name:20s} {load_preset(name).source}")
        return 0
    field_source, origin = _field_source(args)  # a bad source: exit 2 before anything is written
    out = out_dir(args.out)
    preset = build_case(args)
    if field_source is not None:
        from .solve_source import run_source

        return run_source(args, preset, field_source, origin, out)
    if args.critical or (args.field_mT is not None and len(args.field_mT) == 3) or not preset.beam.is_planar:
        from .rod import run_rod

        return run_rod(args, preset, out)
    results = solve_path(preset.beam, preset.fields, **preset.solver_options())
    rows = [metrics_row(r, preset.beam, axis=preset.sweep_axis) for r in results]

    print(textwrap.fill(f"{preset.name}: {preset.description}", width=110))
    print(f"L = {preset.beam.length / MM:.4g} mm, support {preset.support}, gravity {preset.gravity:g} m/s^2, "
          f"coupling {preset.coupling}, extensible {preset.extensible}")
    print(format_table(rows, METRIC_COLUMNS))

    stem = f"solve_{preset.name}"
    files = []
    if not args.no_plot:
        from magsoft_env.render.figures import path_figure

        files.append(path_figure([(f"{preset.name} ({preset.source or 'custom'})", results, preset.beam.length)],
                                 out / f"{stem}.png"))
    payload = {
        "preset": preset.name,
        "description": preset.description,
        "source": preset.source,
        "config": preset.config,
        "solver_options": preset.solver_options(),
        "length_m": preset.beam.length,
        "results": rows,
        "final": {**rows[-1], "shape": _shape(results[-1])},
    }
    files.append(write_json(out / f"{stem}.json", payload))
    for f in files:
        print(f"wrote {f}")
    failed = sum(not r["success"] for r in rows)
    if failed:
        print(f"warning: {failed} of {len(rows)} equilibria did not converge (see 'status' and 'message').")
        return 1
    return 0


def _field_source(args):
    """``(source, origin)`` of ``--source`` / ``--currents-A`` or the robot file's ``field_source`` (None, None
    without one), with the flags a source excludes refused."""
    from .sources import source_from_args

    robot = None
    if getattr(args, "robot", None) is not None and args.source is None:
        from magsoft_env.cases.robots import load_robot

        robot = load_robot(args.robot)  # as robot_preset reads it: the same message for a bad robot
    source, origin = source_from_args(args, robot)
    if source is None:
        return None, None
    given = "--source" if origin == "--source" else f"--robot {args.robot} (its field_source)"
    if args.critical:
        raise ValueError(f"--critical takes a uniform field (the 3D rod); {given} solves the planar cantilever in a "
                         "field source.")
    if args.field_mT is not None and len(args.field_mT) == 3:
        raise ValueError(f"{given} solves the planar cantilever: --field-mT (a uniform field added to the source) "
                         "takes two numbers, BX BZ, in mT.")
    return source, origin


def _shape(result, n: int = 101) -> dict:
    s, x, z, theta = result.sample(n)
    return {"s_m": s, "x_m": x, "z_m": z, "theta_rad": theta}

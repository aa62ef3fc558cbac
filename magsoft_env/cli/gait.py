"""``magsoft gait``: run a crawling gait (a paper Fig. 5 robot, or a robot file) on the floor and report its speed."""

from __future__ import annotations

import argparse
import dataclasses
import inspect
import math
import sys
from pathlib import Path

from ..rods import DEFAULT_ROD, rod_names
from .output import dumps_json, out_file, write_json
from .solve import add_planar_only_flags, refuse_3d
from .sources import add_source_flags, source_description, source_from_args, source_label


def add_rod_option_flag(p) -> None:
    """``--rod-option KEY=VALUE`` (repeatable): a :class:`~magsoft_env.sim.RodOptions` keyword for the rod."""
    p.add_argument("--rod-option", action="append", default=[], metavar="KEY=VALUE",
                   help="a RodOptions setting for the rod, winning over the robot's (contact and solver settings, "
                        "e.g. solver_iterations=20, noslip_iterations=0, cone=pyramidal, contact_geom=sphere): trade "
                        "accuracy for speed knowingly; repeatable")


def rod_options(args) -> dict:
    """The ``--rod-option KEY=VALUE`` flags as keywords: values read as Python literals (numbers, tuples, True), or
    as text."""
    import ast

    out = {}
    for item in args.rod_option:
        key, sep, text = item.partition("=")
        if not sep or not key.strip().isidentifier():
            raise ValueError(f"--rod-option must be KEY=VALUE (a RodOptions keyword), got {item!r}.")
        try:
            value = ast.literal_eval(text.strip())
        except (ValueError, SyntaxError):
            value = text.strip()
        out[key.strip()] = value
    return out


def add_parser(subparsers) -> argparse.ArgumentParser:
    from magsoft_env.cases.gaits import list_gaits

    p = subparsers.add_parser(
        "gait",
        help="run a crawling gait (--preset paper-5a/5b/5c or --robot FILE) and print displacement and speed",
        description=(
            "Simulate an open-loop crawling gait (a robot of the paper's Fig. 5, or your own robot file with a drive) "
            "on a floor (MuJoCo rod) and print the centre-of-mass displacement (mm) and speed (mm/s, signed along "
            "+x), the direction, and the paper's value. The speed is measured over whole field periods after the "
            "first one (start-up transient). A robot whose body turns past vertical (end over end) is reported as a "
            "tumble, without a crawl speed. A run shorter than that warm-up plus one period gets a warning (its "
            "speed is not over whole periods). --out writes the result as JSON."
        ),
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--preset", choices=list(list_gaits()), help="built-in gait name")
    src.add_argument("--robot", type=Path, metavar="PATH",
                     help="robot file (.yml, .yaml, .json; Robot.save, magsoft design) with a drive block")
    p.add_argument("--reverse", action="store_true", help="invert B_x (paper Fig. 5c: reverses the direction)")
    p.add_argument("--seconds", type=float, default=4.0, help="simulated time in s (default 4)")
    p.add_argument("--timestep-ms", type=float, default=None,
                   help="simulation step in ms (default: the robot's own, 0.1 / 0.025 / 0.2 ms for paper-5a / 5b / 5c, "
                        "0.2 ms for a robot file that states none)")
    p.add_argument("--fidelity", choices=["fast", "fine", "converged"], default=None,
                   help="named numerics instead of --segments/--timestep-ms: fast (20 segments, 0.2 ms), fine (80, "
                        "0.1 ms), converged (80, 0.025 ms); errors in docs/convergence.md")
    p.add_argument("--segments", type=int, default=None,
                   help="rod segments (default: the robot's own, 80 / 80 / 20 for paper-5a / 5b / 5c, 20 for a robot "
                        "file that states none)")
    p.add_argument("--waveform", choices=["sine", "square"], default=None,
                   help="drive shape (default: the preset's, a sine); square = switched at the sine's zero "
                        "crossings (docs/envs.md, 'The drive waveform')")
    p.add_argument("--coil-ms", type=float, default=0.0,
                   help="coil time constant of the square drive in ms (default 0: an ideal square)")
    p.add_argument("--field-scale", type=float, default=1.0,
                   help="multiply the preset's field amplitudes by this factor (default 1)")
    p.add_argument("--face-down", action="store_true",
                   help="paper-5a, paper-5b: the other face on the floor (beta -> -beta; the paper gives no face)")
    p.add_argument("--friction", type=float, default=None,
                   help="floor friction coefficient (default: the preset's, 0.5; docs/envs.md, 'Tacky friction')")
    p.add_argument("--rod", choices=rod_names(), default=DEFAULT_ROD,
                   help="planar: the hinge chain in the x-z plane (default); cable: the 3D flexcomp strip on the floor "
                        "(its edges' boxes on the floor, twist free; without --segments/--timestep-ms/--fidelity at "
                        "least 30 segments and a step of at most 6 ms / segments; 5-8x the chain's wall time at the "
                        "same numerics; docs/sim.md)")
    add_rod_option_flag(p)
    add_y_drive_flags(p)
    add_rotate_flags(p)
    add_source_flags(p, what="its field and gradient act on every piece besides the drive's uniform field (run_gait("
                              "source=...))")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.add_argument("--out", type=Path, default=None, metavar="PATH",
                   help="also write the result as JSON to this file (checked before the run, written atomically)")
    add_planar_only_flags(p)
    p.set_defaults(run=run)
    return p


#: What the help says of the y drive: how to make the field's horizontal part turn about z.
Y_DRIVE_HELP = ("B_x = A_x sin(2 pi f t + phase_x) is the drive's own; with AMP = A_x and phase_y = phase_x - 90 deg "
                "(paper-5c: --amplitude-y-mT 2 --phase-y-deg 0) its horizontal part (B_x, B_y) turns about +z, "
                "counter-clockwise seen from above, while the drive's B_z stays; a field rotating about z alone: "
                "--rotate-about z")


def add_y_drive_flags(p) -> None:
    """``--amplitude-y-mT`` and ``--phase-y-deg``: a third axis for the drive of the 3D rod (``magsoft gait``,
    ``magsoft video``)."""
    p.add_argument("--amplitude-y-mT", type=float, default=0.0, metavar="MT",
                   help="--rod cable: add B_y = AMP sin(2 pi f t + phase_y) to the drive (mT; default 0). "
                        + Y_DRIVE_HELP)
    p.add_argument("--phase-y-deg", type=float, default=0.0, metavar="DEG",
                   help="--rod cable: the phase of B_y (deg; default 0)")


def check_y_drive(args) -> None:
    """The y drive's flags: finite, at most 1000 mT (a rod that takes no y component refuses the drive when it
    starts, naming the rod that does)."""
    if not (math.isfinite(args.amplitude_y_mT) and abs(args.amplitude_y_mT) <= 1000):
        raise ValueError(f"--amplitude-y-mT must be finite and at most 1000 mT in size, got {args.amplitude_y_mT}.")
    if not math.isfinite(args.phase_y_deg):
        raise ValueError(f"--phase-y-deg must be finite, got {args.phase_y_deg}.")


def with_y_drive(preset, args):
    """``preset`` with ``B_y = amplitude_y sin(2 pi f t + phase_y)`` added to its drive (unchanged without one)."""
    if not args.amplitude_y_mT:
        return preset
    w = dataclasses.replace(preset.wave, amplitude_y=args.amplitude_y_mT * 1e-3,
                            phase_y=math.radians(args.phase_y_deg))
    return dataclasses.replace(preset, drive=w)


def add_rotate_flags(p) -> None:
    """``--rotate-about``, ``--rotation-mT`` and ``--frequency-hz``: a field turning about a world axis instead of the
    drive (``magsoft gait``, ``magsoft video``)."""
    p.add_argument("--rotate-about", choices=["x", "y", "z"], default=None,
                   help="replace the drive by a field of --rotation-mT turning right-handed about this world axis (z: "
                        "the strip lying on the floor turns in place; x: it turns into the y-z plane and tumbles along "
                        "y; y: end over end along x); x and z need --rod cable")
    p.add_argument("--rotation-mT", type=float, default=2.0, metavar="MT",
                   help="--rotate-about: the rotating field's magnitude (mT; default 2)")
    p.add_argument("--frequency-hz", type=float, default=None, metavar="HZ",
                   help="the drive's frequency (Hz; default: the robot's own)")


def rotate_drive_args(args) -> None:
    """Check ``--rotate-about``, ``--field-mT`` and ``--frequency-hz`` (ValueError naming the flag)."""
    if args.rotate_about is not None:
        if not (math.isfinite(args.rotation_mT) and 0 < args.rotation_mT <= 100):
            raise ValueError(f"--rotation-mT must lie in (0, 100] mT, got {args.rotation_mT}.")
        if (args.amplitude_y_mT or getattr(args, "waveform", None) not in (None, "sine")
                or getattr(args, "field_scale", 1.0) != 1.0):
            raise ValueError("--rotate-about replaces the drive: give it without --amplitude-y-mT, --waveform square "
                             "or --field-scale.")
    if args.frequency_hz is not None and not (math.isfinite(args.frequency_hz) and 0 < args.frequency_hz <= 100):
        raise ValueError(f"--frequency-hz must lie in (0, 100] Hz, got {args.frequency_hz}.")


def rotated_drive(args, preset):
    """``preset`` with the drive of ``--rotate-about`` / ``--frequency-hz`` (unchanged without them)."""
    from magsoft_env.spec.drive import Waveparams

    f = preset.wave.frequency if args.frequency_hz is None else args.frequency_hz
    if args.rotate_about is not None:
        return dataclasses.replace(preset, drive=Waveparams.rotating(args.rotation_mT * 1e-3, f, args.rotate_about))
    if args.frequency_hz is not None:
        return dataclasses.replace(preset, drive=dataclasses.replace(preset.wave, frequency=f))
    return preset


def _turned_over(name: str):
    from magsoft_env.cases.gaits import PAPER_5A_VEES, beam_5a, beam_5b

    return beam_5a(vees=PAPER_5A_VEES, face_down=True) if name == "paper-5a" else beam_5b(face_down=True)


def run(args) -> int:
    from magsoft_env.cases.gaits import gait_preset
    from magsoft_env.sim.gait import run_gait

    refuse_3d(args, "gait")
    if not (args.seconds > 0 and math.isfinite(args.seconds)):
        raise ValueError(f"--seconds must be > 0 (s) and finite, got {args.seconds}.")
    if args.fidelity is not None and (args.timestep_ms is not None or args.segments is not None):
        raise ValueError("give --fidelity or --segments/--timestep-ms, not both.")
    if args.timestep_ms is not None and not 0 < args.timestep_ms <= 10:
        raise ValueError(f"--timestep-ms must lie in (0, 10] ms, got {args.timestep_ms}.")
    if args.segments is not None and not 2 <= args.segments <= 1000:
        raise ValueError(f"--segments must be an integer in [2, 1000], got {args.segments}.")
    if not 0 < args.field_scale <= 10:
        raise ValueError(f"--field-scale must lie in (0, 10], got {args.field_scale}.")
    if not 0 <= args.coil_ms <= 1000:
        raise ValueError(f"--coil-ms must lie in [0, 1000] ms, got {args.coil_ms}.")
    if args.face_down and args.preset not in ("paper-5a", "paper-5b"):
        got = f"--preset {args.preset}" if args.preset else "--robot"
        raise ValueError(f"--face-down applies to --preset paper-5a and paper-5b (paper-5c is its own mirror image; "
                         f"turn a robot file's beam over in the file), got {got}.")
    if args.friction is not None and not 0 <= args.friction <= 10:
        raise ValueError(f"--friction must lie in [0, 10], got {args.friction}.")
    check_y_drive(args)
    rotate_drive_args(args)
    shape = args.waveform or "sine"
    if args.coil_ms and shape != "square":
        raise ValueError(f"--coil-ms applies to --waveform square only, got --coil-ms {args.coil_ms} with a {shape}.")
    if args.out is not None:
        args.out = out_file(args.out)
    source = args.preset if args.preset is not None else args.robot
    preset = gait_preset(source, reverse=args.reverse)  # a robot file: loaded and checked here, before the run
    w = preset.wave
    if shape != w.shape or args.coil_ms or args.field_scale != 1.0:
        k = args.field_scale
        w = dataclasses.replace(w, amplitude_x=w.amplitude_x * k, amplitude_z=w.amplitude_z * k, shape=shape,
                                coil_time=args.coil_ms * 1e-3)
        preset = dataclasses.replace(preset, drive=w)
    preset = with_y_drive(preset, args)
    preset = rotated_drive(args, preset)
    if args.friction is not None:
        preset = dataclasses.replace(preset, friction=args.friction)
    if args.face_down:
        preset = dataclasses.replace(preset, beam=_turned_over(args.preset))
    field_source, origin = source_from_args(args, preset)  # --source, else the robot file's field_source
    res = run_gait(preset, args.seconds, segments=args.segments, fidelity=args.fidelity,
                   timestep=None if args.timestep_ms is None else args.timestep_ms * 1e-3,
                   # a bar on a terminal only: logs and pipes stay clean
                   progress=sys.stderr.isatty(), rod=args.rod, rod_options=rod_options(args),
                   **({} if field_source is None else {"source": field_source}))
    out = res.to_dict()
    if field_source is not None:
        out["field_source"] = {"given": source_label(args, origin), "origin": origin,
                               "source": source_description(field_source)}
    out["paper_speed_mm_s"] = None if preset.paper_speed is None else preset.paper_speed * 1e3
    out["paper_direction"] = preset.paper_direction
    out["field_mT"] = {
        "amplitude_x": preset.wave.amplitude_x * 1e3, "amplitude_z": preset.wave.amplitude_z * 1e3,
        "frequency_Hz": preset.wave.frequency, "phase_x_deg": math.degrees(preset.wave.phase),
        "shape": preset.wave.shape, "coil_ms": preset.wave.coil_time * 1e3,
        "amplitude_y": preset.wave.amplitude_y * 1e3, "phase_y_deg": math.degrees(preset.wave.phase_y),
    }
    out["friction"] = preset.friction
    out["face_down"] = bool(args.face_down)
    out["fidelity"] = args.fidelity
    short = _short_run_warning(res, preset.wave.frequency)
    out["short_run"] = short is not None  # speed over less than one whole field period after the warm-up
    out["speed_window_periods"] = res.window * preset.wave.frequency
    out["warnings"] = [] if short is None else [short]
    if args.out is not None:
        write_json(args.out, out)
    if args.json:
        print(dumps_json(out))
        if short is not None:
            print(f"magsoft gait: warning: {short}", file=sys.stderr)
    else:
        print(f"{out['preset']}: {preset.description}")
        if preset.wave != gait_preset(source, reverse=args.reverse).wave:
            print(f"field replaced: {preset.wave.describe()}")
        if args.face_down or args.friction is not None:
            print(f"robot: {'face down' if args.face_down else 'face up'}, friction {preset.friction:g}")
        if field_source is not None:
            from .sources import markers_text

            where = markers_text(field_source)
            print(f"field source: {source_label(args, origin)}, added to the drive" + (f" ({where})" if where else ""))
        if res.flipped:  # the displacement of a tumble is not a crawl: no speed, and say so first
            print(f"TUMBLE: the robot flipped end over end (body orientation up to {out['max_orientation_deg']:.0f} "
                  f"deg, past vertical first at t = {res.flip_time:.2f} s); no crawl speed")
            print(f"displacement {out['displacement_mm']:+.3f} mm in {out['seconds']:.2f} s (tumbling, not crawling)")
        else:
            print(f"displacement {out['displacement_mm']:+.3f} mm in {out['seconds']:.2f} s; "
                  f"speed {out['speed_mm_s']:+.3f} mm/s (over {out['speed_window_s']:.2f} s after "
                  f"{out['warmup_s']:.2f} s warm-up), direction {out['direction']}")
        print(f"paper: {_paper_values(preset)}; max height {out['max_height_mm']:.2f} mm, "
              f"max link rotation {out['max_link_rotation_deg']:.0f} deg, body orientation up to "
              f"{out['max_orientation_deg']:.0f} deg ({out['locomotion']}); {out['wall_time_s']:.1f} s wall")
        if preset.paper_speed and not res.flipped:  # say so when the model's speed is not the paper's measured one
            ratio = abs(out["speed_mm_s"] / (preset.paper_speed * 1e3))
            if not 0.8 <= ratio <= 1.25:
                print(f"note: the simulated speed is {ratio:.2g} x the paper's measured "
                      f"{abs(preset.paper_speed) * 1e3:.2f} mm/s; the model does not reproduce the paper's speed "
                      "(docs/envs.md, 'Paper gaits: measured against the paper')")
        if res.out_of_plane:
            print(f"out of the x-z plane: sideways travel {out['displacement_y_mm']:+.3f} mm, heading "
                  f"{out['final_heading_deg']:+.2f} deg at the end (turned {out['turned_deg']:+.0f} deg on the floor), "
                  f"roll up to {out['max_roll_deg']:.1f} deg")
        given = (f"fidelity {args.fidelity}" if args.fidelity else "the robot's own"
                 if args.segments is None and args.timestep_ms is None else "as given")
        print(f"numerics: {res.segments} segments, {res.timestep * 1e3:g} ms ({given}; docs/convergence.md)")
        if short is not None:
            print(f"warning: {short}")
        if not res.success:
            print(f"UNSTABLE: {res.message}")
        if args.out is not None:
            print(f"wrote {args.out}")
    return 0 if res.success else 1


def _paper_values(preset) -> str:
    """The paper's direction and speed as the case data holds them (``paper_speed`` None: no speed to
    compare with; any figure the paper's text gives is quoted in the case's description)."""
    if preset.paper_speed is not None and preset.paper_direction == "reversible":
        return f"reversible, {preset.paper_speed * 1e3:.2f} mm/s either way"
    if preset.paper_speed is not None:
        return f"{preset.paper_direction}, {preset.paper_speed * 1e3:+.2f} mm/s"
    return f"{preset.paper_direction}, no speed to compare with in the case data (see the description)"


def _warmup_cycles() -> float:
    """The warm-up (field periods) :func:`magsoft_env.sim.gait.run_gait` uses by default, as called here."""
    from magsoft_env.sim.gait import run_gait

    return float(inspect.signature(run_gait).parameters["warmup_cycles"].default)


def _short_run_warning(res, frequency: float) -> str | None:
    """A warning when the run is shorter than the warm-up plus one field period (the speed is then
    measured over part of a period, so it includes the gait's oscillation); None otherwise."""
    if not frequency > 0:
        return None
    period = 1.0 / frequency
    need = (_warmup_cycles() + 1.0) * period
    if res.whole_periods and res.seconds >= need - 1e-9:
        return None
    window = res.window
    return (f"the run ({res.seconds:.3g} s) is shorter than the warm-up plus one field period "
            f"({need:.3g} s at {frequency:g} Hz): the speed is measured over {window:.3g} s, not over whole "
            f"periods; use --seconds {need:g} or more")

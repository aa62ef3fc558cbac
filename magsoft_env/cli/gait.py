"""``magsoft gait``: run one of the paper's crawling gaits (Fig. 5) on the floor and report its speed."""

from __future__ import annotations

import argparse
import dataclasses
import json


def add_parser(subparsers) -> argparse.ArgumentParser:
    from magsoft_env.cases.gaits import list_gaits

    p = subparsers.add_parser(
        "gait",
        help="run a paper crawling gait (paper-5a, paper-5b, paper-5c) and print displacement and speed",
        description=(
            "Simulate an open-loop crawling gait of the paper's Fig. 5 on a floor (MuJoCo rod) and print the "
            "centre-of-mass displacement (mm) and speed (mm/s, signed along +x), the direction, and the paper's "
            "value. Speed excludes the first field period (start-up transient)."
        ),
    )
    p.add_argument("--preset", required=True, choices=list(list_gaits()), help="gait name")
    p.add_argument("--reverse", action="store_true", help="invert B_x (paper Fig. 5c: reverses the direction)")
    p.add_argument("--seconds", type=float, default=4.0, help="simulated time in s (default 4)")
    p.add_argument("--timestep-ms", type=float, default=0.1, help="simulation step in ms (default 0.1, converged)")
    p.add_argument("--segments", type=int, default=None,
                   help="rod segments (default: the preset's, 40 for paper-5b and 20 for the others)")
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
    p.add_argument("--json", action="store_true", help="print one JSON object instead of text")
    p.set_defaults(run=run)
    return p


def _turned_over(name: str):
    from magsoft_env.cases.gaits import PAPER_5A_VEES, beam_5a, beam_5b

    return beam_5a(vees=PAPER_5A_VEES, face_down=True) if name == "paper-5a" else beam_5b(face_down=True)


def run(args) -> int:
    from magsoft_env.cases.gaits import gait_preset
    from magsoft_env.sim.gait import run_gait

    if not args.seconds > 0:
        raise ValueError(f"--seconds must be > 0 (s), got {args.seconds}.")
    if not 0 < args.timestep_ms <= 10:
        raise ValueError(f"--timestep-ms must lie in (0, 10] ms, got {args.timestep_ms}.")
    if args.segments is not None and not 2 <= args.segments <= 1000:
        raise ValueError(f"--segments must be an integer in [2, 1000], got {args.segments}.")
    if not 0 < args.field_scale <= 10:
        raise ValueError(f"--field-scale must lie in (0, 10], got {args.field_scale}.")
    if not 0 <= args.coil_ms <= 1000:
        raise ValueError(f"--coil-ms must lie in [0, 1000] ms, got {args.coil_ms}.")
    if args.face_down and args.preset not in ("paper-5a", "paper-5b"):
        raise ValueError(f"--face-down applies to paper-5a and paper-5b (paper-5c is its own mirror image), got "
                         f"--preset {args.preset}.")
    if args.friction is not None and not 0 <= args.friction <= 10:
        raise ValueError(f"--friction must lie in [0, 10], got {args.friction}.")
    shape = args.waveform or "sine"
    if args.coil_ms and shape != "square":
        raise ValueError(f"--coil-ms applies to --waveform square only, got --coil-ms {args.coil_ms} with a {shape}.")
    preset = gait_preset(args.preset, reverse=args.reverse)
    w = preset.wave
    if shape != w.shape or args.coil_ms or args.field_scale != 1.0:
        k = args.field_scale
        w = dataclasses.replace(w, amplitude_x=w.amplitude_x * k, amplitude_z=w.amplitude_z * k, shape=shape,
                                coil_time=args.coil_ms * 1e-3)
        preset = dataclasses.replace(preset, wave=w)
    if args.friction is not None:
        preset = dataclasses.replace(preset, friction=args.friction)
    if args.face_down:
        preset = dataclasses.replace(preset, beam=_turned_over(args.preset))
    res = run_gait(preset, args.seconds, segments=args.segments, timestep=args.timestep_ms * 1e-3)
    out = res.to_dict()
    out["paper_speed_mm_s"] = None if preset.paper_speed is None else preset.paper_speed * 1e3
    out["paper_direction"] = preset.paper_direction
    out["field_mT"] = {
        "amplitude_x": preset.wave.amplitude_x * 1e3, "amplitude_z": preset.wave.amplitude_z * 1e3,
        "frequency_Hz": preset.wave.frequency, "phase_x_deg": preset.wave.phase * 180.0 / 3.141592653589793,
        "shape": preset.wave.shape, "coil_ms": preset.wave.coil_time * 1e3,
    }
    out["friction"] = preset.friction
    out["face_down"] = bool(args.face_down)
    out["segments"] = preset.segments if args.segments is None else args.segments
    out["timestep_ms"] = args.timestep_ms
    if args.json:
        print(json.dumps(out))
    else:
        paper = "no speed given" if preset.paper_speed is None else f"{preset.paper_speed * 1e3:+.2f} mm/s"
        print(f"{out['preset']}: {preset.description}")
        if preset.wave != gait_preset(args.preset, reverse=args.reverse).wave:
            print(f"field replaced: {preset.wave.describe()}")
        if args.face_down or args.friction is not None:
            print(f"robot: {'face down' if args.face_down else 'face up'}, friction {preset.friction:g}")
        print(f"displacement {out['displacement_mm']:+.3f} mm in {out['seconds']:.2f} s; "
              f"speed {out['speed_mm_s']:+.3f} mm/s (after {out['warmup_s']:.2f} s warm-up), "
              f"direction {out['direction']}")
        print(f"paper: {preset.paper_direction}, {paper}; max height {out['max_height_mm']:.2f} mm, "
              f"max link rotation {out['max_link_rotation_deg']:.0f} deg; {out['wall_time_s']:.1f} s wall")
        if not res.success:
            print(f"UNSTABLE: {res.message}")
    return 0 if res.success else 1

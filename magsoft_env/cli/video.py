"""``magsoft video``: render a gait, a trained policy or an environment headless to MP4 or GIF.

What the frames show, the flags and their defaults: docs/rendering.md. The OpenGL backend is chosen
before mujoco is imported: ``MUJOCO_GL`` if set, else EGL, else OSMesa (each probed); when neither
starts the error names the Debian packages to install.
"""

from __future__ import annotations

import argparse
import difflib
import math
import sys
from pathlib import Path

from ..rods import DEFAULT_ROD, rod_names
from .gait import (
    add_rod_option_flag,
    add_rotate_flags,
    add_y_drive_flags,
    check_y_drive,
    rod_options,
    rotate_drive_args,
    rotated_drive,
    with_y_drive,
)
from .output import dumps_json, out_file
from .sources import add_source_flags, source_description, source_from_args, source_label


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "video",
        help="render a gait (--preset, --robot), or an environment with a policy (--env, --policy), to MP4/GIF",
        description=(
            "Render headless (MUJOCO_GL=egl or osmesa) with an orthographic side camera: mm grid and scale bar, "
            "the field dial with its value, the centre-of-mass path and the start line, and in the floor scene a zoom "
            "inset of the rod's end over a 0.1 mm ruler (--no-zoom leaves it out). --preset NAME (or --robot "
            "FILE) renders a gait on the floor; --env ID renders a Gymnasium environment driven by a "
            "Stable-Baselines3 model (--policy model.zip) or, without one, by the robot's open-loop gait "
            "(--robot FILE: that robot in the environment). --panel adds plots of x(t) and B(t) beside the frames. "
            "--rod cable renders the gait of the 3D strip on the floor (in perspective; --view top from above; "
            "--view perspective shows the planar rod in 3D too), with a three-axis drive from --amplitude-y-mT and "
            "--phase-y-deg, or a field turning about an axis "
            "(--rotate-about z: the strip turns in place), as in magsoft gait."
        ),
    )
    src = p.add_mutually_exclusive_group()
    src.add_argument("--preset", help="gait preset (paper-5a, paper-5b, paper-5c)")
    src.add_argument("--env", help="environment id, e.g. MagSoftCrawl-v1")
    p.add_argument("--robot", default=None,
                   help="robot file (.yml, .yaml, .json) or built-in name: rendered like --preset, or with --env the "
                        "environment's robot")
    p.add_argument("--policy", type=Path, default=None, help="SB3 model .zip for --env (algorithm read from run)")
    p.add_argument("--reverse", action="store_true", help="invert B_x of the gait")
    p.add_argument("--scene", default="floor", choices=["floor", "channel", "obstacle"], help="scene for --preset")
    p.add_argument("--seconds", type=float, default=4.0, help="simulated seconds (default 4)")
    p.add_argument("--fps", type=float, default=25.0, help="frames per simulated second (default 25)")
    p.add_argument("--width", type=int, default=960, help="side view, pixels (default 960)")
    p.add_argument("--height", type=int, default=540, help="pixels (default 540)")
    p.add_argument("--panel", action="store_true",
                   help="add a panel of x(t) and B(t) to the right (the frame grows by 0.9 x --height)")
    p.add_argument("--no-zoom", action="store_true",
                   help="leave out the zoom inset of the rod's end over a 0.1 mm ruler (default: on in the floor scene "
                        "of a gait, so that a 1-2 mm crawl shows)")
    p.add_argument("--timestep-ms", type=float, default=None,
                   help="simulation step for --preset, ms (default: the robot's own, as magsoft gait)")
    p.add_argument("--rod", choices=rod_names(), default=None,
                   help="the rod: planar = the hinge chain, in its side view (the default); cable = the 3D flexcomp "
                        "strip on the floor, seen in perspective or from above (--view), its field (B_x, B_y, B_z) as "
                        "an arrow over the robot (docs/rendering.md, 'The 3D strip'). With --env: the environment's "
                        "rod")
    p.add_argument("--view", choices=["side", "perspective", "top"], default=None,
                   help="the camera: side (the planar rod's default: orthographic, x right, z up), perspective (the "
                        "3D strip's default; a camera above and behind the robot, looking down at 40 deg) or top "
                        "(orthographic, straight down, x right, y up); any rod in perspective or top")
    add_rod_option_flag(p)
    add_y_drive_flags(p)
    add_rotate_flags(p)
    add_source_flags(p, what="added to the gait's drive (as magsoft gait --source); the frames draw its magnets in "
                              "view and the field at the robot's centre (an arrow labelled in mT)")
    p.add_argument("--out", type=Path, required=True, help="output file, .mp4 or .gif")
    p.set_defaults(run=run)
    return p


#: The simulator's step limit (``magsoft_env.sim.health.MAX_STEPS``), not imported: that imports mujoco,
#: which must wait until the GL backend is chosen.
_MAX_STEPS = 10_000_000
#: Frames are held in memory until the file is written: at most this many bytes of RGB frames.
_MAX_FRAME_BYTES = 4 * 2**30
#: Frames per simulated second of an --env video, for the memory estimate (the crawl envs' render rate).
_ENV_FPS = 50


def _check_env_id(env_id: str) -> None:
    """``env_id`` must be one of the package's registered environments; the message suggests the closest."""
    from magsoft_env.envs import ENV_SPECS

    if env_id in ENV_SPECS:
        return
    hint = difflib.get_close_matches(str(env_id), list(ENV_SPECS), n=1, cutoff=0.5)
    extra = f" Did you mean {hint[0]!r}?" if hint else ""
    raise ValueError(f"--env must be a registered magsoft environment id ({', '.join(ENV_SPECS)}), got "
                     f"{env_id!r}.{extra}")


def _panel_width(height: int) -> int:
    """Width (pixels) of the --panel beside a frame of ``height`` (:class:`~magsoft_env.render.frames.TimePanel`)."""
    return 2 * int(round(0.45 * height))


def run(args) -> int:
    from magsoft_env.render.video import VIDEO_SUFFIXES

    # every check before any work (and before the GL backend is chosen, which starts subprocesses)
    if args.preset is None and args.env is None and args.robot is None:
        raise ValueError("one of the arguments --preset --env is required (or --robot FILE alone, for its gait).")
    if args.preset is not None and args.robot is not None:
        raise ValueError("--preset and --robot both name the robot; give one (--robot takes built-in names too).")
    gait = args.env is None  # --preset or --robot alone: an open-loop gait
    args.out = out_file(args.out, suffixes=tuple(VIDEO_SUFFIXES))
    if not (args.seconds > 0 and math.isfinite(args.seconds)):
        raise ValueError(f"--seconds must be > 0 (s) and finite, got {args.seconds}.")
    if not (args.fps > 0 and math.isfinite(args.fps)):
        raise ValueError(f"--fps must be > 0 and finite, got {args.fps}.")
    for name in ("width", "height"):
        v = getattr(args, name)
        if not 16 <= v <= 4096:
            raise ValueError(f"--{name} must be an integer in [16, 4096] pixels, got {v}.")
    if args.timestep_ms is not None and not 0 < args.timestep_ms <= 10:
        raise ValueError(f"--timestep-ms must lie in (0, 10] ms, got {args.timestep_ms}.")
    if args.policy is not None and args.env is None:
        raise ValueError("--policy needs --env (the environment the policy was trained on).")
    if args.view is not None and not gait:
        raise ValueError("--view chooses the camera of a gait (--preset or --robot); an --env renders its own view.")
    check_y_drive(args)
    rotate_drive_args(args)
    if not gait and (args.rotate_about is not None or args.frequency_hz is not None or args.amplitude_y_mT):
        raise ValueError("--amplitude-y-mT, --rotate-about and --frequency-hz change a gait's drive (--preset or "
                         "--robot); an --env is driven by its policy.")
    robot = None
    if args.robot is not None:
        from magsoft_env.cases.robots import resolve_robot

        robot = resolve_robot(args.robot, name="--robot")  # a missing or invalid file: ValueError naming it
    if gait:
        from magsoft_env.cases.gaits import gait_preset

        # an unknown name: the closest one suggested; a robot without a drive: refused
        preset = gait_preset(robot if robot is not None else args.preset, reverse=args.reverse)
        preset = rotated_drive(args, with_y_drive(preset, args))
        field_source, origin = source_from_args(args, preset)  # --source, else the robot file's field_source
        step_ms = args.timestep_ms if args.timestep_ms is not None else preset.timestep * 1e3
        if args.seconds / (step_ms * 1e-3) > _MAX_STEPS:
            raise ValueError(f"--seconds / --timestep-ms = {args.seconds:g} s / {step_ms:g} ms is more than "
                             f"{_MAX_STEPS:.0e} simulation steps; use fewer seconds or a larger timestep.")
    else:
        if args.source is not None or args.currents_A is not None:
            raise ValueError("--source adds a field source to a gait (--preset or --robot); an --env builds its own "
                             "field.")
        _check_env_id(args.env)
        if args.policy is not None and not args.policy.is_file():
            raise ValueError(f"--policy must be an existing model .zip, got {str(args.policy)!r}.")
    frames = (args.seconds * (args.fps if gait else _ENV_FPS) + 1)
    width = args.width + (_panel_width(args.height) if args.panel else 0)
    if frames * width * args.height * 3 > _MAX_FRAME_BYTES:
        raise ValueError(f"the video would hold about {frames:.3g} frames of {width} x {args.height} pixels "
                         f"({frames * width * args.height * 3 / 2**30:.3g} GiB) in memory, more than "
                         f"{_MAX_FRAME_BYTES / 2**30:g} GiB; use fewer --seconds, a lower --fps or a smaller frame.")
    # choose the GL backend before anything imports mujoco
    from magsoft_env.gl import RenderBackendError, select_gl_backend

    try:
        backend = select_gl_backend()
    except RenderBackendError as err:
        print(f"magsoft video: {err}")
        return 1
    from magsoft_env.render.video import render_gait, render_policy

    if gait:
        _, summary = render_gait(preset, args.seconds, args.out, fps=args.fps, width=args.width, height=args.height,
                                 timestep=None if args.timestep_ms is None else args.timestep_ms * 1e-3,
                                 scene=args.scene, panel=args.panel, zoom=False if args.no_zoom else None,
                                 rod=args.rod or DEFAULT_ROD, view=args.view, progress=sys.stderr.isatty(),
                                 rod_options=rod_options(args),
                                 **({} if field_source is None else {"source": field_source}))
        if field_source is not None:
            summary["field_source"] = {"given": source_label(args, origin), "origin": origin,
                                       "source": source_description(field_source)}
    else:
        policy, env_kwargs = None, {}
        if args.policy is not None:
            from magsoft_env.rl import load_policy

            # refused (ValueError, exit 2) when the run recorded another env or the spaces differ
            policy = load_policy(args.policy, env=args.env)
            env_kwargs = dict(policy.env_kwargs or {})  # the run's environment arguments (field limit, ...)
        if robot is not None:
            env_kwargs["robot"] = robot
        if args.rod is not None:
            env_kwargs["rod"] = args.rod
        _, summary = render_policy(args.env, policy, args.seconds, args.out, env_kwargs=env_kwargs, width=args.width,
                                   height=args.height, panel=args.panel, progress=sys.stderr.isatty())
    summary["gl_backend"] = backend
    print(dumps_json(summary))
    return 0

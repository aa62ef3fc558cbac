"""``magsoft video``: render a gait, a trained policy or an environment headless to MP4 or GIF.

The OpenGL backend is chosen before mujoco is imported: ``MUJOCO_GL`` if set, else EGL, else
OSMesa (each probed); when neither starts the error names the Debian packages to install.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "video",
        help="render a gait (--preset), or an environment with a policy (--env, --policy), to MP4/GIF",
        description=(
            "Render headless (MUJOCO_GL=egl or osmesa) with a side camera, a mm grid and the field arrow. "
            "--preset NAME renders a paper gait on the floor; --env ID renders a Gymnasium environment driven by "
            "a Stable-Baselines3 model (--policy model.zip) or, without one, by the robot's open-loop gait."
        ),
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--preset", help="gait preset (paper-5a, paper-5b, paper-5c)")
    src.add_argument("--env", help="environment id, e.g. MagSoftCrawl-v0")
    p.add_argument("--policy", type=Path, default=None, help="SB3 model .zip for --env (algorithm read from run)")
    p.add_argument("--reverse", action="store_true", help="invert B_x of the gait")
    p.add_argument("--scene", default="floor", choices=["floor", "channel", "obstacle"], help="scene for --preset")
    p.add_argument("--seconds", type=float, default=4.0, help="simulated seconds (default 4)")
    p.add_argument("--fps", type=float, default=25.0, help="frames per simulated second (default 25)")
    p.add_argument("--width", type=int, default=480, help="pixels (default 480)")
    p.add_argument("--height", type=int, default=270, help="pixels (default 270)")
    p.add_argument("--timestep-ms", type=float, default=0.1, help="simulation step for --preset, ms (default 0.1)")
    p.add_argument("--out", type=Path, required=True, help="output file, .mp4 or .gif")
    p.set_defaults(run=run)
    return p


def run(args) -> int:
    # choose the GL backend before anything imports mujoco
    from magsoft_env.gl import RenderBackendError, select_gl_backend
    from magsoft_env.render.video import VIDEO_SUFFIXES

    if args.out.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"--out must end in one of {list(VIDEO_SUFFIXES)}, got {str(args.out)!r}.")
    if not args.seconds > 0:
        raise ValueError(f"--seconds must be > 0 (s), got {args.seconds}.")
    if not args.fps > 0:
        raise ValueError(f"--fps must be > 0, got {args.fps}.")
    for name in ("width", "height"):
        v = getattr(args, name)
        if not 16 <= v <= 4096:
            raise ValueError(f"--{name} must be an integer in [16, 4096] pixels, got {v}.")
    if args.policy is not None and args.env is None:
        raise ValueError("--policy needs --env (the environment the policy was trained on).")
    try:
        backend = select_gl_backend()
    except RenderBackendError as err:
        print(f"magsoft video: {err}")
        return 1
    from magsoft_env.render.video import render_gait, render_policy

    if args.preset is not None:
        from magsoft_env.cases.gaits import gait_preset

        preset = gait_preset(args.preset, reverse=args.reverse)
        _, summary = render_gait(preset, args.seconds, args.out, fps=args.fps, width=args.width, height=args.height,
                                 timestep=args.timestep_ms * 1e-3, scene=args.scene)
    else:
        policy, env_kwargs = None, {}
        if args.policy is not None:
            from magsoft_env.rl import load_policy

            if not args.policy.exists():
                raise ValueError(f"--policy must be an existing model .zip, got {str(args.policy)!r}.")
            policy = load_policy(args.policy)
            cfg = args.policy.parent / "config.yml"
            if cfg.exists():  # the run's environment arguments (field limit, crawl mode, ...)
                import yaml

                env_kwargs = dict(yaml.safe_load(cfg.read_text()).get("env_kwargs") or {})
        env_kwargs.update(width=args.width, height=args.height)
        _, summary = render_policy(args.env, policy, args.seconds, args.out, env_kwargs=env_kwargs)
    summary["gl_backend"] = backend
    print(json.dumps(summary))
    return 0

"""Record a video (MP4 or GIF) of a trained policy, headless (MUJOCO_GL=egl, else osmesa).

    python train/record.py runs/<run-id> --out crawl_policy.mp4 [--seconds 4]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run", type=Path, help="run folder written by train/train.py")
    p.add_argument("--out", type=Path, required=True, help=".mp4 or .gif")
    p.add_argument("--seconds", type=float, default=4.0)
    p.add_argument("--seed", type=int, default=0)
    args = p.parse_args(argv)
    # the GL backend must be chosen before mujoco is imported
    from magsoft_env.gl import RenderBackendError, select_gl_backend

    try:
        select_gl_backend()
    except RenderBackendError as err:
        print(f"record.py: {err}", file=sys.stderr)
        return 1
    import yaml

    from magsoft_env.render.video import render_policy
    from magsoft_env.rl import load_policy

    if not (args.run / "model.zip").exists():
        print(f"record.py: error: {args.run} has no model.zip (is it a run folder?)", file=sys.stderr)
        return 2
    cfg = yaml.safe_load((args.run / "config.yml").read_text())
    policy = load_policy(args.run / "model.zip", algo=cfg["algo"])
    _, summary = render_policy(cfg["env_id"], policy, args.seconds, args.out, seed=args.seed,
                               env_kwargs=cfg["env_kwargs"])
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())

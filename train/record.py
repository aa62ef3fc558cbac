"""Record a video (MP4 or GIF) of a trained policy with the project's overlays, headless (MUJOCO_GL=egl, else osmesa).

    python train/record.py RUN --out crawl_policy.mp4 [--seconds 4] [--best]

RUN: a run folder of train/train.py, an rl-zoo3 log folder or a model .zip in one; the env id and env
arguments are the run's. (rl-zoo3's own ``python -m rl_zoo3.record_video`` films the plain env.)
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run", type=Path, help="run folder (train/train.py or rl-zoo3 log folder) or model .zip")
    p.add_argument("--out", type=Path, required=True, help=".mp4 or .gif")
    p.add_argument("--seconds", type=float, default=4.0)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--best", action="store_true", help="the best evaluated model (best_model.zip), not the final")
    args = p.parse_args(argv)
    # the GL backend must be chosen before mujoco is imported
    from magsoft_env.gl import RenderBackendError, select_gl_backend

    try:
        select_gl_backend()
    except RenderBackendError as err:
        print(f"record.py: {err}", file=sys.stderr)
        return 1
    from magsoft_env.render.video import render_policy
    from magsoft_env.rl import find_run, load_policy

    try:
        rec = find_run(args.run)
        model = args.run if args.run.is_file() else rec.model(best=args.best)
        policy = load_policy(model, algo=rec.algo, env=rec.env_id)
    except ValueError as err:
        print(f"record.py: error: {err}", file=sys.stderr)
        return 2
    _, summary = render_policy(rec.env_id, policy, args.seconds, args.out, seed=args.seed, env_kwargs=rec.env_kwargs)
    print(json.dumps(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())

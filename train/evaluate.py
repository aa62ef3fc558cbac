"""Evaluate a trained run against the open-loop paper gaits under the same limits, with its learning curve.

    python train/evaluate.py RUN [--episodes 3] [--best] [--env-kwarg sim_dt=1e-4 --tag dt1e-4]

RUN: a run folder of train/train.py (runs/<run-id>), an rl-zoo3 log folder (logs/ppo/<env>_1, from
``python -m rl_zoo3.train ... -f logs``) or a model .zip in one. The env id and env arguments are the
run's (its args.yml / config.yml). Writes evaluation[_<tag>].json (policy and open-loop speeds in mm/s
along +x, returns, the learning curve of rl-zoo's evaluation returns) and learning_curve[_<tag>].png
into the run folder (--out to choose) and prints the summary.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run", type=Path, help="run folder (train/train.py or rl-zoo3 log folder) or model .zip")
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--best", action="store_true", help="the best evaluated model (best_model.zip), not the final")
    p.add_argument("--env-kwarg", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override environment arguments, e.g. --env-kwarg sim_dt=1e-4 (SI units)")
    p.add_argument("--tag", default=None, help="writes evaluation_<tag>.json and learning_curve_<tag>.png")
    p.add_argument("--out", type=Path, default=None, help="folder for the outputs (default: the run folder)")
    args = p.parse_args(argv)
    from magsoft_env.rl import check_env_kwargs, find_run, parse_override, summarize_run

    try:
        if args.episodes < 1:
            raise ValueError(f"--episodes must be >= 1, got {args.episodes}.")
        rec = find_run(args.run)
        overrides = {}
        for item in args.env_kwarg:
            if "=" not in item:
                raise ValueError(f"--env-kwarg expects KEY=VALUE, got {item!r}.")
            k, v = item.split("=", 1)
            overrides[k] = parse_override(v)
        check_env_kwargs(rec.env_id, {**rec.env_kwargs, **overrides}, build=True)
        out = args.out or (args.run if args.run.is_dir() else rec.log_dir)
        out.mkdir(parents=True, exist_ok=True)
        res = summarize_run(rec, out, episodes=args.episodes, seed=args.seed, env_overrides=overrides,
                            best=args.best, model=args.run if args.run.is_file() else None, tag=args.tag)
    except ValueError as err:
        print(f"evaluate.py: error: {err}", file=sys.stderr)
        return 2
    print(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

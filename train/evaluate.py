"""Evaluate a trained run against the open-loop paper gaits in the same environment.

    python train/evaluate.py runs/<run-id> [--episodes 3]

Prints speeds (mm/s along +x) and returns as JSON and writes runs/<run-id>/evaluation_<tag>.json.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("run", type=Path, help="run folder written by train/train.py")
    p.add_argument("--episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--env-kwarg", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override environment arguments, e.g. --env-kwarg sim_dt=1e-4 (SI units)")
    p.add_argument("--tag", default="rerun", help="writes evaluation_<tag>.json")
    args = p.parse_args(argv)
    if not (args.run / "model.zip").exists():
        print(f"evaluate.py: error: {args.run} has no model.zip (is it a run folder?)", file=sys.stderr)
        return 2
    from magsoft_env.rl import evaluate_run, parse_override

    overrides = {}
    for item in args.env_kwarg:
        if "=" not in item:
            print(f"evaluate.py: error: --env-kwarg expects KEY=VALUE, got {item!r}.", file=sys.stderr)
            return 2
        k, v = item.split("=", 1)
        overrides[k] = parse_override(v)
    res = evaluate_run(args.run, episodes=args.episodes, seed=args.seed, env_overrides=overrides)
    (args.run / f"evaluation_{args.tag}.json").write_text(json.dumps(res, indent=2))
    print(json.dumps(res, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

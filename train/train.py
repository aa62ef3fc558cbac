"""Train a Stable-Baselines3 agent (PPO or SAC) on a magsoft_env environment.

    python train/train.py --env MagSoftCrawl-v0 --algo ppo [--timesteps N] [--seed 0]

Writes runs/<run-id>/: config.yml (resolved), model.zip, vecnormalize.pkl, monitor/,
learning_curve.png and evaluation.json (the policy against the open-loop paper gaits in the same
environment, same field limits).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent



def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", required=True, help="environment id, e.g. MagSoftCrawl-v0")
    p.add_argument("--algo", default="ppo", choices=["ppo", "sac"])
    p.add_argument("--hyperparams", type=Path, default=HERE / "hyperparams.yml")
    p.add_argument("--timesteps", type=int, default=None, help="override n_timesteps")
    p.add_argument("--n-envs", type=int, default=None, help="override n_envs")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--vec", default="dummy", choices=["dummy", "subproc"], help="vector env class")
    p.add_argument("--runs", type=Path, default=Path("runs"), help="folder of run folders (default runs/)")
    p.add_argument("--run-id", default=None, help="run folder name (default <env>_<algo>_s<seed>_<time>)")
    p.add_argument("--max-minutes", type=float, default=None, help="wall-time budget for learning (minutes)")
    p.add_argument("--no-eval", action="store_true", help="skip the evaluation against the open-loop gaits")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override algorithm arguments, e.g. --set learning_rate=1e-3 n_steps=256")
    p.add_argument("--env-kwarg", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override environment arguments (SI units), e.g. --env-kwarg segments=10")
    args = p.parse_args(argv)

    from magsoft_env.rl import load_hyperparams, parse_override, train

    try:
        cfg = load_hyperparams(args.hyperparams, args.env, args.algo)
        if args.timesteps is not None:
            if args.timesteps < 1:
                raise ValueError(f"--timesteps must be >= 1, got {args.timesteps}.")
            cfg["n_timesteps"] = args.timesteps
        if args.n_envs is not None:
            if args.n_envs < 1:
                raise ValueError(f"--n-envs must be >= 1, got {args.n_envs}.")
            cfg["n_envs"] = args.n_envs
        for item in args.set:
            if "=" not in item:
                raise ValueError(f"--set expects KEY=VALUE, got {item!r}.")
            k, v = item.split("=", 1)
            cfg["algo_kwargs"][k] = parse_override(v)
        for item in args.env_kwarg:
            if "=" not in item:
                raise ValueError(f"--env-kwarg expects KEY=VALUE, got {item!r}.")
            k, v = item.split("=", 1)
            cfg["env_kwargs"][k] = parse_override(v)
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2
    run_id = args.run_id or f"{args.env}_{args.algo}_s{args.seed}_{time.strftime('%Y%m%d-%H%M%S')}"
    if args.max_minutes is not None and not args.max_minutes > 0:
        print(f"train.py: error: --max-minutes must be > 0, got {args.max_minutes}.", file=sys.stderr)
        return 2
    summary = train(cfg, args.runs / run_id, seed=args.seed, vec=args.vec, evaluate=not args.no_eval,
                    max_seconds=None if args.max_minutes is None else 60.0 * args.max_minutes)
    summary["run_dir"] = str(args.runs / run_id)
    print(json.dumps(summary, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

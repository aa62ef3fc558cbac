"""Train a magsoft_env environment with rl-zoo3 into runs/<run-id>/ (never overwriting a run), then evaluate.

    python train/train.py --env MagSoftCrawl-v1 [--algo ppo] [--timesteps N] [--run-id ID] [--set k=v] [--env-kwarg k=v]
    python train/train.py --env ID --optimize [--storage URL --study-name NAME] [--n-trials N | --max-total-trials N]
    python train/train.py --fail-stale-trials MINUTES --storage URL --study-name NAME

``--optimize`` searches hyperparameters instead (rl-zoo3's ``-optimize``, Optuna; magsoft_env.rl.tune): workers
started with the same ``--storage`` (a database URL, or a journal file ``*.log``) and ``--study-name`` share one
study and its ``--max-total-trials`` budget; the env's kwargs score the trials too (``--eval-env-kwargs``).
``--seed`` is each trial's training seed; the sampler's seed is ``--seed`` in a study of one worker (no
``--storage``), else drawn for each worker (printed, kept in tune.json; ``--sampler-seed`` sets it).
``--fail-stale-trials`` marks FAIL the trials a killed worker left RUNNING, prints how many, and exits
(docs/training.md, "Tuning on a shared study").

The same as ``python -m rl_zoo3.train --algo ALGO --env ID --gym-packages magsoft_env -conf
train/hyperparams.yml`` (printed, and kept in zoo_command.txt), plus: the run folder is refused if it
exists, ``--set`` / ``--env-kwarg`` keys are checked against the algorithm's and the env's constructors
(the closest name suggested) before any work, and the trained policy is evaluated against the open-loop
paper gaits under the same limits (train/evaluate.py); with ``--vec threads`` (the default) the envs step
on threads (magsoft_env.rl.ThreadedVecEnv: rl-zoo's DummyVecEnv results in less time); ``--vec warp
[--warp-device cuda:0]`` steps the ``n_envs`` robots as one MuJoCo Warp batch (docs/gpu.md, "Training at scale"). Writes
runs/<run-id>/: hyperparams.yml (resolved, rl-zoo's format), zoo_command.txt, train.json, rl-zoo's log
folder <algo>/<env>_1/ (models, evaluations.npz, monitor, config.yml, args.yml, vecnormalize.pkl),
evaluation.json, learning_curve.png.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: The hyperparameter file of each algorithm (rl-zoo3 takes one per algorithm).
CONF = {"ppo": HERE / "hyperparams.yml", "sac": HERE / "hyperparams_sac.yml"}


def _key_values(items, option: str) -> dict:
    from magsoft_env.rl import parse_override

    out = {}
    for item in items:
        if "=" not in item:
            raise ValueError(f"{option} expects KEY=VALUE, got {item!r}.")
        key, value = item.split("=", 1)
        out[key] = parse_override(value)
    return out


def _fail_stale(args) -> int:
    """--fail-stale-trials: one line saying how many trials were marked FAIL (magsoft_env.rl.fail_stale_trials)."""
    if not (args.storage and args.study_name):
        print("train.py: error: --fail-stale-trials needs --storage and --study-name.", file=sys.stderr)
        return 2
    from magsoft_env.rl import fail_stale_trials

    try:
        if not args.fail_stale_trials >= 0:
            raise ValueError(f"--fail-stale-trials must be a number of minutes >= 0, got {args.fail_stale_trials}.")
        failed = fail_stale_trials(args.storage, args.study_name, 60.0 * args.fail_stale_trials)
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2
    numbers = f" (number{'s' if len(failed) > 1 else ''} {', '.join(map(str, failed))})" if failed else ""
    print(f"study {args.study_name!r}: {len(failed)} trial{'' if len(failed) == 1 else 's'} RUNNING for "
          f"{args.fail_stale_trials:g} min or more marked FAIL{numbers}")
    return 0


def main(argv=None) -> int:
    from magsoft_env.rl.training import VEC_CHOICES

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--env", default=None, help="environment id, e.g. MagSoftCrawl-v1 (required, except with "
                   "--fail-stale-trials)")
    p.add_argument("--algo", default="ppo", choices=sorted(CONF))
    p.add_argument("--hyperparams", type=Path, default=None,
                   help="rl-zoo hyperparameter file (default: train/hyperparams.yml for ppo, hyperparams_sac.yml)")
    p.add_argument("--timesteps", type=int, default=None, help="override n_timesteps")
    p.add_argument("--n-envs", type=int, default=None, help="override n_envs")
    p.add_argument("--seed", type=int, default=0, help="training seed (of each trial with --optimize; default 0)")
    p.add_argument("--vec", default="threads", choices=list(VEC_CHOICES),
                   help="vector env: threads (default; rl-zoo's DummyVecEnv with the envs stepped on threads, the same "
                        "results in less time), dummy or subproc (rl-zoo's), warp (the n_envs robots as one MuJoCo "
                        "Warp batch, MagSoftCrawl-v1 and MagSoftCrawlWaveform-v1; docs/gpu.md)")
    p.add_argument("--warp-device", default=None,
                   help="Warp device of --vec warp (cpu, cuda:0; default: Warp's default, a GPU where there is one)")
    p.add_argument("--device", default="cpu", help="torch device of the policy (rl-zoo's --device; default cpu)")
    p.add_argument("--runs", type=Path, default=Path("runs"), help="folder of run folders (default runs/)")
    p.add_argument("--run-id", default=None, help="run folder name (default <env>_<algo>_s<seed>_<time>); "
                   "refused if runs/<run-id> exists")
    p.add_argument("--continue-from", type=Path, default=None, metavar="RUN",
                   help="continue training the final model of RUN (a run folder or model .zip) into the new run")
    p.add_argument("--max-minutes", type=float, default=None, help="wall-time budget for learning (minutes)")
    p.add_argument("--eval-freq", type=int, default=10000,
                   help="rl-zoo evaluation callback every N env steps (keeps best_model.zip); <= 0: none")
    p.add_argument("--eval-episodes", type=int, default=2, help="episodes per evaluation (callback and final)")
    p.add_argument("--save-freq", type=int, default=-1, help="checkpoint every N env steps; <= 0: none")
    p.add_argument("--tensorboard", action="store_true", help="TensorBoard logs in runs/<run-id>/tensorboard/")
    p.add_argument("--progress", action="store_true", help="a progress bar (besides the log tables)")
    p.add_argument("--no-eval", action="store_true", help="skip the evaluation against the open-loop gaits")
    p.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override hyperparameters, e.g. --set learning_rate=1e-3 n_steps=256")
    p.add_argument("--env-kwarg", nargs="*", default=[], metavar="KEY=VALUE",
                   help="override environment arguments (SI units), e.g. --env-kwarg segments=10")
    tune = p.add_argument_group("hyperparameter search (rl-zoo3 -optimize, Optuna)")
    tune.add_argument("--optimize", action="store_true", help="search hyperparameters instead of training one run")
    tune.add_argument("--storage", default=None,
                      help="the study's storage, shared by workers: sqlite:///study.db, postgresql://..., or a "
                           "journal file study.log")
    tune.add_argument("--study-name", default=None, help="the study's name (the same for every worker)")
    tune.add_argument("--n-trials", type=int, default=None, help="trials of this worker")
    tune.add_argument("--max-total-trials", type=int, default=None,
                      help="trials of the study, all workers together (running ones count)")
    tune.add_argument("--n-startup-trials", type=int, default=None, help="random trials before the sampler's own")
    tune.add_argument("--n-evaluations", type=int, default=None, help="evaluations per trial (for pruning)")
    tune.add_argument("--sampler", default="tpe", choices=["random", "tpe", "skopt"], help="Optuna sampler")
    tune.add_argument("--sampler-seed", type=int, default=None,
                      help="seed of the Optuna sampler (default: --seed without --storage; with --storage, one "
                           "drawn for this worker, printed and kept in tune.json)")
    tune.add_argument("--pruner", default="median", choices=["halving", "median", "none"], help="Optuna pruner")
    tune.add_argument("--fail-stale-trials", type=float, default=None, metavar="MINUTES",
                      help="mark FAIL the study's trials RUNNING for longer than MINUTES (a killed worker's), and exit")
    args = p.parse_args(argv)
    if args.fail_stale_trials is not None:
        return _fail_stale(args)
    if args.env is None:
        print("train.py: error: --env is required (e.g. --env MagSoftCrawl-v1), except with --fail-stale-trials.",
              file=sys.stderr)
        return 2
    searching = [f for f in ("storage", "study_name", "n_trials", "max_total_trials", "n_startup_trials",
                             "n_evaluations", "sampler_seed") if getattr(args, f) is not None]
    if searching and not args.optimize:
        print(f"train.py: error: --{searching[0].replace('_', '-')} goes with --optimize.", file=sys.stderr)
        return 2

    run_id = args.run_id or f"{args.env}_{args.algo}_s{args.seed}_{time.strftime('%Y%m%d-%H%M%S')}"
    run_dir = args.runs / run_id
    if run_dir.exists():  # before any work
        print(f"train.py: error: run folder {str(run_dir)!r} exists already; a run is never overwritten: "
              "choose another --run-id (or --continue-from it into a new one).", file=sys.stderr)
        return 2
    from magsoft_env.rl import check_env_kwargs, check_hyperparams, find_run, load_hyperparams
    from magsoft_env.rl.training import check_vec

    try:
        for name in ("timesteps", "n_envs", "eval_episodes"):
            value = getattr(args, name)
            if value is not None and value < 1:
                raise ValueError(f"--{name.replace('_', '-')} must be >= 1, got {value}.")
        if args.max_minutes is not None and not args.max_minutes > 0:
            raise ValueError(f"--max-minutes must be > 0, got {args.max_minutes}.")
        block = load_hyperparams(args.hyperparams or CONF[args.algo], args.env, args.algo)
        block.update(_key_values(args.set, "--set"))
        if args.timesteps is not None:
            block["n_timesteps"] = args.timesteps
        if args.n_envs is not None:
            block["n_envs"] = args.n_envs
        block["env_kwargs"] = {**(block.get("env_kwargs") or {}), **_key_values(args.env_kwarg, "--env-kwarg")}
        check_hyperparams(block, args.env, args.algo)
        check_vec(args.vec, args.env)
        check_env_kwargs(args.env, block["env_kwargs"], build=True)  # the env's own checks on the values
        agent = None
        if args.continue_from is not None:
            old = find_run(args.continue_from)
            if old.env_id != args.env:
                raise ValueError(f"--continue-from {str(args.continue_from)!r} was trained on {old.env_id}, "
                                 f"not {args.env}.")
            agent = old.model() if args.continue_from.is_dir() else args.continue_from
    except ValueError as err:
        print(f"train.py: error: {err}", file=sys.stderr)
        return 2
    if args.optimize:
        from magsoft_env.rl import tune as tune_run

        try:
            out = tune_run(block, args.env, run_dir, algo=args.algo, seed=args.seed, storage=args.storage,
                           study_name=args.study_name, n_trials=args.n_trials, max_total_trials=args.max_total_trials,
                           n_startup_trials=args.n_startup_trials, n_evaluations=args.n_evaluations,
                           sampler=args.sampler, pruner=args.pruner, eval_episodes=args.eval_episodes, vec=args.vec,
                           sampler_seed=args.sampler_seed)
        except ValueError as err:
            print(f"train.py: error: {err}", file=sys.stderr)
            return 2
        print(json.dumps({"run_dir": str(run_dir), **out}, indent=2, default=str))
        return 0
    from magsoft_env.rl import summarize_run, train

    # checked above: errors from here on are not usage errors and keep their traceback
    rec = train(block, args.env, run_dir, algo=args.algo, seed=args.seed, eval_freq=args.eval_freq,
                eval_episodes=args.eval_episodes, save_freq=args.save_freq, tensorboard=args.tensorboard,
                progress=args.progress, trained_agent=agent, vec=args.vec, warp_device=args.warp_device,
                device=args.device,
                max_seconds=None if args.max_minutes is None else 60.0 * args.max_minutes)
    if args.no_eval:
        print(json.dumps({"run_dir": str(run_dir), "log_dir": str(rec.log_dir)}, indent=2))
        return 0
    summary = summarize_run(rec, run_dir, episodes=args.eval_episodes, seed=args.seed + 1000)
    summary["run_dir"] = str(run_dir)
    print(json.dumps({k: v for k, v in summary.items() if k != "curve"}, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

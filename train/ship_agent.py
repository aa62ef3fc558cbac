"""Ship a trained run as a package agent: ``assets/agents/<env-id>/<name>/`` (magsoft_env.rl.agents).

    python train/ship_agent.py runs/<run-id> --name ppo_seed0 [--best] [--machine "2-core x86 cloud VM, shared"]

Copies the run's final model (``--best``: its best evaluated one) as ``<env-id>.zip``, rl-zoo3's ``<env-id>/``
folder (``config.yml``, ``args.yml``, ``vecnormalize.pkl``), ``evaluations.npz`` and the training monitor
(``monitor.csv``), and writes ``agent.yml``: env id and version, env arguments (recorded and registered),
algorithm, seed, the resolved hyperparameters, training steps, wall time, the machine, package versions and the
run's evaluation (``evaluation.json`` of train/evaluate.py, when there). Refuses to overwrite an agent.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def _version(name: str) -> str | None:
    try:
        return version(name)
    except PackageNotFoundError:
        return None


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", help="a train/train.py run folder")
    ap.add_argument("--name", required=True, help="the agent's name, e.g. ppo_seed0")
    ap.add_argument("--best", action="store_true", help="ship the best evaluated model, not the final one")
    ap.add_argument("--machine", default="", help="words on the machine it trained on (cores, shared or not)")
    ap.add_argument("--agents", default=str(ROOT / "assets" / "agents"), help="the agents' folder")
    args = ap.parse_args(argv)

    import gymnasium as gym
    import yaml
    from stable_baselines3.common.save_util import load_from_zip_file

    import magsoft_env  # noqa: F401  (registers the ids)
    from magsoft_env.rl.runs import find_run

    run_dir = Path(args.run)
    rec = find_run(run_dir)
    model = rec.model(best=args.best)
    env_folder = rec.env_id.replace("/", "-")
    out = Path(args.agents) / rec.env_id / args.name
    if out.exists():
        print(f"ship_agent.py: error: {out} exists already; an agent is never overwritten.", file=sys.stderr)
        return 2
    (out / env_folder).mkdir(parents=True)
    shutil.copyfile(model, out / f"{env_folder}.zip")
    for name in ("config.yml", "args.yml", "vecnormalize.pkl"):
        if (rec.params_dir / name).is_file():
            shutil.copyfile(rec.params_dir / name, out / env_folder / name)
    if (rec.log_dir / "evaluations.npz").is_file():
        shutil.copyfile(rec.log_dir / "evaluations.npz", out / "evaluations.npz")
    monitors = sorted(rec.log_dir.glob("*.monitor.csv"))
    if monitors:
        shutil.copyfile(monitors[0], out / "monitor.csv")

    data, _, _ = load_from_zip_file(model, device="cpu", load_data=True)
    train = json.loads((run_dir / "train.json").read_text()) if (run_dir / "train.json").is_file() else {}
    evaluation = json.loads((run_dir / "evaluation.json").read_text()) if (run_dir / "evaluation.json").is_file() \
        else {}
    spec = gym.spec(rec.env_id)
    hyper = {k: v for k, v in rec.hyperparams.items()}
    info = {
        "name": args.name,
        "env_id": rec.env_id,
        "env_version": spec.version,
        "env_kwargs": dict(rec.env_kwargs),
        "registered_kwargs": dict(spec.kwargs),
        "algo": rec.algo,
        "seed": rec.args.get("seed"),
        "model": "best" if args.best else "final",
        "model_file": f"{env_folder}.zip",
        "model_timesteps": int(data.get("num_timesteps", 0)),
        "n_timesteps": hyper.get("n_timesteps"),
        "hyperparameters": json.loads(json.dumps(hyper, default=str)),
        "train_wall_s": round(float(train.get("wall_s", float("nan"))), 1),
        "train_steps_per_s": round(int(data.get("num_timesteps", 0)) / float(train["wall_s"]), 1)
        if train.get("wall_s") else None,
        "zoo_command": train.get("zoo_command"),
        "machine": {"description": args.machine, "cpu_count": os.cpu_count(), "machine": platform.machine(),
                    "system": platform.system(), "python": platform.python_version()},
        "versions": {n: _version(n) for n in ("magsoft_env", "stable_baselines3", "rl_zoo3", "torch", "mujoco",
                                              "gymnasium")},
        "evaluation": {k: evaluation[k] for k in ("policy", "open_loop") if k in evaluation},
    }
    if evaluation:
        info["evaluation_by"] = ("train/evaluate.py at the end of training (train.py --eval-episodes episodes, default "
                                 "2, seeds from 1000); the benchmark's rows: magsoftbench-v1.json")
    if evaluation and evaluation.get("model", "").endswith("best_model.zip") != args.best:
        info["evaluation_note"] = "evaluation.json is of the run's other model (final / best)"
    (out / "agent.yml").write_text(yaml.safe_dump(info, sort_keys=False, width=120))
    size = sum(p.stat().st_size for p in out.rglob("*") if p.is_file())
    print(f"shipped {model} -> {out} ({size / 1024:.0f} kB)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Training runs through rl-zoo3 (``rl_zoo3.train``, run in this process) into a run folder that is never
overwritten, and what rl-zoo3 does not do: the evaluation of a run against the open-loop paper gaits under
the same limits, a learning curve of its evaluation returns, a result summary."""

from __future__ import annotations

import copy
import json
import math
import shlex
import sys
import time
from pathlib import Path

import numpy as np

from .evaluation import evaluate_open_loop, load_policy, run_episodes
from .hyperparams import check_hyperparams
from .runs import RunRecord, find_run

#: ``--gym-packages`` for rl-zoo3: importing it registers the ids.
GYM_PACKAGE = "magsoft_env"


def zoo_argv(env_id: str, conf, log_folder, *, algo: str = "ppo", seed: int = 0, eval_freq: int = 10000,
             eval_episodes: int = 2, save_freq: int = -1, tensorboard_log=None, progress: bool = False,
             trained_agent=None, vec: str = "dummy", num_threads: int = 1, device: str = "cpu",
             eval_env_kwargs: dict | None = None) -> list[str]:
    """The ``python -m rl_zoo3.train`` arguments for one run (the hyperparameters from ``conf``).

    ``eval_env_kwargs``: pass the block's ``env_kwargs`` here. rl-zoo3 2.9.2 builds its evaluation env
    with the command line's ``--env-kwargs`` only, not with the file's ``env_kwargs`` (``ExperimentManager``
    binds ``eval_env_kwargs`` before it reads the file), so without ``--eval-env-kwargs`` the evaluation
    callback would score the policy in the env's registered defaults.

    ``eval_freq`` and ``save_freq`` count environment steps over all envs (rl-zoo3 divides by ``n_envs``);
    negative: no evaluation callback / no checkpoints. ``num_threads=1``: a 64 x 64 MLP trains no slower on
    one torch thread, and the other cores stay with the simulation.
    """
    argv = ["--algo", algo, "--env", env_id, "--gym-packages", GYM_PACKAGE, "-conf", str(conf),
            "-f", str(log_folder), "--seed", str(int(seed)), "--eval-freq", str(int(eval_freq)),
            "--eval-episodes", str(int(eval_episodes)), "--save-freq", str(int(save_freq)), "--vec-env", vec,
            "--num-threads", str(int(num_threads)), "--device", device]
    if eval_env_kwargs:
        argv += ["--eval-env-kwargs", *(f"{k}:{v!r}" for k, v in eval_env_kwargs.items())]
    if tensorboard_log is not None:
        argv += ["-tb", str(tensorboard_log)]
    if progress:
        argv.append("--progress")
    if trained_agent is not None:
        argv += ["-i", str(trained_agent)]
    return argv


#: ``vec`` choices of :func:`train`: rl-zoo3's two, and ``"threads"`` (:class:`~magsoft_env.rl.vec.ThreadedVecEnv`).
VEC_CHOICES = ("threads", "dummy", "subproc")


def run_zoo(argv: list[str], *, vec_env_cls=None) -> None:
    """Run ``python -m rl_zoo3.train *argv`` in this process (rl-zoo3 parses ``sys.argv``); ``vec_env_cls``:
    the SB3 ``VecEnv`` class rl-zoo3 builds its envs with, for this run (its ``ExperimentManager``'s
    ``default_vec_env_cls`` hook, which overrides ``--vec-env``)."""
    from rl_zoo3.exp_manager import ExperimentManager
    from rl_zoo3.train import train as zoo_train

    saved, saved_cls = sys.argv, ExperimentManager.default_vec_env_cls
    sys.argv = ["rl_zoo3.train", *argv]
    if vec_env_cls is not None:
        ExperimentManager.default_vec_env_cls = vec_env_cls
    try:
        zoo_train()
    finally:
        sys.argv = saved
        ExperimentManager.default_vec_env_cls = saved_cls


def train(block: dict, env_id: str, run_dir, *, algo: str = "ppo", seed: int = 0, eval_freq: int = 10000,
          eval_episodes: int = 2, save_freq: int = -1, tensorboard: bool = False, progress: bool = False,
          trained_agent=None, vec: str = "threads", num_threads: int = 1,
          max_seconds: float | None = None) -> RunRecord:
    """Train one run with rl-zoo3 into the new folder ``run_dir``.

    Writes ``run_dir/hyperparams.yml`` (``{env_id: block}``, rl-zoo's format: the resolved settings),
    ``run_dir/zoo_command.txt`` (the equivalent ``python -m rl_zoo3.train`` command), then rl-zoo3's log
    folder ``run_dir/<algo>/<env_id>_1/`` (final and best model, ``evaluations.npz``, monitor files,
    ``<env_id>/config.yml``, ``args.yml``, ``vecnormalize.pkl``; ``run_dir/tensorboard/`` with
    ``tensorboard``) and ``run_dir/train.json`` (wall time).

    Parameters
    ----------
    block : dict
        One rl-zoo block (:func:`load_hyperparams`, overrides applied); checked first.
    run_dir : str or Path
        Must not exist: a run is never overwritten (ValueError).
    trained_agent : str or Path, optional
        A model ``.zip`` to continue training (rl-zoo3's ``-i``; its run's ``vecnormalize.pkl`` is loaded).
    max_seconds : float, optional
        Wall-time budget for learning (s): a :class:`magsoft_env.rl.callbacks.WallTimeLimit` entry in the
        block's ``callback`` list; the model is saved when it runs out.
    vec : {"threads", "dummy", "subproc"}
        The SB3 vector env of the run: ``"threads"`` (default), :class:`~magsoft_env.rl.vec.ThreadedVecEnv`,
        rl-zoo3's ``DummyVecEnv`` with the envs stepped on threads (the same results; zoo_command.txt then
        reads ``--vec-env dummy``, with a comment); ``"dummy"`` / ``"subproc"``: rl-zoo3's own.

    Returns
    -------
    RunRecord
    """
    import yaml

    run_dir = Path(run_dir)
    if run_dir.exists():
        raise ValueError(f"run folder {str(run_dir)!r} exists already; a run is never overwritten: choose "
                         "another --run-id (or --continue-from it into a new one).")
    block = copy.deepcopy(block)
    if max_seconds is not None:
        if not (isinstance(max_seconds, int | float) and max_seconds > 0):
            raise ValueError(f"max_seconds must be > 0 (s), got {max_seconds!r}.")
        callbacks = block.get("callback") or []
        callbacks = list(callbacks) if isinstance(callbacks, list) else [callbacks]
        limit = {"magsoft_env.rl.callbacks.WallTimeLimit": {"max_seconds": float(max_seconds)}}
        block["callback"] = [*callbacks, limit]
    check_hyperparams(block, env_id, algo)
    if vec not in VEC_CHOICES:
        raise ValueError(f"vec must be one of {', '.join(VEC_CHOICES)}, got {vec!r}.")
    if trained_agent is not None:
        trained = find_run(trained_agent)
        if trained.env_id != env_id:
            raise ValueError(f"the agent to continue was trained on {trained.env_id}, not {env_id}.")
    run_dir.mkdir(parents=True, exist_ok=False)
    conf = run_dir / "hyperparams.yml"
    header = f"# resolved hyperparameters of this run, rl-zoo3's format ({algo}); see zoo_command.txt\n"
    conf.write_text(header + yaml.safe_dump({env_id: block}, sort_keys=False, default_flow_style=None))
    argv = zoo_argv(env_id, conf, run_dir, algo=algo, seed=seed, eval_freq=eval_freq, eval_episodes=eval_episodes,
                    save_freq=save_freq, tensorboard_log=run_dir / "tensorboard" if tensorboard else None,
                    progress=progress, trained_agent=trained_agent, vec="dummy" if vec == "threads" else vec,
                    num_threads=num_threads, eval_env_kwargs=block.get("env_kwargs") or None)
    command = "python -m rl_zoo3.train " + shlex.join(argv)
    note = ("# stepped by magsoft_env.rl.ThreadedVecEnv (rl-zoo3's DummyVecEnv on threads, the same results; "
            "magsoft_env.rl.train(vec='threads'))\n") if vec == "threads" else ""
    (run_dir / "zoo_command.txt").write_text(note + command + "\n")
    print(f"train: {command}" + (" [envs on threads: ThreadedVecEnv]" if vec == "threads" else ""), flush=True)
    vec_env_cls = None
    if vec == "threads":
        from .vec import ThreadedVecEnv

        vec_env_cls = ThreadedVecEnv
    t0 = time.perf_counter()
    run_zoo(argv, vec_env_cls=vec_env_cls)
    wall = time.perf_counter() - t0
    rec = find_run(run_dir)
    (run_dir / "train.json").write_text(json.dumps(
        {"env_id": env_id, "algo": algo, "seed": int(seed), "n_timesteps": int(block["n_timesteps"]),
         "wall_s": wall, "log_dir": str(rec.log_dir), "zoo_command": command, "vec": vec}, indent=2))
    return rec


# ---------------------------------------------------------------------------- evaluation
def evaluate_run(run, *, episodes: int = 2, seed: int = 1000, env_overrides: dict | None = None,
                 best: bool = False, model=None) -> dict:
    """Evaluate a run's policy (deterministic) and the open-loop paper gaits in the run's env, with the run's
    env arguments updated by ``env_overrides`` (e.g. ``{"sim_dt": 1e-4}`` to check that a policy does not
    exploit the timestep): same robot, same field limits, same control and simulation steps.

    ``run``: a :class:`RunRecord` or anything :func:`find_run` takes. ``best``: the best evaluated model
    instead of the final one; ``model``: this model file of the run (e.g. a checkpoint) instead.

    Returns ``{"env_id", "algo", "model", "model_timesteps", "env_kwargs", "policy": {...},
    "open_loop": [{...}, ...], "policy_speed_mm_s", "best_open_loop_speed_mm_s"}``; speeds along +x in mm/s.
    """
    import gymnasium as gym

    rec = run if isinstance(run, RunRecord) else find_run(run)
    env_kwargs = {**rec.env_kwargs, **(env_overrides or {})}
    model = rec.model(best=best) if model is None else Path(model)
    policy = load_policy(model, algo=rec.algo, env=rec.env_id, env_kwargs=env_kwargs)
    env = gym.make(rec.env_id, **env_kwargs)
    res = run_episodes(env, lambda obs, _env: policy(obs), episodes=episodes, seed=seed, name=f"{rec.algo} policy")
    env.close()
    gaits = evaluate_open_loop(rec.env_id, env_kwargs, episodes=1, seed=seed)
    direction = int(env_kwargs.get("target_direction", 1))
    best_speed = max((g.speed * direction for g in gaits), default=math.nan) * direction
    return {"env_id": rec.env_id, "algo": rec.algo, "model": str(model),
            "model_timesteps": int(policy.model.num_timesteps), "env_kwargs": env_kwargs, "policy": res.to_dict(),
            "open_loop": [g.to_dict() for g in gaits],
            "policy_speed_mm_s": None if math.isnan(res.speed) else res.speed * 1e3,
            "best_open_loop_speed_mm_s": None if math.isnan(best_speed) else best_speed * 1e3}


def _monitor_episodes(log_dir: Path) -> list:
    """Training episodes ``(wall t (s), return, length)`` from rl-zoo's ``*.monitor.csv``, in time order."""
    rows = []
    for f in sorted(log_dir.glob("*.monitor.csv")):
        for ln in f.read_text().splitlines()[2:]:
            r, n, t = ln.split(",")[:3]
            rows.append((float(t), float(r), int(n)))
    return sorted(rows)


def learning_curve(run, png=None, *, reference: dict | None = None) -> dict:
    """The learning curve of a run: rl-zoo3's evaluation returns (``evaluations.npz``, deterministic policy,
    mean and spread over the evaluation episodes) against environment steps, over the training episodes'
    returns (monitor files, stochastic policy); ``reference`` = ``{label: return}`` as dashed lines (e.g.
    the open-loop gaits). Saved to ``png`` when given.

    Returns ``{"eval_timesteps", "eval_mean_return", "eval_std_return", "eval_mean_ep_length",
    "best_eval_return", "best_eval_timesteps", "train_episodes", "train_timesteps", "train_last_mean_return",
    "monitor_wall_s"}`` (lists of numbers; None where there is nothing).
    """
    rec = run if isinstance(run, RunRecord) else find_run(run)
    out = {"eval_timesteps": [], "eval_mean_return": [], "eval_std_return": [], "eval_mean_ep_length": [],
           "best_eval_return": None, "best_eval_timesteps": None}
    npz = rec.log_dir / "evaluations.npz"
    if npz.is_file():
        with np.load(npz) as data:
            steps, results, lengths = data["timesteps"], data["results"], data["ep_lengths"]
        out.update(eval_timesteps=[int(s) for s in steps], eval_mean_return=[float(r) for r in results.mean(axis=1)],
                   eval_std_return=[float(r) for r in results.std(axis=1)],
                   eval_mean_ep_length=[float(n) for n in lengths.mean(axis=1)])
        if len(steps):
            k = int(np.argmax(results.mean(axis=1)))
            out.update(best_eval_return=float(results[k].mean()), best_eval_timesteps=int(steps[k]))
    rows = _monitor_episodes(rec.log_dir)
    out.update(train_episodes=len(rows), train_timesteps=int(sum(r[2] for r in rows)),
               train_last_mean_return=float(np.mean([r[1] for r in rows[-10:]])) if rows else None,
               monitor_wall_s=rows[-1][0] if rows else None)
    if png is not None:
        _plot_curve(out, rows, Path(png), f"{rec.algo.upper()} on {rec.env_id}", reference or {})
    return out


def _plot_curve(curve: dict, rows: list, png: Path, title: str, reference: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8))
    if rows:
        ax.plot(np.cumsum([r[2] for r in rows]), [r[1] for r in rows], ".", color="0.6", alpha=0.4, ms=3,
                label="training episode (stochastic)")
    if curve["eval_timesteps"]:
        steps, mean, std = (np.asarray(curve[k]) for k in ("eval_timesteps", "eval_mean_return", "eval_std_return"))
        ax.fill_between(steps, mean - std, mean + std, color="C0", alpha=0.2)
        ax.plot(steps, mean, "o-", color="C0", ms=3, label="evaluation (deterministic), mean +- std")
    for k, (name, value) in enumerate(reference.items()):
        ax.axhline(value, color=f"C{k + 1}", ls="--", lw=1, label=f"{name}")
    if rows or curve["eval_timesteps"] or reference:
        ax.legend(fontsize=7)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)


def summarize_run(run, out_dir=None, *, episodes: int = 2, seed: int = 1000, env_overrides: dict | None = None,
                  best: bool = False, model=None, tag: str | None = None) -> dict:
    """This project's result summary of a run: :func:`evaluate_run` and :func:`learning_curve` (the
    open-loop gaits' and the evaluated policy's returns as references), written to
    ``out_dir/evaluation[_tag].json`` and ``out_dir/learning_curve[_tag].png`` (default ``out_dir``: the
    run's log folder). A ``train.json`` beside (train/train.py) adds the training wall time."""
    rec = run if isinstance(run, RunRecord) else find_run(run)
    out = Path(out_dir) if out_dir is not None else rec.log_dir
    suffix = f"_{tag}" if tag else ""
    res = evaluate_run(rec, episodes=episodes, seed=seed, env_overrides=env_overrides, best=best, model=model)
    ref = {f"{g['name']} (return)": g["return"] for g in res["open_loop"]}
    ref[f"{res['algo']} policy, {Path(res['model']).stem} (return)"] = res["policy"]["return"]
    curve = learning_curve(rec, out / f"learning_curve{suffix}.png", reference=ref)
    summary = {**res, "curve": curve, "log_dir": str(rec.log_dir)}
    trained = out / "train.json"
    if trained.is_file():
        t = json.loads(trained.read_text())
        rate = res["model_timesteps"] / t["wall_s"] if t["wall_s"] else None
        summary.update(train_wall_s=t["wall_s"], steps_per_s=rate)
    (out / f"evaluation{suffix}.json").write_text(json.dumps(summary, indent=2))
    return summary


__all__ = ["GYM_PACKAGE", "evaluate_run", "learning_curve", "run_zoo", "summarize_run", "train", "zoo_argv"]

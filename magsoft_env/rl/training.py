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


#: ``vec`` choices of :func:`train`: rl-zoo3's two, ``"threads"`` (:class:`~magsoft_env.rl.vec.ThreadedVecEnv`) and
#: ``"warp"`` (the MuJoCo Warp batch, ``gym.make_vec(..., backend="warp")``: docs/gpu.md).
VEC_CHOICES = ("threads", "dummy", "subproc", "warp")
#: The ids ``vec="warp"`` trains (the Warp backend's; magsoft_env.envs.warp_vector.SUPPORTED_IDS, not imported here).
WARP_IDS = ("MagSoftCrawl-v1", "MagSoftCrawlWaveform-v1")


def warp_create_envs(original, device=None):
    """rl-zoo3's ``ExperimentManager.create_envs`` with its training envs as one MuJoCo Warp batch: ``n_envs``
    worlds of ``gym.make_vec(env_id, n_envs, backend="warp", device=device, **env_kwargs)`` in
    :class:`~magsoft_env.rl.vec.SB3VecAdapter`, ``VecMonitor`` (its monitor file in rl-zoo3's log folder, as
    ``0.monitor.csv``) and rl-zoo3's ``VecNormalize`` when the block asks for it; the evaluation env stays
    rl-zoo3's own (single C envs), in a ``VecMonitor`` too, so that SB3 can copy the normalization statistics
    between the two wrapper stacks (it walks them level by level). ``original``: the unpatched method."""

    def create_envs(manager, n_envs: int, eval_env: bool = False, no_log: bool = False):
        import os

        from stable_baselines3.common.vec_env import VecMonitor

        from .vec import make_sb3_vec_env

        if manager.env_wrapper is not None or manager.vec_env_wrapper is not None or manager.frame_stack:
            raise ValueError("vec='warp' takes no env_wrapper, vec_env_wrapper or frame_stack (the worlds are one "
                             "batch, not single envs to wrap); remove them from the block or use vec='threads'.")
        if eval_env:
            manager.vec_env_wrapper = VecMonitor
            try:
                return original(manager, n_envs, eval_env=eval_env, no_log=no_log)
            finally:
                manager.vec_env_wrapper = None
        log_dir = None if no_log else manager.save_path
        venv = make_sb3_vec_env(manager.env_name.gym_id, n_envs, seed=manager.seed, monitor=False, backend="warp",
                                device=device, **(manager.env_kwargs or {}))
        venv = VecMonitor(venv, None if log_dir is None else os.path.join(log_dir, "0"), **manager.monitor_kwargs)
        return manager._maybe_normalize(venv, eval_env)

    return create_envs


def seeded_sampler(original, sampler_seed: int):
    """rl-zoo3's ``ExperimentManager._create_sampler`` with the sampler seeded by ``sampler_seed`` instead of
    ``--seed``: rl-zoo3's own sampler (the same classes and settings), whose seed alone differs; ``--seed`` keeps
    seeding the trials' envs and the process's random generators. ``original``: the unpatched method."""

    def create_sampler(manager, sampler_method: str):
        training_seed = manager.seed
        manager.seed = sampler_seed
        try:
            return original(manager, sampler_method)
        finally:
            manager.seed = training_seed

    return create_sampler


def run_zoo(argv: list[str], *, vec_env_cls=None, warp_device=None, warp: bool = False,
            sampler_seed: int | None = None) -> None:
    """Run ``python -m rl_zoo3.train *argv`` in this process (rl-zoo3 parses ``sys.argv``); ``vec_env_cls``:
    the SB3 ``VecEnv`` class rl-zoo3 builds its envs with, for this run (its ``ExperimentManager``'s
    ``default_vec_env_cls`` hook, which overrides ``--vec-env``); ``warp``: the training envs as one MuJoCo Warp
    batch on ``warp_device`` (:func:`warp_create_envs`); ``sampler_seed``: the seed of ``-optimize``'s Optuna
    sampler (:func:`seeded_sampler`; None: rl-zoo3's, ``--seed``)."""
    from rl_zoo3.exp_manager import ExperimentManager
    from rl_zoo3.train import train as zoo_train

    saved, saved_cls, saved_create = sys.argv, ExperimentManager.default_vec_env_cls, ExperimentManager.create_envs
    saved_sampler = ExperimentManager._create_sampler
    sys.argv = ["rl_zoo3.train", *argv]
    if vec_env_cls is not None:
        ExperimentManager.default_vec_env_cls = vec_env_cls
    if warp:
        ExperimentManager.create_envs = warp_create_envs(saved_create, warp_device)
    if sampler_seed is not None:
        ExperimentManager._create_sampler = seeded_sampler(saved_sampler, sampler_seed)
    try:
        zoo_train()
    finally:
        sys.argv = saved
        ExperimentManager.default_vec_env_cls = saved_cls
        ExperimentManager.create_envs = saved_create
        ExperimentManager._create_sampler = saved_sampler


def check_vec(vec: str, env_id: str) -> None:
    """ValueError unless ``vec`` is one of :data:`VEC_CHOICES` that can run ``env_id`` here (``"warp"``: the
    Warp backend's ids, with the extra installed)."""
    if vec not in VEC_CHOICES:
        raise ValueError(f"vec must be one of {', '.join(VEC_CHOICES)}, got {vec!r}.")
    if vec == "warp":
        import importlib.util

        if env_id not in WARP_IDS:
            raise ValueError(f"vec='warp' trains {' and '.join(WARP_IDS)}, got {env_id!r}; use vec='threads'.")
        if any(importlib.util.find_spec(name) is None for name in ("warp", "mujoco_warp")):
            raise ValueError("vec='warp' needs the optional extra 'warp': pip install -e \".[warp]\" (docs/gpu.md).")


def train(block: dict, env_id: str, run_dir, *, algo: str = "ppo", seed: int = 0, eval_freq: int = 10000,
          eval_episodes: int = 2, save_freq: int = -1, tensorboard: bool = False, progress: bool = False,
          trained_agent=None, vec: str = "threads", num_threads: int = 1,
          max_seconds: float | None = None, warp_device=None, device: str = "cpu") -> RunRecord:
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
    vec : {"threads", "dummy", "subproc", "warp"}
        The SB3 vector env of the run: ``"threads"`` (default), :class:`~magsoft_env.rl.vec.ThreadedVecEnv`,
        rl-zoo3's ``DummyVecEnv`` with the envs stepped on threads (the same results; zoo_command.txt then
        reads ``--vec-env dummy``, with a comment); ``"dummy"`` / ``"subproc"``: rl-zoo3's own; ``"warp"``: the
        block's ``n_envs`` as MuJoCo Warp worlds (:func:`warp_create_envs`; ``MagSoftCrawl-v1`` and
        ``MagSoftCrawlWaveform-v1``, the optional extra ``warp``), evaluated in single C envs.
    warp_device : str, optional
        Warp device of ``vec="warp"`` (None: Warp's default, a GPU where there is one).
    device : str
        Torch device of the policy (rl-zoo3's ``--device``).

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
    check_vec(vec, env_id)
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
                    progress=progress, trained_agent=trained_agent,
                    vec="dummy" if vec in ("threads", "warp") else vec, num_threads=num_threads, device=device,
                    eval_env_kwargs=block.get("env_kwargs") or None)
    command = "python -m rl_zoo3.train " + shlex.join(argv)
    note = {"threads": "# stepped by magsoft_env.rl.ThreadedVecEnv (rl-zoo3's DummyVecEnv on threads, the same "
                       "results; magsoft_env.rl.train(vec='threads'))\n",
            "warp": f"# training envs: one MuJoCo Warp batch (gym.make_vec(..., backend='warp', "
                    f"device={warp_device!r}) in SB3VecAdapter and VecMonitor; magsoft_env.rl.train(vec='warp')); "
                    "evaluation in C\n"}.get(vec, "")
    (run_dir / "zoo_command.txt").write_text(note + command + "\n")
    tag = {"threads": " [envs on threads: ThreadedVecEnv]", "warp": " [training envs: MuJoCo Warp batch]"}.get(vec, "")
    print(f"train: {command}" + tag, flush=True)
    vec_env_cls = None
    if vec == "threads":
        from .vec import ThreadedVecEnv

        vec_env_cls = ThreadedVecEnv
    t0 = time.perf_counter()
    run_zoo(argv, vec_env_cls=vec_env_cls, warp=vec == "warp", warp_device=warp_device)
    wall = time.perf_counter() - t0
    rec = find_run(run_dir)
    (run_dir / "train.json").write_text(json.dumps(
        {"env_id": env_id, "algo": algo, "seed": int(seed), "n_timesteps": int(block["n_timesteps"]),
         "wall_s": wall, "log_dir": str(rec.log_dir), "zoo_command": command, "vec": vec,
         **({"warp_device": warp_device} if vec == "warp" else {})}, indent=2))
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


def optuna_storage(storage: str):
    """The Optuna storage rl-zoo3 makes of ``storage``: a ``.log`` path is a journal file (one machine, or a shared
    file system), anything else a database URL (``sqlite:///study.db``, ``postgresql://...``)."""
    import optuna

    if storage.endswith(".log"):
        return optuna.storages.JournalStorage(optuna.storages.journal.JournalFileBackend(storage))
    return storage


#: Optuna's samplers take seeds below 2**32 (numpy's ``RandomState``).
_SEED_LIMIT = 2**32


def draw_sampler_seed() -> int:
    """A sampler seed for one worker of a shared study, from the operating system's entropy (as rl-zoo3 draws
    its ``--seed`` when given none): workers started together, on one machine or many, with the same ``--seed``,
    then sample their own trials."""
    import secrets

    return secrets.randbelow(_SEED_LIMIT)


def tune(block: dict, env_id: str, run_dir, *, algo: str = "ppo", seed: int = 0, storage: str | None = None,
         study_name: str | None = None, n_trials: int | None = None, max_total_trials: int | None = None,
         n_startup_trials: int | None = None, n_evaluations: int | None = None, sampler: str = "tpe",
         pruner: str = "median", eval_episodes: int = 2, vec: str = "threads",
         sampler_seed: int | None = None) -> dict:
    """Search hyperparameters with rl-zoo3 (``-optimize``, Optuna) into the new folder ``run_dir``; several
    workers (processes, machines) given the same ``storage`` and ``study_name`` share one study.

    ``storage``: a database URL (``sqlite:///study.db`` on one machine, ``postgresql://...`` for a cluster) or a
    journal file ``*.log`` (one machine or a shared file system); None: a study in memory, this worker's alone.
    ``max_total_trials``: the study's budget, counted over all workers (complete, pruned and running trials);
    ``n_trials``: this worker's. The block's ``env_kwargs`` also go to rl-zoo3's evaluation env
    (``--eval-env-kwargs``), which is where the trials are scored. Writes ``run_dir/hyperparams.yml``,
    ``zoo_command.txt``, rl-zoo3's report (``<algo>/report_*.csv``) and ``tune.json``; returns the latter's
    content: the sampler's seed, the study's trials by state and its best value and parameters.

    Seeds: ``seed`` is the training seed of every trial (rl-zoo3's ``--seed``: the trials' envs and the
    process's random generators). ``sampler_seed`` seeds the Optuna sampler that draws the trials'
    hyperparameters; default: ``seed`` without ``storage`` (rl-zoo3's choice: the same seed, the same trials),
    else one drawn for this worker (:func:`draw_sampler_seed`), since workers of one study seeded alike draw the
    same hyperparameters. It is printed and kept in ``tune.json``; given again, the sampler draws as before.
    """
    import yaml

    run_dir = Path(run_dir)
    if run_dir.exists():
        raise ValueError(f"run folder {str(run_dir)!r} exists already; a run is never overwritten: choose "
                         "another --run-id.")
    if storage is not None and study_name is None:
        raise ValueError("a shared study needs a study name (--study-name) besides its storage.")
    for name, value in (("n_trials", n_trials), ("max_total_trials", max_total_trials),
                        ("n_startup_trials", n_startup_trials), ("n_evaluations", n_evaluations)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, int) or value < 1):
            raise ValueError(f"{name} must be an integer >= 1, got {value!r}.")
    if sampler_seed is not None and (isinstance(sampler_seed, bool) or not isinstance(sampler_seed, int)
                                     or not 0 <= sampler_seed < _SEED_LIMIT):
        raise ValueError(f"sampler_seed must be an integer in [0, 2**32), got {sampler_seed!r}.")
    check_hyperparams(block, env_id, algo)
    check_vec(vec, env_id)
    if vec == "warp":
        raise ValueError("vec='warp' trains one run (train); the hyperparameter search runs on the CPU batch "
                         "(vec='threads', 'dummy' or 'subproc').")
    if sampler_seed is None:
        sampler_seed, origin = (int(seed), "--seed") if storage is None else (draw_sampler_seed(), "drawn")
    else:
        origin = "given"
    run_dir.mkdir(parents=True, exist_ok=False)
    conf = run_dir / "hyperparams.yml"
    conf.write_text(f"# hyperparameters the search starts from, rl-zoo3's format ({algo}); see zoo_command.txt\n"
                    + yaml.safe_dump({env_id: block}, sort_keys=False, default_flow_style=None))
    argv = zoo_argv(env_id, conf, run_dir, algo=algo, seed=seed, eval_episodes=eval_episodes,
                    vec="dummy" if vec == "threads" else vec, eval_env_kwargs=block.get("env_kwargs") or None)
    argv += ["-optimize", "--sampler", sampler, "--pruner", pruner, "--no-optim-plots"]
    for flag, value in (("--storage", storage), ("--study-name", study_name), ("--n-trials", n_trials),
                        ("--max-total-trials", max_total_trials), ("--n-startup-trials", n_startup_trials),
                        ("--n-evaluations", n_evaluations)):
        if value is not None:
            argv += [flag, str(value)]
    command = "python -m rl_zoo3.train " + shlex.join(argv)
    note = "" if sampler_seed == int(seed) else (
        f"# the Optuna sampler seeded with {sampler_seed}, not --seed (magsoft_env.rl.tune(sampler_seed="
        f"{sampler_seed}); rl-zoo3 seeds it with --seed)\n")
    (run_dir / "zoo_command.txt").write_text(note + command + "\n")
    print(f"tune: {command}", flush=True)
    print(f"tune: sampler seed {sampler_seed} ({origin}; --sampler-seed {sampler_seed} draws the same), "
          f"training seed {int(seed)}", flush=True)
    vec_env_cls = None
    if vec == "threads":
        from .vec import ThreadedVecEnv

        vec_env_cls = ThreadedVecEnv
    if storage is not None:
        ensure_study(storage, study_name)
    t0 = time.perf_counter()
    note = None
    try:
        # rl-zoo3 seeds its sampler with --seed: hooked only where the sampler's seed is another
        run_zoo(argv, vec_env_cls=vec_env_cls, sampler_seed=None if sampler_seed == int(seed) else sampler_seed)
    except ImportError as exc:  # rl-zoo3 writes its report with pandas, after the search: the trials are stored
        if "pandas" not in str(exc):
            raise
        note = "rl-zoo3's CSV report needs pandas (not installed); the trials are listed here"
    out = {"env_id": env_id, "algo": algo, "seed": int(seed), "sampler": sampler, "sampler_seed": sampler_seed,
           "sampler_seed_from": origin, "storage": storage, "study_name": study_name,
           "wall_s": time.perf_counter() - t0, "zoo_command": command}
    if note:
        out["note"] = note
    if storage is not None:
        import optuna

        study = optuna.load_study(study_name=study_name, storage=optuna_storage(storage))
        trials = study.get_trials(deepcopy=False)
        out["trials"] = {st.name: sum(t.state == st for t in trials) for st in optuna.trial.TrialState}
        done = [t for t in trials if t.state == optuna.trial.TrialState.COMPLETE]
        if done:
            out["best_value"], out["best_params"] = study.best_value, study.best_params
        out["trial_list"] = [{"number": t.number, "state": t.state.name, "value": t.value, "params": t.params}
                             for t in trials]
    (run_dir / "tune.json").write_text(json.dumps(out, indent=2, default=str))
    return out


def ensure_study(storage: str, study_name: str, *, attempts: int = 8) -> None:
    """Create the study (maximize, as rl-zoo3 does) unless it exists. Workers started together on a new
    SQLite file race to create its tables ("table studies already exists"): the loser waits and tries again."""
    import random

    import optuna

    for k in range(attempts):
        try:
            optuna.create_study(storage=optuna_storage(storage), study_name=study_name, load_if_exists=True,
                                direction="maximize")
            return
        except Exception:  # noqa: BLE001  sqlalchemy's OperationalError, or a study half made by the other worker
            if k == attempts - 1:
                raise
            time.sleep(0.2 + random.random())


def _shown(storage: str) -> str:
    """``storage`` as it may be printed: a database URL's password hidden."""
    if storage.endswith(".log"):
        return repr(storage)
    try:
        from sqlalchemy.engine import make_url

        return repr(make_url(storage).render_as_string(hide_password=True))
    except Exception:  # noqa: BLE001  not a URL sqlalchemy reads: shown as given (no password to hide)
        return repr(storage)


def open_study(storage: str, study_name: str):
    """The existing study ``study_name`` of ``storage`` (a database URL or a journal file ``*.log``, as
    :func:`optuna_storage` reads it), or a ValueError saying why not: a journal or SQLite file that does not exist
    (nothing is created), a URL that cannot be opened, a study that is not there (the storage's studies listed,
    the closest name suggested)."""
    import optuna

    from .hyperparams import _suggest

    if not isinstance(storage, str) or not storage:
        raise ValueError(f"storage must be a database URL or a journal file *.log, got {storage!r}.")
    if storage.endswith(".log"):
        if not Path(storage).is_file():
            raise ValueError(f"journal file {storage!r} does not exist: give the --storage the workers were "
                             "given.")
    elif storage.startswith("sqlite:///"):
        path = storage[len("sqlite:///"):].split("?", 1)[0]
        if path and path != ":memory:" and not Path(path).is_file():
            raise ValueError(f"SQLite file {path!r} of {storage!r} does not exist: give the --storage the workers "
                             "were given (sqlite:///relative/path.db, sqlite:////absolute/path.db).")
    try:
        names = optuna.get_all_study_names(optuna_storage(storage))
    except Exception as exc:  # noqa: BLE001  sqlalchemy's URL and connection errors, a missing database driver
        raise ValueError(f"cannot open the study storage {_shown(storage)}: {type(exc).__name__}: {exc} "
                         "(a database URL such as sqlite:///study.db or postgresql://user:pass@host/db, or a "
                         "journal file study.log).") from exc
    if study_name not in names:
        held = f"its studies: {', '.join(map(repr, sorted(names)))}.{_suggest(study_name, names)}" if names \
            else "it holds none."
        raise ValueError(f"the storage {_shown(storage)} has no study {study_name!r}; {held}")
    return optuna.load_study(study_name=study_name, storage=optuna_storage(storage))


def fail_stale_trials(storage: str, study_name: str, older_than_s: float = 3600.0) -> list[int]:
    """Mark FAIL the trials of a shared study still RUNNING ``older_than_s`` seconds after they started: the
    trials of workers that were killed (rl-zoo3 gives Optuna its storage as a string, so no heartbeat can find
    them). A RUNNING trial counts against ``max_total_trials``; once failed, another worker runs one in its place.
    Returns their numbers. Give a time longer than any live trial takes. The study must exist
    (:func:`open_study`: a ValueError otherwise)."""
    import datetime

    import optuna

    if isinstance(older_than_s, bool) or not (isinstance(older_than_s, int | float) and older_than_s >= 0):
        raise ValueError(f"older_than_s must be a number of seconds >= 0, got {older_than_s!r}.")
    study = open_study(storage, study_name)
    now = datetime.datetime.now()  # Optuna's start times are naive local times too
    failed = []
    for t in study.get_trials(deepcopy=False, states=(optuna.trial.TrialState.RUNNING,)):
        if t.datetime_start is not None and (now - t.datetime_start).total_seconds() >= older_than_s:
            # a trial that finished meanwhile is left as it is
            if study.tell(t.number, state=optuna.trial.TrialState.FAIL, skip_if_finished=True).state \
                    == optuna.trial.TrialState.FAIL:
                failed.append(t.number)
    return failed


__all__ = ["GYM_PACKAGE", "draw_sampler_seed", "ensure_study", "evaluate_run", "fail_stale_trials", "learning_curve",
           "open_study", "optuna_storage", "run_zoo", "seeded_sampler", "summarize_run", "train", "tune", "zoo_argv"]

"""Training runs behind ``train/train.py`` (Stable-Baselines3, imported only when used), learning
curves, and the evaluation of a finished run against the open-loop gaits."""

from __future__ import annotations

import copy
import json
import math
import time
from pathlib import Path

import numpy as np

from .evaluation import algo_class, evaluate_open_loop, load_policy, run_episodes


def _learning_curve(monitor_dir: Path, png: Path, title: str, reference: dict | None = None) -> dict:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = []
    for f in sorted(monitor_dir.glob("*.monitor.csv")):
        lines = f.read_text().splitlines()[2:]
        for ln in lines:
            r, l, t = ln.split(",")[:3]
            rows.append((float(t), float(r), int(l)))
    rows.sort()
    fig, ax = plt.subplots(figsize=(6, 3.5))
    if rows:
        steps = np.cumsum([r[2] for r in rows])
        rets = np.array([r[1] for r in rows])
        ax.plot(steps, rets, ".", alpha=0.3, label="episode")
        k = max(1, len(rets) // 20)
        if len(rets) >= k:
            smooth = np.convolve(rets, np.ones(k) / k, mode="valid")
            ax.plot(steps[k - 1:], smooth, "-", label=f"mean of {k}")
    for k, (name, value) in enumerate((reference or {}).items()):
        ax.axhline(value, color=f"C{k + 2}", ls="--", label=f"{name} (return)")
    if rows or reference:
        ax.legend(fontsize=8)
    ax.set_xlabel("environment steps")
    ax.set_ylabel("episode return")
    ax.set_title(title)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)
    final = float(np.mean([r[1] for r in rows[-10:]])) if rows else math.nan
    return {"episodes": len(rows), "final_mean_return": final}


def _wall_time_callback(max_seconds: float):
    from stable_baselines3.common.callbacks import BaseCallback

    class StopAfter(BaseCallback):
        """Stop learning after ``max_seconds`` of wall time (the run then saves what it has)."""

        def _on_training_start(self) -> None:
            self.t0 = time.perf_counter()

        def _on_step(self) -> bool:
            return time.perf_counter() - self.t0 < max_seconds

    return StopAfter()


def train(config: dict, out_dir, *, seed: int = 0, vec: str = "dummy", evaluate: bool = True,
          progress: bool = False, max_seconds: float | None = None) -> dict:
    """Train one run and write its outputs into ``out_dir``.

    Parameters
    ----------
    config : dict
        From :func:`load_hyperparams` (``n_timesteps`` etc. may be edited before).
    out_dir : str or Path
        Run folder: ``config.yml`` (resolved settings), ``model.zip``, ``vecnormalize.pkl``,
        ``monitor/``, ``learning_curve.png``, ``evaluation.json``.
    seed : int
    vec : {"dummy", "subproc"}
        Vector env class for the ``n_envs`` copies.
    evaluate : bool
        Evaluate the trained policy and the open-loop gaits (same env, same limits).
    max_seconds : float, optional
        Wall-time budget for learning (s); learning stops early (and says so in the summary)
        when it runs out.

    Returns
    -------
    dict
        The summary also written to ``evaluation.json``.
    """
    import yaml
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv, VecNormalize


    if vec not in ("dummy", "subproc"):
        raise ValueError(f"vec must be 'dummy' or 'subproc', got {vec!r}.")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg = copy.deepcopy(config)
    cfg.update(seed=int(seed), vec=vec)
    (out / "config.yml").write_text(yaml.safe_dump(cfg, sort_keys=False))
    mon = out / "monitor"
    mon.mkdir(exist_ok=True)
    # "module:id" makes worker processes import magsoft_env (which registers the ids) first
    venv = make_vec_env(f"magsoft_env:{cfg['env_id']}", n_envs=cfg["n_envs"], seed=seed, env_kwargs=cfg["env_kwargs"],
                        monitor_dir=str(mon), vec_env_cls=SubprocVecEnv if vec == "subproc" else DummyVecEnv)
    if cfg["normalize"]:
        venv = VecNormalize(venv, norm_obs=True, norm_reward=True, clip_obs=10.0)
    kwargs = dict(cfg["algo_kwargs"])
    policy = kwargs.pop("policy", "MlpPolicy")
    model = algo_class(cfg["algo"])(policy, venv, seed=seed, verbose=0, device="cpu", **kwargs)
    t0 = time.perf_counter()
    callback = None if max_seconds is None else _wall_time_callback(float(max_seconds))
    model.learn(total_timesteps=cfg["n_timesteps"], progress_bar=progress, callback=callback)
    train_s = time.perf_counter() - t0
    done_steps = int(model.num_timesteps)
    model.save(out / "model.zip")
    if cfg["normalize"]:
        venv.save(str(out / "vecnormalize.pkl"))
    venv.close()
    curve = _learning_curve(mon, out / "learning_curve.png", f"{cfg['algo'].upper()} on {cfg['env_id']}")
    summary = {"env_id": cfg["env_id"], "algo": cfg["algo"], "n_timesteps": cfg["n_timesteps"],
               "timesteps_done": done_steps, "stopped_by_wall_time": done_steps < cfg["n_timesteps"],
               "train_wall_s": train_s, "steps_per_s": done_steps / train_s, **curve}
    if evaluate:
        summary.update(evaluate_run(out, episodes=cfg["eval_episodes"], seed=seed + 1000))
        ref = {g["name"]: g["return"] for g in summary["open_loop"]}
        ref["trained policy, deterministic"] = summary["policy"]["return"]
        _learning_curve(mon, out / "learning_curve.png", f"{cfg['algo'].upper()} on {cfg['env_id']}", ref)
    (out / "evaluation.json").write_text(json.dumps(summary, indent=2))
    return summary


def evaluate_run(run_dir, *, episodes: int = 2, seed: int = 1000, env_overrides: dict | None = None) -> dict:
    """Evaluate a run's policy and the open-loop gaits in the run's env (same kwargs, updated
    by ``env_overrides``, e.g. ``{"sim_dt": 1e-4}`` to check that a policy does not exploit the
    timestep).

    Returns ``{"policy": {...}, "open_loop": [{...}, ...], "best_open_loop_speed_mm_s",
    "policy_speed_mm_s"}``; speeds along +x in mm/s.
    """
    import gymnasium as gym
    import yaml


    run_dir = Path(run_dir)
    cfg = yaml.safe_load((run_dir / "config.yml").read_text())
    policy = load_policy(run_dir / "model.zip", algo=cfg["algo"])
    cfg["env_kwargs"] = {**cfg["env_kwargs"], **(env_overrides or {})}
    env = gym.make(cfg["env_id"], **cfg["env_kwargs"])
    res = run_episodes(env, lambda obs, _env: policy(obs), episodes=episodes, seed=seed, name=f"{cfg['algo']} policy")
    env.close()
    gaits = evaluate_open_loop(cfg["env_id"], cfg["env_kwargs"], episodes=1, seed=seed)
    direction = int(cfg["env_kwargs"].get("target_direction", 1))
    best = max((g.speed * direction for g in gaits), default=math.nan) * direction
    best = None if math.isnan(best) else best
    return {"env_kwargs": cfg["env_kwargs"], "policy": res.to_dict(), "open_loop": [g.to_dict() for g in gaits],
            "policy_speed_mm_s": None if math.isnan(res.speed) else res.speed * 1e3,
            "best_open_loop_speed_mm_s": None if best is None else best * 1e3}


__all__ = ["evaluate_run", "train"]

"""Reinforcement-learning helpers behind ``train/``: hyperparameters, training runs, evaluation
against the open-loop gaits, policy loading. Stable-Baselines3 is imported only when used."""

from __future__ import annotations

import copy
import difflib
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ALGOS = ("ppo", "sac")


# ---------------------------------------------------------------------------- hyperparameters
def parse_override(text: str):
    """Value of a ``KEY=VALUE`` command-line override: YAML, with "1e-4"-style strings as floats
    (YAML 1.1 reads exponent notation without a dot as a string)."""
    import yaml

    return _yaml_numbers(yaml.safe_load(text))


def _yaml_numbers(v):
    """``v`` with YAML 1.1's exponent strings ("1e-4", read as strings without a dot) as floats,
    in nested dicts and lists too; other strings unchanged."""
    if isinstance(v, str):
        try:
            return float(v) if any(c.isdigit() for c in v) else v
        except ValueError:
            return v
    if isinstance(v, dict):
        return {k: _yaml_numbers(x) for k, x in v.items()}
    if isinstance(v, list):
        return [_yaml_numbers(x) for x in v]
    return v


def load_hyperparams(path, env_id: str, algo: str) -> dict:
    """Resolved settings for ``env_id`` and ``algo`` from a YAML file keyed by env id.

    The file has a ``default:`` block and one block per env id; each block may hold
    ``env_kwargs`` (constructor arguments), ``n_envs``, ``n_timesteps``, ``normalize``,
    ``eval_episodes`` and one sub-block per algorithm (``ppo:``, ``sac:``) of SB3 keyword
    arguments. The env block overrides the default block key by key (sub-blocks merged).

    Returns
    -------
    dict
        ``{"env_id", "algo", "env_kwargs", "n_envs", "n_timesteps", "normalize",
        "eval_episodes", "algo_kwargs"}``.
    """
    import yaml

    algo = str(algo).lower()
    if algo not in ALGOS:
        raise ValueError(f"algo must be one of {list(ALGOS)}, got {algo!r}.")
    with open(path) as fh:
        table = yaml.safe_load(fh) or {}
    if not isinstance(table, dict) or "default" not in table:
        raise ValueError(f"hyperparameter file {str(path)!r} must be a mapping with a 'default:' block.")
    known = [k for k in table if k != "default"]
    if env_id not in table:
        import gymnasium as gym

        import magsoft_env  # noqa: F401  (registers the ids)

        if env_id not in gym.registry:
            hint = difflib.get_close_matches(env_id, known + list(gym.registry), n=1)
            extra = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ValueError(f"env id {env_id!r} is not registered.{extra}")
    merged = copy.deepcopy(table["default"])
    for key, value in (table.get(env_id) or {}).items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = {**merged[key], **value}
        else:
            merged[key] = value
    algo_kwargs = _yaml_numbers(dict(merged.get(algo) or {}))
    return {
        "env_id": env_id,
        "algo": algo,
        "env_kwargs": _yaml_numbers(dict(merged.get("env_kwargs") or {})),
        "n_envs": int(merged.get("n_envs", 1)),
        "n_timesteps": int(float(algo_kwargs.pop("n_timesteps", merged.get("n_timesteps", 10000)))),
        "normalize": bool(merged.get("normalize", True)),
        "eval_episodes": int(merged.get("eval_episodes", 2)),
        "algo_kwargs": algo_kwargs,
    }


# ---------------------------------------------------------------------------- evaluation
@dataclass(frozen=True)
class EvalResult:
    """Speeds of one controller in one environment.

    Attributes
    ----------
    name : str
    speed : float
        Mean centre-of-mass speed along +x over the episodes (m/s).
    episode_return : float
        Mean return.
    episode_seconds : float
        Mean simulated episode length (s).
    crawl_violations : int
        Episodes that ended by breaking the crawl limit.
    max_com_height : float
        Highest centre of mass over the episodes (m): hopping or standing up shows here.
    final_error : float
        Shape env: mean tip-position error at the end of the episodes (m); NaN otherwise.
    successes : int
        Episodes that ended with ``info["is_success"]`` (channel, obstacle, shape envs).
    success_seconds : float
        Mean simulated time to success over the successful episodes (s); NaN if none.
    """

    name: str
    speed: float
    episode_return: float
    episode_seconds: float
    crawl_violations: int
    max_com_height: float = math.nan
    final_error: float = math.nan
    successes: int = 0
    success_seconds: float = math.nan

    def as_dict(self) -> dict:
        d = {"name": self.name, "speed_mm_s": self.speed * 1e3, "return": self.episode_return,
             "episode_s": self.episode_seconds, "crawl_violations": self.crawl_violations,
             "max_com_height_mm": self.max_com_height * 1e3, "final_error_mm": self.final_error * 1e3,
             "successes": self.successes, "success_s": self.success_seconds}
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in d.items()}


def run_episodes(env, act, *, episodes: int = 2, seed: int = 0, name: str = "policy") -> EvalResult:
    """Run ``episodes`` episodes of ``env`` (a Gymnasium env, time limit included) with
    ``act(obs, env) -> action``; measure centre-of-mass speed (m/s, along +x)."""
    speeds, returns, lengths, violations, zmax, errors, success_t = [], [], [], 0, -math.inf, [], []
    for k in range(int(episodes)):
        obs, info = env.reset(seed=seed + k)
        x0, t0 = info.get("x_position", math.nan), info["time"]
        total, done = 0.0, False
        while not done:
            obs, r, term, trunc, info = env.step(act(obs, env))
            total += float(r)
            zmax = max(zmax, float(info.get("z_position", math.nan)))
            done = term or trunc
        violations += int(bool(info.get("crawl_violation")))
        if info.get("is_success"):
            success_t.append(info["time"] - t0)
        errors.append(float(info.get("position_error", math.nan)))
        dt = info["time"] - t0
        speeds.append((info.get("x_position", math.nan) - x0) / dt if dt > 0 else 0.0)
        returns.append(total)
        lengths.append(dt)
    zmax = zmax if math.isfinite(zmax) else math.nan
    return EvalResult(name, float(np.mean(speeds)), float(np.mean(returns)), float(np.mean(lengths)), violations,
                      zmax, float(np.mean(errors)), len(success_t),
                      float(np.mean(success_t)) if success_t else math.nan)


def open_loop_actor(wave=None):
    """``act(obs, env)`` that plays the open-loop gait ``wave`` (default: the env robot's)."""

    def act(obs, env):
        base = env.unwrapped
        return base.open_loop_action(base.sim.time, wave)

    return act


def evaluate_open_loop(env_id: str, env_kwargs: dict | None = None, *, episodes: int = 1, seed: int = 0) -> list:
    """The paper gaits played open loop in ``env_id`` with the same limits and timesteps.

    For a crawl-type env whose robot is ``paper-5X``: that robot's gait, and the same gait
    with B_x inverted; for the shape env: holding the field whose equilibrium is the target.
    Returns a list of :class:`EvalResult` (empty for other envs).
    """
    import gymnasium as gym

    import magsoft_env  # noqa: F401
    from magsoft_env.gaits import gait_preset

    env = gym.make(env_id, **(env_kwargs or {}))
    base = env.unwrapped
    if not hasattr(base, "open_loop_action"):
        env.close()
        return []
    if not hasattr(base, "robot"):  # shape env: hold the field that made the target
        res = run_episodes(env, lambda obs, e: e.unwrapped.open_loop_action(), episodes=episodes, seed=seed,
                           name="open-loop target field")
        env.close()
        return [res]
    out = []
    for reverse in (False, True):
        preset = gait_preset(base.robot, reverse=reverse)
        name = f"open-loop {preset.name}{' --reverse' if reverse else ''}"
        out.append(run_episodes(env, open_loop_actor(preset.wave), episodes=episodes, seed=seed, name=name))
    env.close()
    return out


# ---------------------------------------------------------------------------- policies
def _algo_class(algo: str):
    import stable_baselines3 as sb3

    return {"ppo": sb3.PPO, "sac": sb3.SAC}[algo]


def load_policy(path, *, algo: str | None = None):
    """``obs -> action`` (deterministic) from a saved model ``.zip``; observation
    normalization statistics (``vecnormalize.pkl`` beside the model) are applied if present.
    The algorithm is read from ``config.yml`` beside the model unless given."""
    import pickle

    path = Path(path)
    if not path.exists():
        raise ValueError(f"policy path must be an existing model .zip, got {str(path)!r}.")
    if algo is None:
        cfg = path.parent / "config.yml"
        if cfg.exists():
            import yaml

            algo = yaml.safe_load(cfg.read_text()).get("algo", "ppo")
        else:
            algo = "ppo"
    model = _algo_class(algo).load(path, device="cpu")
    norm = None
    stats = path.parent / "vecnormalize.pkl"
    if stats.exists():
        with open(stats, "rb") as fh:
            norm = pickle.load(fh)

    def policy(obs):
        o = np.asarray(obs, dtype=np.float32)
        if norm is not None:
            o = norm.normalize_obs(o)
        action, _ = model.predict(o, deterministic=True)
        return action

    return policy


# ---------------------------------------------------------------------------- training
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

    import magsoft_env  # noqa: F401

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
    model = _algo_class(cfg["algo"])(policy, venv, seed=seed, verbose=0, device="cpu", **kwargs)
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

    import magsoft_env  # noqa: F401

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
    return {"env_kwargs": cfg["env_kwargs"], "policy": res.as_dict(), "open_loop": [g.as_dict() for g in gaits],
            "policy_speed_mm_s": None if math.isnan(res.speed) else res.speed * 1e3,
            "best_open_loop_speed_mm_s": None if best is None else best * 1e3}


__all__ = ["ALGOS", "EvalResult", "evaluate_open_loop", "evaluate_run", "load_hyperparams", "load_policy",
           "open_loop_actor", "run_episodes", "train"]

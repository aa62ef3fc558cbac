"""Episodes of a policy or of the open-loop paper gaits in an environment, and trained-policy loading.
Stable-Baselines3 is imported only when a policy is loaded."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np


@dataclass(frozen=True)
class EvalResult:
    """Speeds of one controller in one environment (frozen). Units are SI.

    Attributes
    ----------
    name : str
        The controller's label (e.g. ``"policy"`` or ``"open-loop paper-5a"``).
    speed : float
        Mean centre-of-mass speed along +x over the episodes (m/s).
    episode_return : float
        Mean undiscounted return per episode (dimensionless, the environment's reward units).
    episode_seconds : float
        Mean simulated episode length (s).
    crawl_violations : int
        Episodes that ended by breaking the crawl limit (dimensionless count).
    max_com_height : float
        Highest centre of mass over the episodes (m): hopping or standing up shows here.
    final_error : float
        Shape env: mean tip-position error at the end of the episodes (m); NaN otherwise.
    successes : int
        Episodes that ended with ``info["is_success"]`` (channel, obstacle, shape envs; count).
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

    def to_dict(self) -> dict:
        """JSON-ready summary with units in the keys (mm, mm/s, s); NaN becomes None."""
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

    from ..cases.gaits import gait_preset

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
def algo_class(algo: str):
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
    model = algo_class(algo).load(path, device="cpu")
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


__all__ = ["EvalResult", "evaluate_open_loop", "load_policy", "open_loop_actor", "run_episodes"]

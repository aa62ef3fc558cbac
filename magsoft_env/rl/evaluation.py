"""Episodes of a policy or of the open-loop paper gaits in an environment, and trained-policy loading checked
against the env it is played in. Stable-Baselines3 is imported only when a policy is loaded."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

#: Largest piece angle from the floor (rad) beyond which a floor gait is a tumble: the crawl envs' rotation limit
#: (``envs.crawl.DEFAULT_MAX_LINK_ROTATION``, 120 deg; a curl that lifts one end stays below it).
TUMBLE_ANGLE = 2.0 * math.pi / 3.0
#: Mean speed (m/s) below which a gait is called still: a tenth of the slowest open-loop paper gait (0.38 mm/s).
STILL_SPEED = 0.04e-3


def locomotion_mode(speed: float, airborne_fraction: float, largest_piece_angle: float) -> str:
    """What a floor gait does: ``"tumble"`` (a piece past :data:`TUMBLE_ANGLE`), ``"hop"`` (the whole beam off
    the floor at some substeps), ``"still"`` (absolute speed below :data:`STILL_SPEED`, m/s) or ``"crawl"``; ``""``
    where the env reports neither (the shape env)."""
    if math.isnan(airborne_fraction) or math.isnan(largest_piece_angle):
        return ""
    if largest_piece_angle > TUMBLE_ANGLE:
        return "tumble"
    if airborne_fraction > 0.0:
        return "hop"
    return "still" if abs(speed) < STILL_SPEED else "crawl"


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
        Shape env: mean tip-position error at the end of the episodes (m); steering env: mean distance to the
        goal at the end (m); NaN otherwise.
    successes : int
        Episodes that ended with ``info["is_success"]`` (channel, obstacle, shape envs; count).
    success_seconds : float
        Mean simulated time to success over the successful episodes (s); NaN if none.
    airborne_fraction : float
        Floor envs: mean over the episodes of the fraction of substeps with the whole beam off the floor
        (``info["airborne_fraction"]``); NaN otherwise.
    highest_clearance : float
        Floor envs: highest the beam's lowest point rose above the floor at any substep (m); NaN otherwise.
    largest_piece_angle : float
        Floor envs: largest angle of any piece from the floor at any substep (rad); NaN otherwise.
    locomotion : str
        :func:`locomotion_mode` of the above: ``"crawl"``, ``"hop"``, ``"tumble"``, ``"still"``, or ``""``.
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
    airborne_fraction: float = math.nan
    highest_clearance: float = math.nan
    largest_piece_angle: float = math.nan
    locomotion: str = ""

    def to_dict(self) -> dict:
        """JSON-ready summary with units in the keys (mm, mm/s, s); NaN becomes None."""
        d = {"name": self.name, "speed_mm_s": self.speed * 1e3, "return": self.episode_return,
             "episode_s": self.episode_seconds, "crawl_violations": self.crawl_violations,
             "max_com_height_mm": self.max_com_height * 1e3, "final_error_mm": self.final_error * 1e3,
             "successes": self.successes, "success_s": self.success_seconds, "locomotion": self.locomotion,
             "airborne_fraction": self.airborne_fraction, "highest_clearance_mm": self.highest_clearance * 1e3,
             "largest_piece_angle_deg": math.degrees(self.largest_piece_angle)}
        return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in d.items()}


def run_episodes(env, act, *, episodes: int = 2, seed: int = 0, name: str = "policy") -> EvalResult:
    """Run ``episodes`` episodes of ``env`` (a Gymnasium env, time limit included) with
    ``act(obs, env) -> action``; measure centre-of-mass speed (m/s, along +x)."""
    speeds, returns, lengths, violations, zmax, errors, success_t = [], [], [], 0, -math.inf, [], []
    airborne, clearance, angle = [], [], []
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
        airborne.append(float(info.get("airborne_fraction", math.nan)))
        clearance.append(float(info.get("highest_clearance", math.nan)))
        angle.append(float(info.get("largest_piece_angle", math.nan)))
        dt = info["time"] - t0
        speeds.append((info.get("x_position", math.nan) - x0) / dt if dt > 0 else 0.0)
        returns.append(total)
        lengths.append(dt)
    zmax = zmax if math.isfinite(zmax) else math.nan
    speed, air = float(np.mean(speeds)), float(np.mean(airborne))
    top, ang = float(np.max(clearance)), float(np.max(angle))
    return EvalResult(name, speed, float(np.mean(returns)), float(np.mean(lengths)), violations,
                      zmax, float(np.mean(errors)), len(success_t),
                      float(np.mean(success_t)) if success_t else math.nan, air, top, ang,
                      locomotion_mode(speed, air, ang))


def open_loop_actor(wave=None):
    """``act(obs, env)`` that plays the open-loop gait ``wave`` (default: the env robot's)."""

    def act(obs, env):
        base = env.unwrapped
        return base.open_loop_action(base.sim.time, wave)

    return act


def evaluate_open_loop(env_id: str, env_kwargs: dict | None = None, *, episodes: int = 1, seed: int = 0) -> list:
    """The paper gaits played open loop in ``env_id`` with the same limits and timesteps.

    For a crawl-type env whose robot is ``paper-5X``: that robot's gait, and the same gait
    with B_x inverted; for the shape env: holding the field whose equilibrium is the target; for the
    steering env: its hand-designed controller (``baseline_action``, closed loop on the observation).
    Returns a list of :class:`EvalResult` (empty for other envs).
    """
    import gymnasium as gym

    from ..cases.gaits import gait_preset

    env = gym.make(env_id, **(env_kwargs or {}))
    base = env.unwrapped
    if hasattr(base, "baseline_action"):  # steering env: the hand-designed controller (turn to the goal, go)
        res = run_episodes(env, lambda obs, e: e.unwrapped.baseline_action(obs), episodes=episodes, seed=seed,
                           name="hand controller")
        env.close()
        return [res]
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
def _space_mismatch(trained, played) -> str | None:
    """How ``played`` differs from the space a policy was ``trained`` on (None if it does not)."""
    if type(trained) is not type(played):
        return f"{type(trained).__name__} vs {type(played).__name__}"
    if getattr(trained, "shape", None) != getattr(played, "shape", None):
        return f"shape {trained.shape} vs {played.shape}"
    if hasattr(trained, "low") and not (np.array_equal(trained.low, played.low)
                                        and np.array_equal(trained.high, played.high)):
        return "bounds differ"
    if hasattr(trained, "n") and trained.n != played.n:
        return f"{trained.n} vs {played.n} choices"
    return None


def _describe(space) -> str:
    """A space in a few words: ``Box((48,), float32)`` (bounds left out)."""
    if hasattr(space, "shape") and hasattr(space, "low"):
        return f"{type(space).__name__}({space.shape}, {space.dtype})"
    return str(space)


def check_policy_env(trained_env_id: str | None, trained_spaces: tuple, env, *, env_kwargs: dict | None = None,
                     source: str = "the policy") -> None:
    """Raise ValueError when ``env`` is not the env a policy was trained in: another env id than
    ``trained_env_id`` (when recorded), or other observation / action spaces than ``trained_spaces`` =
    ``(observation_space, action_space)``.

    ``env`` is a Gymnasium env or a registered id; an id is made with ``env_kwargs`` for the check (the
    spaces depend on arguments such as ``segments``) and closed again.
    """
    import gymnasium as gym

    made = isinstance(env, str)
    if made:
        from .hyperparams import check_env_id

        check_env_id(env)
        env_id = env
    else:
        env_id = env.spec.id if env.spec is not None else None
    if trained_env_id is not None and env_id is not None and env_id != trained_env_id:
        raise ValueError(f"{source} was trained on {trained_env_id}, not {env_id}: play it with "
                         f"--env {trained_env_id} (or train one for {env_id}).")
    if made:
        env = gym.make(env_id, **(env_kwargs or {}))
    try:
        for what, trained, played in (("observation", trained_spaces[0], env.observation_space),
                                      ("action", trained_spaces[1], env.action_space)):
            diff = _space_mismatch(trained, played)
            if diff is not None:
                raise ValueError(f"{source} does not fit {env_id or type(env.unwrapped).__name__}: its {what} "
                                 f"space is {_describe(trained)}, the env's {_describe(played)} ({diff}).")
    finally:
        if made:
            env.close()


def _legacy_config(path: Path) -> dict | None:
    """``config.yml`` beside a model written by train/train.py before magsoft_env 0.5 (``env_id``, ``algo``)."""
    import yaml

    cfg = path.parent / "config.yml"
    if not cfg.is_file():
        return None
    data = yaml.safe_load(cfg.read_text()) or {}
    return data if isinstance(data, dict) and "env_id" in data else None


def policy_run_info(path) -> dict:
    """What a saved model's folder records about its training: ``{"env_id", "algo", "env_kwargs",
    "vecnormalize"}`` (``None`` where nothing is recorded). Reads rl-zoo3's ``<env>/args.yml`` and
    ``config.yml`` (:func:`magsoft_env.rl.runs.find_run`), else a ``config.yml`` with ``env_id`` beside
    the model (train/train.py before rl-zoo3)."""
    from .runs import find_run

    path = Path(path)
    if not path.is_file():
        raise ValueError(f"policy path must be an existing model .zip, got {str(path)!r}.")
    try:
        rec = find_run(path)
    except ValueError:
        rec = None
    if rec is not None:
        return {"env_id": rec.env_id, "algo": rec.algo, "env_kwargs": dict(rec.env_kwargs),
                "vecnormalize": rec.vecnormalize}
    legacy = _legacy_config(path)
    if legacy is not None:
        stats = path.parent / "vecnormalize.pkl"
        return {"env_id": legacy["env_id"], "algo": legacy.get("algo", "ppo"),
                "env_kwargs": dict(legacy.get("env_kwargs") or {}), "vecnormalize": stats if stats.exists() else None}
    return {"env_id": None, "algo": None, "env_kwargs": None, "vecnormalize": None}


class Policy:
    """A trained policy as ``obs -> action`` (deterministic), with observation normalization applied.

    Attributes
    ----------
    model : stable_baselines3.common.base_class.BaseAlgorithm
    env_id : str or None
        The env id the run recorded (None for a bare model file).
    env_kwargs : dict or None
        The env arguments the run was trained with (None if not recorded): play it in
        ``gym.make(env_id, **env_kwargs)``.
    """

    def __init__(self, model, norm=None, *, env_id: str | None = None, env_kwargs: dict | None = None):
        self.model, self.norm, self.env_id, self.env_kwargs = model, norm, env_id, env_kwargs

    def __call__(self, obs):
        o = np.asarray(obs, dtype=np.float32)
        if self.norm is not None:
            o = self.norm.normalize_obs(o)
        action, _ = self.model.predict(o, deterministic=True)
        return action


def load_policy(path, *, algo: str | None = None, env=None, env_kwargs: dict | None = None) -> Policy:
    """A saved model ``.zip`` as a deterministic :class:`Policy`, checked against the env it is played in.

    Parameters
    ----------
    path : str or Path
        The model: in an rl-zoo3 log folder (``<env>.zip``, ``best_model.zip``, checkpoints), whose
        ``<env>/vecnormalize.pkl`` observation statistics are then applied, or any SB3 model file.
    algo : str, optional
        rl-zoo3's algorithm name; default: the one the run recorded, else ``"ppo"``.
    env : str or gymnasium.Env, optional
        The env (or registered id) the policy will be played in. Refused with a ValueError when the run
        recorded another env id, or when the model's observation or action space is not the env's
        (:func:`check_policy_env`).
    env_kwargs : dict, optional
        Arguments ``env`` (an id) will be made with; default: the run's recorded ones.

    Example: ``policy = load_policy(zip_path, env=env_id)``, then play it in
    ``gym.make(env_id, **(policy.env_kwargs or {}))``.
    """
    import pickle

    path = Path(path)
    info = policy_run_info(path)
    from .hyperparams import algo_class

    model = algo_class(algo or info["algo"] or "ppo").load(path, device="cpu")
    if env is not None:
        kwargs = info["env_kwargs"] if env_kwargs is None else env_kwargs
        check_policy_env(info["env_id"], (model.observation_space, model.action_space), env, env_kwargs=kwargs,
                         source=f"policy {str(path)!r}")
    norm = None
    if info["vecnormalize"] is not None:
        with open(info["vecnormalize"], "rb") as fh:
            norm = pickle.load(fh)
    return Policy(model, norm, env_id=info["env_id"], env_kwargs=info["env_kwargs"])


__all__ = ["EvalResult", "Policy", "check_policy_env", "evaluate_open_loop", "load_policy", "open_loop_actor",
           "policy_run_info", "run_episodes"]

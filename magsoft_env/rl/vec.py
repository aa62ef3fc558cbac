"""Stable-Baselines3 ``VecEnv`` s for the batched floor envs: an adapter over a Gymnasium vector env, and
``DummyVecEnv`` on threads (what rl-zoo3 runs use: ``magsoft_env.rl.train(vec="threads")``)."""

from __future__ import annotations

import time
from copy import deepcopy

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode
from stable_baselines3.common.vec_env import DummyVecEnv
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


def unbatch_infos(infos: dict, num_envs: int) -> list[dict]:
    """Gymnasium vector infos (``info[key]`` an array over the envs, ``info["_" + key]`` its mask, nested
    dicts alike) -> one plain dict per env, as SB3's ``VecEnv`` returns them (numbers as Python scalars)."""
    out: list[dict] = [{} for _ in range(num_envs)]
    for key, value in infos.items():
        if key.startswith("_") and key[1:] in infos:
            continue  # a mask
        mask = infos.get(f"_{key}")
        ids = range(num_envs) if mask is None else np.flatnonzero(mask).tolist()
        if isinstance(value, dict):
            sub = unbatch_infos(value, num_envs)
            for i in ids:
                out[i][key] = sub[i]
            continue
        for i in ids:
            v = value[i]
            if isinstance(v, np.generic):
                v = v.item()
            elif isinstance(v, np.ndarray):
                v = v.copy()
            out[i][key] = v
    return out


class SB3VecAdapter(VecEnv):
    """A Gymnasium :class:`~gymnasium.vector.VectorEnv` with ``AutoresetMode.NEXT_STEP`` (the batched
    :class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`, or ``SyncVectorEnv``) as an SB3 ``VecEnv``.

    SB3's semantics: ``step_wait`` returns ``(obs, rewards, dones, infos)`` with ``dones = terminated |
    truncated``; an env whose episode ended is reset at once (``reset(options={"reset_mask": dones})``),
    its returned observation is the reset one and ``infos[i]["terminal_observation"]`` the last one of the
    episode; ``infos[i]["TimeLimit.truncated"]`` is ``truncated and not terminated``. Seeds from
    :meth:`seed` (and ``PPO(seed=...)``) reach the next :meth:`reset`.

    Parameters
    ----------
    venv : gymnasium.vector.VectorEnv
        With ``metadata["autoreset_mode"] = AutoresetMode.NEXT_STEP`` and ``reset_mask`` support.

    Examples
    --------
    >>> import gymnasium as gym, magsoft_env
    >>> from stable_baselines3 import PPO
    >>> venv = SB3VecAdapter(gym.make_vec("MagSoftCrawl-v1", num_envs=2, segments=4, sim_dt=1e-3))
    >>> model = PPO("MlpPolicy", venv, n_steps=16, batch_size=16, n_epochs=1).learn(32)
    >>> venv.close()
    """

    def __init__(self, venv: gym.vector.VectorEnv):
        if not isinstance(venv, gym.vector.VectorEnv):
            raise ValueError(f"venv must be a gymnasium.vector.VectorEnv, got {type(venv).__name__}.")
        mode = venv.metadata.get("autoreset_mode")
        if mode != AutoresetMode.NEXT_STEP:
            raise ValueError(f"venv must autoreset in AutoresetMode.NEXT_STEP (metadata['autoreset_mode']), got "
                             f"{mode!r}.")
        self.venv = venv
        self._actions = None
        super().__init__(venv.num_envs, venv.single_observation_space, venv.single_action_space)

    def _sub_envs(self):
        envs = getattr(self.venv.unwrapped, "envs", None)
        return None if envs is None else list(envs)

    def reset(self):
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        options = [o or {} for o in self._options]
        if any(o != options[0] for o in options):
            raise ValueError("SB3VecAdapter passes one options dict to every env: set_options(dict), not a list of "
                             "different ones.")
        obs, info = self.venv.reset(seed=seeds, options=dict(options[0]) or None)
        self.reset_infos = unbatch_infos(info, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        obs, rewards, terminated, truncated, info = self.venv.step(self._actions)
        dones = np.logical_or(terminated, truncated)
        infos = unbatch_infos(info, self.num_envs)
        for i, d in enumerate(infos):
            d["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
        if dones.any():
            ended = np.flatnonzero(dones).tolist()
            for i in ended:
                infos[i]["terminal_observation"] = obs[i].copy()
            reset_obs, reset_info = self.venv.reset(options={"reset_mask": dones.copy()})
            obs[dones] = reset_obs[dones]
            fresh = unbatch_infos(reset_info, self.num_envs)
            for i in ended:
                self.reset_infos[i] = fresh[i]
        return obs, np.asarray(rewards, dtype=np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    def get_images(self):
        if self.render_mode != "rgb_array":
            return [None] * self.num_envs
        return list(self.venv.render())

    def get_attr(self, attr_name: str, indices=None) -> list:
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value, indices=None) -> None:
        ids = list(self._get_indices(indices))
        envs = self._sub_envs()
        if envs is not None:
            for i in ids:
                setattr(envs[i], attr_name, value)
            return
        if sorted(ids) != list(range(self.num_envs)):
            raise ValueError(f"set_attr on some envs needs a vector env with .envs; {type(self.venv).__name__} "
                             "has none.")
        self.venv.set_attr(attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list:
        ids = list(self._get_indices(indices))
        envs = self._sub_envs()
        if envs is None:
            if sorted(ids) != list(range(self.num_envs)):
                raise ValueError(f"env_method on some envs needs a vector env with .envs; {type(self.venv).__name__} "
                                 "has none.")
            return list(self.venv.call(method_name, *method_args, **method_kwargs))
        return [envs[i].get_wrapper_attr(method_name)(*method_args, **method_kwargs) for i in ids]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        from stable_baselines3.common.env_util import is_wrapped

        ids = list(self._get_indices(indices))
        envs = self._sub_envs()
        if envs is None:
            return [False] * len(ids)
        return [is_wrapped(envs[i], wrapper_class) for i in ids]


class ThreadedVecEnv(DummyVecEnv):
    """SB3's ``DummyVecEnv`` with its envs stepped on threads: the same envs (built by ``env_fns``, with their
    wrappers: ``Monitor``, ``TimeLimit``, rl-zoo3's), the same semantics and results, in less wall time
    where an env's step releases the GIL for most of its time, as the MagSoft envs' MuJoCo blocks do.

    Each call hands the envs to ``num_threads`` threads (the calling one included; the env whose last step
    took longest first); each steps its env, records SB3's ``dones``, ``TimeLimit.truncated`` and
    ``terminal_observation`` and resets it when its episode ended, as ``DummyVecEnv.step_wait`` does one
    env after the other. Envs are independent, so the order does not change any env's result (tested
    against ``DummyVecEnv``). A MagSoft env's simulator gets its MuJoCo warnings from whichever thread
    steps it (:func:`magsoft_env.envs.vector.route_warnings`).

    rl-zoo3 builds its vector env with ``make_vec_env(..., vec_env_cls=...)``: :func:`magsoft_env.rl.train`
    with ``vec="threads"`` (``train/train.py --vec threads``) sets this class as rl-zoo3's
    ``ExperimentManager.default_vec_env_cls`` for the run. Unlike :class:`SB3VecAdapter` over
    ``gym.make_vec`` (which interleaves the robots block by block), whole env steps are the unit here,
    so the threads end a call up to one env step apart.

    Parameters
    ----------
    env_fns : list of callables
        Each returns a new env (as for ``DummyVecEnv``).
    num_threads : int, optional
        Threads, the calling one included; default ``min(len(env_fns), usable CPUs)``.

    Examples
    --------
    >>> import gymnasium as gym, magsoft_env
    >>> from stable_baselines3.common.env_util import make_vec_env
    >>> venv = make_vec_env("MagSoftCrawl-v1", n_envs=2, vec_env_cls=ThreadedVecEnv,
    ...                     env_kwargs={"segments": 4, "sim_dt": 1e-3})
    >>> venv.num_threads <= 2
    True
    >>> venv.close()
    """

    def __init__(self, env_fns, num_threads: int | None = None):
        from ..envs.vector import ThreadTeam, route_warnings, usable_cpus

        super().__init__(env_fns)
        n = self.num_envs
        if num_threads is None:
            num_threads = min(n, usable_cpus())
        if isinstance(num_threads, (bool, np.bool_)) or not isinstance(num_threads, (int, np.integer)) \
                or num_threads < 1:
            raise ValueError(f"num_threads must be an integer >= 1, got {num_threads!r}.")
        self.num_threads = min(int(num_threads), n)
        self._team = ThreadTeam(self.num_threads, name="magsoft-sb3vec")
        self._sinks = [route_warnings(getattr(env.unwrapped, "sim", None)) for env in self.envs]
        self._cost = np.zeros(n)  # wall time of each env's last step (s): the longest go first

    def _step_env(self, i: int) -> None:
        t0 = time.perf_counter()
        env = self.envs[i]
        obs, reward, terminated, truncated, info = env.step(self.actions[i])
        self.buf_rews[i] = reward
        self.buf_dones[i] = done = terminated or truncated
        info["TimeLimit.truncated"] = truncated and not terminated
        if done:  # SB3: the episode's last observation in the info, the reset's in the buffer
            info["terminal_observation"] = obs
            obs, self.reset_infos[i] = env.reset()
        self.buf_infos[i] = info
        self._save_obs(i, obs)
        self._cost[i] = time.perf_counter() - t0

    def step_wait(self):
        from ..envs.vector import with_sink  # (envs.vector imports MuJoCo and the envs: on first use)

        order = np.argsort(-self._cost, kind="stable").tolist()
        self._team.each(order, lambda i: with_sink(self._sinks[i], self._step_env, i))
        return self._obs_from_buf(), np.copy(self.buf_rews), np.copy(self.buf_dones), deepcopy(self.buf_infos)

    def close(self) -> None:
        self._team.close()
        super().close()


def make_sb3_vec_env(env_id: str, num_envs: int = 1, *, seed: int | None = None, monitor: bool = True,
                     **env_kwargs) -> VecEnv:
    """``gym.make_vec(env_id, num_envs, vectorization_mode="vector_entry_point", **env_kwargs)`` as an SB3
    ``VecEnv`` (:class:`SB3VecAdapter`), seeded for its first reset, inside ``VecMonitor`` when ``monitor``
    (episode returns and lengths in the infos, as SB3's logger reads them)."""
    from stable_baselines3.common.vec_env import VecMonitor

    venv = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode="vector_entry_point", **env_kwargs)
    env = SB3VecAdapter(venv)
    if seed is not None:
        env.seed(seed)
    return VecMonitor(env) if monitor else env


__all__ = ["SB3VecAdapter", "ThreadedVecEnv", "make_sb3_vec_env", "unbatch_infos"]

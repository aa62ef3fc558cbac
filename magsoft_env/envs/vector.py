"""Batched floor environments: ``num_envs`` robots stepped per call on a thread pool, each exactly as the single env."""

from __future__ import annotations

import os
import threading
import time
from collections import deque
from concurrent.futures import ThreadPoolExecutor

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..rods import DEFAULT_ROD
from ..sim.model import CONTACT_HISTORY
from . import constructor_arguments, refuse_unknown_kwargs
from .batching import count as _count
from .batching import refuse_warp_rod, reset_arguments
from .channel import MagSoftChannelEnv
from .crawl import MagSoftCrawlEnv
from .crawl_task import stack_infos
from .obstacle import MagSoftObstacleEnv
from .steer import MagSoftSteerEnv

#: Substeps per interleaved block in field mode (a 100-substep control step: 4 blocks); the trajectory does not
#: depend on it. Waveform mode, whose control step is a whole field period (hundreds to thousands of substeps),
#: interleaves blocks of the contact history's length (100).
DEFAULT_BLOCK = 25

#: How long the calling thread polls for the pool's end before it sleeps on an event (s).
SPIN_S = 2e-3

#: The warning sink of the simulator each thread is stepping (MuJoCo's warning handler is one per process).
_local = threading.local()


def _route_warning(text: str) -> None:
    """MuJoCo's warning handler while a batch runs: the text goes to the simulator that the calling
    thread is stepping (its own ``Simulator`` handler, which times the warning and stops the block)."""
    sink = getattr(_local, "sink", None)
    if sink is not None:
        sink(text)
    else:  # outside a Simulator.step (a reset's mj_forward): where MuJoCo's own handler would print it
        gym.logger.warn(f"MuJoCo warning: {text.strip()}")


def usable_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def route_warnings(sim):
    """Let ``sim``'s MuJoCo warnings reach it from any thread: its own warning handler is returned, to be
    named the thread's sink (:func:`with_sink`) while that thread steps it, and ``sim`` installs the
    router instead (MuJoCo's warning handler is one per process). ``sim`` without a handler: None."""
    own = getattr(sim, "on_warning", None)
    if own is None or own is _route_warning:
        return own
    sim.on_warning = _route_warning
    return own


def with_sink(sink, fn, *args):
    """``fn(*args)`` with ``sink`` as this thread's MuJoCo warning sink."""
    _local.sink = sink
    try:
        return fn(*args)
    finally:
        _local.sink = None


class ThreadTeam:
    """``num_threads`` threads, the calling one included, that run a worker function until all return.

    While they run, MuJoCo's (process-wide) warning handler is the router that sends each warning to
    the sink of the thread that raised it (:func:`route_warnings`). The calling thread polls for the
    others' end (for at most :data:`SPIN_S`, then it sleeps on an event) rather than waiting on a
    condition at once, which an idle vCPU of a virtual machine takes 1-2 ms to wake from (measured on
    a 2-core x86 cloud VM: about 5 % of an 8-robot call).
    """

    def __init__(self, num_threads: int, *, name: str = "magsoft-vec"):
        self.num_threads = _count("num_threads", num_threads)
        self._pool = (ThreadPoolExecutor(max_workers=self.num_threads - 1, thread_name_prefix=name)
                      if self.num_threads > 1 else None)

    def run(self, worker) -> None:
        """``worker()`` on the calling thread and on each of the pool's, until all return; a worker's
        exception is raised here, after all have returned."""
        # every simulator sets its own handler for a step and restores the one it found: with this one
        # installed first, all of them find and restore it, whichever thread finishes first
        prev = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(_route_warning)
        lock = threading.Lock()
        busy = [0]
        done = threading.Event()
        errors: list[BaseException] = []

        def pooled():
            try:
                worker()
            except BaseException as err:  # raised on the calling thread below
                errors.append(err)
            finally:
                with lock:
                    busy[0] -= 1
                    if not busy[0]:
                        done.set()

        try:
            if self._pool is not None:
                busy[0] = self.num_threads - 1
                for _ in range(busy[0]):
                    self._pool.submit(pooled)
            worker()
        finally:
            # the others usually end within a block of this one: poll for them, yielding CPU and GIL, for
            # at most SPIN_S; then sleep until the last one signals (a long job, e.g. a waveform period)
            t0 = time.perf_counter()
            while busy[0] and time.perf_counter() - t0 < SPIN_S:
                time.sleep(0)
            if busy[0]:
                done.wait()
            mujoco.set_mju_user_warning(prev)
        if errors:
            raise errors[0]

    def each(self, ids, job) -> None:
        """``job(i)`` for every ``i`` of ``ids``, in that order, taken by whichever thread is free."""
        todo = iter(list(ids))
        lock = threading.Lock()

        def worker():
            while True:
                with lock:
                    i = next(todo, None)
                if i is None:
                    return
                job(i)

        self.run(worker)

    def close(self) -> None:
        """Stop the pool's threads."""
        pool, self._pool = self._pool, None
        if pool is not None:
            pool.shutdown(wait=True)


class MagSoftCrawlVecEnv(VectorEnv):
    """
    ## Description

    ``num_envs`` independent copies of :class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv` (or of
    :attr:`env_class`: the channel and obstacle envs in the subclasses) as one Gymnasium
    :class:`~gymnasium.vector.VectorEnv`, the ``vector_entry_point`` of the floor ids:
    ``gym.make_vec("MagSoftCrawl-v1", num_envs=8)`` returns one, with the same keyword arguments as
    ``gym.make``. Each call steps every robot with the single env's own code (its ``step``: the field,
    :meth:`Simulator.step <magsoft_env.sim.Simulator.step>` with every health check, observation, reward,
    termination, info), on ``num_threads`` threads: a held field runs as ``mj_step(m, d, k)`` blocks in
    MuJoCo, which release the GIL, so the robots' physics runs in parallel and only the Python between
    blocks (about 15 % of a step) takes turns. The threads interleave the robots block by block (the
    single env's step as a generator, :meth:`Simulator.stepping <magsoft_env.sim.Simulator.stepping>`;
    ``block`` substeps at a time), so that all robots end a call within about one block of each other
    rather than one robot's whole step. Robot ``i`` is therefore the single env, bit for bit, under the
    same seed and actions (tested), whatever the thread count and block.

    On a 2-core x86 cloud VM the batch gives 1.7-1.8x the single env's steps/s at 8 and 32
    robots, which is the machine's own two-thread scaling of MuJoCo's C step at that moment (98-106 % of
    it, measured in the same rounds: ``python -m magsoft_env.bench.vec_bench --only batched,machine``).

    ## Action Space, Observation Space

    The single env's spaces batched: ``(num_envs, 2)`` actions in field mode (``(num_envs, 4)`` in
    waveform mode), ``(num_envs, 2 N + 8)`` float32 observations (:attr:`single_action_space`,
    :attr:`single_observation_space`).

    ## Rewards, Episode End

    As the single env's, per robot; ``max_episode_steps`` truncates as ``gym.make``'s ``TimeLimit``
    does (``gym.make_vec`` passes the registered limit; None: no limit).

    ## Autoreset

    ``AutoresetMode.NEXT_STEP`` (``metadata["autoreset_mode"]``), as ``SyncVectorEnv``: the step after a
    robot's episode ended resets it (without a seed: its random stream goes on, as ``env.reset()`` after
    an episode) and returns the reset observation with reward 0, ``terminated`` and ``truncated`` False
    and the reset's info; the action given to it that step is ignored. ``reset(options={"reset_mask":
    mask})`` resets only the robots in the boolean ``mask``.

    ## Infos

    Gymnasium's vector convention: ``info[key]`` an array over the robots, ``info["_" + key]`` the
    mask of the robots whose info has the key (``crawl_violation``, ``truncation_reason``,
    ``unphysical`` and its figures appear only where they happened).

    ## Health checks

    Every robot keeps its :class:`~magsoft_env.sim.Simulator` checks (penetration from the contact
    sensors' history, energy, runaway, tunnelling, MuJoCo warnings): an unstable or unphysical robot
    truncates with the single env's info and is reset at its next step. MuJoCo's warning handler is
    one per process, so while a batch runs it routes each warning to the simulator that the warning's
    thread is stepping (each simulator's own handler, which times the warning and stops its block).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``num_envs`` | 1 | robots |
    | ``max_episode_steps`` | None | time limit (steps); ``gym.make_vec`` passes the registered one |
    | ``num_threads`` | None | threads stepping the robots (the calling one included); None: ``min(num_envs,`` |
    | | | usable CPUs) |
    | ``block`` | None | substeps of one robot the threads run before taking the next robot in turn; None: |
    | | | 25 in field mode, 100 in waveform mode (a whole period per control step) |
    | ``backend`` | ``"cpu"`` | ``"warp"``: MuJoCo Warp worlds instead (``envs/warp_vector.py``, docs/gpu.md) |
    | ``**kwargs`` | | every argument of :attr:`env_class` (``robot``, ``field_limit``, ...), checked as there |

    ## Version History

    - v0: initial version (magsoft_env 0.4.0); robots interleaved block by block (``block``), same results.
    - v1: the single envs' v1 (crawl limits at every substep, ``highest_clearance`` and ``airborne_fraction`` in
      ``info``).

    Examples
    --------
    >>> import gymnasium as gym, numpy as np, magsoft_env
    >>> envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, segments=4, sim_dt=1e-3)
    >>> obs, info = envs.reset(seed=0)
    >>> obs.shape
    (2, 16)
    >>> obs, reward, terminated, truncated, info = envs.step(np.zeros((2, 2), dtype=np.float32))
    >>> envs.close()
    """

    #: The single environment each robot runs.
    env_class = MagSoftCrawlEnv

    def __new__(cls, num_envs: int = 1, *, backend: str = "cpu", **kwargs):
        # backend="warp": the robots as MuJoCo Warp worlds (the optional extra; envs/warp_vector.py, imported here only)
        if backend == "warp":
            refuse_warp_rod(kwargs.get("rod", DEFAULT_ROD))
            from .warp_vector import MagSoftCrawlWarpVecEnv

            return MagSoftCrawlWarpVecEnv(num_envs, env_class=cls.env_class, **kwargs)
        if backend != "cpu":
            raise ValueError(f"backend must be 'cpu' or 'warp', got {backend!r}.")
        return super().__new__(cls)

    def __init__(self, num_envs: int = 1, *, max_episode_steps: int | None = None, num_threads: int | None = None,
                 block: int | None = None, backend: str = "cpu", **kwargs):
        allowed = constructor_arguments(self.env_class)
        refuse_unknown_kwargs(self, {k: v for k, v in kwargs.items() if k not in allowed}, classes=(self.env_class,))
        self.num_envs = _count("num_envs", num_envs)
        self.max_episode_steps = None if max_episode_steps is None else _count("max_episode_steps", max_episode_steps)
        threads = min(self.num_envs, usable_cpus()) if num_threads is None else _count("num_threads", num_threads)
        self.num_threads = min(threads, self.num_envs)
        #: Substeps of one robot's native block, the unit the threads interleave (see ``_step_all``).
        self.block = None if block is None else _count("block", block)
        self.envs = tuple(self.env_class(**kwargs) for _ in range(self.num_envs))
        if self.block is None:
            self.block = DEFAULT_BLOCK if self.envs[0].action_mode == "field" else CONTACT_HISTORY
        # each simulator's warnings reach it from any thread (see "Health checks"): the thread that steps
        # a robot names its own handler as the sink of the handler all of them install
        self._sinks = [route_warnings(env.sim) for env in self.envs]
        first = self.envs[0]
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {**first.metadata, "autoreset_mode": AutoresetMode.NEXT_STEP}
        self.render_mode = first.render_mode
        n = self.num_envs
        self._obs = np.zeros((n, *self.single_observation_space.shape), dtype=self.single_observation_space.dtype)
        self._rewards = np.zeros(n)
        self._terminations = np.zeros(n, dtype=bool)
        self._truncations = np.zeros(n, dtype=bool)
        self._autoreset = np.zeros(n, dtype=bool)
        self._elapsed = np.zeros(n, dtype=np.int64)
        self._env_infos: list[dict] = [{} for _ in range(n)]
        self._cost = np.zeros(n)  # wall time of each robot's last step (s): the longest go first
        self._actions = None
        self._team = ThreadTeam(self.num_threads)

    def __repr__(self) -> str:
        name = self.spec.id if self.spec is not None else self.env_class.__name__
        return f"{type(self).__name__}({name}, num_envs={self.num_envs}, num_threads={self.num_threads})"

    # ------------------------------------------------------------------ the robots, on threads
    def _reset_one(self, i: int, seed, options) -> None:
        obs, info = self.envs[i].reset(seed=seed, options=options)
        self._obs[i] = obs
        self._env_infos[i] = info
        self._rewards[i] = 0.0
        self._terminations[i] = self._truncations[i] = self._autoreset[i] = False
        self._elapsed[i] = 0

    def _step_all(self, order) -> None:
        """Step the robots of ``order`` (autoresetting those whose episode ended), interleaved block by
        block on the threads: a worker takes the robot at the head of the queue, runs its next native
        block (:meth:`MagSoftCrawlEnv._stepping`, at most :attr:`block` substeps) and puts it back at
        the tail, so that every robot advances in turn and all end the call within about one block of
        each other (a robot's blocks are sequential: the threads cannot share one robot's last block)."""
        queue = deque(order)
        running: dict[int, object] = {}
        lock = threading.Lock()

        def job(i: int) -> None:
            steps = running.get(i)
            if steps is None:
                if self._autoreset[i]:  # AutoresetMode.NEXT_STEP: the step after an episode's end resets it
                    self._reset_one(i, None, None)
                    return
                self._cost[i] = 0.0
                steps = running[i] = self.envs[i]._stepping(self._actions[i], block=self.block)
            t0 = time.perf_counter()
            try:
                with_sink(self._sinks[i], next, steps)
            except StopIteration as done:
                del running[i]
                self._finish(i, *done.value)
                return
            finally:
                self._cost[i] += time.perf_counter() - t0
            with lock:
                queue.append(i)

        def worker():
            while True:
                with lock:
                    if not queue:
                        return
                    i = queue.popleft()
                job(i)

        try:
            self._team.run(worker)
        finally:  # after a worker's exception: the other robots' steps end here (their simulators' cleanup runs)
            for steps in running.values():
                steps.close()

    def _finish(self, i: int, obs, reward, terminated, truncated, info) -> None:
        self._elapsed[i] += 1
        if self.max_episode_steps is not None and self._elapsed[i] >= self.max_episode_steps:
            truncated = True  # as gymnasium's TimeLimit
        self._obs[i] = obs
        self._rewards[i] = reward
        self._terminations[i] = terminated
        self._truncations[i] = truncated
        self._env_infos[i] = info

    def _infos(self, ids) -> dict:
        return stack_infos({int(i): self._env_infos[i] for i in ids}, self.num_envs)

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every robot (or those of ``options["reset_mask"]``); ``seed``: None, an int (robot ``i``
        gets ``seed + i``, as ``SyncVectorEnv``) or one seed per robot; the other options go to every robot's
        ``reset`` (e.g. a start state, ``{"qpos": ..., "qvel": ...}``)."""
        seeds, mask, rest = reset_arguments(seed, options, self.num_envs)
        ids = range(self.num_envs) if mask is None else np.flatnonzero(mask).tolist()
        env_options = rest or None
        self._team.each(ids, lambda i: self._reset_one(i, seeds[i], env_options))
        return self._obs.copy(), self._infos(ids)

    def step(self, actions):
        """Step every robot with its row of ``actions`` (shape ``(num_envs, *single_action_space.shape)``);
        a robot whose episode ended at the last step is reset instead (NEXT_STEP autoreset)."""
        a = np.asarray(actions)
        if a.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape} (num_envs, action), got {a.shape}.")
        self._actions = a
        # longest expected first (a robot's last step; a reset costs little), so that the threads end together
        order = np.argsort(-np.where(self._autoreset, 0.0, self._cost), kind="stable").tolist()
        try:
            self._step_all(order)
        finally:
            self._actions = None
        infos = self._infos(range(self.num_envs))
        np.logical_or(self._terminations, self._truncations, out=self._autoreset)
        return (self._obs.copy(), self._rewards.copy(), self._terminations.copy(), self._truncations.copy(), infos)

    def render(self):
        """Every robot's frame (``render_mode="rgb_array"``), as a tuple."""
        return tuple(env.render() for env in self.envs)

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Call method ``name`` of every robot's env (or read the attribute), as ``SyncVectorEnv.call``."""
        out = []
        for env in self.envs:
            attr = getattr(env, name)
            out.append(attr(*args, **kwargs) if callable(attr) else attr)
        return tuple(out)

    def get_attr(self, name: str) -> tuple:
        """Attribute ``name`` of every robot's env."""
        return tuple(getattr(env, name) for env in self.envs)

    def set_attr(self, name: str, values) -> None:
        """Set attribute ``name`` of every robot's env: one value each (a list or tuple of ``num_envs``), or
        the same value for all."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(f"values must hold {self.num_envs} values (one per robot), got {len(values)}.")
        for env, v in zip(self.envs, values, strict=True):
            setattr(env, name, v)

    def close_extras(self, **kwargs) -> None:
        """Stop the thread pool and close every robot's env."""
        team = getattr(self, "_team", None)
        if team is not None:
            team.close()
        for env in getattr(self, "envs", ()):
            env.close()


class MagSoftChannelVecEnv(MagSoftCrawlVecEnv):
    """:class:`MagSoftCrawlVecEnv` of :class:`~magsoft_env.envs.channel.MagSoftChannelEnv` (``MagSoftChannel-v1``)."""

    env_class = MagSoftChannelEnv


class MagSoftObstacleVecEnv(MagSoftCrawlVecEnv):
    """:class:`MagSoftCrawlVecEnv` of :class:`~magsoft_env.envs.obstacle.MagSoftObstacleEnv` (``MagSoftObstacle-v1``).
    """

    env_class = MagSoftObstacleEnv


class MagSoftSteerVecEnv(MagSoftCrawlVecEnv):
    """:class:`MagSoftCrawlVecEnv` of :class:`~magsoft_env.envs.steer.MagSoftSteerEnv` (``MagSoftSteer-v0``): the
    3D strips on threads (each step's couples are written from Python, so the threads share the GIL for part of
    every substep). CPU only: ``backend="warp"`` is refused."""

    env_class = MagSoftSteerEnv

    def __new__(cls, num_envs: int = 1, *, backend: str = "cpu", **kwargs):
        if backend != "cpu":
            raise ValueError(f"MagSoftSteer-v0 runs on backend 'cpu' only (the 3D strip is not on MuJoCo Warp), "
                             f"got backend={backend!r}.")
        return VectorEnv.__new__(cls)


__all__ = ["MagSoftChannelVecEnv", "MagSoftCrawlVecEnv", "MagSoftObstacleVecEnv", "MagSoftSteerVecEnv", "ThreadTeam",
           "refuse_warp_rod", "reset_arguments", "route_warnings", "usable_cpus", "with_sink"]

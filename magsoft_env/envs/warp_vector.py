"""``gym.make_vec("MagSoftCrawl-v1", num_envs=n, backend="warp")``: the floor crawl env's robots as MuJoCo Warp worlds.

:class:`MagSoftCrawlWarpVecEnv` keeps the CPU batch's contract (:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`:
spaces, observations, rewards, crawl limits at every substep, terminations, truncations, ``info`` keys,
``AutoresetMode.NEXT_STEP``, ``reset(options={"reset_mask": mask})``) on a
:class:`~magsoft_env.sim.warp_batch.WarpRodBatch`: one env step is one replay of a captured graph (the fields
written per world, ``n_substeps`` MJWarp steps, each followed by the crawl-limit and contact-depth reductions on
the device, the end state's kinematics); the host reads one copy of the small per-world arrays and computes
observations, rewards, terminations and ``info`` with the single env's own functions over the worlds
(:mod:`magsoft_env.envs.crawl_task`, ``n = num_envs``); the batch's readouts and health checks are
:class:`~magsoft_env.sim.warp_batch.WarpRodBatch`'s, its failures the C simulator's errors
(:mod:`magsoft_env.sim.health`).

Differences from the CPU batch, all stated in docs/gpu.md:

- MJWarp steps in float32 with a solver tolerance of at least 1e-6, and the rod starts each episode from a state
  settled in C (the straight beam lying on the floor at zero field for ``settle_time``, then the reset noise on
  its hinges: the same noise draws as the CPU batch's under the same seeds), not from the beam built at exactly
  zero contact distance, where float32 and float64 disagree on which contacts exist.
- Health checks per world on the device's records: a non-finite state, kinetic energy above 100 x the energy
  scale and the energy drift ("launch") at the C simulator's checkpoints, a contact deeper than the penetration
  limit, the centreline below the floor by more than it, an MJWarp buffer overflow; all but the penetration are
  reported at the end of the env step. MuJoCo's C warnings do not exist there.
- ``MagSoftCrawl-v1`` and ``MagSoftCrawlWaveform-v1`` (field and waveform modes) on the planar chain, without
  ``slew_rate`` or rendering; the channel and obstacle ids and ``rod="cable"`` refuse ``backend="warp"``.
- Per-world parameters: ``friction`` (the rod-floor pairs' sliding friction) and ``field_scale`` (a factor on the
  applied field) may be given one per world.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..rods import DEFAULT_ROD
from ..sim.health import FIELD_FLOOR
from ..sim.warp_batch import WarpRodBatch
from . import instability_info
from .batching import count as _count
from .batching import refuse_warp_rod, reset_arguments
from .crawl import MagSoftCrawlEnv
from .crawl_task import (
    AIRBORNE_TOLERANCE,
    NONFINITE_OBSERVATION,
    CrawlRecords,
    clock_tail,
    crawl_info,
    crawl_limits,
    crawl_reward,
    observation,
    period_substeps,
    stack_infos,
    vector_info,
    violation_texts,
    wave_rows,
    zero_terms,
)

#: Simulated time (s) the straight beam settles on the floor at zero field, in C, before the batch starts from it.
DEFAULT_SETTLE_TIME = 0.05
_MODES = {"none": 0, "rotation": 1, "height": 2}
#: The ids ``backend="warp"`` runs.
SUPPORTED_IDS = ("MagSoftCrawl-v1", "MagSoftCrawlWaveform-v1")
#: Substeps per graph of a waveform period (and between its energy checks, as the C simulator's waveform mode).
WAVE_BLOCK = 100


class MagSoftCrawlWarpVecEnv(VectorEnv):
    """
    ## Description

    ``num_envs`` robots of :class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv` (field or waveform mode) as MuJoCo
    Warp worlds, the ``backend="warp"`` of ``gym.make_vec("MagSoftCrawl-v1", num_envs=n, backend="warp")`` and of
    ``MagSoftCrawlWaveform-v1`` (the optional extra ``warp``). In waveform mode each world plays its own period
    (its own number of substeps) from a per-world step counter; the batch steps until the longest ends. Spaces,
    observations, rewards, the crawl limits at every substep, terminations, truncations, ``info`` and
    ``AutoresetMode.NEXT_STEP`` are the CPU batch's
    (:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`), computed by the same functions
    (:mod:`magsoft_env.envs.crawl_task`, with ``n = num_envs``; the health checks' errors by
    :mod:`magsoft_env.sim.health`'s); the numbers are MJWarp's float32 physics from a start state settled in C
    (module docstring, docs/gpu.md). The planar hinge chain only: ``rod="cable"`` (the 3D strip) is refused.

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``num_envs`` | 1 | robots (worlds) |
    | ``max_episode_steps`` | None | time limit (steps); ``gym.make_vec`` passes the registered one |
    | ``device`` | None | Warp device (``"cpu"``, ``"cuda:0"``); None: Warp's default (a GPU where there is one) |
    | ``graph`` | True | replay one captured graph per env step (False: launch the kernels each step) |
    | ``settle_time`` | 0.05 | simulated time (s) the beam settles on the floor in C before every episode |
    | ``nconmax``, ``njmax`` | None | MJWarp contacts and constraint rows per world (None: sized for the rod) |
    | ``friction`` | None | rod-floor sliding friction: one number (as the single env) or one per world |
    | ``field_scale`` | None | factor on each world's applied field, one number or one per world (None: 1); |
    | | | observations, rewards and ``info["field"]`` keep the commanded field |
    | ``**kwargs`` | | the single env's arguments (``robot``, ``field_limit``, ``segments``, ...) |

    Examples
    --------
    >>> import gymnasium as gym, numpy as np, magsoft_env
    >>> envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, backend="warp", device="cpu", segments=4, sim_dt=1e-3)
    >>> obs, info = envs.reset(seed=0)
    >>> obs.shape
    (2, 16)
    >>> obs, reward, terminated, truncated, info = envs.step(np.zeros((2, 2), np.float32))
    >>> reward.shape, bool(np.all(np.isfinite(obs)))
    ((2,), True)
    >>> envs.close()
    """

    def __init__(self, num_envs: int = 1, *, max_episode_steps: int | None = None, device=None, graph: bool = True,
                 settle_time: float = DEFAULT_SETTLE_TIME, nconmax: int | None = None, njmax: int | None = None,
                 friction=None, field_scale=None, env_class=MagSoftCrawlEnv, **kwargs):
        if env_class is not MagSoftCrawlEnv:
            raise ValueError(f"backend='warp' runs {' and '.join(SUPPORTED_IDS)} (the floor), not "
                             f"{env_class.__name__} (its scene's walls and block are not built for MJWarp here); "
                             "use the CPU batch (backend='cpu') for MagSoftChannel-v1 and MagSoftObstacle-v1.")
        refuse_warp_rod(kwargs.get("rod", DEFAULT_ROD))
        if kwargs.get("friction_range") is not None:
            raise ValueError("backend='warp' does not draw friction_range at resets (its worlds reset on the device); "
                             "give one friction per world instead (friction=[...]), or use backend='cpu'.")
        material = [name for name in ("modulus_range", "magnetization_range") if kwargs.get(name) is not None]
        if material:
            raise ValueError(f"backend='warp' does not randomize the material ({' and '.join(material)}): its worlds "
                             "share one compiled model and reset on the device. It randomizes per world the friction "
                             "(friction=[...]) and the field's scale (field_scale=[...]); use backend='cpu' (the C "
                             "batch draws modulus_range and magnetization_range at every reset).")
        self.num_envs = _count("num_envs", num_envs)
        self.max_episode_steps = None if max_episode_steps is None else _count("max_episode_steps", max_episode_steps)
        if not (isinstance(settle_time, (int, float)) and math.isfinite(settle_time) and settle_time >= 0):
            raise ValueError(f"settle_time must be a finite number of seconds >= 0, got {settle_time!r}.")
        per_world_friction = friction is not None and np.ndim(friction) > 0
        proto = env_class(**kwargs) if per_world_friction else env_class(friction=friction, **kwargs)
        refuse_warp_rod(proto.rod)
        if proto.slew_rate is not None or proto.render_mode is not None:
            raise ValueError("backend='warp' runs without slew_rate or rendering (slew_rate=None, render_mode=None), "
                             f"got slew_rate={proto.slew_rate!r}, render_mode={proto.render_mode!r}; use the CPU "
                             "batch for them.")
        self.action_mode = proto.action_mode
        self.proto = proto
        sim = proto.sim
        self.single_observation_space = proto.observation_space
        self.single_action_space = proto.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.metadata = {**proto.metadata, "autoreset_mode": AutoresetMode.NEXT_STEP}
        self.render_mode = None
        self.settle_time = float(settle_time)
        # the start state: the straight beam settled on the floor at zero field, in C
        sim.reset()
        sim.set_field((0.0, 0.0))
        sim.step(int(round(self.settle_time / proto.sim_dt)))
        self._qpos_settled = sim.state()[0]
        self._qvel_settled = np.zeros(sim.model.nv)
        # the rest state the reset noise perturbs (a draw of zero width: the rest state itself)
        self._qpos_rest = sim.noisy_rest(np.random.default_rng(0), 0.0)
        self._half_h = 0.5 * proto.gait.beam.thickness
        task = proto.task
        limits = {"half_thickness": self._half_h,
                  "max_clearance": math.inf if task.max_clearance is None or task.crawl_mode == "none"
                  else task.max_clearance,
                  "cos_rotation": task.cos_rotation, "max_height": task.max_height, "mode": _MODES[task.crawl_mode],
                  "airborne_tolerance": AIRBORNE_TOLERANCE, "penetration_limit": sim.penetration_limit}
        self.batch = WarpRodBatch(sim.rod, sim.data, self.num_envs, limits=limits, device=device, graph=graph,
                                  nconmax=nconmax, njmax=njmax, backend=sim.backend,
                                  friction=friction if per_world_friction else None, field_scale=field_scale,
                                  block=WAVE_BLOCK)
        #: Every world's rod-floor sliding friction and field scale (what the device holds)
        self.friction = (self.batch.friction if per_world_friction
                         else np.full(self.num_envs, float(sim.model.pair_friction[0, 0]) if sim.model.npair
                                      else math.nan))
        self.field_scale = self.batch.field_scale
        self.device = str(self.batch.device)
        self._inv_piece_length = 1.0 / self.batch.piece_lengths
        self._pen_limit = sim.penetration_limit
        self._dt = proto.sim_dt
        self._k = proto.n_substeps
        n = self.num_envs
        self._rngs: list = [None] * n
        self._obs = np.zeros((n, *self.single_observation_space.shape), dtype=np.float32)
        self._high = self.single_observation_space.high
        #: the episodes' records (the crawl task's, n = num_envs)
        self._records = CrawlRecords.zeros(n)
        self._clock = np.zeros(n, dtype=np.int64)  # substeps run in the episode: the world's time
        self._elapsed = np.zeros(n, dtype=np.int64)
        self._max_pen = np.zeros(n)
        self._drift = np.zeros(n)
        self._autoreset = np.zeros(n, dtype=bool)
        self._state: dict = {}
        #: Every world's start state of its present episode (float64, before the device's float32)
        self.start_qpos = np.tile(self._qpos_settled, (n, 1))

    def __repr__(self) -> str:
        name = SUPPORTED_IDS[self.action_mode == "waveform"]
        return f"{type(self).__name__}({name}, num_envs={self.num_envs}, device={self.device!r})"

    # ------------------------------------------------------------------ the crawl task over the worlds
    def _observe(self, s, time, task) -> np.ndarray:
        rec = self._records
        tail = clock_tail(rec.field, time, task) if self.action_mode == "field" else rec.last_action
        return observation(self.batch.angles(s), self.batch.angular_velocities(s), rec.com_velocity, tail, self._high)

    def _info(self, s, time, reward, terms) -> dict:
        return crawl_info(self._records, orientation=self.batch.orientation(s), reward=reward, terms=terms,
                          time=time, max_penetration=self._max_pen.copy(), is_success=np.zeros(self.num_envs, bool))

    # ------------------------------------------------------------------ resets
    def _start_states(self, ids, seeds) -> tuple[np.ndarray, np.ndarray]:
        """Per-world start states: the settled beam plus each world's reset noise (the single env's draw,
        :meth:`Simulator.noisy_rest <magsoft_env.sim.Simulator.noisy_rest>`, after seeding)."""
        n = self.num_envs
        qpos = np.tile(self._qpos_settled, (n, 1))
        qvel = np.tile(self._qvel_settled, (n, 1))
        sim, scale = self.proto.sim, self.proto.reset_noise_scale
        for i in ids:
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(seeds[i])  # as gymnasium.Env.reset seeds the single env
            qpos[i] += sim.noisy_rest(self._rngs[i], scale) - self._qpos_rest
        return qpos, qvel

    def _reset_worlds(self, mask: np.ndarray, seeds) -> None:
        qpos, qvel = self._start_states(np.flatnonzero(mask).tolist(), seeds)
        self.start_qpos[mask] = qpos[mask]
        self.batch.reset_worlds(mask, qpos, qvel)
        s = self._state = self.batch.state()
        start = crawl_limits(self.batch.centreline(s)[:, :, None, :], np.zeros(self.num_envs),
                             half_thickness=self._half_h, inv_piece_length=self._inv_piece_length)[:, :, 0]
        self._records.restart(mask, com=self.batch.com(s), start_limits=start)
        for a in (self._clock, self._elapsed, self._max_pen, self._drift):
            a[mask] = 0
        self._autoreset[mask] = False
        self._obs[mask] = self._observe(s, self._clock * self._dt, self.proto.task)[mask]

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every robot (or those of ``options["reset_mask"]``); ``seed`` as the CPU batch's (robot ``i`` gets
        ``seed + i``)."""
        n = self.num_envs
        seeds, mask, rest = reset_arguments(seed, options, n)
        if rest:
            raise ValueError(f"backend='warp' takes only options['reset_mask'], got {sorted(rest)}.")
        mask = np.ones(n, dtype=bool) if mask is None else mask
        self._reset_worlds(mask, seeds)
        s = self._state
        info = vector_info(self._info(s, self._clock * self._dt, np.zeros(n), zero_terms(n)), mask)
        return self._obs.copy(), info

    # ------------------------------------------------------------------ the step
    def step(self, actions):
        """Step every world with its row of ``actions``; a world whose episode ended at the last step is reset
        instead (NEXT_STEP autoreset: its action is ignored, reward 0, reset observation and info)."""
        a = np.asarray(actions, dtype=float)
        if a.shape != self.action_space.shape:
            raise ValueError(f"actions must have shape {self.action_space.shape} (num_envs, action), got {a.shape}.")
        if not np.all(np.isfinite(a)):
            raise ValueError("actions must be finite numbers.")
        n, batch, rec = self.num_envs, self.batch, self._records
        task = self.proto.task
        resetting = self._autoreset.copy()
        stepping = ~resetting
        k, power = self._advance(a, resetting, task)
        s = self._state = batch.state()
        self._clock[stepping] += k[stepping]
        time = self._clock * self._dt
        old_obs = self._obs.copy()
        self._max_pen[stepping] = np.maximum(self._max_pen, np.maximum(s["depth"], 0.0))[stepping]

        # health, per world: a failing world truncates with the C simulator's error (SimulationError in the single
        # env) and books nothing of its step but its field
        failures = batch.failures(s, stepping, nstep=self._clock, time=time, substeps=k,
                                  penetration_limit=self._pen_limit, max_penetration=self._max_pen,
                                  energy_drift=self._drift)
        ok = stepping.copy()
        ok[list(failures)] = False
        if "drift" in s:
            self._drift[ok] = np.maximum(self._drift, s["drift"])[ok]
        rec.book(ok, com=batch.com(s), duration=k * self._dt, highest_clearance=s["clear_max"],
                 lowest_cos=s["cos_min"], airborne=s["airborne"], substeps=k)

        # crawl limits at every substep (the device's records), the reward, the observation
        column = s["violation"]
        violated = ok & (column != -1) & (task.crawl_mode != "none")
        reward, terms = crawl_reward(rec.com_velocity[:, 0], power, violated, rec.episode_forward, task)
        rec.episode_forward[ok] += terms["forward"][ok]
        obs = self._observe(s, time, task)
        bad_obs = ok & ~np.isfinite(obs).all(axis=1)
        failed = ~ok | bad_obs  # the resetting worlds' step is replaced below
        reward = np.where(failed, 0.0, reward)
        terms = {key: np.where(failed, 0.0, v) for key, v in terms.items()}
        self._obs = np.where(failed[:, None], old_obs, obs).astype(np.float32)
        terminated = violated & ~bad_obs
        truncated = stepping & failed
        self._elapsed[stepping] += 1
        if self.max_episode_steps is not None:
            truncated |= stepping & (self._elapsed >= self.max_episode_steps)
        infos = vector_info(self._info(s, time, reward, terms))
        if terminated.any():
            # column j: the state j substeps into the step (-2: its end state)
            when = time - (k - np.where(column == -2, k, column)) * self._dt
            infos.update(vector_info({"crawl_violation": violation_texts(s["figures"], when, task, terminated)},
                                     terminated))
        ends = {i: instability_info({}, err) for i, err in failures.items()}
        ends.update({i: dict(NONFINITE_OBSERVATION) for i in np.flatnonzero(bad_obs).tolist()})
        infos.update(stack_infos(ends, n))
        if resetting.any():
            self._autoreset_worlds(resetting, infos)
            reward[resetting] = 0.0
            terminated[resetting] = truncated[resetting] = False
        np.logical_or(terminated, truncated, out=self._autoreset)
        return self._obs.copy(), reward, terminated, truncated, infos

    def _advance(self, actions: np.ndarray, resetting: np.ndarray, task) -> tuple[np.ndarray, np.ndarray]:
        """Apply every world's action (those of ``resetting``: none) and run the batch: returns each world's
        substeps and mean normalized field power; the records take the field (and the last waveform action)."""
        n, batch, rec, stepping = self.num_envs, self.batch, self._records, ~resetting
        energy_scale = self.proto.sim.backend.energy_scale
        act = np.clip(actions, -1.0, 1.0)
        act[resetting] = 0.0
        if self.action_mode == "field":
            field = act * task.field_limit
            power = np.sum(field**2, axis=1) / task.field_limit**2
            batch.set_fields(field)
            batch.set_energy_scale(energy_scale(np.maximum(np.hypot(field[:, 0], field[:, 1]) * self.field_scale,
                                                           FIELD_FLOOR)))
            batch.advance(self._k)
            k = np.full(n, self._k, dtype=np.int64)
        else:
            waves = wave_rows(act, field_limit=task.field_limit, frequency_range=self.proto.frequency_range)
            k = period_substeps(waves[:, 2], self._dt)
            k[resetting] = 1  # reset after this step: one substep, so that it never sets the batch's length
            power = 0.5 * (waves[:, 0] ** 2 + waves[:, 1] ** 2) / task.field_limit**2
            batch.set_waveforms(waves, k)
            batch.set_energy_scale(energy_scale(np.maximum(self._peaks(waves) * self.field_scale, FIELD_FLOOR)))
            batch.advance_waveforms()
            field = np.zeros((n, 2))  # a whole period ends where it began
            rec.last_action[stepping] = act[stepping]
        rec.field[stepping] = field[stepping]
        return k, power

    def _autoreset_worlds(self, mask: np.ndarray, infos: dict) -> None:
        """NEXT_STEP autoreset: the worlds of ``mask`` ended last step and start again; their entries of ``infos``
        become their reset's (the step they were given is discarded)."""
        n = self.num_envs
        self._reset_worlds(mask, [None] * n)
        reset_info = self._info(self._state, self._clock * self._dt, np.zeros(n), zero_terms(n))
        for key, v in reset_info.items():
            infos[key] = np.where(mask if np.ndim(v) == 1 else mask[:, None], v, infos[key])
        for key in list(infos):
            if key.startswith("_") and key[1:] not in reset_info:
                infos[key] = infos[key] & ~mask

    @staticmethod
    def _peaks(waves: np.ndarray) -> np.ndarray:
        """Peak field (T) of each world's waveform as the C simulator takes it for its energy scale: the largest
        |B_x| and |B_z| over 257 samples of its first second, combined."""
        t = np.linspace(0.0, 1.0, 257)
        w = 2.0 * np.pi * waves[:, 2:3] * t
        bx = np.abs(waves[:, 0:1] * np.sin(w + waves[:, 3:4])).max(axis=1)
        bz = np.abs(waves[:, 1:2] * np.sin(w)).max(axis=1)
        return np.hypot(bx, bz)

    # ------------------------------------------------------------------ the rest of the VectorEnv API
    def qpos(self) -> np.ndarray:
        """Joint positions of every world, ``(num_envs, nq)`` (float64 copy of the device's float32)."""
        return self.batch.qpos()

    def render(self):
        """No rendering on the Warp backend (None)."""
        return None

    def get_attr(self, name: str) -> tuple:
        """Attribute ``name`` of the worlds' env: all worlds share one parameter set (the prototype single env's)."""
        return (getattr(self.proto, name),) * self.num_envs

    def call(self, name: str, *args, **kwargs) -> tuple:
        """Method ``name`` of the prototype single env (or its attribute), once, as every world's value."""
        attr = getattr(self.proto, name)
        value = attr(*args, **kwargs) if callable(attr) else attr
        return (value,) * self.num_envs

    def set_attr(self, name: str, values) -> None:
        """Set attribute ``name`` of the worlds' shared env (one value for all: the worlds share their parameters;
        those read on the host, such as the reward weights, take effect at the next step)."""
        if isinstance(values, (list, tuple)):
            if len(values) != self.num_envs or any(v is not values[0] and v != values[0] for v in values):
                raise ValueError("backend='warp' worlds share their parameters: set_attr takes one value for all.")
            values = values[0]
        setattr(self.proto, name, values)

    def close_extras(self, **kwargs) -> None:
        """Close the prototype env; the device arrays go with the batch."""
        proto = getattr(self, "proto", None)
        if proto is not None:
            proto.close()


__all__ = ["DEFAULT_SETTLE_TIME", "SUPPORTED_IDS", "MagSoftCrawlWarpVecEnv"]

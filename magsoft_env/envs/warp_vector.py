"""``gym.make_vec("MagSoftCrawl-v1", num_envs=n, backend="warp")``: the floor crawl env's robots as MuJoCo Warp worlds.

:class:`MagSoftCrawlWarpVecEnv` keeps the CPU batch's contract (:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`:
spaces, observations, rewards, crawl limits at every substep, terminations, truncations, ``info`` keys,
``AutoresetMode.NEXT_STEP``, ``reset(options={"reset_mask": mask})``) on a
:class:`~magsoft_env.sim.warp_batch.WarpRodBatch`: one env step is one replay of a captured graph (the fields
written per world, ``n_substeps`` MJWarp steps, each followed by the crawl-limit and contact-depth reductions on
the device, the end state's kinematics); the host reads one copy of the small per-world arrays and computes
observations, rewards and ``info`` vectorized over the worlds.

Differences from the CPU batch, all stated in docs/gpu.md:

- MJWarp steps in float32 with a solver tolerance of at least 1e-6, and the rod starts each episode from a state
  settled in C (the straight beam lying on the floor at zero field for ``settle_time``, then the reset noise on
  its hinges: the same noise draws as the CPU batch's under the same seeds), not from the beam built at exactly
  zero contact distance, where float32 and float64 disagree on which contacts exist.
- Health checks per world on the device's records: a non-finite state, kinetic energy above 100 x the energy
  scale and the energy drift ("launch") at the C simulator's checkpoints, a contact deeper than the penetration
  limit, the centreline below the floor by more than it, an MJWarp buffer overflow. MuJoCo's C warnings do not
  exist there.
- ``MagSoftCrawl-v1`` and ``MagSoftCrawlWaveform-v1`` (field and waveform modes) without ``slew_rate`` or
  rendering; the channel and obstacle ids refuse ``backend="warp"``.
- Per-world parameters: ``friction`` (the rod-floor pairs' sliding friction) and ``field_scale`` (a factor on the
  applied field) may be given one per world.
"""

from __future__ import annotations

import math

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ..sim.health import ENERGY_DRIFT_LIMIT, FIELD_FLOOR, RUNAWAY_FACTOR
from ..sim.readouts import FLIP_ANGLE
from ..sim.warp_batch import BUFFER_OVERFLOWS, WarpRodBatch
from .crawl import AIRBORNE_TOLERANCE, MagSoftCrawlEnv
from .vector import _count

#: Simulated time (s) the straight beam settles on the floor at zero field, in C, before the batch starts from it.
DEFAULT_SETTLE_TIME = 0.05
_TURN = 2.0 * math.pi
_MODES = {"none": 0, "rotation": 1, "height": 2}
#: The ids ``backend="warp"`` runs.
SUPPORTED_IDS = ("MagSoftCrawl-v1", "MagSoftCrawlWaveform-v1")
#: Substeps per graph of a waveform period (and between its energy checks, as the C simulator's waveform mode).
WAVE_BLOCK = 100


def _vector_info(values: dict, mask: np.ndarray | None = None) -> dict:
    """Gymnasium's vector ``info``: each key an array over the worlds and ``"_" + key`` its mask."""
    out = {}
    for key, v in values.items():
        out[key] = v
        out["_" + key] = np.ones(len(v), dtype=bool) if mask is None else mask.copy()
    return out


class MagSoftCrawlWarpVecEnv(VectorEnv):
    """
    ## Description

    ``num_envs`` robots of :class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv` (field or waveform mode) as MuJoCo
    Warp worlds, the ``backend="warp"`` of ``gym.make_vec("MagSoftCrawl-v1", num_envs=n, backend="warp")`` and of
    ``MagSoftCrawlWaveform-v1`` (the optional extra ``warp``). In waveform mode each world plays its own period
    (its own number of substeps) from a per-world step counter; the batch steps until the longest ends. Spaces,
    observations, rewards, the crawl limits at every substep, terminations, truncations, ``info`` and
    ``AutoresetMode.NEXT_STEP`` are the CPU batch's
    (:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`); the numbers are MJWarp's float32 physics from a
    start state settled in C (module docstring, docs/gpu.md).

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
        self.num_envs = _count("num_envs", num_envs)
        self.max_episode_steps = None if max_episode_steps is None else _count("max_episode_steps", max_episode_steps)
        if not (isinstance(settle_time, (int, float)) and math.isfinite(settle_time) and settle_time >= 0):
            raise ValueError(f"settle_time must be a finite number of seconds >= 0, got {settle_time!r}.")
        per_world_friction = friction is not None and np.ndim(friction) > 0
        proto = env_class(**kwargs) if per_world_friction else env_class(friction=friction, **kwargs)
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
        self._qpos_settled = sim.data.qpos.copy()
        self._qvel_settled = np.zeros(sim.model.nv)
        rod = sim.rod
        if sim.model.nq != sim.model.nv:
            raise RuntimeError("the planar rod's joints are hinges and slides (nq == nv)")  # guaranteed by build_model
        self._hinge_qpos = np.asarray(rod.hinge_qpos)
        self._h = proto.gait.beam.thickness
        cm = proto.crawl_mode
        limits = {"half_thickness": 0.5 * self._h, "inv_piece_length": proto._inv_piece_length.ravel(),
                  "max_clearance": math.inf if proto.max_clearance is None or cm == "none" else proto.max_clearance,
                  "cos_rotation": proto.task.cos_rotation, "max_height": proto.max_height, "mode": _MODES[cm],
                  "airborne_tolerance": AIRBORNE_TOLERANCE}
        self.batch = WarpRodBatch(rod, sim.data, self.num_envs, limits=limits, device=device, graph=graph,
                                  nconmax=nconmax, njmax=njmax, backend=sim.backend,
                                  friction=friction if per_world_friction else None, field_scale=field_scale,
                                  block=WAVE_BLOCK)
        #: Every world's rod-floor sliding friction and field scale (what the device holds)
        self.friction = (self.batch.friction if per_world_friction
                         else np.full(self.num_envs, float(sim.model.pair_friction[0, 0]) if sim.model.npair
                                      else math.nan))
        self.field_scale = self.batch.field_scale
        self._energy_on = bool(sim._health.energy_on)
        self.device = str(self.batch.device)
        backend = sim.backend
        self._mass = np.asarray(rod.disc.mass, dtype=float)
        bodies = np.asarray(rod.body_ids)
        self._omega_map = backend._angles[0][:, bodies - backend.b0]  # (nv, pieces): piece angle about y per qvel
        w = np.diff(backend.arc_length())
        self._piece_w, self._piece_total = w, float(w.sum())
        self._tip_len = backend.tip_len
        self._base_angle = float(backend.options.clamp_angle)
        self._base_qpos = int(rod.base_qpos[2]) if rod.base_qpos.size else -1
        self._tip_hinges = self._hinge_qpos[backend.options.base_piece:]
        self._pen_limit = sim.penetration_limit
        self._dt = proto.sim_dt
        self._k = proto.n_substeps
        n = self.num_envs
        self._rngs: list = [None] * n
        self._obs = np.zeros((n, *self.single_observation_space.shape), dtype=np.float32)
        self._field = np.zeros((n, 2))
        self._last_action = np.zeros((n, 4))
        self._com = np.zeros((n, 2))
        self._com_vel = np.zeros((n, 2))
        self._episode_forward = np.zeros(n)
        self._flipped = np.zeros(n, dtype=bool)
        self._highest_clearance = np.zeros(n)
        self._lowest_cos = np.ones(n)
        self._airborne = np.zeros(n, dtype=np.int64)
        self._substeps = np.zeros(n, dtype=np.int64)
        self._elapsed = np.zeros(n, dtype=np.int64)
        self._max_pen = np.zeros(n)
        self._autoreset = np.zeros(n, dtype=bool)
        self._state: dict = {}
        #: Every world's start state of its present episode (float64, before the device's float32)
        self.start_qpos = np.tile(self._qpos_settled, (n, 1))

    def __repr__(self) -> str:
        name = SUPPORTED_IDS[self.action_mode == "waveform"]
        return f"{type(self).__name__}({name}, num_envs={self.num_envs}, device={self.device!r})"

    # ------------------------------------------------------------------ readouts, vectorized over the worlds
    def _angles(self, s) -> np.ndarray:
        R = s["xmat"].reshape(self.num_envs, -1, 9)
        return np.arctan2(R[:, :, 6], R[:, :, 0])

    def _orientation(self, s, angles) -> np.ndarray:
        q = s["qpos"]
        anchor = self._base_angle + q[:, self._tip_hinges].sum(axis=1)
        if self._base_qpos >= 0:
            anchor = anchor + q[:, self._base_qpos]
        rel = np.cumsum(np.remainder(np.diff(angles, axis=1) + math.pi, _TURN) - math.pi, axis=1)
        first = angles[:, 0]
        last = first + (rel[:, -1] if rel.shape[1] else 0.0)
        with np.errstate(invalid="ignore"):
            first = first + _TURN * np.round((anchor - last) / _TURN)
        out = first + rel @ self._piece_w[1:] / self._piece_total
        return np.where(np.isfinite(anchor), out, np.nan)

    def _com_of(self, s) -> np.ndarray:
        p = s["xipos"]
        return np.stack([p[:, :, 0] @ self._mass, p[:, :, 2] @ self._mass], axis=1) / self._mass.sum()

    def _centreline_limits(self, s) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Clearance, highest point and cos of the largest piece angle of every world's present state."""
        p, R = s["xpos"], s["xmat"].reshape(self.num_envs, -1, 9)
        x = np.concatenate([p[:, :, 0], p[:, -1:, 0] + self._tip_len * R[:, -1:, 0]], axis=1)
        z = np.concatenate([p[:, :, 2], p[:, -1:, 2] + self._tip_len * R[:, -1:, 6]], axis=1)
        cos = (np.diff(x, axis=1) * self.proto._inv_piece_length.ravel()).min(axis=1)
        return z.min(axis=1) - 0.5 * self._h, z.max(axis=1), cos

    def _observe(self, s, angles) -> np.ndarray:
        omega = -(s["qvel"] @ self._omega_map)
        if self.action_mode == "waveform":
            tail = self._last_action
        else:
            t = self._substeps * self._dt
            w = 2.0 * math.pi * self.proto.clock_frequency * t
            tail = np.column_stack([self._field / self.proto.field_limit, np.sin(w), np.cos(w)])
        obs = np.concatenate([angles, omega, self._com_vel, tail], axis=1).astype(np.float32)
        return np.clip(obs, self.single_observation_space.low, self.single_observation_space.high)

    def _info(self, s, angles, reward, forward, field_cost, crawl) -> dict:
        turn = self._orientation(s, angles)
        self._flipped |= np.abs(turn) > FLIP_ANGLE
        n = self.num_envs
        frac = np.divide(self._airborne, self._substeps, out=np.zeros(n), where=self._substeps > 0)
        return {
            "orientation": turn, "flipped": self._flipped.copy(),
            "reward_forward": forward, "reward_field": field_cost, "reward_crawl": crawl,
            "reward_success": np.zeros(n), "reward": reward,
            "x_position": self._com[:, 0].copy(), "z_position": self._com[:, 1].copy(),
            "x_velocity": self._com_vel[:, 0].copy(), "field": self._field.copy(), "time": self._substeps * self._dt,
            "is_success": np.zeros(n, dtype=bool), "max_penetration": self._max_pen.copy(),
            "highest_clearance": self._highest_clearance.copy(), "airborne_fraction": frac,
            "largest_piece_angle": np.arccos(np.clip(self._lowest_cos, -1.0, 1.0)),
        }

    # ------------------------------------------------------------------ resets
    def _start_states(self, ids, seeds) -> tuple[np.ndarray, np.ndarray]:
        """Per-world start states: the settled beam plus each world's reset noise on its hinges (the single env's
        draw: ``np_random.uniform(-scale, scale, segments)`` after seeding)."""
        n = self.num_envs
        qpos = np.tile(self._qpos_settled, (n, 1))
        qvel = np.tile(self._qvel_settled, (n, 1))
        scale = self.proto.reset_noise_scale
        for i in ids:
            if seeds[i] is not None or self._rngs[i] is None:
                self._rngs[i], _ = seeding.np_random(seeds[i])
            qpos[i, self._hinge_qpos] += self._rngs[i].uniform(-scale, scale, self.proto.segments)
        return qpos, qvel

    def _reset_worlds(self, mask: np.ndarray, seeds) -> None:
        ids = np.flatnonzero(mask).tolist()
        qpos, qvel = self._start_states(ids, seeds)
        self.start_qpos[mask] = qpos[mask]
        self.batch.reset_worlds(mask, qpos, qvel)
        s = self.batch.state()
        self._state = s
        m = mask
        self._field[m] = 0.0
        self._last_action[m] = 0.0
        self._com[m] = self._com_of(s)[m]
        self._com_vel[m] = 0.0
        self._episode_forward[m] = 0.0
        self._flipped[m] = False
        clear, _, cos = self._centreline_limits(s)
        self._highest_clearance[m] = clear[m]
        self._lowest_cos[m] = cos[m]
        self._airborne[m] = 0
        self._substeps[m] = 0
        self._elapsed[m] = 0
        self._max_pen[m] = 0.0
        self._autoreset[m] = False
        angles = self._angles(s)
        self._obs[m] = self._observe(s, angles)[m]

    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None):
        """Reset every robot (or those of ``options["reset_mask"]``); ``seed`` as the CPU batch's (robot ``i`` gets
        ``seed + i``)."""
        n = self.num_envs
        if seed is None:
            seeds = [None] * n
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
            seeds = [int(seed) + i for i in range(n)]
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(f"seed must be None, an int or a list of {n} seeds (one per robot), got {seed!r}.")
        options = dict(options) if options else {}
        mask = options.pop("reset_mask", None)
        if options:
            raise ValueError(f"backend='warp' takes only options['reset_mask'], got {sorted(options)}.")
        if mask is None:
            mask = np.ones(n, dtype=bool)
        elif not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
            raise ValueError(f"options['reset_mask'] must be a boolean numpy array of shape ({n},), got {mask!r}.")
        elif not mask.any():
            raise ValueError("options['reset_mask'] must select at least one robot, got none.")
        self._reset_worlds(mask, seeds)
        s = self._state
        z = np.zeros(n)
        info = _vector_info(self._info(s, self._angles(s), z, z, z, z), mask)
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
        n, proto = self.num_envs, self.proto
        resetting = self._autoreset.copy()
        stepping = ~resetting
        backend = proto.sim.backend
        if self.action_mode == "field":
            field = np.clip(a, -1.0, 1.0) * proto.field_limit
            field[resetting] = 0.0
            power = np.sum(field**2, axis=1) / proto.field_limit**2
            applied = np.hypot(field[:, 0], field[:, 1]) * self.field_scale
            self.batch.set_fields(field)
            self.batch.set_energy_scale(backend.energy_scale(np.maximum(applied, FIELD_FLOOR)))
            self.batch.advance(self._k)
            k = np.full(n, self._k, dtype=np.int64)
        else:
            act = np.clip(a, -1.0, 1.0)
            act[resetting] = 0.0
            waves, k = self._waves(act)
            k[resetting] = 1  # reset after this step: one substep, so that it never sets the batch's length
            power = 0.5 * (waves[:, 0] ** 2 + waves[:, 1] ** 2) / proto.field_limit**2
            self.batch.set_waveforms(waves, k)
            self.batch.set_energy_scale(backend.energy_scale(np.maximum(self._peaks(waves) * self.field_scale,
                                                                        FIELD_FLOOR)))
            self.batch.advance_waveforms()
            field = np.zeros((n, 2))  # a whole period ends where it began
            self._last_action[stepping] = act[stepping]
        s = self.batch.state()
        self._state = s
        duration = k * self._dt
        old_obs = self._obs.copy()
        self._field[stepping] = field[stepping]
        self._substeps[stepping] += k[stepping]
        com = self._com_of(s)
        self._com_vel[stepping] = ((com - self._com) / duration[:, None])[stepping]
        self._com[stepping] = com[stepping]
        self._highest_clearance = np.where(stepping, np.maximum(self._highest_clearance, s["clear_max"]),
                                           self._highest_clearance)
        self._lowest_cos = np.where(stepping, np.minimum(self._lowest_cos, s["cos_min"]), self._lowest_cos)
        self._airborne[stepping] += s["airborne"][stepping]
        depth = np.maximum(s["depth"], 0.0)
        self._max_pen[stepping] = np.maximum(self._max_pen, depth)[stepping]

        # health, per world (a failing world truncates, as a SimulationError in the single env)
        reasons: dict[int, tuple[str, str, str | None, dict]] = {}
        finite = np.isfinite(s["qpos"]).all(axis=1) & np.isfinite(s["qvel"]).all(axis=1)
        over = s["overflow"] & BUFFER_OVERFLOWS
        scale = self.batch._scale.numpy()
        ratio, drift = s["ke_ratio"], s["drift"]
        clear_end, _, _ = self._centreline_limits(s)
        for i in np.flatnonzero(stepping).tolist():
            if not finite[i]:
                reasons[i] = ("non-finite state (qpos or qvel) in MJWarp", "state", None, {})
            elif over[i]:
                reasons[i] = (f"MJWarp buffer overflow (OverflowType bits {int(over[i])}): raise nconmax / njmax",
                              "overflow", None, {})
            elif not ratio[i] <= RUNAWAY_FACTOR:
                reasons[i] = (f"runaway kinetic energy (J): {ratio[i] * scale[i]:.3g} > {RUNAWAY_FACTOR:g} x the "
                              f"energy scale {scale[i]:.3g} J", "runaway kinetic energy (J)", None, {})
            elif depth[i] > self._pen_limit:
                figs = {"penetration_m": float(depth[i]), "penetration_h": float(depth[i] / self._h)}
                reasons[i] = (f"penetration {depth[i] * 1e3:.3f} mm > {self._pen_limit * 1e3:.3f} mm",
                              "penetration (m)", "penetration", figs)
            elif clear_end[i] + 0.5 * self._h < -self._pen_limit:
                depth_t = -(clear_end[i] + 0.5 * self._h)
                figs = {"penetration_m": float(depth_t), "penetration_h": float(depth_t / self._h)}
                reasons[i] = (f"tunnelling: the centreline {depth_t * 1e3:.3f} mm below the floor",
                              "tunnelling (m)", "tunnelling", figs)
            elif self._energy_on and drift[i] > ENERGY_DRIFT_LIMIT:
                excess = float(drift[i] * scale[i])
                figs = {"energy_created_J": excess, "energy_drift": float(drift[i])}
                reasons[i] = (f"launch: the rod gained {excess:.3g} J more than the field supplied ({drift[i]:.3g} of "
                              f"the energy scale {scale[i]:.3g} J, limit {ENERGY_DRIFT_LIMIT:g})", "launch", "launch",
                              figs)

        # crawl limits at every substep (the device's records) and the rewards
        col = s["violation"]
        violated = stepping & (col != -1) & (proto.crawl_mode != "none")
        forward = np.where(violated, 0.0, proto.forward_reward_weight * proto.target_direction * self._com_vel[:, 0])
        field_cost = -proto.field_cost_weight * power
        crawl = np.where(violated, -(proto.crawl_penalty + np.maximum(self._episode_forward, 0.0)), 0.0)
        self._episode_forward = np.where(stepping, self._episode_forward + forward, self._episode_forward)
        reward = forward + field_cost + crawl
        angles = self._angles(s)
        obs = self._observe(s, angles)
        bad_obs = ~np.isfinite(obs).all(axis=1)
        for i in np.flatnonzero(stepping & bad_obs).tolist():
            reasons.setdefault(i, ("non-finite observation", "observation", None, {}))
        broken = np.zeros(n, dtype=bool)
        broken[list(reasons)] = True
        reward = np.where(stepping & ~broken, reward, 0.0)
        z = np.zeros(n)
        forward, field_cost, crawl = (np.where(broken, 0.0, v) for v in (forward, field_cost, crawl))
        self._obs = np.where(broken[:, None], old_obs, obs).astype(np.float32)
        terminated = violated & ~broken
        truncated = broken.copy()
        self._elapsed[stepping] += 1
        if self.max_episode_steps is not None:
            truncated |= stepping & (self._elapsed >= self.max_episode_steps)
        values = self._info(s, angles, reward, forward, field_cost, crawl)
        infos = _vector_info(values)
        time_end = self._substeps * self._dt
        if violated.any():
            infos.update(_vector_info({"crawl_violation": self._violation_texts(s, violated, time_end, k)},
                                      violated & ~broken))
        if reasons:
            mask = broken
            texts = np.full(n, None, dtype=object)
            kinds = np.full(n, None, dtype=object)
            for i, (text, kind, _, _) in reasons.items():
                texts[i], kinds[i] = text, kind
            infos.update(_vector_info({"truncation_reason": texts, "instability": kinds}, mask))
            un = {i: r for i, r in reasons.items() if r[2] is not None}
            if un:
                umask = np.zeros(n, dtype=bool)
                umask[list(un)] = True
                extra: dict[str, np.ndarray] = {"unphysical": np.full(n, None, dtype=object)}
                for i, (_, _, why, figs) in un.items():
                    extra["unphysical"][i] = why
                    for key, v in figs.items():
                        extra.setdefault(key, np.zeros(n))[i] = v
                infos.update(_vector_info(extra, umask))
        # NEXT_STEP autoreset: the worlds that ended last step start again (their step above is discarded)
        if resetting.any():
            self._reset_worlds(resetting, [None] * n)
            reset_info = self._info(self._state, self._angles(self._state), z, z, z, z)
            for key, v in reset_info.items():
                infos[key] = np.where(resetting if np.ndim(v) == 1 else resetting[:, None], v, infos[key])
            for key in list(infos):
                if key.startswith("_") and key[1:] not in reset_info:
                    infos[key] = infos[key] & ~resetting
            reward[resetting] = 0.0
            terminated[resetting] = truncated[resetting] = False
        np.logical_or(terminated, truncated, out=self._autoreset)
        return self._obs.copy(), reward, terminated, truncated, infos

    def _waves(self, act: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``(A_x, A_z, f, phase)`` of the waveform-mode actions ``act`` (clipped) and each period's substeps
        (:meth:`MagSoftCrawlEnv.waveparams_of_action <magsoft_env.envs.crawl.MagSoftCrawlEnv.waveparams_of_action>`
        and its ``round(1 / (f sim_dt))``)."""
        proto = self.proto
        f_lo, f_hi = proto.frequency_range
        freq = f_lo + 0.5 * (act[:, 3] + 1.0) * (f_hi - f_lo)
        waves = np.column_stack([act[:, 0] * proto.field_limit, act[:, 1] * proto.field_limit, freq,
                                 act[:, 2] * math.pi])
        k = np.maximum(1, np.round(1.0 / (freq * self._dt))).astype(np.int64)
        return waves, k

    @staticmethod
    def _peaks(waves: np.ndarray) -> np.ndarray:
        """Peak field (T) of each world's waveform as the C simulator takes it for its energy scale: the largest
        |B_x| and |B_z| over 257 samples of its first second, combined."""
        t = np.linspace(0.0, 1.0, 257)
        w = 2.0 * np.pi * waves[:, 2:3] * t
        bx = np.abs(waves[:, 0:1] * np.sin(w + waves[:, 3:4])).max(axis=1)
        bz = np.abs(waves[:, 1:2] * np.sin(w)).max(axis=1)
        return np.hypot(bx, bz)

    def _violation_texts(self, s, violated, time_end, k) -> np.ndarray:
        proto = self.proto
        out = np.full(self.num_envs, None, dtype=object)
        for i in np.flatnonzero(violated).tolist():
            ki = int(k[i])
            j = int(s["violation"][i])
            j = ki if j == -2 else j  # -2: the end state (the last column)
            clear, top, cos = s["figures"][i]
            when = f"at t = {time_end[i] - (ki - j) * self._dt:.4f} s"
            if proto.max_clearance is not None and clear > proto.max_clearance:
                out[i] = (f"airborne {when}: the lowest point is {clear * 1e3:.3f} mm above the floor > "
                          f"{proto.max_clearance * 1e3:.3f} mm (the whole beam off the floor: a hop, not a crawl)")
            elif proto.crawl_mode == "rotation":
                rot = math.acos(max(-1.0, min(1.0, cos)))
                out[i] = (f"link rotation {math.degrees(rot):.1f} deg > {math.degrees(proto.max_link_rotation):.1f} "
                          f"deg {when}")
            else:
                out[i] = f"height {top * 1e3:.2f} mm > {proto.max_height * 1e3:.2f} mm {when}"
        return out

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

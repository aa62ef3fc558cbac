"""MagSoftShape-v0: a clamped magnetic beam reaches a target tip pose by choosing the field."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..sim import RodOptions, SimulationError, Simulator
from ..sim.health import check_steps
from ..sim.model import MAX_TIMESTEP
from ..spec import Beam
from ..validate import nonnegative, positive
from . import as_action, refuse_unknown_kwargs

#: Default coil limit per axis (T).
DEFAULT_FIELD_LIMIT = 20e-3
#: Length of the default beam (m): the paper's Fig. 3 cantilever.
DEFAULT_LENGTH = 25e-3
#: Default simulation step (s) up to :data:`STABLE_FIELD`; above it the step scales as 1 / field_limit.
DEFAULT_SIM_DT = 1e-3
#: Largest coil limit (T) the default 1 ms step keeps stable under sudden field reversals.
STABLE_FIELD = 20e-3
#: Targets are equilibria under fields drawn from this box per axis (T).
DEFAULT_TARGET_FIELD = 10e-3


class MagSoftShapeEnv(gym.Env):
    """
    ## Description

    A 25 x 5 x 1.13 mm cantilever (phi = 20 %, axial magnetization: the paper's Fig. 3 beam; or the
    beam of ``robot``) is clamped horizontally at its left end and sags under gravity. Each episode draws a
    target tip pose: the analytical equilibrium (:func:`magsoft_env.solve_equilibrium`, rotated
    coupling, loading path from zero field) under a field drawn uniformly from
    ``[-target_field, target_field]^2``. The agent chooses the field every ``ctrl_dt`` and
    must bring the MuJoCo rod's tip there and hold it. The target is reachable by a constant
    field, but the dynamic path may land on another equilibrium branch.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``: ``B_x / field_limit``, ``B_z / field_limit`` (field, T),
    held for ``ctrl_dt`` (ramped when ``slew_rate`` is set).

    ## Observation Space

    ``Box(-high, high, (2 N + 12,), float32)``, clipped to the bounds (pi for angles, 1000
    rad/s, 2 for lengths / L, 1 for the rest):

    | Num | Observation | Type (Unit) |
    |-----|-------------|-------------|
    | 0 .. N | tangent angle of each piece from +x toward +z | angle (rad) |
    | N+1 .. 2N+1 | angular velocity of each piece | angular velocity (rad/s) |
    | 2N+2, 2N+3 | tip x / L, tip z / L | dimensionless |
    | 2N+4, 2N+5 | sin, cos of the tip angle | dimensionless |
    | 2N+6, 2N+7 | target tip x / L, z / L | dimensionless |
    | 2N+8, 2N+9 | sin, cos of the target tip angle | dimensionless |
    | 2N+10, 2N+11 | B_x / field_limit, B_z / field_limit | dimensionless |

    ## Rewards

    ``reward = position + angle + field_cost`` (each in ``info`` as ``reward_position``,
    ``reward_angle``, ``reward_field``):

    - ``position = -position_weight * |tip - target| / L``
    - ``angle = -angle_weight * (1 - cos(tip angle - target angle))``
    - ``field_cost = -field_cost_weight * (B_x^2 + B_z^2) / field_limit^2``

    ``info["position_error"]`` (m) and ``info["is_success"]`` (position error below
    ``success_tolerance``) report progress; ``info["target_field"]`` (T) is the field whose
    equilibrium made the target (NaN for targets given in ``reset``): holding it is the
    open-loop baseline.

    ## Starting State

    Straight horizontal beam at rest, zero field (gravity then sags it); hinge angles
    perturbed by ``U(-reset_noise_scale, reset_noise_scale)`` rad. ``reset(options={"target":
    (x, z, angle)})`` sets the target (m, m, rad) instead of drawing one.

    ## Episode End

    No termination; truncation after ``max_episode_steps`` (100 steps = 5 s) or on
    instability (``info["truncation_reason"]``).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``robot`` | None | a robot (built-in name, robot file or ``Robot``) whose beam is clamped instead |
    | ``length`` | None | beam length (m) of the default beam (0.025); not with ``robot`` |
    | ``field_limit`` | 0.02 | coil limit per axis (T) |
    | ``target_field`` | 0.01 | targets come from fields in this box per axis (T) |
    | ``slew_rate`` | None | largest field change rate per axis (T/s) |
    | ``ctrl_dt`` | 0.05 | control interval (s), >= ``sim_dt`` |
    | ``sim_dt`` | None | simulation step (s), discrete integrator, in (0, 0.1]; None: see below |
    | ``segments`` | 20 | rod cells |
    | ``position_weight``, ``angle_weight``, ``field_cost_weight`` | 1, 0.2, 0.01 | reward weights |
    | ``success_tolerance`` | 1e-3 | tip position tolerance (m) for ``is_success`` |
    | ``reset_noise_scale`` | 1e-3 | initial hinge-angle noise (rad) |
    | ``render_mode`` | None | ``"rgb_array"`` (with the analytical shape at the current field overlaid) |

    ``sim_dt=None`` is 1 ms up to a 20 mT ``field_limit`` and ``1 ms x 20 mT / field_limit`` above: the 1 ms
    step goes unstable under sudden reversals of 30-100 mT, while 0.67, 0.4 and 0.2 ms ran three episodes of
    16 extreme and random actions each at 30, 50 and 100 mT without an instability (measured). At most 1e7
    simulation steps per env step.

    ## Version History

    - v0: initial version (magsoft_env 0.1).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 20}

    def __init__(
        self,
        *,
        robot=None,
        length: float | None = None,
        field_limit: float = DEFAULT_FIELD_LIMIT,
        target_field: float = DEFAULT_TARGET_FIELD,
        slew_rate: float | None = None,
        ctrl_dt: float = 0.05,
        sim_dt: float | None = None,
        segments: int = 20,
        position_weight: float = 1.0,
        angle_weight: float = 0.2,
        field_cost_weight: float = 0.01,
        success_tolerance: float = 1e-3,
        reset_noise_scale: float = 1e-3,
        render_mode: str | None = None,
        width: int = 960,
        height: int = 540,
        **unknown,
    ):
        refuse_unknown_kwargs(self, unknown)
        if robot is not None and length is not None:
            raise ValueError(f"give robot or length, not both: the robot's beam has its own length, got "
                             f"robot={robot!r} and length={length!r}.")
        if robot is not None:
            from ..cases.robots import resolve_robot

            beam = resolve_robot(robot).beam.require_planar("MagSoftShape (the MuJoCo hinge-chain rod)")
        else:
            beam = Beam(length=positive("length", DEFAULT_LENGTH if length is None else length, unit="m"),
                        width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
        self.field_limit = positive("field_limit", field_limit, unit="T")
        if self.field_limit > 0.1:
            raise ValueError(f"field_limit must be <= 0.1 T (20 mT is 0.02), got {field_limit!r}.")
        self.target_field = positive("target_field", target_field, unit="T")
        if self.target_field > self.field_limit:
            raise ValueError(
                f"target_field must be <= field_limit ({self.field_limit:g} T), got {target_field!r}."
            )
        self.slew_rate = None if slew_rate is None else positive("slew_rate", slew_rate, unit="T/s")
        self.ctrl_dt = positive("ctrl_dt", ctrl_dt, unit="s")
        if sim_dt is None:
            sim_dt = DEFAULT_SIM_DT * min(1.0, STABLE_FIELD / self.field_limit)
        self.sim_dt = positive("sim_dt", sim_dt, unit="s")
        if self.sim_dt > MAX_TIMESTEP:
            raise ValueError(f"sim_dt must lie in (0, {MAX_TIMESTEP:g}] s, got {sim_dt!r}.")
        if self.sim_dt > self.ctrl_dt:  # one step would silently last sim_dt, not ctrl_dt
            raise ValueError(f"sim_dt must be <= ctrl_dt ({self.ctrl_dt:g} s), got {sim_dt!r}.")
        self.n_substeps = max(1, int(round(check_steps(
            f"ctrl_dt / sim_dt = {self.ctrl_dt:g} s / {self.sim_dt:g} s per env step", self.ctrl_dt / self.sim_dt,
            "Use a larger sim_dt or a smaller ctrl_dt."))))
        self.position_weight = nonnegative("position_weight", position_weight)
        self.angle_weight = nonnegative("angle_weight", angle_weight)
        self.field_cost_weight = nonnegative("field_cost_weight", field_cost_weight)
        self.success_tolerance = positive("success_tolerance", success_tolerance, unit="m")
        self.reset_noise_scale = nonnegative("reset_noise_scale", reset_noise_scale, unit="rad")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}."
            )
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or not 16 <= v <= 4096:
                raise ValueError(f"{name} must be an integer number of pixels in [16, 4096], got {v!r}.")
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)
        self.beam = beam
        self.sim = Simulator(self.beam, RodOptions(scene="cantilever", segments=segments, timestep=self.sim_dt,
                                                   render=render_mode is not None))
        self.segments = int(segments)
        self.metadata = {**self.metadata, "render_fps": max(1, int(round(1.0 / (self.n_substeps * self.sim_dt))))}
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        n1 = self.segments + 1
        high = np.concatenate([np.full(n1, np.pi), np.full(n1, 1e3), np.full(2, 2.0), np.ones(2), np.full(2, 2.0),
                               np.ones(4)]).astype(np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self._obs_buf = np.zeros(high.size)
        self._field = np.zeros(2)
        self._target = np.zeros(3)
        self._target_field = np.zeros(2)
        self._broken = False
        self._renderer = None

    def target_pose(self, field) -> np.ndarray:
        """Analytical equilibrium tip pose (x m, z m, angle rad) under ``field`` (T)."""
        from ..theory import solve_equilibrium

        res = solve_equilibrium(self.beam, tuple(float(b) for b in field))
        if not res.success:
            return np.full(3, np.nan)
        return np.array([res.x[-1], res.z[-1], res.tip_angle])

    def open_loop_action(self) -> np.ndarray:
        """Hold the field that produced the target (the open-loop baseline); zeros if unknown."""
        b = np.nan_to_num(self._target_field / self.field_limit)
        return np.clip(b, -1.0, 1.0).astype(np.float32)

    def tip_pose(self) -> np.ndarray:
        """MuJoCo tip pose (x m, z m, angle rad)."""
        x, z = self.sim.tip_position()
        return np.array([x, z, self.sim.tip_angle()])

    def _get_obs(self, tip: np.ndarray) -> np.ndarray:
        sim = self.sim
        ang = sim.angles()
        omega = sim.angular_velocities()
        tgt, L = self._target, self.beam.length
        n1 = ang.size
        obs = self._obs_buf  # filled in place: this runs every control step
        obs[:n1] = ang
        obs[n1:2 * n1] = omega
        obs[2 * n1:] = (tip[0] / L, tip[1] / L, math.sin(tip[2]), math.cos(tip[2]), tgt[0] / L, tgt[1] / L,
                        math.sin(tgt[2]), math.cos(tgt[2]), self._field[0] / self.field_limit,
                        self._field[1] / self.field_limit)
        return np.clip(obs, self.observation_space.low, self.observation_space.high).astype(np.float32)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        target = None if options is None else options.get("target")
        if target is not None:
            try:
                t = np.asarray(target, dtype=float)
            except (TypeError, ValueError):
                t = np.full(1, np.nan)
            if t.shape != (3,) or not np.all(np.isfinite(t)):
                raise ValueError(f"options['target'] must be finite (x m, z m, angle rad), got {target!r}.")
            # the tip stays within the beam's length of the clamp (the origin); angles are radians
            L = self.beam.length
            if math.hypot(t[0], t[1]) > L or abs(t[2]) > 2.0 * math.pi:
                raise ValueError(
                    f"options['target'] must lie within the beam's reach: sqrt(x^2 + z^2) <= L = {L:g} m from the "
                    f"clamp and |angle| <= 2 pi rad (radians: 90 deg is 1.571), got {target!r}.")
            self._target = t
            self._target_field = np.full(2, np.nan)
        else:
            for _ in range(10):
                b = self.np_random.uniform(-self.target_field, self.target_field, 2)
                t = self.target_pose(b)
                if np.all(np.isfinite(t)):
                    break
            else:
                b = np.zeros(2)
                t = self.target_pose(b)
            self._target = t
            self._target_field = b
        self.sim.set_field((0.0, 0.0))
        self.sim.reset(qpos=self.sim.noisy_rest(self.np_random, self.reset_noise_scale))
        self._field = np.zeros(2)
        self._broken = False
        tip = self.tip_pose()
        self._last_obs = self._get_obs(tip)
        return self._last_obs, self._info(tip)

    def step(self, action):
        if self._broken:
            raise RuntimeError("step() called after the simulation became unstable; call reset() first.")
        target_b = np.clip(as_action(self.action_space, action), -1.0, 1.0) * self.field_limit
        try:
            if self.slew_rate is not None:
                from ..sim import Ramp

                dmax = self.slew_rate * self.n_substeps * self.sim_dt
                target_b = self._field + np.clip(target_b - self._field, -dmax, dmax)
                self.sim.set_waveform(Ramp(tuple(self._field), tuple(target_b), duration=self.n_substeps * self.sim_dt))
            else:
                self.sim.set_field((float(target_b[0]), float(target_b[1])))
            self._field = target_b
            self.sim.step(self.n_substeps)
        except SimulationError as err:
            self._broken = True
            info = self._info(np.full(3, np.nan))
            info.update(truncation_reason=str(err), instability=err.quantity)
            return self._last_obs.copy(), 0.0, False, True, info
        tip = self.tip_pose()
        obs = self._get_obs(tip)
        err = math.hypot(tip[0] - self._target[0], tip[1] - self._target[1])
        position = -self.position_weight * err / self.beam.length
        angle = -self.angle_weight * (1.0 - math.cos(tip[2] - self._target[2]))
        field = -self.field_cost_weight * (self._field[0]**2 + self._field[1]**2) / self.field_limit**2
        reward = position + angle + field
        self._last_obs = obs
        info = self._info(tip, reward_position=position, reward_angle=angle, reward_field=field, reward=reward)
        return obs, float(reward), False, False, info

    def _info(self, tip: np.ndarray, **terms) -> dict:
        err = float(np.hypot(*(tip[:2] - self._target[:2])))
        info = {"reward_position": 0.0, "reward_angle": 0.0, "reward_field": 0.0, "reward": 0.0}
        info.update({k: float(v) for k, v in terms.items()})
        info.update(position_error=err, is_success=err < self.success_tolerance, target=self._target.copy(),
                    target_field=self._target_field.copy(),
                    tip=tip, field=self._field.copy(), time=self.sim.time)
        return info

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to the constructor.")
            return None
        if self._renderer is None:
            from ..render.views import make_renderer

            self._renderer = make_renderer(self.sim, width=self.width, height=self.height, follow=False)
        overlay = None
        if np.any(self._field):
            from ..theory import solve_equilibrium

            res = solve_equilibrium(self.beam, tuple(self._field))
            if res.success:
                overlay = (np.asarray(res.x), np.asarray(res.z))
        return self._renderer.render(field=self.sim.field, overlay=overlay, target=self._target[:2])

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

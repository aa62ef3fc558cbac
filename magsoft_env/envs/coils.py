"""MagSoftCoils-v0: the 3D strip on a floor steered to a goal by the currents of a coil system (Navion, CardioMag)."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from ..validate import choice, finite_array, nonnegative, positive
from .steer import OBS_MAX_POSITION, OBS_MAX_VELOCITY, MagSoftSteerEnv, steer_controller
from .vector import MagSoftSteerVecEnv

#: Coil systems this env takes (names of :data:`magsoft_env.fields.CALIBRATIONS`).
COIL_SYSTEMS = ("navion", "cardiomag")
#: Default L/R time constant of every coil (s): a few ms, as a current-controlled amplifier on an
#: electromagnet of tens of mH and a few ohms gives; within a 20 ms control step the currents reach 98 %.
DEFAULT_COIL_TAU = 5e-3
#: Default slew rate of every coil (A/s): Navion's +-35 A swing (70 A) takes 70 ms; a 1 Hz field of 3 mT
#: (about 10 A in Navion) needs about 60 A/s.
DEFAULT_SLEW_RATE = 1000.0
#: Default scale of the field the observation reports (T): the field is observed as B / field_scale, so that the
#: steering field of :class:`~magsoft_env.envs.steer.MagSoftSteerEnv` (3 mT) reads as there.
DEFAULT_FIELD_SCALE = 3e-3
#: The observed field is clipped to this many ``field_scale`` (Navion's largest field, about 33 mT, is 11).
OBS_MAX_FIELD = 20.0
#: The hand controller's field (T): :func:`~magsoft_env.envs.steer.steer_controller`'s at the steer env's default.
CONTROLLER_FIELD = 3e-3
#: Arguments of the steer env that a field source env sets itself.
_OWN = ("action_mode", "field_limit", "field_cost_weight", "frequency_range")


class _ActuatorSource:
    """The env's actuator as a field source of the simulation time: the Simulator evaluates it at the strip's
    pieces before every physics step (``field_and_gradient(points, t=...)``: a source that changes in time)."""

    def __init__(self, env):
        self._env = env

    def field_and_gradient(self, points, t: float = 0.0):
        return self._env._source_at(np.asarray(points, dtype=float), float(t))


class SourceSteerEnv(MagSoftSteerEnv):
    """:class:`~magsoft_env.envs.steer.MagSoftSteerEnv` driven by a field source instead of a uniform field: the
    base of :class:`MagSoftCoilsEnv` and :class:`~magsoft_env.envs.magnet.MagSoftMagnetEnv`.

    A subclass is the actuator: ``_apply(action)`` plans the control step (and returns ``(substeps, power)``, the
    power the step's cost weighs), ``_source_at(points, t)`` is the field and gradient at simulation time ``t``,
    ``_reset_actuator()``, ``_extra_obs()`` (appended to the steer env's observation) with ``_extra_high`` its
    bounds, ``_actuator_info()`` (added to ``info``). The task (goal, progress, success, crawl limits,
    locomotion readouts, episode end) is the steer env's; the field slot of its observation is the source's field
    at the strip's centre of mass, ``B / field_scale``; its cost term is reported as ``info[cost_key]``.
    """

    cost_key = "reward_cost"

    def __init__(self, robot="paper-5c", *, field_scale: float = DEFAULT_FIELD_SCALE, cost_weight: float = 0.1,
                 **kwargs):
        for name in _OWN:
            if name in kwargs:
                raise ValueError(f"{type(self).__name__} does not take {name!r}: its actuator sets the field "
                                 f"(see the class docstring's Arguments).")
        scale = positive("field_scale", field_scale, unit="T")
        if scale > 0.1:
            raise ValueError(f"field_scale must lie in (0, 0.1] T (fields are in tesla: 3 mT is 0.003), got "
                             f"{field_scale!r}.")
        super().__init__(robot, field_limit=scale, field_cost_weight=cost_weight, **kwargs)
        self.field_scale = scale
        p = self._npoints
        high = np.concatenate([np.full(3, OBS_MAX_POSITION), np.full(3, OBS_MAX_VELOCITY),
                               np.full(3 * p, OBS_MAX_POSITION), np.full(3, OBS_MAX_FIELD), np.ones(2),
                               self._extra_high]).astype(np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self._last_obs = np.zeros(self.observation_space.shape, np.float32)
        #: the length of the steer env's part of the observation (the hand controllers read it)
        self.steer_obs_size = 3 * p + 11

    def _attach_source(self) -> None:
        """Set the actuator as the simulator's source (after the subclass built its actuator)."""
        self._reset_actuator()
        self.sim.set_source(_ActuatorSource(self))

    # ------------------------------------------------------------------ readouts
    def _field_reading(self) -> np.ndarray:
        """The source's field (T, (3,)) at the strip's centre of mass now."""
        B, _ = self._source_at(self._com[None, :], self.sim.time)
        return B[0]

    def _get_obs(self) -> np.ndarray:
        self._field = self._field_reading()
        x, y, z = self.sim.centerline()
        rel = np.stack([x, y, z], axis=1) - self._com
        w = 2.0 * math.pi * self.clock_frequency * self.sim.time
        obs = np.concatenate([self._goal - self._com[:2], [self._distance], self._com_vel, rel.ravel(),
                              self._field / self.field_scale, [math.sin(w), math.cos(w)],
                              self._extra_obs()]).astype(np.float32)
        return np.clip(obs, self.observation_space.low, self.observation_space.high)

    def _info(self, reward: float, *, progress: float = 0.0, field: float = 0.0, crawl: float = 0.0,
              success: float = 0.0) -> dict:
        info = super()._info(reward, progress=progress, field=field, crawl=crawl, success=success)
        info[self.cost_key] = info.pop("reward_field")
        info.update(self._actuator_info())
        return info

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self._reset_actuator()
        return super().reset(seed=seed, options=options)

    def field_action(self, field) -> np.ndarray:
        """The actuator's action (float32) that makes ``field`` (T, (3,)) at the strip's centre of mass now, as
        near as the actuator can: the hand controllers and the waveform ids
        (:mod:`~magsoft_env.envs.source_waveform`) act through it."""
        raise NotImplementedError

    def wanted_field(self, obs=None) -> np.ndarray:
        """The field (T, (3,)) the steer env's hand controller (:func:`~magsoft_env.envs.steer.steer_controller`)
        wants at the strip for ``obs`` (default the last observation): :data:`CONTROLLER_FIELD` turning at
        ``clock_frequency`` in the vertical plane through the goal."""
        o = self._last_obs if obs is None else np.asarray(obs, dtype=float)
        return steer_controller(o[:self.steer_obs_size]).astype(float) * CONTROLLER_FIELD

    # ------------------------------------------------------------------ to be given by the actuator
    _extra_high = np.zeros(0)

    def _reset_actuator(self) -> None:
        raise NotImplementedError

    def _source_at(self, points: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        raise NotImplementedError

    def _extra_obs(self) -> np.ndarray:
        return np.zeros(0)

    def _actuator_info(self) -> dict:
        return {}


class MagSoftCoilsEnv(SourceSteerEnv):
    """
    ## Description

    :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s task (the paper's Fig. 5c strip on a floor as the 3D rod,
    brought to a goal point on the floor) with the coils of a real electromagnetic navigation system as the
    actuator: Navion (3 coils, +-35 A; default) or CardioMag (8 coils, +-20 A), from their calibrations
    (:meth:`~magsoft_env.fields.CoilSystem.from_calibration`). The agent commands the coils' currents; the actual
    currents follow a :class:`~magsoft_env.fields.CoilDrive` (an L/R lag ``coil_tau`` and a slew rate, stepped at
    every physics step), and the coils' field **and its gradient** act on every piece of the strip at every physics
    step (the couple ``m x B`` and the force ``G^T m``, through the simulator's field source; docs/sim.md, "Field
    sources").

    Placement: the calibration's axes are the world's (z up), and the calibration's origin (the centre of its
    calibrated workspace, where its field is mapped best) lies at ``coils_origin``, by default the strip's starting
    centre of mass projected on the floor, ``(x_c, y_c, 0)``: the floor at the system's centre height. There the
    coils make 0.29-0.41 mT/A each (Navion; CardioMag 1.0-2.0 mT/A) and gradients of 1-4 mT/m/A (CardioMag
    2-16): at the 3 mT of the steering field the gradient force on the strip (about 0.013 A m^2) is of the order of
    0.1-0.5 mN, against its weight of 2.6 mN.

    The coils set the field at one point; elsewhere it differs, and the gradient comes with it (Navion's three coils
    cannot set both). :meth:`baseline_action` is the hand controller: the field that
    :func:`~magsoft_env.envs.steer.steer_controller` wants at the strip's centre (3 mT turning at
    ``clock_frequency`` in the vertical plane through the goal), turned into the least-norm currents within the
    limits by :func:`~magsoft_env.fields.allocate`.

    ## Action Space

    ``Box(-1, 1, (n,), float32)``, n the number of coils (Navion 3, CardioMag 8): the commanded currents, held for
    ``ctrl_dt``.

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | j | command of coil j / max_current | -1 | 1 | current (A) |

    ## Observation Space

    ``Box(-high, high, (3 P + 11 + n,), float32)``, P = ``segments`` + 2 points (47 + n by default); the first
    3 P + 11 entries are :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s, with the coils' field in the field slot:

    | Num | Observation | Type (Unit) |
    |-----|-------------|-------------|
    | 0, 1 | goal minus centre of mass, x and y | position (m) |
    | 2 | horizontal distance to the goal | position (m) |
    | 3 .. 5 | centre-of-mass velocity (x, y, z), mean over the last step | velocity (m/s) |
    | 6 .. 3P+5 | the strip's points minus its centre of mass, (x, y, z) per point, first end first | position (m) |
    | 3P+6 .. 3P+8 | the coils' field at the centre of mass now, B / field_scale (clipped to +-20) | dimensionless |
    | 3P+9, 3P+10 | sin, cos of the clock phase ``2 pi clock_frequency t`` | dimensionless |
    | 3P+11 .. 3P+10+n | the actual currents now / max_current | dimensionless |

    ## Rewards

    ``reward = progress + current_cost + crawl + success``, each term in ``info`` (``reward_progress``,
    ``reward_current``, ``reward_crawl``, ``reward_success``): as :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s,
    with ``current_cost = -current_cost_weight * mean((I / max_current)^2)``, the mean over the coils and the
    step's physics steps of the actual currents (the coils' resistive power, normalized).

    ## Starting State

    As :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s; all currents zero (no field: the calibrations have no
    offset field).

    ## Episode End

    As :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s (goal reached, lost, crawl limits, time limit: 250
    steps = 5 s, unstable or unphysical simulation).

    ``info`` has the steer env's keys (``field``: the coils' field at the centre of mass, T) and ``currents`` (the
    actual currents, A), ``current_command`` (A) and ``saturated`` (coils whose command the slew rate or the limit
    held back during the step).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``coils`` | ``"navion"`` | ``"navion"`` or ``"cardiomag"`` |
    | ``coil_tau`` | 0.005 | L/R time constant of every coil (s), >= 0 (0: none) |
    | ``slew_rate`` | 1000 | largest rate of change of every coil's current (A/s), > 0; None: none |
    | ``coils_origin`` | None | where the calibration's origin lies in the world (m, (3,)); None: the strip's |
    | | | starting centre of mass on the floor |
    | ``field_scale`` | 0.003 | the observed field's unit (T) |
    | ``current_cost_weight`` | 0.1 | weight of the normalized current power |
    | others | | as :class:`~magsoft_env.envs.steer.MagSoftSteerEnv` (``robot``, ``ctrl_dt``, ``sim_dt``, |
    | | | ``segments``, ``goal_distance``, ``clock_frequency``, ``crawl_mode``, ``render_mode``, ...); not |
    | | | ``action_mode``, ``field_limit``, ``field_cost_weight``, ``frequency_range`` |

    ## Version History

    - v0: initial version.
    """

    cost_key = "reward_current"

    def __init__(self, robot="paper-5c", *, coils: str = "navion", coil_tau: float = DEFAULT_COIL_TAU,
                 slew_rate: float | None = DEFAULT_SLEW_RATE, coils_origin=None,
                 field_scale: float = DEFAULT_FIELD_SCALE, current_cost_weight: float = 0.1, **kwargs):
        from ..fields import CoilDrive, CoilSystem

        name = choice("coils", coils, COIL_SYSTEMS)
        tau = nonnegative("coil_tau", coil_tau, unit="s")
        rate = None if slew_rate is None else positive("slew_rate", slew_rate, unit="A/s")
        origin = None
        if coils_origin is not None:
            origin = finite_array("coils_origin", coils_origin)
            if origin.shape != (3,):
                raise ValueError(f"coils_origin must be a point (x, y, z) in m, shape (3,), got {coils_origin!r}.")
        cost = nonnegative("current_cost_weight", current_cost_weight)
        self.system = CoilSystem.from_calibration(name)
        self.coils = name
        self.max_current = self.system.max_current.copy()
        self._drive = CoilDrive(self.system, tau=tau, slew_rate=rate)
        self.coil_tau, self.slew_rate = tau, rate
        n = self.system.n_coils
        self._extra_high = np.ones(n)
        self._trajectory = np.zeros((1, n))
        self._t0 = 0.0
        self._command = np.zeros(n)
        self._saturated = np.zeros(n, dtype=bool)
        self.coils_origin = np.zeros(3)
        super().__init__(robot, field_scale=field_scale, cost_weight=cost, **kwargs)
        self.current_cost_weight = cost
        if origin is None:
            origin = self.com_position()
            origin[2] = 0.0
        self.coils_origin = origin
        self.action_space = spaces.Box(-1.0, 1.0, (n,), np.float32)
        self._attach_source()

    # ------------------------------------------------------------------ the actuator
    @property
    def currents(self) -> np.ndarray:
        """The coils' actual currents now (A), shape (n_coils,)."""
        return self._drive.currents

    def _reset_actuator(self) -> None:
        self._drive.reset()
        n = self.system.n_coils
        self._trajectory = np.zeros((1, n))
        self._t0 = 0.0
        self._command = np.zeros(n)
        self._saturated = np.zeros(n, dtype=bool)

    def _apply(self, action) -> tuple[int, float]:
        """Plan the step: the drive stepped at every physics step toward the command; ``(substeps, mean (I /
        max_current)^2)``."""
        n, dt, drive = self.n_substeps, self.sim_dt, self._drive
        command = np.clip(np.asarray(action, dtype=float), -1.0, 1.0) * self.max_current
        path = np.empty((n + 1, self.system.n_coils))
        path[0] = drive.currents
        held = np.zeros(self.system.n_coils, dtype=bool)
        for k in range(n):
            path[k + 1] = drive.step(command, dt)
            held |= drive.rate_limited | drive.saturated
        self._trajectory, self._t0, self._command, self._saturated = path, self.sim.time, command, held
        return n, float(np.mean((path[:-1] / self.max_current) ** 2))

    def _currents_at(self, t: float) -> np.ndarray:
        """The actual currents (A) at simulation time ``t`` within the present step (those of its physics step)."""
        k = int(round((t - self._t0) / self.sim_dt))
        return self._trajectory[min(max(k, 0), len(self._trajectory) - 1)]

    def _source_at(self, points, t):
        return self.system.field_and_gradient(points - self.coils_origin, self._currents_at(t))

    def _extra_obs(self) -> np.ndarray:
        return self._drive.currents / self.max_current

    def _actuator_info(self) -> dict:
        return {"currents": self._drive.currents, "current_command": self._command.copy(),
                "saturated": self._saturated.copy()}

    # ------------------------------------------------------------------ the hand controller
    def currents_for(self, field) -> np.ndarray:
        """The least-norm currents (A) that make ``field`` (T, (3,)) at the strip's centre of mass within the limits
        (:func:`~magsoft_env.fields.allocate`; beyond reach, the field scaled down to the reach keeps its
        direction)."""
        from ..fields import allocate

        point = self._com - self.coils_origin
        b = np.asarray(field, dtype=float)
        if not np.any(b):
            return np.zeros(self.system.n_coils)
        a = allocate(self.system, point, field=b)
        if not a.reachable:
            a = allocate(self.system, point, field=b * min(1.0, 0.999 * a.scale_limit))
        return a.currents

    def field_action(self, field) -> np.ndarray:
        """The normalized currents (float32) that make ``field`` (T, (3,)) at the strip's centre of mass
        (:meth:`currents_for`)."""
        return np.clip(self.currents_for(field) / self.max_current, -1.0, 1.0).astype(np.float32)

    def baseline_action(self, obs=None) -> np.ndarray:
        """The hand controller's action: :meth:`wanted_field` (:func:`~magsoft_env.envs.steer.steer_controller`'s
        field, 3 mT) allocated to the coils at the strip's centre of mass (:meth:`currents_for`), normalized.
        It reads the strip's position from the env (the observation holds it relative to the goal only)."""
        return coils_controller(self._last_obs if obs is None else obs, self)


def coils_controller(obs, env) -> np.ndarray:
    """The hand controller of ``MagSoftCoils-v0`` (``env`` the env or its wrapper): the field
    :func:`~magsoft_env.envs.steer.steer_controller` wants at the strip, allocated to the coils."""
    e = env.unwrapped
    return e.field_action(e.wanted_field(obs))


class MagSoftCoilsVecEnv(MagSoftSteerVecEnv):
    """:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv` of :class:`MagSoftCoilsEnv` (``MagSoftCoils-v0``): the
    robots on threads, each bit for bit the single env under the same seed and actions. Every physics step under a
    field source runs from Python (docs/sim.md, "Field sources"), so the threads share the GIL for most of it:
    expect little gain from threads. CPU only."""

    env_class = MagSoftCoilsEnv


__all__ = ["COIL_SYSTEMS", "MagSoftCoilsEnv", "MagSoftCoilsVecEnv", "SourceSteerEnv", "coils_controller"]

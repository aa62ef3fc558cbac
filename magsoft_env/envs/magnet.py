"""MagSoftMagnet-v0: the 3D strip on a floor steered to a goal by a permanent magnet that a robot arm holds above it."""

from __future__ import annotations

import math

import numpy as np
from gymnasium import spaces

from ..validate import boolean, finite_array, in_range, nonnegative, positive
from .coils import DEFAULT_FIELD_SCALE, SourceSteerEnv
from .vector import MagSoftSteerVecEnv

#: Default magnet: an NdFeB cylinder 25 mm across and 25 mm long (m), remanence 1.2 T (N35-N40): moment 11.7 A m^2,
#: 2.3 mT on its axis 10 cm away (1.2 mT beside it). A 15 mm one (2.5 A m^2) gives 1 mT at 8 cm and did not move the
#: strip at all with the hand controller; closer, it lifts the strip off the floor (below).
DEFAULT_MAGNET_DIAMETER = 0.025
DEFAULT_MAGNET_LENGTH = 0.025
DEFAULT_REMANENCE = 1.2
#: Default heights of the magnet's centre above the floor (m). A strip standing up below the magnet (its centre 12 mm
#: up, 8.8 cm from the magnet's) is pulled up with about 1.5 mN (coaxial dipoles, ``3 mu0 m1 m2 / (2 pi d^4)``, the
#: strip 0.013 A m^2) against its weight of 2.6 mN: it is not lifted to the magnet. (The 15 mm magnet at 6 cm,
#: where the estimate for the strip lying flat gave 1.5 mN, lifted the strip once it stood up below it: the simulator
#: has no contact with the magnet, so the strip flew through it.)
DEFAULT_HEIGHTS = (0.10, 0.20)
#: Default horizontal half-width of the magnet's box around the strip's starting centre of mass (m): the goals lie
#: within 6 cm of it.
DEFAULT_REACH = 0.1
#: Default largest speed of the magnet's centre (m/s): a robot arm's tool speed near a person; 2 mm per 20 ms step.
DEFAULT_MAX_SPEED = 0.1
#: Default largest turn rate of the magnet's axis (rad/s), with ``tilt=True``: 360 deg/s, a fast wrist.
DEFAULT_MAX_TURN_RATE = 2.0 * math.pi
#: The hand controller's lead (m): with the axis vertical, the magnet's centre this far ahead of the strip's
#: centre of mass toward the goal, at the lowest height.
CONTROLLER_LEAD = 0.02
#: The episode ends (``info["magnet_contact"]``) when a point of the strip's centreline comes this close to the
#: magnet's bounding sphere (m): pulled up to the magnet (the simulator has no contact with it).
CONTACT_MARGIN = 2e-3
_MU0 = 4e-7 * math.pi


def _axis_of(u: float, v: float, max_tilt: float) -> np.ndarray:
    """The axis of tilt action ``(u, v)``: tilted ``max_tilt * min(1, |(u, v)|)`` from +z toward azimuth
    ``atan2(v, u)``."""
    r = min(1.0, math.hypot(u, v))
    th, ph = max_tilt * r, math.atan2(v, u)
    return np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])


def _turn(a: np.ndarray, b: np.ndarray, angle: float) -> np.ndarray:
    """Unit vector ``a`` turned toward ``b`` by at most ``angle`` (rad), in their plane."""
    c = float(np.clip(np.dot(a, b), -1.0, 1.0))
    full = math.acos(c)
    if full <= angle:
        return b.copy()
    w = b - c * a
    nw = float(np.linalg.norm(w))
    if nw < 1e-12:  # opposite: any perpendicular plane
        w = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
        nw = float(np.linalg.norm(w))
    w /= nw
    return math.cos(angle) * a + math.sin(angle) * w


def _frame(axis: np.ndarray) -> np.ndarray:
    """A rotation (3, 3) taking +z to the unit vector ``axis`` (the smallest one)."""
    z = np.array([0.0, 0.0, 1.0])
    k = np.cross(z, axis)
    s, c = float(np.linalg.norm(k)), float(axis[2])
    if s < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k /= s
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + s * K + (1.0 - c) * (K @ K)


class MagSoftMagnetEnv(SourceSteerEnv):
    """
    ## Description

    :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s task (the paper's Fig. 5c strip on a floor as the 3D rod,
    brought to a goal point on the floor) with a permanent magnet as the actuator: an axially magnetized NdFeB
    cylinder (:class:`~magsoft_env.fields.CylinderMagnet`, exact field and gradient; 25 x 25 mm, 1.2 T by default:
    11.7 A m^2) held above the floor by a robot arm within a :class:`~magsoft_env.fields.MagnetWorkspace` box. The
    agent commands the magnet's position (and, with ``tilt=True``, its axis); the arm moves it toward the command
    at a bounded speed, and the magnet's field **and gradient** act on every piece of the strip at every physics
    step (the couple ``m x B`` and the force ``G^T m``, through the simulator's field source; docs/sim.md, "Field
    sources"), with the magnet's pose interpolated along the step.

    The strip turns along the magnet's field and is pulled toward it (the gradient): below a magnet with its axis
    vertical the field points along the axis, beside it the other way. :meth:`baseline_action` is the hand
    controller: the magnet at the lowest height, :data:`CONTROLLER_LEAD` ahead of the strip toward the goal, which
    pulls it along the floor (``tilt=False``); with ``tilt=True``, the magnet straight above the strip, its axis
    turned so that the field below it turns as :func:`~magsoft_env.envs.steer.steer_controller`'s (the strip
    tumbles toward the goal).

    ## Action Space

    ``Box(-1, 1, (5,), float32)`` (``tilt=False``: ``(3,)``, the position only): the commanded pose.

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | 0 .. 2 | the magnet's centre, mapped linearly onto the workspace box (x, y, z) | -1 | 1 | position (m) |
    | 3, 4 | the axis (``tilt``), tilted ``max_tilt min(1, r)`` from +z toward (a3, a4) | -1 | 1 | dimensionless |

    (r the length of (a3, a4); the azimuth its direction.)

    Each step the magnet's centre moves toward the command by at most ``max_speed * ctrl_dt`` (2 mm by default) and
    its axis turns toward the command by at most ``max_turn_rate * ctrl_dt``, at a constant rate within the step:
    it never leaves the workspace.

    ## Observation Space

    ``Box(-high, high, (3 P + 17,), float32)``, P = ``segments`` + 2 points (53 by default); the first 3 P + 11
    entries are :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s, with the magnet's field in the field slot:

    | Num | Observation | Type (Unit) |
    |-----|-------------|-------------|
    | 0, 1 | goal minus centre of mass, x and y | position (m) |
    | 2 | horizontal distance to the goal | position (m) |
    | 3 .. 5 | centre-of-mass velocity (x, y, z), mean over the last step | velocity (m/s) |
    | 6 .. 3P+5 | the strip's points minus its centre of mass, (x, y, z) per point, first end first | position (m) |
    | 3P+6 .. 3P+8 | the magnet's field at the centre of mass now, B / field_scale (clipped to +-20) | dimensionless |
    | 3P+9, 3P+10 | sin, cos of the clock phase ``2 pi clock_frequency t`` | dimensionless |
    | 3P+11 .. 3P+13 | the magnet's centre minus the strip's centre of mass | position (m) |
    | 3P+14 .. 3P+16 | the magnet's axis (its moment's direction), unit vector | dimensionless |

    ## Rewards

    ``reward = progress + motion_cost + crawl + success``, each term in ``info`` (``reward_progress``,
    ``reward_motion``, ``reward_crawl``, ``reward_success``): as :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s,
    with ``motion_cost = -motion_cost_weight * (d / (max_speed ctrl_dt))^2``, d the step's displacement of the
    magnet's centre.

    ## Starting State

    As :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s; the magnet at the top of its box straight above the
    strip's starting centre of mass, axis +z (0.3 mT at the strip by default).

    ## Episode End

    As :class:`~magsoft_env.envs.steer.MagSoftSteerEnv`'s (goal reached, lost, crawl limits, time limit: 250
    steps = 5 s, unstable or unphysical simulation); and termination when a point of the strip comes within 2 mm
    of the magnet's bounding sphere or as high as its bottom (``info["magnet_contact"]``, checked at the end of each
    step): pulled up to it (the simulator has no contact with the magnet: the strip would pass through it). That
    step is no success even if the goal lies below the strip.

    ``info`` has the steer env's keys (``field``: the magnet's field at the centre of mass, T) and
    ``magnet_position`` (m), ``magnet_axis`` and ``magnet_target`` (the commanded position, m).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``magnet_diameter``, ``magnet_length`` | 0.025, 0.025 | the cylinder's size (m) |
    | ``remanence`` | 1.2 | its remanence B_r (T), in (0, 1.5]: magnetization B_r / mu0 along its axis |
    | ``workspace_bounds`` | None | the box of the magnet's centre, ((3, 2), m); None: 0.1 m either side of the |
    | | | strip's starting centre of mass in x and y, 0.10-0.20 m above the floor |
    | ``tilt`` | True | the action also sets the magnet's axis (False: its position only) |
    | ``max_tilt`` | pi | ``tilt=True``: largest angle of the axis from +z (rad) |
    | ``max_speed`` | 0.1 | largest speed of the magnet's centre (m/s) |
    | ``max_turn_rate`` | 2 pi | largest turn rate of its axis (rad/s) |
    | ``field_scale`` | 0.003 | the observed field's unit (T) |
    | ``motion_cost_weight`` | 0.0 | weight of the normalized squared displacement |
    | others | | as :class:`~magsoft_env.envs.steer.MagSoftSteerEnv` (``robot``, ``ctrl_dt``, ``sim_dt``, |
    | | | ``segments``, ``goal_distance``, ``clock_frequency``, ``crawl_mode``, ``render_mode``, ...); not |
    | | | ``action_mode``, ``field_limit``, ``field_cost_weight``, ``frequency_range`` |

    ## Version History

    - v0: initial version (the axis is part of the action by default, ``tilt=True``: with the position alone the
      hand controller reaches 0 of 10 shared goals, tilting 10 of 10).
    """

    cost_key = "reward_motion"

    def __init__(self, robot="paper-5c", *, magnet_diameter: float = DEFAULT_MAGNET_DIAMETER,
                 magnet_length: float = DEFAULT_MAGNET_LENGTH, remanence: float = DEFAULT_REMANENCE,
                 workspace_bounds=None, tilt: bool = True, max_tilt: float = math.pi,
                 max_speed: float = DEFAULT_MAX_SPEED, max_turn_rate: float = DEFAULT_MAX_TURN_RATE,
                 field_scale: float = DEFAULT_FIELD_SCALE, motion_cost_weight: float = 0.0, **kwargs):
        from ..fields import CylinderMagnet, MagnetWorkspace

        d = positive("magnet_diameter", magnet_diameter, unit="m")
        length = positive("magnet_length", magnet_length, unit="m")
        for name, v in (("magnet_diameter", d), ("magnet_length", length)):
            if v > 0.2:
                raise ValueError(f"{name} must lie in (0, 0.2] m (sizes are in metres: 15 mm is 0.015), got {v!r}.")
        br = in_range("remanence", remanence, 0.0, 1.5, unit="T")
        if br <= 0.0:
            raise ValueError(f"remanence must lie in (0, 1.5] T (NdFeB: 1.2), got {remanence!r}.")
        bounds = None
        if workspace_bounds is not None:
            bounds = finite_array("workspace_bounds", workspace_bounds)
            if bounds.shape != (3, 2) or np.any(bounds[:, 0] > bounds[:, 1]):
                raise ValueError(f"workspace_bounds must be [[xmin, xmax], [ymin, ymax], [zmin, zmax]] in m with "
                                 f"min <= max, got {workspace_bounds!r}.")
        self.tilt = boolean("tilt", tilt)
        self.max_tilt = in_range("max_tilt", max_tilt, 0.0, math.pi, unit="rad")
        self.max_speed = positive("max_speed", max_speed, unit="m/s")
        self.max_turn_rate = positive("max_turn_rate", max_turn_rate, unit="rad/s")
        cost = nonnegative("motion_cost_weight", motion_cost_weight)
        self.magnet = CylinderMagnet(position=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), radius=0.5 * d, length=length,
                                     magnetization=br / _MU0)
        self.magnet_diameter, self.magnet_length, self.remanence = d, length, br
        self._extra_high = np.concatenate([np.full(3, 1.0), np.ones(3)])
        self._p0 = self._p1 = self._target = np.zeros(3)
        self._a0 = self._a1 = np.array([0.0, 0.0, 1.0])
        self._t0, self._span = 0.0, 1.0
        self.workspace = None
        super().__init__(robot, field_scale=field_scale, cost_weight=cost, **kwargs)
        self.motion_cost_weight = cost
        if bounds is None:
            c = self.com_position()
            h = DEFAULT_REACH
            bounds = np.array([[c[0] - h, c[0] + h], [c[1] - h, c[1] + h], list(DEFAULT_HEIGHTS)])
        if bounds[2, 0] <= 0.5 * length:
            raise ValueError(f"workspace_bounds z must keep the magnet above the floor: zmin > magnet_length / 2 = "
                             f"{0.5 * length:g} m, got {bounds[2, 0]!r}.")
        self.workspace = MagnetWorkspace(bounds=bounds, max_tilt=self.max_tilt if self.tilt else 0.0)
        self.max_step = self.max_speed * self.n_substeps * self.sim_dt
        self.action_space = spaces.Box(-1.0, 1.0, (5 if self.tilt else 3,), np.float32)
        self._attach_source()

    # ------------------------------------------------------------------ the actuator
    @property
    def magnet_position(self) -> np.ndarray:
        """The magnet's centre now (m), shape (3,)."""
        return self._p1.copy()

    @property
    def magnet_axis(self) -> np.ndarray:
        """The magnet's axis now (unit, shape (3,)): its moment's direction."""
        return self._a1.copy()

    @property
    def magnet_moment(self) -> float:
        """The magnet's moment (A m^2)."""
        return float(np.linalg.norm(self.magnet.moment))

    def _start_pose(self) -> np.ndarray:
        b = self.workspace.bounds
        return np.array([0.5 * (b[0, 0] + b[0, 1]), 0.5 * (b[1, 0] + b[1, 1]), b[2, 1]])

    def _reset_actuator(self) -> None:
        if self.workspace is None:  # during the base's construction
            return
        self._p0 = self._p1 = self._target = self._start_pose()
        self._a0 = self._a1 = np.array([0.0, 0.0, 1.0])
        self._t0, self._span = 0.0, self.n_substeps * self.sim_dt

    def pose_of_action(self, action) -> tuple[np.ndarray, np.ndarray]:
        """The commanded ``(position (m), axis)`` of an action."""
        a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        b = self.workspace.bounds
        p = b[:, 0] + 0.5 * (a[:3] + 1.0) * (b[:, 1] - b[:, 0])
        axis = _axis_of(a[3], a[4], self.max_tilt) if self.tilt else np.array([0.0, 0.0, 1.0])
        return p, axis

    def action_of_pose(self, position, axis=None) -> np.ndarray:
        """The action that commands the magnet to ``position`` (m; clipped to the box) and, with ``tilt``, ``axis``
        (a direction; tilts beyond ``max_tilt`` are reduced to it)."""
        b = self.workspace.bounds
        width = np.where(b[:, 1] > b[:, 0], b[:, 1] - b[:, 0], 1.0)
        a = 2.0 * (np.asarray(position, dtype=float) - b[:, 0]) / width - 1.0
        if self.tilt:
            ax = np.array([0.0, 0.0, 1.0]) if axis is None else np.asarray(axis, dtype=float)
            ax = ax / np.linalg.norm(ax)
            th = math.atan2(math.hypot(ax[0], ax[1]), ax[2])
            r = min(1.0, th / self.max_tilt) if self.max_tilt > 0 else 0.0
            ph = math.atan2(ax[1], ax[0])
            a = np.concatenate([a, [r * math.cos(ph), r * math.sin(ph)]])
        return np.clip(a, -1.0, 1.0).astype(np.float32)

    def _apply(self, action) -> tuple[int, float]:
        """Plan the step: the magnet moved toward the command at the bounded speed and turn rate; ``(substeps,
        (d / max_step)^2)``."""
        target, axis = self.pose_of_action(action)
        p0, a0 = self._p1, self._a1
        d = target - p0
        dist = float(np.linalg.norm(d))
        p1 = target if dist <= self.max_step else p0 + d * (self.max_step / dist)
        p1 = np.clip(p1, self.workspace.bounds[:, 0], self.workspace.bounds[:, 1])  # rounding
        a1 = _turn(a0, axis, self.max_turn_rate * self.n_substeps * self.sim_dt) if self.tilt else a0
        self._p0, self._p1, self._a0, self._a1, self._target = p0, p1, a0, a1, target
        self._t0, self._span = self.sim.time, self.n_substeps * self.sim_dt
        moved = float(np.linalg.norm(p1 - p0))
        return self.n_substeps, (moved / self.max_step) ** 2

    def _pose_at(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The magnet's ``(centre, axis)`` at simulation time ``t``: moved at a constant rate along the step."""
        f = min(max((t - self._t0) / self._span, 0.0), 1.0)
        p = self._p0 + f * (self._p1 - self._p0)
        if self._a0 is self._a1 or np.array_equal(self._a0, self._a1):
            return p, self._a1
        angle = math.acos(float(np.clip(np.dot(self._a0, self._a1), -1.0, 1.0)))
        return p, _turn(self._a0, self._a1, f * angle)

    def _source_at(self, points, t):
        from ..fields.base import to_global

        p, axis = self._pose_at(t)
        if axis[2] == 1.0:
            return self.magnet.field_and_gradient(points - p)
        R = _frame(axis)
        B, G = self.magnet.field_and_gradient((points - p) @ R)
        return to_global(B, G, R)

    def _extra_obs(self) -> np.ndarray:
        return np.concatenate([self._p1 - self._com, self._a1])

    def _actuator_info(self) -> dict:
        return {"magnet_position": self._p1.copy(), "magnet_axis": self._a1.copy(),
                "magnet_target": self._target.copy()}

    def _stepping(self, action, block: int | None = None):
        obs, reward, terminated, truncated, info = yield from super()._stepping(action, block)
        if not truncated and self._touching():
            # the simulator has no contact with the magnet: a strip pulled up to it would pass through it; a goal
            # "reached" on the way up (the distance is horizontal) is no success
            info["magnet_contact"] = True
            terminated = True
            if info["is_success"]:
                reward -= info["reward_success"]
                info.update(is_success=False, reward_success=0.0, reward=reward)
                info.pop("time_to_goal", None)
                self._success = False
        return obs, reward, terminated, truncated, info

    def _touching(self) -> bool:
        """Whether a point of the strip lies within the magnet's bounding sphere plus :data:`CONTACT_MARGIN`, or
        as high as that sphere's bottom (it flew up to the magnet, maybe through it within the step)."""
        x, y, z = self.sim.centerline()
        d = np.linalg.norm(np.stack([x, y, z], axis=1) - self._p1, axis=1)
        reach = math.hypot(0.5 * self.magnet_diameter, 0.5 * self.magnet_length) + CONTACT_MARGIN
        return bool(d.min() < reach or z.max() > self._p1[2] - reach)

    # ------------------------------------------------------------------ the hand controller
    def field_action(self, field) -> np.ndarray:
        """The action (``tilt=True`` only) that makes ``field`` (T, (3,)) at the strip's centre of mass as near as
        the magnet can: the magnet straight above the centre of mass, its axis such that the field below it (a
        dipole's, ``(-m_x, -m_y, 2 m_z)`` per unit) points along ``field``, and its height such that the dipole's
        field there has the magnitude of ``field``, within the workspace's heights (at the lowest, about 1.2-2.3 mT
        for the default magnet). A zero field: the magnet at its highest, its axis kept."""
        if not self.tilt:
            raise ValueError("field_action needs the magnet's axis in the action (tilt=True): with the position "
                             "alone the field's direction at the strip cannot be chosen.")
        b = np.asarray(field, dtype=float)
        amp = float(np.linalg.norm(b))
        com = self._com
        low, high = self.workspace.bounds[2]
        if amp == 0.0:
            return self.action_of_pose([com[0], com[1], high], self._a1)
        d = b / amp
        axis = np.array([-d[0], -d[1], 0.5 * d[2]])
        axis /= np.linalg.norm(axis)
        gain = math.hypot(math.hypot(axis[0], axis[1]), 2.0 * axis[2])  # |B| per mu0 m / (4 pi h^3)
        h = (1e-7 * self.magnet_moment * gain / amp) ** (1.0 / 3.0)
        return self.action_of_pose([com[0], com[1], min(max(com[2] + h, low), high)], axis)

    def baseline_action(self, obs=None) -> np.ndarray:
        """The hand controller's action (:func:`magnet_controller`)."""
        return magnet_controller(self._last_obs if obs is None else obs, self)


def magnet_controller(obs, env, *, lead: float = CONTROLLER_LEAD) -> np.ndarray:
    """The hand controller of ``MagSoftMagnet-v0`` (``env`` the env or its wrapper). ``tilt=False``: the magnet at
    its lowest height, ``lead`` (m) ahead of the strip's centre of mass toward the goal (not beyond the goal), which
    pulls the strip. ``tilt=True``: the magnet at its lowest height straight above the strip, its axis along
    ``(cos(w t) u, sin(w t) / 2)`` (u toward the goal), so that the field below it, ``(-m_h, 2 m_z)`` per unit,
    turns as :func:`~magsoft_env.envs.steer.steer_controller`'s and tumbles the strip toward the goal."""
    e = env.unwrapped
    o = np.asarray(obs, dtype=float)
    com = e._com
    g = o[0:2]
    dist = float(np.hypot(*g))
    u = g / dist if dist > 0 else np.zeros(2)
    zlow = e.workspace.bounds[2, 0]
    if not e.tilt:
        xy = com[:2] + u * min(lead, dist)
        return e.action_of_pose([xy[0], xy[1], zlow])
    s, c = o[e.steer_obs_size - 2], o[e.steer_obs_size - 1]
    axis = np.array([c * u[0], c * u[1], 0.5 * s])
    return e.action_of_pose([com[0], com[1], zlow], axis)


class MagSoftMagnetVecEnv(MagSoftSteerVecEnv):
    """:class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv` of :class:`MagSoftMagnetEnv` (``MagSoftMagnet-v0``): the
    robots on threads, each bit for bit the single env under the same seed and actions (every physics step under a
    field source runs from Python: little gain from threads). CPU only."""

    env_class = MagSoftMagnetEnv


__all__ = ["MagSoftMagnetEnv", "MagSoftMagnetVecEnv", "magnet_controller"]

"""MagSoftSteer-v0: the 3D strip on a floor, steered to a goal point by the three-axis field (B_x, B_y, B_z)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..cases.gaits import numerics
from ..cases.robots import resolve_robot
from ..sim import SimulationError, Simulator
from ..sim.gait import gait_rod_options
from ..sim.health import check_steps
from ..sim.model import MAX_TIMESTEP
from ..sim.readouts import PitchTracker, is_flipped, pitch_orientation
from ..sim.waveforms import Conical
from ..validate import choice, finite_array, finite_number, nonnegative, positive
from . import as_action, instability_info, refuse_unknown_kwargs, run_to_end, warn_ignored_source
from .crawl import (
    DEFAULT_MAX_CLEARANCE,
    DEFAULT_MAX_HEIGHT,
    DEFAULT_MAX_LINK_ROTATION,
    draw_material,
    material_options,
    material_range,
)
from .crawl_task import (
    CRAWL_MODES,
    CrawlRecords,
    CrawlTask,
    book_substeps,
    crawl_limits,
    first_violation,
    locomotion_modes,
    violation_texts,
)

#: Default coil limit per axis (T). A field of 3 mT turning in a vertical plane at 1 Hz tumbles the paper-5c strip
#: end over end at about 40 mm/s along the plane's horizontal direction (the strip turns into that plane within the
#: first half-turn); at the crawl envs' 2 mT it crawls at under 1 mm/s.
DEFAULT_FIELD_LIMIT = 3e-3
#: Default control interval (s).
DEFAULT_CTRL_DT = 0.02
#: Default rod cells: the tumbling gait's displacement after 2 s differs by about 2 % of its 80 mm between 10 and 20
#: cells, at half the cost.
DEFAULT_SEGMENTS = 10
#: A cheaper simulation step for training (s): the hand controller's time to goal on four goals is the same within
#: 0.02 s at 0.2 ms (paper-5c's own, the default) and at 0.4 ms, at half the cost, but the deepest floor contact
#: doubles (random actions: 0.43-0.54 mm against 0.19-0.23 mm of the 1.13 mm thickness; the controller 0.17 mm
#: against 0.06-0.10 mm). 6 cells instead of 10 changed the time to goal by up to 0.5 s.
TRAINING_SIM_DT = 4e-4
#: Goal distance from the strip's starting centre of mass (m), drawn uniformly in this range.
DEFAULT_GOAL_DISTANCE = (0.02, 0.06)
#: Reached: the centre of mass within this horizontal distance of the goal (m).
DEFAULT_GOAL_RADIUS = 5e-3
#: Lost: the centre of mass farther than this from the goal ends the episode (m).
DEFAULT_MAX_DISTANCE = 0.15
#: Waveform mode: the rotating field's frequencies (Hz).
DEFAULT_FREQUENCY_RANGE = (0.25, 2.0)
ACTION_MODES = ("field", "waveform")
#: Observation bounds (observations are clipped to them): positions (m), velocities (m/s).
OBS_MAX_POSITION = 1.0
OBS_MAX_VELOCITY = 10.0


class MagSoftSteerEnv(gym.Env):
    """
    ## Description

    The paper's Fig. 5c strip (or any robot) lies on a floor as the 3D MuJoCo rod (the flexcomp strip of
    :mod:`magsoft_env.sim.cable`: bending both ways, twist, width-wise floor contact). A goal point on the
    floor is drawn at every reset; the agent chooses the three-axis field and must bring the strip's centre of
    mass within ``goal_radius`` of the goal.

    How the field moves it: the strip's net magnetic moment is nearly axial, so a horizontal field turns it
    (yaw) like a compass needle, and a field turning in a vertical plane rolls it end over end along that
    plane's horizontal direction (tumbling; at 3 mT and 1 Hz about 40 mm/s). The plane's direction steers.
    :func:`steer_controller` is the hand-designed baseline: the field turns at ``clock_frequency`` in the
    vertical plane through the goal, so the strip turns toward the goal within the first half-turn and
    tumbles to it. Fields up to about 2 mT crawl instead (under 1 mm/s; the crawl envs' regime).

    ## Action Space

    ``action_mode="field"`` (default): ``Box(-1, 1, (3,), float32)``; the field held for ``ctrl_dt`` seconds.

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | 0 | B_x / field_limit | -1 | 1 | field (T) |
    | 1 | B_y / field_limit | -1 | 1 | field (T) |
    | 2 | B_z / field_limit | -1 | 1 | field (T) |

    ``action_mode="waveform"`` (``MagSoftSteerWaveform-v0``, 0.1 s steps): ``Box(-1, 1, (4,), float32)``; each step
    plays ``ctrl_dt`` seconds of a field of magnitude ``A`` turning at ``f`` in the vertical plane through the
    horizontal direction ``u``, ``B = A (-cos(phi) u + sin(phi) z)``, which tumbles the strip along ``+u``; the
    phase ``phi`` runs on from step to step (``2 pi f`` per second).

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | 0, 1 | direction u (x, y), normalized; both 0: no field | -1 | 1 | dimensionless |
    | 2 | A, mapped linearly onto [0, field_limit] | -1 | 1 | field (T) |
    | 3 | f, mapped linearly onto ``frequency_range`` | -1 | 1 | frequency (Hz) |

    ## Observation Space

    ``Box(-high, high, (3 P + 11,), float32)`` for the strip's P points (P = N + 2 for N = ``segments``:
    paper-5c's default 10 cells give 47); world frame, SI, clipped to 1 m and 10 m/s:

    | Num | Observation | Type (Unit) |
    |-----|-------------|-------------|
    | 0, 1 | goal minus centre of mass, x and y | position (m) |
    | 2 | horizontal distance to the goal | position (m) |
    | 3 .. 5 | centre-of-mass velocity (x, y, z), mean over the last step | velocity (m/s) |
    | 6 .. 3P+5 | the strip's points minus its centre of mass, (x, y, z) per point, first end first | position (m) |
    | 3P+6 .. 3P+8 | the field now, B / field_limit | dimensionless |
    | 3P+9, 3P+10 | sin, cos of the clock phase ``2 pi clock_frequency t`` (waveform mode: ``phi``) | dimensionless |

    ## Rewards

    ``reward = progress + field_cost + crawl + success``, each term in ``info`` (``reward_progress``,
    ``reward_field``, ``reward_crawl``, ``reward_success``):

    - ``progress = progress_reward_weight * (d_before - d_after)``: the step's approach to the goal (default
      weight 1000 / m: the term reads in mm, and an episode's sum is the distance covered toward the goal).
    - ``field_cost = -field_cost_weight * |B|^2 / field_limit^2`` (waveform mode: ``A^2 / field_limit^2``).
    - ``crawl = -crawl_penalty`` on the step that breaks a crawl limit (``crawl_mode`` other than ``"none"``); that
      step's progress is 0.
    - ``success = success_reward`` on the step that reaches the goal.

    ## Starting State

    The straight strip lies flat on the floor along +x, first end at the origin, at rest, zero field; its
    vertices perturbed by ``U(-reset_noise_scale, reset_noise_scale)`` m horizontally. The goal lies at a
    distance drawn from ``U(goal_distance)`` and a bearing from ``U(-pi, pi)`` from the centre of mass
    (``reset(options={"goal": (x, y)})`` sets it).

    ## Episode End

    - Termination: the goal reached (``info["is_success"]``, ``info["time_to_goal"]``), the centre of mass
      farther than ``max_distance`` from it (``info["lost"]``), or, with ``crawl_mode`` other than ``"none"`` (the
      default: a tumble with flights is this task's fastest locomotion), a crawl limit of the crawl env broken at
      any substep (``info["crawl_violation"]``: the whole strip more than ``max_clearance`` above the floor, or a
      piece turned more than ``max_link_rotation`` from the floor toward +z, or (``"height"``) higher than
      ``max_height``).
    - Truncation: the time limit (``max_episode_steps`` of the registered id: 250 steps = 5 s), or an unstable
      or unphysical simulation (``info["truncation_reason"]``, and ``info["unphysical"]`` with its figures, as
      in the crawl envs; docs/sim.md, "Physical checks").

    ``info`` also carries ``orientation`` (rad, end over end: the strip's mean direction from the floor in its
    own vertical plane, continuous, +-pi after one flip; :class:`~magsoft_env.sim.readouts.PitchTracker`),
    ``flipped`` (it has been past vertical this episode: it tumbled), ``turned`` (rad, how far it turned on
    the floor this episode), the goal, the centre of mass (``x_position``, ``y_position``, ``z_position``), the
    ``heading`` (rad, of the second end from the first, on the floor), ``distance`` (= ``position_error``), the
    ``field`` (T, three components), ``time`` and ``max_penetration`` (m), and how the strip moves, read at every
    substep as the crawl envs read it (``envs.crawl_task``): ``highest_clearance`` (m, the lowest vertex's height
    minus h/2, highest over the episode), ``airborne_fraction`` (substeps with the whole strip more than 0.01 mm
    above the floor), ``largest_piece_angle`` (rad, from the floor toward +z), ``max_roll`` (rad) and
    ``locomotion`` (``"crawl"``, ``"hop"``, ``"roll"``, ``"tumble"``, ``"tumble with flight"``).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``robot`` | ``"paper-5c"`` | built-in name (``list_robots()``), robot file (.yml, .json) or ``Robot`` |
    | ``action_mode`` | ``"field"`` | ``"field"`` or ``"waveform"`` |
    | ``field_limit`` | 0.003 | coil limit per axis (T) |
    | ``ctrl_dt`` | 0.02 | control interval (s), >= ``sim_dt`` |
    | ``sim_dt`` | None | simulation step (s); None: the robot's own (paper-5c: 0.2 ms); 0.4 ms trains at half the |
    | | | cost with twice the contact depth (:data:`TRAINING_SIM_DT`) |
    | ``segments`` | 10 | strip cells |
    | ``friction`` | None | strip-floor sliding friction; None: the robot's (0.5) |
    | ``modulus_range`` | None | domain randomization: a factor of the elastomer's modulus ``E0`` drawn from |
    | | | ``U(low, high)`` at every reset, in [0.1, 10] (``Simulator.set_material_scale``) |
    | ``magnetization_range`` | None | the same for the particles' magnetization ``M_p`` |
    | ``goal_distance`` | (0.02, 0.06) | range of the goal's distance at reset (m) |
    | ``goal_radius`` | 0.005 | reached within this distance (m) |
    | ``max_distance`` | 0.15 | lost beyond this distance (m) |
    | ``progress_reward_weight`` | 1000 | (1/m) |
    | ``field_cost_weight`` | 0.1 | weight of the normalized field power |
    | ``success_reward`` | 20 | reward on reaching the goal |
    | ``clock_frequency`` | 1 | clock observed as sin/cos in field mode (Hz); the hand controller's frequency |
    | ``frequency_range`` | (0.25, 2) | waveform-mode frequencies (Hz) |
    | ``reset_noise_scale`` | 1e-5 | initial vertex noise (m) |
    | ``crawl_mode`` | ``"none"`` | ``"none"``, or the crawl env's limits: ``"rotation"`` or ``"height"`` |
    | ``max_clearance`` | 1e-5 | crawl modes: the episode ends when the whole strip is higher above the floor (m) |
    | ``max_link_rotation`` | 2 pi / 3 | crawl mode ``"rotation"`` (rad) |
    | ``max_height`` | 7.6e-3 | crawl mode ``"height"`` (m) |
    | ``crawl_penalty`` | 10 | reward lost when a crawl limit is broken |
    | ``render_mode`` | None | ``"rgb_array"`` |
    | ``width``, ``height`` | 960, 540 | frame size (pixels) |

    ## Version History

    - v0: initial version (``MagSoftSteer-v0``, ``MagSoftSteerWaveform-v0``).
    - v0, magsoft_env 0.4: ``info`` reports how the strip moves (``highest_clearance``, ``airborne_fraction``,
      ``largest_piece_angle``, ``max_roll``, ``locomotion``, ``reward_crawl``); ``crawl_mode`` and the crawl limits
      as an option (default ``"none"``: the same episodes as before).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}
    def __init__(
        self,
        robot="paper-5c",
        *,
        action_mode: str = "field",
        field_limit: float = DEFAULT_FIELD_LIMIT,
        ctrl_dt: float = DEFAULT_CTRL_DT,
        sim_dt: float | None = None,
        segments: int = DEFAULT_SEGMENTS,
        friction: float | None = None,
        modulus_range: tuple[float, float] | None = None,
        magnetization_range: tuple[float, float] | None = None,
        goal_distance: tuple[float, float] = DEFAULT_GOAL_DISTANCE,
        goal_radius: float = DEFAULT_GOAL_RADIUS,
        max_distance: float = DEFAULT_MAX_DISTANCE,
        progress_reward_weight: float = 1000.0,
        field_cost_weight: float = 0.1,
        success_reward: float = 20.0,
        clock_frequency: float = 1.0,
        frequency_range: tuple[float, float] = DEFAULT_FREQUENCY_RANGE,
        reset_noise_scale: float = 1e-5,
        crawl_mode: str = "none",
        max_clearance: float | None = DEFAULT_MAX_CLEARANCE,
        max_link_rotation: float = DEFAULT_MAX_LINK_ROTATION,
        max_height: float = DEFAULT_MAX_HEIGHT,
        crawl_penalty: float = 10.0,
        render_mode: str | None = None,
        width: int = 960,
        height: int = 540,
        **unknown,
    ):
        refuse_unknown_kwargs(self, unknown)
        self.gait = resolve_robot(robot)  # checked before any work
        warn_ignored_source(self, self.gait)
        self.action_mode = choice("action_mode", action_mode, ACTION_MODES)
        self.field_limit = positive("field_limit", field_limit, unit="T")
        if self.field_limit > 0.1:
            raise ValueError(f"field_limit must be <= 0.1 T (fields are in tesla: 3 mT is 0.003), got {field_limit!r}.")
        if sim_dt is not None:
            positive("sim_dt", sim_dt, unit="s")
        if isinstance(segments, (bool, np.bool_)) or not isinstance(segments, (int, np.integer)) \
                or not 2 <= segments <= 200:
            raise ValueError(f"segments must be an integer in [2, 200], got {segments!r}.")
        segments, self.sim_dt = numerics(self.gait, segments=int(segments), timestep=sim_dt)
        if self.sim_dt > MAX_TIMESTEP:
            raise ValueError(f"sim_dt must lie in (0, {MAX_TIMESTEP:g}] s, got {sim_dt!r}.")
        self.ctrl_dt = positive("ctrl_dt", ctrl_dt, unit="s")
        if self.sim_dt > self.ctrl_dt:
            raise ValueError(f"sim_dt must be <= ctrl_dt ({self.ctrl_dt:g} s), got {sim_dt!r}.")
        self.n_substeps = max(1, int(round(check_steps(
            f"ctrl_dt / sim_dt = {self.ctrl_dt:g} s / {self.sim_dt:g} s per env step", self.ctrl_dt / self.sim_dt,
            "Use a larger sim_dt or a smaller ctrl_dt."))))
        self.goal_distance = _range("goal_distance", goal_distance, unit="m")
        self.goal_radius = positive("goal_radius", goal_radius, unit="m")
        self.max_distance = positive("max_distance", max_distance, unit="m")
        if self.max_distance <= self.goal_distance[1]:
            raise ValueError(f"max_distance must exceed the largest goal distance {self.goal_distance[1]:g} m, "
                             f"got {max_distance!r}.")
        self.progress_reward_weight = nonnegative("progress_reward_weight", progress_reward_weight, unit="1/m")
        self.field_cost_weight = nonnegative("field_cost_weight", field_cost_weight)
        self.success_reward = nonnegative("success_reward", success_reward)
        self.clock_frequency = positive("clock_frequency", clock_frequency, unit="Hz")
        self.frequency_range = _range("frequency_range", frequency_range, unit="Hz")
        self.reset_noise_scale = nonnegative("reset_noise_scale", reset_noise_scale, unit="m")
        self.crawl_mode = choice("crawl_mode", crawl_mode, CRAWL_MODES)
        self.max_clearance = None if max_clearance is None else positive("max_clearance", max_clearance, unit="m")
        self.max_link_rotation = positive("max_link_rotation", max_link_rotation, unit="rad")
        if self.max_link_rotation > math.pi:
            raise ValueError(f"max_link_rotation must lie in (0, pi] rad, got {max_link_rotation!r}.")
        self.max_height = positive("max_height", max_height, unit="m")
        self.crawl_penalty = nonnegative("crawl_penalty", crawl_penalty)
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}.")
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 16 <= v <= 4096:
                raise ValueError(f"{name} must be an integer number of pixels in [16, 4096], got {v!r}.")
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)

        self.robot = self.gait.name
        options = gait_rod_options(self.gait, segments=segments, timestep=self.sim_dt, friction=friction, rod="cable")
        self.modulus_range = material_range("modulus_range", modulus_range)
        self.magnetization_range = material_range("magnetization_range", magnetization_range)
        options = material_options(options, self.gait.beam, self.modulus_range)
        self.sim = Simulator(self.gait.beam, options, field=(0.0, 0.0, 0.0), check_every=max(50, self.n_substeps))
        self.segments = options.segments
        self._npoints = len(self.sim.centerline()[0])
        # the strip's centreline at every substep (MuJoCo's sensor histories) and its pieces' lengths: the crawl
        # limits' figures, as the crawl envs read them
        self._nodes = self.sim.centreline_history()
        self._floor = self.sim.floor_contact_history()
        self._inv_piece_length = 1.0 / self.sim.pose().lengths
        self._records = CrawlRecords.zeros(1)
        self._samples: list = []
        self.metadata = {**self.metadata, "render_fps": int(round(1.0 / (self.n_substeps * self.sim_dt)))}
        self.action_space = spaces.Box(-1.0, 1.0, (3 if self.action_mode == "field" else 4,), np.float32)
        p = self._npoints
        high = np.concatenate([np.full(3, OBS_MAX_POSITION), np.full(3, OBS_MAX_VELOCITY),
                               np.full(3 * p, OBS_MAX_POSITION), np.ones(5)]).astype(np.float32)
        self.observation_space = spaces.Box(-high, high, dtype=np.float32)
        self._renderer = None
        self._field = np.zeros(3)
        self._phase = 0.0  # waveform mode: the rotating field's phase (rad)
        self._goal = np.zeros(2)
        self._com = np.zeros(3)
        self._com_vel = np.zeros(3)
        self._distance = 0.0
        self._broken = False
        self._success = False
        self._pitch = PitchTracker()
        self._heading0 = 0.0
        self._flipped = False
        self._last_obs = np.zeros(self.observation_space.shape, np.float32)

    # ------------------------------------------------------------------ readouts
    @property
    def goal(self) -> np.ndarray:
        """The goal point (x, y) on the floor (m)."""
        return self._goal.copy()

    def com_position(self) -> np.ndarray:
        """Centre of mass (x, y, z) of the strip (m)."""
        return np.asarray(self.sim.center_of_mass(), dtype=float)

    def heading(self) -> float:
        """Direction of the strip's second end from its first, on the floor (rad from +x toward +y)."""
        x, y, _ = self.sim.centerline()
        return math.atan2(y[-1] - y[0], x[-1] - x[0])

    def _horizontal_distance(self) -> float:
        return float(math.hypot(*(self._goal - self._com[:2])))

    def position_observation_indices(self) -> np.ndarray:
        """Indices of the observation entries a tracking camera measures as positions (m): the goal minus the
        centre of mass, the distance, and the strip's points relative to it (what
        :class:`~magsoft_env.envs.sensing.SensingWrapper` puts noise on)."""
        n = len(self.sim.centerline()[0])
        return np.r_[0:3, 6:6 + 3 * n]

    def _get_obs(self) -> np.ndarray:
        x, y, z = self.sim.centerline()
        rel = np.stack([x, y, z], axis=1) - self._com
        w = 2.0 * math.pi * self.clock_frequency * self.sim.time if self.action_mode == "field" else self._phase
        obs = np.concatenate([self._goal - self._com[:2], [self._distance], self._com_vel, rel.ravel(),
                              self._field / self.field_limit, [math.sin(w), math.cos(w)]]).astype(np.float32)
        return np.clip(obs, self.observation_space.low, self.observation_space.high)

    # ------------------------------------------------------------------ gymnasium API
    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        options = dict(options or {})
        goal = options.pop("goal", None)
        if options:
            raise ValueError(f"reset options must be None or {{'goal': (x, y)}} (m), got keys {sorted(options)}.")
        try:  # the goal checked before any work; strings and bools refused, not converted
            goal_xy = None if goal is None else finite_array("goal", goal)
        except ValueError:
            goal_xy = np.empty(0)
        if goal_xy is not None and goal_xy.shape != (2,):
            raise ValueError(f"options['goal'] must be a point (x, y) on the floor in m, shape (2,): two finite "
                             f"numbers within max_distance = {self.max_distance:g} m of the strip's centre of mass, "
                             f"e.g. (0.03, 0.0), got {goal!r}.")
        sim = self.sim
        sim.reset()
        sim.set_field((0.0, 0.0, 0.0))
        if self.reset_noise_scale > 0.0:
            self._perturb()
        self._field = np.zeros(3)
        self._phase = 0.0
        self._com = self.com_position()
        self._com_vel = np.zeros(3)
        if goal is None:
            r = self.np_random.uniform(*self.goal_distance)
            bearing = self.np_random.uniform(-math.pi, math.pi)
            self._goal = self._com[:2] + r * np.array([math.cos(bearing), math.sin(bearing)])
        else:
            self._goal = goal_xy.copy()
        # drawn last: episodes without the material ranges draw as before
        material = draw_material(self)
        self._distance = self._horizontal_distance()
        if goal is not None and self._distance >= self.max_distance:
            raise ValueError(f"options['goal'] must lie within max_distance = {self.max_distance:g} m of the strip's "
                             f"centre of mass, got {self._distance:g} m.")
        self._start_distance = self._distance
        self._pitch = PitchTracker()
        pitch_orientation(sim, self._pitch)  # its reference heading: the strip's at the start
        self._heading0 = self._pitch.heading
        start = self._limits(sim.pose().centreline[:, None, :], [sim.floor_depth()])
        self._records.restart([True], com=self._com[None, [0, 2]], start_limits=start[:, :, 0])
        self._flipped = False
        self._broken = False
        self._success = False
        self._last_obs = self._get_obs()
        info = self._info(0.0)
        info.update(material)
        return self._last_obs, info

    def _perturb(self) -> None:
        """Move the free vertices horizontally by ``U(-reset_noise_scale, reset_noise_scale)`` (m)."""
        sim, cm = self.sim, self.sim.backend.rod
        adr = cm.vertex_qpos[cm.vertex_body > 0][:, :2].ravel()  # slides x, y of each free vertex
        qpos, _ = sim.state()
        qpos[adr] += self.np_random.uniform(-self.reset_noise_scale, self.reset_noise_scale, adr.size)
        sim.set_state(qpos=qpos)

    def field_of_action(self, action) -> np.ndarray:
        """The field (T) an action in [-1, 1]^3 asks for."""
        return np.clip(np.asarray(action, dtype=float), -1.0, 1.0) * self.field_limit

    def baseline_action(self, obs=None) -> np.ndarray:
        """The hand-designed controller's action for ``obs`` (default: the last observation): field mode
        :func:`steer_controller`; waveform mode the same field, full magnitude at ``clock_frequency`` toward the goal
        (:meth:`action_of_wave`)."""
        o = self._last_obs if obs is None else np.asarray(obs)
        if self.action_mode == "field":
            return steer_controller(o)
        return self.action_of_wave(o[:2], self.field_limit, self.clock_frequency)

    def wave_of_action(self, action) -> tuple[np.ndarray, float, float]:
        """Waveform mode: ``(u, A, f)`` of an action: the unit direction (zeros: no field), magnitude (T) and
        frequency (Hz)."""
        a = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        n = math.hypot(a[0], a[1])
        u = a[:2] / n if n > 1e-6 else np.zeros(2)
        amp = 0.5 * (a[2] + 1.0) * self.field_limit if n > 1e-6 else 0.0
        lo, hi = self.frequency_range
        return u, amp, lo + 0.5 * (a[3] + 1.0) * (hi - lo)

    def action_of_wave(self, direction, magnitude: float, frequency: float) -> np.ndarray:
        """Waveform mode: the action for a field of ``magnitude`` (T) turning at ``frequency`` (Hz) that tumbles the
        strip along ``direction`` (x, y)."""
        d = np.asarray(direction, dtype=float)
        n = float(np.hypot(*d))
        u = d / n if n > 0 else np.zeros(2)
        lo, hi = self.frequency_range
        a = [u[0], u[1], 2.0 * magnitude / self.field_limit - 1.0, 2.0 * (frequency - lo) / (hi - lo) - 1.0 if hi > lo
             else 0.0]
        return np.clip(np.array(a), -1.0, 1.0).astype(np.float32)

    def _apply(self, action) -> tuple[int, float]:
        """Set the field of ``action`` for the coming step: ``(substeps, mean |B|^2 / field_limit^2)``."""
        if self.action_mode == "field":
            target = self.field_of_action(action)
            self.sim.set_field(tuple(float(b) for b in target))
            self._field = target
            return self.n_substeps, float(np.sum(target**2)) / self.field_limit**2
        u, amp, f = self.wave_of_action(action)
        if amp == 0.0:
            self.sim.set_field((0.0, 0.0, 0.0))
        else:
            back = (-u[0], -u[1], 0.0)  # e1 = -u, axis = -u x z: e2 = z (Conical's basis)
            axis = (-u[1], u[0], 0.0)
            self.sim.set_waveform(Conical(amp, f, axis=axis, reference=back, phase=self._phase))
        self._phase = math.remainder(self._phase + 2.0 * math.pi * f * self.n_substeps * self.sim_dt, 2.0 * math.pi)
        return self.n_substeps, (amp / self.field_limit) ** 2

    def step(self, action):
        return run_to_end(self._stepping(action))

    @property
    def task(self) -> CrawlTask:
        """The crawl limits as the crawl task's parameters (:class:`~magsoft_env.envs.crawl_task.CrawlTask`; its
        reward weights are not this env's)."""
        return CrawlTask(crawl_mode=self.crawl_mode, max_clearance=self.max_clearance,
                         max_link_rotation=self.max_link_rotation, max_height=self.max_height,
                         forward_reward_weight=0.0, target_direction=1, field_cost_weight=self.field_cost_weight,
                         crawl_penalty=self.crawl_penalty, field_limit=self.field_limit,
                         clock_frequency=self.clock_frequency)

    def _limits(self, points, contact) -> np.ndarray:
        """:func:`~magsoft_env.envs.crawl_task.crawl_limits` of centreline points ``(N + 2, k, 3)`` with their floor
        contacts ``(k,)``, from the strip's heading on the floor: ``(1, 3, k)``."""
        return crawl_limits(points[None], [self._pitch.heading], half_thickness=0.5 * self.gait.beam.thickness,
                            inv_piece_length=self._inv_piece_length, floor_contact=contact)

    def _read_block(self, start: int) -> int:
        """Keep the crawl limits' figures of the substeps since step count ``start`` (before the next block
        overwrites the sensors' history); returns the present step count."""
        k = self.sim.nstep - start
        if k > 0:
            self._samples.append(self._limits(self._nodes.last(k), self._floor.last(k)))
        return self.sim.nstep

    def _stepping(self, action, block: int | None = None):
        """:meth:`step` as a generator that yields between the physics' native blocks (the batched envs
        interleave their robots with it) and returns ``(obs, reward, terminated, truncated, info)``."""
        if self._broken:
            raise RuntimeError("step() called after the simulation became unstable; call reset() first.")
        action = as_action(self.action_space, action)
        n, power = self._apply(action)
        sim = self.sim
        self._samples = []
        done = sim.nstep
        try:
            for _ in sim.stepping(n, block=block):
                done = self._read_block(done)
                yield
            self._read_block(done)
        except SimulationError as err:
            self._broken = True
            self._samples = []
            info = instability_info(self._info(0.0), err)
            return self._last_obs.copy(), 0.0, False, True, info
        com = self.com_position()
        self._com_vel = (com - self._com) / (self.n_substeps * self.sim_dt)
        self._com = com
        # every substep's start state, then the step's end: clearance, highest point, piece angles from the floor
        pose = sim.pose()
        end = self._limits(pose.centreline[:, None, :], [self.sim.floor_depth()])
        lim, k = book_substeps(self._records, self._samples, end, com=self._com[None, [0, 2]],
                               duration=[n * self.sim_dt], roll=[pose.roll])
        self._samples = []
        task = self.task
        column, figures = first_violation(lim, task)
        violated = bool(column[0] >= 0)
        before, self._distance = self._distance, self._horizontal_distance()
        progress = 0.0 if violated else self.progress_reward_weight * (before - self._distance)
        crawl = -self.crawl_penalty if violated else 0.0
        self._field = self.sim.field.vector()
        field_cost = -self.field_cost_weight * power
        reached = self._distance <= self.goal_radius and not violated
        success = self.success_reward if reached else 0.0
        self._success = reached
        reward = progress + field_cost + crawl + success
        obs = self._get_obs()
        if not np.all(np.isfinite(obs)):
            self._broken = True
            info = self._info(0.0)
            info.update(truncation_reason="non-finite observation", instability="observation")
            return self._last_obs.copy(), 0.0, False, True, info
        self._last_obs = obs
        info = self._info(float(reward), progress=progress, field=field_cost, crawl=crawl, success=success)
        if violated:
            when = sim.time - (k - column) * self.sim_dt  # column j: j substeps into the step
            info["crawl_violation"] = violation_texts(figures, when, task, column >= 0)[0]
        lost = self._distance > self.max_distance
        if lost:
            info["lost"] = True
        return obs, float(reward), bool(reached or lost or violated), False, info

    def _info(self, reward: float, *, progress: float = 0.0, field: float = 0.0, crawl: float = 0.0,
              success: float = 0.0) -> dict:
        # end over end (continuous, +-pi per flip) and turns on the floor, apart (sim.readouts.PitchTracker)
        turn = pitch_orientation(self.sim, self._pitch)
        self._flipped = self._flipped or is_flipped(turn)
        info = {
            "orientation": turn, "flipped": self._flipped, "turned": self._pitch.heading - self._heading0,
            "reward_progress": float(progress), "reward_field": float(field), "reward_crawl": float(crawl),
            "reward_success": float(success),
            "reward": float(reward), "goal": self._goal.copy(), "distance": self._distance,
            "x_position": float(self._com[0]), "y_position": float(self._com[1]),
            "z_position": float(self._com[2]), "heading": self.heading(), "field": self._field.copy(),
            "time": self.sim.time, "is_success": self._success, "max_penetration": self.sim.max_penetration,
            "position_error": self._distance,
            **self._motion(),
        }
        if self._success:
            info["time_to_goal"] = self.sim.time
        return info

    def _motion(self) -> dict:
        """How the strip has moved this episode (module docstring, ``info``): from the crawl task's records."""
        r = self._records
        n = int(r.substeps[0])
        return {"highest_clearance": float(r.highest_clearance[0]),
                "airborne_fraction": float(r.airborne[0]) / n if n else 0.0,
                "largest_piece_angle": float(np.arccos(np.clip(r.lowest_cos[0], -1.0, 1.0))),
                "max_roll": float(r.max_roll[0]),
                "locomotion": locomotion_modes([self._flipped], r.airborne, r.max_roll)[0]}

    # ------------------------------------------------------------------ rendering
    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to the constructor.")
            return None
        if self._renderer is None:
            from ..render.views import make_renderer

            self._renderer = make_renderer(self.sim, width=self.width, height=self.height)
        return self._renderer.render(goal=tuple(self._goal), label=self.robot)  # the simulator's field

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


def _range(name: str, value, *, unit: str) -> tuple[float, float]:
    if isinstance(value, (str, bytes)) or not hasattr(value, "__len__") or len(value) != 2:
        raise ValueError(f"{name} must be (low, high) in {unit}, got {value!r}.")
    lo = finite_number(f"{name}[0]", value[0], unit=unit)
    hi = finite_number(f"{name}[1]", value[1], unit=unit)
    if not 0.0 < lo <= hi:
        raise ValueError(f"{name} must satisfy 0 < low <= high ({unit}), got {value!r}.")
    return lo, hi


def steer_controller(obs: np.ndarray, *, amplitude: float = 1.0) -> np.ndarray:
    """The hand-designed steering baseline: a field of ``amplitude`` (x field_limit) turning at the env's clock
    in the vertical plane through the goal, ``B = amplitude (-cos(w t) u + sin(w t) z)`` with ``u`` the unit
    vector from the centre of mass to the goal: the strip turns into that plane and tumbles along ``+u``.
    Observations only (``obs`` of :class:`MagSoftSteerEnv`, one or a batch), so it runs in vector envs and the
    evaluation scripts like a policy."""
    o = np.asarray(obs, dtype=float)
    single = o.ndim == 1
    o = np.atleast_2d(o)
    g = o[:, 0:2]
    u = g / np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
    s, c = o[:, -2], o[:, -1]
    a = np.empty((o.shape[0], 3))
    a[:, 0] = -c * u[:, 0]
    a[:, 1] = -c * u[:, 1]
    a[:, 2] = s
    a = np.clip(amplitude * a, -1.0, 1.0).astype(np.float32)
    return a[0] if single else a


__all__ = ["MagSoftSteerEnv", "steer_controller"]

"""MagSoftCrawl-v1: a free hard-magnetic beam on a floor, driven by the applied field (B_x, B_z)."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..cases.robots import resolve_robot
from ..rods import DEFAULT_ROD
from ..sim import PhaseShifted, Ramp, SimulationError, Simulator
from ..sim.gait import gait_rod_options
from ..sim.health import MAX_STEPS, check_steps
from ..sim.model import CONTACT_HISTORY, MAX_TIMESTEP, material_contact_timeconst
from ..sim.simulator import MATERIAL_SCALE_RANGE
from ..spec.drive import Waveparams
from ..validate import choice, finite_number, nonnegative, positive
from . import as_action, instability_info, refuse_unknown_kwargs, warn_ignored_source
from .crawl_task import (
    AIRBORNE_TOLERANCE,
    CRAWL_MODES,
    NONFINITE_OBSERVATION,
    CrawlRecords,
    CrawlTask,
    book_substeps,
    clock_tail,
    crawl_info,
    crawl_limits,
    crawl_reward,
    first_violation,
    observation,
    observation_high,
    period_substeps,
    single_info,
    violation_texts,
    wave_rows,
    zero_terms,
)

#: Default coil limit per axis (T): +-2 mT. The paper's crawlers crawl at 1.5-2 mT and tumble end over end
#: from about 2.5-3 mT: with hops of up to 2 mm allowed (``max_clearance=2e-3``), episodes of random actions at
#: +-2 mT last 197 of 250 steps on average (6 seeds; under v0's end-of-step limits: 216; at +-4 mT 12, at +-20 mT
#: 2); under the default floor-contact limit they lift the whole beam off the floor within 10 steps on average
#: (docs/training.md, "Registered defaults").
DEFAULT_FIELD_LIMIT = 2e-3
#: Default control interval in "field" mode (s).
DEFAULT_CTRL_DT = 0.02
#: Simulation step (s) of a robot whose file states none (``sim_dt=None`` takes the robot's own numerics,
#: :func:`magsoft_env.cases.gaits.numerics`; docs/convergence.md).
DEFAULT_SIM_DT = 2e-4
#: Largest clearance (m) of the rod's lowest point above the floor at any substep (``max_clearance``) in the crawl
#: modes: part of the beam on the floor at every instant, as the paper's robots crawl; airborne at any substep
#: ends the episode (a hop, not a crawl).
DEFAULT_MAX_CLEARANCE = AIRBORNE_TOLERANCE
#: The paper's channel ceiling (m): the crawl-mode height limit by default.
DEFAULT_MAX_HEIGHT = 7.6e-3
#: Largest |tangent angle| of any piece in crawl mode "rotation" (rad): beyond it the beam tumbles.
DEFAULT_MAX_LINK_ROTATION = 2.0 * math.pi / 3.0
#: Waveform mode: frequency range of one cycle (Hz).
DEFAULT_FREQUENCY_RANGE = (0.5, 4.0)
ACTION_MODES = ("field", "waveform")
#: What a broken crawl limit does (``on_violation``): ``"end"`` ends the episode (v1), ``"penalty"`` charges the
#: step and goes on (v2's default).
VIOLATION_RULES = ("end", "penalty")


class MagSoftCrawlEnv(gym.Env):
    """
    ## Description

    A centimetre-scale hard-magnetic soft beam (silicone + NdFeB, the paper's Fig. 5 robots)
    lies on a floor. A uniform field from coils bends it; friction with the floor turns the
    bending into crawling. The agent chooses the field. Physics: a MuJoCo rod of :mod:`magsoft_env.sim`
    (``segments`` cells, magnetic couples ``(R m) x B``): the planar hinge chain (``rod="planar"``, the default)
    or the 3D flexcomp strip (``rod="cable"``: bending both ways, twist, its width on the floor), with the same
    observation and action contract.

    Above about 2.5-3 mT a 20-30 mm beam stops crawling and tumbles end over end at tens of
    mm/s (docs/envs.md, "Crawl mode"). The crawl modes hold what the paper's robots do: part of the
    beam on the floor at every instant. The default ``crawl_mode="rotation"`` ends the episode when the
    whole beam is off the floor (its lowest point more than ``max_clearance`` = 0.01 mm above it: a hop) or
    a piece turns more than ``max_link_rotation`` from the floor (a tumble); ``"height"`` holds the same
    floor contact and limits the highest point to ``max_height`` (the paper's 7.6 mm channel ceiling);
    ``"none"`` allows hops and tumbling. The limits hold at every simulation substep, not only at the end
    of a control step (a hop that lands within one 20 ms step counts): the rod keeps the centreline of every
    substep of a block (the chain's ``framepos`` sensors' history buffers; :meth:`Simulator.centreline_history
    <magsoft_env.sim.Simulator.centreline_history>`), which the env reads after each block. On the strip the
    clearance is that of its centreline minus h/2 (exact while it lies on its wide face) and the piece angles are
    measured from its heading on the floor, toward +z. A hop-tolerant crawl is
    ``max_clearance=2e-3`` (the whole beam up to 2 mm off the floor) or ``None`` (no floor limit).

    ## Action Space

    ``action_mode="field"`` (default): ``Box(-1, 1, (2,), float32)``; the field is held for
    ``ctrl_dt`` seconds (ramped over it when ``slew_rate`` is set).

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | 0 | B_x / field_limit | -1 | 1 | field (T) |
    | 1 | B_z / field_limit | -1 | 1 | field (T) |

    ``action_mode="waveform"``: ``Box(-1, 1, (4,), float32)``; each step plays one period of
    ``B_x = A_x sin(2 pi f t + phase)``, ``B_z = A_z sin(2 pi f t)``.

    | Num | Action | Min | Max | Type (Unit) |
    |-----|--------|-----|-----|-------------|
    | 0 | A_x / field_limit | -1 | 1 | field (T) |
    | 1 | A_z / field_limit | -1 | 1 | field (T) |
    | 2 | phase / pi | -1 | 1 | angle (rad) |
    | 3 | frequency, mapped linearly onto ``frequency_range`` | -1 | 1 | frequency (Hz) |

    ## Observation Space

    ``Box(-high, high, (2 N + 8,), float32)`` for N = ``segments`` (N + 1 rigid pieces); values
    are clipped to the bounds (pi for angles, 1000 rad/s, 10 m/s, 1 for the rest):

    | Num | Observation | Type (Unit) |
    |-----|-------------|-------------|
    | 0 .. N | tangent angle of each piece from +x toward +z, base end first | angle (rad) |
    | N+1 .. 2N+1 | angular velocity of each piece | angular velocity (rad/s) |
    | 2N+2 | centre-of-mass velocity along x, mean over the last step | velocity (m/s) |
    | 2N+3 | centre-of-mass velocity along z, mean over the last step | velocity (m/s) |
    | 2N+4 .. 2N+7 | see below | dimensionless |

    Entries 2N+4 .. 2N+7: in field mode B_x / limit and B_z / limit now, then sin and cos of
    the clock phase ``2 pi clock_frequency t``; in waveform mode the last action (A_x, A_z,
    phase, frequency, normalized).

    The centre-of-mass position is left out (the task is translation invariant); it is in
    ``info["x_position"]``.

    ## Rewards

    ``reward = forward + field_cost + crawl_penalty (+ success for subclasses)``, each term in
    ``info`` as ``reward_forward``, ``reward_field``, ``reward_crawl``, ``reward_success`` (computed, with the crawl
    limits, the observation and ``info``, by :mod:`magsoft_env.envs.crawl_task`, the batches' own functions;
    :attr:`task` holds the parameters):

    - ``forward = forward_reward_weight * target_direction * dx / dt``: centre-of-mass travel
      along the target direction over the step, per second (default weight 1000 s/m: the term
      reads in mm/s).
    - ``field_cost = -field_cost_weight * mean_t (B_x^2 + B_z^2) / field_limit^2``.
    - ``crawl_penalty = -(crawl_penalty + max(0, forward reward earned so far this episode))``
      on the step that breaks the crawl limit, else 0; that step's forward term is 0. Breaking
      the limit thus forfeits the episode's progress: a lurch into a tumble moves the centre
      of mass fast for a few steps and must never pay.

    ## Starting State

    The straight beam lies on the floor at rest, zero field, hinge angles perturbed by
    ``U(-reset_noise_scale, reset_noise_scale)`` rad (the 3D strip: its interior vertices, by that angle times half
    a cell). ``reset(options={"qpos": qpos, "qvel": qvel})`` starts from that state instead (shapes ``(nq,)``,
    ``(nv,)``; either may be left out: the noisy rest state, zero velocities), at time zero and zero field, with no
    draw from the random stream; other option keys are refused.

    ## Episode End

    - Termination: a crawl limit is broken at any substep of the step (``info["crawl_violation"]`` says
      which, and when). With ``on_violation="penalty"`` (``MagSoftCrawl-v2``) the episode goes on instead: the step
      pays ``crawl_penalty`` and forfeits the forward reward earned since the last broken limit, and
      ``info["crawl_violations"]`` counts the steps that broke one.
    - Truncation: the time limit (``max_episode_steps`` of the registered id: 250 steps = 5 s
      in field mode, 20 cycles in waveform mode), or an unstable simulation:
      ``info["truncation_reason"]`` holds the :class:`~magsoft_env.sim.SimulationError` text.
      An unphysical one (a contact deeper than the beam's thickness, tunnelling through the
      floor, a launch the field cannot power; docs/sim.md, "Physical checks") truncates the same
      way, with ``info["unphysical"]`` = the reason and its figures in ``info``
      (``penetration_m``, ``penetration_h``, ``step``, ``time_s``, ...). Every ``info`` carries
      ``max_penetration`` (m), the deepest contact of the episode so far, ``orientation`` (rad), the body's
      length-weighted mean tangent angle, continuous in time (+-pi after one turn end over end;
      :mod:`magsoft_env.sim.readouts`), ``flipped``, True once it has been past vertical (|orientation| >
      pi / 2) at the end of a step of this episode (a tumble; crawl mode "none" lets the episode go on),
      ``highest_clearance`` (m), the highest the lowest point of the beam has been above the floor at any
      substep of the episode so far (minus the contact depth while it touches), ``airborne_fraction``, the
      fraction of the episode's substeps that started with the whole beam more than :data:`AIRBORNE_TOLERANCE`
      (0.01 mm) above the floor (a state touching the floor, by the rod's contact history, counts as on it:
      a strip on its edge), ``largest_piece_angle`` (rad), the largest angle of any piece from the floor at any
      substep, ``max_roll`` (rad, the largest roll of a piece about its own axis at the end of a step; 0 for the
      planar chain) and ``locomotion``: ``"crawl"`` (on the floor at every substep, right way up), ``"hop"``
      (airborne at a substep), ``"roll"``, ``"tumble"`` or ``"tumble with flight"`` (flipped end over end;
      :func:`~magsoft_env.envs.crawl_task.locomotion_modes`).

    ## Arguments

    | Parameter | Default | Description |
    |-----------|---------|-------------|
    | ``robot`` | ``"paper-5c"`` | built-in name (``list_robots()``), robot file (.yml, .json) or ``Robot`` |
    | ``rod`` | ``"planar"`` | the rod (``RodOptions.rod``): ``"planar"`` (hinge chain) or ``"cable"`` (3D strip; at |
    | | | the robot's own numerics its gait numerics, :func:`~magsoft_env.sim.cable.cable_gait_numerics`) |
    | ``rod_options`` | None | more ``RodOptions`` keywords (contact and solver settings), winning over the gait's |
    | ``action_mode`` | ``"field"`` | ``"field"`` or ``"waveform"`` |
    | ``field_limit`` | 0.002 | coil limit per axis (T); the crawl window ends near 2.5-3 mT |
    | ``slew_rate`` | None | largest field change rate per axis (T/s); None: unlimited |
    | ``ctrl_dt`` | 0.02 | control interval in field mode (s), >= ``sim_dt`` |
    | ``sim_dt`` | None | simulation step (s), in (0, 0.1]; at most 1e7 steps per env step; None: the robot's own |
    | ``segments`` | None | rod cells; None: the robot's own |
    | ``fidelity`` | None | named numerics instead of ``sim_dt`` and ``segments``: ``"fast"`` (20, 0.2 ms), ``"fine"`` |
    | | | (80, 0.1 ms), ``"converged"`` (80, 0.025 ms); None: the robot's own (see "Numerics") |
    | ``friction`` | None | rod-floor sliding friction; None: the robot's (0.5 for the paper robots) |
    | ``friction_range`` | None | domain randomization: a friction drawn from ``U(low, high)`` at every reset |
    | ``modulus_range`` | None | domain randomization: a factor of the elastomer's modulus ``E0`` drawn from |
    | | | ``U(low, high)`` at every reset, in [0.1, 10] (``Simulator.set_material_scale``) |
    | ``magnetization_range`` | None | the same for the particles' magnetization ``M_p`` |
    | ``target_direction`` | 1 | +1: reward motion along +x; -1: along -x |
    | ``forward_reward_weight`` | 1000 | (s/m) |
    | ``field_cost_weight`` | 0.1 | weight of the normalized field power |
    | ``crawl_mode`` | ``"rotation"`` | ``"rotation"``, ``"height"`` or ``"none"`` |
    | ``max_link_rotation`` | 2 pi / 3 (120 deg) | crawl-mode rotation limit (rad), in (0, pi] |
    | ``max_height`` | 7.6e-3 | crawl-mode height limit (m) |
    | ``max_clearance`` | 1e-5 | crawl modes "rotation" and "height": the episode ends when the rod's lowest point is |
    | | | higher above the floor (m) at any substep (the whole beam off the floor); None: no limit |
    | ``crawl_penalty`` | 10 | reward lost when the crawl limit is broken |
    | ``on_violation`` | ``"end"`` | a broken crawl limit ``"end"``s the episode (v1) or is a ``"penalty"`` and the |
    | | | episode goes on (``MagSoftCrawl-v2``); ``info["crawl_violations"]`` counts such steps |
    | ``frequency_range`` | (0.5, 4) | waveform-mode frequencies (Hz) |
    | ``clock_frequency`` | 2 | field-mode clock observed as sin/cos (Hz) |
    | ``reset_noise_scale`` | 1e-3 | initial hinge-angle noise (rad) |
    | ``feature_x`` | None | x (m) of the channel entrance / obstacle (subclasses set it) |
    | ``render_mode`` | None | ``"rgb_array"`` |
    | ``width``, ``height`` | 960, 540 | frame size (pixels) |

    The robot brings its beam (geometry, material, profiles), friction, hinge damping
    (``Robot.retardation_time``), drive (the open-loop gait of :meth:`open_loop_action`) and numerics.

    ## Numerics

    The env and :func:`~magsoft_env.sim.gait.run_gait` build the same rod
    (:func:`~magsoft_env.sim.gait.gait_rod_options`) at the same numerics: the robot's own (``Robot.segments``,
    ``Robot.timestep``) unless ``fidelity`` or ``segments``/``sim_dt`` say otherwise. The paper robots' own are
    the cheapest measured to be within 5 % of the converged crawl (3 s displacement against a 4x finer step at
    80 segments / speed against the converged reference; docs/convergence.md):

    | robot | segments, sim_dt | error | wall time per simulated s (one core) | observation size |
    |---|---|---|---|---|
    | paper-5c (this env's default) | 20, 0.2 ms (``"fast"``) | 2.1 / 2.2 % | 0.3 s | 48 |
    | paper-5a (the channel's) | 80, 0.1 ms (``"fine"``) | 1.9 / 1.9 % | 4.6 s | 168 |
    | paper-5b (the obstacle's) | 80, 0.025 ms (``"converged"``) | 1.3 / 0.4 % | 10 s | 168 |

    ``fidelity="fast"`` trains on any robot at 0.3-0.4 s per simulated second, with the error stated there
    (5a 4-17 %, 5b 31 %). A robot file that states no numerics runs at ``"fast"``'s.

    ## Version History

    - v0: initial version (magsoft_env 0.1).
    - v0, magsoft_env 0.4: ``sim_dt`` and ``segments`` default to the robot's own numerics (paper-5c: 20 and
      0.2 ms, as before); ``fidelity`` added. Waveform mode and ``slew_rate`` step in ``mujoco.rollout``
      blocks (the same trajectories), with energy checks every 100 substeps in waveform mode (was 50).
    - v1 (``MagSoftCrawl-v1``, ``MagSoftCrawlWaveform-v1``; v0 removed): the crawl limits hold at every substep
      (were checked at the end of each control step only), and the crawl modes require part of the beam on
      the floor at every substep (``max_clearance`` 0.01 mm; was 2 mm); ``info`` carries ``highest_clearance``
      and ``airborne_fraction``. ``MagSoftCrawlWaveform-v1`` plays 1-4 Hz periods (was 0.5-4 Hz).
    - v2 (``MagSoftCrawl-v2``; v1 kept unchanged): v1's task, robot, limits, action range (2 mT) and rewards, with
      ``on_violation="penalty"``: a step that breaks a crawl limit (airborne, or a piece past 120 deg) pays
      ``crawl_penalty`` (10) and forfeits the episode's forward reward earned since the last broken limit (as v1's
      end does), and the episode goes on. Why: under v1 random actions lift the whole beam off the floor within
      6.7 steps on average (20 seeded episodes) and stock PPO learns nothing; under v2 they run all 250 steps
      (20 of 20 episodes; 41 steps of 250 break a limit on average). The limits stay as honest as v1's: a hop
      or tumble never pays (every broken step zeroes the progress kept so far) and ``airborne_fraction`` and
      ``locomotion`` report it. A smaller action range (1.5 mT: 5.8 broken steps per random episode) was not
      chosen: the paper's crawls use up to 2 mT, and v1's policies and open-loop gaits compare at the same range.
      Measured (docs/bench.md): the project's PPO block learns a crawl on v2 (one seed, 50,176 steps: +0.78 mm/s,
      airborne fraction 0); stock PPO (SB3 defaults, 51,200 steps) holds a field and stands still.
      v2 has no batched vector entry point (``gym.make_vec`` gives Gymnasium's sync vector env).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}
    _scene = "floor"

    def __init__(
        self,
        robot="paper-5c",
        *,
        rod: str = DEFAULT_ROD,
        rod_options: dict | None = None,
        action_mode: str = "field",
        field_limit: float = DEFAULT_FIELD_LIMIT,
        slew_rate: float | None = None,
        ctrl_dt: float = DEFAULT_CTRL_DT,
        sim_dt: float | None = None,
        segments: int | None = None,
        fidelity: str | None = None,
        friction: float | None = None,
        friction_range: tuple[float, float] | None = None,
        modulus_range: tuple[float, float] | None = None,
        magnetization_range: tuple[float, float] | None = None,
        target_direction: int = 1,
        forward_reward_weight: float = 1000.0,
        field_cost_weight: float = 0.1,
        crawl_mode: str = "rotation",
        max_link_rotation: float = DEFAULT_MAX_LINK_ROTATION,
        max_height: float = DEFAULT_MAX_HEIGHT,
        max_clearance: float | None = DEFAULT_MAX_CLEARANCE,
        crawl_penalty: float = 10.0,
        on_violation: str = "end",
        frequency_range: tuple[float, float] = DEFAULT_FREQUENCY_RANGE,
        clock_frequency: float = 2.0,
        reset_noise_scale: float = 1e-3,
        feature_x: float | None = None,
        render_mode: str | None = None,
        width: int = 960,
        height: int = 540,
        **unknown,
    ):
        refuse_unknown_kwargs(self, unknown)
        self.gait = resolve_robot(robot)  # a built-in name, a robot file or a Robot: checked before any work
        warn_ignored_source(self, self.gait)
        self.action_mode = choice("action_mode", action_mode, ACTION_MODES)
        self.crawl_mode = choice("crawl_mode", crawl_mode, CRAWL_MODES)
        self.field_limit = positive("field_limit", field_limit, unit="T")
        if self.field_limit > 0.1:
            raise ValueError(f"field_limit must be <= 0.1 T (fields are in tesla: 20 mT is 0.02), got {field_limit!r}.")
        self.slew_rate = None if slew_rate is None else positive("slew_rate", slew_rate, unit="T/s")
        self.ctrl_dt = positive("ctrl_dt", ctrl_dt, unit="s")
        if sim_dt is not None:
            positive("sim_dt", sim_dt, unit="s")
            if sim_dt > MAX_TIMESTEP:
                raise ValueError(f"sim_dt must lie in (0, {MAX_TIMESTEP:g}] s, got {sim_dt!r}.")
            check_steps(f"ctrl_dt / sim_dt = {self.ctrl_dt:g} s / {sim_dt:g} s per env step", self.ctrl_dt / sim_dt,
                        "Use a larger sim_dt or a smaller ctrl_dt.")
        # one physics with the gaits: the robot's own numerics (the rod's own where the robot's do not suit it)
        # unless a level or explicit ones are given; the gaits' rod (the beam's own stiff contact, not the sim's
        # fast 2 ms default), so that env results and the open-loop gait table describe the same physics
        options = gait_rod_options(self.gait, scene=self._scene, segments=segments, timestep=sim_dt,
                                   fidelity=fidelity, friction=friction, render=render_mode is not None,
                                   feature_x=feature_x, rod=rod, **(rod_options or {}))
        self.sim_dt = options.timestep
        self.fidelity = fidelity
        self.friction_range = _friction_range(friction_range)
        self.modulus_range = material_range("modulus_range", modulus_range)
        self.magnetization_range = material_range("magnetization_range", magnetization_range)
        options = material_options(options, self.gait.beam, self.modulus_range)
        if self.sim_dt > MAX_TIMESTEP:
            raise ValueError(f"sim_dt must lie in (0, {MAX_TIMESTEP:g}] s, got {sim_dt!r}.")
        if self.action_mode == "field" and self.sim_dt > self.ctrl_dt:
            # one step would silently last sim_dt, not ctrl_dt
            raise ValueError(f"sim_dt must be <= ctrl_dt ({self.ctrl_dt:g} s), got {sim_dt!r}.")
        self.n_substeps = max(1, int(round(check_steps(
            f"ctrl_dt / sim_dt = {self.ctrl_dt:g} s / {self.sim_dt:g} s per env step", self.ctrl_dt / self.sim_dt,
            "Use a larger sim_dt or a smaller ctrl_dt."))))
        if (isinstance(target_direction, (bool, np.bool_)) or not isinstance(target_direction, (int, np.integer))
                or target_direction not in (1, -1)):
            raise ValueError(f"target_direction must be +1 or -1, got {target_direction!r}.")
        self.target_direction = int(target_direction)
        self.forward_reward_weight = nonnegative("forward_reward_weight", forward_reward_weight, unit="s/m")
        self.field_cost_weight = nonnegative("field_cost_weight", field_cost_weight)
        self.max_link_rotation = positive("max_link_rotation", max_link_rotation, unit="rad")
        if self.max_link_rotation > math.pi:  # angles() lie in (-pi, pi]: a larger limit never ends a tumble
            raise ValueError(f"max_link_rotation must lie in (0, pi] rad, got {max_link_rotation!r}.")
        self.max_height = positive("max_height", max_height, unit="m")
        self.max_clearance = None if max_clearance is None else positive("max_clearance", max_clearance, unit="m")
        self.crawl_penalty = nonnegative("crawl_penalty", crawl_penalty)
        self.on_violation = choice("on_violation", on_violation, VIOLATION_RULES)
        if isinstance(frequency_range, (str, bytes)) or not hasattr(frequency_range, "__len__") \
                or len(frequency_range) != 2:
            raise ValueError(f"frequency_range must be (f_min, f_max) in Hz, got {frequency_range!r}.")
        f_lo = finite_number("frequency_range[0]", frequency_range[0], unit="Hz")
        f_hi = finite_number("frequency_range[1]", frequency_range[1], unit="Hz")
        if not 0.0 < f_lo <= f_hi:
            raise ValueError(f"frequency_range must satisfy 0 < f_min <= f_max (Hz), got {frequency_range!r}.")
        if self.action_mode == "waveform":
            # a period (one env step) of at least one simulation step and at most MAX_STEPS of them
            lo, hi = 1.0 / (MAX_STEPS * self.sim_dt), 1.0 / self.sim_dt
            if not lo <= f_lo <= f_hi <= hi:
                raise ValueError(
                    f"frequency_range must lie within [{lo:.3g}, {hi:.3g}] Hz at sim_dt = {self.sim_dt:g} s (one "
                    f"period per env step: at least one and at most {MAX_STEPS:.0e} simulation steps), got "
                    f"{frequency_range!r}.")
        self.frequency_range = (f_lo, f_hi)
        self.clock_frequency = positive("clock_frequency", clock_frequency, unit="Hz")
        self.reset_noise_scale = nonnegative("reset_noise_scale", reset_noise_scale, unit="rad")
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode must be one of {self.metadata['render_modes']} or None, got {render_mode!r}."
            )
        for name, v in (("width", width), ("height", height)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not 16 <= v <= 4096:
                raise ValueError(f"{name} must be an integer number of pixels in [16, 4096], got {v!r}.")
        self.render_mode = render_mode
        self.width, self.height = int(width), int(height)

        self.robot = self.gait.name
        #: the rod (``RodOptions.rod``)
        self.rod = options.rod
        # the energy checks once per control step (at least every 50 substeps): with the contact history of
        # sim.model.CONTACT_HISTORY steps, a 100-substep step runs as one block in MuJoCo (10 % more env steps/s
        # than blocks of 25, same trajectory: vec_bench); waveform mode: every 100 substeps, its rollout blocks
        every = max(50, self.n_substeps) if self.action_mode == "field" else CONTACT_HISTORY
        self.sim = Simulator(self.gait.beam, options, check_every=every)
        self.segments = options.segments
        self._nodes = self.sim.centreline_history()
        self._floor = self.sim.floor_contact_history()
        pose = self.sim.pose()
        self._half_thickness = 0.5 * self.gait.beam.thickness
        self._inv_piece_length = 1.0 / pose.lengths
        self._tracker = self.sim.orientation_tracker()  # the body's orientation, and its heading on the floor
        if self.action_mode == "field":
            self.metadata = {**self.metadata, "render_fps": int(round(1.0 / (self.n_substeps * self.sim_dt)))}
            self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        else:
            self.metadata = {**self.metadata, "render_fps": 2}
            self.action_space = spaces.Box(-1.0, 1.0, (4,), np.float32)
        self._high = observation_high(len(pose.lengths))  # the rod's pieces: N + 1
        self.observation_space = spaces.Box(-self._high, self._high, dtype=np.float32)
        self._renderer = None
        #: the episode's records (the crawl task's, n = 1)
        self._records = CrawlRecords.zeros(1)
        self._broken = False
        self._violations = 0  # steps that broke a crawl limit this episode (on_violation="penalty")
        self._samples: list = []

    # ------------------------------------------------------------------ the task's parameters
    @property
    def task(self) -> CrawlTask:
        """The crawl task's parameters now (:class:`~magsoft_env.envs.crawl_task.CrawlTask`), from this env's
        attributes (changed attributes take effect at the next step)."""
        return CrawlTask(crawl_mode=self.crawl_mode, max_clearance=self.max_clearance,
                         max_link_rotation=self.max_link_rotation, max_height=self.max_height,
                         forward_reward_weight=self.forward_reward_weight, target_direction=self.target_direction,
                         field_cost_weight=self.field_cost_weight, crawl_penalty=self.crawl_penalty,
                         field_limit=self.field_limit, clock_frequency=self.clock_frequency)

    # ------------------------------------------------------------------ physics readouts
    def com_position(self) -> np.ndarray:
        """Centre of mass (x, z) of the rod (m)."""
        return self.sim.pose().com[[0, 2]]

    def piece_angular_velocities(self) -> np.ndarray:
        """Angular velocity of every piece about -y (rad/s), shape ``(N + 1,)``."""
        return self.sim.angular_velocities()

    def field_of_action(self, action) -> np.ndarray:
        """Field-mode action in [-1, 1]^2 -> (B_x, B_z) (T)."""
        return np.clip(np.asarray(action, dtype=float), -1.0, 1.0) * self.field_limit

    def waveparams_of_action(self, action) -> Waveparams:
        """Waveform-mode action in [-1, 1]^4 -> the cycle's :class:`~magsoft_env.spec.drive.Waveparams`."""
        ax, az, freq, phase = wave_rows(np.asarray(action, dtype=float).reshape(1, -1), field_limit=self.field_limit,
                                        frequency_range=self.frequency_range)[0]
        return Waveparams(ax, az, float(freq), float(phase))

    def action_of_waveparams(self, wave: Waveparams) -> np.ndarray:
        """Inverse of :meth:`waveparams_of_action` (clipped to the limits)."""
        f_lo, f_hi = self.frequency_range
        fa = 0.0 if f_hi == f_lo else 2.0 * (wave.frequency - f_lo) / (f_hi - f_lo) - 1.0
        ph = (wave.phase + math.pi) % (2 * math.pi) - math.pi
        a = np.array([wave.amplitude_x / self.field_limit, wave.amplitude_z / self.field_limit, ph / math.pi, fa])
        return np.clip(a, -1.0, 1.0).astype(np.float32)

    # ------------------------------------------------------------------ gymnasium API
    def _get_obs(self, task: CrawlTask | None = None) -> np.ndarray:
        task = self.task if task is None else task
        rec = self._records
        tail = clock_tail(rec.field, [self.sim.time], task) if self.action_mode == "field" else rec.last_action
        return observation(self.sim.angles()[None], self.sim.angular_velocities()[None], rec.com_velocity, tail,
                           self._high)[0]

    def _limits(self, points: np.ndarray, contact) -> np.ndarray:
        """The crawl limits (:func:`~magsoft_env.envs.crawl_task.crawl_limits`) of centreline states ``points``
        ``(N + 2, k, 3)`` with their floor contacts ``(k,)``, the pieces' angles from the body's heading now:
        shape ``(1, 3, k)``."""
        return crawl_limits(points[None], [self._tracker.heading], half_thickness=self._half_thickness,
                            inv_piece_length=self._inv_piece_length, floor_contact=contact)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Start an episode (``seed``: reseed the env's random stream). ``options``: ``{"qpos": (nq,), "qvel":
        (nv,)}`` starts from that state (either may be left out: the noisy rest state, zero velocities) instead of
        the straight beam with reset noise (which draws nothing from the random stream then)."""
        super().reset(seed=seed)
        opts = dict(options or {})
        qpos, qvel = opts.pop("qpos", None), opts.pop("qvel", None)
        if opts:
            raise ValueError(f"options may hold 'qpos' and 'qvel' (a start state), got {sorted(opts)}.")
        sim = self.sim
        if qpos is None:
            qpos = sim.noisy_rest(self.np_random, self.reset_noise_scale)
        if self.friction_range is not None:  # drawn after the reset noise: fixed-friction episodes draw as before
            set_scene_friction(sim.model, float(self.np_random.uniform(*self.friction_range)))
        # drawn after the friction: episodes without the material ranges draw as before
        material = draw_material(self)
        sim.set_field((0.0, 0.0))
        sim.reset(qpos=qpos, qvel=qvel)
        self._tracker = sim.orientation_tracker()
        pose = sim.pose()
        start = self._limits(pose.centreline[:, None, :], [self.sim.floor_depth()])
        self._records.restart([True], com=pose.com[[0, 2]][None], start_limits=start[:, :, 0])
        self._broken = False
        self._violations = 0
        self._last_obs = self._get_obs()
        info = self._info(pose)
        if self.on_violation == "penalty":
            info["crawl_violations"] = 0
        if self.friction_range is not None:
            info["friction"] = scene_friction(sim.model)
        info.update(material)
        return self._last_obs, info

    def _apply(self, action) -> tuple[int, float]:
        """Apply the action's field: returns the step's substeps and mean normalized field power."""
        sim, rec = self.sim, self._records
        if self.action_mode == "field":
            target = self.field_of_action(action)
            if self.slew_rate is not None:
                dmax = self.slew_rate * self.n_substeps * self.sim_dt
                start = rec.field[0].copy()
                target = start + np.clip(target - start, -dmax, dmax)
                sim.set_waveform(Ramp(tuple(start), tuple(target), duration=self.n_substeps * self.sim_dt))
                # mean of the squared linear ramp
                power = float(np.sum(start**2 + start * target + target**2) / 3.0)
            else:
                sim.set_field(tuple(target))
                power = float(np.sum(target**2))
            rec.field[0] = target
            return self.n_substeps, power / self.field_limit**2
        wave = self.waveparams_of_action(action)
        rec.last_action[0] = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        sim.set_waveform(PhaseShifted(wave.amplitude_x, wave.amplitude_z, wave.frequency, wave.phase, 0.0))
        rec.field[0] = 0.0  # a whole period ends where it began
        power = 0.5 * (wave.amplitude_x**2 + wave.amplitude_z**2)
        return int(period_substeps([wave.frequency], self.sim_dt)[0]), power / self.field_limit**2

    def _read_block(self, start: int) -> int:
        """Reduce the substeps since step count ``start`` to their crawl limits (from the centreline sensors'
        history, before the next block overwrites it); returns the present step count."""
        k = self.sim.nstep - start
        if k > self._nodes.nsample:
            raise RuntimeError(f"{k} substeps ran in one native block; the crawl limits read at most "
                               f"{self._nodes.nsample} from the centreline sensors' history (Simulator.stepping "
                               "blocks are at most sim.model.CONTACT_HISTORY steps).")
        if k > 0:
            self._samples.append(self._limits(self._nodes.last(k), self._floor.last(k)))
        return self.sim.nstep

    def step(self, action):
        steps = self._stepping(action)
        while True:
            try:
                next(steps)
            except StopIteration as done:
                return done.value

    def _stepping(self, action, block: int | None = None):
        """:meth:`step` as a generator: it yields between the physics' native blocks (at most ``block``
        substeps each) and returns the step's ``(obs, reward, terminated, truncated, info)``; the
        batched environments interleave their robots' blocks with it (:mod:`magsoft_env.envs.vector`)."""
        if self._broken:
            raise RuntimeError("step() called after the simulation became unstable; call reset() first.")
        n, power = self._apply(as_action(self.action_space, action))
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
            return self._last_obs.copy(), 0.0, False, True, instability_info(self._info(sim.pose()), err)
        return self._finish(n, power)

    def _finish(self, n: int, power: float):
        """The step's outcome after its ``n`` substeps of mean normalized field ``power``: the crawl task's
        records, crawl limits, reward, observation and ``info``."""
        task, sim, rec = self.task, self.sim, self._records
        pose = sim.pose()
        # every substep's start state (the sensors' history), then the step's end state (now)
        end = self._limits(pose.centreline[:, None, :], [self.sim.floor_depth()])
        lim, k = book_substeps(rec, self._samples, end, com=pose.com[[0, 2]][None], duration=[n * self.sim_dt],
                               roll=[pose.roll])
        self._samples = []
        column, figures = first_violation(lim, task)
        violated = column >= 0
        reward, terms = crawl_reward(rec.com_velocity[:, 0], [power], violated, rec.episode_forward, task,
                                     self._success_reward())
        rec.episode_forward += terms["forward"]
        penalty_rule = self.on_violation == "penalty"
        if penalty_rule and violated[0]:
            # the step forfeited the progress earned so far (crawl_reward): what is kept from here on is the
            # progress after the last broken limit
            rec.episode_forward[0] = 0.0
            self._violations += 1
        obs = self._get_obs(task)
        if not np.all(np.isfinite(obs)):
            self._broken = True
            return self._last_obs.copy(), 0.0, False, True, {**self._info(pose), **NONFINITE_OBSERVATION}
        self._last_obs = obs
        info = self._info(pose, reward, terms)
        if violated[0]:
            when = sim.time - (k - column) * self.sim_dt  # column j: j substeps into the step
            info["crawl_violation"] = violation_texts(figures, when, task, violated)[0]
        if penalty_rule:
            info["crawl_violations"] = self._violations
            terminated = self._is_success()
        else:
            terminated = bool(violated[0]) or self._is_success()
        return obs, float(reward[0]), terminated, False, info

    def _success_reward(self) -> float:
        return 0.0

    def _is_success(self) -> bool:
        return False

    def _info(self, pose, reward=(0.0,), terms: dict | None = None) -> dict:
        """The crawl task's ``info`` (:func:`~magsoft_env.envs.crawl_task.crawl_info`) at ``pose``, the state now:
        the body's orientation (continuous; sim.readouts) is tracked here, once per step."""
        values = crawl_info(self._records, orientation=[self._tracker.track(pose)], reward=reward,
                            terms=zero_terms(1) if terms is None else terms, time=[self.sim.time],
                            max_penetration=[self.sim.max_penetration], is_success=[self._is_success()])
        return single_info(values)

    def open_loop_action(self, t: float, wave: Waveparams | None = None) -> np.ndarray:
        """Action reproducing the open-loop gait ``wave`` (default: the robot's paper gait).

        Field mode: the field sampled at the middle of the step starting at ``t`` (s);
        waveform mode: the gait's parameters (``t`` unused).
        """
        wave = self.gait.wave if wave is None else wave
        if self.action_mode == "waveform":
            return self.action_of_waveparams(wave)
        b = wave.sample([t + 0.5 * self.n_substeps * self.sim_dt])[0]
        return np.clip(b / self.field_limit, -1.0, 1.0).astype(np.float32)

    # ------------------------------------------------------------------ rendering
    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' to the constructor.")
            return None
        if self._renderer is None:
            from ..render.views import make_renderer

            self._renderer = make_renderer(self.sim, width=self.width, height=self.height)
        return self._renderer.render(field=self.sim.field)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None


#: Largest sliding friction coefficient ``friction_range`` accepts.
MAX_FRICTION = 2.0


def _friction_range(value) -> tuple[float, float] | None:
    """``friction_range`` checked: None or ``(low, high)`` with 0 <= low <= high <= MAX_FRICTION."""
    if value is None:
        return None
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"friction_range must be None or (low, high), got {value!r}.") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo <= hi <= MAX_FRICTION):
        raise ValueError(f"friction_range must be (low, high) with 0 <= low <= high <= {MAX_FRICTION:g} (sliding "
                         f"friction coefficients), got {value!r}.")
    return lo, hi


def material_range(name: str, value) -> tuple[float, float] | None:
    """``modulus_range`` or ``magnetization_range`` checked: None or ``(low, high)``, relative factors with
    ``0.1 <= low <= high <= 10`` (:data:`~magsoft_env.sim.simulator.MATERIAL_SCALE_RANGE`)."""
    if value is None:
        return None
    lo_ok, hi_ok = MATERIAL_SCALE_RANGE
    what = f"{name} must be None or (low, high), relative factors with {lo_ok:g} <= low <= high <= {hi_ok:g}"
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{what}, got {value!r}.")
    try:
        lo, hi = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"{what}, got {value!r}.") from None
    if any(isinstance(v, (bool, np.bool_)) for v in value) or not (
            math.isfinite(lo) and math.isfinite(hi) and lo_ok <= lo <= hi <= hi_ok):
        raise ValueError(f"{what}, got {value!r}.")
    return lo, hi


def material_options(options, beam, modulus_range):
    """With a ``modulus_range``, a contact time constant the gait took from the material (``h sqrt(rho / E)``,
    :func:`~magsoft_env.sim.model.material_contact_timeconst`) is asked for as ``"material"``: the same model, whose
    contact then follows the drawn modulus as a model built from that modulus would. Otherwise ``options``."""
    if (modulus_range is not None and options.has_contact and not isinstance(options.contact_timeconst, str)
            and options.contact_timeconst == material_contact_timeconst(beam)):
        return dataclasses.replace(options, contact_timeconst="material")
    return options


def draw_material(env) -> dict:
    """Draw the episode's material factors from ``env.np_random`` (the modulus, then the magnetization; a range that
    is None draws nothing and keeps the factor 1), set them on ``env.sim``
    (:meth:`~magsoft_env.sim.Simulator.set_material_scale`) and return the ``info`` entries of the ranges that are
    on (``modulus_scale``, ``magnetization_scale``)."""
    info = {}
    if env.modulus_range is None and env.magnetization_range is None:
        return info
    modulus = magnetization = 1.0
    if env.modulus_range is not None:
        modulus = info["modulus_scale"] = float(env.np_random.uniform(*env.modulus_range))
    if env.magnetization_range is not None:
        magnetization = info["magnetization_scale"] = float(env.np_random.uniform(*env.magnetization_range))
    env.sim.set_material_scale(modulus=modulus, magnetization=magnetization)
    return info


def set_scene_friction(model, mu: float) -> None:
    """Set the sliding friction of every contact of a rod model to ``mu``, as building it with ``friction=mu`` does:
    the contact pairs' two sliding coefficients and every geom's (MuJoCo takes the larger of two geoms')."""
    if model.npair:
        model.pair_friction[:, 0:2] = mu
    model.geom_friction[:, 0] = mu


def scene_friction(model) -> float:
    """The sliding friction of a rod model's contacts (its first pair's, or its first geom's)."""
    return float(model.pair_friction[0, 0] if model.npair else model.geom_friction[0, 0])

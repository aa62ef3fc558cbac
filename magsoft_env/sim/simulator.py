"""The rod simulator: one stepping engine for every field mode, over a rod backend, with one health monitor.

A :class:`Simulator` holds a rod backend (:class:`~magsoft_env.sim.backend.RodBackend`: the MuJoCo model, how a
block of steps runs, the field's inputs, the physical readouts), a :class:`~magsoft_env.sim.health.HealthMonitor`
(every check and its records) and one field ``(B_x, B_y, B_z)`` (held, or a waveform sampled per step).
:meth:`Simulator.stepping` is the one place a call is cut into blocks; the backend runs each block (the planar
chain inside MuJoCo, ``mj_step(m, d, k)`` or ``mujoco.rollout``; the 3D strip with couples written from Python
each step), and each block is checked step by step afterwards. Nothing here depends on which rod runs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..spec import Beam, Field, as_field
from ..spec.field import MAX_FIELD
from ..validate import finite_number, positive
from .backend import Pose, RodBackend, rod_class
from .health import (
    FIELD_FLOOR,
    PENETRATION_LIMIT,
    HealthMonitor,
    SimulationError,
    UnphysicalError,
    check_steps,
)
from .model import RodOptions, contact_timeconst
from .sources import SourceField, field_bound, split_source
from .waveforms import Waveform, as_waveform, lift3

#: Scalar types :meth:`Simulator.set_field` accepts without building a Field.
_FLOATS = (float, np.float64, np.float32)


@dataclass(frozen=True)
class SettleResult:
    """Outcome of :meth:`Simulator.settle` (frozen).

    Attributes
    ----------
    success : bool
        Whether the convergence test passed within ``max_time``.
    steps : int
        Simulation steps taken (dimensionless count).
    residual : float
        Final static residual: ``max_j |Q_j| / k_j`` (rad), the largest hinge-angle change
        that would balance the net generalized force ``Q`` at zero velocity.
    max_speed : float
        Final largest hinge angular speed (rad/s).
    message : str
        ``"converged"``, or why the rod did not settle within ``max_time``.
    """

    success: bool
    steps: int
    residual: float
    max_speed: float
    message: str

    def to_dict(self) -> dict:
        """Plain numbers (SI, unit in the key), for JSON."""
        return {
            "success": bool(self.success),
            "steps": int(self.steps),
            "residual_rad": float(self.residual),
            "max_speed_rad_s": float(self.max_speed),
            "message": self.message,
        }


@dataclass(frozen=True)
class Trajectory:
    """Samples recorded by :meth:`Simulator.run` (frozen).

    ``n`` samples (the first state and every ``record_every`` steps) of a rod with ``N`` cells,
    whose centerline has ``N + 2`` points. Units are SI.

    Attributes
    ----------
    time : (n,) ndarray
        Times (s).
    field : (n, 2) or (n, 3) ndarray
        Applied field in the components the rod takes (T): ``(B_x, B_z)`` for a rod in the x-z plane,
        ``(B_x, B_y, B_z)`` for the 3D rod (the backend's ``field_axes``).
    x, z : (n, N + 2) ndarray
        Centerline points (m), base to tip (the :class:`~magsoft_env.sim.backend.Pose`'s centreline).
    tip_angle : (n,) ndarray
        Tangent angle of the tip (rad); the 3D rod: of its projection on the x-z plane.
    y : (n, N + 2) ndarray
        The centerline points' y (m): 0 for a rod in the x-z plane.
    """

    time: np.ndarray
    field: np.ndarray
    x: np.ndarray
    z: np.ndarray
    tip_angle: np.ndarray
    y: np.ndarray | None = None

    def to_dict(self) -> dict:
        """The samples as nested lists of plain numbers (SI, unit in the key), for JSON."""
        return {
            "time_s": np.asarray(self.time, dtype=float).tolist(),
            "field_T": np.asarray(self.field, dtype=float).tolist(),
            "x_m": np.asarray(self.x, dtype=float).tolist(),
            "z_m": np.asarray(self.z, dtype=float).tolist(),
            "tip_angle_rad": np.asarray(self.tip_angle, dtype=float).tolist(),
            "y_m": np.asarray(self.y, dtype=float).tolist(),
        }


#: The range of the relative material factors :meth:`Simulator.set_material_scale` (and the environments'
#: ``modulus_range`` and ``magnetization_range``) take.
MATERIAL_SCALE_RANGE = (0.1, 10.0)


def material_factor(name: str, value) -> float:
    """``value`` checked as a relative material factor: a finite number in :data:`MATERIAL_SCALE_RANGE`."""
    lo, hi = MATERIAL_SCALE_RANGE
    ok = isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))
    if not ok or not math.isfinite(float(value)) or not lo <= float(value) <= hi:
        raise ValueError(f"{name} must be a finite relative factor in [{lo:g}, {hi:g}], got {value!r}.")
    return float(value)


class Simulator:
    """A magnetic rod in MuJoCo under a uniform applied field.

    Every step each rigid piece feels the couple ``tau_i = (R_i m_i) x B`` (N m) of the state the step
    starts from, applied by MuJoCo itself as forces along the field at the pieces' magnetic poles (site
    actuators; the simulator only sets the field's inputs, ``ctrl = |B|`` and the field frame's
    orientation; docs/sim.md, "Native magnetic forces"). So every step runs inside MuJoCo, in blocks:
    ``mj_step(m, d, k)`` while the field is held, ``mujoco.rollout`` with per-step inputs while it changes
    (a waveform, a slewed field), bit for bit what ``k`` single steps with the inputs set before each give.
    RK4 sees the couples of each of its stages.

    After every block the state is checked (:class:`~magsoft_env.sim.health.HealthMonitor`): MuJoCo's
    warnings (non-finite or huge values; auto-reset is disabled), and at every ``check_every`` steps kinetic
    energy above ``100 x`` the system's energy scale, raise :class:`SimulationError`. The contact scenes are
    also held to physical bounds (:class:`UnphysicalError`; docs/sim.md, "Physical checks"): every step, a
    contact deeper than ``penetration_limit`` x the thickness h (MuJoCo's contact sensors, whose history
    buffer keeps every step of a block); at every energy check, the centreline more than that below the
    floor (tunnelling) and energy the field cannot have supplied (a launch: the total energy above its start
    plus the field's work, more than :data:`~magsoft_env.sim.health.ENERGY_DRIFT_LIMIT` of the energy
    scale). A bound broken (or a warning) inside a block is reported with the step at which it happened,
    while the state has run on to the end of the block (at most
    :data:`~magsoft_env.sim.model.CONTACT_HISTORY` - 1 steps more). The records :attr:`max_penetration`,
    :attr:`energy_drift` and :attr:`max_kinetic_ratio` say of every run whether it stayed resolved.

    The rod is the backend that ``RodOptions.rod`` names (:mod:`~magsoft_env.sim.backend`): ``"planar"``, the
    hinge chain above; ``"cable"``, the 3D flexcomp strip (:class:`~magsoft_env.sim.cable.CableRod`, clamped or
    on the floor), whose couples are written before every step and whose own bound (edge stretch) is checked
    with the others (docs/sim.md, "The 3D rod in the Simulator"). The simulator holds one field
    ``(B_x, B_y, B_z)``; a pair means ``(B_x, B_z)``, and a rod in the x-z plane refuses a y component.

    Besides the uniform field, a field source (:mod:`magsoft_env.fields`; ``source=``, :meth:`set_source`) gives
    every piece the couple ``m x B(p)`` and the force ``G(p)^T m`` at its magnetic centre, written by the backend
    before every step (Python per step); a uniform source is folded into the uniform field (docs/sim.md, "Field
    sources").

    Parameters
    ----------
    beam : Beam
        The beam specification.
    options : RodOptions, optional
        Scene, segments, integrator, timestep (``magnetics`` must be ``"native"``, the default).
    field : Field or (B_x, B_z), optional
        Initial applied field (T).
    source : field source, optional
        A field source (:mod:`magsoft_env.fields`) besides the uniform field: :meth:`set_source`.
    check_every : int
        Steps between energy checks (the state is checked after every block of steps).
    penetration_limit : float
        Contact scenes: the deepest contact allowed, in beam thicknesses (> 0; default
        :data:`~magsoft_env.sim.health.PENETRATION_LIMIT` = 1 h; ``math.inf`` records the depth
        without stopping).

    Attributes
    ----------
    rod : RodModel
        The compiled model and its addresses (:func:`~magsoft_env.sim.model.build_model`).
    backend : RodBackend
        The rod backend (:class:`~magsoft_env.sim.backend.RodBackend`): stepping, field inputs, readouts.
    model, data : mujoco.MjModel, mujoco.MjData
    external_wrench : ndarray, shape (npieces, 6)
        Extra constant wrench per piece, world frame: force (N) at the piece's centre of mass, then couple
        (N m); applied every step while non-zero (its work is not in the energy balance, which is then off).
        Must be finite when a step starts.
    on_warning : callable
        Where MuJoCo's warnings go while this simulator steps (the batched envs route them per thread).

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> sim = Simulator(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), field=(0, 0.005))
    >>> sim.settle().success
    True
    """

    def __init__(
        self, beam: Beam, options: RodOptions | None = None, *, field=(0.0, 0.0), check_every: int = 50,
        penetration_limit: float = PENETRATION_LIMIT, source=None,
    ):
        if not isinstance(beam, Beam):
            raise ValueError(f"beam must be a Beam, got {type(beam).__name__}.")
        if options is not None and not isinstance(options, RodOptions):
            raise ValueError(f"options must be a RodOptions or None, got {type(options).__name__}.")
        if isinstance(check_every, (bool, np.bool_)) or not isinstance(check_every, (int, np.integer)) \
                or check_every < 1:
            raise ValueError(f"check_every must be a positive integer, got {check_every!r}.")
        if not (isinstance(penetration_limit, (int, float, np.floating)) and penetration_limit == math.inf):
            positive("penetration_limit", penetration_limit, unit="beam thicknesses")
        options = RodOptions() if options is None else options
        cls = rod_class(options.rod)
        cls.check_beam(beam)
        cls.check_field(as_field(field, "field"))  # checked before the model is built
        self.backend: RodBackend = cls(beam, options)
        #: the components of (B_x, B_y, B_z) the rod takes
        self._axes = list(self.backend.field_axes)
        self.rod = self.backend.rod
        self.model = self.backend.model
        self.data = mujoco.MjData(self.model)
        self.check_every = int(check_every)
        h = beam.thickness
        #: deepest contact allowed (m)
        self.penetration_limit = float(penetration_limit) * h
        self._health = HealthMonitor(
            self.backend, self.data, penetration_limit=self.penetration_limit,
            contact_timeconst=contact_timeconst(beam, options) if options.has_contact else math.nan)
        self.on_warning = self._health.on_warning
        # the longest block: the rod's histories (every step of a block is checked from them)
        self._block = int(self.backend.block_limit)
        self.external_wrench = np.zeros((self.backend.npieces, 6))
        self._B3 = np.zeros(3)  # the applied field now (T)
        self._waveform: Waveform | None = None
        self._wf_t0 = 0.0
        self._stale = False  # positions in data (xpos, xmat, ...) are those of the last step's start
        self.nstep = 0
        # a source (set_source): its uniform part (T, folded into the uniform field; None: none), the field set
        # without it, the rest as the backend evaluates it, and the largest field of that rest at the pieces (T)
        self._offset: np.ndarray | None = None
        self._held = np.zeros(3)
        self._source: SourceField | None = None
        self._source_given = None
        self._source_bmax = 0.0
        self._energy_bmax = FIELD_FLOOR
        #: the material's factors now, (modulus, magnetization) (:meth:`set_material_scale`)
        self._material = (1.0, 1.0)
        self.set_field(field)
        self.reset()
        if source is not None:
            self.set_source(source)
            self.reset()

    # ------------------------------------------------------------------ state
    @property
    def options(self) -> RodOptions:
        return self.rod.options

    @property
    def beam(self) -> Beam:
        return self.rod.beam

    @property
    def time(self) -> float:
        """Simulation time (s)."""
        return float(self.data.time)

    @property
    def timestep(self) -> float:
        """Simulation step (s)."""
        return float(self.model.opt.timestep)

    @property
    def field(self) -> Field:
        """The applied field now (T), in the components the rod takes (``(B_x, B_z)`` in the x-z plane)."""
        return Field(*(float(b) for b in self._B3[self._axes]))

    @property
    def field_vector(self) -> np.ndarray:
        """The applied field now ``(B_x, B_y, B_z)`` (T), shape ``(3,)`` (a copy)."""
        return self._B3.copy()

    def reset(self, *, qpos=None, qvel=None) -> None:
        """Straight beam at rest (floor scenes: lying on the floor), time zero, or the state ``qpos``, ``qvel``
        (``(nq,)``, ``(nv,)``; either may be None: the rest value) at time zero; the records
        (:attr:`max_penetration`, :attr:`energy_drift`, :attr:`max_kinetic_ratio`) start again from it."""
        qpos, qvel = self._state_args(qpos, qvel)
        mujoco.mj_resetData(self.model, self.data)
        self._write_inputs()  # mj_resetData zeroed the field's inputs
        self.nstep = 0
        self._wf_t0 = 0.0
        self._write_state(qpos, qvel)
        self._health.reset(self._B3.copy())

    def set_state(self, qpos=None, qvel=None) -> None:
        """Write joint positions ``qpos`` ``(nq,)`` and velocities ``qvel`` ``(nv,)`` (either None: unchanged) and
        recompute the derived quantities, as Gymnasium's MuJoCo environments do; the time and the records go on
        (the energy balance restarts from this state at the next step)."""
        self._write_state(*self._state_args(qpos, qvel))

    def _write_state(self, qpos, qvel) -> None:
        """Write checked ``qpos`` / ``qvel`` (None: unchanged) and recompute the derived quantities."""
        if qpos is not None:
            self.data.qpos[:] = qpos
        if qvel is not None:
            self.data.qvel[:] = qvel
        mujoco.mj_forward(self.model, self.data)
        self._stale = False

    def state(self) -> tuple[np.ndarray, np.ndarray]:
        """Copies of the joint positions ``(nq,)`` and velocities ``(nv,)``: what :meth:`set_state` and
        :meth:`reset` take."""
        return self.data.qpos.copy(), self.data.qvel.copy()

    def noisy_rest(self, rng: np.random.Generator, scale: float) -> np.ndarray:
        """The rest ``qpos`` with every bending angle perturbed by ``U(-scale, scale)`` (rad), drawn from ``rng``
        (the rod's own way: the chain's hinges, the strip's interior vertices)."""
        return self.backend.reset_noise(rng, scale)

    def _state_args(self, qpos, qvel):
        out = []
        for name, v, n in (("qpos", qpos, self.model.nq), ("qvel", qvel, self.model.nv)):
            if v is None:
                out.append(None)
                continue
            try:
                a = np.asarray(v, dtype=float)
            except (TypeError, ValueError):
                raise ValueError(f"{name} must be a float array of shape ({n},), got {v!r}.") from None
            if a.shape != (n,) or not np.all(np.isfinite(a)):
                raise ValueError(f"{name} must be a finite array of shape ({n},), got shape {a.shape}.")
            out.append(a)
        return out

    # ------------------------------------------------------------------ physical records
    @property
    def max_penetration(self) -> float:
        """Deepest rod contact seen since the last reset (m; 0 in the cantilever), checked every
        step: with the floor, and in the channel and obstacle scenes with anything (the check of
        those counts from the overlap the start had, :attr:`initial_overlap`)."""
        return self._health.max_penetration

    @property
    def initial_overlap(self) -> float:
        """Channel and obstacle scenes: how deep the resting beam starts inside a scene feature (m;
        0 unless ``feature_x`` places it through the beam). The penetration bound counts from it
        (``penetration_limit`` + this overlap): pushing the beam out of a feature it was placed in
        is the caller's geometry, not a failure of the contact."""
        return self._health.overlap0

    @property
    def energy_drift(self) -> float:
        """Largest energy the numerics created since the last reset, as a fraction of the energy
        scale: ``max (E - E_0 - W) / E_scale`` over the energy checks, with ``E`` the kinetic,
        elastic, gravitational and magnetic energy and ``W`` the work of the field on the rod.
        Physically ``E - E_0 - W <= 0`` (damping and contact dissipate): a resolved run stays near 0
        (measured below 1e-6); above :data:`~magsoft_env.sim.health.ENERGY_DRIFT_LIMIT` the run
        stops as a launch. Restarts from the present state when the state is written from outside
        (``data.qpos`` / ``qvel``). NaN where it is not tracked: the cantilever, RK4 or an
        ``external_wrench`` (whose work it does not count)."""
        return float(self._health.drift)

    @property
    def max_kinetic_ratio(self) -> float:
        """Largest kinetic energy at an energy check since the last reset, over the energy scale
        (the runaway check stops a run at 100)."""
        return float(self._health.max_ke_ratio)

    def health(self) -> dict:
        """The physical records as plain numbers, unit in the key: ``max_penetration_m``,
        ``max_penetration_h`` (in beam thicknesses), ``penetration_limit_h``, ``energy_drift``,
        ``max_kinetic_ratio``."""
        h = self.beam.thickness
        return {
            "max_penetration_m": self.max_penetration,
            "max_penetration_h": self.max_penetration / h,
            "penetration_limit_h": self.penetration_limit / h,
            "energy_drift": self.energy_drift,
            "max_kinetic_ratio": self.max_kinetic_ratio,
        }

    # ------------------------------------------------------------------ field
    def set_field(self, field) -> None:
        """Hold a constant applied field (T) from now on: a :class:`~magsoft_env.spec.Field`, ``(B_x, B_y, B_z)``
        or a pair ``(B_x, B_z)``; a rod in the x-z plane refuses a y component (ValueError)."""
        bx = bz = None
        if type(field) is tuple and len(field) == 2:  # fast path for the per-step caller (envs)
            bx, bz = field
            if not (type(bx) in _FLOATS and type(bz) in _FLOATS and abs(bx) <= MAX_FIELD and abs(bz) <= MAX_FIELD):
                bx = bz = None  # (NaN fails the comparison) full validation below
        if bx is None:
            f = as_field(field)
            self.backend.check_field(f)
            self._B3[:] = f.vector()
        else:
            self._B3[0], self._B3[1], self._B3[2] = bx, 0.0, bz
        if self._offset is not None:  # a uniform source's field, added
            self._held[:] = self._B3
            self._B3 += self._offset
        self._waveform = None
        self._write_inputs()
        bmax = math.hypot(*self._B3)
        if self._source is not None:
            bmax += self._source_bmax
        self._energy_bmax = max(bmax, FIELD_FLOOR)
        self._health.energy_scale = self.backend.energy_scale(self._energy_bmax)

    @property
    def material_scale(self) -> tuple[float, float]:
        """The factors ``(modulus, magnetization)`` :meth:`set_material_scale` last set (``(1.0, 1.0)``: the beam's
        own material)."""
        return self._material

    def set_material_scale(self, modulus: float = 1.0, magnetization: float = 1.0) -> None:
        """Make the model what building it from the beam with its modulus ``E0 * modulus`` and its particles'
        magnetization ``particle_magnetization * magnetization`` would give, without recompiling (domain
        randomization of the material).

        The rod's backend scales, from the values it was built with (so calls do not compound), everything that
        depends on them: its stiffnesses and rod damping (Kelvin-Voigt: proportional to the stiffness), its
        magnetic moments and the inputs that apply them (pole charges, tendon coefficients, couple writers), a
        contact time constant taken from the material (``RodOptions.contact_timeconst="material"``: ``h sqrt(rho /
        E)``), its energy scale and its settling damping. ``(1, 1)`` restores the model bit for bit; a call with
        the factors already set changes nothing. The state is kept (the energy balance starts again from it);
        :attr:`beam` stays the beam the simulator was built from, :attr:`material_scale` says the factors.

        Parameters
        ----------
        modulus, magnetization : float
            Relative factors of ``Material.E0`` and ``Material.particle_magnetization``, finite, in
            :data:`MATERIAL_SCALE_RANGE` ``[0.1, 10]``.
        """
        modulus = material_factor("modulus", modulus)
        magnetization = material_factor("magnetization", magnetization)
        if (modulus, magnetization) == self._material:
            return
        setter = getattr(self.backend, "set_material_scale", None)
        if setter is None:
            raise ValueError(f"{self.backend.label} cannot scale its material in place (its backend "
                             f"{type(self.backend).__name__} has no set_material_scale): build the Simulator "
                             "from a Beam with the material you want instead.")
        setter(modulus, magnetization)
        self._material = (modulus, magnetization)
        h = self._health
        if self.options.has_contact:
            h.tc = contact_timeconst(self.beam, self.options)
            if isinstance(self.options.contact_timeconst, str):  # the material's: h sqrt(rho / E)
                h.tc /= math.sqrt(modulus)
        h.energy_scale = self.backend.energy_scale(self._energy_bmax)
        h.energy_valid = False  # the next call starts the energy balance again, with the new energies
        self._write_inputs()

    def set_waveform(self, waveform, *, start_time: float | None = None) -> None:
        """Let the field follow ``waveform(t - start_time)`` (T); ``start_time`` defaults to now. A rod in the x-z
        plane refuses a three-axis waveform with a y component (ValueError); one without (a field rotating about
        y) it takes."""
        wf = as_waveform(waveform, "waveform")
        probe = lift3(wf.sample(np.linspace(0.0, 1.0, 257)))
        self.backend.check_fields(probe, wf)
        self._waveform = wf
        self._wf_t0 = self.time if start_time is None else finite_number("start_time", start_time, unit="s")
        self._B3[:] = lift3(self._waveform.sample(np.array([self.time - self._wf_t0])))[0]
        if self._offset is not None:  # a uniform source's field, added
            self._B3 += self._offset
            probe = probe + self._offset
        self._write_inputs()
        # a bound of the peak field: the hypotenuse of each component's peak
        px, py, pz = np.abs(probe).max(axis=0)
        bmax = float(np.hypot(px, np.hypot(py, pz)))
        if self._source is not None:
            bmax += self._source_bmax
        self._energy_bmax = max(bmax, FIELD_FLOOR)
        self._health.energy_scale = self.backend.energy_scale(self._energy_bmax)

    @property
    def source(self):
        """The field source given to :meth:`set_source` (or the constructor), or None."""
        return self._source_given

    def set_source(self, source) -> None:
        """Apply a field source (:mod:`magsoft_env.fields`) besides the uniform field from now on; None: the uniform
        field alone again.

        The field on a piece is the uniform field (:meth:`set_field`, :meth:`set_waveform`) plus the source's at the
        piece. The source's uniform parts (a :class:`~magsoft_env.fields.Uniform`, or the uniform terms of a
        :class:`~magsoft_env.fields.SourceSum`) are added to the uniform field and run its path: ``source=Uniform(B)``
        is bit for bit ``field=B`` (:attr:`field` reports the sum). Any other source is evaluated before every
        physics step at the pieces' magnetic centres, in one call for all pieces, at the step's simulation time if
        its ``field_and_gradient`` takes ``t=`` (a :class:`~magsoft_env.fields.MovingSource`); each piece of world
        moment ``m`` gets the couple ``m x B`` and the force ``G^T m``, applied by the rod's backend
        (:meth:`~magsoft_env.sim.backend.RodBackend.set_source`; docs/sim.md, "Field sources"). Those steps run one
        at a time from Python. The energy checks count the source's energy ``-sum m . B(p)``; the energy balance
        of the contact scenes is off (:attr:`energy_drift` NaN) under a source that moves, whose work it does not
        count. A ValueError when the source's field at a piece of the present state exceeds 1 T in a component (or
        at any later step; see :class:`~magsoft_env.sim.sources.SourceField`), or (a rod in the x-z plane) a
        uniform part has a y component.
        """
        uniform, rest = split_source(source)
        if uniform is not None:
            self.backend.check_field(as_field(tuple(float(b) for b in uniform), "source (its uniform part)"))
        held = self._B3.copy() if self._offset is None else self._held.copy()
        src = None if rest is None else SourceField(rest)
        bmax = 0.0
        if src is not None:
            self._sync()
            self.backend.set_source(self.data, src)
            try:
                bmax = field_bound(self.backend.source_field(self.data))
            except ValueError:
                self.backend.set_source(self.data, self._source)
                raise
        else:
            self.backend.set_source(self.data, None)
        self._source, self._source_given, self._source_bmax = src, source, bmax
        self._offset = uniform
        if self._waveform is not None:
            self.set_waveform(self._waveform, start_time=self._wf_t0)
        else:
            self.set_field(tuple(float(b) for b in held))

    def _write_inputs(self) -> None:
        self.backend.write_field(self.data, self._B3)

    def magnetic_couples(self) -> np.ndarray:
        """Magnetic couples on the pieces now, world frame, shape ``(N + 1, 3)`` (N m)."""
        self._sync()
        return self.backend.magnetic_couples(self.data, self._B3)

    # ------------------------------------------------------------------ stepping
    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps.

        Parameters
        ----------
        n : int
            Number of steps, a non-negative integer, at most
            :data:`~magsoft_env.sim.health.MAX_STEPS` per call.

        Raises
        ------
        ValueError
            ``n`` not a non-negative integer, or above the limit; a non-finite :attr:`external_wrench`.
        SimulationError
            On a non-finite or huge state (MuJoCo warning) or runaway kinetic energy;
            :class:`UnphysicalError` (contact scenes) on a contact penetration, tunnelling or
            launch (see the class notes).
        """
        for _ in self.stepping(n):
            pass

    def stepping(self, n: int = 1, *, block: int | None = None):
        """:meth:`step` as a generator that yields after every block of steps MuJoCo runs natively.

        Driving it to its end is :meth:`step` (the same steps, checks and errors); in between, the
        caller may run other work, for example another simulator's block on the same thread: the
        batched environments interleave their robots this way, so that all of them end a call
        together. ``block`` caps the steps of one native block (default and most: the contact history,
        :data:`~magsoft_env.sim.model.CONTACT_HISTORY`); blocks also end at every energy check. The
        trajectory and the checks do not depend on the blocks. A generator closed before its end leaves
        the state of its last block, without the end-of-call check.
        """
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer number of steps, got {n!r}.")
        n = int(check_steps("n", int(n), "Call step() repeatedly for a longer run."))
        if block is not None and (isinstance(block, (bool, np.bool_)) or not isinstance(block, (int, np.integer))
                                  or block < 1):
            raise ValueError(f"block must be None or a positive integer number of steps, got {block!r}.")
        block = self._block if block is None else min(int(block), self._block)
        d = self.data
        external = bool(np.any(self.external_wrench))
        if external and not np.isfinite(self.external_wrench).all():
            raise ValueError("external_wrench must be finite (N, N m), got non-finite entries at pieces "
                             f"{sorted(set(np.argwhere(~np.isfinite(self.external_wrench))[:, 0].tolist()))}.")
        fields = None
        if self._waveform is not None:  # all fields of this call in one vectorized sample
            fields = lift3(self._waveform.sample(d.time - self._wf_t0 + self.timestep * np.arange(n)))
            if self._offset is not None:  # a uniform source's field, added
                fields = fields + self._offset
            self.backend.check_fields(fields, self._waveform)
        health = self._health
        # the work of a moving source is not booked: its energy balance is off, as with an external wrench
        moving = self._source is not None and self._source.moves
        if health.begin_call(self.nstep, None if fields is not None else self._B3.copy(), external=external or moving,
                             stale=self._stale):
            self._stale = False
        self.backend.apply_external(d, self.external_wrench if external else None)
        # MuJoCo's own warning text is captured (not printed or logged to MUJOCO_LOG.TXT), with the time of
        # the step that raised it; between blocks the caller's handler is back (it may step another simulator)
        prev = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self.on_warning)
        try:
            for _ in self._blocks(n, fields, block):
                mujoco.set_mju_user_warning(prev)
                yield
                prev = mujoco.get_mju_user_warning()
                mujoco.set_mju_user_warning(self.on_warning)
        finally:
            mujoco.set_mju_user_warning(prev)
            if fields is not None and n > 0:  # the field of the last step run (or of the step that failed)
                n0 = health.call_ref[0]
                last = min(max(min(self.nstep, health.failed_step(self.nstep)) - 1 - n0, 0), n - 1)
                self._B3[:] = fields[last]
                self._write_inputs()
            if health.contact:
                health.state_key = health.key()
        health.check(self.nstep, self._B3, energy=False)

    def _blocks(self, n: int, fields, block: int):
        """The engine: ``n`` steps in blocks that end at every energy check and after at most ``block`` steps,
        each run by the backend (:meth:`~magsoft_env.sim.backend.RodBackend.advance`) and checked step by step
        afterwards; yields between blocks, stops at a broken bound or a MuJoCo warning (the end-of-call check
        reports it). ``fields``: ``(n, 3)`` per-step fields, or None for the held field."""
        d, health, backend = self.data, self._health, self.backend
        ce = self.check_every
        done = 0
        while done < n:
            k = min(n - done, ce - self.nstep % ce, block)
            n0, t0 = self.nstep, float(d.time)
            backend.advance(d, self._B3, None if fields is None else fields[done:done + k], k, health)
            self.nstep += k
            self._stale = True
            done += k
            warned = bool(health.warning_text)
            # the steps before the one that warned count, as in a per-step loop
            stop = max(0, health.warned_step(self.nstep) - 1 - n0) if warned else k
            if health.scan_block(k, stop, n0, t0) or warned:
                return
            if self.nstep % ce == 0:
                if fields is not None:
                    self._B3[:] = fields[done - 1]
                health.check(self.nstep, self._B3, energy=True)
            if done < n:
                yield

    def _sync(self) -> None:
        # after mj_step the position-dependent quantities (xpos, xmat, qM, contacts) belong to
        # the state before the step; readouts recompute them for the current qpos
        if self._stale:
            mujoco.mj_fwdPosition(self.model, self.data)
            self._stale = False

    def run(self, waveform, duration: float, *, record_every: int = 10) -> Trajectory:
        """Follow ``waveform`` (or a constant field) for ``duration`` (s), recording every
        ``record_every`` steps (and the first state); at most
        :data:`~magsoft_env.sim.health.MAX_STEPS` steps in all."""
        duration = positive("duration", duration, unit="s")
        if isinstance(record_every, bool) or not isinstance(record_every, (int, np.integer)) or record_every < 1:
            raise ValueError(f"record_every must be a positive integer, got {record_every!r}.")
        nsteps = int(round(check_steps(f"duration / timestep = {duration:g} s / {self.timestep:g} s",
                                       duration / self.timestep, "Use a shorter duration or a larger timestep.")))
        self.set_waveform(waveform)
        ts, fs, xs, ys, zs, tips = [], [], [], [], [], []

        def record():
            c = self.pose().centreline
            ts.append(self.time)
            fs.append(self._B3[self._axes])
            xs.append(c[:, 0])
            ys.append(c[:, 1])
            zs.append(c[:, 2])
            tips.append(self.tip_angle())

        record()
        done = 0
        while done < nsteps:
            k = min(record_every, nsteps - done)
            self.step(k)
            done += k
            record()
        return Trajectory(np.array(ts), np.array(fs), np.array(xs), np.array(zs), np.array(tips), np.array(ys))

    # ------------------------------------------------------------------ statics
    def static_residual(self) -> float:
        """``max_j |Q_j| / k_j`` (rad) at the current configuration and zero velocity, where Q
        is the net generalized force on the hinges (springs, gravity, magnetic couples)."""
        m, d = self.model, self.data
        qvel = d.qvel.copy()
        d.qvel[:] = 0.0
        # the magnetic couples are MuJoCo's forces, part of qfrc_smooth (native: actuators; a rod whose couples are
        # written from Python writes them for this state here)
        self.backend.apply_external(d, self.external_wrench if np.any(self.external_wrench) else None)
        self.backend.write_field(d, self._B3)
        mujoco.mj_forward(m, d)
        dofs = self.backend.hinge_dof
        q = d.qfrc_smooth[dofs] + d.qfrc_constraint[dofs]
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        self._stale = False
        return float(np.max(np.abs(q) / self.backend.stiffness))

    def settle(
        self, *, tol: float = 1e-7, max_time: float = 20.0, speed_tol: float | None = None,
        settle_damping: float = 0.05,
    ) -> SettleResult:
        """Settle to static equilibrium by damped dynamics at the current (constant) field.

        The rod's elastic dofs are damped while settling (the backend's ``settle_damping``: the planar chain's
        hinges get ``settle_damping * k_j``, a Kelvin-Voigt time in s; the 3D strip a mass-proportional damping
        at its first bending rate) and restored after. Converged when, at a check, the static residual
        (:meth:`static_residual`, rad) is below ``tol`` and the largest rate of the elastic dofs (the backend's
        ``settle_speed``) is below ``speed_tol`` (rad/s; default ``tol / settle_damping``).

        Parameters
        ----------
        tol : float
            Residual tolerance (rad), > 0.
        max_time : float
            Simulated-time budget (s), at most :data:`~magsoft_env.sim.health.MAX_STEPS` steps.
        settle_damping : float
            Retardation time used while settling (s).
        """
        tol = positive("tol", tol, unit="rad")
        max_time = positive("max_time", max_time, unit="s")
        settle_damping = positive("settle_damping", settle_damping, unit="s")
        speed_tol = tol / settle_damping if speed_tol is None else positive("speed_tol", speed_tol, unit="rad/s")
        nmax = math.ceil(check_steps(f"max_time / timestep = {max_time:g} s / {self.timestep:g} s",
                                     max_time / self.timestep, "Use a shorter max_time or a larger timestep."))
        m = self.model
        dofs, damping = self.backend.settle_damping(settle_damping)
        damp0 = m.dof_damping[dofs].copy()
        m.dof_damping[dofs] = damping
        self._waveform = None  # hold the present field
        steps, chunk = 0, 20
        res, speed = math.inf, math.inf
        try:
            while steps < nmax:
                self.step(chunk)
                steps += chunk
                speed = self.backend.settle_speed(self.data)
                if speed < speed_tol:
                    res = self.static_residual()
                    if res < tol:
                        return SettleResult(True, steps, res, speed, "converged")
            res = self.static_residual()
        finally:
            m.dof_damping[dofs] = damp0
        return SettleResult(
            False, steps, res, speed,
            f"not settled in {max_time:g} s: residual {res:.3g} rad (tol {tol:g}), speed {speed:.3g} rad/s",
        )

    # ------------------------------------------------------------------ readouts
    def pose(self) -> Pose:
        """Where the rod is, in one shape for every rod (:class:`~magsoft_env.sim.backend.Pose`): centre of mass
        ``(3,)``, centreline ``(n, 3)``, the pieces' tangents and width axes (heading, pitch, roll)."""
        self._sync()
        return self.backend.pose(self.data)

    def orientation_tracker(self):
        """A new tracker of the body's orientation end over end, continuous over the poses it is given
        (``tracker.track(sim.pose())``, rad; ``tracker.heading``, rad): the rod's own
        (:mod:`~magsoft_env.sim.readouts`)."""
        return self.backend.orientation_tracker()

    def centreline_history(self):
        """Reader of the centreline at the start of every step of the last block (contact scenes): ``last(k)``
        ``(n, k, 3)`` (m), ``nsample`` (the longest block it covers)."""
        return self.backend.centreline_history(self.data)

    def floor_contact_history(self):
        """Reader of the deepest floor contact at the start of every step of the last block (contact scenes):
        ``last(k)`` ``(k,)`` (m, < 0 touching, 0 none)."""
        return self.backend.contact_histories(self.data)[0]

    def floor_depth(self) -> float:
        """The deepest floor contact of the state now (m, < 0 touching, 0 none), from MuJoCo's contacts."""
        self._sync()
        m, d = self.model, self.data
        floor = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        n = d.ncon
        if floor < 0 or not n:
            return 0.0
        c = d.contact
        on = (c.geom[:n] == floor).any(axis=1)
        return float(min(c.dist[:n][on].min(), 0.0)) if on.any() else 0.0

    def centerline(self) -> tuple[np.ndarray, ...]:
        """Centerline points (m) in the rod's own components: ``(x, z)`` for a rod in the x-z plane (the base
        end, every hinge, the tip; shape ``(N + 2,)`` each; hinge ``j`` at ``s = (j + 1/2) L / N``), ``(x, y, z)``
        for the 3D strip. :meth:`pose` gives ``(n, 3)`` for every rod."""
        self._sync()
        return self.backend.centerline(self.data)

    def tip_position(self) -> tuple[float, ...]:
        """Tip point (m) in the rod's own components (``(x, z)`` in the x-z plane): the last :meth:`centerline`
        point, without building the rest."""
        self._sync()
        return self.backend.tip_position(self.data)

    def center_of_mass(self) -> np.ndarray:
        """Centre of mass (m) in the rod's own components (``(x, z)`` in the x-z plane), of the current state."""
        self._sync()
        return self.backend.center_of_mass(self.data)

    def arc_length(self) -> np.ndarray:
        """Reference arc length (m) of the :meth:`centerline` points, shape ``(N + 2,)``."""
        return self.backend.arc_length()

    def angles(self) -> np.ndarray:
        """Tangent angle of every piece from +x toward +z (rad), shape ``(N + 1,)`` (3D: of its x-z projection)."""
        self._sync()
        return self.backend.angles(self.data)

    def angular_velocities(self) -> np.ndarray:
        """Angular velocity of every piece about -y (rad/s), the rate of :meth:`angles`, shape ``(N + 1,)``."""
        self._sync()
        return self.backend.angular_velocities(self.data)

    def tip_angle(self) -> float:
        """Tangent angle of the tip piece (rad), continuous beyond +-pi (sum of joint angles) for the chain."""
        return self.backend.tip_angle(self.data)

    def tip_twist(self) -> float:
        """Integrated twist ``int k3 ds`` (rad); 0 for a rod that cannot twist."""
        self._sync()
        return self.backend.tip_twist(self.data)

    def contacts(self) -> list[dict]:
        """Active contacts: geom names, position (m), penetration depth (m, >= 0 when touching)."""
        self._sync()
        m, d = self.model, self.data
        return [{"geom1": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, c.geom1),
                 "geom2": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, c.geom2),
                 "pos": np.array(c.pos), "penetration": float(-c.dist)} for c in d.contact[: d.ncon]]

    @property
    def ncon(self) -> int:
        """Number of active contacts."""
        self._sync()
        return int(self.data.ncon)

    def kinetic_energy(self) -> float:
        """Kinetic energy (J)."""
        self._sync()
        mv = np.zeros(self.model.nv)
        mujoco.mj_mulM(self.model, self.data, mv, self.data.qvel)
        return 0.5 * float(self.data.qvel @ mv)

    def energies(self) -> dict[str, float]:
        """Kinetic, elastic, gravitational, magnetic and total energy (J).

        Gravity is measured from z = 0; magnetic energy is ``-sum (R m) . B``, with a source's field at each piece
        added to ``B``.
        """
        kinetic = self.kinetic_energy()
        return self.backend.energies(self.data, self._B3, kinetic)


__all__ = ["MATERIAL_SCALE_RANGE", "material_factor", "SettleResult", "SimulationError", "Simulator", "Trajectory",
           "UnphysicalError"]

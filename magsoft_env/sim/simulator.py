"""The rod simulator: field, stepping, waveforms, settling, readouts and stability checks."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np

from ..spec import Beam, Field, as_field
from ..spec.field import MAX_FIELD
from ..validate import finite_number, positive
from . import magnetics
from .health import (
    ENERGY_DRIFT_LIMIT,
    MAX_STEPS,
    PENETRATION_LIMIT,
    STABILITY_HINT,
    WARNING_IDS,
    SensorHistory,
    SimulationError,
    UnphysicalError,
    check_steps,
    new_warning,
    runaway,
    runaway_hint,
)
from .model import (
    CONTACT_HISTORY,
    CONTACT_SENSOR,
    FEATURE_SENSOR,
    NATIVE_CONTROL_SPEC,
    RodModel,
    RodOptions,
    build_model,
    contact_timeconst,
    field_control,
    field_controls,
    native_controls,
)
from .waveforms import Waveform, as_waveform

#: field magnitude (T) below which the energy scale uses this floor instead
_FIELD_FLOOR = 0.05


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
    field : (n, 2) ndarray
        Applied field B_x, B_z (T).
    x, z : (n, N + 2) ndarray
        Centerline points (m), base to tip (see :meth:`Simulator.centerline`).
    tip_angle : (n,) ndarray
        Tangent angle of the tip (rad).
    """

    time: np.ndarray
    field: np.ndarray
    x: np.ndarray
    z: np.ndarray
    tip_angle: np.ndarray

    def to_dict(self) -> dict:
        """The samples as nested lists of plain numbers (SI, unit in the key), for JSON."""
        return {
            "time_s": np.asarray(self.time, dtype=float).tolist(),
            "field_T": np.asarray(self.field, dtype=float).tolist(),
            "x_m": np.asarray(self.x, dtype=float).tolist(),
            "z_m": np.asarray(self.z, dtype=float).tolist(),
            "tip_angle_rad": np.asarray(self.tip_angle, dtype=float).tolist(),
        }


class Simulator:
    """A magnetic rod in MuJoCo under a uniform applied field.

    Every step each rigid piece feels the couple ``tau_i = (R_i m_i) x B`` (N m) of the state the
    step starts from. With ``RodOptions(magnetics="native")`` (the default) MuJoCo applies it
    itself, as forces along the field at the pieces' magnetic poles (site actuators; the simulator
    only sets ``ctrl = |B|`` and the field frame's mocap quaternion when the field changes): a
    held field then runs in blocks of steps inside MuJoCo (``mj_step(m, d, k)``), RK4 sees the
    couples of each of its stages, and ``mujoco.rollout`` / ``mujoco.batch`` can run the same
    model (docs/sim.md, "Native magnetic forces"). With ``magnetics="python"`` the simulator
    writes the couples into ``data.qfrc_applied`` each step as their generalized forces (the
    planar rod's angular Jacobian about y is a constant 0 / +-1 map), computed from the piece
    orientations of the step's start (``mj_step1`` / ``mj_step2``; RK4 uses ``mj_step`` and the
    previous step's orientations).
    After every call to :meth:`step` the state is checked: non-finite or huge values
    (MuJoCo's warnings; auto-reset is disabled), and kinetic energy above
    ``100 x`` the system's energy scale, raise :class:`SimulationError`.

    The contact scenes are also held to physical bounds (:class:`UnphysicalError`, a
    :class:`SimulationError`; docs/sim.md, "Physical checks"): every step, a contact deeper than
    ``penetration_limit`` x the thickness h (MuJoCo's own contact sensor, read once per step);
    at every energy check, the centreline more than that below the floor (tunnelling) and energy
    the field cannot have supplied (a launch: the total energy above its start plus the field's
    work, more than :data:`~magsoft_env.sim.health.ENERGY_DRIFT_LIMIT` of the energy scale).
    The records :attr:`max_penetration`, :attr:`energy_drift` and :attr:`max_kinetic_ratio`
    say of every run whether it stayed resolved.

    A field that changes every step (a waveform) runs in ``mujoco.rollout`` blocks with the fields'
    inputs as per-step controls (:attr:`rollout_blocks`; the planar rod), bit for bit the per-step loop's
    trajectory and failure reports, the field's work for the energy balance booked from the recorded
    states (equal to round-off).

    Native blocks keep these checks: a block ends at every energy check and after at most
    :data:`~magsoft_env.sim.model.CONTACT_HISTORY` steps, whose deepest contacts MuJoCo keeps in
    the contact sensors' history buffer; a bound broken (or a MuJoCo warning) inside a block is
    reported with the step at which it happened, as a per-step loop would report it, while the
    state has run on to the end of the block (at most ``CONTACT_HISTORY - 1`` steps more).

    Parameters
    ----------
    beam : Beam
        The beam specification.
    options : RodOptions, optional
        Scene, segments, integrator, timestep.
    field : Field or (B_x, B_z), optional
        Initial applied field (T).
    check_every : int
        Steps between energy checks (the finite-state check runs after every call to
        :meth:`step`).
    torque_every : int
        Recompute the magnetic couples every this many steps and hold them in between (1:
        every step). A speed shortcut of the Python couples whose error docs/sim.md measures:
        above 1 the rod is built with ``magnetics="python"`` (native couples are always current).
    penetration_limit : float
        Contact scenes: the deepest contact allowed, in beam thicknesses (> 0; default
        :data:`~magsoft_env.sim.health.PENETRATION_LIMIT` = 1 h; ``math.inf`` records the depth
        without stopping).

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> sim = Simulator(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), field=(0, 0.005))
    >>> sim.settle().success
    True
    """

    def __init__(
        self, beam: Beam, options: RodOptions | None = None, *, field=(0.0, 0.0), check_every: int = 50,
        torque_every: int = 1, penetration_limit: float = PENETRATION_LIMIT,
    ):
        if not isinstance(beam, Beam):
            raise ValueError(f"beam must be a Beam, got {type(beam).__name__}.")
        if options is not None and not isinstance(options, RodOptions):
            raise ValueError(f"options must be a RodOptions or None, got {type(options).__name__}.")
        for name, v in (("check_every", check_every), ("torque_every", torque_every)):
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v < 1:
                raise ValueError(f"{name} must be a positive integer, got {v!r}.")
        if not (isinstance(penetration_limit, (int, float, np.floating)) and penetration_limit == math.inf):
            positive("penetration_limit", penetration_limit, unit="beam thicknesses")
        as_field(field, "field")  # checked before the model is built
        self.torque_every = int(torque_every)
        if self.torque_every > 1:  # held couples are a shortcut of the Python path only
            options = RodOptions() if options is None else options
            if options.magnetics == "native":
                options = replace(options, magnetics="python")
        self.rod: RodModel = build_model(beam, options)
        self.model = self.rod.model
        self.data = mujoco.MjData(self.model)
        self._native = self.rod.native
        if self._native:  # the field's inputs: every actuator's control |B|, the field frame's orientation
            self._ctrl = self.data.ctrl
            self._mquat = self.data.mocap_quat[self.rod.field_mocap]
        self.check_every = int(check_every)
        #: Native magnetics: run a field that changes every step (a waveform) in ``mujoco.rollout`` blocks
        #: (True, the planar rod) rather than one ``mj_step`` at a time with Python in between (False).
        self.rollout_blocks = True
        self._angles = None  # from _angle_map (see _rollout_ok), False where it does not apply; built on first use
        self._roller = None
        disc = self.rod.disc
        self._bodies = self.rod.body_ids
        self._m_body = magnetics.body_moments_3d(disc.moment)
        self._k = disc.stiffness
        self._hinge_dof = self.rod.hinge_dof
        self._hinge_qpos = self.rod.hinge_qpos
        self._tip_len = float(disc.piece_length[-1])
        self._two_stage = self.model.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4
        # pieces in body-id order (the tree is numbered from the base piece outward), so the
        # rows of xmat (and of external wrenches in xfrc_applied) form one contiguous block
        self._order = np.argsort(self._bodies)
        self._b0, self._b1 = int(self._bodies.min()), int(self._bodies.max()) + 1
        if self._b1 - self._b0 != len(self._bodies):
            raise RuntimeError("rod bodies must have consecutive ids")  # guaranteed by build_model
        self._S = self._couple_map()
        self._mv = np.zeros(self.model.nv)
        #: Extra constant wrench per piece, world frame, shape (N + 1, 6): force (N) at the
        #: piece's centre of mass, then couple (N m); added to the magnetic couples each step.
        self.external_wrench = np.zeros((len(self._bodies), 6))
        self._B3 = np.zeros(3)
        self._has_external = False
        self._warning_text: list[str] = []
        self._warning_times: list[float] = []
        self._call_ref = (0, 0.0)  # (nstep, time) at the start of the present step() call
        self._stale = False
        self._waveform: Waveform | None = None
        self._wf_t0 = 0.0
        self.nstep = 0
        self._setup_physical_checks(float(penetration_limit))
        self.set_field(field)
        self.reset()

    def _setup_physical_checks(self, limit: float) -> None:
        o = self.options
        self._contact = o.has_contact
        h = self.beam.thickness
        #: deepest contact allowed (m), and the signed-distance bound the step loop compares with
        self.penetration_limit = limit * h
        self._dist_limit = -self.penetration_limit
        self._sensordata = self.data.sensordata if self._contact else np.zeros(1)
        self._sensor_adr = max(self.rod.contact_sensor, 0)
        self._feature = self.rod.feature_sensor >= 0  # channel, obstacle: contacts with anything
        self._feature_adr = max(self.rod.feature_sensor, 0)
        # native blocks: the contact sensors' history buffers (every step of a block), and the
        # longest block they cover; without contact a block ends only at the energy checks
        self._hist = self._hist_feature = None
        self._block = MAX_STEPS
        if self._contact and self._native:
            sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, CONTACT_SENSOR)
            self._hist = SensorHistory(self.model, sid, self.data.history)
            if self._feature:
                sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, FEATURE_SENSOR)
                self._hist_feature = SensorHistory(self.model, sid, self.data.history)
            self._block = min(self._hist.nsample, CONTACT_HISTORY)
        # energy balance (contact scenes, two-stage integrators, couples every step): the net
        # magnetic moment (sum of R_i m_i, world x and z) is -v[nv + dof], -v[dof] of the
        # generalized-couple products the waveform loop computes anyway (the base hinge turns
        # every piece: S[:, dof] = -1), so the field's work costs two reads per step
        self._C = np.ascontiguousarray(np.stack([self._cx_map().ravel(), self._cz_map().ravel()], axis=1))
        self._energy_on = self._contact and self._two_stage and self.torque_every == 1
        self._ix = self._iz = 0
        if self._energy_on:
            dof = int(self.model.jnt_dofadr[mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_JOINT, "base_theta")])
            if not np.all(self._S[:, dof] == -1.0):
                raise RuntimeError("the base hinge must turn every piece")  # guaranteed by build_model
            self._iz, self._ix = dof, self.model.nv + dof
        # the hinges' qpos / dof addresses as slices where they form one block (they do: the base
        # joints first, then the hinges), with the stiffnesses in that order: views, not gathers
        hq, hd = np.asarray(self._hinge_qpos), np.asarray(self._hinge_dof)
        if (np.array_equal(np.sort(hq), np.arange(hq.min(), hq.min() + hq.size))
                and np.array_equal(hd - hd.min(), hq - hq.min())):
            q0, d0 = int(hq.min()), int(hd.min())
            self._hq, self._hd = slice(q0, q0 + hq.size), slice(d0, d0 + hd.size)
            self._hinge_k = np.zeros(hq.size)
            self._hinge_k[hq - hq.min()] = self._k
        else:
            self._hq, self._hd, self._hinge_k = hq, hd, np.asarray(self._k, dtype=float)
        self._mass_g = self.rod.disc.mass * o.gravity
        self._mass_g_ids = np.ascontiguousarray(self._mass_g[self._order])  # body-id order: xipos[b0:b1]
        self._tip_body = int(self._bodies[-1])
        self._tc = contact_timeconst(self.beam, o) if self._contact else math.nan

    def _cx_map(self) -> np.ndarray:
        # (pieces in body-id order, 9): (R m)_x of each piece is xmat-row @ this row
        mx, mz = self._m_body[self._order, 0], self._m_body[self._order, 2]
        c = np.zeros((len(self._bodies), 9))
        c[:, 0], c[:, 2] = mx, mz
        return c

    def _cz_map(self) -> np.ndarray:
        mx, mz = self._m_body[self._order, 0], self._m_body[self._order, 2]
        c = np.zeros((len(self._bodies), 9))
        c[:, 6], c[:, 8] = mx, mz
        return c

    def _angle_map(self):
        """``(A, phi0)`` with every piece's rotation angle about y (body-id order) = ``A @ qpos + phi0``, when
        every rotation of the tree is about y (the planar rod: hinges and body frames about +-y, slides
        otherwise); else None. ``R_y(phi)`` is then each piece's ``xmat`` to round-off (tested), so the
        net moment of a recorded ``qpos`` is ``cos`` / ``sin`` sums, without MuJoCo's kinematics."""
        m = self.model
        nb = m.nbody
        A = np.zeros((nb, m.nq))
        phi0 = np.zeros(nb)
        for b in range(1, nb):
            w, x, y, z = m.body_quat[b]
            if x != 0.0 or z != 0.0:
                return None
            parent = m.body_parentid[b]
            A[b], phi0[b] = A[parent], phi0[parent] + 2.0 * math.atan2(y, w)
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
                kind = m.jnt_type[j]
                if kind == mujoco.mjtJoint.mjJNT_HINGE:
                    ax = m.jnt_axis[j]
                    if ax[0] != 0.0 or ax[2] != 0.0 or abs(ax[1]) != 1.0:
                        return None
                    A[b, m.jnt_qposadr[j]] += ax[1]
                elif kind != mujoco.mjtJoint.mjJNT_SLIDE:
                    return None
        ids = np.arange(self._b0, self._b1)
        return A[ids], phi0[ids]

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
        """The applied field now (T)."""
        return Field(float(self._B3[0]), float(self._B3[2]))

    def reset(self) -> None:
        """Straight beam at rest (floor scenes: lying on the floor), time zero; the records
        (:attr:`max_penetration`, :attr:`energy_drift`, :attr:`max_kinetic_ratio`) start again."""
        mujoco.mj_resetData(self.model, self.data)
        if self._native:  # mj_resetData zeroed the field's inputs; the field itself is kept
            self._write_controls()
        self._warning_text.clear()
        self._warning_times.clear()
        self.nstep = 0
        self._wf_t0 = 0.0
        mujoco.mj_forward(self.model, self.data)
        self._stale = False
        self._warn0 = self._warning_counts()
        self._min_dist = 0.0  # most negative floor-contact distance seen (m)
        self._pen_at = (0, 0.0)  # step and time of it
        self._pen_hit = ""  # "", "floor" or "scene": which bound was broken
        # a start that already overlaps a scene feature (feature_x through the resting beam) is the
        # caller's geometry, not the dynamics': the contact bounds then count from that overlap
        self._overlap0 = 0.0
        if self._feature:  # the scene sensor sees the floor too: only a contact deeper than the floor's counts
            d_all, d_floor = float(self._sensordata[self._feature_adr]), float(self._sensordata[self._sensor_adr])
            self._overlap0 = -d_all if d_all < min(d_floor, 0.0) else 0.0
        self._feature_limit = self._floor_limit = self._dist_limit - self._overlap0
        self._min_feature = 0.0
        self._feature_at = (0, 0.0)
        self._max_ke_ratio = 0.0
        self._drift = 0.0 if self._energy_on else math.nan
        self._b_applied = self._B3[[0, 2]].copy()
        self._rebaseline()

    # ------------------------------------------------------------------ physical records
    @property
    def max_penetration(self) -> float:
        """Deepest rod contact seen since the last reset (m; 0 in the cantilever), checked every
        step: with the floor, and in the channel and obstacle scenes with anything (the check of
        those counts from the overlap the start had, :attr:`initial_overlap`)."""
        return max(0.0, -self._min_dist, -self._min_feature)  # 0.0 first: never -0.0

    @property
    def initial_overlap(self) -> float:
        """Channel and obstacle scenes: how deep the resting beam starts inside a scene feature (m;
        0 unless ``feature_x`` places it through the beam). The penetration bound counts from it
        (``penetration_limit`` + this overlap): pushing the beam out of a feature it was placed in
        is the caller's geometry, not a failure of the contact."""
        return self._overlap0

    @property
    def energy_drift(self) -> float:
        """Largest energy the numerics created since the last reset, as a fraction of the energy
        scale: ``max (E - E_0 - W) / E_scale`` over the energy checks, with ``E`` the kinetic,
        elastic, gravitational and magnetic energy and ``W`` the work of the field on the rod.
        Physically ``E - E_0 - W <= 0`` (damping and contact dissipate): a resolved run stays near 0
        (measured below 1e-6); above :data:`~magsoft_env.sim.health.ENERGY_DRIFT_LIMIT` the run
        stops as a launch. Restarts from the present state when the state is written from outside
        (``data.qpos`` / ``qvel``). NaN where it is not tracked: the cantilever, RK4,
        ``torque_every > 1`` or an ``external_wrench`` (whose work it does not count)."""
        return float(self._drift)

    @property
    def max_kinetic_ratio(self) -> float:
        """Largest kinetic energy at an energy check since the last reset, over the energy scale
        (the runaway check stops a run at 100)."""
        return float(self._max_ke_ratio)

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

    def _net_moment(self) -> np.ndarray:
        """Net magnetic moment sum R_i m_i (world x, z; A m^2) of the orientations in ``xmat``."""
        return self.data.xmat[self._b0:self._b1].reshape(-1) @ self._C

    def _energy(self, field, *, staggered: bool, kinetic: float | None = None) -> float:
        """Kinetic + elastic + gravitational + magnetic energy (J) under ``field`` (B_x, B_z).

        ``staggered``: the positions in ``xmat`` / ``xipos`` / ``qM`` are those of the step's start
        (after ``mj_step``), paired with the new velocity, the pair symplectic Euler keeps; the hinge
        angles are then ``qpos - dt qvel`` (exact for the Euler-type integrators)."""
        d = self.data
        q = d.qpos[self._hq]
        q = q - self.timestep * d.qvel[self._hd] if staggered else q
        if kinetic is None:
            mv = self._mv
            mujoco.mj_mulM(self.model, d, mv, d.qvel)
            kinetic = 0.5 * float(d.qvel @ mv)
        mom = self._net_moment()
        return (kinetic + 0.5 * float(self._hinge_k @ (q * q)) + float(self._mass_g_ids @ d.xipos[self._b0:self._b1, 2])
                - float(mom[0] * field[0] + mom[1] * field[1]))

    def _rebaseline(self) -> None:
        """Start the energy balance from the present (synchronized) state."""
        self._work = 0.0
        self._energy_valid = self._energy_on
        if self._energy_on:
            self._sync()
            self._e0 = self._energy(self._b_applied, staggered=False)
        self._state_key = self.data.qpos.tobytes() + self.data.qvel.tobytes()

    def set_field(self, field) -> None:
        """Hold a constant applied field ``(B_x, B_z)`` (T) from now on."""
        bx = bz = None
        if type(field) is tuple and len(field) == 2:  # fast path for the per-step caller (envs)
            bx, bz = field
            if not (type(bx) in _FLOATS and type(bz) in _FLOATS and abs(bx) <= MAX_FIELD and abs(bz) <= MAX_FIELD):
                bx = bz = None  # (NaN fails the comparison) full validation below
        if bx is None:
            f = as_field(field)
            bx, bz = f.Bx, f.Bz
        self._waveform = None
        self._B3[0], self._B3[2] = bx, bz
        self._set_coefficients()
        self._energy_scale = self._compute_energy_scale()

    def set_waveform(self, waveform, *, start_time: float | None = None) -> None:
        """Let the field follow ``waveform(t - start_time)`` (T); ``start_time`` defaults to now."""
        self._waveform = as_waveform(waveform, "waveform")
        self._wf_t0 = self.time if start_time is None else finite_number("start_time", start_time, unit="s")
        self._B3[[0, 2]] = self._waveform.sample(np.array([self.time - self._wf_t0]))[0]
        self._set_coefficients()
        peak = np.abs(self._waveform.sample(np.linspace(0.0, 1.0, 257))).max(axis=0)
        self._energy_scale = self._compute_energy_scale(float(np.hypot(*peak)))

    def _compute_energy_scale(self, bmax: float | None = None) -> float:
        b = max(math.hypot(self._B3[0], self._B3[2]) if bmax is None else bmax, _FIELD_FLOOR)
        if not hasattr(self, "_energy_terms"):  # field-independent parts, computed once
            m_tot = float(self.rod.disc.mass.sum())
            mags = float(np.linalg.norm(self._m_body, axis=1).sum())
            elastic = 0.5 * float(np.sum(self._k)) * math.pi**2
            self._energy_terms = (2.0 * mags, 2.0 * m_tot * self.options.gravity * self.beam.length + elastic)
        slope, rest = self._energy_terms
        return slope * b + rest

    # ------------------------------------------------------------------ stepping
    def _couple_map(self) -> np.ndarray:
        """``S`` of shape (pieces in body-id order, nv): the generalized force of a couple
        ``tau_y`` (about world y) on piece ``i`` is ``tau_y S[i]``.

        Every joint that turns a piece is a hinge about +-y and the slides do not turn it, so the
        angular Jacobian about y is constant (entries 0 or +-1, whatever the configuration);
        it is read from MuJoCo once (``mj_applyFT`` of a unit couple at the reference pose).
        """
        m = self.model
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        S = np.zeros((len(self._bodies), m.nv))
        for row, body in enumerate(np.sort(self._bodies)):
            mujoco.mj_applyFT(m, d, np.zeros(3), np.array([0.0, 1.0, 0.0]), d.xipos[body], int(body), S[row])
        S = np.rint(S)  # exact +-1 / 0 (the axes are exact unit vectors; rint removes nothing but -0.0)
        return S

    def _set_coefficients(self) -> None:
        # planar fast path: every piece turns about y, so tau = (R m) x B has only a y part,
        # tau_y = B_x (R m)_z - B_z (R m)_x, linear in the row-major xmat entries 0, 2, 6, 8;
        # _cx / _cz hold the (R m)_x and (R m)_z rows, so coef = B_x _cz - B_z _cx. The
        # generalized force is then Q = S^T tau = xmat.ravel() @ G (G = coef (x) S, a constant
        # topology map S), one matrix-vector product straight into qfrc_applied: no per-body
        # force accumulation in MuJoCo (xfrc_applied) and no per-piece Python.
        if not hasattr(self, "_cx"):
            mx, mz = self._m_body[self._order, 0], self._m_body[self._order, 2]
            self._cx = np.zeros((len(self._bodies), 9))
            self._cz = np.zeros((len(self._bodies), 9))
            self._cx[:, 0], self._cx[:, 2], self._cz[:, 6], self._cz[:, 8] = mx, mz, mx, mz
            nv = self.model.nv
            gx = (self._cx[:, :, None] * self._S[:, None, :]).reshape(-1, nv)
            gz = (self._cz[:, :, None] * self._S[:, None, :]).reshape(-1, nv)
            #: [G_z | G_x], shape (9 pieces, 2 nv): Q = B_x (x @ G_z) - B_z (x @ G_x)
            self._gzx = np.ascontiguousarray(np.concatenate([gz, gx], axis=1))
            self._G = np.zeros((gx.shape[0], nv))
            self._gtmp = np.zeros_like(self._G)
            self._gz, self._gx = np.ascontiguousarray(gz), np.ascontiguousarray(gx)
        if self._native:  # MuJoCo needs only the inputs; G follows in _apply_torques, if ever asked for
            self._write_controls()
            self._g_field = None
            return
        self._python_coefficients()

    def _python_coefficients(self) -> None:
        bx, bz = self._B3[0], self._B3[2]
        np.multiply(self._gz, bx, out=self._G)
        np.multiply(self._gx, bz, out=self._gtmp)
        self._G -= self._gtmp
        self._g_field = (bx, bz)

    def _write_controls(self) -> None:
        # native magnetics: the field's inputs (model.field_control, as the batch and rollouts use)
        mag, w, y = field_control(float(self._B3[0]), float(self._B3[2]))
        self._ctrl.fill(mag)
        mq = self._mquat
        mq[0], mq[1], mq[2], mq[3] = w, 0.0, y, 0.0

    def _apply_torques(self, field=None) -> None:
        d = self.data
        if field is not None:
            self._B3[0], self._B3[2] = field
            self._set_coefficients()
        if self._native and self._g_field != (self._B3[0], self._B3[2]):
            self._python_coefficients()
        b0, b1 = self._b0, self._b1
        np.dot(d.xmat[b0:b1].reshape(-1), self._G, out=d.qfrc_applied)
        if self._has_external:
            d.xfrc_applied[b0:b1] = self.external_wrench[self._order]
        else:
            d.xfrc_applied[b0:b1] = 0.0

    def magnetic_couples(self) -> np.ndarray:
        """Magnetic couples on the pieces now, world frame, shape ``(N + 1, 3)`` (N m)."""
        self._sync()
        mw = magnetics.world_moments(self.data.xmat[self._bodies], self._m_body)
        return magnetics.couples(mw, self._B3)

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps, applying the magnetic couples each step.

        Parameters
        ----------
        n : int
            Number of steps, a non-negative integer, at most
            :data:`~magsoft_env.sim.health.MAX_STEPS` per call.

        Raises
        ------
        ValueError
            ``n`` not a non-negative integer, or above the limit.
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
        together. ``block`` caps the steps of one native block (default: the contact history,
        :data:`~magsoft_env.sim.model.CONTACT_HISTORY`); a native block is ``mj_step(m, d, k)``,
        k steps in a row (``mujoco.rollout`` with per-step inputs for a field that changes every step), so
        the trajectory and the checks do not depend on it. The per-step paths (Python couples, a tree
        that is not planar, ``rollout_blocks = False``) run without yielding. A generator closed before
        its end leaves the state of its last block, without the end-of-call check.
        """
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer number of steps, got {n!r}.")
        n = check_steps("n", int(n), "Call step() repeatedly for a longer run.")
        if block is not None and (isinstance(block, (bool, np.bool_)) or not isinstance(block, (int, np.integer))
                                  or block < 1):
            raise ValueError(f"block must be None or a positive integer number of steps, got {block!r}.")
        block = self._block if block is None else min(int(block), self._block)
        d = self.data
        two = self._two_stage
        self._has_external = bool(np.any(self.external_wrench))
        fields = None
        if self._waveform is not None:  # all fields of this call in one vectorized sample
            t = d.time - self._wf_t0 + self.timestep * np.arange(n)
            fields = self._waveform.sample(t)
        self._begin_balance(fields)
        # MuJoCo's own warning text is captured (not printed or logged to MUJOCO_LOG.TXT), with
        # the time of the step that raised it; _check turns the warning counters into a SimulationError
        prev = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self._on_warning)
        self._call_ref = (self.nstep, float(d.time))
        try:
            if self._native:
                for _ in self._step_native(n, fields, block):
                    # between blocks the caller's warning handler is back (it may step another simulator)
                    mujoco.set_mju_user_warning(prev)
                    yield
                    prev = mujoco.get_mju_user_warning()
                    mujoco.set_mju_user_warning(self._on_warning)
            elif self._has_external or not two:
                self._step_general(n, fields, two)
            else:
                self._step_fast(n, fields)
        finally:
            mujoco.set_mju_user_warning(prev)
            if self._contact:
                self._state_key = d.qpos.tobytes() + d.qvel.tobytes()
        self._check(energy=False)

    def _on_warning(self, text: str) -> None:
        self._warning_text.append(text)
        self._warning_times.append(float(self.data.time))  # the start of the step that warned

    def _warned_step(self) -> int:
        """Steps done when the first MuJoCo warning of this call was raised (counting the step that
        raised it, as a per-step loop stops); the present count if none was timed in this call."""
        n0, t0 = self._call_ref
        if not self._warning_times or self._warning_times[0] < t0 - 0.5 * self.timestep:
            return self.nstep
        return n0 + int(round((self._warning_times[0] - t0) / self.timestep)) + 1

    def _begin_balance(self, fields) -> None:
        """Before a call: restart the energy balance after an outside write to the state (or a
        call it could not follow), and book the work of a field change made since the last step."""
        if not self._contact:
            return
        d = self.data
        if not self._energy_on or self._has_external:
            self._energy_valid = False
            self._drift = math.nan
        elif not self._energy_valid or d.qpos.tobytes() + d.qvel.tobytes() != self._state_key:
            self._rebaseline()
        if self._energy_valid and fields is None:
            db = self._B3[[0, 2]] - self._b_applied
            if db[0] or db[1]:
                # a held field jumps at the state now: the work -M . dB with M of this state
                if self._stale:
                    mujoco.mj_kinematics(self.model, d)
                mom = self._net_moment()
                self._work -= float(mom[0] * db[0] + mom[1] * db[1])
            self._b_applied = self._B3[[0, 2]].copy()

    def _step_general(self, n: int, fields, two: bool) -> None:
        m, d = self.model, self.data
        hold, warned = self.torque_every, self._warning_text
        sd, adr, pen, low = self._sensordata, self._sensor_adr, self._contact, self._min_dist
        adr2, feat, low2 = self._feature_adr, self._feature, self._min_feature
        try:
            for k in range(n):
                f = None if fields is None else fields[k]
                if hold > 1 and self.nstep % hold:
                    mujoco.mj_step(m, d)  # couples held from the last update
                elif two:
                    mujoco.mj_step1(m, d)
                    self._apply_torques(f)
                    mujoco.mj_step2(m, d)
                else:
                    self._apply_torques(f)
                    mujoco.mj_step(m, d)
                self.nstep += 1
                self._stale = True
                if warned:  # MuJoCo reported a bad state in this step: stop here
                    break
                if pen and sd[adr] < low:  # the deepest contact so far (of the step's start state)
                    low = self._record_penetration(float(sd[adr]), self.nstep)
                    if self._pen_hit:
                        break
                if feat and sd[adr2] < low2:
                    low2 = self._record_feature(float(sd[adr2]), self.nstep)
                    if self._pen_hit:
                        break
                if self.nstep % self.check_every == 0:
                    self._check(energy=True)
        finally:
            self._min_dist = min(self._min_dist, low)
            self._min_feature = min(self._min_feature, low2)

    def _record_penetration(self, dist: float, nstep: int, time: float | None = None) -> float:
        # a new deepest floor contact: ``dist`` (m, < 0) of the state step ``nstep`` started from
        # (at ``time``; by default the step just taken)
        self._min_dist = dist
        self._pen_at = (nstep - 1, float(self.data.time) - self.timestep if time is None else time)
        if dist < self._floor_limit:
            self._pen_hit = "floor"
        return dist

    def _record_feature(self, dist: float, nstep: int, time: float | None = None) -> float:
        self._min_feature = dist
        self._feature_at = (nstep - 1, float(self.data.time) - self.timestep if time is None else time)
        if dist < self._feature_limit:
            self._pen_hit = "scene"
        return dist

    def _step_fast(self, n: int, fields) -> None:
        # the same as _step_general for the common case (two-stage integrator, no external
        # wrench), with the per-step Python work cut to one or two matrix-vector products
        # into qfrc_applied (see _set_coefficients), one read of the contact sensor and, with a
        # waveform in a contact scene, two reads for the field's work
        m, d = self.model, self.data
        b0, b1 = self._b0, self._b1
        x = d.xmat[b0:b1].reshape(-1)  # a view: xmat rows of the pieces, contiguous
        q = d.qfrc_applied
        d.xfrc_applied[b0:b1] = 0.0
        G, gzx = self._G, self._gzx
        nv = m.nv
        v = np.empty(2 * nv)
        v2 = v.reshape(2, nv)
        track = fields is not None and self._energy_valid
        if fields is not None:
            bs = fields * np.array([1.0, -1.0])  # (B_x, -B_z) per step
            if track:
                # field change of each step; the net moment is -(v[ix], v[iz]), so the work
                # -M . dB of step k is v[ix] dBx_k + v[iz] dBz_k
                dfield = np.diff(fields, axis=0, prepend=self._b_applied[None, :])
                dbx, dbz = dfield[:, 0].tolist(), dfield[:, 1].tolist()
        ix, iz = self._ix, self._iz
        hold, warned, step1, step2, dot = self.torque_every, self._warning_text, mujoco.mj_step1, \
            mujoco.mj_step2, np.dot
        check_every, nstep = self.check_every, self.nstep
        sd, adr, pen, low = self._sensordata, self._sensor_adr, self._contact, self._min_dist
        adr2, feat, low2 = self._feature_adr, self._feature, self._min_feature
        work = 0.0
        k = 0
        try:
            for k in range(n):
                if hold > 1 and nstep % hold:
                    mujoco.mj_step(m, d)  # couples held from the last update
                elif fields is None:
                    step1(m, d)
                    dot(x, G, out=q)
                    step2(m, d)
                else:
                    step1(m, d)
                    dot(x, gzx, out=v)
                    dot(bs[k], v2, out=q)
                    if track:
                        work += v.item(ix) * dbx[k] + v.item(iz) * dbz[k]
                    step2(m, d)
                nstep += 1
                if warned:  # MuJoCo reported a bad state in this step: stop here
                    break
                if pen and sd[adr] < low:  # the deepest contact so far (of the step's start state)
                    low = self._record_penetration(float(sd[adr]), nstep)
                    if self._pen_hit:
                        break
                if feat and sd[adr2] < low2:
                    low2 = self._record_feature(float(sd[adr2]), nstep)
                    if self._pen_hit:
                        break
                if nstep % check_every == 0:
                    self.nstep = nstep
                    self._stale = True
                    self._check(energy=True, work=float(work), field=None if fields is None else fields[k])
        finally:
            self.nstep = nstep
            self._stale = True
            self._min_dist = min(self._min_dist, low)
            self._min_feature = min(self._min_feature, low2)
            if track:
                self._work += float(work)
            if fields is not None and n > 0:
                self._B3[0], self._B3[2] = fields[min(k, n - 1)]
                self._b_applied = fields[min(k, n - 1)].copy()
                self._set_coefficients()

    # ------------------------------------------------------------------ native stepping
    def _step_native(self, n: int, fields, block: int):
        # MuJoCo applies the couples (the pole actuators): Python only sets the field's inputs when
        # the field changes and reads the checks. Runs of one field go to MuJoCo as blocks of steps
        # (_native_run); a field that changes every step (a sine) takes the per-step loop
        d = self.data
        b0, b1 = self._b0, self._b1
        d.qfrc_applied[:] = 0.0  # Python couples never add to MuJoCo's (static_residual leaves them)
        d.xfrc_applied[b0:b1] = self.external_wrench[self._order] if self._has_external else 0.0
        if fields is None:
            yield from self._native_run(n, block)
            return
        new = np.empty(n, dtype=bool)
        new[:1] = True
        np.any(fields[1:] != fields[:-1], axis=1, out=new[1:])
        starts = np.flatnonzero(new)
        mag, quat = field_controls(fields[starts])
        self._field_k = 0  # index of the field applied last
        try:
            if starts.size == n:
                if self._rollout_ok():  # a field that changes every step, in rollout blocks
                    yield from self._native_run(n, block, fields=fields)
                else:
                    self._native_per_step(fields, mag, quat)
                return
            ends = [*starts[1:].tolist(), n]
            track = self._energy_valid
            for r, (s, e) in enumerate(zip(starts.tolist(), ends, strict=True)):
                self._field_k = s
                f = fields[s]
                self._ctrl.fill(mag[r])
                self._mquat[:] = quat[r]
                self._B3[0], self._B3[2] = f
                db = f - self._b_applied
                if not (yield from self._native_run(e - s, block, dfield=db if track and (db[0] or db[1]) else None)):
                    break
                self._b_applied = f.copy()
        finally:
            self._B3[0], self._B3[2] = fields[self._field_k]
            self._b_applied = fields[self._field_k].copy()
            self._set_coefficients()

    def _rollout_ok(self) -> bool:
        """Whether a field that changes every step may run in ``mujoco.rollout`` blocks: the planar rod,
        whose piece angles are linear in ``qpos`` (the energy balance's net moments then come from the
        recorded states, see :meth:`_angle_map`)."""
        if self._angles is None:
            amap = self._angle_map()
            if amap is None:
                self._angles = False
            else:  # (A^T, phi0, m_x, m_z of the pieces in body-id order), for _field_work
                A, phi0 = amap
                self._angles = (np.ascontiguousarray(A.T), phi0, np.ascontiguousarray(self._m_body[self._order, 0]),
                                np.ascontiguousarray(self._m_body[self._order, 2]))
        return self._angles is not False and self.rollout_blocks

    def _roll_block(self, controls: np.ndarray) -> np.ndarray:
        """Run ``len(controls)`` steps with per-step controls (:data:`NATIVE_CONTROL_SPEC`) in one
        ``mujoco.rollout`` call on this simulator's own data, which ends where as many ``mj_step`` calls
        with the controls set before each would leave it (state, warm start, contact history: tested bit
        for bit); returns the recorded full-physics states after each step, shape ``(k, nstate)``."""
        m, d = self.model, self.data
        k = controls.shape[0]
        if self._roller is None:
            from mujoco import rollout as mjrollout

            self._roller = mjrollout.Rollout(nthread=0)
            self._spec = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
            self._s0 = np.empty((1, mujoco.mj_stateSize(m, self._spec)))
            self._w0 = np.empty((1, m.nv))
            self._bufs = {}
        if k not in self._bufs:
            self._bufs[k] = (np.empty((1, k, self._s0.shape[1])), np.empty((1, k, m.nsensordata)))
        states, sens = self._bufs[k]
        mujoco.mj_getState(m, d, self._s0[0], self._spec)
        self._w0[0] = d.qacc_warmstart
        self._roller.rollout([m], [d], self._s0, np.ascontiguousarray(controls[None]), control_spec=NATIVE_CONTROL_SPEC,
                             skip_checks=True, nstep=k, initial_warmstart=self._w0, state=states, sensordata=sens)
        return states[0]

    def _field_work(self, q0: np.ndarray, states: np.ndarray, fields: np.ndarray, previous: np.ndarray) -> float:
        """The work ``-sum M_j . dB_j`` of a block's field changes: ``M_j`` the net moment at step j's start
        (``qpos`` ``q0``, then the recorded states), ``dB_j`` the change from the field before it."""
        At, phi0, mx, mz = self._angles
        nq = self.model.nq
        q = np.empty((len(fields), nq))
        q[0] = q0
        q[1:] = states[:-1, 1:1 + nq]  # full physics: time, then qpos
        phi = q @ At
        phi += phi0
        c, s_ = np.cos(phi), np.sin(phi)
        mom_x = c @ mx + s_ @ mz
        mom_z = c @ mz - s_ @ mx
        db = np.empty_like(fields)
        db[0] = fields[0] - previous
        np.subtract(fields[1:], fields[:-1], out=db[1:])
        return -float(mom_x @ db[:, 0] + mom_z @ db[:, 1])

    def _native_run(self, count: int, block: int, *, dfield=None, fields=None):
        """``count`` steps at the present inputs, in blocks that end at every energy check and after at
        most ``block`` steps (at most the contact history), each checked step by step from the history.
        ``dfield``: the field change (T) at the first step, whose work ``-M . dB`` is booked with the
        net moment of that step's start (the first block is then that step alone). ``fields``: a field
        per step, shape ``(count, 2)``, applied through ``mujoco.rollout`` blocks (:meth:`_roll_block`),
        their work booked from the recorded states (:meth:`_field_work`). A generator: it
        yields between blocks and returns False when a bound broke or MuJoCo warned (the caller
        stops; :meth:`_check` reports it)."""
        m, d = self.model, self.data
        ce, warned = self.check_every, self._warning_text
        done = 0
        controls = None if fields is None else native_controls(self.rod, fields)
        track = fields is not None and self._energy_valid
        while done < count:
            k = 1 if dfield is not None else min(count - done, ce - self.nstep % ce, block)
            n0, t0 = self.nstep, float(d.time)
            if controls is None:
                mujoco.mj_step(m, d, k)
            else:
                q0 = d.qpos.copy() if track else None
                states = self._roll_block(controls[done:done + k])
                if track:
                    before = self._b_applied
                    self._work += self._field_work(q0, states, fields[done:done + k], before)
                self._field_k = done + k - 1  # the field applied last (_step_native ends at it)
                self._b_applied = fields[done + k - 1].copy()
                self._B3[0], self._B3[2] = fields[done + k - 1]
            self.nstep += k
            self._stale = True
            done += k
            if dfield is not None:  # xmat holds the orientations of the step's start
                mom = self._net_moment()
                self._work -= float(mom[0] * dfield[0] + mom[1] * dfield[1])
                dfield = None
            stop = k
            if warned:  # the steps before the one that warned count, as in a per-step loop
                stop = max(0, self._warned_step() - 1 - n0)
            broke = self._contact and self._scan_contacts(k, stop, n0, t0)
            if broke or warned:
                if fields is not None:  # the field of the step that failed, as a per-step loop ends at it
                    first = min(self._pen_step() if self._pen_hit else math.inf,
                                self._warned_step() if warned else math.inf)
                    self._field_k = int(min(max(first - 1 - self._call_ref[0], 0), count - 1))
                return False
            if self.nstep % ce == 0:
                self._check(energy=True)
            if done < count:
                yield
        return True

    def _scan_contacts(self, k: int, stop: int, n0: int, t0: float) -> bool:
        """Record the deepest contacts of the first ``stop`` of the ``k`` steps just taken (from step
        ``n0`` at time ``t0``); True when one broke a bound (recorded there: a per-step loop stops
        at that step)."""
        if stop <= 0:
            return False
        sd = self._sensordata
        if k == 1:
            floor = np.array([sd[self._sensor_adr]])
            scene = np.array([sd[self._feature_adr]]) if self._feature else None
        elif stop == k and self._hist.values.min() >= self._min_dist and (
                not self._feature or self._hist_feature.values.min() >= self._min_feature):
            return False  # the buffer (this block's steps and older ones) holds no new deepest contact
        else:
            floor = self._hist.last(k)[:stop]
            scene = self._hist_feature.last(k)[:stop] if self._feature else None
        dt = self.timestep
        first = np.flatnonzero(floor < self._floor_limit)
        if scene is not None:
            s_first = np.flatnonzero(scene < self._feature_limit)
            # the scene's bound counts at a step whose floor contact did not already stop the loop
            if s_first.size and (not first.size or s_first[0] < first[0]):
                floor = floor[:s_first[0] + 1]
                scene = scene[:s_first[0] + 1]
                first = np.zeros(0, dtype=int)
            elif first.size:
                scene = scene[:first[0]]
        if first.size:
            floor = floor[:first[0] + 1]
        j = int(np.argmin(floor))
        if floor[j] < self._min_dist:
            self._record_penetration(float(floor[j]), n0 + j + 1, t0 + j * dt)
        if scene is not None and scene.size:
            j = int(np.argmin(scene))
            if scene[j] < self._min_feature:
                self._record_feature(float(scene[j]), n0 + j + 1, t0 + j * dt)
        return bool(self._pen_hit)

    def _native_per_step(self, fields, mag, quat) -> None:
        """A new field every step: set its inputs, one ``mj_step``, the per-step checks (the
        Python path's loop with MuJoCo's couples); ``self._field_k`` ends at the last step's field."""
        m, d = self.model, self.data
        ctrl, mq, step = self._ctrl, self._mquat, mujoco.mj_step
        mags, qw, qy = mag.tolist(), quat[:, 0].tolist(), quat[:, 2].tolist()
        track = self._energy_valid
        if track:  # the work -M . dB of step k, M of its start state (xmat after the step)
            dfield = np.diff(fields, axis=0, prepend=self._b_applied[None, :])
            dbx, dbz = dfield[:, 0].tolist(), dfield[:, 1].tolist()
            x, C, dot = d.xmat[self._b0:self._b1].reshape(-1), self._C, np.dot
            mom = np.empty(2)
        warned, check_every, nstep = self._warning_text, self.check_every, self.nstep
        sd, adr, pen, low = self._sensordata, self._sensor_adr, self._contact, self._min_dist
        adr2, feat, low2 = self._feature_adr, self._feature, self._min_feature
        work = 0.0
        k = 0
        try:
            for k in range(fields.shape[0]):
                ctrl.fill(mags[k])
                mq[0], mq[2] = qw[k], qy[k]
                step(m, d)
                nstep += 1
                if warned:  # MuJoCo reported a bad state in this step: stop here
                    break
                if track:
                    dot(x, C, out=mom)
                    work -= mom.item(0) * dbx[k] + mom.item(1) * dbz[k]
                if pen and sd[adr] < low:  # the deepest contact so far (of the step's start state)
                    low = self._record_penetration(float(sd[adr]), nstep)
                    if self._pen_hit:
                        break
                if feat and sd[adr2] < low2:
                    low2 = self._record_feature(float(sd[adr2]), nstep)
                    if self._pen_hit:
                        break
                if nstep % check_every == 0:
                    self.nstep = nstep
                    self._stale = True
                    self._B3[0], self._B3[2] = fields[k]
                    self._check(energy=True, work=work)
        finally:
            self.nstep = nstep
            self._stale = True
            self._min_dist = min(self._min_dist, low)
            self._min_feature = min(self._min_feature, low2)
            if track:
                self._work += work
            self._field_k = k

    def _sync(self) -> None:
        # after mj_step the position-dependent quantities (xpos, xmat, qM, contacts) belong to
        # the state before the step; readouts recompute them for the current qpos
        if self._stale:
            mujoco.mj_fwdPosition(self.model, self.data)
            self._stale = False

    def _warning_counts(self) -> np.ndarray:
        return self.data.warning.number[WARNING_IDS]

    def _fail(self, quantity: str, value: float, hint: str, *, step: int | None = None) -> None:
        o = self.options
        step = self.nstep if step is None else step
        t = self.time if step == self.nstep else self._call_ref[1] + (step - self._call_ref[0]) * self.timestep
        raise SimulationError(
            f"simulation unstable at step {step} (t = {t:.6g} s): {quantity}"
            f"{'' if math.isnan(value) else f' = {value:.4g}'}. {hint} "
            f"(integrator={o.integrator!r}, timestep={o.timestep:g} s, segments={o.segments}, "
            f"field=({self._B3[0] * 1e3:.4g}, {self._B3[2] * 1e3:.4g}) mT).",
            step=step, time=t, quantity=quantity, value=value,
        )

    def _check(self, *, energy: bool, work: float = 0.0, field=None) -> None:
        d = self.data
        hint = STABILITY_HINT
        what = new_warning(self._warning_counts(), self._warn0)
        # the first cause first: a native block may run on past a broken contact bound into a
        # warning or a non-finite state (a per-step loop stops at the bound)
        if what is not None and not (self._pen_hit and self._pen_step() < self._warned_step()):
            text = f" ({self._warning_text[0].strip()})" if self._warning_text else ""
            self._fail(f"MuJoCo warning: {what}{text}", math.nan, hint, step=self._warned_step())
        if self._pen_hit:
            where, self._pen_hit = self._pen_hit, ""  # reported once; a deeper contact reports again
            self._fail_penetration(where)
        for name in ("qpos", "qvel"):
            arr = getattr(d, name)
            if not math.isfinite(arr.sum()):  # a NaN or an infinity anywhere makes the sum non-finite
                self._fail(f"non-finite {name}", math.nan, hint)
        if energy:
            # the mass matrix of the step's start (mj_step leaves it in qM) is enough for a
            # factor-100 runaway test and saves recomputing the position stage every check
            mv = self._mv
            mujoco.mj_mulM(self.model, d, mv, d.qvel)
            ke = 0.5 * float(d.qvel @ mv)
            if runaway(ke, self._energy_scale):
                self._fail("runaway kinetic energy (J)", ke, runaway_hint(self._energy_scale))
            ratio = ke / self._energy_scale
            if ratio > self._max_ke_ratio:
                self._max_ke_ratio = ratio
            if self._contact:
                if self._sensordata.item(self._sensor_adr) == 0.0:
                    # no floor contact found: the only case a beam can pass below the floor
                    # unseen by the penetration check (the plane collides with anything below it)
                    self._check_tunnelling()
                if self._energy_valid:
                    self._check_energy(ke, work, self._B3[[0, 2]] if field is None else field)

    def _figures(self) -> dict:
        h = self.beam.thickness
        return {"step": int(self.nstep), "time_s": self.time, "max_penetration_m": self.max_penetration,
                "max_penetration_h": self.max_penetration / h, "energy_drift": self.energy_drift}

    def _unphysical(self, cause: str, reason: str, hint: str, figures: dict, value: float, *,
                    at: tuple | None = None) -> None:
        o = self.options
        step, t = (self.nstep, self.time) if at is None else at
        raise UnphysicalError(
            f"unphysical motion at step {step} (t = {t:.6g} s): {reason}. {hint} "
            f"(integrator={o.integrator!r}, timestep={o.timestep:g} s, contact time constant {self._tc * 1e3:.3g} ms, "
            f"segments={o.segments}, field=({self._B3[0] * 1e3:.4g}, {self._B3[2] * 1e3:.4g}) mT).",
            cause=cause, reason=reason, figures={**self._figures(), **figures, "step": step, "time_s": t}, step=step,
            time=t, quantity=cause, value=value,
        )

    def _pen_step(self) -> int:
        # steps done after the step whose start state broke the contact bound (a per-step loop stops there)
        at = self._pen_at if self._pen_hit == "floor" else self._feature_at
        return at[0] + 1

    def _fail_penetration(self, where: str) -> None:
        h = self.beam.thickness
        if where == "floor":
            depth, (step, t), what = -self._min_dist, self._pen_at, "contact penetration into the floor"
        else:
            depth, (step, t) = -self._min_feature, self._feature_at
            what = f"contact penetration into the {self.options.scene}"
        lim = self.penetration_limit + self._overlap0
        start = f" + the {self._overlap0 * 1e3:.3g} mm overlap of the start" if self._overlap0 > 0.0 else ""
        reason = (f"{what} {depth * 1e3:.3g} mm = {depth / h:.3g} h (limit {self.penetration_limit / h:.3g} h{start} "
                  f"= {lim * 1e3:.3g} mm) at step {step} (t = {t:.6g} s)")
        self._unphysical(
            "penetration", reason,
            "The contact is not resolved: use a smaller timestep or a gentler field "
            "(Simulator(penetration_limit=...) moves the bound)",
            {"penetration_m": depth, "penetration_h": depth / h}, depth,
            at=None if step + 1 == self.nstep else (step + 1, t + self.timestep),
        )

    def _check_tunnelling(self) -> None:
        # the centreline (stale: the step's start, as the contact sensor) against the floor z = 0
        d = self.data
        b = self._tip_body
        zmin = d.xpos[self._b0:self._b1, 2].min()
        if zmin > self._dist_limit + self._tip_len:  # the tip (ds/2 past the last hinge) cannot be lower
            return
        zmin = min(float(zmin), d.xpos.item(b, 2) + self._tip_len * d.xmat.item(b, 6))
        if zmin < self._dist_limit:
            h = self.beam.thickness
            reason = (f"tunnelling: the centreline is {-zmin * 1e3:.3g} mm = {-zmin / h:.3g} h below the floor "
                      f"(limit {self.penetration_limit / h:.3g} h)")
            self._unphysical("tunnelling", reason, "The contact is not resolved: use a smaller timestep",
                             {"floor_depth_m": -zmin, "floor_depth_h": -zmin / h}, -zmin)

    def _check_energy(self, kinetic: float, work: float, field) -> None:
        # E - E_0 - W <= 0 for a passive rod in a field that did work W on it (damping and
        # contact only dissipate); anything above is energy the numerics made
        excess = self._energy(field, staggered=True, kinetic=kinetic) - self._e0 - (self._work + work)
        drift = excess / self._energy_scale
        if drift > self._drift:
            self._drift = drift
        if drift > ENERGY_DRIFT_LIMIT:
            mg = float(self._mass_g.sum())
            lift = excess / (mg * self.beam.length) if mg > 0 else math.inf
            reason = (f"launch: the rod gained {excess:.3g} J more than the field supplied ({drift:.3g} of the "
                      f"energy scale {self._energy_scale:.3g} J, limit {ENERGY_DRIFT_LIMIT:g}; enough to lift it "
                      f"{lift:.3g} beam lengths)")
            self._unphysical("launch", reason, STABILITY_HINT, {"energy_created_J": excess}, excess)

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
        ts, fs, xs, zs, tips = [], [], [], [], []

        def record():
            x, z = self.centerline()
            ts.append(self.time)
            fs.append(self._B3[[0, 2]].copy())
            xs.append(x)
            zs.append(z)
            tips.append(self.tip_angle())

        record()
        done = 0
        while done < nsteps:
            k = min(record_every, nsteps - done)
            self.step(k)
            done += k
            record()
        return Trajectory(np.array(ts), np.array(fs), np.array(xs), np.array(zs), np.array(tips))

    # ------------------------------------------------------------------ statics
    def static_residual(self) -> float:
        """``max_j |Q_j| / k_j`` (rad) at the current configuration and zero velocity, where Q
        is the net generalized force on the hinges (springs, gravity, magnetic couples)."""
        m, d = self.model, self.data
        qvel = d.qvel.copy()
        self._has_external = bool(np.any(self.external_wrench))
        d.qvel[:] = 0.0
        mujoco.mj_kinematics(m, d)
        if self._native:  # the actuators' forces are part of qfrc_smooth
            d.qfrc_applied[:] = 0.0
            b0, b1 = self._b0, self._b1
            d.xfrc_applied[b0:b1] = self.external_wrench[self._order] if self._has_external else 0.0
        else:
            self._apply_torques()
        mujoco.mj_forward(m, d)
        self._stale = False
        q = d.qfrc_smooth[self._hinge_dof] + d.qfrc_constraint[self._hinge_dof]
        d.qvel[:] = qvel
        mujoco.mj_forward(m, d)
        return float(np.max(np.abs(q) / self._k))

    def settle(
        self, *, tol: float = 1e-7, max_time: float = 20.0, speed_tol: float | None = None,
        settle_damping: float = 0.05,
    ) -> SettleResult:
        """Settle to static equilibrium by damped dynamics at the current (constant) field.

        Hinge damping is raised to ``settle_damping * k_j`` (a Kelvin-Voigt time in s) while
        settling and restored after. Converged when, at a check, the static residual
        (:meth:`static_residual`, rad) is below ``tol`` and the largest hinge speed is below
        ``speed_tol`` (rad/s; default ``tol / settle_damping``).

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
        damp0 = m.dof_damping[self._hinge_dof].copy()
        m.dof_damping[self._hinge_dof] = settle_damping * self._k
        if self._waveform is not None:
            self._waveform = None  # hold the present field
        steps, chunk = 0, 20
        res, speed = math.inf, math.inf
        try:
            while steps < nmax:
                self.step(chunk)
                steps += chunk
                speed = float(np.max(np.abs(self.data.qvel[self._hinge_dof])))
                if speed < speed_tol:
                    res = self.static_residual()
                    if res < tol:
                        return SettleResult(True, steps, res, speed, "converged")
            res = self.static_residual()
        finally:
            m.dof_damping[self._hinge_dof] = damp0
        return SettleResult(
            False, steps, res, speed,
            f"not settled in {max_time:g} s: residual {res:.3g} rad (tol {tol:g}), speed {speed:.3g} rad/s",
        )

    # ------------------------------------------------------------------ readouts
    def centerline(self) -> tuple[np.ndarray, np.ndarray]:
        """Centerline points (m): the base end (s = 0), every hinge, the tip; shape ``(N + 2,)``.

        Hinge ``j`` sits at ``s = (j + 1/2) L / N``.
        """
        self._sync()
        d = self.data
        p = d.xpos[self._bodies]
        tipmat = d.xmat[self._bodies[-1]]
        tip = p[-1] + self._tip_len * tipmat[[0, 3, 6]]
        x = np.concatenate([p[:, 0], [tip[0]]])
        z = np.concatenate([p[:, 2], [tip[2]]])
        return x, z

    def tip_position(self) -> tuple[float, float]:
        """Tip point (x, z) (m): the last :meth:`centerline` point, without building the rest."""
        self._sync()
        b = self._bodies[-1]
        p, r = self.data.xpos[b], self.data.xmat[b]
        return float(p[0] + self._tip_len * r[0]), float(p[2] + self._tip_len * r[6])

    def center_of_mass(self) -> np.ndarray:
        """Centre of mass (x, z) of the rod (m), shape ``(2,)``, of the current state."""
        self._sync()
        m, ids, p = self.rod.disc.mass, self.rod.body_ids, self.data.xipos
        return np.array([m @ p[ids, 0], m @ p[ids, 2]]) / m.sum()

    def arc_length(self) -> np.ndarray:
        """Reference arc length (m) of the :meth:`centerline` points, shape ``(N + 2,)``."""
        disc = self.rod.disc
        return np.concatenate([[0.0], disc.hinge_s, [disc.length]])

    def angles(self) -> np.ndarray:
        """Tangent angle of every piece from +x toward +z (rad), shape ``(N + 1,)``."""
        self._sync()
        R = self.data.xmat[self._bodies]
        return np.arctan2(R[:, 6], R[:, 0])  # world z and x of the body x axis

    def tip_angle(self) -> float:
        """Tangent angle of the tip piece (rad), continuous beyond +-pi (sum of joint angles)."""
        base = self.options.clamp_angle
        if self.rod.base_qpos.size:
            base += float(self.data.qpos[self.rod.base_qpos[2]])
        return base + float(np.sum(self.data.qpos[self._hinge_qpos[self.options.base_piece:]]))

    def contacts(self) -> list[dict]:
        """Active contacts: geom names, position (m), penetration depth (m, >= 0 when touching)."""
        self._sync()
        m, d = self.model, self.data
        out = []
        for c in d.contact[: d.ncon]:
            out.append({
                "geom1": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, c.geom1),
                "geom2": mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, c.geom2),
                "pos": np.array(c.pos), "penetration": float(-c.dist),
            })
        return out

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

        Gravity is measured from z = 0; magnetic energy is ``-sum (R m) . B``.
        """
        self._sync()
        d = self.data
        q = d.qpos[self._hinge_qpos]
        elastic = 0.5 * float(np.sum(self._k * q**2))
        zc = d.xipos[self._bodies, 2]
        grav = float(np.sum(self.rod.disc.mass * zc)) * self.options.gravity
        mag = magnetics.energy(magnetics.world_moments(d.xmat[self._bodies], self._m_body), self._B3)
        kin = self.kinetic_energy()
        return {"kinetic": kin, "elastic": elastic, "gravity": grav, "magnetic": mag,
                "total": kin + elastic + grav + mag}

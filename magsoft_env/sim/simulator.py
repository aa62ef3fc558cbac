"""The rod simulator: field, stepping, waveforms, settling, readouts and stability checks."""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..spec import Beam, Field, as_field
from ..spec.field import MAX_FIELD
from ..validate import finite_number, positive
from . import magnetics
from .health import (
    ENERGY_DRIFT_LIMIT,
    PENETRATION_LIMIT,
    STABILITY_HINT,
    WARNING_IDS,
    SimulationError,
    UnphysicalError,
    check_steps,
    new_warning,
    runaway,
    runaway_hint,
)
from .model import RodModel, RodOptions, build_model, contact_timeconst
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

    Each step the couple ``tau_i = (R_i m_i) x B`` (N m) on every rigid piece goes into
    ``data.qfrc_applied`` as its generalized force (the planar rod's angular Jacobian about y
    is a constant 0 / +-1 map), computed from the piece orientations of the current state (via
    ``mj_step1`` / ``mj_step2``; RK4 uses ``mj_step`` and the previous step's orientations).
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
        every step). A speed shortcut whose error docs/sim.md measures.
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
        self.rod: RodModel = build_model(beam, options)
        self.model = self.rod.model
        self.data = mujoco.MjData(self.model)
        self.check_every = int(check_every)
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
        self._warning_text.clear()
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
        bx, bz = self._B3[0], self._B3[2]
        np.multiply(self._gz, bx, out=self._G)
        np.multiply(self._gx, bz, out=self._gtmp)
        self._G -= self._gtmp

    def _apply_torques(self, field=None) -> None:
        d = self.data
        if field is not None:
            self._B3[0], self._B3[2] = field
            self._set_coefficients()
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
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer number of steps, got {n!r}.")
        n = check_steps("n", int(n), "Call step() repeatedly for a longer run.")
        d = self.data
        two = self._two_stage
        self._has_external = bool(np.any(self.external_wrench))
        fields = None
        if self._waveform is not None:  # all fields of this call in one vectorized sample
            t = d.time - self._wf_t0 + self.timestep * np.arange(n)
            fields = self._waveform.sample(t)
        self._begin_balance(fields)
        # MuJoCo's own warning text is captured (not printed or logged to MUJOCO_LOG.TXT);
        # _check turns the warning counters into a SimulationError
        prev = mujoco.get_mju_user_warning()
        warned = self._warning_text
        mujoco.set_mju_user_warning(warned.append)
        try:
            if self._has_external or not two:
                self._step_general(n, fields, two)
            else:
                self._step_fast(n, fields)
        finally:
            mujoco.set_mju_user_warning(prev)
            if self._contact:
                self._state_key = d.qpos.tobytes() + d.qvel.tobytes()
        self._check(energy=False)

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

    def _record_penetration(self, dist: float, nstep: int) -> float:
        # a new deepest floor contact: ``dist`` (m, < 0) of the state the step started from
        self._min_dist = dist
        self._pen_at = (nstep - 1, float(self.data.time) - self.timestep)
        if dist < self._floor_limit:
            self._pen_hit = "floor"
        return dist

    def _record_feature(self, dist: float, nstep: int) -> float:
        self._min_feature = dist
        self._feature_at = (nstep - 1, float(self.data.time) - self.timestep)
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

    def _sync(self) -> None:
        # after mj_step the position-dependent quantities (xpos, xmat, qM, contacts) belong to
        # the state before the step; readouts recompute them for the current qpos
        if self._stale:
            mujoco.mj_fwdPosition(self.model, self.data)
            self._stale = False

    def _warning_counts(self) -> np.ndarray:
        return self.data.warning.number[WARNING_IDS]

    def _fail(self, quantity: str, value: float, hint: str) -> None:
        o = self.options
        raise SimulationError(
            f"simulation unstable at step {self.nstep} (t = {self.time:.6g} s): {quantity}"
            f"{'' if math.isnan(value) else f' = {value:.4g}'}. {hint} "
            f"(integrator={o.integrator!r}, timestep={o.timestep:g} s, segments={o.segments}, "
            f"field=({self._B3[0] * 1e3:.4g}, {self._B3[2] * 1e3:.4g}) mT).",
            step=self.nstep, time=self.time, quantity=quantity, value=value,
        )

    def _check(self, *, energy: bool, work: float = 0.0, field=None) -> None:
        d = self.data
        hint = STABILITY_HINT
        what = new_warning(self._warning_counts(), self._warn0)
        if what is not None:
            text = f" ({self._warning_text[0].strip()})" if self._warning_text else ""
            self._fail(f"MuJoCo warning: {what}{text}", math.nan, hint)
        for name in ("qpos", "qvel"):
            arr = getattr(d, name)
            if not math.isfinite(arr.sum()):  # a NaN or an infinity anywhere makes the sum non-finite
                self._fail(f"non-finite {name}", math.nan, hint)
        if self._pen_hit:
            where, self._pen_hit = self._pen_hit, ""  # reported once; a deeper contact reports again
            self._fail_penetration(where)
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

    def _unphysical(self, cause: str, reason: str, hint: str, figures: dict, value: float) -> None:
        o = self.options
        raise UnphysicalError(
            f"unphysical motion at step {self.nstep} (t = {self.time:.6g} s): {reason}. {hint} "
            f"(integrator={o.integrator!r}, timestep={o.timestep:g} s, contact time constant {self._tc * 1e3:.3g} ms, "
            f"segments={o.segments}, field=({self._B3[0] * 1e3:.4g}, {self._B3[2] * 1e3:.4g}) mT).",
            cause=cause, reason=reason, figures={**self._figures(), **figures}, step=self.nstep, time=self.time,
            quantity=cause, value=value,
        )

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

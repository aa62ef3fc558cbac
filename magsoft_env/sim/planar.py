"""The planar rod backend: the hinge chain in the x-z plane, its field inputs and its physical readouts.

A rod backend (:class:`~magsoft_env.sim.backend.RodBackend`) is what :class:`~magsoft_env.sim.Simulator` steps.
This one builds the MuJoCo hinge chain of a beam in a scene (:func:`~magsoft_env.sim.model.build_model`), turns an
applied field into the model's inputs (once, or one row per step for ``mujoco.rollout``), runs blocks of steps
inside MuJoCo (:class:`~magsoft_env.sim.stepping.NativeSteps`), and reads physical quantities off a ``mjData``
(pose, centreline, centre of mass, angles, energies, the net magnetic moment the energy balance needs).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..spec import Beam, Field
from ..spec.field import planar_field
from . import magnetics
from .backend import Pose
from .discretize import PLANAR_ROD
from .health import MAX_STEPS
from .histories import PointsHistory, SensorHistory
from .model import (
    CONTACT_HISTORY,
    CONTACT_SENSOR,
    FEATURE_SENSOR,
    NATIVE_CONTROL_SPEC,
    NODE_SENSOR,
    SCENES,
    RodModel,
    RodOptions,
    build_model,
    contact_timeconst,
    field_control,
    native_controls,
)
from .readouts import ChainOrientation
from .stepping import NativeSteps, PythonSteps


class PlanarRod:
    """A beam as a planar hinge chain (:func:`~magsoft_env.sim.model.build_model`) with native magnetics: a
    :class:`~magsoft_env.sim.backend.RodBackend`.

    The pieces are numbered base half-cell first, tip last; the MuJoCo bodies of the pieces have
    consecutive ids (rows ``b0:b1`` of ``xmat``, ``xpos``, ``xfrc_applied``), in :attr:`order`.

    Parameters
    ----------
    beam : Beam
    options : RodOptions
        ``magnetics`` must be ``"native"``: the couples are MuJoCo's own forces (magnetic poles), so
        every block of steps runs inside MuJoCo.
    """

    #: The registry name (``RodOptions.rod``).
    name = "planar"
    #: What messages call this rod.
    label = PLANAR_ROD
    #: It takes fields in its plane: (B_x, B_z).
    field_axes = (0, 2)
    scenes = SCENES
    #: Frames show it from the side (:class:`~magsoft_env.render.RodRenderer`), or in 3D from its pose.
    views = ("side", "perspective", "top")
    #: :func:`~magsoft_env.sim.mujoco_equilibrium`'s defaults: a 10 ms settling step (the ``discrete`` integrator
    #: is stable there) and a residual of 1e-8 rad.
    static_timestep = 1e-2
    static_tol = 1e-8
    #: ``mujoco.rollout`` control spec of :meth:`controls` rows.
    control_spec = NATIVE_CONTROL_SPEC
    #: Its model is :func:`~magsoft_env.sim.model.build_model`'s hinge chain.
    builds_chain = True

    # ------------------------------------------------------------------ what it takes (before building)
    @classmethod
    def check_options(cls, options: RodOptions) -> None:
        """Every :class:`~magsoft_env.sim.model.RodOptions` is the hinge chain's: nothing to refuse."""

    @classmethod
    def check_beam(cls, beam: Beam, what: str | None = None) -> None:
        """A ValueError for a magnetization or field component out of the x-z plane."""
        beam.require_planar(what or PLANAR_ROD)

    @staticmethod
    def check_field(field: Field) -> None:
        """A planar rod takes fields in its plane (B_y = 0)."""
        planar_field(field, PLANAR_ROD)

    @staticmethod
    def check_fields(samples: np.ndarray, source) -> None:
        """A ValueError for per-step fields ``(n, 3)`` with a y component."""
        by = np.abs(samples[:, 1])
        if np.any(by > 0.0) or not np.all(np.isfinite(by)):
            raise ValueError(
                f"the {PLANAR_ROD} takes fields in the x-z plane, but the waveform {type(source).__name__} has a y "
                f"component (|B_y| up to {float(np.nanmax(by)) * 1e3:.4g} mT). Use the 3D rod, "
                "RodOptions(rod='cable') (on the command line --rod cable), or a waveform in the x-z plane (e.g. "
                "Rotating about axis=(0, 1, 0)).")

    @classmethod
    def gait_options(cls, robot, *, scene: str, segments: int, timestep: float, own_numerics: bool) -> dict:
        """The chain's own keywords of a robot's :class:`~magsoft_env.sim.RodOptions` on the floor: capsule
        colliders, the robot's numerics."""
        from ..cases.gaits import GAIT_CONTACT_GEOM

        cls.check_beam(robot.beam, f"robot {robot.name!r} on {PLANAR_ROD} (gaits, floor environments)")
        return {"segments": segments, "timestep": timestep, "contact_geom": GAIT_CONTACT_GEOM}

    def __init__(self, beam: Beam, options: RodOptions):
        if options.magnetics != "native":
            raise ValueError(
                "the Simulator applies the magnetic couples as MuJoCo forces: RodOptions.magnetics must be "
                f"'native', got {options.magnetics!r} (build_model(beam, RodOptions(magnetics='python')) gives "
                "a model without them, for couples of your own).")
        rod: RodModel = build_model(beam, options)
        self.rod = rod
        self.model = rod.model
        self.beam = beam
        self.options = options
        disc = rod.disc
        self.disc = disc
        self.bodies = rod.body_ids
        self.npieces = len(self.bodies)
        #: body-frame magnetic moments of the pieces (A m^2), shape (N + 1, 3)
        self.m_body = magnetics.body_moments_3d(disc.moment)
        #: hinge stiffnesses (N m / rad) and their dof / qpos addresses
        self.stiffness = disc.stiffness
        self.hinge_dof = rod.hinge_dof
        self.hinge_qpos = rod.hinge_qpos
        self.tip_len = float(disc.piece_length[-1])
        self.two_stage = self.model.opt.integrator != mujoco.mjtIntegrator.mjINT_RK4
        self.order = np.argsort(self.bodies)
        self.b0, self.b1 = int(self.bodies.min()), int(self.bodies.max()) + 1
        if self.b1 - self.b0 != len(self.bodies):
            raise RuntimeError("rod bodies must have consecutive ids")  # guaranteed by build_model
        self.has_contact = options.has_contact
        #: the longest native block: the contact history (every step of a block is checked from it)
        self.block_limit = CONTACT_HISTORY if self.has_contact else MAX_STEPS
        self._steps = NativeSteps(self.model, NATIVE_CONTROL_SPEC, self.controls)
        #: a non-uniform field source (:meth:`set_source`), its per-step stepping, the external wrench (body-id
        #: order) its loads are written with, and the net moment (world x, z; A m^2) of the state they were written at
        self._source = None
        self._python: PythonSteps | None = None
        self._external: np.ndarray | None = None
        self.moment = np.zeros(2)
        self._m_ids = np.ascontiguousarray(self.m_body[self.order])
        self._half_ids = np.ascontiguousarray(0.5 * disc.piece_length[self.order])
        self.has_feature = rod.feature_sensor >= 0
        self.contact_adr = max(rod.contact_sensor, 0)
        self.feature_adr = max(rod.feature_sensor, 0)
        mx, mz = self.m_body[self.order, 0], self.m_body[self.order, 2]
        # (R m)_x and (R m)_z of the pieces are xmat rows @ these columns: the net moment is one product
        c = np.zeros((len(self.bodies), 9, 2))
        c[:, 0, 0], c[:, 2, 0], c[:, 6, 1], c[:, 8, 1] = mx, mz, mx, mz
        self._moment_map = np.ascontiguousarray(c.reshape(-1, 2))
        self._mx, self._mz = np.ascontiguousarray(mx), np.ascontiguousarray(mz)
        self._mass_g = disc.mass * options.gravity
        self._mass_g_ids = np.ascontiguousarray(self._mass_g[self.order])
        self.weight = float(self._mass_g.sum())
        self._hq, self._hd, self._hinge_k = self._hinge_blocks()
        self._angles = self._angle_map()
        self._scale_terms = self._energy_terms()
        #: the values :meth:`set_material_scale` scales from (kept at its first call)
        self._material_base: dict | None = None

    # ------------------------------------------------------------------ model pieces
    def contact_histories(self, data: mujoco.MjData) -> tuple[SensorHistory | None, SensorHistory | None]:
        """Readers of the floor and scene contact sensors' history buffers (None where a scene has none)."""
        if not self.has_contact:
            return None, None
        sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, CONTACT_SENSOR)
        floor = SensorHistory(self.model, sid, data.history)
        scene = None
        if self.has_feature:
            sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, FEATURE_SENSOR)
            scene = SensorHistory(self.model, sid, data.history)
        return floor, scene

    def contact_data(self, data: mujoco.MjData) -> np.ndarray:
        """The array :attr:`contact_adr` / :attr:`feature_adr` index: MuJoCo's ``sensordata``."""
        return data.sensordata

    def centreline_history(self, data: mujoco.MjData) -> PointsHistory:
        """Reader of the centreline at every step of the last block: the contact scenes' ``framepos`` sensors
        (:data:`~magsoft_env.sim.model.NODE_SENSOR`) and their history buffers."""
        return PointsHistory(self.model, data, NODE_SENSOR)

    def _hinge_blocks(self):
        # the hinges' qpos / dof addresses as slices where they form one block (they do: the base joints
        # first, then the hinges), with the stiffnesses in that order: views, not gathers
        hq, hd = np.asarray(self.hinge_qpos), np.asarray(self.hinge_dof)
        if (np.array_equal(np.sort(hq), np.arange(hq.min(), hq.min() + hq.size))
                and np.array_equal(hd - hd.min(), hq - hq.min())):
            q0, d0 = int(hq.min()), int(hd.min())
            k = np.zeros(hq.size)
            k[hq - hq.min()] = self.stiffness
            return slice(q0, q0 + hq.size), slice(d0, d0 + hd.size), k
        return hq, hd, np.asarray(self.stiffness, dtype=float)

    def _angle_map(self):
        """``(A^T, phi0)`` with the pieces' rotation angles about y (body-id order) ``= qpos @ A^T + phi0``: every
        rotation of the chain is about y (hinges and body frames about +-y, slides otherwise), so ``R_y(phi)``
        is each piece's ``xmat`` to round-off (tested) and the net moment of a recorded ``qpos`` needs no
        MuJoCo kinematics."""
        m = self.model
        A = np.zeros((m.nbody, m.nq))
        phi0 = np.zeros(m.nbody)
        for b in range(1, m.nbody):
            w, x, y, z = m.body_quat[b]
            if x != 0.0 or z != 0.0:
                raise RuntimeError("the planar rod's bodies turn about y only")  # guaranteed by build_model
            parent = m.body_parentid[b]
            A[b], phi0[b] = A[parent], phi0[parent] + 2.0 * math.atan2(y, w)
            for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
                if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE:
                    A[b, m.jnt_qposadr[j]] += m.jnt_axis[j][1]
        ids = np.arange(self.b0, self.b1)
        return np.ascontiguousarray(A[ids].T), phi0[ids]

    # ------------------------------------------------------------------ field inputs
    def write_field(self, data: mujoco.MjData, field3: np.ndarray) -> None:
        """Write the inputs of a held field ``(B_x, B_y, B_z)`` (T): every pole actuator's control ``|B|``
        and the field frame's orientation (bit-identical to :meth:`controls` rows)."""
        mag, w, y = field_control(float(field3[0]), float(field3[2]))
        data.ctrl.fill(mag)
        mq = data.mocap_quat[self.rod.field_mocap]
        mq[0], mq[1], mq[2], mq[3] = w, 0.0, y, 0.0
        self._steps.written(field3)
        if self._source is not None:
            self._write_source(data)

    # ------------------------------------------------------------------ a non-uniform field source
    def set_source(self, data: mujoco.MjData, source) -> None:
        """Apply a non-uniform field source (:class:`~magsoft_env.sim.sources.SourceField`; None: none) from now on:
        its loads go into ``xfrc_applied`` before every step (:meth:`write_field`), so blocks run one step at a time
        from Python (:class:`~magsoft_env.sim.stepping.PythonSteps`); the uniform field stays native."""
        self._source = source
        if source is None:
            data.xfrc_applied[self.b0:self.b1] = 0.0 if self._external is None else self._external
            return
        if self._python is None:
            self._python = PythonSteps(self.model, self, records=False)

    def _source_state(self, data: mujoco.MjData):
        """``(p, m, B, G)`` of the pieces (body-id order) at the positions in ``xpos`` / ``xmat``: magnetic centres
        (the pieces' midpoints, m), world moments (A m^2) and the source's field and gradient there, one call."""
        b0, b1 = self.b0, self.b1
        R = data.xmat[b0:b1]  # rows: R00 R01 R02 R10 ... R22
        m = np.zeros((b1 - b0, 3))  # R (m_x, 0, m_z): the body moments lie in the x-z plane, every R turns about y
        m[:, 0] = R[:, 0] * self._mx + R[:, 2] * self._mz
        m[:, 2] = R[:, 6] * self._mx + R[:, 8] * self._mz
        # a body's frame starts at its piece's first point, x along the piece: the midpoint is half a piece along x
        p = data.xpos[b0:b1] + self._half_ids[:, None] * R[:, 0::3]
        B, G = self._source(p, float(data.time))
        return p, m, B, G

    def _write_source(self, data: mujoco.MjData) -> None:
        """The source's loads of the state in ``qpos`` into ``xfrc_applied`` (with the external wrench), and its net
        moment into :attr:`moment`.

        In the x-z plane the chain takes the forces' x and z components and the couples' y component; the rest
        (a force along y, couples about x and z, from a source's out-of-plane field or gradient) is carried by its
        joints (hinges about y, slides in x and z), which it would not move anyway. MuJoCo applies an
        ``xfrc_applied`` force at the body's centre of mass (``xipos``), not at the magnetic centre ``p``: the
        moment arm ``(p - xipos) x f`` is added to the couple (its y component)."""
        # after mj_step, xpos / xmat are those of the step's start: the state in qpos needs its own kinematics
        mujoco.mj_kinematics(self.model, data)
        p, m, B, G = self._source_state(data)
        mx, mz = m[:, 0], m[:, 2]
        # in the plane (m_y = 0): f = G^T m has f_x = G_xx m_x + G_zx m_z, f_z = G_xz m_x + G_zz m_z; (m x B)_y
        fx = G[:, 0, 0] * mx + G[:, 2, 0] * mz
        fz = G[:, 0, 2] * mx + G[:, 2, 2] * mz
        r = p - data.xipos[self.b0:self.b1]
        xf = data.xfrc_applied[self.b0:self.b1]
        xf[:] = 0.0 if self._external is None else self._external
        xf[:, 0] += fx
        xf[:, 2] += fz
        xf[:, 4] += mz * B[:, 0] - mx * B[:, 2] + r[:, 2] * fx - r[:, 0] * fz
        self.moment[0] = m[:, 0].sum()
        self.moment[1] = m[:, 2].sum()

    def _source_energy(self, data: mujoco.MjData) -> float:
        """``-sum m . B(p)`` (J) of the source at the positions in ``xpos`` / ``xmat`` (in the plane: x and z)."""
        _, m, B, _ = self._source_state(data)
        return -float(np.sum(m[:, 0] * B[:, 0] + m[:, 2] * B[:, 2]))

    def source_field(self, data: mujoco.MjData) -> np.ndarray:
        """The source's field (T) at the pieces' midpoints, piece order, ``(N + 1, 3)`` (zeros without a source)."""
        out = np.zeros((self.npieces, 3))
        if self._source is not None:
            out[self.order] = self._source_state(data)[2]
        return out

    def controls(self, fields: np.ndarray) -> np.ndarray:
        """Per-step inputs of the fields ``(k, 3)`` (B_x, B_y, B_z; T; B_y unused), rows for ``mujoco.rollout``
        with :attr:`control_spec`."""
        return native_controls(self.rod, fields[:, [0, 2]])

    def advance(self, data: mujoco.MjData, field3: np.ndarray, fields: np.ndarray | None, k: int, health) -> None:
        """``k`` steps inside MuJoCo: ``mj_step(m, d, k)`` under a held field, one ``mujoco.rollout`` under
        per-step ``fields`` ``(k, 3)`` (T) (:class:`~magsoft_env.sim.stepping.NativeSteps`); with a source
        (:meth:`set_source`), one step at a time with its loads written before each
        (:class:`~magsoft_env.sim.stepping.PythonSteps`)."""
        (self._steps if self._source is None else self._python).advance(data, field3, fields, k, health)

    def settle_damping(self, retardation: float) -> tuple[np.ndarray, np.ndarray]:
        """``(hinge dofs, retardation * k_j)``: Kelvin-Voigt hinges with the retardation time ``retardation`` (s)."""
        return self.hinge_dof, retardation * self.stiffness

    def settle_speed(self, data: mujoco.MjData) -> float:
        """The largest hinge angular speed (rad/s)."""
        return float(np.max(np.abs(data.qvel[self.hinge_dof])))

    def reset_noise(self, rng: np.random.Generator, scale: float) -> np.ndarray:
        """``qpos0`` with every hinge angle perturbed by ``U(-scale, scale)`` (rad)."""
        q = self.model.qpos0.copy()
        q[self.hinge_qpos] += rng.uniform(-scale, scale, len(self.hinge_qpos))
        return q

    def set_material_scale(self, modulus: float, magnetization: float) -> None:
        """Scale the material from the values the chain was built with (factors checked by the
        :class:`~magsoft_env.sim.Simulator`): what :func:`~magsoft_env.sim.model.build_model` gives the beam with
        ``E0 * modulus`` and ``particle_magnetization * magnetization``.

        The modulus scales the hinge stiffnesses (``jnt_stiffness``, :attr:`stiffness`), their Kelvin-Voigt damping
        (``dof_damping = retardation_time * k``) and a contact time constant taken from the material
        (``contact_timeconst="material"``: ``geom_solref``, ``pair_solref`` by ``1 / sqrt(modulus)``); the
        magnetization the pieces' moments (:attr:`m_body` and the columns made of it) and the pole charges
        (``actuator_gainprm``). The poles' positions do not depend on either factor."""
        base = self._material_base
        if base is None:
            m = self.model
            jnt = m.dof_jntid[self.hinge_dof]
            tc = contact_timeconst(self.beam, self.options) if self.options.has_contact else math.nan
            contact = isinstance(self.options.contact_timeconst, str) and self.options.has_contact
            base = self._material_base = {
                "jnt": jnt, "k": m.jnt_stiffness[jnt].copy(), "c": m.dof_damping[self.hinge_dof].copy(),
                "gain": m.actuator_gainprm[:, 0].copy(), "stiffness": self.stiffness.copy(),
                "hinge_k": self._hinge_k.copy(), "moment": self.disc.moment.copy(), "m_body": self.m_body.copy(),
                "m_ids": self._m_ids.copy(), "map": self._moment_map.copy(), "mx": self._mx.copy(),
                "mz": self._mz.copy(), "charge": self.rod.pole_charge.copy(),
                "geoms": np.flatnonzero(m.geom_solref[:, 0] == tc) if contact else np.zeros(0, dtype=int),
                "pairs": np.flatnonzero(m.pair_solref[:, 0] == tc) if contact else np.zeros(0, dtype=int),
                "tc": tc}
        m = self.model
        m.jnt_stiffness[base["jnt"]] = base["k"] * modulus
        m.dof_damping[self.hinge_dof] = base["c"] * modulus
        m.actuator_gainprm[:, 0] = base["gain"] * magnetization
        if base["geoms"].size or base["pairs"].size:
            tc = base["tc"] / math.sqrt(modulus) if modulus != 1.0 else base["tc"]
            m.geom_solref[base["geoms"], 0] = tc
            m.pair_solref[base["pairs"], 0] = tc
        # in place: the discretization, the stiffness and the moment columns are shared with readouts and energies
        self.stiffness[:] = base["stiffness"] * modulus
        if self.disc.stiffness is not self.stiffness:
            self.disc.stiffness[:] = base["stiffness"] * modulus
        self._hinge_k[:] = base["hinge_k"] * modulus
        for name, attr in (("moment", None), ("m_body", "m_body"), ("m_ids", "_m_ids"), ("map", "_moment_map"),
                           ("mx", "_mx"), ("mz", "_mz"), ("charge", None)):
            target = (self.disc.moment if name == "moment" else self.rod.pole_charge if name == "charge"
                      else getattr(self, attr))
            target[...] = base[name] * magnetization
        self._scale_terms = self._energy_terms()

    def apply_external(self, data: mujoco.MjData, wrench: np.ndarray | None) -> None:
        """Write a constant world-frame wrench per piece ``(N + 1, 6)`` (force at the piece's centre of mass,
        then couple), or none, into ``xfrc_applied``; clear ``qfrc_applied`` (the couples are actuator forces)."""
        data.qfrc_applied[:] = 0.0
        data.xfrc_applied[self.b0:self.b1] = 0.0 if wrench is None else wrench[self.order]
        self._external = None if wrench is None else np.array(wrench[self.order], dtype=float)

    # ------------------------------------------------------------------ energies
    def net_moment(self, data: mujoco.MjData) -> np.ndarray:
        """Net magnetic moment ``sum R_i m_i`` (world x, z; A m^2) of the orientations in ``xmat``."""
        return data.xmat[self.b0:self.b1].reshape(-1) @ self._moment_map

    def net_moments(self, qpos: np.ndarray) -> np.ndarray:
        """Net magnetic moments (world x, z) of recorded positions ``qpos`` ``(k, nq)``, shape ``(k, 2)``."""
        phi = qpos @ self._angles[0]
        phi += self._angles[1]
        c, s = np.cos(phi), np.sin(phi)
        out = np.empty((qpos.shape[0], 2))
        out[:, 0] = c @ self._mx + s @ self._mz
        out[:, 1] = c @ self._mz - s @ self._mx
        return out

    def energy(self, data: mujoco.MjData, field, *, kinetic: float, staggered: bool) -> float:
        """Kinetic (given) + elastic + gravitational + magnetic energy (J) under ``field`` (B_x, B_y, B_z).

        ``staggered``: the positions in ``xmat`` / ``xipos`` are those of the step's start (after
        ``mj_step``), paired with the new velocity, the pair symplectic Euler keeps; the hinge angles are
        then ``qpos - dt qvel`` (exact for the Euler-type integrators)."""
        q = data.qpos[self._hq]
        q = q - self.model.opt.timestep * data.qvel[self._hd] if staggered else q
        mom = self.net_moment(data)
        e = (kinetic + 0.5 * float(self._hinge_k @ (q * q))
             + float(self._mass_g_ids @ data.xipos[self.b0:self.b1, 2])
             - float(mom[0] * field[0] + mom[1] * field[2]))
        if self._source is not None:
            e += self._source_energy(data)
        return e

    def _energy_terms(self) -> tuple[float, float]:
        """``(slope, rest)`` of :meth:`energy_scale`."""
        m_tot = float(self.disc.mass.sum())
        mags = float(np.linalg.norm(self.m_body, axis=1).sum())
        elastic = 0.5 * float(np.sum(self.stiffness)) * math.pi**2
        return 2.0 * mags, 2.0 * m_tot * self.options.gravity * self.beam.length + elastic

    def energy_scale(self, bmax: float) -> float:
        """Energy scale (J) of the rod in fields up to ``bmax`` (T): twice the largest magnetic energy and
        potential energy of lifting the rod its length, plus the elastic energy of a half-turn bend."""
        slope, rest = self._scale_terms
        return slope * bmax + rest

    def energies(self, data: mujoco.MjData, field3: np.ndarray, kinetic: float) -> dict[str, float]:
        """Kinetic, elastic, gravitational (from z = 0), magnetic (``-sum (R m) . B``, with a source's ``B`` at each
        piece added) and total energy (J)."""
        q = data.qpos[self.hinge_qpos]
        elastic = 0.5 * float(np.sum(self.stiffness * q**2))
        grav = float(np.sum(self.disc.mass * data.xipos[self.bodies, 2])) * self.options.gravity
        mag = magnetics.energy(magnetics.world_moments(data.xmat[self.bodies], self.m_body), field3)
        if self._source is not None:
            mag += self._source_energy(data)
        return {"kinetic": kinetic, "elastic": elastic, "gravity": grav, "magnetic": mag,
                "total": kinetic + elastic + grav + mag}

    # ------------------------------------------------------------------ readouts (of a synchronized mjData)
    def centerline(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray]:
        """Centreline points (x, z) (m): the base end, every hinge, the tip; shape ``(N + 2,)`` each."""
        p = data.xpos[self.bodies]
        tipmat = data.xmat[self.bodies[-1]]
        tip = p[-1] + self.tip_len * tipmat[[0, 3, 6]]
        return np.concatenate([p[:, 0], [tip[0]]]), np.concatenate([p[:, 2], [tip[2]]])

    def tip_position(self, data: mujoco.MjData) -> tuple[float, float]:
        """Tip point (x, z) (m)."""
        b = self.bodies[-1]
        p, r = data.xpos[b], data.xmat[b]
        return float(p[0] + self.tip_len * r[0]), float(p[2] + self.tip_len * r[6])

    def lowest_point(self, data: mujoco.MjData, below: float) -> float:
        """Lowest centreline height (m) if it may lie below ``below`` (m), else a value above ``below``."""
        zmin = data.xpos[self.b0:self.b1, 2].min()
        if zmin > below + self.tip_len:  # the tip (ds/2 past the last hinge) cannot be lower
            return float(zmin)
        b = int(self.bodies[-1])
        return min(float(zmin), data.xpos.item(b, 2) + self.tip_len * data.xmat.item(b, 6))

    def center_of_mass(self, data: mujoco.MjData) -> np.ndarray:
        """Centre of mass (x, z) (m), shape ``(2,)``."""
        m, p = self.disc.mass, data.xipos[self.bodies]
        return np.array([m @ p[:, 0], m @ p[:, 2]]) / m.sum()

    def arc_length(self) -> np.ndarray:
        """Reference arc length (m) of the centreline points, shape ``(N + 2,)``."""
        return np.concatenate([[0.0], self.disc.hinge_s, [self.disc.length]])

    def angles(self, data: mujoco.MjData) -> np.ndarray:
        """Tangent angle of every piece from +x toward +z (rad), shape ``(N + 1,)``."""
        R = data.xmat[self.bodies]
        return np.arctan2(R[:, 6], R[:, 0])

    def tip_angle(self, data: mujoco.MjData) -> float:
        """Tangent angle of the tip piece (rad), continuous beyond +-pi (the sum of joint angles)."""
        base = self.options.clamp_angle
        if self.rod.base_qpos.size:
            base += float(data.qpos[self.rod.base_qpos[2]])
        return base + float(np.sum(data.qpos[self.hinge_qpos[self.options.base_piece:]]))

    def magnetic_couples(self, data: mujoco.MjData, field3: np.ndarray) -> np.ndarray:
        """Couples ``(R m) x B`` on the pieces, world frame, shape ``(N + 1, 3)`` (N m); with a source, its couples
        ``m x B(p)`` added (the y component, the one the chain takes)."""
        out = magnetics.couples(magnetics.world_moments(data.xmat[self.bodies], self.m_body), field3)
        if self._source is not None:
            _, m, B, _ = self._source_state(data)
            out[self.order, 1] += m[:, 2] * B[:, 0] - m[:, 0] * B[:, 2]
        return out

    def pose(self, data: mujoco.MjData) -> Pose:
        """The :class:`~magsoft_env.sim.backend.Pose`: the chain's points and link frames (y = 0, widths +y)."""
        p = data.xpos[self.bodies]
        R = data.xmat[self.bodies]
        tip = p[-1] + self.tip_len * R[-1, [0, 3, 6]]
        m, c = self.disc.mass, data.xipos[self.bodies]
        com = np.array([m @ c[:, 0], m @ c[:, 1], m @ c[:, 2]]) / m.sum()  # center_of_mass's sums, bit for bit
        return Pose(time=float(data.time), com=com, centreline=np.concatenate([p, tip[None]]),
                    tangents=R[:, [0, 3, 6]], widths=R[:, [1, 4, 7]], lengths=np.diff(self.arc_length()),
                    tip_angle=self.tip_angle(data))

    def orientation_tracker(self) -> ChainOrientation:
        """The chain's orientation needs no history: its tip angle counts whole turns."""
        return ChainOrientation()

    def tip_twist(self, data: mujoco.MjData) -> float:
        """A hinge chain in a plane cannot twist: 0."""
        return 0.0

    def angular_velocities(self, data: mujoco.MjData) -> np.ndarray:
        """Angular velocity of every piece about -y (rad/s), the rate of :meth:`angles`, shape ``(N + 1,)``."""
        mujoco.mj_comVel(self.model, data)
        return -data.cvel[self.bodies, 1].copy()

    def integrity(self, data: mujoco.MjData) -> None:
        """Rigid pieces on joints: nothing of the rod's own can break (None)."""
        return None


__all__ = ["PlanarRod"]

"""Build the planar MuJoCo rod (a hinge chain, midpoint layout) and its scene with ``mujoco.MjSpec``.

World frame = the project frame: x along the undeformed beam from the clamp, z up, y the
width axis. Every hinge turns about ``-y`` so that a positive joint angle turns +x toward
+z: the tangent angle of link ``i`` is ``theta_i = clamp_angle + sum_{j <= i} q_j``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..rods import check_rod
from ..spec import Beam
from ..validate import choice, finite_number, integer, nonnegative, positive
from .discretize import RodDiscretization, discretize

SCENES = ("cantilever", "floor", "channel", "obstacle")

INTEGRATORS = {
    "discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
    "euler": mujoco.mjtIntegrator.mjINT_EULER,
    "implicitfast": mujoco.mjtIntegrator.mjINT_IMPLICITFAST,
    "implicit": mujoco.mjtIntegrator.mjINT_IMPLICIT,
    "rk4": mujoco.mjtIntegrator.mjINT_RK4,
}

#: Paper Fig. 5a channel (hollow box), inner length x width x height (m).
CHANNEL_SIZE = (42e-3, 8.5e-3, 7.6e-3)
#: Paper Fig. 5b obstacle block, length x width x height (m).
OBSTACLE_SIZE = (7e-3, 5.5e-3, 2e-3)
_WALL = 1e-3  # channel wall thickness (m)
_HINGE_AXIS = (0.0, -1.0, 0.0)
_ROD_CONTYPE, _ROD_CONAFFINITY = 1, 2  # rod pieces touch the scene, never each other
_SCENE_CONTYPE, _SCENE_CONAFFINITY = 2, 1
BASES = ("first", "middle")
CONTACT_GEOMS = ("capsule", "sphere", "hinge_sphere")
CONES = {"pyramidal": mujoco.mjtCone.mjCONE_PYRAMIDAL, "elliptic": mujoco.mjtCone.mjCONE_ELLIPTIC}
#: Default cell grading of the cantilever (last / first cell length).
DEFAULT_CANTILEVER_GRADING = 1.5
#: Default timestep of every scene (s).
DEFAULT_TIMESTEP = 1e-3
#: Range of ``RodOptions.segments``.
MAX_SEGMENTS = 1000
#: Largest ``RodOptions.timestep`` (s).
MAX_TIMESTEP = 0.1
#: Smallest ``RodOptions.timestep`` (s): a finer step needs over a million steps per simulated second (the
#: finest step of the convergence studies, docs/convergence.md, is 12.5 us).
MIN_TIMESTEP = 1e-6
#: Largest ``|RodOptions.feature_x|`` (m): the scene feature within a metre of the clamp, as every beam is
#: (:data:`magsoft_env.spec.beam.MAX_SIZE`); further is a unit mistake (mm given as m).
MAX_FEATURE_X = 1.0
#: Largest ``RodOptions.gravity`` (m/s^2), about 100 g.
MAX_GRAVITY = 1000.0
#: Largest ``RodOptions.solver_iterations`` and ``noslip_iterations`` (per step).
MAX_SOLVER_ITERATIONS = 10_000
#: Names of the contact sensors of the contact scenes (MuJoCo ``contact`` sensors, ``reduce="mindist"``):
#: the signed distance (m) of the deepest rod contact with the floor, and (channel, obstacle) with
#: anything in the scene; negative when penetrating, 0 without contact.
CONTACT_SENSOR = "rod_floor_depth"
FEATURE_SENSOR = "rod_scene_depth"
#: Contact scenes: the ``framepos`` sensors of the centreline points (base end, every hinge, tip; the points
#: of ``Simulator.centerline``), named this prefix + index, each with a history of :data:`CONTACT_HISTORY`
#: samples: a native block of steps leaves every step's centreline there, so that an environment holds
#: its crawl limits (clearance, height, rotation) at every step (``envs.crawl``). The tip point is a
#: site of the same name on the last piece.
NODE_SENSOR = "rod_node"
#: The rods built in (``RodOptions.rod``): the planar hinge chain, the 3D flexcomp strip
#: (:mod:`~magsoft_env.sim.cable`); :func:`~magsoft_env.sim.backend.rod_names` lists every registered one.
RODS = ("planar", "cable")
#: How the magnetic couples reach MuJoCo (``RodOptions.magnetics``).
MAGNETICS = ("native", "python")
#: Native magnetics: the world-fixed frame of the field (a mocap body and its site), whose x axis the
#: simulator turns along the field each step; every pole actuator pushes along it.
FIELD_FRAME = "field_frame"
#: Native magnetics: the inputs a step reads, as a ``mujoco.mjtState`` spec: the actuator controls (every one
#: ``|B|``, T) and the mocap quaternion of :data:`FIELD_FRAME` (the field's direction). The control vectors of
#: ``mujoco.rollout`` and ``mujoco.batch`` rollouts with this spec come from :func:`native_controls`.
NATIVE_CONTROL_SPEC = int(mujoco.mjtState.mjSTATE_CTRL) | int(mujoco.mjtState.mjSTATE_MOCAP_QUAT)
#: Native magnetics, contact scenes: samples of each contact sensor kept in MuJoCo's history buffer (steps).
#: The simulator steps a held field in blocks of at most this many steps inside MuJoCo and reads the block's
#: deepest contact from the buffer afterwards, so the penetration check still sees every step. 100: an env
#: step of 100 substeps is one block (25 cost the env 10 % of its steps/s in Python between blocks).
CONTACT_HISTORY = 100
#: Default contact ``solref`` time constant of the contact scenes (s): twice the default
#: timestep, the stiffest contact a 1 ms step resolves (MuJoCo's ``refsafe`` rule), fixed so
#: that smaller timesteps converge to the same contact model (docs/sim.md).
DEFAULT_CONTACT_TIMECONST = 2e-3


@dataclass(frozen=True)
class RodOptions:
    """How to build the rod and its scene.

    Parameters
    ----------
    segments : int
        Number of cells N (hinges), in [2, 1000].
    scene : {"cantilever", "floor", "channel", "obstacle"}
        ``cantilever``: base clamped to the world at ``clamp_angle``, no contact.
        ``floor``: free beam on a plane (planar base joint: slide x, slide z, hinge y).
        ``channel``: floor plus the paper's hollow box (42 x 8.5 x 7.6 mm inside), entrance at
        ``feature_x``. ``obstacle``: floor plus a 7 x 5.5 x 2 mm block whose left face is at
        ``feature_x``.
    integrator : {"discrete", "euler", "implicitfast", "implicit", "rk4"}
        MuJoCo integrator. ``discrete`` folds hinge stiffness and damping into the implicit
        solve; under the others the hinge springs are explicit (see docs/sim.md for the
        measured stable timesteps).
    timestep : float or None
        Simulation step (s), in [1e-6, 0.1]. ``None``: 1 ms for every scene (docs/sim.md has the
        measured errors of each step).
    gravity : float
        Gravitational acceleration along -z (m/s^2), in [0, 1000]; 0 turns gravity off.
    clamp_angle : float
        Cantilever clamp angle from +x toward +z (rad); for floor scenes the initial angle.
    retardation_time : float
        Kelvin-Voigt retardation time (s): hinge damping ``c_j = retardation_time * k_j``.
    friction : float
        Sliding friction coefficient between rod and scene (floor scenes).
    contact_timeconst : float, "material" or None
        Contact ``solref`` time constant (s). ``None`` (default): 2 ms, a soft contact that
        the default 1 ms step resolves (``2 x timestep``), fixed, so the same contact model is
        simulated at every timestep and a finer step converges to it. ``"material"``: the
        beam's own through-thickness time ``h sqrt(rho / E)`` (about 0.14 ms for the paper's
        1.13 mm phi = 0.2 beam; :func:`material_contact_timeconst`), a much stiffer contact
        that needs dt <= 0.1 ms and crawls differently (docs/sim.md, "contact").
    contact_refsafe : bool
        Keep MuJoCo's ``refsafe`` (which raises every contact time constant to at least
        ``2 * timestep``, so the contact softens as the step grows). Off by default: the
        contact time constant is then the one asked for at every timestep.
    contact_dampratio : float
        Contact ``solref`` damping ratio.
    feature_x : float or None
        x (m) of the channel entrance or the obstacle's left face, in [-1, 1]; ``None``: ``L + 5 mm``.
    render : bool
        Add box visual geoms, a light and a camera (only for rendering).
    grading : float or None
        Last cell length / first cell length, in [0.1, 10]; 1 gives equal cells, > 1 finer
        cells at the clamp (more accurate cantilevers in strong fields, see docs/sim.md).
        ``None`` (default): 1.5 for the cantilever (the largest grading that improves every
        static cross-check but one, measured in docs/sim.md), 1 (equal cells) for the contact
        scenes.
    base : {"middle", "first"}
        Floor scenes: which piece carries the planar base joint (the root of the kinematic
        tree). ``middle`` (default) is the least biased with soft contact (docs/sim.md, "symmetry");
        ``first`` is the base half-cell. The cantilever always clamps the first piece.
    contact_geom : {"capsule", "sphere"}
        Collision shape of the rod. ``capsule``: one capsule per piece (two contacts per piece
        lying flat). ``sphere``: a sphere of radius h/2 at each centerline point (base end,
        every hinge, tip), one contact each lying flat: about half the contact rows. Spheres
        leave gaps of ``ds - h`` between them; use capsules for sharp obstacles.
    cone : {"pyramidal", "elliptic"}
        Friction cone (MuJoCo ``opt.cone``).
    noslip_iterations : int
        MuJoCo no-slip solver iterations (0: off), in [0, 10000].
    solver_iterations : int
        Main constraint-solver iterations (MuJoCo ``opt.iterations``), in [1, 10000].
    solver_tolerance : float
        Main constraint-solver tolerance (MuJoCo ``opt.tolerance``), >= 0.
    contact_impedance : (float, float) or None
        Contact ``solimp`` (d_min, d_max), each in (0, 1); ``None``: MuJoCo's (0.9, 0.95).
    contact_pairs : bool
        Contact scenes: list every rod collider x scene geom as an explicit MuJoCo contact
        ``pair`` and switch the broad phase off (``contype = conaffinity = 0`` on every geom):
        the same contacts, found in less than half the time (docs/sim.md). ``False``: the
        ``contype`` / ``conaffinity`` filter (rod 1/2, scene 2/1), for a spec extended with
        more geoms (:func:`build_spec`) that should touch the rod.
    magnetics : {"native", "python"}
        How the magnetic couples ``(R m) x B`` reach MuJoCo. ``native`` (default): as MuJoCo's own
        forces, exact at every state (docs/sim.md, "Native magnetic forces"): each couple is the
        couple of point forces ``c_k B`` at body-fixed poles (:func:`~magsoft_env.sim.magnetics.magnetic_poles`),
        one site actuator per pole pushing along a world frame that the simulator turns along the
        field (``ctrl = |B|``, mocap quaternion = the field's direction). A held field then runs
        whole blocks of steps in C (``mj_step(m, d, n)``), and ``mujoco.rollout`` / ``mujoco.batch``
        run the rod with no Python between steps (:data:`NATIVE_CONTROL_SPEC`, :func:`native_controls`).
        ``python``: the simulator computes the couples each step from the piece orientations and
        writes them into ``qfrc_applied`` (the model has no actuators).

        .. versionadded:: 0.4
    rod : str
        The rod backend, by its registered name (:mod:`magsoft_env.rods`; the backend checks the rest of the
        options it cannot build). ``planar`` (default): the hinge chain in the x-z plane (everything above
        applies). ``cable``: the 3D rod, a MuJoCo 1D flexcomp strip with a box section
        (:func:`~magsoft_env.sim.cable.build_cable`), built from ``segments``, ``scene`` (``cantilever`` or
        ``floor``), ``integrator`` (``discrete``, ``euler`` or ``rk4``), ``timestep``, ``gravity``, ``grading``,
        ``retardation_time`` (MuJoCo's rod damping), ``friction`` and the solver settings, ``clamp_angle`` 0; an
        axial magnetization's couples are MuJoCo's own forces (``magnetics="native"``), any other's are written
        from Python each step (and every one with ``magnetics="python"``). Statics:
        :func:`~magsoft_env.sim.mujoco_equilibrium` with ``rod="cable"``; the
        :class:`~magsoft_env.sim.Simulator` steps it clamped or on the floor
        (:class:`~magsoft_env.sim.cable.CableRod`).
    """

    segments: int = 20
    scene: str = "cantilever"
    integrator: str = "discrete"
    timestep: float | None = None
    gravity: float = 9.81
    clamp_angle: float = 0.0
    retardation_time: float = 5e-3
    friction: float = 0.5
    contact_timeconst: float | str | None = None
    contact_dampratio: float = 1.0
    contact_refsafe: bool = False
    feature_x: float | None = None
    render: bool = False
    grading: float | None = None
    base: str = "middle"
    contact_geom: str = "sphere"
    cone: str = "elliptic"
    noslip_iterations: int = 0
    solver_iterations: int = 100
    solver_tolerance: float = 1e-8
    contact_impedance: tuple | None = None
    contact_pairs: bool = True
    magnetics: str = "native"
    rod: str = "planar"

    def __post_init__(self):
        # every field checked for its type and documented range, nothing built yet
        object.__setattr__(self, "segments", integer("RodOptions.segments", self.segments, 2, MAX_SEGMENTS))
        choice("RodOptions.scene", self.scene, SCENES)
        choice("RodOptions.integrator", self.integrator, INTEGRATORS)
        if self.timestep is None:
            object.__setattr__(self, "timestep", DEFAULT_TIMESTEP)
        dt = positive("RodOptions.timestep", self.timestep, unit="s")
        if not MIN_TIMESTEP <= dt <= MAX_TIMESTEP:
            raise ValueError(f"RodOptions.timestep must lie in [{MIN_TIMESTEP:g}, {MAX_TIMESTEP:g}] s, got "
                             f"{self.timestep!r} (seconds: 0.1 ms is 0.0001).")
        g = nonnegative("RodOptions.gravity", self.gravity, unit="m/s^2")
        if g > MAX_GRAVITY:
            raise ValueError(f"RodOptions.gravity must lie in [0, {MAX_GRAVITY:g}] m/s^2, got {self.gravity!r}.")
        finite_number("RodOptions.clamp_angle", self.clamp_angle, unit="rad")
        nonnegative("RodOptions.retardation_time", self.retardation_time, unit="s")
        nonnegative("RodOptions.friction", self.friction)
        for name in ("contact_refsafe", "render", "contact_pairs"):
            v = getattr(self, name)
            if not isinstance(v, (bool, np.bool_)):
                raise ValueError(f"RodOptions.{name} must be a bool, got {v!r}.")
        tc = self.contact_timeconst
        if isinstance(tc, str) and tc != "material":
            raise ValueError(
                f"RodOptions.contact_timeconst must be a time constant > 0 (s), 'material' or None, got {tc!r}."
            )
        if tc is not None and not isinstance(tc, str):
            positive("RodOptions.contact_timeconst", tc, unit="s")
        positive("RodOptions.contact_dampratio", self.contact_dampratio)
        if self.feature_x is not None:
            fx = finite_number("RodOptions.feature_x", self.feature_x, unit="m")
            if abs(fx) > MAX_FEATURE_X:
                raise ValueError(f"RodOptions.feature_x must lie in [-{MAX_FEATURE_X:g}, {MAX_FEATURE_X:g}] m, got "
                                 f"{self.feature_x!r} (metres: 20 mm is 0.02).")
        if self.grading is None:
            object.__setattr__(self, "grading", DEFAULT_CANTILEVER_GRADING if self.scene == "cantilever" else 1.0)
        g = finite_number("RodOptions.grading", self.grading)
        if not 0.1 <= g <= 10.0:
            raise ValueError(f"RodOptions.grading must lie in [0.1, 10], got {self.grading!r}.")
        choice("RodOptions.base", self.base, BASES)
        choice("RodOptions.contact_geom", self.contact_geom, CONTACT_GEOMS)
        choice("RodOptions.cone", self.cone, CONES)
        choice("RodOptions.magnetics", self.magnetics, MAGNETICS)
        from .backend import rod_class

        check_rod(self.rod, "RodOptions.rod")
        rod_class(self.rod).check_options(self)  # what this rod cannot build (scenes, integrators, clamp)
        # bounded: with tolerance 0 MuJoCo runs every iteration of every step
        for name, lo in (("noslip_iterations", 0), ("solver_iterations", 1)):
            object.__setattr__(self, name, integer(f"RodOptions.{name}", getattr(self, name), lo,
                                                   MAX_SOLVER_ITERATIONS))
        nonnegative("RodOptions.solver_tolerance", self.solver_tolerance)
        if self.contact_impedance is not None:
            imp = self.contact_impedance
            if (not isinstance(imp, (tuple, list)) or len(imp) != 2
                    or not all(isinstance(v, (int, float, np.floating)) and not isinstance(v, (bool, np.bool_))
                               and 0.0 < v < 1.0 for v in imp) or imp[0] > imp[1]):
                raise ValueError(
                    "RodOptions.contact_impedance must be (d_min, d_max) with 0 < d_min <= d_max < 1, "
                    f"got {imp!r}."
                )
            object.__setattr__(self, "contact_impedance", (float(imp[0]), float(imp[1])))

    @property
    def has_contact(self) -> bool:
        return self.scene != "cantilever"

    @property
    def base_piece(self) -> int:
        """Index of the piece that carries the base (clamp or planar base joint)."""
        return self.segments // 2 if self.has_contact and self.base == "middle" else 0


@dataclass(frozen=True)
class RodModel:
    """A compiled rod: the MuJoCo model plus the indices the simulator needs.

    Attributes
    ----------
    model : mujoco.MjModel
    beam : Beam
    options : RodOptions
    disc : RodDiscretization
        Per-piece mass, stiffness and magnetic moment.
    body_ids : ndarray, shape (N + 1,)
        MuJoCo body id of each piece (base half-cell first, tip last).
    hinge_qpos : ndarray, shape (N,)
        qpos address of each bending hinge.
    hinge_dof : ndarray, shape (N,)
        dof address of each bending hinge.
    base_qpos : ndarray, shape (3,) or (0,)
        qpos addresses of the planar base joints (slide x, slide z, hinge) in floor scenes;
        they move the left end of the base piece ``options.base_piece``.
    contact_sensor : int
        Contact scenes: ``sensordata`` address of the signed distance (m, negative = penetration;
        0 without contact) of the deepest rod contact with the floor (:data:`CONTACT_SENSOR`); -1
        in the cantilever.
    feature_sensor : int
        Channel and obstacle scenes: the same for the deepest rod contact with anything
        (:data:`FEATURE_SENSOR`); -1 otherwise.
    pole_piece, pole_pos, pole_charge : ndarray, shapes (P,), (P, 2), (P,)
        Native magnetics: the piece of each pole, its position (x, z) in that piece's frame (m)
        and its charge (A m); pole ``k`` is actuator ``k`` (force ``pole_charge[k] * B``). Empty
        for ``magnetics="python"``.
    field_mocap : int
        Native magnetics: the mocap index of :data:`FIELD_FRAME`; -1 for ``magnetics="python"``.
    """

    model: mujoco.MjModel
    beam: Beam
    options: RodOptions
    disc: RodDiscretization
    body_ids: np.ndarray
    hinge_qpos: np.ndarray
    hinge_dof: np.ndarray
    base_qpos: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    contact_sensor: int = -1
    feature_sensor: int = -1
    pole_piece: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))
    pole_pos: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    pole_charge: np.ndarray = field(default_factory=lambda: np.zeros(0))
    field_mocap: int = -1

    @property
    def native(self) -> bool:
        """Whether MuJoCo applies the magnetic couples itself (``RodOptions.magnetics == "native"``)."""
        return self.field_mocap >= 0


def material_contact_timeconst(beam: Beam) -> float:
    """The beam's through-thickness time ``h sqrt(rho / E)`` (s), smallest along the beam.

    The time a compression wave takes to cross the thickness ``h``: a contact stiffness per
    cell of about ``E w ds / h`` on a cell mass ``rho w h ds`` has this time constant, so it is
    the default contact ``solref`` time constant of floor scenes.
    """
    # the profiles' range probe (257 points plus both sides of every breakpoint), computed here
    # rather than through a private Beam helper, so that this figure does not move with it
    L = beam.length
    bps = np.asarray(beam.breakpoints(), dtype=float)
    s = np.unique(np.concatenate([np.linspace(0.0, L, 257), bps - 1e-9 * L, bps + 1e-9 * L]).clip(0.0, L))
    rho = beam.mass_per_length(s) / beam.area
    return float(np.min(beam.thickness * np.sqrt(rho / beam.youngs_modulus(s))))


def contact_timeconst(beam: Beam, options: RodOptions) -> float:
    """The contact ``solref`` time constant (s) that ``options`` gives ``beam``."""
    tc = options.contact_timeconst
    if tc is None:
        return DEFAULT_CONTACT_TIMECONST
    if isinstance(tc, str):
        return material_contact_timeconst(beam)
    return float(tc)


def _quat_y(theta: float) -> list[float]:
    """Quaternion turning +x toward +z by ``theta`` (rad): a rotation about -y."""
    return [math.cos(theta / 2), 0.0, -math.sin(theta / 2), 0.0]


@dataclass(frozen=True)
class _Contact:
    """The rod-scene contact parameters, one definition for the geoms and the explicit pairs."""

    friction: float
    solref: tuple[float, float]
    solimp: tuple[float, ...] | None  # None: MuJoCo's default

    @classmethod
    def of(cls, o: RodOptions, tc: float) -> _Contact:
        imp = o.contact_impedance
        return cls(float(o.friction), (tc, o.contact_dampratio),
                   None if imp is None else (imp[0], imp[1], 0.001, 0.5, 2.0))

    def set_geom(self, g) -> None:
        g.friction = [self.friction, 0.005, 0.0001]
        g.solref = list(self.solref)
        if self.solimp is not None:
            g.solimp = list(self.solimp)

    def add_pair(self, spec, g1, g2) -> None:
        pair = spec.add_pair(geomname1=g1.name, geomname2=g2.name)
        pair.condim = 3
        pair.friction = [self.friction, self.friction, 0.005, 0.0001, 0.0001]
        pair.solref = list(self.solref)
        pair.solimp = list(g2.solimp)  # the rod geom's: this one's, or MuJoCo's default


def _set_options(spec, o: RodOptions) -> None:
    spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
    spec.option.timestep = o.timestep
    spec.option.integrator = INTEGRATORS[o.integrator]
    spec.option.gravity = [0.0, 0.0, -o.gravity]
    if o.gravity == 0.0:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_GRAVITY
    if not o.has_contact:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    # never silently reset on a bad state: the simulator reports it instead
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
    # one kinematic tree: island discovery finds one island and costs ~10 % of a floor step;
    # the sparse constraint Jacobian (rows reach only the dofs between a contact and the root)
    # is cheaper than dense at 23 dofs. Both measured, neither changes the result (docs/sim.md)
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    spec.option.jacobian = mujoco.mjtJacobian.mjJAC_SPARSE
    if o.has_contact and not o.contact_refsafe:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_REFSAFE
    spec.option.cone = CONES[o.cone]
    spec.option.noslip_iterations = int(o.noslip_iterations)
    spec.option.iterations = int(o.solver_iterations)
    spec.option.tolerance = float(o.solver_tolerance)


def _add_piece(parent, i: int, pos, disc: RodDiscretization, beam: Beam, o: RodOptions, collider, quat=None):
    """Rigid piece ``i`` (mass, inertia; its colliders through ``collider``; a box to draw when rendering)."""
    body = parent.add_body(name=f"piece{i}", pos=pos)
    if quat is not None:
        body.quat = quat
    body.explicitinertial = True
    body.mass = float(disc.mass[i])
    body.ipos = [float(disc.com[i]), 0.0, 0.0]
    body.inertia = [float(v) for v in disc.inertia[i]]
    length = float(disc.piece_length[i])
    radius = 0.5 * beam.thickness
    if not o.has_contact:
        pass  # the cantilever: no colliders at all, MuJoCo would pose them every step
    elif o.contact_geom == "sphere":
        # one sphere at the middle of each piece, owned by that piece: a contact below a
        # hinge would move with whichever piece owns it, a chirality that drifts
        # mirror-symmetric robots (measured: docs/sim.md)
        collider(body.add_geom(name=f"sphere{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0],
                               pos=[0.5 * length, 0, 0]))
    elif o.contact_geom == "hinge_sphere":
        ends = [0.0, length] if i == o.segments else [0.0]
        for k, x in enumerate(ends):
            collider(body.add_geom(name=f"sphere{i}" + ("_tip" if k else ""), type=mujoco.mjtGeom.mjGEOM_SPHERE,
                                   size=[radius, 0, 0], pos=[x, 0, 0]))
    else:
        collider(body.add_geom(name=f"capsule{i}", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[radius, 0, 0],
                               fromto=[0, 0, 0, length, 0, 0]))
    if o.render:
        v = body.add_geom(name=f"box{i}", type=mujoco.mjtGeom.mjGEOM_BOX,
                          size=[0.5 * length, 0.5 * beam.width, 0.5 * beam.thickness], pos=[0.5 * length, 0, 0],
                          rgba=[0.35, 0.35, 0.4, 1])
        v.contype = v.conaffinity = 0
        v.group = 1
    return body


def _add_rod(spec, disc: RodDiscretization, beam: Beam, o: RodOptions, collider) -> None:
    """The pieces and hinges: the base piece on the world (welded at ``clamp_angle``, or on a planar base
    joint), the pieces right of it hanging from their left ends, those left of it from their right ends."""

    def add_hinge(body, j, pos, axis):
        # hinge j joins pieces j and j + 1; its angle is theta_{j+1} - theta_j either way round
        k = float(disc.stiffness[j])
        body.add_joint(name=f"hinge{j}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=axis, pos=pos,
                       stiffness=[k, 0.0, 0.0], damping=[o.retardation_time * k, 0.0, 0.0])

    world = spec.worldbody
    b = o.base_piece
    if o.scene == "cantilever":
        base = _add_piece(world, 0, [0.0, 0.0, 0.0], disc, beam, o, collider, _quat_y(o.clamp_angle))
    else:
        # the base piece's left end starts where arc length s_b lies on the straight beam
        s_b = float(np.sum(disc.piece_length[:b]))
        ca, sa = math.cos(o.clamp_angle), math.sin(o.clamp_angle)
        base = _add_piece(world, b, [s_b * ca, 0.0, 0.5 * beam.thickness + s_b * sa], disc, beam, o, collider,
                          _quat_y(o.clamp_angle))
        base.add_joint(name="base_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
        base.add_joint(name="base_z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
        # the base hinge turns about the base piece's centre: with the middle piece the tree is
        # then mirror-symmetric about the beam's midpoint
        base.add_joint(name="base_theta", type=mujoco.mjtJoint.mjJNT_HINGE, axis=list(_HINGE_AXIS),
                       pos=[0.5 * float(disc.piece_length[b]), 0.0, 0.0])
    parent = base
    for i in range(b - 1, -1, -1):  # pieces left of the base, children toward s = 0
        length = float(disc.piece_length[i])
        body = _add_piece(parent, i, [-length, 0.0, 0.0], disc, beam, o, collider)
        add_hinge(body, i, [length, 0.0, 0.0], [-a for a in _HINGE_AXIS])
        parent = body
    parent = base
    for i in range(b + 1, o.segments + 1):
        body = _add_piece(parent, i, [float(disc.piece_length[i - 1]), 0.0, 0.0], disc, beam, o, collider)
        add_hinge(body, i - 1, [0.0, 0.0, 0.0], list(_HINGE_AXIS))
        parent = body


def _add_contact_sensors(spec, o: RodOptions) -> None:
    # the deepest rod contact each step, computed by MuJoCo in the position stage (cheap; read by the
    # simulator's penetration check, changes nothing in the dynamics)
    for name, ref in ((CONTACT_SENSOR, "floor"), (FEATURE_SENSOR, None)):
        if ref is None and o.scene == "floor":
            continue
        sensor = spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_CONTACT,
                                 objtype=mujoco.mjtObj.mjOBJ_XBODY, objname=f"piece{o.base_piece}")
        if ref is not None:
            sensor.reftype, sensor.refname = mujoco.mjtObj.mjOBJ_GEOM, ref
        sensor.intprm = [1 << int(mujoco.mjtConDataField.mjCONDATA_DIST), 1, 1]  # dist; mindist; 1 contact
        if o.magnetics == "native":
            # a history buffer (read only by the simulator, no delay): a block of steps run inside
            # MuJoCo leaves every step's deepest contact there
            sensor.nsample = CONTACT_HISTORY


def build_spec(beam: Beam, options: RodOptions) -> tuple[mujoco.MjSpec, RodDiscretization]:
    """The scene as an editable ``mujoco.MjSpec`` (see :func:`build_model`)."""
    if not isinstance(options, RodOptions):
        raise ValueError(f"options must be a RodOptions, got {type(options).__name__}.")
    from .backend import rod_class

    if not getattr(rod_class(options.rod), "builds_chain", False):
        raise ValueError(f"build_spec / build_model build the planar hinge chain, not RodOptions.rod={options.rod!r} "
                         "(the 3D rod is magsoft_env.sim.cable.build_cable).")
    disc = discretize(beam, options.segments, grading=options.grading)
    o = options
    spec = mujoco.MjSpec()
    spec.modelname = f"magsoft_rod_{o.scene}_{o.segments}"
    _set_options(spec, o)
    contact = _Contact.of(o, contact_timeconst(beam, o))
    scene_geoms = _add_scene(spec, beam, o, contact) if o.has_contact else []
    rod_geoms = []

    def collider(g):
        g.contype, g.conaffinity = _ROD_CONTYPE, _ROD_CONAFFINITY
        contact.set_geom(g)
        g.group = 3
        rod_geoms.append(g)

    _add_rod(spec, disc, beam, o, collider)
    if o.magnetics == "native":
        _add_poles(spec, disc, o)
    if o.has_contact and o.contact_pairs:
        # explicit pairs: no broad phase (it cost more than the narrow phase of these pairs)
        for sg in scene_geoms:
            for rg in rod_geoms:
                contact.add_pair(spec, sg, rg)
        for g in (*scene_geoms, *rod_geoms):
            g.contype = g.conaffinity = 0
    if o.has_contact:
        _add_contact_sensors(spec, o)
        _add_node_sensors(spec, disc, o)
    if o.render:
        world = spec.worldbody
        world.add_light(name="light", pos=[0.5 * beam.length, -0.1, 0.1], dir=[0, 1, -1])
        world.add_camera(name="side", pos=[0.5 * beam.length, -4.0 * beam.length, 0.0], xyaxes=[1, 0, 0, 0, 0, 1])
    return spec, disc


def _add_node_sensors(spec, disc: RodDiscretization, o: RodOptions) -> None:
    # the centreline points: every piece's frame origin (its end toward s = 0), and a site at the tip;
    # sensors read kinematics MuJoCo computes anyway, and change nothing in the dynamics
    n = o.segments
    tip = spec.body(f"piece{n}").add_site(name=f"{NODE_SENSOR}{n + 1}", pos=[float(disc.piece_length[n]), 0, 0],
                                          size=[1e-5, 0, 0], group=5)
    for i in range(n + 2):
        obj = (mujoco.mjtObj.mjOBJ_XBODY, f"piece{i}") if i <= n else (mujoco.mjtObj.mjOBJ_SITE, tip.name)
        sensor = spec.add_sensor(name=f"{NODE_SENSOR}{i}", type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                                 objtype=obj[0], objname=obj[1])
        sensor.nsample = CONTACT_HISTORY


def rod_tree(disc: RodDiscretization, options: RodOptions) -> dict:
    """The rod's kinematic tree as :func:`~magsoft_env.sim.magnetics.magnetic_poles` takes it.

    Piece ``i`` spans ``x in [0, l_i]`` of its frame. The pieces right of the base piece ``b`` hang
    from their left end (their parent's right end), those left of it from their right end; the
    root's reference point is its base hinge (the piece's middle). Returns ``parent``,
    ``joint_in_self``, ``joint_in_parent``, ``centres`` (m, 3D body-frame points) and ``levers``
    (the piece lengths, m).
    """
    n = options.segments
    length = np.asarray(disc.piece_length, dtype=float)
    b = options.base_piece
    parent = np.empty(n + 1, dtype=int)
    own, in_parent = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    for i in range(n + 1):
        if i > b:  # frame at its left end, the parent's right end
            parent[i] = i - 1
            in_parent[i, 0] = length[i - 1]
        elif i < b:  # frame at its left end, hinge at its right end = the parent's left end
            parent[i] = i + 1
            own[i, 0] = length[i]
        else:
            parent[i] = -1
            own[i, 0] = 0.5 * length[i] if options.has_contact else 0.0
    centres = np.zeros((n + 1, 3))
    centres[:, 0] = 0.5 * length
    return {"parent": parent, "joint_in_self": own, "joint_in_parent": in_parent, "centres": centres,
            "levers": length}


def rod_poles(disc: RodDiscretization, options: RodOptions) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rod's magnetic poles (:func:`~magsoft_env.sim.magnetics.magnetic_poles`): piece ``(P,)``, position
    (x, z) in the piece's frame ``(P, 2)`` (m), charge ``(P,)`` (A m)."""
    from .magnetics import body_moments_3d, magnetic_poles

    piece, pos, charge = magnetic_poles(body_moments_3d(disc.moment), free_root=options.has_contact,
                                        **rod_tree(disc, options))
    return piece, pos[:, [0, 2]], charge


def _add_poles(spec, disc: RodDiscretization, o: RodOptions) -> None:
    # the field's frame: a mocap body at the origin whose x axis the simulator turns along B
    frame = spec.worldbody.add_body(name=FIELD_FRAME, mocap=True)
    frame.add_site(name=FIELD_FRAME, group=5)
    piece, pos, charge = rod_poles(disc, o)
    for k, (i, (x, z), c) in enumerate(zip(piece, pos, charge, strict=True)):
        spec.body(f"piece{int(i)}").add_site(name=f"pole{k}", pos=[float(x), 0.0, float(z)], group=5)
        # force gain * ctrl = c |B| along the field frame's x axis, at the pole (refsite: the force
        # stays in the world frame whatever the piece does)
        a = spec.add_actuator(name=f"pole{k}", target=f"pole{k}", trntype=mujoco.mjtTrn.mjTRN_SITE,
                              refsite=FIELD_FRAME)
        a.gear = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]
        a.gainprm[0] = float(c)
        a.group = 5


def field_controls(fields) -> tuple[np.ndarray, np.ndarray]:
    """Native magnetics: the inputs that apply the fields ``(B_x, B_z)`` (T), shape ``(n, 2)``.

    Returns ``(magnitude, quat)``: ``|B|`` (T, shape ``(n,)``), the value of every actuator's
    control, and the mocap quaternion of :data:`FIELD_FRAME` (shape ``(n, 4)``), the rotation about
    -y by ``alpha = atan2(B_z, B_x)`` that turns its x axis along the field (the identity for
    ``B = 0``). Only +, -, *, / and square roots, each correctly rounded, so :func:`field_control`
    (one field, plain floats) gives the same bits: the simulator, the batch and rollouts apply
    identical inputs.
    """
    f = np.asarray(fields, dtype=float)
    if f.ndim == 0 or f.shape[-1] != 2:
        raise ValueError(f"field_controls takes planar fields (B_x, B_z) (T), shape (n, 2), got shape {f.shape}: the "
                         "MuJoCo hinge-chain rod bends in the x-z plane.")
    f = f.reshape(-1, 2)
    bx, bz = f[:, 0], f[:, 1]
    mag = np.sqrt(bx * bx + bz * bz)
    # (cos, sin)(alpha / 2) is along (|B| + B_x, B_z), or along (B_z, |B| - B_x) where B_x < 0 (no cancellation)
    neg = bx < 0.0
    w = np.where(neg, bz, mag + bx)
    y = np.where(neg, mag - bx, bz)
    norm = np.sqrt(w * w + y * y)
    zero = norm == 0.0
    norm[zero] = 1.0
    quat = np.zeros((f.shape[0], 4))
    quat[:, 0] = np.where(zero, 1.0, w / norm)
    quat[:, 2] = -(y / norm)
    return mag, quat


def field_control(bx: float, bz: float) -> tuple[float, float, float]:
    """:func:`field_controls` of one field as plain floats: ``(|B|, quat[0], quat[2])`` (the other
    quaternion entries are 0), bit-identical to it."""
    mag = math.sqrt(bx * bx + bz * bz)
    w, y = (bz, mag - bx) if bx < 0.0 else (mag + bx, bz)
    norm = math.sqrt(w * w + y * y)
    if norm == 0.0:
        return mag, 1.0, -0.0
    return mag, w / norm, -(y / norm)


def native_controls(rod: RodModel, fields) -> np.ndarray:
    """Native magnetics: control vectors for :data:`NATIVE_CONTROL_SPEC` (``mujoco.rollout``'s
    ``control`` with ``control_spec=NATIVE_CONTROL_SPEC``), shape ``(n, nu + 4)``, from the fields
    ``(B_x, B_z)`` (T), shape ``(n, 2)``: every control ``|B|``, then the field frame's quaternion.

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> rod = build_model(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), RodOptions(scene="floor"))
    >>> u = native_controls(rod, [(0.0, 2e-3), (1e-3, 0.0)])
    >>> u.shape == (2, rod.model.nu + 4) and u.shape[1] == mujoco.mj_stateSize(rod.model, NATIVE_CONTROL_SPEC)
    True
    """
    if not rod.native:
        raise ValueError("native_controls needs a rod built with RodOptions(magnetics='native').")
    mag, quat = field_controls(fields)
    nu = rod.model.nu
    out = np.empty((mag.shape[0], nu + 4))
    out[:, :nu] = mag[:, None]
    out[:, nu:] = quat
    return out


def scene_features(beam: Beam, o: RodOptions) -> list[tuple[str, list[float], list[float]]]:
    """The boxes of a scene besides its floor, the same for every rod: ``(name, half-sizes, centre)`` (m). The
    channel (the paper's Fig. 5a hollow box: ceiling and two side walls, its entrance at ``feature_x``) or the
    obstacle (Fig. 5b block, its left face at ``feature_x``); ``feature_x`` None: ``L + 5 mm``."""
    x0 = beam.length + 5e-3 if o.feature_x is None else float(o.feature_x)
    if o.scene == "channel":
        cl, cw, ch = CHANNEL_SIZE
        out = [("channel_ceiling", [0.5 * cl, 0.5 * cw + _WALL, 0.5 * _WALL], [x0 + 0.5 * cl, 0.0, ch + 0.5 * _WALL])]
        for side, y in (("left", 0.5 * cw + 0.5 * _WALL), ("right", -(0.5 * cw + 0.5 * _WALL))):
            out.append((f"channel_wall_{side}", [0.5 * cl, 0.5 * _WALL, 0.5 * ch], [x0 + 0.5 * cl, y, 0.5 * ch]))
        return out
    if o.scene == "obstacle":
        bl, bw, bh = OBSTACLE_SIZE
        return [("obstacle", [0.5 * bl, 0.5 * bw, 0.5 * bh], [x0 + 0.5 * bl, 0.0, 0.5 * bh])]
    return []


def _add_scene(spec, beam: Beam, o: RodOptions, contact: _Contact) -> list:
    world = spec.worldbody
    geoms = []

    def static_geom(name, **kw):
        g = world.add_geom(name=name, **kw)
        g.contype, g.conaffinity = _SCENE_CONTYPE, _SCENE_CONAFFINITY
        contact.set_geom(g)
        geoms.append(g)
        return g

    half = 10.0 * beam.length
    static_geom("floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[half, half, 1e-3])
    for name, size, pos in scene_features(beam, o):
        static_geom(name, type=mujoco.mjtGeom.mjGEOM_BOX, size=size, pos=pos)
    return geoms


def build_model(beam: Beam, options: RodOptions | None = None) -> RodModel:
    """Compile the rod and its scene.

    Parameters
    ----------
    beam : Beam
        The beam specification (SI units).
    options : RodOptions, optional
        Scene, segments, integrator and timestep (defaults: a 20-segment clamped cantilever,
        ``discrete`` integrator, 1 ms step).

    Returns
    -------
    RodModel
    """
    options = RodOptions() if options is None else options
    spec, disc = build_spec(beam, options)
    model = spec.compile()
    n = options.segments
    body_ids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"piece{i}") for i in range(n + 1)])
    jids = [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, f"hinge{i}") for i in range(n)]
    hinge_qpos = np.array([model.jnt_qposadr[j] for j in jids])
    hinge_dof = np.array([model.jnt_dofadr[j] for j in jids])
    base_qpos = np.zeros(0, dtype=int)
    sensor = feature = -1
    if options.has_contact:
        base_qpos = np.array([
            model.jnt_qposadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, nm)]
            for nm in ("base_x", "base_z", "base_theta")
        ])
        sensor = int(model.sensor_adr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, CONTACT_SENSOR)])
        if options.scene != "floor":
            feature = int(model.sensor_adr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, FEATURE_SENSOR)])
    poles = {}
    if options.magnetics == "native":
        piece, pos, charge = rod_poles(disc, options)
        if model.nu != piece.size:
            raise RuntimeError("one actuator per magnetic pole")  # guaranteed by build_spec
        frame = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, FIELD_FRAME)
        poles = dict(pole_piece=piece, pole_pos=pos, pole_charge=charge, field_mocap=int(model.body_mocapid[frame]))
    return RodModel(model, beam, options, disc, body_ids, hinge_qpos, hinge_dof, base_qpos, sensor, feature, **poles)

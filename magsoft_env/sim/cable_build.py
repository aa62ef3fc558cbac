"""The 3D strip's MuJoCo model: a beam as a MuJoCo 4.0 1D ``flexcomp`` strip (box section, discrete elastic rod).

Layout (the planar chain's midpoint layout, :mod:`~magsoft_env.sim.discretize`): the ``N`` cells of the beam
put a vertex at each cell midpoint ``s_j``, plus one at the clamp (``s = 0``) and one at the tip (``s = L``):
``N + 2`` vertices, ``N + 1`` edges. Edge ``i`` is the planar chain's piece ``i`` (the half cell at the clamp,
links between cell midpoints, the half cell at the tip). Bending and twisting live at the ``N`` interior
vertices; vertex ``j + 1`` carries cell ``j``'s compliance. In a cantilever both points of the first edge are
pinned (``<pin id="0 1"/>``): the edge and its material frame are clamped to the world.

What the builder corrects in MuJoCo's defaults (measured for the 25 x 5 x 1.13 mm strip):

- **Stiffness records.** MuJoCo stores per interior vertex ``k_1 = E I_1 / (l_0 + l_1)`` (its bending energy is
  ``k |kappa b|^2`` with ``|kappa b| = 2 tan(angle / 2)``), the strong-axis excess ``k_2 - k_1`` and the
  torsion ``k_t = G J / (l_0 + l_1)`` (energy ``k_t (twist angle)^2``). With the edge lengths of the midpoint
  layout that is a Voronoi length, which leaves the first and last vertex stiffer than the cell they stand for
  (a first-order error at a clamp); the builder writes ``K / 2`` into each record instead, ``K = 1 / int_cell
  ds / (E I)`` the cell's hinge stiffness (``E I / ds`` for a uniform beam) for each of ``E I_w``, ``E I_s``
  and ``G J``: the planar chain's midpoint rule, second order, and any volume-fraction profile.
- **Masses.** Each edge's mass ``int rho A ds`` goes to its two vertices by the lever rule (each edge keeps its
  mass and first moment), instead of MuJoCo's equal split over the points.
- **Twist inertia.** Each edge's twist body gets the physical polar inertia ``int rho I_p ds`` over the edge,
  ``I_p = w h (w^2 + h^2) / 12``, instead of MuJoCo's compile-time value with its 1e-9 kg m^2 floor (33x the
  physical value for the paper strip: torsion at 3.2 Hz instead of 18.8 Hz).
- **Edge constraint.** The edges are held at length by MuJoCo's edge equality with ``solref = (dt, 1)``
  (``refsafe`` off) and a stiff ``solimp`` (MuJoCo's default let the strip stretch 232 % under its own weight;
  ``(2 dt, 1)`` left 6e-4 at N = 20, dt = 1 ms, in a 5 mT field with gravity, ``(dt, 1)`` 4e-4; docs/sim.md).

Magnetic couples. Edge ``i`` carries the moment ``m_i = int (A B_r / mu0) m_hat ds`` (material components: along
the edge, across the width, through the thickness). Its world moment is ``R_i m_i = m_a t + m_w d1 + m_t d2``
with the edge's material frame (:func:`material_frames`); the couple ``C = (R_i m_i) x B`` is applied exactly as
the force pair ``+-(C x t) / l_i`` (``l_i`` its current length) on the edge's end / start vertex bodies
(``xfrc_applied``: its couple is the part of ``C`` across the edge) and ``C . t`` on the edge's twist hinge
(``qfrc_applied``). Torques on vertex bodies would do nothing (they are points on slide joints).

Material frame from the MuJoCo state: MuJoCo's time-parallel reference frames in ``mjData.plastic``, transported to
the current tangents and turned by the twist hinges (:mod:`~magsoft_env.sim.cable_frames`).

The :class:`~magsoft_env.sim.Simulator` steps the strip, clamped or on the floor, through :class:`CableRod`, its
rod backend. On the floor the flex's contact parameters (the planar rod's friction, ``solref``, ``solimp``) win
over the floor geom's (a higher priority; MuJoCo would otherwise mix them).

Floor contact (``floor_contact`` of :func:`build_cable`). MuJoCo collides a plane with a 1D flex's vertices only:
two corners of the box section at each vertex, each moving with one of the vertex's two edges (the edge that
starts there), so the bottom surface's motion from the bending rate is taken from one side of every vertex (the
planar chain's ``hinge_sphere`` layout; crawl speeds -54 % to +17 % off the capsule chain's, docs/sim.md). The
floor is therefore a box (top face at z = 0), which MuJoCo collides with the flex's elements, each edge's oriented
box of the section: four bottom corners per edge lying flat, each moving with its own edge (its two vertices, its
rotation and its twist; tested), the planar chain's capsule or box layout. ``floor_contact="vertex"`` keeps the
plane.

Native axial couples (``poles`` of :func:`build_cable`). An axial magnetization (along the edges) is exactly a set
of constant world forces at the vertices: edge ``i`` with axial moment ``m_a,i`` and reference length ``l0_i`` is the
pair of poles ``+-(m_a,i / l0_i) B`` on its end / start vertex, whose couple is ``(l_i t_i) x (m_a,i / l0_i) B =
(l_i / l0_i) m_a,i t_i x B``: the axial couple exactly, up to the edge's strain ``l_i / l0_i - 1`` (what the edge
constraint lets through, 1e-5 to 1e-3 of the couple; docs/sim.md). Summed per vertex the force is ``c_v B`` with a
constant ``c_v`` (:func:`pole_coefficients`, A m), which the builder gives MuJoCo as three fixed tendons (x, y, z)
over the vertex slides with coefficients ``c_v`` and a motor on each (``ctrl = (B_x, B_y, B_z)``; ``"tendon"``, the
default), or as one motor per vertex slide with gear ``c_v`` (``"joint"``; ``ctrl`` the field component of its axis).
Then MuJoCo applies the axial couples itself: a held field runs as ``mj_step(m, d, k)`` and fields that change as one
``mujoco.rollout`` with control rows, as the planar chain's. A transverse magnetization (width or thickness
components) turns with the material frame, which only Python knows here: its couples stay in :func:`apply_field`.

Sensors (floor scene). MuJoCo reports every step's deepest floor contact and centreline itself, in history buffers
of :data:`~magsoft_env.sim.model.CONTACT_HISTORY` steps: a ``contact`` sensor on the floor geom (``reduce =
mindist``, ``data = dist``; it matches the flex's element and vertex contacts through the floor geom, bit for bit the
most negative ``dist`` of ``mjData.contact`` with the floor) named :data:`~magsoft_env.sim.model.CONTACT_SENSOR`, and
a ``framepos`` sensor on every vertex body, :data:`~magsoft_env.sim.model.NODE_SENSOR` + index, clamp end first.

Limitations: no varying width or thickness (the Beam has none); scenes ``cantilever`` (clamped) and ``floor``
(free, on the floor) only; MuJoCo's ``discrete``, ``euler`` or ``rk4`` integrator (its rod
elasticity has no implicit variant); the couples of a transverse magnetization need the material frame every
step, so they are applied from Python (:func:`apply_field`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from ..spec import Beam
from .discretize import _integrate, cell_edges
from .model import CONTACT_HISTORY, CONTACT_SENSOR, FEATURE_SENSOR, NODE_SENSOR, contact_timeconst, scene_features

#: What messages call the rod this module builds.
CABLE_ROD = "the MuJoCo flexcomp rod"
#: Name of the flexcomp (its vertex bodies are ``rod_<i>``, its twist bodies and hinges ``rod_twist_<i>``).
FLEX_NAME = "rod"
#: ``solimp`` of the edge-length constraint: stiff from the first micrometre.
EDGE_SOLIMP = (0.99, 0.999, 1e-6, 0.5, 2.0)
#: Edge-constraint ``solref`` time constant in timesteps (with MuJoCo's ``refsafe`` off, which would raise it to 2).
EDGE_TIMECONST_STEPS = 1.0
#: Scenes the cable rod builds.
CABLE_SCENES = ("cantilever", "floor", "channel", "obstacle")
#: Integrators MuJoCo's rod elasticity supports.
CABLE_INTEGRATORS = ("discrete", "euler", "rk4")
#: How the strip meets the floor (:func:`build_cable`): ``element``, each edge's box against a box floor (the
#: default); ``vertex``, the box section's corners at the vertices against a plane.
FLOOR_CONTACTS = ("element", "vertex")
#: The strip's floor contact unless asked otherwise.
DEFAULT_FLOOR_CONTACT = "element"
#: How the poles of an axial magnetization reach MuJoCo (:func:`build_cable`'s ``poles``): ``tendon``, three fixed
#: tendons over the vertex slides (coefficients :func:`pole_coefficients`) with a motor each, ``ctrl = (B_x, B_y,
#: B_z)``; ``joint``, a motor on every vertex slide with gear ``c_v``, ``ctrl`` its axis's field component.
POLE_INPUTS = ("tendon", "joint")
#: Names of the pole tendons (x, y, z).
POLE_TENDONS = ("strip_poles_x", "strip_poles_y", "strip_poles_z")


@dataclass(frozen=True)
class CableLayout:
    """The beam cut for the flexcomp strip (midpoint layout), SI units.

    Attributes
    ----------
    s : (N + 2,) ndarray
        Arc length of the vertices: 0, the cell midpoints, L.
    edge_length : (N + 1,) ndarray
    vertex_mass : (N + 2,) ndarray
        Lever-rule vertex masses (kg).
    edge_mass : (N + 1,) ndarray
        Mass of each edge (kg).
    twist_inertia : (N + 1,) ndarray
        Polar inertia of each edge about its axis, ``int rho I_p ds`` (kg m^2).
    stiffness : (N, 3) ndarray
        Hinge stiffnesses of the cells ``[E I_w, E I_s, G J] / ds`` (compliance-averaged; N m / rad).
    moment : (N + 1, 3) ndarray
        Magnetic moment of each edge in its material frame (along, width, thickness; A m^2).
    """

    s: np.ndarray
    edge_length: np.ndarray
    vertex_mass: np.ndarray
    twist_inertia: np.ndarray
    stiffness: np.ndarray
    moment: np.ndarray
    edge_mass: np.ndarray

    @property
    def segments(self) -> int:
        return len(self.s) - 2


def cable_layout(beam: Beam, segments: int, grading: float = 1.0) -> CableLayout:
    """Cut ``beam`` into ``segments`` midpoint cells for the flexcomp strip (see the module docstring)."""
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    n = int(segments)
    L = beam.length
    cells = cell_edges(L, n, float(grading))
    s = np.concatenate([[0.0], 0.5 * (cells[:-1] + cells[1:]), [L]])
    w, h = beam.width, beam.thickness
    ip_factor = (w * w + h * h) / 12.0
    stiff = np.empty((n, 3))
    for j in range(n):
        for k in range(3):
            stiff[j, k] = 1.0 / _integrate(beam, cells[j], cells[j + 1],
                                           [lambda x, k=k: 1.0 / beam.stiffnesses(x)[..., k]])[0]
    vmass = np.zeros(n + 2)
    tin = np.empty(n + 1)
    emass = np.empty(n + 1)
    mom = np.empty((n + 1, 3))
    for i in range(n + 1):
        a, b = s[i], s[i + 1]
        lo = b - a
        m0, m1 = _integrate(beam, a, b, [beam.mass_per_length,
                                         lambda x, a=a, lo=lo: beam.mass_per_length(x) * (x - a) / lo])
        vmass[i] += m0 - m1
        vmass[i + 1] += m1
        tin[i] = m0 * ip_factor
        emass[i] = m0
        mom[i] = _integrate(beam, a, b, [
            lambda x, k=k: beam.moment_per_length(x) * beam.magnetization_direction(x)[..., k] for k in range(3)])
    return CableLayout(s=s, edge_length=np.diff(s), vertex_mass=vmass, twist_inertia=tin, stiffness=stiff,
                       moment=mom, edge_mass=emass)


def _xml(beam: Beam, lay: CableLayout, clamped: bool, z0: float) -> str:
    pts = " ".join(f"{x:.17g} 0 {z0:.17g}" for x in lay.s)
    elems = " ".join(f"{i} {i + 1}" for i in range(len(lay.s) - 1))
    pin = '<pin id="0 1"/>' if clamped else ""
    # young / poisson only make MuJoCo build the records; the builder overwrites every stiffness
    return (
        f'<mujoco><worldbody><flexcomp name="{FLEX_NAME}" type="direct" dim="1" radius="{0.5 * beam.thickness!r}" '
        f'mass="{float(np.sum(lay.vertex_mass))!r}" point="{pts}" element="{elems}">'
        f'<elasticity young="1" poisson="0.3" section="box" '
        f'sectionsize="{0.5 * beam.width!r} {0.5 * beam.thickness!r}"/>'
        f'<edge equality="true"/>{pin}</flexcomp></worldbody></mujoco>'
    )


def pole_coefficients(layout: CableLayout) -> np.ndarray:
    """The axial magnetization as poles: ``c_v`` (A m) of every vertex, shape ``(N + 2,)``, such that the constant
    world forces ``c_v B`` at the vertices are the axial couples (module docstring): ``c_v = m_a,v-1 / l0_v-1 -
    m_a,v / l0_v`` (edge ``v - 1`` ends at vertex ``v``, edge ``v`` starts there).

    >>> lay = cable_layout(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), 4)
    >>> c = pole_coefficients(lay)
    >>> c.shape, float(abs(c.sum())) < 1e-15 * float(abs(c).max())   # the poles of each edge cancel
    ((6,), True)
    """
    q = layout.moment[:, 0] / layout.edge_length
    c = np.zeros(len(layout.s))
    c[1:] += q
    c[:-1] -= q
    return c


def _add_poles(spec: mujoco.MjSpec, lay: CableLayout, clamped: bool, poles: str) -> None:
    """The axial poles as MuJoCo actuators (module docstring); the pinned vertices of a clamp get none (their
    forces would go to the world)."""
    c = pole_coefficients(lay)
    free = [i for i in range(len(lay.s)) if not (clamped and i < 2)]
    joints = {}
    for i in free:
        for j in spec.body(f"{FLEX_NAME}_{i}").joints:
            axis = int(np.argmax(np.abs(j.axis)))
            j.name = f"{FLEX_NAME}_{i}_{'xyz'[axis]}"
            joints[i, axis] = j.name
    motor = {"gaintype": mujoco.mjtGain.mjGAIN_FIXED, "biastype": mujoco.mjtBias.mjBIAS_NONE, "ctrllimited": 0,
             "forcelimited": 0}
    if poles == "tendon":
        for axis, name in enumerate(POLE_TENDONS):
            t = spec.add_tendon(name=name)
            for i in free:
                if c[i] != 0.0:
                    t.wrap_joint(joints[i, axis], float(c[i]))
            spec.add_actuator(name=name, trntype=mujoco.mjtTrn.mjTRN_TENDON, target=name,
                              gainprm=[1.0] + [0.0] * 9, **motor)
    else:
        for axis in range(3):
            for i in free:
                if c[i] == 0.0:  # a uniform magnetization has poles at its ends only
                    continue
                spec.add_actuator(name=f"{joints[i, axis]}_pole", trntype=mujoco.mjtTrn.mjTRN_JOINT,
                                  target=joints[i, axis], gear=[float(c[i]), 0, 0, 0, 0, 0],
                                  gainprm=[1.0] + [0.0] * 9, **motor)


def _add_sensors(spec: mujoco.MjSpec, lay: CableLayout, features: bool) -> None:
    """The contact scenes' history sensors (module docstring): the deepest floor contact, with ``features`` (the
    channel, the obstacle) the deepest contact of all (the strip touches only the scene: its floor and its boxes,
    as the planar chain's scene sensor sees them), then the vertices in order (consecutive 3-vectors with equal
    buffers, as :class:`~magsoft_env.sim.histories.PointsHistory` reads them)."""
    s = spec.add_sensor(name=CONTACT_SENSOR, type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=mujoco.mjtObj.mjOBJ_GEOM,
                        objname="floor")
    s.intprm = [1 << int(mujoco.mjtConDataField.mjCONDATA_DIST), 1, 1]  # dist; reduce mindist; one contact
    s.nsample = CONTACT_HISTORY
    if features:
        s = spec.add_sensor(name=FEATURE_SENSOR, type=mujoco.mjtSensor.mjSENS_CONTACT)  # every contact
        s.intprm = [1 << int(mujoco.mjtConDataField.mjCONDATA_DIST), 1, 1]
        s.nsample = CONTACT_HISTORY
    for i in range(len(lay.s)):
        s = spec.add_sensor(name=f"{NODE_SENSOR}{i}", type=mujoco.mjtSensor.mjSENS_FRAMEPOS,
                            objtype=mujoco.mjtObj.mjOBJ_XBODY, objname=f"{FLEX_NAME}_{i}")
        s.nsample = CONTACT_HISTORY


@dataclass(frozen=True)
class CableModel:
    """A compiled flexcomp strip and the addresses its readouts need.

    Attributes
    ----------
    model : mujoco.MjModel
    beam : Beam
    options : RodOptions
    layout : CableLayout
    clamped : bool
    vertex_body : (N + 2,) ndarray of int
        Body of each vertex (0, the world, for pinned vertices).
    vertex_ref : (N + 2, 3) ndarray
        Reference positions of the vertices (m).
    vertex_qpos : (N + 2, 3) ndarray of int
        qpos addresses of each vertex's slides x, y, z (-1 where pinned).
    vertex_dof : (N + 2, 3) ndarray of int
        dof addresses of each vertex's slides x, y, z (-1 where pinned).
    twist_dof, twist_qpos : (N + 1,) ndarray of int
        The twist hinge of each edge (-1 for a clamped edge).
    flex : int
        Flex id.
    poles : str or None
        How the axial poles reach MuJoCo (:data:`POLE_INPUTS`), or None: the model has no actuators.
    """

    model: mujoco.MjModel
    beam: Beam
    options: object
    layout: CableLayout
    clamped: bool
    vertex_body: np.ndarray
    vertex_ref: np.ndarray
    vertex_qpos: np.ndarray
    vertex_dof: np.ndarray
    twist_dof: np.ndarray
    twist_qpos: np.ndarray
    flex: int
    poles: str | None = None


def check_cable_options(options) -> None:
    """ValueError for a scene, integrator or clamp angle the strip does not build (before any work)."""
    if options.scene not in CABLE_SCENES:
        raise ValueError(f"RodOptions(rod='cable') builds the scenes {CABLE_SCENES}, got {options.scene!r}.")
    if options.integrator not in CABLE_INTEGRATORS:
        raise ValueError(f"RodOptions(rod='cable') runs with the integrators {CABLE_INTEGRATORS} (MuJoCo's "
                         f"rod elasticity has no implicit variant), got {options.integrator!r}.")
    if options.clamp_angle != 0.0:
        raise ValueError(f"RodOptions(rod='cable') is clamped along +x (clamp_angle = 0), got "
                         f"{options.clamp_angle!r}.")


def build_cable(beam: Beam, options, *, floor_contact: str | None = None, poles: str | None = None,
                layout: CableLayout | None = None) -> CableModel:
    """Compile ``beam`` as a flexcomp strip with ``options`` (a :class:`~magsoft_env.sim.model.RodOptions`:
    ``segments``, ``scene`` (``cantilever``: clamped; ``floor``: free on the floor), ``timestep``, ``integrator``,
    ``gravity``, ``grading``, ``retardation_time``, ``friction``).

    ``floor_contact`` (floor scene; None: :data:`DEFAULT_FLOOR_CONTACT`): ``element``, a box floor that MuJoCo
    collides with each edge's box; ``vertex``, a plane that it collides with the vertices (module docstring).

    ``poles`` (None: none): the axial magnetization's couples as MuJoCo actuators (:data:`POLE_INPUTS`: three
    tendon motors with ``ctrl = (B_x, B_y, B_z)``, or a motor per vertex slide), module docstring. The floor scene
    always carries the history sensors of the deepest floor contact and the vertices. ``layout``: the beam's
    :func:`cable_layout` at ``options.segments`` and ``options.grading``, where the caller has it (None: computed here).

    Every MuJoCo default the module docstring lists is replaced by the beam's own values.
    """
    check_cable_options(options)
    floor_contact = DEFAULT_FLOOR_CONTACT if floor_contact is None else floor_contact
    if floor_contact not in FLOOR_CONTACTS:
        raise ValueError(f"floor_contact must be one of {FLOOR_CONTACTS}, got {floor_contact!r}.")
    if poles is not None and poles not in POLE_INPUTS:
        raise ValueError(f"poles must be None or one of {POLE_INPUTS}, got {poles!r}.")
    if layout is None:
        lay = cable_layout(beam, options.segments, options.grading)
    elif not isinstance(layout, CableLayout) or layout.segments != options.segments:
        raise ValueError(f"layout must be the CableLayout of the beam at {options.segments} segments, got "
                         f"{getattr(layout, 'segments', layout)!r} segments.")
    else:
        lay = layout
    clamped = options.scene == "cantilever"
    z0 = 0.0 if clamped else 0.5 * beam.thickness
    spec = mujoco.MjSpec.from_string(_xml(beam, lay, clamped, z0))
    spec.modelname = f"magsoft_cable_{options.scene}_{options.segments}"
    dt = float(options.timestep)
    spec.option.timestep = dt
    spec.option.integrator = {"discrete": mujoco.mjtIntegrator.mjINT_DISCRETE,
                              "euler": mujoco.mjtIntegrator.mjINT_EULER,
                              "rk4": mujoco.mjtIntegrator.mjINT_RK4}[options.integrator]
    spec.option.gravity = [0.0, 0.0, -float(options.gravity)]
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    spec.option.iterations = int(options.solver_iterations)
    spec.option.tolerance = float(options.solver_tolerance)
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET | mujoco.mjtDisableBit.mjDSBL_REFSAFE
    # the planar rod's friction cone and no-slip pass (the floor scene)
    spec.option.cone = (mujoco.mjtCone.mjCONE_ELLIPTIC if options.cone == "elliptic"
                        else mujoco.mjtCone.mjCONE_PYRAMIDAL)
    spec.option.noslip_iterations = int(options.noslip_iterations)
    if options.gravity == 0.0:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_GRAVITY
    if clamped:
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    elif floor_contact == "vertex":
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE,
                                size=[10 * beam.length, 10 * beam.length, 1e-3])
    else:
        # a box, top face at z = 0: MuJoCo collides a plane with the flex's vertices only, a box with its elements
        big = 10 * beam.length
        spec.worldbody.add_geom(name="floor", type=mujoco.mjtGeom.mjGEOM_BOX, size=[big, big, beam.length],
                                pos=[0.0, 0.0, -beam.length])
    features = scene_features(beam, options)  # the channel's ceiling and walls, the obstacle: the chain's boxes
    for name, size, pos in features:
        spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, size=size, pos=pos)
    if poles is not None:
        _add_poles(spec, lay, clamped, poles)
    if not clamped:
        _add_sensors(spec, lay, bool(features))
    model = spec.compile()
    n = options.segments
    nv = n + 2
    body = np.zeros(nv, dtype=int)
    vdof = -np.ones((nv, 3), dtype=int)
    vq = -np.ones((nv, 3), dtype=int)
    for i in range(nv):
        b = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"{FLEX_NAME}_{i}")
        if b < 0:
            continue
        body[i] = b
        for k in range(3):
            j = model.body_jntadr[b] + k
            axis = int(np.argmax(model.jnt_axis[j]))
            vdof[i, axis], vq[i, axis] = model.jnt_dofadr[j], model.jnt_qposadr[j]
    tdof = -np.ones(n + 1, dtype=int)
    tq = -np.ones(n + 1, dtype=int)
    for e in range(n + 1):
        name = f"{FLEX_NAME}_twist" if e == n else f"{FLEX_NAME}_twist_{e}"
        j = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, name)
        if j >= 0:
            tdof[e], tq[e] = model.jnt_dofadr[j], model.jnt_qposadr[j]
    # masses and inertias: vertex point masses (a small isotropic inertia; their slides never turn them),
    # the twist bodies' polar inertia about the edge
    for i in range(nv):
        if body[i] > 0:
            model.body_mass[body[i]] = lay.vertex_mass[i]
            model.body_inertia[body[i]] = lay.vertex_mass[i] * (beam.thickness / 2) ** 2
    for e in range(n + 1):
        if tdof[e] >= 0:
            b = model.jnt_bodyid[model.dof_jntid[tdof[e]]]
            model.body_mass[b] = lay.edge_mass[e]
            model.body_inertia[b] = lay.twist_inertia[e]
    # stiffness records (10 numbers per interior vertex after a count: v0 v1 v2 . k1 k2-k1 . twistdof kt r)
    f = 0
    adr = int(model.flex_bendingadr[f])
    count = int(model.flex_bending[adr])
    if count != n:
        raise RuntimeError(f"expected {n} bending records, MuJoCo made {count}")
    rec = model.flex_bending[adr + 1: adr + 1 + 10 * n].reshape(n, 10)
    if not np.array_equal(rec[:, 1].astype(int), np.arange(1, n + 1)):
        raise RuntimeError("unexpected layout of MuJoCo's rod bending records")
    rec[:, 4] = 0.5 * lay.stiffness[:, 0]
    rec[:, 5] = 0.5 * (lay.stiffness[:, 1] - lay.stiffness[:, 0])
    rec[:, 8] = 0.5 * lay.stiffness[:, 2]
    model.flex_bending[adr + 1: adr + 1 + 10 * n] = rec.reshape(-1)
    # MuJoCo's rod damping (frame-indifferent): its coefficient times each stiffness, except the weak bending axis,
    # which it damps with sqrt(k_1 k_2) (equal damping ratios on both axes). Scaled so that the weak axis, the
    # strip's main motion and the planar rod's only one, is Kelvin-Voigt with the retardation time; strong bending
    # and torsion then get w / h times less (docs/sim.md)
    model.flex_damping[f] = float(options.retardation_time) * math.sqrt(lay.stiffness[:, 0].mean()
                                                                       / lay.stiffness[:, 1].mean())
    # the edge-length constraint
    model.eq_solref[:] = [EDGE_TIMECONST_STEPS * dt, 1.0]
    model.eq_solimp[:] = EDGE_SOLIMP
    if not clamped:
        # the planar rod's contact: friction, solref time constant and damping ratio, solimp
        model.flex_friction[f, 0] = float(options.friction)
        # the flex's contact parameters alone (a higher priority than the floor's): with equal priorities MuJoCo
        # would mix its solref with the floor geom's default 20 ms (a contact ten to a hundred times softer, 1 h
        # deep under a crawling strip) and take the larger of the two frictions (the floor's default 1)
        model.flex_priority[f] = 1
        model.flex_solref[f] = [contact_timeconst(beam, options), float(options.contact_dampratio)]
        if options.contact_impedance is not None:
            model.flex_solimp[f, :2] = options.contact_impedance
        if not options.contact_refsafe:
            model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_REFSAFE
    data = mujoco.MjData(model)
    mujoco.mj_setConst(model, data)
    ref = np.zeros((nv, 3))
    ref[:, 0], ref[:, 2] = lay.s, z0
    return CableModel(model=model, beam=beam, options=options, layout=lay, clamped=clamped, vertex_body=body,
                      vertex_ref=ref, vertex_qpos=vq, vertex_dof=vdof, twist_dof=tdof, twist_qpos=tq, flex=f,
                      poles=poles)


def frequencies(beam: Beam) -> dict[str, float]:
    """First clamped-free frequencies (Hz) of a uniform strip: weak and strong bending (Euler-Bernoulli) and
    torsion (Saint-Venant), ``1.8751^2 sqrt(E I / (rho A L^4)) / (2 pi)`` and ``(pi / 2L) sqrt(G J / (rho I_p))
    / (2 pi)``, with the beam's values at mid-length."""
    s = 0.5 * beam.length
    ei_w, ei_s, gj = (float(v) for v in beam.stiffnesses(np.array([s]))[0])
    mu = float(beam.mass_per_length(s))
    L = beam.length
    w, h = beam.width, beam.thickness
    rho_ip = mu * (w * w + h * h) / 12.0
    c = 1.8751040687**2 / (2 * math.pi * L * L)
    return {"weak": c * math.sqrt(ei_w / mu), "strong": c * math.sqrt(ei_s / mu),
            "torsion": math.sqrt(gj / rho_ip) / (4.0 * L)}


def settling_damping(cm: CableModel) -> np.ndarray:
    """dof damping that makes every mode of the strip decay at the first weak-bending rate ``omega_1``
    (mass-proportional: ``2 omega_1`` times each vertex mass and twist inertia); statics do not depend on it."""
    m = cm.model
    w1 = 2.0 * math.pi * frequencies(cm.beam)["weak"]
    c = np.zeros(m.nv)
    for i in range(len(cm.vertex_body)):
        if cm.vertex_body[i] > 0:
            c[cm.vertex_dof[i]] = 2.0 * w1 * m.body_mass[cm.vertex_body[i]]
    free = cm.twist_dof >= 0
    c[cm.twist_dof[free]] = 2.0 * w1 * cm.layout.twist_inertia[free]
    return c


__all__ = ["build_cable", "CABLE_INTEGRATORS", "cable_layout", "CABLE_ROD", "CABLE_SCENES", "CableLayout",
           "CableModel", "check_cable_options", "DEFAULT_FLOOR_CONTACT", "EDGE_SOLIMP", "EDGE_TIMECONST_STEPS",
           "FLEX_NAME", "FLOOR_CONTACTS", "frequencies", "pole_coefficients", "POLE_INPUTS", "POLE_TENDONS",
           "settling_damping"]

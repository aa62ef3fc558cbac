"""The 3D rod: a beam as a MuJoCo 4.0 1D ``flexcomp`` strip (box section, discrete elastic rod).

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

Material frame from the MuJoCo state: MuJoCo keeps, per edge, a time-parallel reference frame ``(t_old, u_old)``
in ``mjData.plastic`` (the tangent and director when it last computed the rod's forces). The reference
director at the current state is ``u_old`` parallel-transported from ``t_old`` to the current tangent ``t``
(the rotation about ``t_old x t``); the material frame turns it by the edge's twist angle ``theta`` (its hinge
``qpos``) about ``t``: ``d1 = cos(theta) u + sin(theta) t x u``, ``d2 = t x d1``. At rest ``u = +y``: ``d1`` is the
width axis and ``d2 = +z`` the thickness axis of a strip lying flat. The sign of ``theta`` was checked against
MuJoCo's own elastic forces (a bend in a skewed plane pulls the weak axis toward the bending binormal through
``qfrc_passive``, tests/test_cable.py). Before the first step (``plastic`` all zero) the reference is the
rest director ``+y`` transported from the rest tangent ``+x``.

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

from ..spec import Beam, Field, as_field, as_fields
from .discretize import _integrate, cell_edges

#: What messages call the rod this module builds.
CABLE_ROD = "the MuJoCo flexcomp rod"
#: Name of the flexcomp (its vertex bodies are ``rod_<i>``, its twist bodies and hinges ``rod_twist_<i>``).
FLEX_NAME = "rod"
#: ``solimp`` of the edge-length constraint: stiff from the first micrometre.
EDGE_SOLIMP = (0.99, 0.999, 1e-6, 0.5, 2.0)
#: Edge-constraint ``solref`` time constant in timesteps (with MuJoCo's ``refsafe`` off, which would raise it to 2).
EDGE_TIMECONST_STEPS = 1.0
#: Scenes the cable rod builds.
CABLE_SCENES = ("cantilever", "floor")
#: Integrators MuJoCo's rod elasticity supports.
CABLE_INTEGRATORS = ("discrete", "euler", "rk4")
#: How the strip meets the floor (:func:`build_cable`): ``element``, each edge's box against a box floor (the
#: default); ``vertex``, the box section's corners at the vertices against a plane.
FLOOR_CONTACTS = ("element", "vertex")
#: The strip's floor contact unless asked otherwise.
DEFAULT_FLOOR_CONTACT = "element"


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


def build_cable(beam: Beam, options, *, floor_contact: str | None = None) -> CableModel:
    """Compile ``beam`` as a flexcomp strip with ``options`` (a :class:`~magsoft_env.sim.model.RodOptions`:
    ``segments``, ``scene`` (``cantilever``: clamped; ``floor``: free on the floor), ``timestep``, ``integrator``,
    ``gravity``, ``grading``, ``retardation_time``, ``friction``).

    ``floor_contact`` (floor scene; None: :data:`DEFAULT_FLOOR_CONTACT`): ``element``, a box floor that MuJoCo
    collides with each edge's box; ``vertex``, a plane that it collides with the vertices (module docstring).

    Every MuJoCo default the module docstring lists is replaced by the beam's own values.
    """
    if options.scene not in CABLE_SCENES:
        raise ValueError(f"{CABLE_ROD} builds the scenes {CABLE_SCENES}, got scene={options.scene!r}.")
    if options.integrator not in CABLE_INTEGRATORS:
        raise ValueError(f"{CABLE_ROD} runs with the integrators {CABLE_INTEGRATORS} (MuJoCo's rod elasticity has "
                         f"no implicit variant), got integrator={options.integrator!r}.")
    if options.clamp_angle != 0.0:
        raise ValueError(f"{CABLE_ROD} is clamped along +x (clamp_angle = 0), got {options.clamp_angle!r}.")
    floor_contact = DEFAULT_FLOOR_CONTACT if floor_contact is None else floor_contact
    if floor_contact not in FLOOR_CONTACTS:
        raise ValueError(f"floor_contact must be one of {FLOOR_CONTACTS}, got {floor_contact!r}.")
    lay = cable_layout(beam, options.segments, options.grading)
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
        from .model import contact_timeconst

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
                      vertex_ref=ref, vertex_qpos=vq, vertex_dof=vdof, twist_dof=tdof, twist_qpos=tq, flex=f)


# ---------------------------------------------------------------------------------------------- frames
_I1, _I2 = np.array([1, 2, 0]), np.array([2, 0, 1])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of ``(n, 3)`` arrays (``np.cross`` costs 2-3x more at these sizes)."""
    return np.take(a, _I1, 1) * np.take(b, _I2, 1) - np.take(a, _I2, 1) * np.take(b, _I1, 1)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def _transport(u: np.ndarray, t0: np.ndarray, t1: np.ndarray) -> np.ndarray:
    """Parallel transport of the directors ``u`` (rows, normal to ``t0``) from the unit tangents ``t0`` to ``t1``
    (the rotation about ``t0 x t1``)."""
    return u - (_dot(t1, u) / (1.0 + _dot(t0, t1)))[:, None] * (t0 + t1)


def vertices(cm: CableModel, data: mujoco.MjData) -> np.ndarray:
    """Vertex positions (m), shape ``(N + 2, 3)``, from ``data.qpos`` (every vertex body hangs from the world
    on three slides along x, y, z, so no kinematics pass is needed)."""
    x = cm.vertex_ref.copy()
    free = cm.vertex_qpos >= 0
    x[free] += data.qpos[cm.vertex_qpos[free]]
    return x


def material_frames(cm: CableModel, data: mujoco.MjData, x: np.ndarray | None = None):
    """The edges' material frames ``(t, d1, d2)``, each ``(N + 1, 3)``, at the vertex positions ``x``
    (default: :func:`vertices`) and the twist angles in ``data.qpos`` (see the module docstring)."""
    x = vertices(cm, data) if x is None else x
    e = np.diff(x, axis=0)
    t = e / np.sqrt(_dot(e, e))[:, None]
    ne = len(t)
    a = cm.model.flex_plasticadr[cm.flex]
    p = data.plastic[a:a + 6 * ne].reshape(ne, 6)
    if not p.any():
        t_old = np.tile([1.0, 0.0, 0.0], (ne, 1))
        u_old = np.tile([0.0, 1.0, 0.0], (ne, 1))
    else:
        t_old, u_old = p[:, :3], p[:, 3:]
    u = _transport(u_old, t_old, t)
    u /= np.sqrt(_dot(u, u))[:, None]
    theta = np.where(cm.twist_qpos >= 0, data.qpos[np.maximum(cm.twist_qpos, 0)], 0.0)
    v = _cross(t, u)
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    # d1 = cos u + sin v, d2 = t x d1 = cos v - sin u
    return t, c * u + s * v, c * v - s * u


def world_moments(cm: CableModel, data: mujoco.MjData, x: np.ndarray | None = None) -> np.ndarray:
    """World magnetic moment ``R_i m_i`` of every edge (A m^2), shape ``(N + 1, 3)``."""
    t, d1, d2 = material_frames(cm, data, x)
    m = cm.layout.moment
    return m[:, :1] * t + m[:, 1:2] * d1 + m[:, 2:3] * d2


def magnetic_energy(cm: CableModel, data: mujoco.MjData, field3) -> float:
    """``-sum (R_i m_i) . B`` (J)."""
    return -float(np.sum(world_moments(cm, data) @ np.asarray(field3, dtype=float)))


def apply_field(cm: CableModel, data: mujoco.MjData, field3, extra: np.ndarray | None = None,
                net_moment: np.ndarray | None = None) -> np.ndarray:
    """Write the magnetic couples of the field ``(B_x, B_y, B_z)`` (T) into ``data``: the force pair of each
    edge into ``xfrc_applied`` (rows of the vertex bodies, overwritten), the along-edge part into
    ``qfrc_applied`` (the twist dofs, overwritten; other dofs zeroed). Returns the couples ``(N + 1, 3)`` (N m).
    A clamped edge's couple goes to the clamp (nothing applied). ``extra``: a world wrench per edge ``(N + 1, 6)``
    added (force at the edge's middle, half to each vertex; couple as the magnetic ones). ``net_moment``: a
    ``(3,)`` array that receives the net magnetic moment ``sum R_i m_i`` of the state (A m^2)."""
    B = np.asarray(field3, dtype=float)
    x = vertices(cm, data)
    t, d1, d2 = material_frames(cm, data, x)
    m = cm.layout.moment
    mw = m[:, :1] * t + m[:, 1:2] * d1 + m[:, 2:3] * d2
    if net_moment is not None:
        net_moment[:] = mw.sum(axis=0)
    # m x B for every row: m @ [B]x
    C = mw @ np.array([[0.0, -B[2], B[1]], [B[2], 0.0, -B[0]], [-B[1], B[0], 0.0]])
    if extra is not None:
        C = C + extra[:, 3:]
    # the pair's lever is the edge's current length: its couple is C whatever the edge's strain
    e = np.diff(x, axis=0)
    F = _cross(C, t) / np.sqrt(_dot(e, e))[:, None]
    fv = np.zeros((len(x), 3))
    fv[1:] += F
    fv[:-1] -= F
    if extra is not None:
        fv[1:] += 0.5 * extra[:, :3]
        fv[:-1] += 0.5 * extra[:, :3]
    body = cm.vertex_body
    data.xfrc_applied[body[body > 0], :3] = fv[body > 0]
    data.xfrc_applied[body[body > 0], 3:] = 0.0
    data.qfrc_applied[:] = 0.0
    free = cm.twist_dof >= 0
    data.qfrc_applied[cm.twist_dof[free]] = _dot(C, t)[free]
    return C


# ---------------------------------------------------------------------------------------------- readouts
def tip_twist(cm: CableModel, data: mujoco.MjData) -> float:
    """Integrated twist ``int k3 ds`` (rad): the angle of each edge's ``d1`` about its tangent relative to the
    previous edge's ``d1`` parallel-transported along the centreline, summed (the first edge's frame is the
    clamp's; for a free rod the integral from the first edge)."""
    t, d1, _ = material_frames(cm, data)
    tr = _transport(d1[:-1], t[:-1], t[1:])
    tr /= np.linalg.norm(tr, axis=1)[:, None]
    sin = np.einsum("ij,ij->i", np.cross(tr, d1[1:]), t[1:])
    cos = np.einsum("ij,ij->i", tr, d1[1:])
    return float(np.sum(np.arctan2(sin, cos)))


def edge_strain(cm: CableModel, data: mujoco.MjData) -> float:
    """Largest relative change of an edge's length (dimensionless)."""
    x = vertices(cm, data)
    return float(np.max(np.abs(np.linalg.norm(np.diff(x, axis=0), axis=1) / cm.layout.edge_length - 1.0)))


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



# ---------------------------------------------------------------------------------------------- energy
def elastic_energy(cm: CableModel, data: mujoco.MjData) -> float:
    """Bending and twisting energy (J) of the strip, in the form MuJoCo's rod forces derive from: per interior
    vertex, ``k_1 (kb . d1)^2 + k_2 (kb . d2)^2 + k_t tau^2`` with ``kb = 2 t0 x t1 / (1 + t0 . t1)`` the discrete
    curvature binormal, ``d1``, ``d2`` the mean of the two edges' directors, ``tau`` the twist angle between the
    edges (as :func:`tip_twist` sums it) and the records' stiffnesses ``k = K / 2``. MuJoCo does not report it;
    tests/test_cable.py compares its gradient with MuJoCo's elastic forces."""
    t, d1, d2 = material_frames(cm, data)
    kb = 2.0 * np.cross(t[:-1], t[1:]) / (1.0 + np.einsum("ij,ij->i", t[:-1], t[1:]))[:, None]
    a1 = 0.5 * (d1[:-1] + d1[1:])
    a2 = 0.5 * (d2[:-1] + d2[1:])
    k = 0.5 * cm.layout.stiffness
    tr = _transport(d1[:-1], t[:-1], t[1:])
    tr /= np.linalg.norm(tr, axis=1)[:, None]
    tau = np.arctan2(np.einsum("ij,ij->i", np.cross(tr, d1[1:]), t[1:]), np.einsum("ij,ij->i", tr, d1[1:]))
    return float(k[:, 0] @ np.einsum("ij,ij->i", kb, a1) ** 2 + k[:, 1] @ np.einsum("ij,ij->i", kb, a2) ** 2
                 + k[:, 2] @ tau**2)


#: Largest relative edge stretch the simulator lets pass (the edge constraint holds 1e-3 in the statics of
#: docs/sim.md; 5 % means the constraint lost hold of the strip).
EDGE_STRAIN_LIMIT = 0.05


class ContactRecord:
    """The deepest floor contact of the last steps, oldest first: what MuJoCo's contact sensors with a history
    buffer give the planar rod (:class:`~magsoft_env.sim.health.SensorHistory`'s members), for the 3D rod, whose
    contacts are the flex's (MuJoCo's contact sensors match geoms and bodies, not flex vertices). The engine steps
    the 3D rod one ``mj_step`` at a time, and :meth:`push` records after each the most negative ``dist`` of the
    contacts MuJoCo found at that step's start state (0 when there is none, like a ``mindist`` sensor)."""

    def __init__(self, nsample: int):
        self.nsample = int(nsample)
        #: the values in ring order (the last ``nsample`` steps, in no particular order)
        self.values = np.zeros(self.nsample)
        self._cursor = self.nsample - 1

    def push(self, value: float) -> None:
        self._cursor = (self._cursor + 1) % self.nsample
        self.values[self._cursor] = value

    def last(self, k: int) -> np.ndarray:
        """The values of the last ``k`` (<= nsample) steps, oldest first, shape ``(k,)``."""
        if not 1 <= k <= self.nsample:
            raise ValueError(f"k must lie in [1, {self.nsample}], got {k!r}.")
        return self.values[(self._cursor + np.arange(1 - k, 1)) % self.nsample]


class CableRod:
    """The flexcomp strip as a :class:`~magsoft_env.sim.backend.RodBackend`: what
    :class:`~magsoft_env.sim.Simulator` steps for ``RodOptions(rod="cable")``, clamped (``scene="cantilever"``)
    or free on the floor (``scene="floor"``).

    The magnetic couples depend on the edges' material frames, so the engine writes them before every step
    (:attr:`per_step`, :meth:`write_field`), books the field's work with the net moment they computed
    (:attr:`moment`), and after every step calls :meth:`record_step`, which records the deepest floor contact
    (:class:`ContactRecord`: the per-step penetration check of the planar rod's contact sensors). The pieces are
    the edges (``N + 1``, clamp first); :attr:`hinge_dof` are all dofs (vertex slides and twist hinges), with
    :attr:`stiffness` the whole strip's stiffness against each: ``3 E I_w / L^2`` for a vertex (a force ``Q``
    moves a cantilever's tip by at most ``Q L^3 / (3 E I_w)``) and ``G J / L`` for a twist hinge, so that the
    static residual ``max |Q| / k`` bounds how far the imbalance could still move the strip, as a fraction of L
    or an angle (rad).
    """

    #: The engine calls :meth:`write_field` before every step.
    per_step = True
    control_spec = 0
    has_feature = False
    contact_adr = 0
    feature_adr = 0

    def __init__(self, beam: Beam, options):
        from .model import CONTACT_HISTORY

        cm = build_cable(beam, options)
        self.rod = cm
        self.model = cm.model
        self.beam = beam
        self.options = options
        self.has_contact = not cm.clamped
        self._contact_record = ContactRecord(CONTACT_HISTORY) if self.has_contact else None
        self._sd = np.zeros(1)
        floor = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        self._floor_geom = int(floor)
        #: net magnetic moment of the state :meth:`write_field` last wrote the couples of (A m^2)
        self.moment = np.zeros(3)
        lay = cm.layout
        self.npieces = len(lay.edge_length)
        self.two_stage = options.integrator != "rk4"
        free_v = cm.vertex_body > 0
        vd = cm.vertex_dof[free_v]
        td = cm.twist_dof[cm.twist_dof >= 0]
        self.hinge_dof = np.concatenate([vd.ravel(), td])
        # the whole strip's compliance: a force Q on a vertex moves the tip by up to Q L^3 / (3 E I_w), a moment
        # on a twist hinge turns it by up to Q L / (G J) (harmonic means of the cells' stiffnesses)
        L = beam.length
        ei_w = L / float(np.sum(1.0 / lay.stiffness[:, 0]))
        gj = L / float(np.sum(1.0 / lay.stiffness[:, 2]))
        self.stiffness = np.concatenate([np.full(vd.size, 3.0 * ei_w / L**2), np.full(td.size, gj / L)])
        self.weight = float(lay.vertex_mass.sum()) * float(options.gravity)
        self._field = np.zeros(3)
        self._external: np.ndarray | None = None
        mags = float(np.linalg.norm(lay.moment, axis=1).sum())
        self._scale_terms = (2.0 * mags, 2.0 * self.weight * beam.length + 0.5 * float(lay.stiffness[:, 0].sum())
                             * math.pi**2)

    # ------------------------------------------------------------------ inputs
    def contact_histories(self, data):
        return self._contact_record, None

    def contact_data(self, data) -> np.ndarray:
        """The array :attr:`contact_adr` indexes: the deepest floor contact of the last step (m)."""
        return self._sd

    def deepest_contact(self, data: mujoco.MjData) -> float:
        """The most negative ``dist`` (m) of the floor contacts in ``data`` (0 when there is none)."""
        n = data.ncon
        if not n:
            return 0.0
        c = data.contact
        dist = c.dist[:n]
        on = (c.geom[:n] == self._floor_geom).any(axis=1)
        return float(min(dist[on].min(), 0.0)) if on.any() else 0.0

    def record_step(self, data: mujoco.MjData) -> None:
        """After a step: record its deepest floor contact (the contacts of the state it started from)."""
        if self._contact_record is not None:
            v = self.deepest_contact(data)
            self._sd[0] = v
            self._contact_record.push(v)

    def write_field(self, data: mujoco.MjData, field3: np.ndarray) -> None:
        """The couples of the field ``(B_x, B_y, B_z)`` (T) at the state in ``data``, plus the external wrench,
        into ``xfrc_applied`` / ``qfrc_applied`` (the engine calls it before every step)."""
        self._field[:] = field3
        apply_field(self.rod, data, self._field, extra=self._external, net_moment=self.moment)

    def controls(self, fields):
        raise ValueError("the cable rod's couples are written before every step (per_step); it has no "
                         "per-step control rows for mujoco.rollout.")

    def apply_external(self, data: mujoco.MjData, wrench: np.ndarray | None) -> None:
        """A constant world-frame wrench per edge ``(N + 1, 6)``: the force at the edge's middle (half to each
        vertex), the couple applied as the magnetic ones are; written with the couples before every step."""
        self._external = None if wrench is None else np.array(wrench, dtype=float)
        apply_field(self.rod, data, self._field, extra=self._external, net_moment=self.moment)

    # ------------------------------------------------------------------ energies
    def net_moment(self, data: mujoco.MjData) -> np.ndarray:
        """Net magnetic moment (world x, y, z; A m^2)."""
        return world_moments(self.rod, data).sum(axis=0)

    def net_moments(self, qpos: np.ndarray) -> np.ndarray:
        """Net magnetic moments of recorded positions ``(k, nq)`` (reference frames of the present state)."""
        scratch = mujoco.MjData(self.model)
        out = np.empty((len(qpos), 3))
        for i, q in enumerate(qpos):
            scratch.qpos[:] = q
            out[i] = world_moments(self.rod, scratch).sum(axis=0)
        return out

    def energy(self, data, field, *, kinetic: float, staggered: bool) -> float:
        B = np.zeros(3)
        f = np.asarray(field, dtype=float)
        B[[0, 2] if f.size == 2 else slice(None)] = f
        e = self.energies(data, B, kinetic)
        return e["total"]

    def energy_scale(self, bmax: float) -> float:
        slope, rest = self._scale_terms
        return slope * bmax + rest

    def energies(self, data: mujoco.MjData, field3: np.ndarray, kinetic: float) -> dict[str, float]:
        """Kinetic (given), elastic (:func:`elastic_energy`), gravitational (from z = 0) and magnetic energy (J)."""
        x = vertices(self.rod, data)
        elastic = elastic_energy(self.rod, data)
        grav = float(self.rod.layout.vertex_mass @ x[:, 2]) * float(self.options.gravity)
        mag = -float(np.sum(world_moments(self.rod, data, x) @ np.asarray(field3, dtype=float)))
        return {"kinetic": kinetic, "elastic": elastic, "gravity": grav, "magnetic": mag,
                "total": kinetic + elastic + grav + mag}

    def integrity(self, data: mujoco.MjData):
        """``(quantity, value, hint)`` when an edge stretched beyond :data:`EDGE_STRAIN_LIMIT`, else None."""
        s = edge_strain(self.rod, data)
        if s > EDGE_STRAIN_LIMIT:
            return ("edge stretch (relative)", s, "The edge constraint lost hold of the strip: use a smaller "
                    "timestep.")
        return None

    # ------------------------------------------------------------------ readouts
    def lowest_point(self, data: mujoco.MjData, below: float) -> float:
        return float(vertices(self.rod, data)[:, 2].min())

    def centerline(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vertices (x, y, z) (m), shape ``(N + 2,)`` each."""
        x = vertices(self.rod, data)
        return x[:, 0], x[:, 1], x[:, 2]

    def tip_position(self, data: mujoco.MjData) -> tuple[float, float, float]:
        x = vertices(self.rod, data)[-1]
        return float(x[0]), float(x[1]), float(x[2])

    def center_of_mass(self, data: mujoco.MjData) -> np.ndarray:
        m = self.rod.layout.vertex_mass
        return m @ vertices(self.rod, data) / m.sum()

    def arc_length(self) -> np.ndarray:
        return self.rod.layout.s.copy()

    def angles(self, data: mujoco.MjData) -> np.ndarray:
        """Tangent angle of every edge from +x toward +z (rad), in the x-z projection."""
        t = material_frames(self.rod, data)[0]
        return np.arctan2(t[:, 2], t[:, 0])

    def tip_angle(self, data: mujoco.MjData) -> float:
        return float(self.angles(data)[-1])

    def tip_twist(self, data: mujoco.MjData) -> float:
        return tip_twist(self.rod, data)

    def magnetic_couples(self, data: mujoco.MjData, field3: np.ndarray) -> np.ndarray:
        """Couples ``(R m) x B`` on the edges, world frame, shape ``(N + 1, 3)`` (N m)."""
        return np.cross(world_moments(self.rod, data), np.asarray(field3, dtype=float))

# ---------------------------------------------------------------------------------------------- vibration
#: Free-vibration modes :func:`free_vibration` measures.
MODES = ("weak", "strong", "torsion")


def free_vibration(beam: Beam, mode: str, *, segments: int = 20, timestep: float = 1e-4,
                   integrator: str = "discrete", periods: float = 4.0, amplitude: float = 1e-3,
                   grading: float = 1.0) -> tuple[float, np.ndarray, np.ndarray]:
    """First clamped-free frequency (Hz) of the strip in ``mode`` (``weak``: bending about the width axis, tip z;
    ``strong``: about the thickness axis, tip y; ``torsion``: tip twist), measured from free vibration.

    The strip (no gravity, no damping) is settled under a static tip load (a force along z or y, or a couple about
    x) that deflects the tip by ``amplitude`` (fraction of L; rad for torsion), released, and run ``periods``
    periods of the beam formula (:func:`frequencies`); the frequency is the mean rate of the upward zero
    crossings of the tip signal (linearly interpolated), whose spacing the higher modes of the nearly first-mode
    shape barely move. Returns ``(frequency, time, signal)``.
    """
    from .model import RodOptions

    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}.")
    opts = RodOptions(rod="cable", segments=segments, timestep=timestep, integrator=integrator, gravity=0.0,
                      retardation_time=0.0, grading=grading)
    cm = build_cable(beam, opts)
    m = cm.model
    data = mujoco.MjData(m)
    ref = frequencies(beam)[mode]
    L = beam.length
    tip = cm.vertex_body[-1]
    tw = int(cm.twist_dof[-1])
    ei_w, ei_s, gj = (float(v) for v in beam.stiffnesses(np.array([0.5 * L]))[0])

    def load(on: bool) -> None:
        data.xfrc_applied[:] = 0.0
        data.qfrc_applied[:] = 0.0
        if not on:
            return
        if mode == "weak":
            data.xfrc_applied[tip, 2] = 3.0 * ei_w * amplitude / L**2
        elif mode == "strong":
            data.xfrc_applied[tip, 1] = 3.0 * ei_s * amplitude / L**2
        else:
            data.qfrc_applied[tw] = gj * amplitude / L

    def signal() -> float:
        if mode == "torsion":
            return tip_twist(cm, data)
        x = vertices(cm, data)[-1]
        return float(x[2] if mode == "weak" else x[1])

    m.dof_damping[:] = settling_damping(cm)
    load(True)
    w1 = 2.0 * math.pi * frequencies(beam)["weak"]
    for _ in range(int(20.0 / (w1 * timestep)) + 1):  # e^-20 of the initial transient
        mujoco.mj_step(m, data)
    m.dof_damping[:] = 0.0
    load(False)
    n = int(periods / (ref * timestep)) + 1
    sig = np.empty(n)
    for k in range(n):
        mujoco.mj_step(m, data)
        sig[k] = signal()
    time = timestep * np.arange(1, n + 1)
    y = sig - 0.5 * (sig.max() + sig.min())
    up = np.flatnonzero((y[:-1] < 0.0) & (y[1:] >= 0.0))
    if len(up) < 2:
        return math.nan, time, sig
    tc = time[up] - y[up] * timestep / (y[up + 1] - y[up])
    return float((len(tc) - 1) / (tc[-1] - tc[0])), time, sig


# ---------------------------------------------------------------------------------------------- statics
@dataclass(frozen=True)
class CableEquilibrium:
    """A settled flexcomp strip (frozen). SI units.

    Attributes
    ----------
    success : bool
        Every settle along the path met its tolerance.
    message : str
        ``"converged"`` or the settles that did not, separated by ``"; "``.
    field : Field
        Applied field (T).
    s : (N + 2,) ndarray
        Reference arc length of the centreline points (the vertices; m).
    centreline : (N + 2, 3) ndarray
        The vertices (m), clamp to tip.
    tip_position : (3,) ndarray
        The tip (m).
    tip_twist : float
        ``int k3 ds`` (rad), as the analytical :class:`~magsoft_env.theory.rod_solver.RodResult` measures it.
    residual : float
        Settling residual of the last settle: the largest vertex speed over ``omega_1 L`` and twist rate over
        ``omega_1`` (dimensionless; the distance, as a fraction of L, and the angle the rod would still move at its
        slowest decay rate ``omega_1``, the first weak-bending frequency).
    edge_strain : float
        Largest relative change of an edge's length.
    steps : int
        Simulation steps along the whole path.
    """

    success: bool
    message: str
    field: Field
    s: np.ndarray
    centreline: np.ndarray
    tip_position: np.ndarray
    tip_twist: float
    residual: float
    edge_strain: float
    steps: int

    def to_dict(self) -> dict:
        """Metrics as plain numbers (SI), for JSON."""
        return {"success": bool(self.success), "message": self.message,
                "field_T": [float(v) for v in self.field.vector()], "segments": len(self.s) - 2,
                "tip_position_m": [float(v) for v in self.tip_position], "tip_twist_rad": float(self.tip_twist),
                "residual": float(self.residual), "edge_strain": float(self.edge_strain), "steps": int(self.steps)}


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


def _residual(cm: CableModel, data: mujoco.MjData, w1: float) -> float:
    v = data.qvel
    vert = cm.vertex_dof[cm.vertex_body > 0]
    r = float(np.max(np.abs(v[vert]))) / (w1 * cm.beam.length)
    free = cm.twist_dof >= 0
    if np.any(free):
        r = max(r, float(np.max(np.abs(v[cm.twist_dof[free]]))) / w1)
    return r


def settle(cm: CableModel, data: mujoco.MjData, field3, *, tol: float, max_steps: int,
           check_every: int = 20) -> tuple[bool, float, int]:
    """Step with the couples of ``field3`` (T) until the settling residual (see :class:`CableEquilibrium`)
    drops below ``tol``; ``(converged, residual, steps)``. The model's dof damping should be
    :func:`settling_damping`. Raises RuntimeError on a non-finite state."""
    w1 = 2.0 * math.pi * frequencies(cm.beam)["weak"]
    m = cm.model
    steps, res = 0, math.inf
    while steps < max_steps:
        for _ in range(min(check_every, max_steps - steps)):
            apply_field(cm, data, field3)
            mujoco.mj_step(m, data)
            steps += 1
        if not np.all(np.isfinite(data.qpos)):
            raise RuntimeError(f"{CABLE_ROD}: non-finite state after {steps} steps of settling")
        res = _residual(cm, data, w1)
        if res < tol and steps >= 2 * check_every:
            return True, res, steps
    return False, res, steps


def cable_path(beam: Beam, fields, *, gravity: float = 9.81, segments: int = 20, timestep: float = 1e-3,
               integrator: str = "discrete", grading: float | None = None, tol: float = 1e-6,
               max_time: float = 20.0, max_field_step: float = 1e-3, imperfection: float = 0.0,
               retardation_time: float = 5e-3) -> list[CableEquilibrium]:
    """Settle the clamped flexcomp strip along a loading path: gravity first, then each field, reached from the
    previous one in straight-line steps of at most ``max_field_step`` (T), each settled with
    :func:`settling_damping`. Fields are :class:`~magsoft_env.spec.Field` s, triples ``(B_x, B_y, B_z)`` or planar
    pairs ``(B_x, B_z)`` (T).

    ``imperfection`` (T): a field component along z added to every settle of the ramp but the last one of each
    field (a seed for the branches that leave the plane, e.g. lateral-torsional buckling, whose sign it chooses;
    0: none). ``grading`` None is :class:`~magsoft_env.sim.model.RodOptions`' cantilever default.
    """
    from ..validate import finite_number, nonnegative, positive
    from .model import RodOptions

    flist = [as_field(f) for f in as_fields(fields)]
    finite_number("imperfection", imperfection, unit="T")
    positive("tol", tol)
    positive("max_time", max_time, unit="s")
    mstep = positive("max_field_step", max_field_step, unit="T")
    nonnegative("retardation_time", retardation_time, unit="s")
    opts = RodOptions(rod="cable", segments=segments, timestep=timestep, integrator=integrator, gravity=gravity,
                      grading=grading, retardation_time=retardation_time)
    cm = build_cable(beam, opts)
    m = cm.model
    m.dof_damping[:] = settling_damping(cm)
    data = mujoco.MjData(m)
    seed = np.array([0.0, 0.0, float(imperfection)])
    budget = max(1, int(math.ceil(max_time / opts.timestep)))
    ok, res, steps = settle(cm, data, np.zeros(3), tol=tol, max_steps=budget)
    total = steps
    msgs = [] if ok else [f"gravity: residual {res:.3g} after {steps} steps"]
    out = []
    prev = np.zeros(3)
    for f in flist:
        target = f.vector()
        n = max(1, math.ceil(float(np.max(np.abs(target - prev))) / mstep))
        if imperfection:
            n += 1  # the last settle at the field itself, without the seed
        for k in range(1, n + 1):
            b = prev + (target - prev) * min(k / (n - 1 if imperfection else n), 1.0)
            if imperfection and k < n:
                b = b + seed
            ok_k, res, steps = settle(cm, data, b, tol=tol, max_steps=budget)
            total += steps
            if not ok_k:
                ok = False
                msgs.append(f"field ({', '.join(f'{v * 1e3:.4g}' for v in b)}) mT: residual {res:.3g} after "
                            f"{steps} steps")
        prev = target
        x = vertices(cm, data)
        out.append(CableEquilibrium(success=ok, message="; ".join(msgs) if msgs else "converged", field=f,
                                    s=cm.layout.s.copy(), centreline=x, tip_position=x[-1].copy(),
                                    tip_twist=tip_twist(cm, data), residual=res, edge_strain=edge_strain(cm, data),
                                    steps=total))
    return out


def cable_equilibrium(beam: Beam, field, **kwargs) -> CableEquilibrium:
    """Static equilibrium of the clamped flexcomp strip under ``field`` (T), gravity first, then the field ramped
    from zero (see :func:`cable_path` for the keywords).

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> eq = cable_equilibrium(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), (0.0, 0.5e-3, 0.0), gravity=0.0)
    >>> bool(eq.success), round(float(eq.tip_position[1]) * 1e3, 2)
    (True, 1.17)
    """
    return cable_path(beam, [as_field(field)], **kwargs)[0]


__all__ = [
    "CABLE_ROD", "DEFAULT_FLOOR_CONTACT", "EDGE_STRAIN_LIMIT", "FLOOR_CONTACTS", "MODES", "CableEquilibrium",
    "CableLayout", "CableModel", "CableRod",
    "ContactRecord",
    "apply_field", "build_cable", "cable_equilibrium", "cable_layout", "cable_path", "edge_strain",
    "elastic_energy", "free_vibration", "frequencies", "magnetic_energy", "material_frames", "settle",
    "settling_damping", "tip_twist", "vertices", "world_moments",
]

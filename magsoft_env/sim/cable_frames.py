"""The 3D strip's geometry from a MuJoCo state: vertices, material frames, magnetic moments and couples, twist,
edge strain and elastic energy (:mod:`~magsoft_env.sim.cable_build` has the model and the conventions).

Material frame from the MuJoCo state: MuJoCo keeps, per edge, a time-parallel reference frame ``(t_old, u_old)``
in ``mjData.plastic`` (the tangent and director when it last computed the rod's forces). The reference
director at the current state is ``u_old`` parallel-transported from ``t_old`` to the current tangent ``t``
(the rotation about ``t_old x t``); the material frame turns it by the edge's twist angle ``theta`` (its hinge
``qpos``) about ``t``: ``d1 = cos(theta) u + sin(theta) t x u``, ``d2 = t x d1``. At rest ``u = +y``: ``d1`` is the
width axis and ``d2 = +z`` the thickness axis of a strip lying flat. The sign of ``theta`` was checked against
MuJoCo's own elastic forces (a bend in a skewed plane pulls the weak axis toward the bending binormal through
``qfrc_passive``, tests/test_cable.py). Before the first step (``plastic`` all zero) the reference is the
rest director ``+y`` transported from the rest tangent ``+x``.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .cable_build import CableModel

# columns (1, 2, 0) then (2, 0, 1) of a, (2, 0, 1) then (1, 2, 0) of b
_J1, _J2 = np.array([1, 2, 0, 2, 0, 1]), np.array([2, 0, 1, 1, 2, 0])


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of ``(n, 3)`` arrays (``np.cross`` costs 2-3x more at these sizes): the products
    ``a_j b_k`` and ``a_k b_j`` in one pass, then their difference."""
    p = np.take(a, _J1, 1) * np.take(b, _J2, 1)
    return p[:, :3] - p[:, 3:]


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


def _block(adr: np.ndarray):
    """``adr`` (ints) as a slice where they are consecutive (a view of ``qpos`` instead of a gather), else as is."""
    adr = np.asarray(adr).ravel()
    if adr.size and np.array_equal(adr, np.arange(adr[0], adr[0] + adr.size)):
        return slice(int(adr[0]), int(adr[0]) + adr.size)
    return adr


class CoupleWriter:
    """Writes the magnetic couples of a field into ``mjData`` before a step: :func:`apply_field` with its index
    arrays, moment columns and sums prepared once (the 3D rod calls it every step; numpy's per-call overhead is
    most of its cost, so it makes few calls).

    The force pair of edge ``i`` is ``(C_i x t_i) / l_i`` with ``C_i = M_i x B`` the couple of its world moment
    ``M_i = m_a t + m_w d1 + m_t d2``, and its twist moment ``C_i . t_i``. With the axial part (:meth:`write`) they
    are computed so, operation for operation as :func:`material_frames` and the frame formula (the strip's
    trajectories stay those of the formula to the last bit). Without it (the poles apply the axial part), and for a
    :meth:`write_source`, the rearranged form: since ``M_i . t_i = m_a``, ``C_i x t_i = m_a B - (B . t_i) M_i``,
    and ``C_i . t_i = B . (t_i x M_i)`` with ``t x d1 = d2``, ``t x d2 = -d1``; its transverse part
    ``m_w d1 + m_t d2 = r (cos psi u + sin psi v)`` with ``psi = theta + atan2(m_t, m_w)`` and ``(u, v = t x u)``
    the transported reference frame (:meth:`frames`; the transport keeps ``u`` a unit vector, so it is not
    normalized again: a round-off difference from :func:`material_frames`).

    Parameters
    ----------
    cm : CableModel
    axial : bool
        Apply the axial magnetization's couples too (False: MuJoCo applies them, the poles of
        :func:`~magsoft_env.sim.cable_build.build_cable`; they still count in the net moment).
    """

    def __init__(self, cm: CableModel, *, axial: bool = True):
        self.cm = cm
        self.axial = bool(axial)
        free = cm.vertex_qpos[:, 0] >= 0
        # pinned vertices (a clamp) come first
        f0 = int(np.argmax(free)) if free.any() else len(free)
        if not free[f0:].all():
            raise RuntimeError("the strip's pinned vertices must lead")  # guaranteed by build_cable
        self._f0 = f0
        self._vq = _block(cm.vertex_qpos[f0:])
        self._nfree = len(free) - f0
        self._x = cm.vertex_ref.copy()
        self._ref = cm.vertex_ref[f0:].copy()
        tw = cm.twist_qpos >= 0
        self._t0 = int(np.argmax(tw)) if tw.any() else len(tw)
        if not tw[self._t0:].all():
            raise RuntimeError("the strip's clamped edge must lead")  # guaranteed by build_cable
        self._tq = _block(cm.twist_qpos[self._t0:])
        self._td = _block(cm.twist_dof[self._t0:])
        ne = len(tw)
        self._theta = np.zeros(ne)
        m = cm.layout.moment
        self._m0, self._m1, self._m2 = (np.ascontiguousarray(m[:, k:k + 1]) for k in range(3))
        self._bx = np.zeros((3, 3))
        self._bx_at, self._bx_of = np.array([1, 2, 3, 5, 6, 7]), np.array([2, 1, 2, 0, 1, 0])
        self._bx_sign = np.array([-1.0, 1.0, 1.0, -1.0, -1.0, 1.0])
        self._ma = np.ascontiguousarray(m[:, :1])
        self._phi0 = np.arctan2(m[:, 2], m[:, 1])
        self._r = np.hypot(m[:, 1], m[:, 2])
        self._body = _block(cm.vertex_body[f0:])
        a = int(cm.model.flex_plasticadr[cm.flex])
        self._plastic = slice(a, a + 6 * ne)
        self._rest = np.tile([1.0, 0.0, 0.0, 0.0, 1.0, 0.0], (ne, 1))  # (t_old, u_old) before the first step
        self._one = np.ones(3)
        # a x b from the outer product a b^T (row-major, 9 entries): (a b^T).ravel() @ _EPS
        self._eps = np.zeros((9, 3))
        for i, j, k in ((1, 2, 0), (2, 0, 1), (0, 1, 2)):
            self._eps[3 * i + j, k], self._eps[3 * j + i, k] = 1.0, -1.0
        # edge pairs to vertex forces: +F on the edge's end vertex, -F on its start (the free vertices' rows)
        d = np.zeros((len(free), ne))
        d[np.arange(1, ne + 1), np.arange(ne)] = 1.0
        d[np.arange(ne), np.arange(ne)] = -1.0
        self._pairs = np.ascontiguousarray(d[f0:])
        self._fv = np.zeros((len(free), 3))

    def frames(self, data: mujoco.MjData):
        """The geometry of the state in ``data`` the couples need: ``(x, inv, t, u, v, alpha, beta, mperp)``, the
        vertices ``(N + 2, 3)`` (m; an array this writer reuses), the edges' inverse lengths (1/m), unit tangents,
        transported reference frame ``(u, v = t x u)``, the transverse moment's components along ``u`` and ``v``
        (A m^2) and the transverse moment ``alpha u + beta v`` itself."""
        one = self._one
        x = self._x
        q = data.qpos
        x[self._f0:] = self._ref + q[self._vq].reshape(self._nfree, 3)
        e = x[1:] - x[:-1]
        inv = 1.0 / np.sqrt((e * e) @ one)
        t = e * inv[:, None]
        p = data.plastic[self._plastic].reshape(-1, 6)
        if not (p.item(0) or p.item(1) or p.item(2)):  # no reference frame stored yet (before the first step)
            p = self._rest
        t_old, u_old = p[:, :3], p[:, 3:]
        u = u_old - (((t * u_old) @ one) / (1.0 + (t_old * t) @ one))[:, None] * (t_old + t)
        v = (t[:, :, None] * u[:, None, :]).reshape(-1, 9) @ self._eps
        theta = self._theta  # a clamped edge's stays 0
        theta[self._t0:] = q[self._tq]
        psi = theta + self._phi0
        alpha = self._r * np.cos(psi)
        beta = self._r * np.sin(psi)
        mperp = alpha[:, None] * u + beta[:, None] * v
        return x, inv, t, u, v, alpha, beta, mperp

    def write_source(self, data: mujoco.MjData, field3: np.ndarray, source, extra: np.ndarray | None = None,
                     net_moment: np.ndarray | None = None) -> None:
        """Write the loads of the uniform field ``(B_x, B_y, B_z)`` (T) plus a non-uniform ``source``
        (:class:`~magsoft_env.sim.sources.SourceField`) at the state in ``data``: every edge's world moment ``M_i``
        (axial part included, whatever :attr:`axial` says) in the field ``B_i = B + B_s(p_i)`` at its midpoint
        ``p_i`` (one call of the source for all edges), its couple ``M_i x B_i`` written as :meth:`write` writes the
        couples, and the force ``G_s(p_i)^T M_i`` at the midpoint, half to each vertex (the midpoint is their
        centroid: no moment arm). ``extra`` and ``net_moment`` as :meth:`write`; the entries it never writes are left
        as they are (``clear=False``)."""
        one = self._one
        x, inv, t, u, v, alpha, beta, mperp = self.frames(data)
        mw = self._ma * t + mperp
        if net_moment is not None:
            net_moment[:] = mw.sum(axis=0)
        Bs, Gs = source(0.5 * (x[1:] + x[:-1]), float(data.time))
        B = Bs + field3
        bt = (t * B) @ one
        F = self._ma * B - bt[:, None] * mw
        twist = alpha * ((v * B) @ one) - beta * ((u * B) @ one)
        force = np.matmul(mw[:, None, :], Gs)[:, 0, :]  # G^T M
        if extra is not None:
            F += (extra[:, 3:, None] * t[:, None, :]).reshape(-1, 9) @ self._eps
            twist += (extra[:, 3:] * t) @ one
            force += extra[:, :3]
        F *= inv[:, None]
        fv = self._pairs @ F + np.abs(self._pairs) @ (0.5 * force)
        data.xfrc_applied[self._body, :3] = fv
        data.qfrc_applied[self._td] = twist[self._t0:]

    def write(self, data: mujoco.MjData, field3: np.ndarray, extra: np.ndarray | None = None,
              net_moment: np.ndarray | None = None, *, clear: bool = True) -> None:
        """Write the couples of the field ``(B_x, B_y, B_z)`` (T) at the state in ``data`` (see :func:`apply_field`).
        ``clear`` False: leave the entries it never writes (vertex torques, non-twist dofs of ``qfrc_applied``) as
        they are, zero since the last clearing write (the 3D rod clears once per call, not every step).

        With the axial part (:attr:`axial`) the arithmetic is the frame formula's, operation for operation: the
        material frames as :func:`material_frames` computes them, ``C = M @ [B]x``, the pairs ``(C x t) / l`` summed
        per vertex as ``+F`` then ``-F``, the twist ``C . t`` (the strip's trajectories are those of the formula to
        the last bit; :meth:`_write_transverse`'s rearranged form differs from it by round-off)."""
        if not self.axial:
            self._write_transverse(data, field3, extra, net_moment, clear)
            return
        B = field3
        x = self._x
        q = data.qpos
        x[self._f0:] = self._ref + q[self._vq].reshape(self._nfree, 3)
        # material_frames, with its index arrays prepared
        e = x[1:] - x[:-1]
        le = np.sqrt(_dot(e, e))[:, None]
        t = e / le
        p = data.plastic[self._plastic].reshape(-1, 6)
        if not (p.item(0) or p.item(1) or p.item(2)):  # no reference frame stored yet (before the first step)
            p = self._rest
        t_old, u_old = p[:, :3], p[:, 3:]
        u = _transport(u_old, t_old, t)
        u /= np.sqrt(_dot(u, u))[:, None]
        theta = self._theta  # a clamped edge's stays 0
        theta[self._t0:] = q[self._tq]
        v = _cross(t, u)
        c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
        mw = self._m0 * t + self._m1 * (c * u + s * v) + self._m2 * (c * v - s * u)
        if net_moment is not None:
            net_moment[:] = mw.sum(axis=0)
        # m x B for every row: m @ [B]x, [B]x = [[0, -B_z, B_y], [B_z, 0, -B_x], [-B_y, B_x, 0]]
        bx = self._bx
        bx.flat[self._bx_at] = B[self._bx_of] * self._bx_sign
        C = mw @ bx
        if extra is not None:
            C = C + extra[:, 3:]
        # the pair's lever is the edge's current length: its couple is C whatever the edge's strain
        F = _cross(C, t) / le
        fv = self._fv
        fv[:] = 0.0
        fv[1:] += F
        fv[:-1] -= F
        if extra is not None:
            fv[1:] += 0.5 * extra[:, :3]
            fv[:-1] += 0.5 * extra[:, :3]
        xf = data.xfrc_applied
        xf[self._body, :3] = fv[self._f0:]
        qf = data.qfrc_applied
        if clear:
            xf[self._body, 3:] = 0.0
            qf[:] = 0.0
        qf[self._td] = _dot(C, t)[self._t0:]

    def _write_transverse(self, data: mujoco.MjData, field3: np.ndarray, extra: np.ndarray | None,
                          net_moment: np.ndarray | None, clear: bool) -> None:
        """:meth:`write` without the axial part (MuJoCo's poles apply it): the force pairs ``-(B . t) M_perp / l`` and
        twist moments ``B . (t x M_perp)`` of the transverse moment (the class docstring's rearranged formula)."""
        B = field3
        one = self._one
        _, inv, t, u, v, alpha, beta, mperp = self.frames(data)
        bt = t @ B
        if net_moment is not None:
            net_moment[:] = (self._ma * t + mperp).sum(axis=0)
        F = -bt[:, None] * mperp
        twist = alpha * (v @ B) - beta * (u @ B)
        if extra is not None:
            F += (extra[:, 3:, None] * t[:, None, :]).reshape(-1, 9) @ self._eps
            twist += (extra[:, 3:] * t) @ one
        # the pair's lever is the edge's current length: its couple is C whatever the edge's strain
        F *= inv[:, None]
        fv = self._pairs @ F
        if extra is not None:
            fv += np.abs(self._pairs) @ (0.5 * extra[:, :3])
        xf = data.xfrc_applied
        xf[self._body, :3] = fv
        qf = data.qfrc_applied
        if clear:
            xf[self._body, 3:] = 0.0
            qf[:] = 0.0
        qf[self._td] = twist[self._t0:]


def apply_field(cm: CableModel, data: mujoco.MjData, field3, extra: np.ndarray | None = None,
                net_moment: np.ndarray | None = None, *, axial: bool = True) -> None:
    """Write the magnetic couples of the field ``(B_x, B_y, B_z)`` (T) into ``data``: the force pair of each
    edge into ``xfrc_applied`` (rows of the vertex bodies, overwritten), the along-edge part into
    ``qfrc_applied`` (the twist dofs, overwritten; other dofs zeroed). A clamped edge's couple goes to the clamp
    (nothing applied). ``extra``: a world wrench per edge ``(N + 1, 6)`` added (force at the edge's middle, half
    to each vertex; couple as the magnetic ones). ``net_moment``: a ``(3,)`` array that receives the net magnetic
    moment ``sum R_i m_i`` of the state (A m^2). ``axial`` False: leave the axial magnetization's couples to
    MuJoCo's poles (:func:`~magsoft_env.sim.cable_build.build_cable`). The same as :class:`CoupleWriter`, which
    the 3D rod keeps to write them every step."""
    CoupleWriter(cm, axial=axial).write(data, np.asarray(field3, dtype=float), extra, net_moment)


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


__all__ = ["EDGE_STRAIN_LIMIT", "CoupleWriter", "apply_field", "edge_strain", "elastic_energy", "magnetic_energy",
           "material_frames", "tip_twist", "vertices", "world_moments"]

"""The Kirchhoff rod in three dimensions, sampled on a collocation grid.

A strip of reference arc length s in [0, L] carries a material frame (d1 across its width, d2
through its thickness, d3 = r' its tangent), stored as unit quaternions q(s): ``R(q) = [d1 d2 d3]``
maps body to world coordinates. Undeformed and clamped, ``d1 = y``, ``d2 = z``, ``d3 = x``.
The static Kirchhoff rod (inextensible, unshearable) under dead loads::

    n' + f = 0,   m' + r' x n + c = 0,   m = R diag(E I_w, E I_s, G J) k,   R' = R [k]x

with f = -rho A g z the weight per length and c = (A B_r / mu0) (R m_hat) x B the magnetic couple
per length of a magnetization that turns with the cross-section (``m_hat`` the body-frame
direction of B_r). The force is explicit, ``n(s) = -g W1(s) z`` with ``W1(s) = int_s^L rho A``, and
moment balance integrates from the free tip::

    m_s(s) = int_s^L (d3 x n + c) du,        residual  e(s) = R B k - m_s(s) = 0

with the curvature ``k = 2 vec(conj(q) q')`` taken by spectral differentiation. ``e`` is also the
L2 gradient of the total energy ``U = int 1/2 k.B k - (R a).B + g W1 d3.z`` with respect to
``u = psi'`` for a spatial rotation ``exp([psi]x) R`` with ``psi(0) = 0``; so the Jacobian of ``e``
at an equilibrium is the second variation in those variables (:meth:`RodModel.hessian`).

Jacobians are exact: every quantity is a polynomial in the quaternion components and the
perturbation ``q + (1/2)(0, psi) q`` is linear, so a complex step (:data:`_H`) gives the
derivative to rounding.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from .collocation import Grid

#: Quaternion of the undeformed clamp frame [d1 d2 d3] = [y z x]: a third of a turn about (1, 1, 1).
CLAMP_QUATERNION = np.array([0.5, 0.5, 0.5, 0.5])
_H = 1e-30  # complex step
_EZ = np.array([0.0, 0.0, 1.0])


class Load3(NamedTuple):
    """One load state: field (T, three components) and gravity (m/s^2, along -z)."""

    Bx: float
    By: float
    Bz: float
    g: float

    def lerp(self, other: Load3, t: float) -> Load3:
        return Load3(*(a + t * (b - a) for a, b in zip(self, other, strict=True)))

    def minus(self, other: Load3) -> Load3:
        return Load3(*(a - b for a, b in zip(self, other, strict=True)))

    @property
    def B(self) -> np.ndarray:
        return np.array([self.Bx, self.By, self.Bz])


# quaternions, scalar first, on the last axis ------------------------------------------------------
def _qmul_slow(p, q):
    pw, px, py, pz = p[..., 0], p[..., 1], p[..., 2], p[..., 3]
    qw, qx, qy, qz = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.stack([pw * qw - px * qx - py * qy - pz * qz,
                     pw * qx + px * qw + py * qz - pz * qy,
                     pw * qy - px * qz + py * qw + pz * qx,
                     pw * qz + px * qy - py * qx + pz * qw], axis=-1)


_I4 = np.eye(4)
#: Structure constants: (p q)_i = C_ijk p_j q_k.
_C = np.stack([_qmul_slow(_I4[j], _I4[k]) for j in range(4) for k in range(4)]).reshape(4, 4, 4).transpose(2, 0, 1)
_CL = np.ascontiguousarray(_C.transpose(1, 0, 2).reshape(4, 16))  # p -> L(p) flattened: L(p)_ik = C_ijk p_j
_CR = np.ascontiguousarray(_C.transpose(2, 0, 1).reshape(4, 16))  # q -> R(q) flattened: R(q)_ij = C_ijk q_k
_CONJ = np.array([1.0, -1.0, -1.0, -1.0])
#: Rotation matrix as a quadratic form: R(q)_ab = Q_abjk q_j q_k for unit q.
_Q = np.zeros((3, 3, 4, 4))
for _j in range(4):
    for _k in range(4):
        _e = 0.5 * (np.outer(_I4[_j], _I4[_k]) + np.outer(_I4[_k], _I4[_j]))
        for _a in range(3):
            # R v = vec(q (0, v) conj(q)): column a from v = e_a
            _v = np.zeros(4)
            _v[_a + 1] = 1.0
            _Q[:, _a, _j, _k] = np.einsum("ijk,j,k->i", _C, np.einsum("ijk,j,k->i", _C, _I4[_j], _v),
                                          _I4[_k] * _CONJ)[1:]
_Q = 0.5 * (_Q + _Q.transpose(0, 1, 3, 2))
_QF = np.ascontiguousarray(_Q.reshape(9, 16))
_EPS = np.zeros((3, 3, 3))
_EPS[0, 1, 2] = _EPS[1, 2, 0] = _EPS[2, 0, 1] = 1.0
_EPS[0, 2, 1] = _EPS[2, 1, 0] = _EPS[1, 0, 2] = -1.0
_SK = np.ascontiguousarray((-_EPS).transpose(2, 0, 1).reshape(3, 9))  # v -> [v]x flattened


def qmul(p, q):
    """Quaternion product p q (arrays (..., 4), real or complex)."""
    return np.einsum("...ik,...k->...i", _left(p), q)


def qconj(q):
    return q * _CONJ


def qmat(q):
    """Rotation matrices (..., 3, 3) of unit quaternions (a quadratic form: exact under a complex step)."""
    qq = (q[..., :, None] * q[..., None, :]).reshape(q.shape[:-1] + (16,))
    return (qq @ _QF.T).reshape(q.shape[:-1] + (3, 3))


def qexp(psi):
    """Unit quaternions of the rotations by the rotation vectors ``psi`` (..., 3) (rad)."""
    a = np.linalg.norm(psi, axis=-1)
    half = 0.5 * a
    sinc = np.where(a > 1e-8, np.sin(half) / np.where(a > 1e-8, a, 1.0), 0.5 - a * a / 48.0)
    return np.concatenate([np.cos(half)[..., None], sinc[..., None] * psi], axis=-1)


def rotate(q, psi):
    """Quaternion field ``q`` turned by the spatial rotation vectors ``psi`` (same leading shape)."""
    out = qmul(qexp(psi), q)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def clamp_quaternion(clamp_angle: float) -> np.ndarray:
    """The clamp frame turned by ``clamp_angle`` (rad) about -y: the planar clamp angle theta_0."""
    return qmul(np.array([math.cos(clamp_angle / 2), 0.0, -math.sin(clamp_angle / 2), 0.0]), CLAMP_QUATERNION)


def _left(q):
    """Matrices (..., 4, 4) of left multiplication by q: q p = L(q) p."""
    return (q @ _CL).reshape(q.shape[:-1] + (4, 4))


def _right(q):
    """Matrices (..., 4, 4) of right multiplication by q: p q = R(q) p."""
    return (q @ _CR).reshape(q.shape[:-1] + (4, 4))


def _skew(v):
    """Cross-product matrices (..., 3, 3): [v]x u = v x u."""
    return (v @ _SK).reshape(v.shape[:-1] + (3, 3))


def angle_between(q1, q2) -> np.ndarray:
    """Rotation angle (rad) between two quaternion fields, pointwise (sign of q ignored)."""
    d = np.abs(np.sum(q1 * q2, axis=-1))
    return 2.0 * np.arccos(np.clip(d, -1.0, 1.0))


class RodModel:
    """Coefficients of one beam on one grid, and the residual, Jacobian, energy and second variation.

    ``support`` is ``"cantilever"`` (the frame at s = 0 is fixed) or ``"free"`` (the rotation at
    s = 0, ``c``, is three more unknowns and the net moment ``m_s(0) = 0`` three more equations)."""

    def __init__(self, beam, grid: Grid, *, free: bool, clamp_angle: float = 0.0):
        self.beam, self.grid, self.free = beam, grid, free
        s = grid.s_eval
        M = grid.M
        self.K = np.asarray(beam.stiffnesses(s), dtype=float)  # (M, 3): E I_w, E I_s, G J
        m_hat = np.asarray(beam.magnetization_direction(s), dtype=float)  # (axial, width, thickness)
        # body-frame magnetic moment per length in material coordinates (d1, d2, d3) = (width, thickness, axial)
        self.a = beam.moment_per_length(s)[:, None] * m_hat[:, [1, 2, 0]]
        self.W1 = grid.QL @ beam.mass_per_length(s)  # weight beyond s per unit g (kg)
        self.D, self.Q0, self.QL, self.w = grid._D, grid.Q0, grid.QL, grid.w
        self.L = float(beam.length)
        self.EI_ref = float(self.w @ self.K[:, 0]) / self.L
        self.scale = self.L / self.EI_ref  # residual (N m) -> rad
        # distinct nodes: psi lives on them (clamped: without s = 0)
        uniq = grid.unique()
        expand = np.searchsorted(uniq, np.arange(M), side="right") - 1
        E = np.zeros((M, uniq.size))
        E[np.arange(M), expand] = 1.0
        self.uniq, self.expand = uniq, expand
        self.E = E if free else E[:, 1:]
        self.DE = self.D @ self.E
        self.mass = np.repeat(self.E.T @ self.w, 3)  # lumped L2 mass of psi, per component
        self.q0 = clamp_quaternion(clamp_angle)
        # Newton's unknowns: a spatial rotation psi at every node; unknown (p, c) is psi = e_c at node p
        dirs = np.zeros((3 * M, M, 3))
        for c in range(3):
            dirs[c::3, :, c] = np.eye(M)
        self.dirs = dirs
        npsi = self.E.shape[1]
        pdirs = np.zeros((3 * npsi, M, 3))
        for c in range(3):
            pdirs[c::3, :, c] = self.E.T
        self.pdirs = pdirs  # psi basis on distinct nodes

    # pieces ----------------------------------------------------------------------------------------
    def loads(self, q, load: Load3):
        """Frames R (..., M, 3, 3), load couple density l = c + d3 x n (..., M, 3) (N)."""
        R = qmat(q)
        ma = np.einsum("...ij,...j->...i", R, self.a)
        lam = ma @ _skew(load.B)  # ma x B
        if load.g:
            d3 = R[..., :, 2]
            gw = load.g * self.W1
            lam = lam + np.stack([-gw * d3[..., 1], gw * d3[..., 0], np.zeros_like(gw * d3[..., 0])], axis=-1)
        return R, lam

    def curvature(self, q):
        """Material curvature k (..., M, 3) (1/m), spectral."""
        return 2.0 * qmul(qconj(q), np.matmul(self.D, q))[..., 1:]

    def residual(self, q, load: Load3):
        """Moment-balance residual e = R B k - m_s (..., M, 3) (N m) with k by spectral differentiation,
        and the moment m_s (..., M, 3) (N m): the energy gradient (see the module docstring)."""
        R, lam = self.loads(q, load)
        ms = np.matmul(self.QL, lam)
        e = np.einsum("...ij,...j->...i", R, self.K * self.curvature(q)) - ms
        return e, ms

    def system(self, q, load: Load3):
        """Collocation residual F (..., 3 M) (rad): the integral form of the kinematics,
        ``G = q - q(0) - Q0 (1/2 q (0, k))`` with the curvature ``k = B^-1 R^T m_s`` from moment
        balance, as the rotation ``2 vec(conj(q) G)`` at each node. Row 0 is the clamp,
        ``2 vec(conj(q(0)) (q(0) - q0))``, or on a free beam the net moment ``L m_s(0) / E I_w``."""
        R, lam = self.loads(q, load)
        ms = np.matmul(self.QL, lam)
        k = np.einsum("...ji,...j->...i", R, ms) / self.K
        rate = 0.5 * qmul(q, np.concatenate([np.zeros(k.shape[:-1] + (1,)), k], axis=-1))
        G = q - np.matmul(self.Q0, rate)
        if self.free:
            G = G - q[..., 0:1, :]
        else:
            G = G - self.q0
        F = 2.0 * qmul(qconj(q), G)[..., 1:]
        if self.free:
            F[..., 0, :] = ms[..., 0, :] * self.scale
        return F.reshape(F.shape[:-2] + (-1,))

    def _perturbed(self, q, dirs):
        return q + (1j * _H) * 0.5 * qmul(np.concatenate([np.zeros(dirs.shape[:-1] + (1,)), dirs], axis=-1), q)

    def jacobian(self, q, load: Load3):
        """F and its exact Jacobian dF/dpsi (3 M, 3 M) for spatial rotations psi at every node,
        assembled from the linearization (see :meth:`jacobian_cs` for the same by a complex step).

        With ``dq_p = T_p psi_p``, ``T_p = (1/2) R(q_p) P`` (P embeds a vector as a pure
        quaternion; L(q), R(q) the matrices of left and right multiplication by q)::

            d lam_p = Lam_p psi_p,       Lam = [B]x [R a]x + [n]x [d3]x
            d m_j   = sum_p QL_jp Lam_p psi_p
            d k_j   = K_j^-1 R_j^T ([m_j]x psi_j + d m_j)
            d r_j   = (1/2) R((0, k_j)) T_j psi_j + (1/2) L(q_j) P d k_j
            d G_i   = T_i psi_i - sum_j Q0_ij d r_j
            d F_i   = 2 P^T (L(conj q_i) d G_i + R(G_i) C T_i psi_i)

        so that ``J = local blocks + Q0 (QL_jp A_j Lam_p)`` with ``A_j = (1/2) L(q_j) P K_j^-1 R_j^T``:
        one dense product of M x M by M x 12 M."""
        M = q.shape[0]
        R, lam = self.loads(q, load)
        ms = self.QL @ lam
        Kinv = 1.0 / self.K
        k = np.einsum("mji,mj->mi", R, ms) * Kinv
        rate = 0.5 * qmul(q, np.concatenate([np.zeros((M, 1)), k], axis=1))
        G = q - self.Q0 @ rate - (q[0:1] if self.free else self.q0)
        F = 2.0 * qmul(qconj(q), G)[:, 1:]
        Lq, Rq = _left(q), _right(q)
        T = 0.5 * Rq[:, :, 1:]  # (M, 4, 3)
        ma = np.einsum("mij,mj->mi", R, self.a)
        Lam = _skew(np.broadcast_to(load.B, ma.shape)) @ _skew(ma)
        if load.g:
            n = np.zeros_like(ma)
            n[:, 2] = -load.g * self.W1
            Lam = Lam + _skew(n) @ _skew(R[:, :, 2])
        RtK = np.swapaxes(R, 1, 2) * Kinv[:, :, None]  # K^-1 R^T (M, 3, 3)
        A = 0.5 * Lq[:, :, 1:] @ RtK  # (M, 4, 3)
        # Y[j, :, p, :] = QL_jp A_j Lam_p, plus on the diagonal the local part of d r_p:
        # (1/2) R((0, k_p)) T_p + A_p [m_p]x
        Y = (A.reshape(4 * M, 3) @ Lam.transpose(1, 0, 2).reshape(3, 3 * M)).reshape(M, 4, M, 3)
        Y *= self.QL[:, None, :, None]
        kq = np.concatenate([np.zeros((M, 1)), k], axis=1)
        idx = np.arange(M)
        Y[idx, :, idx, :] += 0.5 * _right(kq) @ T + A @ _skew(ms)
        dG = (self.Q0 @ Y.reshape(M, 12 * M)).reshape(M, 4, M, 3)  # d G = T psi - Q0 Y psi
        dG *= -1.0
        dG[idx, :, idx, :] += T
        if self.free:
            dG[:, :, 0, :] -= T[0]  # G = q - q(0) - ...
        Lc = _left(qconj(q))[:, 1:, :]  # (M, 3, 4): P^T L(conj q)
        Jb = np.matmul(Lc, dG.reshape(M, 4, 3 * M)).reshape(M, 3, M, 3)
        Jb[idx, :, idx, :] += (_right(G)[:, 1:, :] * np.array([1.0, -1.0, -1.0, -1.0])) @ T
        Jb *= 2.0
        if self.free:
            # row 0: the net moment scale * m_0; its derivative scale * QL_0p Lam_p
            Jb[0] = (self.scale * self.QL[0][None, :, None]) * Lam.transpose(1, 0, 2)
            F[0] = ms[0] * self.scale
        return F.reshape(-1), Jb.reshape(3 * M, 3 * M)

    def jacobian_cs(self, q, load: Load3):
        """F and the Jacobian by a complex step (exact to rounding; slower): the check of :meth:`jacobian`."""
        F = self.system(q, load)
        Jt = self.system(self._perturbed(q, self.dirs), load).imag / _H
        return F, Jt.T

    def load_rate(self, q, dload: Load3):
        """dF/dt when the load moves by ``dload`` per unit t (m_s is linear in the load)."""
        R, lam = self.loads(q, dload)
        ms = self.QL @ lam
        k = np.einsum("mji,mj->mi", R, ms) / self.K
        rate = 0.5 * qmul(q, np.concatenate([np.zeros((k.shape[0], 1)), k], axis=-1))
        F = 2.0 * qmul(qconj(q), -(self.Q0 @ rate))[:, 1:]
        if self.free:
            F[0] = ms[0] * self.scale
        return F.reshape(-1)

    @staticmethod
    def psi(x):
        """Rotation field psi (M, 3) (rad) of an update of the unknowns."""
        return x.reshape(-1, 3)

    # energy and second variation ------------------------------------------------------------------
    def energy(self, q, load: Load3) -> float:
        """Total potential energy (J): bending and twist, magnetic, gravity."""
        k = self.curvature(q)
        R = qmat(q)
        ma = np.einsum("...ij,...j->...i", R, self.a)
        dens = 0.5 * np.sum(self.K * k * k, axis=-1) - ma @ load.B + load.g * self.W1 * R[:, 2, 2]
        return float(self.w @ dens)

    def gradient(self, q, load: Load3):
        """Exact gradient of the discrete energy :meth:`energy` with respect to spatial rotations psi at
        the distinct nodes (3 per node; N m), for ``q -> exp(psi / 2) q``.

        With ``k_i = 2 vec(conj(q_i) q'_i)``, ``q' = D q``, a rotation psi_j changes ``k_i`` by
        ``-vec(conj(q_i) (0, psi_i) q'_i) delta_ij + D_ij vec(conj(q_i) (0, psi_j) q_j)``; the adjoint of
        ``psi -> vec(p (0, psi) r)`` is ``a -> vec(conj(p) (0, a) conj(r))``, so::

            g_j = -w_j vec(q_j (0, K k_j) conj(q'_j)) + vec((D^T (w q (0, K k)))_j conj(q_j))
                  - w_j c_j + w_j g W1_j (d3_j x z)
        """
        dq = np.matmul(self.D, q)
        k = 2.0 * qmul(qconj(q), dq)[..., 1:]
        Kk = np.concatenate([np.zeros(k.shape[:-1] + (1,)), self.K * k], axis=-1)
        u = qmul(q, Kk)
        gl = -self.w[:, None] * qmul(u, qconj(dq))[..., 1:]
        gn = qmul(np.matmul(self.D.T, self.w[:, None] * u), qconj(q))[..., 1:]
        R, lam = self.loads(q, load)  # lam = c + d3 x n, and d3 x n = g W1 (z x d3)... see loads
        g = gl + gn - self.w[:, None] * lam
        g = np.matmul(self.E.T, g)
        return g.reshape(g.shape[:-2] + (-1,))

    def hessian(self, q, load: Load3):
        """Gradient and second variation (symmetrized) of the discrete energy with respect to psi on the
        distinct nodes: the linearization of :meth:`gradient` (``d q_j = T_j psi_j``,
        ``d q' = D d q``, then each product rule in turn), checked against :meth:`hessian_cs`."""
        M = q.shape[0]
        n3 = 3 * M
        dq = self.D @ q
        k = 2.0 * qmul(qconj(q), dq)[:, 1:]
        Kk = np.concatenate([np.zeros((M, 1)), self.K * k], axis=1)
        u = qmul(q, Kk)
        V = self.D.T @ (self.w[:, None] * u)
        R, lam = self.loads(q, load)
        g = -self.w[:, None] * qmul(u, qconj(dq))[:, 1:] + qmul(V, qconj(q))[:, 1:] - self.w[:, None] * lam
        # unit rotations psi at every node (columns), as quaternion changes (M, 4, 3 M)
        T = 0.5 * _right(q)[:, :, 1:]
        X = np.zeros((M, 4, n3))
        idx = np.arange(M)
        for c in range(3):
            X[idx, :, 3 * idx + c] = T[:, :, c]
        Xp = (self.D @ X.reshape(M, 4 * n3)).reshape(M, 4, n3)
        Lcq, Rdq = _left(qconj(q)), _right(dq)
        dk = 2.0 * (np.matmul(Lcq[:, 1:, :], Xp) + np.matmul(Rdq[:, 1:, :] * _CONJ, X))
        du = np.matmul(_right(Kk), X) + np.matmul(_left(q)[:, :, 1:] * self.K[:, None, :], dk)
        H = -self.w[:, None, None] * (np.matmul(_right(qconj(dq))[:, 1:, :], du)
                                      + np.matmul(_left(u)[:, 1:, :] * _CONJ, Xp))
        dV = (self.D.T @ (self.w[:, None, None] * du).reshape(M, 4 * n3)).reshape(M, 4, n3)
        H += np.matmul(_right(qconj(q))[:, 1:, :], dV) + np.matmul(_left(V)[:, 1:, :] * _CONJ, X)
        ma = np.einsum("mij,mj->mi", R, self.a)
        Lam = _skew(np.broadcast_to(load.B, ma.shape)) @ _skew(ma)
        if load.g:
            nf = np.zeros_like(ma)
            nf[:, 2] = -load.g * self.W1
            Lam = Lam + _skew(nf) @ _skew(R[:, :, 2])
        Hb = H.reshape(M, 3, M, 3)
        Hb[idx, :, idx, :] -= self.w[:, None, None] * Lam
        # onto the distinct nodes
        Hd = np.tensordot(self.E, Hb, axes=([0], [0]))  # (n, 3, M, 3)
        Hd = np.tensordot(Hd, self.E, axes=([2], [0])).transpose(0, 1, 3, 2)  # (n, 3, n, 3)
        nU = self.E.shape[1]
        Hd = Hd.reshape(3 * nU, 3 * nU)
        return (self.E.T @ g).reshape(-1), 0.5 * (Hd + Hd.T)

    def hessian_cs(self, q, load: Load3):
        """:meth:`hessian` by a complex step of :meth:`gradient` (exact to rounding; slower): its check."""
        g = self.gradient(q, load)
        Ht = self.gradient(self._perturbed(q, self.pdirs), load).imag / _H
        return g, 0.5 * (Ht + Ht.T)

    def scaled(self, H, load: Load3 | None = None):
        """H in the mass-normalized basis, in units E I_w / L^2 (its eigenvalues are the planar solver's).

        On a free beam the rigid rotations that leave the energy unchanged (about the field; all
        three without one) are neutral: given ``load``, they are lifted to eigenvalue 1e6 so that
        stability tests and the smallest eigenvalue see only the deformations."""
        r = 1.0 / np.sqrt(self.mass)
        Hs = H * np.outer(r, r) * (self.L**2 / self.EI_ref)
        if self.free and load is not None:
            B = load.B

            axes = [B / np.linalg.norm(B)] if np.any(B) else list(np.eye(3))
            for a in axes:
                v = (np.sqrt(self.mass).reshape(-1, 3) * a).ravel()
                v /= np.linalg.norm(v)
                Hs += 1e6 * np.outer(v, v)
        return Hs

    def min_eigen(self, q, load: Load3):
        """Smallest eigenvalue (units E I_w / L^2) and its mode psi (M, 3), largest entry 1 and positive."""
        _, H = self.hessian(q, load)
        vals, vecs = np.linalg.eigh(self.scaled(H, load))
        v = vecs[:, 0] / np.sqrt(self.mass)
        v = v / np.max(np.abs(v))
        if v[np.argmax(np.abs(v))] < 0:
            v = -v
        return float(vals[0]), self.E @ v.reshape(-1, 3)

    # output ---------------------------------------------------------------------------------------
    def centreline(self, q):
        """Positions r(s) (M, 3) (m), from the clamp (or left end) at the origin."""
        return self.Q0 @ qmat(q)[:, :, 2]

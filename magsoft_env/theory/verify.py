"""A posteriori check of an equilibrium, independent of the solver's collocation nodes and operators.

The solver finds theta at Chebyshev-Lobatto nodes and interpolates between them. This module
takes that interpolant as the claimed solution and measures how well it satisfies the
equilibrium equations at *other* points: Gauss-Legendre points of panels cut at every
breakpoint of the beam and at every knot of a spline profile, with the loads recomputed from
the beam specification (not from the solver's model) and integrated by Gauss-Legendre panel
quadrature (not by the solver's spectral integration matrices).

The equation checked is the integral form of moment balance,
``theta(s) = theta(0) - int_0^s (1/EI(t)) int_t^L f(theta(u), u) du dt``, with the generalized
load density (N)::

    f = W(s) cos(theta) + m(s) [B_x sin(theta + beta) - B_z cos(theta + beta)]        (rotated)
    f = W(s) cos(theta) + m(s) cos(beta) [B_x sin(theta) - B_z cos(theta)]            (paper)

``W(s) = g int_s^L rho A`` the weight beyond s, ``m = A B_r / mu0``; with axial strain the
axial force ``a`` scales its derivative by ``1 + a / EA``. Its residual is an angle (rad), and
so are the boundary conditions: theta(0) = theta_0 on a cantilever; zero net moment,
``L int_0^L f / EI``, on a free-free beam (theta'(L) = 0 is built into the inner integral).

The panels have the solver's distinct nodes as edges (so every check point lies between two
nodes, and the check is as fine as the grid and then ``GAUSS_POINTS`` times finer), plus the
beam's breakpoints and, for spline jigs with at most ``MAX_KNOT_EDGES`` knots, their knots.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
from numpy.polynomial import legendre

#: Gauss-Legendre points per panel.
GAUSS_POINTS = 8
#: Spline knots that become panel edges (denser knot sets are resolved by the node panels).
MAX_KNOT_EDGES = 100


@lru_cache(maxsize=16)
def _gauss(q: int):
    """Nodes and weights on [-1, 1], and the matrix ``B`` with ``(B f)_j = int_{x_j}^1 p`` for the
    polynomial ``p`` interpolating ``f`` at the nodes."""
    x, w = legendre.leggauss(q)
    V = legendre.legvander(x, q - 1)
    Vinv = np.linalg.inv(V)
    B = np.empty((q, q))
    for k in range(q):
        c = legendre.legint(Vinv[:, k])  # antiderivative of the k-th cardinal polynomial
        B[:, k] = legendre.legval(1.0, c) - legendre.legval(x, c)
    return x, w, B


def _extra_edges(beam) -> tuple[float, ...]:
    """Panel edges a beam adds to its grid's nodes: breakpoints, and spline knots when they are few."""
    knots = beam.spline_knots()  # where a spline's third derivative jumps
    return tuple(sorted({*beam.breakpoints(), *(knots if len(knots) <= MAX_KNOT_EDGES else ())}))


class _Panels:
    """Gauss-Legendre panels between the nodes of one grid (and extra edges): positions, weights,
    the interpolation matrix from nodal values. Shared by every beam on that grid."""

    def __init__(self, grid, extra: tuple[float, ...]):
        x, w, B = _gauss(GAUSS_POINTS)
        L = float(grid.edges[-1])
        e = np.array(sorted({0.0, L, *map(float, grid.s), *extra}))
        e = e[np.concatenate([[True], np.diff(e) > 1e-12 * L])]
        a, b = e[:-1, None], e[1:, None]
        half = 0.5 * (b - a)
        self.s = (0.5 * (a + b) + half * x[None, :]).ravel()  # (P q,)
        self.h = half  # (P, 1)
        self.w = half * w[None, :]  # (P, q)
        self.B = B
        self.P, self.q = e.size - 1, GAUSS_POINTS
        self.Ith = grid.interpolate(np.eye(grid.M), self.s)  # theta at the check points from nodal values


@lru_cache(maxsize=64)
def _panels(grid, extra: tuple[float, ...]) -> _Panels:
    return _Panels(grid, extra)


class _Points:
    """Check points of one beam on one grid: the panels and the beam's coefficients there."""

    def __init__(self, beam, grid):
        pan = _panels(grid, _extra_edges(beam))
        self.s, self.h, self.w, self.B, self.P, self.q, self.Ith = pan.s, pan.h, pan.w, pan.B, pan.P, pan.q, pan.Ith
        s = self.s
        self.EI = beam.bending_stiffness(s)
        self.EA = beam.axial_stiffness(s)
        m = beam.moment_per_length(s)
        beta = beam.beta(s)
        self.m, self.beta = m, beta
        self.mcos = m * np.cos(beta)
        self.msin = m * np.sin(beta)
        # weight per unit g beyond s: rho A integrated from the tip, by the same panel quadrature
        self.W1 = self.beyond(beam.mass_per_length(s))
        self.length = float(beam.length)

    def beyond(self, g: np.ndarray) -> np.ndarray:
        """``int_s^L g`` at every check point, from values at the check points."""
        G = g.reshape(self.P, self.q)
        panel = (self.w * G).sum(axis=1)  # integral over each panel
        after = np.concatenate([np.cumsum(panel[::-1])[::-1][1:], [0.0]])  # over the panels to the right
        within = (G @ self.B.T) * self.h  # from each point to its panel's right end
        return (within + after[:, None]).ravel()

    def before(self, g: np.ndarray) -> np.ndarray:
        """``int_0^s g`` at every check point, from values at the check points."""
        G = g.reshape(self.P, self.q)
        panel = (self.w * G).sum(axis=1)
        upto = np.concatenate([[0.0], np.cumsum(panel)[:-1]])  # over the panels to the left
        within = panel[:, None] - (G @ self.B.T) * self.h  # from each panel's left end to the point
        return (within + upto[:, None]).ravel()

    def total(self, g: np.ndarray) -> float:
        return float((self.w * g.reshape(self.P, self.q)).sum())


@lru_cache(maxsize=32)
def _points(beam, grid) -> _Points:
    return _Points(beam, grid)


def load_density(pts: _Points, theta, Bx: float, Bz: float, g: float, *, coupling: str, extensible: bool):
    """The generalized load density f (N) at the check points (see the module docstring)."""
    W = g * pts.W1
    c, sn = np.cos(theta), np.sin(theta)
    # axial force a and its derivative in theta, from the axial part of the magnetization and gravity
    a = pts.mcos * (Bx * c + Bz * sn) - W * sn
    da = pts.mcos * (Bz * c - Bx * sn) - W * c
    if coupling == "rotated":
        transverse = pts.msin * (Bz * sn + Bx * c)  # d/dtheta of -m sin(beta) (B_z cos - B_x sin)
    else:
        transverse = 0.0
    if extensible:
        return -(1.0 + a / pts.EA) * da + transverse
    return -da + transverse


def equation_residual(beam, grid, theta_nodes, *, Bx: float, Bz: float, g: float, coupling: str,
                      extensible: bool, support: str, theta0: float) -> float:
    """Largest equilibrium residual (rad) of the interpolant of ``theta_nodes`` between the nodes.

    The maximum over the check points of ``|theta(s) - theta(0) + int_0^s (1/EI) int_t^L f|`` and
    of the boundary condition: ``|theta(0) - theta0|`` for a cantilever, ``L |int_0^L f| / EI``
    (net moment) for a free-free beam. NaN in, NaN out.
    """
    pts = _points(beam, grid)
    th = pts.Ith @ theta_nodes
    f = load_density(pts, th, Bx, Bz, g, coupling=coupling, extensible=extensible)
    inner = pts.beyond(f)  # bending moment, up to sign (N m)
    start = float(theta_nodes[0])  # theta(0): s = 0 is a node
    r = np.abs(th - start + pts.before(inner / pts.EI))
    worst = float(np.max(r))
    if support == "cantilever":
        bc = abs(start - theta0)
    else:
        bc = pts.length * abs(pts.total(f)) / float(np.min(pts.EI))
    out = max(worst, bc)
    return out if math.isfinite(out) else math.nan




class _RodPoints:
    """Check points of one beam on one grid for the 3D rod: the panels and the beam's coefficients there
    (stiffnesses, magnetic moment per length in material coordinates, weight beyond s)."""

    def __init__(self, beam, grid):
        pan = _panels(grid, _extra_edges(beam))
        self.pan = pan
        base = _Points.__new__(_Points)  # the panel integrals only
        base.P, base.q, base.w, base.h, base.B = pan.P, pan.q, pan.w, pan.h, pan.B
        self.ints = base
        s = pan.s
        self.K = np.asarray(beam.stiffnesses(s), dtype=float)
        m_hat = np.asarray(beam.magnetization_direction(s), dtype=float)
        self.a = beam.moment_per_length(s)[:, None] * m_hat[:, [1, 2, 0]]  # (d1, d2, d3) = (width, thickness, axial)
        self.W1 = base.beyond(beam.mass_per_length(s))
        self.length = float(beam.length)

    def beyond(self, g):
        return np.stack([self.ints.beyond(g[:, i]) for i in range(g.shape[1])], axis=1)

    def before(self, g):
        return np.stack([self.ints.before(g[:, i]) for i in range(g.shape[1])], axis=1)


@lru_cache(maxsize=32)
def _rod_points(beam, grid) -> _RodPoints:
    return _RodPoints(beam, grid)


def _qmul(p, q):
    pw, pv = p[:, :1], p[:, 1:]
    qw, qv = q[:, :1], q[:, 1:]
    return np.concatenate([pw * qw - np.sum(pv * qv, axis=1, keepdims=True),
                           pw * qv + qw * pv + np.cross(pv, qv)], axis=1)


def _rotation(q):
    """Rotation matrices (n, 3, 3) of quaternions (n, 4), normalized first."""
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, v = q[:, 0], q[:, 1:]
    vx = np.zeros((q.shape[0], 3, 3))
    vx[:, 0, 1], vx[:, 0, 2], vx[:, 1, 2] = -v[:, 2], v[:, 1], -v[:, 0]
    vx -= vx.transpose(0, 2, 1)
    return np.eye(3) + 2.0 * w[:, None, None] * vx + 2.0 * vx @ vx


def rod_residual(beam, grid, q_nodes, *, B, g: float, support: str, q0) -> float:
    """Largest equilibrium residual (rad) of a 3D rod's interpolated frame field between the nodes.

    ``q_nodes`` (M, 4) are the frames at the solver's nodes (unit quaternions, body to world;
    columns of the rotation: across the width, through the thickness, the tangent). At the
    Gauss-Legendre check points the loads are recomputed from the beam (magnetic couple
    ``(A B_r / mu0) (R m_hat) x B`` and the weight beyond s), the moment ``m(s) = int_s^L
    (d3 x n + c)`` is integrated by panel quadrature, the curvature it implies is ``k = B^-1 R^T m``,
    and the frame is integrated back from s = 0, ``q(0) + int_0^s (1/2) q (0, k)``; the residual is
    twice the largest distance between that and the interpolated frame (an angle). The boundary
    condition adds ``|2 vec(conj(q(0)) (q(0) - q0))|`` on a cantilever and the net moment
    ``L |m(0)| / min(E I)`` on a free beam. NaN in, NaN out.
    """
    pts = _rod_points(beam, grid)
    Q = pts.pan.Ith @ q_nodes
    Q = Q / np.linalg.norm(Q, axis=1, keepdims=True)
    R = _rotation(Q)
    B = np.asarray(B, dtype=float)
    lam = np.cross(np.einsum("nij,nj->ni", R, pts.a), B)
    if g:
        d3 = R[:, :, 2]
        gw = g * pts.W1
        lam = lam + np.stack([-gw * d3[:, 1], gw * d3[:, 0], np.zeros_like(gw)], axis=1)
    m = pts.beyond(lam)
    k = np.einsum("nji,nj->ni", R, m) / pts.K
    rate = 0.5 * _qmul(Q, np.concatenate([np.zeros((k.shape[0], 1)), k], axis=1))
    start = q_nodes[0] / np.linalg.norm(q_nodes[0])
    back = start[None, :] + pts.before(rate)
    worst = 2.0 * float(np.max(np.linalg.norm(back - Q, axis=1)))
    if support == "cantilever":
        q0 = np.asarray(q0, dtype=float)
        d = min(np.linalg.norm(start - q0), np.linalg.norm(start + q0))
        bc = 2.0 * float(d)
    else:
        net = np.array([pts.ints.total(lam[:, i]) for i in range(3)])
        bc = pts.length * float(np.linalg.norm(net)) / float(np.min(pts.K))
    out = max(worst, bc)
    return out if math.isfinite(out) else math.nan


def rod_source_residual(beam, grid, q_nodes, load, *, q0) -> float:
    """Largest equilibrium residual (rad) of a clamped 3D rod's interpolated frames in a field source.

    As :func:`rod_residual`, with the loads of a non-uniform source recomputed at the check points: the
    positions ``r(s) = int_0^s d3`` by panel quadrature of the interpolated tangent (the clamp at the origin),
    the field and gradient there from ``load.evaluate(points) -> (B (n, 3), G (n, 3, 3))`` (``load.g`` the
    gravity, m/s^2), the couple ``(R a) x B(r)``, the force per length ``f = G(r)^T (R a) - rho A g z`` and the
    force ``n(s) = int_s^L f`` by panel quadrature; then the moment, curvature and frames as in
    :func:`rod_residual`, plus the clamp condition. NaN in, NaN out.
    """
    pts = _rod_points(beam, grid)
    Q = pts.pan.Ith @ q_nodes
    Q = Q / np.linalg.norm(Q, axis=1, keepdims=True)
    R = _rotation(Q)
    d3 = R[:, :, 2]
    r = pts.before(d3)
    if not np.all(np.isfinite(r)):
        return math.nan
    B, G = load.evaluate(r)
    ma = np.einsum("nij,nj->ni", R, pts.a)
    n = pts.beyond(np.einsum("nab,na->nb", G, ma))
    n[:, 2] -= load.g * pts.W1
    lam = np.cross(ma, B) + np.cross(d3, n)
    m = pts.beyond(lam)
    k = np.einsum("nji,nj->ni", R, m) / pts.K
    rate = 0.5 * _qmul(Q, np.concatenate([np.zeros((k.shape[0], 1)), k], axis=1))
    start = q_nodes[0] / np.linalg.norm(q_nodes[0])
    back = start[None, :] + pts.before(rate)
    worst = 2.0 * float(np.max(np.linalg.norm(back - Q, axis=1)))
    q0 = np.asarray(q0, dtype=float)
    bc = 2.0 * float(min(np.linalg.norm(start - q0), np.linalg.norm(start + q0)))
    out = max(worst, bc)
    return out if math.isfinite(out) else math.nan


def outcome(ok: bool, status: int, tail: float, ver: float, options, *, note: str, events: int, nodes: int,
            messages: dict) -> tuple[int, str]:
    """The status and message of a result (planar or 3D) from what the solve and its verification found.

    A failed solve keeps its status (1 if it had none); a solution whose verification exceeds
    ``options.verify_tol`` is status 4; one resolved to the verification but not to
    ``options.resolution_tol`` is status 2. The message adds why the solve stopped (``note``), the
    folds and bifurcations passed (``events``) and the measured resolution."""
    if not ok:
        status = 1 if status == 0 else status
    elif not ver <= options.verify_tol:
        status = 4
    elif status == 0 and tail > options.resolution_tol:
        status = 2
    msg = messages[status]
    if not ok and note:
        msg += " " + note
    if events:
        msg += f" Passed {events} fold/bifurcation point(s) with a jump to a stable branch."
    if status == 2:
        msg += f" (trailing Chebyshev coefficient {tail:.1e} rad; verified between the nodes to {ver:.1e} rad)"
    if status == 4:
        msg += f" (residual between the nodes {ver:.1e} rad > verify_tol {options.verify_tol:g}, on {nodes} nodes)"
    return status, msg


__all__ = ["GAUSS_POINTS", "MAX_KNOT_EDGES", "equation_residual", "load_density", "outcome", "rod_residual",
           "rod_source_residual"]

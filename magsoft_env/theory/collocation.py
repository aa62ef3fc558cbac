"""Multi-domain Chebyshev-Lobatto discretization: nodes, quadrature, spectral integration.

The beam [0, L] is cut into subdomains at the profiles' breakpoints (and, for long
subdomains, evenly). Each subdomain carries n + 1 Chebyshev-Lobatto nodes; interface nodes
appear twice, once per side, so that discontinuous coefficients take their one-sided values.
Functions that are smooth on each subdomain are integrated and differentiated to spectral
accuracy.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property, lru_cache

import numpy as np


@lru_cache(maxsize=64)
def _cheb_local(n: int):
    """Chebyshev-Lobatto data on [-1, 1] for degree n (ascending nodes).

    Returns nodes x (n+1,), Clenshaw-Curtis weights w (n+1,), cumulative integration matrix
    Q (n+1, n+1) with (Q f)_i = int_{-1}^{x_i} p_f, differentiation matrix D (n+1, n+1), the
    values-to-coefficients matrix C (n+1, n+1) and barycentric weights (n+1,).
    """
    j = np.arange(n + 1)
    x = -np.cos(np.pi * j / n)
    # values -> Chebyshev coefficients (exact inverse of the Vandermonde at Lobatto points)
    T = np.cos(np.outer(np.arccos(np.clip(x, -1, 1)), np.arange(n + 1)))
    C = np.linalg.solve(T, np.eye(n + 1))
    # integrate coefficients: int T_k = T_{k+1}/(2(k+1)) - T_{k-1}/(2(k-1)), T_0 -> T_1, T_1 -> T_2/4
    B = np.zeros((n + 2, n + 1))
    B[1, 0] = 1.0
    if n >= 1:
        B[2, 1] = 0.25
    for k in range(2, n + 1):
        B[k + 1, k] += 1.0 / (2 * (k + 1))
        B[k - 1, k] -= 1.0 / (2 * (k - 1))
    T2 = np.cos(np.outer(np.arccos(np.clip(x, -1, 1)), np.arange(n + 2)))
    at_minus1 = (-1.0) ** np.arange(n + 2)
    Q = (T2 - at_minus1[None, :]) @ B @ C
    w = Q[-1].copy()
    # differentiation matrix (Trefethen's cheb, flipped to ascending order)
    c = np.ones(n + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** j
    X = np.tile(x, (n + 1, 1)).T
    dX = X - X.T
    D = np.outer(c, 1.0 / c) / (dX + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))
    bary = (-1.0) ** j * np.where((j == 0) | (j == n), 0.5, 1.0)
    for a in (x, w, Q, D, C, bary):
        a.setflags(write=False)
    return x, w, Q, D, C, bary


@dataclass(frozen=True, eq=False)  # compared and hashed by identity (grids are cached): usable as a cache key
class Grid:
    """Nodes of a multi-domain Chebyshev discretization of [0, L].

    Attributes
    ----------
    edges : (d + 1,) array
        Subdomain boundaries (m).
    n : int
        Polynomial degree per subdomain.
    s : (M,) array
        All nodes (m), M = d (n + 1); interface nodes repeated.
    s_eval : (M,) array
        Nodes nudged into their own subdomain, to evaluate one-sided coefficients.
    w : (M,) array
        Quadrature weights: ``w @ f`` approximates ``int_0^L f ds``.
    Q0 : (M, M) array
        ``(Q0 @ f)_i`` approximates ``int_0^{s_i} f ds``.
    """

    edges: np.ndarray
    n: int
    s: np.ndarray
    s_eval: np.ndarray
    w: np.ndarray
    Q0: np.ndarray
    domain: np.ndarray  # (M,) subdomain index of each node

    @property
    def M(self) -> int:
        return self.s.size

    @property
    def QL(self) -> np.ndarray:
        """``(QL @ f)_i`` approximates ``int_{s_i}^L f ds``."""
        return self.w[None, :] - self.Q0

    def unique(self) -> np.ndarray:
        """Index of one copy of every distinct node (drops the first node of each domain > 0)."""
        keep = np.ones(self.M, bool)
        keep[(self.n + 1) * np.arange(1, len(self.edges) - 1)] = False
        return np.flatnonzero(keep)

    @cached_property
    def _D(self) -> np.ndarray:
        """Block-diagonal spectral differentiation matrix (M, M)."""
        _, _, _, D, _, _ = _cheb_local(self.n)
        p = self.n + 1
        out = np.zeros((self.M, self.M))
        for k in range(len(self.edges) - 1):
            out[k * p : (k + 1) * p, k * p : (k + 1) * p] = D / (0.5 * (self.edges[k + 1] - self.edges[k]))
        out.setflags(write=False)
        return out

    @cached_property
    def _Ctail(self) -> np.ndarray:
        """Rows giving the last three Chebyshev coefficients of every subdomain (3 d, M)."""
        _, _, _, _, C, _ = _cheb_local(self.n)
        p = self.n + 1
        d = len(self.edges) - 1
        out = np.zeros((3 * d, self.M))
        for k in range(d):
            out[3 * k : 3 * k + 3, k * p : (k + 1) * p] = C[-3:]
        out.setflags(write=False)
        return out

    def derivative(self, f: np.ndarray) -> np.ndarray:
        """Spectral derivative, domain by domain."""
        return self._D @ f

    def tail(self, f: np.ndarray) -> float:
        """Largest size of the last three Chebyshev coefficients over subdomains, relative to |f|."""
        amax = np.maximum.reduce
        scale = max(1.0, float(amax(np.abs(f))))
        return float(amax(np.abs(self._Ctail @ f))) / scale

    def interpolate(self, f: np.ndarray, s_new) -> np.ndarray:
        """Barycentric interpolation of nodal values ``f`` (M,) or (M, k) at ``s_new`` (m)."""
        x, _, _, _, _, bary = _cheb_local(self.n)
        s_new = np.atleast_1d(np.asarray(s_new, dtype=float))
        dom = np.clip(np.searchsorted(self.edges, s_new, side="right") - 1, 0, len(self.edges) - 2)
        out = np.empty((s_new.size,) + f.shape[1:])
        for k in np.unique(dom):
            m = dom == k
            a, b = self.edges[k], self.edges[k + 1]
            t = (2.0 * s_new[m] - (a + b)) / (b - a)
            fk = f[k * (self.n + 1) : (k + 1) * (self.n + 1)]
            diff = t[:, None] - x[None, :]
            exact = np.isclose(diff, 0.0, atol=1e-14)
            diff[exact] = 1.0
            W = bary[None, :] / diff
            val = (W @ fk) / W.sum(axis=1).reshape((-1,) + (1,) * (fk.ndim - 1))
            hit = exact.any(axis=1)
            if hit.any():
                val[hit] = fk[np.argmax(exact[hit], axis=1)]
            out[m] = val
        return out


@lru_cache(maxsize=128)
def _grid_cached(edges: tuple[float, ...], n: int) -> Grid:
    x, wl, Ql, _, _, _ = _cheb_local(n)
    d = len(edges) - 1
    p = n + 1
    M = d * p
    s = np.empty(M)
    s_eval = np.empty(M)
    w = np.empty(M)
    Q0 = np.zeros((M, M))
    domain = np.repeat(np.arange(d), p)
    for k in range(d):
        a, b = edges[k], edges[k + 1]
        h = 0.5 * (b - a)
        sl = slice(k * p, (k + 1) * p)
        s[sl] = a + h * (x + 1.0)
        nudge = 1e-11 * (b - a)
        s_eval[sl] = np.clip(s[sl], a + nudge, b - nudge)
        w[sl] = h * wl
        Q0[sl, sl] = h * Ql
        if k > 0:
            Q0[sl, : k * p] = w[None, : k * p]
    s[0], s[-1] = edges[0], edges[-1]
    s_eval[0], s_eval[-1] = edges[0], edges[-1]
    for a in (s, s_eval, w, Q0, domain):
        a.setflags(write=False)
    return Grid(np.asarray(edges), n, s, s_eval, w, Q0, domain)


def finer_grid(grid: Grid, theta, *, max_nodes: int, max_total: int) -> Grid | None:
    """A finer grid than ``grid`` (on which the shape is ``theta``): the degree raised 1.5x while it stays within
    ``max_nodes``, then the least resolved subdomains (trailing Chebyshev coefficients within 10 % of the largest)
    halved; None when that would pass ``max_total`` nodes."""
    d = len(grid.edges) - 1
    if grid.n < max_nodes:
        n = min(max_nodes, int(np.ceil(grid.n * 1.5)))
        return _grid_cached(tuple(float(e) for e in grid.edges), n) if d * (n + 1) <= max_total else None
    C = np.abs(grid._Ctail @ theta).reshape(d, 3).max(axis=1)
    split = C >= 0.1 * C.max() if C.max() > 0 else np.ones(d, bool)
    if (d + int(split.sum())) * (grid.n + 1) > max_total:
        return None
    e = grid.edges
    edges = [e[0]]
    for k in range(d):
        if split[k]:
            edges.append(0.5 * (e[k] + e[k + 1]))
        edges.append(e[k + 1])
    return _grid_cached(tuple(float(v) for v in edges), grid.n)


def make_grid(length: float, breakpoints=(), *, n: int = 24, max_domain: float | None = None) -> Grid:
    """Grid on [0, length] with subdomains cut at ``breakpoints`` (m).

    ``max_domain`` (m) splits long smooth stretches so each subdomain is at most that long.
    """
    edges = [0.0, *sorted(float(b) for b in breakpoints if 0.0 < b < length), float(length)]
    if max_domain is not None:
        fine = [edges[0]]
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            k = max(1, int(np.ceil((b - a) / max_domain - 1e-9)))
            fine.extend(a + (b - a) * np.arange(1, k + 1) / k)
        edges = fine
    return _grid_cached(tuple(edges), int(n))

"""Fields sampled on a grid, represented by a harmonic scalar potential: divergence- and curl-free by construction.

In a region without currents or magnetized matter, ``B = -grad phi`` with ``laplacian phi = 0``. The samples
(the field, and the gradient if given) are fitted by least squares with ``phi`` a harmonic polynomial of degree
at most ``degree`` in the scaled coordinates ``u = (x - c) / s`` (``c`` the grid's centre, ``s`` its largest
half-extent): a basis of the null space of the Laplacian on the monomials of degree 1 to ``degree``, ``(degree +
1)^2 - 1`` functions (the solid harmonics of those degrees, in another basis). ``B`` and ``G = -hess phi`` are then
polynomials: ``div B = -trace hess phi = 0`` and ``G`` symmetric (curl-free) identically, up to rounding.

This is a fit, not an interpolant: it does not pass through every sample, and it represents a field whose
sources lie outside the grid's box (coils, magnets around a workspace) to an accuracy that improves
geometrically with ``degree``. :attr:`GridField.fit_max_error` reports the largest misfit at the samples. Points
outside the box are refused (a polynomial does not extrapolate).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..validate import finite_array, integer
from .base import Source, as_points

#: Highest degree of the potential (its number of basis functions is (degree + 1)^2 - 1).
MAX_DEGREE = 20
#: Points farther outside the box than this fraction of its size are refused.
BOX_TOL = 1e-9
_PAIRS = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2))


def _monomials(degree: int, lowest: int = 0) -> np.ndarray:
    """Exponents (i, j, k) of the monomials x^i y^j z^k with lowest <= i + j + k <= degree, shape (n, 3)."""
    return np.array([e for d in range(lowest, degree + 1)
                     for e in itertools.product(range(d + 1), repeat=3) if sum(e) == d], dtype=int).reshape(-1, 3)


class HarmonicFit:
    """Harmonic polynomials of degree <= ``degree`` (no constant) on a box, fitted to field samples.

    Internal to :mod:`magsoft_env.fields`: holds the basis, the fitted coefficients for one or more channels (the
    columns of the samples) and evaluates ``B`` and ``G`` with one matrix product."""

    def __init__(self, lo: np.ndarray, hi: np.ndarray, degree: int):
        self.lo, self.hi, self.degree = lo, hi, degree
        self.center = 0.5 * (lo + hi)
        self.scale = float(0.5 * (hi - lo).max())
        phi = _monomials(degree, 1)  # the potential's monomials
        self.eval_exps = _monomials(degree - 1, 0)  # B and G are polynomials of degree <= degree - 1
        index = {tuple(e): i for i, e in enumerate(self.eval_exps)}
        # columns of the flattened power table (n, 3 * degree) for each evaluation monomial
        self._ix, self._iy, self._iz = (a * degree + self.eval_exps[:, a] for a in range(3))
        # the Laplacian of the potential, onto monomials of degree <= degree - 2
        lap = np.zeros((max(len(index), 1), len(phi)))
        for col, (i, j, k) in enumerate(phi):
            for axis, p in enumerate((i, j, k)):
                if p >= 2:
                    e = [i, j, k]
                    e[axis] -= 2
                    lap[index[tuple(e)], col] += p * (p - 1)
        self.basis = scipy.linalg.null_space(lap)  # (n_phi, (degree + 1)^2 - 1), orthonormal columns
        # first and second derivatives of the monomials, as maps onto the evaluation monomials
        self.d1 = [np.zeros((len(index), len(phi))) for _ in range(3)]
        self.d2 = [np.zeros((len(index), len(phi))) for _ in _PAIRS]
        for col, e in enumerate(phi):
            for a in range(3):
                if e[a] >= 1:
                    f = e.copy()
                    f[a] -= 1
                    self.d1[a][index[tuple(f)], col] = e[a]
            for q, (a, b) in enumerate(_PAIRS):
                f = e.copy()
                coef = f[a]
                f[a] -= 1
                if coef < 1:
                    continue
                coef *= f[b]
                f[b] -= 1
                if coef >= 1:
                    self.d2[q][index[tuple(f)], col] = coef
        self.W = None  # (n_eval, 9, channels): B_x, B_y, B_z, then G of _PAIRS

    def monomials_T(self, points: np.ndarray) -> np.ndarray:
        """The evaluation monomials at ``points`` (m), transposed: shape (n_eval, n)."""
        u = ((points - self.center) / self.scale).T
        n = u.shape[1]
        P = np.ones((3, self.degree, n))  # powers 0 .. degree - 1 by products (np.power is slow)
        if self.degree > 1:
            P[:, 1:] = np.cumprod(np.repeat(u[:, None, :], self.degree - 1, axis=1), axis=1)
        P = P.reshape(-1, n)  # rows: x^0 .. x^(degree-1), y^0 .., z^0 ..
        return P[self._ix] * P[self._iy] * P[self._iz]

    def monomials(self, points: np.ndarray) -> np.ndarray:
        """The evaluation monomials at ``points`` (m), shape (n, n_eval)."""
        return self.monomials_T(points).T

    def fit(self, points: np.ndarray, B: np.ndarray, G: np.ndarray | None) -> tuple[np.ndarray, int]:
        """Least-squares coefficients for samples ``B`` (n, 3, c) and optionally ``G`` (n, 3, 3, c); returns the
        residual of B at the samples (n, 3, c, T) and the rank of the system."""
        V = self.monomials(points)
        s = self.scale
        rows = [-(V @ (d @ self.basis)) / s for d in self.d1]
        rhs = [B[:, a] for a in range(3)]
        if G is not None:  # rows scaled by s: comparable in size to the field rows
            rows += [-(V @ (d @ self.basis)) / s for d in self.d2]
            rhs += [G[:, a, b] * s for a, b in _PAIRS]
        A = np.concatenate(rows)
        coef, _, rank, _ = scipy.linalg.lstsq(A, np.concatenate(rhs))
        self.W = np.concatenate([np.stack([-(d @ self.basis @ coef) / s for d in self.d1], axis=1),
                                 np.stack([-(d @ self.basis @ coef) / s**2 for d in self.d2], axis=1)], axis=1)
        fitted = np.stack([r @ coef for r in rows[:3]], axis=1)  # (n, 3, c)
        return fitted - B, int(rank)

    def evaluate(self, points: np.ndarray, W: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """B (n, 3) and G (n, 3, 3) at ``points`` for the evaluation matrix ``W`` (n_eval, 9)."""
        out = W.T @ self.monomials_T(points)  # (9, n)
        return out[:3].T.copy(), out[[3, 4, 5, 4, 6, 7, 5, 7, 8]].T.reshape(-1, 3, 3)

    def check_inside(self, points: np.ndarray, what: str) -> None:
        tol = BOX_TOL * self.scale
        if (points.min(axis=0) >= self.lo - tol).all() and (points.max(axis=0) <= self.hi + tol).all():
            return
        out = ((points < self.lo - tol) | (points > self.hi + tol)).any(axis=1)
        if out.any():
            i = int(np.argmax(out))
            raise ValueError(f"points[{i}] = {points[i].tolist()!r} m lies outside {what}'s box "
                             f"{np.column_stack([self.lo, self.hi]).tolist()!r} m (a fit does not extrapolate).")


def _axes(axes) -> tuple[np.ndarray, ...]:
    if isinstance(axes, (str, bytes)) or len(axes) != 3:
        raise ValueError(f"GridField axes must be three increasing coordinate arrays (x, y, z) in m, got {axes!r}.")
    out = []
    for name, ax in zip("xyz", axes, strict=True):
        a = finite_array(f"GridField axes {name}", ax, ndim=1)
        if a.size < 2 or not np.all(np.diff(a) > 0):
            raise ValueError(f"GridField axes {name} must be at least 2 strictly increasing coordinates (m), got "
                             f"{a.tolist()!r}.")
        out.append(a)
    return tuple(out)


def _grid_points(axes) -> np.ndarray:
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    return np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])


@dataclass(frozen=True, eq=False, init=False)
class GridField(Source):
    """A field sampled on a rectilinear grid (and optionally its gradient), fitted by a harmonic potential.

    Parameters
    ----------
    axes : tuple of three array_like
        The grid's coordinates along x, y, z (m), each at least 2 strictly increasing values.
    B : array_like, shape (nx, ny, nz, 3)
        The field at the grid points (T), ``B[i, j, k]`` at ``(x[i], y[j], z[k])``.
    G : array_like, shape (nx, ny, nz, 3, 3), optional
        The gradient there (T/m), ``G[..., a, b] = dB_a/dx_b``, fitted with the field when given.
    degree : int
        Degree of the harmonic potential, in [2, :data:`MAX_DEGREE`] (default 10).

    Attributes
    ----------
    fit_max_error : float
        Largest ``|B_fit - B|`` component at the samples (T).
    fit_relative_error : float
        ``fit_max_error / max |B|`` over the samples.

    Notes
    -----
    Method and its limits in the module docstring: ``div B`` and ``curl B`` vanish identically (up to rounding);
    the fit is as good as a polynomial potential can represent the field in the box. Points outside the box are
    refused. A grid too coarse for ``degree`` (a rank-deficient fit) is refused.

    Examples
    --------
    >>> from magsoft_env.fields import CoilSystem
    >>> navion = CoilSystem.from_calibration("navion").at_currents([10.0, 0.0, -5.0])
    >>> g = GridField.from_source(navion, bounds=[(-0.02, 0.02)] * 3, shape=(7, 7, 7), degree=6)
    >>> g.fit_relative_error < 1e-5
    True
    """

    axes: tuple
    degree: int
    fit_max_error: float
    fit_relative_error: float

    def __init__(self, axes, B, G=None, *, degree: int = 10):
        ax = _axes(axes)
        shape = tuple(a.size for a in ax)
        b = finite_array("GridField B", B)
        if b.shape != (*shape, 3):
            raise ValueError(f"GridField B must have shape {(*shape, 3)} (the axes' sizes, then 3), got {b.shape}.")
        g = None
        if G is not None:
            g = finite_array("GridField G", G)
            if g.shape != (*shape, 3, 3):
                raise ValueError(f"GridField G must have shape {(*shape, 3, 3)}, got {g.shape}.")
        deg = integer("GridField degree", degree, 2, MAX_DEGREE)
        lo = np.array([a[0] for a in ax])
        hi = np.array([a[-1] for a in ax])
        fit = HarmonicFit(lo, hi, deg)
        pts = _grid_points(ax)
        n_basis = fit.basis.shape[1]
        resid, rank = fit.fit(pts, b.reshape(-1, 3, 1), None if g is None else g.reshape(-1, 3, 3, 1))
        if rank < n_basis:
            raise ValueError(f"GridField: a grid of shape {shape} cannot determine a potential of degree {deg} "
                             f"({n_basis} functions, rank {rank}): give more points along each axis or a lower "
                             "degree.")
        err = float(np.abs(resid).max())
        object.__setattr__(self, "axes", ax)
        object.__setattr__(self, "degree", deg)
        object.__setattr__(self, "fit_max_error", err)
        object.__setattr__(self, "fit_relative_error", err / max(float(np.abs(b).max()), 1e-300))
        object.__setattr__(self, "_fit", fit)
        object.__setattr__(self, "_W", fit.W[:, :, 0])

    @classmethod
    def from_source(cls, source: Source, *, bounds, shape=(9, 9, 9), degree: int = 10,
                    with_gradient: bool = True) -> GridField:
        """Sample ``source`` on a grid over ``bounds`` (``[(xmin, xmax), (ymin, ymax), (zmin, zmax)]``, m) of
        ``shape`` points and fit it (with its gradient if ``with_gradient``)."""
        if not isinstance(source, Source):
            raise ValueError(f"GridField.from_source needs a field source, got {type(source).__name__}.")
        bnd = finite_array("GridField bounds", bounds)
        if bnd.shape != (3, 2) or not np.all(bnd[:, 1] > bnd[:, 0]):
            raise ValueError(f"GridField bounds must be 3 pairs (min, max) with min < max (m), got {bounds!r}.")
        if isinstance(shape, (str, bytes)) or len(shape) != 3:
            raise ValueError(f"GridField shape must be 3 point counts, got {shape!r}.")
        n = [integer(f"GridField shape[{i}]", v, 2, 1000) for i, v in enumerate(shape)]
        ax = tuple(np.linspace(lo, hi, k) for (lo, hi), k in zip(bnd, n, strict=True))
        B, G = source.field_and_gradient(_grid_points(ax))
        return cls(ax, B.reshape(*n, 3), G.reshape(*n, 3, 3) if with_gradient else None, degree=degree)

    @property
    def bounds(self) -> np.ndarray:
        """The box ``[[xmin, xmax], [ymin, ymax], [zmin, zmax]]`` (m)."""
        return np.column_stack([self._fit.lo, self._fit.hi])

    def field_and_gradient(self, points):
        p = as_points(points)
        self._fit.check_inside(p, "the grid")
        return self._fit.evaluate(p, self._W)


__all__ = ["MAX_DEGREE", "GridField", "HarmonicFit"]

"""Profiles along the beam: magnetization angle beta(s) and volume fraction phi(s).

A profile is a scalar function of the reference arc length s (m). Some profiles are
*relative* (uniform values, N equal cells): they stretch to any beam length. Others carry
their own length (a jig curve, knots in metres) and must cover the beam they are given to.

Profiles also report their *breakpoints*: interior points where the value or its slope
jumps (cell boundaries, polyline corners). The equilibrium solver splits its spectral
domains there, which keeps it exponentially accurate for piecewise-smooth profiles.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicSpline

from ..validate import finite_array, finite_number, positive

_COVER_RTOL = 1e-9


class Profile(ABC):
    """Abstract scalar profile along the beam.

    Subclasses implement :meth:`values`; ``length`` is ``None`` for relative profiles and
    the covered length (m) otherwise.
    """

    length: float | None = None

    @abstractmethod
    def values(self, s, length: float) -> np.ndarray:
        """Profile values at arc lengths ``s`` (m) on a beam of length ``length`` (m)."""

    def breakpoints(self, length: float) -> tuple[float, ...]:
        """Interior arc lengths (m) where the profile is not smooth."""
        return ()

    def check_covers(self, length: float, name: str) -> None:
        """Raise ValueError if this profile does not cover ``[0, length]``."""
        if self.length is not None and self.length < length * (1.0 - _COVER_RTOL):
            raise ValueError(
                f"{name} covers s in [0, {self.length * 1e3:.6g}] mm, which does not cover the beam: "
                f"expected at least its length {length * 1e3:.6g} mm."
            )

    def __call__(self, s, length: float | None = None) -> np.ndarray:
        if length is None:
            if self.length is None:
                raise ValueError(f"{type(self).__name__} is relative to the beam length: pass length=... (m).")
            length = self.length
        return self.values(s, length)


@dataclass(frozen=True)
class Constant(Profile):
    """The same value everywhere (a uniform magnetization angle or volume fraction)."""

    value: float

    def __post_init__(self):
        object.__setattr__(self, "value", finite_number("Constant.value", self.value))

    def values(self, s, length):
        return np.full(np.shape(s), self.value, dtype=float)


@dataclass(frozen=True)
class PiecewiseConstant(Profile):
    """Cells of constant value; ``fractions`` are relative cell lengths (equal if omitted).

    Examples
    --------
    >>> p = PiecewiseConstant([0.1, 0.2])          # left half 10 %, right half 20 %
    >>> p.values([0.001, 0.019], 0.02).tolist()
    [0.1, 0.2]
    """

    levels: Sequence[float]
    fractions: Sequence[float] | None = None

    def __post_init__(self):
        v = finite_array("PiecewiseConstant values", self.levels, ndim=1, min_len=1)
        if self.fractions is None:
            f = np.full(len(v), 1.0 / len(v))
        else:
            f = finite_array("PiecewiseConstant fractions", self.fractions, ndim=1, min_len=1)
            if len(f) != len(v):
                raise ValueError(f"PiecewiseConstant fractions must have one entry per value ({len(v)}), got {len(f)}.")
            if np.any(f <= 0):
                raise ValueError(f"PiecewiseConstant fractions must all be > 0, got {f.tolist()}.")
            f = f / f.sum()
        object.__setattr__(self, "levels", tuple(float(x) for x in v))
        object.__setattr__(self, "fractions", tuple(float(x) for x in f))

    @property
    def edges(self) -> np.ndarray:
        """Cell boundaries as fractions of the length, shape ``(n + 1,)``."""
        return np.concatenate([[0.0], np.cumsum(self.fractions)])

    def values(self, s, length):
        s = np.asarray(s, dtype=float)
        idx = np.searchsorted(self.edges[1:-1] * length, s, side="right")
        return np.asarray(self.levels)[idx]

    def breakpoints(self, length):
        v = np.asarray(self.levels)
        inner = self.edges[1:-1] * length
        return tuple(float(b) for b, a, c in zip(inner, v[:-1], v[1:], strict=True) if a != c)


def alternating_cells(n: int, *, angle: float = 0.0) -> PiecewiseConstant:
    """Magnetization of ``n`` equal cells alternating between ``angle`` and ``angle + pi`` (rad)."""
    if not isinstance(n, (int, np.integer)) or n < 1:
        raise ValueError(f"alternating_cells n must be a positive integer, got {n!r}.")
    a = finite_number("alternating_cells angle", angle, unit="rad")
    return PiecewiseConstant([a + np.pi * (i % 2) for i in range(n)])


@dataclass(frozen=True)
class PiecewiseLinear(Profile):
    """Linear interpolation between knots ``s_knots`` (m, increasing, from 0) and ``values``."""

    s_knots: Sequence[float]
    knot_values: Sequence[float]

    def __post_init__(self):
        s = finite_array("PiecewiseLinear s_knots", self.s_knots, ndim=1, min_len=2)
        v = finite_array("PiecewiseLinear values", self.knot_values, ndim=1, min_len=2)
        if len(s) != len(v):
            raise ValueError(f"PiecewiseLinear needs as many values as knots ({len(s)}), got {len(v)}.")
        if s[0] != 0.0:
            raise ValueError(f"PiecewiseLinear s_knots must start at 0 m, got {s[0]!r}.")
        if np.any(np.diff(s) <= 0):
            raise ValueError(f"PiecewiseLinear s_knots must be strictly increasing, got {s.tolist()}.")
        object.__setattr__(self, "s_knots", tuple(s.tolist()))
        object.__setattr__(self, "knot_values", tuple(v.tolist()))
        object.__setattr__(self, "length", float(s[-1]))

    def values(self, s, length):
        return np.interp(np.asarray(s, dtype=float), self.s_knots, self.knot_values)

    def breakpoints(self, length):
        return tuple(k for k in self.s_knots[1:-1] if k < length)


@dataclass(frozen=True)
class Function(Profile):
    """A user function of s (m). Give ``breakpoints`` (m) where it is not smooth, and
    ``length`` (m) if it is only defined up to some arc length."""

    func: Callable
    kinks: Sequence[float] = ()
    length: float | None = None

    def __post_init__(self):
        if not callable(self.func):
            raise ValueError(f"Function profile needs a callable of s (m), got {self.func!r}.")
        b = finite_array("Function breakpoints", list(self.kinks), ndim=1)
        object.__setattr__(self, "kinks", tuple(sorted(b.tolist())))
        if self.length is not None:
            object.__setattr__(self, "length", positive("Function length", self.length, unit="m"))

    def values(self, s, length):
        s = np.asarray(s, dtype=float)
        try:
            out = np.asarray(self.func(s), dtype=float)
            if out.shape != s.shape:
                out = np.broadcast_to(out, s.shape).astype(float)
        except (TypeError, ValueError):
            out = np.vectorize(lambda t: float(self.func(t)), otypes=[float])(s)
        return out

    def breakpoints(self, length):
        return tuple(b for b in self.kinks if 0.0 < b < length)


@dataclass(frozen=True)
class JigProfile(Profile):
    """Magnetization produced by a jig (paper eq. 1).

    The beam lies along the jig curve (x_jig(s), z_jig(s)) while it is magnetized along +x;
    where the jig's tangent angle is ``-psi(s)`` the straightened beam carries
    ``beta(s) = psi(s)``. Build it with :func:`jig_from_points`, :func:`jig_from_polyline` or
    :func:`jig_from_function`; :func:`jig_curve` goes the other way.

    Attributes
    ----------
    pieces : tuple of (s, beta) tuples
        Arc length (m) and beta (rad) sampled on each smooth piece of the jig; pieces meet at
        corners, which become breakpoints. Interpolated by a cubic spline per piece, or held
        constant per piece for polylines (``piecewise_constant``).
    """

    pieces: tuple
    piecewise_constant: bool = False
    length: float | None = None
    _splines: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "length", float(self.pieces[-1][0][-1]))
        if not self.piecewise_constant:
            object.__setattr__(self, "_splines", [CubicSpline(ps, pb) for ps, pb in self.pieces])

    @property
    def breaks(self) -> tuple[float, ...]:
        return tuple(float(p[0][0]) for p in self.pieces[1:])

    def values(self, s, length):
        s = np.asarray(s, dtype=float)
        idx = np.searchsorted(self.breaks, s, side="right")
        if self.piecewise_constant:
            return np.asarray([p[1][0] for p in self.pieces])[idx]
        out = np.empty_like(s)
        for k, spl in enumerate(self._splines):
            m = idx == k
            out[m] = spl(s[m])
        return out

    def breakpoints(self, length):
        return tuple(b for b in self.breaks if 0.0 < b < length)


def jig_from_polyline(x, z) -> JigProfile:
    """Jig made of straight pieces through points ``(x, z)`` (m): beta is constant on each piece."""
    x = finite_array("jig x", x, ndim=1, min_len=2)
    z = finite_array("jig z", z, ndim=1, min_len=2)
    if len(x) != len(z):
        raise ValueError(f"jig x and z must have the same length, got {len(x)} and {len(z)}.")
    seg = np.hypot(np.diff(x), np.diff(z))
    if np.any(seg <= 0):
        raise ValueError("jig polyline has repeated consecutive points (zero-length pieces).")
    s = np.concatenate([[0.0], np.cumsum(seg)])
    beta = -np.arctan2(np.diff(z), np.diff(x))
    pieces, start = [], 0
    for i in range(1, len(beta) + 1):  # merge collinear neighbours
        if i == len(beta) or beta[i] != beta[start]:
            pieces.append(((float(s[start]), float(s[i])), (float(beta[start]),) * 2))
            start = i
    return JigProfile(tuple(pieces), piecewise_constant=True)


def jig_from_points(x, z, *, corners: Sequence[int] = ()) -> JigProfile:
    """Smooth jig through points ``(x, z)`` (m), interpolated by an arc-length cubic spline.

    ``corners`` lists indices of points where the jig has a corner (the tangent jumps).
    """
    x = finite_array("jig x", x, ndim=1, min_len=3)
    z = finite_array("jig z", z, ndim=1, min_len=3)
    if len(x) != len(z):
        raise ValueError(f"jig x and z must have the same length, got {len(x)} and {len(z)}.")
    if np.any(np.hypot(np.diff(x), np.diff(z)) <= 0):
        raise ValueError("jig points must not repeat consecutively.")
    cuts = sorted({0, len(x) - 1, *[int(c) for c in corners]})
    pieces, s0 = [], 0.0
    for a, c in zip(cuts[:-1], cuts[1:], strict=True):
        xs, zs = x[a : c + 1], z[a : c + 1]
        if len(xs) < 2:
            continue
        chord = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(xs), np.diff(zs)))])
        kind = "not-a-knot" if len(xs) >= 4 else "natural"
        sx, sz = CubicSpline(chord, xs, bc_type=kind), CubicSpline(chord, zs, bc_type=kind)
        t = np.linspace(0.0, chord[-1], 8 * len(xs) + 1)
        arc = _cumulative_arc(t, lambda u, sx=sx, sz=sz: np.hypot(sx(u, 1), sz(u, 1)))
        ang = np.unwrap(-np.arctan2(sz(t, 1), sx(t, 1)))
        pieces.append((tuple((s0 + arc).tolist()), tuple(ang.tolist())))
        s0 += arc[-1]
    return JigProfile(tuple(pieces))


def jig_from_function(
    f: Callable,
    x_start: float,
    x_end: float,
    *,
    unit: float = 1.0,
    kinks: Sequence[float] = (),
    samples: int = 4001,
) -> JigProfile:
    """Jig ``z = f(x)`` for x in [x_start, x_end], as in the paper's Fig. 4b-d.

    ``f``, ``x_start``, ``x_end`` and ``kinks`` are in units of ``unit`` metres (``unit=1e-3``
    for the paper's millimetres). ``kinks`` are x values where the slope of f jumps.

    Examples
    --------
    >>> jig = jig_from_function(lambda x: 0.1 * (x - 20) ** 2, 10, 30, unit=1e-3)
    >>> round(jig.length * 1e3, 3)   # mm of beam the jig magnetizes
    29.579
    """
    if not callable(f):
        raise ValueError(f"jig_from_function needs a callable z = f(x), got {f!r}.")
    x0 = finite_number("x_start", x_start)
    x1 = finite_number("x_end", x_end)
    unit = positive("unit", unit, unit="m")
    if x1 <= x0:
        raise ValueError(f"x_end must be greater than x_start, got x_start={x0!r}, x_end={x1!r}.")
    ks = sorted(float(k) for k in kinks if x0 < float(k) < x1)
    edges = [x0, *ks, x1]
    pieces, s0 = [], 0.0
    n_piece = max(int(samples / len(edges)), 201) | 1
    for a, c in zip(edges[:-1], edges[1:], strict=True):
        h = 1e-5 * max(1.0, abs(c - a))

        def slope(u, a=a, c=c, h=h):
            # second-order differences that never step off this piece (kinks stay sharp)
            u = np.asarray(u, dtype=float)
            out = (np.asarray(f(u + h), float) - np.asarray(f(u - h), float)) / (2 * h)
            lo, hi = u - h < a, u + h > c
            if lo.any():
                v = u[lo]
                out[lo] = (-3 * np.asarray(f(v), float) + 4 * np.asarray(f(v + h), float) - f(v + 2 * h)) / (2 * h)
            if hi.any():
                v = u[hi]
                out[hi] = (3 * np.asarray(f(v), float) - 4 * np.asarray(f(v - h), float) + f(v - 2 * h)) / (2 * h)
            return out

        xs = np.linspace(a, c, n_piece)
        with np.errstate(all="ignore"):
            dz = slope(xs)
        if not np.all(np.isfinite(dz)):
            raise ValueError("jig function f(x) returned non-finite values on [x_start, x_end].")
        arc = _cumulative_arc(xs, lambda u, slope=slope: np.sqrt(1.0 + slope(u) ** 2)) * unit
        pieces.append((tuple((s0 + arc).tolist()), tuple((-np.arctan(dz)).tolist())))
        s0 += arc[-1]
    return JigProfile(tuple(pieces))


def jig_curve(profile, length: float, *, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Jig curve (x_jig, z_jig) in metres that produces magnetization ``profile`` (eq. 1).

    ``profile`` is a :class:`Profile`, a callable of s (m) or a number (rad).
    """
    length = positive("length", length, unit="m")
    if not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}.")
    prof = as_profile(profile, "profile")
    prof.check_covers(length, "profile")
    # fine grid including breakpoints, integrated with the trapezoid rule then sampled
    bps = prof.breakpoints(length)
    fine = np.unique(np.concatenate([np.linspace(0.0, length, max(40 * n + 1, 20001)), bps]))
    # evaluate one-sided at breakpoints: midpoints of each fine interval carry the value
    mid = 0.5 * (fine[1:] + fine[:-1])
    psi = prof.values(mid, length)
    dx = np.diff(fine)
    xj = np.concatenate([[0.0], np.cumsum(dx * np.cos(psi))])
    zj = np.concatenate([[0.0], np.cumsum(dx * np.sin(-psi))])
    s_out = np.linspace(0.0, length, n)
    return np.interp(s_out, fine, xj), np.interp(s_out, fine, zj)


def as_profile(value, name: str) -> Profile:
    """Turn a number, callable or Profile into a Profile (raises ValueError otherwise)."""
    if isinstance(value, Profile):
        return value
    if isinstance(value, (int, float, np.integer, np.floating)):
        return Constant(finite_number(name, value))
    if callable(value):
        return Function(value)
    raise ValueError(f"{name} must be a number, a callable of s (m) or a Profile, got {value!r}.")


def _cumulative_arc(t, speed) -> np.ndarray:
    """Cumulative integral of ``speed`` over the grid ``t``, 5-point Gauss-Legendre per interval."""
    t = np.asarray(t, dtype=float)
    g, w = np.polynomial.legendre.leggauss(5)
    mid, half = 0.5 * (t[1:] + t[:-1]), 0.5 * np.diff(t)
    vals = speed(mid[:, None] + half[:, None] * g[None, :])
    return np.concatenate([[0.0], np.cumsum(half * (vals @ w))])

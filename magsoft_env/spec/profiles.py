"""Profiles along the beam: magnetization angle beta(s) or direction, and volume fraction phi(s).

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

from ..validate import angle as check_angle
from ..validate import boolean, finite_array, finite_number, integer, pair, positive

_COVER_RTOL = 1e-9
#: Most cells :func:`alternating_cells` builds (each boundary is a spectral subdomain of the solver).
MAX_CELLS = 1000
#: Most kinks of :func:`jig_from_function` (each one is a piece with at least 201 samples).
MAX_KINKS = 1000
#: Most samples of :func:`jig_from_function` and points of :func:`jig_curve`.
MAX_SAMPLES = 1_000_000
MAX_JIG_CURVE_POINTS = 100_000
#: Largest ``unit`` of :func:`jig_from_function` (m): the jig's x and z are in metres or smaller units.
MAX_UNIT = 1.0
#: Longest beam :func:`jig_curve` draws a jig for (m), as :data:`magsoft_env.spec.beam.MAX_SIZE`.
MAX_JIG_LENGTH = 1.0


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

    def spline_knots(self, length: float) -> tuple[float, ...]:
        """Interior knots (m) of a cubic-spline profile, where its third derivative jumps (none here).

        Solvers that need smooth pieces may cut there when the knots are few; a densely
        sampled spline's jumps are small enough to ignore."""
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
        else:
            length = positive(f"{type(self).__name__} length", length, unit="m")
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
    """Magnetization of ``n`` (in [1, MAX_CELLS]) equal cells alternating between ``angle`` and ``angle + pi`` (rad)."""
    n = integer("alternating_cells n", n, 1, MAX_CELLS)
    a = check_angle("alternating_cells angle", angle)
    flip = np.pi if a <= np.pi else -np.pi  # the opposite direction, kept within [-2 pi, 2 pi]
    return PiecewiseConstant([a + flip * (i % 2) for i in range(n)])


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
        if not callable(self.func) or isinstance(self.func, type):
            raise ValueError(f"Function profile needs a callable of s (m), got {self.func!r}.")
        if isinstance(self.kinks, (str, bytes)) or not isinstance(self.kinks, (Sequence, np.ndarray)):
            raise ValueError(f"Function breakpoints (kinks) must be a sequence of arc lengths (m), got {self.kinks!r}.")
        b = finite_array("Function breakpoints", list(self.kinks), ndim=1)
        object.__setattr__(self, "kinks", tuple(sorted(b.tolist())))
        if self.length is not None:
            object.__setattr__(self, "length", positive("Function length", self.length, unit="m"))

    def values(self, s, length):
        """``func`` at ``s``: called once on the array, or point by point if that fails or gives the wrong shape.

        Raises ValueError when ``func`` does not return one number per arc length."""
        s = np.asarray(s, dtype=float)
        try:
            raw = np.asarray(self.func(s))
            if raw.dtype.kind in "bUSV":
                raise ValueError("not numbers")
            out = raw.astype(float)
            if out.shape != s.shape:
                out = np.broadcast_to(out, s.shape).astype(float)
        except (TypeError, ValueError):
            out = np.vectorize(self._at, otypes=[float])(s) if s.size else np.empty(s.shape)
        except Exception as exc:  # a user function: any failure is bad input
            raise ValueError(f"Function profile: the function of s raised {type(exc).__name__}: {exc}") from None
        return out

    def _at(self, t: float) -> float:
        try:
            v = np.asarray(self.func(t))
        except Exception as exc:  # a user function: any failure is bad input
            raise ValueError(
                f"Function profile: the function of s raised {type(exc).__name__} at s = {t!r} m: {exc}"
            ) from None
        if v.dtype.kind not in "iuf" or v.size != 1:
            raise ValueError(
                f"Function profile must return one number per arc length s (m), got {_short(v)} at s = {t!r} m."
            )
        return float(v.reshape(()))

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
    #: How the jig was built (``("polyline", x, z)``, ``("points", x, z, corners)`` or ``("function", expression,
    #: x_start, x_end, unit, kinks, samples)`` for a jig expression), so that a robot file can store the jig
    #: itself rather than its samples; ``None`` when built from samples or from a Python function.
    recipe: tuple | None = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        flat = boolean("JigProfile piecewise_constant", self.piecewise_constant)
        object.__setattr__(self, "pieces", _check_pieces(self.pieces))
        object.__setattr__(self, "piecewise_constant", flat)
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

    def spline_knots(self, length):
        if self.piecewise_constant:
            return ()
        return tuple(float(v) for ps, _ in self.pieces for v in ps[1:-1] if 0.0 < v < length)


@dataclass(frozen=True)
class Sampled(Profile):
    """A free profile given by samples: a cubic spline (not-a-knot) through ``values`` at ``s_samples`` (m).

    ``s_samples`` start at 0 and increase strictly; the profile covers ``[0, s_samples[-1]]``.
    :func:`sample_profile` samples any profile (a Python function too) this way, piece by piece
    between its breakpoints, so that it can be saved in a robot file.

    Examples
    --------
    >>> p = Sampled([0.0, 0.01, 0.02], [0.1, 0.2, 0.3])
    >>> round(float(p(0.005)), 12)
    0.15
    """

    s_samples: Sequence[float]
    sample_values: Sequence[float]
    length: float | None = None
    _spline: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        s = finite_array("Sampled s_samples", self.s_samples, ndim=1, min_len=2)
        v = finite_array("Sampled values", self.sample_values, ndim=1, min_len=2)
        if len(s) != len(v):
            raise ValueError(f"Sampled needs as many values as samples ({len(s)}), got {len(v)}.")
        if len(s) > MAX_SAMPLES:
            raise ValueError(f"Sampled takes at most {MAX_SAMPLES} samples, got {len(s)}.")
        if s[0] != 0.0:
            raise ValueError(f"Sampled s_samples must start at 0 m, got {s[0]!r}.")
        if np.any(np.diff(s) <= 0):
            raise ValueError(f"Sampled s_samples must be strictly increasing (m), got {s.tolist()[:8]}...")
        object.__setattr__(self, "s_samples", tuple(s.tolist()))
        object.__setattr__(self, "sample_values", tuple(v.tolist()))
        object.__setattr__(self, "length", float(s[-1]))
        kind = "not-a-knot" if len(s) >= 4 else "natural"
        object.__setattr__(self, "_spline", CubicSpline(s, v, bc_type=kind))

    def values(self, s, length):
        return np.asarray(self._spline(np.asarray(s, dtype=float)), dtype=float)

    def spline_knots(self, length):
        return tuple(float(v) for v in self.s_samples[1:-1] if 0.0 < v < length)


def sample_profile(profile, length: float, *, n: int = 257) -> Profile:
    """``profile`` on ``[0, length]`` (m) as samples that a robot file can hold.

    A smooth profile becomes one :class:`Sampled` spline of ``n`` points (an integer in [4, 100000]);
    one with breakpoints (cells, corners, a Function's ``kinks``) becomes a :class:`JigProfile` of
    spline pieces between them, ``n`` points in all (at least 4 per piece), so that jumps stay sharp.
    Raises ValueError where the profile cannot be evaluated.
    """
    length = positive("length", length, unit="m")
    n = integer("sample_profile n", n, 4, MAX_JIG_CURVE_POINTS)
    prof = as_profile(profile, "profile")
    prof.check_covers(length, "profile")
    bps = [b for b in prof.breakpoints(length) if 0.0 < b < length]
    edges = [0.0, *bps, length]
    per = max(4, n // (len(edges) - 1))
    pieces = []
    for a, c in zip(edges[:-1], edges[1:], strict=True):
        s = np.linspace(a, c, per)
        # evaluate just inside the piece, so that a jump at a breakpoint belongs to the right side
        inside = s.copy()
        inside[0], inside[-1] = np.nextafter(a, c), np.nextafter(c, a)
        v = np.asarray(prof.values(inside, length), dtype=float)
        if v.shape != s.shape or not np.all(np.isfinite(v)):
            raise ValueError("sample_profile: the profile must give one finite number per arc length.")
        pieces.append((tuple(s.tolist()), tuple(v.tolist())))
    if len(pieces) == 1:
        return Sampled(pieces[0][0], pieces[0][1])
    return JigProfile(tuple(pieces))


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
    return JigProfile(tuple(pieces), piecewise_constant=True, recipe=("polyline", tuple(x.tolist()), tuple(z.tolist())))


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
    if isinstance(corners, (str, bytes)) or not isinstance(corners, (Sequence, np.ndarray, set, frozenset)):
        raise ValueError(f"jig corners must be a sequence of point indices, got {corners!r}.")
    corner_idx = [integer(f"jig corners[{i}]", c, 1, len(x) - 2) for i, c in enumerate(corners)]
    cuts = sorted({0, len(x) - 1, *corner_idx})
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
    return JigProfile(tuple(pieces), recipe=("points", tuple(x.tolist()), tuple(z.tolist()), tuple(corner_idx)))


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
    if not callable(f) or isinstance(f, type):
        raise ValueError(f"jig_from_function needs a callable z = f(x), got {f!r}.")
    x0 = finite_number("x_start", x_start)
    x1 = finite_number("x_end", x_end)
    unit = positive("unit", unit, unit="m")
    if unit > MAX_UNIT:
        raise ValueError(f"unit must lie in (0, {MAX_UNIT:g}] m (the size of one x unit: 1e-3 for mm), got {unit!r}.")
    samples = integer("jig_from_function samples", samples, 2, MAX_SAMPLES)
    if x1 <= x0:
        raise ValueError(f"x_end must be greater than x_start, got x_start={x0!r}, x_end={x1!r}.")
    if isinstance(kinks, (str, bytes)) or not isinstance(kinks, (Sequence, np.ndarray, set, frozenset)):
        raise ValueError(f"kinks must be a sequence of x values (in units of unit), got {kinks!r}.")
    if len(kinks) > MAX_KINKS:
        raise ValueError(f"kinks must have at most {MAX_KINKS} entries, got {len(kinks)}.")
    ks = sorted({k for k in (finite_number(f"kinks[{i}]", k) for i, k in enumerate(kinks)) if x0 < k < x1})
    edges = [x0, *ks, x1]
    pieces, s0 = [], 0.0
    n_piece = max(int(samples / len(edges)), 201) | 1
    fz = _jig_function(f)
    for a, c in zip(edges[:-1], edges[1:], strict=True):
        h = 1e-5 * max(1.0, abs(c - a))

        def slope(u, a=a, c=c, h=h):
            # second-order differences that never step off this piece (kinks stay sharp)
            u = np.asarray(u, dtype=float)
            out = (fz(u + h) - fz(u - h)) / (2 * h)
            lo, hi = u - h < a, u + h > c
            if lo.any():
                v = u[lo]
                out[lo] = (-3 * fz(v) + 4 * fz(v + h) - fz(v + 2 * h)) / (2 * h)
            if hi.any():
                v = u[hi]
                out[hi] = (3 * fz(v) - 4 * fz(v - h) + fz(v - 2 * h)) / (2 * h)
            return out

        xs = np.linspace(a, c, n_piece)
        with np.errstate(all="ignore"):
            dz = slope(xs)
        if not np.all(np.isfinite(dz)):
            raise ValueError("jig function f(x) returned non-finite values on [x_start, x_end].")
        arc = _cumulative_arc(xs, lambda u, slope=slope: np.sqrt(1.0 + slope(u) ** 2)) * unit
        pieces.append((tuple((s0 + arc).tolist()), tuple((-np.arctan(dz)).tolist())))
        s0 += arc[-1]
    text = getattr(f, "expression", None)  # a jig expression (compile_expression) can be stored as text
    recipe = ("function", text, x0, x1, unit, tuple(ks), samples) if isinstance(text, str) else None
    return JigProfile(tuple(pieces), recipe=recipe)


def jig_curve(profile, length: float, *, n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Jig curve (x_jig, z_jig) in metres that produces magnetization ``profile`` (eq. 1).

    ``profile`` is a :class:`Profile`, a callable of s (m) or a number (rad); ``length`` in (0, 1] m;
    ``n`` points, an integer in [2, 100000].
    """
    length = positive("length", length, unit="m")
    if length > MAX_JIG_LENGTH:
        raise ValueError(
            f"length must lie in (0, {MAX_JIG_LENGTH:g}] m, got {length!r} (lengths are in metres: "
            f"{length:g} mm is {length * 1e-3:g})."
        )
    n = integer("jig_curve n", n, 2, MAX_JIG_CURVE_POINTS)
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


#: Names of a magnetization direction's components, in the undeformed cross-section's frame (x, y, z).
DIRECTION_COMPONENTS = ("axial", "width", "thickness")


@dataclass(frozen=True)
class Direction:
    """Direction of the remanent magnetization in the undeformed beam, one profile per component.

    The components are along the undeformed strip's axes: ``axial`` along it (x, from the clamp), ``width``
    across its width (y) and ``thickness`` through its thickness (z, up). Each is a number, a callable of s (m)
    or a :class:`Profile` (any family: cells, :class:`PiecewiseLinear`, :class:`Sampled`, :class:`Function`,
    a jig profile...), read by :func:`as_profile`. Only the direction counts: :meth:`vectors` normalizes
    pointwise, the magnitude comes from the volume fraction and M_p (:class:`~magsoft_env.spec.material.Material`).
    The planar angle beta is ``Direction(cos beta, 0, sin beta)``; a zero vector anywhere on the beam is refused
    by :class:`~magsoft_env.spec.beam.Beam`, and by :meth:`vectors` where it is evaluated.

    Examples
    --------
    >>> d = Direction(1.0, 0.0, PiecewiseConstant([1.0, -1.0]))   # 45 deg up, then 45 deg down
    >>> (d.vectors([0.005, 0.015], 0.02) ** 2).round(3).tolist()
    [[0.5, 0.0, 0.5], [0.5, 0.0, 0.5]]
    >>> d.breakpoints(0.02)
    (0.01,)
    """

    axial: Profile
    width: Profile
    thickness: Profile

    def __post_init__(self):
        for c in DIRECTION_COMPONENTS:
            object.__setattr__(self, c, as_profile(getattr(self, c), f"Direction {c}"))

    @property
    def components(self) -> tuple[Profile, Profile, Profile]:
        """The three profiles (axial, width, thickness)."""
        return (self.axial, self.width, self.thickness)

    @property
    def length(self) -> float | None:
        """Arc length (m) every component covers (the shortest of those that carry one), or None (relative)."""
        own = [p.length for p in self.components if p.length is not None]
        return min(own) if own else None

    @property
    def has_width(self) -> bool:
        """False when the width component is identically zero (a planar direction in the x-z plane)."""
        return not _identically_zero(self.width)

    def components_at(self, s, length: float) -> np.ndarray:
        """The raw components (not normalized) at arc lengths ``s`` (m), shape ``s.shape + (3,)``."""
        s = np.asarray(s, dtype=float)
        return np.stack([np.broadcast_to(np.asarray(p.values(s, length), dtype=float), s.shape)
                         for p in self.components], axis=-1)

    def vectors(self, s, length: float) -> np.ndarray:
        """Unit vectors (axial, width, thickness) at arc lengths ``s`` (m) on a beam of ``length`` (m), shape
        ``s.shape + (3,)`` ((n, 3) for n arc lengths). A ValueError where the direction is the zero vector."""
        v = self.components_at(s, length)
        if not np.all(np.isfinite(v)):
            bad = np.broadcast_to(np.asarray(s, dtype=float), v.shape[:-1])[~np.all(np.isfinite(v), axis=-1)]
            raise ValueError(f"Direction must have finite (axial, width, thickness) components, got non-finite "
                             f"values at s = {float(bad.ravel()[0]) * 1e3:.6g} mm.")
        scale = np.max(np.abs(v), axis=-1, keepdims=True)
        if np.any(scale == 0.0):
            bad = np.broadcast_to(np.asarray(s, dtype=float), scale.shape[:-1])[scale[..., 0] == 0.0]
            raise ValueError(f"Direction is the zero vector at s = {float(bad.ravel()[0]) * 1e3:.6g} mm: a "
                             "magnetization direction needs a non-zero (axial, width, thickness) everywhere.")
        return unit_rows(v, scale)

    def values(self, s, length):
        """Refused: a direction has three components, not one angle (see :meth:`vectors`)."""
        raise ValueError("a magnetization Direction has three components (axial, width, thickness), not one angle "
                         "beta; use Direction.vectors(s, length) (or Beam.magnetization_direction(s)).")

    def breakpoints(self, length: float) -> tuple[float, ...]:
        """Interior arc lengths (m) where any component is not smooth, sorted."""
        return tuple(sorted({b for p in self.components for b in p.breakpoints(length)}))

    def spline_knots(self, length: float) -> tuple[float, ...]:
        """Interior spline knots (m) of every component, sorted."""
        return tuple(sorted({k for p in self.components for k in p.spline_knots(length)}))

    def check_covers(self, length: float, name: str) -> None:
        """Raise ValueError if a component does not cover ``[0, length]``."""
        for c, p in zip(DIRECTION_COMPONENTS, self.components, strict=True):
            p.check_covers(length, f"{name} {c}")


def unit_rows(v: np.ndarray, scale: np.ndarray | None = None) -> np.ndarray:
    """``v / |v|`` along the last axis without overflow or underflow: each row is first divided by its largest
    magnitude ``scale`` (computed when not given), so components like 1e200 or 1e-200 keep their direction
    instead of squaring to inf or 0. Rows must be finite and non-zero (the callers check)."""
    if scale is None:
        scale = np.max(np.abs(v), axis=-1, keepdims=True)
    w = v / scale
    return w / np.linalg.norm(w, axis=-1, keepdims=True)


def _identically_zero(p: Profile) -> bool:
    """True for a profile that is zero everywhere by construction (a constant 0, zero cells or knots)."""
    if type(p) is Constant:
        return p.value == 0.0
    if type(p) is PiecewiseConstant:
        return all(v == 0.0 for v in p.levels)
    if type(p) is PiecewiseLinear:
        return all(v == 0.0 for v in p.knot_values)
    if type(p) is Sampled:
        return all(v == 0.0 for v in p.sample_values)
    return False


def as_magnetization(value, name: str) -> Profile | Direction:
    """A magnetization: an angle beta (a number in rad, a callable of s or a :class:`Profile`, see
    :func:`as_profile`) or a direction: a :class:`Direction`, or a sequence of three entries (axial, width,
    thickness), each a number, a callable of s or a Profile. Anything else is a ValueError naming ``name``."""
    if isinstance(value, (Profile, Direction)):
        return value
    if isinstance(value, (tuple, list)) or (isinstance(value, np.ndarray) and value.ndim == 1):
        if len(value) == 3:
            return Direction(*(as_profile(v, f"{name} {c}") for c, v in zip(DIRECTION_COMPONENTS, value,
                                                                              strict=True)))
        raise ValueError(f"{name} must be a number, a callable of s (m) or a Profile (the angle beta, rad), or a "
                         f"direction (axial, width, thickness) of three of those, got {len(value)} entries: "
                         f"{value!r}.")
    return as_profile(value, name)


def _short(v) -> str:
    v = np.asarray(v)
    return f"shape {v.shape}" if v.size != 1 else repr(v.reshape(()).item())


def _jig_function(f):
    """``f`` as a function of a float array returning a float array of the same shape.

    ``f`` is called on the whole array, or point by point when that fails (a function written for
    scalars) or gives a shape that does not broadcast; anything but one number per x is a ValueError."""

    def fz(u):
        u = np.asarray(u, dtype=float)
        try:
            raw = np.asarray(f(u))
            if raw.dtype.kind not in "iuf":
                raise TypeError("not numbers")
            return np.broadcast_to(raw.astype(float), u.shape).astype(float)
        except (TypeError, ValueError):
            pass
        except Exception as exc:  # a user function: any failure is bad input
            raise ValueError(f"jig function f(x) raised {type(exc).__name__}: {exc}") from None
        return np.vectorize(point, otypes=[float])(u) if u.size else np.empty(u.shape)

    def point(t):
        try:
            v = np.asarray(f(t))
        except ValueError:
            raise
        except Exception as exc:
            raise ValueError(f"jig function f(x) raised {type(exc).__name__} at x = {t!r}: {exc}") from None
        if v.dtype.kind not in "iuf" or v.size != 1:
            raise ValueError(f"jig function f(x) must return one number per x, got {_short(v)} at x = {t!r}.")
        return float(v.reshape(()))

    return fz


def _check_pieces(pieces) -> tuple:
    """JigProfile pieces as a tuple of (s, beta) float tuples: each piece at least 2 finite samples, s strictly
    increasing, the first piece starting at s = 0 and each next one where the last ended."""
    if isinstance(pieces, (str, bytes)) or not isinstance(pieces, (Sequence, np.ndarray)) or len(pieces) == 0:
        raise ValueError(
            f"JigProfile pieces must be a non-empty sequence of (s, beta) pairs of sample tuples, got {pieces!r}; "
            "build jigs with jig_from_points, jig_from_polyline or jig_from_function."
        )
    out, end = [], 0.0
    for k, piece in enumerate(pieces):
        ps, pb = pair(f"JigProfile pieces[{k}]", piece, "(s, beta) of sample sequences")
        s = finite_array(f"JigProfile pieces[{k}] s", ps, ndim=1, min_len=2)
        b = finite_array(f"JigProfile pieces[{k}] beta", pb, ndim=1, min_len=2)
        if len(s) != len(b):
            raise ValueError(f"JigProfile pieces[{k}] needs as many beta as s samples ({len(s)}), got {len(b)}.")
        if np.any(np.diff(s) <= 0):
            raise ValueError(f"JigProfile pieces[{k}] s must be strictly increasing (m), got {s.tolist()[:8]}...")
        if abs(s[0] - end) > 1e-9 * max(abs(end), abs(s[-1]), 1e-300):
            where = "start at s = 0" if k == 0 else f"start where piece {k - 1} ended (s = {end!r} m)"
            raise ValueError(f"JigProfile pieces[{k}] must {where}, got s[0] = {s[0]!r} m.")
        end = float(s[-1])
        out.append((tuple(s.tolist()), tuple(b.tolist())))
    return tuple(out)


def _cumulative_arc(t, speed) -> np.ndarray:
    """Cumulative integral of ``speed`` over the grid ``t``, 5-point Gauss-Legendre per interval."""
    t = np.asarray(t, dtype=float)
    g, w = np.polynomial.legendre.leggauss(5)
    mid, half = 0.5 * (t[1:] + t[:-1]), 0.5 * np.diff(t)
    vals = speed(mid[:, None] + half[:, None] * g[None, :])
    return np.concatenate([[0.0], np.cumsum(half * (vals @ w))])

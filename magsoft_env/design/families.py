"""Parametrized magnetization profiles beta(s) for inverse design: polynomial, Fourier, piecewise linear, spline.

Every family is linear in its parameters: ``beta(s) = Phi(s / L) @ p`` with a fixed basis
``Phi`` of the normalized arc length u = s / L in [0, 1]. That makes the initial guess a linear
least-squares fit and keeps bounds simple boxes on ``p``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..spec import PiecewiseLinear, Profile, Sampled
from ..validate import choice, finite_array, integer, positive

FAMILIES = ("polynomial", "fourier", "piecewise_linear", "spline")
MAX_SIZE = 40  # most parameters of a family


@dataclass(frozen=True)
class ProfileFamily:
    """A family of magnetization profiles with ``size`` parameters.

    Parameters
    ----------
    kind : {"polynomial", "fourier", "piecewise_linear", "spline"}
        ``polynomial``: Chebyshev series sum_k p_k T_k(2u - 1), k < size (degree size - 1).
        ``fourier``: p_0 + sum_k p_(2k-1) cos(k pi u) + p_(2k) sin(k pi u), k = 1..(size - 1) / 2
        (``size`` odd). ``piecewise_linear``: values (rad) at ``size`` evenly spaced knots,
        linear between them. ``spline``: values (rad) at ``size`` evenly spaced knots, a
        not-a-knot cubic spline between them (smooth jigs).
    size : int
        Number of parameters.

    For ``piecewise_linear`` and ``spline`` the parameters are angles (rad) and their bounds are
    bounds on beta at the knots; for ``polynomial`` and ``fourier`` they are coefficients (rad).
    """

    kind: str = "spline"
    size: int = 6

    def __post_init__(self):
        if not isinstance(self.kind, str):
            raise ValueError(f"family must be one of {list(FAMILIES)}, got {self.kind!r}.")
        choice("family", self.kind, FAMILIES)
        minimum = {"polynomial": 1, "fourier": 1, "piecewise_linear": 2, "spline": 4}[self.kind]
        size = integer(f"{self.kind} family size", self.size, minimum, MAX_SIZE)
        if self.kind == "fourier" and size % 2 == 0:
            raise ValueError(f"fourier family size must be odd (1 + 2 x harmonics), got {self.size!r}.")
        object.__setattr__(self, "size", size)

    @property
    def knots(self) -> np.ndarray:
        """Knot positions u in [0, 1] (piecewise linear and spline families)."""
        return np.linspace(0.0, 1.0, self.size)

    @cached_property
    def _spline_basis(self):
        from scipy.interpolate import CubicSpline

        return CubicSpline(self.knots, np.eye(self.size), bc_type="not-a-knot")

    def basis(self, u) -> np.ndarray:
        """Basis matrix ``Phi`` of shape ``(len(u), size)`` at normalized arc lengths ``u``."""
        u = np.clip(np.atleast_1d(np.asarray(u, dtype=float)), 0.0, 1.0)
        if self.kind == "polynomial":
            return np.polynomial.chebyshev.chebvander(2.0 * u - 1.0, self.size - 1)
        if self.kind == "fourier":
            cols = [np.ones_like(u)]
            for k in range(1, (self.size - 1) // 2 + 1):
                cols += [np.cos(k * math.pi * u), np.sin(k * math.pi * u)]
            return np.column_stack(cols)
        if self.kind == "piecewise_linear":
            return np.column_stack([np.interp(u, self.knots, row) for row in np.eye(self.size)])
        return self._spline_basis(u)

    def profile(self, params, length: float) -> Profile:
        """The magnetization profile (rad) for ``params`` on a beam of ``length`` (m)."""
        p = finite_array(f"{self.kind} family params", params)
        if p.shape != (self.size,):
            raise ValueError(f"{self.kind} family needs {self.size} parameters, got shape {p.shape}.")
        length = positive(f"{self.kind} family length", length, unit="m")
        if self.kind == "piecewise_linear":
            return PiecewiseLinear(tuple((self.knots * length).tolist()), tuple(p.tolist()))
        return BasisProfile(self, tuple(p.tolist()), float(length))

    def fit(self, u, beta) -> np.ndarray:
        """Least-squares parameters whose profile best matches ``beta`` (rad) at ``u``."""
        u = finite_array("fit u", u, ndim=1, min_len=1)
        beta = finite_array("fit beta", beta, ndim=1)
        if beta.shape != u.shape:
            raise ValueError(f"fit needs one beta per u ({len(u)}), got {len(beta)}.")
        phi = self.basis(u)
        return np.linalg.lstsq(phi, beta, rcond=None)[0]


@dataclass(frozen=True)
class BasisProfile(Profile):
    """A magnetization profile from a :class:`ProfileFamily` and its parameters, on a beam of ``length`` (m)."""

    family: ProfileFamily
    params: tuple
    length: float

    def __post_init__(self):
        if not isinstance(self.family, ProfileFamily):
            raise ValueError(f"BasisProfile family must be a ProfileFamily, got {self.family!r}.")
        p = finite_array("BasisProfile params", self.params)
        if p.shape != (self.family.size,):
            raise ValueError(f"BasisProfile needs {self.family.size} params, got shape {p.shape}.")
        object.__setattr__(self, "params", tuple(p.tolist()))
        object.__setattr__(self, "length", positive("BasisProfile length", self.length, unit="m"))

    def spline_knots(self, length):
        if self.family.kind != "spline":
            return ()
        return tuple(float(u) * self.length for u in self.family.knots[1:-1])

    def portable(self) -> Profile | None:
        """The same profile as a file-serializable one, or None: a spline family is the not-a-knot spline
        through its knot values (:class:`~magsoft_env.spec.Sampled`, equal to round-off); the polynomial and
        Fourier series have none (a robot file samples them: ``Robot.save(path, sample_functions=True)``)."""
        if self.family.kind != "spline":
            return None
        return Sampled(tuple((self.family.knots * self.length).tolist()), self.params)

    def values(self, s, length):
        s = np.asarray(s, dtype=float)
        u = s.ravel() / self.length
        return (self.family.basis(u) @ np.asarray(self.params)).reshape(s.shape)

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

from ..spec import PiecewiseLinear, Profile
from ..validate import choice

FAMILIES = ("polynomial", "fourier", "piecewise_linear", "spline")


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
        choice("family", self.kind, FAMILIES)
        minimum = {"polynomial": 1, "fourier": 1, "piecewise_linear": 2, "spline": 4}[self.kind]
        if not isinstance(self.size, (int, np.integer)) or not minimum <= self.size <= 40:
            raise ValueError(f"{self.kind} family size must be an integer in [{minimum}, 40], got {self.size!r}.")
        if self.kind == "fourier" and self.size % 2 == 0:
            raise ValueError(f"fourier family size must be odd (1 + 2 x harmonics), got {self.size!r}.")
        object.__setattr__(self, "size", int(self.size))

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
        p = np.asarray(params, dtype=float)
        if p.shape != (self.size,):
            raise ValueError(f"{self.kind} family needs {self.size} parameters, got shape {p.shape}.")
        if self.kind == "piecewise_linear":
            return PiecewiseLinear(tuple((self.knots * length).tolist()), tuple(p.tolist()))
        return BasisProfile(self, tuple(p.tolist()), float(length))

    def fit(self, u, beta) -> np.ndarray:
        """Least-squares parameters whose profile best matches ``beta`` (rad) at ``u``."""
        phi = self.basis(u)
        return np.linalg.lstsq(phi, np.asarray(beta, dtype=float), rcond=None)[0]


@dataclass(frozen=True)
class BasisProfile(Profile):
    """A magnetization profile from a :class:`ProfileFamily` and its parameters, on a beam of ``length`` (m)."""

    family: ProfileFamily
    params: tuple
    length: float

    def values(self, s, length):
        s = np.asarray(s, dtype=float)
        u = s.ravel() / self.length
        return (self.family.basis(u) @ np.asarray(self.params)).reshape(s.shape)

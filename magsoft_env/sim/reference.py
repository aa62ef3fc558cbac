"""Closed-form references for checking the rod (independent of the rod and of ``theory``).

* :func:`elastica_dead_load`: Euler's elastica of a uniform cantilever under a dead tip load
  ``F`` at angle ``alpha``, by the first integral and quadrature. A uniform axially
  magnetized beam (beta = 0) without gravity obeys the same equation with ``F = A M B``:
  ``E I theta'' = F sin(theta - alpha)``, ``theta(0) = 0``, ``theta'(L) = 0``.
* :func:`tip_couple_angle`: a pure tip couple C bends a uniform beam to uniform curvature
  ``C / (E I)``; tip angle ``C L / (E I)``.
* :func:`gravity_tip_deflection_small`: small-deflection tip deflection under self-weight,
  ``-rho A g L^4 / (8 E I)``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
from scipy.integrate import IntegrationWarning, quad
from scipy.optimize import brentq


def _integrals(theta_L: float, alpha: float, c: float) -> tuple[float, float, float]:
    """(length, x_tip, z_tip) of the branch with tip angle theta_L, for ``c = 2 F / (E I)``."""
    # theta'^2 = c (cos(theta_L - alpha) - cos(theta - alpha))
    #          = -2 c sin((theta_L + theta) / 2 - alpha) sin((theta_L - theta) / 2);
    # theta = theta_L (1 - v^2) removes the inverse-square-root singularity at the tip.
    def ds_dv(v):
        th = theta_L * (1.0 - v * v)
        half = 0.5 * theta_L if v < 1e-7 else math.sin(0.5 * theta_L * v * v) / (v * v)
        g = -2.0 * c * math.sin(0.5 * (theta_L + th) - alpha) * half
        return 2.0 * abs(theta_L) / math.sqrt(g), th

    def fl(v):
        return ds_dv(v)[0]

    def fx(v):
        w, th = ds_dv(v)
        return w * math.cos(th)

    def fz(v):
        w, th = ds_dv(v)
        return w * math.sin(th)

    opts = dict(epsabs=0.0, epsrel=1e-10, limit=400)
    return quad(fl, 0.0, 1.0, **opts)[0], quad(fx, 0.0, 1.0, **opts)[0], quad(fz, 0.0, 1.0, **opts)[0]


def elastica_dead_load(length: float, EI: float, force: float, alpha: float) -> dict[str, float]:
    """Tip of a clamped uniform elastica under a dead tip load (first, monotone branch).

    Parameters
    ----------
    length : float
        L (m).
    EI : float
        Bending stiffness (N m^2).
    force : float
        Load magnitude F (N), > 0.
    alpha : float
        Load direction from +x toward +z (rad), in (0, pi) or (-pi, 0).

    Returns
    -------
    dict
        ``tip_angle`` (rad), ``x``, ``z`` (m) of the tip.
    """
    if not (0.0 < abs(alpha) < math.pi) or force <= 0.0:
        raise ValueError(f"need force > 0 and 0 < |alpha| < pi, got force={force!r}, alpha={alpha!r}.")
    c = 2.0 * force / EI
    sgn = 1.0 if alpha > 0 else -1.0

    def f(tl):
        return _integrals(tl, alpha, c)[0] - length

    eps = 1e-12
    lo, hi = sgn * eps, sgn * abs(alpha) * (1.0 - 1e-7)
    with warnings.catch_warnings():
        # the bracket's far end sits next to the logarithmic singularity at theta_L = alpha
        warnings.simplefilter("ignore", IntegrationWarning)
        tl = brentq(f, min(lo, hi), max(lo, hi), xtol=1e-14, rtol=1e-13)
    _, x, z = _integrals(tl, alpha, c)
    return {"tip_angle": tl, "x": x, "z": z}


def tip_couple_angle(length: float, EI: float, couple: float) -> float:
    """Tip angle (rad) of a uniform cantilever under a pure tip couple ``couple`` (N m)."""
    return couple * length / EI


def gravity_tip_deflection_small(length: float, EI: float, mass_per_length: float, gravity: float) -> float:
    """Small-deflection tip z (m) of a uniform cantilever under its own weight (negative: down)."""
    return -mass_per_length * gravity * length**4 / (8.0 * EI)


def circle_points(s: np.ndarray, curvature: float) -> tuple[np.ndarray, np.ndarray]:
    """Points (x, z) (m) at arc lengths ``s`` of a clamped arc of uniform ``curvature`` (1/m)."""
    s = np.asarray(s, dtype=float)
    if curvature == 0.0:
        return s.copy(), np.zeros_like(s)
    return np.sin(curvature * s) / curvature, (1.0 - np.cos(curvature * s)) / curvature

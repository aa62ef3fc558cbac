"""Closed-form reference: Euler's elastica of a cantilever under a dead tip load.

A uniformly, axially magnetized cantilever without gravity obeys
``E I theta'' = A M B sin(theta - alpha)`` with ``theta(0) = theta_0``, ``theta'(L) = 0``:
the equation of a cantilever loaded at its tip by a dead force of magnitude ``F = A M B`` in
the field direction ``alpha``. With ``q = pi + alpha - theta`` it is the pendulum
``q'' = -lambda sin q`` (``lambda = F / EI``) with a turning point at the tip, solved by
elliptic integrals::

    k = sin(q_L / 2),  sin(q_0 / 2) = k sin(phi_0),
    sqrt(lambda) L = K(k) - F(phi_0, k)

This module is independent of the collocation solver and serves as its reference.
"""

from __future__ import annotations

import math

from scipy.optimize import brentq
from scipy.special import ellipeinc, ellipkinc, ellipkm1


def elastica_tip(force: float, angle: float, EI: float, length: float, *, clamp_angle: float = 0.0):
    """Tip angle (rad) and tip position (m) of the first-mode elastica under a dead tip load.

    Parameters
    ----------
    force : float
        Magnitude of the tip force F (N); for a magnetic beam ``A M B_a``.
    angle : float
        Direction of the force (rad from +x toward +z); for a magnetic beam the field angle.
    EI : float
        Bending stiffness (N m^2).
    length : float
        Length L (m).
    clamp_angle : float
        theta(0) (rad).

    Returns
    -------
    theta_L, x_L, z_L : float
        Tip tangent angle and tip position relative to the clamp.
    """
    lam = force / EI
    sl = math.sqrt(lam) * length
    q0 = math.remainder(math.pi + angle - clamp_angle, 2 * math.pi)  # in [-pi, pi]
    sigma = 1.0 if q0 >= 0 else -1.0
    a0 = abs(q0)
    s0 = math.sin(a0 / 2)
    if lam == 0.0 or (a0 == 0.0 and sl <= math.pi / 2):
        th = clamp_angle
        return th, length * math.cos(th), length * math.sin(th)

    def parts(log_m1):
        m1 = 10.0**log_m1
        m = 1.0 - m1
        k = math.sqrt(m)
        phi0 = math.asin(min(1.0, s0 / k))
        K = float(ellipkm1(m1))
        return m, k, math.sqrt(m1), phi0, K

    def g(log_m1):
        m, _, _, phi0, K = parts(log_m1)
        return K - float(ellipkinc(phi0, m)) - sl

    hi = math.log10(max(1.0 - s0 * s0, 1e-300)) - 1e-12
    lo = -15.5
    if g(lo) < 0:
        raise ValueError(f"elastica_tip: load too large for double precision (sqrt(F/EI) L = {sl:.3g}).")
    log_m1 = brentq(g, lo, hi, xtol=1e-15, rtol=1e-15, maxiter=500)
    m, k, kp, phi0, K = parts(log_m1)
    E_full = float(ellipeinc(math.pi / 2, m)) if m < 1 else 1.0
    F0 = float(ellipkinc(phi0, m))
    E0 = float(ellipeinc(phi0, m))
    qL = sigma * 2.0 * math.atan2(k, kp)
    C = (2.0 * (E_full - E0) - (K - F0)) / math.sqrt(lam)
    S = sigma * math.sqrt(max(0.0, 2.0 * lam * (math.cos(q0) - math.cos(qL)))) / lam
    ca, sa = math.cos(angle), math.sin(angle)
    xL = -(ca * C + sa * S)
    zL = -(sa * C - ca * S)
    thL = math.pi + angle - qL
    # report the tip angle on the branch nearest the clamp angle plus the bend
    thL = clamp_angle + math.remainder(thL - clamp_angle, 2 * math.pi)
    return thL, xL, zL


def prandtl_field(beam) -> float:
    """Prandtl's estimate of the transverse field (T) that buckles a uniformly, axially magnetized strip
    out of its plane (lateral-torsional buckling).

    A field B across the width puts a uniform couple ``A M B`` per length on the straight strip: the
    bending moment of a tip load ``P = A M B``. Prandtl's critical tip load of a deep cantilever,
    ``P_cr = 4.013 sqrt(E I_w G J) / L^2`` (the strip straight until it buckles, at the clamp's
    stiffnesses), gives ``B_cr = P_cr / (A M)``. It is a first estimate: the in-plane deflection before
    buckling and the couple turning with the cross-section move the true value
    (:func:`magsoft_env.theory.rod_solver.critical_field`).
    """
    import numpy as np

    k = np.asarray(beam.stiffnesses(np.array([0.0])), dtype=float)[0]
    P = 4.013 * math.sqrt(k[0] * k[2]) / beam.length**2
    return P / float(beam.moment_per_length(np.array([0.0]))[0])

"""Permanent magnets of finite size in closed form: the axially magnetized cylinder and the uniformly magnetized
cuboid, field and gradient both exact, inside and outside.

Cylinder (radius ``a``, length ``2 b``, magnetization ``M`` along its axis): the field of a solenoid of surface
current ``M`` (Derby and Olbert, *Cylindrical magnets and ideal solenoids*, Am. J. Phys. 78, 229 (2010)), with
``z_+- = z +- b``, ``alpha_+- = a / sqrt(z_+-^2 + (rho + a)^2)``, ``beta_+- = z_+- / sqrt(z_+-^2 + (rho + a)^2)``,
``gamma = (a - rho) / (a + rho)``, ``k_+-^2 = (z_+-^2 + (a - rho)^2) / (z_+-^2 + (a + rho)^2)``, ``B0 = mu0 M / pi``::

    B_rho = B0 (alpha_+ cel(k_+, 1, 1, -1) - alpha_- cel(k_-, 1, 1, -1))
    B_z   = B0 a / (a + rho) (beta_+ cel(k_+, gamma^2, 1, gamma) - beta_- cel(k_-, gamma^2, 1, gamma))

``cel`` is Bulirsch's complete elliptic integral, written here through Carlson's ``R_F``, ``R_J``
(``cel(kc, p, 1, s) = R_F(0, kc^2, 1) + (s - p)/3 R_J(0, kc^2, 1, p)``; ``cel(kc, 1, 1, -1) = K - 2 D = m Q(m)``
with ``m = 1 - kc^2``, as :mod:`magsoft_env.fields.loop`). The gradient: the z-derivative of a uniform
solenoid is the difference of its two end loops, ``dB/dz = M (B_loop(z + b) - B_loop(z - b))`` (current ``M``,
exact), and curl B = div B = 0 give the rest (``dB_z/drho = dB_rho/dz``, ``dB_rho/drho = -dB_z/dz - B_rho/rho``).

Cuboid (half-sides ``(hx, hy, hz)``, uniform magnetization ``M``): the magnetic charges ``sigma = M . n`` on its
faces give ``H``; ``B = mu0 (H + M)`` inside, ``mu0 H`` outside. A face of charge ``sigma`` at height ``z0`` with
``X = x - x'``, ``Y = y - y'``, ``Z = z - z0``, ``R = sqrt(X^2 + Y^2 + Z^2)`` summed over its corners (Furlani,
*Permanent Magnet and Electromechanical Devices*, 2001, sec. 4.3)::

    H_x = -sigma/(4 pi) [[ln(Y + R)]],  H_y = -sigma/(4 pi) [[ln(X + R)]],  H_z = sigma/(4 pi) [[atan(X Y / (Z R))]]

and its gradient, the second derivatives of ``[[X ln(Y + R) + Y ln(X + R) - Z atan(X Y / (Z R))]]``::

    d2/dX2 = X / (R (Y + R)),  d2/dXdY = 1/R,  d2/dXdZ = Z / (R (Y + R)),  d2/dY2 = Y / (R (X + R)),
    d2/dYdZ = Z / (R (X + R)),  d2/dZ2 = X Y (R^2 + Z^2) / (R (X^2 + Z^2) (Y^2 + Z^2))

(``[[f]]`` the sum over the corners with alternating signs; ``ln(Y + R)`` is written ``ln((X^2 + Z^2)/(R - Y))``
for ``Y < 0``, without cancellation). Points on a magnet's surface are refused (the field jumps there).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import elliprf, elliprj

from ..spec import MU0
from ..validate import finite_number, positive
from .base import (
    Source,
    as_points,
    frame_from_axis,
    position3,
    rotation_matrix,
    to_global,
    unit_vector,
    vector3,
)
from .dipole import MAX_MAGNETIZATION
from .loop import cylindrical_to_local, elliptic_kedq, loop_cylindrical

#: Points within this fraction of the magnet's size of its surface are refused: the field jumps there.
SURFACE_TOL = 1e-9
#: Largest side, radius or length of a magnet (m).
MAX_SIZE = 1.0


def _size(name: str, value) -> float:
    x = positive(name, value, unit="m")
    if x > MAX_SIZE:
        raise ValueError(f"{name} must be at most {MAX_SIZE:g} m (lengths are in metres: 10 mm is 0.01), "
                         f"got {value!r}.")
    return x


def _cel_p(kc2: np.ndarray, p: np.ndarray, s: np.ndarray) -> np.ndarray:
    """``cel(kc, p, 1, s)`` for ``p >= 0`` (``p = 0`` only with ``s = 0``: then it is K)."""
    zero = p == 0.0
    pj = np.where(zero, 1.0, p)
    rj = elliprj(0.0, kc2, 1.0, pj)
    return elliprf(0.0, kc2, 1.0) + np.where(zero, 0.0, (s - p) / 3.0 * rj)


@dataclass(frozen=True, init=False)
class CylinderMagnet(Source):
    """An axially magnetized cylinder (exact field and gradient, inside and outside).

    Parameters
    ----------
    position : array_like, shape (3,)
        Its centre (m).
    axis : array_like, shape (3,)
        Its axis (normalized here); the magnetization points along it.
    radius, length : float
        Its radius and full length (m), each in (0, :data:`MAX_SIZE`].
    magnetization : float
        M along ``axis`` (A/m; ``M = B_r / mu0``), within +-:data:`~magsoft_env.fields.dipole.MAX_MAGNETIZATION`.

    Notes
    -----
    Closed forms in the module docstring. Points on the side surface (where ``B_z`` jumps by ``mu0 M``) and on
    the rims are refused; the end faces are not surfaces of discontinuity of B.
    """

    position: tuple
    axis: tuple
    radius: float
    length: float
    magnetization: float

    def __init__(self, *, position, axis=(0.0, 0.0, 1.0), radius, length, magnetization):
        object.__setattr__(self, "position", tuple(position3("CylinderMagnet position", position).tolist()))
        object.__setattr__(self, "axis", tuple(unit_vector("CylinderMagnet axis", axis).tolist()))
        object.__setattr__(self, "radius", _size("CylinderMagnet radius", radius))
        object.__setattr__(self, "length", _size("CylinderMagnet length", length))
        M = finite_number("CylinderMagnet magnetization", magnetization, unit="A/m")
        if abs(M) > MAX_MAGNETIZATION:
            raise ValueError(f"CylinderMagnet magnetization must lie within +-{MAX_MAGNETIZATION:g} A/m "
                             f"(M = B_r / mu0: 1.2 T is 9.5e5 A/m), got {magnetization!r}.")
        object.__setattr__(self, "magnetization", M)
        object.__setattr__(self, "_R", frame_from_axis(np.array(self.axis)))

    @property
    def moment(self) -> np.ndarray:
        """Its moment ``M pi a^2 L`` along the axis (A m^2), shape (3,)."""
        return self.magnetization * math.pi * self.radius**2 * self.length * np.array(self.axis)

    def field_and_gradient(self, points):
        p = as_points(points)
        R = self._R
        x, y, z = ((p - np.array(self.position)) @ R).T
        rho = np.hypot(x, y)
        a, b, M = self.radius, 0.5 * self.length, self.magnetization
        tol = SURFACE_TOL * max(a, b)
        side = (np.abs(rho - a) <= tol) & (np.abs(z) <= b + tol)
        if side.any():
            i = int(np.argmax(side))
            raise ValueError(f"points[{i}] = {p[i].tolist()!r} m is on the cylinder's side surface or rim, where "
                             "its field jumps.")
        B0 = MU0 * M / math.pi
        Brho = np.zeros_like(rho)
        Brho_rho = np.zeros_like(rho)
        Bz = np.zeros_like(rho)
        gamma = (a - rho) / (a + rho)
        for sign, zs in ((1.0, z + b), (-1.0, z - b)):
            v = zs * zs + (a + rho) ** 2
            sq = np.sqrt(v)
            alpha = a / sq
            beta = zs / sq
            m = 4.0 * a * rho / v
            kc2 = ((a - rho) ** 2 + zs * zs) / v
            K, E, D, Q = elliptic_kedq(m, kc2)
            Brho += sign * alpha * m * Q
            Brho_rho += sign * alpha * (4.0 * a / v) * Q
            Bz += sign * beta * _cel_p(kc2, gamma * gamma, gamma)
        c = {"Brho": B0 * Brho, "Brho_rho": B0 * Brho_rho, "Bz": B0 * a / (a + rho) * Bz}
        # dB/dz = M (B_loop at z + b - B_loop at z - b), loops of current M: C = mu0 M / pi = B0
        lo = loop_cylindrical(rho, z + b, a, gradient=False)
        hi = loop_cylindrical(rho, z - b, a, gradient=False)
        c["dBz_dz"] = B0 * (lo["Bz"] - hi["Bz"])
        c["dBz_drho"] = B0 * (lo["Brho"] - hi["Brho"])
        B, G = cylindrical_to_local(x, y, rho, c, 1.0)
        return to_global(B, G, R)


# ------------------------------------------------------------------------------------------------ cuboid


def _log_pair(U_hi, U_lo, R_hi, R_lo, s2):
    """``ln(U_hi + R_hi) - ln(U_lo + R_lo)`` without cancellation (``s2`` the sum of the other two squares)."""
    def lg(U, R):
        return np.where(U >= 0.0, np.log(np.where(U >= 0.0, U + R, 1.0)),
                        -np.log(np.where(U < 0.0, R - U, 1.0)))
    # ln(U + R) = ln(s2) - ln(R - U) for U < 0: ln(s2) cancels unless exactly one corner has U < 0
    one = (U_lo < 0.0) & (U_hi >= 0.0)
    return lg(U_hi, R_hi) - lg(U_lo, R_lo) - np.where(one, np.log(np.where(one, s2, 1.0)), 0.0)


def _ratio(U, R, s2, num):
    """``num / (R (U + R))`` without cancellation: ``num (R - U) / (R s2)`` for ``U < 0`` (0 where s2 = 0, the
    limit of the pair of corners on an edge's line)."""
    neg = U < 0.0
    den = np.where(neg, R * np.where(s2 > 0.0, s2, 1.0) / (R - U), R * (U + R))
    return np.where(neg & (s2 == 0.0), 0.0, num / den)


def _cuboid_z(x, y, z, hx, hy, hz, Mz):
    """H (3, n) and its gradient (3, 3, n) of the charges +-Mz on the faces z = +-hz of the cuboid."""
    n = x.shape[0]
    H = np.zeros((3, n))
    dH = np.zeros((3, 3, n))
    for sigma, z0 in ((Mz, hz), (-Mz, -hz)):
        Z = z - z0
        Z2 = Z * Z
        F = np.zeros((6, n))  # second derivatives summed over the corners: xx, yy, zz, xy, xz, yz
        hxv = atn = 0.0
        for sx, X in ((1.0, x + hx), (-1.0, x - hx)):  # X = x - x', x' = -hx (upper limit) and +hx
            Yh, Yl = y + hy, y - hy
            X2 = X * X
            Rh = np.sqrt(X2 + Yh * Yh + Z2)
            Rl = np.sqrt(X2 + Yl * Yl + Z2)
            sxz = X2 + Z2
            hxv = hxv + sx * _log_pair(Yh, Yl, Rh, Rl, sxz)  # [[ln(Y + R)]]
            for sy, Y, Rc in ((1.0, Yh, Rh), (-1.0, Yl, Rl)):
                s = sx * sy
                Y2 = Y * Y
                syz = Y2 + Z2
                F[0] += s * _ratio(Y, Rc, sxz, X)
                F[1] += s * _ratio(X, Rc, syz, Y)
                F[3] += s / Rc
                F[4] += s * _ratio(Y, Rc, sxz, Z)
                F[5] += s * _ratio(X, Rc, syz, Z)
                den = Rc * sxz * syz
                ok = den > 0.0
                F[2] += s * np.where(ok, X * Y * (Rc * Rc + Z2) / np.where(ok, den, 1.0), 0.0)
                zr = Z * Rc  # Z = 0: the point is in the face's plane, off the face; the corners' terms cancel
                atn = atn + s * np.where(zr != 0.0, np.arctan(X * Y / np.where(zr != 0.0, zr, 1.0)), 0.0)
        # [[ln(X + R)]]: the same sum with the roles of X and Y swapped
        hyv = 0.0
        for sy, Y in ((1.0, y + hy), (-1.0, y - hy)):
            Xh, Xl = x + hx, x - hx
            Y2 = Y * Y
            Rh = np.sqrt(Xh * Xh + Y2 + Z2)
            Rl = np.sqrt(Xl * Xl + Y2 + Z2)
            hyv = hyv + sy * _log_pair(Xh, Xl, Rh, Rl, Y2 + Z2)
        k = sigma / (4.0 * math.pi)
        H[0] -= k * hxv
        H[1] -= k * hyv
        H[2] += k * atn
        # H = -grad phi, phi = k [[F]]: dH_a/dx_b = -k [[d2F/dadb]]
        dH[0, 0] -= k * F[0]
        dH[1, 1] -= k * F[1]
        dH[2, 2] -= k * F[2]
        dH[0, 1] -= k * F[3]
        dH[0, 2] -= k * F[4]
        dH[1, 2] -= k * F[5]
    dH[1, 0] = dH[0, 1]
    dH[2, 0] = dH[0, 2]
    dH[2, 1] = dH[1, 2]
    return H, dH


@dataclass(frozen=True, eq=False, init=False)
class CuboidMagnet(Source):
    """A uniformly magnetized cuboid (exact field and gradient, inside and outside).

    Parameters
    ----------
    position : array_like, shape (3,)
        Its centre (m).
    dimensions : array_like, shape (3,)
        Its full side lengths along its own x, y, z (m), each in (0, :data:`MAX_SIZE`].
    magnetization : array_like, shape (3,)
        M in its own frame (A/m), norm within :data:`~magsoft_env.fields.dipole.MAX_MAGNETIZATION`.
    rotation : array_like, shape (3, 3), or scipy Rotation, optional
        Its orientation: its own axes as the columns (default the identity).

    Notes
    -----
    Closed forms in the module docstring. Points on its surface are refused.
    """

    position: np.ndarray
    dimensions: np.ndarray
    magnetization: np.ndarray
    rotation: np.ndarray

    def __init__(self, *, position, dimensions, magnetization, rotation=None):
        object.__setattr__(self, "position", position3("CuboidMagnet position", position))
        dims = vector3("CuboidMagnet dimensions", dimensions, unit="m")
        for i, d in enumerate(dims):
            _size(f"CuboidMagnet dimensions[{i}]", d)
        object.__setattr__(self, "dimensions", dims)
        object.__setattr__(self, "magnetization", vector3("CuboidMagnet magnetization", magnetization, unit="A/m",
                                                          limit=MAX_MAGNETIZATION))
        R = np.eye(3) if rotation is None else rotation_matrix("CuboidMagnet rotation", rotation)
        object.__setattr__(self, "rotation", R)

    @property
    def moment(self) -> np.ndarray:
        """Its moment ``M V`` in the global frame (A m^2), shape (3,)."""
        return self.rotation @ self.magnetization * float(np.prod(self.dimensions))

    def field_and_gradient(self, points):
        p = as_points(points)
        R = self.rotation
        local = (p - self.position) @ R
        h = 0.5 * self.dimensions
        tol = SURFACE_TOL * float(h.max())
        dist = np.abs(local) - h  # per axis: > 0 outside that slab
        inside = (dist < -tol).all(axis=1)
        outside_any = (dist > tol).any(axis=1)
        surface = ~inside & ~outside_any
        if surface.any():
            i = int(np.argmax(surface))
            raise ValueError(f"points[{i}] = {p[i].tolist()!r} m is on the cuboid's surface, where its field jumps.")
        H = np.zeros((3, p.shape[0]))
        dH = np.zeros((3, 3, p.shape[0]))
        # each magnetization component: its two charged faces, in axes where it is "z" (cyclic permutations)
        for axis in range(3):
            Mc = float(self.magnetization[axis])
            if Mc == 0.0:
                continue
            perm = [(axis + 1) % 3, (axis + 2) % 3, axis]  # local axes playing x, y, z
            h_p = h[perm]
            Hp, dHp = _cuboid_z(local[:, perm[0]], local[:, perm[1]], local[:, perm[2]], *h_p, Mc)
            H[perm] += Hp
            dH[np.ix_(perm, perm)] += dHp
        B = MU0 * H.T
        B[inside] += MU0 * self.magnetization
        G = MU0 * dH.transpose(2, 0, 1)
        return to_global(B, G, R)


__all__ = ["MAX_SIZE", "SURFACE_TOL", "CuboidMagnet", "CylinderMagnet"]

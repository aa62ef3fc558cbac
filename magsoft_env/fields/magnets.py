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


def _lg(U, R):
    """``ln(U + R)`` for ``U >= 0``, ``-ln(R - U)`` for ``U < 0`` (where ``ln(U + R) = ln(s2) - ln(R - U)``: the
    ``ln(s2)`` is added back by the caller where it does not cancel)."""
    pos = U >= 0.0
    return np.where(pos, np.log(np.where(pos, U + R, 1.0)), -np.log(np.where(pos, 1.0, R - U)))


def _ratio(U, R, s2, num):
    """``num / (R (U + R))`` without cancellation: ``num (R - U) / (R s2)`` for ``U < 0`` (0 where s2 = 0, the
    limit of the pair of corners on an edge's line)."""
    neg = U < 0.0
    den = np.where(neg, R * np.where(s2 > 0.0, s2, 1.0) / np.where(neg, R - U, 1.0), R * (U + R))
    return np.where(neg & (s2 == 0.0), 0.0, num / den)


_CORNER = np.array([1.0, -1.0])  # the upper (x' = -h: X = x + h) and lower corner of each pair
_FACE_SIGN = _CORNER.reshape(1, 1, 2, 1)  # sigma = +M on the face z0 = +h, -M on z0 = -h
_SIGNS = (_CORNER.reshape(2, 1, 1, 1) * _CORNER.reshape(1, 2, 1, 1) * _FACE_SIGN)  # (2, 2, 2, 1)


def _cuboid_H(local: np.ndarray, h: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """H (n, 3) and dH (n, 3, 3) of a cuboid's face charges at ``local`` (n, 3) points in its frame (half-sides
    ``h``, magnetization ``M``): each component of M charges the two faces normal to it; all components, faces
    and corners at once, in axes where that component is "z" (cyclic permutations)."""
    n = local.shape[0]
    perms = np.array([[(c + 1) % 3, (c + 2) % 3, c] for c in range(3)])
    q = local[:, perms].transpose(1, 2, 0)  # (3 components, 3 axes, n)
    hh = h[perms]  # (3, 3)
    # corners: (component, X corner, Y corner, face, point)
    X = q[:, 0, None, None, None, :] + _CORNER.reshape(1, 2, 1, 1, 1) * hh[:, 0, None, None, None, None]
    Y = q[:, 1, None, None, None, :] + _CORNER.reshape(1, 1, 2, 1, 1) * hh[:, 1, None, None, None, None]
    Z = q[:, 2, None, None, None, :] - _FACE_SIGN[None, :, :, :, :].reshape(1, 1, 1, 2, 1) * hh[:, 2, None, None,
                                                                                              None, None]
    X, Y, Z = np.broadcast_arrays(X, Y, Z)
    X2, Y2, Z2 = X * X, Y * Y, Z * Z
    R = np.sqrt(X2 + Y2 + Z2)
    sxz, syz = X2 + Z2, Y2 + Z2
    k = (M / (4.0 * np.pi))[:, None, None, None, None] * _SIGNS  # (3, 2, 2, 2, 1): sigma / (4 pi) times the sign
    # [[ln(Y + R)]]: ln(sxz) returns where the two Y corners straddle 0 (then sxz > 0 off the surface)
    one_y = (Y[:, :, 1:] < 0.0) & (Y[:, :, :1] >= 0.0)
    lnY = (k * _lg(Y, R)).sum(axis=(1, 2, 3)) - (
        k[:, :, :1] * np.where(one_y, np.log(np.where(one_y, sxz[:, :, :1], 1.0)), 0.0)).sum(axis=(1, 2, 3))
    one_x = (X[:, 1:] < 0.0) & (X[:, :1] >= 0.0)
    lnX = (k * _lg(X, R)).sum(axis=(1, 2, 3)) - (
        k[:, :1] * np.where(one_x, np.log(np.where(one_x, syz[:, :1], 1.0)), 0.0)).sum(axis=(1, 2, 3))
    zr = Z * R  # 0: the point is in a face's plane, off the face; the corners' terms cancel
    atn = (k * np.where(zr != 0.0, np.arctan(X * Y / np.where(zr != 0.0, zr, 1.0)), 0.0)).sum(axis=(1, 2, 3))
    den = R * sxz * syz
    ok = den > 0.0
    F = np.stack([_ratio(Y, R, sxz, X), _ratio(X, R, syz, Y),
                  np.where(ok, X * Y * (R * R + Z2) / np.where(ok, den, 1.0), 0.0),
                  1.0 / R, _ratio(Y, R, sxz, Z), _ratio(X, R, syz, Z)], axis=1)  # xx, yy, zz, xy, xz, yz
    F = (k[:, None] * F).sum(axis=(2, 3, 4))  # (3, 6, n)
    Hp = np.stack([-lnY, -lnX, atn], axis=1)  # (3 components, 3 axes, n): H = -grad phi, phi = k [[F]]
    H = np.zeros((3, n))
    dH = np.zeros((3, 3, n))
    sym = np.array([[0, 3, 4], [3, 1, 5], [4, 5, 2]])  # dH_ab = -k [[d2F/dadb]]
    for c in range(3):
        pc = perms[c]
        H[pc] += Hp[c]
        dH[np.ix_(pc, pc)] -= F[c][sym]
    return H.T, dH.transpose(2, 0, 1)


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
        H, dH = _cuboid_H(local, h, self.magnetization)
        B = MU0 * H
        B[inside] += MU0 * self.magnetization
        G = MU0 * dH
        return to_global(B, G, R)


__all__ = ["MAX_SIZE", "SURFACE_TOL", "CuboidMagnet", "CylinderMagnet"]

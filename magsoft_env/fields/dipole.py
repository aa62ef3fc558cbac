"""Point dipoles, sets of them (the kernel every dipole-based source uses) and uniformly magnetized spheres.

Field and gradient of a dipole of moment ``m`` (A m^2) at ``r = x - p`` (``r_hat = r / |r|``)::

    B = mu0/(4 pi) (3 r_hat (m . r_hat) - m) / r^3
    G = mu0/(4 pi) 3/r^4 (m r_hat^T + r_hat m^T + (m . r_hat)(I - 5 r_hat r_hat^T))

(Jackson, *Classical Electrodynamics*, 3rd ed., eq. 5.56; the gradient is its derivative, symmetric and
traceless.) A sphere magnetized uniformly (``M``, A/m) is outside exactly the dipole ``m = (4/3) pi R^3 M`` at its
centre; inside, its field is uniform, ``B = (2/3) mu0 M`` (Jackson, eq. 5.104).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..spec.material import MAX_PARTICLE_MAGNETIZATION, MU0
from ..validate import finite_array, positive
from .base import MU0_4PI, Source, as_points, position3, vector3

#: Points closer than this to a point dipole are refused (m): the field diverges there.
MIN_DIPOLE_DISTANCE = 1e-9
#: Largest moment accepted for a point dipole (A m^2): a 10 cm NdFeB sphere has about 560 A m^2.
MAX_MOMENT = 1e4
#: Largest magnetization accepted for a magnet (A/m), as :data:`magsoft_env.spec.material.MAX_PARTICLE_MAGNETIZATION`:
#: NdFeB's remanence 1.4 T is 1.1e6 A/m (``M = B_r / mu0``).
MAX_MAGNETIZATION = MAX_PARTICLE_MAGNETIZATION


def dipole_sum(points: np.ndarray, positions_T: np.ndarray, moments: np.ndarray, moments_T: np.ndarray,
               *, scale: float = MU0_4PI, min_distance: float = MIN_DIPOLE_DISTANCE,
               what: str = "a dipole") -> tuple[np.ndarray, np.ndarray]:
    """Field and gradient of ``k`` point dipoles summed at ``n`` points (no input checks: callers check).

    Parameters
    ----------
    points : ndarray, shape (n, 3)
        Where (m).
    positions_T : ndarray, shape (3, k)
        The dipoles' positions (m), transposed and C-contiguous.
    moments, moments_T : ndarray, shapes (k, 3) and (3, k)
        Their moments (A m^2; or, with ``scale=1``, moments with mu0/(4 pi) folded in, T m^3), and the same
        transposed, C-contiguous.
    scale : float
        The constant in front (mu0/(4 pi) for moments in A m^2).
    min_distance : float
        A point closer than this (m) to a dipole is refused with a ValueError naming it and ``what``.

    Returns
    -------
    B : ndarray, shape (n, 3)
        Field (T).
    G : ndarray, shape (n, 3, 3)
        Gradient (T/m), ``G[i, a, b] = dB_a / dx_b``.
    """
    # layout (3, n, k): every elementwise step runs over the contiguous k axis, few numpy calls in all
    r = np.ascontiguousarray(points.T)[:, :, None] - positions_T[:, None, :]
    r2 = np.einsum("ank,ank->nk", r, r)
    if r2.min() < min_distance * min_distance:
        i, k = np.unravel_index(int(np.argmin(r2)), r2.shape)
        raise ValueError(f"points[{i}] = {points[i].tolist()!r} m is within {min_distance:g} m of {what} at "
                         f"{positions_T[:, k].tolist()!r} m, where the field diverges.")
    inv_r2 = np.reciprocal(r2, out=r2)
    inv_r3 = np.sqrt(inv_r2)
    inv_r3 *= inv_r2
    c = inv_r3 * inv_r2
    c *= 3.0  # 3 / r^5
    a = c * np.einsum("ank,ak->nk", r, moments_T)  # 3 (m . r) / r^5
    r_nk3 = r.transpose(1, 2, 0)  # (n, k, 3) view: batched products over k below
    B = np.matmul(a[:, None, :], r_nk3)[:, 0, :]
    B -= inv_r3 @ moments
    M1 = (c * r) @ moments  # [b, i, a] = sum_k 3/r^5 r_b m_a
    e = a * inv_r2
    e *= 5.0
    G = M1.transpose(1, 2, 0) + M1.transpose(1, 0, 2)
    G -= np.matmul((e * r).transpose(1, 0, 2), r_nk3)  # sum_k 5 a / r^2 r_a r_b
    diagonal = G.reshape(-1, 9)[:, ::4]  # a view of G[:, i, i]
    diagonal += a.sum(axis=1)[:, None]
    if scale != 1.0:
        B *= scale
        G *= scale
    return B, G


@dataclass(frozen=True, eq=False, init=False)
class DipoleSet(Source):
    """Point dipoles summed: the sources of an MPEM coil system at given currents, or any set of magnets far away.

    Parameters
    ----------
    positions : array_like, shape (k, 3)
        Positions (m).
    moments : array_like, shape (k, 3)
        Moments (A m^2).
    scale : float
        Factor of the dipole formula: mu0/(4 pi) (default) for moments in A m^2; 1 for moments with mu0/(4 pi)
        folded in (T m^3, the MPEM ``B_Coeff`` convention).
    """

    positions: np.ndarray
    moments: np.ndarray
    scale: float

    def __init__(self, positions, moments, *, scale: float = MU0_4PI):
        pos = finite_array("DipoleSet positions", positions)
        mom = finite_array("DipoleSet moments", moments)
        if pos.ndim != 2 or pos.shape[1] != 3 or pos.shape[0] == 0:
            raise ValueError(f"DipoleSet positions must have shape (k, 3) with k >= 1 (m), got {pos.shape}.")
        if mom.shape != pos.shape:
            raise ValueError(f"DipoleSet moments must have the shape of positions {pos.shape}, got {mom.shape}.")
        object.__setattr__(self, "positions", pos)
        object.__setattr__(self, "moments", mom)
        object.__setattr__(self, "scale", positive("DipoleSet scale", scale))
        object.__setattr__(self, "_pos_T", np.ascontiguousarray(pos.T))
        object.__setattr__(self, "_mom_T", np.ascontiguousarray(mom.T))

    def field_and_gradient(self, points):
        return dipole_sum(as_points(points), self._pos_T, self.moments, self._mom_T, scale=self.scale)


@dataclass(frozen=True, init=False)
class PointDipole(Source):
    """A point dipole (exact).

    Parameters
    ----------
    position : array_like, shape (3,)
        Where it is (m).
    moment : array_like, shape (3,)
        Its moment (A m^2), norm at most :data:`MAX_MOMENT`.

    Notes
    -----
    ::

        B = mu0/(4 pi) (3 r_hat (m . r_hat) - m) / r^3
        G = mu0/(4 pi) 3/r^4 (m r_hat^T + r_hat m^T + (m . r_hat)(I - 5 r_hat r_hat^T))

    Points closer than :data:`MIN_DIPOLE_DISTANCE` to it are refused.

    Examples
    --------
    >>> import numpy as np
    >>> d = PointDipole(position=(0, 0, 0), moment=(0, 0, 1.0))
    >>> B, G = d.field_and_gradient(np.array([[0.0, 0.0, 0.1]]))
    >>> round(float(B[0, 2]), 12)   # mu0/(4 pi) 2 m / z^3 = 2e-4 T
    0.0002
    """

    position: tuple
    moment: tuple

    def __init__(self, *, position, moment):
        object.__setattr__(self, "position", tuple(position3("PointDipole position", position).tolist()))
        m = vector3("PointDipole moment", moment, unit="A m^2", limit=MAX_MOMENT)
        object.__setattr__(self, "moment", tuple(m.tolist()))

    def field_and_gradient(self, points):
        p = as_points(points)
        pos_T = np.array(self.position).reshape(3, 1)
        m = np.array([self.moment])
        return dipole_sum(p, pos_T, m, m.reshape(3, 1), what="the dipole")


def _magnetization(name: str, value) -> np.ndarray:
    return vector3(name, value, unit="A/m", limit=MAX_MAGNETIZATION)


@dataclass(frozen=True, init=False)
class SphereMagnet(Source):
    """A uniformly magnetized sphere (exact): a dipole outside, a uniform field inside.

    Parameters
    ----------
    position : array_like, shape (3,)
        Its centre (m).
    radius : float
        Its radius (m), > 0.
    magnetization : array_like, shape (3,), optional
        Its magnetization M (A/m; ``M = B_r / mu0`` for a remanence B_r in T), norm at most
        :data:`MAX_MAGNETIZATION`. Give this or ``moment``.
    moment : array_like, shape (3,), optional
        Its moment ``m = (4/3) pi R^3 M`` (A m^2).

    Notes
    -----
    Outside (``|x - p| >= R``) the field is the point dipole's (exact); inside it is ``B = (2/3) mu0 M``, ``G = 0``.
    On the surface the outside value is returned (the tangential field jumps there).
    """

    position: tuple
    radius: float
    magnetization: tuple

    def __init__(self, *, position, radius, magnetization=None, moment=None):
        object.__setattr__(self, "position", tuple(position3("SphereMagnet position", position).tolist()))
        R = positive("SphereMagnet radius", radius, unit="m")
        if R > 1.0:
            raise ValueError(f"SphereMagnet radius must be at most 1 m (lengths are in metres), got {radius!r}.")
        object.__setattr__(self, "radius", R)
        if (magnetization is None) == (moment is None):
            raise ValueError("SphereMagnet takes exactly one of magnetization (A/m) and moment (A m^2), got "
                             f"{'both' if magnetization is not None else 'neither'}.")
        volume = 4.0 / 3.0 * math.pi * R**3
        if moment is not None:
            M = vector3("SphereMagnet moment", moment, unit="A m^2", limit=MAX_MOMENT) / volume
            if np.linalg.norm(M) > MAX_MAGNETIZATION:
                raise ValueError(f"SphereMagnet moment {np.asarray(moment).tolist()!r} A m^2 in a sphere of radius "
                                 f"{R:g} m means a magnetization of {np.linalg.norm(M):.3g} A/m, above "
                                 f"{MAX_MAGNETIZATION:g} A/m (no permanent magnet is that strong).")
        else:
            M = _magnetization("SphereMagnet magnetization", magnetization)
        object.__setattr__(self, "magnetization", tuple(M.tolist()))

    @property
    def moment(self) -> np.ndarray:
        """Its moment ``(4/3) pi R^3 M`` (A m^2), shape (3,)."""
        return 4.0 / 3.0 * math.pi * self.radius**3 * np.array(self.magnetization)

    def field_and_gradient(self, points):
        p = as_points(points)
        c = np.array(self.position)
        m = self.moment.reshape(1, 3)
        d2 = ((p - c) ** 2).sum(axis=1)
        inside = d2 < self.radius**2
        if not inside.any():
            return dipole_sum(p, c.reshape(3, 1), m, m.reshape(3, 1), what="the sphere's centre")
        B = np.empty((p.shape[0], 3))
        G = np.zeros((p.shape[0], 3, 3))
        B[inside] = 2.0 / 3.0 * MU0 * np.array(self.magnetization)
        out = ~inside
        if out.any():
            B[out], G[out] = dipole_sum(p[out], c.reshape(3, 1), m, m.reshape(3, 1), what="the sphere's centre")
        return B, G


__all__ = ["MAX_MAGNETIZATION", "MAX_MOMENT", "MIN_DIPOLE_DISTANCE", "DipoleSet", "PointDipole", "SphereMagnet",
           "dipole_sum"]

"""Circular current loops (exact field and gradient, complete elliptic integrals) and the Helmholtz and Maxwell pairs.

In the loop's own frame (centre at the origin, normal +z, radius ``a``, current ``I`` counter-clockwise about
+z, so that ``B_z > 0`` on the axis for ``I > 0``), with ``rho`` the distance from the axis,
``alpha^2 = (a - rho)^2 + z^2``, ``beta^2 = (a + rho)^2 + z^2``, ``m = k^2 = 4 a rho / beta^2`` and
``C = mu0 I / pi`` (Simpson, Lane, Immer, Youngquist, *Simple analytic expressions for the magnetic field of a
circular current loop*, NASA Technical Report 20010038494, 2001)::

    B_z   = C / (2 alpha^2 beta) ((a^2 - rho^2 - z^2) E(m) + alpha^2 K(m))
    B_rho = C z / (2 alpha^2 beta rho) ((a^2 + rho^2 + z^2) E(m) - alpha^2 K(m))
          = C z a / (alpha^2 beta) m (Q(m) + D(m))

with ``D = (K - E) / m`` and ``Q = (K - 2 D) / m``, both smooth at ``m = 0`` (power series there), so that
``B_rho / rho`` is finite on the axis. The gradient differentiates ``B_z`` in ``rho`` and ``z`` by the chain rule
(``dK/dm = (K - D) / (2 (1 - m))``, ``dE/dm = -D / 2``); the rest follows from curl B = 0 and div B = 0::

    dB_rho/dz = dB_z/drho,    dB_rho/drho = -dB_z/dz - B_rho/rho

and the Cartesian gradient in the loop's frame is ``dB_rho/drho e e^T + (B_rho/rho)(I - e e^T)`` in the plane
(``e`` the radial unit vector), ``dB_rho/dz e`` and ``dB_z/drho e^T`` off it, rotated into place
(``G = R G_l R^T``). On the axis it reduces to ``B = mu0 I a^2 / (2 (a^2 + z^2)^(3/2))``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ellipe, ellipkm1

from ..spec import MU0
from ..validate import finite_array, finite_number, positive
from .base import Source, as_points, frame_from_axis, position3, to_global, unit_vector

#: Points closer to the wire than this fraction of the radius are refused: the field diverges there.
WIRE_TOL = 1e-9
#: Largest loop current accepted (A; N I for a coil of N turns): 10 MA-turns.
MAX_CURRENT = 1e7
#: Largest loop radius accepted (m).
MAX_RADIUS = 10.0

# power series in m of D = (K - E)/m and Q = (K - 2 D)/m, used for m < _SERIES_M: there the closed forms lose
# digits to cancellation (Q's about 1e-12 at m = 0.05, 2e-14 at 0.3), the series' truncation is below 1e-18 (0.3^36)
_SERIES_M = 0.3
_N_TERMS = 36


def _series_coefficients() -> tuple[np.ndarray, np.ndarray]:
    c2 = [1.0]  # c_n^2, c_n = binom(2n, n) / 4^n: K = pi/2 sum c_n^2 m^n
    for n in range(1, _N_TERMS + 3):
        cn = math.sqrt(c2[-1]) * (2 * n - 1) / (2 * n)
        c2.append(cn * cn)
    d = [c2[n + 1] * (2 * (n + 1)) / (2 * n + 1) for n in range(_N_TERMS + 1)]  # D = pi/2 sum d_n m^n
    q = [c2[j] - 2.0 * d[j] for j in range(1, _N_TERMS + 1)]  # Q = pi/2 sum q_j m^(j-1)
    return np.column_stack([d[:_N_TERMS], q]) * (math.pi / 2)  # (terms, 2): coefficients of m^0, m^1, ...


_SERIES = _series_coefficients()


def elliptic_kedq(m: np.ndarray, m1: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``K(m)``, ``E(m)``, ``D = (K - E)/m`` and ``Q = (K - 2 D)/m`` for ``0 <= m < 1``; ``m1 = 1 - m`` given
    separately (computed without cancellation near the wire, where ``m -> 1``)."""
    K = ellipkm1(m1)
    E = ellipe(m)
    small = m < _SERIES_M
    safe = np.where(small, 1.0, m)
    D = (K - E) / safe
    Q = (K - 2.0 * D) / safe
    if small.any():  # the series on those points only, as one product with their powers of m
        ms = m[small]
        powers = np.ones((ms.size, _N_TERMS))
        powers[:, 1:] = np.cumprod(np.repeat(ms[:, None], _N_TERMS - 1, axis=1), axis=1)
        DQ = powers @ _SERIES
        D[small] = DQ[:, 0]
        Q[small] = DQ[:, 1]
    return K, E, D, Q


def loop_cylindrical(rho: np.ndarray, z: np.ndarray, a: float, *, gradient: bool = True) -> dict:
    """A loop of radius ``a`` (m) and current ``pi / mu0`` A (``C = 1``) in its own frame, at ``(rho, z)`` (m):
    ``Brho``, ``Bz``, and with ``gradient`` ``Brho_rho`` (= B_rho / rho), ``dBz_dz``, ``dBz_drho`` (T, T/m for that
    current; multiply by ``mu0 I / pi``). No input checks; points on the wire divide by zero."""
    rho2 = rho * rho
    z2 = z * z
    u = (a - rho) ** 2 + z2  # alpha^2
    v = (a + rho) ** 2 + z2  # beta^2
    m = 4.0 * a * rho / v
    m1 = u / v
    K, E, D, Q = elliptic_kedq(m, m1)
    w = np.sqrt(v)
    N = a * a - rho2 - z2
    Bz = 0.5 * (N * E / (u * w) + K / w)
    pre = z * a / (u * w)
    Brho_rho = pre * (4.0 * a / v) * (Q + D)
    out = {"Brho": Brho_rho * rho, "Bz": Bz}
    if not gradient:
        return out
    dK = (K - D) * v / (2.0 * u)  # dK/dm = (K - D) / (2 (1 - m)), 1 - m = u / v
    dE = -0.5 * D
    # chain rule on f = N E / (u w) + K / w (B_z = f / 2) for q in (rho, z)
    uw = u * w

    def df(N_q, u_q, v_q, m_q):
        w_q = v_q / (2.0 * w)
        return (N_q * E / uw + N * dE * m_q / uw - N * E * (u_q / u + w_q / w) / uw
                + dK * m_q / w - K * w_q / v)

    m_rho = (4.0 * a / v) * (1.0 - 2.0 * rho * (a + rho) / v)
    m_z = -8.0 * a * rho * z / (v * v)
    dBz_drho = 0.5 * df(-2.0 * rho, -2.0 * (a - rho), 2.0 * (a + rho), m_rho)
    dBz_dz = 0.5 * df(-2.0 * z, 2.0 * z, 2.0 * z, m_z)
    out.update(Brho_rho=Brho_rho, dBz_dz=dBz_dz, dBz_drho=dBz_drho)
    return out


def cylindrical_to_local(x: np.ndarray, y: np.ndarray, rho: np.ndarray, c: dict, scale: float,
                         gradient: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """An axisymmetric field ``c`` (keys of :func:`loop_cylindrical`) times ``scale`` as Cartesian ``B`` (n, 3) and
    ``G`` (n, 3, 3) in the frame whose z is the symmetry axis (``x, y`` the points' coordinates there)."""
    n = x.shape[0]
    on_axis = rho == 0.0
    safe = np.where(on_axis, 1.0, rho)
    ex = np.where(on_axis, 1.0, x / safe)  # any radial direction on the axis: the terms it multiplies vanish
    ey = np.where(on_axis, 0.0, y / safe)
    B = np.empty((n, 3))
    B[:, 0] = scale * c["Brho"] * ex
    B[:, 1] = scale * c["Brho"] * ey
    B[:, 2] = scale * c["Bz"]
    if not gradient:
        return B, None
    dr = -c["dBz_dz"] - c["Brho_rho"]  # dB_rho/drho, from div B = 0
    hoop = c["Brho_rho"]
    G = np.empty((n, 3, 3))
    G[:, 0, 0] = dr * ex * ex + hoop * (1.0 - ex * ex)
    G[:, 1, 1] = dr * ey * ey + hoop * (1.0 - ey * ey)
    G[:, 0, 1] = G[:, 1, 0] = (dr - hoop) * ex * ey
    G[:, 0, 2] = G[:, 2, 0] = c["dBz_drho"] * ex  # dB_rho/dz = dB_z/drho, from curl B = 0
    G[:, 1, 2] = G[:, 2, 1] = c["dBz_drho"] * ey
    G[:, 2, 2] = c["dBz_dz"]
    G *= scale
    return B, G


def _radius(name: str, value) -> float:
    a = positive(name, value, unit="m")
    if a > MAX_RADIUS:
        raise ValueError(f"{name} must be at most {MAX_RADIUS:g} m (lengths are in metres: 50 mm is 0.05), "
                         f"got {value!r}.")
    return a


def _current(name: str, value) -> float:
    current = finite_number(name, value, unit="A")
    if abs(current) > MAX_CURRENT:
        raise ValueError(f"{name} must lie within +-{MAX_CURRENT:g} A, got {value!r}.")
    return current


def _coaxial(points, center, R, offsets, radii, currents, what):
    """Field and gradient of loops on one axis (its frame ``R``, local z along it) at ``points`` (n, 3): every
    (loop, point) pair in one pass, the axisymmetric components summed before the frame change."""
    x, y, z = ((points - center) @ R).T
    rho = np.hypot(x, y)
    k = len(offsets)
    zk = z[None, :] - offsets[:, None]  # (k, n)
    a = np.broadcast_to(radii[:, None], zk.shape)
    rk = np.broadcast_to(rho[None, :], zk.shape)
    wire = (a - rk) ** 2 + zk * zk < (WIRE_TOL * a) ** 2
    if wire.any():
        j, i = np.unravel_index(int(np.argmax(wire)), wire.shape)
        raise ValueError(f"points[{i}] = {points[i].tolist()!r} m is on the wire of {what}"
                         f"{f' {j}' if k > 1 else ''} (within {WIRE_TOL:g} x its radius {radii[j]:g} m), where the "
                         "field diverges.")
    c = loop_cylindrical(rk.ravel(), zk.ravel(), a.ravel())
    w = (MU0 / math.pi) * currents[:, None]
    summed = {key: (w * val.reshape(k, -1)).sum(axis=0) for key, val in c.items()}
    B, G = cylindrical_to_local(x, y, rho, summed, 1.0)
    return to_global(B, G, R)


@dataclass(frozen=True, init=False)
class CircularLoop(Source):
    """A circular current loop of negligible cross-section (exact field and gradient).

    Parameters
    ----------
    center : array_like, shape (3,)
        Its centre (m).
    normal : array_like, shape (3,)
        Its axis (normalized here); the current circulates counter-clockwise about it, so that ``B`` along the
        normal is positive at the centre for a positive current (right-hand rule).
    radius : float
        Its radius (m), in (0, :data:`MAX_RADIUS`].
    current : float
        Its current (A; ``N I`` for a coil of N turns of negligible cross-section), within +-:data:`MAX_CURRENT`.

    Notes
    -----
    The closed forms are in the module docstring. Points within ``WIRE_TOL * radius`` of the wire are refused;
    on the axis the axis limit is used.

    Examples
    --------
    >>> import numpy as np
    >>> loop = CircularLoop(center=(0, 0, 0), normal=(0, 0, 1), radius=0.05, current=10.0)
    >>> B, G = loop.field_and_gradient(np.array([[0.0, 0.0, 0.0]]))
    >>> round(float(B[0, 2]) * 1e6, 6)   # mu0 I / (2 R) = 125.663706 uT
    125.663706
    """

    center: tuple
    normal: tuple
    radius: float
    current: float

    def __init__(self, *, center, normal, radius, current):
        object.__setattr__(self, "center", tuple(position3("CircularLoop center", center).tolist()))
        object.__setattr__(self, "normal", tuple(unit_vector("CircularLoop normal", normal).tolist()))
        object.__setattr__(self, "radius", _radius("CircularLoop radius", radius))
        object.__setattr__(self, "current", _current("CircularLoop current", current))
        object.__setattr__(self, "_R", frame_from_axis(np.array(self.normal)))

    def field_and_gradient(self, points):
        return _coaxial(as_points(points), np.array(self.center), self._R, np.zeros(1), np.array([self.radius]),
                        np.array([self.current]), "the loop")


@dataclass(frozen=True, eq=False, init=False)
class CoaxialLoops(Source):
    """Circular loops on one axis (coil pairs, solenoids of thin turns), evaluated together: exact, and cheaper
    than the loops one by one (one pass over every loop and point, one change of frame).

    Parameters
    ----------
    center : array_like, shape (3,)
        A point of the axis (m): the origin of ``offsets``.
    normal : array_like, shape (3,)
        The common axis (normalized here), as :class:`CircularLoop`'s.
    offsets : array_like, shape (k,)
        Each loop's centre along the axis from ``center`` (m).
    radii : float or array_like, shape (k,)
        Their radii (m).
    currents : float or array_like, shape (k,)
        Their currents (A, ``N I`` for N turns), counter-clockwise about ``normal``.
    """

    center: np.ndarray
    normal: np.ndarray
    offsets: np.ndarray
    radii: np.ndarray
    currents: np.ndarray

    def __init__(self, *, center, normal, offsets, radii, currents):
        object.__setattr__(self, "center", position3("CoaxialLoops center", center))
        object.__setattr__(self, "normal", unit_vector("CoaxialLoops normal", normal))
        off = finite_array("CoaxialLoops offsets", offsets, ndim=1, min_len=1)
        if np.abs(off).max() > MAX_RADIUS:
            raise ValueError(f"CoaxialLoops offsets must lie within +-{MAX_RADIUS:g} m (metres), got {off.tolist()!r}.")
        k = off.size
        r = finite_array("CoaxialLoops radii", radii)
        cur = finite_array("CoaxialLoops currents", currents)
        r = np.full(k, float(r)) if r.ndim == 0 else r
        cur = np.full(k, float(cur)) if cur.ndim == 0 else cur
        if r.shape != (k,) or cur.shape != (k,):
            raise ValueError(f"CoaxialLoops needs one radius and one current per offset ({k}), got {r.size} radii "
                             f"and {cur.size} currents.")
        object.__setattr__(self, "offsets", off)
        object.__setattr__(self, "radii", np.array([_radius(f"CoaxialLoops radii[{j}]", v) for j, v in enumerate(r)]))
        object.__setattr__(self, "currents", np.array([_current(f"CoaxialLoops currents[{j}]", v)
                                                      for j, v in enumerate(cur)]))
        object.__setattr__(self, "_R", frame_from_axis(self.normal))

    @property
    def loops(self) -> list[CircularLoop]:
        """The loops one by one."""
        return [CircularLoop(center=self.center + o * self.normal, normal=self.normal, radius=a, current=i)
                for o, a, i in zip(self.offsets, self.radii, self.currents, strict=True)]

    def field_and_gradient(self, points):
        return _coaxial(as_points(points), self.center, self._R, self.offsets, self.radii, self.currents, "loop")


def _pair(center, normal, radius, current, spacing_ratio: float, sign: float, what: str) -> CoaxialLoops:
    a = _radius(f"{what} radius", radius)
    I = _current(f"{what} current", current)
    d = spacing_ratio * a
    return CoaxialLoops(center=position3(f"{what} center", center), normal=unit_vector(f"{what} normal", normal),
                        offsets=[-0.5 * d, 0.5 * d], radii=[a, a], currents=[sign * I, I])


def helmholtz_pair(*, center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), radius, current) -> CoaxialLoops:
    """Two coaxial loops one radius apart with the same current: the most uniform field of two loops.

    At the centre ``B = (4/5)^(3/2) mu0 I / R`` along ``normal``; its first, second and third derivatives along
    the axis vanish there, the fourth does not (``B(z) = B(0) (1 - 144/125 (z/R)^4 + ...)``).

    Parameters
    ----------
    center : array_like, shape (3,)
        Midpoint between the loops (m).
    normal : array_like, shape (3,)
        Common axis.
    radius : float
        Loop radius R (m); the loops sit at ``center +- (R/2) normal``.
    current : float
        Each loop's current (A, ``N I`` for N turns).
    """
    return _pair(center, normal, radius, current, 1.0, 1.0, "helmholtz_pair")


def maxwell_pair(*, center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), radius, current) -> CoaxialLoops:
    """Two coaxial loops ``sqrt(3) R`` apart with opposite currents: the most uniform gradient of two loops.

    The loop at ``center + (sqrt(3) R / 2) normal`` carries ``current``, the other ``-current``. At the centre
    ``B = 0`` and ``dB_n/dn = (3 sqrt(3) / 2) (4/7)^(5/2) mu0 I / R^2`` (about ``0.6413 mu0 I / R^2``); the third
    derivative along the axis vanishes there.

    Parameters
    ----------
    center, normal, radius, current
        As :func:`helmholtz_pair`.
    """
    return _pair(center, normal, radius, current, math.sqrt(3.0), -1.0, "maxwell_pair")


__all__ = ["MAX_CURRENT", "MAX_RADIUS", "WIRE_TOL", "CircularLoop", "CoaxialLoops", "helmholtz_pair",
           "loop_cylindrical", "maxwell_pair"]

"""Point-to-curve distances: the residuals of the paper's design objective (eq. 18), and their derivatives."""

from __future__ import annotations

import numpy as np


def _check(points, curve):
    p = np.asarray(points, dtype=float)
    c = np.asarray(curve, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {p.shape}.")
    if c.ndim != 2 or c.shape[1] != 2 or len(c) < 2:
        raise ValueError(f"curve must have shape (m, 2) with m >= 2, got {c.shape}.")
    return p, c


def _closest(p, c):
    """For each point: the nearest segment k, its parameter t in [0, 1], the segment vectors d, the offsets
    rel = p - c[k] and the distance (component arrays: several times faster than 3D einsums)."""
    a = c[:-1]  # (m-1, 2)
    d = c[1:] - a
    dx, dz = d[:, 0], d[:, 1]
    dd = dx * dx + dz * dz
    dd = np.where(dd > 0.0, dd, 1.0)
    rx = p[:, 0:1] - a[:, 0]  # (n, m-1)
    rz = p[:, 1:2] - a[:, 1]
    t = rx * dx
    t += rz * dz
    t /= dd
    np.clip(t, 0.0, 1.0, out=t)
    ex = rx - t * dx
    ez = rz - t * dz
    ex *= ex
    ez *= ez
    ex += ez
    k = np.argmin(ex, axis=1)
    rows = np.arange(len(p))
    rel = np.column_stack([rx[rows, k], rz[rows, k]])
    return k, t[rows, k], d, rel, np.sqrt(ex[rows, k])


def point_to_polyline(points, curve, *, signed: bool = False) -> np.ndarray:
    """Shortest distance from each point to the polyline ``curve`` (not to its vertices).

    Parameters
    ----------
    points : (n, 2) array
        Query points (any length unit).
    curve : (m, 2) array, m >= 2
        Polyline vertices, same unit.
    signed : bool
        If True, the distance is positive for points to the left of the curve (the side its
        normal, the tangent turned by +90 degrees, points to) and negative to the right. The
        sign makes the residual smooth where the curve passes through a point, which helps
        Gauss-Newton; squares are the same either way.

    Returns
    -------
    (n,) array
        Distances, same unit.
    """
    p, c = _check(points, curve)
    k, _, d, rel, dist = _closest(p, c)
    if not signed:
        return dist
    side = d[k, 0] * rel[:, 1] - d[k, 1] * rel[:, 0]
    return np.where(side < 0.0, -dist, dist)


def point_to_polyline_jacobian(points, curve, dcurve) -> tuple[np.ndarray, np.ndarray]:
    """Signed distances (as :func:`point_to_polyline` with ``signed=True``) and their derivatives with respect to
    parameters that move the curve's vertices.

    With the nearest point ``c* = (1 - t) c_k + t c_(k+1)`` of point ``i`` on segment ``k`` and the signed unit vector
    ``g_i = sign_i (p_i - c*) / |p_i - c*|`` (the segment's left normal when the point lies on it), the derivative is
    ``-g_i . ((1 - t) dc_k + t dc_(k+1))``: exact wherever the nearest point is unique (the change of ``t`` is
    orthogonal to ``g`` inside a segment and absent at a vertex).

    Parameters
    ----------
    points : (n, 2) array
        Query points.
    curve : (m, 2) array
        Polyline vertices.
    dcurve : (m, 2, k) array
        Derivatives of the vertices with respect to k parameters.

    Returns
    -------
    dist : (n,) array
        Signed distances.
    jac : (n, k) array
        d dist / d parameter.
    """
    p, c = _check(points, curve)
    dc = np.asarray(dcurve, dtype=float)
    if dc.ndim != 3 or dc.shape[:2] != c.shape:
        raise ValueError(f"dcurve must have shape ({len(c)}, 2, k), got {dc.shape}.")
    dist, foot = _signed_foot(p, c)
    return dist, _foot_jacobian(foot, dc)


def _signed_foot(p, c):
    """Signed distances and what their derivative needs: (segment index, t, unit vector g)."""
    k, t, d, rel, dist = _closest(p, c)
    side = d[k, 0] * rel[:, 1] - d[k, 1] * rel[:, 0]
    sign = np.where(side < 0.0, -1.0, 1.0)
    off = rel - t[:, None] * d[k]  # p - c*
    nd = np.hypot(d[k, 0], d[k, 1])
    normal = np.column_stack([-d[k, 1], d[k, 0]]) / np.where(nd > 0, nd, 1.0)[:, None]
    tiny = dist <= 1e-12 * max(float(np.abs(c).max()), 1e-300)
    g = np.where(tiny[:, None], normal, sign[:, None] * off / np.where(tiny, 1.0, dist)[:, None])
    return sign * dist, (k, t, g)


def _foot_jacobian(foot, dc):
    k, t, g = foot
    dfoot = (1.0 - t)[:, None, None] * dc[k] + t[:, None, None] * dc[k + 1]  # (n, 2, k)
    return -np.einsum("nj,njk->nk", g, dfoot)

"""Point-to-curve distances: the residuals of the paper's design objective (eq. 18)."""

from __future__ import annotations

import numpy as np


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
    p = np.asarray(points, dtype=float)
    c = np.asarray(curve, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2:
        raise ValueError(f"points must have shape (n, 2), got {p.shape}.")
    if c.ndim != 2 or c.shape[1] != 2 or len(c) < 2:
        raise ValueError(f"curve must have shape (m, 2) with m >= 2, got {c.shape}.")
    a = c[:-1]  # (m-1, 2)
    d = c[1:] - a
    dd = np.einsum("ij,ij->i", d, d)
    dd = np.where(dd > 0.0, dd, 1.0)
    rel = p[:, None, :] - a[None, :, :]  # (n, m-1, 2)
    t = np.clip(np.einsum("nmj,mj->nm", rel, d) / dd, 0.0, 1.0)
    diff = rel - t[..., None] * d[None, :, :]
    dist2 = np.einsum("nmj,nmj->nm", diff, diff)
    k = np.argmin(dist2, axis=1)
    rows = np.arange(len(p))
    dist = np.sqrt(dist2[rows, k])
    if not signed:
        return dist
    side = d[k, 0] * rel[rows, k, 1] - d[k, 1] * rel[rows, k, 0]
    return np.where(side < 0.0, -dist, dist)

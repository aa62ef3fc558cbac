"""Magnetic couples on rigid pieces in a uniform field, independent of the rod backend.

A rigid piece with body-frame moment ``m`` (A m^2) and world rotation ``R`` in a uniform
field ``B`` (T) feels the couple ``tau = (R m) x B`` (N m) and has energy ``-(R m) . B`` (J).
All functions are vectorized over pieces and take 3D vectors, so a planar chain (moments
in the body x-z plane) and a future 3D rod share them.
"""

from __future__ import annotations

import numpy as np


def body_moments_3d(moment_xz: np.ndarray) -> np.ndarray:
    """Planar moments ``(n, 2)`` (x, z) to 3D body-frame moments ``(n, 3)`` (A m^2)."""
    m = np.asarray(moment_xz, dtype=float)
    out = np.zeros((m.shape[0], 3))
    out[:, 0] = m[:, 0]
    out[:, 2] = m[:, 1]
    return out


def world_moments(xmat: np.ndarray, moment_body: np.ndarray) -> np.ndarray:
    """World-frame moments ``R m``, shape ``(n, 3)``.

    Parameters
    ----------
    xmat : ndarray, shape (n, 9) or (n, 3, 3)
        Row-major rotation matrices of the pieces (MuJoCo's ``data.xmat``).
    moment_body : ndarray, shape (n, 3)
        Body-frame moments (A m^2).
    """
    R = np.asarray(xmat).reshape(-1, 3, 3)
    return np.einsum("nij,nj->ni", R, moment_body)


def couples(m_world: np.ndarray, field3: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Couples ``m x B`` (N m), shape ``(n, 3)``; ``field3`` is ``(B_x, B_y, B_z)`` in T."""
    bx, by, bz = float(field3[0]), float(field3[1]), float(field3[2])
    if out is None:
        out = np.empty_like(m_world)
    mx, my, mz = m_world[:, 0], m_world[:, 1], m_world[:, 2]
    out[:, 0] = my * bz - mz * by
    out[:, 1] = mz * bx - mx * bz
    out[:, 2] = mx * by - my * bx
    return out


def energy(m_world: np.ndarray, field3: np.ndarray) -> float:
    """Magnetic potential energy ``-sum (R m) . B`` (J)."""
    return -float(np.sum(m_world @ np.asarray(field3, dtype=float)))

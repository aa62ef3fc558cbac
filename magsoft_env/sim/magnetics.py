"""Magnetic couples on rigid pieces in a uniform field, independent of the rod backend.

A rigid piece with body-frame moment ``m`` (A m^2) and world rotation ``R`` in a uniform
field ``B`` (T) feels the couple ``tau = (R m) x B`` (N m) and has energy ``-(R m) . B`` (J).
All functions are vectorized over pieces and take 3D vectors, so a planar chain (moments
in the body x-z plane) and the 3D strip's edges share them.
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


# ---------------------------------------------------------------------------------------------------------------------
# Magnetic poles: the couples as forces along the field, which a physics engine applies itself


#: Relative size below which a pole's dipole (or charge) counts as zero: a few hundred round-offs, so a
#: uniformly magnetized run of pieces needs no poles inside it (its interior charges cancel exactly).
POLE_TOLERANCE = 64 * float(np.finfo(float).eps)


def magnetic_poles(
    moments: np.ndarray, parent: np.ndarray, joint_in_self: np.ndarray, joint_in_parent: np.ndarray,
    centres: np.ndarray, levers: np.ndarray, *, free_root: bool,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Point forces ``c_k B`` along the field that exert exactly the couples ``(R_i m_i) x B`` of a tree of pieces.

    A force ``c B`` at a body-fixed point ``q`` of piece ``i`` (a "pole" of charge ``c``, A m) does, at
    every configuration, what the couples do when, for every piece ``i``, the charges of the subtree
    of ``i`` have the dipole moment of its magnetic moments about the joint of ``i``:

    .. code-block:: text

        sum_{poles k on i} c_k (q_k - o_i) + sum_{children j of i} C_j (h_j - o_i) = m_i

    with ``o_i`` the joint of ``i`` to its parent, ``h_j`` the joint of child ``j`` and ``C_j`` the
    total charge of the subtree of ``j`` (all in the frame of ``i``); a free root (slide joints)
    also needs zero total charge. The forces are constant in the world frame (only the field sets
    them), so the engine's own point-force Jacobians give the generalized couples; exact in 3D as
    in the plane. Pieces are solved from the leaves: each gets at most one pole, where its
    residual dipole is nonzero, at the lever distance from its joint toward its centre. A
    uniformly magnetized run needs no pole inside it (its charges cancel: the poles of a
    uniform beam are its two ends), a transverse magnetization one per piece.

    Parameters
    ----------
    moments : ndarray, shape (n, 3)
        Magnetic moment of each piece in its body frame (A m^2).
    parent : ndarray, shape (n,)
        Index of each piece's parent, -1 for the root (exactly one).
    joint_in_self : ndarray, shape (n, 3)
        The joint of each piece to its parent, in its own frame (m); for the root, the point the
        root's dipole is taken about (its base joint).
    joint_in_parent : ndarray, shape (n, 3)
        The same joint in the parent's frame (m); ignored for the root.
    centres : ndarray, shape (n, 3)
        A point inside each piece (m), toward which its pole is placed.
    levers : ndarray, shape (n,)
        Distance of each pole from its joint (m), > 0 (the piece length keeps round-off at that of
        the couples).
    free_root : bool
        True: the root moves (a free or planar base): total charge zero, poles on the root too.
        False: the root is welded to the world: forces on it do nothing, it gets no poles.

    Returns
    -------
    piece : ndarray of int, shape (p,)
        Piece of each pole.
    position : ndarray, shape (p, 3)
        Pole positions in the pieces' frames (m).
    charge : ndarray, shape (p,)
        Charges (A m): the force on pole ``k`` is ``charge[k] * B`` (N, B in T).

    Examples
    --------
    A uniform two-piece chain clamped at piece 0 has one pole, at the tip, of charge m / l:

    >>> m = np.array([[1e-3, 0, 0], [1e-3, 0, 0]])
    >>> piece, pos, c = magnetic_poles(m, np.array([-1, 0]), np.zeros((2, 3)), np.array([[0, 0, 0], [0.01, 0, 0]]),
    ...                                np.array([[0.005, 0, 0]] * 2), np.array([0.01, 0.01]), free_root=False)
    >>> piece.tolist(), pos.tolist(), c.tolist()
    ([1], [[0.01, 0.0, 0.0]], [0.1])
    """
    m = np.asarray(moments, dtype=float)
    n = m.shape[0]
    parent = np.asarray(parent, dtype=int)
    o, h = np.asarray(joint_in_self, dtype=float), np.asarray(joint_in_parent, dtype=float)
    centres, levers = np.asarray(centres, dtype=float), np.asarray(levers, dtype=float)
    roots = np.nonzero(parent < 0)[0]
    if roots.size != 1:
        raise ValueError(f"parent must name exactly one root (-1), got {roots.size}.")
    children = [[] for _ in range(n)]
    for i, p in enumerate(parent):
        if p >= 0:
            children[p].append(i)
    order, stack = [], [int(roots[0])]
    while stack:  # depth-first from the root; reversed, every child comes before its parent
        i = stack.pop()
        order.append(i)
        stack.extend(children[i])
    if len(order) != n:
        raise ValueError("parent must describe one tree over all pieces.")
    subtree = np.zeros(n)  # total charge of the subtree of each piece (A m)
    piece, pos, charge = [], [], []

    def add(i, q, c):
        piece.append(i)
        pos.append(q)
        charge.append(c)

    for i in reversed(order):
        kids = children[i]
        c_kids = float(sum(subtree[j] for j in kids))
        arm = [h[j] - o[i] for j in kids]
        dipole = m[i] - sum((subtree[j] * a for j, a in zip(kids, arm, strict=True)), np.zeros(3))
        size = float(np.linalg.norm(dipole))
        scale = float(np.linalg.norm(m[i])) + sum(abs(subtree[j]) * float(np.linalg.norm(a))
                                                  for j, a in zip(kids, arm, strict=True))
        lever = float(levers[i])
        if parent[i] >= 0:
            c = 0.0
            if size > POLE_TOLERANCE * scale:
                u = dipole / size
                s = 1.0 if u @ (centres[i] - o[i]) >= 0.0 else -1.0
                c = s * size / lever
                add(i, o[i] + s * lever * u, c)
            subtree[i] = c_kids + c
        elif free_root:
            c = -c_kids  # total charge zero: no net force
            c_small = abs(c) <= POLE_TOLERANCE * max(sum(abs(subtree[j]) for j in kids), 1e-300)
            if size <= POLE_TOLERANCE * scale:
                if not c_small:
                    add(i, o[i].copy(), c)
            elif not c_small and size <= abs(c) * lever:
                add(i, o[i] + dipole / c, c)
            else:  # a pair: charge c in all, dipole as required
                u, d = dipole / size, size / lever
                add(i, o[i] + 0.5 * lever * u, 0.5 * c + d)
                add(i, o[i] - 0.5 * lever * u, 0.5 * c - d)
    return np.array(piece, dtype=int), np.array(pos, dtype=float).reshape(-1, 3), np.array(charge, dtype=float)

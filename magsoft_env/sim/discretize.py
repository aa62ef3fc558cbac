"""Backend-neutral discretization of a :class:`~magsoft_env.spec.Beam` into rigid links.

The midpoint layout: the beam is cut into ``N`` cells (equal, ``ds = L / N``, unless a
``grading`` is given) and a hinge sits at the midpoint of each cell, ``s_j = (j + 1/2) ds``.
The half-cell ``[0, ds/2]`` is the base piece (fixed to the clamp in a cantilever), links
``0 .. N-2`` span from one hinge to the next and the last link is the half cell
``[L - ds/2, L]``. Hinge ``j`` carries the bending compliance of cell ``j``
(``k_j = 1 / int_cell ds / EI``, which is ``E I / ds`` for a uniform beam): the midpoint rule
for the elastica, second-order accurate in ``ds``. A ``grading > 1`` makes the cells
geometrically finer toward the clamp, where a cantilever in a strong field concentrates its
curvature. Everything here is numpy only, so a 3D rod backend can reuse it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..spec import Beam

#: What the planar checks call the rod this package builds in MuJoCo (it bends in the x-z plane).
PLANAR_ROD = "the MuJoCo hinge-chain rod"
_GAUSS_ORDER = 8  # Gauss-Legendre points per smooth piece (exact for degree-15 polynomials)


def _integrate(beam: Beam, a: float, b: float, funcs) -> list[float]:
    """Integrals over ``[a, b]`` (m) of each ``f(s)`` in ``funcs``, split at profile breakpoints."""
    cuts = [a, *[p for p in beam.breakpoints() if a < p < b], b]
    x, w = np.polynomial.legendre.leggauss(_GAUSS_ORDER)
    s_all, w_all = [], []
    for lo, hi in zip(cuts[:-1], cuts[1:], strict=True):
        s_all.append(0.5 * (hi - lo) * x + 0.5 * (hi + lo))
        w_all.append(0.5 * (hi - lo) * w)
    s = np.concatenate(s_all)
    wt = np.concatenate(w_all)
    return [float(np.dot(wt, f(s))) for f in funcs]


@dataclass(frozen=True)
class RodDiscretization:
    """Per-piece quantities of a beam cut into ``segments`` midpoint cells.

    Index 0 of the piece arrays is the base half-cell ``[0, ds/2]``; index ``i + 1`` is
    link ``i`` (``i = 0 .. N-1``), the link that hinge ``i`` turns.

    Attributes
    ----------
    length : float
        Beam length L (m).
    segments : int
        Number of cells (and hinges) N.
    hinge_s : ndarray, shape (N,)
        Arc length of each hinge (m).
    piece_start, piece_length : ndarray, shape (N + 1,)
        Start arc length and length of each piece (m).
    stiffness : ndarray, shape (N,)
        Hinge rotational stiffness (N m / rad).
    mass : ndarray, shape (N + 1,)
        Piece mass (kg).
    com : ndarray, shape (N + 1,)
        Centre of mass of each piece along its axis, from the piece start (m).
    inertia : ndarray, shape (N + 1, 3)
        Principal moments of inertia about the centre of mass (kg m^2), body axes x (along
        the beam), y (width, the bending axis), z (thickness).
    moment : ndarray, shape (N + 1, 2)
        Magnetic moment of each piece in its body frame, components (x, z) (A m^2):
        ``int A M(s) (cos beta(s), sin beta(s)) ds``.
    """

    length: float
    segments: int
    hinge_s: np.ndarray
    piece_start: np.ndarray
    piece_length: np.ndarray
    stiffness: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    moment: np.ndarray

    @property
    def ds(self) -> float:
        """Mean cell length L / N (m)."""
        return self.length / self.segments


def cell_edges(length: float, segments: int, grading: float = 1.0) -> np.ndarray:
    """Cell boundaries (m), shape ``(segments + 1,)``: geometric cells, the last ``grading``
    times as long as the first (1: equal cells; > 1: finer at the clamp)."""
    if grading == 1.0:
        return np.linspace(0.0, length, segments + 1)
    r = grading ** (1.0 / (segments - 1))
    sizes = r ** np.arange(segments)
    return np.concatenate([[0.0], np.cumsum(sizes)]) * (length / sizes.sum())


def discretize(beam: Beam, segments: int, *, grading: float = 1.0) -> RodDiscretization:
    """Cut ``beam`` into ``segments`` midpoint cells (see the module docstring).

    Parameters
    ----------
    beam : Beam
        The beam specification.
    segments : int
        Number of cells N, in [2, 1000].
    grading : float
        Ratio of the first cell's length to the last one's, in [0.1, 10] (1: equal cells).

    Returns
    -------
    RodDiscretization
    """
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    beam.require_planar(PLANAR_ROD)
    if isinstance(segments, bool) or not isinstance(segments, (int, np.integer)) or not 2 <= segments <= 1000:
        raise ValueError(f"segments must be an integer in [2, 1000], got {segments!r}.")
    if not (isinstance(grading, (int, float, np.floating)) and 0.1 <= grading <= 10.0):
        raise ValueError(f"grading must be a number in [0.1, 10], got {grading!r}.")
    n = int(segments)
    L = beam.length
    edges = cell_edges(L, n, float(grading))
    hinge_s = 0.5 * (edges[:-1] + edges[1:])
    start = np.concatenate([[0.0], hinge_s])
    end = np.concatenate([hinge_s, [L]])
    h, w = beam.thickness, beam.width

    def flex(s):
        return 1.0 / beam.bending_stiffness(s)

    stiffness = np.array([1.0 / _integrate(beam, edges[j], edges[j + 1], [flex])[0] for j in range(n)])

    mass = np.empty(n + 1)
    com = np.empty(n + 1)
    inertia = np.empty((n + 1, 3))
    moment = np.empty((n + 1, 2))
    for i, (a, b) in enumerate(zip(start, end, strict=True)):
        def mx(s):
            return beam.moment_per_length(s) * np.cos(beam.beta(s))

        def mz(s):
            return beam.moment_per_length(s) * np.sin(beam.beta(s))

        m0, m1 = _integrate(beam, a, b, [beam.mass_per_length, lambda s: beam.mass_per_length(s) * s])
        c = m1 / m0
        j2 = _integrate(beam, a, b, [lambda s, c=c: beam.mass_per_length(s) * (s - c) ** 2])[0]
        mass[i] = m0
        com[i] = c - a
        inertia[i] = (m0 * (w**2 + h**2) / 12.0, j2 + m0 * h**2 / 12.0, j2 + m0 * w**2 / 12.0)
        moment[i] = _integrate(beam, a, b, [mx, mz])
    return RodDiscretization(
        length=L, segments=n, hinge_s=hinge_s, piece_start=start, piece_length=end - start,
        stiffness=stiffness, mass=mass, com=com, inertia=inertia, moment=moment,
    )

"""The fields and readings every analytical equilibrium shares, planar or 3D: :class:`PathResult`.

:class:`~magsoft_env.theory.solver.EquilibriumResult` (the planar beam) and
:class:`~magsoft_env.theory.rod_solver.RodResult` (the 3D rod) extend it with their own shape; code that reads
status, stability, the tip or the centreline reads both alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as dc_field

import numpy as np

from ..spec import Field


@dataclass(frozen=True)
class PathResult:
    """Equilibrium of a beam under one field along a loading path, in the style of scipy's ``BVPResult`` (frozen):
    what every solver's result has. Arrays hold one value per distinct collocation node, ``n = nodes`` of them,
    from the clamp (or left end) to the tip. Units are SI.

    Attributes
    ----------
    success : bool
        True when an equilibrium was found and verified (``status`` 0 or 2).
    status : int
        0 converged; 1 continuation stalled; 2 converged but under-resolved; 3 direct solve failed; 4 not
        verified between the nodes; 5 (3D) a load step used up its work budget.
    message : str
        Human-readable status (``TERMINATION_MESSAGES``, plus passed folds and the resolution).
    s : (n,) ndarray
        Reference arc length of the nodes (m).
    tip_deflection : float
        z(L) (m).
    max_curvature : float
        Largest bending curvature over the nodes (1/m).
    stable : bool
        Smallest eigenvalue of the discrete second variation is positive.
    snap_through : bool
        A fold (or a bifurcation onto an unstable branch) was passed on the way to this field and the solver
        left the branch to a stable one.
    field : Field
        The applied field (T).
    gravity : float
        Gravitational acceleration along -z (m/s^2).
    residual : float
        Largest |residual| of the discrete equilibrium equations at the nodes (rad).
    resolution : float
        The error that was measured (rad): the larger of the shape's trailing Chebyshev coefficients on the
        final grid and :attr:`verification` (NaN when the solve failed).
    nodes : int
        Number of distinct collocation nodes, ``n``.
    newton_iterations : int
        Newton iterations spent by the solver up to this result (cumulative along a path).
    wall_time : float
        Seconds spent reaching this equilibrium from the previous one (or from the unloaded beam, gravity
        included, for the first).
    events : list of dict
        Folds and bifurcations passed so far along the path, each ``{"kind", "load_fraction", "field_T",
        "gravity", "converged"}`` (3D results may add ``"critical_field_T"`` and ``"critical_fraction"``).
    verification : float
        Largest residual of the equilibrium equations between the nodes (rad), measured independently of the
        solver (:mod:`magsoft_env.theory.verify`); ``success`` requires it to be at most ``verify_tol``.
    """

    success: bool
    status: int
    message: str
    s: np.ndarray
    tip_deflection: float
    max_curvature: float
    stable: bool
    snap_through: bool
    field: Field
    gravity: float
    residual: float
    resolution: float
    nodes: int
    newton_iterations: int
    wall_time: float = 0.0
    events: list = dc_field(default_factory=list)
    verification: float = math.nan

    @property
    def length(self) -> float:
        """L (m)."""
        return float(self.s[-1])

    def _samples(self, n) -> np.ndarray:
        """``n`` evenly spaced arc lengths over [0, L] (m), ``n`` an integer >= 2."""
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 2:
            raise ValueError(f"sample n must be an integer >= 2, got {n!r}.")
        return np.linspace(0.0, self.length, int(n))

    def _arc(self, s) -> np.ndarray:
        """``s`` as an array of reference arc lengths within [0, L] (m), or a ValueError."""
        s = np.asarray(s, dtype=float)
        if not np.all(np.isfinite(s)) or np.any(s < 0) or np.any(s > self.length * (1 + 1e-12)):
            raise ValueError(f"s must lie in [0, {self.length:g}] m, got values in [{s.min():g}, {s.max():g}].")
        return s

    def _status_dict(self) -> dict:
        """The shared metrics as plain numbers, for JSON."""
        return {
            "success": bool(self.success),
            "status": int(self.status),
            "message": self.message,
            "gravity_m_s2": self.gravity,
            "max_curvature_1_m": self.max_curvature,
            "stable": bool(self.stable),
            "snap_through": bool(self.snap_through),
            "verification_rad": self.verification,
            "residual": self.residual,
            "nodes": self.nodes,
        }


class PlanarShape:
    """The planar readings of a result with ``x``, ``z`` (nodes), ``_full`` (theta, x, z on every grid node) and
    ``_grid``: the 3D result's names (``tip_position``, ``tip_twist``, ``centreline``) and spectral sampling."""

    @property
    def tip_position(self) -> np.ndarray:
        """(x, y, z) of the tip (m), y = 0: the same reading as the 3D :class:`RodResult`'s."""
        return np.array([self.x[-1], 0.0, self.z[-1]])

    @property
    def tip_twist(self) -> float:
        """0.0 (rad): a planar beam does not twist (as the 3D :class:`RodResult` reports it)."""
        return 0.0

    @property
    def centreline(self) -> np.ndarray:
        """(n, 3) deformed centreline (m), y = 0: the same reading as the 3D result's."""
        return np.column_stack([self.x, np.zeros_like(self.x), self.z])

    def sample(self, n: int = 101):
        """Centreline at ``n`` evenly spaced arc lengths: (s, x, z, theta) arrays (m, m, m, rad)."""
        s_new = self._samples(n)
        return (s_new, *self.at(s_new))

    def at(self, s):
        """Centreline (x, z, theta) at reference arc lengths ``s`` (m), spectrally interpolated."""
        s = self._arc(s)
        th, xx, zz = self._full
        vals = self._grid.interpolate(np.column_stack([th, xx, zz]), s.ravel())
        return vals[:, 1].reshape(s.shape), vals[:, 2].reshape(s.shape), vals[:, 0].reshape(s.shape)


__all__ = ["PathResult", "PlanarShape"]

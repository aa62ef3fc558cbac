"""Theory versus MuJoCo rod along a preset's loading path: tip error / L against segments."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from ..sim.equilibrium import SimEquilibrium, mujoco_path
from ..spec.field import planar_field


@dataclass(frozen=True)
class CrosscheckRow:
    """One preset at one segment count (frozen).

    Attributes
    ----------
    preset : str
        Name of the statics preset.
    segments : int
        Number of cells N of the MuJoCo rod (dimensionless count).
    grading : float
        Last / first cell length of the rod (dimensionless; see :class:`~magsoft_env.sim.RodOptions`).
    max_tip_error : float
        Largest tip-position distance over the path, divided by L (dimensionless).
    mean_tip_error : float
        Mean of the same over the path states (dimensionless, fraction of L).
    sim_seconds, theory_seconds : float
        Wall time of the MuJoCo path and of the analytical path (s), same process;
        ``theory_seconds`` is NaN when the analytical path was given precomputed.
    success : bool
        Both sides converged at every state.
    """

    preset: str
    segments: int
    grading: float
    max_tip_error: float
    mean_tip_error: float
    sim_seconds: float
    theory_seconds: float
    success: bool

    def to_dict(self) -> dict:
        """Plain numbers with the unit in the key (the columns of ``crosscheck.csv``), for JSON."""
        return {
            "preset": self.preset,
            "segments": int(self.segments),
            "grading": float(self.grading),
            "max_tip_error_over_L": float(self.max_tip_error),
            "mean_tip_error_over_L": float(self.mean_tip_error),
            "mujoco_s": float(self.sim_seconds),
            "theory_s": float(self.theory_seconds),
            "success": bool(self.success),
        }


def crosscheck_preset(preset, segments=(10, 20, 40), *, grading: float | None = None, theory_results=None):
    """Compare the analytical solver (``coupling="rotated"``, inextensible) and the MuJoCo rod.

    Parameters
    ----------
    preset : magsoft_env.cases.Preset
        A cantilever preset.
    segments : sequence of int
        Segment counts to run.
    grading : float or None
        Cell grading of the rod (see :class:`~magsoft_env.sim.RodOptions`); ``None``: the
        cantilever default.
    theory_results : list, optional
        Precomputed analytical path (skips the theory solve and its timing).

    Returns
    -------
    rows : list of CrosscheckRow
    theory : list of EquilibriumResult
    sims : dict of int to list of SimEquilibrium
    """
    if preset.support != "cantilever":
        raise ValueError(f"preset {preset.name!r} has support={preset.support!r}; the MuJoCo rod is clamped only.")
    what = f"crosscheck_preset (preset {preset.name!r} on the MuJoCo hinge-chain rod)"
    preset.beam.require_planar(what)
    for f in preset.fields:
        planar_field(f, what)
    from ..sim.model import RodOptions
    from ..theory import solve_path

    grading = RodOptions(scene="cantilever", grading=grading).grading
    fields = preset.fields
    t_th = math.nan
    if theory_results is None:
        t0 = time.perf_counter()
        theory_results = solve_path(
            preset.beam, fields, gravity=preset.gravity, coupling="rotated", extensible=False,
            clamp_angle=preset.clamp_angle,
        )
        t_th = time.perf_counter() - t0
    L = preset.beam.length
    rows, sims = [], {}
    for n in segments:
        t0 = time.perf_counter()
        sim = mujoco_path(
            preset.beam, fields, gravity=preset.gravity, segments=int(n), clamp_angle=preset.clamp_angle,
            grading=grading,
        )
        t_sim = time.perf_counter() - t0
        err = tip_errors(sim, theory_results, L)
        ok = all(r.success for r in theory_results) and all(s.success for s in sim)
        rows.append(CrosscheckRow(preset.name, int(n), grading, float(err.max()), float(err.mean()), t_sim, t_th, ok))
        sims[int(n)] = sim
    return rows, theory_results, sims


def tip_errors(sims: list[SimEquilibrium], theory_results, length: float) -> np.ndarray:
    """Tip-position distance / L for each state of a path, shape ``(n,)``."""
    return np.array([
        math.hypot(s.x[-1] - t.x[-1], s.z[-1] - t.z[-1]) / length for s, t in zip(sims, theory_results, strict=True)
    ])

"""Static equilibria of the MuJoCo rod along a loading path (gravity first, then fields)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..spec import Beam, Field, as_field, as_fields
from ..spec.field import planar_field
from ..validate import nonnegative, positive
from .discretize import PLANAR_ROD
from .health import MAX_STEPS, check_steps
from .model import RodOptions
from .simulator import SettleResult, Simulator


@dataclass(frozen=True)
class SimEquilibrium:
    """A settled MuJoCo rod (frozen).

    The rod has ``N`` cells (``segments``): ``N + 1`` rigid pieces joined by ``N`` hinges, so
    the centreline has ``N + 2`` points (the clamp, every hinge, the tip). Units are SI.

    Attributes
    ----------
    success : bool
        Every settle along the path passed its convergence test.
    message : str
        ``"converged"``, or the settles that failed, separated by ``"; "``.
    field : Field
        Applied field (T).
    s : (N + 2,) ndarray
        Reference arc length of the centerline points (m): clamp, hinges, tip.
    x, z : (N + 2,) ndarray
        Centerline (m), base to tip.
    theta : (N + 1,) ndarray
        Tangent angle of each rigid piece (rad), base half-cell first.
    tip_angle : float
        Tangent angle of the tip piece (rad).
    tip_deflection : float
        z of the tip (m).
    residual : float
        Final static residual (rad; see :meth:`Simulator.static_residual`).
    steps : int
        Simulation steps spent settling along the whole path so far (dimensionless count).
    """

    success: bool
    message: str
    field: Field
    s: np.ndarray
    x: np.ndarray
    z: np.ndarray
    theta: np.ndarray
    tip_angle: float
    tip_deflection: float
    residual: float
    steps: int

    def to_dict(self) -> dict:
        """Metrics as plain numbers (SI and degrees), for JSON."""
        return {
            "success": bool(self.success),
            "message": self.message,
            "field_T": [float(self.field.Bx), float(self.field.Bz)],
            "segments": len(self.theta) - 1,
            "tip_deflection_m": float(self.tip_deflection),
            "v_over_L": float(self.tip_deflection) / float(self.s[-1]),
            "tip_angle_rad": float(self.tip_angle),
            "tip_angle_deg": math.degrees(self.tip_angle),
            "tip_x_m": float(self.x[-1]),
            "tip_z_m": float(self.z[-1]),
            "residual_rad": float(self.residual),
            "steps": int(self.steps),
        }


def _snapshot(sim: Simulator, ok: bool, msg: str, res: float, steps: int) -> SimEquilibrium:
    x, z = sim.centerline()
    return SimEquilibrium(
        success=ok, message=msg, field=sim.field, s=sim.arc_length(), x=x, z=z, theta=sim.angles(),
        tip_angle=sim.tip_angle(), tip_deflection=float(z[-1]), residual=res, steps=steps,
    )


def mujoco_path(
    beam: Beam,
    fields,
    *,
    gravity: float = 9.81,
    segments: int = 20,
    clamp_angle: float = 0.0,
    max_field_step: float = 1e-3,
    timestep: float = 1e-2,
    integrator: str = "discrete",
    tol: float = 1e-8,
    max_time: float = 20.0,
    grading: float | None = None,
) -> list[SimEquilibrium]:
    """Settle the clamped MuJoCo rod along a loading path: gravity first, then each field in turn.

    Between consecutive fields (starting from zero field) the field moves in straight-line
    sub-steps no larger than ``max_field_step`` (T), each settled (damped dynamics, see
    :meth:`Simulator.settle`); one result is returned per entry of ``fields``.

    Parameters
    ----------
    beam : Beam
    fields : sequence of Field or (B_x, B_z)
        Fields (T) in loading order.
    gravity : float
        m/s^2 along -z, >= 0.
    segments : int
        Number of cells N.
    clamp_angle : float
        Clamp angle (rad) from +x toward +z.
    max_field_step : float
        Largest field change (T) between settles, > 0.
    timestep : float
        Step (s) used while settling, in (0, 0.1]; with the ``discrete`` integrator large steps
        are stable.
    integrator : str
        MuJoCo integrator (see :class:`RodOptions`).
    tol : float
        Static-residual tolerance (rad), > 0.
    max_time : float
        Simulated-time budget per settle (s), > 0.
    grading : float or None
        Last / first cell length (see :class:`RodOptions`); 1 gives equal cells; ``None``:
        the cantilever default (1.5, finer at the clamp).

    Every argument is checked before any work, and so is the work: a path segment (from one
    field to the next) may take at most :data:`~magsoft_env.sim.health.MAX_STEPS` steps in the
    worst case (its settles times ``max_time / timestep`` each), else a ValueError says how
    much work it would be and what to change.

    Returns
    -------
    list of SimEquilibrium
    """
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a Beam, got {type(beam).__name__}.")
    beam.require_planar(PLANAR_ROD)
    flist = [planar_field(f, PLANAR_ROD) for f in as_fields(fields)]
    nonnegative("gravity", gravity, unit="m/s^2")
    mstep = positive("max_field_step", max_field_step, unit="T")
    tol = positive("tol", tol, unit="rad")
    max_time = positive("max_time", max_time, unit="s")
    if timestep is not None:
        positive("timestep", timestep, unit="s")
    opts = RodOptions(
        segments=segments, scene="cantilever", integrator=integrator, timestep=timestep, gravity=gravity,
        clamp_angle=clamp_angle, grading=grading,
    )
    # the worst-case work, before any: every settle may use its whole budget
    budget = math.ceil(check_steps(f"max_time / timestep = {max_time:g} s / {opts.timestep:g} s per settle",
                                   max_time / opts.timestep, "Use a larger timestep or a shorter max_time."))
    prev = np.zeros(2)
    substeps = []
    for f in flist:
        target = f.as_array()
        n = max(1, math.ceil(float(np.max(np.abs(target - prev))) / mstep))
        if n * budget > MAX_STEPS:
            need = float(np.max(np.abs(target - prev))) * budget / MAX_STEPS
            check_steps(
                f"the path segment to ({f.Bx * 1e3:.4g}, {f.Bz * 1e3:.4g}) mT: {n:.3g} settles (max_field_step = "
                f"{mstep:g} T) x up to {budget} steps each", float(n) * budget,
                f"Use max_field_step >= {need:.3g} T, or fewer steps per settle (larger timestep, shorter max_time).",
            )
        substeps.append(n)
        prev = target
    sim = Simulator(beam, opts)
    steps = 0
    r: SettleResult = sim.settle(tol=tol, max_time=max_time)
    steps += r.steps
    ok, msgs = r.success, [] if r.success else [f"gravity: {r.message}"]
    out = []
    prev = np.zeros(2)
    for f, n in zip(flist, substeps, strict=True):
        target = f.as_array()
        for k in range(1, n + 1):
            sim.set_field(prev + (target - prev) * k / n)
            r = sim.settle(tol=tol, max_time=max_time)
            steps += r.steps
            if not r.success:
                ok = False
                msgs.append(f"field ({sim.field.Bx * 1e3:.4g}, {sim.field.Bz * 1e3:.4g}) mT: {r.message}")
        prev = target
        out.append(_snapshot(sim, ok, "; ".join(msgs) if msgs else "converged", r.residual, steps))
    return out


def mujoco_equilibrium(
    beam: Beam,
    field,
    *,
    gravity: float = 9.81,
    segments: int = 20,
    clamp_angle: float = 0.0,
    max_field_step: float = 1e-3,
    timestep: float | None = None,
    integrator: str = "discrete",
    tol: float | None = None,
    max_time: float = 20.0,
    grading: float | None = None,
    rod: str = "planar",
    imperfection: float = 0.0,
):
    """Static equilibrium of the clamped MuJoCo rod under ``field`` (T), reached like the
    analytical solver: gravity first, then the field ramped from zero in straight-line steps
    of at most ``max_field_step`` (T), each settled. See :func:`mujoco_path` for the arguments.

    ``rod="cable"``: the 3D flexcomp strip (:func:`~magsoft_env.sim.cable.cable_path`), for fields
    ``(B_x, B_y, B_z)`` (a pair keeps its planar meaning ``(B_x, B_z)``) and any magnetization direction;
    ``timestep`` defaults to 1 ms there (10 ms for the planar rod; the cable's edge constraint follows the
    step), ``tol`` (default 1e-6) is its settling residual, ``imperfection`` (T) a field along z that seeds
    out-of-plane branches, and ``clamp_angle`` must be 0. ``tol`` defaults to 1e-8 rad for the planar rod;
    ``imperfection`` is the cable's only.

    Returns
    -------
    SimEquilibrium or CableEquilibrium
        Planar: ``x``, ``z`` (m, base to tip), ``tip_angle`` (rad), ``success``. Cable: ``tip_position``
        (x, y, z; m), ``tip_twist`` (rad, ``int k3 ds``), ``centreline`` (m), ``success``, ``residual``.

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> beam = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> eq = mujoco_equilibrium(beam, (0.0, 0.013))
    >>> bool(eq.success), round(eq.tip_angle, 2)
    (True, 1.57)
    """
    from ..validate import choice

    choice("rod", rod, ("planar", "cable"))
    if rod == "cable":
        from .cable import cable_path

        if clamp_angle != 0.0:
            raise ValueError(f"the cable rod is clamped along +x (clamp_angle = 0), got {clamp_angle!r}.")
        return cable_path(
            beam, [as_field(field)], gravity=gravity, segments=segments,
            timestep=1e-3 if timestep is None else timestep, integrator=integrator, grading=grading,
            tol=1e-6 if tol is None else tol, max_time=max_time, max_field_step=max_field_step,
            imperfection=imperfection)[0]
    if imperfection != 0.0:
        raise ValueError("imperfection applies to rod='cable' (the planar rod cannot leave its plane).")
    tol = 1e-8 if tol is None else tol
    timestep = 1e-2 if timestep is None else timestep
    return mujoco_path(
        beam, [as_field(field)], gravity=gravity, segments=segments, clamp_angle=clamp_angle,
        max_field_step=max_field_step, timestep=timestep, integrator=integrator, tol=tol, max_time=max_time,
        grading=grading,
    )[0]

"""Static equilibria of the MuJoCo rods along a loading path (gravity first, then fields), with their stability.

Every rod settles on the :class:`~magsoft_env.sim.Simulator` (its health checks included) and returns one result
type, :class:`SimEquilibrium`. Each equilibrium is then tested for stability from the stiffness of the
constrained system (:func:`static_stability`): the derivative of the accelerations at rest with respect to the
positions, whose largest eigenvalue is negative at a stable state and positive past a bifurcation. An unstable
state is left along its unstable mode (the side chosen by ``branch``) and settled again, so that above a
bifurcation the stable branch is found without an imperfection.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..spec import Beam, Field, as_field, as_fields
from ..validate import finite_number, nonnegative, positive
from .backend import rod_class
from .health import MAX_STEPS, check_steps
from .model import RodOptions
from .simulator import SettleResult, Simulator
from .sources import Blend, SourceField, check_source, field_bound, split_source

#: A state is unstable when the largest eigenvalue of ``d qacc / d qpos`` at rest exceeds this fraction of the
#: square of the beam's first bending frequency (:func:`static_stability`); the finite-difference noise of the
#: eigenvalues stays below 1e-6 of it (measured on the clamped paper strip and chain, tests/test_statics.py).
UNSTABLE_EIGENVALUE = 1e-4
#: Most times an unstable state is left along its unstable mode and settled again.
MAX_BRANCH_SWITCHES = 4
#: Where an unstable state is pushed along its mode: the largest centreline point moves this fraction of L.
MODE_KICK = 0.02


@dataclass(frozen=True)
class Stability:
    """The stability of a settled rod (frozen): :func:`static_stability`.

    Attributes
    ----------
    stable : bool or None
        False when the largest eigenvalue exceeds :data:`UNSTABLE_EIGENVALUE` x ``omega_1^2``; None where it
        was not assessed (a scene with contact).
    eigenvalue : float
        The largest real part of the eigenvalues of ``d qacc / d qpos`` at rest (1/s^2): about ``-omega^2`` of the
        softest mode while stable, ``+sigma^2`` (sigma the growth rate) past a bifurcation.
    scale : float
        ``omega_1^2`` (1/s^2), the first clamped-free bending frequency squared, of the beam's weak axis.
    mode : (nv,) ndarray
        The eigenvector of that eigenvalue (dof space, unit norm; zeros where not assessed).
    message : str
    """

    stable: bool | None
    eigenvalue: float
    scale: float
    mode: np.ndarray = field(repr=False)
    message: str


@dataclass(frozen=True)
class SimEquilibrium:
    """A settled MuJoCo rod (frozen), one shape for every rod.

    The rod has ``N`` cells (``segments``) and ``N + 1`` rigid pieces (the planar chain's links, the strip's
    edges), so its centreline has ``N + 2`` points (the clamp, every hinge or vertex, the tip). Units are SI.

    Attributes
    ----------
    success : bool
        Every settle along the path passed its convergence test.
    message : str
        ``"converged"``, or the settles that failed, separated by ``"; "``.
    field : Field
        Applied field (T), in the components the rod takes.
    s : (N + 2,) ndarray
        Reference arc length of the centerline points (m): clamp, hinges, tip.
    x, y, z : (N + 2,) ndarray
        Centerline (m), base to tip (``y = 0`` for a rod in the x-z plane).
    centreline : (N + 2, 3) ndarray
        The same points as rows (m).
    theta : (N + 1,) ndarray
        Tangent angle of each rigid piece from +x toward +z (rad; 3D: of its x-z projection), base first.
    tip_angle : float
        Tangent angle of the tip piece (rad).
    tip_deflection : float
        z of the tip (m).
    tip_position : (3,) ndarray
        The tip (m).
    tip_twist : float
        ``int k3 ds`` (rad), as the analytical :class:`~magsoft_env.theory.rod_solver.RodResult` measures it (0 for
        a rod that cannot twist).
    residual : float
        Final static residual (:meth:`Simulator.static_residual`: rad, or a fraction of L for a slide).
    steps : int
        Simulation steps spent settling along the whole path so far (dimensionless count).
    edge_strain : float
        Largest relative change of a piece's length (0 to round-off for rigid links).
    stable : bool or None
        Whether the returned state is stable (:func:`static_stability`); None: not assessed.
    stability : Stability or None
        The assessment (None when ``stability=False`` was asked).
    rod : str
        The rod (``RodOptions.rod``).
    field_axes : tuple of int
        The components of ``(B_x, B_y, B_z)`` the rod takes (``(0, 2)``: ``field_T`` is ``(B_x, B_z)``).
    source : field source or None
        The non-uniform source of this load (its uniform parts are in ``field``), or None.
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
    y: np.ndarray | None = None
    centreline: np.ndarray | None = None
    tip_position: np.ndarray | None = None
    tip_twist: float = 0.0
    edge_strain: float = 0.0
    stable: bool | None = None
    stability: Stability | None = field(default=None, repr=False)
    rod: str = "planar"
    field_axes: tuple = (0, 2)
    source: object = field(default=None, repr=False)

    def to_dict(self) -> dict:
        """Metrics as plain numbers (SI and degrees), for JSON."""
        out = {
            "success": bool(self.success),
            "message": self.message,
            "rod": self.rod,
            "field_T": [float(v) for v in self.field.vector()[list(self.field_axes)]],
            "segments": len(self.theta) - 1,
            "tip_deflection_m": float(self.tip_deflection),
            "v_over_L": float(self.tip_deflection) / float(self.s[-1]),
            "tip_angle_rad": float(self.tip_angle),
            "tip_angle_deg": math.degrees(self.tip_angle),
            "tip_x_m": float(self.x[-1]),
            "tip_z_m": float(self.z[-1]),
            "tip_position_m": [float(v) for v in self.tip_position],
            "tip_twist_rad": float(self.tip_twist),
            "residual_rad": float(self.residual),
            "edge_strain": float(self.edge_strain),
            "steps": int(self.steps),
            "stable": self.stable,
            "source": None if self.source is None else type(self.source).__name__,
        }
        if self.stability is not None:
            out["stability_eigenvalue_per_s2"] = float(self.stability.eigenvalue)
            out["stability_message"] = self.stability.message
        return out


def _omega1_sq(beam: Beam) -> float:
    """``omega_1^2`` (1/s^2): the first clamped-free bending frequency of the weak axis, squared, at mid-length."""
    s = 0.5 * beam.length
    ei = float(beam.stiffnesses(np.array([s]))[0][0])
    mu = float(beam.mass_per_length(s))
    return (1.8751040687**2 / beam.length**2) ** 2 * ei / mu


def _accelerations(sim: Simulator, qpos: np.ndarray, scratch: np.ndarray) -> np.ndarray:
    """``qacc`` at rest at ``qpos`` with the held field's couples of that state (the state's reference frames, kept
    in ``scratch``, restored first)."""
    m, d = sim.model, sim.data
    d.plastic[:] = scratch
    d.qpos[:] = qpos
    d.qvel[:] = 0.0
    sim.backend.write_field(d, sim._B3)
    mujoco.mj_forward(m, d)
    return d.qacc.copy()


def static_stability(sim: Simulator, *, rel_step: float = 1e-6) -> Stability:
    """Whether the state in ``sim`` (settled, clamped, no contact) is a stable equilibrium under its held field.

    The stiffness of the constrained system: ``J = d qacc / d qpos`` at rest, by central differences of MuJoCo's
    own accelerations (every force it applies: elasticity, gravity, the edge constraints, the magnetic couples of
    each perturbed state, written by the rod's backend; explicit accelerations ``M^-1 F``, whatever the model's
    integrator), one dof at a time, ``rel_step`` rad (a hinge) or ``rel_step`` L (a slide). At a stable equilibrium
    every eigenvalue of ``J`` is ``-omega^2 < 0``; past a bifurcation one is ``+sigma^2``. The state is restored
    exactly.
    """
    if sim.options.has_contact:
        return Stability(None, math.nan, math.nan, np.zeros(sim.model.nv),
                         "not assessed: a scene with contact (the contact forces have no derivative there)")
    m, d = sim.model, sim.data
    spec = int(mujoco.mjtState.mjSTATE_FULLPHYSICS)
    state = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, state, spec)
    warm = d.qacc_warmstart.copy()
    plastic = d.plastic.copy()
    q0 = d.qpos.copy()
    nv = m.nv
    L = sim.beam.length
    hinge = np.array([m.jnt_type[m.dof_jntid[j]] in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_BALL)
                      for j in range(nv)])
    eps = np.where(hinge, rel_step, rel_step * L)
    J = np.empty((nv, nv))
    dq = np.zeros(nv)
    qp, qm = np.empty(m.nq), np.empty(m.nq)
    # the explicit accelerations M^-1 F: the discrete (and implicit) integrators fold part of the stiffness into
    # their qacc, which then is no derivative of a force
    integrator = m.opt.integrator
    m.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    try:
        for j in range(nv):
            dq[:] = 0.0
            dq[j] = 1.0
            qp[:] = q0
            mujoco.mj_integratePos(m, qp, dq, eps[j])
            qm[:] = q0
            mujoco.mj_integratePos(m, qm, dq, -eps[j])
            J[:, j] = (_accelerations(sim, qp, plastic) - _accelerations(sim, qm, plastic)) / (2.0 * eps[j])
    finally:
        m.opt.integrator = integrator
        mujoco.mj_setState(m, d, state, spec)
        d.qacc_warmstart[:] = warm
        d.plastic[:] = plastic
        sim.backend.write_field(d, sim._B3)
        mujoco.mj_forward(m, d)
        sim._stale = False
    # eigenvalues in a scale-free basis: slides in units of L (J's units are 1/s^2 either way)
    S = np.where(hinge, 1.0, L)
    w, v = np.linalg.eig(J * (S[None, :] / S[:, None]))
    i = int(np.argmax(w.real))
    lam = float(w.real[i])
    mode = np.real(v[:, i]) * S
    nrm = float(np.linalg.norm(mode))
    mode = mode / nrm if nrm > 0 else mode
    scale = _omega1_sq(sim.beam)
    stable = lam <= UNSTABLE_EIGENVALUE * scale
    msg = (f"stable: largest eigenvalue of d qacc / d qpos {lam:.4g} 1/s^2 ({lam / scale:.3g} omega_1^2)" if stable
           else f"unstable: an eigenvalue of d qacc / d qpos is {lam:.4g} 1/s^2 = {lam / scale:.3g} omega_1^2 > 0 "
                f"(growth time {1.0 / math.sqrt(lam):.3g} s): a bifurcation has been passed")
    return Stability(bool(stable), lam, scale, mode, msg)


def _leave_along(sim: Simulator, mode: np.ndarray, branch: int) -> None:
    """Push the state along ``mode`` so that the centreline moves :data:`MODE_KICK` L at most, to the side ``branch``
    chooses: +1, the side where the point that moves most moves toward the positive direction of the axis it moves
    most along (e.g. the tip upward); -1 the mirror side."""
    m, d = sim.model, sim.data
    c0 = sim.pose().centreline
    q0 = d.qpos.copy()
    probe = 1e-6
    mujoco.mj_integratePos(m, d.qpos, mode, probe)
    sim.set_state()
    dc = (sim.pose().centreline - c0) / probe
    i, a = np.unravel_index(int(np.argmax(np.abs(dc))), dc.shape)
    sign = branch * (1.0 if dc[i, a] >= 0.0 else -1.0)
    amp = MODE_KICK * sim.beam.length / max(float(np.abs(dc).max()), 1e-300)
    d.qpos[:] = q0
    mujoco.mj_integratePos(m, d.qpos, mode, sign * amp)
    d.qvel[:] = 0.0
    sim.set_state()


def _snapshot(sim: Simulator, rod: str, ok: bool, msg: str, res: float, steps: int,
              stab: Stability | None, source=None) -> SimEquilibrium:
    p = sim.pose()
    c = p.centreline
    s = sim.arc_length()
    strain = float(np.max(np.abs(np.linalg.norm(np.diff(c, axis=0), axis=1) / np.diff(s) - 1.0)))
    return SimEquilibrium(
        success=ok, message=msg, field=sim.field, s=s, x=c[:, 0].copy(), y=c[:, 1].copy(), z=c[:, 2].copy(),
        centreline=c.copy(), theta=sim.angles(), tip_angle=sim.tip_angle(), tip_deflection=float(c[-1, 2]),
        tip_position=c[-1].copy(), tip_twist=sim.tip_twist(), residual=res, steps=steps, edge_strain=strain,
        stable=None if stab is None else stab.stable, stability=stab, rod=rod,
        field_axes=tuple(sim.backend.field_axes), source=source,
    )


def _between(prev, nxt, a: float):
    """The source ``(1 - a) prev + a nxt`` (either may be None: none); ``nxt`` itself at ``a = 1``."""
    if a == 1.0:
        return nxt
    return Blend([(w, s) for w, s in ((1.0 - a, prev), (a, nxt)) if s is not None])


def _loads(fields, cls, beam: Beam, clamp_angle: float) -> list[tuple[np.ndarray, object, float]]:
    """The loads of a path as ``(uniform (3,) T, rest source or None, largest field of the rest (T) along the
    straight clamped beam)``: every entry a field (Field, pair, triple) or a field source."""
    if isinstance(fields, np.ndarray) or isinstance(fields, Field) or hasattr(fields, "field_and_gradient"):
        if hasattr(fields, "field_and_gradient"):
            raise ValueError("fields must be a sequence of loads (fields or field sources), got a single "
                             f"{type(fields).__name__}; wrap it in a list (or call mujoco_equilibrium).")
        entries = as_fields(fields)
    else:
        try:
            entries = list(fields)
        except TypeError:
            entries = as_fields(fields)  # its error
        if not entries or isinstance(fields, (str, bytes, dict)):
            entries = as_fields(fields)  # its error
    # where the loads are measured: the straight beam from the clamp (RodOptions checks the angle)
    a = float(clamp_angle) if isinstance(clamp_angle, (int, float, np.floating)) and math.isfinite(clamp_angle) else 0.0
    pts = np.outer(np.linspace(0.0, beam.length, 41), [math.cos(a), 0.0, math.sin(a)])
    out = []
    for i, e in enumerate(entries):
        if hasattr(e, "field_and_gradient"):
            uni, rest = split_source(check_source(e, f"fields[{i}]"))
            uni = np.zeros(3) if uni is None else uni
            cls.check_field(Field(*uni))
            big = 0.0
            if rest is not None:
                sf = SourceField(rest)
                if sf.moves:
                    raise ValueError(f"fields[{i}]: a static path needs a source fixed in time, got a "
                                     f"{type(rest).__name__} whose field changes with t (use its pose at one time, "
                                     "e.g. MovingSource.at(t)).")
                big = field_bound(sf(pts, 0.0)[0])
            out.append((uni, rest, big))
        else:
            f = as_field(e, f"fields[{i}]")
            cls.check_field(f)
            out.append((f.vector(), None, 0.0))
    return out


def mujoco_path(
    beam: Beam,
    fields,
    *,
    rod: str = "planar",
    gravity: float = 9.81,
    segments: int = 20,
    clamp_angle: float = 0.0,
    max_field_step: float = 1e-3,
    timestep: float | None = None,
    integrator: str = "discrete",
    tol: float | None = None,
    max_time: float = 20.0,
    grading: float | None = None,
    retardation_time: float = 5e-3,
    imperfection: float = 0.0,
    stability: bool = True,
    branch: int = 1,
    rod_options: dict | None = None,
) -> list[SimEquilibrium]:
    """Settle the clamped MuJoCo rod along a loading path: gravity first, then each field in turn.

    Between consecutive fields (starting from zero field) the field moves in straight-line
    sub-steps no larger than ``max_field_step`` (T), each settled (damped dynamics, see
    :meth:`Simulator.settle`); one result is returned per entry of ``fields``. Each returned state is then
    tested for stability (:func:`static_stability`); an unstable one is left along its unstable mode to the
    side ``branch`` names and settled again (at most :data:`MAX_BRANCH_SWITCHES` times), so that past a
    bifurcation the stable branch is returned, and the path goes on from it.

    Parameters
    ----------
    beam : Beam
    fields : sequence of loads: Field, (B_x, B_y, B_z), (B_x, B_z) or a field source
        Loads in loading order: uniform fields (T; a pair means ``(B_x, B_z)``; a rod in the x-z plane refuses
        ``B_y``) or field sources (:mod:`magsoft_env.fields`, fixed in time: a :class:`~magsoft_env.fields.Uniform`
        is its field, bit for bit; any other is applied as :meth:`Simulator.set_source` says, couples and gradient
        forces on every piece). Between two loads the field moves on a straight line: the uniform parts
        interpolated, the sources weighed ``(1 - a) S_prev + a S_next``
        (:class:`~magsoft_env.sim.sources.Blend`), in sub-steps that change neither the uniform field nor the
        sources' field along the straight beam by more than ``max_field_step``.
    rod : str
        The rod (``RodOptions.rod``): ``"planar"`` (the hinge chain, default) or ``"cable"`` (the 3D strip).
    gravity : float
        m/s^2 along -z, in [0, 1000].
    segments : int
        Number of cells N.
    clamp_angle : float
        Clamp angle (rad) from +x toward +z (the strip: 0).
    max_field_step : float
        Largest field change (T) between settles, > 0.
    timestep : float or None
        Step (s) used while settling; None: the rod's own (the chain 10 ms, with the ``discrete`` integrator
        stable there; the strip 1 ms, its edge constraint follows the step).
    integrator : str
        MuJoCo integrator (see :class:`RodOptions`).
    tol : float or None
        Static-residual tolerance (rad, or a fraction of L for a slide), > 0; None: the rod's own (chain 1e-8,
        strip 1e-6).
    max_time : float
        Simulated-time budget per settle (s), > 0.
    grading : float or None
        Last / first cell length (see :class:`RodOptions`); 1 gives equal cells; ``None``:
        the cantilever default (1.5, finer at the clamp).
    retardation_time : float
        The rod's own damping (s, see :class:`RodOptions`); the settles damp it further.
    imperfection : float
        A field along z (T) added to every settle of a ramp but the last one of each field, a seed for branches
        that leave a symmetric state (0: none; the stability test finds them without one).
    stability : bool
        Test every returned state (about ``2 nv`` MuJoCo evaluations) and leave unstable ones.
    branch : {1, -1}
        Which side of a bifurcation an unstable state leaves to (see :func:`_leave_along`).
    rod_options : dict or None
        More :class:`RodOptions` keywords for the rod (e.g. ``{"magnetics": "python"}``, solver settings); the
        ones above win.

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
    cls = rod_class(rod)
    cls.check_beam(beam)
    loads = _loads(fields, cls, beam, clamp_angle)
    nonnegative("gravity", gravity, unit="m/s^2")
    mstep = positive("max_field_step", max_field_step, unit="T")
    tol = cls.static_tol if tol is None else tol
    tol = positive("tol", tol, unit="rad")
    max_time = positive("max_time", max_time, unit="s")
    timestep = cls.static_timestep if timestep is None else positive("timestep", timestep, unit="s")
    imperfection = finite_number("imperfection", imperfection, unit="T")
    if isinstance(stability, (bool, np.bool_)) is False:
        raise ValueError(f"stability must be a bool, got {stability!r}.")
    if branch not in (1, -1) or isinstance(branch, (bool, np.bool_)):
        raise ValueError(f"branch must be +1 or -1 (which side of a bifurcation), got {branch!r}.")
    opts = RodOptions(**{
        **(rod_options or {}), "rod": rod, "segments": segments, "scene": "cantilever", "integrator": integrator,
        "timestep": timestep, "gravity": gravity, "clamp_angle": clamp_angle, "grading": grading,
        "retardation_time": retardation_time,
    })
    # the worst-case work, before any: every settle may use its whole budget
    budget = math.ceil(check_steps(f"max_time / timestep = {max_time:g} s / {opts.timestep:g} s per settle",
                                   max_time / opts.timestep, "Use a larger timestep or a shorter max_time."))
    prev, prev_big = np.zeros(3), 0.0
    substeps = []
    seed = np.array([0.0, 0.0, imperfection])
    for target, rest, big in loads:
        f = Field(*target)
        change = max(float(np.max(np.abs(target - prev))), big + prev_big)  # a bound of the sources' change
        n = max(1, math.ceil(change / mstep)) + (1 if imperfection else 0)
        extra = MAX_BRANCH_SWITCHES if stability else 0
        if (n + extra) * budget > MAX_STEPS:
            need = change * budget / MAX_STEPS
            check_steps(
                f"the path segment to {_mt(f, cls.field_axes)}: {n + extra:.3g} settles (max_field_step = "
                f"{mstep:g} T) x up to {budget} steps each", float(n + extra) * budget,
                f"Use max_field_step >= {need:.3g} T, or fewer steps per settle (larger timestep, shorter max_time).",
            )
        substeps.append(n)
        prev, prev_big = target, big
    sim = Simulator(beam, opts)
    steps = 0
    r: SettleResult = sim.settle(tol=tol, max_time=max_time)
    steps += r.steps
    ok, msgs = r.success, [] if r.success else [f"gravity: {r.message}"]
    out = []
    prev, prev_src = np.zeros(3), None
    for (target, rest, _), n in zip(loads, substeps, strict=True):
        ramp = n - 1 if imperfection else n
        for k in range(1, n + 1):
            b = prev + (target - prev) * min(k, ramp) / ramp
            if rest is not None or prev_src is not None:
                sim.set_source(_between(prev_src, rest, min(k, ramp) / ramp))
            sim.set_field(tuple(b + seed) if imperfection and k < n else tuple(b))
            r = sim.settle(tol=tol, max_time=max_time)
            steps += r.steps
            if not r.success:
                ok = False
                msgs.append(f"field {_mt(sim.field, cls.field_axes)}: {r.message}")
        prev, prev_src = target, rest
        stab = static_stability(sim) if stability else None
        switches = 0
        while stab is not None and stab.stable is False and switches < MAX_BRANCH_SWITCHES:
            _leave_along(sim, stab.mode, branch)
            r = sim.settle(tol=tol, max_time=max_time)
            steps += r.steps
            switches += 1
            if not r.success:
                ok = False
                msgs.append(f"field {_mt(sim.field, cls.field_axes)}, leaving an unstable state: {r.message}")
            stab = static_stability(sim)
        if stab is not None and switches:
            stab = Stability(stab.stable, stab.eigenvalue, stab.scale, stab.mode,
                             f"{stab.message} (reached after leaving {switches} unstable state"
                             f"{'s' if switches > 1 else ''} along the unstable mode, branch {branch:+d})")
        out.append(_snapshot(sim, rod, ok, "; ".join(msgs) if msgs else "converged", r.residual, steps, stab,
                             rest))
    return out


def _mt(f: Field, axes) -> str:
    """A field in the components a rod takes, in mT."""
    return "(" + ", ".join(f"{b * 1e3:.4g}" for b in f.vector()[list(axes)]) + ") mT"


def mujoco_equilibrium(beam: Beam, field, **kwargs) -> SimEquilibrium:
    """Static equilibrium of the clamped MuJoCo rod under ``field``: a uniform field (T) or a field source
    (:mod:`magsoft_env.fields`, fixed in time; ``Uniform(B)`` is ``B`` bit for bit), reached like the
    analytical solver: gravity first, then the field ramped from zero in straight-line steps
    of at most ``max_field_step`` (T), each settled, then tested for stability (an unstable state
    leaves along its unstable mode to the stable branch). See :func:`mujoco_path` for the keywords
    (``rod="cable"``: the 3D strip, for fields ``(B_x, B_y, B_z)`` and any magnetization direction).

    Returns
    -------
    SimEquilibrium
        ``x``, ``y``, ``z`` and ``centreline`` (m, base to tip), ``tip_position``, ``tip_angle`` (rad),
        ``tip_twist`` (rad), ``success``, ``stable``.

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> beam = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> eq = mujoco_equilibrium(beam, (0.0, 0.013))
    >>> bool(eq.success), bool(eq.stable), round(eq.tip_angle, 2)
    (True, True, 1.57)
    """
    return mujoco_path(beam, [field if hasattr(field, "field_and_gradient") else as_field(field)], **kwargs)[0]


__all__ = ["MAX_BRANCH_SWITCHES", "MODE_KICK", "UNSTABLE_EIGENVALUE", "SimEquilibrium", "Stability",
           "mujoco_equilibrium", "mujoco_path", "static_stability"]

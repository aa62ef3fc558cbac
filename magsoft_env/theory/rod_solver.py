"""Equilibria of the 3D Kirchhoff rod along a loading path: collocation, Newton, continuation, branch switching.

The rotation field is solved on the planar solver's multi-domain Chebyshev grid
(:mod:`magsoft_env.theory.collocation`) with the integral form of the kinematics
(:meth:`magsoft_env.theory.rod.RodModel.system`), by Newton on spatial rotations at the nodes
with an exact Jacobian. Quaternions carry the frames: no singular angles, and every quantity is a
polynomial in them. Along a path, natural-parameter continuation with a tangent predictor and
adaptive steps follows the branch; every accepted step is tested for stability (the second
variation in the rotation field, :meth:`RodModel.hessian`); when it turns unstable, the crossing
is located by a secant on the smallest eigenvalue (a bifurcation, such as lateral-torsional
buckling, or a fold) and the solver leaves along the lowest mode by energy descent to a stable
branch. Every result is refined until resolved and verified between the nodes by
:func:`magsoft_env.theory.verify.rod_residual`.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from dataclasses import field as dc_field
from functools import cached_property, lru_cache

import numpy as np
import scipy.linalg

from ..spec import Beam, Field
from ..threads import single_threaded_blas
from .collocation import Grid, make_grid
from .options import MAX_ROD_NODES, SolverOptions, check_problem, subdomain_edges
from .result import PathResult
from .rod import Load3, RodModel, angle_between, clamp_quaternion, qmat, rotate
from .verify import outcome, rod_residual

_MAX_NEWTON = 12
_MAX_STEP_RAD = 0.6  # Newton updates larger than this (rad, max over nodes) are damped
_STEP_RAD = 0.5  # largest predicted change of the frames in one continuation step (rad)
_JUMP_RAD = 0.2  # a converged step this far from its prediction counts as a branch jump
_NEUTRAL = 1e-9  # eigenvalues (units E I_w / L^2) above -this count as stable (neutral rigid rotations)
_SHRINK = 0.25
_KICK_RAD = 0.05  # size of the push along the unstable mode when leaving a branch (rad)
_PAST = 0.05  # a branch is left this fraction of the step past its located crossing
#: Largest trailing Chebyshev coefficient of the frames during continuation: beyond it the grid is refined
#: before the step's stability is judged (an under-resolved shape can show a spurious negative eigenvalue).
_CONT_TAIL = 1e-5
MAX_STEPS = 2000
MAX_JUMPS = 20
MAX_DESCENT = 300
MAX_REFINEMENTS = 8
VERIFY_MARGIN = 0.1
#: Work of a load step is counted in dense solves of a grid of this many nodes: each Newton iteration,
#: stability test or energy-descent iteration on a grid of M nodes counts (M / WORK_NODES)^3 times its
#: weight below (the dense Jacobian and second variation are 3 M x 3 M; factorizing them is O(M^3)).
WORK_NODES = 100
_W_NEWTON = 1.0  # a Jacobian and one solve
_W_STABLE = 2.0  # the second variation and a Cholesky factorization
_W_EIGEN = 3.0  # the second variation and its lowest eigenpair (a stability eigenvalue, a descent iteration)


#: The status of a result whose load step (or an earlier one on its path) used up ``max_step_work``.
OVER_BUDGET = 5


class _OverBudget(Exception):
    """A load step passed ``SolverOptions.max_step_work``; caught where the step began."""


@dataclass(frozen=True, kw_only=True)
class RodResult(PathResult):
    """Equilibrium of a strip in three dimensions under one field (frozen), the 3D member of the
    :class:`~magsoft_env.theory.solver.EquilibriumResult` family: the same status fields and the
    same :meth:`sample`, with the shape as a centreline and a material frame.

    Arrays hold one value per distinct collocation node, ``n = nodes`` of them, from the clamp
    (or left end) to the tip; :meth:`sample` and :meth:`at` interpolate spectrally. SI units.
    Frame: x along the undeformed strip, y across its width, z up; the material frame is (d1
    across the width, d2 through the thickness, d3 the tangent), ``(y, z, x)`` at an undeformed
    clamp.

    Attributes
    ----------
    success, status, message
        As in the planar result (0 converged; 1 continuation stalled; 2 under-resolved;
        3 direct solve failed; 4 not verified), plus 5: a load step used up its work budget
        (``SolverOptions.max_step_work``; the message says where and what to change).
    s : (n,) ndarray
        Reference arc length of the nodes (m).
    centreline : (n, 3) ndarray
        Deformed centreline r(s) (m), the clamp (or left end) at the origin.
    frames : (n, 3, 3) ndarray
        Rotation matrices [d1 d2 d3] (columns) of the cross-sections, body to world.
    curvature : (n, 3) ndarray
        Material curvature (k1, k2, k3) (1/m): bending about d1 (the weak axis of a flat strip),
        about d2, and the twist rate about the tangent.
    twist : (n,) ndarray
        Twist accumulated from s = 0, int_0^s k3 (rad): the rotation of the cross-section about
        the tangent relative to a frame carried along the centreline without twisting.
    tip_position : (3,) ndarray
        r(L) (m).
    tip_tangent : (3,) ndarray
        d3(L), a unit vector.
    tip_twist : float
        twist(L) (rad).
    tip_deflection : float
        z(L) (m), as in the planar result.
    max_curvature : float
        Largest bending curvature sqrt(k1^2 + k2^2) over the nodes (1/m).
    energy : float
        Total potential energy (J): elastic, magnetic and gravitational, relative to the straight
        unloaded strip (magnetic and gravitational energy measured from the clamp frame's).
    stable : bool
        Smallest eigenvalue of the discrete second variation (rotations in 3D) is positive.
    snap_through : bool
        A fold or a bifurcation was passed on the way to this field and the solver left the
        branch along the lowest mode to a stable one (lateral-torsional buckling is reported so).
    field : Field
        The applied field (T), three components.
    gravity, residual, resolution, verification, nodes, newton_iterations, wall_time, events
        As in the planar result; ``residual`` and ``verification`` are angles (rad) of the frame
        field, ``events`` list the folds and bifurcations passed so far along the path, each
        ``{"kind", "load_fraction", "field_T" (3), "gravity", "converged"}`` with ``load_fraction``
        the fraction of the load step (from the previous field) where the solver left the branch;
        for a bifurcation located on the branch, ``"critical_field_T"`` and ``"critical_fraction"``
        give the crossing found by a secant on the smallest eigenvalue.
    min_eigenvalue : float
        (property) Smallest eigenvalue of the second variation, in units E I_w / L^2.
    """

    centreline: np.ndarray
    frames: np.ndarray
    curvature: np.ndarray
    twist: np.ndarray
    tip_position: np.ndarray
    tip_tangent: np.ndarray
    tip_twist: float
    energy: float
    _grid: Grid | None = dc_field(default=None, repr=False, compare=False)
    _state: tuple | None = dc_field(default=None, repr=False, compare=False)

    @property
    def x(self) -> np.ndarray:
        return self.centreline[:, 0]

    @property
    def y(self) -> np.ndarray:
        return self.centreline[:, 1]

    @property
    def z(self) -> np.ndarray:
        return self.centreline[:, 2]

    @cached_property
    def min_eigenvalue(self) -> float:
        """Smallest eigenvalue of the discrete second variation (units E I_w / L^2)."""
        mdl, q, load = self._state
        return mdl.min_eigen(q, load)[0]

    def sample(self, n: int = 101):
        """Shape at ``n`` evenly spaced arc lengths: (s (n,), centreline (n, 3), frames (n, 3, 3))."""
        s_new = self._samples(n)
        return (s_new, *self.at(s_new))

    def at(self, s):
        """Centreline (…, 3) (m) and frames (…, 3, 3) at reference arc lengths ``s`` (m), interpolated."""
        s = self._arc(s)
        mdl, q, _ = self._state
        r = mdl.centreline(q)
        vals = self._grid.interpolate(np.column_stack([q, r]), s.ravel())
        qq = vals[:, :4] / np.linalg.norm(vals[:, :4], axis=1, keepdims=True)
        return vals[:, 4:].reshape(s.shape + (3,)), qmat(qq).reshape(s.shape + (3, 3))

    def to_dict(self) -> dict:
        """Metrics as plain numbers (SI and degrees), for JSON."""
        L = self.length
        return {
            **self._status_dict(),
            "field_T": [float(v) for v in self.field.vector()],
            "tip_position_m": [float(v) for v in self.tip_position],
            "tip_position_over_L": [float(v) / L for v in self.tip_position],
            "tip_tangent": [float(v) for v in self.tip_tangent],
            "tip_twist_rad": self.tip_twist,
            "tip_twist_deg": math.degrees(self.tip_twist),
            "energy_J": self.energy,
            "min_eigenvalue": self.min_eigenvalue,
            "events": [dict(e) for e in self.events],
        }


@lru_cache(maxsize=32)
def _rod_model_cached(beam, grid, free, clamp_angle):
    return RodModel(beam, grid, free=free, clamp_angle=clamp_angle)


def _rod_model(beam, grid, free, clamp_angle):
    try:
        return _rod_model_cached(beam, grid, free, clamp_angle)
    except TypeError:  # unhashable user callables
        return RodModel(beam, grid, free=free, clamp_angle=clamp_angle)


def _regrid(grid: Grid, n: int) -> Grid:
    from .collocation import _grid_cached

    return _grid_cached(tuple(float(e) for e in grid.edges), n)


class RodSolver:
    """Continuation state for one beam in 3D: the grid, the model and the frame field."""

    def __init__(self, beam: Beam, *, support: str, clamp_angle: float, options, edges: tuple):
        self.beam, self.support, self.clamp_angle, self.opt = beam, support, clamp_angle, options
        self.free = support == "free"
        grid0 = make_grid(beam.length, edges, n=8, max_domain=options.max_domain * beam.length)
        d = len(grid0.edges) - 1
        if options.nodes is not None:
            n = options.nodes
        else:
            n = min(24 if d == 1 else 16, MAX_ROD_NODES // d - 1)
        self._set_grid(make_grid(beam.length, edges, n=n, max_domain=options.max_domain * beam.length))
        self.q = np.tile(clamp_quaternion(clamp_angle if not self.free else 0.0), (self.grid.M, 1))
        self.load = Load3(0.0, 0.0, 0.0, 0.0)
        self.newton_its = 0
        self.events: list[dict] = []
        self.note = ""
        self._J = None  # (q, model, J) of the last Newton step
        self._stable = (None, False)
        self.work = 0.0  # work of the current load step (see WORK_NODES)
        self._work_limit = math.inf  # SolverOptions.max_step_work inside a load step
        self.over_budget = False
        self._accepted = None  # (grid, q, load fraction) of the last accepted point of the load step

    def _spend(self, weight: float) -> None:
        """Count ``weight`` dense solves on the current grid (scaled to WORK_NODES); past the budget, end the step."""
        self.work += weight * (self.grid.M / WORK_NODES) ** 3
        if self.work > self._work_limit:
            raise _OverBudget

    def _budgeted(self, step, start: Load3, target: Load3) -> bool:
        """Run ``step()`` (one load step, from ``start`` toward ``target``) within ``options.max_step_work``; past
        it, go back to the step's last accepted equilibrium and say which limit was hit and what to change."""
        self.work, self._work_limit = 0.0, self.opt.max_step_work
        self._accepted = (self.grid, self.q, 0.0)
        t0 = time.perf_counter()
        try:
            return step()
        except _OverBudget:
            grid, q, t = self._accepted
            self._set_grid(grid)
            self.q, self.load = q, start.lerp(target, t)
            self.over_budget = True
            self.note = (
                f"It reached max_step_work = {self.opt.max_step_work:g} (dense solves counted as on a "
                f"{WORK_NODES}-node grid; {time.perf_counter() - t0:.1f} s here) at {100 * t:.3g} % of the step, on "
                f"{int(self.model.uniq.size)} nodes. Ramp the field in smaller steps (solve_path with ms.ramp: each "
                "field gets its own budget), give fewer magnetization cells or a larger max_domain (fewer nodes), "
                "or raise max_step_work (math.inf: no bound)."
            )
            return False
        finally:
            self._work_limit = math.inf

    def _set_grid(self, grid: Grid):
        self.grid = grid
        self.model = _rod_model(self.beam, grid, self.free, self.clamp_angle)

    # Newton ---------------------------------------------------------------------------------
    def _solve(self, J, F):
        if self.free:  # the rotation about the field is neutral: least squares, minimum norm
            x, *_ = scipy.linalg.lstsq(J, F, cond=1e-13, check_finite=False)
            return x
        try:
            return scipy.linalg.solve(J, F, check_finite=False)
        except (np.linalg.LinAlgError, ValueError):
            return None

    def newton(self, q, load: Load3, maxiter: int = _MAX_NEWTON):
        """Damped Newton on the collocation equations. Returns (ok, q, iterations)."""
        mdl = self.model
        tol = self.opt.tol
        prev = math.inf
        for it in range(1, maxiter + 1):
            self._spend(_W_NEWTON)
            F, J = mdl.jacobian(q, load)
            if not np.all(np.isfinite(J)) or not np.all(np.isfinite(F)):
                return False, q, it
            x = self._solve(J, F)
            if x is None or not np.all(np.isfinite(x)):
                return False, q, it
            psi = -mdl.psi(x)
            big = float(np.max(np.abs(psi)))
            if it >= 4 and big > 0.25 * prev and maxiter <= _MAX_NEWTON:
                return False, q, it
            if big > _MAX_STEP_RAD:
                psi *= _MAX_STEP_RAD / big
            q = rotate(q, psi)
            if big < tol or (it >= 2 and big**3 < tol * prev**2 and big < 1e-5):
                self._J = (q, mdl, J)
                return True, q, it
            prev = big
        return False, q, maxiter

    # stability ----------------------------------------------------------------------------------
    def stability(self, q, load: Load3):
        """(stable, smallest eigenvalue in E I_w / L^2, mode psi (M, 3))."""
        self._spend(_W_EIGEN)
        lam, mode = self.model.min_eigen(q, load)
        return lam > -_NEUTRAL, lam, mode

    def _is_stable(self, q, load: Load3) -> bool:
        self._spend(_W_STABLE)
        _, H = self.model.hessian(q, load)
        Hs = self.model.scaled(H, load)
        Hs.flat[:: Hs.shape[0] + 1] += _NEUTRAL
        try:
            scipy.linalg.cholesky(Hs, check_finite=False)
            return True
        except (np.linalg.LinAlgError, ValueError):
            return False

    # energy descent ------------------------------------------------------------------------------
    def descend(self, q, load: Load3, kick=None, _refined: int = 0):
        """Minimize the energy from ``q`` (turned by ``kick``, (M, 3) rad) by Newton steps on the
        second variation shifted to be positive, with a line search; then polish with Newton on the
        collocation equations. Returns (ok, q): ok when the polished equilibrium is stable."""
        mdl = self.model
        if kick is not None:
            q = rotate(q, kick)
        U = mdl.energy(q, load)
        tol = 1e-10 * mdl.EI_ref / mdl.L
        for _ in range(MAX_DESCENT):
            self._spend(_W_EIGEN)
            g, H = mdl.hessian(q, load)
            Hs = mdl.scaled(H, load)
            r = 1.0 / np.sqrt(mdl.mass)
            lam, vec = scipy.linalg.eigh(Hs, subset_by_index=[0, 0], check_finite=False)
            lam0 = float(lam[0])
            if float(np.max(np.abs(g * r))) < tol and lam0 > -_NEUTRAL:
                break
            Hs.flat[:: Hs.shape[0] + 1] += max(0.0, -lam0) * 1.5 + 1e-3
            step = -r * scipy.linalg.solve(Hs, r * g * (mdl.L**2 / mdl.EI_ref), assume_a="pos", check_finite=False)
            psi = mdl.E @ step.reshape(-1, 3)
            big = float(np.max(np.abs(psi)))
            if lam0 < -_NEUTRAL and big < 1e-3:
                # near a saddle the gradient has no part along the unstable mode (a symmetric state):
                # go down along the mode itself, the way that lowers the energy more
                mode = mdl.E @ (r * vec[:, 0]).reshape(-1, 3)
                mode *= _KICK_RAD / float(np.max(np.abs(mode)))
                psi = min((mode, -mode), key=lambda p: mdl.energy(rotate(q, p), load))
                big = _KICK_RAD
            if big > _MAX_STEP_RAD:
                psi *= _MAX_STEP_RAD / big
            alpha, moved = 1.0, False
            while alpha > 1e-8:
                qn = rotate(q, alpha * psi)
                Un = mdl.energy(qn, load)
                if Un < U:
                    q, U, moved = qn, Un, True
                    break
                alpha *= 0.5
            if not moved or alpha * big < 1e-13:
                break
        ok, q2, its = self.newton(q, load, maxiter=4 * _MAX_NEWTON)
        self.newton_its += its
        if not ok:
            # the minimizer may not be resolved on this grid: again on finer ones (up to four), from its interpolant
            n = min(self.opt.max_nodes, int(math.ceil(1.5 * self.grid.n)))
            d = len(self.grid.edges) - 1
            if _refined >= 4 or self.opt.nodes is not None or n <= self.grid.n or d * (n + 1) > MAX_ROD_NODES:
                return False, q
            old = self.grid
            self._set_grid(_regrid(old, n))
            fine = old.interpolate(q, self.grid.s)
            fine /= np.linalg.norm(fine, axis=1, keepdims=True)
            ok, q2 = self.descend(fine, load, _refined=_refined + 1)
            if not ok:
                self._set_grid(old)
                return False, q
            return ok, q2
        return self._is_stable(q2, load), q2

    # continuation ----------------------------------------------------------------------------------
    def _tangent(self, q, start: Load3, target: Load3, t: float = 0.0):
        """d psi / d t along the step from ``start`` to ``target`` at the equilibrium ``q`` (load fraction ``t``;
        a uniform load is linear in t, so t is not needed here: a field source's path uses it)."""
        st = self._J
        if st is not None and st[0] is q and st[1] is self.model:
            J = st[2]
        else:
            self._spend(_W_NEWTON)
            _, J = self.model.jacobian(q, start)
        x = self._solve(J, self.model.load_rate(q, target.minus(start)))
        if x is None or not np.all(np.isfinite(x)):
            return np.zeros((self.grid.M, 3))
        return -self.model.psi(x)

    def _locate(self, q_a, t_a, lam_a, q_b, t_b, lam_b, start, target):
        """The load fraction where the smallest eigenvalue crosses zero between two equilibria of one
        branch: a secant (Illinois variant) on the eigenvalue, each point solved by Newton from the
        nearer end of the bracket, until the eigenvalue is below 1e-9 E I_w / L^2, the bracket below
        1e-12 or Newton stops converging (near the crossing the Jacobian is nearly singular); the
        answer is the secant through the last bracket."""
        side = 0
        for _ in range(40):
            if abs(t_b - t_a) < 1e-12 or min(abs(lam_a), abs(lam_b)) < 1e-9:
                break
            t_c = t_b - lam_b * (t_b - t_a) / (lam_b - lam_a)
            if not (min(t_a, t_b) < t_c < max(t_a, t_b)):
                t_c = 0.5 * (t_a + t_b)
            ok, q_c, its = self.newton(q_a if abs(t_c - t_a) < abs(t_c - t_b) else q_b, start.lerp(target, t_c))
            self.newton_its += its
            if not ok:
                break
            lam_c = self.stability(q_c, start.lerp(target, t_c))[1]
            if (lam_c > 0) == (lam_a > 0):
                t_a, lam_a, q_a = t_c, lam_c, q_c
                if side == -1:
                    lam_b *= 0.5
                side = -1
            else:
                t_b, lam_b, q_b = t_c, lam_c, q_c
                if side == 1:
                    lam_a *= 0.5
                side = 1
        if abs(lam_a) <= abs(lam_b) and abs(lam_a) < 1e-9:
            return t_a
        if abs(lam_b) < 1e-9:
            return t_b
        return t_b - lam_b * (t_b - t_a) / (lam_b - lam_a)

    def _leave(self, q, load: Load3, kind: str, t: float, extra: dict):
        """Leave an unstable equilibrium (or the last one before a fold) along its lowest mode to a
        stable one, trying both directions; the lower energy wins."""
        _, _, mode = self.stability(q, load)
        best = None
        for sign in (1.0, -1.0):
            ok, q2 = self.descend(q, load, kick=sign * _KICK_RAD * mode)
            if ok:
                U = self.model.energy(q2, load)
                if best is None or U < best[0] - 1e-12 * abs(U):
                    best = (U, q2)
        ok = best is not None
        self.events.append({"kind": kind, "load_fraction": t, "field_T": [load.Bx, load.By, load.Bz],
                            "gravity": load.g, "converged": ok, **extra})
        return ok, (best[1] if ok else q)

    def continue_to(self, target: Load3) -> bool:
        """Follow the equilibrium from the current load to ``target`` (see the module docstring), within
        ``options.max_step_work``."""
        start = self.load
        return self._budgeted(lambda: self._continue_to(start, target), start, target)

    def _continue_to(self, start: Load3, target: Load3) -> bool:
        q = self.q
        t, dt = 0.0, 1.0
        stable = self._stable[0] is q and self._stable[1]
        if self._stable[0] is not q:
            stable = self._is_stable(q, start)
        steps = jumps = 0
        while t < 1.0:
            self._accepted = (self.grid, q, t)
            steps += 1
            if steps > MAX_STEPS or jumps > MAX_JUMPS:
                self.note = (f"Stopped after {steps - 1} continuation steps and {jumps} jumps in one load step (bounds "
                             f"{MAX_STEPS} and {MAX_JUMPS}) at {100 * t:.3g} % of it.")
                self.q, self.load = q, start.lerp(target, t)
                return False
            tan = self._tangent(q, start, target, t)
            tmax = float(np.max(np.abs(tan)))
            dt = min(dt, 1.0 - t, _STEP_RAD / tmax if tmax > 0 else 1.0)
            if dt < self.opt.min_step:
                dt = self.opt.min_step
            t_new = 1.0 if 1.0 - (t + dt) < 1e-12 else t + dt
            h = t_new - t
            load = start.lerp(target, t_new) if t_new < 1.0 else target
            guess = rotate(q, h * tan)
            ok, q_new, its = self.newton(guess, load)
            self.newton_its += its
            if ok and float(np.max(angle_between(q_new, guess))) > max(_JUMP_RAD, 0.5 * h * tmax):
                ok = False  # converged far from the prediction: likely another branch
            if not ok:
                if dt > self.opt.min_step:
                    dt *= _SHRINK
                    continue
                # a fold: no equilibrium near this one beyond t; snap to a stable one
                jumps += 1
                t_new = min(1.0, t + 4 * self.opt.min_step)
                load = start.lerp(target, t_new) if t_new < 1.0 else target
                ok2, q_new = self._leave(q, load, "fold", t_new, {})
                if not ok2:
                    self.q, self.load = q, start.lerp(target, t)
                    self.note = "Energy descent after a fold found no stable equilibrium."
                    return False
                t, q, stable, dt = t_new, q_new, True, 4 * self.opt.min_step
                continue
            if self._tail(q_new) > _CONT_TAIL and self._finer_grid(q, start.lerp(target, t)):
                q = self.q  # the shape outgrew the grid: the step again, on a finer one (stability needs it)
                continue
            now_stable = self._is_stable(q_new, load)
            if stable and not now_stable:
                jumps += 1
                lam_a = self.stability(q, start.lerp(target, t))[1]
                lam_b = self.stability(q_new, load)[1]
                t_c = self._locate(q, t, lam_a, q_new, t_new, lam_b, start, target)
                lc = start.lerp(target, t_c)
                extra = {"critical_fraction": t_c, "critical_field_T": [lc.Bx, lc.By, lc.Bz]}
                # leave the branch just past the crossing, where the strip does, not at the end of the step
                t_leave = min(t_new, t_c + _PAST * (t_new - t))
                if t_leave < t_new:
                    ld = start.lerp(target, t_leave)
                    ok3, q3, its3 = self.newton(q, ld, maxiter=4 * _MAX_NEWTON)
                    self.newton_its += its3
                    if ok3 and not self._is_stable(q3, ld):
                        t_new, q_new, load = t_leave, q3, ld
                ok2, q_new = self._leave(q_new, load, "bifurcation", t_new, extra)
                if not ok2:
                    self.q, self.load = q, start.lerp(target, t)
                    self.note = "Energy descent after a bifurcation found no stable equilibrium."
                    return False
                now_stable = True
            t, q, stable = t_new, q_new, now_stable
            if its <= 4:
                dt = min(1.0, 2.0 * dt)
        self.q, self.load = q, target
        self._stable = (q, stable)
        return True

    def _tail(self, q) -> float:
        return max(self.grid.tail(q[:, i]) for i in range(4))

    def _finer_grid(self, q, load: Load3) -> bool:
        """Move the state ``q`` (an equilibrium at ``load``) to a grid of 1.5 times the degree, when allowed
        and Newton converges there; returns whether it moved (then ``self.q`` is the new state)."""
        n = min(self.opt.max_nodes, int(math.ceil(1.5 * self.grid.n)))
        d = len(self.grid.edges) - 1
        if self.opt.nodes is not None or n <= self.grid.n or d * (n + 1) > MAX_ROD_NODES:
            return False
        old = self.grid
        self._set_grid(_regrid(old, n))
        guess = old.interpolate(q, self.grid.s)
        guess /= np.linalg.norm(guess, axis=1, keepdims=True)
        ok, q2, its = self.newton(guess, load, maxiter=4 * _MAX_NEWTON)
        self.newton_its += its
        if not ok:
            self._set_grid(old)
            return False
        self.q = q2
        return True

    def relax(self, target: Load3) -> bool:
        """A free beam: each field is reached by energy descent from the previous shape (within
        ``options.max_step_work``)."""
        start = self.load
        return self._budgeted(lambda: self._relax(target), start, target)

    def _relax(self, target: Load3) -> bool:
        ok, q = self.descend(self.q, target)
        if ok:
            lam, mode = self.model.min_eigen(q, target)
            if lam < -_NEUTRAL:
                ok, q = self.descend(q, target, kick=_KICK_RAD * mode)
        if ok:
            self.q, self.load = q, target
            self._stable = (q, True)
        return ok

    # resolution -----------------------------------------------------------------------------------
    def tail(self) -> float:
        return max(self.grid.tail(self.q[:, i]) for i in range(4))

    def verify(self) -> float:
        ld = self.load
        return rod_residual(self.beam, self.grid, self.q, B=ld.B, g=ld.g, support=self.support,
                            q0=clamp_quaternion(self.clamp_angle))

    def refine(self) -> tuple[float, float]:
        """Raise the degree until the frames' Chebyshev tail is below ``resolution_tol`` and the
        verification below ``VERIFY_MARGIN * verify_tol`` (bounded). Returns (tail, verification)."""
        tail, ver = self.tail(), self.verify()
        if self.opt.nodes is not None:
            return tail, ver
        for _ in range(MAX_REFINEMENTS):
            if tail <= self.opt.resolution_tol and ver <= VERIFY_MARGIN * self.opt.verify_tol:
                break
            n = min(self.opt.max_nodes, int(math.ceil(1.5 * self.grid.n)))
            d = len(self.grid.edges) - 1
            if n <= self.grid.n or d * (n + 1) > MAX_ROD_NODES:
                break
            old, q_old = self.grid, self.q
            self._set_grid(_regrid(old, n))
            guess = old.interpolate(q_old, self.grid.s)
            guess /= np.linalg.norm(guess, axis=1, keepdims=True)
            ok, q, its = self.newton(guess, self.load, maxiter=4 * _MAX_NEWTON)
            self.newton_its += its
            if not ok:
                self._set_grid(old)
                self.q = q_old
                break
            self.q = q
            tail, ver = self.tail(), self.verify()
        return tail, ver

    # result ----------------------------------------------------------------------------------------
    def result(self, ok, status, snapped, field_, gravity, tail, ver, messages, wall_time=0.0) -> RodResult:
        mdl, grid, q, load = self.model, self.grid, self.q, self.load
        status, msg = outcome(ok, status, tail, ver, self.opt, note=self.note, events=len(self.events),
                              nodes=int(mdl.uniq.size), messages=messages)
        u = mdl.uniq
        F = mdl.system(q, load)
        R = qmat(q)
        r = mdl.centreline(q)
        k = mdl.curvature(q)
        tw = grid.Q0 @ k[:, 2]
        stable = (self._stable[0] is q and self._stable[1]) or self._is_stable(q, load)
        return RodResult(
            success=bool(ok and status in (0, 2)),
            status=int(status),
            message=msg,
            s=grid.s[u],
            centreline=r[u],
            frames=R[u],
            curvature=k[u],
            twist=tw[u],
            tip_position=r[-1].copy(),
            tip_tangent=R[-1, :, 2].copy(),
            tip_twist=float(tw[-1]),
            tip_deflection=float(r[-1, 2]),
            max_curvature=float(np.max(np.hypot(k[:, 0], k[:, 1]))),
            energy=mdl.energy(q, load) - mdl.energy(np.tile(mdl.q0, (grid.M, 1)), load._replace(Bx=0.0, By=0.0,
                                                                                                   Bz=0.0, g=0.0)),
            stable=bool(stable),
            snap_through=bool(snapped),
            field=field_,
            gravity=float(gravity),
            residual=float(np.max(np.abs(F))),
            resolution=max(tail, ver) if ok else math.nan,
            nodes=int(u.size),
            newton_iterations=self.newton_its,
            wall_time=float(wall_time),
            events=list(self.events),
            verification=float(ver) if ok else math.nan,
            _grid=grid,
            _state=(mdl, q.copy(), load),
        )


def solve_rod_path(beam, fields, g, support, th0, options, edges, messages, progress=False) -> list[RodResult]:
    """Equilibria of the 3D rod along ``fields`` (Field objects), gravity first (see solve_path)."""
    t_prev = time.perf_counter()
    solver = RodSolver(beam, support=support, clamp_angle=th0, options=options, edges=edges)
    out: list[RodResult] = []
    ok = True
    if g > 0 and support == "cantilever":
        ok = solver.continue_to(Load3(0.0, 0.0, 0.0, g))
    iterator = fields
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(fields, desc="equilibria (3D)", unit="field")
    for fld in iterator:
        if ok:
            n_events = len(solver.events)
            Bx, By, Bz = (float(v) for v in fld.vector())
            target = Load3(Bx, By, Bz, g)
            ok = solver.continue_to(target) if support == "cantilever" else solver.relax(target)
            snapped = len(solver.events) > n_events
            tail, ver = solver.refine() if ok else (math.nan, math.nan)
        else:
            snapped, tail, ver = False, math.nan, math.nan
        now = time.perf_counter()
        status = OVER_BUDGET if solver.over_budget else 0
        out.append(solver.result(ok, status, snapped, fld, g, tail, ver, messages, wall_time=now - t_prev))
        t_prev = now
    return out


@dataclass(frozen=True)
class CriticalField:
    """Where a strip loses stability along a ramp of the field from zero, located on three grids.

    Attributes
    ----------
    field : Field
        The field at the crossing on the finest grid (T).
    magnitude : float
        |B| there (T).
    fraction : float
        Its fraction of the ramp's end field.
    error : float
        Discretization error of ``magnitude`` (T): its change between the two finest grids (the
        solution converges spectrally, so this bounds the coarser value's error and overstates the
        finer's).
    kind : str
        ``"bifurcation"`` (the branch continues, unstable: lateral-torsional buckling) or ``"fold"``.
    magnitudes : tuple of (int, float)
        (distinct nodes, |B| in T) on each grid, coarse to fine.
    """

    field: Field
    magnitude: float
    fraction: float
    error: float
    kind: str
    magnitudes: tuple


def critical_field(beam: Beam, field, *, gravity: float = 0.0, support: str = "cantilever",
                   clamp_angle: float = 0.0, options=None, degrees=(24, 36, 54)) -> CriticalField | None:
    """The first loss of stability of the 3D rod along a field ramped from zero to ``field``.

    Follows the branch (gravity first) on grids of each degree in ``degrees``, stops at the first
    crossing of the smallest eigenvalue of the second variation, and locates it by a secant
    (:meth:`RodSolver._locate`). Returns None when the branch stays stable up to ``field``; a RuntimeError
    (with the reason) when the branch could not be followed that far (a stall, or ``options.max_step_work``).

    Parameters
    ----------
    beam : Beam
    field : Field or (B_x, B_y, B_z)
        End of the ramp (T); the direction of the field is kept.
    gravity, clamp_angle, options
        As in :func:`magsoft_env.solve_path` (``options.nodes`` is set per grid).
    support : {"cantilever"}
        Only the clamped strip has a loading branch to follow.
    degrees : sequence of int
        Chebyshev degrees per subdomain, coarse to fine (at least two, each in [8, 400]).

    Examples
    --------
    >>> import magsoft_env as ms
    >>> beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> crit = critical_field(beam, (0, 2e-3, 0))
    >>> round(crit.magnitude * 1e3, 3), crit.kind, crit.error < 1e-9
    (0.841, 'bifurcation', True)
    """
    from ..spec import as_field
    from ..validate import integer
    fld = as_field(field)
    degrees = tuple(integer("critical_field degrees", d, 8, 400) for d in degrees)
    if len(degrees) < 2:
        raise ValueError(f"critical_field degrees needs at least two grids to state an error, got {degrees!r}.")
    g, support, _, _, th0, options = check_problem(beam, gravity, support, "rotated", False, clamp_angle,
                                                   options or SolverOptions(), rod=True)
    if support != "cantilever":
        raise ValueError("critical_field follows the branch of a clamped strip (support='cantilever'); a free "
                         f"strip is relaxed field by field and has no loading branch to follow, got {support!r}.")
    Bx, By, Bz = (float(v) for v in fld.vector())
    target = Load3(Bx, By, Bz, g)
    with single_threaded_blas():
        return _critical(beam, target, g, th0, options, degrees)


def _critical(beam, target, g, th0, options, degrees):
    from dataclasses import replace

    support = "cantilever"
    found = []
    kind = "bifurcation"
    for n in degrees:
        opt = replace(options, nodes=n)
        solver = RodSolver(beam, support=support, clamp_angle=th0, options=opt,
                           edges=subdomain_edges(beam, options.split_at_knots))
        if g > 0 and support == "cantilever" and not solver.continue_to(Load3(0.0, 0.0, 0.0, g)):
            raise ValueError(f"critical_field: the strip found no equilibrium under gravity alone ({solver.note}).")
        start = solver.load
        ok = solver.continue_to(target)
        if not solver.events:
            if not ok:  # stopped before the end of the ramp: that is not "stable up to the field"
                raise RuntimeError(f"critical_field: the branch could not be followed to the end of the ramp on "
                                   f"degree {n} ({solver.note}).")
            return None
        ev = solver.events[0]
        kind = ev["kind"]
        t = ev.get("critical_fraction", ev["load_fraction"])
        ld = start.lerp(target, t)
        found.append((int(solver.model.uniq.size), float(np.linalg.norm(ld.B)), t, ld))
    _, mag, t, ld = found[-1]
    return CriticalField(field=Field(ld.Bx, ld.By, ld.Bz), magnitude=mag, fraction=t,
                         error=abs(found[-1][1] - found[-2][1]), kind=kind,
                         magnitudes=tuple((n, b) for n, b, _, _ in found))

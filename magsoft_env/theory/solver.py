"""Equilibrium shapes along a loading path: spectral collocation, damped Newton, continuation."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from dataclasses import field as dc_field
from functools import cached_property, lru_cache

import numpy as np
import scipy.linalg
import scipy.optimize

from ..spec import Beam, as_field, as_fields
from ..threads import single_threaded_blas
from ..validate import choice
from .collocation import Grid, _grid_cached, finer_grid, make_grid
from .model import BeamModel, Load
from .options import (
    MAX_TOTAL_NODES,
    SolverOptions,
    check_problem,
    subdomain_edges,
    use_rod,
)
from .result import PathResult, PlanarShape
from .rod_solver import RodResult, solve_rod_path
from .sources import SourceResult, is_source, solve_source_path, uniform_field
from .verify import equation_residual, outcome

#: The models :func:`solve_path` takes: the planar beam, the 3D rod, or the one the problem needs.

TERMINATION_MESSAGES = {
    0: "Converged: equilibrium found along the loading path.",
    1: "Continuation stalled: Newton did not converge even for the smallest load step.",
    2: "Converged, but the solution is not resolved to the requested tolerance on the finest grid "
    "allowed; give breakpoints for non-smooth profiles or raise max_nodes.",
    3: "Direct Newton solve (start='straight') did not converge.",
    4: "Not verified: the solution satisfies the equations at the collocation nodes but not between them "
    "(an under-resolved grid); raise max_nodes, give breakpoints for non-smooth profiles, or relax verify_tol.",
    5: "Stopped: a load step of the 3D rod used up its work budget (SolverOptions.max_step_work).",
}
#: Largest number of refinements of the grid for one equilibrium (degree raises and subdomain splits).
MAX_REFINEMENTS = 12
#: Work bounds of one load segment of the continuation: accepted or rejected steps, and jumps
#: (folds and bifurcations passed by energy descent). Beyond them the segment fails with a message.
MAX_STEPS = 4000
MAX_JUMPS = 40
#: Refinement aims at this fraction of ``verify_tol``, so that an independent measurement of the
#: residual (other points, other quadrature) also finds it below ``verify_tol``.
VERIFY_MARGIN = 0.1

_MAX_NEWTON = 10
_MAX_STEP_RAD = 0.6  # Newton steps larger than this (rad, max norm) are damped
_JUMP_RAD = 0.2  # a converged step this far from its prediction counts as a branch jump
_NEUTRAL = 1e-9  # eigenvalues (units EI/L^2) above -this count as stable (neutral rigid rotation)
_STEP_RAD = 2.0  # largest predicted change of theta in one continuation step (rad)
_CURV_RAD = 1.0  # largest second-order term of the prediction in one continuation step (rad)
_FOLD_FRAC = 0.5  # largest load step as a fraction of the estimated distance to a fold
_GIVEUP_IT, _GIVEUP_RATIO = 3, 0.25
_SHRINK = 0.25  # step reduction after a failed or rejected continuation step
_abs, _amax = np.abs, np.maximum.reduce  # max |x| without ndarray.max's Python wrapper


@dataclass(frozen=True, kw_only=True)
class EquilibriumResult(PlanarShape, PathResult):
    """Equilibrium of a beam in the x-z plane under one field (frozen): a
    :class:`~magsoft_env.theory.result.PathResult` (status, stability, tip, path) with the planar shape.

    Arrays hold one value per distinct collocation node, ``n = nodes`` of them, ordered from the
    clamp (or left end) to the tip; :meth:`sample` and :meth:`at` interpolate spectrally between
    them. Units are SI.

    Attributes
    ----------
    success : bool
        True when an equilibrium was found (``status`` 0 or 2).
    status : int
        0 converged; 1 continuation stalled; 2 converged but under-resolved; 3 direct solve failed.
    message : str
        Human-readable status (:data:`TERMINATION_MESSAGES`, plus passed folds and the resolution).
    s : (n,) ndarray
        Reference arc length of the nodes (m), from the clamp (or left end) to the tip.
    theta : (n,) ndarray
        Tangent angle (rad) from +x toward +z.
    strain : (n,) ndarray
        Axial strain (dimensionless; zero unless ``extensible``).
    x, z : (n,) ndarray
        Deformed centreline (m), eq. (17).
    tip_angle : float
        theta(L) (rad).
    tip_deflection : float
        Vertical displacement of the tip, z(L) (m).
    rotation_angle : float
        Overall rotation gamma (rad): the chord angle atan2(z(L), x(L)), taken on the branch
        nearest the mean tangent angle so that it can exceed 180 degrees continuously.
    max_curvature : float
        Largest |d theta / ds| over the nodes (1/m).
    max_strain : float
        Largest |axial strain| (dimensionless; 0 unless ``extensible``).
    stable : bool
        Smallest eigenvalue of the discrete second variation is positive (a Cholesky test).
    snap_through : bool
        A fold (or a bifurcation onto an unstable branch) was passed on the way to this field
        and the solver jumped to a stable branch by energy descent.
    field : Field
        The applied field (T).
    gravity : float
        Gravitational acceleration along -z (m/s^2).
    residual : float
        Largest |residual| of the discrete equilibrium equations at the nodes (rad).
    resolution : float
        The error that was measured (rad): the larger of theta's trailing Chebyshev coefficients
        on the final grid and :attr:`verification` (NaN when the solve failed).
    verification : float
        Largest residual of the equilibrium equations between the nodes (rad), measured
        independently of the solver (:func:`magsoft_env.theory.verify.equation_residual`: the
        integral form on Gauss-Legendre points between every pair of nodes, with the loads
        recomputed from the beam); ``success`` requires it to be at most ``verify_tol``.
    nodes : int
        Number of distinct collocation nodes, ``n``.
    newton_iterations : int
        Newton iterations spent by the solver up to this result (cumulative along a path).
    wall_time : float
        Seconds spent reaching this equilibrium from the previous one (or from the unloaded
        beam, gravity included, for the first).
    events : list of dict
        Folds and bifurcations passed so far along the path, each ``{"kind", "load_fraction",
        "field_T", "gravity", "converged"}``.
    min_eigenvalue : float
        (property) Smallest eigenvalue of the discrete second variation in units of EI/L^2.
    min_eigenvalue_uncertainty : float
        (property) Its change on a 1.5 times finer grid (EI/L^2): how well the grid resolves it.
    tip_position, tip_twist, centreline
        (properties) The 3D readings of :class:`~magsoft_env.theory.rod_solver.RodResult`: (x_L, 0, z_L),
        0.0 and (n, 3), so that code written for either result reads both.
    """

    theta: np.ndarray
    strain: np.ndarray
    x: np.ndarray
    z: np.ndarray
    tip_angle: float
    rotation_angle: float
    max_strain: float
    _grid: Grid | None = dc_field(default=None, repr=False, compare=False)
    _eig: tuple | None = dc_field(default=None, repr=False, compare=False)
    _full: tuple | None = dc_field(default=None, repr=False, compare=False)

    @cached_property
    def min_eigenvalue(self) -> float:
        """Smallest eigenvalue of the discrete second variation in units of EI/L^2 (computed on
        first access; ``stable`` is decided without it, by a Cholesky test)."""
        mdl, th, load, clamped, _ = self._eig
        return mdl.min_eigen(th, load, clamped=clamped, vector=False)[0]

    @cached_property
    def min_eigenvalue_uncertainty(self) -> float:
        """How far :attr:`min_eigenvalue` is from converged in the grid (EI/L^2): its change when
        the same shape is evaluated on a grid of 1.5 times the degree (computed on first access).
        The eigenvalue converges more slowly than the shape; a ``stable`` result whose eigenvalue
        is smaller than this uncertainty is marginal."""
        mdl, th, load, clamped, coupling = self._eig
        grid = self._grid
        finer = _regrid(grid, min(400, int(math.ceil(1.5 * grid.n))))
        fine = _model(mdl.beam, finer, coupling, mdl.extensible)
        lam = fine.min_eigen(grid.interpolate(th, finer.s), load, clamped=clamped, vector=False)[0]
        return abs(float(lam) - float(self.min_eigenvalue))

    def to_dict(self) -> dict:
        """Metrics as plain numbers (SI and degrees), for JSON."""
        L = self.length
        return {
            **self._status_dict(),
            "field_T": [self.field.Bx, self.field.Bz],
            "tip_deflection_m": self.tip_deflection,
            "v_over_L": self.tip_deflection / L,
            "tip_angle_rad": self.tip_angle,
            "tip_angle_deg": math.degrees(self.tip_angle),
            "rotation_angle_rad": self.rotation_angle,
            "rotation_angle_deg": math.degrees(self.rotation_angle),
            "tip_x_m": float(self.x[-1]),
            "tip_z_m": float(self.z[-1]),
            "max_strain": self.max_strain,
            "min_eigenvalue": self.min_eigenvalue,
            "min_eigenvalue_uncertainty": self.min_eigenvalue_uncertainty,
        }


# ----------------------------------------------------------------------------------------
@lru_cache(maxsize=32)
def _model_cached(beam, grid, coupling, extensible):
    return BeamModel(beam, grid, coupling=coupling, extensible=extensible)


def _model(beam, grid, coupling, extensible):
    try:
        return _model_cached(beam, grid, coupling, extensible)
    except TypeError:  # unhashable user callables
        return BeamModel(beam, grid, coupling=coupling, extensible=extensible)


class _Solver:
    """Continuation state for one beam: the current grid, model and solution."""

    def __init__(self, beam: Beam, *, support, coupling, extensible, clamp_angle, options: SolverOptions):
        self.beam = beam
        self.support = support
        self.coupling = coupling
        self.extensible = extensible
        self.theta0 = clamp_angle
        self.opt = options
        bps = subdomain_edges(beam, options.split_at_knots)
        edges = make_grid(beam.length, bps, n=8, max_domain=options.max_domain * beam.length).edges
        if options.nodes is not None:
            n = options.nodes
        else:
            n = min(32 if not bps else 20, MAX_TOTAL_NODES // (len(edges) - 1) - 1)
        self._set_grid(make_grid(beam.length, bps, n=n, max_domain=options.max_domain * beam.length))
        self.theta = np.full(self.grid.M, clamp_angle if support == "cantilever" else 0.0)
        self.c = 0.0  # free support: angle at s = 0
        self.load = Load(0.0, 0.0, 0.0)
        self.newton_its = 0
        self.events: list[dict] = []
        self._last_stable = (None, False)
        self._J_state = None
        self._moved = 0.0
        self._mode = None  # last lowest stability mode (warm start of inverse iteration)
        self._stab = None  # (theta, model, load, cos, sin, stable, lambda, mode, f) of the last test
        self.note = ""  # why the continuation stopped, when a work bound stopped it

    def _set_grid(self, grid: Grid):
        self.grid = grid
        self.model = _model(self.beam, grid, self.coupling, self.extensible)

    # Newton ---------------------------------------------------------------------------------
    def newton(self, theta, load: Load, c=None, maxiter: int = _MAX_NEWTON):
        """Damped Newton on the collocation equations. Returns (ok, theta, c, iterations).

        On success ``self._lu`` holds the factorized Jacobian of the last step (cantilever)."""
        mdl = self.model
        free = self.support == "free"
        th = theta.copy()
        cc = self.c if c is None else c
        if not free:
            return self._newton_clamped(theta, th, cc, load, maxiter)
        M = th.size
        scale = self.beam.length / mdl.EI_ref
        tol = self.opt.tol
        prev_big = math.inf
        moved = 0.0  # bound on max |theta - start| (sum of the update sizes)
        for it in range(1, maxiter + 1):
            if free:
                R, fth = mdl.residual(th, cc, load)
                _, f, _, _ = mdl.density(th, load)
                J = np.empty((M + 1, M + 1))
                J[:M, :M] = mdl.jacobian(fth)
                J[:M, M] = -1.0
                J[M, :M] = scale * mdl.grid.w * fth
                J[M, M] = 0.0
                R = np.concatenate([R, [scale * (mdl.grid.w @ f)]])
                try:
                    d = np.linalg.solve(J, R)
                except np.linalg.LinAlgError:
                    return False, theta, cc, it
                lu = None
            else:
                f, fth = mdl.f_fth_at(th, load)
                R = mdl.P @ f
                R += th
                if self.theta0:
                    R -= self.theta0
                d, lu = mdl.solve_newton(R, fth)
                if d is None:
                    return False, theta, cc, it
            big = float(_amax(_abs(d)))  # NaN or inf in R or J propagate here
            if not math.isfinite(big):
                return False, theta, cc, it
            if it >= _GIVEUP_IT and big > _GIVEUP_RATIO * prev_big and maxiter <= _MAX_NEWTON:
                return False, theta, cc, it  # not converging quadratically: give up early
            if big > _MAX_STEP_RAD:
                d *= _MAX_STEP_RAD / big
                big_applied = _MAX_STEP_RAD
            else:
                big_applied = big
            moved += big_applied
            th -= d if d.size == M else d[:M]
            if free:
                cc -= d[M]
            # quadratic convergence: the next update would be about big^3 / prev^2
            if big < tol or (it >= 2 and big**3 < tol * prev_big**2 and big < 1e-5):
                self._lu = lu
                self._moved = moved
                return True, th, cc, it
            prev_big = big
        return False, theta, cc, maxiter

    def _newton_clamped(self, theta, th, cc, load: Load, maxiter: int):
        """The cantilever branch of :meth:`newton`, with the per-iteration work kept to a few
        numpy calls (this loop dominates the time per equilibrium along a path)."""
        mdl = self.model
        P, solve, theta0, tol = mdl.P, mdl.solve_newton, self.theta0, self.opt.tol
        sin, cos, isfinite = np.sin, np.cos, math.isfinite
        if mdl.extensible:
            density = mdl.density
            amp = ph = None
        else:
            amp, ph = mdl._coeffs(load)[6:]  # phi_theta = amp sin(theta + ph), phi_theta_theta = amp cos(...)
        giveup = maxiter <= _MAX_NEWTON
        prev_big = math.inf
        moved = 0.0  # bound on max |theta - start| (sum of the update sizes)
        for it in range(1, maxiter + 1):
            if amp is None:
                f, fth = density(th, load)[1:3]
            else:
                fth = th + ph
                f = sin(fth)
                f *= amp
                cos(fth, out=fth)
                fth *= amp
            R = P @ f
            R += th
            if theta0:
                R -= theta0
            d, lu = solve(R, fth)
            if d is None:
                return False, theta, cc, it
            big = float(_amax(_abs(d)))  # NaN or inf in R or J propagate here
            if not isfinite(big):
                return False, theta, cc, it
            if it >= _GIVEUP_IT and big > _GIVEUP_RATIO * prev_big and giveup:
                return False, theta, cc, it  # not converging quadratically: give up early
            if big > _MAX_STEP_RAD:
                d *= _MAX_STEP_RAD / big
                moved += _MAX_STEP_RAD
            else:
                moved += big
            th -= d
            # quadratic convergence: the next update would be about big^3 / prev^2
            if big < tol or (it >= 2 and big**3 < tol * prev_big**2 and big < 1e-5):
                self._lu = lu
                self._moved = moved
                return True, th, cc, it
            prev_big = big
        return False, theta, cc, maxiter

    # energy descent (branch switching) --------------------------------------------------------
    def descend(self, theta, load: Load, kick=None):
        """Minimize the discrete energy from ``theta`` (plus a kick), then polish with Newton.

        If Newton cannot polish the minimizer (the new shape is not resolved by the grid), the
        degree is raised and the descent repeated from the interpolated shape.
        """
        th = theta if kick is None else theta + kick
        entry = self.grid
        while True:
            th_min, c = self._minimize(th, load)
            ok, th2, c2, _ = self.newton(th_min, load, c, maxiter=4 * _MAX_NEWTON)
            if ok:
                return ok, th2, c2
            if self.opt.nodes is not None or self.grid.n >= self.opt.max_nodes or \
                    len(self.grid.edges) * (self._finer(self.grid.n) + 1) > MAX_TOTAL_NODES:
                if self.grid is not entry:  # failed: the caller keeps its state, on its grid
                    self._set_grid(entry)
                return False, theta, self.c
            old = self.grid
            self._set_grid(_regrid(old, self._finer(old.n)))
            th = old.interpolate(th_min, self.grid.s)
            if self.support == "free":
                self.c = float(th[0])

    def _minimize(self, theta, load: Load):
        mdl = self.model
        u0 = theta[mdl.uniq]
        clamped = self.support == "cantilever"
        if clamped:
            fixed = self.theta0

            def fun(v):
                e, g, H = mdl.energy_grad_hess(np.concatenate([[fixed], v]), load)
                return e, g[1:], H[1:, 1:]

            v0 = u0[1:]
        else:

            def fun(v):
                return mdl.energy_grad_hess(v, load)

            v0 = u0

        def f(v):
            e, g, _ = fun(v)
            return e, g

        def h(v):
            return fun(v)[2]

        scale = mdl.EI_ref / self.beam.length
        res = scipy.optimize.minimize(
            f, v0, jac=True, hess=h, method="trust-exact", options={"gtol": 1e-12 * scale, "maxiter": 1000}
        )
        u = np.concatenate([[self.theta0], res.x]) if clamped else res.x
        return u[mdl.expand], (None if clamped else float(u[0]))

    # continuation ---------------------------------------------------------------------------------
    def tangent(self, theta, lu, start: Load, target: Load, t: float):
        """Derivatives d theta / d t and d^2 theta / d t^2 along the segment (predictor), from the
        factorized Jacobian at theta. The second derivative is None where it is not available."""
        mdl = self.model
        if not self.extensible:
            # f = phi_theta is linear in the load (B_x, B_z, g): R_t = P f_delta exactly, and
            # differentiating R(theta(t), t) = 0 twice (f_theta_theta = -f) gives
            #   J theta'' = -P (2 f_theta,delta theta' - f theta'^2)
            delta = Load(target.Bx - start.Bx, target.Bz - start.Bz, target.g - start.g)
            _, df, dfth, _ = mdl.density(theta, delta)
            tan = mdl.lu_solve(lu, mdl.P @ df)
            tan *= -1.0
            if not np.isfinite(tan).all():
                return np.zeros_like(theta), None
            f = mdl.density(theta, start.lerp(target, t))[1]
            acc = mdl.lu_solve(lu, mdl.P @ ((f * tan - 2.0 * dfth) * tan))
            return tan, (acc if np.isfinite(acc).all() else None)
        h = 1e-3
        df = (mdl.density(theta, start.lerp(target, t + h))[1] - mdl.density(theta, start.lerp(target, t - h))[1]) / (
            2 * h
        )
        tan = mdl.lu_solve(lu, mdl.P @ df)
        tan *= -1.0
        return (tan if np.isfinite(tan).all() else np.zeros_like(theta)), None

    def _stability(self, theta, load: Load):
        """Stability of an equilibrium by a Cholesky test, with cos/sin of theta and, when stable,
        the lowest mode's eigenvalue and unit vector (inverse iteration). Cached for ``theta``."""
        st = self._stab
        if st is not None and st[0] is theta and st[1] is self.model and st[2] == load:
            return st
        mdl = self.model
        c, sn = np.cos(theta), np.sin(theta)
        f, fth = mdl.f_fth(c, sn, load)
        U = mdl.cholesky(fth, clamped=True, tol=0.0)
        lam, v = 0.0, None
        if U is not None:
            v = self._mode
            if v is None or v.size != U.shape[0]:  # cold start: two inverse iterations
                lam, v = mdl.low_mode(U, np.full(U.shape[0], 1.0 / math.sqrt(U.shape[0])), its=2)
            else:  # warm start from the previous step's mode
                lam, v = mdl.low_mode(U, v, its=1)
            self._mode = v
        self._stab = st = (theta, mdl, load, c, sn, U is not None, lam, v, f)
        return st

    def _point(self, theta, lu, start: Load, target: Load, t: float):
        """At an equilibrium on the segment (inextensible): its stability, the derivatives
        theta', theta'' along the segment, and an estimate of the load distance to a fold.

        The fold estimate follows the smallest eigenvalue lambda of the second variation:
        at a fold lambda vanishes like sqrt(t_fold - t), so lambda^2 is nearly linear in t and
        t_fold - t ~ lambda / (2 |d lambda / d t|), with d lambda / d t = v^T (d H / d t) v for
        the unit mode v."""
        mdl = self.model
        load = start.lerp(target, t) if t < 1.0 else target
        _, _, _, c, sn, stable, lam, v, f = self._stability(theta, load)
        delta = Load(target.Bx - start.Bx, target.Bz - start.Bz, target.g - start.g)
        fd, fthd = mdl.f_fth(c, sn, delta)
        lu_solve, total = mdl.lu_solve, np.add.reduce
        tan = lu_solve(lu, mdl._Pneg @ fd)  # -P @ fd, the sign exact
        if math.isfinite(total(tan)):
            # differentiating R(theta(t), t) = 0 twice (f_theta_theta = -f):
            #   J theta'' = -P (2 f_theta,delta theta' - f theta'^2)
            g = f * tan
            g -= 2.0 * fthd
            g *= tan
            acc = lu_solve(lu, mdl.P @ g)
            if not math.isfinite(total(acc)):
                acc = None
        else:
            tan, acc = np.zeros_like(theta), None
        d_fold = math.inf
        if stable:
            rate = mdl.mode_rate(v, fthd - f * tan, clamped=True)
            if rate < 0.0 and lam > 0.0:
                d_fold = lam / (-2.0 * rate)
        return stable, tan, acc, d_fold

    def continue_to(self, target: Load) -> tuple[bool, bool]:
        """Follow the equilibrium from the current load to ``target``. Returns (ok, snapped).

        Predictor (tangent, plus the second derivative for inextensible beams), Newton
        corrector; the step is limited so that the predicted change stays below ``_STEP_RAD``,
        its second-order part below ``_CURV_RAD``, and the load step below a fraction of the
        estimated distance to a fold; it is cut when Newton fails or lands far from the
        prediction. Every accepted step is checked for stability; when the smallest
        eigenvalue turns negative the step is shortened to the crossing, then the solver
        jumps to a stable branch by energy descent.
        """
        if self.support == "free":
            return self._free_to(target)
        start = self.load
        t, dt = 0.0, 1.0
        theta = self.theta
        if self._J_state is not None and self._J_state[0] is theta and self._J_state[1] is self.model:
            lu = self._J_state[2]  # Jacobian of the Newton step that produced this state
        else:
            R, fth = self.model.residual(theta, self.theta0, start)
            _, lu = self.model.solve_newton(R, fth)
        snapped = False
        second = not self.extensible
        if second:
            _, tan, acc, d_fold = self._point(theta, lu, start, target, t)
        else:
            tan, acc = self.tangent(theta, lu, start, target, t)
            d_fold = math.inf
        steps = jumps = 0
        while t < 1.0:
            steps += 1
            if steps > MAX_STEPS or jumps > MAX_JUMPS:
                self.note = (
                    f"Stopped after {steps - 1} continuation steps and {jumps} jumps in one load step (bounds "
                    f"{MAX_STEPS} and {MAX_JUMPS}) at {100 * t:.3g} % of it: the equilibria change faster than "
                    "the continuation can follow (check the load's size: nondimensional_groups())."
                )
                self.theta, self.load = theta, start.lerp(target, t)
                return False, snapped
            tmax = float(_amax(_abs(tan)))
            dt = min(dt, 1.0 - t, _STEP_RAD / tmax if tmax > 0 else 1.0)
            # keep the second-order term of the prediction moderate, and approach a predicted
            # fold geometrically; only a failed step declares a fold (a dip of the eigenvalue
            # that does not reach zero is crossed)
            lim = _FOLD_FRAC * d_fold
            if acc is not None:
                amax = float(_amax(_abs(acc)))
                if amax > 0:
                    lim = min(lim, math.sqrt(2.0 * _CURV_RAD / amax))
            dt = min(dt, max(lim, 4 * self.opt.min_step))
            fold = dt < self.opt.min_step
            if not fold:
                t_new = t + dt
                if 1.0 - t_new < 1e-12:
                    t_new = 1.0
                load = start.lerp(target, t_new) if t_new < 1.0 else target
                h = t_new - t
                guess = theta + h * tan
                if acc is not None:
                    guess += (0.5 * h * h) * acc
                ok, th_new, _, its = self.newton(guess, load)
                self.newton_its += its
                jump = max(_JUMP_RAD, 0.5 * h * tmax)
                if ok and self._moved > jump and float(_amax(_abs(th_new - guess))) > jump:
                    ok = False  # converged far from the prediction: likely another branch
                if not ok:
                    dt *= _SHRINK
                    fold = dt < self.opt.min_step
                    if not fold:
                        continue
            nxt = None
            if fold:
                # no equilibrium near the current one beyond load t: snap to a stable one
                t_new = min(1.0, t + 4 * self.opt.min_step)
                load = start.lerp(target, t_new)
                lam, mode = self.model.min_eigen(theta, start.lerp(target, t), clamped=True)
                ok2, th_new, _ = self._jump(theta, 0.02 * mode, load, t_new, "fold")
                jumps += 1
                if not ok2:
                    self.theta, self.load = theta, start.lerp(target, t)
                    return False, snapped
                snapped, its, dt = True, _MAX_NEWTON, 4 * self.opt.min_step
            else:
                # stability at every accepted step: one eigenvalue crossing at a time
                if second and t_new < 1.0:
                    nxt = self._point(th_new, self._lu, start, target, t_new)
                    stable = nxt[0]
                elif second:  # end of the segment: derivatives come with the next one
                    stable = self._stability(th_new, load)[5]
                else:
                    stable = self.model.is_stable(th_new, load, clamped=True, tol=0.0)
                self._last_stable = (th_new, stable)
                if not stable:
                    nxt = None
                    if h > 1e-3:
                        dt = 0.25 * h  # home in on the crossing before leaving the branch
                        continue
                    lam, mode = self.model.min_eigen(th_new, load, clamped=True)
                    ok2, th_s, _ = self._jump(th_new, mode, load, t_new, "bifurcation")
                    jumps += 1
                    if not ok2:
                        self.theta, self.load = theta, start.lerp(target, t)
                        return False, snapped
                    th_new, snapped = th_s, True
            t, theta = t_new, th_new
            if its <= 4:
                dt = min(1.0, 2.0 * dt)
            if t < 1.0:
                if nxt is not None:
                    _, tan, acc, d_fold = nxt
                elif second:
                    _, tan, acc, d_fold = self._point(theta, self._lu, start, target, t)
                else:
                    tan, acc = self.tangent(theta, self._lu, start, target, t)
        self.theta, self.load = theta, target
        self._J_state = (theta, self.model, self._lu)
        return True, snapped

    def _jump(self, theta, kick, load, t, kind):
        ok, th, c = self.descend(theta, load, kick=kick)
        if ok:
            lam2, mode2 = self.model.min_eigen(th, load, clamped=True)
            if lam2 < 0.0:  # landed on a saddle: push along its unstable mode
                ok, th, c = self.descend(th, load, kick=0.02 * mode2)
        self.events.append(
            {"kind": kind, "load_fraction": t, "field_T": (load.Bx, load.Bz), "gravity": load.g, "converged": ok}
        )
        return ok, th, c

    def _free_to(self, target: Load):
        # A free beam has no preferred orientation at zero field, so each field is reached by
        # energy descent from the previous shape (a field switch), then polished by Newton.
        if target.Bx == 0.0 and target.Bz == 0.0:
            # no load at all: the beam relaxes straight, keeping its mean orientation
            mean = float(self.grid.w @ self.theta) / self.beam.length
            self.theta, self.c, self.load = np.full_like(self.theta, mean), mean, target
            return True, False
        ok, th, c = self.descend(self.theta, target)
        if ok:
            lam, mode = self.model.min_eigen(th, target, clamped=False)
            if lam < 0:
                ok, th, c = self.descend(th, target, kick=0.02 * mode)
        if ok:
            self.theta, self.c, self.load = th, c, target
        return ok, False

    # resolution -----------------------------------------------------------------------------------
    def _finer(self, n: int) -> int:
        return min(self.opt.max_nodes, int(math.ceil(n * 1.5)))

    def verify(self) -> float:
        """Equation residual between the nodes (rad), independent of the solver's operators."""
        ld = self.load
        return equation_residual(self.beam, self.grid, self.theta, Bx=ld.Bx, Bz=ld.Bz, g=ld.g,
                                 coupling=self.coupling, extensible=self.extensible, support=self.support,
                                 theta0=self.theta0)

    def _next_grid(self, grid: Grid, theta) -> Grid | None:
        """A finer grid than ``grid`` (:func:`~magsoft_env.theory.collocation.finer_grid`)."""
        return finer_grid(grid, theta, max_nodes=self.opt.max_nodes, max_total=MAX_TOTAL_NODES)

    def refine(self) -> tuple[float, float]:
        """Refine the grid until theta's Chebyshev tail is below ``resolution_tol`` and the
        verification residual below ``verify_tol``: first the degree, up to ``max_nodes``, then
        (for the verification, which aims at ``VERIFY_MARGIN * verify_tol``) the least resolved
        subdomains are halved. A refinement whose Newton
        solve fails does not end the search: the next finer grid is tried from the last good state.
        At most ``MAX_REFINEMENTS`` grids and ``MAX_TOTAL_NODES`` nodes. Returns (tail, verification)."""
        tail, ver = self.grid.tail(self.theta), self.verify()
        if self.opt.nodes is not None:
            return tail, ver
        good = (self.grid, self.theta, self.c)
        grid = self.grid
        for _ in range(MAX_REFINEMENTS):
            need_p = tail > self.opt.resolution_tol and grid.n < self.opt.max_nodes
            if not (need_p or not ver <= VERIFY_MARGIN * self.opt.verify_tol):
                break
            g0, th0, c0 = good
            new = self._next_grid(grid, th0 if grid is g0 else g0.interpolate(th0, grid.s))
            if new is None:
                break
            self._set_grid(new)
            guess = g0.interpolate(th0, new.s)
            ok, th, c, its = self.newton(guess, self.load, c0)
            self.newton_its += its
            if not ok and self.support == "free":
                # a free beam's coarse shape can be far from the resolved one: descend on the finer grid
                ok, th, c = self.descend(guess, self.load)
                new = self.grid  # descend may have raised the degree itself
            grid = new
            if not ok:
                continue
            self.theta, self.c = th, c
            tail, ver = new.tail(th), self.verify()
            good = (new, th, c)
        if self.grid is not good[0]:
            self._set_grid(good[0])
        self.theta, self.c = good[1], good[2]
        return tail, ver

    # result -------------------------------------------------------------------------------------
    def result(self, ok, status, snapped, field_, gravity, tail, ver, wall_time: float = 0.0) -> EquilibriumResult:
        mdl, grid = self.model, self.grid
        th = self.theta
        load = self.load
        st = self._stab
        if not self.extensible and st is not None and st[0] is th and st[1] is mdl and st[2] == load:
            c, sn, f = st[3], st[4], st[8]  # from the stability test of this state
            eps = mdl._zeros
        else:
            _, f, _, eps = mdl.density(th, load)
            c, sn = np.cos(th), np.sin(th)
            if self.extensible:
                c, sn = c * (1.0 + eps), sn * (1.0 + eps)
        theta0 = self.theta0 if self.support == "cantilever" else self.c
        R = mdl.P @ f
        R += th
        R -= theta0
        x, z = grid.Q0 @ c, grid.Q0 @ sn
        clamped = self.support == "cantilever"
        if self._last_stable[0] is th and self._last_stable[1]:  # checked by the last continuation step
            stable = True
        else:
            stable = mdl.is_stable(th, load, clamped=clamped, tol=_NEUTRAL)
        u = mdl.uniq
        L = self.beam.length
        kappa = grid.derivative(th)
        thc = th.copy()  # kept for min_eigenvalue and interpolation
        chord = math.atan2(z[-1], x[-1])
        mean_angle = float(grid.w @ th) / L
        chord += 2 * math.pi * round((mean_angle - chord) / (2 * math.pi))
        status, msg = outcome(ok, status, tail, ver, self.opt, note=self.note, events=len(self.events),
                              nodes=int(u.size), messages=TERMINATION_MESSAGES)
        return EquilibriumResult(
            success=ok and status in (0, 2),
            status=status,
            message=msg,
            s=grid.s[u],  # fancy indexing: copies
            theta=th[u],
            strain=eps[u],
            x=x[u],
            z=z[u],
            tip_angle=float(th[-1]),
            tip_deflection=float(z[-1]),
            rotation_angle=chord,
            max_curvature=float(_amax(_abs(kappa))),
            max_strain=float(np.abs(eps).max()) if self.extensible else 0.0,
            stable=bool(stable),
            _eig=(mdl, thc, load, clamped, self.coupling),
            snap_through=snapped,
            field=field_,
            gravity=gravity,
            residual=float(_amax(_abs(R))),
            resolution=max(tail, ver) if ok else math.nan,
            verification=float(ver) if ok else math.nan,
            nodes=int(u.size),
            newton_iterations=self.newton_its,
            events=list(self.events),
            wall_time=float(wall_time),
            _grid=grid,
            _full=(thc, x, z),
        )


def _regrid(grid: Grid, n: int) -> Grid:
    return _grid_cached(tuple(float(e) for e in grid.edges), n)


# ----------------------------------------------------------------------------------------------
def solve_path(
    beam: Beam,
    fields,
    *,
    gravity: float = 9.81,
    support: str = "cantilever",
    coupling: str = "rotated",
    extensible: bool = False,
    clamp_angle: float = 0.0,
    options: SolverOptions | None = None,
    progress: bool = False,
    model: str = "auto",
) -> list[EquilibriumResult] | list[RodResult] | list[SourceResult]:
    """Equilibria along a loading path, one result per field, in order.

    The path starts from the straight, unloaded beam: gravity is applied first (zero field),
    then the field is ramped from zero to ``fields[0]`` and on to each following field.
    Between fields, natural-parameter continuation with tangent predictors (plus the exact
    second derivative for inextensible beams) and adaptive steps follows the equilibrium
    branch; steps shrink toward a fold predicted from the lowest stability eigenvalue. Each
    step is checked for stability (smallest eigenvalue of the second variation); if the branch
    turns unstable, or a fold ends it, the solver jumps to a stable equilibrium by energy
    descent and reports ``snap_through``.

    Parameters
    ----------
    beam : Beam
        The beam.
    fields : sequence of Field, (B_x, B_z) pairs, (B_x, B_y, B_z) triples or field sources
        Applied fields (T), in loading order. A pair is (B_x, B_z), in the plane of bending. A field source
        (:mod:`magsoft_env.fields`: a magnet, a coil system at its currents, ...; one source or a sequence) loads
        every piece with the couple ``m x B`` and the force ``G^T m`` at its position, the clamp at the origin:
        the cantilever, inextensible, planar (:mod:`magsoft_env.theory.sources`, returning
        :class:`~magsoft_env.theory.sources.SourceResult`) or in 3D (:mod:`magsoft_env.theory.rod_sources`,
        returning :class:`~magsoft_env.theory.rod_sources.SourceRodResult`; see ``model``). Between consecutive
        sources one magnet at two poses moves, other sources blend; the first is switched on from zero. A
        ``fields.Uniform`` source is today's uniform field, bit for bit.
    gravity : float
        Gravitational acceleration (m/s^2) along -z. Must be 0 for ``support="free"``.
    support : {"cantilever", "free"}
        Clamped at s = 0 with angle ``clamp_angle`` and free at s = L, or free at both ends.
    coupling : {"rotated", "paper"}
        Magnetization that rotates with the cross-section (default; what tau = m x B gives),
        or the paper's eq. (10), where only the axial component B_r cos(beta) couples.
    extensible : bool
        Include axial strain (paper eq. 14).
    clamp_angle : float
        theta(0) for the cantilever (rad).
    options : SolverOptions, optional
        Numerical settings.
    progress : bool
        Show a progress bar (tqdm).
    model : {"auto", "planar", "3d"}
        ``"planar"``: the beam bends in the x-z plane (theta(s), the paper's model). ``"3d"``: the
        Kirchhoff rod in three dimensions (bending about both axes and twist,
        :mod:`magsoft_env.theory.rod_solver`; rotated coupling, inextensible). ``"auto"``
        (default) takes the 3D model when a field is given with three components (or as a Field
        with B_y != 0) or the magnetization has a component across the width, and the planar one
        otherwise. On a planar problem both give the same shape; the 3D model also tests
        stability against out-of-plane bending and twist. With a non-uniform field source, ``"auto"``
        takes the 3D rod when the magnetization has a width component or a source loads the strip out of
        its x-z plane (``B_y``, ``dB_x/dy``, ``dB_z/dy``) by more than 1e-6 of its in-plane loads anywhere
        within its reach (:func:`~magsoft_env.theory.rod_sources.out_of_plane_load`), the planar one otherwise.

    Returns
    -------
    list of EquilibriumResult (planar) or of RodResult (3D); with a field source, of SourceResult (planar) or
    of SourceRodResult (3D)

    Examples
    --------
    >>> import magsoft_env as ms
    >>> beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> res = ms.solve_path(beam, ms.ramp((0, 0), (0, 13e-3), 14))
    >>> bool(res[-1].success), round(res[-1].tip_deflection / beam.length, 2)
    (True, 0.92)
    """
    if is_source(fields):
        fields = [fields]
    elif not isinstance(fields, np.ndarray) and isinstance(fields, (list, tuple)) and any(map(is_source, fields)):
        uniform = [uniform_field(f) if is_source(f) else f for f in fields]
        if any(f is None for f in uniform):  # a non-uniform source on the path
            return _solve_source_path(beam, fields, gravity, support, coupling, extensible, clamp_angle, options,
                                      progress, model)
        fields = uniform  # uniform sources: today's solver, bit for bit
    rod = use_rod(beam, fields, model)
    g, support, coupling, extensible, th0, options = check_problem(
        beam, gravity, support, coupling, extensible, clamp_angle, options, rod=rod
    )
    fields = as_fields(fields)
    with single_threaded_blas():
        if rod:
            return solve_rod_path(beam, fields, g, support, th0, options, subdomain_edges(beam, options.split_at_knots),
                                  TERMINATION_MESSAGES, progress)
        return _solve_path(beam, fields, g, support, coupling, extensible, th0, options, progress)


def _solve_source_path(beam, fields, gravity, support, coupling, extensible, clamp_angle, options, progress, model):
    """A path with a non-uniform field source: the cantilever with couples and gradient forces, planar
    (:mod:`magsoft_env.theory.sources`) or in 3D (:mod:`magsoft_env.theory.rod_sources`).

    ``model="3d"`` takes the 3D rod; ``"planar"`` the planar one (a planar beam only); ``"auto"`` the 3D rod when
    the beam's magnetization has a width component or a source loads a planar strip out of its plane by more than
    ``OUT_OF_PLANE_TOL`` (1e-6) of its in-plane loads anywhere within its reach
    (:func:`~magsoft_env.theory.rod_sources.out_of_plane_load`), and the planar one otherwise."""
    from ..fields import Uniform
    from .rod_sources import OUT_OF_PLANE_TOL, out_of_plane_load, solve_rod_source_path
    from .sources import _check_source

    model = choice("model", model, ["auto", "planar", "3d"])
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    if model == "planar" and not beam.is_planar:
        raise ValueError("model='planar' cannot take a magnetization with a component across the width; use "
                         "model='3d' (or 'auto') in a non-uniform field source.")
    sources = [f if is_source(f) else Uniform(f) for f in fields]
    if not sources:
        raise ValueError("fields must hold at least one field or source, got none.")
    sources = [_check_source(i, s) for i, s in enumerate(sources)]
    rod = model == "3d" or (model == "auto" and (not beam.is_planar
                                                 or out_of_plane_load(sources, beam.length) > OUT_OF_PLANE_TOL))
    g, support, coupling, extensible, th0, options = check_problem(
        beam, gravity, support, coupling, extensible, clamp_angle, options, rod=rod
    )
    if support != "cantilever":
        raise ValueError(f"a non-uniform field source needs support='cantilever' (a free beam in a gradient is pulled "
                         f"away: no equilibrium), got {support!r}.")
    if extensible:
        raise ValueError("a non-uniform field source takes the inextensible beam: pass extensible=False.")
    with single_threaded_blas():
        if rod:
            return solve_rod_source_path(beam, sources, gravity=g, clamp_angle=th0, options=options,
                                         messages=TERMINATION_MESSAGES, progress=progress)
        return solve_source_path(beam, sources, gravity=g, coupling=coupling, clamp_angle=th0, options=options,
                                 progress=progress)


def _solve_path(beam, fields, g, support, coupling, extensible, th0, options, progress):
    t_start = time.perf_counter()
    solver = _Solver(beam, support=support, coupling=coupling, extensible=extensible, clamp_angle=th0, options=options)
    results: list[EquilibriumResult] = []
    ok = True
    if g > 0:
        ok, _ = solver.continue_to(Load(0.0, 0.0, g))
    iterator = fields
    if progress:
        from tqdm.auto import tqdm

        iterator = tqdm(fields, desc="equilibria", unit="field")
    t_prev = t_start
    for fld in iterator:
        if ok:
            n_events = len(solver.events)
            ok, _ = solver.continue_to(Load(fld.Bx, fld.Bz, g))
            snapped = len(solver.events) > n_events
            tail, ver = solver.refine() if ok else (math.nan, math.nan)
        else:
            snapped, tail, ver = False, math.nan, math.nan
        now = time.perf_counter()
        results.append(solver.result(ok, 0, snapped, fld, g, tail, ver, wall_time=now - t_prev))
        t_prev = now
    return results


def solve_equilibrium(
    beam: Beam,
    field,
    *,
    gravity: float = 9.81,
    support: str = "cantilever",
    coupling: str = "rotated",
    extensible: bool = False,
    clamp_angle: float = 0.0,
    start: str = "path",
    options: SolverOptions | None = None,
    model: str = "auto",
) -> EquilibriumResult | RodResult | SourceResult:
    """Equilibrium shape of a beam under a uniform field (T) and gravity.

    Solves, for the cantilever (``theta(0) = clamp_angle``, ``theta'(L) = 0``)::

        (E I theta')' = W(s) cos(theta) + (A B_r B_a / mu0) sin(theta + beta - alpha)

    (rotated coupling, inextensible; see :mod:`magsoft_env.theory.model` for the general
    energy), by Chebyshev collocation of the integral form and damped Newton.

    Parameters
    ----------
    beam : Beam
    field : Field, (B_x, B_z), (B_x, B_y, B_z) or a field source
        Applied field (T). Three components (or a magnetization across the width) take the 3D
        rod and return a :class:`~magsoft_env.theory.rod_solver.RodResult` (``model``). A non-uniform
        field source (:mod:`magsoft_env.fields`) adds gradient forces (see :func:`solve_path`) and returns a
        :class:`~magsoft_env.theory.sources.SourceResult` (planar) or, in 3D, a
        :class:`~magsoft_env.theory.rod_sources.SourceRodResult`.
    start : {"path", "straight"}
        ``"path"`` (default) follows the loading path: gravity first, then the field ramped
        from zero, as the real beam experiences it. ``"straight"`` runs Newton once from the
        straight beam at the full load; it can land on an unstable or unreachable
        equilibrium and exists to show why the path matters.
    gravity, support, coupling, extensible, clamp_angle, options, model
        As in :func:`solve_path`.

    Returns
    -------
    EquilibriumResult, or RodResult in 3D

    Examples
    --------
    >>> import magsoft_env as ms
    >>> beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> r = ms.solve_equilibrium(beam, (0.0, 13e-3))
    >>> r.success, r.stable
    (True, True)
    """
    if is_source(field) and uniform_field(field) is None:
        if choice("start", start, ["path", "straight"]) != "path":
            raise ValueError("start='straight' takes a uniform field; a field source follows the loading path: "
                             "pass start='path'.")
        return solve_path(beam, [field], gravity=gravity, support=support, coupling=coupling, extensible=extensible,
                          clamp_angle=clamp_angle, options=options, model=model)[0]
    if is_source(field):
        field = uniform_field(field)
    rod = use_rod(beam, [field], model)
    fld = as_field(field)
    start = choice("start", start, ["path", "straight"])
    if rod and start != "path":
        raise ValueError("start='straight' is planar only (it shows why the loading path matters); the 3D rod "
                         "follows the loading path: pass start='path'.")
    if start == "path":
        return solve_path(
            beam,
            [fld],
            gravity=gravity,
            support=support,
            coupling=coupling,
            extensible=extensible,
            clamp_angle=clamp_angle,
            options=options,
            model="3d" if rod else "planar",
        )[0]
    g, support, coupling, extensible, th0, options = check_problem(
        beam, gravity, support, coupling, extensible, clamp_angle, options
    )
    if support != "cantilever":
        raise ValueError(f"start='straight' supports only support='cantilever', got {support!r}.")
    t_start = time.perf_counter()
    with single_threaded_blas():
        solver = _Solver(
            beam, support=support, coupling=coupling, extensible=extensible, clamp_angle=th0, options=options
        )
        load = Load(fld.Bx, fld.Bz, g)
        ok, th, _, its = solver.newton(solver.theta, load, maxiter=100)
        solver.newton_its += its
        status = 0
        if ok:
            solver.theta, solver.load = th, load
            tail, ver = solver.refine()
        else:
            status, tail, ver = 3, math.nan, math.nan
            solver.load = load
        return solver.result(ok, status, False, fld, g, tail, ver, wall_time=time.perf_counter() - t_start)

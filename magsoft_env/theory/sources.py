"""Planar equilibria in a non-uniform field: couples ``m x B`` and gradient forces ``G^T m`` on every piece.

A cantilever clamped at the origin with angle ``theta_0`` bends in the x-z plane (theta from +x toward +z). Its
piece at arc length s has the moment per length ``m(s) = m_c t + m_s n`` (A m; ``t = (cos theta, sin theta)``,
``n = (-sin theta, cos theta)``, ``m_c = m cos beta``, ``m_s = m sin beta``, ``m_s = 0`` for the paper's
coupling) at the position ``r(s) = int_0^s t``, where a field source gives ``B(r)`` and ``G(r) = dB/dx``. The
loads per length are the couple ``c = m_x B_z - m_z B_x`` (about -y: toward larger theta) and the force
``f = G^T m - rho A g e_z``. With ``F(s) = int_s^L f`` the force the part beyond s carries, moment balance is::

    E I theta'(s) = int_s^L h(u) du,     h = c + t x F    (a x b = a_x b_z - a_z b_x)

and the solver finds theta at the Chebyshev nodes of the integral form
``theta = theta_0 + P h(theta)``, ``P = Q0 diag(1/EI) QL``, where ``h`` depends on the whole shape through the
positions (the loads are non-local, unlike a uniform field's). In a uniform field ``f`` is the weight alone and
this is :mod:`magsoft_env.theory.model`'s equation.

The loads are conservative (energy ``int EI/2 theta'^2 - m . B(r) + rho A g z``), so the linearized operator
``J = I - P dh/dtheta`` has real eigenvalues ``mu``: those of ``H v = mu K v`` with ``H`` the second variation
and ``K`` its bending part. The equilibrium is stable when the smallest ``mu`` is positive (``mu = 1`` unloaded,
``0`` at a fold). The force's derivative in position needs the source's second derivatives: they are taken by
central differences of ``G`` (``HESSIAN_STEP`` of L), which only shapes Newton's steps and the stability test,
not the equations that are solved and verified.

A loading path is a sequence of sources: the first is switched on from zero (its strength ramped, after
gravity), and between consecutive sources the fields and gradients are blended linearly. To follow a magnet
that approaches, give its positions in small steps (each step's blend is then close to a moved magnet).

The result is verified independently of the collocation operators (:func:`source_residual`: Gauss-Legendre
panels, positions and loads recomputed there), and :func:`shoot` is an independent shooting solver of the same
boundary-value problem for checks.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from dataclasses import field as dc_field
from functools import cached_property

import numpy as np
import scipy.linalg

from ..spec import Beam, Field
from .collocation import Grid, finer_grid, make_grid
from .options import MAX_TOTAL_NODES, SolverOptions, subdomain_edges
from .result import PathResult, PlanarShape
from .verify import _points, outcome

#: Step of the central differences of G for the force's position derivative (fraction of L).
HESSIAN_STEP = 1e-4
#: Largest |B| (T) on the beam that the solver follows: beyond it the beam has reached the source.
MAX_FIELD_ON_BEAM = 5.0
_MAX_NEWTON = 12
_MAX_STEP_RAD = 0.6
_JUMP_RAD = 0.3
_STEP_RAD = 0.5  # largest predicted change of theta in one continuation step (rad)
_MAX_STEPS = 4000
_MAX_JUMPS = 40
_DESCENT_ITS = 3000
_VERIFY_MARGIN = 0.1
_MAX_REFINEMENTS = 12


def is_source(obj) -> bool:
    """Whether ``obj`` is a field source (has ``field_and_gradient``), not a uniform field given by numbers."""
    return callable(getattr(obj, "field_and_gradient", None))


def uniform_field(source) -> Field | None:
    """The Field of a :class:`~magsoft_env.fields.Uniform` source (today's uniform path, bit for bit), else None."""
    from ..fields import Uniform

    return Field(*source.B) if isinstance(source, Uniform) else None


def _check_source(i: int, source):
    if not is_source(source) or hasattr(source, "at_currents"):
        raise ValueError(f"sources[{i}] must be a field source with field_and_gradient(points), got "
                         f"{type(source).__name__}" + (" (a CoilSystem needs its currents: coils.at_currents(I))"
                                                       if hasattr(source, "at_currents") else "") + ".")
    B, G = source.field_and_gradient(np.zeros((1, 3)))
    if np.shape(B) != (1, 3) or np.shape(G) != (1, 3, 3):
        raise ValueError(f"sources[{i}].field_and_gradient must return B (n, 3) and G (n, 3, 3), got shapes "
                         f"{np.shape(B)} and {np.shape(G)}.")
    return source


@dataclass(frozen=True)
class _Load:
    """Sources with weights (a blend along the path) and gravity (m/s^2)."""

    terms: tuple  # ((weight, source), ...)
    g: float

    def evaluate(self, pts: np.ndarray):
        B = np.zeros((pts.shape[0], 3))
        G = np.zeros((pts.shape[0], 3, 3))
        for w, src in self.terms:
            if w != 0.0:
                b, gg = src.field_and_gradient(pts)
                B += w * b
                G += w * gg
        return B, G


def _between(a, b, t: float):
    """The source a fraction ``t`` of the way from source ``a`` to source ``b`` where both are the same magnet at
    two poses (a point dipole, or one source placed by ``Transformed``): the pose is interpolated, so a path of
    positions follows the moving magnet itself. None where the two cannot be interpolated (then fields blend)."""
    from ..fields import PointDipole, Transformed

    if type(a) is not type(b):
        return None
    if isinstance(a, PointDipole):
        pa, pb = np.array(a.position), np.array(b.position)
        ma, mb = np.array(a.moment), np.array(b.moment)
        return PointDipole(position=pa + t * (pb - pa), moment=ma + t * (mb - ma))
    if isinstance(a, Transformed) and a.source is b.source:
        from scipy.spatial.transform import Rotation, Slerp

        rot = Slerp([0.0, 1.0], Rotation.from_matrix(np.stack([a.rotation, b.rotation])))([t]).as_matrix()[0]
        pa, pb = np.asarray(a.position, float), np.asarray(b.position, float)
        return Transformed(a.source, position=pa + t * (pb - pa), rotation=rot)
    return None


def _blend(a: _Load, b: _Load, t: float) -> _Load:
    """The load a fraction ``t`` of the way from ``a`` to ``b``: one magnet at two poses moves between them,
    anything else has its fields and gradients blended linearly (exact for coil currents); gravity is blended."""
    if t >= 1.0:
        return b
    g = a.g + t * (b.g - a.g)
    if len(a.terms) == 1 and len(b.terms) == 1 and a.terms[0][0] == 1.0 and b.terms[0][0] == 1.0:
        mid = _between(a.terms[0][1], b.terms[0][1], t)
        if mid is not None:
            return _Load(((1.0, mid),), g)
    return _Load(tuple((w * (1 - t), s) for w, s in a.terms) + tuple((w * t, s) for w, s in b.terms), g)


class _Model:
    """One beam on one grid: coefficients, loads, residual and Jacobian of the integral form."""

    def __init__(self, beam: Beam, grid: Grid, coupling: str, theta0: float):
        self.beam, self.grid, self.theta0 = beam, grid, theta0
        s = grid.s_eval
        self.EI = beam.bending_stiffness(s)
        m = beam.moment_per_length(s)
        beta = beam.beta(s)
        self.mc = m * np.cos(beta)
        self.ms = m * np.sin(beta) if coupling == "rotated" else np.zeros_like(m)
        self.rhoA = beam.mass_per_length(s)
        self.Q0, self.QL, self.w = grid.Q0, grid.QL, grid.w
        self.P = grid.Q0 @ (grid.QL / self.EI[:, None])
        self.h_step = HESSIAN_STEP * beam.length
        self.EI_ref = float(grid.w @ self.EI) / beam.length

    def frame(self, th):
        c, sn = np.cos(th), np.sin(th)
        pts = np.zeros((th.size, 3))
        pts[:, 0] = self.Q0 @ c
        pts[:, 2] = self.Q0 @ sn
        mx = self.mc * c - self.ms * sn
        mz = self.mc * sn + self.ms * c
        return c, sn, pts, mx, mz

    def loads(self, th, load: _Load):
        """h at the nodes, and what the Jacobian reuses."""
        c, sn, pts, mx, mz = self.frame(th)
        B, G = load.evaluate(pts)
        couple = mx * B[:, 2] - mz * B[:, 0]
        fx = G[:, 0, 0] * mx + G[:, 2, 0] * mz
        fz = G[:, 0, 2] * mx + G[:, 2, 2] * mz - load.g * self.rhoA
        Fx, Fz = self.QL @ fx, self.QL @ fz
        h = couple + c * Fz - sn * Fx
        return h, (c, sn, pts, mx, mz, B, G, Fx, Fz)

    def residual(self, th, load: _Load):
        h, aux = self.loads(th, load)
        return th - self.theta0 - self.P @ h, h, aux

    def dh(self, th, load: _Load, aux):
        """dh/dtheta (M, M)."""
        c, sn, pts, mx, mz, B, G, Fx, Fz = aux
        M = th.size
        # dm/dtheta (rotate by 90 degrees), dr_i/dtheta_k = Q0[i, k] n_k
        dmx, dmz = -mz, mx
        nx, nz = -sn, c
        # second derivatives of B by central differences of G along x and z (in-plane only)
        hs = self.h_step
        off = np.zeros((4 * M, 3))
        for k, (ax, sg) in enumerate(((0, 1), (0, -1), (2, 1), (2, -1))):
            off[k * M:(k + 1) * M] = pts
            off[k * M:(k + 1) * M, ax] += sg * hs
        _, Gd = load.evaluate(off)
        Gx = (Gd[:M] - Gd[M:2 * M]) / (2 * hs)  # dG/dx
        Gz = (Gd[2 * M:3 * M] - Gd[3 * M:]) / (2 * hs)  # dG/dz
        # couple: local part through m, position part through B
        dcouple_local = dmx * B[:, 2] - dmz * B[:, 0]
        ax_ = mx * G[:, 2, 0] - mz * G[:, 0, 0]  # d couple / dx
        az_ = mx * G[:, 2, 2] - mz * G[:, 0, 2]  # d couple / dz
        D = self.Q0 * (ax_[:, None] * nx[None, :] + az_[:, None] * nz[None, :])
        D[np.diag_indices(M)] += dcouple_local
        # force per length: f_b = G[a, b] m_a; local part through m, position part through G
        dfx_local = G[:, 0, 0] * dmx + G[:, 2, 0] * dmz
        dfz_local = G[:, 0, 2] * dmx + G[:, 2, 2] * dmz
        fx_x = Gx[:, 0, 0] * mx + Gx[:, 2, 0] * mz
        fx_z = Gz[:, 0, 0] * mx + Gz[:, 2, 0] * mz
        fz_x = Gx[:, 0, 2] * mx + Gx[:, 2, 2] * mz
        fz_z = Gz[:, 0, 2] * mx + Gz[:, 2, 2] * mz
        Dfx = self.Q0 * (fx_x[:, None] * nx[None, :] + fx_z[:, None] * nz[None, :])
        Dfz = self.Q0 * (fz_x[:, None] * nx[None, :] + fz_z[:, None] * nz[None, :])
        Dfx[np.diag_indices(M)] += dfx_local
        Dfz[np.diag_indices(M)] += dfz_local
        dFx, dFz = self.QL @ Dfx, self.QL @ Dfz
        D += c[:, None] * dFz - sn[:, None] * dFx
        D[np.diag_indices(M)] += -sn * Fz - c * Fx  # d t / d theta = n
        return D

    def jacobian(self, th, load, aux):
        return np.eye(th.size) - self.P @ self.dh(th, load, aux)

    def energy(self, th, load: _Load) -> float:
        c, sn, pts, mx, mz = self.frame(th)
        B, _ = load.evaluate(pts)
        k = self.grid.derivative(th)
        dens = 0.5 * self.EI * k * k - (mx * B[:, 0] + mz * B[:, 2]) + load.g * self.rhoA * pts[:, 2]
        return float(self.w @ dens)

    def field_on_beam(self, th, load: _Load) -> float:
        _, _, pts, _, _ = self.frame(th)
        B, _ = load.evaluate(pts)
        return float(np.max(np.linalg.norm(B, axis=1)))


def _stability(J) -> tuple[float, np.ndarray]:
    """Smallest real eigenvalue mu of J (see the module docstring) and its mode (max-norm 1, tip >= 0)."""
    vals, vecs = scipy.linalg.eig(J)
    k = int(np.argmin(vals.real))
    v = vecs[:, k].real
    v = v / max(float(np.max(np.abs(v))), 1e-300)
    return float(vals[k].real), (v if v[-1] >= 0 else -v)


@dataclass(frozen=True, kw_only=True)
class SourceResult(PlanarShape, PathResult):
    """Planar equilibrium of a cantilever in a field source (frozen): a
    :class:`~magsoft_env.theory.result.PathResult` with the planar shape, like
    :class:`~magsoft_env.theory.solver.EquilibriumResult`.

    Attributes (beyond PathResult's)
    --------------------------------
    theta, x, z : (n,) ndarray
        Tangent angle (rad, from +x toward +z) and deformed centreline (m), clamp at the origin.
    tip_angle, rotation_angle : float
        theta(L) and the chord angle atan2(z_L, x_L) (rad).
    source : object
        The field source of this result (the last of its path).
    field : Field
        The source's field at the deformed tip (T), each component clipped to +-1 T: a reading, not the load (the
        load varies along the beam).
    tip_field : (3,) ndarray
        The same, unclipped (T).
    clamp_force : (2,) ndarray
        The force (x, z) the beam's loads put on the clamp (N): the integral of the force per length.
    clamp_moment : float
        The bending moment at the clamp, ``E I theta'(0)`` (N m).
    min_eigenvalue : float
        Smallest eigenvalue ``mu`` of ``H v = mu K v`` (dimensionless: 1 unloaded, 0 at a fold, negative when
        unstable), H the second variation, K its bending part.
    out_of_plane : float
        Largest out-of-plane load on the beam (force along y, couple about x and z) relative to the in-plane
        ones: the planar model drops it; above about 1e-6 the 3D problem differs.
    """

    theta: np.ndarray
    x: np.ndarray
    z: np.ndarray
    tip_angle: float
    rotation_angle: float
    source: object = None
    min_eigenvalue: float = math.nan
    out_of_plane: float = 0.0
    tip_field: np.ndarray | None = None
    clamp_force: np.ndarray | None = None
    clamp_moment: float = math.nan
    _grid: Grid | None = dc_field(default=None, repr=False, compare=False)
    _full: tuple | None = dc_field(default=None, repr=False, compare=False)

    @cached_property
    def loads(self) -> dict:
        """Couple per length (N m/m, about -y) and force per length (N/m, x and z) of the source at the nodes."""
        th = self.theta
        beam = self._beam
        m, beta = beam.moment_per_length(self.s), beam.beta(self.s)
        mx, mz = m * np.cos(th + beta), m * np.sin(th + beta)
        B, G = self.source.field_and_gradient(self.centreline)
        return {"couple": mx * B[:, 2] - mz * B[:, 0],
                "force_x": G[:, 0, 0] * mx + G[:, 2, 0] * mz, "force_z": G[:, 0, 2] * mx + G[:, 2, 2] * mz}

    _beam: object = dc_field(default=None, repr=False, compare=False)
    _coupling: str = dc_field(default="rotated", repr=False, compare=False)

    def to_dict(self) -> dict:
        return {
            **self._status_dict(),
            "field_at_tip_T": [self.field.Bx, self.field.By, self.field.Bz],
            "tip_x_m": float(self.x[-1]),
            "tip_z_m": float(self.z[-1]),
            "tip_deflection_m": self.tip_deflection,
            "tip_angle_deg": math.degrees(self.tip_angle),
            "rotation_angle_deg": math.degrees(self.rotation_angle),
            "min_eigenvalue": self.min_eigenvalue,
            "out_of_plane": self.out_of_plane,
        }


def source_residual(beam: Beam, grid: Grid, theta_nodes, load: _Load, *, coupling: str, theta0: float) -> float:
    """Largest residual (rad) of the interpolant of ``theta_nodes`` between the nodes, independent of the solver.

    At Gauss-Legendre panel points (:mod:`magsoft_env.theory.verify`) the shape is interpolated, the positions
    integrated by panel quadrature, the source evaluated there and the moment integrated back:
    ``|theta(s) - theta(0) - int_0^s (1/EI) int_t^L h|`` and ``|theta(0) - theta_0|``.
    """
    pts = _points(beam, grid)
    th = pts.Ith @ theta_nodes
    c, sn = np.cos(th), np.sin(th)
    P = np.zeros((th.size, 3))
    P[:, 0] = pts.before(c)
    P[:, 2] = pts.before(sn)
    msin = pts.msin if coupling == "rotated" else 0.0 * pts.msin
    mx = pts.mcos * c - msin * sn
    mz = pts.mcos * sn + msin * c
    B, G = load.evaluate(P)
    couple = mx * B[:, 2] - mz * B[:, 0]
    Fx = pts.beyond(G[:, 0, 0] * mx + G[:, 2, 0] * mz)
    Fz = pts.beyond(G[:, 0, 2] * mx + G[:, 2, 2] * mz) - load.g * pts.W1
    h = couple + c * Fz - sn * Fx
    start = float(theta_nodes[0])
    r = np.abs(th - start - pts.before(pts.beyond(h) / pts.EI))
    out = max(float(np.max(r)), abs(start - theta0))
    return out if math.isfinite(out) else math.nan


class _SourceSolver:
    """Continuation state of one cantilever along a path of sources."""

    def __init__(self, beam: Beam, coupling: str, theta0: float, options: SolverOptions):
        self.beam, self.coupling, self.theta0, self.opt = beam, coupling, theta0, options
        bps = subdomain_edges(beam, options.split_at_knots)
        L = beam.length
        edges = make_grid(L, bps, n=8, max_domain=options.max_domain * L).edges
        n = options.nodes if options.nodes is not None else min(24 if not bps else 16,
                                                                MAX_TOTAL_NODES // (len(edges) - 1) - 1)
        self._set_grid(make_grid(L, bps, n=n, max_domain=options.max_domain * L))
        self.theta = np.full(self.grid.M, theta0)
        self.load = _Load((), 0.0)  # unloaded
        self.events: list[dict] = []
        self.newton_its = 0
        self.note = ""
        self.mu, self.mode = 1.0, None

    def _set_grid(self, grid: Grid):
        self.grid = grid
        self.model = _Model(self.beam, grid, self.coupling, self.theta0)

    def newton(self, th, load: _Load, maxiter: int = _MAX_NEWTON):
        mdl = self.model
        th = th.copy()
        prev = math.inf
        for it in range(1, maxiter + 1):
            R, _, aux = mdl.residual(th, load)
            J = mdl.jacobian(th, load, aux)
            try:
                d = np.linalg.solve(J, R)
            except np.linalg.LinAlgError:
                return False, th, it, None
            big = float(np.max(np.abs(d)))
            if not math.isfinite(big):
                return False, th, it, None
            if it >= 3 and big > 0.25 * prev and maxiter <= _MAX_NEWTON:
                return False, th, it, None
            if big > _MAX_STEP_RAD:
                d *= _MAX_STEP_RAD / big
            th = th - d
            if big < self.opt.tol or (it >= 2 and big ** 3 < self.opt.tol * prev ** 2 and big < 1e-5):
                if mdl.field_on_beam(th, load) > MAX_FIELD_ON_BEAM:
                    return False, th, it, None
                R, _, aux = mdl.residual(th, load)
                return True, th, it, mdl.jacobian(th, load, aux)
            prev = big
        return False, th, maxiter, None

    def _rate(self, th, a: _Load, b: _Load, t: float, J):
        """d theta / d t along the path from a to b at t (central differences in t; exact where the load is
        linear in t)."""
        mdl = self.model
        d = 1e-6
        lo, hi = max(0.0, t - d), min(1.0, t + d)
        dh = (mdl.loads(th, _blend(a, b, hi))[0] - mdl.loads(th, _blend(a, b, lo))[0]) / (hi - lo)
        return np.linalg.solve(J, mdl.P @ dh)

    def descend(self, th, load: _Load):
        """Energy descent (the residual is the K^-1 preconditioned gradient) to a stable equilibrium."""
        mdl = self.model
        E = mdl.energy(th, load)
        alpha = 0.5
        self._descent_field = max(getattr(self, "_descent_field", 0.0), mdl.field_on_beam(th, load))
        for _ in range(_DESCENT_ITS):
            R, _, _ = mdl.residual(th, load)
            if float(np.max(np.abs(R))) < 1e-4:
                ok, th2, its, J = self.newton(th, load)
                self.newton_its += its
                if ok:
                    mu, v = _stability(J)
                    if mu > -1e-9:
                        return True, th2, J
                    th = th2 + 1e-2 * v  # a saddle: leave along its mode
                    E = mdl.energy(th, load)
                    continue
            while alpha > 1e-12:
                trial = th - alpha * R
                Et = mdl.energy(trial, load)
                if Et < E - 1e-4 * alpha * float(R @ (mdl.w * R)) * mdl.EI_ref and math.isfinite(Et):
                    break
                alpha *= 0.5
            else:
                return False, th, None
            self._descent_field = max(self._descent_field, mdl.field_on_beam(trial, load))
            if self._descent_field > MAX_FIELD_ON_BEAM:
                self.note = "The beam reached the source (the field on it exceeded " \
                            f"{MAX_FIELD_ON_BEAM:g} T): there is no equilibrium beyond the snap."
                return False, th, None
            th, E = trial, Et
            alpha = min(1.0, 2.0 * alpha)
        return False, th, None

    def continue_to(self, target: _Load) -> bool:
        """Follow the equilibrium from the current load to ``target`` (t from 0 to 1 along the blend)."""
        start = self.load
        t, dt = 0.0, 1.0
        J = None
        steps = jumps = 0
        while t < 1.0:
            steps += 1
            if steps > _MAX_STEPS or jumps > _MAX_JUMPS:
                self.note = f"The continuation used up its work bound ({_MAX_STEPS} steps, {_MAX_JUMPS} jumps)."
                return False
            if J is None:
                ld = _blend(start, target, t)
                R, _, aux = self.model.residual(self.theta, ld)
                J = self.model.jacobian(self.theta, ld, aux)
            rate = self._rate(self.theta, start, target, t, J)
            big = float(np.max(np.abs(rate)))
            dt = min(dt, 1.0 - t, _STEP_RAD / big if big > 0 else 1.0)
            t_new = t + dt
            pred = self.theta + dt * rate
            ld_new = _blend(start, target, t_new)
            ok, th, its, J_new = self.newton(pred, ld_new)
            self.newton_its += its
            if ok and float(np.max(np.abs(th - pred))) > _JUMP_RAD:
                ok = False
            mu = v = None
            if ok:
                mu, v = _stability(J_new)
                if mu < -1e-9 and self.mu >= -1e-9:
                    ok = False  # crossed into instability: step back and approach the fold
            if ok:
                t, self.theta, J, self.mu, self.mode = t_new, th, J_new, mu, v
                self.load = ld_new
                dt = min(1.0, 2.0 * dt)
                continue
            dt *= 0.25
            if dt >= self.opt.min_step:
                continue
            # a fold (or a bifurcation) at t: jump beyond it by energy descent
            if self.mu >= 0.05:
                near = self.model.field_on_beam(pred, ld_new)
                self.note = (f"Newton did not converge for load steps down to {self.opt.min_step:g} at load "
                             f"fraction {t:.6f}, away from a fold (smallest eigenvalue {self.mu:.3g}); the largest "
                             f"field on the predicted shape was {near:.3g} T")
                self.note += (": the beam reaches the source there (a point source's field diverges)." if
                              near > MAX_FIELD_ON_BEAM else ".")
                return False
            t_j = min(1.0, t + max(100 * self.opt.min_step, 1e-3))
            ld_j = _blend(start, target, t_j)
            self.events.append({"kind": "fold", "load_fraction": float(t), "gravity": target.g,
                                "min_eigenvalue": float(self.mu), "converged": False})
            jumps += 1
            mode = self.mode if self.mode is not None else np.zeros_like(self.theta)
            best = None
            for sign in (1.0, -1.0):
                okd, thd, Jd = self.descend(self.theta + sign * 0.05 * mode, ld_j)
                if okd:
                    E = self.model.energy(thd, ld_j)
                    if best is None or E < best[0]:
                        best = (E, thd, Jd)
            if best is None:
                if not self.note:
                    self.note = (f"No stable equilibrium found beyond the fold at load fraction {t:.6f}: energy "
                                 f"descent from it did not settle (the largest field on the beam reached "
                                 f"{self._descent_field:.3g} T). A beam that snaps onto a magnet has no equilibrium "
                                 "in this model, which has no contact with the source.")
                return False
            self.events[-1]["converged"] = True
            t, self.theta, J = t_j, best[1], best[2]
            self.mu, self.mode = _stability(J)
            self.load = ld_j
            dt = 1e-2
        self.load = target
        return True

    def verify(self) -> float:
        return source_residual(self.beam, self.grid, self.theta, self.load, coupling=self.coupling,
                               theta0=self.theta0)

    def refine(self) -> tuple[float, float]:
        tail, ver = self.grid.tail(self.theta), self.verify()
        if self.opt.nodes is not None:
            return tail, ver
        good = (self.grid, self.theta)
        for _ in range(_MAX_REFINEMENTS):
            if tail <= self.opt.resolution_tol and ver <= _VERIFY_MARGIN * self.opt.verify_tol:
                break
            g0, th0 = good
            new = self._next_grid(g0, th0)
            if new is None:
                break
            self._set_grid(new)
            ok, th, its, _ = self.newton(g0.interpolate(th0, new.s), self.load)
            self.newton_its += its
            if not ok:
                break
            self.theta = th
            tail, ver = new.tail(th), self.verify()
            good = (new, th)
        if self.grid is not good[0]:
            self._set_grid(good[0])
        self.theta = good[1]
        return tail, ver

    def _next_grid(self, grid: Grid, theta) -> Grid | None:
        """A finer grid than ``grid`` (:func:`~magsoft_env.theory.collocation.finer_grid`)."""
        return finer_grid(grid, theta, max_nodes=self.opt.max_nodes, max_total=MAX_TOTAL_NODES)

    def result(self, ok: bool, snapped: bool, source, tail, ver, wall_time) -> SourceResult:
        mdl, grid, th = self.model, self.grid, self.theta
        load = self.load
        R, h, aux = mdl.residual(th, load)
        c, sn, pts, mx, mz, B, G, Fx, Fz = aux
        J = mdl.jacobian(th, load, aux)
        mu, _ = _stability(J)
        x, z = pts[:, 0], pts[:, 2]
        u = grid.unique()
        chord = math.atan2(z[-1], x[-1])
        mean_angle = float(grid.w @ th) / self.beam.length
        chord += 2 * math.pi * round((mean_angle - chord) / (2 * math.pi))
        # out-of-plane loads the planar model drops, relative to the in-plane ones
        fy = G[:, 0, 1] * mx + G[:, 2, 1] * mz
        cx = -mz * B[:, 1]
        cz = mx * B[:, 1]
        inplane = float(np.max(np.abs(mx * B[:, 2] - mz * B[:, 0])))
        inplane = max(inplane + float(np.max(np.abs(Fx)) + np.max(np.abs(Fz))) * self.beam.length, 1e-300)
        oop = (float(np.max(np.abs(cx)) + np.max(np.abs(cz))) + float(np.max(np.abs(fy))) * self.beam.length) / inplane
        status, msg = outcome(ok, 0, tail, ver, self.opt, note=self.note,
                              events=sum(bool(e.get("converged")) for e in self.events),
                              nodes=int(u.size), messages=_MESSAGES)
        if ok and oop > 1e-6:
            msg += (f" The source also loads the beam out of its plane ({oop:.1e} of the in-plane loads), which the "
                    "planar model drops.")
        tipB = B[-1]
        return SourceResult(
            success=ok and status in (0, 2), status=status, message=msg, s=grid.s[u], theta=th[u].copy(),
            x=x[u].copy(), z=z[u].copy(), tip_angle=float(th[-1]), tip_deflection=float(z[-1]),
            rotation_angle=chord, max_curvature=float(np.max(np.abs(grid.derivative(th)))),
            stable=bool(mu > -1e-9), snap_through=snapped, field=Field(*(float(v) for v in np.clip(tipB, -1.0, 1.0))),
            tip_field=tipB.copy(), clamp_force=np.array([Fx[0], Fz[0]]), clamp_moment=float(mdl.w @ h),
            gravity=load.g, residual=float(np.max(np.abs(R))), resolution=max(tail, ver) if ok else math.nan,
            verification=float(ver) if ok else math.nan, nodes=int(u.size), newton_iterations=self.newton_its,
            events=list(self.events), wall_time=float(wall_time), source=source, min_eigenvalue=float(mu),
            out_of_plane=float(oop), _grid=grid, _full=(th.copy(), x.copy(), z.copy()), _beam=self.beam,
            _coupling=self.coupling)


_MESSAGES = {
    0: "Converged: equilibrium found along the loading path (field source).",
    1: "Continuation stalled.",
    2: "Converged, but the solution is not resolved to the requested tolerance on the finest grid allowed.",
    4: "Not verified: the solution satisfies the equations at the collocation nodes but not between them.",
}


def solve_source_path(beam: Beam, sources, *, gravity: float, coupling: str, clamp_angle: float,
                      options: SolverOptions, progress: bool = False) -> list[SourceResult]:
    """Equilibria of a planar cantilever along a path of field sources (see the module docstring).

    Checked input is expected (:func:`magsoft_env.theory.solver.solve_path` checks it): ``sources`` a
    non-empty sequence of sources, ``gravity`` >= 0 (m/s^2), ``coupling`` "rotated" or "paper".
    """
    sources = [_check_source(i, s) for i, s in enumerate(sources)]
    t0 = time.perf_counter()
    sol = _SourceSolver(beam, coupling, clamp_angle, options)
    ok = True
    if gravity > 0:
        ok = sol.continue_to(_Load((), gravity))
    out = []
    it = sources
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(sources, desc="equilibria", unit="source")
    prev = t0
    for src in it:
        target = _Load(((1.0, src),), gravity)
        n_events = len(sol.events)
        if ok:
            ok = sol.continue_to(target)
        tail, ver = sol.refine() if ok else (math.nan, math.nan)
        now = time.perf_counter()
        out.append(sol.result(ok, len(sol.events) > n_events, src, tail, ver, now - prev))
        prev = now
    return out


# -------------------------------------------------------------------------------------------------------------------
def shoot(beam: Beam, source, *, gravity: float = 0.0, clamp_angle: float = 0.0, coupling: str = "rotated",
          guess=None, steps: int = 10, rtol: float = 1e-12) -> dict:
    """An independent shooting solution of the same problem, for checks (no collocation, no shared operators).

    Integrates ``x' = cos theta, z' = sin theta, theta' = M/EI, N' = -f, M' = -(c + t x N)`` from the clamp with
    scipy's DOP853 and finds the clamp's force ``N(0)`` and moment ``M(0)`` so that ``N(L) = M(L) = 0``
    (scipy.optimize.root), ramping gravity and then the source's strength in ``steps`` steps each from zero, each
    from the last (or from ``guess``, a triple ``(N_x(0), N_z(0), M(0))``, in one step). Piecewise-smooth beams are
    integrated piece by piece. Returns ``{"s", "x", "z", "theta", "unknowns", "residual", "success"}``.
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    L = beam.length
    edges = [0.0, *subdomain_edges(beam), L]

    def rhs(s, y, scale, gscale, a, b):
        x, z, th, Nx, Nz, Mb = y
        s_ = np.array([min(max(s, a + 1e-12 * L), b - 1e-12 * L)])  # a piece's own side of a jump
        EI = float(beam.bending_stiffness(s_)[0])
        m = float(beam.moment_per_length(s_)[0])
        b = float(beam.beta(s_)[0])
        if coupling == "rotated":
            mx, mz = m * math.cos(th + b), m * math.sin(th + b)
        else:  # the paper's form: the axial part only
            mx, mz = m * math.cos(b) * math.cos(th), m * math.cos(b) * math.sin(th)
        if scale:
            B, G = source.field_and_gradient(np.array([[x, 0.0, z]]))
            B, G = scale * B[0], scale * G[0]
        else:
            B, G = np.zeros(3), np.zeros((3, 3))
        c = mx * B[2] - mz * B[0]
        fx = G[0, 0] * mx + G[2, 0] * mz
        fz = G[0, 2] * mx + G[2, 2] * mz - gscale * gravity * float(beam.mass_per_length(s_)[0])
        return [math.cos(th), math.sin(th), Mb / EI, -fx, -fz, -(c + math.cos(th) * Nz - math.sin(th) * Nx)]

    def integrate(u, scale, gscale, tol, dense=False):
        y = np.array([0.0, 0.0, clamp_angle, *u])
        pieces = []
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=tol, atol=tol * 1e-3, args=(scale, gscale, a, b),
                            dense_output=dense)
            y = sol.y[:, -1]
            pieces.append(sol)
        return y, pieces

    EImax = float(np.max(beam.bending_stiffness(np.linspace(0.0, L, 65))))

    def F(u, scale, gscale, tol):
        y, _ = integrate(u, scale, gscale, tol)
        return [y[3], y[4], y[5] * L / EImax]

    u = np.zeros(3) if guess is None else np.asarray(guess, float)
    # gravity first, then the source's strength, each ramped; coarse tolerances on the way, rtol at the end
    if guess is not None:
        ramp = [(1.0, 1.0)]
    else:
        ramp = [(0.0, k / steps) for k in range(1, steps + 1)] if gravity else []
        ramp += [(k / steps, 1.0) for k in range(1, steps + 1)]
    ok = True
    for i, (sc, gs) in enumerate(ramp):
        last = i == len(ramp) - 1
        r = root(F, u, args=(sc, gs, rtol if last else max(rtol, 1e-8)), method="hybr",
                 options={"xtol": 1e-14 if last else 1e-9})
        u = r.x
        ok = bool(r.success) or float(np.max(np.abs(r.fun))) < 1e-12  # hybr flags an xtol it cannot reach
    y, pieces = integrate(u, 1.0, 1.0, rtol, dense=True)
    s = np.linspace(0.0, L, 201)
    vals = np.concatenate([p.sol(np.clip(s[(s >= p.t[0]) & ((s < p.t[-1]) | (s == L))], p.t[0], p.t[-1]))
                           for p in pieces], axis=1) if len(pieces) == 1 else None
    if vals is None:
        parts = []
        for p in pieces:
            sel = (s >= p.t[0]) & (s <= p.t[-1])
            parts.append((s[sel], p.sol(s[sel])))
        ss = np.concatenate([q[0] for q in parts])
        vv = np.concatenate([q[1] for q in parts], axis=1)
        _, idx = np.unique(ss, return_index=True)
        s, vals = ss[idx], vv[:, idx]
    res = abs(y[3]) + abs(y[4]) + abs(y[5])
    return {"s": s, "x": vals[0], "z": vals[1], "theta": vals[2], "unknowns": u, "residual": float(res),
            "success": ok, "tip": np.array([y[0], 0.0, y[1]])}


__all__ = ["HESSIAN_STEP", "MAX_FIELD_ON_BEAM", "SourceResult", "is_source", "shoot", "solve_source_path",
           "source_residual", "uniform_field"]

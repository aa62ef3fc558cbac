"""The 3D Kirchhoff rod (cantilever) in a non-uniform field source: couples and gradient forces on every piece.

The strip of :mod:`magsoft_env.theory.rod` (frames as unit quaternions at the Chebyshev nodes, clamped at the
origin) in a field source (:mod:`magsoft_env.fields`). Its piece at arc length s, at the position
``r(s) = int_0^s d3``, carries the moment per length ``R a`` (``a = (A B_r / mu0) m_hat`` in the material frame)
and feels the couple ``c = (R a) x B(r)`` and the force ``f = G(r)^T (R a) - rho A g z`` (``G[a, b] = dB_a/dx_b``).
The force the part beyond s carries is ``n(s) = int_s^L f``; it is no longer the weight alone, and the loads
depend on the positions, so on the whole shape (non-local). Moment balance is integrated from the free tip as in
the uniform field, ``m_s(s) = int_s^L (c + d3 x n)``, and the kinematics is collocated in integral form
(:meth:`RodModel.system`, unchanged: only :meth:`SourceRodModel.loads` differs).

Jacobian: the derivative of the couple density ``lam = c + d3 x n`` in a rotation ``psi_k`` at node k is local
(the frame turns ``R a`` and ``d3`` there) plus non-local (``d3_k`` moves every position beyond k,
``dr_i = -Q0_ik [d3_k]x psi_k``, which changes ``B`` and ``G`` there). The position derivative of the force,
``df/dr = sum_a (dG[a, :]/dr) (R a)_a``, needs the source's second derivatives: they are taken by central
differences of G (``HESSIAN_STEP`` of L, as in :mod:`magsoft_env.theory.sources`). Everything else is exact, so
the Jacobian is exact up to those differences (about 1e-8 relative); it only shapes Newton's steps and the
stability test, never the equations that are solved and verified. Cost: 7 M field evaluations and two dense
(M x M) by (M x 9 M) products per Jacobian, about the uniform field's.

Stability uses the linearization of the energy gradient ``-w lam + elastic`` (:meth:`RodModel.gradient`) with
the same non-local block, symmetrized: the energy is ``U = int 1/2 k.K k - (R a).B(r) + g W1 d3.z``, conservative,
so the second variation is symmetric up to the discretization (the position part of the discrete gradient uses
``int_s^L f`` where the discrete energy's own gradient has its quadrature transpose).

A loading path is a sequence of sources with the semantics of :mod:`magsoft_env.theory.sources` (``_blend``):
gravity first, the first source switched on from zero (its strength ramped), between consecutive sources one
magnet at two poses moves between them and anything else blends linearly. Continuation, fold and bifurcation
detection, energy descent, refinement and the work budget are :class:`~magsoft_env.theory.rod_solver.RodSolver`'s;
the tangent predictor differentiates the collocation residual along the path by central differences (the blend
of a moving magnet is not linear in the path parameter).

Every result is verified independently by :func:`magsoft_env.theory.verify.rod_source_residual` (positions and
loads recomputed at Gauss-Legendre panel points), and :func:`shoot3d` is an independent shooting solver of the
same boundary-value problem, for checks.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from ..spec import Beam, Field
from .collocation import Grid
from .options import SolverOptions, subdomain_edges
from .rod import RodModel, _left, _right, _skew, clamp_quaternion, qconj, qmat, qmul
from .rod_solver import _MAX_NEWTON, OVER_BUDGET, RodResult, RodSolver
from .sources import HESSIAN_STEP, MAX_FIELD_ON_BEAM, _blend, _check_source, _Load
from .verify import outcome, rod_source_residual

_CONJ = np.array([1.0, -1.0, -1.0, -1.0])
_RATE_STEP = 1e-6  # central difference of the residual along the path (fraction of a load step)


@dataclass(frozen=True)
class SourceLoad3(_Load):
    """One load state of the 3D rod in field sources: ``terms`` ((weight, source), ...) and gravity ``g`` (m/s^2).

    ``lerp`` moves along the path with :mod:`magsoft_env.theory.sources`' blend (one magnet at two poses moves,
    anything else blends linearly); ``B`` (and ``Bx``, ``By``, ``Bz``) is the field at the clamp (the origin), a
    reading for events, not the load (the load varies along the rod)."""

    def lerp(self, other: SourceLoad3, t: float) -> SourceLoad3:
        b = _blend(self, other, t)
        return b if isinstance(b, SourceLoad3) else SourceLoad3(b.terms, b.g)

    @property
    def B(self) -> np.ndarray:
        return self.evaluate(np.zeros((1, 3)))[0][0]

    @property
    def Bx(self) -> float:
        return float(self.B[0])

    @property
    def By(self) -> float:
        return float(self.B[1])

    @property
    def Bz(self) -> float:
        return float(self.B[2])


class SourceRodModel(RodModel):
    """The clamped rod of :class:`RodModel` with loads from a field source (positions-dependent, non-local)."""

    def __init__(self, beam, grid: Grid, *, clamp_angle: float = 0.0):
        super().__init__(beam, grid, free=False, clamp_angle=clamp_angle)
        self.rhoA = beam.mass_per_length(grid.s_eval)
        self.h_step = HESSIAN_STEP * self.L

    def positions(self, q):
        """Positions r (M, 3) (m) of the nodes, the clamp at the origin, and the frames R (M, 3, 3)."""
        R = qmat(q)
        return self.Q0 @ R[:, :, 2], R

    def source_loads(self, q, load: SourceLoad3, second: bool = False) -> dict:
        """Frames, positions, the source's field and gradient there, moments, force and couple density; with
        ``second`` also the position derivative of the force per length, ``Hf[j, b, c] = df_b / dx_c``."""
        if q.ndim != 2:
            raise ValueError("the source rod model takes one frame field (M, 4) at a time")
        r, R = self.positions(q)
        M = r.shape[0]
        if second:
            hs = self.h_step
            off = np.tile(r, (7, 1))
            for c in range(3):
                off[(1 + 2 * c) * M:(2 + 2 * c) * M, c] += hs
                off[(2 + 2 * c) * M:(3 + 2 * c) * M, c] -= hs
            Ball, Gall = load.evaluate(off)
            B, G = Ball[:M], Gall[:M]
        else:
            B, G = load.evaluate(r)
        ma = np.einsum("mij,mj->mi", R, self.a)
        d3 = R[:, :, 2]
        f = np.einsum("mab,ma->mb", G, ma)
        n = self.QL @ f
        if load.g:
            n[:, 2] -= load.g * self.W1
        lam = np.cross(ma, B) + np.cross(d3, n)
        out = {"R": R, "r": r, "B": B, "G": G, "ma": ma, "d3": d3, "f": f, "n": n, "lam": lam}
        if second:
            Hf = np.empty((M, 3, 3))
            for c in range(3):
                dG = (Gall[(1 + 2 * c) * M:(2 + 2 * c) * M] - Gall[(2 + 2 * c) * M:(3 + 2 * c) * M]) / (2 * hs)
                Hf[:, :, c] = np.einsum("mab,ma->mb", dG, ma)
            out["Hf"] = Hf
        return out

    def loads(self, q, load):
        """Frames R (M, 3, 3) and the couple density lam = c + d3 x n (M, 3) (N)."""
        ld = self.source_loads(q, load)
        return ld["R"], ld["lam"]

    def lam_derivative(self, ld: dict):
        """d lam_p / d psi_k (M, 3, M, 3): the local part (the frame at p turns) and the non-local one (a turn at
        k moves every position beyond it: B, G and so the couple and the force change there)."""
        R, B, G, ma, d3, n, Hf = ld["R"], ld["B"], ld["G"], ld["ma"], ld["d3"], ld["n"], ld["Hf"]
        M = R.shape[0]
        idx = np.arange(M)
        Sd3, Sma = _skew(d3), _skew(ma)
        # dr_i = -Q0_ik [d3_k]x psi_k
        # couple through the position: [ma_p]x G_p dr_p
        term1 = -self.Q0[:, None, :, None] * np.einsum("pab,kbc->pakc", Sma @ G, Sd3)
        # force: df_j = -G_j^T [ma_j]x psi_j + Hf_j dr_j, then dn = QL df and d3_p x dn_p
        Df = -self.Q0[:, None, :, None] * np.einsum("jab,kbc->jakc", Hf, Sd3)
        Df[idx, :, idx, :] -= np.swapaxes(G, 1, 2) @ Sma
        Dn = (self.QL @ Df.reshape(M, 9 * M)).reshape(M, 3, M, 3)
        Lam = term1 + np.einsum("pab,pbkc->pakc", Sd3, Dn)
        Lam[idx, :, idx, :] += _skew(B) @ Sma + _skew(n) @ Sd3
        return Lam

    def jacobian(self, q, load):
        """F and its Jacobian dF/dpsi (3 M, 3 M), as :meth:`RodModel.jacobian` with the non-local load block
        (position derivatives of the force by central differences of G; see the module docstring)."""
        M = q.shape[0]
        ld = self.source_loads(q, load, second=True)
        R, lam = ld["R"], ld["lam"]
        ms = self.QL @ lam
        Kinv = 1.0 / self.K
        k = np.einsum("mji,mj->mi", R, ms) * Kinv
        rate = 0.5 * qmul(q, np.concatenate([np.zeros((M, 1)), k], axis=1))
        G = q - self.Q0 @ rate - self.q0
        F = 2.0 * qmul(qconj(q), G)[:, 1:]
        Lq, Rq = _left(q), _right(q)
        T = 0.5 * Rq[:, :, 1:]
        Lam = self.lam_derivative(ld)
        RtK = np.swapaxes(R, 1, 2) * Kinv[:, :, None]
        A = 0.5 * Lq[:, :, 1:] @ RtK  # (M, 4, 3)
        Dm = (self.QL @ Lam.reshape(M, 9 * M)).reshape(M, 3, M, 3)  # d m_j / d psi_k
        Y = np.einsum("jab,jbkc->jakc", A, Dm)
        kq = np.concatenate([np.zeros((M, 1)), k], axis=1)
        idx = np.arange(M)
        Y[idx, :, idx, :] += 0.5 * _right(kq) @ T + A @ _skew(ms)
        dG = (self.Q0 @ Y.reshape(M, 12 * M)).reshape(M, 4, M, 3)
        dG *= -1.0
        dG[idx, :, idx, :] += T
        Lc = _left(qconj(q))[:, 1:, :]
        Jb = np.matmul(Lc, dG.reshape(M, 4, 3 * M)).reshape(M, 3, M, 3)
        Jb[idx, :, idx, :] += (_right(G)[:, 1:, :] * _CONJ) @ T
        Jb *= 2.0
        return F.reshape(-1), Jb.reshape(3 * M, 3 * M)

    def jacobian_cs(self, q, load):  # sources are real-valued: no complex step
        raise NotImplementedError("a field source is evaluated in real arithmetic: check the Jacobian by finite "
                                  "differences of system()")

    def hessian(self, q, load):
        """Gradient and symmetrized linearization of :meth:`RodModel.gradient` (with this model's loads) on
        the distinct nodes: :meth:`RodModel.hessian`'s elastic part and the non-local load block."""
        M = q.shape[0]
        n3 = 3 * M
        dq = self.D @ q
        k = 2.0 * qmul(qconj(q), dq)[:, 1:]
        Kk = np.concatenate([np.zeros((M, 1)), self.K * k], axis=1)
        u = qmul(q, Kk)
        V = self.D.T @ (self.w[:, None] * u)
        ld = self.source_loads(q, load, second=True)
        lam = ld["lam"]
        g = -self.w[:, None] * qmul(u, qconj(dq))[:, 1:] + qmul(V, qconj(q))[:, 1:] - self.w[:, None] * lam
        T = 0.5 * _right(q)[:, :, 1:]
        X = np.zeros((M, 4, n3))
        idx = np.arange(M)
        for c in range(3):
            X[idx, :, 3 * idx + c] = T[:, :, c]
        Xp = (self.D @ X.reshape(M, 4 * n3)).reshape(M, 4, n3)
        Lcq, Rdq = _left(qconj(q)), _right(dq)
        dk = 2.0 * (np.matmul(Lcq[:, 1:, :], Xp) + np.matmul(Rdq[:, 1:, :] * _CONJ, X))
        du = np.matmul(_right(Kk), X) + np.matmul(_left(q)[:, :, 1:] * self.K[:, None, :], dk)
        H = -self.w[:, None, None] * (np.matmul(_right(qconj(dq))[:, 1:, :], du)
                                      + np.matmul(_left(u)[:, 1:, :] * _CONJ, Xp))
        dV = (self.D.T @ (self.w[:, None, None] * du).reshape(M, 4 * n3)).reshape(M, 4, n3)
        H += np.matmul(_right(qconj(q))[:, 1:, :], dV) + np.matmul(_left(V)[:, 1:, :] * _CONJ, X)
        Hb = H.reshape(M, 3, M, 3)
        Hb -= self.w[:, None, None, None] * self.lam_derivative(ld)
        Hd = np.tensordot(self.E, Hb, axes=([0], [0]))
        Hd = np.tensordot(Hd, self.E, axes=([2], [0])).transpose(0, 1, 3, 2)
        nU = self.E.shape[1]
        Hd = Hd.reshape(3 * nU, 3 * nU)
        return (self.E.T @ g).reshape(-1), 0.5 * (Hd + Hd.T)

    def hessian_cs(self, q, load):
        raise NotImplementedError("a field source is evaluated in real arithmetic: no complex step")

    def energy(self, q, load) -> float:
        """Total potential energy (J): bending and twist, ``-(R a).B(r)`` and gravity ``g W1 d3.z``."""
        k = self.curvature(q)
        r, R = self.positions(q)
        B, _ = load.evaluate(r)
        ma = np.einsum("mij,mj->mi", R, self.a)
        dens = 0.5 * np.sum(self.K * k * k, axis=-1) - np.sum(ma * B, axis=1) + load.g * self.W1 * R[:, 2, 2]
        return float(self.w @ dens)

    def field_on_beam(self, q, load) -> float:
        r, _ = self.positions(q)
        B, _ = load.evaluate(r)
        return float(np.max(np.linalg.norm(B, axis=1)))

    def load_rate(self, q, dload):
        raise NotImplementedError("a path of sources is not linear in its parameter: see SourceRodSolver._tangent")


@lru_cache(maxsize=32)
def _model_cached(beam, grid, clamp_angle):
    return SourceRodModel(beam, grid, clamp_angle=clamp_angle)


def _source_model(beam, grid, clamp_angle):
    try:
        return _model_cached(beam, grid, clamp_angle)
    except TypeError:  # unhashable user callables
        return SourceRodModel(beam, grid, clamp_angle=clamp_angle)


@dataclass(frozen=True, kw_only=True)
class SourceRodResult(RodResult):
    """Equilibrium of a clamped strip in three dimensions in a field source (frozen): a
    :class:`~magsoft_env.theory.rod_solver.RodResult` (same status fields, shape, frames, :meth:`sample`).

    Attributes (beyond RodResult's)
    -------------------------------
    source : object
        The field source of this result (the last of its path).
    field : Field
        The source's field at the deformed tip (T), each component clipped to +-1 T: a reading, not the load.
    tip_field : (3,) ndarray
        The same, unclipped (T).
    clamp_force : (3,) ndarray
        The force the rod's loads put on the clamp, ``n(0) = int_0^L f`` (N): magnetic forces and weight.
    clamp_moment : (3,) ndarray
        The moment of the rod's loads about the clamp, ``m(0) = int_0^L (c + d3 x n)`` (N m), world axes.

    ``events`` report ``"field_T"`` as the field at the clamp (the origin).
    """

    source: object = None
    tip_field: np.ndarray | None = None
    clamp_force: np.ndarray | None = None
    clamp_moment: np.ndarray | None = None

    def to_dict(self) -> dict:
        d = super().to_dict()
        d["field_T"] = [float(v) for v in self.tip_field]
        d["clamp_force_N"] = [float(v) for v in self.clamp_force]
        d["clamp_moment_Nm"] = [float(v) for v in self.clamp_moment]
        return d


class SourceRodSolver(RodSolver):
    """:class:`RodSolver` (clamped) along a path of field sources."""

    def __init__(self, beam: Beam, *, clamp_angle: float, options: SolverOptions, edges: tuple):
        super().__init__(beam, support="cantilever", clamp_angle=clamp_angle, options=options, edges=edges)
        self.load = SourceLoad3((), 0.0)

    def _set_grid(self, grid: Grid):
        self.grid = grid
        self.model = _source_model(self.beam, grid, self.clamp_angle)

    def newton(self, q, load, maxiter: int = _MAX_NEWTON):
        ok, q, its = super().newton(q, load, maxiter)
        if ok and self.model.field_on_beam(q, load) > MAX_FIELD_ON_BEAM:
            self.note = (f"The rod reached the source (the field on it exceeded {MAX_FIELD_ON_BEAM:g} T): there is no "
                         "equilibrium beyond the snap.")
            self._J = None
            return False, q, its
        return ok, q, its

    def _tangent(self, q, start, target, t: float = 0.0):
        """d psi / d t: the residual's derivative along the path by central differences in t (exact to about
        1e-10 relative; the blend of a moving magnet is not linear in t), through the Jacobian at ``q``."""
        st = self._J
        if st is not None and st[0] is q and st[1] is self.model:
            J = st[2]
        else:
            self._spend(1.0)
            _, J = self.model.jacobian(q, start.lerp(target, t))
        lo, hi = max(0.0, t - _RATE_STEP), min(1.0, t + _RATE_STEP)
        rate = (self.model.system(q, start.lerp(target, hi)) - self.model.system(q, start.lerp(target, lo))) / (hi - lo)
        x = self._solve(J, rate)
        if x is None or not np.all(np.isfinite(x)):
            return np.zeros((self.grid.M, 3))
        return -self.model.psi(x)

    def verify(self) -> float:
        return rod_source_residual(self.beam, self.grid, self.q, self.load, q0=clamp_quaternion(self.clamp_angle))

    def source_result(self, ok, status, snapped, source, gravity, tail, ver, messages, wall_time=0.0):
        mdl, grid, q, load = self.model, self.grid, self.q, self.load
        status, msg = outcome(ok, status, tail, ver, self.opt, note=self.note, events=len(self.events),
                              nodes=int(mdl.uniq.size), messages=messages)
        u = mdl.uniq
        F = mdl.system(q, load)
        ld = mdl.source_loads(q, load)
        R, r = ld["R"], ld["r"]
        k = mdl.curvature(q)
        tw = grid.Q0 @ k[:, 2]
        stable = (self._stable[0] is q and self._stable[1]) or self._is_stable(q, load)
        tipB = ld["B"][-1].copy()
        f_all = ld["f"] - (load.g * mdl.rhoA)[:, None] * np.array([0.0, 0.0, 1.0])
        return SourceRodResult(
            success=bool(ok and status in (0, 2)), status=int(status), message=msg, s=grid.s[u], centreline=r[u],
            frames=R[u], curvature=k[u], twist=tw[u], tip_position=r[-1].copy(), tip_tangent=R[-1, :, 2].copy(),
            tip_twist=float(tw[-1]), tip_deflection=float(r[-1, 2]),
            max_curvature=float(np.max(np.hypot(k[:, 0], k[:, 1]))), energy=mdl.energy(q, load),
            stable=bool(stable), snap_through=bool(snapped),
            field=Field(*(float(v) for v in np.clip(tipB, -1.0, 1.0))), gravity=float(gravity),
            residual=float(np.max(np.abs(F))), resolution=max(tail, ver) if ok else math.nan, nodes=int(u.size),
            newton_iterations=self.newton_its, wall_time=float(wall_time), events=list(self.events),
            verification=float(ver) if ok else math.nan, _grid=grid, _state=(mdl, q.copy(), load), source=source,
            tip_field=tipB, clamp_force=mdl.w @ f_all, clamp_moment=mdl.w @ ld["lam"],
        )


def solve_rod_source_path(beam: Beam, sources, *, gravity: float, clamp_angle: float, options: SolverOptions,
                          messages: dict, progress: bool = False) -> list[SourceRodResult]:
    """Equilibria of the clamped 3D rod along a path of field sources (see the module docstring).

    Checked input is expected (:func:`magsoft_env.theory.solver.solve_path` checks it): ``sources`` a non-empty
    sequence of sources (each checked here), ``gravity`` >= 0 (m/s^2), ``messages`` the status messages.
    """
    sources = [_check_source(i, s) for i, s in enumerate(sources)]
    t_prev = time.perf_counter()
    solver = SourceRodSolver(beam, clamp_angle=clamp_angle, options=options,
                             edges=subdomain_edges(beam, options.split_at_knots))
    out: list[SourceRodResult] = []
    ok = True
    if gravity > 0:
        ok = solver.continue_to(SourceLoad3((), gravity))
    it = sources
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(sources, desc="equilibria (3D)", unit="source")
    for src in it:
        if ok:
            n_events = len(solver.events)
            ok = solver.continue_to(SourceLoad3(((1.0, src),), gravity))
            snapped = len(solver.events) > n_events
            tail, ver = solver.refine() if ok else (math.nan, math.nan)
        else:
            snapped, tail, ver = False, math.nan, math.nan
        now = time.perf_counter()
        status = OVER_BUDGET if solver.over_budget else 0
        out.append(solver.source_result(ok, status, snapped, src, gravity, tail, ver, messages, wall_time=now - t_prev))
        t_prev = now
    return out


#: ``model="auto"`` takes the 3D rod for a planar beam when a source's out-of-plane load exceeds this fraction of its
#: in-plane one anywhere in the beam's reach (:func:`out_of_plane_load`).
OUT_OF_PLANE_TOL = 1e-6


def out_of_plane_load(sources, length: float) -> float:
    """How much a path of sources loads a planar strip out of its plane, relative to in plane (dimensionless).

    A strip that bends in the x-z plane with its magnetization in that plane feels out-of-plane loads only
    through ``B_y`` (couples about x and z) and ``dB_x/dy``, ``dB_z/dy`` (a force along y). This probes each
    source on a polar grid of the disk of radius ``length`` about the clamp in the x-z plane (where the strip can
    be, whatever its clamp angle) and returns the largest ``max |B_y| + L max(|dB_x/dy|, |dB_z/dy|)`` over
    ``max |B| + L max |G|`` (non-finite values, at a source's singular point, are skipped). Zero for a source
    symmetric about y = 0 (a dipole at y = 0 with its moment in the x-z plane, a uniform field with B_y = 0).
    """
    L = float(length)
    ang = np.linspace(0.0, 2 * np.pi, 48, endpoint=False)
    rho = L * np.array([0.125, 0.25, 0.5, 0.75, 1.0])
    pts = np.zeros((1 + rho.size * ang.size, 3))
    pts[1:, 0] = (rho[:, None] * np.cos(ang)[None, :]).ravel()
    pts[1:, 2] = (rho[:, None] * np.sin(ang)[None, :]).ravel()
    worst = 0.0
    for src in sources:
        B, G = src.field_and_gradient(pts)
        ok = np.all(np.isfinite(B), axis=1) & np.all(np.isfinite(G), axis=(1, 2))
        if not np.any(ok):
            continue
        B, G = B[ok], G[ok]
        oop = float(np.max(np.abs(B[:, 1]))) + L * float(np.max(np.abs(G[:, [0, 2], 1])))
        inplane = float(np.max(np.linalg.norm(B, axis=1))) + L * float(np.max(np.abs(G)))
        if inplane > 0:
            worst = max(worst, oop / inplane)
    return worst


# -------------------------------------------------------------------------------------------------------------------
def _frame_quaternion(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (scalar first) of a rotation matrix (Shepperd's method)."""
    tr = np.trace(R)
    if tr > 0:
        S = 2.0 * math.sqrt(tr + 1.0)
        return np.array([0.25 * S, (R[2, 1] - R[1, 2]) / S, (R[0, 2] - R[2, 0]) / S, (R[1, 0] - R[0, 1]) / S])
    i = int(np.argmax(np.diag(R)))
    j, k = (i + 1) % 3, (i + 2) % 3
    S = 2.0 * math.sqrt(1.0 + R[i, i] - R[j, j] - R[k, k])
    out = np.empty(4)
    out[0] = (R[k, j] - R[j, k]) / S
    out[1 + i] = 0.25 * S
    out[1 + j] = (R[j, i] + R[i, j]) / S
    out[1 + k] = (R[k, i] + R[i, k]) / S
    return out


def _cross(a, b) -> np.ndarray:
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = q / math.sqrt(q @ q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def shoot3d(beam: Beam, source, *, gravity: float = 0.0, clamp_angle: float = 0.0, guess=None, steps: int = 10,
            rtol: float = 1e-12) -> dict:
    """An independent shooting solution of the clamped 3D rod in a field source, for checks (no collocation,
    no shared operators).

    Integrates from the clamp, with scipy's DOP853, ``r' = d3``, ``q' = (1/2) q (0, k)`` with
    ``k = K^-1 R^T m``, ``n' = -f`` and ``m' = -(c + d3 x n)`` (``c = (R a) x B(r)``,
    ``f = G(r)^T (R a) - rho A g z``), and finds the clamp's force ``n(0)`` and moment ``m(0)`` (6 unknowns) so
    that ``n(L) = m(L) = 0`` (scipy.optimize.root), ramping gravity and then the source's strength in ``steps``
    steps each from zero (or from ``guess``, ``(n(0), m(0))`` as 6 numbers, in one step). Piecewise-smooth beams
    are integrated piece by piece. Returns ``{"s", "centreline" (n, 3), "unknowns", "residual", "success",
    "tip"}``.
    """
    from scipy.integrate import solve_ivp
    from scipy.optimize import root

    L = float(beam.length)
    edges = [0.0, *subdomain_edges(beam), L]
    c0, s0 = math.cos(clamp_angle), math.sin(clamp_angle)
    R0 = np.array([[0.0, -s0, c0], [1.0, 0.0, 0.0], [0.0, c0, s0]])  # columns d1 = y, d2, d3 (turned about -y)
    q0 = _frame_quaternion(R0)

    def rhs(s, y, scale, gscale, a, b):
        s_ = np.array([min(max(s, a + 1e-12 * L), b - 1e-12 * L)])  # a piece's own side of a jump
        K = np.asarray(beam.stiffnesses(s_), float)[0]
        mh = np.asarray(beam.magnetization_direction(s_), float)[0]
        amat = float(beam.moment_per_length(s_)[0]) * np.array([mh[1], mh[2], mh[0]])
        r, q, n, m = y[:3], y[3:7], y[7:10], y[10:13]
        R = _quat_matrix(q)
        d3 = R[:, 2]
        ma = R @ amat
        if scale:
            B, G = source.field_and_gradient(r[None, :])
            B, G = scale * B[0], scale * G[0]
        else:
            B, G = np.zeros(3), np.zeros((3, 3))
        f = G.T @ ma
        f[2] -= gscale * gravity * float(beam.mass_per_length(s_)[0])
        k = (R.T @ m) / K
        w, v = q[0], q[1:]
        dq = 0.5 * np.concatenate([[-v @ k], w * k + _cross(v, k)])
        return np.concatenate([d3, dq, -f, -(_cross(ma, B) + _cross(d3, n))])

    def integrate(u, scale, gscale, tol, dense=False):
        y = np.concatenate([np.zeros(3), q0, u[:3], u[3:]])
        pieces = []
        for a, b in zip(edges[:-1], edges[1:], strict=True):
            sol = solve_ivp(rhs, (a, b), y, method="DOP853", rtol=tol, atol=tol * 1e-3 * L,
                            args=(scale, gscale, a, b), dense_output=dense)
            y = sol.y[:, -1]
            pieces.append(sol)
        return y, pieces

    EImax = float(np.max(np.asarray(beam.stiffnesses(np.linspace(0.0, L, 65)))[:, 0]))
    nscale = EImax / L**2  # force scale (N) to compare forces with moments / L

    def F(u, scale, gscale, tol):
        y, _ = integrate(u * np.r_[[nscale] * 3, [nscale * L] * 3], scale, gscale, tol)
        return np.concatenate([y[7:10] / nscale, y[10:13] / (nscale * L)])

    scl = np.r_[[nscale] * 3, [nscale * L] * 3]
    u = np.zeros(6) if guess is None else np.asarray(guess, float) / scl
    if guess is not None:
        ramp = [(1.0, 1.0)]
    else:
        ramp = [(0.0, k / steps) for k in range(1, steps + 1)] if gravity else []
        ramp += [(k / steps, 1.0) for k in range(1, steps + 1)]
    ok = True
    res = math.inf
    for i, (sc, gs) in enumerate(ramp):
        last = i == len(ramp) - 1
        r = root(F, u, args=(sc, gs, rtol if last else max(rtol, 1e-8)), method="hybr",
                 options={"xtol": 1e-14 if last else 1e-9})
        u = r.x
        res = float(np.max(np.abs(r.fun)))
        ok = bool(r.success) or res < 1e-12
    u = u * scl
    y, pieces = integrate(u, 1.0, 1.0, rtol, dense=True)
    s = np.linspace(0.0, L, 201)
    cols = []
    for s_i in s:
        p = next(p for p in pieces if p.t[0] - 1e-15 <= s_i <= p.t[-1] + 1e-15)
        cols.append(p.sol(s_i)[:3])
    return {"s": s, "centreline": np.array(cols), "unknowns": u, "residual": res, "success": ok, "tip": y[:3].copy()}


__all__ = ["OUT_OF_PLANE_TOL", "SourceLoad3", "SourceRodModel", "SourceRodResult", "SourceRodSolver",
           "out_of_plane_load", "shoot3d", "solve_rod_source_path"]

"""The beam sampled on a collocation grid: energy density, residual, Jacobian, Hessian.

Total potential energy of a beam with reference arc length s in [0, L]::

    U[theta] = int_0^L  EI/2 theta'^2 + phi(theta, s) ds

with the energy density (``kappa = 1`` for the rotated coupling, 0 for the paper's eq. 10)::

    a(theta)   = m cos(beta) (B_x cos theta + B_z sin theta) - W(s) sin theta    (axial force)
    phi        = -a - kappa m sin(beta) (B_z cos theta - B_x sin theta)  [- a^2 / (2 EA) if extensible]

where m = A B_r / mu0 (A m) and W(s) = g int_s^L rho A is the weight beyond s (N).
The extensible form minimizes EA/2 eps^2 - (1 + eps) a over eps: eps = a / EA (paper eq. 14).
The Euler-Lagrange equation ``(EI theta')' = phi_theta`` with ``theta(0) = theta_0`` and
``theta'(L) = 0`` is solved in integral form, which is well conditioned::

    theta(s) = theta_0 - int_0^s (1/EI) int_t^L phi_theta(theta(u), u) du dt
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from scipy.linalg.lapack import dgesv, dgetrs, dpotrf, dpotrs

from .collocation import Grid


class Load(NamedTuple):
    """One load state: field (T) and gravity (m/s^2). A named tuple: hashing and comparison in C,
    as coefficient caches look loads up several times per equilibrium."""

    Bx: float
    Bz: float
    g: float

    def lerp(self, other: Load, t: float) -> Load:
        return Load(
            self.Bx + t * (other.Bx - self.Bx), self.Bz + t * (other.Bz - self.Bz), self.g + t * (other.g - self.g)
        )


class BeamModel:
    """Coefficients of one beam on one grid, and the discrete operators built from them."""

    def __init__(self, beam, grid: Grid, *, coupling: str, extensible: bool):
        self.beam = beam
        self.grid = grid
        self.extensible = extensible
        s = grid.s_eval
        self.EI = beam.bending_stiffness(s)
        self.EA = beam.axial_stiffness(s)
        m = beam.moment_per_length(s)
        beta = beam.beta(s)
        self.mc = m * np.cos(beta)
        self.ms = m * np.sin(beta) if coupling == "rotated" else np.zeros_like(m)
        self.W1 = grid.QL @ beam.mass_per_length(s)  # weight beyond s per unit g (kg)
        # theta = theta0 + P @ (-phi_theta):  P = Q0 diag(1/EI) QL
        self.P = grid.Q0 @ (grid.QL / self.EI[:, None])
        self._PT = np.ascontiguousarray(self.P.T)
        self._Pneg = -self.P  # J.T = I + fth[:, None] * P.T, built row-wise
        self._diag = slice(None, None, grid.M + 1)
        self._eye = np.eye(grid.M)
        self._zeros = np.zeros(grid.M)
        self._pq = {}  # load -> coefficients (a few recent loads)
        zero = np.zeros_like(self.mc)
        # (Bx, Bz, g) @ _rbasis -> (r1, r2) concatenated: the coefficients of phi_theta
        self._rbasis = np.array([np.r_[self.ms, self.mc], np.r_[-self.mc, self.ms], np.r_[self.W1, zero]])
        self.EI_ref = float(grid.w @ self.EI) / beam.length
        # energy operators on distinct nodes (for stability and energy descent)
        self.uniq = grid.unique()
        self.expand = np.searchsorted(self.uniq, np.arange(grid.M), side="right") - 1  # full <- unique
        n = grid.n
        Dblk = np.zeros((grid.M, grid.M))
        for k in range(len(grid.edges) - 1):
            sl = slice(k * (n + 1), (k + 1) * (n + 1))
            Dblk[sl, sl] = _local_D(n) / (0.5 * (grid.edges[k + 1] - grid.edges[k]))
        E = np.zeros((grid.M, self.uniq.size))
        E[np.arange(grid.M), self.expand] = 1.0
        self.E = E
        DE = Dblk @ E
        self.K = DE.T @ ((grid.w * self.EI)[:, None] * DE)
        self.mass = E.T @ grid.w  # lumped quadrature weights on distinct nodes
        # second variation in the mass-normalized basis: Ks + diag(w fth / mass), per support
        r = 1.0 / np.sqrt(self.mass)
        Ks = self.K * r[:, None] * r[None, :]
        self._Ks = {False: Ks, True: np.ascontiguousarray(Ks[1:, 1:])}
        self._single = self.uniq.size == grid.M  # one subdomain: no repeated nodes

    # energy density and its derivatives --------------------------------------------------
    def _coeffs(self, load: Load):
        pq = self._pq.get(load)
        if pq is None:
            if len(self._pq) > 8:
                self._pq.clear()
            if self.extensible:
                W = load.g * self.W1
                p1, p2 = self.mc * load.Bx, self.mc * load.Bz - W
                q1, q2 = self.ms * load.Bz, self.ms * load.Bx
            else:  # only r1, r2 are used
                p1 = p2 = q1 = q2 = None
            # r1 = q2 - p2 = ms Bx - mc Bz + g W1, r2 = q1 + p1 = ms Bz + mc Bx: one product
            r = np.dot(load, self._rbasis)
            r1, r2 = r[: r.size // 2], r[r.size // 2 :]
            # f = r1 cos + r2 sin = A sin(theta + ph), f_theta = A cos(theta + ph)
            pq = self._pq[load] = (p1, p2, q1, q2, r1, r2, np.hypot(r1, r2), np.arctan2(r1, r2))
        return pq

    def density(self, theta, load: Load):
        """phi, phi_theta, phi_theta_theta and strain eps at all nodes."""
        p1, p2, q1, q2, r1, r2, amp, ph = self._coeffs(load)
        if not self.extensible:
            # phi = -a - t0, f = -a1 + t1, f_theta = a + t0 (see module docstring)
            u = theta + ph
            f = np.sin(u)
            f *= amp
            fth = np.cos(u)
            fth *= amp
            return -fth, f, fth, self._zeros
        c, sn = np.cos(theta), np.sin(theta)
        a = p1 * c + p2 * sn
        a1 = p2 * c - p1 * sn
        t0 = q1 * c - q2 * sn
        t1 = q1 * sn + q2 * c
        eps = a / self.EA
        phi = -a - 0.5 * a * eps - t0
        f = -a1 * (1.0 + eps) + t1
        fth = a * (1.0 + eps) - a1 * a1 / self.EA + t0
        return phi, f, fth, eps

    def f_fth_at(self, theta, load: Load):
        """phi_theta and phi_theta_theta only (what Newton needs)."""
        if self.extensible:
            return self.density(theta, load)[1:3]
        amp, ph = self._coeffs(load)[6:]
        u = theta + ph
        f = np.sin(u)
        f *= amp
        u = np.cos(u, out=u)
        u *= amp
        return f, u

    # collocation residual (integral form) -------------------------------------------------
    def residual(self, theta, theta0: float, load: Load):
        _, f, fth, _ = self.density(theta, load)
        return theta - theta0 + self.P @ f, fth

    def jacobian(self, fth):
        return self._eye + self.P * fth[None, :]

    def solve_newton(self, R, fth):
        """Solve J d = R for the cantilever Jacobian J = I + P diag(fth) (LAPACK, no checks).

        Returns (d, lu) with ``lu`` the factorization for :meth:`lu_solve`; d is None when J is
        singular."""
        JT = fth[:, None] * self._PT
        JT.reshape(-1)[self._diag] += 1.0
        lu, piv, d, info = dgesv(JT.T, R, overwrite_a=1, overwrite_b=0)
        return (d if info == 0 else None), (lu, piv)

    @staticmethod
    def lu_solve(lu, b):
        """Solve with a factorization returned by :meth:`solve_newton` or :func:`lu_factor`."""
        x, info = dgetrs(lu[0], lu[1], b)
        return x

    # energy on distinct nodes ---------------------------------------------------------------
    def energy(self, u, load: Load) -> float:
        theta = u[self.expand]
        phi, _, _, _ = self.density(theta, load)
        return 0.5 * u @ (self.K @ u) + self.grid.w @ phi

    def energy_grad_hess(self, u, load: Load):
        theta = u[self.expand]
        phi, f, fth, _ = self.density(theta, load)
        wf = self.grid.w * f
        wfth = self.grid.w * fth
        g = self.K @ u + np.bincount(self.expand, weights=wf, minlength=u.size)
        H = self.K + np.diag(np.bincount(self.expand, weights=wfth, minlength=u.size))
        return 0.5 * u @ (self.K @ u) + self.grid.w @ phi, g, H

    def _scaled_hessian(self, theta, load: Load, clamped: bool):
        """Second variation on distinct nodes in the mass-normalized basis, and the basis scale."""
        _, _, fth, _ = self.density(theta, load)
        H = self.K + np.diag(np.bincount(self.expand, weights=self.grid.w * fth, minlength=self.uniq.size))
        Mm = self.mass
        if clamped:
            H, Mm = H[1:, 1:], Mm[1:]
        r = 1.0 / np.sqrt(Mm)
        return H * r[:, None] * r[None, :], r

    def is_stable(self, theta, load: Load, *, clamped: bool, tol: float = 1e-9) -> bool:
        """Whether the smallest eigenvalue (units EI/L^2) exceeds -tol: a Cholesky test, no eigensolve."""
        _, _, fth, _ = self.density(theta, load)
        if self._single:
            d = fth  # w fth / mass with mass = w
        else:
            d = np.bincount(self.expand, weights=self.grid.w * fth, minlength=self.uniq.size) / self.mass
        H = self._Ks[clamped].copy()
        H.reshape(-1)[:: H.shape[0] + 1] += (d[1:] if clamped else d) + tol * self.EI_ref / self.beam.length**2
        _, info = dpotrf(H, lower=0, clean=0, overwrite_a=1)  # symmetric: C order is its own transpose
        return info == 0

    # continuation helpers (inextensible) -----------------------------------------------------
    def f_fth(self, c, sn, load: Load):
        """phi_theta and phi_theta_theta from precomputed cos, sin of theta (inextensible)."""
        r1, r2 = self._coeffs(load)[4:6]
        return r1 * c + r2 * sn, r2 * c - r1 * sn

    def cholesky(self, fth, *, clamped: bool, tol: float = 0.0):
        """Upper Cholesky factor of the mass-normalized second variation (shifted by tol, units
        EI/L^2), or None when it is not positive definite."""
        if self._single:
            d = fth
        else:
            d = np.bincount(self.expand, weights=self.grid.w * fth, minlength=self.uniq.size) / self.mass
        H = self._Ks[clamped].copy()
        dg = H.reshape(-1)[:: H.shape[0] + 1]
        dg += d[1:] if clamped else d
        if tol:
            dg += tol * self.EI_ref / self.beam.length**2
        U, info = dpotrf(H, lower=0, clean=0, overwrite_a=1)
        return U if info == 0 else None

    def low_mode(self, U, v, its: int = 2):
        """Smallest eigenvalue (mass-normalized units) and its unit eigenvector, by inverse
        iteration with the Cholesky factor U, started from v."""
        lam = 0.0
        for _ in range(its):
            w, _ = dpotrs(U, v, lower=0)
            n = math.sqrt(w @ w)
            lam = float(v @ w)  # Rayleigh quotient of H^-1 at the unit vector v
            v = w / n
        return 1.0 / lam, v

    def mode_rate(self, v, dfth, *, clamped: bool):
        """d lambda / d t for the unit mode v (mass-normalized) when f_theta changes by dfth."""
        if self._single:
            d = dfth
        else:
            d = np.bincount(self.expand, weights=self.grid.w * dfth, minlength=self.uniq.size) / self.mass
        if clamped:
            d = d[1:]
        return float((v * v) @ d)

    def min_eigen(self, theta, load: Load, *, clamped: bool, vector: bool = True):
        """Smallest eigenvalue of the second variation, made dimensionless by EI/L^2, and its mode."""
        Hs, r = self._scaled_hessian(theta, load, clamped)
        scale = self.beam.length**2 / self.EI_ref
        if not vector:
            return float(np.linalg.eigvalsh(Hs)[0]) * scale, None
        vals, vecs = np.linalg.eigh(Hs)
        v = vecs[:, 0] * r
        if clamped:
            v = np.concatenate([[0.0], v])
        v = v / np.max(np.abs(v))
        if v[-1] < 0:
            v = -v
        return float(vals[0]) * scale, v[self.expand]


def _local_D(n):
    from .collocation import _cheb_local

    return _cheb_local(n)[3]

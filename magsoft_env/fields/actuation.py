"""Actuation as a user has it: coil currents with limits, slew rates and lag, current allocation, a magnet's pose.

Coil currents (:class:`CoilDrive`): a coil of inductance ``L`` and resistance ``R`` driven by a voltage that asks
for the current ``c`` follows ``tau dI/dt = c - I`` with ``tau = L / R`` (s); with ``c`` held over a step ``dt``
(zero-order hold) the exact update is::

    I(t + dt) = c + (I(t) - c) exp(-dt / tau)

then the amplifier's slew rate clamps the change to ``+-rate dt`` (A) and the coil's limit clips the result. A
command beyond a limit is clipped to it first and reported (``saturated``).

Allocation (:func:`allocate`): the actuation matrix ``A`` at a point maps the currents ``I`` (A) to the field
(T), its gradient (T/m) and the force ``G^T m`` (N) on a moment ``m`` (A m^2), all linear in ``I``. The wanted
quantities ``b`` are reached by the currents of least norm::

    minimize ||I||  over the minimizers of  ||W (A I - b)||,   -I_max <= I <= I_max

(``W`` normalizes each quantity by the system's scale for it, so that teslas and teslas per metre weigh alike).
Without the bounds it is the pseudo-inverse ``I = pinv(W A) W b`` (rank from a relative tolerance of the
singular values); where that exceeds a limit the bounded least-squares problem is solved (BVLS), then the least
norm among its minimizers (a least-distance problem solved exactly through NNLS, Lawson and Hanson, *Solving
Least Squares Problems*, 1974, ch. 23). :func:`reachable_field` and ``Allocation.scale_limit`` are linear
programs (HiGHS) for how far a direction can go within the limits.

A permanent magnet's pose (:class:`MagnetWorkspace`, :class:`PosedMagnet`): a position in a box, the tilt of the
magnet's axis from a reference axis at most ``max_tilt``, optionally at least ``min_distance`` from a point (the
robot's workspace). A pose outside is refused naming the bound, or projected into the workspace.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from dataclasses import field as dc_field

import numpy as np
from scipy.optimize import linprog, lsq_linear, nnls

from ..validate import boolean, finite_array, finite_number, in_range, nonnegative
from .base import (
    MAX_COORDINATE,
    Source,
    Transformed,
    as_points,
    position3,
    rotation_matrix,
    unit_vector,
    vector3,
)
from .coils import CoilSystem

#: Relative tolerance of the singular values below which a direction counts as not actuated (the rank).
RCOND = 1e-9
#: Default tolerance of ``Allocation.reachable``: the weighted residual relative to the weighted wanted quantities.
REACH_TOL = 1e-6
#: A current within this fraction of its limit counts as saturated.
SATURATION_TOL = 1e-9
#: Largest wanted field accepted (T) and largest wanted gradient (T/m): beyond any navigation system.
MAX_WANTED_FIELD = 10.0
MAX_WANTED_GRADIENT = 1e4
#: Largest moment accepted (A m^2) and force (N).
MAX_MOMENT = 1e3
MAX_FORCE = 1e4
#: Largest time constant (s) and slew rate (A/s) a :class:`CoilDrive` accepts.
MAX_TAU = 1e3
MAX_SLEW_RATE = 1e9
#: Tolerance on the symmetry and trace of a wanted gradient given as a 3x3 matrix, relative to its largest entry.
GRADIENT_TOL = 1e-6
#: The five independent gradient entries of :data:`ACTUATION_ROWS`, as (row, column) of ``G``.
GRADIENT_ENTRIES = ((0, 0), (0, 1), (0, 2), (1, 1), (1, 2))

STATUS_MESSAGES = {
    0: "reached by the least-norm currents, within the limits",
    1: "reached within the limits, with coils at their limits (the least-norm currents without limits exceed them)",
    2: "not reachable within the current limits: the currents are the nearest within them (weighted least squares, "
       "then least norm)",
    3: "not reachable at any currents: the wanted quantities are not independent at this point (the currents are "
       "the weighted least-squares compromise of least norm; weights= sets the trade-off)",
    -1: "the bounded solver failed",
}


# ------------------------------------------------------------------------------------------------ coil drive


def _per_coil(name: str, value, n: int, *, unit: str, lo: float, hi: float, lo_open: bool) -> np.ndarray:
    """One number or one per coil, each in (lo, hi] (``lo_open``) or [lo, hi]."""
    arr = finite_array(name, value)
    if arr.ndim == 0:
        arr = np.full(n, float(arr))
    if arr.shape != (n,):
        raise ValueError(f"{name} must be one number or one per coil ({n}) ({unit}), got shape {arr.shape}.")
    bad = (arr <= lo) if lo_open else (arr < lo)
    bad |= arr > hi
    if bad.any():
        j = int(np.argmax(bad))
        lb = "(" if lo_open else "["
        raise ValueError(f"{name}[{j}] must lie in {lb}{lo:g}, {hi:g}] {unit}, got {float(arr[j])!r}.")
    return arr


def _limits_for(system: CoilSystem, limits, what: str) -> np.ndarray:
    """Per-coil limits (A): the system's, or ``limits`` (one or one per coil), each in (0, the system's]."""
    if limits is None:
        return system.max_current.copy()
    lim = _per_coil(f"{what} limits", limits, system.n_coils, unit="A", lo=0.0, hi=math.inf, lo_open=True)
    over = lim > system.max_current
    if over.any():
        j = int(np.argmax(over))
        raise ValueError(f"{what} limits[{j}] ({system.coil_names[j]}) must lie in (0, {system.max_current[j]:g}] A "
                         f"(the system's limit: the linear model holds within it only), got {float(lim[j])!r}.")
    return lim


class CoilDrive:
    """The coils' currents as an input: commanded currents become actual ones through limits, slew and lag.

    Per coil, over a step ``dt`` with the command ``c`` held (zero-order hold), in this order::

        c   <- clip(c, -I_max, I_max)                      (reported in ``saturated``)
        I_1  = c + (I - c) exp(-dt / tau)                  (exact solution of tau dI/dt = c - I; I_1 = c if tau = 0)
        I_2  = I + clip(I_1 - I, -rate dt, rate dt)         (slew rate; reported in ``rate_limited``)
        I   <- clip(I_2, -I_max, I_max)

    Parameters
    ----------
    system : CoilSystem
        The coils; their ``max_current`` are the limits unless ``limits`` is given.
    limits : float or array_like, shape (n_coils,), optional
        Lower limits (A), each in (0, the system's].
    slew_rate : float or array_like, shape (n_coils,), optional
        Largest rate of change of each coil's current (A/s), > 0; ``None``: no slew limit.
    tau : float or array_like, shape (n_coils,), optional
        Time constant ``L / R`` of each coil (s), >= 0 (0: no lag); ``None``: no lag.
    currents : array_like, shape (n_coils,), optional
        Initial currents (A), within the limits; default zero.

    Examples
    --------
    >>> from magsoft_env.fields import CoilSystem
    >>> drive = CoilDrive(CoilSystem.from_calibration("navion"), tau=0.1, slew_rate=100.0)
    >>> drive.step([50.0, 10.0, 0.0], dt=0.01).round(4).tolist()   # coil 0: 35 A, lagged to 3.33 A, slewed to 1 A
    [1.0, 0.9516, 0.0]
    >>> drive.saturated.tolist(), drive.rate_limited.tolist()
    ([True, False, False], [True, False, False])
    """

    def __init__(self, system, *, limits=None, slew_rate=None, tau=None, currents=None):
        if not isinstance(system, CoilSystem):
            raise ValueError(f"CoilDrive system must be a CoilSystem (CoilSystem.from_calibration('navion')), got "
                             f"{type(system).__name__}.")
        self._system = system
        n = system.n_coils
        self._limits = _limits_for(system, limits, "CoilDrive")
        self._slew = None if slew_rate is None else _per_coil(
            "CoilDrive slew_rate", slew_rate, n, unit="A/s", lo=0.0, hi=MAX_SLEW_RATE, lo_open=True)
        self._tau = None if tau is None else _per_coil(
            "CoilDrive tau", tau, n, unit="s", lo=0.0, hi=MAX_TAU, lo_open=False)
        self._currents = np.zeros(n)
        self.saturated = np.zeros(n, dtype=bool)
        self.rate_limited = np.zeros(n, dtype=bool)
        self.reset(currents)

    @property
    def system(self) -> CoilSystem:
        """The coil system."""
        return self._system

    @property
    def limits(self) -> np.ndarray:
        """Current limit of each coil (A), shape (n_coils,)."""
        return self._limits.copy()

    @property
    def slew_rate(self) -> np.ndarray | None:
        """Largest rate of change of each coil's current (A/s), or None."""
        return None if self._slew is None else self._slew.copy()

    @property
    def tau(self) -> np.ndarray | None:
        """Time constant L/R of each coil (s), or None."""
        return None if self._tau is None else self._tau.copy()

    @property
    def currents(self) -> np.ndarray:
        """The actual currents (A), shape (n_coils,) (a copy)."""
        return self._currents.copy()

    def _check_within(self, name: str, value) -> np.ndarray:
        I = finite_array(name, value)
        n = self._system.n_coils
        if I.shape != (n,):
            raise ValueError(f"{name} must have shape ({n},) (A, one per coil: {', '.join(self._system.coil_names)}), "
                             f"got shape {I.shape}.")
        over = np.abs(I) > self._limits
        if over.any():
            j = int(np.argmax(over))
            raise ValueError(f"{name}[{j}] ({self._system.coil_names[j]}) must lie within +-{self._limits[j]:g} A, "
                             f"got {float(I[j])!r}.")
        return I

    def reset(self, currents=None) -> np.ndarray:
        """Set the actual currents (A; default zero, else within the limits) and clear the masks; returns them."""
        n = self._system.n_coils
        self._currents = np.zeros(n) if currents is None else self._check_within("CoilDrive currents", currents).copy()
        self.saturated = np.zeros(n, dtype=bool)
        self.rate_limited = np.zeros(n, dtype=bool)
        return self.currents

    def step(self, command, dt: float) -> np.ndarray:
        """Advance by ``dt`` (s, > 0) with the commanded currents ``command`` (A, shape (n_coils,)) held.

        Returns the actual currents at the end of the step (A, a copy). Sets ``saturated`` (commands beyond a limit,
        clipped) and ``rate_limited`` (coils whose change the slew rate clamped) for this step."""
        n = self._system.n_coils
        c = finite_array("CoilDrive command", command)
        if c.shape != (n,):
            raise ValueError(f"CoilDrive command must have shape ({n},) (A, one per coil: "
                             f"{', '.join(self._system.coil_names)}), got shape {c.shape}.")
        dt = finite_number("CoilDrive dt", dt, unit="s")
        if dt <= 0.0:
            raise ValueError(f"CoilDrive dt must be > 0 (s), got {dt!r}.")
        lim = self._limits
        self.saturated = np.abs(c) > lim
        c = np.clip(c, -lim, lim)
        I = self._currents
        if self._tau is None:
            target = c
        else:
            with np.errstate(divide="ignore"):  # tau = 0: exp(-inf) = 0, no lag
                decay = np.exp(-dt / self._tau)
            target = c + (I - c) * decay
        change = target - I
        if self._slew is not None:
            bound = self._slew * dt
            self.rate_limited = np.abs(change) > bound
            change = np.clip(change, -bound, bound)
        else:
            self.rate_limited = np.zeros(n, dtype=bool)
        self._currents = np.clip(I + change, -lim, lim)
        return self.currents

    def __repr__(self) -> str:
        return (f"CoilDrive({self._system.name!r}, slew_rate={None if self._slew is None else self._slew.tolist()}, "
                f"tau={None if self._tau is None else self._tau.tolist()})")


# ------------------------------------------------------------------------------------------------ allocation


def _gradient5(value) -> np.ndarray:
    """A wanted gradient (T/m) as its five independent entries (ACTUATION_ROWS order) and the full 3x3."""
    g = finite_array("allocate gradient", value)
    if g.shape == (5,):
        G = np.array([[g[0], g[1], g[2]], [g[1], g[3], g[4]], [g[2], g[4], -g[0] - g[3]]])
    elif g.shape == (3, 3):
        G = g
        scale = max(float(np.abs(G).max()), 1e-300)
        asym = float(np.abs(G - G.T).max())
        trace = abs(float(np.trace(G)))
        if asym > GRADIENT_TOL * scale or trace > GRADIENT_TOL * scale:
            raise ValueError("allocate gradient must be symmetric and traceless (the gradient of a source-free field), "
                             f"to {GRADIENT_TOL:g} of its largest entry, got max |G - G^T| = {asym:.3g} and "
                             f"|trace| = {trace:.3g} T/m: {G.tolist()!r}.")
    else:
        raise ValueError("allocate gradient must be 5 entries (T/m: dBx/dx, dBx/dy, dBx/dz, dBy/dy, dBy/dz) or a "
                         f"(3, 3) matrix G[a, b] = dB_a/dx_b, got shape {g.shape}.")
    if np.abs(G).max() > MAX_WANTED_GRADIENT:
        raise ValueError(f"allocate gradient entries must lie within +-{MAX_WANTED_GRADIENT:g} T/m, got "
                         f"{G.tolist()!r}.")
    return np.array([G[r, c] for r, c in GRADIENT_ENTRIES]), G


def _full_gradient(g5: np.ndarray) -> np.ndarray:
    return np.array([[g5[0], g5[1], g5[2]], [g5[1], g5[3], g5[4]], [g5[2], g5[4], -g5[0] - g5[3]]])


@dataclass(frozen=True)
class Allocation:
    """Currents for wanted quantities at a point, what they achieve and what the system can do there.

    Attributes
    ----------
    currents : ndarray, shape (n_coils,)
        The currents (A), within ``limits``.
    field : ndarray, shape (3,)
        The field they make at ``point`` (T), with the system's offset field if it has one.
    gradient : ndarray, shape (3, 3)
        Its gradient (T/m), ``G[a, b] = dB_a / dx_b``.
    force : ndarray, shape (3,), or None
        The force ``G^T m`` on ``moment`` (N), where a moment was given.
    wanted : dict
        The wanted quantities: ``"field"`` (T, (3,)), and ``"gradient"`` (T/m, (3, 3)) or ``"force"`` (N, (3,)).
    error : dict
        Per wanted quantity, the norm of achieved minus wanted (T, T/m (Frobenius), N).
    relative_error : float
        ``||W (A I - b)|| / ||W b||`` (0 when nothing is wanted): the weighted residual that ``reachable`` tests.
    reachable : bool
        ``relative_error <= tol``: the wanted quantities are reached within the limits.
    saturated : ndarray of bool, shape (n_coils,)
        Coils at their limit (within :data:`SATURATION_TOL`).
    rank : int
        Rank of the (weighted) map from the currents to the wanted components at this point.
    n_wanted : int
        Number of wanted components (3 for the field, 8 with a gradient, 6 with a force).
    settable : tuple of str
        Which of ``"field"``, ``"field+gradient"``, ``"field+force"`` (the last where a moment was given) the
        system sets fully and independently at this point (the rank equals the number of components).
    scale_limit : float
        The largest factor by which the wanted quantities can be scaled together and stay reachable within the
        limits (``inf`` when nothing is wanted, 0 when they are not reachable at any currents). Where the currents
        for the wanted quantities are unique (rank = number of coils) and the system has no offset field, it is
        ``min_j I_max,j / |I_j|`` of the unbounded solution, exactly; otherwise a linear program (HiGHS).
    limits : ndarray, shape (n_coils,)
        Limits used (A).
    point : ndarray, shape (3,)
        The point (m).
    success : bool
        Whether the solvers converged (``status >= 0``).
    status : int
        0, 1, 2, 3 as :data:`STATUS_MESSAGES`; -1 when a solver failed.
    message : str
        The status in words, then what the system can set at this point.
    """

    currents: np.ndarray
    field: np.ndarray
    gradient: np.ndarray
    force: np.ndarray | None
    wanted: dict
    error: dict
    relative_error: float
    reachable: bool
    saturated: np.ndarray
    rank: int
    n_wanted: int
    settable: tuple
    scale_limit: float
    limits: np.ndarray
    point: np.ndarray
    success: bool
    status: int
    message: str = dc_field(default="")


def _rank(M: np.ndarray, rcond: float) -> int:
    s = np.linalg.svd(M, compute_uv=False)
    return int((s > rcond * s[0]).sum()) if s.size and s[0] > 0 else 0


def _least_norm_bounded(M: np.ndarray, b: np.ndarray, lim: np.ndarray, rcond: float) -> tuple[np.ndarray, bool]:
    """The currents of least norm among the minimizers of ||M I - b|| within -lim <= I <= lim; (I, success)."""
    # 1. the bounded least squares (BVLS: exact active set, fine for a handful of coils), in currents scaled by
    #    their limits so that the variables are alike.
    res = lsq_linear(M * lim, b, bounds=(-1.0, 1.0), method="bvls", tol=1e-14, max_iter=1000)
    I_ls = np.clip(res.x, -1.0, 1.0) * lim
    if res.status < 0:
        return I_ls, False
    # 2. all minimizers share y* = M I_ls (the objective is strictly convex in M I), so they are
    #    I = I_p + N z with I_p = pinv(M) y* and N an orthonormal basis of the null space of M; ||I||^2 =
    #    ||I_p||^2 + ||z||^2. The least-norm one is the least-distance problem min ||z|| subject to the bounds
    #    on I_p + N z, solved exactly by NNLS (Lawson and Hanson ch. 23). A tiny regularization of step 1
    #    would only approximate it, and a general QP solver would add a dependency and a tolerance.
    U, s, Vt = np.linalg.svd(M)
    r = int((s > rcond * s[0]).sum()) if s[0] > 0 else 0
    n = M.shape[1]
    if r == n:  # a unique minimizer
        return I_ls, True
    y = M @ I_ls
    I_p = Vt[:r].T @ ((U[:, :r].T @ y) / s[:r])
    N = Vt[r:].T  # (n, d)
    slack = 1e-12 * lim  # the bounds widened by round-off: I_ls itself must stay feasible
    Gm = np.vstack([N, -N])
    h = np.concatenate([-lim - slack - I_p, I_p - lim - slack])
    E = np.vstack([Gm.T, h[None, :]])
    f = np.zeros(E.shape[0])
    f[-1] = 1.0
    u, _ = nnls(E, f, maxiter=50 * E.shape[1])
    rvec = E @ u - f
    if abs(rvec[-1]) < 1e-14:  # infeasible by round-off: keep the bounded least-squares solution
        return I_ls, True
    z = -rvec[:-1] / rvec[-1]
    I = np.clip(I_p + N @ z, -lim, lim)
    # the least-norm one must not be a worse fit than step 1's (it cannot be, up to round-off)
    if np.linalg.norm(M @ I - b) > np.linalg.norm(M @ I_ls - b) + 1e-12 * max(np.linalg.norm(b), 1e-300):
        return I_ls, True
    return I, True


def _largest_scale(M: np.ndarray, d: np.ndarray, o: np.ndarray, lim: np.ndarray) -> tuple[float, np.ndarray, bool]:
    """max t >= 0 with M I + o = t d and -lim <= I <= lim (linprog, HiGHS); returns (t, I, success).

    M (k, n) of full row rank, d (k,) not zero, o (k,)."""
    n = M.shape[1]
    dn = float(np.linalg.norm(d))
    scale = float(np.linalg.norm(M * lim, 2))  # the variables x = I / lim and t in units of what M reaches
    A_eq = np.hstack([M * lim / scale, -(d / dn)[:, None]])
    b_eq = -o / scale
    c = np.zeros(n + 1)
    c[-1] = -1.0
    res = linprog(c, A_eq=A_eq, b_eq=b_eq, bounds=[(-1.0, 1.0)] * n + [(0.0, None)], method="highs",
                  options={"primal_feasibility_tolerance": 1e-10, "dual_feasibility_tolerance": 1e-10})
    if res.status != 0:
        return (math.inf if res.status == 3 else 0.0), np.zeros(n), res.status == 3
    t = float(res.x[-1]) * scale / dn
    return t, np.clip(res.x[:n], -1.0, 1.0) * lim, True


def _blocks(system: CoilSystem, point: np.ndarray, moment: np.ndarray | None):
    """The actuation rows per quantity at ``point``: field (3, n) T/A, gradient (5, n) T/(m A), force (3, n) N/A."""
    full = system.actuation_matrix(point, full=True)
    Gfull = full[3:].reshape(3, 3, -1)  # G[a, b, j]
    blocks = {"field": full[:3], "gradient": np.array([Gfull[r, c] for r, c in GRADIENT_ENTRIES])}
    if moment is not None:
        blocks["force"] = np.einsum("a,abj->bj", moment, Gfull)  # (G^T m)_b = sum_a m_a G[a, b]
    return blocks


def _offsets(system: CoilSystem, point: np.ndarray, moment: np.ndarray | None) -> dict:
    if system.offset is None:
        z = {"field": np.zeros(3), "gradient": np.zeros(5)}
        if moment is not None:
            z["force"] = np.zeros(3)
        return z
    B, G = system.offset.field_and_gradient(point.reshape(1, 3))
    out = {"field": B[0], "gradient": np.array([G[0][r, c] for r, c in GRADIENT_ENTRIES])}
    if moment is not None:
        out["force"] = G[0].T @ moment
    return out


def allocate(system, point, *, field, gradient=None, force=None, moment=None, limits=None, weights=None,
             tol: float = REACH_TOL, rcond: float = RCOND) -> Allocation:
    """The currents of least norm that make the wanted field (and gradient, or force) at a point, within limits.

    With the actuation rows ``A`` of the wanted quantities at ``point`` and their wanted values ``b``::

        minimize ||I||  over the minimizers of  ||W (A I + o - b)||  subject to  -I_max <= I <= I_max

    (``o`` the system's offset field, if any). Where the pseudo-inverse solution is within the limits it is the
    answer; otherwise bounded least squares (BVLS), then the least norm among its minimizers (NNLS on the
    least-distance problem; module docstring).

    Parameters
    ----------
    system : CoilSystem
        The coils.
    point : array_like, shape (3,)
        Where (m).
    field : array_like, shape (3,)
        Wanted field (T), each component within +-:data:`MAX_WANTED_FIELD`.
    gradient : array_like, shape (5,) or (3, 3), optional
        Wanted gradient (T/m): the five entries of :data:`ACTUATION_ROWS` (dBx/dx, dBx/dy, dBx/dz, dBy/dy, dBy/dz)
        or the symmetric, traceless matrix ``G[a, b] = dB_a/dx_b``. Not with ``force``.
    force : array_like, shape (3,), optional
        Wanted force ``G^T m`` (N) on ``moment``. Not with ``gradient``.
    moment : array_like, shape (3,), optional
        The magnetic moment (A m^2) the force acts on; required with ``force`` and only with it.
    limits : float or array_like, shape (n_coils,), optional
        Current limits (A), each in (0, the system's]; default the system's ``max_current``.
    weights : array_like, shape (k,), optional
        Relative weight (> 0, dimensionless) of each wanted component (k = 3, 8 or 6: field, then gradient or
        force), multiplying the default normalization, which divides each quantity by the system's scale for it
        at this point (the largest singular value of its rows times the limits). Only matters where the wanted
        quantities cannot all be reached.
    tol : float
        Tolerance of ``reachable`` on the weighted relative residual, in (0, 1).
    rcond : float
        Singular values below ``rcond`` times the largest count as zero (the rank), in (0, 1).

    Returns
    -------
    Allocation
        The currents, what they achieve, the errors, the saturated coils, the rank and what the system can set
        at this point, and ``scale_limit``.

    Examples
    --------
    >>> from magsoft_env.fields import CoilSystem
    >>> navion = CoilSystem.from_calibration("navion")
    >>> a = allocate(navion, [0, 0, 0], field=[0, 0, 0.01])   # 10 mT along z at the centre
    >>> a.reachable, a.currents.round(2).tolist(), round(a.scale_limit, 3)
    (True, [-17.02, -7.56, -7.59], 2.056)
    """
    if not isinstance(system, CoilSystem):
        raise ValueError(f"allocate system must be a CoilSystem (CoilSystem.from_calibration('navion')), got "
                         f"{type(system).__name__}.")
    x = position3("allocate point", point)
    B = vector3("allocate field", field, unit="T")
    if np.abs(B).max() > MAX_WANTED_FIELD:
        raise ValueError(f"allocate field components must lie within +-{MAX_WANTED_FIELD:g} T (teslas: 10 mT is "
                         f"0.01), got {B.tolist()!r}.")
    if gradient is not None and force is not None:
        raise ValueError("allocate takes a wanted gradient or a wanted force (on a moment), not both: with 8 or more "
                         "coils give the gradient, which sets the force on any moment.")
    if (force is None) != (moment is None):
        raise ValueError("allocate force and moment go together: the force G^T m (N) acts on the moment m (A m^2); "
                         f"got force={force!r} and moment={moment!r}.")
    m = None
    wanted = {"field": B}
    b_parts = [B]
    if gradient is not None:
        g5, G = _gradient5(gradient)
        wanted["gradient"] = G
        b_parts.append(g5)
    if force is not None:
        m = vector3("allocate moment", moment, unit="A m^2", limit=MAX_MOMENT)
        if not np.any(m):
            raise ValueError(f"allocate moment must not be zero (A m^2), got {m.tolist()!r}.")
        F = vector3("allocate force", force, unit="N", limit=MAX_FORCE)
        wanted["force"] = F
        b_parts.append(F)
    lim = _limits_for(system, limits, "allocate")
    tol = finite_number("allocate tol", tol)
    if not 0.0 < tol < 1.0:
        raise ValueError(f"allocate tol must lie in (0, 1), got {tol!r}.")
    rcond = finite_number("allocate rcond", rcond)
    if not 0.0 < rcond < 1.0:
        raise ValueError(f"allocate rcond must lie in (0, 1), got {rcond!r}.")
    names = list(wanted)
    sizes = {"field": 3, "gradient": 5, "force": 3}
    k = sum(sizes[q] for q in names)
    w_user = np.ones(k)
    if weights is not None:
        w_user = finite_array("allocate weights", weights)
        if w_user.shape != (k,):
            raise ValueError(f"allocate weights must have shape ({k},) (one per wanted component: "
                             f"{' + '.join(f'{q} {sizes[q]}' for q in names)}), got shape {w_user.shape}.")
        if (w_user <= 0).any():
            j = int(np.argmax(w_user <= 0))
            raise ValueError(f"allocate weights[{j}] must be > 0, got {float(w_user[j])!r}.")

    # ---- the weighted system
    blocks = _blocks(system, x, m)
    offs = _offsets(system, x, m)
    A = np.vstack([blocks[q] for q in names])
    o = np.concatenate([offs[q] for q in names])
    b = np.concatenate(b_parts)
    caps = {q: float(np.linalg.norm(blocks[q] * lim, 2)) for q in names}
    w = np.concatenate([np.full(sizes[q], 1.0 / caps[q] if caps[q] > 0 else 1.0) for q in names]) * w_user
    M = A * w[:, None]
    target = w * (b - o)
    U, s, Vt = np.linalg.svd(M, full_matrices=False)
    r = int((s > rcond * s[0]).sum()) if s.size and s[0] > 0 else 0
    n = system.n_coils

    # ---- unbounded least norm (pseudo-inverse), then bounded where it exceeds a limit
    I0 = Vt[:r].T @ ((U[:, :r].T @ target) / s[:r]) if r else np.zeros(n)
    consistent = np.linalg.norm(M @ I0 - target) <= tol * max(np.linalg.norm(w * b), np.linalg.norm(w * o), 1e-300)
    ok = True
    if np.all(np.abs(I0) <= lim * (1.0 + 1e-12)):
        I = np.clip(I0, -lim, lim)
        bounded = False
    else:
        I, ok = _least_norm_bounded(M, target, lim, rcond)
        bounded = True

    # ---- what they achieve
    full_B, full_G = system.field_and_gradient(x.reshape(1, 3), I)
    Gk = full_G[0]
    achieved = {"field": full_B[0], "gradient": Gk}
    Fk = None
    if m is not None:
        Fk = Gk.T @ m
        achieved["force"] = Fk
    error = {q: float(np.linalg.norm(achieved[q] - wanted[q])) for q in names}
    wb = float(np.linalg.norm(w * b))
    denom = max(wb, float(np.linalg.norm(target)))
    resid = float(np.linalg.norm(M @ I - target))
    rel = resid / denom if denom > 0 else 0.0
    reachable = bool(rel <= tol)
    sat = np.abs(I) >= lim * (1.0 - SATURATION_TOL)

    # ---- status
    if not ok:
        status = -1
    elif reachable:
        status = 1 if bounded else 0
    elif not consistent:
        status = 3
    else:
        status = 2

    # ---- scale limit: the largest t with t b reachable (the direction's least-norm currents first)
    if not np.any(b):
        scale = math.inf
    else:
        Iu = Vt[:r].T @ ((U[:, :r].T @ (w * b)) / s[:r]) if r else np.zeros(n)
        if np.linalg.norm(M @ Iu - w * b) > tol * wb:
            scale = 0.0  # the direction itself is out of reach at any currents
        elif r == n and system.offset is None:  # unique currents, linear in t: the exact ratio
            big = np.abs(Iu) > 0
            scale = float(np.min(lim[big] / np.abs(Iu[big])))
        else:
            scale = _scale_lp(M, U, r, w * b, w * o, lim)

    # ---- what the system can set here
    settable = []
    if _rank(blocks["field"] / caps.get("field", 1.0), rcond) == 3:
        settable.append("field")
    fg = np.vstack([blocks["field"] / max(caps["field"], 1e-300),
                    blocks["gradient"] / max(float(np.linalg.norm(blocks["gradient"] * lim, 2)), 1e-300)])
    if _rank(fg, rcond) == 8:
        settable.append("field+gradient")
    if m is not None and _rank(np.vstack([blocks["field"] / max(caps["field"], 1e-300),
                                          blocks["force"] / max(caps["force"], 1e-300)]), rcond) == 6:
        settable.append("field+force")
    parts = " + ".join(f"{q} {sizes[q]}" for q in names)
    can = ", ".join(settable) if settable else "nothing fully (not even the field)"
    msg = f"{STATUS_MESSAGES[status]}. {system.name} ({n} coils) at {np.round(x, 6).tolist()} m sets {can}"
    if r < k:
        lost = [q for q in names if q != "field"]
        what = " and the ".join(lost) if lost else "field"
        msg += (f"; the {k} wanted components ({parts}) have rank {r}: it cannot set the {what} independently "
                "here" + (f" (it has {n} coils for {k} components)" if n < k else ""))
    msg += "."
    if sat.any():
        msg += f" At their limits: {', '.join(c for c, f in zip(system.coil_names, sat, strict=True) if f)}."
    return Allocation(currents=I, field=achieved["field"], gradient=Gk, force=Fk, wanted=wanted, error=error,
                      relative_error=rel, reachable=reachable, saturated=sat, rank=r, n_wanted=k,
                      settable=tuple(settable), scale_limit=scale, limits=lim, point=x, success=ok, status=status,
                      message=msg)


def _scale_lp(M, U, r, d, o, lim) -> float:
    """The largest t with M I + o = t d within the limits, on the rank-r row space of M (full row rank there)."""
    P = U[:, :r].T
    t, _, ok = _largest_scale(P @ M, P @ d, P @ o, lim)
    return t if ok else math.nan


@dataclass(frozen=True)
class Reach:
    """The largest field along a direction within the limits (:func:`reachable_field`).

    Attributes
    ----------
    magnitude : float
        The largest ``|B|`` (T) with ``B`` along ``direction``.
    field : ndarray, shape (3,)
        That field (T).
    currents : ndarray, shape (n_coils,)
        Currents that make it (A), within the limits.
    direction : ndarray, shape (3,)
        The unit direction.
    success : bool
        Whether the linear program was solved.
    message : str
    """

    magnitude: float
    field: np.ndarray
    currents: np.ndarray
    direction: np.ndarray
    success: bool
    message: str


def reachable_field(system, point, direction, *, limits=None) -> Reach:
    """The largest field along ``direction`` (3,) that ``system`` makes at ``point`` (m) within its current limits.

    The linear program ``maximize t subject to A_B I + o = t d, -I_max <= I <= I_max`` (``A_B`` the field rows of
    the actuation matrix, ``o`` the offset field, ``d`` the unit direction; scipy's linprog, HiGHS). Unlike
    :meth:`CoilSystem.max_field`, the other components are held at zero.

    Examples
    --------
    >>> from magsoft_env.fields import CoilSystem
    >>> round(reachable_field(CoilSystem.from_calibration("navion"), [0, 0, 0], [0, 0, 1]).magnitude * 1e3, 2)
    20.56
    """
    if not isinstance(system, CoilSystem):
        raise ValueError(f"reachable_field system must be a CoilSystem, got {type(system).__name__}.")
    x = position3("reachable_field point", point)
    d = unit_vector("reachable_field direction", direction)
    lim = _limits_for(system, limits, "reachable_field")
    A = system.actuation_matrix(x)[:3]
    o = _offsets(system, x, None)["field"]
    r = _rank(A, RCOND)
    if r < 3:
        U, _, _ = np.linalg.svd(A)
        P = U[:, :r].T
        if np.linalg.norm(d - P.T @ (P @ d)) > 1e-9:
            return Reach(0.0, o.copy(), np.zeros(system.n_coils), d, True,
                         f"{system.name} cannot make a field along {d.tolist()} at {x.tolist()} m (rank {r}).")
        A, dd, oo = P @ A, P @ d, P @ o
    else:
        dd, oo = d, o
    t, I, ok = _largest_scale(A, dd, oo, lim)
    if not ok:
        return Reach(math.nan, np.full(3, math.nan), np.zeros(system.n_coils), d, False,
                     "the linear program failed (infeasible: the offset field cannot be cancelled within the limits?)")
    sat = np.abs(I) >= lim * (1.0 - 1e-6)
    names = ", ".join(c for c, f in zip(system.coil_names, sat, strict=True) if f) or "none"
    return Reach(t, t * d, I, d, True, f"|B| = {t * 1e3:.6g} mT along {np.round(d, 6).tolist()}; coils at their "
                                      f"limits: {names}.")


# ------------------------------------------------------------------------------------------------ magnet pose


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit vector ``a`` to unit vector ``b``."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    sn = float(np.linalg.norm(v))
    if sn < 1e-15:
        if c > 0:
            return np.eye(3)
        helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        k = np.cross(a, helper)
        k /= np.linalg.norm(k)
        return 2.0 * np.outer(k, k) - np.eye(3)  # a half turn about k
    k = v / sn
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    ang = math.atan2(sn, c)
    return np.eye(3) + math.sin(ang) * K + (1.0 - math.cos(ang)) * (K @ K)


@dataclass(frozen=True, eq=False, init=False)
class MagnetWorkspace:
    """Where a permanent magnet may be: its centre in a box, its axis tilted at most ``max_tilt`` from a reference,
    optionally at least ``min_distance`` from a point (the robot's workspace, a patient).

    Parameters
    ----------
    bounds : array_like, shape (3, 2)
        ``[[xmin, xmax], [ymin, ymax], [zmin, zmax]]`` of the magnet's position (m), min <= max.
    max_tilt : float
        Largest angle between the magnet's axis and ``reference_axis`` (rad), in [0, pi]; default pi (any).
    reference_axis : array_like, shape (3,)
        The reference direction (normalized); default +z.
    magnet_axis : array_like, shape (3,)
        The magnet's axis in its own frame (normalized); default +z (a :class:`CylinderMagnet` built with
        ``axis=(0, 0, 1)``). The axis of a pose ``R`` is ``R @ magnet_axis``.
    keep_out_center : array_like, shape (3,), optional
        A point (m) the magnet's centre must stay ``min_distance`` from.
    min_distance : float
        That distance (m), >= 0; needs ``keep_out_center`` when > 0.

    Examples
    --------
    >>> import math
    >>> ws = MagnetWorkspace(bounds=[[-0.1, 0.1], [-0.1, 0.1], [0.05, 0.2]], max_tilt=math.radians(30))
    >>> p, R, clipped = ws.clip([0.0, 0.0, 0.3], [1.0, 0.0, 1.0])    # too high, tilted 45 deg
    >>> p.tolist(), round(math.degrees(ws.tilt(R)), 6), clipped
    ([0.0, 0.0, 0.2], 30.0, True)
    """

    bounds: np.ndarray
    max_tilt: float
    reference_axis: np.ndarray
    magnet_axis: np.ndarray
    keep_out_center: np.ndarray | None
    min_distance: float

    def __init__(self, *, bounds, max_tilt: float = math.pi, reference_axis=(0.0, 0.0, 1.0),
                 magnet_axis=(0.0, 0.0, 1.0), keep_out_center=None, min_distance: float = 0.0):
        bd = finite_array("MagnetWorkspace bounds", bounds)
        if bd.shape != (3, 2):
            raise ValueError(f"MagnetWorkspace bounds must have shape (3, 2): [[xmin, xmax], [ymin, ymax], [zmin, "
                             f"zmax]] (m), got shape {bd.shape}.")
        for i, axis in enumerate("xyz"):
            lo, hi = bd[i]
            if lo > hi:
                raise ValueError(f"MagnetWorkspace bounds {axis} must have min <= max (m), got "
                                 f"[{float(lo)!r}, {float(hi)!r}].")
            if max(abs(lo), abs(hi)) > MAX_COORDINATE:
                raise ValueError(f"MagnetWorkspace bounds {axis} must lie within {MAX_COORDINATE:g} m (metres), got "
                                 f"[{float(lo)!r}, {float(hi)!r}].")
        object.__setattr__(self, "bounds", bd)
        object.__setattr__(self, "max_tilt", in_range("MagnetWorkspace max_tilt", max_tilt, 0.0, math.pi, unit="rad"))
        object.__setattr__(self, "reference_axis", unit_vector("MagnetWorkspace reference_axis", reference_axis))
        object.__setattr__(self, "magnet_axis", unit_vector("MagnetWorkspace magnet_axis", magnet_axis))
        dmin = nonnegative("MagnetWorkspace min_distance", min_distance, unit="m")
        center = None if keep_out_center is None else position3("MagnetWorkspace keep_out_center", keep_out_center)
        if dmin > 0 and center is None:
            raise ValueError(f"MagnetWorkspace min_distance = {dmin!r} m needs keep_out_center (m, shape (3,)): the "
                             "point to keep away from.")
        object.__setattr__(self, "keep_out_center", center)
        object.__setattr__(self, "min_distance", dmin)

    def rotation(self, orientation) -> np.ndarray:
        """A pose's rotation (3, 3) from ``orientation``: a rotation matrix (or scipy Rotation), or the axis
        direction (3,) (the smallest rotation from ``magnet_axis`` to it), or None (the identity)."""
        if orientation is None:
            return np.eye(3)
        if hasattr(orientation, "as_matrix"):
            return rotation_matrix("orientation", orientation)
        arr = finite_array("orientation", orientation)
        if arr.shape == (3,):
            return _rotation_between(self.magnet_axis, unit_vector("orientation (the magnet's axis)", arr))
        if arr.shape == (3, 3):
            return rotation_matrix("orientation", arr)
        raise ValueError("orientation must be a rotation matrix (3, 3) or the magnet's axis direction (3,), got shape "
                         f"{arr.shape}.")

    def tilt(self, rotation) -> float:
        """The angle (rad) between the axis of ``rotation`` (``R @ magnet_axis``) and ``reference_axis``."""
        axis = self.rotation(rotation) @ self.magnet_axis
        return math.atan2(float(np.linalg.norm(np.cross(axis, self.reference_axis))),
                          float(np.dot(axis, self.reference_axis)))

    def check_pose(self, position, orientation=None) -> tuple[np.ndarray, np.ndarray]:
        """``(position (3,) m, rotation (3, 3))`` if the pose lies in the workspace; a ValueError naming the bound
        it breaks otherwise (``orientation`` as :meth:`rotation`)."""
        p = position3("position", position)
        R = self.rotation(orientation)
        for i, axis in enumerate("xyz"):
            lo, hi = self.bounds[i]
            if not lo <= p[i] <= hi:
                raise ValueError(f"position {axis} = {float(p[i])!r} m is outside the magnet workspace's {axis} bounds "
                                 f"[{lo:g}, {hi:g}] m.")
        t = self.tilt(R)
        if t > self.max_tilt + 1e-12:
            raise ValueError(f"the magnet's axis {np.round(R @ self.magnet_axis, 6).tolist()} is tilted "
                             f"{math.degrees(t):.6g} deg from the reference axis {self.reference_axis.tolist()}, "
                             f"beyond max_tilt = {math.degrees(self.max_tilt):.6g} deg.")
        if self.min_distance > 0:
            dist = float(np.linalg.norm(p - self.keep_out_center))
            if dist < self.min_distance:
                raise ValueError(f"position {p.tolist()} m is {dist:.6g} m from keep_out_center "
                                 f"{self.keep_out_center.tolist()} m, closer than min_distance = "
                                 f"{self.min_distance:g} m.")
        return p, R

    def clip(self, position, orientation=None) -> tuple[np.ndarray, np.ndarray, bool]:
        """The pose moved into the workspace: ``(position, rotation, clipped)``.

        The position is clipped to the box (the nearest point of it); where it is then closer than
        ``min_distance`` to ``keep_out_center`` it is pushed out along the line from that point and clipped to the
        box again (not the nearest admissible point in general: the box minus a ball is not convex). A tilt beyond
        ``max_tilt`` is reduced to it by the smallest rotation, in the plane of the axis and the reference. A pose
        for which this finds no admissible position raises a ValueError."""
        p = position3("position", position)
        R = self.rotation(orientation)
        q = np.clip(p, self.bounds[:, 0], self.bounds[:, 1])
        if self.min_distance > 0:
            v = q - self.keep_out_center
            dist = float(np.linalg.norm(v))
            if dist < self.min_distance:
                if dist == 0.0:
                    v, dist = self.reference_axis.copy(), 1.0
                q = np.clip(self.keep_out_center + v / dist * self.min_distance * (1 + 1e-12),
                            self.bounds[:, 0], self.bounds[:, 1])
                if np.linalg.norm(q - self.keep_out_center) < self.min_distance:
                    raise ValueError(f"position {p.tolist()} m cannot be moved into the magnet workspace: pushed "
                                     f"{self.min_distance:g} m from keep_out_center and back into the bounds it is "
                                     "still too close; choose a position farther away.")
        t = self.tilt(R)
        R2 = R
        if t > self.max_tilt:
            axis = R @ self.magnet_axis
            k = np.cross(axis, self.reference_axis)
            if np.linalg.norm(k) < 1e-12:  # pointing opposite to the reference: any perpendicular plane
                helper = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
                k = np.cross(axis, helper)
            k = k / np.linalg.norm(k)
            K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
            a = t - self.max_tilt
            R2 = (np.eye(3) + math.sin(a) * K + (1.0 - math.cos(a)) * (K @ K)) @ R
        clipped = bool(np.any(q != p) or t > self.max_tilt)
        return q, R2, clipped


@dataclass(frozen=True, eq=False, init=False)
class PosedMagnet:
    """A permanent magnet whose pose is the input, within a :class:`MagnetWorkspace`.

    Parameters
    ----------
    source : Source
        The magnet in its own frame (centred at its origin, its axis the workspace's ``magnet_axis``).
    workspace : MagnetWorkspace
        Where it may be.

    Examples
    --------
    >>> import math
    >>> from magsoft_env.fields import CylinderMagnet
    >>> magnet = CylinderMagnet(position=(0, 0, 0), axis=(0, 0, 1), radius=0.01, length=0.02, magnetization=1e6)
    >>> arm = PosedMagnet(magnet, MagnetWorkspace(bounds=[[-0.1, 0.1]] * 2 + [[0.05, 0.2]], max_tilt=math.pi / 4))
    >>> src = arm.at_pose([0.0, 0.0, 0.1], [0.0, 0.3, 1.0])      # a Transformed source
    >>> B = src.field([[0.0, 0.0, 0.0]])                            # (1, 3) T at the origin
    """

    source: Source
    workspace: MagnetWorkspace

    def __init__(self, source, workspace):
        if not isinstance(source, Source):
            raise ValueError(f"PosedMagnet source must be a field source, got {type(source).__name__}.")
        if not isinstance(workspace, MagnetWorkspace):
            raise ValueError(f"PosedMagnet workspace must be a MagnetWorkspace, got {type(workspace).__name__}.")
        object.__setattr__(self, "source", source)
        object.__setattr__(self, "workspace", workspace)

    def at_pose(self, position, orientation=None, *, clip: bool = False) -> Transformed:
        """The magnet at ``position`` (m, (3,)) with ``orientation`` (a rotation matrix (3, 3), the axis direction
        (3,), or None: the identity), as a :class:`Transformed` source. A pose outside the workspace is refused
        (a ValueError naming the bound), or moved into it with ``clip=True`` (:meth:`MagnetWorkspace.clip`)."""
        if boolean("at_pose clip", clip):
            p, R, _ = self.workspace.clip(position, orientation)
        else:
            p, R = self.workspace.check_pose(position, orientation)
        return Transformed(self.source, p, R)

    def field_and_gradient(self, points, *, position, orientation=None) -> tuple[np.ndarray, np.ndarray]:
        """Field (T, (n, 3)) and gradient (T/m, (n, 3, 3)) at ``points`` (m) with the magnet at the pose."""
        return self.at_pose(position, orientation).field_and_gradient(as_points(points))


__all__ = ["GRADIENT_ENTRIES", "STATUS_MESSAGES", "Allocation", "CoilDrive", "MagnetWorkspace", "PosedMagnet",
           "Reach", "allocate", "reachable_field"]

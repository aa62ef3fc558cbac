"""Exact sensitivities of a planar equilibrium: how the shape moves when a parameter of the robot or the load does.

At an equilibrium the collocation residual ``R(theta, p) = theta - theta_0 + P f(theta, p)`` vanishes
(:mod:`magsoft_env.theory.model`), so by the implicit-function theorem::

    d theta / d p = -J^-1 dR/dp,        J = dR/dtheta = I + P diag(f_theta)

with ``J`` the Jacobian the solver already factors. ``dR/dp`` is exact for the parameters the residual depends on
linearly or by a power law (inextensible beam):

=========================  ======================================================================================
``E0``                     ``P`` scales as 1/E0 (E = E0 exp(...)):  dR/dE0 = -P f / E0
``particle_magnetization`` the magnetic part of ``f`` scales with M_p:  P f_mag / M_p
``density``                (a number) the weight part scales with rho:  P f_grav / rho
``gravity``                P f_grav / g
``Bx``, ``Bz``             ``f`` is linear in the field:  P f(B = e_x), P f(B = e_z)
``clamp_angle``            dR/dtheta_0 = -1
``thickness``              EI ~ t^3, moment and weight ~ t:  dR/dt = -2 P f / t
``volume_fraction``        (a number) E, B_r and rho all change: central differences of the residual alone
                           (not of the solve), step 1e-6 of phi, about 1e-10 relative
profile parameters         (:func:`profile_sensitivities`) q changes beta(s) by d beta/dq and ln m(s) by
                           d ln m/dq: exact through mc = m cos beta, ms = m sin beta
=========================  ======================================================================================

(the width cancels from the planar equation). The tip's position and angle follow by differentiating
``x = Q0 cos theta``, ``z = Q0 sin theta``. The derivative exists where ``J`` is regular: at a fold it does not,
and :func:`sensitivities` says so instead of returning a number (the smallest eigenvalue of the second
variation, in EI/L^2, below ``FOLD_EIGENVALUE``). One factorization serves every parameter: a full gradient
costs less than one forward solve.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from .model import BeamModel, Load

#: The parameters :func:`sensitivities` differentiates with respect to (SI units).
PARAMETERS = ("E0", "particle_magnetization", "density", "gravity", "Bx", "Bz", "clamp_angle", "thickness",
              "volume_fraction")
#: Smallest eigenvalue of the second variation (units EI/L^2) below which the equilibrium counts as at a fold.
FOLD_EIGENVALUE = 1e-6
_UNITS = {"E0": "Pa", "particle_magnetization": "A/m", "density": "kg/m^3", "gravity": "m/s^2", "Bx": "T",
          "Bz": "T", "clamp_angle": "rad", "thickness": "m", "volume_fraction": "1"}


@dataclass(frozen=True)
class Sensitivity:
    """Derivatives of one planar equilibrium with respect to parameters (frozen).

    Attributes
    ----------
    params : tuple of str
        The parameters, in order.
    theta : (n, k) ndarray
        d theta / d p at the distinct nodes (rad per unit of each parameter, SI).
    tip_position : (3, k) ndarray
        d (x_L, 0, z_L) / d p (m per unit).
    tip_angle : (k,) ndarray
        d theta(L) / d p (rad per unit).
    s : (n,) ndarray
        Arc length of the nodes (m).
    min_eigenvalue : float
        Smallest eigenvalue of the second variation (EI/L^2) at the equilibrium: how far from a fold.
    units : dict
        The SI unit of each parameter.
    """

    params: tuple
    theta: np.ndarray
    tip_position: np.ndarray
    tip_angle: np.ndarray
    s: np.ndarray
    min_eigenvalue: float
    units: dict
    _positions: tuple | None = dataclasses.field(default=None, repr=False, compare=False)

    def positions(self, s) -> np.ndarray:
        """d (x, 0, z) / d p at reference arc lengths ``s`` (m): shape ``(len(s), 3, k)`` (m per unit)."""
        grid, dx, dz = self._positions
        s = np.atleast_1d(np.asarray(s, dtype=float))
        L = float(grid.edges[-1])
        if not np.all(np.isfinite(s)) or np.any(s < 0) or np.any(s > L * (1 + 1e-12)):
            raise ValueError(f"s must lie in [0, {L:g}] m, got {s.tolist()}.")
        k = dx.shape[1]
        both = grid.interpolate(np.concatenate([dx, dz], axis=1), s)  # one interpolation for x and z
        ix, iz = both[:, :k], both[:, k:]
        return np.stack([ix, np.zeros_like(ix), iz], axis=1)

    def __getitem__(self, name: str) -> dict:
        """The derivatives with respect to one parameter: ``{"theta", "tip_position", "tip_angle"}``."""
        if name not in self.params:
            raise KeyError(f"no derivative with respect to {name!r}; this result has {list(self.params)}.")
        k = self.params.index(name)
        return {"theta": self.theta[:, k], "tip_position": self.tip_position[:, k],
                "tip_angle": float(self.tip_angle[k])}


def check_params(params, allowed=PARAMETERS, what: str = "sensitivities") -> tuple[str, ...]:
    """``params`` as a tuple of names from ``allowed``, or a ValueError (unknown name with a suggestion, none,
    a repeat) saying which ``what`` are available."""
    if isinstance(params, str):
        params = (params,)
    try:
        params = tuple(params)
    except TypeError:
        raise ValueError(f"params must be a sequence of parameter names, got {params!r}.") from None
    if not params:
        raise ValueError(f"params must name at least one of {list(allowed)}, got none.")
    for p in params:
        if p not in allowed:
            import difflib

            close = difflib.get_close_matches(str(p), allowed, n=1)
            hint = f" Did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"unknown parameter {p!r}: {what} are available for {list(allowed)}.{hint}")
    if len(set(params)) != len(params):
        raise ValueError(f"params must not repeat a name, got {list(params)}.")
    return params


def _state(result):
    """(model, full-node theta, load, theta0) of a planar cantilever equilibrium, or a ValueError."""
    from .solver import EquilibriumResult

    if not isinstance(result, EquilibriumResult):
        hint = ""
        from .rod_solver import RodResult

        if isinstance(result, RodResult):
            hint = " (a 3D result: magsoft_env.theory.rod_sensitivities, or source_rod_sensitivities in a source)"
        raise ValueError("sensitivities take a planar EquilibriumResult (magsoft_env.solve_equilibrium with a "
                         f"uniform field and model='planar'), got {type(result).__name__}{hint}.")
    if not result.success:
        raise ValueError(f"the equilibrium was not found (status {result.status}): no sensitivities. "
                         f"{result.message}")
    mdl, th, load, clamped, _ = result._eig
    if not clamped:
        raise ValueError("sensitivities are implemented for the cantilever (support='cantilever'), not a free beam.")
    if mdl.extensible:
        raise ValueError("sensitivities are implemented for the inextensible beam (extensible=False).")
    return mdl, th, load


def sensitivities(result, params=("E0", "particle_magnetization")) -> Sensitivity:
    """Exact derivatives of a planar cantilever equilibrium with respect to ``params``.

    Parameters
    ----------
    result : EquilibriumResult
        A successful planar, inextensible cantilever equilibrium (:func:`magsoft_env.solve_equilibrium`).
    params : sequence of str
        Any of :data:`PARAMETERS` (SI units: Pa, A/m, kg/m^3, m/s^2, T, rad, m, 1).

    Returns
    -------
    Sensitivity

    Raises
    ------
    ValueError
        On an unknown parameter, an unsupported result, a density given as a function (for ``density``), a
        varying volume fraction (for ``volume_fraction``), or an equilibrium at a fold (where the derivative does
        not exist).

    Examples
    --------
    >>> import magsoft_env as ms
    >>> from magsoft_env.theory.sensitivity import sensitivities
    >>> beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> r = ms.solve_equilibrium(beam, (0.0, 5e-3))
    >>> d = sensitivities(r, ["E0"])
    >>> bool(d["E0"]["tip_position"][2] < 0)   # a stiffer beam rises less toward a field along +z
    True
    """
    params = check_params(params)
    mdl, th, load = _state(result)
    lam = float(result.min_eigenvalue)
    if not lam > FOLD_EIGENVALUE:
        raise ValueError(f"the equilibrium is at (or past) a fold: smallest eigenvalue {lam:.3g} EI/L^2 <= "
                         f"{FOLD_EIGENVALUE:g}; the shape's derivative does not exist there.")
    cols = _param_columns(mdl, th, load, params)
    return _solve(mdl, th, load, np.column_stack(cols), params, {p: _UNITS[p] for p in params}, lam)


def collocation_nodes(result) -> np.ndarray:
    """The arc lengths (m) at which ``result``'s equilibrium evaluates the beam's coefficients: the rows of an array
    ``dbeta`` or ``dlog_moment`` given to :func:`profile_sensitivities` (``M`` of them, interface nodes repeated and
    nudged into their own subdomain, so that one-sided values of a discontinuous profile are taken)."""
    mdl, _, _ = _state(result)
    return mdl.grid.s_eval.copy()


def _profile_array(name, value, s_eval) -> np.ndarray | None:
    """``value`` (a callable of s or an array at the collocation nodes) as an (M, k) array, or None."""
    if value is None:
        return None
    if callable(value):
        a = value(s_eval.copy())
        where = "its values at the collocation nodes"
    else:
        a = value
        where = "the array"
    try:
        a = np.array(a, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a callable of s (m) or an array of numbers, "
                         f"got {type(a).__name__}.") from None
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[0] != s_eval.size or a.shape[1] < 1:
        raise ValueError(f"{name} must give one row per collocation node ({s_eval.size}; collocation_nodes(result)) "
                         f"and one column per parameter: {where} has shape {np.shape(a)}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite: {where} holds NaN or inf.")
    return a


def profile_sensitivities(result, dbeta=None, *, dlog_moment=None, names=None, params=(),
                          exact_eigenvalue: bool = True) -> Sensitivity:
    """Exact derivatives of a planar cantilever equilibrium with respect to the parameters of its magnetization
    profile (and, in the same solve, any of :data:`PARAMETERS`).

    A parameter ``q`` of the profile changes the magnetization angle by ``d beta(s)/dq`` and, optionally, the
    magnitude of the moment per length by ``d ln m(s)/dq``. Only the coefficients ``m cos beta`` and ``m sin beta``
    of ``f = r1 cos theta + r2 sin theta`` depend on them (r1 = ms Bx - mc Bz + g W1, r2 = ms Bz + mc Bx), so::

        dR/dq = P (df/dmc dmc/dq + df/dms dms/dq),
        dmc/dq = -m sin(beta) dbeta/dq + mc dln m/dq,   dms/dq = kappa (m cos(beta) dbeta/dq + ms dln m/dq)

        (kappa = 1 for the rotated coupling, 0 for the paper's: there m sin(beta) still enters through dmc)

    exactly; the shape's derivative is ``-J^-1 dR/dq`` with one factorization for all columns.

    Parameters
    ----------
    result : EquilibriumResult
        A successful planar, inextensible cantilever equilibrium.
    dbeta : callable or (M, k) array, optional
        ``d beta(s) / d q_j`` (rad per unit of q_j): a callable of the arc length (m) returning ``(len(s), k)``
        values (or ``(len(s),)`` for one parameter), or its values at :func:`collocation_nodes`.
    dlog_moment : callable or (M, k) array, optional
        ``d ln m(s) / d q_j`` (per unit of q_j), the relative change of the moment per length (a profile of the
        magnitude); same forms and the same ``k`` as ``dbeta`` when both are given.
    names : sequence of str, optional
        Names of the k profile parameters (default ``"q0"``, ``"q1"``, ...).
    params : sequence of str
        Further parameters of :data:`PARAMETERS` (``"Bx"``, ``"Bz"``, ``"volume_fraction"``, ...), after the
        profile's columns.
    exact_eigenvalue : bool
        True: the smallest eigenvalue of the second variation is computed (an eigensolve) and reported in
        ``min_eigenvalue``. False: only a Cholesky test decides whether it exceeds :data:`FOLD_EIGENVALUE`
        (several times cheaper than the eigensolve, for optimizers) and ``min_eigenvalue`` is NaN.

    Returns
    -------
    Sensitivity
        Columns in the order ``names`` then ``params``; the unit of a profile parameter is its own ("q").

    Raises
    ------
    ValueError
        On a wrongly shaped or non-finite ``dbeta`` / ``dlog_moment``, neither given nor ``params``, repeated names,
        what :func:`sensitivities` refuses, or an equilibrium at a fold.

    Examples
    --------
    >>> import magsoft_env as ms
    >>> from magsoft_env.theory.sensitivity import profile_sensitivities
    >>> beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> r = ms.solve_equilibrium(beam, (0.0, 5e-3))
    >>> d = profile_sensitivities(r, lambda s: 1.0 + 0.0 * s, names=["beta0"])   # turn all of beta together
    >>> bool(d["beta0"]["tip_angle"] < 0)   # magnetization turned toward +z: less torque from a field along +z
    True
    """
    mdl, th, load = _state(result)
    s_eval = mdl.grid.s_eval
    db = _profile_array("dbeta", dbeta, s_eval)
    dl = _profile_array("dlog_moment", dlog_moment, s_eval)
    k = db.shape[1] if db is not None else (dl.shape[1] if dl is not None else 0)
    if db is not None and dl is not None and db.shape[1] != dl.shape[1]:
        raise ValueError(f"dbeta and dlog_moment must describe the same parameters: {db.shape[1]} against "
                         f"{dl.shape[1]} columns.")
    try:
        extra = (params,) if isinstance(params, str) else tuple(params)
    except TypeError:
        raise ValueError(f"params must be a sequence of parameter names, got {params!r}.") from None
    extra = check_params(extra) if extra else ()
    if k == 0 and not extra:
        raise ValueError("give dbeta, dlog_moment or params: there is nothing to differentiate with respect to.")
    if names is None:
        names = tuple(f"q{j}" for j in range(k))
    else:
        if isinstance(names, str):
            names = (names,)
        names = tuple(str(n) for n in names)
        if len(names) != k:
            raise ValueError(f"names must name the {k} profile parameters, got {len(names)}.")
    allnames = names + extra
    if len(set(allnames)) != len(allnames):
        raise ValueError(f"parameter names must not repeat, got {list(allnames)}.")
    if exact_eigenvalue:
        lam = float(result.min_eigenvalue)
        at_fold = not lam > FOLD_EIGENVALUE
    else:
        lam = math.nan
        at_fold = mdl.cholesky(mdl.f_fth_at(th, load)[1], clamped=True, tol=-FOLD_EIGENVALUE) is None
    if at_fold:
        shown = f"{lam:.3g}" if exact_eigenvalue else "(Cholesky test)"
        raise ValueError(f"the equilibrium is at (or past) a fold: smallest eigenvalue {shown} EI/L^2 <= "
                         f"{FOLD_EIGENVALUE:g}; the shape's derivative does not exist there.")
    cols = []
    if k:
        # d mc, d ms per unit change of each parameter, at the collocation nodes
        rotated = result._eig[4] == "rotated"
        msin = mdl.ms if rotated else mdl.beam.moment_per_length(s_eval) * np.sin(mdl.beam.beta(s_eval))
        dmc = np.zeros((s_eval.size, k))
        dms = np.zeros((s_eval.size, k))
        if db is not None:
            dmc -= msin[:, None] * db
            if rotated:
                dms += mdl.mc[:, None] * db
        if dl is not None:
            dmc += mdl.mc[:, None] * dl
            dms += mdl.ms[:, None] * dl
        c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        Bx, Bz = load.Bx, load.Bz
        df = (dms * Bx - dmc * Bz) * c + (dms * Bz + dmc * Bx) * sn
        cols.extend((mdl.P @ df).T)
    cols.extend(_param_columns(mdl, th, load, extra))
    units = {n: "q" for n in names} | {p: _UNITS[p] for p in extra}
    return _solve(mdl, th, load, np.column_stack(cols), allnames, units, lam)


def _param_columns(mdl: BeamModel, th, load: Load, params) -> list:
    """dR/dp for each named parameter (see the module's table)."""
    beam = mdl.beam
    P = mdl.P

    def f_at(ld: Load) -> np.ndarray:
        return mdl.f_fth_at(th, ld)[0]

    f_all = f_at(load)
    cols = []
    for p in params:
        if p == "E0":
            d = -(P @ f_all) / beam.material.E0
        elif p == "particle_magnetization":
            Mp = beam.material.particle_magnetization
            if Mp == 0:
                raise ValueError("particle_magnetization is 0: the derivative with respect to it is taken relative "
                                 "to a non-zero value; give the beam a magnetization.")
            d = P @ f_at(Load(load.Bx, load.Bz, 0.0)) / Mp
        elif p == "density":
            rho = beam.material.density
            if callable(rho):
                raise ValueError("density is a function of the volume fraction in this beam's material: the "
                                 "derivative with respect to one density number does not apply.")
            d = P @ f_at(Load(0.0, 0.0, load.g)) / rho
        elif p == "gravity":
            d = P @ f_at(Load(0.0, 0.0, 1.0))
        elif p == "Bx":
            d = P @ f_at(Load(1.0, 0.0, 0.0))
        elif p == "Bz":
            d = P @ f_at(Load(0.0, 1.0, 0.0))
        elif p == "clamp_angle":
            d = -np.ones_like(th)
        elif p == "thickness":
            d = -2.0 * (P @ f_all) / beam.thickness
        else:  # volume_fraction: central differences of the residual alone
            d = _residual_difference(mdl, th, load, beam)
        cols.append(d)
    return cols


def _solve(mdl: BeamModel, th, load: Load, dR, params, units, lam) -> Sensitivity:
    """d theta / d p = -J^-1 dR/dp for the columns of ``dR``, and the centreline's derivatives."""
    J = np.eye(th.size) + mdl.P * mdl.f_fth_at(th, load)[1][None, :]
    dth = -scipy.linalg.lu_solve(scipy.linalg.lu_factor(J), dR)
    c, sn = np.cos(th), np.sin(th)
    Q0 = mdl.grid.Q0
    dx_all = -Q0 @ (sn[:, None] * dth)
    dz_all = Q0 @ (c[:, None] * dth)
    dx, dz = dx_all[-1], dz_all[-1]
    u = mdl.uniq
    return Sensitivity(params=params, theta=dth[u], tip_position=np.vstack([dx, np.zeros_like(dx), dz]),
                       tip_angle=dth[-1].copy(), s=mdl.grid.s[u], min_eigenvalue=lam,
                       units=units, _positions=(mdl.grid, dx_all, dz_all))


#: The parameters of an equilibrium in a field source (:class:`~magsoft_env.theory.sources.SourceResult`):
#: the material and load ones, and the source's translation (m) along x and z (its pose offset).
SOURCE_PARAMETERS = ("E0", "particle_magnetization", "density", "gravity", "clamp_angle", "thickness", "source_x",
                     "source_z", "source_pitch")
#: Step of the central differences in the source's position (fraction of L).
SOURCE_STEP = 1e-5


#: A source's pose parameters: translations (m) and turns (rad, right-handed about x, y, z through its centre).
SOURCE_POSE = {"source_x": 0, "source_y": 1, "source_z": 2, "source_roll": 3, "source_pitch": 4, "source_yaw": 5}


def source_center(source) -> np.ndarray:
    """The point a source turns about for ``source_roll|pitch|yaw``: the position of its one magnet or dipole
    (through placements: :func:`magsoft_env.fields.source_markers`), else the origin (a coil system's workspace
    centre, several magnets, a field with no parts)."""
    from ..fields import source_markers

    pts = [np.asarray(p, dtype=float).reshape(-1, 3) for kind, p in source_markers(source)
           if kind in ("magnet", "dipole")]
    pts = np.concatenate(pts) if pts else np.zeros((0, 3))
    return pts[0].copy() if len(pts) == 1 and np.all(np.isfinite(pts[0])) else np.zeros(3)


def turn_matrix(rotvec) -> np.ndarray:
    """The rotation matrix of a rotation vector (rad, axis times angle), by Rodrigues' formula."""
    w = np.asarray(rotvec, dtype=float)
    a = float(np.linalg.norm(w))
    if a == 0.0:
        return np.eye(3)
    k = w / a
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(a) * K + (1.0 - math.cos(a)) * (K @ K)


def turn_jacobian(rotvec) -> np.ndarray:
    """``J`` with ``R(w + dw) = (I + [J dw]x) R(w)`` to first order: the world-frame turn (rad) that a change of the
    rotation vector ``w`` makes (SO(3)'s left Jacobian; the identity at ``w = 0``)."""
    w = np.asarray(rotvec, dtype=float)
    a = float(np.linalg.norm(w))
    W = np.array([[0.0, -w[2], w[1]], [w[2], 0.0, -w[0]], [-w[1], w[0], 0.0]])
    if a < 1e-8:
        return np.eye(3) + 0.5 * W + (W @ W) / 6.0
    return np.eye(3) + (1.0 - math.cos(a)) / a**2 * W + (a - math.sin(a)) / a**3 * (W @ W)


def posed_source(source, offset=(0.0, 0.0, 0.0), rotvec=(0.0, 0.0, 0.0)):
    """``source`` turned by the rotation vector ``rotvec`` (rad) about :func:`source_center`, then translated by
    ``offset`` (m): a source's pose error, as :func:`magsoft_env.fit` fits it."""
    from ..fields import Transformed

    out = source
    if np.any(np.asarray(rotvec, dtype=float) != 0.0):
        c = source_center(source)
        out = Transformed(Transformed(source, position=-c), position=c, rotation=turn_matrix(rotvec))
    if np.any(np.asarray(offset, dtype=float) != 0.0):
        out = Transformed(out, position=offset)
    return out


def moved_source(source, param: str, value: float):
    """``source`` moved by ``value`` along one pose parameter of :data:`SOURCE_POSE`: translated (m) or turned
    (rad) about :func:`source_center`."""
    from ..fields import Transformed

    k = SOURCE_POSE[param]
    if k < 3:
        off = np.zeros(3)
        off[k] = value
        return Transformed(source, position=off)
    c = source_center(source)
    a = k - 3
    i, j = (a + 1) % 3, (a + 2) % 3
    R = np.eye(3)
    R[i, i] = R[j, j] = math.cos(value)
    R[j, i], R[i, j] = math.sin(value), -math.sin(value)
    return Transformed(Transformed(source, position=-c), position=c, rotation=R)


def pose_step(param: str, length: float) -> float:
    """The central-difference step of a pose parameter: :data:`SOURCE_STEP` of ``length`` (m) or rad."""
    return SOURCE_STEP * (length if SOURCE_POSE[param] < 3 else 1.0)


def source_sensitivities(result, params=("E0", "particle_magnetization")) -> Sensitivity:
    """Derivatives of a planar cantilever equilibrium in a field source with respect to ``params``.

    The residual there is ``R = theta - theta_0 - P h(theta, p)`` (:mod:`magsoft_env.theory.sources`), so
    ``d theta / d p = J^-1 P dh/dp`` with ``J`` the solver's Jacobian. ``dh/dp`` is exact for ``E0`` (P ~ 1/E0),
    ``particle_magnetization`` (the magnetic loads scale with it), ``density`` and ``gravity`` (the weight),
    ``thickness`` (EI ~ t^3, loads ~ t) and ``clamp_angle``; for ``source_x`` / ``source_z`` (the source
    translated along x or z, m) and ``source_pitch`` (turned about the y axis through its centre,
    :func:`source_center`, rad, right-handed) it is a central difference of h alone (a step of 1e-5 L or
    1e-5 rad), not of the solve. The Jacobian's own position derivative is the solver's (central differences of
    G): about 1e-8 relative. For a coil system's currents see :func:`current_sensitivities`.

    Parameters
    ----------
    result : SourceResult
        A successful planar equilibrium in a source (:func:`magsoft_env.solve_equilibrium` with a source).
    params : sequence of str
        Any of :data:`SOURCE_PARAMETERS`.
    """
    from .sources import SourceResult, _Load

    params = check_params(params, SOURCE_PARAMETERS, "sensitivities in a source")
    if not isinstance(result, SourceResult):
        raise ValueError(f"source_sensitivities take a planar SourceResult, got {type(result).__name__}.")
    beam, grid, th, mdl, h, J, mu = _source_state(result)
    P = mdl.P
    h_grav = mdl.loads(th, _Load((), result.gravity))[0]
    h_mag = h - h_grav
    cols = []
    for p in params:
        if p == "E0":
            d = P @ h / beam.material.E0
        elif p == "particle_magnetization":
            d = -(P @ h_mag) / beam.material.particle_magnetization
        elif p == "density":
            if callable(beam.material.density):
                raise ValueError("density is a function of the volume fraction in this beam's material.")
            d = -(P @ h_grav) / beam.material.density
        elif p == "gravity":
            d = -(P @ mdl.loads(th, _Load((), 1.0))[0])
        elif p == "clamp_angle":
            d = -np.ones_like(th)
        elif p == "thickness":
            d = 2.0 * (P @ h) / beam.thickness
        else:
            step = pose_step(p, beam.length)
            hp = mdl.loads(th, _Load(((1.0, moved_source(result.source, p, step)),), result.gravity))[0]
            hm = mdl.loads(th, _Load(((1.0, moved_source(result.source, p, -step)),), result.gravity))[0]
            d = -(P @ ((hp - hm) / (2.0 * step)))
        cols.append(d)
    units = {**_UNITS, "source_x": "m", "source_z": "m", "source_pitch": "rad"}
    return _planar_sensitivity(grid, th, J, cols, params, mu, {p: units[p] for p in params})


def _source_state(result):
    """``(beam, grid, theta, model, h, J, mu)`` of a planar equilibrium in a source: its loads, the solver's
    Jacobian and its smallest stability eigenvalue; a ValueError if it was not found or sits at a fold."""
    from .sources import _Load, _Model, _stability

    if not result.success:
        raise ValueError(f"the equilibrium was not found (status {result.status}): no sensitivities.")
    beam, grid = result._beam, result._grid
    th = result._full[0]
    mdl = _Model(beam, grid, result._coupling, float(th[0]))
    load = _Load(((1.0, result.source),), result.gravity)
    _, h, aux = mdl.residual(th, load)
    J = mdl.jacobian(th, load, aux)
    mu, _ = _stability(J)
    if not mu > FOLD_EIGENVALUE:
        raise ValueError(f"the equilibrium is at (or past) a fold: smallest eigenvalue {mu:.3g} <= "
                         f"{FOLD_EIGENVALUE:g}; the shape's derivative does not exist there.")
    return beam, grid, th, mdl, h, J, float(mu)


def _planar_sensitivity(grid, th, J, cols, params, mu, units) -> Sensitivity:
    """Solve ``J dtheta = -dR/dp`` for the columns ``cols`` and carry the angles to the positions."""
    dth = -scipy.linalg.lu_solve(scipy.linalg.lu_factor(J), np.column_stack(cols))
    c, sn = np.cos(th), np.sin(th)
    dx_all = -grid.Q0 @ (sn[:, None] * dth)
    dz_all = grid.Q0 @ (c[:, None] * dth)
    u = grid.unique()
    return Sensitivity(params=params, theta=dth[u], tip_position=np.vstack([dx_all[-1], np.zeros(len(params)),
                                                                           dz_all[-1]]),
                       tip_angle=dth[-1].copy(), s=grid.s[u], min_eigenvalue=float(mu), units=units,
                       _positions=(grid, dx_all, dz_all))


def coil_unit_sources(system) -> list:
    """One field source per coil of ``system`` (a :class:`~magsoft_env.fields.CoilSystem`) at one ampere."""
    from ..fields import DipoleSet

    out = []
    for i in range(system.n_coils):
        k = system.source_coil == i
        out.append(DipoleSet(system.source_positions[k], system.source_moments[k], scale=1.0))
    return out


def check_coil_source(source, system, currents, points) -> np.ndarray:
    """``currents`` checked against the coil system, and that ``source`` is ``system`` at them (its field and
    gradient at ``points`` equal to rounding); a ValueError otherwise."""
    from ..fields import CoilSystem

    if not isinstance(system, CoilSystem):
        raise ValueError(f"system must be a magsoft_env.fields.CoilSystem, got {type(system).__name__}.")
    I = system.check_currents(currents)
    B0, G0 = source.field_and_gradient(points)
    B1, G1 = system.field_and_gradient(points, I)
    scale = max(float(np.abs(B1).max()), 1e-300)
    gscale = max(float(np.abs(G1).max()), 1e-300)
    if not (np.abs(B0 - B1).max() <= 1e-9 * scale and np.abs(G0 - G1).max() <= 1e-9 * gscale):
        raise ValueError(f"the equilibrium was not solved in {system.name} at these currents (its field differs "
                         f"by up to {np.abs(B0 - B1).max():.3g} T): pass the system and currents it was solved in.")
    return I


def current_sensitivities(result, system, currents) -> Sensitivity:
    """Derivatives of an equilibrium in a coil system with respect to each coil's current (per ampere).

    The loads are linear in the field and its gradient, and these in the currents, so ``dR/dI_i`` is the load of
    coil ``i`` at one ampere, exact; one factorization of the solver's Jacobian serves every coil. ``result``
    is a planar :class:`~magsoft_env.theory.sources.SourceResult` or a 3D
    :class:`~magsoft_env.theory.rod_sources.SourceRodResult` (then a
    :class:`~magsoft_env.theory.rod_sensitivity.RodSensitivity`), solved in ``system.at_currents(currents)``
    (checked). The parameters are named ``I_<coil name>``, in the system's coil order.

    Examples
    --------
    >>> import magsoft_env as ms
    >>> from magsoft_env.fields import CoilSystem, allocate
    >>> from magsoft_env.theory.sensitivity import current_sensitivities
    >>> navion = CoilSystem.from_calibration("navion")
    >>> I = allocate(navion, (12e-3, 0, 0), field=(0.0, 0.0, 4e-3)).currents
    >>> r = ms.solve_equilibrium(ms.Beam(25e-3, 5e-3, 1.13e-3), navion.at_currents(I), model="planar")
    >>> S = current_sensitivities(r, navion, I)
    >>> len(S.params) == navion.n_coils, S.units[S.params[0]]
    (True, 'A')
    """
    from .rod_sources import SourceRodResult
    from .sources import SourceResult, _Load

    if isinstance(result, SourceRodResult):
        from .rod_sensitivity import current_rod_sensitivities

        return current_rod_sensitivities(result, system, currents)
    if not isinstance(result, SourceResult):
        raise ValueError("current_sensitivities take an equilibrium in a coil system (a SourceResult or "
                         f"SourceRodResult), got {type(result).__name__}.")
    _, grid, th, mdl, _, J, mu = _source_state(result)
    check_coil_source(result.source, system, currents, mdl.frame(th)[2])
    cols = [-(mdl.P @ mdl.loads(th, _Load(((1.0, u),), 0.0))[0]) for u in coil_unit_sources(system)]
    params = tuple(f"I_{n}" for n in system.coil_names)
    return _planar_sensitivity(grid, th, J, cols, params, mu, dict.fromkeys(params, "A"))


def _residual_difference(mdl: BeamModel, th, load: Load, beam) -> np.ndarray:
    from ..spec.profiles import Constant

    phi = beam.volume_fraction
    phi = phi.value if isinstance(phi, Constant) else phi
    if not isinstance(phi, (int, float)):
        raise ValueError("volume_fraction varies along this beam (a profile): the derivative with respect to one "
                         "number does not apply.")
    h = 1e-6 * max(abs(float(phi)), 1e-3)
    out = []
    for sign in (1.0, -1.0):
        b = dataclasses.replace(beam, volume_fraction=float(phi) + sign * h)
        # the coupling shows only in ms, which is zero for the paper's form (and for beta = 0 either way)
        m = BeamModel(b, mdl.grid, coupling="rotated" if np.any(mdl.ms) else "paper", extensible=False)
        out.append(m.P @ m.f_fth_at(th, load)[0])
    return (out[0] - out[1]) / (2.0 * h)


__all__ = ["FOLD_EIGENVALUE", "PARAMETERS", "SOURCE_PARAMETERS", "SOURCE_POSE", "Sensitivity", "check_coil_source",
           "coil_unit_sources", "collocation_nodes", "current_sensitivities", "moved_source", "pose_step",
           "posed_source", "profile_sensitivities", "sensitivities", "source_center", "source_sensitivities",
           "turn_jacobian", "turn_matrix"]

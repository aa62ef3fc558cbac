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
=========================  ======================================================================================

(the width cancels from the planar equation). The tip's position and angle follow by differentiating
``x = Q0 cos theta``, ``z = Q0 sin theta``. The derivative exists where ``J`` is regular: at a fold it does not,
and :func:`sensitivities` says so instead of returning a number (the smallest eigenvalue of the second
variation, in EI/L^2, below ``FOLD_EIGENVALUE``). One factorization serves every parameter: a full gradient
costs less than one forward solve.
"""

from __future__ import annotations

import dataclasses
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
        ix, iz = grid.interpolate(dx, s), grid.interpolate(dz, s)
        return np.stack([ix, np.zeros_like(ix), iz], axis=1)

    def __getitem__(self, name: str) -> dict:
        """The derivatives with respect to one parameter: ``{"theta", "tip_position", "tip_angle"}``."""
        if name not in self.params:
            raise KeyError(f"no derivative with respect to {name!r}; this result has {list(self.params)}.")
        k = self.params.index(name)
        return {"theta": self.theta[:, k], "tip_position": self.tip_position[:, k],
                "tip_angle": float(self.tip_angle[k])}


def _check_params(params) -> tuple[str, ...]:
    if isinstance(params, str):
        params = (params,)
    try:
        params = tuple(params)
    except TypeError:
        raise ValueError(f"params must be a sequence of parameter names, got {params!r}.") from None
    if not params:
        raise ValueError(f"params must name at least one of {list(PARAMETERS)}, got none.")
    for p in params:
        if p not in PARAMETERS:
            import difflib

            close = difflib.get_close_matches(str(p), PARAMETERS, n=1)
            hint = f" Did you mean {close[0]!r}?" if close else ""
            raise ValueError(f"unknown parameter {p!r}: sensitivities are available for {list(PARAMETERS)}.{hint}")
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
    params = _check_params(params)
    mdl, th, load = _state(result)
    lam = float(result.min_eigenvalue)
    if not lam > FOLD_EIGENVALUE:
        raise ValueError(f"the equilibrium is at (or past) a fold: smallest eigenvalue {lam:.3g} EI/L^2 <= "
                         f"{FOLD_EIGENVALUE:g}; the shape's derivative does not exist there.")
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
    dR = np.column_stack(cols)
    J = np.eye(th.size) + P * mdl.f_fth_at(th, load)[1][None, :]
    dth = -scipy.linalg.lu_solve(scipy.linalg.lu_factor(J), dR)
    c, sn = np.cos(th), np.sin(th)
    Q0 = mdl.grid.Q0
    dx_all = -Q0 @ (sn[:, None] * dth)
    dz_all = Q0 @ (c[:, None] * dth)
    dx, dz = dx_all[-1], dz_all[-1]
    u = mdl.uniq
    return Sensitivity(params=params, theta=dth[u], tip_position=np.vstack([dx, np.zeros_like(dx), dz]),
                       tip_angle=dth[-1].copy(), s=mdl.grid.s[u], min_eigenvalue=lam,
                       units={p: _UNITS[p] for p in params}, _positions=(mdl.grid, dx_all, dz_all))


#: The parameters of an equilibrium in a field source (:class:`~magsoft_env.theory.sources.SourceResult`):
#: the material and load ones, and the source's translation (m) along x and z (its pose offset).
SOURCE_PARAMETERS = ("E0", "particle_magnetization", "density", "gravity", "clamp_angle", "thickness", "source_x",
                     "source_z")
#: Step of the central differences in the source's position (fraction of L).
SOURCE_STEP = 1e-5


def source_sensitivities(result, params=("E0", "particle_magnetization")) -> Sensitivity:
    """Derivatives of a planar cantilever equilibrium in a field source with respect to ``params``.

    The residual there is ``R = theta - theta_0 - P h(theta, p)`` (:mod:`magsoft_env.theory.sources`), so
    ``d theta / d p = J^-1 P dh/dp`` with ``J`` the solver's Jacobian. ``dh/dp`` is exact for ``E0`` (P ~ 1/E0),
    ``particle_magnetization`` (the magnetic loads scale with it), ``density`` and ``gravity`` (the weight),
    ``thickness`` (EI ~ t^3, loads ~ t) and ``clamp_angle``; for ``source_x`` / ``source_z`` (the source
    translated along x or z, m) it is a central difference of h alone (a step of 1e-5 L), not of the solve.
    The Jacobian's own position derivative is the solver's (central differences of G): about 1e-8 relative.

    Parameters
    ----------
    result : SourceResult
        A successful planar equilibrium in a source (:func:`magsoft_env.solve_equilibrium` with a source).
    params : sequence of str
        Any of :data:`SOURCE_PARAMETERS`.
    """
    from ..fields import Transformed
    from .sources import SourceResult, _Load, _Model, _stability

    if isinstance(params, str):
        params = (params,)
    params = tuple(params)
    for p in params:
        if p not in SOURCE_PARAMETERS:
            import difflib

            close = difflib.get_close_matches(str(p), SOURCE_PARAMETERS, n=1)
            raise ValueError(f"unknown parameter {p!r}: sensitivities in a source are available for "
                             f"{list(SOURCE_PARAMETERS)}." + (f" Did you mean {close[0]!r}?" if close else ""))
    if not params or len(set(params)) != len(params):
        raise ValueError(f"params must name distinct parameters of {list(SOURCE_PARAMETERS)}, got {list(params)}.")
    if not isinstance(result, SourceResult):
        raise ValueError(f"source_sensitivities take a planar SourceResult, got {type(result).__name__}.")
    if not result.success:
        raise ValueError(f"the equilibrium was not found (status {result.status}): no sensitivities.")
    beam, grid = result._beam, result._grid
    th = result._full[0]
    mdl = _Model(beam, grid, result._coupling, float(th[0]))
    load = _Load(((1.0, result.source),), result.gravity)
    R, h, aux = mdl.residual(th, load)
    J = mdl.jacobian(th, load, aux)
    mu, _ = _stability(J)
    if not mu > FOLD_EIGENVALUE:
        raise ValueError(f"the equilibrium is at (or past) a fold: smallest eigenvalue {mu:.3g} <= "
                         f"{FOLD_EIGENVALUE:g}; the shape's derivative does not exist there.")
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
            axis = 0 if p == "source_x" else 2
            step = SOURCE_STEP * beam.length
            off = np.zeros(3)
            off[axis] = step
            hp = mdl.loads(th, _Load(((1.0, Transformed(result.source, position=off)),), result.gravity))[0]
            hm = mdl.loads(th, _Load(((1.0, Transformed(result.source, position=-off)),), result.gravity))[0]
            d = -(P @ ((hp - hm) / (2.0 * step)))
        cols.append(d)
    dth = -scipy.linalg.lu_solve(scipy.linalg.lu_factor(J), np.column_stack(cols))
    c, sn = np.cos(th), np.sin(th)
    dx_all = -grid.Q0 @ (sn[:, None] * dth)
    dz_all = grid.Q0 @ (c[:, None] * dth)
    u = grid.unique()
    units = {**_UNITS, "source_x": "m", "source_z": "m"}
    return Sensitivity(params=params, theta=dth[u], tip_position=np.vstack([dx_all[-1], np.zeros(len(params)),
                                                                           dz_all[-1]]),
                       tip_angle=dth[-1].copy(), s=grid.s[u], min_eigenvalue=float(mu),
                       units={p: units[p] for p in params}, _positions=(grid, dx_all, dz_all))


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


__all__ = ["FOLD_EIGENVALUE", "PARAMETERS", "SOURCE_PARAMETERS", "Sensitivity", "sensitivities", "source_sensitivities"]

"""Exact sensitivities of a 3D rod equilibrium: how the frames and the tip move when a parameter does.

The 3D solver (:mod:`magsoft_env.theory.rod_solver`) finds the frame field ``q`` (unit quaternions at the
collocation nodes) where the collocation residual ``F(q, p)`` (:meth:`~magsoft_env.theory.rod.RodModel.system`,
3 rows per node, row 0 the clamp) vanishes, by Newton on spatial rotations ``psi`` at every node
(``q -> exp(psi / 2) q``: the quaternions stay unit by construction, so there are no norm or gauge rows). The
implicit-function theorem on the same system gives::

    psi_p = d psi / d p = -J^-1 dF/dp,        J = dF/dpsi  (the solver's Jacobian, RodModel.jacobian)

and every output follows from the rotation ``psi_p`` of each frame: ``d q = (1/2) (0, psi_p) q``,
``d R = [psi_p]x R``, ``d d3 = psi_p x d3``, ``d r = Q0 (psi_p x d3)`` (positions are the integral of the
tangent), and the twist's derivative ``Q0 d k_3`` with the curvature's change by a complex step of
:meth:`~magsoft_env.theory.rod.RodModel.curvature` (a polynomial in q: exact to rounding).

``dF/dp`` is a complex step of ``F`` alone (never of the solve) in the quantities ``F`` is built from, the
stiffnesses ``K = (E I_w, E I_s, G J)``, the moment per length ``a``, the weight beyond s per unit g ``W1``, the
clamp frame ``q0``, the field and gravity, moved along their exact derivatives in ``p``:

=========================  ===========================================================================================
``E0``                     K ~ E0 (E = E0 exp(...), G = E / (2 (1 + nu))): dK = K / E0
``particle_magnetization`` a ~ M_p: da = a / M_p
``density``                (a number) W1 ~ rho: dW1 = W1 / rho
``gravity``                dg = 1 (m/s^2)
``Bx``, ``By``, ``Bz``     dB = e_x, e_y, e_z (T)
``clamp_angle``            dq0 = d/dtheta_0 of the clamp quaternion (a turn about -y)
``thickness``              E I_w ~ h^3, E I_s ~ h, a and W1 ~ h; G J by the exact derivative of the Saint-Venant
                           series in h (:func:`torsion_derivatives`)
``width``                  E I_w ~ w, E I_s ~ w^3, a and W1 ~ w; G J by the series' derivative in w
``poisson_ratio``          G J ~ 1 / (1 + nu)
``volume_fraction``        (a constant) E, B_r and rho all change: central differences (1e-6 of phi) of the
                           coefficients K, a and W1 alone (not of F, not of the solve), about 1e-10 relative
=========================  ===========================================================================================

so ``dF/dp`` is exact to rounding for all but ``volume_fraction``. In a field source
(:class:`~magsoft_env.theory.rod_sources.SourceRodResult`) the source's field is evaluated in real arithmetic at
the (real) positions, the rest of ``F`` is polynomial in the same coefficients, so the same complex step applies;
the source's translation ``source_x``, ``source_y``, ``source_z`` (m) is a central difference of ``F`` alone
(a step of 1e-5 L), and the Jacobian is the source solver's (its position derivative of the gradient force by
central differences): about 1e-8 relative there.

The derivative exists where ``J`` is regular: at a fold or a bifurcation it does not, and the functions refuse an
equilibrium whose smallest eigenvalue of the second variation (E I_w / L^2) is below
:data:`~magsoft_env.theory.sensitivity.FOLD_EIGENVALUE`. One factorization of ``J`` serves every parameter (a few
residual evaluations each): a full gradient costs less than one forward solve.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from ..threads import single_threaded_blas
from .rod import _H, Load3, qmat, qmul
from .sensitivity import _UNITS, FOLD_EIGENVALUE, Sensitivity, check_params

#: Parameters of :func:`rod_sensitivities` (a 3D cantilever in a uniform field), SI units.
ROD_PARAMETERS = ("E0", "particle_magnetization", "density", "gravity", "Bx", "By", "Bz", "clamp_angle", "thickness",
                  "width", "poisson_ratio", "volume_fraction")
#: Parameters of :func:`source_rod_sensitivities` (a 3D cantilever in a field source): the material and geometry
#: ones, and the source's translation (m) along x, y, z.
SOURCE_ROD_PARAMETERS = ("E0", "particle_magnetization", "density", "gravity", "clamp_angle", "thickness", "width",
                         "poisson_ratio", "volume_fraction", "source_x", "source_y", "source_z", "source_roll",
                         "source_pitch", "source_yaw")
#: Step of the central differences in the source's position (fraction of L).
SOURCE_STEP = 1e-5
#: Relative step of the central differences of the coefficients in the volume fraction.
PHI_STEP = 1e-6
_UNITS3 = {**_UNITS, "By": "T", "width": "m", "poisson_ratio": "1", "source_x": "m", "source_y": "m",
           "source_z": "m", "source_roll": "rad", "source_pitch": "rad", "source_yaw": "rad"}
_TORSION_RTOL = 1e-16  # as magsoft_env.spec.beam


@dataclass(frozen=True, kw_only=True)
class RodSensitivity(Sensitivity):
    """Derivatives of one 3D rod equilibrium with respect to parameters (frozen): a
    :class:`~magsoft_env.theory.sensitivity.Sensitivity` with the 3D quantities.

    Arrays hold one row per distinct node (``n``, from the clamp to the tip) and one column per parameter (``k``),
    in units of the quantity per SI unit of the parameter.

    Attributes (beyond Sensitivity's)
    ---------------------------------
    theta : (n, k) ndarray
        d/dp of the in-plane angle of the tangent, ``atan2(d3_z, d3_x)`` (rad per unit): the planar ``theta``.
    tip_position : (3, k) ndarray
        d r(L) / d p (m per unit), all three components.
    tip_angle : (k,) ndarray
        ``theta``'s row at the tip.
    rotation : (n, 3, k) ndarray
        The spatial rotation vector of each frame per unit parameter (rad per unit): ``d R = [rotation]x R``.
    frames : (n, 3, 3, k) ndarray
        d [d1 d2 d3] / d p.
    quaternions : (n, 4, k) ndarray
        d q / d p (scalar first), tangent to the unit sphere.
    curvature : (n, 3, k) ndarray
        d (k1, k2, k3) / d p (1/m per unit).
    twist : (n, k) ndarray
        d twist(s) / d p (rad per unit).
    tip_tangent : (3, k) ndarray
        d d3(L) / d p.
    tip_twist : (k,) ndarray
        d twist(L) / d p (rad per unit).
    """

    rotation: np.ndarray
    frames: np.ndarray
    quaternions: np.ndarray
    curvature: np.ndarray
    twist: np.ndarray
    tip_tangent: np.ndarray
    tip_twist: np.ndarray

    def positions(self, s) -> np.ndarray:
        """d r / d p at reference arc lengths ``s`` (m): shape ``(len(s), 3, k)`` (m per unit), interpolated."""
        grid, dr = self._positions
        s = np.atleast_1d(np.asarray(s, dtype=float))
        L = float(grid.edges[-1])
        if not np.all(np.isfinite(s)) or np.any(s < 0) or np.any(s > L * (1 + 1e-12)):
            raise ValueError(f"s must lie in [0, {L:g}] m, got {s.tolist()}.")
        k = dr.shape[2]
        return grid.interpolate(dr.reshape(dr.shape[0], 3 * k), s).reshape(s.size, 3, k)

    def __getitem__(self, name: str) -> dict:
        """The derivatives with respect to one parameter: Sensitivity's, and ``"rotation"``, ``"frames"``,
        ``"tip_tangent"``, ``"tip_twist"``."""
        d = super().__getitem__(name)
        k = self.params.index(name)
        d.update(rotation=self.rotation[:, :, k], frames=self.frames[..., k], tip_tangent=self.tip_tangent[:, k],
                 tip_twist=float(self.tip_twist[k]))
        return d


# the coefficients of RodModel and their derivatives ---------------------------------------------------------
def _coefficients(beam, grid):
    """(K, a, W1) of :class:`~magsoft_env.theory.rod.RodModel` for ``beam`` on ``grid`` (its own formulas)."""
    s = grid.s_eval
    K = np.asarray(beam.stiffnesses(s), dtype=float)
    m_hat = np.asarray(beam.magnetization_direction(s), dtype=float)
    a = beam.moment_per_length(s)[:, None] * m_hat[:, [1, 2, 0]]
    W1 = grid.QL @ beam.mass_per_length(s)
    return K, a, W1


def torsion_derivatives(width: float, thickness: float) -> tuple[float, float, float]:
    """The Saint-Venant torsion constant J of the w x h rectangle (m^4) (:attr:`Beam.torsion_constant`'s series)
    and its exact derivatives (dJ/dw, dJ/dh) (m^3).

    With a = max(w, h), b = min(w, h), r = a / b and ``S(r) = sum_{n odd} tanh(n pi r / 2) / n^5``::

        J = a b^3 / 3 - (64 / pi^5) b^4 S(r),    S'(r) = (pi / 2) sum sech^2(n pi r / 2) / n^4
        dJ/da = b^3 / 3 - (64 / pi^5) b^3 S'(r),  dJ/db = a b^2 - (64 / pi^5) (4 b^3 S(r) - a b^2 S'(r))
    """
    w, h = float(width), float(thickness)
    a, b = max(w, h), min(w, h)
    n = np.arange(1.0, 2.0 * math.ceil(_TORSION_RTOL ** -0.2) + 3.0, 2.0)
    x = n * math.pi * a / (2.0 * b)
    terms = np.tanh(x) / n**5
    keep = terms >= _TORSION_RTOL * terms[0]
    S = float(np.sum(terms[keep][::-1]))
    e = np.exp(-2.0 * x)
    sech2 = 4.0 * e / (1.0 + e) ** 2
    dS = float(np.sum((0.5 * math.pi * sech2 / n**4)[::-1]))
    c = 64.0 / math.pi**5
    J = a * b**3 / 3.0 - c * b**4 * S
    dJa = b**3 / 3.0 - c * b**3 * dS
    dJb = a * b**2 - c * (4.0 * b**3 * S - a * b**2 * dS)
    return (J, dJa, dJb) if w >= h else (J, dJb, dJa)


@dataclass
class _Direction:
    """A direction of the coefficients of F: their change per unit of one parameter."""

    dK: np.ndarray | float = 0.0
    da: np.ndarray | float = 0.0
    dW1: np.ndarray | float = 0.0
    dq0: np.ndarray | float = 0.0
    dB: tuple = (0.0, 0.0, 0.0)
    dg: float = 0.0


def _direction(p: str, mdl, beam) -> _Direction:
    """The exact change of (K, a, W1, q0, B, g) per unit of parameter ``p`` (central differences of the
    coefficients for ``volume_fraction``), or a ValueError where the derivative does not apply."""
    mat = beam.material
    K, a, W1 = mdl.K, mdl.a, mdl.W1
    if p == "E0":
        return _Direction(dK=K / mat.E0)
    if p == "particle_magnetization":
        if mat.particle_magnetization == 0:
            raise ValueError("particle_magnetization is 0: the derivative with respect to it is taken relative to a "
                             "non-zero value; give the beam a magnetization.")
        return _Direction(da=a / mat.particle_magnetization)
    if p == "density":
        if callable(mat.density):
            raise ValueError("density is a function of the volume fraction in this beam's material: the derivative "
                             "with respect to one density number does not apply.")
        return _Direction(dW1=W1 / mat.density)
    if p == "gravity":
        return _Direction(dg=1.0)
    if p in ("Bx", "By", "Bz"):
        dB = [0.0, 0.0, 0.0]
        dB[("Bx", "By", "Bz").index(p)] = 1.0
        return _Direction(dB=tuple(dB))
    if p == "clamp_angle":
        # q0(theta_0) = exp(theta_0 / 2 (0, -e_y)) q0(0): dq0 = (1/2) (0, -e_y) q0
        return _Direction(dq0=0.5 * qmul(np.array([0.0, 0.0, -1.0, 0.0]), mdl.q0))
    if p in ("thickness", "width"):
        w, h = beam.width, beam.thickness
        J, dJw, dJh = torsion_derivatives(w, h)
        if p == "thickness":
            rel = np.array([3.0 / h, 1.0 / h, dJh / J])
            return _Direction(dK=K * rel, da=a / h, dW1=W1 / h)
        rel = np.array([1.0 / w, 3.0 / w, dJw / J])
        return _Direction(dK=K * rel, da=a / w, dW1=W1 / w)
    if p == "poisson_ratio":
        dK = np.zeros_like(K)
        dK[:, 2] = -K[:, 2] / (1.0 + mat.poisson_ratio)
        return _Direction(dK=dK)
    # volume_fraction
    from ..spec.profiles import Constant

    phi = beam.volume_fraction
    if not isinstance(phi, Constant):
        raise ValueError("volume_fraction varies along this beam (a profile): the derivative with respect to one "
                         "number does not apply.")
    phi = float(phi.value)
    step = PHI_STEP * max(abs(phi), 1e-3)
    up = _coefficients(dataclasses.replace(beam, volume_fraction=phi + step), mdl.grid)
    dn = _coefficients(dataclasses.replace(beam, volume_fraction=phi - step), mdl.grid)
    dK, da, dW1 = ((u - d) / (2.0 * step) for u, d in zip(up, dn, strict=True))
    return _Direction(dK=dK, da=da, dW1=dW1)


def _residual_rate(mdl, q, load, d: _Direction, *, source: bool) -> np.ndarray:
    """dF/dp along ``d`` by a complex step of F alone in the coefficients (exact to rounding: F is a rational
    function of K, a, W1, q0, B and g at fixed q, and a source's field is evaluated at the real positions)."""
    m = copy.copy(mdl)
    ih = 1j * _H
    m.K = mdl.K + ih * np.asarray(d.dK)
    m.a = mdl.a + ih * np.asarray(d.da)  # complex even when da = 0 (the source model adds into it in place)
    m.W1 = mdl.W1 + ih * np.asarray(d.dW1)
    m.q0 = mdl.q0 + ih * np.asarray(d.dq0)
    if source:
        ld = dataclasses.replace(load, g=load.g + ih * d.dg)
    else:
        ld = Load3(*(v + ih * dv for v, dv in zip(load, (*d.dB, d.dg), strict=True)))
    return m.system(q, ld).imag / _H


def _source_pose_rate(mdl, q, load, param: str) -> np.ndarray:
    """dF/d(a pose parameter of every source of the load: a translation or a turn about its centre) by central
    differences of F alone (a step of SOURCE_STEP L, or SOURCE_STEP rad)."""
    from .sensitivity import moved_source, pose_step

    step = pose_step(param, mdl.L)
    out = []
    for sign in (1.0, -1.0):
        terms = tuple((w, moved_source(src, param, sign * step)) for w, src in load.terms)
        out.append(mdl.system(q, dataclasses.replace(load, terms=terms)))
    return (out[0] - out[1]) / (2.0 * step)


def current_rod_sensitivities(result, system, currents) -> RodSensitivity:
    """Derivatives of a 3D equilibrium in a coil system with respect to each coil's current (per ampere): the
    residual is affine in the sources' fields, so ``dF/dI_i = (F(+coil i at 1 A) - F(-coil i at 1 A)) / 2``
    (exact to rounding). See :func:`magsoft_env.theory.sensitivity.current_sensitivities`."""
    from .sensitivity import check_coil_source, coil_unit_sources

    with single_threaded_blas():
        mdl, q, load, lam = _check_result(result, source=True)
        check_coil_source(result.source, system, currents, result.centreline)
        cols = []
        for u in coil_unit_sources(system):
            Fp = mdl.system(q, dataclasses.replace(load, terms=(*load.terms, (1.0, u))))
            Fm = mdl.system(q, dataclasses.replace(load, terms=(*load.terms, (-1.0, u))))
            cols.append(0.5 * (Fp - Fm))
        params = tuple(f"I_{n}" for n in system.coil_names)
        return _sensitivity(mdl, q, load, np.column_stack(cols), params, lam, dict.fromkeys(params, "A"))


# the checks and the solve --------------------------------------------------------------------------------------
def _check_result(result, source: bool):
    from .rod_solver import RodResult
    from .rod_sources import SourceRodResult

    if source:
        if not isinstance(result, SourceRodResult):
            raise ValueError("source_rod_sensitivities take a 3D SourceRodResult (magsoft_env.solve_equilibrium with "
                             f"a field source and model='3d'), got {type(result).__name__}.")
    elif not isinstance(result, RodResult) or isinstance(result, SourceRodResult):
        hint = " (in a field source: source_rod_sensitivities)" if isinstance(result, SourceRodResult) else ""
        raise ValueError("rod_sensitivities take a 3D RodResult in a uniform field (magsoft_env.solve_equilibrium "
                         f"with model='3d'){hint}, got {type(result).__name__}.")
    if not result.success:
        raise ValueError(f"the equilibrium was not found (status {result.status}): no sensitivities. {result.message}")
    mdl, q, load = result._state
    if mdl.free:
        raise ValueError("sensitivities are implemented for the cantilever (support='cantilever'), not a free beam: "
                         "its rigid rotation about the field leaves the equilibrium undetermined.")
    lam = float(result.min_eigenvalue)
    if not lam > FOLD_EIGENVALUE:
        raise ValueError(f"the equilibrium is at (or past) a fold or bifurcation: smallest eigenvalue {lam:.3g} "
                         f"E I_w/L^2 <= {FOLD_EIGENVALUE:g}; the shape's derivative does not exist there.")
    return mdl, q, load, lam


def _sensitivity(mdl, q, load, dF: np.ndarray, params, lam, units: dict | None = None) -> RodSensitivity:
    """Solve J psi_p = -dF/dp and carry the frames' rotations to every output."""
    M, k = q.shape[0], dF.shape[1]
    _, J = mdl.jacobian(q, load)
    psi = -scipy.linalg.lu_solve(scipy.linalg.lu_factor(J, check_finite=False), dF, check_finite=False)
    psi = psi.reshape(M, 3, k)
    R = qmat(q)
    d3 = R[:, :, 2]
    dd3 = np.cross(psi, d3[:, :, None], axisa=1, axisb=1, axisc=1)  # (M, 3, k)
    dr = np.einsum("ij,jck->ick", mdl.Q0, dd3)
    # d R = [psi]x R: column c of R turned, (M, 3, 3, k)
    dR = np.stack([np.cross(psi, R[:, :, c][:, :, None], axisa=1, axisb=1, axisc=1) for c in range(3)], axis=2)
    pq = np.concatenate([np.zeros((M, 1, k)), psi], axis=1)  # (M, 4, k)
    dq = 0.5 * qmul(np.moveaxis(pq, 2, 0), q[None])  # (k, M, 4)
    dk = mdl.curvature(q[None] + (1j * _H) * dq).imag / _H  # (k, M, 3): curvature is polynomial in q
    dk = np.moveaxis(dk, 0, 2)  # (M, 3, k)
    dtw = mdl.Q0 @ dk[:, 2, :]  # (M, k)
    tx, tz = d3[:, 0], d3[:, 2]
    den = tx * tx + tz * tz
    with np.errstate(invalid="ignore", divide="ignore"):
        dth = (tx[:, None] * dd3[:, 2, :] - tz[:, None] * dd3[:, 0, :]) / den[:, None]
    u = mdl.uniq
    return RodSensitivity(
        params=params, theta=dth[u], tip_position=dr[-1].copy(), tip_angle=dth[-1].copy(), s=mdl.grid.s[u],
        min_eigenvalue=lam, units=units or {p: _UNITS3[p] for p in params}, _positions=(mdl.grid, dr),
        rotation=psi[u], frames=dR[u], quaternions=np.moveaxis(dq, 0, 2)[u], curvature=dk[u], twist=dtw[u],
        tip_tangent=dd3[-1].copy(), tip_twist=dtw[-1].copy(),
    )


def rod_sensitivities(result, params=("E0", "particle_magnetization")) -> RodSensitivity:
    """Exact derivatives of a 3D cantilever equilibrium in a uniform field with respect to ``params``.

    By the implicit-function theorem on the solver's own collocation system (the module docstring): one
    factorization of its Jacobian, ``dF/dp`` by a complex step of the residual alone in the coefficients moved
    along their exact derivatives (central differences of the coefficients for ``volume_fraction``).

    Parameters
    ----------
    result : RodResult
        A successful 3D cantilever equilibrium in a uniform field (:func:`magsoft_env.solve_equilibrium` with
        ``model="3d"`` or three field components).
    params : sequence of str
        Any of :data:`ROD_PARAMETERS` (SI units: Pa, A/m, kg/m^3, m/s^2, T, rad, m, 1).

    Returns
    -------
    RodSensitivity

    Raises
    ------
    ValueError
        On an unknown parameter, an unsupported result (planar, in a source, free, not converged), a density given
        as a function (for ``density``), a varying volume fraction (for ``volume_fraction``), a zero particle
        magnetization (for ``particle_magnetization``), or an equilibrium at a fold or bifurcation.

    Examples
    --------
    >>> import magsoft_env as ms
    >>> from magsoft_env.theory.rod_sensitivity import rod_sensitivities
    >>> beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    >>> r = ms.solve_equilibrium(beam, (0.0, 1e-3, 5e-3), model="3d")
    >>> d = rod_sensitivities(r, ["E0", "By"])
    >>> bool(d["E0"]["tip_position"][2] < 0), bool(d["By"]["tip_twist"] != 0)
    (True, True)
    """
    params = check_params(params, ROD_PARAMETERS, "3D sensitivities")
    with single_threaded_blas():  # small dense problems: threads only cost (as in the solver)
        mdl, q, load, lam = _check_result(result, source=False)
        beam = mdl.beam
        cols = [_residual_rate(mdl, q, load, _direction(p, mdl, beam), source=False) for p in params]
        return _sensitivity(mdl, q, load, np.column_stack(cols), params, lam)


def source_rod_sensitivities(result, params=("E0", "particle_magnetization")) -> RodSensitivity:
    """Derivatives of a 3D cantilever equilibrium in a field source with respect to ``params``.

    As :func:`rod_sensitivities`, on the source solver's system and Jacobian: ``dF/dp`` by a complex step of the
    residual alone in the coefficients (the source's field is evaluated at the real positions), and for the
    source's translation ``source_x``, ``source_y``, ``source_z`` (m; every source of the load moved together) and
    turns ``source_roll``, ``source_pitch``, ``source_yaw`` (rad, right-handed about x, y, z through the source's
    centre, :func:`~magsoft_env.theory.sensitivity.source_center`) by central differences of the residual alone
    (1e-5 L or 1e-5 rad). The Jacobian's position derivative of the gradient force is the solver's (central
    differences of G): about 1e-8 relative. A coil system's currents: :func:`current_rod_sensitivities`.

    Parameters
    ----------
    result : SourceRodResult
        A successful 3D cantilever equilibrium in a field source.
    params : sequence of str
        Any of :data:`SOURCE_ROD_PARAMETERS`.
    """
    params = check_params(params, SOURCE_ROD_PARAMETERS, "3D sensitivities in a source")
    with single_threaded_blas():
        mdl, q, load, lam = _check_result(result, source=True)
        beam = mdl.beam
        cols = []
        for p in params:
            if p.startswith("source_"):
                cols.append(_source_pose_rate(mdl, q, load, p))
            else:
                cols.append(_residual_rate(mdl, q, load, _direction(p, mdl, beam), source=True))
        return _sensitivity(mdl, q, load, np.column_stack(cols), params, lam)


__all__ = ["ROD_PARAMETERS", "SOURCE_ROD_PARAMETERS", "RodSensitivity", "current_rod_sensitivities",
           "rod_sensitivities", "source_rod_sensitivities", "torsion_derivatives"]

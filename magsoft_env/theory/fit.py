"""Fit a robot's parameters to measured shapes: Levenberg-Marquardt on exact Jacobians, with uncertainties.

A measurement is a field (and the gravity of the fit) and tracked positions on the beam: the tip, or points at
given reference arc lengths. For each measurement the planar solver finds the equilibrium along the loading path
(gravity, then the field ramped from zero, as the robot meets it), and :mod:`magsoft_env.theory.sensitivity`
gives the exact derivatives of the positions with respect to the parameters. With fields that have a ``B_y``
component, points off the x-z plane (or ``model="3d"``) the 3D rod does the same
(:mod:`magsoft_env.theory.rod_solver`, :mod:`magsoft_env.theory.rod_sensitivity`), on x, y and z of every point,
and the width and the Poisson ratio (through the torsional stiffness ``G J``) become fittable. The fit minimizes
the sum of squared position misfits (``scipy.optimize.least_squares``, Levenberg-Marquardt, in the logarithm
of the positive parameters). At the optimum, with ``J`` the Jacobian of the misfits in the parameters' units and
``s^2`` the residual variance (the sum of squares over ``n - k``, or the given measurement sigma squared)::

    covariance = s^2 (J^T J)^-1,      sigma = sqrt(diag(covariance))

Parameters that the data cannot tell apart (for example ``E0`` and ``particle_magnetization`` without gravity:
a field bends the beam by ``M_p / E0`` alone) are refused before the fit with a message saying which.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from ..spec import Beam, as_field
from .options import SolverOptions
from .sensitivity import posed_source, sensitivities, source_sensitivities, turn_jacobian

#: Parameters :func:`fit` can fit (SI units), and whether each is positive (fitted in its logarithm).
FIT_PARAMETERS = {"E0": True, "particle_magnetization": True, "density": True, "thickness": True,
                  "volume_fraction": True, "clamp_angle": False, "source_x": False, "source_z": False,
                  "width": True, "poisson_ratio": False, "source_y": False, "source_roll": False,
                  "source_pitch": False, "source_yaw": False}
#: Parameters that move every measurement's field source (its pose offset, m), starting from 0.
SOURCE_OFFSETS = ("source_x", "source_y", "source_z")
#: Parameters that turn every measurement's field source about its centre (rad, the components of one rotation
#: vector: about x, y, z), starting from 0.
SOURCE_TURNS = ("source_roll", "source_pitch", "source_yaw")
#: Parameters only the 3D model depends on (the planar one has no width, no twist, no y, turns about y alone).
PARAMETERS_3D = ("width", "poisson_ratio", "source_y", "source_roll", "source_yaw")
#: Parameters with a closed valid range (the Poisson ratio, 0 to 1/2), fitted through ``p = mid + half sin(u)``:
#: every step of the optimizer lands in the range, and one that would leave it folds back in.
BOUNDED = {"poisson_ratio": (0.0, 0.5)}
#: The models of :func:`fit`.
MODELS = ("auto", "planar", "3d")
#: Largest |correlation| between two fitted parameters before they count as not identifiable from the data.
MAX_CORRELATION = 0.9999
#: Restarts of the fit lie this factor above and below the guess of each positive parameter.
RESTART_FACTOR = 1.4
#: Most measurements (fields) one fit takes; each costs one equilibrium per iteration.
MAX_MEASUREMENTS = 500
#: A parameter whose change by its own size moves the points by less than this fraction of the beam's length
#: (root mean square) does not act on the data (it is refused as not identifiable).
NEGLIGIBLE = 1e-9


@dataclass(frozen=True)
class Measurement:
    """One measured shape: the field (T, a pair ``(B_x, B_z)`` in the planar model, a triple in 3D) or a field
    source, the reference arc lengths (m) of the tracked points and their measured positions in m, clamp at the
    origin: ``(n, 2)`` (x, z) in the planar model, ``(n, 3)`` (x, y, z) in 3D."""

    field: tuple
    s: np.ndarray
    points: np.ndarray


@dataclass(frozen=True)
class FitResult:
    """The outcome of :func:`fit` (frozen).

    Attributes
    ----------
    success : bool
        The optimizer converged and every equilibrium was found.
    message : str
    params : tuple of str
    values, sigma : dict
        Fitted values and their 1-sigma uncertainties, by parameter (SI units).
    interval95 : dict
        ``(low, high)`` 95 % intervals (normal approximation, +-1.96 sigma).
    covariance, correlation : (k, k) ndarray
    beam : Beam
        The beam with the fitted values.
    residual : (m,) ndarray
        Misfits at the optimum (m), x then z of each tracked point, measurement by measurement.
    rms : float
        Root-mean-square misfit (m).
    residual_sigma : float
        ``s``: the measurement sigma given, or the one the residual implies (m).
    iterations : int
        Function evaluations of the optimizer.
    model : str
        The model fitted: ``"planar"`` (residuals x then z of each point) or ``"3d"`` (x, y, z of each point).
    """

    success: bool
    message: str
    params: tuple
    values: dict
    sigma: dict
    interval95: dict
    covariance: np.ndarray
    correlation: np.ndarray
    beam: Beam
    residual: np.ndarray
    rms: float
    residual_sigma: float
    iterations: int
    model: str = "planar"

    def to_dict(self) -> dict:
        return {"success": self.success, "message": self.message, "values": dict(self.values),
                "sigma": dict(self.sigma), "interval95": {k: list(v) for k, v in self.interval95.items()},
                "correlation": self.correlation.tolist(), "rms_m": self.rms, "residual_sigma_m": self.residual_sigma,
                "iterations": self.iterations, "model": self.model}


def _value(beam: Beam, p: str, clamp_angle: float) -> float:
    from ..spec.profiles import Constant

    if p == "E0":
        return float(beam.material.E0)
    if p == "particle_magnetization":
        return float(beam.material.particle_magnetization)
    if p == "density":
        if callable(beam.material.density):
            raise ValueError("the beam's density is a function of the volume fraction: fit 'volume_fraction' or give "
                             "the material a density number.")
        return float(beam.material.density)
    if p == "thickness":
        return float(beam.thickness)
    if p == "width":
        return float(beam.width)
    if p == "poisson_ratio":
        return float(beam.material.poisson_ratio)
    if p in SOURCE_OFFSETS or p in SOURCE_TURNS:
        return 0.0
    if p == "volume_fraction":
        phi = beam.volume_fraction
        if not isinstance(phi, Constant):
            raise ValueError("the beam's volume fraction varies along it: fitting one number does not apply.")
        return float(phi.value)
    return float(clamp_angle)


def _with(beam: Beam, values: dict) -> Beam:
    mat = {k: values[k] for k in ("E0", "particle_magnetization", "density", "poisson_ratio") if k in values}
    if mat:
        beam = dataclasses.replace(beam, material=dataclasses.replace(beam.material, **mat))
    if "thickness" in values:
        beam = dataclasses.replace(beam, thickness=values["thickness"])
    if "width" in values:
        beam = dataclasses.replace(beam, width=values["width"])
    if "volume_fraction" in values:
        beam = dataclasses.replace(beam, volume_fraction=values["volume_fraction"])
    return beam


def _as_3d(m: Measurement) -> Measurement:
    """A :class:`Measurement` with a field triple (or its source) and ``(n, 3)`` points (y = 0 added to planar ones)."""
    field = m.field
    if isinstance(field, tuple) and len(field) == 2:
        field = (float(field[0]), 0.0, float(field[1]))
    pts = np.asarray(m.points, dtype=float)
    if pts.ndim == 2 and pts.shape[1] == 2:
        pts = np.column_stack([pts[:, 0], np.zeros(pts.shape[0]), pts[:, 1]])
    return Measurement(field=field, s=np.asarray(m.s, dtype=float), points=pts)


def _parse(measurements, length: float) -> list[Measurement]:
    """Each measurement checked, in the 3D form (:func:`_as_3d`)."""
    if isinstance(measurements, (str, bytes)) or not hasattr(measurements, "__len__"):
        raise ValueError("measurements must be a list of (field, tip_position) or (field, s, points) entries, got "
                         f"{type(measurements).__name__}.")
    if not 1 <= len(measurements) <= MAX_MEASUREMENTS:
        raise ValueError(f"measurements must hold 1 to {MAX_MEASUREMENTS} entries, got {len(measurements)}.")
    out = []
    for i, m in enumerate(measurements):
        if isinstance(m, Measurement):
            pts = np.asarray(m.points)
            if pts.ndim != 2 or pts.shape[1] not in (2, 3):
                raise ValueError(f"measurements[{i}] points must be (n, 2) (x, z) or (n, 3) (x, y, z) in m, got shape "
                                 f"{pts.shape}.")
            out.append(_as_3d(m))
            continue
        if not isinstance(m, (tuple, list)) or len(m) not in (2, 3):
            raise ValueError(f"measurements[{i}] must be (field, tip_position) or (field, s, points), got {m!r}.")
        from .sources import is_source

        if is_source(m[0]) and not hasattr(m[0], "at_currents"):
            load = m[0]
        else:
            fld = as_field(m[0], f"measurements[{i}] field")
            load = (fld.Bx, fld.By, fld.Bz)
        if len(m) == 2:
            s = np.array([length])
            pts = np.atleast_2d(np.asarray(m[1], dtype=float))
        else:
            s = np.atleast_1d(np.asarray(m[1], dtype=float))
            pts = np.atleast_2d(np.asarray(m[2], dtype=float))
        if pts.ndim != 2 or pts.shape not in ((s.size, 2), (s.size, 3)) or not np.all(np.isfinite(pts)):
            raise ValueError(f"measurements[{i}] positions must be {s.size} finite (x, z) or (x, y, z) rows in m, got "
                             f"shape {pts.shape}.")
        if not np.all(np.isfinite(s)) or np.any(s <= 0) or np.any(s > length * (1 + 1e-12)):
            raise ValueError(f"measurements[{i}] arc lengths must lie in (0, {length:g}] m, got {s.tolist()}.")
        if np.max(np.abs(pts)) > 10 * length:
            raise ValueError(f"measurements[{i}] positions reach {np.max(np.abs(pts)):g} m, more than 10 beam lengths "
                             f"({10 * length:g} m): positions are in metres.")
        out.append(_as_3d(Measurement(field=load, s=s, points=pts)))
    return out


def _planar(parsed) -> list[Measurement]:
    """The parsed measurements in the planar model's form: field pairs, (x, z) points (y dropped), or a ValueError
    for a field with B_y."""
    out = []
    for i, m in enumerate(parsed):
        if isinstance(m.field, tuple):
            if m.field[1] != 0:
                raise ValueError(f"measurements[{i}] field has B_y = {m.field[1]:g} T: the planar model takes fields "
                                 "in the x-z plane only; fit the 3D rod (model='3d' or 'auto').")
            field = (m.field[0], m.field[2])
        else:
            field = m.field
        out.append(Measurement(field=field, s=m.s, points=m.points[:, [0, 2]]))
    return out


def as_measurements(measurements, length: float, model: str = "planar") -> list[Measurement]:
    """The measurements of :func:`fit` checked and as :class:`Measurement` records (ValueError naming the entry):
    in the planar model's form (field pairs, (x, z) points; a y coordinate is dropped, a field with ``B_y``
    refused), or with ``model="3d"`` in the 3D form (field triples, (x, y, z) points, y = 0 where not given)."""
    if model not in ("planar", "3d"):
        raise ValueError(f"model must be 'planar' or '3d' here, got {model!r}.")
    parsed = _parse(measurements, length)
    return parsed if model == "3d" else _planar(parsed)


def _out_of_plane(parsed, beam: Beam, params) -> str:
    """Why the data or the beam need the 3D model (a phrase), or '' when the planar one holds them."""
    from .rod_sources import OUT_OF_PLANE_TOL, out_of_plane_load

    for i, m in enumerate(parsed):
        if isinstance(m.field, tuple):
            if m.field[1] != 0:
                return f"measurements[{i}] field has B_y = {m.field[1]:g} T"
        elif out_of_plane_load([m.field], beam.length) > OUT_OF_PLANE_TOL:
            return f"measurements[{i}] field source loads the strip out of its x-z plane"
        if np.any(m.points[:, 1] != 0):
            return f"measurements[{i}] has points off the x-z plane (y != 0)"
    if not beam.is_planar:
        return "the beam's magnetization has a component across the width"
    for p in ("source_y", "source_roll", "source_yaw"):
        if p in params:
            return f"{p} moves the sources out of the x-z plane"
    return ""


def _choose_model(model, parsed, beam: Beam, params) -> str:
    """The model :func:`fit` uses: ``model`` checked, ``"auto"`` resolved (3D when :func:`_out_of_plane` says why)."""
    if not isinstance(model, str) or model not in MODELS:
        raise ValueError(f"model must be one of {list(MODELS)}, got {model!r}.")
    why = _out_of_plane(parsed, beam, params)
    three = [p for p in params if p in PARAMETERS_3D]
    if model == "auto":
        if why:
            return "3d"
        if three:
            raise ValueError(f"{', '.join(three)} need(s) the 3D model, and these data are planar (fields with B_y = "
                             "0, points with y = 0): the planar model does not depend on the width or the Poisson "
                             "ratio (the width cancels from its equation; it has no twist). Add measurements out of "
                             "the x-z plane (fields with a B_y component, tracked y coordinates), or pass "
                             "model='3d'.")
        return "planar"
    if model == "planar":
        if three:
            raise ValueError(f"{', '.join(three)} need(s) the 3D model: the planar model does not depend on the width "
                             "or the Poisson ratio (the width cancels from its equation; it has no twist), has no "
                             "y and turns sources about y alone. Pass model='3d' (or 'auto') with measurements out "
                             "of the x-z plane.")
        if not beam.is_planar:
            raise ValueError("model='planar' cannot take a magnetization with a component across the width; pass "
                             "model='3d' (or 'auto').")
    return model


def _misfit(beam: Beam, data, params, vals: dict, *, gravity, clamp_angle, coupling, options, model):
    """Misfits (m) of every tracked point at the parameter values ``vals`` and their Jacobian (m per SI unit of each
    parameter), and the (measurement, message) of each equilibrium not found: x then z of each point in the planar
    model, x, y, z in 3D."""
    from .solver import solve_equilibrium

    b = _with(beam, vals)
    th0 = vals.get("clamp_angle", clamp_angle)
    res, jac, failed = [], [], []
    k = len(params)
    three = model == "3d"
    ncoord = 3 if three else 2
    offset = np.array([vals.get(p, 0.0) for p in SOURCE_OFFSETS])
    turn = np.array([vals.get(p, 0.0) for p in SOURCE_TURNS])
    turned = [p for p in params if p in SOURCE_TURNS]
    # the sensitivities move the source by world-frame turns: d/d(rotation vector) = (world turns) @ turn_jacobian
    world = tuple(p for p in params if p not in SOURCE_TURNS) + (SOURCE_TURNS if three and turned else
                                                                   ("source_pitch",) if turned else ())
    for m in data:
        in_source = not isinstance(m.field, tuple)
        load = m.field
        if in_source and (np.any(offset) or np.any(turn)):
            load = posed_source(m.field, offset, turn)
        r = solve_equilibrium(b, load, gravity=gravity, clamp_angle=th0, coupling=coupling, options=options,
                              model=model)
        if not r.success:
            failed.append((len(res), r.message))
            res.append(np.full(ncoord * m.s.size, 1e3))
            jac.append(np.zeros((ncoord * m.s.size, k)))
            continue
        if three:
            from .rod_sensitivity import rod_sensitivities, source_rod_sensitivities
            from .rod_sources import SourceRodResult

            res.append((r.at(m.s)[0] - m.points).ravel())
            in_source = isinstance(r, SourceRodResult)  # a uniform source gives the uniform field's result
            sens, source_sens = rod_sensitivities, source_rod_sensitivities
        else:
            x, z, _ = r.at(m.s)
            res.append(np.column_stack([x - m.points[:, 0], z - m.points[:, 1]]).ravel())
            sens, source_sens = sensitivities, source_sensitivities
        if in_source:
            S = source_sens(r, world)
            dw = S.positions(m.s)  # (n, 3, len(world))
            dp = np.zeros((m.s.size, 3, k))
            for j, p in enumerate(params):
                if p not in SOURCE_TURNS:
                    dp[:, :, j] = dw[:, :, world.index(p)]
                elif three:
                    cols = [world.index(q) for q in SOURCE_TURNS]
                    dp[:, :, j] = dw[:, :, cols] @ turn_jacobian(turn)[:, SOURCE_TURNS.index(p)]
                else:  # in the plane a turn about y: the rotation vector's y component is the angle
                    dp[:, :, j] = dw[:, :, world.index("source_pitch")]
        else:  # a uniform field: the source's pose does not act
            own = tuple(p for p in params if p not in SOURCE_OFFSETS and p not in SOURCE_TURNS)
            dp = np.zeros((m.s.size, 3, k))
            if own:
                S = sens(r, own)
                dp[:, :, [params.index(p) for p in own]] = S.positions(m.s)
        jac.append((dp if three else dp[:, [0, 2], :]).reshape(-1, k))
    return np.concatenate(res), np.vstack(jac), failed


def misfit(beam: Beam, measurements, params=("E0", "particle_magnetization"), *, gravity: float = 9.81,
           clamp_angle: float = 0.0, coupling: str = "rotated", options: SolverOptions | None = None,
           model: str = "auto") -> tuple[np.ndarray, np.ndarray]:
    """The misfits :func:`fit` minimizes, at ``beam``'s own values (source offsets 0), and their exact Jacobian.

    Returns ``(residual, jacobian)``: ``(m,)`` in m (x then z of each tracked point in the planar model, x, y, z
    in 3D; ``model`` as in :func:`fit`) and ``(m, k)`` in m per SI unit of each of ``params``. A ValueError where
    an equilibrium is not found."""
    params = tuple(p.strip() for p in params.split(",")) if isinstance(params, str) else tuple(params)
    for p in params:
        if p not in FIT_PARAMETERS:
            raise ValueError(f"unknown fit parameter {p!r}: fit any of {list(FIT_PARAMETERS)}.")
    parsed = _parse(measurements, beam.length)
    model = _choose_model(model, parsed, beam, params)
    data = parsed if model == "3d" else _planar(parsed)
    vals = {p: _value(beam, p, clamp_angle) for p in params}
    r, J, failed = _misfit(beam, data, params, vals, gravity=gravity, clamp_angle=clamp_angle, coupling=coupling,
                           options=options if options is not None else SolverOptions(), model=model)
    if failed:
        i, msg = failed[0]
        raise ValueError(f"measurements[{i}]: no equilibrium: {msg}")
    return r, J


def fit(beam: Beam, measurements, params=("E0", "particle_magnetization"), *, gravity: float = 9.81,
        clamp_angle: float = 0.0, coupling: str = "rotated", sigma: float | None = None,
        options: SolverOptions | None = None, max_evaluations: int = 100, restarts: int = 4,
        model: str = "auto") -> FitResult:
    """Fit ``params`` of ``beam`` to measured shapes under known fields (a cantilever, clamp at the origin: planar,
    or the 3D rod).

    Parameters
    ----------
    beam : Beam
        The starting guess (and every parameter not fitted).
    measurements : list
        ``(field, tip_position)`` (field as in :func:`~magsoft_env.solve_equilibrium`, T, or a field source such as
        a magnet at a commanded pose; tip ``(x, z)`` or ``(x, y, z)`` in m) or ``(field, s, points)`` with
        reference arc lengths ``s`` (m) and ``points`` ``(len(s), 2 or 3)`` (m), or :class:`Measurement`.
    params : sequence of str
        Any of ``E0``, ``particle_magnetization``, ``density``, ``thickness``, ``volume_fraction``,
        ``clamp_angle``, ``source_x`` / ``source_z``: one offset (m) of every measurement's source from its
        given pose (a magnet's position error), and ``source_pitch``: one turn (rad, right-handed about y) of every
        source about its centre (its one magnet or dipole, else the origin), applied before the offset; in the
        planar model ``volume_fraction`` with uniform fields only. In 3D also ``width``, ``poisson_ratio`` (fitted
        on [0, 0.5]; both act through out-of-plane bending and twist, so they need fields with ``B_y`` or points
        off the x-z plane), ``source_y`` and ``source_roll`` / ``source_yaw`` (with ``source_pitch`` the
        components of one rotation vector about x, y, z).
    gravity : float
        Gravitational acceleration during the measurements (m/s^2, along -z).
    clamp_angle : float
        theta(0) (rad); the start value when it is fitted.
    sigma : float, optional
        The measurement noise (m, 1 sigma) if known; otherwise estimated from the residual.
    max_evaluations : int
        Most evaluations of all the equilibria per start (in [5, 2000]).
    restarts : int
        Further starts, a factor :data:`RESTART_FACTOR` up and down each parameter in turn (in [0, 20]); the
        lowest misfit wins (branches of the equilibria can make the misfit jump).
    model : {"auto", "planar", "3d"}
        ``"planar"``: the planar solver, residuals x and z of each point (a y coordinate is dropped, a field with
        ``B_y`` refused). ``"3d"``: the 3D rod, residuals x, y and z. ``"auto"`` (default): 3D when a field has a
        ``B_y`` component (a source loads the strip out of its x-z plane), a point has y != 0, the magnetization
        has a width component or ``source_y``, ``source_roll`` or ``source_yaw`` is fitted; planar otherwise.
        ``width`` and ``poisson_ratio`` are refused in the planar model (it does not depend on them).

    Returns
    -------
    FitResult

    Examples
    --------
    >>> import magsoft_env as ms
    >>> truth = ms.Beam(25e-3, 5e-3, 1.13e-3, material=ms.Material(E0=0.07e6, particle_magnetization=600e3))
    >>> fields = [(0, 3e-3), (0, -3e-3), (3e-3, 0), (-3e-3, 2e-3), (0, 8e-3)]
    >>> data = [(B, ms.solve_equilibrium(truth, B).tip_position) for B in fields]
    >>> res = ms.fit(ms.Beam(25e-3, 5e-3, 1.13e-3), data, params=("E0", "particle_magnetization"))
    >>> round(res.values["E0"]), round(res.values["particle_magnetization"])
    (70000, 600000)
    """
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    if isinstance(params, str):
        params = tuple(p.strip() for p in params.split(","))
    params = tuple(params)
    if not params:
        raise ValueError(f"params must name at least one of {list(FIT_PARAMETERS)}, got none.")
    for p in params:
        if p not in FIT_PARAMETERS:
            import difflib

            close = difflib.get_close_matches(str(p), list(FIT_PARAMETERS), n=1)
            raise ValueError(f"unknown fit parameter {p!r}: fit any of {list(FIT_PARAMETERS)}."
                             + (f" Did you mean {close[0]!r}?" if close else ""))
    if len(set(params)) != len(params):
        raise ValueError(f"params must not repeat a name, got {list(params)}.")
    if not (isinstance(max_evaluations, int) and 5 <= max_evaluations <= 2000):
        raise ValueError(f"max_evaluations must be an integer in [5, 2000], got {max_evaluations!r}.")
    if not (isinstance(restarts, int) and 0 <= restarts <= 20):
        raise ValueError(f"restarts must be an integer in [0, 20], got {restarts!r}.")
    if sigma is not None and not (math.isfinite(sigma) and sigma > 0):
        raise ValueError(f"sigma must be a positive length (m), got {sigma!r}.")
    parsed = _parse(measurements, beam.length)
    model = _choose_model(model, parsed, beam, params)
    data = parsed if model == "3d" else _planar(parsed)
    ncoord = 3 if model == "3d" else 2
    if model == "planar" and "volume_fraction" in params and any(not isinstance(m.field, tuple) for m in data):
        raise ValueError("volume_fraction under a field source needs the 3D model (model='3d'): the planar source "
                         "sensitivities do not take it; or measure under uniform fields.")
    n_res = sum(ncoord * m.s.size for m in data)
    if n_res < len(params):
        raise ValueError(f"{len(params)} parameters need at least as many measured coordinates; the data give "
                         f"{n_res}.")
    start = {p: _value(beam, p, clamp_angle) for p in params}
    logs = [FIT_PARAMETERS[p] for p in params]
    for p, lg in zip(params, logs, strict=True):
        if lg and not start[p] > 0:
            raise ValueError(f"{p} must start from a positive value, got {start[p]!r}.")
    options = options if options is not None else SolverOptions()
    cache: dict = {}
    failed: list = []  # (measurement, message) whose equilibrium the last evaluation did not find

    # positive parameters are fitted in their logarithm, a bounded one through a sine onto its range, the others in
    # units of a natural scale: the beam's length for a source's offset, 1 rad for the clamp angle
    unit = [1.0 if lg else (beam.length if p in SOURCE_OFFSETS else 1.0) for p, lg in zip(params, logs, strict=True)]

    def unpack(u):
        out = {}
        for p, v, lg, k in zip(params, u, logs, unit, strict=True):
            if p in BOUNDED:
                lo, hi = BOUNDED[p]
                out[p] = min(max(0.5 * (lo + hi) + 0.5 * (hi - lo) * math.sin(v), lo), hi)
            else:
                out[p] = math.exp(v) if lg else v * k
        return out

    def evaluate(u):
        key = tuple(np.round(u, 15))
        if key in cache:
            return cache[key]
        r, J, fails = _misfit(beam, data, params, unpack(u), gravity=gravity, clamp_angle=clamp_angle,
                              coupling=coupling, options=options, model=model)
        failed[:] = fails
        out = (r, J, not fails)
        cache.clear()
        cache[key] = out
        return out

    def pack(p, v, lg, k):
        if p in BOUNDED:
            lo, hi = BOUNDED[p]
            return math.asin(min(max((2.0 * v - lo - hi) / (hi - lo), -1.0), 1.0))
        return math.log(v) if lg else v / k

    u0 = np.array([pack(p, start[p], lg, k) for p, lg, k in zip(params, logs, unit, strict=True)])

    def fun(u):
        return evaluate(u)[0]

    def jac(u):
        vals = np.array(list(unpack(u).values()))
        d = np.array([0.5 * (BOUNDED[p][1] - BOUNDED[p][0]) * math.cos(x) if p in BOUNDED else (v if lg else k)
                      for p, x, v, lg, k in zip(params, u, vals, logs, unit, strict=True)])
        return evaluate(u)[1] * d[None, :]  # d/d log p = p d/dp; d/d(p / k) = k d/dp; the sine's derivative

    J0 = jac(u0)
    if failed:
        i, msg = failed[0]
        raise ValueError(f"measurements[{i}]: no equilibrium at the starting parameters ({len(failed)} measurement(s) "
                         f"fail): {msg} Start nearer the truth, or drop measurements the model cannot reach.")
    # a parameter that moves the points by less than NEGLIGIBLE L when it changes by its own size (by L for a
    # source offset, 1 rad for the clamp angle, its range for a bounded one) counts as not acting at all
    scale = np.array([BOUNDED[p][1] - BOUNDED[p][0] if p in BOUNDED else (start[p] if lg else k)
                      for p, lg, k in zip(params, logs, unit, strict=True)])
    moved = np.linalg.norm(evaluate(u0)[1] * scale[None, :], axis=0) / math.sqrt(n_res)
    _check_identifiable(J0, params, inert=moved < NEGLIGIBLE * beam.length)
    # Equilibria along the loading path can switch branch as the parameters move (a field that pulls a hanging
    # beam over: the objective jumps there), so the fit starts from the guess and from points a factor
    # RESTART_FACTOR away along each parameter, and keeps the lowest misfit.
    starts = [u0]
    for i, lg in enumerate(logs):
        for sign in (1.0, -1.0):
            if len(starts) > restarts:
                break
            u = u0.copy()
            if params[i] in BOUNDED:  # halfway to either end of the range
                u[i] = pack(params[i], 0.5 * (start[params[i]] + BOUNDED[params[i]][1 if sign > 0 else 0]), False, 1.0)
            else:
                u[i] += sign * (math.log(RESTART_FACTOR) if lg else 0.1)
            starts.append(u)
    best, nfev = None, 0
    for u_start in starts:
        try:
            sol = scipy.optimize.least_squares(fun, u_start, jac=jac, method="lm", xtol=1e-12, ftol=1e-12,
                                               gtol=1e-12, max_nfev=max_evaluations)
        except ValueError:  # a start whose parameters leave the material's valid range
            continue
        nfev += sol.nfev
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None:
        raise ValueError("every start of the fit left the parameters' valid range; start nearer the truth.")
    sol = best
    r, J, ok = evaluate(sol.x)
    vals = unpack(sol.x)
    dof = max(r.size - len(params), 1)
    s2 = sigma**2 if sigma is not None else float(r @ r) / dof
    try:
        cov = s2 * np.linalg.inv(J.T @ J)
    except np.linalg.LinAlgError:
        cov = np.full((len(params), len(params)), np.nan)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    values = {p: float(vals[p]) for p in params}
    sig = {p: float(v) for p, v in zip(params, sd, strict=True)}
    msg = sol.message if ok else "Some equilibria were not found at the last parameters."
    bad = _correlated(corr, params)
    if bad:
        msg += " " + bad
    for p in params:
        if p in BOUNDED and min(abs(values[p] - b) for b in BOUNDED[p]) <= 1e-9 * (BOUNDED[p][1] - BOUNDED[p][0]):
            msg += (f" Warning: {p} ended at an end of its valid range {list(BOUNDED[p])} ({values[p]:g}): not an "
                    "interior minimum, so its sigma does not apply; try more restarts or fix it.")
    return FitResult(success=bool(sol.success and ok), message=msg, params=params, values=values, sigma=sig,
                     interval95={p: (values[p] - 1.96 * sig[p], values[p] + 1.96 * sig[p]) for p in params},
                     covariance=cov, correlation=corr, beam=_with(beam, values), residual=r,
                     rms=float(math.sqrt(float(r @ r) / r.size)), residual_sigma=float(math.sqrt(s2)),
                     iterations=int(nfev), model=model)


def _correlated(corr: np.ndarray, params) -> str:
    k = len(params)
    pairs = [(params[i], params[j], corr[i, j]) for i in range(k) for j in range(i + 1, k)
             if not abs(corr[i, j]) < MAX_CORRELATION]
    if not pairs:
        return ""
    return "Warning: " + "; ".join(f"{a} and {b} are correlated ({c:+.5f})" for a, b, c in pairs) + \
        ": the data barely tell them apart."


def _check_identifiable(J: np.ndarray, params, inert=None) -> None:
    """Refuse parameter sets the data cannot identify at the starting point (rank-deficient Jacobian; ``inert``
    marks parameters that move the points by a negligible amount)."""
    norms = np.linalg.norm(J, axis=0)
    inert = np.zeros(len(params), dtype=bool) if inert is None else inert
    for p, n, dead in zip(params, norms, inert, strict=True):
        if not n > 0 or dead:
            raise ValueError(f"{p} is not identifiable from these data: the measured positions do not depend on it "
                             "(for example the width or the Poisson ratio when every field and point lies in the x-z "
                             "plane, the density without gravity, or a source's offset under uniform fields).")
    Jn = J / norms[None, :]
    sv = np.linalg.svd(Jn, compute_uv=False)
    if sv[-1] < 1e-6 * sv[0]:
        _, _, vt = np.linalg.svd(Jn)
        v = vt[-1]
        involved = [p for p, c in zip(params, v, strict=True) if abs(c) > 0.1]
        raise ValueError(f"{', '.join(involved)} are not identifiable together from these data (they change the "
                         "measured positions only in a fixed combination; e.g. E0 and particle_magnetization without "
                         "gravity act only through M_p / E0): add measurements that separate them (gravity, another "
                         "field direction) or fit fewer parameters.")


__all__ = ["FIT_PARAMETERS", "MODELS", "RESTART_FACTOR", "SOURCE_OFFSETS", "SOURCE_TURNS", "FitResult", "Measurement",
           "as_measurements", "fit", "misfit"]

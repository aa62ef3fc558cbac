"""Plan the measurements of a fit: which fields pin the parameters down best, and how well, before measuring.

How precisely :func:`~magsoft_env.theory.fit.fit` recovers a parameter is set by the experiment as much as by the
noise. For a guess of the robot, the tracking noise ``sigma`` and the fitted parameters ``p`` (positive ones in
their logarithm, as the fit does), a measurement at field ``B`` carries the information ``J_B^T J_B / sigma^2``,
with ``J_B`` the exact derivative of its tracked positions (:mod:`magsoft_env.theory.sensitivity`). The predicted
covariance of a set of measurements is the inverse of their summed information, which is what the fit reports at
its optimum when the guess is near the truth::

    covariance = sigma^2 (sum_B J_B^T J_B)^-1

:func:`predict_precision` gives it for fields you chose; :func:`plan_measurements` chooses ``n`` distinct fields
from candidates (every ``360 / directions`` degrees, magnitudes up to ``max_field``, and gravity alone), one at a
time, each time the one that lowers the largest predicted relative 1-sigma most. A field whose equilibrium lies
near a fold (a snap-through) is informative but treacherous: the true robot may snap where the guess does not,
and the fit then meets a jump. So a candidate counts only if its equilibrium keeps the second variation's smallest
eigenvalue above ``margin`` (units E I / L^2; a straight cantilever has pi^2 / 4) at the guess and at the corners
of the prior uncertainty (each positive parameter times ``1 +- spread``).

What the measurements identify, for the paper's strip (``docs/fit.md``): a field alone bends the beam through
``M_p / E0`` only; gravity (``rho g / E0``) separates the two, so the information on each comes from fields that
the weight and the magnetic couple share, and fields that turn the strip up against gravity (1-2 mT, a little
past vertical) carry the most.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ..spec import Beam
from .options import SolverOptions

#: Parameters a plan can aim at (uniform fields; ``width`` and ``poisson_ratio`` in the 3D model only).
PLAN_PARAMETERS = ("E0", "particle_magnetization", "density", "thickness", "volume_fraction", "clamp_angle", "width",
                   "poisson_ratio")
#: Parameters only the 3D model depends on (the width cancels from the planar equation; it has no twist).
PLAN_PARAMETERS_3D = ("width", "poisson_ratio")
#: The models a plan takes.
PLAN_MODELS = ("planar", "3d")
#: Most candidate fields one plan evaluates.
MAX_CANDIDATES = 2000


@dataclass(frozen=True)
class MeasurementPlan:
    """The fields of a planned experiment and the precision they predict (frozen).

    Attributes
    ----------
    fields : list of (B_x, B_z), or (B_x, B_y, B_z) in 3D
        The fields to apply (T), in the order chosen (the most informative first; zero is gravity alone).
    params : tuple of str
    sigma : dict
        Predicted 1-sigma of each parameter (SI units) at the guess.
    relative_sigma : dict
        ``sigma / value`` (for ``clamp_angle``: sigma in rad).
    correlation : (k, k) ndarray
        Predicted correlations of the fitted parameters.
    min_eigenvalue : list of float
        For each field, the smallest eigenvalue of the second variation (E I / L^2) over the guess and the corners
        of the prior: how far each measurement stays from a fold.
    candidates : int
        Candidate fields evaluated.
    rejected : int
        Candidates refused: no equilibrium, or within ``margin`` of a fold at the guess or a corner of the prior.
    """

    fields: list
    params: tuple
    sigma: dict
    relative_sigma: dict
    correlation: np.ndarray
    min_eigenvalue: list
    candidates: int
    rejected: int

    def table(self) -> str:
        """The plan as lines of text: one field per line, then the predicted precision."""
        three = any(len(f) == 3 for f in self.fields)
        if three:
            lines = [f"{'#':>3} {'B_x mT':>8} {'B_y mT':>8} {'B_z mT':>8} {'|B| mT':>7} {'margin':>7}"]
        else:
            lines = [f"{'#':>3} {'B_x mT':>8} {'B_z mT':>8} {'|B| mT':>7} {'dir deg':>8} {'margin':>7}"]
        for i, (f, lam) in enumerate(zip(self.fields, self.min_eigenvalue, strict=True), 1):
            mag = math.sqrt(sum(b * b for b in f))
            if three:
                bx, by, bz = f
                lines.append(f"{i:3d} {bx * 1e3:8.3f} {by * 1e3:8.3f} {bz * 1e3:8.3f} {mag * 1e3:7.3f} {lam:7.2f}")
                continue
            bx, bz = f
            ang = math.degrees(math.atan2(bz, bx)) % 360.0 if mag > 0 else float("nan")
            lines.append(f"{i:3d} {bx * 1e3:8.3f} {bz * 1e3:8.3f} {mag * 1e3:7.3f} {ang:8.1f} {lam:7.2f}")
        lines.append("predicted 1-sigma: " + ", ".join(
            f"{p} {self.relative_sigma[p]:.3%}" if p != "clamp_angle" else f"{p} {self.sigma[p]:.2e} rad"
            for p in self.params))
        return "\n".join(lines)


def _check(beam, params, noise, gravity, s, model="planar"):
    from .fit import _value

    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    if isinstance(params, str):
        params = tuple(p.strip() for p in params.split(","))
    params = tuple(params)
    if not params or len(set(params)) != len(params):
        raise ValueError(f"params must name distinct parameters among {list(PLAN_PARAMETERS)}, got {list(params)}.")
    bad = [p for p in params if p not in PLAN_PARAMETERS]
    if bad:
        raise ValueError(f"cannot plan for {bad}: plan for any of {list(PLAN_PARAMETERS)}.")
    if model not in PLAN_MODELS:
        raise ValueError(f"model must be one of {list(PLAN_MODELS)}, got {model!r}.")
    three = [p for p in params if p in PLAN_PARAMETERS_3D]
    if three and model != "3d":
        raise ValueError(f"{', '.join(three)} need(s) the 3D model (model='3d'): the planar model does not depend "
                         "on the width or the Poisson ratio (the width cancels from its equation; it has no twist).")
    if not (isinstance(noise, (int, float)) and math.isfinite(noise) and 0 < noise < beam.length):
        raise ValueError(f"noise must be the tracking noise in m, in (0, {beam.length:g}) (the beam length), got "
                         f"{noise!r}.")
    if not (isinstance(gravity, (int, float)) and math.isfinite(gravity) and 0 <= gravity <= 1000):
        raise ValueError(f"gravity must be in [0, 1000] m/s^2, got {gravity!r}.")
    s = np.array([beam.length]) if s is None else np.atleast_1d(np.asarray(s, dtype=float))
    if s.size == 0 or not np.all(np.isfinite(s)) or np.any(s <= 0) or np.any(s > beam.length * (1 + 1e-12)):
        raise ValueError(f"s (the tracked points' arc lengths) must lie in (0, {beam.length:g}] m, got {s.tolist()}.")
    values = {p: _value(beam, p, 0.0) for p in params}
    return params, s, values


def _scaled_rows(beam, field, params, s, values, gravity, clamp_angle, options, model="planar"):
    """(rows of d positions / d scaled parameter, min eigenvalue) at one field, or None if there is no equilibrium
    or it sits at a fold: x and z of each tracked point in the planar model, x, y and z in 3D."""
    from .rod_sensitivity import rod_sensitivities
    from .sensitivity import sensitivities
    from .solver import solve_equilibrium

    r = solve_equilibrium(beam, field, gravity=gravity, clamp_angle=clamp_angle, options=options, model=model)
    if not r.success:
        return None
    try:
        S = rod_sensitivities(r, params) if model == "3d" else sensitivities(r, params)
    except ValueError:  # at a fold or bifurcation
        return None
    P = S.positions(s)
    dp = (P if model == "3d" else P[:, [0, 2], :]).reshape(-1, len(params))
    scale = np.array([values[p] if p != "clamp_angle" else 1.0 for p in params])
    return dp * scale[None, :], float(S.min_eigenvalue)


def _covariance(rows, noise):
    F = sum(J.T @ J for J in rows) / noise**2
    try:
        return np.linalg.inv(F)
    except np.linalg.LinAlgError:
        return None


def _worst(cov) -> float:
    if cov is None:
        return math.inf
    d = np.diag(cov)
    return math.inf if np.any(~np.isfinite(d)) or np.any(d <= 0) else float(np.sqrt(d.max()))


def _result(beam, params, values, fields, rows, lams, noise, candidates, rejected) -> MeasurementPlan:
    cov = _covariance(rows, noise)
    if cov is None or not np.all(np.isfinite(cov)):
        raise ValueError(f"{', '.join(params)} are not identifiable together from these fields: add gravity or "
                         "other field directions, or fit fewer parameters.")
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))  # relative (log) for positive parameters, rad for the angle
    rel = {p: float(v) for p, v in zip(params, sd, strict=True)}
    sigma = {p: float(v * (values[p] if p != "clamp_angle" else 1.0)) for p, v in zip(params, sd, strict=True)}
    return MeasurementPlan(fields=[tuple(float(b) for b in f) for f in fields], params=params, sigma=sigma,
                           relative_sigma=rel, correlation=cov / np.outer(sd, sd), min_eigenvalue=list(lams),
                           candidates=candidates, rejected=rejected)


def _directions(count: int, three: bool) -> list:
    """Unit field directions: every ``360 / count`` degrees in the x-z plane, or in 3D about ``count`` points spread
    over the sphere: a Fibonacci lattice on the upper half and its reverses (so every direction's reverse is
    there too, for pairs B, -B)."""
    if not three:
        return [(math.cos(2.0 * math.pi * j / count), math.sin(2.0 * math.pi * j / count)) for j in range(count)]
    golden = math.pi * (3.0 - math.sqrt(5.0))
    half = max(1, (count + 1) // 2)
    up = []
    for j in range(half):
        z = 1.0 - (j + 0.5) / half
        r = math.sqrt(max(0.0, 1.0 - z * z))
        up.append((r * math.cos(golden * j), r * math.sin(golden * j), z))
    return up + [tuple(-c for c in u) for u in up]


def _reverse(f: tuple) -> tuple:
    return tuple(-c + 0.0 for c in f)


def _leading_positive(f: tuple) -> bool:
    """Whether the last nonzero component of ``f`` is positive (one field of each pair B, -B)."""
    for c in reversed(f):
        if c != 0.0:
            return c > 0.0
    return False


def predict_precision(beam: Beam, fields, params=("E0", "particle_magnetization"), *, noise: float = 1e-4,
                      gravity: float = 9.81, s=None, clamp_angle: float = 0.0, model: str = "auto",
                      options: SolverOptions | None = None) -> MeasurementPlan:
    """The precision a fit of ``params`` would reach from positions tracked under ``fields``, predicted at the guess.

    Parameters
    ----------
    beam : Beam
        The guess of the robot.
    fields : list of (B_x, B_z) or (B_x, B_y, B_z)
        Uniform fields (T) of the measurements, each with gravity.
    params : sequence of str
        Any of :data:`PLAN_PARAMETERS`.
    noise : float
        1-sigma of each tracked coordinate (m).
    gravity : float
        m/s^2 along -z during the measurements.
    s : array_like, optional
        Reference arc lengths of the tracked points (m); default the tip.
    model : {"auto", "planar", "3d"}
        ``"auto"``: the 3D rod (x, y, z tracked) when a field has a ``B_y`` component, the beam a magnetization
        across its width or ``params`` the width or the Poisson ratio; the planar model (x, z) otherwise.

    Returns
    -------
    MeasurementPlan
        ``fields`` as given; ``candidates`` and ``rejected`` are 0.
    """
    from ..spec import as_field

    if isinstance(fields, (str, bytes)) or not hasattr(fields, "__len__") or len(fields) == 0:
        raise ValueError(f"fields must be a non-empty list of (B_x, B_z) or (B_x, B_y, B_z) fields in T, got "
                         f"{fields!r}.")
    flds = [as_field(f, f"fields[{i}]") for i, f in enumerate(fields)]
    if model == "auto":
        pnames = tuple(p.strip() for p in params.split(",")) if isinstance(params, str) else tuple(params)
        three = (any(not f.is_planar for f in flds) or not beam.is_planar
                 or any(p in PLAN_PARAMETERS_3D for p in pnames))
        model = "3d" if three else "planar"
    params, s, values = _check(beam, params, noise, gravity, s, model)
    options = options if options is not None else SolverOptions()
    rows, lams, loads = [], [], []
    for i, (f, fld) in enumerate(zip(fields, flds, strict=True)):
        if model == "planar" and not fld.is_planar:
            raise ValueError(f"fields[{i}] has B_y = {fld.By:g} T: the planar model takes fields in the x-z plane "
                             "(model='3d' or 'auto' for the 3D rod).")
        load = (fld.Bx, fld.By, fld.Bz) if model == "3d" else (fld.Bx, fld.Bz)
        got = _scaled_rows(beam, load, params, s, values, gravity, clamp_angle, options, model)
        if got is None:
            raise ValueError(f"fields[{i}] = {tuple(f)}: no equilibrium away from a fold at the guess; the "
                             "precision there cannot be predicted.")
        rows.append(got[0])
        lams.append(got[1])
        loads.append(load)
    return _result(beam, params, values, loads, rows, lams, noise, 0, 0)


def plan_measurements(beam: Beam, params=("E0", "particle_magnetization"), *, n: int = 8, noise: float = 1e-4,
                      gravity: float = 9.81, max_field: float = 4e-3, s=None, spread: float = 0.3,
                      margin: float = 0.5, directions: int = 24, magnitudes: int = 8, include_gravity: bool = True,
                      both_directions: bool = False, clamp_angle: float = 0.0, model: str = "planar",
                      options: SolverOptions | None = None, progress=None) -> MeasurementPlan:
    """Choose ``n`` distinct uniform fields whose tracked shapes fit ``params`` most precisely (module docstring).

    Parameters
    ----------
    beam : Beam
        The guess of the robot (the fit's start).
    params : sequence of str
        Any of :data:`PLAN_PARAMETERS`.
    n : int
        Measurements to plan (2-100), gravity alone included when ``include_gravity``.
    noise : float
        1-sigma of each tracked coordinate (m).
    gravity : float
        m/s^2 along -z during the measurements.
    max_field : float
        Largest field magnitude the set-up makes (T).
    s : array_like, optional
        Reference arc lengths of the tracked points (m); default the tip.
    spread : float
        Prior relative uncertainty of each positive parameter (in [0, 0.9]): a field must stay ``margin`` from a
        fold at every corner ``value * (1 +- spread)``.
    margin : float
        Smallest eigenvalue of the second variation (E I / L^2) a measurement must keep (> 0).
    directions, magnitudes : int
        The candidate grid: directions every ``360 / directions`` degrees in the x-z plane (in 3D, ``directions``
        points spread evenly over the sphere, a Fibonacci lattice), magnitudes ``max_field * k / magnitudes``.
    include_gravity : bool
        Start from the shape under gravity alone (field zero), the measurement that separates the modulus from the
        magnetization.
    both_directions : bool
        Choose the fields in pairs ``B`` and ``-B`` (a set-up that reverses its currents, or a protocol that
        measures both signs); ``n`` less the gravity measurement must then be even. Less informative than free
        choice for the paper's strip (the reversed field pushes it down with its weight), but robust to a field
        offset.
    model : {"planar", "3d"}
        ``"3d"``: the 3D rod, fields with a ``B_y`` component among the candidates and x, y, z tracked (needed for
        ``width`` and ``poisson_ratio``, which act through the twist); each candidate costs about 25 ms per corner
        of the prior there (a minute for a 24 x 8 grid and two parameters).
    progress : callable, optional
        ``progress(done, total)`` after each candidate field is evaluated (long plans in 3D).

    Returns
    -------
    MeasurementPlan

    Examples
    --------
    >>> import magsoft_env as ms
    >>> plan = ms.plan_measurements(ms.Beam(25e-3, 5e-3, 1.13e-3), n=6, noise=1e-4)
    >>> len(plan.fields), plan.fields[0]
    (6, (0.0, 0.0))
    >>> bool(plan.relative_sigma["E0"] < 0.005)
    True
    """
    params, s, values = _check(beam, params, noise, gravity, s, model)
    if not (isinstance(n, int) and 2 <= n <= 100):
        raise ValueError(f"n (the measurements to plan) must be an integer in [2, 100], got {n!r}.")
    if not (isinstance(max_field, (int, float)) and math.isfinite(max_field) and 0 < max_field <= 1.0):
        raise ValueError(f"max_field must be a field magnitude in (0, 1] T, got {max_field!r}.")
    if not (isinstance(spread, (int, float)) and 0 <= spread <= 0.9):
        raise ValueError(f"spread (the prior relative uncertainty) must be in [0, 0.9], got {spread!r}.")
    if not (isinstance(margin, (int, float)) and math.isfinite(margin) and margin > 0):
        raise ValueError(f"margin must be a positive eigenvalue (E I / L^2), got {margin!r}.")
    for name, v in (("directions", directions), ("magnitudes", magnitudes)):
        if not (isinstance(v, int) and v >= 1):
            raise ValueError(f"{name} must be a positive integer, got {v!r}.")
    if directions * magnitudes + 1 > MAX_CANDIDATES:
        raise ValueError(f"directions x magnitudes must stay below {MAX_CANDIDATES} candidates, got "
                         f"{directions} x {magnitudes}.")
    if both_directions and (n - int(include_gravity)) % 2:
        raise ValueError(f"n = {n} with both_directions needs an even number of fields besides gravity alone "
                         f"({n - int(include_gravity)} given): the fields come in pairs B, -B.")
    if n > directions * magnitudes + int(include_gravity):
        raise ValueError(f"n = {n} exceeds the {directions * magnitudes + int(include_gravity)} candidate fields; "
                         "raise directions or magnitudes.")
    options = options if options is not None else SolverOptions()
    three = model == "3d"
    zero = (0.0, 0.0, 0.0) if three else (0.0, 0.0)
    cands = [zero] if include_gravity else []
    for k in range(1, magnitudes + 1):
        b = max_field * k / magnitudes
        for u in _directions(directions, three):
            cands.append(tuple(round(b * c, 15) + 0.0 for c in u))  # no 1e-19 T crumbs, no -0
    # the corners of the prior: every sign pattern of the positive parameters (along each axis beyond three)
    pos = [p for p in params if p != "clamp_angle"]
    if spread > 0 and pos:
        signs = list(itertools.product((-1.0, 1.0), repeat=len(pos))) if len(pos) <= 3 else \
            [tuple(sg if i == j else 0.0 for i in range(len(pos))) for j in range(len(pos)) for sg in (-1.0, 1.0)]
    else:
        signs = []
    from .fit import BOUNDED, _with

    def corner(p, sg):  # within a bounded parameter's range (the Poisson ratio: [0, 0.5])
        lo, hi = BOUNDED.get(p, (-math.inf, math.inf))
        return min(max(values[p] * (1.0 + sg * spread), lo), hi)

    corners = [_with(beam, {p: corner(p, sg) for p, sg in zip(pos, pattern, strict=True)}) for pattern in signs]
    rows, lams, keep = [], [], []
    for done, f in enumerate(cands, 1):
        if progress is not None and done > 1:
            progress(done - 1, len(cands))
        got = _scaled_rows(beam, f, params, s, values, gravity, clamp_angle, options, model)
        if got is None or got[1] < margin:
            continue
        lam = got[1]
        for b in corners:
            c = _scaled_rows(b, f, params, s, values, gravity, clamp_angle, options, model)
            lam = -math.inf if c is None else min(lam, c[1])
            if lam < margin:
                break
        if lam < margin:
            continue
        rows.append(got[0])
        lams.append(lam)
        keep.append(f)
    if progress is not None:
        progress(len(cands), len(cands))
    rejected = len(cands) - len(keep)
    if len(keep) < n:
        raise ValueError(f"only {len(keep)} of {len(cands)} candidate fields stay {margin:g} E I / L^2 from a fold "
                         f"over the prior (spread {spread:g}); ask for fewer measurements, a smaller margin or "
                         "spread, or a finer grid.")
    chosen = [0] if include_gravity and keep and keep[0] == zero else []
    # the units of choice: one field, or a field and its reverse (both kept)
    index = {f: i for i, f in enumerate(keep)}
    if both_directions:
        units = [(i, index[_reverse(f)]) for i, f in enumerate(keep)
                 if i not in chosen and _reverse(f) in index and _leading_positive(f)]
    else:
        units = [(i,) for i in range(len(keep)) if i not in chosen]
    if sum(len(u) for u in units) < n - len(chosen):
        raise ValueError(f"only {len(units)} field pairs B, -B stay {margin:g} E I / L^2 from a fold over the prior; "
                         "ask for fewer measurements, a smaller margin or spread, or a finer grid.")
    # a faint prior lets the first picks be compared before the set is full rank
    ridge = [math.sqrt(1e-9 * max(float(np.sum(J * J)) for J in rows)) * np.eye(len(params))]
    while len(chosen) < n:
        best = min(units, key=lambda u: (_worst(_covariance([rows[j] for j in chosen] + [rows[i] for i in u] + ridge,
                                                            noise)), -min(lams[i] for i in u)))
        chosen.extend(best)
        units.remove(best)
    return _result(beam, params, values, [keep[i] for i in chosen], [rows[i] for i in chosen],
                   [lams[i] for i in chosen], noise, len(cands), rejected)


__all__ = ["MAX_CANDIDATES", "PLAN_PARAMETERS", "MeasurementPlan", "plan_measurements", "predict_precision"]

"""Inverse design (paper Sec. II, eq. 18, Algorithm 2): magnetization profile and field for a target shape."""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from dataclasses import field as dc_field

import numpy as np

from ..spec import MAX_FIELD, Beam, Field, jig_curve
from ..spec.beam import MAX_SIZE, MIN_SLENDERNESS
from ..spec.loading import check_loading
from ..spec.material import MAX_VOLUME_FRACTION
from ..threads import single_threaded_blas
from ..validate import boolean, choice, finite_number, integer, pair
from .distance import _foot_jacobian, _signed_foot, point_to_polyline
from .families import FAMILIES, ProfileFamily
from .targets import MAX_POINTS, MIN_POINTS, curve_length, prepare_target, tangent_angle

_CENTRELINE_SAMPLES = 241  # points of the predicted centreline polyline (spectral interpolation)
_DEFAULT_SIZE = {"polynomial": 6, "fourier": 7, "piecewise_linear": 8, "spline": 7}
_START_NOISE_RAD = 0.35  # spread (rad) of the random starts around the aligned guess
_DIFF_STEP = 1e-4  # relative step of the forward-difference Jacobian
_POLISH_GAIN = 1e-4  # relative RMS gain predicted at the fine settings that calls for the polish
_FAST_NODES = 48  # Chebyshev degree of the exact method's first stage (one domain, no refinement)
#: How :func:`design_profile` takes the objective's Jacobian.
JACOBIANS = ("exact", "2-point")
#: Ranges of the integer options of :func:`design_profile` (``max_nfev`` and ``n_starts`` bound the run time).
MAX_STARTS = 1000
MAX_NFEV = 100_000
MAX_SEED = 2**32 - 1  # scipy's differential evolution seeds a RandomState: [0, 2^32)
MAX_BETA_BOUND = 20.0  # rad, about three turns either way

STATUS_MESSAGES = {
    0: "Converged: the fit meets rms_tol.",
    1: "Converged, but the fit does not meet rms_tol: the target may be out of reach of this profile family, "
    "field range or beam; try more parameters, a wider field range, more starts or global=True.",
    2: "Stopped at the evaluation limit (max_nfev) before converging; the best design found is returned.",
    3: "The equilibrium of the designed beam could not be computed.",
}


@dataclass(frozen=True)
class DesignResult:
    """Outcome of :func:`design_profile` (frozen). Units are SI.

    Attributes
    ----------
    success : bool
        The optimizer converged (``status`` 0 or 1) and the final equilibrium was found.
    status : int
        See :data:`STATUS_MESSAGES`.
    message : str
        Human-readable status, with the optimizer's own message.
    beam : Beam
        The designed beam (length = target curve length unless ``match_length=False``).
    field : Field
        The designed applied field (T).
    family : ProfileFamily
        The profile family of the magnetization angle beta(s).
    params : (p,) ndarray
        The family's parameters (rad), ``p = family.size``.
    rms_error, max_error : float
        RMS and largest distance (m) from the target points to the predicted centreline
        (NaN when the final equilibrium failed).
    target_xz : (n, 2) ndarray
        Target points used (m), resampled evenly in arc length, starting at the origin;
        ``n = n_points``.
    predicted_xz : (m, 2) ndarray
        Predicted centreline of the designed beam under the designed field (m), ``m = 241``
        points (a (2, 2) array of NaN when the final equilibrium failed).
    jig_xz : (k, 2) ndarray
        Jig curve (m) that produces the designed magnetization (paper eq. 1), ``k = 201``.
    equilibrium : EquilibriumResult
        The analytical solution behind ``predicted_xz``.
    history : list of dict
        One record per start (local, then the global stage if run): initial and final RMS
        error (m), field (T), evaluations, status, time (s), equilibrium solves and (local starts)
        Jacobians taken by differences where the exact one did not exist; the unit is in each key
        that has one.
    nfev : int
        Equilibrium solves in total (dimensionless count).
    wall_time : float
        Wall time of the whole design (s).
    settings : dict
        The options the design ran with, JSON-ready, the unit in each key that has one
        (``field_bounds_T``, ``beta_bounds_rad``, ``gravity_m_s2``, ``target_length_m``, ...).
    length : float
        (property) Beam length L (m).
    rms_error_percent, max_error_percent : float
        (property) ``rms_error`` and ``max_error`` as a percentage of L.
    """

    success: bool
    status: int
    message: str
    beam: Beam
    field: Field
    family: ProfileFamily
    params: np.ndarray
    rms_error: float
    max_error: float
    target_xz: np.ndarray
    predicted_xz: np.ndarray
    jig_xz: np.ndarray
    equilibrium: object
    history: list = dc_field(default_factory=list)
    nfev: int = 0
    wall_time: float = 0.0
    settings: dict = dc_field(default_factory=dict)

    @property
    def length(self) -> float:
        return self.beam.length

    @property
    def rms_error_percent(self) -> float:
        """RMS error as a percentage of the beam length."""
        return 100.0 * self.rms_error / self.beam.length

    @property
    def max_error_percent(self) -> float:
        return 100.0 * self.max_error / self.beam.length

    def to_dict(self) -> dict:
        """Plain numbers (mm, mT, %) for JSON and tables."""
        return {
            "success": bool(self.success),
            "status": int(self.status),
            "message": self.message,
            "length_mm": self.beam.length * 1e3,
            "field_Bx_mT": self.field.Bx * 1e3,
            "field_Bz_mT": self.field.Bz * 1e3,
            "field_magnitude_mT": self.field.magnitude * 1e3,
            "rms_error_mm": self.rms_error * 1e3,
            "rms_error_percent_L": self.rms_error_percent,
            "max_error_mm": self.max_error * 1e3,
            "max_error_percent_L": self.max_error_percent,
            "family": self.family.kind,
            "params_rad": [float(p) for p in self.params],
            "volume_fraction": float(np.mean(self.beam.phi(np.linspace(0, self.beam.length, 11)))),
            "nfev": self.nfev,
            "wall_time_s": self.wall_time,
        }


def _bounds(name, value, lo, hi, unit):
    a, b = pair(name, value, f"(min, max) in {unit}")
    a = finite_number(f"{name}[0]", a, unit=unit)
    b = finite_number(f"{name}[1]", b, unit=unit)
    if not (lo <= a < b <= hi):
        hint = (" Angles are in radians: this looks like degrees; convert with math.radians."
                if unit == "rad" and max(abs(a), abs(b)) > hi else "")
        raise ValueError(f"{name} must satisfy {lo:g} <= min < max <= {hi:g} ({unit}), got ({a!r}, {b!r}).{hint}")
    return a, b


def design_profile(
    target_xz,
    beam: Beam,
    *,
    field_bounds,
    family: str | ProfileFamily = "spline",
    size: int | None = None,
    beta_bounds=(-math.pi, math.pi),
    field_direction: str = "perpendicular",
    volume_fraction_bounds=None,
    match_length: bool = True,
    n_points: int = 50,
    n_starts: int = 4,
    seed: int | None = 0,
    rms_tol: float = 0.0025,
    max_nfev: int = 60,
    global_stage: bool = False,
    gravity: float = 9.81,
    clamp_angle: float | None = 0.0,
    coupling: str = "rotated",
    extensible: bool = False,
    progress: bool = False,
    jacobian: str = "exact",
) -> DesignResult:
    """Design the magnetization profile and field that make ``beam`` follow ``target_xz``.

    Minimizes the paper's objective (eq. 18), the sum over N target points of the squared
    distance to the predicted centreline::

        min_p,B  f = sum_i d_i^2,   d_i = min_s |X_target,i - X(s; p, B)|,
        s.t.     B_min <= |B_a| <= B_max,  lo <= p <= hi

    where X(s; p, B) is the equilibrium centreline reached along the loading path (gravity,
    then the field ramped from zero) and d_i is the distance to the curve (to its polyline
    through 241 points, spectrally interpolated), not to its nodes. Solved by
    ``scipy.optimize.least_squares(method="trf")`` with box bounds (the same interior
    trust-region family as the paper's fmincon) and the residuals' exact Jacobian (``jacobian``), from several
    starts: the first aligns the
    magnetization with the field along the target (beta = alpha - theta_target, the
    strong-field limit), the others perturb it with a seeded random generator. Optionally a
    global stage (``scipy.optimize.differential_evolution``) runs first when the local starts
    miss ``rms_tol``.

    Parameters
    ----------
    target_xz : (N, 2) array
        Target centreline (m) starting at the clamped end; translated so it starts at the origin
        and resampled to ``n_points`` evenly in arc length. At least 4 distinct points, finite,
        not self-intersecting.
    beam : Beam
        Geometry and material. Its magnetization is replaced by the design.
    field_bounds : (float, float)
        Range (T) of the applied field magnitude, ``0 <= B_min < B_max``.
    family : {"spline", "polynomial", "fourier", "piecewise_linear"} or ProfileFamily
        Profile family for beta(s); ``size`` parameters (default 7, 6, 7 or 8).
    beta_bounds : (float, float)
        Bounds (rad) on every profile parameter (knot values or coefficients), within [-20, 20].
        The default [-pi, pi] keeps jigs free of loops; widen it if a profile must wind further.
    field_direction : {"perpendicular", "free"}
        ``"perpendicular"``: along +z, perpendicular to the undeformed beam (the paper's
        choice); ``"free"``: the field angle alpha in [-pi, pi] is a design variable too.
    volume_fraction_bounds : (float, float), optional
        Make a uniform particle volume fraction a design variable within these bounds
        (0 < min < max <= 0.5).
    match_length : bool
        Set the beam length to the target's curve length (the paper's assumption); that length
        must then be a valid beam length, at most 1 m and at least the beam's thickness.
    n_points : int
        N, points on the target, in [4, 100000].
    n_starts : int
        Local starts at most, in [1, 1000]; stops early once the RMS error is below ``rms_tol`` x L.
    seed : int or None
        Seed of the random starts (and the global stage), in [0, 2^32 - 1].
    rms_tol : float
        RMS error (fraction of L, in [0, 1]) that counts as a fit.
    max_nfev : int
        Objective evaluations per local start (each one equilibrium solve plus its Jacobian), in
        [2, 100000]; with ``jacobian="exact"`` per stage (the fast stage and the polish, see ``jacobian``).
    global_stage : bool
        Run differential evolution when the local starts miss ``rms_tol``.
    gravity, coupling, extensible
        Passed to :func:`magsoft_env.solve_equilibrium`.
    clamp_angle : float or None
        Tangent angle (rad) of the beam at the clamp; 0 (along +x) by default. None takes the
        target's initial tangent (for strokes that start downward, like the letters J and U).
    progress : bool
        Show a tqdm progress bar over the starts.
    jacobian : {"exact", "2-point"}
        How the optimizer gets the residuals' Jacobian. ``"exact"`` (default): from the equilibrium's exact
        sensitivities (:func:`magsoft_env.theory.sensitivity.profile_sensitivities`, one linear solve on the
        collocation Jacobian the solver has factored) and the exact derivative of the point-to-curve distance
        (:func:`magsoft_env.design.point_to_polyline_jacobian`): one equilibrium solve per optimizer iteration.
        Each start searches first with the solver on one fixed grid (48 Chebyshev nodes, about 3 times cheaper
        a solve; where a solve fails on it, the rest of that search runs at the usual settings), then continues
        at the optimizer's usual settings (the polish) only where a Gauss-Newton step there, checked by a solve,
        gains more than 1e-4 of the RMS error. Where the derivative does not exist (a failed equilibrium, an
        equilibrium at a fold) or is not implemented (``extensible=True``) that iteration falls back to forward
        differences. ``"2-point"``: forward
        differences throughout (relative step 1e-4; one more solve per design variable and iteration), the
        method before exact gradients, kept to reproduce earlier designs.

    Returns
    -------
    DesignResult
        ``success`` is False (and ``message`` says why) when the optimizer did not converge.

    Examples
    --------
    >>> import numpy as np, magsoft_env as ms
    >>> from magsoft_env.design import builtin_target
    >>> beam = ms.Beam(length=20e-3, width=5e-3, thickness=1.13e-3)
    >>> res = ms.design_profile(builtin_target("ball"), beam, field_bounds=(1e-3, 40e-3))
    >>> res.success, res.rms_error_percent < 1.0
    (True, True)
    """
    t_start = time.perf_counter()
    # ---- validation, all before any work
    if not isinstance(beam, Beam):
        raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
    b_lo, b_hi = _bounds("field_bounds", field_bounds, 0.0, MAX_FIELD, "T")
    if isinstance(family, ProfileFamily):
        fam = family
        if size is not None and size != fam.size:
            raise ValueError(f"size conflicts with the given ProfileFamily (size {fam.size}), got {size!r}.")
    else:
        if not isinstance(family, str):
            raise ValueError(f"family must be one of {list(FAMILIES)} or a ProfileFamily, got {family!r}.")
        kind = choice("family", family, ("spline", "polynomial", "fourier", "piecewise_linear"))
        fam = ProfileFamily(kind, _DEFAULT_SIZE[kind] if size is None else size)
    p_lo, p_hi = _bounds("beta_bounds", beta_bounds, -MAX_BETA_BOUND, MAX_BETA_BOUND, "rad")
    if not isinstance(field_direction, str):
        raise ValueError(f"field_direction must be one of ['perpendicular', 'free'], got {field_direction!r}.")
    direction = choice("field_direction", field_direction, ("perpendicular", "free"))
    vf = None
    if volume_fraction_bounds is not None:
        vf = _bounds("volume_fraction_bounds", volume_fraction_bounds, 0.0, MAX_VOLUME_FRACTION, "1")
        if vf[0] <= 0.0:
            raise ValueError(f"volume_fraction_bounds must have min > 0 (no particles, no actuation), got {vf!r}.")
    if not isinstance(match_length, (bool, np.bool_)):
        raise ValueError(f"match_length must be True or False, got {match_length!r}.")
    global_stage = boolean("global_stage", global_stage)
    progress = boolean("progress", progress)
    if not isinstance(jacobian, str):
        raise ValueError(f"jacobian must be one of {list(JACOBIANS)}, got {jacobian!r}.")
    jac_method = choice("jacobian", jacobian, JACOBIANS)
    n_points = integer("n_points", n_points, MIN_POINTS, MAX_POINTS)
    n_starts = integer("n_starts", n_starts, 1, MAX_STARTS)
    max_nfev = integer("max_nfev", max_nfev, 2, MAX_NFEV)
    if seed is not None:
        seed = integer("seed", seed, 0, MAX_SEED)
    rms_tol = finite_number("rms_tol", rms_tol)
    if not 0.0 <= rms_tol <= 1.0:
        raise ValueError(f"rms_tol must lie in [0, 1] (a fraction of L: 0.0025 is 0.25 %), got {rms_tol!r}.")
    if clamp_angle is not None:
        clamp_angle = finite_number("clamp_angle", clamp_angle, unit="rad")
    # loading options that do not depend on the target: checked before the target is processed
    check_loading(gravity=gravity, coupling=coupling, extensible=extensible,
                  clamp_angle=0.0 if clamp_angle is None else clamp_angle)
    target = prepare_target(target_xz, n_points)
    if clamp_angle is None:
        clamp_angle = float(tangent_angle(target)[1][0])
    lo = check_loading(gravity=gravity, coupling=coupling, extensible=extensible, clamp_angle=clamp_angle)
    g, coupling, extensible, th0 = lo["gravity"], lo["coupling"], lo["extensible"], lo["clamp_angle"]
    raw_length = curve_length(np.asarray(target_xz, dtype=float))
    if match_length:
        if raw_length > MAX_SIZE:
            raise ValueError(
                f"target_xz is {raw_length:g} m long, longer than the longest beam ({MAX_SIZE:g} m): the target is in "
                f"metres ({raw_length:g} mm would be {raw_length * 1e-3:g} m)."
            )
        if raw_length < MIN_SLENDERNESS * beam.thickness:
            raise ValueError(
                f"target_xz is {raw_length:g} m long, shorter than the beam is thick ({beam.thickness:g} m): with "
                "match_length=True the beam would not be slender; is the target in metres?"
            )
        beam = beam.replace(length=raw_length)
    L = beam.length

    problem = _Problem(
        target=target, beam=beam, family=fam, b_range=(b_lo, b_hi), direction=direction, vf=vf,
        gravity=g, coupling=coupling, extensible=bool(extensible), clamp_angle=th0, jacobian=jac_method,
    )
    lo, hi = problem.bounds(p_lo, p_hi)
    with single_threaded_blas():  # ~100 x 100 systems: threads only cost time
        x_guess = problem.initial_guess(lo, hi)
        rng = np.random.default_rng(seed)

        history: list[dict] = []
        best = None  # (cost, x, ls_result)
        starts = range(n_starts)
        bar = None
        if progress:
            from tqdm.auto import tqdm

            bar = tqdm(total=n_starts, desc="design starts", unit="start")
        for k in starts:
            x0 = x_guess if k == 0 else problem.perturb(x_guess, lo, hi, rng)
            t0 = time.perf_counter()
            solves0, fb0 = problem.nfev, problem.fallbacks
            r0 = problem.rms(x0)
            ls = problem.least_squares(x0, lo, hi, max_nfev)
            rms = problem.rms(ls.x)
            history.append({
                "start": k, "stage": "local", "initial_rms_m": r0 * L, "rms_m": rms * L,
                "field_T": problem.field(ls.x).as_array().tolist(), "nfev": int(ls.nfev), "status": int(ls.status),
                "message": ls.message, "time_s": time.perf_counter() - t0, "solves": problem.nfev - solves0,
                "jacobian_fallbacks": problem.fallbacks - fb0,
            })
            if best is None or rms < best[0]:
                best = (rms, ls.x, ls)
            if bar is not None:
                bar.update(1)
                bar.set_postfix(best_rms_pct=f"{100 * best[0]:.3f}")
            if best[0] <= rms_tol:
                break
        if bar is not None:
            bar.close()

        if global_stage and best[0] > rms_tol:
            best = _global(problem, lo, hi, best, seed, max_nfev, history, L)

        # ---- final, accurate evaluation of the best design
        x_best, ls_best = best[1], best[2]
        d_beam, d_field = problem.beam_for(x_best), problem.field(x_best)
        from ..theory import solve_equilibrium

        eq = solve_equilibrium(d_beam, d_field, gravity=g, coupling=coupling, extensible=bool(extensible),
                                clamp_angle=th0)
        note = ""
        if not eq.success:
            # the default (finer) settings can stall where the optimizer's converged: keep the latter, say so
            first = eq.message
            eq = solve_equilibrium(d_beam, d_field, gravity=g, coupling=coupling, extensible=bool(extensible),
                                    clamp_angle=th0, options=problem.options)
            note = (" The final equilibrium used the optimizer's solver settings (resolution 1e-6 rad) because the "
                    f"default settings failed: {first}")
        if problem.fallbacks and jac_method == "exact" and not extensible:
            note += (f" {problem.fallbacks} Jacobians were taken by finite differences (a failed equilibrium or one "
                     "at a fold, where the exact derivative does not exist).")
        if problem.failed:
            note += (f" {problem.failed} of {problem.nfev} equilibrium solves failed during the search and counted "
                     "as an error of L at every point.")
        if eq.success and eq.snap_through:
            note += (" Along the field ramp the beam snaps through (a fold of the equilibrium path) before it "
                     "reaches the designed shape; see the ramp figure.")
        if eq.success:
            _, xs, zs, _ = eq.sample(_CENTRELINE_SAMPLES)
            pred = np.column_stack([xs, zs])
            dist = point_to_polyline(target, pred)
            rms_error, max_error = float(np.sqrt(np.mean(dist**2))), float(dist.max())
        else:
            pred = np.full((2, 2), np.nan)
            rms_error = max_error = float("nan")
        jx, jz = jig_curve(d_beam.magnetization, L, n=201)
        if not eq.success:
            status = 3
        elif rms_error <= rms_tol * L:
            status = 0
        elif ls_best.status == 0:
            status = 2
        else:
            status = 1
        message = f"{STATUS_MESSAGES[status]} (optimizer: {ls_best.message}){note}"
        return DesignResult(
            success=status in (0, 1), status=status, message=message, beam=d_beam, field=d_field, family=fam,
            params=np.asarray(x_best[: fam.size]).copy(), rms_error=rms_error, max_error=max_error,
            target_xz=target, predicted_xz=pred, jig_xz=np.column_stack([jx, jz]), equilibrium=eq, history=history,
            nfev=problem.nfev, wall_time=time.perf_counter() - t_start,
            settings={
                "field_bounds_T": [b_lo, b_hi], "beta_bounds_rad": [p_lo, p_hi], "field_direction": direction,
                "volume_fraction_bounds": list(vf) if vf else None, "n_points": n_points, "n_starts": n_starts,
                "seed": seed, "rms_tol": rms_tol, "max_nfev": max_nfev, "global_stage": bool(global_stage),
                "gravity_m_s2": g, "clamp_angle_rad": th0, "coupling": coupling, "extensible": bool(extensible),
                "family": fam.kind,
                "size": fam.size, "target_length_m": raw_length, "jacobian": jac_method,
            },
        )


class _Problem:
    """Design variables x = [profile params (rad), B / B_max, (alpha, rad), (volume fraction)] and residuals."""

    def __init__(self, *, target, beam, family, b_range, direction, vf, gravity, coupling, extensible, clamp_angle,
                 jacobian="exact"):
        from ..theory import SolverOptions

        self.target, self.beam, self.family = target, beam, family
        self.b_lo, self.b_hi = b_range
        self.direction, self.vf = direction, vf
        self.gravity, self.coupling, self.extensible = gravity, coupling, extensible
        self.clamp_angle = clamp_angle
        self.n = len(target)
        # looser than the default: ~1e-6 rad resolution (verified to 1e-5 between the nodes) is far
        # below the fit errors that matter; the returned design is solved again at the defaults
        if family.kind == "piecewise_linear":  # one spectral domain per knot interval: few nodes each
            self.options = SolverOptions(nodes=16, resolution_tol=1e-6, tol=1e-10, verify_tol=1e-5)
            self.fast_options = self.options
        else:
            self.options = SolverOptions(resolution_tol=1e-6, tol=1e-10, max_nodes=64, verify_tol=1e-5,
                                         split_at_knots=False)
            # the first, fast stage of the exact method: one fixed grid, no refinement
            self.fast_options = SolverOptions(nodes=_FAST_NODES, resolution_tol=1e-3, tol=1e-10, verify_tol=1e-3,
                                              split_at_knots=False)
        self.fast = False  # solve with fast_options
        self.nfev = 0
        self.failed = 0
        self.fallbacks = 0  # Jacobians taken by differences where the exact one was asked for
        self.fast_misses = 0  # fast-stage solves that failed and were repeated at the usual settings
        self.method = jacobian
        self._box = (-np.inf, np.inf)
        self._samples = np.linspace(0.0, beam.length, _CENTRELINE_SAMPLES)
        self._cache: dict[bytes, np.ndarray] = {}
        self._eqs: dict = {}  # x -> equilibrium (None when failed) of the last few evaluations
        self._basis: dict = {}  # collocation nodes -> the family's basis there

    # layout
    def bounds(self, p_lo, p_hi):
        lo = [p_lo] * self.family.size + [self.b_lo / self.b_hi]
        hi = [p_hi] * self.family.size + [1.0]
        if self.direction == "free":
            lo.append(-math.pi)
            hi.append(math.pi)
        if self.vf is not None:
            lo.append(self.vf[0])
            hi.append(self.vf[1])
        self._box = (np.array(lo), np.array(hi))
        return np.array(lo), np.array(hi)

    def alpha(self, x) -> float:
        return float(x[self.family.size + 1]) if self.direction == "free" else 0.5 * math.pi

    def field(self, x) -> Field:
        b = float(np.clip(x[self.family.size], self.b_lo / self.b_hi, 1.0)) * self.b_hi
        if self.direction == "perpendicular":
            return Field(0.0, b)
        return Field.polar(b, self.alpha(x))

    def beam_for(self, x) -> Beam:
        changes = {"magnetization": self.family.profile(x[: self.family.size], self.beam.length)}
        if self.vf is not None:
            changes["volume_fraction"] = float(x[-1])
        return self.beam.replace(**changes)

    def initial_guess(self, lo, hi):
        # strong-field limit: each element aligns its magnetization with the field, theta + beta = alpha
        u, theta = tangent_angle(self.target)
        p = self.family.fit(u, 0.5 * math.pi - theta)
        x = list(p) + [0.75]
        if self.direction == "free":
            x.append(0.5 * math.pi)
        if self.vf is not None:
            x.append(0.5 * (self.vf[0] + self.vf[1]))
        return np.clip(np.array(x), lo, hi)

    def perturb(self, x, lo, hi, rng):
        y = x.copy()
        m = self.family.size
        y[:m] += rng.normal(0.0, _START_NOISE_RAD, m)
        y[m] = rng.uniform(lo[m], hi[m])
        for j in range(m + 1, len(y)):
            y[j] = rng.uniform(lo[j], hi[j])
        return np.clip(y, lo, hi)

    # objective
    def residuals(self, x) -> np.ndarray:
        key = bytes([self.fast]) + np.asarray(x, dtype=float).tobytes()
        hit = self._cache.get(key)
        if hit is not None:
            return hit
        from ..theory import solve_equilibrium

        beam, fld = self.beam_for(x), self.field(x)

        def solve(options):
            self.nfev += 1
            try:
                return solve_equilibrium(beam, fld, gravity=self.gravity, coupling=self.coupling,
                                         clamp_angle=self.clamp_angle, extensible=self.extensible, options=options)
            except ValueError:
                return None

        eq = solve(self.fast_options if self.fast else self.options)
        if self.fast and (eq is None or not eq.success):
            # the fixed grid cannot resolve this shape (or the path on it fails): the rest of this search runs
            # at the usual settings
            self.fast_misses += 1
            self.fast = False
            key = bytes([self.fast]) + key[1:]
            eq = solve(self.options)
        if eq is None or not eq.success:
            self.failed += 1
            r = np.full(self.n, 1.0 / math.sqrt(self.n))  # as if every point were L away
            eq = None
        else:
            _, xs, zs, _ = eq.sample(_CENTRELINE_SAMPLES)
            if self.method == "exact":  # keep what the Jacobian needs
                d, foot = _signed_foot(self.target, np.column_stack([xs, zs]))
                eq = (eq, foot)
            else:
                d = point_to_polyline(self.target, np.column_stack([xs, zs]), signed=True)
            r = d / (self.beam.length * math.sqrt(self.n))
        if len(self._cache) > 4096:
            self._cache.clear()
        self._cache[key] = r
        if len(self._eqs) > 8:  # the Jacobian is asked for at the last point evaluated, or close to it
            self._eqs.pop(next(iter(self._eqs)))
        self._eqs[key] = eq
        return r

    def least_squares(self, x0, lo, hi, max_nfev):
        """One local search from ``x0``: trust-region reflective least squares.

        With forward differences, at the optimizer's solver settings (:attr:`options`) throughout. With the exact
        Jacobian, first on one fixed grid (:attr:`fast_options`, no refinement: about 3 times cheaper a solve),
        then, from where that stage stopped, at :attr:`options`: the residuals and their Jacobian there give the
        Gauss-Newton step within the bounds, and when that step does lower the RMS error by more than
        ``_POLISH_GAIN`` of itself (predicted, then checked by a solve) the search continues from there at
        :attr:`options` (the polish). ``nfev`` counts both stages."""
        from scipy.optimize import least_squares, lsq_linear

        kw = dict(bounds=(lo, hi), method="trf", x_scale=1.0, ftol=1e-9, xtol=1e-9, gtol=1e-9)
        if self.method != "exact":
            return least_squares(self.residuals, x0, jac="2-point", diff_step=_DIFF_STEP, max_nfev=max_nfev, **kw)
        if self.fast_options is self.options:
            return least_squares(self.residuals, x0, jac=self.jacobian, max_nfev=max_nfev, **kw)
        self.fast = True
        try:
            first = least_squares(self.residuals, x0, jac=self.jacobian, max_nfev=max_nfev, **kw)
        finally:
            self.fast = False
        x = first.x
        r = self.residuals(x)
        now = float(np.linalg.norm(r))
        J = self.jacobian(x)
        step = lsq_linear(J, -r, bounds=(lo - x, hi - x)).x if np.all(np.isfinite(J)) else np.zeros_like(x)
        first.nfev += 1
        if now - float(np.linalg.norm(r + J @ step)) > _POLISH_GAIN * now:
            # the linear model promises a gain: check it (at a jump of the objective, where the loading path
            # switches branches, it does not hold and a polish would only walk along the jump)
            y = np.clip(x + step, lo, hi)
            first.nfev += 1
            if now - float(np.linalg.norm(self.residuals(y))) > _POLISH_GAIN * now:
                ls = least_squares(self.residuals, y, jac=self.jacobian, max_nfev=max_nfev, **kw)
                ls.nfev += first.nfev
                return ls
        return first

    def jacobian(self, x) -> np.ndarray:
        """d residuals / d x: exact (one linear solve on the equilibrium's collocation Jacobian), or forward
        differences (``jacobian="2-point"``, and where the exact one does not exist: a failed equilibrium, an
        extensible beam, a fold)."""
        x = np.asarray(x, dtype=float)
        if self.method == "exact":
            key = bytes([self.fast]) + x.tobytes()
            if key not in self._eqs:
                self.residuals(x)
            eq = self._eqs.get(key)
            if eq is not None:
                try:
                    return self._exact_jacobian(x, *eq)
                except ValueError:  # at a fold: no derivative
                    pass
            self.fallbacks += 1
        from scipy.optimize._numdiff import approx_derivative

        return approx_derivative(self.residuals, x, method="2-point", rel_step=_DIFF_STEP, f0=self.residuals(x),
                                 bounds=self._box)

    def _exact_jacobian(self, x, eq, foot) -> np.ndarray:
        from ..theory.sensitivity import profile_sensitivities

        m, L = self.family.size, self.beam.length
        free = self.direction == "free"
        extra = ["Bx", "Bz"] if free else ["Bz"]
        if self.vf is not None:
            extra.append("volume_fraction")
        s_eval = eq._eig[0].grid.s_eval  # the collocation nodes (collocation_nodes without the checks)
        k = s_eval.tobytes()
        basis = self._basis.get(k)
        if basis is None:  # d beta / d p at the nodes: the same few grids again and again
            if len(self._basis) > 16:
                self._basis.clear()
            basis = self._basis[k] = self.family.basis(s_eval / L)
        S = profile_sensitivities(eq, basis, params=extra, exact_eigenvalue=False)
        dpos = S.positions(self._samples)[:, [0, 2], :]  # (241, 2, m + len(extra))
        cols = [dpos[..., :m]]
        b = float(np.clip(x[m], self.b_lo / self.b_hi, 1.0)) * self.b_hi
        if free:
            a = self.alpha(x)
            dBx, dBz = dpos[..., m], dpos[..., m + 1]
            cols.append((self.b_hi * (math.cos(a) * dBx + math.sin(a) * dBz))[..., None])
            cols.append((b * (-math.sin(a) * dBx + math.cos(a) * dBz))[..., None])
        else:
            cols.append(self.b_hi * dpos[..., m : m + 1])
        if self.vf is not None:
            cols.append(dpos[..., -1:])
        return _foot_jacobian(foot, np.concatenate(cols, axis=2)) / (L * math.sqrt(self.n))

    def rms(self, x) -> float:
        """RMS distance as a fraction of L."""
        return float(np.sqrt(np.sum(self.residuals(x) ** 2)))


def _global(problem, lo, hi, best, seed, max_nfev, history, L):
    """Differential evolution over the same box, polished by least squares; keeps the better design."""
    from scipy.optimize import differential_evolution

    t0 = time.perf_counter()
    de = differential_evolution(
        lambda x: problem.rms(x) ** 2, list(zip(lo, hi, strict=True)), seed=seed, popsize=8, maxiter=15,
        tol=1e-8, polish=False, init="sobol", x0=best[1],
    )
    ls = problem.least_squares(np.clip(de.x, lo, hi), lo, hi, max_nfev)
    rms = problem.rms(ls.x)
    history.append({
        "start": len(history), "stage": "global", "initial_rms_m": math.sqrt(de.fun) * L, "rms_m": rms * L,
        "field_T": problem.field(ls.x).as_array().tolist(), "nfev": int(de.nfev + ls.nfev), "status": int(ls.status),
        "message": ls.message, "time_s": time.perf_counter() - t0,
    })
    return (rms, ls.x, ls) if rms < best[0] else best

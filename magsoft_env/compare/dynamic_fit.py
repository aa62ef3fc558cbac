"""Fit a robot's dynamic parameters to dynamic data through the MuJoCo rods (finite differences of simulations).

Two protocols (docs/fit.md, "Dynamic data: free decay and crawl speed"):

- :func:`fit_decay`: a clamped strip rings down after a release; its tracked tip height ``z(t)`` gives the hinge
  damping (``Robot.retardation_time``, the Kelvin-Voigt time: hinge damping = retardation time x stiffness) and
  the modulus ``E0``. Least squares on the whole trajectory (Levenberg-Marquardt), started from a modulus whose
  simulated ringing frequency matches the measured one (the trajectory misfit has a local minimum at every
  whole-period phase slip; matching the frequency first puts the start in the right valley).
- :func:`fit_friction`: the robot's open-loop gait crawls at a speed that depends on the floor friction; a measured
  mean speed (or the speeds of several drives) gives the friction coefficient, by a sweep over a bracket smoothed
  by a quadratic (the simulated speed is rough in friction at the per-cent scale), then the root (one speed) or
  the 1-D least squares (several) of the smoothed speed.

The MuJoCo rods are not differentiable here: the decay's Jacobian is central finite differences of whole
simulations (step :data:`DECAY_FD_STEP` in the logarithm); the crawl's slope is that of the smoothed sweep. Every
fit is bounded by a maximum number of simulations, and bad input is refused with a ValueError before any
simulation.
"""

from __future__ import annotations

import dataclasses
import math
import time as _time
from dataclasses import dataclass, field

import numpy as np
import scipy.interpolate
import scipy.optimize

from ..cases.robots import MAX_FRICTION, Robot
from ..sim.gait import run_gait
from ..sim.health import MAX_STEPS
from ..sim.model import RodOptions
from ..sim.simulator import SimulationError, Simulator
from ..spec import as_field
from ..spec.drive import Waveparams
from ..validate import finite_array, in_range, integer, positive

#: Parameters :func:`fit_decay` fits (names as in :class:`~magsoft_env.Robot` and its material); ``"damping"`` is
#: read as ``"retardation_time"``.
DECAY_PARAMETERS = ("retardation_time", "E0")
DECAY_ALIASES = {"damping": "retardation_time"}
#: Central finite-difference step of :func:`fit_decay`'s Jacobian, in the logarithm of each parameter (0.1 %).
DECAY_FD_STEP = 1e-3
#: Longest decay record (s) and the most samples one takes.
MAX_DECAY_TIME = 60.0
MAX_DECAY_SAMPLES = 200_000
#: Largest |tip z| accepted, in beam lengths (metres given as mm otherwise).
MAX_TIP_LENGTHS = 2.0
#: Largest |speed| accepted (m/s): crawlers move mm/s; a larger number is a unit mistake (mm/s given as m/s).
MAX_SPEED = 0.1
#: Degree of the polynomial in the friction that smooths :func:`fit_friction`'s sweep (per drive).
SURROGATE_DEGREE = 2
#: Most drives (measured speeds) one friction fit takes.
MAX_DRIVES = 20
#: The simulated tip is recorded at most this often (s) and interpolated (cubic) at the measured times.
RECORD_DT = 1e-3
#: Residual (m) of a decay simulation that failed (unstable): large, so the optimizer steps back.
FAILED_RESIDUAL = 1.0


class _Budget(Exception):
    """The simulation budget is spent."""


@dataclass(frozen=True)
class DynamicFitResult:
    """The outcome of :func:`fit_decay` or :func:`fit_friction` (frozen), like :class:`~magsoft_env.FitResult`.

    Attributes
    ----------
    success : bool
    message : str
    params : tuple of str
    values, sigma : dict
        Fitted values and their 1-sigma uncertainties, by parameter (SI units; friction dimensionless).
    interval95 : dict
        ``(low, high)``: +-1.96 sigma (normal approximation).
    covariance, correlation : (k, k) ndarray
    robot : Robot
        The robot with the fitted values.
    residual : (m,) ndarray
        Misfits at the optimum: tip z (m) at each measured time (decay); speed (m/s) of each drive (friction).
    rms : float
        Root-mean-square misfit (m or m/s).
    residual_sigma : float
        The measurement sigma given, or the one the residual implies (NaN when it cannot: one speed, no sigma).
    simulations : int
        Simulations run (each a whole release or gait).
    wall_time : float
        Seconds of wall time.
    details : dict
        Protocol-specific records: the decay's measured and simulated frequencies; the friction sweep
        (``sweep_friction``, ``sweep_speed``), whether it was monotonic, the slope(s) d speed / d friction.
    """

    success: bool
    message: str
    params: tuple
    values: dict
    sigma: dict
    interval95: dict
    covariance: np.ndarray
    correlation: np.ndarray
    robot: Robot
    residual: np.ndarray
    rms: float
    residual_sigma: float
    simulations: int
    wall_time: float
    details: dict = field(default_factory=dict)

    def to_dict(self) -> dict:
        def plain(v):
            if isinstance(v, np.ndarray):
                return v.tolist()
            if isinstance(v, (list, tuple)):
                return [plain(x) for x in v]
            return v

        return {"success": self.success, "message": self.message, "values": dict(self.values),
                "sigma": dict(self.sigma), "interval95": {k: list(v) for k, v in self.interval95.items()},
                "correlation": self.correlation.tolist(), "rms": self.rms, "residual_sigma": self.residual_sigma,
                "simulations": self.simulations, "wall_time_s": self.wall_time,
                "details": {k: plain(v) for k, v in self.details.items()}}


def _record(params, values, sd, cov, **kw) -> dict:
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sd, sd)
    sig = {p: float(s) for p, s in zip(params, sd, strict=True)}
    return dict(params=tuple(params), values=dict(values), sigma=sig,
                interval95={p: (values[p] - 1.96 * sig[p], values[p] + 1.96 * sig[p]) for p in params},
                covariance=cov, correlation=corr, **kw)


# ---------------------------------------------------------------------------------------------- free decay
def _with_values(robot: Robot, values: dict) -> Robot:
    changes = {}
    if "retardation_time" in values:
        changes["retardation_time"] = values["retardation_time"]
    if "E0" in values:
        beam = robot.beam
        changes["beam"] = dataclasses.replace(beam, material=dataclasses.replace(beam.material, E0=values["E0"]))
    return robot.replace(**changes) if changes else robot


def simulate_decay(robot: Robot, times, *, hold_field=None, gravity: float = 9.81, segments: int | None = None,
                   timestep: float | None = None) -> np.ndarray:
    """The tip height ``z(t)`` (m, clamp at the origin, z up) of ``robot``'s strip clamped horizontally at the
    origin, released at ``t = 0``, at the measured ``times`` (s): the forward model of :func:`fit_decay`.

    ``hold_field`` None: released from straight and at rest (held horizontal, then let go) under gravity. A field
    ``(B_x, B_z)`` (T): settled under it with gravity, then the field switched off at ``t = 0``. The planar MuJoCo
    chain (``RodOptions(scene="cantilever")``) at the robot's numerics (``segments``, ``timestep`` replace them),
    its damping ``Robot.retardation_time``; the tip recorded every :data:`RECORD_DT` (or every step, if longer) and
    interpolated (cubic) at ``times``. Raises :class:`~magsoft_env.sim.SimulationError` if the rod goes unstable.
    """
    times = np.asarray(times, dtype=float)
    opts = RodOptions(scene="cantilever", segments=robot.segments if segments is None else segments,
                      timestep=robot.timestep if timestep is None else timestep,
                      retardation_time=robot.retardation_time, gravity=gravity)
    sim = Simulator(robot.beam, opts)
    if hold_field is not None:
        sim.set_field(hold_field)
        res = sim.settle(tol=1e-8, max_time=20.0)
        if not res.success:
            raise SimulationError(f"the strip did not settle under the held field: {res.message}")
        sim.set_field((0.0, 0.0))
        sim.reset(qpos=sim.state()[0])  # at rest, time zero, field off
    every = max(1, int(round(RECORD_DT / sim.timestep)))
    nsteps = int(math.ceil(times[-1] / sim.timestep - 1e-9)) + 2 * every
    ts, zs = [0.0], [sim.tip_position()[-1]]
    done = 0
    while done < nsteps:
        k = min(every, nsteps - done)
        sim.step(k)
        done += k
        ts.append(sim.time)
        zs.append(sim.tip_position()[-1])
    return scipy.interpolate.CubicSpline(np.array(ts), np.array(zs))(times)


def ringing_frequency(times, z) -> float:
    """The ringing frequency (Hz) of a record: the peak of the spectrum of ``z`` less the mean of its second half
    (resampled uniformly, zero-padded 16x, the peak refined by a parabola through its three bins), above one period
    per record; NaN for a record without a peak there."""
    t, z = np.asarray(times, dtype=float), np.asarray(z, dtype=float)
    n = t.size
    tu = np.linspace(t[0], t[-1], n)
    zu = np.interp(tu, t, z) - float(np.mean(z[n // 2:]))
    d = tu[1] - tu[0]
    nfft = 16 * int(2 ** math.ceil(math.log2(n)))
    spec = np.abs(np.fft.rfft(zu, nfft))
    freq = np.fft.rfftfreq(nfft, d)
    ok = freq > 1.0 / (t[-1] - t[0])
    if ok.sum() < 3:
        return math.nan
    i = int(np.argmax(np.where(ok, spec, -1.0)))
    if i <= 0 or i >= spec.size - 1 or not ok[i - 1]:
        return math.nan
    a, b, c = spec[i - 1], spec[i], spec[i + 1]
    den = a - 2 * b + c
    shift = 0.5 * (a - c) / den if den != 0 else 0.0
    return float(freq[i] + shift * (freq[1] - freq[0]))


def _decay_params(params) -> tuple:
    if isinstance(params, str):
        params = tuple(p.strip() for p in params.split(","))
    try:
        params = tuple(params)
    except TypeError:
        raise ValueError(f"params must be a sequence of names from {list(DECAY_PARAMETERS)}, got {params!r}.") \
            from None
    out = []
    for p in params:
        name = DECAY_ALIASES.get(p, p)
        if name not in DECAY_PARAMETERS:
            raise ValueError(f"unknown decay parameter {p!r}: fit any of {list(DECAY_PARAMETERS)} ('damping' is "
                             "'retardation_time').")
        out.append(name)
    if not out:
        raise ValueError(f"params must name at least one of {list(DECAY_PARAMETERS)}, got none.")
    if len(set(out)) != len(out):
        raise ValueError(f"params must not repeat a parameter, got {list(params)}.")
    return tuple(out)


def fit_decay(robot: Robot, times, tip_z, *, params=("retardation_time", "E0"), hold_field=None,
              gravity: float = 9.81, sigma: float | None = None, segments: int | None = None,
              timestep: float | None = None, max_simulations: int = 80, fd_step: float = DECAY_FD_STEP,
              match_frequency: bool = True) -> DynamicFitResult:
    """Fit the hinge damping and the modulus of ``robot`` to a free decay of its clamped strip.

    Protocol: the strip is clamped horizontally at its base (x along it, z up, the clamp at the origin) and
    released at ``t = 0``: from straight and at rest (held horizontal by a support that is pulled away;
    ``hold_field`` None), or from rest under a held field that is switched off at ``t = 0`` (``hold_field``
    ``(B_x, B_z)``, T: coils whose current falls in a few ms, fast against the ringing). The tip's height is
    tracked (camera, laser) at ``times`` measured from the release. The forward model is the planar MuJoCo chain
    (:func:`simulate_decay`) at the robot's numerics.

    The fit: if ``E0`` is fitted and ``match_frequency``, the modulus is first moved until the simulated
    ringing frequency (:func:`ringing_frequency`, the spectrum's peak) matches the measured one (secant steps in
    log-log, at most 4 simulations; the lowest misfit seen is kept as the start), then Levenberg-Marquardt
    (``scipy.optimize.least_squares``) minimizes the tip misfits over the whole trajectory, in the logarithm of
    the parameters, on a Jacobian of central differences (step ``fd_step`` in the logarithm: 2 simulations per
    parameter). Uncertainties: ``covariance = s^2 (J^T J)^-1``, ``s`` the given
    ``sigma`` or the residual's.

    Parameters
    ----------
    robot : Robot
        The starting guess; its beam, numerics and every parameter not fitted are kept.
    times, tip_z : (n,) array
        Times (s, from the release, increasing, >= 0) and the tip height (m) at each; n >= 8.
    params : sequence of str
        ``retardation_time`` (alias ``damping``; s) and/or ``E0`` (Pa).
    hold_field : (B_x, B_z) or None
        The field (T) the strip was held in before it was switched off; None: released from straight.
    gravity : float
        m/s^2 along -z, in [0, 1000].
    sigma : float, optional
        The tip-height noise (m, 1 sigma) if known.
    segments, timestep : optional
        Numerics (default: the robot's own).
    max_simulations : int
        Most simulations in all (in [5, 1000]); the fit stops there (``success`` False) and reports where it was.
    fd_step : float
        Finite-difference step in the logarithm of each parameter, in [1e-5, 0.1].

    Returns
    -------
    DynamicFitResult
    """
    t_start = _time.perf_counter()
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a magsoft_env.Robot (see load_robot), got {type(robot).__name__}.")
    params = _decay_params(params)
    times = finite_array("times", times, ndim=1, min_len=8)
    tip_z = finite_array("tip_z", tip_z, ndim=1)
    if tip_z.shape != times.shape:
        raise ValueError(f"tip_z must have one height per time: expected shape {times.shape}, got {tip_z.shape}.")
    if times.size > MAX_DECAY_SAMPLES:
        raise ValueError(f"times must hold at most {MAX_DECAY_SAMPLES} samples, got {times.size}.")
    if times[0] < 0.0 or np.any(np.diff(times) <= 0.0):
        raise ValueError("times must be increasing and >= 0 s (measured from the release), got "
                         f"first {times[0]:g} s and {int(np.sum(np.diff(times) <= 0))} non-increasing step(s).")
    if times[-1] > MAX_DECAY_TIME:
        raise ValueError(f"times must end within {MAX_DECAY_TIME:g} s of the release, got {times[-1]:g} s "
                         "(seconds: 500 ms is 0.5).")
    L = robot.beam.length
    if np.max(np.abs(tip_z)) > MAX_TIP_LENGTHS * L:
        raise ValueError(f"tip_z must lie within {MAX_TIP_LENGTHS:g} beam lengths ({MAX_TIP_LENGTHS * L:g} m) of the "
                         f"clamp, got {np.max(np.abs(tip_z)):g} m (metres: 5 mm is 0.005).")
    if hold_field is not None:
        fld = as_field(hold_field, "hold_field")
        if not fld.is_planar:
            raise ValueError(f"hold_field must lie in the x-z plane (the planar chain), got B_y = {fld.By:g} T.")
        hold_field = (fld.Bx, fld.Bz)
    gravity = in_range("gravity", gravity, 0.0, 1000.0, unit="m/s^2")
    if sigma is not None:
        sigma = positive("sigma", sigma, unit="m")
    max_simulations = integer("max_simulations", max_simulations, 5, 1000)
    fd_step = in_range("fd_step", fd_step, 1e-5, 0.1)
    if not isinstance(match_frequency, bool):
        raise ValueError(f"match_frequency must be True or False, got {match_frequency!r}.")
    seg = robot.segments if segments is None else integer("segments", segments, 2, 1000)
    dt = robot.timestep if timestep is None else in_range("timestep", timestep, 1e-6, 1e-2, unit="s")
    if times[-1] / dt > MAX_STEPS:
        raise ValueError(f"times end at {times[-1]:g} s: {times[-1] / dt:.3g} steps of {dt:g} s, more than "
                         f"{MAX_STEPS}. Use a shorter record or a larger timestep.")
    start = {"retardation_time": robot.retardation_time, "E0": float(robot.beam.material.E0)}
    for p in params:
        if not start[p] > 0.0:
            raise ValueError(f"{p} must start from a positive value (the fit works in its logarithm), got "
                             f"{start[p]!r}: give the robot a guess, e.g. robot.replace(retardation_time=5e-3).")
    if times.size < len(params) + 1:
        raise ValueError(f"{len(params)} parameters need more than {len(params)} samples, got {times.size}.")

    fixed = {p: v for p, v in start.items() if p not in params}
    count = [0]
    best = {"cost": math.inf, "u": None}

    def simulate(u):
        if count[0] >= max_simulations:
            raise _Budget
        count[0] += 1
        vals = {**fixed, **{p: math.exp(v) for p, v in zip(params, u, strict=True)}}
        r = _with_values(robot, vals)
        try:
            return simulate_decay(r, times, hold_field=hold_field, gravity=gravity, segments=seg, timestep=dt)
        except (SimulationError, ValueError):
            return None

    cache: dict = {}

    def fun(u):
        key = tuple(np.round(u, 14))
        if key not in cache:
            z = simulate(u)
            res = np.full(times.size, FAILED_RESIDUAL) if z is None else z - tip_z
            cache[key] = res
            cost = float(res @ res)
            if z is not None and cost < best["cost"]:
                best.update(cost=cost, u=np.array(u, dtype=float))
        return cache[key]

    def jac(u):
        J = np.empty((times.size, len(params)))
        for i in range(len(params)):
            up, um = np.array(u, dtype=float), np.array(u, dtype=float)
            up[i] += fd_step
            um[i] -= fd_step
            zp, zm = simulate(up), simulate(um)
            if zp is None or zm is None:
                J[:, i] = 0.0
            else:
                J[:, i] = (zp - zm) / (2.0 * fd_step)
        return J

    u0 = np.array([math.log(start[p]) for p in params])
    details: dict = {"f_measured_Hz": ringing_frequency(times, tip_z), "protocol":
                     "straight release" if hold_field is None else f"field {hold_field} T switched off",
                     "fd_step_log": fd_step, "segments": seg, "timestep": dt}
    message = ""
    stopped = False
    try:
        r0 = fun(u0)
        if np.all(r0 == FAILED_RESIDUAL):
            raise ValueError("the strip's release is unstable at the starting parameters: start nearer the truth, "
                             "or give finer numerics (timestep).")
        f_meas = details["f_measured_Hz"]
        if "E0" in params and match_frequency and math.isfinite(f_meas):
            iE = params.index("E0")
            u = u0.copy()
            z = r0 + tip_z
            hist = []
            for _ in range(4):
                f_sim = ringing_frequency(times, z)
                if not math.isfinite(f_sim):
                    break
                hist.append((u[iE], math.log(f_sim)))
                if abs(math.log(f_meas / f_sim)) < 0.005:
                    break
                slope = 0.5  # f ~ sqrt(E0) for an elastic strip; measured once two points exist
                if len(hist) >= 2 and hist[-1][0] != hist[-2][0]:
                    s = (hist[-1][1] - hist[-2][1]) / (hist[-1][0] - hist[-2][0])
                    slope = min(max(s, 0.1), 1.0)
                u = u.copy()
                u[iE] += float(np.clip(math.log(f_meas / f_sim) / slope, -math.log(4.0), math.log(4.0)))
                z = fun(u) + tip_z
            details["f_start_Hz"] = [math.exp(h[1]) for h in hist]
            if best["u"] is not None:
                u0 = best["u"]
        nfev = max(1, (max_simulations - count[0]) // (1 + 2 * len(params)))
        sol = scipy.optimize.least_squares(fun, u0, jac=jac, method="lm", xtol=1e-8, ftol=1e-10, gtol=1e-10,
                                           max_nfev=nfev)
        message = sol.message
        success = bool(sol.success)
    except _Budget:
        stopped, success = True, False
        message = f"stopped at the budget of {max_simulations} simulations; the best point so far is reported."
    if best["u"] is None:
        raise ValueError("no simulation of the release succeeded: start nearer the truth, or give finer numerics.")
    u_best = best["u"]
    res = fun(u_best)
    # the Jacobian at the optimum, for the uncertainties (2 k more simulations, past the budget if need be)
    count_limit = max_simulations
    max_simulations = count[0] + 2 * len(params)
    J = jac(u_best)
    max_simulations = count_limit
    vals = {p: math.exp(v) for p, v in zip(params, u_best, strict=True)}
    Jp = J / np.array([vals[p] for p in params])[None, :]  # d z / d p = (d z / d log p) / p
    dof = max(times.size - len(params), 1)
    s2 = sigma**2 if sigma is not None else float(res @ res) / dof
    try:
        cov = s2 * np.linalg.inv(Jp.T @ Jp)
    except np.linalg.LinAlgError:
        cov = np.full((len(params), len(params)), np.nan)
    sd = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    z_fit = res + tip_z
    details["f_fitted_Hz"] = ringing_frequency(times, z_fit)
    if stopped:
        success = False
    return DynamicFitResult(success=success, message=str(message),
                            robot=_with_values(robot, vals), residual=res, rms=float(math.sqrt(res @ res / res.size)),
                            residual_sigma=float(math.sqrt(s2)), simulations=count[0],
                            wall_time=_time.perf_counter() - t_start, details=details,
                            **_record(params, vals, sd, cov))


# ---------------------------------------------------------------------------------------------- crawl speed
def simulate_speed(robot: Robot, friction: float, drive: Waveparams | None = None, *, seconds: float = 3.0,
                   warmup_cycles: float = 1.0, segments: int | None = None, timestep: float | None = None,
                   fidelity: str | None = None) -> float:
    """The mean crawl speed (m/s, signed along +x) of ``robot`` driven by ``drive`` (default its own) on a floor of
    friction ``friction``: :func:`~magsoft_env.sim.gait.run_gait`'s speed (whole periods after ``warmup_cycles``);
    NaN when the run failed or the body tumbled."""
    r = robot.replace(friction=friction, **({} if drive is None else {"drive": drive}))
    g = run_gait(r, seconds, segments=segments, timestep=timestep, fidelity=fidelity, warmup_cycles=warmup_cycles)
    return float(g.speed) if g.success else math.nan


def _sequence(name: str, value, unit: str) -> np.ndarray:
    if isinstance(value, (int, float, np.floating, np.integer)) and not isinstance(value, (bool, np.bool_)):
        value = [value]
    a = finite_array(name, value, ndim=1, min_len=1)
    return a


def fit_friction(robot: Robot, measured_speed, *, speed_sigma=None, drives=None, seconds: float = 3.0,
                 warmup_cycles: float = 1.0, bracket=(0.1, 1.5), sweep_points: int = 7,
                 segments: int | None = None, timestep: float | None = None, fidelity: str | None = None,
                 max_simulations: int = 60) -> DynamicFitResult:
    """Fit the floor friction coefficient of ``robot`` to measured mean crawl speeds of its open-loop gait.

    Protocol: the robot crawls on the floor under its drive (or each of ``drives``) from lying straight at rest;
    its mean centre-of-mass speed along +x is measured over whole field periods after ``warmup_cycles`` (as
    :func:`~magsoft_env.sim.gait.run_gait` measures it) for ``seconds``: measure the robot the same way.

    The fit: a sweep of ``sweep_points`` frictions evenly over ``bracket`` (every drive), which shows whether the
    speed is monotonic there (``details["monotonic"]``). The simulated speed is rough in friction at the scale of a
    few per cent (a short run's contact events shift with it: paper-5a at 20 segments, 0.2 ms, 2 s reads 0.4691,
    0.4603, 0.4597 mm/s at 0.50, 0.52, 0.55 and turns over below 0.38), so neither a root of the raw simulations
    nor a finite-difference slope is reliable: the sweep is smoothed by a polynomial of degree
    :data:`SURROGATE_DEGREE` in the friction per drive, its scatter about it (``details["roughness"]``, m/s) is
    counted as model noise, and the fit inverts the polynomial: one speed, its root in the bracket (where it has
    several, the speed is not monotonic there: the root nearest the robot's own friction is kept and the message
    says so; narrow the bracket); several speeds, the least squares over the bracket, each weighted by
    ``1 / sqrt(speed_sigma^2 + roughness^2)``. ``sigma_mu = (sum slope_i^2 / (speed_sigma_i^2 +
    roughness_i^2))^-1/2`` with the polynomial's slope; without ``speed_sigma``, several speeds use the residual's
    scatter where it is larger. One more simulation per drive at the fit reports the simulated speed there
    (``details["speed_simulated_at_fit"]``).

    Parameters
    ----------
    robot : Robot
        The robot with its drive; its friction is the prior that picks a root where several exist.
    measured_speed : float or sequence
        Mean speed(s) (m/s, signed along +x), one per drive.
    speed_sigma : float or sequence, optional
        Their 1-sigma uncertainties (m/s).
    drives : sequence of Waveparams, optional
        The drive of each measured speed (default: the robot's own, for one speed).
    seconds, warmup_cycles : float
        The run (s) and the periods left out of the speed, as measured.
    bracket : (low, high)
        Friction range searched, within [0, 10].
    sweep_points : int
        Frictions in the sweep, in [3, 50]; at least 5 to see the roughness about a quadratic.
    segments, timestep, fidelity : optional
        Numerics (default: the robot's own; :func:`~magsoft_env.sim.gait.run_gait`).
    max_simulations : int
        Most gait simulations in all, in [5, 2000]; must cover the sweep (sweep_points x drives) plus the check at
        the fit (1 x drives). The fit runs exactly that many.

    Returns
    -------
    DynamicFitResult
        ``values["friction"]``; ``details`` holds the sweep and the slopes.
    """
    t_start = _time.perf_counter()
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a magsoft_env.Robot (see load_robot), got {type(robot).__name__}.")
    v_meas = _sequence("measured_speed", measured_speed, "m/s")
    n = v_meas.size
    if n > MAX_DRIVES:
        raise ValueError(f"measured_speed must hold 1 to {MAX_DRIVES} speeds, got {n}.")
    if np.max(np.abs(v_meas)) > MAX_SPEED:
        raise ValueError(f"measured_speed must lie within +-{MAX_SPEED:g} m/s, got {np.max(np.abs(v_meas)):g} m/s "
                         "(metres per second: 0.5 mm/s is 0.0005).")
    if drives is None:
        if n != 1:
            raise ValueError(f"{n} measured speeds need drives: one Waveparams per speed, got none.")
        drives = (robot.wave,)
    else:
        if isinstance(drives, Waveparams):
            drives = (drives,)
        drives = tuple(drives)
        if len(drives) != n:
            raise ValueError(f"drives must hold one Waveparams per measured speed: expected {n}, got {len(drives)}.")
        for i, d in enumerate(drives):
            if not isinstance(d, Waveparams):
                raise ValueError(f"drives[{i}] must be a magsoft_env.Waveparams, got {type(d).__name__}.")
    sig = None
    if speed_sigma is not None:
        sig = _sequence("speed_sigma", speed_sigma, "m/s")
        if sig.size == 1:
            sig = np.full(n, sig[0])
        if sig.size != n or np.any(sig <= 0.0):
            raise ValueError(f"speed_sigma must be one positive number or {n} (one per speed) in m/s, got "
                             f"{speed_sigma!r}.")
    seconds = positive("seconds", seconds, unit="s")
    warmup_cycles = in_range("warmup_cycles", warmup_cycles, 0.0, 1e3)
    if (not isinstance(bracket, (tuple, list)) or len(bracket) != 2):
        raise ValueError(f"bracket must be (low, high) frictions in [0, {MAX_FRICTION:g}], got {bracket!r}.")
    lo = in_range("bracket low", bracket[0], 0.0, MAX_FRICTION)
    hi = in_range("bracket high", bracket[1], 0.0, MAX_FRICTION)
    if not hi > lo:
        raise ValueError(f"bracket must be (low, high) with low < high, got {bracket!r}.")
    sweep_points = integer("sweep_points", sweep_points, 3, 50)
    max_simulations = integer("max_simulations", max_simulations, 5, 2000)
    need = (sweep_points + 1) * n
    if max_simulations < need:
        raise ValueError(f"max_simulations must cover the sweep ({sweep_points} x {n} drive(s)) and the check at the "
                         f"fit ({n}): >= {need}, got {max_simulations}.")
    for d in drives:
        if not seconds * d.frequency > warmup_cycles + 1.0 - 1e-9:
            raise ValueError(f"seconds must cover the warm-up ({warmup_cycles:g} periods) and one whole period of "
                             f"the drive at {d.frequency:g} Hz: >= {(warmup_cycles + 1) / d.frequency:g} s, got "
                             f"{seconds:g} s.")
    # numerics checked before any simulation (run_gait resolves them the same way)
    from ..cases.gaits import numerics

    numerics(robot, fidelity=fidelity, segments=segments, timestep=timestep)

    count = [0]

    def speeds(mu: float) -> np.ndarray:
        if count[0] + n > max_simulations:
            raise _Budget
        count[0] += n
        return np.array([simulate_speed(robot, mu, d, seconds=seconds, warmup_cycles=warmup_cycles,
                                        segments=segments, timestep=timestep, fidelity=fidelity) for d in drives])

    grid = np.linspace(lo, hi, sweep_points)
    sweep = np.array([speeds(float(mu)) for mu in grid])  # (points, n)
    ok = np.all(np.isfinite(sweep), axis=1)
    if ok.sum() < 2:
        raise ValueError(f"the gait failed or tumbled at {int((~ok).sum())} of {sweep_points} frictions in "
                         f"[{lo:g}, {hi:g}]: narrow the bracket or check the numerics.")
    diffs = np.diff(sweep[ok], axis=0)
    monotonic = [bool(np.all(diffs[:, j] > 0) or np.all(diffs[:, j] < 0)) for j in range(n)]
    details = {"sweep_friction": grid, "sweep_speed": sweep, "monotonic": monotonic, "seconds": seconds}
    notes = []
    if not all(monotonic):
        notes.append("the simulated speed is not monotonic in friction over the bracket "
                     f"[{lo:g}, {hi:g}] (sweep: {np.round(sweep[:, 0] * 1e3, 4).tolist()} mm/s)")
    g_grid, mu_ok = sweep[ok], grid[ok]
    # the simulated speed is rough in friction at the scale of a few per cent (the contact events of a short run
    # shift with it), so the fit inverts a smooth surrogate of the sweep, a polynomial of degree SURROGATE_DEGREE in
    # the friction per drive, and counts the sweep's scatter about it as model noise
    deg = min(SURROGATE_DEGREE, mu_ok.size - 2) if mu_ok.size > 2 else 1
    coef = [np.polyfit(mu_ok, g_grid[:, j], deg) for j in range(n)]
    rough = np.array([math.sqrt(float(np.sum((np.polyval(c, mu_ok) - g_grid[:, j]) ** 2))
                                / max(mu_ok.size - deg - 1, 1)) for j, c in enumerate(coef)])
    dense = np.linspace(lo, hi, 2001)
    smooth = np.array([np.polyval(c, dense) for c in coef]).T  # (2001, n)
    dsmooth = np.array([np.polyval(np.polyder(c), dense) for c in coef]).T
    details.update(surrogate_degree=deg, roughness=rough)
    for j in range(n):
        if not (np.all(dsmooth[:, j] > 0) or np.all(dsmooth[:, j] < 0)):
            notes.append(f"the smoothed speed of drive {j} turns over within the bracket (not monotonic)")
    eff = np.sqrt((sig if sig is not None else np.zeros(n)) ** 2 + rough**2)
    w = 1.0 / np.where(eff > 0, eff, 1.0)
    if n == 1:
        g = smooth[:, 0] - v_meas[0]
        idx = np.nonzero(np.sign(g[:-1]) * np.sign(g[1:]) <= 0)[0]
        if idx.size == 0:
            vmin, vmax = g_grid[:, 0].min() * 1e3, g_grid[:, 0].max() * 1e3
            raise ValueError(f"measured_speed {v_meas[0] * 1e3:g} mm/s is outside the simulated speeds "
                             f"{vmin:.4g} to {vmax:.4g} mm/s over frictions [{lo:g}, {hi:g}] ({count[0]} "
                             "simulations): no friction in the bracket gives it; widen the bracket or check the "
                             "other parameters (damping, contact) and numerics.")
        roots = []
        for i in idx:  # linear interpolation between the dense points, then the root of the polynomial itself
            a, b = dense[i], dense[i + 1]
            m = a if g[i] == g[i + 1] else a - g[i] * (b - a) / (g[i + 1] - g[i])
            roots.append(float(m))
        roots = sorted(set(round(r, 12) for r in roots))
        mu = min(roots, key=lambda r: abs(r - robot.friction))
        if len(roots) > 1:
            notes.append(f"{len(roots)} frictions give the measured speed on the smoothed sweep: "
                         + ", ".join(f"{r:.4g}" for r in roots)
                         + f"; kept {mu:.4g} (nearest the robot's friction {robot.friction:g}): narrow the bracket "
                         "to choose")
    else:
        chi = np.sum(((smooth - v_meas[None, :]) * w[None, :]) ** 2, axis=1)
        mu = float(dense[int(np.argmin(chi))])
    success = True
    slope = np.array([np.polyval(np.polyder(c), mu) for c in coef])
    v_fit = np.array([np.polyval(c, mu) for c in coef])
    # one simulation per drive at the fit, to report how far the simulated speed there is from the surrogate
    try:
        v_check = speeds(mu)
    except _Budget:
        v_check = np.full(n, math.nan)
    res = v_fit - v_meas
    details.update(slope=slope, speed_fit=v_fit, speed_simulated_at_fit=v_check)
    info = float(np.sum((slope * w) ** 2))
    if sig is not None or n > 1 or rough[0] > 0:
        s_res = float(np.sqrt(np.mean(eff**2)))
        if sig is None and n > 1:  # the residual's scatter, where it is larger than the surrogate's
            s2 = float(res @ res) / (n - 1)
            scale = max(1.0, s2 / max(float(np.mean(eff**2)), 1e-300))
            s_res *= math.sqrt(scale)
            info /= scale
        var = 1.0 / info if info > 0 else math.inf
    else:
        s_res, var = math.nan, math.nan
    if sig is None and n == 1:
        notes.append("one speed without speed_sigma: the uncertainty counts only the sweep's roughness (give "
                     "speed_sigma)")
    if not np.all(np.isfinite(slope)) or not np.any(slope != 0):
        notes.append("the slope d speed / d friction is zero or undefined at the fit: the friction is not identified")
        success = False
    sd = np.array([math.sqrt(var) if math.isfinite(var) else math.nan])
    cov = np.array([[var]])
    vals = {"friction": mu}
    msg = "converged" if success else "not converged"
    if notes:
        msg += "; " + "; ".join(notes)
    return DynamicFitResult(success=success, message=msg + ".", robot=robot.replace(friction=mu), residual=res,
                            rms=float(math.sqrt(res @ res / n)), residual_sigma=s_res, simulations=count[0],
                            wall_time=_time.perf_counter() - t_start, details=details,
                            **_record(("friction",), vals, sd, cov))


__all__ = ["DECAY_FD_STEP", "DECAY_PARAMETERS", "SURROGATE_DEGREE", "DynamicFitResult", "ringing_frequency",
           "fit_decay", "fit_friction", "simulate_decay", "simulate_speed"]

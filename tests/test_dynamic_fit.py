"""Fits to dynamic data through the MuJoCo rods (magsoft_env.compare.dynamic_fit): synthetic round trips and
refusals. Decay: paper-5c's strip at coarse numerics (10 segments, 0.5 ms), 1.5 s records at 200 Hz. Crawl:
paper-5a at the "fast" numerics (20 segments, 0.2 ms), 2 s runs."""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.compare import dynamic_fit as dfit

E0_TRUE, RT_TRUE = 75e3, 7e-3  # the "true" strip: 21 % stiffer and 40 % more damped than the robot file's
NOISE_Z = 0.05e-3  # m, 1 sigma, white


def _decay_robot():
    return ms.load_robot("paper-5c").replace(segments=10, timestep=5e-4)


def _with_e0(robot, e0):
    return robot.replace(beam=dataclasses.replace(robot.beam, material=dataclasses.replace(robot.beam.material,
                                                                                          E0=e0)))


@pytest.mark.parametrize("hold", [None, (0.0, 3e-3)], ids=["straight", "field-off"])
def test_decay_round_trip(hold):
    guess = _decay_robot()  # E0 62 kPa, retardation 5 ms
    truth = _with_e0(guess, E0_TRUE).replace(retardation_time=RT_TRUE)
    t = np.arange(0.0, 1.5, 0.005)
    z = dfit.simulate_decay(truth, t, hold_field=hold)
    z_meas = z + np.random.default_rng(1).normal(0.0, NOISE_Z, t.size)
    res = ms.fit_decay(guess, t, z_meas, params=("damping", "E0"), hold_field=hold)
    assert res.success, res.message
    assert res.params == ("retardation_time", "E0")
    for p, true in (("E0", E0_TRUE), ("retardation_time", RT_TRUE)):
        assert res.values[p] == pytest.approx(true, rel=0.01)  # measured: 0.02-0.05 % and 0.1 %
        assert 0 < res.sigma[p] < 0.01 * true
        assert abs(res.values[p] - true) < 4 * res.sigma[p]
        lo, hi = res.interval95[p]
        assert lo < res.values[p] < hi
    assert res.residual_sigma == pytest.approx(NOISE_Z, rel=0.2)
    assert res.simulations <= 80 + 4
    assert res.robot.retardation_time == res.values["retardation_time"]
    assert res.robot.beam.material.E0 == res.values["E0"]
    assert abs(res.correlation[0, 1]) < 0.9


def test_decay_budget_stops_and_reports():
    guess = _decay_robot()
    t = np.arange(0.0, 1.0, 0.005)
    z = dfit.simulate_decay(_with_e0(guess, E0_TRUE), t)
    res = dfit.fit_decay(guess, t, z, params=("E0",), max_simulations=5)
    assert not res.success and "budget of 5" in res.message
    assert res.simulations <= 5 + 2  # the budget, then the Jacobian for the uncertainty
    assert res.values["E0"] == pytest.approx(E0_TRUE, rel=0.2)


def _counting_speed(monkeypatch):
    """simulate_speed cached (the simulations are deterministic), counting the real runs."""
    calls = []
    real = dfit.simulate_speed

    @functools.cache
    def cached(robot, mu, drive, seconds, warmup_cycles):
        calls.append(mu)
        return real(robot, mu, drive, seconds=seconds, warmup_cycles=warmup_cycles)

    def fake(robot, mu, drive=None, *, seconds=3.0, warmup_cycles=1.0, segments=None, timestep=None, fidelity=None):
        assert segments is None and timestep is None and fidelity is None
        return cached(robot, float(mu), drive, seconds, warmup_cycles)

    monkeypatch.setattr(dfit, "simulate_speed", fake)
    return calls


def _friction_case(monkeypatch, seeds, truth=0.55, noise=0.01):
    robot = ms.load_robot("paper-5a").replace(segments=20, timestep=2e-4)
    calls = _counting_speed(monkeypatch)
    v = dfit.simulate_speed(robot, truth, seconds=2.0)
    out = []
    for seed in seeds:
        vm = v * (1.0 + noise * np.random.default_rng(seed).normal())
        res = ms.fit_friction(robot, vm, speed_sigma=noise * abs(v), seconds=2.0, bracket=(0.4, 0.8),
                              sweep_points=9)
        assert res.success, res.message
        assert res.params == ("friction",)
        assert res.robot.friction == res.values["friction"]
        assert res.simulations == 10  # 9 sweep points and the check at the fit
        assert 0 < res.sigma["friction"] < 0.1
        out.append(res)
    return out, calls


def test_friction_round_trip_within_its_uncertainty(monkeypatch):
    # paper-5a's crawl speed is a rough, step-like function of the friction at these numerics (a limit cycle: 2 s
    # and 4 s runs read the same speeds), 2.5 % about a quadratic; the fitted sigma counts it. Measured (seed 1,
    # 1 % noise): friction 0.516 +- 0.018 for 0.55 (-6.2 %, 1.9 sigma), 10 simulations, 10 s.
    (res,), _ = _friction_case(monkeypatch, [1])
    err = res.values["friction"] - 0.55
    assert abs(err) < 3 * res.sigma["friction"]
    assert abs(err) < 0.10 * 0.55
    assert res.details["roughness"][0] > 0


@pytest.mark.slow
def test_friction_within_5_percent_from_paper_5b_crawl_speeds(monkeypatch):
    """The fitting check on a robot whose crawl speed moves smoothly with friction: paper-5b at its own numerics,
    3 s runs, -1.30 to -0.51 mm/s over friction 0.3-0.8 (monotonic). Three noisy measurements (1 %) of the speed at
    a true friction of 0.55 (measured +2.2 % and +1.7 % for two of them). paper-5a's speed is step-like in friction
    at the 'fast' numerics (-6.2 %: the test above), which is why this one uses 5b."""
    robot = ms.load_robot("paper-5b")
    _counting_speed(monkeypatch)
    v = dfit.simulate_speed(robot, 0.55, seconds=3.0)
    for seed in (0, 1, 2):
        vm = v * (1.0 + 0.01 * np.random.default_rng(seed).normal())
        res = ms.fit_friction(robot, vm, speed_sigma=0.01 * abs(v), seconds=3.0, bracket=(0.3, 0.8), sweep_points=9)
        assert res.success, res.message
        assert abs(res.values["friction"] / 0.55 - 1.0) < 0.05, (seed, res.values)


def test_friction_several_drives_and_unreachable_speed(monkeypatch):
    robot = ms.load_robot("paper-5a").replace(segments=20, timestep=2e-4)
    _counting_speed(monkeypatch)
    drives = (robot.drive, dataclasses.replace(robot.drive, frequency=3.0))
    v = [dfit.simulate_speed(robot, 0.55, d, seconds=2.0) for d in drives]
    res = ms.fit_friction(robot, v, drives=drives, seconds=2.0, bracket=(0.4, 0.8), sweep_points=5)
    # measured: 0.516 for 0.55 (-6.3 %): the same roughness as one drive (both drives' speeds sit above the trend)
    assert res.values["friction"] == pytest.approx(0.55, rel=0.10)
    assert abs(res.values["friction"] - 0.55) < 3 * res.sigma["friction"]
    assert res.simulations == 12
    with pytest.raises(ValueError, match="outside the simulated speeds"):
        ms.fit_friction(robot, 5e-3, seconds=2.0, bracket=(0.4, 0.8), sweep_points=5)


def _no_simulation(monkeypatch):
    def boom(*a, **k):
        raise AssertionError("simulated before the input was checked")

    monkeypatch.setattr(dfit, "simulate_decay", boom)
    monkeypatch.setattr(dfit, "run_gait", boom)
    monkeypatch.setattr(dfit, "Simulator", boom)


T = np.linspace(0.0, 1.0, 50)
Z = -0.01 * np.ones(50)


@pytest.mark.parametrize("kwargs, match", [
    (dict(robot="paper-5c"), "robot must be a magsoft_env.Robot"),
    (dict(params=("E0", "friction")), "unknown decay parameter 'friction'"),
    (dict(params=()), "at least one"),
    (dict(params=("E0", "E0")), "must not repeat"),
    (dict(times=T[:5], tip_z=Z[:5]), "at least 8"),
    (dict(tip_z=Z[:40]), "one height per time"),
    (dict(times=T[::-1].copy()), "increasing"),
    (dict(times=T - 0.5), "increasing and >= 0"),
    (dict(times=T * 100), "within 60 s"),
    (dict(tip_z=Z * 1e3), "beam lengths"),
    (dict(tip_z=np.where(T > 0.5, np.nan, Z)), "finite"),
    (dict(hold_field=(0.0, 2e-3, 1e-3)), "x-z plane"),
    (dict(hold_field=(0.0, 5.0)), "hold_field"),
    (dict(gravity=-1.0), "gravity"),
    (dict(sigma=0.0), "sigma"),
    (dict(max_simulations=2), "max_simulations"),
    (dict(fd_step=0.5), "fd_step"),
    (dict(timestep=0.5), "timestep"),
    (dict(robot_rt=0.0), "retardation_time must start from a positive value"),
])
def test_decay_refusals(monkeypatch, kwargs, match):
    _no_simulation(monkeypatch)
    kw = dict(kwargs)
    robot = _decay_robot()
    if "robot_rt" in kw:
        robot = robot.replace(retardation_time=kw.pop("robot_rt"))
    robot = kw.pop("robot", robot)
    times, tip_z = kw.pop("times", T), kw.pop("tip_z", Z)
    with pytest.raises(ValueError, match=match):
        dfit.fit_decay(robot, times, tip_z, **kw)


@pytest.mark.parametrize("kwargs, match", [
    (dict(robot="paper-5a"), "robot must be a magsoft_env.Robot"),
    (dict(measured_speed=0.5), r"within \+-0.1 m/s"),
    (dict(measured_speed=[]), "at least 1"),
    (dict(measured_speed=math.nan), "finite"),
    (dict(measured_speed=[1e-4, 2e-4]), "need drives"),
    (dict(measured_speed=[1e-4, 2e-4], drives=["sine"]), "one Waveparams per measured speed"),
    (dict(measured_speed=[1e-4, 2e-4], drives=["a", "b"]), r"drives\[0\] must be"),
    (dict(speed_sigma=-1e-5), "speed_sigma must be one positive"),
    (dict(speed_sigma=[1e-5, 1e-5]), "speed_sigma must be one positive"),
    (dict(bracket=(0.8, 0.4)), "low < high"),
    (dict(bracket=(0.1, 20.0)), "bracket high"),
    (dict(bracket=0.5), r"\(low, high\)"),
    (dict(sweep_points=2), "sweep_points"),
    (dict(max_simulations=5, sweep_points=7), "max_simulations must cover"),
    (dict(seconds=0.6), "seconds must cover the warm-up"),
    (dict(seconds=-1.0), "seconds"),
    (dict(fidelity="coarse"), "fidelity"),
    (dict(robot_nodrive=True), "has no drive"),
])
def test_friction_refusals(monkeypatch, kwargs, match):
    _no_simulation(monkeypatch)
    kw = dict(kwargs)
    robot = ms.load_robot("paper-5a")
    if kw.pop("robot_nodrive", False):
        robot = robot.replace(drive=None)
    robot = kw.pop("robot", robot)
    v = kw.pop("measured_speed", 4e-4)
    with pytest.raises(ValueError, match=match):
        dfit.fit_friction(robot, v, **kw)

"""The simulator never lies (issue 12): bad input refused, work bounded, unphysical runs reported."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from magsoft_env import Beam
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.envs import register_all
from magsoft_env.sim import RodOptions, SimulationError, Simulator, Sine, mujoco_equilibrium, mujoco_path
from magsoft_env.sim.gait import run_gait
from magsoft_env.sim.health import MAX_STEPS, PENETRATION_LIMIT, UnphysicalError

register_all()

H = 1.13e-3


@pytest.fixture(scope="module")
def beam():
    return Beam(length=25e-3, width=5e-3, thickness=H, volume_fraction=0.2)


def _make(env_id, **kwargs):
    return gym.make(env_id, disable_env_checker=True, **kwargs)


# ---------------------------------------------------------------- every option, with its type
@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"segments": 20.5}, "segments"),
        ({"segments": True}, "segments"),
        ({"segments": 1001}, "segments"),
        ({"timestep": "1e-3"}, "timestep"),
        ({"timestep": 0.5}, "timestep"),
        ({"timestep": math.nan}, "timestep"),
        ({"gravity": 1e4}, "gravity"),
        ({"gravity": "9.81"}, "gravity"),
        ({"clamp_angle": math.inf}, "clamp_angle"),
        ({"scene": 3}, "scene"),
        ({"integrator": "rk5"}, "integrator"),
        ({"render": "yes"}, "render"),
        ({"contact_pairs": 1}, "contact_pairs"),
        ({"contact_timeconst": "soft"}, "contact_timeconst"),
        ({"contact_timeconst": -1e-3}, "contact_timeconst"),
        ({"solver_iterations": 2.5}, "solver_iterations"),
        ({"solver_iterations": 10**9}, "solver_iterations"),
        ({"noslip_iterations": 10**9}, "noslip_iterations"),
        ({"feature_x": "0.03"}, "feature_x"),
        ({"contact_impedance": (True, 0.95)}, "contact_impedance"),
    ],
)
def test_rod_options_check_type_and_range(kwargs, name):
    with pytest.raises(ValueError, match=f"RodOptions.{name}"):
        RodOptions(**kwargs)


@pytest.mark.parametrize("kwargs, message", [
    ({"feature_x": 1e30}, r"RodOptions.feature_x must lie in \[-1, 1\] m, got 1e\+30"),
    ({"feature_x": -20.0}, r"RodOptions.feature_x must lie in \[-1, 1\] m, got -20.0 \(metres"),
    ({"timestep": 1e-30}, r"RodOptions.timestep must lie in \[1e-06, 0.1\] s, got 1e-30"),
    ({"timestep": 0.5}, r"RodOptions.timestep must lie in \[1e-06, 0.1\] s, got 0.5"),
])
def test_rod_options_range_names_parameter_range_and_value(kwargs, message):
    with pytest.raises(ValueError, match=message):
        RodOptions(**kwargs)
    RodOptions(feature_x=-8.5e-3, timestep=1e-6)  # the ends of the ranges stay open to use


@pytest.mark.parametrize("value", [20, np.int64(20), 20.0, np.float64(20.0), 2.5, "20", True, math.nan, 10**9])
def test_one_integer_policy_for_rod_options_and_validate(value):
    """validate.integer and RodOptions accept and refuse the same values: integral floats (20.0) are integers."""
    from magsoft_env.validate import integer

    try:
        expected = integer("n", value, 2, 1000)
    except ValueError:
        with pytest.raises(ValueError, match=r"RodOptions.segments must be a positive integer|an integer"):
            RodOptions(segments=value)
        return
    opts = RodOptions(segments=value, solver_iterations=value, noslip_iterations=value)
    for name in ("segments", "solver_iterations", "noslip_iterations"):
        got = getattr(opts, name)
        assert got == expected and type(got) is int, name  # stored as a Python int


@pytest.mark.parametrize("n", [-5, "10", 2.7, True, None])
def test_step_count_must_be_a_non_negative_integer(beam, n):
    sim = Simulator(beam)
    with pytest.raises(ValueError, match=r"\bn must be a non-negative integer"):
        sim.step(n)
    assert sim.nstep == 0
    sim.step(np.int64(3))  # numpy integers are integers
    sim.step(0)
    assert sim.nstep == 3


def test_simulator_arguments_are_checked(beam):
    with pytest.raises(ValueError, match="beam must be a Beam"):
        Simulator("beam")
    with pytest.raises(ValueError, match="options must be a RodOptions"):
        Simulator(beam, {"scene": "floor"})
    with pytest.raises(ValueError, match="penetration_limit"):
        Simulator(beam, penetration_limit=0.0)
    with pytest.raises(ValueError, match="field"):
        Simulator(beam, field=(0.0, 5.0))
    sim = Simulator(beam)
    with pytest.raises(ValueError, match="start_time"):
        sim.set_waveform(Sine((0.0, 1e-3), 1.0), start_time="0")
    with pytest.raises(ValueError, match="record_every"):
        sim.run(Sine((0.0, 1e-3), 1.0), 0.01, record_every=2.0)


def test_equilibrium_arguments_are_checked(beam):
    with pytest.raises(ValueError, match="tol"):
        mujoco_equilibrium(beam, (0.0, 0.01), tol=-1.0)
    with pytest.raises(ValueError, match="max_time"):
        mujoco_equilibrium(beam, (0.0, 0.01), max_time="20")
    with pytest.raises(ValueError, match="timestep"):
        mujoco_path(beam, [(0.0, 0.01)], timestep=0.0)
    with pytest.raises(ValueError, match="integrator"):
        mujoco_path(beam, [(0.0, 0.01)], integrator="leapfrog")
    with pytest.raises(ValueError, match="beam must be a Beam"):
        mujoco_path(None, [(0.0, 0.01)])


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"sim_dt": 0.05}, r"sim_dt must be <= ctrl_dt \(0.02 s\), got 0.05"),
        ({"sim_dt": 0.5, "ctrl_dt": 1.0}, r"sim_dt must lie in \(0, 0.1\]"),
        ({"sim_dt": "2e-4"}, "sim_dt"),
        ({"ctrl_dt": -0.02}, "ctrl_dt"),
        ({"max_link_rotation": 4.0}, r"max_link_rotation must lie in \(0, pi\]"),
        ({"max_link_rotation": 0.0}, "max_link_rotation"),
        ({"field_limit": 0.5}, "field_limit"),
        ({"field_limit": "0.02"}, "field_limit"),
        ({"max_height": -1.0}, "max_height"),
        ({"target_direction": True}, "target_direction"),
        ({"frequency_range": ("1", "2")}, "frequency_range"),
        ({"frequency_range": (1.0, 2.0, 3.0)}, "frequency_range"),
        ({"segments": 1}, "segments"),
        ({"friction": -0.5}, "friction"),
    ],
)
def test_crawl_env_arguments_are_checked(kwargs, match):
    with pytest.raises(ValueError, match=match):
        _make("MagSoftCrawl-v1", **kwargs)


def test_waveform_env_period_must_hold_whole_steps():
    with pytest.raises(ValueError, match=r"frequency_range must lie within \[2e-06, 20\] Hz at sim_dt = 0.05 s"):
        _make("MagSoftCrawlWaveform-v1", sim_dt=0.05, frequency_range=(0.5, 40.0))


@pytest.mark.parametrize(
    "env_id, kwargs, match",
    [
        ("MagSoftChannel-v1", {"entrance_gap": -3e-3}, "entrance_gap must lie in"),
        ("MagSoftChannel-v1", {"entrance_gap": 2.0}, "entrance_gap must lie in"),
        ("MagSoftChannel-v1", {"entrance_gap": "2e-3"}, "entrance_gap"),
        ("MagSoftObstacle-v1", {"obstacle_gap": -2e-3}, "obstacle_gap must lie in"),
        ("MagSoftObstacle-v1", {"obstacle_gap": 0.2e-3}, r"obstacle_gap must lie in .*h/2"),
        ("MagSoftObstacle-v1", {"obstacle_gap": math.nan}, "obstacle_gap"),
        ("MagSoftChannel-v1", {"robot": "paper-5z"}, "robot"),
    ],
)
def test_feature_gaps_must_keep_the_feature_off_the_resting_beam(env_id, kwargs, match):
    with pytest.raises(ValueError, match=match):
        _make(env_id, **kwargs)


def test_obstacle_gap_of_half_the_thickness_starts_clear():
    env = _make("MagSoftObstacle-v1", obstacle_gap=0.5 * H + 1e-6)
    _, info = env.reset(seed=0)
    assert env.unwrapped.sim.initial_overlap == 0.0 and info["max_penetration"] == 0.0
    env.close()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"sim_dt": 0.1}, r"sim_dt must be <= ctrl_dt \(0.05 s\), got 0.1"),
        ({"sim_dt": 0.2, "ctrl_dt": 1.0}, "sim_dt must lie in"),
        ({"width": 8}, "width"),
        ({"height": 300.5}, "height"),
        ({"ctrl_dt": "0.05"}, "ctrl_dt"),
    ],
)
def test_shape_env_arguments_are_checked(kwargs, match):
    with pytest.raises(ValueError, match=match):
        _make("MagSoftShape-v0", **kwargs)


# ---------------------------------------------------------------- bounded work: refused up front
@pytest.mark.parametrize(
    "call, match",
    [
        (lambda b: mujoco_equilibrium(b, (0.0, 0.013), max_field_step=1e-30), "max_field_step"),
        (lambda b: mujoco_equilibrium(b, (0.0, 0.013), timestep=1e-30), "timestep"),
        (lambda b: mujoco_path(b, [(0.0, 0.013)], max_time=1e30), "max_time"),
        (lambda b: Simulator(b).step(10 * MAX_STEPS), "limit of 1e\\+07"),
        (lambda b: Simulator(b).settle(max_time=1e30), "max_time"),
        (lambda b: Simulator(b, RodOptions(timestep=1e-30)).settle(), r"RodOptions.timestep must lie in \[1e-06"),
        (lambda b: Simulator(b).run(Sine((0.0, 1e-3), 1.0), 1e30), "duration / timestep"),
        (lambda b: Simulator(b, RodOptions(scene="floor")).run((0.0, 0.0), 1e300), "duration"),
        (lambda b: _make("MagSoftCrawl-v1", sim_dt=1e-30), r"ctrl_dt / sim_dt"),
        (lambda b: _make("MagSoftCrawl-v1", ctrl_dt=1e30), r"ctrl_dt / sim_dt"),
        (lambda b: _make("MagSoftCrawlWaveform-v1", frequency_range=(1e-30, 1.0)), "frequency_range must lie within"),
        (lambda b: _make("MagSoftShape-v0", ctrl_dt=1e30), r"ctrl_dt / sim_dt"),
        (lambda b: _make("MagSoftShape-v0", sim_dt=1e-30), r"ctrl_dt / sim_dt"),
        (lambda b: run_gait(gait_preset("paper-5c"), seconds=1e30), "seconds / timestep"),
    ],
)
def test_absurd_settings_are_refused_before_any_work(beam, call, match):
    with pytest.raises(ValueError, match=match):
        call(beam)


def test_work_refusal_says_how_much_and_what_to_change(beam):
    with pytest.raises(ValueError) as err:
        mujoco_equilibrium(beam, (0.0, 0.013), max_field_step=1e-30)
    text = str(err.value)
    assert "settles" in text and "Use max_field_step >=" in text
    # the largest allowed step works: every current setting is far inside the bound
    eq = mujoco_equilibrium(beam, (0.0, 0.013), segments=6)
    assert eq.success


# ---------------------------------------------------------------- unphysical runs stop, with figures
def test_deep_floor_penetration_stops_the_simulator(beam):
    # 100 mT on the default (soft, 1 ms) floor drives the centreline 2.65 mm below the floor
    # within 2 ms; unchecked, it then throws the beam 0.16-0.37 m
    sim = Simulator(beam, RodOptions(scene="floor"))
    sim.set_waveform(Sine((0.1, 0.1), 5, phase=1))
    with pytest.raises(UnphysicalError, match="penetration into the floor") as info:
        sim.step(300)
    err = info.value
    assert isinstance(err, SimulationError) and err.cause == "penetration"
    assert err.step <= 3 and err.figures["penetration_h"] > PENETRATION_LIMIT
    assert f"{err.figures['penetration_m'] * 1e3:.3g} mm" in err.reason and " h " in err.reason
    assert sim.max_penetration == pytest.approx(err.figures["penetration_m"])
    assert sim.max_penetration > 2e-3  # 2.39 mm = 2.1 h at the first step
    # math.inf records without stopping
    rec = Simulator(beam, RodOptions(scene="floor"), penetration_limit=math.inf)
    rec.set_waveform(Sine((0.1, 0.1), 5, phase=1))
    rec.step(10)
    assert rec.max_penetration > 2e-3


def test_tunnelling_is_reported(beam):
    import mujoco

    sim = Simulator(beam, RodOptions(scene="floor"), check_every=5)
    sim.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT  # no contact: it falls through
    with pytest.raises(UnphysicalError, match="tunnelling") as info:
        sim.step(100)
    assert info.value.cause == "tunnelling" and info.value.figures["floor_depth_h"] > PENETRATION_LIMIT
    assert info.value.step < 30  # free fall passes -h/2 after 15 ms


def test_energy_no_field_supplied_is_a_launch(beam):
    sim = Simulator(beam, RodOptions(scene="floor"))
    sim.model.opt.gravity[2] = 30.0  # an unmodelled upward pull lifts the beam
    with pytest.raises(UnphysicalError, match="launch") as info:
        sim.step(500)
    assert info.value.cause == "launch" and info.value.figures["energy_created_J"] > 0.0
    assert sim.energy_drift > 0.01


def test_unphysical_run_truncates_the_env_with_reason_and_figures():
    env = _make("MagSoftCrawl-v1", field_limit=0.1, sim_dt=1e-3)
    env.reset(seed=0)
    obs, r, term, trunc, info = env.step(np.array([0.0, 1.0], dtype=np.float32))  # 100 mT at 1 ms: 2.3 h
    assert trunc and not term and r == 0.0
    assert "penetration" in info["unphysical"] and "mm" in info["unphysical"]
    assert info["penetration_h"] > PENETRATION_LIMIT and info["penetration_m"] > PENETRATION_LIMIT * H
    assert info["max_penetration"] == pytest.approx(info["penetration_m"])
    assert "unphysical motion" in info["truncation_reason"]
    assert np.all(np.isfinite(obs))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(2, dtype=np.float32))
    env.reset(seed=0)  # usable again, the records restart
    _, _, _, trunc, info = env.step(np.zeros(2, dtype=np.float32))
    assert not trunc and info["max_penetration"] < 0.1 * H
    env.close()


# ---------------------------------------------------------------- resolved runs say so
def test_gait_run_reports_a_small_penetration_and_no_energy_created():
    p = gait_preset("paper-5c")
    r = run_gait(p, seconds=0.3)
    assert r.success and r.unphysical == ""
    assert 0.0 < r.max_penetration < 0.1 * p.beam.thickness < PENETRATION_LIMIT * p.beam.thickness  # 0.04 h
    assert r.max_penetration_h == pytest.approx(r.max_penetration / p.beam.thickness)
    assert 0.0 <= r.energy_drift < 1e-6
    d = r.to_dict()
    assert d["max_penetration_mm"] == pytest.approx(r.max_penetration * 1e3)
    assert {"max_penetration_h", "energy_drift", "unphysical"} <= set(d)


def test_energy_balance_follows_field_changes_and_outside_writes(beam):
    sim = Simulator(beam, RodOptions(scene="floor"))
    for k in range(6):  # held fields, changed between calls: each change's work is booked
        sim.set_field((1e-3 * math.sin(k), 1.5e-3 * math.cos(k)))
        sim.step(100)
    assert 0.0 <= sim.energy_drift < 1e-6
    sim.data.qvel[1] = 0.3  # a kick from outside: the balance restarts, no false launch
    sim.step(200)
    assert 0.0 <= sim.energy_drift < 1e-6
    h = sim.health()
    assert set(h) == {"max_penetration_m", "max_penetration_h", "penetration_limit_h", "energy_drift",
                      "max_kinetic_ratio"}
    assert 0.0 < h["max_kinetic_ratio"] < 1.0
    sim.reset()
    assert sim.max_penetration == 0.0 and sim.energy_drift == 0.0 and sim.max_kinetic_ratio == 0.0
    assert math.isnan(Simulator(beam).energy_drift)  # not tracked in the cantilever
    assert Simulator(beam).max_penetration == 0.0


def test_a_start_through_a_feature_counts_from_its_overlap(beam):
    # feature_x through the resting beam is the caller's geometry: the bound counts from it
    sim = Simulator(beam, RodOptions(scene="obstacle", feature_x=20e-3))
    assert sim.initial_overlap == pytest.approx(H, rel=1e-6)
    sim.run(Sine((0.0, 2.5e-3), 2.0), 0.05)
    assert sim.max_penetration == pytest.approx(H, rel=1e-6)

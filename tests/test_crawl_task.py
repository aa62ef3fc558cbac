"""The crawl task's functions (envs/crawl_task.py) on arrays, against closed forms, and the single env as their
n = 1 caller: its reward, termination and info are the functions' on its own state, for the chain and the strip."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import VectorEnv

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.envs.crawl_task import (
    AIRBORNE_TOLERANCE,
    CrawlRecords,
    CrawlTask,
    clock_tail,
    crawl_info,
    crawl_limits,
    crawl_reward,
    first_violation,
    limit_summary,
    observation,
    observation_high,
    period_substeps,
    single_info,
    stack_infos,
    vector_info,
    violation_texts,
    wave_rows,
    zero_terms,
)

H = 1e-3  # beam thickness (m)


def task(**kw) -> CrawlTask:
    base = {"crawl_mode": "rotation", "max_clearance": 1e-5, "max_link_rotation": 2.0 * math.pi / 3.0,
            "max_height": 7.6e-3, "forward_reward_weight": 1000.0, "target_direction": 1, "field_cost_weight": 0.1,
            "crawl_penalty": 10.0, "field_limit": 2e-3, "clock_frequency": 2.0}
    return CrawlTask(**{**base, **kw})


def chain(angles, *, z0=0.5 * H, length=1e-3, heading=0.0) -> np.ndarray:
    """Centreline points (N + 2, 3) of pieces of ``length`` at ``angles`` (rad from the heading toward +z)."""
    p = [np.array([0.0, 0.0, z0])]
    for a in angles:
        step = length * np.array([math.cos(a) * math.cos(heading), math.cos(a) * math.sin(heading), math.sin(a)])
        p.append(p[-1] + step)
    return np.array(p)


# ---------------------------------------------------------------------- crawl limits
def test_crawl_limits_of_a_bent_chain_are_its_clearance_top_and_steepest_piece():
    pts = chain([0.0, 0.3, -0.5], z0=0.5 * H + 2e-4)
    lim = crawl_limits(pts[None, :, None, :], [0.0], half_thickness=0.5 * H, inv_piece_length=np.full(3, 1e3))
    assert lim.shape == (1, 3, 1)
    assert lim[0, 0, 0] == pytest.approx(pts[:, 2].min() - 0.5 * H, abs=1e-15)
    assert lim[0, 1, 0] == pytest.approx(pts[:, 2].max(), abs=1e-15)
    assert lim[0, 2, 0] == pytest.approx(math.cos(0.5), abs=1e-12)


def test_crawl_limits_measure_piece_angles_from_each_robots_heading():
    # the same bent chain pointing along +y (the strip turned on the floor) and along +x: the same figures
    a = chain([0.2, -0.4, 0.1], heading=0.5 * math.pi)
    b = chain([0.2, -0.4, 0.1])
    pts = np.stack([a, b])[:, :, None, :]
    lim = crawl_limits(pts, [0.5 * math.pi, 0.0], half_thickness=0.5 * H, inv_piece_length=np.full(3, 1e3))
    np.testing.assert_allclose(lim[0], lim[1], atol=1e-12)
    assert lim[0, 2, 0] == pytest.approx(math.cos(0.4), abs=1e-12)
    # read from +x, the chain along +y has no extent along the heading: every piece at 90 deg
    wrong = crawl_limits(pts[:1], [0.0], half_thickness=0.5 * H, inv_piece_length=np.full(3, 1e3))
    assert abs(wrong[0, 2, 0]) < 1e-12


def test_limit_summary_counts_airborne_substeps_but_not_the_end_state():
    lim = np.zeros((2, 3, 4))
    lim[0, 0] = [0.0, 2 * AIRBORNE_TOLERANCE, 0.0, 5 * AIRBORNE_TOLERANCE]  # the last column: the end state
    lim[1, 0] = [AIRBORNE_TOLERANCE, 0.0, 0.0, 0.0]  # at the tolerance: not airborne
    lim[:, 2] = [[1.0, 0.5, 0.9, 1.0], [0.2, 1.0, 1.0, 1.0]]
    clear, cos, airborne = limit_summary(lim)
    np.testing.assert_array_equal(clear, [5 * AIRBORNE_TOLERANCE, AIRBORNE_TOLERANCE])
    np.testing.assert_array_equal(cos, [0.5, 0.2])
    np.testing.assert_array_equal(airborne, [1, 0])


@pytest.mark.parametrize("mode, expected", [("rotation", [1, 2, -1]), ("height", [0, 2, -1]), ("none", [-1, -1, -1])])
def test_first_violation_is_the_first_state_breaking_a_limit_of_the_mode(mode, expected):
    lim = np.zeros((3, 3, 3))
    lim[:, 2] = 1.0
    lim[0, 1, 0] = 8e-3  # robot 0: too high first, then tumbled
    lim[0, 2, 1] = -0.9
    lim[1, 0, 2] = 2e-5  # robot 1: airborne at its end state
    column, figures = first_violation(lim, task(crawl_mode=mode))
    np.testing.assert_array_equal(column, expected)
    if mode == "rotation":
        np.testing.assert_array_equal(figures[0], lim[0, :, 1])


def test_violation_texts_name_the_limit_its_figure_and_the_time():
    lim = np.zeros((3, 3, 1))
    lim[:, 2] = 1.0
    lim[0, 0, 0] = 2.5e-3
    lim[1, 2, 0] = math.cos(math.radians(130.0))
    lim[2, 1, 0] = 8e-3
    when = np.array([0.1234, 0.5, 1.0])
    rot = violation_texts(lim[:, :, 0], when, task(max_clearance=2e-3), np.array([True, True, False]))
    assert rot[0] == ("airborne at t = 0.1234 s: the lowest point is 2.500 mm above the floor > 2.000 mm (the whole "
                      "beam off the floor: a hop, not a crawl)")
    assert rot[1] == "link rotation 130.0 deg > 120.0 deg at t = 0.5000 s"
    assert rot[2] is None
    height = violation_texts(lim[:, :, 0], when, task(crawl_mode="height", max_clearance=None), np.ones(3, bool))
    assert height[2] == "height 8.00 mm > 7.60 mm at t = 1.0000 s"


# ---------------------------------------------------------------------- reward
def test_the_reward_is_its_terms_and_a_broken_limit_forfeits_the_episode():
    t = task(target_direction=-1)
    reward, terms = crawl_reward(np.array([2e-3, 2e-3, -1e-3]), np.array([0.5, 0.0, 1.0]),
                                 np.array([False, True, True]), np.array([5.0, 5.0, -3.0]), t,
                                 success=[0.0, 0.0, 100.0])
    np.testing.assert_allclose(terms["forward"], [-2.0, 0.0, 0.0])
    np.testing.assert_allclose(terms["field"], [-0.05, 0.0, -0.1])
    np.testing.assert_allclose(terms["crawl"], [0.0, -15.0, -10.0])  # the penalty plus what was earned (>= 0)
    np.testing.assert_allclose(terms["success"], [0.0, 0.0, 100.0])
    np.testing.assert_array_equal(reward, terms["forward"] + terms["field"] + terms["crawl"] + terms["success"])


# ---------------------------------------------------------------------- observation
def test_observation_is_float32_clipped_to_its_bounds_with_the_clock():
    high = observation_high(3)
    assert high.dtype == np.float32 and high.shape == (12,)
    tail = clock_tail(np.array([[1e-3, -4e-3]]), [0.125], task())  # a quarter period of the 2 Hz clock
    np.testing.assert_allclose(tail, [[0.5, -2.0, 1.0, 0.0]], atol=1e-15)
    obs = observation(np.array([[0.1, 4.0, -0.2]]), np.array([[2e3, 0.0, 1.0]]), np.array([[1e-3, 20.0]]), tail, high)
    assert obs.dtype == np.float32
    np.testing.assert_allclose(obs[0], [0.1, np.pi, -0.2, 1e3, 0.0, 1.0, 1e-3, 10.0, 0.5, -1.0, 1.0, 0.0], rtol=1e-6,
                               atol=1e-7)


def test_wave_rows_are_the_single_envs_waveparams():
    env = gym.make("MagSoftCrawlWaveform-v1", segments=4, sim_dt=1e-3).unwrapped
    acts = np.random.default_rng(0).uniform(-1.2, 1.2, (5, 4))
    rows = wave_rows(acts, field_limit=env.field_limit, frequency_range=env.frequency_range)
    for a, row in zip(acts, rows, strict=True):
        w = env.waveparams_of_action(a)
        assert (w.amplitude_x, w.amplitude_z, w.frequency, w.phase) == tuple(row)
    np.testing.assert_array_equal(period_substeps(rows[:, 2], 1e-3), np.round(1.0 / (rows[:, 2] * 1e-3)))
    assert period_substeps([1e9], 1e-3)[0] == 1


# ---------------------------------------------------------------------- records and info
def test_records_book_only_the_masked_robots_and_info_latches_a_flip():
    rec = CrawlRecords.zeros(2)
    start = np.array([[-1e-6, 5e-4, 0.9], [-2e-6, 5e-4, 0.8]])
    rec.restart([True, True], com=np.array([[0.0, 5e-4], [1e-3, 5e-4]]), start_limits=start)
    rec.book([True, False], com=np.array([[2e-5, 5e-4], [9.0, 9.0]]), duration=[0.02, 0.02],
             highest_clearance=[3e-5, 1.0], lowest_cos=[0.5, -1.0], airborne=[4, 7], substeps=[100, 100])
    np.testing.assert_allclose(rec.com_velocity, [[1e-3, 0.0], [0.0, 0.0]], atol=1e-15)
    np.testing.assert_array_equal(rec.com[1], [1e-3, 5e-4])  # robot 1 not booked
    info = crawl_info(rec, orientation=[2.0, 0.1], reward=[0.0, 0.0], terms=zero_terms(2), time=[0.02, 0.0],
                      max_penetration=[0.0, 0.0], is_success=[False, False])
    np.testing.assert_array_equal(info["flipped"], [True, False])
    np.testing.assert_allclose(info["airborne_fraction"], [0.04, 0.0])  # robot 1: no substeps yet, 0
    np.testing.assert_allclose(info["largest_piece_angle"], np.arccos([0.5, 0.8]))
    np.testing.assert_allclose(info["highest_clearance"], [3e-5, -2e-6])
    info = crawl_info(rec, orientation=[0.0, 0.0], reward=[0.0, 0.0], terms=zero_terms(2), time=[0.04, 0.0],
                      max_penetration=[0.0, 0.0], is_success=[False, False])
    assert info["flipped"].tolist() == [True, False]  # once flipped in the episode, flipped
    one = single_info({k: v[:1] for k, v in info.items()})
    assert type(one["flipped"]) is bool and type(one["time"]) is float and one["field"].shape == (2,)


def test_stack_infos_is_gymnasiums_vector_form():
    per_robot = {0: {"time": 0.1, "flipped": False, "field": np.array([1.0, 2.0]), "step": 3},
                 2: {"time": 0.2, "flipped": True, "field": np.array([3.0, 4.0]), "crawl_violation": "hop"}}

    class Three(VectorEnv):
        num_envs = 3

    want: dict = {}
    for i, info in per_robot.items():
        want = Three()._add_info(want, info, i)
    got = stack_infos(per_robot, 3)
    assert list(got) == list(want)
    for key in want:
        assert got[key].dtype == want[key].dtype, key
        np.testing.assert_array_equal(got[key], want[key], err_msg=key)
    v = vector_info({"time": np.array([0.1, 0.2, 0.3])}, np.array([True, False, True]))
    assert v["_time"].tolist() == [True, False, True]


def test_bad_arrays_and_parameters_are_refused():
    with pytest.raises(ValueError, match=r"points must have shape \(n, N \+ 2, k, 3\)"):
        crawl_limits(np.zeros((3, 4, 3)), [0.0], half_thickness=0.5, inv_piece_length=np.ones(2))
    with pytest.raises(ValueError, match=r"inv_piece_length must have shape \(3,\)"):
        crawl_limits(np.zeros((1, 4, 1, 3)), [0.0], half_thickness=0.5, inv_piece_length=np.ones(4))
    with pytest.raises(ValueError, match="crawl_mode must be one of"):
        task(crawl_mode="tumble")


# ---------------------------------------------------------------------- the single env, n = 1
FAST = {"segments": 6, "sim_dt": 1e-3, "field_limit": 4e-3}


def _recomputed(env, info) -> None:
    """The env's info fields against the crawl task's functions on its own state now."""
    pose = env.sim.pose()
    np.testing.assert_array_equal([info["x_position"], info["z_position"]], pose.com[[0, 2]])
    assert info["time"] == env.sim.time and info["max_penetration"] == env.sim.max_penetration
    terms = ("reward_forward", "reward_field", "reward_crawl", "reward_success")
    assert info["reward"] == sum(info[k] for k in terms)
    tracker = env.sim.orientation_tracker()  # the body's heading on the floor now
    tracker.track(pose)
    lim = crawl_limits(pose.centreline[None, :, None, :], [tracker.heading],
                       half_thickness=0.5 * env.gait.beam.thickness, inv_piece_length=1.0 / pose.lengths)
    assert info["highest_clearance"] >= lim[0, 0, 0]  # the episode's highest includes the present state
    assert info["largest_piece_angle"] >= math.acos(min(1.0, lim[0, 2, 0])) - 1e-12


@pytest.mark.parametrize("rod", ["planar", "cable"])
def test_the_single_env_runs_through_the_task_functions(rod):
    # the planar chain and the 3D strip (MagSoftCrawl-v1's rod="cable"): the same functions, the same info keys
    env = gym.make("MagSoftCrawl-v1", rod=rod, **FAST).unwrapped
    obs, info = env.reset(seed=0)
    _recomputed(env, info)
    keys = set(info)
    rng = np.random.default_rng(0)
    for _ in range(4):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        assert set(info) - {"crawl_violation"} == keys
        assert r == info["reward"]
        _recomputed(env, info)
        power = np.sum(info["field"] ** 2) / env.field_limit**2
        assert info["reward_field"] == -env.field_cost_weight * power
        if term:
            assert info["crawl_violation"] and info["reward_forward"] == 0.0
            break
    env.close()


def test_reset_from_a_given_state_is_the_reset_of_that_state():
    env = gym.make("MagSoftCrawl-v1", **FAST).unwrapped
    obs0, info0 = env.reset(seed=4)
    qpos = env.sim.data.qpos.copy()
    a = np.array([0.3, -0.6], np.float32)
    want = env.step(a)
    env.reset(seed=99)
    obs, info = env.reset(options={"qpos": qpos, "qvel": np.zeros(env.sim.model.nv)})
    np.testing.assert_array_equal(obs, obs0)
    assert info == {**info0, "field": info["field"]} and np.array_equal(info["field"], info0["field"])
    got = env.step(a)
    np.testing.assert_array_equal(got[0], want[0])
    assert got[1:4] == want[1:4]
    with pytest.raises(ValueError, match=r"options may hold 'qpos' and 'qvel'.*\['target'\]"):
        env.reset(options={"target": 1.0})
    with pytest.raises(ValueError, match=r"qpos must be a finite array of shape"):
        env.reset(options={"qpos": qpos[:-1]})


def test_env_step_goes_down_to_mujoco_through_each_file_once():
    # the call chain from env.step to mujoco's step: every file entered once, never returned to (envs -> sim)
    import os
    import sys

    env = gym.make("MagSoftCrawl-v1", **FAST).unwrapped
    env.reset(seed=0)
    step_code = type(env).step.__code__
    chains = []

    def hook(frame, event, arg):
        if event == "c_call" and getattr(arg, "__name__", "") in ("mj_step", "rollout"):
            files = []
            while frame is not None:
                files.append(os.path.basename(os.path.dirname(frame.f_code.co_filename)) + "/"
                             + os.path.basename(frame.f_code.co_filename))
                if frame.f_code is step_code:
                    break
                frame = frame.f_back
            chains.append(files[::-1])

    sys.setprofile(hook)
    try:
        env.step(np.zeros(2, np.float32))
    finally:
        sys.setprofile(None)
    assert chains
    for files in chains:
        assert files[0] == "envs/crawl.py"
        order = [f for i, f in enumerate(files) if i == 0 or f != files[i - 1]]
        assert len(order) == len(set(order)), order  # no file is come back to

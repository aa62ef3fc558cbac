"""MagSoftSteer-v0: the 3D strip steered to a goal point by the three-axis field; rotating drives; the 3D body
orientation (end over end, not turns on the floor)."""

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import magsoft_env as ms
from magsoft_env.envs.steer import MagSoftSteerEnv, steer_controller
from magsoft_env.sim.readouts import PitchTracker
from magsoft_env.spec.drive import Waveparams

FAST = {"segments": 6}


@pytest.fixture(scope="module")
def env():
    e = MagSoftSteerEnv(**FAST)
    yield e
    e.close()


def test_spaces_and_check_env(env):
    assert env.action_space.shape == (3,)
    p = env.segments + 2
    assert env.observation_space.shape == (3 * p + 11,)
    check_env(env, skip_render_check=True)


def test_registered_with_the_spec_sheet_defaults():
    e = gym.make("MagSoftSteer-v0")
    try:
        assert e.spec.max_episode_steps == 250
        base = e.unwrapped
        assert base.field_limit == 3e-3 and base.segments == 10 and base.ctrl_dt == 0.02
        obs, info = e.reset(seed=3)
        assert obs.shape == (47,)
        assert 0.02 <= info["distance"] <= 0.06
    finally:
        e.close()


def test_seeding_and_goal_option(env):
    a = env.reset(seed=7)[0]
    env.step(np.array([0.3, -0.2, 0.5], np.float32))
    b = env.reset(seed=7)[0]
    np.testing.assert_array_equal(a, b)
    c = env.reset(seed=8)[0]
    assert not np.array_equal(a[:2], c[:2])  # another goal
    obs, info = env.reset(seed=0, options={"goal": (0.03, -0.02)})
    np.testing.assert_allclose(info["goal"], [0.03, -0.02])
    com = np.array([info["x_position"], info["y_position"]])
    np.testing.assert_allclose(obs[:2], np.array([0.03, -0.02]) - com, atol=1e-7)
    assert info["distance"] == pytest.approx(np.hypot(*(np.array([0.03, -0.02]) - com)))


@pytest.mark.parametrize("kwargs, match", [
    ({"field_limit": 1.0}, "field_limit"),
    ({"goal_distance": (0.05, 0.01)}, "goal_distance"),
    ({"goal_distance": (0.02, 0.06), "max_distance": 0.05}, "max_distance"),
    ({"segments": 1}, "segments"),
    ({"goal_radius": -1.0}, "goal_radius"),
    ({"ctrl_dt": 1e-5}, "sim_dt"),
    ({"goal_radus": 0.01}, "goal_radius"),
])
def test_bad_arguments_are_refused_before_any_work(kwargs, match):
    with pytest.raises(ValueError, match=match):
        MagSoftSteerEnv(**kwargs)


def test_bad_reset_options_and_actions(env):
    with pytest.raises(ValueError, match="goal"):
        env.reset(options={"goal": (1.0, 0.0)})  # beyond max_distance
    with pytest.raises(ValueError, match="goal"):
        env.reset(options={"goal": (0.01,)})
    with pytest.raises(ValueError, match="reset options"):
        env.reset(options={"target": (0.01, 0.0)})
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action"):
        env.step(np.zeros(2, np.float32))


def test_no_field_no_motion_and_the_reward_terms(env):
    obs, info = env.reset(seed=1)
    d0 = info["distance"]
    total = 0.0
    for _ in range(5):
        obs, r, term, trunc, info = env.step(np.zeros(3, np.float32))
        total += info["reward_progress"]
        assert info["reward_field"] == 0.0 and not (term or trunc)
    assert abs(info["distance"] - d0) < 2e-5  # lying still (settling by microns)
    assert total == pytest.approx(1000.0 * (d0 - info["distance"]), abs=1e-9)
    env.step(np.ones(3, np.float32))
    _, r, _, _, info = env.step(np.ones(3, np.float32))
    assert info["reward_field"] == pytest.approx(-0.1 * 3.0)
    np.testing.assert_allclose(info["field"], [3e-3, 3e-3, 3e-3])
    assert r == pytest.approx(info["reward_progress"] + info["reward_field"])


def test_hand_controller_turns_to_the_goal_and_reaches_it(env):
    # the goal to the side: the strip (along +x) must turn by 90 deg and go
    obs, info = env.reset(seed=0, options={"goal": (0.012, 0.035)})
    for _ in range(150):
        obs, r, term, trunc, info = env.step(steer_controller(obs))
        if term or trunc:
            break
    assert term and not trunc and info["is_success"], info
    assert info["distance"] <= env.goal_radius
    assert 0.2 < info["time_to_goal"] < 3.0
    assert info["flipped"]  # it tumbles there, end over end
    assert abs(abs(info["turned"]) - 0.5 * math.pi) < 0.5  # and turned a quarter turn on the floor
    assert info["max_penetration"] < 0.5 * env.gait.beam.thickness


def test_controller_is_batched_and_follows_the_clock():
    obs = np.zeros((2, 47), np.float32)
    obs[0, :2] = (0.01, 0.0)
    obs[1, :2] = (0.0, -0.02)
    obs[:, -2:] = (0.0, 1.0)  # sin, cos of the clock phase: t = 0
    a = steer_controller(obs)
    np.testing.assert_allclose(a, [[-1, 0, 0], [0, 1, 0]], atol=1e-7)
    obs[:, -2:] = (1.0, 0.0)  # a quarter period later: straight up
    np.testing.assert_allclose(steer_controller(obs), [[0, 0, 1], [0, 0, 1]], atol=1e-7)
    np.testing.assert_allclose(steer_controller(obs[0]), [0, 0, 1], atol=1e-7)


def test_vector_env_robot_equals_the_single_env():
    envs = gym.make_vec("MagSoftSteer-v0", num_envs=2, **FAST)
    single = gym.make("MagSoftSteer-v0", **FAST)
    try:
        obs, _ = envs.reset(seed=4)
        o1, _ = single.reset(seed=4)
        np.testing.assert_array_equal(obs[0], o1)
        rng = np.random.default_rng(0)
        for _ in range(4):
            a = rng.uniform(-1, 1, (2, 3)).astype(np.float32)
            obs, r, *_ = envs.step(a)
            o1, r1, *_ = single.step(a[0])
            np.testing.assert_array_equal(obs[0], o1)
            assert r[0] == r1
    finally:
        envs.close()
        single.close()
    with pytest.raises(ValueError, match="backend"):
        gym.make_vec("MagSoftSteer-v0", num_envs=2, backend="warp")


def test_rotating_drives():
    for axis, first, quarter in (("z", [1, 0, 0], [0, 1, 0]), ("x", [0, 1, 0], [0, 0, 1]), ("y", [-1, 0], [0, 1])):
        w = Waveparams.rotating(2e-3, 1.0, axis)
        s = w.sample([0.0, 0.25]) / 2e-3
        np.testing.assert_allclose(s[0], first, atol=1e-12)
        np.testing.assert_allclose(s[1], quarter, atol=1e-12)
    with pytest.raises(ValueError, match="axis"):
        Waveparams.rotating(2e-3, 1.0, "w")


def test_a_three_axis_drive_survives_the_robot_file(tmp_path):
    robot = ms.load_robot("paper-5c").replace(name="spinner", drive=Waveparams.rotating(2e-3, 0.5, "z"))
    robot.save(tmp_path / "spinner.yml")
    back = ms.load_robot(tmp_path / "spinner.yml")
    assert back.drive.amplitude_y == pytest.approx(2e-3) and back.drive.phase == pytest.approx(0.5 * math.pi)
    np.testing.assert_allclose(back.drive.sample([0.0, 0.5]), robot.drive.sample([0.0, 0.5]), atol=1e-15)
    with pytest.raises(ValueError, match="y component"):
        ms.run_gait(back, 0.01, segments=4)  # the planar rod refuses it


def test_field_rotating_about_z_turns_the_strip_in_place():
    robot = ms.load_robot("paper-5c").replace(drive=Waveparams.rotating(2e-3, 0.5, "z"))
    res = ms.run_gait(robot, 2.0, segments=6, rod="cable")
    assert res.success and res.locomotion == "crawl"  # turning on the floor is not a tumble
    assert abs(res.turned - 2.0 * math.pi * 0.5 * 2.0) < 0.35 * math.pi  # it follows the field, about one turn
    assert abs(res.displacement) < 1e-3 and abs(res.max_orientation) < 0.3


def test_pitch_tracker_counts_flips_not_turns():
    lengths = np.ones(3)
    yaw = PitchTracker()
    for psi in np.linspace(0.0, 4.0 * math.pi, 200):  # two turns on the floor
        t = np.tile([math.cos(psi), math.sin(psi), 0.0], (3, 1))
        v = yaw.update(t, lengths)
    assert abs(v) < 1e-9 and yaw.heading == pytest.approx(4.0 * math.pi)
    tumble = PitchTracker()
    for a in np.linspace(0.0, 2.0 * math.pi, 200):  # one flip end over end in the plane through +y
        t = np.tile([0.0, math.cos(a), math.sin(a)], (3, 1))
        v = tumble.update(t, lengths)
    assert v == pytest.approx(2.0 * math.pi)
    planar = PitchTracker()
    assert planar.update(np.array([[math.cos(0.3), 0.0, math.sin(0.3)]] * 2), np.ones(2)) == pytest.approx(0.3)


def test_waveform_mode_plays_a_rotating_field_and_its_baseline_reaches_the_goal():
    env = gym.make("MagSoftSteerWaveform-v0", **FAST)
    try:
        base = env.unwrapped
        assert env.action_space.shape == (4,) and base.ctrl_dt == 0.1 and env.spec.max_episode_steps == 50
        check_env(base, skip_render_check=True)
        a = base.action_of_wave((0.0, -2.0), 1.5e-3, 1.0)
        u, amp, f = base.wave_of_action(a)
        np.testing.assert_allclose(u, [0.0, -1.0], atol=1e-7)
        assert amp == pytest.approx(1.5e-3, rel=1e-6) and f == pytest.approx(1.0, rel=1e-6)
        assert base.wave_of_action([0.0, 0.0, 1.0, 0.0])[1] == 0.0  # no direction: no field
        obs, info = env.reset(seed=0, options={"goal": (-0.02, 0.0)})
        obs, r, *_ , info = env.step(base.action_of_wave((1.0, 0.0), 3e-3, 1.0))
        # a tenth of a turn at 1 Hz from phi = 0; the field of the step's last substep (it started at 0.1 s - dt):
        # B = A (-cos(phi) u + sin(phi) z), u = +x
        phi = 2.0 * math.pi * (0.1 - base.sim_dt)
        np.testing.assert_allclose(info["field"], 3e-3 * np.array([-math.cos(phi), 0.0, math.sin(phi)]), atol=1e-12)
        assert info["reward_field"] == pytest.approx(-0.1)
        obs, info = env.reset(seed=0, options={"goal": (0.012, -0.03)})
        for _ in range(40):
            obs, r, term, trunc, info = env.step(base.baseline_action(obs))
            if term or trunc:
                break
        assert term and info["is_success"] and info["time_to_goal"] < 3.0, info
    finally:
        env.close()


def test_steer_eval_counts_successes_and_times_on_shared_goals():
    from magsoft_env.bench.steer_eval import _baseline, _zero, run_controller

    hand = run_controller("MagSoftSteer-v0", _baseline, episodes=1, seed=3, env_kwargs=FAST, name="hand")
    assert hand["successes"] == 1 and 0.2 < hand["time_to_goal_mean_s"] < 3.0
    assert hand["final_distance_mean_mm"] <= 5.0 and hand["unstable"] == 0
    still = run_controller("MagSoftSteer-v0", _zero, episodes=1, seed=3,
                           env_kwargs={**FAST, "goal_distance": (0.03, 0.03)}, name="zero")
    assert still["successes"] == 0 and math.isnan(still["time_to_goal_mean_s"])
    assert still["final_distance_mean_mm"] == pytest.approx(30.0, abs=0.05)  # lying still, the goal 30 mm away

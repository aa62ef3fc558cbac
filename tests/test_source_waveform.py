"""MagSoftCoilsWaveform-v0 and MagSoftMagnetWaveform-v0: the wave made by the actuator, the same physics as the
source envs, the contract, bad arguments."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.envs.coils import MagSoftCoilsEnv
from magsoft_env.envs.magnet import MagSoftMagnetEnv
from magsoft_env.envs.source_waveform import MagSoftCoilsWaveformEnv, MagSoftMagnetWaveformEnv

FAST = {"segments": 6, "sim_dt": 4e-4}
IDS = ("MagSoftCoilsWaveform-v0", "MagSoftMagnetWaveform-v0")


def test_sb3_check_env_passes():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_checker import check_env

    for env_id in IDS:
        env = gym.make(env_id, **FAST)
        check_env(env.unwrapped, warn=True)
        env.close()


def test_coils_field_action_makes_the_field_at_the_strip():
    env = MagSoftCoilsEnv(**FAST)
    env.reset(seed=0)
    for want in ([2e-3, -1e-3, 1.5e-3], [0.0, 0.0, 3e-3], [-3e-3, 0.0, 0.0]):
        I = env.field_action(want) * env.max_current
        B, _ = env.system.field_and_gradient((env.com_position() - env.coils_origin)[None], I)
        np.testing.assert_allclose(B[0], want, rtol=0, atol=1e-6 * 3e-3)  # float32 currents


def test_magnet_field_action_points_the_dipole_field_at_the_strip():
    env = MagSoftMagnetEnv(**FAST)
    env.reset(seed=0)
    com = env.com_position()
    for want in ([1e-3, -1e-3, 1e-3], [0.0, 0.0, -1e-3], [-2e-3, 0.5e-3, 0.0], [0.3e-3, 0.0, 0.1e-3]):
        position, axis = env.pose_of_action(env.field_action(want))
        np.testing.assert_allclose(position[:2], com[:2], atol=1e-7)  # the action is float32
        r = com - position  # from the magnet down to the strip
        d = np.linalg.norm(r)
        m = env.magnet_moment * axis
        B = 1e-7 * (3.0 * np.dot(m, r) * r / d**5 - m / d**3)  # the point dipole's field
        w = np.asarray(want)
        assert np.dot(B, w) / (np.linalg.norm(B) * np.linalg.norm(w)) > 1 - 1e-10
        low, high = env.workspace.bounds[2]
        if low < position[2] < high:  # the height set for the magnitude (the cylinder is a dipole to 1e-3 here)
            assert np.linalg.norm(B) == pytest.approx(np.linalg.norm(w), rel=1e-5)
        else:  # beyond the heights: the nearest one
            assert (position[2] == low) == (np.linalg.norm(B) < np.linalg.norm(w))


def test_magnet_without_tilt_cannot_make_a_wave():
    with pytest.raises(ValueError, match="tilt=True"):
        MagSoftMagnetWaveformEnv(tilt=False, **FAST)
    env = MagSoftMagnetEnv(tilt=False, **FAST)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="tilt=True"):
        env.field_action([0.0, 0.0, 1e-3])


@pytest.mark.parametrize("cls", [MagSoftCoilsWaveformEnv, MagSoftMagnetWaveformEnv])
def test_a_step_is_the_source_env_stepped_with_the_wave(cls):
    """Five source-env steps with the field actions of the wave's field at each interval's middle: the same
    observations (bar the clock slot) and rewards, bit for bit."""
    env = cls(**FAST)
    ref = cls.source_class(ctrl_dt=0.02, **FAST)
    obs, _ = env.reset(seed=5)
    ref_obs, _ = ref.reset(seed=5)
    clock = ref.steer_obs_size - 2
    np.testing.assert_array_equal(np.delete(obs, [clock, clock + 1]), np.delete(ref_obs, [clock, clock + 1]))
    assert obs[clock] == 0.0 and obs[clock + 1] == 1.0
    phase = 0.0
    for action in np.array([[0.6, 0.8, 1.0, 0.0], [-1.0, 0.2, 0.5, 1.0]], np.float32):
        u, amp, f = env.wave_of_action(action)
        obs, reward, term, trunc, info = env.step(action)
        total = 0.0
        for _ in range(info["actuator_steps"]):
            turn = 2 * math.pi * f * 0.02
            field = amp * np.array([-math.cos(phase + turn / 2) * u[0], -math.cos(phase + turn / 2) * u[1],
                                    math.sin(phase + turn / 2)])
            ref_obs, r, *_ = ref.step(ref.field_action(field))
            phase = math.remainder(phase + turn, 2 * math.pi)
            total += r
        assert info["actuator_steps"] == 5 and not (term or trunc)
        assert reward == total
        np.testing.assert_array_equal(np.delete(obs, [clock, clock + 1]), np.delete(ref_obs, [clock, clock + 1]))
        np.testing.assert_allclose(obs[clock:clock + 2], [math.sin(phase), math.cos(phase)], atol=1e-7)
        assert info["wave_frequency"] == pytest.approx(f) and info["wave_magnitude"] == pytest.approx(amp)


def test_the_hand_controller_reaches_a_goal_through_the_coils():
    env = gym.make("MagSoftCoilsWaveform-v0", sim_dt=4e-4)
    obs, info = env.reset(seed=1000)
    start = info["distance"]
    for _ in range(50):
        obs, r, term, trunc, info = env.step(env.unwrapped.baseline_action(obs))
        if term or trunc:
            break
    assert info["is_success"], (start, info["distance"])
    assert info["time_to_goal"] < 3.0
    env.close()


def test_bad_arguments_are_refused_before_any_work():
    with pytest.raises(ValueError, match="whole multiple"):
        MagSoftCoilsWaveformEnv(ctrl_dt=0.05, **FAST)
    with pytest.raises(ValueError, match="frequency_range"):
        MagSoftCoilsWaveformEnv(frequency_range=(2.0, 1.0), **FAST)
    with pytest.raises(ValueError, match="action_mode"):
        MagSoftCoilsWaveformEnv(action_mode="field", **FAST)
    with pytest.raises(ValueError, match="actuator_dt"):
        MagSoftCoilsWaveformEnv(actuator_dt=-1.0, **FAST)

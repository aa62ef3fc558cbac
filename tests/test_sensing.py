"""The tracking-camera wrapper: latency, frame rate, dropout and position noise on the steering envs' observation."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

from magsoft_env.envs.sensing import SensingWrapper
from magsoft_env.envs.steer import MagSoftSteerEnv

FAST = {"sim_dt": 4e-4}


def _raw_and_wrapped(steps=6, **kw):
    raw = MagSoftSteerEnv(**FAST)
    env = SensingWrapper(MagSoftSteerEnv(**FAST), **kw)
    o_raw, _ = raw.reset(seed=3)
    o_env, _ = env.reset(seed=3)
    raws, seen = [o_raw], [o_env]
    a = np.array([0.3, -0.2, 0.5], dtype=np.float32)
    for _ in range(steps):
        raws.append(raw.step(a)[0])
        seen.append(env.step(a)[0])
    return raws, seen, env


def test_latency_delivers_the_frame_taken_k_steps_before():
    raws, seen, _ = _raw_and_wrapped(latency_frames=2)
    for k in range(2, len(raws)):
        assert np.array_equal(seen[k], raws[k - 2])
    assert np.array_equal(seen[1], raws[0])  # before the first delayed frame arrives: the initial image


def test_frame_rate_holds_the_last_frame_between_frames():
    raws, seen, _ = _raw_and_wrapped(frame_rate=25.0)  # ctrl_dt 20 ms: a frame every 40 ms, every other step
    for k in range(len(raws)):
        assert np.array_equal(seen[k], raws[k - (k % 2)])


def test_dropout_keeps_the_previous_frame_and_noise_is_on_positions_only():
    raws, seen, env = _raw_and_wrapped(steps=3, dropout=0.999999)
    assert all(np.array_equal(s, raws[0]) for s in seen)
    raws, seen, env = _raw_and_wrapped(steps=2, position_noise=1e-4)
    idx = env.unwrapped.position_observation_indices()
    other = np.setdiff1d(np.arange(raws[0].size), idx)
    d = seen[2] - raws[2]
    assert np.all(d[other] == 0.0)
    assert 2e-5 < float(np.std(d[idx])) < 5e-4
    # the same seed replays the same noise
    _, again, _ = _raw_and_wrapped(steps=2, position_noise=1e-4)
    assert np.array_equal(again[2], seen[2])


def test_the_wrapped_env_passes_gymnasiums_checker():
    import warnings

    from gymnasium.utils.env_checker import check_env

    env = SensingWrapper(MagSoftSteerEnv(**FAST), frame_rate=25.0, latency_frames=1, position_noise=1e-4, dropout=0.1)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", message=".*different from the unwrapped version")
        check_env(env, skip_render_check=True)  # seeded resets replay the noise and the dropped frames too


@pytest.mark.parametrize("kwargs, match", [
    ({"frame_rate": 100.0}, "at most the control rate"),
    ({"frame_rate": -1.0}, "frame_rate"),
    ({"latency_frames": 1.5}, "latency_frames"),
    ({"position_noise": 1.0}, "metres"),
    ({"dropout": 1.0}, "dropout"),
])
def test_bad_arguments_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        SensingWrapper(MagSoftSteerEnv(**FAST), **kwargs)


def test_it_wraps_a_made_env():
    env = SensingWrapper(gym.make("MagSoftCoils-v0", sim_dt=4e-4), latency_frames=1)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)

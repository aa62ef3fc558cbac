"""MagSoftCoils-v0 and MagSoftMagnet-v0: the env contract, the drive, the field reported, the magnet's workspace."""

from __future__ import annotations

import math
import warnings

import gymnasium as gym
import numpy as np
import pytest

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.envs.coils import MagSoftCoilsEnv
from magsoft_env.envs.magnet import MagSoftMagnetEnv
from magsoft_env.fields import CoilDrive

FAST = {"segments": 4, "sim_dt": 4e-4}


@pytest.mark.parametrize("env_id", ["MagSoftCoils-v0", "MagSoftMagnet-v0"])
def test_check_env(env_id):
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = gym.make(env_id, **FAST)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
        sb3_check_env(env.unwrapped, warn=True)
    env.close()


def test_cardiomag_spaces():
    env = MagSoftCoilsEnv(coils="cardiomag", **FAST)
    obs, _ = env.reset(seed=0)
    assert env.action_space.shape == (8,)
    assert obs.shape == (3 * 6 + 11 + 8,)
    env.close()


def test_currents_follow_the_drive():
    """The actual currents lag (L/R) and slew toward the command as a CoilDrive stepped at every physics step."""
    env = MagSoftCoilsEnv(coil_tau=5e-3, slew_rate=1000.0, **FAST)
    obs, _ = env.reset(seed=1)
    a = np.array([0.1, -0.05, 1.0], dtype=np.float32)  # coil 2 slew-limited (35 A), the others not
    obs, _, _, _, info = env.step(a)
    ref = CoilDrive(env.system, tau=5e-3, slew_rate=1000.0)
    for _ in range(env.n_substeps):
        ref.step(a.astype(float) * env.max_current, env.sim_dt)
    np.testing.assert_array_equal(info["currents"], ref.currents)
    I = info["currents"]
    lagged = a[:2] * env.max_current[:2] * (1.0 - math.exp(-env.ctrl_dt / 5e-3))
    np.testing.assert_allclose(I[:2], lagged, rtol=1e-9)
    assert I[2] == pytest.approx(1000.0 * env.ctrl_dt)  # 20 A of the 35 commanded
    assert info["saturated"].tolist() == [False, False, True]
    np.testing.assert_allclose(obs[-3:], I / env.max_current, rtol=1e-6)
    assert info["reward_current"] < 0.0 and "reward_field" not in info
    env.close()


def test_zero_currents_no_magnetic_load():
    """Zero currents: no field, and the strip stays at rest on the floor (gravity and contact only)."""
    env = MagSoftCoilsEnv(reset_noise_scale=0.0, **FAST)
    env.reset(seed=2)
    com0 = env.com_position()
    for _ in range(10):
        obs, reward, terminated, truncated, info = env.step(np.zeros(3, dtype=np.float32))
    assert not (terminated or truncated)
    assert np.all(info["field"] == 0.0) and np.all(info["currents"] == 0.0)
    assert np.linalg.norm(env.com_position() - com0) < 1e-6
    assert np.linalg.norm(env.sim.magnetic_couples()) == 0.0
    env.close()


@pytest.mark.parametrize("coils", ["navion", "cardiomag"])
def test_observed_field_is_the_coils_field_at_the_centre(coils):
    env = MagSoftCoilsEnv(coils=coils, **FAST)
    env.reset(seed=3)
    env.action_space.seed(3)
    for _ in range(3):
        obs, _, _, _, info = env.step(env.action_space.sample())
    I = env.currents
    B, _ = env.system.at_currents(I).field_and_gradient((env.com_position() - env.coils_origin)[None])
    k = env.steer_obs_size - 5
    np.testing.assert_allclose(info["field"], B[0], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(obs[k:k + 3], B[0] / env.field_scale, rtol=1e-6)
    assert 1e-4 < np.linalg.norm(B[0]) / max(np.abs(I).max(), 1e-9) < 3e-3  # of the order of mT per A
    env.close()


@pytest.mark.parametrize("tilt", [False, True])
def test_magnet_stays_in_its_workspace(tilt):
    env = MagSoftMagnetEnv(tilt=tilt, **FAST)
    env.reset(seed=4)
    env.action_space.seed(4)
    p = env.magnet_position
    for _ in range(15):
        obs, _, terminated, truncated, info = env.step(env.action_space.sample())
        env.workspace.check_pose(info["magnet_position"], info["magnet_axis"])
        assert np.linalg.norm(info["magnet_position"] - p) <= env.max_step * (1 + 1e-12)
        p = info["magnet_position"]
        np.testing.assert_allclose(obs[-6:-3], p - env.com_position(), atol=1e-7)
        if terminated or truncated:
            env.reset()
    env.close()


def test_strip_at_the_magnet_ends_the_episode(monkeypatch):
    env = MagSoftMagnetEnv(**FAST)
    env.reset(seed=6)
    assert not env._touching()  # the magnet starts 0.2 m up
    com = env.com_position()
    monkeypatch.setattr(env, "_p1", com + [0.0, 0.0, 0.019])  # 18.4 mm from the centre: within 17.7 + 2 mm
    assert env._touching()
    monkeypatch.setattr(env, "_touching", lambda: True)
    _, _, terminated, truncated, info = env.step(env.action_of_pose(env.magnet_position))
    assert terminated and not truncated and info["magnet_contact"]
    env.close()


def test_magnet_field_is_the_posed_magnet():
    from magsoft_env.fields import PosedMagnet

    env = MagSoftMagnetEnv(tilt=True, **FAST)
    env.reset(seed=5)
    env.action_space.seed(5)
    for _ in range(3):
        _, _, _, _, info = env.step(env.action_space.sample())
    src = PosedMagnet(env.magnet, env.workspace).at_pose(info["magnet_position"], info["magnet_axis"])
    B, _ = src.field_and_gradient(env.com_position()[None])
    np.testing.assert_allclose(info["field"], B[0], rtol=1e-9, atol=1e-15)
    env.close()


@pytest.mark.parametrize(("cls", "kwargs", "name"), [
    (MagSoftCoilsEnv, {"coils": "navoin"}, "coils"),
    (MagSoftCoilsEnv, {"coil_tau": -1e-3}, "coil_tau"),
    (MagSoftCoilsEnv, {"slew_rate": 0.0}, "slew_rate"),
    (MagSoftCoilsEnv, {"coils_origin": (0.0, 0.0)}, "coils_origin"),
    (MagSoftCoilsEnv, {"current_cost_weight": -1.0}, "current_cost_weight"),
    (MagSoftCoilsEnv, {"field_scale": 3.0}, "field_scale"),
    (MagSoftCoilsEnv, {"field_limit": 0.003}, "field_limit"),
    (MagSoftCoilsEnv, {"action_mode": "waveform"}, "action_mode"),
    (MagSoftCoilsEnv, {"colis": "navion"}, "colis"),
    (MagSoftMagnetEnv, {"remanence": 2.0}, "remanence"),
    (MagSoftMagnetEnv, {"magnet_diameter": -0.01}, "magnet_diameter"),
    (MagSoftMagnetEnv, {"magnet_length": 25.0}, "magnet_length"),
    (MagSoftMagnetEnv, {"workspace_bounds": [[0, 1], [0, 1]]}, "workspace_bounds"),
    (MagSoftMagnetEnv, {"workspace_bounds": [[0, 0.1], [0, 0.1], [0.0, 0.1]]}, "workspace_bounds"),
    (MagSoftMagnetEnv, {"max_speed": 0.0}, "max_speed"),
    (MagSoftMagnetEnv, {"max_turn_rate": -1.0}, "max_turn_rate"),
    (MagSoftMagnetEnv, {"max_tilt": 4.0}, "max_tilt"),
    (MagSoftMagnetEnv, {"tilt": "yes"}, "tilt"),
])
def test_bad_arguments(cls, kwargs, name):
    with pytest.raises(ValueError, match=name):
        cls(**FAST, **kwargs)


@pytest.mark.parametrize("env_id", ["MagSoftCoils-v0", "MagSoftMagnet-v0"])
def test_vector_env_is_the_single_env(env_id):
    n, steps = 2, 3
    envs = gym.make_vec(env_id, num_envs=n, **FAST)
    singles = [gym.make(env_id, **FAST).unwrapped for _ in range(n)]
    obs, _ = envs.reset(seed=10)
    rng = np.random.default_rng(0)
    ref = [s.reset(seed=10 + i)[0] for i, s in enumerate(singles)]
    np.testing.assert_array_equal(obs, np.stack(ref))
    for _ in range(steps):
        a = rng.uniform(-1, 1, envs.action_space.shape).astype(np.float32)
        obs, rew, term, trunc, _ = envs.step(a)
        out = [s.step(a[i]) for i, s in enumerate(singles)]
        np.testing.assert_array_equal(obs, np.stack([o[0] for o in out]))
        np.testing.assert_array_equal(rew, [o[1] for o in out])
    envs.close()
    for s in singles:
        s.close()

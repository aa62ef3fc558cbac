"""The 3D strip in every crawl environment: the same observation and action contract, the channel's walls and the
obstacle as 3D geometry the strip touches, the C batch, and paper-5c's crawl beside the planar chain's."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.sim import RodOptions, Simulator

IDS = ("MagSoftCrawl-v1", "MagSoftCrawlWaveform-v1", "MagSoftChannel-v1", "MagSoftObstacle-v1")


@pytest.mark.parametrize("env_id", IDS)
def test_every_crawl_id_takes_the_strip_with_the_same_contract(env_id):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    strip = gym.make(env_id, rod="cable", fidelity="fast")
    chain = gym.make(env_id, fidelity="fast")
    assert strip.observation_space == chain.observation_space and strip.action_space == chain.action_space
    u = strip.unwrapped
    assert u.rod == "cable" and u.sim.options.scene == chain.unwrapped.sim.options.scene
    check_env(u, skip_render_check=True)
    sb3_check_env(u)
    obs, info = strip.reset(seed=2)
    for _ in range(2):
        obs, r, term, trunc, info = strip.step(u.open_loop_action(u.sim.time))
    assert np.all(np.isfinite(obs)) and not trunc
    assert {"highest_clearance", "airborne_fraction", "largest_piece_angle", "reward_forward"} <= set(info)
    strip.close()
    chain.close()


@pytest.mark.parametrize("scene", ["channel", "obstacle"])
def test_the_scene_boxes_are_3d_geometry_the_strip_touches(scene):
    beam = gait_preset("paper-5c").beam
    # the feature placed through the strip's end: its start overlaps it, which the scene's contact sensor sees
    # (the channel's ceiling is 7.6 mm up: its wall is what reaches the strip, from the side, when moved in y)
    x = beam.length - 2e-3
    sim = Simulator(beam, RodOptions(rod="cable", scene=scene, segments=10, timestep=2e-4, feature_x=x))
    assert sim.backend.has_feature
    names = {sim.model.geom(i).name for i in range(sim.model.ngeom)}
    assert ({"channel_ceiling", "channel_wall_left", "channel_wall_right"} if scene == "channel"
            else {"obstacle"}) <= names
    if scene == "obstacle":
        assert sim.initial_overlap > 0.0  # the block cuts the strip's end
        sim.step(50)  # the strip is pushed out of the block, not through it
        assert sim.max_penetration < 1.5 * beam.thickness
    else:
        sim.step(50)
        assert sim.max_penetration < 0.1 * beam.thickness  # inside the box, on its floor


def test_the_c_batch_steps_each_strip_as_the_single_env():
    v = gym.make_vec("MagSoftCrawl-v1", num_envs=2, rod="cable", fidelity="fast")
    obs, _ = v.reset(seed=1)
    a = np.array([[0.3, -0.5], [0.0, 0.8]], dtype=np.float32)
    for _ in range(2):
        obs, r, *_ = v.step(a)
    s = gym.make("MagSoftCrawl-v1", rod="cable", fidelity="fast")
    o, _ = s.reset(seed=1)
    for _ in range(2):
        o, r0, *_ = s.step(a[0])
    np.testing.assert_array_equal(obs[0], o)
    assert r[0] == r0
    v.close()
    s.close()


def test_the_warp_batch_refuses_the_strip_naming_what_runs():
    with pytest.raises(ValueError, match="backend='cpu'"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=2, rod="cable", backend="warp")


@pytest.mark.slow
def test_paper_5c_crawls_on_the_strip_within_5_percent_of_the_chain():
    """Open-loop paper-5c for 6 s in MagSoftCrawl-v1, the strip at its gait numerics against the chain at the same
    numerics (30 segments, 0.2 ms), in one process (measured: -0.3663 against -0.3756 mm/s, -2.5 %)."""
    speeds = {}
    for rod in ("cable", "planar"):
        kw = {} if rod == "cable" else {"segments": 30, "sim_dt": 2e-4}
        env = gym.make("MagSoftCrawl-v1", rod=rod, max_episode_steps=10_000, **kw)
        u = env.unwrapped
        _, info = env.reset(seed=0)
        x0 = info["x_position"]
        while u.sim.time < 6.0 - 1e-9:
            _, _, term, trunc, info = env.step(u.open_loop_action(u.sim.time))
            assert not (term or trunc)
        speeds[rod] = (info["x_position"] - x0) / u.sim.time
        env.close()
    assert speeds["planar"] < 0.0
    assert abs(speeds["cable"] / speeds["planar"] - 1.0) < 0.05

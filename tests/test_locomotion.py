"""Honest locomotion: every free-moving env says how the robot moved (clearance, airborne fraction, roll, mode), the
steering envs offer the crawl limits, and the limits' texts read their figures apart."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.envs.crawl_task import (
    AIRBORNE_TOLERANCE,
    LOCOMOTION_MODES,
    CrawlTask,
    crawl_limits,
    locomotion_modes,
    violation_texts,
)

TASK = CrawlTask(crawl_mode="rotation", max_clearance=1e-5, max_link_rotation=2.0, max_height=7.6e-3,
                 forward_reward_weight=1000.0, target_direction=1, field_cost_weight=0.1, crawl_penalty=10.0,
                 field_limit=2e-3, clock_frequency=2.0)


def test_locomotion_modes_by_their_definitions():
    modes = locomotion_modes([False, False, False, True, True], [0, 3, 0, 0, 5], [0.1, 0.1, 2.0, 0.0, 0.0])
    assert modes.tolist() == ["crawl", "hop", "roll", "tumble", "tumble with flight"]
    assert set(modes) <= set(LOCOMOTION_MODES)


def test_a_strip_touching_the_floor_on_edge_is_not_airborne():
    # a strip standing on its narrow face: its centreline w/2 above the floor, minus h/2: 1.9 mm of "clearance"
    w, h = 5e-3, 1.13e-3
    pts = np.zeros((1, 4, 1, 3))
    pts[0, :, 0, 0] = [0.0, 5e-3, 10e-3, 15e-3]
    pts[..., 2] = 0.5 * w
    inv = np.full(3, 1 / 5e-3)
    lifted = crawl_limits(pts, [0.0], half_thickness=0.5 * h, inv_piece_length=inv)
    touching = crawl_limits(pts, [0.0], half_thickness=0.5 * h, inv_piece_length=inv, floor_contact=[[-1e-7]])
    assert lifted[0, 0, 0] == pytest.approx(0.5 * (w - h)) and lifted[0, 0, 0] > AIRBORNE_TOLERANCE
    assert touching[0, 0, 0] == 0.0  # in contact: on the floor, whatever the centreline's height
    # a capsule that touches reads its own (negative) clearance, unchanged
    pts[..., 2] = 0.5 * h - 1e-6
    both = [crawl_limits(pts, [0.0], half_thickness=0.5 * h, inv_piece_length=inv, floor_contact=c)
            for c in (None, [[-1e-6]])]
    np.testing.assert_array_equal(both[0], both[1])


def test_violation_texts_read_their_figures_apart():
    figures = np.array([[1.00004e-5, 1e-3, 1.0]])  # just past the 0.010 mm clearance limit
    text = violation_texts(figures, np.array([0.1]), TASK, np.array([True]))[0]
    assert "0.010 mm above the floor > 0.010 mm" not in text
    assert "0.0100004 mm above the floor > 0.0100000 mm" in text
    got, lim = text.split("above the floor > ")[0].split()[-2], text.split("> ")[1].split()[0]
    assert float(got) > float(lim)


@pytest.mark.parametrize("rod", ["planar", "cable"])
def test_crawl_env_info_says_how_the_robot_moved(rod):
    env = gym.make("MagSoftCrawl-v1", rod=rod, fidelity="fast")
    u = env.unwrapped
    _, info = env.reset(seed=0)
    assert info["locomotion"] == "crawl" and info["airborne_fraction"] == 0.0
    for _ in range(10):
        _, _, term, trunc, info = env.step(u.open_loop_action(u.sim.time))
        assert not (term or trunc)
    assert info["locomotion"] == "crawl" and info["airborne_fraction"] == 0.0 and info["max_roll"] < 0.05
    env.close()
    # a strong field lifts the beam: a hop, airborne at some substeps, the crawl limits off
    env = gym.make("MagSoftCrawl-v1", rod=rod, fidelity="fast", crawl_mode="none", max_clearance=None,
                   field_limit=0.02)
    env.reset(seed=0)
    for _ in range(5):
        _, _, _, _, info = env.step(np.array([1.0, 1.0], np.float32))
    assert info["airborne_fraction"] > 0.0 and info["locomotion"] in ("hop", "tumble with flight")
    env.close()


def test_steering_env_reports_flights_and_offers_the_crawl_limits():
    env = gym.make("MagSoftSteer-v0")
    u = env.unwrapped
    obs, info = env.reset(seed=1003)
    assert {"highest_clearance", "airborne_fraction", "largest_piece_angle", "max_roll", "locomotion",
            "reward_crawl"} <= set(info)
    for _ in range(40):
        obs, r, term, trunc, info = env.step(u.baseline_action(obs))
        if term or trunc:
            break
    # the hand controller's tumble leaves the floor at some substeps (no floor contact, centreline above h/2)
    assert 0.0 < info["airborne_fraction"] < 1.0 and info["locomotion"] == "tumble with flight"
    assert sum(info[k] for k in ("reward_progress", "reward_field", "reward_crawl", "reward_success")) \
        == pytest.approx(info["reward"])
    env.close()
    env = gym.make("MagSoftSteer-v0", crawl_mode="rotation")
    u = env.unwrapped
    obs, _ = env.reset(seed=1003)
    obs, r, term, trunc, info = env.step(u.baseline_action(obs))
    assert term and "crawl_violation" in info and info["reward_crawl"] == -10.0 and info["reward_progress"] == 0.0
    env.close()
    with pytest.raises(ValueError, match="crawl_mode"):
        gym.make("MagSoftSteer-v0", crawl_mode="tumble")

"""A crawler that flips end over end is reported as a tumble (gait results, CLI, the crawl env's info)."""

from __future__ import annotations

import dataclasses
import json
import math

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import magsoft_env  # noqa: F401  (registers the envs)
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.cli import main
from magsoft_env.sim import RodOptions, Simulator
from magsoft_env.sim.gait import run_gait
from magsoft_env.sim.readouts import FLIP_ANGLE, body_orientation, is_flipped, orientation
from magsoft_env.spec import Beam

#: paper-5c with a 7.14 % stronger field flips end over end within 0.3 s (measured: past vertical at 0.27 s)
FLIP_SCALE = 1.0714


def _scaled(k: float):
    p = gait_preset("paper-5c")
    w = p.wave
    return dataclasses.replace(p, drive=dataclasses.replace(w, amplitude_x=w.amplitude_x * k,
                                                            amplitude_z=w.amplitude_z * k))


def test_body_orientation_is_the_length_weighted_mean_unwrapped_and_anchored():
    assert body_orientation([0.1, 0.3], [1.0, 3.0]) == pytest.approx(0.25)
    # across +-pi the chain is unwrapped: a beam lying upside down reads pi, not 0
    assert body_orientation([3.1, -3.1], [1.0, 1.0]) == pytest.approx(math.pi)
    # the anchor (the last piece's continuous angle) adds whole turns
    assert body_orientation([0.0, 0.2], [1.0, 1.0], anchor=0.2 + 4 * math.pi) == pytest.approx(0.1 + 4 * math.pi)
    assert is_flipped(FLIP_ANGLE + 1e-9) and is_flipped(-2.0) and not is_flipped(FLIP_ANGLE)
    with pytest.raises(ValueError, match="lengths"):
        body_orientation([0.0, 0.1], [0.0, 0.0])
    with pytest.raises(ValueError, match="shape"):
        body_orientation([0.0, 0.1], [1.0])


def test_orientation_of_a_simulator_follows_the_pieces():
    beam = Beam(length=20e-3, width=5e-3, thickness=1e-3)
    sim = Simulator(beam, RodOptions(scene="cantilever", segments=6, clamp_angle=0.3, gravity=0.0))
    assert orientation(sim) == pytest.approx(0.3, abs=1e-12)  # a straight beam: its clamp angle
    sim.data.qpos[sim.rod.hinge_qpos] = 0.1  # a uniform bend
    mujoco.mj_forward(sim.model, sim.data)
    s = sim.arc_length()
    expected = np.diff(s) @ sim.angles() / s[-1]
    assert orientation(sim) == pytest.approx(expected, abs=1e-12) and expected > 0.3
    sim.data.qpos[sim.rod.hinge_qpos] = 0.6  # curled past a full turn: whole turns counted (tip angle 3.9 rad)
    mujoco.mj_forward(sim.model, sim.data)
    assert sim.tip_angle() == pytest.approx(0.3 + 6 * 0.6)
    assert orientation(sim) == pytest.approx(np.diff(s) @ np.unwrap(sim.angles()) / s[-1], abs=1e-12)


def test_plain_paper_5c_crawls_without_flipping():
    res = run_gait("paper-5c", 1.5)
    assert res.locomotion == "crawl" and not res.flipped
    assert res.max_orientation < math.radians(30)  # measured 19.8 deg
    assert math.isfinite(res.speed) and res.direction == "left" and res.message == "ok"
    assert math.isnan(res.flip_time)


def test_a_flipped_gait_is_a_tumble_without_crawl_speed():
    res = run_gait(_scaled(FLIP_SCALE), 1.0)
    assert res.success and res.flipped and res.locomotion == "tumble"
    assert math.isnan(res.speed) and res.direction == "tumble"
    assert res.max_orientation > math.pi / 2 and 0.0 < res.flip_time < 0.5
    assert res.message.startswith("tumbled:")
    d = res.to_dict()
    assert d["speed_mm_s"] is None and d["locomotion"] == "tumble" and d["flipped"] is True
    assert abs(d["displacement_mm"]) > 5  # the tumble's lurch (-19.3 mm in 2 s)


def test_gait_cli_reports_the_tumble(capsys):
    assert main(["gait", "--preset", "paper-5c", "--field-scale", str(FLIP_SCALE), "--seconds", "1"]) == 0
    text = capsys.readouterr().out
    assert "TUMBLE: the robot flipped end over end" in text
    assert "TUMBLE" in text and "speed" not in text.split("TUMBLE")[1].split("paper:")[0].replace("no crawl speed", "")
    assert main(["gait", "--preset", "paper-5c", "--field-scale", str(FLIP_SCALE), "--seconds", "1", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["locomotion"] == "tumble" and out["speed_mm_s"] is None and out["direction"] == "tumble"


def test_crawl_env_info_carries_orientation_and_flipped():
    wave = _scaled(FLIP_SCALE).wave
    env = gym.make("MagSoftCrawl-v1", crawl_mode="none", field_limit=3e-3)
    base = env.unwrapped
    _, info = env.reset(seed=0)
    assert info["flipped"] is False and abs(info["orientation"]) < 0.01
    flipped_at = None
    for k in range(30):  # 0.6 s
        _, _, term, trunc, info = env.step(base.open_loop_action(base.sim.time, wave))
        assert info["orientation"] == pytest.approx(orientation(base.sim))
        if info["flipped"] and flipped_at is None:
            flipped_at = k
        assert not (term or trunc)
    assert flipped_at is not None and info["flipped"]  # stays set for the episode
    _, info = env.reset(seed=0)  # a new episode starts unflipped
    assert info["flipped"] is False
    for _ in range(30):
        _, _, _, _, info = env.step(base.open_loop_action(base.sim.time))
    assert info["flipped"] is False and abs(info["orientation"]) < math.radians(30)
    env.close()


def test_readouts_examples_run():
    import doctest

    import magsoft_env.sim.readouts as readouts

    result = doctest.testmod(readouts, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0 and result.attempted > 0


def test_body_orientation_matches_numpy_unwrap_on_random_chains():
    rng = np.random.default_rng(0)
    for _ in range(500):
        n = int(rng.integers(1, 30))
        true = np.cumsum(rng.uniform(-3.0, 3.0, n))  # neighbours differ by less than pi
        w = rng.uniform(0.0, 1.0, n) + 1e-3
        wrapped = np.angle(np.exp(1j * true))
        unwrapped = np.unwrap(wrapped)
        assert body_orientation(wrapped, w) == pytest.approx(w @ unwrapped / w.sum(), abs=1e-12)
        anchor = true[-1]
        assert body_orientation(wrapped, w, anchor=anchor) == pytest.approx(w @ true / w.sum(), abs=1e-9)


def test_orientation_of_a_non_finite_state_is_nan():
    assert math.isnan(body_orientation(np.array([0.0, np.nan, 0.1]), np.ones(3), anchor=np.nan))

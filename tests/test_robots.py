"""Robots as files: every profile family round-trips exactly, the files run everywhere a preset name does."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import magsoft_env as ms
from magsoft_env.cases.gaits import PAPER_5A_VEES, beam_5a, beam_5b
from magsoft_env.cases.robots import Robot, load_robot
from magsoft_env.spec.drive import Waveparams

L, W, H = 24e-3, 5e-3, 1.13e-3


def _beams():
    """One beam per profile family a file can hold."""
    mm = 1e-3
    yield "cells", ms.Beam(L, W, H, volume_fraction=ms.PiecewiseConstant([0.1, 0.25, 0.15], [1, 2, 1]),
                           magnetization=ms.alternating_cells(3, angle=0.3))
    yield "polyline", ms.Beam(L, W, H, magnetization=ms.jig_from_polyline([0, 8 * mm, 16 * mm, 24 * mm],
                                                                           [0, -2 * mm, 0.5 * mm, -1 * mm]))
    yield "points", ms.Beam(18e-3, W, H, magnetization=ms.jig_from_points(
        np.linspace(0, 18 * mm, 7), 2 * mm * np.sin(np.linspace(0, 3, 7)), corners=[3]))
    yield "piecewise_linear", ms.Beam(L, W, H, volume_fraction=ms.PiecewiseLinear([0, 0.01, L], [0.1, 0.3, 0.2]),
                                      magnetization=ms.PiecewiseLinear([0, 0.012, L], [0.0, 1.0, -0.5]))
    yield "samples", ms.Beam(L, W, H, volume_fraction=ms.Sampled(np.linspace(0, L, 9), 0.2 + 0.05 * np.sin(
        np.linspace(0, 3, 9))), magnetization=ms.Sampled(np.linspace(0, L, 17), np.linspace(-1, 1, 17) ** 3))
    yield "uniform", ms.Beam(L, W, H, volume_fraction=0.17, magnetization=math.radians(12.5),
                             material=ms.Material(E0=0.08e6, particle_magnetization=600e3, density=2100.0))
    yield "rule_of_mixtures", ms.Beam(L, W, H, material=ms.Material.rule_of_mixtures(), volume_fraction=0.2)


@pytest.mark.parametrize("kind,beam", list(_beams()), ids=[k for k, _ in _beams()])
@pytest.mark.parametrize("suffix", [".yml", ".json"])
def test_every_profile_family_round_trips_exactly(tmp_path, kind, beam, suffix):
    robot = Robot(f"my-{kind}", beam, description="a test robot", friction=0.7, retardation_time=3e-3,
                  drive=Waveparams(1e-3, -1.5e-3, 2.5, 0.4), segments=16)
    path = robot.save(tmp_path / f"robot{suffix}")
    back = load_robot(path)
    assert back == robot  # every field, profiles included, to the last bit
    s = np.linspace(0.0, beam.length, 2001)
    assert np.array_equal(back.beam.beta(s), beam.beta(s))
    assert np.array_equal(back.beam.phi(s), beam.phi(s))


def test_reloaded_robot_gives_the_same_equilibrium(tmp_path):
    beam = dict(_beams())["points"]
    path = Robot("eq", beam).save(tmp_path / "eq.yml")
    a = ms.solve_equilibrium(beam, (2e-3, 8e-3))
    b = ms.solve_equilibrium(load_robot(path).beam, (2e-3, 8e-3))
    assert a.success and b.success
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.z, b.z)


def test_a_python_function_profile_is_refused_or_sampled(tmp_path):
    beam = ms.Beam(L, W, H, magnetization=lambda s: 0.5 * np.sin(2 * np.pi * s / L))
    robot = Robot("free", beam)
    with pytest.raises(ValueError, match="Python function.*sample_functions=True"):
        robot.save(tmp_path / "free.yml")
    assert not (tmp_path / "free.yml").exists()
    back = load_robot(robot.save(tmp_path / "free.yml", sample_functions=True))
    s = np.linspace(0, L, 1001)
    assert np.max(np.abs(back.beam.beta(s) - beam.beta(s))) < 1e-6  # a 257-point spline of a sine
    a, b = ms.solve_equilibrium(beam, (0, 5e-3)), ms.solve_equilibrium(back.beam, (0, 5e-3))
    assert abs(a.x[-1] - b.x[-1]) < 1e-6 * L and abs(a.z[-1] - b.z[-1]) < 1e-6 * L


def test_expression_profiles_round_trip(tmp_path):
    text = """
magsoft_robot: 1
name: expr
beam:
  length_mm: 20
  width_mm: 5
  thickness_mm: 1.13
  volume_fraction: {kind: expression, phi: "0.1 + 0.1*s/20"}
  magnetization: {kind: expression, angle_deg: "where(s < 10, 30, -30)", kinks_s_mm: [10]}
"""
    (tmp_path / "expr.yml").write_text(text)
    robot = load_robot(tmp_path / "expr.yml")
    assert robot.beam.phi(0.02) == pytest.approx(0.2)
    assert robot.beam.beta(0.005) == pytest.approx(math.radians(30))
    assert robot.beam.breakpoints() == pytest.approx((0.01,))
    assert load_robot(robot.save(tmp_path / "again.json")) == robot


def test_built_in_robot_files_are_the_paper_robots():
    assert ms.list_robots() == ("paper-5a", "paper-5b", "paper-5c")
    assert load_robot("paper-5a").beam == beam_5a(vees=PAPER_5A_VEES)
    assert load_robot("paper-5b").beam == beam_5b()
    c = load_robot("paper-5c")
    assert c.beam.length == pytest.approx(23.889e-3, abs=1e-6) and c.drive.phase == pytest.approx(math.pi / 2)
    # each robot's own numerics: the cheapest measured within 5 % of the converged crawl (docs/convergence.md)
    numerics = {name: (load_robot(name).segments, load_robot(name).timestep) for name in ms.list_robots()}
    assert numerics == {"paper-5a": (80, 1e-4), "paper-5b": (80, 2.5e-5), "paper-5c": (20, 2e-4)}


def test_built_in_robots_carry_the_papers_speeds():
    # paper Fig. 5: 5a crawls left at 0.85 mm/s, 5b gives no speed, 5c crawls both ways at 3 mm/s
    paper = {name: (load_robot(name).paper_speed, load_robot(name).paper_direction) for name in ms.list_robots()}
    assert paper == {"paper-5a": (-0.85e-3, "left"), "paper-5b": (None, "left"), "paper-5c": (3e-3, "reversible")}
    assert ms.gait_preset("paper-5c", reverse=True).paper_speed == 3e-3  # a magnitude: the same either way


@pytest.mark.parametrize("speed, direction, want", [(1e-3, "left", "< 0"), (-1e-3, "right", "> 0"),
                                                    (-3e-3, "reversible", ">= 0")])
def test_paper_speed_sign_must_agree_with_the_direction(speed, direction, want):
    beam = ms.Beam(25e-3, 5e-3, 1.13e-3)
    with pytest.raises(ValueError, match=f"Robot.paper_speed must be {want}.*{direction!r}, got {speed!r}"):
        ms.Robot("x", beam, paper_speed=speed, paper_direction=direction)


def test_robot_numerics_round_trip_and_default(tmp_path):
    text = "name: x\nbeam: {width_mm: 5, thickness_mm: 1, length_mm: 20}\n"
    (tmp_path / "plain.yml").write_text(text)
    plain = load_robot(tmp_path / "plain.yml")
    assert (plain.segments, plain.timestep) == (ms.cases.robots.DEFAULT_SEGMENTS, 2e-4)
    fine = plain.replace(segments=80, timestep=2.5e-5)
    assert load_robot(fine.save(tmp_path / "fine.yml")).timestep == 2.5e-5
    assert load_robot(fine.save(tmp_path / "fine.json")) == fine
    for bad in (0.0, -1e-4, 0.5, float("nan")):
        with pytest.raises(ValueError, match="timestep"):
            plain.replace(timestep=bad)
    (tmp_path / "bad.yml").write_text(text + "simulation: {timestep_ms: 0}\n")
    with pytest.raises(ValueError, match="timestep"):
        load_robot(tmp_path / "bad.yml")

    # a scene's own numerics (the channel's ceiling needs finer ones for paper-5c: docs/convergence.md)
    from magsoft_env.cases.gaits import numerics

    c = load_robot("paper-5c")
    assert c.scene_numerics == (("channel", 40, 1e-4),)
    assert numerics(c) == numerics(c, scene="obstacle") == (20, 2e-4)
    assert numerics(c, scene="channel") == (40, 1e-4) and numerics(c, scene="channel", segments=10) == (10, 1e-4)
    assert numerics(c, scene="channel", fidelity="fast") == (20, 2e-4)
    assert load_robot(c.save(tmp_path / "c.yml")) == c
    for bad, message in ((("tunnel", 40, 1e-4),), "scene must be one of"), \
                        ((("channel", 40, 1e-4), ("channel", 20, 1e-4)), "twice"), \
                        ((("channel", 40, 0.5),), "timestep must lie in"), ((("channel", 1, 1e-4),), "segments"):
        with pytest.raises(ValueError, match=message):
            plain.replace(scene_numerics=bad)
    (tmp_path / "bad2.yml").write_text(text + "simulation: {scenes: {chanel: {segments: 40, timestep_ms: 0.1}}}\n")
    with pytest.raises(ValueError, match="Did you mean 'channel'"):
        load_robot(tmp_path / "bad2.yml")
    (tmp_path / "bad3.yml").write_text(text + "simulation: {scenes: {channel: {segments: 40}}}\n")
    with pytest.raises(ValueError, match="needs key 'timestep_ms'"):
        load_robot(tmp_path / "bad3.yml")


@pytest.mark.parametrize("content,message", [
    ("name: x\nbeam: {width_mm: 5, thickness_mm: 1, length_mm: 20}\ncontakt: {}\n", "Did you mean 'contact'"),
    ("name: x\nbeam: {width_mm: 5, thickness_mm: 1, length_mm: 20}\ncontact: {friction: -1}\n", "friction"),
    ("name: x\nbeam: {width_mm: 5, thickness_mm: 1}\n", "needs length_mm"),
    ("magsoft_robot: 7\nname: x\nbeam: {width_mm: 5, thickness_mm: 1, length_mm: 20}\n", "format version 7"),
    ("name: x\nbeam: [1, 2\n", "not valid YML"),
    ("name: x\nbeam: {width_mm: 5, thickness_mm: 1, length_mm: 20, magnetization: {kind: jig_polylin}}\n",
     "kind must be one of"),
])
def test_bad_robot_files_say_what_is_wrong(tmp_path, content, message):
    path = tmp_path / "bad.yml"
    path.write_text(content)
    with pytest.raises(ValueError, match=message):
        load_robot(path)


def test_bad_robot_sources():
    with pytest.raises(ValueError, match="Did you mean 'paper-5c'"):
        load_robot("paper5c")
    with pytest.raises(ValueError, match="does not exist"):
        load_robot("nowhere/robot.yml")
    with pytest.raises(ValueError, match="must end in one of"):
        Robot("x", beam_5b()).save("robot.txt")
    with pytest.raises(ValueError, match="retardation_time must lie in"):
        Robot("x", beam_5b(), retardation_time=5.0)


def test_a_robot_file_runs_in_every_floor_env_and_the_cli(tmp_path):
    beam = dict(_beams())["polyline"]
    path = Robot("mine", beam, drive=Waveparams(0.0, 1.5e-3, 2.0), segments=10).save(tmp_path / "mine.yml")
    for env_id in ("MagSoftCrawl-v1", "MagSoftChannel-v1", "MagSoftObstacle-v1"):
        env = gym.make(env_id, robot=str(path), segments=10)
        assert env.unwrapped.gait.beam == beam
        env.close()
    env = gym.make("MagSoftCrawl-v1", robot=path, segments=10)
    check_env(env.unwrapped, skip_render_check=True)
    shape = gym.make("MagSoftShape-v0", robot=str(path), segments=10)
    assert shape.unwrapped.beam == beam
    with pytest.raises(ValueError, match="robot or length, not both"):
        gym.make("MagSoftShape-v0", robot=str(path), length=0.02)
    out = subprocess.run([sys.executable, "-m", "magsoft_env.cli", "gait", "--robot", str(path), "--seconds", "1.0",
                          "--timestep-ms", "0.5", "--segments", "8", "--json"], capture_output=True, text=True,
                         timeout=300)
    assert out.returncode == 0, out.stderr
    res = json.loads(out.stdout)
    assert res["preset"] == "mine" and res["whole_periods"] and res["speed_window_s"] == pytest.approx(0.5)


def test_a_statics_preset_may_name_a_robot(tmp_path):
    path = tmp_path / "p.json"
    path.write_text(json.dumps({"description": "5c in a field", "robot": "paper-5c",
                                "path": [{"from_mT": [0, 0], "to_mT": [0, 5], "steps": 3}]}))
    assert ms.load_preset(str(path)).beam == load_robot("paper-5c").beam
    path.write_text(json.dumps({"description": "both", "robot": "paper-5c", "beam": {},
                                "path": [{"field_mT": [0, 5]}]}))
    with pytest.raises(ValueError, match="exactly one of 'beam'"):
        ms.load_preset(str(path))


@pytest.mark.slow
def test_random_actions_at_the_registered_coil_limit_crawl_for_50_steps_or_more_when_hops_are_allowed():
    # 2 mT keeps random actions from tumbling the beam; they do lift it off the floor within a few steps (the
    # default crawl limit), so the episode lengths are measured with hops of up to 2 mm allowed
    env = gym.make("MagSoftCrawl-v1", max_clearance=2e-3)
    env.action_space.seed(0)
    lengths = []
    for ep in range(4):
        env.reset(seed=ep)
        n, done = 0, False
        while not done:
            _, _, term, trunc, _ = env.step(env.action_space.sample())
            n, done = n + 1, term or trunc
        lengths.append(n)
    assert np.mean(lengths) >= 50, lengths


def test_design_writes_a_robot_file_that_loads_and_reproduces_the_design(tmp_path):
    from magsoft_env.cli import main

    assert main(["design", "--target", "ball", "--quiet", "--no-figures", "--points", "20", "--starts", "1",
                 "--max-nfev", "12", "--out", str(tmp_path)]) in (0, 1)  # 1: a loose fit, still written
    robot = load_robot(tmp_path / "robot.yml")
    assert robot.name == "design-ball" and robot.drive is None
    assert isinstance(robot.beam.magnetization, ms.Sampled)  # the spline's knots, not samples of it
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert robot.beam.length == pytest.approx(summary["length_mm"] * 1e-3, rel=1e-9)


def test_solve_and_crosscheck_take_a_robot(tmp_path, capsys):
    from magsoft_env.cli import main

    path = Robot("strip", dict(_beams())["cells"]).save(tmp_path / "strip.json")
    assert main(["solve", "--robot", str(path), "--steps", "3", "--no-plot", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "solve_strip.json").is_file()
    assert main(["crosscheck", "--robot", str(path), "--segments", "8", "--steps", "3", "--field-mT", "0", "4"]) == 0
    assert "strip" in capsys.readouterr().out
    assert main(["solve", "--robot", str(path), "--preset", "fig3a_L25"]) == 2
    assert "give --robot, --preset or beam parameters" in capsys.readouterr().err

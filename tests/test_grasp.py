"""Grasp scene (magsoft_env.compare.grasp): grippers close on an object in MuJoCo and lift it."""

import math

import numpy as np
import pytest

pytest.importorskip("mujoco")

import magsoft_env as ms  # noqa: E402
from magsoft_env.compare.grasp import (  # noqa: E402
    GraspOptions,
    GraspScene,
    _polygon_properties,
    contour_aligned_beam,
    design_gripper,
    hanging_target,
    max_lift_mass,
)
from magsoft_env.design import curve_length  # noqa: E402

FAST = GraspOptions(segments=10, timestep=2e-4, ramp_time=0.2, settle_time=0.1, lift_time=0.2, hold_time=0.2)


@pytest.fixture(scope="module")
def ball_scene():
    tgt = hanging_target("ball")
    beam = ms.Beam(length=curve_length(tgt), width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
    return GraspScene(contour_aligned_beam(tgt, beam), (0.0, 20e-3), tgt, FAST)


def test_hanging_target_is_the_mirrored_contour():
    from magsoft_env.design import builtin_target

    raw = builtin_target("vase")
    t = hanging_target("vase")
    assert np.allclose(t[0], 0.0)
    assert np.allclose(t[:, 0], raw[:, 0] - raw[0, 0])
    assert np.allclose(t[:, 1], -(raw[:, 1] - raw[0, 1]))
    assert t[:, 1].max() <= 1e-12  # the finger goes down from the carrier


def test_contour_aligned_profile_is_the_alignment_guess():
    tgt = hanging_target("ball")
    beam = ms.Beam(length=curve_length(tgt), width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
    b = contour_aligned_beam(tgt, beam)
    # the ball's tangent turns from 0 to -135 degrees: beta = pi/2 - theta runs from 90 to 225 degrees
    assert b.beta(0.0) == pytest.approx(0.5 * math.pi, abs=0.03)
    assert b.beta(b.length) == pytest.approx(0.5 * math.pi + 0.75 * math.pi, abs=0.05)


def test_polygon_properties_of_a_circle():
    r = 0.01
    a = np.linspace(0, 2 * np.pi, 721)[:-1]
    poly = np.column_stack([1 + r * np.cos(a), 2 + r * np.sin(a)])
    area, c, j = _polygon_properties(poly)
    assert area == pytest.approx(np.pi * r**2, rel=1e-4)
    assert np.allclose(c, [1, 2], atol=1e-9)
    assert j == pytest.approx(0.5 * r**2, rel=1e-4)


def test_gripper_holds_a_light_object_and_drops_a_heavy_one(ball_scene):
    light = ball_scene.trial(0.2 * ball_scene.gripper_mass)
    heavy = ball_scene.trial(20.0 * ball_scene.gripper_mass)
    assert light.stable and heavy.stable
    assert light.lifted and light.rise > 0.5 * FAST.lift_height
    assert not heavy.lifted and heavy.rise < 0.1 * FAST.lift_height  # it stays on the table


def test_field_off_lifts_nothing(ball_scene):
    t = ball_scene.trial(0.05 * ball_scene.gripper_mass, field_on=False)
    assert t.stable and not t.lifted
    assert t.rise < 0.1 * FAST.lift_height


def test_max_lift_mass_brackets_the_threshold(ball_scene):
    res = max_lift_mass(ball_scene, rel_tol=0.3, max_ratio=64.0)
    assert 0.0 < res.ratio < res.upper_ratio <= 1.3 * res.ratio + 1e-12
    assert res.max_mass == pytest.approx(res.ratio * ball_scene.gripper_mass)
    assert res.gripper_mass == pytest.approx(2 * ball_scene.beam.mass(), rel=1e-3)
    held = [t.object_mass for t in res.trials if t.lifted]
    dropped = [t.object_mass for t in res.trials if not t.lifted]
    assert max(held) == pytest.approx(res.max_mass) and min(dropped) > max(held)


@pytest.mark.slow
def test_designed_ball_gripper_matches_its_contour_and_lifts():
    res = design_gripper("ball")
    assert res.success and res.rms_error_percent < 0.25
    assert res.target_xz[:, 1].min() < -0.015  # wraps below the ball's equator
    scene = GraspScene(res.beam, res.field, hanging_target("ball"), FAST)
    assert scene.trial(0.5 * scene.gripper_mass).lifted
    assert not scene.trial(0.5 * scene.gripper_mass, field_on=False).lifted


@pytest.mark.parametrize("kw, match", [
    ({"segments": 2}, "segments"),
    ({"timestep": 0.01}, "timestep"),
    ({"hold_fraction": 1.5}, "hold_fraction"),
    ({"lift_height": 0.0}, "lift_height"),
    ({"friction": -0.1}, "friction"),
])
def test_options_validation(kw, match):
    with pytest.raises(ValueError, match=match):
        GraspOptions(**kw)


def test_scene_and_trial_validation(ball_scene):
    tgt = hanging_target("ball")
    with pytest.raises(ValueError, match="target_xz must stay at x >= 0"):
        GraspScene(ball_scene.beam, (0, 0.01), tgt * np.array([-1.0, 1.0]), FAST)
    with pytest.raises(ValueError, match="beam must be"):
        GraspScene("beam", (0, 0.01), tgt, FAST)
    with pytest.raises(ValueError, match="options must be"):
        GraspScene(ball_scene.beam, (0, 0.01), tgt, {"segments": 10})
    with pytest.raises(ValueError, match="object_mass"):
        ball_scene.trial(0.0)
    with pytest.raises(ValueError, match="max_ratio"):
        max_lift_mass(ball_scene, min_ratio=1.0, max_ratio=0.5)

"""Three-axis field waveforms: fields rotating about any axis, precessing (conical) fields, drives with a y
component; the planar rod refuses a y component and keeps its planar waveforms bit for bit."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.sim import RodOptions, Simulator
from magsoft_env.sim.waveforms import Conical, Hold, PhaseShifted, Precessing, Rotating, Sequence, as_waveform
from magsoft_env.spec.drive import Waveparams

BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)


@pytest.mark.parametrize("axis", [(0, 0, 1), (1, 0, 0), (0, 1, 0), (1, 2, -0.5)])
def test_rotating_field_turns_right_handed_about_its_axis(axis):
    wf = Rotating(2e-3, 3.0, axis=axis)
    t = np.linspace(0.0, 1.0 / 3.0, 41)
    b = wf.sample(t)
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    np.testing.assert_allclose(np.linalg.norm(b, axis=1), 2e-3, rtol=1e-12)
    np.testing.assert_allclose(b @ a, 0.0, atol=1e-18)  # in the plane normal to the axis
    # right-handed: B x dB/dt along +axis, turning 2 pi f
    w = np.cross(b[:-1], b[1:]) @ a
    assert np.all(w > 0)
    assert wf.components == 3 and wf(0.0) == tuple(b[0])


def test_conical_field_keeps_its_cone():
    wf = Precessing(3e-3, 2.0, axis=(0, 0, 1), cone_angle=math.radians(30))
    assert Precessing is Conical
    b = wf.sample(np.linspace(0.0, 1.0, 101))
    np.testing.assert_allclose(np.linalg.norm(b, axis=1), 3e-3, rtol=1e-12)
    np.testing.assert_allclose(b[:, 2], 3e-3 * math.cos(math.radians(30)), rtol=1e-12)
    np.testing.assert_allclose(np.hypot(b[:, 0], b[:, 1]), 3e-3 * 0.5, rtol=1e-12)
    with pytest.raises(ValueError, match="axis"):
        Conical(1e-3, 1.0, axis=(0, 0, 0))
    with pytest.raises(ValueError, match="peak"):
        Conical(1.5, 1.0)
    with pytest.raises(ValueError, match="parallel"):
        Conical(1e-3, 1.0, axis=(0, 0, 1), reference=(0, 0, 2))


def test_a_rotation_about_y_is_planar_to_the_last_bit():
    b = Rotating(2e-3, 1.0, axis=(0, 1, 0)).sample(np.linspace(0.0, 1.0, 97))
    assert np.all(b[:, 1] == 0.0)


def test_drives_and_holds_take_a_y_component():
    w = Waveparams(1e-3, 2e-3, 1.0, amplitude_y=1.5e-3, phase_y=math.pi / 2)
    assert w.components == 3 and "B_y" in w.describe()
    t = np.array([0.0, 0.1, 0.3])
    np.testing.assert_array_equal(as_waveform(w).sample(t), w.sample(t))
    assert as_waveform(w).sample(t).shape == (3, 3)
    sq = Waveparams(1e-3, 2e-3, 1.0, shape="square", amplitude_y=1e-3)
    np.testing.assert_array_equal(as_waveform(sq).sample(t), sq.sample(t))
    assert Hold(ms.Field(0.0, 1e-3, 0.0)).components == 3 and Hold((1e-3, 0.0)).components == 2
    seq = Sequence((Hold((0.0, 1e-3), duration=0.5), Rotating(1e-3, 1.0)))
    assert seq.components == 3 and seq.sample([0.0]).tolist() == [[0.0, 0.0, 1e-3]]
    assert as_waveform(lambda t: (0.0, 1e-3, 0.0)).sample([0.0, 1.0]).shape == (2, 3)


def test_planar_waveforms_are_unchanged():
    w = Waveparams(2e-3, 1.5e-3, 2.0, phase=math.pi / 2)
    t = np.linspace(0, 1, 11)
    assert w.components == 2 and w.sample(t).shape == (11, 2)
    assert PhaseShifted(1e-3, 2e-3, 1.0).sample(t).shape == (11, 2)
    ref = np.stack([2e-3 * np.sin(2 * np.pi * 2 * t + np.pi / 2), 1.5e-3 * np.sin(2 * np.pi * 2 * t)], axis=1)
    np.testing.assert_array_equal(w.sample(t), ref)


def test_the_planar_rod_refuses_a_y_component_and_takes_a_rotation_about_y():
    sim = Simulator(BEAM, RodOptions(segments=8))
    with pytest.raises(ValueError, match="y component"):
        sim.set_waveform(Rotating(2e-3, 1.0, axis=(0, 0, 1)))
    with pytest.raises(ValueError, match="y component"):
        sim.set_waveform(Waveparams(1e-3, 1e-3, 1.0, amplitude_y=1e-3))
    late = Sequence((Hold((0.0, 1e-3), duration=2.0), Hold(ms.Field(0.0, 1e-3, 0.0))))  # y only after 2 s
    sim.set_waveform(late, start_time=-1.99)
    with pytest.raises(ValueError, match="y component"):
        sim.step(200)
    sim = Simulator(BEAM, RodOptions(segments=8))
    sim.set_waveform(Rotating(2e-3, 2.0, axis=(0, 1, 0)))
    sim.step(100)
    bx, bz = sim.field.Bx, sim.field.Bz
    assert sim.field.By == 0.0 and math.isclose(math.hypot(bx, bz), 2e-3, rel_tol=1e-9)


def test_the_3d_rod_follows_a_conical_field():
    """A precessing field about z drags the strip's tip around: it leaves the x-z plane."""
    sim = Simulator(BEAM, RodOptions(rod="cable", segments=10, timestep=1e-4, gravity=0.0))
    sim.set_waveform(Conical(3e-3, 2.0, axis=(0, 0, 1), cone_angle=math.radians(45)))
    sim.step(1250)
    assert abs(sim.tip_position()[1]) > 1e-4
    assert math.isclose(float(np.linalg.norm(sim.field.vector())), 3e-3, rel_tol=1e-9)

"""Frames of a run under a field source: its magnets drawn where they lie in the view, the field at the robot's
centre (drive plus source), in the side view and the 3D views; a moving source drawn at the simulator's time."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("mujoco")

from magsoft_env.cases.gaits import gait_preset  # noqa: E402
from magsoft_env.fields import MovingSource, PointDipole, SphereMagnet  # noqa: E402

#: A weak magnet ahead of and above paper-5c (in the side view's frame, clear of the zoom inset and the dial).
MAGNET = SphereMagnet(position=(0.030, 0.0, 0.012), radius=1e-3, magnetization=(0.0, 0.0, 1.2 / (4e-7 * np.pi)))
RED = np.array([0xC0, 0x39, 0x2B])


def _sim(source=None, rod="planar"):
    from magsoft_env.gl import RenderBackendError, select_gl_backend

    try:
        select_gl_backend()
    except RenderBackendError:
        pytest.skip("no headless OpenGL")
    from magsoft_env.sim import Simulator, as_waveform
    from magsoft_env.sim.gait import gait_rod_options

    preset = gait_preset("paper-5c")
    sim = Simulator(preset.beam, gait_rod_options(preset, render=True, rod=rod), source=source)
    sim.set_waveform(as_waveform(preset.wave))
    return sim


def _patch(img, u, v, r=2):
    u, v = int(round(float(u))), int(round(float(v)))
    return img[v - r:v + r + 1, u - r:u + r + 1].reshape(-1, 3).astype(float)


def _is_red(px) -> bool:
    """A lit sphere in the field colour: red well above green and blue (its shading changes the brightness)."""
    m = px.mean(axis=0)
    return m[0] > m[1] + 60 and m[0] > m[2] + 60


def test_side_view_draws_the_magnet_and_the_field_at_the_centre():
    from magsoft_env.render.frames import RodRenderer, source_state

    frames = {}
    for key, src in (("with", MAGNET), ("without", None)):
        sim = _sim(src)
        r = RodRenderer(sim, width=480, height=270, zoom=False)
        frames[key] = r.render(label="x")
        view = r.view
        r.close()
    u, v = RodRenderer._to_px(r, view, MAGNET.position[0], MAGNET.position[2])
    assert 0 <= u < 480 and 0 <= v < 270
    on, off = _patch(frames["with"], u, v), _patch(frames["without"], u, v)
    assert _is_red(on) and not _is_red(off)
    assert np.abs(on - off).mean() > 60
    # the field at the robot: the drive's (at t = 0) plus the magnet's at the centre of mass
    sim = _sim(MAGNET)
    st = source_state(sim)
    com = sim.pose().com
    assert st["centre"] == pytest.approx(com)
    assert st["B"] == pytest.approx(sim.field_vector + MAGNET.field(com.reshape(1, 3))[0], rel=1e-12, abs=1e-15)
    assert [k for k, _ in st["markers"]] == ["magnet"]


def test_a_magnet_out_of_view_is_not_drawn_and_no_source_draws_nothing():
    from magsoft_env.render.frames import RodRenderer, source_state

    sim = _sim(None)
    r = RodRenderer(sim, width=320, height=180, zoom=False)
    r.render()
    assert source_state(sim) is None and r._source is None
    r.close()
    far = SphereMagnet(position=(0.3, 0.0, 0.012), radius=1e-3, magnetization=(0.0, 0.0, 1e5))
    sim = _sim(far)
    r = RodRenderer(sim, width=320, height=180, zoom=False)
    r.render()
    assert len(r._source["markers"]) == 1 and r._visible_markers(r.view) == []
    r.close()


def test_strip_view_draws_the_magnet():
    from magsoft_env.render.strip import StripRenderer

    frames, proj = {}, None
    for key, src in (("with", MAGNET), ("without", None)):
        sim = _sim(src, rod="cable")
        r = StripRenderer(sim, width=480, height=270, view="top")
        frames[key] = r.render()
        proj = r.project(np.array(MAGNET.position))
        r.close()
    u, v = proj
    assert 0 <= u < 480 and 0 <= v < 270
    on, off = _patch(frames["with"], u, v), _patch(frames["without"], u, v)
    assert _is_red(on) and not _is_red(off)


def test_a_moving_source_is_drawn_at_the_simulators_time():
    from magsoft_env.render.frames import source_state

    moving = MovingSource(PointDipole(position=(0, 0, 0), moment=(0.0, 0.0, 1e-4)),
                          position=lambda t: (0.03 + 0.1 * t, 0.0, 0.02))
    sim = _sim(moving)
    st0 = source_state(sim)
    assert st0["markers"][0][1][0] == pytest.approx([0.03, 0.0, 0.02])
    sim.step(50)
    st1 = source_state(sim)
    assert st1["markers"][0][1][0] == pytest.approx([0.03 + 0.1 * sim.time, 0.0, 0.02])
    com = sim.pose().com
    B = moving.field_and_gradient(com.reshape(1, 3), t=sim.time)[0][0]
    assert st1["B"] == pytest.approx(sim.field_vector + B, rel=1e-12, abs=1e-15)


def test_render_gait_with_a_source_draws_it_in_the_video_frames():
    pytest.importorskip("imageio")
    from magsoft_env.gl import RenderBackendError, select_gl_backend

    try:
        select_gl_backend()
    except RenderBackendError:
        pytest.skip("no headless OpenGL")
    from magsoft_env.render.video import render_gait

    preset = gait_preset("paper-5c")
    with_src, _ = render_gait(preset, 0.05, fps=20, width=320, height=180, zoom=False, source=MAGNET)
    without, _ = render_gait(preset, 0.05, fps=20, width=320, height=180, zoom=False)
    assert len(with_src) == len(without) == 2
    assert np.abs(with_src[0].astype(float) - without[0].astype(float)).sum() > 0

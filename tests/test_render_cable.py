"""Frames and videos of the 3D strip on the floor: perspective and top views, field arrow, goal, panel, CLI."""

from __future__ import annotations

import numpy as np
import pytest

from magsoft_env.render.figures import PALETTE
from magsoft_env.units import MM, MT

W, H = 320, 180


def _teal(img: np.ndarray) -> np.ndarray:
    """Pixels of the goal's teal, also where a thin line is blended with the floor (green well above red, and
    not blue: the heading arrow's)."""
    c = img.astype(int)
    return (c[..., 1] - c[..., 0] > 25) & (c[..., 1] >= c[..., 2])


def _rgb(name: str) -> np.ndarray:
    h = PALETTE[name].lstrip("#")
    return np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)])


def _near(img: np.ndarray, name: str, tol: int = 14) -> np.ndarray:
    return np.all(np.abs(img.astype(int) - _rgb(name)) <= tol, axis=-1)


@pytest.fixture(scope="module")
def paper_5c():
    from magsoft_env.cases.gaits import gait_preset

    return gait_preset("paper-5c")


def _sim(preset, rod: str = "cable"):
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.gait import gait_rod_options

    return Simulator(preset.beam, gait_rod_options(preset, segments=10, rod=rod, render=rod == "planar"))


def _renderer(sim, **kw):
    from magsoft_env.gl import RenderBackendError
    from magsoft_env.render.views import make_renderer

    try:
        return make_renderer(sim, width=W, height=H, **kw)
    except RenderBackendError as err:
        pytest.skip(f"no headless OpenGL here: {str(err).splitlines()[0]}")


@pytest.mark.parametrize("view", ["perspective", "top"])
def test_strip_frame_shows_the_strip_with_its_width(paper_5c, view):
    from magsoft_env.render.strip import StripRenderer

    sim = _sim(paper_5c)
    r = _renderer(sim, view=view)
    assert isinstance(r, StripRenderer) and r.view == view  # the strip's views are StripRenderer's
    img = r.render(label="paper-5c")
    x = np.column_stack(sim.centerline())
    # the strip's middle, and points a quarter of the width to either side, are robot-coloured
    mid = x[len(x) // 2]
    side = np.array([0.0, 0.25 * sim.beam.width, 0.0])
    pts = r.project(np.stack([mid, mid + side, mid - side]) + [0.0, 0.0, 0.5 * sim.beam.thickness])
    r.close()
    assert img.shape == (H, W, 3) and img.dtype == np.uint8
    robot = _near(img, "robot")
    for u, v in pts:
        assert robot[int(round(v)) - 1:int(round(v)) + 2, int(round(u)) - 1:int(round(u)) + 2].any()
    # the strip is a band, not a line: in the top view its width spans 5 mm / span of the frame
    rows = robot.sum(axis=0)
    assert robot.sum() > 400 and rows.max() >= (8 if view == "top" else 4)
    assert _near(img, "floor").mean() > 0.3  # the floor fills the frame behind


def test_top_view_reads_true_lengths_x_right_y_up(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim, view="top")
    r.render()
    com = np.array(sim.center_of_mass())
    p = r.project(np.stack([com, com + [1 * MM, 0, 0], com + [0, 1 * MM, 0], com + [0, 0, 1 * MM]]))
    r.close()
    px_per_mm = W / (r.span / MM)
    np.testing.assert_allclose(p[1] - p[0], [px_per_mm, 0.0], atol=1e-6)
    np.testing.assert_allclose(p[2] - p[0], [0.0, -px_per_mm], atol=1e-6)
    np.testing.assert_allclose(p[3], p[0], atol=1e-6)  # straight down
    bar = r.scale_bar[0]
    assert bar / MM in (1, 2, 5, 10, 20, 50) and 0.08 < bar / r.span < 0.25  # a 1-2-5 length, about 15 %
    assert r.scale_bar[1] == pytest.approx(bar / MM * px_per_mm, rel=1e-6)


def _arrow_direction(r) -> np.ndarray:
    """Mean offset (pixels) of the field-coloured pixels around the arrow's anchor, from the anchor, in the last
    frame's scene without its overlay (text, dial)."""
    img = r._renderer.render()
    a = r.project(r._anchor)
    reach = float(np.hypot(*(r.project(r._anchor + [0.4 * r._L, 0, 0]) - a)))
    c = img.astype(int)
    red = (c[..., 0] > 90) & (c[..., 0] - c[..., 1] > 50) & (c[..., 0] - c[..., 2] > 50)  # the field's red, shaded
    vv, uu = np.nonzero(red)
    near = np.hypot(uu - a[0], vv - a[1]) < 1.2 * reach
    assert near.sum() > 10, "no field arrow around its anchor"
    return np.array([uu[near].mean() - a[0], vv[near].mean() - a[1]])


def test_field_arrow_turns_with_the_field(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim, field_scale=2 * MT)
    fields = {"+x": (2 * MT, 0.0, 0.0), "-x": (-2 * MT, 0.0, 0.0), "+y": (0.0, 2 * MT, 0.0), "+z": (0.0, 0.0, 2 * MT)}
    d = {}
    for name, b in fields.items():
        r.render(field=b)
        d[name] = _arrow_direction(r)
        a = r.project(r._anchor)
        tip = r.project(r._anchor + 0.3 * r._L * np.asarray(b) / 2e-3)
        want = (tip - a) / np.hypot(*(tip - a))
        assert d[name] @ want > 0.6 * np.hypot(*d[name]), name  # along the field as the camera sees it
    r.close()
    assert d["+x"] @ d["-x"] < 0  # reversed
    assert d["+z"][1] < 0  # up is up
    assert abs(d["+x"] @ d["+y"]) < 0.9 * np.hypot(*d["+x"]) * np.hypot(*d["+y"])  # a different direction


def test_goal_marker_on_the_floor_and_in_the_header(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim)
    com = np.array(sim.center_of_mass())
    goal = (com[0], com[1] - 0.3 * sim.beam.length)  # in front of the strip, toward the camera
    plain = r.render(field=(1 * MT, 0.5 * MT, 0.0), label="steer")
    img = r.render(field=(1 * MT, 0.5 * MT, 0.0), goal=goal, label="steer")
    u, v = r.project(np.array([goal[0], goal[1], 0.0]))
    ring = r.project(np.array([goal[0] + 0.08 * sim.beam.length, goal[1], 0.0]))
    r.close()
    box = (slice(int(v) - 12, int(v) + 13), slice(int(u) - 24, int(u) + 25))
    assert _teal(img[box]).sum() > 15
    assert _teal(plain[box]).sum() == 0
    # the ring passes through its projected edge
    ru, rv = int(round(ring[0])), int(round(ring[1]))
    assert _teal(img[rv - 2:rv + 3, ru - 2:ru + 3]).any()
    with pytest.raises(ValueError, match="goal must be 2 finite numbers"):
        r.render(goal=(0.0, np.nan))


def test_goal_out_of_view_gets_an_arrow_at_the_edge(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim)
    img = r.render(goal=(0.5, 0.0))  # half a metre to the right
    r.close()
    teal = _teal(img)
    assert teal[:, int(0.75 * W):].sum() > 10 and teal[:, :int(0.5 * W)].sum() == 0


def test_path_displacement_heading_and_reset(paper_5c):
    from magsoft_env.sim import as_waveform

    sim = _sim(paper_5c)
    sim.set_waveform(as_waveform(paper_5c.wave))
    r = _renderer(sim, view="top")
    r.render()
    com0 = np.array(sim.center_of_mass())
    for _ in range(3):
        sim.step(100)
        r.render()
    com = np.array(sim.center_of_mass())
    assert len(r._path) == 4
    assert r.displacement == pytest.approx(com[0] - com0[0])
    assert r.displacement_y == pytest.approx(com[1] - com0[1])
    x, y, _ = sim.centerline()
    assert r.heading == pytest.approx(np.arctan2(y[-1] - y[0], x[-1] - x[0]))
    sim.reset()  # time went back: a new path
    r.render()
    r.close()
    assert len(r._path) == 1 and r.displacement == 0.0


def test_panel_plots_two_displacements_and_three_field_components(paper_5c):
    from magsoft_env.render.frames import TimePanel

    sim = _sim(paper_5c)
    r = _renderer(sim, panel=True, panel_seconds=0.1)
    img = r.render(field=(1 * MT, -1 * MT, 0.5 * MT))
    assert img.shape == (H, W + 2 * round(0.45 * H), 3)
    assert len(r.panel._lines_x) == 2 and len(r.panel._lines_b) == 3
    r.close()
    p = TimePanel(height=120, components=3)
    with pytest.raises(ValueError, match="2 displacement"):
        p.update(0.0, 0.0, (0.0, 0.0, 0.0))
    p.close()
    with pytest.raises(ValueError, match="components must be 2"):
        TimePanel(height=120, components=4)


def test_views_and_options_are_checked(paper_5c):
    from magsoft_env.render.frames import RodRenderer
    from magsoft_env.render.strip import StripRenderer
    from magsoft_env.render.views import make_renderer

    planar = _sim(paper_5c, rod="planar")
    with pytest.raises(ValueError, match="is a 3D view"):
        RodRenderer(planar, view="top")
    strip = _sim(paper_5c)
    with pytest.raises(ValueError, match="side view of a rod in the x-z plane"):
        RodRenderer(strip)
    with pytest.raises(ValueError, match="view must be one of"):
        make_renderer(strip, view="side")
    with pytest.raises(ValueError, match="zoom is the side view"):
        StripRenderer(strip, zoom=True)
    with pytest.raises(ValueError, match="elevation must lie"):
        StripRenderer(strip, elevation=-5.0)
    r = _renderer(strip)
    with pytest.raises(ValueError, match="goal="):
        r.render(target=(0.0, 0.0))
    r.close()


def test_render_gait_refuses_mixed_rods_and_views(paper_5c):
    from magsoft_env.render.video import render_gait

    with pytest.raises(ValueError, match="floor scenes"):
        render_gait(paper_5c, 0.1, rod="cable", scene="cantilever")
    with pytest.raises(ValueError, match="view must be one of"):
        render_gait(paper_5c, 0.1, rod="cable", view="side")


def test_video_cli_writes_the_strip_with_a_three_axis_drive(tmp_path, capsys):
    import json

    import imageio.v2 as imageio

    from magsoft_env.cli import main

    out = tmp_path / "strip.gif"
    code = main(["video", "--preset", "paper-5c", "--rod", "cable", "--view", "top", "--amplitude-y-mT", "2",
                 "--phase-y-deg", "0", "--seconds", "0.2", "--fps", "10", "--width", str(W), "--height", str(H),
                 "--out", str(out)])
    if code == 1:
        pytest.skip("no headless OpenGL here")
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["rod"] == "cable" and summary["view"] == "top" and summary["frames"] == 3
    frames = imageio.mimread(out)
    assert len(frames) == 3 and frames[0].shape[:2] == (H, W)
    assert np.abs(frames[-1][..., :3].astype(int) - frames[0][..., :3]).sum() > 0


@pytest.mark.parametrize(("argv", "fragment"), [
    (["--env", "MagSoftCrawl-v1", "--view", "top"], "an --env renders its own view"),
    (["--preset", "paper-5c", "--amplitude-y-mT", "1"], "--rod cable"),
    (["--preset", "paper-5c", "--rotate-about", "z"], "--rod cable"),
    (["--env", "MagSoftCrawl-v1", "--rotate-about", "y"], "driven by its policy"),
])
def test_video_cli_refuses_options_the_rod_cannot_take(tmp_path, capsys, argv, fragment):
    from magsoft_env.cli import main

    out = tmp_path / "never.gif"
    assert main(["video", *argv, "--seconds", "0.1", "--out", str(out)]) == 2
    assert fragment in capsys.readouterr().err
    assert not out.exists()

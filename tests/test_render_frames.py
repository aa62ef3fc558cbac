"""What the video frames show: light backdrop, flat palette colours, scale bar, path and start, field dial, framing."""

from __future__ import annotations

import math

import numpy as np
import pytest

from magsoft_env.render.figures import PALETTE
from magsoft_env.units import MM, MT


def _rgb(name: str) -> np.ndarray:
    h = PALETTE[name].lstrip("#")
    return np.array([int(h[i:i + 2], 16) for i in (0, 2, 4)])


def _near(img: np.ndarray, name: str, tol: int = 12) -> np.ndarray:
    """Mask of the pixels within ``tol`` (per channel) of palette colour ``name``."""
    return np.all(np.abs(img.astype(int) - _rgb(name)) <= tol, axis=-1)


@pytest.fixture(scope="module")
def paper_5c():
    from magsoft_env.cases.gaits import gait_preset

    return gait_preset("paper-5c")


def _sim(preset, scene: str = "floor", segments: int = 8):
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.gait import gait_rod_options

    return Simulator(preset.beam, gait_rod_options(preset, scene=scene, segments=segments, timestep=5e-4, render=True))


def _renderer(sim, **kw):
    from magsoft_env.gl import RenderBackendError
    from magsoft_env.render.frames import RodRenderer

    try:
        return RodRenderer(sim, **kw)
    except RenderBackendError as err:
        pytest.skip(f"no headless OpenGL here: {str(err).splitlines()[0]}")


def test_default_frame_is_960x540_on_a_light_evenly_lit_backdrop(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim)
    img = r.render()
    r.close()
    assert img.shape == (540, 960, 3) and img.dtype == np.uint8
    assert img.mean() > 200  # light, not today's black
    assert (img.max(axis=-1) < 40).mean() < 0.02  # no black areas: only the rod and text are dark
    # one even light, no shadows: the backdrop is the palette's colour everywhere it shows
    assert _near(img, "background", tol=3).mean() > 0.4
    # the rod shows flat in the robot colour (no shading, no specular highlights)
    assert _near(img, "robot", tol=3).sum() > 1000


def test_scene_lights_cast_no_shadow(paper_5c):
    import mujoco

    r = _renderer(_sim(paper_5c), width=64, height=48)
    r.render()
    scn = r._renderer.scene
    assert scn.flags[mujoco.mjtRndFlag.mjRND_SHADOW] == 0
    assert all(scn.lights[i].castshadow == 0 for i in range(scn.nlight))
    r.close()


def test_scale_bar_is_a_1_2_5_length_of_about_15_percent_of_the_view(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim, width=480, height=270)
    img = r.render()
    bar_m, bar_px = r.scale_bar
    r.close()
    x_lo, x_hi = r.view[:2]
    assert bar_m / MM in (1, 2, 5, 10, 20, 50, 100)
    assert 0.07 < bar_m / (x_hi - x_lo) < 0.3
    assert bar_px == pytest.approx(bar_m / (x_hi - x_lo) * 480)
    # drawn: the longest run of text-coloured pixels in the floor band's left half is the bar
    floor = int(r._to_px(r.view, 0.0, 0.0)[1]) + 3
    ink = _near(img[floor:, :240], "text", tol=12)
    runs = [max((len(s) for s in "".join("1" if v else "0" for v in row).split("0")), default=0) for row in ink]
    assert max(runs) == pytest.approx(bar_px, abs=4)
    # its label sits above it: dark (anti-aliased) text in the floor band's rows above the bar
    bar_rows = [i for i, n in enumerate(runs) if n >= bar_px - 4]
    label = img[floor:floor + min(bar_rows) - 3, :240].astype(int).mean(axis=-1)
    assert (label < 140).sum() > 15


def test_nice_numbers():
    from magsoft_env.render.frames import _nice, _nice_ceil, dial_scale

    assert [_nice(v) for v in (0.9, 1.6, 3.4, 7.0, 13.0)] == [1.0, 2.0, 5.0, 5.0, 10.0]
    assert _nice_ceil(0.3) == 0.5 and _nice_ceil(2.0) == 2.0 and _nice_ceil(2.1) == 5.0
    assert dial_scale(0.0) == pytest.approx(1 * MT)
    assert dial_scale(2 * MT) == pytest.approx(2 * MT)
    assert dial_scale(5.36 * MT) == pytest.approx(10 * MT)


def test_field_text():
    from magsoft_env.render.frames import field_text

    assert field_text((1.2e-3, -0.5e-3)) == "B = (+1.20, \u22120.50) mT"
    assert field_text((0.0, 0.0)) == "B = 0"
    assert field_text((1e-20, 0.0)) == "B = 0"  # a sine's zero crossing
    assert field_text((-1e-7, 2e-3)) == "B = (+0.00, +2.00) mT"  # no "-0.00"


def _dial(img: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    return img[: int(0.25 * h), int(0.8 * w):]


@pytest.mark.parametrize("bx", [1e-4, -1e-4])
def test_field_arrow_shows_at_0_1_mT_and_grows_with_the_field(paper_5c, bx):
    sim = _sim(paper_5c)
    r = _renderer(sim, width=480, height=270, field_scale=2 * MT)
    counts = [_near(_dial(r.render(field=(b, 0.0))), "field", tol=30).sum() for b in (0.0, bx, 10 * bx, 20 * bx)]
    r.close()
    # zero field: the dot only; 0.1 mT: an arrow of the minimum length; then longer up to the ring
    assert counts[1] > counts[0] + 30
    assert counts[0] < counts[1] < counts[2] < counts[3]


def test_field_arrow_points_along_the_field(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim, width=480, height=270, field_scale=1 * MT)
    up, right = (_near(_dial(r.render(field=f)), "field", tol=30) for f in ((0.0, 1e-3), (1e-3, 0.0)))
    r.close()
    # the dial's centre: the common dot; the arrow adds pixels above it (B_z > 0) or right of it (B_x > 0)
    rows, cols = np.nonzero(up & ~right)
    assert rows.size and cols.size
    rr, rc = np.nonzero(right & ~up)
    assert rc.mean() > cols.mean()  # the B_x arrow lies to the right of the B_z arrow
    assert rows.mean() < rr.mean()  # the B_z arrow lies above the B_x arrow


def test_path_and_start_marker_appear_as_the_robot_moves_and_reset_with_the_sim(paper_5c):
    sim = _sim(paper_5c)
    sim.set_field((0.0, 5e-3))  # the robot arches: its centre of mass rises
    r = _renderer(sim, width=480, height=270)
    first = r.render()
    sim.step(400)
    moved = r.render()
    assert len(r._path) == 2
    assert _near(moved, "trace", tol=30).sum() > _near(first, "trace", tol=30).sum() + 20
    assert _near(first, "start", tol=20).sum() > 20  # the start line and its label
    sim.reset()  # time goes back: a new path
    r.render()
    assert len(r._path) == 1 and r.displacement == 0.0
    r.close()
    plain = _renderer(sim, width=480, height=270, trace=False)
    sim.step(400)
    no_trace = plain.render()
    plain.close()
    assert _near(no_trace, "trace", tol=30).sum() == 0


def test_displacement_is_the_centre_of_mass_x_since_the_first_frame(paper_5c):
    sim = _sim(paper_5c)
    sim.set_field((3e-3, 3e-3))
    r = _renderer(sim, width=64, height=48)
    x0 = sim.center_of_mass()[0]
    r.render()
    sim.step(200)
    r.render()
    assert r.displacement == pytest.approx(sim.center_of_mass()[0] - x0)
    r.close()


@pytest.mark.parametrize("scene", ["channel", "obstacle"])
def test_channel_and_obstacle_are_framed_whole(paper_5c, scene):
    from magsoft_env.sim.model import CHANNEL_SIZE, OBSTACLE_SIZE

    sim = _sim(paper_5c, scene=scene)
    r = _renderer(sim, width=960, height=540)
    img = r.render()
    r.close()
    x_lo, x_hi, z_lo, z_hi = r.view
    L = paper_5c.beam.length
    x0 = L + 5e-3  # the scene's default feature position
    length, _, height = CHANNEL_SIZE if scene == "channel" else OBSTACLE_SIZE
    x, _ = sim.centerline()
    assert x_lo < min(x.min(), x0) and max(x.max(), x0 + length) < x_hi
    assert z_lo < 0 and height + 1e-3 < z_hi
    # the obstacle or the ceiling shows in the scene colour
    assert _near(img, "scene", tol=6).sum() > 500


def test_cantilever_view_holds_every_pose_of_the_beam():
    from magsoft_env.sim import RodOptions, Simulator
    from magsoft_env.spec import Beam

    beam = Beam(length=20e-3, width=5e-3, thickness=1e-3)
    sim = Simulator(beam, RodOptions(segments=6, render=True))
    for w, h in ((960, 540), (400, 600)):
        r = _renderer(sim, width=w, height=h)
        r.render()
        x_lo, x_hi, z_lo, z_hi = r.view
        r.close()
        assert x_lo < -beam.length and x_hi > beam.length and z_lo < -beam.length and z_hi > beam.length


def test_shape_env_frame_shows_the_target_and_the_theory_overlay():
    import gymnasium as gym

    import magsoft_env  # noqa: F401  (registers the ids)

    env = gym.make("MagSoftShape-v0", render_mode="rgb_array", segments=6)  # the default 960 x 540
    L = env.unwrapped.beam.length
    target = (0.3 * L, -0.8 * L)
    env.reset(seed=0, options={"target": (*target, -1.0)})
    try:
        img = env.render()
    except Exception as err:  # noqa: BLE001
        from magsoft_env.gl import RenderBackendError

        if isinstance(err, RenderBackendError):
            pytest.skip("no headless OpenGL here")
        raise
    r = env.unwrapped._renderer
    u, v = r._to_px(r.view, *target)
    win = img[int(v) - 14:int(v) + 15, int(u) - 14:int(u) + 15]
    assert _near(win, "target", tol=30).sum() > 10  # the target ring where the target is
    assert _near(img, "target", tol=30).sum() < 5 * _near(win, "target", tol=30).sum() + 40  # ... and not elsewhere
    env.step(np.array([0.3, -0.6], np.float32))
    img = env.render()
    env.close()
    assert _near(img, "theory", tol=30).sum() > 200  # the analytical equilibrium, dashed


def test_time_panel_size_growth_and_reset():
    from magsoft_env.render.frames import TimePanel

    p = TimePanel(height=120, seconds=1.0)
    a = p.update(0.0, 0.0, (0.0, 0.0))
    b = p.update(0.5, 1e-3, (2e-3, -1e-3))
    assert a.shape == b.shape == (120, 108, 3) and a.dtype == np.uint8
    assert np.abs(a.astype(int) - b).sum() > 0  # the curves were drawn
    assert p._xlim[1] > 1.0 and p._blim[0] < -1.0  # mm and mT
    p.update(0.1, 0.0, (0.0, 0.0))  # time went back: a new history
    assert len(p._t) == 1
    p.close()
    with pytest.raises(ValueError, match="seconds must be a time > 0"):
        TimePanel(height=120, seconds=0.0)


def test_renderer_panel_widens_the_frame(paper_5c):
    sim = _sim(paper_5c)
    r = _renderer(sim, width=160, height=90, panel=True, panel_seconds=0.1)
    img = r.render()
    r.close()
    assert img.shape == (90, 160 + 2 * round(0.45 * 90), 3)


@pytest.mark.parametrize(("kw", "match"), [
    ({"width": 8}, "width must be an integer in"),
    ({"height": 100.5}, "height must be an integer in"),
    ({"minor": 0.0}, "minor must be a grid spacing"),
    ({"span": -1.0}, "span must be a view width"),
    ({"field_scale": math.nan}, "field_scale must be a field"),
])
def test_renderer_refuses_bad_arguments(paper_5c, kw, match):
    from magsoft_env.render.frames import RodRenderer

    with pytest.raises(ValueError, match=match):
        RodRenderer(_sim(paper_5c), **kw)


def test_figures_share_the_palette_and_font():
    import matplotlib

    from magsoft_env.render.figures import COLOR_CYCLE, _figure, styled

    fig, axes = _figure(1, 2)
    ax = axes[0, 0]
    (line,) = ax.plot([0, 1], [0, 1])
    assert matplotlib.colors.to_hex(line.get_color()) == COLOR_CYCLE[0] == PALETTE["theory"]
    assert not ax.spines["top"].get_visible()

    @styled
    def inside():
        return matplotlib.rcParams["font.family"], matplotlib.rcParams["text.color"]

    before = dict(matplotlib.rcParams)
    assert inside() == (["DejaVu Sans"], PALETTE["text"])
    assert dict(matplotlib.rcParams) == before  # the global settings are left alone


def _rod_left_edge(img: np.ndarray, row: int) -> int:
    """Column of the leftmost robot-coloured pixel of ``row``."""
    cols = np.nonzero(_near(img[row], "robot", tol=20))[0]
    assert cols.size, "no rod in this row"
    return int(cols[0])


def test_zoom_inset_shows_a_1_mm_crawl_of_the_rods_end(paper_5c):
    import mujoco

    sim = _sim(paper_5c)
    r = _renderer(sim, width=480, height=270)
    assert r.zoom and r.zoom_span == pytest.approx(0.25 * paper_5c.beam.length)
    a = r.render()
    ox, oy, zw, zh = r.zoom_box
    x_lo, x_hi, z_lo, z_hi = r.zoom_view
    row = oy + int(round((z_hi - 0.5 * paper_5c.beam.thickness) / (z_hi - z_lo) * zh))  # the rod's mid-plane
    edge_a = _rod_left_edge(a[:, ox:ox + zw], row)
    sim.data.qpos[sim.rod.base_qpos[0]] -= 1.0 * MM  # the whole rod 1 mm to the left, as a crawl would
    mujoco.mj_forward(sim.model, sim.data)
    b = r.render()
    r.close()
    assert r.zoom_box == (ox, oy, zw, zh) and r.zoom_view == (x_lo, x_hi, z_lo, z_hi)  # the window stays put
    assert r.end_displacement == pytest.approx(-1.0 * MM)
    px_per_mm = zw / ((x_hi - x_lo) / MM)
    assert px_per_mm > 3.0 * 480 / (r.span / MM)  # magnified: over 3 x the scene's mm
    # in the inset the end moves a millimetre's worth of zoomed pixels (about 30 px at this size)
    assert edge_a - _rod_left_edge(b[:, ox:ox + zw], row) == pytest.approx(px_per_mm, abs=2.0)
    # the ruler: 0.1 mm ticks (a tick every px_per_mm / 10 pixels) in ink under the floor line
    floor_row = oy + int(round(z_hi / (z_hi - z_lo) * zh)) + 1  # just under the floor line, in the floor band
    ticks = b[floor_row, ox + 2:ox + zw - 2].mean(axis=-1) < 0.8 * _rgb("floor").mean()
    starts = np.count_nonzero(ticks[1:] & ~ticks[:-1])
    assert starts >= 0.8 * 10 * (x_hi - x_lo) / MM  # about one per 0.1 mm across the window


def test_zoom_defaults_and_refusals(paper_5c):
    r = _renderer(_sim(paper_5c, scene="channel"), width=320, height=180)
    assert not r.zoom and r.render().shape == (180, 320, 3) and r.zoom_box is None
    r.close()
    from magsoft_env.render.frames import RodRenderer
    from magsoft_env.sim import RodOptions, Simulator
    from magsoft_env.spec import Beam

    cantilever = Simulator(Beam(length=20e-3, width=5e-3, thickness=1e-3), RodOptions(segments=4, render=True))
    with pytest.raises(ValueError, match="zoom needs a floor scene"):
        RodRenderer(cantilever, zoom=True)
    with pytest.raises(ValueError, match="zoom_span must be"):
        RodRenderer(_sim(paper_5c), zoom_span=-1.0)


def test_render_gait_draws_the_zoom_inset_unless_told_not_to(paper_5c, tmp_path):
    from magsoft_env.cli import main
    from magsoft_env.gl import RenderBackendError
    from magsoft_env.render.video import render_gait

    try:
        zoomed, _ = render_gait(paper_5c, 0.04, fps=25, width=320, height=180, segments=8, timestep=5e-4)
    except RenderBackendError as err:
        pytest.skip(f"no headless OpenGL here: {str(err).splitlines()[0]}")
    plain, _ = render_gait(paper_5c, 0.04, fps=25, width=320, height=180, segments=8, timestep=5e-4, zoom=False)
    w = int(round(0.36 * 320))
    left = int(round(0.46 * 320 - 0.5 * w))
    box = (slice(5, 5 + int(round(w * 180 / 320))), slice(left, left + w))  # the inset, top centre
    # the inset's magnified rod end: robot-coloured pixels where the plain frame has only backdrop and grid
    assert _near(zoomed[-1][box], "robot", tol=20).sum() > 200
    assert _near(plain[-1][box], "robot", tol=20).sum() == 0
    out = tmp_path / "v.gif"
    assert main(["video", "--preset", "paper-5c", "--seconds", "0.04", "--width", "160", "--height", "90",
                 "--no-zoom", "--out", str(out)]) == 0 and out.stat().st_size > 0

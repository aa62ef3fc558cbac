"""Side-view frames of a :class:`~magsoft_env.sim.Simulator`: mm grid and scale bar, field arrow, path, overlays."""

from __future__ import annotations

import functools
import math
from pathlib import Path

import mujoco
import numpy as np

from ..gl import bind_headless_context, context_error
from ..spec import as_field
from ..spec.field import planar_field
from ..units import MM, MT
from .figures import PALETTE, _rc

#: The 2-D overlay (lines, text) is drawn at this multiple of the frame size and averaged down:
#: anti-aliased lines for the cost of a few milliseconds.
_SUPERSAMPLE = 2
#: Depths (m, along the camera's +y) of the layers behind the rod (which spans |y| <= w / 2): the
#: backdrop, the grid in front of it, the floor band in front of the grid. All lie behind the
#: channel's far wall (5.25 mm), which is not drawn.
_Y_BACKDROP, _Y_GRID, _Y_FLOOR = 30e-3, 25e-3, 20e-3
#: Opacity of the channel's near wall (it lies between the camera and the robot).
_NEAR_WALL_ALPHA = 0.22
#: Length of the field arrow as a fraction of the dial radius: for the weakest field, and at the full scale.
_ARROW_MIN, _ARROW_MAX = 0.4, 1.0
#: Full-scale fields (T) the dial steps through when ``field_scale`` is not given.
_FIELD_STEPS = tuple(m * 10.0**e * MT for e in range(0, 4) for m in (1.0, 2.0, 5.0))
#: Fields weaker than this (T) draw as zero: a dot and "B = 0" (a sine's zero crossing leaves ~1e-19 T).
_ZERO_FIELD = 1e-9
#: Trace points kept (older ones are thinned out to every second one).
_MAX_TRACE = 4000
#: The zoom inset (floor scene): its width as a fraction of the frame's (its aspect is the frame's), and its
#: default view width as a fraction of the beam length (a quarter: 4 x the frame's 2.4 L view magnified 2.4 x ...
#: about 4 x for the default view, so a 1.6 mm crawl moves the end about 100 px in a 960 px frame).
_ZOOM_FRACTION = 0.36
_ZOOM_SPAN = 0.25
#: Ruler ticks of the zoom inset (m): every 0.1 mm, longer every 0.5 mm, labelled every 1 mm.
_TICK_MINOR, _TICK_MID, _TICK_MAJOR = 0.1 * MM, 0.5 * MM, 1.0 * MM


#: A field source's magnets, dipoles and loop centres are drawn as spheres of this radius (a fraction of the beam
#: length; at least :data:`_MARKER_MIN`), in the field colour, where they lie within the view.
_MARKER_FRACTION, _MARKER_MIN = 0.05, 0.4 * MM
#: Colour (palette key) of the arrow of the field at the robot's centre under a field source.
_SOURCE_ARROW = "field_z"
#: Marker text by kind (``magsoft_env.fields.source_markers``).
_MARKER_NAMES = {"magnet": "magnet", "dipole": "dipole", "loop": "loop centre"}


def source_state(sim):
    """What a frame draws of the simulator's field source at its time, or None without one (``sim.source``):
    ``{"markers": [(kind, (k, 3) positions in m), ...], "centre": (3,) the centre of mass (m), "B": (3,) the
    field there (T): the uniform field (the drive and the source's uniform parts) plus the rest of the source}``.
    A :class:`~magsoft_env.fields.MovingSource` is posed at the simulator's time."""
    src = getattr(sim, "source", None)
    if src is None:
        return None
    from ..fields import MovingSource, source_markers
    from ..sim.sources import split_source, takes_time

    t = float(sim.time)
    posed = src.at(t) if isinstance(src, MovingSource) else src
    try:
        markers = source_markers(posed)
    except (TypeError, ValueError):
        markers = []
    centre = np.asarray(sim.pose().com, dtype=float)
    B = np.asarray(sim.field_vector, dtype=float).copy()
    _, rest = split_source(src)
    if rest is not None:
        p = centre.reshape(1, 3)
        b, _ = rest.field_and_gradient(p, t=t) if takes_time(rest) else rest.field_and_gradient(p)
        B = B + np.asarray(b, dtype=float)[0]
    return {"markers": markers, "centre": centre, "B": B}


def marker_radius(length: float) -> float:
    """Radius (m) of a source marker sphere for a beam of ``length`` (m)."""
    return max(_MARKER_FRACTION * float(length), _MARKER_MIN)


def source_field_text(b) -> str:
    """``"B here = 1.23 mT"``: the field at the robot's centre under a source (T in, mT out)."""
    return f"B at centre = {float(np.linalg.norm(b)) / MT:.2f} mT"


def _rgb(name: str) -> tuple[int, int, int]:
    h = PALETTE[name].lstrip("#")
    return int(h[0:2], 16), int(h[2:4], 16), int(h[4:6], 16)


def _rgba32(name: str, alpha: float = 1.0) -> np.ndarray:
    return np.array([*(c / 255.0 for c in _rgb(name)), alpha], dtype=np.float32)


@functools.lru_cache(maxsize=32)
def _font(size: int, bold: bool = False):
    """DejaVu Sans (the figures' font, shipped with matplotlib) at ``size`` pixels."""
    import matplotlib
    from PIL import ImageFont

    path = Path(matplotlib.get_data_path()) / "fonts" / "ttf" / ("DejaVuSans-Bold.ttf" if bold else "DejaVuSans.ttf")
    try:
        return ImageFont.truetype(str(path), size)
    except OSError:  # a matplotlib without its fonts: Pillow's own
        return ImageFont.load_default(size)


def _nice(value: float) -> float:
    """The 1-2-5 number nearest to ``value`` (> 0) on a log scale."""
    e = math.floor(math.log10(value))
    m = value / 10.0**e
    return min((1.0, 2.0, 5.0, 10.0), key=lambda c: abs(math.log(m / c))) * 10.0**e


def _signed(v: float, fmt: str = "+.2f") -> str:
    """``v`` formatted with a true minus sign; a value that rounds to zero shows as +0."""
    text = format(v, fmt)
    if float(text) == 0.0:
        text = format(0.0, fmt)
    return text.replace("-", "\u2212")


def dial_scale(peak: float) -> float:
    """The field dial's full scale (T) for fields up to ``peak`` (T): the smallest of 1, 2, 5, 10, ... mT
    at or above it (1 mT for a zero peak)."""
    return next((s for s in _FIELD_STEPS if s >= peak * (1 - 1e-9)), _FIELD_STEPS[-1])


def field_text(b, *, digits: int = 2) -> str:
    """``"B = (+1.20, −0.50) mT"`` for a field ``(B_x, B_z)`` in T (``"B = 0"`` for zero)."""
    if math.hypot(float(b[0]), float(b[1])) < _ZERO_FIELD:
        return "B = 0"
    bx, bz = (float(v) / MT for v in b)
    f = f"+.{digits}f"
    return f"B = ({_signed(bx, f)}, {_signed(bz, f)}) mT"


def check_frame_args(width, height, minor, major, span, field_scale) -> None:
    """ValueError for a frame size outside [16, 8192] pixels, a grid spacing, view width or field scale that is not
    a positive finite number (``span`` and ``field_scale`` may be None)."""
    for name, v in (("width", width), ("height", height)):
        if int(v) != v or not 16 <= v <= 8192:
            raise ValueError(f"{name} must be an integer in [16, 8192] pixels, got {v!r}.")
    for name, v in (("minor", minor), ("major", major)):
        if not (v > 0 and math.isfinite(v)):
            raise ValueError(f"{name} must be a grid spacing > 0 (m), got {v!r}.")
    if span is not None and not (span > 0 and math.isfinite(span)):
        raise ValueError(f"span must be a view width > 0 (m) or None, got {span!r}.")
    if field_scale is not None and not (field_scale > 0 and math.isfinite(field_scale)):
        raise ValueError(f"field_scale must be a field > 0 (T) or None, got {field_scale!r}.")


def trace_append(times: list, path: list, t: float, p) -> tuple[list, list]:
    """A path trace with the sample ``(t, p)`` added (the last point replaced at an equal time); beyond
    ``_MAX_TRACE`` points the first and the newest 100 are kept and the rest thinned by two."""
    if times and t == times[-1]:
        path[-1] = p
        return times, path
    times.append(t)
    path.append(p)
    if len(path) > _MAX_TRACE:  # keep the first and the newest points, thin the rest
        times = times[:1] + times[1:-100:2] + times[-100:]
        path = path[:1] + path[1:-100:2] + path[-100:]
    return times, path


class _Canvas:
    """PIL drawing in frame pixels on a supersampled copy of a frame (see :data:`_SUPERSAMPLE`)."""

    def __init__(self, img: np.ndarray):
        from PIL import Image, ImageDraw

        self.h, self.w = img.shape[:2]
        k = self.k = _SUPERSAMPLE
        self.im = Image.fromarray(img).resize((self.w * k, self.h * k), Image.Resampling.NEAREST)
        self.draw = ImageDraw.Draw(self.im, "RGBA")
        self.unit = max(self.h / 540.0, 0.25)  # line widths and fonts scale with the frame height

    def _p(self, pts):
        return [(float(u) * self.k, float(v) * self.k) for u, v in pts]

    def lw(self, px: float) -> int:
        return max(1, int(round(px * self.unit * self.k)))

    def line(self, pts, colour, width: float, *, dash: float | None = None) -> None:
        pts = list(pts)
        if len(pts) < 2:
            return
        if dash is None:
            self.draw.line(self._p(pts), fill=colour, width=self.lw(width), joint="curve")
            return
        # dashes of ``dash`` px (frame pixels) along the polyline, gaps as long
        d = dash * self.unit
        p = np.asarray(pts, dtype=float)
        seg = np.hypot(*np.diff(p, axis=0).T)
        s = np.concatenate([[0.0], np.cumsum(seg)])
        for a in np.arange(0.0, s[-1], 2 * d):
            b = min(a + d, s[-1])
            ts = np.concatenate([[a], s[(s > a) & (s < b)], [b]])
            q = np.column_stack([np.interp(ts, s, p[:, 0]), np.interp(ts, s, p[:, 1])])
            self.draw.line(self._p(q), fill=colour, width=self.lw(width), joint="curve")

    def circle(self, c, r: float, *, fill=None, outline=None, width: float = 1.0) -> None:
        u, v = c[0] * self.k, c[1] * self.k
        rr = r * self.k
        self.draw.ellipse((u - rr, v - rr, u + rr, v + rr), fill=fill, outline=outline,
                          width=self.lw(width) if outline is not None else 0)

    def polygon(self, pts, fill) -> None:
        self.draw.polygon(self._p(pts), fill=fill)

    def rect(self, box, fill, *, radius: float = 0.0) -> None:
        b = [c * self.k for c in box]
        if radius > 0:
            self.draw.rounded_rectangle(b, radius=radius * self.k, fill=fill)
        else:
            self.draw.rectangle(b, fill=fill)

    def font(self, px: float, bold: bool = False):
        return _font(max(6, int(round(px * self.unit))) * self.k, bold)

    def text(self, xy, s: str, colour, *, px: float = 15.0, bold: bool = False, anchor: str = "la",
             box: bool = False) -> tuple[float, float, float, float]:
        """Draw ``s`` at ``xy`` (frame pixels, PIL anchor); returns its box in frame pixels."""
        f = self.font(px, bold)
        p = (xy[0] * self.k, xy[1] * self.k)
        bb = self.draw.textbbox(p, s, font=f, anchor=anchor)
        if box:  # a pale box keeps text readable over the scene
            pad = 3 * self.unit * self.k
            self.draw.rounded_rectangle((bb[0] - pad, bb[1] - pad, bb[2] + pad, bb[3] + pad), radius=pad,
                                        fill=(255, 255, 255, 200))
        self.draw.text(p, s, font=f, fill=colour, anchor=anchor)
        return tuple(c / self.k for c in bb)

    def text_width(self, s: str, *, px: float = 15.0, bold: bool = False) -> float:
        return self.draw.textlength(s, font=self.font(px, bold)) / self.k

    def arrow(self, a, b, colour, *, width: float, head: float) -> None:
        """A filled arrow from ``a`` to ``b`` (frame pixels); ``head`` is the head length (px)."""
        a, b = np.asarray(a, float), np.asarray(b, float)
        d = b - a
        n = float(np.hypot(*d))
        if n == 0:
            return
        e = d / n
        o = np.array([-e[1], e[0]])
        hl = min(head, n)
        base = b - hl * e
        self.line([a, base + 0.2 * hl * e], colour, width)
        self.polygon([b, base + 0.5 * hl * o, base - 0.5 * hl * o], colour)

    def result(self) -> np.ndarray:
        return np.asarray(self.im.reduce(self.k))  # the mean of each k x k block


class RodRenderer:
    """Offscreen side-camera frames of a rod, for videos and papers.

    An orthographic camera looks along +y at the x-z plane, so lengths read true anywhere in the
    frame. The frame shows, on a light backdrop:

    - the rod (flat, robot colour), the floor as a band below z = 0, the channel (ceiling, and its
      near wall see-through) or the obstacle, a clamp block for a cantilever;
    - a grid behind the rod, lines every ``minor`` (default 1 mm, left out when closer than 8 px)
      and heavier every ``major`` (5 mm), and a scale bar with its length in mm (1-2-5 steps,
      about 15 % of the view) bottom left;
    - the path of the centre of mass (floor scenes) or of the tip (cantilever) since the first
      frame, with the current point, and the start: a dashed vertical line at the first frame's
      centre-of-mass x (a ring at the first tip position for a cantilever). The header reads the
      time, the displacement ``dx`` of the centre of mass since the start (floor scenes) and,
      with a ``target``, the tip's distance to it;
    - the field in a dial top right, with its value as text (``B = (B_x, B_z) mT`` and ``|B|``).
      The arrow points along the field; its length is ``r * (0.4 + 0.6 * min(|B| / B_ring, 1))``
      for a dial of radius ``r``: 0.4 r for the weakest field, the full radius at the dial's full
      scale ``B_ring`` and above (the label says "ring = B_ring"). Zero field draws a dot;
    - optionally an overlay polyline (dashed, e.g. the analytical equilibrium) and a target (ring).

    The renderer remembers the path across :meth:`render` calls and starts a new one when the
    simulator's time goes backwards (an environment reset), so environments only call
    ``render()``.

    Parameters
    ----------
    sim : Simulator
        Built with ``RodOptions(render=True)`` for the rod's box geoms (otherwise its colliders
        show).
    width, height : int
        Frame size (pixels), default 960 x 540.
    follow : bool
        Floor scenes: move the view with the rod when it nears the frame's edge. False: a fixed
        view. A cantilever's view is fixed either way: a circle of radius 1.08 L about the clamp.
    span : float or None
        Width of the view (m). Default: floor scenes 2.4 L, widened to hold the channel or the
        obstacle whole (and their height under the header); cantilever 2.16 L (or the width
        that makes the height 2.16 L, whichever is larger).
    minor, major : float
        Grid spacings (m).
    field_scale : float or None
        The dial's full scale ``B_ring`` (T). None: the smallest of 1, 2, 5, 10, 20, ... mT at or
        above the largest |B| drawn so far (it only grows).
    trace : bool
        Draw the path and the start marker.
    zoom : bool or None
        Draw a zoom inset (top centre) of the rod's first end (s = 0) at the floor: a window
        ``zoom_span`` wide, magnified about 4 x for the default view, with a ruler along the floor ticked
        every 0.1 mm (0.5 mm, 1 mm) from that end's start position, a dashed start line and the end's
        displacement; the window's outline is drawn in the scene. The window stays put while the end is in
        its middle 80 % and re-centres on it otherwise, so a 1-2 mm crawl shows as the end stepping away
        from its start line (about 100 px at 960 x 540). None: on for the ``floor`` scene (channel and
        obstacle scenes fill the top of the frame), off otherwise.
    zoom_span : float or None
        Width (m) of the zoom window; None: a quarter of the beam length.
    panel : bool
        Put a :class:`TimePanel` (x(t) and B(t)) to the right of each frame; the frame grows by
        the panel's width (about half the height's 16:9 width, even).
    panel_seconds : float or None
        Time axis of the panel (s); None: grows with the time.
    view : {None, "side"}
        The planar rod's camera (the side view). For the 3D strip (``RodOptions(rod="cable")``)
        ``RodRenderer(sim, ...)`` returns a :class:`~magsoft_env.render.strip.StripRenderer`, whose ``view`` is
        ``"perspective"`` (default) or ``"top"``.

    Attributes
    ----------
    view : tuple of float
        The last frame's view ``(x_lo, x_hi, z_lo, z_hi)`` (m).
    scale_bar : tuple of float
        The last frame's scale bar: length (m) and pixels.
    displacement : float
        x displacement (m) of the centre of mass since the path started.
    end_displacement : float
        x displacement (m) of the rod's first end (s = 0) since the path started: the zoom inset's reading.
    zoom_view, zoom_box : tuple or None
        The last frame's zoom window ``(x_lo, x_hi, z_lo, z_hi)`` (m) and the inset's place in the frame
        ``(left, top, width, height)`` (pixels); None without the zoom.

    Raises
    ------
    RenderBackendError
        When no OpenGL context starts (the message names the packages to install).
    ValueError
        For a size outside [16, 8192] pixels, a grid spacing, span or field scale that is not > 0.
    """

    def __init__(self, sim, *, width: int = 960, height: int = 540, follow: bool = True, span: float | None = None,
                 minor: float = 1 * MM, major: float = 5 * MM, field_scale: float | None = None, trace: bool = True,
                 panel: bool = False, panel_seconds: float | None = None, zoom: bool | None = None,
                 zoom_span: float | None = None, view: str | None = None):
        if view not in (None, "side"):
            raise ValueError(f"view={view!r} is a 3D view (StripRenderer, or make_renderer(sim, view={view!r})); "
                             "RodRenderer draws the side view (view='side' or None).")
        views = getattr(getattr(sim, "backend", None), "views", ("side",))
        if "side" not in views:
            raise ValueError(f"RodRenderer draws the side view of a rod in the x-z plane; this rod is drawn in "
                             f"{list(views)} (magsoft_env.render.make_renderer(sim) picks its view).")
        check_frame_args(width, height, minor, major, span, field_scale)
        if zoom_span is not None and not (zoom_span > 0 and math.isfinite(zoom_span)):
            raise ValueError(f"zoom_span must be a window width > 0 (m) or None, got {zoom_span!r}.")
        if zoom is not None and not isinstance(zoom, (bool, np.bool_)):
            raise ValueError(f"zoom must be True, False or None, got {zoom!r}.")
        self.sim = sim
        self.width, self.height = int(width), int(height)
        self.follow = bool(follow)
        self.minor, self.major = float(minor), float(major)
        self.trace = bool(trace)
        self._field_scale_fixed = field_scale is not None
        self.field_scale = float(field_scale) if field_scale is not None else _FIELD_STEPS[0]
        self._floor = bool(sim.options.has_contact)
        self.zoom = bool(zoom) if zoom is not None else sim.options.scene == "floor"
        if self.zoom and not self._floor:
            raise ValueError("zoom needs a floor scene (it magnifies the rod's end at the floor), got a cantilever.")
        self.zoom_span = float(zoom_span) if zoom_span is not None else _ZOOM_SPAN * float(sim.beam.length)
        zw = max(16, int(round(_ZOOM_FRACTION * self.width)))
        self._zoom_size = (zw, max(16, int(round(zw * self.height / self.width))))
        self.zoom_view: tuple[float, float, float, float] | None = None
        self.zoom_box: tuple[int, int, int, int] | None = None
        self._static = self._static_geoms()
        self._pieces = self._piece_boxes()
        self._frame_view(span)
        vis = sim.model.vis.global_
        vis.offwidth = max(int(vis.offwidth), self.width)
        vis.offheight = max(int(vis.offheight), self.height)
        try:
            bind_headless_context()  # EGL or OSMesa when mujoco was imported without MUJOCO_GL
            self._renderer = mujoco.Renderer(sim.model, self.height, self.width)
            self._zoom_renderer = None
            if self.zoom:
                self._zoom_renderer = mujoco.Renderer(sim.model, self._zoom_size[1], self._zoom_size[0])
        except Exception as exc:  # noqa: BLE001  (any GL failure gets the same explanation)
            raise context_error(exc) from exc
        flags = self._renderer.scene.flags
        # a flat, evenly lit side view: no shadows (the field arrow's smudge), reflections or sky
        for f in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                  mujoco.mjtRndFlag.mjRND_SKYBOX, mujoco.mjtRndFlag.mjRND_FOG, mujoco.mjtRndFlag.mjRND_HAZE):
            flags[f] = 0
        self._cam = mujoco.MjvCamera()
        self._cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._cam.azimuth = 90.0
        self._cam.elevation = 0.0
        # orthographic: the mm grid reads true at any depth; the free camera's vertical extent
        # is the model's global fovy, in metres
        self._cam.orthographic = 1
        self._opt = mujoco.MjvOption()
        self.panel = TimePanel(height=self.height, seconds=panel_seconds) if panel else None
        self.view: tuple[float, float, float, float] | None = None
        self.scale_bar: tuple[float, float] | None = None
        self._source = None  # source_state(sim) of the frame being drawn (None: no field source)
        self._source_scale = _FIELD_STEPS[0]  # full scale (T) of the field-at-the-centre arrow; it only grows
        self._reset_path()

    # ------------------------------------------------------------------ framing
    def _static_geoms(self) -> dict[int, tuple[np.ndarray, np.ndarray, str]]:
        """World boxes (channel, obstacle): id -> (lower, upper corner (m), role)."""
        m = self.sim.model
        out = {}
        for g in range(m.ngeom):
            if m.geom_bodyid[g] != 0 or m.geom_type[g] != mujoco.mjtGeom.mjGEOM_BOX:
                continue
            lo, hi = m.geom_pos[g] - m.geom_size[g], m.geom_pos[g] + m.geom_size[g]
            role = "near" if hi[1] < 0 else "far" if lo[1] > 0 else "solid"
            out[g] = (lo, hi, role)
        return out

    def _piece_boxes(self) -> dict[int, int]:
        """The rod's box geoms (``RodOptions(render=True)``): geom id -> piece index."""
        m = self.sim.model
        out = {}
        for g in range(m.ngeom):
            name = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_GEOM, g) or ""
            if m.geom_bodyid[g] != 0 and name.startswith("box") and name[3:].isdigit():
                out[g] = int(name[3:])
        return out

    def _frame_view(self, span: float | None) -> None:
        L = self.sim.beam.length
        aspect = self.height / self.width
        x, z = self.sim.centerline()
        if not self._floor:  # cantilever: every pose of the beam lies within L of the clamp
            r = 1.08 * L
            self.span = float(span) if span is not None else max(2 * r, 2 * r / aspect)
            self._cx = self._cx0 = self._cz = 0.0
            return
        x_lo, x_hi, top = float(np.min(x)), float(np.max(x)), 0.0
        for lo, hi, role in self._static.values():
            if role != "far":
                x_lo, x_hi, top = min(x_lo, lo[0]), max(x_hi, hi[0]), max(top, hi[2])
        need = 1.15 * (x_hi - x_lo)
        # the floor band takes the bottom 17 % of the view, the header the top 22 %
        need = max(need, top / (0.61 * aspect))
        self.span = float(span) if span is not None else max(2.4 * L, need)
        self._cx = self._cx0 = 0.5 * (x_lo + x_hi)
        self._cz = (0.5 - 0.17) * self.span * aspect

    def _view(self) -> tuple[float, float, float, float]:
        """The view (x_lo, x_hi, z_lo, z_hi) in m, moved to keep the rod in sight."""
        half_w = 0.5 * self.span
        half_h = half_w * self.height / self.width
        if self.follow and self._floor:
            x, _ = self.sim.centerline()
            margin = 0.04 * self.span
            if np.min(x) < self._cx - half_w + margin or np.max(x) > self._cx + half_w - margin:
                self._cx = 0.5 * float(np.min(x) + np.max(x))
        return self._cx - half_w, self._cx + half_w, self._cz - half_h, self._cz + half_h

    # ------------------------------------------------------------------ path
    def _reset_path(self) -> None:
        self._t: list[float] = []
        self._path: list[tuple[float, float]] = []
        self._start: tuple[float, float] | None = None
        self._tip0: tuple[float, float] | None = None
        self._end0: float | None = None  # x (m) of the rod's first end at the first frame (the zoom's ruler)
        self._zx: float | None = None  # centre x (m) of the zoom window

    def _record(self) -> None:
        sim = self.sim
        t = float(sim.time)
        if self._t and t < self._t[-1] - 1e-12:  # time went backwards: an environment reset
            self._reset_path()
            self._cx = self._cx0
            if self.panel is not None:
                self.panel.reset()
        com = sim.center_of_mass()
        p = (float(com[0]), float(com[1])) if self._floor else sim.tip_position()
        if self._start is None:
            self._start = (float(com[0]), float(com[1]))
            self._tip0 = sim.tip_position()
            if self._floor:
                self._end0 = float(sim.centerline()[0][0])
        self._t, self._path = trace_append(self._t, self._path, t, p)

    @property
    def displacement(self) -> float:
        """x displacement (m) of the centre of mass since the path started (0 before any frame)."""
        if self._start is None:
            return 0.0
        return float(self.sim.center_of_mass()[0] - self._start[0])

    # ------------------------------------------------------------------ scene (GL)
    def _connector(self, scn, kind, a, b, rgba, width) -> None:
        if scn.ngeom >= scn.maxgeom:
            return
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, kind, np.zeros(3), np.zeros(3), np.eye(3).ravel(), rgba)
        mujoco.mjv_connector(g, kind, width, np.asarray(a, float), np.asarray(b, float))
        scn.ngeom += 1

    def _box(self, scn, center, half, rgba, mat=None) -> None:
        if scn.ngeom >= scn.maxgeom:
            return
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_BOX, np.asarray(half, float), np.asarray(center, float),
                            (np.eye(3) if mat is None else mat).ravel(), rgba)
        g.specular = 0.0
        scn.ngeom += 1

    def _restyle(self, scn) -> None:
        """The model's geoms in the palette; one even light from the camera."""
        m = self.sim.model
        robot, scene = _rgba32("robot"), _rgba32("scene")
        boxes = {}
        for i in range(scn.ngeom):
            g = scn.geoms[i]
            if g.objtype != mujoco.mjtObj.mjOBJ_GEOM:
                continue
            gid = g.objid
            if m.geom_bodyid[gid] != 0:
                g.rgba[:] = robot
                if gid in self._pieces:
                    boxes[self._pieces[gid]] = g
            elif gid in self._static:
                role = self._static[gid][2]
                g.rgba[:] = scene if role == "solid" else _rgba32("scene", _NEAR_WALL_ALPHA if role == "near" else 0.0)
            else:  # the floor plane, seen edge-on: the floor band stands for it
                g.rgba[3] = 0.0
            g.specular, g.emission, g.reflectance = 0.0, 0.0, 0.0
        self._close_joints(boxes)
        # a single directional light along the view: a face turned to the camera shows its colour
        light = scn.lights[0]
        light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        light.headlight = 0
        light.castshadow = 0
        light.dir[:] = (0.0, 1.0, 0.0)
        light.pos[:] = (self._cx, -1.0, self._cz)
        light.ambient[:] = 0.35
        light.diffuse[:] = 0.65
        light.specular[:] = 0.0
        scn.nlight = 1

    def _close_joints(self, boxes: dict) -> None:
        """Lengthen the rod's boxes into the wedge that opens on the outside of each bent joint
        (by h/2 tan(|dtheta|/2) each), so the strip shows without notches."""
        if len(boxes) < 2:
            return
        order = sorted(boxes)
        geoms = [boxes[i] for i in order]
        axes = [np.array([g.mat[0, 0], g.mat[1, 0], g.mat[2, 0]]) for g in geoms]
        theta = np.array([math.atan2(a[2], a[0]) for a in axes])
        d = np.angle(np.exp(1j * np.diff(theta)))
        ext = 0.5 * self.sim.beam.thickness * np.tan(np.minimum(np.abs(d), 1.2) / 2)
        for k, (g, a) in enumerate(zip(geoms, axes, strict=True)):
            left = ext[k - 1] if k > 0 else 0.0
            right = ext[k] if k < len(ext) else 0.0
            g.size[0] += 0.5 * (left + right)
            g.pos[:] += a * 0.5 * (right - left)

    def _grid_lines(self, scn, view, px_width: int, minor: float, major: float) -> None:
        x_lo, x_hi, z_lo, z_hi = view
        px_per_m = px_width / (x_hi - x_lo)
        lw = max(1.0, round(self.height / 540.0))
        if self._floor:
            z_lo = 0.0  # no grid below the floor
        for step, colour, width in ((minor, "grid_minor", lw), (major, "grid_major", 1.5 * lw)):
            if step * px_per_m < 8 or (x_hi - x_lo) / step > 600:
                continue
            rgba = _rgba32(colour)
            for gx in np.arange(math.ceil(x_lo / step) * step, x_hi, step):
                self._connector(scn, mujoco.mjtGeom.mjGEOM_LINE, (gx, _Y_GRID, z_lo), (gx, _Y_GRID, z_hi), rgba, width)
            for gz in np.arange(math.ceil(z_lo / step) * step, z_hi, step):
                self._connector(scn, mujoco.mjtGeom.mjGEOM_LINE, (x_lo, _Y_GRID, gz), (x_hi, _Y_GRID, gz), rgba, width)

    def _scene(self, view, renderer=None, px_width: int | None = None, minor: float | None = None,
               major: float | None = None) -> None:
        """Pose the scene of ``view`` in ``renderer`` (default the frame's): the rod, backdrop, grid, floor."""
        sim = self.sim
        x_lo, x_hi, z_lo, z_hi = view
        cam = self._cam
        cam.lookat[:] = (0.5 * (x_lo + x_hi), 0.0, 0.5 * (z_lo + z_hi))
        cam.distance = 10.0 * self.span
        sim.model.vis.global_.fovy = z_hi - z_lo
        r = self._renderer if renderer is None else renderer
        r.update_scene(sim.data, camera=cam, scene_option=self._opt)
        scn = r.scene
        self._restyle(scn)
        cx, cz, w, h = 0.5 * (x_lo + x_hi), 0.5 * (z_lo + z_hi), x_hi - x_lo, z_hi - z_lo
        self._box(scn, (cx, _Y_BACKDROP, cz), (w, 1e-4, h), _rgba32("background"))
        self._grid_lines(scn, view, self.width if px_width is None else px_width,
                         self.minor if minor is None else minor, self.major if major is None else major)
        if self._floor:
            depth = max(-z_lo, 0.0) + h
            self._box(scn, (cx, _Y_FLOOR, -0.5 * depth), (w, 1e-4, 0.5 * depth), _rgba32("floor"))
            lw = max(2.0, 2 * round(self.height / 540.0))
            self._connector(scn, mujoco.mjtGeom.mjGEOM_LINE, (x_lo, _Y_FLOOR - 1e-3, 0.0), (x_hi, _Y_FLOOR - 1e-3, 0.0),
                            _rgba32("floor_edge"), lw)
        if self._source is not None:
            self._source_spheres(scn, view)
        if not self._floor:  # a clamp block behind the rod's base, along the clamp angle
            th = float(sim.options.clamp_angle)
            c, s = math.cos(th), math.sin(th)
            half = np.array([1.0 * MM, 0.75 * sim.beam.width, 2.0 * sim.beam.thickness])
            rot = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
            self._box(scn, (-half[0] * c, 0.0, -half[0] * s), half, _rgba32("scene"), rot)

    def _visible_markers(self, view):
        """The source's markers within ``view`` (x, z; the side view sees every depth): (kind, (x, y, z))."""
        x_lo, x_hi, z_lo, z_hi = view
        r = marker_radius(self.sim.beam.length)
        out = []
        for kind, pts in self._source["markers"]:
            for p in np.asarray(pts, dtype=float):
                if x_lo - r <= p[0] <= x_hi + r and z_lo - r <= p[2] <= z_hi + r:
                    out.append((kind, p))
        return out

    def _source_spheres(self, scn, view) -> None:
        """Spheres at the source's magnets, dipoles and loop centres in the view, in the rod's plane (y = 0: the
        side view is orthographic, so their depth does not move them)."""
        r = marker_radius(self.sim.beam.length)
        for _, p in self._visible_markers(view):
            if scn.ngeom >= scn.maxgeom:
                return
            g = scn.geoms[scn.ngeom]
            mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_SPHERE, np.array([r, r, r]), np.array([p[0], 0.0, p[2]]),
                                np.eye(3).ravel(), _rgba32("field"))
            g.specular = 0.0
            scn.ngeom += 1

    def _draw_source(self, cv: _Canvas, view) -> None:
        """The source's markers named, and the field at the centre of mass as an arrow (its x-z part; length by
        the dial's rule against its own full scale) labelled with |B| in mT."""
        st = self._source
        u = cv.unit
        r_px = marker_radius(self.sim.beam.length) / (view[1] - view[0]) * self.width
        for kind, p in self._visible_markers(view):
            pu, pv = self._to_px(view, p[0], p[2])
            where = "" if abs(p[1]) < 1e-9 else f" (y = {p[1] / MM:.3g} mm)"
            cv.text((pu, pv - r_px - 3 * u), _MARKER_NAMES.get(kind, kind) + where, _rgb("field"), px=12.5,
                    anchor="md", box=True)
        b = st["B"]
        bmag = float(np.linalg.norm(b))
        if bmag > self._source_scale:
            self._source_scale = dial_scale(bmag)
        c = st["centre"]
        cu, cv_ = self._to_px(view, c[0], c[2])
        col = _rgb(_SOURCE_ARROW) + (255,)
        cv.circle((cu, cv_), 3.5 * u, fill=col)
        b2 = float(np.hypot(b[0], b[2]))
        R = 70 * u
        tip = (cu, cv_)
        if b2 >= _ZERO_FIELD:
            length = R * (_ARROW_MIN + (_ARROW_MAX - _ARROW_MIN) * min(bmag / self._source_scale, 1.0))
            tip = (cu + length * b[0] / b2, cv_ - length * b[2] / b2)
            cv.arrow((cu, cv_), tip, col, width=3.0, head=11 * u)
        below = tip[1] >= cv_
        cv.text((tip[0], tip[1] + (6 if below else -6) * u), source_field_text(b), col, px=12.5, bold=True,
                anchor="ma" if below else "md", box=True)

    # ------------------------------------------------------------------ overlay (2-D)
    def _to_px(self, view, x, z):
        x_lo, x_hi, z_lo, z_hi = view
        u = (np.asarray(x, float) - x_lo) / (x_hi - x_lo) * self.width
        v = (z_hi - np.asarray(z, float)) / (z_hi - z_lo) * self.height
        return u, v

    def _draw_path(self, cv: _Canvas, view) -> None:
        start, trace = _rgb("start"), _rgb("trace")
        if self._floor and self._start is not None:
            u0, v0 = self._to_px(view, self._start[0], 0.0)
            top = self.height * 0.30
            if self.zoom:  # the start label under the zoom inset
                top = max(top, self._zoom_origin(cv.unit)[1] + self._zoom_size[1] + 24 * cv.unit)
            cv.line([(u0, v0), (u0, top)], start + (255,), 1.6, dash=6.0)
            cv.polygon([(u0, v0 - 1), (u0 - 6 * cv.unit, v0 + 9 * cv.unit), (u0 + 6 * cv.unit, v0 + 9 * cv.unit)],
                       start + (255,))
            cv.text((u0, top - 3 * cv.unit), "start", start, px=13, anchor="md")
        elif self._tip0 is not None:
            u0, v0 = self._to_px(view, *self._tip0)
            cv.circle((u0, v0), 5 * cv.unit, outline=start + (255,), width=1.6)
        if not self._path:
            return
        p = np.asarray(self._path)
        u, v = self._to_px(view, p[:, 0], p[:, 1])
        if self._floor:  # the distance covered, as a bar just under the floor line from start to now
            v0 = self._to_px(view, 0.0, 0.0)[1] + 5 * cv.unit
            u0 = self._to_px(view, self._start[0], 0.0)[0]
            cv.line([(u0, v0), (u[-1], v0)], trace + (255,), 4.0)
            cv.circle((u[-1], v0), 3.5 * cv.unit, fill=trace + (255,))
        cv.line(list(zip(u, v, strict=True)), trace + (180,), 1.3)
        cv.circle((u[-1], v[-1]), 4.0 * cv.unit, fill=trace + (255,), outline=(255, 255, 255, 255), width=1.2)

    def _draw_overlay(self, cv: _Canvas, view, overlay, target) -> None:
        if overlay is not None:
            ox, oz = (np.asarray(a, dtype=float).ravel() for a in overlay)
            u, v = self._to_px(view, ox, oz)
            cv.line(list(zip(u, v, strict=True)), _rgb("theory") + (255,), 3.0, dash=7.0)
        if target is not None:
            u, v = self._to_px(view, float(target[0]), float(target[1]))
            col = _rgb("target") + (255,)
            r = 8 * cv.unit
            cv.circle((u, v), r, outline=col, width=2.4)
            cv.line([(u - 1.6 * r, v), (u - 0.5 * r, v)], col, 1.6)
            cv.line([(u + 0.5 * r, v), (u + 1.6 * r, v)], col, 1.6)
            cv.line([(u, v - 1.6 * r), (u, v - 0.5 * r)], col, 1.6)
            cv.line([(u, v + 0.5 * r), (u, v + 1.6 * r)], col, 1.6)

    def _draw_field(self, cv: _Canvas, b: np.ndarray) -> None:
        bmag = float(np.hypot(*b))
        if bmag < _ZERO_FIELD:
            bmag = 0.0
        if not self._field_scale_fixed and bmag > self.field_scale:
            self.field_scale = max(self.field_scale, dial_scale(bmag))
        u = cv.unit
        R = 46 * u
        m = 16 * u
        c = (self.width - m - R, m + R)
        col = _rgb("field") + (255,)
        muted = _rgb("muted")
        cv.circle(c, R + 4 * u, fill=(255, 255, 255, 190))
        cv.circle(c, R, outline=_rgb("grid_major") + (255,), width=1.2)
        for k in range(4):  # ticks at 0, 90, 180, 270 degrees
            e = np.array([math.cos(k * math.pi / 2), -math.sin(k * math.pi / 2)])
            cv.line([c + 0.86 * R * e, c + R * e], _rgb("grid_major") + (255,), 1.2)
        if bmag > 0:
            length = R * (_ARROW_MIN + (_ARROW_MAX - _ARROW_MIN) * min(bmag / self.field_scale, 1.0))
            tip = np.array(c) + length * np.array([b[0], -b[1]]) / bmag
            cv.arrow(c, tip, col, width=4.0, head=15 * u)
        cv.circle(c, 3.2 * u, fill=col)
        tx = self.width - 2 * m - 2 * R - 6 * u
        cv.text((tx, c[1] - 3 * u), field_text(b), col, px=16, bold=True, anchor="rd", box=True)
        sub = (f"|B| = {bmag / MT:.2f} mT   " if bmag > 0 else "") + f"ring = {self.field_scale / MT:g} mT"
        cv.text((tx, c[1] + 5 * u), sub, muted, px=12.5, anchor="ra", box=True)

    def _draw_header(self, cv: _Canvas, label: str, target) -> None:
        u = cv.unit
        x, y = 16 * u, 14 * u
        ink = _rgb("text")
        if label:
            bb = cv.text((x, y), label, ink, px=17, bold=True, box=True)
            x_t = bb[2] + 14 * u
        else:
            x_t = x
        bb = cv.text((x_t, y), f"t = {self.sim.time:.2f} s", ink, px=17, box=True)
        y = bb[3] + 7 * u
        lines = []
        if self._floor:
            lines.append(f"\u0394x = {_signed(self.displacement / MM)} mm (centre of mass)")
        if target is not None:
            tip = self.sim.tip_position()
            d = math.hypot(tip[0] - float(target[0]), tip[1] - float(target[1]))
            lines.append(f"tip to target = {d / MM:.2f} mm")
        for line in lines:
            bb = cv.text((x, y), line, ink, px=14, box=True)
            y = bb[3] + 6 * u

    def _draw_legend(self, cv: _Canvas, overlay, target) -> None:
        u = cv.unit
        items = []
        if self.trace:
            items.append(("trace", "path of the centre of mass" if self._floor else "path of the tip", None))
            items.append(("start", "start", 6.0 if self._floor else "ring"))
        if overlay is not None:
            items.append(("theory", "analytical equilibrium", 7.0))
        if target is not None:
            items.append(("target", "target", "ring"))
        if not items:
            return
        px = 12.5
        x = self.width - 16 * u
        y = 2 * (16 + 46) * u + 22 * u  # under the field dial
        for key, text, style in items:
            w = cv.text_width(text, px=px)
            cv.text((x, y), text, _rgb("muted"), px=px, anchor="rm", box=True)
            x0, x1 = x - w - 36 * u, x - w - 8 * u
            col = _rgb(key) + (255,)
            if style == "ring":
                cv.circle((0.5 * (x0 + x1), y), 6 * u, outline=col, width=2.0)
            else:
                cv.line([(x0, y), (x1, y)], col, 2.4, dash=style)
            y += 20 * u

    def _draw_scale(self, cv: _Canvas, view) -> None:
        x_lo, x_hi, z_lo, z_hi = view
        u = cv.unit
        px_per_m = self.width / (x_hi - x_lo)
        bar = _nice(0.15 * (x_hi - x_lo))
        n = bar * px_per_m
        self.scale_bar = (bar, n)
        ink = _rgb("text")
        if self._floor:  # centred in the floor band
            v0 = self._to_px(view, 0.0, 0.0)[1]
            y = min(0.5 * (v0 + self.height) + 8 * u, self.height - 12 * u)
        else:
            y = self.height - 18 * u
        x = 18 * u
        cv.rect((x, y - 3 * u, x + n, y + 3 * u), ink + (255,))
        for e in (x, x + n):
            cv.rect((e - 1 * u, y - 7 * u, e + 1 * u, y + 7 * u), ink + (255,))
        cv.text((x + 0.5 * n, y - 10 * u), f"{bar / MM:g} mm", ink, px=14, bold=True, anchor="md")
        grid = f"grid {self.minor / MM:g} mm, bold {self.major / MM:g} mm"
        cv.text((self.width - 16 * u, y), grid, _rgb("muted"), px=12, anchor="rm")

    # ------------------------------------------------------------------ zoom inset
    @property
    def end_displacement(self) -> float:
        """x displacement (m) of the rod's first end (s = 0) since the path started (0 before any frame)."""
        if self._end0 is None:
            return 0.0
        return float(self.sim.centerline()[0][0] - self._end0)

    def _zoom_window(self) -> tuple[float, float, float, float]:
        """The zoom window (x_lo, x_hi, z_lo, z_hi) in m: the floor 18 % from its bottom, centred on the
        rod's first end, re-centred only when the end leaves its middle 80 %."""
        x_end = float(self.sim.centerline()[0][0])
        w = self.zoom_span
        if self._zx is None or abs(x_end - self._zx) > 0.4 * w:
            self._zx = x_end
        h = w * self._zoom_size[1] / self._zoom_size[0]
        return self._zx - 0.5 * w, self._zx + 0.5 * w, -0.18 * h, 0.82 * h

    def _zoom_origin(self, unit: float) -> tuple[int, int]:
        """Top-left pixel of the inset in the frame: top centre, between the header and the field dial."""
        zw = self._zoom_size[0]
        return int(round(0.46 * self.width - 0.5 * zw)), int(round(14 * unit))

    def _draw_zoom_outline(self, cv: _Canvas, view, zview) -> None:
        """The zoom window's outline in the scene, and a leader line to the inset."""
        x_lo, x_hi, z_lo, z_hi = zview
        u0, v0 = self._to_px(view, x_lo, z_hi)
        u1, v1 = self._to_px(view, x_hi, z_lo)
        col = _rgb("muted") + (255,)
        cv.line([(u0, v0), (u1, v0), (u1, v1), (u0, v1), (u0, v0)], col, 1.2)
        ox, oy = self._zoom_origin(cv.unit)
        zw, zh = self._zoom_size
        cv.line([(0.5 * (u0 + u1), v0), (ox + 0.5 * zw, oy + zh)], col, 1.0, dash=4.0)

    def _zoom_image(self, unit: float) -> np.ndarray:
        """The inset: the zoomed scene, the ruler from the end's start, the start line and the end's marker."""
        zview = self.zoom_view
        zw, zh = self._zoom_size
        self._scene(zview, self._zoom_renderer, zw, _TICK_MID, _TICK_MAJOR)
        img = self._zoom_renderer.render()
        cv = _Canvas(img)
        cv.unit = unit
        x_lo, x_hi, z_lo, z_hi = zview

        def px(x, z):
            return (x - x_lo) / (x_hi - x_lo) * zw, (z_hi - z) / (z_hi - z_lo) * zh

        ink, muted = _rgb("text") + (255,), _rgb("muted")
        v_floor = px(0.0, 0.0)[1]
        x0 = self._end0 if self._end0 is not None else 0.5 * (x_lo + x_hi)
        k_lo, k_hi = math.ceil((x_lo - x0) / _TICK_MINOR - 1e-9), math.floor((x_hi - x0) / _TICK_MINOR + 1e-9)
        for k in range(k_lo, k_hi + 1):  # the ruler, counted from the end's start position
            u = px(x0 + k * _TICK_MINOR, 0.0)[0]
            major, mid = k % 10 == 0, k % 5 == 0
            length = (13 if major else 9 if mid else 5) * unit
            cv.line([(u, v_floor), (u, v_floor + length)], ink, 1.4 if major else 1.0)
            if major:
                label = "0" if k == 0 else f"{_signed(k / 10, '+.0f')} mm"
                cv.text((u, v_floor + length + 2 * unit), label, ink, px=11, anchor="ma")
        start, robot = _rgb("start") + (255,), _rgb("robot") + (255,)
        if x_lo <= x0 <= x_hi:
            u = px(x0, 0.0)[0]
            cv.line([(u, v_floor), (u, 0.0)], start, 1.4, dash=5.0)
        x_end = float(self.sim.centerline()[0][0])
        u = px(x_end, 0.0)[0]
        s = 6 * unit
        cv.polygon([(u, v_floor + 1), (u - s, v_floor + 1 + 1.6 * s), (u + s, v_floor + 1 + 1.6 * s)], robot)
        mag = self.span / self.zoom_span * zw / self.width
        cv.text((6 * unit, 5 * unit), f"zoom \u00d7{mag:.1f}: rod end s = 0", ink, px=12.5, bold=True, box=True)
        cv.text((6 * unit, 24 * unit), f"end \u0394x = {_signed(self.end_displacement / MM)} mm; ticks 0.1 mm", muted,
                px=11.5, box=True)
        out = cv.result().copy()
        edge = np.array(_rgb("grid_major"), dtype=np.uint8)
        b = max(1, int(round(1.5 * unit)))
        out[:b], out[-b:], out[:, :b], out[:, -b:] = edge, edge, edge, edge
        return out

    # ------------------------------------------------------------------ public
    def render(self, *, field=None, overlay=None, target=None, label: str = "") -> np.ndarray:
        """One frame, shape ``(height, width, 3)`` uint8 (``width`` plus the panel's with ``panel``).

        Parameters
        ----------
        field : Field or (B_x, B_z), optional
            Field to draw (T); default the simulator's.
        overlay : (x, z) arrays, optional
            A centerline (m) drawn dashed in the theory colour.
        target : (x, z), optional
            A point (m) drawn as a ring; the header gives the tip's distance to it.
        label : str
            Title in the header (e.g. the robot's name).
        """
        sim = self.sim
        f = sim.field if field is None else field
        b = planar_field(as_field(f, "field"), "the frame's field arrow (drawn in the x-z plane)").as_array()
        self._record()
        self._source = source_state(sim)
        view = self.view = self._view()
        if self.zoom:
            self.zoom_view = self._zoom_window()
        self._scene(view)
        img = self._renderer.render()
        cv = _Canvas(img)
        if self.zoom:
            self._draw_zoom_outline(cv, view, self.zoom_view)
        if self.trace:
            self._draw_path(cv, view)
        self._draw_overlay(cv, view, overlay, target)
        if self._source is not None:
            self._draw_source(cv, view)
        self._draw_scale(cv, view)
        self._draw_field(cv, b)
        self._draw_header(cv, str(label), target)
        self._draw_legend(cv, overlay, target)
        frame = cv.result()
        if self.zoom:
            inset = self._zoom_image(cv.unit)
            ox, oy = self._zoom_origin(cv.unit)
            frame = frame.copy()
            frame[oy:oy + inset.shape[0], ox:ox + inset.shape[1]] = inset
            self.zoom_box = (ox, oy, inset.shape[1], inset.shape[0])
        if self.panel is not None:
            x = self.displacement if self._floor else self.sim.tip_position()[0]
            frame = np.concatenate([frame, self.panel.update(sim.time, x, b)], axis=1)
        return frame

    def close(self) -> None:
        self._renderer.close()
        if self._zoom_renderer is not None:
            self._zoom_renderer.close()
        if self.panel is not None:
            self.panel.close()


class TimePanel:
    """A side panel for videos: displacement x(t) (mm) above the field B_x(t), B_z(t) (mT); with
    ``components=3`` (the 3D strip) Δx(t) and Δy(t) above B_x(t), B_y(t), B_z(t).

    Drawn with matplotlib (Agg) in the figures' style (:data:`~magsoft_env.render.figures.RC_PARAMS`).
    Each :meth:`update` adds a sample and returns the panel, shape ``(height, width, 3)`` uint8;
    a time before the last sample starts a new history (an environment reset). The axes only
    widen (the time axis in 1-2-5 steps), and between widenings only the curves are redrawn.

    Parameters
    ----------
    height : int
        Pixels; the frame's height.
    width : int or None
        Pixels; default ``0.9 * height`` rounded to even.
    seconds : float or None
        Time axis (s); None: grows in 1-2-5 steps with the time.
    x_label : str or None
        Label of the upper plot; None: ``"Δx centre of mass (mm)"`` (``"centre of mass (mm)"`` with
        ``components=3``).
    components : {2, 3}
        2: :meth:`update` takes a displacement ``x`` and a field ``(B_x, B_z)``; 3: a pair ``(Δx, Δy)`` and
        ``(B_x, B_y, B_z)``.
    """

    def __init__(self, *, height: int, width: int | None = None, seconds: float | None = None,
                 x_label: str | None = None, components: int = 2):
        import matplotlib
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.height = int(height)
        self.width = int(width) if width is not None else 2 * int(round(0.45 * self.height))
        if seconds is not None and not (seconds > 0 and math.isfinite(seconds)):
            raise ValueError(f"seconds must be a time > 0 (s) or None, got {seconds!r}.")
        self.seconds = None if seconds is None else float(seconds)
        if components not in (2, 3):
            raise ValueError(f"components must be 2 (B_x, B_z) or 3 (B_x, B_y, B_z), got {components!r}.")
        self.components = int(components)
        with_y = self.components == 3  # a y displacement and a B_y line
        if x_label is None:
            x_label = "centre of mass (mm)" if with_y else "\u0394x centre of mass (mm)"
        dpi = 120.0 * max(self.height / 540.0, 0.2)
        with matplotlib.rc_context(_rc()):
            self.fig = Figure(figsize=(self.width / dpi, self.height / dpi), dpi=dpi, layout="constrained")
            self.canvas = FigureCanvasAgg(self.fig)
            self.ax_x, self.ax_b = self.fig.subplots(2, 1, sharex=True)
            (self._lx,) = self.ax_x.plot([], [], color=PALETTE["trace"], lw=1.8, label="$\\Delta x$", animated=True)
            self._lines_x = [self._lx]
            if with_y:
                (ly,) = self.ax_x.plot([], [], color=PALETTE["theory"], lw=1.6, ls="--", label="$\\Delta y$",
                                       animated=True)
                self._lines_x.append(ly)
                self.ax_x.legend(loc="upper right", ncols=2)
            (self._lbx,) = self.ax_b.plot([], [], color=PALETTE["field"], lw=1.6, label="$B_x$", animated=True)
            self._lines_b = [self._lbx]
            if with_y:
                (lby,) = self.ax_b.plot([], [], color=PALETTE["field_y"], lw=1.6, ls="-.", label="$B_y$",
                                        animated=True)
                self._lines_b.append(lby)
            (self._lbz,) = self.ax_b.plot([], [], color=PALETTE["field_z"], lw=1.6, ls="--", label="$B_z$",
                                          animated=True)
            self._lines_b.append(self._lbz)
            self.ax_x.set_ylabel(x_label)
            self.ax_b.set_ylabel("field (mT)")
            self.ax_b.set_xlabel("t (s)")
            self.ax_b.legend(loc="upper right", ncols=len(self._lines_b))
            for ax in (self.ax_x, self.ax_b):
                ax.axhline(0.0, color=PALETTE["muted"], lw=0.6)
        self.reset()

    def reset(self) -> None:
        """Forget the history."""
        self._t, self._x, self._b = [], [], []
        self._lims = None
        self._xlim = (-0.1, 0.1)
        self._blim = (-0.5, 0.5)
        self._background = None

    def update(self, t: float, x, b) -> np.ndarray:
        """Add the sample (t s; x m, or (Δx, Δy) m with ``components=3``; b = (B_x, B_z) T, or (B_x, B_y, B_z))
        and draw the panel."""
        import matplotlib

        t = float(t)
        if self._t and t < self._t[-1]:
            self.reset()
        xs = np.atleast_1d(np.asarray(x, dtype=float)).ravel()
        bs = np.asarray(b, dtype=float).ravel()
        if xs.size != len(self._lines_x) or bs.size != self.components:
            raise ValueError(f"this panel takes {len(self._lines_x)} displacement(s) and {self.components} field "
                             f"components, got {xs.size} and {bs.size}.")
        self._t.append(t)
        self._x.append(tuple(xs / MM))
        self._b.append(tuple(bs / MT))
        tx = np.asarray(self._x)
        tb = np.asarray(self._b)
        for k, line in enumerate(self._lines_x):
            line.set_data(self._t, tx[:, k])
        for k, line in enumerate(self._lines_b):
            line.set_data(self._t, tb[:, k])
        t_max = self.seconds if self.seconds is not None else _nice_ceil(max(t, 0.1))
        self._xlim = _grow(self._xlim, float(tx.min()), float(tx.max()))
        self._blim = _grow(self._blim, float(tb.min()), float(tb.max()))
        lims = (t_max, self._xlim, self._blim)
        with matplotlib.rc_context(_rc()):
            if lims != self._lims or self._background is None:  # new axes: draw all, keep it without curves
                self.ax_b.set_xlim(0.0, t_max)
                self.ax_x.set_ylim(*self._xlim)
                self.ax_b.set_ylim(*self._blim)
                self.canvas.draw()
                self._background = self.canvas.copy_from_bbox(self.fig.bbox)
                self._lims = lims
            else:
                self.canvas.restore_region(self._background)
            for line in self._lines_x:
                self.ax_x.draw_artist(line)
            for line in self._lines_b:
                self.ax_b.draw_artist(line)
        img = np.asarray(self.canvas.buffer_rgba())[..., :3]
        if img.shape[:2] != (self.height, self.width):  # the figure size rounds to whole pixels
            out = np.full((self.height, self.width, 3), 255, np.uint8)
            h, w = min(self.height, img.shape[0]), min(self.width, img.shape[1])
            out[:h, :w] = img[:h, :w]
            img = out
        return img.copy()

    def close(self) -> None:
        self.fig.clear()


def _nice_ceil(v: float) -> float:
    """The smallest 1-2-5 number >= v (> 0)."""
    e = math.floor(math.log10(v))
    for m in (1.0, 2.0, 5.0, 10.0):
        if m * 10.0**e >= v * (1 - 1e-12):
            return m * 10.0**e
    return 10.0 ** (e + 1)


def _grow(lim: tuple[float, float], lo: float, hi: float) -> tuple[float, float]:
    """Axis limits that only widen, and then by 30 % of the range beyond the data, so that the
    panel redraws its axes rarely and does not jitter."""
    a, b = lim
    if lo >= a and hi <= b:
        return lim
    pad = 0.3 * max(hi - lo, b - a)
    return (min(a, lo - pad) if lo < a else a, max(b, hi + pad) if hi > b else b)


__all__ = ["RodRenderer", "TimePanel", "dial_scale", "field_text"]

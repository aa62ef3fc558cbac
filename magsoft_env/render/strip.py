"""3D frames of a rod on the floor (the flexcomp strip's own view; any rod's): perspective or top view.

The rod is drawn from its pose (:meth:`Simulator.pose <magsoft_env.sim.Simulator.pose>`: centreline, the pieces'
tangents and width axes) as one box per piece, so its width, thickness, bending and twist show; the floor carries
a mm grid, the strip's drop shadow, the
centre of mass's path, the start, the heading, an optional goal and a scale bar; the field is an arrow in the
scene above the robot and a dial with its three components. The 2-D overlay (text, dial) is drawn as the
side view's is (:class:`~magsoft_env.render.frames._Canvas`). What a frame shows: docs/rendering.md, "The 3D
strip".
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ..gl import bind_headless_context, context_error
from ..spec import as_field
from ..units import MM, MT
from .frames import (
    _ARROW_MAX,
    _ARROW_MIN,
    _FIELD_STEPS,
    _MARKER_NAMES,
    _SOURCE_ARROW,
    _ZERO_FIELD,
    TimePanel,
    _Canvas,
    _nice,
    _rgb,
    _rgba32,
    _signed,
    check_frame_args,
    dial_scale,
    marker_radius,
    source_field_text,
    source_state,
    trace_append,
)

#: The views of the strip.
STRIP_VIEWS = ("perspective", "top")
#: Vertical field of view of the perspective camera (deg): narrow, so that the floor's foreshortening is mild.
_FOVY = 30.0
#: Height (m) of the strip's drop shadow's top above the floor's (z = 0): far below what the frame resolves,
#: far above the depth buffer's step.
_Z_SHADOW = 3e-5
#: The field arrow in the scene: its anchor height, and its full-scale length, as fractions of the beam length.
_ANCHOR_Z, _ARROW_REACH = 0.5, 0.36
#: Opacity of the strip's drop shadow where it touches the floor (it fades as the strip lifts).
_SHADOW_ALPHA = 0.28
#: Radius of the goal's ring, as a fraction of the beam length.
_GOAL_RADIUS = 0.08
#: Opacity of the floor grid's lines (the floor's edge colour): minor, major.
_GRID_ALPHA = (0.16, 0.36)
#: Most path segments drawn (older points are skipped evenly beyond it).
_MAX_DRAWN = 600


def _mix(a: str, b: str, alpha: float) -> np.ndarray:
    """Palette colour ``a`` laid with opacity ``alpha`` over ``b``, as an opaque RGBA (float32): opaque geoms
    cost the renderer less than see-through ones, and overlapping ones do not darken each other."""
    ca, cb = np.array(_rgb(a), float), np.array(_rgb(b), float)
    return np.array([*((alpha * ca + (1.0 - alpha) * cb) / 255.0), 1.0], np.float32)


def _vec(name: str, v, n: int = 2) -> np.ndarray:
    a = np.asarray(v, dtype=float).ravel()
    if a.shape != (n,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be {n} finite numbers (m), got {v!r}.")
    return a


def field_text3(b, *, digits: int = 2) -> str:
    """``"B = (+1.20, −0.50, +3.00) mT"`` for a field ``(B_x, B_y, B_z)`` in T (``"B = 0"`` for zero)."""
    b = np.asarray(b, dtype=float)
    if float(np.linalg.norm(b)) < _ZERO_FIELD:
        return "B = 0"
    f = f"+.{digits}f"
    return "B = (" + ", ".join(_signed(float(v) / MT, f) for v in b) + ") mT"


class StripRenderer:
    """Offscreen 3D frames of a rod on the floor, for videos and environments: the 3D strip's view, and a view of
    any rod (the planar chain too) from its pose.

    A perspective camera above and behind the robot looks down at it (``view="perspective"``, the default), or
    an orthographic camera looks straight down (``view="top"``, x to the right, y up: lengths read true). The
    frame shows, on the floor (a light plane):

    - the strip, one box per edge along its material frame (width, thickness, bending, twist), in the robot
      colour on its top face (one light from straight above; its sides darker), and its drop shadow on the
      floor (fainter as the strip lifts), so a lifted end shows its height;
    - a grid on the floor, lines every ``minor`` (default 1 mm, left out when closer than 7 px at the robot)
      and heavier every ``major`` (5 mm), and a scale bar of 1, 2, 5, 10, ... mm lying on the floor near the
      bottom left with its length; in perspective, lengths on the floor shrink away from the camera, which the
      note bottom right says;
    - the path of the centre of mass since the first frame, the start (a disc), and the heading: an arrow on
      the floor ahead of the tip along the strip's tip-minus-base direction projected on the floor;
    - the field as an arrow in the scene from a point ``0.5 L`` above the centre of mass, with a ring of the
      full-scale length around that point in the horizontal plane; its length is
      ``R * (0.4 + 0.6 * min(|B| / B_ring, 1))`` for the ring's radius ``R`` (the side view's dial rule);
    - a dial top right: the field seen from above, turned as the camera sees the floor (its ``+x``, ``+y``
      marked), with the same length rule for ``|(B_x, B_y)|``, and a gauge of ``B_z`` beside it; the value
      ``B = (B_x, B_y, B_z) mT``, ``|B|`` and the full scale ``ring = B_ring``;
    - the header: the robot's name, the time, the centre of mass's displacement ``(Δx, Δy)`` since the first
      frame and the heading (deg, from +x toward +y); with a goal, the centre of mass's distance to it;
    - an optional goal ``render(goal=(x, y))``: a ring with cross hairs on the floor (or, out of view, an arrow
      at the frame's edge toward it with its distance).

    The renderer remembers the path across :meth:`render` calls and starts a new one when the simulator's time
    goes backwards (an environment reset), so environments only call ``render()``.

    Parameters
    ----------
    sim : Simulator
        A rod in a floor scene (``RodOptions(scene="floor")``), any rod.
    width, height : int
        Frame size (pixels), default 960 x 540.
    view : {"perspective", "top"}
        The camera.
    follow : bool
        Move the view with the robot: the camera's aim follows the centre of mass once it is more than 15 %
        of the view's width from it (smoothly, no jumps). False: a fixed view about the first frame's centre
        of mass.
    span : float or None
        Width of the view (m) at the robot (perspective: across the frame at the camera's aim); default 2.4 L.
    minor, major : float
        Floor grid spacings (m).
    field_scale : float or None
        Full scale ``B_ring`` (T) of the arrow and the dial. None: the smallest of 1, 2, 5, 10, 20, ... mT at or
        above the largest |B| drawn so far (it only grows).
    trace : bool
        Draw the path and the start.
    panel : bool
        Put a :class:`~magsoft_env.render.frames.TimePanel` (Δx, Δy and B_x, B_y, B_z against time) to the right.
    panel_seconds : float or None
        Time axis of the panel (s); None: grows with the time.
    azimuth, elevation : float
        Perspective camera (deg, MuJoCo's free camera): the direction it looks along in the floor plane (from +x
        toward +y; 90 looks along +y, as the side view does, so +x runs to the right) and its angle below the
        horizon (negative: looking down; -75 to -20).

    Attributes
    ----------
    view : str
    displacement, displacement_y : float
        x and y displacement (m) of the centre of mass since the path started.
    heading : float
        The strip's heading now (rad): its tip-minus-base direction in the floor plane, from +x toward +y.
    scale_bar : tuple of float or None
        The last frame's scale bar: length (m) and its length in pixels where it lies.

    Raises
    ------
    RenderBackendError
        When no OpenGL context starts (the message names the packages to install).
    ValueError
        For a simulator that is not on the floor, an unknown view, a size outside [16, 8192] pixels, a
        spacing, span or field scale that is not > 0, an elevation outside [-75, -20] deg.
    """

    def __init__(self, sim, *, width: int = 960, height: int = 540, view: str = "perspective", follow: bool = True,
                 span: float | None = None, minor: float = 1 * MM, major: float = 5 * MM,
                 field_scale: float | None = None, trace: bool = True, panel: bool = False,
                 panel_seconds: float | None = None, azimuth: float = 60.0, elevation: float = -40.0,
                 zoom: bool | None = None):
        opts = getattr(sim, "options", None)
        if opts is None or not hasattr(sim, "pose"):
            raise ValueError(f"StripRenderer draws a magsoft_env.sim.Simulator, got {type(sim).__name__}.")
        if zoom:
            raise ValueError("zoom is the side view's inset of the rod's end; the 3D frames have none.")
        if not opts.has_contact:
            raise ValueError(f"StripRenderer draws a rod on the floor (scene 'floor', 'channel' or 'obstacle'), got "
                             f"scene={opts.scene!r}.")
        if view not in STRIP_VIEWS:
            raise ValueError(f"view must be one of {list(STRIP_VIEWS)} for the 3D strip, got {view!r}.")
        check_frame_args(width, height, minor, major, span, field_scale)
        if not math.isfinite(azimuth):
            raise ValueError(f"azimuth must be a finite angle (deg), got {azimuth!r}.")
        if not -75.0 <= elevation <= -20.0:
            raise ValueError(f"elevation must lie in [-75, -20] deg (looking down at the floor), got {elevation!r}.")
        self.sim = sim
        self.view = view
        self.width, self.height = int(width), int(height)
        self.follow = bool(follow)
        self.minor, self.major = float(minor), float(major)
        self.trace = bool(trace)
        self.azimuth, self.elevation = float(azimuth), float(elevation)
        self._field_scale_fixed = field_scale is not None
        self.field_scale = float(field_scale) if field_scale is not None else _FIELD_STEPS[0]
        beam = sim.beam
        self._L, self._w, self._h = float(beam.length), float(beam.width), float(beam.thickness)
        self.span = float(span) if span is not None else 2.4 * self._L
        vis = sim.model.vis.global_
        vis.offwidth = max(int(vis.offwidth), self.width)
        vis.offheight = max(int(vis.offheight), self.height)
        try:
            bind_headless_context()
            self._renderer = mujoco.Renderer(sim.model, self.height, self.width)
        except Exception as exc:  # noqa: BLE001  (any GL failure gets the same explanation)
            raise context_error(exc) from exc
        flags = self._renderer.scene.flags
        for f in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION,
                  mujoco.mjtRndFlag.mjRND_SKYBOX, mujoco.mjtRndFlag.mjRND_FOG, mujoco.mjtRndFlag.mjRND_HAZE):
            flags[f] = 0
        self._cam = mujoco.MjvCamera()
        self._cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._opt = mujoco.MjvOption()
        self.panel = TimePanel(height=self.height, seconds=panel_seconds, components=3) if panel else None
        self.scale_bar: tuple[float, float] | None = None
        self._glcam = None
        self._source_scale = _FIELD_STEPS[0]  # full scale (T) of the field-at-the-centre arrow under a source
        self._markers: list = []
        self._source_tip = None
        self._reset_path()

    # ------------------------------------------------------------------ state
    def _reset_path(self) -> None:
        self._t: list[float] = []
        self._path: list[tuple[float, float]] = []
        self._start: tuple[float, float] | None = None
        self._look: np.ndarray | None = None

    def _strip(self):
        """Centreline points (n, 3), the pieces' frames (tangent, width axis, thickness axis) and the centre of mass,
        of the current state (the rod's pose)."""
        p = self.sim.pose()
        t, d1 = p.tangents, p.widths
        return p.centreline, (t, d1, np.cross(t, d1)), p.com

    def _record(self, com: np.ndarray) -> None:
        t = float(self.sim.time)
        if self._t and t < self._t[-1] - 1e-12:  # time went backwards: an environment reset
            self._reset_path()
            if self.panel is not None:
                self.panel.reset()
        p = (float(com[0]), float(com[1]))
        if self._start is None:
            self._start = p
            self._look = np.array(p)
        self._t, self._path = trace_append(self._t, self._path, t, p)

    @property
    def displacement(self) -> float:
        """x displacement (m) of the centre of mass since the path started (0 before any frame)."""
        return 0.0 if self._start is None else float(self.sim.pose().com[0] - self._start[0])

    @property
    def displacement_y(self) -> float:
        """y displacement (m) of the centre of mass since the path started (0 before any frame)."""
        return 0.0 if self._start is None else float(self.sim.pose().com[1] - self._start[1])

    @property
    def heading(self) -> float:
        """The rod's tip-minus-base direction in the floor plane (rad, from +x toward +y)."""
        return self.sim.pose().heading

    # ------------------------------------------------------------------ camera
    def _aim(self, com: np.ndarray) -> np.ndarray:
        """The camera's aim on the floor (x, y), dragged along by the centre of mass beyond a dead zone."""
        if self.follow:
            d = com[:2] - self._look
            n = float(np.hypot(*d))
            dead = 0.15 * self.span
            if n > dead:
                self._look = self._look + d * (1.0 - dead / n)
        return self._look

    def _place_camera(self, aim: np.ndarray) -> None:
        cam, L = self._cam, self._L
        if self.view == "top":
            cam.orthographic = 1
            cam.azimuth, cam.elevation = 90.0, -90.0
            cam.lookat[:] = (aim[0], aim[1], 0.0)
            cam.distance = 4.0 * L
            self.sim.model.vis.global_.fovy = self.span * self.height / self.width  # metres when orthographic
        else:
            cam.orthographic = 0
            cam.azimuth, cam.elevation = self.azimuth, self.elevation
            cam.lookat[:] = (aim[0], aim[1], 0.12 * L)
            aspect = self.width / self.height
            cam.distance = self.span / (2.0 * math.tan(math.radians(_FOVY) / 2.0) * aspect)
            self.sim.model.vis.global_.fovy = _FOVY

    def _read_camera(self, scn) -> None:
        """The GL camera of the posed scene, as the renderer uses it without stereo (the mean of the two eyes,
        which stand the model's inter-pupillary distance apart): what :meth:`project` and :meth:`_floor_point`
        use."""
        c0, c1 = scn.camera[0], scn.camera[1]
        fwd, up = np.array(c0.forward, float), np.array(c0.up, float)
        top, bottom = float(c0.frustum_top), float(c0.frustum_bottom)
        half = 0.5 * self.width / self.height * (top - bottom)
        self._glcam = {"pos": 0.5 * (np.array(c0.pos, float) + np.array(c1.pos, float)), "fwd": fwd, "up": up,
                       "right": np.cross(fwd, up), "near": float(c0.frustum_near), "top": top, "bottom": bottom,
                       "center": 0.5 * (float(c0.frustum_center) + float(c1.frustum_center)), "half": half,
                       "ortho": bool(c0.orthographic)}

    def project(self, points) -> np.ndarray:
        """Pixel coordinates ``(u, v)`` (u right, v down) of world points (m), shape ``(..., 2)``, in the last
        frame's camera (before any frame: a ValueError). Points behind a perspective camera give NaN."""
        if self._glcam is None:
            raise ValueError("project() needs a rendered frame (call render() first).")
        c = self._glcam
        p = np.asarray(points, dtype=float)
        d = p - c["pos"]
        xc, yc, zc = d @ c["right"], d @ c["up"], d @ c["fwd"]
        if not c["ortho"]:
            with np.errstate(divide="ignore", invalid="ignore"):
                k = np.where(zc > 1e-9, c["near"] / zc, np.nan)
            xc, yc = xc * k, yc * k
        u = (xc - (c["center"] - c["half"])) / (2.0 * c["half"]) * self.width
        v = (c["top"] - yc) / (c["top"] - c["bottom"]) * self.height
        return np.stack([u, v], axis=-1)

    def _floor_point(self, u: float, v: float) -> np.ndarray | None:
        """The floor point (x, y, 0) seen at pixel (u, v); None above the horizon."""
        c = self._glcam
        sx = c["center"] - c["half"] + u / self.width * 2.0 * c["half"]
        sy = c["top"] - v / self.height * (c["top"] - c["bottom"])
        if c["ortho"]:
            o, d = c["pos"] + sx * c["right"] + sy * c["up"], c["fwd"]
        else:
            o, d = c["pos"], c["near"] * c["fwd"] + sx * c["right"] + sy * c["up"]
        if d[2] > -1e-12:
            return None
        return o - (o[2] / d[2]) * d

    # ------------------------------------------------------------------ scene (GL)
    @staticmethod
    def _add(scn, kind, size, pos, mat, rgba):
        if scn.ngeom >= scn.maxgeom:
            return None
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, kind, np.asarray(size, float), np.asarray(pos, float),
                            np.asarray(mat, float).ravel(), np.asarray(rgba, np.float32))
        g.specular, g.emission, g.reflectance, g.shininess = 0.0, 0.0, 0.0, 0.0
        scn.ngeom += 1
        return g

    @staticmethod
    def _connect(scn, kind, a, b, rgba, width):
        if scn.ngeom >= scn.maxgeom:
            return
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, kind, np.zeros(3), np.zeros(3), np.eye(3).ravel(), np.asarray(rgba, np.float32))
        mujoco.mjv_connector(g, kind, width, np.asarray(a, float), np.asarray(b, float))
        g.specular, g.emission, g.reflectance, g.shininess = 0.0, 0.0, 0.0, 0.0
        scn.ngeom += 1

    def _floor(self, scn, aim) -> None:
        """The floor: a large flat box, its top at z = 0 (its grid is drawn on the floor layer)."""
        big = 40.0 * self.span
        self._add(scn, mujoco.mjtGeom.mjGEOM_BOX, (big, big, 1e-4), (aim[0], aim[1], -1e-4), np.eye(3),
                  _rgba32("floor"))

    def _features(self, scn) -> None:
        """The scene's boxes (the channel's walls and ceiling, the obstacle), translucent so the rod shows through
        (the ceiling most)."""
        from ..sim.model import scene_features

        for name, size, pos in scene_features(self.sim.beam, self.sim.options):
            alpha = 0.25 if name.endswith("ceiling") else 0.55
            self._add(scn, mujoco.mjtGeom.mjGEOM_BOX, size, pos, np.eye(3), _rgba32("scene", alpha))

    def _strip_boxes(self, scn, x, frames) -> None:
        """One box per edge along its material frame, lengthened into the wedge that opens on the outside of
        each bend so the strip shows without notches; and its drop shadow on the floor."""
        t, d1, d2 = frames
        w, h = self._w, self._h
        mid = 0.5 * (x[:-1] + x[1:])
        length = np.linalg.norm(np.diff(x, axis=0), axis=1)
        ext = np.zeros(len(t) - 1)
        for k in range(len(t) - 1):
            b = np.cross(t[k], t[k + 1])
            s = float(np.linalg.norm(b))
            if s < 1e-9:
                continue
            ang = math.atan2(s, float(t[k] @ t[k + 1]))
            n = np.cross(b / s, t[k])  # the section's direction toward the outside of the bend
            reach = 0.5 * (h * abs(float(n @ d2[k])) + w * abs(float(n @ d1[k])))
            ext[k] = reach * math.tan(min(ang, 1.2) / 2.0)
        robot = _rgba32("robot")
        for i in range(len(t)):
            left = ext[i - 1] if i > 0 else 0.0
            right = ext[i] if i < len(ext) else 0.0
            half_len = 0.5 * length[i] + 0.5 * (left + right)
            c = mid[i] + t[i] * 0.5 * (right - left)
            mat = np.column_stack([t[i], d1[i], d2[i]])
            self._add(scn, mujoco.mjtGeom.mjGEOM_BOX, (half_len, 0.5 * w, 0.5 * h), c, mat, robot)
            # the shadow: the box's footprint straight down, fainter the higher it is
            txy = t[i][:2]
            n = float(np.hypot(*txy))
            if n < 1e-6:
                continue
            e = txy / n
            perp = np.array([-e[1], e[0]])
            foot_len = half_len * n + 0.5 * (w * abs(float(d1[i][:2] @ e)) + h * abs(float(d2[i][:2] @ e)))
            foot_w = 0.5 * (w * abs(float(d1[i][:2] @ perp)) + h * abs(float(d2[i][:2] @ perp)))
            lift = max(float(c[2]) - 0.5 * h, 0.0)
            rgba = _mix("robot", "floor", _SHADOW_ALPHA * max(0.25, 1.0 - lift / (0.4 * self._L)))
            mat2 = np.array([[e[0], -e[1], 0.0], [e[1], e[0], 0.0], [0.0, 0.0, 1.0]])
            self._add(scn, mujoco.mjtGeom.mjGEOM_BOX, (foot_len, foot_w, 1e-5), (c[0], c[1], _Z_SHADOW - 1e-5),
                      mat2, rgba)

    def _field_arrow(self, scn, com, b) -> None:
        """The field as an arrow from a point above the centre of mass, and the full-scale ring around it."""
        L = self._L
        anchor = np.array([com[0], com[1], _ANCHOR_Z * L])
        R = _ARROW_REACH * L
        ring = _mix("muted", "floor", 0.55)
        ang = np.linspace(0.0, 2 * math.pi, 41)
        pts = anchor + R * np.column_stack([np.cos(ang), np.sin(ang), np.zeros_like(ang)])
        lw = max(1.0, 1.2 * self.height / 540.0)
        for a, c in zip(pts[:-1], pts[1:], strict=True):
            self._connect(scn, mujoco.mjtGeom.mjGEOM_LINE, a, c, ring, lw)
        col = _rgba32("field")
        self._add(scn, mujoco.mjtGeom.mjGEOM_SPHERE, (0.022 * L, 0, 0), anchor, np.eye(3), col)
        bmag = float(np.linalg.norm(b))
        if bmag > 0:
            length = R * (_ARROW_MIN + (_ARROW_MAX - _ARROW_MIN) * min(bmag / self.field_scale, 1.0))
            self._connect(scn, mujoco.mjtGeom.mjGEOM_ARROW, anchor, anchor + length * b / bmag, col, 0.014 * L)
        self._anchor = anchor

    def _near(self, state, aim):
        """The source's markers near the view (within four view widths of the camera's aim): (kind, (3,))."""
        out = []
        for kind, pts in state["markers"]:
            for p in np.asarray(pts, dtype=float):
                if np.linalg.norm(p[:2] - np.asarray(aim, dtype=float)[:2]) <= 4.0 * self.span:
                    out.append((kind, p))
        return out

    def _source_arrow(self, state):
        """(base, tip) of the arrow of the field at the centre of mass (m), or (base, None) for a zero field."""
        b = state["B"]
        bmag = float(np.linalg.norm(b))
        if bmag > self._source_scale:
            self._source_scale = dial_scale(bmag)
        base = state["centre"] + np.array([0.0, 0.0, 0.6 * self._h])
        if bmag < _ZERO_FIELD:
            return base, None
        R = _ARROW_REACH * self._L
        length = R * (_ARROW_MIN + (_ARROW_MAX - _ARROW_MIN) * min(bmag / self._source_scale, 1.0))
        return base, base + length * b / bmag

    def _source_geoms(self, scn, state, aim) -> None:
        """Spheres at the source's magnets, dipoles and loop centres near the view, and the arrow of the field at
        the robot's centre of mass (drive plus source)."""
        self._markers = self._near(state, aim)
        r = marker_radius(self._L)
        for _, p in self._markers:
            self._add(scn, mujoco.mjtGeom.mjGEOM_SPHERE, (r, 0, 0), p, np.eye(3), _rgba32("field"))
        base, tip = self._source_arrow(state)
        col = _rgba32(_SOURCE_ARROW)
        self._add(scn, mujoco.mjtGeom.mjGEOM_SPHERE, (0.02 * self._L, 0, 0), base, np.eye(3), col)
        if tip is not None:
            self._connect(scn, mujoco.mjtGeom.mjGEOM_ARROW, base, tip, col, 0.012 * self._L)
        self._source_tip = base if tip is None else tip

    def _draw_source(self, cv: _Canvas, state) -> None:
        """The markers named where they show, and the field at the centre of mass labelled in mT."""
        u = cv.unit
        for kind, p in self._markers:
            q = self.project(p + np.array([0.0, 0.0, 1.3 * marker_radius(self._L)]))
            if np.isfinite(q).all() and 0 <= q[0] <= self.width and 0 <= q[1] <= self.height:
                cv.text((q[0], q[1] - 2 * u), _MARKER_NAMES.get(kind, kind), _rgb("field"), px=12.5, anchor="md",
                        box=True)
        q = self.project(self._source_tip)
        if np.isfinite(q).all():
            cv.text((q[0] + 8 * u, q[1]), source_field_text(state["B"]), _rgb(_SOURCE_ARROW) + (255,), px=12.5,
                    bold=True, anchor="lm", box=True)

    def _lights(self, scn) -> None:
        """One directional light straight down (a face turned up shows its colour), no headlight."""
        light = scn.lights[0]
        light.type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
        light.headlight = 0
        light.castshadow = 0
        light.dir[:] = (0.0, 0.0, -1.0)
        light.pos[:] = (0.0, 0.0, 1.0)
        light.ambient[:] = 0.42
        light.diffuse[:] = 0.58
        light.specular[:] = 0.0
        scn.nlight = 1

    # ------------------------------------------------------------------ floor layer (2-D, under the strip)
    def _floor_mask(self, img: np.ndarray) -> np.ndarray:
        """Pixels of the floor and the strip's shadow: those on the floor-to-robot colour line no further than
        the shadow's darkest mix (lit straight from above, the floor shows its own colour). The floor layer is
        drawn there only, so the strip, the field arrow and its ring hide what lies under them."""
        f = np.array(_rgb("floor"), np.float32)
        d = np.array(_rgb("robot"), np.float32) - f
        # how far each pixel lies from the floor's colour toward the robot's; the strip's faces (1 and darker),
        # the field's red and the ring's grey all lie beyond the shadow's darkest mix
        k = (img.astype(np.float32) @ d - float(f @ d)) / float(d @ d)
        return k <= _SHADOW_ALPHA + 0.04

    def _floor_px(self, pts) -> np.ndarray:
        """Pixels of floor points (x, y) (m), shape (n, 2)."""
        p = np.asarray(pts, float).reshape(-1, 2)
        return self.project(np.column_stack([p, np.zeros(len(p))]))

    def _clip_floor(self, a, b):
        """The part of the floor segment a-b (x, y) in front of the camera, in pixels; None if none."""
        c = self._glcam
        if c["ortho"]:
            return self._floor_px([a, b])
        pa, pb = np.r_[a, 0.0], np.r_[b, 0.0]
        za, zb = (pa - c["pos"]) @ c["fwd"], (pb - c["pos"]) @ c["fwd"]
        lim = 2.0 * c["near"]
        if za < lim and zb < lim:
            return None
        if za < lim:
            pa = pa + (pb - pa) * (lim - za) / (zb - za)
        elif zb < lim:
            pb = pb + (pa - pb) * (lim - zb) / (za - zb)
        return self.project(np.stack([pa, pb]))

    def _draw_floor(self, cv: _Canvas, img: np.ndarray, aim, x, com, goal):
        """Grid, path, start, heading arrow, goal and scale bar on the floor, where the floor shows.
        Returns the scale bar ``(length, p0, p1)`` (m) or None."""
        from PIL import Image, ImageDraw

        base = cv.im
        layer = base.copy()
        cv.draw = ImageDraw.Draw(layer, "RGBA")
        L = self._L
        # the grid: lines every minor (where at least 7 px apart at the camera's aim) and every major step, over
        # the part of the floor in view (minor lines within 0.9 span of the aim, where they stay apart)
        px_per_m = self.width / self.span
        seen = [self._floor_point(pu, pv) for pu in (0.0, self.width) for pv in (0.0, 0.5 * self.height, self.height)]
        seen = np.array([q[:2] for q in seen if q is not None] or [aim])
        seen = np.clip(seen, aim - 3.0 * self.span, aim + 3.0 * self.span)
        edge = _rgb("floor_edge")
        for step, r, alpha, lw in ((self.minor, 0.9 * self.span, _GRID_ALPHA[0], 1.0),
                                   (self.major, 3.0 * self.span, _GRID_ALPHA[1], 1.5)):
            lo = np.maximum(seen.min(axis=0), aim - r)
            hi = np.minimum(seen.max(axis=0), aim + r)
            if step * px_per_m < 7 or np.any(hi <= lo) or np.max(hi - lo) / step > 800:
                continue
            col = edge + (int(255 * alpha),)
            for g in np.arange(math.ceil(lo[0] / step) * step, hi[0], step):
                seg = self._clip_floor((g, lo[1]), (g, hi[1]))
                if seg is not None:
                    cv.line(seg, col, lw)
            for g in np.arange(math.ceil(lo[1] / step) * step, hi[1], step):
                seg = self._clip_floor((lo[0], g), (hi[0], g))
                if seg is not None:
                    cv.line(seg, col, lw)
        ang = np.linspace(0.0, 2 * math.pi, 41)
        circle = np.column_stack([np.cos(ang), np.sin(ang)])
        if self.trace and self._path:
            p = np.asarray(self._path)
            if len(p) > _MAX_DRAWN:
                keep = np.unique(np.r_[np.linspace(0, len(p) - 1, _MAX_DRAWN).astype(int), len(p) - 1])
                p = p[keep]
            start = np.asarray(self._start)
            cv.polygon(self._floor_px(start + 0.03 * L * circle), _rgb("start") + (255,))
            if len(p) > 1:
                cv.line(self._floor_px(p), _rgb("trace") + (255,), 3.0)
            cv.polygon(self._floor_px(com[:2] + 0.015 * L * circle), _rgb("trace") + (255,))
        # heading: a flat arrow on the floor ahead of the tip, along tip - base
        d = x[-1, :2] - x[0, :2]
        n = float(np.hypot(*d))
        if n > 1e-9:
            e = d / n
            o = np.array([-e[1], e[0]])
            a = x[-1, :2] + 0.05 * L * e
            hw, hl, ln = 0.012 * L, 0.08 * L, 0.3 * L
            shaft = [a + hw * o, a + (ln - hl) * e + hw * o, a + (ln - hl) * e - hw * o, a - hw * o]
            head = [a + (ln - hl) * e + 3 * hw * o, a + ln * e, a + (ln - hl) * e - 3 * hw * o]
            col = _rgb("theory") + (255,)
            cv.polygon(self._floor_px(shaft), col)
            cv.polygon(self._floor_px(head), col)
        if goal is not None:
            r = _GOAL_RADIUS * L
            col = _rgb("target") + (255,)
            cv.line(self._floor_px(goal + r * circle), col, 3.0)
            for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                e = np.array([dx, dy], float)
                cv.line(self._floor_px([goal + 0.45 * r * e, goal + 1.7 * r * e]), col, 2.0)
        bar = None
        p0 = self._floor_point(0.05 * self.width, 0.9 * self.height)
        if p0 is not None:  # a 1-2-5 mm bar on the floor, along the camera's right
            rr = self._glcam["right"][:2]
            rr = rr / float(np.hypot(*rr))
            f = np.array([-rr[1], rr[0]])
            length = _nice(0.15 * self.span)
            q0, q1 = p0[:2], p0[:2] + length * rr
            hw = 0.006 * self.span
            ink = _rgb("text") + (255,)
            cv.polygon(self._floor_px([q0 + hw * f, q1 + hw * f, q1 - hw * f, q0 - hw * f]), ink)
            for q in (q0, q1):
                cv.line(self._floor_px([q - 3 * hw * f, q + 3 * hw * f]), ink, 1.6)
            bar = (length, np.r_[q0, 0.0], np.r_[q1, 0.0])
        mask = Image.fromarray((self._floor_mask(img) * 255).astype(np.uint8)).resize(base.size,
                                                                                       Image.Resampling.NEAREST)
        self._mask = mask
        cv.im = Image.composite(layer, base, mask)
        cv.draw = ImageDraw.Draw(cv.im, "RGBA")
        return bar

    # ------------------------------------------------------------------ overlay (2-D)
    def _draw_labels(self, cv: _Canvas, goal, bar) -> None:
        u = cv.unit
        if self.trace and self._start is not None:
            s = self.project(np.array([self._start[0], self._start[1], 0.0]))
            if self._shows_floor(s):
                cv.text((s[0], s[1] + 9 * u), "start", _rgb("start"), px=12.5, anchor="ma", box=True)
        if bar is not None:
            length, p0, p1 = bar
            a, b = self.project(p0), self.project(p1)
            n = float(np.hypot(*(b - a)))
            self.scale_bar = (length, n)
            m = 0.5 * (a + b)
            cv.text((m[0], m[1] - 9 * u), f"{length / MM:g} mm", _rgb("text"), px=14, bold=True, anchor="md",
                    box=True)
        note = f"floor grid {self.minor / MM:g} mm, bold {self.major / MM:g} mm"
        if self.view == "perspective":
            note += " (perspective: lengths shrink with depth)"
        cv.text((self.width - 14 * u, self.height - 12 * u), note, _rgb("muted"), px=12, anchor="rd", box=True)
        if goal is not None:
            g = self.project(np.array([goal[0], goal[1], 0.0]))
            col = _rgb("target")
            inside = np.all(np.isfinite(g)) and 0 <= g[0] <= self.width and 0 <= g[1] <= self.height
            if inside:
                r = self.project(np.array([goal[0], goal[1] + 1.7 * _GOAL_RADIUS * self._L, 0.0]))
                top = min(float(g[1]), float(r[1])) if np.all(np.isfinite(r)) else float(g[1])
                cv.text((g[0], top - 6 * u), "goal", col, px=13, bold=True, anchor="md", box=True)
            else:  # an arrow at the frame's edge, toward the goal
                com = self.sim.pose().com
                c = self.project(np.array([com[0], com[1], 0.0]))
                if not np.all(np.isfinite(g)):  # behind the camera: the direction on the floor, as the dial turns it
                    right, up = self._dial_axes()
                    gd = np.asarray(goal, float) - com[:2]
                    g = c + np.array([gd @ right, -(gd @ up)])
                d = g - c
                n = float(np.hypot(*d))
                if n > 0:
                    e = d / n
                    # the frame's edge, below the header: the box [m, W - m] x [top, H - m]
                    m, top = 26 * u, 118 * u
                    c0 = np.array([0.5 * self.width, 0.5 * (top + self.height - m)])
                    hx, hy = 0.5 * self.width - m, 0.5 * (self.height - m - top)
                    k = min(hx / max(abs(e[0]), 1e-9), hy / max(abs(e[1]), 1e-9))
                    tip = c0 + k * e
                    cv.arrow(tip - 30 * u * e, tip, col + (255,), width=3.0, head=12 * u)
                    dist = math.hypot(goal[0] - com[0], goal[1] - com[1])
                    text = f"goal {dist / MM:.1f} mm"
                    tw, th = cv.text_width(text, px=12.5, bold=True), 14 * u
                    reach = 0.5 * (tw * abs(e[0]) + th * abs(e[1])) + 38 * u  # the box clear of the arrow
                    cv.text(tip - reach * e, text, col, px=12.5, bold=True, anchor="mm", box=True)

    def _shows_floor(self, px) -> bool:
        """Whether the floor shows at pixel ``px`` of the last frame (in the frame, not under the strip)."""
        if not np.all(np.isfinite(px)) or not (0 <= px[0] < self.width and 0 <= px[1] < self.height):
            return False
        k = self._mask.size[0] // self.width
        return bool(self._mask.getpixel((int(px[0] * k), int(px[1] * k))))

    def _draw_header(self, cv: _Canvas, label: str, goal, com) -> None:
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
        dx, dy = float(com[0] - self._start[0]), float(com[1] - self._start[1])
        lines = [f"\u0394x = {_signed(dx / MM)} mm, \u0394y = {_signed(dy / MM)} mm (centre of mass)",
                 f"heading {_signed(math.degrees(self.heading), '+.1f')}\u00b0 (tip \u2212 base, from +x toward +y)"]
        if goal is not None:
            d = math.hypot(float(goal[0] - com[0]), float(goal[1] - com[1]))
            lines.append(f"centre of mass to goal = {d / MM:.2f} mm")
        for line in lines:
            bb = cv.text((x, y), line, ink, px=14, box=True)
            y = bb[3] + 6 * u

    def _dial_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """World (x, y) directions that point right and up on the dial: the floor as the camera sees it."""
        if self.view == "top":
            return np.array([1.0, 0.0]), np.array([0.0, 1.0])
        a = math.radians(self.azimuth)
        fwd = np.array([math.cos(a), math.sin(a)])
        return np.array([fwd[1], -fwd[0]]), fwd

    def _draw_field(self, cv: _Canvas, b: np.ndarray) -> None:
        u = cv.unit
        R = 42 * u
        m = 16 * u
        gauge = 16 * u
        c = np.array([self.width - m - gauge - 10 * u - R, m + R])
        col = _rgb("field") + (255,)
        grid = _rgb("grid_major") + (255,)
        muted = _rgb("muted")
        cv.circle(c, R + 4 * u, fill=(255, 255, 255, 190))
        cv.rect((c[0] + R + 6 * u, c[1] - R - 4 * u, c[0] + R + 10 * u + gauge, c[1] + R + 4 * u), (255, 255, 255, 190),
                radius=4 * u)
        cv.circle(c, R, outline=grid, width=1.2)
        right, up = self._dial_axes()
        for name, e in (("+x", np.array([1.0, 0.0])), ("+y", np.array([0.0, 1.0]))):
            d = np.array([e @ right, -(e @ up)])
            cv.line([c + 0.8 * R * d, c + R * d], grid, 1.4)
            cv.text(c + (R + 1 * u) * d * 0.6, name, muted, px=10.5, anchor="mm")
        for k in range(4):  # the other ticks
            e = np.array([math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)])
            d = np.array([e @ right, -(e @ up)])
            cv.line([c + 0.88 * R * d, c + R * d], grid, 1.0)
        bh = float(np.hypot(b[0], b[1]))
        if bh >= _ZERO_FIELD:
            length = R * (_ARROW_MIN + (_ARROW_MAX - _ARROW_MIN) * min(bh / self.field_scale, 1.0))
            d = np.array([b[:2] @ right, -(b[:2] @ up)]) / bh
            cv.arrow(c, c + length * d, col, width=3.6, head=13 * u)
        cv.circle(c, 3.0 * u, fill=col)
        # the B_z gauge: a bar from the middle, up for +z, full height at the full scale
        gx = c[0] + R + 8 * u + 0.5 * gauge
        cv.line([(gx, c[1] - R), (gx, c[1] + R)], grid, 1.2)
        cv.line([(gx - 0.4 * gauge, c[1]), (gx + 0.4 * gauge, c[1])], grid, 1.2)
        if abs(b[2]) >= _ZERO_FIELD:
            hz = R * min(abs(b[2]) / self.field_scale, 1.0) * math.copysign(1.0, b[2])
            cv.rect((gx - 0.3 * gauge, min(c[1], c[1] - hz), gx + 0.3 * gauge, max(c[1], c[1] - hz)), col)
        cv.text((gx, c[1] + R + 8 * u), "Bz", muted, px=10.5, anchor="ma")
        bmag = float(np.linalg.norm(b))
        tx = c[0] - R - 10 * u
        cv.text((tx, c[1] - 3 * u), field_text3(b), col, px=16, bold=True, anchor="rd", box=True)
        sub = (f"|B| = {bmag / MT:.2f} mT   " if bmag >= _ZERO_FIELD else "") + f"ring = {self.field_scale / MT:g} mT"
        cv.text((tx, c[1] + 5 * u), sub, muted, px=12.5, anchor="ra", box=True)
        cv.text((c[0] + R, c[1] + R + 8 * u), "seen from above", muted, px=10.5, anchor="ra")

    def _draw_legend(self, cv: _Canvas, goal) -> None:
        u = cv.unit
        items = []
        if self.trace:
            items.append(("trace", "path of the centre of mass", "line"))
            items.append(("start", "start", "dot"))
        items.append(("theory", "heading (tip \u2212 base)", "arrow"))
        items.append(("field", "field (arrow over the robot)", "arrow"))
        if goal is not None:
            items.append(("target", "goal", "ring"))
        px = 12.5
        x = self.width - 16 * u
        y = 2 * (16 + 42) * u + 40 * u
        for key, text, style in items:
            w = cv.text_width(text, px=px)
            cv.text((x, y), text, _rgb("muted"), px=px, anchor="rm", box=True)
            x0, x1 = x - w - 36 * u, x - w - 8 * u
            col = _rgb(key) + (255,)
            if style == "ring":
                cv.circle((0.5 * (x0 + x1), y), 6 * u, outline=col, width=2.0)
            elif style == "dot":
                cv.circle((0.5 * (x0 + x1), y), 5 * u, fill=col)
            elif style == "arrow":
                cv.arrow((x0, y), (x1, y), col, width=2.4, head=8 * u)
            else:
                cv.line([(x0, y), (x1, y)], col, 2.4)
            y += 20 * u

    # ------------------------------------------------------------------ public
    def render(self, *, field=None, goal=None, label: str = "", overlay=None, target=None) -> np.ndarray:
        """One frame, shape ``(height, width, 3)`` uint8 (``width`` plus the panel's with ``panel``).

        Parameters
        ----------
        field : Field, (B_x, B_y, B_z) or (B_x, B_z), optional
            Field to draw (T); default the simulator's (under a field source: the source's at the centre of mass).
        goal : (x, y), optional
            A point on the floor (m), drawn as a ring with cross hairs; the header gives the centre of mass's
            distance to it.
        label : str
            Title in the header (e.g. the robot's name).
        overlay, target
            The side view's drawings (x-z plane); must be None here.
        """
        if overlay is not None or target is not None:
            raise ValueError("the 3D strip's frames take goal=(x, y) on the floor; overlay and target are the side "
                             "view's (x, z) drawings.")
        sim = self.sim
        state = source_state(sim)
        if field is None and state is not None:  # under a source: the field at the robot's centre
            b = np.asarray(state["B"], dtype=float)
        else:
            b = as_field(sim.field if field is None else field, "field").vector()
        goal = None if goal is None else _vec("goal", goal)
        bmag = float(np.linalg.norm(b))
        if bmag < _ZERO_FIELD:
            b, bmag = np.zeros(3), 0.0
        if not self._field_scale_fixed and bmag > self.field_scale:
            self.field_scale = max(self.field_scale, dial_scale(bmag))
        x, frames, com = self._strip()
        self._record(com)
        aim = self._aim(com)
        self._place_camera(aim)
        r = self._renderer
        r.update_scene(sim.data, camera=self._cam, scene_option=self._opt)
        scn = r.scene
        self._read_camera(scn)
        scn.ngeom = 0  # the scene is drawn here, not from the model's geoms (the flex, the floor plane)
        self._lights(scn)
        self._floor(scn, aim)
        self._features(scn)
        self._strip_boxes(scn, x, frames)
        self._field_arrow(scn, com, b)
        if state is not None:
            self._source_geoms(scn, state, aim)
        img = r.render()
        cv = _Canvas(img)
        bar = self._draw_floor(cv, img, aim, x, com, goal)
        self._draw_labels(cv, goal, bar)
        if state is not None:
            self._draw_source(cv, state)
        self._draw_field(cv, b)
        self._draw_header(cv, str(label), goal, com)
        self._draw_legend(cv, goal)
        frame = cv.result()
        if self.panel is not None:
            frame = np.concatenate([frame, self.panel.update(sim.time, (self.displacement, self.displacement_y), b)],
                                   axis=1)
        return frame

    def close(self) -> None:
        self._renderer.close()
        if self.panel is not None:
            self.panel.close()


__all__ = ["STRIP_VIEWS", "StripRenderer", "field_text3"]

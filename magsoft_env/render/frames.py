"""Side-view frames of a :class:`~magsoft_env.sim.Simulator`: mm grid, field arrow, overlays."""

from __future__ import annotations

import mujoco
import numpy as np

from ..gl import bind_headless_context, context_error
from ..units import MM

_MINOR_RGBA = np.array([0.75, 0.78, 0.82, 1.0], dtype=np.float32)
_MAJOR_RGBA = np.array([0.45, 0.50, 0.58, 1.0], dtype=np.float32)
_ARROW_RGBA = np.array([0.85, 0.15, 0.10, 1.0], dtype=np.float32)
_OVERLAY_RGBA = np.array([0.10, 0.45, 0.95, 1.0], dtype=np.float32)
_TARGET_RGBA = np.array([0.10, 0.75, 0.25, 1.0], dtype=np.float32)


class RodRenderer:
    """Offscreen side-camera frames of a rod.

    The camera looks along +y at the x-z plane. Behind the rod: a grid with lines every
    ``minor`` (m, default 1 mm) and heavier lines every ``major`` (default 5 mm), labelled in
    mm. A red arrow shows the applied field (length ``arrow_per_tesla`` m per T, capped); an
    optional blue polyline overlays another shape (e.g. the analytical quasi-static
    equilibrium) and a green dot a target point.

    Parameters
    ----------
    sim : Simulator
        Built with ``RodOptions(render=True)`` for the visual box geoms (otherwise only the
        floor and the grid show).
    width, height : int
        Frame size (pixels).
    follow : bool
        Keep the centre of the rod in view (crawlers); False: fixed view of the clamp region.
    span : float or None
        Width of the view (m); default 2.4 L.
    minor, major : float
        Grid spacings (m).
    arrow_per_tesla : float
        Field-arrow length per tesla (m/T); default 4 mm per mT.

    Raises
    ------
    RenderBackendError
        When no OpenGL context starts (the message names the packages to install).
    """

    def __init__(self, sim, *, width: int = 480, height: int = 270, follow: bool = True, span: float | None = None,
                 minor: float = 1 * MM, major: float = 5 * MM, arrow_per_tesla: float = 4.0):
        self.sim = sim
        self.width, self.height = int(width), int(height)
        self.follow = bool(follow)
        L = sim.beam.length
        self.span = 2.4 * L if span is None else float(span)
        self.minor, self.major = float(minor), float(major)
        self.arrow_per_tesla = float(arrow_per_tesla)
        vis = sim.model.vis.global_
        vis.offwidth = max(int(vis.offwidth), self.width)
        vis.offheight = max(int(vis.offheight), self.height)
        try:
            bind_headless_context()  # EGL or OSMesa when mujoco was imported without MUJOCO_GL
            self._renderer = mujoco.Renderer(sim.model, self.height, self.width)
        except Exception as exc:  # noqa: BLE001  (any GL failure gets the same explanation)
            raise context_error(exc) from exc
        self._cam = mujoco.MjvCamera()
        self._cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        self._cam.azimuth = 90.0
        self._cam.elevation = 0.0
        # orthographic: the mm grid reads true at any depth; the free camera's vertical extent
        # is the model's global fovy, in metres
        self._cam.orthographic = 1
        self._x0 = 0.5 * L
        self._opt = mujoco.MjvOption()

    def _center(self) -> tuple[float, float]:
        x, z = self.sim.centerline()
        if self.follow:
            cx = float(np.mean(x))
            # move the view in whole major-grid steps so the grid does not crawl with the rod
            if abs(cx - self._x0) > 0.25 * self.span:
                self._x0 = cx
            return self._x0, 0.3 * self.span * self.height / self.width
        return 0.3 * self.sim.beam.length, 0.0  # clamp region, fixed

    def _line(self, scn, a, b, rgba, width):
        self._connector(scn, mujoco.mjtGeom.mjGEOM_LINE, a, b, rgba, width)

    def _arrow(self, scn, a, b, rgba, radius):
        self._connector(scn, mujoco.mjtGeom.mjGEOM_ARROW, a, b, rgba, radius)

    @staticmethod
    def _connector(scn, kind, a, b, rgba, width):
        if scn.ngeom >= scn.maxgeom:
            return
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, kind, np.zeros(3), np.zeros(3), np.eye(3).ravel(), rgba)
        mujoco.mjv_connector(g, kind, width, np.asarray(a, float), np.asarray(b, float))
        scn.ngeom += 1

    def _sphere(self, scn, p, rgba, radius):
        if scn.ngeom >= scn.maxgeom:
            return
        g = scn.geoms[scn.ngeom]
        mujoco.mjv_initGeom(g, mujoco.mjtGeom.mjGEOM_SPHERE, np.array([radius, 0, 0]), np.asarray(p, float),
                            np.eye(3).ravel(), rgba)
        scn.ngeom += 1

    def render(self, *, field=None, overlay=None, target=None, label: str = "") -> np.ndarray:
        """One frame, shape ``(height, width, 3)`` uint8.

        Parameters
        ----------
        field : Field or (B_x, B_z), optional
            Field to draw (T); default the simulator's.
        overlay : (x, z) arrays, optional
            A centerline (m) drawn in blue.
        target : (x, z), optional
            A point (m) drawn in green.
        label : str
            Extra text for the caption.
        """
        sim = self.sim
        cx, cz = self._center()
        half_w = 0.5 * self.span
        half_h = half_w * self.height / self.width
        cam = self._cam
        cam.lookat[:] = (cx, 0.0, cz)
        cam.distance = 10.0 * self.span
        sim.model.vis.global_.fovy = 2.0 * half_h
        r = self._renderer
        r.update_scene(sim.data, camera=cam, scene_option=self._opt)
        scn = r.scene
        y = sim.beam.width  # grid plane behind the rod
        x_lo, x_hi = cx - half_w, cx + half_w
        z_lo, z_hi = cz - half_h, cz + half_h
        if sim.options.has_contact:
            z_lo = max(z_lo, 0.0)  # no grid below the floor
        for step, rgba, lw in ((self.minor, _MINOR_RGBA, 1.0), (self.major, _MAJOR_RGBA, 2.0)):
            if step <= 0 or (x_hi - x_lo) / step > 400:
                continue
            for gx in np.arange(np.ceil(x_lo / step) * step, x_hi, step):
                self._line(scn, (gx, y, z_lo), (gx, y, z_hi), rgba, lw)
            for gz in np.arange(np.ceil(z_lo / step) * step, z_hi, step):
                self._line(scn, (x_lo, y, gz), (x_hi, y, gz), rgba, lw)
        f = sim.field if field is None else field
        b = np.array([f.Bx, f.Bz] if hasattr(f, "Bx") else f, dtype=float).ravel()[:2]
        bmag = float(np.hypot(*b))
        if bmag > 0:
            length = min(self.arrow_per_tesla * bmag, 0.3 * half_h * 2)
            a0 = np.array([x_lo + 0.12 * self.span, -2 * sim.beam.width, z_hi - 0.45 * half_h])
            a1 = a0 + length * np.array([b[0], 0.0, b[1]]) / bmag
            self._arrow(scn, a0, a1, _ARROW_RGBA, 0.006 * self.span)
        if overlay is not None:
            ox, oz = (np.asarray(v, dtype=float) for v in overlay)
            for i in range(len(ox) - 1):
                self._line(scn, (ox[i], -2 * sim.beam.width, oz[i]), (ox[i + 1], -2 * sim.beam.width, oz[i + 1]),
                           _OVERLAY_RGBA, 3.0)
        if target is not None:
            self._sphere(scn, (target[0], -2 * sim.beam.width, target[1]), _TARGET_RGBA, 0.6 * MM)
        img = r.render().copy()
        return _caption(img, f"t = {sim.time:.2f} s   B = ({b[0] * 1e3:+.2f}, {b[1] * 1e3:+.2f}) mT   "
                             f"grid {self.minor * 1e3:g} / {self.major * 1e3:g} mm {label}".rstrip())

    def close(self) -> None:
        self._renderer.close()


def _caption(img: np.ndarray, text: str) -> np.ndarray:
    try:
        from PIL import Image, ImageDraw
    except ImportError:  # captions are optional
        return img
    im = Image.fromarray(img)
    draw = ImageDraw.Draw(im)
    draw.rectangle((0, 0, im.width, 16), fill=(255, 255, 255))
    draw.text((6, 3), text, fill=(20, 20, 20))
    return np.asarray(im)

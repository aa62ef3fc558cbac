"""Figures of a field source over the workspace: |B| on a plane (log colour scale, mT) with streamlines.

:func:`plot_source` samples a source (:mod:`magsoft_env.fields`) at the centres of a grid of cells on a plane
(``xz``, ``xy`` or ``yz``, at an offset along the third axis), shows the magnitude as an image on a logarithmic
colour scale in mT with the streamlines of the in-plane field, marks the dipoles, magnet centres and loop
centres the source knows (filled in the plane, hollow when off it by up to the plotted span: their
projection; farther ones, such as a navigation system's coils, are left out), and draws a robot's
centreline. matplotlib (Agg, no pyplot) is imported only when a figure is made.
"""

from __future__ import annotations

import numpy as np

from ..fields import Source, load_source, source_markers
from ..units import MM, MT
from .figures import PALETTE, _figure, save_figure, styled

#: Planes: (horizontal axis, vertical axis, normal axis) as indices of x, y, z.
PLANES = {"xz": (0, 2, 1), "xy": (0, 1, 2), "yz": (1, 2, 0), "zx": (2, 0, 1), "yx": (1, 0, 2), "zy": (2, 1, 0)}
_AXIS = "xyz"
#: Default half-width of the square plotted (mm).
DEFAULT_EXTENT_MM = 40.0
#: Default number of cells along the horizontal axis.
DEFAULT_POINTS = 160
#: Largest number of cells along an axis.
MAX_POINTS = 1000
_MARKERS = {"dipole": ("o", "dipole"), "magnet": ("s", "magnet centre"), "loop": ("D", "loop centre")}


def _extent(extent_mm) -> tuple[float, float, float, float]:
    if isinstance(extent_mm, (int, float)) and not isinstance(extent_mm, bool):
        h = float(extent_mm)
        if not (np.isfinite(h) and h > 0):
            raise ValueError(f"plot_source extent_mm must be a half-width > 0 (mm) or (u_min, u_max, v_min, v_max), "
                             f"got {extent_mm!r}.")
        return (-h, h, -h, h)
    try:
        e = np.asarray(extent_mm, dtype=float)
    except (TypeError, ValueError):
        e = np.zeros(0)
    if e.shape != (4,) or not np.isfinite(e).all() or e[1] <= e[0] or e[3] <= e[2]:
        raise ValueError(f"plot_source extent_mm must be a half-width > 0 (mm) or (u_min, u_max, v_min, v_max) "
                         f"with min < max, got {extent_mm!r}.")
    return tuple(float(v) for v in e)


def _evaluate(source: Source, pts: np.ndarray, rows: int) -> np.ndarray:
    """B (T) at ``pts``; points where the source refuses (on a dipole, a wire, a magnet's surface, outside a
    grid) are NaN."""
    try:
        return source.field(pts)
    except ValueError:
        pass
    B = np.full(pts.shape, np.nan)
    for chunk in np.array_split(np.arange(pts.shape[0]), rows):
        try:
            B[chunk] = source.field(pts[chunk])
        except ValueError:
            for i in chunk:
                try:
                    B[i] = source.field(pts[i:i + 1])[0]
                except ValueError:
                    pass
    return B


def field_map(source, *, plane: str = "xz", extent_mm=DEFAULT_EXTENT_MM, offset_mm: float = 0.0,
              points: int = DEFAULT_POINTS) -> dict:
    """The field on a plane at the centres of a grid of cells.

    Returns a dict: ``u_mm`` (n_u,), ``v_mm`` (n_v,) the cell centres along the plane's axes (mm), ``extent_mm``
    (u_min, u_max, v_min, v_max), ``points`` (n_v, n_u, 3) in m, ``B`` (n_v, n_u, 3) in T (NaN where the
    source refuses a point), ``magnitude_mT`` (n_v, n_u), ``axes`` (the indices of u, v and the normal).
    """
    if plane not in PLANES:
        raise ValueError(f"plot_source plane must be one of {list(PLANES)}, got {plane!r}.")
    iu, iv, iw = PLANES[plane]
    u0, u1, v0, v1 = _extent(extent_mm)
    if isinstance(points, bool) or not isinstance(points, (int, np.integer)) or not 4 <= points <= MAX_POINTS:
        raise ValueError(f"plot_source points must be an integer in [4, {MAX_POINTS}] (cells along the horizontal "
                         f"axis), got {points!r}.")
    if isinstance(offset_mm, bool) or not np.isfinite(float(offset_mm)):
        raise ValueError(f"plot_source offset_mm must be a finite number (mm), got {offset_mm!r}.")
    n_u = int(points)
    n_v = max(4, min(MAX_POINTS, round(n_u * (v1 - v0) / (u1 - u0))))
    u = u0 + (np.arange(n_u) + 0.5) * (u1 - u0) / n_u
    v = v0 + (np.arange(n_v) + 0.5) * (v1 - v0) / n_v
    U, V = np.meshgrid(u, v)
    pts = np.empty((n_v, n_u, 3))
    pts[..., iu] = U * MM
    pts[..., iv] = V * MM
    pts[..., iw] = float(offset_mm) * MM
    B = _evaluate(source, pts.reshape(-1, 3), n_v).reshape(n_v, n_u, 3)
    return {"u_mm": u, "v_mm": v, "extent_mm": (u0, u1, v0, v1), "points": pts, "B": B,
            "magnitude_mT": np.linalg.norm(B, axis=-1) / MT, "axes": (iu, iv, iw)}


def _centreline(robot) -> np.ndarray:
    line = getattr(robot, "centreline", robot)
    if callable(line):
        line = line()
    a = np.asarray(line, dtype=float)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 2 or not np.isfinite(a).all():
        raise ValueError(f"plot_source robot must be a centreline of shape (n, 3), n >= 2 (m), or have one as "
                         f".centreline, got shape {a.shape}.")
    return a


@styled
def plot_source(source, *, plane: str = "xz", extent_mm=DEFAULT_EXTENT_MM, offset_mm: float = 0.0,
                points: int = DEFAULT_POINTS, robot=None, path=None, ax=None, title: str | None = None,
                size=(5.6, 4.6)):
    """A map of a source's field on a plane: |B| (log colour scale, mT), streamlines of the in-plane field.

    Parameters
    ----------
    source : Source, dict or source file
        The field (anything :func:`~magsoft_env.fields.load_source` reads without currents).
    plane : str
        ``"xz"`` (default), ``"xy"`` or ``"yz"`` (horizontal axis first; ``"zx"`` etc. swap them).
    extent_mm : float or (u_min, u_max, v_min, v_max)
        The half-width of a square centred on the origin, or the plotted ranges along the plane's axes (mm).
    offset_mm : float
        Position of the plane along its normal axis (mm).
    points : int
        Cells along the horizontal axis (the vertical count keeps them square); the field is sampled at their
        centres, which are the image's pixel centres.
    robot : array_like, shape (n, 3), or an object with ``.centreline``
        A centreline (m) to draw, projected on the plane.
    path : path, optional
        Save the figure there (format from the suffix).
    ax : matplotlib Axes, optional
        Draw into it (with its own colour bar) instead of a new figure.
    title : str, optional
        Default: the plane and its offset.
    size : (float, float)
        Figure size (in) of a new figure.

    Returns
    -------
    matplotlib.figure.Figure
        Its first image (``fig.axes[0].images[0]``) holds ``|B|`` in mT, ``origin="lower"``, over
        ``extent_mm``; NaN (masked) where the source refuses a point (on a dipole, a wire, a magnet's surface).
    """
    from matplotlib.colors import LogNorm
    from matplotlib.lines import Line2D

    if not isinstance(source, Source):
        source = load_source(source)
    m = field_map(source, plane=plane, extent_mm=extent_mm, offset_mm=offset_mm, points=points)
    iu, iv, iw = m["axes"]
    u0, u1, v0, v1 = m["extent_mm"]
    if ax is None:
        fig, axes = _figure(size=size)
        ax = axes[0, 0]
    else:
        fig = ax.figure
    mag = np.ma.masked_invalid(m["magnitude_mT"])
    good = mag.compressed()
    good = good[good > 0]
    if good.size:
        lo, hi = float(np.percentile(good, 1.0)), float(np.percentile(good, 99.5))
        if hi <= lo * 1.0001:
            lo, hi = lo / 1.5, hi * 1.5
    else:
        lo, hi = 1e-3, 1.0
    im = ax.imshow(mag, origin="lower", extent=(u0, u1, v0, v1), norm=LogNorm(vmin=lo, vmax=hi, clip=True),
                   cmap="viridis", interpolation="nearest", aspect="equal")
    Bu = np.ma.masked_invalid(m["B"][..., iu])
    Bv = np.ma.masked_invalid(m["B"][..., iv])
    if np.ma.max(np.ma.abs(Bu) + np.ma.abs(Bv)) > 0:
        ax.streamplot(m["u_mm"], m["v_mm"], Bu, Bv, color="white", linewidth=0.6, arrowsize=0.6, density=1.1)
    handles = []
    span = max(u1 - u0, v1 - v0)
    for kind, pts in source_markers(source):
        p = pts / MM
        inside = (p[:, iu] >= u0) & (p[:, iu] <= u1) & (p[:, iv] >= v0) & (p[:, iv] <= v1)
        dist = np.abs(p[:, iw] - float(offset_mm))
        near, close = dist <= 0.02 * span, dist <= span  # farther than the plotted span: not drawn at all
        marker, label = _MARKERS[kind]
        for sel, filled, note in ((inside & near, True, ""), (inside & close & ~near, False, " (off the plane)")):
            if sel.any():
                ax.plot(p[sel, iu], p[sel, iv], ls="none", marker=marker, ms=6,
                        mfc=PALETTE["field"] if filled else "none", mec=PALETTE["field"], mew=1.4)
                handles.append(Line2D([], [], ls="none", marker=marker, mfc=PALETTE["field"] if filled else "none",
                                      mec=PALETTE["field"], mew=1.4, label=label + note))
    if robot is not None:
        c = _centreline(robot) / MM
        ax.plot(c[:, iu], c[:, iv], color=PALETTE["trace"], lw=2.6, solid_capstyle="round")
        handles.append(Line2D([], [], color=PALETTE["trace"], lw=2.6, label="robot"))
    ax.set_xlim(u0, u1)
    ax.set_ylim(v0, v1)
    ax.grid(False)
    ax.set_xlabel(f"{_AXIS[iu]} (mm)")
    ax.set_ylabel(f"{_AXIS[iv]} (mm)")
    ax.set_title(title if title is not None else
                 f"|B| in the {_AXIS[iu]}{_AXIS[iv]} plane, {_AXIS[iw]} = {float(offset_mm):g} mm")
    if handles:
        ax.legend(handles=handles, loc="upper right", fontsize=7, frameon=True, framealpha=0.8)
    fig.colorbar(im, ax=ax, label="|B| (mT)", shrink=0.9)
    if path is not None:
        save_figure(fig, path)
    return fig


__all__ = ["DEFAULT_EXTENT_MM", "DEFAULT_POINTS", "PLANES", "field_map", "plot_source"]

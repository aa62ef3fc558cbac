"""Figures of equilibrium shapes and load curves (matplotlib, Agg; imported only when a plot is made).

Shapes are drawn in millimetres with equal aspect. Figures are built on
``matplotlib.figure.Figure`` directly (no pyplot, no global backend switch) and saved
atomically: a figure file is either complete or absent.

One style serves the figures and the videos (:mod:`.frames`): :data:`PALETTE` names the
colours (robot, field, trace, theory, target, ...), :data:`RC_PARAMS` the matplotlib settings
(font, sizes, grid, colour cycle), applied by :func:`styled` around every figure function and by
:func:`_figure`. The font is DejaVu Sans, matplotlib's own, which the video frames load too.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..io import atomic_path
from ..units import MM, MT

#: Colours shared by the figures and the video frames (hex sRGB).
PALETTE = {
    "robot": "#2c3e50",        # the MuJoCo rod
    "field": "#c0392b",        # field arrow, B_x
    "field_z": "#8e44ad",      # B_z in the time panel
    "field_y": "#1e8449",      # B_y in the time panel (the 3D strip)
    "trace": "#e67e22",        # centre-of-mass (or tip) path
    "start": "#7f8c8d",        # start marker
    "theory": "#1f77b4",       # analytical equilibrium
    "target": "#16a085",       # target point
    "scene": "#95a5a6",        # channel, obstacle, clamp
    "floor": "#e2ddd3",        # floor band in the side view
    "floor_edge": "#8a8275",
    "background": "#f7f8fa",
    "grid_minor": "#e8ebef",
    "grid_major": "#d3d9e1",
    "text": "#1c2833",
    "muted": "#5d6d7e",        # secondary text
}
#: Colour cycle of the figures: the palette's data colours first, then tab10's.
COLOR_CYCLE = (PALETTE["theory"], PALETTE["trace"], PALETTE["target"], PALETTE["field"], PALETTE["field_z"],
               "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf")
#: matplotlib settings of every figure (and of the video's time panel).
RC_PARAMS = {
    "font.family": "DejaVu Sans",
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "legend.fontsize": 7.0,
    "legend.frameon": False,
    "xtick.labelsize": 8.0,
    "ytick.labelsize": 8.0,
    "text.color": PALETTE["text"],
    "axes.labelcolor": PALETTE["text"],
    "axes.edgecolor": PALETTE["muted"],
    "xtick.color": PALETTE["muted"],
    "ytick.color": PALETTE["muted"],
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": True,
    "grid.color": PALETTE["grid_major"],
    "grid.linewidth": 0.6,
    "grid.alpha": 1.0,
    "lines.linewidth": 1.6,
    "figure.facecolor": "white",
    "axes.facecolor": "white",
    "savefig.facecolor": "white",
}


def _rc() -> dict:
    from cycler import cycler

    return {**RC_PARAMS, "axes.prop_cycle": cycler(color=list(COLOR_CYCLE))}


def styled(fn):
    """Run ``fn`` (a function that builds and saves a figure) under :data:`RC_PARAMS`: the
    settings are read when artists are created and drawn, so the whole function runs inside them."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        import matplotlib

        with matplotlib.rc_context(_rc()):
            return fn(*args, **kwargs)

    return wrapper


_SHAPE_SAMPLES = 201


def _figure(nrows: int = 1, ncols: int = 1, *, size=(6.4, 4.8)):
    """A constrained-layout figure and its ``(nrows, ncols)`` axes, built under :data:`RC_PARAMS`."""
    import matplotlib
    from matplotlib.figure import Figure

    with matplotlib.rc_context(_rc()):
        fig = Figure(figsize=size, layout="constrained")
        axes = fig.subplots(nrows, ncols, squeeze=False)
    return fig, axes


def save_figure(fig, path) -> Path:
    """Write ``fig`` to ``path`` (format from the suffix) through a temporary file; returns the path."""
    path = Path(path)
    import matplotlib

    with atomic_path(path) as tmp, matplotlib.rc_context(_rc()):
        fig.savefig(tmp, dpi=150)
    return path


def shape_mm(result, n: int = _SHAPE_SAMPLES) -> tuple[np.ndarray, np.ndarray]:
    """Centerline (x, z) of an equilibrium in mm, ``n`` evenly spaced points base to tip."""
    _, x, z, _ = result.sample(n)
    return np.asarray(x) / MM, np.asarray(z) / MM


def _field_label(field) -> str:
    """``B = (B_x, B_z) mT`` of a planar field, ``B = (B_x, B_y, B_z) mT`` of one with a y component."""
    if getattr(field, "By", 0.0) != 0.0:
        return f"B = ({field.Bx / MT:.3g}, {field.By / MT:.3g}, {field.Bz / MT:.3g}) mT"
    return f"B = ({field.Bx / MT:.3g}, {field.Bz / MT:.3g}) mT"


def _pick(n_total: int, n_max: int) -> list[int]:
    """Up to ``n_max`` indices spread over ``range(n_total)``, always including the last."""
    if n_total <= n_max:
        return list(range(n_total))
    return sorted({int(round(i)) for i in np.linspace(0, n_total - 1, n_max)})


@styled
def draw_path_shapes(ax, results: Sequence, *, length: float, max_shapes: int = 8, cmap: str = "viridis",
                     reference: tuple | None = None) -> None:
    """Draw shapes along a loading path on ``ax``, coloured by the step, with the undeformed beam.

    ``reference`` is the undeformed centerline (x, z) in m; a straight beam on the x axis if omitted.
    """
    import matplotlib

    colours = matplotlib.colormaps[cmap]
    if reference is None:
        ax.plot([0.0, length / MM], [0.0, 0.0], color=PALETTE["scene"], ls="--", lw=1.0, label="undeformed")
    else:
        ax.plot(np.asarray(reference[0]) / MM, np.asarray(reference[1]) / MM, color=PALETTE["scene"], ls="--", lw=1.0,
                label="undeformed")
    idx = _pick(len(results), max_shapes)
    for k, i in enumerate(idx):
        r = results[i]
        x, z = shape_mm(r)
        c = colours(k / max(len(idx) - 1, 1))
        ls = "-" if (r.success and r.stable) else ":"
        ax.plot(x, z, color=c, ls=ls, lw=1.6, label=_field_label(r.field) + ("" if r.success else " (failed)"))
    _shape_axes(ax)


def _shape_axes(ax) -> None:
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.grid(True)


@styled
def path_figure(cases: Sequence[tuple], path, *, max_shapes: int = 8) -> Path:
    """One panel per case ``(title, results, length_m)``: shapes along each loading path; saved to ``path``."""
    n = len(cases)
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    fig, axes = _figure(nrows, ncols, size=(5.2 * ncols, 4.4 * nrows))
    for ax, (title, results, length) in zip(axes.flat, cases, strict=False):
        draw_path_shapes(ax, results, length=length, max_shapes=max_shapes)
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=6, loc="best")
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    return save_figure(fig, path)


SWEEP_METRICS = (
    ("v_over_L", "v / L", 1.0),
    ("tip_angle_deg", "tip angle $\\theta^l$ (deg)", 1.0),
    ("rotation_angle_deg", "rotation angle $\\gamma$ (deg)", 1.0),
)


@styled
def sweep_figure(rows: Sequence[dict], path) -> Path:
    """Fig. 3-style curves: one row of panels per loading path (v/L, tip angle, rotation angle against P).

    ``rows`` are dicts with keys ``path``, ``length_mm``, ``l_over_h``, ``gravity_m_per_s2``, ``P`` and the
    metrics in :data:`SWEEP_METRICS`. Solid lines with gravity, dashed without; one colour per beam.
    """
    import matplotlib

    paths = sorted({r["path"] for r in rows})
    beams = sorted({r["length_mm"] for r in rows})
    colours = matplotlib.colormaps["tab10"]
    fig, axes = _figure(len(paths), len(SWEEP_METRICS), size=(14, 4.0 * len(paths)))
    for i, p in enumerate(paths):
        for j, (key, label, _) in enumerate(SWEEP_METRICS):
            ax = axes[i, j]
            for b, L in enumerate(beams):
                for g_on in (True, False):
                    sel = [r for r in rows if r["path"] == p and r["length_mm"] == L and (r["gravity_m_per_s2"] > 0)
                           == g_on]
                    if not sel:
                        continue
                    P = [r["P"] for r in sel]
                    y = [r[key] for r in sel]
                    lh = sel[0]["l_over_h"]
                    ax.plot(P, y, color=colours(b), ls="-" if g_on else "--", marker="o" if g_on else None, ms=2.5,
                            label=f"l/h = {lh:.1f}" + ("" if g_on else ", no gravity"))
                    bad = [(pp, yy) for pp, yy, r in zip(P, y, sel, strict=True) if not (r["success"] and r["stable"])]
                    if bad:
                        ax.plot(*zip(*bad, strict=True), ls="none", marker="x", color=PALETTE["field"], ms=5)
            ax.set_xlabel(sel_axis_label(p))
            ax.set_ylabel(label)
            ax.grid(True)
            ax.set_title(f"path {p}", fontsize=10)
            if j == 0:
                ax.legend(fontsize=7)
    return save_figure(fig, path)


def sel_axis_label(path_name: str) -> str:
    """x-axis label for a sweep path: P of the component being ramped."""
    if path_name == "b":
        return "P of $|B_x|$ ($B_z$ held)"
    return "P of $B_z$"


@styled
def couplings_figure(cases: Sequence[dict], path) -> Path:
    """Overlay of the two couplings. Each case: ``title``, ``length`` (m), ``reference`` (x, z) m,
    ``rotated`` and ``paper`` (lists of results at the same fields), optionally ``beta``
    (s in m, beta in rad) drawn in a second row."""
    n = len(cases)
    with_beta = all("beta" in c for c in cases)
    fig, axes = _figure(2 if with_beta else 1, n, size=(5.2 * n, 4.6 + (2.2 if with_beta else 0.0)))
    if with_beta:
        fig.get_layout_engine().set(h_pad=0.1)
        for ax in axes[0]:  # shapes get most of the height
            ax.set_box_aspect(None)
    import matplotlib

    colours = matplotlib.colormaps["viridis"]
    if with_beta:
        for ax, case in zip(axes[1], cases, strict=True):
            s, beta = case["beta"]
            ax.plot(np.asarray(s) / MM, np.degrees(beta), color=PALETTE["robot"], lw=1.4)
            ax.set_xlabel("s (mm)")
            ax.set_ylabel("magnetization angle beta (deg)")
            ax.grid(True)
    for ax, case in zip(axes[0], cases, strict=True):
        ref = case["reference"]
        ax.plot(np.asarray(ref[0]) / MM, np.asarray(ref[1]) / MM, color=PALETTE["scene"], ls="--", lw=1.0,
                label="undeformed")
        m = len(case["rotated"])
        for k, (rr, rp) in enumerate(zip(case["rotated"], case["paper"], strict=True)):
            c = colours(k / max(m - 1, 1))
            xr, zr = shape_mm(rr)
            xp, zp = shape_mm(rp)
            lab = _field_label(rr.field)
            ax.plot(xr, zr, color=c, ls="-", lw=1.8, label=f"rotated, {lab}")
            ax.plot(xp, zp, color=c, ls=(0, (4, 2)), lw=1.4, label=f"paper eq. 10, {lab}")
        _shape_axes(ax)
        ax.set_title(case["title"], fontsize=10)
        ax.legend(fontsize=6, loc="best")
    return save_figure(fig, path)


@styled
def letters_figure(results: dict, path, *, spacing_mm: float = 22.0):
    """Designed letters side by side (target dots, predicted centreline), with their fields and errors."""
    fig, axes = _figure(1, 1, size=(2.6 * len(results) + 1.0, 4.2))
    ax = axes[0, 0]
    for k, (ch, r) in enumerate(results.items()):
        off = np.array([k * spacing_mm, 0.0])
        t = r.target_xz / MM - r.target_xz.min(axis=0) / MM + off
        p = r.predicted_xz / MM - r.target_xz.min(axis=0) / MM + off
        ax.plot(t[:, 0], t[:, 1], "o", ms=2.5, mfc="none", color=PALETTE["target"], label="target" if k == 0 else None)
        ax.plot(p[:, 0], p[:, 1], "-", lw=4, color=PALETTE["theory"], alpha=0.8,
                label="designed beam" if k == 0 else None)
        ax.plot(*p[0], "s", color=PALETTE["robot"], ms=5, label="clamp" if k == 0 else None)
        ax.text(off[0], -3.0, f"{ch}: |B| {r.field.magnitude / MT:.1f} mT\nRMS {r.rms_error_percent:.2f}% L",
                fontsize=7, va="top")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title("SJTU letters (paper Fig. 4e): one designed beam per letter, vertical field", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    ax.grid(True)
    return save_figure(fig, path)


#: Marker and palette colour of each MuJoCo segment count in :func:`crosscheck_figure`.
_SIM_MARKERS = (("o", "robot"), ("s", "trace"), ("^", "target"), ("v", "field_z"))


@styled
def crosscheck_figure(name: str, theory_results: Sequence, sims: dict, path) -> Path:
    """Analytical shapes (lines) against MuJoCo rods (markers, one per segment count) at the first,
    middle and last state of a loading path (``magsoft crosscheck --out``)."""
    fig, axes = _figure(1, 1, size=(5, 5))
    ax = axes[0, 0]
    idx = sorted({0, len(theory_results) // 2, len(theory_results) - 1})
    for i in idx:
        t = theory_results[i]
        ax.plot(t.x / MM, t.z / MM, "-", color=PALETTE["theory"], lw=1.5, label="theory" if i == idx[0] else None)
        for n, (mk, key) in zip(sorted(sims), _SIM_MARKERS, strict=False):
            s = sims[n][i]
            ax.plot(s.x / MM, s.z / MM, mk, color=PALETTE[key], ls="none", ms=3, mfc="none",
                    label=f"MuJoCo N={n}" if i == idx[0] else None)
        f = t.field
        ax.annotate(f"({f.Bx / MT:.3g}, {f.Bz / MT:.3g}) mT", (t.x[-1] / MM, t.z[-1] / MM), fontsize=7)
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("z (mm)")
    ax.set_title(f"{name}: theory vs MuJoCo rod")
    ax.legend(fontsize=7)
    return save_figure(fig, path)


#: Colours of the paper robots in the time-against-error figure.
ROBOT_COLORS = {"paper-5a": PALETTE["theory"], "paper-5b": PALETTE["field"], "paper-5c": PALETTE["target"]}


@styled
def frontier_figure(results: dict, path, *, tolerance: float = 0.05) -> Path:
    """Time against error, one panel per scene (:mod:`magsoft_env.bench.frontier`): every run's error (%, the
    larger of its displacement and speed errors) against its wall time per simulated second, log-log; the
    frontier joined per robot, the robot's own numerics ringed, ``tolerance`` dashed; the reference's own run
    (``"reference"`` True) is left out.

    ``results``: ``{scene: {robot: {"rows": [...], "own_numerics": (N, dt_ms)}}}`` as ``frontier`` builds it."""
    floor_pct = 0.05  # errors below this (%) are drawn at it: a log axis has no zero
    fig, axes = _figure(1, len(results), size=(3.6 * len(results), 3.4))
    for ax, (scene, per_robot) in zip(axes[0], results.items(), strict=True):
        for robot, res in per_robot.items():
            c = ROBOT_COLORS.get(robot, PALETTE["robot"])
            rows = [r for r in res["rows"] if not r.get("reference")]
            ax.scatter([r["wall_per_sim_s"] for r in rows], [max(100.0 * r["error"], floor_pct) for r in rows],
                       s=12, color=c, alpha=0.4, lw=0)
            fr = [r for r in rows if r["frontier"]]
            ax.step([r["wall_per_sim_s"] for r in fr], [max(100.0 * r["error"], floor_pct) for r in fr],
                    where="post", color=c, label=robot)
            own = tuple(res["own_numerics"])
            for r in rows:
                if (r["segments"], r["timestep_ms"]) == own:
                    ax.scatter([r["wall_per_sim_s"]], [max(100.0 * r["error"], floor_pct)], s=70,
                               facecolors="none", edgecolors=c, lw=1.6)
        ax.axhline(100.0 * tolerance, color=PALETTE["muted"], ls="--", lw=0.9)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(scene)
        ax.set_xlabel("wall time per simulated second (s)")
        ax.legend(loc="upper right")
    axes[0][0].set_ylabel("crawl error against the reference (%)")
    fig.suptitle(f"Time against error (3 s crawls; ring: the robot's own numerics; dashed: {100 * tolerance:g} %)")
    return save_figure(fig, path)


# ---------------------------------------------------------------------------------------------
# 3D shapes (the Kirchhoff rod)

#: (title, horizontal axis, vertical axis) of the three projections of :func:`rod_figure`: 0 x, 1 y, 2 z.
ROD_VIEWS = (("side view (x-z)", 0, 2), ("top view (x-y)", 0, 1), ("end view (y-z)", 1, 2))


def rod_edges_mm(result, width: float | None, n: int = _SHAPE_SAMPLES):
    """Centreline (n, 3) and the strip's two long edges (n, 3) each, in mm, of a 3D equilibrium: the edges are
    the centreline -+ (w / 2) d1 (d1 the cross-section's direction across the width), so that twist shows.
    ``width`` in m; None gives the centreline for both edges."""
    _, r, frames = result.sample(n)
    r = np.asarray(r, dtype=float)
    half = 0.0 if width is None else 0.5 * float(width)
    d1 = np.asarray(frames, dtype=float)[:, :, 0]
    return r / MM, (r - half * d1) / MM, (r + half * d1) / MM


@styled
def rod_figure(results: Sequence, path, *, width: float | None = None, max_shapes: int = 8,
               title: str | None = None) -> Path:
    """Shapes of a strip in 3D along a loading path: a 3D view and its three projections; saved to ``path``.

    Parameters
    ----------
    results : sequence of RodResult
        Equilibria along a path (:func:`magsoft_env.solve_path` with a 3D field, or ``model="3d"``), SI units.
    path : str or Path
        Output file; the format follows the suffix (PNG, SVG, PDF).
    width : float, optional
        Strip width (m), e.g. ``beam.width``. Each shape is drawn as a ribbon of this width, its edges at
        centreline +- (w / 2) d1 (d1 across the width), so that twist about the tangent is visible; None
        draws the centreline alone.
    max_shapes : int
        Most shapes drawn, spread over the path and always with the last; coloured by the step, the last
        one opaque. Unstable or failed states are dotted.
    title : str, optional
        Figure title.

    Panels: the 3D view (top left), the side view (x-z, top right), the top view (x-y) and the end view (y-z,
    looking along -x from the tip). Axes in mm, equal aspect; the undeformed strip is dashed, the clamp at
    the origin. Returns ``path``.
    """
    import matplotlib
    from matplotlib.figure import Figure

    if not isinstance(max_shapes, int) or isinstance(max_shapes, bool) or max_shapes < 1:
        raise ValueError(f"max_shapes must be an integer >= 1, got {max_shapes!r}.")
    results = list(results)
    if not results:
        raise ValueError("rod_figure needs at least one result.")
    if width is not None and not (isinstance(width, (int, float)) and math.isfinite(width) and width > 0):
        raise ValueError(f"width must be a positive length in m (or None), got {width!r}.")
    colours = matplotlib.colormaps["viridis"]
    idx = _pick(len(results), max_shapes)
    shapes = []
    for k, i in enumerate(idx):
        r = results[i]
        c = colours(k / max(len(idx) - 1, 1))
        last = i == len(results) - 1
        shapes.append((r, c, last, *rod_edges_mm(r, width)))
    length = float(results[0].length) / MM
    fig = Figure(figsize=(10.0, 8.0), layout="constrained")
    ax3 = fig.add_subplot(2, 2, 1, projection="3d")
    axes2 = [fig.add_subplot(2, 2, k) for k in (2, 3, 4)]
    pts = [np.array([[0.0, 0.0, 0.0], [length, 0.0, 0.0]])]
    half_mm = 0.0 if width is None else 0.5 * width / MM
    ax3.plot([0.0, length], [0.0, 0.0], [0.0, 0.0], color=PALETTE["scene"], ls="--", lw=1.0)
    for r, c, last, cl, e0, e1 in shapes:
        ls = "-" if (r.success and r.stable) else ":"
        alpha = 0.85 if last else 0.12
        if width is not None:
            X = np.stack([e0[:, 0], e1[:, 0]])
            Y = np.stack([e0[:, 1], e1[:, 1]])
            Z = np.stack([e0[:, 2], e1[:, 2]])
            ax3.plot_surface(X, Y, Z, color=c, alpha=alpha, linewidth=0, shade=True)
            for e in (e0, e1):
                ax3.plot(e[:, 0], e[:, 1], e[:, 2], color=c, lw=0.6, alpha=min(1.0, alpha + 0.15))
        f = r.field
        label = f"B = ({f.Bx / MT:.3g}, {f.By / MT:.3g}, {f.Bz / MT:.3g}) mT" + ("" if r.success else " (failed)")
        ax3.plot(cl[:, 0], cl[:, 1], cl[:, 2], color=c, ls=ls, lw=1.6 if last else 0.9, label=label)
        pts += [e0, e1, cl]
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    mid, span = 0.5 * (lo + hi), max(float((hi - lo).max()), 2.0 * half_mm, 1e-9)
    ax3.set_xlim(mid[0] - span / 2, mid[0] + span / 2)
    ax3.set_ylim(mid[1] - span / 2, mid[1] + span / 2)
    ax3.set_zlim(mid[2] - span / 2, mid[2] + span / 2)
    ax3.set_box_aspect((1.0, 1.0, 1.0))
    ax3.view_init(elev=22.0, azim=-58.0)
    ax3.set_xlabel("x (mm)")
    ax3.set_ylabel("y (mm)")
    ax3.set_zlabel("z (mm)")
    ax3.set_title("3D view")
    ax3.legend(fontsize=6, loc="upper left")
    names = "xyz"
    for ax, (view, a, b) in zip(axes2, ROD_VIEWS, strict=True):
        und = np.array([[0.0, -half_mm, 0.0], [length, -half_mm, 0.0], [length, half_mm, 0.0], [0.0, half_mm, 0.0]])
        ax.fill(und[:, a], und[:, b], facecolor="none", edgecolor=PALETTE["scene"], ls="--", lw=1.0)
        for r, c, last, cl, e0, e1 in shapes:
            ls = "-" if (r.success and r.stable) else ":"
            if width is not None:
                poly = np.concatenate([e0, e1[::-1]])
                ax.fill(poly[:, a], poly[:, b], color=c, alpha=0.45 if last else 0.06, lw=0)
                for e in (e0, e1):
                    ax.plot(e[:, a], e[:, b], color=c, lw=0.8 if last else 0.4, alpha=1.0 if last else 0.6)
            ax.plot(cl[:, a], cl[:, b], color=c, ls=ls, lw=1.6 if last else 0.9)
        ax.plot([0.0], [0.0], "s", color=PALETTE["robot"], ms=4)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel(f"{names[a]} (mm)")
        ax.set_ylabel(f"{names[b]} (mm)")
        ax.set_title(view)
        ax.grid(True)
    if title:
        fig.suptitle(title)
    return save_figure(fig, path)

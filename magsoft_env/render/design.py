"""A design written to a folder: profile, field and jig as CSV, the jig as a true-scale SVG, a summary, figures."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..design.svg import jig_svg
from ..io import write_csv, write_json, write_text_atomic
from ..threads import single_threaded_blas
from ..units import MM, MT
from .figures import PALETTE, _figure, _shape_axes, draw_path_shapes, save_figure, styled


def write_design(result, out, *, name: str = "design", ramp_steps: int = 8, figures: bool = True) -> list[Path]:
    """Write a :class:`DesignResult` to folder ``out``; returns the paths written.

    Files: ``profile.csv`` (s_mm, beta_rad, beta_deg), ``field.csv`` (Bx_mT, Bz_mT,
    magnitude_mT, angle_deg), ``jig.csv`` and ``jig.svg`` (x_mm, z_mm; true scale),
    ``target.csv`` and ``prediction.csv`` (x_mm, z_mm), ``ramp.csv`` (shapes along the field
    ramp), ``summary.json`` (errors in mm and % of L, settings, history) and, with ``figures``,
    ``fit.png`` (target against prediction, profile, jig) and ``ramp.png`` (shapes along the
    field ramp, paper Fig. 6 III).
    """
    from ..theory import solve_path

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    L = result.beam.length
    s = np.linspace(0.0, L, 201)
    beta = result.beam.beta(s)
    written = [
        write_csv(out / "profile.csv", [
            {"s_mm": a / MM, "beta_rad": float(b), "beta_deg": math.degrees(b)} for a, b in zip(s, beta, strict=True)
        ]),
        write_csv(out / "field.csv", [{
            "Bx_mT": result.field.Bx / MT, "Bz_mT": result.field.Bz / MT,
            "magnitude_mT": result.field.magnitude / MT, "angle_deg": math.degrees(result.field.angle),
        }]),
        write_csv(out / "jig.csv", [{"x_mm": a / MM, "z_mm": b / MM} for a, b in result.jig_xz]),
        write_text_atomic(out / "jig.svg", jig_svg(result.jig_xz, label=f"{name} jig (eq. 1), mm")),
        write_csv(out / "target.csv", [{"x_mm": a / MM, "z_mm": b / MM} for a, b in result.target_xz]),
        write_csv(out / "prediction.csv", [{"x_mm": a / MM, "z_mm": b / MM} for a, b in result.predicted_xz]),
    ]
    st = result.settings
    fields = [(result.field.Bx * t, result.field.Bz * t) for t in np.linspace(0.0, 1.0, ramp_steps + 1)[1:]]
    with single_threaded_blas():
        path = solve_path(result.beam, fields, gravity=st["gravity_m_s2"], coupling=st["coupling"],
                          extensible=st["extensible"], clamp_angle=st["clamp_angle_rad"])
    rows = []
    for r in path:
        if r.success:
            _, xs, zs, _ = r.sample(101)
            rows += [{"Bx_mT": r.field.Bx / MT, "Bz_mT": r.field.Bz / MT, "x_mm": a / MM, "z_mm": b / MM}
                     for a, b in zip(xs, zs, strict=True)]
    written.append(write_csv(out / "ramp.csv", rows))
    summary = {"name": name, **result.to_dict(), "settings": result.settings, "history": result.history}
    written.append(write_json(out / "summary.json", summary))
    if figures:
        written += [fit_figure(result, out / "fit.png", title=name), ramp_figure(result, path, out / "ramp.png")]
    return written


@styled
def fit_figure(result, path, *, title: str = ""):
    """Target against prediction (left), the profile beta(s) (middle) and the jig curve (right)."""

    fig, axes = _figure(1, 3, size=(14.0, 4.4))
    ax = axes[0, 0]
    t, p = result.target_xz / MM, result.predicted_xz / MM
    th0 = result.settings.get("clamp_angle_rad", 0.0)
    end = result.beam.length / MM * np.array([math.cos(th0), math.sin(th0)])
    ax.plot([0, end[0]], [0, end[1]], color=PALETTE["scene"], ls="--", lw=1.0, label="undeformed")
    ax.plot(t[:, 0], t[:, 1], "o", ms=3.5, mfc="none", color=PALETTE["target"], label="target")
    ax.plot(p[:, 0], p[:, 1], "-", color=PALETTE["theory"], lw=1.8,
            label=f"prediction, |B| = {result.field.magnitude / MT:.3g} mT")
    _shape_axes(ax)
    ax.set_title(f"{title}: RMS {result.rms_error / MM:.3f} mm ({result.rms_error_percent:.2f}% of L), "
                 f"max {result.max_error / MM:.3f} mm", fontsize=9)
    ax.legend(fontsize=7)
    ax = axes[0, 1]
    s = np.linspace(0.0, result.beam.length, 201)
    ax.plot(s / MM, np.degrees(result.beam.beta(s)), color=PALETTE["field"])
    ax.set_xlabel("s (mm)")
    ax.set_ylabel(r"magnetization angle $\beta$ (deg)")
    ax.set_title(f"profile: {result.family.kind}, {result.family.size} parameters", fontsize=9)
    ax.grid(True)
    ax = axes[0, 2]
    j = result.jig_xz / MM
    ax.plot(j[:, 0], j[:, 1], color=PALETTE["robot"])
    ax.plot(j[0, 0], j[0, 1], "o", color=PALETTE["field"], ms=4, label="s = 0 (clamp end)")
    _shape_axes(ax)
    ax.set_title("jig curve (eq. 1), magnetize along +x", fontsize=9)
    ax.legend(fontsize=7)
    return save_figure(fig, path)


@styled
def ramp_figure(result, path_results, path):
    """Predicted shapes as the field ramps up to the designed field, with the target (paper Fig. 6 III)."""

    fig, axes = _figure(1, 1, size=(6.0, 5.0))
    ax = axes[0, 0]
    th0 = result.settings.get("clamp_angle_rad", 0.0)
    ref = (np.array([0.0, result.beam.length * math.cos(th0)]), np.array([0.0, result.beam.length * math.sin(th0)]))
    draw_path_shapes(ax, path_results, length=result.beam.length, max_shapes=8, reference=ref)
    t = result.target_xz / MM
    ax.plot(t[:, 0], t[:, 1], "o", ms=3, mfc="none", color=PALETTE["target"], label="target")
    ax.legend(fontsize=6)
    ax.set_title("shapes along the field ramp", fontsize=10)
    return save_figure(fig, path)

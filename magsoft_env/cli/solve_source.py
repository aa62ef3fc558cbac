"""``magsoft solve --source``: the planar cantilever's equilibrium in a field source (the analytical solver,
:mod:`magsoft_env.theory.sources`): couples ``m x B`` and gradient forces ``G^T m`` on every piece, with gravity.

The beam (a preset's, a robot's or the parameters') is clamped at the origin along +x (or the preset's clamp
angle); the source is switched on from zero after gravity, in ``--steps`` states of its strength (default one:
``ms.solve_equilibrium(beam, source, gravity=...)``). ``--field-mT BX BZ`` adds a uniform field to the source.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from ..fields import Source
from ..io import format_table
from ..units import MM, MT
from .output import write_json
from .sources import markers_text, source_description, source_label

SOURCE_COLUMNS = [
    ("strength", "strength", ".3g"),
    ("tip_x_mm", "tip x mm", ".3f"),
    ("tip_z_mm", "tip z mm", ".3f"),
    ("v_over_L", "v/L", ".4f"),
    ("tip_angle_deg", "tip deg", ".2f"),
    ("rotation_angle_deg", "rot deg", ".2f"),
    ("tip_Bx_mT", "tip Bx mT", ".4g"),
    ("tip_By_mT", "tip By mT", ".4g"),
    ("tip_Bz_mT", "tip Bz mT", ".4g"),
    ("stable", "stable", ""),
    ("success", "success", ""),
]
#: Most states along the source's ramp.
MAX_STEPS = 1000


class Scaled(Source):
    """``w S``: a source at a fraction of its strength (the states of the ramp)."""

    def __init__(self, weight: float, source):
        self.weight = float(weight)
        self.source = source

    def field_and_gradient(self, points):
        B, G = self.source.field_and_gradient(points)
        return self.weight * B, self.weight * G


def source_row(result, beam, strength: float) -> dict:
    """The reported metrics of one equilibrium in a source (mm, mT, deg): a planar result, or the 3D rod's when the
    source loads the beam out of its plane (``model="auto"``; the tip and chord angles are then those of the
    tip's tangent and chord projected on the x-z plane)."""
    tip_B = np.asarray(result.tip_field, dtype=float)
    L = beam.length
    tip = np.asarray(result.tip_position, dtype=float)
    c = np.asarray(result.centreline, dtype=float)
    tip_angle = getattr(result, "tip_angle", None)
    if tip_angle is None:
        tangent = c[-1] - c[-2]
        tip_angle = math.atan2(tangent[2], tangent[0])
    rotation = getattr(result, "rotation_angle", math.atan2(tip[2], tip[0]))
    return {
        "strength": strength,
        "tip_x_mm": float(tip[0]) / MM,
        "tip_y_mm": float(tip[1]) / MM,
        "tip_z_mm": float(tip[2]) / MM,
        "v_over_L": float(result.tip_deflection) / L,
        "tip_angle_deg": math.degrees(float(tip_angle)),
        "rotation_angle_deg": math.degrees(float(rotation)),
        "tip_Bx_mT": tip_B[0] / MT,
        "tip_By_mT": tip_B[1] / MT,
        "tip_Bz_mT": tip_B[2] / MT,
        "tip_B_norm_mT": float(np.linalg.norm(tip_B)) / MT,
        "max_curvature_per_mm": float(result.max_curvature) * MM,
        "min_eigenvalue": float(result.min_eigenvalue),
        "out_of_plane": float(getattr(result, "out_of_plane", math.nan)),
        "model": "planar" if hasattr(result, "theta") else "3d",
        "clamp_force_N": [float(v) for v in result.clamp_force],
        "clamp_moment_N_m": np.asarray(result.clamp_moment, dtype=float).tolist(),  # about -y (planar) or (3,)
        "stable": bool(result.stable),
        "snap_through": bool(result.snap_through),
        "success": bool(result.success),
        "status": int(result.status),
        "message": str(result.message),
    }


def solve_in_source(preset, source, *, steps: int = 1, field=None):
    """Equilibria of ``preset.beam`` (its solver options) in ``source`` (plus the uniform ``field``, a Field, if
    given), ramped in ``steps`` states of its strength: ``(strengths, results)``."""
    from magsoft_env.fields import SourceSum, Uniform
    from magsoft_env.theory import solve_path

    total = source if field is None else SourceSum([Uniform(field.vector()), source])
    strengths = [k / steps for k in range(1, steps + 1)]
    loads = [total] if steps == 1 else [Scaled(w, total) if w != 1.0 else total for w in strengths]
    opts = preset.solver_options()
    return strengths, solve_path(preset.beam, loads, **opts)


def check_source_case(preset, steps) -> int:
    """The case the source solvers take, or a ValueError naming the flag: a cantilever, inextensible (a beam
    magnetized across its width, or a source that loads it out of its plane, takes the 3D rod)."""
    if steps is None:
        steps = 1
    if preset.support != "cantilever":
        raise ValueError(f"--source solves a cantilever (a free beam in a gradient is pulled away: no equilibrium), "
                         f"got support {preset.support!r}; give --support cantilever.")
    if preset.extensible:
        raise ValueError("--source solves the inextensible beam: give --no-extensible.")
    if not 1 <= steps <= MAX_STEPS:
        raise ValueError(f"--steps must be an integer in [1, {MAX_STEPS}] with --source, got {steps}.")
    return steps


def run_source(args, preset, source, origin, out) -> int:
    from .solve import field_mT_flag

    steps = check_source_case(preset, args.steps)
    field = None if args.field_mT is None else field_mT_flag(args.field_mT)
    strengths, results = solve_in_source(preset, source, steps=steps, field=field)
    rows = [source_row(r, preset.beam, w) for r, w in zip(results, strengths, strict=True)]
    label = source_label(args, origin)

    print(textwrap.fill(f"{preset.name}: {preset.description}", width=110))
    print(f"L = {preset.beam.length / MM:.4g} mm, cantilever clamped at the origin, gravity {preset.gravity:g} m/s^2, "
          f"coupling {preset.coupling}, inextensible, planar (x-z)")
    extra = "" if field is None else f", plus the uniform field ({field.Bx / MT:g}, {field.Bz / MT:g}) mT"
    print(f"field source: {label}{extra}")
    where = markers_text(source)
    if where:
        print(f"  {where}")
    print(format_table(rows, SOURCE_COLUMNS))
    last = rows[-1]
    print(f"field at the tip: B = ({last['tip_Bx_mT']:.4g}, {last['tip_By_mT']:.4g}, {last['tip_Bz_mT']:.4g}) mT, "
          f"|B| = {last['tip_B_norm_mT']:.4g} mT; smallest eigenvalue {last['min_eigenvalue']:.4g}")
    if last["out_of_plane"] > 1e-6:
        print(f"note: the source pulls the strip out of the x-z plane (out-of-plane load {last['out_of_plane']:.2g} "
              "of the in-plane ones); the planar model drops that part.")

    stem = f"solve_{preset.name}"
    files = []
    if not args.no_plot:
        files.append(_figure(source, results, preset.beam.length, out / f"{stem}.png", title=f"{preset.name} in "
                             f"{label}"))
    payload = {
        "preset": preset.name,
        "description": preset.description,
        "source": preset.source,
        "config": preset.config,
        "solver_options": preset.solver_options(),
        "length_m": preset.beam.length,
        "field_source": {"given": label, "origin": origin, "source": source_description(source),
                         "uniform_field_mT": None if field is None else [field.Bx / MT, field.By / MT, field.Bz / MT],
                         "steps": steps},
        "results": rows,
        "final": {**last, "shape": _shape(results[-1])},
    }
    files.append(write_json(out / f"{stem}.json", payload))
    for f in files:
        print(f"wrote {f}")
    failed = sum(not r["success"] for r in rows)
    if failed:
        print(f"warning: {failed} of {len(rows)} equilibria did not converge (see 'status' and 'message').")
        return 1
    return 0


def _shape(result, n: int = 101) -> dict:
    if hasattr(result, "theta"):
        s, x, z, theta = result.sample(n)
        return {"s_m": s, "x_m": x, "z_m": z, "theta_rad": theta}
    s, c, _ = result.sample(n)
    return {"s_m": s, "x_m": c[:, 0], "y_m": c[:, 1], "z_m": c[:, 2]}


def _figure(source, results, length: float, path, *, title: str):
    """|B| of the source in the x-z plane (log scale), its magnets, the shapes along the ramp (the last bold) and
    the rest shape (dashed)."""
    from magsoft_env.fields import source_markers
    from magsoft_env.render.fields import plot_source
    from magsoft_env.render.figures import PALETTE, save_figure

    L = length / MM
    u0, u1, v0, v1 = -0.3 * L, 1.3 * L, -1.1 * L, 1.1 * L
    for _, pts in source_markers(source):  # magnets near the beam come into the view
        for p in np.asarray(pts) / MM:
            if abs(p[1]) <= 3 * L and np.hypot(p[0], p[2]) <= 4 * L:
                u0, u1 = min(u0, p[0] - 0.15 * L), max(u1, p[0] + 0.15 * L)
                v0, v1 = min(v0, p[2] - 0.15 * L), max(v1, p[2] + 0.15 * L)
    final = results[-1]
    fig = plot_source(source, plane="xz", extent_mm=(u0, u1, v0, v1), points=120, robot=final.centreline,
                      title=title)
    ax = fig.axes[0]
    ax.plot([0.0, L], [0.0, 0.0], color=PALETTE["muted"], lw=1.2, ls="--", label="rest")
    for r in results[:-1][-4:]:
        if r.success:
            c = np.asarray(r.centreline)
            ax.plot(c[:, 0] / MM, c[:, 2] / MM, color=PALETTE["trace"], lw=1.0, alpha=0.5)
    return save_figure(fig, path)

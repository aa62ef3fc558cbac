"""``magsoft solve`` in three dimensions: the Kirchhoff rod under (B_x, B_y, B_z), its events and critical field.

Taken when ``--field-mT`` has three numbers, the magnetization has a component across the width
(``--magnetization``, or a robot file's ``direction``), or ``--critical`` is given.
"""

from __future__ import annotations

import math
import textwrap

import numpy as np

from ..io import format_table
from ..units import MM, MT
from .output import write_json

ROD_COLUMNS = [
    ("Bx_mT", "Bx mT", ".3g"),
    ("By_mT", "By mT", ".3g"),
    ("Bz_mT", "Bz mT", ".3g"),
    ("tip_x_mm", "tip x mm", ".3f"),
    ("tip_y_mm", "tip y mm", ".3f"),
    ("tip_z_mm", "tip z mm", ".3f"),
    ("tip_twist_deg", "twist deg", ".2f"),
    ("stable", "stable", ""),
    ("snap_through", "snap", ""),
    ("verification_rad", "verif rad", ".1e"),
    ("success", "success", ""),
]
#: Points of the final shape written to the JSON file (centreline and frames).
SHAPE_SAMPLES = 101
#: Shapes drawn in the PNG: the last and a few along the path.
FIGURE_SHAPES = 5
#: Relative spread below which a beam counts as uniform (Prandtl's estimate is for a uniform strip).
_UNIFORM_RTOL = 1e-9


def rod_row(result, beam) -> dict:
    """The reported metrics of one 3D equilibrium (mm, mT, deg)."""
    f = result.field
    tip = np.asarray(result.tip_position, dtype=float)
    return {
        "Bx_mT": f.Bx / MT,
        "By_mT": f.By / MT,
        "Bz_mT": f.Bz / MT,
        "B_mT": f.magnitude / MT,
        "Lambda": float(beam.nondimensional_groups(f, gravity=0.0)["Lambda"]),
        "tip_x_mm": tip[0] / MM,
        "tip_y_mm": tip[1] / MM,
        "tip_z_mm": tip[2] / MM,
        "tip_over_L": [float(v) / beam.length for v in tip],
        "tip_tangent": [float(v) for v in result.tip_tangent],
        "tip_twist_deg": math.degrees(float(result.tip_twist)),
        "max_curvature_per_mm": float(result.max_curvature) * MM,
        "energy_J": float(result.energy),
        "min_eigenvalue": float(result.min_eigenvalue) if result.success else math.nan,
        "stable": bool(result.stable),
        "snap_through": bool(result.snap_through),
        "verification_rad": float(result.verification),
        "success": bool(result.success),
        "status": int(result.status),
        "message": str(result.message),
    }


def _mT(v) -> str:
    return "(" + ", ".join(f"{x / MT:.4g}" for x in v) + ") mT"


def event_line(ev: dict) -> str:
    """One line for a solver event: its kind, the critical field when located, else where it was detected."""
    text = f"{ev['kind']}"
    if "critical_field_T" in ev:
        b = np.asarray(ev["critical_field_T"], dtype=float)
        text += f" at |B| = {np.linalg.norm(b) / MT:.4g} mT, B = {_mT(b)}"
    else:
        text += f" detected on the way to B = {_mT(ev['field_T'])} (load fraction {ev['load_fraction']:.3g})"
    if not ev.get("converged", True):
        text += " (not converged)"
    return text


def is_uniform_axial(beam) -> bool:
    """Whether ``beam`` is uniform (stiffnesses, magnetic moment) and magnetized along its axis everywhere."""
    s = np.linspace(0.0, beam.length, 65)
    d = np.asarray(beam.magnetization_direction(s), dtype=float)
    k = np.asarray(beam.stiffnesses(s), dtype=float)
    m = np.asarray(beam.moment_per_length(s), dtype=float)
    axial = np.all(np.abs(np.abs(d[:, 0]) - 1.0) < 1e-12) and np.all(np.sign(d[:, 0]) == np.sign(d[0, 0]))
    return bool(axial and np.allclose(k, k[0], rtol=_UNIFORM_RTOL, atol=0.0)
                and np.allclose(m, m[0], rtol=_UNIFORM_RTOL, atol=0.0))


def critical_ramp_end(preset):
    """The end field of the preset's one ramp from zero, which ``--critical`` follows (a cantilever's); else a
    ValueError."""
    if preset.support != "cantilever":
        raise ValueError("--critical follows the loading branch of a clamped strip (--support cantilever); a free "
                         "strip is relaxed field by field and has no branch to follow.")
    seg = preset.path
    if len(seg) != 1 or seg[0].start.magnitude != 0.0:
        what = f"{len(seg)} segments" if len(seg) != 1 else "a ramp from a non-zero field"
        raise ValueError("--critical follows one ramp from zero: give --field-mT (with --preset, it replaces the "
                         f"preset's path; {preset.name!r} has {what}).")
    return seg[0].end


def critical_report(preset) -> dict:
    """The first loss of stability along the ramp from zero to the preset's last field (3D rod), with
    Prandtl's estimate when the strip is uniform and axially magnetized (else None there)."""
    from magsoft_env.theory.elastica import prandtl_field
    from magsoft_env.theory.rod_solver import critical_field
    from magsoft_env.threads import single_threaded_blas

    end = critical_ramp_end(preset)
    opts = preset.solver_options()
    with single_threaded_blas():
        crit = critical_field(preset.beam, end, gravity=opts["gravity"], support=opts["support"],
                              clamp_angle=opts.get("clamp_angle", 0.0))
    prandtl = prandtl_field(preset.beam) if is_uniform_axial(preset.beam) else None
    out = {"ramp_end_mT": [end.Bx / MT, end.By / MT, end.Bz / MT], "found": crit is not None,
           "prandtl_mT": None if prandtl is None else prandtl / MT}
    if crit is not None:
        out.update({"magnitude_mT": crit.magnitude / MT, "error_mT": crit.error / MT, "kind": crit.kind,
                    "field_mT": [crit.field.Bx / MT, crit.field.By / MT, crit.field.Bz / MT],
                    "fraction": crit.fraction,
                    "grids": [{"nodes": n, "magnitude_mT": b / MT} for n, b in crit.magnitudes]})
    return out


def print_critical(c: dict) -> None:
    end = "(" + ", ".join(f"{v:.4g}" for v in c["ramp_end_mT"]) + ") mT"
    if not c["found"]:
        print(f"critical field: none, the strip stays stable along the ramp to B = {end}")
    else:
        at = "(" + ", ".join(f"{v:.4g}" for v in c["field_mT"]) + ") mT"
        print(f"critical field: |B| = {c['magnitude_mT']:.6g} mT +- {c['error_mT']:.1e} mT ({c['kind']}), "
              f"at B = {at}, {100 * c['fraction']:.2f} % of the ramp to {end}")
    if c["prandtl_mT"] is not None:
        ratio = f", critical / Prandtl = {c['magnitude_mT'] / c['prandtl_mT']:.4f}" if c["found"] else ""
        print(f"Prandtl's estimate (straight uniform strip, axial magnetization, field across the width): "
              f"{c['prandtl_mT']:.6g} mT{ratio}")


def _planar_only_hint(exc: ValueError) -> ValueError:
    text = str(exc)
    if "coupling='paper'" in text:
        return ValueError(f"a 3D problem takes --coupling rotated: {text}")
    if "extensible=True" in text:
        return ValueError(f"a 3D problem takes --no-extensible: {text}")
    return exc


def run_rod(args, preset, out) -> int:
    """``magsoft solve`` with the 3D rod: prints the table, events (and critical field), writes JSON and PNG."""
    from magsoft_env.theory import solve_path

    if args.critical:
        critical_ramp_end(preset)  # checked before any work
    try:
        results = solve_path(preset.beam, preset.fields, **preset.solver_options(), model="3d")
    except ValueError as exc:
        raise _planar_only_hint(exc) from None
    beam = preset.beam
    rows = [rod_row(r, beam) for r in results]
    print(textwrap.fill(f"{preset.name}: {preset.description}", width=110))
    print(f"L = {beam.length / MM:.4g} mm, w = {beam.width / MM:.4g} mm, support {preset.support}, gravity "
          f"{preset.gravity:g} m/s^2, model 3d (Kirchhoff rod, rotated coupling, inextensible), poisson "
          f"{beam.material.poisson_ratio:g}")
    print(format_table(rows, ROD_COLUMNS))
    events = [dict(e) for e in results[-1].events]
    for ev in events:
        print(f"event: {event_line(ev)}")
    if not events:
        print("events: none (no bifurcation or fold along the path)")
    critical = None
    if args.critical:
        critical = critical_report(preset)
        print_critical(critical)

    stem = f"solve_{preset.name}"
    files = []
    if not args.no_plot:
        from magsoft_env.render.figures import rod_figure

        files.append(rod_figure(results, out / f"{stem}.png", width=beam.width, max_shapes=FIGURE_SHAPES,
                                title=f"{preset.name} ({preset.source or 'custom'})"))
    s, r, frames = results[-1].sample(SHAPE_SAMPLES)
    payload = {
        "preset": preset.name,
        "description": preset.description,
        "source": preset.source,
        "config": preset.config,
        "model": "3d",
        "solver_options": preset.solver_options(),
        "length_m": beam.length,
        "width_m": beam.width,
        "fields_mT": [[f.Bx / MT, f.By / MT, f.Bz / MT] for f in preset.fields],
        "results": rows,
        "events": events,
        "final": {**rows[-1], "shape": {"s_m": s, "centreline_m": r, "frames": frames,
                                        "frames_note": "columns d1 (across the width), d2 (through the "
                                                       "thickness), d3 (tangent), body to world"}},
    }
    if critical is not None:
        payload["critical"] = critical
    files.append(write_json(out / f"{stem}.json", payload))
    for f in files:
        print(f"wrote {f}")
    failed = sum(not row["success"] for row in rows)
    if failed:
        print(f"warning: {failed} of {len(rows)} equilibria did not converge (see 'status' and 'message').")
        return 1
    return 0

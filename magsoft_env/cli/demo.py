"""``magsoft demo``: the main job on built-in defaults, in seconds.

Solves the paper's Fig. 3a loading path for the 25 mm validation beam (B_z 0 -> 13 mT, with
gravity) and the quadratic-jig beam of Fig. 4b, prints a short table and writes
``demo.png`` (shapes along both paths) and ``demo.json`` (metrics and resolved presets).
"""

from __future__ import annotations

import time

from ..io import format_table
from ..units import MM
from .output import DEFAULT_OUT, out_dir, write_json
from .solve import METRIC_COLUMNS, metrics_row

DEMO_PRESETS = ("fig3a_L25", "fig4b_quadratic")


def add_parser(subparsers) -> None:
    p = subparsers.add_parser(
        "demo",
        help="the main job on defaults: Fig. 3a path of the 25 mm beam and the Fig. 4b jig beam; table and figure",
        description="Solve two of the paper's cases along their loading paths and write a figure and JSON.",
    )
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT}/)")
    p.add_argument("--no-plot", action="store_true", help="skip the PNG")
    p.set_defaults(run=run)


def run(args) -> int:
    from magsoft_env.cases import load_preset
    from magsoft_env.theory import solve_path

    out = out_dir(args.out)
    presets = [load_preset(n) for n in DEMO_PRESETS]
    summary, panels = [], []
    failed = 0
    for preset in presets:
        t0 = time.perf_counter()
        results = solve_path(preset.beam, preset.fields, **preset.solver_options())
        dt = time.perf_counter() - t0
        rows = [metrics_row(r, preset.beam, axis=preset.sweep_axis) for r in results]
        failed += sum(not r["success"] for r in rows)
        print(f"\n{preset.name} ({preset.source}): L = {preset.beam.length / MM:.1f} mm, "
              f"{len(results)} equilibria along the path in {dt * 1e3:.0f} ms")
        picks = sorted({0, len(rows) // 4, len(rows) // 2, 3 * len(rows) // 4, len(rows) - 1})
        print(format_table([rows[i] for i in picks], METRIC_COLUMNS))
        summary.append({"preset": preset.name, "description": preset.description, "config": preset.config,
                        "solver_options": preset.solver_options(), "solve_seconds": dt, "results": rows})
        panels.append((f"{preset.name} ({preset.source})", results, preset.beam.length))

    files = []
    if not args.no_plot:
        from magsoft_env.render.figures import path_figure

        files.append(path_figure(panels, out / "demo.png"))
    files.append(write_json(out / "demo.json", {"cases": summary}))
    print()
    for f in files:
        print(f"wrote {f}")
    if failed:
        print(f"warning: {failed} equilibria did not converge (see 'success' in demo.json).")
        return 1
    return 0

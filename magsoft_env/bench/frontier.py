"""Time against error for every floor scene: wall time per simulated second against the crawl
error over segments N and timestep dt, the Pareto frontier, the knee, and where each robot's own numerics sit.

    python -m magsoft_env.bench.frontier [--cache runs.json] [--cached-only] [--scenes floor,channel,obstacle]
                                         [--plot frontier.png] [--json out.json] [--quick]

Every run is :func:`magsoft_env.bench.crawl_convergence.crawl_run`: a paper gait at the gaits' physics (material
contact, capsules, elliptic cone, native magnetics), 3 s, only N and dt changed (plus the scene). The scenes and
their robots (each scene's environment's own robot where it crawls):

* ``floor`` (``MagSoftCrawl-v1``): paper-5a, paper-5b, paper-5c on the open floor;
* ``channel`` (``MagSoftChannel-v1``): paper-5c inside the paper's 7.6 mm high box (beam 8.5 mm past the
  entrance), whose ceiling its 7.9 mm lift meets every period. The channel env's own robot, paper-5a, does not
  crawl in the box (under 0.05 mm in 3 s at N >= 40): a relative error of nothing is no measure, so it is left out;
* ``obstacle`` (``MagSoftObstacle-v1``): paper-5b crawling left into the paper's 7 x 5.5 x 2 mm block, 1 mm away.

Grid: N = 10, 20, 40, 80 x dt = 0.4, 0.2, 0.1, 0.05, 0.025 ms, plus N = 80 at 0.0125 ms and N = 160 at 0.05 and
0.025 ms for the reference (paper-5b on the floor also 0.00625 ms at N = 80). The reference and its uncertainty are
:func:`~magsoft_env.bench.crawl_convergence.reference`'s; the error of a run is the larger of its 3 s displacement
error and its speed error against it. A point is on the frontier when no cheaper point has a smaller error (the
reference's own run, the finest N at its finest step, is shown but not counted). Wall
times come from one run each on the machine that ran them (a cost ratio, not an absolute). The whole grid takes
about 40 minutes on one core; ``--cache`` keeps every run, so an interrupted run resumes, and the docs' tables
come from ``--cached-only``. ``--quick``: 1 s runs, N = 10 and 20, dt = 0.4 and 0.2 ms (a smoke test).
"""

from __future__ import annotations

import argparse
import math
import sys

from magsoft_env.bench.crawl_convergence import SCENES, Runner, reference, rel_error
from magsoft_env.io import write_json

#: Scene -> (robots, RodOptions replacements that place the scene's feature).
SCENE_RUNS = {
    "floor": (("paper-5a", "paper-5b", "paper-5c"), {}),
    "channel": (("paper-5c",), {"scene": "channel", "feature_x": SCENES["channel"]}),
    "obstacle": (("paper-5b",), {"scene": "obstacle", "feature_x": SCENES["obstacle"]}),
}
SEGMENTS = (10, 20, 40, 80)
TIMESTEPS_MS = (0.4, 0.2, 0.1, 0.05, 0.025)
#: Extra (N, dt ms) runs for the reference: a finer step at N = 80 and N = 160 at the two finest steps.
REFERENCE_RUNS = ((80, 0.0125), (160, 0.05), (160, 0.025))
#: paper-5b on the floor settles only at dt <= 0.025 ms (docs/convergence.md): one more halving at N = 80.
EXTRA_RUNS = {("floor", "paper-5b"): ((80, 0.00625),)}
TOLERANCE = 0.05


def scene_grid(run: Runner, scene: str, robot: str, *, quick: bool = False) -> dict:
    """``{(robot, N, dt_ms): row}`` of one scene's robot (cached runs reused; missing ones run unless cached-only)."""
    _, extra = SCENE_RUNS[scene]
    segs, dts = ((10, 20), (0.4, 0.2)) if quick else (SEGMENTS, TIMESTEPS_MS)
    points = [(n, d) for n in segs for d in dts]
    if not quick:
        points += list(REFERENCE_RUNS) + list(EXTRA_RUNS.get((scene, robot), ()))
    grid = {}
    for n, d in points:
        row = run(robot, n, d, **extra)
        if row is not None:
            grid[(robot, n, d)] = row
    return grid


def frontier_rows(grid: dict, robot: str) -> tuple[list[dict], dict]:
    """Every run of ``robot`` with its error against the reference, the frontier flag, sorted by cost; and the
    reference (displacement and speed)."""
    refs = {q: reference(grid, robot, q) for q in ("displacement_mm", "speed_mm_s")}
    rows = []
    for (g, n, d), r in grid.items():
        if g != robot:
            continue
        ok = r["success"]
        ed = rel_error(r["displacement_mm"] if ok else math.nan, refs["displacement_mm"]["value"])
        ev = rel_error(r["speed_mm_s"] if ok else math.nan, refs["speed_mm_s"]["value"])
        rows.append({"robot": g, "segments": n, "timestep_ms": d, "wall_per_sim_s": r["wall_per_sim_s"],
                     "error": max(ed, ev), "error_displacement": ed, "error_speed": ev,
                     "displacement_mm": r["displacement_mm"], "speed_mm_s": r["speed_mm_s"], "success": ok})
    rows.sort(key=lambda r: r["wall_per_sim_s"])
    # the reference's own run (finest N, finest step) has no error of its own to show: it is marked, and left off
    # the frontier and the knee
    n_ref = refs["speed_mm_s"]["segments"]
    d_ref = min(r["timestep_ms"] for r in rows if r["segments"] == n_ref)
    best = math.inf
    for r in rows:
        r["reference"] = (r["segments"], r["timestep_ms"]) == (n_ref, d_ref)
        r["frontier"] = not r["reference"] and r["error"] < best
        if not r["reference"]:
            best = min(best, r["error"])
    return rows, refs


def knee(rows: list[dict], tolerance: float = TOLERANCE) -> dict | None:
    """The cheapest run within ``tolerance`` whose next finer step at the same N is within it too (robust), else
    the cheapest within it; None if there is none."""
    by = {(r["segments"], r["timestep_ms"]): r for r in rows}
    ok = [r for r in rows if r["error"] <= tolerance and not r.get("reference")]
    for r in ok:  # rows are sorted by cost
        finer = [d for (n, d) in by if n == r["segments"] and d < r["timestep_ms"]]
        if finer and by[(r["segments"], max(finer))]["error"] <= tolerance:
            return {**r, "robust": True}
    return {**ok[0], "robust": False} if ok else None


def own_numerics(robot: str, scene: str = "floor") -> tuple[int, float]:
    """The robot's own (segments, timestep in ms) in ``scene`` (its file's numerics for that scene)."""
    from magsoft_env.cases.gaits import numerics
    from magsoft_env.cases.robots import load_robot

    n, dt = numerics(load_robot(robot), scene=scene)
    return n, dt * 1e3


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", default=",".join(SCENE_RUNS), help=f"comma list of {list(SCENE_RUNS)}")
    p.add_argument("--cache", default=None, help="JSON file of finished runs, reused and extended")
    p.add_argument("--cached-only", action="store_true", help="run nothing: tabulate the cached runs")
    p.add_argument("--quick", action="store_true", help="1 s runs, N 10/20, dt 0.4/0.2 ms (smoke test)")
    p.add_argument("--plot", default=None, help="write the frontier figure here (.png)")
    p.add_argument("--json", default=None, help="write the results here")
    a = p.parse_args(argv)
    scenes = tuple(a.scenes.split(","))
    for s in scenes:
        if s not in SCENE_RUNS:
            raise SystemExit(f"frontier: --scenes takes {list(SCENE_RUNS)}, got {s!r}.")
    run = Runner(a.cache, seconds=1.0 if a.quick else 3.0, cached_only=a.cached_only)
    results: dict = {}
    for scene in scenes:
        for robot in SCENE_RUNS[scene][0]:
            grid = scene_grid(run, scene, robot, quick=a.quick)
            if not grid:
                print(f"{scene} {robot}: no runs (cached-only with an empty cache)")
                continue
            rows, refs = frontier_rows(grid, robot)
            k = knee(rows)
            results.setdefault(scene, {})[robot] = {"rows": rows, "reference": {
                q: {kk: r[kk] for kk in ("value", "uncertainty", "relative_uncertainty")} for q, r in refs.items()},
                "knee": k, "own_numerics": own_numerics(robot, scene)}
    for scene, per_robot in results.items():
        for robot, res in per_robot.items():
            rd, rv = res["reference"]["displacement_mm"], res["reference"]["speed_mm_s"]
            n_own, d_own = res["own_numerics"]
            print(f"\n### {scene}, {robot}: reference {rd['value']:+.3f} mm in 3 s "
                  f"(+-{100 * rd['relative_uncertainty']:.1f} %), {rv['value']:+.3f} mm/s "
                  f"(+-{100 * rv['relative_uncertainty']:.1f} %)\n")
            print("| N | dt (ms) | wall / sim s | error (max of displacement, speed) | frontier |")
            print("|---|---|---|---|---|")
            for r in res["rows"]:
                mark = " (robot's own)" if (r["segments"], r["timestep_ms"]) == (n_own, d_own) else ""
                mark += " (the reference's run)" if r["reference"] else ""
                print(f"| {r['segments']} | {r['timestep_ms']:g}{mark} | {r['wall_per_sim_s']:.2f} | "
                      f"{100 * r['error']:.1f} % | {'yes' if r['frontier'] else ''} |")
            k = res["knee"]
            print(f"\nknee (cheapest within {100 * TOLERANCE:g} %"
                  + (f"): N {k['segments']}, {k['timestep_ms']:g} ms, {100 * k['error']:.1f} %, "
                     f"{k['wall_per_sim_s']:.2f} s/s{', robust (the next finer step too)' if k['robust'] else ''}"
                     if k else "): none in the grid"))
    if results:
        print("\n### Summary\n")
        print("| scene | robot | reference speed (mm/s) | robot's own numerics | error | wall / sim s | knee (within "
              f"{100 * TOLERANCE:g} %) | error | wall / sim s |")
        print("|---|---|---|---|---|---|---|---|---|")
        for scene, per_robot in results.items():
            for robot, res in per_robot.items():
                rv = res["reference"]["speed_mm_s"]
                own = next((r for r in res["rows"] if (r["segments"], r["timestep_ms"]) == tuple(res["own_numerics"])),
                           None)
                k = res["knee"]
                own_txt = (f"N {own['segments']}, {own['timestep_ms']:g} ms | {100 * own['error']:.1f} % | "
                           f"{own['wall_per_sim_s']:.2f}") if own else "not in the grid | | "
                k_txt = (f"N {k['segments']}, {k['timestep_ms']:g} ms{'' if k['robust'] else ' (not robust)'} | "
                         f"{100 * k['error']:.1f} % | {k['wall_per_sim_s']:.2f}") if k else "none in the grid | | "
                print(f"| {scene} | {robot} | {rv['value']:+.3f} +- {rv['uncertainty']:.3f} | {own_txt} | {k_txt} |")
    if a.plot and results:
        from magsoft_env.render.figures import frontier_figure

        frontier_figure(results, a.plot, tolerance=TOLERANCE)
        print(f"\nfigure: {a.plot}")
    if a.json:
        write_json(a.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())

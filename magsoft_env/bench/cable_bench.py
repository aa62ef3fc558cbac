"""Benchmark: time against error of the 3D rod (the MuJoCo flexcomp strip, :mod:`magsoft_env.sim.cable`).

Run: ``python -m magsoft_env.bench.cable_bench`` (``--quick``: one tiny case per section, seconds;
``--only sfc``: sections; ``--json out.json``: the rows).

Every row gives an error beside a wall time, against a baseline run in the same process:

``s`` **statics**: the tip of the clamped strip (``cable_equilibrium``, gravity first, then the field ramped,
each settle to ``tol = 1e-6``) against the 3D analytical model (``solve_equilibrium(model="3d")``, timed as the
baseline), error ``|tip - tip_ref| / L`` and the tip-twist error, over segments N and the timestep. Cases (paper
strip 25 x 5 x 1.13 mm, phi 0.2): ``plane``, axial magnetization, field (0, 0, 5 mT) with gravity, in plane (the
planar chain at its statics defaults is timed and compared beside it); ``buckled``, field (0, 1.2 mT, 0) without
gravity, past lateral-torsional buckling (0.84 mT), seeded by a 10 uT field along -z during the ramp: the
analytical buckled branch, where bending and twist couple.

``f`` **frequencies**: the first weak-bending, strong-bending and torsion frequencies from free vibration
(``free_vibration``) against the beam formulas (``frequencies``), over N and the timestep.

``c`` **crawl cost**: ``run_gait("paper-5c", rod="cable")`` on the floor, wall time per simulated second at N and
the timestep, beside the planar chain's (``run_gait("paper-5c")``, capsules, native couples) at the same N and
timestep, with both crawl speeds and the strip's difference from the chain.

Then the **knee** of each section: the setting with the least work ``N / dt`` (the wall time of every section grows
with it; measured times on a shared machine are too noisy to rank close settings) whose rows are all within the
section's tolerance (statics 0.5 % of L in plane and 1.5 % of L on the buckled branch, frequencies 0.5 %, crawl 5 %
of the chain's speed at the same numerics, the chain's own stated error), beside the defaults (:data:`DEFAULTS`)
and their errors.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import magsoft_env as ms
from magsoft_env.io import format_table, write_json
from magsoft_env.sim import cable as C
from magsoft_env.sim import mujoco_equilibrium
from magsoft_env.sim.gait import run_gait

#: Statics cases: name -> (field (T), gravity (m/s^2), imperfection (T)).
STATICS_CASES = {
    "plane": ((0.0, 0.0, 5e-3), 9.81, 0.0),
    "buckled": ((0.0, 1.2e-3, 0.0), 0.0, -1e-5),
}
#: (segments, timestep) of the statics rows.
STATICS_GRID = ((10, 1e-3), (20, 1e-3), (40, 1e-3), (80, 1e-3), (40, 3e-4), (80, 3e-4))
#: (segments, timestep) of the frequency rows.
FREQ_GRID = ((10, 1e-4), (20, 1e-4), (40, 1e-4), (10, 3e-4), (20, 3e-4), (20, 1e-3), (40, 1e-3))
#: (segments, timestep) of the crawl rows.
CRAWL_GRID = ((20, 2e-4), (20, 1e-4), (20, 5e-5), (40, 1e-4), (40, 5e-5), (40, 2.5e-5), (80, 1e-4),
              (80, 2.5e-5))
#: Tolerances of the knee: statics tip error / L per case, frequency error (relative), crawl speed against the
#: chain's (relative).
TOL = {"plane": 5e-3, "buckled": 1.5e-2, "frequency": 5e-3, "crawl": 5e-2}
#: The strip's defaults: statics (``cable_equilibrium``), dynamics (``free_vibration``), the paper-5c crawl
#: (``run_gait(rod="cable")``, :func:`~magsoft_env.sim.gait.cable_gait_numerics`).
DEFAULTS = {"statics": (20, 1e-3), "frequency": (20, 1e-4), "crawl": (40, 1e-4)}
QUICK = {"statics": ((10, 1e-3),), "frequency": ((10, 1e-3),), "crawl": ((10, 2e-4),)}
BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, volume_fraction=0.2)


def _timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def statics(grid, cases=tuple(STATICS_CASES)) -> list[dict]:
    """Rows of the statics section (see the module docstring)."""
    L = BEAM.length
    rows = []
    for case in cases:
        field, g, imp = STATICS_CASES[case]
        ref, t_ref = _timed(ms.solve_equilibrium, BEAM, field, gravity=g, model="3d")
        if case == "plane":  # the planar chain at its statics defaults (N = 20, 10 ms, grading 1.5)
            chain, t_chain = _timed(mujoco_equilibrium, BEAM, (field[0], field[2]), gravity=g)
            tip = np.array([chain.x[-1], 0.0, chain.z[-1]])
            rows.append({"case": case, "rod": "planar chain", "segments": 20, "timestep_ms": 10.0,
                         "success": bool(chain.success),
                         "tip_error_L": float(np.linalg.norm(tip - ref.tip_position)) / L,
                         "twist_error_deg": 0.0, "edge_strain": 0.0, "steps": -1, "wall_s": t_chain,
                         "baseline_wall_s": t_ref})
        for n, dt in grid:
            eq, t = _timed(C.cable_equilibrium, BEAM, field, gravity=g, segments=n, timestep=dt, imperfection=imp)
            rows.append({"case": case, "rod": "strip", "segments": n, "timestep_ms": dt * 1e3,
                         "success": bool(eq.success),
                         "tip_error_L": float(np.linalg.norm(eq.tip_position - ref.tip_position)) / L,
                         "twist_error_deg": math.degrees(eq.tip_twist - ref.tip_twist),
                         "edge_strain": float(eq.edge_strain), "steps": int(eq.steps), "wall_s": t,
                         "baseline_wall_s": t_ref})
    return rows


def frequencies(grid, modes=C.MODES, periods: float = 4.0) -> list[dict]:
    """Rows of the frequency section."""
    ref = C.frequencies(BEAM)
    rows = []
    for n, dt in grid:
        for mode in modes:
            (fr, _, _), t = _timed(C.free_vibration, BEAM, mode, segments=n, timestep=dt, periods=periods)
            rows.append({"mode": mode, "segments": n, "timestep_ms": dt * 1e3, "frequency_Hz": fr,
                         "formula_Hz": ref[mode], "error": fr / ref[mode] - 1.0, "wall_s": t})
    return rows


def crawl(grid, seconds: float) -> list[dict]:
    """Rows of the crawl section: the strip and the planar chain, paper-5c drive, same N and timestep."""
    rows = []
    for n, dt in grid:
        s, ts = _timed(run_gait, "paper-5c", seconds, segments=n, timestep=dt, rod="cable")
        c, tc = _timed(run_gait, "paper-5c", seconds, segments=n, timestep=dt)
        rows.append({"segments": n, "timestep_ms": dt * 1e3, "strip_ok": bool(s.success), "chain_ok": bool(c.success),
                     "strip_speed_mm_s": s.speed * 1e3, "chain_speed_mm_s": c.speed * 1e3,
                     "difference": s.speed / c.speed - 1.0, "strip_wall_per_s": ts / seconds,
                     "chain_wall_per_s": tc / seconds, "cost_ratio": ts / tc,
                     "strip_penetration_h": float(s.max_penetration_h)})
    return rows


def knees(stat: list[dict], freq: list[dict], crw: list[dict]) -> list[dict]:
    """The cheapest row within tolerance of each section (see the module docstring), and the defaults."""
    out = []

    def pick(label, rows, key, err, cost, tol):
        setting = sorted({key(r) for r in rows})
        per = {k: [r for r in rows if key(r) == k] for k in setting}
        ok = [k for k in setting if all(math.isfinite(err(r)) and abs(err(r)) <= tol(r) for r in per[k])]
        best = min(ok, key=lambda k: (k[0] / k[1], k[0])) if ok else None  # least work N / dt
        d = DEFAULTS[label]
        dkey = (d[0], d[1] * 1e3)
        for what, k in (("knee", best), ("default", dkey if dkey in per else None)):
            if k is None:
                out.append({"section": label, "what": what, "segments": -1, "timestep_ms": math.nan,
                            "worst_error": math.nan, "wall_s": math.nan})
                continue
            out.append({"section": label, "what": what, "segments": k[0], "timestep_ms": k[1],
                        "worst_error": max(abs(err(r)) for r in per[k]), "wall_s": sum(cost(r) for r in per[k])})

    strip = [r for r in stat if r["rod"] == "strip"]
    if strip:
        pick("statics", strip, lambda r: (r["segments"], r["timestep_ms"]), lambda r: r["tip_error_L"],
             lambda r: r["wall_s"], lambda r: TOL[r["case"]])
    if freq:
        pick("frequency", freq, lambda r: (r["segments"], r["timestep_ms"]), lambda r: r["error"],
             lambda r: r["wall_s"], lambda r: TOL["frequency"])
    if crw:
        pick("crawl", [r for r in crw if r["strip_ok"] and r["chain_ok"]],
             lambda r: (r["segments"], r["timestep_ms"]), lambda r: r["difference"],
             lambda r: r["strip_wall_per_s"], lambda r: TOL["crawl"])
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one tiny case per section (seconds)")
    ap.add_argument("--only", default="sfc", help="sections, letters among s (statics), f (frequencies), "
                                                  "c (crawl cost); default all")
    ap.add_argument("--seconds", type=float, default=None,
                    help="simulated seconds of each crawl (default 1.5: two periods after a warm-up one; quick 0.3)")
    ap.add_argument("--json", default=None, help="write the rows here")
    args = ap.parse_args(argv)
    if not args.only or set(args.only) - set("sfc"):
        ap.error(f"--only takes letters among sfc, got {args.only!r}")
    t_start = time.perf_counter()
    quick = args.quick
    seconds = args.seconds or (0.3 if quick else 1.5)
    stat = freq = crw = []
    if "s" in args.only:
        stat = statics(QUICK["statics"] if quick else STATICS_GRID, ("plane",) if quick else tuple(STATICS_CASES))
        print("statics: tip error against the 3D analytical model (baseline: solve_equilibrium(model='3d'), wall "
              "time beside)")
        print(format_table(stat, [("case", "case", ""), ("rod", "rod", ""), ("segments", "N", "d"),
                                  ("timestep_ms", "dt ms", "g"), ("success", "ok", ""),
                                  ("tip_error_L", "tip err / L", ".2e"), ("twist_error_deg", "twist err deg", "+.4f"),
                                  ("edge_strain", "edge strain", ".1e"), ("steps", "steps", "d"),
                                  ("wall_s", "wall s", ".2f"), ("baseline_wall_s", "3D model s", ".3f")]), "\n",
              flush=True)
    if "f" in args.only:
        freq = frequencies(QUICK["frequency"] if quick else FREQ_GRID, ("weak",) if quick else C.MODES,
                           periods=2.0 if quick else 4.0)
        print("frequencies: free vibration against the beam formulas")
        print(format_table(freq, [("mode", "mode", ""), ("segments", "N", "d"), ("timestep_ms", "dt ms", "g"),
                                  ("frequency_Hz", "measured Hz", ".4f"), ("formula_Hz", "formula Hz", ".4f"),
                                  ("error", "error", "+.2%"), ("wall_s", "wall s", ".2f")]), "\n", flush=True)
    if "c" in args.only:
        crw = crawl(QUICK["crawl"] if quick else CRAWL_GRID, seconds)
        print(f"crawl on the floor: paper-5c drive, {seconds:g} s, strip beside the planar chain (baseline) at the "
              "same N and dt")
        print(format_table(crw, [("segments", "N", "d"), ("timestep_ms", "dt ms", "g"),
                                 ("strip_speed_mm_s", "strip mm/s", "+.4f"), ("chain_speed_mm_s", "chain mm/s", "+.4f"),
                                 ("difference", "strip - chain", "+.1%"),
                                 ("strip_wall_per_s", "strip wall/sim s", ".1f"),
                                 ("chain_wall_per_s", "chain wall/sim s", ".1f"), ("cost_ratio", "cost ratio", ".1f"),
                                 ("strip_penetration_h", "penetration h", ".3f")]), "\n", flush=True)
    kn = knees(stat, freq, crw)
    if kn:
        print("knee (least work N / dt within tolerance: statics 0.5 % L plane / 1.5 % L buckled, frequencies 0.5 %, "
              "crawl 5 % of the chain) and the defaults")
        print(format_table(kn, [("section", "section", ""), ("what", "", ""), ("segments", "N", "d"),
                                ("timestep_ms", "dt ms", "g"), ("worst_error", "worst error", ".2e"),
                                ("wall_s", "wall s (crawl: per sim s)", ".2f")]))
    if args.json:
        write_json(args.json, {"statics": stat, "frequencies": freq, "crawl": crw, "knee": kn,
                               "crawl_seconds": seconds})
        print(f"wrote {args.json}")
    print(f"total {time.perf_counter() - t_start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

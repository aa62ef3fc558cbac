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

``n`` **native couples**: the crawl by couple path (:attr:`~magsoft_env.sim.cable.CableRod.couples`), each strip run
beside the others and the planar chain at the same numerics: CPU and wall time per simulated second, crawl speed,
the largest centreline difference from the strip's Python-couple run (``"python"``, the couples written from
Python every step, the strip's only way before the poles) as a fraction of L, over the first second and over the
run, and the largest edge stretch (the native couples' relative error: their lever is the current edge length).
Cases: paper-5c (its programmed magnetization has thickness components, so the automatic path is Python; the
``"mixed"`` path puts its axial part in MuJoCo's poles) at the strip's gait numerics and at 30 segments and 0.2 ms;
``axial-5a``, paper-5a's beam and drive with the magnetization along the strip (the automatic path is native:
every couple MuJoCo's, blocks of steps in C).

``v`` **variants**: the floor contact (``element``, the default; ``vertex``, a plane; a cylinder floor, against which
MuJoCo collides the flex's elements as capsules of radius h/2) on the paper-5c crawl at the strip's gait numerics,
crawl speed against the element contact's with its cost; and the pole inputs (three tendon motors or a motor per
vertex slide), MuJoCo's cost per step of the ``axial-5a`` strip.

Then the **knee** of each section: the setting with the least work ``N / dt`` (the wall time of every section grows
with it; measured times on a shared machine are too noisy to rank close settings) whose rows are all within the
section's tolerance (statics 0.5 % of L in plane and 1.5 % of L on the buckled branch, frequencies 0.5 %, crawl 5 %
of the chain's speed at the same numerics, the chain's own stated error), beside the defaults (:data:`DEFAULTS`)
and their errors. The statics run with each couple path (native poles and Python couples; both cases are axial);
the frequencies have no field, so the couples do not enter them.

Times: wall time, and for the new sections also the process's CPU time, which other jobs on a shared machine
disturb less (one thread: it is the time the run itself took).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import time

import mujoco
import numpy as np

import magsoft_env as ms
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.io import format_table, write_json
from magsoft_env.sim import Simulator, mujoco_equilibrium
from magsoft_env.sim import cable as C
from magsoft_env.sim.gait import gait_rod_options, run_gait, speed_window
from magsoft_env.sim.readouts import is_flipped
from magsoft_env.sim.waveforms import as_waveform

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
CRAWL_GRID = ((20, 2e-4), (20, 1e-4), (20, 5e-5), (30, 2e-4), (40, 2e-4), (40, 1e-4), (40, 5e-5), (40, 2.5e-5),
              (80, 1e-4), (80, 2.5e-5))
#: Cases of the couple-path section: (robot, segments, timestep, strip paths), the first path the reference of the
#: trajectory differences.
PATH_CASES = (("paper-5c", 40, 1e-4, ("python", "mixed")), ("paper-5c", 30, 2e-4, ("python",)),
              ("axial-5a", 40, 1e-4, ("python", "native")))
#: Floor contacts of the variant section: the builder's, and a cylinder floor (elements as capsules).
FLOOR_VARIANTS = ("element", "vertex", "capsule")
#: Tolerances of the knee: statics tip error / L per case, frequency error (relative), crawl speed against the
#: chain's (relative).
TOL = {"plane": 5e-3, "buckled": 1.5e-2, "frequency": 5e-3, "crawl": 5e-2}
#: The strip's defaults: statics (``cable_equilibrium``), dynamics (``free_vibration``), the paper-5c crawl
#: (``run_gait(rod="cable")``, :func:`~magsoft_env.sim.gait.cable_gait_numerics`).
DEFAULTS = {"statics": (20, 1e-3), "frequency": (20, 1e-4), "crawl": (40, 1e-4)}
QUICK = {"statics": ((10, 1e-3),), "frequency": ((10, 1e-3),), "crawl": ((10, 2e-4),),
         "paths": (("paper-5c", 10, 2e-4, ("python", "mixed")), ("axial-5a", 10, 2e-4, ("python", "native"))),
         "variants": (10, 2e-4)}
BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, volume_fraction=0.2)


def _timed(fn, *args, **kwargs):
    t0 = time.perf_counter()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - t0


def statics(grid, cases=tuple(STATICS_CASES), paths=("native", "python")) -> list[dict]:
    """Rows of the statics section (see the module docstring), the strip with each couple path of ``paths``."""
    L = BEAM.length
    rows = []
    for case in cases:
        field, g, imp = STATICS_CASES[case]
        ref, t_ref = _timed(ms.solve_equilibrium, BEAM, field, gravity=g, model="3d")
        if case == "plane":  # the planar chain at its statics defaults (N = 20, 10 ms, grading 1.5)
            chain, t_chain = _timed(mujoco_equilibrium, BEAM, (field[0], field[2]), gravity=g)
            tip = np.array([chain.x[-1], 0.0, chain.z[-1]])
            rows.append({"case": case, "rod": "planar chain", "couples": "native", "segments": 20,
                         "timestep_ms": 10.0, "success": bool(chain.success),
                         "tip_error_L": float(np.linalg.norm(tip - ref.tip_position)) / L,
                         "twist_error_deg": 0.0, "edge_strain": 0.0, "steps": -1, "wall_s": t_chain,
                         "baseline_wall_s": t_ref})
        for n, dt in grid:
            for path in paths:
                with C.overrides(path):
                    eq, t = _timed(C.cable_equilibrium, BEAM, field, gravity=g, segments=n, timestep=dt,
                                   imperfection=imp)
                rows.append({"case": case, "rod": "strip", "couples": path, "segments": n, "timestep_ms": dt * 1e3,
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


def robot(name: str):
    """A gait preset, or ``"axial-5a"``: paper-5a's beam and drive with the magnetization along the strip."""
    if name == "axial-5a":
        r = gait_preset("paper-5a")
        return dataclasses.replace(r, beam=dataclasses.replace(r.beam, magnetization=(1.0, 0.0, 0.0)), name=name)
    return gait_preset(name)


def run_crawl(name: str, seconds: float, segments: int, timestep: float, *, rod: str = "cable",
              couples: str | None = None, floor_contact: str | None = None, floor_geom=None,
              sample_dt: float = 0.01) -> dict:
    """The gait of robot ``name`` (:func:`robot`) on the floor as :func:`~magsoft_env.sim.gait.run_gait` runs it,
    recording the centreline every ``sample_dt`` (s): ``cpu_s`` and ``wall_s`` of the stepping, ``speed`` (m/s,
    NaN after a flip end over end), ``t`` ``(n,)`` (s), ``centrelines`` ``(n, N + 2, 3)`` (m), ``ok``, ``message``,
    ``penetration_h``, ``roll_deg``. ``couples``, ``floor_contact``: :func:`~magsoft_env.sim.cable.overrides` of the
    strip; ``floor_geom``: ``(type, size, pos)`` written over the strip's floor geom after it is built."""
    r = robot(name)
    options = gait_rod_options(r, segments=segments, timestep=timestep, rod=rod)
    with C.overrides(couples, floor_contact=floor_contact):
        sim = Simulator(r.beam, options)
    if floor_geom is not None:
        g = mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        sim.model.geom_type[g], sim.model.geom_size[g], sim.model.geom_pos[g] = floor_geom
        sim.reset()
    sim.set_waveform(as_waveform(r.wave))
    every = max(1, int(round(sample_dt / sim.timestep)))
    nsteps = int(round(seconds / sim.timestep))
    tracker = sim.orientation_tracker()
    pose = sim.pose()
    tracker.track(pose)
    ts, xs, lines, roll, flipped = [0.0], [float(pose.com[0])], [pose.centreline], pose.roll, False
    # the couples' relative error on the native path: the edges' stretch (0 for the chain's rigid links)
    strain = (lambda: C.edge_strain(sim.backend.rod, sim.data)) if rod == "cable" else (lambda: 0.0)
    max_strain = strain()
    ok, msg, done = True, "ok", 0
    cpu0, wall0 = time.process_time(), time.perf_counter()
    while done < nsteps:
        k = min(every, nsteps - done)
        try:
            sim.step(k)
        except ms.sim.SimulationError as err:
            ok, msg = False, str(err)
            break
        done += k
        pose = sim.pose()
        ts.append(sim.time)
        xs.append(float(pose.com[0]))
        lines.append(pose.centreline)
        roll = max(roll, pose.roll)
        max_strain = max(max_strain, strain())
        flipped = flipped or is_flipped(tracker.track(pose))
    cpu, wall = time.process_time() - cpu0, time.perf_counter() - wall0
    t, x = np.array(ts), np.array(xs)
    i0, i1, _ = speed_window(t, r.wave.frequency, 1.0)
    speed = math.nan if flipped or t[i1] <= t[i0] else (x[i1] - x[i0]) / (t[i1] - t[i0])
    return {"cpu_s": cpu, "wall_s": wall, "speed": speed, "t": t, "centrelines": np.array(lines), "ok": ok,
            "message": msg, "penetration_h": sim.max_penetration / r.beam.thickness, "roll_deg": math.degrees(roll),
            "seconds": float(t[-1]), "flipped": flipped, "edge_strain": max_strain}


def _difference(a: dict, b: dict, length: float, until: float) -> float:
    """Largest centreline difference (fraction of L) between two runs' common samples up to ``until`` (s)."""
    n = min(len(a["t"]), len(b["t"]))
    keep = a["t"][:n] <= until + 1e-9
    return float(np.max(np.abs(a["centrelines"][:n][keep] - b["centrelines"][:n][keep]))) / length


def couple_paths(cases, seconds: float) -> list[dict]:
    """Rows of the couple-path section (module docstring): each case's strip paths and the planar chain."""
    rows = []
    for name, n, dt, paths in cases:
        L = robot(name).beam.length
        runs = {path: run_crawl(name, seconds, n, dt, couples=path) for path in paths}
        chain = run_crawl(name, seconds, n, dt, rod="planar")
        ref = runs[paths[0]]
        for label, r in [*runs.items(), ("planar chain", chain)]:
            strip = label != "planar chain"
            rows.append({"robot": name, "segments": n, "timestep_ms": dt * 1e3, "rod": "strip" if strip else "chain",
                         "couples": label if strip else "native", "ok": r["ok"],
                         "cpu_per_s": r["cpu_s"] / seconds, "wall_per_s": r["wall_s"] / seconds,
                         "speed_mm_s": r["speed"] * 1e3,
                         "vs_chain": r["speed"] / chain["speed"] - 1.0 if strip else 0.0,
                         "speedup": ref["cpu_s"] / r["cpu_s"],
                         "diff_1s_L": _difference(r, ref, L, 1.0) if strip else math.nan,
                         "diff_end_L": _difference(r, ref, L, seconds) if strip else math.nan,
                         "penetration_h": r["penetration_h"], "roll_deg": r["roll_deg"],
                         "edge_strain": r["edge_strain"]})
    return rows


def floor_variants(seconds: float, segments: int = 40, timestep: float = 1e-4) -> list[dict]:
    """Rows of the floor-contact variants on the paper-5c crawl (module docstring), the element contact first."""
    L = gait_preset("paper-5c").beam.length
    big = 10.0 * L
    rows, ref = [], None
    for v in FLOOR_VARIANTS:
        if v == "capsule":  # a cylinder floor, top face at z = 0: MuJoCo collides the elements as capsules
            r = run_crawl("paper-5c", seconds, segments, timestep,
                          floor_geom=(mujoco.mjtGeom.mjGEOM_CYLINDER, [big, L, 0.0], [0.0, 0.0, -L]))
        else:
            r = run_crawl("paper-5c", seconds, segments, timestep, floor_contact=v)
        ref = ref or r
        rows.append({"variant": v, "segments": segments, "timestep_ms": timestep * 1e3, "ok": r["ok"],
                     "cpu_per_s": r["cpu_s"] / seconds, "cost": r["cpu_s"] / ref["cpu_s"],
                     "speed_mm_s": r["speed"] * 1e3, "vs_element": r["speed"] / ref["speed"] - 1.0,
                     "penetration_h": r["penetration_h"], "roll_deg": r["roll_deg"]})
    return rows


def pole_inputs(segments: int = 40, timestep: float = 1e-4, steps: int = 2000, repeats: int = 3) -> list[dict]:
    """MuJoCo's cost per step (CPU, held field) of the ``axial-5a`` strip crawling with each pole input, best of
    ``repeats`` interleaved runs from the same state."""
    r = robot("axial-5a")
    sims = {}
    for poles in C.POLE_INPUTS:
        with C.overrides(poles=poles):
            sim = Simulator(r.beam, gait_rod_options(r, segments=segments, timestep=timestep, rod="cable"))
        sim.set_waveform(as_waveform(r.wave))
        sim.step(1000)
        sims[poles] = sim
    spec = int(mujoco.mjtState.mjSTATE_INTEGRATION)
    best = {p: math.inf for p in sims}
    for _ in range(repeats):
        for p, sim in sims.items():
            state = np.empty(mujoco.mj_stateSize(sim.model, spec))
            mujoco.mj_getState(sim.model, sim.data, state, spec)
            t0 = time.process_time()
            mujoco.mj_step(sim.model, sim.data, steps)
            best[p] = min(best[p], (time.process_time() - t0) / steps)
            mujoco.mj_setState(sim.model, sim.data, state, spec)
    return [{"poles": p, "segments": segments, "timestep_ms": timestep * 1e3, "actuators": int(sims[p].model.nu),
             "us_per_step": best[p] * 1e6, "cost": best[p] / best[C.POLE_INPUT]} for p in sims]


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

    def pick(label, rows, key, err, cost, tol, couples=""):
        setting = sorted({key(r) for r in rows})
        per = {k: [r for r in rows if key(r) == k] for k in setting}
        ok = [k for k in setting if all(math.isfinite(err(r)) and abs(err(r)) <= tol(r) for r in per[k])]
        best = min(ok, key=lambda k: (k[0] / k[1], k[0])) if ok else None  # least work N / dt
        d = DEFAULTS[label]
        dkey = (d[0], d[1] * 1e3)
        for what, k in (("knee", best), ("default", dkey if dkey in per else None)):
            if k is None:
                out.append({"section": label, "couples": couples, "what": what, "segments": -1,
                            "timestep_ms": math.nan, "worst_error": math.nan, "wall_s": math.nan})
                continue
            out.append({"section": label, "couples": couples, "what": what, "segments": k[0], "timestep_ms": k[1],
                        "worst_error": max(abs(err(r)) for r in per[k]), "wall_s": sum(cost(r) for r in per[k])})

    for path in ("native", "python"):
        strip = [r for r in stat if r["rod"] == "strip" and r["couples"] == path]
        if strip:
            pick("statics", strip, lambda r: (r["segments"], r["timestep_ms"]), lambda r: r["tip_error_L"],
                 lambda r: r["wall_s"], lambda r: TOL[r["case"]], path)
    if freq:
        pick("frequency", freq, lambda r: (r["segments"], r["timestep_ms"]), lambda r: r["error"],
             lambda r: r["wall_s"], lambda r: TOL["frequency"])
    if crw:
        pick("crawl", [r for r in crw if r["strip_ok"] and r["chain_ok"]],
             lambda r: (r["segments"], r["timestep_ms"]), lambda r: r["difference"],
             lambda r: r["strip_wall_per_s"], lambda r: TOL["crawl"])
    return out


SECTIONS = "sfcnv"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one tiny case per section (seconds)")
    ap.add_argument("--only", default=SECTIONS, help="sections, letters among s (statics), f (frequencies), "
                                                     "c (crawl cost), n (native couples), v (variants); default all")
    ap.add_argument("--seconds", type=float, default=None,
                    help="simulated seconds of each crawl of section c (default 1.5: two periods after a warm-up one; "
                         "quick 0.3)")
    ap.add_argument("--path-seconds", type=float, default=None,
                    help="simulated seconds of each crawl of sections n and v (default 4; quick 0.3)")
    ap.add_argument("--json", default=None, help="write the rows here")
    args = ap.parse_args(argv)
    if not args.only or set(args.only) - set(SECTIONS):
        ap.error(f"--only takes letters among {SECTIONS}, got {args.only!r}")
    t_start = time.perf_counter()
    quick = args.quick
    seconds = args.seconds or (0.3 if quick else 1.5)
    path_seconds = args.path_seconds or (0.3 if quick else 4.0)
    stat = freq = crw = paths = variants = poles = []
    if "s" in args.only:
        stat = statics(QUICK["statics"] if quick else STATICS_GRID, ("plane",) if quick else tuple(STATICS_CASES))
        print("statics: tip error against the 3D analytical model (baseline: solve_equilibrium(model='3d'), wall "
              "time beside), the strip with native (poles) and Python couples")
        print(format_table(stat, [("case", "case", ""), ("rod", "rod", ""), ("couples", "couples", ""),
                                  ("segments", "N", "d"), ("timestep_ms", "dt ms", "g"), ("success", "ok", ""),
                                  ("tip_error_L", "tip err / L", ".2e"), ("twist_error_deg", "twist err deg", "+.4f"),
                                  ("edge_strain", "edge strain", ".1e"), ("steps", "steps", "d"),
                                  ("wall_s", "wall s", ".2f"), ("baseline_wall_s", "3D model s", ".3f")]), "\n",
              flush=True)
    if "f" in args.only:
        freq = frequencies(QUICK["frequency"] if quick else FREQ_GRID, ("weak",) if quick else C.MODES,
                           periods=2.0 if quick else 4.0)
        print("frequencies: free vibration against the beam formulas (no field: the couples do not enter)")
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
    if "n" in args.only:
        paths = couple_paths(QUICK["paths"] if quick else PATH_CASES, path_seconds)
        print(f"native couples: the crawl by couple path, {path_seconds:g} s, beside the planar chain at the same "
              "numerics; speed-up and differences against the first strip row of each case")
        print(format_table(paths, [("robot", "robot", ""), ("segments", "N", "d"), ("timestep_ms", "dt ms", "g"),
                                   ("rod", "rod", ""), ("couples", "couples", ""), ("ok", "ok", ""),
                                   ("cpu_per_s", "cpu/sim s", ".2f"), ("wall_per_s", "wall/sim s", ".2f"),
                                   ("speedup", "speed-up (cpu)", ".2f"), ("speed_mm_s", "mm/s", "+.4f"),
                                   ("vs_chain", "vs chain", "+.1%"), ("diff_1s_L", "max diff 1 s / L", ".1e"),
                                   ("diff_end_L", "max diff / L", ".1e"), ("penetration_h", "pen. h", ".3f"),
                                   ("roll_deg", "roll deg", ".2f"), ("edge_strain", "edge strain", ".1e")]), "\n",
              flush=True)
    if "v" in args.only:
        n, dt = QUICK["variants"] if quick else (40, 1e-4)
        variants = floor_variants(path_seconds, n, dt)
        print(f"floor contact variants: paper-5c, {path_seconds:g} s, N = {n}, dt = {dt * 1e3:g} ms, against the "
              "element contact")
        print(format_table(variants, [("variant", "floor", ""), ("ok", "ok", ""), ("cpu_per_s", "cpu/sim s", ".2f"),
                                      ("cost", "cost", ".2f"), ("speed_mm_s", "mm/s", "+.4f"),
                                      ("vs_element", "vs element", "+.1%"), ("penetration_h", "pen. h", ".3f"),
                                      ("roll_deg", "roll deg", ".1f")]), "\n", flush=True)
        poles = pole_inputs(n, dt, steps=200 if quick else 2000)
        print("pole inputs: MuJoCo's cost per step of the axial-5a strip (CPU, best of 3)")
        print(format_table(poles, [("poles", "poles", ""), ("actuators", "actuators", "d"),
                                   ("us_per_step", "us/step", ".0f"), ("cost", "cost", ".3f")]), "\n", flush=True)
    kn = knees(stat, freq, crw)
    if kn:
        print("knee (least work N / dt within tolerance: statics 0.5 % L plane / 1.5 % L buckled, frequencies 0.5 %, "
              "crawl 5 % of the chain) and the defaults")
        print(format_table(kn, [("section", "section", ""), ("couples", "couples", ""), ("what", "", ""),
                                ("segments", "N", "d"), ("timestep_ms", "dt ms", "g"),
                                ("worst_error", "worst error", ".2e"), ("wall_s", "wall s (crawl: per sim s)", ".2f")]))
    if args.json:
        write_json(args.json, {"statics": stat, "frequencies": freq, "crawl": crw, "paths": paths,
                               "variants": variants, "poles": poles, "knee": kn, "crawl_seconds": seconds,
                               "path_seconds": path_seconds})
        print(f"wrote {args.json}")
    print(f"total {time.perf_counter() - t_start:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark of the MuJoCo rod: error beside time, against named baselines in the same process.

Sections (run all, or pick with ``--only``):

* ``static``: tip error / L against segments for the uniform cantilever without gravity
  (baseline: the elastica closed form, ``magsoft_env.sim.reference``) and for the paper's
  Fig. 3 paths (baseline: ``magsoft_env.solve_path``), with wall times of both.
* ``timestep``: largest stable timestep per integrator and segment count (a 0.3 s step
  response of a gravity-loaded cantilever to 13 mT; stable = no SimulationError).
* ``speed``: microseconds per step, raw ``mj_step`` (baseline) against ``Simulator.step``
  (magnetics included), clamped and on a floor, contact on and off, real-time factor.
* ``dynamics``: a 20-segment crawler on a floor driven by an oscillating B_z: dynamic error
  (largest centerline RMS distance / L over the run, and centre-of-mass travel) against a
  fine-step reference, with real-time factor; also the torque-hold shortcut.

Usage: ``python -m magsoft_env.bench.sim_bench [--quick] [--only static speed ...]``.
Timings depend on the machine and its load: compare numbers from one run only.
"""

from __future__ import annotations

import argparse
import math
import time

import mujoco
import numpy as np

from magsoft_env import Beam, Field, PiecewiseConstant, ramp
from magsoft_env.sim import RodOptions, SimulationError, Simulator, Sine, mujoco_path
from magsoft_env.sim.reference import elastica_dead_load

W, H = 5e-3, 1.13e-3


def _best_us_per_step(fn, n: int, repeats: int = 5) -> float:
    best = math.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn(n)
        best = min(best, (time.perf_counter() - t0) / n * 1e6)
    return best


def static(quick: bool) -> None:
    print("\n## static: tip error / L vs segments")
    beam = Beam(length=25e-3, width=W, thickness=H)
    EI, AM = float(beam.bending_stiffness(0.0)), float(beam.moment_per_length(0.0))
    segs = (10, 20, 40) if quick else (10, 20, 40, 80)
    print("uniform cantilever, no gravity, field along +z; baseline: elastica closed form")
    print(f"{'B (mT)':>7} {'Lambda':>7} {'N':>4} {'err/L %':>9} {'MuJoCo s':>9} {'closed form s':>14}")
    for B in (5e-3, 13e-3):
        t0 = time.perf_counter()
        ref = elastica_dead_load(beam.length, EI, AM * B, math.pi / 2)
        t_ref = time.perf_counter() - t0
        for n in segs:
            t0 = time.perf_counter()
            eq = mujoco_path(beam, [(0.0, B)], gravity=0.0, segments=n)[-1]
            t_sim = time.perf_counter() - t0
            err = math.hypot(eq.x[-1] - ref["x"], eq.z[-1] - ref["z"]) / beam.length
            lam = AM * B * beam.length**2 / EI
            print(f"{B * 1e3:>7.1f} {lam:>7.1f} {n:>4} {100 * err:>9.4f} {t_sim:>9.3f} {t_ref:>14.4f}")
    from magsoft_env import solve_path

    print("\nFig. 3 paths (gravity first; a: B_z 0 -> 13 mT; b: B_z 13 mT, B_x 0 -> -22 mT), max over the path")
    print("baseline: magsoft_env.solve_path (rotated coupling, inextensible)")
    print(f"{'L mm':>5} {'path':>4} {'grading':>7} {'N':>4} {'max err/L %':>12} {'MuJoCo s':>9} {'theory s':>9}")
    lengths = (25e-3,) if quick else (20e-3, 25e-3, 30e-3)
    for L in lengths:
        b = Beam(length=L, width=W, thickness=H)
        paths = {
            "a": ramp((0.0, 0.0), (0.0, 13e-3), 14),
            "b": [Field(0.0, 13e-3), *ramp((0.0, 13e-3), (-22e-3, 13e-3), 12, include_start=False)],
        }
        for name, path in paths.items():
            t0 = time.perf_counter()
            th = solve_path(b, path)
            t_th = time.perf_counter() - t0
            for grading in (1.0, 3.0):
                for n in (10, 20, 40):
                    t0 = time.perf_counter()
                    sim = mujoco_path(b, path, segments=n, grading=grading)
                    t_sim = time.perf_counter() - t0
                    err = max(math.hypot(s.x[-1] - t.x[-1], s.z[-1] - t.z[-1]) for s, t in zip(sim, th, strict=True))
                    print(f"{L * 1e3:>5.0f} {name:>4} {grading:>7.1f} {n:>4} {100 * err / L:>12.3f} "
                          f"{t_sim:>9.3f} {t_th:>9.3f}")


_DT_LADDER = (2e-2, 1e-2, 5e-3, 2e-3, 1e-3, 5e-4, 2e-4, 1e-4, 5e-5, 2e-5, 1e-5)


def _stable(beam, integrator, n, dt, duration=0.3) -> bool:
    sim = Simulator(beam, RodOptions(segments=n, integrator=integrator, timestep=dt), field=(0.0, 13e-3))
    try:
        sim.step(int(round(duration / dt)))
    except SimulationError:
        return False
    x, z = sim.centerline()
    return bool(np.all(np.isfinite(x)) and np.all(np.isfinite(z)))


def timestep(quick: bool) -> None:
    print("\n## timestep: largest stable step (s) from the ladder", ", ".join(f"{d:g}" for d in _DT_LADDER))
    print("test: 25 mm beam, gravity, a 13 mT step in B_z at t = 0, 0.3 s, retardation time 5 ms; "
          "stable = no SimulationError")
    beam = Beam(length=25e-3, width=W, thickness=H)
    segs = (10, 20, 40) if quick else (10, 20, 40, 80)
    print(f"{'integrator':>13} " + " ".join(f"{'N=' + str(n):>9}" for n in segs))
    for integ in ("discrete", "implicitfast", "euler", "rk4"):
        cells = []
        for n in segs:
            found = None
            for dt in _DT_LADDER:
                if _stable(beam, integ, n, dt):
                    found = dt
                    break
            cells.append(f"{found:>9g}" if found else f"{'<1e-5':>9}")
        print(f"{integ:>13} " + " ".join(cells))


def speed(quick: bool) -> None:
    print("\n## speed: us per step (best of 5); baseline raw mj_step on the same model and state")
    beam = Beam(length=25e-3, width=W, thickness=H, volume_fraction=PiecewiseConstant([0.1, 0.2]))
    n = 500 if quick else 2000
    print(f"{'scene':>11} {'N':>3} {'integrator':>12} {'dt s':>7} {'mj_step':>8} {'Simulator':>10} "
          f"{'RTF (sim)':>10} {'ncon':>5}")
    # floor cases: the crawler lying on the floor at zero field (contact everywhere)
    cases = [("cantilever", 20, "discrete", 1e-3), ("cantilever", 20, "euler", 1e-4),
             ("cantilever", 40, "discrete", 1e-3), ("floor", 20, "discrete", 1e-4),
             ("floor", 20, "discrete", 5e-4), ("floor", 20, "discrete", 1e-3), ("floor", 20, "implicitfast", 1e-4)]
    for scene, nseg, integ, dt in cases:
        field = (0.0, 2e-3) if scene == "cantilever" else (0.0, 0.0)
        sim = Simulator(beam, RodOptions(scene=scene, segments=nseg, integrator=integ, timestep=dt), field=field)
        try:
            sim.step(200)
            full = _best_us_per_step(sim.step, n)
            sim.reset()
            sim.step(200)
            raw = _best_us_per_step(lambda k, s=sim: [mujoco.mj_step(s.model, s.data) for _ in range(k)], n)
            sim._check(energy=True)  # the raw loop is unchecked: make sure it timed a sane state
        except SimulationError as err:
            print(f"{scene:>11} {nseg:>3} {integ:>12} {dt:>7g} unstable: {err.quantity} at step {err.step}")
            continue
        print(f"{scene:>11} {nseg:>3} {integ:>12} {dt:>7g} {raw:>8.1f} {full:>10.1f} {dt * 1e6 / full:>10.1f} "
              f"{sim.ncon:>5}")
    # contact on/off on the same floor model
    sim = Simulator(beam, RodOptions(scene="floor", timestep=5e-4))
    sim.step(200)
    on = _best_us_per_step(lambda k: [mujoco.mj_step(sim.model, sim.data) for _ in range(k)], n)
    ncon = sim.data.ncon
    sim.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
    off = _best_us_per_step(lambda k: [mujoco.mj_step(sim.model, sim.data) for _ in range(k)], n)
    print(f"floor N=20 discrete 5e-4, lying at zero field: mj_step contact on {on:.1f} us "
          f"({ncon} contacts), contact off {off:.1f} us")


def _crawl(beam, dt, duration, integrator="discrete", torque_every=1):
    wf = Sine((0.0, 2e-3), 2.0)
    sim = Simulator(beam, RodOptions(scene="floor", timestep=dt, integrator=integrator), torque_every=torque_every)
    every = max(1, int(round(0.01 / dt)))
    t0 = time.perf_counter()
    tr = sim.run(wf, duration, record_every=every)
    return tr, time.perf_counter() - t0


def dynamics(quick: bool) -> None:
    print("\n## dynamics: crawler on a floor (L = 25 mm, phi 10 %/20 % halves, N = 20, B_z = 2 mT sin(2 pi 2 t))")
    beam = Beam(length=25e-3, width=W, thickness=H, volume_fraction=PiecewiseConstant([0.1, 0.2]))
    duration = 0.5 if quick else 2.0
    ref_dt = 5e-5 if quick else 2e-5
    ref, t_ref = _crawl(beam, ref_dt, duration)
    print(f"reference: discrete, dt = {ref_dt:g} s ({t_ref:.1f} s wall); "
          "error = max over time of the centerline RMS distance / L; com = centre-of-mass x travel")
    com_ref = (ref.x[-1].mean() - ref.x[0].mean()) * 1e3
    print(f"{'integrator':>12} {'dt s':>7} {'hold':>4} {'err/L %':>8} {'com mm':>7} {'ref com mm':>10} "
          f"{'us/step':>8} {'RTF':>6}")
    cases = [("discrete", 1e-3, 1), ("discrete", 5e-4, 1), ("discrete", 2e-4, 1), ("discrete", 1e-4, 1),
             ("discrete", 1e-4, 5), ("implicitfast", 1e-4, 1)]
    for integ, dt, hold in cases:
        try:
            tr, wall = _crawl(beam, dt, duration, integ, hold)
        except SimulationError as err:
            print(f"{integ:>12} {dt:>7g} {hold:>4} unstable: {err.quantity} at step {err.step}")
            continue
        m = min(len(tr.time), len(ref.time))  # both record every 10 ms
        err = np.sqrt(((tr.x[:m] - ref.x[:m]) ** 2 + (tr.z[:m] - ref.z[:m]) ** 2).mean(axis=1)).max() / beam.length
        com = (tr.x[-1].mean() - tr.x[0].mean()) * 1e3
        us = wall / (duration / dt) * 1e6
        print(f"{integ:>12} {dt:>7g} {hold:>4} {100 * err:>8.2f} {com:>7.3f} {com_ref:>10.3f} {us:>8.1f} "
              f"{duration / wall:>6.1f}")


SECTIONS = {"static": static, "timestep": timestep, "speed": speed, "dynamics": dynamics}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer cases, shorter runs")
    p.add_argument("--only", nargs="+", choices=sorted(SECTIONS), default=list(SECTIONS))
    args = p.parse_args(argv)
    print(f"mujoco {mujoco.__version__}")
    for name in args.only:
        SECTIONS[name](args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark of the MuJoCo rod: error beside time, against named baselines in the same process.

Sections (run all, or pick with ``--only``):

* ``targets``: the timing targets (clamped ``mj_step`` <= 10 us, floor ``mj_step`` <= 30 us, end to end >= 25x
  real time), every timed case once in each of ``--rounds``
  interleaved rounds (best, median, and in how many rounds each target and all of them
  together were met): raw ``mj_step`` of the clamped rod; for two 20-segment crawlers at the
  default floor settings, ``mj_step`` alone (a C replay of the same trajectory) and end to end
  (microseconds per step, real-time factor), beside the dynamic error against a fine-step
  reference of the same contact model and against the stiff material-contact model.

* ``static``: tip error / L against segments for the uniform cantilever without gravity
  (baseline: the elastica closed form, ``magsoft_env.sim.reference``) and for the paper's
  Fig. 3 paths (baseline: ``magsoft_env.solve_path``), with wall times of both.
* ``timestep``: largest stable timestep per integrator and segment count (a 0.3 s step
  response of a gravity-loaded cantilever to 13 mT; stable = no SimulationError).
* ``sweep``: segments x timestep x integrator on the clamped rod (a field switched on at
  t = 0): static error of the settled state against the elastica closed form, dynamic error
  against the same segment count at a 10 us step, microseconds per step, real-time factor;
  then segments x timestep for a crawler on the floor (crawl and shape against the same N at
  25 us), and its fine-step crawl against N for both contact models.
* ``speed``: microseconds per step, raw ``mj_step`` (baseline) against ``Simulator.step``
  (magnetics included), clamped and on a floor, explicit contact pairs against the broad
  phase, contact on and off, real-time factor.
* ``floor``: a 20-segment crawler on a floor driven by an oscillating B_z: timestep x settings
  -> crawl distance, its error and the shape error against a fine-step reference of the
  same contact model (the default 2 ms one, or the stiff material one), penetration,
  microseconds per step and real-time factor.
* ``contact``: crawl distance against the contact time constant (how much the answer
  depends on the contact model rather than on the numerics).
* ``convergence``: whether any contact setting (time constant, damping ratio, noslip,
  impratio, refsafe, near-rigid) makes the 1 ms floor step converge: crawl at 1 and 0.5 ms
  against the same setting at 25 us, for both crawlers.
* ``reference``: whether the fine-step reference is right: the default crawl by the
  ``discrete`` integrator at 50 / 25 / 12.5 us against a second integrator (``euler``, whose
  springs and contact rows are explicit) at 10 / 5 / 2.5 us and its Richardson extrapolation.
* ``symmetry``: numerical left/right bias, from a mirror-symmetric robot driven both ways.
* ``peer``: PyElastica (if installed) on the same magnetic cantilever: time to the same
  static error (``magsoft_env.bench.sim_peer``).

Usage: ``python -m magsoft_env.bench.sim_bench [--quick] [--only static speed ...] [--rounds N]``.
Timings depend on the machine and its load: compare numbers from one run only.
"""

from __future__ import annotations

import argparse
import math
import time

import mujoco
import numpy as np

from magsoft_env import Beam, Field, PiecewiseConstant, ramp
from magsoft_env.sim import RodOptions, SimulationError, Simulator, Sine, as_waveform, mujoco_path
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
    print(f"{'B (mT)':>7} {'Lambda':>7} {'grading':>7} {'N':>4} {'err/L %':>9} {'MuJoCo s':>9} {'closed form s':>14}")
    for B in (5e-3, 13e-3):
        t0 = time.perf_counter()
        ref = elastica_dead_load(beam.length, EI, AM * B, math.pi / 2)
        t_ref = time.perf_counter() - t0
        for grading in (1.0, None):
            for n in segs:
                t0 = time.perf_counter()
                eq = mujoco_path(beam, [(0.0, B)], gravity=0.0, segments=n, grading=grading)[-1]
                t_sim = time.perf_counter() - t0
                err = math.hypot(eq.x[-1] - ref["x"], eq.z[-1] - ref["z"]) / beam.length
                lam = AM * B * beam.length**2 / EI
                g = "1.5 (d)" if grading is None else f"{grading:.1f}"
                print(f"{B * 1e3:>7.1f} {lam:>7.1f} {g:>7} {n:>4} {100 * err:>9.4f} {t_sim:>9.3f} {t_ref:>14.4f}")
    from magsoft_env import solve_path

    print("\nFig. 3 paths (gravity first; a: B_z 0 -> 13 mT; b: B_z 13 mT, B_x 0 -> -22 mT), max over the path; "
          "grading 1.5 (d) = the cantilever default")
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
            for grading in (1.0, None, 3.0):
                for n in (10, 20, 40):
                    t0 = time.perf_counter()
                    sim = mujoco_path(b, path, segments=n, grading=grading)
                    t_sim = time.perf_counter() - t0
                    err = max(math.hypot(s.x[-1] - t.x[-1], s.z[-1] - t.z[-1]) for s, t in zip(sim, th, strict=True))
                    g = "1.5 (d)" if grading is None else f"{grading:.1f}"
                    print(f"{L * 1e3:>5.0f} {name:>4} {g:>7} {n:>4} {100 * err / L:>12.3f} "
                          f"{t_sim:>9.3f} {t_th:>9.3f}")
    from magsoft_env.cases import load_preset
    from magsoft_env.compare.crosscheck import crosscheck_preset

    print("\nFig. 4b-d jig beams (presets), max tip error / L over the path, N = 20; baseline solve_path (rotated)")
    print(f"{'preset':>17} {'grading':>7} {'max err/L %':>12} {'MuJoCo s':>9} {'theory s':>9}")
    for name in ("fig4b_quadratic", "fig4c_sinusoidal", "fig4d_piecewise"):
        preset = load_preset(name)
        theory = None
        for grading in (1.0, None, 3.0):
            rows, th, _ = crosscheck_preset(preset, (20,), grading=grading, theory_results=theory)
            theory = th
            g = "1.5 (d)" if grading is None else f"{grading:.1f}"
            print(f"{name:>17} {g:>7} {100 * rows[0].max_tip_error:>12.3f} {rows[0].sim_seconds:>9.3f} "
                  f"{rows[0].theory_seconds:>9.3f}")


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


_CRAWLER = dict(length=25e-3, width=W, thickness=H)
#: the floor defaults of version 0.2: the material's contact time constant at a 0.1 ms step
MATERIAL = dict(contact_timeconst="material", timestep=1e-4)


def _step_response(beam, n, integrator, dt, B, duration, sample=2e-3):
    """A clamped rod from rest under a field switched on at t = 0: tip (x, z) every ``sample``
    s, CPU us per step of ``Simulator.step``, the simulator (or the SimulationError)."""
    options = RodOptions(segments=n, integrator=integrator, timestep=dt, gravity=0.0)
    sim = Simulator(beam, options, field=(0.0, B))
    every = max(1, int(round(sample / dt)))
    tips = [sim.tip_position()]
    try:
        for _ in range(int(round(duration / sample))):
            sim.step(every)
            tips.append(sim.tip_position())
    except SimulationError as err:
        return None, math.nan, err
    timed = Simulator(beam, options, field=(0.0, B))  # the same run in one call, timed
    nsteps = every * int(round(duration / sample))
    us = math.inf
    for _ in range(3):
        timed.reset()
        t0 = time.process_time()
        timed.step(nsteps)
        us = min(us, (time.process_time() - t0) / nsteps * 1e6)
    return np.array(tips), us, sim


def sweep(quick: bool) -> None:
    print("\n## sweep: segments x timestep x integrator, clamped rod (static error, dynamic error, cost)")
    beam = Beam(length=25e-3, width=W, thickness=H)
    B, duration = 5e-3, 0.2
    EI, AM = float(beam.bending_stiffness(0.0)), float(beam.moment_per_length(0.0))
    exact = elastica_dead_load(beam.length, EI, AM * B, math.pi / 2)
    segs = (10, 20) if quick else (10, 20, 40)
    dts = (1e-3, 2e-4) if quick else (2e-3, 1e-3, 5e-4, 2e-4, 1e-4)
    integrators = ("discrete", "euler") if quick else ("discrete", "implicitfast", "euler", "rk4")
    fine = 1e-5
    print(f"25 mm uniform beam, no gravity, default cells (graded 1.5), B_z = {B * 1e3:g} mT switched on at t = 0 "
          f"on the straight beam at rest, {duration:g} s")
    print("static = tip error / L of the settled state (Simulator.settle, tol 1e-8 rad, same integrator and step) "
          "against the elastica closed form; dynamic = max over the run of the tip distance / L from the same N "
          f"under the discrete integrator at {fine * 1e6:g} us (tip every 2 ms); us/step = CPU time of "
          "Simulator.step over the whole run in one call, best of 3 (magnetics and checks); RTF = dt / (us/step)")
    refs = {}
    for n in segs:
        tips, _, _ = _step_response(beam, n, "discrete", fine, B, duration)
        alt, _, _ = _step_response(beam, n, "euler", fine, B, duration)
        refs[n] = tips
        gap = float(np.max(np.hypot(*(alt - tips).T))) / beam.length
        print(f"reference check, N = {n}: euler at {fine * 1e6:g} us differs from it by {100 * gap:.4f} % of L at most")
    print(f"{'N':>4} {'integrator':>12} {'dt s':>8} {'static %L':>10} {'dynamic %L':>11} {'us/step':>8} {'RTF':>7}")
    for n in segs:
        for integ in integrators:
            for dt in dts:
                tips, us, sim = _step_response(beam, n, integ, dt, B, duration)
                if tips is None:
                    what = sim.quantity.split(" (")[0].removeprefix("MuJoCo warning: ")
                    print(f"{n:>4} {integ:>12} {dt:>8g} unstable at step {sim.step}: {what}")
                    continue
                dyn = float(np.max(np.hypot(*(tips - refs[n]).T))) / beam.length
                try:
                    res = sim.settle(tol=1e-8)
                    x, z = sim.tip_position()
                    st = f"{100 * math.hypot(x - exact['x'], z - exact['z']) / beam.length:>10.4f}"
                    st = st if res.success else f"{'no conv.':>10}"
                except SimulationError:
                    st = f"{'unstable':>10}"
                print(f"{n:>4} {integ:>12} {dt:>8g} {st} {100 * dyn:>11.4f} {us:>8.1f} {dt * 1e6 / us:>7.1f}")
    _sweep_floor(quick)


def _sweep_floor(quick: bool) -> None:
    duration = 0.5 if quick else 2.0
    segs = (10, 20) if quick else (10, 20, 40)
    dts = (1e-3, 1e-4) if quick else (1e-3, 5e-4, 2.5e-4, 1e-4)
    fine = 2.5e-5
    beam = _crawler()
    print(f"\nfloor: crawler A (25 mm, phi 10 %/20 % halves, B_z = 2 mT sin(2 pi 2 t)), default contact, discrete, "
          f"{duration:g} s; crawl = centre-of-mass x travel, d = its error and shape = max centerline RMS distance / L "
          f"against the same N at {fine * 1e6:g} us; us/step, RTF: CPU time of the run (one run)")
    print(f"{'N':>4} {'dt s':>8} {'crawl mm':>9} {'ref mm':>8} {'d %':>7} {'shape %L':>9} {'us/step':>8} {'RTF':>6}")
    soft = {}
    for n in segs:
        ref = _crawl(beam, duration, timestep=fine, segments=n)
        cr = soft[n] = 1e3 * _travel(ref)
        for dt in dts:
            run = _crawl(beam, duration, timestep=dt, segments=n)
            c = 1e3 * _travel(run)
            us = run[3] / int(round(duration / dt)) * 1e6
            print(f"{n:>4} {dt:>8g} {c:>9.3f} {cr:>8.3f} {100 * (c - cr) / cr:>+7.1f} "
                  f"{100 * _shape_error(run, ref, beam.length):>9.3f} {us:>8.1f} {dt * 1e6 / us:>6.1f}")
    print(f"fine-step crawl ({fine * 1e6:g} us) against N, both contact models: does the crawl converge in N?")
    print(f"{'N':>4} {'default mm':>11} {'material mm':>12}")
    for n in (*segs, *(() if quick else (80, 160))):
        if n not in soft:
            soft[n] = 1e3 * _travel(_crawl(beam, duration, timestep=fine, segments=n))
        stiff = 1e3 * _travel(_crawl(beam, duration, timestep=fine, segments=n, contact_timeconst="material"))
        print(f"{n:>4} {soft[n]:>11.4f} {stiff:>12.4f}")


def _crawler() -> Beam:
    return Beam(**_CRAWLER, volume_fraction=PiecewiseConstant([0.1, 0.2]))


def _crawlers():
    """The two 20-segment crawlers of the floor benchmarks: (name, beam, waveform)."""
    from magsoft_env.cases.gaits import gait_preset

    p5c = gait_preset("paper-5c")
    return [
        ("A: 10/20 % halves, B_z 2 mT 2 Hz", _crawler(), Sine((0.0, 2e-3), 2.0)),
        ("5c: cosine jig, paper-5c field", p5c.beam, as_waveform(p5c.wave)),
    ]


def _cpu_us_per_step(fn, n: int, repeats: int = 7) -> float:
    # CPU time of this process (not wall time): less sensitive to other jobs on a shared machine
    best = math.inf
    for _ in range(repeats):
        t0 = time.process_time()
        fn(n)
        best = min(best, (time.process_time() - t0) / n * 1e6)
    return best


def _state(sim) -> np.ndarray:
    st = np.empty(mujoco.mj_stateSize(sim.model, mujoco.mjtState.mjSTATE_INTEGRATION))
    mujoco.mj_getState(sim.model, sim.data, st, mujoco.mjtState.mjSTATE_INTEGRATION)
    return st


def _raw_and_full(sim, n: int) -> tuple[float, float]:
    """Best-of-7 CPU us per step: raw ``mj_step`` (C loop, couples held) from a copy of the
    state, and ``Simulator.step`` (magnetics and checks included), interleaved."""
    st = _state(sim)
    raw_data = mujoco.MjData(sim.model)
    raw, full = math.inf, math.inf
    for _ in range(7):
        mujoco.mj_setState(sim.model, raw_data, st, mujoco.mjtState.mjSTATE_INTEGRATION)
        raw = min(raw, _cpu_us_per_step(lambda k: mujoco.mj_step(sim.model, raw_data, nstep=k), n, repeats=1))
        full = min(full, _cpu_us_per_step(sim.step, n, repeats=1))
    return raw, full


def speed(quick: bool) -> None:
    print("\n## speed: us per step (CPU time, best of 7, interleaved); baseline raw mj_step on the same model "
          "and state")
    print("cantilever: 5 mT + gravity, moving (0.2 s after the field step); floor: crawler A after 0.3 s of its "
          "waveform (crawling state)")
    beam = _crawler()
    n = 300 if quick else 1000
    print(f"{'scene':>10} {'N':>3} {'settings':>34} {'dt s':>7} {'mj_step':>8} {'Simulator':>10} "
          f"{'RTF (sim)':>10} {'ncon':>5} {'nefc':>5}")
    cases = [("cantilever", 20, {}), ("cantilever", 20, dict(grading=1.0)), ("cantilever", 40, {}),
             ("floor", 20, {}), ("floor", 20, dict(contact_pairs=False)),
             ("floor", 20, dict(cone="pyramidal")), ("floor", 20, dict(contact_geom="capsule")),
             ("floor", 20, MATERIAL), ("floor", 20, dict(MATERIAL, contact_pairs=False)),
             ("channel", 20, dict(feature_x=20e-3)), ("channel", 20, dict(feature_x=20e-3, contact_pairs=False))]
    for scene, nseg, kw in cases:
        label = "0.2 defaults (material tc)" if kw.get("contact_timeconst") == "material" else "defaults"
        extra = ",".join(f"{k}={v}" for k, v in kw.items() if k not in MATERIAL and k != "feature_x")
        label = label + ("," + extra if extra else "")
        field = (0.0, 5e-3) if scene == "cantilever" else (0.0, 2e-3)
        sim = Simulator(beam, RodOptions(scene=scene, segments=nseg, **kw), field=field)
        dt = sim.timestep
        try:
            if scene == "cantilever":
                sim.step(int(round(0.2 / dt)))
            else:
                sim.run(Sine((0.0, 2e-3), 2.0), 0.3)
            raw, full = _raw_and_full(sim, n)
        except SimulationError as err:
            print(f"{scene:>10} {nseg:>3} {label:>34} {dt:>7g} unstable: {err.quantity} at step {err.step}")
            continue
        print(f"{scene:>10} {nseg:>3} {label:>34} {dt:>7g} {raw:>8.1f} {full:>10.1f} {dt * 1e6 / full:>10.1f} "
              f"{sim.data.ncon:>5} {sim.data.nefc:>5}")
    sim = Simulator(beam, RodOptions(scene="floor"))
    sim.step(200)  # lying flat at zero field: every collider touches
    raw, full = _raw_and_full(sim, n)
    print(f"{'floor flat':>10} {20:>3} {'defaults':>34} {sim.timestep:>7g} {raw:>8.1f} {full:>10.1f} "
          f"{sim.timestep * 1e6 / full:>10.1f} {sim.data.ncon:>5} {sim.data.nefc:>5}")
    sim = Simulator(beam, RodOptions(scene="floor"))
    sim.run(Sine((0.0, 2e-3), 2.0), 0.3)
    ncon = sim.data.ncon
    st = _state(sim)
    d = mujoco.MjData(sim.model)
    on = off = math.inf
    n = min(n, 200)  # without contact the rod falls through the floor: keep the runs short
    for _ in range(5):
        sim.model.opt.disableflags &= ~int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        mujoco.mj_setState(sim.model, d, st, mujoco.mjtState.mjSTATE_INTEGRATION)
        on = min(on, _cpu_us_per_step(lambda k: mujoco.mj_step(sim.model, d, nstep=k), n, repeats=1))
        sim.model.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONTACT
        mujoco.mj_setState(sim.model, d, st, mujoco.mjtState.mjSTATE_INTEGRATION)
        off = min(off, _cpu_us_per_step(lambda k: mujoco.mj_step(sim.model, d, nstep=k), n, repeats=1))
    print(f"floor defaults, crawling: mj_step contact on {on:.1f} us ({ncon} contacts), contact off {off:.1f} us")


def _crawl(beam, duration, *, waveform=None, mj_opt=None, **options):
    """Crawl under ``waveform`` (default B_z = 2 mT sin(2 pi 2 t)): trajectory (every 10 ms),
    CPU s, max penetration (m). ``mj_opt``: MuJoCo ``opt`` fields set on the built model (settings
    ``RodOptions`` does not expose, e.g. ``impratio``)."""
    sim = Simulator(beam, RodOptions(scene="floor", **options))
    for key, value in (mj_opt or {}).items():
        setattr(sim.model.opt, key, value)
    dt = sim.timestep
    every = max(1, int(round(0.01 / dt)))
    sim.set_waveform(Sine((0.0, 2e-3), 2.0) if waveform is None else waveform)
    ts, xs, zs, pen = [], [], [], 0.0
    cpu = 0.0
    nsteps = int(round(duration / dt))
    done = 0
    while True:
        x, z = sim.centerline()  # also brings the contacts up to date
        d = sim.data
        if d.ncon:
            pen = max(pen, float(-d.contact.dist[: d.ncon].min()))
        ts.append(sim.time)
        xs.append(x)
        zs.append(z)
        if done >= nsteps:
            break
        k = min(every, nsteps - done)
        t0 = time.process_time()
        sim.step(k)
        cpu += time.process_time() - t0
        done += k
    return np.array(ts), np.array(xs), np.array(zs), cpu, pen


def _shape_error(run, ref, length) -> float:
    (_, x, z, _, _), (_, xr, zr, _, _) = run, ref
    m = min(len(x), len(xr))  # both sampled every 10 ms
    return float(np.sqrt(((x[:m] - xr[:m]) ** 2 + (z[:m] - zr[:m]) ** 2).mean(axis=1)).max() / length)


def _travel(run) -> float:
    x = run[1]
    return float(x[-1].mean() - x[0].mean())


class _CrawlTimer:
    """Per-step CPU cost along one default crawl, one sample per :meth:`round`:

    * ``Simulator.step`` over the whole crawl (one call: rollout blocks with every check);
    * ``mj_step`` alone along the same trajectory: the field's per-step inputs replayed by ``mujoco.rollout``
      (a C loop, no Python per step) from the same initial state."""

    def __init__(self, beam, waveform, duration, **options):
        from magsoft_env.sim.model import native_controls

        self.waveform = waveform
        self.sim = Simulator(beam, RodOptions(scene="floor", **options))
        m, d = self.sim.model, self.sim.data
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        self.x0 = np.empty(mujoco.mj_stateSize(m, spec))
        mujoco.mj_getState(m, d, self.x0, spec)
        self.w0 = d.qacc_warmstart.copy()
        self.n = n = int(round(duration / self.sim.timestep))
        self.controls = native_controls(self.sim.rod, waveform.sample(self.sim.timestep * np.arange(n)))
        self.model = m
        self.scratch = mujoco.MjData(m)
        self.replay_diff = math.nan

    def round(self) -> tuple[float, float]:
        """One sample: (Simulator.step us, replayed mj_step us)."""
        from mujoco import rollout as mjrollout

        from magsoft_env.sim.model import NATIVE_CONTROL_SPEC

        sim = self.sim
        sim.reset()
        sim.set_waveform(self.waveform)
        t0 = time.process_time()
        sim.step(self.n)
        e2e = (time.process_time() - t0) / self.n * 1e6
        t0 = time.process_time()
        state, _ = mjrollout.rollout(self.model, self.scratch, self.x0[None], self.controls[None],
                                     control_spec=NATIVE_CONTROL_SPEC, initial_warmstart=self.w0[None])
        raw = (time.process_time() - t0) / self.n * 1e6
        nq = self.model.nq  # FULLPHYSICS rows: time, qpos, ...
        self.replay_diff = float(np.abs(state[0, -1, 1 : 1 + nq] - sim.data.qpos).max())
        return e2e, raw


class _ClampedTimer:
    """Raw ``mj_step`` of the clamped 20-segment rod (defaults, 5 mT + gravity, moving) and
    ``Simulator.step``, each sample ``n`` steps from the same state."""

    def __init__(self, n: int = 1000):
        self.sim = Simulator(_crawler(), RodOptions(segments=20), field=(0.0, 5e-3))
        self.sim.step(200)
        self.st = _state(self.sim)
        self.raw_data = mujoco.MjData(self.sim.model)
        self.n = n

    def round(self) -> tuple[float, float]:
        sim, n, st = self.sim, self.n, self.st
        mujoco.mj_setState(sim.model, self.raw_data, st, mujoco.mjtState.mjSTATE_INTEGRATION)
        self.raw_data.ctrl[:], self.raw_data.mocap_quat[:] = sim.data.ctrl, sim.data.mocap_quat
        t0 = time.process_time()
        mujoco.mj_step(sim.model, self.raw_data, nstep=n)
        raw = (time.process_time() - t0) / n * 1e6
        mujoco.mj_setState(sim.model, sim.data, st, mujoco.mjtState.mjSTATE_INTEGRATION)
        t0 = time.process_time()
        sim.step(n)
        return raw, (time.process_time() - t0) / n * 1e6


#: timing targets: clamped mj_step (us), floor mj_step (us), end to end (x real time)
TARGET_CLAMPED_US, TARGET_FLOOR_US, TARGET_RTF = 10.0, 30.0, 25.0


def _met(values, ok) -> str:
    return f"{sum(map(ok, values))}/{len(values)}"


def targets(quick: bool, rounds: int | None = None) -> None:
    print("\n## targets")
    duration = 0.5 if quick else 2.0
    rounds = (5 if quick else 30) if rounds is None else rounds
    crawlers = _crawlers()
    clamped = _ClampedTimer()
    timers = [_CrawlTimer(beam, wf, duration) for _, beam, wf in crawlers]
    # the half step, within 5 % of the fine reference (convergence section): how fast can it be?
    halves = [_CrawlTimer(beam, wf, duration, timestep=5e-4) for _, beam, wf in crawlers]
    c_raw, c_full = [], []
    e2e = [[] for _ in timers]
    raw = [[] for _ in timers]
    h_e2e, h_raw = [[] for _ in halves], [[] for _ in halves]
    for _ in range(rounds):  # every timed case in every round: the machine's speed drifts within a run
        r, f = clamped.round()
        c_raw.append(r)
        c_full.append(f)
        for i, t in enumerate(timers):
            e, w = t.round()
            raw[i].append(w)
            e2e[i].append(e)
        for i, t in enumerate(halves):
            e, w = t.round()
            h_raw[i].append(w)
            h_e2e[i].append(e)
    all_met = [
        c_raw[k] <= TARGET_CLAMPED_US
        and all(raw[i][k] <= TARGET_FLOOR_US and 1e3 / e2e[i][k] >= TARGET_RTF for i in range(len(timers)))
        for k in range(rounds)
    ]
    print(f"timings: CPU time of this process, {rounds} rounds, every timed case below once in each round "
          "(interleaved); best and median over the rounds; 'met' = rounds in which the case meets its target "
          f"(clamped mj_step <= {TARGET_CLAMPED_US:g} us, floor mj_step <= {TARGET_FLOOR_US:g} us, end to end "
          f">= {TARGET_RTF:g}x real time)")
    print(f"clamped 20 segments (cantilever defaults: 1 ms, grading 1.5), {clamped.n} steps from the same moving "
          f"state: mj_step best {min(c_raw):.1f} us, median {float(np.median(c_raw)):.1f} us, met "
          f"{_met(c_raw, lambda v: v <= TARGET_CLAMPED_US)}; Simulator.step best {min(c_full):.1f} us "
          f"({1e3 / min(c_full):.0f}x real time), median {float(np.median(c_full)):.1f} us")
    print(f"all timing targets met in the same round (clamped, and both crawlers' mj_step and end to end): "
          f"{sum(all_met)}/{rounds} rounds")
    print("\nend to end at the default floor settings (N = 20, dt 1 ms, contact tc 2 ms, discrete, "
          "native magnetics), one core")
    print(f"each crawler for {duration:g} s. us/step = CPU time of Simulator.step over the whole run "
          "(magnetics, checks); mj_step = the same trajectory replayed by mujoco.rollout with the field's "
          "per-step inputs (C loop; |dq| = its distance from the run); best (median); "
          "RTF = dt / best us/step; 'dt 0.5 ms': the same at half the default step (mj_step: the real-time "
          "factor of mj_step alone, a bound for any per-step work)")
    print("crawl = centre-of-mass x travel; d = its error vs the reference; shape = max over time of the centerline "
          "RMS distance / L vs the fine reference; pen = largest penetration (sampled every 10 ms)")
    print("fine ref: the same contact model (tc 2 ms) at dt = 50 us. stiff ref: the material contact "
          "(tc = h sqrt(rho / E)) at dt = 25 us, the 0.2 default model")
    print(f"{'crawler':>34} {'mj_step':>13} {'met':>6} {'|dq|':>7} {'us/step':>13} {'RTF':>5} {'met':>6} "
          f"{'crawl mm':>9} {'fine mm':>8} {'d fine %':>8} {'shape %L':>8} {'pen um':>7} {'stiff mm':>8} "
          f"{'d stiff %':>9} {'pen stiff':>9}")

    def best_med(v) -> str:
        return f"{min(v):.1f} ({float(np.median(v)):.1f})"

    for (name, beam, wf), t, rw, e, th, hr, he in zip(crawlers, timers, raw, e2e, halves, h_raw, h_e2e,
                                                       strict=True):
        us = e
        run = _crawl(beam, duration, waveform=wf)
        fine = _crawl(beam, duration, waveform=wf, timestep=5e-5)
        stiff = _crawl(beam, duration, waveform=wf, timestep=2.5e-5, contact_timeconst="material")
        c, cf, cs = (1e3 * _travel(r) for r in (run, fine, stiff))
        print(f"{name:>34} {best_med(rw):>13} {_met(rw, lambda v: v <= TARGET_FLOOR_US):>6} "
              f"{t.replay_diff:>7.0e} {best_med(us):>13} {1e3 / min(us):>5.1f} "
              f"{_met(us, lambda v: 1e3 / v >= TARGET_RTF):>6} {c:>9.3f} {cf:>8.3f} "
              f"{100 * (c - cf) / cf:>+8.1f} {100 * _shape_error(run, fine, beam.length):>8.2f} "
              f"{run[4] * 1e6:>7.1f} {cs:>8.3f} {100 * (c - cs) / cs:>+9.1f} {stiff[4] * 1e6:>7.1f}um")
        rh = _crawl(beam, duration, waveform=wf, timestep=5e-4)
        ch = 1e3 * _travel(rh)
        print(f"{'  dt 0.5 ms (mj_step: ' + format(5e2 / min(hr), '.1f') + 'x)':>34} {best_med(hr):>13} "
              f"{'':>6} {th.replay_diff:>7.0e} {best_med(he):>13} {5e2 / min(he):>5.1f} "
              f"{_met(he, lambda v: 5e2 / v >= TARGET_RTF):>6} {ch:>9.3f} {cf:>8.3f} {100 * (ch - cf) / cf:>+8.1f} "
              f"{100 * _shape_error(rh, fine, beam.length):>8.2f} {rh[4] * 1e6:>7.1f}")


def floor(quick: bool) -> None:
    print("\n## floor: crawler A (L = 25 mm, phi 10 %/20 % halves, N = 20) on a floor, B_z = 2 mT sin(2 pi 2 t)")
    beam = _crawler()
    duration = 0.5 if quick else 2.0
    refs = {}
    for model, kw, ref_dt in (("default contact (tc 2 ms)", {}, 2.5e-5 if quick else 1.25e-5),
                              ("material contact", dict(contact_timeconst="material"), 2.5e-5 if quick else 1.25e-5)):
        refs[model] = _crawl(beam, duration, timestep=ref_dt, **kw)
        print(f"reference, {model}: dt = {ref_dt:g} s, crawl {1e3 * _travel(refs[model]):.3f} mm in {duration:g} s, "
              f"max penetration {refs[model][4] * 1e6:.1f} um")
    print("crawl = centre-of-mass x travel; d crawl = its error vs the reference of the same contact model; "
          "shape err = max over time of the centerline RMS distance / L vs that reference; us/step and RTF end to end "
          "(Simulator.step, magnetics and checks included, CPU time of one run)")
    print(f"{'settings':>34} {'dt s':>7} {'crawl mm':>9} {'d crawl %':>9} {'shape err/L %':>13} {'pen um':>7} "
          f"{'us/step':>8} {'RTF':>6}")
    D, M = "default contact (tc 2 ms)", "material contact"
    cases = [("defaults", D, {}, dt) for dt in (5e-5, 1e-4, 2.5e-4, 5e-4, 1e-3, 2e-3)]
    cases += [
        ("implicitfast integrator", D, dict(integrator="implicitfast"), 1e-3),
        ("pyramidal cones", D, dict(cone="pyramidal"), 1e-3),
        ("capsules", D, dict(contact_geom="capsule"), 1e-3),
        ("base on the first piece", D, dict(base="first"), 1e-3),
        ("contact tc 1 ms", None, dict(contact_timeconst=1e-3), 1e-3),
    ]
    cases += [("material contact", M, dict(contact_timeconst="material"), dt) for dt in (2.5e-5, 1e-4, 5e-4, 1e-3)]
    for label, ref_name, kw, dt in cases:
        try:
            run = _crawl(beam, duration, timestep=dt, **kw)
        except SimulationError as err:
            print(f"{label:>34} {dt:>7g} unstable: {err.quantity} at step {err.step}")
            continue
        com = 1e3 * _travel(run)
        us = run[3] / (duration / dt) * 1e6
        if ref_name is None:
            err_c, err_s = "", ""
        else:
            ref = refs[ref_name]
            com_ref = 1e3 * _travel(ref)
            err_c = f"{100 * (com - com_ref) / com_ref:+.1f}"
            err_s = f"{100 * _shape_error(run, ref, beam.length):.2f}"
        print(f"{label:>34} {dt:>7g} {com:>9.3f} {err_c:>9} {err_s:>13} {run[4] * 1e6:>7.1f} {us:>8.1f} "
              f"{dt * 1e6 / us:>6.1f}")


def contact(quick: bool) -> None:
    print("\n## contact: crawl distance against the contact time constant (the contact model), each at a "
          "timestep that resolves it (dt = min(0.1 ms, tc / 2))")
    duration = 0.5 if quick else 2.0
    print(f"{'crawler':>34} {'tc ms':>7} {'dt s':>8} {'crawl mm':>9} {'max pen um':>10}")
    from magsoft_env.sim.model import material_contact_timeconst

    for name, beam, wf in _crawlers():
        tcm = material_contact_timeconst(beam)
        for tc in (5e-5, tcm, 5e-4, 1e-3, 2e-3):
            dt = min(1e-4, tc / 2)
            run = _crawl(beam, duration, waveform=wf, timestep=dt, contact_timeconst=tc)
            label = f"{tc * 1e3:.3f}" + ("m" if tc == tcm else "") + ("d" if tc == 2e-3 else "")
            print(f"{name:>34} {label:>7} {dt:>8.3g} {1e3 * _travel(run):>9.3f} {run[4] * 1e6:>10.1f}")
    print("m: the material's through-thickness time; d: the default")


def convergence(quick: bool) -> None:
    print("\n## convergence: can a contact setting make the 1 ms step converge? Each setting against its own "
          "fine-step reference (dt = 25 us, same setting)")
    duration = 0.5 if quick else 2.0
    settings = [
        ("defaults (tc 2 ms)", {}),
        ("tc 3 ms", dict(contact_timeconst=3e-3)),
        ("tc 2 ms, dampratio 2", dict(contact_dampratio=2.0)),
        ("tc 2 ms, dampratio 0.5", dict(contact_dampratio=0.5)),
        ("tc 2 ms, noslip 10 iterations", dict(noslip_iterations=10)),
        ("tc 2 ms, impratio 10", dict(mj_opt=dict(impratio=10.0))),
        ("tc 2 ms, impratio 10, noslip 10", dict(noslip_iterations=10, mj_opt=dict(impratio=10.0))),
        ("material tc (0.142 ms)", dict(contact_timeconst="material")),
        ("material tc, refsafe on", dict(contact_timeconst="material", contact_refsafe=True)),
        ("near-rigid tc 0.01 ms", dict(contact_timeconst=1e-5)),
        # diagnostics, not contact settings: the beam's own damping (a different beam)
        ("hinge retardation 20 ms (diag.)", dict(retardation_time=2e-2)),
        ("hinge retardation 1 ms (diag.)", dict(retardation_time=1e-3)),
    ]
    if quick:
        settings = settings[:2]
    print(f"crawl = centre-of-mass x travel in {duration:g} s; d = error against the same setting at 25 us; "
          "pen = largest penetration (um)")
    print(f"{'crawler':>4} {'setting':>32} {'ref mm':>8} {'pen':>5} {'1 ms mm':>8} {'d %':>7} {'pen':>5} "
          f"{'0.5 ms mm':>9} {'d %':>7} {'pen':>5}")
    for name, beam, wf in _crawlers():
        for label, kw in settings:
            ref = _crawl(beam, duration, waveform=wf, timestep=2.5e-5, **kw)
            cr = 1e3 * _travel(ref)
            cells = []
            for dt in (1e-3, 5e-4):
                run = _crawl(beam, duration, waveform=wf, timestep=dt, **kw)
                c = 1e3 * _travel(run)
                cells.append(f"{c:>8.3f} {100 * (c - cr) / cr:>+7.1f} {run[4] * 1e6:>5.0f}")
            print(f"{name[:3]:>4} {label:>32} {cr:>8.3f} {ref[4] * 1e6:>5.0f} {cells[0]} {cells[1]:>23}")


def reference(quick: bool) -> None:
    print("\n## reference: is the fine-step reference right? The same model (default contact, tc 2 ms) by a second "
          "integrator")
    duration = 0.2 if quick else 2.0
    print("discrete (implicit in position; contact rows folded into the step) at 50 / 25 / 12.5 us against Euler "
          "(semi-implicit: hinge springs and contact rows explicit, hinge damping implicit) at 10 / 5 / 2.5 us; "
          "Richardson = 2 x(h / 2) - x(h) for a first-order method, from Euler's two finest runs. crawl = centre-"
          f"of-mass x travel in {duration:g} s (mm); shape = max over time of the centerline RMS distance / L "
          "against the discrete 12.5 us run")
    print(f"{'crawler':>4} {'integrator':>10} {'dt us':>6} {'crawl mm':>9} {'shape %L':>9}")
    for name, beam, wf in _crawlers():
        ref = _crawl(beam, duration, waveform=wf, timestep=1.25e-5)
        rows = [("discrete", dt, _crawl(beam, duration, waveform=wf, timestep=dt)) for dt in (5e-5, 2.5e-5)]
        rows.append(("discrete", 1.25e-5, ref))
        rows += [("euler", dt, _crawl(beam, duration, waveform=wf, timestep=dt, integrator="euler"))
                 for dt in (1e-5, 5e-6, 2.5e-6)]
        for integ, dt, run in rows:
            print(f"{name[:3]:>4} {integ:>10} {dt * 1e6:>6.1f} {1e3 * _travel(run):>9.4f} "
                  f"{100 * _shape_error(run, ref, beam.length):>9.3f}")
        richardson = 2e3 * _travel(rows[-1][2]) - 1e3 * _travel(rows[-2][2])
        cr = 1e3 * _travel(ref)
        print(f"{name[:3]:>4} {'euler':>10} {'Rich.':>6} {richardson:>9.4f}   ({100 * (richardson - cr) / cr:+.1f} % "
              "from discrete 12.5 us)")


def symmetry(quick: bool) -> None:
    print("\n## symmetry: the cosine-jig beam (Fig. 5c, 23.9 mm) under B_z = +-2 mT sin(2 pi 2 t); turned end for end "
          "it is the same beam with B_z reversed, so the two travels must be opposite: their sum is numerical bias")
    from magsoft_env import jig_from_function

    jig = jig_from_function(lambda x: 3.0 * np.cos(2.0 * np.pi * x / 20.0), 0.0, 20.0, unit=1e-3)
    beam = Beam(length=jig.length, width=W, thickness=H, volume_fraction=0.2, magnetization=jig)
    duration = 1.0 if quick else 2.0
    print(f"{'colliders':>13} {'base':>7} {'+B_z mm':>8} {'-B_z mm':>8} {'sum mm':>8}")
    for geom, base in (("sphere", "middle"), ("capsule", "middle"), ("hinge_sphere", "middle"), ("sphere", "first")):
        travel = []
        for sign in (1.0, -1.0):
            sim = Simulator(beam, RodOptions(scene="floor", contact_geom=geom, base=base))
            x0 = sim.centerline()[0].mean()
            sim.run(Sine((0.0, sign * 2e-3), 2.0), duration, record_every=100)
            travel.append((sim.centerline()[0].mean() - x0) * 1e3)
        print(f"{geom:>13} {base:>7} {travel[0]:>8.3f} {travel[1]:>8.3f} {travel[0] + travel[1]:>+8.3f}")


def peer(quick: bool) -> None:
    from magsoft_env.bench import sim_peer

    sim_peer.main(quick)


SECTIONS = {
    "targets": targets,
    "static": static, "timestep": timestep, "sweep": sweep, "speed": speed, "floor": floor, "contact": contact,
    "convergence": convergence, "reference": reference, "symmetry": symmetry,
    "peer": peer,
}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="fewer cases, shorter runs")
    p.add_argument("--only", nargs="+", choices=sorted(SECTIONS), default=list(SECTIONS))
    p.add_argument("--rounds", type=int, default=None,
                   help="timing rounds of the targets section (default 30, 5 with --quick)")
    args = p.parse_args(argv)
    if args.rounds is not None and args.rounds < 1:
        p.error(f"--rounds must be a positive integer, got {args.rounds}")
    print(f"mujoco {mujoco.__version__}")
    for name in args.only:
        if name == "targets":
            targets(args.quick, rounds=args.rounds)
        else:
            SECTIONS[name](args.quick)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

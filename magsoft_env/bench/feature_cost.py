"""What each MuJoCo feature of the floor scenes costs, and what it changes (to skip what a scene does not
need, measured per feature).

    python -m magsoft_env.bench.feature_cost [--robot paper-5c] [--seconds 3] [--rounds 3] [--fidelity LEVEL]

A paper gait (the robot's drive at its own numerics, or ``--fidelity``) is played in C alone: the per-step field
of the drive as native controls, ``mujoco.rollout`` from the rest state, no Python between steps and none of the
simulator's checks, so the time is MuJoCo's own. Each variant changes one feature of the model the gaits and the
environments build (:func:`magsoft_env.sim.gait.gait_rod_options`); the variants and the pinned model take turns,
``--rounds`` times, and the median time per step is printed beside the ratio to the pinned model and the change
of the 3 s centre-of-mass displacement (0 where the feature does not change the physics):

* ``broad phase``: MuJoCo's broad phase over every geom instead of the explicit rod-floor (and rod-feature) pairs;
* ``islands on``: constraint island discovery (off in the rod: one kinematic tree is one island);
* ``contact sensor off``: the sensor the penetration check reads (changes nothing in the dynamics);
* ``pyramidal cone``, ``noslip 10``, ``solver 20 iterations``, ``solver tolerance 1e-6``, ``no warm start``,
  ``dense Jacobian``: solver settings.

Timings are wall clock on a shared machine: compare the ratios within one run.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time

import mujoco
import numpy as np
from mujoco import rollout

from magsoft_env.cases.gaits import gait_preset
from magsoft_env.sim.gait import gait_rod_options
from magsoft_env.sim.model import NATIVE_CONTROL_SPEC, native_controls
from magsoft_env.sim.simulator import Simulator
from magsoft_env.sim.waveforms import as_waveform

_D = mujoco.mjtDisableBit
#: name -> (RodOptions replacements, function changing the compiled model's options in place).
VARIANTS = {
    "as built (explicit pairs, islands off, elliptic, Newton, sparse)": ({}, None),
    "broad phase instead of explicit pairs": ({"contact_pairs": False}, None),
    "islands on": ({}, lambda m: setattr(m.opt, "disableflags", m.opt.disableflags & ~int(_D.mjDSBL_ISLAND))),
    "contact sensor off": ({}, lambda m: setattr(m.opt, "disableflags", m.opt.disableflags | int(_D.mjDSBL_SENSOR))),
    "pyramidal cone": ({}, lambda m: setattr(m.opt, "cone", mujoco.mjtCone.mjCONE_PYRAMIDAL)),
    "noslip 10": ({}, lambda m: setattr(m.opt, "noslip_iterations", 10)),
    "solver 20 iterations": ({}, lambda m: setattr(m.opt, "iterations", 20)),
    "solver tolerance 1e-6": ({}, lambda m: setattr(m.opt, "tolerance", 1e-6)),
    "no warm start": ({}, lambda m: setattr(m.opt, "disableflags", m.opt.disableflags | int(_D.mjDSBL_WARMSTART))),
    "dense Jacobian": ({}, lambda m: setattr(m.opt, "jacobian", mujoco.mjtJacobian.mjJAC_DENSE)),
}


def _model(robot, options, replacements, change):
    sim = Simulator(robot.beam, dataclasses.replace(options, **replacements))
    m = sim.model
    if change is not None:
        change(m)
    return sim, m


def feature_costs(robot_name: str = "paper-5c", *, seconds: float = 3.0, rounds: int = 3,
                  fidelity: str | None = None) -> list[dict]:
    """Median microseconds per step of every variant, its ratio to the pinned model, and the change of the
    displacement (mm) it makes, for the robot's drive over ``seconds``."""
    robot = gait_preset(robot_name)
    options = gait_rod_options(robot, fidelity=fidelity)
    nstep = int(round(seconds / options.timestep))
    built = {name: _model(robot, options, rep, ch) for name, (rep, ch) in VARIANTS.items()}
    t = (np.arange(nstep) + 0.5) * options.timestep  # each step's field at its middle
    fields = as_waveform(robot.wave).sample(t)
    times: dict = {name: [] for name in built}
    final: dict = {}
    runner = rollout.Rollout(nthread=0)
    try:
        for _ in range(rounds):
            for name, (sim, m) in built.items():
                d = mujoco.MjData(m)
                mujoco.mj_copyData(d, m, sim.data)
                spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
                x0 = np.empty((1, mujoco.mj_stateSize(m, spec)))
                mujoco.mj_getState(m, d, x0[0], spec)
                control = native_controls(sim.rod, fields)[None]
                state = np.empty((1, nstep, x0.shape[1]))
                t0 = time.perf_counter()
                runner.rollout(m, d, x0, control, control_spec=NATIVE_CONTROL_SPEC, nstep=nstep, state=state)
                times[name].append(time.perf_counter() - t0)
                mujoco.mj_setState(m, d, state[0, -1], spec)
                mujoco.mj_forward(m, d)
                final[name] = (d.qpos.copy(), bool(np.all(np.isfinite(state))))
    finally:
        runner.close()
    base = next(iter(built))
    rows = []
    for name, (sim, m) in built.items():
        qpos, finite = final[name]
        sim.data.qpos[:] = qpos
        mujoco.mj_forward(m, sim.data)
        x = float(sim.center_of_mass()[0])
        us = 1e6 * float(np.median(times[name])) / nstep
        rows.append({"variant": name, "us_per_step": us, "finite": finite, "x_mm": x * 1e3})
    b = rows[0]
    for r in rows:
        r["ratio"] = r["us_per_step"] / b["us_per_step"]
        r["displacement_change_mm"] = r["x_mm"] - b["x_mm"]
    return [{"robot": robot_name, "segments": options.segments, "timestep_ms": options.timestep * 1e3,
             "steps": nstep, "base": base, **r} for r in rows]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robot", default="paper-5c", help="a built-in robot or a robot file with a drive")
    p.add_argument("--seconds", type=float, default=3.0, help="simulated time (s, default 3)")
    p.add_argument("--rounds", type=int, default=3, help="turns of every variant (default 3)")
    p.add_argument("--fidelity", default=None, help="a named level instead of the robot's own numerics")
    a = p.parse_args(argv)
    if not (a.seconds > 0 and math.isfinite(a.seconds)) or a.rounds < 1:
        raise SystemExit("feature_cost: --seconds must be > 0 and --rounds >= 1")
    rows = feature_costs(a.robot, seconds=a.seconds, rounds=a.rounds, fidelity=a.fidelity)
    r0 = rows[0]
    print(f"{a.robot}: its drive for {a.seconds:g} s at N {r0['segments']}, {r0['timestep_ms']:g} ms, in C alone "
          f"(mujoco.rollout, {r0['steps']} steps, median of {a.rounds} rounds)\n")
    print("| variant | us per step | x the model as built | displacement change (mm) |")
    print("|---|---|---|---|")
    for r in rows:
        change = "non-finite state" if not r["finite"] else f"{r['displacement_change_mm']:+.4f}"
        print(f"| {r['variant']} | {r['us_per_step']:.1f} | {r['ratio']:.2f} | {change} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The simulator's native magnetic forces against plain MuJoCo: cost per step, blocks and rollouts, error beside time.

    python -m magsoft_env.bench.native_bench [--quick] [--rounds 7] [--steps 1000]

The scene is the cosine-jig crawler (``gait_preset("paper-5c")``) on its floor (``gait_rod_options``:
capsules, the beam's own contact), at 0.1 ms (the gaits' step) and 0.2 ms (the crawl env's), 20 and 40
segments, from one crawling state (0.05 s of its gait). Every case runs ``--steps`` steps from that
state, once per round, the cases interleaved; the tables give the median over the rounds (CPU time for
one thread, wall time for the threaded rows) and the largest state difference ``max |dq|`` (m, rad)
against the named baseline, run in the same process from the same state with the same fields:

* ``mj_step loop``: plain MuJoCo, one ``mj_step`` per step with the field's inputs (pole controls and the
  field frame's quaternion, :func:`~magsoft_env.sim.model.native_controls`) set from Python before each,
  no checks. The baseline of the per-step table.
* ``Simulator``: ``Simulator.step`` following the gait's waveform: ``mujoco.rollout`` blocks with per-step
  inputs, every health check. Baseline: ``mj_step loop`` (0 means bit-identical).
* ``mj_step 10``: ``mj_step(m, d, 10)`` with the inputs set between blocks (a field held 10 steps, a 1 or 2
  ms control step), no checks. The baseline of the held-field rows.
* ``Simulator 10``: ``set_field`` + ``step(10)``, every check. Baseline: ``mj_step 10``.
* ``xz actuators``: the alternative native formulation, two world-frame actuators per pole (controls
  B_x, B_z, no mocap frame), ``mj_step(m, d, 10)`` blocks: twice the actuators. Baseline: ``mj_step 10``.
* rollouts: ``mujoco.rollout.Rollout`` of 1, 2 and 8 robots (per-step native controls, no checks) on 2
  threads, and 8 robots on 1 thread. Aggregate robot-steps per second (wall), against ``mj_step loop``
  (one robot after the other); ``max |dq|`` against ``Simulator`` (the same inputs: 0 means bit-identical).

Timings depend on the machine and its load (other processes share the CPUs): compare numbers from one
run only.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import mujoco
import numpy as np
from mujoco import rollout as mjrollout

from magsoft_env.cases.gaits import gait_preset
from magsoft_env.sim import Simulator, as_waveform, build_spec
from magsoft_env.sim.gait import gait_rod_options
from magsoft_env.sim.model import NATIVE_CONTROL_SPEC, native_controls, rod_poles

_FP = mujoco.mjtState.mjSTATE_FULLPHYSICS


def _xz_model(beam, options) -> mujoco.MjModel:
    """The native rod with two actuators per pole (world-frame x and z, controls B_x and B_z)."""
    spec, disc = build_spec(beam, dataclasses.replace(options, magnetics="python"))
    spec.worldbody.add_site(name="xz_frame")
    piece, pos, charge = rod_poles(disc, options)
    for k, (i, (x, z), c) in enumerate(zip(piece, pos, charge, strict=True)):
        spec.body(f"piece{int(i)}").add_site(name=f"xz{k}", pos=[float(x), 0.0, float(z)])
        for comp in (0, 2):
            a = spec.add_actuator(name=f"xz{k}_{comp}", target=f"xz{k}", trntype=mujoco.mjtTrn.mjTRN_SITE,
                                  refsite="xz_frame")
            gear = [0.0] * 6
            gear[comp] = 1.0
            a.gear = gear
            a.gainprm[0] = float(c)
    return spec.compile()


class _Case:
    """One scene: the simulator, the start state and the fields of the timed window."""

    def __init__(self, dt: float, segments: int, steps: int):
        p = gait_preset("paper-5c")
        self.wave = as_waveform(p.wave)
        opts = gait_rod_options(p, segments=segments, timestep=dt)
        self.sim = Simulator(p.beam, opts)
        self.sim.set_waveform(self.wave)
        self.sim.step(int(round(0.05 / dt)))
        d = self.sim.data
        self.q, self.v, self.t, self.w = d.qpos.copy(), d.qvel.copy(), float(d.time), d.qacc_warmstart.copy()
        self.steps = steps
        self.fields = self.wave.sample(self.t + dt * np.arange(steps))
        self.x0 = self._state(self.sim.model)  # the start state of the native model (with its history)
        self.controls = native_controls(self.sim.rod, self.fields)
        self.xz = _xz_model(p.beam, opts)
        self.dxz, self.draw = mujoco.MjData(self.xz), mujoco.MjData(self.sim.model)
        self.poles = self.sim.model.nu

    def _state(self, model) -> np.ndarray:
        d = mujoco.MjData(model)
        self._load_data(d)
        x = np.empty(mujoco.mj_stateSize(model, _FP))
        mujoco.mj_getState(model, d, x, _FP)
        return x

    def _load_data(self, d) -> None:
        d.qpos[:], d.qvel[:], d.time, d.qacc_warmstart[:] = self.q, self.v, self.t, self.w

    def simulator(self) -> tuple[float, np.ndarray]:
        sim = self.sim
        self._load_data(sim.data)
        mujoco.mj_forward(sim.model, sim.data)
        sim.set_waveform(self.wave, start_time=0.0)
        t0 = time.process_time()
        sim.step(self.steps)
        return (time.process_time() - t0) / self.steps, sim.data.qpos.copy()

    def simulator_blocks(self) -> tuple[float, np.ndarray]:
        sim = self.sim
        self._load_data(sim.data)
        mujoco.mj_forward(sim.model, sim.data)
        fields = [tuple(float(v) for v in f) for f in self.fields[::10]]
        t0 = time.process_time()
        for f in fields:
            sim.set_field(f)
            sim.step(10)
        return (time.process_time() - t0) / self.steps, sim.data.qpos.copy()

    def raw(self, every: int) -> tuple[float, np.ndarray]:
        m, d = self.sim.model, self.draw
        mujoco.mj_setState(m, d, self.x0, _FP)
        d.qacc_warmstart[:] = self.w
        u = self.controls[::every]
        nu = m.nu
        mq = d.mocap_quat[self.sim.rod.field_mocap]
        t0 = time.process_time()
        for row in u:
            d.ctrl[:] = row[:nu]
            mq[:] = row[nu:]
            mujoco.mj_step(m, d, every)
        return (time.process_time() - t0) / self.steps, d.qpos.copy()

    def xz_blocks(self) -> tuple[float, np.ndarray]:
        m, d = self.xz, self.dxz
        mujoco.mj_resetData(m, d)
        self._load_data(d)
        fields = self.fields[::10]
        t0 = time.process_time()
        for bx, bz in fields:
            d.ctrl[0::2], d.ctrl[1::2] = bx, bz
            mujoco.mj_step(m, d, 10)
        return (time.process_time() - t0) / self.steps, d.qpos.copy()

    def rollout(self, pool, nrobot: int) -> tuple[float, np.ndarray]:
        m = self.sim.model
        datas = [mujoco.MjData(m) for _ in range(max(1, pool.nthread))]
        x0 = np.tile(self.x0, (nrobot, 1))
        u = np.ascontiguousarray(np.broadcast_to(self.controls, (nrobot, *self.controls.shape)))
        w0 = np.tile(self.w, (nrobot, 1))
        t0 = time.perf_counter()
        state, _ = pool.rollout(m, datas, x0, u, control_spec=NATIVE_CONTROL_SPEC, initial_warmstart=w0)
        wall = time.perf_counter() - t0
        return nrobot * self.steps / wall, state[:, -1, 1:1 + m.nq]


def _med(xs) -> float:
    return float(np.median(xs))


def run_case(dt: float, segments: int, steps: int, rounds: int) -> None:
    c = _Case(dt, segments, steps)
    us = {k: [] for k in ("mj_step loop", "Simulator", "mj_step 10", "Simulator 10", "xz actuators")}
    dq = {k: 0.0 for k in us}
    rate = {k: [] for k in ("rollout 1 robot, 2 threads", "rollout 2 robots, 2 threads",
                            "rollout 8 robots, 2 threads", "rollout 8 robots, 1 thread")}
    dq_roll = 0.0
    pools = {1: mjrollout.Rollout(nthread=1), 2: mjrollout.Rollout(nthread=2)}
    try:
        for _ in range(rounds):
            t, q_raw = c.raw(1)
            us["mj_step loop"].append(t)
            t, q_sim = c.simulator()
            us["Simulator"].append(t)
            dq["Simulator"] = max(dq["Simulator"], float(np.abs(q_sim - q_raw).max()))
            t, q_raw10 = c.raw(10)
            us["mj_step 10"].append(t)
            for name, fn in (("Simulator 10", c.simulator_blocks), ("xz actuators", c.xz_blocks)):
                t, q = fn()
                us[name].append(t)
                dq[name] = max(dq[name], float(np.abs(q - q_raw10).max()))
            for name, pool, nr in (("rollout 1 robot, 2 threads", 2, 1), ("rollout 2 robots, 2 threads", 2, 2),
                                   ("rollout 8 robots, 2 threads", 2, 8), ("rollout 8 robots, 1 thread", 1, 8)):
                r, q = c.rollout(pools[pool], nr)
                rate[name].append(r)
                dq_roll = max(dq_roll, float(np.abs(q - q_sim).max()))
    finally:
        for pool in pools.values():
            pool.close()
    base = _med(us["mj_step loop"])
    base10 = _med(us["mj_step 10"])
    print(f"\n### dt = {dt * 1e3:g} ms, N = {segments} ({c.poles} poles = native actuators, "
          f"{2 * c.poles} xz actuators), {steps} steps x {rounds} rounds")
    print(f"{'case':>40} {'us/step':>8} {'min':>7} {'vs baseline':>11} {'max |dq|':>9}  baseline")
    for name, ts in us.items():
        b, bname = (base, "mj_step loop") if name in ("mj_step loop", "Simulator") else (base10, "mj_step 10")
        err = "-" if name in ("mj_step loop", "mj_step 10") else f"{dq[name]:.1e}"
        print(f"{name:>40} {_med(ts) * 1e6:>8.1f} {min(ts) * 1e6:>7.1f} {_med(ts) / b:>10.2f}x {err:>9}  {bname}")
    print(f"{'case':>40} {'robot-steps/s':>13} {'vs loop':>10} {'max |dq|':>9}  (vs Simulator: same inputs)")
    print(f"{'mj_step loop (one robot after the other)':>40} {1.0 / base:>13.0f} {1.0:>9.2f}x {'-':>9}")
    for name, rs in rate.items():
        print(f"{name:>40} {_med(rs):>13.0f} {_med(rs) * base:>9.2f}x {dq_roll:>9.1e}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="one scene (0.2 ms, 20 segments), 2 rounds of 100 steps")
    p.add_argument("--rounds", type=int, default=7, help="interleaved rounds per scene (default 7)")
    p.add_argument("--steps", type=int, default=1000, help="steps per case and round, a multiple of 10 (default 1000)")
    args = p.parse_args(argv)
    if args.steps < 10 or args.steps % 10 or args.rounds < 1:
        raise SystemExit("--steps must be a positive multiple of 10 and --rounds >= 1")
    print("## the simulator's native magnetic forces against plain MuJoCo, paper-5c floor scene")
    scenes = [(2e-4, 20)] if args.quick else [(1e-4, 20), (2e-4, 20), (1e-4, 40), (2e-4, 40)]
    steps, rounds = (100, 2) if args.quick else (args.steps, args.rounds)
    for dt, n in scenes:
        run_case(dt, n, steps, rounds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

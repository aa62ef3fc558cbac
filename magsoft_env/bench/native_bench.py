"""Native magnetic forces against the Python couples: cost per step, blocks, batches and threads, error beside time.

    python -m magsoft_env.bench.native_bench [--quick] [--rounds 7] [--steps 1000]

The scene is the cosine-jig crawler (``gait_preset("paper-5c")``) on its floor (``gait_rod_options``:
capsules, the beam's own contact), at 0.1 ms (the gaits' step) and 0.2 ms (the crawl env's), 20 and 40
segments, from one crawling state (0.05 s of its gait). Every case runs ``--steps`` steps from that
state, once per round, the cases interleaved; the tables give the median over the rounds (CPU time for
one thread, wall time for the threaded rows) and the largest state difference ``max |dq|`` (m, rad)
against the named baseline, run in the same process from the same state with the same fields:

* ``python``: ``Simulator.step`` with ``RodOptions(magnetics="python")`` (the couples computed in
  Python each step), the field of the gait's waveform at every step. The baseline of the table.
* ``native``: the same with ``magnetics="native"`` (MuJoCo's pole forces; the field's inputs set per
  step by the simulator's per-step loop).
* ``python 10`` / ``native 10``: the field held over blocks of 10 steps (``set_field`` + ``step(10)``,
  a 1 or 2 ms control step): the native simulator runs each block inside MuJoCo. Baseline: ``python 10``.
* ``native mj_step 10``: ``mj_step(m, d, 10)`` on the native model with the inputs set between blocks,
  no simulator checks: what the simulator's bookkeeping costs on top. Baseline: ``python 10``.
* ``no magnetics``: ``mj_step`` of the Python model with the couples frozen at their first value (a
  different trajectory): MuJoCo alone, for scale.
* ``xz actuators``: the alternative native formulation, two world-frame actuators per pole (controls
  B_x, B_z, no mocap frame), ``mj_step(m, d, 10)`` blocks: twice the actuators. Baseline: ``python 10``.
* rollouts: ``mujoco.rollout.Rollout`` of 1, 2 and 8 robots (per-step native controls from
  :func:`~magsoft_env.sim.model.native_controls`, no checks) on 2 threads, and 8 robots on 1 thread;
  ``RodBatch`` of 8 robots on 2 threads, native and Python (checks included). Aggregate robot-steps
  per second (wall), against ``python`` (one robot after the other). Baseline of ``max |dq|``:
  ``native`` (the rollout applies the same inputs, so 0 means bit-identical).

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
from magsoft_env.sim import RodBatch, Simulator, as_waveform, build_spec
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
    """One scene: the simulators, the start state and the fields of the timed window."""

    def __init__(self, dt: float, segments: int, steps: int):
        p = gait_preset("paper-5c")
        self.wave = as_waveform(p.wave)
        opts = gait_rod_options(p, segments=segments, timestep=dt)
        self.py = Simulator(p.beam, dataclasses.replace(opts, magnetics="python"))
        self.nat = Simulator(p.beam, dataclasses.replace(opts, magnetics="native"))
        self.py.set_waveform(self.wave)
        self.py.step(int(round(0.05 / dt)))
        d = self.py.data
        self.q, self.v, self.t, self.w = d.qpos.copy(), d.qvel.copy(), float(d.time), d.qacc_warmstart.copy()
        self.steps = steps
        self.fields = self.wave.sample(self.t + dt * np.arange(steps))
        self.x0 = self._state(self.nat.model)  # the start state of the native model (with its history)
        self.controls = native_controls(self.nat.rod, self.fields)
        self.xz = _xz_model(p.beam, opts)
        self.dxz, self.draw = mujoco.MjData(self.xz), mujoco.MjData(self.py.model)
        self.dnat = mujoco.MjData(self.nat.model)
        self.poles = self.nat.model.nu

    def _state(self, model) -> np.ndarray:
        d = mujoco.MjData(model)
        self._load_data(d)
        x = np.empty(mujoco.mj_stateSize(model, _FP))
        mujoco.mj_getState(model, d, x, _FP)
        return x

    def _load_data(self, d) -> None:
        d.qpos[:], d.qvel[:], d.time, d.qacc_warmstart[:] = self.q, self.v, self.t, self.w

    def load(self, sim) -> None:
        self._load_data(sim.data)
        mujoco.mj_forward(sim.model, sim.data)

    def per_step(self, sim) -> tuple[float, np.ndarray]:
        self.load(sim)
        sim.set_waveform(self.wave, start_time=0.0)
        t0 = time.process_time()
        sim.step(self.steps)
        return (time.process_time() - t0) / self.steps, sim.data.qpos.copy()

    def blocks(self, sim) -> tuple[float, np.ndarray]:
        self.load(sim)
        fields = [tuple(float(v) for v in f) for f in self.fields[::10]]
        t0 = time.process_time()
        for f in fields:
            sim.set_field(f)
            sim.step(10)
        return (time.process_time() - t0) / self.steps, sim.data.qpos.copy()

    def raw_blocks(self) -> tuple[float, np.ndarray]:
        m, d = self.nat.model, self.dnat
        mujoco.mj_setState(m, d, self.x0, _FP)
        d.qacc_warmstart[:] = self.w
        u = self.controls[::10]
        nu = m.nu
        mq = d.mocap_quat[self.nat.rod.field_mocap]
        t0 = time.process_time()
        for row in u:
            d.ctrl[:] = row[:nu]
            mq[:] = row[nu:]
            mujoco.mj_step(m, d, 10)
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

    def no_magnetics(self) -> float:
        m, d = self.py.model, self.draw
        self.load(self.py)
        self.py._apply_torques()  # the couples of the start state, frozen
        self._load_data(d)
        d.qfrc_applied[:] = self.py.data.qfrc_applied
        t0 = time.process_time()
        mujoco.mj_step(m, d, self.steps)
        return (time.process_time() - t0) / self.steps

    def rollout(self, pool, nrobot: int) -> tuple[float, np.ndarray]:
        m = self.nat.model
        datas = [mujoco.MjData(m) for _ in range(max(1, pool.nthread))]
        x0 = np.tile(self.x0, (nrobot, 1))
        u = np.ascontiguousarray(np.broadcast_to(self.controls, (nrobot, *self.controls.shape)))
        w0 = np.tile(self.w, (nrobot, 1))
        t0 = time.perf_counter()
        state, _ = pool.rollout(m, datas, x0, u, control_spec=NATIVE_CONTROL_SPEC, initial_warmstart=w0)
        wall = time.perf_counter() - t0
        return nrobot * self.steps / wall, state[:, -1, 1:1 + m.nq]

    def batch(self, options_sim, nrobot: int, nthread: int) -> float:
        rb = RodBatch(options_sim.beam, options_sim.options, nsim=nrobot, nthread=nthread)
        rb.qpos[:], rb.qvel[:] = self.q, self.v
        rb.time = self.t
        rb.set_waveforms([self.wave] * nrobot)
        t0 = time.perf_counter()
        rb.step(self.steps)
        return nrobot * self.steps / (time.perf_counter() - t0)


def _med(xs) -> float:
    return float(np.median(xs))


def run_case(dt: float, segments: int, steps: int, rounds: int) -> None:
    c = _Case(dt, segments, steps)
    us = {k: [] for k in ("python", "native", "python 10", "native 10", "native mj_step 10", "xz actuators",
                          "no magnetics")}
    dq = {k: 0.0 for k in us}
    rate = {k: [] for k in ("rollout 1 robot, 2 threads", "rollout 2 robots, 2 threads",
                            "rollout 8 robots, 2 threads", "rollout 8 robots, 1 thread",
                            "RodBatch native 8 robots, 2 threads", "RodBatch python 8 robots, 2 threads")}
    dq_roll = 0.0
    pools = {1: mjrollout.Rollout(nthread=1), 2: mjrollout.Rollout(nthread=2)}
    try:
        for _ in range(rounds):
            t, q_py = c.per_step(c.py)
            us["python"].append(t)
            t, q_nat = c.per_step(c.nat)
            us["native"].append(t)
            dq["native"] = max(dq["native"], float(np.abs(q_nat - q_py).max()))
            t, q_py10 = c.blocks(c.py)
            us["python 10"].append(t)
            for name, fn in (("native 10", lambda: c.blocks(c.nat)), ("native mj_step 10", c.raw_blocks),
                             ("xz actuators", c.xz_blocks)):
                t, q = fn()
                us[name].append(t)
                dq[name] = max(dq[name], float(np.abs(q - q_py10).max()))
            us["no magnetics"].append(c.no_magnetics())
            for name, pool, nr in (("rollout 1 robot, 2 threads", 2, 1), ("rollout 2 robots, 2 threads", 2, 2),
                                   ("rollout 8 robots, 2 threads", 2, 8), ("rollout 8 robots, 1 thread", 1, 8)):
                r, q = c.rollout(pools[pool], nr)
                rate[name].append(r)
                dq_roll = max(dq_roll, float(np.abs(q - q_nat).max()))
            rate["RodBatch native 8 robots, 2 threads"].append(c.batch(c.nat, 8, 2))
            rate["RodBatch python 8 robots, 2 threads"].append(c.batch(c.py, 8, 2))
    finally:
        for pool in pools.values():
            pool.close()
    base = _med(us["python"])
    base10 = _med(us["python 10"])
    print(f"\n### dt = {dt * 1e3:g} ms, N = {segments} ({c.poles} poles = native actuators, "
          f"{2 * c.poles} xz actuators), {steps} steps x {rounds} rounds")
    print(f"{'case':>40} {'us/step':>8} {'min':>7} {'vs baseline':>11} {'max |dq|':>9}  baseline")
    for name, ts in us.items():
        b, bname = (base, "python") if name in ("python", "native") else (base10, "python 10")
        if name == "no magnetics":
            b, bname = base10, "python 10 (other trajectory)"
        err = "-" if name in ("python", "python 10", "no magnetics") else f"{dq[name]:.1e}"
        print(f"{name:>40} {_med(ts) * 1e6:>8.1f} {min(ts) * 1e6:>7.1f} {_med(ts) / b:>10.2f}x {err:>9}  {bname}")
    print(f"{'case':>40} {'robot-steps/s':>13} {'vs python':>10} {'max |dq|':>9}  (vs native: same inputs)")
    print(f"{'python (one robot after the other)':>40} {1.0 / base:>13.0f} {1.0:>9.2f}x {'-':>9}")
    for name, rs in rate.items():
        err = f"{dq_roll:.1e}" if name.startswith("rollout") else "-"
        print(f"{name:>40} {_med(rs):>13.0f} {_med(rs) * base:>9.2f}x {err:>9}")


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="one scene (0.2 ms, 20 segments), 2 rounds of 100 steps")
    p.add_argument("--rounds", type=int, default=7, help="interleaved rounds per scene (default 7)")
    p.add_argument("--steps", type=int, default=1000, help="steps per case and round, a multiple of 10 (default 1000)")
    args = p.parse_args(argv)
    if args.steps < 10 or args.steps % 10 or args.rounds < 1:
        raise SystemExit("--steps must be a positive multiple of 10 and --rounds >= 1")
    print("## native magnetic forces (MuJoCo's pole actuators) against the Python couples, paper-5c floor scene")
    scenes = [(2e-4, 20)] if args.quick else [(1e-4, 20), (2e-4, 20), (1e-4, 40), (2e-4, 40)]
    steps, rounds = (100, 2) if args.quick else (args.steps, args.rounds)
    for dt, n in scenes:
        run_case(dt, n, steps, rounds)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

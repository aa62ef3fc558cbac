"""Environment throughput: env steps/s (single, vectorized) and the env's overhead over the raw Simulator.

    python -m magsoft_env.bench.env_bench [--steps 200] [--segments 20]

Baselines, run in the same process on the same model and field sequence:

* ``Simulator``: ``sim.set_field(B); sim.step(n_substeps)`` per control step on the env's own
  Simulator, from the same reset state, same fields: the physics the env wraps without its
  observation, reward and bookkeeping (target: env overhead < 15 %). Best of 3 repeats.
* raw ``mj_step``: MuJoCo alone with the couples frozen (no magnetics in Python), for scale
  (not the same trajectory: the field is held at its first value).

Timings are wall-clock on a shared machine: read them as indicative.
"""

from __future__ import annotations

import argparse
import time

import numpy as np


def _actions(env, steps: int) -> np.ndarray:
    # the robot's open-loop gait: a realistic crawling state (contacts, moderate bending)
    base = env.unwrapped
    t = np.arange(steps) * base.n_substeps * base.sim_dt
    if not hasattr(base, "gait"):  # shape env (no gait): a slow field sweep
        return np.stack([0.3 * np.sin(2 * np.pi * 0.5 * t), 0.5 * np.cos(2 * np.pi * 0.5 * t)], 1).astype(np.float32)
    return np.array([base.open_loop_action(ti) for ti in t], dtype=np.float32)


def bench_single(env_id: str, steps: int, *, repeats: int = 3, **kwargs) -> dict:
    """Best-of-``repeats`` timings of the env and of the Simulator inside it, from the same
    reset state with the same field sequence (so the same trajectory and contacts)."""
    import gymnasium as gym
    import mujoco

    import magsoft_env  # noqa: F401

    env = gym.make(env_id, **kwargs)
    base = env.unwrapped
    sim = base.sim
    acts = _actions(env, steps)
    fields = acts.astype(float) * base.field_limit
    env.reset(seed=0)
    env.step(acts[0])  # warm up
    t_env, t_sim, t_raw = [], [], []
    for _ in range(repeats):
        env.reset(seed=0)
        t0 = time.perf_counter()
        for a in acts:
            env.step(a)
        t_env.append(time.perf_counter() - t0)

        env.reset(seed=0)
        t0 = time.perf_counter()
        for b in fields:
            sim.set_field((float(b[0]), float(b[1])))
            sim.step(base.n_substeps)
        t_sim.append(time.perf_counter() - t0)

        env.reset(seed=0)
        sim.set_field(tuple(fields[0]))
        sim.step(1)  # couples written once, then frozen: MuJoCo alone
        m, d = sim.model, sim.data
        n = steps * base.n_substeps
        t0 = time.perf_counter()
        for _ in range(n):
            mujoco.mj_step(m, d)
        t_raw.append(time.perf_counter() - t0)
    env.close()
    env_s, sim_s, raw_s = min(t_env), min(t_sim), min(t_raw)
    return {"env_id": env_id, "steps": steps, "substeps": base.n_substeps, "sim_dt": base.sim_dt,
            "env_steps_per_s": steps / env_s, "sim_steps_per_s": steps / sim_s, "raw_steps_per_s": steps / raw_s,
            "overhead_vs_simulator": env_s / sim_s - 1.0,
            "real_time_factor": steps * base.n_substeps * base.sim_dt / env_s}


def bench_vector(env_id: str, steps: int, mode: str, num_envs: int, **kwargs) -> float:
    import gymnasium as gym

    import magsoft_env  # noqa: F401

    envs = gym.make_vec(env_id, num_envs=num_envs, vectorization_mode=mode, **kwargs)
    envs.reset(seed=list(range(num_envs)))
    a = np.tile(np.array([[0.0, 0.05]], dtype=np.float32), (num_envs, 1))
    envs.step(a)
    t0 = time.perf_counter()
    for _ in range(steps):
        envs.step(a)
    dt = time.perf_counter() - t0
    envs.close()
    return steps * num_envs / dt


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, default=200, help="control steps per measurement (default 200)")
    p.add_argument("--segments", type=int, default=20)
    p.add_argument("--num-envs", type=int, default=2)
    args = p.parse_args(argv)
    if args.steps < 10:
        raise SystemExit("--steps must be >= 10")
    print("## single environment vs the Simulator it wraps (same model, same field sequence)")
    print(f"{'env':>24} {'N':>3} {'substeps':>8} {'dt ms':>6} {'env st/s':>9} {'Simulator st/s':>15} "
          f"{'raw mj_step st/s':>17} {'overhead':>9} {'RTF':>5}")
    for env_id in ("MagSoftCrawl-v1", "MagSoftShape-v0"):
        r = bench_single(env_id, args.steps, segments=args.segments)
        print(f"{env_id:>24} {args.segments:>3} {r['substeps']:>8} {r['sim_dt'] * 1e3:>6.2f} "
              f"{r['env_steps_per_s']:>9.1f} {r['sim_steps_per_s']:>15.1f} {r['raw_steps_per_s']:>17.1f} "
              f"{100 * r['overhead_vs_simulator']:>8.1f}% {r['real_time_factor']:>5.2f}")
    print(f"\n## vectorized MagSoftCrawl-v1, {args.num_envs} envs (total env steps/s)")
    for mode in ("sync", "async"):
        sps = bench_vector("MagSoftCrawl-v1", args.steps // 2, mode, args.num_envs, segments=args.segments)
        print(f"{mode:>6}: {sps:8.1f} env steps/s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Env steps per second against the number of worlds: the CPU batch and the MuJoCo Warp backend, with the error of
the Warp worlds against the C reference beside it.

    python -m magsoft_env.bench.warp_bench [--worlds 1,8,64,512,4096,8192] [--backends cpu,warp] [--device cuda:0]
                                           [--steps 10] [--budget 120] [--error-steps 25] [--json out.json]

Every row builds ``gym.make_vec("MagSoftCrawl-v1", num_envs=n[, backend="warp"])`` at the registered defaults
(paper-5c, 20 segments, 0.2 ms, 100 substeps per 20 ms env step), resets it with seed 0, takes one untimed step
(the Warp backend records its graph there; Warp's kernels are compiled before, at the first build) and then
times ``--steps`` env steps of random actions in [-0.5, 0.5]^2 (episodes that end restart as in training). A size
whose predicted time (the previous size's per-world cost times the worlds) exceeds ``--budget`` seconds is left
out and said so; a Warp size that does not fit the device's memory ends the scan of that backend.

The error column: the Warp worlds (the first ``--error-worlds``) and single C envs restarted from their start
states (``env.reset(options={"qpos": start_qpos[i]})``) step the paper's open-loop gait for ``--error-steps``
env steps side by side; it gives the largest difference of any piece angle (rad) and of the centre of mass's
x (mm) at the end. The paper-5c contact is stiff, so lift-off and touchdown amplify round-off: read it against
the 3e-4 rad that C gives itself when its start state moves by 1e-9 (docs/gpu.md).

The printed table is what docs/gpu.md carries; on a GPU machine run it unchanged (``--device cuda:0`` or
Warp's default device).
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import time

import gymnasium as gym
import numpy as np

import magsoft_env  # noqa: F401  (registers the ids)

ENV_ID = "MagSoftCrawl-v1"


def _ints(text: str) -> list[int]:
    out = [int(v) for v in text.split(",") if v.strip()]
    if not out or min(out) < 1:
        raise argparse.ArgumentTypeError(f"a comma-separated list of positive integers, got {text!r}")
    return out


def make(backend: str, n: int, device=None):
    """The batch of ``n`` robots on ``backend`` (``"cpu"`` or ``"warp"``)."""
    if backend == "warp":
        return gym.make_vec(ENV_ID, num_envs=n, backend="warp", device=device)
    return gym.make_vec(ENV_ID, num_envs=n)


def throughput(envs, steps: int, seed: int = 0) -> float:
    """Env steps per second (all worlds) over ``steps`` timed steps after one untimed one."""
    n = envs.num_envs
    rng = np.random.default_rng(seed)
    envs.reset(seed=seed)
    envs.step((0.5 * rng.uniform(-1, 1, (n, 2))).astype(np.float32))
    t0 = time.perf_counter()
    for _ in range(steps):
        envs.step((0.5 * rng.uniform(-1, 1, (n, 2))).astype(np.float32))
    return n * steps / (time.perf_counter() - t0)


def error_against_c(envs, worlds: int, steps: int) -> tuple[float, float]:
    """Largest piece-angle difference (rad) and centre-of-mass x difference (m) of the first ``worlds`` Warp
    worlds against C envs restarted from their start states, after ``steps`` env steps of the open-loop gait."""
    from ..envs.crawl import MagSoftCrawlEnv

    w = envs.unwrapped
    k = min(worlds, w.num_envs)
    wo, wi = w.reset(seed=1)
    refs = [MagSoftCrawlEnv() for _ in range(k)]
    last = []
    for i, env in enumerate(refs):
        env.reset(seed=1 + i)
        last.append(env.reset(options={"qpos": w.start_qpos[i]}))  # the world's start state, in C
    n1 = refs[0].segments + 1
    dt = refs[0].n_substeps * refs[0].sim_dt
    for j in range(steps):
        a = refs[0].open_loop_action(j * dt)
        wo, *_, wi = w.step(np.tile(a, (w.num_envs, 1)))
        last = [(obs, info) for obs, _, _, _, info in (env.step(a) for env in refs)]
    ang = max(float(np.abs(wo[i, :n1] - last[i][0][:n1]).max()) for i in range(k))
    dx = max(abs(float(wi["x_position"][i] - last[i][1]["x_position"])) for i in range(k))
    for env in refs:
        env.close()
    return ang, dx


def run(worlds, backends, *, device=None, steps=10, budget=120.0, error_steps=25, error_worlds=4) -> list[dict]:
    rows = []
    for backend in backends:
        per_world = None  # seconds per world of the last size (build + steps)
        for n in worlds:
            row = {"backend": backend, "worlds": n, "device": "cpu (C, threads)" if backend == "cpu" else None}
            if per_world is not None and per_world * n > budget:
                row["note"] = f"left out: predicted {per_world * n:.0f} s > budget {budget:g} s"
                rows.append(row)
                continue
            t0 = time.perf_counter()
            try:
                envs = make(backend, n, device)
            except (MemoryError, RuntimeError) as err:  # a GPU out of memory
                row["note"] = f"did not fit: {str(err).splitlines()[0][:80]}"
                rows.append(row)
                break
            if backend == "warp":
                row["device"] = envs.unwrapped.device
            row["steps_per_s"] = throughput(envs, steps)
            if backend == "warp" and error_steps > 0:
                row["angle_error_rad"], row["com_x_error_m"] = error_against_c(envs, error_worlds, error_steps)
            envs.close()
            per_world = (time.perf_counter() - t0) / n
            rows.append(row)
            print(_line(row), flush=True)
    return rows


def _line(row: dict) -> str:
    if "steps_per_s" not in row:
        return f"| {row['backend']} | {row['device'] or '-'} | {row['worlds']} | - | - | {row['note']} |"
    err = ("reference (C)" if row["backend"] == "cpu" else
           f"{row['angle_error_rad']:.1e} rad, {row['com_x_error_m'] * 1e3:.1e} mm"
           if "angle_error_rad" in row else "-")
    return f"| {row['backend']} | {row['device']} | {row['worlds']} | {row['steps_per_s']:.1f} | {err} | |"


def table(rows) -> str:
    head = ("| backend | device | worlds | env steps/s | error vs C (gait, max over worlds) | note |\n"
            "|---|---|---|---|---|---|")
    return "\n".join([head, *(_line(r) for r in rows)])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m magsoft_env.bench.warp_bench", description=__doc__.splitlines()[0])
    p.add_argument("--worlds", type=_ints, default=_ints("1,8,64,512,4096,8192"))
    p.add_argument("--backends", default="cpu,warp", help="comma-separated: cpu, warp")
    p.add_argument("--device", default=None, help="Warp device (cpu, cuda:0); default: Warp's own")
    p.add_argument("--steps", type=int, default=10, help="timed env steps per size")
    p.add_argument("--budget", type=float, default=120.0, help="seconds a size may take (predicted), else left out")
    p.add_argument("--error-steps", type=int, default=25, help="env steps of the gait for the error column (0: none)")
    p.add_argument("--error-worlds", type=int, default=4)
    p.add_argument("--json", default=None, help="also write the rows to this file")
    args = p.parse_args(argv)
    backends = [b.strip() for b in args.backends.split(",") if b.strip()]
    if not set(backends) <= {"cpu", "warp"}:
        p.error(f"--backends takes cpu and warp, got {args.backends!r}")
    if "warp" in backends:
        from ..sim.warp_extra import INSTALL_HINT, warp_available

        if not warp_available():
            p.error(f"the warp backend needs the optional extra 'warp': {INSTALL_HINT}")
    print(f"{ENV_ID} defaults (paper-5c, 20 segments, 0.2 ms, 100 substeps per env step); "
          f"{platform.machine()}, {platform.python_version()}", flush=True)
    rows = run(args.worlds, backends, device=args.device, steps=args.steps, budget=args.budget,
               error_steps=args.error_steps, error_worlds=args.error_worlds)
    print()
    print(table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([{k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in r.items()}
                       for r in rows], fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Steering evaluation: success rate and time to goal of controllers in ``MagSoftSteer-v0`` and
``MagSoftSteerWaveform-v0`` (with ``--sources`` also ``MagSoftCoils-v0``, ``MagSoftMagnet-v0`` and their waveform
ids), on the same goals.

Run: ``python -m magsoft_env.bench.steer_eval [--episodes 20] [--run RUN ...] [--sim-dt 2e-4] [--sources] [--json]``.

Controllers: the hand-designed baseline of each id (:func:`magsoft_env.envs.steer.steer_controller`, the field
turning at 1 Hz in the vertical plane through the goal), zero field and random actions (seeded), and every
trained run given with ``--run`` (a ``train/train.py`` run folder; its final model, with ``--best`` also its best
evaluated one, played in its own env id with its own env arguments, and again at ``--sim-dt`` when that
differs). Episode ``k`` of every controller
uses seed ``seed + k``: the same goals for all. Prints one row per controller and env: successes, mean and
median time to goal over the successes (s), mean final distance (mm), mean return, episodes that ended unstable
or unphysical, the deepest floor contact (mm), how the strip moved (the mean airborne fraction of the episodes'
substeps, the highest clearance (mm), and how many episodes crawled, hopped, rolled, tumbled or tumbled with
flights: ``info["locomotion"]``).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

IDS = ("MagSoftSteer-v0", "MagSoftSteerWaveform-v0")
#: ``--sources``: the steer task through a field source, each with its hand controller (``baseline_action``):
#: (id, env arguments, name)
SOURCE_CASES = (
    ("MagSoftCoils-v0", {}, "hand controller (navion)"),
    ("MagSoftCoils-v0", {"coils": "cardiomag"}, "hand controller (cardiomag)"),
    ("MagSoftMagnet-v0", {}, "hand controller (pull)"),
    ("MagSoftMagnet-v0", {"tilt": True}, "hand controller (tilt)"),
    ("MagSoftCoilsWaveform-v0", {}, "hand controller (wave)"),
    ("MagSoftMagnetWaveform-v0", {}, "hand controller (wave)"),
)


def run_controller(env_id: str, act, *, episodes: int, seed: int, env_kwargs: dict | None = None,
                   name: str = "") -> dict:
    """Play ``act(obs, env) -> action`` for ``episodes`` episodes (seeds ``seed .. seed + episodes - 1``)."""
    import gymnasium as gym

    env = gym.make(env_id, **(env_kwargs or {}))
    times, finals, returns, broken, depth, airborne, clearance, modes = [], [], [], 0, 0.0, [], 0.0, {}
    t0 = time.perf_counter()
    for k in range(int(episodes)):
        obs, info = env.reset(seed=seed + k)
        env.action_space.seed(seed + k)
        total, done = 0.0, False
        while not done:
            obs, r, term, trunc, info = env.step(act(obs, env))
            total += float(r)
            done = term or trunc
        if info.get("is_success"):
            times.append(float(info["time_to_goal"]))
        broken += int("truncation_reason" in info)
        finals.append(float(info["distance"]))
        returns.append(total)
        depth = max(depth, float(info["max_penetration"]))
        airborne.append(float(info["airborne_fraction"]))
        clearance = max(clearance, float(info["highest_clearance"]))
        modes[info["locomotion"]] = modes.get(info["locomotion"], 0) + 1
    env.close()
    return {"controller": name, "env_id": env_id, "sim_dt_ms": (env_kwargs or {}).get("sim_dt", 2e-4) * 1e3,
            "episodes": int(episodes), "successes": len(times),
            "time_to_goal_mean_s": float(np.mean(times)) if times else math.nan,
            "time_to_goal_median_s": float(np.median(times)) if times else math.nan,
            "final_distance_mean_mm": float(np.mean(finals)) * 1e3, "return_mean": float(np.mean(returns)),
            "unstable": broken, "max_penetration_mm": depth * 1e3, "airborne_fraction_mean": float(np.mean(airborne)),
            "highest_clearance_mm": clearance * 1e3, "locomotion": modes, "wall_s": time.perf_counter() - t0}


def _baseline(obs, env):
    return env.unwrapped.baseline_action(obs)


def _zero(obs, env):
    return np.zeros(env.action_space.shape, dtype=np.float32)


def _random(obs, env):
    return env.action_space.sample()


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument("--seed", type=int, default=1000)
    p.add_argument("--run", nargs="*", default=[], help="train/train.py run folders of the steering ids")
    p.add_argument("--sim-dt", type=float, default=2e-4, help="simulation step of the baselines (s; default 0.2 ms)")
    p.add_argument("--best", action="store_true", help="also each run's best evaluated model (best_model.zip)")
    p.add_argument("--no-baselines", action="store_true", help="only the runs")
    p.add_argument("--sources", action="store_true",
                   help="also the coil and magnet ids' hand controllers (slower: every physics step from Python)")
    p.add_argument("--json", action="store_true", help="print the rows as JSON")
    args = p.parse_args(argv)
    if args.episodes < 1:
        raise SystemExit(f"--episodes must be >= 1, got {args.episodes}.")
    if not 0 < args.sim_dt <= 1e-3:
        raise SystemExit(f"--sim-dt must lie in (0, 1e-3] s, got {args.sim_dt}.")
    import magsoft_env  # noqa: F401  (registers the ids)

    rows = []
    kw = {"sim_dt": args.sim_dt}
    if not args.no_baselines:
        for env_id in IDS:
            rows.append(run_controller(env_id, _baseline, episodes=args.episodes, seed=args.seed, env_kwargs=kw,
                                       name="hand controller"))
        rows.append(run_controller(IDS[0], _zero, episodes=args.episodes, seed=args.seed, env_kwargs=kw,
                                   name="zero field"))
        rows.append(run_controller(IDS[0], _random, episodes=args.episodes, seed=args.seed, env_kwargs=kw,
                                   name="random actions"))
        for env_id, extra, name in SOURCE_CASES if args.sources else ():
            rows.append(run_controller(env_id, _baseline, episodes=args.episodes, seed=args.seed,
                                       env_kwargs={**kw, **extra}, name=name))
    for run in args.run:
        from magsoft_env.rl import find_run, load_policy

        rec = find_run(run)
        trained = dict(rec.env_kwargs)
        for best in (False, True) if args.best else (False,):
            policy = load_policy(rec.model(best=best), env=rec.env_id)
            name = f"{rec.algo} {Path(run).name}{' best' if best else ''}"
            for kwargs in ([trained, {**trained, "sim_dt": args.sim_dt}]
                           if trained.get("sim_dt", 2e-4) != args.sim_dt else [trained]):
                rows.append(run_controller(rec.env_id, lambda obs, env, pol=policy: pol(obs), episodes=args.episodes,
                                           seed=args.seed, env_kwargs=kwargs, name=name))
    if args.json:
        print(json.dumps(rows, indent=1))
        return 0
    print(f"{'controller':28s} {'env':24s} {'dt ms':>5s} {'reached':>8s} {'t mean':>7s} {'t median':>8s} "
          f"{'final mm':>8s} {'return':>7s} {'unstable':>8s} {'depth mm':>8s} {'airborne':>8s} {'clear mm':>8s} "
          f"{'wall s':>7s}  locomotion")
    for r in rows:
        print(f"{r['controller'][:28]:28s} {r['env_id']:24s} {r['sim_dt_ms']:5.2f} "
              f"{r['successes']:>3d}/{r['episodes']:<4d} {r['time_to_goal_mean_s']:7.2f} "
              f"{r['time_to_goal_median_s']:8.2f} {r['final_distance_mean_mm']:8.1f} {r['return_mean']:7.1f} "
              f"{r['unstable']:8d} {r['max_penetration_mm']:8.3f} {r['airborne_fraction_mean']:8.3f} "
              f"{r['highest_clearance_mm']:8.2f} {r['wall_s']:7.1f}  "
              + ", ".join(f"{k} {v}" for k, v in sorted(r["locomotion"].items())))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

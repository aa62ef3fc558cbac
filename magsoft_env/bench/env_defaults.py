"""The acceptance check at the floor environments' defaults: is each paper gait's crawl, run through the
environment itself at its default numerics, within 5 % of a converged answer?

    python -m magsoft_env.bench.env_defaults [--robots paper-5a,paper-5b,paper-5c] [--fidelity LEVEL]
                                             [--seconds 3] [--json out.json]

For each robot, ``MagSoftCrawl-v1`` (the floor) is built with that robot and nothing else changed except what a
gait measurement needs: ``action_mode="waveform"`` with the robot's own drive as every action (one field period
per env step, the same sine :func:`~magsoft_env.sim.gait.run_gait` applies), no reset noise, and no crawl limit
(``crawl_mode="none"``, ``max_clearance=None``: the check measures the gait, not the task). Two criteria:

* **(a) displacement**: the centre-of-mass travel over ``--seconds`` (3 s) at the env's default numerics against
  the same env at 80 segments and a 4x finer step (same contact model, same drive);
* **(b) speed**: the mean speed over the whole periods after the first (0.5-3 s) against the converged reference
  at the material contact (:data:`REFERENCE_SPEED`, measured by :mod:`magsoft_env.bench.crawl_convergence`,
  docs/convergence.md, with its uncertainty).

Both must be within :data:`TOLERANCE` (5 %). Wall time per simulated second is printed beside each (one run on
the machine that runs it; a cost ratio). The 4x finer runs dominate: about 4 minutes in all on one core (paper-5b's
0.00625 ms run at 80 segments about 2 of them).
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from magsoft_env.io import write_json

#: The converged crawl speed (mm/s, along +x) of each paper gait at the material contact and its uncertainty
#: (mm/s): N = 160 / 80 at 0.025 ms and finer, Richardson-extrapolated where regular (docs/convergence.md,
#: section 1, "Reference"; ``python -m magsoft_env.bench.crawl_convergence --segments 10,20,40,80,160``).
REFERENCE_SPEED = {"paper-5a": (0.490, 0.004), "paper-5b": (-0.842, 0.012), "paper-5c": (-0.401, 0.004)}
#: The tolerance on both criteria (relative).
TOLERANCE = 0.05
ROBOTS = tuple(REFERENCE_SPEED)


def env_gait(robot: str, seconds: float, **env_kwargs) -> dict:
    """The robot's drive played through ``MagSoftCrawl-v1`` for ``seconds``; displacement (mm), speed over the whole
    periods after the first (mm/s), the numerics the env used, wall time, and whether the run stayed physical."""
    import gymnasium as gym

    import magsoft_env  # noqa: F401  (registers the environments)

    env = gym.make("MagSoftCrawl-v1", robot=robot, action_mode="waveform", reset_noise_scale=0.0,
                   crawl_mode="none", max_clearance=None, max_episode_steps=10**6, **env_kwargs)
    base = env.unwrapped
    env.reset(seed=0)
    wave = base.gait.wave
    action = base.action_of_waveparams(wave)
    period = 1.0 / wave.frequency
    periods = max(1, int(round(seconds / period)))
    xs = [float(base.com_position()[0])]
    ok, message = True, "ok"
    t0 = time.perf_counter()
    for _ in range(periods):
        _, _, terminated, truncated, info = env.step(action)
        xs.append(float(info["x_position"]))
        if terminated or truncated:
            ok, message = False, str(info.get("truncation_reason") or info.get("crawl_violation") or "ended")[:200]
            break
    wall = time.perf_counter() - t0
    env.close()
    x = np.asarray(xs) * 1e3
    done = (len(x) - 1) * period
    return {"robot": robot, "segments": base.segments, "timestep_ms": base.sim_dt * 1e3, "fidelity": base.fidelity,
            "seconds": done, "displacement_mm": float(x[-1] - x[0]),
            "speed_mm_s": float((x[-1] - x[1]) / (done - period)) if len(x) > 2 else math.nan,
            "wall_s": wall, "wall_per_sim_s": wall / max(done, 1e-12), "success": ok, "message": message}


def check(robot: str, seconds: float = 3.0, fidelity: str | None = None) -> dict:
    """Criteria (a) and (b) of one robot at the env's defaults (or at ``fidelity``)."""
    default = env_gait(robot, seconds, fidelity=fidelity)
    fine = env_gait(robot, seconds, segments=80, sim_dt=default["timestep_ms"] * 1e-3 / 4.0)
    ref, unc = REFERENCE_SPEED[robot]
    e_a = abs(default["displacement_mm"] - fine["displacement_mm"]) / abs(fine["displacement_mm"])
    e_b = abs(default["speed_mm_s"] - ref) / abs(ref)
    return {"robot": robot, "default": default, "fine": fine, "reference_speed_mm_s": ref,
            "reference_uncertainty_mm_s": unc, "error_displacement_vs_fine": e_a, "error_speed_vs_reference": e_b,
            "passes": bool(default["success"] and fine["success"] and e_a <= TOLERANCE and e_b <= TOLERANCE)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", default=",".join(ROBOTS), help=f"comma list of {list(ROBOTS)}")
    p.add_argument("--fidelity", default=None, help="a named level instead of each robot's own numerics")
    p.add_argument("--seconds", type=float, default=3.0, help="simulated time (s), whole field periods (default 3)")
    p.add_argument("--json", default=None, help="write the results here")
    a = p.parse_args(argv)
    robots = tuple(a.robots.split(","))
    for r in robots:
        if r not in REFERENCE_SPEED:
            raise SystemExit(f"env_defaults: --robots takes {list(ROBOTS)} (robots with a converged reference), "
                             f"got {r!r}.")
    if not (a.seconds >= 1.0 and math.isfinite(a.seconds)):
        raise SystemExit(f"env_defaults: --seconds must be >= 1 (one period to skip, then whole periods), got "
                         f"{a.seconds}.")
    print(f"MagSoftCrawl-v1 at {'its defaults' if a.fidelity is None else 'fidelity=' + a.fidelity}, each robot's "
          f"drive for {a.seconds:g} s; tolerance {100 * TOLERANCE:g} %", flush=True)
    rows = []
    print("\n| robot | numerics | displacement (mm) | N 80, dt / 4 (mm) | (a) error | speed (mm/s) | reference "
          "(mm/s) | (b) error | wall / sim s (default, fine) | passes |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in robots:
        c = check(r, a.seconds, a.fidelity)
        rows.append(c)
        d, f = c["default"], c["fine"]
        print(f"| {r} | N {d['segments']}, {d['timestep_ms']:g} ms | {d['displacement_mm']:+.3f} | "
              f"{f['displacement_mm']:+.3f} | {100 * c['error_displacement_vs_fine']:.1f} % | {d['speed_mm_s']:+.3f} | "
              f"{c['reference_speed_mm_s']:+.3f} +- {c['reference_uncertainty_mm_s']:.3f} | "
              f"{100 * c['error_speed_vs_reference']:.1f} % | {d['wall_per_sim_s']:.2f}, {f['wall_per_sim_s']:.2f} | "
              f"{'yes' if c['passes'] else 'NO'}{'' if d['success'] and f['success'] else ' (' + d['message'] + ')'} |",
              flush=True)
    if a.json:
        write_json(a.json, rows)
    return 0 if all(c["passes"] for c in rows) else 1


if __name__ == "__main__":
    sys.exit(main())

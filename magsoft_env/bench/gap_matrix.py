"""The sim-to-sim gap of the shipped crawl agents: each played on other rods, numerics, friction and modulus.

Every shipped agent of ``MagSoftCrawl-v1`` (trained on the planar chain, paper-5c, 20 links, 0.2 ms, friction 0.5)
is played deterministically on MagSoftBench's crawl seeds in variants of its env: the 3D strip (``rod="cable"``,
2 s episodes; it observes 68 numbers, the chain 48, so a chain agent does not run there: the row says so), a
half physics step (0.1 ms), floor friction 0.4 and 0.6, and the elastomer's modulus E0 15 % lower
and higher; one row per variant, one column per agent: the mean speed along +x (mm/s), and where it did not
crawl, what it did (the locomotion mode, or the steps before a crawl limit ended the episode)::

    python -m magsoft_env.bench.gap_matrix [--agents ppo_seed0,ppo_seed1] [--json out.json]

Same machine, same process, one torch thread. The planar-chain Warp backend plays the same model as the C chain
(docs/gpu.md), so it is not a separate column here.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time

ENV_ID = "MagSoftCrawl-v1"


def variants() -> list[tuple[str, dict, tuple, int]]:
    """``(label, env_kwargs, seeds, steps)`` of every variant, the training env first."""
    from ..cases.robots import load_robot

    robot = load_robot("paper-5c")
    mat = robot.beam.material

    def modulus(scale: float):
        beam = dataclasses.replace(robot.beam, material=dataclasses.replace(mat, E0=mat.E0 * scale))
        return robot.replace(beam=beam)

    seeds = (1000, 1001, 1002)
    return [
        ("as trained (planar chain, 0.2 ms, friction 0.5)", {}, seeds, 250),
        ("3D strip (rod='cable'), 2 s", {"rod": "cable"}, seeds[:2], 100),
        ("half step (0.1 ms)", {"sim_dt": 1e-4}, seeds, 250),
        ("friction 0.4", {"friction": 0.4}, seeds, 250),
        ("friction 0.6", {"friction": 0.6}, seeds, 250),
        ("E0 -15 %", {"robot": modulus(0.85)}, seeds, 250),
        ("E0 +15 %", {"robot": modulus(1.15)}, seeds, 250),
    ]


def run(agents=None, *, progress=print) -> list[dict]:
    from ..rl.agents import shipped_agents
    from .rl_bench import BenchTask, evaluate

    names = agents or shipped_agents().get(ENV_ID, [])
    rows = []
    for label, kwargs, seeds, steps in variants():
        task = BenchTask(label, ENV_ID, kwargs, seeds=seeds, steps=steps, gait=None)
        for name in names:
            t = time.perf_counter()
            try:
                row = evaluate(task, name)
            except ValueError as err:  # the agent does not fit the variant's spaces (the strip observes more)
                row = {"controller": name, "measure_mean": float("nan"), "steps_mean": 0.0,
                       "airborne_fraction": float("nan"), "locomotion": {}, "not_applicable": str(err)}
            row["variant"] = label
            rows.append(row)
            if progress and "not_applicable" in row:
                progress(f"{label:46s} {name:10s} not applicable: {row['not_applicable'][-90:]}")
            elif progress:
                progress(f"{label:46s} {name:10s} {row['measure_mean']:+.3f} mm/s  steps {row['steps_mean']:.0f}"
                         f"  airborne {row['airborne_fraction']:.3f}  {row['locomotion']}  "
                         f"{time.perf_counter() - t:.0f} s")
    return rows


def markdown(rows: list[dict]) -> str:
    names = list(dict.fromkeys(r["controller"] for r in rows))
    labels = list(dict.fromkeys(r["variant"] for r in rows))
    out = ["| variant | " + " | ".join(names) + " |", "|---|" + "---|" * len(names)]
    for label in labels:
        cells = []
        for name in names:
            r = next(x for x in rows if x["variant"] == label and x["controller"] == name)
            if "not_applicable" in r:
                cells.append("n/a (another observation space)")
                continue
            modes = ", ".join(f"{k} {v}" for k, v in r["locomotion"].items())
            ended = "" if r["steps_mean"] >= 0.999 * max(1, max(
                x["steps_mean"] for x in rows if x["variant"] == label)) else f", ended at {r['steps_mean']:.0f} steps"
            cells.append(f"{r['measure_mean']:+.2f} ({modes}{ended})")
        out.append(f"| {label} | " + " | ".join(cells) + " |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--agents", default=None, help="comma-separated agent names (default: every shipped one)")
    ap.add_argument("--json", default=None, help="also write the rows here")
    a = ap.parse_args(argv)
    from ..threads import single_threaded_blas

    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:  # the table needs the RL extra; load_agent says so
        pass
    with single_threaded_blas():
        rows = run(a.agents.split(",") if a.agents else None)
    print(markdown(rows))
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1, default=str)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

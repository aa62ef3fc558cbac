"""MagSoftBench: a named, versioned set of RL tasks on the magsoft environments, each with fixed evaluation seeds,
a success measure, reference controllers and the shipped trained agents (docs/bench.md).

    python -m magsoft_env.bench.rl_bench [--tasks crawl-planar,steer] [--controllers zero,ppo_seed0] [--json out.json]
    python -m magsoft_env.bench.rl_bench --check [--tasks ...] [--controllers ...]

The first prints the table (markdown): one row per task and controller, with the mean and spread (std over the
episodes) of the task's measure, the episode return, the airborne fraction (mean over the episodes of the fraction
of substeps with the whole robot off the floor), the locomotion modes of the episodes, the wall time of the
evaluation and its env steps per second. ``--check`` plays every deterministic controller (zero field, seeded random
actions, the open-loop paper gait or the hand controller) and every shipped agent on the task's seeds again and
compares with the stored table (:data:`TABLE_FILE`, next to the agents) within :data:`TOLERANCE`; it exits 1 on a
mismatch (wall time and steps per second are measured, not compared). ``--write`` stores the table.

Every controller is deterministic: episode ``k`` of a task resets with seed ``seeds[k]``, and the random
controller's action space is seeded with the same seed before the episode. The episodes are short (``steps``
control steps of each task; the envs' own episodes are longer), so that ``--check`` runs in a few minutes on 2
cores; what a number means is that of the capped episode.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

#: The benchmark's name and version: a change of any task, seed, cap or measure is a new version.
BENCH_NAME = "MagSoftBench"
BENCH_VERSION = "v1"
#: The stored table of this version (in the agents' folder of the assets).
TABLE_FILE = f"magsoftbench-{BENCH_VERSION}.json"
#: ``--check`` tolerance: a stored mean ``m`` and a replayed one ``r`` agree when ``|r - m| <= abs + rel * |m|``
#: (per number: the measure, the return, the airborne fraction). Replays on one machine and build repeat to the
#: last digit; another machine's floating point (BLAS, compiler, MuJoCo build) may move a contact-rich
#: trajectory a little.
TOLERANCE = {"measure": (0.02, 0.05), "return": (1.0, 0.05), "airborne_fraction": (0.005, 0.0)}


@dataclass(frozen=True)
class BenchTask:
    """One task of the benchmark.

    Attributes
    ----------
    name : str
        The task's short name (``crawl-planar``, ...).
    env_id : str
        The registered env id.
    env_kwargs : dict
        Constructor arguments on top of the id's registered ones (numerics only; the id's task otherwise).
    seeds : tuple of int
        The evaluation seeds, one episode each.
    steps : int
        Control steps per evaluation episode (the episode ends earlier if the env ends it).
    measure : str
        ``"speed"``: the centre-of-mass speed along +x over the episode (mm/s); ``"success"``: 1 if the episode
        ended with ``info["is_success"]``, else 0 (the mean is the success rate).
    gait : str or None
        The task's hand or open-loop controller: ``"paper"`` (the robot's paper gait played open loop, B_x inverted
        when ``gait_reverse``: the direction of +x), ``"hand"`` (the env's ``baseline_action``), None.
    gait_reverse : bool
        Play the paper gait with B_x inverted (the paper-5b and -5c gaits crawl toward -x).
    note : str
        What the task is.
    """

    name: str
    env_id: str
    env_kwargs: dict = field(default_factory=dict)
    seeds: tuple = (1000, 1001, 1002)
    steps: int = 250
    measure: str = "speed"
    gait: str | None = "paper"
    gait_reverse: bool = False
    note: str = ""

    @property
    def measure_label(self) -> str:
        return "speed (mm/s)" if self.measure == "speed" else "success rate"


#: MagSoftBench v1 (v0's six tasks, then the steering task with a rotating field's waveform as the action, and
#: that task through a coil system and through a permanent magnet). The channel and obstacle tasks run at
#: ``fidelity="fast"`` (the numerics their training blocks use; the robots' own cost 12x and 30x as much per step),
#: the 3D-strip crawl for 100 steps (2 s: the strip costs about 15x the chain per step), the waveform steering tasks
#: at 0.4 ms (:data:`~magsoft_env.envs.steer.TRAINING_SIM_DT`, their training step; docs/training.md gives them at
#: 0.2 ms too).
_WAVE = {"sim_dt": 4e-4}
_GOALS = (1000, 1001, 1002, 1003)
TASKS: tuple[BenchTask, ...] = (
    BenchTask("crawl-planar", "MagSoftCrawl-v1", gait_reverse=True,
              note="paper-5c planar chain, 2 mT, crawl limits end the episode"),
    BenchTask("crawl-planar-v2", "MagSoftCrawl-v2", gait_reverse=True,
              note="the same, a broken crawl limit charged (progress forfeited) instead of ending the episode"),
    BenchTask("crawl-strip", "MagSoftCrawl-v1", {"rod": "cable"}, seeds=(1000, 1001), steps=100,
              gait_reverse=True, note="paper-5c as the 3D strip (rod='cable'), 2 s episodes"),
    BenchTask("channel", "MagSoftChannel-v1", {"robot": "paper-5a", "fidelity": "fast"}, seeds=(1000, 1001),
              note="paper-5a toward the 42 mm channel, 5 s of the 30 s episode, fidelity fast"),
    BenchTask("obstacle", "MagSoftObstacle-v1", {"robot": "paper-5b", "fidelity": "fast"}, seeds=(1000, 1001),
              note="paper-5b toward the 2 mm block, 5 s of the 30 s episode, fidelity fast"),
    BenchTask("steer", "MagSoftSteer-v0", seeds=_GOALS, measure="success", gait="hand",
              note="3D strip to a goal 20-60 mm away within 5 mm, 5 s"),
    BenchTask("steer-waveform", "MagSoftSteerWaveform-v0", _WAVE, seeds=_GOALS, steps=50, measure="success",
              gait="hand", note="the same, action = a rotating field's plane, magnitude and frequency each 0.1 s"),
    BenchTask("coils", "MagSoftCoilsWaveform-v0", _WAVE, seeds=_GOALS, steps=50, measure="success", gait="hand",
              note="the same wave made by Navion's coils (drive lag, slew, gradients)"),
    BenchTask("magnet", "MagSoftMagnetWaveform-v0", _WAVE, seeds=_GOALS, steps=50, measure="success", gait="hand",
              note="the same wave made by a permanent magnet on an arm (bounded speed, gradients)"),
)
#: The reference controllers of every task (plus ``gait`` where the task has one).
REFERENCE = ("zero", "random")


def task_by_name(name: str) -> BenchTask:
    for t in TASKS:
        if t.name == name:
            return t
    import difflib

    hint = difflib.get_close_matches(name, [t.name for t in TASKS], n=1)
    raise ValueError(f"unknown task {name!r}{f'; did you mean {hint[0]!r}?' if hint else ''} "
                     f"Tasks of {BENCH_NAME} {BENCH_VERSION}: {', '.join(t.name for t in TASKS)}.")


def task_agents(task: BenchTask) -> list[str]:
    """The shipped agents played in ``task``: those of its env id trained with its env arguments."""
    from ..rl.agents import agent_info, shipped_agents

    names = []
    for name in shipped_agents().get(task.env_id, []):
        if dict(agent_info(task.env_id, name).get("env_kwargs") or {}) == dict(task.env_kwargs):
            names.append(name)
    return names


def controllers(task: BenchTask) -> list[str]:
    """The controllers of ``task``: zero, random, the gait (``gait`` / ``hand``), then its shipped agents."""
    out = list(REFERENCE)
    if task.gait == "paper":
        out.append("paper gait")
    elif task.gait == "hand":
        out.append("hand controller")
    return out + task_agents(task)


def _actor(task: BenchTask, name: str, env):
    """``(start(seed), act(obs))`` of controller ``name`` in ``env``."""
    space = env.action_space
    if name == "zero":
        zero = np.zeros(space.shape, dtype=space.dtype)
        return (lambda seed: None), (lambda obs: zero)
    if name == "random":
        return (lambda seed: space.seed(int(seed))), (lambda obs: space.sample())
    if name == "paper gait":
        from ..cases.gaits import gait_preset

        base = env.unwrapped
        wave = gait_preset(base.robot, reverse=task.gait_reverse).wave
        return (lambda seed: None), (lambda obs: base.open_loop_action(base.sim.time, wave))
    if name == "hand controller":
        base = env.unwrapped
        return (lambda seed: None), (lambda obs: base.baseline_action(obs))
    from ..rl.agents import load_agent

    policy = load_agent(task.env_id, name, env=env.unwrapped)
    return (lambda seed: None), policy


def evaluate(task: BenchTask, name: str) -> dict:
    """Play controller ``name`` on ``task``'s seeds: a row of the table."""
    from ..rl.agents import quiet_make

    env = quiet_make(task.env_id, **task.env_kwargs)
    start, act = _actor(task, name, env)
    measures, returns, airborne, modes, steps, lengths = [], [], [], {}, 0, []
    t0 = time.perf_counter()
    for seed in task.seeds:
        obs, info = env.reset(seed=int(seed))
        start(seed)
        x0, time0, total = info.get("x_position", math.nan), info["time"], 0.0
        k = 0
        while k < task.steps:
            obs, r, term, trunc, info = env.step(act(obs))
            total += float(r)
            k += 1
            if term or trunc:
                break
        steps += k
        lengths.append(k)
        dt = info["time"] - time0
        if task.measure == "speed":
            measures.append(1e3 * (info["x_position"] - x0) / dt if dt > 0 else 0.0)
        else:
            measures.append(1.0 if info.get("is_success") else 0.0)
        returns.append(total)
        airborne.append(float(info.get("airborne_fraction", math.nan)))
        mode = str(info.get("locomotion", ""))
        modes[mode] = modes.get(mode, 0) + 1
    wall = time.perf_counter() - t0
    env.close()
    return {"task": task.name, "env_id": task.env_id, "controller": name, "episodes": len(task.seeds),
            "measure": task.measure, "measure_mean": float(np.mean(measures)), "measure_std": float(np.std(measures)),
            "measures": [float(m) for m in measures],
            "return_mean": float(np.mean(returns)), "return_std": float(np.std(returns)),
            "steps_mean": float(np.mean(lengths)), "airborne_fraction": float(np.mean(airborne)),
            "locomotion": dict(sorted(modes.items())),
            "env_steps": steps, "wall_s": wall, "steps_per_s": steps / wall if wall > 0 else math.nan}


def run(tasks=None, names=None, *, progress=None) -> list[dict]:
    """Rows of every controller (or those of ``names``) on every task (or those of ``tasks``)."""
    rows = []
    for task in TASKS if tasks is None else [task_by_name(t) for t in tasks]:
        for name in controllers(task):
            if names is not None and name not in names:
                continue
            row = evaluate(task, name)
            rows.append(row)
            if progress is not None:
                progress(row)
    return rows


def _fmt_modes(modes: dict) -> str:
    return ", ".join(f"{m or '-'} {n}" for m, n in modes.items())


def markdown(rows: list[dict]) -> str:
    """The table (markdown)."""
    lines = ["| task | env id | controller | measure: mean +- std | return: mean +- std | airborne fraction | "
             "locomotion (episodes) | episodes x steps (cap) | wall time | env steps/s |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        task = task_by_name(r["task"])
        what = "mm/s" if r["measure"] == "speed" else "reached"
        lines.append(f"| {r['task']} | `{r['env_id']}` | {r['controller']} | {r['measure_mean']:+.3f} +- "
                     f"{r['measure_std']:.3f} {what} | {r['return_mean']:+.1f} +- {r['return_std']:.1f} | "
                     f"{r['airborne_fraction']:.4f} | {_fmt_modes(r['locomotion'])} | {r['episodes']} x "
                     f"{r['steps_mean']:.0f} ({task.steps}) | {r['wall_s']:.1f} s | {r['steps_per_s']:.0f} |")
    return "\n".join(lines)


def table_path() -> Path:
    from ..rl.agents import agents_root

    return agents_root() / TABLE_FILE


def load_table(path=None) -> dict:
    p = table_path() if path is None else Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"no stored {BENCH_NAME} table at {str(p)!r}: run with --write first.")
    return json.loads(p.read_text())


def _agree(new: float, old: float, kind: str) -> bool:
    a, r = TOLERANCE[kind]
    if math.isnan(old) or math.isnan(new):
        return math.isnan(old) and math.isnan(new)
    return abs(new - old) <= a + r * abs(old)


def compare(rows: list[dict], stored: dict) -> list[str]:
    """Mismatches (texts) of ``rows`` against the stored table."""
    old = {(r["task"], r["controller"]): r for r in stored["rows"]}
    bad = []
    for r in rows:
        key = (r["task"], r["controller"])
        if key not in old:
            bad.append(f"{key[0]} / {key[1]}: not in the stored table")
            continue
        o = old[key]
        for field_, kind in (("measure_mean", "measure"), ("return_mean", "return"),
                             ("airborne_fraction", "airborne_fraction")):
            if not _agree(float(r[field_]), float(o[field_]), kind):
                a, rel = TOLERANCE[kind]
                bad.append(f"{key[0]} / {key[1]}: {field_} {r[field_]:.6g}, stored {o[field_]:.6g} "
                           f"(tolerance {a:g} + {rel:g} x |stored|)")
    return bad


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m magsoft_env.bench.rl_bench",
                                 description=f"{BENCH_NAME} {BENCH_VERSION}: tasks, reference controllers and the "
                                             "shipped agents, on fixed seeds.")
    ap.add_argument("--tasks", help="comma-separated task names (default: all)")
    ap.add_argument("--controllers", help="comma-separated controller names (default: all of each task)")
    ap.add_argument("--check", action="store_true",
                    help="replay and compare with the stored table within the tolerance; exit 1 on a mismatch")
    ap.add_argument("--write", action="store_true", help="store the table (the agents' folder)")
    ap.add_argument("--table", help="the stored table to compare with or write (default: the shipped one)")
    ap.add_argument("--json", help="write the rows to this JSON file too")
    ap.add_argument("--list", action="store_true", help="print the tasks, their seeds and controllers, and exit")
    args = ap.parse_args(argv)
    tasks = args.tasks.split(",") if args.tasks else None
    names = args.controllers.split(",") if args.controllers else None
    try:
        for t in tasks or []:
            task_by_name(t)
    except ValueError as err:
        ap.error(str(err))
    if args.list:
        print(f"{BENCH_NAME} {BENCH_VERSION}")
        for t in TASKS:
            print(f"- {t.name}: {t.env_id} {t.env_kwargs or ''} seeds {list(t.seeds)} x <= {t.steps} steps, "
                  f"measure {t.measure_label}; controllers: {', '.join(controllers(t))}. {t.note}")
        return 0
    t0 = time.perf_counter()
    rows = run(tasks, names, progress=lambda r: print(f"  {r['task']} / {r['controller']}: "
                                                       f"{r['measure_mean']:+.4f} ({r['wall_s']:.1f} s)",
                                                       file=sys.stderr, flush=True))
    wall = time.perf_counter() - t0
    print(f"{BENCH_NAME} {BENCH_VERSION} ({len(rows)} rows, {wall:.0f} s)\n")
    print(markdown(rows))
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    if args.write:
        import platform

        path = Path(args.table) if args.table else table_path()
        path.write_text(json.dumps({"bench": BENCH_NAME, "version": BENCH_VERSION, "tolerance": TOLERANCE,
                                    "machine": f"{platform.machine()}, {platform.system()}, "
                                               f"python {platform.python_version()}",
                                    "wall_s": wall, "rows": rows}, indent=1) + "\n")
        print(f"\nwrote {path}")
    if args.check:
        bad = compare(rows, load_table(args.table))
        if bad:
            print(f"\n--check: {len(bad)} mismatch(es) with the stored table:\n  " + "\n  ".join(bad))
            return 1
        print(f"\n--check: {len(rows)} rows agree with the stored table ({wall:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What running a batch on each engine costs: throughput and overhead per case against the serial run.

    python -m magsoft_env.bench.batch_bench [--quick] [--engines serial,local,ray] [--workers N]
                                            [--equilibria N] [--gaits N] [--gait-seconds S] [--json out.json]

Three workloads, each run serially in this process first (the reference), then on each engine
(:func:`magsoft_env.parallel.run_batch`, a fresh results file each time):

* ``noop``: ``sleep`` cases of no time, one per task: the engine's own cost per task;
* ``equilibria``: ``solve_equilibrium`` of paper-5c under fields from 1 to 8 mT, millisecond jobs grouped in
  chunks (four per worker);
* ``gaits``: ``run_gait`` of paper-5c (alternately reversed), jobs of seconds, one per task.

The engine's start is timed apart (``start s``: Ray's ``ray.init`` of a private cluster, kept up for the
workloads; the local pool's, which each batch pays, as a batch of one no-op once the fork server that starts
the workers runs, which the first batch of a process starts, about a second); from the run time without it:
throughput (cases/s), speed-up over the serial run, overhead per case (ms: the workers' time not spent on
cases, ``(workers x run - serial) / cases``), time per task (ms), and whether every row equals the serial one
(every field but the wall time). ``--quick``: 20 equilibria, 2 gaits of 0.3 s, 50 no-ops.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import sys
import tempfile
import time
from pathlib import Path

from ..io import format_table, write_json
from ..parallel import comparable, run_batch


def workloads(n_eq: int, n_gait: int, gait_seconds: float, n_noop: int) -> dict:
    eq = [{"kind": "equilibrium", "robot": "paper-5c", "field_mT": [0.0, 1.0 + 7.0 * i / max(1, n_eq - 1)]}
          for i in range(n_eq)]
    gaits = [{"kind": "gait", "robot": "paper-5c", "seconds": gait_seconds, "reverse": bool(i % 2), "tags": [i]}
             for i in range(n_gait)]
    noop = [{"kind": "sleep", "tags": [i]} for i in range(n_noop)]
    return {"noop": noop, "equilibria": eq, "gaits": gaits}


def _timed(cases, folder: Path, name: str, **kw):
    out = folder / f"{name}.jsonl"
    t0 = time.perf_counter()
    res = run_batch(cases, out, **kw)
    return time.perf_counter() - t0, res


def _row(load, engine, workers, n, run, start, serial_wall, same) -> dict:
    return {"workload": load, "engine": engine, "workers": workers, "cases": n, "run_s": run, "start_s": start,
            "cases_per_s": n / run, "speedup": serial_wall / run,
            "overhead_ms": (workers * run - serial_wall) / n * 1e3, "per_task_ms": run / n * 1e3,
            "identical": same}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="20 equilibria, 2 gaits of 0.3 s, 50 no-ops")
    p.add_argument("--engines", default=None,
                   help="comma-separated engines (default: local, and ray when it is installed)")
    p.add_argument("--workers", type=int, default=None, help="workers per engine (default: the local CPUs)")
    p.add_argument("--equilibria", type=int, default=None, help="equilibrium cases (default 200)")
    p.add_argument("--gaits", type=int, default=None, help="gait cases (default 8)")
    p.add_argument("--gait-seconds", type=float, default=None, help="simulated seconds per gait (default 1.5)")
    p.add_argument("--noops", type=int, default=None, help="no-op tasks (default 200)")
    p.add_argument("--json", type=Path, default=None, help="write the rows as JSON")
    args = p.parse_args(argv)
    engines = (args.engines.split(",") if args.engines
               else ["local"] + (["ray"] if importlib.util.find_spec("ray") else []))
    workers = args.workers or os.cpu_count() or 1
    q = args.quick
    loads = workloads(args.equilibria or (20 if q else 200), args.gaits or (2 if q else 8),
                      args.gait_seconds or (0.3 if q else 1.5), args.noops or (50 if q else 200))
    rows = []
    with tempfile.TemporaryDirectory(prefix="batch-bench-") as tmp:
        folder = Path(tmp)
        serial = {}
        for load, cases in loads.items():
            wall, res = _timed(cases, folder, f"{load}-serial", engine="serial")
            serial[load] = (wall, [comparable(r) for r in res.rows])
            rows.append(_row(load, "serial", 1, len(cases), wall, 0.0, wall, True))
        for engine in engines:
            ray_engine = None
            if engine == "ray":  # started once, kept for the workloads (a batch on a running cluster)
                from ..parallel.ray_engine import RayEngine

                ray_engine = RayEngine(workers=workers)
                t0 = time.perf_counter()
                ray_engine.start()
                start = time.perf_counter() - t0
            else:  # the pool starts with each batch: its cost is that of a batch of one no-op (the fork server up)
                first, _ = _timed(loads["noop"][:1], folder, f"{engine}-first", engine=engine, workers=workers)
                start, _ = _timed(loads["noop"][:1], folder, f"{engine}-one", engine=engine, workers=workers)
                print(f"{engine}: first batch in this process {first:.2f} s (the fork server starts), then "
                      f"{start:.2f} s", file=sys.stderr)
            try:
                for load, cases in loads.items():
                    wall, res = _timed(cases, folder, f"{load}-{engine}", engine=engine, workers=workers,
                                       chunk_size=1 if load == "noop" else None)
                    run = wall - (0.0 if ray_engine else start)
                    same = [comparable(r) for r in res.rows] == serial[load][1]
                    rows.append(_row(load, engine, workers, len(cases), run, start, serial[load][0], same))
                    print(f"{load} on {engine}: {wall:.2f} s", file=sys.stderr, flush=True)
            finally:
                if ray_engine is not None:
                    ray_engine.stop()
    print(f"batch engines, {workers} workers, {os.cpu_count()} CPUs; 'run s' leaves out the engine's start")
    print(format_table(rows, [("workload", "workload", ""), ("engine", "engine", ""), ("workers", "workers", "d"),
                              ("cases", "cases", "d"), ("run_s", "run s", ".2f"), ("cases_per_s", "cases/s", ".1f"),
                              ("speedup", "speed-up", ".2f"), ("overhead_ms", "overhead ms/case", ".1f"),
                              ("start_s", "start s", ".2f"), ("per_task_ms", "ms/task", ".2f"),
                              ("identical", "= serial", "")]))
    if args.json is not None:
        write_json(args.json, {"workers": workers, "cpus": os.cpu_count(), "rows": rows})
        print(f"wrote {args.json}")
    return 0 if all(r["identical"] for r in rows) else 1


__all__ = ["main", "workloads"]

if __name__ == "__main__":
    sys.exit(main())

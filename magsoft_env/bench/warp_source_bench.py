"""Benchmark: the step cost of the MuJoCo Warp rod batch with and without field sources, beside the C simulator's.

    python -m magsoft_env.bench.warp_source_bench [--worlds 1,16,64] [--segments 49] [--substeps 100]
                                                  [--device cpu] [--json out.json]

The clamped strip of :func:`~magsoft_env.sim.sources.magnet_case` (``segments + 1`` pieces: 50 by default, dt 0.1
ms, gravity on, a held 2 mT field along z) as a :class:`~magsoft_env.sim.warp_batch.WarpRodBatch` of each size,
under the held field alone, under CardioMag's 8 coils at fixed currents (``CoilSystem.at_currents``: one set of 59
dipoles, the same in every world) and under the magnet case's point dipole
(:meth:`~magsoft_env.sim.warp_batch.WarpRodBatch.set_field_sources`): the wall time of one recorded graph of
``--substeps`` substeps (replayed; the median of a few rounds after one untimed call that records it), per substep
and per world-substep, and the source kernel alone (launched ``--substeps`` times outside a graph). The C
simulator's time per step of the same strip under the same sources, in the same process (as
:mod:`magsoft_env.bench.source_step_bench`: the native path under the held field, the loads written from Python
before every step under a source), is printed beside it.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import statistics
import time

import numpy as np


def _ints(text: str) -> list[int]:
    out = [int(v) for v in text.split(",") if v.strip()]
    if not out or min(out) < 1:
        raise argparse.ArgumentTypeError(f"a comma-separated list of positive integers, got {text!r}")
    return out


def _median_time(fn, rounds: int = 5) -> float:
    fn()  # untimed: records the graph (and compiles the kernels at the first build)
    per = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        per.append(time.perf_counter() - t0)
    return statistics.median(per)


def run(worlds=(1, 16, 64), *, segments: int = 49, substeps: int = 100, device: str | None = "cpu",
        c_steps: int = 1000) -> list[dict]:
    from ..sim import RodOptions, Simulator
    from ..sim.sources import magnet_case
    from ..sim.warp_batch import WarpRodBatch
    from .source_step_bench import sources

    beam, _, _ = magnet_case()
    opts = RodOptions(segments=segments, timestep=1e-4, gravity=9.81)
    field = (0.0, 0.002)
    rows = []
    for name, src in sources().items():
        sim = Simulator(beam, opts, field=field, source=src)
        c_step = _median_time(lambda sim=sim: sim.step(c_steps)) / c_steps
        rows.append({"backend": "C", "device": "cpu (1 thread)", "source": name, "worlds": 1,
                     "pieces": sim.backend.npieces, "substep_us": c_step * 1e6, "world_substep_us": c_step * 1e6})
    base = Simulator(beam, opts, field=field)
    for n in worlds:
        batch = WarpRodBatch(base.rod, base.data, n, device=device)
        batch.set_fields(np.tile(field, (n, 1)))
        for name, src in sources().items():
            if src is None:
                batch.clear_sources()
            else:
                batch.set_field_sources([src] * n)
            t = _median_time(lambda b=batch: b.advance(substeps)) / substeps
            kernel = float("nan")
            if src is not None:  # the source kernel alone, launched as a substep launches it
                kernel = _median_time(lambda b=batch: _kernel_calls(b, substeps)) / substeps
            rows.append({"backend": "warp", "device": str(batch.device), "source": name, "worlds": n,
                         "pieces": base.backend.npieces, "substep_us": t * 1e6, "world_substep_us": t * 1e6 / n,
                         "kernel_us": kernel * 1e6})
    return rows


def _kernel_calls(batch, k: int) -> None:
    batch.run_source_kernel(k)


def table(rows) -> str:
    head = ("| backend | device | source | worlds | us / substep | us / world-substep | source kernel us / substep |\n"
            "|---|---|---|---|---|---|---|")
    lines = []
    for r in rows:
        k = r.get("kernel_us", math.nan)
        lines.append(f"| {r['backend']} | {r['device']} | {r['source']} | {r['worlds']} | {r['substep_us']:.0f} | "
                     f"{r['world_substep_us']:.1f} | {'-' if math.isnan(k) else format(k, '.0f')} |")
    return "\n".join([head, *lines])


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="python -m magsoft_env.bench.warp_source_bench",
                                description=__doc__.splitlines()[0])
    p.add_argument("--worlds", type=_ints, default=_ints("1,16,64"))
    p.add_argument("--segments", type=int, default=49)
    p.add_argument("--substeps", type=int, default=100, help="substeps per recorded graph (timed per replay)")
    p.add_argument("--device", default="cpu", help="Warp device (cpu, cuda:0)")
    p.add_argument("--json", default=None, help="also write the rows to this file")
    args = p.parse_args(argv)
    from ..sim.warp_extra import INSTALL_HINT, warp_available

    if not warp_available():
        p.error(f"the Warp batch needs the optional extra 'warp': {INSTALL_HINT}")
    rows = run(args.worlds, segments=args.segments, substeps=args.substeps, device=args.device)
    print(f"clamped strip, {args.segments + 1} pieces, dt 0.1 ms, gravity on; {platform.machine()}, "
          f"{platform.python_version()}; median of 5 replays")
    print(table(rows))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

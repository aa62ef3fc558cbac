"""Benchmark: the wall time of one physics step of the MuJoCo rods under a uniform field and under field sources.

    python -m magsoft_env.bench.source_step_bench [--segments 49] [--steps 2000] [--json out.json]

For the planar chain and the 3D strip (clamped, ``segments + 1`` pieces: 50 by default), in one process: the time
per step under a uniform field (the native path: ``mj_step(m, d, k)``), under CardioMag's 8 coils at fixed currents
(``CoilSystem.at_currents``: the per-ampere dipoles of all coils combined once into one
:class:`~magsoft_env.fields.DipoleSet` of 59 dipoles) and under a point dipole (both: the loads written from Python
before every step, :meth:`~magsoft_env.sim.Simulator.set_source`), and the cost of the source's evaluation alone
(one ``field_and_gradient`` call at the pieces). Each figure is the median of a few rounds.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time

import numpy as np

from ..fields import CoilSystem, PointDipole
from ..io import format_table, write_json
from ..sim import RodOptions, Simulator
from ..sim.sources import magnet_case


def _per_call(fn, n: int, rounds: int = 5) -> float:
    fn()
    per = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        per.append((time.perf_counter() - t0) / n)
    return statistics.median(per)


def sources() -> dict:
    """The sources measured: CardioMag at fixed currents (about 3 mT at the strip) and the magnet case's dipole."""
    cardio = CoilSystem.from_calibration("cardiomag")
    beam, dipole, _ = magnet_case()
    return {"uniform": None, "CardioMag (8 coils, 59 dipoles)": cardio.at_currents(np.linspace(-0.6, 0.6, 8)),
            "PointDipole": dipole}


def run(segments: int = 49, steps: int = 2000) -> list[dict]:
    beam, _, _ = magnet_case()
    rows = []
    for rod, dt in (("planar", 1e-4), ("cable", 1e-4)):
        base = None
        for name, src in sources().items():
            sim = Simulator(beam, RodOptions(rod=rod, segments=segments, timestep=dt, gravity=9.81),
                            field=(0.0, 0.0, 0.002) if rod == "cable" else (0.0, 0.002), source=src)
            step = _per_call(lambda sim=sim: sim.step(steps), steps)
            evaluation = float("nan")
            if src is not None:
                pts = sim.pose().centreline
                pts = 0.5 * (pts[1:] + pts[:-1])
                evaluation = _per_call(lambda src=src, pts=pts: [src.field_and_gradient(pts) for _ in range(steps)],
                                       steps)
            base = step if src is None else base
            rows.append({"rod": rod, "source": name, "pieces": sim.backend.npieces, "step_us": step * 1e6,
                         "evaluation_us": evaluation * 1e6, "x_uniform": step / base})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--segments", type=int, default=49)
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    rows = run(args.segments, args.steps)
    print(f"{platform.processor() or platform.machine()}, {platform.python_version()}; clamped, dt = 0.1 ms, "
          "gravity on; median of 5 rounds")
    print(format_table(rows, [("rod", "rod", ""), ("source", "source", ""), ("pieces", "pieces", ""),
                              ("step_us", "us / step", ".1f"), ("evaluation_us", "source eval us", ".1f"),
                              ("x_uniform", "x uniform", ".2f")]))
    if args.json:
        write_json(args.json, rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

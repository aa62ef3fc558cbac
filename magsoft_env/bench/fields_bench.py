"""Benchmark: the cost of evaluating each field source at the pieces of a rod, beside magpylib where installed.

    python -m magsoft_env.bench.fields_bench [--points 50] [--repeat 2000] [--json out.json]

Each source is evaluated at ``--points`` points (the pieces of a rod, spread over a 4 cm box at the centre of
the workspace) for its field and gradient; the table prints the median time per call (microseconds) over
``--repeat`` calls in a few rounds, and, where magpylib is installed (``pip install magsoft_env[fields]``), the
time of magpylib's ``getB`` on the same sources (field only: magpylib has no gradient) and the largest
difference of the fields, relative to the largest field. Sources: CardioMag's 8 coils (59 dipoles) at changing
currents (``field_and_gradient(points, currents)``, what a simulation step calls) and at fixed currents
(``at_currents``), Navion's 3 coils, a Helmholtz pair, a point dipole, a cylinder and a cuboid magnet, and a
:class:`~magsoft_env.fields.GridField` fit of CardioMag's field (degree 10 over its workspace), against the exact
dipole sum.
"""

from __future__ import annotations

import argparse
import importlib.util
import statistics
import time

import numpy as np

from ..fields import (
    CoilSystem,
    CuboidMagnet,
    CylinderMagnet,
    GridField,
    PointDipole,
    helmholtz_pair,
)
from ..io import format_table, write_json
from ..spec import MU0


def _time(fn, repeat: int, rounds: int = 5) -> float:
    """Median over ``rounds`` of the mean time of one call (s), ``repeat`` calls a round."""
    fn()
    per = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        for _ in range(repeat):
            fn()
        per.append((time.perf_counter() - t0) / repeat)
    return statistics.median(per)


def cases(points: np.ndarray):
    """(name, sources summed, our callable, a magpylib builder or None, exact reference for a fit or None)."""
    cardio = CoilSystem.from_calibration("cardiomag")
    currents = np.linspace(-15.0, 15.0, cardio.n_coils)
    navion = CoilSystem.from_calibration("navion")
    nav_I = np.array([20.0, -10.0, 35.0])
    pair = helmholtz_pair(center=(0, 0, 0), normal=(0, 0, 1), radius=0.05, current=10.0)
    dipole = PointDipole(position=(0.0, 0.0, 0.08), moment=(0.0, 0.5, 1.0))
    cyl = CylinderMagnet(position=(0, 0, 0.06), axis=(0, 0, 1), radius=0.005, length=0.01, magnetization=9e5)
    cub = CuboidMagnet(position=(0, 0, 0.06), dimensions=(0.01, 0.01, 0.005), magnetization=(0, 0, 9e5))
    fixed = cardio.at_currents(currents)
    grid = GridField.from_source(fixed, bounds=cardio.workspace, shape=(11, 11, 11), degree=10)

    def mp_dipoles(coils, I):
        def build(magpy):
            m = coils.source_moments * I[coils.source_coil][:, None] / (MU0 / (4 * np.pi))
            return magpy.Collection(*[magpy.misc.Dipole(position=p, moment=mi)
                                      for p, mi in zip(coils.source_positions, m, strict=True)])
        return build

    def mp_pair(magpy):
        return magpy.Collection(*[magpy.current.Circle(position=s.center, diameter=2 * s.radius, current=s.current)
                                  for s in pair.loops])

    # n: dipoles for the coil systems, the potential's degree for the grid fit, 1 otherwise
    return [
        ("CardioMag, currents", cardio.source_positions.shape[0], lambda: cardio.field_and_gradient(points, currents),
         mp_dipoles(cardio, currents), None),
        ("CardioMag, at_currents", cardio.source_positions.shape[0], lambda: fixed.field_and_gradient(points),
         mp_dipoles(cardio, currents), None),
        ("Navion, currents", navion.source_positions.shape[0], lambda: navion.field_and_gradient(points, nav_I),
         mp_dipoles(navion, nav_I), None),
        ("Helmholtz pair", 2, lambda: pair.field_and_gradient(points), mp_pair, None),
        ("point dipole", 1, lambda: dipole.field_and_gradient(points),
         lambda magpy: magpy.misc.Dipole(position=dipole.position, moment=dipole.moment), None),
        ("cylinder magnet", 1, lambda: cyl.field_and_gradient(points),
         lambda magpy: magpy.magnet.Cylinder(position=cyl.position, dimension=(2 * cyl.radius, cyl.length),
                                             polarization=(0, 0, MU0 * cyl.magnetization)), None),
        ("cuboid magnet", 1, lambda: cub.field_and_gradient(points),
         lambda magpy: magpy.magnet.Cuboid(position=cub.position, dimension=cub.dimensions,
                                           polarization=MU0 * cub.magnetization), None),
        ("grid fit of CardioMag", grid.degree, lambda: grid.field_and_gradient(points), None, fixed),
    ]


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--points", type=int, default=50, help="points per call (default 50: the pieces of a rod)")
    p.add_argument("--repeat", type=int, default=2000, help="calls per timing round (default 2000)")
    p.add_argument("--json", default=None, help="also write the table to this JSON file")
    args = p.parse_args(argv)
    if not 1 <= args.points <= 100_000 or not 1 <= args.repeat <= 10**7:
        p.error("--points must lie in [1, 100000] and --repeat in [1, 1e7]")
    rng = np.random.default_rng(0)
    points = rng.uniform(-0.02, 0.02, size=(args.points, 3))
    magpy = importlib.import_module("magpylib") if importlib.util.find_spec("magpylib") else None
    rows = []
    for name, n_src, ours, mp_build, exact in cases(points):
        t = _time(ours, args.repeat)
        B = ours()[0]
        row = {"source": name, "sources": n_src, "points": args.points, "ours_us": t * 1e6,
               "magpylib_us": None, "rel_error": None}
        if exact is not None:
            Bx = exact.field(points)
            row["rel_error"] = float(np.abs(B - Bx).max() / np.abs(Bx).max())
        elif magpy is not None and mp_build is not None:
            obj = mp_build(magpy)
            row["magpylib_us"] = _time(lambda obj=obj: obj.getB(points), max(1, args.repeat // 20)) * 1e6
            Bm = np.asarray(obj.getB(points)).reshape(-1, 3)
            row["rel_error"] = float(np.abs(B - Bm).max() / np.abs(Bm).max())
        rows.append(row)
    print(f"field and gradient at {args.points} points, median of 5 rounds of {args.repeat} calls"
          + ("" if magpy else "; magpylib not installed (pip install magsoft_env[fields])"))
    shown = [{**r, "magpylib_us": "-" if r["magpylib_us"] is None else f"{r['magpylib_us']:.1f}",
              "rel_error": "-" if r["rel_error"] is None else f"{r['rel_error']:.1e}"} for r in rows]
    print(format_table(shown, [("source", "source", ""), ("sources", "n", ""), ("ours_us", "ours B+G us", ".1f"),
                               ("magpylib_us", "magpylib B us", ""), ("rel_error", "max |dB|/max|B|", "")]))
    print("max |dB|/max|B|: against magpylib's getB, or for the grid fit against the exact dipole sum")
    if args.json:
        write_json(args.json, {"points": args.points, "repeat": args.repeat, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

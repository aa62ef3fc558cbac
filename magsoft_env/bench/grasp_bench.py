"""Benchmark of the grasp scene (paper Fig. S11): heaviest object lifted, optimized against contour-magnetized grippers.

Run ``python -m magsoft_env.bench.grasp_bench`` (``--help`` for options). For each object, a hanging
finger is designed with :func:`magsoft_env.compare.grasp.design_gripper` (5 x 1.13 mm, phi = 0.2,
field 1-20 mT along +z by default); the unoptimized gripper is the same beam magnetized straight from
the contour (beta = pi/2 - theta_target) under the same field. Both are closed on the object in MuJoCo
and lifted; the object mass is bisected (:func:`magsoft_env.compare.grasp.max_lift_mass`). Prints the
design's fit, each gripper's shape error under the field (analytical), and the heaviest mass lifted
over the gripper mass, with wall times.
"""

from __future__ import annotations

import argparse
import math
import os
import platform
import time

import numpy as np

from magsoft_env.units import GRAM, MM, MT


def _shape_rms(beam, fld, target, gravity):
    """RMS distance (m) from the target to the analytical centreline of ``beam`` under ``fld``."""
    import magsoft_env as ms
    from magsoft_env.design import point_to_polyline, prepare_target

    eq = ms.solve_equilibrium(beam, fld, gravity=gravity)
    if not eq.success:
        return math.nan
    _, x, z, _ = eq.sample(241)
    d = point_to_polyline(prepare_target(target, 50), np.column_stack([x, z]))
    return float(np.sqrt(np.mean(d**2)))


def run(objects, *, field_max_mT: float, friction: float, segments: int, timestep: float, rel_tol: float,
        seed: int = 0) -> list[dict]:
    from magsoft_env.compare.grasp import (
        GraspOptions,
        GraspScene,
        contour_aligned_beam,
        design_gripper,
        hanging_target,
        max_lift_mass,
    )
    from magsoft_env.threads import single_threaded_blas

    opts = GraspOptions(segments=segments, timestep=timestep, friction=friction)
    rows = []
    for name in objects:
        target = hanging_target(name)
        t0 = time.perf_counter()
        res = design_gripper(name, field_bounds=(1e-3, field_max_mT * 1e-3), seed=seed)
        t_design = time.perf_counter() - t0
        grippers = {
            "optimized": res.beam,
            "unoptimized": contour_aligned_beam(target, res.beam, family=res.family.kind, size=res.family.size),
        }
        for kind, beam in grippers.items():
            with single_threaded_blas():
                rms = _shape_rms(beam, res.field, target, opts.gravity)
            t0 = time.perf_counter()
            scene = GraspScene(beam, res.field, target, opts)
            lift = max_lift_mass(scene, rel_tol=rel_tol)
            off = scene.trial(0.05 * scene.gripper_mass, field_on=False)
            rows.append({
                "object": name, "gripper": kind, "L_mm": beam.length / MM, "B_mT": res.field.magnitude / MT,
                "design_ok": res.success, "shape_rms_mm": rms / MM, "shape_rms_pct": 100 * rms / beam.length,
                "gripper_g": scene.gripper_mass / GRAM, "max_g": lift.max_mass / GRAM, "ratio": lift.ratio,
                "upper_ratio": lift.upper_ratio, "trials": len(lift.trials),
                "field_off_lifts": off.lifted, "unstable": sum(not t.stable for t in lift.trials),
                "design_s": t_design if kind == "optimized" else 0.0, "grasp_s": time.perf_counter() - t0,
            })
            r = rows[-1]
            print(f"{name:9s} {kind:11s} shape RMS {r['shape_rms_mm']:.3f} mm ({r['shape_rms_pct']:.2f}% L)  "
                  f"max lifted {r['max_g']:.3f} g = {r['ratio']:.2f} x gripper ({r['gripper_g']:.3f} g), "
                  f"next fails at {r['upper_ratio']:.2f} x; field off lifts: {r['field_off_lifts']}; "
                  f"{r['trials']} trials, {r['grasp_s']:.1f} s", flush=True)
    return rows


_COLUMNS = [
    ("object", "object", ""), ("gripper", "gripper", ""), ("L_mm", "L (mm)", ".2f"), ("B_mT", "B (mT)", ".2f"),
    ("shape_rms_pct", "shape RMS to contour (% L)", ".2f"), ("gripper_g", "gripper mass (g)", ".3f"),
    ("max_g", "heaviest lifted (g)", ".3f"), ("ratio", "lifted / gripper mass", ".2f"),
    ("upper_ratio", "first failure / gripper mass", ".2f"), ("field_off_lifts", "field off lifts", ""),
    ("trials", "trials", "d"), ("grasp_s", "time (s)", ".1f"),
]


def markdown(rows) -> str:
    head = "| " + " | ".join(c[1] for c in _COLUMNS) + " |"
    sep = "|" + "---|" * len(_COLUMNS)
    lines = [head, sep]
    for r in rows:
        lines.append("| " + " | ".join(format(r[k], f) if f else str(r[k]) for k, _, f in _COLUMNS) + " |")
    return "\n".join(lines)


def main(argv=None) -> int:
    from magsoft_env.design import BUILTIN_TARGETS

    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--objects", nargs="+", default=list(BUILTIN_TARGETS), choices=list(BUILTIN_TARGETS))
    p.add_argument("--field-max-mT", type=float, default=20.0)
    p.add_argument("--friction", type=float, default=0.8)
    p.add_argument("--segments", type=int, default=20)
    p.add_argument("--timestep", type=float, default=1e-4, help="s")
    p.add_argument("--rel-tol", type=float, default=0.05, help="bisection stops at upper/lower < 1 + rel_tol")
    p.add_argument("--markdown", help="write the table to this file")
    a = p.parse_args(argv)
    print(f"{platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}, "
          f"numpy {np.__version__}; friction {a.friction}, N = {a.segments}, dt = {a.timestep} s")
    rows = run(a.objects, field_max_mT=a.field_max_mT, friction=a.friction, segments=a.segments,
               timestep=a.timestep, rel_tol=a.rel_tol)
    table = markdown(rows)
    print(table)
    if a.markdown:
        with open(a.markdown, "w") as f:
            f.write(table + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Benchmark of inverse design on the paper's four objects (Fig. 6): fit error and wall time per design.

Run ``python -m magsoft_env.bench.design_bench`` (``--help`` for options). Each object's half-contour
(assets/contours) is the target; the beam is the paper's cross-section (5 x 1.13 mm, phi = 0.2) with
its length set to the curve length. Prints, per object, the RMS and largest point-to-curve distance
(mm and % of L), the designed field, the equilibrium solves and the wall time, next to the
baseline the paper's Fig. S11 compares against: the beam magnetized straight from the contour
(beta = pi/2 - theta_target, the strong-field alignment guess, no optimization) under the best
field of the same range. Optionally writes the table as Markdown.

``--compare`` (the default ``--methods 2-point exact``) also runs each design with the forward-difference Jacobian
(``jacobian="2-point"``, the method before exact gradients) and the exact one, in the same process, each
``--repeat`` times (the best time counts: the designs are deterministic, the machine's load is not), and prints them
side by side: wall time, equilibrium solves, RMS and largest error, and the speed-up. ``--gripper`` takes the grasp
scene's hanging fingers (:func:`magsoft_env.compare.grasp.design_gripper`, the contour mirrored, beta within
[-2 pi, 2 pi]) instead of the upright half-contours.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

from magsoft_env.units import MM, MT


def _baseline(target, beam, b_hi, family, coupling):
    """Best RMS (m) of the unoptimized, contour-aligned profile over a scan of field magnitudes."""
    import magsoft_env as ms
    from magsoft_env.design import point_to_polyline, prepare_target
    from magsoft_env.design.targets import tangent_angle

    tgt = prepare_target(target, 50)
    u, theta = tangent_angle(tgt)
    prof = family.profile(family.fit(u, 0.5 * np.pi - theta), beam.length)
    b = beam.replace(magnetization=prof)
    fields = [(0.0, v) for v in np.linspace(b_hi / 8, b_hi, 8)]
    best = np.inf
    for r in ms.solve_path(b, fields, coupling=coupling):
        if r.success:
            _, x, z, _ = r.sample(241)
            d = point_to_polyline(tgt, np.column_stack([x, z]))
            best = min(best, float(np.sqrt(np.mean(d**2))))
    return best


def _design(name, *, field_max_mT, family, starts, seed, coupling, gripper, jacobian):
    import magsoft_env as ms
    from magsoft_env.design import builtin_target, curve_length

    kw = dict(field_bounds=(1e-3, field_max_mT * 1e-3), family=family, n_starts=starts, seed=seed, coupling=coupling,
              jacobian=jacobian)
    if gripper:
        from magsoft_env.compare.grasp import design_gripper

        return design_gripper(name, **kw)
    target = builtin_target(name)
    beam = ms.Beam(length=curve_length(target), width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
    return ms.design_profile(target, beam, **kw)


def compare(objects, *, field_max_mT: float, family: str, starts: int, seed: int, coupling: str,
            gripper: bool = False, methods=("2-point", "exact"), repeat: int = 1) -> list[dict]:
    """Each object designed by each Jacobian ``method`` in turn (``repeat`` times, best time kept): one row per
    object and method, with the speed-up over the first method and the RMS error relative to it."""
    rows = []
    for name in objects:
        first = None
        for method in methods:
            best = None
            for _ in range(repeat):
                t0 = time.perf_counter()
                res = _design(name, field_max_mT=field_max_mT, family=family, starts=starts, seed=seed,
                              coupling=coupling, gripper=gripper, jacobian=method)
                wall = time.perf_counter() - t0
                best = wall if best is None else min(best, wall)
            L = res.beam.length
            row = {"object": name, "target": "gripper" if gripper else "contour", "jacobian": method,
                   "time_s": best, "solves": res.nfev, "starts": len(res.history), "B_mT": res.field.magnitude / MT,
                   "rms_mm": res.rms_error / MM, "rms_pct": 100 * res.rms_error / L, "max_pct": 100 * res.max_error / L,
                   "status": res.status}
            if first is None:
                first = row
            row["speedup"] = first["time_s"] / best
            row["rms_ratio"] = row["rms_mm"] / first["rms_mm"]
            rows.append(row)
    return rows


COMPARE_COLUMNS = [
    ("object", "object", ""), ("target", "target", ""), ("jacobian", "jacobian", ""), ("time_s", "time (s)", ".3f"),
    ("speedup", "speed-up", ".1f"), ("solves", "solves", "d"), ("starts", "starts", "d"), ("B_mT", "B (mT)", ".2f"),
    ("rms_mm", "RMS (mm)", ".5f"), ("rms_pct", "RMS (% L)", ".4f"), ("rms_ratio", "RMS / first", ".5f"),
    ("max_pct", "max (% L)", ".3f"), ("status", "status", "d"),
]


def run(objects, *, field_max_mT: float, family: str, starts: int, seed: int, coupling: str,
        mujoco: bool = False) -> list[dict]:
    import magsoft_env as ms
    from magsoft_env.design import ProfileFamily, builtin_target, curve_length
    from magsoft_env.threads import single_threaded_blas

    rows = []
    for name in objects:
        target = builtin_target(name)
        beam = ms.Beam(length=curve_length(target), width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
        t0 = time.perf_counter()
        res = ms.design_profile(target, beam, field_bounds=(1e-3, field_max_mT * 1e-3), family=family,
                                n_starts=starts, seed=seed, coupling=coupling)
        wall = time.perf_counter() - t0
        with single_threaded_blas():
            base = _baseline(target, res.beam, field_max_mT * 1e-3, ProfileFamily(family, res.family.size), coupling)
        L = res.beam.length
        rows.append({
            "object": name, "L_mm": L / MM, "rms_mm": res.rms_error / MM, "rms_pct": 100 * res.rms_error / L,
            "max_mm": res.max_error / MM, "max_pct": 100 * res.max_error / L, "B_mT": res.field.magnitude / MT,
            "starts": len(res.history), "solves": res.nfev, "time_s": wall, "success": res.success,
            "baseline_rms_mm": base / MM, "baseline_rms_pct": 100 * base / L,
        })
        if mujoco:
            from magsoft_env.compare import mujoco_check

            chk = mujoco_check(res, segments=20)
            rows[-1].update({"mj_max_mm": chk["max_to_analytical"] / MM,
                             "mj_target_pct": 100 * chk["rms_to_target"] / L, "mj_ok": chk["success"]})
    return rows


COLUMNS = [
    ("object", "object", ""), ("L_mm", "L (mm)", ".2f"), ("rms_mm", "RMS (mm)", ".4f"), ("rms_pct", "RMS (% L)", ".3f"),
    ("max_mm", "max (mm)", ".4f"), ("max_pct", "max (% L)", ".3f"), ("B_mT", "B (mT)", ".2f"),
    ("starts", "starts", "d"), ("solves", "solves", "d"), ("time_s", "time (s)", ".2f"), ("success", "success", ""),
    ("baseline_rms_mm", "unoptimized RMS (mm)", ".3f"), ("baseline_rms_pct", "unoptimized RMS (% L)", ".2f"),
]


MUJOCO_COLUMNS = [
    ("mj_max_mm", "MuJoCo N=20 vs analytical, max (mm)", ".3f"), ("mj_target_pct", "MuJoCo RMS to target (% L)", ".3f"),
    ("mj_ok", "MuJoCo settled", ""),
]


def _columns(rows):
    return COLUMNS + (MUJOCO_COLUMNS if rows and "mj_max_mm" in rows[0] else [])


def markdown(rows, cols=None) -> str:
    cols = _columns(rows) if cols is None else cols
    head = "| " + " | ".join(h for _, h, _ in cols) + " |"
    sep = "|" + "|".join("---" for _ in cols) + "|"
    body = ["| " + " | ".join(format(r[k], f) if f else str(r[k]) for k, _, f in cols) + " |" for r in rows]
    return "\n".join([head, sep, *body])


def main(argv=None) -> int:
    from magsoft_env.design import BUILTIN_TARGETS

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--objects", nargs="+", default=list(BUILTIN_TARGETS), choices=BUILTIN_TARGETS)
    p.add_argument("--field-max-mT", type=float, default=20.0)
    p.add_argument("--family", default="spline")
    p.add_argument("--starts", type=int, default=4)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--coupling", default="rotated", choices=("rotated", "paper"))
    p.add_argument("--mujoco", action="store_true", help="also simulate each design in MuJoCo (20 segments)")
    p.add_argument("--markdown", metavar="FILE", help="also write the table as Markdown to FILE")
    p.add_argument("--compare", action="store_true",
                   help="time the Jacobian methods (--methods) side by side instead of the fit table")
    p.add_argument("--methods", nargs="+", default=["2-point", "exact"], choices=["2-point", "exact"],
                   help="Jacobians to compare (the first is the reference of speed-up and RMS ratio)")
    p.add_argument("--repeat", type=int, default=1, help="runs of each design with --compare (best time kept)")
    p.add_argument("--gripper", action="store_true",
                   help="with --compare: the grasp scene's hanging fingers (design_gripper) instead of the contours")
    a = p.parse_args(argv)
    from magsoft_env.io import format_table

    env = (f"{platform.processor() or platform.machine()}, {os.cpu_count()} CPUs visible, "
           f"python {platform.python_version()}, numpy {np.__version__}")
    print(f"inverse design, field 1-{a.field_max_mT:g} mT along +z, {a.family} profile, coupling {a.coupling}, "
          f"seed {a.seed}; {env}")
    if a.compare:
        if a.repeat < 1:
            p.error("--repeat must be at least 1")
        rows = compare(a.objects, field_max_mT=a.field_max_mT, family=a.family, starts=a.starts, seed=a.seed,
                       coupling=a.coupling, gripper=a.gripper, methods=a.methods, repeat=a.repeat)
        cols = COMPARE_COLUMNS
    else:
        rows = run(a.objects, field_max_mT=a.field_max_mT, family=a.family, starts=a.starts, seed=a.seed,
                   coupling=a.coupling, mujoco=a.mujoco)
        cols = _columns(rows)
    print(format_table(rows, cols))
    if a.markdown:
        with open(a.markdown, "w", encoding="utf-8") as fh:
            fh.write(markdown(rows, cols) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Synthetic round trips of ``magsoft_env.fit``: recover E0 and M_p from noisy tip positions, many seeds.

For each seed a "true" paper strip has E0 and M_p drawn within +-30 % of the paper's; its tips under 5-10 loads
are computed by the planar solver and perturbed by Gaussian noise of 0.05-0.1 mm; the fit starts from the paper's
values. The loads are gravity alone and then fields with gravity, by one of two designs:

- ``random``: random directions at 0.5-4 mT (any sign);
- ``planned``: the fields :func:`magsoft_env.plan_measurements` chooses at the paper's values (the guess), as
  many as the random design has, at most 4 mT, kept 0.5 E I / L^2 from a fold over +-30 % of each parameter;
- ``paired``: the same with ``both_directions=True`` (pairs B, -B), one load fewer where the random design's
  count leaves an odd number of fields.

Prints the relative errors, the predicted and reported 1-sigma, whether each 95 % interval covers the truth, and
the time per fit::

    python -m magsoft_env.bench.fit_bench --seeds 100 --design random
    python -m magsoft_env.bench.fit_bench --seeds 100 --design planned
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

_PLANS: dict = {}


def planned_fields(base, n: int, both_directions: bool = False) -> list:
    """The ``n`` loads :func:`magsoft_env.plan_measurements` picks at the guess ``base`` (gravity alone first)."""
    import magsoft_env as ms

    if (n, both_directions) not in _PLANS:
        _PLANS[n, both_directions] = ms.plan_measurements(base, n=n, noise=1e-4, max_field=4e-3, spread=0.3,
                                                          both_directions=both_directions).fields
    return _PLANS[n, both_directions]


def case(seed: int, design: str = "random"):
    import magsoft_env as ms

    rng = np.random.default_rng(seed)
    base = ms.Beam(25e-3, 5e-3, 1.13e-3)
    mat = base.material
    e0 = mat.E0 * rng.uniform(0.7, 1.3)
    mp = mat.particle_magnetization * rng.uniform(0.7, 1.3)
    truth = dataclasses.replace(base, material=dataclasses.replace(mat, E0=e0, particle_magnetization=mp))
    n = int(rng.integers(5, 11))
    noise = float(rng.uniform(0.05e-3, 0.1e-3))
    data = []
    plan = None
    if design == "planned":
        plan = planned_fields(base, n)
    elif design == "paired":
        plan = planned_fields(base, n - 1 + n % 2, both_directions=True)
    for k in range(n):
        a = rng.uniform(0, 2 * np.pi)
        B = (0.0 if k == 0 else rng.uniform(0.5e-3, 4e-3)) * np.array([np.cos(a), np.sin(a)])
        if plan is not None:  # the same draws as the random design, so the truth and the noise match it
            if k >= len(plan):
                continue
            B = np.array(plan[k])
        r = ms.solve_equilibrium(truth, tuple(B), gravity=9.81, model="planar")
        tip = r.tip_position[[0, 2]] + rng.normal(scale=noise, size=2)
        data.append((tuple(B), tip))
    return base, truth, data, noise


def run(seed: int, design: str = "random") -> dict:
    import magsoft_env as ms

    base, truth, data, noise = case(seed, design)
    t = time.perf_counter()
    res = ms.fit(base, data, params=("E0", "particle_magnetization"), gravity=9.81)
    wall = time.perf_counter() - t
    out = {"seed": seed, "success": res.success, "time_s": wall, "n": len(data), "noise_mm": noise * 1e3}
    out.update(recovery(res, {"E0": truth.material.E0,
                              "particle_magnetization": truth.material.particle_magnetization}))
    return out


def recovery(res, truths: dict) -> dict:
    """For each parameter of ``truths`` (its true value): the fit's relative error, whether its 95 % interval
    covers the truth and its relative 1-sigma, as ``<p>_rel_error``, ``<p>_covered``, ``<p>_rel_sigma``."""
    out = {}
    for p, true in truths.items():
        lo, hi = res.interval95[p]
        out[p + "_rel_error"] = res.values[p] / true - 1.0
        out[p + "_covered"] = bool(lo <= true <= hi)
        out[p + "_rel_sigma"] = res.sigma[p] / res.values[p]
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--design", choices=("random", "planned", "paired"), default="planned",
                    help="the fields: random directions at 0.5-4 mT, those plan_measurements picks (default), or "
                         "its pairs B, -B")
    a = ap.parse_args(argv)
    if a.seeds < 1:
        ap.error(f"--seeds must be at least 1, got {a.seeds}")
    print(f"design: {a.design}", flush=True)
    rows = []
    for s in range(a.first, a.first + a.seeds):
        r = run(s, a.design)
        rows.append(r)
        print(f"seed {s:3d}  n={r['n']:2d} noise={r['noise_mm']:.3f} mm  E0 {r['E0_rel_error']:+.4%} "
              f"(sigma {r['E0_rel_sigma']:.3%}, covered {r['E0_covered']})  "
              f"M_p {r['particle_magnetization_rel_error']:+.4%} "
              f"(covered {r['particle_magnetization_covered']})  {r['time_s']:.2f} s  success {r['success']}",
              flush=True)
    k = len(rows)
    for p in ("E0", "particle_magnetization"):
        err = np.array([abs(r[p + "_rel_error"]) for r in rows])
        cov = sum(r[p + "_covered"] for r in rows)
        print(f"{p}: max |rel error| {err.max():.3%}, median {np.median(err):.3%}, "
              f"within 1 %: {int((err < 0.01).sum())}/{k}; "
              f"95 % interval covers the truth: {cov}/{k}")
    t = np.array([r["time_s"] for r in rows])
    ok = sum(r["success"] for r in rows)
    print(f"time per fit: median {np.median(t):.2f} s, max {t.max():.2f} s; successes {ok}/{k}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

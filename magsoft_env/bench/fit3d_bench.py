"""Synthetic round trips of ``magsoft_env.fit`` on the 3D rod: E0, M_p, the width and the Poisson ratio from noisy
3D tip positions under fields with a B_y component, many seeds.

For each seed a "true" paper strip has E0 and M_p drawn within +-30 % of the paper's, the width within +-15 % and
the Poisson ratio in [0.3, 0.5]; its tips (x, y, z) under 5-8 loads (gravity alone, then random field directions
in 3D at 0.5-3 mT, with gravity) are computed by the 3D solver and perturbed by Gaussian noise of 0.02-0.05 mm; the
fit (``model="auto"``: 3D) starts from the paper's values. Prints the relative errors, the 1-sigma uncertainties,
whether each 95 % interval covers the truth, the largest correlation and the time per fit::

    python -m magsoft_env.bench.fit3d_bench --seeds 20
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import numpy as np

PARAMS = ("E0", "particle_magnetization", "width", "poisson_ratio")


def case(seed: int):
    import magsoft_env as ms

    rng = np.random.default_rng(seed)
    base = ms.Beam(25e-3, 5e-3, 1.13e-3)
    mat = base.material
    e0, mp = mat.E0 * rng.uniform(0.7, 1.3), mat.particle_magnetization * rng.uniform(0.7, 1.3)
    truth = dataclasses.replace(base, width=base.width * rng.uniform(0.85, 1.15), material=dataclasses.replace(
        mat, E0=e0, particle_magnetization=mp, poisson_ratio=rng.uniform(0.3, 0.5)))
    n = int(rng.integers(5, 9))
    noise = float(rng.uniform(0.02e-3, 0.05e-3))
    data = []
    while len(data) < n:
        v = rng.normal(size=3)
        B = (0.0 if not data else rng.uniform(0.5e-3, 3e-3)) * v / np.linalg.norm(v)
        r = ms.solve_equilibrium(truth, tuple(B), gravity=9.81, model="3d")
        if not r.success or r.snap_through:  # keep loads away from folds (the fit's derivatives need a regular one)
            continue
        data.append((tuple(B), r.tip_position + rng.normal(scale=noise, size=3)))
    return base, truth, data, noise


def _truth(beam, p):
    return {"E0": beam.material.E0, "particle_magnetization": beam.material.particle_magnetization,
            "width": beam.width, "poisson_ratio": beam.material.poisson_ratio}[p]


def run(seed: int, restarts: int = 4) -> dict:
    import magsoft_env as ms

    base, truth, data, noise = case(seed)
    t = time.perf_counter()
    try:
        res = ms.fit(base, data, params=PARAMS, gravity=9.81, restarts=restarts)
    except ValueError as e:  # e.g. a start at a fold
        return {"seed": seed, "success": False, "error": str(e), "time_s": time.perf_counter() - t, "n": len(data),
                "noise_mm": noise * 1e3}
    wall = time.perf_counter() - t
    out = {"seed": seed, "success": res.success, "time_s": wall, "n": len(data), "noise_mm": noise * 1e3,
           "model": res.model, "iterations": res.iterations,
           "max_correlation": float(np.max(np.abs(res.correlation[~np.eye(len(PARAMS), dtype=bool)])))}
    from .fit_bench import recovery

    out.update(recovery(res, {p: _truth(truth, p) for p in PARAMS}))
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first", type=int, default=0)
    ap.add_argument("--restarts", type=int, default=4)
    a = ap.parse_args(argv)
    rows = []
    for s in range(a.first, a.first + a.seeds):
        r = run(s, a.restarts)
        rows.append(r)
        if "error" in r:
            print(f"seed {s:3d}  refused: {r['error']}", flush=True)
            continue
        errs = "  ".join(f"{p} {r[p + '_rel_error']:+.3%} (sigma {r[p + '_rel_sigma']:.2%})" for p in PARAMS)
        print(f"seed {s:3d}  n={r['n']} noise={r['noise_mm']:.3f} mm  {errs}  max |corr| {r['max_correlation']:.3f}  "
              f"{r['time_s']:.2f} s  success {r['success']}", flush=True)
    done = [r for r in rows if "error" not in r]
    k = len(done)
    for p in PARAMS:
        err = np.array([abs(r[p + "_rel_error"]) for r in done])
        sig = np.array([r[p + "_rel_sigma"] for r in done])
        cov = sum(r[p + "_covered"] for r in done)
        print(f"{p}: median |rel error| {np.median(err):.3%}, max {err.max():.3%}; median sigma {np.median(sig):.3%}; "
              f"95 % interval covers the truth: {cov}/{k}")
    t = np.array([r["time_s"] for r in done])
    corr = np.array([r["max_correlation"] for r in done])
    ok = sum(r["success"] for r in done)
    print(f"largest |correlation|: median {np.median(corr):.3f}, max {corr.max():.3f}")
    print(f"time per fit: median {np.median(t):.2f} s, max {t.max():.2f} s; successes {ok}/{len(rows)} "
          f"({len(rows) - k} refused)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

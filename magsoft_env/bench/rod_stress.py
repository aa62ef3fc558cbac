"""Stress benchmark of the 3D rod solver: random valid cases, every success checked independently.

    python -m magsoft_env.bench.rod_stress --cases 1000 [--seed 0] [--out rod_stress.json]

Draws random strips (length 10-40 mm, thickness 0.5-2 mm, width 2-8 mm, volume fraction 0.05-0.3),
magnetizations (a planar angle, alternating cells, a 3D direction, cells with a width component),
supports (cantilever with or without gravity, free-free) and fields up to ``--max-field-mT`` in any
direction, and classifies every result: success verified by the check below (residual <= 1e-8 rad),
success NOT verified (a wrong answer reported as a success: must be 0), an honest failure (a status
and a message), or an internal exception (must be 0).

The check is written here, independently of the solver: on a uniform mesh of ``--points`` points per
smooth piece it takes the claimed frames ``result.at(s)``, integrates the moment the loads imply from
the free tip by composite Simpson, ``m(s) = int_s^L (d3 x n + (A B_r / mu0) (R m_hat) x B)`` with
``n = -g int_s^L rho A`` along z, takes the curvature it implies, ``k = diag(E I_w, E I_s, G J)^-1 R^T m``,
integrates the frames back from the start of each piece, ``R(a) + int_a^s R [k]x`` (Simpson again), and
reports the largest distance (matrix 2-norm: an angle) from the claimed frames; a free strip adds the
net moment ``L |m(0)| / E I_w``. Its own error falls as h^4; a case above the tolerance is measured
again 4x finer.
"""

from __future__ import annotations

import argparse
import math
import time
import traceback
import warnings
from collections import Counter

import numpy as np
from scipy.integrate import cumulative_simpson

import magsoft_env as ms

VERIFY_TOL = 1e-8


def random_case(rng: np.random.Generator, max_field: float) -> dict:
    """One random valid case: beam, field (T, three components), gravity, support, and a description."""
    L, h, w = rng.uniform(10e-3, 40e-3), rng.uniform(0.5e-3, 2e-3), rng.uniform(2e-3, 8e-3)
    kind = str(rng.choice(["angle", "cells", "direction", "cells+width"]))
    if kind == "angle":
        mag = float(rng.uniform(-math.pi, math.pi))
    elif kind == "cells":
        mag = ms.alternating_cells(int(rng.integers(2, 6)))
    elif kind == "direction":
        mag = tuple(float(v) for v in rng.standard_normal(3))
    else:
        cells = ms.alternating_cells(int(rng.integers(2, 4)))
        mag = (cells, float(rng.standard_normal()), float(rng.standard_normal()))
    beam = ms.Beam(length=L, width=w, thickness=h, magnetization=mag, volume_fraction=float(rng.uniform(0.05, 0.3)))
    support = "free" if rng.random() < 0.25 else "cantilever"
    g = 0.0 if support == "free" or rng.random() < 0.3 else 9.81
    d = rng.standard_normal(3)
    field = tuple(float(v) for v in rng.uniform(0.0, max_field) * d / np.linalg.norm(d))
    desc = f"{kind} L={L * 1e3:.1f}mm h={h * 1e3:.2f}mm {support} g={g} B={np.round(np.array(field) * 1e3, 2)}mT"
    return {"beam": beam, "field": field, "gravity": g, "support": support, "desc": desc}


def _skew(v):
    o = np.zeros(len(v))
    return np.stack([np.stack([o, -v[:, 2], v[:, 1]], 1), np.stack([v[:, 2], o, -v[:, 0]], 1),
                     np.stack([-v[:, 1], v[:, 0], o], 1)], 1)


def _moment(res, case, a: float, b: float, points: int, m_after: np.ndarray, mass_after: float):
    """Frames, stiffnesses and the load moment on a uniform mesh of [a, b] (the moment beyond b is ``m_after``)."""
    beam, B, g = case["beam"], np.asarray(case["field"]), case["gravity"]
    s = np.linspace(a, b, points)
    s_in = np.clip(s, a + 1e-9 * (b - a), b - 1e-9 * (b - a))  # one-sided coefficients at the piece's ends
    _, R = res.at(s)
    K = beam.stiffnesses(s_in)
    mhat = beam.magnetization_direction(s_in)[:, [1, 2, 0]]  # material coordinates (width, thickness, axial)
    couple = np.cross(np.einsum("nij,nj->ni", R, beam.moment_per_length(s_in)[:, None] * mhat), B)
    beyond = cumulative_simpson(beam.mass_per_length(s_in)[::-1], x=-s[::-1], initial=0.0)[::-1] + mass_after
    n = np.zeros_like(couple)
    n[:, 2] = -g * beyond
    dens = np.cross(R[:, :, 2], n) + couple
    m = np.stack([cumulative_simpson(dens[::-1, i], x=-s[::-1], initial=0.0)[::-1] for i in range(3)], axis=1)
    return s, R, K, m + m_after, float(beyond[0])


def independent_residual(res, case, points: int = 4001) -> float:
    """Largest residual (rad) of a claimed 3D equilibrium, measured as described above: the moment from
    the tip, the curvature it implies, the frames integrated back from the clamp piece by piece."""
    beam = case["beam"]
    L = beam.length
    edges = [0.0, *beam.breakpoints(), L]
    pieces, m_after, mass_after = [], np.zeros(3), 0.0
    for a, b in reversed(list(zip(edges[:-1], edges[1:], strict=True))):
        s, R, K, m, mass_after = _moment(res, case, a, b, points, m_after, mass_after)
        m_after = m[0]
        pieces.append((s, R, K, m))
    worst = 0.0
    for s, R, K, m in reversed(pieces):
        k = np.einsum("nji,nj->ni", R, m) / K  # the curvature the moment implies
        rate = R @ _skew(k)  # R' = R [k]x
        back = R[0] + np.stack([cumulative_simpson(rate[:, i, j], x=s, initial=0.0)
                                for i in range(3) for j in range(3)], axis=1).reshape(-1, 3, 3)
        worst = max(worst, float(np.max(np.linalg.norm(back - R, ord=2, axis=(1, 2)))))
    if case["support"] == "free":
        EI = float(np.min(beam.stiffnesses(np.linspace(0.0, L, 33))[:, 0]))
        worst = max(worst, L * float(np.linalg.norm(m_after)) / EI)
    return worst


def run(n_cases: int, seed: int = 0, *, points: int = 4001, max_field: float = 40e-3, progress: bool = True) -> dict:
    """Solve ``n_cases`` random cases; returns the counts, the worst verified residual and the bad cases."""
    rng = np.random.default_rng(seed)
    counts: Counter = Counter()
    worst, bad, t0 = 0.0, [], time.perf_counter()
    for i in range(n_cases):
        case = random_case(rng, max_field)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # slenderness warnings of short thick strips
                res = ms.solve_equilibrium(case["beam"], case["field"], gravity=case["gravity"],
                                           support=case["support"], model="3d")
        except Exception:  # valid input: any exception is a defect to report
            counts["exception"] += 1
            bad.append({"case": i, "desc": case["desc"], "error": traceback.format_exc(limit=3)})
            continue
        if not res.success:
            counts[f"failure (status {res.status})"] += 1
            bad.append({"case": i, "desc": case["desc"], "message": res.message})
            continue
        r = independent_residual(res, case, points)
        if r > VERIFY_TOL:
            r = independent_residual(res, case, 4 * points - 3)
        if r <= VERIFY_TOL:
            counts["success, verified"] += 1
            worst = max(worst, r)
        else:
            counts["success, NOT verified"] += 1
            bad.append({"case": i, "desc": case["desc"], "residual": r})
        if progress and (i + 1) % max(1, n_cases // 20) == 0:
            print(f"{i + 1}/{n_cases} cases, {time.perf_counter() - t0:.0f} s", flush=True)
    return {"cases": n_cases, "seed": seed, "counts": dict(counts), "worst_verified_residual": worst,
            "seconds": time.perf_counter() - t0, "bad": bad}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", type=int, default=200, help="random cases (default 200)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--points", type=int, default=4001, help="check points per smooth piece (default 4001)")
    ap.add_argument("--max-field-mT", type=float, default=40.0, help="largest field magnitude (default 40 mT)")
    ap.add_argument("--out", default=None, help="write the full report (JSON) here")
    args = ap.parse_args(argv)
    if not 1 <= args.cases <= 1_000_000 or not 101 <= args.points <= 1_000_001 or not 0 < args.max_field_mT <= 1000:
        raise SystemExit("--cases in [1, 1e6], --points in [101, 1e6], --max-field-mT in (0, 1000]")
    rep = run(args.cases, args.seed, points=args.points, max_field=args.max_field_mT * 1e-3)
    for k, v in sorted(rep["counts"].items()):
        print(f"{k:>24}: {v}")
    print(f"worst independent residual of a verified success: {rep['worst_verified_residual']:.2e} rad "
          f"(tolerance {VERIFY_TOL:g}); {rep['seconds']:.0f} s")
    for b in rep["bad"][:20]:
        print("  ", b)
    if args.out:
        from magsoft_env.io import write_json

        write_json(args.out, rep)
    ok = rep["counts"].get("exception", 0) == 0 and rep["counts"].get("success, NOT verified", 0) == 0
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())

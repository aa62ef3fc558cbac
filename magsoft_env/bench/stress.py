"""Stress benchmark of the analytical solver: random valid cases, every success checked independently.

    python -m magsoft_env.bench.stress --cases 10000 [--seed 0] [--out stress.json]

Draws random beams (length 10-40 mm, thickness 0.5-2 mm, width 2-8 mm), profiles (uniform,
cells, smooth beta(s), spline jigs through random points, jigs from a function with a corner,
steps in the particle fraction), supports (cantilever, free-free), couplings (rotated, paper),
axial strain on or off, loads up to Lambda = 500 and G = 100 (gravity 0 for free-free beams) and
any field angle, antiparallel and straight down included. Every result is classified:

- success, verified: the independent check below finds a residual <= 1e-8 rad;
- success, NOT verified: the solver said success but the check finds more (a wrong answer
  reported as a success: the count must be 0);
- failure with a status and a message (an honest failure);
- internal exception (anything but a ValueError for these valid inputs: the count must be 0).

The check is written here, independently of the solver (its own load formula, in the angle form
``(EI theta')' = (1 + eps) (m cos(beta) B sin(theta - alpha) + W cos(theta)) + m sin(beta) B
cos(theta - alpha)``, its own quadrature, its own points): the claimed shape ``result.at(s)`` on
a uniform mesh of about ``--points`` points along the beam, split into pieces at the beam's
breakpoints and at the knots of spline profiles (at least 65 points per piece), composite
Simpson integration from the tip (inner, the bending moment) and from the clamp (outer), and the
residual ``theta(s) - theta(0) + int_0^s M / EI`` at every mesh point with the boundary condition
(theta(0) = theta_0; zero net moment for a free-free beam). The check's own error falls as h^4
(measured: 3e-7, 2e-8, 1e-9, 8e-11, 5e-12 rad at 501-8001 points on a Lambda = 330 sine-profile
beam whose solution the solver verifies to 3e-13).
"""

from __future__ import annotations

import argparse
import math
import time
import traceback
from collections import Counter

import numpy as np
from scipy.integrate import cumulative_simpson

import magsoft_env as ms

VERIFY_TOL = 1e-8
#: Spline knots that cut the check's pieces (denser knot sets: their third-derivative jumps are negligible).
MAX_KNOT_CUTS = 100


def random_case(rng: np.random.Generator) -> dict:
    """One random valid case: the beam, field, gravity and solver options, plus a description."""
    L = rng.uniform(10e-3, 40e-3)
    h = rng.uniform(0.5e-3, 2e-3)
    w = rng.uniform(2e-3, 8e-3)
    kind = rng.choice(["uniform", "cells", "smooth", "spline-jig", "corner-jig", "phi-steps"])
    phi = float(rng.uniform(0.05, 0.4))
    if kind == "uniform":
        beta = float(rng.uniform(-math.pi, math.pi))
    elif kind == "cells":
        beta = ms.PiecewiseConstant(list(rng.uniform(-math.pi, math.pi, int(rng.integers(2, 7)))))
    elif kind == "smooth":
        amp, k = float(rng.uniform(0, 2.5)), float(rng.uniform(0.2, 3.0))
        beta = ms.Function(lambda s, amp=amp, k=k, L=L: amp * np.sin(2 * np.pi * k * s / L))
    elif kind == "spline-jig":
        n = int(rng.integers(4, 9))
        x = np.linspace(0.0, L * rng.uniform(0.6, 0.95), n)
        z = rng.uniform(-0.25, 0.25, n) * L
        beta = ms.jig_from_points(x, z)
    elif kind == "corner-jig":
        a, c = float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.3, 0.3))
        beta = ms.jig_from_function(lambda x, a=a, c=c: np.where(x < 0.5, a * x, a * 0.5 + c * (x - 0.5)),
                                    0.0, 1.0, unit=L, kinks=[0.5])
    else:
        beta = 0.0
        phi = ms.PiecewiseConstant(list(rng.uniform(0.05, 0.4, int(rng.integers(2, 5)))))
    length = beta.length if hasattr(beta, "length") and beta.length else L
    beam = ms.Beam(length=length, width=w, thickness=h, volume_fraction=phi, magnetization=beta)
    support = "free" if rng.random() < 0.2 else "cantilever"
    groups = beam.nondimensional_groups((0.0, 1.0))  # Lambda per tesla, G at g = 9.81
    lam = float(rng.uniform(0.0, 500.0))
    G = 0.0 if support == "free" else float(rng.uniform(0.0, 100.0))
    B = min(lam / groups["Lambda"], 0.9)
    r = rng.random()
    alpha = math.pi if r < 0.15 else (-math.pi / 2 if r < 0.3 else float(rng.uniform(-math.pi, math.pi)))
    if support == "free" and B == 0.0:
        B = 1e-3
    return {
        "beam": beam, "field": ms.Field.polar(B, alpha), "gravity": G / groups["G"] * 9.81 if G else 0.0,
        "support": support, "coupling": str(rng.choice(["rotated", "paper"])), "extensible": bool(rng.random() < 0.3),
        "describe": f"{kind}, {support}, L={length * 1e3:.1f} mm, h={h * 1e3:.2f} mm, Lambda={lam:.0f}, G={G:.0f}, "
                    f"alpha={math.degrees(alpha):.0f} deg",
    }


def _load_density(beam, s_in, s, theta, field, g, coupling, extensible):
    """f (N) in the angle form of the module docstring, from the beam specification (profiles
    evaluated at ``s_in``, integrals over the mesh ``s``)."""
    B, alpha = field.magnitude, field.angle
    m, beta = beam.moment_per_length(s_in), beam.beta(s_in)
    mc = m * np.cos(beta)
    ms_ = m * np.sin(beta) if coupling == "rotated" else 0.0
    W = g * _from_tip(s, beam.mass_per_length(s_in)) if g else 0.0
    eps = (mc * B * np.cos(theta - alpha) - W * np.sin(theta)) / beam.axial_stiffness(s_in) if extensible else 0.0
    return (1.0 + eps) * (mc * B * np.sin(theta - alpha) + W * np.cos(theta)) + ms_ * B * np.cos(theta - alpha)


def _knots_of(beam):
    # versions before Beam.spline_knots: the knots of spline jigs
    return tuple(float(v) for ps, _ in getattr(beam.magnetization, "pieces", None) or () for v in ps[1:-1])


def _pieces(beam, n):
    """Mesh points of every smooth piece, and where to evaluate the beam's profiles there (the end
    points nudged into their own piece, so that a profile's jump is seen from the right side)."""
    cuts = set(beam.breakpoints())
    knots = beam.spline_knots() if hasattr(beam, "spline_knots") else _knots_of(beam)  # third derivative jumps
    if len(knots) <= MAX_KNOT_CUTS:  # dense knots (a sampled jig function) have negligible jumps
        cuts.update(knots)
    edges = [0.0, *sorted(cuts), beam.length]
    edges = [e for i, e in enumerate(edges) if i == 0 or e - edges[i - 1] > 1e-9 * beam.length]
    delta = 1e-13 * beam.length
    L = beam.length
    # about n points in all, in proportion to the pieces' lengths, at least 65 per piece (odd counts)
    counts = [max(65, 2 * math.ceil(0.5 * n * (b - a) / L) + 1) for a, b in zip(edges[:-1], edges[1:], strict=True)]
    mesh = [np.linspace(a, b, k) for a, b, k in zip(edges[:-1], edges[1:], counts, strict=True)]
    inside = [np.clip(m, m[0] + delta, m[-1] - delta) for m in mesh]
    return np.concatenate(mesh), np.concatenate(inside)


def _from_tip(s_all, values):
    """int_s^L of values sampled on the concatenated pieces (each piece's first point repeats the
    previous piece's last): composite Simpson per piece, accumulated from the tip."""
    out = np.empty_like(values)
    pieces = _split(s_all)
    acc = 0.0
    for idx in reversed(pieces):
        s, v = s_all[idx], values[idx]
        part = cumulative_simpson(v[::-1], x=-s[::-1], initial=0.0)[::-1]  # int_s^{end of piece}
        out[idx] = part + acc
        acc += part[0]
    return out


def _from_start(s_all, values):
    out = np.empty_like(values)
    acc = 0.0
    for idx in _split(s_all):
        part = cumulative_simpson(values[idx], x=s_all[idx], initial=0.0)
        out[idx] = part + acc
        acc += part[-1]
    return out


def _split(s_all):
    starts = np.flatnonzero(np.diff(s_all) == 0.0) + 1  # a repeated point starts a new piece
    bounds = [0, *starts.tolist(), s_all.size]
    return [np.arange(a, b) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _residual_on(beam, res, case, s, s_in):
    _, _, theta = res.at(np.clip(s, 0.0, beam.length))
    f = _load_density(beam, s_in, s, theta, res.field, case["gravity"], case["coupling"], case["extensible"])
    moment = _from_tip(s, f)
    return theta - theta[0] + _from_start(s, moment / beam.bending_stiffness(s_in)), theta, moment


def independent_residual(res, case, points: int = 4001) -> float:
    """Largest residual (rad) of ``res`` against the equations, by the independent check above.

    Its own error falls as h^4, so a residual above a tenth of the tolerance is measured again on
    a mesh 4 and then 16 times finer, and the finest value counts (a coarse check must not call a
    good solution bad, nor a finer one a bad solution good)."""
    r = _independent(res, case, points)
    for k in (4, 16):
        if r <= 0.1 * VERIFY_TOL:
            break
        r = _independent(res, case, k * (points - 1) + 1)
    return r


def _independent(res, case, points):
    beam = case["beam"]
    s, s_in = _pieces(beam, points)
    r, theta, moment = _residual_on(beam, res, case, s, s_in)
    worst = float(np.max(np.abs(r)))
    if case["support"] == "cantilever":
        worst = max(worst, abs(float(theta[0]) - 0.0))
    else:
        worst = max(worst, beam.length * abs(float(moment[0])) / float(np.min(beam.bending_stiffness(s_in))))
    return worst if math.isfinite(worst) else math.inf


def run(n_cases: int, seed: int = 0, *, points: int = 4001, progress: bool = True, options=None) -> dict:
    """Solve ``n_cases`` random cases and classify them (see the module docstring)."""
    rng = np.random.default_rng(seed)
    counts = Counter()
    statuses = Counter()
    worst_verified = 0.0
    bad, errors = [], []
    t0 = time.perf_counter()
    solve_s = 0.0
    it = range(n_cases)
    if progress:
        from tqdm.auto import tqdm

        it = tqdm(it, desc="stress", unit="case", mininterval=2.0)
    for i in it:
        case = random_case(rng)
        try:
            ts = time.perf_counter()
            res = ms.solve_equilibrium(case["beam"], case["field"], gravity=case["gravity"], support=case["support"],
                                       coupling=case["coupling"], extensible=case["extensible"], options=options)
            solve_s += time.perf_counter() - ts
        except Exception as exc:  # noqa: BLE001 - counting them is the point
            counts["internal exception" if not isinstance(exc, ValueError) else "ValueError on valid input"] += 1
            errors.append({"case": i, "describe": case["describe"], "error": f"{type(exc).__name__}: {exc}",
                           "traceback": traceback.format_exc(limit=3)})
            continue
        statuses[res.status] += 1
        if not res.message:
            counts["failure without a message"] += 1
        if res.success:
            r = independent_residual(res, case, points)
            if r <= VERIFY_TOL:
                counts["success, verified"] += 1
                worst_verified = max(worst_verified, r)
            else:
                counts["success, NOT verified"] += 1
                bad.append({"case": i, "describe": case["describe"], "independent_residual": r,
                            "solver_verification": getattr(res, "verification", math.nan), "status": res.status,
                            "nodes": res.nodes})
        else:
            counts[f"failure, status {res.status}"] += 1
    return {
        "cases": n_cases, "seed": seed, "counts": dict(counts), "statuses": {str(k): v for k, v in statuses.items()},
        "worst_verified_residual_rad": worst_verified, "wall_s": time.perf_counter() - t0, "solve_s": solve_s,
        "not_verified": bad, "exceptions": errors,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", type=int, default=1000, help="random cases (default 1000)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--points", type=int, default=4001, help="check points along the beam (default 4001)")
    ap.add_argument("--out", default=None, help="write the full report (JSON) here")
    args = ap.parse_args(argv)
    if not 1 <= args.cases <= 10**6 or not 101 <= args.points <= 100001 or args.points % 2 == 0:
        ap.error("--cases must be in [1, 1e6] and --points an odd integer in [101, 100001]")
    rep = run(args.cases, args.seed, points=args.points)
    print(f"{rep['cases']} random valid cases (seed {rep['seed']}), {rep['wall_s']:.1f} s "
          f"({rep['solve_s']:.1f} s solving), independent check at ~{args.points} points along the beam:")
    for k in sorted(rep["counts"]):
        print(f"  {k:<32} {rep['counts'][k]:>7}")
    print(f"  statuses: {rep['statuses']}")
    print(f"  worst independent residual of a verified success: {rep['worst_verified_residual_rad']:.2e} rad "
          f"(tolerance {VERIFY_TOL:g})")
    for b in rep["not_verified"][:10]:
        print(f"  NOT VERIFIED case {b['case']}: {b['describe']}: residual {b['independent_residual']:.2e} rad")
    for e in rep["exceptions"][:10]:
        print(f"  EXCEPTION case {e['case']}: {e['describe']}: {e['error']}")
    if args.out:
        from magsoft_env.io import write_json

        write_json(args.out, rep)
    return 0 if not rep["not_verified"] and not rep["exceptions"] else 1


if __name__ == "__main__":
    raise SystemExit(main())


__all__ = ["independent_residual", "random_case", "run"]

"""Benchmark: the 3D rod solver against scipy ``solve_bvp`` on the same boundary-value problem, same process.

Run: ``python -m magsoft_env.bench.rod_bench`` (add ``--quick`` for a short run).

``solve_bvp`` gets a formulation of its own, written from the equations of the static
Kirchhoff rod (inextensible, unshearable, dead loads) and sharing no code with the solver: the
state is ``y = (q, m, n, r, tw)``, the frame as a unit quaternion body -> world (scalar first;
``[d1 d2 d3] = R(q)``, d1 across the width, d2 through the thickness, d3 the tangent), the
spatial internal moment and force, the position and the accumulated twist::

    q' = 1/2 q (0, k),   k = K^-1 R^T m,   K = diag(E I_w, E I_s, G J)
    m' = -(d3 x n) - c,  c = (A B_r / mu0) (R m_hat) x B
    n' = -f = rho A g z,    r' = d3,    tw' = k3
    q(0) = q_clamp,  m(L) = 0,  n(L) = 0,  r(0) = 0,  tw(0) = 0

non-dimensionalized (s/L, moments in E I_w / L, forces in E I_w / L^2, lengths in L) so that
its tolerance is meaningful. It has no continuation of its own: along a path it starts from the
previous solution, resampled on 101 even nodes (gravity first, in 4 steps), and sub-steps a load
step when a solve fails or jumps (tip moves more than 0.3 L, or twists more than 0.3 rad), as a careful user would.

Cases (paper strip 25 x 5 x 1.13 mm, phi 0.2), each a ramp of fields from zero:
``a`` field across the width below lateral-torsional buckling (elastica in the x-y plane on
E I_s); ``b`` magnetization across the width, field along z (pure twist: elastica on G J);
``c`` a general 3D case with gravity; ``d`` a strongly bent 3D path with gravity. The
reference is the closed form for a and b and the 3D solver on a fine fixed grid for c and d,
checked against ``solve_bvp`` at ``tol=1e-10``. ``solve_bvp`` gets the loosest tolerance of a
ladder whose worst error along the path is at most the 3D solver's at default settings, or
1e-8 (tip position / L and twist in rad) if that is larger ("matched accuracy"); then both run
the path in interleaved rounds.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
from scipy.integrate import solve_bvp

import magsoft_env as ms
from magsoft_env.theory import SolverOptions, elastica_tip

FLOOR = 1e-8  # matched accuracy is never asked below this (tip / L, twist rad)
LADDER = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10)
REF_OPTIONS = SolverOptions(nodes=80, tol=1e-14)
#: Clamp frame [d1 d2 d3] = [y z x] (columns): a third of a turn about (1, 1, 1).
Q_CLAMP = np.array([0.5, 0.5, 0.5, 0.5])
_JUMP = 0.3  # a converged load step that moves the tip more than this (L, or rad of twist) is refused


def _beam(magnetization=0.0):
    return ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, volume_fraction=0.2, magnetization=magnetization)


# ---- scipy solve_bvp formulation -----------------------------------------------------------------
def _frame(q):
    """Directors d1, d2, d3 (each (3, m)) of quaternions q (4, m), homogeneous in q (any non-zero norm)."""
    w, x, y, z = q
    nn = w * w + x * x + y * y + z * z
    d1 = np.array([w * w + x * x - y * y - z * z, 2 * (x * y + w * z), 2 * (x * z - w * y)]) / nn
    d2 = np.array([2 * (x * y - w * z), w * w - x * x + y * y - z * z, 2 * (y * z + w * x)]) / nn
    d3 = np.array([2 * (x * z + w * y), 2 * (y * z - w * x), w * w - x * x - y * y + z * z]) / nn
    return d1, d2, d3


class BvpRod:
    """The rod's boundary-value problem for ``solve_bvp`` (dimensionless; see the module docstring)."""

    def __init__(self, beam):
        self.beam = beam
        self.L = float(beam.length)
        self.EI = float(beam.stiffnesses(np.array([0.0]))[0, 0])

    def coefficients(self, sig):
        s = np.asarray(sig) * self.L
        K = np.asarray(self.beam.stiffnesses(s), dtype=float).T / self.EI  # (3, m)
        mhat = np.asarray(self.beam.magnetization_direction(s), dtype=float).T  # (axial, width, thickness)
        a = self.beam.moment_per_length(s) * self.L**2 / self.EI * mhat[[1, 2, 0]]  # material (d1, d2, d3)
        rho = self.beam.mass_per_length(s) * self.L**3 / self.EI
        return K, a, rho

    def rhs(self, sig, y, B, g):
        K, a, rho = self.coefficients(sig)
        q, m, n = y[0:4], y[4:7], y[7:10]
        d1, d2, d3 = _frame(q)
        k = np.array([np.sum(d1 * m, 0), np.sum(d2 * m, 0), np.sum(d3 * m, 0)]) / K
        w, x, yq, z = q
        dq = 0.5 * np.array([-x * k[0] - yq * k[1] - z * k[2],
                             w * k[0] + yq * k[2] - z * k[1],
                             w * k[1] + z * k[0] - x * k[2],
                             w * k[2] + x * k[1] - yq * k[0]])
        Ra = a[0] * d1 + a[1] * d2 + a[2] * d3
        c = np.cross(Ra, np.asarray(B)[:, None], axis=0)
        dm = -np.cross(d3, n, axis=0) - c
        dn = np.zeros_like(n)
        dn[2] = rho * g
        return np.vstack([dq, dm, dn, d3, k[2:3]])

    @staticmethod
    def bc(ya, yb):
        return np.concatenate([ya[0:4] - Q_CLAMP, yb[4:7], yb[7:10], ya[10:13], ya[13:14]])

    def solve(self, load, mesh, y, tol, max_nodes=20000):
        """One equilibrium for ``load = (Bx, By, Bz, g)`` from the guess (mesh, y)."""
        B, g = np.array(load[:3]), load[3]
        return solve_bvp(lambda s, yy: self.rhs(s, yy, B, g), self.bc, mesh, y, tol=tol, max_nodes=max_nodes)

    def straight(self, n_mesh=41):
        mesh = np.linspace(0.0, 1.0, n_mesh)
        y = np.zeros((14, mesh.size))
        y[0:4] = Q_CLAMP[:, None]
        y[10] = mesh
        return mesh, y


def _tip(y):
    return np.concatenate([y[10:13, -1], y[13:14, -1]])  # tip position / L, twist (rad)


def bvp_path(beam, fields, g, tol, n_mesh=101):
    """solve_bvp along ``fields`` (warm starts; gravity first in 4 steps; load sub-stepping).

    Each solve starts from the previous solution sampled on ``n_mesh`` even nodes (solve_bvp only adds
    nodes: started on the previous mesh, the mesh grows along a path, to ten thousand nodes and more
    at tol 1e-7, and each solve gets slower without getting more accurate).

    Returns ([(converged, tip position / L (3,), tip twist (rad), mesh nodes)] per field, times (s) per field,
    the last solution (mesh, y))."""
    rod = BvpRod(beam)
    grid, y0 = rod.straight(n_mesh)
    mesh, y, interp = grid, y0, None
    loads = [(0.0, 0.0, 0.0, g * k / 4) for k in range(1, 5)] if g > 0 else []
    loads += [(*(float(v) for v in f.vector()), g) for f in fields]
    prev = np.zeros(4)
    out, times = [], []
    for i, load in enumerate(loads):
        t0 = time.perf_counter()
        target = np.array(load)
        frac, step, ok = 0.0, 1.0, True
        while frac < 1.0:
            trial = min(1.0, frac + step)
            sol = rod.solve(prev + trial * (target - prev), grid, y0 if interp is None else interp(grid), tol)
            if sol.success and np.max(np.abs(_tip(sol.y) - _tip(y))) < _JUMP:
                frac, mesh, y, interp = trial, sol.x, sol.y, sol.sol
                step = min(1.0, 2 * step)
            else:
                step /= 2
                if step < 1e-3:
                    ok = False
                    break
        prev = target if ok else prev + frac * (target - prev)
        dt = time.perf_counter() - t0
        if i >= len(loads) - len(fields):
            out.append((ok, y[10:13, -1].copy(), float(y[13, -1]), y.shape[1]))
            times.append(dt)
    return out, times, (mesh, y)


def bvp_cold(beam, field, g, tol, n=8):
    """solve_bvp from zero load, with its own ramp of ``n`` fields (it cannot start cold)."""
    t0 = time.perf_counter()
    res, _, _ = bvp_path(beam, ms.ramp((0, 0, 0), field, n, include_start=False), g, tol)
    return time.perf_counter() - t0, res[-1]


# ---- cases -----------------------------------------------------------------------------------------
def _elastica_ref(beam, fields, which):
    L = beam.length
    F0 = float(beam.moment_per_length(0.0))
    Ks = beam.stiffnesses(np.array([0.0]))[0]
    tips, tw = [], []
    for f in fields:
        B = float(np.linalg.norm(f.vector()))
        if which == "a":  # bending in the x-y plane on E I_s
            _, x, yy = elastica_tip(F0 * B, np.pi / 2, float(Ks[1]), L)
            tips.append([x / L, yy / L, 0.0])
            tw.append(0.0)
        else:  # pure twist on G J
            tips.append([1.0, 0.0, 0.0])
            tw.append(elastica_tip(F0 * B, np.pi / 2, float(Ks[2]), L)[0])
    return np.array(tips), np.array(tw)


def cases(quick: bool):
    """(name, beam, fields (ramp from zero, start included), gravity, closed-form reference or None)."""
    n = 5 if quick else 9
    out = []
    fa = ms.ramp((0, 0, 0), (0, 0.5e-3, 0), n)
    out.append(("a: B across width", _beam(), fa, 0.0, "a"))
    fb = ms.ramp((0, 0, 0), (0, 0, 3e-3), n)
    out.append(("b: twist (m wide)", _beam((0.0, 1.0, 0.0)), fb, 0.0, "b"))
    fc = ms.ramp((0, 0, 0), (1e-3, 2e-3, 5e-3), n)
    out.append(("c: general 3D, g", _beam((0.3, 0.8, 0.5)), fc, 9.81, None))
    fd = ms.ramp((0, 0, 0), (0, 0.6e-3, 13e-3), 11 if quick else 21)
    out.append(("d: path to 13 mT", _beam(), fd, 9.81, None))
    return out


def _ours(beam, fields, g, options=None):
    res = ms.solve_path(beam, fields, gravity=g, options=options)
    tips = np.array([r.tip_position for r in res]) / beam.length
    tw = np.array([r.tip_twist for r in res])
    return tips, tw, [r.wall_time for r in res], res


def _err(tips, tw, ref_tips, ref_tw):
    """Worst tip-position error / L and worst twist error (rad) along the path."""
    return float(np.max(np.linalg.norm(tips - ref_tips, axis=1))), float(np.max(np.abs(tw - ref_tw)))


def _bvp_arrays(bres):
    return np.array([b[1] for b in bres]), np.array([b[2] for b in bres])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="shorter paths, fewer timing rounds")
    ap.add_argument("--rounds", type=int, default=None, help="interleaved timing rounds (default 5, quick 2)")
    ap.add_argument("--only", default="abcd", help="cases to run, letters among abcd (default all)")
    args = ap.parse_args(argv)
    if not args.only or set(args.only) - set("abcd"):
        ap.error(f"--only takes letters among abcd, got {args.only!r}")
    rounds = args.rounds or (2 if args.quick else 5)
    t_start = time.perf_counter()
    hdr = (f"{'case':18s} {'method':9s} {'setting':12s} {'ms/eq':>8s} {'cold ms':>8s} {'tip err/L':>9s} "
           f"{'twist err':>9s} {'nodes':>5s} {'ratio':>6s}")
    print(hdr)
    print("-" * len(hdr), flush=True)
    checks = []
    for name, beam, fields, g, closed in cases(args.quick):
        if name[0] not in args.only:
            continue
        # reference, and its independent check
        rt, rw, _, rres = _ours(beam, fields, g, REF_OPTIONS)
        if not all(r.success for r in rres):
            print(f"{name}: the 3D reference failed: {[r.message for r in rres if not r.success][0]}")
        if closed is not None:
            ref_tips, ref_tw = _elastica_ref(beam, fields, closed)
            check = ("elastica", *_err(rt, rw, ref_tips, ref_tw))
        else:
            ref_tips, ref_tw = rt, rw
            check = None

        # the 3D solver at default settings (warm-up run first: grid caches)
        _ours(beam, fields, g)
        ot, ow, _, ores = _ours(beam, fields, g)
        e_pos, e_tw = _err(ot, ow, ref_tips, ref_tw)
        target = max(FLOOR, e_pos, e_tw)

        # solve_bvp: loosest tolerance of the ladder that reaches the target
        for tol in LADDER:
            bres, _, last = bvp_path(beam, fields, g, tol)
            bt_, bw_ = _bvp_arrays(bres)
            b_pos, b_tw = _err(bt_, bw_, ref_tips, ref_tw)
            if all(b[0] for b in bres) and max(b_pos, b_tw) <= target:
                break
        b_nodes = bres[-1][3]
        if check is None:  # solve_bvp at tol 1e-10 on the last field, from its matched solution
            f = fields[-1]
            sol = BvpRod(beam).solve((*(float(v) for v in f.vector()), g), *last, 1e-10)
            e = _err(sol.y[10:13, -1][None], sol.y[13:14, -1], ref_tips[-1:], ref_tw[-1:])
            check = ("bvp 1e-10, last" + ("" if sol.success else " (failed)"), *e)
        checks.append((name, *check))

        # interleaved timing rounds: median per equilibrium (fields after the zero field) per round,
        # then the median over rounds
        t_o, t_b = [], []
        for _ in range(rounds):
            t_o.append(statistics.median(_ours(beam, fields, g)[2][1:]))
            t_b.append(statistics.median(bvp_path(beam, fields, g, tol)[1][1:]))
        cold_o = []
        for _ in range(3):
            t0 = time.perf_counter()
            ms.solve_equilibrium(beam, fields[-1], gravity=g)
            cold_o.append(time.perf_counter() - t0)
        cold_b, _ = bvp_cold(beam, fields[-1], g, tol)
        mo, mb = statistics.median(t_o), statistics.median(t_b)
        print(f"{name:18s} {'3D rod':9s} {'default':12s} {mo * 1e3:8.2f} {min(cold_o) * 1e3:8.1f} {e_pos:9.1e} "
              f"{e_tw:9.1e} {ores[-1].nodes:5d} {'':>6s}")
        print(f"{'':18s} {'solve_bvp':9s} {f'tol {tol:.0e}':12s} {mb * 1e3:8.2f} {cold_b * 1e3:8.1f} {b_pos:9.1e} "
              f"{b_tw:9.1e} {b_nodes:5d} {mb / mo:5.0f}x", flush=True)
        if name.startswith("d"):
            per = [f"{t * 1e3:.1f}" for t in _ours(beam, fields, g)[2][1:]]
            print(f"{'':18s} 3D rod ms per equilibrium along the path: {' '.join(per)}")

    print("\nreferences (3D solver, 80 nodes, tol 1e-14) against an independent solution:")
    for name, what, e_pos, e_tw in checks:
        print(f"  {name:18s} vs {what:18s} tip {e_pos:8.1e} L   twist {e_tw:8.1e} rad")
    print(
        "\nms/eq: median wall time per equilibrium along the ramp (warm start from the previous field; the zero "
        f"field left out), median over {rounds} rounds interleaved between the two solvers; cold: one solve from "
        "zero load to the last field (3D rod: best of 3; solve_bvp: one run of its own 8-field ramp, gravity "
        "first). err: worst along the ramp against the reference (closed form for a and b, the 3D solver on 80 "
        "nodes for c and d); solve_bvp's tolerance is the loosest of 1e-3..1e-10 that reaches max(1e-8, the 3D "
        "solver's error); ratio: solve_bvp ms/eq over the 3D rod's."
        f"\ntotal {time.perf_counter() - t_start:.0f} s"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The floor friction against Coulomb's law: does a flat beam creep below the static limit,
and does it slide at mu N above it?

    python -m magsoft_env.bench.friction_check [--quick] [--json out.json]

A paper gait's beam (``paper-5c`` by default; field 0, so its magnetization plays no part) lies flat on the
floor, built exactly as the gaits build it (:func:`magsoft_env.sim.gait.gait_rod_options`: capsules, the
material contact, elliptic cone). After it has settled, every piece i is pushed along +x by
``r(t) mu m_i g`` at its centre of mass (``Simulator.external_wrench``; proportional to mass, so the flat
beam is not bent), the load ratio ``r`` growing linearly from 0 to ``r_max = 1.5`` over ``ramp`` seconds.
Coulomb's law says:

* below the limit (``r < 1``) the beam does not move at all. MuJoCo's friction rows are soft: a tangential
  load is held by a small sliding velocity ("creep"), which MuJoCo's noslip solver removes;
* above it the beam slides with ``a = (r - 1) mu g``; the *effective* friction coefficient
  ``mu_eff = (r mu g - a) / g``, fitted over the sliding phase, must equal ``mu``.

Measured with ``noslip_iterations`` 0 (the gaits' setting) and 10, at the gaits' step (0.1 ms) and the
environments' (0.2 ms). The crawl's response to noslip is in :mod:`magsoft_env.bench.crawl_convergence`
(section ``sensitivity``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import sys

import numpy as np

from magsoft_env.cases.gaits import gait_preset
from magsoft_env.sim.gait import gait_rod_options
from magsoft_env.sim.simulator import Simulator

RATIOS = (0.25, 0.5, 0.75, 0.9, 0.99)


def coulomb_ramp(gait: str = "paper-5c", *, segments: int = 20, timestep: float = 1e-4, ramp: float = 1.5,
                 r_max: float = 1.5, settle: float = 0.1, update_dt: float = 5e-4, **overrides) -> dict:
    """Ramp a horizontal load on a flat beam from 0 to ``r_max`` x the Coulomb limit over ``ramp`` s.

    Returns the friction coefficient asked for, the creep (COM travel, m) reached at the load ratios
    :data:`RATIOS`, the creep velocity (m/s) at those ratios, the fitted sliding ``mu_eff`` (over
    ``r`` in [1.1, r_max]), and its relative error against ``mu``. ``overrides``: RodOptions fields.
    """
    robot = gait_preset(gait)
    friction = overrides.pop("friction", None)
    options = dataclasses.replace(gait_rod_options(robot, segments=segments, timestep=timestep, friction=friction),
                                  **overrides)
    sim = Simulator(robot.beam, options, field=(0.0, 0.0))
    mu, g = options.friction, options.gravity
    sim.step(int(round(settle / timestep)))
    mass = np.asarray(sim.rod.disc.mass, dtype=float)
    k = max(1, int(round(update_dt / timestep)))
    nblocks = int(round(ramp / (k * timestep)))
    x0 = float(sim.center_of_mass()[0])
    t0 = sim.time
    ts, xs, rs = [0.0], [0.0], [0.0]
    for b in range(nblocks):
        r = r_max * (b + 0.5) / nblocks  # the block's mean load ratio
        sim.external_wrench[:, 0] = r * mu * mass * g
        sim.step(k)
        ts.append(sim.time - t0)
        xs.append(float(sim.center_of_mass()[0]) - x0)
        rs.append(r_max * (b + 1) / nblocks)
    t, x, rr = np.asarray(ts), np.asarray(xs), np.asarray(rs)
    v = np.gradient(x, t)
    creep = {f"{q:g}": float(np.interp(q, rr, x)) for q in RATIOS}
    creep_v = {f"{q:g}": float(np.interp(q, rr, v)) for q in RATIOS}
    # sliding, r in [1.1, r_max]: Coulomb's v(t) is quadratic (a = (r(t) - 1) mu g grows linearly); a quadratic
    # fit of v gives a(t), and mu_eff(t) = (r(t) mu g - a(t)) / g, whose mean and largest deviation are reported
    sel = rr >= 1.1
    if np.count_nonzero(sel) > 5:
        acc = np.polyval(np.polyder(np.polyfit(t[sel], v[sel], 2)), t[sel])
        mu_t = rr[sel] * mu - acc / g
        mu_eff, mu_dev = float(np.mean(mu_t)), float(np.max(np.abs(mu_t - mu)))
    else:
        mu_eff = mu_dev = math.nan
    # the velocity reached at the end against Coulomb's: v_end = mu g (r_max / ramp) (ramp - t1)^2 / 2,
    # t1 = ramp / r_max
    t1 = ramp / r_max
    v_coulomb = 0.5 * mu * g * (r_max / ramp) * (ramp - t1) ** 2
    moving = np.flatnonzero(v > 1e-3)  # 1 mm/s: sliding, not creeping
    onset = float(rr[moving[0]]) if moving.size else math.nan
    return {
        "gait": gait, "segments": segments, "timestep_ms": timestep * 1e3, "friction": mu, "ramp_s": ramp,
        "r_max": r_max, "overrides": overrides, "creep_m": creep, "creep_velocity_m_s": creep_v,
        "creep_at_limit_um": float(np.interp(1.0, rr, x)) * 1e6, "mu_eff": mu_eff,
        "mu_error": (mu_eff - mu) / mu, "mu_max_deviation": mu_dev,
        "sliding_onset_ratio": onset, "v_end_m_s": float(v[-1]), "v_end_coulomb_m_s": v_coulomb,
        "v_end_error": (float(v[-1]) - v_coulomb) / v_coulomb,
        "max_penetration_h": sim.max_penetration / robot.beam.thickness,
    }


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="0.5 s ramp, 0.2 ms only")
    p.add_argument("--gait", default="paper-5c")
    p.add_argument("--json", default=None)
    a = p.parse_args(argv)
    ramp = 0.5 if a.quick else 1.5
    cases = [(dt, ns) for dt in ((2e-4,) if a.quick else (1e-4, 2e-4)) for ns in (0, 10)]
    rows = []
    print("| dt (ms) | noslip | creep at r = 0.25 / 0.5 / 0.9 / 0.99 (um) | creep velocity at r = 0.5 / 0.9 (um/s) | "
          "sliding onset r | mu_eff (mu = 0.5) | v_end / Coulomb |")
    print("|---|---|---|---|---|---|---|")
    for dt, ns in cases:
        r = coulomb_ramp(a.gait, timestep=dt, ramp=ramp, noslip_iterations=ns)
        rows.append(r)
        c, cv = r["creep_m"], r["creep_velocity_m_s"]
        print(f"| {dt * 1e3:g} | {ns} | {1e6 * c['0.25']:.2f} / {1e6 * c['0.5']:.2f} / {1e6 * c['0.9']:.2f} / "
              f"{1e6 * c['0.99']:.2f} | {1e6 * cv['0.5']:.2f} / {1e6 * cv['0.9']:.2f} | "
              f"{r['sliding_onset_ratio']:.3f} | "
              f"{r['mu_eff']:.4f} "
              f"({100 * r['mu_error']:+.2f} %) | {r['v_end_m_s']:.4f} / {r['v_end_coulomb_m_s']:.4f} m/s "
              f"({100 * r['v_end_error']:+.1f} %) |", flush=True)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())

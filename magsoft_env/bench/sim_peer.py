"""Peer comparison: the magnetic cantilever in PyElastica against the MuJoCo rod, time to the same error.

Case: the 25 mm beam (5 x 1.13 mm, phi = 0.2), uniform axial magnetization, no gravity, a
5 mT field along +z; baseline for both: the elastica closed form (``sim/reference.py``).
MuJoCo: ``mujoco_equilibrium`` at N = 10, 20, 40 (the target error is the N = 20 one).
PyElastica: a Cosserat rod with the same EI (circular section of radius h / sqrt(3), so EA / EI
matches the strip's 12 / h^2) and the magnetic couple ``(A M l_e d3) x B`` on every element as a
custom forcing, clamped at s = 0, relaxed by analytical linear damping; the wall time at which
its tip error first stays within the target, and its final error, per element count.

PyElastica is not a project dependency: this section is skipped, with a message, when
``import elastica`` fails (``pip install pyelastica``). Run:
``python -m magsoft_env.bench.sim_peer [--quick]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from magsoft_env import Beam
from magsoft_env.sim import mujoco_equilibrium
from magsoft_env.sim.reference import elastica_dead_load

FIELD_Z = 5e-3  # T
_DAMPING = 25.0  # 1/s, uniform damping rate: about critical for the first mode (omega_1 ~ 13 rad/s)
_CFL = 0.3  # dt = _CFL * dl / c, c = sqrt(E / rho) the axial wave speed


def _mujoco(beam, ref, segments):
    t0 = time.perf_counter()
    eq = mujoco_equilibrium(beam, (0.0, FIELD_Z), gravity=0.0, segments=segments)
    wall = time.perf_counter() - t0
    return math.hypot(eq.x[-1] - ref["x"], eq.z[-1] - ref["z"]) / beam.length, wall


def _elastica(ea, beam, ref, n_elem, target, duration):
    """Relax the PyElastica rod; (first wall time the error stays <= target or None, final error, wall)."""
    L, h = beam.length, beam.thickness
    EI = float(beam.bending_stiffness(0.0))
    AM = float(beam.moment_per_length(0.0))
    rho_a = float(beam.mass_per_length(0.0))
    r = h / math.sqrt(3.0)
    area, second = math.pi * r**2, math.pi * r**4 / 4.0
    E = EI / second

    class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping, ea.CallBacks):
        pass

    class MagneticCouple(ea.NoForces):
        # tau = m x B with m = A M l_e d3 (world), into the material frame as PyElastica wants
        def __init__(self, moment_per_length, field):
            super().__init__()
            self.mpl, self.B = moment_per_length, np.asarray(field, dtype=float)

        def apply_torques(self, system, time=0.0):
            d3 = system.director_collection[2]  # (3, n_elem), world components of d3
            m = self.mpl * system.rest_lengths * d3
            tau = np.cross(m, self.B[:, None], axis=0)
            system.external_torques += np.einsum("ijk,jk->ik", system.director_collection, tau)

    sim = Sim()
    rod = ea.CosseratRod.straight_rod(
        n_elem, np.zeros(3), np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 1.0]), L, r, rho_a / area,
        youngs_modulus=E, shear_modulus=E / 3.0,
    )
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    sim.add_forcing_to(rod).using(MagneticCouple, moment_per_length=AM, field=(0.0, 0.0, FIELD_Z))
    dl = L / n_elem
    dt = _CFL * dl / math.sqrt(E / (rho_a / area))  # inside the explicit wave-speed limit
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=_DAMPING, time_step=dt)
    sim.finalize()
    stepper = ea.PositionVerlet()
    chunk = max(1, int(round(0.01 / dt)))
    nchunks = int(math.ceil(duration / (chunk * dt)))
    t_sim, first_ok, err = 0.0, None, math.inf
    t0 = time.perf_counter()
    for _ in range(nchunks):
        for _ in range(chunk):
            t_sim = stepper.step(sim, t_sim, dt)
        tip = rod.position_collection[:, -1]
        err = math.hypot(tip[0] - ref["x"], tip[2] - ref["z"]) / L
        if not np.isfinite(err):
            return None, math.inf, time.perf_counter() - t0
        if err <= target:
            if first_ok is None:
                first_ok = time.perf_counter() - t0
        else:
            first_ok = None
    return first_ok, err, time.perf_counter() - t0


def main(quick: bool = False) -> None:
    print("\n## peer: PyElastica vs the MuJoCo rod, 25 mm uniform cantilever, B_z = 5 mT, no gravity; "
          "baseline: elastica closed form")
    try:
        import elastica as ea
    except ImportError:
        print("skipped: PyElastica is not installed (pip install pyelastica)")
        return
    beam = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    EI, AM = float(beam.bending_stiffness(0.0)), float(beam.moment_per_length(0.0))
    ref = elastica_dead_load(beam.length, EI, AM * FIELD_Z, math.pi / 2)
    print(f"{'model':>22} {'n':>4} {'tip err/L %':>12} {'wall s':>8}")
    target = wall20 = None
    for n in (10, 20, 40):
        err, wall = _mujoco(beam, ref, n)
        if n == 20:
            target, wall20 = err, wall
        print(f"{'MuJoCo rod (settle)':>22} {n:>4} {100 * err:>12.4f} {wall:>8.2f}")
    duration = 0.5 if quick else 1.0  # settled by 0.5 s at this damping (the final errors agree)
    print(f"PyElastica: time until the tip error stays <= the MuJoCo N = 20 error ({100 * target:.4f} %), "
          f"relaxing {duration:g} s of simulated time at damping {_DAMPING:g} 1/s")
    print(f"{'model':>22} {'n_elem':>6} {'final err/L %':>14} {'to target s':>12} {'wall s':>8} {'x MuJoCo':>9}")
    _elastica(ea, beam, ref, 10, target, 0.02)  # numba compiles on first use: not timed below
    ns, errs, walls = (20, 40) if quick else (20, 40, 80), [], []
    for n in ns:
        first, err, wall = _elastica(ea, beam, ref, n, target, duration)
        errs.append(err)
        walls.append(wall)
        ratio = f"{first / wall20:>9.1f}" if first is not None else f"{'-':>9}"
        to = f"{first:>12.2f}" if first is not None else f"{'not reached':>12}"
        print(f"{'PyElastica':>22} {n:>6} {100 * err:>14.4f} {to} {wall:>8.2f} {ratio}")
    if errs[-1] > target and all(np.isfinite(errs)):
        # error ~ C n^-p and wall ~ n^q from the last two runs (q -> 2 once the per-step work,
        # not PyElastica's fixed per-step overhead, dominates: dt ~ dl and work ~ n)
        p = math.log(errs[-2] / errs[-1]) / math.log(ns[-1] / ns[-2])
        q = math.log(walls[-1] / walls[-2]) / math.log(ns[-1] / ns[-2])
        n_need = ns[-1] * (errs[-1] / target) ** (1.0 / p)
        t_need = walls[-1] * (n_need / ns[-1]) ** q
        print(f"extrapolated (not run): error ~ n^-{p:.2f}, wall ~ n^{q:.2f}, so PyElastica needs n_elem ~ "
              f"{n_need:.0f} for {100 * target:.4f} %, ~ {t_need:.0f} s of wall time ({t_need / wall20:.0f} x the "
              f"MuJoCo rod's {wall20:.2f} s at N = 20; at least {walls[-1] / wall20:.0f} x, measured at n_elem = "
              f"{ns[-1]} with {100 * errs[-1]:.2f} % error)")


if __name__ == "__main__":
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true")
    main(p.parse_args().quick)

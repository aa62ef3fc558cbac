"""The planar analytical solver in a non-uniform field source: couples and gradient forces on every piece.

Checked against references it does not share code with: today's uniform-field solver (a source that is uniform
but not ``fields.Uniform`` takes the new solver), an independent shooting solver (``theory.shoot``: DOP853 and a
root finder, no collocation), finite differences of its own residual for the Jacobian, and a fold when a magnet
approaches.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.fields import CoilSystem, PointDipole, SourceSum, SphereMagnet, Uniform
from magsoft_env.theory import sources as S
from magsoft_env.theory.collocation import make_grid

BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
L = BEAM.length


def _magnet():
    """The paper strip's neighbour: a 5e-3 A m^2 dipole 10 mm below the beam and 5 mm beyond its tip."""
    return PointDipole(position=(30e-3, 0.0, -10e-3), moment=(0.0, 0.0, 5e-3))


def test_uniform_source_is_todays_solver_bit_for_bit():
    for B in [(0.0, 13e-3), (-22e-3, 5e-3)]:
        a = ms.solve_equilibrium(BEAM, Uniform(B))
        b = ms.solve_equilibrium(BEAM, B)
        assert type(a) is type(b)
        assert np.array_equal(a.theta, b.theta) and np.array_equal(a.x, b.x)
    pa = ms.solve_path(BEAM, [Uniform((0, 5e-3)), Uniform((0, 10e-3))])
    pb = ms.solve_path(BEAM, [(0, 5e-3), (0, 10e-3)])
    assert all(np.array_equal(p.theta, q.theta) for p, q in zip(pa, pb, strict=True))


@pytest.mark.parametrize("profile", ["uniform", "cells", "jig"])
def test_source_solver_equals_uniform_solver_in_a_uniform_field(profile):
    """A uniform field given as a sum (not fields.Uniform) takes the source solver; it must land on the uniform
    solver's verified equilibrium (gravity included, a continuous profile exercises the transverse moment)."""
    mag = {"uniform": None, "cells": ms.alternating_cells(3), "jig": ms.Function(lambda s: 40.0 * s)}[profile]
    beam = BEAM if mag is None else ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=mag)
    B = (-6e-3, 9e-3)
    src = SourceSum([Uniform(B), Uniform((0.0, 0.0))])
    a = ms.solve_equilibrium(beam, src, gravity=9.81)
    b = ms.solve_equilibrium(beam, B, gravity=9.81)
    assert isinstance(a, ms.SourceResult) and a.success and b.success
    assert np.abs(a.tip_position - b.tip_position).max() < 1e-10 * L
    assert a.verification < 1e-8


def test_jacobian_matches_finite_differences():
    grid = make_grid(L, (), n=16)
    mdl = S._Model(BEAM, grid, "rotated", 0.1)
    load = S._Load(((1.0, _magnet()), (0.5, Uniform((2e-3, 1e-3)))), 9.81)
    th = 0.1 + 0.4 * np.sin(np.linspace(0.0, 2.0, grid.M))
    R, _, aux = mdl.residual(th, load)
    J = mdl.jacobian(th, load, aux)
    e = 1e-7
    Jfd = np.column_stack([(mdl.residual(th + e * d, load)[0] - mdl.residual(th - e * d, load)[0]) / (2 * e)
                           for d in np.eye(grid.M)])
    assert np.abs(J - Jfd).max() < 1e-6 * np.abs(J).max()


def _cases():
    """Random loads of moderate size (tip angles up to about 90 degrees): dipoles beside the beam, a sphere
    magnet below it, Navion at random currents plus a uniform field; uniform and alternating magnetization;
    gravity on or off; a clamp angle."""
    rng = np.random.default_rng(7)
    navion = CoilSystem.from_calibration("navion")
    out = []
    for k in range(6):
        kind = k % 3
        if kind == 0:
            pos = (rng.uniform(15e-3, 35e-3), 0.0, rng.choice([-1, 1]) * rng.uniform(10e-3, 14e-3))
            m = rng.normal(size=3) * np.array([1, 0, 1])
            src = PointDipole(position=pos, moment=3e-3 * m / np.linalg.norm(m))
        elif kind == 1:
            src = SphereMagnet(position=(rng.uniform(20e-3, 30e-3), 0.0, -15e-3), radius=3e-3,
                               magnetization=(0.0, 0.0, rng.uniform(1e5, 3e5)))
        else:
            src = navion.at_currents(rng.uniform(-10, 10, size=navion.n_coils)) + Uniform((0.0, 1e-3))
        mag = ms.alternating_cells(2) if k in (2, 4) else None
        beam = BEAM if mag is None else ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=mag)
        out.append((beam, src, float(rng.choice([0.0, 9.81])), float(rng.uniform(-0.3, 0.3))))
    return out


@pytest.mark.parametrize("case", [0, 1, 3] + [pytest.param(k, marks=pytest.mark.slow) for k in (2, 4, 5)])
def test_against_an_independent_shooting_solver(case):
    """The shooting solver integrates the strong form from the clamp and finds the clamp's reactions that free
    the tip; started 0.1 % away (shooting is ill-conditioned near a magnet) from the reactions the collocation
    solution implies, it must land on the same shape to 1e-6 of L (the collocation shape then solves the
    boundary-value problem)."""
    beam, src, g, th0 = _cases()[case]
    r = ms.solve_equilibrium(beam, src, gravity=g, clamp_angle=th0, model="planar")
    assert r.success and r.stable, r.message
    guess = 1.001 * np.array([*r.clamp_force, r.clamp_moment])
    sh = ms.theory.shoot(beam, src, gravity=g, clamp_angle=th0, guess=guess)
    assert sh["success"] and sh["residual"] < 1e-9 * (1.0 + abs(r.clamp_moment) / beam.length)
    assert np.abs(r.tip_position - sh["tip"]).max() < 1e-6 * beam.length
    x, z, _ = r.at(sh["s"])
    assert np.max(np.hypot(x - sh["x"], z - sh["z"])) < 1e-6 * beam.length


def test_magnet_case_matches_shooting_and_deflects_about_23_degrees():
    r = ms.solve_equilibrium(BEAM, _magnet(), gravity=0.0)
    sh = ms.theory.shoot(BEAM, _magnet())
    assert r.success and r.stable
    assert np.abs(r.tip_position - sh["tip"]).max() < 1e-6 * L
    assert 20.0 < math.degrees(r.tip_angle) < 28.0
    # the force term matters as much as the couple: dropping the gradient moves the tip by much
    only_couple = ms.solve_equilibrium(BEAM, Uniform(tuple(_magnet().field_and_gradient([[L, 0, 0]])[0][0])),
                                       gravity=0.0)
    assert abs(only_couple.tip_angle - r.tip_angle) > math.radians(3)


def test_an_approaching_magnet_snaps_the_tip_to_it_at_a_fold():
    zs = np.linspace(20e-3, 6e-3, 29)
    path = [PointDipole(position=(25e-3, 0.0, z), moment=(0.0, 0.0, 2e-4)) for z in zs]
    res = ms.solve_path(BEAM, path, gravity=0.0)
    assert all(r.success for r in res)
    snapped = [i for i, r in enumerate(res) if r.snap_through]
    assert len(snapped) == 1
    i = snapped[0]
    ev = res[i].events[0]
    assert ev["kind"] == "fold" and ev["converged"] and ev["min_eigenvalue"] < 0.05
    gap_before = zs[i - 1] - res[i - 1].tip_position[2]
    gap_after = zs[i] - res[i].tip_position[2]
    assert gap_after < 0.4 * gap_before  # the tip jumped toward the magnet
    assert res[i - 1].min_eigenvalue < 0.5 and all(r.stable for r in res)
    # a path of the same magnet's positions follows the moving magnet: each result is the equilibrium there
    guess = 1.001 * np.array([*res[i].clamp_force, res[i].clamp_moment])
    sh = ms.theory.shoot(BEAM, path[i], guess=guess)
    assert sh["success"] and np.abs(res[i].tip_position - sh["tip"]).max() < 1e-6 * L


def test_bad_input_is_refused_before_work():
    src = _magnet()
    with pytest.raises(ValueError, match="coupling='paper'"):  # model='3d' takes a source (test_theory_sources_3d)
        ms.solve_equilibrium(BEAM, src, model="3d", coupling="paper")
    with pytest.raises(ValueError, match="cantilever"):
        ms.solve_equilibrium(BEAM, src, support="free", gravity=0.0)
    with pytest.raises(ValueError, match="extensible"):
        ms.solve_equilibrium(BEAM, src, extensible=True)
    with pytest.raises(ValueError, match="start='path'"):
        ms.solve_equilibrium(BEAM, src, start="straight")
    with pytest.raises(ValueError, match="at_currents"):
        ms.solve_path(BEAM, [src, CoilSystem.from_calibration("navion")])


@pytest.mark.slow
def test_mujoco_rods_agree_with_the_analytical_solution_near_a_magnet():
    """The issue's cross-check: the paper strip clamped near a small magnet, no gravity. The analytical solver
    equals the shooting solver (from zero load, its own continuation) to 1e-6 of L; the MuJoCo planar chain is
    within 0.5 % of L and the 3D strip within 1 % at their defaults (measured: 1.0e-4 and 1.6e-4 of L)."""
    from magsoft_env.sim.sources import magnet_case

    beam, src, clamp = magnet_case()
    a = ms.solve_equilibrium(beam, src, **clamp)
    assert a.success and a.stable
    sh = ms.theory.shoot(beam, src, gravity=clamp["gravity"], clamp_angle=clamp["clamp_angle"])
    assert sh["success"] and np.abs(a.tip_position - sh["tip"]).max() < 1e-6 * beam.length
    for rod, tol in (("planar", 5e-3), ("cable", 1e-2)):
        e = ms.mujoco_equilibrium(beam, src, rod=rod, **clamp)
        assert e.success, e.message
        assert np.abs(e.tip_position - a.tip_position).max() < tol * beam.length, rod

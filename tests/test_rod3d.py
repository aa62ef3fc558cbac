"""The 3D Kirchhoff rod: closed forms, the planar reduction, buckling, exact derivatives, errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.theory.collocation import make_grid
from magsoft_env.theory.elastica import elastica_tip, prandtl_field
from magsoft_env.theory.rod import CLAMP_QUATERNION, Load3, RodModel, rotate
from magsoft_env.theory.rod_solver import RodResult, critical_field

L, W, H = 25e-3, 5e-3, 1.13e-3


def strip(**kw):
    return ms.Beam(length=L, width=W, thickness=H, **kw)


def wrapped(a):
    return np.abs(a - 2 * np.pi * np.round(a / (2 * np.pi)))


def planar_angle(res: RodResult, n=41):
    s, r, F = res.sample(n)
    return s, r, np.arctan2(F[:, 2, 2], F[:, 0, 2])


@pytest.mark.parametrize("field, g, mag", [
    ((0.0, 13e-3), 9.81, 0.0),
    ((-22e-3, 13e-3), 9.81, 0.0),
    ((5e-3, 0.0), 0.0, math.pi / 2),
    ((0.0, -6e-3), 9.81, ms.PiecewiseConstant([0.0, math.pi / 3], [0.5, 0.5])),
])
def test_planar_problems_give_the_planar_answer(field, g, mag):
    beam = strip(magnetization=mag)
    planar = ms.solve_equilibrium(beam, field, gravity=g)
    rod = ms.solve_equilibrium(beam, (field[0], 0.0, field[1]), gravity=g)
    assert isinstance(rod, RodResult) and rod.success and planar.success
    s, r, th = planar_angle(rod)
    _, x, z, theta = planar.sample(41)
    assert np.max(wrapped(th - theta)) < 1e-10
    assert np.max(np.abs(r[:, 0] - x)) < 1e-10 * L and np.max(np.abs(r[:, 2] - z)) < 1e-10 * L
    assert np.max(np.abs(r[:, 1])) < 1e-12 * L and abs(rod.tip_twist) < 1e-12
    assert rod.stable == planar.stable
    assert rod.verification <= 1e-8


def test_free_free_cells_give_the_planar_answer():
    beam = strip(magnetization=ms.alternating_cells(3))
    planar = ms.solve_equilibrium(beam, (3e-3, 4e-3), gravity=0.0, support="free")
    rod = ms.solve_equilibrium(beam, (3e-3, 0.0, 4e-3), gravity=0.0, support="free")
    assert rod.success and planar.success
    _, r, th = planar_angle(rod)
    _, x, z, theta = planar.sample(41)
    assert np.max(wrapped(th - theta)) < 1e-10
    assert np.max(np.abs(r[:, 0] - x)) < 1e-10 * L and np.max(np.abs(r[:, 2] - z)) < 1e-10 * L


def test_field_across_the_width_bends_about_the_strong_axis():
    beam = strip()
    B = 0.5e-3  # below the lateral-torsional buckling field
    res = ms.solve_equilibrium(beam, (0.0, B, 0.0), gravity=0.0)
    EI_s = beam.stiffnesses(np.array([0.0]))[0, 1]
    F = float(beam.moment_per_length(np.array([0.0]))[0]) * B
    th, xL, yL = elastica_tip(F, math.pi / 2, EI_s, L)  # the elastica in the x-y plane with E I_s
    assert res.success and res.stable
    assert abs(res.tip_position[0] - xL) < 1e-8 * L and abs(res.tip_position[1] - yL) < 1e-8 * L
    assert abs(res.tip_position[2]) < 1e-12 and abs(res.tip_twist) < 1e-10
    assert abs(math.atan2(res.tip_tangent[1], res.tip_tangent[0]) - th) < 1e-8


@pytest.mark.parametrize("B, alpha", [(3e-3, math.pi / 2), (8e-3, 2.0), (1.5e-3, -2.5)])
def test_magnetization_across_the_width_twists_without_bending(B, alpha):
    beam = strip(magnetization=(0.0, 1.0, 0.0))
    field = (0.0, B * math.cos(alpha), B * math.sin(alpha))
    res = ms.solve_equilibrium(beam, field, gravity=0.0)
    GJ = beam.stiffnesses(np.array([0.0]))[0, 2]
    F = float(beam.moment_per_length(np.array([0.0]))[0]) * B
    phi, _, _ = elastica_tip(F, alpha, GJ, L)  # G J phi'' = -(A M B) sin(alpha - phi): the elastica's pendulum
    assert res.success
    assert abs(res.tip_twist - phi) < 1e-8
    s, r, _ = res.sample(21)
    assert np.max(np.abs(r - np.column_stack([s, 0 * s, 0 * s]))) < 1e-10 * L


def test_lateral_torsional_buckling_is_found_and_followed():
    beam = strip()
    B_p = prandtl_field(beam)
    assert B_p == pytest.approx(0.78e-3, rel=0.01)
    fields = [(0.0, b, 0.0) for b in np.linspace(0.2, 1.4, 7) * 1e-3]
    path = ms.solve_path(beam, fields, gravity=0.0)
    assert all(r.success and r.stable for r in path)
    before = [r for r in path if not r.snap_through and not r.events]
    assert before and all(abs(r.tip_position[2]) < 1e-12 for r in before)  # in the x-y plane until it buckles
    jumped = [r for r in path if r.snap_through]
    assert len(jumped) == 1
    ev = jumped[0].events[0]
    assert ev["kind"] == "bifurcation" and ev["converged"]
    Bc = ev["critical_field_T"][1]
    assert B_p < Bc < 1.15 * B_p  # the in-plane deflection raises Prandtl's estimate somewhat
    last = path[-1]
    assert abs(last.tip_position[2]) > 0.2 * L and abs(last.tip_twist) > 0.3  # out of its plane, twisted
    assert last.verification < 1e-8 and last.min_eigenvalue > 0
    crit = critical_field(beam, (0.0, 2e-3, 0.0))
    assert crit.kind == "bifurcation" and crit.error < 1e-6 * crit.magnitude
    assert crit.magnitude == pytest.approx(Bc, rel=1e-6)


def _random_state(model, rng, size=0.3):
    return rotate(np.tile(CLAMP_QUATERNION, (model.grid.M, 1)), size * rng.standard_normal((model.grid.M, 3)))


@pytest.mark.parametrize("free", [False, True])
@pytest.mark.parametrize("magnetization", [ms.alternating_cells(2), (0.3, 0.8, 0.5)])
def test_jacobian_and_second_variation_are_exact(free, magnetization):
    beam = strip(magnetization=magnetization)
    grid = make_grid(L, beam.breakpoints(), n=10)
    model = RodModel(beam, grid, free=free, clamp_angle=0.3)
    q = _random_state(model, np.random.default_rng(1))
    load = Load3(2e-3, -3e-3, 4e-3, 0.0 if free else 9.81)
    F1, J1 = model.jacobian(q, load)
    F2, J2 = model.jacobian_cs(q, load)
    assert np.max(np.abs(F1 - F2)) < 1e-13 and np.max(np.abs(J1 - J2)) < 1e-12 * np.max(np.abs(J2))
    # the gradient is the discrete energy's: central differences, one rotation at a time
    g, Hs = model.hessian(q, load)
    h = 1e-6
    num = np.empty_like(g)
    for j in range(g.size):
        v = np.zeros(g.size)
        v[j] = h
        psi = model.E @ v.reshape(-1, 3)
        num[j] = (model.energy(rotate(q, psi), load) - model.energy(rotate(q, -psi), load)) / (2 * h)
    assert np.max(np.abs(g - num)) < 1e-8 * np.max(np.abs(g))
    g2, H2 = model.hessian_cs(q, load)
    assert np.max(np.abs(g - g2)) < 1e-13 * np.max(np.abs(g2))
    assert np.max(np.abs(Hs - H2)) < 1e-12 * np.max(np.abs(H2))


def test_results_are_documented_shapes_and_json():
    res = ms.solve_equilibrium(strip(), (1e-3, 2e-3, 5e-3))
    n = res.nodes
    assert res.centreline.shape == (n, 3) and res.frames.shape == (n, 3, 3) and res.curvature.shape == (n, 3)
    assert np.allclose(res.frames @ res.frames.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    s, r, F = res.sample(7)
    assert s.shape == (7,) and r.shape == (7, 3) and F.shape == (7, 3, 3)
    assert np.allclose(r[-1], res.tip_position, atol=1e-12)
    json.dumps(res.to_dict())
    assert res.to_dict()["field_T"] == pytest.approx([1e-3, 2e-3, 5e-3])
    with pytest.raises(ValueError, match="sample n"):
        res.sample(1)


def test_three_dimensional_limits_are_stated():
    beam = strip()
    with pytest.raises(ValueError, match="paper"):
        ms.solve_equilibrium(beam, (0.0, 1e-3, 5e-3), coupling="paper")
    with pytest.raises(ValueError, match="extensible"):
        ms.solve_equilibrium(beam, (0.0, 1e-3, 5e-3), extensible=True)
    with pytest.raises(ValueError, match="straight"):
        ms.solve_equilibrium(beam, (0.0, 1e-3, 5e-3), start="straight")
    with pytest.raises(ValueError, match="B_y"):
        ms.solve_equilibrium(beam, (0.0, 1e-3, 5e-3), model="planar")
    with pytest.raises(ValueError, match="model"):
        ms.solve_equilibrium(beam, (0.0, 5e-3), model="2d")
    with pytest.raises(ValueError, match="width"):
        ms.solve_equilibrium(strip(magnetization=(0, 1, 0)), (0.0, 5e-3), model="planar")


def test_an_unresolved_grid_is_not_reported_as_a_success():
    res = ms.solve_equilibrium(strip(), (0.0, 4e-3, 13e-3), options=ms.theory.SolverOptions(nodes=8))
    assert not res.success and res.status == 4 and res.verification > 1e-8


def test_random_3d_problems_are_verified_or_fail_honestly():
    rng = np.random.default_rng(7)
    for _ in range(16):
        L_ = rng.uniform(10, 40) * 1e-3
        h = rng.uniform(0.5, 2) * 1e-3
        kind = rng.integers(3)
        mag = (float(rng.uniform(-3, 3)) if kind == 0 else ms.alternating_cells(int(rng.integers(2, 5))) if kind == 1
               else tuple(rng.standard_normal(3)))
        beam = ms.Beam(length=L_, width=rng.uniform(2, 8) * 1e-3, thickness=h, magnetization=mag)
        support = "free" if rng.random() < 0.25 else "cantilever"
        g = 0.0 if support == "free" else 9.81
        d = rng.standard_normal(3)
        field = tuple(rng.uniform(0, 30e-3) * d / np.linalg.norm(d))
        res = ms.solve_equilibrium(beam, field, gravity=g, support=support)
        if res.success:
            assert res.verification <= 1e-8 and np.all(np.isfinite(res.centreline))
        else:
            assert res.status in (1, 3, 4) and res.message


def test_a_slice_of_the_3d_stress_benchmark_is_all_verified():
    from magsoft_env.bench.rod_stress import run

    rep = run(12, seed=3, points=2001, progress=False)
    assert rep["counts"] == {"success, verified": 12}, rep["bad"]
    assert rep["worst_verified_residual"] < 1e-8


def test_small_gravity_gives_the_beam_formula_in_3d():
    beam = strip()
    g = 0.02  # G = rho A g L^3 / (E I_w) = 0.05: the linear cantilever under its weight
    res = ms.solve_equilibrium(beam, (0.0, 0.0, 0.0), gravity=g, model="3d")
    q = float(beam.mass_per_length(np.array([0.0]))[0]) * g
    EI = beam.stiffnesses(np.array([0.0]))[0, 0]
    w = q * L**4 / (8 * EI)
    G = q * L**3 / EI
    assert res.success and abs(res.tip_position[2] + w) < 0.05 * G**2 * w + 1e-12 * L
    assert abs(res.tip_position[1]) < 1e-15 and abs(res.tip_twist) < 1e-14

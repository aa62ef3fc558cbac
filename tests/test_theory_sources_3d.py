"""The 3D Kirchhoff rod (cantilever) in a non-uniform field source: couples and gradient forces on every piece.

Checked against references it does not share code with: today's uniform-field 3D solver (a source that is uniform
but not ``fields.Uniform`` takes the new solver), the planar source solver on planar problems, an independent 3D
shooting solver (``rod_sources.shoot3d``: DOP853 and a root finder on the six clamp reactions, no collocation),
finite differences of its own residual and gradient for the Jacobian and the second variation.
"""

from __future__ import annotations

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.fields import CoilSystem, PointDipole, SourceSum, Uniform
from magsoft_env.theory import rod_sources as RS
from magsoft_env.theory.collocation import make_grid
from magsoft_env.theory.rod import clamp_quaternion, rotate

BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
WIDTH = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, magnetization=(1.0, 0.3, 0.2))
L = BEAM.length


def _oblique():
    """A dipole off the strip's plane (y = 8 mm), its moment out of the plane too."""
    return PointDipole(position=(28e-3, 8e-3, -8e-3), moment=(1e-3, -2e-3, 4e-3))


@pytest.mark.parametrize("beam,B,g,th0", [
    (BEAM, (-4e-3, 3e-3, 6e-3), 9.81, 0.1),
    (BEAM, (0.0, 1.2e-3, 0.0), 0.0, 0.0),  # across the width: bent about the strong axis, below buckling
    (WIDTH, (2e-3, -5e-3, 8e-3), 9.81, -0.2),
    (ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=ms.alternating_cells(2)), (5e-3, 2e-3, -3e-3), 9.81, 0.0),
])
def test_uniform_source_equals_todays_3d_solver(beam, B, g, th0):
    src = SourceSum([Uniform(B), Uniform((0.0, 0.0, 0.0))])
    a = ms.solve_equilibrium(beam, src, gravity=g, clamp_angle=th0, model="3d")
    b = ms.solve_equilibrium(beam, B, gravity=g, clamp_angle=th0, model="3d")
    assert isinstance(a, RS.SourceRodResult) and a.success and b.success and a.status == 0
    assert np.abs(a.tip_position - b.tip_position).max() < 1e-10 * L
    s = np.linspace(0.0, L, 41)
    (ca, Ra), (cb, Rb) = a.at(s), b.at(s)
    assert np.abs(ca - cb).max() < 1e-10 * L and np.abs(Ra - Rb).max() < 1e-9
    assert a.verification < 1e-8 and a.stable == b.stable
    assert abs(a.min_eigenvalue - b.min_eigenvalue) < 1e-6 * abs(b.min_eigenvalue)
    assert np.allclose(a.tip_field, B, rtol=0, atol=1e-15)


@pytest.mark.parametrize("g,th0", [(0.0, 0.0), (9.81, 0.2)])
def test_planar_problem_equals_the_planar_source_solver(g, th0):
    """A dipole at y = 0 with its moment in the x-z plane and an axial magnetization: the 3D rod stays in the
    plane and lands on the planar source solver's shape (auto takes the planar solver there)."""
    mag = PointDipole(position=(30e-3, 0.0, -10e-3), moment=(1e-3, 0.0, 5e-3))
    a = ms.solve_equilibrium(BEAM, mag, gravity=g, clamp_angle=th0, model="3d")
    b = ms.solve_equilibrium(BEAM, mag, gravity=g, clamp_angle=th0)
    assert isinstance(a, RS.SourceRodResult) and isinstance(b, ms.SourceResult)
    assert a.success and b.success and a.stable and b.stable
    s = np.linspace(0.0, L, 51)
    c, _ = a.at(s)
    x, z, _ = b.at(s)
    assert np.abs(c - np.column_stack([x, 0 * x, z])).max() < 1e-8 * L
    assert np.abs(a.clamp_force[[0, 2]] - b.clamp_force).max() < 1e-8 * np.abs(b.clamp_force).max()
    assert abs(a.clamp_moment[1] + b.clamp_moment) < 1e-8 * abs(b.clamp_moment)  # planar moment about -y


@pytest.mark.parametrize("y", [0.0, 3e-3])
def test_an_approaching_magnet_folds_as_in_the_plane_and_off_it(y):
    """The planar suite's approaching magnet: the 3D rod passes the same fold at the same position with the same
    shapes (1e-8 L); moved 3 mm off the plane, the strip snaps toward it and sideways, verified, and its snapped
    shape is the shooting solution."""
    zs = np.linspace(20e-3, 6e-3, 29)
    path = [PointDipole(position=(25e-3, y, z), moment=(0.0, 0.0, 2e-4)) for z in zs]
    res = ms.solve_path(BEAM, path, gravity=0.0, model="3d")
    assert all(r.success and r.stable for r in res)
    snapped = [i for i, r in enumerate(res) if r.snap_through]
    assert len(snapped) == 1
    i = snapped[0]
    ev = res[i].events[0]
    assert ev["kind"] == "fold" and ev["converged"]
    assert zs[i] - res[i].tip_position[2] < 0.4 * (zs[i - 1] - res[i - 1].tip_position[2])
    if y == 0.0:
        pl = ms.solve_path(BEAM, path, gravity=0.0)
        assert [r.snap_through for r in pl] == [r.snap_through for r in res]
        assert max(np.abs(a.tip_position - b.tip_position).max() for a, b in zip(res, pl, strict=True)) < 1e-8 * L
    else:
        assert res[i].tip_position[1] > 0.05 * L > res[i - 1].tip_position[1]  # toward the magnet's side
        guess = 1.001 * np.r_[res[i].clamp_force, res[i].clamp_moment]
        sh = RS.shoot3d(BEAM, path[i], guess=guess, rtol=1e-10)
        assert sh["success"] and np.abs(res[i].tip_position - sh["tip"]).max() < 1e-6 * L


def _out_of_plane_cases():
    nav = CoilSystem.from_calibration("navion")
    rng = np.random.default_rng(3)
    return [
        (BEAM, _oblique(), 9.81, 0.1),
        (WIDTH, _oblique(), 0.0, 0.0),
        (BEAM, nav.at_currents(rng.uniform(-10, 10, size=nav.n_coils)), 9.81, 0.0),
    ]


@pytest.mark.parametrize("case", range(3))
def test_out_of_plane_against_an_independent_shooting_solver(case):
    """Started 0.1 % away from the clamp reactions the collocation solution implies, the shooting solver must land
    on the same shape to 1e-6 L (the collocation shape then solves the boundary-value problem)."""
    beam, src, g, th0 = _out_of_plane_cases()[case]
    r = ms.solve_equilibrium(beam, src, gravity=g, clamp_angle=th0)  # auto: out of the plane, so 3D
    assert isinstance(r, RS.SourceRodResult) and r.status == 0 and r.success, r.message
    assert abs(r.tip_position[1]) > 1e-3 * L  # really out of the plane
    guess = 1.001 * np.r_[r.clamp_force, r.clamp_moment]
    sh = RS.shoot3d(beam, src, gravity=g, clamp_angle=th0, guess=guess, rtol=1e-10)
    assert sh["success"] and sh["residual"] < 1e-9
    assert np.abs(r.tip_position - sh["tip"]).max() < 1e-6 * L
    c, _ = r.at(sh["s"])
    assert np.abs(c - sh["centreline"]).max() < 1e-6 * L


def test_auto_takes_the_3d_rod_only_for_out_of_plane_loads():
    sym = PointDipole(position=(30e-3, 0.0, -10e-3), moment=(1e-3, 0.0, 5e-3))
    assert RS.out_of_plane_load([sym], L) == 0.0
    assert RS.out_of_plane_load([_oblique()], L) > 1e-2
    assert isinstance(ms.solve_equilibrium(BEAM, sym, gravity=0.0), ms.SourceResult)
    assert isinstance(ms.solve_equilibrium(WIDTH, sym, gravity=0.0), RS.SourceRodResult)
    assert isinstance(ms.solve_equilibrium(BEAM, _oblique(), gravity=0.0), RS.SourceRodResult)
    planar = ms.solve_equilibrium(BEAM, _oblique(), gravity=0.0, model="planar")  # forced: it drops the y loads
    assert isinstance(planar, ms.SourceResult) and planar.out_of_plane > 1e-6


def _state(mdl, grid):
    s = grid.s / L
    psi = np.column_stack([0.3 * np.sin(2 * s), 0.4 * s**2, -0.2 * s])
    return rotate(np.tile(clamp_quaternion(0.1), (grid.M, 1)), psi)


def test_jacobian_and_second_variation_match_finite_differences():
    grid = make_grid(L, (), n=14)
    mdl = RS.SourceRodModel(WIDTH, grid, clamp_angle=0.1)
    load = RS.SourceLoad3(((1.0, _oblique()), (0.5, Uniform((2e-3, -1e-3, 1e-3)))), 9.81)
    q = _state(mdl, grid)
    F, J = mdl.jacobian(q, load)
    assert np.abs(F - mdl.system(q, load)).max() < 1e-13 * np.abs(F).max()
    M, e = grid.M, 1e-7
    cols = []
    for j in range(3 * M):
        d = np.zeros((M, 3))
        d.flat[j] = e
        cols.append((mdl.system(rotate(q, d), load) - mdl.system(rotate(q, -d), load)) / (2 * e))
    assert np.abs(J - np.column_stack(cols)).max() < 1e-6 * np.abs(J).max()  # measured 1.6e-8
    g, H = mdl.hessian(q, load)
    nU = mdl.E.shape[1]
    cols = []
    for j in range(3 * nU):
        x = np.zeros(3 * nU)
        x[j] = e
        d = mdl.E @ x.reshape(-1, 3)
        cols.append((mdl.gradient(rotate(q, d), load) - mdl.gradient(rotate(q, -d), load)) / (2 * e))
    Hfd = np.column_stack(cols)
    assert np.abs(H - 0.5 * (Hfd + Hfd.T)).max() < 1e-7 * np.abs(H).max()  # measured 4e-10
    assert np.abs(g - mdl.gradient(q, load)).max() < 1e-12 * np.abs(g).max()


def test_the_work_budget_ends_the_path_with_status_5():
    res = ms.solve_path(BEAM, [_oblique()], gravity=9.81, options=ms.theory.SolverOptions(max_step_work=1e-3))
    assert res[0].status == 5 and not res[0].success and "max_step_work" in res[0].message


def test_bad_input_is_refused_before_work():
    src = _oblique()
    with pytest.raises(ValueError, match="coupling='paper'"):
        ms.solve_equilibrium(BEAM, src, coupling="paper")  # out of the plane: the 3D rod's coupling only
    with pytest.raises(ValueError, match="cantilever"):
        ms.solve_equilibrium(BEAM, src, support="free", gravity=0.0, model="3d")
    with pytest.raises(ValueError, match="extensible"):
        ms.solve_equilibrium(BEAM, src, extensible=True, model="3d")
    with pytest.raises(ValueError, match="model='planar'"):
        ms.solve_equilibrium(WIDTH, src, model="planar")
    with pytest.raises(ValueError, match="at_currents"):
        ms.solve_path(BEAM, [src, CoilSystem.from_calibration("navion")], model="3d")
    with pytest.raises(ValueError, match="model"):
        ms.solve_path(BEAM, [src], model="4d")
    with pytest.raises(ValueError, match="gravity"):
        ms.solve_path(BEAM, [src], gravity=-1.0, model="3d")

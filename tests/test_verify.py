"""Verified results: every returned equilibrium is checked between the nodes, independently of the solver."""

from __future__ import annotations

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.bench.stress import independent_residual
from magsoft_env.bench.stress import run as stress_run
from magsoft_env.cases import load_preset
from magsoft_env.theory import SolverOptions
from magsoft_env.theory.solver import _MAX_NEWTON, MAX_JUMPS, MAX_STEPS, TERMINATION_MESSAGES
from magsoft_env.theory.verify import equation_residual

L = 20e-3
SINE = ms.Beam(length=L, width=5e-3, thickness=1e-3, volume_fraction=0.2,
               magnetization=ms.Function(lambda s: np.sin(2 * np.pi * s / L)))
UNIFORM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)


def _case(beam, *, gravity=9.81, support="cantilever", coupling="rotated", extensible=False):
    return {"beam": beam, "gravity": gravity, "support": support, "coupling": coupling, "extensible": extensible}


def test_free_free_case_that_used_to_return_a_wrong_shape_is_resolved_and_verified():
    # a regression: on 33 nodes this returned success with a trailing coefficient of 1.7e-3 rad
    r = ms.solve_equilibrium(SINE, (-0.1114, 0.0), gravity=0, support="free")
    assert r.success and r.status == 0 and r.verification <= 1e-8
    fine = ms.solve_equilibrium(SINE, (-0.1114, 0.0), gravity=0, support="free",
                                options=SolverOptions(nodes=300, max_nodes=400))
    assert fine.success
    assert r.tip_angle == pytest.approx(fine.tip_angle, abs=1e-8)
    np.testing.assert_allclose(r.at(np.linspace(0, L, 11))[2], fine.at(np.linspace(0, L, 11))[2], atol=1e-8)
    assert independent_residual(r, _case(SINE, gravity=0.0, support="free")) <= 1e-8


def test_an_under_resolved_fixed_grid_is_reported_not_verified():
    r = ms.solve_equilibrium(SINE, (-0.1114, 0.0), gravity=0, support="free", options=SolverOptions(nodes=8))
    assert not r.success and r.status == 4
    assert "Not verified" in r.message and r.verification > 1e-8
    # the check itself: the residual it reports is also found by the independent one
    assert independent_residual(r, _case(SINE, gravity=0.0, support="free")) > 1e-8


def test_the_check_sees_a_wrong_shape_between_correct_nodes():
    r = ms.solve_equilibrium(UNIFORM, (0.0, 13e-3))
    theta = r._full[0].copy()
    kw = dict(Bx=0.0, Bz=13e-3, g=9.81, coupling="rotated", extensible=False, support="cantilever", theta0=0.0)
    assert equation_residual(UNIFORM, r._grid, theta, **kw) < 1e-11
    theta[5] += 1e-6  # one node off by a micro-radian
    assert equation_residual(UNIFORM, r._grid, theta, **kw) > 1e-7


@pytest.mark.parametrize("name", ["fig4b_quadratic", "fig4c_sinusoidal", "fig4d_piecewise", "fig3b_L25"])
def test_presets_are_verified_along_their_paths(name):
    p = load_preset(name)
    results = ms.solve_path(p.beam, p.fields, **p.solver_options())
    assert all(r.success and r.verification <= 1e-8 for r in results), [r.message for r in results if not r.success]
    last = results[-1]
    assert last.resolution >= last.verification
    assert independent_residual(last, _case(p.beam, gravity=p.gravity, coupling=p.coupling)) <= 1e-8


def test_refinement_goes_on_after_a_failed_newton_step(monkeypatch):
    from magsoft_env.theory import solver as sv

    real = sv._Solver.newton
    failed = []

    def flaky(self, theta, load, c=None, maxiter=sv._MAX_NEWTON):
        if self.grid.n == 48 and not failed:  # the first refinement of the 32-node grid
            failed.append(self.grid.n)
            return False, theta, self.c, 1
        return real(self, theta, load, c, maxiter)

    monkeypatch.setattr(sv._Solver, "newton", flaky)
    r = ms.solve_equilibrium(SINE, (-0.1114, 0.0), gravity=0, support="free")
    assert failed == [48]
    assert r.success and r.verification <= 1e-8 and r.nodes > 49


@pytest.mark.parametrize(
    "options, name",
    [
        (dict(max_domain=0), "max_domain"),
        (dict(nodes="20"), "nodes"),
        (dict(nodes=2.5), "nodes"),
        (dict(nodes=True), "nodes"),
        (dict(tol=1.0), "tol"),
        (dict(tol=1e-30), "tol"),
        (dict(max_nodes=10**6), "max_nodes"),
        (dict(resolution_tol=-1.0), "resolution_tol"),
        (dict(resolution_tol=float("nan")), "resolution_tol"),
        (dict(min_step=0.0), "min_step"),
        (dict(verify_tol=1.0), "verify_tol"),
    ],
)
def test_solver_options_are_checked_before_any_work(options, name):
    with pytest.raises(ValueError, match=f"SolverOptions.{name}"):
        ms.solve_equilibrium(UNIFORM, (0.0, 13e-3), options=SolverOptions(**options))


@pytest.mark.parametrize("gravity", [1e8, 1e30])
def test_absurd_gravity_is_refused_before_any_work(gravity):
    with pytest.raises(ValueError, match=r"gravity must lie in \[0, 1000\] m/s\^2"):
        ms.solve_equilibrium(UNIFORM, (0.0, 13e-3), gravity=gravity)


@pytest.mark.parametrize("field", [(0.0, 1.0), (-1.0, 0.0)])
def test_extreme_loads_end_with_a_status_after_bounded_work(field):
    r = ms.solve_equilibrium(UNIFORM, field, gravity=1000.0)  # the largest gravity and field accepted
    # the work is bounded by steps, not time: at most MAX_STEPS + MAX_JUMPS continuation steps of at most
    # 4 x _MAX_NEWTON Newton iterations in each of the two load segments (gravity, then the field)
    assert 0 <= r.newton_iterations <= 2 * (MAX_STEPS + MAX_JUMPS + 1) * 4 * _MAX_NEWTON
    if r.success:  # 100 g, or a field of a tesla: verified all the same
        assert r.status in (0, 2) and r.verification <= SolverOptions().verify_tol
    else:  # a failure says why, and carries no verification
        assert r.status == 1 and r.message.startswith(TERMINATION_MESSAGES[1])
        assert math.isnan(r.verification)


def test_largest_grids_are_refused_up_front():
    many = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3,
                   magnetization=ms.PiecewiseConstant([0.0, 1.0] * 80))
    with pytest.raises(ValueError, match="collocation nodes"):
        ms.solve_equilibrium(many, (0.0, 5e-3), options=SolverOptions(nodes=40))


def test_stress_slice_has_no_unverified_success_and_no_exception():
    rep = stress_run(40, seed=1, progress=False)
    assert rep["not_verified"] == [] and rep["exceptions"] == []
    assert sum(rep["counts"].values()) == 40
    assert rep["counts"].get("success, verified", 0) >= 30

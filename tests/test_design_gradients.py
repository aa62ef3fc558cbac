"""Gradient-based inverse design (issue 32, item 3): exact sensitivities with respect to the magnetization profile,
the design objective's exact Jacobian, and the designs it finds.

The profile sensitivities are checked against fourth-order central differences of full solves (every perturbed
equilibrium solved from scratch along its loading path, on the same fixed grid); the objective's Jacobian against
central differences of the objective itself.
"""

from __future__ import annotations

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.design import ProfileFamily
from magsoft_env.theory.options import SolverOptions
from magsoft_env.theory.sensitivity import collocation_nodes, profile_sensitivities, sensitivities

L = 22e-3
BEAM = ms.Beam(length=L, width=5e-3, thickness=1.13e-3)
OPTS = SolverOptions(nodes=40)
FAM = ProfileFamily("spline", 5)
P0 = np.array([1.2, 0.9, 0.1, -0.6, -1.0])


def _solve(p, B=(-3e-3, 9e-3), coupling="rotated", fam=FAM, **kw):
    beam = BEAM.replace(magnetization=fam.profile(p, L), **kw)
    return ms.solve_equilibrium(beam, B, coupling=coupling, clamp_angle=0.1, model="planar", options=OPTS)


@pytest.mark.parametrize("coupling", ["rotated", "paper"])
@pytest.mark.parametrize("kind", ["spline", "fourier"])
def test_profile_sensitivities_equal_differences_of_full_solves(coupling, kind):
    fam = ProfileFamily(kind, 5)
    p0 = P0 if kind == "spline" else np.array([0.3, 0.8, -0.4, 0.2, 0.1])
    r = _solve(p0, coupling=coupling, fam=fam)
    assert r.success
    S = profile_sensitivities(r, lambda s: fam.basis(s / L), params=["Bz"])
    assert S.params == ("q0", "q1", "q2", "q3", "q4", "Bz")
    s_chk = np.linspace(0, L, 7)
    for j in range(fam.size):
        h = 1e-3
        tips, pos = [], []
        for m in (-2, -1, 1, 2):
            p = p0.copy()
            p[j] += m * h
            rr = _solve(p, coupling=coupling, fam=fam)
            tips.append(rr.tip_position)
            x, z, _ = rr.at(s_chk)
            pos.append(np.column_stack([x, z]))
        fd = (tips[0] - 8 * tips[1] + 8 * tips[2] - tips[3]) / (12 * h)
        assert np.abs(S.tip_position[:, j] - fd).max() <= 1e-7 * np.abs(fd).max(), (j, S.tip_position[:, j], fd)
        fdp = (pos[0] - 8 * pos[1] + 8 * pos[2] - pos[3]) / (12 * h)
        dp = S.positions(s_chk)[:, [0, 2], j]
        assert np.abs(dp - fdp).max() <= 1e-7 * np.abs(fdp).max(), j
    # the field's column equals sensitivities' own
    assert np.allclose(S["Bz"]["tip_position"], sensitivities(r, ["Bz"])["Bz"]["tip_position"], rtol=1e-12, atol=0)


def test_magnitude_profile_and_array_input_agree_with_known_columns():
    r = _solve(P0)
    Mp = BEAM.material.particle_magnetization
    s = collocation_nodes(r)
    # a uniform relative change of the moment per length is a change of the particle magnetization
    S = profile_sensitivities(r, dlog_moment=np.full(s.size, 1.0 / Mp), names=["Mp"], params=["particle_magnetization"])
    assert np.allclose(S.tip_position[:, 0], S.tip_position[:, 1], rtol=1e-10, atol=0)
    # an array at the collocation nodes gives what the callable gives, exact eigenvalue or Cholesky test alike
    a = profile_sensitivities(r, FAM.basis(s / L))
    b = profile_sensitivities(r, lambda x: FAM.basis(x / L), exact_eigenvalue=False)
    assert np.array_equal(a.theta, b.theta) and np.isnan(b.min_eigenvalue) and a.min_eigenvalue > 0


def test_profile_sensitivities_refuse_bad_input():
    r = _solve(P0)
    with pytest.raises(ValueError, match="one row per collocation node"):
        profile_sensitivities(r, np.ones((3, 2)))
    with pytest.raises(ValueError, match="finite"):
        profile_sensitivities(r, lambda s: np.full_like(s, np.nan))
    with pytest.raises(ValueError, match="nothing to differentiate"):
        profile_sensitivities(r)
    with pytest.raises(ValueError, match="same parameters"):
        profile_sensitivities(r, lambda s: FAM.basis(s / L), dlog_moment=lambda s: np.ones_like(s))
    with pytest.raises(ValueError, match="names must name"):
        profile_sensitivities(r, lambda s: FAM.basis(s / L), names=["a"])
    with pytest.raises(ValueError, match="unknown parameter 'bz'"):
        profile_sensitivities(r, lambda s: FAM.basis(s / L), params=["bz"])
    with pytest.raises(ValueError, match="must not repeat"):
        profile_sensitivities(r, lambda s: s, names=["Bz"], params=["Bz"])
    with pytest.raises(ValueError, match="inextensible"):
        profile_sensitivities(ms.solve_equilibrium(BEAM, (0, 5e-3), extensible=True), lambda s: s)


# ---- the design objective's Jacobian -------------------------------------------------------------------------------
def _problem(direction="perpendicular", vf=None, coupling="rotated"):
    from magsoft_env.design.optimize import _Problem
    from magsoft_env.design.targets import prepare_target

    target = prepare_target(ms.design.builtin_target("ball"), 30)
    beam = BEAM.replace(length=ms.design.curve_length(target))
    pr = _Problem(target=target, beam=beam, family=FAM, b_range=(1e-3, 20e-3), direction=direction, vf=vf,
                  gravity=9.81, coupling=coupling, extensible=False, clamp_angle=0.0)
    pr.fast = True  # one fixed grid: the objective is a smooth function of x, as its differences need
    pr.fast_options = SolverOptions(nodes=48, tol=1e-14, resolution_tol=1e-3, verify_tol=1e-3,
                                    split_at_knots=False)
    lo, hi = pr.bounds(-np.pi, np.pi)
    return pr, pr.initial_guess(lo, hi)


@pytest.mark.parametrize(("direction", "vf", "coupling"), [("perpendicular", None, "rotated"),
                                                           ("free", (0.1, 0.3), "rotated"),
                                                           ("perpendicular", None, "paper")])
def test_design_jacobian_equals_differences_of_the_objective(direction, vf, coupling):
    pr, x = _problem(direction, vf, coupling)
    x = x + np.linspace(-0.05, 0.05, x.size)  # a generic point, not the aligned guess
    J = pr.jacobian(x)
    assert pr.fallbacks == 0
    h = 1e-5
    for j in range(x.size):
        e = np.zeros_like(x)
        e[j] = h
        fd = (pr.residuals(x + e) - pr.residuals(x - e)) / (2 * h)
        assert np.abs(J[:, j] - fd).max() <= 1e-5 * np.abs(J).max(), j
    # the sum of squares' gradient, what the optimizer descends
    g = 2 * J.T @ pr.residuals(x)
    e = 1e-5 * g / np.linalg.norm(g)
    df = (np.sum(pr.residuals(x + e) ** 2) - np.sum(pr.residuals(x - e) ** 2)) / 2
    assert df == pytest.approx(g @ e, rel=1e-5)


def test_design_jacobian_falls_back_to_differences_at_a_failed_solve():
    pr, x = _problem()
    pr.residuals(x)
    pr._eqs[bytes([True]) + x.tobytes()] = None  # as if this equilibrium had failed
    J = pr.jacobian(x)
    assert pr.fallbacks == 1 and J.shape == (30, x.size) and np.all(np.isfinite(J))


def test_exact_design_at_least_as_good_as_differences():
    fam = ProfileFamily("spline", 5)
    target = ms.solve_equilibrium(BEAM.replace(magnetization=fam.profile(P0, L)), (0.0, 12e-3)).sample(40)
    target = np.column_stack(target[1:3])
    kw = dict(field_bounds=(1e-3, 30e-3), family=fam, n_points=30, n_starts=1, rms_tol=0.0)
    old = ms.design_profile(target, BEAM, jacobian="2-point", **kw)
    new = ms.design_profile(target, BEAM, **kw)
    assert new.settings["jacobian"] == "exact" and old.settings["jacobian"] == "2-point"
    assert new.rms_error <= old.rms_error * (1 + 1e-3) + 1e-9 * L
    assert new.nfev < old.nfev / 3  # one solve an iteration instead of one per variable and one
    # the same ball as design_bench, a handful of iterations: the exact method is ahead after as many iterations
    ball = ms.design.builtin_target("ball")
    kw = dict(field_bounds=(1e-3, 20e-3), n_points=20, n_starts=1, max_nfev=8, size=5, rms_tol=0.0)
    a = ms.design_profile(ball, BEAM, jacobian="2-point", **kw)
    b = ms.design_profile(ball, BEAM, **kw)
    assert b.rms_error <= a.rms_error * 1.05


def test_jacobian_option_is_checked():
    target = ms.design.builtin_target("ball")
    for bad in ("exakt", 3, None):
        with pytest.raises(ValueError, match="jacobian must be one of"):
            ms.design_profile(target, BEAM, field_bounds=(1e-3, 20e-3), jacobian=bad)


def test_extensible_design_takes_differences():
    target = ms.design.builtin_target("ball")
    res = ms.design_profile(target, BEAM, field_bounds=(1e-3, 20e-3), n_points=15, n_starts=1, max_nfev=3, size=5,
                            extensible=True)
    assert res.history[0]["jacobian_fallbacks"] >= 1 and np.isfinite(res.rms_error)


def test_at_a_fold_no_derivative_and_the_design_takes_differences(monkeypatch):
    import magsoft_env.theory.sensitivity as sens

    pr, x = _problem()
    r = _solve(P0)
    monkeypatch.setattr(sens, "FOLD_EIGENVALUE", 1e9)  # every equilibrium counts as at a fold
    for exact in (True, False):
        with pytest.raises(ValueError, match="fold"):
            profile_sensitivities(r, lambda s: FAM.basis(s / L), exact_eigenvalue=exact)
    J = pr.jacobian(x)
    assert pr.fallbacks == 1 and np.all(np.isfinite(J))


def test_a_failed_fast_solve_hands_the_search_to_the_usual_settings():
    pr, x = _problem()
    pr.fast_options = SolverOptions(nodes=8, verify_tol=1e-14, split_at_knots=False)  # never verifies
    r = pr.residuals(x)
    assert pr.fast_misses == 1 and not pr.fast and pr.failed == 0
    pr.fast = False
    assert np.array_equal(r, pr.residuals(x))  # the usual settings' residuals, now cached under them
    assert pr.fallbacks == 0 and np.all(np.isfinite(pr.jacobian(x)))


def test_design_bench_compares_methods_side_by_side(capsys, tmp_path):
    from magsoft_env.bench import design_bench

    rows = design_bench.compare(["dumbbell"], field_max_mT=20.0, family="spline", starts=1, seed=0,
                                coupling="rotated", gripper=True, methods=("exact", "exact"))
    assert [r["jacobian"] for r in rows] == ["exact", "exact"] and rows[1]["rms_ratio"] == 1.0
    assert rows[0]["target"] == "gripper" and rows[0]["speedup"] == 1.0
    md = tmp_path / "t.md"
    assert design_bench.main(["--compare", "--methods", "exact", "--objects", "dumbbell", "--markdown", str(md)]) == 0
    out = capsys.readouterr().out
    assert "speed-up" in out and "dumbbell" in out and "| exact |" in md.read_text()

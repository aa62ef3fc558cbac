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

"""Statics of every MuJoCo rod on the Simulator: one result type, and a stability test that finds the stable branch.

References are the analytical solvers (planar and Kirchhoff), which locate the same bifurcations independently.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.sim import RodOptions, SimEquilibrium, Simulator, mujoco_equilibrium, mujoco_path, static_stability

BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
L = BEAM.length


def _tip_error(eq, ref) -> float:
    return float(np.linalg.norm(eq.tip_position - np.asarray(ref.tip_position))) / L


def test_both_rods_return_one_result_type():
    a = mujoco_equilibrium(BEAM, (0.0, 5e-3), segments=10)
    b = mujoco_equilibrium(BEAM, (0.0, 5e-3), segments=10, rod="cable")
    for eq in (a, b):
        assert isinstance(eq, SimEquilibrium) and eq.success and eq.stable
        assert eq.centreline.shape == (12, 3) and eq.tip_position.shape == (3,)
        np.testing.assert_array_equal(eq.centreline[:, 0], eq.x)
        d = eq.to_dict()
        assert d["stable"] is True and len(d["tip_position_m"]) == 3
    assert a.to_dict()["field_T"] == [0.0, 5e-3] and b.to_dict()["field_T"] == [0.0, 0.0, 5e-3]
    assert a.tip_twist == 0.0 and a.edge_strain < 1e-12 and b.edge_strain < 1e-3
    # the same planar problem on both rods: within the strip's 0.2 % of L
    assert np.linalg.norm(a.tip_position - b.tip_position) / L < 5e-3


def test_strip_above_lateral_buckling_finds_the_stable_branch_without_an_imperfection():
    """0.8415 mT across the width buckles the paper strip sideways; at 1 mT the flat state is unstable, and each
    mirror branch (``branch=+-1``) is reached and matches the Kirchhoff solver's within 1 % of L."""
    ref = ms.solve_equilibrium(BEAM, (0.0, 1e-3, 0.0), gravity=0.0)
    assert ref.success
    found = {}
    for branch in (1, -1):
        eq = mujoco_equilibrium(BEAM, (0.0, 1e-3, 0.0), rod="cable", gravity=0.0, branch=branch)
        assert eq.success and eq.stable is True
        assert "leaving 1 unstable state" in eq.stability.message
        found[branch] = eq
    up, down = found[1], found[-1]
    assert up.tip_position[2] > 5e-3 and down.tip_position[2] < -5e-3  # out of the plane, both ways
    np.testing.assert_allclose(up.tip_position[:2], down.tip_position[:2], atol=1e-9)
    mirror = down if ref.tip_position[2] < 0 else up
    assert _tip_error(mirror, ref) < 0.01
    assert abs(mirror.tip_twist - ref.tip_twist) < 0.03  # rad


def test_the_flat_state_above_buckling_is_reported_unstable():
    eq = mujoco_equilibrium(BEAM, (0.0, 1e-3, 0.0), rod="cable", gravity=0.0, stability=False)
    assert eq.success and eq.stable is None and eq.stability is None
    assert abs(eq.tip_position[2]) < 1e-9  # flat: bent about the strong axis only
    sim = Simulator(BEAM, RodOptions(rod="cable", segments=20, timestep=1e-3, gravity=0.0))
    sim.set_field((0.0, 1e-3, 0.0))
    assert sim.settle(tol=1e-6).success
    st = static_stability(sim)
    assert st.stable is False and st.eigenvalue > 0.0 and "unstable" in st.message
    q = sim.data.qpos.copy()
    static_stability(sim)
    np.testing.assert_array_equal(sim.data.qpos, q)  # the test restores the state


def test_strip_below_buckling_is_stable_as_before():
    eq = mujoco_equilibrium(BEAM, (0.0, 0.5e-3, 0.0), rod="cable", gravity=0.0)
    assert eq.success and eq.stable is True and "leaving" not in eq.stability.message
    assert abs(eq.tip_position[2]) < 1e-9 and round(float(eq.tip_position[1]) * 1e3, 2) == 1.17
    assert eq.stability.eigenvalue < 0.0


def test_planar_chain_under_a_reversed_field_leaves_the_straight_state():
    """A beam magnetized along +x in a field along -x stays straight (an equilibrium) until the field passes its
    critical value; past it the straight state is unstable and the chain finds the bent branch, either way."""
    for bx in (-2e-3, -5e-3):
        ref = ms.solve_equilibrium(BEAM, (bx, 0.0), gravity=0.0)
        eqs = [mujoco_equilibrium(BEAM, (bx, 0.0), gravity=0.0, branch=b) for b in (1, -1)]
        for eq in eqs:
            assert eq.success and eq.stable
        assert eqs[0].tip_position[2] == pytest.approx(-eqs[1].tip_position[2], abs=1e-12)
        mirror = eqs[0] if ref.tip_position[2] > 0 else eqs[1]
        assert _tip_error(mirror, ref) < 5e-3


def test_stability_of_an_ordinary_cantilever_and_its_cost_bound():
    eq = mujoco_equilibrium(BEAM, (0.0, 13e-3), segments=12)
    assert eq.stable and eq.stability.eigenvalue < 0.0 and math.isfinite(eq.stability.scale)
    path = mujoco_path(BEAM, [(0.0, 5e-3), (0.0, 10e-3)], segments=8)
    assert [p.stable for p in path] == [True, True]


def test_statics_arguments_are_checked_before_any_work():
    with pytest.raises(ValueError, match="branch must be"):
        mujoco_equilibrium(BEAM, (0.0, 1e-3), branch=0)
    with pytest.raises(ValueError, match="stability must be a bool"):
        mujoco_equilibrium(BEAM, (0.0, 1e-3), stability="yes")
    with pytest.raises(ValueError, match="B_y"):
        mujoco_equilibrium(BEAM, (0.0, 1e-3, 0.0))  # the planar chain takes no y component
    with pytest.raises(ValueError, match="rod must be one of"):
        mujoco_equilibrium(BEAM, (0.0, 1e-3), rod="rope")
    with pytest.raises(ValueError, match="imperfection"):
        mujoco_equilibrium(BEAM, (0.0, 1e-3), imperfection=float("inf"))

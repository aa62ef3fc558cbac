"""Actuation: current allocation against the pseudo-inverse, a QP and the field it makes, reach and saturation,
the coil drive against the closed-form L/R response, the magnet workspace, ``magsoft field --want-mT``."""

from __future__ import annotations

import doctest
import json
import math

import numpy as np
import pytest
from scipy.linalg import null_space
from scipy.optimize import minimize

from magsoft_env.fields import (
    CoilDrive,
    CoilSystem,
    CylinderMagnet,
    MagnetWorkspace,
    PosedMagnet,
    Transformed,
    allocate,
    reachable_field,
)
from magsoft_env.fields import actuation as actuation_module

POINTS = [(0.0, 0.0, 0.0), (0.02, -0.01, 0.03), (-0.03, 0.02, -0.01)]


@pytest.fixture(scope="module")
def navion():
    return CoilSystem.from_calibration("navion")


@pytest.fixture(scope="module")
def cardiomag():
    return CoilSystem.from_calibration("cardiomag")


def _rel(a, b) -> float:
    return float(np.linalg.norm(np.asarray(a) - np.asarray(b)) / np.linalg.norm(b))


def _field_at(system, point, currents):
    B, G = system.field_and_gradient(np.asarray(point, dtype=float).reshape(1, 3), currents)
    return B[0], G[0]


# ---------------------------------------------------------------------------------------------- allocation


@pytest.mark.parametrize("name", ["navion", "cardiomag"])
@pytest.mark.parametrize("point", POINTS)
def test_allocation_reproduces_a_reachable_field(name, point, navion, cardiomag):
    system = {"navion": navion, "cardiomag": cardiomag}[name]
    rng = np.random.default_rng(abs(hash((name, point))) % 2**32)
    for _ in range(3):
        d = rng.normal(size=3)
        d /= np.linalg.norm(d)
        reach = reachable_field(system, point, d)
        B = 0.6 * reach.magnitude * d
        a = allocate(system, point, field=B)
        assert a.success and a.reachable and a.status in (0, 1)
        assert np.all(np.abs(a.currents) <= system.max_current)
        B_made, G_made = _field_at(system, point, a.currents)  # recomputed from the dipole sum, not the matrix
        assert _rel(B_made, B) < 1e-9 and _rel(a.field, B) < 1e-9
        np.testing.assert_allclose(a.gradient, G_made, rtol=1e-12, atol=1e-15)
        assert a.error["field"] < 1e-9 * np.linalg.norm(B)
        assert a.rank == 3 and a.n_wanted == 3 and "field" in a.settable


def test_least_norm_is_the_pseudo_inverse_and_nothing_smaller_reaches_it(cardiomag):
    x = np.array([0.01, 0.005, -0.02])
    B = np.array([0.004, -0.007, 0.01])
    a = allocate(cardiomag, x, field=B)
    assert a.status == 0 and a.reachable
    A = cardiomag.actuation_matrix(x)[:3]
    I_pinv = np.linalg.pinv(A) @ B  # unweighted: the least-norm solution of a consistent system does not depend on W
    assert _rel(a.currents, I_pinv) < 1e-10
    N = null_space(A)
    assert N.shape == (8, 5)
    rng = np.random.default_rng(3)
    for _ in range(200):
        other = a.currents + N @ rng.normal(scale=0.5, size=5)
        assert _rel(_field_at(cardiomag, x, other)[0], B) < 1e-9  # another solution ...
        assert np.linalg.norm(other) > np.linalg.norm(a.currents)  # ... of larger norm


def test_bounded_least_norm_when_the_pseudo_inverse_exceeds_the_limits(cardiomag):
    x = np.zeros(3)
    d = np.array([0.0, 0.0, 1.0])
    B = 0.95 * reachable_field(cardiomag, x, d).magnitude * d
    A = cardiomag.actuation_matrix(x)[:3]
    assert np.abs(np.linalg.pinv(A) @ B).max() > 20.0  # the unbounded least norm would exceed a limit
    a = allocate(cardiomag, x, field=B)
    assert a.success and a.reachable and a.status == 1 and a.saturated.any()
    assert np.all(np.abs(a.currents) <= 20.0) and _rel(_field_at(cardiomag, x, a.currents)[0], B) < 1e-9
    # an independent QP: minimize |I|^2 subject to A I = B within the bounds (SLSQP, in currents / 20 A)
    qp = minimize(lambda u: u @ u, a.reachable and np.zeros(8), jac=lambda u: 2 * u, method="SLSQP",
                  bounds=[(-1.0, 1.0)] * 8, constraints=[{"type": "eq", "fun": lambda u: (A @ (20 * u) - B) * 1e3}],
                  options={"ftol": 1e-14, "maxiter": 500})
    assert qp.success
    assert np.linalg.norm(a.currents) <= np.linalg.norm(20 * qp.x) * (1 + 1e-7)
    # feasible moves along the null space never shorten it
    N = null_space(A)
    rng = np.random.default_rng(5)
    tried = 0
    for _ in range(2000):
        other = a.currents + N @ rng.normal(scale=0.3, size=5)
        if np.all(np.abs(other) <= 20.0):
            tried += 1
            assert np.linalg.norm(other) >= np.linalg.norm(a.currents) - 1e-9
    assert tried > 20


@pytest.mark.parametrize("name, point, B", [
    ("navion", (0.0, 0.0, 0.0), (0.0, 0.0, 0.05)),         # unique currents: the ratio
    ("navion", (0.02, -0.01, 0.03), (0.03, 0.02, -0.01)),
    ("cardiomag", (0.0, 0.0, 0.0), (0.1, -0.2, 0.15)),     # 8 coils for 3 components: the linear program
])
def test_a_field_beyond_reach_saturates_and_its_scale_limit_is_tight(name, point, B, navion, cardiomag):
    system = {"navion": navion, "cardiomag": cardiomag}[name]
    B = np.array(B)
    a = allocate(system, point, field=B)
    assert a.success and not a.reachable and a.status == 2
    assert a.saturated.any() and np.all(np.abs(a.currents) <= system.max_current)
    assert np.array_equal(a.saturated, np.abs(a.currents) >= system.max_current * (1 - 1e-9))
    assert all(c in a.message for c, f in zip(system.coil_names, a.saturated, strict=True) if f)
    assert 0.0 < a.scale_limit < 1.0
    assert allocate(system, point, field=B * a.scale_limit * 0.999).reachable
    assert not allocate(system, point, field=B * a.scale_limit * 1.001).reachable
    d = B / np.linalg.norm(B)
    assert math.isclose(a.scale_limit * np.linalg.norm(B), reachable_field(system, point, d).magnitude, rel_tol=1e-7)


def test_reachable_field_against_the_inverse_for_three_coils(navion, cardiomag):
    x = np.array([0.01, 0.0, -0.02])
    A = navion.actuation_matrix(x)[:3]
    for d in np.eye(3):
        r = reachable_field(navion, x, d)
        u = np.linalg.solve(A, d)  # currents per tesla along d: unique with 3 coils
        assert math.isclose(r.magnitude, float(np.min(35.0 / np.abs(u))), rel_tol=1e-8)
        assert r.magnitude <= navion.max_field(x) @ np.abs(d) * (1 + 1e-12)
    for d in (np.array([1.0, 1.0, 0.0]) / math.sqrt(2), np.array([0.0, 0.0, -1.0])):
        r = reachable_field(cardiomag, x, d)
        assert r.success and np.all(np.abs(r.currents) <= 20.0 + 1e-9)
        assert _rel(_field_at(cardiomag, x, r.currents)[0], r.magnitude * d) < 1e-8


def test_cardiomag_sets_field_and_gradient_together(cardiomag):
    rng = np.random.default_rng(11)
    for x in POINTS:
        I_true = rng.uniform(-10.0, 10.0, size=8)
        B, G = _field_at(cardiomag, x, I_true)
        for gradient in (G, np.array([G[0, 0], G[0, 1], G[0, 2], G[1, 1], G[1, 2]])):
            a = allocate(cardiomag, x, field=B, gradient=gradient)
            assert a.reachable and a.rank == 8 and a.n_wanted == 8 and "field+gradient" in a.settable
            assert _rel(a.currents, I_true) < 1e-8  # 8 coils, 8 components: the currents are unique
            B2, G2 = _field_at(cardiomag, x, a.currents)
            assert _rel(B2, B) < 1e-9 and _rel(G2, G) < 1e-9
            assert math.isclose(a.scale_limit, float(np.min(20.0 / np.abs(I_true))), rel_tol=1e-7)


def test_navion_cannot_set_a_gradient_and_says_so(navion):
    a = allocate(navion, [0, 0, 0], field=[0, 0, 0.01], gradient=[0.1, 0.0, 0.0, 0.1, 0.0])
    assert a.success and not a.reachable and a.status == 3
    assert a.rank == 3 and a.n_wanted == 8 and a.settable == ("field",) and a.scale_limit == 0.0
    assert "cannot set the gradient independently" in a.message and "3 coils for 8 components" in a.message
    # the field alone it sets exactly
    assert allocate(navion, [0, 0, 0], field=[0, 0, 0.01]).reachable


def test_force_allocation_is_G_transpose_m(cardiomag):
    rng = np.random.default_rng(7)
    m = np.array([0.0, 0.003, 0.008])  # A m^2
    for x in POINTS:
        I_true = rng.uniform(-8.0, 8.0, size=8)
        B, G = _field_at(cardiomag, x, I_true)
        F = G.T @ m
        a = allocate(cardiomag, x, field=B, force=F, moment=m)
        assert a.reachable and a.rank == 6 and "field+force" in a.settable
        B2, G2 = _field_at(cardiomag, x, a.currents)
        assert _rel(B2, B) < 1e-9 and _rel(G2.T @ m, F) < 1e-9 and _rel(a.force, F) < 1e-9
        # least norm among the solutions: 8 coils, 6 components, 2 free directions
        A = np.vstack([cardiomag.actuation_matrix(x)[:3],
                       np.einsum("a,abj->bj", m, cardiomag.actuation_matrix(x, full=True)[3:].reshape(3, 3, -1))])
        assert _rel(a.currents, np.linalg.pinv(A) @ np.concatenate([B, F])) < 1e-8


def test_weights_and_limits_change_the_compromise(navion):
    x = np.zeros(3)
    want = dict(field=[0, 0, 0.01], gradient=[0.1, 0.0, 0.0, 0.1, 0.0])
    field_first = allocate(navion, x, **want, weights=[1e6] * 3 + [1.0] * 5)
    assert field_first.error["field"] < 1e-9 and field_first.error["gradient"] > 0
    lower = allocate(navion, x, field=[0, 0, 0.01], limits=5.0)
    assert not lower.reachable and np.all(np.abs(lower.currents) <= 5.0) and lower.limits.tolist() == [5.0] * 3


@pytest.mark.parametrize("kwargs, match", [
    (dict(field=[0, 0, 10.0 + 1]), r"allocate field components must lie within \+-10 T"),
    (dict(field=[0, 0]), r"allocate field must have shape \(3,\)"),
    (dict(field=[0, 0, 0.01], gradient=np.diag([1.0, 1.0, 1.0])), "symmetric and traceless"),
    (dict(field=[0, 0, 0.01], gradient=[1, 2, 3]), r"5 entries .* or a \(3, 3\) matrix"),
    (dict(field=[0, 0, 0.01], force=[0, 0, 1e-3]), "force and moment go together"),
    (dict(field=[0, 0, 0.01], force=[0, 0, 1e-3], moment=[0, 0, 1e-3], gradient=np.zeros(5)), "not both"),
    (dict(field=[0, 0, 0.01], force=[0, 0, 1e-3], moment=[0, 0, 0]), "moment must not be zero"),
    (dict(field=[0, 0, 0.01], limits=40.0), r"limits\[0\] \(Coil_0\) must lie in \(0, 35\] A"),
    (dict(field=[0, 0, 0.01], weights=[1, 1]), r"weights must have shape \(3,\)"),
    (dict(field=[0, 0, 0.01], weights=[1, 0, 1]), r"weights\[1\] must be > 0"),
    (dict(field=[0, 0, 0.01], tol=2.0), r"tol must lie in \(0, 1\)"),
])
def test_allocate_refuses_bad_input(kwargs, match, navion):
    with pytest.raises(ValueError, match=match):
        allocate(navion, [0, 0, 0], **kwargs)


def test_allocate_refuses_a_non_system_and_a_point_in_mm(navion):
    with pytest.raises(ValueError, match="allocate system must be a CoilSystem"):
        allocate("navion", [0, 0, 0], field=[0, 0, 0.01])
    with pytest.raises(ValueError, match="allocate point must have a norm of at most 1000 m"):
        allocate(navion, [0, 0, 5000.0], field=[0, 0, 0.01])


# ---------------------------------------------------------------------------------------------- coil drive


def test_the_lag_is_exact_in_discrete_time(navion):
    tau, c, T = 0.05, np.array([10.0, -20.0, 5.0]), 0.12
    closed = c * (1.0 - math.exp(-T / tau))  # tau dI/dt = c - I from I = 0
    one = CoilDrive(navion, tau=tau)
    big = one.step(c, T)
    many = CoilDrive(navion, tau=tau)
    for _ in range(1200):
        small = many.step(c, T / 1200)
    np.testing.assert_allclose(big, closed, rtol=1e-12)
    np.testing.assert_allclose(small, closed, rtol=1e-11)
    # per-coil time constants, and 0 for no lag
    per = CoilDrive(navion, tau=[0.01, 0.1, 0.0])
    np.testing.assert_allclose(per.step(c, 0.02), c * np.array([1 - math.exp(-2.0), 1 - math.exp(-0.2), 1.0]),
                               rtol=1e-12)


def test_slew_rate_bounds_the_change(navion):
    drive = CoilDrive(navion, slew_rate=[100.0, 50.0, 1000.0])
    dt, c = 0.01, np.array([10.0, -10.0, 10.0])
    t, last = 0.0, drive.currents
    for _ in range(30):
        now = drive.step(c, dt)
        t += dt
        assert np.all(np.abs(now - last) <= np.array([100.0, 50.0, 1000.0]) * dt * (1 + 1e-12))
        np.testing.assert_allclose(now, np.sign(c) * np.minimum(np.array([100.0, 50.0, 1000.0]) * t, 10.0),
                                   rtol=1e-9)
        last = now
    # the slew rate bounds the lagged response too: a big step with a short lag
    lagged = CoilDrive(navion, slew_rate=100.0, tau=1e-3)
    assert np.allclose(lagged.step([30.0, 0.0, 0.0], 0.01), [1.0, 0.0, 0.0]) and lagged.rate_limited[0]


def test_commands_beyond_the_limits_are_clipped_and_reported(navion):
    drive = CoilDrive(navion)
    out = drive.step([50.0, -36.0, 10.0], 0.01)
    assert out.tolist() == [35.0, -35.0, 10.0] and drive.saturated.tolist() == [True, True, False]
    assert drive.step([0.0, 0.0, 0.0], 0.01).tolist() == [0.0, 0.0, 0.0] and not drive.saturated.any()
    low = CoilDrive(navion, limits=[5.0, 10.0, 35.0], tau=0.2)
    for _ in range(200):
        cur = low.step([100.0, -100.0, 100.0], 0.05)
        assert np.all(np.abs(cur) <= [5.0, 10.0, 35.0])
    assert low.saturated.all()
    assert low.reset([1.0, 2.0, 3.0]).tolist() == [1.0, 2.0, 3.0] and not low.saturated.any()


@pytest.mark.parametrize("build, match", [
    (lambda s: CoilDrive(s, tau=-1.0), r"CoilDrive tau\[0\] must lie in \[0, 1000\] s"),
    (lambda s: CoilDrive(s, slew_rate=0.0), r"CoilDrive slew_rate\[0\] must lie in \(0, 1e\+09\] A/s"),
    (lambda s: CoilDrive(s, slew_rate=[1.0, 2.0]), r"one number or one per coil \(3\)"),
    (lambda s: CoilDrive(s, limits=50.0), r"CoilDrive limits\[0\] \(Coil_0\) must lie in \(0, 35\] A"),
    (lambda s: CoilDrive(s, currents=[0.0, 40.0, 0.0]), r"CoilDrive currents\[1\] \(Coil_1\) must lie within"),
    (lambda s: CoilDrive(s).step([1.0, 2.0], 0.01), r"CoilDrive command must have shape \(3,\)"),
    (lambda s: CoilDrive(s).step([1.0, 2.0, 3.0], 0.0), r"CoilDrive dt must be > 0 \(s\)"),
    (lambda s: CoilDrive(s).step([1.0, 2.0, float("nan")], 0.01), "CoilDrive command must contain only finite"),
    (lambda s: CoilDrive("navion"), "CoilDrive system must be a CoilSystem"),
])
def test_coil_drive_refuses_bad_input(build, match, navion):
    with pytest.raises(ValueError, match=match):
        build(navion)


# ---------------------------------------------------------------------------------------------- magnet pose


def _workspace(**kw):
    return MagnetWorkspace(bounds=[[-0.1, 0.1], [-0.1, 0.1], [0.05, 0.2]], max_tilt=math.radians(30), **kw)


def test_workspace_refuses_poses_naming_the_bound():
    ws = _workspace(keep_out_center=(0, 0, 0), min_distance=0.08)
    with pytest.raises(ValueError, match=r"position z = 0.3 m is outside the magnet workspace's z bounds \[0.05, 0.2"):
        ws.check_pose([0.0, 0.0, 0.3])
    with pytest.raises(ValueError, match=r"tilted 45 deg from the reference axis .* beyond max_tilt = 30 deg"):
        ws.check_pose([0.0, 0.0, 0.1], [1.0, 0.0, 1.0])
    with pytest.raises(ValueError, match="closer than min_distance = 0.08 m"):
        ws.check_pose([0.0, 0.0, 0.06])
    p, R = ws.check_pose([0.05, 0.0, 0.1], [0.0, 0.2, 1.0])
    assert np.allclose(R @ [0, 0, 1], np.array([0.0, 0.2, 1.0]) / math.hypot(0.2, 1.0))
    for kwargs, match in [
        (dict(bounds=[[0.1, -0.1], [0, 1], [0, 1]]), r"bounds x must have min <= max"),
        (dict(bounds=[[0, 1], [0, 1]]), r"bounds must have shape \(3, 2\)"),
        (dict(bounds=[[0, 1]] * 3, max_tilt=4.0), r"max_tilt must lie in \[0, 3.14159\]"),
        (dict(bounds=[[0, 1]] * 3, min_distance=0.1), "needs keep_out_center"),
    ]:
        with pytest.raises(ValueError, match=match):
            MagnetWorkspace(**kwargs)


def test_workspace_clips_into_itself():
    ws = _workspace(keep_out_center=(0, 0, 0), min_distance=0.08)
    p, R, clipped = ws.clip([0.3, -0.05, 0.1], np.eye(3))
    assert clipped and p.tolist() == [0.1, -0.05, 0.1] and np.array_equal(R, np.eye(3))
    p, R, clipped = ws.clip([0.0, 0.0, 0.06])  # too close: pushed out along the line from the centre
    assert clipped and math.isclose(np.linalg.norm(p), 0.08, rel_tol=1e-9) and np.allclose(p[:2], 0)
    axis = np.array([1.0, 0.0, 0.3])
    p, R, clipped = ws.clip([0.0, 0.0, 0.1], axis)
    new_axis = R @ [0, 0, 1]
    assert clipped and math.isclose(ws.tilt(R), math.radians(30), rel_tol=1e-12)
    assert abs(new_axis[1]) < 1e-15 and new_axis[0] > 0  # in the plane of the axis and the reference
    assert np.allclose(R.T @ R, np.eye(3), atol=1e-14)
    p, R, clipped = ws.clip([0.0, 0.0, 0.1], [0.0, 0.0, -1.0])  # pointing opposite to the reference
    assert clipped and math.isclose(ws.tilt(R), math.radians(30), rel_tol=1e-9)
    q, R2, clipped = ws.clip([0.02, 0.03, 0.15], [0.0, 0.1, 1.0])
    assert not clipped and q.tolist() == [0.02, 0.03, 0.15]
    ws.check_pose(*ws.clip([5.0, -5.0, -5.0], [-1.0, 0.0, 0.0])[:2])  # whatever is clipped passes the check


def test_posed_magnet_is_the_transformed_source():
    magnet = CylinderMagnet(position=(0, 0, 0), axis=(0, 0, 1), radius=0.01, length=0.02, magnetization=1e6)
    arm = PosedMagnet(magnet, _workspace())
    pts = np.array([[0.0, 0.0, 0.0], [0.01, -0.02, 0.01]])
    src = arm.at_pose([0.02, 0.0, 0.1], [0.0, 0.3, 1.0])
    assert isinstance(src, Transformed)
    assert np.allclose(src.rotation @ [0, 0, 1], np.array([0.0, 0.3, 1.0]) / math.hypot(0.3, 1.0))
    ref = Transformed(magnet, [0.02, 0.0, 0.1], src.rotation)
    B, G = src.field_and_gradient(pts)
    B0, G0 = ref.field_and_gradient(pts)
    assert np.array_equal(B, B0) and np.array_equal(G, G0)
    B1, _ = arm.field_and_gradient(pts, position=[0.02, 0.0, 0.1], orientation=src.rotation)
    assert np.array_equal(B1, B)
    with pytest.raises(ValueError, match="outside the magnet workspace's x bounds"):
        arm.at_pose([0.5, 0.0, 0.1])
    clipped = arm.at_pose([0.5, 0.0, 0.1], clip=True)
    assert clipped.position.tolist() == [0.1, 0.0, 0.1]
    with pytest.raises(ValueError, match="PosedMagnet workspace must be a MagnetWorkspace"):
        PosedMagnet(magnet, None)


# ---------------------------------------------------------------------------------------------- command line


def test_cli_want_mT_prints_the_allocation(capsys, cardiomag):
    from magsoft_env.cli import main

    argv = ["field", "--source", "cardiomag", "--want-mT", "0", "0", "10", "--at-mm", "5", "0", "10"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "allocation at (5, 0, 10) mm: reachable" in text and "current A" in text and "sets here: field" in text
    assert main([*argv, "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    a = allocate(cardiomag, [0.005, 0.0, 0.01], field=[0.0, 0.0, 0.01])
    assert np.allclose(info["allocation"]["currents_A"], a.currents, rtol=1e-12, atol=1e-12)
    assert info["currents_A"] == info["allocation"]["currents_A"]  # the report uses the allocated currents
    assert np.allclose(info["points"][0]["B_mT"], [0.0, 0.0, 10.0], atol=1e-9)
    assert info["allocation"]["reachable"] and info["allocation"]["saturated"] == []
    assert main(["field", "--source", "navion", "--want-mT", "0", "0", "50", "--json"]) == 0
    beyond = json.loads(capsys.readouterr().out)["allocation"]
    assert not beyond["reachable"] and beyond["saturated"] and beyond["scale_limit"] < 1
    assert main(["field", "--source", "navion", "--want-mT", "0", "0", "10", "--want-gradient-mT-per-m",
                 "100", "0", "0", "100", "0"]) == 0
    assert "cannot set the gradient independently" in capsys.readouterr().out
    assert main(["field", "--source", "navion", "--json"]) == 0
    assert "allocation" not in json.loads(capsys.readouterr().out)  # nothing new without --want-mT


@pytest.mark.parametrize("argv, match", [
    (["--want-mT", "0", "0", "nan"], "--want-mT must be 3 finite components"),
    (["--want-mT", "0", "0", "1e5"], "--want-mT must be 3 finite components within +-10000 mT"),
    (["--want-mT", "0", "0", "10", "--currents-A", "1", "2", "3"], "--want-mT and --currents-A exclude each other"),
    (["--want-gradient-mT-per-m", "1", "0", "0", "1", "0"], "--want-gradient-mT-per-m needs --want-mT"),
    (["--want-mT", "0", "0", "10", "--want-gradient-mT-per-m", "1", "2"], "--want-gradient-mT-per-m takes 5 values"),
    (["--want-mT", "0", "0", "10", "--want-gradient-mT-per-m", *["1"] * 9], "symmetric, traceless"),
    (["--want-mT", "0", "0"], "--want-mT"),
])
def test_cli_want_mT_refuses_bad_input(argv, match, capsys):
    from magsoft_env.cli import main

    try:
        rc = main(["field", "--source", "navion", *argv])
    except SystemExit as exc:  # argparse's own errors (a wrong number of values) exit
        rc = exc.code
    assert rc == 2
    err = capsys.readouterr().err
    assert err.startswith("magsoft field: error:") and match in err and len(err.strip().splitlines()) == 1


def test_the_examples_in_the_docstrings_run():
    result = doctest.testmod(actuation_module)
    assert result.attempted >= 10 and result.failed == 0

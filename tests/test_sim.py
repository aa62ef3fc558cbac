"""MuJoCo rod: closed forms, torque signs, contacts, energy, stability reports, input checks."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import mujoco
import numpy as np
import pytest

from magsoft_env import Beam, PiecewiseConstant
from magsoft_env.sim import (
    RodOptions,
    SimulationError,
    Simulator,
    build_model,
    discretize,
    magnetics,
    mujoco_equilibrium,
    mujoco_path,
)
from magsoft_env.sim.discretize import cell_edges
from magsoft_env.sim.reference import (
    circle_points,
    elastica_dead_load,
    gravity_tip_deflection_small,
    tip_couple_angle,
)

L = 25e-3


@pytest.fixture(scope="module")
def beam():
    return Beam(length=L, width=5e-3, thickness=1.13e-3, volume_fraction=0.2)


def _uniform(beam):
    return float(beam.bending_stiffness(0.0)), float(beam.moment_per_length(0.0)), float(beam.mass_per_length(0.0))


# ---------------------------------------------------------------- discretization


def test_discretization_conserves_mass_and_moment():
    b = Beam(length=L, width=5e-3, thickness=1.13e-3, volume_fraction=PiecewiseConstant([0.1, 0.2, 0.3]),
             magnetization=lambda s: 40.0 * s)
    d = discretize(b, 17)
    s = np.linspace(0.0, L, 200001)
    assert d.mass.sum() == pytest.approx(np.trapezoid(b.mass_per_length(s), s), rel=1e-6)
    mom = b.moment_per_length(s)
    assert d.moment[:, 0].sum() == pytest.approx(np.trapezoid(mom * np.cos(b.beta(s)), s), rel=1e-6)
    assert d.moment[:, 1].sum() == pytest.approx(np.trapezoid(mom * np.sin(b.beta(s)), s), rel=1e-6)
    # stiffness: the cell compliance integral (series springs), here for a cell split by a breakpoint
    j = int(L / 3 / d.ds)
    a, c = j * d.ds, (j + 1) * d.ds
    ss = np.linspace(a, c, 100001)
    assert d.stiffness[j] == pytest.approx(1.0 / np.trapezoid(1.0 / b.bending_stiffness(ss), ss), rel=1e-6)
    assert d.piece_length[0] == pytest.approx(0.5 * d.ds) and d.piece_length[-1] == pytest.approx(0.5 * d.ds)
    assert d.piece_length.sum() == pytest.approx(L)


def test_couples_match_cross_product():
    rng = np.random.default_rng(0)
    m = rng.normal(size=(7, 3))
    b = rng.normal(size=3)
    np.testing.assert_allclose(magnetics.couples(m, b), np.cross(m, b), rtol=1e-14)


# ---------------------------------------------------------------- closed forms


@pytest.mark.parametrize("grading", [1.0, None])  # equal cells and the cantilever default (graded)
def test_tip_couple_gives_uniform_curvature(beam, grading):
    EI, _, _ = _uniform(beam)
    C = 0.5 * math.pi * EI / L  # quarter circle
    sim = Simulator(beam, RodOptions(segments=16, gravity=0.0, timestep=1e-2, grading=grading))
    sim.external_wrench[-1, 4] = -C  # a couple about -y turns +x toward +z
    r = sim.settle(tol=1e-10)
    assert r.success, r.message
    q = sim.data.qpos[sim.rod.hinge_qpos]
    cells = np.diff(cell_edges(L, 16, sim.options.grading))
    assert np.ptp(cells) > 0.1 * cells[0] if grading is None else np.ptp(cells) < 1e-15
    np.testing.assert_allclose(q, C * cells / EI, rtol=1e-7)  # every hinge turns by C / EI x its cell length
    assert sim.tip_angle() == pytest.approx(tip_couple_angle(L, EI, C), rel=1e-7)
    # hinges on the arc up to the O(ds^2) polygon offset
    x, z = sim.centerline()
    xc, zc = circle_points(sim.arc_length(), C / EI)
    assert np.max(np.hypot(x - xc, z - zc)) < 2e-3 * L


def _elastica_error(beam, B, segments):
    EI, AM, _ = _uniform(beam)
    ref = elastica_dead_load(L, EI, AM * B, math.pi / 2)
    eq = mujoco_equilibrium(beam, (0.0, B), gravity=0.0, segments=segments)
    assert eq.success, eq.message
    return math.hypot(eq.x[-1] - ref["x"], eq.z[-1] - ref["z"]) / L, eq.tip_angle - ref["tip_angle"]


def test_uniform_magnetization_matches_elastica_and_converges(beam):
    # 5 mT: Lambda = A M B L^2 / EI = 27.5
    e20, a20 = _elastica_error(beam, 5e-3, 20)
    e40, a40 = _elastica_error(beam, 5e-3, 40)
    assert e20 < 2e-3
    assert e40 < e20 / 3.0  # second order in ds
    assert abs(a40) < abs(a20) / 3.0


def test_gravity_small_deflection_matches_beam_theory(beam):
    EI, _, rhoA = _uniform(beam)
    g = 0.1 * EI / (rhoA * L**3)  # G = 0.1: linear regime
    ref = gravity_tip_deflection_small(L, EI, rhoA, g)
    errs = []
    for n in (10, 20):
        eq = mujoco_equilibrium(beam, (0.0, 0.0), gravity=g, segments=n)
        assert eq.success
        errs.append(abs(eq.tip_deflection / ref - 1.0))
    assert errs[1] < 1e-2
    assert errs[1] < errs[0]


# ---------------------------------------------------------------- signs


def test_field_along_plus_z_lifts_axially_magnetized_beam(beam):
    up = mujoco_equilibrium(beam, (0.0, 3e-3), gravity=0.0, segments=10)
    down = mujoco_equilibrium(beam, (0.0, -3e-3), gravity=0.0, segments=10)
    assert up.z[-1] > 0.1 * L and up.tip_angle > 0
    assert down.z[-1] == pytest.approx(-up.z[-1], rel=1e-6)


def test_transverse_magnetization_turns_toward_field():
    # m along +z in a +x field: m turns toward +x, so the tip goes down
    b = Beam(length=L, width=5e-3, thickness=1.13e-3, magnetization=math.pi / 2)
    eq = mujoco_equilibrium(b, (3e-3, 0.0), gravity=0.0, segments=10)
    assert eq.z[-1] < -0.1 * L and eq.tip_angle < 0


def test_gravity_pulls_down(beam):
    eq = mujoco_equilibrium(beam, (0.0, 0.0), segments=10)
    assert eq.z[-1] < -0.5 * L


# ---------------------------------------------------------------- scenes and contacts


def test_scene_builds_only_what_it_needs(beam):
    m = build_model(beam, RodOptions(gravity=0.0)).model
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_GRAVITY
    assert m.ncam == 0 and m.nlight == 0 and m.ntex == 0
    assert m.ngeom == 0  # no contact: no colliders, no floor, no boxes
    mf = build_model(beam, RodOptions(scene="floor")).model
    assert not mf.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert mujoco.mj_name2id(mf, mujoco.mjtObj.mjOBJ_GEOM, "floor") >= 0
    mc = build_model(beam, RodOptions(scene="channel")).model
    assert mujoco.mj_name2id(mc, mujoco.mjtObj.mjOBJ_GEOM, "channel_ceiling") >= 0
    mo = build_model(beam, RodOptions(scene="obstacle")).model
    oid = mujoco.mj_name2id(mo, mujoco.mjtObj.mjOBJ_GEOM, "obstacle")
    np.testing.assert_allclose(2 * mo.geom_size[oid], (7e-3, 5.5e-3, 2e-3))
    mr = build_model(beam, RodOptions(render=True)).model
    assert mr.ncam == 1 and mr.ngeom == 21  # one visual box per piece


def test_no_floor_means_no_contacts(beam):
    sim = Simulator(beam, RodOptions(segments=20), field=(0.0, 0.0))
    sim.step(300)  # gravity curls the beam far below z = 0
    assert sim.centerline()[1].min() < -0.5 * L
    assert sim.ncon == 0 and sim.contacts() == []


def test_floor_supports_the_beam(beam):
    sim = Simulator(beam, RodOptions(scene="floor", timestep=2e-4))
    sim.step(500)
    assert sim.ncon > 0
    pen = max(c["penetration"] for c in sim.contacts())
    assert pen < 0.1 * beam.thickness  # stiff contact: the rod does not sink
    x, z = sim.centerline()
    assert np.all(np.abs(z - 0.5 * beam.thickness) < 0.1 * beam.thickness)


# ---------------------------------------------------------------- energy and stability


def test_energy_does_not_grow_with_damping_and_constant_field(beam):
    sim = Simulator(beam, RodOptions(segments=20, timestep=5e-4), field=(0.0, 0.008))
    energies = []
    for _ in range(40):
        sim.step(25)
        energies.append(sim.energies()["total"])
    e = np.array(energies)
    scale = abs(e[0] - e[-1])
    assert e[-1] < e[0]
    assert np.all(np.diff(e) <= 1e-6 * scale)


def test_too_large_timestep_is_reported_with_step_and_quantity(beam):
    sim = Simulator(beam, RodOptions(segments=20, integrator="euler", timestep=2e-2), field=(0.0, 0.01))
    with pytest.raises(SimulationError) as info:
        sim.step(200)
    err = info.value
    assert err.step >= 1 and err.quantity
    assert f"step {err.step}" in str(err) and "timestep" in str(err)
    assert err.step < 200  # stopped, not stepped through


@pytest.mark.parametrize(
    "case",
    ["50mT", "reversal", "10Hz", "80seg"],
)
def test_stress_cases_run_clean_or_report(beam, case):
    from magsoft_env.sim.waveforms import Hold, PhaseShifted, Sequence

    n, dt, wf, dur = 20, 1e-3, (0.0, 0.05), 0.3
    if case == "reversal":
        wf, dur = Sequence((Hold((0.0, 0.013), duration=0.15), Hold((0.0, -0.013)))), 0.3
    elif case == "10Hz":
        wf, dur = PhaseShifted(0.01, 0.01, 10.0, 0.0, math.pi / 2), 0.2
    elif case == "80seg":
        n, wf = 80, (0.0, 0.013)
    sim = Simulator(beam, RodOptions(segments=n, timestep=dt))
    try:
        tr = sim.run(wf, dur, record_every=20)
    except SimulationError as err:  # a clear report is acceptable
        assert err.quantity and f"step {err.step}" in str(err)
        return
    assert np.all(np.isfinite(tr.x)) and np.all(np.isfinite(tr.z))
    # inextensible chain: every point within L of the clamp
    assert np.max(np.hypot(tr.x, tr.z)) <= L * (1 + 1e-9)


# ---------------------------------------------------------------- waveforms


def test_waveforms():
    from magsoft_env.sim.waveforms import Hold, PhaseShifted, Ramp, Sequence, Sine, Square

    s = Sine((0.0, 0.01), 2.0)
    assert s(0.125) == pytest.approx((0.0, 0.01))
    sq = Square((0.01, 0.0), 1.0, duty=0.25)
    assert sq(0.2)[0] == 0.01 and sq(0.3)[0] == -0.01
    r = Ramp((0, 0), (0, 0.013), duration=2.0)
    assert r(1.0) == pytest.approx((0.0, 0.0065)) and r(5.0) == pytest.approx((0.0, 0.013))
    rot = PhaseShifted(0.01, 0.01, 3.0, 0.0, math.pi / 2)
    t = np.linspace(0, 1, 50)
    np.testing.assert_allclose(np.hypot(*rot.sample(t).T), 0.01, rtol=1e-12)
    seq = Sequence((Hold((0, 0.013), duration=1.0), Ramp((0, 0.013), (-0.022, 0.013), duration=2.0)))
    assert seq.duration == 3.0
    np.testing.assert_allclose(seq.sample([0.5, 2.0, 9.0]), [[0, 0.013], [-0.011, 0.013], [-0.022, 0.013]])


def test_switched_square_is_a_first_order_coil_driven_by_a_square():
    from magsoft_env.sim.waveforms import Square, SwitchedSquare

    a, f = 2e-3, 2.0
    t = np.linspace(0.0, 2.0, 4001) + 1.234e-5  # off the switching instants
    ideal = SwitchedSquare(0.0, a, f)
    np.testing.assert_array_equal(ideal.sample(t), Square((0.0, a), f).sample(t))
    tau = 0.02
    coil = SwitchedSquare(-a, a, f, math.pi / 2, 0.0, tau)
    b = coil.sample(t)[:, 1]
    # half-wave antisymmetric and periodic (the periodic steady state from t = 0)
    np.testing.assert_allclose(SwitchedSquare(0.0, a, f, 0.0, 0.0, tau).sample(t + 0.25)[:, 1], -b, atol=1e-15)
    np.testing.assert_allclose(coil.sample(t + 0.5), coil.sample(t), atol=1e-15)
    # the defining ODE, tau db/dt = u - b with u = +-a the ideal square, by central differences
    dt = t[1] - t[0]
    u = ideal.sample(t)[:, 1]
    inner = np.flatnonzero((u[:-2] == u[2:]) & (u[1:-1] == u[2:])) + 1  # away from switches
    dbdt = (b[inner + 1] - b[inner - 1]) / (2 * dt)
    np.testing.assert_allclose(tau * dbdt, u[inner] - b[inner], atol=2e-3 * a)
    assert np.abs(np.diff(b)).max() < 2 * a * dt / tau * 1.01  # continuous: no jumps at the switches
    # B_x with its own phase: a quarter period ahead
    np.testing.assert_allclose(coil.sample(t)[:, 0], -SwitchedSquare(0.0, a, f, 0.0, 0.0, tau).sample(t + 0.125)[:, 1],
                               atol=1e-15)


def test_waveform_drives_simulator(beam):
    from magsoft_env.sim.waveforms import Ramp

    sim = Simulator(beam, RodOptions(segments=10, gravity=0.0, timestep=1e-3))
    tr = sim.run(Ramp((0, 0), (0, 0.004), duration=0.1), 0.2, record_every=10)
    assert tr.field[0, 1] == 0.0 and tr.field[-1, 1] == pytest.approx(0.004)
    assert tr.tip_angle[-1] > 0.5


# ---------------------------------------------------------------- input checks


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"segments": 1}, "segments"),
        ({"segments": 2.5}, "segments"),
        ({"scene": "flor"}, "scene"),
        ({"integrator": "rk5"}, "integrator"),
        ({"timestep": 0.0}, "timestep"),
        ({"timestep": 0.5}, "timestep"),
        ({"gravity": -9.81}, "gravity"),
        ({"friction": -1.0}, "friction"),
        ({"contact_timeconst": 0.0}, "contact_timeconst"),
        ({"grading": 20.0}, "grading"),
        ({"base": "left"}, "base"),
        ({"contact_geom": "box"}, "contact_geom"),
        ({"cone": "round"}, "cone"),
        ({"noslip_iterations": -1}, "noslip_iterations"),
        ({"solver_iterations": 0}, "solver_iterations"),
        ({"solver_tolerance": -1.0}, "solver_tolerance"),
        ({"contact_impedance": (0.99, 0.9)}, "contact_impedance"),
        ({"contact_impedance": (0.9, 1.0)}, "contact_impedance"),
        ({"contact_refsafe": "yes"}, "contact_refsafe"),
    ],
)
def test_rod_options_reject_bad_input(kwargs, name):
    with pytest.raises(ValueError, match=name):
        RodOptions(**kwargs)


def test_scene_typo_suggests_name():
    with pytest.raises(ValueError, match="Did you mean 'floor'"):
        RodOptions(scene="flor")


@pytest.mark.parametrize(
    "make, name",
    [
        (lambda W: W.Sine((0, 0.01), 0.0), "frequency"),
        (lambda W: W.Square((0, 0.01), 1.0, duty=1.5), "duty"),
        (lambda W: W.Ramp((0, 0), (0, 13), duration=1.0), "tesla"),
        (lambda W: W.Ramp((0, 0), (0, 0.01), duration=-1.0), "duration"),
        (lambda W: W.Sequence((W.Sine((0, 0.01), 1.0), W.Hold((0, 0)))), "duration"),
        (lambda W: W.PhaseShifted(0.9, 0.9, 1.0), "peak"),
        (lambda W: W.SwitchedSquare(0.0, 0.01, 1.0, time_constant=-1e-3), "time_constant"),
        (lambda W: W.SwitchedSquare(0.0, 0.01, 0.0), "frequency"),
    ],
)
def test_waveforms_reject_bad_input(make, name):
    from magsoft_env.sim import waveforms as W

    with pytest.raises(ValueError, match=name):
        make(W)


def test_equilibrium_rejects_bad_input(beam):
    with pytest.raises(ValueError, match="gravity"):
        mujoco_equilibrium(beam, (0, 0.01), gravity=-1.0)
    with pytest.raises(ValueError, match="max_field_step"):
        mujoco_path(beam, [(0, 0.01)], max_field_step=0.0)
    with pytest.raises(ValueError, match="field"):
        mujoco_equilibrium(beam, 0.01)
    with pytest.raises(ValueError, match="segments"):
        mujoco_equilibrium(beam, (0, 0.01), segments=1)
    with pytest.raises(ValueError, match="beam"):
        discretize("beam", 10)


def test_import_is_light():
    # importing the sim layer pulls in no RL stack and no GL backend (gymnasium itself is
    # imported by the package, which registers its environment ids on import)
    code = (
        "import sys, magsoft_env.sim; "
        "bad = [m for m in ('torch', 'stable_baselines3', 'OpenGL', 'mujoco.egl', 'mujoco.osmesa') "
        "if m in sys.modules]; print(bad); sys.exit(1 if bad else 0)"
    )
    # without MUJOCO_GL: a render test earlier in the session may have set it (mujoco then loads its GL module)
    env = {k: v for k, v in os.environ.items() if k not in ("MUJOCO_GL", "PYOPENGL_PLATFORM")}
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stdout + r.stderr


def test_native_forces_match_general_couples(beam):
    # MuJoCo's pole forces must equal its own projection of the general cross-product couples (R m) x B
    b = Beam(length=L, width=5e-3, thickness=1.13e-3, magnetization=lambda s: 90.0 * s)
    for options in (RodOptions(segments=12, gravity=9.81), RodOptions(segments=12, scene="floor")):
        sim = Simulator(b, options, field=(-0.004, 0.006))
        sim.step(100)  # a bent, moving state
        couples = sim.magnetic_couples()  # brings kinematics up to date
        assert np.abs(couples[:, 1]).max() > 0
        mujoco.mj_forward(sim.model, sim.data)
        expected = np.zeros(sim.model.nv)
        for body, c in zip(sim.rod.body_ids, couples, strict=True):
            mujoco.mj_applyFT(sim.model, sim.data, np.zeros(3), c, sim.data.xipos[body], int(body), expected)
        scale = np.abs(expected).max()
        np.testing.assert_allclose(sim.data.qfrc_actuator, expected, rtol=0, atol=1e-12 * scale)
        assert not sim.data.xfrc_applied.any() and not sim.data.qfrc_applied.any()


def test_couples_as_generalized_forces_match_the_body_couple_path(beam):
    # stepping with MuJoCo's pole forces against stepping a model without them, the general couples
    # written into xfrc_applied every step: equal to round-off
    import dataclasses

    from magsoft_env.sim import Sine, build_model

    b = Beam(length=L, width=5e-3, thickness=1.13e-3, magnetization=lambda s: 90.0 * s)
    for options in (RodOptions(segments=10, timestep=1e-4), RodOptions(segments=10, scene="floor", timestep=1e-4)):
        wf = Sine((1e-3, 2e-3), 2.0)
        a = Simulator(b, options)
        ref = build_model(b, dataclasses.replace(options, magnetics="python"))
        a.set_waveform(wf)
        a.step(500)
        m, d, ids = ref.model, mujoco.MjData(ref.model), ref.body_ids
        for _ in range(500):
            f = wf.sample(np.array([d.time]))[0]
            mujoco.mj_step1(m, d)
            d.xfrc_applied[ids, 3:6] = magnetics.couples(
                magnetics.world_moments(d.xmat[ids], a.backend.m_body), np.array([f[0], 0.0, f[1]]))
            mujoco.mj_step2(m, d)
        assert np.abs(d.qpos[ref.hinge_qpos]).max() > 1e-3  # it bent
        np.testing.assert_allclose(a.data.qpos, d.qpos, rtol=0, atol=1e-12)


@pytest.mark.parametrize("bad", [(float("nan"), 0.0), (0.0, float("inf")), (2.0, 0.0), (np.float64(-1.5), 0.0),
                                 (1e-3,)])
def test_set_field_rejects_bad_fields_on_every_path(beam, bad):
    sim = Simulator(beam, RodOptions(segments=8))
    sim.set_field((1e-3, 2e-3))
    with pytest.raises(ValueError, match="field"):
        sim.set_field(bad)
    assert sim.field.Bx == 1e-3 and sim.field.Bz == 2e-3  # the old field is kept


def test_set_field_fast_path_matches_field_object(beam):
    a, b = Simulator(beam, RodOptions(segments=8)), Simulator(beam, RodOptions(segments=8))
    a.set_field((np.float64(3e-3), -2e-3))
    from magsoft_env import Field

    b.set_field(Field(3e-3, -2e-3))
    a.step(50)
    b.step(50)
    np.testing.assert_array_equal(a.data.qpos, b.data.qpos)
    assert a.tip_position() == (float(a.centerline()[0][-1]), float(a.centerline()[1][-1]))

"""The 3D rod (MuJoCo flexcomp strip): its build, its material frame and couples, its statics against the 3D
analytical model, its frequencies against the beam formulas."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.sim import (
    RodBackend,
    RodOptions,
    SimulationError,
    Simulator,
    UnphysicalError,
    build_model,
    mujoco_equilibrium,
)
from magsoft_env.sim import cable as C
from magsoft_env.sim.discretize import cell_edges
from magsoft_env.sim.waveforms import Waveform

BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
WIDTH_MAG = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, magnetization=(0, 1, 0))
L = BEAM.length


def _cable(beam=BEAM, **kw):
    return C.build_cable(beam, RodOptions(rod="cable", **kw))


# ------------------------------------------------------------------------------------------ options
def test_rod_options_choose_and_check_the_rod():
    assert RodOptions().rod == "planar"
    assert RodOptions(rod="cable").rod == "cable"
    with pytest.raises(ValueError, match="rod"):
        RodOptions(rod="chain3d")
    assert RodOptions(rod="cable", scene="channel").scene == "channel"  # the strip builds every scene
    with pytest.raises(ValueError, match="integrators"):
        RodOptions(rod="cable", integrator="implicitfast")
    with pytest.raises(ValueError, match="clamp_angle"):
        RodOptions(rod="cable", clamp_angle=0.1)
    with pytest.raises(ValueError, match="planar hinge chain"):
        build_model(BEAM, RodOptions(rod="cable"))
    with pytest.raises(ValueError, match="imperfection"):
        mujoco_equilibrium(BEAM, (0.0, 1e-3), imperfection=float("nan"))


# ------------------------------------------------------------------------------------------ build
def test_layout_keeps_mass_first_moment_and_cell_stiffness():
    beam = ms.Beam(length=20e-3, width=4e-3, thickness=1e-3, volume_fraction=lambda s: 0.1 + 5.0 * s)
    lay = C.cable_layout(beam, 12, grading=1.5)
    s = np.linspace(0.0, beam.length, 20001)
    mu = beam.mass_per_length(s)
    assert lay.vertex_mass.sum() == pytest.approx(np.trapezoid(mu, s), rel=1e-7)
    assert lay.vertex_mass @ lay.s == pytest.approx(np.trapezoid(mu * s, s), rel=1e-7)
    assert lay.s[0] == 0.0 and lay.s[-1] == beam.length and len(lay.s) == 14
    # the stiffer clamp end (more particles at the tip here: stiffer tip cells)
    assert np.all(np.diff(lay.stiffness[:, 0] * np.diff(cell_edges(beam.length, 12, 1.5))) > 0)
    ratio = lay.stiffness[:, 1] / lay.stiffness[:, 0]
    np.testing.assert_allclose(ratio, (beam.width / beam.thickness) ** 2, rtol=1e-12)


def test_model_carries_the_beam_values():
    cm = _cable(segments=8, timestep=1e-3)
    m, lay = cm.model, cm.layout
    assert cm.clamped and m.nv == 3 * 8 + 8  # 8 free vertices, 8 free edges (the first is clamped)
    assert np.all(cm.vertex_body[:2] == 0) and np.all(cm.twist_dof[1:] >= 0) and cm.twist_dof[0] == -1
    np.testing.assert_allclose(m.body_mass[cm.vertex_body[2:]], lay.vertex_mass[2:], rtol=1e-12)
    tb = m.jnt_bodyid[m.dof_jntid[cm.twist_dof[1:]]]
    np.testing.assert_allclose(m.body_inertia[tb, 0], lay.twist_inertia[1:], rtol=1e-12)
    assert m.body_inertia[tb, 0].max() < 1e-9  # below MuJoCo's floor: the physical value survived mj_setConst
    rec = m.flex_bending[1:1 + 10 * 8].reshape(8, 10)
    np.testing.assert_allclose(rec[:, 4], 0.5 * lay.stiffness[:, 0], rtol=1e-12)
    np.testing.assert_allclose(rec[:, 5] + rec[:, 4], 0.5 * lay.stiffness[:, 1], rtol=1e-12)
    np.testing.assert_allclose(rec[:, 8], 0.5 * lay.stiffness[:, 2], rtol=1e-12)
    # the cells' hinge stiffnesses E I_w / ds (the cantilever's default grading)
    ei_w = float(BEAM.stiffnesses(np.array([0.0]))[0, 0])
    cells = np.diff(cell_edges(L, 8, RodOptions(rod="cable").grading))
    np.testing.assert_allclose(lay.stiffness[:, 0], ei_w / cells, rtol=1e-9)


def test_bending_law_is_mujocos_tan_half_angle():
    """One vertex bent by phi resists with 2 K tan(phi/2) sec^2(phi/2): the hinge stiffness K written into the
    record, stiffening by phi^2 / 3 (the reason the strip's strong-bending error exceeds the planar chain's)."""
    cm = _cable(segments=4, timestep=1e-3, gravity=0.0, retardation_time=0.0)
    m, d = cm.model, mujoco.MjData(cm.model)
    K, l = cm.layout.stiffness[-1, 0], cm.layout.edge_length[-1]
    for phi in (0.01, 0.2, 0.6):
        d.qpos[:] = 0.0
        d.qpos[cm.vertex_qpos[-1, 0]] = l * (math.cos(phi) - 1.0)
        d.qpos[cm.vertex_qpos[-1, 2]] = l * math.sin(phi)
        mujoco.mj_forward(m, d)
        f = d.qfrc_passive[cm.vertex_dof[-1]]
        torque = -np.cross([l * math.cos(phi), 0.0, l * math.sin(phi)], f)[1]
        assert abs(torque) == pytest.approx(2.0 * K * math.tan(phi / 2) / math.cos(phi / 2) ** 2, rel=1e-9)


# ------------------------------------------------------------------------------------------ frames and couples
def test_material_frame_at_rest_lies_flat():
    cm = _cable(segments=6, timestep=1e-3)
    d = mujoco.MjData(cm.model)
    t, d1, d2 = C.material_frames(cm, d)
    np.testing.assert_allclose(t, np.tile([1.0, 0, 0], (7, 1)), atol=1e-15)
    np.testing.assert_allclose(d1, np.tile([0.0, 1, 0], (7, 1)), atol=1e-15)
    np.testing.assert_allclose(d2, np.tile([0.0, 0, 1], (7, 1)), atol=1e-15)


@pytest.mark.parametrize("psi", [0.5, -0.5])
def test_twist_sign_matches_mujocos_elastic_forces(psi):
    """Bend the last vertex in a plane tilted by psi: MuJoCo's passive force on the twist hinges turns the weak
    axis d1 toward the bending binormal, in the direction our material frame says that is."""
    cm = _cable(segments=4, timestep=1e-3, gravity=0.0, retardation_time=0.0)
    m, d = cm.model, mujoco.MjData(cm.model)
    dz = 1e-4
    d.qpos[cm.vertex_qpos[-1, 1]] = dz * math.sin(psi)
    d.qpos[cm.vertex_qpos[-1, 2]] = dz * math.cos(psi)
    mujoco.mj_forward(m, d)
    tw = cm.twist_dof[-1]
    x = C.vertices(cm, d)
    e = np.diff(x[-3:], axis=0)
    b = np.cross(e[0], e[1])
    b /= np.linalg.norm(b)

    def alignment(theta):
        d.qpos[cm.twist_qpos[-1]] = theta
        return float(C.material_frames(cm, d)[1][-1] @ b) ** 2

    gain = alignment(1e-3) - alignment(-1e-3)
    assert abs(gain) > 1e-6 and np.sign(d.qfrc_passive[tw]) == np.sign(gain)


def test_couples_do_the_virtual_work_of_the_magnetic_energy():
    """The generalized force of the applied force pairs and twist torques equals -dE/dq of E = -sum (R m) . B
    (central differences), in a deformed, twisted state with a magnetization in all three directions."""
    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3,
                   magnetization=(lambda s: 1.0 + 0 * s, lambda s: 0.6 - 30.0 * s, 0.8))
    cm = _cable(beam, segments=6, timestep=1e-3, gravity=0.0)
    m, d = cm.model, mujoco.MjData(cm.model)
    rng = np.random.default_rng(3)
    free = cm.vertex_qpos[cm.vertex_qpos >= 0]
    d.qpos[free] = rng.uniform(-1e-3, 1e-3, free.size)
    d.qpos[cm.twist_qpos[cm.twist_qpos >= 0]] = rng.uniform(-0.5, 0.5, 6)
    for _ in range(3):
        mujoco.mj_step(m, d)
    d.qvel[:] = 0.0
    # make the stored reference frames those of this state (the frame's linearization point)
    t, d1, _ = C.material_frames(cm, d)
    theta = np.where(cm.twist_qpos >= 0, d.qpos[np.maximum(cm.twist_qpos, 0)], 0.0)
    u = np.cos(theta)[:, None] * d1 - np.sin(theta)[:, None] * np.cross(t, d1)
    a = m.flex_plasticadr[0]
    d.plastic[a:a + 6 * 7] = np.concatenate([t, u], axis=1).ravel()
    B = np.array([2e-3, -1.5e-3, 3e-3])
    mujoco.mj_forward(m, d)
    C.apply_field(cm, d, B)
    q = d.qfrc_applied.copy()
    for b in range(1, m.nbody):  # what mj_step does with xfrc_applied: a wrench at each body's centre of mass
        mujoco.mj_applyFT(m, d, d.xfrc_applied[b, :3].copy(), d.xfrc_applied[b, 3:].copy(), d.xipos[b].copy(), b, q)
    h = 1e-7
    fd = np.zeros(m.nv)
    q0 = d.qpos.copy()
    for k in range(m.nv):  # nq == nv: slides and hinges only
        d.qpos[:] = q0
        d.qpos[k] += h
        ep = C.magnetic_energy(cm, d, B)
        d.qpos[k] -= 2 * h
        em = C.magnetic_energy(cm, d, B)
        fd[k] = -(ep - em) / (2 * h)
    np.testing.assert_allclose(q, fd, atol=1e-7 * np.abs(fd).max())
    assert np.abs(q).max() > 0.0


# ------------------------------------------------------------------------------------------ statics vs 3D model
def _err(eq, ref):
    return np.linalg.norm(eq.tip_position - ref.tip_position) / L


def test_planar_field_with_gravity_matches_the_elastica():
    """(0, 0, 5 mT) with gravity, N = 20, dt = 1 ms: 0.26 % of L measured (docs/sim.md, second order in N)."""
    eq = mujoco_equilibrium(BEAM, (0.0, 0.0, 5e-3), rod="cable", grading=1.0)
    ref = ms.solve_equilibrium(BEAM, (0.0, 0.0, 5e-3), gravity=9.81)
    assert eq.success and eq.centreline.shape == (22, 3)
    assert _err(eq, ref) < 4e-3
    assert abs(eq.tip_position[1]) < 1e-12 and abs(eq.tip_twist) < 1e-9
    # the axial magnetization's poles load the edges with their own tension (m_a / l0) (B . t): 1.4e-3 at this 1 ms
    # step (4.3e-4 with the couples written from Python; docs/sim.md)
    assert eq.edge_strain < 2e-3


def test_planar_pair_keeps_its_planar_meaning():
    a = mujoco_equilibrium(BEAM, (1e-3, 2e-3), rod="cable", gravity=0.0, segments=10)
    b = mujoco_equilibrium(BEAM, (1e-3, 0.0, 2e-3), rod="cable", gravity=0.0, segments=10)
    np.testing.assert_array_equal(a.tip_position, b.tip_position)


def test_field_across_the_width_bends_about_the_strong_axis():
    """(0, 0.5 mT, 0), no gravity: 0.003 % of L measured at N = 20."""
    eq = mujoco_equilibrium(BEAM, (0.0, 0.5e-3, 0.0), rod="cable", gravity=0.0, grading=1.0)
    ref = ms.solve_equilibrium(BEAM, (0.0, 0.5e-3, 0.0), gravity=0.0)
    assert eq.success and _err(eq, ref) < 2e-4
    assert abs(eq.tip_position[2]) < 1e-12


def test_width_magnetization_twists_like_the_torsional_elastica():
    """Magnetization across the width, field along z: pure twist, -0.014 degree at N = 20 (0.1 degree asked)."""
    eq = mujoco_equilibrium(WIDTH_MAG, (0.0, 0.0, 1e-3), rod="cable", gravity=0.0, grading=1.0)
    ref = ms.solve_equilibrium(WIDTH_MAG, (0.0, 0.0, 1e-3), gravity=0.0)
    assert eq.success
    assert abs(math.degrees(eq.tip_twist - ref.tip_twist)) < 0.05
    assert _err(eq, ref) < 1e-9


def test_past_the_buckling_field_the_strip_leaves_its_plane():
    """(0, 1.2 mT, 0), no gravity, seeded by a 10 uT field along -z during the ramp: the analytical buckled branch
    (tip z = -10.2 mm, twist 0.78 rad); 1.5 % of L and -0.95 degree at N = 20, second order in N."""
    eq = mujoco_equilibrium(BEAM, (0.0, 1.2e-3, 0.0), rod="cable", gravity=0.0, grading=1.0, imperfection=-1e-5)
    ref = ms.solve_equilibrium(BEAM, (0.0, 1.2e-3, 0.0), gravity=0.0)
    assert eq.success and ref.tip_position[2] < -5e-3
    assert np.sign(eq.tip_position[2]) == np.sign(ref.tip_position[2])
    assert _err(eq, ref) < 2.5e-2
    assert abs(eq.tip_twist - ref.tip_twist) < math.radians(2.0)


@pytest.mark.slow
def test_statics_converge_with_segments():
    errs = []
    for n in (10, 20, 40):
        eq = mujoco_equilibrium(BEAM, (0.0, 1.2e-3, 0.0), rod="cable", gravity=0.0, grading=1.0,
                                imperfection=-1e-5, segments=n)
        errs.append(_err(eq, ms.solve_equilibrium(BEAM, (0.0, 1.2e-3, 0.0), gravity=0.0)))
    assert errs[0] > 3.0 * errs[1] > 9.0 * errs[2]  # second order (measured ratios 3.4 and 3.8)


# ------------------------------------------------------------------------------------------ dynamics
def test_beam_formula_frequencies():
    f = C.frequencies(BEAM)
    assert f["weak"] == pytest.approx(2.33, abs=0.01)
    assert f["strong"] == pytest.approx(10.29, abs=0.01)
    assert f["torsion"] == pytest.approx(18.83, abs=0.01)


def test_weak_bending_frequency_at_a_coarse_step():
    fr, _, sig = C.free_vibration(BEAM, "weak", segments=20, timestep=1e-3)
    assert np.all(np.isfinite(sig))
    assert fr == pytest.approx(C.frequencies(BEAM)["weak"], rel=5e-3)  # -0.06 % measured


@pytest.mark.slow
@pytest.mark.parametrize("mode", C.MODES)
def test_first_frequencies_match_the_beam_formulas(mode):
    """N = 20, dt = 0.1 ms: -0.07, -0.03, -0.01 % measured. 0.3 %: the rod's discretization error at N = 20
    (lumped masses, second order) with room for the zero-crossing estimate over four periods; the torsion
    frequency needs the physical twist inertia (MuJoCo's default gave 3.2 Hz)."""
    fr, _, _ = C.free_vibration(BEAM, mode, segments=20, timestep=1e-4)
    assert fr == pytest.approx(C.frequencies(BEAM)[mode], rel=3e-3)


# ------------------------------------------------------------------------------------------ the Simulator
def test_elastic_energy_is_what_mujocos_forces_derive_from():
    """The gradient of :func:`cable.elastic_energy` against MuJoCo's elastic forces in a bent, twisted state:
    within 3 % of the largest force (the vertex frames MuJoCo averages are not exactly ours)."""
    cm = _cable(segments=6, timestep=1e-4, gravity=0.0, retardation_time=0.0)
    m, d = cm.model, mujoco.MjData(cm.model)
    rng = np.random.default_rng(1)
    free = cm.vertex_qpos[cm.vertex_qpos >= 0]
    d.qpos[free] = rng.uniform(-3e-4, 3e-4, free.size)
    d.qpos[cm.twist_qpos[cm.twist_qpos >= 0]] = rng.uniform(-0.2, 0.2, 6)
    for _ in range(3):
        mujoco.mj_step(m, d)
    d.qvel[:] = 0.0
    mujoco.mj_forward(m, d)
    q0 = d.qpos.copy()
    fd = np.zeros(m.nv)
    for k in range(m.nv):
        d.qpos[:] = q0
        d.qpos[k] += 1e-8
        ep = C.elastic_energy(cm, d)
        d.qpos[k] -= 2e-8
        fd[k] = -(ep - C.elastic_energy(cm, d)) / 2e-8
    d.qpos[:] = q0
    mujoco.mj_forward(m, d)
    np.testing.assert_allclose(d.qfrc_passive, fd, atol=0.03 * np.abs(fd).max())


def test_simulator_steps_the_cable_rod():
    sim = Simulator(BEAM, RodOptions(rod="cable", segments=20, timestep=1e-3, grading=1.0), field=(0.0, 0.0, 5e-3))
    assert isinstance(sim.backend, C.CableRod) and isinstance(sim.backend, RodBackend)
    r = sim.settle()
    assert r.success
    eq = mujoco_equilibrium(BEAM, (0.0, 0.0, 5e-3), rod="cable", grading=1.0)
    np.testing.assert_allclose(sim.tip_position(), eq.tip_position, atol=1e-6 * L)
    x, y, z = sim.centerline()
    assert len(x) == 22 and sim.field == ms.Field(0.0, 0.0, 5e-3)
    e = sim.energies()
    assert e["elastic"] > 0 and e["magnetic"] < 0
    sim.set_field((0.0, 1e-3, 5e-3))  # a field with a y component bends it sideways
    sim.step(300)
    assert sim.tip_position()[1] > 1e-4 and sim.field.By == 1e-3
    tr = sim.run((0.0, 0.0, 5e-3), 0.02, record_every=10)  # the 3D rod records x, y, z and three components
    assert tr.field.shape == (3, 3) and tr.y.shape == tr.x.shape == tr.z.shape == (3, 22)
    np.testing.assert_array_equal(tr.field[-1], [0.0, 0.0, 5e-3])
    np.testing.assert_allclose([tr.x[-1, -1], tr.y[-1, -1], tr.z[-1, -1]], sim.tip_position(), rtol=0, atol=0)
    assert "y_m" in tr.to_dict()


class _Rotating(Waveform):
    """A field of 2 mT turning about x at 5 Hz: (0, B sin wt, B cos wt)."""

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = 2 * np.pi * 5.0
        return np.stack([0 * t, 2e-3 * np.sin(w * t), 2e-3 * np.cos(w * t)], axis=1)


def test_changing_3d_field_is_the_per_step_loop():
    """A waveform in three components, the couples written from Python (``magnetics="python"``; an axial beam's are
    otherwise native, tests/test_strip_native.py): the engine's steps are those of writing the couples of each
    step's field before ``mj_step``, bit for bit."""
    opts = RodOptions(rod="cable", segments=8, timestep=1e-4, gravity=9.81, magnetics="python")
    sim = Simulator(BEAM, opts)
    sim.set_waveform(_Rotating())
    sim.step(400)
    cm = C.build_cable(BEAM, opts)
    d = mujoco.MjData(cm.model)
    fields = _Rotating().sample(1e-4 * np.arange(400))
    for f in fields:
        C.apply_field(cm, d, f)
        mujoco.mj_step(cm.model, d)
    np.testing.assert_array_equal(sim.data.qpos, d.qpos)
    np.testing.assert_array_equal(sim.field.vector(), fields[-1])
    assert abs(sim.tip_position()[1]) > 1e-5 and np.isfinite(sim.backend.tip_twist(sim.data))


def test_health_checks_of_the_cable_rod():
    sim = Simulator(BEAM, RodOptions(rod="cable", segments=8, timestep=1e-4))
    cm = sim.backend.rod
    sim.data.qpos[cm.vertex_qpos[-1, 0]] += 0.2 * cm.layout.edge_length[-1]  # the last edge 20 % too long
    with pytest.raises(SimulationError, match="edge stretch"):
        sim.step(1)
    sim.reset()
    sim.step(10)
    sim.data.qvel[3] = np.nan
    with pytest.raises(SimulationError, match="non-finite"):
        sim.step(10)


@pytest.mark.parametrize(("tilt", "final"), [(0.0, 0.0), (30.0, 0.0), (80.0, 90.0)])
def test_on_the_floor_the_strip_lies_flat_topples_or_stands(tilt, final):
    """A free strip on the floor (default 2 ms contact): flat it stays flat, from a 30 degree tilt about its axis it
    topples onto its wide face, from 80 degrees it stands on its narrow face (statically stable there)."""
    cm = _cable(scene="floor", segments=20, timestep=1e-4)
    m, d = cm.model, mujoco.MjData(cm.model)
    th = math.radians(tilt)
    w, h = BEAM.width, BEAM.thickness
    d.qpos[cm.twist_qpos[cm.twist_qpos >= 0]] = th
    d.qpos[cm.vertex_qpos[:, 2]] = 0.5 * w * math.sin(th) + 0.5 * h * math.cos(th) - 0.5 * h
    for _ in range(1500):
        mujoco.mj_step(m, d)
    _, d1, _ = C.material_frames(cm, d)
    angle = np.degrees(np.arctan2(d1[:, 2], d1[:, 1]))
    assert np.all(np.abs(angle - final) < 5.0)
    z = C.vertices(cm, d)[:, 2]
    rest = 0.5 * (w if final else h)
    assert np.all(np.abs(z - rest) < 0.1 * h)


def _tilted(sim, tilt_deg):
    """Turn the free strip about its axis by ``tilt_deg``, its lower long edge on the floor."""
    cm = sim.backend.rod
    th = math.radians(tilt_deg)
    w, h = BEAM.width, BEAM.thickness
    sim.data.qpos[cm.twist_qpos[cm.twist_qpos >= 0]] = th
    sim.data.qpos[cm.vertex_qpos[:, 2]] = 0.5 * w * math.sin(th) + 0.5 * h * math.cos(th) - 0.5 * h


def test_simulator_drops_the_strip_on_the_floor_and_settles():
    """The Simulator's floor scene with the 3D rod: dropped flat it settles lying flat, the deepest contact (read
    every step) far inside the bound, the energy balance tracked and passive."""
    sim = Simulator(BEAM, RodOptions(rod="cable", scene="floor", segments=20, timestep=1e-4))
    assert sim.backend.has_contact and math.isfinite(sim.energy_drift)
    sim.data.qpos[sim.backend.rod.vertex_qpos[:, 2]] = 0.2 * BEAM.thickness  # dropped from 0.2 h
    sim.step(1000)
    r = sim.settle()
    assert r.success, r.message
    hl = sim.health()
    assert 0.0 < hl["max_penetration_h"] < 0.1 and hl["energy_drift"] < 1e-6  # 0.045 h landing (2 ms contact)
    _, _, z = sim.centerline()
    assert np.all(np.abs(z - 0.5 * BEAM.thickness) < 0.1 * BEAM.thickness)
    assert sim.ncon >= 2 * 21


def test_simulator_strip_tilted_30_degrees_falls_flat():
    """From a 30 degree tilt about its axis the strip falls onto its wide face; its landing reaches 0.16 h (the
    corner rocks 2 degrees past flat) with the default 2 ms contact, inside the 1 h bound, which a tighter bound
    turns into an UnphysicalError."""
    sim = Simulator(BEAM, RodOptions(rod="cable", scene="floor", segments=20, timestep=1e-4))
    _tilted(sim, 30.0)
    sim.step(1500)
    _, d1, _ = C.material_frames(sim.backend.rod, sim.data)
    assert np.all(np.abs(np.degrees(np.arctan2(d1[:, 2], d1[:, 1]))) < 1.0)
    assert 0.05 < sim.health()["max_penetration_h"] < 0.3
    tight = Simulator(BEAM, RodOptions(rod="cable", scene="floor", segments=20, timestep=1e-4),
                      penetration_limit=0.05)
    _tilted(tight, 30.0)
    with pytest.raises(UnphysicalError, match="penetration") as err:
        tight.step(1500)
    assert err.value.cause == "penetration" and err.value.figures["penetration_h"] > 0.05


def test_floor_contact_takes_the_flex_parameters():
    """The flex's contact parameters win over the floor geom's defaults (no mixing of solref, no larger friction)."""
    cm = _cable(scene="floor", segments=8, timestep=1e-4, friction=0.3)
    d = mujoco.MjData(cm.model)
    mujoco.mj_forward(cm.model, d)
    assert d.ncon > 0
    np.testing.assert_allclose(d.contact.friction[:d.ncon, 0], 0.3)
    np.testing.assert_allclose(d.contact.solref[:d.ncon], np.tile(cm.model.flex_solref[0], (d.ncon, 1)))


def _pressed(cm):
    """A free strip lying flat, pressed 2 um into the floor, its contacts found (``mj_forward``)."""
    d = mujoco.MjData(cm.model)
    d.qpos[cm.vertex_qpos[:, 2]] = -2e-6
    mujoco.mj_forward(cm.model, d)
    return d


def test_floor_contact_is_the_elements_rolling_with_the_edges():
    """On the box floor every edge's box touches with its four bottom corners, and each contact moves with its
    edge's rotation: a corner's speed along the strip is the edge's in-plane angular velocity times h / 2 (what
    the planar chain's capsules and boxes do); the plane touches only at the vertices, two corners each."""
    n = 6
    cm = _cable(scene="floor", segments=n, timestep=1e-4)
    d = _pressed(cm)
    c = d.contact
    assert d.ncon == 4 * (n + 1)
    assert np.all(c.elem[:d.ncon, 1] >= 0) and np.all(c.vert[:d.ncon] == -1)
    np.testing.assert_array_equal(np.bincount(c.elem[:d.ncon, 1]), np.full(n + 1, 4))
    # vertex z velocities only: each edge turns about the width axis at (zdot_1 - zdot_0) / l
    zdot = np.random.default_rng(3).normal(size=n + 2)
    d.qvel[:] = 0.0
    d.qvel[cm.vertex_dof[:, 2]] = zdot
    v = np.zeros(d.nefc)
    mujoco.mj_mulJacVec(cm.model, d, v, d.qvel)
    for k in range(d.ncon):
        e = c.elem[k, 1]
        row = c.efc_address[k]
        frame = c.frame[k].reshape(3, 3)
        world = v[row: row + 3] @ frame  # normal, first and second tangent rows: the point's world velocity
        # the lever reaches the contact point, midway through the 2 um overlap
        lever = (0.5 * BEAM.thickness + 0.5 * c.dist[k]) * (zdot[e + 1] - zdot[e]) / cm.layout.edge_length[e]
        assert world[0] == pytest.approx(lever, rel=1e-6)
    vert = C.build_cable(BEAM, RodOptions(rod="cable", scene="floor", segments=n, timestep=1e-4),
                         floor_contact="vertex")
    d = _pressed(vert)
    assert d.ncon == 2 * (n + 2) and np.all(d.contact.vert[:d.ncon, 1] >= 0)
    with pytest.raises(ValueError, match="floor_contact"):
        C.build_cable(BEAM, RodOptions(rod="cable", scene="floor", segments=n), floor_contact="capsule")


def test_simulator_strip_on_the_floor_books_the_work_of_three_components():
    """A held field jump and a field turning about z on the floor: the balance books the work of all three
    components (a launch would break it), so the passive strip stays at or below zero drift."""
    sim = Simulator(BEAM, RodOptions(rod="cable", scene="floor", segments=12, timestep=1e-4))
    sim.set_field((1e-3, 1e-3, 0.0))
    sim.step(300)
    w_held = sim._health.work
    assert w_held != 0.0
    sim.set_waveform(_RotatingZ())
    sim.step(600)
    assert sim._health.energy_valid and sim.energy_drift < 1e-4 and sim._health.work != w_held
    sim._health.work -= 1.0  # a joule the field never supplied: what a launch looks like to the balance
    with pytest.raises(UnphysicalError, match="launch"):
        sim.step(100)


class _RotatingZ(Waveform):
    """2 mT turning about z at 5 Hz: (B cos wt, B sin wt, 0)."""

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = 2 * np.pi * 5.0
        return np.stack([2e-3 * np.cos(w * t), 2e-3 * np.sin(w * t), 0 * t], axis=1)


def test_weak_bending_damping_is_kelvin_voigt():
    """The retardation time damps weak bending as the planar chain's hinges: damping ratio omega tau / 2
    (0.0372 measured against 0.0365 for 5 ms; MuJoCo's own weighting would give w / h = 4.4 times more)."""
    tau = 5e-3
    cm = _cable(segments=10, timestep=1e-4, gravity=0.0, retardation_time=tau)
    m, d = cm.model, mujoco.MjData(cm.model)
    d.qvel[cm.vertex_dof[2:, 2]] = 1e-3 * (cm.layout.s[2:] / L) ** 2  # a first-mode-like kick
    f = C.frequencies(BEAM)["weak"]
    n = int(4.0 / f / 1e-4)
    z = np.empty(n)
    for k in range(n):
        mujoco.mj_step(m, d)
        z[k] = C.vertices(cm, d)[-1, 2]
    peaks = np.array([abs(z[i]) for i in range(1, n - 1) if abs(z[i]) >= abs(z[i - 1]) and abs(z[i]) >= abs(z[i + 1])])
    zeta = math.log(peaks[1] / peaks[-1]) / (len(peaks) - 2) / math.pi
    assert zeta == pytest.approx(math.pi * f * tau, rel=0.1)

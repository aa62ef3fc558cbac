"""The 3D strip's native couples: an axial magnetization as MuJoCo's own forces (poles on the vertices), blocks of
steps inside MuJoCo, and the per-step histories read from MuJoCo's sensors (docs/sim.md, "Native couples of the
strip")."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.sim import RodOptions, SimulationError, Simulator, UnphysicalError, mujoco_equilibrium, stepping
from magsoft_env.sim import cable as C
from magsoft_env.sim.histories import PointsHistory, SensorHistory
from magsoft_env.sim.waveforms import Waveform

BEAM = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)  # axial magnetization
WIDTH = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, magnetization=(0, 1, 0))
MIXED = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, magnetization=(1, 0, 0.5))
GRADED = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3, magnetization=(lambda s: 1.0 + 40.0 * s, 0.0, 0.0))
L = BEAM.length


class _Turning(Waveform):
    """2 mT turning in a tilted plane at 5 Hz: all three components change every step."""

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = 2 * np.pi * 5.0
        return np.stack([2e-3 * np.cos(w * t), 1e-3 * np.sin(w * t), 2e-3 * np.sin(w * t)], axis=1)


def _opts(scene="floor", **kw):
    return RodOptions(rod="cable", scene=scene, timestep=kw.pop("timestep", 1e-4), segments=kw.pop("segments", 12),
                      **kw)


def _state(sim):
    m, d = sim.model, sim.data
    spec = int(mujoco.mjtState.mjSTATE_INTEGRATION)
    s = np.empty(mujoco.mj_stateSize(m, spec))
    mujoco.mj_getState(m, d, s, spec)
    return s


def _copy(sim, state):
    """A fresh MjData of ``sim``'s model in ``state`` (the integration state: inputs, warm start, history)."""
    d = mujoco.MjData(sim.model)
    mujoco.mj_setState(sim.model, d, state, int(mujoco.mjtState.mjSTATE_INTEGRATION))
    return d


# ------------------------------------------------------------------------------------------ which path
@pytest.mark.parametrize(("beam", "magnetics", "path", "nu"), [
    (BEAM, "native", "native", 3), (GRADED, "native", "native", 3), (MIXED, "native", C.MIXED_PATH, 0),
    (WIDTH, "native", "python", 0), (BEAM, "python", "python", 0)])
def test_the_couples_path_is_chosen_from_the_magnetization(beam, magnetics, path, nu):
    for scene in ("cantilever", "floor"):
        rod = Simulator(beam, _opts(scene, magnetics=magnetics)).backend
        assert rod.couples == path and rod.model.nu == nu
        assert isinstance(rod.steps, stepping.NativeSteps) == (path == "native")
    assert C.couple_path(C.cable_layout(beam, 12), magnetics) == path


def test_forced_paths_and_their_refusals():
    with C.overrides("mixed"):
        rod = Simulator(MIXED, _opts()).backend
    assert rod.couples == "mixed" and rod.model.nu == 3 and not rod._writer.axial
    assert Simulator(MIXED, _opts()).backend.couples == C.MIXED_PATH  # the block's choice is gone after it
    with C.overrides("native"), pytest.raises(ValueError, match="axial magnetization alone"):
        Simulator(MIXED, _opts())
    with C.overrides("mixed"), pytest.raises(ValueError, match="no axial part"):
        Simulator(WIDTH, _opts())
    with pytest.raises(ValueError, match="couples must be"):
        with C.overrides("poles"):
            pass
    with pytest.raises(ValueError, match="magnetics"):
        C.couple_path(C.cable_layout(BEAM, 4), "c")
    with pytest.raises(ValueError, match="poles must be"):
        C.build_cable(BEAM, _opts(), poles="site")
    with pytest.raises(ValueError, match="floor_contact must be"):
        with C.overrides(floor_contact="capsule"):
            pass
    with C.overrides(floor_contact="vertex"):
        assert Simulator(BEAM, _opts()).model.geom_type[0] == mujoco.mjtGeom.mjGEOM_PLANE
    with pytest.raises(ValueError, match="layout"):
        C.build_cable(BEAM, _opts(), layout=C.cable_layout(BEAM, 5))


# ------------------------------------------------------------------------------------------ the poles
@pytest.mark.parametrize("poles", C.POLE_INPUTS)
def test_poles_are_the_axial_couples(poles):
    """The pole motors push every vertex with c_v B (both inputs), and the pair of each edge is its axial couple
    (l / l0) m_a t x B: the couple of the Python path's pair, scaled by the edge's stretch."""
    with C.overrides(poles=poles):
        sim = Simulator(GRADED, _opts("cantilever", segments=8, gravity=0.0))
    rod, cm = sim.backend, sim.backend.rod
    m, d = sim.model, sim.data
    rng = np.random.default_rng(5)
    d.qpos[:] = rng.uniform(-3e-4, 3e-4, m.nq)
    B = np.array([1e-3, -2e-3, 3e-3])
    rod.write_field(d, B)
    mujoco.mj_forward(m, d)
    c = C.pole_coefficients(cm.layout)
    free = cm.vertex_body > 0
    np.testing.assert_allclose(d.qfrc_actuator[cm.vertex_dof[free]], c[free, None] * B, rtol=1e-14, atol=0)
    x = C.vertices(cm, d)
    e = np.diff(x, axis=0)
    q = cm.layout.moment[:, 0] / cm.layout.edge_length
    t = e / np.linalg.norm(e, axis=1)[:, None]
    stretch = np.linalg.norm(e, axis=1) / cm.layout.edge_length
    np.testing.assert_allclose(np.cross(e, q[:, None] * B), stretch[:, None] * cm.layout.moment[:, :1]
                               * np.cross(t, B), rtol=1e-12, atol=1e-18)
    assert np.array_equal(rod.controls(np.array([B, 2 * B])), np.array([B, 2 * B])[:, rod._ctrl_axes])


@pytest.mark.parametrize("scene", ["floor", "cantilever"])
def test_couple_writer_is_the_frame_formula(scene):
    """The Python couples (CoupleWriter, every path's transverse part) equal the force pairs (C x t) / l and twist
    moments C . t of C = (R m) x B from the material frames, in a bent, twisted strip (free, or clamped: the clamped
    edge's couple goes to the clamp) with all three components of magnetization and an external wrench; without the
    axial part they are the rest."""
    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3,
                   magnetization=(lambda s: 1.0 + 0 * s, lambda s: 0.6 - 30.0 * s, 0.8))
    cm = C.build_cable(beam, _opts(scene, segments=8))
    m, d = cm.model, mujoco.MjData(cm.model)
    rng = np.random.default_rng(2)
    B = np.array([2e-3, -1.5e-3, 3e-3])
    for _ in range(30):  # bend and twist it, with reference frames MuJoCo has stored
        d.qfrc_applied[:] = rng.normal(0.0, 1e-6, m.nv)
        mujoco.mj_step(m, d)
    assert np.abs(C.tip_twist(cm, d)) > 1e-4
    extra = rng.normal(0.0, 1e-6, (9, 6))
    x = C.vertices(cm, d)
    t, d1, d2 = C.material_frames(cm, d, x)
    mm = cm.layout.moment
    mw = mm[:, :1] * t + mm[:, 1:2] * d1 + mm[:, 2:3] * d2
    for axial in (True, False):
        part = mw if axial else mw - mm[:, :1] * t
        Cp = np.cross(part, B) + extra[:, 3:]
        F = np.cross(Cp, t) / np.linalg.norm(np.diff(x, axis=0), axis=1)[:, None]
        fv = np.zeros_like(x)
        fv[1:] += F + 0.5 * extra[:, :3]
        fv[:-1] += -F + 0.5 * extra[:, :3]
        net = np.zeros(3)
        C.CoupleWriter(cm, axial=axial).write(d, B, extra, net)
        scale = np.abs(fv).max()
        body, tw = cm.vertex_body > 0, cm.twist_dof >= 0
        np.testing.assert_allclose(d.xfrc_applied[cm.vertex_body[body], :3], fv[body], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(d.qfrc_applied[cm.twist_dof[tw]], np.einsum("ij,ij->i", Cp, t)[tw], rtol=0,
                                   atol=1e-12 * np.abs(Cp).max())
        np.testing.assert_allclose(net, mw.sum(axis=0), rtol=1e-12)


def _frame_formula(cm, data, B, extra=None, net_moment=None):
    """The couples as the strip wrote them before CoupleWriter (apply_field of a36fe4c), the reference of the strip's
    trajectories: frames as material_frames computed them, C = M @ [B]x, pairs (C x t) / l added +F then -F,
    twist C . t."""
    def dot(a, b):
        return np.einsum("ij,ij->i", a, b)

    def cross(a, b):
        i1, i2 = [1, 2, 0], [2, 0, 1]
        return np.take(a, i1, 1) * np.take(b, i2, 1) - np.take(a, i2, 1) * np.take(b, i1, 1)

    x = cm.vertex_ref.copy()
    free = cm.vertex_qpos >= 0
    x[free] += data.qpos[cm.vertex_qpos[free]]
    e = np.diff(x, axis=0)
    t = e / np.sqrt(dot(e, e))[:, None]
    ne = len(t)
    a = cm.model.flex_plasticadr[cm.flex]
    p = data.plastic[a:a + 6 * ne].reshape(ne, 6)
    if not p.any():
        t_old = np.tile([1.0, 0.0, 0.0], (ne, 1))
        u_old = np.tile([0.0, 1.0, 0.0], (ne, 1))
    else:
        t_old, u_old = p[:, :3], p[:, 3:]
    u = u_old - (dot(t, u_old) / (1.0 + dot(t_old, t)))[:, None] * (t_old + t)
    u /= np.sqrt(dot(u, u))[:, None]
    theta = np.where(cm.twist_qpos >= 0, data.qpos[np.maximum(cm.twist_qpos, 0)], 0.0)
    v = cross(t, u)
    c, s = np.cos(theta)[:, None], np.sin(theta)[:, None]
    d1, d2 = c * u + s * v, c * v - s * u
    m = cm.layout.moment
    mw = m[:, :1] * t + m[:, 1:2] * d1 + m[:, 2:3] * d2
    if net_moment is not None:
        net_moment[:] = mw.sum(axis=0)
    Cp = mw @ np.array([[0.0, -B[2], B[1]], [B[2], 0.0, -B[0]], [-B[1], B[0], 0.0]])
    if extra is not None:
        Cp = Cp + extra[:, 3:]
    F = cross(Cp, t) / np.sqrt(dot(e, e))[:, None]
    fv = np.zeros((len(x), 3))
    fv[1:] += F
    fv[:-1] -= F
    if extra is not None:
        fv[1:] += 0.5 * extra[:, :3]
        fv[:-1] += 0.5 * extra[:, :3]
    body = cm.vertex_body
    data.xfrc_applied[body[body > 0], :3] = fv[body > 0]
    data.xfrc_applied[body[body > 0], 3:] = 0.0
    data.qfrc_applied[:] = 0.0
    tw = cm.twist_dof >= 0
    data.qfrc_applied[cm.twist_dof[tw]] = dot(Cp, t)[tw]


@pytest.mark.parametrize("scene", ["floor", "cantilever"])
def test_couple_writer_is_the_frame_formula_bit_for_bit(scene):
    """With the axial part the Python couples are the frame formula's arithmetic to the last bit (the strip's
    trajectories on the Python path are those from before the writer, hash for hash), before the first step (no
    reference frames stored) and in a bent, twisted state, with and without an external wrench."""
    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3,
                   magnetization=(lambda s: 1.0 + 0 * s, lambda s: 0.6 - 30.0 * s, 0.8))
    cm = C.build_cable(beam, _opts(scene, segments=8))
    m, d = cm.model, mujoco.MjData(cm.model)
    rng = np.random.default_rng(5)
    ref = mujoco.MjData(m)
    writer = C.CoupleWriter(cm)
    for k in range(31):
        if k:  # bend and twist it, with reference frames MuJoCo has stored
            d.qfrc_applied[:] = rng.normal(0.0, 1e-6, m.nv)
            mujoco.mj_step(m, d)
        if k not in (0, 30):
            continue
        for extra in (None, rng.normal(0.0, 1e-6, (9, 6))):
            B = rng.normal(0.0, 2e-3, 3)
            ref.qpos[:], ref.plastic[:] = d.qpos, d.plastic
            net, net_ref = np.full(3, np.nan), np.full(3, np.nan)
            d.xfrc_applied[:] = ref.xfrc_applied[:] = rng.normal(size=ref.xfrc_applied.shape)
            d.qfrc_applied[:] = ref.qfrc_applied[:] = rng.normal(size=m.nv)
            writer.write(d, B, extra, net)
            _frame_formula(cm, ref, B, extra, net_ref)
            assert np.array_equal(d.xfrc_applied, ref.xfrc_applied)
            assert np.array_equal(d.qfrc_applied, ref.qfrc_applied)
            assert np.array_equal(net, net_ref)


def test_net_moments_of_recorded_positions_are_vectorized():
    sim = Simulator(GRADED, _opts(segments=10))
    rod, cm = sim.backend, sim.backend.rod
    rng = np.random.default_rng(7)
    Q = sim.model.qpos0 + rng.uniform(-1e-3, 1e-3, (6, sim.model.nq))
    d = mujoco.MjData(sim.model)
    want = []
    for q in Q:
        d.qpos[:] = q
        want.append(C.world_moments(cm, d).sum(axis=0))
    np.testing.assert_allclose(rod.net_moments(Q), np.array(want), rtol=1e-13)
    d.qpos[:] = Q[2]
    np.testing.assert_allclose(rod.net_moment(d), want[2], rtol=1e-13)


# ------------------------------------------------------------------------------------------ blocks in MuJoCo
def test_native_blocks_are_mj_step_k_and_rollouts(monkeypatch):
    calls = []
    real = mujoco.mj_step

    def counting(m, d, *k):
        calls.append(k[0] if k else 1)
        return real(m, d, *k)

    monkeypatch.setattr(mujoco, "mj_step", counting)
    rolls = []
    real_roll = stepping.NativeSteps._roll
    monkeypatch.setattr(stepping.NativeSteps, "_roll", lambda self, d, u: rolls.append(len(u)) or real_roll(self, d, u))
    sim = Simulator(BEAM, _opts(), field=(1e-3, 0.0, 1e-3))
    sim.step(250)  # blocks end at every energy check (50 steps)
    assert calls == [50] * 5 and rolls == []
    sim.set_waveform(_Turning())
    calls.clear()
    sim.step(120)
    assert calls == [] and rolls == [50, 50, 20]
    python = Simulator(BEAM, _opts(magnetics="python"), field=(1e-3, 0.0, 1e-3))
    calls.clear()
    python.step(30)
    assert calls == [1] * 30


def test_rollouts_are_the_from_python_loop_bit_for_bit():
    """Fields that change every step run as one rollout per block: what setting the pole motors' controls before each
    single mj_step gives, to the last bit (the history buffers included)."""
    sim = Simulator(BEAM, _opts(), field=(0.0, 0.0, 1e-3))
    sim.step(40)
    state = _state(sim)
    sim.set_waveform(_Turning(), start_time=0.0)
    t0 = sim.time
    sim.step(130)
    d = _copy(sim, state)
    fields = _Turning().sample(t0 + 1e-4 * np.arange(130))
    for f in fields:
        d.ctrl[:] = f
        mujoco.mj_step(sim.model, d)
    np.testing.assert_array_equal(sim.data.qpos, d.qpos)
    np.testing.assert_array_equal(sim.data.qvel, d.qvel)
    np.testing.assert_array_equal(sim.data.history, d.history)


# ------------------------------------------------------------------------------------------ native against Python
@pytest.mark.parametrize(("scene", "tol"), [("cantilever", 1e-4), ("floor", 2e-3)])
def test_native_couples_follow_the_python_couples(scene, tol):
    """A held field with three components, then a field turning every step: the native path's centreline stays
    within ``tol`` L of the Python path's (measured 2e-5 L clamped, 5e-4 L on the floor: the poles' lever is the
    current edge length over the reference one, and their tension stretches the edges by 3e-5 to 5e-5 here)."""
    out = {}
    for magnetics in ("native", "python"):
        sim = Simulator(BEAM, _opts(scene, magnetics=magnetics), field=(0.0, 1e-3, 3e-3))
        sim.step(300)
        held = sim.pose().centreline
        sim.set_waveform(_Turning())
        sim.step(500)
        out[magnetics] = held, sim.pose().centreline, C.edge_strain(sim.backend.rod, sim.data)
    (h0, c0, s0), (h1, c1, s1) = out["native"], out["python"]
    assert np.abs(c1 - C.vertices(sim.backend.rod, mujoco.MjData(sim.model))).max() > 0.2 * L  # it moved
    assert np.abs(h0 - h1).max() < tol * L and np.abs(c0 - c1).max() < tol * L
    assert s0 < 1e-4 and s1 < 1e-4


# ------------------------------------------------------------------------------------------ histories from sensors
def _drop(sim):
    """Tilt the free strip 30 degrees about its axis, its lower long edge on the floor: it falls flat, its deepest
    contact changing every step."""
    cm = sim.backend.rod
    th = math.radians(30.0)
    sim.data.qpos[cm.twist_qpos[cm.twist_qpos >= 0]] = th
    sim.data.qpos[cm.vertex_qpos[:, 2]] = 0.5 * BEAM.width * math.sin(th) + 0.5 * BEAM.thickness * (math.cos(th) - 1)
    sim.set_state()


@pytest.mark.parametrize("magnetics", ["native", "python"])
def test_histories_read_what_python_reads_every_step(magnetics):
    """The contact sensor's and the vertices' history buffers after a block hold, bit for bit, the deepest floor
    contact (most negative dist of mjData.contact with the floor) and the vertices that a Python loop of single
    steps reads, whichever path the couples take."""
    sim = Simulator(BEAM, _opts(magnetics=magnetics), field=(1e-3, 0.0, 2e-3), check_every=100)
    _drop(sim)
    sim.step(1)
    state = _state(sim)
    sim.step(100)
    rod = sim.backend
    floor, feature = rod.contact_histories(sim.data)
    nodes = rod.centreline_history(sim.data)
    assert isinstance(floor, SensorHistory) and feature is None and isinstance(nodes, PointsHistory)
    assert floor.nsample == nodes.nsample == rod.block_limit == 100
    d = _copy(sim, state)
    deepest, points = [], []
    for _ in range(100):
        points.append(C.vertices(rod.rod, d))
        if magnetics == "python":
            rod.write_field(d, sim.field_vector)
        mujoco.mj_step(sim.model, d)
        deepest.append(rod.deepest_contact(d))
    np.testing.assert_array_equal(sim.data.qpos, d.qpos)
    assert min(deepest) < -1e-6 and np.ptp(deepest) > 1e-6  # the contacts changed
    np.testing.assert_array_equal(floor.last(100), deepest)
    np.testing.assert_array_equal(nodes.last(100), np.array(points).transpose(1, 0, 2))
    assert rod.contact_data(sim.data)[rod.contact_adr] == deepest[-1]
    with pytest.raises(ValueError, match="clamped strip keeps no centreline"):
        Simulator(BEAM, _opts("cantilever")).centreline_history()


# ------------------------------------------------------------------------------------------ checks still hold
def test_energy_balance_of_native_blocks():
    """A held field set from outside, then one turning every step (rollouts, the work booked from the recorded
    positions): the passive strip's balance stays at or below zero drift; a joule the field never supplied stops the
    run as a launch."""
    sim = Simulator(BEAM, _opts())
    sim.set_field((1e-3, 1e-3, 0.0))
    sim.step(300)
    assert sim._health.work != 0.0
    sim.set_waveform(_Turning())
    sim.step(600)
    assert sim._health.energy_valid and 0.0 <= sim.energy_drift < 1e-4
    sim._health.work -= 1.0
    with pytest.raises(UnphysicalError, match="launch"):
        sim.step(100)


@pytest.mark.parametrize(("timestep", "field"), [(1e-3, (1.0, 0.0, -1.0)), (2e-2, (5e-3, 0.0, 5e-3))])
def test_absurd_settings_fail_as_before(timestep, field):
    """An absurd field (1 T at 1 ms) or timestep (20 ms): the native path stops with the error the Python path
    stops with, at the same step."""
    errors = []
    for magnetics in ("native", "python"):
        sim = Simulator(BEAM, _opts(timestep=timestep, magnetics=magnetics), field=field)
        with pytest.raises(SimulationError) as err:
            sim.step(100)
        errors.append((type(err.value), getattr(err.value, "cause", ""), err.value.step))
    assert errors[0] == errors[1] and errors[0][0] is UnphysicalError


def test_an_external_couple_runs_from_python():
    """Forces alone stay native (constant); an external couple turns with its edge, so that call runs from Python,
    the axial couples still the poles'."""
    sim = Simulator(BEAM, _opts(), field=(1e-3, 0.0, 1e-3))
    rod = sim.backend
    sim.external_wrench[3, 2] = 1e-6
    sim.step(20)
    assert not rod._from_python and np.any(sim.data.xfrc_applied[:, 2])
    sim.external_wrench[3, 3] = 1e-9  # about x, nearly along the edge: a twist moment
    sim.step(20)
    assert rod._from_python and not rod._writer.axial and np.any(sim.data.qfrc_applied)
    sim.external_wrench[:] = 0.0
    sim.step(20)
    assert not rod._from_python and not np.any(sim.data.xfrc_applied) and not np.any(sim.data.qfrc_applied)


def test_statics_and_the_buckled_branch_with_native_couples():
    """The clamped strip settles as before: in plane within 0.25 % of L of the analytical model; past
    lateral-torsional buckling (1 mT across the width) the stability test leaves the straight state for the stable
    buckled branch (tip z about +8.3 mm)."""
    eq = mujoco_equilibrium(BEAM, (0.0, 1e-3, 0.0), rod="cable", gravity=0.0)
    assert eq.success and eq.stable
    assert abs(eq.tip_position[2]) == pytest.approx(8.3e-3, abs=0.2e-3)
    plane = mujoco_equilibrium(BEAM, (0.0, 0.0, 5e-3), rod="cable", grading=1.0)
    ref = ms.solve_equilibrium(BEAM, (0.0, 0.0, 5e-3), gravity=9.81)
    assert plane.success and np.linalg.norm(plane.tip_position - ref.tip_position) < 2.5e-3 * L

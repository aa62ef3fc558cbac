"""Native magnetic forces: MuJoCo's own pole forces against the Python couples, block stepping, rollouts."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest
from mujoco import rollout as mjrollout

from magsoft_env import Beam
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.sim import RodBatch, RodOptions, Simulator, Sine, as_waveform, build_model
from magsoft_env.sim.gait import gait_rod_options
from magsoft_env.sim.health import PENETRATION_LIMIT, SensorHistory, SimulationError, UnphysicalError
from magsoft_env.sim.magnetics import magnetic_poles
from magsoft_env.sim.model import CONTACT_HISTORY, CONTACT_SENSOR, NATIVE_CONTROL_SPEC, native_controls
from magsoft_env.sim.waveforms import PhaseShifted

H = 1.13e-3
UNIFORM = Beam(length=25e-3, width=5e-3, thickness=H, volume_fraction=0.2)


def _both(beam, options):
    return (Simulator(beam, dataclasses.replace(options, magnetics="python")),
            Simulator(beam, dataclasses.replace(options, magnetics="native")))


def _profiles():
    jig, cells, slopes = (gait_preset(n).beam for n in ("paper-5c", "paper-5a", "paper-5b"))
    return {"uniform": UNIFORM, "jig": jig, "cells": cells, "slopes": slopes}


@pytest.mark.parametrize("profile", ["uniform", "jig", "cells", "slopes"])
@pytest.mark.parametrize("options", [
    RodOptions(scene="floor"), RodOptions(scene="floor", base="first", gravity=0.0, segments=13),
    RodOptions(), RodOptions(gravity=0.0, grading=1.0, segments=7), RodOptions(scene="channel", segments=40),
], ids=["floor", "floor-first-nograv", "cantilever", "cantilever-equal-nograv", "channel-40"])
def test_native_forces_equal_the_python_couples_at_any_state(profile, options):
    # MuJoCo's pole forces (qfrc_actuator) against the simulator's couples (qfrc_applied) at random
    # bent, moving states and random fields; measured: at most 4e-14 of |B| sum |m_i| (the largest
    # generalized couple), from the round-off of world positions in the lever arms
    beam = _profiles()[profile]
    py, nat = _both(beam, options)
    assert nat.model.nu == nat.rod.pole_charge.size > 0 and py.model.nu == 0
    rng = np.random.default_rng(7)
    scale_m = float(np.abs(py._m_body).sum())
    worst = 0.0
    for _ in range(25):
        q = rng.normal(0.0, 0.7, py.model.nq)
        if py.rod.base_qpos.size:
            q[py.rod.base_qpos[:2]] = rng.uniform(-0.05, 0.05, 2)  # a few beam lengths from the origin
        v = rng.normal(0.0, 1.0, py.model.nv)
        field = tuple(rng.normal(0.0, 0.01, 2))
        for s in (py, nat):
            s.data.qpos[:], s.data.qvel[:] = q, v
            s.set_field(field)
        mujoco.mj_kinematics(py.model, py.data)
        py._apply_torques()
        mujoco.mj_forward(nat.model, nat.data)
        err = np.abs(nat.data.qfrc_actuator - py.data.qfrc_applied).max() / (scale_m * math.hypot(*field))
        worst = max(worst, float(err))
    assert worst < 1e-12


def test_poles_of_a_uniform_beam_are_its_ends():
    # uniform axial magnetization: the interior charges cancel, the poles are the two ends (free
    # beam, total charge zero) or the tip alone (clamped), each of charge M A
    ma = float(np.hypot(*build_model(UNIFORM, RodOptions(scene="floor")).disc.moment[5])) / (25e-3 / 20)
    free = build_model(UNIFORM, RodOptions(scene="floor"))
    assert free.pole_piece.tolist() == [0, 20]
    np.testing.assert_allclose(free.pole_charge, [-ma, ma], rtol=1e-12)
    np.testing.assert_allclose(free.pole_pos, [[0.0, 0.0], [free.disc.piece_length[-1], 0.0]], atol=1e-15)
    clamped = build_model(UNIFORM, RodOptions(grading=1.0))
    assert clamped.pole_piece.tolist() == [20] and clamped.pole_charge == pytest.approx([ma], rel=1e-12)
    # a transverse magnetization needs one pole per piece (two on a free root that must stay neutral)
    jig = build_model(gait_preset("paper-5c").beam, RodOptions(scene="floor"))
    assert 21 <= jig.pole_piece.size <= 22 and abs(jig.pole_charge.sum()) < 1e-12 * np.abs(jig.pole_charge).max()


def test_pole_construction_is_checked_and_exact_in_3d():
    with pytest.raises(ValueError, match="exactly one root"):
        magnetic_poles(np.zeros((2, 3)), np.array([-1, -1]), np.zeros((2, 3)), np.zeros((2, 3)), np.zeros((2, 3)),
                       np.ones(2), free_root=True)
    # a 3D chain turned arbitrarily: the poles' couple sum (q - o) x F equals the couples (R m) x B on
    # every subtree about its joint, the condition the construction solves
    rng = np.random.default_rng(3)
    n = 6
    m = rng.normal(0.0, 1e-3, (n, 3))
    parent = np.arange(-1, n - 1)
    own, in_parent = np.zeros((n, 3)), np.zeros((n, 3))
    in_parent[1:, 0] = 0.01
    piece, pos, charge = magnetic_poles(m, parent, own, in_parent, np.tile([0.005, 0, 0], (n, 1)), np.full(n, 0.01),
                                        free_root=True)
    assert abs(charge.sum()) < 1e-15
    rot = [np.linalg.qr(rng.normal(size=(3, 3)))[0] for _ in range(n)]
    origin = [np.zeros(3)]
    for i in range(1, n):
        origin.append(origin[i - 1] + rot[i - 1] @ in_parent[i])
    B = rng.normal(0.0, 0.01, 3)
    for j in range(n):  # the subtree of j (pieces j..n-1), about its joint origin[j]
        couple = sum(np.cross(rot[i] @ m[i], B) for i in range(j, n))
        poles = sum(np.cross(origin[i] + rot[i] @ p - origin[j], c * B)
                    for i, p, c in zip(piece, pos, charge, strict=True) if i >= j)
        np.testing.assert_allclose(poles, couple, rtol=0, atol=1e-13 * np.abs(m).sum() * np.linalg.norm(B))


def test_held_field_blocks_equal_stepping_one_step_at_a_time():
    sim = Simulator(gait_preset("paper-5c").beam, RodOptions(scene="floor", timestep=2e-4))
    sim.set_field((1.5e-3, 2e-3))
    ref = mujoco.MjData(sim.model)
    ref.ctrl[:], ref.mocap_quat[:] = sim.data.ctrl, sim.data.mocap_quat
    sim.step(137)  # blocks of CONTACT_HISTORY, cut at the energy checks
    for _ in range(137):
        mujoco.mj_step(sim.model, ref)
    np.testing.assert_array_equal(sim.data.qpos, ref.qpos)
    np.testing.assert_array_equal(sim.data.qvel, ref.qvel)
    # the history buffer holds the last steps' deepest contacts, oldest first, as sensordata showed them
    hist = SensorHistory(sim.model, mujoco.mj_name2id(sim.model, mujoco.mjtObj.mjOBJ_SENSOR, CONTACT_SENSOR),
                         ref.history)
    seen = []
    for _ in range(5):
        mujoco.mj_step(sim.model, ref)
        seen.append(float(ref.sensordata[sim.rod.contact_sensor]))
    np.testing.assert_array_equal(hist.last(5), seen)
    assert hist.nsample == CONTACT_HISTORY


def test_stepping_interleaves_simulators_block_by_block_without_changing_them():
    # two simulators advanced in turn, a few steps each, on one thread (as the batched envs do): each
    # ends bit for bit where step() alone takes it, with the same records; the caller's warning
    # handler is back between blocks
    beam, opts = gait_preset("paper-5b").beam, RodOptions(scene="floor", timestep=2e-4, segments=12)
    fields = [(2e-3, 1e-3), (-1e-3, 2.5e-3)]
    alone, paired = [], []
    for f in fields:
        for group in (alone, paired):
            group.append(Simulator(beam, opts, field=f))
    for sim in alone:
        sim.step(180)
    seen = []
    handler = seen.append
    prev = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(handler)
    try:
        runs = [sim.stepping(180, block=7) for sim in paired]
        blocks = [0, 0]
        live = [0, 1]
        while live:
            for i in list(live):
                try:
                    next(runs[i])
                    blocks[i] += 1
                    assert mujoco.get_mju_user_warning() is handler
                except StopIteration:
                    live.remove(i)
    finally:
        mujoco.set_mju_user_warning(prev)
    assert blocks[0] >= 180 // 7  # it did yield between blocks
    for a, b in zip(alone, paired, strict=True):
        np.testing.assert_array_equal(a.data.qpos, b.data.qpos)
        np.testing.assert_array_equal(a.data.qvel, b.data.qvel)
        assert (a.nstep, a.time, a.max_penetration, a.energy_drift) == (b.nstep, b.time, b.max_penetration,
                                                                          b.energy_drift)
    assert not seen
    with pytest.raises(ValueError, match="block must be None or a positive integer"):
        next(alone[0].stepping(10, block=0))


@pytest.mark.parametrize("options", [
    RodOptions(scene="floor", timestep=2e-4, segments=12), RodOptions(scene="floor", base="first", segments=7),
    RodOptions(timestep=1e-4), RodOptions(scene="channel", segments=10, timestep=2e-4),
], ids=["floor", "floor-first", "cantilever", "channel"])
def test_waveform_rollout_blocks_equal_the_per_step_loop(options):
    # a field that changes every step runs in mujoco.rollout blocks: the same trajectory bit for bit as
    # one mj_step at a time, the same records, the field's work booked from the recorded states
    wf = PhaseShifted(2e-3, 1.5e-3, 2.0, 0.3, 0.0)
    loop, blocks = (Simulator(gait_preset("paper-5b").beam, options) for _ in range(2))
    loop.rollout_blocks = False
    for sim in (loop, blocks):
        sim.set_waveform(wf)
        for _ in range(3):
            sim.step(137)
    assert blocks._rollout_ok() and not loop._rollout_ok() and blocks._roller is not None and loop._roller is None
    np.testing.assert_array_equal(loop.data.qpos, blocks.data.qpos)
    np.testing.assert_array_equal(loop.data.qvel, blocks.data.qvel)
    assert np.abs(blocks.data.qpos[blocks.rod.hinge_qpos]).max() > 1e-3  # it moved
    assert (loop.nstep, loop.time, loop.field, loop.max_penetration) == (blocks.nstep, blocks.time, blocks.field,
                                                                           blocks.max_penetration)
    assert blocks._work == pytest.approx(loop._work, rel=1e-12, abs=1e-20)
    if options.has_contact:
        assert abs(loop._work) > 0 and blocks.energy_drift == pytest.approx(loop.energy_drift, abs=1e-12)
    # the angles behind the net moments: R_y(A q + phi0) is every piece's xmat, at any state
    A, phi0 = blocks._angle_map()
    rng = np.random.default_rng(1)
    d = blocks.data
    for _ in range(10):
        d.qpos[:] = rng.uniform(-2.0, 2.0, blocks.model.nq) * 1e-2
        d.qpos[blocks.rod.hinge_qpos] = rng.uniform(-1.5, 1.5, len(blocks.rod.hinge_qpos))
        mujoco.mj_kinematics(blocks.model, d)
        phi = A @ d.qpos + phi0
        c, s = np.cos(phi), np.sin(phi)
        x = d.xmat[blocks._b0:blocks._b1]
        np.testing.assert_allclose(x[:, [0, 2, 6, 8]], np.stack([c, s, -s, c], axis=1), rtol=0, atol=1e-14)


@pytest.mark.parametrize("options, wf, limit", [
    (RodOptions(scene="floor"), PhaseShifted(0.1, 0.1, 5.0, 1.0, 1.0), PENETRATION_LIMIT),
    (RodOptions(segments=6, timestep=2e-3), PhaseShifted(0.05, 0.05, 9.0, 1.0, 0.0), PENETRATION_LIMIT),
], ids=["penetration", "blow-up"])
def test_waveform_failures_in_rollout_blocks_are_reported_as_the_loop_reports_them(options, wf, limit):
    errors = []
    for blocks in (False, True):
        sim = Simulator(UNIFORM, options, penetration_limit=limit)
        sim.rollout_blocks = blocks
        sim.set_waveform(wf)
        with pytest.raises(SimulationError) as info:
            for _ in range(20):
                sim.step(250)
        errors.append((type(info.value), info.value.step, str(info.value)))
    assert errors[0] == errors[1]


def test_paper_gait_trajectory_agrees_between_paths():
    # 0.3 s of the cosine-jig crawler on its stiff floor (3000 steps of 0.1 ms, per-step fields):
    # measured max |dq| 3.5e-13 (m, rad) between the paths; contact may amplify round-off, so the
    # bound is 1e-9, still 1e-7 of the hinge angles (0.02 rad)
    p = gait_preset("paper-5c")
    py, nat = _both(p.beam, gait_rod_options(p))
    for s in (py, nat):
        s.set_waveform(as_waveform(p.wave))
    dq = 0.0
    for _ in range(30):
        for s in (py, nat):
            s.step(100)
        dq = max(dq, float(np.abs(py.data.qpos - nat.data.qpos).max()))
    assert np.abs(py.data.qpos[py.rod.hinge_qpos]).max() > 0.01  # it bends
    assert dq < 1e-9
    assert nat.max_penetration == pytest.approx(py.max_penetration, rel=1e-9)
    assert nat.energy_drift == pytest.approx(py.energy_drift, abs=1e-12) and nat.energy_drift < 1e-6


def test_rollout_runs_the_native_rod_without_python():
    # mujoco.rollout with native_controls reproduces Simulator.run bit for bit (same inputs each step)
    beam = gait_preset("paper-5c").beam
    sim = Simulator(beam, RodOptions(scene="floor", timestep=2e-4))
    x0 = np.empty(mujoco.mj_stateSize(sim.model, mujoco.mjtState.mjSTATE_FULLPHYSICS))
    mujoco.mj_getState(sim.model, sim.data, x0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    wf = Sine((1e-3, 2e-3), 4.0)
    n = 250
    u = native_controls(sim.rod, wf.sample(sim.timestep * np.arange(n)))
    assert u.shape[1] == mujoco.mj_stateSize(sim.model, NATIVE_CONTROL_SPEC)
    state, sensordata = mjrollout.rollout(sim.model, mujoco.MjData(sim.model), x0, u[None],
                                          control_spec=NATIVE_CONTROL_SPEC)
    sim.set_waveform(wf)
    sim.step(n)  # one call: the same sample times as the rollout's
    qpos = state[0, -1, 1:1 + sim.model.nq]  # FULLPHYSICS rows: time, qpos, ...
    assert np.abs(sim.data.qpos[sim.rod.hinge_qpos]).max() > 1e-3
    np.testing.assert_array_equal(qpos, sim.data.qpos)
    assert -sensordata[0, :, sim.rod.contact_sensor].min() == sim.max_penetration
    with pytest.raises(ValueError, match="magnetics='native'"):
        native_controls(build_model(beam, RodOptions(magnetics="python")), [(0.0, 1e-3)])


def test_static_equilibrium_and_rk4_with_native_forces():
    # the settled state is the same equilibrium whichever path applies the couples
    beam = gait_preset("paper-5c").beam
    tips = {}
    for mag in ("python", "native"):
        sim = Simulator(beam, RodOptions(magnetics=mag, segments=10), field=(0.0, 8e-3))
        res = sim.settle(tol=1e-9, max_time=5.0)
        assert res.success, res.message
        assert sim.static_residual() < 1e-9
        tips[mag] = sim.tip_position()
    np.testing.assert_allclose(tips["native"], tips["python"], rtol=0, atol=1e-9)
    # RK4: the Python path feeds every stage the couples of the step's start (first order in dt),
    # MuJoCo's poles see each stage's own orientation (fourth order). Measured against RK4 at 2.5 us
    # over a 0.05 s transient: Python 2.7e-5 / 1.4e-5 m at 40 / 20 us, native 7e-13 / 4e-14 m

    def tip(mag, dt):
        sim = Simulator(beam, RodOptions(magnetics=mag, segments=10, integrator="rk4", timestep=dt, gravity=0.0),
                        field=(0.0, 8e-3))
        sim.step(int(round(0.05 / dt)))
        return np.array(sim.tip_position())

    ref = tip("native", 5e-6)
    py = [np.linalg.norm(tip("python", dt) - ref) for dt in (4e-5, 2e-5)]
    nat = [np.linalg.norm(tip("native", dt) - ref) for dt in (4e-5, 2e-5)]
    assert py[1] > 1e-6 and py[0] / py[1] == pytest.approx(2.0, rel=0.1)
    assert nat[0] < 1e-11 and nat[1] < 1e-12


def test_held_couples_use_the_python_path():
    sim = Simulator(UNIFORM, RodOptions(scene="floor"), torque_every=2)
    assert sim.options.magnetics == "python" and sim.model.nu == 0
    assert RodOptions().magnetics == "native"
    with pytest.raises(ValueError, match="RodOptions.magnetics"):
        RodOptions(magnetics="c")


# ---------------------------------------------------------------- health checks with block stepping
def test_deep_penetration_in_a_held_block_is_reported_at_its_step():
    # test_sim_honesty's 100 mT on the soft 1 ms floor, as a held field: the block runs inside MuJoCo,
    # the history buffer gives the step it broke the bound, as the Python path's per-step loop does
    errs = {}
    for mag in ("python", "native"):
        sim = Simulator(UNIFORM, RodOptions(scene="floor", magnetics=mag))
        sim.set_field((0.1, 0.1))
        with pytest.raises(UnphysicalError, match="penetration into the floor") as info:
            sim.step(300)
        errs[mag] = (info.value, sim.nstep, sim.max_penetration)
    (ep, np_, pp), (en, nn, pn) = errs["python"], errs["native"]
    assert en.step == ep.step <= 3 and en.figures["penetration_h"] > PENETRATION_LIMIT
    assert pn == pytest.approx(pp, rel=1e-9) and en.figures["penetration_m"] == pytest.approx(pn)
    assert en.figures["step"] == en.step and f"at step {en.step - 1}" in en.reason
    assert np_ == ep.step and ep.step <= nn <= CONTACT_HISTORY  # native: the state ran to the block's end


def test_batch_reports_a_held_penetration_and_a_warning_at_their_steps(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    rb = RodBatch(UNIFORM, RodOptions(scene="floor"), nsim=3)
    rb.set_fields([(0.0, 1e-3), (0.1, 0.1), (0.0, -1e-3)])
    with pytest.raises(UnphysicalError, match=r"simulations \[1\]") as info:
        rb.step(100)
    assert info.value.step <= 3 and rb.max_penetration[1] > PENETRATION_LIMIT * H > rb.max_penetration[0]
    sim = Simulator(UNIFORM, RodOptions(scene="floor"))
    sim.data.qvel[0] = 1e11  # MuJoCo warns at the first step; the held block runs on
    with pytest.raises(Exception, match="MuJoCo warning") as info:
        sim.step(100)
    assert info.value.step == 1 and sim.nstep > 1
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()


def test_batch_with_native_forces_matches_simulators_and_threads():
    opts = RodOptions(scene="floor", timestep=2e-4)
    wfs = [Sine((0.0, 2e-3), 2.0), Sine((1e-3, 0.0), 3.0)]
    runs = []
    for nthread in (1, 2):
        rb = RodBatch(UNIFORM, opts, nsim=2, nthread=nthread)
        rb.set_waveforms(wfs)
        rb.step(120)
        rb.set_fields([(0.0, 1e-3), (1e-3, 0.0)])
        rb.step(80)
        runs.append(rb.qpos.copy())
    np.testing.assert_array_equal(runs[0], runs[1])
    for i, wf in enumerate(wfs):
        s = Simulator(UNIFORM, opts)
        s.set_waveform(wf)
        s.step(120)
        s.set_field([(0.0, 1e-3), (1e-3, 0.0)][i])
        s.step(80)
        np.testing.assert_array_equal(runs[0][i], s.data.qpos)  # bit-identical


def test_native_bench_quick_runs(capsys):
    # the benchmark end to end, tiny; its timings are for reading, never asserted
    from magsoft_env.bench import native_bench

    assert native_bench.main(["--quick"]) == 0
    out = capsys.readouterr().out
    rows = {line.split(maxsplit=1)[0]: line for line in out.splitlines() if line.strip()}
    assert "xz" in rows and "rollout" in rows
    roll = [line for line in out.splitlines() if line.strip().startswith("rollout")]
    assert len(roll) == 4 and all(float(line.split()[-1]) == 0.0 for line in roll)  # bit-identical to native
    (nat,) = [line for line in out.splitlines() if line.split()[:1] == ["native"] and "python" in line.split()[-1]]
    assert float(nat.split()[-2]) < 1e-10  # max |dq| against the Python path

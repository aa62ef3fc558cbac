"""Field sources on the MuJoCo rods: couples m x B and gradient forces G^T m on every piece (docs/sim.md, "Field
sources")."""

from __future__ import annotations

import hashlib
import math

import mujoco
import numpy as np
import pytest

from magsoft_env import Beam
from magsoft_env.fields import MovingSource, PointDipole, SourceSum, Uniform
from magsoft_env.sim import RodOptions, Simulator, mujoco_equilibrium
from magsoft_env.sim.cable_frames import world_moments
from magsoft_env.sim.gait import run_gait
from magsoft_env.sim.sources import magnet_case


def dipole(x, pos, m):
    """Field and gradient of a point dipole at points ``x`` (n, 3), written here from the closed forms (DESIGN.md
    section 12), independently of magsoft_env.fields."""
    from magsoft_env.spec import MU0

    k = MU0 / (4 * math.pi)
    B, G = np.empty((len(x), 3)), np.empty((len(x), 3, 3))
    for i, xi in enumerate(x):
        r = xi - pos
        d = np.linalg.norm(r)
        u = r / d
        B[i] = k * (3 * u * (m @ u) - m) / d**3
        G[i] = k * 3 / d**4 * (np.outer(m, u) + np.outer(u, m) + (m @ u) * (np.eye(3) - 5 * np.outer(u, u)))
    return B, G


def state_hash(sim) -> str:
    return hashlib.sha256(sim.data.qpos.tobytes() + sim.data.qvel.tobytes()).hexdigest()


BEAM = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
# a magnet off the strip's plane (y = 3 mm): out-of-plane field and gradient too
DIPOLE = dict(position=(18e-3, 3e-3, -9e-3), moment=(1e-3, -2e-3, 4e-3))


# ----------------------------------------------------------------------------------- (a) the loads, exactly
def test_chain_loads_are_the_dipole_force_and_couple():
    """Every link of a free chain (floor scene, deformed) gets the force G^T m at its midpoint and the couple m x B:
    the generalized forces of MuJoCo's xfrc_applied equal those of mj_applyFT with the reference loads at the
    magnetic centres, to 1e-9 (the in-plane parts: the chain's joints carry the rest)."""
    src = PointDipole(**DIPOLE)
    sim = Simulator(BEAM, RodOptions(segments=8, scene="floor", gravity=0.0), source=src)
    sim.set_state(sim.noisy_rest(np.random.default_rng(1), 0.3))
    sim.set_field((0.0, 0.0))  # writes the loads of this state
    m, d, be = sim.model, sim.data, sim.backend
    q = np.zeros(m.nv)
    for b in range(1, m.nbody):
        mujoco.mj_applyFT(m, d, d.xfrc_applied[b, :3].copy(), d.xfrc_applied[b, 3:].copy(), d.xipos[b].copy(), b, q)
    ref = np.zeros(m.nv)
    c = sim.pose().centreline
    mid = 0.5 * (c[1:] + c[:-1])
    mw = np.einsum("nij,nj->ni", d.xmat[be.bodies].reshape(-1, 3, 3), be.m_body)
    B, G = dipole(mid, np.array(DIPOLE["position"]), np.array(DIPOLE["moment"]))
    force_total = np.zeros(3)
    for i, b in enumerate(be.bodies):
        f = G[i].T @ mw[i]
        force_total += f
        mujoco.mj_applyFT(m, d, f, np.cross(mw[i], B[i]), mid[i], int(b), ref)
    assert np.abs(ref).max() > 0
    assert np.abs(q - ref).max() <= 1e-9 * np.abs(ref).max()
    # the base's slides carry the net force on the whole chain: sum G^T m (x and z)
    slides = [be.model.jnt_dofadr[j] for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE]
    got = sorted(float(q[s]) for s in slides)
    assert np.allclose(got, sorted([force_total[0], force_total[2]]), rtol=1e-9, atol=0)


@pytest.mark.parametrize("beta", [0.0, 0.6])
def test_strip_loads_are_the_dipole_force_and_couple(beta):
    """The strip's loads (deformed, floor scene; an axial and a partly transverse magnetization): the vertex forces
    add up to sum G^T M, and with the twist hinges' moments their moment about the origin is sum (M x B + p x f),
    to 1e-9 of the reference."""
    beam = Beam(length=25e-3, width=5e-3, thickness=1.13e-3, magnetization=beta)
    sim = Simulator(beam, RodOptions(rod="cable", segments=8, scene="floor", gravity=0.0), source=PointDipole(**DIPOLE))
    rng = np.random.default_rng(2)
    q = sim.noisy_rest(rng, 0.3)
    cm = sim.backend.rod
    tw = cm.twist_qpos[cm.twist_qpos >= 0]
    q[tw] += rng.uniform(-0.3, 0.3, tw.size)
    sim.set_state(q)
    sim.step(1)  # MuJoCo's reference frames of a deformed state
    sim.set_field((0.0, 0.0, 0.0))
    d = sim.data
    x = sim.pose().centreline
    M = world_moments(cm, d, x)
    mid = 0.5 * (x[1:] + x[:-1])
    B, G = dipole(mid, np.array(DIPOLE["position"]), np.array(DIPOLE["moment"]))
    f = np.einsum("nab,na->nb", G, M)
    body = cm.vertex_body
    Fv = d.xfrc_applied[body, :3]
    assert np.abs(Fv.sum(axis=0) - f.sum(axis=0)).max() <= 1e-9 * np.abs(f).sum()
    t = np.diff(x, axis=0)
    t /= np.linalg.norm(t, axis=1)[:, None]
    twist = np.where(cm.twist_dof >= 0, d.qfrc_applied[np.maximum(cm.twist_dof, 0)], 0.0)
    got = np.cross(x, Fv).sum(axis=0) + (twist[:, None] * t).sum(axis=0)
    want = (np.cross(M, B) + np.cross(mid, f)).sum(axis=0)
    scale = np.abs(np.cross(M, B)).sum() + np.abs(np.cross(mid, f)).sum()
    assert np.abs(got - want).max() <= 1e-9 * scale


def test_the_package_dipole_is_the_reference():
    """The reference above and magsoft_env.fields agree (so the 1e-9 checks test the rods' loads, not the field)."""
    pts = np.array([[0.01, 0.002, 0.001], [0.02, -0.001, 0.0]])
    B, G = PointDipole(**DIPOLE).field_and_gradient(pts)
    B0, G0 = dipole(pts, np.array(DIPOLE["position"]), np.array(DIPOLE["moment"]))
    assert np.allclose(B, B0, rtol=1e-12, atol=0) and np.allclose(G, G0, rtol=1e-12, atol=1e-18)


# ----------------------------------------------------------------------------------- (b) Uniform is the field path
@pytest.mark.parametrize("rod,B", [("planar", (0.002, 0.0, -0.003)), ("cable", (0.002, 0.001, -0.003))])
def test_uniform_source_is_the_field_path_bit_for_bit(rod, B):
    """``source=Uniform(B)`` runs the uniform-field path: a free run on the floor and a settle give the same qpos /
    qvel bytes as ``field=B``, and so do the statics."""
    floor = RodOptions(rod=rod, segments=10, scene="floor", timestep=2e-4)
    a, b = Simulator(BEAM, floor, field=B), Simulator(BEAM, floor, source=Uniform(B))
    a.step(300)
    b.step(300)
    assert state_hash(a) == state_hash(b)
    assert a.field == b.field
    clamped = RodOptions(rod=rod, segments=10, gravity=0.0, timestep=1e-2 if rod == "planar" else 1e-3)
    a, b = Simulator(BEAM, clamped, field=B), Simulator(BEAM, clamped, source=SourceSum([Uniform(B)]))
    ra, rb = a.settle(max_time=2.0), b.settle(max_time=2.0)
    assert ra == rb and state_hash(a) == state_hash(b)
    ea = mujoco_equilibrium(BEAM, B, rod=rod, gravity=0.0, stability=False)
    eb = mujoco_equilibrium(BEAM, Uniform(B), rod=rod, gravity=0.0, stability=False)
    assert np.array_equal(ea.centreline, eb.centreline)


def test_uniform_source_in_a_gait_is_bit_for_bit():
    """``run_gait(source=Uniform(0))`` is the gait itself, bit for bit (the uniform part adds to the drive)."""
    a = run_gait("paper-5c", seconds=0.1, sample_dt=0.01)
    b = run_gait("paper-5c", seconds=0.1, sample_dt=0.01, source=Uniform((0.0, 0.0, 0.0)))
    assert np.array_equal(a.com_x, b.com_x)


def test_a_uniform_part_with_y_is_refused_by_the_chain():
    with pytest.raises(ValueError, match="x-z plane"):
        Simulator(BEAM, source=Uniform((0.0, 1e-3, 0.0)))


# ----------------------------------------------------------------------------------- (c) the magnet case
def test_magnet_case_chain_and_strip_agree():
    """The clamped paper strip near a small magnet (sim.sources.magnet_case): the chain and the strip settle within
    1 % of L of each other (measured 8.4e-5 L at 20 segments), bent by about 20 degrees toward +z."""
    beam, source, clamp = magnet_case()
    eqs = [mujoco_equilibrium(beam, source, rod=rod, **clamp) for rod in ("planar", "cable")]
    for eq in eqs:
        assert eq.success and eq.stable
        assert 15 < math.degrees(eq.tip_angle) < 30
        assert eq.source is source
    gap = np.abs(eqs[0].centreline - eqs[1].centreline).max() / beam.length
    assert gap < 1e-3


# ----------------------------------------------------------------------------------- (d) energy
def test_free_swing_near_a_dipole_conserves_energy():
    """An undamped clamped chain released straight near the magnet swings in a conservative field: the total energy
    (kinetic, elastic, -sum m . B(p)) drifts by the first-order stepping error only, halving with the step. Measured
    over 50 ms (semi-implicit Euler, 10 segments), as a fraction of the largest kinetic energy: 3.4e-4, 1.7e-4 and
    8.6e-5 at 20, 10 and 5 us."""
    beam, source, _ = magnet_case()
    drifts = []
    for dt in (2e-5, 1e-5):
        sim = Simulator(beam, RodOptions(segments=10, timestep=dt, integrator="euler", gravity=0.0,
                                         retardation_time=0.0), source=source)
        e0 = sim.energies()["total"]
        tot, kin = [], []
        for _ in range(10):
            sim.step(int(round(5e-3 / dt)))
            e = sim.energies()
            tot.append(e["total"])
            kin.append(e["kinetic"])
        drifts.append(np.max(np.abs(np.array(tot) - e0)) / max(kin))
    assert drifts[0] < 1e-3
    assert 0.4 < drifts[1] / drifts[0] < 0.6


# ----------------------------------------------------------------------------------- (e) a source moving away
@pytest.mark.parametrize("rod", ["planar", "cable"])
def test_moving_source_moving_away_leaves_the_strip_unloaded(rod):
    """A magnet that starts at the magnet case's place and leaves at 2 m/s: the strip first bends, then its loads
    vanish and it settles back straight."""
    beam, source, clamp = magnet_case()
    away = MovingSource(PointDipole(position=(0, 0, 0), moment=source.moment),
                        position=lambda t: np.array(source.position) + np.array([0.0, 0.0, -2.0]) * t)
    sim = Simulator(beam, RodOptions(rod=rod, segments=10, gravity=0.0, timestep=2e-4), source=away)
    sim.step(50)  # 10 ms: 2 cm away
    assert sim.tip_position()[-1] > 1e-4
    sim.step(500)  # 110 ms: 22 cm away
    assert np.abs(sim.backend.source_field(sim.data)).max() < 1e-6
    assert np.abs(sim.magnetic_couples()).max() < 1e-3 * 5e-3 * 1e-3
    r = sim.settle(max_time=5.0)
    assert r.success
    assert abs(sim.tip_position()[-1]) < 1e-4 * beam.length
    assert sim.source is away


def test_field_beyond_range_at_a_piece_is_refused():
    with pytest.raises(ValueError, match="1 T|beyond"):
        Simulator(BEAM, RodOptions(gravity=0.0), source=PointDipole(position=(0.01, 0.0, 1e-4), moment=(0, 0, 1.0)))


def test_set_source_none_restores_the_uniform_path():
    """After ``set_source(None)`` the chain steps natively again, bit for bit as one that never had a source."""
    opts = RodOptions(segments=10, scene="floor", timestep=2e-4)
    a = Simulator(BEAM, opts, field=(0.0, 0.002))
    b = Simulator(BEAM, opts, field=(0.0, 0.002), source=PointDipole(**DIPOLE))
    b.set_source(None)
    a.step(200)
    b.step(200)
    assert state_hash(a) == state_hash(b)


def test_source_step_bench_runs():
    from magsoft_env.bench import source_step_bench

    assert source_step_bench.main(["--segments", "4", "--steps", "5"]) == 0


def test_run_gait_reads_a_robots_field_source_block():
    """A robot file's ``field_source`` block acts in the Python API as in the CLI: ``run_gait(robot)`` equals
    ``run_gait(robot without it, source=the same source)`` bit for bit, and differs from the robot without it."""
    import magsoft_env as ms
    from magsoft_env.fields import source_from_dict

    block = {"type": "sphere", "position_mm": [30, 0, 14], "radius_mm": 1, "remanence_T": [0, 0, 1.2]}
    plain = ms.load_robot("paper-5c")
    with_block = plain.replace(field_source=block)
    a = ms.run_gait(with_block, 0.3)
    b = ms.run_gait(plain, 0.3, source=source_from_dict(block))
    c = ms.run_gait(plain, 0.3)
    assert a.displacement == b.displacement and a.speed == b.speed
    assert a.displacement != c.displacement


def test_envs_warn_that_they_do_not_use_a_robots_field_source():
    """The crawl and steering envs make their own fields: a robot file's source is named in a warning, not lost
    without a word; a robot without one gives no warning."""
    import warnings

    import gymnasium as gym

    import magsoft_env as ms

    block = {"type": "sphere", "position_mm": [12, 0, 15], "radius_mm": 3, "remanence_T": [0, 0, 1.2]}
    robot = ms.load_robot("paper-5c").replace(field_source=block)
    for env_id in ("MagSoftCrawl-v1", "MagSoftSteer-v0"):
        with pytest.warns(UserWarning, match="field_source .sphere. that this env does not use"):
            gym.make(env_id, robot=robot).close()
    with warnings.catch_warnings():
        warnings.simplefilter("error", UserWarning)
        gym.make("MagSoftCrawl-v1", robot="paper-5c").close()

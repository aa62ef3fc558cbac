"""Field sources in the MuJoCo Warp rod batch, on Warp's CPU device: per-world point dipoles against the C
simulator's ``source=``, the loads the kernel writes against :func:`~magsoft_env.sim.sources.piece_loads`, the
world without dipoles against the batch without sources, the API's refusals."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from magsoft_env.sim.warp_extra import INSTALL_HINT, warp_available

needs_warp = pytest.mark.skipif(not warp_available(), reason=f"the optional extra 'warp' is not installed: "
                                f"{INSTALL_HINT}")

# one pytest-xdist worker runs this module with tests/test_warp.py: the kernels are compiled once
pytestmark = [pytest.mark.xdist_group("warp"), pytest.mark.slow, needs_warp]

SUBSTEPS = 200


def _case():
    """The clamped strip of the magnet case (no gravity) and four worlds: the magnet, two dipoles, CardioMag's 59
    dipoles at fixed currents, none; each with its own held uniform field."""
    from magsoft_env.fields import CoilSystem, DipoleSet
    from magsoft_env.sim.model import RodOptions
    from magsoft_env.sim.sources import magnet_case

    beam, magnet, clamp = magnet_case()
    L = beam.length
    two = DipoleSet([[L, 0.0, 8e-3], [0.5 * L, 0.0, -8e-3]], [[3e-3, 0.0, 0.0], [0.0, 0.0, -2e-3]])
    cardio = CoilSystem.from_calibration("cardiomag").at_currents(np.linspace(-3.0, 3.0, 8))
    sources = [magnet, two, cardio, None]
    fields = np.array([[0.0, 0.0], [1e-3, 0.0], [0.0, -1e-3], [0.0, 1e-3]])
    opts = RodOptions(scene="cantilever", segments=20, timestep=2e-4, **clamp)
    return beam, opts, sources, fields


@pytest.fixture(scope="module")
def runs():
    """The batch with the sources and without, and the C simulators, after :data:`SUBSTEPS` substeps."""
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.warp_batch import WarpRodBatch

    beam, opts, sources, fields = _case()
    sim0 = Simulator(beam, opts)
    start = sim0.data.qpos.copy()
    batch = WarpRodBatch(sim0.rod, sim0.data, len(sources), device="cpu", backend=sim0.backend)
    plain = WarpRodBatch(sim0.rod, sim0.data, len(sources), device="cpu", backend=sim0.backend)
    batch.set_fields(fields)
    plain.set_fields(fields)
    batch.set_field_sources(sources)
    refs = [Simulator(beam, opts, field=(f[0], 0.0, f[1]), source=s) for s, f in zip(sources, fields, strict=True)]
    for _ in range(SUBSTEPS // 50):
        batch.advance(50)
        plain.advance(50)
        for sim in refs:
            sim.step(50)
    return {"sim0": sim0, "start": start, "batch": batch, "plain": plain, "refs": refs, "beam": beam,
            "sources": sources, "fields": fields}


def test_dipole_worlds_match_c_within_2e_6_of_the_length(runs):
    """Every world within 2e-6 L (centreline) and 2e-6 rad (hinges) of the C simulator with ``source=`` after 200
    substeps of 0.2 ms (measured: 1-2e-8 rad and 7-8e-8 L; 1.4e-7 rad and 3.4e-7 L in the CardioMag world, whose
    tip swings by 0.75 L), and the fields move every tip by more than 1e-3 L (measured: 0.14 L under the magnet,
    5e-3 L under the two dipoles)."""
    batch, refs, beam = runs["batch"], runs["refs"], runs["beam"]
    L = beam.length
    hinges = np.asarray(runs["sim0"].rod.hinge_qpos)
    s = batch.state()
    line = batch.centreline(s)
    q = batch.qpos()
    start_tip = runs["sim0"].pose().centreline[-1]
    for i, sim in enumerate(refs):
        c_line = sim.pose().centreline
        assert np.abs(q[i, hinges] - sim.data.qpos[hinges]).max() <= 2e-6
        assert np.abs(line[i][:, [0, 2]] - c_line[:, [0, 2]]).max() <= 2e-6 * L
        assert np.abs(c_line[-1] - start_tip).max() > 1e-3 * L


def test_the_world_without_dipoles_is_the_batch_without_sources_bit_for_bit(runs):
    batch, plain = runs["batch"], runs["plain"]
    a, b = batch.state(), plain.state()
    for key in ("qpos", "qvel", "xpos", "xmat"):
        assert np.array_equal(a[key][3], b[key][3]), key
    # and the worlds with dipoles are not the plain ones
    assert not np.array_equal(a["qpos"][0], b["qpos"][0])


def test_the_kernel_writes_piece_loads_at_a_state(runs):
    """At the batch's bent states: the kernel's forces and couples (with the moment arm to the CoM) are those of
    :func:`piece_loads` of the C source's field and gradient at the same pieces, to float32 round-off (measured:
    3e-7 to 1.1e-6 of the largest force or couple of the world)."""
    from magsoft_env.sim.sources import piece_loads

    batch, sim0, sources = runs["batch"], runs["sim0"], runs["sources"]
    loads = batch.write_source_loads()  # (nworld, pieces, 6), chain order
    be = sim0.backend
    order = be.order  # chain position of each body id
    data = mujoco.MjData(sim0.model)
    q = batch.qpos()
    for i, src in enumerate(sources):
        if src is None:
            assert not loads[i].any()
            continue
        data.qpos[:] = q[i]
        mujoco.mj_kinematics(sim0.model, data)
        R = data.xmat[be.b0:be.b1]
        m = np.zeros((be.npieces, 3))
        m[:, 0] = R[:, 0] * be._mx + R[:, 2] * be._mz
        m[:, 2] = R[:, 6] * be._mx + R[:, 8] * be._mz
        p = data.xpos[be.b0:be.b1] + be._half_ids[:, None] * R[:, 0::3]
        B, G = src.field_and_gradient(p)
        c, f = piece_loads(m, B, G)
        r = p - data.xipos[be.b0:be.b1]
        torque_y = c[:, 1] + r[:, 2] * f[:, 0] - r[:, 0] * f[:, 2]
        want = np.zeros((be.npieces, 6))
        want[:, 0], want[:, 2], want[:, 4] = f[:, 0], f[:, 2], torque_y
        got = loads[i][order]  # body-id order
        for cols in ([0, 2], [4]):
            scale = np.abs(want[:, cols]).max()
            assert scale > 0.0
            err = np.abs(got[:, cols] - want[:, cols]).max() / scale
            assert err <= 2e-5, (i, cols, err)
        assert not got[:, [1, 3, 5]].any()  # in the plane: no y force, no x or z couple


def test_graph_replay_equals_plain_launches_with_sources():
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.warp_batch import WarpRodBatch

    beam, opts, sources, fields = _case()
    sim0 = Simulator(beam, opts)
    out = []
    for graph in (True, False):
        b = WarpRodBatch(sim0.rod, sim0.data, len(sources), device="cpu", graph=graph)
        b.set_fields(fields)
        b.set_field_sources(sources)
        for _ in range(2):
            b.advance(20)
        out.append(b.qpos())
    assert np.array_equal(out[0], out[1])


def test_clear_sources_is_the_plain_path_again_and_sources_can_change():
    from magsoft_env.fields import PointDipole
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.warp_batch import WarpRodBatch

    beam, opts, sources, fields = _case()
    sim0 = Simulator(beam, opts)
    a = WarpRodBatch(sim0.rod, sim0.data, 2, device="cpu")
    b = WarpRodBatch(sim0.rod, sim0.data, 2, device="cpu")
    for x in (a, b):
        x.set_fields(fields[:2])
    a.set_field_sources(sources[:2])
    a.advance(10)
    a.clear_sources()
    assert a.source_dipoles() is None
    assert not a.d.xfrc_applied.numpy().any()
    # from the same state, a batch that never had sources and the cleared one step alike
    b.reset_worlds(np.ones(2, bool), a.qpos(), a.d.qvel.numpy())
    a.reset_worlds(np.ones(2, bool), a.qpos(), a.d.qvel.numpy())
    a.advance(10)
    b.advance(10)
    assert np.array_equal(a.qpos(), b.qpos())
    # new dipoles of the same count reuse the arrays (and graphs); another count builds new ones
    a.set_field_sources([sources[0], None])
    a.advance(10)
    a.set_field_sources([PointDipole(position=(0.02, 0.0, -0.01), moment=(0.0, 0.0, 1e-3)), sources[1]])
    a.advance(10)
    pos, mom = a.source_dipoles()
    assert pos.shape == mom.shape == (2, 2, 3)
    assert np.isfinite(a.qpos()).all()


def test_set_sources_refuses_bad_shapes_and_non_dipole_sources():
    from magsoft_env.fields import Uniform
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.warp_batch import WarpRodBatch

    beam, opts, *_ = _case()
    sim0 = Simulator(beam, opts)
    b = WarpRodBatch(sim0.rod, sim0.data, 3, device="cpu")
    with pytest.raises(ValueError, match=r"positions must have shape \(nworld, K, 3\) = \(3, K, 3\).*got \(2, 1, 3\)"):
        b.set_sources(np.zeros((2, 1, 3)), np.zeros((2, 1, 3)))
    with pytest.raises(ValueError, match=r"moments must have the shape of positions \(3, 2, 3\).*got \(3, 1, 3\)"):
        b.set_sources(np.zeros((3, 2, 3)), np.zeros((3, 1, 3)))
    with pytest.raises(ValueError, match="finite"):
        b.set_sources(np.full((1, 3), np.nan), np.zeros((1, 3)))
    with pytest.raises(ValueError, match="scale must be"):
        b.set_sources(np.zeros((1, 3)), np.zeros((1, 3)), scale=0.0)
    with pytest.raises(ValueError, match="one source .* per world"):
        b.set_field_sources([None])
    with pytest.raises(ValueError, match="set_fields"):
        b.set_field_sources([Uniform((1e-3, 0.0, 0.0)), None, None])
    with pytest.raises(ValueError, match="write_source_loads: no sources"):
        b.write_source_loads()
    # (K, 3): the same dipoles in every world
    b.set_sources([[0.03, 0.0, 0.0]], [[0.0, 0.0, 1e-3]])
    pos, mom = b.source_dipoles()
    assert pos.shape == (3, 1, 3)
    assert np.allclose(mom[:, 0, 2], 1e-10)  # mu0/(4 pi) folded in


def test_warp_source_bench_prints_the_table(capsys):
    from magsoft_env.bench import warp_source_bench

    assert warp_source_bench.main(["--worlds", "2", "--segments", "4", "--substeps", "5"]) == 0
    out = capsys.readouterr().out
    assert "| warp | cpu | CardioMag (8 coils, 59 dipoles) | 2 |" in out
    assert "| C | cpu (1 thread) | PointDipole | 1 |" in out


def test_the_energy_records_count_the_dipoles_energy_as_c():
    """With a backend, the energy balance counts ``-sum m . B`` of the dipoles: started at rest, every world's
    drift after 200 substeps is C's (``PlanarRod.energy`` with the source, staggered as the batch's check) within
    1e-6 of the scale (measured: the same to 5-6 digits, -1.5e-5 .. -1.6e-3 of the scale), while the dipoles'
    energy alone changes by 3.1e-3 of the scale in the CardioMag world."""
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.warp_batch import WarpRodBatch

    beam, opts, sources, fields = _case()
    sim0 = Simulator(beam, opts)
    n = len(sources)
    b = WarpRodBatch(sim0.rod, sim0.data, n, device="cpu", backend=sim0.backend)
    b.set_fields(fields)
    b.set_field_sources(sources)
    scale = 5.9e-3  # J: about the strip's energy scale at 1 mT
    b.set_energy_scale(np.full(n, scale))
    b.reset_worlds(np.ones(n, bool), np.tile(sim0.data.qpos, (n, 1)), np.zeros((n, sim0.model.nv)))
    e_start = b._src_energy.numpy().copy()
    b.advance(200)
    drift = b.state()["drift"]
    change = (b._src_energy.numpy() - e_start) / scale
    assert abs(change[2]) > 1e-3 and change[3] == 0.0  # no dipoles: no dipole energy
    for i, (src, f) in enumerate(zip(sources, fields, strict=True)):
        sim = Simulator(beam, opts, field=(f[0], 0.0, f[1]), source=src)
        be, d, field3 = sim.backend, sim.data, np.array([f[0], 0.0, f[1]])

        def energy(staggered, sim=sim, be=be, d=d, field3=field3):
            mv = np.zeros(sim.model.nv)
            mujoco.mj_mulM(sim.model, d, mv, d.qvel)
            return be.energy(d, field3, kinetic=0.5 * float(d.qvel @ mv), staggered=staggered)

        mujoco.mj_kinematics(sim.model, d)
        e0 = energy(False)
        sim.step(200)
        c_drift = (energy(True) - e0) / scale
        assert abs(drift[i] - c_drift) <= 1e-6, (i, drift[i], c_drift)
        assert drift[i] < 1e-6  # energy lost to the integrator, none created

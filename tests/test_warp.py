"""The MuJoCo Warp backend (the optional extra ``warp``), on Warp's CPU device: agreement with C, graph replay,
per-world health and resets, the vector-env contract, training through the SB3 adapter."""

from __future__ import annotations

import copy
import subprocess
import sys

import gymnasium as gym
import mujoco
import numpy as np
import pytest

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env import Beam
from magsoft_env.sim.warp_extra import INSTALL_HINT, warp_available

needs_warp = pytest.mark.skipif(not warp_available(), reason=f"the optional extra 'warp' is not installed: "
                                f"{INSTALL_HINT}")


# one pytest-xdist worker runs this module (``--dist loadgroup``): the kernels are compiled once, not in every worker
pytestmark = pytest.mark.xdist_group("warp")


def builds_kernels(test):
    """A test that runs MuJoCo Warp: slow, since on a fresh machine (an empty Warp kernel cache) its first such test
    compiles the solver's kernels, about half a minute of CPU on Warp's CPU device; the refusals above build none."""
    return pytest.mark.slow(needs_warp(test))


BEAM = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)


def test_nothing_imports_warp_until_the_backend_is_asked_for():
    code = (
        "import sys, gymnasium as gym, numpy as np, magsoft_env\n"
        "import magsoft_env.sim.warp_extra, magsoft_env.envs.crawl_task\n"
        "env = gym.make('MagSoftCrawl-v1', segments=4, sim_dt=1e-3); env.reset(seed=0)\n"
        "envs = gym.make_vec('MagSoftCrawl-v1', num_envs=2, segments=4, sim_dt=1e-3); envs.reset(seed=0)\n"
        "envs.step(np.zeros((2, 2), np.float32)); envs.close()\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('warp', 'mujoco_warp'))\n"
        "assert not bad, bad\n"
        "print('ok')\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")


def test_unknown_backend_is_refused():
    with pytest.raises(ValueError, match="backend must be 'cpu' or 'warp'"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=1, backend="gpu", segments=4, sim_dt=1e-3)


@needs_warp
@pytest.mark.parametrize("env_id", ["MagSoftChannel-v1", "MagSoftObstacle-v1"])
def test_warp_backend_refuses_the_channel_and_obstacle_naming_what_it_runs(env_id):
    with pytest.raises(ValueError, match="MagSoftCrawl-v1 and MagSoftCrawlWaveform-v1"):
        gym.make_vec(env_id, num_envs=1, backend="warp", device="cpu")


def test_warp_backend_refuses_the_3d_strip_naming_the_cpu_batch():
    # MJWarp 4.0 steps the strip's elasticity but not its floor contact as C does, and the strip's couples are
    # written from Python every substep (docs/gpu.md): refused before anything is built or Warp is imported
    with pytest.raises(ValueError, match=r"rod='cable'.*not on MuJoCo Warp.*backend='cpu'"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=2, backend="warp", device="cpu", rod="cable")


@needs_warp
def test_warp_backend_refuses_slew_rate_and_bad_per_world_values():
    with pytest.raises(ValueError, match="slew_rate"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=1, backend="warp", device="cpu", slew_rate=0.1)
    with pytest.raises(ValueError, match=r"field_scale must be .* one per world \(shape \(2,\)\)"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=2, backend="warp", device="cpu", field_scale=[1.0, 1.0, 1.0])
    with pytest.raises(ValueError, match="friction must be"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=2, backend="warp", device="cpu", friction=[0.5, -0.1])


# ---------------------------------------------------------------------- the rod batch against C
def _c_worlds(sim, n):
    return [copy.copy(sim.data) for _ in range(n)]


def _step_c(sim, datas, fields, k):
    from magsoft_env.sim.model import field_control

    for d, (bx, bz) in zip(datas, fields, strict=True):
        mag, w, y = field_control(float(bx), float(bz))
        d.ctrl[:] = mag
        d.mocap_quat[sim.rod.field_mocap] = [w, 0.0, y, 0.0]
        mujoco.mj_step(sim.model, d, k)


FIELDS = np.array([[1e-3, 1e-3], [-1.5e-3, 0.5e-3], [0.0, 2e-3], [0.0, 0.0]])


@builds_kernels
@pytest.mark.parametrize("scene", ["cantilever", "floor"])
def test_rod_batch_matches_c_to_1e6_rad_over_200_steps(scene):
    """The cantilever and the soft floor (2 ms contact), started from a state settled in C: every world within
    1e-6 rad (hinges) of MuJoCo's C step after 200 steps under its own field."""
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.model import RodOptions
    from magsoft_env.sim.warp_batch import WarpRodBatch

    sim = Simulator(BEAM, RodOptions(scene=scene, segments=20, timestep=2e-4))
    if scene == "floor":
        sim.set_field((0.0, 0.0))
        sim.step(500)
    batch = WarpRodBatch(sim.rod, sim.data, len(FIELDS), device="cpu")
    ref = _c_worlds(sim, len(FIELDS))
    batch.set_fields(FIELDS)
    hinges = np.asarray(sim.rod.hinge_qpos)
    worst = 0.0
    for _ in range(4):
        batch.advance(50)
        _step_c(sim, ref, FIELDS, 50)
        q = batch.qpos()
        worst = max(worst, max(np.abs(q[i, hinges] - ref[i].qpos[hinges]).max() for i in range(len(FIELDS))))
    moved = max(np.abs(ref[i].qpos[hinges] - sim.data.qpos[hinges]).max() for i in range(len(FIELDS)))
    assert moved > 1e-3  # the fields bend the rods: the agreement is not that of rods at rest
    assert worst <= 1e-6, worst


@builds_kernels
def test_graph_replay_equals_plain_launches():
    from magsoft_env.sim import Simulator
    from magsoft_env.sim.model import RodOptions
    from magsoft_env.sim.warp_batch import WarpRodBatch

    sim = Simulator(BEAM, RodOptions(scene="floor", segments=20, timestep=2e-4))
    sim.set_field((0.0, 0.0))
    sim.step(200)
    a = WarpRodBatch(sim.rod, sim.data, 3, device="cpu", graph=True)
    b = WarpRodBatch(sim.rod, sim.data, 3, device="cpu", graph=False)
    for batch in (a, b):
        batch.set_fields(FIELDS[:3])
        for _ in range(3):
            batch.advance(20)
    sa, sb = a.state(), b.state()
    for key in ("qpos", "qvel", "xpos", "clear_max", "cos_min", "depth"):
        np.testing.assert_array_equal(sa[key], sb[key], err_msg=key)


WAVES = np.array([[1e-3, 1e-3, 4.0, 0.5], [-1.5e-3, 0.5e-3, 3.0, -1.0], [0.0, 2e-3, 3.7, 0.0]])


@builds_kernels
def test_waveform_periods_match_c_to_1e6_rad_on_the_soft_floor():
    """Three worlds play their own waveform periods (1250, 1667 and 1351 substeps, phase from the step counter) on
    the soft floor (2 ms contact) for two periods: every world within 1e-6 rad of C's ``set_waveform`` run, and the
    energy records agree with C's balance (no drift)."""
    from magsoft_env.sim import PhaseShifted, Simulator
    from magsoft_env.sim.model import RodOptions
    from magsoft_env.sim.warp_batch import WarpRodBatch

    def settled():
        sim = Simulator(BEAM, RodOptions(scene="floor", segments=20, timestep=2e-4))
        sim.set_field((0.0, 0.0))
        sim.step(500)
        return sim

    sim = settled()
    nsub = np.round(1.0 / (WAVES[:, 2] * 2e-4)).astype(int)
    batch = WarpRodBatch(sim.rod, sim.data, len(WAVES), device="cpu", backend=sim.backend)
    batch.reset_worlds(np.ones(len(WAVES), bool), np.tile(sim.data.qpos, (len(WAVES), 1)),
                       np.zeros((len(WAVES), sim.model.nv)))
    refs = [settled() for _ in WAVES]
    hinges = np.asarray(sim.rod.hinge_qpos)
    worst, moved = 0.0, 0.0
    for _ in range(2):
        batch.set_waveforms(WAVES, nsub)
        batch.set_energy_scale(np.ones(len(WAVES)))
        batch.advance_waveforms()
        q = batch.qpos()
        for i, ref in enumerate(refs):
            ref.set_waveform(PhaseShifted(*WAVES[i]))
            ref.step(int(nsub[i]))
            worst = max(worst, np.abs(q[i, hinges] - ref.data.qpos[hinges]).max())
            moved = max(moved, np.abs(ref.data.qpos[hinges] - sim.data.qpos[hinges]).max())
    # MJWarp's float32 clock has drifted by parts in 1e5 (why the phase comes from the step counter)
    np.testing.assert_allclose(batch.d.time.numpy(), 2 * nsub * 2e-4, rtol=1e-4)
    s = batch.state()
    assert moved > 1e-2
    assert worst <= 1e-6, worst
    assert np.all(s["ke_ratio"] < 1e-3) and np.all(np.abs(s["drift"]) < 1e-4), (s["ke_ratio"], s["drift"])


# ---------------------------------------------------------------------- the env
#: Largest difference of each numeric ``info`` entry, Warp (float32 physics) against C, on the stiff paper-5c contact
#: over a few gentle steps (rad, m, m/s, reward units); the others must be equal.
INFO_TOLERANCE = {"orientation": 1e-3, "largest_piece_angle": 1e-3, "x_position": 1e-6, "z_position": 1e-6,
                  "x_velocity": 1e-4, "reward": 0.1, "reward_forward": 0.1, "highest_clearance": 1e-7,
                  "max_penetration": 1e-6, "time": 1e-12, "airborne_fraction": 0.02}


def assert_same_info(wi: dict, ci: dict, tolerance: dict | None = None) -> None:
    """The Warp batch's ``info`` against the CPU batch's: the same keys, masks and dtypes; the values equal, or within
    ``tolerance`` (:data:`INFO_TOLERANCE` by default) where the physics is float32."""
    tolerance = INFO_TOLERANCE if tolerance is None else tolerance
    assert set(wi) == set(ci), sorted(set(wi) ^ set(ci))
    for key, want in ci.items():
        got = wi[key]
        assert got.dtype == want.dtype and got.shape == want.shape, (key, got.dtype, want.dtype)
        if key.startswith("_") or want.dtype == object:
            assert key.startswith("_") or np.array_equal(wi["_" + key], ci["_" + key])
            if key.startswith("_"):
                np.testing.assert_array_equal(got, want, err_msg=key)
            continue
        mask = ci["_" + key]
        np.testing.assert_allclose(got[mask], want[mask], rtol=0, atol=tolerance.get(key, 0.0), err_msg=key)


@pytest.fixture(scope="module")
def warp_envs():
    if not warp_available():
        pytest.skip(f"the optional extra 'warp' is not installed: {INSTALL_HINT}")
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu")
    yield envs
    envs.close()


@builds_kernels
def test_env_contract_and_agreement_with_the_cpu_batch(warp_envs):
    envs = warp_envs
    cpu = gym.make_vec("MagSoftCrawl-v1", num_envs=3)
    assert envs.metadata["autoreset_mode"] == gym.vector.AutoresetMode.NEXT_STEP
    assert envs.single_observation_space == cpu.single_observation_space
    assert envs.single_action_space == cpu.single_action_space
    wo, wi = envs.reset(seed=5)
    co, ci = cpu.reset(seed=5)
    # the same reset noise as the CPU batch, on the beam settled in C
    settled = envs.unwrapped._qpos_settled
    hinges = np.asarray(cpu.envs[0].sim.rod.hinge_qpos)
    for i in range(3):
        noise = cpu.envs[i].sim.data.qpos[hinges] - cpu.envs[i].sim.model.qpos0[hinges]
        np.testing.assert_allclose(envs.unwrapped.start_qpos[i, hinges] - settled[hinges], noise, atol=1e-15)
        co[i], ci_i = cpu.envs[i].reset(options={"qpos": envs.unwrapped.start_qpos[i]})  # the C reference
        ci = {key: np.asarray(v).copy() for key, v in ci.items()}
        for key in ci_i:  # the C robot's info of its reset to the Warp world's start
            ci[key][i] = ci_i[key]
    assert wo.dtype == np.float32 and wo.shape == (3, 48)
    np.testing.assert_allclose(wo, co, atol=1e-6)
    assert_same_info(wi, ci)
    rng = np.random.default_rng(0)
    n1 = cpu.envs[0].segments + 1
    for _ in range(5):
        a = (0.3 * rng.uniform(-1, 1, (3, 2))).astype(np.float32)
        wo, wr, wt, wtr, wi = envs.step(a)
        co, cr, ct, ctr, ci = cpu.step(a)
        assert envs.observation_space.contains(wo)
        assert np.abs(wo[:, :n1] - co[:, :n1]).max() < 1e-3  # angles (rad): the stiff contact, round-off apart
        np.testing.assert_allclose(wr, cr, atol=0.05)
        np.testing.assert_array_equal(wt, ct)
        np.testing.assert_array_equal(wtr, ctr)
        assert_same_info(wi, ci)  # every key, mask and dtype; the values to float32's agreement
    cpu.close()


@builds_kernels
def test_waveform_env_matches_the_cpu_batch_and_autoresets_as_it():
    """``MagSoftCrawlWaveform-v1`` on Warp against the CPU batch from the same start: gentle periods (0.3 mT or less,
    the beam stays on the floor) of 3-4 Hz with their own lengths per world; observations, rewards, terminations,
    truncations (time limit 2), the NEXT_STEP autoreset and the info keys as the CPU batch's."""
    n = 3
    envs = gym.make_vec("MagSoftCrawlWaveform-v1", num_envs=n, backend="warp", device="cpu", max_episode_steps=2)
    cpu = gym.make_vec("MagSoftCrawlWaveform-v1", num_envs=n, num_threads=1, max_episode_steps=2)
    assert envs.single_action_space == cpu.single_action_space and envs.single_action_space.shape == (4,)
    assert envs.single_observation_space == cpu.single_observation_space
    wo, wi = envs.reset(seed=5)
    co, ci = cpu.reset(seed=5)
    for i in range(n):
        co[i] = cpu.envs[i].reset(options={"qpos": envs.unwrapped.start_qpos[i]})[0]
    np.testing.assert_allclose(wo, co, atol=1e-6)
    assert set(wi) == set(ci)
    rng = np.random.default_rng(0)
    n1 = cpu.envs[0].segments + 1
    for step in range(3):
        a = rng.uniform(-1, 1, (n, 4)).astype(np.float32)
        a[:, :2] *= 0.15
        a[:, 3] = rng.uniform(0.5, 1.0, n)  # 3.25-4 Hz: 1250-1540 substeps, a different length per world
        wo, wr, wt, wtr, wi = envs.step(a)
        co, cr, ct, ctr, ci = cpu.step(a)
        assert set(wi) == set(ci)
        np.testing.assert_array_equal(wt, ct)
        np.testing.assert_array_equal(wtr, ctr)
        if step < 2:
            assert np.abs(wo[:, :n1] - co[:, :n1]).max() < 1e-4  # angles (rad); measured 1e-7 .. 6e-6
            np.testing.assert_allclose(wo[:, -6:], co[:, -6:], atol=1e-6)  # COM velocity, the last action
            np.testing.assert_allclose(wr, cr, atol=1e-4)  # measured 2e-6 .. 3e-6
            np.testing.assert_allclose(wi["x_position"], ci["x_position"], atol=1e-8)
            np.testing.assert_allclose(wi["time"], ci["time"], atol=1e-9)
            np.testing.assert_array_equal(wi["field"], ci["field"])
        else:  # the step after the time limit: every world restarts, reward 0, time 0, the reset observation
            assert step == 2 and not (wt | wtr).any()
            np.testing.assert_array_equal(wr, cr)
            assert np.all(wi["time"] == 0.0) and np.all(ci["time"] == 0.0)
            np.testing.assert_array_equal(wo[:, -4:], co[:, -4:])
    assert wtr.sum() == 0
    envs.close()
    cpu.close()


def _parse(text: str) -> tuple[list[str], list[float]]:
    """The words and numbers of an info text (a crawl violation, a failure)."""
    import re

    number = r"[-+]?\d+(?:\.\d*)?(?:e[-+]?\d+)?"
    return re.sub(number, "#", text).split(), [float(v) for v in re.findall(number, text)]


def _c_twins(envs, n, **kw):
    """A CPU batch whose robots start where the Warp worlds of ``envs`` (just reset) start."""
    cpu = gym.make_vec("MagSoftCrawl-v1", num_envs=n, num_threads=1, **kw)
    cpu.reset(seed=0)
    for i in range(n):
        cpu.envs[i].reset(options={"qpos": envs.unwrapped.start_qpos[i]})
    return cpu


@builds_kernels
def test_crawl_violations_terminate_as_in_c_with_the_same_texts():
    """10 mT along z lifts the ends past the 7.6 mm ceiling within a step (height mode): every world terminates at
    the step C does, with the same text (the same substep; the height within float32's 0.02 mm)."""
    kw = {"crawl_mode": "height", "max_clearance": None, "field_limit": 0.01}
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu", **kw)
    envs.reset(seed=5)
    cpu = _c_twins(envs, 3, **kw)
    a = np.array([[0.0, 1.0], [0.0, 0.7], [0.0, 0.4]], np.float32)
    wo, wr, wt, wtr, wi = envs.step(a)
    co, cr, ct, ctr, ci = cpu.step(a)
    assert wt.all() and np.array_equal(wt, ct) and not (wtr | ctr).any()
    assert_same_info(wi, ci, {**INFO_TOLERANCE, "highest_clearance": 1e-6, "reward_crawl": 0.1})
    np.testing.assert_array_equal(wr, cr)  # -(penalty + the episode's forward reward): nothing earned before
    for w, c in zip(wi["crawl_violation"], ci["crawl_violation"], strict=True):
        (ww, wn), (cw, cn) = _parse(w), _parse(c)
        assert ww == cw and wn[1:] == cn[1:] and abs(wn[0] - cn[0]) <= 0.02, (w, c)  # "height # mm > # mm at t = #"
    envs.close()
    cpu.close()


@builds_kernels
def test_an_unphysical_world_reads_as_the_c_simulator():
    """100 mT pressed straight down at 1 ms (docs/envs.md): world 0 penetrates the floor in its fourth substep. Its
    truncation, ``info["unphysical"]``, ``instability`` and figures are the single C env's, from the same functions
    (sim/health.py): the same step and time, the depth within float32's; world 1 steps on."""
    kw = {"sim_dt": 1e-3, "field_limit": 0.1}
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, backend="warp", device="cpu", **kw)
    envs.reset(seed=0)
    cpu = _c_twins(envs, 2, **kw)
    a = np.array([[0.0, -1.0], [0.0, 0.0]], np.float32)
    _, wr, wt, wtr, wi = envs.step(a)
    _, cr, ct, ctr, ci = cpu.step(a)
    assert wtr.tolist() == ctr.tolist() == [True, False] and not (wt | ct).any()
    assert wi["instability"][0] == ci["instability"][0] == "penetration"
    tol = {**INFO_TOLERANCE, "penetration_m": 1e-6, "penetration_h": 1e-3, "max_penetration_m": 1e-6,
           "max_penetration_h": 1e-3, "max_penetration": 1e-6, "time_s": 1e-12, "orientation": 1e300}
    assert_same_info(wi, ci, tol)  # world 0's orientation is that of a blown-up state in both
    for key in ("truncation_reason", "unphysical"):
        (ww, wn), (cw, cn) = _parse(wi[key][0]), _parse(ci[key][0])
        assert ww == cw, (wi[key][0], ci[key][0])
        np.testing.assert_allclose(wn, cn, rtol=2e-3)  # the steps and times equal, the depth float32's
    assert wi["truncation_reason"][0].startswith("unphysical motion at step 4 (t = 0.004 s): contact penetration")
    envs.close()
    cpu.close()


@builds_kernels
def test_the_device_crawl_limits_are_the_task_functions(warp_envs):
    """The substep kernel (sim/warp_batch.py) against :func:`crawl_task.crawl_limits` on the same states: a call of
    no substeps records the present state alone."""
    from magsoft_env.envs.crawl_task import crawl_limits

    envs = warp_envs.unwrapped
    envs.reset(seed=8)
    envs.step(np.full((3, 2), 0.8, np.float32))
    batch = envs.batch
    batch.advance(0)
    s = batch.state()
    pts = batch.centreline(s)
    lim = crawl_limits(pts[:, :, None, :], np.zeros(3), half_thickness=0.5 * envs.proto.gait.beam.thickness,
                       inv_piece_length=1.0 / batch.piece_lengths)[:, :, 0]
    np.testing.assert_allclose(s["clear_max"], lim[:, 0], atol=1e-7)  # m: float32 positions near 1e-2 m
    np.testing.assert_allclose(s["cos_min"], lim[:, 2], atol=5e-6)  # float32 piece lengths and positions
    assert (lim[:, 2] < 0.9999).all()  # the field bent them: the comparison is not that of straight beams
    envs.reset(seed=8)


@builds_kernels
def test_friction_and_field_scale_per_world():
    """``friction`` and ``field_scale`` one per world: a world equals the world of a batch built with its values
    (round-off apart: the worlds' contacts are gathered together); the friction changes the crawl."""
    gait = gym.make("MagSoftCrawl-v1").unwrapped
    acts = [np.tile(gait.open_loop_action(k * gait.n_substeps * gait.sim_dt), (3, 1)) for k in range(6)]
    mixed = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu", friction=[0.5, 0.5, 0.1],
                         field_scale=[1.0, 0.5, 1.0])
    plain = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu")
    slippery = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu", friction=0.1)
    np.testing.assert_array_equal(mixed.unwrapped.friction, [0.5, 0.5, 0.1])
    np.testing.assert_array_equal(slippery.unwrapped.friction, [0.1] * 3)
    for e in (mixed, plain, slippery):
        e.reset(seed=7)
    for a in acts:
        half = a.copy()
        half[1] *= 0.5  # the scaled world's applied field (a power of two: the same bits)
        mo, mr, *_, mi = mixed.step(a)
        po, pr, *_, pi = plain.step(half)
        so, sr, *_, si = slippery.step(a)
    q = mixed.unwrapped.qpos()
    np.testing.assert_allclose(q[0], plain.unwrapped.qpos()[0], atol=1e-4)
    np.testing.assert_allclose(q[1], plain.unwrapped.qpos()[1], atol=1e-4)
    np.testing.assert_allclose(q[2], slippery.unwrapped.qpos()[2], atol=1e-4)
    np.testing.assert_allclose(mi["x_position"][2], si["x_position"][2], atol=1e-7)
    # the observation keeps the commanded field; the friction moves the crawl
    np.testing.assert_array_equal(mo[1, -4:-2], (a[1] / 1.0).astype(np.float32))
    moved = abs(pi["x_position"][2] - mi["x_position"][2])
    same = abs(si["x_position"][2] - mi["x_position"][2])
    print(f"x of world 2 (m): mu 0.5 vs 0.1 apart by {moved:.3g}, the mu 0.1 twins by {same:.3g}")
    assert moved > 1e-7 and moved > 10 * same, (moved, same)
    for e in (mixed, plain, slippery, gait):
        e.close()


@builds_kernels
def test_a_non_finite_world_truncates_and_resets_alone(warp_envs):
    """World 1 goes non-finite: it truncates and restarts at its next step; worlds 0 and 2 step on exactly as in a
    twin batch where nothing happened (bit for bit)."""
    envs = warp_envs.unwrapped
    twin = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu").unwrapped
    act = np.full((3, 2), 0.4, np.float32)
    for e in (envs, twin):
        e.reset(seed=1)
        e.step(act)
    d = envs.batch.d
    qvel = d.qvel.numpy()
    qvel[1] = np.nan
    d.qvel.assign(qvel)
    obs, r, term, trunc, info = envs.step(act)
    tobs, *_ = twin.step(act)
    assert trunc.tolist() == [False, True, False] and not term.any()
    assert info["_truncation_reason"].tolist() == [False, True, False]
    assert "non-finite" in info["truncation_reason"][1]
    assert r[1] == 0.0 and np.all(np.isfinite(obs))
    np.testing.assert_array_equal(obs[[0, 2]], tobs[[0, 2]])
    # the next step resets it (NEXT_STEP) from the settled state with fresh noise, the others step on
    obs, r, term, trunc, info = envs.step(act)
    tobs, *_ = twin.step(act)
    assert not trunc.any() and not term.any() and r[1] == 0.0
    assert info["time"][1] == 0.0 and info["time"][0] > 0.0
    np.testing.assert_array_equal(envs.qpos()[[0, 2]], twin.qpos()[[0, 2]])
    np.testing.assert_array_equal(obs[[0, 2]], tobs[[0, 2]])
    obs, *_ = envs.step(act)
    assert np.all(np.isfinite(obs)) and np.all(np.isfinite(envs.qpos()))
    twin.close()


@builds_kernels
def test_worlds_made_to_blow_up_truncate_and_reset_alone(warp_envs):
    """World 1 is thrown upward at 300 m/s (kinetic energy above 100 x the energy scale: runaway), world 2 at 2 m/s
    (below it, but 8 % of the energy scale that the field never supplied: a launch, from the device's energy
    balance); both truncate with the CPU batch's reasons and restart at their next step, world 0 steps on as in a
    twin batch."""
    envs = warp_envs.unwrapped
    twin = gym.make_vec("MagSoftCrawl-v1", num_envs=3, backend="warp", device="cpu").unwrapped
    act = np.full((3, 2), 0.4, np.float32)
    for e in (envs, twin):
        e.reset(seed=1)
        e.step(act)
    z = int(envs.proto.sim.rod.base_qpos[1])  # the base's vertical slide
    qvel = envs.batch.d.qvel.numpy()
    qvel[1, z], qvel[2, z] = 300.0, 2.0
    envs.batch.d.qvel.assign(qvel)
    obs, r, term, trunc, info = envs.step(act)
    tobs, *_ = twin.step(act)
    assert trunc.tolist() == [False, True, True] and not term.any()
    assert info["instability"][1] == "runaway kinetic energy (J)"
    assert info["truncation_reason"][1].startswith("simulation unstable at step 200 (t = 0.04 s): runaway kinetic "
                                                   "energy (J) = ")  # the C simulator's text (sim/health.py)
    assert info["instability"][2] == "launch" and info["_unphysical"].tolist() == [False, False, True]
    assert info["unphysical"][2].startswith("launch: the rod gained ")
    assert info["truncation_reason"][2].startswith("unphysical motion at step 200 (t = 0.04 s): launch: the rod")
    assert 0.01 < info["energy_drift"][2] < 100.0 and info["energy_created_J"][2] > 0.0
    assert info["step"][2] == 200 and info["time_s"][2] == pytest.approx(0.04)
    assert r[1] == r[2] == 0.0 and np.all(np.isfinite(obs))
    np.testing.assert_allclose(obs[0], tobs[0], atol=1e-6)
    obs, r, term, trunc, info = envs.step(act)
    tobs, *_ = twin.step(act)
    assert not trunc.any() and not term.any() and info["time"][1] == info["time"][2] == 0.0
    np.testing.assert_allclose(obs[0], tobs[0], atol=1e-6)
    obs, r, term, trunc, info = envs.step(act)
    assert not trunc.any() and np.all(info["time"] > 0.0)
    twin.close()


@builds_kernels
def test_an_mjwarp_buffer_overflow_is_reported_for_its_world_alone(warp_envs):
    """MJWarp's overflow bits are per world (``Data.overflow``): a world that set one (here: the contact buffer's)
    truncates naming nconmax / njmax and restarts with its bits cleared; the solver's iteration caps are not
    failures."""
    import mujoco_warp as mjw

    envs = warp_envs.unwrapped
    act = np.zeros((3, 2), np.float32)
    envs.reset(seed=3)
    envs.step(act)
    flags = envs.batch.d.overflow.numpy()
    flags[0] |= int(mjw.OverflowType.NARROWPHASE)
    flags[2] |= int(mjw.OverflowType.ITERATIONS)
    envs.batch.d.overflow.assign(flags)
    _, r, term, trunc, info = envs.step(act)
    assert trunc.tolist() == [True, False, False] and info["instability"][0].startswith("MJWarp buffer overflow")
    assert "raise nconmax / njmax" in info["truncation_reason"][0]
    envs.step(act)
    assert envs.batch.d.overflow.numpy()[0] == 0
    _, r, term, trunc, info = envs.step(act)
    assert not trunc.any()


@builds_kernels
def test_attributes_are_the_shared_prototype_s(warp_envs):
    assert warp_envs.unwrapped.get_attr("field_limit") == (2e-3,) * 3
    assert warp_envs.unwrapped.call("open_loop_action", 0.0)[0].shape == (2,)
    with pytest.raises(ValueError, match="share their parameters"):
        warp_envs.unwrapped.set_attr("crawl_penalty", [1.0, 2.0, 3.0])


@builds_kernels
def test_reset_mask_resets_only_the_masked_worlds(warp_envs):
    envs = warp_envs
    envs.reset(seed=2)
    for _ in range(2):
        envs.step(np.full((3, 2), 0.5, np.float32))
    before = envs.unwrapped.qpos()
    mask = np.array([False, True, False])
    obs, info = envs.reset(options={"reset_mask": mask})
    after = envs.unwrapped.qpos()
    np.testing.assert_array_equal(after[[0, 2]], before[[0, 2]])
    assert info["_time"].tolist() == [False, True, False] and info["time"][1] == 0.0
    again, _ = envs.reset(seed=[None, 2 + 1, None], options={"reset_mask": mask})
    first, _ = envs.reset(seed=2)
    np.testing.assert_array_equal(again[1], first[1])  # the same seed, the same start


@builds_kernels
def test_crawl_displacement_statistics_match_c():
    """The paper-5c gait at its default (stiff) contact, where lift-off and touchdown amplify round-off: the
    distribution of the displacement over seeds agrees with C's within the scatter."""
    n, steps = 6, 40
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=n, backend="warp", device="cpu")
    cpu = gym.make_vec("MagSoftCrawl-v1", num_envs=n, num_threads=1)
    _, wi = envs.reset(seed=100)
    cpu.reset(seed=100)
    x0c = np.array([cpu.envs[i].reset(options={"qpos": envs.unwrapped.start_qpos[i]})[1]["x_position"]
                    for i in range(n)])
    x0w = wi["x_position"].copy()
    proto = cpu.envs[0]
    for k in range(steps):
        a = np.tile(proto.open_loop_action(k * proto.n_substeps * proto.sim_dt), (n, 1))
        _, _, wt, wtr, wi = envs.step(a)
        _, _, ct, ctr, ci = cpu.step(a)
        assert not (wt | wtr | ct | ctr).any()
    dw = wi["x_position"] - x0w
    dc = ci["x_position"] - x0c
    assert abs(dc.mean()) > 0.1e-3  # it moves (a fraction of a mm in 0.8 s)
    print("displacement (mm): warp", dw * 1e3, "C", dc * 1e3)
    spread = np.sqrt(dw.var(ddof=1) / n + dc.var(ddof=1) / n)
    assert abs(dw.mean() - dc.mean()) <= 3 * spread + 0.03 * abs(dc.mean()), (dw, dc)
    envs.close()
    cpu.close()


@builds_kernels
def test_ppo_trains_on_the_warp_batch_through_the_sb3_adapter():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from magsoft_env.rl.vec import make_sb3_vec_env

    # SB3VecAdapter over the Warp batch, in VecMonitor: the same path as the CPU batch's
    venv = make_sb3_vec_env("MagSoftCrawl-v1", 4, seed=0, backend="warp", device="cpu", max_episode_steps=10)
    model = PPO("MlpPolicy", venv, n_steps=8, batch_size=16, n_epochs=1, seed=0, device="cpu")
    model.learn(64)
    assert model.num_timesteps >= 64
    assert len(model.ep_info_buffer) >= 4  # episodes ended (time limit), were reset and logged
    obs = venv.reset()
    assert obs.shape == (4, 48) and np.all(np.isfinite(obs))
    venv.close()


@builds_kernels
def test_warp_bench_prints_the_table(capsys):
    from magsoft_env.bench import warp_bench

    assert warp_bench.main(["--worlds", "1,2", "--steps", "1", "--error-steps", "2", "--error-worlds", "2",
                            "--device", "cpu"]) == 0
    out = capsys.readouterr().out
    assert "| backend | device | worlds | env steps/s |" in out
    assert out.count("| warp | cpu |") >= 2 and "reference (C)" in out


# ---------------------------------------------------------------------- rl-zoo3 through train/train.py --vec warp
def _train_script():
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "train" / "train.py"
    spec = importlib.util.spec_from_file_location("train_train_warp", path)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_train_refuses_vec_warp_for_what_the_backend_does_not_run(tmp_path, capsys):
    rc = _train_script().main(["--env", "MagSoftChannel-v1", "--vec", "warp", "--runs", str(tmp_path),
                               "--run-id", "r"])
    assert rc == 2
    assert "vec='warp' trains MagSoftCrawl-v1 and MagSoftCrawlWaveform-v1" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


@builds_kernels
def test_train_py_runs_rl_zoo_on_the_warp_batch(tmp_path, capsys):
    """``train/train.py --vec warp``: rl-zoo3's PPO (VecNormalize from the block) learns on 4 Warp worlds, evaluates in
    a single C env, and writes the run folder with the Warp worlds' monitor file."""
    pytest.importorskip("rl_zoo3")
    import json

    args = ["--env", "MagSoftCrawl-v1", "--vec", "warp", "--warp-device", "cpu", "--n-envs", "4", "--runs",
            str(tmp_path), "--run-id", "w", "--timesteps", "64", "--set", "n_steps=16", "batch_size=32", "n_epochs=1",
            "--eval-freq", "64", "--eval-episodes", "1", "--no-eval"]
    assert _train_script().main(args) == 0
    out = capsys.readouterr().out
    assert "[training envs: MuJoCo Warp batch]" in out and "Eval num_timesteps=64" in out
    run = tmp_path / "w"
    rec = json.loads((run / "train.json").read_text())
    assert rec["vec"] == "warp" and rec["warp_device"] == "cpu"
    assert "backend='warp'" in (run / "zoo_command.txt").read_text()
    log = run / "ppo" / "MagSoftCrawl-v1_1"
    assert (log / "0.monitor.csv").exists() and (log / "MagSoftCrawl-v1.zip").exists()
    assert (log / "MagSoftCrawl-v1" / "vecnormalize.pkl").exists()
    from rl_zoo3.exp_manager import ExperimentManager

    assert ExperimentManager.create_envs.__name__ == "create_envs"  # rl-zoo3's own again
    assert ExperimentManager.create_envs.__qualname__.startswith("ExperimentManager")

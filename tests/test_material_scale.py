"""Domain randomization of the material: ``Simulator.set_material_scale`` against a simulator rebuilt from the scaled
beam (every MjModel array, trajectories), restoring, validation; the environments' ``modulus_range`` and
``magnetization_range``."""

from __future__ import annotations

import copy
import dataclasses
import hashlib

import mujoco
import numpy as np
import pytest

from magsoft_env import Beam
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.fields import PointDipole
from magsoft_env.sim import RodOptions, Simulator

#: paper-5c: a programmed magnetization in the x-z plane (the strip writes its couples from Python); AXIAL: a uniform
#: axial one (the strip's couples are MuJoCo's poles)
PAPER = gait_preset("paper-5c").beam
AXIAL = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
#: an axial magnetization graded along the strip: every vertex carries a pole well above round-off
GRADED = Beam(length=25e-3, width=5e-3, thickness=1.13e-3, volume_fraction=lambda s: 0.1 + 6.0 * s)
#: the arrays of a strip's pole tendons whose layout follows which coefficients are exactly zero
TENDON_LAYOUT = {"ten_J_colind", "ten_J_rowadr", "ten_J_rownnz", "tendon_adr", "tendon_num", "tendon_treeid",
                 "tendon_treenum", "tree_sleep_policy", "wrap_objid", "wrap_prm", "wrap_type"}


def scaled(beam: Beam, modulus: float, magnetization: float) -> Beam:
    mat = beam.material
    return beam.replace(material=dataclasses.replace(mat, E0=mat.E0 * modulus,
                                                     particle_magnetization=mat.particle_magnetization * magnetization))


def arrays(model: mujoco.MjModel) -> dict[str, np.ndarray]:
    out = {}
    for name in dir(model):
        if name.startswith("_"):
            continue
        try:
            value = getattr(model, name)
        except Exception:  # noqa: BLE001 - a property MuJoCo refuses for this model
            continue
        if isinstance(value, np.ndarray):
            out[name] = value
    return out


def tendon_coefficients(model: mujoco.MjModel) -> np.ndarray:
    """The pole tendons' coefficients as a dense (tendon, joint) matrix."""
    c = np.zeros((model.ntendon, model.njnt))
    for t in range(model.ntendon):
        for w in range(model.tendon_adr[t], model.tendon_adr[t] + model.tendon_num[t]):
            c[t, model.wrap_objid[w]] += model.wrap_prm[w]
    return c


def model_differences(a: mujoco.MjModel, b: mujoco.MjModel, rtol: float = 1e-12) -> list[str]:
    """Names of the arrays of ``a`` that differ from ``b``'s beyond ``rtol`` (of each array's largest entry)."""
    A, B = arrays(a), arrays(b)
    layout = A["wrap_prm"].shape != B["wrap_prm"].shape or not np.array_equal(A["wrap_objid"], B["wrap_objid"])
    out = []
    for name, x in A.items():
        y = B[name]
        if layout and name in TENDON_LAYOUT:
            continue  # compared as coefficients below
        if x.shape != y.shape:
            out.append(f"{name} (shape)")
        elif x.dtype.kind in "fc":
            if not np.allclose(x, y, rtol=rtol, atol=rtol * (float(np.max(np.abs(y))) if y.size else 0.0)):
                out.append(name)
        elif not np.array_equal(x, y):
            out.append(name)
    if layout:
        ca, cb = tendon_coefficients(a), tendon_coefficients(b)
        if not np.allclose(ca, cb, rtol=rtol, atol=rtol * float(np.max(np.abs(cb)))):
            out.append("tendon coefficients")
    return out


def bit_differences(a: mujoco.MjModel, b: mujoco.MjModel) -> list[str]:
    A, B = arrays(a), arrays(b)
    return [n for n, x in A.items() if x.shape != B[n].shape or not np.array_equal(x, B[n], equal_nan=True)]


def digest(sim: Simulator) -> str:
    h = hashlib.sha256()
    for a in (sim.data.qpos, sim.data.qvel, sim.data.qacc_warmstart):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


CASES = [
    pytest.param("planar", "floor", PAPER, id="planar-floor"),
    pytest.param("planar", "cantilever", AXIAL, id="planar-cantilever"),
    pytest.param("cable", "cantilever", PAPER, id="cable-cantilever-python"),
    pytest.param("cable", "cantilever", AXIAL, id="cable-cantilever-native"),
    pytest.param("cable", "floor", AXIAL, id="cable-floor-native"),
    pytest.param("planar", "channel", PAPER, id="planar-channel"),
    pytest.param("cable", "channel", PAPER, id="cable-channel-python"),
]


def options(rod: str, scene: str) -> RodOptions:
    kw = {"contact_timeconst": "material"} if scene != "cantilever" else {}
    if scene in ("channel", "obstacle"):
        kw["feature_x"] = 5e-3
    return RodOptions(rod=rod, scene=scene, segments=6, timestep=2e-4, **kw)


def held_field(rod: str):
    return (1e-3, 5e-4, 3e-3) if rod == "cable" else (1e-3, 3e-3)


@pytest.mark.parametrize("rod, scene, beam", CASES)
def test_scaled_model_is_the_rebuilt_one(rod, scene, beam):
    o = options(rod, scene)
    sim = Simulator(beam, o)
    before = copy.deepcopy(sim.model)
    sim.set_material_scale(modulus=1.3, magnetization=0.8)
    assert sim.material_scale == (1.3, 0.8)
    rebuilt = Simulator(scaled(beam, 1.3, 0.8), o)
    assert model_differences(sim.model, rebuilt.model) == []
    assert sim._health.energy_scale == pytest.approx(rebuilt._health.energy_scale, rel=1e-12)
    if o.has_contact:
        assert sim._health.tc == pytest.approx(rebuilt._health.tc, rel=1e-12)
    s0, s1 = sim.backend.settle_damping(0.05), rebuilt.backend.settle_damping(0.05)
    np.testing.assert_allclose(s0[1], s1[1], rtol=1e-12)
    np.testing.assert_allclose(sim.backend.stiffness, rebuilt.backend.stiffness, rtol=1e-12)
    # a short trajectory under a held field agrees with the rebuilt simulator's
    for s in (sim, rebuilt):
        s.set_field(held_field(rod))
        s.step(200)
    assert np.max(np.abs(sim.data.qpos - rebuilt.data.qpos)) <= 1e-10 * beam.length
    assert sim.energies()["total"] == pytest.approx(rebuilt.energies()["total"], rel=1e-9, abs=1e-15)
    # (1, 1) restores the model bit for bit, and scaling again does not compound
    sim.set_material_scale(2.0, 3.0)
    sim.set_material_scale(1.0, 1.0)
    assert bit_differences(sim.model, before) == []
    assert sim.material_scale == (1.0, 1.0)


@pytest.mark.parametrize("poles", ["tendon", "joint"])
def test_the_strip_poles_scale_either_way(poles):
    from magsoft_env.sim.cable import overrides

    # a uniform magnetization's interior poles are round-off, present or not as the rounding falls (the tendon
    # entries are compared as coefficients above; a slide motor per pole changes the actuators): a graded one here
    o = options("cable", "floor")
    with overrides(poles=poles):
        sim = Simulator(GRADED, o)
        rebuilt = Simulator(scaled(GRADED, 0.7, 1.9), o)
    before = copy.deepcopy(sim.model)
    sim.set_material_scale(modulus=0.7, magnetization=1.9)
    assert model_differences(sim.model, rebuilt.model) == []
    for s in (sim, rebuilt):
        s.set_field(held_field("cable"))
        s.step(200)
    assert np.max(np.abs(sim.data.qpos - rebuilt.data.qpos)) <= 1e-10 * GRADED.length
    sim.set_material_scale()
    assert bit_differences(sim.model, before) == []


def test_the_test_twin_scales_through_the_interface():
    from magsoft_env.rods import ROD_BACKENDS, register_rod

    saved = dict(ROD_BACKENDS)
    register_rod("twin", "rod_twin:ChainTwin")
    try:
        o = RodOptions(rod="twin", scene="floor", segments=6, timestep=2e-4)
        twin, chain = Simulator(PAPER, o), Simulator(PAPER, dataclasses.replace(o, rod="planar"))
        for s in (twin, chain):
            s.set_material_scale(1.3, 0.8)
            s.set_field((1e-3, 3e-3))
            s.step(100)
        assert digest(twin) == digest(chain)
    finally:
        ROD_BACKENDS.clear()
        ROD_BACKENDS.update(saved)


@pytest.mark.parametrize("rod", ["planar", "cable"])
def test_a_scale_of_one_changes_nothing(rod):
    runs = []
    for call in (False, True):
        sim = Simulator(PAPER, options(rod, "floor" if rod == "planar" else "cantilever"))
        if call:
            sim.set_material_scale(1.0, 1.0)
            sim.set_material_scale(modulus=1, magnetization=1)
        sim.set_field(held_field(rod))
        sim.step(150)
        runs.append(digest(sim))
    assert runs[0] == runs[1]


@pytest.mark.parametrize("rod", ["planar", "cable"])
def test_the_source_path_scales(rod):
    src = PointDipole(position=(0.012, 0.0, 0.02), moment=(0.0, 0.0, 0.05))
    o = options(rod, "cantilever")
    sim = Simulator(PAPER, o, source=src)
    sim.set_material_scale(1.3, 0.8)
    rebuilt = Simulator(scaled(PAPER, 1.3, 0.8), o, source=src)
    for s in (sim, rebuilt):
        s.set_field(held_field(rod))
        s.step(100)
    assert np.max(np.abs(sim.data.qpos - rebuilt.data.qpos)) <= 1e-10 * PAPER.length
    np.testing.assert_allclose(sim.magnetic_couples(), rebuilt.magnetic_couples(), rtol=1e-9, atol=1e-15)


@pytest.mark.parametrize("bad", [0.05, 11.0, float("nan"), float("inf"), True, "2", None])
@pytest.mark.parametrize("name", ["modulus", "magnetization"])
def test_material_scale_is_validated(name, bad):
    sim = Simulator(AXIAL, RodOptions(segments=4))
    with pytest.raises(ValueError, match=rf"{name} must be a finite relative factor in \[0.1, 10\], got"):
        sim.set_material_scale(**{name: bad})
    assert sim.material_scale == (1.0, 1.0)


def test_a_backend_without_the_method_is_refused():
    sim = Simulator(AXIAL, RodOptions(segments=4))

    class Bare:  # the rod's interface without set_material_scale
        def __init__(self, inner):
            self._inner = inner

        def __getattr__(self, name):
            if name == "set_material_scale":
                raise AttributeError(name)
            return getattr(self._inner, name)

    sim.backend = Bare(sim.backend)
    with pytest.raises(ValueError, match="cannot scale its material in place"):
        sim.set_material_scale(1.5)


# ---------------------------------------------------------------------------------------------- the environments
FAST = {"segments": 6, "sim_dt": 2e-4}
RANGES = {"modulus_range": (0.5, 2.0), "magnetization_range": (0.8, 1.25)}


def make(env_id, **kw):
    import gymnasium as gym

    import magsoft_env  # noqa: F401  (registers the ids)

    return gym.make(env_id, **{**FAST, **kw})


@pytest.mark.parametrize("env_id", ["MagSoftCrawl-v1", "MagSoftSteer-v0"])
def test_the_env_draws_the_material_per_reset(env_id):
    env = make(env_id, **RANGES)
    draws = []
    for seed in (1, 2, 1):
        _, info = env.reset(seed=seed)
        draws.append((info["modulus_scale"], info["magnetization_scale"]))
        assert env.unwrapped.sim.material_scale == draws[-1]
        assert 0.5 <= draws[-1][0] <= 2.0 and 0.8 <= draws[-1][1] <= 1.25
    assert draws[0] != draws[1] and draws[0] == draws[2]
    one = make(env_id, modulus_range=(0.5, 2.0))
    _, info = one.reset(seed=1)
    assert "magnetization_scale" not in info and one.unwrapped.sim.material_scale[1] == 1.0


@pytest.mark.parametrize("env_id", ["MagSoftCrawl-v1", "MagSoftSteer-v0"])
def test_ranges_off_draw_and_run_as_a_scale_of_one(env_id):
    """Without the ranges nothing is drawn or reported; point ranges at 1 run the same episodes (the draws come
    last in reset, and a factor of 1 leaves the model as built)."""
    off = make(env_id)
    ones = make(env_id, modulus_range=(1.0, 1.0), magnetization_range=(1.0, 1.0))
    oa, ia = off.reset(seed=3)
    ob, ib = ones.reset(seed=3)
    assert "modulus_scale" not in ia and "magnetization_scale" not in ia
    assert ib["modulus_scale"] == 1.0 and ib["magnetization_scale"] == 1.0
    assert np.array_equal(oa, ob)
    assert bit_differences(off.unwrapped.sim.model, ones.unwrapped.sim.model) == []
    act = np.array([0.4, 0.7, 0.2][:off.action_space.shape[0]] + [0.0] * max(0, off.action_space.shape[0] - 3),
                   dtype=np.float32)
    for _ in range(3):
        oa, ra = off.step(act)[:2]
        ob, rb = ones.step(act)[:2]
    assert np.array_equal(oa, ob) and ra == rb


@pytest.mark.parametrize("env_id", ["MagSoftCrawl-v1", "MagSoftSteer-v0"])
def test_a_stiffer_elastomer_moves_differently(env_id):
    soft = make(env_id)
    stiff = make(env_id, modulus_range=(1.5, 1.5))
    soft.reset(seed=0)
    stiff.reset(seed=0)
    act = np.full(soft.action_space.shape, 0.8, dtype=np.float32)
    for _ in range(3):
        a = soft.step(act)[0]
        b = stiff.step(act)[0]
    assert not np.allclose(a, b)
    pa, pb = soft.unwrapped.sim.pose().centreline, stiff.unwrapped.sim.pose().centreline
    assert np.max(np.abs(pa - pb)) > 1e-7


def test_the_env_contact_follows_the_drawn_modulus():
    env = make("MagSoftCrawl-v1", modulus_range=(2.0, 2.0))
    ref = make("MagSoftCrawl-v1")
    env.reset(seed=0)
    ref.reset(seed=0)
    m, r = env.unwrapped.sim.model, ref.unwrapped.sim.model
    np.testing.assert_allclose(m.pair_solref[:, 0], r.pair_solref[:, 0] / np.sqrt(2.0), rtol=1e-12)
    np.testing.assert_allclose(m.jnt_stiffness, 2.0 * r.jnt_stiffness, rtol=1e-15)


@pytest.mark.parametrize("bad", [(0.05, 1.0), (2.0, 1.0), (1.0, 11.0), (1.0,), "ab", (float("nan"), 1.0),
                                 (True, 2.0), 1.5])
@pytest.mark.parametrize("name", ["modulus_range", "magnetization_range"])
def test_the_env_ranges_are_validated(name, bad):
    from magsoft_env.envs.crawl import MagSoftCrawlEnv
    from magsoft_env.envs.steer import MagSoftSteerEnv

    for cls in (MagSoftCrawlEnv, MagSoftSteerEnv):
        with pytest.raises(ValueError, match=rf"{name} must be None or \(low, high\), relative factors with "
                                             r"0.1 <= low <= high <= 10, got"):
            cls(**{name: bad})


def test_the_c_batch_passes_the_ranges_on():
    import gymnasium as gym

    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, vectorization_mode="vector_entry_point", **FAST, **RANGES)
    _, infos = envs.reset(seed=[5, 6])
    scales = infos["modulus_scale"]
    assert len(set(scales.tolist())) == 2 and all(0.5 <= s <= 2.0 for s in scales)
    assert [e.sim.material_scale[0] for e in envs.envs] == scales.tolist()
    envs.close()


def test_the_warp_batch_refuses_the_ranges_by_name():
    from magsoft_env.envs.warp_vector import MagSoftCrawlWarpVecEnv

    with pytest.raises(ValueError, match="does not randomize the material \\(modulus_range\\).*friction=\\[...\\]"):
        MagSoftCrawlWarpVecEnv(2, modulus_range=(0.5, 2.0))


@pytest.mark.parametrize("env_id", ["MagSoftCrawl-v1", "MagSoftSteer-v0"])
def test_check_env_passes_with_the_ranges(env_id):
    import warnings

    from gymnasium.utils.env_checker import check_env

    env = make(env_id, **RANGES)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    sb3 = pytest.importorskip("stable_baselines3.common.env_checker")
    env = make(env_id, **RANGES)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sb3.check_env(env.unwrapped, warn=True)


@pytest.mark.parametrize("env_id", ["MagSoftCrawlWaveform-v1", "MagSoftChannel-v1", "MagSoftObstacle-v1",
                                    "MagSoftCrawl-v2", "MagSoftSteerWaveform-v0", "MagSoftCoils-v0",
                                    "MagSoftMagnet-v0", "MagSoftCoilsWaveform-v0", "MagSoftMagnetWaveform-v0"])
def test_every_crawl_and_steering_id_takes_the_ranges(env_id):
    env = make(env_id, **RANGES)
    _, info = env.reset(seed=11)
    inner = env.unwrapped
    sim = getattr(inner, "source_env", inner).sim
    assert sim.material_scale == (info["modulus_scale"], info["magnetization_scale"]) != (1.0, 1.0)
    env.step(env.action_space.sample())


@pytest.mark.parametrize("env_id", ["MagSoftSteer-v0", "MagSoftCoils-v0"])
def test_the_steering_batches_pass_the_ranges_on(env_id):
    import gymnasium as gym

    envs = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **FAST, **RANGES)
    _, infos = envs.reset(seed=[5, 6])
    assert len(set(infos["magnetization_scale"].tolist())) == 2
    envs.close()

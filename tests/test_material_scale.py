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
]


def options(rod: str, scene: str) -> RodOptions:
    kw = {"contact_timeconst": "material"} if scene != "cantilever" else {}
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

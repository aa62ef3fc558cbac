"""The simulator's structure: one stepping engine, rods as backends behind one interface, one health monitor."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numpy as np
import pytest

import magsoft_env.sim.simulator as simulator_module
from magsoft_env.cases.gaits import gait_preset
from magsoft_env.sim import PlanarRod, RodBackend, RodOptions, Simulator, Sine, Square
from magsoft_env.sim.health import HealthMonitor

BEAM = gait_preset("paper-5c").beam


class _OnlyTheInterface:
    """A backend that answers only the members :class:`RodBackend` declares: a simulator that runs on it
    uses nothing else of the planar rod, so a second rod with the same members plugs in."""

    allowed = {name for name in dir(RodBackend) if not name.startswith("_")} | set(RodBackend.__annotations__)

    def __init__(self, inner):
        self._inner = inner

    def __getattr__(self, name):
        if name not in self.allowed:
            raise AttributeError(f"the simulator reached past the backend interface: {name!r}")
        return getattr(self._inner, name)


def _drive(sim: Simulator) -> list:
    out = []
    sim.set_field((0.0, 1.5e-3))
    sim.step(120)
    sim.set_waveform(Sine((1e-3, 2e-3), 4.0))
    sim.step(230)
    sim.set_waveform(Square((0.0, 2e-3), 8.0))
    for _ in sim.stepping(150, block=9):
        pass
    sim.external_wrench[2, 0] = 1e-6
    sim.step(40)
    x, z = sim.centerline()
    out += [sim.data.qpos.copy(), x, z, sim.angles(), sim.center_of_mass(), sim.tip_angle(), sim.tip_position(),
            sim.magnetic_couples(), sim.energies(), sim.health(), sim.static_residual()]
    return out


@pytest.mark.parametrize("scene", ["floor", "channel", "cantilever"])
def test_the_simulator_reaches_the_rod_only_through_the_backend_interface(scene, monkeypatch):
    opts = RodOptions(scene=scene, segments=12, timestep=2e-4)
    plain = _drive(Simulator(BEAM, opts))
    assert isinstance(Simulator(BEAM, opts).backend, RodBackend)
    def only_the_interface(name):
        def make(beam, o):
            return _OnlyTheInterface(PlanarRod(beam, o))

        make.check_beam, make.check_field = PlanarRod.check_beam, PlanarRod.check_field
        return make

    monkeypatch.setattr(simulator_module, "rod_class", only_the_interface)
    wrapped_sim = Simulator(BEAM, opts)
    assert isinstance(wrapped_sim.backend, _OnlyTheInterface)
    wrapped = _drive(wrapped_sim)
    for a, b in zip(plain, wrapped, strict=True):
        if isinstance(a, dict):
            assert a.keys() == b.keys()
            np.testing.assert_array_equal(np.array(list(a.values())), np.array(list(b.values())))
        else:
            np.testing.assert_array_equal(a, b)


def _calls(module, names):
    """``{Class.method: [called names]}`` of the calls of ``names`` in ``module``'s classes."""
    tree = ast.parse(Path(inspect.getsourcefile(module)).read_text())
    calls = {}
    for cls in (n for n in tree.body if isinstance(n, ast.ClassDef)):
        for fn in (n for n in cls.body if isinstance(n, ast.FunctionDef)):
            for node in ast.walk(fn):
                if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr in names:
                    calls.setdefault(f"{cls.name}.{fn.name}", []).append(node.func.attr)
    return calls


def test_a_step_happens_in_one_place():
    # the simulator cuts a call into blocks in one method and hands each to the backend; MuJoCo is stepped only
    # by the two ways of running a block (sim/stepping.py), by mj_step or by a rollout
    import magsoft_env.sim.cable as cable_module
    import magsoft_env.sim.planar as planar_module
    import magsoft_env.sim.stepping as stepping_module

    steps = ("mj_step", "mj_step1", "mj_step2", "rollout")
    assert _calls(simulator_module, steps) == {}
    assert _calls(simulator_module, ("advance",)) == {"Simulator._blocks": ["advance"]}
    assert _calls(stepping_module, steps) == {"NativeSteps.advance": ["mj_step"], "NativeSteps._roll": ["rollout"],
                                              "PythonSteps.advance": ["mj_step"]}
    assert _calls(planar_module, steps) == {} and _calls(cable_module, steps) == {}


def test_attributes_are_created_in_init_only():
    # every attribute of a Simulator and a HealthMonitor exists right after construction and no call adds one
    sim = Simulator(BEAM, RodOptions(scene="floor", segments=8, timestep=2e-4))
    before = set(vars(sim)), set(vars(sim._health)), set(vars(sim.backend))
    assert isinstance(sim._health, HealthMonitor)
    sim.set_waveform(Sine((1e-3, 2e-3), 4.0))
    sim.step(300)
    sim.set_field((0.0, 1e-3))
    sim.step(60)
    sim.settle(max_time=0.05)
    sim.centerline(), sim.energies(), sim.static_residual()
    sim.reset()
    assert (set(vars(sim)), set(vars(sim._health)), set(vars(sim.backend))) == before


def test_the_callers_options_are_never_rewritten():
    opts = RodOptions(scene="floor", segments=8)
    sim = Simulator(BEAM, opts)
    assert sim.options is opts
    with pytest.raises(TypeError):
        Simulator(BEAM, opts, torque_every=2)  # the held-couples shortcut is gone, not silently mapped

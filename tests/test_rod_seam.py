"""One seam for the rod: a third rod is one module and one registry line, and every consumer runs it unchanged.

The third rod is the planar chain under another name, built by composition (``rod_twin.ChainTwin``): it answers only
the :class:`~magsoft_env.sim.backend.RodBackend` interface, so each consumer that runs on it uses nothing else of
the chain; and its results equal the chain's bit for bit.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

from magsoft_env.cases.gaits import gait_preset
from magsoft_env.rods import ROD_BACKENDS, register_rod, rod_names
from magsoft_env.sim import RodOptions, Simulator, Sine, mujoco_equilibrium
from magsoft_env.sim.gait import run_gait

HERE = Path(__file__).parent
ROBOT = gait_preset("paper-5c")


@pytest.fixture
def twin():
    saved = dict(ROD_BACKENDS)
    register_rod("twin", "rod_twin:ChainTwin")  # the one registry line
    from rod_twin import ChainTwin

    ChainTwin.reached.clear()
    yield ChainTwin
    ROD_BACKENDS.clear()
    ROD_BACKENDS.update(saved)


def test_registry_names_and_refuses_unknown_rods(twin):
    assert "twin" in rod_names()
    assert RodOptions(rod="twin").rod == "twin"
    with pytest.raises(ValueError, match="Did you mean 'twin'"):
        RodOptions(rod="twim")
    with pytest.raises(ValueError, match="module:Class"):
        register_rod("bad", "no_colon")


def test_simulator_runs_the_twin_as_the_chain(twin):
    out = {}
    for rod in ("planar", "twin"):
        sim = Simulator(ROBOT.beam, RodOptions(rod=rod, scene="floor", segments=10, timestep=2e-4))
        sim.set_field((0.0, 1.5e-3))
        sim.step(120)
        sim.set_waveform(Sine((1e-3, 2e-3), 4.0))
        sim.step(230)
        out[rod] = (sim.data.qpos.copy(), sim.data.qvel.copy(), sim.pose().centreline, sim.health())
    np.testing.assert_array_equal(out["planar"][0], out["twin"][0])
    np.testing.assert_array_equal(out["planar"][1], out["twin"][1])
    np.testing.assert_array_equal(out["planar"][2], out["twin"][2])
    assert out["planar"][3] == out["twin"][3]
    assert {"advance", "write_field", "pose"} <= twin.reached


def test_gait_and_statics_run_the_twin(twin):
    a = run_gait("paper-5c", seconds=0.3)
    b = run_gait("paper-5c", seconds=0.3, rod="twin")
    assert b.rod == "twin" and b.success
    np.testing.assert_array_equal(a.com_x, b.com_x)
    assert a.max_link_rotation == b.max_link_rotation and a.final_orientation == b.final_orientation
    e1 = mujoco_equilibrium(ROBOT.beam, (0.0, 3e-3), segments=8)
    e2 = mujoco_equilibrium(ROBOT.beam, (0.0, 3e-3), segments=8, rod="twin")
    assert e2.success and e2.stable and e2.rod == "twin"
    np.testing.assert_array_equal(e1.centreline, e2.centreline)


def test_env_runs_the_twin(twin):
    rewards = {}
    for rod in ("planar", "twin"):
        env = gym.make("MagSoftCrawl-v1", rod=rod, fidelity="fast")
        obs, _ = env.reset(seed=4)
        rng = np.random.default_rng(0)
        rs = []
        for _ in range(4):
            obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            rs.append(r)
        rewards[rod] = (rs, obs)
        env.close()
    assert rewards["planar"][0] == rewards["twin"][0]
    np.testing.assert_array_equal(rewards["planar"][1], rewards["twin"][1])


def test_render_gait_runs_the_twin(twin):
    from magsoft_env.gl import RenderBackendError
    from magsoft_env.render.video import render_gait

    try:
        frames, summary = render_gait(ROBOT, 0.04, fps=50, width=160, height=96, rod="twin")
    except RenderBackendError as err:
        pytest.skip(f"no headless OpenGL here: {str(err).splitlines()[0]}")
    assert summary["rod"] == "twin" and summary["view"] == "side" and len(frames) == 3


def test_the_command_line_runs_the_twin(tmp_path):
    # a fresh process: the registry line, then `magsoft gait --rod twin` as a user would run it
    out_file = str(tmp_path / "g.json")
    code = (f"import sys; sys.path.insert(0, {str(HERE)!r}); from magsoft_env.rods import register_rod; "
            "register_rod('twin', 'rod_twin:ChainTwin'); from magsoft_env.cli import main; "
            "raise SystemExit(main(['gait', '--preset', 'paper-5c', '--rod', 'twin', '--seconds', '0.2', "
            f"'--json', '--out', {out_file!r}]))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    out = json.loads((tmp_path / "g.json").read_text())
    assert out["rod"] == "twin" and out["success"]


#: Names that decide the rod: its kind, the per-step flag, the flags derived from them, the backend classes.
_KINDS = {"cable", "planar", "strip", "chain"}
_FLAGS = {"per_step", "_per_step", "three", "ps", "is_3d", "is_cable", "is_planar", "planar", "three_d",
          "PlanarRod", "CableRod"}
#: The rods' own files (the backends and what only they use) and the analytical side (its planar/3D model choice
#: is not a rod kind).
_OWN = ("planar.py", "cable", "strip", "chain")


def _rod_branches(root: Path) -> dict[str, list[int]]:
    """Every if, while, conditional expression and comprehension filter outside the rods' own files whose test names
    a rod kind, a rod flag or a backend class, or compares a ``rod`` with any string (stricter than the shared
    counter, which misses ``rod == name`` for a name it does not know)."""
    import ast

    found: dict[str, list[int]] = {}
    for path in sorted(root.rglob("*.py")):
        if path.parent.name in ("theory", "spec") or any(k in path.name for k in _OWN):
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.If, ast.IfExp, ast.While)):
                test = node.test
            elif isinstance(node, ast.comprehension) and node.ifs:
                test = ast.BoolOp(op=ast.And(), values=node.ifs)
            else:
                continue
            names = {n.id for n in ast.walk(test) if isinstance(n, ast.Name)}
            names |= {n.attr for n in ast.walk(test) if isinstance(n, ast.Attribute)}
            consts = {n.value for n in ast.walk(test) if isinstance(n, ast.Constant) and isinstance(n.value, str)}
            by_name = any(isinstance(c, ast.Compare) and any(
                isinstance(x, ast.Constant) and isinstance(x.value, str) for x in c.comparators + [c.left])
                and {getattr(x, "id", getattr(x, "attr", None)) for x in c.comparators + [c.left]} & {"rod"}
                for c in ast.walk(test))
            if consts & _KINDS or names & _FLAGS or by_name:
                found.setdefault(str(path.relative_to(root.parent)), []).append(getattr(node, "lineno", 0))
    return found


def test_rod_kind_branches_stay_few():
    # a third rod must not mean finding forks: at most 10 tests of the rod outside the rods' own files
    found = _rod_branches(HERE.parent / "magsoft_env")
    assert sum(map(len, found.values())) <= 10, found

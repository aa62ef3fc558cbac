"""Every ``>>>`` example in the package runs and prints what its docstring says.

The modules are found by walking the package, so a new module's examples are run without
listing it here. An example that genuinely needs a GPU, a display or a long run says
``# doctest: +SKIP`` in its own line; none is skipped here. A module whose examples run the MuJoCo Warp backend
(``backend="warp"``) runs them under the ``slow`` marker: on a fresh machine, with Warp's kernel cache empty,
they compile the solver's kernels first (about half a minute of CPU on Warp's CPU device).
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import re
from pathlib import Path

import pytest

import magsoft_env

PACKAGE = Path(magsoft_env.__file__).parent
#: Third-party packages a module may need that the test environment may lack (its examples are skipped then).
OPTIONAL = {"torch", "stable_baselines3", "rl_zoo3", "sb3_contrib", "tensorboard", "warp", "mujoco_warp"}


def _source(name: str) -> str:
    rel = name.split(".")[1:]
    path = PACKAGE.joinpath(*rel).with_suffix(".py") if rel else PACKAGE / "__init__.py"
    if not path.is_file():
        path = PACKAGE.joinpath(*rel, "__init__.py")
    return path.read_text(encoding="utf-8")


def _modules_with_examples() -> list[str]:
    names = ["magsoft_env"] + [m.name for m in pkgutil.walk_packages([str(PACKAGE)], prefix="magsoft_env.")]
    return sorted(name for name in names if ">>>" in _source(name))


def _builds_warp_kernels(name: str) -> bool:
    """Whether the module's examples ask for the Warp backend (an example line with ``backend="warp"``)."""
    return bool(re.search(r"^\s*(>>>|\.\.\.) .*backend=[\"']warp[\"']", _source(name), re.M))


MODULES = _modules_with_examples()
WARP_MODULES = {name for name in MODULES if _builds_warp_kernels(name)}


def test_examples_are_found():
    # the simulator, the vector env, the specification and the solver are among them
    for name in ("magsoft_env.sim.simulator", "magsoft_env.envs.vector", "magsoft_env.spec.beam",
                 "magsoft_env.theory.solver", "magsoft_env.sim.gait", "magsoft_env.design.optimize"):
        assert name in MODULES, name


def test_warp_examples_are_found():
    assert "magsoft_env.envs.warp_vector" in WARP_MODULES


# under pytest-xdist (--dist loadgroup) the Warp examples run on the worker that runs tests/test_warp.py
WARP_MARKS = [pytest.mark.slow, pytest.mark.xdist_group("warp")]


@pytest.mark.parametrize("name", [pytest.param(name, marks=WARP_MARKS) if name in WARP_MODULES else name
                                  for name in MODULES])
def test_docstring_examples(name):
    try:
        module = importlib.import_module(name)
    except ImportError as exc:
        if exc.name and exc.name.split(".")[0] in OPTIONAL:
            pytest.skip(f"{name} needs {exc.name}")
        raise
    result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.failed == 0
    assert result.attempted > 0

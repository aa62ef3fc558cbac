"""Every ``>>>`` example in the package runs and prints what its docstring says.

The modules are found by walking the package, so a new module's examples are run without
listing it here. An example that genuinely needs a GPU, a display or a long run says
``# doctest: +SKIP`` in its own line; none is skipped here.
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
from pathlib import Path

import pytest

import magsoft_env

PACKAGE = Path(magsoft_env.__file__).parent
#: Third-party packages a module may need that the test environment may lack (its examples are skipped then).
OPTIONAL = {"torch", "stable_baselines3", "rl_zoo3", "sb3_contrib", "tensorboard", "warp", "mujoco_warp"}


def _modules_with_examples() -> list[str]:
    names = ["magsoft_env"] + [m.name for m in pkgutil.walk_packages([str(PACKAGE)], prefix="magsoft_env.")]
    out = []
    for name in names:
        rel = name.split(".")[1:]
        path = PACKAGE.joinpath(*rel).with_suffix(".py") if rel else PACKAGE / "__init__.py"
        if not path.is_file():
            path = PACKAGE.joinpath(*rel, "__init__.py")
        if ">>>" in path.read_text(encoding="utf-8"):
            out.append(name)
    return sorted(out)


MODULES = _modules_with_examples()


def test_examples_are_found():
    # the simulator, the vector env, the specification and the solver are among them
    for name in ("magsoft_env.sim.simulator", "magsoft_env.envs.vector", "magsoft_env.spec.beam",
                 "magsoft_env.theory.solver", "magsoft_env.sim.gait", "magsoft_env.design.optimize"):
        assert name in MODULES, name


@pytest.mark.parametrize("name", MODULES)
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

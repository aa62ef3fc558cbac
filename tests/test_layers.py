"""Layering of the package, checked statically from the sources (every import statement, lazy ones too).

Each module belongs to one unit: the facade (``magsoft_env/__init__.py``), the root leaf utilities
(``units``, ``io``, ``threads``, ``gl``, ``validate``, ``assets``, ``rods``), or a layer package.
``ALLOWED`` lists the units each may import; a new upward import, an import of the facade from
inside a layer, a private name (``_x``) imported from another unit, a heavy third-party package in
a layer that must not load it, or a module in no known unit fails the test.
"""

from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

import magsoft_env

PACKAGE = Path(magsoft_env.__file__).parent
LEAVES = {"units", "io", "threads", "gl", "validate", "assets", "rods"}

# unit -> units it may import (itself always)
ALLOWED = {
    "leaf": set(),
    "spec": {"leaf"},
    "cases": {"spec", "leaf"},
    "theory": {"fields", "spec", "leaf"},
    "fields": {"spec", "leaf"},
    "design": {"theory", "fields", "spec", "leaf"},
    "sim": {"cases", "fields", "spec", "leaf"},
    "compare": {"sim", "design", "theory", "cases", "fields", "spec", "leaf"},
    "render": {"sim", "design", "theory", "cases", "fields", "spec", "leaf"},
    "envs": {"render", "sim", "theory", "cases", "fields", "spec", "leaf"},
    "rl": {"envs", "cases", "fields", "spec", "leaf"},
    "parallel": {"rl", "envs", "compare", "sim", "design", "theory", "cases", "fields", "spec", "leaf"},
    "cli": {"parallel", "rl", "envs", "render", "compare", "sim", "design", "theory", "fields", "cases", "spec",
            "leaf", "facade"},
    "bench": {"parallel", "rl", "envs", "render", "compare", "sim", "design", "theory", "fields", "cases", "spec",
              "leaf", "facade"},
    "facade": {"spec", "leaf"},  # the rest is reached lazily by name (importlib), never imported at import time
}
# third-party packages a unit may import; all others may import none of these
HEAVY = {"mujoco", "gymnasium", "torch", "stable_baselines3", "rl_zoo3", "matplotlib", "imageio", "ray", "warp",
         "mujoco_warp"}
HEAVY_ALLOWED = {
    "sim": {"mujoco", "warp", "mujoco_warp"},  # warp: the optional extra, in sim/warp_extra.py only (lazily)
    "compare": {"mujoco"},
    "render": {"mujoco", "matplotlib", "imageio", "gymnasium"},
    "envs": {"mujoco", "gymnasium"},
    "rl": {"gymnasium", "torch", "stable_baselines3", "rl_zoo3", "matplotlib"},
    "parallel": {"gymnasium", "matplotlib", "ray"},
    "cli": {"gymnasium"},
    "bench": {"mujoco", "gymnasium", "torch", "stable_baselines3"},
    "leaf": {"mujoco"},  # gl: binds mujoco's offscreen context class, lazily
}


def unit_of(module: str) -> str | None:
    parts = module.split(".")
    if parts == ["magsoft_env"]:
        return "facade"
    if parts[0] != "magsoft_env":
        return None
    if parts[1] in LEAVES:
        return "leaf"
    return parts[1] if parts[1] in ALLOWED else None


def module_name(path: Path, root: Path = PACKAGE) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


@functools.cache
def _import_nodes(source: str) -> tuple:
    """The import statements of a source text (parsed once: the package copies below share their sources)."""
    return tuple(node for node in ast.walk(ast.parse(source)) if isinstance(node, (ast.Import, ast.ImportFrom)))


def imports(path: Path, root: Path = PACKAGE):
    """(line, imported module, imported names) for every import in ``path``, relative ones resolved."""
    mod = module_name(path, root)
    pkg = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    for node in _import_nodes(path.read_text(encoding="utf-8")):
        if isinstance(node, ast.Import):
            for a in node.names:
                yield node.lineno, a.name, []
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg.split(".")
                base = base[: len(base) - (node.level - 1)]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = [a.name for a in node.names]
            if target.startswith("magsoft_env"):
                # "from magsoft_env.sim import gait" imports a module: check it as such
                stem = [root.parent / f"{target}.{n}".replace(".", "/") for n in names]
                sub = [f"{target}.{n}" for n, st in zip(names, stem, strict=True)
                       if st.is_dir() or st.with_suffix(".py").exists()]
                for s in sub:
                    yield node.lineno, s, []
                names = [n for n in names if f"{target}.{n}" not in sub]
                if sub and not names:
                    continue
            yield node.lineno, target, names


def violations(root: Path = PACKAGE) -> list[str]:
    out = []
    for path in sorted(root.rglob("*.py")):
        mod = module_name(path, root)
        unit = unit_of(mod)
        if unit is None:
            out.append(f"{mod}: in no known unit (add its package to ALLOWED in tests/test_layers.py)")
            continue
        for line, target, names in imports(path, root):
            top = target.split(".")[0]
            where = f"{path.relative_to(root.parent)}:{line}"
            if top == "magsoft_env":
                tu = unit_of(target)
                if tu is None:
                    out.append(f"{where}: imports {target}, which is in no known unit")
                elif tu != unit and tu not in ALLOWED[unit]:
                    out.append(f"{where}: {unit} imports {target} ({tu}), not allowed for {unit}")
                if tu != unit and unit != "facade":
                    private = [p for p in target.split(".")[1:] if p.startswith("_") and not p.startswith("__")]
                    private += [n for n in names if n.startswith("_") and not n.startswith("__")]
                    if private:
                        out.append(f"{where}: private name(s) {private} of {target} imported across units")
            elif top in HEAVY and top not in HEAVY_ALLOWED.get(unit, set()):
                out.append(f"{where}: {unit} imports {top}")
    return out


def test_every_module_is_in_its_layer():
    assert violations() == []


def test_root_holds_only_the_facade_and_leaf_utilities():
    root_modules = {p.stem for p in PACKAGE.glob("*.py")} - {"__init__"}
    assert root_modules == LEAVES
    for stem in LEAVES:
        for _, target, _ in imports(PACKAGE / f"{stem}.py"):
            assert not target.startswith("magsoft_env"), (stem, target)


@pytest.mark.parametrize(
    "package, source, expected",
    [
        ("spec", "from ..sim import Simulator\n", "spec imports magsoft_env.sim (sim)"),
        ("theory", "def f():\n    from ..envs.crawl import MagSoftCrawlEnv\n", "theory imports magsoft_env.envs.crawl"),
        ("sim", "from ..compare import crosscheck\n", "sim imports magsoft_env.compare.crosscheck (compare)"),
        ("design", "import magsoft_env\n", "design imports magsoft_env (facade)"),
        ("design", "from ..theory.solver import _model\n", "private name(s) ['_model']"),
        ("envs", "from ..spec import _validate\n", "private name(s) ['_validate']"),
        ("cases", "import mujoco\n", "cases imports mujoco"),
    ],
)
def test_an_upward_import_fails(tmp_path, package, source, expected):
    # a copy of the package with one bad import added is rejected, naming the edge
    import shutil

    copy = tmp_path / "magsoft_env"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__", "_assets"))
    assert violations(copy) == []
    (copy / package / "bad.py").write_text(source)
    found = violations(copy)
    assert len(found) == 1 and f"{package}/bad.py:" in found[0] and expected in found[0], found


def test_old_module_paths_are_gone():
    """The 0.3 module paths (the ``_moved`` import shim) are removed: nothing in the repository needs them."""
    import importlib.util
    import sys

    assert not (PACKAGE / "_moved.py").exists()
    assert not any(type(f).__module__ == "magsoft_env._moved" for f in sys.meta_path)
    for old in ("magsoft_env.presets", "magsoft_env.gaits", "magsoft_env.plotting", "magsoft_env.render.backend"):
        assert importlib.util.find_spec(old) is None, old

"""Old module paths of version 0.3, kept importable for one release with a DeprecationWarning.

Version 0.4 gave every module one layer (see docs/layout.md). ``import magsoft_env.gaits``
and ``from magsoft_env.presets import load_preset`` still work: a finder on ``sys.meta_path``
answers for the old names only (after the normal finders found nothing) with a module whose
attributes are looked up, on first use, in the modules that now hold them. Nothing here
imports a layer at import time.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import types
import warnings

#: old module -> the modules that now hold its public names, searched in order
MOVED = {
    "magsoft_env.presets": ("magsoft_env.cases.statics", "magsoft_env.cases.expressions"),
    "magsoft_env.gaits": ("magsoft_env.cases.gaits", "magsoft_env.sim.gait", "magsoft_env.spec.drive"),
    "magsoft_env._signals": ("magsoft_env.spec.drive",),
    "magsoft_env.plotting": ("magsoft_env.render.figures",),
    "magsoft_env.spec._validate": ("magsoft_env.validate",),
    "magsoft_env.design._blas": ("magsoft_env.threads",),
    "magsoft_env.design.check": ("magsoft_env.compare.design_check",),
    "magsoft_env.design.grasp": ("magsoft_env.compare.grasp",),
    "magsoft_env.design.output": ("magsoft_env.design.svg", "magsoft_env.render.design"),
    "magsoft_env.sim.crosscheck": ("magsoft_env.compare.crosscheck",),
    "magsoft_env.render.backend": ("magsoft_env.gl",),
}


class _MovedModule(types.ModuleType):
    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        for target in MOVED[self.__name__]:
            mod = importlib.import_module(target)
            if hasattr(mod, name):
                value = getattr(mod, name)
                setattr(self, name, value)
                return value
        raise AttributeError(
            f"module {self.__name__!r} was split in version 0.4 and {name!r} is not in "
            f"{', '.join(MOVED[self.__name__])}; see docs/layout.md."
        )

    def __dir__(self):
        names = set()
        for target in MOVED[self.__name__]:
            names |= set(getattr(importlib.import_module(target), "__all__", ()))
        return sorted(names)


class _Loader(importlib.abc.Loader):
    def create_module(self, spec):
        return _MovedModule(spec.name)

    def exec_module(self, module):
        module.__doc__ = f"Moved in version 0.4 to {', '.join(MOVED[module.__name__])}."
        warnings.warn(
            f"{module.__name__} moved in magsoft_env 0.4: import from {' / '.join(MOVED[module.__name__])} "
            "(or from magsoft_env itself) instead; the old path goes in 0.5.",
            DeprecationWarning, stacklevel=2,
        )


class _Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, fullname, path=None, target=None):
        if fullname in MOVED:
            return importlib.machinery.ModuleSpec(fullname, _Loader())
        return None


def install() -> None:
    """Put the finder last on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.append(_Finder())

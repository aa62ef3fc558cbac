"""The registry of rod backends by name, importable without MuJoCo (the command line checks ``--rod`` before a GL
backend is chosen): ``RodOptions.rod`` names one of these; :mod:`magsoft_env.sim.backend` builds it."""

from __future__ import annotations

#: name -> ``"module:Class"`` of every rod backend: the planar hinge chain and the 3D flexcomp strip.
ROD_BACKENDS: dict[str, str] = {
    "planar": "magsoft_env.sim.planar:PlanarRod",
    "cable": "magsoft_env.sim.cable:CableRod",
}
#: The rod a caller gets without asking.
DEFAULT_ROD = "planar"


def register_rod(name: str, entry: str) -> None:
    """Register a rod backend: ``RodOptions(rod=name)``, ``run_gait(rod=name)``, ``magsoft gait --rod name`` and
    every other consumer build ``entry`` (``"module:Class"``, a :class:`~magsoft_env.sim.backend.RodBackend`)."""
    if not isinstance(name, str) or not name.isidentifier():
        raise ValueError(f"a rod's name must be an identifier, got {name!r}.")
    if not isinstance(entry, str) or entry.count(":") != 1 or not all(entry.split(":")):
        raise ValueError(f"entry must be 'module:Class', got {entry!r}.")
    ROD_BACKENDS[name] = entry


def rod_names() -> tuple[str, ...]:
    """The registered rods' names."""
    return tuple(ROD_BACKENDS)


def check_rod(name, what: str = "rod") -> str:
    """``name`` if a rod is registered under it, else a ValueError naming the registered ones."""
    if not isinstance(name, str) or name not in ROD_BACKENDS:
        import difflib

        hint = difflib.get_close_matches(str(name), list(ROD_BACKENDS), n=1)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ValueError(f"{what} must be one of {list(ROD_BACKENDS)}, got {name!r}.{extra}")
    return name


__all__ = ["DEFAULT_ROD", "ROD_BACKENDS", "check_rod", "register_rod", "rod_names"]

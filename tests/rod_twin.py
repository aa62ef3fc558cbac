"""A third rod for the tests: the planar hinge chain under another name, built by composition.

:class:`ChainTwin` holds a :class:`~magsoft_env.sim.planar.PlanarRod` and lets through only the members that
:class:`~magsoft_env.sim.backend.RodBackend` declares: a consumer that runs on it (the simulator, the gaits, the
statics, the renderers, the environments, the command line) uses nothing of the chain but the interface. Registered
with one line, ``register_rod("twin", "rod_twin:ChainTwin")``.
"""

from __future__ import annotations

from magsoft_env.sim.backend import RodBackend
from magsoft_env.sim.planar import PlanarRod

#: The members a consumer may use: the interface's, and the chain builder's mark (``build_model`` builds it).
ALLOWED = {n for n in dir(RodBackend) if not n.startswith("_")} | set(RodBackend.__annotations__) | {"builds_chain"}


class ChainTwin:
    """The planar chain, answering only the :class:`RodBackend` interface (see the module docstring)."""

    name = "twin"
    label = "the chain's twin"
    field_axes = PlanarRod.field_axes
    scenes = PlanarRod.scenes
    views = PlanarRod.views
    static_timestep = PlanarRod.static_timestep
    static_tol = PlanarRod.static_tol
    builds_chain = True
    check_options = PlanarRod.check_options
    check_beam = PlanarRod.check_beam
    check_field = staticmethod(PlanarRod.check_field)
    check_fields = staticmethod(PlanarRod.check_fields)
    gait_options = PlanarRod.gait_options
    #: members reached on the wrapped chain (for the test's record)
    reached: set = set()

    def __init__(self, beam, options):
        object.__setattr__(self, "_inner", PlanarRod(beam, options))

    def __getattr__(self, name):
        if name not in ALLOWED:
            raise AttributeError(f"a consumer reached past the rod interface: {name!r}")
        ChainTwin.reached.add(name)
        return getattr(self._inner, name)


__all__ = ["ALLOWED", "ChainTwin"]

"""The frames of a rod in each view: the side view of a rod in the x-z plane, the 3D views of any rod.

:func:`make_renderer` is what videos and environments call: it draws a simulator's rod in the view asked for, or
in the rod's own default (its backend's ``views``, the first one: the side view for the planar chain, perspective
for the 3D strip), so that no caller decides by the rod's kind.
"""

from __future__ import annotations

#: Every view: the orthographic side view (x right, z up) and the 3D views.
VIEWS = ("side", "perspective", "top")


def views_of(sim) -> tuple[str, ...]:
    """The views a simulator's rod can be drawn in, its default first."""
    return tuple(getattr(sim.backend, "views", ("side",)))


def make_renderer(sim, *, view: str | None = None, **kwargs):
    """A renderer of ``sim`` in ``view`` (None: the rod's default): :class:`~magsoft_env.render.frames.RodRenderer`
    for ``"side"``, :class:`~magsoft_env.render.strip.StripRenderer` for ``"perspective"`` and ``"top"``.
    ``kwargs`` go to the renderer (a side view's ``zoom`` is refused by the 3D views when true, ignored when
    None or False)."""
    allowed = views_of(sim)
    view = allowed[0] if view is None else view
    if view not in allowed:
        raise ValueError(f"view must be one of {list(allowed)} for this rod ({sim.backend.label}), got {view!r}.")
    if view == "side":
        from .frames import RodRenderer

        kwargs.pop("view", None)
        return RodRenderer(sim, **kwargs)
    from .strip import StripRenderer

    kwargs.pop("zoom_span", None)
    return StripRenderer(sim, view=view, **kwargs)


__all__ = ["VIEWS", "make_renderer", "views_of"]

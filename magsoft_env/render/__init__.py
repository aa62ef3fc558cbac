"""Offscreen frames and videos of the rod: side camera, mm grid and scale bar, field dial, path, overlays.

The headless OpenGL backend (EGL, then OSMesa) is chosen by :mod:`magsoft_env.gl`: programs that
know they will render call :func:`~magsoft_env.gl.select_gl_backend` before mujoco is imported;
:class:`RodRenderer` binds one late otherwise. Figures (matplotlib) are :mod:`.figures`;
a design written to files is :func:`magsoft_env.render.design.write_design`; a field source's map is
:func:`plot_source` (:mod:`.fields`). One palette
(:data:`.figures.PALETTE`) colours the figures and the frames. Importing this package does not
import mujoco: :class:`RodRenderer`, :class:`StripRenderer`, :func:`make_renderer` (the renderer of a rod in a
view), :class:`TimePanel` and :func:`write_video` load lazily.
What a frame shows: docs/rendering.md.
"""

from __future__ import annotations

import importlib

from ..gl import GL_BACKENDS, RenderBackendError, preselect_gl_backend, select_gl_backend

_LAZY = {"RodRenderer": "magsoft_env.render.frames", "TimePanel": "magsoft_env.render.frames",
         "StripRenderer": "magsoft_env.render.strip", "make_renderer": "magsoft_env.render.views",
         "write_video": "magsoft_env.render.video", "render_gait": "magsoft_env.render.video",
         "render_policy": "magsoft_env.render.video", "PALETTE": "magsoft_env.render.figures",
         "plot_source": "magsoft_env.render.fields"}


def __getattr__(name):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'magsoft_env.render' has no attribute {name!r}")
    return getattr(importlib.import_module(mod), name)


__all__ = ["GL_BACKENDS", "PALETTE", "RenderBackendError", "RodRenderer", "StripRenderer", "TimePanel",
           "make_renderer", "plot_source", "preselect_gl_backend", "render_gait", "render_policy", "select_gl_backend",
           "write_video"]

"""Offscreen frames and videos of the rod: side camera, mm grid, field arrow, analytical overlay.

The OpenGL backend must be chosen before mujoco is imported (mujoco reads ``MUJOCO_GL`` once,
at import). :func:`select_gl_backend` does that (``egl``, then ``osmesa``); the Gymnasium
environments call :func:`preselect_gl_backend` before importing mujoco. Importing this
package does not import mujoco: :class:`RodRenderer` and :func:`write_video` load lazily.
"""

from __future__ import annotations

import importlib

from .backend import GL_BACKENDS, RenderBackendError, preselect_gl_backend, select_gl_backend

_LAZY = {"RodRenderer": "magsoft_env.render.frames", "write_video": "magsoft_env.render.video",
         "render_gait": "magsoft_env.render.video", "render_policy": "magsoft_env.render.video"}


def __getattr__(name):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'magsoft_env.render' has no attribute {name!r}")
    return getattr(importlib.import_module(mod), name)


__all__ = ["GL_BACKENDS", "RenderBackendError", "RodRenderer", "preselect_gl_backend", "render_gait",
           "render_policy", "select_gl_backend", "write_video"]

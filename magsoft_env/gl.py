"""MuJoCo's headless OpenGL backend (EGL, then OSMesa): chosen before mujoco is imported where a
program knows it will render, or bound late where rendering starts (imports nothing from the package).

mujoco reads ``MUJOCO_GL`` once, when it is first imported, and binds its offscreen context
class then. Programs that render (``magsoft video``, ``train/record.py``) call
:func:`select_gl_backend` first, which probes EGL and OSMesa in subprocesses. Where mujoco was
imported with ``MUJOCO_GL`` unset (a Gymnasium env made with ``render_mode="rgb_array"``, which
imports the simulator first), it bound GLFW, which needs a display: :func:`bind_headless_context`,
called by :class:`~magsoft_env.render.RodRenderer` before it opens a context, then switches this
process to EGL or OSMesa. Importing the package or the simulator chooses nothing, so a program that
never renders never loads OpenGL.

``MUJOCO_GL=egl`` or ``osmesa`` set without that library installed makes ``import mujoco`` itself fail, with a
long PyOpenGL traceback: :func:`missing_gl_library` (called by ``magsoft`` before any command runs and by
:func:`select_gl_backend`) turns that into one line naming the package to install.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import importlib
import os
import subprocess
import sys

#: Backends tried in order, with the Debian packages each needs.
GL_BACKENDS = ("egl", "osmesa")
GL_PACKAGES = {"egl": "libegl1 and libgl1-mesa-dri", "osmesa": "libosmesa6"}
_LIBRARIES = {"egl": "EGL", "osmesa": "OSMesa"}
_PROBE = (
    "import mujoco; c = mujoco.GLContext(16, 16); c.make_current(); c.free()"
)


class RenderBackendError(RuntimeError):
    """No headless OpenGL backend could start; the message names the packages to install."""


class GLLibraryMissing(RenderBackendError):
    """``MUJOCO_GL`` names a backend whose library is not installed (mujoco cannot even be imported)."""


def _library_loads(name: str) -> bool:
    """Whether ``lib<name>.so`` loads, tried as PyOpenGL tries it (``.so``, then ``.so.9`` down to ``.so.0``)."""
    base = f"lib{name}.so"
    for filename in (base, *(f"{base}.{i}" for i in range(9, -1, -1))):
        try:
            ctypes.CDLL(filename, mode=ctypes.RTLD_GLOBAL)
        except OSError:
            continue
        return True
    return False


def missing_gl_library() -> str:
    """A one-line message if ``MUJOCO_GL`` is ``egl`` or ``osmesa`` and that library does not load, else ``""``.

    mujoco loads the library when it is imported and fails there with a long PyOpenGL traceback
    (``'NoneType' object has no attribute 'glGetError'``), so programs check this before importing it.
    Cheap: one ``dlopen``, no context."""
    backend = os.environ.get("MUJOCO_GL", "").strip().lower()
    if backend not in _LIBRARIES or _library_loads(_LIBRARIES[backend]):
        return ""
    other = "osmesa" if backend == "egl" else "egl"
    return (f"MUJOCO_GL={backend} but the {_LIBRARIES[backend]} library (lib{_LIBRARIES[backend]}.so) is not "
            f"installed: install it (Debian/Ubuntu: apt-get install {GL_PACKAGES[backend]}), or set "
            f"MUJOCO_GL={other} or unset MUJOCO_GL.")


def check_gl_library() -> None:
    """Raise :class:`GLLibraryMissing` (one line naming the package to install) if :func:`missing_gl_library`
    finds the library of ``MUJOCO_GL`` missing; call it before importing mujoco."""
    msg = missing_gl_library()
    if msg:
        raise GLLibraryMissing(msg)


def _message(errors: dict[str, str]) -> str:
    lines = [f"  MUJOCO_GL={b}: {errors[b]}" for b in errors]
    return (
        "MuJoCo could not start a headless OpenGL context.\n" + "\n".join(lines) + "\n"
        f"Install EGL (Debian/Ubuntu: apt-get install {GL_PACKAGES['egl']}) or OSMesa "
        f"(apt-get install {GL_PACKAGES['osmesa']}), then retry; or set MUJOCO_GL yourself "
        "(e.g. MUJOCO_GL=glfw with a display) before Python starts."
    )


def preselect_gl_backend() -> str:
    """Set ``MUJOCO_GL`` (and ``PYOPENGL_PLATFORM``) to a headless backend whose library exists,
    unless the user chose one or mujoco is already imported. Cheap: no context is created.

    Returns the backend now in ``MUJOCO_GL`` (``""`` if none).
    """
    if os.environ.get("MUJOCO_GL") or "mujoco" in sys.modules:
        return os.environ.get("MUJOCO_GL", "")
    for b in GL_BACKENDS:
        if ctypes.util.find_library(_LIBRARIES[b]):
            os.environ["MUJOCO_GL"] = b
            os.environ.setdefault("PYOPENGL_PLATFORM", b)
            return b
    return ""


def probe_gl_backend(backend: str, *, timeout: float = 60.0) -> str:
    """Try to create a MuJoCo GL context with ``backend`` in a subprocess; ``""`` on success,
    else the error text."""
    env = {**os.environ, "MUJOCO_GL": backend, "PYOPENGL_PLATFORM": backend}
    try:
        r = subprocess.run([sys.executable, "-c", _PROBE], env=env, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return f"timed out after {timeout:g} s"
    if r.returncode == 0:
        return ""
    tail = (r.stderr or r.stdout).strip().splitlines()
    return tail[-1] if tail else f"exit status {r.returncode}"


def select_gl_backend() -> str:
    """Pick a working headless backend before mujoco is imported: ``MUJOCO_GL`` if set,
    else ``egl``, else ``osmesa`` (each probed in a subprocess).

    Returns
    -------
    str
        The backend now in ``MUJOCO_GL``.

    Raises
    ------
    RenderBackendError
        When neither starts, or ``MUJOCO_GL`` names one whose library is missing
        (:class:`GLLibraryMissing`); the message names the Debian packages (``libegl1`` /
        ``libgl1-mesa-dri`` for EGL, ``libosmesa6`` for OSMesa).
    """
    chosen = os.environ.get("MUJOCO_GL", "")
    if chosen:
        check_gl_library()
        return chosen
    if "mujoco" in sys.modules:
        # too late to choose for this process: mujoco took its default at import
        return ""
    errors = {}
    for b in GL_BACKENDS:
        err = probe_gl_backend(b)
        if not err:
            os.environ["MUJOCO_GL"] = b
            os.environ.setdefault("PYOPENGL_PLATFORM", b)
            return b
        errors[b] = err
    raise RenderBackendError(_message(errors))


def _bound_backend() -> str:
    """The backend mujoco's offscreen context class belongs to (``"egl"``, ``"osmesa"``, ``"glfw"``, ...)."""
    try:
        from mujoco.rendering.classic import gl_context
    except ImportError:  # pragma: no cover - another mujoco layout
        return ""
    parts = getattr(getattr(gl_context, "GLContext", None), "__module__", "").split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "mujoco" else ""


def bind_headless_context() -> str:
    """Make sure ``mujoco.Renderer`` opens a headless context in this process; returns the backend.

    Before mujoco is imported this is :func:`preselect_gl_backend`. After, when mujoco bound GLFW
    because ``MUJOCO_GL`` was unset at its import, and there is no display: the first of EGL and
    OSMesa whose library exists is imported and made mujoco's context class (as if ``MUJOCO_GL``
    had named it), unless PyOpenGL was already loaded for another platform. A backend the user
    named in ``MUJOCO_GL`` before mujoco's import is never changed. Cheap: no context is created.
    """
    if "mujoco" not in sys.modules:
        return preselect_gl_backend()
    bound = _bound_backend()
    if bound != "glfw" or os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"):
        return bound
    if os.environ.get("MUJOCO_GL", "").lower() == "glfw":
        return bound  # the user's choice
    platform = os.environ.get("PYOPENGL_PLATFORM", "").lower()
    for b in GL_BACKENDS:
        if platform not in ("", b) or not ctypes.util.find_library(_LIBRARIES[b]):
            continue  # PyOpenGL is set (or loaded) for another platform and cannot switch
        try:
            mod = importlib.import_module(f"mujoco.{b}")
            from mujoco.rendering.classic import gl_context
        except ImportError:
            continue
        gl_context.GLContext = mod.GLContext
        os.environ["MUJOCO_GL"] = b
        return b
    return bound


def context_error(exc: BaseException) -> RenderBackendError:
    """A :class:`RenderBackendError` explaining a failed ``mujoco.Renderer``."""
    b = os.environ.get("MUJOCO_GL", "") or "(unset: mujoco's default, glfw, which needs a display)"
    return RenderBackendError(_message({b: f"{type(exc).__name__}: {exc}"}))

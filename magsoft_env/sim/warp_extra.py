"""MuJoCo Warp backend of the batched floor environments (the optional extra ``warp``).

Nothing here imports Warp at import time: :func:`require_warp` does, when a Warp batch is built, and says how to
install the extra where it is missing. :mod:`magsoft_env.sim.warp_batch` holds the rod batch (one model put once,
``nworld`` worlds stepped as captured graphs, per-world health checks and resets),
:mod:`magsoft_env.envs.warp_vector` the Gymnasium vector env of ``gym.make_vec(id, num_envs=n, backend="warp")``.
"""

from __future__ import annotations

import importlib.util

#: The versions the backend is built and tested against (``pip install -e ".[warp]"``).
MUJOCO_WARP_VERSION = "4.0.0"
WARP_LANG_VERSION = "1.19.0"
INSTALL_HINT = (f'pip install -e ".[warp]" (mujoco-warp=={MUJOCO_WARP_VERSION}, '
                f"warp-lang=={WARP_LANG_VERSION})")


def warp_available() -> bool:
    """Whether ``mujoco_warp`` and ``warp`` can be imported (without importing them)."""
    return all(importlib.util.find_spec(name) is not None for name in ("warp", "mujoco_warp"))


def require_warp():
    """Import and return ``(warp, mujoco_warp)``, or raise ImportError with the install command."""
    try:
        import warp

        # Warp's module-load and initialisation lines on stdout: warnings and errors only
        warp.config.quiet = True
        warp.config.log_level = max(warp.config.log_level, warp.LOG_WARNING)
        import mujoco_warp
    except ImportError as err:
        raise ImportError(f"the Warp backend needs the optional extra 'warp': {INSTALL_HINT}. ({err})") from err
    return warp, mujoco_warp


__all__ = ["INSTALL_HINT", "MUJOCO_WARP_VERSION", "WARP_LANG_VERSION", "require_warp", "warp_available"]

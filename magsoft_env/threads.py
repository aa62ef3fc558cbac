"""One BLAS thread limiter for the whole package (threadpoolctl; imports nothing from the package).

The equilibrium solver's matrices are about 50 x 50 to 200 x 200. Multi-threaded OpenBLAS on
such systems is slower than one thread, and on a busy machine its spinning threads slowed one
solve by 10-100x (measured: 7 s instead of 20 ms for one equilibrium). Solvers, the design
optimizer and benchmarks run their inner loops inside :func:`single_threaded_blas`.
"""

from __future__ import annotations

import contextlib

_CONTROLLER = []


def _controller():
    if not _CONTROLLER:
        from threadpoolctl import ThreadpoolController

        _CONTROLLER.append(ThreadpoolController())  # inspects the loaded libraries once: cache it
    return _CONTROLLER[0]


def single_threaded_blas(enabled: bool = True):
    """Context manager: BLAS runs on one thread inside the block (``enabled=False``: a no-op).

    Examples
    --------
    >>> with single_threaded_blas():
    ...     pass
    """
    if not enabled:
        return contextlib.nullcontext()
    return _controller().limit(limits=1, user_api="blas")


__all__ = ["single_threaded_blas"]

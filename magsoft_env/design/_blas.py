"""Run a block with single-threaded OpenBLAS (the equilibrium solver's matrices are ~100 x 100).

Multi-threaded OpenBLAS on such small systems is slower than one thread, and on a busy machine
its spinning threads can slow a 100 x 100 solve by 100x or more (measured: 7 s instead of 20 ms
for one equilibrium). This is a stand-in for ``threadpoolctl`` (not a dependency): it finds the
OpenBLAS libraries numpy and scipy loaded and sets their thread count, restoring it afterwards.
It uses ``threadpoolctl`` instead when that is installed.
"""

from __future__ import annotations

import contextlib
import ctypes

_PREFIXES = ("scipy_openblas", "openblas")
_SUFFIXES = ("64_", "")


def _libraries():
    paths = set()
    try:
        with open("/proc/self/maps", encoding="utf-8") as fh:
            for line in fh:
                parts = line.split()
                if len(parts) >= 6 and "openblas" in parts[-1].lower() and ".so" in parts[-1]:
                    paths.add(parts[-1])
    except OSError:  # not Linux: leave threads alone
        return []
    out = []
    for p in sorted(paths):
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        for pre in _PREFIXES:
            for suf in _SUFFIXES:
                setter = getattr(lib, f"{pre}_set_num_threads{suf}", None)
                getter = getattr(lib, f"{pre}_get_num_threads{suf}", None)
                if setter is not None and getter is not None:
                    out.append((setter, getter))
                    break
            else:
                continue
            break
    return out


@contextlib.contextmanager
def single_threaded_blas(enabled: bool = True):
    """Context manager: OpenBLAS runs on one thread inside the block (no-op if not found)."""
    if not enabled:
        yield
        return
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        pass
    else:
        with threadpool_limits(limits=1, user_api="blas"):
            yield
        return
    libs = _libraries()
    previous = []
    for setter, getter in libs:
        try:
            previous.append((setter, int(getter())))
            setter(1)
        except Exception:  # noqa: BLE001 - a foreign library: never fail the design over it
            continue
    try:
        yield
    finally:
        for setter, n in previous:
            with contextlib.suppress(Exception):
                setter(n)

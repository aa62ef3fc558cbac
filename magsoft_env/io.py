"""File and text output shared by every layer: atomic writers, JSON/CSV, output folders, tables.

Every file the package writes goes through :func:`atomic_path`: the content is written to a
temporary file in the target folder and moved into place, so a file is either complete or
absent (an interrupted run never leaves half a CSV or a truncated figure). The file gets the
permissions any new file gets (``0o666`` less the umask, as ``open()`` gives), not the private
``0o600`` of :func:`tempfile.mkstemp`. Imports nothing from the package.
"""

from __future__ import annotations

import contextlib
import csv
import io
import json
import math
import os
import secrets
from collections.abc import Iterator
from pathlib import Path


def check_out_dir(out, *, flag: str = "--out") -> Path:
    """The output folder as a Path; raises ValueError (before any work) if it cannot be one.

    ``flag`` names the option in the message (the CLI's ``--out`` by default)."""
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{flag} must be a folder, got {str(path)!r}, which is an existing file.")
    probe = path
    while not probe.exists():
        probe = probe.parent
    if not os.access(probe, os.W_OK):
        raise ValueError(f"{flag} {str(path)!r} is not writable (checked {str(probe)!r}).")
    return path


@contextlib.contextmanager
def atomic_path(path) -> Iterator[Path]:
    """Context manager: yields a temporary path beside ``path``; on success it replaces ``path``.

    On an exception the temporary file is removed and ``path`` is left as it was."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = _new_file(path)
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _new_file(path: Path) -> Path:
    """Create an empty, unique hidden file beside ``path`` with mode ``0o666`` less the umask.

    Created with ``os.open(..., 0o666)`` so that the kernel applies the umask (and any default ACL)
    as for any new file; :func:`tempfile.mkstemp` would make it ``0o600``, unreadable to colleagues."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        tmp = path.parent / f".{path.stem}-{secrets.token_hex(6)}{path.suffix}"
        try:
            fd = os.open(tmp, flags, 0o666)
        except FileExistsError:
            continue
        os.close(fd)
        return tmp
    raise FileExistsError(f"could not create a temporary file beside {str(path)!r}")


def write_text_atomic(path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_path(path) as tmp, open(tmp, "w", encoding="utf-8", newline="") as fh:
        fh.write(text)
    return Path(path)


def write_json(path, data) -> Path:
    """Write ``data`` as strict JSON (numpy values converted, NaN/inf as null), atomically."""
    return write_text_atomic(path, json.dumps(jsonable(data), indent=2, allow_nan=False) + "\n")


def write_csv(path, rows: list[dict]) -> Path:
    """Write ``rows`` (dicts with the same keys) as CSV, floats with 10 significant digits, atomically."""
    buf = io.StringIO()
    keys = list(rows[0]) if rows else []
    w = csv.DictWriter(buf, fieldnames=keys, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: _csv_value(r[k]) for k in keys})
    return write_text_atomic(path, buf.getvalue())


def _csv_value(v):
    if isinstance(v, float):
        return f"{v:.10g}"
    return v


def jsonable(obj):
    """``obj`` with numpy arrays and scalars turned into Python values; NaN and inf become None."""
    import numpy as np

    if isinstance(obj, dict):
        return {str(k): jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return jsonable(obj.tolist())
    if isinstance(obj, (np.bool_,)):
        return bool(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        return float(obj) if math.isfinite(obj) else None  # strict JSON: NaN/inf (failed solves) -> null
    return obj


def format_table(rows: list[dict], columns: list[tuple[str, str, str]]) -> str:
    """Plain-text table; ``columns`` are (key, header, format)."""
    head = [h for _, h, _ in columns]
    body = [[format(r[k], f) if f else str(r[k]) for k, _, f in columns] for r in rows]
    widths = [max(len(h), *(len(b[i]) for b in body)) if body else len(h) for i, h in enumerate(head)]
    lines = ["  ".join(h.rjust(w) for h, w in zip(head, widths, strict=True))]
    lines += ["  ".join(c.rjust(w) for c, w in zip(b, widths, strict=True)) for b in body]
    return "\n".join(lines)


__all__ = ["atomic_path", "check_out_dir", "format_table", "jsonable", "write_csv", "write_json",
           "write_text_atomic"]

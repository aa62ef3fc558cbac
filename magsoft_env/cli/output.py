"""The command line's outputs: the output folder and file checks (before any work) and the JSON it writes."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

from ..io import check_out_dir, jsonable
from ..io import write_json as _write_json

#: Where commands write when no ``--out`` is given.
DEFAULT_OUT = "magsoft_out"
_NAME_MAX = 255  # bytes in one path component on common file systems


def out_dir(out, *, flag: str = "--out") -> Path:
    """The output folder, checked before any work: it must be a folder or creatable as one, and writable.

    :func:`magsoft_env.io.check_out_dir` first (an existing file is refused), then a real test: the
    nearest existing ancestor must be a folder in which a (temporary, removed at once) folder can be
    created, which refuses read-only and virtual file systems such as ``/proc`` or ``/sys`` whatever the
    permission bits say. Creates nothing that stays; raises ValueError naming ``flag``.
    """
    if not isinstance(out, (str, os.PathLike)) or not str(out):
        raise ValueError(f"{flag} must be a folder path, got {out!r}.")
    try:
        path = check_out_dir(out, flag=flag)
        probe, missing = path, []
        while not probe.exists():
            missing.append(probe.name)
            probe = probe.parent
    except OSError as exc:
        raise ValueError(f"{flag} {str(out)!r} cannot be checked: {exc.strerror or exc}.") from None
    if not probe.is_dir():
        raise ValueError(f"{flag} {str(path)!r} cannot be created: {str(probe)!r} is a file, not a folder.")
    for name in missing:
        if len(os.fsencode(name)) > _NAME_MAX:
            raise ValueError(f"{flag} {str(path)!r} has a path component longer than {_NAME_MAX} bytes.")
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".magsoft-write-test-", dir=probe))
    except OSError as exc:
        raise ValueError(
            f"{flag} {str(path)!r} is not writable: nothing can be created in {str(probe)!r} "
            f"({exc.strerror or exc})."
        ) from None
    return path


def out_file(path, *, flag: str = "--out", suffixes: tuple[str, ...] | None = None) -> Path:
    """An output file, checked before any work: not a folder, its folder creatable and writable (see
    :func:`out_dir`), its name not too long and, if ``suffixes`` are given, ending in one of them.

    Creates nothing that stays; raises ValueError naming ``flag``.
    """
    if not isinstance(path, (str, os.PathLike)) or not str(path) or str(path).endswith(("/", os.sep)):
        raise ValueError(f"{flag} must be a file path, got {path!r}.")
    p = Path(path)
    if suffixes is not None and p.suffix.lower() not in suffixes:
        raise ValueError(f"{flag} must end in one of {list(suffixes)}, got {str(p)!r}.")
    if p.is_dir():
        raise ValueError(f"{flag} must be a file, got {str(p)!r}, which is a folder.")
    if len(os.fsencode(p.name)) > _NAME_MAX:
        raise ValueError(f"{flag} {str(p)!r} has a file name longer than {_NAME_MAX} bytes.")
    if p.exists() and not os.access(p, os.W_OK):
        raise ValueError(f"{flag} {str(p)!r} exists and is not writable.")
    probe = p.parent
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if probe.exists() and not probe.is_dir():
        raise ValueError(f"{flag} {str(p)!r} cannot be created: {str(probe)!r} is a file, not a folder.")
    out_dir(p.parent, flag=f"the folder of {flag}")
    return p


#: Significant digits of the floats the CLI writes as JSON (files and ``--json`` output).
JSON_DIGITS = 10
#: A float is written with ``JSON_DIGITS`` digits when that moves it by at most this (relative):
#: it removes float noise (0.9999999999999062 -> 1.0, 90.00000000000001 -> 90.0) but keeps the
#: written numbers consistent with each other to 1e-12 (e.g. ``v_over_L`` = ``tip_z_mm`` / L).
_JSON_REL_TOL = 2e-13
_JSON_MAX_DIGITS = 15


def tidy_float(x: float) -> float:
    """``x`` written with as few significant digits as keep it within 2e-13 (relative): at most
    ``JSON_DIGITS`` (10) when that is within the tolerance (float noise), else up to 15."""
    if not math.isfinite(x) or x == 0.0:
        return x
    for digits in range(JSON_DIGITS, _JSON_MAX_DIGITS):
        y = float(f"{x:.{digits}g}")
        if abs(y - x) <= _JSON_REL_TOL * abs(x):
            return y
    return float(f"{x:.{_JSON_MAX_DIGITS}g}")


def tidy(obj):
    """``obj`` made JSON-ready (:func:`magsoft_env.io.jsonable`: numpy converted, NaN/inf as None) with
    every float passed through :func:`tidy_float`."""
    return _tidy(jsonable(obj))


def _tidy(obj):
    if isinstance(obj, dict):
        return {k: _tidy(v) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_tidy(v) for v in obj]
    if isinstance(obj, float):
        return tidy_float(obj)
    return obj


def write_json(path, data) -> Path:
    """:func:`magsoft_env.io.write_json` (atomic, strict JSON) of ``tidy(data)``: the CLI's JSON files."""
    return _write_json(path, tidy(data))


def dumps_json(data) -> str:
    """One line of strict JSON of ``tidy(data)``: the CLI's ``--json`` output."""
    return json.dumps(tidy(data), allow_nan=False)


__all__ = ["DEFAULT_OUT", "JSON_DIGITS", "dumps_json", "out_dir", "out_file", "tidy", "tidy_float", "write_json"]

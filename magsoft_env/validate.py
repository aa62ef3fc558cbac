"""Input checks shared by the specification layer: one place, one message style."""

from __future__ import annotations

import difflib
import math
import operator
from collections.abc import Iterable

import numpy as np


def finite_number(name: str, value, *, unit: str = "") -> float:
    """Return ``value`` as a float or raise a ValueError naming ``name``.

    Numbers only: a string ("1e-3") or a bool is refused, not converted, so a quoted number or a
    flag passed in the wrong place is reported instead of read as a value."""
    if isinstance(value, (str, bytes, bool, np.bool_)):
        kind = "a bool" if isinstance(value, (bool, np.bool_)) else "a string"
        raise ValueError(f"{name} must be a finite number{_u(unit)}, got {kind}: {value!r}.")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a finite number{_u(unit)}, got {value!r}.") from None
    if not math.isfinite(x):
        raise ValueError(f"{name} must be a finite number{_u(unit)}, got {value!r}.")
    return x


def positive(name: str, value, *, unit: str = "") -> float:
    x = finite_number(name, value, unit=unit)
    if x <= 0.0:
        raise ValueError(f"{name} must be > 0{_u(unit)}, got {value!r}.")
    return x


def nonnegative(name: str, value, *, unit: str = "") -> float:
    x = finite_number(name, value, unit=unit)
    if x < 0.0:
        raise ValueError(f"{name} must be >= 0{_u(unit)}, got {value!r}.")
    return x


def in_range(name: str, value, lo: float, hi: float, *, unit: str = "") -> float:
    x = finite_number(name, value, unit=unit)
    if not lo <= x <= hi:
        raise ValueError(f"{name} must lie in [{lo:g}, {hi:g}]{_u(unit)}, got {value!r}.")
    return x


#: Largest magnitude of an angle given in radians (rad): a larger one looks like degrees.
MAX_ANGLE = 2 * math.pi


class AngleRangeError(ValueError):
    """An angle (rad) beyond :data:`MAX_ANGLE`; ``largest`` is its magnitude (rad). Readers of files in
    degrees catch it to say so in their own unit."""

    def __init__(self, message: str, largest: float):
        super().__init__(message)
        self.largest = largest


def degrees_message(name: str, got: str, largest: float) -> str:
    """The message for an angle (rad) whose magnitude ``largest`` exceeds :data:`MAX_ANGLE` (``got``: the value
    received, as the message shows it)."""
    return (f"{name} must be an angle in radians, |beta| <= 2 pi (6.283), got {got}: this looks like degrees. "
            f"Angles are in radians: convert with math.radians (math.radians({largest:g}) = "
            f"{math.radians(largest):.6g}) or np.radians for arrays.")


def angle(name: str, value) -> float:
    """Return ``value`` as an angle (rad) in [-2 pi, 2 pi], or a ValueError naming ``name`` (one that says a larger
    number looks like degrees and how to convert it)."""
    x = finite_number(name, value, unit="rad")
    if abs(x) > MAX_ANGLE:
        raise AngleRangeError(degrees_message(name, repr(value), abs(x)), abs(x))
    return x


def integer(name: str, value, lo: int | None = None, hi: int | None = None) -> int:
    """Return ``value`` as an int in ``[lo, hi]`` (either bound may be None) or raise a ValueError naming ``name``.

    Integers only: a string ("20"), a bool, or a float with a fractional part (2.5) is refused; a float
    with an integral value (3.0) is accepted as that integer."""
    what = f"{'a positive integer' if lo == 1 else 'an integer'}{_int_range(lo, hi)}"
    if isinstance(value, (str, bytes, bool, np.bool_)):
        kind = "a bool" if isinstance(value, (bool, np.bool_)) else "a string"
        raise ValueError(f"{name} must be {what}, got {kind}: {value!r}.")
    if isinstance(value, (float, np.floating)):
        if not (math.isfinite(value) and float(value).is_integer()):
            raise ValueError(f"{name} must be {what}, got {value!r}.")
        n = int(value)
    else:
        try:
            n = operator.index(value)
        except TypeError:
            raise ValueError(f"{name} must be {what}, got {value!r}.") from None
    if (lo is not None and n < lo) or (hi is not None and n > hi):
        raise ValueError(f"{name} must be {what}, got {value!r}.")
    return int(n)


def pair(name: str, value, what: str, *, note: str = "") -> tuple:
    """``value`` unpacked into its two items, or a ValueError: ``{name} must be a pair {what}, got {value!r}.``

    The items are returned as they are (the caller checks each). Strings, bytes, dicts and sets are
    refused: they unpack, but not into two values. ``note`` is appended to the message (a hint)."""
    msg = f"{name} must be a pair {what}, got {value!r}.{' ' + note if note else ''}"
    if isinstance(value, (str, bytes, dict, set, frozenset)):
        raise ValueError(msg)
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ValueError(msg) from None
    return a, b


def boolean(name: str, value) -> bool:
    """Return ``value`` as a bool; only True/False (or numpy bools) are accepted, not 0/1 or strings."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{name} must be True or False (a bool), got {value!r}.")
    return bool(value)


def finite_array(name: str, value, *, ndim: int | None = None, min_len: int = 0) -> np.ndarray:
    """``value`` as a float array of finite numbers; strings and bools are refused, not converted."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"{name} must be an array of finite numbers, got a string: {value!r}.")
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):  # ragged nesting
        raise ValueError(f"{name} must be an array of finite numbers, got {value!r}.") from None
    if raw.dtype.kind in "bUSV" or (raw.dtype.kind == "O" and any(
            isinstance(v, (str, bytes, bool, np.bool_)) for v in raw.ravel())):
        raise ValueError(f"{name} must be an array of finite numbers (not strings or bools), got {value!r}.")
    try:
        a = raw.astype(float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be an array of finite numbers, got {value!r}.") from None
    if ndim is not None and a.ndim != ndim:
        raise ValueError(f"{name} must be a {ndim}-D array, got shape {a.shape}.")
    if a.ndim >= 1 and a.shape[0] < min_len:
        raise ValueError(f"{name} needs at least {min_len} entries, got {a.shape[0]}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must contain only finite numbers, got {a!r}.")
    return a


def choice(name: str, value, options: Iterable[str]) -> str:
    options = list(options)
    if value in options:
        return value
    hint = difflib.get_close_matches(str(value), options, n=1)
    extra = f" Did you mean {hint[0]!r}?" if hint else ""
    raise ValueError(f"{name} must be one of {options}, got {value!r}.{extra}")


def _int_range(lo, hi) -> str:
    if lo is not None and hi is not None:
        return f" in [{lo}, {hi}]"
    if lo is not None:
        return f" >= {lo}"
    if hi is not None:
        return f" <= {hi}"
    return ""


def _u(unit: str) -> str:
    return f" ({unit})" if unit else ""


def checked_replace(obj, changes: dict, what: str):
    """``dataclasses.replace(obj, **changes)`` (which checks the copy again through ``__post_init__``),
    refusing names that are not fields of ``obj`` with a ValueError naming ``what``."""
    import dataclasses

    names = [f.name for f in dataclasses.fields(obj)]
    unknown = sorted(set(changes) - set(names))
    if unknown:
        raise ValueError(f"{what} got unknown field(s) {unknown}; allowed: {names}.")
    return dataclasses.replace(obj, **changes)

"""Uniform applied fields B_a = (B_x, B_z) in tesla, and sequences of them for loading paths."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from ..validate import boolean, finite_number, integer, pair

#: Largest field magnitude accepted (T). Coil systems for these robots give tens of mT;
#: anything near a tesla is almost surely a unit mistake (mT given as T).
MAX_FIELD = 1.0
#: Most states :func:`ramp` builds (each one is an equilibrium to solve).
MAX_RAMP_STEPS = 100_000
#: What a three-component field gets told (the model is planar: x along the beam, z up).
PLANAR_FIELD_NOTE = ("3D fields are not supported yet: the beam bends in the x-z plane, so a field has two "
                     "components, (B_x, B_z); a 2-component field means (B_x, B_z), not (B_x, B_y).")


def _three_components(value) -> bool:
    if isinstance(value, (str, bytes, dict, set, frozenset)):
        return False
    try:
        return len(value) == 3
    except TypeError:
        return False


def field_pair(name: str, value, what: str = "(B_x, B_z) in tesla") -> tuple:
    """``value`` as its two raw components ``(B_x, B_z)``; a three-component field is a ValueError that says
    3D fields are not supported yet."""
    if _three_components(value):
        raise ValueError(f"{name} must be a pair {what}, got 3 components {value!r}. {PLANAR_FIELD_NOTE}")
    return pair(name, value, what)


def field_component(name: str, value) -> float:
    """``value`` as one field component (T), within +-:data:`MAX_FIELD`, or a ValueError naming ``name``."""
    v = finite_number(name, value, unit="T")
    if abs(v) > MAX_FIELD:
        raise ValueError(
            f"{name} must lie in [-{MAX_FIELD:g}, {MAX_FIELD:g}] T, got {v!r} (fields are in tesla: 13 mT is 0.013)."
        )
    return v


@dataclass(frozen=True)
class Field:
    """A uniform applied field (T). ``alpha = atan2(B_z, B_x)`` is its angle from +x.

    Examples
    --------
    >>> Field.from_mT(-22, 13).as_array() * 1e3
    array([-22.,  13.])
    """

    Bx: float = 0.0
    Bz: float = 0.0

    def __new__(cls, *args, **kwargs):
        if len(args) > 2:  # Field(Bx, By, Bz): say why, rather than the dataclass's bare TypeError
            raise ValueError(f"Field takes two components (B_x, B_z) in tesla, got {len(args)}: {args!r}. "
                             f"{PLANAR_FIELD_NOTE}")
        return super().__new__(cls)

    def __post_init__(self):
        for name in ("Bx", "Bz"):
            object.__setattr__(self, name, field_component(f"field {name}", getattr(self, name)))

    @classmethod
    def from_mT(cls, Bx_mT: float = 0.0, Bz_mT: float = 0.0, *more) -> Field:
        """A field from its components in mT."""
        if more:
            raise ValueError(f"Field.from_mT takes two components (B_x, B_z) in mT, got "
                             f"{(Bx_mT, Bz_mT, *more)!r}. {PLANAR_FIELD_NOTE}")
        return cls(finite_number("Bx_mT", Bx_mT) * 1e-3, finite_number("Bz_mT", Bz_mT) * 1e-3)

    @classmethod
    def polar(cls, magnitude: float, angle: float) -> Field:
        """Field of ``magnitude`` (T, in [0, MAX_FIELD]) at ``angle`` (rad, finite) from +x toward +z."""
        b = finite_number("Field.polar magnitude", magnitude, unit="T")
        if not 0.0 <= b <= MAX_FIELD:
            raise ValueError(
                f"Field.polar magnitude must lie in [0, {MAX_FIELD:g}] T, got {magnitude!r} (give the direction "
                "with the angle, not a negative magnitude; fields are in tesla: 13 mT is 0.013)."
            )
        a = finite_number("Field.polar angle", angle, unit="rad")
        return cls(b * math.cos(a), b * math.sin(a))

    @property
    def magnitude(self) -> float:
        return math.hypot(self.Bx, self.Bz)

    @property
    def angle(self) -> float:
        return math.atan2(self.Bz, self.Bx)

    def as_array(self) -> np.ndarray:
        return np.array([self.Bx, self.Bz])

    def __iter__(self):
        yield self.Bx
        yield self.Bz


def as_field(value, name: str = "field") -> Field:
    """Accept a :class:`Field` or a pair ``(B_x, B_z)`` in tesla."""
    if isinstance(value, Field):
        return value
    bx, bz = field_pair(name, value, "(B_x, B_z) in tesla (or a Field)")
    return Field(bx, bz)


def as_fields(values: Iterable, name: str = "fields") -> list[Field]:
    """A non-empty sequence of fields; a single (B_x, B_z) pair is not accepted here."""
    if isinstance(values, Field):
        raise ValueError(f"{name} must be a sequence of fields, got a single Field; wrap it in a list.")
    arr = values
    if isinstance(values, np.ndarray):
        if values.ndim != 2 or values.shape[1] != 2:
            raise ValueError(f"{name} as an array must have shape (n, 2), got {values.shape}.")
        arr = values.tolist()
    if isinstance(values, (str, bytes, dict, set, frozenset)) or not isinstance(arr, Iterable):
        raise ValueError(f"{name} must be a sequence of fields or (B_x, B_z) pairs in tesla, got {values!r}.")
    out = [as_field(v, f"{name}[{i}]") for i, v in enumerate(arr)]
    if not out:
        raise ValueError(f"{name} must contain at least one field, got none.")
    return out


def ramp(start, end, n: int = 21, *, include_start: bool = True) -> list[Field]:
    """``n`` fields (an integer in [1, MAX_RAMP_STEPS]) evenly spaced from ``start`` to ``end`` (pairs in T)."""
    n = integer("ramp n", n, 1, MAX_RAMP_STEPS)
    include_start = boolean("ramp include_start", include_start)
    a, b = as_field(start, "start").as_array(), as_field(end, "end").as_array()
    t = np.linspace(0.0, 1.0, n + (0 if include_start else 1))
    if not include_start:
        t = t[1:]
    return [Field(*(a + (b - a) * ti)) for ti in t]

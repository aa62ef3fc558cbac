"""Uniform applied fields B_a = (B_x, B_y, B_z) in tesla, and sequences of them for loading paths.

A two-component field means (B_x, B_z): the planar parts of the package bend the beam in the x-z plane."""

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
#: What a three-component field gets told where only planar fields are taken (x along the beam, z up).
PLANAR_FIELD_NOTE = ("This part is planar (the beam bends in the x-z plane), so a field here has two components "
                     "(B_x, B_z); a 2-component field means (B_x, B_z), not (B_x, B_y). The analytical model "
                     "(solve_equilibrium) takes 3D fields (B_x, B_y, B_z).")
_NAMES = ("Bx", "By", "Bz")
#: Which components positional arguments give: one is B_x, two are (B_x, B_z), three are (B_x, B_y, B_z).
_POSITIONAL = {0: (), 1: ("Bx",), 2: ("Bx", "Bz"), 3: ("Bx", "By", "Bz")}


def _three_components(value) -> bool:
    if isinstance(value, (str, bytes, dict, set, frozenset)):
        return False
    try:
        return len(value) == 3
    except TypeError:
        return False


def field_pair(name: str, value, what: str = "(B_x, B_z) in tesla", *, planar: str = "") -> tuple:
    """``value`` as its two raw components ``(B_x, B_z)``, for the parts that are planar.

    A three-component value is a ValueError that names the planar part (``planar``, e.g. "preset files") and says
    that the analytical model takes (B_x, B_y, B_z)."""
    if _three_components(value):
        part = f"{planar} take" if planar else "this part takes"
        raise ValueError(f"{name} must be a pair {what}, got 3 components {value!r}: {part} planar fields "
                         "(x-z plane), where two components mean (B_x, B_z). The analytical model "
                         "(solve_equilibrium) takes 3D fields (B_x, B_y, B_z).")
    return pair(name, value, what)


def field_component(name: str, value) -> float:
    """``value`` as one field component (T), within +-:data:`MAX_FIELD`, or a ValueError naming ``name``."""
    v = finite_number(name, value, unit="T")
    if abs(v) > MAX_FIELD:
        raise ValueError(
            f"{name} must lie in [-{MAX_FIELD:g}, {MAX_FIELD:g}] T, got {v!r} (fields are in tesla: 13 mT is 0.013)."
        )
    return v


def _components(args: tuple, kwargs: dict, suffix: str, what: str) -> dict:
    """Component name -> raw value from positional ``args`` (one: B_x; two: (B_x, B_z); three: (B_x, B_y, B_z))
    and keywords ``Bx``, ``By``, ``Bz`` (each name followed by ``suffix``); a ValueError for anything else."""
    if len(args) > 3:
        raise ValueError(f"{what} takes at most three components (B_x, B_y, B_z), or two meaning (B_x, B_z), "
                         f"got {len(args)}: {args!r}.")
    keys = {n + suffix: n for n in _NAMES}
    unknown = sorted(k for k in kwargs if k not in keys)
    if unknown:
        raise ValueError(f"{what} got unknown keyword(s) {unknown}; allowed: {list(keys)}.")
    out = dict(zip(_POSITIONAL[len(args)], args, strict=True))
    for k, v in kwargs.items():
        if keys[k] in out:
            raise ValueError(f"{what} got {k} both by position and by keyword (positional components are B_x; "
                             "(B_x, B_z); or (B_x, B_y, B_z)).")
        out[keys[k]] = v
    return out


@dataclass(frozen=True, init=False)
class Field:
    """A uniform applied field (T): ``(B_x, B_y, B_z)`` with x along the undeformed beam, y across its width, z up.

    ``Field(Bx, Bz)`` (two components) is a planar field, B_y = 0; ``Field(Bx, By, Bz)`` gives all three;
    keywords ``Field(Bx=..., By=..., Bz=...)`` name them. Each component is in T, within +-:data:`MAX_FIELD`.
    The planar parts of the package (the MuJoCo rod, gaits, inverse design) take only fields with B_y = 0
    (:attr:`is_planar`); :meth:`vector` gives the three components, :meth:`as_array` the two of a planar field.

    Examples
    --------
    >>> Field.from_mT(-22, 13).as_array() * 1e3
    array([-22.,  13.])
    >>> Field.from_mT(3, 4, 0).vector() * 1e3
    array([3., 4., 0.])
    """

    Bx: float
    By: float
    Bz: float

    def __init__(self, *components, **named):
        if not named and len(components) == 2:  # the planar Field(Bx, Bz) of most callers
            given = {"Bx": components[0], "Bz": components[1]}
        else:
            given = _components(components, named, "", "Field")
        setter = object.__setattr__
        for name in _NAMES:
            setter(self, name, field_component(f"field {name}", given[name]) if name in given else 0.0)

    @classmethod
    def from_mT(cls, *components_mT, **named_mT) -> Field:
        """A field from its components in mT: ``from_mT(bx, bz)`` (planar) or ``from_mT(bx, by, bz)``; keywords
        ``Bx_mT``, ``By_mT``, ``Bz_mT``."""
        given = _components(components_mT, named_mT, "_mT", "Field.from_mT")
        return cls(**{n: finite_number(f"{n}_mT", v, unit="mT") * 1e-3 for n, v in given.items()})

    @classmethod
    def polar(cls, magnitude: float, angle: float) -> Field:
        """Planar field of ``magnitude`` (T, in [0, MAX_FIELD]) at ``angle`` (rad, finite) from +x toward +z."""
        b = finite_number("Field.polar magnitude", magnitude, unit="T")
        if not 0.0 <= b <= MAX_FIELD:
            raise ValueError(
                f"Field.polar magnitude must lie in [0, {MAX_FIELD:g}] T, got {magnitude!r} (give the direction "
                "with the angle, not a negative magnitude; fields are in tesla: 13 mT is 0.013)."
            )
        a = finite_number("Field.polar angle", angle, unit="rad")
        return cls(b * math.cos(a), b * math.sin(a))

    @property
    def is_planar(self) -> bool:
        """True when the field lies in the x-z plane (B_y = 0)."""
        return self.By == 0.0

    @property
    def magnitude(self) -> float:
        """|B| (T), the norm of all three components."""
        return math.sqrt(self.Bx**2 + self.By**2 + self.Bz**2)

    @property
    def angle(self) -> float:
        """``atan2(B_z, B_x)`` (rad): the angle from +x toward +z of the field's projection on the x-z plane."""
        return math.atan2(self.Bz, self.Bx)

    def vector(self) -> np.ndarray:
        """The three components ``(B_x, B_y, B_z)`` (T), shape (3,)."""
        return np.array([self.Bx, self.By, self.Bz])

    def _planar(self) -> None:
        if self.By != 0.0:
            raise ValueError(f"{self!r} has B_y = {self.By!r} T; this quantity is planar (x-z plane): its two "
                             "components are (B_x, B_z). Use Field.vector() for the three components.")

    def as_array(self) -> np.ndarray:
        """The in-plane components ``(B_x, B_z)`` (T), shape (2,); a ValueError for a field with B_y != 0."""
        self._planar()
        return np.array([self.Bx, self.Bz])

    def __iter__(self):
        """``B_x, B_z`` of a planar field (``bx, bz = field``); a ValueError for a field with B_y != 0."""
        self._planar()
        yield self.Bx
        yield self.Bz


def planar_field(field: Field, what: str) -> Field:
    """``field`` if it lies in the x-z plane (B_y = 0), else a ValueError naming ``what`` (the planar part that
    would take it, e.g. "the MuJoCo hinge-chain rod")."""
    if not isinstance(field, Field):
        raise ValueError(f"planar_field needs a Field, got {type(field).__name__}.")
    if not field.is_planar:
        raise ValueError(
            f"{what} is planar (x-z plane) and takes fields with B_y = 0, got B_y = {field.By!r} T in {field!r}. "
            "The 3D analytical model (solve_equilibrium) takes fields with a y component."
        )
    return field


def as_field(value, name: str = "field") -> Field:
    """A :class:`Field`, a pair ``(B_x, B_z)`` or a triple ``(B_x, B_y, B_z)`` (T) as a Field."""
    if isinstance(value, Field):
        return value
    shape = _nested_shape(value)
    if shape is not None and len(shape) >= 2:
        hint = (f" Flatten it first (np.ravel gives shape ({math.prod(shape)},))." if math.prod(shape) in (2, 3)
                else "")
        raise ValueError(f"{name} must have shape (2,) for (B_x, B_z) or (3,) for (B_x, B_y, B_z) in tesla, "
                         f"got an array of shape {shape}{_small(value)}.{hint}")
    if _three_components(value):
        bx, by, bz = value
        return Field(*(field_component(f"{name} {c}", v) for c, v in zip(_NAMES, (bx, by, bz), strict=True)))
    bx, bz = pair(name, value, "(B_x, B_z) in tesla (or a triple (B_x, B_y, B_z), or a Field)")
    return Field(field_component(f"{name} Bx", bx), field_component(f"{name} Bz", bz))


def _nested_shape(value) -> tuple | None:
    """The array shape of an ndarray or a nested list/tuple of numbers, or None (not an array, or ragged)."""
    if isinstance(value, np.ndarray):
        return value.shape
    if not isinstance(value, (list, tuple)):
        return None
    try:
        return np.shape(value)
    except ValueError:  # ragged nesting
        return None


def _small(value) -> str:
    """``": [...]"`` with the values of a small array (at most 9 numbers), else ``""``."""
    a = np.asarray(value, dtype=object)
    return f": {a.tolist()!r}" if a.size <= 9 else ""


def as_fields(values: Iterable, name: str = "fields") -> list[Field]:
    """A non-empty sequence of fields: Fields, pairs (B_x, B_z), triples (B_x, B_y, B_z) (T), or an array of
    shape (n, 2) or (n, 3) with those rows. A single field is not accepted here."""
    if isinstance(values, Field):
        raise ValueError(f"{name} must be a sequence of fields, got a single Field; wrap it in a list.")
    arr = values
    if isinstance(values, np.ndarray):
        if values.ndim != 2 or values.shape[1] not in (2, 3):
            raise ValueError(f"{name} as an array must have shape (n, 2) rows (B_x, B_z) or (n, 3) rows "
                             f"(B_x, B_y, B_z), got {values.shape}.")
        arr = values.tolist()
    if isinstance(values, (str, bytes, dict, set, frozenset)) or not isinstance(arr, Iterable):
        raise ValueError(f"{name} must be a sequence of fields, (B_x, B_z) pairs or (B_x, B_y, B_z) triples in "
                         f"tesla, got {values!r}.")
    out = [as_field(v, f"{name}[{i}]") for i, v in enumerate(arr)]
    if not out:
        raise ValueError(f"{name} must contain at least one field, got none.")
    return out


def ramp(start, end, n: int = 21, *, include_start: bool = True) -> list[Field]:
    """``n`` fields (an integer in [1, MAX_RAMP_STEPS]) evenly spaced from ``start`` to ``end`` (Fields, pairs
    (B_x, B_z) or triples (B_x, B_y, B_z) in T); all three components are interpolated."""
    n = integer("ramp n", n, 1, MAX_RAMP_STEPS)
    include_start = boolean("ramp include_start", include_start)
    a, b = as_field(start, "start").vector(), as_field(end, "end").vector()
    t = np.linspace(0.0, 1.0, n + (0 if include_start else 1))
    if not include_start:
        t = t[1:]
    return [Field(*(a + (b - a) * ti)) for ti in t]

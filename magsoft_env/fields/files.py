"""Field sources as data: read from a name, a YAML or JSON file or a dict, and written back (mm, mT, A, kA/m).

A source file holds one source; units are in the key names, as in robot files (docs/robots.md)::

    magsoft_source: 1                       # format version (optional)
    sources:                                # a sum; any source may be placed with position_mm and rotation
      - {type: coil_system, name: navion, currents_A: [10, 0, -5]}
      - type: cylinder
        position_mm: [0, 0, 30]
        axis: [0, 0, 1]
        radius_mm: 5
        length_mm: 10
        remanence_T: 1.2                    # or magnetization_kA_per_m: 955

Types and their keys (``position_mm`` defaults to the origin; ``rotation`` to the identity):

=================  ===============================================================================================
``uniform``        ``B_mT`` ([B_x, B_z] or [B_x, B_y, B_z])
``dipole``         ``moment_A_m2`` (3)
``dipoles``        ``positions_mm`` (k, 3) and ``moments_A_m2`` or ``moments_T_m3`` (k, 3; mu0/4pi folded in)
``sphere``         ``radius_mm`` and one of ``magnetization_kA_per_m`` (3), ``remanence_T`` (3), ``moment_A_m2``
``cylinder``       ``radius_mm``, ``length_mm``, ``axis`` (default [0, 0, 1]) and ``magnetization_kA_per_m`` or
                   ``remanence_T`` (one number, along the axis)
``cuboid``         ``dimensions_mm`` (3) and ``magnetization_kA_per_m`` or ``remanence_T`` (3, its own frame)
``loop``           ``radius_mm``, ``current_A``, ``normal`` (default [0, 0, 1])
``coaxial_loops``  ``offsets_mm`` (k), ``radii_mm`` and ``currents_A`` (one or k each), ``normal``
``helmholtz``,     ``radius_mm``, ``current_A``, ``normal``: :func:`~.loop.helmholtz_pair`,
``maxwell``        :func:`~.loop.maxwell_pair`
``coil_system``    ``name`` (a calibration of :data:`~.coils.CALIBRATIONS`) or ``file`` (an MPEM .yaml), with
                   ``currents_A`` (one per coil), optional ``max_current_A`` (one or one per coil) and
                   ``normalize_directions`` (bool)
``grid``           ``file`` (.npz with ``x_mm``, ``y_mm``, ``z_mm``, ``B_mT`` (nx, ny, nz, 3) and optionally
                   ``G_mT_per_m`` (nx, ny, nz, 3, 3)), optional ``degree``: a :class:`~.grid.GridField`
``sum``            ``sources``: a list of sources (``type: sum`` may be left out)
=================  ===============================================================================================

Every source also takes ``position_mm`` (3) and ``rotation`` (a 3x3 matrix, its own axes as columns, or
``{axis: [x, y, z], angle_deg: a}``): where its own frame goes. A magnet, dipole or loop is moved by its
parameters (its centre, moment, axis); the others are wrapped in a :class:`~.base.Transformed`. ``description``
(text) is allowed anywhere and ignored. File paths inside a file are relative to that file's folder.

Numbers are converted from their digits (``18`` mm is exactly ``0.018`` m), and the writer picks numbers that
read back to the same floats, so ``dict -> source -> dict -> source`` gives the same field to the bit. Every
malformed input is a ``ValueError`` naming the file, the key path (``sources[1].moment_A_m2``), what was
expected and what was received; an unknown key names the closest valid one.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import weakref
from decimal import Decimal, InvalidOperation
from pathlib import Path

import numpy as np

from ..io import write_text_atomic
from ..spec import MU0
from .base import MU0_4PI, Source, SourceSum, Transformed, Uniform, rotation_matrix, unit_vector
from .coils import CALIBRATIONS, CoilSystem
from .dipole import DipoleSet, PointDipole, SphereMagnet
from .grid import GridField
from .loop import CircularLoop, CoaxialLoops, helmholtz_pair, maxwell_pair
from .magnets import CuboidMagnet, CylinderMagnet
from .moving import MovingSource, rotation_about

#: Version of the source file format written by :func:`save_source`.
FORMAT_VERSION = 1
#: File suffixes :func:`load_source` reads as source files.
SOURCE_SUFFIXES = (".yml", ".yaml", ".json")
#: Largest source file read (bytes).
MAX_FILE_BYTES = 20 * 2**20

_PLACE = ("position_mm", "rotation")
_COMMON = ("type", "description", *_PLACE)
_KEYS = {
    "uniform": ("B_mT",),
    "dipole": ("moment_A_m2",),
    "dipoles": ("positions_mm", "moments_A_m2", "moments_T_m3"),
    "sphere": ("radius_mm", "magnetization_kA_per_m", "remanence_T", "moment_A_m2"),
    "cylinder": ("radius_mm", "length_mm", "axis", "magnetization_kA_per_m", "remanence_T"),
    "cuboid": ("dimensions_mm", "magnetization_kA_per_m", "remanence_T"),
    "loop": ("radius_mm", "current_A", "normal"),
    "coaxial_loops": ("offsets_mm", "radii_mm", "currents_A", "normal"),
    "helmholtz": ("radius_mm", "current_A", "normal"),
    "maxwell": ("radius_mm", "current_A", "normal"),
    "coil_system": ("name", "file", "currents_A", "max_current_A", "normalize_directions"),
    "grid": ("file", "degree"),
    "sum": ("sources",),
}
TYPES = tuple(_KEYS)
_GRID_ARRAYS = ("x_mm", "y_mm", "z_mm", "B_mT", "G_mT_per_m")

# what a loaded coil system at currents or a grid came from, to write it back as such (identity-keyed)
_ORIGINS: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


class _Ctx:
    """Where an input comes from (``source file 'a.yaml'`` or ``source dict``) and the folder of its paths."""

    def __init__(self, where: str, base: Path):
        self.where = where
        self.base = base

    def error(self, path: str, message: str) -> ValueError:
        return ValueError(f"{self.where}: {path + ' ' if path else ''}{message}")


def _key(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


# --------------------------------------------------------------------------------------------- numbers


def _decimal(ctx: _Ctx, path: str, value, unit: str) -> Decimal:
    """A finite number's digits: an int, a float (its shortest repr) or a numeric string (YAML 1.1 reads
    ``1e-3`` as a string)."""
    if isinstance(value, (bool, np.bool_)) or value is None or isinstance(value, (list, tuple, dict)):
        raise ctx.error(path, f"must be a finite number ({unit}), got {value!r}.")
    try:
        if isinstance(value, (int, np.integer)):
            d = Decimal(int(value))
        elif isinstance(value, (float, np.floating)):
            d = Decimal(repr(float(value)))
        elif isinstance(value, str):
            d = Decimal(value.strip().replace("_", ""))
        else:
            raise InvalidOperation
    except (InvalidOperation, ValueError):
        raise ctx.error(path, f"must be a finite number ({unit}), got {value!r}.") from None
    if not d.is_finite():
        raise ctx.error(path, f"must be a finite number ({unit}), got {value!r}.")
    return d


def _number(ctx: _Ctx, path: str, value, unit: str, exponent: int = 0) -> float:
    """A number in a unit ``10**-exponent`` times SI (3 for mm, mT; -3 for kA/m) as SI, rounded once."""
    return float(_decimal(ctx, path, value, unit).scaleb(-exponent))


def _array(ctx: _Ctx, path: str, value, shape: tuple, unit: str, exponent: int = 0) -> np.ndarray:
    """A nested list of numbers of ``shape`` (-1: any length >= 1) in SI."""
    def walk(v, dims, where):
        if not dims:
            return _number(ctx, where, v, unit, exponent)
        if not isinstance(v, (list, tuple, np.ndarray)) or (dims[0] != -1 and len(v) != dims[0]) or len(v) == 0:
            raise ctx.error(path, f"must have shape {_shape_text(shape)} ({unit}), got {_short(value)}.")
        return [walk(x, dims[1:], f"{where}[{i}]") for i, x in enumerate(v)]

    return np.array(walk(value, shape, path), dtype=float)


def _shape_text(shape: tuple) -> str:
    return "(" + ", ".join("k" if s == -1 else str(s) for s in shape) + ("," if len(shape) == 1 else "") + ")"


def _short(value) -> str:
    text = repr(value.tolist() if isinstance(value, np.ndarray) else value)
    return text if len(text) <= 200 else text[:200] + "..."


def _to_unit(value: float, exponent: int) -> float:
    """``value`` (SI) in a unit ``10**-exponent`` times SI, chosen to read back (:func:`_number`) to ``value``
    exactly when a float can (the shifted shortest repr, else its neighbours)."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write a non-finite number {value!r}.")
    if exponent == 0:
        return value
    guess = float(Decimal(repr(value)).scaleb(exponent))
    for direction in (math.inf, -math.inf):
        c = guess
        for _ in range(4):
            if float(Decimal(repr(c)).scaleb(-exponent)) == value:
                return c
            c = math.nextafter(c, direction)
    return guess


def _write(values, exponent: int = 0):
    a = np.asarray(values, dtype=float)
    if a.ndim == 0:
        return _to_unit(float(a), exponent)
    return [_write(v, exponent) for v in a]


def _direction_text(n) -> list:
    """A direction that normalizes (:func:`~.base.unit_vector`) to exactly the unit vector ``n``."""
    n = np.asarray(n, dtype=float)
    nonzero = np.abs(n[n != 0.0])
    for scale in (1.0, 1.0 / nonzero.min(), 1.0 / nonzero.max(), 3.0, 5.0, 7.0, 10.0, 11.0, 13.0, 100.0):
        v = n * scale
        if np.array_equal(unit_vector("direction", v), n):
            return v.tolist()
    return n.tolist()


# ---------------------------------------------------------------------------------------------- reading


def _check_keys(ctx: _Ctx, path: str, d, allowed, *, required=()) -> None:
    if not isinstance(d, dict):
        raise ctx.error(path, f"must be a mapping with keys among {list(allowed)}, got {_short(d)}.")
    for k in d:
        if k not in allowed:
            hint = difflib.get_close_matches(str(k), list(allowed), n=1, cutoff=0.5)
            extra = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ctx.error(_key(path, str(k)), f"is not a key of this source; allowed: {list(allowed)}.{extra}")
    for k in required:
        if k not in d:
            raise ctx.error(path, f"needs key {k!r} ({_required_hint(k)}).")


def _required_hint(key: str) -> str:
    return {"moment_A_m2": "the moment in A m^2, 3 numbers", "radius_mm": "the radius in mm, > 0",
            "length_mm": "the length in mm, > 0", "dimensions_mm": "3 side lengths in mm",
            "current_A": "the current in A", "B_mT": "the field in mT, [B_x, B_z] or [B_x, B_y, B_z]",
            "positions_mm": "the dipoles' positions in mm, (k, 3)", "offsets_mm": "the loops' offsets in mm",
            "sources": "a list of sources", "file": "a file path", "type": f"one of {list(TYPES)}",
            }.get(key, key)


def _positive_mm(ctx: _Ctx, path: str, d: dict, key: str) -> float:
    x = _number(ctx, _key(path, key), d[key], "mm", 3)
    if x <= 0.0:
        raise ctx.error(_key(path, key), f"must be > 0 (mm), got {d[key]!r}.")
    return x


def _one_of(ctx: _Ctx, path: str, d: dict, keys: tuple) -> str:
    given = [k for k in keys if k in d]
    if len(given) != 1:
        raise ctx.error(path, f"needs exactly one of {list(keys)}, got {given or 'none'}.")
    return given[0]


def _rotation(ctx: _Ctx, path: str, value) -> np.ndarray:
    """A rotation matrix from ``[[...], [...], [...]]`` (columns: the source's own axes) or ``{axis, angle_deg}``."""
    if isinstance(value, dict):
        _check_keys(ctx, path, value, ("axis", "angle_deg"), required=("axis", "angle_deg"))
        axis = _array(ctx, _key(path, "axis"), value["axis"], (3,), "dimensionless")
        if not axis.any():
            raise ctx.error(_key(path, "axis"), f"must be a non-zero direction, got {value['axis']!r}.")
        return rotation_about(axis, math.radians(_number(ctx, _key(path, "angle_deg"), value["angle_deg"], "deg")))
    R = _array(ctx, path, value, (3, 3), "a rotation matrix, or {axis: [x, y, z], angle_deg: a}")
    try:
        return rotation_matrix("rotation", R)
    except ValueError as exc:
        raise ctx.error(path, f"must be a rotation matrix (orthonormal to 1e-9, det +1; or write {{axis: [x, y, z], "
                              f"angle_deg: a}}): {exc}") from None


def _direction(ctx: _Ctx, path: str, d: dict, key: str) -> np.ndarray:
    if key not in d:
        return np.array([0.0, 0.0, 1.0])
    v = _array(ctx, _key(path, key), d[key], (3,), "a direction, dimensionless")
    if not v.any():
        raise ctx.error(_key(path, key), f"must be a non-zero direction, got {d[key]!r}.")
    return v


def _magnetization(ctx: _Ctx, path: str, d: dict, *, vector: bool) -> np.ndarray | float:
    key = _one_of(ctx, path, d, ("magnetization_kA_per_m", "remanence_T"))
    shape = (3,) if vector else ()
    if key == "remanence_T":
        B_r = _array(ctx, _key(path, key), d[key], shape, "T")
        M = B_r / MU0
    else:
        M = _array(ctx, _key(path, key), d[key], shape, "kA/m", -3)
    return M if vector else float(M)


def _build(ctx: _Ctx, path: str, what: str, make):
    """Call a source's constructor; its own range checks are reported at ``path``."""
    try:
        return make()
    except ValueError as exc:
        raise (ctx.error(path, f"({what}): {exc}") if path else ValueError(f"{ctx.where}: {what}: {exc}")) from None


def _resolve_file(ctx: _Ctx, path: str, value, suffixes: tuple) -> Path:
    if not isinstance(value, (str, os.PathLike)) or not os.fspath(value):
        raise ctx.error(path, f"must be a file path ({', '.join(suffixes)}), got {value!r}.")
    p = Path(os.fspath(value)).expanduser()
    if not p.is_absolute():
        p = ctx.base / p
    if p.suffix.lower() not in suffixes:
        raise ctx.error(path, f"must be a {' or '.join(suffixes)} file, got {os.fspath(value)!r}.")
    if not p.is_file():
        raise ctx.error(path, f"names a file that does not exist: {str(p)!r}.")
    return p


def _coil_system(ctx: _Ctx, path: str, d: dict, currents) -> Source:
    key = _one_of(ctx, path, d, ("name", "file"))
    if "max_current_A" in d:
        v = d["max_current_A"]
        limit = (_array(ctx, _key(path, "max_current_A"), v, (-1,), "A") if isinstance(v, (list, tuple))
                 else _number(ctx, _key(path, "max_current_A"), v, "A"))
    else:
        limit = None
    normalize = d.get("normalize_directions", False)
    if not isinstance(normalize, bool):
        raise ctx.error(_key(path, "normalize_directions"), f"must be true or false, got {normalize!r}.")
    if key == "name":
        name = d["name"]
        if not isinstance(name, str) or name not in CALIBRATIONS:
            hint = difflib.get_close_matches(str(name).lower(), list(CALIBRATIONS), n=1, cutoff=0.5)
            extra = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ctx.error(_key(path, "name"), f"must be one of {list(CALIBRATIONS)} (or give file: an MPEM "
                                                f".yaml), got {name!r}.{extra}")
        system = _build(ctx, path, "coil_system", lambda: CoilSystem.from_calibration(
            name, max_current=limit, normalize_directions=normalize))
        origin = {"type": "coil_system", "name": name}
    else:
        file = _resolve_file(ctx, _key(path, "file"), d["file"], (".yaml", ".yml"))
        system = _build(ctx, path, "coil_system", lambda: CoilSystem.from_file(
            file, max_current=limit, normalize_directions=normalize))
        origin = {"type": "coil_system", "file": str(file)}
    if "currents_A" in d and currents is not None:
        raise ctx.error(_key(path, "currents_A"), "is given twice: in the file and as currents=; give one.")
    if "currents_A" not in d and currents is None:
        raise ctx.error(path, f"needs key 'currents_A': one current (A) per coil ({system.n_coils}: "
                              f"{', '.join(system.coil_names)}).")
    raw = d["currents_A"] if currents is None else currents
    where = _key(path, "currents_A") if currents is None else "currents"
    if isinstance(raw, np.ndarray):
        raw = raw.tolist()
    if not isinstance(raw, (list, tuple)) or len(raw) != system.n_coils:
        got = f"{len(raw)} values" if isinstance(raw, (list, tuple)) else repr(raw)
        raise ctx.error(where, f"must hold one current (A) per coil of {system.name}: {system.n_coils} "
                               f"({', '.join(system.coil_names)}), got {got}.")
    I = _array(ctx, where, raw, (system.n_coils,), "A")
    source = _build(ctx, where, "coil_system", lambda: system.at_currents(I))
    if limit is not None:
        origin["max_current_A"] = limit.tolist() if isinstance(limit, np.ndarray) else limit
    if normalize:
        origin["normalize_directions"] = True
    origin["currents_A"] = I.tolist()
    _ORIGINS[source] = origin
    return source


def _grid(ctx: _Ctx, path: str, d: dict) -> GridField:
    file = _resolve_file(ctx, _key(path, "file"), d["file"], (".npz",))
    degree = d.get("degree", 10)
    if isinstance(degree, bool) or not isinstance(degree, int):
        raise ctx.error(_key(path, "degree"), f"must be an integer (2 to 20), got {degree!r}.")
    try:
        with np.load(file, allow_pickle=False) as z:
            arrays = {k: np.asarray(z[k]) for k in z.files}
    except (OSError, ValueError) as exc:
        raise ctx.error(_key(path, "file"), f"is not a readable .npz file: {exc}") from None
    fp = f"{_key(path, 'file')} ({file.name})"
    unknown = [k for k in arrays if k not in _GRID_ARRAYS]
    if unknown:
        hint = difflib.get_close_matches(unknown[0], _GRID_ARRAYS, n=1, cutoff=0.5)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ctx.error(fp, f"has an unknown array {unknown[0]!r}; allowed: {list(_GRID_ARRAYS)}.{extra}")
    for k in _GRID_ARRAYS[:4]:
        if k not in arrays:
            raise ctx.error(fp, f"needs the array {k!r}: the grid axes x_mm, y_mm, z_mm (mm) and B_mT "
                                "(nx, ny, nz, 3).")
    axes = tuple(arrays[k].astype(float) * 1e-3 for k in ("x_mm", "y_mm", "z_mm"))
    B = arrays["B_mT"].astype(float) * 1e-3
    G = arrays["G_mT_per_m"].astype(float) * 1e-3 if "G_mT_per_m" in arrays else None
    source = _build(ctx, fp, "grid", lambda: GridField(axes, B, G, degree=degree))
    _ORIGINS[source] = {"type": "grid", "file": str(file), "degree": degree}
    return source


def _read(ctx: _Ctx, path: str, d, currents=None, *, top: bool = False) -> Source:
    if not isinstance(d, dict):
        raise ctx.error(path, f"must be a mapping describing a source (with 'type', one of {list(TYPES)}), "
                              f"got {_short(d)}.")
    kind = d.get("type", "sum" if "sources" in d else None)
    if kind is None:
        raise ctx.error(path, f"needs key 'type' (one of {list(TYPES)}), or 'sources' for a sum.")
    if kind not in _KEYS:
        hint = [t for t in TYPES if t.startswith(str(kind))] or difflib.get_close_matches(str(kind), TYPES, n=1,
                                                                                            cutoff=0.5)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ctx.error(_key(path, "type"), f"must be one of {list(TYPES)}, got {kind!r}.{extra}")
    allowed = (*_COMMON, *_KEYS[kind], *(("magsoft_source",) if top else ()))
    if top and "magsoft_source" in d and d["magsoft_source"] != FORMAT_VERSION:
        raise ctx.error("magsoft_source", f"must be {FORMAT_VERSION} (the format version), got "
                                          f"{d['magsoft_source']!r}.")
    required = {"uniform": ("B_mT",), "dipole": ("moment_A_m2",), "dipoles": ("positions_mm",),
                "sphere": ("radius_mm",), "cylinder": ("radius_mm", "length_mm"), "cuboid": ("dimensions_mm",),
                "loop": ("radius_mm", "current_A"), "coaxial_loops": ("offsets_mm", "radii_mm", "currents_A"),
                "helmholtz": ("radius_mm", "current_A"), "maxwell": ("radius_mm", "current_A"),
                "grid": ("file",), "sum": ("sources",)}.get(kind, ())
    _check_keys(ctx, path, d, allowed, required=required)
    if currents is not None and kind != "coil_system":
        raise ctx.error(path, f"is a {kind!r} source: currents= applies to a coil_system only.")
    if "description" in d and not isinstance(d["description"], str):
        raise ctx.error(_key(path, "description"), f"must be text, got {d['description']!r}.")
    p = (_array(ctx, _key(path, "position_mm"), d["position_mm"], (3,), "mm", 3) if "position_mm" in d
         else np.zeros(3))
    R = _rotation(ctx, _key(path, "rotation"), d["rotation"]) if "rotation" in d else None
    Rm = np.eye(3) if R is None else R

    def mm(key):
        return _positive_mm(ctx, path, d, key)

    if kind == "uniform":
        B = _array(ctx, _key(path, "B_mT"), d["B_mT"], (-1,), "mT", 3)
        if B.shape not in ((2,), (3,)):
            raise ctx.error(_key(path, "B_mT"), f"must be [B_x, B_z] or [B_x, B_y, B_z] (mT), got {d['B_mT']!r}.")
        return _placed(ctx, path, _build(ctx, path, kind, lambda: Uniform(B)), d, p, R)
    if kind == "dipole":
        m = _array(ctx, _key(path, "moment_A_m2"), d["moment_A_m2"], (3,), "A m^2")
        return _build(ctx, path, kind, lambda: PointDipole(position=p, moment=Rm @ m if R is not None else m))
    if kind == "dipoles":
        pos = _array(ctx, _key(path, "positions_mm"), d["positions_mm"], (-1, 3), "mm", 3)
        key = _one_of(ctx, path, d, ("moments_A_m2", "moments_T_m3"))
        mom = _array(ctx, _key(path, key), d[key], (pos.shape[0], 3), key.split("_", 1)[1].replace("_", " "))
        if R is not None:
            pos, mom = pos @ R.T, mom @ R.T
        if "position_mm" in d:
            pos = pos + p
        scale = 1.0 if key == "moments_T_m3" else None
        return _build(ctx, path, kind, lambda: DipoleSet(pos, mom) if scale is None
                      else DipoleSet(pos, mom, scale=scale))
    if kind == "sphere":
        a = mm("radius_mm")
        key = _one_of(ctx, path, d, ("magnetization_kA_per_m", "remanence_T", "moment_A_m2"))
        if key == "moment_A_m2":
            m = _array(ctx, _key(path, key), d[key], (3,), "A m^2")
            m = Rm @ m if R is not None else m
            return _build(ctx, path, kind, lambda: SphereMagnet(position=p, radius=a, moment=m))
        M = _magnetization(ctx, path, d, vector=True)
        M = Rm @ M if R is not None else M
        return _build(ctx, path, kind, lambda: SphereMagnet(position=p, radius=a, magnetization=M))
    if kind == "cylinder":
        a, length = mm("radius_mm"), mm("length_mm")
        axis = _direction(ctx, path, d, "axis")
        axis = Rm @ axis if R is not None else axis
        M = _magnetization(ctx, path, d, vector=False)
        return _build(ctx, path, kind, lambda: CylinderMagnet(position=p, axis=axis, radius=a, length=length,
                                                              magnetization=M))
    if kind == "cuboid":
        dims = _array(ctx, _key(path, "dimensions_mm"), d["dimensions_mm"], (3,), "mm", 3)
        if (dims <= 0).any():
            raise ctx.error(_key(path, "dimensions_mm"), f"must be 3 side lengths > 0 (mm), got "
                                                         f"{d['dimensions_mm']!r}.")
        M = _magnetization(ctx, path, d, vector=True)
        return _build(ctx, path, kind, lambda: CuboidMagnet(position=p, dimensions=dims, magnetization=M,
                                                            rotation=R))
    if kind in ("loop", "helmholtz", "maxwell"):
        a = mm("radius_mm")
        current = _number(ctx, _key(path, "current_A"), d["current_A"], "A")
        normal = _direction(ctx, path, d, "normal")
        normal = Rm @ normal if R is not None else normal
        make = {"loop": lambda: CircularLoop(center=p, normal=normal, radius=a, current=current),
                "helmholtz": lambda: helmholtz_pair(center=p, normal=normal, radius=a, current=current),
                "maxwell": lambda: maxwell_pair(center=p, normal=normal, radius=a, current=current)}[kind]
        source = _build(ctx, path, kind, make)
        if kind != "loop":  # written back as the pair: its loops' offsets (sqrt(3) R / 2) need not read back in mm
            _ORIGINS[source] = {"type": kind, "position_mm": _write(p, 3), "normal": _direction_text(source.normal),
                                "radius_mm": _write(a, 3), "current_A": current}
        return source
    if kind == "coaxial_loops":
        off = _array(ctx, _key(path, "offsets_mm"), d["offsets_mm"], (-1,), "mm", 3)
        k = off.size
        radii = _per_loop(ctx, path, d, "radii_mm", k, "mm", 3)
        if (radii <= 0).any():
            raise ctx.error(_key(path, "radii_mm"), f"must be > 0 (mm), got {d['radii_mm']!r}.")
        cur = _per_loop(ctx, path, d, "currents_A", k, "A", 0)
        normal = _direction(ctx, path, d, "normal")
        normal = Rm @ normal if R is not None else normal
        return _build(ctx, path, kind, lambda: CoaxialLoops(center=p, normal=normal, offsets=off, radii=radii,
                                                            currents=cur))
    if kind == "coil_system":
        return _placed(ctx, path, _coil_system(ctx, path, d, currents), d, p, R)
    if kind == "grid":
        return _placed(ctx, path, _grid(ctx, path, d), d, p, R)
    items = d["sources"]
    if not isinstance(items, list) or not items:
        raise ctx.error(_key(path, "sources"), f"must be a non-empty list of sources, got {_short(items)}.")
    parts = [_read(ctx, f"{_key(path, 'sources')}[{i}]", s) for i, s in enumerate(items)]
    return _placed(ctx, path, SourceSum(parts), d, p, R)


def _per_loop(ctx, path, d, key, k, unit, exponent):
    v = d[key]
    if isinstance(v, (list, tuple)):
        a = _array(ctx, _key(path, key), v, (-1,), unit, exponent)
        if a.size != k:
            raise ctx.error(_key(path, key), f"must be one number or one per offset ({k}) ({unit}), got "
                                             f"{len(v)} values.")
        return a
    return np.full(k, _number(ctx, _key(path, key), v, unit, exponent))


def _placed(ctx, path, source, d, p, R):
    if "position_mm" not in d and "rotation" not in d:
        return source
    return _build(ctx, path, "placement", lambda: Transformed(source, p, R))


def source_from_dict(d: dict, *, currents=None, where: str = "source dict", base_dir=None) -> Source:
    """A field source from its description (module docstring: types, keys, units).

    Parameters
    ----------
    d : dict
        The description: ``{"type": ..., ...}``, or ``{"sources": [...]}`` for a sum.
    currents : array_like, optional
        Currents (A) of a top-level ``coil_system`` that gives no ``currents_A``.
    where : str
        What the messages call the input (a file name).
    base_dir : path, optional
        Folder that relative ``file`` paths start from (default the working directory).

    Returns
    -------
    Source

    Raises
    ------
    ValueError
        Naming ``where``, the key path (``sources[1].moment_A_m2``), what was expected and what was received.

    Examples
    --------
    >>> import numpy as np
    >>> s = source_from_dict({"type": "dipole", "position_mm": [0, 0, 0], "moment_A_m2": [0, 0, 1]})
    >>> round(float(s.field(np.array([[0.0, 0.0, 0.1]]))[0, 2]), 12)   # mu0/(4 pi) 2 m / z^3
    0.0002
    """
    ctx = _Ctx(where, Path(base_dir) if base_dir is not None else Path.cwd())
    if currents is not None and not isinstance(currents, (list, tuple, np.ndarray)):
        raise ctx.error("currents", f"must be a list of currents (A), one per coil, got {currents!r}.")
    return _read(ctx, "", d, currents, top=True)


def _read_file(path: Path) -> dict:
    where = f"source file {str(path)!r}"
    if not path.exists():
        raise ValueError(f"{where} does not exist.")
    if not path.is_file():
        raise ValueError(f"{where} is not a file.")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise ValueError(f"{where} is larger than {MAX_FILE_BYTES // 2**20} MiB.")
    import yaml

    try:
        text = path.read_text(encoding="utf-8")
        data = json.loads(text) if path.suffix.lower() == ".json" else yaml.safe_load(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{where} is not valid JSON: {exc}") from None
    except yaml.YAMLError as exc:
        raise ValueError(f"{where} is not valid YAML: {' '.join(str(exc).split())}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"{where} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise ValueError(f"{where} cannot be read: {exc.strerror or exc}") from None
    return data


def load_source(spec, *, currents=None) -> Source:
    """A field source from a calibration name, a YAML or JSON source file, a dict, or a source.

    Parameters
    ----------
    spec : str, path, dict or Source
        A name of :data:`~.coils.CALIBRATIONS` (``"navion"``, ``"cardiomag"``, ...: needs ``currents``), a
        ``.yml``/``.yaml``/``.json`` source file (module docstring; an MPEM calibration file, with
        ``Coil_List``, is read as a coil system and needs ``currents``), a dict (:func:`source_from_dict`), or a
        :class:`~.base.Source` (returned as it is).
    currents : array_like, optional
        Coil currents (A), one per coil, for a coil system that does not state its own.

    Returns
    -------
    Source

    Examples
    --------
    >>> import numpy as np
    >>> navion = load_source("navion", currents=[10.0, 0.0, 0.0])
    >>> round(float(navion.field(np.zeros((1, 3)))[0, 2]) * 1e3, 2)   # B_z at the centre (mT)
    -4.14
    """
    if isinstance(spec, Source):
        if currents is not None:
            raise ValueError("load_source: currents= applies to a coil system by name or file, not to a "
                             f"{type(spec).__name__}.")
        return spec
    if isinstance(spec, CoilSystem):
        if currents is None:
            raise ValueError(f"load_source: the coil system {spec.name!r} needs currents= (A, one per coil: "
                             f"{spec.n_coils}).")
        try:
            return spec.at_currents(currents)
        except ValueError as exc:
            raise ValueError(f"load_source: {exc}") from None
    if isinstance(spec, MovingSource):
        raise ValueError("load_source: a MovingSource depends on time; give its pose at a time: source.at(t).")
    if isinstance(spec, dict):
        return source_from_dict(spec, currents=currents)
    if not isinstance(spec, (str, os.PathLike)) or not os.fspath(spec):
        raise ValueError(f"load_source: spec must be a calibration name ({', '.join(CALIBRATIONS)}), a source "
                         f"file (.yml, .yaml, .json), a dict or a source, got {spec!r}.")
    text = os.fspath(spec)
    path = Path(text).expanduser()
    if path.suffix.lower() not in SOURCE_SUFFIXES:
        if text in CALIBRATIONS:
            if currents is None:
                n = CoilSystem.from_calibration(text).n_coils
                raise ValueError(f"load_source: the coil system {text!r} needs currents= (A, one per coil: {n}).")
            return source_from_dict({"type": "coil_system", "name": text}, currents=currents,
                                    where=f"load_source({text!r})")
        hint = difflib.get_close_matches(text.lower(), list(CALIBRATIONS), n=1, cutoff=0.5)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ValueError(f"load_source: {text!r} is neither a calibration name ({', '.join(CALIBRATIONS)}) nor a "
                         f"source file (.yml, .yaml, .json).{extra}")
    data = _read_file(path)
    where = f"source file {path.name!r}"
    if isinstance(data, dict) and "Coil_List" in data:  # an MPEM calibration itself
        return source_from_dict({"type": "coil_system", "file": str(path)}, currents=currents, where=where)
    return source_from_dict(data, currents=currents, where=where, base_dir=path.resolve().parent)


# ---------------------------------------------------------------------------------------------- writing


def _moved(source: Source, p: np.ndarray, R: np.ndarray) -> Source | None:
    """``Transformed(source, p, R)`` as a source of the same kind moved by its parameters, where it has them."""
    if isinstance(source, PointDipole):
        return PointDipole(position=p + R @ np.array(source.position), moment=R @ np.array(source.moment))
    if isinstance(source, SphereMagnet):
        return SphereMagnet(position=p + R @ np.array(source.position), radius=source.radius,
                            magnetization=R @ np.array(source.magnetization))
    if isinstance(source, CylinderMagnet):
        return CylinderMagnet(position=p + R @ np.array(source.position), axis=R @ np.array(source.axis),
                              radius=source.radius, length=source.length, magnetization=source.magnetization)
    if isinstance(source, CuboidMagnet):
        return CuboidMagnet(position=p + R @ source.position, dimensions=source.dimensions,
                            magnetization=source.magnetization, rotation=R @ source.rotation)
    if isinstance(source, CircularLoop):
        return CircularLoop(center=p + R @ np.array(source.center), normal=R @ np.array(source.normal),
                            radius=source.radius, current=source.current)
    if isinstance(source, CoaxialLoops):
        return CoaxialLoops(center=p + R @ source.center, normal=R @ source.normal, offsets=source.offsets,
                            radii=source.radii, currents=source.currents)
    if isinstance(source, DipoleSet) and source not in _ORIGINS:
        return DipoleSet(source.positions @ R.T + p, source.moments @ R.T, scale=source.scale)
    return None


def _relative(file: str, base: Path | None) -> str:
    if base is None:
        return file
    try:
        return Path(file).resolve().relative_to(base.resolve()).as_posix()
    except ValueError:
        return file


def _to_dict(source, base: Path | None, path: str) -> dict:
    if _hashable(source) and source in _ORIGINS:
        d = dict(_ORIGINS[source])
        if "file" in d:
            d["file"] = _relative(d["file"], base)
        return d
    if isinstance(source, Transformed):
        moved = _moved(source.source, source.position, source.rotation)
        if moved is not None:
            return _to_dict(moved, base, path)
        d = _to_dict(source.source, base, path)
        if "position_mm" in d or "rotation" in d:  # nested placements: compose them
            p0 = np.array(d.pop("position_mm", [0.0, 0.0, 0.0]), dtype=float) * 1e-3
            R0 = np.array(d.pop("rotation", np.eye(3)), dtype=float)
            p, R = source.position + source.rotation @ p0, source.rotation @ R0
        else:
            p, R = source.position, source.rotation
        if p.any():
            d["position_mm"] = _write(p, 3)
        if not np.array_equal(R, np.eye(3)):
            d["rotation"] = R.tolist()
        return d
    if isinstance(source, Uniform):
        return {"type": "uniform", "B_mT": _write(source.B, 3)}
    if isinstance(source, PointDipole):
        return {"type": "dipole", "position_mm": _write(source.position, 3), "moment_A_m2": list(source.moment)}
    if isinstance(source, DipoleSet):
        d = {"type": "dipoles", "positions_mm": _write(source.positions, 3)}
        if source.scale == 1.0:
            d["moments_T_m3"] = source.moments.tolist()
        elif source.scale == MU0_4PI:
            d["moments_A_m2"] = source.moments.tolist()
        else:
            d["moments_T_m3"] = (source.moments * source.scale).tolist()
        return d
    if isinstance(source, SphereMagnet):
        return {"type": "sphere", "position_mm": _write(source.position, 3), "radius_mm": _write(source.radius, 3),
                "magnetization_kA_per_m": _write(source.magnetization, -3)}
    if isinstance(source, CylinderMagnet):
        return {"type": "cylinder", "position_mm": _write(source.position, 3), "axis": _direction_text(source.axis),
                "radius_mm": _write(source.radius, 3), "length_mm": _write(source.length, 3),
                "magnetization_kA_per_m": _write(source.magnetization, -3)}
    if isinstance(source, CuboidMagnet):
        d = {"type": "cuboid", "position_mm": _write(source.position, 3),
             "dimensions_mm": _write(source.dimensions, 3),
             "magnetization_kA_per_m": _write(source.magnetization, -3)}
        if not np.array_equal(source.rotation, np.eye(3)):
            d["rotation"] = source.rotation.tolist()
        return d
    if isinstance(source, CircularLoop):
        return {"type": "loop", "position_mm": _write(source.center, 3), "normal": _direction_text(source.normal),
                "radius_mm": _write(source.radius, 3), "current_A": source.current}
    if isinstance(source, CoaxialLoops):
        return {"type": "coaxial_loops", "position_mm": _write(source.center, 3),
                "normal": _direction_text(source.normal), "offsets_mm": _write(source.offsets, 3),
                "radii_mm": _write(source.radii, 3), "currents_A": source.currents.tolist()}
    if isinstance(source, SourceSum):
        return {"type": "sum", "sources": [_to_dict(s, base, f"{_key(path, 'sources')}[{i}]")
                                           for i, s in enumerate(source.sources)]}
    at = f" at {path}" if path else ""
    if isinstance(source, CoilSystem):
        raise ValueError(f"source_to_dict{at}: a CoilSystem needs its currents: write coils.at_currents(I), or "
                         "load it with load_source(name, currents=I) to keep its name.")
    if isinstance(source, MovingSource):
        raise ValueError(f"source_to_dict{at}: a MovingSource depends on time; write its pose at a time: "
                         "source.at(t).")
    if isinstance(source, GridField):
        raise ValueError(f"source_to_dict{at}: a GridField keeps its fit, not its samples: only one read from a "
                         ".npz file (type: grid) can be written. Save the samples (x_mm, y_mm, z_mm, B_mT) with "
                         "numpy.savez and describe it as {type: grid, file: ...}.")
    raise ValueError(f"source_to_dict{at}: cannot write a {type(source).__name__}; the types written are "
                     f"{list(TYPES)}.")


def _hashable(source) -> bool:
    try:
        hash(source)
    except TypeError:
        return False
    return True


def source_to_dict(source, *, base_dir=None) -> dict:
    """The description of ``source`` that :func:`source_from_dict` reads back to the same field.

    Written: every type of the module docstring; a coil system or grid read by :func:`load_source` is written
    as its name or file and currents (paths relative to ``base_dir`` when under it); a :class:`~.base.Transformed`
    magnet, dipole or loop as the moved source, any other with ``position_mm`` and ``rotation``. Numbers read
    back to the same floats (to the bit) wherever a float in the file's unit can give them, which covers every
    number that came from a file. A ``CoilSystem`` without currents, a ``MovingSource``, a ``GridField`` not read
    from a file and unknown sources are refused (ValueError).
    """
    base = Path(base_dir) if base_dir is not None else None
    return _to_dict(source, base, "")


def save_source(source, path) -> Path:
    """Write ``source`` to a YAML or JSON file (by the suffix) that :func:`load_source` reads back; returns the path."""
    path = Path(path)
    if path.suffix.lower() not in SOURCE_SUFFIXES:
        raise ValueError(f"save_source path must end in {', '.join(SOURCE_SUFFIXES)}, got {str(path)!r}.")
    d = {"magsoft_source": FORMAT_VERSION, **source_to_dict(source, base_dir=path.resolve().parent)}
    if path.suffix.lower() == ".json":
        text = json.dumps(d, indent=2) + "\n"
    else:
        import yaml

        text = yaml.safe_dump(d, sort_keys=False, default_flow_style=None, width=110)
    return write_text_atomic(path, text)


def source_markers(source) -> list[tuple[str, np.ndarray]]:
    """Where a source's parts are: ``(kind, positions (k, 3) in m)`` for its dipoles, magnet centres and loop
    centres (kinds ``"dipole"``, ``"magnet"``, ``"loop"``), through sums and placements; empty when it knows
    none (a uniform field, a grid)."""
    out = []
    if isinstance(source, Transformed):
        for kind, pts in source_markers(source.source):
            out.append((kind, pts @ source.rotation.T + source.position))
    elif isinstance(source, SourceSum):
        for s in source.sources:
            out.extend(source_markers(s))
    elif isinstance(source, PointDipole):
        out.append(("dipole", np.array([source.position])))
    elif isinstance(source, DipoleSet):
        out.append(("dipole", source.positions.copy()))
    elif isinstance(source, (SphereMagnet, CylinderMagnet)):
        out.append(("magnet", np.array([source.position])))
    elif isinstance(source, CuboidMagnet):
        out.append(("magnet", source.position.reshape(1, 3).copy()))
    elif isinstance(source, CircularLoop):
        out.append(("loop", np.array([source.center])))
    elif isinstance(source, CoaxialLoops):
        out.append(("loop", source.center + source.offsets[:, None] * source.normal))
    return out


__all__ = ["FORMAT_VERSION", "SOURCE_SUFFIXES", "TYPES", "load_source", "save_source", "source_from_dict",
           "source_markers", "source_to_dict"]

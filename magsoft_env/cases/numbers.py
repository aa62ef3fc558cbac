"""Numbers in files, exact to the bit: read from their digits, written so that they read back the same.

A file holds a length in mm; the model wants metres. ``18 * 1e-3`` is ``0.018000000000000002``, not the
``18e-3`` a user types, and 3 % of all metre values have no float ``d`` at all with ``d / 1000`` equal to
them. So the readers here keep each number's digits (:class:`FileNumber`) and convert the *decimal*
number: ``milli("18")`` is the float nearest to 0.018, exactly ``18e-3``; and the writers shift the
decimal point of a value's shortest repr (``0.0016829419696157931`` m is written ``1.6829419696157931``
mm), which reads back to the same float. Angles in degrees use pi to 50 digits, and are written with as
many digits as needed to read back exactly (the float's repr in most cases).
"""

from __future__ import annotations

import json
import math
from decimal import Decimal, localcontext

import yaml

#: pi to 50 significant digits, for degrees <-> radians in decimal arithmetic.
_PI = Decimal("3.1415926535897932384626433832795028841971693993751")


class FileNumber(float):
    """A float read from a file (or to be written to one) that keeps its digits in ``text``."""

    text: str

    def __new__(cls, text: str):
        obj = super().__new__(cls, float(text))
        obj.text = text
        return obj

    def __reduce__(self):
        return (float, (float(self),))


def _digits(x) -> Decimal:
    if isinstance(x, FileNumber):
        return Decimal(x.text)
    if isinstance(x, (int,)) and not isinstance(x, bool):
        return Decimal(x)
    return Decimal(repr(float(x)))


def milli(x) -> float:
    """A milli-unit number (mm, mT, ms) in SI, from its digits: ``x / 1000`` rounded once."""
    return float(_digits(x).scaleb(-3))


def kilo(x) -> float:
    """A kilo-unit number (kA/m) in SI, from its digits."""
    return float(_digits(x).scaleb(3))


def mega(x) -> float:
    """A mega-unit number (MPa) in SI, from its digits."""
    return float(_digits(x).scaleb(6))


def same(x) -> float:
    """A number already in SI (a volume fraction)."""
    return float(x)


def radians(x) -> float:
    """Degrees to radians: ``math.radians`` for a number of up to 17 digits (``15`` reads as ``math.radians(15)``),
    50-digit decimal arithmetic rounded once for a longer one (what :func:`to_degrees` writes for the few
    angles ``math.radians`` cannot reach)."""
    d = _digits(x)
    if len(d.as_tuple().digits) <= 17:
        return math.radians(float(d))
    with localcontext() as ctx:
        ctx.prec = 60
        return float(d * _PI / 180)


def _text(d: Decimal) -> str:
    """Decimal as a YAML/JSON float literal: a dot in the mantissa, a signed exponent when one is needed."""
    if d.is_zero():
        return "0.0"
    sign, digits, exp = d.as_tuple()
    s = "".join(map(str, digits)).rstrip("0") or "0"
    exp += len(digits) - len(s)  # trailing zeros moved into the exponent
    point = len(s) + exp  # position of the decimal point from the left of s
    if -5 <= point <= 17:
        if point <= 0:
            body = "0." + "0" * (-point) + s
        elif point >= len(s):
            body = s + "0" * (point - len(s)) + ".0"
        else:
            body = s[:point] + "." + s[point:]
    else:
        e = point - 1
        body = f"{s[0]}.{s[1:] or '0'}e{'+' if e >= 0 else '-'}{abs(e):02d}"
    return ("-" if sign else "") + body


def to_unit(value: float, exponent: int) -> FileNumber:
    """``value`` (SI) in a unit 10**-exponent times SI (3 for mm), digits shifted exactly."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write a non-finite number {value!r} to a file.")
    return FileNumber(_text(Decimal(repr(value)).scaleb(exponent)))


def to_milli(value: float) -> FileNumber:
    """``value`` (m, T, s) as mm, mT, ms: reads back with :func:`milli` to the same float."""
    return to_unit(value, 3)


def to_degrees(value: float) -> FileNumber:
    """``value`` (rad) in degrees that read back with :func:`radians` to the same float: the shortest repr
    of a float near ``math.degrees(value)`` when ``math.radians`` reaches the value from one (``15.0`` for
    ``math.radians(15)``), else 18 to 25 digits."""
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write a non-finite angle {value!r} to a file.")
    guess, found = math.degrees(value), []
    for direction in (math.inf, -math.inf):
        c = guess
        for _ in range(4):
            if math.radians(c) == value:
                found.append(repr(c))
            c = math.nextafter(c, direction)
    if found:
        return FileNumber(min(found, key=len))
    with localcontext() as ctx:
        ctx.prec = 60
        exact = Decimal(value) * 180 / _PI
    for digits in range(18, 26):
        with localcontext() as ctx:
            ctx.prec = digits
            candidate = FileNumber(_text(+exact))
        if radians(candidate) == value:
            return candidate
    return candidate


# ---------------------------------------------------------------------------------------------
# YAML and JSON that keep the digits


class _Loader(yaml.SafeLoader):
    """Safe YAML whose floats are :class:`FileNumber`."""


def _float(loader, node):
    value = loader.construct_yaml_float(node)
    text = node.value.replace("_", "")
    try:
        Decimal(text)
    except ArithmeticError:
        return value  # .inf, .nan: the checks refuse them later
    return FileNumber(text) if math.isfinite(value) else value


_Loader.add_constructor("tag:yaml.org,2002:float", _float)


class _Dumper(yaml.SafeDumper):
    """Safe YAML that writes :class:`FileNumber` digits as they are and folds long texts."""


def _represent_number(dumper, value: FileNumber):
    return dumper.represent_scalar("tag:yaml.org,2002:float", value.text)


def _represent_str(dumper, value: str):
    style = ">" if len(value) > 80 and "\n" not in value else None
    return dumper.represent_scalar("tag:yaml.org,2002:str", value, style=style)


_Dumper.add_representer(FileNumber, _represent_number)
_Dumper.add_representer(str, _represent_str)


def load_yaml(text: str):
    return yaml.load(text, Loader=_Loader)  # noqa: S506  (a SafeLoader subclass)


def dump_yaml(data) -> str:
    return yaml.dump(data, Dumper=_Dumper, sort_keys=False, default_flow_style=None, width=100, allow_unicode=True)


def load_json(text: str):
    return json.loads(text, parse_float=FileNumber)


def dump_json(data, indent: int = 2) -> str:
    """JSON with :class:`FileNumber` digits as they are (json.dumps would print the float's repr)."""
    return _json(data, indent, 0) + "\n"


def _json(v, indent: int, level: int) -> str:
    pad, inner = " " * (indent * level), " " * (indent * (level + 1))
    if isinstance(v, dict):
        if not v:
            return "{}"
        items = [f"{inner}{json.dumps(str(k))}: {_json(x, indent, level + 1)}" for k, x in v.items()]
        return "{\n" + ",\n".join(items) + "\n" + pad + "}"
    if isinstance(v, (list, tuple)):
        if all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v):
            return "[" + ", ".join(_json(x, indent, level + 1) for x in v) + "]"
        if not v:
            return "[]"
        return "[\n" + ",\n".join(inner + _json(x, indent, level + 1) for x in v) + "\n" + pad + "]"
    if isinstance(v, FileNumber):
        return v.text
    return json.dumps(v)


__all__ = ["FileNumber", "dump_json", "dump_yaml", "kilo", "load_json", "load_yaml", "mega", "milli", "radians",
           "same", "to_degrees", "to_milli", "to_unit"]

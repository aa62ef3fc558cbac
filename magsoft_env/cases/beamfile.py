"""The beam as file data (mm, mT, deg in the key names): read by statics presets and robot files alike.

A beam block::

    {"length_mm": 25.0, "width_mm": 5.0, "thickness_mm": 1.13,
     "material": {"E0_MPa": 0.062, "particle_magnetization_kA_per_m": 575, "density_kg_per_m3": 1940},
     "volume_fraction": 0.2,
     "magnetization": {"kind": "uniform", "angle_deg": 0}}

``volume_fraction`` is a number, ``{"cells": [...], "fractions": [...]}`` (cells of equal length unless
``fractions`` says otherwise), or an object with a ``kind``: ``piecewise_linear`` (``s_mm``, ``values``),
``samples`` (``s_mm`` and ``values`` for one cubic spline, or ``pieces``: a list of such, splines
between breakpoints) or ``expression`` (``phi``: an expression in ``s``, mm; optional ``kinks_s_mm``).

Magnetization kinds: ``uniform`` (``angle_deg``), ``alternating_cells`` (``cells``, ``angle_deg``,
optional ``cell_length_mm``), ``cells`` (``angles_deg``, optional ``fractions``), ``jig_function``
(``z_mm``: an expression in ``x`` (mm), ``x_start_mm``, ``x_end_mm``, optional ``kinks_x_mm``,
``samples``), ``jig_polyline`` (``x_mm``, ``z_mm``), ``jig_points`` (``x_mm``, ``z_mm``, optional
``corners``: point indices), ``piecewise_linear`` (``s_mm``, ``angles_deg``), ``samples`` (``s_mm`` and
``angles_deg``, or ``pieces`` of them; ``piecewise_constant`` for a polyline jig's pieces) and
``expression`` (``angle_deg``: an expression in ``s``, mm; optional ``kinks_s_mm``). A jig sets the
beam length to its arc length unless ``length_mm`` says otherwise.

A magnetization with a component across the width is of kind ``direction``: ``axial``, ``width`` and
``thickness`` (each 0 when omitted), the components along the undeformed strip, across its width and
through its thickness (dimensionless; only the direction counts), each written like a volume fraction:
a number, ``{"cells": [...], "fractions": [...]}`` or an object with a ``kind``: ``piecewise_linear``
(``s_mm``, ``values``), ``samples`` (``s_mm`` and ``values``, or ``pieces``; ``piecewise_constant`` for
pieces held constant) or ``expression`` (``value``: an expression in ``s``, mm; optional ``kinks_s_mm``)::

    "magnetization": {"kind": "direction", "axial": 1, "width": {"cells": [1, -1]}, "thickness": 0}

``material.poisson_ratio`` (dimensionless, in [0, 0.5]; default 0.49) sets the shear modulus of the
3D rod. ``material.density_kg_per_m3`` is a number or ``{"rule_of_mixtures": {"particle_kg_per_m3": ..,
"matrix_kg_per_m3": ..}}``.

:func:`beam_to_dict` writes every profile family this way. Numbers are written so that reading them
back gives the same floats (a value ``d`` in mm is chosen with ``d * 1e-3`` equal to the metres), so a
beam survives a round trip exactly; a profile of a Python function cannot be written (say
``sample_functions=True`` to store it as samples, or give it as an expression).

Expressions are read by :func:`magsoft_env.cases.expressions.compile_expression`: numbers, the
variable, ``pi``, arithmetic, comparisons and a few numpy functions; no Python code is ever executed.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field

import numpy as np

from ..spec import (
    Beam,
    Constant,
    Direction,
    Function,
    JigProfile,
    Material,
    PiecewiseConstant,
    PiecewiseLinear,
    Sampled,
    alternating_cells,
    jig_from_function,
    jig_from_points,
    jig_from_polyline,
    sample_profile,
)
from ..spec.material import POISSON_RANGE
from ..spec.profiles import DIRECTION_COMPONENTS, MAX_CELLS, MAX_SAMPLES
from ..units import MM
from ..validate import AngleRangeError, choice, finite_array, finite_number, in_range, integer, positive
from .expressions import compile_expression
from .numbers import kilo, mega, milli, radians, same, to_degrees, to_milli, to_unit

_BEAM_KEYS = ("length_mm", "width_mm", "thickness_mm", "volume_fraction", "material", "magnetization")
_MATERIAL_KEYS = ("E0_MPa", "particle_magnetization_kA_per_m", "density_kg_per_m3", "poisson_ratio")
_MAG_KEYS = {
    "uniform": ("kind", "angle_deg"),
    "alternating_cells": ("kind", "cells", "angle_deg", "cell_length_mm"),
    "cells": ("kind", "angles_deg", "fractions"),
    "jig_function": ("kind", "z_mm", "x_start_mm", "x_end_mm", "kinks_x_mm", "samples"),
    "jig_polyline": ("kind", "x_mm", "z_mm"),
    "jig_points": ("kind", "x_mm", "z_mm", "corners"),
    "piecewise_linear": ("kind", "s_mm", "angles_deg"),
    "samples": ("kind", "s_mm", "angles_deg", "pieces", "piecewise_constant"),
    "expression": ("kind", "angle_deg", "kinks_s_mm"),
    "direction": ("kind", "axial", "width", "thickness"),
}
_PHI_KEYS = {
    "piecewise_linear": ("kind", "s_mm", "values"),
    "samples": ("kind", "s_mm", "values", "pieces"),
    "expression": ("kind", "phi", "kinks_s_mm"),
}
#: A direction component's kinds: the volume fraction's, with the expression under ``value`` and the pieces of
#: ``samples`` optionally held constant (``piecewise_constant``: a polyline jig's pieces).
_COMPONENT_KEYS = {
    "piecewise_linear": ("kind", "s_mm", "values"),
    "samples": ("kind", "s_mm", "values", "pieces", "piecewise_constant"),
    "expression": ("kind", "value", "kinks_s_mm"),
}
_DEG = math.pi / 180.0
_JIG_SAMPLES = 4001  # jig_from_function's default


# ---------------------------------------------------------------------------------------------
# expressions of the arc length


@dataclass(frozen=True)
class ArcExpression:
    """A profile given as an expression of the arc length ``s`` in mm, read from a file (picklable).

    ``scale`` turns the expression's value into SI: pi/180 for an angle in degrees, 1 for a volume fraction."""

    text: str
    scale: float = 1.0
    _f: object = field(default=None, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "_f", compile_expression(self.text, name=f"expression {self.text!r}", variable="s"))

    def __call__(self, s):
        return self._f(np.asarray(s, dtype=float) * 1000.0) * self.scale

    def __reduce__(self):
        return (ArcExpression, (self.text, self.scale))


# ---------------------------------------------------------------------------------------------
# reading


def beam_from_dict(d: dict, *, where: str = "beam") -> Beam:
    """A :class:`Beam` from a beam block (mm, deg -> SI); every key is checked, unknown keys are errors."""
    check_keys(where, d, _BEAM_KEYS, required=("width_mm", "thickness_mm"))
    material = _material_from_dict(d.get("material", {}), where=f"{where} material")
    try:
        beta, natural_length = _magnetization_from_dict(d.get("magnetization", {"kind": "uniform"}), where=where)
    except AngleRangeError as exc:
        raise _angles_in_degrees(where, exc) from None
    if "length_mm" in d:
        length = _scalar(f"{where} length_mm", d["length_mm"], milli, positive, "mm")
        if natural_length is not None and abs(length - natural_length) > 1e-9 * natural_length and (
            getattr(beta, "length", None) is None
        ):
            raise ValueError(
                f"{where} length_mm is {length / MM:g} but the magnetization's cells give "
                f"{natural_length / MM:g} mm; give one of them."
            )
    elif natural_length is not None:
        length = natural_length
    else:
        raise ValueError(f"{where} needs length_mm (> 0, mm): the magnetization does not fix the length.")
    try:
        return Beam(
            length=length,
            width=_scalar(f"{where} width_mm", d["width_mm"], milli, positive, "mm"),
            thickness=_scalar(f"{where} thickness_mm", d["thickness_mm"], milli, positive, "mm"),
            material=material,
            volume_fraction=_phi_from_dict(d.get("volume_fraction", 0.2), where=f"{where} volume_fraction"),
            magnetization=beta,
        )
    except AngleRangeError as exc:
        raise _angles_in_degrees(where, exc) from None


def _angles_in_degrees(where: str, exc: AngleRangeError) -> ValueError:
    """An angle beyond a turn, told in the file's unit (degrees), not as a radians-vs-degrees mix-up."""
    return ValueError(f"{where} magnetization angles must lie in [-360, 360] deg (one turn either way), got up to "
                      f"{math.degrees(exc.largest):.6g} deg.")


def _material_from_dict(d: dict, *, where: str) -> Material:
    check_keys(where, d, _MATERIAL_KEYS)
    kw = {}
    if "E0_MPa" in d:
        kw["E0"] = _scalar(f"{where} E0_MPa", d["E0_MPa"], mega, positive, "MPa")
    if "particle_magnetization_kA_per_m" in d:
        kw["particle_magnetization"] = (
            _scalar(f"{where} particle_magnetization_kA_per_m", d["particle_magnetization_kA_per_m"], kilo)
        )
    if "density_kg_per_m3" in d:
        rho = d["density_kg_per_m3"]
        if isinstance(rho, dict):
            w = f"{where} density_kg_per_m3"
            check_keys(w, rho, ("rule_of_mixtures",), required=("rule_of_mixtures",))
            mix = rho["rule_of_mixtures"]
            check_keys(f"{w} rule_of_mixtures", mix, ("particle_kg_per_m3", "matrix_kg_per_m3"),
                       required=("particle_kg_per_m3", "matrix_kg_per_m3"))
            return Material.rule_of_mixtures(
                particle_density=positive(f"{w} particle_kg_per_m3", mix["particle_kg_per_m3"], unit="kg/m^3"),
                matrix_density=positive(f"{w} matrix_kg_per_m3", mix["matrix_kg_per_m3"], unit="kg/m^3"),
                **kw, **_poisson(where, d))
        kw["density"] = positive(f"{where} density_kg_per_m3", rho, unit="kg/m^3")
    return Material(**kw, **_poisson(where, d))


def _poisson(where: str, d: dict) -> dict:
    """``{"poisson_ratio": nu}`` from the material block, or nothing (the default)."""
    if "poisson_ratio" not in d:
        return {}
    return {"poisson_ratio": in_range(f"{where} poisson_ratio", d["poisson_ratio"], *POISSON_RANGE)}


def _scalar(name: str, raw, to_si, check=finite_number, unit: str = "") -> float:
    """``raw`` checked (in the file's unit, for the message), then converted from its digits by ``to_si``."""
    check(name, raw, unit=unit)
    return to_si(raw)


def _list(name: str, raw, to_si, *, min_len: int = 1) -> np.ndarray:
    """A list of numbers checked, then each converted from its digits by ``to_si``."""
    _numbers(name, raw, min_len=min_len)
    return np.array([to_si(x) for x in raw], dtype=float)


def _numbers(name: str, value, *, min_len: int = 1) -> np.ndarray:
    check_list(name, value, min_len=min_len)
    if len(value) > MAX_SAMPLES:
        raise ValueError(f"{name} must have at most {MAX_SAMPLES} entries, got {len(value)}.")
    return finite_array(name, value, ndim=1)


def _kinks(w: str, d: dict, key: str) -> list[float]:
    """Arc lengths (mm -> m) of ``d[key]`` (default none)."""
    values = check_list(f"{w} {key}", d.get(key, []))
    return [_scalar(f"{w} {key}[{i}]", k, milli, unit="mm") for i, k in enumerate(values)]


def _samples(d: dict, w: str, values_key: str, to_si, *, piecewise_constant: bool = False):
    """A Sampled profile (``s_mm`` + values) or a JigProfile of spline pieces (``pieces``).

    ``to_si`` converts the values (math.radians for angles)."""
    if "pieces" in d:
        if "s_mm" in d or values_key in d:
            raise ValueError(f"{w} of kind 'samples' takes either 'pieces' or 's_mm' and {values_key!r}, not both.")
        pieces = []
        for k, piece in enumerate(check_list(f"{w} pieces", d["pieces"], min_len=1)):
            pw = f"{w} pieces[{k}]"
            check_keys(pw, piece, ("s_mm", values_key), required=("s_mm", values_key))
            s = _list(f"{pw} s_mm", piece["s_mm"], milli, min_len=2)
            v = _list(f"{pw} {values_key}", piece[values_key], to_si, min_len=2)
            pieces.append((tuple(s.tolist()), tuple(v)))
        return JigProfile(tuple(pieces), piecewise_constant=piecewise_constant)
    for k in ("s_mm", values_key):
        if k not in d:
            raise ValueError(f"{w} of kind 'samples' needs {k!r} (or 'pieces').")
    v = _list(f"{w} {values_key}", d[values_key], to_si, min_len=2)
    return Sampled(_list(f"{w} s_mm", d["s_mm"], milli, min_len=2), v)


def _phi_from_dict(vf, *, where: str):
    return _dimensionless_from_dict(vf, where=where, kinds=_PHI_KEYS, expression="phi")


def _dimensionless_from_dict(vf, *, where: str, kinds: dict, expression: str):
    """A dimensionless profile (a volume fraction, a direction component): a number, ``{"cells": [...]}`` or an
    object with a ``kind`` among ``kinds``; the expression of kind ``expression`` is under the key ``expression``."""
    if isinstance(vf, bool) or not isinstance(vf, (int, float, dict)):
        raise ValueError(f"{where} must be a number, {{'cells': [...]}} or an object with a 'kind' among "
                         f"{list(kinds)}, got {vf!r}.")
    if not isinstance(vf, dict):
        return vf
    if "kind" not in vf:
        check_keys(where, vf, ("cells", "fractions"), required=("cells",))
        return PiecewiseConstant(check_list(f"{where} cells", vf["cells"], min_len=1), vf.get("fractions"))
    kind = choice(f"{where} kind", vf["kind"], list(kinds))
    check_keys(where, vf, kinds[kind])
    if kind == "piecewise_linear":
        for k in ("s_mm", "values"):
            if k not in vf:
                raise ValueError(f"{where} of kind 'piecewise_linear' needs {k!r}.")
        return PiecewiseLinear(_list(f"{where} s_mm", vf["s_mm"], milli, min_len=2),
                               _list(f"{where} values", vf["values"], same, min_len=2))
    if kind == "samples":
        flat = vf.get("piecewise_constant", False)
        if not isinstance(flat, bool):
            raise ValueError(f"{where} piecewise_constant must be true or false, got {flat!r}.")
        return _samples(vf, where, "values", same, piecewise_constant=flat)
    if expression not in vf:
        raise ValueError(f"{where} of kind 'expression' needs {expression!r} (an expression in s, mm).")
    return Function(ArcExpression(vf[expression], 1.0), kinks=_kinks(where, vf, "kinks_s_mm"))


def _magnetization_from_dict(d: dict, *, where: str):
    """(profile, natural length in m or None)."""
    w = f"{where} magnetization"
    if not isinstance(d, dict) or "kind" not in d:
        raise ValueError(f"{w} must be an object with a 'kind' among {list(_MAG_KEYS)}, got {d!r}.")
    kind = choice(f"{w} kind", d["kind"], list(_MAG_KEYS))
    check_keys(w, d, _MAG_KEYS[kind])
    if kind == "direction":
        parts = [_dimensionless_from_dict(d.get(c, 0.0), where=f"{w} {c}", kinds=_COMPONENT_KEYS, expression="value")
                 for c in DIRECTION_COMPONENTS]
        prof = Direction(*parts)
        return prof, prof.length
    angle = _scalar(f"{w} angle_deg", d.get("angle_deg", 0.0), radians, unit="deg") \
        if kind != "expression" else 0.0
    if kind == "uniform":
        return angle, None
    if kind == "alternating_cells":
        n = integer(f"{w} cells", d.get("cells"), 1, MAX_CELLS)
        length = None
        if "cell_length_mm" in d:
            length = n * _scalar(f"{w} cell_length_mm", d["cell_length_mm"], milli, positive, "mm")
        return alternating_cells(n, angle=angle), length
    if kind == "cells":
        if "angles_deg" not in d:
            raise ValueError(f"{w} of kind 'cells' needs 'angles_deg'.")
        check_list(f"{w} angles_deg", d["angles_deg"], min_len=1)
        angles = [_scalar(f"{w} angles_deg[{i}]", a, radians, unit="deg") for i, a in enumerate(d["angles_deg"])]
        fractions = d.get("fractions")
        if fractions is not None:
            check_list(f"{w} fractions", fractions, min_len=1)
            fractions = finite_array(f"{w} fractions", fractions, ndim=1)
        return PiecewiseConstant(angles, fractions), None
    if kind == "jig_function":
        for k in ("z_mm", "x_start_mm", "x_end_mm"):
            if k not in d:
                raise ValueError(f"{w} of kind 'jig_function' needs {k!r}.")
        f = compile_expression(d["z_mm"], name=f"{w} z_mm")
        kinks = check_list(f"{w} kinks_x_mm", d.get("kinks_x_mm", []))
        kinks = [finite_number(f"{w} kinks_x_mm[{i}]", k, unit="mm") for i, k in enumerate(kinks)]
        prof = jig_from_function(
            f,
            finite_number(f"{w} x_start_mm", d["x_start_mm"], unit="mm"),
            finite_number(f"{w} x_end_mm", d["x_end_mm"], unit="mm"),
            unit=MM,
            kinks=kinks,
            samples=d.get("samples", _JIG_SAMPLES),
        )
        return prof, prof.length
    if kind in ("jig_polyline", "jig_points"):
        for k in ("x_mm", "z_mm"):
            if k not in d:
                raise ValueError(f"{w} of kind {kind!r} needs {k!r}.")
        xs = _list(f"{w} x_mm", d["x_mm"], milli, min_len=2)
        zs = _list(f"{w} z_mm", d["z_mm"], milli, min_len=2)
        if kind == "jig_polyline":
            prof = jig_from_polyline(xs, zs)
        else:
            prof = jig_from_points(xs, zs, corners=check_list(f"{w} corners", d.get("corners", [])))
        return prof, prof.length
    if kind == "piecewise_linear":
        for k in ("s_mm", "angles_deg"):
            if k not in d:
                raise ValueError(f"{w} of kind 'piecewise_linear' needs {k!r}.")
        angles = _list(f"{w} angles_deg", d["angles_deg"], radians, min_len=2)
        prof = PiecewiseLinear(_list(f"{w} s_mm", d["s_mm"], milli, min_len=2), angles)
        return prof, prof.length
    if kind == "samples":
        flat = d.get("piecewise_constant", False)
        if not isinstance(flat, bool):
            raise ValueError(f"{w} piecewise_constant must be true or false, got {flat!r}.")
        prof = _samples(d, w, "angles_deg", radians, piecewise_constant=flat)
        return prof, prof.length
    # expression
    if "angle_deg" not in d or not isinstance(d["angle_deg"], str):
        raise ValueError(f"{w} of kind 'expression' needs 'angle_deg': an expression in s (mm), "
                         f"got {d.get('angle_deg')!r}.")
    return Function(ArcExpression(d["angle_deg"], _DEG), kinks=_kinks(w, d, "kinks_s_mm")), None


# ---------------------------------------------------------------------------------------------
# writing


def _mm(v):
    return [to_milli(x) for x in v] if np.ndim(v) else to_milli(v)


def _deg(v):
    return [to_degrees(x) for x in v] if np.ndim(v) else to_degrees(v)


def beam_to_dict(beam: Beam, *, sample_functions: bool = False, where: str = "beam") -> dict:
    """The beam block of ``beam`` (SI -> mm, deg). Raises ValueError for a profile a file cannot hold
    (a Python function) unless ``sample_functions`` is set, which stores it as samples."""
    m = beam.material
    mat = {"E0_MPa": to_unit(m.E0, -6), "particle_magnetization_kA_per_m": to_unit(m.particle_magnetization, -3)}
    if callable(m.density):
        mix = getattr(m.density, "particle_density", None), getattr(m.density, "matrix_density", None)
        if None in mix:
            raise ValueError(f"{where} material density is a Python function of phi, which a file cannot hold; "
                             "use a number or Material.rule_of_mixtures(...).")
        mat["density_kg_per_m3"] = {"rule_of_mixtures": {"particle_kg_per_m3": mix[0], "matrix_kg_per_m3": mix[1]}}
    else:
        mat["density_kg_per_m3"] = m.density
    mat["poisson_ratio"] = m.poisson_ratio
    return {
        "length_mm": _mm(beam.length),
        "width_mm": _mm(beam.width),
        "thickness_mm": _mm(beam.thickness),
        "material": mat,
        "volume_fraction": _phi_to_dict(beam.volume_fraction, beam.length, sample_functions,
                                        f"{where} volume_fraction"),
        "magnetization": _magnetization_to_dict(beam.magnetization, beam.length, sample_functions,
                                                f"{where} magnetization"),
    }


def _plain(values) -> list[float]:
    return [float(v) for v in values]


def _cannot(where: str, prof) -> ValueError:
    return ValueError(
        f"{where} is a {type(prof).__name__} of a Python function, which a file cannot hold. Save it as samples "
        "(Robot.save(path, sample_functions=True), or magsoft_env.sample_profile(profile, length) yourself), or "
        "give it as an expression of s in mm (kind 'expression')."
    )


def _pieces(prof: JigProfile, values_key: str, angle: bool) -> list[dict]:
    conv = _deg if angle else _plain
    return [{"s_mm": _mm(s), values_key: conv(v)} for s, v in prof.pieces]


def _portable(prof):
    """A profile's file-serializable equivalent when it offers one (``portable()``, e.g. a designed spline)."""
    make = getattr(prof, "portable", None)
    return make() if callable(make) else None


def _phi_to_dict(prof, length: float, sample: bool, where: str):
    return _dimensionless_to_dict(prof, length, sample, where, expression="phi")


def _dimensionless_to_dict(prof, length: float, sample: bool, where: str, *, expression: str):
    """A dimensionless profile as file data (the reader's forms); a direction component's kinds
    (``expression="value"``) also hold a polyline jig's constant pieces."""
    if (alt := _portable(prof)) is not None:
        return _dimensionless_to_dict(alt, length, sample, where, expression=expression)
    if type(prof) is Constant:
        return prof.value
    if type(prof) is PiecewiseConstant:
        return {"cells": _plain(prof.levels), "fractions": _plain(prof.fractions)}
    if type(prof) is PiecewiseLinear:
        return {"kind": "piecewise_linear", "s_mm": _mm(prof.s_knots), "values": _plain(prof.knot_values)}
    if type(prof) is Sampled:
        return {"kind": "samples", "s_mm": _mm(prof.s_samples), "values": _plain(prof.sample_values)}
    if type(prof) is JigProfile and (expression != "phi" or not prof.piecewise_constant):
        out = {"kind": "samples", "pieces": _pieces(prof, "values", False)}
        if prof.piecewise_constant:
            out["piecewise_constant"] = True
        return out
    if type(prof) is Function and isinstance(prof.func, ArcExpression) and prof.func.scale == 1.0 \
            and prof.length is None:
        return {"kind": "expression", expression: prof.func.text, "kinks_s_mm": _mm(prof.kinks)}
    if sample:
        return _dimensionless_to_dict(sample_profile(prof, length), length, False, where, expression=expression)
    raise _cannot(where, prof)


def _magnetization_to_dict(prof, length: float, sample: bool, where: str) -> dict:
    if (alt := _portable(prof)) is not None:
        return _magnetization_to_dict(alt, length, sample, where)
    if type(prof) is Direction:
        return {"kind": "direction", **{c: _dimensionless_to_dict(p, length, sample, f"{where} {c}", expression="value")
                                        for c, p in zip(DIRECTION_COMPONENTS, prof.components, strict=True)}}
    if type(prof) is Constant:
        return {"kind": "uniform", "angle_deg": _deg(prof.value)}
    if type(prof) is PiecewiseConstant:
        return {"kind": "cells", "angles_deg": _deg(prof.levels), "fractions": _plain(prof.fractions)}
    if type(prof) is PiecewiseLinear:
        return {"kind": "piecewise_linear", "s_mm": _mm(prof.s_knots), "angles_deg": _deg(prof.knot_values)}
    if type(prof) is Sampled:
        return {"kind": "samples", "s_mm": _mm(prof.s_samples), "angles_deg": _deg(prof.sample_values)}
    if type(prof) is JigProfile:
        r = prof.recipe
        if r is not None and r[0] == "polyline":
            return {"kind": "jig_polyline", "x_mm": _mm(r[1]), "z_mm": _mm(r[2])}
        if r is not None and r[0] == "points":
            return {"kind": "jig_points", "x_mm": _mm(r[1]), "z_mm": _mm(r[2]), "corners": list(r[3])}
        if r is not None and r[0] == "function" and r[4] == MM:
            _, text, x0, x1, _, kinks, samples = r
            out = {"kind": "jig_function", "z_mm": text, "x_start_mm": x0, "x_end_mm": x1,
                   "kinks_x_mm": list(kinks)}
            if samples != _JIG_SAMPLES:
                out["samples"] = samples
            return out
        out = {"kind": "samples", "pieces": _pieces(prof, "angles_deg", True)}
        if prof.piecewise_constant:
            out["piecewise_constant"] = True
        return out
    if type(prof) is Function and isinstance(prof.func, ArcExpression) and prof.func.scale == _DEG \
            and prof.length is None:
        return {"kind": "expression", "angle_deg": prof.func.text, "kinks_s_mm": _mm(prof.kinks)}
    if sample:
        return _magnetization_to_dict(sample_profile(prof, length), length, False, where)
    raise _cannot(where, prof)


# ---------------------------------------------------------------------------------------------
# checks shared by the file readers


def check_list(name: str, value, *, min_len: int = 0) -> list:
    if not isinstance(value, list) or len(value) < min_len:
        need = f"with at least {min_len} entries" if min_len else ""
        raise ValueError(f"{name} must be a list {need}, got {value!r}.".replace("  ", " "))
    return value


def check_keys(where: str, d, allowed, *, required=()) -> None:
    if not isinstance(d, dict):
        raise ValueError(f"{where} must be an object with keys among {list(allowed)}, got {d!r}.")
    for k in d:
        if k not in allowed:
            hint = difflib.get_close_matches(str(k), list(allowed), n=1)
            extra = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ValueError(f"{where} has unknown key {k!r}; allowed: {list(allowed)}.{extra}")
    for k in required:
        if k not in d:
            raise ValueError(f"{where} needs key {k!r}.")


__all__ = ["ArcExpression", "beam_from_dict", "beam_to_dict", "check_keys", "check_list"]

"""Bad input anywhere in the specification, design and CLI layers: a ValueError naming the parameter, before any work.

Every case asserts ``pytest.raises(ValueError, match=<the parameter's name>)``; no other exception type
may escape. CLI cases assert exit status 2, a one-line ``error:`` message and no traceback.
"""

from __future__ import annotations

import math
import os
import re
import warnings

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.cases import PathSegment, Preset, load_preset, preset_from_dict
from magsoft_env.cli import main
from magsoft_env.design import builtin_target, prepare_target, read_curve_csv, resample
from magsoft_env.design.families import BasisProfile, ProfileFamily
from magsoft_env.design.targets import turtle_curve
from magsoft_env.spec import JigProfile, as_field, as_fields, jig_from_points
from magsoft_env.spec.drive import Waveparams, switched_square
from magsoft_env.spec.loading import check_loading
from magsoft_env.validate import finite_array, integer

NAN, INF = float("nan"), float("inf")
BEAM_KW = {"length": 0.02, "width": 5e-3, "thickness": 1e-3}


def _beam(**kw):
    return ms.Beam(**{**BEAM_KW, **kw})


# ----------------------------------------------------------------------------------- validate.integer


@pytest.mark.parametrize("value", ["20", b"20", True, np.bool_(False), 2.5, NAN, INF, None, [3], 0, 11])
def test_integer_refuses_strings_bools_fractions_and_out_of_range(value):
    with pytest.raises(ValueError, match="nodes"):
        integer("nodes", value, 1, 10)


@pytest.mark.parametrize(("value", "expected"), [(3, 3), (np.int64(4), 4), (5.0, 5), (np.float32(6.0), 6)])
def test_integer_accepts_integral_numbers(value, expected):
    n = integer("nodes", value, 1, 10)
    assert n == expected and type(n) is int


@pytest.mark.parametrize("value", ["1,2", ["0.1", 0.2], [True, False], np.array(["1"]), [[1, 2], [3]], [1, NAN]])
def test_finite_array_refuses_strings_bools_ragged_and_nan(value):
    with pytest.raises(ValueError, match="levels"):
        finite_array("levels", value)


# ----------------------------------------------------------------------------------- Beam sizes


@pytest.mark.parametrize("name", ["length", "width", "thickness"])
@pytest.mark.parametrize("value", ["0.02", True, NAN, INF, -1e-3, 0.0, 25.0])
def test_beam_sizes_are_numbers_in_0_1_metre(name, value):
    with pytest.raises(ValueError, match=f"Beam.{name}"):
        _beam(**{name: value})


def test_a_25_m_beam_is_a_unit_mistake():
    with pytest.raises(ValueError, match=r"Beam.length must lie in \(0, 1\] m.*25 mm is 0.025"):
        _beam(length=25.0)


def test_a_beam_thicker_than_long_is_refused():
    with pytest.raises(ValueError, match="Beam.thickness must not exceed Beam.length.*slender"):
        ms.Beam(length=1e-3, width=5e-3, thickness=1.0)


def test_width_minus_five_is_refused():  # the report's "Shape(width=-5)": the beam's width
    with pytest.raises(ValueError, match="Beam.width must be > 0"):
        _beam(width=-5)


def test_a_stubby_beam_warns_that_shear_is_neglected():
    with pytest.warns(UserWarning, match="slenderness L/h = 2.5.*shear"):
        ms.Beam(length=2.5e-3, width=5e-3, thickness=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _beam()  # L/h = 20: no warning


def test_beam_replace_refuses_unknown_fields():
    with pytest.raises(ValueError, match="lenght"):
        _beam().replace(lenght=0.03)


@pytest.mark.parametrize("g", [-9.81, NAN, "9.81"])
def test_nondimensional_groups_gravity(g):
    with pytest.raises(ValueError, match="gravity"):
        _beam().nondimensional_groups(gravity=g)


# ----------------------------------------------------------------------------------- volume fraction


def test_volume_fraction_spike_between_the_old_probes_is_caught_at_construction():
    # 257 probes are 78 um apart on a 20 mm beam; this spike is 1 um wide
    def phi(s):
        return 0.2 + 0.7 * np.exp(-(((np.asarray(s) - 0.0123457) / 1e-6) ** 2))

    with pytest.raises(ValueError, match=r"volume_fraction must lie in \[0, 0.5\]"):
        _beam(volume_fraction=phi)


def test_volume_fraction_spike_finer_than_any_grid_is_caught_when_sampled():
    s0 = 0.0123456789

    def phi(s):
        return 0.2 + 0.7 * np.exp(-(((np.asarray(s) - s0) / 1e-10) ** 2))

    beam = _beam(volume_fraction=phi)  # the spike falls between the construction probes
    with pytest.raises(ValueError, match=r"volume_fraction must lie in \[0, 0.5\].*12.3457 mm"):
        beam.phi(np.array([0.0, s0]))
    for method in (beam.youngs_modulus, beam.bending_stiffness, beam.remanence, beam.mass_per_length):
        with pytest.raises(ValueError, match="volume_fraction"):
            method(np.array([s0]))


def test_volume_fraction_spike_at_a_breakpoint_is_caught():
    spike = ms.Function(lambda s: np.where(np.abs(np.asarray(s) - 0.01) < 1e-12, 0.9, 0.2), kinks=[0.01])
    with pytest.raises(ValueError, match="volume_fraction"):
        _beam(volume_fraction=spike)


@pytest.mark.parametrize(
    "func",
    [
        lambda s: np.array([0.2, 0.2]),  # an array whatever s is
        lambda s: np.zeros((np.size(s), 2)),  # the wrong shape
        lambda s: "0.2",  # a string
        lambda s: None,
        lambda s: 1 / 0,  # raises
        lambda s: [0.2] * 3,
    ],
)
def test_volume_fraction_callable_must_return_one_number_per_s(func):
    with pytest.raises(ValueError, match="volume_fraction"):
        _beam(volume_fraction=func)


@pytest.mark.parametrize("func", [lambda s: np.array([0.0, 1.0]), lambda s: {}, lambda s: 1 / 0])
def test_magnetization_callable_must_return_one_number_per_s(func):
    with pytest.raises(ValueError, match="magnetization"):
        _beam(magnetization=func)


@pytest.mark.parametrize("value", ["0.2", True, NAN, INF, -0.01, 0.51, [0.2]])
def test_volume_fraction_numbers(value):
    with pytest.raises(ValueError, match="volume_fraction"):
        _beam(volume_fraction=value)


# ----------------------------------------------------------------------------------- material


@pytest.mark.parametrize(
    ("kw", "name"),
    [
        ({"E0": "62000"}, "E0"), ({"E0": True}, "E0"), ({"E0": NAN}, "E0"), ({"E0": -1.0}, "E0"),
        ({"E0": 0.062}, "E0"), ({"E0": 1e12}, "E0"),
        ({"particle_magnetization": "575e3"}, "particle_magnetization"),
        ({"particle_magnetization": INF}, "particle_magnetization"),
        ({"particle_magnetization": 575e6}, "particle_magnetization"),
        ({"density": "1940"}, "density"), ({"density": NAN}, "density"), ({"density": 1.94}, "density"),
        ({"density": 1e6}, "density"), ({"density": lambda phi: np.array([1.0, 2.0])}, "density"),
        ({"density": lambda phi: 1 / 0}, "density"), ({"density": lambda phi: 1e6}, "density"),
    ],
)
def test_material_ranges(kw, name):
    with pytest.raises(ValueError, match=f"Material.{name}"):
        ms.Material(**kw)


# ----------------------------------------------------------------------------------- fields


@pytest.mark.parametrize(("args", "name"), [
    (("a", 0), "magnitude"), ((True, 0), "magnitude"), ((NAN, 0), "magnitude"), ((INF, 0), "magnitude"),
    ((-0.01, 0), "magnitude"), ((2.0, 0), "magnitude"), ((0.01, "0"), "angle"), ((0.01, NAN), "angle"),
])
def test_field_polar(args, name):
    with pytest.raises(ValueError, match=f"Field.polar {name}"):
        ms.Field.polar(*args)


@pytest.mark.parametrize("value", ["ab", {"Bx": 0, "Bz": 1}, {0, 1}, 5, None])
def test_as_field_refuses_strings_dicts_and_sets(value):
    with pytest.raises(ValueError, match="field"):
        as_field(value)


@pytest.mark.parametrize("value", [5, None, "ab", []])
def test_as_fields_refuses_non_sequences(value):
    with pytest.raises(ValueError, match="fields"):
        as_fields(value)


@pytest.mark.parametrize("n", ["20", True, 2.5, NAN, 0, -1, 10**9])
def test_ramp_n(n):
    with pytest.raises(ValueError, match="ramp n"):
        ms.ramp((0, 0), (0, 1e-3), n)


def test_ramp_include_start_is_a_bool():
    with pytest.raises(ValueError, match="include_start"):
        ms.ramp((0, 0), (0, 1e-3), 3, include_start="no")


# ----------------------------------------------------------------------------------- loading options


@pytest.mark.parametrize(("kw", "name"), [
    ({"gravity": "9.81"}, "gravity"), ({"gravity": NAN}, "gravity"), ({"gravity": -1.0}, "gravity"),
    ({"clamp_angle": "0"}, "clamp_angle"), ({"clamp_angle": INF}, "clamp_angle"),
    ({"clamp_angle": 30.0}, "clamp_angle"),
    ({"extensible": 1}, "extensible"), ({"support": 3}, "support"), ({"coupling": None}, "coupling"),
])
def test_check_loading(kw, name):
    with pytest.raises(ValueError, match=name):
        check_loading(**{"gravity": 9.81, **kw})


def test_clamp_angle_in_degrees_is_caught():
    with pytest.raises(ValueError, match=r"clamp_angle must lie in \[-2 pi, 2 pi\].*radians"):
        check_loading(gravity=9.81, clamp_angle=45.0)


# ----------------------------------------------------------------------------------- profiles


@pytest.mark.parametrize("n", [True, False, "4", 2.5, NAN, 0, -3, 10**9])
def test_alternating_cells_n(n):
    with pytest.raises(ValueError, match="alternating_cells n"):
        ms.alternating_cells(n)


def test_alternating_cells_angle():
    with pytest.raises(ValueError, match="angle"):
        ms.alternating_cells(2, angle="0")


@pytest.mark.parametrize("pieces", [(), [], None, "ab", ((1.0,),), (((0.0,), (0.0,)),),
                                    (((0.0, 1e-3), (0.0,)),), (((0.0, 1e-3, 5e-4), (0.0, 0.0, 0.0)),),
                                    (((1e-3, 2e-3), (0.0, 0.0)),),
                                    (((0.0, 1e-3), (0.0, 0.0)), ((2e-3, 3e-3), (0.0, 0.0))),
                                    (((0.0, NAN), (0.0, 0.0)),)])
def test_jig_profile_pieces(pieces):
    with pytest.raises(ValueError, match="JigProfile pieces"):
        JigProfile(pieces)


def test_jig_profile_piecewise_constant_is_a_bool():
    with pytest.raises(ValueError, match="piecewise_constant"):
        JigProfile((((0.0, 1e-3), (0.0, 0.0)),), piecewise_constant="yes")


@pytest.mark.parametrize(("kw", "name"), [
    ({"samples": "abc"}, "samples"), ({"samples": True}, "samples"), ({"samples": 2.5}, "samples"),
    ({"samples": 10**9}, "samples"), ({"samples": -1}, "samples"),
    ({"unit": "1e-3"}, "unit"), ({"unit": 0.0}, "unit"), ({"unit": 1000.0}, "unit"), ({"unit": NAN}, "unit"),
    ({"kinks": 5.0}, "kinks"), ({"kinks": ["a"]}, "kinks"), ({"kinks": [NAN]}, "kinks"),
    ({"kinks": list(range(2000))}, "kinks"), ({"x_start": "0"}, "x_start"), ({"x_end": INF}, "x_end"),
])
def test_jig_from_function_options(kw, name):
    args = {"x_start": 0.0, "x_end": 10.0, "unit": 1e-3, **kw}
    with pytest.raises(ValueError, match=name):
        ms.jig_from_function(lambda x: 0.1 * x, args.pop("x_start"), args.pop("x_end"), **args)


@pytest.mark.parametrize("f", [lambda x: np.array([1.0, 2.0]), lambda x: "z", lambda x: 1 / 0, lambda x: None])
def test_jig_from_function_f_must_return_one_number_per_x(f):
    with pytest.raises(ValueError, match="jig function"):
        ms.jig_from_function(f, 0, 10, unit=1e-3)


def test_jig_from_function_accepts_constant_and_scalar_only_functions():
    flat = ms.jig_from_function(lambda x: 1.0, 0, 10, unit=1e-3)  # a scalar for an array: broadcast
    assert flat.length == pytest.approx(10e-3)
    arc = ms.jig_from_function(lambda x: math.sin(0.1 * x), 0, 10, unit=1e-3, samples=401)  # math: scalars only
    ref = ms.jig_from_function(lambda x: np.sin(0.1 * x), 0, 10, unit=1e-3, samples=401)
    assert arc.length == pytest.approx(ref.length, rel=1e-12)


@pytest.mark.parametrize("corners", [[0], [3], [7], [-1], [True], ["1"], [1.5], 1, "1"])
def test_jig_corners_must_be_interior_point_indices(corners):
    x, z = [0, 1e-3, 2e-3, 3e-3], [0, 1e-3, 0, 1e-3]
    with pytest.raises(ValueError, match="corners"):
        jig_from_points(x, z, corners=corners)


@pytest.mark.parametrize(("kw", "name"), [
    ({"n": "201"}, "n"), ({"n": 1}, "n"), ({"n": 10**9}, "n"), ({"n": True}, "n"),
    ({"length": 25.0}, "length"), ({"length": -1.0}, "length"), ({"length": "0.02"}, "length"),
])
def test_jig_curve_options(kw, name):
    args = {"length": 0.02, **kw}
    with pytest.raises(ValueError, match=name):
        ms.jig_curve(0.1, **args)


@pytest.mark.parametrize(("kw", "name"), [
    ({"kinks": 0.01}, "breakpoints"), ({"kinks": ["a"]}, "breakpoints"), ({"length": -1.0}, "length"),
    ({"func": 3.0}, "callable"), ({"func": int}, "callable"),
])
def test_function_profile_options(kw, name):
    with pytest.raises(ValueError, match=name):
        ms.Function(**{"func": np.sin, **kw})


def test_profile_call_length():
    with pytest.raises(ValueError, match="length"):
        ms.alternating_cells(2)(np.array([0.0]), "0.02")


# ----------------------------------------------------------------------------------- drives


@pytest.mark.parametrize(("kw", "name"), [
    ({"amplitude_x": "1e-3"}, "amplitude_x"), ({"amplitude_z": NAN}, "amplitude_z"),
    ({"amplitude_x": 2.0}, "amplitude_x"),
    ({"frequency": 0.0}, "frequency"), ({"frequency": -2.0}, "frequency"), ({"frequency": "2"}, "frequency"),
    ({"phase": INF}, "phase"), ({"shape": ["sine"]}, "shape"),
])
def test_waveparams(kw, name):
    with pytest.raises(ValueError, match=f"Waveparams.{name}"):
        Waveparams(**{"amplitude_x": 0.0, "amplitude_z": 1e-3, "frequency": 2.0, **kw})


@pytest.mark.parametrize(("args", "name"), [((1.0, 0.0), "frequency"), ((1.0, "2"), "frequency"),
                                            ((NAN, 2.0), "amplitude"), ((1.0, 2.0, 0.0, -1.0), "time_constant")])
def test_switched_square(args, name):
    with pytest.raises(ValueError, match=name):
        switched_square([0.1], *args)


# ----------------------------------------------------------------------------------- presets


def _minimal(**change):
    d = {"description": "d", "beam": {"length_mm": 20.0, "width_mm": 5.0, "thickness_mm": 1.0},
         "path": [{"from_mT": [0, 0], "to_mT": [0, 5], "steps": 3}]}
    d.update(change)
    return d


def _mag(m, **beam):
    return _minimal(beam={"length_mm": 20.0, "width_mm": 5.0, "thickness_mm": 1.0, "magnetization": m, **beam})


@pytest.mark.parametrize(("data", "name"), [
    (_minimal(path=[{"to_mT": [0, 5], "steps": "3"}]), "steps"),
    (_minimal(path=[{"to_mT": [0, 5], "steps": True}]), "steps"),
    (_minimal(path=[{"to_mT": [0, 5], "steps": 2.5}]), "steps"),
    (_minimal(path=[{"to_mT": [0, 5], "steps": 10**6}]), "steps"),
    (_minimal(path=[{"field_mT": "0 5"}]), "field_mT"),
    (_minimal(path=[{"field_mT": {"x": 0, "z": 5}}]), "field_mT"),
    (_minimal(clamp_angle_deg="0"), "clamp_angle_deg"),
    (_minimal(clamp_angle_deg=1000.0), "clamp_angle"),
    (_minimal(description=5), "description"),
    (_mag({"kind": "alternating_cells", "cells": True}), "cells"),
    (_mag({"kind": "alternating_cells", "cells": "4"}), "cells"),
    (_mag({"kind": "alternating_cells", "cells": 10**6}), "cells"),
    (_mag({"kind": "cells"}), "angles_deg"),
    (_mag({"kind": "cells", "angles_deg": 5}), "angles_deg"),
    (_mag({"kind": "cells", "angles_deg": []}), "angles_deg"),
    (_mag({"kind": "cells", "angles_deg": [0, "90"]}), "angles_deg"),
    (_mag({"kind": "cells", "angles_deg": [0, 90], "fractions": "1 1"}), "fractions"),
    (_mag({"kind": "cells", "angles_deg": [0, 90], "fractions": [1, "a"]}), "fractions"),
    (_mag({"kind": "jig_function", "z_mm": "x", "x_start_mm": 0, "x_end_mm": 10, "kinks_x_mm": 5}), "kinks_x_mm"),
    (_mag({"kind": "jig_function", "z_mm": "x", "x_start_mm": 0, "x_end_mm": 10, "kinks_x_mm": ["a"]}),
     "kinks_x_mm"),
    (_mag({"kind": "jig_polyline", "x_mm": [0, "a"], "z_mm": [0, 1]}), "x_mm"),
    (_mag({"kind": "jig_polyline", "x_mm": 5, "z_mm": [0, 1]}), "x_mm"),
    (_mag({"kind": "jig_polyline", "x_mm": [0, 1, 2], "z_mm": [[0], [1, 2]]}), "z_mm"),
    (_minimal(beam={"length_mm": 25000.0, "width_mm": 5.0, "thickness_mm": 1.0}), "length"),
    (_minimal(beam={"length_mm": 1.0, "width_mm": 5.0, "thickness_mm": 1000.0}), "thickness"),
    (_minimal(beam={"length_mm": 20.0, "width_mm": 5.0, "thickness_mm": 1.0, "volume_fraction": "0.2"}),
     "volume_fraction"),
    (_minimal(beam={"length_mm": 20.0, "width_mm": 5.0, "thickness_mm": 1.0, "material": {"E0_MPa": 1e9}}), "E0"),
])
def test_invalid_preset_data(data, name):
    with pytest.raises(ValueError, match=name):
        preset_from_dict(data, name="bad")


@pytest.mark.parametrize("steps", ["5", True, 1, 2.5, 10**6])
def test_with_steps(steps):
    with pytest.raises(ValueError, match="steps"):
        load_preset("fig3a_L20").with_steps(steps)


@pytest.mark.parametrize(("args", "name"), [
    ((ms.Field(), ms.Field(), "3"), "steps"), ((ms.Field(), ms.Field(), 0), "steps"),
    (("x", ms.Field(), 2), "start"), ((ms.Field(), None, 2), "end"),
])
def test_path_segment(args, name):
    with pytest.raises(ValueError, match=f"PathSegment.{name}"):
        PathSegment(*args)


@pytest.mark.parametrize(("kw", "name"), [({"beam": "beam"}, "beam"), ({"path": "abc"}, "path"),
                                          ({"path": ()}, "path"), ({"name": 5}, "name"),
                                          ({"description": None}, "description")])
def test_preset_fields(kw, name):
    args = {"name": "x", "description": "d", "beam": _beam(), "path": (PathSegment(ms.Field(), ms.Field(), 2),), **kw}
    with pytest.raises(ValueError, match=name):
        Preset(**args)


def test_preset_replace_refuses_unknown_fields():
    with pytest.raises(ValueError, match="gravty"):
        load_preset("fig3a_L20").replace(gravty=0.0)


def test_preset_file_that_is_not_utf8(tmp_path):
    f = tmp_path / "latin.json"
    f.write_bytes(b'{"description": "\xe9"}')
    with pytest.raises(ValueError, match="UTF-8"):
        load_preset(str(f))


# ----------------------------------------------------------------------------------- design


TARGET = builtin_target("ball")
DESIGN_BEAM = ms.Beam(length=20e-3, width=5e-3, thickness=1.13e-3)


@pytest.mark.parametrize(
    ("option", "value"),
    [
        *[("field_bounds", v) for v in ["1,20", (1e-3, "2e-2"), (NAN, 2e-2), (1e-3, INF), (-1e-3, 2e-2), (1e-3, 2.0),
                                         (2e-2, 1e-3), 5e-3, {"min": 0, "max": 1}]],
        *[("family", v) for v in ["splin", 3, None, ["spline"]]],
        *[("size", v) for v in ["7", True, 2.5, 0, 41, NAN]],
        *[("beta_bounds", v) for v in ["-3,3", (NAN, 3.0), (-30.0, 3.0), (3.0, -3.0), (0.0, INF)]],
        *[("field_direction", v) for v in ["up", 1, None]],
        *[("volume_fraction_bounds", v) for v in [(0.0, 0.3), (0.1, 0.6), ("0.1", 0.3), (0.1, NAN), 0.2]],
        *[("match_length", v) for v in [1, "yes", None]],
        *[("n_points", v) for v in ["50", True, 3, 2.5, NAN, 10**9, -1]],
        *[("n_starts", v) for v in ["4", True, 0, 1.5, 10**6]],
        *[("seed", v) for v in ["0", True, -1, 0.5, 2**40]],
        *[("rms_tol", v) for v in ["0.01", True, NAN, INF, -0.1, 2.0]],
        *[("max_nfev", v) for v in ["60", True, 1, 2.5, 10**9]],
        *[("global_stage", v) for v in [1, "yes", None]],
        *[("gravity", v) for v in ["9.81", NAN, -9.81, True]],
        *[("clamp_angle", v) for v in ["0", NAN, INF, 45.0]],
        *[("coupling", v) for v in ["rotate", 1]],
        *[("extensible", v) for v in [0, "no"]],
        *[("progress", v) for v in [1, "yes"]],
    ],
)
def test_design_options_are_checked_before_any_work(option, value, monkeypatch):
    import magsoft_env.design.optimize as opt

    def boom(*a, **k):  # no equilibrium may be solved before the options are checked
        raise AssertionError("work started before the options were checked")

    monkeypatch.setattr(opt, "_Problem", boom)
    kw = {"field_bounds": (1e-3, 20e-3), option: value}
    with pytest.raises(ValueError, match=option):
        ms.design_profile(TARGET, DESIGN_BEAM, **kw)


@pytest.mark.parametrize("target", [TARGET * 1e3, TARGET * 1e-5])
def test_design_target_in_the_wrong_unit(target, monkeypatch):
    import magsoft_env.design.optimize as opt

    monkeypatch.setattr(opt, "_Problem", None)
    with pytest.raises(ValueError, match="target_xz.*metres"):
        ms.design_profile(target, DESIGN_BEAM, field_bounds=(1e-3, 20e-3))


@pytest.mark.parametrize("value", ["ball", 5, None, [[0, 0], [1, "a"]], np.zeros((5, 3)), np.zeros((2_000_000, 2))])
def test_design_target_shape(value):
    with pytest.raises(ValueError, match="target_xz"):
        ms.design_profile(value, DESIGN_BEAM, field_bounds=(1e-3, 20e-3))


def test_design_beam_type():
    with pytest.raises(ValueError, match="beam"):
        ms.design_profile(TARGET, "beam", field_bounds=(1e-3, 20e-3))


@pytest.mark.parametrize(("call", "name"), [
    (lambda: ProfileFamily("spline", True), "size"), (lambda: ProfileFamily("spline", "7"), "size"),
    (lambda: ProfileFamily("spline", 7.5), "size"), (lambda: ProfileFamily(7, 7), "family"),
    (lambda: ProfileFamily("spline", 5).profile([0, 1, 2, 3, NAN], 0.02), "params"),
    (lambda: ProfileFamily("spline", 5).profile([0] * 5, -1.0), "length"),
    (lambda: ProfileFamily("spline", 5).fit([0, 0.5, 1], [0, 1]), "beta"),
    (lambda: BasisProfile(ProfileFamily("spline", 5), (0.0,) * 4, 0.02), "params"),
    (lambda: BasisProfile(ProfileFamily("spline", 5), (0.0,) * 5, "0.02"), "length"),
    (lambda: BasisProfile("spline", (0.0,) * 5, 0.02), "family"),
])
def test_profile_families(call, name):
    with pytest.raises(ValueError, match=name):
        call()


@pytest.mark.parametrize(("call", "name"), [
    (lambda: resample(TARGET, "31"), "n"), (lambda: resample(TARGET, True), "n"),
    (lambda: resample(TARGET, 10**9), "n"),
    (lambda: resample([[0, 0], [1, NAN]], 5), "xz"), (lambda: resample([1, 2, 3], 5), "xz"),
    (lambda: prepare_target(TARGET, "50"), "n_points"), (lambda: prepare_target(TARGET, 2), "n_points"),
    (lambda: turtle_curve([(None, 2.0)], step=0.0), "step"), (lambda: turtle_curve([(None, 2.0)], step=1e-9), "step"),
    (lambda: turtle_curve([(None, -2.0)]), "length"), (lambda: turtle_curve([(-1.0, 90.0)]), "radius"),
    (lambda: turtle_curve([(1.0, "90")]), "turn"), (lambda: turtle_curve([]), "pieces"),
    (lambda: turtle_curve([5]), "pieces"),
    (lambda: read_curve_csv(None), "path"), (lambda: read_curve_csv(5), "path"),
    (lambda: builtin_target(["ball"]), "target"),
])
def test_target_helpers(call, name):
    with pytest.raises(ValueError, match=name):
        call()


def test_target_csv_with_nan_or_latin1(tmp_path):
    f = tmp_path / "nan.csv"
    f.write_text("x_mm,z_mm\n0,0\n1,nan\n2,0\n3,1\n")
    with pytest.raises(ValueError, match="finite"):
        read_curve_csv(f)
    g = tmp_path / "latin.csv"
    g.write_bytes(b"x_mm,z_mm\n0,0\xe9\n")
    with pytest.raises(ValueError, match="UTF-8"):
        read_curve_csv(g)


# ----------------------------------------------------------------------------------- solving never uses a bad phi


def test_solver_refuses_a_phi_spike_it_samples():
    beam = _beam()
    # bypass the construction checks (as a spike between the probe points would) to reach the solver
    object.__setattr__(beam, "volume_fraction", ms.Function(lambda s: np.where(np.asarray(s) == 0.0, 0.9, 0.2)))
    with pytest.raises(ValueError, match=r"volume_fraction must lie in \[0, 0.5\]"):
        ms.solve_equilibrium(beam, (0.0, 5e-3))


# ----------------------------------------------------------------------------------- the command line


def _cli(argv, capsys):
    rc = main(argv)
    cap = capsys.readouterr()
    return rc, cap.out + cap.err, cap.err


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["solve", "--out", "/proc/x"], "--out '/proc/x' is not writable"),
        (["solve", "--out", "/proc/x/y/z"], "is not writable"),
        (["solve", "--out", "/sys/magsoft"], "is not writable"),
        (["solve", "--out", "/dev/null/x"], "'/dev/null' is a file"),
        (["demo", "--out", "/proc/x"], "--out"),
        (["sweep", "--out", "/proc/x"], "--out"),
        (["couplings", "--out", "/proc/x"], "--out"),
        (["design", "--target", "ball", "--out", "/proc/x"], "--out"),
        (["crosscheck", "fig3a_L20", "--segments", "4", "--out", "/proc/x"], "--out"),
        (["solve", "--out", "x" * 300], "--out"),
        (["solve", "--out", ""], "--out must be a folder path"),
    ],
)
def test_cli_refuses_unwritable_output_before_any_work(argv, fragment, capsys, monkeypatch):
    import magsoft_env.theory as theory

    monkeypatch.setattr(theory, "solve_path", None)  # would fail loudly if any command got to solving
    rc, text, err = _cli(argv, capsys)
    assert rc == 2, text
    assert "Traceback" not in text
    assert fragment in err
    assert len(err.strip().splitlines()) == 1, err


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write anywhere")
def test_cli_refuses_a_read_only_folder(tmp_path, capsys):
    ro = tmp_path / "ro"
    ro.mkdir()
    ro.chmod(0o500)
    try:
        rc, text, err = _cli(["solve", "--out", str(ro / "x")], capsys)
    finally:
        ro.chmod(0o700)
    assert rc == 2 and "not writable" in err


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["solve", "--steps", "abc"], "--steps"),
        (["solve", "--steps", "2.5"], "--steps"),
        (["solve", "--length-mm", "abc"], "--length-mm"),
        (["solve", "--length-mm", "nan"], "--length-mm"),
        (["solve", "--length-mm", "inf"], "--length-mm"),
        (["solve", "--length-mm", "25000"], "--length-mm"),
        (["solve", "--length-mm", "0.5"], "Beam.thickness must not exceed Beam.length"),
        (["solve", "--width-mm", "-5"], "--width-mm"),
        (["solve", "--phi", "-0.1"], "--phi"),
        (["solve", "--beta-deg", "1e9"], "--beta-deg"),
        (["solve", "--density-kg-per-m3", "1.94"], "--density-kg-per-m3"),
        (["solve", "--density-kg-per-m3", "1e6"], "--density-kg-per-m3"),
        (["solve", "--gravity", "9810"], "--gravity"),
        (["solve", "--gravity", "nan"], "--gravity"),
        (["solve", "--field-mT", "0", "inf"], "--field-mT BZ"),
        (["solve", "--field-mT", "2000", "0"], "--field-mT BX"),
        (["solve", "--steps", "100000"], "--steps"),
        (["solve", "--preset", "nope"], "unknown preset"),
        (["solve", "--coupling", "rotate"], "--coupling"),
        (["sweep", "--lengths-mm", "nan"], "--lengths-mm"),
        (["sweep", "--lengths-mm", "5000"], "--lengths-mm"),
        (["sweep", "--steps", "0"], "--steps"),
        (["sweep", "--gravity", "-1"], "--gravity"),
        (["couplings", "--levels", "100"], "--levels"),
        (["couplings", "--gravity", "inf"], "--gravity"),
        (["couplings", "--steps", "1"], "--steps"),
        (["crosscheck", "fig3a_L20", "--segments", "0"], "--segments"),
        (["crosscheck", "fig3a_L20", "--grading", "nan"], "--grading"),
        (["crosscheck", "fig3a_L20", "--grading", "0"], "--grading"),
        (["crosscheck", "fig3a_L20", "--steps", "1"], "--steps"),
        (["design", "--target", "ball", "--width-mm", "nan"], "--width-mm"),
        (["design", "--target", "ball", "--thickness-mm", "inf"], "--thickness-mm"),
        (["design", "--target", "ball", "--volume-fraction", "0.9"], "--volume-fraction"),
        (["design", "--target", "ball", "--volume-fraction", "0"], "--volume-fraction"),
        (["design", "--target", "ball", "--field-min-mT", "-1"], "--field-min-mT"),
        (["design", "--target", "ball", "--field-max-mT", "nan"], "--field-max-mT"),
        (["design", "--target", "ball", "--field-max-mT", "5000"], "--field-max-mT"),
        (["design", "--target", "ball", "--size", "0"], "--size"),
        (["design", "--target", "ball", "--size", "abc"], "--size"),
        (["design", "--target", "ball", "--points", "3"], "--points"),
        (["design", "--target", "ball", "--points", "1000000000"], "--points"),
        (["design", "--target", "ball", "--starts", "0"], "--starts"),
        (["design", "--target", "ball", "--max-nfev", "1"], "--max-nfev"),
        (["design", "--target", "ball", "--seed", "-1"], "--seed"),
        (["design", "--target", "ball", "--rms-tol-percent", "nan"], "--rms-tol-percent"),
        (["design", "--target", "ball", "--rms-tol-percent", "500"], "--rms-tol-percent"),
        (["design", "--target", "ball", "--gravity", "-9.81"], "--gravity"),
        (["design", "--target", "ball", "--family", "splin"], "--family"),
        (["design", "--target-csv", "/nonexistent/t.csv"], "does not exist"),
        (["design"], "--target"),
        (["nosuchcommand"], "invalid choice"),
    ],
)
def test_cli_bad_values_exit_2_with_one_line(argv, fragment, tmp_path, capsys, monkeypatch):
    import magsoft_env.theory as theory

    monkeypatch.setattr(theory, "solve_path", None)
    out = tmp_path / "never"
    extra = [] if argv[0] == "nosuchcommand" else ["--out", str(out)]
    rc, text, err = _cli([*argv, *extra], capsys)
    assert rc == 2, text
    assert "Traceback" not in text
    assert fragment in err, err
    assert re.search(r"error: ", err)
    assert len(err.strip().splitlines()) == 1, err
    assert not out.exists()


def test_cli_directory_named_like_a_preset_file(tmp_path, capsys):
    d = tmp_path / "p.json"
    d.mkdir()
    rc, text, err = _cli(["solve", "--preset", str(d), "--out", str(tmp_path / "o")], capsys)
    assert rc == 2 and "Traceback" not in text and "does not exist" in err


def test_cli_help_returns_0(capsys):
    assert main(["solve", "--help"]) == 0
    assert "--preset" in capsys.readouterr().out


# ------------------------------------------------------- angles that look like degrees, 3D fields, pairs


@pytest.mark.parametrize("beta, got", [
    (90, "90.0"), (-180.0, "-180.0"), (ms.PiecewiseConstant([0.0, 180.0]), "PiecewiseConstant with |beta| up to 180"),
    (ms.PiecewiseLinear([0.0, 0.02], [0.0, 45.0]), "PiecewiseLinear with |beta| up to 45"),
    (ms.Sampled([0.0, 0.01, 0.02], [0.0, 30.0, 60.0]), "Sampled with |beta| up to 60"),
    (lambda s: 30.0 + 0.0 * s, "Function with |beta| up to 30"),
])
def test_magnetization_in_degrees_is_refused(beta, got):
    with pytest.raises(ValueError, match=r"Beam.magnetization must be an angle in radians, \|beta\| <= 2 pi") as e:
        ms.Beam(**BEAM_KW, magnetization=beta)
    assert got in str(e.value) and "looks like degrees" in str(e.value) and "math.radians" in str(e.value)


def test_magnetization_up_to_a_full_turn_is_accepted():
    for beta in (2 * math.pi, -2 * math.pi, 6.0, ms.PiecewiseConstant([-math.pi, math.pi])):
        ms.Beam(**BEAM_KW, magnetization=beta)
    # a jig's tangent angle may wind past a turn (a spiral jig): it is geometry, not a typed angle
    t = np.linspace(0.0, 3.0 * math.pi, 60)
    jig = jig_from_points(1e-3 * (1 + t) * np.cos(t), 1e-3 * (1 + t) * np.sin(t))
    ms.Beam(length=jig.length, width=5e-3, thickness=1e-3, magnetization=jig)


def test_alternating_cells_angle_in_degrees_and_the_flip_stays_within_a_turn():
    with pytest.raises(ValueError, match=r"alternating_cells angle must be an angle in radians.*got 90.*math.radians"):
        ms.alternating_cells(2, angle=90)
    levels = ms.alternating_cells(3, angle=4.0).levels
    assert levels[0] == levels[2] == 4.0 and levels[1] == pytest.approx(4.0 - math.pi)
    assert ms.alternating_cells(2, angle=0.3).levels == (0.3, 0.3 + math.pi)  # unchanged below pi
    ms.Beam(**BEAM_KW, magnetization=ms.alternating_cells(2, angle=4.0))


def test_design_beta_bounds_in_degrees_get_the_hint():
    with pytest.raises(ValueError, match=r"beta_bounds must satisfy .*got \(-90.0, 90.0\).*looks like degrees"):
        ms.design_profile(builtin_target("ball"), ms.Beam(**BEAM_KW), field_bounds=(1e-3, 2e-2),
                          beta_bounds=(-90, 90))


def _preset_with_field(field_mT) -> dict:
    return {"description": "d", "beam": {"length_mm": 20, "width_mm": 5, "thickness_mm": 1},
            "path": [{"field_mT": field_mT}]}


def test_three_component_field_in_a_preset_file_says_files_are_planar():
    with pytest.raises(ValueError, match=r"preset files take planar fields .*\(B_x, B_z\).*\(B_x, B_y, B_z\)"):
        preset_from_dict(_preset_with_field([0, 5, 10]), name="x")


def test_cli_field_mT_with_three_numbers_to_crosscheck(tmp_path, capsys):
    cmd = ["crosscheck", "--robot", "paper-5c", "--field-mT", "0", "5", "10"]
    assert main([*cmd, "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "--field-mT takes two numbers, BX BZ in mT, got 3: 0 5 10" in err and "This part is planar" in err
    assert "magsoft solve takes --field-mT BX BY BZ" in err
    assert len(err.strip().splitlines()) == 1


def test_cli_field_mT_with_one_number(tmp_path, capsys):
    assert main(["solve", "--field-mT", "5", "--out", str(tmp_path)]) == 2
    assert "--field-mT takes two numbers, BX BZ, or three, BX BY BZ, in mT, got 1: 5." in capsys.readouterr().err


@pytest.mark.parametrize("make, message", [
    (lambda: as_field("ab"), r"field must be a pair \(B_x, B_z\) in tesla \(or a triple \(B_x, B_y, B_z\), or a "
                           r"Field\), got 'ab'"),
    (lambda: as_field(1.0), r"field must be a pair \(B_x, B_z\) in tesla"),
    (lambda: preset_from_dict(_preset_with_field([13]), name="x"), r"must be a pair \[B_x, B_z\] in mT, got \[13\]"),
    (lambda: ms.design_profile(builtin_target("ball"), ms.Beam(**BEAM_KW), field_bounds={1: 2}),
     r"field_bounds must be a pair \(min, max\) in T, got \{1: 2\}"),
    (lambda: JigProfile([(1.0, 2.0, 3.0)]), r"JigProfile pieces\[0\] must be a pair \(s, beta\) of sample sequences"),
    (lambda: turtle_curve([(1.0,)]), r"turtle_curve pieces\[0\] must be a pair \(radius_mm or None, amount\)"),
])
def test_every_pair_check_has_one_message(make, message):
    with pytest.raises(ValueError, match=message):
        make()


@pytest.mark.parametrize("value", ["ab", b"ab", {1: 2}, {1, 2}, 3, None, (1,), (1, 2, 3)])
def test_validate_pair_refuses_what_is_not_two_items(value):
    from magsoft_env.validate import pair

    with pytest.raises(ValueError, match=r"^x must be a pair \(a, b\), got .*\.$"):
        pair("x", value, "(a, b)")
    assert pair("x", [1, "b"], "(a, b)") == (1, "b")


@pytest.mark.parametrize("magnetization, top", [
    ({"kind": "uniform", "angle_deg": 400}, "400"), ({"kind": "cells", "angles_deg": [0, 720]}, "720"),
    ({"kind": "piecewise_linear", "s_mm": [0, 20], "angles_deg": [0, -450]}, "450"),
    ({"kind": "alternating_cells", "cells": 2, "angle_deg": 400}, "400"),
])
def test_file_angles_beyond_a_turn_are_reported_in_degrees(magnetization, top):
    from magsoft_env.cases.beamfile import beam_from_dict

    block = {"length_mm": 20, "width_mm": 5, "thickness_mm": 1, "magnetization": magnetization}
    with pytest.raises(ValueError, match=rf"beam magnetization angles must lie in \[-360, 360\] deg .*got up to {top}"):
        beam_from_dict(block)
    assert beam_from_dict({**block, "magnetization": {"kind": "uniform", "angle_deg": 360}}).beta(0.0) == 2 * math.pi

"""Presets: every shipped case loads, units convert, jig expressions are parsed safely."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import quad

from magsoft_env.cases import (
    compile_expression,
    list_presets,
    load_preset,
    preset_from_dict,
)
from magsoft_env.spec import Field, jig_curve

REQUIRED = {
    "fig3a_L20", "fig3a_L25", "fig3a_L30", "fig3b_L20", "fig3b_L25", "fig3b_L30",
    "fig4a_4cells_up", "fig4a_4cells_down", "fig4a_6cells_up", "fig4a_6cells_down",
    "fig4b_quadratic", "fig4c_sinusoidal", "fig4d_piecewise",
}


def _minimal(**changes):
    d = {
        "description": "test beam",
        "beam": {"length_mm": 25.0, "width_mm": 5.0, "thickness_mm": 1.13},
        "path": [{"from_mT": [0, 0], "to_mT": [0, 13], "steps": 3}],
    }
    d.update(changes)
    return d


# ----------------------------------------------------------------------------------- loading


def test_required_presets_are_shipped():
    assert REQUIRED <= set(list_presets())


@pytest.mark.parametrize("name", list_presets())
def test_every_preset_loads_with_a_valid_path(name):
    p = load_preset(name)
    assert p.name == name
    assert p.description and p.source.startswith("paper Fig.")
    fields = p.fields
    assert len(fields) >= 2
    assert all(isinstance(f, Field) for f in fields)
    assert all(a != b for a, b in zip(fields[:-1], fields[1:], strict=True))
    if p.support == "free":
        assert p.gravity == 0.0
        assert all(f.magnitude > 0 for f in fields)
    assert 20e-3 <= p.beam.length <= 40e-3
    assert p.beam.width == pytest.approx(5e-3)
    assert p.beam.thickness == pytest.approx(1.13e-3)
    assert float(p.beam.phi(0.0)) == pytest.approx(0.2)
    # the description states the length the file produces
    assert f"{p.beam.length * 1e3:.1f}".rstrip("0").rstrip(".") in p.description


@pytest.mark.parametrize(("L_mm", "lh"), [(20, 17.7), (25, 22.1), (30, 26.5)])
def test_fig3_beams_convert_mm_and_mT_to_SI(L_mm, lh):
    a = load_preset(f"fig3a_L{L_mm}")
    b = load_preset(f"fig3b_L{L_mm}")
    for p in (a, b):
        assert p.beam.length == pytest.approx(L_mm * 1e-3, rel=1e-12)
        assert round(p.beam.slenderness, 1) == lh
        assert p.beam.material.E0 == pytest.approx(0.062e6)
        assert p.beam.material.particle_magnetization == pytest.approx(575e3)
        assert p.beam.material.density == pytest.approx(1940.0)
        assert float(p.beam.beta(0.01)) == 0.0
        assert p.support == "cantilever" and p.gravity == pytest.approx(9.81)
    # Fig. 3a: B_z 0 -> 13 mT, B_x = 0
    assert (a.fields[0].Bx, a.fields[0].Bz) == (0.0, 0.0)
    assert a.fields[-1].Bz == pytest.approx(13e-3) and a.fields[-1].Bx == 0.0
    assert np.all(np.diff([f.Bz for f in a.fields]) > 0)
    # Fig. 3b: B_z held at 13 mT, B_x 0 -> -22 mT
    assert all(f.Bz == pytest.approx(13e-3) for f in b.fields)
    assert b.fields[0].Bx == 0.0 and b.fields[-1].Bx == pytest.approx(-22e-3)
    assert a.sweep_axis == "Bz" and b.sweep_axis == "Bx"


@pytest.mark.parametrize(("n", "sign"), [(4, 1), (4, -1), (6, 1), (6, -1)])
def test_fig4a_cell_beams(n, sign):
    p = load_preset(f"fig4a_{n}cells_{'up' if sign > 0 else 'down'}")
    assert p.support == "free" and p.gravity == 0.0
    assert p.beam.length == pytest.approx(n * 5e-3)
    L = p.beam.length
    mids = (np.arange(n) + 0.5) * L / n
    np.testing.assert_allclose(np.cos(p.beam.beta(mids)), [(-1) ** i for i in range(n)], atol=1e-12)
    assert len(p.beam.breakpoints()) == n - 1
    bz = [f.Bz for f in p.fields]
    assert any(b == pytest.approx(sign * 11.42e-3) for b in bz)
    assert bz[-1] == pytest.approx(sign * 14.42e-3)
    assert all(f.Bx == 0.0 for f in p.fields)


def test_unknown_preset_names_the_closest():
    with pytest.raises(ValueError, match=r"unknown preset 'fig3a_L26'.*Did you mean 'fig3a_L25'.*Available"):
        load_preset("fig3a_L26")
    with pytest.raises(ValueError, match="unknown preset 'zzz'"):
        load_preset("zzz")
    with pytest.raises(ValueError, match="non-empty string"):
        load_preset("")


def test_preset_from_a_json_file(tmp_path):
    f = tmp_path / "mine.json"
    f.write_text(json.dumps(_minimal()))
    p = load_preset(str(f))
    assert p.name == "mine" and len(p.fields) == 3 and p.fields[1].Bz == pytest.approx(6.5e-3)


def test_with_steps_resamples_each_ramp():
    p = load_preset("fig3a_L25").with_steps(5)
    np.testing.assert_allclose([f.Bz for f in p.fields], np.linspace(0, 13e-3, 5))
    with pytest.raises(ValueError, match=r"steps must be an integer in \[2, "):
        p.with_steps(1)


# ----------------------------------------------------------------------------------- file checks


@pytest.mark.parametrize(
    ("change", "match"),
    [
        ({"beam": {"length_mm": -25.0, "width_mm": 5.0, "thickness_mm": 1.13}}, r"length_mm must be > 0 \(mm\)"),
        ({"beam": {"length_mm": 25.0, "width_mm": 5.0}}, "needs key 'thickness_mm'"),
        ({"beam": {"lenght_mm": 25.0, "width_mm": 5.0, "thickness_mm": 1.1}}, "Did you mean 'length_mm'"),
        ({"beam": {"width_mm": 5.0, "thickness_mm": 1.13}}, "needs length_mm"),
        ({"path": [{"from_mT": [0, 0], "to_mT": [0, 13], "steps": 1}]}, r"steps must be an integer in \[2"),
        ({"path": [{"field_mT": [13]}]}, r"must be a pair \[B_x, B_z\] in mT"),
        ({"path": [{"field_mT": [0, 2000]}]}, "field Bz must lie in"),
        ({"path": []}, "non-empty list"),
        ({"support": "free"}, "free-free beam needs gravity 0"),
        ({"support": "pinned"}, "support must be one of"),
        ({"coupling": "rotate"}, "Did you mean 'rotated'"),
        ({"gravity_m_per_s2": -9.81}, "gravity must be >= 0"),
        ({"extensible": "yes"}, "extensible must be true or false"),
        ({"gravity": 9.81}, "unknown key 'gravity'"),
    ],
)
def test_invalid_preset_files_are_rejected(change, match):
    with pytest.raises(ValueError, match=match):
        preset_from_dict(_minimal(**change), name="bad")


def test_cell_length_must_agree_with_length():
    beam = {"length_mm": 25.0, "width_mm": 5.0, "thickness_mm": 1.13,
            "magnetization": {"kind": "alternating_cells", "cells": 4, "cell_length_mm": 5.0}}
    with pytest.raises(ValueError, match="cells give 20 mm"):
        preset_from_dict(_minimal(beam=beam), name="bad")
    del beam["length_mm"]
    assert preset_from_dict(_minimal(beam=beam), name="ok").beam.length == pytest.approx(20e-3)


def test_unknown_magnetization_kind():
    beam = {"length_mm": 25.0, "width_mm": 5.0, "thickness_mm": 1.13, "magnetization": {"kind": "jig_funtion"}}
    with pytest.raises(ValueError, match="Did you mean 'jig_function'"):
        preset_from_dict(_minimal(beam=beam), name="bad")


# ----------------------------------------------------------------------------------- expressions


def test_expression_matches_numpy():
    x = np.linspace(0.0, 40.0, 81)
    f = compile_expression("where(x < 20, -0.2*(x - 10)**2 + 20, -10*sin(0.2*pi*(x - 20)))")
    ref = np.where(x < 20, -0.2 * (x - 10) ** 2 + 20, -10 * np.sin(0.2 * np.pi * (x - 20)))
    np.testing.assert_allclose(f(x), ref, rtol=0, atol=1e-12)
    g = compile_expression("-exp(-x/10) + sqrt(abs(x - 3)) * cos(x) / 2 + +1")
    np.testing.assert_allclose(g(x), -np.exp(-x / 10) + np.sqrt(np.abs(x - 3)) * np.cos(x) / 2 + 1)
    assert compile_expression("3")(x).shape == x.shape  # constants broadcast
    h = compile_expression("where(0 < x <= 10, 1, 0)")  # chained comparison
    np.testing.assert_array_equal(h(np.array([0.0, 5.0, 10.0, 11.0])), [0, 1, 1, 0])


@pytest.mark.parametrize(
    "text",
    [
        "__import__('os').system('true')",
        "x.__class__",
        "open('f')",
        "np.sin(x)",
        "lambda: 1",
        "x[0]",
        "[x]",
        "'abc'",
        "True",
        "y + 1",
        "x if x else 1",
        "sin(x=1)",
        "sin(x, x)",
        "where(x < 1, 1)",
        "x == 1",
        "x % 2",
        "x // 2",
        "x & 1",
        "(lambda: 1)()",
        "sin",
        "x; import os",
        "",
        "x" * 600,
    ],
)
def test_expression_rejects_anything_else(text):
    with pytest.raises(ValueError, match="z_mm"):
        compile_expression(text, name="z_mm")


def test_huge_powers_overflow_instead_of_hanging():
    f = compile_expression("10**10**10 * x", name="z_mm")
    with pytest.raises(ValueError, match="z_mm = .* gives non-finite values"):
        f(np.array([1.0, 2.0]))
    with pytest.raises(ValueError, match="non-finite"):
        compile_expression("sqrt(x)")(np.array([-1.0]))
    beam = {"width_mm": 5.0, "thickness_mm": 1.13,
            "magnetization": {"kind": "jig_function", "z_mm": "10**10**10 * x", "x_start_mm": 0, "x_end_mm": 10}}
    with pytest.raises(ValueError, match="non-finite"):
        preset_from_dict(_minimal(beam=beam), name="bad")


# ----------------------------------------------------------------------------------- jig profiles


JIGS = {
    "fig4b_quadratic": (lambda x: 0.2 * (x - 20), 10.0, [11.0, 15.0, 20.0, 26.0, 29.5]),
    "fig4c_sinusoidal": (lambda x: 15 * 0.05 * np.pi * np.cos(0.05 * np.pi * x), 0.0, [0.5, 5.0, 10.0, 17.0]),
    "fig4d_piecewise": (
        lambda x: np.where(x < 20, -0.4 * (x - 10), -10 * 0.2 * np.pi * np.cos(0.2 * np.pi * (x - 20))),
        15.0,
        [15.5, 18.0, 19.9, 20.1, 22.0, 24.5],
    ),
}


@pytest.mark.parametrize("name", sorted(JIGS))
def test_jig_magnetization_is_minus_the_jig_slope_angle(name):
    """Paper eq. 1: at the point of the jig above x, beta = -atan(f'(x))."""
    dfdx, x0, xs = JIGS[name]
    beam = load_preset(name).beam
    for x in xs:
        s = quad(lambda t: math.sqrt(1.0 + float(dfdx(t)) ** 2), x0, x, points=[20.0] if x0 < 20 < x else None,
                 epsabs=1e-12)[0] * 1e-3
        assert float(beam.beta(s)) == pytest.approx(-math.atan(float(dfdx(x))), abs=1e-6), x


def test_piecewise_jig_has_its_kink_as_a_breakpoint():
    beam = load_preset("fig4d_piecewise").beam
    s_kink = quad(lambda t: math.sqrt(1.0 + (0.4 * (t - 10)) ** 2), 15.0, 20.0)[0] * 1e-3
    assert beam.breakpoints() == pytest.approx((s_kink,), rel=1e-9)
    jump = float(beam.beta(s_kink + 1e-9)) - float(beam.beta(s_kink - 1e-9))
    assert jump == pytest.approx(math.atan(2 * math.pi) - math.atan(4.0), abs=1e-6)


@pytest.mark.parametrize("name", sorted(JIGS))
def test_jig_curve_round_trip_reproduces_the_jig(name):
    """The jig rebuilt from the beam's profile (eq. 1) lies on z = f(x) - f(x_start)."""
    p = load_preset(name)
    mag = p.config["beam"]["magnetization"]
    f = compile_expression(mag["z_mm"])
    xj, zj = jig_curve(p.beam.magnetization, p.beam.length, n=101)
    x_mm = xj * 1e3 + mag["x_start_mm"]
    np.testing.assert_allclose(zj * 1e3, f(x_mm) - f(mag["x_start_mm"]), atol=2e-3)
    assert x_mm[-1] == pytest.approx(mag["x_end_mm"], abs=2e-3)


# ----------------------------------------------------------------------------------- property test

_leaf = st.one_of(
    st.just("x"), st.just("pi"), st.integers(0, 9).map(str), st.floats(0.1, 5.0).map(lambda v: f"{v:.3f}")
)


def _grow(children):
    return st.one_of(
        st.tuples(children, st.sampled_from(["+", "-", "*"]), children).map(lambda t: f"({t[0]} {t[1]} {t[2]})"),
        st.tuples(children, st.integers(1, 3)).map(lambda t: f"({t[0]})**{t[1]}"),
        children.map(lambda c: f"-({c})"),
        st.tuples(st.sampled_from(["sin", "cos", "abs"]), children).map(lambda t: f"{t[0]}({t[1]})"),
        st.tuples(children, st.sampled_from(["<", ">=", "<="]), children, children).map(
            lambda t: f"where({t[0]} {t[1]} {t[2]}, {t[3]}, 1.5)"
        ),
    )


@settings(max_examples=150, deadline=None)
@given(st.recursive(_leaf, _grow, max_leaves=8))
def test_expression_agrees_with_numpy_on_random_expressions(text):
    """The interpreter computes what numpy computes for the same formula (numpy as the reference)."""
    x = np.linspace(-3.0, 3.0, 13)
    env = {"x": x, "pi": np.pi, "sin": np.sin, "cos": np.cos, "abs": np.abs, "where": np.where}
    with np.errstate(all="ignore"):
        ref = np.asarray(eval(text, {"__builtins__": {}}, env), dtype=float) + np.zeros_like(x)  # test oracle only
    f = compile_expression(text, name="z_mm")
    if np.all(np.isfinite(ref)):
        np.testing.assert_allclose(f(x), ref, rtol=1e-12, atol=1e-12)
    else:
        with pytest.raises(ValueError, match="non-finite"):
            f(x)

"""Specification layer: material laws, profiles, jigs, fields and their validation."""

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.spec import MU0, as_profile, jig_curve, jig_from_function, jig_from_points, jig_from_polyline


def test_material_laws_match_paper_equations():
    m = ms.Material()
    assert m.youngs_modulus(0.2) == pytest.approx(0.062e6 * math.exp(0.5 / 0.73))
    assert m.remanence(0.2) == pytest.approx(MU0 * 575e3 * 0.2)
    assert m.density_at(0.3) == pytest.approx(1940.0)
    mix = ms.Material.rule_of_mixtures()
    assert mix.density_at(0.2) == pytest.approx(0.2 * 7600 + 0.8 * 1070)


def test_beam_groups_match_design_notes():
    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    g = beam.nondimensional_groups((0.0, 13e-3))
    assert g["Lambda"] == pytest.approx(71.4, abs=0.1)
    assert g["G"] == pytest.approx(22.7, abs=0.1)
    assert beam.second_moment == pytest.approx(5e-3 * 1.13e-3**3 / 12)


def test_piecewise_constant_and_breakpoints():
    p = ms.PiecewiseConstant([0.1, 0.2, 0.2], fractions=[1, 1, 2])
    L = 0.04
    np.testing.assert_allclose(p.values(np.array([0.001, 0.011, 0.039]), L), [0.1, 0.2, 0.2])
    assert p.breakpoints(L) == (pytest.approx(0.01),)  # equal neighbours are merged


def test_alternating_cells():
    p = ms.alternating_cells(4, angle=0.2)
    np.testing.assert_allclose(p.values(np.array([0.1, 0.3, 0.6, 0.9]), 1.0), [0.2, 0.2 + np.pi, 0.2, 0.2 + np.pi])
    assert len(p.breakpoints(1.0)) == 3


def test_jig_from_function_matches_analytic_slope():
    jig = jig_from_function(lambda x: 0.1 * (x - 20) ** 2, 10, 30, unit=1e-3)
    # arc length of z = 0.1 (x-20)^2 on [10, 30] mm, closed form
    u = 2.0  # slope at the ends: 0.2 * 10
    half = (u * math.sqrt(1 + u * u) + math.asinh(u)) / (2 * 0.2)
    assert jig.length == pytest.approx(2 * half * 1e-3, rel=1e-9)
    # beta = -atan(f'(x)) where the beam passes x
    s_mid = jig.length / 2
    assert jig.values(np.array([0.0, s_mid]), jig.length) == pytest.approx([-math.atan(-2.0), 0.0], abs=1e-8)


def test_jig_curve_round_trip():
    jig = jig_from_function(lambda x: 15 * np.sin(0.05 * np.pi * x), 0, 20, unit=1e-3)
    xj, zj = jig_curve(jig, jig.length, n=21)
    xs = np.linspace(0, 20, 201)
    # eq. 1 rebuilds the jig itself: z_jig = f(x) - f(x_start)
    np.testing.assert_allclose(zj * 1e3, 15 * np.sin(0.05 * np.pi * xj * 1e3), atol=2e-5)
    assert xj[-1] * 1e3 == pytest.approx(20.0, abs=2e-5)
    assert xs.size == 201


def test_jig_kink_becomes_breakpoint():
    f = lambda x: np.where(x < 20, -0.2 * (x - 10) ** 2 + 20, -10 * np.sin(0.2 * np.pi * (x - 20)))  # noqa: E731
    jig = jig_from_function(f, 10, 30, unit=1e-3, kinks=[20])
    assert len(jig.breaks) == 1
    b = jig.breaks[0]
    left, right = jig.values(np.array([b - 1e-9, b + 1e-9]), jig.length)
    assert left == pytest.approx(-math.atan(-4.0), abs=1e-6)
    assert right == pytest.approx(-math.atan(-2 * np.pi), abs=1e-6)


def test_polyline_and_points_jigs():
    poly = jig_from_polyline([0, 3e-3, 6e-3], [0, 3e-3, 3e-3])
    assert poly.values(np.array([1e-3, 5e-3]), poly.length) == pytest.approx([-math.pi / 4, 0.0])
    x = np.linspace(0, 10e-3, 30)
    pts = jig_from_points(x, 1e-3 * np.sin(x / 3e-3))
    s = np.linspace(0, pts.length, 5)
    assert np.all(np.isfinite(pts.values(s, pts.length)))


def test_field_helpers():
    f = ms.Field.from_mT(-22, 13)
    assert f.Bx == pytest.approx(-0.022) and f.angle == pytest.approx(math.atan2(13, -22))
    r = ms.ramp((0, 0), (0, 0.01), 11)
    assert len(r) == 11 and r[-1].Bz == pytest.approx(0.01)


def test_callable_magnetization_is_accepted():
    beam = ms.Beam(length=0.02, width=0.005, thickness=0.001, magnetization=lambda s: 10 * s)
    assert beam.beta(np.array([0.01]))[0] == pytest.approx(0.1)


# --- one test per validation error -------------------------------------------------------------
@pytest.mark.parametrize("name", ["length", "width", "thickness"])
def test_beam_rejects_nonpositive_sizes(name):
    kw = {"length": 0.02, "width": 0.005, "thickness": 0.001, name: -1.0}
    with pytest.raises(ValueError, match=f"Beam.{name} must be > 0"):
        ms.Beam(**kw)


def test_beam_rejects_nonfinite_size():
    with pytest.raises(ValueError, match="finite"):
        ms.Beam(length=float("nan"), width=0.005, thickness=0.001)


@pytest.mark.parametrize("value, kind", [("0.02", "a string"), (True, "a bool")])
def test_numbers_are_not_read_from_strings_or_bools(value, kind):
    with pytest.raises(ValueError, match=f"Beam.length must be a finite number .*got {kind}"):
        ms.Beam(length=value, width=0.005, thickness=0.001)
    with pytest.raises(ValueError, match=f"field Bx must be a finite number .*got {kind}"):
        ms.Field(value, 0.0)


@pytest.mark.parametrize("phi", [-0.1, 0.6, 0.74])
def test_beam_rejects_volume_fraction_out_of_range(phi):
    with pytest.raises(ValueError, match=r"volume_fraction must lie in \[0, 0.5\]"):
        ms.Beam(length=0.02, width=0.005, thickness=0.001, volume_fraction=phi)


def test_beam_rejects_volume_fraction_profile_out_of_range():
    with pytest.raises(ValueError, match="volume_fraction"):
        ms.Beam(length=0.02, width=0.005, thickness=0.001, volume_fraction=ms.PiecewiseConstant([0.2, 0.9]))


def test_beam_rejects_profile_not_covering_beam():
    jig = jig_from_function(lambda x: 0.1 * x, 0, 10, unit=1e-3)  # ~10 mm long
    with pytest.raises(ValueError, match="does not cover the beam"):
        ms.Beam(length=0.02, width=0.005, thickness=0.001, magnetization=jig)


def test_beam_rejects_nonfinite_magnetization():
    with pytest.raises(ValueError, match="magnetization must be a finite angle"), np.errstate(invalid="ignore"):
        ms.Beam(length=0.02, width=0.005, thickness=0.001, magnetization=lambda s: np.log(s - 1))


def test_beam_rejects_wrong_types():
    with pytest.raises(ValueError, match="Beam.material"):
        ms.Beam(length=0.02, width=0.005, thickness=0.001, material="silicone")
    with pytest.raises(ValueError, match="magnetization must be a number"):
        ms.Beam(length=0.02, width=0.005, thickness=0.001, magnetization="up")


def test_material_errors():
    with pytest.raises(ValueError, match="E0 must be > 0"):
        ms.Material(E0=0)
    with pytest.raises(ValueError, match="particle_magnetization must be >= 0"):
        ms.Material(particle_magnetization=-1)
    with pytest.raises(ValueError, match="density must be > 0"):
        ms.Material(density=-5)
    with pytest.raises(ValueError, match="density as a function"):
        ms.Material(density=lambda phi: -1.0)


def test_field_errors():
    with pytest.raises(ValueError, match="tesla"):
        ms.Field(0.0, 13.0)
    with pytest.raises(ValueError, match="finite"):
        ms.Field(float("inf"), 0.0)
    with pytest.raises(ValueError, match="positive integer"):
        ms.ramp((0, 0), (0, 1e-3), 0)


def test_profile_errors():
    with pytest.raises(ValueError, match="one entry per value"):
        ms.PiecewiseConstant([0, 1], fractions=[1, 2, 3])
    with pytest.raises(ValueError, match="fractions must all be > 0"):
        ms.PiecewiseConstant([0, 1], fractions=[1, 0])
    with pytest.raises(ValueError, match="strictly increasing"):
        ms.PiecewiseLinear([0, 2e-3, 1e-3], [0, 1, 2])
    with pytest.raises(ValueError, match="start at 0"):
        ms.PiecewiseLinear([1e-3, 2e-3], [0, 1])
    with pytest.raises(ValueError, match="x_end must be greater"):
        jig_from_function(lambda x: x, 5, 1)
    with pytest.raises(ValueError, match="repeated"):
        jig_from_polyline([0, 0, 1], [0, 0, 1])
    with pytest.raises(ValueError, match="positive integer"):
        ms.alternating_cells(0)
    with pytest.raises(ValueError, match="length=..."):
        ms.alternating_cells(2)(np.array([0.1]))
    with pytest.raises(ValueError, match="Profile"):
        as_profile(object(), "thing")

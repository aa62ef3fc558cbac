"""Target curves: validation errors, arc-length resampling, CSV reading, built-in contours."""

import math

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.design import BUILTIN_TARGETS, builtin_target, curve_length, read_curve_csv, resample, validate_target
from magsoft_env.design.targets import BUILTIN_PIECES, turtle_curve


def _arc(radius=1.0, turn=math.pi, n=50):
    t = np.linspace(0.0, turn, n)
    return np.column_stack([radius * np.sin(t), radius * (1 - np.cos(t))])


def test_resample_is_even_in_arc_length_and_stays_on_the_curve():
    # uneven input spacing along a circle of radius 2
    t = np.linspace(0.0, 1.0, 400) ** 2 * math.pi
    xz = np.column_stack([2 * np.sin(t), 2 * (1 - np.cos(t))])
    out = resample(xz, 31)
    steps = np.hypot(*np.diff(out, axis=0).T)
    assert np.allclose(steps, steps.mean(), rtol=1e-3)
    assert np.allclose(np.hypot(out[:, 0], out[:, 1] - 2.0), 2.0, atol=1e-4)
    assert np.allclose(out[[0, -1]], xz[[0, -1]])
    assert curve_length(xz) == pytest.approx(2 * math.pi, rel=1e-4)


@pytest.mark.parametrize("name", BUILTIN_TARGETS)
def test_builtin_contours_start_at_clamp_with_x_tangent_and_match_their_pieces(name):
    xz = builtin_target(name)
    validate_target(xz)
    assert np.allclose(xz[0], 0.0)
    d = xz[1] - xz[0]
    assert abs(math.atan2(d[1], d[0])) < 0.05
    # length from the construction: straight lengths plus radius x turn (mm)
    expected_mm = sum(a if r is None else r * math.radians(abs(a)) for r, a in BUILTIN_PIECES[name]["pieces"])
    assert curve_length(xz) == pytest.approx(expected_mm * 1e-3, rel=2e-3)
    assert 15e-3 < curve_length(xz) < 35e-3  # centimetre-scale fingers, like the paper's beams


def test_ball_contour_lies_on_its_circle():
    xz = builtin_target("ball")
    assert np.allclose(np.hypot(xz[:, 0], xz[:, 1] - 10e-3), 10e-3, atol=1e-7)


def test_turtle_curve_straight_then_quarter_circle():
    xz = turtle_curve([(None, 2.0), (1.0, 90.0)], step=0.01)
    assert np.allclose(xz[-1], [3.0, 1.0], atol=1e-9)


@pytest.mark.parametrize(
    ("bad", "fragment"),
    [
        (np.zeros((3, 3)), "shape (N, 2)"),
        (np.array([[0, 0], [1, 0], [2, 0.5]]), "at least 4 distinct points, got 3"),
        (np.array([[0, 0], [1, 0], [1, 0], [1, 0], [2, 1]]), "at least 4 distinct points, got 3"),
        (np.array([[0, 0], [1, 0], [np.nan, 1], [2, 2], [3, 3]]), "non-finite values in rows [2]"),
        (np.array([[0, 0], [1, 0], [np.inf, 1], [2, 2]]), "finite"),
        (np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, -1]]), "must not intersect itself"),
        ("abc", "(N, 2)"),
    ],
)
def test_validate_target_rejects_unusable_curves(bad, fragment):
    with pytest.raises(ValueError, match="target_xz") as info:
        validate_target(bad)
    assert fragment in str(info.value)


def test_figure_eight_is_self_intersecting():
    t = np.linspace(0, 2 * np.pi * 0.9, 80)
    xz = np.column_stack([np.sin(t), np.sin(t) * np.cos(t)])
    with pytest.raises(ValueError, match="intersect"):
        validate_target(xz)


def test_touching_collinear_overlap_is_self_intersecting():
    xz = np.array([[0, 0], [3, 0], [3, 1], [2, 1], [2, 0.0], [1, 0.0]])
    with pytest.raises(ValueError, match="intersect"):
        validate_target(xz)


def test_design_profile_rejects_bad_target_before_any_solve(monkeypatch):
    import magsoft_env.theory as theory

    def boom(*a, **k):  # any solve would be work done before validation
        raise AssertionError("solver called")

    monkeypatch.setattr(theory, "solve_equilibrium", boom)
    beam = ms.Beam(length=20e-3, width=5e-3, thickness=1.13e-3)
    with pytest.raises(ValueError, match="at least 4"):
        ms.design_profile(np.zeros((2, 2)), beam, field_bounds=(0, 0.02))
    with pytest.raises(ValueError, match="field_bounds"):
        ms.design_profile(_arc(0.01), beam, field_bounds=(0.02, 0.01))
    with pytest.raises(ValueError, match="family"):
        ms.design_profile(_arc(0.01), beam, field_bounds=(0, 0.02), family="splien")
    with pytest.raises(ValueError, match="n_starts"):
        ms.design_profile(_arc(0.01), beam, field_bounds=(0, 0.02), n_starts=0)


def test_read_curve_csv_units(tmp_path):
    p = tmp_path / "c.csv"
    p.write_text("# comment\nx_mm,z_mm\n0,0\n1,0\n2,1\n")
    assert np.allclose(read_curve_csv(p), [[0, 0], [1e-3, 0], [2e-3, 1e-3]])
    q = tmp_path / "m.csv"
    q.write_text("z_m,x_m\n0,0\n0.5,1\n")
    assert np.allclose(read_curve_csv(q), [[0, 0], [1, 0.5]])
    r = tmp_path / "bad.csv"
    r.write_text("x,z\n0,0\n")
    with pytest.raises(ValueError, match="x_mm,z_mm"):
        read_curve_csv(r)
    with pytest.raises(ValueError, match="does not exist"):
        read_curve_csv(tmp_path / "missing.csv")


def test_unknown_builtin_suggests_closest():
    with pytest.raises(ValueError, match="Did you mean 'vase'"):
        builtin_target("vace")

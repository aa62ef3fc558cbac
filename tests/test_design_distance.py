"""Point-to-curve distance (the eq. 18 residual) against brute force and closed forms."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from magsoft_env.design import point_to_polyline


def _brute(points, curve, per_segment=4000):
    t = np.linspace(0.0, 1.0, per_segment)
    dense = np.concatenate([a + t[:, None] * (b - a) for a, b in zip(curve[:-1], curve[1:], strict=True)])
    d = np.hypot(points[:, None, 0] - dense[None, :, 0], points[:, None, 1] - dense[None, :, 1])
    return d.min(axis=1), max(np.hypot(*np.diff(curve, axis=0).T)) / (per_segment - 1)


coords = st.floats(-5, 5, allow_nan=False, allow_infinity=False)


@settings(max_examples=40, deadline=None)
@given(
    curve=st.lists(st.tuples(coords, coords), min_size=2, max_size=7),
    points=st.lists(st.tuples(coords, coords), min_size=1, max_size=6),
)
def test_matches_brute_force(curve, points):
    c = np.array(curve, dtype=float)
    p = np.array(points, dtype=float)
    exact = point_to_polyline(p, c)
    brute, spacing = _brute(p, c)
    # the dense sampling can only overestimate, by at most half its spacing
    assert np.all(exact <= brute + 1e-9)
    assert np.all(brute - exact <= 0.5 * spacing + 1e-9)
    assert np.allclose(np.abs(point_to_polyline(p, c, signed=True)), exact)


def test_distance_is_to_the_curve_not_its_vertices():
    curve = np.array([[0.0, 0.0], [10.0, 0.0]])
    assert point_to_polyline(np.array([[5.0, 1.0]]), curve)[0] == pytest.approx(1.0)


def test_circle_polygon_distance_closed_form():
    # points at radius 2 from the centre of a fine polygon of the unit circle: distance ~ 1
    t = np.linspace(0, 2 * np.pi, 2001)
    circle = np.column_stack([np.cos(t), np.sin(t)])
    ang = np.linspace(0.1, 6.0, 9)
    p = 2.0 * np.column_stack([np.cos(ang), np.sin(ang)])
    assert np.allclose(point_to_polyline(p, circle), 1.0, atol=2e-6)
    assert np.allclose(point_to_polyline(0.5 * p / 2, circle), 0.5, atol=2e-6)


def test_sign_left_positive_right_negative():
    curve = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    d = point_to_polyline(np.array([[0.5, 0.3], [1.5, -0.2]]), curve, signed=True)
    assert d == pytest.approx([0.3, -0.2])


def test_bad_shapes():
    with pytest.raises(ValueError, match="curve must have shape"):
        point_to_polyline(np.zeros((2, 2)), np.zeros((1, 2)))
    with pytest.raises(ValueError, match="points must have shape"):
        point_to_polyline(np.zeros(2), np.zeros((3, 2)))

"""Field sources against closed forms and independent quadratures, their gradients against finite differences,
div B = 0 and curl B = 0 away from matter, the MPEM coil systems against their files, poses, sums, input errors."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

from magsoft_env.assets import asset_path
from magsoft_env.fields import (
    CALIBRATIONS,
    CircularLoop,
    CoaxialLoops,
    CoilSystem,
    CuboidMagnet,
    CylinderMagnet,
    DipoleSet,
    GridField,
    MovingSource,
    PointDipole,
    Source,
    SourceSum,
    SphereMagnet,
    Transformed,
    Uniform,
    helmholtz_pair,
    maxwell_pair,
    rotation_about,
)
from magsoft_env.spec import MU0, Field

K = MU0 / (4 * math.pi)
RTOL = 1e-10  # closed forms, quadratures, div and curl
RNG = np.random.default_rng(20240607)


def _rel(a, b) -> float:
    """Largest difference relative to the largest magnitude of the reference."""
    return float(np.abs(np.asarray(a) - np.asarray(b)).max() / np.abs(np.asarray(b)).max())


def _fd_gradient(source, points, h):
    """Central differences of the field, fourth order (Richardson): G[i, a, b] = dB_a/dx_b."""
    G = np.empty((len(points), 3, 3))
    for b in range(3):
        e = np.zeros(3)
        e[b] = h
        f = [source.field(points + s * e) for s in (-2, -1, 1, 2)]
        G[:, :, b] = (8 * (f[2] - f[1]) - (f[3] - f[0])) / (12 * h)
    return G


def _div_curl(G) -> tuple[float, float]:
    """max |trace G| and max |G - G^T|, each relative to max |G|."""
    scale = np.abs(G).max()
    return (float(np.abs(np.trace(G, axis1=1, axis2=2)).max() / scale),
            float(np.abs(G - G.transpose(0, 2, 1)).max() / scale))


# ----------------------------------------------------------------------------------- independent references


def _dipole_reference(points, position, m):
    """DESIGN section 12's formulas, point by point."""
    B, G = [], []
    for x in points:
        r = x - position
        d = np.linalg.norm(r)
        rh = r / d
        B.append(K * (3 * rh * (m @ rh) - m) / d**3)
        G.append(K * 3 / d**4 * (np.outer(m, rh) + np.outer(rh, m) + (m @ rh) * (np.eye(3) - 5 * np.outer(rh, rh))))
    return np.array(B), np.array(G)


def _biot_savart(x, center, normal, radius, current, n=4000):
    """Field and gradient of a loop by the periodic trapezoid rule on Biot-Savart (exponentially convergent off
    the wire): B = mu0 I/(4 pi) sum dl x R / |R|^3, and its derivative in x."""
    normal = np.asarray(normal, float) / np.linalg.norm(normal)
    u = np.cross(normal, [1.0, 0, 0] if abs(normal[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(normal, u)
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    wire = center + radius * (np.outer(np.cos(t), u) + np.outer(np.sin(t), v))
    dl = radius * (np.outer(-np.sin(t), u) + np.outer(np.cos(t), v)) * (2 * np.pi / n)
    R = x - wire
    d = np.linalg.norm(R, axis=1)[:, None]
    c = MU0 * current / (4 * np.pi)
    B = c * (np.cross(dl, R) / d**3).sum(axis=0)
    G = np.empty((3, 3))
    for b in range(3):
        e = np.zeros(3)
        e[b] = 1.0
        G[:, b] = c * (np.cross(dl, e) / d**3 - 3 * np.cross(dl, R) * R[:, b:b + 1] / d**5).sum(axis=0)
    return B, G


def _gauss_legendre(a, b, n):
    x, w = np.polynomial.legendre.leggauss(n)
    return 0.5 * (b - a) * x + 0.5 * (b + a), 0.5 * (b - a) * w


def _cuboid_reference(x, dims, M, n=60):
    """B of a cuboid (centred, axis-aligned) by Gauss-Legendre quadrature of its face charges M . n (points not
    near a face): H = sum sigma/(4 pi) int (x - x') / |x - x'|^3 dA, B = mu0 (H + M inside)."""
    h = np.asarray(dims) / 2
    H = np.zeros(3)
    for axis in range(3):
        o1, o2 = [i for i in range(3) if i != axis]
        s1, w1 = _gauss_legendre(-h[o1], h[o1], n)
        s2, w2 = _gauss_legendre(-h[o2], h[o2], n)
        S1, S2 = np.meshgrid(s1, s2, indexing="ij")
        W = np.outer(w1, w2)
        for side in (1.0, -1.0):
            src = np.zeros((S1.size, 3))
            src[:, o1], src[:, o2], src[:, axis] = S1.ravel(), S2.ravel(), side * h[axis]
            r = x - src
            d3 = np.linalg.norm(r, axis=1)[:, None] ** 3
            H += side * M[axis] / (4 * np.pi) * (W.ravel()[:, None] * r / d3).sum(axis=0)
    inside = np.all(np.abs(x) < h)
    return MU0 * (H + (M if inside else 0.0))


def _mpem_sum(path, point, currents, coils=None):
    """The dipole sum of an MPEM file as written (B_Coeff * Source_Direction, not normalized), independently."""
    data = yaml.safe_load(open(path))
    B = np.zeros(3)
    for coil, current in zip(coils or [c for c in data["Coil_List"] if c != "Offset"], currents, strict=True):
        for s in data[coil]["Source_List"]:
            src = data[coil][s]
            m = float(src["B_Coeff"][0]) * np.array(src["Source_Direction"], float)
            r = point - np.array(src["Source_Position"], float)
            d = np.linalg.norm(r)
            B += current * (3 * r * (m @ r) / d**5 - m / d**3)
    return B


# ------------------------------------------------------------------------------------------------- sources


def _sources():
    """(name, source, points away from its material, length scale for finite differences)."""
    near = RNG.normal(size=(12, 3)) * 0.02
    loop = CircularLoop(center=(0.01, -0.02, 0.005), normal=(1, 2, 2), radius=0.03, current=5.0)
    cyl = CylinderMagnet(position=(0.0, 0.0, 0.0), axis=(0.2, 0.3, 1.0), radius=0.004, length=0.01,
                         magnetization=9e5)
    cub = CuboidMagnet(position=(0.001, 0.0, -0.002), dimensions=(0.006, 0.01, 0.004), magnetization=(3e5, -1e5, 8e5),
                       rotation=rotation_about((1, 1, 0), 0.4))
    sph = SphereMagnet(position=(0.0, 0.0, 0.0), radius=0.003, magnetization=(1e5, 2e5, 9e5))
    outside = near[np.linalg.norm(near, axis=1) > 0.012]
    local = (near - loop.center) @ loop._R
    off_wire = near[np.hypot(np.hypot(local[:, 0], local[:, 1]) - loop.radius, local[:, 2]) > 0.005]
    coils = CoilSystem.from_calibration("cardiomag").at_currents(np.linspace(-20, 20, 8))
    return [
        ("dipole", PointDipole(position=(0.001, 0.002, -0.003), moment=(0.1, -0.2, 0.3)), near, 2e-5),
        ("sphere", sph, outside, 2e-5),
        ("loop", loop, off_wire, 2e-5),
        ("helmholtz", helmholtz_pair(center=(0, 0, 0.01), normal=(0, 1, 0), radius=0.05, current=2.0), near, 2e-5),
        ("maxwell", maxwell_pair(normal=(1, 0, 1), radius=0.05, current=2.0), near, 2e-5),
        ("cylinder", cyl, outside, 2e-5),
        ("cuboid", cub, outside, 2e-5),
        ("cardiomag", coils, near, 1e-3),
        ("moved", Transformed(cyl, (0.05, 0.0, 0.0), rotation_about((0, 0, 1), 1.0)), outside + [0.05, 0, 0], 2e-5),
        ("sum", loop + sph + Uniform((0.001, 0.002, 0.003)), off_wire[np.linalg.norm(off_wire, axis=1) > 0.012], 2e-5),
    ]


SOURCES = _sources()
IDS = [s[0] for s in SOURCES]


@pytest.mark.parametrize("name, source, points, h", SOURCES, ids=IDS)
def test_gradient_matches_finite_differences(name, source, points, h):
    B, G = source.field_and_gradient(points)
    assert B.shape == (len(points), 3) and G.shape == (len(points), 3, 3)
    assert _rel(G, _fd_gradient(source, points, h)) < 1e-7


@pytest.mark.parametrize("name, source, points, h", SOURCES, ids=IDS)
def test_divergence_and_curl_vanish_away_from_matter(name, source, points, h):
    div, curl = _div_curl(source.field_and_gradient(points)[1])
    assert div < RTOL and curl < RTOL


# ---------------------------------------------------------------------------------------------- uniform


def test_uniform_is_the_fields_vector_bit_for_bit():
    for value in (Field.from_mT(-22, 13), (0.003, 0.004), (0.001, -0.002, 0.0031)):
        B, G = Uniform(value).field_and_gradient(np.zeros((4, 3)))
        want = value.vector() if isinstance(value, Field) else Field(*value).vector()
        assert all((row == want).all() for row in B) and not G.any()
    assert Uniform((1e-3, 2e-3)).B == (1e-3, 0.0, 2e-3)  # a pair is (B_x, B_z)


# ---------------------------------------------------------------------------------------------- dipoles


def test_point_dipole_against_its_closed_forms():
    m = np.array([0.3, -0.1, 0.7])
    pos = np.array([0.01, -0.02, 0.005])
    d = PointDipole(position=pos, moment=m)
    pts = pos + RNG.normal(size=(20, 3)) * 0.03
    B, G = d.field_and_gradient(pts)
    Br, Gr = _dipole_reference(pts, pos, m)
    assert _rel(B, Br) < RTOL and _rel(G, Gr) < RTOL
    # on its axis and in its equatorial plane
    z = PointDipole(position=(0, 0, 0), moment=(0, 0, 2.0))
    B, G = z.field_and_gradient(np.array([[0, 0, 0.05], [0.05, 0, 0]]))
    assert B[0, 2] == pytest.approx(K * 2 * 2.0 / 0.05**3, rel=RTOL)
    assert B[1, 2] == pytest.approx(-K * 2.0 / 0.05**3, rel=RTOL)
    assert G[0, 2, 2] == pytest.approx(-3 * K * 2 * 2.0 / 0.05**4, rel=RTOL)


def test_sphere_is_a_dipole_outside_and_uniform_inside():
    M = np.array([1e5, -3e5, 6e5])
    s = SphereMagnet(position=(0.01, 0, 0), radius=0.004, magnetization=M)
    m = 4 / 3 * math.pi * 0.004**3 * M
    out = np.array([[0.01, 0, 0.005], [0.02, 0.003, -0.001]])
    B, G = s.field_and_gradient(out)
    Br, Gr = _dipole_reference(out, np.array([0.01, 0, 0]), m)
    assert _rel(B, Br) < RTOL and _rel(G, Gr) < RTOL
    B, G = s.field_and_gradient(np.array([[0.011, 0.001, -0.002]]))
    assert np.allclose(B[0], 2 / 3 * MU0 * M, rtol=1e-15) and not G.any()
    same = SphereMagnet(position=(0.01, 0, 0), radius=0.004, moment=m)
    assert np.allclose(same.magnetization, M, rtol=1e-12)


def test_a_point_on_a_dipole_is_refused():
    with pytest.raises(ValueError, match=r"points\[1\].*within 1e-09 m of the dipole"):
        PointDipole(position=(0, 0, 0), moment=(0, 0, 1)).field(np.array([[0, 0, 0.1], [0, 0, 0]]))


def test_dipole_set_is_the_sum_of_its_dipoles():
    pos = RNG.normal(size=(5, 3)) * 0.1
    mom = RNG.normal(size=(5, 3))
    pts = RNG.normal(size=(7, 3)) * 0.01
    B, G = DipoleSet(pos, mom).field_and_gradient(pts)
    parts = [PointDipole(position=p, moment=m).field_and_gradient(pts) for p, m in zip(pos, mom, strict=True)]
    assert _rel(B, sum(b for b, _ in parts)) < 1e-13 and _rel(G, sum(g for _, g in parts)) < 1e-13


# --------------------------------------------------------------------------------------------------- loops


def test_loop_on_its_axis_is_the_closed_form():
    R, I = 0.04, 3.0
    loop = CircularLoop(center=(0, 0, 0.01), normal=(0, 0, 1), radius=R, current=I)
    z = np.linspace(-0.1, 0.1, 21)
    B, G = loop.field_and_gradient(np.column_stack([0 * z, 0 * z, z + 0.01]))
    assert _rel(B[:, 2], MU0 * I * R**2 / (2 * (R**2 + z**2) ** 1.5)) < RTOL
    assert np.abs(B[:, :2]).max() == 0.0
    dz = -3 * MU0 * I * R**2 * z / (2 * (R**2 + z**2) ** 2.5)
    assert _rel(G[:, 2, 2], dz) < RTOL
    assert _rel(G[:, 0, 0], -dz / 2) < RTOL and _rel(G[:, 1, 1], -dz / 2) < RTOL  # axis limit of B_rho / rho


@pytest.mark.parametrize("rho_over_R", [0.0, 1e-9, 1e-4, 0.3, 0.9, 1.1, 3.0])
def test_loop_off_its_axis_against_biot_savart(rho_over_R):
    c, n, R, I = np.array([0.01, 0.0, -0.02]), np.array([1.0, -1.0, 2.0]), 0.03, -4.0
    loop = CircularLoop(center=c, normal=n, radius=R, current=I)
    u = np.cross(n, [1, 0, 0])
    u /= np.linalg.norm(u)
    for h in (-0.5 * R, 0.2 * R, 1.5 * R):
        x = c + rho_over_R * R * u + h * n / np.linalg.norm(n)
        B, G = loop.field_and_gradient(x.reshape(1, 3))
        Bq, Gq = _biot_savart(x, c, n, R, I)
        assert _rel(B[0], Bq) < RTOL and _rel(G[0], Gq) < RTOL


def test_coaxial_loops_are_the_sum_of_their_loops():
    coil = CoaxialLoops(center=(0.01, 0, 0), normal=(0, 1, 1), offsets=[-0.02, 0.0, 0.015], radii=[0.03, 0.02, 0.04],
                        currents=[2.0, -1.0, 0.5])
    x = RNG.normal(size=(9, 3)) * 0.01
    B, G = coil.field_and_gradient(x)
    parts = [loop.field_and_gradient(x) for loop in coil.loops]
    assert _rel(B, sum(b for b, _ in parts)) < 1e-14 and _rel(G, sum(g for _, g in parts)) < 1e-14
    with pytest.raises(ValueError, match=r"one radius and one current per offset \(3\)"):
        CoaxialLoops(center=(0, 0, 0), normal=(0, 0, 1), offsets=[0, 0.1, 0.2], radii=[0.1, 0.1], currents=1.0)


def test_the_wire_is_refused():
    loop = CircularLoop(center=(0, 0, 0), normal=(0, 0, 1), radius=0.02, current=1.0)
    with pytest.raises(ValueError, match=r"points\[0\].*on the wire of the loop"):
        loop.field(np.array([[0.02, 0.0, 0.0]]))
    assert np.isfinite(loop.field(np.array([[0.02, 0.0, 1e-6]]))).all()


def test_helmholtz_pair_is_uniform_to_the_fourth_order():
    R, I = 0.05, 2.0
    pair = helmholtz_pair(center=(0, 0, 0), normal=(0, 0, 1), radius=R, current=I)
    B0, G0 = pair.field_and_gradient(np.zeros((1, 3)))
    assert B0[0, 2] == pytest.approx((4 / 5) ** 1.5 * MU0 * I / R, rel=RTOL)
    assert np.abs(G0).max() < 1e-12 * B0[0, 2] / R
    for h in (0.02 * R, 0.04 * R):  # B(z) = B0 (1 - 144/125 (z/R)^4 + O(z^6))
        Bh = pair.field(np.array([[0, 0, h], [0, 0, -h]]))[:, 2]
        assert (Bh - B0[0, 2]) / B0[0, 2] == pytest.approx(-144 / 125 * (h / R) ** 4, rel=0.02)
        second = (Bh.sum() - 2 * B0[0, 2]) / h**2  # zero: the curvature would be O(B0 / R^2) otherwise
        assert abs(second) < 0.01 * B0[0, 2] / R**2


def test_maxwell_pair_gradient_at_the_centre():
    R, I = 0.05, 2.0
    pair = maxwell_pair(center=(0, 0, 0), normal=(0, 0, 1), radius=R, current=I)
    B, G = pair.field_and_gradient(np.zeros((1, 3)))
    assert np.abs(B).max() < 1e-20
    want = 3 * math.sqrt(3) / 2 * (4 / 7) ** 2.5 * MU0 * I / R**2
    assert G[0, 2, 2] == pytest.approx(want, rel=RTOL) and want == pytest.approx(0.6413 * MU0 * I / R**2, rel=1e-4)
    assert G[0, 0, 0] == pytest.approx(-want / 2, rel=RTOL)


# ------------------------------------------------------------------------------------------------- magnets


def test_cylinder_on_its_axis_inside_and_outside():
    a, L, M = 0.005, 0.02, 9e5
    cyl = CylinderMagnet(position=(0, 0, 0), axis=(0, 0, 1), radius=a, length=L, magnetization=M)
    z = np.linspace(-0.04, 0.04, 17)
    b = L / 2
    want = MU0 * M / 2 * ((z + b) / np.hypot(z + b, a) - (z - b) / np.hypot(z - b, a))
    B = cyl.field(np.column_stack([0 * z, 0 * z, z]))
    assert _rel(B[:, 2], want) < RTOL


def test_cylinder_off_its_axis_against_a_stack_of_loops():
    """The cylinder as a solenoid of surface current M: Gauss-Legendre over its length of Biot-Savart loops."""
    a, L, M = 0.005, 0.02, 9e5
    cyl = CylinderMagnet(position=(0, 0, 0), axis=(0, 0, 1), radius=a, length=L, magnetization=M)
    zs, w = _gauss_legendre(-L / 2, L / 2, 80)
    for x in ([0.003, 0.001, 0.002], [0.012, -0.004, 0.0], [0.004, 0.003, 0.02], [0.001, 0.0, -0.0149]):
        x = np.array(x)
        B, G = cyl.field_and_gradient(x.reshape(1, 3))
        Bq = sum(wi * _biot_savart(x, np.array([0, 0, zi]), (0, 0, 1), a, M)[0] for zi, wi in zip(zs, w, strict=True))
        assert _rel(B[0], Bq) < RTOL


def test_cuboid_against_a_quadrature_of_its_face_charges():
    dims, M = np.array([0.006, 0.01, 0.004]), np.array([3e5, -1e5, 8e5])
    cub = CuboidMagnet(position=(0, 0, 0), dimensions=dims, magnetization=M)
    # outside, inside, and on the lines of two edges and in the plane of a face (off the magnet)
    for x in ([0.01, 0.004, 0.006], [-0.012, 0.0, 0.001], [0.0, 0.0, 0.0], [0.001, -0.002, 0.0005],
              [0.003, 0.012, 0.002], [-0.003, -0.011, 0.002], [0.009, 0.001, 0.002]):
        x = np.array(x)
        assert _rel(cub.field(x.reshape(1, 3))[0], _cuboid_reference(x, dims, M)) < RTOL
    # far away: the dipole M V (its quadrupole vanishes by symmetry)
    far = np.array([[0.0, 0.0, 2.0], [1.5, 1.0, -0.3]])
    B, G = cub.field_and_gradient(far)
    Bd, Gd = _dipole_reference(far, np.zeros(3), M * dims.prod())
    assert _rel(B, Bd) < 1e-4 and _rel(G, Gd) < 1e-4


def test_magnets_inside_are_continuous_with_outside():
    cub = CuboidMagnet(position=(0, 0, 0), dimensions=(0.01, 0.01, 0.01), magnetization=(0, 0, 1e6))
    eps = 1e-7  # across the top face: B_z (normal) continuous; across a side face: H_z tangential continuous
    B = cub.field(np.array([[0.001, 0.002, 0.005 - eps], [0.001, 0.002, 0.005 + eps]]))
    assert B[0, 2] == pytest.approx(B[1, 2], rel=1e-4)
    B = cub.field(np.array([[0.005 - eps, 0.001, 0.0], [0.005 + eps, 0.001, 0.0]]))
    assert B[0, 2] - B[1, 2] == pytest.approx(MU0 * 1e6, rel=1e-4)  # the magnetization current sheet
    with pytest.raises(ValueError, match=r"points\[0\].*on the cuboid's surface"):
        cub.field(np.array([[0.005, 0.001, 0.0]]))
    cyl = CylinderMagnet(position=(0, 0, 0), radius=0.005, length=0.01, magnetization=1e6)
    with pytest.raises(ValueError, match="side surface or rim"):
        cyl.field(np.array([[0.005, 0.0, 0.001]]))


def test_magnets_against_magpylib():
    magpy = pytest.importorskip("magpylib")
    from scipy.spatial.transform import Rotation

    pts = RNG.normal(size=(30, 3)) * 0.01
    cyl = CylinderMagnet(position=(0.001, 0, 0), axis=(0.3, 0.1, 1), radius=0.004, length=0.012, magnetization=8e5)
    ref = magpy.magnet.Cylinder(position=(0.001, 0, 0), orientation=Rotation.from_matrix(cyl._R),
                                dimension=(0.008, 0.012), polarization=(0, 0, MU0 * 8e5))
    R = rotation_about((0, 1, 1), 0.7)
    cub = CuboidMagnet(position=(0, 0.001, 0), dimensions=(0.004, 0.006, 0.008), magnetization=(1e5, 2e5, -7e5),
                       rotation=R)
    refc = magpy.magnet.Cuboid(position=(0, 0.001, 0), orientation=Rotation.from_matrix(R),
                               dimension=(0.004, 0.006, 0.008), polarization=MU0 * np.array([1e5, 2e5, -7e5]))
    assert _rel(cyl.field(pts), ref.getB(pts)) < 1e-9 and _rel(cub.field(pts), refc.getB(pts)) < 1e-9


# -------------------------------------------------------------------------------------------- coil systems


@pytest.mark.parametrize("name", ["navion", "cardiomag", "octomag"])
def test_mpem_evaluation_is_the_dipole_sum_of_the_file(name):
    coils = CoilSystem.from_calibration(name)
    path = asset_path("fields", CALIBRATIONS[name].file)
    pts = RNG.uniform(-0.04, 0.04, size=(6, 3))
    I = RNG.uniform(-1, 1, size=coils.n_coils) * coils.max_current
    B = coils.field(pts, I)
    for x, b in zip(pts, B, strict=True):
        assert _rel(b, _mpem_sum(path, x, I)) < 1e-9
    assert _rel(coils.at_currents(I).field(pts), B) < 1e-14


def test_navion_per_ampere_at_the_centre_is_designs():
    A = CoilSystem.from_calibration("navion").actuation_matrix([0, 0, 0])[:3] * 1e3  # mT/A
    design = [(0.000, -0.291, -0.414), (-0.388, 0.330, -0.199), (0.385, 0.323, -0.192)]
    assert np.abs(A.T - np.array(design)).max() <= 5e-4  # DESIGN's numbers are rounded to 0.001 mT/A


def test_actuation_matrix_is_the_linear_map_of_the_currents():
    coils = CoilSystem.from_calibration("cardiomag")
    x = np.array([0.01, -0.005, 0.02])
    A, A12 = coils.actuation_matrix(x), coils.actuation_matrix(x, full=True)
    assert A.shape == (8, 8) and A12.shape == (12, 8)
    I = np.linspace(-15, 15, 8)
    B, G = coils.field_and_gradient(x.reshape(1, 3), I)
    assert _rel(A12 @ I, np.concatenate([B[0], G[0].ravel()])) < 1e-13
    assert _rel(A @ I, [*B[0], G[0, 0, 0], G[0, 0, 1], G[0, 0, 2], G[0, 1, 1], G[0, 1, 2]]) < 1e-13
    mx = coils.max_field(x)  # reached by the currents at their limits with the signs of the row
    for a in range(3):
        assert coils.field(x.reshape(1, 3), np.sign(A[a]) * coils.max_current)[0, a] == pytest.approx(mx[a], rel=1e-13)


def test_every_named_system_loads_with_its_limits():
    for name, cal in CALIBRATIONS.items():
        coils = CoilSystem.from_calibration(name)
        assert coils.name == name and (coils.max_current == cal.max_current).all()
    assert CoilSystem.from_calibration("navion").max_current.tolist() == [35.0] * 3
    assert CoilSystem.from_calibration("cardiomag").offset is None  # its Offset block is not in Coil_List


def _write(tmp_path, data, name="sys.yaml"):
    p = tmp_path / name
    p.write_text(yaml.safe_dump(data))
    return p


def _two_coils():
    src = {"A_Coeff": None, "B_Coeff": [1e-4], "Source_Direction": [1.0, 0.0, 0.0],
           "Source_Position": [-0.15, 0.0, 0.0]}
    src2 = {**src, "Source_Direction": [0.0, 1.0, 0.0], "Source_Position": [0.0, -0.15, 0.0]}
    return {"System_Name": "two", "Coil_List": ["Coil_0", "Coil_1"], "Coil_0": {"Source_List": ["Src_0"], "Src_0": src},
            "Coil_1": {"Source_List": ["Src_0"], "Src_0": src2}, "Max_Current": [2.0, 3.0]}


def test_a_file_with_limits_and_an_offset(tmp_path):
    data = _two_coils()
    coils = CoilSystem.from_calibration(str(_write(tmp_path, data)))
    assert coils.max_current.tolist() == [2.0, 3.0] and coils.name == "two"
    data["Coil_List"].append("Offset")
    data["Offset"] = {"Source_List": ["Src_0"], "Src_0": {**data["Coil_0"]["Src_0"], "B_Coeff": [5e-6]}}
    with_offset = CoilSystem.from_file(_write(tmp_path, data, "o.yaml"))
    x = np.array([[0.01, 0.02, 0.0]])
    off = _mpem_sum(_write(tmp_path, data, "o.yaml"), x[0], [1.0], coils=["Offset"])
    assert with_offset.n_coils == 2 and _rel(with_offset.field(x, [0.0, 0.0])[0], off) < 1e-12
    assert _rel(with_offset.field(x, [1.0, -2.0]) - coils.field(x, [1.0, -2.0]), off.reshape(1, 3)) < 1e-12


@pytest.mark.parametrize("edit, match", [
    (lambda d: d.pop("Coil_List"), "Coil_List must be a non-empty list"),
    (lambda d: d.pop("Coil_1"), "coil 'Coil_1' .* has no block"),
    (lambda d: d["Coil_0"]["Src_0"].pop("B_Coeff"), "Coil_0.Src_0 has no B_Coeff"),
    (lambda d: d["Coil_0"]["Src_0"].update(A_Coeff=[1.0]), "Coil_0.Src_0.A_Coeff must be ~"),
    (lambda d: d["Coil_0"]["Src_0"].update(B_Coeff=[1e-4, 2e-5]), r"Coil_0.Src_0.B_Coeff must be a list of one"),
    (lambda d: d["Coil_1"]["Src_0"].update(Source_Direction=[0, 0, 0]), "Coil_1.Src_0.Source_Direction must not"),
    (lambda d: d["Coil_1"]["Src_0"].update(Source_Position=[0, "a", 0]), r"Source_Position\[1\] must be a finite"),
    (lambda d: d.update(Max_Current=[2.0]), r"Max_Current must be one limit .* or one per coil \(2"),
    (lambda d: d.update(Max_Current=-1), r"coil 0 \(Coil_0\) must lie in \(0, 1000\] A"),
    (lambda d: d.pop("Max_Current"), "has no Max_Current; pass max_current="),
])
def test_a_bad_file_is_refused_naming_the_key(tmp_path, edit, match):
    data = _two_coils()
    edit(data)
    with pytest.raises(ValueError, match=match):
        CoilSystem.from_calibration(str(_write(tmp_path, data)))


def test_bad_currents_and_names_are_refused():
    navion = CoilSystem.from_calibration("navion")
    with pytest.raises(ValueError, match=r"currents\[2\] \(Coil_2\) = -40.0 A exceeds its limit \+-35 A"):
        navion.field(np.zeros((1, 3)), [0, 0, -40])
    with pytest.raises(ValueError, match=r"currents must have shape \(3,\)"):
        navion.at_currents([1.0, 2.0])
    with pytest.raises(ValueError, match="Did you mean 'cardiomag'"):
        CoilSystem.from_calibration("cardiomagg")
    with pytest.raises(ValueError, match="does not exist"):
        CoilSystem.from_calibration("missing.yaml")
    with pytest.raises(ValueError, match="SourceSum sources.*needs its currents"):
        SourceSum([navion, Uniform((0, 0.01))])


# ---------------------------------------------------------------------------------------------------- grid


def test_grid_field_is_divergence_free_and_fits_the_source():
    coils = CoilSystem.from_calibration("navion").at_currents([20.0, -10.0, 35.0])
    bounds = [(-0.03, 0.03), (-0.02, 0.02), (-0.03, 0.03)]
    g = GridField.from_source(coils, bounds=bounds, shape=(9, 7, 9), degree=8)
    pts = RNG.uniform([b[0] for b in bounds], [b[1] for b in bounds], size=(50, 3))
    B, G = g.field_and_gradient(pts)
    Bt, Gt = coils.field_and_gradient(pts)
    div, curl = _div_curl(G)
    assert div < RTOL and curl < RTOL
    assert _rel(B, Bt) < 1e-5 and _rel(G, Gt) < 1e-4 and g.fit_relative_error < 1e-5
    assert _rel(g.field_and_gradient(pts * 0.9)[1], _fd_gradient(g, pts * 0.9, 1e-4)) < 1e-7  # its own derivative
    field_only = GridField(g.axes, coils.field(np.stack(np.meshgrid(*g.axes, indexing="ij"), -1).reshape(-1, 3))
                           .reshape(9, 7, 9, 3), degree=8)
    assert _rel(field_only.field(pts), Bt) < 1e-5
    with pytest.raises(ValueError, match=r"points\[0\].*outside the grid's box"):
        g.field(np.array([[0.0, 0.021, 0.0]]))
    with pytest.raises(ValueError, match="cannot determine a potential of degree 12"):
        GridField.from_source(coils, bounds=bounds, shape=(3, 3, 3), degree=12, with_gradient=False)
    with pytest.raises(ValueError, match=r"GridField B must have shape \(2, 2, 2, 3\)"):
        GridField((np.arange(2.0), np.arange(2.0), np.arange(2.0)), np.zeros((2, 2, 3)), degree=2)


# ---------------------------------------------------------------------------------------------- moving, sums


def test_a_moved_source_is_the_unmoved_one_rotated_by_hand():
    magnet = CuboidMagnet(position=(0, 0, 0), dimensions=(0.01, 0.005, 0.02), magnetization=(0, 2e5, 9e5))
    arm = MovingSource(magnet, position=lambda t: (0.1 * t, 0.02, 0.05 - 0.01 * t),
                       orientation=lambda t: rotation_about((1, 2, 3), 0.8 * t))
    x = RNG.normal(size=(10, 3)) * 0.01
    for t in (0.0, 0.3, 1.7):
        p = np.array([0.1 * t, 0.02, 0.05 - 0.01 * t])
        R = rotation_about((1, 2, 3), 0.8 * t)
        B, G = arm.field_and_gradient(x, t=t)
        for i in range(len(x)):
            b, g = magnet.field_and_gradient((R.T @ (x[i] - p)).reshape(1, 3))
            assert _rel(B[i], R @ b[0]) < 1e-12 and _rel(G[i], R @ g[0] @ R.T) < 1e-12
    assert np.allclose(arm.at(0.3).position, [0.03, 0.02, 0.047])
    with pytest.raises(ValueError, match=r"MovingSource orientation at t = 1.0 s must be a rotation matrix"):
        MovingSource(magnet, position=(0, 0, 0), orientation=lambda t: np.diag([1.0, 1.0, -1.0])).at(1.0)


def test_sums_add_fields_and_gradients():
    a = PointDipole(position=(0.1, 0, 0), moment=(0, 0, 1))
    b = CircularLoop(center=(0, 0, 0), normal=(0, 1, 0), radius=0.05, current=1.0)
    c = Uniform((0.001, 0.0, 0.002))
    x = RNG.normal(size=(5, 3)) * 0.01
    total = a + b + c
    assert isinstance(total, SourceSum) and len(total.sources) == 3
    assert sum([a, b, c]).field(x) == pytest.approx(total.field(x), rel=1e-15)
    parts = [s.field_and_gradient(x) for s in (a, b, c)]
    B, G = total.field_and_gradient(x)
    assert _rel(B, sum(p[0] for p in parts)) < 1e-15 and _rel(G, sum(p[1] for p in parts)) < 1e-15
    assert isinstance(total, Source)


# --------------------------------------------------------------------------------------------- input errors


@pytest.mark.parametrize("build, match", [
    (lambda: Uniform((0.0, 2.0)), r"Uniform B Bz must lie in \[-1, 1\] T"),
    (lambda: PointDipole(position=(0, 0), moment=(0, 0, 1)), r"PointDipole position must have shape \(3,\)"),
    (lambda: PointDipole(position=(0, 0, 0), moment=(0, 0, float("nan"))), "PointDipole moment must contain only"),
    (lambda: PointDipole(position=(0, 0, 5000), moment=(0, 0, 1)), "PointDipole position must have a norm of at most"),
    (lambda: SphereMagnet(position=(0, 0, 0), radius=0.01), "exactly one of magnetization"),
    (lambda: SphereMagnet(position=(0, 0, 0), radius=-1, moment=(0, 0, 1)), "SphereMagnet radius must be > 0"),
    (lambda: SphereMagnet(position=(0, 0, 0), radius=0.001, magnetization=(0, 0, 1e8)), "norm of at most 2e\\+06"),
    (lambda: CircularLoop(center=(0, 0, 0), normal=(0, 0, 0), radius=0.1, current=1), "normal must be a non-zero"),
    (lambda: CircularLoop(center=(0, 0, 0), normal=(0, 0, 1), radius=50, current=1), "radius must be at most 10 m"),
    (lambda: CircularLoop(center=(0, 0, 0), normal=(0, 0, 1), radius=0.1, current="1"), "current must be a finite"),
    (lambda: CylinderMagnet(position=(0, 0, 0), radius=0.01, length=0.0, magnetization=1e5), "length must be > 0"),
    (lambda: CylinderMagnet(position=(0, 0, 0), radius=0.01, length=0.01, magnetization=1.2e7), "magnetization must"),
    (lambda: CuboidMagnet(position=(0, 0, 0), dimensions=(0.01, 0.01, 20), magnetization=(0, 0, 1)),
     r"dimensions\[2\] must be at most 1 m"),
    (lambda: CuboidMagnet(position=(0, 0, 0), dimensions=(0.01,) * 3, magnetization=(0, 0, 1), rotation=np.eye(3) * 2),
     "rotation must be a rotation matrix"),
    (lambda: Transformed("magnet", (0, 0, 0)), "Transformed source must be a field source"),
    (lambda: SourceSum([]), "needs at least one source"),
    (lambda: SourceSum(Uniform((0, 0.01))), "got a single Uniform; wrap it in a list"),
    (lambda: MovingSource(Uniform((0, 0.01)), position=(0, 0, 0)).at(float("inf")), "MovingSource t must be a finite"),
    (lambda: Uniform((0, 0.01)).field([0.0, 0.0, 0.0]), r"a single point is \[\[x, y, z\]\]"),
    (lambda: Uniform((0, 0.01)).field([[0.0, 0.0, 1e4]]), r"within 1000 m of the origin .* at points\[0\]"),
    (lambda: DipoleSet(np.zeros((2, 3)), np.zeros((3, 3))), r"moments must have the shape of positions \(2, 3\)"),
])
def test_bad_input_is_refused_naming_the_parameter(build, match):
    with pytest.raises(ValueError, match=match):
        build()


# ---------------------------------------------------------------------------------------------- command line


def test_cli_field_prints_mT_and_json(capsys):
    from magsoft_env.cli import main

    argv = ["field", "--source", "navion", "--currents-A", "10", "0", "-5", "--at-mm", "0", "0", "10"]
    assert main(argv) == 0
    text = capsys.readouterr().out
    assert "B (mT)" in text and "mT/m" in text and "Coil_2" in text and "within the limits" in text
    assert main([*argv, "--at-mm", "5", "0", "0", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    coils = CoilSystem.from_calibration("navion")
    x = np.array([[0, 0, 0.01], [0.005, 0, 0]])
    B, G = coils.field_and_gradient(x, [10, 0, -5])
    first, second = info["points"]
    assert first["at_mm"] == [0.0, 0.0, 10.0] and info["currents_A"] == [10.0, 0.0, -5.0]
    assert np.allclose(first["B_mT"], B[0] * 1e3, rtol=1e-9)
    assert np.allclose(second["G_mT_per_m"], G[1] * 1e3, rtol=1e-9)
    assert np.allclose(first["per_ampere_mT_per_A"], coils.actuation_matrix(x[0])[:3].T * 1e3, rtol=1e-9)
    assert np.allclose(first["max_field_mT"], coils.max_field(x[0]) * 1e3, rtol=1e-9)
    assert info["max_current_A"] == [35.0] * 3


def test_cli_field_reads_a_file_and_lists_the_names(tmp_path, capsys):
    from magsoft_env.cli import main

    path = _write(tmp_path, {**_two_coils(), "Max_Current": 2.0})
    assert main(["field", "--source", str(path), "--currents-A", "1", "-2", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["source"] == "two" and info["max_current_A"] == [2.0, 2.0]
    assert main(["field", "--source", str(path), "--max-current-A", "5", "--currents-A", "4", "4", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["max_current_A"] == [5.0, 5.0]
    assert main(["field", "--list"]) == 0
    listed = capsys.readouterr().out
    assert all(name in listed for name in CALIBRATIONS)


@pytest.mark.parametrize("argv, match", [
    (["--source", "navion", "--currents-A", "1", "2"], "--currents-A needs one current per coil (3"),
    (["--source", "navion", "--currents-A", "1", "2", "40"], "currents[2] (Coil_2) = 40.0 A exceeds its limit"),
    (["--source", "navoin"], "Did you mean 'navion'?"),
    (["--source", "navion", "--at-mm", "0", "0", "1e9"], "--at-mm must be finite coordinates within"),
    (["--source", "navion", "--max-current-A", "-1"], "--max-current-A must be positive"),
    (["--currents-A", "1"], "--source is required"),
])
def test_cli_field_refuses_bad_input(argv, match, capsys):
    from magsoft_env.cli import main

    assert main(["field", *argv]) == 2
    err = capsys.readouterr().err
    assert err.startswith("magsoft field: error:") and match in err and len(err.strip().splitlines()) == 1


def test_the_benchmark_runs(capsys):
    from magsoft_env.bench import fields_bench

    assert fields_bench.main(["--points", "5", "--repeat", "2"]) == 0
    out = capsys.readouterr().out
    for name in ("CardioMag, currents", "Helmholtz pair", "point dipole", "grid fit of CardioMag"):
        assert name in out

"""Field sources in files (magsoft_env.fields.files) and their figures (magsoft_env.render.fields).

Round trips: every type read from a dict, written back and read again gives the same field and gradient to the
bit; a named coil system at currents is the calibration's ``at_currents``; every malformed input is a
ValueError naming the key path; the figure's image holds |B| in mT at its pixel centres.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from magsoft_env.assets import asset_path
from magsoft_env.fields import (
    CoilSystem,
    GridField,
    MovingSource,
    PointDipole,
    Source,
    SourceSum,
    SphereMagnet,
    Transformed,
    load_source,
    rotation_about,
    save_source,
    source_from_dict,
    source_to_dict,
)
from magsoft_env.fields.coils import CALIBRATIONS

RNG = np.random.default_rng(30)
POINTS = RNG.uniform(-0.06, 0.06, size=(200, 3))

SPECS = {
    "uniform": {"type": "uniform", "B_mT": [1.5, -2.0, 13.0]},
    "uniform_pair_rotated": {"type": "uniform", "B_mT": [0.0, 10.0], "rotation": {"axis": [1, 0, 0], "angle_deg": 30}},
    "dipole": {"type": "dipole", "position_mm": [3.7, -80.1, 12.5], "moment_A_m2": [0.1, -0.02, 0.3]},
    "dipole_rotated": {"type": "dipole", "position_mm": [0, 0, 90], "moment_A_m2": [0, 0, 1],
                       "rotation": {"axis": [1, 1, 0], "angle_deg": 37.5}},
    "dipoles_A_m2": {"type": "dipoles", "positions_mm": [[0, 0, 100], [0, 120, 0]],
                     "moments_A_m2": [[0, 0, 1], [0.5, 0, 0]]},
    "dipoles_T_m3": {"type": "dipoles", "positions_mm": [[0, 0, -100]], "moments_T_m3": [[1e-7, 0, 2.5e-7]],
                     "position_mm": [1, 2, 3]},
    "sphere_M": {"type": "sphere", "position_mm": [12, 0, 15], "radius_mm": 3, "magnetization_kA_per_m": [0, 0, 900]},
    "sphere_Br": {"type": "sphere", "position_mm": [0, 10, -5], "radius_mm": 4.5, "remanence_T": [0.3, 0, 1.1]},
    "sphere_m": {"type": "sphere", "radius_mm": 5, "moment_A_m2": [0, 0.2, 0], "position_mm": [-7, 0, 0]},
    "cylinder": {"type": "cylinder", "position_mm": [0, 0, 30], "axis": [1, 1, 0], "radius_mm": 5, "length_mm": 10,
                 "remanence_T": 1.2},
    "cylinder_rotated": {"type": "cylinder", "radius_mm": 2.5, "length_mm": 20, "magnetization_kA_per_m": -800,
                         "rotation": [[0, 0, 1], [0, 1, 0], [-1, 0, 0]], "position_mm": [5, 5, 5]},
    "cuboid": {"type": "cuboid", "position_mm": [10, -3, 2], "dimensions_mm": [4, 6, 8],
               "magnetization_kA_per_m": [0, 500, 700], "rotation": {"axis": [0, 0, 1], "angle_deg": 20}},
    "loop": {"type": "loop", "position_mm": [0, 0, 0], "normal": [0.2, 0.1, 1], "radius_mm": 35, "current_A": 120},
    "coaxial_loops": {"type": "coaxial_loops", "offsets_mm": [-20, 0, 20], "radii_mm": [30, 32, 30],
                      "currents_A": 50, "normal": [0, 1, 0]},
    "helmholtz": {"type": "helmholtz", "radius_mm": 70, "current_A": 500, "normal": [1, 0, 0]},
    "maxwell": {"type": "maxwell", "radius_mm": 70, "current_A": -500, "position_mm": [0, 0, 1]},
    "navion": {"type": "coil_system", "name": "navion", "currents_A": [10, 0, -5]},
    "cardiomag_limits": {"type": "coil_system", "name": "cardiomag", "currents_A": [1, 2, 3, 4, 5, 6, 7, -8],
                         "max_current_A": 25, "normalize_directions": True},
    "navion_placed": {"type": "coil_system", "name": "navion", "currents_A": [0, 20, 0], "position_mm": [0, 0, 5],
                      "rotation": {"axis": [0, 0, 1], "angle_deg": 90}},
    "sum": {"description": "a magnet near the strip in Navion's field",
            "sources": [{"type": "coil_system", "name": "navion", "currents_A": [10, 0, 0]},
                        {"type": "sphere", "position_mm": [12, 0, 15], "radius_mm": 3, "remanence_T": [0, 0, 1.2]},
                        {"sources": [{"type": "uniform", "B_mT": [0, 1]}], "position_mm": [0, 0, 1],
                         "rotation": {"axis": [0, 1, 0], "angle_deg": 45}}]},
}


def _same_field(a, b, points=POINTS):
    Ba, Ga = a.field_and_gradient(points)
    Bb, Gb = b.field_and_gradient(points)
    assert np.array_equal(Ba, Bb) and np.array_equal(Ga, Gb)


@pytest.mark.parametrize("name", list(SPECS))
def test_dict_round_trip_is_exact(name):
    s1 = source_from_dict(SPECS[name])
    d2 = source_to_dict(s1)
    s2 = source_from_dict(json.loads(json.dumps(d2)))  # through plain JSON, as a file would be
    _same_field(s1, s2)
    assert source_to_dict(s2) == d2
    assert np.abs(s1.field(POINTS)).max() > 0


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_file_round_trip_is_exact(tmp_path, suffix):
    s1 = source_from_dict(SPECS["sum"])
    path = save_source(s1, tmp_path / f"source{suffix}")
    s2 = load_source(path)
    _same_field(s1, s2)
    text = path.read_text()
    assert "magsoft_source" in text and "navion" in text


def test_round_trip_of_sources_built_in_python():
    built = [PointDipole(position=(0.01, 0.0, -0.07), moment=(0.0, 0.3, 0.1)),
             SphereMagnet(position=(0.0, 0.012, 0.0), radius=2e-3, moment=(0.01, 0.0, 0.0)),
             Transformed(SphereMagnet(position=(0.0, 0.0, 0.0), radius=3e-3, magnetization=(0, 0, 8e5)),
                         (0.01, 0.02, 0.0), rotation_about((1, 2, 3), 0.4)),
             CoilSystem.from_calibration("octomag").at_currents(np.linspace(-1, 1, 8))]
    for s1 in built:
        d = source_to_dict(s1)
        s2 = source_from_dict(d)
        B1, G1 = s1.field_and_gradient(POINTS)
        B2, G2 = s2.field_and_gradient(POINTS)
        # a Transformed magnet is written as the moved magnet: equal to rounding, then exact from there on
        assert np.abs(B2 - B1).max() <= 1e-13 * np.abs(B1).max()
        assert np.abs(G2 - G1).max() <= 1e-13 * np.abs(G1).max()
        _same_field(s2, source_from_dict(source_to_dict(s2)))


@pytest.mark.parametrize("name", ["navion", "cardiomag", "octomag", "3coils_triangle"])
def test_named_coil_system_equals_the_calibration_at_currents(name):
    system = CoilSystem.from_calibration(name)
    I = RNG.uniform(-1, 1, system.n_coils) * system.max_current * 0.9
    expected = system.at_currents(I)
    _same_field(load_source(name, currents=I), expected)
    _same_field(source_from_dict({"type": "coil_system", "name": name, "currents_A": I.tolist()}), expected)
    B, G = system.field_and_gradient(POINTS, I)
    Bs, Gs = load_source(name, currents=list(I)).field_and_gradient(POINTS)
    assert np.allclose(Bs, B, rtol=0, atol=1e-15 * np.abs(B).max())
    assert np.allclose(Gs, G, rtol=0, atol=1e-15 * np.abs(G).max())


def test_mpem_file_and_relative_paths(tmp_path):
    mpem = asset_path("fields", CALIBRATIONS["navion"].file)
    I = [5.0, -5.0, 2.0]
    expected = CoilSystem.from_calibration("navion").at_currents(I)
    with pytest.raises(ValueError, match=r"Navion_2.*coil_system: .*no Max_Current; pass max_current="):
        load_source(str(mpem), currents=I)  # the MPEM file itself: it states no limits
    (tmp_path / "cal.yaml").write_text(mpem.read_text())
    (tmp_path / "src.yaml").write_text("type: coil_system\nfile: cal.yaml\nmax_current_A: 35\n")
    s = load_source(tmp_path / "src.yaml", currents=I)  # the file's path is relative to the source file
    _same_field(s, expected)
    saved = save_source(s, tmp_path / "again.yml")
    assert "file: cal.yaml" in saved.read_text()
    _same_field(load_source(saved), expected)


def test_grid_round_trip(tmp_path):
    dipole = PointDipole(position=(0.0, 0.0, 0.2), moment=(0.0, 0.0, 5.0))
    axes = [np.linspace(-20, 20, 9)] * 3
    X, Y, Z = np.meshgrid(*axes, indexing="ij")
    pts = np.stack([X, Y, Z], axis=-1).reshape(-1, 3) * 1e-3
    B, G = dipole.field_and_gradient(pts)
    np.savez(tmp_path / "grid.npz", x_mm=axes[0], y_mm=axes[1], z_mm=axes[2], B_mT=B.reshape(9, 9, 9, 3) * 1e3,
             G_mT_per_m=G.reshape(9, 9, 9, 3, 3) * 1e3)
    s1 = source_from_dict({"type": "grid", "file": "grid.npz", "degree": 6}, base_dir=tmp_path)
    assert isinstance(s1, GridField)
    inside = RNG.uniform(-0.019, 0.019, (50, 3))
    assert np.abs(s1.field(inside) - dipole.field(inside)).max() < 1e-4 * np.abs(dipole.field(inside)).max()
    d = source_to_dict(s1, base_dir=tmp_path)
    assert d == {"type": "grid", "file": "grid.npz", "degree": 6}
    _same_field(s1, source_from_dict(d, base_dir=tmp_path), inside)
    np.savez(tmp_path / "bad.npz", x_mm=axes[0], y_mm=axes[1], z_mm=axes[2], B_T=B)
    with pytest.raises(ValueError, match=r"file \(bad.npz\).*'B_T'.*Did you mean 'B_mT'"):
        source_from_dict({"type": "grid", "file": "bad.npz"}, base_dir=tmp_path)


# --------------------------------------------------------------------------------------------- errors

DIPOLE = {"type": "dipole", "moment_A_m2": [0, 0, 1]}
ERRORS = {
    "missing key": ({"type": "dipole"}, ["needs key 'moment_A_m2'"]),
    "missing key in a sum": ({"sources": [DIPOLE, {"type": "sphere", "moment_A_m2": [0, 0, 1]}]},
                             ["sources[1]", "needs key 'radius_mm'"]),
    "missing type": ({"moment_A_m2": [0, 0, 1]}, ["needs key 'type'"]),
    "bad unit": ({"type": "sphere", "radius_m": 0.003, "moment_A_m2": [0, 0, 1]},
                 ["radius_m ", "Did you mean 'radius_mm'?"]),
    "bad unit (field)": ({"type": "uniform", "B_T": [0, 0, 1]}, ["B_T", "Did you mean 'B_mT'?"]),
    "unknown key": ({"type": "dipole", "moment_Am2": [0, 0, 1]}, ["moment_Am2", "Did you mean 'moment_A_m2'?"]),
    "unknown key deep": ({"sources": [DIPOLE, {"sources": [{"type": "loop", "radius_mm": 5, "current_A": 1,
                                                             "curent_A": 2}]}]},
                         ["sources[1].sources[0].curent_A", "Did you mean 'current_A'?"]),
    "wrong shape": ({"sources": [DIPOLE, {"type": "dipole", "moment_A_m2": [0, 1]}]},
                    ["sources[1].moment_A_m2", "shape (3,)", "[0, 1]"]),
    "wrong shape matrix": ({"type": "dipoles", "positions_mm": [[0, 0, 50]], "moments_A_m2": [[0, 0, 1], [1, 0, 0]]},
                           ["moments_A_m2", "shape (1, 3)"]),
    "not a number": ({"type": "loop", "radius_mm": "five", "current_A": 1}, ["radius_mm", "'five'"]),
    "negative radius": ({"type": "sphere", "radius_mm": -3, "remanence_T": [0, 0, 1]}, ["radius_mm", "> 0", "-3"]),
    "zero length": ({"type": "cylinder", "radius_mm": 3, "length_mm": 0, "remanence_T": 1},
                    ["length_mm", "> 0"]),
    "negative side": ({"type": "cuboid", "dimensions_mm": [1, -2, 3], "remanence_T": [0, 0, 1]},
                      ["dimensions_mm", "> 0"]),
    "radius too large": ({"sources": [{"type": "sphere", "radius_mm": 5000, "remanence_T": [0, 0, 1]}]},
                         ["sources[0] (sphere)", "radius"]),
    "two magnetizations": ({"type": "cylinder", "radius_mm": 3, "length_mm": 3, "remanence_T": 1,
                            "magnetization_kA_per_m": 900}, ["exactly one of", "remanence_T"]),
    "zero axis": ({"type": "cylinder", "radius_mm": 3, "length_mm": 3, "remanence_T": 1, "axis": [0, 0, 0]},
                  ["axis", "non-zero"]),
    "unknown type": ({"type": "cylindre", "radius_mm": 3}, ["type", "'cylindre'", "Did you mean 'cylinder'?"]),
    "bad rotation": ({"type": "dipole", "moment_A_m2": [0, 0, 1], "rotation": [[1, 0, 0], [0, 1, 0], [0, 0, 2]]},
                     ["rotation", "rotation matrix", "angle_deg"]),
    "bad axis-angle": ({"type": "dipole", "moment_A_m2": [0, 0, 1], "rotation": {"axis": [0, 0, 1], "angle": 3}},
                       ["rotation.angle", "Did you mean 'angle_deg'?"]),
    "wrong current count": ({"type": "coil_system", "name": "navion", "currents_A": [1, 2]},
                            ["currents_A", "3 (Coil_0, Coil_1, Coil_2)", "got 2 values"]),
    "current over the limit": ({"type": "coil_system", "name": "navion", "currents_A": [1, 2, 40]},
                               ["currents_A", "Coil_2", "35"]),
    "missing currents": ({"sources": [{"type": "coil_system", "name": "cardiomag"}]},
                         ["sources[0]", "currents_A", "8"]),
    "unknown calibration": ({"type": "coil_system", "name": "navoin", "currents_A": [0, 0, 0]},
                            ["name", "Did you mean 'navion'?"]),
    "calibration file missing": ({"type": "coil_system", "file": "nowhere.yaml", "currents_A": [0]},
                                 ["file", "does not exist", "nowhere.yaml"]),
    "grid file missing": ({"type": "grid", "file": "nowhere.npz"}, ["file", "does not exist"]),
    "empty sum": ({"sources": []}, ["sources", "non-empty list"]),
    "wrong version": ({"magsoft_source": 2, **DIPOLE}, ["magsoft_source", "must be 1"]),
}


@pytest.mark.parametrize("case", list(ERRORS))
def test_errors_name_the_key(case):
    d, fragments = ERRORS[case]
    with pytest.raises(ValueError) as info:
        source_from_dict(d)
    msg = str(info.value)
    assert msg.startswith("source dict: ")
    for f in fragments:
        assert f in msg, (f, msg)


def test_file_errors_name_the_file(tmp_path):
    with pytest.raises(ValueError, match=r"source file .*missing\.yaml.* does not exist"):
        load_source(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("type: dipole\nmoment_A_m2: [0, 0, 1\n")
    with pytest.raises(ValueError, match=r"bad\.yaml.*not valid YAML"):
        load_source(bad)
    badj = tmp_path / "bad.json"
    badj.write_text('{"type": "dipole",}')
    with pytest.raises(ValueError, match=r"bad\.json.*not valid JSON"):
        load_source(badj)
    nested = tmp_path / "nested.yaml"
    nested.write_text("sources:\n  - {type: dipole, moment_A_m2: [0, 0, 1]}\n  - {type: dipole, moment_A_m2: [0, 1]}\n")
    with pytest.raises(ValueError, match=r"^source file 'nested\.yaml': sources\[1\]\.moment_A_m2 must have shape"):
        load_source(nested)
    not_mapping = tmp_path / "list.yaml"
    not_mapping.write_text("- 1\n- 2\n")
    with pytest.raises(ValueError, match=r"list\.yaml.*must be a mapping"):
        load_source(not_mapping)


def test_load_source_names_and_currents():
    with pytest.raises(ValueError, match=r"'navion' needs currents= .*3"):
        load_source("navion")
    with pytest.raises(ValueError, match=r"Did you mean 'cardiomag'"):
        load_source("cardiomg", currents=[0] * 8)
    with pytest.raises(ValueError, match=r"currents must hold one current .* 8 \("):
        load_source("cardiomag", currents=[0, 0])
    with pytest.raises(ValueError, match=r"currents_A is given twice"):
        source_from_dict(SPECS["navion"], currents=[0, 0, 0])
    with pytest.raises(ValueError, match=r"currents= applies to a coil_system only"):
        source_from_dict(DIPOLE, currents=[0, 0, 0])
    _same_field(source_from_dict({"type": "coil_system", "name": "navion"}, currents=[1, 2, 3]),
                CoilSystem.from_calibration("navion").at_currents([1, 2, 3]))


def test_what_cannot_be_written():
    navion = CoilSystem.from_calibration("navion")
    with pytest.raises(ValueError, match="needs its currents"):
        source_to_dict(navion)
    arm = MovingSource(PointDipole(position=(0, 0, 0), moment=(0, 0, 1)), position=lambda t: (0.0, 0.0, 0.1 * t))
    with pytest.raises(ValueError, match="a MovingSource depends on time"):
        source_to_dict(arm)
    posed = source_to_dict(arm.at(0.5))  # its pose at a time is a moved dipole
    assert posed["type"] == "dipole" and posed["position_mm"] == [0.0, 0.0, 50.0]
    g = GridField.from_source(navion.at_currents([1, 0, 0]), bounds=[(-0.01, 0.01)] * 3, shape=(5, 5, 5), degree=4)
    with pytest.raises(ValueError, match="keeps its fit, not its samples"):
        source_to_dict(g)

    class Odd(Source):  # a source of no known type
        def field_and_gradient(self, points):
            return np.zeros((len(points), 3)), np.zeros((len(points), 3, 3))

    with pytest.raises(ValueError, match=r"at sources\[1\]: cannot write a Odd"):
        source_to_dict(SourceSum([PointDipole(position=(0, 0, 0), moment=(0, 0, 1)), Odd()]))


# --------------------------------------------------------------------------------------------- figures


def _pixel_check(fig, source, *, plane_axes, offset_mm, n_checks=25):
    """The image's value at pixel (i, j) is |B| (mT) at that pixel's centre, from the image's own extent."""
    ax = fig.axes[0]
    im = ax.images[0]
    arr = np.ma.asarray(im.get_array())
    u0, u1, v0, v1 = im.get_extent()
    n_v, n_u = arr.shape
    iu, iv, iw = plane_axes
    rng = np.random.default_rng(1)
    checked = 0
    for i, j in zip(rng.integers(0, n_v, 4 * n_checks), rng.integers(0, n_u, 4 * n_checks), strict=True):
        if np.ma.is_masked(arr[i, j]):
            continue
        p = np.zeros(3)
        p[iu] = (u0 + (j + 0.5) * (u1 - u0) / n_u) * 1e-3
        p[iv] = (v0 + (i + 0.5) * (v1 - v0) / n_v) * 1e-3
        p[iw] = offset_mm * 1e-3
        expected = np.linalg.norm(source.field(p[None])[0]) * 1e3
        assert abs(float(arr[i, j]) - expected) <= 1e-12 * expected, (i, j, float(arr[i, j]), expected)
        checked += 1
        if checked == n_checks:
            break
    assert checked == n_checks
    return arr


def test_plot_dipole(tmp_path):
    from magsoft_env.render.fields import plot_source

    dipole = PointDipole(position=(0.004, 0.0, 0.012), moment=(0.0, 0.0, 0.02))
    strip = np.column_stack([np.linspace(0, 0.025, 20), np.zeros(20), np.zeros(20)])
    out = tmp_path / "dipole.png"
    fig = plot_source(dipole, extent_mm=(-10, 30, -10, 25), points=80, robot=strip, path=out)
    assert out.stat().st_size > 20_000
    arr = _pixel_check(fig, dipole, plane_axes=(0, 2, 1), offset_mm=0.0)
    assert arr.shape == (70, 80)  # square cells: 40 mm by 35 mm
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x (mm)" and ax.get_ylabel() == "z (mm)"
    assert "mT" in fig.axes[1].get_ylabel()  # the colour bar
    assert ax.images[0].norm.__class__.__name__ == "LogNorm"
    lines = {tuple(np.round(np.asarray(line.get_xydata()).ravel(), 9)) for line in ax.lines}
    assert (4.0, 12.0) in lines  # the dipole, in the plane
    assert tuple(np.round(np.column_stack([strip[:, 0], strip[:, 2]]).ravel() * 1e3, 9)) in lines  # the robot
    assert len(ax.collections) > 0  # streamlines


def test_plot_other_plane_and_a_point_on_the_dipole():
    from magsoft_env.render.fields import plot_source

    dipole = PointDipole(position=(0.003, 0.0, 0.0), moment=(0.01, 0.02, 0.0))
    fig = plot_source(dipole, plane="yz", offset_mm=3.0, extent_mm=10, points=5)  # cell centres -8, -4, 0, 4, 8
    arr = _pixel_check(fig, dipole, plane_axes=(1, 2, 0), offset_mm=3.0, n_checks=10)
    assert np.ma.is_masked(arr[2, 2]) and int(np.ma.count_masked(arr)) == 1  # the point on the dipole


def test_plot_navion_at_currents(tmp_path):
    from magsoft_env.render.fields import plot_source

    navion = load_source("navion", currents=[10.0, 0.0, 0.0])
    out = tmp_path / "navion.png"
    fig = plot_source(navion, extent_mm=60, offset_mm=5.0, points=60, path=out)
    assert out.stat().st_size > 20_000
    _pixel_check(fig, navion, plane_axes=(0, 2, 1), offset_mm=5.0)
    # 1 mm cells centred on integers: pixel (30, 30) is the workspace centre, where coil 0 gives
    # (0.000, -0.291, -0.414) mT/A (DESIGN section 12), |B| = 5.060 mT at 10 A
    arr = plot_source(navion, extent_mm=30.5, points=61).axes[0].images[0].get_array()
    assert abs(float(arr[30, 30]) - 10 * np.hypot(0.291, 0.414)) < 0.01


def test_plot_into_given_axes_and_from_a_dict():
    from matplotlib.figure import Figure

    from magsoft_env.render.fields import plot_source

    fig = Figure()
    ax = fig.subplots()
    out = plot_source(SPECS["helmholtz"], ax=ax, plane="xy", points=30, extent_mm=50)
    assert out is fig and ax.images
    with pytest.raises(ValueError, match="plane must be one of"):
        plot_source(SPECS["helmholtz"], plane="xq")
    with pytest.raises(ValueError, match="robot must be a centreline"):
        plot_source(SPECS["helmholtz"], robot=np.zeros((3, 2)), points=8)


def test_the_documented_example_file(tmp_path):
    """docs/fields.md's example YAML reads, and is the sphere plus Navion at 10 A on coil 0."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "fields.md").read_text()
    block = text.split("## Sources in files", 1)[1].split("```yaml\n", 1)[1].split("```", 1)[0]
    (tmp_path / "magnet_near_strip.yaml").write_text(block)
    s = load_source(tmp_path / "magnet_near_strip.yaml")
    expected = (SphereMagnet(position=(0.0125, 0.0, 0.015), radius=0.003, magnetization=(0.0, 0.0, 1.2 / 4e-7 / np.pi))
                + CoilSystem.from_calibration("navion").at_currents([10.0, 0.0, 0.0]))
    B, G = s.field_and_gradient(POINTS)
    Be, Ge = expected.field_and_gradient(POINTS)
    assert np.allclose(B, Be, rtol=0, atol=1e-14 * np.abs(Be).max())
    assert np.allclose(G, Ge, rtol=0, atol=1e-14 * np.abs(Ge).max())

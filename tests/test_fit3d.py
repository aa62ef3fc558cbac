"""``ms.fit`` on the 3D rod: fields with B_y and tracked y coordinates identify the width and the Poisson ratio
(through the twist, G J) besides E0 and the magnetization; ``model="auto"`` keeps planar data planar, bit for bit.

Synthetic round trips from the 3D solver itself, and the fit's Jacobian against central differences of its own
residual (:func:`magsoft_env.theory.fit.misfit`).
"""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.theory.fit import misfit

BEAM = ms.Beam(25e-3, 5e-3, 1.13e-3)
MAT = BEAM.material
TRUTH = dataclasses.replace(BEAM, width=5.4e-3, material=dataclasses.replace(
    MAT, E0=0.075e6, particle_magnetization=520e3, poisson_ratio=0.4))
#: gravity alone, then fields with B_y: the strip bends sideways (E I_s ~ w^3) and twists (G J)
FIELDS = [(0.0, 0.0, 0.0), (2e-3, 2e-3, 1e-3), (-1e-3, 3e-3, 2e-3), (1e-3, -2e-3, -2e-3), (-2e-3, -1e-3, 3e-3)]
ALL4 = ("E0", "particle_magnetization", "width", "poisson_ratio")


def _tips(truth=TRUTH, fields=FIELDS, noise=0.0, seed=0):
    rng = np.random.default_rng(seed)
    return [(B, ms.solve_equilibrium(truth, B, model="3d").tip_position + rng.normal(scale=noise, size=3))
            for B in fields]


def test_3d_round_trip_recovers_the_modulus_magnetization_width_and_poisson_ratio():
    data = _tips()
    res = ms.fit(BEAM, data, params=ALL4, restarts=0)  # model="auto": the fields have B_y
    assert res.success, res.message
    assert res.model == "3d" and res.to_dict()["model"] == "3d"
    assert res.residual.shape == (3 * len(FIELDS),)  # x, y, z of each tip
    truth = {"E0": 0.075e6, "particle_magnetization": 520e3, "width": 5.4e-3, "poisson_ratio": 0.4}
    for p, v in truth.items():
        assert res.values[p] == pytest.approx(v, rel=1e-6), p
    assert res.beam.width == pytest.approx(5.4e-3, rel=1e-6)
    assert res.beam.material.poisson_ratio == pytest.approx(0.4, rel=1e-6)
    assert res.rms < 1e-9


def test_3d_round_trip_with_noise_gives_calibrated_uncertainties():
    res = ms.fit(BEAM, _tips(noise=0.02e-3, seed=1), params=ALL4, restarts=0)
    assert res.success, res.message
    truth = {"E0": 0.075e6, "particle_magnetization": 520e3, "width": 5.4e-3, "poisson_ratio": 0.4}
    for p, v in truth.items():
        assert abs(res.values[p] - v) < 4 * res.sigma[p], (p, res.values[p], res.sigma[p])
        assert res.sigma[p] < 0.05 * v  # identified, to a few per cent at 0.02 mm noise
    # the twist separates the width and the Poisson ratio from the rest: no pair is near-degenerate
    off = res.correlation[~np.eye(4, dtype=bool)]
    assert np.all(np.abs(off) < 0.9), res.correlation
    assert 0.01e-3 < res.residual_sigma < 0.04e-3


def test_fit_jacobian_equals_central_differences_of_its_residual():
    """The Jacobian the fit uses (exact rod sensitivities) against central differences of the fit's own residual,
    in a uniform field and under a dipole beside the strip (its offset along y, source_y, included)."""
    from magsoft_env.fields import PointDipole, Transformed

    s = np.array([0.5, 1.0]) * BEAM.length
    data = [(B, s, np.zeros((2, 3))) for B in FIELDS[1:3]]
    params = ("E0", "particle_magnetization", "width", "poisson_ratio", "thickness", "clamp_angle")
    r0, J = misfit(BEAM, data, params, gravity=9.81, clamp_angle=0.1, model="3d")
    assert J.shape == (2 * 2 * 3, len(params))

    def moved(p, v):
        if p in ("width", "thickness"):
            return dataclasses.replace(BEAM, **{p: v}), 0.1
        if p == "clamp_angle":
            return BEAM, v
        return dataclasses.replace(BEAM, material=dataclasses.replace(MAT, **{p: v})), 0.1

    values = {"E0": MAT.E0, "particle_magnetization": MAT.particle_magnetization, "width": BEAM.width,
              "poisson_ratio": MAT.poisson_ratio, "thickness": BEAM.thickness, "clamp_angle": 0.1}
    for k, p in enumerate(params):
        h = 1e-5 * abs(values[p])
        f = []
        for v in (values[p] + h, values[p] - h):
            b, th0 = moved(p, v)
            f.append(misfit(b, data, params, gravity=9.81, clamp_angle=th0, model="3d")[0])
        fd = (f[0] - f[1]) / (2 * h)
        assert np.abs(J[:, k] - fd).max() <= 1e-7 * np.abs(fd).max(), p  # measured 5e-11 to 2.3e-10

    src = PointDipole(position=(25e-3, 10e-3, -20e-3), moment=(0, 0, 3e-3))  # beside the strip, off its plane
    sdata = [(src, s, np.zeros((2, 3)))]
    _, Js = misfit(BEAM, sdata, ("E0", "source_y"), model="3d")
    h = 1e-5 * BEAM.length
    f = [misfit(BEAM, [(Transformed(src, position=(0, d, 0)), s, np.zeros((2, 3)))], ("E0",), model="3d")[0]
         for d in (h, -h)]
    fd = (f[0] - f[1]) / (2 * h)
    assert np.abs(Js[:, 1] - fd).max() <= 1e-6 * np.abs(fd).max()  # measured 5e-9


def test_a_magnets_offset_in_three_dimensions_with_the_modulus():
    """A magnet beside and above or below the strip at commanded poses all off by one unknown offset, y included:
    the 3D fit finds the offset (source_x, source_y, source_z) and E0 (auto: the sources load the strip out of its
    plane)."""
    from magsoft_env.fields import PointDipole, Transformed

    truth = dataclasses.replace(BEAM, material=dataclasses.replace(MAT, E0=0.07e6))
    off = np.array([0.8e-3, 0.5e-3, -0.5e-3])
    data = [((0, 0, 0), ms.solve_equilibrium(truth, (0, 0, 0), model="3d").tip_position)]
    for x in (15e-3, 30e-3):
        for y in (-10e-3, 10e-3):
            for z in (-25e-3, 15e-3):
                src = PointDipole(position=(x, y, z), moment=(0, 0, 3e-3))
                tip = ms.solve_equilibrium(truth, Transformed(src, position=off), model="3d").tip_position
                data.append((src, tip))
    res = ms.fit(BEAM, data, params=("E0", "source_x", "source_y", "source_z"), restarts=0)
    assert res.success and res.model == "3d", res.message
    assert res.values["E0"] == pytest.approx(0.07e6, rel=1e-6)
    for k, p in enumerate(("source_x", "source_y", "source_z")):
        assert abs(res.values[p] - off[k]) < 1e-8, p


def test_auto_takes_3d_for_B_y_or_y_data_and_keeps_planar_data_planar():
    # planar data: the planar model, the same numbers as model="planar" (today's fit, bit for bit)
    planar = [(B[::2], ms.solve_equilibrium(TRUTH, B[::2]).tip_position) for B in FIELDS]
    auto = ms.fit(BEAM, planar, params=("E0", "particle_magnetization"), restarts=0)
    forced = ms.fit(BEAM, planar, params=("E0", "particle_magnetization"), restarts=0, model="planar")
    assert auto.model == forced.model == "planar"
    assert auto.values == forced.values and auto.sigma == forced.sigma
    assert np.array_equal(auto.residual, forced.residual) and auto.residual.shape == (2 * len(FIELDS),)
    # a y coordinate off the plane takes the 3D rod, even under in-plane fields
    moved = [(B, tip + np.array([0.0, 1e-5, 0.0])) for B, tip in planar]
    res = ms.fit(BEAM, moved, params=("E0",), restarts=0)
    assert res.model == "3d" and res.residual.shape == (3 * len(FIELDS),)
    # and the 3D rod on planar data agrees with the planar fit (the same equilibria, to the solvers' tolerance)
    both = ms.fit(BEAM, planar, params=("E0", "particle_magnetization"), restarts=0, model="3d")
    assert both.model == "3d"
    for p in ("E0", "particle_magnetization"):
        assert both.values[p] == pytest.approx(auto.values[p], rel=1e-5)


def test_3d_parameters_and_out_of_plane_fields_are_refused_in_the_planar_model():
    planar = [(B[::2], ms.solve_equilibrium(BEAM, B[::2]).tip_position) for B in FIELDS]
    with pytest.raises(ValueError, match="width need.* the 3D model.*planar model does not depend"):
        ms.fit(BEAM, planar, params=("E0", "width"))
    with pytest.raises(ValueError, match="poisson_ratio need.* the 3D model"):
        ms.fit(BEAM, planar, params=("poisson_ratio",), model="planar")
    with pytest.raises(ValueError, match="width need.* the 3D model"):
        ms.fit(BEAM, _tips(BEAM)[:2], params=("width",), model="planar")
    # the 3D rod asked for, but planar data: the width does not act on them
    with pytest.raises(ValueError, match="width is not identifiable"):
        ms.fit(BEAM, planar, params=("E0", "width"), model="3d")
    with pytest.raises(ValueError, match=r"measurements\[1\] field has B_y = 0.002 T.*model='3d'"):
        ms.fit(BEAM, _tips(BEAM)[:2], params=("E0",), model="planar")
    # the planar source sensitivities have no volume fraction; the 3D ones do
    from magsoft_env.fields import PointDipole

    src = PointDipole(position=(25e-3, 0, -20e-3), moment=(0, 0, 3e-3))
    with pytest.raises(ValueError, match="volume_fraction under a field source needs the 3D model"):
        ms.fit(BEAM, [(src, (20e-3, -5e-3))], params=("volume_fraction",))
    with pytest.raises(ValueError, match="model must be one of"):
        ms.fit(BEAM, planar, params=("E0",), model="3D")
    with pytest.raises(ValueError, match=r"measurements\[0\] positions must be 1 finite"):
        ms.fit(BEAM, [((0, 1e-3, 1e-3), (1e-3, 2e-3, 3e-3, 4e-3))])


def test_a_3d_csv_through_the_cli(tmp_path, capsys):
    from magsoft_env.cli import main
    from magsoft_env.cli.fit import read_measurements

    beam = ms.load_robot("paper-5b").beam  # a jig-magnetized strip (three pieces)
    truth = dataclasses.replace(beam, width=5.4e-3, material=dataclasses.replace(beam.material, E0=0.068e6))
    rows = ["Bx_mT,By_mT,Bz_mT,tip_x_mm,tip_y_mm,tip_z_mm"]
    for B, tip in _tips(truth, FIELDS[:4]):
        rows.append(",".join(f"{v * 1e3:.9f}" for v in (*B, *tip)))
    path = tmp_path / "tips3d.csv"
    path.write_text("\n".join(rows) + "\n")
    data = read_measurements(path)
    assert len(data[1][0]) == 3 and data[1][1].shape == (3,)  # (B_x, B_y, B_z) and (x, y, z)
    fig = tmp_path / "fit3d.png"
    rc = main(["fit", str(path), "--robot", "paper-5b", "--params", "E0,width", "--restarts", "0", "--plot", str(fig),
               "--json"])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert info["model"] == "3d" and fig.stat().st_size > 10_000
    assert info["values"]["E0"] == pytest.approx(0.068e6, rel=1e-6)
    assert info["values"]["width"] == pytest.approx(5.4e-3, rel=1e-6)
    # the planar model refuses the B_y column's fields, with the reason (exit status 2)
    assert main(["fit", str(path), "--robot", "paper-5b", "--params", "E0", "--model", "planar"]) == 2
    assert "B_y" in capsys.readouterr().err


def test_a_magnets_turn_in_three_dimensions():
    """Dipoles whose moments are all turned by one unknown rotation (a magnet mounted askew): the 3D fit finds the
    rotation vector (source_roll, source_pitch, source_yaw) and E0. The truth turns the moments with scipy's
    Rotation, independently of the fit's own posed_source."""
    from scipy.spatial.transform import Rotation

    from magsoft_env.fields import PointDipole

    truth = dataclasses.replace(BEAM, material=dataclasses.replace(MAT, E0=0.07e6))
    w = np.array([0.06, -0.08, 0.05])
    data = [((0, 0, 0), ms.solve_equilibrium(truth, (0, 0, 0), model="3d").tip_position)]
    for pos, m in (((20e-3, 8e-3, -20e-3), (0, 0, 3e-3)), ((30e-3, -8e-3, 15e-3), (2e-3, 0, 2e-3)),
                   ((10e-3, 12e-3, 18e-3), (0, 2e-3, -2e-3)), ((28e-3, 10e-3, -18e-3), (-2e-3, 1e-3, 2e-3))):
        tip = ms.solve_equilibrium(truth, PointDipole(position=pos, moment=tuple(Rotation.from_rotvec(w).apply(m))),
                                   model="3d").tip_position
        data.append((PointDipole(position=pos, moment=m), tip))
    res = ms.fit(BEAM, data, params=("E0", "source_roll", "source_pitch", "source_yaw"), restarts=0)
    assert res.success and res.model == "3d", res.message
    assert res.values["E0"] == pytest.approx(0.07e6, rel=1e-6)
    for k, p in enumerate(("source_roll", "source_pitch", "source_yaw")):
        assert abs(res.values[p] - w[k]) < 1e-7, p


def test_the_turns_jacobian_equals_differences_of_the_misfit_away_from_zero():
    """At a nonzero rotation vector the fit's column of a turn is the world turns mapped by SO(3)'s left Jacobian;
    checked against central differences of the misfit itself (offset and turn both nonzero)."""
    from magsoft_env.fields import PointDipole
    from magsoft_env.theory.fit import _misfit, as_measurements
    from magsoft_env.theory.options import SolverOptions

    src = PointDipole(position=(25e-3, 8e-3, -18e-3), moment=(1e-3, -1e-3, 3e-3))
    data = as_measurements([(src, np.array([20e-3, 1e-3, -8e-3]))], BEAM.length, model="3d")
    params = ("source_x", "source_roll", "source_pitch", "source_yaw")
    vals = {"source_x": 0.5e-3, "source_roll": 0.2, "source_pitch": -0.3, "source_yaw": 0.25}
    kw = {"gravity": 9.81, "clamp_angle": 0.0, "coupling": "rotated", "options": SolverOptions(), "model": "3d"}
    _, J, failed = _misfit(BEAM, data, params, vals, **kw)
    assert not failed
    for j, p in enumerate(params):
        h = 1e-6 if p != "source_x" else 1e-8
        rp = _misfit(BEAM, data, params, {**vals, p: vals[p] + h}, **kw)[0]
        rm = _misfit(BEAM, data, params, {**vals, p: vals[p] - h}, **kw)[0]
        fd = (rp - rm) / (2 * h)
        assert np.abs(J[:, j] - fd).max() <= 1e-6 * np.abs(fd).max(), p

"""``magsoft fit``: a CSV of tracked tips to a fitted robot file, a figure and the uncertainties."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.cli import main
from magsoft_env.cli.fit import read_measurements

FIELDS = [(0, 0), (0, 2e-3), (0, -2e-3), (2e-3, 1e-3), (-1.5e-3, 2.5e-3), (1e-3, -3e-3)]


def _csv(path, beam, noise=0.0):
    rng = np.random.default_rng(3)
    rows = ["Bx_mT,Bz_mT,tip_x_mm,tip_y_mm,tip_z_mm"]
    for B in FIELDS:
        tip = ms.solve_equilibrium(beam, B).tip_position + rng.normal(scale=noise, size=3)
        rows.append(f"{B[0] * 1e3:g},{B[1] * 1e3:g},{tip[0] * 1e3:.6f},0,{tip[2] * 1e3:.6f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_fit_from_a_csv_writes_the_fitted_robot_and_a_figure(tmp_path, capsys):
    robot = ms.load_robot("paper-5b")
    truth = dataclasses.replace(robot.beam, material=dataclasses.replace(robot.beam.material, E0=0.07e6))
    data = _csv(tmp_path / "tips.csv", truth, noise=0.02e-3)
    out, fig = tmp_path / "fitted.yml", tmp_path / "fit.png"
    rc = main(["fit", str(data), "--robot", "paper-5b", "--params", "E0", "--out", str(out), "--plot", str(fig),
               "--json"])
    assert rc == 0
    info = json.loads(capsys.readouterr().out)
    assert abs(info["values"]["E0"] / 0.07e6 - 1) < 0.01
    fitted = ms.load_robot(out)
    assert fitted.beam.material.E0 == pytest.approx(info["values"]["E0"], rel=1e-12)
    assert fig.stat().st_size > 10_000
    # the same numbers as the Python call on the same data
    res = ms.fit(robot.beam, read_measurements(data), params=("E0",))
    assert res.values["E0"] == pytest.approx(info["values"]["E0"], rel=1e-9)


@pytest.mark.parametrize("text, match", [
    ("Bx_mT,Bz_mT,tip_x_mm\n0,1,2\n", "missing column tip_z"),
    ("Bx_mT,Bz_mT,tip_x_in,tip_z_mm\n0,1,2,3\n", "column 'tip_x_in' is not known"),
    ("Bx_mT,Bz_mT,tip_x_mm,tip_z_mm\n0,1,two,3\n", "row 2, column 'tip_x_mm': expected a number"),
    ("Bx_mT,Bz_mT,tip_x_mm,tip_z_mm\n", "at least one data row"),
    ("Bx_mT,Bz_mT,tip_x_mm,tip_z_mm,s_mm\n0,1,2,3,4\n", "either tip_x_mm"),
])
def test_malformed_csvs_get_clear_errors(tmp_path, capsys, text, match):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    assert main(["fit", str(p)]) == 2
    assert match in capsys.readouterr().err


def test_unknown_and_unidentifiable_parameters_are_refused(tmp_path, capsys):
    data = _csv(tmp_path / "tips.csv", ms.load_robot("paper-5b").beam)
    assert main(["fit", str(data), "--robot", "paper-5b", "--params", "E0,magnetization"]) == 2
    assert "Did you mean 'particle_magnetization'" in capsys.readouterr().err
    assert main(["fit", str(data), "--robot", "paper-5b", "--params", "E0,particle_magnetization",
                 "--gravity", "0"]) == 2
    assert "not identifiable" in capsys.readouterr().err

"""``magsoft design`` end to end with tiny budgets, and its input errors."""

import csv
import json

import numpy as np
import pytest

from magsoft_env.cli import main


def _rows(path):
    with open(path, encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


def test_design_builtin_target_writes_all_outputs(tmp_path, capsys):
    out = tmp_path / "ball"
    rc = main(["design", "--target", "ball", "--out", str(out), "--starts", "1", "--max-nfev", "4", "--points", "20",
               "--quiet", "--size", "5"])
    assert rc in (0, 1)  # 1: a tiny budget may miss the tolerance, which must be reported, not hidden
    text = capsys.readouterr().out
    assert "fit error: RMS" in text and "% of L" in text
    for name in ("profile.csv", "field.csv", "jig.csv", "jig.svg", "target.csv", "prediction.csv", "ramp.csv",
                 "summary.json", "fit.png", "ramp.png"):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["success"] == (rc == 0)
    # the summary's error is recomputed from the written curves
    target = np.array([[float(r["x_mm"]), float(r["z_mm"])] for r in _rows(out / "target.csv")])
    pred = np.array([[float(r["x_mm"]), float(r["z_mm"])] for r in _rows(out / "prediction.csv")])
    from magsoft_env.design import point_to_polyline

    d = point_to_polyline(target, pred)
    assert summary["rms_error_mm"] == pytest.approx(np.sqrt(np.mean(d**2)), rel=1e-6)
    field = _rows(out / "field.csv")[0]
    assert float(field["Bx_mT"]) == 0.0 and 1.0 <= float(field["Bz_mT"]) <= 20.0
    assert summary["length_mm"] == pytest.approx(10 * np.radians(135), rel=2e-3)
    svg = (out / "jig.svg").read_text()
    assert svg.startswith("<?xml") and "<polyline" in svg and 'mm"' in svg


def test_design_target_csv(tmp_path):
    t = np.linspace(0, 1.8, 30)
    csv_path = tmp_path / "arc.csv"
    csv_path.write_text("x_mm,z_mm\n" + "\n".join(f"{12 * np.sin(a)},{12 * (1 - np.cos(a))}" for a in t) + "\n")
    rc = main(["design", "--target-csv", str(csv_path), "--out", str(tmp_path / "o"), "--starts", "1",
               "--max-nfev", "3", "--points", "15", "--quiet", "--no-figures"])
    assert rc in (0, 1)
    assert (tmp_path / "o" / "jig.svg").is_file() and not (tmp_path / "o" / "fit.png").exists()


@pytest.mark.parametrize(
    ("argv", "fragment"),
    [
        (["--target", "bal"], "Did you mean 'ball'"),
        (["--target", "ball", "--field-min-mT", "30"], "field_bounds"),
        (["--target", "ball", "--thickness-mm", "0"], "--thickness-mm"),
    ],
)
def test_design_bad_input_exits_2(tmp_path, capsys, argv, fragment):
    rc = main(["design", *argv, "--out", str(tmp_path / "x"), "--quiet"])
    assert rc == 2
    assert fragment in capsys.readouterr().err


def test_design_bad_csv_exits_2(tmp_path, capsys):
    p = tmp_path / "few.csv"
    p.write_text("x_mm,z_mm\n0,0\n1,0\n")
    assert main(["design", "--target-csv", str(p), "--out", str(tmp_path / "x"), "--quiet"]) == 2
    assert "at least 4 distinct points" in capsys.readouterr().err


def test_design_bad_letters_exit_2(tmp_path, capsys):
    assert main(["design", "--letters", "SX", "--out", str(tmp_path / "x"), "--quiet"]) == 2
    assert "--letters must use only SJTU" in capsys.readouterr().err


@pytest.mark.slow
def test_design_letter_j(tmp_path, capsys):
    out = tmp_path / "letters"
    assert main(["design", "--letters", "J", "--out", str(out), "--quiet"]) == 0
    assert (out / "letters.png").is_file() and (out / "J" / "jig.svg").is_file()
    assert "J: L 26.57 mm" in capsys.readouterr().out


def test_designed_robot_keeps_its_field_and_solve_ramps_to_it(tmp_path, capsys):
    from magsoft_env.cases.robots import load_robot
    from magsoft_env.units import MT

    out = tmp_path / "ball"
    rc = main(["design", "--target", "ball", "--out", str(out), "--starts", "1", "--max-nfev", "4", "--points", "20",
               "--quiet", "--size", "5", "--no-figures"])
    assert rc in (0, 1)
    summary = json.loads((out / "summary.json").read_text())
    robot = load_robot(out / "robot.yml")
    assert robot.design_field is not None
    assert robot.design_field.Bx == 0.0
    assert robot.design_field.Bz / MT == pytest.approx(summary["field_Bz_mT"], rel=1e-15)
    # exact round trip: saved again, the file reads back the same field to the bit
    again = load_robot(robot.save(tmp_path / "again.json"))
    assert again.design_field == robot.design_field and again == robot
    capsys.readouterr()
    assert main(["solve", "--robot", str(out / "robot.yml"), "--out", str(tmp_path / "s"), "--no-plot"]) == 0
    solved = json.loads((tmp_path / "s" / "solve_design-ball.json").read_text())
    assert solved["config"]["field_mT"] == pytest.approx([0.0, robot.design_field.Bz / MT], rel=1e-12)  # not 13 mT
    pred = _rows(out / "prediction.csv")[-1]
    shape = solved["final"]["shape"]
    assert shape["x_m"][-1] * 1e3 == pytest.approx(float(pred["x_mm"]), abs=1e-6)
    assert shape["z_m"][-1] * 1e3 == pytest.approx(float(pred["z_mm"]), abs=1e-6)
    # an explicit field still wins
    assert main(["solve", "--robot", str(out / "robot.yml"), "--field-mT", "0", "5", "--out", str(tmp_path / "t"),
                 "--no-plot"]) == 0
    assert json.loads((tmp_path / "t" / "solve_design-ball.json").read_text())["config"]["field_mT"] == [0.0, 5.0]


def test_robot_design_field_is_checked():
    import magsoft_env as ms
    from magsoft_env.cases.robots import Robot

    beam = ms.Beam(25e-3, 5e-3, 1.13e-3)
    assert Robot("x", beam, design_field=(0.0, 0.02)).design_field == ms.Field(0.0, 0.02)
    with pytest.raises(ValueError, match=r"Robot.design_field must be a pair \(B_x, B_z\) in tesla \(or a triple"):
        Robot("x", beam, design_field="20 mT")
    with pytest.raises(ValueError, match=r"design_field_mT must be a pair \[B_x, B_z\] in mT, got 3 components.*3D"):
        Robot.from_dict({"name": "x", "beam": {"length_mm": 25, "width_mm": 5, "thickness_mm": 1.13},
                         "design_field_mT": [0, 20, 1]})

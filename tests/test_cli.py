"""The real ``magsoft`` command line, end to end on tiny settings, and its input errors."""

from __future__ import annotations

import csv
import json
import math
import re

import pytest

from magsoft_env.cli import main

METRICS = ("v_over_L", "tip_angle_deg", "rotation_angle_deg", "stable", "success", "P", "Bx_mT", "Bz_mT")


def _read_csv(path):
    with open(path, newline="") as fh:
        return list(csv.DictReader(fh))


# ----------------------------------------------------------------------------------- solve


def test_solve_preset_writes_metrics_json_and_png(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["solve", "--preset", "fig3a_L20", "--steps", "3", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "v/L" in text and "tip deg" in text and "rot deg" in text and "stable" in text and "success" in text
    data = json.loads((out / "solve_fig3a_L20.json").read_text())
    assert (out / "solve_fig3a_L20.png").stat().st_size > 0
    rows = data["results"]
    assert len(rows) == 3
    for r in rows:
        assert set(METRICS) <= set(r)
        assert r["success"] is True
        # metrics agree with the shape they summarise
        assert r["v_over_L"] == pytest.approx(r["tip_z_mm"] / 20.0, rel=1e-12)
        assert math.radians(r["rotation_angle_deg"]) % (2 * math.pi) == pytest.approx(
            math.atan2(r["tip_z_mm"], r["tip_x_mm"]) % (2 * math.pi), abs=1e-9)
    assert [r["Bz_mT"] for r in rows] == pytest.approx([0.0, 6.5, 13.0])
    assert rows[-1]["v_over_L"] > rows[0]["v_over_L"]  # B_z up lifts the drooping beam
    shape = data["final"]["shape"]
    assert shape["x_m"][-1] == pytest.approx(rows[-1]["tip_x_mm"] * 1e-3, abs=1e-9)
    assert data["solver_options"]["gravity"] == pytest.approx(9.81)
    assert data["config"]["beam"]["length_mm"] == 20.0


def test_solve_parameters_without_gravity(tmp_path):
    out = tmp_path / "p"
    rc = main(["solve", "--length-mm", "20", "--width-mm", "5", "--thickness-mm", "1.13", "--phi", "0.2",
               "--field-mT", "0", "5", "--steps", "2", "--gravity", "0", "--coupling", "paper", "--out", str(out),
               "--no-plot"])
    assert rc == 0
    data = json.loads((out / "solve_custom.json").read_text())
    assert not (out / "solve_custom.png").exists()
    assert data["solver_options"]["gravity"] == 0.0 and data["solver_options"]["coupling"] == "paper"
    first, last = data["results"]
    assert first["v_over_L"] == pytest.approx(0.0, abs=1e-12)  # no field, no gravity: straight
    assert 0.0 < last["v_over_L"] < 1.0 and 0.0 < last["tip_angle_deg"] < 90.0
    assert data["length_m"] == pytest.approx(20e-3)


def test_solve_free_free_cells(tmp_path):
    out = tmp_path / "f"
    assert main(["solve", "--preset", "fig4a_4cells_up", "--steps", "3", "--out", str(out), "--no-plot"]) == 0
    rows = json.loads((out / "solve_fig4a_4cells_up.json").read_text())["results"]
    assert all(r["success"] for r in rows)
    assert rows[-1]["Bz_mT"] == pytest.approx(14.42)


def test_solve_list(capsys):
    assert main(["solve", "--list"]) == 0
    out = capsys.readouterr().out
    assert "fig3a_L25" in out and "fig4d_piecewise" in out


# ----------------------------------------------------------------------------------- sweep, couplings, demo


def test_sweep_writes_curves_with_and_without_gravity(tmp_path):
    out = tmp_path / "s"
    rc = main(["sweep", "--lengths-mm", "20", "--paths", "a", "b", "--steps", "3", "--quiet", "--out", str(out)])
    assert rc == 0
    rows = _read_csv(out / "sweep.csv")
    assert (out / "sweep.png").stat().st_size > 0
    assert len(rows) == 2 * 2 * 3  # paths x gravity on/off x states
    assert {r["gravity_m_per_s2"] for r in rows} == {"9.81", "0"}
    assert {r["path"] for r in rows} == {"a", "b"}
    assert set(METRICS) <= set(rows[0])
    a0 = [r for r in rows if r["path"] == "a" and r["gravity_m_per_s2"] == "0"]
    assert float(a0[0]["P"]) == 0.0 and float(a0[0]["v_over_L"]) == pytest.approx(0.0, abs=1e-12)
    b = [r for r in rows if r["path"] == "b"]
    assert all(float(r["Bz_mT"]) == pytest.approx(13.0) for r in b)
    # P of path b is that of |B_x|; of path a that of B_z
    assert float(b[-1]["P"]) == pytest.approx(float(a0[-1]["P"]) * 22.0 / 13.0, rel=1e-9)
    config = json.loads((out / "sweep_config.json").read_text())
    assert len(config["cases"]) == 4


def test_couplings_table_and_figure(tmp_path, capsys):
    out = tmp_path / "c"
    rc = main(["couplings", "--presets", "fig4b_quadratic", "--steps", "4", "--levels", "1", "--gravity", "0",
               "--out", str(out)])
    assert rc == 0
    assert "|dtip| mm" in capsys.readouterr().out
    rows = _read_csv(out / "couplings.csv")
    assert (out / "couplings.png").stat().st_size > 0
    assert len(rows) == 1
    r = rows[0]
    d = math.hypot(float(r["tip_x_rotated_mm"]) - float(r["tip_x_paper_mm"]),
                   float(r["tip_z_rotated_mm"]) - float(r["tip_z_paper_mm"]))
    assert float(r["tip_distance_mm"]) == pytest.approx(d, rel=1e-9)
    assert d > 0.1  # beta varies along a jig beam, so the couplings disagree


def test_couplings_agree_on_a_uniform_beam(tmp_path):
    """beta = 0 everywhere: eq. 10 and the rotated coupling are the same model."""
    out = tmp_path / "u"
    rc = main(["couplings", "--presets", "fig3a_L20", "--steps", "3", "--levels", "1", "--out", str(out),
               "--no-plot"])
    assert rc == 0
    r = _read_csv(out / "couplings.csv")[0]
    assert float(r["tip_distance_mm"]) < 1e-6


def test_demo_runs_on_defaults(tmp_path, capsys):
    out = tmp_path / "d"
    assert main(["demo", "--out", str(out)]) == 0
    assert "fig3a_L25" in capsys.readouterr().out
    data = json.loads((out / "demo.json").read_text())
    assert (out / "demo.png").stat().st_size > 0
    names = [c["preset"] for c in data["cases"]]
    assert names == ["fig3a_L25", "fig4b_quadratic"]
    for c in data["cases"]:
        assert all(set(METRICS) <= set(r) for r in c["results"])


# ----------------------------------------------------------------------------------- bad input


@pytest.mark.parametrize(
    ("argv", "match"),
    [
        (["solve", "--preset", "fig3a_L26"], "Did you mean 'fig3a_L25'"),
        (["solve", "--length-mm", "-25"], r"--length-mm must lie in \(0, 1000\], got -25"),
        (["solve", "--thickness-mm", "0"], "--thickness-mm must lie in"),
        (["solve", "--phi", "0.9"], r"--phi must lie in \[0, 0.5\], got 0.9"),
        (["solve", "--field-mT", "0", "nan"], "--field-mT BZ must lie in"),
        (["solve", "--steps", "1"], r"--steps must lie in \[2, 10000\], got 1"),
        (["solve", "--gravity", "-1"], "--gravity must lie in"),
        (["solve", "--density-kg-per-m3", "0"], "--density-kg-per-m3 must lie in"),
        (["solve", "--preset", "fig3a_L20", "--length-mm", "30"], "give --preset or beam parameters, not both"),
        (["solve", "--preset", "fig4a_4cells_up", "--gravity", "9.81"], "free-free beam needs gravity 0"),
        (["solve", "--support", "free"], "free-free beam needs gravity 0"),
        (["sweep", "--lengths-mm", "-5"], "--lengths-mm must lie in"),
        (["couplings", "--presets", "fig4b_quadratc"], "Did you mean 'fig4b_quadratic'"),
        (["couplings", "--levels", "0"], "--levels must lie in"),
    ],
)
def test_bad_input_exits_2_with_a_message_and_writes_nothing(tmp_path, capsys, argv, match):
    out = tmp_path / "never"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "error:" in err
    assert re.search(match, err), err
    assert not out.exists()


def test_out_must_be_a_folder(tmp_path, capsys):
    f = tmp_path / "file.txt"
    f.write_text("x")
    assert main(["demo", "--out", str(f)]) == 2
    assert "--out must be a folder" in capsys.readouterr().err
    assert f.read_text() == "x"

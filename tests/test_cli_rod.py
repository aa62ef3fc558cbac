"""``magsoft solve`` in 3D (three-component fields, magnetizations across the width, --critical), the rod
figure, and the planar commands refusing 3D input."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.cli import main
from magsoft_env.render.figures import rod_figure

# the default strip of ``magsoft solve``: L 25 mm, w 5 mm, h 1.13 mm, phi 0.2, axial magnetization
STRIP = dict(length=25e-3, width=5e-3, thickness=1.13e-3)


def _run(argv, capsys):
    rc = main(argv)
    out, err = capsys.readouterr()
    return rc, out, err


def test_solve_3d_prints_tip_and_twist_and_writes_png_and_json(tmp_path, capsys):
    rc, out, err = _run(["solve", "--field-mT", "2", "1", "5", "--steps", "4", "--out", str(tmp_path)], capsys)
    assert rc == 0, err
    header = next(line for line in out.splitlines() if "tip x mm" in line)
    for col in ("By mT", "tip y mm", "tip z mm", "twist deg", "stable", "snap", "verif rad"):
        assert col in header
    assert "model 3d" in out
    png = tmp_path / "solve_custom.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads((tmp_path / "solve_custom.json").read_text())
    assert data["model"] == "3d" and data["config"]["field_mT"] == [2.0, 1.0, 5.0]
    assert data["fields_mT"][-1] == [2.0, 1.0, 5.0] and len(data["fields_mT"]) == 4
    final = data["final"]
    ref = ms.solve_equilibrium(ms.Beam(**STRIP), ms.Field.from_mT(2, 1, 5), gravity=9.81)
    tip = [final["tip_x_mm"], final["tip_y_mm"], final["tip_z_mm"]]
    np.testing.assert_allclose(tip, ref.tip_position * 1e3, atol=1e-6)
    assert final["tip_twist_deg"] == pytest.approx(np.degrees(ref.tip_twist), abs=1e-5)
    assert abs(final["tip_y_mm"]) > 0.1 and abs(final["tip_twist_deg"]) > 0.1  # out of the plane, twisted
    shape = final["shape"]
    r, frames = np.array(shape["centreline_m"]), np.array(shape["frames"])
    assert r.shape == (101, 3) and frames.shape == (101, 3, 3)
    np.testing.assert_allclose(r[-1], ref.tip_position, atol=1e-9)
    np.testing.assert_allclose(frames[-1][:, 2], ref.tip_tangent, atol=1e-7)
    # the printed last row is the JSON's
    last = out.split(header)[1].strip().splitlines()[3].split()
    assert float(last[5]) == pytest.approx(final["tip_z_mm"], abs=1e-3)


def test_critical_field_of_the_default_strip(tmp_path, capsys):
    rc, out, err = _run(["solve", "--field-mT", "0", "2", "0", "--gravity", "0", "--critical", "--steps", "3",
                         "--no-plot", "--out", str(tmp_path)], capsys)
    assert rc == 0, err
    m = re.search(r"critical field: \|B\| = ([0-9.]+) mT \+- ([0-9.e+-]+) mT \(bifurcation\)", out)
    assert m, out
    assert float(m.group(1)) == pytest.approx(0.8415, abs=2e-3)
    assert float(m.group(2)) < 1e-6
    p = re.search(r"Prandtl's estimate .*: ([0-9.]+) mT, critical / Prandtl = ([0-9.]+)", out)
    assert p and float(p.group(1)) == pytest.approx(0.784, abs=2e-3)
    assert "event: bifurcation at |B| = 0.84" in out
    crit = json.loads((tmp_path / "solve_custom.json").read_text())["critical"]
    assert crit["kind"] == "bifurcation" and crit["magnitude_mT"] == pytest.approx(0.8415, abs=2e-3)


def test_magnetization_across_the_width_solves_in_3d_with_a_planar_field(tmp_path, capsys):
    rc, out, err = _run(["solve", "--magnetization", "1", "1", "0", "--poisson", "0.3", "--field-mT", "0", "5",
                         "--gravity", "0", "--steps", "3", "--no-plot", "--out", str(tmp_path)], capsys)
    assert rc == 0, err
    assert "twist deg" in out and "magnetization (1 1 0), nu = 0.3" in out
    data = json.loads((tmp_path / "solve_custom.json").read_text())
    assert data["config"]["magnetization"] == [1.0, 1.0, 0.0] and data["config"]["poisson"] == 0.3
    assert abs(data["final"]["tip_y_mm"]) > 0.1
    assert not (tmp_path / "solve_custom.png").exists()


def test_planar_solve_keeps_its_table(tmp_path, capsys):
    rc, out, _ = _run(["solve", "--field-mT", "0", "5", "--steps", "3", "--no-plot", "--out", str(tmp_path)], capsys)
    assert rc == 0 and "v/L" in out and "twist" not in out
    data = json.loads((tmp_path / "solve_custom.json").read_text())
    assert "model" not in data and set(data["final"]["shape"]) == {"s_m", "x_m", "z_m", "theta_rad"}


def test_rod_figure_from_python(tmp_path):
    beam = ms.Beam(**STRIP)
    res = ms.solve_path(beam, ms.ramp((0, 0, 0), (0, 2e-3, 0), 3), gravity=0.0)
    assert rod_figure(res, tmp_path / "rod.png", width=beam.width, max_shapes=2) == tmp_path / "rod.png"
    assert (tmp_path / "rod.png").stat().st_size > 10_000
    rod_figure(res[-1:], tmp_path / "line.svg")  # the centreline alone
    with pytest.raises(ValueError, match="width"):
        rod_figure(res, tmp_path / "x.png", width=-1.0)


def _three_d_preset(tmp_path):
    path = tmp_path / "tilted.json"
    path.write_text(json.dumps({
        "description": "a strip magnetized across its width", "source": "test",
        "beam": {"length_mm": 25, "width_mm": 5, "thickness_mm": 1.13, "volume_fraction": 0.2,
                 "magnetization": {"kind": "direction", "axial": 1, "width": 1, "thickness": 0}},
        "path": [{"from_mT": [0, 0], "to_mT": [0, 5], "steps": 3}],
    }))
    return str(path)


def _three_d_robot(tmp_path):
    from magsoft_env.cases.robots import load_robot

    robot = load_robot("paper-5c")
    path = tmp_path / "tilted.yml"
    robot.replace(name="tilted", beam=robot.beam.replace(magnetization=(1.0, 0.5, 0.0))).save(path)
    return str(path)


@pytest.mark.parametrize("argv, message", [
    (["solve", "--field-mT", "1"], "--field-mT takes two numbers, BX BZ, or three, BX BY BZ, in mT, got 1: 1."),
    (["solve", "--field-mT", "1", "2", "3", "4"], "got 4: 1 2 3 4."),
    (["solve", "--field-mT", "0", "1", "5", "--coupling", "paper"], "a 3D problem takes --coupling rotated: "
                                                                    "coupling='paper' is planar only"),
    (["solve", "--field-mT", "0", "1", "5", "--extensible"], "a 3D problem takes --no-extensible"),
    (["solve", "--magnetization", "1", "1", "0", "--beta-deg", "10"], "give --beta-deg"),
    (["solve", "--magnetization", "0", "0", "0"], "must not be 0 0 0"),
    (["solve", "--poisson", "0.6"], "--poisson must lie in [0, 0.5]"),
    (["solve", "--preset", "fig3b_L25", "--critical"], "--critical follows one ramp from zero"),
    (["solve", "--field-mT", "0", "1", "5", "--gravity", "0", "--support", "free", "--critical"],
     "--critical follows the loading branch of a clamped strip"),
    (["sweep", "--field-mT", "0", "1", "5"], "magsoft sweep is planar (x-z plane)"),
    (["sweep", "--magnetization", "1", "1", "0"], "magsoft sweep is planar"),
    (["couplings", "--field-mT", "0", "1", "5"], "magsoft couplings is planar (x-z plane)"),
    (["couplings", "--magnetization", "1", "1", "0"], "magsoft couplings is planar"),
    (["couplings", "--presets", "TILTED"], "magsoft couplings is planar (x-z plane), but 'tilted' has a "
                                           "magnetization with a component across the width"),
    (["crosscheck", "--preset", "TILTED"], "magsoft crosscheck is planar"),
    (["crosscheck", "--robot", "paper-5c", "--field-mT", "0", "1", "5"], "magsoft solve takes --field-mT BX BY BZ"),
    (["gait", "--preset", "paper-5c", "--field-mT", "0", "1", "5"], "magsoft gait is planar (x-z plane)"),
    (["gait", "--robot", "ROBOT3D"], "is planar (x-z plane), but this beam's magnetization has a component"),
    (["design", "--target", "ball", "--field-mT", "0", "1", "5"], "magsoft design is planar (x-z plane)"),
])
def test_errors(argv, message, tmp_path, capsys):
    argv = [_three_d_preset(tmp_path) if a == "TILTED" else _three_d_robot(tmp_path) if a == "ROBOT3D" else a
            for a in argv]
    out_dir = tmp_path / "out"
    rc, _, err = _run([*argv, "--out", str(out_dir)], capsys)
    assert rc == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"magsoft {argv[0]}: error: ") and message in lines[0], err
    if argv[0] != "crosscheck" or "--robot" not in argv:
        assert not out_dir.exists() or not any(out_dir.iterdir())
    if argv[0] in ("sweep", "couplings", "design") or "--field-mT" in argv and argv[0] == "gait":
        assert "magsoft solve takes 3D fields" in lines[0]

"""Field sources on the command line: ``magsoft solve / gait / video --source`` (with ``--currents-A``), a robot
file's ``field_source`` block, ``magsoft field`` on a source file and ``--plot``; numbers against the Python API,
errors (exit 2, one line naming the key or coil, nothing written)."""

from __future__ import annotations

import json

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.cases.robots import Robot, load_robot
from magsoft_env.cli import main
from magsoft_env.fields import load_source

#: A small magnet over the middle of the paper's 25 mm strip (statics).
MAGNET = """\
type: sphere
position_mm: [12.5, 0, 15]
radius_mm: 3
remanence_T: [0, 0, 1.2]
"""
#: A weak magnet ahead of paper-5c on the floor (the gait stays a crawl).
FLOOR_MAGNET = {"type": "sphere", "position_mm": [30, 0, 14], "radius_mm": 1, "remanence_T": [0, 0, 1.2]}


@pytest.fixture
def magnet(tmp_path):
    path = tmp_path / "magnet.yaml"
    path.write_text(MAGNET)
    return path


def _robot_with_source(tmp_path, field_source, name="r5c_src.yml"):
    robot = load_robot("paper-5c").replace(field_source=field_source)
    return robot.save(tmp_path / name)


# ------------------------------------------------------------------------------------------------------- solve


def test_solve_source_file_matches_solve_equilibrium(tmp_path, magnet, capsys):
    out = tmp_path / "out"
    assert main(["solve", "--source", str(magnet), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "field at the tip" in text and "magnet at (12.5, 0, 15) mm" in text
    data = json.loads((out / "solve_custom.json").read_text())
    assert (out / "solve_custom.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    source = load_source(magnet)
    r = ms.solve_equilibrium(beam, source)
    final = data["final"]
    assert final["tip_x_mm"] == pytest.approx(r.x[-1] * 1e3, rel=1e-9)
    assert final["tip_z_mm"] == pytest.approx(r.z[-1] * 1e3, rel=1e-9)
    B = source.field(r.tip_position.reshape(1, 3))[0] * 1e3
    assert [final["tip_Bx_mT"], final["tip_By_mT"], final["tip_Bz_mT"]] == pytest.approx(B, rel=1e-9, abs=1e-12)
    assert data["field_source"]["source"]["type"] == "sphere"


def test_solve_named_coil_system_with_currents_and_a_ramp(tmp_path, capsys):
    out = tmp_path / "out"
    argv = ["solve", "--source", "navion", "--currents-A", "10", "0", "-5", "--steps", "3", "--no-plot",
            "--gravity", "0", "--out", str(out)]
    assert main(argv) == 0
    rows = json.loads((out / "solve_custom.json").read_text())["results"]
    assert [r["strength"] for r in rows] == pytest.approx([1 / 3, 2 / 3, 1.0])
    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    r = ms.solve_equilibrium(beam, load_source("navion", currents=[10, 0, -5]), gravity=0.0)
    assert rows[-1]["tip_x_mm"] == pytest.approx(r.x[-1] * 1e3, rel=1e-7)
    assert rows[-1]["tip_z_mm"] == pytest.approx(r.z[-1] * 1e3, rel=1e-7, abs=1e-9)


def test_solve_field_mT_adds_a_uniform_field(tmp_path, magnet, capsys):
    out = tmp_path / "out"
    assert main(["solve", "--source", str(magnet), "--field-mT", "1", "0", "--no-plot", "--out", str(out)]) == 0
    final = json.loads((out / "solve_custom.json").read_text())["final"]
    from magsoft_env.fields import SourceSum, Uniform

    beam = ms.Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    r = ms.solve_equilibrium(beam, SourceSum([Uniform((1e-3, 0.0, 0.0)), load_source(magnet)]))
    assert final["tip_z_mm"] == pytest.approx(r.z[-1] * 1e3, rel=1e-9)


def test_robot_field_source_equals_passing_the_source_and_source_wins(tmp_path, magnet, capsys):
    robot_file = _robot_with_source(tmp_path, {"type": "sphere", "position_mm": [12.5, 0, 15], "radius_mm": 3,
                                               "remanence_T": [0, 0, 1.2]})
    a, b, c = tmp_path / "a", tmp_path / "b", tmp_path / "c"
    assert main(["solve", "--robot", str(robot_file), "--no-plot", "--out", str(a)]) == 0
    assert main(["solve", "--robot", "paper-5c", "--source", str(magnet), "--no-plot", "--out", str(b)]) == 0
    fa = json.loads((a / "solve_paper-5c.json").read_text())["final"]
    fb = json.loads((b / "solve_paper-5c.json").read_text())["final"]
    assert fa["tip_x_mm"] == fb["tip_x_mm"] and fa["tip_z_mm"] == fb["tip_z_mm"]
    # --source overrides the file's block: a far, weak dipole instead gives another shape
    far = tmp_path / "far.yaml"
    far.write_text("type: dipole\nposition_mm: [0, 0, 200]\nmoment_A_m2: [0, 0, 0.001]\n")
    assert main(["solve", "--robot", str(robot_file), "--source", str(far), "--no-plot", "--out", str(c)]) == 0
    fc = json.loads((c / "solve_paper-5c.json").read_text())["final"]
    assert abs(fc["tip_z_mm"] - fa["tip_z_mm"]) > 0.1


# -------------------------------------------------------------------------------------------------- gait, video


def test_gait_source_matches_run_gait_and_the_robot_file_block(tmp_path, capsys):
    src = tmp_path / "floor_magnet.json"
    src.write_text(json.dumps(FLOOR_MAGNET))
    robot_file = _robot_with_source(tmp_path, FLOOR_MAGNET)
    assert main(["gait", "--preset", "paper-5c", "--seconds", "0.1", "--source", str(src), "--json"]) == 0
    with_flag = json.loads(capsys.readouterr().out)
    assert main(["gait", "--robot", str(robot_file), "--seconds", "0.1", "--json"]) == 0
    with_file = json.loads(capsys.readouterr().out)
    assert main(["gait", "--preset", "paper-5c", "--seconds", "0.1", "--json"]) == 0
    plain = json.loads(capsys.readouterr().out)
    from magsoft_env.sim.gait import run_gait

    ref = run_gait("paper-5c", 0.1, source=load_source(src)).to_dict()
    assert with_flag["displacement_mm"] == pytest.approx(ref["displacement_mm"], rel=1e-9, abs=1e-12)
    assert with_file["displacement_mm"] == with_flag["displacement_mm"]
    assert with_flag["max_height_mm"] == pytest.approx(ref["max_height_mm"], rel=1e-9)
    assert abs(with_flag["displacement_mm"] - plain["displacement_mm"]) > 1e-6  # the magnet acts
    assert "field_source" not in plain and with_flag["field_source"]["source"]["type"] == "sphere"


def test_video_source_writes_and_reports_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    src = tmp_path / "floor_magnet.json"
    src.write_text(json.dumps(FLOOR_MAGNET))
    out = tmp_path / "v.gif"
    rc = main(["video", "--preset", "paper-5c", "--seconds", "0.1", "--fps", "10", "--width", "160", "--height",
               "90", "--source", str(src), "--out", str(out)])
    if rc == 1:
        pytest.skip("no headless OpenGL")
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert out.stat().st_size > 0 and summary["field_source"]["source"]["type"] == "sphere"


# ---------------------------------------------------------------------------------------------------- errors

BAD_KEY = "type: sphere\nposition_mm: [0, 0, 20]\nradius_m: 3\nremanence_T: [0, 0, 1]\n"


@pytest.mark.parametrize("command", [
    ["solve"],
    ["gait", "--preset", "paper-5c"],
    ["video", "--preset", "paper-5c"],
])
@pytest.mark.parametrize("flags, fragment", [
    (["--source", "{bad}"], "Did you mean 'radius_mm'"),
    (["--source", "navion", "--currents-A", "1", "2"], "3 (Coil_0, Coil_1, Coil_2), got 2"),
    (["--source", "navion"], "needs --currents-A"),
    (["--source", "navoin", "--currents-A", "1", "2", "3"], "Did you mean 'navion'"),
    (["--currents-A", "1", "2", "3"], "give it with --source"),
    (["--source", "{missing}"], "does not exist"),
])
def test_bad_sources_exit_2_before_any_work(tmp_path, capsys, command, flags, fragment):
    bad = tmp_path / "bad.yaml"
    bad.write_text(BAD_KEY)
    flags = [f.format(bad=bad, missing=tmp_path / "none.yaml") for f in flags]
    out = tmp_path / "out"
    target = ["--out", str(out / "v.gif")] if command[0] == "video" else (["--out", str(out)] if command[0] == "solve"
                                                                          else [])
    assert main([*command, *flags, *target]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"magsoft {command[0]}: error: ") and fragment in err
    assert "Traceback" not in err and not out.exists()


def test_robot_file_with_a_bad_field_source_names_the_robot_and_key(tmp_path, capsys):
    robot_file = _robot_with_source(tmp_path, {"type": "sphere", "position_mm": [0, 0, 20], "radius_m": 3,
                                               "remanence_T": [0, 0, 1]})
    assert main(["gait", "--robot", str(robot_file), "--seconds", "0.1"]) == 2
    err = capsys.readouterr().err
    assert "field_source" in err and "radius_mm" in err


def test_solve_source_refuses_what_the_source_solver_cannot_take(tmp_path, magnet, capsys):
    for extra, fragment in ((["--critical"], "--critical"), (["--field-mT", "0", "1", "2"], "two numbers"),
                            (["--support", "free", "--gravity", "0"], "cantilever"),
                            (["--extensible"], "--no-extensible")):
        assert main(["solve", "--source", str(magnet), *extra, "--out", str(tmp_path / "o")]) == 2
        assert fragment in capsys.readouterr().err


def test_video_env_refuses_a_source(tmp_path, magnet, capsys):
    assert main(["video", "--env", "MagSoftCrawl-v1", "--source", str(magnet), "--out", str(tmp_path / "v.gif")]) == 2
    assert "--env" in capsys.readouterr().err


# ------------------------------------------------------------------------------------------------ robot files


def test_robot_field_source_round_trips_and_is_plain_data(tmp_path):
    robot = load_robot("paper-5c").replace(field_source=FLOOR_MAGNET)
    assert load_robot(robot.save(tmp_path / "r.yml")) == robot
    assert load_robot(robot.save(tmp_path / "r.json")) == robot
    assert load_robot(robot.save(tmp_path / "r.yml")).field_source == FLOOR_MAGNET
    assert hash(robot) == hash(load_robot(tmp_path / "r.yml"))
    with pytest.raises(ValueError, match="mapping"):
        robot.replace(field_source=[1, 2])
    with pytest.raises(ValueError, match="plain data"):
        robot.replace(field_source={"type": "dipole", "moment_A_m2": np.array([0.0, 0.0, 1.0])})
    data = robot.to_dict()
    data["source"] = {"type": "dipole"}
    with pytest.raises(ValueError, match="field_source"):
        Robot.from_dict(data)


def test_robot_field_source_file_paths_are_relative_to_the_robot_file(tmp_path, monkeypatch):
    from magsoft_env.cli.sources import robot_field_source

    sub = tmp_path / "sub"
    sub.mkdir()
    ax = np.linspace(-20.0, 20.0, 5)
    B = np.broadcast_to(np.array([1.0, 0.0, 2.0]), (5, 5, 5, 3)).copy()
    np.savez(sub / "grid.npz", x_mm=ax, y_mm=ax, z_mm=ax, B_mT=B)
    robot = load_robot("paper-5c").replace(field_source={"type": "grid", "file": "grid.npz"})
    path = robot.save(sub / "r.yml")
    monkeypatch.chdir(tmp_path)  # not the robot file's folder
    src = robot_field_source(load_robot(path))
    assert src.field(np.array([[0.001, 0.0, 0.002]]))[0] * 1e3 == pytest.approx([1.0, 0.0, 2.0], abs=1e-9)
    with pytest.raises(ValueError, match="field_source"):
        robot_field_source(robot)  # built in Python: paths from the working directory, where there is none


# ------------------------------------------------------------------------------------------------- magsoft field


def test_field_source_file_and_plot(tmp_path, magnet, capsys):
    png = tmp_path / "map.png"
    assert main(["field", "--source", str(magnet), "--at-mm", "0", "0", "0", "--json", "--plot", str(png),
                 "--robot", "paper-5c", "--extent-mm", "-10", "35", "-10", "30", "--points", "40"]) == 0
    info = json.loads(capsys.readouterr().out)
    B = load_source(magnet).field(np.zeros((1, 3)))[0] * 1e3
    assert info["points"][0]["B_mT"] == pytest.approx(B, rel=1e-9, abs=1e-12)
    assert info["markers"] == [{"kind": "magnet", "at_mm": pytest.approx([12.5, 0.0, 15.0])}]
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 5000


def test_field_coil_system_plot_and_flag_errors(tmp_path, capsys):
    png = tmp_path / "navion.png"
    assert main(["field", "--source", "navion", "--currents-A", "10", "0", "0", "--plot", str(png), "--plane",
                 "xy", "--points", "30"]) == 0
    assert f"wrote {png}" in capsys.readouterr().out and png.stat().st_size > 0
    for argv, fragment in ((["--robot", "paper-5c"], "give --plot"),
                           (["--plot", str(tmp_path / "x.txt")], "--plot must end"),
                           (["--plot", str(png), "--extent-mm", "1", "2"], "one number"),
                           (["--plot", str(png), "--extent-mm", "5", "1", "0", "1"], "U_MIN < U_MAX")):
        assert main(["field", "--source", "navion", *argv]) == 2
        assert fragment in capsys.readouterr().err


def test_crosscheck_says_it_does_not_use_a_robots_field_source(tmp_path, capsys):
    path = _robot_with_source(tmp_path, FLOOR_MAGNET)
    assert main(["crosscheck", "--robot", str(path), "--segments", "4", "--steps", "3"]) == 0
    err = capsys.readouterr().err
    assert "field_source (sphere) that magsoft crosscheck does not use" in err
    assert main(["crosscheck", "--robot", "paper-5c", "--segments", "4", "--steps", "3"]) == 0
    assert "field_source" not in capsys.readouterr().err

"""``magsoft export`` / ``export_mjcf``: the robot's MuJoCo model as MJCF, driven in plain MuJoCo as documented."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from magsoft_env.cases.gaits import gait_preset
from magsoft_env.cli import main
from magsoft_env.sim import Simulator
from magsoft_env.sim.export import export_mjcf
from magsoft_env.sim.gait import gait_rod_options, run_gait

#: Simulated time of the plain-MuJoCo drive (s): two field periods after paper-5c's warm-up cycle.
DRIVE_SECONDS = 1.5


def _drive_plain(path, wave, seconds):
    """The documented convention, in plain MuJoCo: ctrl[:P] = B_x(t), ctrl[P:] = B_z(t) before each mj_step."""
    m = mujoco.MjModel.from_xml_path(str(path))
    d = mujoco.MjData(m)
    P = m.nu // 2
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or "" for b in range(m.nbody)]
    pieces = [b for b, name in enumerate(names) if name.startswith("piece")]
    mass = m.body_mass[pieces]

    def com_x():
        mujoco.mj_kinematics(m, d)
        return float(mass @ d.xipos[pieces, 0] / mass.sum())

    mujoco.mj_forward(m, d)
    x0 = com_x()
    w = 2.0 * math.pi * wave.frequency
    for _ in range(int(round(seconds / m.opt.timestep))):
        t = d.time
        d.ctrl[:P] = wave.amplitude_x * math.sin(w * t + wave.phase)
        d.ctrl[P:] = wave.amplitude_z * math.sin(w * t)
        mujoco.mj_step(m, d)
    return com_x() - x0


def test_cli_export_loads_in_plain_mujoco_and_crawls_as_the_package(tmp_path, capsys):
    out = tmp_path / "m.xml"
    assert main(["export", "--robot", "assets/robots/paper-5c.yml", "--out", str(out)]) == 0
    assert "ctrl[:22] = B_x(t)" in capsys.readouterr().out
    text = out.read_text()
    assert "<!-- magsoft_env export: field convention." in text and "ctrl[0:22]" in text
    robot = gait_preset("paper-5c")
    assert robot.wave.shape == "sine"
    dx = _drive_plain(out, robot.wave, DRIVE_SECONDS)
    ref = run_gait(robot, DRIVE_SECONDS).displacement
    assert abs(ref) > 0.3e-3  # it crawls (-0.785 mm in 2 s)
    assert dx == pytest.approx(ref, rel=0.01)  # measured: 1e-12 relative


def test_exported_model_is_the_packages_rod_at_full_precision(tmp_path):
    robot = gait_preset("paper-5c")
    info = export_mjcf(robot, tmp_path / "m.xml")
    m = mujoco.MjModel.from_xml_path(info["path"])
    ref = Simulator(robot.beam, gait_rod_options(robot)).model
    assert info["poles"] * 2 == info["nu"] == m.nu and info["segments"] == robot.segments
    def pieces(model):  # body ids of the rod's pieces (the package's model also has its field's mocap frame)
        return [mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, f"piece{i}") for i in range(robot.segments + 1)]

    for name in ("body_pos", "body_quat", "body_ipos", "body_mass", "body_inertia"):
        assert np.array_equal(getattr(m, name)[pieces(m)], getattr(ref, name)[pieces(ref)]), name
    for name in ("jnt_stiffness", "jnt_pos", "dof_damping", "geom_size", "geom_pos", "geom_friction", "geom_solref",
                 "pair_solref", "pair_friction"):
        a, b = getattr(m, name), getattr(ref, name)
        assert a.shape == b.shape and np.array_equal(a, b), name  # the XML writer's 6 digits rewritten
    assert m.opt.timestep == ref.opt.timestep and m.opt.integrator == ref.opt.integrator


def test_export_scenes_and_bad_input(tmp_path):
    info = export_mjcf("paper-5c", tmp_path / "o.xml", scene="obstacle", segments=10, timestep=1e-3)
    m = mujoco.MjModel.from_xml_path(info["path"])
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "obstacle") >= 0 and m.opt.timestep == 1e-3
    with pytest.raises(ValueError, match="scene must be one of"):
        export_mjcf("paper-5c", tmp_path / "x.xml", scene="cantilever")
    with pytest.raises(ValueError, match="scene must be one of"):
        export_mjcf("paper-5c", tmp_path / "x.xml", scene="moon")
    with pytest.raises(ValueError, match=r"path must end in \.xml"):
        export_mjcf("paper-5c", tmp_path / "x.mjb")
    with pytest.raises(ValueError, match="paper-5c"):
        export_mjcf("paper-5q", tmp_path / "x.xml")
    assert not (tmp_path / "x.xml").exists()


@pytest.mark.parametrize(("argv", "match"), [
    (["--robot", "paper-5c", "--scene", "moon"], "--scene must be one of"),
    (["--robot", "paper-5c", "--segments", "1"], "--segments must be"),
    (["--robot", "paper-5c", "--timestep-ms", "0"], "--timestep-ms must lie"),
    (["--robot", "paper-5c", "--feature-x-mm", "5"], "--feature-x-mm applies to"),
    (["--robot", "nowhere.yml"], "--robot"),
])
def test_cli_export_bad_input_exits_2(tmp_path, capsys, argv, match):
    out = tmp_path / "m.xml"
    assert main(["export", *argv, "--out", str(out)]) == 2
    assert match in capsys.readouterr().err
    assert not out.exists()
    assert main(["export", "--robot", "paper-5c", "--out", str(tmp_path / "m.txt")]) == 2

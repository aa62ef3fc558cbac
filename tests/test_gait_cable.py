"""The paper's gaits on the 3D rod (the flexcomp strip on the floor): ``run_gait(rod="cable")`` and
``magsoft gait --rod cable``."""

from __future__ import annotations

import json
import math

import pytest

from magsoft_env.cases.gaits import gait_preset
from magsoft_env.cli import main
from magsoft_env.sim.gait import gait_rod_options, run_gait


def test_cable_gait_options_are_the_planar_ones():
    robot = gait_preset("paper-5c")
    planar = gait_rod_options(robot)
    cable = gait_rod_options(robot, rod="cable")
    assert cable.rod == "cable" and cable.scene == "floor"
    for name in ("segments", "timestep", "friction", "retardation_time", "contact_timeconst", "cone", "integrator",
                 "contact_dampratio", "contact_refsafe", "solver_iterations", "solver_tolerance", "gravity"):
        assert getattr(cable, name) == getattr(planar, name), name
    with pytest.raises(ValueError, match="floor scene only"):
        gait_rod_options(robot, rod="cable", scene="channel")
    with pytest.raises(ValueError, match="rod must be"):
        gait_rod_options(robot, rod="chain3d")


def test_cli_y_drive_needs_the_3d_rod(capsys):
    assert main(["gait", "--preset", "paper-5c", "--seconds", "0.1", "--amplitude-y-mT", "1"]) == 2
    assert "--rod cable" in capsys.readouterr().err


def test_cli_gait_on_the_strip_reports_its_third_dimension(tmp_path, capsys):
    out = tmp_path / "g.json"
    code = main(["gait", "--preset", "paper-5c", "--seconds", "0.1", "--rod", "cable", "--json", "--out", str(out)])
    assert code == 0
    data = json.loads(out.read_text())
    assert data["rod"] == "cable" and data["segments"] == 20
    assert abs(data["displacement_y_mm"]) < 1e-3 and data["max_roll_deg"] < 1.0  # an x-z drive keeps it in plane
    assert data["field_mT"]["amplitude_y"] == 0.0
    assert math.isfinite(data["max_penetration_h"]) and data["max_penetration_h"] < 0.2


@pytest.mark.slow
def test_paper_5c_crawls_on_the_strip_in_the_planar_chains_direction():
    """paper-5c at its own numerics (20 segments, 0.2 ms), 2 s: the strip crawls left like the planar chain, on its
    wide face, in the plane of the drive (measured: -0.22 mm/s against the chain's -0.41 mm/s; docs/sim.md)."""
    strip = run_gait("paper-5c", 2.0, rod="cable")
    chain = run_gait("paper-5c", 2.0)
    assert strip.success and chain.success, (strip.message, chain.message)
    assert strip.locomotion == chain.locomotion == "crawl"
    assert strip.direction == chain.direction == "left"
    assert abs(strip.displacement_y) < 1e-5 and math.degrees(strip.max_roll) < 1.0
    assert strip.max_penetration_h < 0.2
    assert 0.3 < strip.speed / chain.speed < 1.0

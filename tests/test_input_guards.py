"""Input guards found by reviewers trying the package as users would: one test per defect.

Each test fails on the code before its fix: the input was taken silently, reported under the wrong name,
or ran for a long time before an honest failure.
"""

from __future__ import annotations

import math
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import magsoft_env as ms
from magsoft_env.cli import main
from magsoft_env.spec import as_field
from magsoft_env.theory import TERMINATION_MESSAGES

BEAM_KW = {"length": 0.02, "width": 5e-3, "thickness": 1e-3}


def _beam(**kw):
    return ms.Beam(**{**BEAM_KW, **kw})


@pytest.mark.parametrize("m, expected", [
    ((1e200, 1.0, 0.0), (1.0, 0.0, 0.0)),
    ((0.0, 1e200, 1e200), (0.0, 2 ** -0.5, 2 ** -0.5)),
    ((1.3e154, 0.0, 1.3e154), (2 ** -0.5, 0.0, 2 ** -0.5)),
    ((1e-200, 0.0, 0.0), (1.0, 0.0, 0.0)),
])
def test_huge_or_tiny_magnetization_components_keep_their_direction(m, expected):
    # |m| squared overflowed to inf (or underflowed to 0): the direction became (0, 0, 0) and the strip was
    # solved as unmagnetized (or refused as a zero vector)
    d = _beam(magnetization=m).magnetization_direction(np.array([0.0, 0.01]))
    np.testing.assert_allclose(d, [expected, expected], atol=1e-12)


def test_field_as_a_column_array_is_reported_as_a_bad_shape():
    with pytest.raises(ValueError, match=r"field must have shape \(2,\) .* or \(3,\) .*got an array of shape \(3, 1\)"):
        as_field(np.array([[0.0], [13e-3], [0.0]]))


def test_gravity_beyond_100_g_is_refused_before_solving():
    with pytest.raises(ValueError, match=r"gravity must lie in \[0, 1000\] m/s\^2.*got 1e\+30"):
        ms.solve_equilibrium(_beam(), (0.0, 13e-3), gravity=1e30)
    with pytest.raises(ValueError, match=r"gravity must lie in \[0, 1000\] m/s\^2.*got 9810"):
        ms.solve_path(_beam(magnetization=(1.0, 1.0, 0.0)), [(0.0, 13e-3, 0.0)], gravity=9810)


def test_a_3d_load_step_past_its_work_budget_ends_with_a_status_saying_so():
    # a strip magnetized across its width, flipped by a field against it: a fold and a jump on the way
    beam = _beam(magnetization=(0.0, 1.0, 0.0))
    field = (0.0, -50e-3, 0.0)
    free = ms.solve_equilibrium(beam, field, options=ms.theory.SolverOptions(max_step_work=math.inf))
    default = ms.solve_equilibrium(beam, field)
    assert free.success and free.snap_through
    np.testing.assert_array_equal(default.centreline, free.centreline)  # the budget changes nothing not hit
    r = ms.solve_equilibrium(beam, field, options=ms.theory.SolverOptions(max_step_work=2))
    assert not r.success and r.status == 5
    assert r.message.startswith(TERMINATION_MESSAGES[5])
    assert "max_step_work = 2 " in r.message and "ms.ramp" in r.message
    assert math.isnan(r.verification)
    with pytest.raises(ValueError, match=r"SolverOptions.max_step_work must be > 0"):
        ms.solve_equilibrium(beam, field, options=ms.theory.SolverOptions(max_step_work=0))


def test_tesla_given_to_an_mT_flag_warns_with_the_likely_value(tmp_path, capsys):
    assert main(["solve", "--field-mT", "0", "0.013", "--steps", "2", "--no-plot", "--out", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert "warning: --field-mT 0 0.013 is a field of 0.013 mT" in err and "--field-mT 0 13 is 13 mT" in err
    assert main(["solve", "--field-mT", "0", "13", "--steps", "2", "--no-plot", "--out", str(tmp_path)]) == 0
    assert "warning" not in capsys.readouterr().err  # a plausible field: no word


@pytest.mark.parametrize("goal", ["abc", (0.01, 0.02, 0.0), [[0.01], [0.02]], ("0.01", "0.02")])
def test_a_bad_steering_goal_is_named_with_its_shape_units_and_range(goal):
    from magsoft_env.envs.steer import MagSoftSteerEnv

    env = MagSoftSteerEnv()
    with pytest.raises(ValueError, match=r"options\['goal'\] must be a point \(x, y\) on the floor in m, shape \(2,\)"
                                         r".*within max_distance = .* m .*got "):
        env.reset(seed=0, options={"goal": goal})
    env.close()


def test_long_work_shows_progress_on_stderr_only_when_asked(capsys):
    from magsoft_env.compare.grasp import GraspTrial, max_lift_mass

    class Scene:  # lifts up to 3 gripper masses; a real trial takes seconds of MuJoCo
        gripper_mass = 1e-3

        def trial(self, mass):
            lifted = mass <= 3e-3
            return GraspTrial(lifted, mass, 0.01, message="lifted" if lifted else "not lifted")

    quiet = max_lift_mass(Scene())
    assert capsys.readouterr().err == ""
    loud = max_lift_mass(Scene(), progress=True)
    err = capsys.readouterr().err.splitlines()
    assert loud.ratio == quiet.ratio and len(err) == len(loud.trials)
    assert err[0].startswith("grasp trial 1: 0.05 x the gripper mass (0.05 g): lifted [")

    pytest.importorskip("stable_baselines3")
    from magsoft_env.rl.callbacks import ProgressLines

    cb = ProgressLines(100, every=0.5, label="PPO")
    cb._on_training_start()
    for n in (49, 50, 99, 100):
        cb.num_timesteps = n
        cb._on_step()
    err = capsys.readouterr().err.splitlines()
    assert err[0] == "PPO: 100 steps ..." and len(err) == 3
    assert err[1].startswith("PPO: 50/100 steps (50 %), ") and err[2].startswith("PPO: 100/100 steps (100 %), ")


README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_commands_parse_as_pasted_and_name_what_all_installs():
    import shlex

    from magsoft_env.cli import build_parser

    text = README.read_text()
    commands = [" ".join(c.split()) for c in re.findall(r"`(magsoft [^`]*)`", text) if "COMMAND" not in c]
    assert any("--rod cable" in c for c in commands)
    for cmd in commands:  # argparse exits (status 2) on a missing required flag such as --preset or --out
        _, extras = build_parser().parse_known_args(shlex.split(cmd)[1:])
        assert not extras, cmd
    extras = tomllib.loads((README.parent / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    (all_extra,) = extras["all"]
    parts = re.search(r"\[(.*)\]", all_extra).group(1)
    assert f"`.[all]` is `.[{parts}]`" in text and "Ray" in text and "Warp" in text and "pillow" in text


def test_export_takes_built_in_names_anywhere_and_suggests_them_for_a_missing_file(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # not the repository's root: assets/robots/... is not here
    cmd = re.search(r"`magsoft (export [^`]*)`", README.read_text()).group(1).split()
    assert main(cmd) == 0 and (tmp_path / "m.xml").stat().st_size > 0
    capsys.readouterr()
    assert main(["export", "--robot", "assets/robots/paper-5c.yml", "--out", "m2.xml"]) == 2
    err = capsys.readouterr().err
    assert "does not exist" in err and "paper-5a, paper-5b, paper-5c" in err and "--robot paper-5c" in err


def test_gait_says_when_its_speed_is_not_the_papers(capsys):
    assert main(["gait", "--preset", "paper-5c", "--seconds", "1.5"]) == 0
    out = capsys.readouterr().out.splitlines()
    i = next(k for k, line in enumerate(out) if line.startswith("paper: reversible, 3.00 mm/s either way"))
    assert out[i + 1].startswith("note: the simulated speed is ") and "docs/envs.md" in out[i + 1]

"""``magsoft`` fails well: every user error of every subcommand exits 2 before any work, with one error line
on stderr naming the subcommand (and its usage for argparse errors), never a traceback; plus --version,
the (Bx, Bz) order of ``couplings``, ``crosscheck --preset``, ``gait --out`` and the short-gait warning."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

import magsoft_env
from magsoft_env.cli import main
from magsoft_env.cli.solve import tidy, tidy_float

HAVE_PROC = Path("/proc").is_dir()
PROC = "/proc/x/y"  # a virtual file system: nothing can be created there, whatever the permission bits

# (subcommand, arguments without --out, the --out to give or None, fragment expected in stderr); in --out,
# {never} is a folder that must never be created, {tmp} the test's folder (holding a file "file" and the folders
# "folder" and "folder.mp4")
CASES = [
    # unknown flags: the subcommand's usage, not the top-level parser's
    ("demo", ["--bogus"], "{never}", "usage: magsoft demo"),
    ("solve", ["--preset", "fig3a_L20", "--bogus", "1"], "{never}", "usage: magsoft solve"),
    ("sweep", ["--bogus"], "{never}", "usage: magsoft sweep"),
    ("couplings", ["--bogus"], "{never}", "usage: magsoft couplings"),
    ("design", ["--target", "ball", "--bogus"], "{never}", "usage: magsoft design"),
    ("crosscheck", ["fig3a_L20", "--bogus"], "{never}", "usage: magsoft crosscheck"),
    ("gait", ["--preset", "paper-5a", "--bogus"], None, "usage: magsoft gait"),
    ("video", ["--preset", "paper-5a", "--bogus"], "{never}/x.gif", "usage: magsoft video"),
    # malformed values and missing arguments (argparse)
    ("solve", ["--steps", "abc"], "{never}", "invalid int value: 'abc'"),
    ("sweep", ["--paths", "c"], "{never}", "invalid choice: 'c'"),
    ("gait", ["--preset", "paper-5x"], None, "did you mean 'paper-5c'?"),
    ("gait", [], None, "one of the arguments --preset --robot is required"),
    # robot files
    ("gait", ["--robot", "{never}/robot.yml"], None, "does not exist"),
    ("gait", ["--robot", "robot.txt"], None, "must end in one of ['.yml', '.yaml', '.json']"),
    ("solve", ["--robot", "paper5c"], "{never}", "Did you mean 'paper-5c'?"),
    ("crosscheck", ["--robot", "paper-5c", "--field-mT", "0", "1e9"], "{never}", "--field-mT BZ must lie in"),
    ("video", [], "{never}/x.gif", "one of the arguments --preset --env is required"),
    # out-of-range values
    ("solve", ["--steps", "1"], "{never}", "--steps must lie in [2, 10000]"),
    ("sweep", ["--lengths-mm", "-5"], "{never}", "--lengths-mm must lie in"),
    ("couplings", ["--levels", "0"], "{never}", "--levels must lie in"),
    ("design", ["--target", "ball", "--points", "2"], "{never}", "--points must lie in [4, 100000]"),
    ("crosscheck", ["fig3a_L20", "--segments", "1"], "{never}", "--segments must be integers in [2, 1000]"),
    ("gait", ["--preset", "paper-5a", "--seconds", "-1"], None, "--seconds must be > 0"),
    ("gait", ["--preset", "paper-5a", "--timestep-ms", "nan"], None, "--timestep-ms must lie in (0, 10]"),
    ("video", ["--preset", "paper-5a", "--width", "8"], "{never}/x.gif", "--width must be an integer in [16, 4096]"),
    ("video", ["--preset", "paper-5a", "--seconds", "inf"], "{never}/x.gif", "--seconds must be > 0"),
    ("video", ["--preset", "paper-5a", "--seconds", "1e5"], "{never}/x.gif", "simulation steps"),
    # unknown presets and environment ids: the closest name suggested
    ("solve", ["--preset", "fig3a_L26"], "{never}", "Did you mean 'fig3a_L25'"),
    ("couplings", ["--preset", "fig4b_quadratc"], "{never}", "Did you mean 'fig4b_quadratic'"),
    ("crosscheck", ["--preset", "fig3a_L2O", "--segments", "8"], "{never}", "fig3a_L20"),
    ("crosscheck", ["fig3a_L2O", "--segments", "8"], "{never}", "fig3a_L20"),
    ("design", ["--target", "bal"], "{never}", "Did you mean 'ball'"),
    ("video", ["--preset", "paper-5x"], "{never}/x.gif", "Did you mean 'paper-5c'"),
    ("video", ["--env", "MagSoftCrawl-v9"], "{never}/x.mp4", "Did you mean 'MagSoftCrawl-v2'"),
    ("video", ["--env", "MagSoftCrawl-v1", "--policy", "missing.zip"], "{never}/x.gif", "--policy must be an existing"),
    # output paths that cannot be written
    ("video", ["--preset", "paper-5a"], "{never}/x.avi", "--out must end in one of"),
    ("video", ["--preset", "paper-5a"], "{tmp}/folder.mp4", "which is a folder"),
    ("gait", ["--preset", "paper-5a"], "{tmp}/folder", "which is a folder"),
    ("demo", [], "{tmp}/file/out", "is a file, not a folder"),
    ("gait", ["--preset", "paper-5a"], "{tmp}/file/r.json", "is a file, not a folder"),
    ("demo", [], PROC, "is not writable"),
    ("solve", ["--preset", "fig3a_L20"], PROC, "is not writable"),
    ("sweep", [], PROC, "is not writable"),
    ("couplings", [], PROC, "is not writable"),
    ("design", ["--target", "ball"], PROC, "is not writable"),
    ("crosscheck", ["fig3a_L20"], PROC, "is not writable"),
    ("gait", ["--preset", "paper-5a"], PROC + "/r.json", "is not writable"),
    ("video", ["--preset", "paper-5a"], PROC + "/v.mp4", "is not writable"),
]


def _run(argv):
    try:
        return main(argv)
    except SystemExit as exc:  # main should return, but a SystemExit with status 2 would do too
        return exc.code


@pytest.mark.parametrize(("command", "argv", "out", "fragment"), CASES,
                         ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_user_errors_exit_2_with_one_line_and_no_traceback(tmp_path, capsys, command, argv, out, fragment):
    if out is not None and out.startswith("/proc") and not HAVE_PROC:
        pytest.skip("no /proc here")
    blocker = tmp_path / "file"
    blocker.write_text("x")
    (tmp_path / "folder").mkdir()
    (tmp_path / "folder.mp4").mkdir()
    never = tmp_path / "never"
    extra = [] if out is None else ["--out", out.format(never=never, tmp=tmp_path)]
    rc = _run([command, *argv, *extra])
    captured = capsys.readouterr()
    assert rc == 2, captured
    assert "Traceback" not in captured.err + captured.out
    (line,) = captured.err.strip().splitlines()  # one line on stderr, naming the subcommand
    assert line.startswith(f"magsoft {command}: error: "), captured.err
    assert fragment in captured.out + line, captured
    # nothing ran (no table, no progress, no "wrote"); errors in the flags print the subcommand's usage
    assert captured.out == "" or captured.out.startswith(f"usage: magsoft {command} "), captured.out
    if "error: argument " in line or "unrecognized arguments" in line or "arguments are required" in line:
        assert captured.out.startswith(f"usage: magsoft {command} "), captured
    assert not never.exists()  # nothing written
    assert blocker.read_text() == "x"


def test_the_real_command_fails_well(tmp_path):
    """``python -m magsoft_env.cli``: exit status 2, the message on the real stderr, no traceback."""
    r = subprocess.run([sys.executable, "-m", "magsoft_env.cli", "video", "--env", "MagSoftCrawl-v9", "--out",
                        str(tmp_path / "x.mp4")], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2, r
    assert r.stdout == "" and "Traceback" not in r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith("magsoft video: error: --env must be a registered magsoft environment id (")
    assert line.endswith("got 'MagSoftCrawl-v9'. Did you mean 'MagSoftCrawl-v2'?")


def test_unknown_flag_suggests_the_closest_one(capsys):
    assert main(["gait", "--preset", "paper-5a", "--secondz", "1"]) == 2
    captured = capsys.readouterr()
    assert captured.out.startswith("usage: magsoft gait ")  # the subcommand's usage, not the top-level one
    assert captured.err == ("magsoft gait: error: unrecognized arguments: --secondz 1; did you mean --seconds? "
                            "(see magsoft gait --help)\n")


def test_unknown_command_and_no_command(capsys):
    assert main(["sovle"]) == 2
    captured = capsys.readouterr()
    assert captured.out.startswith("usage: magsoft [")
    assert "did you mean 'solve'?" in captured.err and len(captured.err.splitlines()) == 1
    assert main([]) == 2
    captured = capsys.readouterr()
    assert captured.out.startswith("usage: magsoft [")
    assert captured.err.startswith("magsoft: error: give a COMMAND") and len(captured.err.splitlines()) == 1


def test_version(capsys):
    assert main(["--version"]) == 0
    assert capsys.readouterr().out == f"magsoft_env {magsoft_env.__version__}\n"


def test_help_exits_0(capsys):
    assert main(["gait", "--help"]) == 0
    assert "--out PATH" in capsys.readouterr().out


# ----------------------------------------------------------------------------------- (Bx, Bz) order


def test_couplings_table_is_in_bx_bz_order(tmp_path, capsys):
    out = tmp_path / "c"
    assert main(["couplings", "--preset", "fig3a_L20", "--steps", "3", "--levels", "1", "--no-plot",
                 "--out", str(out)]) == 0
    lines = capsys.readouterr().out.splitlines()
    header = next(ln for ln in lines if "Bx mT" in ln)
    assert header.index("Bx mT") < header.index("Bz mT")
    cols = header.split()
    row = next(ln for ln in lines if ln.split()[:1] == ["fig3a_L20"]).split()
    # header "preset Bx mT Bz mT ...": the row's second and third cells are B_x = 0 and B_z = 13 mT (path a)
    assert cols[:5] == ["preset", "Bx", "mT", "Bz", "mT"]
    assert (float(row[1]), float(row[2])) == (0.0, 13.0)
    csv_header = (out / "couplings.csv").read_text().splitlines()[0].split(",")
    assert csv_header.index("Bx_mT") < csv_header.index("Bz_mT")


# ----------------------------------------------------------------------------------- crosscheck --preset


def test_crosscheck_takes_presets_positionally_or_with_preset(capsys):
    argv = ["--segments", "6", "--steps", "3"]
    assert main(["crosscheck", "--preset", "fig3a_L20", *argv]) == 0
    flag = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("fig3a_L20")]
    assert main(["crosscheck", "fig3a_L20", "--presets", "fig3a_L20", *argv]) == 0  # both forms, deduplicated
    both = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("fig3a_L20")]
    assert len(flag) == len(both) == 1
    assert flag[0].split()[:3] == both[0].split()[:3]  # same preset, segments and error


# ----------------------------------------------------------------------------------- gait


GAIT = ["gait", "--timestep-ms", "0.5", "--segments", "6"]


def test_gait_out_writes_json_and_warns_on_a_short_run(tmp_path, capsys):
    path = tmp_path / "sub" / "gait.json"
    assert main([*GAIT, "--preset", "paper-5c", "--seconds", "0.2", "--json", "--out", str(path)]) == 0
    captured = capsys.readouterr()
    printed = json.loads(captured.out)
    written = json.loads(path.read_text())
    assert written == printed
    assert written["short_run"] is True and written["speed_window_periods"] < 1.0
    assert len(written["warnings"]) == 1 and "not over whole periods" in written["warnings"][0]
    assert "magsoft gait: warning:" in captured.err and "not over whole periods" in captured.err
    # the paper values follow the case data: paper-5c crawls 3 mm/s either way
    assert written["paper_speed_mm_s"] == 3.0 and written["paper_direction"] == "reversible"
    # rounded: 90 deg, not 90.00000000000001
    assert written["field_mT"]["phase_x_deg"] == 90.0
    assert not list(path.parent.glob(".*"))  # written atomically: no temporary file left


def test_gait_text_short_warning_and_paper_line(tmp_path, capsys):
    path = tmp_path / "g.json"
    assert main([*GAIT, "--preset", "paper-5c", "--seconds", "0.2", "--out", str(path)]) == 0
    text = capsys.readouterr().out
    assert "warning: the run (0.2 s) is shorter than the warm-up plus one field period (1 s at 2 Hz)" in text
    assert "no speed given" not in text  # the description quotes the paper's 3 mm/s
    assert "paper: reversible, 3.00 mm/s either way" in text
    assert f"wrote {path}" in text
    assert json.loads(path.read_text())["short_run"] is True


def test_gait_long_enough_run_has_no_warning(capsys):
    assert main([*GAIT, "--preset", "paper-5a", "--seconds", "1.0", "--json"]) == 0
    captured = capsys.readouterr()
    out = json.loads(captured.out)
    assert out["short_run"] is False and out["warnings"] == [] and out["speed_window_periods"] >= 0.9
    assert "warning" not in captured.err


# ----------------------------------------------------------------------------------- JSON rounding


@pytest.mark.parametrize(
    ("x", "expected"),
    [(0.9999999999999062, 1.0), (90.00000000000001, 90.0), (0.1 + 0.2, 0.3), (-0.85, -0.85), (0.0, 0.0),
     (1e300, 1e300)],
)
def test_tidy_float_removes_float_noise(x, expected):
    assert tidy_float(x) == expected


def test_tidy_keeps_values_to_2e_13_and_json_strict():
    for x in (1 / 3, math.pi, 2 / 3 * 1e-7, 123456.78901234567, -math.e * 1e-20):
        y = tidy_float(x)
        assert abs(y - x) <= 2e-13 * abs(x)
        assert float(f"{y:.15g}") == y  # at most 15 significant digits
    assert tidy({"a": [float("nan"), 1.0000000000000002, True, 3], "b": "x"}) == {"a": [None, 1.0, True, 3],
                                                                                 "b": "x"}


def test_solve_json_is_rounded(tmp_path):
    out = tmp_path / "s"
    assert main(["solve", "--preset", "fig3a_L20", "--steps", "3", "--no-plot", "--out", str(out)]) == 0
    data = json.loads((out / "solve_fig3a_L20.json").read_text())

    def floats(obj):
        if isinstance(obj, dict):
            for v in obj.values():
                yield from floats(v)
        elif isinstance(obj, list):
            for v in obj:
                yield from floats(v)
        elif isinstance(obj, float):
            yield obj

    values = list(floats(data))
    assert values and all(float(f"{v:.15g}") == v for v in values)  # at most 15 significant digits

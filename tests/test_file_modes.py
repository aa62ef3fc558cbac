"""Files the package writes are readable as the umask allows (not the private 0o600 of a temporary file)."""

from __future__ import annotations

import os
import stat

import pytest

import magsoft_env as ms
from magsoft_env.io import atomic_path, write_csv, write_json, write_text_atomic


@pytest.fixture
def umask():
    """Run the test under a chosen umask, restored afterwards."""
    old = os.umask(0o022)
    try:
        yield os.umask
    finally:
        os.umask(old)


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


def test_json_csv_text_and_robot_files_are_0644_under_umask_022(tmp_path, umask):
    files = [write_json(tmp_path / "a.json", {"x": 1}), write_csv(tmp_path / "a.csv", [{"x": 1.0}]),
             write_text_atomic(tmp_path / "a.yml", "x: 1\n")]
    robot = ms.Robot("strip", ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=ms.alternating_cells(2)))
    files.append(robot.save(tmp_path / "robot.yml"))
    files.append(robot.save(tmp_path / "robot.json"))
    for f in files:
        assert _mode(f) == 0o644, f
    assert not list(tmp_path.glob(".*"))  # no temporary file left


def test_png_figure_is_0644_under_umask_022(tmp_path, umask):
    from matplotlib.figure import Figure

    from magsoft_env.render.figures import save_figure

    fig = Figure(figsize=(1, 1))
    assert _mode(save_figure(fig, tmp_path / "f.png")) == 0o644


def test_mode_follows_the_umask(tmp_path, umask):
    umask(0o077)
    assert _mode(write_json(tmp_path / "private.json", {})) == 0o600
    umask(0o002)
    assert _mode(write_json(tmp_path / "group.json", {})) == 0o664


def test_failed_write_leaves_nothing(tmp_path):
    with pytest.raises(RuntimeError), atomic_path(tmp_path / "x.json") as tmp:
        tmp.write_text("half")
        raise RuntimeError("interrupted")
    assert list(tmp_path.iterdir()) == []

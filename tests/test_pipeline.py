"""The whole pipeline of docs/examples/pipeline.py with tiny budgets: design, save, check, gait, PPO, video."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

import magsoft_env as ms

SCRIPT = Path(__file__).resolve().parents[1] / "docs" / "examples" / "pipeline.py"


@pytest.mark.slow
def test_pipeline_designs_saves_checks_trains_and_renders(tmp_path):
    out = subprocess.run([sys.executable, str(SCRIPT), "--out", str(tmp_path), "--timesteps", "128", "--seconds",
                          "0.6", "--starts", "1", "--nfev", "8"], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    for step in ("1. design", "2. saved", "3. MuJoCo check", "4. open-loop gait", "5. trained PPO", "6. video"):
        assert step in out.stdout
    robot = ms.load_robot(tmp_path / "robot.yml")
    assert robot.drive is not None and robot.name == "ball-crawler"
    assert (tmp_path / "ppo_ball_crawler.zip").stat().st_size > 0
    assert (tmp_path / "ball_crawler.mp4").stat().st_size > 10_000
    summary = json.loads((tmp_path / "pipeline.json").read_text())
    assert summary["mujoco_max_to_analytical_mm"] < 0.5  # the rod reproduces the design (0.013 mm measured)

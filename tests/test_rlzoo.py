"""rl-zoo3's own command line on every floor env with train/hyperparams.yml, and train/ end to end (tiny budgets)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rl_zoo3")

ROOT = Path(__file__).resolve().parents[1]
FLOOR_ENVS = ["MagSoftCrawl-v1", "MagSoftCrawlWaveform-v1", "MagSoftChannel-v1", "MagSoftObstacle-v1"]


@pytest.mark.slow
@pytest.mark.parametrize("env_id", FLOOR_ENVS)
def test_rl_zoo_trains_every_floor_env_from_the_shipped_file(tmp_path, env_id):
    n = 32 if "Waveform" in env_id else 64  # a waveform step is a whole field period (0.25-1 s simulated)
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", env_id, "--gym-packages", "magsoft_env",
           "-conf", str(ROOT / "train" / "hyperparams.yml"), "-n", str(n), "--eval-freq", str(n),
           "--eval-episodes", "1", "--hyperparams", f"n_steps:{n // 2}", f"batch_size:{n // 2}", "n_epochs:1",
           "-f", str(tmp_path), "--seed", "0", "--num-threads", "1", "--device", "cpu"]
    # rl-zoo3 2.9.2 builds its evaluation env without the file's env_kwargs (docs/training.md): the channel and
    # obstacle blocks train at fidelity "fast", whose observation differs from the robots' own numerics, so the
    # evaluation env gets the block's env_kwargs as train.py passes them
    from magsoft_env.rl.hyperparams import load_hyperparams

    env_kwargs = load_hyperparams(ROOT / "train" / "hyperparams.yml", env_id).get("env_kwargs") or {}
    if "fidelity" in env_kwargs:
        cmd += ["--eval-env-kwargs", *(f"{k}:{v!r}" for k, v in env_kwargs.items())]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "total_timesteps" in r.stdout and f"Eval num_timesteps={n}" in r.stdout
    log = tmp_path / "ppo" / f"{env_id}_1"
    assert (log / f"{env_id}.zip").is_file() and (log / "best_model.zip").is_file()
    with np.load(log / "evaluations.npz") as data:
        assert data["timesteps"].tolist() == [n] and data["ep_lengths"].shape == (1, 1)
    from magsoft_env.rl import find_run, load_policy

    rec = find_run(tmp_path)  # rl-zoo's -f folder holds this one run
    assert rec.env_id == env_id and rec.env_kwargs == env_kwargs  # the file's (none: the registered task)
    load_policy(rec.final_model, env=env_id)  # the spaces fit the env it was trained on (its recorded kwargs)


@pytest.mark.slow
def test_train_then_evaluate_against_the_open_loop_gaits(tmp_path):
    cmd = [sys.executable, str(ROOT / "train" / "train.py"), "--env", "MagSoftCrawl-v1", "--runs", str(tmp_path),
           "--run-id", "t", "--timesteps", "128", "--set", "n_steps=64", "batch_size=32", "n_epochs=2",
           "--env-kwarg", "segments=6", "--eval-freq", "64", "--eval-episodes", "1", "--max-minutes", "5"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    run = tmp_path / "t"
    summary = json.loads((run / "evaluation.json").read_text())
    assert summary["env_id"] == "MagSoftCrawl-v1" and summary["env_kwargs"]["segments"] == 6
    assert summary["model_timesteps"] == 128 and summary["curve"]["eval_timesteps"] == [64, 128]
    assert [g["name"] for g in summary["open_loop"]] == ["open-loop paper-5c", "open-loop paper-5c --reverse"]
    assert summary["policy"]["episode_s"] > 0 and summary["train_wall_s"] > 0
    assert (run / "learning_curve.png").is_file()
    hyper = (run / "hyperparams.yml").read_text()
    assert "magsoft_env.rl.callbacks.WallTimeLimit" in hyper  # --max-minutes, in the resolved settings
    # re-evaluate the best model at half the timestep, into tagged files
    r = subprocess.run([sys.executable, str(ROOT / "train" / "evaluate.py"), str(run), "--episodes", "1", "--best",
                        "--env-kwarg", "sim_dt=1e-4", "--tag", "dt1e-4"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-3000:]
    again = json.loads((run / "evaluation_dt1e-4.json").read_text())
    assert again["env_kwargs"]["sim_dt"] == 1e-4 and again["model"].endswith("best_model.zip")
    # continue training into a new run (the old one is left alone)
    cont = [*cmd[:7], "t2", "--continue-from", str(run), *cmd[8:], "--no-eval"]
    r = subprocess.run(cont, capture_output=True, text=True, timeout=300, cwd=tmp_path)
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Loading pretrained agent" in r.stdout and (tmp_path / "t2" / "ppo" / "MagSoftCrawl-v1_1").is_dir()

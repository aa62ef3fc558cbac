"""Hyperparameter search on a shared Optuna study (train/train.py --optimize, rl-zoo3 -optimize): two workers,
one study, its trial budget finished together; a dead worker's RUNNING trial marked FAIL."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# a worker: train/train.py with rl-zoo3's PPO sampler cut down to tiny trials (the sampler's n_steps reach 4096)
_WORKER = textwrap.dedent("""
    import sys
    import rl_zoo3.hyperparams_opt as opt

    def tiny(trial, n_actions, n_envs, additional_args):
        return {"n_steps": 16, "batch_size": 16, "n_epochs": 1,
                "learning_rate": trial.suggest_float("learning_rate", 1e-4, 1e-2, log=True)}

    opt.HYPERPARAMS_SAMPLER["ppo"] = tiny
    sys.path.insert(0, TRAIN)
    import train

    sys.exit(train.main(sys.argv[1:]))
""")


def _args(tmp_path, run_id, storage):
    return ["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path / "runs"), "--run-id", run_id, "--optimize",
            "--storage", storage, "--study-name", "crawl", "--max-total-trials", "4", "--timesteps", "32",
            "--n-evaluations", "1", "--eval-episodes", "1", "--n-startup-trials", "2", "--sampler", "random",
            "--pruner", "none", "--env-kwarg", "segments=6", "--vec", "dummy"]


@pytest.mark.slow
def test_two_workers_share_one_study_and_its_budget(tmp_path):
    pytest.importorskip("rl_zoo3")
    import optuna

    from magsoft_env.rl import fail_stale_trials

    script = tmp_path / "worker.py"
    script.write_text(_WORKER.replace("TRAIN", repr(str(ROOT / "train"))))
    storage = f"sqlite:///{tmp_path / 'study.db'}"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    procs = [subprocess.Popen([sys.executable, str(script), *_args(tmp_path, f"w{i}", storage)], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) for i in range(2)]
    outs = [p.communicate(timeout=240)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], "\n".join(o[-3000:] for o in outs)
    study = optuna.load_study(study_name="crawl", storage=storage)
    trials = study.get_trials()
    assert sum(t.state == optuna.trial.TrialState.COMPLETE for t in trials) == 4  # the budget, not 4 each
    workers = [json.loads((tmp_path / "runs" / f"w{i}" / "tune.json").read_text()) for i in range(2)]
    assert all(w["trials"]["COMPLETE"] >= 1 for w in workers)
    assert "--eval-env-kwargs segments:6" in (tmp_path / "runs" / "w0" / "zoo_command.txt").read_text()

    # a worker killed mid-trial leaves it RUNNING (counted against the budget) until marked FAIL
    stale = study.ask()
    assert fail_stale_trials(storage, "crawl", older_than_s=3600) == []
    assert fail_stale_trials(storage, "crawl", older_than_s=0) == [stale.number]
    assert study.get_trials()[-1].state == optuna.trial.TrialState.FAIL


def test_search_flags_go_with_optimize(tmp_path, capsys):
    sys.path.insert(0, str(ROOT / "train"))
    try:
        import train
    finally:
        sys.path.remove(str(ROOT / "train"))
    args = ["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path), "--run-id", "r"]
    assert train.main([*args, "--storage", "sqlite:///x.db"]) == 2
    assert "--storage goes with --optimize" in capsys.readouterr().err
    assert train.main([*args, "--fail-stale-trials", "30"]) == 2
    assert "needs --storage and --study-name" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()

"""Hyperparameter search on a shared Optuna study (train/train.py --optimize, rl-zoo3 -optimize): two workers,
one study, its trial budget finished together, each drawing its own trials; a single worker reproduced by its
seed; a dead worker's RUNNING trial marked FAIL by the documented command, which refuses a storage or study that
is not there."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from magsoft_env.rl import optuna_storage

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
            "--n-evaluations", "1", "--eval-episodes", "1", "--n-startup-trials", "2", "--pruner", "none",
            "--env-kwarg", "segments=6", "--vec", "dummy"]


@pytest.mark.slow
def test_two_workers_sample_their_own_trials_of_one_study(tmp_path):
    pytest.importorskip("rl_zoo3")
    import optuna

    script = tmp_path / "worker.py"
    script.write_text(_WORKER.replace("TRAIN", repr(str(ROOT / "train"))))
    storage = str(tmp_path / "study.log")  # a journal file, as on a shared file system
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    # both with the default --seed 0 and the default sampler (TPE), as the documented loop runs them
    procs = [subprocess.Popen([sys.executable, str(script), *_args(tmp_path, f"w{i}", storage)], env=env,
                              stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True) for i in range(2)]
    outs = [p.communicate(timeout=300)[0] for p in procs]
    assert [p.returncode for p in procs] == [0, 0], "\n".join(o[-3000:] for o in outs)
    study = optuna.load_study(study_name="crawl", storage=optuna_storage(storage))
    trials = study.get_trials()
    assert sum(t.state == optuna.trial.TrialState.COMPLETE for t in trials) == 4  # the budget, not 4 each
    params = [t.params["learning_rate"] for t in trials]
    assert len(set(params)) == len(params), f"two trials with the same hyperparameters: {params}"
    workers = [json.loads((tmp_path / "runs" / f"w{i}" / "tune.json").read_text()) for i in range(2)]
    assert all(w["trials"]["COMPLETE"] >= 1 for w in workers)
    assert [w["seed"] for w in workers] == [0, 0]  # the training seed, as given
    assert [w["sampler_seed_from"] for w in workers] == ["drawn", "drawn"]
    assert workers[0]["sampler_seed"] != workers[1]["sampler_seed"]
    for i, w in enumerate(workers):
        assert f"tune: sampler seed {w['sampler_seed']} (drawn;" in outs[i]
    assert "--eval-env-kwargs segments:6" in (tmp_path / "runs" / "w0" / "zoo_command.txt").read_text()


def _train_module():
    sys.path.insert(0, str(ROOT / "train"))
    try:
        import train
    finally:
        sys.path.remove(str(ROOT / "train"))
    return train


def test_search_flags_go_with_optimize(tmp_path, capsys):
    train = _train_module()
    args = ["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path), "--run-id", "r"]
    assert train.main([*args, "--storage", "sqlite:///x.db"]) == 2
    assert "--storage goes with --optimize" in capsys.readouterr().err
    assert train.main([*args, "--sampler-seed", "3"]) == 2
    assert "--sampler-seed goes with --optimize" in capsys.readouterr().err
    assert train.main([*args, "--fail-stale-trials", "30"]) == 2
    assert "needs --storage and --study-name" in capsys.readouterr().err
    assert train.main(["--runs", str(tmp_path), "--run-id", "r", "--optimize"]) == 2
    assert "--env is required" in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def _study_left_by_a_killed_worker(storage: str):
    """A study of one complete trial and one RUNNING trial (its worker killed)."""
    import optuna

    study = optuna.create_study(study_name="crawl", storage=optuna_storage(storage), direction="maximize")
    done = study.ask()
    done.suggest_float("learning_rate", 1e-4, 1e-2, log=True)
    study.tell(done, 1.0)
    study.ask().suggest_float("learning_rate", 1e-4, 1e-2, log=True)
    return study


@pytest.mark.parametrize("kind", ["journal", "sqlite"])
def test_fail_stale_trials_command_marks_a_killed_workers_trial_fail(tmp_path, kind):
    import optuna

    storage = str(tmp_path / "study.log") if kind == "journal" else f"sqlite:///{tmp_path / 'study.db'}"
    study = _study_left_by_a_killed_worker(storage)
    env = {**os.environ, "PYTHONPATH": str(ROOT)}

    def command(minutes):  # as documented: no --env
        return subprocess.run([sys.executable, str(ROOT / "train" / "train.py"), "--fail-stale-trials", minutes,
                               "--storage", storage, "--study-name", "crawl"], env=env, capture_output=True,
                              text=True, timeout=120)

    young = command("60")
    assert young.returncode == 0, young.stderr
    assert young.stdout.strip().splitlines()[-1] == "study 'crawl': 0 trials RUNNING for 60 min or more marked FAIL"
    assert [t.state for t in study.get_trials()][-1] == optuna.trial.TrialState.RUNNING
    stale = command("0")
    assert stale.returncode == 0, stale.stderr
    assert stale.stdout.strip().splitlines()[-1] == \
        "study 'crawl': 1 trial RUNNING for 0 min or more marked FAIL (number 1)"
    assert [t.state for t in study.get_trials()] == [optuna.trial.TrialState.COMPLETE, optuna.trial.TrialState.FAIL]


@pytest.mark.parametrize("storage, message", [
    ("STUDY_LOG", "has no study 'crawll'; its studies: 'crawl'. Did you mean 'crawl'?"),
    ("missing.log", "journal file 'TMP/missing.log' does not exist"),
    ("sqlite:///TMP/missing.db", "SQLite file 'TMP/missing.db' of 'sqlite:///TMP/missing.db' does not exist"),
    ("nosuchdb://user:secret@host/db", "cannot open the study storage 'nosuchdb://user:***@host/db'"),
])
def test_fail_stale_trials_refuses_a_storage_or_study_that_is_not_there(tmp_path, capsys, storage, message):
    train = _train_module()
    _study_left_by_a_killed_worker(str(tmp_path / "study.log"))
    storage = storage.replace("STUDY_LOG", str(tmp_path / "study.log")).replace("TMP", str(tmp_path))
    if storage == "missing.log":
        storage = str(tmp_path / storage)
    name = "crawll" if storage.endswith("study.log") else "crawl"
    assert train.main(["--fail-stale-trials", "0", "--storage", storage, "--study-name", name]) == 2
    err = capsys.readouterr().err
    assert message.replace("TMP", str(tmp_path)) in err
    assert "secret" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study.log"]  # nothing created


def _tiny_search(monkeypatch, tmp_path, run_id, *extra):
    """train/train.py --optimize in this process, no storage (a study of its own), two tiny trials; returns the
    hyperparameters its sampler drew, trial by trial, and its tune.json."""
    pytest.importorskip("rl_zoo3")
    import rl_zoo3.hyperparams_opt as opt

    drawn = []

    def tiny(trial, n_actions, n_envs, additional_args):
        drawn.append(trial.suggest_float("learning_rate", 1e-4, 1e-2, log=True))
        return {"n_steps": 16, "batch_size": 16, "n_epochs": 1, "learning_rate": drawn[-1]}

    monkeypatch.setitem(opt.HYPERPARAMS_SAMPLER, "ppo", tiny)
    args = ["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path / "runs"), "--run-id", run_id, "--optimize",
            "--n-trials", "2", "--timesteps", "32", "--n-evaluations", "1", "--eval-episodes", "1", "--pruner", "none",
            "--env-kwarg", "segments=6", "--vec", "dummy", *extra]
    assert _train_module().main(args) == 0
    return drawn, json.loads((tmp_path / "runs" / run_id / "tune.json").read_text())


def test_a_single_worker_search_is_reproduced_by_its_seed(tmp_path, monkeypatch):
    import optuna

    first, record = _tiny_search(monkeypatch, tmp_path, "a", "--seed", "3")
    again, _ = _tiny_search(monkeypatch, tmp_path, "b", "--seed", "3")
    assert first == again and len(set(first)) == 2
    assert (record["seed"], record["sampler_seed"], record["sampler_seed_from"]) == (3, 3, "--seed")
    # rl-zoo3's own sampler seeded with --seed (TPE's first trials are its random sampler's): as before this change
    expected = optuna.samplers.RandomSampler(seed=3)
    study = optuna.create_study(sampler=expected)
    assert [study.ask().suggest_float("learning_rate", 1e-4, 1e-2, log=True) for _ in range(2)] == first
    # another training seed, the sampler's seed given: the same hyperparameters drawn
    given, record = _tiny_search(monkeypatch, tmp_path, "c", "--seed", "4", "--sampler-seed", "3")
    assert given == first
    assert (record["seed"], record["sampler_seed"], record["sampler_seed_from"]) == (4, 3, "given")

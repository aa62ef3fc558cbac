"""RL helpers and the train/ command line (fast: checks before any work, one 64-step run)."""

from __future__ import annotations

import importlib
import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from magsoft_env.rl import load_hyperparams, open_loop_actor, run_episodes

ROOT = Path(__file__).resolve().parents[1]
PPO_FILE = ROOT / "train" / "hyperparams.yml"
SAC_FILE = ROOT / "train" / "hyperparams_sac.yml"


def _script(name: str):
    spec = importlib.util.spec_from_file_location(f"train_{name}", ROOT / "train" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


# ---------------------------------------------------------------------------- hyperparameter files
def test_hyperparams_env_block_else_default_with_merge_keys(tmp_path):
    f = tmp_path / "h.yml"
    f.write_text(
        "default: &d\n  n_timesteps: 100\n  policy: MlpPolicy\n  n_envs: 2\n  learning_rate: 0.001\n"
        "  n_steps: 8\n  env_kwargs: {segments: 10}\n"
        "MagSoftCrawl-v1:\n  <<: *d\n  n_steps: 16\n  env_kwargs: {robot: paper-5a}\n"
    )
    cfg = load_hyperparams(f, "MagSoftCrawl-v1", "ppo")
    assert cfg == {"n_timesteps": 100, "policy": "MlpPolicy", "n_envs": 2, "learning_rate": 0.001, "n_steps": 16,
                   "env_kwargs": {"robot": "paper-5a"}}  # rl-zoo: one block, merged one level deep
    other = load_hyperparams(f, "MagSoftShape-v0", "ppo")  # registered id without its own block
    assert other["env_kwargs"] == {"segments": 10} and other["n_steps"] == 8


def test_shipped_hyperparams_are_what_rl_zoo_reads():
    pytest.importorskip("rl_zoo3")
    import argparse

    from rl_zoo3.exp_manager import ExperimentManager

    from magsoft_env.envs import ENV_SPECS

    for algo, path in (("ppo", PPO_FILE), ("sac", SAC_FILE)):
        for env_id in ENV_SPECS:
            ours = load_hyperparams(path, env_id, algo)
            zoo = ExperimentManager(argparse.Namespace(), algo, env_id, "/nonexistent", config=str(path))
            theirs, _ = zoo.read_hyperparameters()
            assert ours == dict(theirs), (algo, env_id)
            assert ours["n_timesteps"] >= 1


#: Constructor arguments that choose how a task is simulated or shown, not the task itself.
NUMERICS = {"fidelity", "segments", "sim_dt", "render_mode", "width", "height"}


def test_shipped_hyperparams_train_the_registered_task_of_their_id():
    import inspect

    import gymnasium as gym

    from magsoft_env.envs import ENV_SPECS

    for algo, path in (("ppo", PPO_FILE), ("sac", SAC_FILE)):
        for env_id in ENV_SPECS:
            spec = gym.spec(env_id)
            cls = spec.entry_point.split(":")
            cls = getattr(importlib.import_module(cls[0]), cls[1])
            defaults = {}
            for klass in reversed(cls.__mro__):
                init = klass.__dict__.get("__init__")
                if init is not None:
                    defaults.update({n: p.default for n, p in inspect.signature(init).parameters.items()
                                     if p.default is not inspect.Parameter.empty})
            defaults.update(spec.kwargs)
            for key, value in (load_hyperparams(path, env_id, algo).get("env_kwargs") or {}).items():
                assert key in NUMERICS or value == defaults.get(key, object()), (
                    f"{path.name}: {env_id}'s env_kwargs set {key}={value!r}, a task its id registers as "
                    f"{defaults.get(key)!r}")


def test_hyperparams_refuse_yaml_exponent_strings(tmp_path):
    # YAML 1.1 (rl-zoo3's reader) reads 2e-3 (no dot) as a string and would hand the env a string
    f = tmp_path / "h.yml"
    f.write_text("default:\n  n_timesteps: 10\n  policy: MlpPolicy\n  env_kwargs: {field_limit: 2e-3}\n")
    with pytest.raises(ValueError, match=r"field_limit = '2e-3' is a string in YAML 1\.1.*0\.002"):
        load_hyperparams(f, "MagSoftCrawl-v1", "ppo")


def test_hyperparams_errors(tmp_path):
    with pytest.raises(ValueError, match="Did you mean 'MagSoftCrawl-v[12]'"):
        load_hyperparams(PPO_FILE, "MagSoftCrawl-v9", "ppo")
    with pytest.raises(ValueError, match="algo must be one of .*got 'ppp'.* Did you mean 'ppo'"):
        load_hyperparams(PPO_FILE, "MagSoftCrawl-v1", "ppp")
    f = tmp_path / "h.yml"
    f.write_text("default:\n  n_timesteps: 10\n  policy: MlpPolicy\n  learnin_rate: 0.001\n")
    with pytest.raises(ValueError, match="unknown PPO hyperparameter 'learnin_rate'. Did you mean 'learning_rate'"):
        load_hyperparams(f, "MagSoftCrawl-v1", "ppo")
    f.write_text("default:\n  n_timesteps: 10\n  policy: MlpPolicy\n  policy_kwargs: {net_ach: [8]}\n")
    with pytest.raises(ValueError, match="policy_kwargs key 'net_ach'. Did you mean 'net_arch'"):
        load_hyperparams(f, "MagSoftCrawl-v1", "ppo")
    f.write_text("default:\n  n_timesteps: 10\n  policy: MlpPolicy\n  env_kwargs: {fieldlimit: 0.004}\n")
    with pytest.raises(ValueError, match="no argument 'fieldlimit'. Did you mean 'field_limit'"):
        load_hyperparams(f, "MagSoftChannel-v1", "ppo")
    f.write_text("default:\n  n_timesteps: 0\n  policy: MlpPolicy\n")
    with pytest.raises(ValueError, match="n_timesteps must be a whole number >= 1, got 0"):
        load_hyperparams(f, "MagSoftCrawl-v1", "ppo")
    f.write_text("MagSoftShape-v0:\n  n_timesteps: 10\n")
    with pytest.raises(ValueError, match="no block for 'MagSoftCrawl-v1' and no 'default' block"):
        load_hyperparams(f, "MagSoftCrawl-v1", "ppo")


def test_zoo_argv_gives_the_eval_env_the_files_env_kwargs():
    # rl-zoo3 2.9.2 builds the evaluation env from the command line's env kwargs only
    from magsoft_env.rl import zoo_argv

    argv = zoo_argv("MagSoftCrawl-v1", "h.yml", "runs/x", eval_env_kwargs={"robot": "paper-5c", "segments": 6})
    k = argv.index("--eval-env-kwargs")
    assert argv[k + 1:k + 3] == ["robot:'paper-5c'", "segments:6"]
    assert "--eval-env-kwargs" not in zoo_argv("MagSoftCrawl-v1", "h.yml", "runs/x")


# ---------------------------------------------------------------------------- episodes
def test_open_loop_gait_in_the_env_matches_its_definition():
    import gymnasium as gym

    env = gym.make("MagSoftCrawl-v1", segments=6, robot="paper-5c")
    env = gym.wrappers.TimeLimit(env.unwrapped, max_episode_steps=5)
    res = run_episodes(env, open_loop_actor(), episodes=1)
    assert res.episode_seconds == pytest.approx(0.1)
    assert np.isfinite(res.speed) and res.crawl_violations == 0


def test_run_episodes_name_the_gait_crawl_hop_or_tumble():
    import gymnasium as gym

    from magsoft_env.rl import locomotion_mode

    env = gym.make("MagSoftCrawl-v1", segments=6)  # paper-5c's gait at 6 segments stays on the floor too
    res = run_episodes(env, open_loop_actor(), episodes=1, seed=0, name="open loop")
    assert res.locomotion == "crawl" and res.airborne_fraction == 0.0 and res.crawl_violations == 0
    assert res.to_dict()["locomotion"] == "crawl" and res.to_dict()["highest_clearance_mm"] < 0.01
    # a beam thrown off the floor at 4 mT (tests/test_envs.py::HOP_ACTIONS), tumbling allowed
    hop = gym.make("MagSoftCrawl-v1", field_limit=0.004, crawl_mode="none", max_clearance=None,
                   max_episode_steps=3)
    actions = iter([(0.0, -1.0), (1.0, 0.0), (0.0, 1.0)])
    res = run_episodes(hop, lambda obs, e: np.array(next(actions), dtype=np.float32), episodes=1, name="hop")
    assert res.locomotion == "hop" and 0.0 < res.airborne_fraction < 1.0 and res.highest_clearance > 2.5e-3
    assert [locomotion_mode(1e-3, 0.0, 2.5), locomotion_mode(0.0, 0.0, 0.1), locomotion_mode(1e-3, 0.0, 0.1)] == \
        ["tumble", "still", "crawl"]
    assert locomotion_mode(1e-3, float("nan"), float("nan")) == ""  # the shape env reports neither


def test_run_episodes_counts_successes_and_their_times():
    import gymnasium as gym

    class Reach(gym.Env):  # succeeds at step 3 when reset with an even seed, else runs out at step 5
        observation_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        action_space = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)

        def reset(self, *, seed=None, options=None):
            self.k, self.even = 0, seed % 2 == 0
            return np.zeros(1, np.float32), {"time": 0.0, "x_position": 0.0}

        def step(self, action):
            self.k += 1
            done = self.even and self.k == 3
            info = {"time": 0.1 * self.k, "x_position": 0.001 * self.k, "is_success": done}
            return np.zeros(1, np.float32), 1.0, done, self.k == 5 and not done, info

    res = run_episodes(Reach(), lambda obs, env: np.zeros(1, np.float32), episodes=3, seed=0)
    assert (res.successes, res.success_seconds) == (2, pytest.approx(0.3))
    assert res.to_dict()["successes"] == 2 and res.to_dict()["success_s"] == pytest.approx(0.3)
    none = run_episodes(Reach(), lambda obs, env: np.zeros(1, np.float32), episodes=1, seed=1)
    assert none.successes == 0 and none.to_dict()["success_s"] is None


# ---------------------------------------------------------------------------- policies and the env they play in
def _untrained(env_id: str, folder: Path, **env_kwargs) -> Path:
    """An untrained PPO model saved in an rl-zoo3-like log folder (``<env>/args.yml`` beside it)."""
    import gymnasium as gym
    import yaml
    from stable_baselines3 import PPO

    env = gym.make(env_id, **env_kwargs)
    model = PPO("MlpPolicy", env, n_steps=16, batch_size=16, device="cpu")
    (folder / env_id).mkdir(parents=True)
    (folder / env_id / "args.yml").write_text(yaml.safe_dump({"algo": "ppo", "env": env_id, "env_kwargs": env_kwargs}))
    model.save(folder / f"{env_id}.zip")
    env.close()
    return folder / f"{env_id}.zip"


def test_policy_refused_in_another_env(tmp_path):
    from magsoft_env.rl import load_policy

    path = _untrained("MagSoftCrawl-v1", tmp_path / "crawl", segments=6)
    policy = load_policy(path, env="MagSoftCrawl-v1")  # made with the run's env_kwargs (6 segments)
    assert policy.env_id == "MagSoftCrawl-v1" and policy.env_kwargs == {"segments": 6}
    action = policy(np.zeros(2 * 7 + 6, dtype=np.float32))
    assert action.shape == (2,) and np.all(np.abs(action) <= 1.0)
    with pytest.raises(ValueError, match="was trained on MagSoftCrawl-v1, not MagSoftChannel-v1"):
        load_policy(path, env="MagSoftChannel-v1")
    with pytest.raises(ValueError, match=r"observation space is Box.*\(20,\).*\(48,\)"):
        load_policy(path, env="MagSoftCrawl-v1", env_kwargs={})  # 20 segments: another observation
    (tmp_path / "bare").mkdir()
    bare = tmp_path / "bare" / "model.zip"  # no run recorded: the spaces are still checked
    path.rename(bare)
    with pytest.raises(ValueError, match="does not fit MagSoftShape-v0"):
        load_policy(bare, env="MagSoftShape-v0")


# ---------------------------------------------------------------------------- train/train.py
def test_train_refuses_an_existing_run_id_before_any_work(tmp_path, capsys):
    (tmp_path / "taken").mkdir()
    (tmp_path / "taken" / "keep.txt").write_text("an earlier run")
    rc = _script("train").main(["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path), "--run-id", "taken"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "exists already; a run is never overwritten" in err and "another --run-id" in err
    assert sorted(p.name for p in (tmp_path / "taken").iterdir()) == ["keep.txt"]


def test_train_refuses_an_unknown_vec_before_any_work(tmp_path):
    from magsoft_env.rl import load_hyperparams, train

    block = load_hyperparams(ROOT / "train" / "hyperparams.yml", "MagSoftCrawl-v1")
    with pytest.raises(ValueError, match="vec must be one of threads, dummy, subproc, warp, got 'gpu'"):
        train(block, "MagSoftCrawl-v1", tmp_path / "r", vec="gpu")
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize("option, item, message", [
    ("--set", "learnin_rate=1e-3", "unknown PPO hyperparameter 'learnin_rate'. Did you mean 'learning_rate'"),
    ("--set", "n_step=64", "Did you mean 'n_steps'"),
    ("--env-kwarg", "fieldlimit=0.004", "MagSoftCrawl-v1 has no argument 'fieldlimit'. Did you mean 'field_limit'"),
    ("--env-kwarg", "field_limit=0.5", "field_limit must be <= 0.1 T"),
    ("--set", "learning_rate", "--set expects KEY=VALUE"),
])
def test_train_misspelt_overrides_get_suggestions(tmp_path, capsys, option, item, message):
    rc = _script("train").main(["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path), "--run-id", "r", option, item])
    assert rc == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "r").exists()


def test_train_runs_rl_zoo_prints_progress_and_refuses_a_second_run(tmp_path, capsys):
    pytest.importorskip("rl_zoo3")
    train = _script("train")
    args = ["--env", "MagSoftCrawl-v1", "--runs", str(tmp_path), "--run-id", "t", "--timesteps", "64",
            "--set", "n_steps=32", "batch_size=32", "n_epochs=1", "--env-kwarg", "segments=6",
            "--eval-freq", "64", "--eval-episodes", "1", "--no-eval"]
    assert train.main(args) == 0
    out = capsys.readouterr().out
    assert "python -m rl_zoo3.train --algo ppo --env MagSoftCrawl-v1 --gym-packages magsoft_env" in out
    assert "total_timesteps" in out and "Eval num_timesteps=64" in out  # log tables, evaluation callback
    assert "[envs on threads: ThreadedVecEnv]" in out  # the default --vec threads
    from rl_zoo3.exp_manager import ExperimentManager

    assert ExperimentManager.default_vec_env_cls is None  # rl-zoo's hook is restored after the run
    run = tmp_path / "t"
    assert (run / "zoo_command.txt").read_text().startswith("# stepped by magsoft_env.rl.ThreadedVecEnv")
    assert json.loads((run / "train.json").read_text())["vec"] == "threads"
    log = run / "ppo" / "MagSoftCrawl-v1_1"
    for p in ("hyperparams.yml", "zoo_command.txt", "train.json"):
        assert (run / p).is_file(), p
    for p in ("MagSoftCrawl-v1.zip", "best_model.zip", "evaluations.npz", "MagSoftCrawl-v1/args.yml",
              "MagSoftCrawl-v1/config.yml", "MagSoftCrawl-v1/vecnormalize.pkl"):
        assert (log / p).is_file(), p
    from magsoft_env.rl import find_run, learning_curve

    rec = find_run(run)
    assert rec.log_dir == log and rec.env_id == "MagSoftCrawl-v1" and rec.algo == "ppo"
    assert rec.env_kwargs == {"segments": 6}  # the override (the file trains the registered task: no env_kwargs)
    assert rec.args["eval_env_kwargs"] == rec.env_kwargs  # the evaluation callback played the same env
    curve = learning_curve(rec, tmp_path / "c.png")
    assert curve["eval_timesteps"] == [64] and curve["eval_mean_ep_length"][0] > 0
    assert (tmp_path / "c.png").is_file()
    assert json.loads((run / "train.json").read_text())["wall_s"] > 0
    assert train.main(args) == 2  # the same run id again
    assert "exists already" in capsys.readouterr().err


def test_policy_of_a_run_before_rl_zoo_loads_and_is_checked(tmp_path):
    import yaml

    from magsoft_env.rl import load_policy

    path = _untrained("MagSoftCrawl-v1", tmp_path / "zoo", segments=6)
    (tmp_path / "old").mkdir()
    old = tmp_path / "old" / "model.zip"  # train/train.py's former layout: config.yml with env_id beside
    path.rename(old)
    (tmp_path / "old" / "config.yml").write_text(yaml.safe_dump(
        {"env_id": "MagSoftCrawl-v1", "algo": "ppo", "env_kwargs": {"segments": 6}}))
    assert load_policy(old, env="MagSoftCrawl-v1").env_kwargs == {"segments": 6}
    with pytest.raises(ValueError, match="was trained on MagSoftCrawl-v1, not MagSoftObstacle-v1"):
        load_policy(old, env="MagSoftObstacle-v1")

"""RL helpers and the train/ command line."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from magsoft_env.rl import load_hyperparams, open_loop_actor, run_episodes

ROOT = Path(__file__).resolve().parents[1]
HYPER = ROOT / "train" / "hyperparams.yml"


def test_hyperparams_merge_default_and_env_blocks(tmp_path):
    f = tmp_path / "h.yml"
    f.write_text(
        "default:\n  n_envs: 2\n  env_kwargs: {segments: 10}\n"
        "  ppo: {n_timesteps: 100, learning_rate: 0.001, n_steps: 8}\n"
        "MagSoftCrawl-v0:\n  env_kwargs: {robot: paper-5a}\n  ppo: {n_steps: 16}\n"
    )
    cfg = load_hyperparams(f, "MagSoftCrawl-v0", "ppo")
    assert cfg["env_kwargs"] == {"segments": 10, "robot": "paper-5a"}
    assert cfg["algo_kwargs"] == {"learning_rate": 0.001, "n_steps": 16}
    assert cfg["n_timesteps"] == 100 and cfg["n_envs"] == 2
    other = load_hyperparams(f, "MagSoftShape-v0", "ppo")  # registered id without its own block
    assert other["env_kwargs"] == {"segments": 10}


def test_hyperparams_read_yaml_exponent_strings_as_numbers(tmp_path):
    # YAML 1.1 reads 2e-3 (no dot) as a string; the simulator refuses strings for numbers
    f = tmp_path / "h.yml"
    f.write_text("default:\n  env_kwargs: {field_limit: 2e-3, robot: paper-5a}\n  ppo: {learning_rate: 3e-4}\n")
    cfg = load_hyperparams(f, "MagSoftCrawl-v0", "ppo")
    assert cfg["env_kwargs"] == {"field_limit": 2e-3, "robot": "paper-5a"}
    assert cfg["algo_kwargs"] == {"learning_rate": 3e-4}


def test_shipped_hyperparams_cover_every_id_and_algo():
    from magsoft_env.envs import ENV_SPECS

    for env_id in ENV_SPECS:
        for algo in ("ppo", "sac"):
            cfg = load_hyperparams(HYPER, env_id, algo)
            assert cfg["n_timesteps"] > 0


def test_hyperparams_errors():
    with pytest.raises(ValueError, match="Did you mean 'MagSoftCrawl-v0'"):
        load_hyperparams(HYPER, "MagSoftCrawl-v9", "ppo")
    with pytest.raises(ValueError, match="algo must be one of"):
        load_hyperparams(HYPER, "MagSoftCrawl-v0", "td3")


def test_open_loop_gait_in_the_env_matches_its_definition():
    import gymnasium as gym

    env = gym.make("MagSoftCrawl-v0", segments=6, robot="paper-5c")
    env = gym.wrappers.TimeLimit(env.unwrapped, max_episode_steps=5)
    res = run_episodes(env, open_loop_actor(), episodes=1)
    assert res.episode_seconds == pytest.approx(0.1)
    assert np.isfinite(res.speed) and res.crawl_violations == 0


@pytest.mark.slow
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


def test_ppo_cli_trains_saves_and_loads(tmp_path):
    cmd = [sys.executable, str(ROOT / "train" / "train.py"), "--env", "MagSoftCrawl-v0", "--algo", "ppo",
           "--timesteps", "2048", "--n-envs", "2", "--runs", str(tmp_path), "--run-id", "t", "--no-eval",
           "--env-kwarg", "segments=6", "--set", "n_steps=256", "batch_size=128", "n_epochs=2"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    run = tmp_path / "t"
    for name in ("config.yml", "model.zip", "vecnormalize.pkl", "learning_curve.png", "evaluation.json"):
        assert (run / name).exists(), name
    summary = json.loads((run / "evaluation.json").read_text())
    assert summary["n_timesteps"] == 2048 and summary["episodes"] > 0
    from magsoft_env.rl import load_policy

    policy = load_policy(run / "model.zip")
    action = policy(np.zeros(2 * 7 + 6, dtype=np.float32))
    assert action.shape == (2,) and np.all(np.abs(action) <= 1.0)

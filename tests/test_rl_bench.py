"""MagSoftBench v1 (magsoft_env.bench.rl_bench), the shipped agents (magsoft_env.rl.agents), ``magsoft replay`` and
``MagSoftCrawl-v2`` (the crawl limits as a penalty): fast checks (about a minute on one core)."""

import json
import math
import warnings

import numpy as np
import pytest

from magsoft_env.bench import rl_bench
from magsoft_env.rl.agents import agent_info, quiet_make, shipped_agents


def test_the_task_list_and_its_seeds_are_fixed():
    # a change of any of these is a new version of the benchmark (and of its stored table)
    assert (rl_bench.BENCH_NAME, rl_bench.BENCH_VERSION) == ("MagSoftBench", "v1")
    got = [(t.name, t.env_id, t.env_kwargs, t.seeds, t.steps, t.measure, t.gait, t.gait_reverse)
           for t in rl_bench.TASKS]
    assert got == [
        ("crawl-planar", "MagSoftCrawl-v1", {}, (1000, 1001, 1002), 250, "speed", "paper", True),
        ("crawl-planar-v2", "MagSoftCrawl-v2", {}, (1000, 1001, 1002), 250, "speed", "paper", True),
        ("crawl-strip", "MagSoftCrawl-v1", {"rod": "cable"}, (1000, 1001), 100, "speed", "paper", True),
        ("channel", "MagSoftChannel-v1", {"robot": "paper-5a", "fidelity": "fast"}, (1000, 1001), 250, "speed",
         "paper", False),
        ("obstacle", "MagSoftObstacle-v1", {"robot": "paper-5b", "fidelity": "fast"}, (1000, 1001), 250, "speed",
         "paper", False),
        ("steer", "MagSoftSteer-v0", {}, (1000, 1001, 1002, 1003), 250, "success", "hand", False),
        ("steer-waveform", "MagSoftSteerWaveform-v0", {"sim_dt": 4e-4}, (1000, 1001, 1002, 1003), 50, "success",
         "hand", False),
        ("coils", "MagSoftCoilsWaveform-v0", {"sim_dt": 4e-4}, (1000, 1001, 1002, 1003), 50, "success", "hand",
         False),
        ("magnet", "MagSoftMagnetWaveform-v0", {"sim_dt": 4e-4}, (1000, 1001, 1002, 1003), 50, "success", "hand",
         False),
    ]
    stored = rl_bench.load_table()
    assert stored["version"] == "v1"
    # every task and controller of the bench has a stored row, and nothing else
    want = {(t.name, c) for t in rl_bench.TASKS for c in rl_bench.controllers(t)}
    assert {(r["task"], r["controller"]) for r in stored["rows"]} == want
    with pytest.raises(ValueError, match="unknown task 'crawl-plannar'; did you mean 'crawl-planar'"):
        rl_bench.task_by_name("crawl-plannar")


def test_check_reproduces_a_shipped_agent_and_a_reference_controller(capsys):
    agent = shipped_agents()["MagSoftCrawl-v1"][0]
    rc = rl_bench.main(["--check", "--tasks", "crawl-planar", "--controllers", f"{agent},paper gait"])
    out = capsys.readouterr().out
    assert rc == 0, out
    assert "--check: 2 rows agree" in out and f"| crawl-planar | `MagSoftCrawl-v1` | {agent} |" in out


def test_check_fails_on_a_mismatch(tmp_path, capsys):
    stored = rl_bench.load_table()
    for r in stored["rows"]:
        if (r["task"], r["controller"]) == ("crawl-planar", "zero"):
            r["return_mean"] += 5.0
    bad = tmp_path / "table.json"
    bad.write_text(json.dumps(stored))
    rc = rl_bench.main(["--check", "--tasks", "crawl-planar", "--controllers", "zero", "--table", str(bad)])
    assert rc == 1
    assert "crawl-planar / zero: return_mean" in capsys.readouterr().out


def test_every_shipped_agent_loads_and_predicts_on_its_env():
    from magsoft_env.rl import load_agent

    agents = shipped_agents()
    assert len(agents.get("MagSoftCrawl-v1", [])) >= 3
    for env_id, names in agents.items():
        for name in names:
            info = agent_info(env_id, name)
            for key in ("env_id", "env_version", "env_kwargs", "algo", "seed", "hyperparameters", "model_timesteps",
                        "train_wall_s", "machine", "model"):
                assert key in info, (env_id, name, key)
            assert info["env_id"] == env_id
            policy = load_agent(env_id, name)
            env = quiet_make(env_id, **(policy.env_kwargs or {}))
            obs, _ = env.reset(seed=0)
            action = policy(obs)
            assert env.action_space.contains(np.asarray(action, dtype=env.action_space.dtype))
            env.close()


def test_load_agent_refuses_unknown_names_listing_the_shipped_ones():
    from magsoft_env.rl import load_agent

    with pytest.raises(ValueError, match=r"no agent 'ppo_sed0' is shipped for MagSoftCrawl-v1\. Did you mean "
                                         r"'ppo_seed0'\? Its agents: ppo_seed0"):
        load_agent("MagSoftCrawl-v1", "ppo_sed0")
    with pytest.raises(ValueError, match=r"no agent is shipped for env 'MagSoftCrawl-v9'.*Shipped agents: .*"
                                         r"MagSoftCrawl-v1: ppo_seed0"):
        load_agent("MagSoftCrawl-v9", "ppo_seed0")


def test_replay_prints_the_numbers_and_refuses_unknown_names(capsys):
    from magsoft_env.cli import main

    assert main(["replay", "--env", "MagSoftCrawl-v1", "--agent", "ppo_seed0", "--episodes", "1", "--steps", "20",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (ep,) = out["episodes"]
    assert ep["seed"] == 1000 and ep["steps"] == 20
    for key in ("speed_mm_s", "return", "airborne_fraction", "highest_clearance_mm", "locomotion"):
        assert key in ep
    assert math.isfinite(ep["speed_mm_s"]) and ep["locomotion"] in ("crawl", "hop", "roll", "tumble",
                                                                     "tumble with flight")
    assert main(["replay", "--env", "MagSoftCrawl-v1", "--agent", "ppo_seed0", "--episodes", "1", "--steps", "5"]) == 0
    text = capsys.readouterr().out
    assert "| seed | steps | speed (mm/s) | return | airborne fraction |" in text and "| 1000 | 5 |" in text
    assert main(["replay", "--env", "MagSoftCrawl-v1", "--agent", "sac_seed0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("magsoft replay: error: no agent 'sac_seed0' is shipped for MagSoftCrawl-v1.")
    assert "ppo_seed0" in err and len(err.splitlines()) == 1
    assert main(["replay", "--env", "MagSoftSteer-v9", "--agent", "ppo_seed0"]) == 2
    err = capsys.readouterr().err
    assert "Shipped agents: " in err and "MagSoftCrawl-v1: ppo_seed0" in err


def test_v2_random_episodes_last_at_least_50_steps():
    # the crawl limits charged, not ending the episode: v1's random episodes end within about 7 steps
    env = quiet_make("MagSoftCrawl-v2", segments=6)
    lengths, violations = [], []
    for k in range(3):
        env.reset(seed=100 + k)
        env.action_space.seed(k)
        n, done = 0, False
        while n < 80 and not done:
            _, _, term, trunc, info = env.step(env.action_space.sample())
            n, done = n + 1, term or trunc
        lengths.append(n)
        violations.append(info["crawl_violations"])
    assert np.mean(lengths) >= 50 and min(lengths) == 80
    assert sum(violations) > 0  # limits were broken, charged and counted


def test_v2_charges_a_broken_limit_and_forfeits_the_progress():
    env = quiet_make("MagSoftCrawl-v2", segments=6)
    env.reset(seed=0)
    env.action_space.seed(0)
    earned = 0.0
    for _ in range(200):
        _, r, term, trunc, info = env.step(env.action_space.sample())
        assert not term
        if info.get("crawl_violation"):
            assert info["reward_forward"] == 0.0
            assert info["reward_crawl"] == pytest.approx(-(10.0 + max(earned, 0.0)))
            earned = 0.0
            break
        earned += info["reward_forward"]
    else:
        pytest.fail("no crawl limit broken in 200 random steps")


def test_v1_is_unchanged():
    # main's v1 before v2 was added: the same seeded random rollout (episodes ended by the crawl limits)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        import gymnasium as gym

        env = gym.make("MagSoftCrawl-v1")
    env.action_space.seed(3)
    env.reset(seed=7)
    rewards, ends = [], []
    for i in range(30):
        _, r, term, trunc, info = env.step(env.action_space.sample())
        rewards.append(r)
        assert "crawl_violations" not in info
        if term or trunc:
            ends.append(i)
            env.reset()
    assert ends == [10]
    assert rewards == pytest.approx(V1_REWARDS, rel=1e-6, abs=1e-9)


#: ``MagSoftCrawl-v1`` at commit 4273cc0 (main, before v2), action_space.seed(3), reset(seed=7), 30 random steps
V1_REWARDS = [0.00023570929, -0.522847535, -0.816240015, 0.825985027, 8.28741919, -3.86411811, -3.11565349,
              -6.47230071, -8.30071741, 4.31091223, -10.1890707, -0.121788515, -0.667940287, -0.863952883,
              0.699514813, 0.557109881, -6.30367962, -3.17865764, 4.81366458, 7.7776811, -5.37162215, -6.6638329,
              -3.74787495, 13.8943043, 10.5193253, -1.01041571, -9.41902959, -7.24405613, -0.901901892, 1.28054752]


@pytest.mark.slow
def test_the_wheel_ships_every_agent_file(tmp_path):
    # tests/test_packaging.py checks the presets, contours and fields; the agents (nested folders, and *.zip / *.pkl
    # that .gitignore ignores elsewhere) ride on the same force-include of assets/
    import importlib.util
    import subprocess
    import sys
    import zipfile
    from pathlib import Path

    if importlib.util.find_spec("pip") is None:
        pytest.skip("pip is not installed in this interpreter's environment")
    pytest.importorskip("hatchling", reason="the wheel is built without isolation (pip install -e '.[test]')")
    root = Path(__file__).resolve().parents[1]
    subprocess.run([sys.executable, "-m", "pip", "wheel", str(root), "--no-deps", "--no-build-isolation", "-q", "-w",
                    str(tmp_path)], check=True)
    with zipfile.ZipFile(next(tmp_path.glob("magsoft_env-*.whl"))) as zf:
        members = set(zf.namelist())
    files = [p.relative_to(root / "assets").as_posix() for p in (root / "assets" / "agents").rglob("*") if p.is_file()]
    assert any(f.endswith(".zip") for f in files) and any(f.endswith(".pkl") for f in files)
    for f in files:
        assert f"magsoft_env/_assets/{f}" in members, f


@pytest.mark.slow
def test_gap_matrix_rows_and_the_strip_refusal():
    """The gap matrix plays an agent on every variant; the strip's observation does not fit a chain agent, and the
    row says so instead of failing."""
    from magsoft_env.bench import gap_matrix

    rows = gap_matrix.run(["ppo_seed1"], progress=None)
    assert [r["variant"] for r in rows] == [v[0] for v in gap_matrix.variants()]
    strip = next(r for r in rows if "strip" in r["variant"])
    assert "observation space" in strip["not_applicable"]
    trained = rows[0]
    assert trained["measure_mean"] > 0.5 and trained["airborne_fraction"] == 0.0
    assert "n/a" in gap_matrix.markdown(rows)

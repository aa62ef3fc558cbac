"""The batched floor envs (``gym.make_vec`` -> MagSoftCrawlVecEnv) against the single env, and the SB3 adapter."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.envs.channel import MagSoftChannelEnv
from magsoft_env.envs.obstacle import MagSoftObstacleEnv
from magsoft_env.envs.vector import MagSoftChannelVecEnv, MagSoftCrawlVecEnv, MagSoftObstacleVecEnv, usable_cpus

#: small and coarse, with a field strong enough that episodes end (tumbles) within tens of steps
FAST = {"segments": 4, "sim_dt": 1e-3, "field_limit": 4e-3}
INFO_KEYS = ("reward_forward", "reward_field", "reward_crawl", "reward_success", "x_position", "z_position",
             "x_velocity", "time", "max_penetration", "is_success")


def _single_run(env_id, seed, actions, **kw):
    """The single env under ``actions``, reset (without a seed) the step after an episode ends, as the
    vector env's NEXT_STEP autoreset: (obs, reward, terminated, truncated, info) per step."""
    env = gym.make(env_id, **kw)
    out = [(*env.reset(seed=seed), None, None, None)]
    done = False
    for a in actions:
        if done:
            obs, info = env.reset()
            out.append((obs, info, 0.0, False, False))
            done = False
            continue
        obs, r, term, trunc, info = env.step(a)
        out.append((obs, info, r, term, trunc))
        done = term or trunc
    env.close()
    return out


def _robot(info: dict, i: int) -> dict:
    return {k: v[i] for k, v in info.items() if not k.startswith("_") and info[f"_{k}"][i]}


@pytest.mark.parametrize("num_threads, block", [(1, 25), (2, 25), (2, 3)])
def test_every_robot_is_the_single_env_through_episode_ends(num_threads, block):
    # block 3: each robot's 20-substep control step runs as 7 native blocks, interleaved with the others'
    kw = {**FAST, "max_episode_steps": 25}  # time limits as well as tumbles
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=3, num_threads=num_threads, block=block, **kw)
    assert isinstance(envs, MagSoftCrawlVecEnv) and envs.num_threads == num_threads and envs.block == block
    assert envs.envs[0].n_substeps == 20
    assert envs.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    actions = np.random.default_rng(3).uniform(-1, 1, (60, 3, 2)).astype(np.float32)
    got = [(*envs.reset(seed=11), None, None, None)]
    for a in actions:
        obs, r, term, trunc, info = envs.step(a)
        got.append((obs, info, r, term, trunc))
    envs.close()
    ended = 0
    for i in range(3):  # robot i: the single env seeded 11 + i, as SyncVectorEnv seeds
        want = _single_run("MagSoftCrawl-v1", 11 + i, actions[:, i], **kw)
        for t, ((obs, info, r, term, trunc), (w_obs, w_info, w_r, w_term, w_trunc)) in enumerate(
                zip(got, want, strict=True)):
            np.testing.assert_array_equal(obs[i], w_obs, err_msg=f"robot {i}, step {t}")  # bit for bit
            mine = _robot(info, i)
            assert set(mine) == set(w_info), (i, t)
            for k in INFO_KEYS:
                assert mine[k] == w_info[k], (i, t, k)
            np.testing.assert_array_equal(mine["field"], w_info["field"])
            if t:
                assert (r[i], bool(term[i]), bool(trunc[i])) == (w_r, w_term, w_trunc), (i, t)
                assert mine.get("crawl_violation") == w_info.get("crawl_violation")
                ended += bool(w_term or w_trunc)
    assert ended >= 6  # the run went through several autoresets (terminations and time limits)


def test_waveform_robots_are_the_single_env_in_rollout_blocks():
    # waveform mode: a whole field period per step, in mujoco.rollout blocks of 100 interleaved on two threads
    kw = {"segments": 4, "sim_dt": 1e-3}
    envs = gym.make_vec("MagSoftCrawlWaveform-v1", num_envs=2, num_threads=2, **kw)
    assert envs.block == 100
    actions = np.random.default_rng(5).uniform(-1, 1, (4, 2, 4)).astype(np.float32)
    got = [envs.reset(seed=3)[0]] + [envs.step(a)[0] for a in actions]
    envs.close()
    for i in range(2):
        want = [w[0] for w in _single_run("MagSoftCrawlWaveform-v1", 3 + i, actions[:, i], **kw)]
        for t, (obs, w) in enumerate(zip(got, want, strict=True)):
            np.testing.assert_array_equal(obs[i], w, err_msg=f"robot {i}, step {t}")


def test_robots_are_independent():
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=3, **FAST)
    obs, _ = envs.reset(seed=[5, 5, 5])
    assert np.array_equal(obs[0], obs[1]) and np.array_equal(obs[1], obs[2])
    a = np.array([[0.0, 0.8], [0.0, 0.8], [0.6, -0.3]], dtype=np.float32)
    for _ in range(5):
        obs, _, _, _, info = envs.step(a)
    assert np.array_equal(obs[0], obs[1])  # same seed, same actions
    assert not np.allclose(obs[0], obs[2])  # other actions, other state
    assert info["x_position"][0] == info["x_position"][1] != info["x_position"][2]
    envs.close()


def test_reset_mask_resets_only_the_chosen_robots():
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, **FAST)
    obs0, _ = envs.reset(seed=0)
    for _ in range(3):
        moved, *_ = envs.step(np.full((2, 2), 0.5, dtype=np.float32))
    obs, info = envs.reset(seed=[0, None], options={"reset_mask": np.array([True, False])})
    np.testing.assert_array_equal(obs[0], obs0[0])
    np.testing.assert_array_equal(obs[1], moved[1])
    assert info["_time"].tolist() == [True, False] and info["time"][0] == 0.0
    with pytest.raises(ValueError, match="reset_mask"):
        envs.reset(options={"reset_mask": np.array([False, False])})
    envs.close()


def test_reset_arguments_are_parsed_once_for_both_batches():
    from magsoft_env.envs.vector import reset_arguments

    mask = np.array([True, False, True])
    assert reset_arguments(7, {"reset_mask": mask, "qpos": 1}, 3) == ([7, 8, 9], mask, {"qpos": 1})
    assert reset_arguments([None, 1, 2], None, 3) == ([None, 1, 2], None, {})
    with pytest.raises(ValueError, match=r"seed must be None, an int or a list of 3 seeds"):
        reset_arguments([1, 2], None, 3)
    with pytest.raises(ValueError, match=r"options\['reset_mask'\] must be a boolean numpy array of shape \(3,\)"):
        reset_arguments(None, {"reset_mask": [True, False, True]}, 3)
    with pytest.raises(ValueError, match="must select at least one robot"):
        reset_arguments(None, {"reset_mask": np.zeros(3, bool)}, 3)


def test_a_start_state_option_reaches_every_robot():
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, **FAST)
    envs.reset(seed=0)
    qpos = envs.envs[0].sim.data.qpos.copy()
    qpos[0] += 1e-3  # 1 mm along x
    obs, info = envs.reset(seed=5, options={"qpos": qpos})
    np.testing.assert_array_equal(obs[0], obs[1])  # the same state, no reset noise drawn
    assert info["x_position"][0] == info["x_position"][1]
    with pytest.raises(ValueError, match="options may hold 'qpos' and 'qvel'"):
        envs.reset(options={"start": qpos})
    envs.close()


def test_an_unphysical_robot_truncates_alone_with_the_single_envs_info():
    # 100 mT pressed straight down at 1 ms: the contact penetrates 2.3 h in the first step (docs/envs.md)
    kw = {"segments": 4, "sim_dt": 1e-3, "field_limit": 0.1}
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, **kw)
    envs.reset(seed=0)
    a = np.array([[0.0, -1.0], [0.0, 0.0]], dtype=np.float32)
    obs, r, term, trunc, info = envs.step(a)
    assert trunc.tolist() == [True, False] and not term.any()
    assert info["_unphysical"].tolist() == [True, False]
    single = gym.make("MagSoftCrawl-v1", **kw)
    single.reset(seed=0)
    w_obs, w_r, _, w_trunc, w_info = single.step(a[0])
    assert w_trunc and info["truncation_reason"][0] == w_info["truncation_reason"]
    assert info["unphysical"][0] == w_info["unphysical"] and info["penetration_h"][0] == w_info["penetration_h"]
    np.testing.assert_array_equal(obs[0], w_obs)
    obs, r, term, trunc, info = envs.step(a)  # the next step resets robot 0, robot 1 steps on
    assert r[0] == 0.0 and not trunc[0] and info["time"][0] == 0.0 and info["time"][1] > 0.0


@pytest.mark.parametrize("block", [25, 2])
def test_mujoco_warnings_reach_the_robot_that_raised_them(block):
    # at 20 mT and 1 ms the 6-segment rod blows up (bad qacc) after a few hundred steps: every simulator's
    # warning text and step must be its own while two threads step them (one process-wide MuJoCo handler)
    kw = {"segments": 6, "sim_dt": 1e-3, "field_limit": 0.02, "crawl_mode": "none"}
    t = np.arange(30)
    wild = np.stack([np.sin(t), np.cos(1.3 * t)], axis=1).astype(np.float32)
    actions = np.stack([wild, np.zeros_like(wild), wild[::-1].copy()], axis=1)
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=3, num_threads=2, block=block, **kw)
    envs.reset(seed=[0, 0, 0])
    reasons = [None, None, None]
    for a in actions:
        _, _, _, trunc, info = envs.step(a)
        for i in np.flatnonzero(trunc):
            reasons[i] = reasons[i] or info["truncation_reason"][i]
    envs.close()
    for i in range(3):
        single = gym.make("MagSoftCrawl-v1", **kw)
        single.reset(seed=0)
        want = None
        for a in actions[:, i]:
            *_, trunc, info = single.step(a)
            if trunc:
                want = info["truncation_reason"]
                break
        assert reasons[i] == want, i
    assert "MuJoCo warning" in reasons[0] and "QACC" in reasons[0] and reasons[1] is None


def test_make_vec_takes_the_single_envs_kwargs():
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, robot="paper-5a", field_limit=1e-3, segments=4)
    assert isinstance(envs, MagSoftCrawlVecEnv) and envs.max_episode_steps == 250
    assert envs.get_attr("robot") == ("paper-5a", "paper-5a") and envs.envs[1].field_limit == 1e-3
    assert envs.observation_space.shape == (2, 2 * 4 + 8) and envs.single_action_space.shape == (2,)
    assert envs.spec.id == "MagSoftCrawl-v1"
    envs.close()
    same = gym.make_vec("MagSoftCrawl-v1", num_envs=1, vectorization_mode="vector_entry_point", segments=4)
    assert isinstance(same, MagSoftCrawlVecEnv) and same.num_threads == 1
    wave = gym.make_vec("MagSoftCrawlWaveform-v1", num_envs=2, segments=4)
    assert wave.envs[0].action_mode == "waveform" and wave.action_space.shape == (2, 4)
    assert wave.max_episode_steps == 20
    for env_id, cls, single in (("MagSoftChannel-v1", MagSoftChannelVecEnv, MagSoftChannelEnv),
                                ("MagSoftObstacle-v1", MagSoftObstacleVecEnv, MagSoftObstacleEnv)):
        v = gym.make_vec(env_id, num_envs=1, segments=4)
        assert isinstance(v, cls) and type(v.envs[0]) is single and v.max_episode_steps == 1500
    sync = gym.make_vec("MagSoftCrawl-v1", num_envs=1, vectorization_mode="sync", segments=4)
    assert isinstance(sync, gym.vector.SyncVectorEnv)  # Gymnasium's own, on request


@pytest.mark.parametrize("kwargs, match", [
    ({"fild_limit": 1e-3}, "unknown argument 'fild_limit'. Did you mean 'field_limit'"),
    ({"num_thread": 2}, "Did you mean 'num_threads'"),
    ({"num_threads": 0}, "num_threads must be an integer >= 1"),
    ({"max_episode_steps": 0}, "max_episode_steps must be an integer >= 1"),
    ({"block": 0}, "block must be an integer >= 1"),
    ({"field_limit": -1.0}, "field_limit must be > 0"),
])
def test_bad_arguments_are_refused(kwargs, match):
    with pytest.raises(ValueError, match=match):
        gym.make_vec("MagSoftCrawl-v1", num_envs=2, **kwargs)


def test_bad_num_envs_and_actions_are_refused():
    with pytest.raises(ValueError, match="num_envs must be an integer >= 1"):
        MagSoftCrawlVecEnv(0)
    envs = MagSoftCrawlVecEnv(2, **FAST)
    envs.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions must have shape \(2, 2\)"):
        envs.step(np.zeros(2))
    with pytest.raises(ValueError, match="seed must be"):
        envs.reset(seed=[1, 2, 3])
    envs.close()


def test_sb3_adapter_autoresets_the_sb3_way_and_ppo_trains():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    from magsoft_env.rl import SB3VecAdapter, make_sb3_vec_env

    venv = SB3VecAdapter(gym.make_vec("MagSoftCrawl-v1", num_envs=2, max_episode_steps=4, **FAST))
    venv.seed(0)
    obs = venv.reset()
    assert obs.shape == (2, 16)
    ends = []
    for _ in range(4):
        obs, rewards, dones, infos = venv.step(np.zeros((2, 2), dtype=np.float32))
        ends.append(dones.tolist())
    assert ends == [[False, False]] * 3 + [[True, True]] and rewards.dtype == np.float32  # the time limit
    assert all(i["TimeLimit.truncated"] for i in infos) and infos[0]["terminal_observation"].shape == (16,)
    assert obs[0][2 * 4 + 2 + 2:].tolist() == [0.0, 0.0, 0.0, 1.0]  # the reset observation: no field, clock at 0
    assert venv.get_attr("robot") == ["paper-5c", "paper-5c"]
    obs, _, dones, infos = venv.step(np.zeros((2, 2), dtype=np.float32))  # the new episode's first step
    assert not dones.any() and "terminal_observation" not in infos[0]
    venv.close()

    env = make_sb3_vec_env("MagSoftCrawl-v1", 2, seed=0, **FAST)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=128)
    assert model.num_timesteps == 128 and len(model.ep_info_buffer) > 0  # episodes ended and were logged
    env.close()


def test_vec_bench_runs_its_rows(capsys):
    # the benchmark's numbers are not checked (timings never are), only that its rows run and print
    from magsoft_env.bench import vec_bench

    assert vec_bench.main(["--env-id", "MagSoftCrawl-v1", "--seconds", "0.05", "--rounds", "2", "--sizes", "1", "2",
                           "--only", "single,batched,machine,bound", "--bound-steps", "3"]) == 0
    out = capsys.readouterr().out
    assert "single env, robots in turn (baseline)" in out and out.count("| batched |") == 1
    assert "| C step alone, 2 threads |" in out and "The machine's own 2-thread scaling" in out
    assert "C alone, 2 threads" in out and "1000 env steps/s on 2 cores needs <= 20 us" in out
    with pytest.raises(SystemExit, match="unknown mode"):
        vec_bench.main(["--only", "batched,gpu"])
    with pytest.raises(SystemExit, match="--rounds"):
        vec_bench.main(["--rounds", "0"])


def test_vec_bench_baseline_runs_the_batched_envs_trajectories():
    # the fixed-work comparison holds only if the baseline's robots are the batched env's, step for step
    from magsoft_env.bench.vec_bench import _Single, _Vector

    single = _Single("MagSoftCrawl-v1", 3, **FAST)
    batched = _Vector("batched", "MagSoftCrawl-v1", 3, **FAST)
    for _ in range(40):  # through episode ends (FAST tumbles within tens of steps)
        single.step()
        batched.step()
    obs = np.array([env.unwrapped._get_obs() for env in single.envs])
    assert any(env.unwrapped.sim.nstep < 40 * env.unwrapped.n_substeps for env in single.envs)  # some reset
    np.testing.assert_array_equal(obs, [env._get_obs() for env in batched.venv.envs])
    single.close()
    batched.close()


def test_threaded_dummy_vec_env_is_dummy_vec_env_on_threads():
    # rl-zoo3 runs (vec="threads"): SB3's DummyVecEnv semantics and results, every step, through episode ends
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    from magsoft_env.rl import ThreadedVecEnv

    threaded = make_vec_env("MagSoftCrawl-v1", n_envs=3, seed=5, vec_env_cls=ThreadedVecEnv, env_kwargs=FAST)
    dummy = make_vec_env("MagSoftCrawl-v1", n_envs=3, seed=5, vec_env_cls=DummyVecEnv, env_kwargs=FAST)
    assert threaded.num_threads == min(3, usable_cpus())
    np.testing.assert_array_equal(threaded.reset(), dummy.reset())
    rng = np.random.default_rng(0)
    ended = 0
    for _ in range(60):
        a = rng.uniform(-1, 1, (3, 2)).astype(np.float32)
        got, want = threaded.step(a), dummy.step(a)
        for x, y in zip(got[:3], want[:3], strict=True):
            np.testing.assert_array_equal(x, y)
        for mine, theirs in zip(got[3], want[3], strict=True):
            assert set(mine) == set(theirs)
            for k in ("reward", "x_position", "TimeLimit.truncated"):
                assert mine.get(k) == theirs.get(k), k
            if "episode" in theirs:  # Monitor's return and length ("t" is wall time)
                assert (mine["episode"]["r"], mine["episode"]["l"]) == (theirs["episode"]["r"], theirs["episode"]["l"])
            if "terminal_observation" in theirs:
                np.testing.assert_array_equal(mine["terminal_observation"], theirs["terminal_observation"])
        ended += int(want[2].sum())
    assert ended >= 3
    threaded.close()
    dummy.close()
    with pytest.raises(ValueError, match="num_threads must be an integer >= 1"):
        ThreadedVecEnv([lambda: gym.make("MagSoftCrawl-v1", **FAST)], num_threads=0)

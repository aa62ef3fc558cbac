"""Environment contract: registration, check_env, determinism, finiteness, reward terms, instability."""

from __future__ import annotations

import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import magsoft_env  # noqa: F401  (registers the ids)
from magsoft_env.envs import ENV_SPECS, register_all
from magsoft_env.envs.crawl import AIRBORNE_TOLERANCE

IDS = list(ENV_SPECS)
# small rods at a coarse step keep the contract tests fast; the physics does not change the contract
FAST = {"segments": 6, "sim_dt": 2e-4}


def make(env_id, **kw):
    return gym.make(env_id, **{**FAST, **kw})


def test_import_does_not_load_mujoco_torch_or_gl():
    code = (
        "import sys, magsoft_env, gymnasium\n"
        "assert 'MagSoftCrawl-v1' in gymnasium.registry\n"
        "bad = [m for m in ('mujoco', 'torch', 'stable_baselines3', 'OpenGL') if m in sys.modules]\n"
        "print(bad)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_register_all_is_idempotent_and_sets_time_limits():
    register_all()
    register_all()
    for env_id, (entry, steps, _) in ENV_SPECS.items():
        spec = gym.spec(env_id)
        assert spec.entry_point == entry
        assert spec.max_episode_steps == steps


@pytest.mark.parametrize("env_id", IDS)
def test_check_env_passes_without_warnings(env_id):
    env = make(env_id)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    env.close()


@pytest.mark.parametrize("env_id", IDS)
def test_same_seed_same_trajectory(env_id):
    def rollout():
        env = make(env_id)
        env.action_space.seed(7)
        obs, _ = env.reset(seed=3)
        traj = [obs]
        for _ in range(4):
            obs, r, term, trunc, _ = env.step(0.1 * env.action_space.sample())
            traj.append(obs)
            if term or trunc:
                break
        env.close()
        return np.array(traj)

    a, b = rollout(), rollout()
    assert a.shape == b.shape
    np.testing.assert_array_equal(a, b)


@pytest.mark.parametrize("env_id", IDS)
def test_observations_finite_and_reward_terms_add_up(env_id):
    kw = {"crawl_mode": "none"} if not env_id.startswith(("MagSoftShape", "MagSoftSteer")) else {}
    env = make(env_id, **kw)
    env.action_space.seed(0)
    obs, _ = env.reset(seed=0)
    for _ in range(6):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        assert obs.dtype == np.float32
        assert np.all(np.isfinite(obs))
        assert env.observation_space.contains(obs)
        terms = sum(v for k, v in info.items() if k.startswith("reward_"))
        assert r == pytest.approx(terms, rel=1e-12, abs=1e-12)
        if term or trunc:
            obs, _ = env.reset()
    env.close()


def test_different_seeds_give_different_starts():
    env = make("MagSoftCrawl-v1")
    a, _ = env.reset(seed=1)
    b, _ = env.reset(seed=2)
    assert not np.array_equal(a, b)


@pytest.mark.parametrize("env_id", IDS)
def test_forced_instability_truncates_with_reason(env_id):
    env = make(env_id)
    env.reset(seed=0)
    env.unwrapped.sim.data.qvel[:] = np.nan
    obs, r, term, trunc, info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert trunc and not term
    assert "unstable" in info["truncation_reason"]
    assert np.all(np.isfinite(obs))
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    env.reset(seed=0)  # usable again after reset
    env.step(np.zeros(env.action_space.shape, dtype=np.float32))


def test_crawl_limit_terminates_with_penalty_and_no_forward_reward():
    env = make("MagSoftCrawl-v1", field_limit=0.02, max_clearance=None)  # the rotation limit alone
    env.reset(seed=0)
    for _ in range(50):  # full field along z flips the beam
        obs, r, term, trunc, info = env.step(np.array([0.0, 1.0], dtype=np.float32))
        if term:
            break
    assert term
    assert "link rotation" in info["crawl_violation"]
    assert info["reward_forward"] == 0.0
    assert info["reward_crawl"] <= -10.0  # the penalty plus the forward reward earned before


def test_crawl_violation_forfeits_the_episode_forward_reward():
    env = make("MagSoftCrawl-v1", field_limit=0.02)
    env.reset(seed=0)
    earned, total = 0.0, 0.0
    for _ in range(50):
        _, r, term, _, info = env.step(np.array([0.0, 1.0], dtype=np.float32))
        total += r
        if term:
            break
        earned += info["reward_forward"]
    assert term
    assert info["reward_crawl"] == pytest.approx(-10.0 - max(earned, 0.0))
    assert total <= -10.0 + 1e-9  # a tumble never pays


def test_height_mode_and_slew_rate_limit():
    env = make("MagSoftCrawl-v1", crawl_mode="height", slew_rate=0.05)  # 50 mT/s: 1 mT per 20 ms step
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([1.0, -1.0], dtype=np.float32))
    np.testing.assert_allclose(info["field"], [1e-3, -1e-3], rtol=1e-9)
    _, _, _, _, info = env.step(np.array([1.0, -1.0], dtype=np.float32))
    np.testing.assert_allclose(info["field"], [2e-3, -2e-3], rtol=1e-9)


def test_waveform_action_mapping_round_trip():
    env = make("MagSoftCrawlWaveform-v1").unwrapped
    a = np.array([0.3, -0.5, 0.25, 0.1], dtype=np.float32)
    w = env.waveparams_of_action(a)
    assert w.amplitude_x == pytest.approx(0.3 * env.field_limit)
    assert w.phase == pytest.approx(0.25 * np.pi)
    np.testing.assert_allclose(env.action_of_waveparams(w), a, atol=1e-6)


def test_waveform_step_lasts_one_period():
    env = make("MagSoftCrawlWaveform-v1")
    env.reset(seed=0)
    a = np.array([0.0, 0.05, 0.0, 1.0], dtype=np.float32)  # f = 4 Hz
    _, _, _, _, info = env.step(a)
    assert info["time"] == pytest.approx(0.25, abs=1e-9)


def test_shape_target_option_and_success_flag():
    env = make("MagSoftShape-v0")
    L = env.unwrapped.beam.length
    _, info = env.reset(seed=0, options={"target": (0.5 * L, -0.5 * L, -1.0)})
    np.testing.assert_allclose(info["target"], [0.5 * L, -0.5 * L, -1.0])
    assert not info["is_success"]
    with pytest.raises(ValueError, match="target"):
        env.reset(options={"target": (1.0, 2.0)})


@pytest.mark.parametrize("mode", ["sync", "async"])
def test_vector_envs(mode):
    envs = gym.make_vec("MagSoftCrawl-v1", num_envs=2, vectorization_mode=mode, **FAST)
    obs, _ = envs.reset(seed=[0, 1])
    assert obs.shape == (2, envs.single_observation_space.shape[0])
    for _ in range(3):
        obs, r, term, trunc, info = envs.step(0.05 * np.ones((2, 2), dtype=np.float32))
    assert np.all(np.isfinite(obs)) and r.shape == (2,)
    envs.close()


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"field_limit": -0.02}, "field_limit must be > 0"),
        ({"field_limit": 20.0}, "field_limit must be <= 0.1 T"),
        ({"action_mode": "torque"}, "action_mode must be one of"),
        ({"crawl_mode": "rotaton"}, "Did you mean"),
        ({"robot": "paper-5d"}, "Did you mean"),
        ({"target_direction": 2}, "target_direction must be"),
        ({"slew_rate": 0.0}, "slew_rate must be > 0"),
        ({"frequency_range": (4.0, 1.0)}, "frequency_range"),
        ({"render_mode": "human"}, "render_mode must be one of"),
    ],
)
def test_bad_arguments_raise_value_errors(kwargs, match):
    from magsoft_env.envs.crawl import MagSoftCrawlEnv

    with pytest.raises(ValueError, match=match):
        MagSoftCrawlEnv(**kwargs)


def test_open_loop_action_follows_the_gait():
    env = make("MagSoftCrawl-v1", robot="paper-5c").unwrapped
    wave = env.gait.wave
    t = 0.13
    b = wave.sample([t + 0.01])[0]
    np.testing.assert_allclose(env.open_loop_action(t) * env.field_limit, b, rtol=1e-6)


def test_shape_open_loop_target_field_reaches_the_target():
    # holding the field whose analytical equilibrium is the target brings the MuJoCo tip there
    env = make("MagSoftShape-v0", segments=10)
    env.reset(seed=2)
    for _ in range(60):
        _, _, _, _, info = env.step(env.unwrapped.open_loop_action())
    assert np.all(np.isfinite(info["target_field"]))
    assert info["position_error"] < 0.05 * env.unwrapped.beam.length


@pytest.mark.parametrize("env_id, past", [("MagSoftChannel-v1", "exit_x"), ("MagSoftObstacle-v1", "clear_x")])
def test_feature_envs_reach_success_past_the_feature(env_id, past):
    # the success condition, exercised: a beam set down beyond the box's far end (the block's
    # right face) ends the episode with the success reward; one 0.5 mm short of it is not a
    # success (checked on the predicate only: stepping it would push it off the block it overlaps)
    env = make(env_id)
    u = env.unwrapped

    def place(shift):  # an episode started from the rested beam moved along x (reset's start-state option)
        env.reset(seed=0)
        sim = u.sim
        qpos = sim.data.qpos.copy()
        qpos[sim.rod.base_qpos[0]] += getattr(u, past) - sim.centerline()[0].min() + shift
        env.reset(options={"qpos": qpos})

    place(-0.5e-3)
    assert not u._is_success() and u._success_reward() == 0.0
    place(0.5e-3)
    _, reward, terminated, truncated, info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))
    assert info["is_success"] and terminated and not truncated
    assert info["reward_success"] == u.success_reward == 100.0
    assert reward == pytest.approx(info["reward_forward"] + info["reward_field"] + info["reward_crawl"]
                                   + info["reward_success"])


def test_floor_envs_run_each_robots_own_numerics_unless_told():
    # one physics with the gaits: the robot's own (segments, timestep), a named level, or explicit values
    from magsoft_env.cases.gaits import FIDELITY
    from magsoft_env.sim.gait import gait_rod_options

    for env_id, own in (("MagSoftCrawl-v1", (20, 2e-4)), ("MagSoftChannel-v1", (80, 1e-4)),
                        ("MagSoftObstacle-v1", (80, 2.5e-5))):
        u = gym.make(env_id).unwrapped
        assert (u.segments, u.sim_dt) == own and u.fidelity is None
        assert u.observation_space.shape == (2 * own[0] + 8,)
        # the rod is the gaits' rod at those numerics
        o = gait_rod_options(u.gait, scene=u._scene, feature_x=u.sim.options.feature_x)
        assert u.sim.options == o
    for level, (n, dt) in FIDELITY.items():
        u = gym.make("MagSoftObstacle-v1", fidelity=level).unwrapped
        assert (u.segments, u.sim_dt, u.sim.options.timestep, u.fidelity) == (n, dt, dt, level)
    # a robot's numerics for the scene: paper-5c under the channel's ceiling
    u = gym.make("MagSoftChannel-v1", robot="paper-5c").unwrapped
    assert (u.segments, u.sim_dt) == (40, 1e-4)
    assert (gym.make("MagSoftCrawl-v1").unwrapped.segments, gym.make("MagSoftObstacle-v1", robot="paper-5c")
            .unwrapped.segments) == (20, 20)
    u = gym.make("MagSoftChannel-v1", segments=10, sim_dt=5e-4).unwrapped
    assert (u.segments, u.sim_dt) == (10, 5e-4)
    with pytest.raises(ValueError, match="not both"):
        gym.make("MagSoftCrawl-v1", fidelity="fast", sim_dt=1e-4)
    with pytest.raises(ValueError, match="fidelity must be one of"):
        gym.make("MagSoftCrawl-v1", fidelity="quick")


def _violation_now(env) -> str | None:
    """The crawl task's verdict on the env's present state (one column of the crawl limits)."""
    from magsoft_env.envs.crawl_task import crawl_limits, first_violation, violation_texts

    pose = env.sim.pose()
    lim = crawl_limits(pose.centreline[None, :, None, :], [0.0], half_thickness=0.5 * env.gait.beam.thickness,
                       inv_piece_length=1.0 / pose.lengths)
    column, figures = first_violation(lim, env.task)
    return violation_texts(figures, [env.sim.time], env.task, column >= 0)[0]


def test_a_jump_is_not_a_crawl():
    env = make("MagSoftCrawl-v1", max_clearance=2e-3).unwrapped
    env.reset(seed=0)
    assert _violation_now(env) is None  # resting on the floor
    qpos = env.sim.data.qpos.copy()
    qpos[1] += 3e-3  # the whole beam 3 mm up (base_z): more than the 2 mm clearance limit
    env.sim.set_state(qpos=qpos)
    assert "the lowest point is 2.989 mm above the floor > 2.000 mm" in _violation_now(env)
    assert make("MagSoftCrawl-v1", max_clearance=None).unwrapped.max_clearance is None
    assert make("MagSoftObstacle-v1").unwrapped.max_clearance is None  # on the block the beam is above the floor
    with pytest.raises(ValueError, match="max_clearance must be > 0"):
        make("MagSoftCrawl-v1", max_clearance=0.0)


#: At 4 mT: B_z down, B_x right, then B_z up throws the whole beam 2.7 mm off the floor in the middle of the
#: third 20 ms step; it lands before that step ends (found by a search over the +-1 corners, seed 0).
HOP_ACTIONS = [(0.0, -1.0), (1.0, 0.0), (0.0, 1.0)]


def _hop_env(**kw):
    return gym.make("MagSoftCrawl-v1", field_limit=0.004, **kw)


def test_a_hop_within_a_control_step_ends_the_episode():
    # what an end-of-step check sees: every step ends with the beam within 2 mm of the floor, below 120 deg
    free = _hop_env(crawl_mode="none", max_clearance=None).unwrapped
    free.reset(seed=0)
    for a in HOP_ACTIONS:
        free.step(np.array(a, dtype=np.float32))
        _, z = free.sim.centerline()
        assert np.min(z) - 0.5 * free.gait.beam.thickness < 2e-3
        assert np.max(np.abs(free.sim.angles())) < free.max_link_rotation
    assert free.step(np.zeros(2, dtype=np.float32))[-1]["highest_clearance"] > 2.5e-3  # but it hopped 2.7 mm
    # the limits hold at every substep: the hop ends the episode on the step in which it happened
    env = _hop_env(max_clearance=2e-3)
    env.reset(seed=0)
    for k, a in enumerate(HOP_ACTIONS):
        _, reward, terminated, truncated, info = env.step(np.array(a, dtype=np.float32))
        assert terminated == (k == 2) and not truncated
    assert info["crawl_violation"].startswith("airborne at t = 0.0")
    assert "above the floor > 2.000 mm" in info["crawl_violation"]
    assert info["reward_forward"] == 0.0 and info["reward_crawl"] < 0.0
    # under the default (part of the beam on the floor at every substep) the smaller lift of step 2 ends it
    env = _hop_env()
    env.reset(seed=0)
    assert not env.step(np.array(HOP_ACTIONS[0], dtype=np.float32))[2]
    _, _, terminated, _, info = env.step(np.array(HOP_ACTIONS[1], dtype=np.float32))
    assert terminated and info["crawl_violation"].startswith("airborne")


def test_substep_clearance_and_airborne_fraction_are_the_states_own():
    # the sensors' history against the centreline read after every single substep
    env = _hop_env(crawl_mode="none", max_clearance=None).unwrapped
    env.reset(seed=0)
    half_h = 0.5 * env.gait.beam.thickness
    clear = [np.min(env.sim.centerline()[1]) - half_h]
    for a in HOP_ACTIONS:
        more, info = _substep_clearances(env, a, half_h)
        clear += more
    clear = np.array(clear)
    assert info["highest_clearance"] == pytest.approx(clear.max(), abs=1e-12)
    n = len(HOP_ACTIONS) * env.n_substeps
    assert len(clear) == n + 1
    assert info["airborne_fraction"] == pytest.approx(np.count_nonzero(clear[:-1] > AIRBORNE_TOLERANCE) / n)
    assert 0.0 < info["airborne_fraction"] < 1.0
    # the rotation row: the cosine of the largest piece angle
    from magsoft_env.envs.crawl_task import crawl_limits

    pose = env.sim.pose()
    lim = crawl_limits(pose.centreline[None, :, None, :], [0.0], half_thickness=half_h,
                       inv_piece_length=1.0 / pose.lengths)
    assert lim[0, 2, 0] == pytest.approx(np.cos(np.max(np.abs(env.sim.angles()))), abs=1e-12)


def test_the_paper_gait_never_leaves_the_floor():
    env = gym.make("MagSoftCrawl-v1")  # paper-5c at its own numerics, the default crawl limits
    base = env.unwrapped
    env.reset(seed=0)
    for k in range(250):
        _, _, terminated, truncated, info = env.step(base.open_loop_action(k * base.ctrl_dt))
        assert not terminated
    assert truncated and info["airborne_fraction"] == 0.0
    assert info["highest_clearance"] < 0.1 * AIRBORNE_TOLERANCE


@pytest.mark.parametrize("name", ["MagSoftCrawl", "MagSoftCrawlWaveform", "MagSoftChannel", "MagSoftObstacle"])
def test_the_floor_ids_v0_are_removed_with_an_error_naming_v1(name):
    # v1 changed what their episodes reward (crawl limits at every substep; the channel and obstacle observe
    # 168 numbers, v0 48): a policy trained on v0 must not run on v1 silently
    assert f"{name}-v1" in gym.registry and f"{name}-v0" not in gym.registry
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(gym.error.DeprecatedEnv, match=f"Please use `{name}-v[12]`"):
            gym.make(f"{name}-v0")


@pytest.mark.parametrize("env_id", ["MagSoftCrawl-v1", "MagSoftShape-v0"])
@pytest.mark.parametrize("action", [np.zeros(3), "ab", ["x", "y"], [0.0, np.nan], None])
def test_an_action_of_the_wrong_shape_or_type_is_named_with_the_expected_shape(env_id, action):
    env = make(env_id)
    env.reset(seed=0)
    expected = r"action must be a float array of shape \(2,\) \(dtype float32, in \[-1, 1\]\)"
    with pytest.raises(ValueError, match=expected):
        env.step(action)


def test_an_absurd_frequency_range_is_named_with_its_valid_range():
    expected = r"frequency_range must lie within \[0\.0005, 5e\+03\] Hz at sim_dt = 0\.0002 s"
    with pytest.raises(ValueError, match=expected):
        make("MagSoftCrawlWaveform-v1", frequency_range=(1.0, 1e9))


@pytest.mark.parametrize("target", [(1e30, 0.0, 0.0), (0.02, 0.02, 0.0), (0.01, 0.0, 90.0)])
def test_a_shape_target_out_of_the_beams_reach_is_refused(target):
    env = make("MagSoftShape-v0")
    with pytest.raises(ValueError, match=r"options\['target'\] must lie within the beam's reach: .* L = 0\.025 m"):
        env.reset(seed=0, options={"target": target})
    env.reset(seed=0, options={"target": (0.02, -0.01, -0.5)})  # within reach


def test_waveform_substeps_are_all_read():
    # a whole 4 Hz period per step (1250 substeps in blocks), whose samples repeat at the symmetric peak
    env = make("MagSoftCrawlWaveform-v1", crawl_mode="none", max_clearance=None, field_limit=0.004).unwrapped
    env.reset(seed=0)
    half_h = 0.5 * env.gait.beam.thickness
    clear = [np.min(env.sim.centerline()[1]) - half_h]
    more, info = _substep_clearances(env, [0.0, 1.0, 0.0, 1.0], half_h)
    clear += more
    assert len(clear) == 1251 and info["time"] == pytest.approx(0.25)
    assert info["highest_clearance"] == pytest.approx(max(clear), abs=1e-12)
    airborne = np.count_nonzero(np.array(clear[:-1]) > AIRBORNE_TOLERANCE)
    assert info["airborne_fraction"] == pytest.approx(airborne / 1250)
    # the default blocks read the same substeps
    again = make("MagSoftCrawlWaveform-v1", crawl_mode="none", max_clearance=None, field_limit=0.004)
    again.reset(seed=0)
    info2 = again.step(np.array([0.0, 1.0, 0.0, 1.0], dtype=np.float32))[-1]
    for key in ("highest_clearance", "airborne_fraction"):
        assert info2[key] == info[key]


def _substep_clearances(env, action, half_h):
    """One env step driven a substep at a time: the lowest point's clearance after every substep (the step's
    end state last) and the step's info."""
    clear = []
    steps = env._stepping(np.array(action, dtype=np.float32), block=1)
    while True:
        try:
            next(steps)
        except StopIteration as done:
            info = done.value[-1]
            break
        clear.append(np.min(env.sim.centerline()[1]) - half_h)
    clear.append(np.min(env.sim.centerline()[1]) - half_h)  # the step's end state
    return clear, info


def test_friction_range_randomizes_the_floor_per_reset_and_a_point_range_is_the_fixed_friction():
    """Domain randomization: friction_range=(0.6, 0.6) runs exactly as friction=0.6 (the same model arrays and the
    same trajectory: the draw comes after the reset noise), a range gives each seeded reset its own friction."""
    from magsoft_env.envs.crawl import scene_friction

    a = make("MagSoftCrawl-v1", friction=0.6)
    b = make("MagSoftCrawl-v1", friction_range=(0.6, 0.6))
    oa, _ = a.reset(seed=4)
    ob, info = b.reset(seed=4)
    assert info["friction"] == 0.6 and np.array_equal(oa, ob)
    ma, mb = a.unwrapped.sim.model, b.unwrapped.sim.model
    assert np.array_equal(ma.pair_friction, mb.pair_friction) and np.array_equal(ma.geom_friction, mb.geom_friction)
    act = np.array([0.4, 0.7], dtype=np.float32)
    for _ in range(5):
        oa = a.step(act)[0]
        ob = b.step(act)[0]
    assert np.array_equal(oa, ob)
    c = make("MagSoftCrawl-v1", friction_range=(0.3, 0.7))
    drawn = {c.reset(seed=s)[1]["friction"] for s in range(5)}
    assert len(drawn) == 5 and all(0.3 <= f <= 0.7 for f in drawn)
    assert c.reset(seed=2)[1]["friction"] == scene_friction(c.unwrapped.sim.model)
    with pytest.raises(ValueError, match="friction_range"):
        make("MagSoftCrawl-v1", friction_range=(0.7, 0.3))


def test_the_warp_backend_refuses_friction_range_by_name():
    pytest.importorskip("warp")
    pytest.importorskip("mujoco_warp")
    with pytest.raises(ValueError, match="friction_range"):
        gym.make_vec("MagSoftCrawl-v1", num_envs=2, backend="warp", device="cpu", friction_range=(0.4, 0.6))

"""Unknown environment arguments are refused by name, with the closest valid one."""

import gymnasium as gym
import pytest

import magsoft_env  # noqa: F401  (registers the ids)


@pytest.mark.parametrize(
    "env_id, kwargs, hint",
    [
        ("MagSoftCrawl-v1", {"fieldlimit": 0.004}, "field_limit"),
        ("MagSoftCrawlWaveform-v1", {"sim_dtt": 1e-4}, "sim_dt"),
        ("MagSoftChannel-v1", {"channel_gap": 0.0}, "entrance_gap"),
        ("MagSoftObstacle-v1", {"obstacle_gapp": 1e-3}, "obstacle_gap"),
        ("MagSoftShape-v0", {"ctrldt": 0.1}, "ctrl_dt"),
    ],
)
def test_unknown_env_argument_names_the_closest_one(env_id, kwargs, hint):
    with pytest.raises(ValueError, match=f"unknown argument {next(iter(kwargs))!r}. Did you mean {hint!r}"):
        gym.make(env_id, **kwargs)


@pytest.mark.parametrize("limit", [0.05, 0.1])
def test_shape_env_runs_at_its_own_field_limit(limit):
    # a regression: at field_limit = 0.1 T the 1 ms step went unstable on the second full reversal
    import numpy as np

    env = gym.make("MagSoftShape-v0", field_limit=limit)
    assert env.unwrapped.sim_dt == pytest.approx(1e-3 * 0.02 / limit)
    env.reset(seed=0)
    for a in ([1, 1], [-1, 1], [1, -1], [-1, -1], [0, 1], [1, 0]):
        _, _, term, trunc, info = env.step(np.array(a, np.float32))
        assert "truncation_reason" not in info, info.get("truncation_reason")
        if term or trunc:
            break
    env.close()

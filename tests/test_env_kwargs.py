"""Unknown environment arguments are refused by name, with the closest valid one (issue 13, item 4)."""

import gymnasium as gym
import pytest

import magsoft_env  # noqa: F401  (registers the ids)


@pytest.mark.parametrize(
    "env_id, kwargs, hint",
    [
        ("MagSoftCrawl-v0", {"fieldlimit": 0.004}, "field_limit"),
        ("MagSoftCrawlWaveform-v0", {"sim_dtt": 1e-4}, "sim_dt"),
        ("MagSoftChannel-v0", {"channel_gap": 0.0}, "entrance_gap"),
        ("MagSoftObstacle-v0", {"obstacle_gapp": 1e-3}, "obstacle_gap"),
        ("MagSoftShape-v0", {"ctrldt": 0.1}, "ctrl_dt"),
    ],
)
def test_unknown_env_argument_names_the_closest_one(env_id, kwargs, hint):
    with pytest.raises(ValueError, match=f"unknown argument {next(iter(kwargs))!r}. Did you mean {hint!r}"):
        gym.make(env_id, **kwargs)

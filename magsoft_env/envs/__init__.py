"""Gymnasium environments of magnetic soft robots, registered lazily (no mujoco import here).

Ids (see each class docstring for the spec sheet):

- ``MagSoftCrawl-v0``: free beam on a floor, action = field (B_x, B_z) each 20 ms.
- ``MagSoftCrawlWaveform-v0``: the same robot, action = one period of a waveform (gait design).
- ``MagSoftChannel-v0``: crawl through the paper's 42 x 8.5 x 7.6 mm hollow box.
- ``MagSoftObstacle-v0``: crawl over the paper's 7 x 5.5 x 2 mm block.
- ``MagSoftShape-v0``: a clamped beam reaches a target tip pose by choosing the field.
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

#: id -> (entry point, max_episode_steps, kwargs)
ENV_SPECS = {
    "MagSoftCrawl-v0": ("magsoft_env.envs.crawl:MagSoftCrawlEnv", 250, {}),
    "MagSoftCrawlWaveform-v0": ("magsoft_env.envs.crawl:MagSoftCrawlEnv", 20, {"action_mode": "waveform"}),
    "MagSoftChannel-v0": ("magsoft_env.envs.channel:MagSoftChannelEnv", 1500, {}),
    "MagSoftObstacle-v0": ("magsoft_env.envs.obstacle:MagSoftObstacleEnv", 1500, {}),
    "MagSoftShape-v0": ("magsoft_env.envs.shape:MagSoftShapeEnv", 100, {}),
}


def refuse_unknown_kwargs(env, unknown: dict) -> None:
    """Raise ValueError for constructor arguments ``env`` does not take, with the closest names
    (gymnasium would raise a bare TypeError from deep inside ``gym.make``)."""
    if not unknown:
        return
    import difflib
    import inspect

    allowed = set()
    for cls in type(env).__mro__:
        init = cls.__dict__.get("__init__")
        if init is not None:
            allowed |= {n for n, p in inspect.signature(init).parameters.items()
                        if n != "self" and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
    name = next(iter(unknown))
    hint = difflib.get_close_matches(name, sorted(allowed), n=1)
    extra = f" Did you mean {hint[0]!r}?" if hint else ""
    raise ValueError(
        f"{type(env).__name__} got an unknown argument {name!r}.{extra} Allowed: {', '.join(sorted(allowed))}."
    )


def register_all() -> None:
    """Register every id with Gymnasium; ids already registered are left alone."""
    for env_id, (entry_point, steps, kwargs) in ENV_SPECS.items():
        if env_id in registry:
            continue
        register(id=env_id, entry_point=entry_point, max_episode_steps=steps, kwargs=dict(kwargs))


__all__ = ["ENV_SPECS", "refuse_unknown_kwargs", "register_all"]

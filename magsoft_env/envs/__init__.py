"""Gymnasium environments of magnetic soft robots, registered lazily (no mujoco import here).

Ids (see each class docstring for the spec sheet):

- ``MagSoftCrawl-v1``: free beam on a floor, action = field (B_x, B_z) each 20 ms.
- ``MagSoftCrawl-v2``: the same, a broken crawl limit charged (``on_violation="penalty"``) instead of ending the
  episode.
- ``MagSoftCrawlWaveform-v1``: the same robot, action = one period of a waveform (gait design).
- ``MagSoftChannel-v1``: crawl through the paper's 42 x 8.5 x 7.6 mm hollow box.
- ``MagSoftObstacle-v1``: crawl over the paper's 7 x 5.5 x 2 mm block.
- ``MagSoftShape-v0``: a clamped beam reaches a target tip pose by choosing the field.
- ``MagSoftSteer-v0``: the 3D strip on a floor, steered to a goal point (x, y) by the field (B_x, B_y, B_z).
- ``MagSoftSteerWaveform-v0``: the same task, action = the vertical plane, magnitude and frequency of a rotating
  field each 0.1 s.
- ``MagSoftCoils-v0``: the same task, action = the currents of a real coil system (Navion; CardioMag by
  ``coils="cardiomag"``), through a current drive (lag, slew rate), gradient forces included.
- ``MagSoftMagnet-v0``: the same task, action = the pose of a permanent magnet held above the floor by a robot arm
  (moved at a bounded speed), gradient forces included.
- ``MagSoftCoilsWaveform-v0``, ``MagSoftMagnetWaveform-v0``: those two tasks with ``MagSoftSteerWaveform-v0``'s
  action (a rotating field's plane, magnitude and frequency each 0.1 s), which the coils or the magnet make at the
  strip.

The floor ids' v0 (crawl limits checked only at the end of each control step; the channel and obstacle
observing 48 numbers) are no longer registered: ``gym.make("MagSoftCrawl-v0")`` raises Gymnasium's
``DeprecatedEnv``, which names the v1 id.

The floor ids (crawl, waveform, channel, obstacle, steer, coils, magnet) also have a ``vector_entry_point``:
``gym.make_vec(id, num_envs=n)`` returns a :class:`~magsoft_env.envs.vector.MagSoftCrawlVecEnv`, which
steps all robots per call on a thread pool (``vectorization_mode="sync"`` / ``"async"`` still give
Gymnasium's own vector envs).
"""

from __future__ import annotations

from gymnasium.envs.registration import register, registry

#: id -> (entry point, max_episode_steps, kwargs)
ENV_SPECS = {
    "MagSoftCrawl-v1": ("magsoft_env.envs.crawl:MagSoftCrawlEnv", 250, {}),
    # v1's task with a broken crawl limit charged (and the progress so far forfeited) instead of ending the
    # episode: random actions run whole episodes (the crawl env's spec sheet, Version History)
    "MagSoftCrawl-v2": ("magsoft_env.envs.crawl:MagSoftCrawlEnv", 250, {"on_violation": "penalty"}),
    # 1-4 Hz: one step (a period) lasts at most 1 s of simulated time
    "MagSoftCrawlWaveform-v1": ("magsoft_env.envs.crawl:MagSoftCrawlEnv", 20,
                                {"action_mode": "waveform", "frequency_range": (1.0, 4.0)}),
    "MagSoftChannel-v1": ("magsoft_env.envs.channel:MagSoftChannelEnv", 1500, {}),
    "MagSoftObstacle-v1": ("magsoft_env.envs.obstacle:MagSoftObstacleEnv", 1500, {}),
    "MagSoftShape-v0": ("magsoft_env.envs.shape:MagSoftShapeEnv", 100, {}),
    "MagSoftSteer-v0": ("magsoft_env.envs.steer:MagSoftSteerEnv", 250, {}),
    # the field turning in a vertical plane chosen each 0.1 s step (direction, magnitude, frequency): 5 s
    "MagSoftSteerWaveform-v0": ("magsoft_env.envs.steer:MagSoftSteerEnv", 50, {"action_mode": "waveform",
                                                                               "ctrl_dt": 0.1}),
    # the steer task through a field source: coil currents (a drive with lag and slew) or a magnet's pose; 5 s
    "MagSoftCoils-v0": ("magsoft_env.envs.coils:MagSoftCoilsEnv", 250, {}),
    "MagSoftMagnet-v0": ("magsoft_env.envs.magnet:MagSoftMagnetEnv", 250, {}),
    # the same two tasks with MagSoftSteerWaveform-v0's action, made at the strip by the actuator each 20 ms; 5 s
    "MagSoftCoilsWaveform-v0": ("magsoft_env.envs.source_waveform:MagSoftCoilsWaveformEnv", 50, {}),
    "MagSoftMagnetWaveform-v0": ("magsoft_env.envs.source_waveform:MagSoftMagnetWaveformEnv", 50, {}),
}
#: id -> vector entry point (``gym.make_vec``): the floor envs, batched on threads (envs/vector.py)
VECTOR_ENTRY_POINTS = {
    "MagSoftCrawl-v1": "magsoft_env.envs.vector:MagSoftCrawlVecEnv",
    "MagSoftCrawlWaveform-v1": "magsoft_env.envs.vector:MagSoftCrawlVecEnv",
    "MagSoftChannel-v1": "magsoft_env.envs.vector:MagSoftChannelVecEnv",
    "MagSoftObstacle-v1": "magsoft_env.envs.vector:MagSoftObstacleVecEnv",
    "MagSoftSteer-v0": "magsoft_env.envs.vector:MagSoftSteerVecEnv",
    "MagSoftSteerWaveform-v0": "magsoft_env.envs.vector:MagSoftSteerVecEnv",
    "MagSoftCoils-v0": "magsoft_env.envs.coils:MagSoftCoilsVecEnv",
    "MagSoftMagnet-v0": "magsoft_env.envs.magnet:MagSoftMagnetVecEnv",
}


def constructor_arguments(*classes) -> set[str]:
    """Names of the keyword arguments the constructors of ``classes`` (and of their bases) take."""
    import inspect

    allowed = set()
    for top in classes:
        for cls in top.__mro__:
            init = cls.__dict__.get("__init__")
            if init is not None:
                allowed |= {n for n, p in inspect.signature(init).parameters.items()
                            if n != "self" and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL)}
    return allowed


def refuse_unknown_kwargs(env, unknown: dict, *, classes: tuple = ()) -> None:
    """Raise ValueError for constructor arguments ``env`` does not take, with the closest names
    (gymnasium would raise a bare TypeError from deep inside ``gym.make``). ``classes``: further
    classes whose arguments ``env`` passes on (a vector env's sub-environments)."""
    if not unknown:
        return
    import difflib

    allowed = constructor_arguments(type(env), *classes)
    name = next(iter(unknown))
    hint = difflib.get_close_matches(name, sorted(allowed), n=1)
    extra = f" Did you mean {hint[0]!r}?" if hint else ""
    raise ValueError(
        f"{type(env).__name__} got an unknown argument {name!r}.{extra} Allowed: {', '.join(sorted(allowed))}."
    )


def warn_ignored_source(env, robot) -> None:
    """Warn (once per construction) that ``robot``'s file holds a ``field_source`` block that ``env`` does not use:
    the crawl and steering envs make their own fields (the action, or their own coils or magnet), so a robot
    file's source would otherwise vanish without a word."""
    if getattr(robot, "field_source", None) is None:
        return
    import warnings

    kind = (robot.field_source or {}).get("type", "a field source")
    warnings.warn(f"{type(env).__name__}: robot {robot.name!r} has a field_source ({kind}) that this env does not "
                  "use: its fields are its action (uniform), or its own coils or magnet. run_gait, magsoft gait "
                  "and magsoft video run the robot in its source.", UserWarning, stacklevel=3)


def as_action(space, action):
    """``action`` as a float64 array of ``space``'s shape, or a ValueError naming the action, the shape and dtype
    expected and what was given (numpy's own reshape or float conversion errors name neither)."""
    import numpy as np

    expected = f"a float array of shape {space.shape} (dtype {space.dtype}, in [-1, 1])"
    try:
        a = np.asarray(action, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"action must be {expected}, got {action!r}.") from None
    if a.size != int(np.prod(space.shape)):
        raise ValueError(f"action must be {expected}, got shape {a.shape}: {action!r}.")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"action must be {expected} of finite numbers, got {action!r}.")
    return a.reshape(space.shape)


def run_to_end(steps):
    """Drive a generator to its end and return its value: an env's ``step`` from its ``_stepping`` generator
    (the batched envs interleave the generators instead)."""
    while True:
        try:
            next(steps)
        except StopIteration as done:
            return done.value


def instability_info(info: dict, err) -> dict:
    """``info`` with what a :class:`~magsoft_env.sim.SimulationError` says: ``truncation_reason``,
    ``instability`` and, for an unphysical run (penetration, tunnelling, launch), ``unphysical`` and its figures."""
    from ..sim.health import UnphysicalError

    info.update(truncation_reason=str(err), instability=err.quantity)
    if isinstance(err, UnphysicalError):
        info.update(err.figures)
        info["unphysical"] = err.reason
    return info


def register_all() -> None:
    """Register every id with Gymnasium; ids already registered are left alone."""
    for env_id, (entry_point, steps, kwargs) in ENV_SPECS.items():
        if env_id in registry:
            continue
        register(id=env_id, entry_point=entry_point, max_episode_steps=steps, kwargs=dict(kwargs),
                 vector_entry_point=VECTOR_ENTRY_POINTS.get(env_id))


__all__ = ["ENV_SPECS", "VECTOR_ENTRY_POINTS", "as_action", "constructor_arguments", "instability_info",
           "refuse_unknown_kwargs", "register_all", "run_to_end", "warn_ignored_source"]

"""The C reference of the Warp backend: a single CPU env restarted from a given state (no Warp import here).

The Warp batch starts every episode from the beam settled in C plus the reset noise
(:class:`~magsoft_env.envs.warp_vector.MagSoftCrawlWarpVecEnv`); :func:`restart_from` puts a
:class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv` in the same state, so that the two can be stepped side by side
(the tests, ``python -m magsoft_env.bench.warp_bench``).
"""

from __future__ import annotations

import mujoco
import numpy as np


def restart_from(env, qpos, qvel=None):
    """Put the single env ``env`` (field mode, just reset) at joint positions ``qpos`` (and velocities ``qvel``,
    default zero) at time zero, zero field, and redo its reset's bookkeeping; returns ``(obs, info)`` as
    ``env.reset`` does."""
    env = env.unwrapped
    sim = env.sim
    sim.reset()
    sim.set_field((0.0, 0.0))
    sim.data.qpos[:] = np.asarray(qpos, dtype=float)
    sim.data.qvel[:] = 0.0 if qvel is None else np.asarray(qvel, dtype=float)
    mujoco.mj_forward(sim.model, sim.data)
    sim._health.reset(np.zeros(3))
    env._field = np.zeros(2)
    env._last_action = np.zeros(4)
    env._com = env.com_position()
    env._com_vel = np.zeros(2)
    env._broken = False
    env._episode_forward = 0.0
    env._flipped = False
    env._tracker = sim.orientation_tracker()
    pts = sim.pose().centreline
    env._highest_clearance = float(np.min(pts[:, 2])) - 0.5 * env.gait.beam.thickness
    env._lowest_cos = float(env._limits_of(pts[:, None, :])[2, 0])
    env._airborne = 0
    env._substeps = 0
    env._last_obs = env._get_obs()
    return env._last_obs, env._info(0.0)


__all__ = ["restart_from"]

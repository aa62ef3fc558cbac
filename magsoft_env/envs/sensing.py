"""A tracking camera between the robot and the agent: frame rate, latency, position noise and dropped frames.

The steering envs (``MagSoftSteer-v0``, ``MagSoftCoils-v0``, ``MagSoftMagnet-v0``) observe the strip's tracked
positions exactly and at once. A laboratory tracks them with a camera: frames come at its rate, arrive some frames
late, carry pixel noise, and some are lost. :class:`SensingWrapper` puts that between the env and the agent,
without touching the physics::

    env = SensingWrapper(gym.make("MagSoftSteer-v0"), frame_rate=25.0, latency_frames=1,
                         position_noise=0.1e-3, dropout=0.05)

- ``frame_rate`` (Hz): a frame is taken when the control clock passes a multiple of ``1 / frame_rate``; between
  frames the agent keeps the last delivered one. None: every control step (the env's own rate).
- ``latency_frames``: a frame reaches the agent that many frames after it was taken (0: at once).
- ``position_noise`` (m): Gaussian noise of that standard deviation on every tracked position entry of a frame
  (the env's ``position_observation_indices()``; all entries where the env has none), independently per entry.
- ``dropout``: the probability that a frame is lost (the agent keeps the previous one).

The noise and the dropout draw from the wrapper's own generator, seeded by ``reset(seed=...)`` (a different
stream from the env's), so an episode replays exactly.
"""

from __future__ import annotations

import collections
import math

import gymnasium as gym
import numpy as np

#: Largest latency (frames) and position noise (m) accepted.
MAX_LATENCY_FRAMES = 1000
MAX_POSITION_NOISE = 0.1


class SensingWrapper(gym.Wrapper):
    """Frame rate, latency, position noise and dropout on an env's observation (see the module docstring).

    Parameters
    ----------
    env : gymnasium.Env
    frame_rate : float or None
        Camera frames per second (Hz), in (0, 1 / ctrl_dt]; None: one frame per control step.
    latency_frames : int
        Frames between taking a frame and delivering it, in [0, 1000].
    position_noise : float
        Standard deviation (m) of the noise on each position entry, in [0, 0.1].
    dropout : float
        Probability that a frame is lost, in [0, 1).
    """

    def __init__(self, env, *, frame_rate: float | None = None, latency_frames: int = 0,
                 position_noise: float = 0.0, dropout: float = 0.0):
        super().__init__(env)
        base = env.unwrapped
        ctrl_dt = float(getattr(base, "ctrl_dt", getattr(base, "dt", 0.0)) or 0.0)
        if frame_rate is not None:
            if isinstance(frame_rate, bool) or not isinstance(frame_rate, (int, float)) or not math.isfinite(
                    frame_rate) or frame_rate <= 0:
                raise ValueError(f"frame_rate must be a positive rate (Hz) or None, got {frame_rate!r}.")
            if ctrl_dt > 0 and frame_rate > 1.0 / ctrl_dt * (1 + 1e-9):
                raise ValueError(f"frame_rate must be at most the control rate 1 / ctrl_dt = {1.0 / ctrl_dt:g} Hz "
                                 f"(one frame per step at most), got {frame_rate!r} Hz.")
            if ctrl_dt <= 0:
                raise ValueError("frame_rate needs an env with a control interval (ctrl_dt); this one has none.")
        if isinstance(latency_frames, bool) or not isinstance(latency_frames, (int, np.integer)) or not (
                0 <= latency_frames <= MAX_LATENCY_FRAMES):
            raise ValueError(f"latency_frames must be an integer in [0, {MAX_LATENCY_FRAMES}], got {latency_frames!r}.")
        if isinstance(position_noise, bool) or not isinstance(position_noise, (int, float)) or not (
                0.0 <= position_noise <= MAX_POSITION_NOISE):
            raise ValueError(f"position_noise must lie in [0, {MAX_POSITION_NOISE:g}] m (metres: 0.1 mm is 1e-4), "
                             f"got {position_noise!r}.")
        if isinstance(dropout, bool) or not isinstance(dropout, (int, float)) or not 0.0 <= dropout < 1.0:
            raise ValueError(f"dropout must lie in [0, 1) (a probability), got {dropout!r}.")
        self.frame_rate = None if frame_rate is None else float(frame_rate)
        self.latency_frames = int(latency_frames)
        self.position_noise = float(position_noise)
        self.dropout = float(dropout)
        self._ctrl_dt = ctrl_dt
        self._rng = np.random.default_rng()
        self._queue: collections.deque = collections.deque()
        self._shown = None
        self._t = 0.0
        self._next_frame = 0.0
        self._index = None

    def _positions(self) -> np.ndarray:
        if self._index is None:
            fn = getattr(self.env.unwrapped, "position_observation_indices", None)
            self._index = np.asarray(fn() if callable(fn) else np.arange(self.observation_space.shape[0]))
        return self._index

    def _frame(self, obs: np.ndarray) -> np.ndarray:
        frame = np.array(obs, dtype=np.float32, copy=True)
        if self.position_noise > 0.0:
            idx = self._positions()
            frame[idx] += self._rng.normal(0.0, self.position_noise, size=idx.size).astype(np.float32)
        space = self.observation_space
        return np.clip(frame, space.low, space.high) if isinstance(space, gym.spaces.Box) else frame

    def _deliver(self, obs, *, first: bool) -> np.ndarray:
        due = first or self.frame_rate is None or self._t >= self._next_frame - 1e-9 * max(1.0, self._t)
        if due:
            if self.frame_rate is not None:
                self._next_frame += 1.0 / self.frame_rate
            lost = not first and self.dropout > 0.0 and self._rng.random() < self.dropout
            self._queue.append(None if lost else self._frame(obs))
            while len(self._queue) > self.latency_frames:
                frame = self._queue.popleft()
                if frame is not None:
                    self._shown = frame
        if self._shown is None:  # nothing has arrived yet: the first frame, as the camera's initial image
            self._shown = self._frame(obs)
        return self._shown.copy()

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        if seed is not None:
            self._rng = np.random.default_rng([int(seed), 0x5E45])  # not the env's stream
        self._queue.clear()
        self._shown = None
        self._t = 0.0
        self._next_frame = 0.0
        return self._deliver(obs, first=True), info

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._t += self._ctrl_dt
        return self._deliver(obs, first=False), reward, terminated, truncated, info


__all__ = ["MAX_LATENCY_FRAMES", "MAX_POSITION_NOISE", "SensingWrapper"]

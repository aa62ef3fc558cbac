"""Stable-Baselines3 callbacks for rl-zoo3 blocks (``callback: [{magsoft_env.rl.callbacks.WallTimeLimit:
{max_seconds: 600}}]``); Stable-Baselines3 is imported when this module is."""

from __future__ import annotations

import time

from stable_baselines3.common.callbacks import BaseCallback


class WallTimeLimit(BaseCallback):
    """Stop learning after ``max_seconds`` of wall time (s); rl-zoo3 then saves the model as at the end.

    Parameters
    ----------
    max_seconds : float
        Wall-time budget for learning (s), > 0.
    """

    def __init__(self, max_seconds: float, verbose: int = 1):
        super().__init__(verbose)
        if isinstance(max_seconds, bool) or not isinstance(max_seconds, int | float) or not max_seconds > 0:
            raise ValueError(f"max_seconds must be a number > 0 (s), got {max_seconds!r}.")
        self.max_seconds = float(max_seconds)
        self.t0 = None

    def _on_training_start(self) -> None:
        self.t0 = time.perf_counter()

    def _on_step(self) -> bool:
        if time.perf_counter() - self.t0 < self.max_seconds:
            return True
        if self.verbose:
            print(f"WallTimeLimit: stopping after {self.max_seconds:g} s at {self.num_timesteps} steps")
        return False


__all__ = ["WallTimeLimit"]

"""Stable-Baselines3 callbacks for rl-zoo3 blocks (``callback: [{magsoft_env.rl.callbacks.WallTimeLimit:
{max_seconds: 600}}]``) and scripts (progress lines); Stable-Baselines3 is imported when this module is."""

from __future__ import annotations

import sys
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


class ProgressLines(BaseCallback):
    """A line on stderr at every ``every`` (a fraction) of ``total_timesteps``: steps done, elapsed wall time and
    steps/s. Plain lines, not a bar, so that a log file or a pipe shows them too.

    Parameters
    ----------
    total_timesteps : int
        The ``total_timesteps`` given to ``learn`` (>= 1).
    every : float
        Fraction of it between lines, in (0, 1] (default 0.1: ten lines).
    label : str
        Prefix of each line.
    """

    def __init__(self, total_timesteps: int, *, every: float = 0.1, label: str = "training", verbose: int = 0):
        super().__init__(verbose)
        if isinstance(total_timesteps, bool) or not isinstance(total_timesteps, int) or total_timesteps < 1:
            raise ValueError(f"total_timesteps must be an integer >= 1, got {total_timesteps!r}.")
        if isinstance(every, bool) or not isinstance(every, int | float) or not 0 < every <= 1:
            raise ValueError(f"every must be a fraction in (0, 1], got {every!r}.")
        self.total = total_timesteps
        self.step = max(1, round(every * total_timesteps))
        self.label = label
        self.t0 = None
        self._next = self.step

    def _on_training_start(self) -> None:
        self.t0 = time.perf_counter()
        self._next = self.num_timesteps + self.step
        print(f"{self.label}: {self.total} steps ...", file=sys.stderr, flush=True)

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            dt, n = time.perf_counter() - self.t0, self.num_timesteps
            print(f"{self.label}: {n}/{self.total} steps ({100 * n / self.total:.0f} %), {dt:.0f} s, "
                  f"{n / max(dt, 1e-9):.0f} steps/s", file=sys.stderr, flush=True)
            self._next += self.step
        return True


__all__ = ["ProgressLines", "WallTimeLimit"]

"""MagSoftChannel-v1: crawl through the paper's hollow box (Fig. 5a: 42 x 8.5 x 7.6 mm inside)."""

from __future__ import annotations

from ..sim import CHANNEL_SIZE
from .crawl import MagSoftCrawlEnv

#: Default gap between the beam's right end and the channel entrance (m).
DEFAULT_ENTRANCE_GAP = 2e-3
#: Largest gap accepted (m): a metre is a unit mistake (mm given as m).
MAX_GAP = 1.0


class MagSoftChannelEnv(MagSoftCrawlEnv):
    """
    ## Description

    :class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv` in the ``channel`` scene: the paper's
    hollow box (inside 42 x 8.5 x 7.6 mm) starts ``entrance_gap`` to the right of the beam.
    The goal is to crawl through it: success when the whole beam lies past the far end.
    The crawl limit defaults to ``crawl_mode="height"`` with ``max_height`` = the ceiling
    height, 7.6 mm, everywhere: a beam that rises higher outside the box could not enter it.

    ## Action Space, Observation Space

    As ``MagSoftCrawl-v1`` (field mode by default).

    ## Rewards

    As ``MagSoftCrawl-v1`` (target direction +x) plus ``reward_success = success_reward`` on
    the step the beam's base end passes the far end of the box.

    ## Starting State

    As ``MagSoftCrawl-v1``; the entrance is at ``x = L + entrance_gap``.

    ## Episode End

    Termination on success or a broken crawl limit; truncation after 1500 steps (30 s) or on
    instability (``info["truncation_reason"]``).

    ## Arguments

    ``entrance_gap`` (m, default 2e-3, in [0, 1]: the beam starts outside the box),
    ``success_reward`` (default 100), and every argument of ``MagSoftCrawl-v1``. Default
    ``crawl_mode="height"``.

    ## Numerics

    As ``MagSoftCrawl-v1``: the robot's own for this scene (a robot file's ``simulation: {scenes: {channel:
    ...}}``, else its floor numerics; paper-5a: 80 segments at 0.1 ms, 1.9 % on the floor). Under the ceiling
    the contact events change, and so does what converges (docs/convergence.md, section 5, measured with the
    beam inside the box): paper-5c, 20 segments at 0.2 ms on the floor (2 %), is 27 % off inside the box, where
    40 segments at 0.1 ms are within 4.8 % (robust) and 80 at 0.05 ms within 1.8 %; its file states 40 at 0.1 ms
    for the channel, which this env uses. paper-5a does not crawl inside the box
    (under 0.05 mm/s either way at every setting from 20 segments and 0.1 ms, against +0.49 mm/s on the
    floor), so only its floor crawl up to the entrance has a measured error.

    ## Version History

    - v0: initial version (magsoft_env 0.1).
    - v1 (v0 removed): the robot's own numerics by default: paper-5a runs 80 segments at 0.1 ms (was 20 at
      0.2 ms), so the observation has 168 entries (was 48); ``fidelity="fast"`` restores the old numerics. The
      crawl limits hold at every substep, with part of the beam on the floor (as ``MagSoftCrawl-v1``).
    """

    _scene = "channel"

    def __init__(self, robot="paper-5a", *, entrance_gap: float = DEFAULT_ENTRANCE_GAP,
                 success_reward: float = 100.0, crawl_mode: str = "height", **kwargs):
        from ..cases.robots import resolve_robot
        from ..validate import finite_number, nonnegative

        robot = resolve_robot(robot)
        length = robot.beam.length
        # the beam starts outside the box (a negative gap would start it inside)
        gap = finite_number("entrance_gap", entrance_gap, unit="m")
        if not 0.0 <= gap <= MAX_GAP:
            raise ValueError(
                f"entrance_gap must lie in [0, {MAX_GAP:g}] m (a negative gap starts the beam inside the channel), "
                f"got {entrance_gap!r}."
            )
        self.success_reward = nonnegative("success_reward", success_reward)
        self.entrance_x = length + gap
        self.exit_x = self.entrance_x + CHANNEL_SIZE[0]
        super().__init__(robot, crawl_mode=crawl_mode, feature_x=self.entrance_x, **kwargs)

    def _is_success(self) -> bool:
        return bool(self.sim.centerline()[0].min() > self.exit_x)

    def _success_reward(self) -> float:
        return self.success_reward if self._is_success() else 0.0

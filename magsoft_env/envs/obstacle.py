"""MagSoftObstacle-v1: crawl over the paper's block (Fig. 5b: 7 x 5.5 x 2 mm)."""

from __future__ import annotations

from ..sim import OBSTACLE_SIZE
from .crawl import MagSoftCrawlEnv

#: Default gap between the beam's right end and the block's left face (m).
DEFAULT_OBSTACLE_GAP = 2e-3
#: Largest gap accepted (m): a metre is a unit mistake (mm given as m).
MAX_GAP = 1.0


class MagSoftObstacleEnv(MagSoftCrawlEnv):
    """
    ## Description

    :class:`~magsoft_env.envs.crawl.MagSoftCrawlEnv` in the ``obstacle`` scene: the paper's
    7 x 5.5 x 2 mm block stands ``obstacle_gap`` to the right of the beam. The goal is to
    climb over it: success when the whole beam lies past the block's right face.

    ## Action Space, Observation Space

    As ``MagSoftCrawl-v1`` (field mode by default).

    ## Rewards

    As ``MagSoftCrawl-v1`` (target direction +x) plus ``reward_success = success_reward`` on
    the step the beam's base end passes the block.

    ## Starting State

    As ``MagSoftCrawl-v1``; the block's left face is at ``x = L + obstacle_gap``.

    ## Episode End

    Termination on success or a broken crawl limit; truncation after 1500 steps (30 s) or on
    instability (``info["truncation_reason"]``).

    ## Arguments

    ``obstacle_gap`` (m, default 2e-3, in [h/2, 1]: h/2 = 0.565 mm, where the block's face
    touches the resting beam's rounded end), ``success_reward`` (default 100), and every
    argument of ``MagSoftCrawl-v1``. Default robot ``"paper-5b"`` (the paper's climber).

    ## Version History

    - v0: initial version (magsoft_env 0.1).
    - v1 (v0 removed): the robot's own numerics by default: paper-5b runs 80 segments at 0.025 ms (was 20 at
      0.2 ms, 31 % off), so the observation has 168 entries (was 48); ``fidelity="fast"`` restores the old numerics.
      The rotation limit holds at every substep (as ``MagSoftCrawl-v1``; no floor-contact limit here: on the
      block the whole beam is off the floor).
    """

    _scene = "obstacle"

    def __init__(self, robot="paper-5b", *, obstacle_gap: float = DEFAULT_OBSTACLE_GAP,
                 success_reward: float = 100.0, **kwargs):
        from ..cases.robots import resolve_robot
        from ..validate import finite_number, nonnegative

        robot = resolve_robot(robot)
        beam = robot.beam
        length = beam.length
        # the rod's colliders (radius h/2) reach h/2 past its end: a block face nearer than that
        # would start inside the resting beam
        lo = 0.5 * beam.thickness
        gap = finite_number("obstacle_gap", obstacle_gap, unit="m")
        if not lo <= gap <= MAX_GAP:
            raise ValueError(
                f"obstacle_gap must lie in [{lo:g}, {MAX_GAP:g}] m (at least h/2 = {lo * 1e3:.3g} mm: a nearer block "
                f"would cut into the resting beam's rounded end), got {obstacle_gap!r}."
            )
        self.success_reward = nonnegative("success_reward", success_reward)
        self.obstacle_x = length + gap
        self.clear_x = self.obstacle_x + OBSTACLE_SIZE[0]
        # on top of the block the whole beam is above the floor: no clearance limit here
        kwargs.setdefault("max_clearance", None)
        super().__init__(robot, feature_x=self.obstacle_x, **kwargs)

    def _is_success(self) -> bool:
        return bool(self.sim.centerline()[0].min() > self.clear_x)

    def _success_reward(self) -> float:
        return self.success_reward if self._is_success() else 0.0

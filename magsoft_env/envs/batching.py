"""What the batched environments share, the CPU threads' (:mod:`~magsoft_env.envs.vector`) and MuJoCo Warp's
(:mod:`~magsoft_env.envs.warp_vector`): their counts, their reset arguments and the rods each runs."""

from __future__ import annotations

import numpy as np

from ..rods import DEFAULT_ROD


def count(name: str, value, *, lo: int = 1) -> int:
    """``value`` as an int, or a ValueError naming ``name``: it must be an integer >= ``lo``."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < lo:
        raise ValueError(f"{name} must be an integer >= {lo}, got {value!r}.")
    return int(value)


def reset_arguments(seed, options: dict | None, num_envs: int) -> tuple[list, np.ndarray | None, dict]:
    """A batched env's ``reset`` arguments: the robots' seeds (``seed`` None, an int: robot ``i`` gets ``seed + i``
    as ``SyncVectorEnv``, or one seed per robot), the boolean ``options["reset_mask"]`` (None: every robot; it must
    select at least one) and the other options, each checked (ValueError)."""
    n = num_envs
    if seed is None:
        seeds = [None] * n
    elif isinstance(seed, (int, np.integer)) and not isinstance(seed, (bool, np.bool_)):
        seeds = [int(seed) + i for i in range(n)]
    else:
        seeds = list(seed)
        if len(seeds) != n:
            raise ValueError(f"seed must be None, an int or a list of {n} seeds (one per robot), got {seed!r}.")
    rest = dict(options) if options else {}
    mask = rest.pop("reset_mask", None)
    if mask is not None:
        if not isinstance(mask, np.ndarray) or mask.dtype != np.bool_ or mask.shape != (n,):
            raise ValueError(f"options['reset_mask'] must be a boolean numpy array of shape ({n},), got {mask!r}.")
        if not mask.any():
            raise ValueError("options['reset_mask'] must select at least one robot, got none.")
    return seeds, mask, rest


def refuse_warp_rod(rod) -> None:
    """ValueError unless ``rod`` is the planar chain, the one rod ``backend="warp"`` runs (checked before Warp is
    imported)."""
    if rod != DEFAULT_ROD:
        raise ValueError(
            f"backend='warp' runs the planar hinge chain (rod='planar'), got rod={rod!r}: the 3D strip is not on "
            "MuJoCo Warp here (its magnetic couples are written from Python every substep, from the strip's material "
            "frame; MJWarp 4.0 steps the strip's elasticity but not its floor contact as MuJoCo does, docs/gpu.md). "
            "Use the CPU batch for it: gym.make_vec(..., rod='cable', backend='cpu').")


__all__ = ["count", "refuse_warp_rod", "reset_arguments"]

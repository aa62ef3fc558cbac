"""Readouts of a crawler's body as a whole: its orientation, and whether it flipped end over end.

One definition, used by the gaits (:func:`~magsoft_env.sim.gait.run_gait`), the crawl environments' ``info``
and the command line:

- the body's **orientation** is the length-weighted mean tangent angle of its pieces (rad, from +x toward
  +z), with the pieces' angles unwrapped along the chain and anchored to the tip's continuous angle
  (:meth:`Simulator.tip_angle <magsoft_env.sim.Simulator.tip_angle>`, the sum of the joint angles), so it is
  continuous in time and counts whole turns: a beam that rolled end over end once reads about +-pi, not 0;
- the body **flipped** (tumbled) when ``|orientation|`` exceeded :data:`FLIP_ANGLE` (pi / 2, past vertical)
  at any time of the run.

A crawl bends the beam but keeps its mean direction near 0 (the paper-5c gait: at most a few degrees); a
tumble turns the whole body past vertical.

Examples
--------
>>> import numpy as np
>>> round(body_orientation(np.array([0.1, 0.3]), np.array([1.0, 3.0])), 12)   # (0.1 + 0.9) / 4
0.25
>>> round(body_orientation(np.array([3.1, -3.1]), np.array([1.0, 1.0])), 6)   # across +-pi: unwrapped
3.141593
>>> is_flipped(2.0), is_flipped(-1.0)
(True, False)
"""

from __future__ import annotations

import math

import numpy as np

#: |orientation| above which the body counts as flipped (rad): past vertical.
FLIP_ANGLE = 0.5 * math.pi
_TURN = 2.0 * math.pi


def body_orientation(angles, lengths, *, anchor: float | None = None) -> float:
    """Length-weighted mean tangent angle of a chain of pieces (rad).

    Parameters
    ----------
    angles : (n,) array_like
        Tangent angle of each piece (rad), in chain order, each known modulo 2 pi (e.g. in (-pi, pi]).
    lengths : (n,) array_like
        Length of each piece (m, or any unit: only the weights' ratios count), >= 0, not all zero.
    anchor : float or None
        The continuous angle (rad) of the last piece (e.g. the tip's, a sum of joint angles): the
        unwrapped chain is shifted by whole turns so that its last piece reads nearest to it. None: the
        first piece stays in (-pi, pi].

    Returns
    -------
    float
        ``sum(l_i theta_i) / sum(l_i)`` with ``theta`` unwrapped along the chain (neighbouring pieces
        differ by less than pi).
    """
    a = np.asarray(angles, dtype=float).ravel()
    w = np.asarray(lengths, dtype=float).ravel()
    if a.shape != w.shape or a.size == 0:
        raise ValueError(f"angles and lengths must be two non-empty arrays of one shape, got {a.shape} and {w.shape}.")
    total = float(np.sum(w))
    if not (total > 0 and float(np.min(w)) >= 0):
        raise ValueError("lengths must be >= 0 and not all zero.")
    return _mean_angle(a, w, total, anchor)


def _mean_angle(a: np.ndarray, w: np.ndarray, total: float, anchor: float | None) -> float:
    """:func:`body_orientation` of checked float arrays ``a``, ``w`` (``total = w.sum()``)."""
    # unwrapped along the chain: each neighbour's difference brought into [-pi, pi) (np.unwrap costs 4 x more)
    rel = np.cumsum(np.remainder(np.diff(a) + math.pi, _TURN) - math.pi)  # each piece's angle minus the first's
    first = float(a[0])
    if anchor is not None:
        if not math.isfinite(anchor):  # a state gone non-finite (the simulator has reported it): no orientation
            return math.nan
        last = first + (float(rel[-1]) if rel.size else 0.0)
        first += _TURN * round((float(anchor) - last) / _TURN)
    return first + float(w[1:] @ rel) / total


def orientation(sim) -> float:
    """The body's orientation (rad) in a :class:`~magsoft_env.sim.Simulator`'s current state: the
    length-weighted mean tangent angle of its pieces (:meth:`Simulator.angles`, weights from
    :meth:`Simulator.arc_length`), continuous in time through :meth:`Simulator.tip_angle`."""
    w = np.diff(sim.arc_length())  # the pieces' lengths: positive by construction, no checks needed
    return _mean_angle(sim.angles(), w, float(w.sum()), sim.tip_angle())


def is_flipped(orientation_rad: float) -> bool:
    """True when ``|orientation_rad|`` is past vertical (> :data:`FLIP_ANGLE`)."""
    return bool(abs(float(orientation_rad)) > FLIP_ANGLE)


__all__ = ["FLIP_ANGLE", "body_orientation", "is_flipped", "orientation"]

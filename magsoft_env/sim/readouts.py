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


class ChainOrientation:
    """The orientation end over end of a rod in the x-z plane (rad), from its pose: the length-weighted mean
    tangent angle of its pieces, anchored to the tip's continuous angle (:func:`orientation`); its heading on the
    floor is +x, always. The tracker of the planar chain (``RodBackend.orientation_tracker``)."""

    heading = 0.0

    def track(self, pose) -> float:
        """The orientation (rad) of a :class:`~magsoft_env.sim.backend.Pose`."""
        t, w = pose.tangents, pose.lengths
        return _mean_angle(np.arctan2(t[:, 2], t[:, 0]), w, float(w.sum()), pose.tip_angle)


def orientation(sim) -> float:
    """The body's orientation (rad) in a :class:`~magsoft_env.sim.Simulator`'s current state: the
    length-weighted mean tangent angle of its pieces (:meth:`Simulator.angles`, weights from
    :meth:`Simulator.arc_length`), continuous in time through :meth:`Simulator.tip_angle`."""
    w = np.diff(sim.arc_length())  # the pieces' lengths: positive by construction, no checks needed
    return _mean_angle(sim.angles(), w, float(w.sum()), sim.tip_angle())


class PitchTracker:
    """The 3D strip's orientation end over end (rad), continuous in time, not counting turns on the floor.

    The body's direction is its length-weighted mean tangent ``T``. Its orientation is the angle of ``T`` from a
    horizontal reference heading ``h`` toward +z, in the vertical plane through ``h``, unwrapped between
    samples. While the body lies within 45 deg of the floor, ``h`` follows its heading on the floor (turns about
    z, however far, are not end over end), taking whichever of the heading and its reverse is nearer ``h`` (a
    body that has flipped keeps reading about +-pi); steeper, ``h`` is held, so that passing through vertical
    reads as the angle going past +-pi / 2. In the plane (``T_y = 0``, ``h = +x``) it is the planar
    :func:`orientation` for bodies bent less than a half turn. Samples must be dense enough that the body turns
    less than 90 deg between them.
    """

    #: Steepest elevation of T (rad) at which the reference heading still follows the body.
    FOLLOW_ELEVATION = 0.25 * math.pi

    def __init__(self):
        self.heading = 0.0  # the reference heading h (rad from +x toward +y)
        self.value: float | None = None

    def update(self, tangents, lengths) -> float:
        """The orientation (rad) for edge ``tangents`` (shape ``(n, 3)``) of ``lengths`` (shape ``(n,)``)."""
        t = np.asarray(lengths, dtype=float) @ np.asarray(tangents, dtype=float)
        horiz = math.hypot(t[0], t[1])
        if not np.all(np.isfinite(t)):
            return math.nan
        if math.atan2(abs(t[2]), horiz) < self.FOLLOW_ELEVATION:
            phi = math.atan2(t[1], t[0])
            if self.value is None:
                self.heading = phi
            else:  # the heading or its reverse, whichever is nearer the reference
                d = math.remainder(phi - self.heading, _TURN)
                self.heading += d if abs(d) <= 0.5 * math.pi else math.remainder(d + math.pi, _TURN)
        along = t[0] * math.cos(self.heading) + t[1] * math.sin(self.heading)
        a = math.atan2(t[2], along)
        if self.value is not None:
            a += _TURN * round((self.value - a) / _TURN)
        self.value = a
        return a

    def track(self, pose) -> float:
        """:meth:`update` with a :class:`~magsoft_env.sim.backend.Pose`'s tangents and piece lengths."""
        return self.update(pose.tangents, pose.lengths)


def pitch_orientation(sim, tracker) -> float:
    """A tracker (:class:`PitchTracker`, :class:`ChainOrientation`) of a :class:`~magsoft_env.sim.Simulator`,
    updated with its pose now."""
    return tracker.track(sim.pose())


def is_flipped(orientation_rad: float) -> bool:
    """True when ``|orientation_rad|`` is past vertical (> :data:`FLIP_ANGLE`)."""
    return bool(abs(float(orientation_rad)) > FLIP_ANGLE)


__all__ = ["FLIP_ANGLE", "ChainOrientation", "PitchTracker", "body_orientation", "is_flipped", "orientation",
           "pitch_orientation"]

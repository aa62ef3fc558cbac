"""A source whose pose is an input over time: a magnet held by a robot arm, a coil on a moving stage.

At time ``t`` the source's own frame has its origin at ``p(t)`` and its axes the columns of ``R(t)``::

    B(x, t) = R B_0(R^T (x - p))        G(x, t) = R G_0(R^T (x - p)) R^T

(``B_0``, ``G_0`` the source in its own frame). The pose is read at ``t`` only: the field is quasi-static (no
eddy currents, no motional induction), right for a magnet moved at robot-arm speeds.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..validate import finite_number
from .base import Source, Transformed, position3, rotation_matrix, unit_vector


def rotation_about(axis, angle: float) -> np.ndarray:
    """The rotation matrix (3, 3) of ``angle`` (rad) about ``axis`` (3,) (right-hand rule; Rodrigues' formula)."""
    k = unit_vector("rotation_about axis", axis)
    a = finite_number("rotation_about angle", angle, unit="rad")
    K = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + np.sin(a) * K + (1.0 - np.cos(a)) * (K @ K)


@dataclass(frozen=True, eq=False, init=False)
class MovingSource:
    """A source moved rigidly along a trajectory: :meth:`at` gives the posed source at a time.

    Parameters
    ----------
    source : Source
        The source in its own frame (e.g. a magnet centred at its origin).
    position : callable or array_like, shape (3,)
        ``t -> p(t)`` (m), or a fixed position.
    orientation : callable or array_like, shape (3, 3), optional
        ``t -> R(t)`` (a rotation matrix or a scipy Rotation: the source's axes as columns), or a fixed one;
        default the identity.

    Examples
    --------
    >>> import numpy as np
    >>> from magsoft_env.fields import PointDipole
    >>> arm = MovingSource(PointDipole(position=(0, 0, 0), moment=(0, 0, 1.0)),
    ...                    position=lambda t: (0.0, 0.0, 0.1 + 0.01 * t),
    ...                    orientation=lambda t: rotation_about((1, 0, 0), 0.5 * t))
    >>> B, G = arm.field_and_gradient(np.zeros((1, 3)), t=0.0)
    >>> round(float(B[0, 2]), 12)   # 2 mu0/(4 pi) m / 0.1^3
    0.0002
    """

    source: Source
    position: Callable | np.ndarray
    orientation: Callable | np.ndarray | None

    def __init__(self, source, *, position, orientation=None):
        if not isinstance(source, Source):
            raise ValueError(f"MovingSource source must be a field source, got {type(source).__name__}.")
        object.__setattr__(self, "source", source)
        object.__setattr__(self, "position", position if callable(position)
                           else position3("MovingSource position", position))
        if orientation is not None and not callable(orientation):
            orientation = rotation_matrix("MovingSource orientation", orientation)
        object.__setattr__(self, "orientation", orientation)

    def pose(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(p, R)`` at time ``t`` (s): the position (3,) in m and the rotation (3, 3), both checked."""
        t = finite_number("MovingSource t", t, unit="s")
        p = self.position(t) if callable(self.position) else self.position
        p = position3(f"MovingSource position at t = {t!r} s", p)
        if self.orientation is None:
            R = np.eye(3)
        elif callable(self.orientation):
            R = rotation_matrix(f"MovingSource orientation at t = {t!r} s", self.orientation(t))
        else:
            R = self.orientation
        return p, R

    def at(self, t: float) -> Transformed:
        """The source posed at time ``t`` (s)."""
        p, R = self.pose(t)
        return Transformed(self.source, p, R)

    def field_and_gradient(self, points, *, t: float) -> tuple[np.ndarray, np.ndarray]:
        """Field (T, (n, 3)) and gradient (T/m, (n, 3, 3)) at ``points`` (m) at time ``t`` (s)."""
        return self.at(t).field_and_gradient(points)


__all__ = ["MovingSource", "rotation_about"]

"""What every field source shares: the interface, input checks, poses, the uniform field and sums.

A source is anything with ``field_and_gradient(points) -> (B, G)``: ``points`` of shape ``(n, 3)`` in m,
``B`` of shape ``(n, 3)`` in T and ``G`` of shape ``(n, 3, 3)`` in T/m with ``G[i, a, b] = dB_a / dx_b`` at
point ``i``. A piece of rod of moment ``m`` (A m^2) there feels the couple ``m x B`` and the force ``G^T m``
(``= G m`` where the field is curl-free).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from ..spec import MU0
from ..spec.field import as_field
from ..validate import finite_array

#: mu0 / (4 pi) (T m / A), the dipole formula's constant.
MU0_4PI = MU0 / (4.0 * math.pi)
#: Largest distance from the origin accepted for a point or a source position (m): anything farther is almost
#: surely a length in mm given as metres.
MAX_COORDINATE = 1e3
#: Largest deviation of R^T R from the identity (and of det R from 1) accepted for a rotation matrix.
ROTATION_TOL = 1e-9
_EYE = np.eye(3)


class Source(ABC):
    """A magnetic field source: :meth:`field_and_gradient` at points; ``a + b`` is their :class:`SourceSum`."""

    @abstractmethod
    def field_and_gradient(self, points) -> tuple[np.ndarray, np.ndarray]:
        """Field and its gradient at ``points``.

        Parameters
        ----------
        points : array_like, shape (n, 3)
            Positions (m).

        Returns
        -------
        B : ndarray, shape (n, 3)
            Field (T).
        G : ndarray, shape (n, 3, 3)
            Gradient (T/m), ``G[i, a, b] = dB_a / dx_b``.
        """

    def field(self, points) -> np.ndarray:
        """The field ``B`` (T), shape (n, 3), at ``points`` (m), shape (n, 3)."""
        return self.field_and_gradient(points)[0]

    def __add__(self, other):
        if not isinstance(other, Source):
            return NotImplemented
        return SourceSum((self, other))

    def __radd__(self, other):
        if isinstance(other, (int, float)) and other == 0:  # sum([...]) starts from 0
            return self
        return NotImplemented


# ----------------------------------------------------------------------------------------------- input checks


def as_points(points, name: str = "points") -> np.ndarray:
    """``points`` as a float array of shape (n, 3) (m), n >= 1, finite, within :data:`MAX_COORDINATE` of the
    origin; a ValueError naming ``name`` otherwise."""
    if (isinstance(points, np.ndarray) and points.dtype == np.float64 and points.ndim == 2
            and points.shape[1] == 3 and points.shape[0] > 0):
        p = points
        if not np.isfinite(p).all():
            bad = np.argwhere(~np.isfinite(p))[0][0]
            raise ValueError(f"{name} must be finite (m), got {p[bad].tolist()!r} at {name}[{bad}].")
    else:
        p = finite_array(name, points)
        if p.ndim != 2 or p.shape[1] != 3 or p.shape[0] == 0:
            hint = " (a single point is [[x, y, z]])" if p.shape == (3,) else ""
            raise ValueError(f"{name} must have shape (n, 3) with n >= 1 (m), got shape {p.shape}{hint}.")
    if np.abs(p).max() > MAX_COORDINATE:
        bad = int(np.argmax(np.abs(p).max(axis=1)))
        raise ValueError(f"{name} must lie within {MAX_COORDINATE:g} m of the origin (positions are in metres: "
                         f"10 mm is 0.01), got {p[bad].tolist()!r} at {name}[{bad}].")
    return p


def vector3(name: str, value, *, unit: str, limit: float | None = None) -> np.ndarray:
    """``value`` as a finite float array of shape (3,); with ``limit``, its norm at most ``limit`` (``unit``)."""
    v = finite_array(name, value)
    if v.shape != (3,):
        raise ValueError(f"{name} must have shape (3,) ({unit}), got shape {v.shape}: {np.asarray(value).tolist()!r}.")
    if limit is not None and np.linalg.norm(v) > limit:
        raise ValueError(f"{name} must have a norm of at most {limit:g} {unit}, got {v.tolist()!r} "
                         f"(norm {np.linalg.norm(v):g} {unit}).")
    return v


def position3(name: str, value) -> np.ndarray:
    """A position (m), shape (3,), within :data:`MAX_COORDINATE` of the origin."""
    return vector3(name, value, unit="m", limit=MAX_COORDINATE)


def unit_vector(name: str, value) -> np.ndarray:
    """``value`` (shape (3,), not zero) normalized to length 1."""
    v = vector3(name, value, unit="dimensionless")
    n = float(np.linalg.norm(v))
    if n == 0.0:
        raise ValueError(f"{name} must be a non-zero direction (3,), got {v.tolist()!r}.")
    return v / n


def rotation_matrix(name: str, value) -> np.ndarray:
    """A rotation as a (3, 3) matrix (orthonormal, det +1, within :data:`ROTATION_TOL`); a
    ``scipy.spatial.transform.Rotation`` is taken too."""
    if hasattr(value, "as_matrix") and callable(value.as_matrix):
        value = value.as_matrix()
    R = finite_array(name, value)
    if R.shape != (3, 3):
        raise ValueError(f"{name} must be a rotation matrix of shape (3, 3), got shape {R.shape}.")
    err = float(np.abs(R.T @ R - _EYE).max())
    det = float(np.linalg.det(R))
    if err > ROTATION_TOL or abs(det - 1.0) > ROTATION_TOL:
        raise ValueError(f"{name} must be a rotation matrix (R^T R = I to {ROTATION_TOL:g}, det R = +1), got "
                         f"max |R^T R - I| = {err:.3g} and det R = {det:.6g}: {R.tolist()!r}.")
    return R


def frame_from_axis(axis: np.ndarray) -> np.ndarray:
    """A rotation matrix whose third column is the unit vector ``axis`` (its first two complete a right-handed
    frame): local z along ``axis``."""
    z = axis
    helper = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(helper, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.column_stack([x, y, z])


def to_global(B_local: np.ndarray, G_local: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Field and gradient of a local frame (axes the columns of ``R``) in the global one: ``B = R B_l``,
    ``G = R G_l R^T``."""
    return B_local @ R.T, np.matmul(np.matmul(R, G_local), R.T)


# ------------------------------------------------------------------------------------------------- sources


@dataclass(frozen=True, init=False)
class Uniform(Source):
    """A uniform field (T): the package's original field model, ``G = 0``.

    Parameters
    ----------
    B : Field, pair or triple
        A :class:`~magsoft_env.spec.Field`, a pair ``(B_x, B_z)`` or a triple ``(B_x, B_y, B_z)`` (T), each
        component within +-1 T. The field at every point is the Field's :meth:`~magsoft_env.spec.Field.vector`,
        bit for bit.

    Examples
    --------
    >>> import numpy as np
    >>> B, G = Uniform((0.0, 0.013)).field_and_gradient(np.zeros((2, 3)))
    >>> B.tolist(), float(abs(G).max())
    ([[0.0, 0.0, 0.013], [0.0, 0.0, 0.013]], 0.0)
    """

    B: tuple

    def __init__(self, B):
        object.__setattr__(self, "B", tuple(float(c) for c in as_field(B, "Uniform B").vector()))

    def field_and_gradient(self, points):
        p = as_points(points)
        n = p.shape[0]
        return np.tile(np.array(self.B), (n, 1)), np.zeros((n, 3, 3))


@dataclass(frozen=True, init=False)
class SourceSum(Source):
    """The sum of sources: fields and gradients add. ``a + b + c`` builds one flat sum.

    Parameters
    ----------
    sources : sequence of Source
        At least one.
    """

    sources: tuple

    def __init__(self, sources):
        if isinstance(sources, Source) or isinstance(sources, (str, bytes)):
            raise ValueError("SourceSum sources must be a sequence of sources, got a single "
                             f"{type(sources).__name__}; wrap it in a list.")
        try:
            items = list(sources)
        except TypeError:
            raise ValueError(f"SourceSum sources must be a sequence of sources, got {sources!r}.") from None
        flat = []
        for i, s in enumerate(items):
            if isinstance(s, SourceSum):
                flat.extend(s.sources)
            elif isinstance(s, Source):
                flat.append(s)
            else:
                hint = (" (a CoilSystem needs its currents: use coils.at_currents(I))"
                        if hasattr(s, "at_currents") else "")
                raise ValueError(f"SourceSum sources[{i}] must be a field source (with field_and_gradient), got "
                                 f"{type(s).__name__}{hint}.")
        if not flat:
            raise ValueError("SourceSum needs at least one source, got none.")
        object.__setattr__(self, "sources", tuple(flat))

    def field_and_gradient(self, points):
        p = as_points(points)
        B, G = self.sources[0].field_and_gradient(p)
        B, G = B.copy(), G.copy()
        for s in self.sources[1:]:
            b, g = s.field_and_gradient(p)
            B += b
            G += g
        return B, G


@dataclass(frozen=True, eq=False, init=False)
class Transformed(Source):
    """A source moved rigidly: its own frame's origin at ``position`` (m), its axes the columns of ``rotation``.

    ``B'(x) = R B(R^T (x - p))`` and ``G'(x) = R G(R^T (x - p)) R^T``.

    Parameters
    ----------
    source : Source
        The source in its own frame.
    position : array_like, shape (3,)
        Where its origin goes (m).
    rotation : array_like, shape (3, 3), or scipy Rotation
        Its orientation (its axes as columns); default the identity.
    """

    source: Source
    position: np.ndarray
    rotation: np.ndarray

    def __init__(self, source, position=(0.0, 0.0, 0.0), rotation=None):
        if not isinstance(source, Source):
            raise ValueError(f"Transformed source must be a field source, got {type(source).__name__}.")
        object.__setattr__(self, "source", source)
        object.__setattr__(self, "position", position3("Transformed position", position))
        R = _EYE.copy() if rotation is None else rotation_matrix("Transformed rotation", rotation)
        object.__setattr__(self, "rotation", R)

    def field_and_gradient(self, points):
        p = as_points(points)
        R = self.rotation
        local = (p - self.position) @ R  # rows: R^T (x - p)
        B, G = self.source.field_and_gradient(local)
        return to_global(B, G, R)


__all__ = ["MAX_COORDINATE", "MU0_4PI", "Source", "SourceSum", "Transformed", "Uniform", "as_points",
           "frame_from_axis", "position3", "rotation_matrix", "to_global", "unit_vector", "vector3"]

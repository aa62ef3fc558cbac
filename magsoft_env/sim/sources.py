"""Field sources in the MuJoCo rods: the loads of a non-uniform field on the rods' magnetic pieces.

A field source (:mod:`magsoft_env.fields`) is anything with ``field_and_gradient(points) -> (B, G)`` (``points``
``(n, 3)`` in m, ``B`` ``(n, 3)`` in T, ``G`` ``(n, 3, 3)`` in T/m with ``G[i, a, b] = dB_a / dx_b``), or with
``field_and_gradient(points, t=...)`` for one that changes in time (:class:`~magsoft_env.fields.MovingSource`).
A rigid piece of world moment ``m`` (A m^2) whose magnetic centre is at ``p`` gets the couple ``m x B(p)`` and the
force ``G(p)^T m`` (docs/sim.md, "Field sources"); its magnetic energy is ``-m . B(p)``.

How the :class:`~magsoft_env.sim.Simulator` takes a source (:meth:`~magsoft_env.sim.Simulator.set_source`):

- its uniform parts (:class:`~magsoft_env.fields.Uniform`, also inside a
  :class:`~magsoft_env.fields.SourceSum`) are folded into the simulator's uniform field (:func:`split_source`): they
  run the uniform-field path, bit for bit what ``field=B`` runs;
- the rest is a :class:`SourceField`, which the rod backend evaluates at its pieces before every step (one
  vectorized call for all pieces) and applies as forces and couples (``RodBackend.set_source``).

:class:`Blend` weighs sources (the loading ramps of :func:`~magsoft_env.sim.mujoco_path`); :func:`magnet_case` is
the clamped paper strip near a small magnet (tests/test_sim_sources.py; an analytical reference meets it there).
"""

from __future__ import annotations

import inspect
import math

import numpy as np

from ..fields import PointDipole, Source, SourceSum, Uniform
from ..spec import Beam
from ..spec.field import MAX_FIELD


def takes_time(source) -> bool:
    """Whether ``source.field_and_gradient`` takes a time ``t=`` (a :class:`~magsoft_env.fields.MovingSource`)."""
    try:
        return "t" in inspect.signature(source.field_and_gradient).parameters
    except (TypeError, ValueError):
        return False


def check_source(source, name: str = "source"):
    """``source`` if it is a field source (has ``field_and_gradient``), else a ValueError that says what is."""
    fn = getattr(source, "field_and_gradient", None)
    if not callable(fn) or isinstance(source, type):
        raise ValueError(f"{name} must be a field source with field_and_gradient(points) (magsoft_env.fields: "
                         f"Uniform, PointDipole, SphereMagnet, CoilSystem.at_currents(I), MovingSource, ...), got "
                         f"{type(source).__name__}.")
    if hasattr(source, "at_currents") and "currents" in inspect.signature(fn).parameters:
        raise ValueError(f"{name}: a CoilSystem needs its currents: pass coils.at_currents(I) (A), not the system.")
    return source


def split_source(source) -> tuple[np.ndarray | None, object | None]:
    """``(uniform, rest)``: the sum of the uniform parts of ``source`` (``(B_x, B_y, B_z)`` in T, or None where it
    has none) and the rest (a source, or None). A :class:`~magsoft_env.fields.Uniform` is all uniform; a
    :class:`~magsoft_env.fields.SourceSum` splits into its uniform terms and the others; anything else is all rest.
    None gives ``(None, None)``."""
    if source is None:
        return None, None
    check_source(source)
    if isinstance(source, Uniform):
        return np.array(source.B, dtype=float), None
    if isinstance(source, SourceSum):
        uni = [s for s in source.sources if isinstance(s, Uniform)]
        rest = [s for s in source.sources if not isinstance(s, Uniform)]
        b = None
        for s in uni:
            b = np.array(s.B, dtype=float) if b is None else b + np.array(s.B, dtype=float)
        if not rest:
            return b, None
        return b, rest[0] if len(rest) == 1 else SourceSum(rest)
    return None, source


class Blend(Source):
    """``sum_k w_k S_k``: sources weighed (fields and gradients scale), the ramps of a loading path.

    Parameters
    ----------
    terms : sequence of (float, source)
        Weights and sources (a source may take ``t=``; then the blend does too).
    """

    def __init__(self, terms):
        self.terms = tuple((float(w), check_source(s)) for w, s in terms if float(w) != 0.0)
        self._timed = any(takes_time(s) for _, s in self.terms)

    def field_and_gradient(self, points, t: float = 0.0):
        p = np.asarray(points, dtype=float)
        B = np.zeros((p.shape[0], 3))
        G = np.zeros((p.shape[0], 3, 3))
        for w, s in self.terms:
            b, g = s.field_and_gradient(p, t=t) if takes_time(s) else s.field_and_gradient(p)
            B += w * b
            G += w * g
        return B, G


class SourceField:
    """A non-uniform source as a rod backend evaluates it: at the pieces' magnetic centres, at a time, checked.

    Parameters
    ----------
    source
        A field source (see the module docstring); with ``field_and_gradient(points, t=...)`` it is evaluated at
        the simulation time of each step (:attr:`moves`).
    """

    def __init__(self, source):
        self.source = check_source(source)
        #: whether the field changes in time (evaluated at each step's time; the energy balance is then off)
        self.moves = takes_time(source) and not (isinstance(source, Blend) and not source._timed)

    def __call__(self, points: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(B, G)`` at ``points`` ``(n, 3)`` (m) at time ``t`` (s): one call of the source. A ValueError when the
        field at a piece is not finite or beyond :data:`~magsoft_env.spec.field.MAX_FIELD` (1 T) in a component
        (the range the uniform field is held to)."""
        src = self.source
        finite = np.isfinite(points).all(axis=1)
        if not finite.all():
            # a state gone non-finite: no load there; the health checks report the state itself (a SimulationError
            # naming it), which a ValueError from the source would hide
            B, G = np.zeros((len(points), 3)), np.zeros((len(points), 3, 3))
            if finite.any():
                B[finite], G[finite] = self(points[finite], t)
            return B, G
        B, G = src.field_and_gradient(points, t=t) if self.moves else src.field_and_gradient(points)
        big = float(np.abs(B).max())
        if not big <= MAX_FIELD or not np.isfinite(G).all():
            i = int(np.argmax(np.where(np.isfinite(B), np.abs(B), np.inf).max(axis=1)))
            raise ValueError(f"the source's field at piece {i} (at {points[i].tolist()!r} m, t = {t:.6g} s) is "
                             f"{B[i].tolist()!r} T: beyond the +-{MAX_FIELD:g} T a field component may have (or not "
                             "finite, or its gradient is not). Is a piece inside or on top of the source?")
        return B, G


def robot_source(robot):
    """The field source of a robot's ``field_source`` block (:class:`~magsoft_env.cases.robots.Robot`), read by
    :func:`magsoft_env.fields.source_from_dict` (relative ``file`` paths from the robot file's folder); None
    without one. A ValueError names the robot and the key."""
    block = getattr(robot, "field_source", None)
    if block is None:
        return None
    from ..fields import source_from_dict

    return source_from_dict(block, where=f"robot {robot.name!r} field_source",
                            base_dir=getattr(robot, "field_source_dir", "") or None)


def piece_loads(m: np.ndarray, B: np.ndarray, G: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Couples ``m x B`` (N m) and forces ``G^T m`` (N) of pieces with world moments ``m`` ``(n, 3)`` (A m^2) in
    fields ``B`` ``(n, 3)`` (T) with gradients ``G`` ``(n, 3, 3)`` (T/m), each ``(n, 3)``."""
    c = np.empty_like(m)
    c[:, 0] = m[:, 1] * B[:, 2] - m[:, 2] * B[:, 1]
    c[:, 1] = m[:, 2] * B[:, 0] - m[:, 0] * B[:, 2]
    c[:, 2] = m[:, 0] * B[:, 1] - m[:, 1] * B[:, 0]
    return c, np.matmul(m[:, None, :], G)[:, 0, :]


#: Magnetic moment of the magnet of :func:`magnet_case` (A m^2, along +z): a 4 mm NdFeB sphere has about 0.03.
MAGNET_CASE_MOMENT = 5e-3


def magnet_case():
    """The clamped paper strip near a small magnet: ``(beam, source, clamp)``.

    The paper's strip (25 x 5 x 1.13 mm, axial magnetization, the package's default material at 20 % volume
    fraction), clamped at the origin along +x (``clamp = {"clamp_angle": 0.0, "gravity": 0.0}``: no gravity), and a
    point dipole of :data:`MAGNET_CASE_MOMENT` A m^2 along +z at ``(L - 5 mm, 0, -10 mm)``: 5 mm short of the free
    end and 10 mm below it. The strip bends up, away from it, by about 23 degrees at the tip; the gradient forces'
    moment about the clamp is about -9 % of the couples' there (docs/sim.md, "Field sources"). The planar chain and
    the 3D strip agree within 1e-3 L (tests/test_sim_sources.py) and with the analytical solver within 2e-4 L
    (tests/test_theory_sources.py)::

        beam, source, clamp = magnet_case()
        eq = mujoco_equilibrium(beam, source, rod="planar", **clamp)
    """
    beam = Beam(length=25e-3, width=5e-3, thickness=1.13e-3)
    source = PointDipole(position=(beam.length - 5e-3, 0.0, -10e-3), moment=(0.0, 0.0, MAGNET_CASE_MOMENT))
    return beam, source, {"clamp_angle": 0.0, "gravity": 0.0}


def field_bound(B: np.ndarray) -> float:
    """The largest field magnitude (T) among rows ``(n, 3)``."""
    return float(math.sqrt(float(np.max(np.einsum("ij,ij->i", B, B))))) if len(B) else 0.0


__all__ = ["MAGNET_CASE_MOMENT", "Blend", "SourceField", "check_source", "field_bound", "magnet_case",
           "piece_loads", "robot_source", "split_source", "takes_time"]

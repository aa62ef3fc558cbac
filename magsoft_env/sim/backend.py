"""What a rod backend provides to the simulator: the interface the planar chain implements and a 3D rod will.

The :class:`~magsoft_env.sim.Simulator` steps any object with these members; it never reaches into a
backend's MuJoCo addresses. :class:`~magsoft_env.sim.planar.PlanarRod` is the planar hinge chain; a 3D rod (a
MuJoCo 1D flexcomp strip) is a second class with the same members, chosen by :func:`rod_backend`.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import mujoco
import numpy as np

from ..spec import Beam
from .health import SensorHistory
from .model import RodModel, RodOptions


@runtime_checkable
class RodBackend(Protocol):
    """A rod in a scene, as the stepping engine and the health monitor see it.

    Attributes
    ----------
    model : mujoco.MjModel
    rod : RodModel
        The compiled model and its addresses.
    beam : Beam
    options : RodOptions
    npieces : int
        Rigid pieces (rows of ``Simulator.external_wrench``).
    hinge_dof : ndarray of int
        The dofs that carry the rod's elastic energy (damped while settling, checked by the static residual).
    stiffness : ndarray
        Their stiffnesses (N m / rad).
    two_stage : bool
        The integrator splits a step in two stages (the energy balance's staggered positions apply).
    has_contact, has_feature : bool
        The scene has a floor; and a feature (channel, obstacle) besides it.
    contact_adr, feature_adr : int
        ``sensordata`` addresses of the deepest floor / feature contact (m, < 0 when penetrating).
    weight : float
        Total weight (N).
    control_spec : int
        ``mujoco.mjtState`` spec of :meth:`controls` rows.
    per_step : bool
        The couples depend on the state in a way MuJoCo cannot apply by itself (the 3D rod's material frames):
        the engine calls :meth:`write_field` before every step instead of running native blocks, books the
        field's work with :attr:`moment` (the net moment :meth:`write_field` computed) and calls
        :meth:`record_step` after every step.
    """

    model: mujoco.MjModel
    rod: RodModel
    beam: Beam
    options: RodOptions
    npieces: int
    hinge_dof: np.ndarray
    stiffness: np.ndarray
    two_stage: bool
    has_contact: bool
    has_feature: bool
    contact_adr: int
    feature_adr: int
    weight: float
    control_spec: int
    per_step: bool

    def contact_histories(self, data: mujoco.MjData) -> tuple[SensorHistory | None, SensorHistory | None]:
        """Readers of the floor and feature contact sensors' history buffers."""

    def contact_data(self, data: mujoco.MjData) -> np.ndarray:
        """The array that :attr:`contact_adr` and :attr:`feature_adr` index (MuJoCo's ``sensordata``, or the
        rod's own record of the last step)."""

    def record_step(self, data: mujoco.MjData) -> None:
        """After each step of a :attr:`per_step` rod: record what its health checks read (its deepest contact)."""

    def write_field(self, data: mujoco.MjData, field3: np.ndarray) -> None:
        """Write the inputs of a held field ``(B_x, B_y, B_z)`` (T) into ``data``."""

    def controls(self, fields: np.ndarray) -> np.ndarray:
        """Per-step input rows of the fields, for ``mujoco.rollout`` with :attr:`control_spec`."""

    def apply_external(self, data: mujoco.MjData, wrench: np.ndarray | None) -> None:
        """Write a constant world-frame wrench per piece ``(npieces, 6)`` (None: none); clear other applied forces."""

    def net_moment(self, data: mujoco.MjData) -> np.ndarray:
        """Net magnetic moment (world; A m^2) of the orientations in ``data``."""

    def net_moments(self, qpos: np.ndarray) -> np.ndarray:
        """Net magnetic moments of recorded positions ``(k, nq)``."""

    def energy(self, data: mujoco.MjData, field, *, kinetic: float, staggered: bool) -> float:
        """Kinetic (given) + elastic + gravitational + magnetic energy (J)."""

    def energy_scale(self, bmax: float) -> float:
        """The rod's energy scale (J) in fields up to ``bmax`` (T)."""

    def energies(self, data: mujoco.MjData, field3: np.ndarray, kinetic: float) -> dict[str, float]:
        """Kinetic, elastic, gravitational, magnetic and total energy (J)."""

    def lowest_point(self, data: mujoco.MjData, below: float) -> float:
        """Lowest centreline height (m), exact where it may lie below ``below``."""

    def centerline(self, data: mujoco.MjData) -> tuple[np.ndarray, ...]:
        """Centreline points (m)."""

    def tip_position(self, data: mujoco.MjData) -> tuple[float, ...]:
        """Tip point (m)."""

    def center_of_mass(self, data: mujoco.MjData) -> np.ndarray:
        """Centre of mass (m)."""

    def arc_length(self) -> np.ndarray:
        """Reference arc length (m) of the centreline points."""

    def angles(self, data: mujoco.MjData) -> np.ndarray:
        """Tangent angles of the pieces (rad)."""

    def tip_angle(self, data: mujoco.MjData) -> float:
        """Tangent angle of the tip (rad)."""

    def magnetic_couples(self, data: mujoco.MjData, field3: np.ndarray) -> np.ndarray:
        """Couples ``(R m) x B`` on the pieces, world frame (N m)."""

    def integrity(self, data: mujoco.MjData) -> tuple[str, float, str] | None:
        """``(quantity, value, hint)`` when the rod's own state broke a bound of its model, else None."""


def rod_backend(beam: Beam, options: RodOptions) -> RodBackend:
    """The backend that simulates ``beam`` with ``options``: the planar hinge chain
    (:class:`~magsoft_env.sim.planar.PlanarRod`) or, for ``RodOptions(rod="cable")``, the 3D flexcomp strip
    (:class:`~magsoft_env.sim.cable.CableRod`)."""
    from .planar import PlanarRod

    if options.rod == "cable":
        from .cable import CableRod

        return CableRod(beam, options)
    return PlanarRod(beam, options)


__all__ = ["RodBackend", "rod_backend"]

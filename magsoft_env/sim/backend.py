"""What a rod backend provides: the interface every rod implements, the pose every consumer reads, the registry.

Everything that depends on which rod runs lives in the rod's backend: how a block of steps runs (natively in
MuJoCo or with couples written from Python), which fields it takes, how it settles, its pose, its histories and
readouts, the options a gait gives it and the view that draws it. The :class:`~magsoft_env.sim.Simulator`, the
gaits, the statics, the environments, the renderers and the command line know a rod only through this
interface; a new rod is one new module and one line in :data:`~magsoft_env.rods.ROD_BACKENDS` (or a
:func:`~magsoft_env.rods.register_rod` call).

Registered rods:

- ``"planar"``: :class:`~magsoft_env.sim.planar.PlanarRod`, the hinge chain in the x-z plane (native couples);
- ``"cable"``: :class:`~magsoft_env.sim.cable.CableRod`, the 3D MuJoCo flexcomp strip (bending both ways,
  twist, width-wise contact).
"""

from __future__ import annotations

import importlib
import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import mujoco
import numpy as np

from ..rods import ROD_BACKENDS, check_rod, register_rod, rod_names
from ..spec import Beam, Field


@dataclass(frozen=True)
class Pose:
    """Where a rod is, in one shape for every rod (frozen; SI units). A planar rod has ``y = 0`` and every
    width axis along +y.

    Attributes
    ----------
    time : float
        Simulation time (s).
    com : (3,) ndarray
        Centre of mass (m).
    centreline : (n, 3) ndarray
        Centreline points (m), base end (s = 0) to tip (s = L).
    tangents : (npieces, 3) ndarray
        Unit tangent of every rigid piece (planar chain: link; strip: edge), base first.
    widths : (npieces, 3) ndarray
        Unit width axis of every piece (the material direction across the beam's width).
    lengths : (npieces,) ndarray
        Reference length of every piece (m): the weights of the body's mean direction.
    tip_angle : float
        The tip's tangent angle from +x toward +z (rad), continuous beyond +-pi where the rod counts whole
        turns (the planar chain: the sum of its joint angles); else in (-pi, pi].
    """

    time: float
    com: np.ndarray
    centreline: np.ndarray
    tangents: np.ndarray
    widths: np.ndarray
    lengths: np.ndarray
    tip_angle: float = math.nan

    @property
    def heading(self) -> float:
        """Direction of the end-to-end chord in the floor plane (rad, from +x toward +y)."""
        c = self.centreline
        return math.atan2(float(c[-1, 1] - c[0, 1]), float(c[-1, 0] - c[0, 0]))

    @property
    def roll(self) -> float:
        """Largest roll of any piece about its own axis: its width axis's angle from the floor (rad)."""
        return float(np.max(np.abs(np.arcsin(np.clip(self.widths[:, 2], -1.0, 1.0)))))

    def pitch_angles(self, heading: float = 0.0) -> np.ndarray:
        """Tangent angle of every piece from the horizontal direction ``heading`` (rad from +x toward +y) toward +z
        (rad), in the vertical plane through it: the planar chain's piece angles for ``heading = 0``."""
        t = self.tangents
        return np.arctan2(t[:, 2], t[:, 0] * math.cos(heading) + t[:, 1] * math.sin(heading))


@runtime_checkable
class RodBackend(Protocol):
    """A rod in a scene, as the stepping engine, the health monitor and every consumer see it.

    Class attributes and class methods (what a caller may ask before building anything)
    ------------------------------------------------------------------------------------
    name : str
        The registry name (``RodOptions.rod``).
    label : str
        What messages call it (``"the MuJoCo hinge-chain rod"``).
    field_axes : tuple of int
        The components of ``(B_x, B_y, B_z)`` it takes: ``(0, 2)`` for a rod in the x-z plane, ``(0, 1, 2)``
        for a 3D rod. Its moments and energies are in these components.
    scenes : tuple of str
        The scenes it builds (``RodOptions.scene``).
    views : tuple of str
        How frames may show it, the default first: ``"side"`` (:class:`~magsoft_env.render.RodRenderer`, a rod in
        the x-z plane), ``"perspective"`` or ``"top"`` (:class:`~magsoft_env.render.strip.StripRenderer`, any rod,
        drawn from its :class:`Pose`).
    static_timestep, static_tol : float
        Defaults of :func:`~magsoft_env.sim.mujoco_equilibrium`: the settling step (s) and residual tolerance.
    check_options(options)
        ValueError for options it cannot build (before any work).
    check_beam(beam, what)
        ValueError for a beam it cannot simulate (a planar rod: a magnetization across the width).
    check_field(field: Field)
        ValueError for a field it cannot take (a planar rod: ``B_y != 0``).
    check_fields(samples (n, 3), source)
        The same for the samples of a waveform ``source``.
    gait_options(robot, **common) -> dict
        The rod's own :class:`~magsoft_env.sim.RodOptions` keywords for a robot on the floor (its colliders, its
        numerics where the robot's own do not suit it), merged into the common ones.

    Instance attributes
    -------------------
    model : mujoco.MjModel
    rod
        The compiled model and its addresses (the planar chain's :class:`~magsoft_env.sim.model.RodModel`, the
        strip's :class:`~magsoft_env.sim.cable_build.CableModel`).
    beam : Beam
    options : RodOptions
    npieces : int
        Rigid pieces (rows of ``Simulator.external_wrench``).
    hinge_dof : ndarray of int
        The dofs that carry the rod's elastic energy (damped while settling, checked by the static residual).
    stiffness : ndarray
        The stiffness against each (N m / rad, or N / m for a slide): ``max |Q| / k`` is the static residual.
    two_stage : bool
        The integrator splits a step in two stages (the energy balance's staggered positions apply).
    has_contact, has_feature : bool
        The scene has a floor; and a feature (channel, obstacle) besides it.
    contact_adr, feature_adr : int
        Indices into :meth:`contact_data` of the deepest floor / feature contact (m, < 0 when penetrating).
    weight : float
        Total weight (N).
    block_limit : int
        The longest block of steps :meth:`advance` may run (its histories keep that many steps).
    """

    name: str
    label: str
    field_axes: tuple
    scenes: tuple
    views: tuple
    static_timestep: float
    static_tol: float
    model: mujoco.MjModel
    rod: object
    beam: Beam
    options: object
    npieces: int
    hinge_dof: np.ndarray
    stiffness: np.ndarray
    two_stage: bool
    has_contact: bool
    has_feature: bool
    contact_adr: int
    feature_adr: int
    weight: float
    block_limit: int

    # ---------------------------------------------------------------- inputs and stepping
    def check_field(self, field: Field) -> None:
        """ValueError for a field this rod cannot take."""

    def check_fields(self, samples: np.ndarray, source) -> None:
        """ValueError for per-step fields ``(n, 3)`` (T) of ``source`` that this rod cannot take."""

    def write_field(self, data: mujoco.MjData, field3: np.ndarray) -> None:
        """Write the inputs of a held field ``(B_x, B_y, B_z)`` (T) into ``data``."""

    def advance(self, data: mujoco.MjData, field3: np.ndarray, fields: np.ndarray | None, k: int, health) -> None:
        """Run ``k`` steps (at most :attr:`block_limit`) under the held ``field3`` or per-step ``fields`` ``(k, 3)``
        (T), booking the field's work with ``health`` (:class:`~magsoft_env.sim.health.HealthMonitor`)."""

    def apply_external(self, data: mujoco.MjData, wrench: np.ndarray | None) -> None:
        """Write a constant world-frame wrench per piece ``(npieces, 6)`` (None: none); clear other applied forces."""

    def set_source(self, data: mujoco.MjData, source) -> None:
        """Apply a non-uniform field source (:class:`~magsoft_env.sim.sources.SourceField`; None: none) besides the
        uniform field from now on: before every step (Python per step, :class:`~magsoft_env.sim.stepping.PythonSteps`)
        its field ``B`` and gradient ``G`` at the pieces' magnetic centres (one call for all pieces) give each piece
        the couple ``m x B`` and the force ``G^T m``; its energy ``-sum m . B`` is in :meth:`energy` and
        :meth:`energies`, its couples in :meth:`magnetic_couples`."""

    def source_field(self, data: mujoco.MjData) -> np.ndarray:
        """The source's field (T) at the pieces' magnetic centres of the state in ``data``, ``(npieces, 3)`` (zeros
        without a source)."""

    def settle_damping(self, retardation: float) -> tuple[np.ndarray, np.ndarray]:
        """``(dofs, damping)``: the dof damping that settles the rod (for a retardation time ``retardation``, s,
        where the rod uses one)."""

    def settle_speed(self, data: mujoco.MjData) -> float:
        """The largest rate (rad/s, or m/s over L) of the rod's elastic dofs: settled when small."""

    def reset_noise(self, rng: np.random.Generator, scale: float) -> np.ndarray:
        """``qpos`` of the rest state perturbed by ``U(-scale, scale)`` rad in each bending angle."""

    def set_material_scale(self, modulus: float, magnetization: float) -> None:
        """Make the model and every cache of the rod what building it from the beam with ``E0 * modulus`` and
        ``particle_magnetization * magnetization`` gives, scaled from the values it was built with (checked
        factors; :meth:`~magsoft_env.sim.Simulator.set_material_scale`). A backend without this method cannot be
        randomized in place (the simulator refuses)."""

    # ---------------------------------------------------------------- histories
    def contact_histories(self, data: mujoco.MjData):
        """Readers (``nsample``, ``values``, ``last(k)``) of the deepest floor and feature contact of every step
        of the last block (None where a scene has none)."""

    def contact_data(self, data: mujoco.MjData) -> np.ndarray:
        """The array :attr:`contact_adr` and :attr:`feature_adr` index (the last step's contacts)."""

    def centreline_history(self, data: mujoco.MjData):
        """Reader of the centreline at the start of every step of the last block: ``last(k)`` ``(n, k, 3)``."""

    # ---------------------------------------------------------------- energies and checks
    def net_moment(self, data: mujoco.MjData) -> np.ndarray:
        """Net magnetic moment (world, :attr:`field_axes` components; A m^2) of the state in ``data``."""

    def net_moments(self, qpos: np.ndarray) -> np.ndarray:
        """Net magnetic moments of recorded positions ``(k, nq)``, shape ``(k, len(field_axes))``."""

    def energy(self, data: mujoco.MjData, field3, *, kinetic: float, staggered: bool) -> float:
        """Kinetic (given) + elastic + gravitational + magnetic energy (J)."""

    def energy_scale(self, bmax: float) -> float:
        """The rod's energy scale (J) in fields up to ``bmax`` (T)."""

    def energies(self, data: mujoco.MjData, field3: np.ndarray, kinetic: float) -> dict[str, float]:
        """Kinetic, elastic, gravitational, magnetic and total energy (J)."""

    def lowest_point(self, data: mujoco.MjData, below: float) -> float:
        """Lowest centreline height (m), exact where it may lie below ``below``."""

    def integrity(self, data: mujoco.MjData) -> tuple[str, float, str] | None:
        """``(quantity, value, hint)`` when the rod's own state broke a bound of its model, else None."""

    # ---------------------------------------------------------------- readouts (of a synchronized mjData)
    def pose(self, data: mujoco.MjData) -> Pose:
        """The :class:`Pose`."""

    def orientation_tracker(self):
        """A new tracker of the body's orientation end over end, continuous in time (``update(pose) -> rad``,
        ``heading``): :class:`~magsoft_env.sim.readouts.ChainOrientation` or
        :class:`~magsoft_env.sim.readouts.PitchTracker`."""

    def centerline(self, data: mujoco.MjData) -> tuple[np.ndarray, ...]:
        """Centreline points (m) in the rod's own components (the planar chain: ``(x, z)``)."""

    def tip_position(self, data: mujoco.MjData) -> tuple[float, ...]:
        """Tip point (m), the rod's own components."""

    def center_of_mass(self, data: mujoco.MjData) -> np.ndarray:
        """Centre of mass (m), the rod's own components."""

    def arc_length(self) -> np.ndarray:
        """Reference arc length (m) of the centreline points."""

    def angles(self, data: mujoco.MjData) -> np.ndarray:
        """Tangent angles of the pieces from +x toward +z (rad; a 3D rod: of their x-z projections)."""

    def tip_angle(self, data: mujoco.MjData) -> float:
        """Tangent angle of the tip (rad)."""

    def tip_twist(self, data: mujoco.MjData) -> float:
        """Integrated twist ``int k3 ds`` (rad): 0 for a rod that cannot twist."""

    def angular_velocities(self, data: mujoco.MjData) -> np.ndarray:
        """Angular velocity of every piece about -y (rad/s; the rate of :meth:`angles`), ``(npieces,)``."""

    def magnetic_couples(self, data: mujoco.MjData, field3: np.ndarray) -> np.ndarray:
        """Couples ``(R m) x B`` on the pieces, world frame (N m)."""


def rod_class(name: str) -> type:
    """The backend class registered as ``name`` (ValueError naming the registered ones otherwise)."""
    module, cls = ROD_BACKENDS[check_rod(name)].split(":")
    return getattr(importlib.import_module(module), cls)


def rod_backend(beam: Beam, options) -> RodBackend:
    """The backend of ``options.rod`` simulating ``beam`` with ``options``."""
    return rod_class(options.rod)(beam, options)


__all__ = ["ROD_BACKENDS", "Pose", "RodBackend", "register_rod", "rod_backend", "rod_class", "rod_names"]

"""MuJoCo rods: the magnetic beam as a planar hinge chain or a 3D flexcomp strip, under gravity, fields and contact.

Importing this package imports mujoco (no renderer, no gymnasium, no torch).

Main entry points: :class:`Simulator` (dynamics, waveforms, settling, readouts: one stepping engine over a
rod backend, with one health monitor), the rod backends (:mod:`.backend`: the interface, the :class:`Pose` every
consumer reads and the registry; :class:`~magsoft_env.sim.planar.PlanarRod`, the hinge chain in the x-z plane;
:class:`~magsoft_env.sim.cable.CableRod`, the 3D strip), :func:`mujoco_equilibrium` and :func:`mujoco_path`
(statics along a loading path, with stability), :func:`build_model` / :class:`RodOptions` (the chain's MjSpec
builder and every rod's options), :mod:`.waveforms`.
"""

from ..rods import register_rod, rod_names
from .backend import Pose, RodBackend, rod_backend, rod_class
from .cable import CableRod, cable_equilibrium, cable_path
from .discretize import RodDiscretization, discretize
from .equilibrium import SimEquilibrium, Stability, mujoco_equilibrium, mujoco_path, static_stability
from .health import UnphysicalError
from .model import CHANNEL_SIZE, INTEGRATORS, OBSTACLE_SIZE, SCENES, RodModel, RodOptions, build_model, build_spec
from .planar import PlanarRod
from .simulator import SettleResult, SimulationError, Simulator, Trajectory
from .waveforms import Hold, PhaseShifted, Ramp, Sequence, Sine, Square, SwitchedSquare, Waveform, as_waveform

__all__ = [
    "as_waveform", "build_model", "build_spec", "cable_equilibrium", "cable_path", "CableRod", "CHANNEL_SIZE",
    "discretize", "Hold", "INTEGRATORS", "mujoco_equilibrium", "mujoco_path", "OBSTACLE_SIZE", "PhaseShifted",
    "PlanarRod", "Pose", "Ramp", "register_rod", "rod_backend", "rod_class", "rod_names", "RodBackend",
    "RodDiscretization", "RodModel", "RodOptions", "SCENES", "Sequence", "SettleResult", "SimEquilibrium",
    "SimulationError", "Simulator", "Sine", "Square", "Stability", "static_stability", "SwitchedSquare",
    "Trajectory", "UnphysicalError", "Waveform",
]

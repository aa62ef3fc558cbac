"""MuJoCo rod: the magnetic beam as a planar hinge chain under gravity, fields and contact.

Importing this package imports mujoco (no renderer, no gymnasium, no torch).

Main entry points: :class:`Simulator` (dynamics, waveforms, settling, readouts: one stepping engine over a
rod backend, :class:`~magsoft_env.sim.planar.PlanarRod` or the 3D flexcomp strip
:class:`~magsoft_env.sim.cable.CableRod`, with one health monitor),
:func:`mujoco_equilibrium` and :func:`mujoco_path` (statics along a loading path),
:func:`build_model` / :class:`RodOptions` (the MjSpec builder), :mod:`.waveforms`.
"""

from .backend import RodBackend, rod_backend
from .cable import CableRod, cable_equilibrium, cable_path
from .discretize import RodDiscretization, discretize
from .equilibrium import SimEquilibrium, mujoco_equilibrium, mujoco_path
from .health import UnphysicalError
from .model import CHANNEL_SIZE, INTEGRATORS, OBSTACLE_SIZE, SCENES, RodModel, RodOptions, build_model, build_spec
from .planar import PlanarRod
from .simulator import SettleResult, SimulationError, Simulator, Trajectory
from .waveforms import Hold, PhaseShifted, Ramp, Sequence, Sine, Square, SwitchedSquare, Waveform, as_waveform

__all__ = [
    "CHANNEL_SIZE", "INTEGRATORS", "CableRod", "cable_equilibrium", "cable_path",
    "OBSTACLE_SIZE", "SCENES", "Hold", "PhaseShifted", "Ramp", "RodDiscretization",
    "PlanarRod", "RodBackend", "RodModel", "RodOptions", "SettleResult", "Sequence", "SimEquilibrium",
    "SimulationError",
    "UnphysicalError", "Simulator", "Sine", "Square", "SwitchedSquare", "Trajectory", "Waveform", "as_waveform",
    "build_model", "build_spec", "rod_backend", "discretize", "mujoco_equilibrium", "mujoco_path",
]

"""Analytical side: equilibrium shapes of hard-magnetic beams along loading paths."""

from .elastica import elastica_tip, prandtl_field
from .rod_solver import CriticalField, RodResult, critical_field
from .solver import TERMINATION_MESSAGES, EquilibriumResult, SolverOptions, solve_equilibrium, solve_path
from .sources import SourceResult, shoot

__all__ = [
    "TERMINATION_MESSAGES",
    "CriticalField",
    "EquilibriumResult",
    "RodResult",
    "SolverOptions",
    "SourceResult",
    "critical_field",
    "elastica_tip",
    "prandtl_field",
    "shoot",
    "solve_equilibrium",
    "solve_path",
]

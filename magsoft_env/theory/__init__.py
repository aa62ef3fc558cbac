"""Analytical side: equilibrium shapes of hard-magnetic beams along loading paths."""

from .elastica import elastica_tip
from .solver import TERMINATION_MESSAGES, EquilibriumResult, SolverOptions, solve_equilibrium, solve_path

__all__ = [
    "TERMINATION_MESSAGES",
    "EquilibriumResult",
    "SolverOptions",
    "elastica_tip",
    "solve_equilibrium",
    "solve_path",
]

"""Analytical side: equilibrium shapes of hard-magnetic beams along loading paths."""

from .elastica import elastica_tip, prandtl_field
from .fit import FitResult, fit
from .fit_plan import MeasurementPlan, plan_measurements, predict_precision
from .rod_sensitivity import RodSensitivity, rod_sensitivities, source_rod_sensitivities
from .rod_solver import CriticalField, RodResult, critical_field
from .sensitivity import Sensitivity, sensitivities
from .solver import TERMINATION_MESSAGES, EquilibriumResult, SolverOptions, solve_equilibrium, solve_path
from .sources import SourceResult, shoot

__all__ = [
    "TERMINATION_MESSAGES",
    "CriticalField",
    "EquilibriumResult",
    "FitResult",
    "MeasurementPlan",
    "RodResult",
    "RodSensitivity",
    "Sensitivity",
    "SolverOptions",
    "SourceResult",
    "critical_field",
    "elastica_tip",
    "fit",
    "plan_measurements",
    "prandtl_field",
    "predict_precision",
    "rod_sensitivities",
    "sensitivities",
    "shoot",
    "solve_equilibrium",
    "solve_path",
    "source_rod_sensitivities",
]

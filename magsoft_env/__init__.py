"""magsoft_env: design and simulate centimetre-scale hard-magnetic soft robots.

Analytical equilibria (``solve_equilibrium``, ``solve_path``), inverse design
(``design_profile``), MuJoCo rods (``mujoco_equilibrium``) and Gymnasium environments
(registered on import). Heavy layers load lazily: importing this package does not import
mujoco, torch, stable-baselines3 or a GL backend.

Rendering chooses its headless OpenGL backend itself (:mod:`magsoft_env.gl`): EGL, else OSMesa.
"""

from __future__ import annotations

import importlib
import importlib.util

from .spec import (
    MU0,
    Beam,
    Constant,
    Direction,
    Field,
    Function,
    Material,
    PiecewiseConstant,
    PiecewiseLinear,
    Profile,
    Sampled,
    alternating_cells,
    jig_curve,
    jig_from_function,
    jig_from_points,
    jig_from_polyline,
    ramp,
    sample_profile,
)

__version__ = "0.4.0"

# public name -> module that defines it (imported on first use)
_LAZY = {
    "solve_equilibrium": "magsoft_env.theory",
    "solve_path": "magsoft_env.theory",
    "fit": "magsoft_env.theory",
    "plan_measurements": "magsoft_env.theory",
    "predict_precision": "magsoft_env.theory",
    "sensitivities": "magsoft_env.theory",
    "FitResult": "magsoft_env.theory",
    "EquilibriumResult": "magsoft_env.theory",
    "RodResult": "magsoft_env.theory",
    "SourceResult": "magsoft_env.theory",
    "critical_field": "magsoft_env.theory",
    "mujoco_equilibrium": "magsoft_env.sim",
    "design_profile": "magsoft_env.design",
    "load_preset": "magsoft_env.cases",
    "Robot": "magsoft_env.cases",
    "load_robot": "magsoft_env.cases",
    "list_robots": "magsoft_env.cases",
    "gait_preset": "magsoft_env.cases",
    "list_gaits": "magsoft_env.cases",
    "list_presets": "magsoft_env.cases",
    "Waveparams": "magsoft_env.spec.drive",
    "run_gait": "magsoft_env.sim.gait",
    "crosscheck_preset": "magsoft_env.compare",
    "mujoco_check": "magsoft_env.compare",
    "fit_decay": "magsoft_env.compare",
    "fit_friction": "magsoft_env.compare",
}


def __getattr__(name):
    mod = _LAZY.get(name)
    if mod is None:
        raise AttributeError(f"module 'magsoft_env' has no attribute {name!r}")
    value = getattr(importlib.import_module(mod), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY))


def _register_envs():
    # gymnasium ids are registered lazily (entry_point strings): no mujoco import here
    if importlib.util.find_spec("magsoft_env.envs") is not None:
        importlib.import_module("magsoft_env.envs").register_all()


_register_envs()

__all__ = [
    "MU0",
    "Beam",
    "Constant",
    "Direction",
    "EquilibriumResult",
    "Field",
    "RodResult",
    "FitResult",
    "SourceResult",
    "Function",
    "Material",
    "PiecewiseConstant",
    "PiecewiseLinear",
    "Profile",
    "Robot",
    "Sampled",
    "Waveparams",
    "alternating_cells",
    "critical_field",
    "crosscheck_preset",
    "design_profile",
    "fit",
    "fit_decay",
    "fit_friction",
    "gait_preset",
    "jig_curve",
    "jig_from_function",
    "jig_from_points",
    "jig_from_polyline",
    "list_gaits",
    "list_presets",
    "list_robots",
    "load_preset",
    "load_robot",
    "mujoco_check",
    "mujoco_equilibrium",
    "plan_measurements",
    "predict_precision",
    "ramp",
    "run_gait",
    "sample_profile",
    "sensitivities",
    "solve_equilibrium",
    "solve_path",
]

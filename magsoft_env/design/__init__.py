"""Inverse design (pure computation): target curves, point-to-curve objective, parametrized profiles,
optimizer, the jig as SVG. Checking a design in MuJoCo is :func:`magsoft_env.compare.mujoco_check`;
writing it to files is :func:`magsoft_env.render.design.write_design`.
"""

from .distance import point_to_polyline, point_to_polyline_jacobian
from .families import FAMILIES, BasisProfile, ProfileFamily
from .optimize import STATUS_MESSAGES, DesignResult, design_profile
from .targets import (
    BUILTIN_TARGETS,
    builtin_target,
    curve_length,
    prepare_target,
    read_curve_csv,
    resample,
    validate_target,
)

__all__ = [
    "BUILTIN_TARGETS",
    "FAMILIES",
    "STATUS_MESSAGES",
    "BasisProfile",
    "DesignResult",
    "ProfileFamily",
    "builtin_target",
    "curve_length",
    "design_profile",
    "point_to_polyline",
    "point_to_polyline_jacobian",
    "prepare_target",
    "read_curve_csv",
    "resample",
    "validate_target",
]

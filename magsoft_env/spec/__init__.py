"""Specification layer: what a user describes (material, beam, profiles, fields), validated once."""

from .beam import Beam
from .field import MAX_FIELD, Field, as_field, as_fields, planar_field, ramp
from .material import MAX_VOLUME_FRACTION, MU0, Material
from .profiles import (
    Constant,
    Direction,
    Function,
    JigProfile,
    PiecewiseConstant,
    PiecewiseLinear,
    Profile,
    Sampled,
    alternating_cells,
    as_magnetization,
    as_profile,
    jig_curve,
    jig_from_function,
    jig_from_points,
    jig_from_polyline,
    sample_profile,
)

__all__ = [
    "MAX_FIELD",
    "MAX_VOLUME_FRACTION",
    "MU0",
    "Beam",
    "Constant",
    "Direction",
    "Field",
    "Function",
    "JigProfile",
    "Material",
    "PiecewiseConstant",
    "PiecewiseLinear",
    "Profile",
    "Sampled",
    "alternating_cells",
    "as_field",
    "as_fields",
    "as_magnetization",
    "as_profile",
    "jig_curve",
    "jig_from_function",
    "jig_from_points",
    "jig_from_polyline",
    "planar_field",
    "sample_profile",
    "ramp",
]

"""Specification layer: what a user describes (material, beam, profiles, fields), validated once."""

from .beam import Beam
from .field import MAX_FIELD, Field, as_field, as_fields, ramp
from .material import MAX_VOLUME_FRACTION, MU0, Material
from .profiles import (
    Constant,
    Function,
    JigProfile,
    PiecewiseConstant,
    PiecewiseLinear,
    Profile,
    Sampled,
    alternating_cells,
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
    "as_profile",
    "jig_curve",
    "jig_from_function",
    "jig_from_points",
    "jig_from_polyline",
    "sample_profile",
    "ramp",
]

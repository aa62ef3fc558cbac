"""The "SJTU" letters of the paper's Fig. 4e: one beam per letter, designed to form it under a vertical field.

Each letter is one stroke, built like the object contours from straight and circular pieces
(:func:`magsoft_env.design.targets.turtle_curve`) and drawn from the clamped end. J and U start
downward, so their beams are clamped pointing down (``clamp_angle`` = the stroke's first tangent);
T, which a single beam cannot branch into, is a stem with a folded bar (a hairpin turn).
"""

from __future__ import annotations

import math

import numpy as np

from ..units import MM
from .targets import curve_length, turtle_curve

#: (first tangent in degrees, pieces) per letter; pieces as in turtle_curve (mm, degrees)
LETTERS: dict[str, tuple[float, list]] = {
    "S": (0.0, [(None, 2.0), (4.0, 180.0), (4.0, -180.0), (None, 2.0)]),
    "J": (-90.0, [(None, 2.0), (4.0, 180.0), (None, 12.0)]),
    "T": (90.0, [(None, 12.0), (2.5, -90.0), (None, 2.0), (2.5, 180.0), (None, 10.5)]),
    "U": (-90.0, [(None, 10.0), (5.0, 180.0), (None, 10.0)]),
}


def letter_target(letter: str) -> np.ndarray:
    """One-stroke curve (m) of ``letter`` (S, J, T or U), starting at the clamp at the origin."""
    from ..validate import choice

    letter = choice("letter", letter, list(LETTERS))
    heading, pieces = LETTERS[letter]
    xz = turtle_curve(pieces, step=0.1) * MM
    c, s = math.cos(math.radians(heading)), math.sin(math.radians(heading))
    return xz @ np.array([[c, s], [-s, c]])


def design_letters(letters: str = "SJTU", *, field_bounds=(1e-3, 40e-3), width: float = 5e-3,
                   thickness: float = 1.13e-3, progress: bool = False, **kw) -> dict:
    """Design one beam per letter (vertical field, shared bounds); returns ``{letter: DesignResult}``."""
    from ..spec import Beam
    from .optimize import design_profile

    out = {}
    for ch in letters:
        target = letter_target(ch)
        beam = Beam(length=curve_length(target), width=width, thickness=thickness)
        opts = {"beta_bounds": (-2 * math.pi, 2 * math.pi), "size": 11, "n_starts": 6, "max_nfev": 80, **kw}
        out[ch] = design_profile(target, beam, field_bounds=field_bounds, clamp_angle=None, progress=progress, **opts)
    return out

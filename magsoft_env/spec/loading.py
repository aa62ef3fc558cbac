"""How a beam is held and loaded, checked in one place: support, gravity, coupling, extensibility, clamp angle.

The analytical solver, the inverse design and the statics presets take the same loading options;
:func:`check_loading` validates them for all three (``where`` names the caller in messages).
"""

from __future__ import annotations

import math

import numpy as np

from ..validate import choice, finite_number

#: Boundary conditions: clamped at s = 0 and free at s = L, or free at both ends.
SUPPORTS = ("cantilever", "free")
#: Magnetic couplings: the complete one (magnetization turns with the section) and the paper's eq. (10).
COUPLINGS = ("rotated", "paper")
#: Largest gravity accepted (m/s^2), about 100 g: Earth's is 9.81 and no test of a centimetre strip comes near
#: 100 g (the strip would just hang); a larger number is almost surely a unit mistake (9810 is 9.81 in mm/s^2).
MAX_GRAVITY = 1000.0
#: Largest clamp angle accepted (rad): a full turn either way; larger values are almost surely degrees.
MAX_CLAMP_ANGLE = 2.0 * math.pi


def check_loading(*, gravity, support: str = "cantilever", coupling: str = "rotated", extensible=False,
                  clamp_angle=0.0, where: str = "") -> dict:
    """The loading options, checked: ``{"gravity", "support", "coupling", "extensible", "clamp_angle"}``.

    ``gravity`` (m/s^2, in [0, :data:`MAX_GRAVITY`], acting along -z; 0 for a free-free beam), ``support`` in
    :data:`SUPPORTS`, ``coupling`` in :data:`COUPLINGS`, ``extensible`` a bool, ``clamp_angle``
    (rad) in [-2 pi, 2 pi]. Raises ValueError naming the option (prefixed by ``where``) otherwise.
    """
    support = choice(f"{where}support", support, SUPPORTS)
    coupling = choice(f"{where}coupling", coupling, COUPLINGS)
    g = finite_number(f"{where}gravity", gravity, unit="m/s^2")
    if g < 0:
        raise ValueError(f"{where}gravity must be >= 0 (m/s^2, acting along -z), got {gravity!r}.")
    if g > MAX_GRAVITY:
        raise ValueError(
            f"{where}gravity must lie in [0, {MAX_GRAVITY:g}] m/s^2 (about 100 g; Earth's is 9.81, and under more "
            f"than 100 g a centimetre strip just hangs), got {gravity!r}. Gravity is in m/s^2: 9810 mm/s^2 is 9.81."
        )
    if support == "free" and g != 0.0:
        raise ValueError(
            f"{where}support='free': a free-free beam needs gravity 0 (it has no static equilibrium under "
            f"gravity), got {gravity!r}. Use the MuJoCo floor scene for beams on the ground."
        )
    if not isinstance(extensible, (bool, np.bool_)):
        raise ValueError(f"{where}extensible must be true or false (a bool), got {extensible!r}.")
    th0 = finite_number(f"{where}clamp_angle", clamp_angle, unit="rad")
    if abs(th0) > MAX_CLAMP_ANGLE:
        raise ValueError(
            f"{where}clamp_angle must lie in [-2 pi, 2 pi] rad (one turn either way), got {clamp_angle!r} "
            f"(angles are in radians: {th0:g} deg is {math.radians(th0):.4g} rad)."
        )
    return {"gravity": g, "support": support, "coupling": coupling, "extensible": bool(extensible), "clamp_angle": th0}


__all__ = ["COUPLINGS", "MAX_CLAMP_ANGLE", "MAX_GRAVITY", "SUPPORTS", "check_loading"]

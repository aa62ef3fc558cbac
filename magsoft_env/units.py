"""Unit constants: the one place where the package's non-SI units are defined (no imports).

Everything inside the package is SI (m, T, s, kg, Pa, rad). Files, command-line flags and
printed tables use millimetres, millitesla, degrees and a few others, with the unit in the key
or flag name. Each constant below is the size of one such unit in SI, so that

    value_SI = value_in_unit * UNIT        and        value_in_unit = value_SI / UNIT

e.g. ``25 * MM`` is 0.025 m and ``beam.length / MM`` is the length in mm. There is no
"per-metre" variant: a conversion to display units always divides.

Examples
--------
>>> 25 * MM
0.025
>>> round(13 * MT, 12)
0.013
>>> round(0.0113 / MM, 6)
11.3
"""

from __future__ import annotations

import math

#: One millimetre (m).
MM = 1e-3
#: One micrometre (m).
UM = 1e-6
#: One millitesla (T).
MT = 1e-3
#: One millisecond (s).
MS = 1e-3
#: One degree (rad).
DEG = math.pi / 180.0
#: One gram (kg).
GRAM = 1e-3
#: One megapascal (Pa).
MPA = 1e6
#: One kiloampere per metre (A/m).
KA_PER_M = 1e3

__all__ = ["DEG", "GRAM", "KA_PER_M", "MM", "MPA", "MS", "MT", "UM"]

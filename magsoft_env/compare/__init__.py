"""The analytical model against MuJoCo: the only layer that imports both ``theory``/``design`` and ``sim``.

- :func:`crosscheck_preset`: a statics preset's loading path solved by both, tip error / L
  against the segment count (``magsoft crosscheck``).
- :func:`mujoco_check`: a design's beam simulated under its field, against the analytical shape.
- :mod:`~magsoft_env.compare.grasp`: two designed fingers close on an object in MuJoCo and lift it.
- :func:`fit_decay`, :func:`fit_friction`: a robot's damping and modulus from a free decay, its floor friction from
  a crawl speed, through the MuJoCo rods (:mod:`~magsoft_env.compare.dynamic_fit`).

Importing this package imports mujoco.
"""

from .crosscheck import CrosscheckRow, crosscheck_preset, tip_errors
from .design_check import mujoco_check
from .dynamic_fit import DynamicFitResult, fit_decay, fit_friction

__all__ = ["CrosscheckRow", "DynamicFitResult", "crosscheck_preset", "fit_decay", "fit_friction", "mujoco_check",
           "tip_errors"]

"""The analytical model against MuJoCo: the only layer that imports both ``theory``/``design`` and ``sim``.

- :func:`crosscheck_preset`: a statics preset's loading path solved by both, tip error / L
  against the segment count (``magsoft crosscheck``).
- :func:`mujoco_check`: a design's beam simulated under its field, against the analytical shape.
- :mod:`~magsoft_env.compare.grasp`: two designed fingers close on an object in MuJoCo and lift it.

Importing this package imports mujoco.
"""

from .crosscheck import CrosscheckRow, crosscheck_preset, tip_errors
from .design_check import mujoco_check

__all__ = ["CrosscheckRow", "crosscheck_preset", "mujoco_check", "tip_errors"]

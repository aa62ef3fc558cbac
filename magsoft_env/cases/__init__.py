"""The paper's cases as data (numpy only): statics presets (Figs. 3-4) and crawling robots (Fig. 5).

- :mod:`~magsoft_env.cases.statics`: named loading cases read from ``assets/presets/*.json``
  (mm, mT) into SI: a beam, a loading path and the solver options. Solve one with
  ``solve_path(p.beam, p.fields, **p.solver_options())``.
- :mod:`~magsoft_env.cases.robots`: robots as files (:class:`Robot`: beam, friction, damping, drive),
  YAML or JSON, and the built-in ones in ``assets/robots/``.
- :mod:`~magsoft_env.cases.gaits`: the Fig. 5 crawlers (built-in robots with a drive and what the paper
  reports); :func:`magsoft_env.sim.gait.run_gait` runs them.
- :mod:`~magsoft_env.cases.beamfile`: the beam block of robot and preset files (every profile family).
- :mod:`~magsoft_env.cases.expressions`: the safe expression interpreter of jig curves in files.
"""

from .beamfile import beam_to_dict
from .expressions import compile_expression
from .gaits import GaitPreset, beam_5a, beam_5b, gait_preset, list_gaits
from .robots import Robot, list_robots, load_robot, resolve_robot
from .statics import PathSegment, Preset, beam_from_dict, list_presets, load_preset, preset_from_dict, presets_dir

__all__ = [
    "GaitPreset",
    "PathSegment",
    "Preset",
    "Robot",
    "beam_5a",
    "beam_5b",
    "beam_from_dict",
    "beam_to_dict",
    "compile_expression",
    "gait_preset",
    "list_gaits",
    "list_presets",
    "list_robots",
    "load_preset",
    "load_robot",
    "preset_from_dict",
    "presets_dir",
    "resolve_robot",
]

"""The paper's cases as data (numpy only): statics presets (Figs. 3-4) and crawling robots (Fig. 5).

- :mod:`~magsoft_env.cases.statics`: named loading cases read from ``assets/presets/*.json``
  (mm, mT) into SI: a beam, a loading path and the solver options. Solve one with
  ``solve_path(p.beam, p.fields, **p.solver_options())``.
- :mod:`~magsoft_env.cases.gaits`: the Fig. 5 crawlers (beam, drive, friction, what the paper
  reports); :func:`magsoft_env.sim.gait.run_gait` runs them.
- :mod:`~magsoft_env.cases.expressions`: the safe expression interpreter of jig curves in files.
"""

from .expressions import compile_expression
from .gaits import GaitPreset, beam_5a, beam_5b, gait_preset, list_gaits
from .statics import PathSegment, Preset, beam_from_dict, list_presets, load_preset, preset_from_dict, presets_dir

__all__ = [
    "GaitPreset",
    "PathSegment",
    "Preset",
    "beam_5a",
    "beam_5b",
    "beam_from_dict",
    "compile_expression",
    "gait_preset",
    "list_gaits",
    "list_presets",
    "load_preset",
    "preset_from_dict",
    "presets_dir",
]

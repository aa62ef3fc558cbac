"""The paper's statics cases as named presets: JSON files in ``assets/presets/`` (mm, mT) loaded into SI specs.

A preset is a beam, a loading path (a sequence of applied fields) and the solver options
that reproduce one case of the reference paper. Files use millimetres and millitesla with
the unit in the key name; :func:`load_preset` converts everything to SI once, here.

File format (every key is checked; unknown keys are errors)::

    {
      "description": "...",                      # says every choice the paper leaves open
      "source": "paper Fig. 3a",
      "beam": {
        "length_mm": 25.0,                       # optional when the magnetization fixes it
        "width_mm": 5.0, "thickness_mm": 1.13,
        "volume_fraction": 0.2,                  # or {"cells": [0.1, 0.2]} (equal cells)
        "material": {"E0_MPa": 0.062, "particle_magnetization_kA_per_m": 575,
                     "density_kg_per_m3": 1940},  # optional, paper values by default
        "magnetization": {"kind": "uniform", "angle_deg": 0}
      },
      "path": [{"from_mT": [0, 0], "to_mT": [0, 13], "steps": 27}, {"field_mT": [-5, 13]}],
      "support": "cantilever", "gravity_m_per_s2": 9.81, "coupling": "rotated",
      "extensible": false, "clamp_angle_deg": 0, "sweep_axis": "Bz"
    }

The beam block is the one robot files use (:mod:`magsoft_env.cases.beamfile` lists every profile kind);
instead of ``"beam"`` a preset may name a robot, ``"robot": "paper-5c"`` or a robot file's path, and
solve that robot's beam.

Examples
--------
>>> p = load_preset("fig3a_L25")
>>> round(p.beam.length * 1e3, 3), round(p.fields[-1].Bz * 1e3, 3)
(25.0, 13.0)
"""

from __future__ import annotations

import dataclasses
import difflib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

from ..assets import assets_dir
from ..spec import Beam, Field, ramp
from ..spec.field import as_field, field_pair
from ..spec.loading import check_loading
from ..validate import checked_replace, choice, finite_number, integer
from .beamfile import beam_from_dict, check_keys

SWEEP_AXES = ("Bx", "Bz", "magnitude")
MAX_PATH_STEPS = 10_000

_TOP_KEYS = (
    "robot", "description", "source", "beam", "path", "support", "gravity_m_per_s2", "coupling", "extensible",
    "clamp_angle_deg", "sweep_axis",
)


# ---------------------------------------------------------------------------------------------
# records


@dataclass(frozen=True)
class PathSegment:
    """Fields from ``start`` to ``end`` (T) in ``steps`` evenly spaced states (``steps = 1``: only ``end``)."""

    start: Field
    end: Field
    steps: int = 1

    def __post_init__(self):
        object.__setattr__(self, "start", as_field(self.start, "PathSegment.start"))
        object.__setattr__(self, "end", as_field(self.end, "PathSegment.end"))
        object.__setattr__(self, "steps", integer("PathSegment.steps", self.steps, 1, MAX_PATH_STEPS))

    def fields(self, *, include_start: bool = True) -> list[Field]:
        if self.steps == 1:
            return [self.end]
        return ramp(self.start, self.end, self.steps, include_start=include_start)


@dataclass(frozen=True)
class Preset:
    """One named case: a beam, its loading path and the solver options (all SI).

    Attributes
    ----------
    name, description, source : str
        Identifier, the choices made (in words) and the figure of the paper it reproduces.
    beam : Beam
    path : tuple of PathSegment
        The loading path; :attr:`fields` lists its states in order.
    support : {"cantilever", "free"}
    gravity : float
        Gravitational acceleration (m/s^2), along -z; 0 switches gravity off.
    coupling : {"rotated", "paper"}
    extensible : bool
    clamp_angle : float
        Tangent angle at the clamp (rad), cantilevers only.
    sweep_axis : {"Bx", "Bz", "magnitude"}
        Which field component is the load parameter when plotting against P (Fig. 3a: Bz,
        Fig. 3b: |Bx|).
    config : dict
        The file's content as read (mm, mT), written beside outputs as the resolved config.
    """

    name: str
    description: str
    beam: Beam
    path: tuple
    support: str = "cantilever"
    gravity: float = 9.81
    coupling: str = "rotated"
    extensible: bool = False
    clamp_angle: float = 0.0
    sweep_axis: str = "magnitude"
    source: str = ""
    config: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def fields(self) -> list[Field]:
        """The loading path's fields in order (T); consecutive duplicates are dropped.

        A free-free beam has no preferred orientation at zero field, so zero-field states
        are dropped from its path (the solver ramps up from zero to the first field itself).
        """
        out: list[Field] = []
        for seg in self.path:
            for f in seg.fields():
                if self.support == "free" and f.magnitude == 0.0:
                    continue
                if not out or f != out[-1]:
                    out.append(f)
        if not out:
            raise ValueError(f"preset {self.name!r}: the loading path of a free-free beam needs a non-zero field.")
        return out

    def solver_options(self) -> dict:
        """Keyword arguments for :func:`magsoft_env.solve_path` / :func:`~magsoft_env.solve_equilibrium`."""
        opts = {
            "gravity": self.gravity,
            "support": self.support,
            "coupling": self.coupling,
            "extensible": self.extensible,
        }
        if self.support == "cantilever":
            opts["clamp_angle"] = self.clamp_angle
        return opts

    def replace(self, **changes) -> Preset:
        """A copy with some attributes changed (checked again)."""
        return checked_replace(self, changes, "Preset.replace")

    def with_steps(self, steps: int) -> Preset:
        """The same path with every ramp resampled to ``steps`` states (an integer in [2, MAX_PATH_STEPS])."""
        steps = integer("steps", steps, 2, MAX_PATH_STEPS)
        segs = tuple(
            dataclasses.replace(s, steps=steps) if s.steps > 1 else s for s in self.path
        )
        return self.replace(path=segs)

    def __post_init__(self):
        for key in ("name", "description", "source"):
            if not isinstance(getattr(self, key), str):
                raise ValueError(f"Preset.{key} must be a string, got {getattr(self, key)!r}.")
        if not self.name:
            raise ValueError("Preset.name must be a non-empty string, got ''.")
        if not isinstance(self.beam, Beam):
            raise ValueError(f"preset {self.name!r} beam must be a magsoft_env.Beam, got {type(self.beam).__name__}.")
        if not isinstance(self.config, dict):
            raise ValueError(f"preset {self.name!r} config must be a dict, got {type(self.config).__name__}.")
        lo = check_loading(gravity=self.gravity, support=self.support, coupling=self.coupling,
                           extensible=self.extensible, clamp_angle=self.clamp_angle, where=f"preset {self.name!r} ")
        choice(f"preset {self.name!r} sweep_axis", self.sweep_axis, SWEEP_AXES)
        if (isinstance(self.path, (str, bytes)) or not isinstance(self.path, (tuple, list)) or not self.path
                or not all(isinstance(s, PathSegment) for s in self.path)):
            raise ValueError(f"preset {self.name!r} path must be a non-empty sequence of PathSegment.")
        object.__setattr__(self, "path", tuple(self.path))
        object.__setattr__(self, "gravity", lo["gravity"])
        object.__setattr__(self, "clamp_angle", lo["clamp_angle"])


# ---------------------------------------------------------------------------------------------
# loading


def presets_dir() -> Path:
    """Folder of the shipped preset files."""
    return assets_dir() / "presets"


def list_presets() -> list[str]:
    """Names of the shipped presets, sorted."""
    d = presets_dir()
    return sorted(p.stem for p in d.glob("*.json")) if d.is_dir() else []


def load_preset(name: str) -> Preset:
    """Load a shipped preset by name (see :func:`list_presets`); a path to a ``.json`` file also works.

    Raises
    ------
    ValueError
        Unknown name (with the closest names) or an invalid file (naming the key).
    """
    if not isinstance(name, str) or not name:
        raise ValueError(f"preset name must be a non-empty string, got {name!r}.")
    if name.endswith(".json"):
        path = Path(name)
        if not path.is_file():
            raise ValueError(f"preset file {name!r} does not exist.")
    else:
        names = list_presets()
        if name not in names:
            hint = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
            extra = f" Did you mean {', '.join(map(repr, hint))}?" if hint else ""
            raise ValueError(f"unknown preset {name!r}.{extra} Available presets: {', '.join(names)}.")
        path = presets_dir() / f"{name}.json"
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except json.JSONDecodeError as exc:
        raise ValueError(f"preset file {path.name!r} is not valid JSON: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"preset file {path.name!r} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise ValueError(f"preset file {str(path)!r} cannot be read: {exc.strerror or exc}") from None
    return preset_from_dict(data, name=path.stem)


def preset_from_dict(data: dict, *, name: str) -> Preset:
    """Build a :class:`Preset` from a dict in the file format above (mm, mT -> SI)."""
    where = f"preset {name!r}"
    check_keys(where, data, _TOP_KEYS, required=("description", "path"))
    if ("beam" in data) == ("robot" in data):
        raise ValueError(f"{where} needs exactly one of 'beam' (a beam block) and 'robot' (a robot name or file).")
    if "beam" in data:
        beam = beam_from_dict(data["beam"], where=f"{where} beam")
    else:
        from .robots import load_robot

        beam = load_robot(data["robot"]).beam
    path = _path_from_list(data["path"], where=f"{where} path")
    for key in ("description", "source"):
        if key in data and not isinstance(data[key], str):
            raise ValueError(f"{where} {key} must be a string, got {data[key]!r}.")
    return Preset(
        name=name,
        description=str(data["description"]),
        source=str(data.get("source", "")),
        beam=beam,
        path=path,
        support=data.get("support", "cantilever"),
        gravity=data.get("gravity_m_per_s2", 9.81),
        coupling=data.get("coupling", "rotated"),
        extensible=data.get("extensible", False),
        clamp_angle=math.radians(finite_number(f"{where} clamp_angle_deg", data.get("clamp_angle_deg", 0.0),
                                               unit="deg")),
        sweep_axis=data.get("sweep_axis", "magnitude"),
        config=data,
    )


def _path_from_list(items, *, where: str) -> tuple[PathSegment, ...]:
    if not isinstance(items, list) or not items:
        raise ValueError(f"{where} must be a non-empty list of segments, got {items!r}.")
    segs: list[PathSegment] = []
    prev = Field(0.0, 0.0)
    for i, item in enumerate(items):
        w = f"{where}[{i}]"
        if not isinstance(item, dict):
            raise ValueError(f"{w} must be an object, got {item!r}.")
        if "field_mT" in item:
            check_keys(w, item, ("field_mT",))
            end = _field_mT(item["field_mT"], f"{w} field_mT")
            segs.append(PathSegment(end, end, 1))
        else:
            check_keys(w, item, ("from_mT", "to_mT", "steps"), required=("to_mT", "steps"))
            start = _field_mT(item["from_mT"], f"{w} from_mT") if "from_mT" in item else prev
            end = _field_mT(item["to_mT"], f"{w} to_mT")
            steps = integer(f"{w} steps", item["steps"], 2, MAX_PATH_STEPS)
            segs.append(PathSegment(start, end, steps))
        prev = segs[-1].end
    return tuple(segs)


def _field_mT(value, name: str) -> Field:
    bx, bz = field_pair(name, value, "[B_x, B_z] in mT", planar="preset files")
    return Field.from_mT(finite_number(f"{name} B_x", bx, unit="mT"), finite_number(f"{name} B_z", bz, unit="mT"))

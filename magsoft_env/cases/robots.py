"""Robots as data: a beam plus what its dynamics need, saved to and loaded from YAML or JSON files.

A :class:`Robot` is what every dynamic tool takes (``run_gait``, the floor environments' ``robot=``,
``magsoft gait --robot``, ``magsoft video --robot``): the :class:`~magsoft_env.Beam` (geometry, material,
volume-fraction and magnetization profiles), the floor friction and hinge damping, a name and a
description, and optionally a default drive. The paper's Fig. 5 crawlers ship as robot files
(``assets/robots/*.yml``); :func:`load_robot` reads a built-in name or a path.

File format (YAML or JSON by the extension; units in the key names; every key checked)::

    magsoft_robot: 1                 # format version
    name: my-crawler
    description: what it is and which choices were made
    beam: {length_mm: 25, width_mm: 5, thickness_mm: 1.13, volume_fraction: 0.2,
           magnetization: {kind: jig_polyline, x_mm: [0, 12.5, 25], z_mm: [0, -3, 0]}}
    contact: {friction: 0.5, retardation_time_ms: 5}
    drive: {shape: sine, amplitude_x_mT: 0, amplitude_z_mT: 2, frequency_Hz: 2, phase_deg: 0}
                                     # optional amplitude_y_mT, phase_y_deg: a three-axis drive (the 3D rod)
    simulation: {segments: 20, timestep_ms: 0.2,   # optional: the robot's own numerics (default 20, 0.2 ms),
                 scenes: {channel: {segments: 40, timestep_ms: 0.1}}}   # and a scene's, where they differ
    design_field_mT: [0.0, 19.99]    # optional: the held field a design found (magsoft design), [B_x, B_z]
    field_source: {type: sphere, position_mm: [12, 0, 15], radius_mm: 3, remanence_T: [0, 0, 1.2]}
                                     # optional: a field source (magnet, coil system, ...; docs/fields.md,
                                     # "Sources in files"), kept here as data; the tools that take it (magsoft
                                     # solve, gait, video) read it with magsoft_env.fields.load_source
    paper: {speed_mm_per_s: -0.85, direction: left}    # optional: what a reference reports (signed along +x;
                                                       # direction reversible: the speed either way, >= 0)

The beam block and its profile kinds are those of :mod:`magsoft_env.cases.beamfile`.

Examples
--------
>>> import magsoft_env as ms
>>> robot = ms.Robot("strip", ms.Beam(25e-3, 5e-3, 1.13e-3, magnetization=ms.alternating_cells(2)))
>>> robot.friction, robot.drive is None
(0.5, True)
"""

from __future__ import annotations

import difflib
import json
import os
from dataclasses import dataclass, replace
from dataclasses import field as dc_field
from pathlib import Path

import yaml

from ..assets import assets_dir
from ..io import write_text_atomic
from ..spec import Beam, Field, as_field
from ..spec.drive import WAVE_SHAPES, Waveparams
from ..spec.field import field_pair, planar_field
from ..units import MM
from ..validate import checked_replace, choice, finite_number, in_range, integer, nonnegative
from .beamfile import beam_from_dict, beam_to_dict, check_keys
from .numbers import dump_json, dump_yaml, load_json, load_yaml, milli, radians, to_degrees, to_milli

#: Version of the robot file format written by :meth:`Robot.save`.
FORMAT_VERSION = 1
#: File suffixes :func:`load_robot` and :meth:`Robot.save` know.
ROBOT_SUFFIXES = (".yml", ".yaml", ".json")
#: Default sliding friction coefficient between silicone and the substrate (dimensionless).
DEFAULT_FRICTION = 0.5
#: Default Kelvin-Voigt retardation time of the silicone (s): hinge damping c = retardation_time x k.
DEFAULT_RETARDATION_TIME = 5e-3
#: Default number of rod segments in MuJoCo.
DEFAULT_SEGMENTS = 20
#: Default MuJoCo timestep (s) of a robot whose file states none: with :data:`DEFAULT_SEGMENTS`, the ``"fast"``
#: fidelity (:data:`magsoft_env.cases.gaits.FIDELITY`). A robot whose crawl needs finer numerics says so in its
#: file (``simulation: {segments: ..., timestep_ms: ...}``), as the paper's 5a and 5b do (docs/convergence.md).
DEFAULT_TIMESTEP = 2e-4
#: Largest timestep accepted (s): a step beyond 10 ms cannot resolve the floor contact of any beam here (a value in
#: ms given as s).
MAX_ROBOT_TIMESTEP = 1e-2
#: Scenes a robot may state its own numerics for (``simulation: {scenes: {channel: {...}}}``): the floor scenes of
#: :mod:`magsoft_env.sim.model`.
NUMERICS_SCENES = ("floor", "channel", "obstacle")
#: Ranges accepted: a friction coefficient beyond 10 or a retardation time beyond 1 s is a unit mistake.
MAX_FRICTION = 10.0
MAX_RETARDATION_TIME = 1.0
SEGMENTS_RANGE = (2, 1000)
DIRECTIONS = ("", "left", "right", "reversible")
#: Largest robot file read (bytes): a beam with 100,000 samples is about 4 MB.
MAX_FILE_BYTES = 50 * 2**20

_TOP_KEYS = ("magsoft_robot", "name", "description", "source", "beam", "contact", "drive", "design_field_mT",
             "simulation", "paper", "reverse", "field_source")
_CONTACT_KEYS = ("friction", "retardation_time_ms")
_DRIVE_KEYS = ("shape", "amplitude_x_mT", "amplitude_z_mT", "frequency_Hz", "phase_deg", "coil_time_ms",
               "amplitude_y_mT", "phase_y_deg")
_PAPER_KEYS = ("speed_mm_per_s", "direction")


@dataclass(frozen=True)
class Robot:
    """A hard-magnetic soft robot: a beam and what its dynamics need (frozen, validated). SI units.

    Parameters
    ----------
    name : str
        Identifier (used in results and file names).
    beam : Beam
        Geometry, material, volume-fraction and magnetization profiles.
    description : str
        What the robot is and which choices were made.
    friction : float
        Sliding friction coefficient with the floor, in [0, 10].
    retardation_time : float
        Kelvin-Voigt retardation time of the silicone (s), in [0, 1]: the rod's hinge damping is
        ``retardation_time x`` its bending stiffness.
    drive : Waveparams or None
        The default periodic field (open-loop gait), or None.
    design_field : Field or None
        The held field (T) the robot was designed for (``magsoft design`` finds it with the profile), or None:
        ``magsoft solve --robot`` ramps to it when no ``--field-mT`` is given. A ``(B_x, B_z)`` pair is accepted.
    segments : int
        Rod segments the simulator uses by default, in [2, 1000].
    timestep : float
        MuJoCo timestep (s) the simulator uses by default, in (0, 0.01]. With ``segments``, the robot's own
        numerics: what its crawl needs to converge (the paper robots' files state the error they give;
        docs/convergence.md). The gaits and the floor environments both use them unless told otherwise
        (``fidelity=``, ``segments=``, ``timestep=`` / ``sim_dt=``).
    scene_numerics : tuple of (scene, segments, timestep)
        Numerics for a scene whose contacts need others than the floor's (``"channel"``, ``"obstacle"``):
        the floor environments and videos of that scene use them instead of ``segments`` and ``timestep``. At
        most one entry per scene.
    paper_speed : float or None
        Speed a reference reports (m/s, signed along +x: < 0 for ``"left"``, > 0 for ``"right"``), for comparison
        only. For a ``"reversible"`` robot it is the speed in either direction (>= 0).
    paper_direction : str
        ``""``, ``"left"``, ``"right"`` or ``"reversible"``: what a reference reports.
    reverse : bool
        The drive's B_x was inverted (:meth:`reversed`); results carry ``" (reverse)"`` in their name.
    source : str
        Where the robot comes from (a figure, a design run).
    field_source : dict or None
        A field source besides the drive (a magnet, a coil system at its currents, ...) as plain data: the dict of
        :func:`magsoft_env.fields.source_from_dict` (docs/fields.md, "Sources in files"), kept as given and turned
        into a source by the tools that take it (``magsoft solve``, ``gait``, ``video``: ``--source`` wins over
        it). Only its form (plain JSON-like data, a mapping) is checked here; its content is checked when it is
        read as a source.
    field_source_dir : str
        Folder that relative ``file`` paths in ``field_source`` start from (the robot file's folder when loaded from
        a file; "" the working directory). Not compared, not written.
    """

    name: str
    beam: Beam
    description: str = ""
    friction: float = DEFAULT_FRICTION
    retardation_time: float = DEFAULT_RETARDATION_TIME
    drive: Waveparams | None = None
    design_field: Field | None = None
    segments: int = DEFAULT_SEGMENTS
    timestep: float = DEFAULT_TIMESTEP
    scene_numerics: tuple = ()
    paper_speed: float | None = None
    paper_direction: str = ""
    reverse: bool = False
    source: str = ""
    field_source: dict | None = dc_field(default=None, hash=False)
    field_source_dir: str = dc_field(default="", compare=False, repr=False, hash=False)

    def __post_init__(self):
        for key in ("name", "description", "source"):
            if not isinstance(getattr(self, key), str):
                raise ValueError(f"Robot.{key} must be a string, got {getattr(self, key)!r}.")
        if not self.name.strip():
            raise ValueError("Robot.name must be a non-empty string, got ''.")
        if not isinstance(self.beam, Beam):
            raise ValueError(f"Robot.beam must be a magsoft_env.Beam, got {type(self.beam).__name__}.")
        object.__setattr__(self, "friction", in_range("Robot.friction", self.friction, 0.0, MAX_FRICTION))
        rt = nonnegative("Robot.retardation_time", self.retardation_time, unit="s")
        if rt > MAX_RETARDATION_TIME:
            raise ValueError(f"Robot.retardation_time must lie in [0, {MAX_RETARDATION_TIME:g}] s, got "
                             f"{self.retardation_time!r} (seconds: 5 ms is 0.005).")
        object.__setattr__(self, "retardation_time", rt)
        if self.drive is not None and not isinstance(self.drive, Waveparams):
            raise ValueError(f"Robot.drive must be a Waveparams or None, got {type(self.drive).__name__}.")
        if self.design_field is not None:
            design = as_field(self.design_field, "Robot.design_field")
            object.__setattr__(self, "design_field", planar_field(design, "Robot.design_field (a planar design's "
                                                                          "held field)"))
        object.__setattr__(self, "segments", integer("Robot.segments", self.segments, *SEGMENTS_RANGE))
        object.__setattr__(self, "timestep", _timestep("Robot.timestep", self.timestep))
        object.__setattr__(self, "scene_numerics", _scene_numerics(self.scene_numerics))
        if self.paper_speed is not None:
            object.__setattr__(self, "paper_speed", finite_number("Robot.paper_speed", self.paper_speed, unit="m/s"))
        choice("Robot.paper_direction", self.paper_direction, DIRECTIONS)
        _check_paper_sign(self.paper_speed, self.paper_direction)
        if not isinstance(self.reverse, bool):
            raise ValueError(f"Robot.reverse must be True or False, got {self.reverse!r}.")
        if self.field_source is not None:
            object.__setattr__(self, "field_source", _plain_source(self.field_source))
        if not isinstance(self.field_source_dir, str):
            raise ValueError(f"Robot.field_source_dir must be a string (a folder), got {self.field_source_dir!r}.")

    # -------------------------------------------------------------- derived
    @property
    def wave(self) -> Waveparams:
        """The drive; raises ValueError for a robot without one (the gait tools need it)."""
        if self.drive is None:
            raise ValueError(f"robot {self.name!r} has no drive: give one (Robot(..., drive=Waveparams(...)), or "
                             "a 'drive' block in its file).")
        return self.drive

    def reversed(self) -> Robot:
        """The same robot with the drive's B_x inverted (the paper's reversal of Fig. 5c)."""
        wave = self.wave
        return replace(self, drive=replace(wave, amplitude_x=-wave.amplitude_x), reverse=not self.reverse)

    def replace(self, **changes) -> Robot:
        """A copy with some fields changed (checked again)."""
        return checked_replace(self, changes, "Robot.replace")

    # -------------------------------------------------------------- files
    def to_dict(self, *, sample_functions: bool = False) -> dict:
        """The robot file's content (mm, mT, ms, deg in the key names)."""
        out = {"magsoft_robot": FORMAT_VERSION, "name": self.name, "description": self.description}
        if self.source:
            out["source"] = self.source
        out["beam"] = beam_to_dict(self.beam, sample_functions=sample_functions, where=f"robot {self.name!r} beam")
        out["contact"] = {"friction": self.friction,
                          "retardation_time_ms": to_milli(self.retardation_time)}
        if self.drive is not None:
            d = self.drive
            out["drive"] = {"shape": d.shape, "amplitude_x_mT": to_milli(d.amplitude_x),
                            "amplitude_z_mT": to_milli(d.amplitude_z), "frequency_Hz": d.frequency,
                            "phase_deg": to_degrees(d.phase)}
            if d.coil_time:
                out["drive"]["coil_time_ms"] = to_milli(d.coil_time)
            if d.amplitude_y or d.phase_y:  # a three-axis drive (the 3D rod)
                out["drive"]["amplitude_y_mT"] = to_milli(d.amplitude_y)
                out["drive"]["phase_y_deg"] = to_degrees(d.phase_y)
        if self.design_field is not None:
            out["design_field_mT"] = [to_milli(self.design_field.Bx), to_milli(self.design_field.Bz)]
        out["simulation"] = {"segments": self.segments, "timestep_ms": to_milli(self.timestep)}
        if self.scene_numerics:
            out["simulation"]["scenes"] = {sc: {"segments": n, "timestep_ms": to_milli(dt)}
                                           for sc, n, dt in self.scene_numerics}
        if self.paper_speed is not None or self.paper_direction:
            paper = {}
            if self.paper_speed is not None:
                paper["speed_mm_per_s"] = to_milli(self.paper_speed)
            if self.paper_direction:
                paper["direction"] = self.paper_direction
            out["paper"] = paper
        if self.reverse:
            out["reverse"] = True
        if self.field_source is not None:
            out["field_source"] = _plain_source(self.field_source)
        return out

    def save(self, path, *, sample_functions: bool = False) -> Path:
        """Write the robot to ``path`` (``.yml``/``.yaml`` or ``.json``), atomically; returns the path.

        A profile of a Python function cannot be written: ``sample_functions=True`` stores it as
        samples (:func:`magsoft_env.sample_profile`), otherwise a ValueError says so before anything is written."""
        path = Path(os.fspath(path))
        suffix = _suffix(path)
        data = self.to_dict(sample_functions=sample_functions)
        if suffix == ".json":
            text = dump_json(data)
        else:
            text = f"# magsoft_env robot file (format {FORMAT_VERSION}); units in the key names\n" + dump_yaml(data)
        return write_text_atomic(path, text)

    @classmethod
    def from_dict(cls, data: dict, *, where: str = "robot", base_dir=None) -> Robot:
        """A Robot from a robot file's content (see the module docstring). ``base_dir``: the folder relative
        ``file`` paths of its ``field_source`` start from (the file's folder)."""
        check_keys(where, data, _TOP_KEYS, required=("name", "beam"))
        if isinstance(data.get("source"), dict):
            raise ValueError(f"{where} source is where the robot comes from (text); a field source (a magnet, a coil "
                             "system) goes under field_source: (docs/robots.md).")
        field_source = data.get("field_source")
        if field_source is not None:
            field_source = _plain_source(field_source, where=f"{where} field_source")
        version = data.get("magsoft_robot", FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise ValueError(f"{where} has format version {version!r}; this magsoft_env reads version "
                             f"{FORMAT_VERSION}.")
        contact = data.get("contact", {})
        check_keys(f"{where} contact", contact, _CONTACT_KEYS)
        sim = data.get("simulation", {})
        check_keys(f"{where} simulation", sim, ("segments", "timestep_ms", "scenes"))
        scenes = sim.get("scenes", {})
        check_keys(f"{where} simulation scenes", scenes, NUMERICS_SCENES)
        scene_numerics = []
        for sc, block in scenes.items():
            w = f"{where} simulation scenes {sc}"
            check_keys(w, block, ("segments", "timestep_ms"), required=("segments", "timestep_ms"))
            scene_numerics.append((sc, block["segments"], _milli(f"{w} timestep_ms", block["timestep_ms"], "ms")))
        paper = data.get("paper", {})
        check_keys(f"{where} paper", paper, _PAPER_KEYS)
        drive = None
        if data.get("drive") is not None:
            drive = _drive_from_dict(data["drive"], where=f"{where} drive")
        speed = paper.get("speed_mm_per_s")
        design_field = None
        if data.get("design_field_mT") is not None:
            design_field = _field_mT(f"{where} design_field_mT", data["design_field_mT"])
        return cls(
            name=data["name"], beam=beam_from_dict(data["beam"], where=f"{where} beam"),
            description=data.get("description", ""), source=data.get("source", ""),
            friction=contact.get("friction", DEFAULT_FRICTION),
            retardation_time=_milli(f"{where} contact retardation_time_ms",
                                    contact.get("retardation_time_ms", DEFAULT_RETARDATION_TIME * 1e3), "ms"),
            drive=drive, design_field=design_field, segments=sim.get("segments", DEFAULT_SEGMENTS),
            timestep=_milli(f"{where} simulation timestep_ms", sim.get("timestep_ms", DEFAULT_TIMESTEP * 1e3), "ms"),
            scene_numerics=tuple(scene_numerics),
            paper_speed=None if speed is None else _milli(f"{where} paper speed_mm_per_s", speed, "mm/s"),
            paper_direction=paper.get("direction", ""), reverse=data.get("reverse", False),
            field_source=field_source, field_source_dir="" if base_dir is None else os.fspath(base_dir),
        )

    def summary(self) -> dict:
        """Name, beam size (mm), drive and contact in display units, for tables and JSON."""
        b = self.beam
        out = {"name": self.name, "length_mm": b.length / MM, "width_mm": b.width / MM,
               "thickness_mm": b.thickness / MM, "friction": self.friction,
               "retardation_time_ms": self.retardation_time * 1e3, "segments": self.segments,
               "timestep_ms": self.timestep * 1e3}
        if self.drive is not None:
            out["drive"] = self.drive.describe()
        return out


def _check_paper_sign(speed, direction: str) -> None:
    """The paper speed's sign agrees with the paper direction (a reversible robot's speed is a magnitude)."""
    if speed is None or speed == 0.0:
        return
    want = {"left": (speed < 0.0, "< 0 (signed along +x)"), "right": (speed > 0.0, "> 0 (signed along +x)"),
            "reversible": (speed > 0.0, ">= 0 (the speed in either direction)")}.get(direction)
    if want is not None and not want[0]:
        raise ValueError(f"Robot.paper_speed must be {want[1]} for paper_direction {direction!r}, got "
                         f"{speed!r} m/s.")


def _timestep(name: str, value) -> float:
    dt = finite_number(name, value, unit="s")
    if not 0.0 < dt <= MAX_ROBOT_TIMESTEP:
        raise ValueError(f"{name} must lie in (0, {MAX_ROBOT_TIMESTEP:g}] s, got {value!r} "
                         "(seconds: 0.1 ms is 0.0001).")
    return dt


def _scene_numerics(entries) -> tuple:
    """``Robot.scene_numerics`` checked: (scene, segments, timestep) triples, one per scene, scenes in
    :data:`NUMERICS_SCENES`."""
    if isinstance(entries, (str, bytes)) or not hasattr(entries, "__iter__"):
        raise ValueError(f"Robot.scene_numerics must be a tuple of (scene, segments, timestep), got {entries!r}.")
    out, seen = [], set()
    for e in entries:
        if not isinstance(e, (tuple, list)) or len(e) != 3:
            raise ValueError(f"Robot.scene_numerics entries must be (scene, segments, timestep), got {e!r}.")
        scene = choice("Robot.scene_numerics scene", e[0], NUMERICS_SCENES)
        if scene in seen:
            raise ValueError(f"Robot.scene_numerics names scene {scene!r} twice.")
        seen.add(scene)
        out.append((scene, integer(f"Robot.scene_numerics[{scene!r}] segments", e[1], *SEGMENTS_RANGE),
                    _timestep(f"Robot.scene_numerics[{scene!r}] timestep", e[2])))
    return tuple(out)


def _milli(name: str, raw, unit: str) -> float:
    """A milli-unit number of the file checked (in its unit, for the message), then in SI from its digits."""
    finite_number(name, raw, unit=unit)
    return milli(raw)


def _field_mT(name: str, raw) -> Field:
    """A ``[B_x, B_z]`` pair in mT of the file, in T from its digits (reads back exactly what was written)."""
    bx, bz = field_pair(name, raw, "[B_x, B_z] in mT", planar="design_field_mT values (a planar design's held field)")
    return Field(_milli(f"{name} B_x", bx, "mT"), _milli(f"{name} B_z", bz, "mT"))


def _degrees(name: str, raw) -> float:
    finite_number(name, raw, unit="deg")
    return radians(raw)


def _drive_from_dict(d, *, where: str) -> Waveparams:
    check_keys(where, d, _DRIVE_KEYS, required=("frequency_Hz",))
    shape = choice(f"{where} shape", d.get("shape", "sine"), WAVE_SHAPES)
    return Waveparams(
        amplitude_x=_milli(f"{where} amplitude_x_mT", d.get("amplitude_x_mT", 0.0), "mT"),
        amplitude_z=_milli(f"{where} amplitude_z_mT", d.get("amplitude_z_mT", 0.0), "mT"),
        frequency=finite_number(f"{where} frequency_Hz", d["frequency_Hz"], unit="Hz"),
        phase=_degrees(f"{where} phase_deg", d.get("phase_deg", 0.0)),
        shape=shape,
        coil_time=_milli(f"{where} coil_time_ms", d.get("coil_time_ms", 0.0), "ms"),
        amplitude_y=_milli(f"{where} amplitude_y_mT", d.get("amplitude_y_mT", 0.0), "mT"),
        phase_y=_degrees(f"{where} phase_y_deg", d.get("phase_y_deg", 0.0)),
    )


def _plain_source(value, *, where: str = "Robot.field_source") -> dict:
    """A deep copy of a field source description, checked to be plain data: a mapping of text keys to numbers,
    text, booleans, None, lists and mappings (what YAML and JSON hold). Its content is the fields layer's to
    check (``magsoft_env.fields.source_from_dict``), where it is read as a source."""
    if not isinstance(value, dict):
        raise ValueError(f"{where} must be a mapping, a field source as in docs/fields.md (\"Sources in files\"), "
                         f"e.g. {{type: dipole, position_mm: [0, 0, 20], moment_A_m2: [0, 0, 0.05]}}, got {value!r}.")

    def copy(v, path):
        if isinstance(v, dict):
            out = {}
            for k, item in v.items():
                if not isinstance(k, str):
                    raise ValueError(f"{where}{path} has a key that is not text: {k!r}.")
                out[k] = copy(item, f"{path}.{k}")
            return out
        if isinstance(v, (list, tuple)):
            return [copy(item, f"{path}[{i}]") for i, item in enumerate(v)]
        if v is None or isinstance(v, (str, bool, int, float)):
            return v
        raise ValueError(f"{where}{path} must be plain data (numbers, text, lists, mappings), got "
                         f"{type(v).__name__} {v!r}.")

    return copy(value, "")


def _suffix(path: Path) -> str:
    suffix = path.suffix.lower()
    if suffix not in ROBOT_SUFFIXES:
        raise ValueError(f"robot file must end in one of {list(ROBOT_SUFFIXES)}, got {str(path)!r}.")
    return suffix


def robots_dir() -> Path:
    """Folder of the built-in robot files."""
    return assets_dir() / "robots"


def list_robots() -> tuple[str, ...]:
    """Names of the built-in robots (the paper's Fig. 5 crawlers), sorted."""
    d = robots_dir()
    return tuple(sorted(p.stem for p in d.glob("*.yml"))) if d.is_dir() else ()


def load_robot(source) -> Robot:
    """A :class:`Robot` from a built-in name (:func:`list_robots`) or a ``.yml``/``.yaml``/``.json`` path.

    Raises
    ------
    ValueError
        Unknown name (with the closest names), a missing or unreadable file, or invalid content (naming the key).
    """
    if isinstance(source, Robot):
        return source
    if not isinstance(source, (str, os.PathLike)) or not os.fspath(source):
        raise ValueError(f"robot must be a built-in name {list(list_robots())}, a robot file path or a Robot, "
                         f"got {source!r}.")
    text = os.fspath(source)
    if isinstance(source, str) and Path(text).suffix.lower() not in ROBOT_SUFFIXES:
        names = list_robots()
        if text not in names:
            hint = difflib.get_close_matches(text, names, n=1, cutoff=0.5)
            extra = f" Did you mean {hint[0]!r}?" if hint else ""
            raise ValueError(f"robot must be one of {list(names)} or a robot file (.yml, .yaml, .json), got "
                             f"{text!r}.{extra}")
        path = robots_dir() / f"{text}.yml"
    else:
        path = Path(text)
    suffix = _suffix(path)
    if not path.is_file():
        raise ValueError(f"robot file {str(path)!r} does not exist.")
    if path.stat().st_size > MAX_FILE_BYTES:
        raise ValueError(f"robot file {str(path)!r} is larger than {MAX_FILE_BYTES // 2**20} MiB.")
    try:
        raw = path.read_text(encoding="utf-8")
        data = load_json(raw) if suffix == ".json" else load_yaml(raw)
    except (json.JSONDecodeError, yaml.YAMLError) as exc:
        raise ValueError(f"robot file {str(path)!r} is not valid {suffix[1:].upper()}: {exc}") from None
    except UnicodeDecodeError as exc:
        raise ValueError(f"robot file {str(path)!r} is not UTF-8 text: {exc}") from None
    except OSError as exc:
        raise ValueError(f"robot file {str(path)!r} cannot be read: {exc.strerror or exc}") from None
    return Robot.from_dict(data, where=f"robot file {path.name!r}", base_dir=path.resolve().parent)


def resolve_robot(value, *, name: str = "robot") -> Robot:
    """``value`` (a built-in name, a file path or a :class:`Robot`) as a Robot; ValueError naming ``name`` otherwise."""
    try:
        return load_robot(value)
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if msg.startswith(name) or name == "robot" else f"{name}: {msg}") from None


__all__ = ["DEFAULT_FRICTION", "DEFAULT_RETARDATION_TIME", "DEFAULT_SEGMENTS", "DEFAULT_TIMESTEP", "FORMAT_VERSION",
           "ROBOT_SUFFIXES",
           "Robot", "list_robots", "load_robot", "resolve_robot", "robots_dir"]

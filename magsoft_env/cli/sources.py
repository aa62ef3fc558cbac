"""Field sources on the command line: ``--source NAME_OR_FILE`` and ``--currents-A I ...`` of ``magsoft solve``,
``magsoft gait`` and ``magsoft video``, and a robot file's ``field_source:`` block (docs/robots.md).

A source is read by :func:`magsoft_env.fields.load_source` (a calibration name with its currents, a YAML or JSON
source file, an MPEM calibration file); every error is a ValueError naming the flag (or the robot file) and the
key or coil, raised before any work.
"""

from __future__ import annotations

import math

import numpy as np

from ..units import MM, MT


def add_source_flags(p, *, what: str) -> None:
    """``--source NAME_OR_FILE`` and ``--currents-A I ...``; ``what`` says what the source does in this command."""
    p.add_argument("--source", default=None, metavar="NAME_OR_FILE",
                   help=f"a field source: a source file (.yaml, .yml, .json: magnets, dipoles, loops, coil systems; "
                        f"docs/fields.md, 'Sources in files') or a coil system by name (navion, cardiomag, ...: give "
                        f"--currents-A); {what}. Wins over a robot file's field_source")
    p.add_argument("--currents-A", type=float, nargs="+", default=None, metavar="I",
                   help="--source NAME (or an MPEM calibration file): the coil currents (A), one per coil")


def source_from_args(args, robot=None):
    """The field source of ``--source`` (with ``--currents-A``), else the ``field_source`` of ``robot`` (a Robot or
    None), else None. Returns ``(source, origin)``: ``origin`` is ``"--source"``, ``"robot file"`` or None."""
    from magsoft_env.fields import load_source

    spec = getattr(args, "source", None)
    currents = getattr(args, "currents_A", None)
    if currents is not None:
        if spec is None:
            raise ValueError("--currents-A gives a coil system's currents: give it with --source NAME_OR_FILE (a coil "
                             "system by name, e.g. --source navion --currents-A 10 0 -5).")
        bad = [v for v in currents if not (math.isfinite(v) and abs(v) <= 1e6)]
        if bad:
            raise ValueError(f"--currents-A must be finite currents (A), got {currents}.")
    if spec is not None:
        try:
            return load_source(spec, currents=currents), "--source"
        except ValueError as exc:
            raise ValueError(f"--source {spec}: {_flag_words(str(exc))}") from None
    if robot is not None and getattr(robot, "field_source", None) is not None:
        return robot_field_source(robot), "robot file"
    return None, None


def _flag_words(message: str) -> str:
    """A :func:`~magsoft_env.fields.load_source` message in the command line's words (``--currents-A``)."""
    import re

    message = re.sub(r"^load_source(\('[^']*'\))?: ", "", message)
    return message.replace("currents= (A", "--currents-A (A").replace("currents must hold", "--currents-A must hold")


def robot_field_source(robot):
    """The field source of a robot's ``field_source`` block, or None (:func:`magsoft_env.sim.sources.robot_source`)."""
    from magsoft_env.sim.sources import robot_source

    return robot_source(robot)


def source_description(source) -> dict | None:
    """The source as data (:func:`magsoft_env.fields.source_to_dict`), or None where it cannot be written."""
    from magsoft_env.fields import source_to_dict

    try:
        return source_to_dict(source)
    except (ValueError, TypeError):
        return None


def source_label(args, origin) -> str:
    """How the text output names the source."""
    if origin == "--source":
        cur = getattr(args, "currents_A", None)
        return args.source + ("" if cur is None else f" at {' '.join(f'{v:g}' for v in cur)} A")
    return "the robot file's field_source"


def field_at(source, point, t: float = 0.0) -> np.ndarray:
    """B (T, (3,)) of ``source`` at ``point`` (m), at time ``t`` for a moving source."""
    p = np.asarray(point, dtype=float).reshape(1, 3)
    try:
        B, _ = source.field_and_gradient(p, t=t)
    except TypeError:
        B, _ = source.field_and_gradient(p)
    return np.asarray(B[0], dtype=float)


def markers_text(source) -> str:
    """The source's magnets, dipoles and loop centres (mm), for the text output; '' when it knows none."""
    from magsoft_env.fields import source_markers

    parts = []
    for kind, pts in source_markers(source):
        for p in np.asarray(pts) / MM:
            if np.linalg.norm(p) < 200.0:  # a navigation system's coils (25-37 cm away) are left out
                parts.append(f"{kind} at ({p[0]:.4g}, {p[1]:.4g}, {p[2]:.4g}) mm")
    return "; ".join(parts)


def mT(v) -> list[float]:
    return [float(x) / MT for x in v]

"""``magsoft export``: write a robot's MuJoCo model in a scene as MJCF, with its field convention.

The convention and an example script: docs/sim.md, "Export to MJCF".
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from .output import dumps_json, out_file


def add_parser(subparsers) -> argparse.ArgumentParser:
    p = subparsers.add_parser(
        "export",
        help="write a robot's MuJoCo model in a scene as MJCF (.xml) for your own MuJoCo scripts",
        description=(
            "Write the MuJoCo model the package simulates for a robot (its segments, timestep, friction, damping "
            "and contact) in a scene as an MJCF file that plain mujoco.MjModel.from_xml_path loads. The magnetic "
            "couples are actuators: for P poles, ctrl[:P] = B_x and ctrl[P:] = B_z (tesla), written before every "
            "mj_step with the field at data.time (a comment at the top of the file says so; docs/sim.md, "
            "'Export to MJCF')."
        ),
    )
    p.add_argument("--robot", required=True,
                   help="robot file (.yml, .yaml, .json) or built-in name (paper-5a, paper-5b, paper-5c, ...)")
    p.add_argument("--scene", default="floor", help="floor (default), channel or obstacle")
    p.add_argument("--segments", type=int, default=None, help="rod segments (default: the robot's own)")
    p.add_argument("--timestep-ms", type=float, default=None, help="MuJoCo timestep in ms (default: the robot's own)")
    p.add_argument("--feature-x-mm", type=float, default=None,
                   help="channel entrance or obstacle's left face, x in mm (default: the scene's)")
    p.add_argument("--json", action="store_true", help="print a JSON summary instead of text")
    p.add_argument("--out", type=Path, required=True, metavar="PATH", help="the .xml file to write")
    p.set_defaults(run=run)
    return p


def robot_file_exists(value: str, flag: str = "--robot") -> None:
    """A ValueError when ``value`` names a robot file that is not there, suggesting the built-in names (a path
    such as assets/robots/paper-5c.yml works only from the repository's root; the name paper-5c anywhere)."""
    from magsoft_env.cases.robots import ROBOT_SUFFIXES, list_robots

    path = Path(value)
    if path.suffix.lower() not in ROBOT_SUFFIXES or path.is_file():
        return
    names = list_robots()
    example = f"{flag} {path.stem} is the built-in robot of that name" if path.stem in names else \
        f"e.g. {flag} {names[-1] if names else 'paper-5c'}"
    raise ValueError(f"{flag}: robot file {value!r} does not exist (relative to {Path.cwd()}). Built-in robots go "
                     f"by name, from any folder: {', '.join(names)} (ms.list_robots()); {example}.")


def run(args) -> int:
    from magsoft_env.sim.export import EXPORT_SCENES, export_mjcf

    # every check before any work
    if args.scene not in EXPORT_SCENES:
        raise ValueError(f"--scene must be one of {list(EXPORT_SCENES)}, got {args.scene!r}.")
    if args.segments is not None and not 2 <= args.segments <= 1000:
        raise ValueError(f"--segments must be an integer in [2, 1000], got {args.segments}.")
    if args.timestep_ms is not None and not (math.isfinite(args.timestep_ms) and 0 < args.timestep_ms <= 10):
        raise ValueError(f"--timestep-ms must lie in (0, 10] ms, got {args.timestep_ms}.")
    if args.feature_x_mm is not None and not (math.isfinite(args.feature_x_mm) and abs(args.feature_x_mm) <= 1000):
        raise ValueError(f"--feature-x-mm must be a finite x in [-1000, 1000] mm, got {args.feature_x_mm}.")
    if args.feature_x_mm is not None and args.scene == "floor":
        raise ValueError("--feature-x-mm applies to --scene channel or obstacle, not floor.")
    robot_file_exists(args.robot)
    out = out_file(args.out, suffixes=(".xml",))
    from magsoft_env.cases.robots import resolve_robot

    robot = resolve_robot(args.robot, name="--robot")
    info = export_mjcf(robot, out, scene=args.scene, segments=args.segments,
                       timestep=None if args.timestep_ms is None else args.timestep_ms * 1e-3,
                       feature_x=None if args.feature_x_mm is None else args.feature_x_mm * 1e-3)
    if args.json:
        print(dumps_json(info))
        return 0
    p = info["poles"]
    print(f"wrote {info['path']}: {robot.name} in the {info['scene']} scene, {info['segments']} segments, "
          f"timestep {info['timestep_s'] * 1e3:g} ms, {info['nq']} qpos, {info['nu']} actuators")
    print(f"field convention: before every mj_step set data.ctrl[:{p}] = B_x(t) and data.ctrl[{p}:{2 * p}] = B_z(t), "
          "in tesla, with t = data.time (docs/sim.md, 'Export to MJCF')")
    return 0

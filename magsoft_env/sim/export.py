"""Export a robot's MuJoCo model in a scene as MJCF, for one's own MuJoCo scripts (docs/sim.md, "Export to MJCF").

The exported model is the rod the package simulates (:func:`~magsoft_env.sim.gait.gait_rod_options`: the
robot's segments, timestep, friction, damping and contact), with the magnetic couples as MuJoCo actuators
that plain MuJoCo applies itself. The field convention, also written into the file as a comment:

- the model has ``2 P`` actuators for its ``P`` magnetic poles: actuators ``0 .. P-1`` (named ``Bx_pole<k>``)
  take ``B_x``, actuators ``P .. 2P-1`` (``Bz_pole<k>``) take ``B_z``, in tesla;
- every step, before ``mj_step``, write the field at the step's start time ``t = data.time`` into every one:
  ``data.ctrl[:P] = B_x(t)``, ``data.ctrl[P:] = B_z(t)``; nothing else needs to be set;
- the field is uniform, in the world x-z plane (x along the beam at rest, z up); pole ``k`` feels the
  world-fixed force ``charge_k * (B_x, 0, B_z)`` (N), and the poles together exert exactly the couples
  ``(R m) x B`` of the beam's magnetization on its pieces (:func:`~magsoft_env.sim.magnetics.magnetic_poles`).

Examples
--------
>>> from magsoft_env.sim.export import export_mjcf
>>> info = export_mjcf("paper-5c", "m.xml")                        # doctest: +SKIP
>>> import mujoco
>>> m = mujoco.MjModel.from_xml_path("m.xml"); d = mujoco.MjData(m)  # doctest: +SKIP
>>> P = m.nu // 2                                                    # doctest: +SKIP
>>> d.ctrl[:P], d.ctrl[P:] = 2e-3, 0.0; mujoco.mj_step(m, d)       # B = (2, 0) mT  # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import mujoco

from ..cases.robots import resolve_robot
from .model import SCENES, RodOptions, build_spec, rod_poles

#: Scenes a robot can be exported in: the contact scenes (the cantilever clamps a beam, it does not crawl).
EXPORT_SCENES = tuple(s for s in SCENES if s != "cantilever")
#: Name of the world-fixed site whose axes the pole actuators push along (the world's axes).
FIELD_SITE = "field_axes"


def field_convention(npoles: int) -> str:
    """The field convention of an exported model with ``npoles`` poles, as the text written into the file."""
    p = int(npoles)
    return (
        f"magsoft_env export: field convention. {2 * p} actuators for {p} magnetic poles. "
        f"ctrl[0:{p}] (actuators Bx_pole0..Bx_pole{p - 1}) = B_x and ctrl[{p}:{2 * p}] (Bz_pole0..Bz_pole{p - 1}) "
        "= B_z, in tesla: the uniform applied field in the world x-z plane (x along the beam at rest, z up). "
        "Before every mj_step write the field at the step's start time t = data.time into all of them "
        "(data.ctrl[:P] = Bx(t); data.ctrl[P:] = Bz(t)); nothing else needs to be set. Pole k feels the "
        "world-fixed force gainprm_k * (B_x, 0, B_z) newtons (gainprm = its charge, A m); the poles together "
        "exert the couples (R m) x B of the beam's magnetization. Units: SI (m, kg, s, T)."
    )


#: (XML tag, attribute) -> the compiled model's array that holds its value, indexed by the element's id.
_FIELDS = {
    ("body", "pos"): "body_pos", ("body", "quat"): "body_quat",
    ("inertial", "pos"): "body_ipos", ("inertial", "quat"): "body_iquat", ("inertial", "mass"): "body_mass",
    ("inertial", "diaginertia"): "body_inertia",
    ("joint", "pos"): "jnt_pos", ("joint", "axis"): "jnt_axis", ("joint", "stiffness"): "jnt_stiffness",
    ("joint", "damping"): "dof_damping",
    ("geom", "size"): "geom_size", ("geom", "pos"): "geom_pos", ("geom", "quat"): "geom_quat",
    ("geom", "friction"): "geom_friction", ("geom", "solref"): "geom_solref", ("geom", "solimp"): "geom_solimp",
    ("site", "pos"): "site_pos", ("site", "quat"): "site_quat",
    ("general", "gainprm"): "actuator_gainprm", ("general", "gear"): "actuator_gear",
    ("pair", "friction"): "pair_friction", ("pair", "solref"): "pair_solref", ("pair", "solimp"): "pair_solimp",
    ("option", "timestep"): None,
}
_OBJECTS = {"body": mujoco.mjtObj.mjOBJ_BODY, "joint": mujoco.mjtObj.mjOBJ_JOINT, "geom": mujoco.mjtObj.mjOBJ_GEOM,
            "site": mujoco.mjtObj.mjOBJ_SITE, "general": mujoco.mjtObj.mjOBJ_ACTUATOR}


def _full_precision_xml(xml: str, model: mujoco.MjModel, comment: str) -> str:
    """``MjSpec.to_xml``'s text with every number of :data:`_FIELDS` rewritten at full precision (the writer
    keeps 6 significant digits, and the crawl on a contact-rich floor amplifies such a 1e-6 change of the
    model to about 0.5 % of its displacement in 2 s), and ``comment`` as the root's first child."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(xml)
    parents = {child: parent for parent in root.iter() for child in parent}
    npair = 0
    for el in root.iter():
        tag = el.tag
        if tag == "pair":
            idx, npair = npair, npair + 1  # pairs are unnamed: their order is their id
        elif tag == "inertial":
            idx = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, parents[el].get("name", ""))
        elif tag in _OBJECTS and el.get("name"):
            idx = mujoco.mj_name2id(model, _OBJECTS[tag], el.get("name"))
        elif tag == "option":
            idx = 0
        else:
            continue
        for attr, value in list(el.attrib.items()):
            key = (tag, attr)
            if key not in _FIELDS or idx < 0:
                continue
            if _FIELDS[key] is None:
                full = [float(model.opt.timestep)]
            elif key == ("joint", "damping"):
                full = [float(model.dof_damping[model.jnt_dofadr[idx]])]
            else:
                full = [float(v) for v in getattr(model, _FIELDS[key])[idx].ravel()]
            n = len(value.split())  # the writer leaves out trailing defaults
            el.set(attr, " ".join(repr(v) for v in full[:n]))
    root.insert(0, ET.Comment(" " + comment.replace("--", "- -") + " "))
    ET.indent(root, space="  ")
    return ET.tostring(root, encoding="unicode") + "\n"


def export_spec(robot, *, scene: str = "floor", segments: int | None = None, timestep: float | None = None,
                feature_x: float | None = None) -> tuple[mujoco.MjSpec, int, RodOptions]:
    """The exported model as a ``mujoco.MjSpec``, its number of poles ``P`` and the rod's options (see
    :func:`export_mjcf`)."""
    from .gait import gait_rod_options

    if not isinstance(scene, str) or scene not in EXPORT_SCENES:
        raise ValueError(f"scene must be one of {list(EXPORT_SCENES)}, got {scene!r}.")
    robot = resolve_robot(robot)
    options = gait_rod_options(robot, scene=scene, segments=segments, timestep=timestep, feature_x=feature_x)
    # the package's own model without its simulator-driven inputs (a mocap frame turned along B, every
    # control |B|); poles with one actuator per field component instead
    options = dataclasses.replace(options, magnetics="python")
    spec, disc = build_spec(robot.beam, options)
    spec.modelname = f"magsoft_{robot.name}_{scene}".replace(" ", "_")
    spec.worldbody.add_site(name=FIELD_SITE, group=5)
    piece, pos, charge = rod_poles(disc, options)
    for k, (i, (x, z)) in enumerate(zip(piece, pos, strict=True)):
        spec.body(f"piece{int(i)}").add_site(name=f"pole{k}", pos=[float(x), 0.0, float(z)], group=5)
    for axis, gear in (("Bx", [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]), ("Bz", [0.0, 0.0, 1.0, 0.0, 0.0, 0.0])):
        for k, c in enumerate(charge):
            # force gain * ctrl = c B_axis along the world axis (refsite: the world-fixed field_axes site)
            a = spec.add_actuator(name=f"{axis}_pole{k}", target=f"pole{k}", trntype=mujoco.mjtTrn.mjTRN_SITE,
                                  refsite=FIELD_SITE)
            a.gear = gear
            a.gainprm[0] = float(c)
            a.group = 5
    return spec, int(charge.size), options


def export_mjcf(robot, path, *, scene: str = "floor", segments: int | None = None, timestep: float | None = None,
                feature_x: float | None = None) -> dict:
    """Write a robot's MuJoCo model in a scene as an MJCF file that plain ``mujoco.MjModel.from_xml_path`` loads.

    The model is the rod :func:`~magsoft_env.sim.gait.run_gait` simulates (its segments, timestep,
    friction, hinge damping and contact), in ``scene``, with the magnetic couples as actuators.

    **Field convention** (also a comment at the top of the file): for ``P`` poles there are ``2 P``
    actuators; ``ctrl[:P]`` (named ``Bx_pole<k>``) take ``B_x`` and ``ctrl[P:]`` (``Bz_pole<k>``) take
    ``B_z``, in tesla, the uniform field in the world x-z plane (x along the beam at rest, z up). Before
    every ``mj_step`` write the field at the step's start time ``data.time`` into all of them; nothing
    else needs to be set. That is what the package's simulator does, so a script that drives the file
    with a robot's waveform crawls as :func:`~magsoft_env.sim.gait.run_gait` reports (tested to 1 %)::

        m = mujoco.MjModel.from_xml_path("m.xml"); d = mujoco.MjData(m); P = m.nu // 2
        while d.time < T:
            bx, bz = field(d.time)
            d.ctrl[:P], d.ctrl[P:] = bx, bz
            mujoco.mj_step(m, d)

    Parameters
    ----------
    robot : Robot, str or path
        A built-in robot name, a robot file (.yml, .yaml, .json) or a :class:`~magsoft_env.cases.robots.Robot`.
    path : str or Path
        The ``.xml`` file to write (its folder is created).
    scene : {"floor", "channel", "obstacle"}
        The scene (:class:`~magsoft_env.sim.RodOptions`).
    segments, timestep : int, float or None
        Rod segments and MuJoCo timestep (s); None: the robot's own.
    feature_x : float or None
        x (m) of the channel entrance or the obstacle's left face; None: the scene's default.

    Returns
    -------
    dict
        ``path``, ``robot``, ``scene``, ``segments``, ``timestep_s``, ``poles`` (P), ``nu`` (2 P), ``nq``,
        ``convention`` (the text written into the file).

    Raises
    ------
    ValueError
        An unknown scene or robot, a path that does not end in ``.xml``, numerics out of range.
    """
    path = Path(path)
    if path.suffix.lower() != ".xml":
        raise ValueError(f"path must end in .xml (an MJCF file), got {str(path)!r}.")
    spec, npoles, options = export_spec(robot, scene=scene, segments=segments, timestep=timestep, feature_x=feature_x)
    model = spec.compile()  # check it compiles before writing anything
    text = field_convention(npoles)
    out = _full_precision_xml(spec.to_xml(), model, text)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(out)
    # the file as written loads in plain MuJoCo: checked, so that a bad export fails here, not in the user's script
    mujoco.MjModel.from_xml_path(str(path))
    return {"path": str(path), "robot": spec.modelname, "scene": scene, "segments": options.segments,
            "timestep_s": float(model.opt.timestep), "poles": npoles, "nu": int(model.nu), "nq": int(model.nq),
            "convention": text}


__all__ = ["EXPORT_SCENES", "FIELD_SITE", "export_mjcf", "export_spec", "field_convention"]

"""The paper's crawling robots (Fig. 5a-c): robot files with a drive, and the settings the gaits pin.

The robots are files, ``assets/robots/paper-5a.yml`` etc. (:mod:`magsoft_env.cases.robots`): beam, drive,
floor friction, the paper's observation. The paper gives no beam lengths, field amplitudes, frequencies
or friction for Fig. 5; the files choose them and say so (see their comments and docs/envs.md for the
reasons and the measured speeds next to the paper's). :func:`beam_5a` and :func:`beam_5b` build the
variants studied there (the number of V's, the face on the floor). Numpy only:
:func:`magsoft_env.sim.gait.run_gait` runs them in MuJoCo. Everything here is SI: m, T, s, Hz, rad.

Examples
--------
>>> from magsoft_env.cases.gaits import gait_preset
>>> preset = gait_preset("paper-5c", reverse=True)
>>> round(preset.wave.amplitude_x * 1e3, 3)        # B_x inverted (mT)
-2.0
"""

from __future__ import annotations

import math

import numpy as np

from ..spec import Beam, PiecewiseConstant, jig_from_polyline
from .robots import DEFAULT_FRICTION, DEFAULT_SEGMENTS, DEFAULT_TIMESTEP, Robot, list_robots, load_robot

#: Beam cross-section shared by the presets (m): the paper's 5 x 1.13 mm strips.
WIDTH = 5e-3
THICKNESS = 1.13e-3
#: Timestep (s) of a robot whose file states none (:data:`~magsoft_env.cases.robots.DEFAULT_TIMESTEP`, 0.2 ms). A
#: robot's own numerics are ``Robot.segments`` and ``Robot.timestep``; the paper robots' files state theirs.
GAIT_TIMESTEP = DEFAULT_TIMESTEP
#: Default sliding friction coefficient between silicone and the substrate (dimensionless).
GAIT_FRICTION = DEFAULT_FRICTION
#: Segments of a robot whose file states none.
GAIT_SEGMENTS = DEFAULT_SEGMENTS
#: Named numerics of the floor scenes, (segments, timestep in s), with the crawl error each gave against the
#: converged reference at the material contact (3 s runs, the larger of the displacement and speed errors;
#: docs/convergence.md) and the wall time per simulated second on one core of a 2-core x86 cloud VM
#: (``python -m magsoft_env.bench.crawl_convergence``):
#:
#: - ``"fast"``: 20 segments, 0.2 ms: 5a 4.3 % (a lucky point: 4-17 % at 20 segments), 5b 31 %, 5c 2.7 %; 0.3-0.4 s/s.
#: - ``"fine"``: 80 segments, 0.1 ms: 5a 1.9 %, 5b 9.6 %, 5c 2.0 %; 3-4.6 s/s.
#: - ``"converged"``: 80 segments, 0.025 ms: 5a 0.0 %, 5b 0.5 %, 5c 1.0 %; 10-15 s/s.
#:
#: Without a level (``fidelity=None``) the gaits and the floor environments use the robot's own numerics
#: (:func:`numerics`): the paper robots' files choose the cheapest level within 5 % of both acceptance checks
#: (docs/convergence.md): 5a ``fine``, 5b ``converged``, 5c ``fast``. paper-5b's crawl is decided by its contact
#: events and settles only once the step resolves the contact (<= 0.025 ms).
FIDELITY = {"fast": (20, 2e-4), "fine": (80, 1e-4), "converged": (80, 2.5e-5)}
#: Rod collision shape. Capsules, not the sim's default spheres: with spheres a mirror-symmetric
#: robot (cosine jig, pure B_z) drifts at +0.55 mm/s where symmetry demands 0 (capsules: 0.01 mm/s).
GAIT_CONTACT_GEOM = "capsule"
#: Rod options the gaits pin explicitly, so that their speeds do not move when the sim's defaults
#: change. The hinge damping is the robot's (``Robot.retardation_time``, 5 ms for the paper's silicone). The
#: contact time constant is the beam's own through-thickness time
#: (``RodOptions(contact_timeconst="material")``, :func:`magsoft_env.sim.model.material_contact_timeconst`).
GAIT_ROD_OPTIONS = dict(
    integrator="discrete", gravity=9.81, contact_dampratio=1.0, contact_refsafe=False, magnetics="native",
    base="middle", cone="elliptic", noslip_iterations=0, solver_iterations=100, solver_tolerance=1e-8,
    contact_impedance=None, grading=1.0,
)


#: The gaits are robots (:class:`~magsoft_env.cases.robots.Robot`) with a drive; the old name stays.
GaitPreset = Robot


def beam_5a(jig_angle: float = math.radians(15.0), *, face_down: bool = False, vees: int = 1) -> Beam:
    """The Fig. 5a robot: 25 x 5 x 1.13 mm, phi = 10 % left half / 20 % right half, polyline jig.

    ``vees = 1`` (the preset): the symmetric "V" jig falls ``jig_angle`` (rad) over the left half
    and rises as much over the right, so beta = +angle on the left half and -angle on the right.
    ``vees = n``: the paper's "multiple symmetric polylines" read as a zigzag of n V's ("W" for
    n = 2), 2n equal pieces alternately falling and rising by ``jig_angle``: beta = +angle, -angle,
    +angle, ... (mirror-symmetric about the middle for every n: beta(L - s) = -beta(s)).
    ``face_down`` turns the beam over (the other face on the floor, left and right kept):
    beta -> -beta. The paper gives neither the angle, the number of V's nor the face; the preset
    uses 15 deg, two V's (a "W"), face up (docs/envs.md, "5a with multiple polylines", has the study of
    n = 1-4).
    """
    n = int(vees)
    if n < 1 or n != vees:
        raise ValueError(f"vees must be a positive integer, got {vees!r}.")
    L, a = 25e-3, float(jig_angle)
    sign = -1.0 if face_down else 1.0
    piece = L / (2 * n)
    x = piece * math.cos(a) * np.arange(2 * n + 1)
    z = np.where(np.arange(2 * n + 1) % 2 == 1, -sign * piece * math.sin(a), 0.0)
    return Beam(length=L, width=WIDTH, thickness=THICKNESS, volume_fraction=PiecewiseConstant([0.1, 0.2]),
                magnetization=jig_from_polyline(x, z))


def beam_5b(*, face_down: bool = False) -> Beam:
    """The Fig. 5b robot: 25 x 5 x 1.13 mm, phi = 20 %, polyline jig of three equal pieces falling
    ever more steeply to the right (slopes -5, -10, -20 deg; beta = +5, +10, +20 deg).

    ``face_down`` turns the beam over (beta -> -beta, left and right kept). The paper gives no
    face; the preset is face up, whose left end lifts more under B_z. Face down the right end
    lifts more, as the paper describes ("the right end flips at a larger speed"), and the robot
    crawls right (docs/envs.md, "The drive waveform").
    """
    L = 25e-3
    sign = -1.0 if face_down else 1.0
    angles = np.radians(sign * np.array([-5.0, -10.0, -20.0]))
    seg = L / 3.0
    x = np.concatenate([[0.0], np.cumsum(seg * np.cos(angles))])
    z = np.concatenate([[0.0], np.cumsum(seg * np.sin(angles))])
    return Beam(length=L, width=WIDTH, thickness=THICKNESS, volume_fraction=0.2, magnetization=jig_from_polyline(x, z))


#: V's in the paper-5a preset's zigzag jig (``beam_5a(vees=...)``): 2, a "W" (docs/envs.md,
#: "5a with multiple polylines").
PAPER_5A_VEES = 2

def numerics(robot: Robot, *, fidelity: str | None = None, segments: int | None = None,
             timestep: float | None = None, scene: str = "floor") -> tuple[int, float]:
    """The ``(segments, timestep)`` a simulation of ``robot`` in ``scene`` runs at: the named level ``fidelity``
    (:data:`FIDELITY`), or the robot's own numerics for that scene (``robot.scene_numerics`` where it names the
    scene, else ``robot.segments`` and ``robot.timestep``) with ``segments`` and ``timestep`` (s) replacing them
    where given. The gaits, the videos and the floor environments all resolve here.

    Raises
    ------
    ValueError
        For an unknown level, or a level given together with ``segments`` or ``timestep``.

    >>> from magsoft_env.cases.gaits import gait_preset, numerics
    >>> numerics(gait_preset("paper-5b")), numerics(gait_preset("paper-5b"), fidelity="fast")
    ((80, 2.5e-05), (20, 0.0002))
    """
    if fidelity is not None:
        if not isinstance(fidelity, str) or fidelity not in FIDELITY:
            raise ValueError(f"fidelity must be one of {list(FIDELITY)} or None (the robot's own numerics), "
                             f"got {fidelity!r}.")
        if segments is not None or timestep is not None:
            raise ValueError(f"give fidelity or segments/timestep, not both: got fidelity={fidelity!r}, "
                             f"segments={segments!r}, timestep={timestep!r}.")
        return FIDELITY[fidelity]
    own = next(((n, dt) for sc, n, dt in robot.scene_numerics if sc == scene), (robot.segments, robot.timestep))
    return (own[0] if segments is None else segments, own[1] if timestep is None else timestep)


def list_gaits() -> tuple[str, ...]:
    """Names of the built-in gaits: the built-in robots (``assets/robots/*.yml``), which all carry a drive."""
    return list_robots()


def gait_preset(name, *, reverse: bool = False) -> Robot:
    """The built-in gait ``name`` (see :func:`list_gaits`), a robot file's path, or a :class:`Robot` with a drive;
    ``reverse`` inverts B_x.

    Raises
    ------
    ValueError
        For an unknown name (the message suggests the closest one), an invalid file, or a robot without a drive.
    """
    robot = load_robot(name)
    robot.wave  # noqa: B018  (raises for a robot without a drive)
    return robot.reversed() if reverse else robot


__all__ = ["FIDELITY", "GAIT_CONTACT_GEOM", "GAIT_FRICTION", "GAIT_ROD_OPTIONS", "GAIT_SEGMENTS", "GAIT_TIMESTEP",
           "PAPER_5A_VEES", "THICKNESS", "WIDTH", "GaitPreset", "beam_5a", "beam_5b", "gait_preset", "list_gaits",
           "numerics"]

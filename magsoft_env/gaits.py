"""The paper's crawling gaits (Fig. 5a-c) as open-loop baselines: robot, field waveform, floor.

The paper gives no beam lengths, field amplitudes, frequencies or friction for Fig. 5; the
presets below choose them and say so (see docs/envs.md for the reasons and the measured
speeds next to the paper's). Everything here is SI: m, T, s, Hz, rad.

Examples
--------
>>> from magsoft_env.gaits import gait_preset, run_gait
>>> preset = gait_preset("paper-5c", reverse=True)
>>> result = run_gait(preset, seconds=2.0)          # doctest: +SKIP
>>> result.speed * 1e3                              # mm/s, signed along +x  # doctest: +SKIP
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ._signals import switched_square
from .spec import Beam, PiecewiseConstant, jig_from_function, jig_from_polyline
from .spec._validate import nonnegative, positive

MM = 1e-3
MT = 1e-3

#: Beam cross-section shared by the presets (m): the paper's 5 x 1.13 mm strips.
WIDTH = 5e-3
THICKNESS = 1.13e-3
#: Default gait timestep (s): the floor contact needs <= 0.1 ms to converge (docs/sim.md).
GAIT_TIMESTEP = 1e-4
#: Default sliding friction coefficient between silicone and the substrate (dimensionless).
GAIT_FRICTION = 0.5
#: Default number of rod segments.
GAIT_SEGMENTS = 20
#: Rod collision shape. Capsules, not the sim's default spheres: with spheres a mirror-symmetric
#: robot (cosine jig, pure B_z) drifts at +0.55 mm/s where symmetry demands 0 (capsules: 0.01 mm/s).
GAIT_CONTACT_GEOM = "capsule"
#: Drive shapes of :class:`Waveparams`.
WAVE_SHAPES = ("sine", "square")
#: Rod options the gaits pin explicitly, so that their speeds do not move when the sim's defaults
#: change (the values are the sim's defaults at the time the docs/envs.md table was measured).
#: The contact time constant is the beam's own through-thickness time, see :func:`contact_timeconst`.
GAIT_ROD_OPTIONS = dict(
    integrator="discrete", gravity=9.81, retardation_time=5e-3, contact_dampratio=1.0, contact_refsafe=False,
    base="middle", cone="elliptic", noslip_iterations=0, solver_iterations=100, solver_tolerance=1e-8,
    contact_impedance=None, grading=1.0,
)


def contact_timeconst(beam: Beam) -> float:
    """Contact ``solref`` time constant of the gaits (s): ``h sqrt(rho / E)``, smallest along the beam.

    The time a compression wave takes to cross the thickness (0.14 ms for the presets): the
    contact model then does not change with the timestep.
    """
    s = np.linspace(0.0, beam.length, 401)
    rho = beam.mass_per_length(s) / beam.area
    return float(np.min(beam.thickness * np.sqrt(rho / beam.youngs_modulus(s))))


@dataclass(frozen=True)
class Waveparams:
    """A periodic field, sinusoidal or switched.

    ``shape="sine"`` (the presets): ``B_x = amplitude_x sin(2 pi f t + phase)``,
    ``B_z = amplitude_z sin(2 pi f t)``.
    ``shape="square"``: each axis switched between its +- amplitude at the zero crossings of the
    same sines, through a coil with time constant ``coil_time`` (s; 0 = an ideal square; see
    :class:`magsoft_env.sim.SwitchedSquare`). The paper does not say which waveform drove its
    crawlers; docs/envs.md ("The drive waveform") measures what the choice changes.

    Attributes
    ----------
    amplitude_x, amplitude_z : float
        Amplitudes (T); signed.
    frequency : float
        Frequency f (Hz).
    phase : float
        Phase of B_x ahead of B_z (rad).
    shape : str
        ``"sine"`` or ``"square"``.
    coil_time : float
        First-order coil time constant (s) of the square drive; must be 0 for ``"sine"``.
    """

    amplitude_x: float
    amplitude_z: float
    frequency: float
    phase: float = 0.0
    shape: str = "sine"
    coil_time: float = 0.0

    def __post_init__(self):
        if self.shape not in WAVE_SHAPES:
            raise ValueError(f"Waveparams.shape must be one of {list(WAVE_SHAPES)}, got {self.shape!r}.")
        object.__setattr__(self, "coil_time", nonnegative("Waveparams.coil_time", self.coil_time, unit="s"))
        if self.shape == "sine" and self.coil_time != 0.0:
            raise ValueError(
                f"Waveparams.coil_time applies to shape='square' only (a coil only delays a sine), got "
                f"{self.coil_time!r} s with shape='sine'."
            )

    def waveform(self):
        """The simulator waveform (imports mujoco via ``magsoft_env.sim``): a
        :class:`~magsoft_env.sim.PhaseShifted` sine or a :class:`~magsoft_env.sim.SwitchedSquare`."""
        from .sim.waveforms import PhaseShifted, SwitchedSquare

        if self.shape == "square":
            return SwitchedSquare(self.amplitude_x, self.amplitude_z, self.frequency, self.phase, 0.0, self.coil_time)
        return PhaseShifted(self.amplitude_x, self.amplitude_z, self.frequency, self.phase, 0.0)

    def sample(self, t) -> np.ndarray:
        """Field (T) at times ``t`` (s), shape ``(n, 2)``: B_x, B_z."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.shape == "square":
            return np.stack([switched_square(t, self.amplitude_x, self.frequency, self.phase, self.coil_time),
                             switched_square(t, self.amplitude_z, self.frequency, 0.0, self.coil_time)], axis=1)
        w = 2.0 * np.pi * self.frequency * t
        return np.stack([self.amplitude_x * np.sin(w + self.phase), self.amplitude_z * np.sin(w)], axis=1)

    def describe(self) -> str:
        """One line in mT, Hz and deg, e.g. ``"sine B_z 2 mT, 2 Hz"``."""
        parts = []
        if self.amplitude_x:
            ph = f" {math.degrees(self.phase):+.0f} deg" if self.phase and self.amplitude_z else ""
            parts.append(f"B_x {self.amplitude_x / MT:+g}{ph}")
        if self.amplitude_z:
            parts.append(f"B_z {self.amplitude_z / MT:g}")
        coil = f" (coil {self.coil_time * 1e3:g} ms)" if self.coil_time else ""
        return f"{self.shape}{coil} " + ", ".join(parts) + f" mT, {self.frequency:g} Hz"

    @property
    def peak(self) -> tuple[float, float]:
        """Peak |B_x|, |B_z| (T)."""
        return (abs(self.amplitude_x), abs(self.amplitude_z))


@dataclass(frozen=True)
class GaitPreset:
    """One open-loop crawling gait: robot, field, floor, and the paper's observation.

    Attributes
    ----------
    name : str
    description : str
        What the paper says and what was chosen here.
    beam : Beam
    wave : Waveparams
        The applied field (T, Hz, rad).
    friction : float
        Sliding friction coefficient rod-floor.
    paper_speed : float or None
        Speed the paper reports (m/s, signed along +x; None where the paper gives none).
    paper_direction : str
        ``"left"``, ``"right"`` or ``"reversible"``.
    reverse : bool
        Whether B_x was inverted (``--reverse``).
    segments : int
        Rod segments :func:`run_gait` uses by default (40 for paper-5b, whose speed is not
        converged at 20; see docs/envs.md).
    """

    name: str
    description: str
    beam: Beam
    wave: Waveparams
    friction: float = GAIT_FRICTION
    paper_speed: float | None = None
    paper_direction: str = ""
    reverse: bool = False
    segments: int = GAIT_SEGMENTS

    def rod_options(self, *, scene: str = "floor", segments: int | None = None, timestep: float = GAIT_TIMESTEP,
                    render: bool = False, feature_x: float | None = None):
        """The :class:`magsoft_env.sim.RodOptions` for this gait (imports mujoco); ``segments``
        ``None``: the preset's own."""
        from .sim import RodOptions

        segments = self.segments if segments is None else segments
        return RodOptions(scene=scene, segments=segments, timestep=timestep, friction=self.friction,
                          render=render, feature_x=feature_x, contact_geom=GAIT_CONTACT_GEOM,
                          contact_timeconst=contact_timeconst(self.beam), **GAIT_ROD_OPTIONS)


@dataclass(frozen=True)
class GaitResult:
    """Outcome of :func:`run_gait`.

    Attributes
    ----------
    name : str
    seconds : float
        Simulated time (s).
    warmup : float
        Time (s) excluded from the speed (the first cycle, a start-up transient).
    displacement : float
        Centre-of-mass travel along +x over the whole run (m).
    speed : float
        Mean centre-of-mass speed along +x after the warm-up (m/s).
    direction : str
        ``"left"``, ``"right"`` or ``"none"`` (|speed| below 0.01 mm/s).
    max_height : float
        Highest centerline point over the run (m): crawling stays low, tumbling does not.
    max_link_rotation : float
        Largest |tangent angle| of any piece over the run (rad).
    max_lift_left, max_lift_right : float
        Largest lift of the left half (arc length s < L/2) and of the right half (s > L/2) over
        the run (m): the height of a centerline point above its resting height h/2. The paper's
        "displacement on the right side of the beam is larger" (Fig. 5a) reads as
        ``max_lift_right > max_lift_left``.
    wall_time : float
        Seconds of computing.
    time, com_x : ndarray
        Recorded times (s) and centre-of-mass x (m).
    success : bool
        False when the simulation became unstable (then ``message`` says why).
    message : str
    """

    name: str
    seconds: float
    warmup: float
    displacement: float
    speed: float
    direction: str
    max_height: float
    max_link_rotation: float
    wall_time: float
    time: np.ndarray = field(repr=False)
    com_x: np.ndarray = field(repr=False)
    max_lift_left: float = math.nan
    max_lift_right: float = math.nan
    success: bool = True
    message: str = "ok"

    def as_dict(self) -> dict:
        """JSON-ready summary with units in the keys (mm, mm/s, deg)."""
        return {
            "preset": self.name,
            "seconds": self.seconds,
            "warmup_s": self.warmup,
            "displacement_mm": self.displacement / MM,
            "speed_mm_s": self.speed / MM,
            "direction": self.direction,
            "max_height_mm": self.max_height / MM,
            "max_link_rotation_deg": math.degrees(self.max_link_rotation),
            "max_lift_left_mm": self.max_lift_left / MM,
            "max_lift_right_mm": self.max_lift_right / MM,
            "wall_time_s": self.wall_time,
            "success": self.success,
            "message": self.message,
        }


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


def _beam_5c() -> Beam:
    # cosine jig z = 3 cos(2 pi x / 20) mm over one period, x in [0, 20] mm (arc length 23.9 mm)
    jig = jig_from_function(lambda x: 3.0 * np.cos(2.0 * np.pi * x / 20.0), 0.0, 20.0, unit=MM)
    return Beam(length=jig.length, width=WIDTH, thickness=THICKNESS, volume_fraction=0.2, magnetization=jig)


#: V's in the paper-5a preset's zigzag jig (``beam_5a(vees=...)``): 2, a "W" (1, a "V", until the
#: multiple-polyline study in docs/envs.md).
PAPER_5A_VEES = 2

_PRESETS = {
    "paper-5a": dict(
        # The robot: the paper's 5a "is programmed using multiple symmetric polylines", so the jig is a
        # zigzag of V's, here two ("W", beta = +15, -15, +15, -15 deg on four equal pieces). The single
        # V (beam_5a(vees=1)) was the preset before; docs/envs.md, "5a with multiple polylines", has the
        # 40-row study of 1-4 V's: same gait (the right end curls up, then the left end less), same
        # direction (right at every amplitude, frequency 1-3 Hz, angle 10-30 deg, face), converged
        # (+0.43 to +0.58 mm/s over 20/40 segments and 0.1/0.05 ms); the W lifts less (12.0 vs 14.7 mm
        # at 2 mT) and crawls at half the V's speed. The number of V's is not given by the paper; 2-4
        # V's differ little (+0.45 / +0.46 / +0.54 mm/s, lifts 12.0 / 12.1 / 11.7 mm), so the preset
        # takes the smallest number that is "multiple".
        # Why an oscillating B_z (docs/envs.md, "Paper gaits", has the measured table):
        # - the paper's text: section IV.B introduces 5c's B_x as added "besides an oscillating B^a(z)",
        #   and sets 5a's mechanism (asymmetric phi) apart from 5c's (asymmetric field); so 5a's
        #   "oscillating magnetic field" is read as vertical;
        # - the paper's description, "the displacement on the right side of the beam is larger": under
        #   B_z the right half lifts 3.6-15 mm and the left 0.3-7 mm (1.25-2.5 mT). B_x acts on the small
        #   transverse magnetization (sin 15 deg) only: at 5 mT no half of the W lifts more than 0.4 mm
        #   and the beam does not move (the V: up to 6 mT, then it tumbles at 7 mT);
        # - robustness: under B_z at 2 Hz the direction is right for every V count, amplitude, jig angle
        #   and face tried; the single V turns left at 4 Hz (a dynamic effect: 1 Hz barely moves).
        # The paper's direction (left) is therefore not reproduced; that is a result, not tuned away.
        # A switched (square) B_z turns this robot left (-0.54 mm/s at 1.5 mT) but turns paper-5b right:
        # no one drive gives both paper directions (docs/envs.md, "The drive waveform"), so the
        # preset keeps the sine of the other gaits; Waveparams(shape="square") is the option.
        beam=partial(beam_5a, vees=PAPER_5A_VEES),
        wave=Waveparams(0.0, 2.0 * MT, 2.0),
        paper_speed=-0.85 * MM, paper_direction="left",
        description=(
            "Fig. 5a: 25 x 5 x 1.13 mm beam, phi = 10 % left half / 20 % right half (composite density 1940 "
            "kg/m^3 throughout, the paper's measured value), magnetized by multiple symmetric polylines: a 'W' "
            "jig of four equal pieces falling and rising 15 deg in turn (beta = +15, -15, +15, -15 deg; the "
            "former single 'V' is beam_5a(vees=1)). Field: oscillating B_z = 2 mT sin(2 pi 2 Hz t) (vertical, "
            "as the paper's 'oscillating B^a(z)' of Fig. 5c; B_x up to 5 mT barely deforms this beam). "
            "Friction 0.5. Paper: crawls left at 0.85 mm/s; simulated: right under this sine, left under a switched "
            "field (--waveform square), which turns paper-5b right (docs/envs.md)."
        ),
    ),
    "paper-5b": dict(
        beam=beam_5b,
        wave=Waveparams(0.0, 2.0 * MT, 2.0),
        paper_speed=None, paper_direction="left", segments=40,
        description=(
            "Fig. 5b: 25 x 5 x 1.13 mm beam, phi = 20 %, polyline jig of three equal pieces falling with slopes "
            "5, 10 and 20 deg (the largest on the right; beta = +5, +10, +20 deg). Field: oscillating B_z = 2 mT "
            "sin(2 pi 2 Hz t). Friction 0.5. 40 segments (at 20 the speed is not converged in the timestep). "
            "Paper: crawls left (no speed given), climbs a 7 x 5.5 x 2 mm block."
        ),
    ),
    "paper-5c": dict(
        beam=_beam_5c,
        wave=Waveparams(2.0 * MT, 1.5 * MT, 2.0, math.pi / 2),
        paper_speed=None, paper_direction="reversible",
        description=(
            "Fig. 5c: cosine jig z = 3 cos(2 pi x / 20 mm) over one period (beam 23.9 x 5 x 1.13 mm, phi = 20 "
            "%). Field: B_z = 1.5 mT sin(2 pi 2 Hz t) with B_x = 2 mT sin(2 pi 2 Hz t + 90 deg); --reverse "
            "inverts B_x. Friction 0.5. Paper: dual-direction crawling at 3 mm/s, reversed by inverting B_x "
            "(the sign of the non-reversed B_x is a convention: the paper gives no phase)."
        ),
    ),
}


def list_gaits() -> tuple[str, ...]:
    """Names of the built-in gaits."""
    return tuple(_PRESETS)


def gait_preset(name: str, *, reverse: bool = False) -> GaitPreset:
    """The built-in gait ``name`` (see :func:`list_gaits`); ``reverse`` inverts B_x.

    Raises
    ------
    ValueError
        For an unknown name (the message suggests the closest one).
    """
    if name not in _PRESETS:
        hint = difflib.get_close_matches(str(name), list(_PRESETS), n=1)
        extra = f" Did you mean {hint[0]!r}?" if hint else ""
        raise ValueError(f"gait preset must be one of {list(_PRESETS)}, got {name!r}.{extra}")
    d = _PRESETS[name]
    wave = d["wave"]
    if reverse:
        wave = replace(wave, amplitude_x=-wave.amplitude_x)
    speed = d["paper_speed"]
    return GaitPreset(name=name, description=d["description"], beam=d["beam"](), wave=wave,
                      paper_speed=speed, paper_direction=d["paper_direction"], reverse=bool(reverse),
                      segments=d.get("segments", GAIT_SEGMENTS))


def com_x(sim) -> float:
    """Centre-of-mass x (m) of the rod in a :class:`magsoft_env.sim.Simulator`."""
    sim.centerline()  # brings positions up to date with the current state
    m = sim.rod.disc.mass
    return float(m @ sim.data.xipos[sim.rod.body_ids, 0] / m.sum())


def direction_of(speed: float, *, threshold: float = 1e-5) -> str:
    """``"left"``, ``"right"`` or ``"none"`` for a speed (m/s) along +x; ``threshold`` in m/s."""
    if speed > threshold:
        return "right"
    if speed < -threshold:
        return "left"
    return "none"


def run_gait(
    preset: GaitPreset, seconds: float = 4.0, *, segments: int | None = None, timestep: float = GAIT_TIMESTEP,
    warmup_cycles: float = 1.0, sample_dt: float = 0.01,
) -> GaitResult:
    """Run a gait on the floor and measure the centre-of-mass speed.

    Parameters
    ----------
    preset : GaitPreset
    seconds : float
        Simulated time (s), > 0.
    segments : int or None
        Rod segments; ``None``: the preset's own (``preset.segments``).
    timestep : float
        Simulation step (s); 0.1 ms converges the floor contact (docs/sim.md).
    warmup_cycles : float
        Field periods excluded from the speed (start-up transient); the displacement covers
        the whole run.
    sample_dt : float
        Recording interval (s).

    Returns
    -------
    GaitResult
        ``success`` False (and the partial record) when the rod became unstable.
    """
    import time as _time

    from .sim import SimulationError, Simulator

    if not isinstance(preset, GaitPreset):
        raise ValueError(f"preset must be a GaitPreset (see gait_preset), got {type(preset).__name__}.")
    seconds = positive("seconds", seconds, unit="s")
    warmup_cycles = nonnegative("warmup_cycles", warmup_cycles)
    sample_dt = positive("sample_dt", sample_dt, unit="s")
    t0 = _time.perf_counter()
    sim = Simulator(preset.beam, preset.rod_options(segments=segments, timestep=timestep))
    sim.set_waveform(preset.wave.waveform())
    every = max(1, int(round(sample_dt / sim.timestep)))
    nsteps = int(round(seconds / sim.timestep))
    s_pts = sim.arc_length()
    left, right = s_pts < 0.5 * preset.beam.length, s_pts > 0.5 * preset.beam.length
    z_rest = 0.5 * preset.beam.thickness
    ts, xs = [0.0], [com_x(sim)]
    z = sim.centerline()[1]
    zmax, rot = float(np.max(z)), float(np.max(np.abs(sim.angles())))
    lift_l, lift_r = float(np.max(z[left])) - z_rest, float(np.max(z[right])) - z_rest
    ok, msg, done = True, "ok", 0
    while done < nsteps:
        k = min(every, nsteps - done)
        try:
            sim.step(k)
        except SimulationError as err:
            ok, msg = False, str(err)
            break
        done += k
        ts.append(sim.time)
        xs.append(com_x(sim))
        z = sim.centerline()[1]
        zmax = max(zmax, float(np.max(z)))
        lift_l, lift_r = max(lift_l, float(np.max(z[left])) - z_rest), max(lift_r, float(np.max(z[right])) - z_rest)
        rot = max(rot, float(np.max(np.abs(sim.angles()))))
    t, x = np.asarray(ts), np.asarray(xs)
    warm = min(warmup_cycles / preset.wave.frequency, 0.5 * t[-1])
    i0 = int(np.searchsorted(t, warm))
    speed = (x[-1] - x[i0]) / (t[-1] - t[i0]) if t[-1] > t[i0] else 0.0
    return GaitResult(
        name=preset.name + (" (reverse)" if preset.reverse else ""), seconds=float(t[-1]), warmup=float(t[i0]),
        displacement=float(x[-1] - x[0]), speed=float(speed), direction=direction_of(speed),
        max_height=zmax, max_link_rotation=rot, wall_time=_time.perf_counter() - t0, time=t, com_x=x,
        success=ok, message=msg, max_lift_left=lift_l, max_lift_right=lift_r,
    )


__all__ = ["PAPER_5A_VEES", "WAVE_SHAPES", "GaitPreset", "GaitResult", "Waveparams", "beam_5a", "beam_5b", "com_x",
           "contact_timeconst", "direction_of", "gait_preset", "list_gaits", "run_gait"]

"""Run the crawling gaits (:mod:`magsoft_env.cases.gaits`) on the MuJoCo floor and measure them.

Examples
--------
>>> from magsoft_env.cases.gaits import gait_preset
>>> from magsoft_env.sim.gait import run_gait
>>> result = run_gait(gait_preset("paper-5c", reverse=True), seconds=2.0)
>>> result.direction, round(result.speed * 1e3, 1)   # mm/s, signed along +x
('right', 0.4)
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field

import numpy as np

from ..cases.gaits import GAIT_ROD_OPTIONS, gait_preset, numerics
from ..cases.robots import Robot
from ..units import MM
from ..validate import nonnegative, positive
from .backend import rod_class
from .cable import CABLE_GAIT_MIN_SEGMENTS, CABLE_GAIT_STEP_SEGMENTS, cable_gait_numerics
from .health import UnphysicalError, check_steps
from .model import RodOptions, material_contact_timeconst
from .readouts import is_flipped
from .simulator import SimulationError, Simulator
from .waveforms import as_waveform


def gait_rod_options(robot: Robot, *, scene: str = "floor", segments: int | None = None,
                     timestep: float | None = None, render: bool = False, feature_x: float | None = None,
                     friction: float | None = None, fidelity: str | None = None, rod: str = "planar",
                     **rod_options) -> RodOptions:
    """The :class:`~magsoft_env.sim.RodOptions` of a robot on the floor: its friction and damping
    (retardation time), the beam's own contact time constant, the pinned
    :data:`~magsoft_env.cases.gaits.GAIT_ROD_OPTIONS` and the rod's own keywords (the rod backend's
    ``gait_options``: the chain's capsule colliders; the strip's numerics where the robot's own do not suit it).

    ``segments``, ``timestep`` ``None``: the robot's own numerics (``Robot.segments``, ``Robot.timestep``), or
    the named level ``fidelity`` (:func:`~magsoft_env.cases.gaits.numerics`); ``friction`` ``None``: the robot's
    own. The gaits and the floor environments build their rods here, so both describe the same physics.

    ``rod``: the rod (``RodOptions.rod``): ``"planar"``, the hinge chain; ``"cable"``, the 3D flexcomp strip on the
    floor (:mod:`~magsoft_env.sim.cable`) with the same friction, cone, damping, contact time constant and solver
    settings (its contact is its edges' boxes on a box floor, width-wise; twist free); with neither ``segments``,
    ``timestep`` nor ``fidelity`` its numerics are :func:`~magsoft_env.sim.cable.cable_gait_numerics` of the
    robot's own. ``rod_options``: any other :class:`~magsoft_env.sim.RodOptions` keyword (contact and solver
    settings: ``contact_geom``, ``cone``, ``noslip_iterations``, ``solver_iterations``, ``solver_tolerance``,
    ``contact_impedance``, ...), which win over the gait's own: trade accuracy for speed knowingly.
    """
    if not isinstance(robot, Robot):
        raise ValueError(f"robot must be a magsoft_env.Robot (see load_robot), got {type(robot).__name__}.")
    cls = rod_class(rod)
    fixed = {"rod", "scene", "segments", "timestep", "friction", "render", "feature_x", "retardation_time"}
    known = set(RodOptions.__dataclass_fields__)
    for name in rod_options:
        if name in fixed or name not in known:
            raise ValueError(f"rod option {name!r} is not a RodOptions keyword a gait takes: give any of "
                             f"{sorted(known - fixed)}.")
    own = segments is None and timestep is None and fidelity is None
    segments, timestep = numerics(robot, fidelity=fidelity, segments=segments, timestep=timestep, scene=scene)
    friction = robot.friction if friction is None else friction
    keys = {**GAIT_ROD_OPTIONS, "contact_timeconst": material_contact_timeconst(robot.beam),
            **cls.gait_options(robot, scene=scene, segments=segments, timestep=timestep, own_numerics=own),
            **rod_options}
    return RodOptions(rod=rod, scene=scene, friction=friction, render=render, feature_x=feature_x,
                      retardation_time=robot.retardation_time, **keys)


@dataclass(frozen=True)
class GaitResult:
    """Outcome of :func:`run_gait` (frozen). Units are SI.

    Attributes
    ----------
    name : str
        The preset's name, with ``" (reverse)"`` for a reversed gait.
    seconds : float
        Simulated time (s) actually run (shorter than asked when the rod became unstable).
    warmup : float
        Time (s) excluded from the speed (the first cycle, a start-up transient): the speed window starts here.
    window : float
        Length (s) of the speed window: whole field periods after the warm-up (the whole rest of the run when
        it is shorter than one period; :attr:`whole_periods` is then False).
    displacement : float
        Centre-of-mass travel along +x over the whole run (m).
    speed : float
        Mean centre-of-mass speed along +x after the warm-up (m/s); NaN when the body flipped
        (``locomotion == "tumble"``: the centre of mass moved, but not by crawling).
    direction : str
        ``"left"``, ``"right"`` or ``"none"`` (|speed| below 0.01 mm/s); ``"tumble"`` when the body flipped.
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
        Wall time of the run (s).
    time, com_x : (n,) ndarray
        Recorded times (s) and centre-of-mass x (m), ``n`` samples (the first state, then one
        per ``sample_dt`` rounded to whole steps).
    success : bool
        False when the simulation became unstable or unphysical (then ``message`` says why).
    message : str
        ``"ok"``, the instability that stopped the run early, or (a stable run whose body flipped) a
        line starting ``"tumbled:"``.
    max_penetration : float
        Deepest rod contact over the run (m), every step (:attr:`Simulator.max_penetration`);
        the run stops above 1 h (docs/sim.md, "Physical checks"). The paper gaits stay below
        0.05 h (0.06 mm) at the 0.1 ms gait step.
    max_penetration_h : float
        The same in beam thicknesses h (dimensionless).
    energy_drift : float
        Largest energy the numerics created, as a fraction of the energy scale
        (:attr:`Simulator.energy_drift`, dimensionless): about 0 in a resolved run.
    unphysical : str
        ``""``, or the reason an unphysical motion (penetration, tunnelling, launch) stopped the run.
    segments, timestep : int, float
        The numerics the run used: rod segments and MuJoCo timestep (s).
    locomotion : str
        ``"crawl"``, or ``"tumble"`` when the body flipped: its orientation (the length-weighted mean
        tangent angle of the pieces, continuous in time; :func:`~magsoft_env.sim.readouts.orientation`)
        went past vertical (``|orientation| > pi / 2``) at a recorded sample.
    flipped : bool
        ``locomotion == "tumble"``.
    max_orientation : float
        Largest |orientation| of the body over the run (rad), at the recorded samples.
    final_orientation : float
        The body's orientation at the end (rad); about +-pi after one flip end over end.
    flip_time : float
        Time (s) of the first sample past vertical; NaN when the body did not flip.
    rod : str
        ``"planar"`` (the hinge chain) or ``"cable"`` (the 3D strip).
    displacement_y : float
        3D rod: centre-of-mass travel across the plane of the drive, along +y (m); 0 for the planar rod.
    final_heading : float
        3D rod: the strip's heading at the end, the angle of its end-to-end chord in the floor plane from +x
        toward +y (rad); 0 for the planar rod.
    max_roll : float
        3D rod: largest roll of any edge about its own axis over the run, the width axis's angle from the floor
        (rad, at the recorded samples): about 0 while the strip crawls on its wide face; 0 for the planar rod.
    turned : float
        3D rod: how far the strip turned on the floor (about z) over the run, counted continuously (rad, +
        from +x toward +y; two turns in place read 4 pi); 0 for the planar rod. Its orientation and
        ``max_link_rotation`` are end over end only (:class:`~magsoft_env.sim.readouts.PitchTracker`): turning on
        the floor is not a tumble.
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
    max_penetration: float = math.nan
    max_penetration_h: float = math.nan
    energy_drift: float = math.nan
    unphysical: str = ""
    window: float = math.nan
    segments: int = 0
    timestep: float = math.nan
    whole_periods: bool = True
    locomotion: str = "crawl"
    max_orientation: float = math.nan
    final_orientation: float = math.nan
    flip_time: float = math.nan
    rod: str = "planar"
    displacement_y: float = 0.0
    final_heading: float = 0.0
    max_roll: float = 0.0
    turned: float = 0.0

    @property
    def out_of_plane(self) -> bool:
        """True when the body left the x-z plane: it moved or turned sideways, or rolled."""
        return bool(self.displacement_y or self.turned or self.max_roll)

    @property
    def flipped(self) -> bool:
        """True when the body turned past vertical during the run (``locomotion == "tumble"``)."""
        return self.locomotion == "tumble"

    def to_dict(self) -> dict:
        """JSON-ready summary with units in the keys (mm, mm/s, deg)."""
        return {
            "preset": self.name,
            "seconds": self.seconds,
            "warmup_s": self.warmup,
            "speed_window_s": self.window,
            "whole_periods": self.whole_periods,
            "displacement_mm": self.displacement / MM,
            "speed_mm_s": None if math.isnan(self.speed) else self.speed / MM,
            "direction": self.direction,
            "max_height_mm": self.max_height / MM,
            "max_link_rotation_deg": math.degrees(self.max_link_rotation),
            "max_lift_left_mm": self.max_lift_left / MM,
            "max_lift_right_mm": self.max_lift_right / MM,
            "segments": self.segments,
            "timestep_ms": self.timestep * 1e3,
            "wall_time_s": self.wall_time,
            "success": self.success,
            "message": self.message,
            "max_penetration_mm": self.max_penetration / MM,
            "max_penetration_h": self.max_penetration_h,
            "energy_drift": self.energy_drift,
            "unphysical": self.unphysical,
            "locomotion": self.locomotion,
            "flipped": self.flipped,
            "max_orientation_deg": math.degrees(self.max_orientation),
            "final_orientation_deg": math.degrees(self.final_orientation),
            "flip_time_s": None if math.isnan(self.flip_time) else self.flip_time,
            "rod": self.rod,
            "displacement_y_mm": self.displacement_y / MM,
            "final_heading_deg": math.degrees(self.final_heading),
            "max_roll_deg": math.degrees(self.max_roll),
            "turned_deg": math.degrees(self.turned),
        }


def direction_of(speed: float, *, threshold: float = 1e-5) -> str:
    """``"left"``, ``"right"`` or ``"none"`` for a speed (m/s) along +x; ``threshold`` in m/s."""
    if speed > threshold:
        return "right"
    if speed < -threshold:
        return "left"
    return "none"


def run_gait(
    preset, seconds: float = 4.0, *, segments: int | None = None, timestep: float | None = None,
    warmup_cycles: float = 1.0, sample_dt: float = 0.01, fidelity: str | None = None, progress: bool = False,
    rod: str = "planar", rod_options: dict | None = None, source=None,
) -> GaitResult:
    """Run a gait on the floor and measure the centre-of-mass speed.

    The speed is measured over whole field periods after the warm-up (the centre of mass swings
    back and forth within a period, by 3.4 mm for paper-5b, so a window that cuts a period reads a
    wrong speed); a run too short for one whole period after the warm-up measures over what is left
    and says so (``whole_periods`` False).

    Parameters
    ----------
    preset : Robot, str or path
        A robot with a drive (:class:`~magsoft_env.cases.robots.Robot`), a built-in gait name or a robot file.
    seconds : float
        Simulated time (s), > 0, at most :data:`~magsoft_env.sim.health.MAX_STEPS` steps.
    segments : int or None
        Rod segments; ``None``: the robot's own (``preset.segments``).
    timestep : float or None
        Simulation step (s); ``None``: the robot's own (``preset.timestep``). The paper robots' own numerics are
        within 5 % of the converged crawl (5a 1.9 %, 5b 0.5 %, 5c 2.7 %; docs/convergence.md).
    fidelity : {"fast", "fine", "converged"} or None
        Named numerics (segments and timestep, :data:`~magsoft_env.cases.gaits.FIDELITY`, with the crawl error
        each gives against the converged reference); not with ``segments`` or ``timestep``. ``None``: the
        robot's own.
    warmup_cycles : float
        Field periods excluded from the speed (start-up transient); the displacement covers
        the whole run.
    sample_dt : float
        Recording interval (s).
    progress : bool
        Show a progress bar (tqdm, on stderr) over the simulated time: paper-5b at its own numerics takes about
        10-15 s of wall time per simulated second.
    rod : str
        The rod (``RodOptions.rod``): the planar hinge chain (``"planar"``, default) or the 3D flexcomp strip on the
        floor (``"cable"``, :func:`gait_rod_options`; it takes drives with a y component,
        ``Waveparams(amplitude_y=...)``). The strip at the robot's own numerics runs
        :func:`~magsoft_env.sim.cable.cable_gait_numerics` of them (paper-5a 80 segments at 0.075 ms, 5b 80 at
        0.025 ms, 5c 30 at 0.2 ms), where it crawls within 4 % of the chain at the same numerics. Every result
        reports the sideways travel, the heading and the roll (0 for the chain).
    rod_options : dict or None
        More :class:`~magsoft_env.sim.RodOptions` keywords for the rod (contact and solver settings, e.g.
        ``{"solver_iterations": 20, "noslip_iterations": 0}``), winning over the gait's own
        (:func:`gait_rod_options`): a slow robot can trade accuracy for speed, knowingly.
    source : field source or None
        A field source (:mod:`magsoft_env.fields`: a magnet, a coil system at its currents, a
        :class:`~magsoft_env.fields.MovingSource` evaluated at each step's time) besides the drive's uniform field
        (:meth:`~magsoft_env.sim.Simulator.set_source`): couples and gradient forces on every piece, each step from
        Python. ``Uniform(B)`` adds ``B`` to the drive, bit for bit the uniform-field path. None: the robot's own
        ``field_source`` block, if its file has one (docs/robots.md), else none.

    Returns
    -------
    GaitResult
        ``success`` False (and the partial record) when the rod became unstable. A robot whose body
        flipped (turned past vertical, end over end; :mod:`magsoft_env.sim.readouts`) gets
        ``locomotion="tumble"``, ``speed`` NaN, ``direction="tumble"`` and a ``message`` that says so: its
        displacement is that of a tumble, not a crawl.
    """
    preset = gait_preset(preset)  # a name or a path loads; a robot without a drive is refused
    seconds = positive("seconds", seconds, unit="s")
    warmup_cycles = nonnegative("warmup_cycles", warmup_cycles)
    sample_dt = positive("sample_dt", sample_dt, unit="s")
    t0 = _time.perf_counter()
    options = gait_rod_options(preset, segments=segments, timestep=timestep, fidelity=fidelity, rod=rod,
                               **(rod_options or {}))
    nsteps = int(round(check_steps(f"seconds / timestep = {seconds:g} s / {options.timestep:g} s",
                                   seconds / options.timestep, "Use fewer seconds or a larger timestep.")))
    if source is None:
        from .sources import robot_source

        source = robot_source(preset)  # the robot file's field_source block, if it has one
    sim = Simulator(preset.beam, options, source=source)
    sim.set_waveform(as_waveform(preset.wave))
    every = max(1, int(round(sample_dt / sim.timestep)))
    s_pts = sim.arc_length()
    left, right = s_pts < 0.5 * preset.beam.length, s_pts > 0.5 * preset.beam.length
    z_rest = 0.5 * preset.beam.thickness
    # the body's orientation end over end (the rod's tracker: turning on the floor is not a tumble)
    tracker = sim.orientation_tracker()
    pose = sim.pose()
    ts, xs = [0.0], [float(pose.com[0])]
    y0 = float(pose.com[1])
    roll = pose.roll
    z = pose.centreline[:, 2]
    turn = tracker.track(pose)
    heading0 = tracker.heading
    zmax, rot = float(np.max(z)), _link_rotation(pose, tracker.heading)
    max_turn, flip_time = abs(turn), math.nan
    lift_l, lift_r = float(np.max(z[left])) - z_rest, float(np.max(z[right])) - z_rest
    ok, msg, done, unphysical = True, "ok", 0, ""
    bar = None
    if progress:
        from tqdm.auto import tqdm

        fmt = "{desc}: {percentage:3.0f}% of " + f"{seconds:g} s" + " simulated [{elapsed}<{remaining}]"
        bar = tqdm(total=nsteps, desc=preset.name, unit="step", mininterval=0.5, leave=False, bar_format=fmt)
    while done < nsteps:
        k = min(every, nsteps - done)
        try:
            sim.step(k)
        except SimulationError as err:
            ok, msg = False, str(err)
            if isinstance(err, UnphysicalError):
                unphysical = err.reason
            break
        done += k
        if bar is not None:
            bar.update(k)
        pose = sim.pose()
        ts.append(sim.time)
        xs.append(float(pose.com[0]))
        z = pose.centreline[:, 2]
        roll = max(roll, pose.roll)
        zmax = max(zmax, float(np.max(z)))
        lift_l, lift_r = max(lift_l, float(np.max(z[left])) - z_rest), max(lift_r, float(np.max(z[right])) - z_rest)
        turn = tracker.track(pose)
        rot = max(rot, _link_rotation(pose, tracker.heading))
        max_turn = max(max_turn, abs(turn))
        if math.isnan(flip_time) and is_flipped(turn):
            flip_time = sim.time
    if bar is not None:
        bar.close()
    t, x = np.asarray(ts), np.asarray(xs)
    pose = sim.pose()
    i0, i1, whole = speed_window(t, preset.wave.frequency, warmup_cycles)
    speed = (x[i1] - x[i0]) / (t[i1] - t[i0]) if t[i1] > t[i0] else 0.0
    direction, locomotion = direction_of(speed), "crawl"
    if not math.isnan(flip_time):
        speed, direction, locomotion = math.nan, "tumble", "tumble"
        if ok:
            msg = (f"tumbled: the body turned past vertical (orientation {math.degrees(max_turn):.0f} deg at most, "
                   f"{math.degrees(turn):+.0f} deg at the end; first past 90 deg at t = {flip_time:.2f} s), end over "
                   "end: no crawl speed")
    return GaitResult(
        name=preset.name + (" (reverse)" if preset.reverse else ""), seconds=float(t[-1]), warmup=float(t[i0]),
        displacement=float(x[-1] - x[0]), speed=float(speed), direction=direction,
        max_height=zmax, max_link_rotation=rot, wall_time=_time.perf_counter() - t0, time=t, com_x=x,
        success=ok, message=msg, max_lift_left=lift_l, max_lift_right=lift_r,
        max_penetration=sim.max_penetration, max_penetration_h=sim.max_penetration / preset.beam.thickness,
        energy_drift=sim.energy_drift, unphysical=unphysical, window=float(t[i1] - t[i0]), whole_periods=whole,
        segments=options.segments, timestep=options.timestep, locomotion=locomotion, max_orientation=max_turn,
        final_orientation=turn, flip_time=flip_time, rod=rod, displacement_y=float(pose.com[1]) - y0,
        final_heading=pose.heading, max_roll=roll, turned=tracker.heading - heading0,
    )


def _link_rotation(pose, heading: float) -> float:
    """Largest |tangent angle| of any piece (rad) from the horizontal direction ``heading`` (the orientation
    tracker's: +x for the planar chain) toward +z, so that turning on the floor does not count."""
    return float(np.max(np.abs(pose.pitch_angles(heading))))


def speed_window(t, frequency: float, warmup_cycles: float = 1.0) -> tuple[int, int, bool]:
    """Sample indices ``(i0, i1)`` of the speed window of a record at times ``t`` (s), and whether it is whole periods.

    ``i0`` is the sample nearest to ``warmup_cycles / frequency`` (at most half the run), ``i1`` the sample
    nearest to the last whole period after it. Nearest, not the next one: accumulated step times read
    0.49999... where 0.5 s is meant. Without a whole period left, ``i1`` is the last sample (False).
    """
    t = np.asarray(t, dtype=float)
    period = 1.0 / frequency
    warm = min(warmup_cycles * period, 0.5 * t[-1])
    i0 = int(np.argmin(np.abs(t - warm)))
    periods = math.floor((t[-1] - t[i0]) / period + 1e-6)
    if periods < 1:
        return i0, len(t) - 1, False
    i1 = int(np.argmin(np.abs(t - (t[i0] + periods * period))))
    return i0, i1, True


__all__ = ["CABLE_GAIT_MIN_SEGMENTS", "CABLE_GAIT_STEP_SEGMENTS", "GaitResult", "cable_gait_numerics", "direction_of",
           "gait_rod_options", "run_gait", "speed_window"]

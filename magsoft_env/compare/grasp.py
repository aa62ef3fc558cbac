"""Grasp check in MuJoCo: two designed gripper fingers close on an object, lift it, and the heaviest object held.

The scene is planar (x-z, gravity along -z). A carrier above the object holds two mirror-image
fingers clamped at one point, the object's top centre; each finger leaves the clamp horizontally
(right finger along +x, left along -x) and, once the field is on, curls down around the object.
The built-in contours (``assets/contours``) are half-contours from an object's bottom centre, for a
finger under the object; here the gripper hangs above the object, so the object is held upside
down: the contour mirrored in z, ``(x, -z)``, is both the finger's design target and the object's
outline (:func:`hanging_target`). The finger is designed for this orientation, gravity included
(:func:`design_gripper`); the unoptimized baseline of the paper's Fig. S11 is the beam magnetized
straight from the contour (:func:`contour_aligned_beam`) under the same field.

A trial (:meth:`GraspScene.trial`): the object rests on a table, touching the finger roots; the
field is ramped from zero and held, then the carrier (a slide joint driven by a stiff position
actuator) rises by ``lift_height`` and holds. The object counts as lifted when it rose by at
least ``hold_fraction * lift_height``. :func:`max_lift_mass` brackets and bisects the object mass.

The object is a rigid planar body: the region bounded by the two mirrored contours (offset inward
by half the beam thickness, so that a finger whose centreline follows the contour touches it
along its length) and the chord joining their ends, as a chain of thin capsules. Imports mujoco
only when a scene is built.
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field

import numpy as np

from ..spec import Beam, as_field
from ..spec.field import planar_field
from ..validate import boolean, finite_number, nonnegative, positive

_SHELL_RADIUS = 0.25e-3  # capsule radius of the object's shell (m)
_SHELL_POINTS = 41  # points per half-contour of the object's shell
_CARRIER_MASS = 0.05  # kg
_CARRIER_FREQUENCY = 40.0  # Hz, natural frequency of the carrier on its position servo
_TABLE_FRICTION = 0.5


def _smoothstep(u):
    u = min(max(u, 0.0), 1.0)
    return u * u * (3.0 - 2.0 * u)


@dataclass(frozen=True)
class GraspOptions:
    """Settings of a grasp trial (SI units).

    Parameters
    ----------
    segments : int
        Hinge-chain cells per finger, >= 4.
    timestep : float
        Simulation step (s), in (0, 1e-3].
    friction : float
        Sliding friction coefficient between fingers and object, >= 0.
    ramp_time, settle_time, lift_time, hold_time : float
        Durations (s): field ramp from zero (smoothstep), hold before lifting, carrier rise
        (smoothstep), hold at the top.
    lift_height : float
        Carrier rise (m), > 0.
    hold_fraction : float
        The object is lifted if it rose by at least this fraction of ``lift_height``, in (0, 1].
    retardation_time : float
        Kelvin-Voigt retardation time (s): hinge damping = retardation_time * stiffness.
    gravity : float
        Gravitational acceleration along -z (m/s^2), > 0.
    contact_timeconst : float
        Contact solref time constant (s), > 0.
    """

    segments: int = 20
    timestep: float = 1e-4
    friction: float = 0.8
    ramp_time: float = 0.3
    settle_time: float = 0.2
    lift_time: float = 0.4
    hold_time: float = 0.3
    lift_height: float = 10e-3
    hold_fraction: float = 0.5
    retardation_time: float = 5e-3
    gravity: float = 9.81
    contact_timeconst: float = 4e-4

    def __post_init__(self):
        seg = self.segments
        if isinstance(seg, bool) or not isinstance(seg, (int, np.integer)) or not 4 <= seg <= 200:
            raise ValueError(f"GraspOptions.segments must be an integer in [4, 200], got {seg!r}.")
        dt = positive("GraspOptions.timestep", self.timestep, unit="s")
        if dt > 1e-3:
            raise ValueError(f"GraspOptions.timestep must lie in (0, 1e-3] s, got {self.timestep!r}.")
        nonnegative("GraspOptions.friction", self.friction)
        for name in ("ramp_time", "settle_time", "lift_time", "hold_time", "lift_height", "gravity",
                     "contact_timeconst"):
            positive(f"GraspOptions.{name}", getattr(self, name))
        nonnegative("GraspOptions.retardation_time", self.retardation_time, unit="s")
        f = finite_number("GraspOptions.hold_fraction", self.hold_fraction)
        if not 0.0 < f <= 1.0:
            raise ValueError(f"GraspOptions.hold_fraction must lie in (0, 1], got {self.hold_fraction!r}.")

    @property
    def duration(self) -> float:
        """Length of one trial (s)."""
        return self.ramp_time + self.settle_time + self.lift_time + self.hold_time


def hanging_target(name_or_xz) -> np.ndarray:
    """Finger target (m, ``(n, 2)``) for a gripper hanging above the object.

    A built-in name (``ball``, ``vase``, ``calabash``, ``dumbbell``) or a contour from the object's
    bottom centre (finger under the object, as in ``assets/contours``), translated to start at the
    origin and mirrored in z: the same object held upside down by a finger above it.
    """
    from ..design.targets import builtin_target, validate_target

    xz = builtin_target(name_or_xz) if isinstance(name_or_xz, str) else validate_target(name_or_xz)
    xz = xz - xz[0]
    return xz * np.array([1.0, -1.0])


def design_gripper(name_or_xz, *, width: float = 5e-3, thickness: float = 1.13e-3, volume_fraction: float = 0.2,
                   field_bounds=(1e-3, 20e-3), gravity: float = 9.81, **kwargs):
    """Design a hanging finger for an object with :func:`magsoft_env.design_profile`.

    The target is :func:`hanging_target`; the beam length is matched to it; the field is along +z
    (perpendicular to the undeformed finger) and the magnetization may wind over [-2 pi, 2 pi]
    (the finger curls down in an upward field). Extra keyword arguments go to ``design_profile``.

    Returns
    -------
    DesignResult
    """
    from ..design.optimize import design_profile
    from ..design.targets import curve_length

    target = hanging_target(name_or_xz)
    beam = Beam(length=curve_length(target), width=width, thickness=thickness, volume_fraction=volume_fraction)
    kwargs.setdefault("beta_bounds", (-2.0 * math.pi, 2.0 * math.pi))
    return design_profile(target, beam, field_bounds=field_bounds, gravity=gravity, **kwargs)


def contour_aligned_beam(target_xz, beam: Beam, *, family: str = "spline", size: int = 7) -> Beam:
    """The unoptimized gripper (paper Fig. S11): ``beam`` magnetized straight from the contour.

    A beam held along the target and magnetized by a uniform field along +z gets
    ``beta(s) = pi/2 - theta_target(s)`` (the strong-field alignment, also the optimizer's first
    start), fitted to the profile ``family``; no optimization.
    """
    from ..design.families import ProfileFamily
    from ..design.targets import prepare_target, tangent_angle

    fam = ProfileFamily(family, size)
    u, theta = tangent_angle(prepare_target(target_xz, 50))
    return beam.replace(magnetization=fam.profile(fam.fit(u, 0.5 * math.pi - theta), beam.length))


def _offset_inward(xz: np.ndarray, d: float) -> np.ndarray:
    """Offset the hanging right half-contour by ``d`` (m) toward the object's inside (right of travel)."""
    t = np.gradient(xz, axis=0)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    n = np.column_stack([t[:, 1], -t[:, 0]])
    return xz + d * n


def _polygon_properties(poly: np.ndarray) -> tuple[float, np.ndarray, float]:
    """Area (m^2), centroid (m) and polar second moment about the centroid per unit area (m^2)."""
    x, z = poly[:, 0], poly[:, 1]
    x1, z1 = np.roll(x, -1), np.roll(z, -1)
    c = x * z1 - x1 * z
    a = 0.5 * c.sum()
    cx = ((x + x1) * c).sum() / (6 * a)
    cz = ((z + z1) * c).sum() / (6 * a)
    ixx = ((z**2 + z * z1 + z1**2) * c).sum() / 12
    izz = ((x**2 + x * x1 + x1**2) * c).sum() / 12
    j = (ixx + izz) / a - (cx**2 + cz**2)
    return abs(a), np.array([cx, cz]), abs(j)


@dataclass(frozen=True)
class GraspTrial:
    """One lift attempt (frozen). Units are SI.

    Attributes
    ----------
    lifted : bool
        The object rose by at least ``hold_fraction * lift_height``.
    object_mass : float
        Mass of the object (kg).
    rise : float
        Object's rise (m) from the start to the end of the trial (NaN when not ``stable``).
    stable : bool
        False if the state became non-finite (then ``lifted`` is False).
    message : str
        ``"lifted"``, ``"not lifted"``, or where the state became non-finite.
    """

    lifted: bool
    object_mass: float
    rise: float
    stable: bool = True
    message: str = ""

    def to_dict(self) -> dict:
        """Plain numbers (SI, unit in the key), for JSON."""
        return {
            "lifted": bool(self.lifted),
            "object_mass_kg": float(self.object_mass),
            "rise_m": float(self.rise),
            "stable": bool(self.stable),
            "message": self.message,
        }


@dataclass(frozen=True)
class LiftResult:
    """Heaviest object lifted, from :func:`max_lift_mass` (frozen). Units are SI.

    Attributes
    ----------
    max_mass : float
        Heaviest mass lifted (kg); 0 if even ``min_ratio`` times the gripper mass fell.
    ratio : float
        ``max_mass / gripper_mass`` (dimensionless).
    upper_ratio : float
        Lightest mass that fell, over the gripper mass (dimensionless; ``inf`` if none fell up
        to ``max_ratio``).
    gripper_mass : float
        Mass of both fingers (kg).
    trials : list of GraspTrial
        Every trial, in the order run.
    """

    max_mass: float
    ratio: float
    upper_ratio: float
    gripper_mass: float
    trials: list = field(default_factory=list)

    def to_dict(self) -> dict:
        """Plain numbers (SI, unit in the key; ratios dimensionless), with every trial, for JSON."""
        return {
            "max_mass_kg": float(self.max_mass),
            "ratio": float(self.ratio),
            "upper_ratio": float(self.upper_ratio),
            "gripper_mass_kg": float(self.gripper_mass),
            "trials": [t.to_dict() for t in self.trials],
        }


class GraspScene:
    """Two mirror fingers of ``beam`` on a carrier above the object whose outline is ``target_xz``.

    Parameters
    ----------
    beam : Beam
        One finger (length, section, material, magnetization); the left finger is its mirror image.
    field : Field or (float, float)
        Closing field (B_x, B_z) in T, applied to the right finger; the left finger, a copy of the
        right one turned by pi about z, sees the same field (a field along z keeps the mirror
        symmetry; a B_x breaks it, as it would in a real gripper).
    target_xz : (n, 2) array
        The object's outline as a hanging finger sees it (m), from the clamp point (the object's top
        centre), x >= 0 (e.g. :func:`hanging_target`).
    options : GraspOptions, optional
    """

    def __init__(self, beam: Beam, field, target_xz, options: GraspOptions | None = None):
        import mujoco

        from ..design.targets import resample, validate_target
        from ..sim.discretize import discretize
        from ..sim.magnetics import body_moments_3d

        if not isinstance(beam, Beam):
            raise ValueError(f"beam must be a magsoft_env.Beam, got {type(beam).__name__}.")
        self.options = o = GraspOptions() if options is None else options
        if not isinstance(o, GraspOptions):
            raise ValueError(f"options must be a GraspOptions, got {type(o).__name__}.")
        beam.require_planar("the grasp scene (planar MuJoCo fingers)")
        f = planar_field(as_field(field, "field"), "the grasp scene (planar MuJoCo fingers)")
        self.field = np.array([f.Bx, 0.0, f.Bz])
        tgt = validate_target(target_xz, name="target_xz")
        tgt = resample(tgt - tgt[0], _SHELL_POINTS)
        if np.any(tgt[:, 0] < -1e-9):
            raise ValueError("target_xz must stay at x >= 0 (the right half of the object, from its top centre), "
                             f"got min x = {tgt[:, 0].min():.4g} m.")
        self.beam = beam
        self.disc = disc = discretize(beam, o.segments)
        self.gripper_mass = 2.0 * float(disc.mass.sum())
        h = beam.thickness

        # object outline: half-contour offset inward by h/2 (finger surface) and the shell radius
        half = _offset_inward(tgt, 0.5 * h + _SHELL_RADIUS)
        half[0, 0] = 0.0
        left = half[::-1] * np.array([-1.0, 1.0])
        poly = np.vstack([half, left[1:-1]])
        area, centroid, j_per_area = _polygon_properties(poly)
        self._obj_j = j_per_area
        z_table = float(min(half[-1, 1], half[:, 1].min())) - _SHELL_RADIUS

        spec = mujoco.MjSpec()
        spec.modelname = "magsoft_grasp"
        spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
        spec.option.timestep = o.timestep
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.gravity = [0.0, 0.0, -o.gravity]
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_AUTORESET
        spec.option.iterations = 100
        world = spec.worldbody

        def collide(g, contype, conaffinity, friction):
            g.contype, g.conaffinity = contype, conaffinity
            g.friction = [friction, 0.005, 0.0001]
            g.solref = [o.contact_timeconst, 1.0]

        table = world.add_geom(name="table", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.2, 0.2, 1e-3],
                               pos=[0, 0, z_table])
        collide(table, 3, 3, _TABLE_FRICTION)

        # carrier: slide z on a stiff position servo
        carrier = world.add_body(name="carrier", pos=[0, 0, 0])
        carrier.explicitinertial = True
        carrier.mass = _CARRIER_MASS
        carrier.inertia = [1e-6, 1e-6, 1e-6]
        carrier.gravcomp = 1.0  # the servo then holds its set height exactly
        carrier.add_joint(name="carrier_z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
        w_n = 2 * math.pi * _CARRIER_FREQUENCY
        act = spec.add_actuator(name="lift", target="carrier_z", trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=_CARRIER_MASS * w_n**2, kv=2.0 * _CARRIER_MASS * w_n)

        names = []
        for side, quat in (("r", [1.0, 0.0, 0.0, 0.0]), ("l", [0.0, 0.0, 0.0, 1.0])):
            parent = None
            for i in range(o.segments + 1):
                nm = f"{side}{i}"
                if i == 0:
                    body = carrier.add_body(name=nm, pos=[0, 0, 0], quat=quat)
                else:
                    body = parent.add_body(name=nm, pos=[float(disc.piece_length[i - 1]), 0, 0])
                    k = float(disc.stiffness[i - 1])
                    body.add_joint(name=f"{side}hinge{i - 1}", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, -1, 0],
                                   stiffness=[k, 0, 0], damping=[o.retardation_time * k, 0, 0])
                body.explicitinertial = True
                body.mass = float(disc.mass[i])
                body.ipos = [float(disc.com[i]), 0, 0]
                body.inertia = [float(v) for v in disc.inertia[i]]
                g = body.add_geom(name=f"{nm}_capsule", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[0.5 * h, 0, 0],
                                  fromto=[0, 0, 0, float(disc.piece_length[i]), 0, 0])
                collide(g, 1, 2, o.friction)
                names.append(nm)
                parent = body

        obj = world.add_body(name="object", pos=[0, 0, 0])
        obj.explicitinertial = True
        obj.mass = 1e-3
        obj.ipos = [float(centroid[0]), 0, float(centroid[1])]
        obj.inertia = [1e-3 * j_per_area] * 3
        obj.add_joint(name="object_x", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1, 0, 0])
        obj.add_joint(name="object_z", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0, 0, 1])
        obj.add_joint(name="object_theta", type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, -1, 0],
                      pos=[float(centroid[0]), 0, float(centroid[1])])
        closed = np.vstack([poly, poly[:1]])
        for k in range(len(closed) - 1):
            a, b = closed[k], closed[k + 1]
            g = obj.add_geom(name=f"shell{k}", type=mujoco.mjtGeom.mjGEOM_CAPSULE, size=[_SHELL_RADIUS, 0, 0],
                             fromto=[a[0], 0, a[1], b[0], 0, b[1]])
            collide(g, 2, 1, o.friction)

        self.spec = spec
        self.model = m = spec.compile()
        self.data = mujoco.MjData(m)
        self._mujoco = mujoco
        bid = lambda nm: mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, nm)  # noqa: E731
        self._finger_ids = np.array([bid(nm) for nm in names])
        self._moments = np.vstack([body_moments_3d(disc.moment)] * 2)
        self._obj_id = bid("object")
        jid = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "object_z")
        self._obj_z = int(m.jnt_qposadr[jid])
        self.object_outline = poly

    def _set_object_mass(self, mass: float) -> None:
        self.model.body_mass[self._obj_id] = mass
        self.model.body_inertia[self._obj_id] = mass * self._obj_j

    def trial(self, object_mass: float, *, field_on: bool = True, record: bool = False) -> GraspTrial:
        """Close the gripper on an object of ``object_mass`` (kg) and lift it (see the module docstring).

        ``field_on=False`` keeps the field at zero (a control: nothing should be lifted).
        ``record=True`` stores the object's height (m) at each step in ``self.last_object_z``.
        """
        from ..sim.magnetics import couples, world_moments

        mass = positive("object_mass", object_mass, unit="kg")
        mj, m, d, o = self._mujoco, self.model, self.data, self.options
        self._set_object_mass(mass)
        mj.mj_resetData(m, d)
        mj.mj_forward(m, d)
        z0 = float(d.qpos[self._obj_z])
        n = int(round(o.duration / o.timestep))
        t_lift = o.ramp_time + o.settle_time
        ids, mom = self._finger_ids, self._moments
        zs = np.empty(n) if record else None
        for k in range(n):
            t = k * o.timestep
            scale = _smoothstep(t / o.ramp_time) if field_on else 0.0
            d.ctrl[0] = o.lift_height * _smoothstep((t - t_lift) / o.lift_time)
            if scale:
                d.xfrc_applied[ids, 3:6] = couples(world_moments(d.xmat[ids], mom), scale * self.field)
            mj.mj_step(m, d)
            if record:
                zs[k] = d.qpos[self._obj_z]
            if k % 500 == 0 and not np.all(np.isfinite(d.qpos)):
                return GraspTrial(False, mass, float("nan"), stable=False, message=f"non-finite state at t = {t:.4f} s")
        if not np.all(np.isfinite(d.qpos)):
            return GraspTrial(False, mass, float("nan"), stable=False, message="non-finite state at the end")
        if record:
            self.last_object_z = zs
        rise = float(d.qpos[self._obj_z]) - z0
        lifted = rise >= o.hold_fraction * o.lift_height
        return GraspTrial(lifted, mass, rise, message="lifted" if lifted else "not lifted")


def max_lift_mass(scene: GraspScene, *, min_ratio: float = 0.05, max_ratio: float = 256.0,
                  rel_tol: float = 0.05, progress: bool = False) -> LiftResult:
    """Heaviest object (kg) the gripper of ``scene`` lifts, by bracketing and bisection.

    Masses are tried as multiples of the gripper mass: ``min_ratio`` first (if it falls, the
    answer is 0), then doubling from 1 up to ``max_ratio``, then bisection in log-mass until the
    bracket's upper/lower ratio is below ``1 + rel_tol``. Assumes lifting is monotone in mass;
    every trial is returned so that a violation can be seen. ``progress``: a line on stderr per trial
    (a few seconds each), with the mass tried, the outcome and the wall time so far.
    """
    positive("min_ratio", min_ratio)
    positive("rel_tol", rel_tol)
    progress = boolean("progress", progress)
    if not max_ratio > min_ratio:
        raise ValueError(f"max_ratio must exceed min_ratio ({min_ratio!r}), got {max_ratio!r}.")
    mg = scene.gripper_mass
    trials = []
    t0 = time.perf_counter()

    def ok(r):
        t = scene.trial(r * mg)
        trials.append(t)
        if progress:
            print(f"grasp trial {len(trials)}: {r:.3g} x the gripper mass ({r * mg * 1e3:.3g} g): {t.message} "
                  f"[{time.perf_counter() - t0:.0f} s]", file=sys.stderr, flush=True)
        return t.lifted

    if not ok(min_ratio):
        return LiftResult(0.0, 0.0, min_ratio, mg, trials)
    lo, hi = min_ratio, None
    r = max(1.0, 2 * min_ratio)
    while r <= max_ratio:
        if ok(r):
            lo, r = r, 2 * r
        else:
            hi = r
            break
    if hi is None:
        return LiftResult(lo * mg, lo, math.inf, mg, trials)
    while hi / lo > 1.0 + rel_tol:
        mid = math.sqrt(lo * hi)
        if ok(mid):
            lo = mid
        else:
            hi = mid
    return LiftResult(lo * mg, lo, hi, mg, trials)

"""The 3D rod backend: the beam as a MuJoCo 4.0 1D ``flexcomp`` strip, clamped or free on the floor.

:class:`CableRod` is the :class:`~magsoft_env.sim.backend.RodBackend` of ``RodOptions(rod="cable")``: what the
:class:`~magsoft_env.sim.Simulator`, the gaits, the statics, the environments and the renderers run for the strip.
The model and its conventions are :mod:`~magsoft_env.sim.cable_build`; the geometry read off a state (material
frames, moments, couples, twist, elastic energy) :mod:`~magsoft_env.sim.cable_frames`; free vibration
:mod:`~magsoft_env.sim.cable_vibration`. Their public names are importable from here too.

Magnetic couples. Edge ``i`` carries the moment ``m_i = int (A B_r / mu0) m_hat ds`` (material components: along
the edge, across the width, through the thickness). Its world moment is ``R_i m_i = m_a t + m_w d1 + m_t d2``
with the edge's material frame; the couple ``C = (R_i m_i) x B`` is applied exactly as the force pair
``+-(C x t) / l_i`` (``l_i`` its current length) on the edge's end / start vertex bodies (``xfrc_applied``: its
couple is the part of ``C`` across the edge) and ``C . t`` on the edge's twist hinge (``qfrc_applied``). Torques
on vertex bodies would do nothing (they are points on slide joints).

Which way they reach MuJoCo is chosen per beam (:attr:`CableRod.couples`):

- ``"native"``, an axial magnetization (along the strip; ``RodOptions.magnetics="native"``, the default): the
  couples are constant world forces at the vertices, poles, which MuJoCo applies itself
  (:func:`~magsoft_env.sim.cable_build.build_cable`'s ``poles``: three tendon motors, ``ctrl = (B_x, B_y, B_z)``).
  Blocks of steps run inside MuJoCo (:class:`~magsoft_env.sim.stepping.NativeSteps`): ``mj_step(m, d, k)`` under a
  held field, one ``mujoco.rollout`` with control rows under fields that change, as the planar chain's. Exact up to
  the edges' strain (the poles' lever is the edge's current length over its reference length).
- ``"python"``, a magnetization with a transverse part (width or thickness components, which turn with the
  material frame: the paper's programmed robots), or ``RodOptions.magnetics="python"``: every couple written from
  Python before every step (:class:`~magsoft_env.sim.stepping.PythonSteps`,
  :class:`~magsoft_env.sim.cable_frames.CoupleWriter`), the strip's only way before the poles.
- ``"mixed"``, on request (:func:`overrides`; :data:`MIXED_PATH`): a magnetization's axial part as poles, its
  transverse part from Python before every step. Measured no cheaper than ``"python"`` (the material frames are
  needed anyway), so a mixed magnetization takes ``"python"`` unless asked.

The histories every block is checked from (the deepest floor contact, the centreline of every step) are MuJoCo's
own sensors with history buffers whichever way the couples go.
"""

from __future__ import annotations

import contextlib
import math

import mujoco
import numpy as np

from ..spec import Beam, Field
from .backend import Pose
from .cable_build import (
    CABLE_INTEGRATORS,
    CABLE_ROD,
    CABLE_SCENES,
    DEFAULT_FLOOR_CONTACT,
    EDGE_SOLIMP,
    EDGE_TIMECONST_STEPS,
    FLEX_NAME,
    FLOOR_CONTACTS,
    POLE_INPUTS,
    CableLayout,
    CableModel,
    build_cable,
    cable_layout,
    check_cable_options,
    frequencies,
    pole_coefficients,
    settling_damping,
)
from .cable_frames import (
    EDGE_STRAIN_LIMIT,
    CoupleWriter,
    apply_field,
    edge_strain,
    elastic_energy,
    magnetic_energy,
    material_frames,
    tip_twist,
    vertices,
    world_moments,
)
from .cable_vibration import MODES, free_vibration
from .health import MAX_STEPS
from .histories import PointsHistory, SensorHistory
from .model import CONTACT_HISTORY, CONTACT_SENSOR, FEATURE_SENSOR, NODE_SENSOR
from .readouts import PitchTracker
from .stepping import NativeSteps, PythonSteps

#: The strip's floor numerics when a gait runs at its robot's own (no ``segments``, ``timestep`` or ``fidelity``
#: given): at least this many segments ...
CABLE_GAIT_MIN_SEGMENTS = 30
#: ... and a timestep of at most this over the segments (s; 0.2 ms at 30, 0.075 ms at 80). Measured (docs/sim.md,
#: "Measured: the paper's gaits on the strip"), 6 s in one process against the planar chain at the same numerics:
#: paper-5c at 30 segments and 0.2 ms -0.3989 against -0.3977 mm/s (+0.3 %), paper-5a at 80 and 0.075 ms +0.4673
#: against +0.4783 (-2.3 %), paper-5b at its own 80 and 0.025 ms (unchanged; -0.878 against -0.846, +3.8 %); at 20
#: segments 10-14 % slower for 5c, at 80 segments and 0.1 ms 6-8 % off. (The rule was 40 segments and 4 ms / N:
#: paper-5c at 40 and 0.1 ms, within 1.5 % too, at 3x the wall time.)
CABLE_GAIT_STEP_SEGMENTS = 6e-3

#: The ways the magnetic couples reach MuJoCo (:attr:`CableRod.couples`; module docstring).
COUPLE_PATHS = ("native", "mixed", "python")
#: A magnetization's width and thickness components below this fraction of its largest edge moment count as none
#: (the couples they would add are dropped: relative error below this).
TRANSVERSE_TOL = 1e-12
#: How the axial poles reach MuJoCo (:data:`~magsoft_env.sim.cable_build.POLE_INPUTS`): three tendon motors
#: (measured cheaper than a motor per vertex slide; docs/sim.md, "Native couples of the strip").
POLE_INPUT = "tendon"
#: The path of a magnetization with both an axial and a transverse part (paper-5a, 5b and 5c). Python: the
#: transverse part needs the material frame every step anyway, and the poles of the axial part save nothing
#: measurable beside it (docs/sim.md, "Native couples of the strip"), while they load the edges with their tension.
MIXED_PATH = "python"

_overrides: dict = {"couples": None, "poles": None, "floor_contact": None}


@contextlib.contextmanager
def overrides(couples: str | None = None, *, poles: str | None = None, floor_contact: str | None = None):
    """Within the ``with`` block every :class:`CableRod` built takes the couple path ``couples`` (one of
    :data:`COUPLE_PATHS`; None: the automatic choice, :func:`couple_path`), the pole inputs ``poles`` (one of
    :data:`~magsoft_env.sim.cable_build.POLE_INPUTS`; None: :data:`POLE_INPUT`) and the floor contact
    ``floor_contact`` (one of :data:`~magsoft_env.sim.cable_build.FLOOR_CONTACTS`; None: the default). How the
    benchmarks measure the alternatives through calls that build their own :class:`~magsoft_env.sim.RodOptions`
    (``mujoco_equilibrium``, ``run_gait``); not thread-safe. A path the beam's magnetization cannot take is a
    ValueError when the rod is built (``"native"`` needs an axial magnetization alone, ``"mixed"`` an axial part).

    >>> from magsoft_env import Beam
    >>> from magsoft_env.sim import RodOptions, Simulator
    >>> with overrides("python"):
    ...     sim = Simulator(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), RodOptions(rod="cable"))
    >>> sim.backend.couples
    'python'
    """
    for name, value, allowed in (("couples", couples, COUPLE_PATHS), ("poles", poles, POLE_INPUTS),
                                 ("floor_contact", floor_contact, FLOOR_CONTACTS)):
        if value is not None and value not in allowed:
            raise ValueError(f"{name} must be None or one of {allowed}, got {value!r}.")
    before = dict(_overrides)
    _overrides.update(couples=couples, poles=poles, floor_contact=floor_contact)
    try:
        yield
    finally:
        _overrides.update(before)


def magnetization_parts(layout: CableLayout) -> tuple[bool, bool]:
    """``(axial, transverse)``: whether the beam cut as ``layout`` has an axial magnetization, and a transverse one
    (width or thickness components above :data:`TRANSVERSE_TOL` of the largest edge moment)."""
    m = np.abs(layout.moment)
    scale = float(m.max()) if m.size else 0.0
    return scale > 0.0 and bool(np.any(m[:, 0] > 0.0)), scale > 0.0 and bool(np.any(m[:, 1:] > TRANSVERSE_TOL * scale))


def couple_path(layout: CableLayout, magnetics: str = "native") -> str:
    """How the couples of a beam cut as ``layout`` reach MuJoCo (:data:`COUPLE_PATHS`, module docstring):
    ``"native"`` for an axial magnetization, :data:`MIXED_PATH` for one with a transverse part too, ``"python"`` for
    a transverse one alone (or none) or when ``magnetics="python"`` asks for it (ValueError for another
    ``magnetics``)."""
    if magnetics not in ("native", "python"):
        raise ValueError(f"magnetics must be 'native' or 'python', got {magnetics!r}.")
    axial, transverse = magnetization_parts(layout)
    if magnetics == "python" or not axial:
        return "python"
    return MIXED_PATH if transverse else "native"


def cable_gait_numerics(segments: int, timestep: float) -> tuple[int, float]:
    """The strip's floor numerics from a robot's own ``(segments, timestep)`` (s): at least
    :data:`CABLE_GAIT_MIN_SEGMENTS` segments, a timestep of at most :data:`CABLE_GAIT_STEP_SEGMENTS` / segments.

    >>> cable_gait_numerics(20, 2e-4), cable_gait_numerics(80, 1e-4), cable_gait_numerics(80, 2.5e-5)
    ((30, 0.0002), (80, 7.5e-05), (80, 2.5e-05))
    """
    n = max(int(segments), CABLE_GAIT_MIN_SEGMENTS)
    return n, min(float(timestep), float(f"{CABLE_GAIT_STEP_SEGMENTS / n:.12g}"))  # 0.075 ms, not 7.500...01e-05


class CableRod:
    """The flexcomp strip as a :class:`~magsoft_env.sim.backend.RodBackend`: what
    :class:`~magsoft_env.sim.Simulator` steps for ``RodOptions(rod="cable")``, clamped (``scene="cantilever"``)
    or free on the floor (``scene="floor"``).

    The couples reach MuJoCo as :attr:`couples` says (module docstring, chosen from the beam's magnetization):
    natively (poles; blocks of steps inside MuJoCo, :class:`~magsoft_env.sim.stepping.NativeSteps`), or with the
    transverse part (or all of it) written from Python before every step
    (:class:`~magsoft_env.sim.stepping.PythonSteps`): then :meth:`write_field` writes the couples of the state the
    step starts from and leaves their net moment in :attr:`moment`, with which the field's work is booked. An
    external wrench with couples (:meth:`apply_external`) also runs from Python (its force pairs turn with the
    edges). The deepest floor contact and the centreline of every step are MuJoCo's sensors' history buffers (the
    planar chain's, :data:`~magsoft_env.sim.model.CONTACT_SENSOR`, :data:`~magsoft_env.sim.model.NODE_SENSOR`) on
    every path. The pieces are the edges (``N + 1``, clamp first);
    :attr:`hinge_dof` are all dofs (vertex slides and twist hinges), with :attr:`stiffness` the whole strip's
    stiffness against each: ``3 E I_w / L^2`` for a vertex (a force ``Q`` moves a cantilever's tip by at most
    ``Q L^3 / (3 E I_w)``) and ``G J / L`` for a twist hinge, so that the static residual ``max |Q| / k`` bounds how
    far the imbalance could still move the strip, as a fraction of L or an angle (rad).
    """

    #: The registry name (``RodOptions.rod``).
    name = "cable"
    #: What messages call this rod.
    label = CABLE_ROD
    #: It takes fields with three components (B_x, B_y, B_z).
    field_axes = (0, 1, 2)
    scenes = CABLE_SCENES
    #: Frames show it in perspective or from above (:class:`~magsoft_env.render.strip.StripRenderer`).
    views = ("perspective", "top")
    #: :func:`~magsoft_env.sim.mujoco_equilibrium`'s defaults: a 1 ms settling step (the edge constraint follows the
    #: step) and a residual of 1e-6 (fraction of L, or rad).
    static_timestep = 1e-3
    static_tol = 1e-6
    #: ``mujoco.rollout`` control spec of :meth:`controls` rows: the pole motors' controls.
    control_spec = int(mujoco.mjtState.mjSTATE_CTRL)

    # ------------------------------------------------------------------ what it takes (before building)
    @classmethod
    def check_options(cls, options) -> None:
        """ValueError for a scene, integrator or clamp angle the strip does not build (``magnetics``: ``"native"``
        chooses the couples' path from the magnetization, ``"python"`` writes them all from Python)."""
        check_cable_options(options)

    @classmethod
    def check_beam(cls, beam: Beam, what: str | None = None) -> None:
        """The strip takes any magnetization direction: nothing to refuse."""

    @staticmethod
    def check_field(field: Field) -> None:
        """The strip takes any field (B_x, B_y, B_z)."""

    @staticmethod
    def check_fields(samples: np.ndarray, source) -> None:
        """The strip takes any per-step fields."""

    @classmethod
    def gait_options(cls, robot, *, scene: str, segments: int, timestep: float, own_numerics: bool) -> dict:
        """The strip's keywords of a robot's :class:`~magsoft_env.sim.RodOptions` on the floor: at the robot's own
        numerics, :func:`cable_gait_numerics` of them (where the strip crawls within 2.3 % of the chain)."""
        if scene not in CABLE_SCENES or scene == "cantilever":
            raise ValueError(f"the 3D rod's gaits run on the floor scenes {CABLE_SCENES[1:]}, got scene={scene!r}.")
        if own_numerics:
            segments, timestep = cable_gait_numerics(segments, timestep)
        return {"segments": segments, "timestep": timestep}

    def __init__(self, beam: Beam, options):
        self.check_options(options)
        lay = cable_layout(beam, options.segments, options.grading)
        #: how the couples reach MuJoCo: ``"native"``, ``"mixed"`` or ``"python"`` (module docstring)
        self.couples = _overrides["couples"] or couple_path(lay, options.magnetics)
        axial, transverse = magnetization_parts(lay)
        if self.couples == "native" and not (axial and not transverse) or self.couples == "mixed" and not axial:
            raise ValueError(f"the couple path {self.couples!r} needs an axial magnetization"
                             f"{' alone' if self.couples == 'native' else ''}: this beam's has "
                             f"{'an axial and a transverse part' if axial and transverse else 'no axial part'}.")
        poles = (_overrides["poles"] or POLE_INPUT) if self.couples != "python" else None
        cm = build_cable(beam, options, poles=poles, layout=lay, floor_contact=_overrides["floor_contact"])
        self.rod = cm
        self.model = cm.model
        self.beam = beam
        self.options = options
        self.has_contact = not cm.clamped
        #: the longest block: the sensors' history buffers (every step of a block is checked from them); the clamped
        #: strip keeps none
        self.block_limit = CONTACT_HISTORY if self.has_contact else MAX_STEPS
        if self.has_contact:
            sid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, CONTACT_SENSOR)
            self._contact_sensor = int(sid)
            #: index into :meth:`contact_data` (``sensordata``) of the deepest floor contact
            self.contact_adr = int(self.model.sensor_adr[sid])
        else:
            self._contact_sensor = -1
            self.contact_adr = 0
        fid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SENSOR, FEATURE_SENSOR)
        #: the scene has a feature besides the floor (the channel, the obstacle), and the index into
        #: :meth:`contact_data` of the deepest contact with anything (floor or feature)
        self.has_feature = fid >= 0
        self._feature_sensor = int(fid)
        self.feature_adr = int(self.model.sensor_adr[fid]) if fid >= 0 else 0
        self._floor_geom = int(mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_GEOM, "floor"))
        # the pole motors' controls are the field's components (tendons x, y, z; or each slide's axis)
        m = self.model
        self._ctrl_axes = np.array([int(np.argmax(np.abs(m.jnt_axis[m.actuator_trnid[a, 0]])))
                                    if m.actuator_trntype[a] == mujoco.mjtTrn.mjTRN_JOINT else a for a in range(m.nu)],
                                   dtype=int)
        self._writer = CoupleWriter(cm, axial=poles is None)
        self._native = NativeSteps(self.model, self.control_spec, self.controls) if poles is not None else None
        self._python = PythonSteps(self.model, self, records=False)
        #: net magnetic moment of the state :meth:`write_field` last wrote the couples of (A m^2)
        self.moment = np.zeros(3)
        self.npieces = len(lay.edge_length)
        self.two_stage = options.integrator != "rk4"
        free_v = cm.vertex_body > 0
        vd = cm.vertex_dof[free_v]
        td = cm.twist_dof[cm.twist_dof >= 0]
        self.hinge_dof = np.concatenate([vd.ravel(), td])
        # the whole strip's compliance: a force Q on a vertex moves the tip by up to Q L^3 / (3 E I_w), a moment
        # on a twist hinge turns it by up to Q L / (G J) (harmonic means of the cells' stiffnesses)
        L = beam.length
        ei_w = L / float(np.sum(1.0 / lay.stiffness[:, 0]))
        gj = L / float(np.sum(1.0 / lay.stiffness[:, 2]))
        self.stiffness = np.concatenate([np.full(vd.size, 3.0 * ei_w / L**2), np.full(td.size, gj / L)])
        self.weight = float(lay.vertex_mass.sum()) * float(options.gravity)
        self._field = np.zeros(3)
        self._external: np.ndarray | None = None
        #: a non-uniform field source (:meth:`set_source`) or None
        self._source = None
        #: couples written from Python this call: a transverse magnetization, or an external couple
        self._from_python = self.couples != "native"
        # the axial net moment sum_i m_a,i t_i of recorded positions (the energy balance of native blocks)
        free = cm.vertex_qpos[:, 0] >= 0
        self._ma = np.ascontiguousarray(lay.moment[:, 0])
        self._vq_free = cm.vertex_qpos[free]
        self._ref_free = cm.vertex_ref[free]
        self._pinned = cm.vertex_ref[~free]
        self._scale_terms = self._energy_terms()
        #: the values :meth:`set_material_scale` scales from (kept at its first call), and the modulus factor now
        self._material_base: dict | None = None
        self._modulus = 1.0

    # ------------------------------------------------------------------ histories
    def contact_histories(self, data):
        """Readers of the floor and scene contact sensors' history buffers (None where a scene has none)."""
        if not self.has_contact:
            return None, None
        scene = SensorHistory(self.model, self._feature_sensor, data.history) if self.has_feature else None
        return SensorHistory(self.model, self._contact_sensor, data.history), scene

    def contact_data(self, data) -> np.ndarray:
        """The array :attr:`contact_adr` indexes: MuJoCo's ``sensordata`` (the last step's deepest floor contact, m)."""
        return data.sensordata

    def centreline_history(self, data) -> PointsHistory:
        """Reader of the vertices at the start of every step of the last block (floor scenes; the ``framepos``
        sensors' history buffers), ``last(k)`` ``(N + 2, k, 3)``."""
        if not self.has_contact:
            raise ValueError("the clamped strip keeps no centreline history: a contact scene (floor) does.")
        return PointsHistory(self.model, data, NODE_SENSOR)

    def deepest_contact(self, data: mujoco.MjData) -> float:
        """The most negative ``dist`` (m) of the floor contacts in ``data`` (0 when there is none), read from
        ``mjData.contact`` in Python: what the floor contact sensor reports (tests/test_strip_native.py)."""
        n = data.ncon
        if not n:
            return 0.0
        c = data.contact
        dist = c.dist[:n]
        on = (c.geom[:n] == self._floor_geom).any(axis=1)
        return float(min(dist[on].min(), 0.0)) if on.any() else 0.0

    # ------------------------------------------------------------------ inputs and stepping
    def write_field(self, data: mujoco.MjData, field3: np.ndarray) -> None:
        """The inputs of the field ``(B_x, B_y, B_z)`` (T): the pole motors' controls, and where couples go from
        Python (:attr:`couples`, an external couple) the couples of the state in ``data`` plus the external
        wrench into ``xfrc_applied`` / ``qfrc_applied`` (before every step, and whenever the field is set)."""
        self._field[:] = field3
        if self._source is not None:
            # every couple and force from Python (the poles' motors off): the uniform field plus the source at
            # each edge's midpoint, the axial part too
            if self._native is not None:
                data.ctrl[:] = 0.0
            self._writer.write_source(data, self._field, self._source, self._external, self.moment)
            return
        if self._native is not None:
            data.ctrl[:] = self._field[self._ctrl_axes]
            self._native.written(self._field)
        if self._from_python:
            # the entries it never writes were cleared by the call's apply_external
            self._writer.write(data, self._field, self._external, self.moment, clear=False)

    def controls(self, fields: np.ndarray) -> np.ndarray:
        """Per-step inputs of the fields ``(k, 3)`` (T): rows of the pole motors' controls for ``mujoco.rollout``
        with :attr:`control_spec`, shape ``(k, nu)``."""
        return np.ascontiguousarray(fields[:, self._ctrl_axes])

    @property
    def steps(self) -> NativeSteps | PythonSteps:
        """How the next block runs: inside MuJoCo where every couple is native
        (:class:`~magsoft_env.sim.stepping.NativeSteps`), else each step with the couples of its start state written
        first (:class:`~magsoft_env.sim.stepping.PythonSteps`)."""
        return self._python if self._from_python else self._native

    def advance(self, data: mujoco.MjData, field3: np.ndarray, fields: np.ndarray | None, k: int, health) -> None:
        """``k`` steps under the held ``field3`` or per-step ``fields`` ``(k, 3)`` (T), run as :attr:`steps` says."""
        self.steps.advance(data, field3, fields, k, health)

    def apply_external(self, data: mujoco.MjData, wrench: np.ndarray | None) -> None:
        """A constant world-frame wrench per edge ``(N + 1, 6)``: the force at the edge's middle (half to each
        vertex), the couple applied as the magnetic ones are, as a force pair that turns with the edge (written
        with the couples before every step: a call with external couples runs from Python)."""
        self._external = None if wrench is None else np.array(wrench, dtype=float)
        self._from_python = (self.couples != "native" or self._source is not None
                             or (wrench is not None and bool(np.any(self._external[:, 3:]))))
        if self._from_python:
            # cleared here; the couples of each step's start state are written before it (and by write_field)
            data.xfrc_applied[:] = 0.0
            data.qfrc_applied[:] = 0.0
            return
        # native couples: constant forces only (or none); the poles are the motors'
        cm = self.rod
        fv = np.zeros((len(cm.vertex_body), 3))
        if wrench is not None:
            half = 0.5 * self._external[:, :3]
            fv[1:] += half
            fv[:-1] += half
        body = cm.vertex_body
        data.xfrc_applied[:] = 0.0
        data.xfrc_applied[body[body > 0], :3] = fv[body > 0]
        data.qfrc_applied[:] = 0.0

    def set_source(self, data: mujoco.MjData, source) -> None:
        """Apply a non-uniform field source (:class:`~magsoft_env.sim.sources.SourceField`; None: none) from now on.
        With one, every load is written from Python before every step
        (:meth:`~magsoft_env.sim.cable_frames.CoupleWriter.write_source`: each edge's couple in the uniform field
        plus the source's field at its midpoint, and the source's force ``G^T M`` there, half to each vertex), the
        poles' motors (an axial magnetization's native couples) off; without, the couples go as :attr:`couples`
        says. The caller writes the field's inputs next (:meth:`write_field`)."""
        self._source = source
        self.apply_external(data, self._external)

    def _source_state(self, data: mujoco.MjData):
        """``(M, B)``: the edges' world moments (A m^2) and the source's field (T) at their midpoints."""
        x = vertices(self.rod, data)
        M = world_moments(self.rod, data, x)
        return M, self._source(0.5 * (x[1:] + x[:-1]), float(data.time))[0]

    def source_field(self, data: mujoco.MjData) -> np.ndarray:
        """The source's field (T) at the edges' midpoints, ``(N + 1, 3)`` (zeros without a source)."""
        if self._source is None:
            return np.zeros((self.npieces, 3))
        return self._source_state(data)[1]

    def settle_damping(self, retardation: float) -> tuple[np.ndarray, np.ndarray]:
        """``(all dofs, mass-proportional damping)``: every mode decays at the first weak-bending rate
        (:func:`~magsoft_env.sim.cable_build.settling_damping`, of the modulus :meth:`set_material_scale` set;
        ``retardation`` does not apply)."""
        c = settling_damping(self.rod)[self.hinge_dof]
        return self.hinge_dof, c if self._modulus == 1.0 else c * math.sqrt(self._modulus)

    def set_material_scale(self, modulus: float, magnetization: float) -> None:
        """Scale the material from the values the strip was built with (factors checked by the
        :class:`~magsoft_env.sim.Simulator`): what :func:`~magsoft_env.sim.cable_build.build_cable` gives the beam
        with ``E0 * modulus`` and ``particle_magnetization * magnetization``.

        The modulus scales the layout's cell stiffnesses and MuJoCo's stiffness records (``flex_bending``: ``k_1``,
        ``k_2 - k_1``, ``k_t``), the static residual's :attr:`stiffness`, the settling damping (the first bending
        rate, by ``sqrt(modulus)``) and a contact time constant taken from the material
        (``contact_timeconst="material"``: ``flex_solref`` by ``1 / sqrt(modulus)``); the rod damping
        (``flex_damping``) is a retardation time times a stiffness ratio, which it leaves. The magnetization scales
        the edges' moments (the layout's, the couple writer's columns, the net moment's), and the poles of a native
        path (the tendons' coefficients ``wrap_prm``, or the slide motors' gears), after which MuJoCo's constants
        (``tendon_invweight0``, ``actuator_acc0``) are computed again (``mj_setConst``), as compiling does.

        A rebuilt strip's poles can differ from these in coefficients at round-off level (a uniform magnetization's
        interior ``c_v``, ``1e-16`` of the end ones), which the builder keeps as tendon entries where they are not
        exactly zero: the dynamics agree to round-off."""
        base = self._material_base
        m, cm, w = self.model, self.rod, self._writer
        lay = cm.layout
        f = cm.flex
        if base is None:
            adr = int(m.flex_bendingadr[f])
            n = int(m.flex_bending[adr])
            rec = slice(adr + 1, adr + 1 + 10 * n)
            base = self._material_base = {
                "rec": rec, "bending": m.flex_bending[rec].copy(), "stiffness": lay.stiffness.copy(),
                "k": self.stiffness.copy(), "moment": lay.moment.copy(), "ma": self._ma.copy(),
                "writer": {k: getattr(w, k).copy() for k in ("_m0", "_m1", "_m2", "_ma", "_r")},
                "solref": m.flex_solref[f, 0].copy() if isinstance(self.options.contact_timeconst, str)
                and self.has_contact else None,
                "wrap": m.wrap_prm.copy(), "gear": m.actuator_gear[:, 0].copy()}
        r = m.flex_bending[base["rec"]].reshape(-1, 10)
        b = base["bending"].reshape(-1, 10)
        r[:, 4] = b[:, 4] * modulus
        r[:, 5] = b[:, 5] * modulus
        r[:, 8] = b[:, 8] * modulus
        if base["solref"] is not None:
            m.flex_solref[f, 0] = base["solref"] / math.sqrt(modulus) if modulus != 1.0 else base["solref"]
        lay.stiffness[...] = base["stiffness"] * modulus
        self.stiffness[:] = base["k"] * modulus
        lay.moment[...] = base["moment"] * magnetization
        self._ma[:] = base["ma"] * magnetization
        for k, v in base["writer"].items():
            getattr(w, k)[...] = v * magnetization
        if m.nu:  # the poles: tendon coefficients or slide gears
            m.wrap_prm[:] = base["wrap"] * magnetization
            m.actuator_gear[:, 0] = base["gear"] if cm.poles == "tendon" else base["gear"] * magnetization
            mujoco.mj_setConst(m, mujoco.MjData(m))
        self._modulus = float(modulus)
        self._scale_terms = self._energy_terms()

    def settle_speed(self, data: mujoco.MjData) -> float:
        """The largest vertex speed over L and twist rate (1/s, rad/s)."""
        v = data.qvel
        cm = self.rod
        r = float(np.max(np.abs(v[cm.vertex_dof[cm.vertex_body > 0]]))) / self.beam.length
        free = cm.twist_dof >= 0
        if np.any(free):
            r = max(r, float(np.max(np.abs(v[cm.twist_dof[free]]))))
        return r

    def reset_noise(self, rng: np.random.Generator, scale: float) -> np.ndarray:
        """``qpos0`` with each interior vertex raised by ``U(-scale, scale)`` times half its cell: a bending angle of
        that order (rad) at every interior vertex."""
        cm = self.rod
        q = self.model.qpos0.copy()
        noise = rng.uniform(-scale, scale, self.options.segments)
        adr = cm.vertex_qpos[1:-1, 2]
        ok = adr >= 0
        q[adr[ok]] += (noise * 0.5 * np.diff(cm.layout.s)[1:])[ok]
        return q

    # ------------------------------------------------------------------ energies
    def net_moment(self, data: mujoco.MjData) -> np.ndarray:
        """Net magnetic moment ``sum R_i m_i`` (world x, y, z; A m^2)."""
        if self.couples == "native":
            return self.net_moments(data.qpos[None])[0]
        return world_moments(self.rod, data).sum(axis=0)

    def net_moments(self, qpos: np.ndarray) -> np.ndarray:
        """Net magnetic moments of recorded positions ``(k, nq)``, shape ``(k, 3)`` (A m^2): for an axial
        magnetization ``sum_i m_a,i t_i`` from the vertices alone, vectorized over the records; else with the
        reference frames of the present state."""
        qpos = np.atleast_2d(qpos)
        if self.couples == "native":
            k = qpos.shape[0]
            x = np.empty((k, len(self.rod.vertex_ref), 3))
            npin = len(self._pinned)
            x[:, :npin] = self._pinned
            x[:, npin:] = self._ref_free + qpos[:, self._vq_free]
            e = x[:, 1:] - x[:, :-1]
            w = self._ma / np.sqrt(np.einsum("kij,kij->ki", e, e))
            return np.einsum("ki,kij->kj", w, e)
        scratch = mujoco.MjData(self.model)
        out = np.empty((len(qpos), 3))
        for i, q in enumerate(qpos):
            scratch.qpos[:] = q
            out[i] = world_moments(self.rod, scratch).sum(axis=0)
        return out

    def energy(self, data, field, *, kinetic: float, staggered: bool) -> float:
        return self.energies(data, np.asarray(field, dtype=float), kinetic)["total"]

    def _energy_terms(self) -> tuple[float, float]:
        """``(slope, rest)`` of :meth:`energy_scale`."""
        lay = self.rod.layout
        mags = float(np.linalg.norm(lay.moment, axis=1).sum())
        return 2.0 * mags, 2.0 * self.weight * self.beam.length + 0.5 * float(lay.stiffness[:, 0].sum()) * math.pi**2

    def energy_scale(self, bmax: float) -> float:
        slope, rest = self._scale_terms
        return slope * bmax + rest

    def energies(self, data: mujoco.MjData, field3: np.ndarray, kinetic: float) -> dict[str, float]:
        """Kinetic (given), elastic (:func:`elastic_energy`), gravitational (from z = 0) and magnetic energy (J)."""
        x = vertices(self.rod, data)
        elastic = elastic_energy(self.rod, data)
        grav = float(self.rod.layout.vertex_mass @ x[:, 2]) * float(self.options.gravity)
        M = world_moments(self.rod, data, x)
        mag = -float(np.sum(M @ np.asarray(field3, dtype=float)))
        if self._source is not None:  # -sum M . B_s at the edges' midpoints
            mag -= float(np.sum(M * self._source(0.5 * (x[1:] + x[:-1]), float(data.time))[0]))
        return {"kinetic": kinetic, "elastic": elastic, "gravity": grav, "magnetic": mag,
                "total": kinetic + elastic + grav + mag}

    def integrity(self, data: mujoco.MjData):
        """``(quantity, value, hint)`` when an edge stretched beyond :data:`EDGE_STRAIN_LIMIT`, else None."""
        s = edge_strain(self.rod, data)
        if s > EDGE_STRAIN_LIMIT:
            return ("edge stretch (relative)", s, "The edge constraint lost hold of the strip: use a smaller "
                    "timestep.")
        return None

    # ------------------------------------------------------------------ readouts
    def pose(self, data: mujoco.MjData) -> Pose:
        """The :class:`~magsoft_env.sim.backend.Pose`: vertices, edges' tangents and width axes."""
        x = vertices(self.rod, data)
        t, d1, _ = material_frames(self.rod, data, x)
        m = self.rod.layout.vertex_mass
        return Pose(time=float(data.time), com=m @ x / m.sum(), centreline=x, tangents=t, widths=d1,
                    lengths=self.rod.layout.edge_length, tip_angle=float(math.atan2(t[-1, 2], t[-1, 0])))

    def orientation_tracker(self) -> PitchTracker:
        """End over end, not counting turns on the floor (:class:`~magsoft_env.sim.readouts.PitchTracker`)."""
        return PitchTracker()

    def lowest_point(self, data: mujoco.MjData, below: float) -> float:
        return float(vertices(self.rod, data)[:, 2].min())

    def centerline(self, data: mujoco.MjData) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Vertices (x, y, z) (m), shape ``(N + 2,)`` each."""
        x = vertices(self.rod, data)
        return x[:, 0], x[:, 1], x[:, 2]

    def tip_position(self, data: mujoco.MjData) -> tuple[float, float, float]:
        x = vertices(self.rod, data)[-1]
        return float(x[0]), float(x[1]), float(x[2])

    def center_of_mass(self, data: mujoco.MjData) -> np.ndarray:
        m = self.rod.layout.vertex_mass
        return m @ vertices(self.rod, data) / m.sum()

    def arc_length(self) -> np.ndarray:
        return self.rod.layout.s.copy()

    def angles(self, data: mujoco.MjData) -> np.ndarray:
        """Tangent angle of every edge from +x toward +z (rad), in the x-z projection."""
        t = material_frames(self.rod, data)[0]
        return np.arctan2(t[:, 2], t[:, 0])

    def tip_angle(self, data: mujoco.MjData) -> float:
        return float(self.angles(data)[-1])

    def tip_twist(self, data: mujoco.MjData) -> float:
        return tip_twist(self.rod, data)

    def angular_velocities(self, data: mujoco.MjData) -> np.ndarray:
        """Angular velocity of every edge's direction about -y (rad/s): ``-(t x (v_end - v_start) / l)_y``."""
        cm = self.rod
        x = vertices(cm, data)
        v = np.zeros_like(x)
        free = cm.vertex_qpos >= 0
        v[free] = data.qvel[cm.vertex_dof[free]]
        e = np.diff(x, axis=0)
        dv = np.diff(v, axis=0)
        l2 = np.einsum("ij,ij->i", e, e)
        # omega = e x de / |e|^2; its y component is e_z de_x - e_x de_z
        return -(e[:, 2] * dv[:, 0] - e[:, 0] * dv[:, 2]) / l2

    def magnetic_couples(self, data: mujoco.MjData, field3: np.ndarray) -> np.ndarray:
        """Couples ``(R m) x B`` on the edges, world frame, shape ``(N + 1, 3)`` (N m); with a source, in the field
        plus the source's at each edge's midpoint."""
        if self._source is not None:
            M, Bs = self._source_state(data)
            return np.cross(M, Bs + np.asarray(field3, dtype=float))
        return np.cross(world_moments(self.rod, data), np.asarray(field3, dtype=float))


def cable_path(beam: Beam, fields, **kwargs):
    """The clamped strip settled along a loading path: :func:`~magsoft_env.sim.mujoco_path` with ``rod="cable"``."""
    from .equilibrium import mujoco_path

    return mujoco_path(beam, fields, rod="cable", **kwargs)


def cable_equilibrium(beam: Beam, field, **kwargs):
    """Static equilibrium of the clamped strip: :func:`~magsoft_env.sim.mujoco_equilibrium` with ``rod="cable"``.

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> eq = cable_equilibrium(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), (0.0, 0.5e-3, 0.0), gravity=0.0)
    >>> bool(eq.success), round(float(eq.tip_position[1]) * 1e3, 2)
    (True, 1.17)
    """
    from .equilibrium import mujoco_equilibrium

    return mujoco_equilibrium(beam, field, rod="cable", **kwargs)


__all__ = [
    "CABLE_GAIT_MIN_SEGMENTS", "CABLE_GAIT_STEP_SEGMENTS", "CABLE_INTEGRATORS", "CABLE_ROD", "CABLE_SCENES",
    "DEFAULT_FLOOR_CONTACT", "EDGE_SOLIMP", "EDGE_STRAIN_LIMIT", "EDGE_TIMECONST_STEPS", "FLEX_NAME",
    "FLOOR_CONTACTS", "MIXED_PATH", "MODES", "COUPLE_PATHS", "POLE_INPUT", "POLE_INPUTS", "TRANSVERSE_TOL",
    "CableLayout", "CableModel", "CableRod", "CoupleWriter", "apply_field", "couple_path", "overrides",
    "magnetization_parts", "pole_coefficients",
    "build_cable", "cable_equilibrium", "cable_gait_numerics", "cable_layout", "cable_path", "edge_strain",
    "elastic_energy", "free_vibration", "frequencies", "magnetic_energy", "material_frames", "settling_damping",
    "tip_twist", "vertices", "world_moments",
]

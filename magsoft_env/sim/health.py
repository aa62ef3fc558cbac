"""Health checks of a MuJoCo rod simulation: the error types, the MuJoCo warnings that stop a run, the
runaway-energy bound, the physical bounds of the contact scenes (penetration, tunnelling, launch), the work
bound of one call, the reader of MuJoCo's sensor history buffers that lets blocks of steps run inside MuJoCo
keep the per-step penetration check, and :class:`HealthMonitor`, the one component that applies them.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from .histories import SensorHistory

#: MuJoCo warnings that stop a simulation, with what they mean.
WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQACC: "non-finite or huge qacc (acceleration)",
    mujoco.mjtWarning.mjWARN_BADQVEL: "non-finite or huge qvel (velocity)",
    mujoco.mjtWarning.mjWARN_BADQPOS: "non-finite or huge qpos (position)",
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "contact buffer full",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "constraint buffer full",
    mujoco.mjtWarning.mjWARN_INERTIA: "singular inertia or failed effective-metric solve",
}
#: Their ids, as an index array into ``mjData.warning``.
WARNING_IDS = np.array([int(w) for w in WARNINGS])
#: Kinetic energy above this multiple of the system's energy scale is runaway.
RUNAWAY_FACTOR = 100.0
#: What to change when a check fails.
STABILITY_HINT = "Use a smaller timestep or integrator='discrete'."
#: Contact scenes: a contact penetration deeper than this many beam thicknesses h is unphysical:
#: the beam has sunk its whole thickness into the floor (for the radius-h/2 colliders, the
#: centreline is h/2 below the surface). Chosen from measurements (docs/sim.md, "Physical checks"):
#: the gaits at their 0.1-0.2 ms steps reach at most 0.08 h; the soft default contact (2 ms at
#: 1 ms) reaches 0.79 h in current uses (the cosine-jig crawler at 2 mT), 1.1-1.6 h when the beam
#: tumbles at 2-3 mT, and a beam driven at 100 mT 2.1 h in its first step.
PENETRATION_LIMIT = 1.0
#: Contact scenes: energy created by the numerics (total mechanical + magnetic energy above its
#: start plus the work the field did), as a fraction of the energy scale, above which the run is a
#: launch the field cannot have powered. Resolved runs stay below 1e-6 (docs/sim.md).
ENERGY_DRIFT_LIMIT = 0.01
#: Most simulation steps one call may take (a step, a run, a settle, an environment step, a segment
#: of an equilibrium path): about 5-10 minutes of stepping. A setting that needs more is refused up
#: front with the figures, so that no input makes a call run for hours.
MAX_STEPS = 10_000_000


class SimulationError(RuntimeError):
    """The simulation became unstable; stepping stopped.

    Attributes
    ----------
    step : int
        Index of the step (since construction or reset) at which the problem was detected.
    time : float
        Simulation time (s) at detection.
    quantity : str
        What went wrong (``"qvel"``, ``"kinetic energy"``, a MuJoCo warning, ...).
    value : float
        The offending value where one exists (NaN otherwise).
    """

    def __init__(self, message: str, *, step: int, time: float, quantity: str, value: float = math.nan):
        super().__init__(message)
        self.step = step
        self.time = time
        self.quantity = quantity
        self.value = value


class UnphysicalError(SimulationError):
    """The motion broke a physical bound of a contact scene; stepping stopped.

    Attributes (besides :class:`SimulationError`'s)
    ----------
    cause : str
        ``"penetration"`` (a contact deeper than :data:`PENETRATION_LIMIT` x h), ``"tunnelling"``
        (the centreline below the floor by more than that) or ``"launch"`` (energy the field
        cannot have supplied, :data:`ENERGY_DRIFT_LIMIT`).
    reason : str
        One line: the cause and its figures (what an environment puts in ``info["unphysical"]``).
    figures : dict
        The figures, SI with the unit in the key (``"penetration_m"``, ``"penetration_h"``,
        ``"energy_drift"``, ``"step"``, ``"time_s"``, ...).
    """

    def __init__(self, message: str, *, cause: str, reason: str, figures: dict, step: int, time: float,
                 quantity: str, value: float = math.nan):
        super().__init__(message, step=step, time=time, quantity=quantity, value=value)
        self.cause = cause
        self.reason = reason
        self.figures = dict(figures)


def check_steps(what: str, steps: float, change: str):
    """``steps`` (unchanged), or a ValueError when it exceeds :data:`MAX_STEPS` (or is NaN):
    ``what`` names the work (e.g. "ctrl_dt / sim_dt"), ``change`` says what to change."""
    if not steps <= MAX_STEPS:
        raise ValueError(f"{what} = {float(steps):.3g} simulation steps, more than the limit of "
                         f"{MAX_STEPS:.0e} (MAX_STEPS). {change}")
    return steps


def new_warning(counts: np.ndarray, baseline: np.ndarray) -> str | None:
    """The description of the first stopping warning whose count grew past ``baseline``, else None.

    ``counts`` and ``baseline`` hold the counts of :data:`WARNING_IDS`, in that order (one row of
    them for one simulation)."""
    new = np.nonzero(np.asarray(counts) > np.asarray(baseline))[0]
    if not new.size:
        return None
    return WARNINGS[int(WARNING_IDS[new[0]])]


def runaway(kinetic_energy, energy_scale):
    """True where the kinetic energy (J) exceeds :data:`RUNAWAY_FACTOR` x the energy scale (J), or is NaN."""
    return ~(np.asarray(kinetic_energy) <= RUNAWAY_FACTOR * np.asarray(energy_scale))


def runaway_hint(energy_scale: float, where: str = "") -> str:
    """The message tail of a runaway-energy failure."""
    return f"It exceeds {RUNAWAY_FACTOR:g} x the energy scale {energy_scale:.3g} J{where}. {STABILITY_HINT}"


# ---------------------------------------------------------------------- the failures' texts and figures
# Written once: the health monitor of a C simulation and the MuJoCo Warp batch's per-world checks
# (sim/warp_batch.py) build their errors here, so that a failure reads the same on either.

#: What to change when the contact is not resolved (a penetration).
PENETRATION_HINT = ("The contact is not resolved: use a smaller timestep or a gentler field "
                    "(Simulator(penetration_limit=...) moves the bound)")
#: What to change when the centreline passed below the floor (tunnelling).
TUNNELLING_HINT = "The contact is not resolved: use a smaller timestep"


def setting_text(options, field, *, contact_timeconst: float | None = None) -> str:
    """The numerics a failure message quotes: ``integrator=..., timestep=... s, [contact time constant ... ms, ]
    segments=..., field=(...) mT``, from :class:`~magsoft_env.sim.model.RodOptions` ``options`` and the applied
    ``field`` (T, the components the rod takes); the contact time constant (s) only where one is given."""
    tc = "" if contact_timeconst is None else f"contact time constant {contact_timeconst * 1e3:.3g} ms, "
    return (f"integrator={options.integrator!r}, timestep={options.timestep:g} s, {tc}segments={options.segments}, "
            f"field={_mt(field)}")


def unstable_error(quantity: str, value: float, hint: str, *, step: int, time: float,
                   setting: str) -> SimulationError:
    """The :class:`SimulationError` of an unstable run: ``quantity`` (and its ``value``, NaN: none) at ``step``
    (``time`` s), what to change (``hint``) and the numerics (:func:`setting_text` without the contact)."""
    return SimulationError(
        f"simulation unstable at step {step} (t = {time:.6g} s): {quantity}"
        f"{'' if math.isnan(value) else f' = {value:.4g}'}. {hint} ({setting}).",
        step=step, time=time, quantity=quantity, value=value,
    )


def runaway_error(kinetic_energy: float, energy_scale: float, *, step: int, time: float,
                  setting: str) -> SimulationError:
    """Runaway kinetic energy (J) above :data:`RUNAWAY_FACTOR` x ``energy_scale`` (J)."""
    return unstable_error("runaway kinetic energy (J)", kinetic_energy, runaway_hint(energy_scale), step=step,
                          time=time, setting=setting)


def nonfinite_error(name: str, *, step: int, time: float, setting: str) -> SimulationError:
    """A non-finite ``name`` (``"qpos"``, ``"qvel"``)."""
    return unstable_error(f"non-finite {name}", math.nan, STABILITY_HINT, step=step, time=time, setting=setting)


def penetration_reason(depth: float, *, thickness: float, limit: float, step: int, time: float,
                       overlap: float = 0.0, into: str = "floor") -> str:
    """One line: a contact ``depth`` (m) into the ``into`` (the floor, the scene) deeper than ``limit`` (m) plus the
    start's ``overlap`` (m), at ``step`` (``time`` s), in beam thicknesses ``thickness`` (m) too."""
    h = thickness
    lim = limit + overlap
    start = f" + the {overlap * 1e3:.3g} mm overlap of the start" if overlap > 0.0 else ""
    return (f"contact penetration into the {into} {depth * 1e3:.3g} mm = {depth / h:.3g} h (limit {limit / h:.3g} "
            f"h{start} = {lim * 1e3:.3g} mm) at step {step} (t = {time:.6g} s)")


def penetration_figures(depth: float, thickness: float) -> dict:
    """The figures of a penetration (m, beam thicknesses)."""
    return {"penetration_m": depth, "penetration_h": depth / thickness}


def tunnelling_reason(lowest: float, *, thickness: float, limit: float) -> str:
    """One line: the centreline's ``lowest`` point (m, below the floor z = 0) beyond ``limit`` (m)."""
    h = thickness
    return (f"tunnelling: the centreline is {-lowest * 1e3:.3g} mm = {-lowest / h:.3g} h below the floor "
            f"(limit {limit / h:.3g} h)")


def tunnelling_figures(lowest: float, thickness: float) -> dict:
    """The figures of a tunnelling: how deep the centreline is below the floor (m, beam thicknesses)."""
    return {"floor_depth_m": -lowest, "floor_depth_h": -lowest / thickness}


def launch_reason(excess: float, drift: float, *, energy_scale: float, weight: float, length: float) -> str:
    """One line: ``excess`` energy (J) the field did not supply, ``drift`` of the ``energy_scale`` (J), and how
    far it would lift a rod of ``weight`` (N) in beam lengths ``length`` (m)."""
    lift = excess / (weight * length) if weight > 0 else math.inf
    return (f"launch: the rod gained {excess:.3g} J more than the field supplied ({drift:.3g} of the "
            f"energy scale {energy_scale:.3g} J, limit {ENERGY_DRIFT_LIMIT:g}; enough to lift it "
            f"{lift:.3g} beam lengths)")


def unphysical_error(cause: str, reason: str, hint: str, figures: dict, value: float, *, step: int, time: float,
                     setting: str, max_penetration: float, thickness: float, drift: float) -> UnphysicalError:
    """The :class:`UnphysicalError` of a broken physical bound: its ``cause`` (``"penetration"``, ``"tunnelling"``,
    ``"launch"``), one-line ``reason``, ``hint``, the cause's ``figures`` and the run's records
    (``max_penetration`` m, ``drift``) beside them, at ``step`` (``time`` s); ``setting``: :func:`setting_text`."""
    h = thickness
    figs = {"step": step, "time_s": time, "max_penetration_m": max_penetration,
            "max_penetration_h": max_penetration / h, "energy_drift": float(drift), **figures}
    return UnphysicalError(
        f"unphysical motion at step {step} (t = {time:.6g} s): {reason}. {hint} ({setting}).",
        cause=cause, reason=reason, figures=figs, step=step, time=time, quantity=cause, value=value,
    )



def _mt(field) -> str:
    """A field (T) as ``(B_x, B_z) mT`` or ``(B_x, B_y, B_z) mT`` (the components a rod takes)."""
    return "(" + ", ".join(f"{float(b) * 1e3:.4g}" for b in field) + ") mT"


#: field magnitude (T) below which the energy scale uses this floor instead
FIELD_FLOOR = 0.05


class HealthMonitor:
    """Every check of one simulation, and its records: MuJoCo's warnings, a non-finite state, runaway kinetic
    energy and, in contact scenes, the physical bounds (penetration read step by step from the contact
    sensors' history, tunnelling, and the energy balance that detects a launch).

    The stepping engine calls :meth:`begin_call` before a call to ``step``, :meth:`scan_block` after every
    native block, :meth:`check` at every energy check and at the end of a call, and :meth:`book_work` with the
    work of every field change. The records (:attr:`max_penetration`, :attr:`energy_drift`,
    :attr:`max_kinetic_ratio`) say of every run whether it stayed resolved.

    Parameters
    ----------
    rod
        The rod backend (:class:`~magsoft_env.sim.backend.RodBackend`): energies, net moment, lowest point, its
        contact history, its own bounds. Fields are ``(B_x, B_y, B_z)`` (T); the rod's energies and moments are in
        its :attr:`~magsoft_env.sim.backend.RodBackend.field_axes`.
    data : mujoco.MjData
    penetration_limit : float
        Deepest contact allowed (m).
    contact_timeconst : float
        The contact ``solref`` time constant (s), quoted in failure messages.
    """

    def __init__(self, rod, data, *, penetration_limit: float, contact_timeconst: float):
        self.rod = rod
        self.model = rod.model
        self.data = data
        self.contact = rod.has_contact
        self.feature = rod.has_feature
        self.penetration_limit = float(penetration_limit)
        self.tc = float(contact_timeconst)
        self.energy_on = self.contact and rod.two_stage
        self.hist, self.hist_feature = rod.contact_histories(data)
        self._sd = rod.contact_data(data) if self.contact else np.zeros(1)
        self._adr, self._adr2 = rod.contact_adr, rod.feature_adr
        self._mv = np.zeros(self.model.nv)
        self.warning_text: list[str] = []
        self.warning_times: list[float] = []
        self.call_ref = (0, 0.0)  # (nstep, time) at the start of the present call
        self.energy_scale = 0.0
        self.energy_valid = False
        self.work = self.e0 = 0.0
        self.state_key = b""
        #: the components of (B_x, B_y, B_z) the rod takes: its moments and energies are in these
        self.axes = list(rod.field_axes)
        #: the field the last step applied (T), (B_x, B_y, B_z)
        self.b_applied = np.zeros(3)
        self.warn0 = np.zeros(len(WARNING_IDS), dtype=int)
        self.min_dist = self.min_feature = 0.0  # most negative contact distances seen (m)
        self.pen_at = self.feature_at = (0, 0.0)  # step and time of each
        self.pen_hit = ""  # "", "floor" or "scene": which bound was broken
        self.overlap0 = 0.0
        self.floor_limit = self.feature_limit = -self.penetration_limit
        self.max_ke_ratio = 0.0
        self.drift = math.nan

    # ------------------------------------------------------------------ records
    def reset(self, field3: np.ndarray) -> None:
        """Start the records again from the present (synchronized, freshly reset) state under ``field3``."""
        self.warning_text.clear()
        self.warning_times.clear()
        self.warn0 = self.warning_counts()
        self.min_dist = self.min_feature = 0.0
        self.pen_at = self.feature_at = (0, 0.0)
        self.pen_hit = ""
        # a start that already overlaps a scene feature (feature_x through the resting beam) is the
        # caller's geometry, not the dynamics': the contact bounds then count from that overlap
        self.overlap0 = 0.0
        if self.feature:  # the scene sensor sees the floor too: only a contact deeper than the floor's counts
            d_all, d_floor = float(self._sd[self._adr2]), float(self._sd[self._adr])
            self.overlap0 = -d_all if d_all < min(d_floor, 0.0) else 0.0
        self.feature_limit = self.floor_limit = -self.penetration_limit - self.overlap0
        self.max_ke_ratio = 0.0
        self.drift = 0.0 if self.energy_on else math.nan
        self.b_applied = np.array(field3, dtype=float)
        self.rebaseline(stale=False)

    @property
    def max_penetration(self) -> float:
        """Deepest rod contact seen since the last reset (m)."""
        return max(0.0, -self.min_dist, -self.min_feature)  # 0.0 first: never -0.0

    def warning_counts(self) -> np.ndarray:
        return self.data.warning.number[WARNING_IDS].copy()

    def on_warning(self, text: str) -> None:
        """MuJoCo's warning handler while a call runs: the text, with the time of the step that raised it."""
        self.warning_text.append(text)
        self.warning_times.append(float(self.data.time))

    def warned_step(self, nstep: int) -> int:
        """Steps done when the first MuJoCo warning of this call was raised (counting the step that raised
        it, as a per-step loop stops); ``nstep`` if none was timed in this call."""
        n0, t0 = self.call_ref
        dt = self.model.opt.timestep
        if not self.warning_times or self.warning_times[0] < t0 - 0.5 * dt:
            return nstep
        return n0 + int(round((self.warning_times[0] - t0) / dt)) + 1

    # ------------------------------------------------------------------ energy balance
    def kinetic(self) -> float:
        mujoco.mj_mulM(self.model, self.data, self._mv, self.data.qvel)
        return 0.5 * float(self.data.qvel @ self._mv)

    def key(self) -> bytes:
        return self.data.qpos.tobytes() + self.data.qvel.tobytes()

    def rebaseline(self, *, stale: bool) -> None:
        """Start the energy balance from the present state (``stale``: positions not yet synchronized)."""
        self.work = 0.0
        self.energy_valid = self.energy_on
        if self.energy_on:
            if stale:
                mujoco.mj_fwdPosition(self.model, self.data)
            self.e0 = self.rod.energy(self.data, self.b_applied, kinetic=self.kinetic(), staggered=False)
        self.state_key = self.key()

    def begin_call(self, nstep: int, field3: np.ndarray | None, *, external: bool, stale: bool) -> bool:
        """Before a call: restart the energy balance after an outside write to the state (or a call it could
        not follow, or an external wrench whose work it does not count), and book the work of a held field
        set since the last step (``field3``; None when the call's fields vary). Returns whether the
        positions were synchronized here."""
        self.call_ref = (nstep, float(self.data.time))
        if not self.contact:
            return False
        synced = False
        if not self.energy_on or external:
            self.energy_valid = False
            self.drift = math.nan
        elif not self.energy_valid or self.key() != self.state_key:
            self.rebaseline(stale=stale)
            synced = stale
        if self.energy_valid and field3 is not None:
            db = field3 - self.b_applied
            if np.any(db):
                # a held field jumps at the state now: the work -M . dB with M of this state
                if stale and not synced:
                    mujoco.mj_kinematics(self.model, self.data)
                mom = self.rod.net_moment(self.data)
                self.work -= float(mom @ db[self.axes])
            self.b_applied = field3.copy()
        return synced

    def book_work(self, qpos0: np.ndarray, states: np.ndarray, fields: np.ndarray) -> None:
        """The work ``-sum M_j . dB_j`` of a block of per-step fields ``(k, 3)``: ``M_j`` the net moment at step
        j's start (``qpos0``, then the recorded full-physics ``states``), ``dB_j`` the change from the field
        before it."""
        if self.energy_valid:
            nq = self.model.nq
            q = np.empty((len(fields), nq))
            q[0] = qpos0
            q[1:] = states[:-1, 1:1 + nq]  # full physics: time, then qpos
            mom = self.rod.net_moments(q)
            f = fields[:, self.axes]
            db = np.empty_like(f)
            db[0] = f[0] - self.b_applied[self.axes]
            np.subtract(f[1:], f[:-1], out=db[1:])
            self.work -= float(np.einsum("ij,ij->", mom, db))
        self.b_applied = fields[-1].copy()

    def book_step(self, moment: np.ndarray, field: np.ndarray) -> None:
        """The work ``-M . dB`` of one step of a per-step backend that applies ``field`` from a state whose net
        moment is ``moment`` (the 3D rod's couples compute it anyway)."""
        if self.energy_valid:
            db = field - self.b_applied
            if np.any(db):
                self.work -= float(moment @ db[self.axes])
        self.b_applied[:] = field

    # ------------------------------------------------------------------ per-step contact bounds
    def scan_block(self, k: int, stop: int, n0: int, t0: float) -> bool:
        """Record the deepest contacts of the first ``stop`` of the ``k`` steps just taken (from step ``n0`` at
        time ``t0``); True when one broke a bound (recorded there: a per-step loop stops at that step)."""
        if stop <= 0 or not self.contact:
            return False
        sd = self._sd
        if k == 1:
            floor = np.array([sd[self._adr]])
            scene = np.array([sd[self._adr2]]) if self.feature else None
        elif stop == k and self.hist.values.min() >= self.min_dist and (
                not self.feature or self.hist_feature.values.min() >= self.min_feature):
            return False  # the buffer (this block's steps and older ones) holds no new deepest contact
        else:
            floor = self.hist.last(k)[:stop]
            scene = self.hist_feature.last(k)[:stop] if self.feature else None
        dt = self.model.opt.timestep
        first = np.flatnonzero(floor < self.floor_limit)
        if scene is not None:
            s_first = np.flatnonzero(scene < self.feature_limit)
            # the scene's bound counts at a step whose floor contact did not already stop the loop
            if s_first.size and (not first.size or s_first[0] < first[0]):
                floor = floor[:s_first[0] + 1]
                scene = scene[:s_first[0] + 1]
                first = np.zeros(0, dtype=int)
            elif first.size:
                scene = scene[:first[0]]
        if first.size:
            floor = floor[:first[0] + 1]
        j = int(np.argmin(floor))
        if floor[j] < self.min_dist:  # a new deepest floor contact, of the state step n0 + j started from
            self.min_dist = float(floor[j])
            self.pen_at = (n0 + j, t0 + j * dt)
            if self.min_dist < self.floor_limit:
                self.pen_hit = "floor"
        if scene is not None and scene.size:
            j = int(np.argmin(scene))
            if scene[j] < self.min_feature:
                self.min_feature = float(scene[j])
                self.feature_at = (n0 + j, t0 + j * dt)
                if self.min_feature < self.feature_limit:
                    self.pen_hit = "scene"
        return bool(self.pen_hit)

    def pen_step(self) -> int:
        """Steps done after the step whose start state broke the contact bound (a per-step loop stops there)."""
        at = self.pen_at if self.pen_hit == "floor" else self.feature_at
        return at[0] + 1

    def failed_step(self, nstep: int) -> float:
        """The step (count) at which this call's first failure happened (inf if none)."""
        first = self.pen_step() if self.pen_hit else math.inf
        if self.warning_text:
            first = min(first, self.warned_step(nstep))
        return first

    # ------------------------------------------------------------------ checks
    def check(self, nstep: int, field3: np.ndarray, *, energy: bool) -> None:
        """Raise :class:`SimulationError` on a MuJoCo warning, a broken contact bound or a non-finite state;
        with ``energy``, also on runaway kinetic energy and, in contact scenes, tunnelling or a launch."""
        d = self.data
        what = new_warning(self.warning_counts(), self.warn0)
        # the first cause first: a native block may run on past a broken contact bound into a
        # warning or a non-finite state (a per-step loop stops at the bound)
        if what is not None and not (self.pen_hit and self.pen_step() < self.warned_step(nstep)):
            text = f" ({self.warning_text[0].strip()})" if self.warning_text else ""
            self.fail(nstep, field3, f"MuJoCo warning: {what}{text}", math.nan, STABILITY_HINT,
                      step=self.warned_step(nstep))
        if self.pen_hit:
            where, self.pen_hit = self.pen_hit, ""  # reported once; a deeper contact reports again
            self._fail_penetration(nstep, field3, where)
        for name in ("qpos", "qvel"):
            if not math.isfinite(getattr(d, name).sum()):  # a NaN or an infinity makes the sum non-finite
                raise nonfinite_error(name, step=nstep, time=float(d.time), setting=self._numerics(field3))
        bad = self.rod.integrity(d)  # a rod with bounds of its own (the 3D strip's edge stretch)
        if bad is not None:
            self.fail(nstep, field3, bad[0], bad[1], bad[2])
        if not energy:
            return
        # the mass matrix of the step's start (mj_step leaves it in qM) is enough for a
        # factor-100 runaway test and saves recomputing the position stage every check
        ke = self.kinetic()
        if runaway(ke, self.energy_scale):
            raise runaway_error(ke, self.energy_scale, step=nstep, time=float(d.time), setting=self._numerics(field3))
        self.max_ke_ratio = max(self.max_ke_ratio, ke / self.energy_scale)
        if self.contact:
            if self._sd.item(self._adr) == 0.0:
                # no floor contact found: the only case a beam can pass below the floor
                # unseen by the penetration check (the plane collides with anything below it)
                self._check_tunnelling(nstep, field3)
            if self.energy_valid:
                self._check_energy(nstep, field3, ke)

    def _where(self, nstep: int, step: int) -> tuple[int, float]:
        if step == nstep:
            return nstep, float(self.data.time)
        return step, self.call_ref[1] + (step - self.call_ref[0]) * self.model.opt.timestep

    def _setting(self, field3) -> str:
        return setting_text(self.rod.options, np.asarray(field3)[self.axes],
                            contact_timeconst=self.tc if self.contact else None)

    def _numerics(self, field3) -> str:
        return setting_text(self.rod.options, np.asarray(field3)[self.axes])

    def fail(self, nstep: int, field3, quantity: str, value: float, hint: str, *, step: int | None = None) -> None:
        step, t = self._where(nstep, nstep if step is None else step)
        raise unstable_error(quantity, value, hint, step=step, time=t, setting=self._numerics(field3))

    def _unphysical(self, nstep: int, field3, cause: str, reason: str, hint: str, figures: dict, value: float, *,
                    at: tuple | None = None) -> None:
        step, t = (nstep, float(self.data.time)) if at is None else at
        raise unphysical_error(cause, reason, hint, figures, value, step=step, time=t, setting=self._setting(field3),
                               max_penetration=self.max_penetration, thickness=self.rod.beam.thickness,
                               drift=self.drift)

    def _fail_penetration(self, nstep: int, field3, where: str) -> None:
        h = self.rod.beam.thickness
        if where == "floor":
            depth, (step, t), into = -self.min_dist, self.pen_at, "floor"
        else:
            depth, (step, t), into = -self.min_feature, self.feature_at, self.rod.options.scene
        reason = penetration_reason(depth, thickness=h, limit=self.penetration_limit, step=step, time=t,
                                    overlap=self.overlap0, into=into)
        dt = self.model.opt.timestep
        self._unphysical(nstep, field3, "penetration", reason, PENETRATION_HINT, penetration_figures(depth, h), depth,
                         at=None if step + 1 == nstep else (step + 1, t + dt))

    def _check_tunnelling(self, nstep: int, field3) -> None:
        # the centreline (stale: the step's start, as the contact sensor) against the floor z = 0
        zmin = self.rod.lowest_point(self.data, -self.penetration_limit)
        if zmin < -self.penetration_limit:
            h = self.rod.beam.thickness
            self._unphysical(nstep, field3, "tunnelling", tunnelling_reason(zmin, thickness=h,
                                                                            limit=self.penetration_limit),
                             TUNNELLING_HINT, tunnelling_figures(zmin, h), -zmin)

    def _check_energy(self, nstep: int, field3, kinetic: float) -> None:
        # E - E_0 - W <= 0 for a passive rod in a field that did work W on it (damping and
        # contact only dissipate); anything above is energy the numerics made
        excess = self.rod.energy(self.data, field3, kinetic=kinetic, staggered=True) - self.e0 - self.work
        drift = excess / self.energy_scale
        if drift > self.drift:
            self.drift = drift
        if drift > ENERGY_DRIFT_LIMIT:
            reason = launch_reason(excess, drift, energy_scale=self.energy_scale, weight=self.rod.weight,
                                   length=self.rod.beam.length)
            self._unphysical(nstep, field3, "launch", reason, STABILITY_HINT, {"energy_created_J": excess}, excess)


__all__ = ["ENERGY_DRIFT_LIMIT", "FIELD_FLOOR", "MAX_STEPS", "PENETRATION_HINT", "PENETRATION_LIMIT", "RUNAWAY_FACTOR",
           "STABILITY_HINT", "TUNNELLING_HINT", "WARNINGS", "WARNING_IDS", "HealthMonitor", "SensorHistory",
           "SimulationError", "UnphysicalError", "check_steps", "launch_reason", "new_warning", "nonfinite_error",
           "penetration_figures", "penetration_reason", "runaway", "runaway_error", "runaway_hint", "setting_text",
           "tunnelling_figures", "tunnelling_reason", "unphysical_error", "unstable_error"]

"""Many copies of one rod stepped together with ``mujoco.batch``, magnetic couples every step.

The couples are the same as :class:`~magsoft_env.sim.Simulator`'s (``tau = (R m) x B`` from
the orientations of the step's start), and the results bit-identical to a loop of
:class:`Simulator` objects. With native magnetics (``RodOptions(magnetics="native")``, the
default) MuJoCo applies them: each call is a few ``mujoco.batch`` rollouts, one per energy
check, with the fields' inputs as per-step controls (or held) and every step's contact
sensors recorded, so no Python runs between steps. With ``magnetics="python"`` each step asks
``mujoco.batch`` for the position stage at the new state (``stage=mjSTAGE_VEL``, which a
persistent batch reuses, as ``mj_step1`` / ``mj_step2`` do), and each simulation's generalized
magnetic force goes into its ``qfrc_applied`` by the simulator's matrix-vector products.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from ..spec import Beam
from .health import (
    MAX_STEPS,
    STABILITY_HINT,
    WARNING_IDS,
    SimulationError,
    UnphysicalError,
    check_steps,
    new_warning,
    runaway,
    runaway_hint,
)
from .model import NATIVE_CONTROL_SPEC, field_controls
from .simulator import Simulator
from .waveforms import as_waveform


class RodBatch:
    """``nsim`` copies of a rod under per-simulation uniform fields.

    Parameters
    ----------
    beam : Beam
        The beam specification.
    options : RodOptions, optional
        Scene, segments, integrator, timestep (as for :class:`Simulator`).
    nsim : int
        Number of simulations, >= 1.
    nthread : int
        Threads of the batch (1: the calling thread only; 0: all CPUs).

    Notes
    -----
    Stability, checked as :class:`Simulator` checks it, every ``check_every`` steps and at the
    end of every :meth:`step` call: a MuJoCo warning (bad qacc, qvel or qpos, full buffers), a
    non-finite state or a kinetic energy above 100 x the simulation's energy scale raises
    :class:`SimulationError` naming the step and the simulations (``quantity`` lists their
    ids). A simulation MuJoCo fails on is kept at its state before the call. In the contact
    scenes every step also checks the contact penetration of every simulation against the
    template's ``penetration_limit`` (as :class:`Simulator`; :class:`UnphysicalError` naming the
    simulations); :attr:`max_penetration` records the deepest contact of each. The
    simulator's tunnelling and energy-balance checks are not run here. With native magnetics a
    failure found in a rollout chunk is reported with the step at which it happened, as a
    per-step loop reports it; the other simulations have then run on to the next energy check.

    Examples
    --------
    >>> from magsoft_env import Beam
    >>> from magsoft_env.sim import RodOptions
    >>> b = RodBatch(Beam(length=25e-3, width=5e-3, thickness=1.13e-3), RodOptions(scene="floor"), nsim=4)
    >>> b.set_fields([(0.0, 1e-3)] * 4)
    >>> b.step(10)
    >>> b.centerline()[0].shape
    (4, 22)
    """

    def __init__(self, beam: Beam, options=None, *, nsim: int = 16, nthread: int = 1, check_every: int = 50):
        for name, v, lo in (("nsim", nsim, 1), ("nthread", nthread, 0), ("check_every", check_every, 1)):
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"{name} must be an integer >= {lo}, got {v!r}.")
        if nsim > MAX_STEPS:
            raise ValueError(f"nsim must be <= {MAX_STEPS:.0e}, got {nsim!r}.")
        # one Simulator holds the model, the piece tables and the coefficient helpers
        self.template = Simulator(beam, options)
        t = self.template
        self.model = t.model
        self.nsim = int(nsim)
        self.batch = mjbatch.Batch(self.model, nsim=self.nsim, nthread=int(nthread), persistent=True)
        self._qpos = self.batch.bind("qpos")
        self._qvel = self.batch.bind("qvel")
        self._xmat = self.batch.bind("xmat")
        self._xpos = self.batch.bind("xpos")
        self._qfrc = self.batch.bind("qfrc_applied")
        self._M = self.batch.bind("M")  # mass matrices (MuJoCo's sparse layout)
        self._contact = t._contact
        if self._contact:  # the template's contact sensors, one row per simulation
            sd = self.batch.bind("sensordata")
            self._floor_depth = sd[:, t._sensor_adr]
            self._scene_depth = sd[:, t._feature_adr] if t._feature else None
        self._b0, self._b1 = t._b0, t._b1
        self._native = t._native
        if self._native:  # the fields' inputs (every actuator's control |B|, the field frame's quaternion)
            self._ctrl = self.batch.bind("ctrl")
            self._mquat = self.batch.bind("mocap_quat")
            self._nu = self.model.nu
            self._mocap = t.rod.field_mocap
        self._fields = np.zeros((self.nsim, 2))
        self._waveforms = None
        self.check_every = int(check_every)
        self._scratch = mujoco.MjData(self.model)  # holds one simulation's mass matrix for mj_mulM
        self._mv = np.zeros(self.model.nv)
        self.time = 0.0
        self.reset()  # sets nstep and the warning baseline
        self._set_energy_scales()

    @property
    def timestep(self) -> float:
        """Simulation step (s)."""
        return float(self.model.opt.timestep)

    def reset(self) -> None:
        """Every simulation: straight beam at rest (as :meth:`Simulator.reset`), time zero."""
        self.batch.reset()
        if self._native:  # the reset zeroed the fields' inputs; the fields are kept
            self._write_inputs(self._fields)
        self.batch.forward()
        self.time = 0.0
        self.nstep = 0
        self._warn0 = self._warning_counts()
        self._min_dist = np.zeros(self.nsim)  # deepest contact distance of each simulation (m)
        self._dist_limit = np.full(self.nsim, -self.template.penetration_limit)
        if self._contact and self._scene_depth is not None:  # a start that overlaps a feature, as Simulator
            self._dist_limit += np.minimum(np.asarray(self._scene_depth), 0.0)

    @property
    def max_penetration(self) -> np.ndarray:
        """Deepest rod contact of every simulation since the last reset (m), shape ``(nsim,)``."""
        return 0.0 - np.minimum(self._min_dist, 0.0)  # never -0.0

    def _depth_now(self) -> np.ndarray:
        d = np.array(self._floor_depth)
        if self._scene_depth is not None:
            np.minimum(d, self._scene_depth, out=d)
        return d

    def _at(self, n0: int, j: int) -> tuple[int, float]:
        # (step, time) after the j-th step of a native chunk that started at step n0; the batch
        # itself has run on to the chunk's end
        return n0 + j, self.time - (self.nstep - n0 - j) * self.timestep

    def _fail_penetration(self, dist: np.ndarray, *, at: tuple | None = None) -> None:
        step, time = (self.nstep, self.time) if at is None else at
        bad = np.nonzero(dist < self._dist_limit)[0]
        depth, h = -float(dist[bad[0]]), self.template.beam.thickness
        ids = [int(i) for i in bad]
        reason = (f"contact penetration {depth * 1e3:.3g} mm = {depth / h:.3g} h (limit "
                  f"{-float(self._dist_limit[bad[0]]) * 1e3:.3g} mm) in simulation {ids[0]}")
        raise UnphysicalError(
            f"unphysical motion at step {step} (t = {time:.6g} s) in simulations {ids}: {reason}. "
            "The contact is not resolved: use a smaller timestep or a gentler field.",
            cause="penetration", reason=reason,
            figures={"step": step, "time_s": time, "penetration_m": depth, "penetration_h": depth / h},
            step=step, time=time, quantity=f"penetration in simulations {ids}", value=depth,
        )

    def _warning_counts(self) -> np.ndarray:
        return np.asarray(self.batch.warning)[:, WARNING_IDS, 1].copy()

    def _set_energy_scales(self) -> None:
        # per simulation, as Simulator's: its peak field (a waveform's over its first second)
        if self._waveforms is None:
            peaks = np.hypot(self._fields[:, 0], self._fields[:, 1])
        else:
            ts = np.linspace(0.0, 1.0, 257)
            peaks = np.array([float(np.hypot(*np.abs(w.sample(ts)).max(axis=0))) for w in self._waveforms])
        self._energy_scale = np.array([self.template._compute_energy_scale(float(b)) for b in peaks])

    def kinetic_energy(self) -> np.ndarray:
        """Kinetic energy of every simulation (J), shape ``(nsim,)``, from the mass matrix the
        batch holds for it (the current state's after :meth:`step`)."""
        ke = np.empty(self.nsim)
        d, mv = self._scratch, self._mv
        for s in range(self.nsim):
            d.M[:] = self._M[s]
            mujoco.mj_mulM(self.model, d, mv, self._qvel[s])
            ke[s] = 0.5 * float(self._qvel[s] @ mv)
        return ke

    def _check(self, *, energy: bool, text=(), at: tuple | None = None) -> None:
        hint = STABILITY_HINT
        counts = self._warning_counts()
        bad = np.nonzero((counts > self._warn0).any(axis=1))[0]
        if bad.size:
            what = new_warning(counts[bad[0]], self._warn0[bad[0]])
            detail = f"({text[0].strip()}) " if text else ""
            self._fail(f"MuJoCo warning: {what}", bad, math.nan, detail + hint, at=at)
        bad = np.nonzero(~np.all(np.isfinite(self._qpos), axis=1) | ~np.all(np.isfinite(self._qvel), axis=1))[0]
        if bad.size:
            self._fail("non-finite state", bad, math.nan, hint)
        if energy:
            ke = self.kinetic_energy()
            bad = np.nonzero(runaway(ke, self._energy_scale))[0]
            if bad.size:
                self._fail("runaway kinetic energy (J)", bad, float(ke[bad[0]]),
                           runaway_hint(self._energy_scale[bad[0]], f" in simulation {bad[0]}"))

    def _fail(self, what: str, ids, value: float, hint: str, *, at: tuple | None = None) -> None:
        ids = [int(i) for i in ids]
        step, time = (self.nstep, self.time) if at is None else at
        raise SimulationError(
            f"{what} at step {step} (t = {time:.6g} s) in simulations {ids}"
            f"{'' if math.isnan(value) else f': {value:.4g}'}. {hint}",
            step=step, time=time, quantity=f"{what} in simulations {ids}", value=value,
        )

    def set_fields(self, fields) -> None:
        """Hold constant fields, shape ``(nsim, 2)`` of ``(B_x, B_z)`` (T), from now on."""
        f = np.asarray(fields, dtype=float)
        if f.shape != (self.nsim, 2) or not np.all(np.isfinite(f)):
            raise ValueError(f"fields must be a finite array of shape ({self.nsim}, 2) in T, got shape {f.shape}.")
        self._fields[:] = f
        self._waveforms = None
        if self._native:
            self._write_inputs(f)
        self._set_energy_scales()

    def _write_inputs(self, fields: np.ndarray) -> None:
        mag, quat = field_controls(fields)
        self._ctrl[:] = mag[:, None]
        self._mquat[:, self._mocap] = quat

    def _native_controls(self, fields: np.ndarray) -> np.ndarray:
        # (k, nsim, 2) fields -> (nsim, k, nu + 4) rollout controls (NATIVE_CONTROL_SPEC)
        k = fields.shape[0]
        mag, quat = field_controls(fields.reshape(-1, 2))
        u = np.empty((k, self.nsim, self._nu + 4))
        u[..., :self._nu] = mag.reshape(k, self.nsim, 1)
        u[..., self._nu:] = quat.reshape(k, self.nsim, 4)
        return np.ascontiguousarray(u.transpose(1, 0, 2))

    def set_waveforms(self, waveforms) -> None:
        """Let simulation ``i`` follow ``waveforms[i](t)`` (T), ``t`` the batch time (s)."""
        wfs = list(waveforms)
        if len(wfs) != self.nsim:
            raise ValueError(f"waveforms must hold {self.nsim} waveforms, got {len(wfs)}.")
        self._waveforms = [as_waveform(w, f"waveforms[{i}]") for i, w in enumerate(wfs)]
        self._set_energy_scales()

    def step(self, n: int = 1) -> None:
        """Advance every simulation ``n`` steps with the couples updated each step.

        Raises
        ------
        SimulationError
            If MuJoCo failed on a simulation or warned about it, its state turned non-finite or
            its kinetic energy ran away (see the class notes).
        """
        if isinstance(n, (bool, np.bool_)) or not isinstance(n, (int, np.integer)) or n < 0:
            raise ValueError(f"n must be a non-negative integer number of steps, got {n!r}.")
        n = int(n)
        check_steps(f"n x nsim = {n} x {self.nsim}", n * self.nsim, "Call step() repeatedly for a longer run.")
        if self._native:
            self._step_native(n)
            return
        t = self.template
        nv = self.model.nv
        gzx = t._gzx
        b0, b1 = self._b0, self._b1
        x = self._xmat[:, b0:b1].reshape(self.nsim, -1)  # live views
        q = self._qfrc
        dot = np.dot
        if self._waveforms is not None:
            ts = self.time + self.timestep * np.arange(n)
            fields = np.stack([w.sample(ts) for w in self._waveforms], axis=1)  # (n, nsim, 2)
            bs = fields * np.array([1.0, -1.0])
            v = np.empty((self.nsim, 2 * nv))
            v2 = v.reshape(self.nsim, 2, nv)
        else:
            fields = None
            # as Simulator._set_coefficients: G = B_x G_z - B_z G_x
            G = [np.subtract(bx * gzx[:, :nv], bz * gzx[:, nv:]) for bx, bz in self._fields]
        stage = mujoco.mjtStage.mjSTAGE_VEL
        contact = self._contact
        # MuJoCo's warning text is captured (not printed or logged to MUJOCO_LOG.TXT), as in
        # Simulator.step; a warning ends the loop at the step that raised it
        prev = mujoco.get_mju_user_warning()
        warned = []
        mujoco.set_mju_user_warning(warned.append)
        k = -1
        try:
            for k in range(n):
                for s in range(self.nsim):  # the simulator's own products, so the arithmetic is identical
                    if fields is None:
                        dot(x[s], G[s], out=q[s])
                    else:
                        dot(x[s], gzx, out=v[s])
                        dot(bs[k, s], v2[s], out=q[s])
                try:
                    self.batch.step(stage=stage)
                except mjbatch.SimulationError as err:
                    raise self._batch_failure(err) from err
                self.time += self.timestep
                self.nstep += 1
                if warned:
                    break
                if contact:  # every simulation's deepest contact of the state the step started from
                    dist = self._depth_now()
                    np.minimum(self._min_dist, dist, out=self._min_dist)
                    if np.any(dist < self._dist_limit):
                        self._check(energy=False, text=warned)  # a MuJoCo warning or NaN comes first
                        self._fail_penetration(dist)
                if self.nstep % self.check_every == 0:
                    self._check(energy=True)
        finally:
            mujoco.set_mju_user_warning(prev)
            if fields is not None and k >= 0:
                self._fields[:] = fields[k]
        self._check(energy=False, text=warned)

    def _batch_failure(self, err) -> SimulationError:
        """mujoco.batch's failure as this batch's SimulationError, naming the step, time and simulations."""
        ids = list(getattr(err, "ids", []))
        return SimulationError(
            f"batch step failed at step {self.nstep} (t = {self.time:.6g} s) in simulations {ids}: {err}",
            step=self.nstep, time=self.time, quantity=f"simulations {ids}",
        )

    def _step_native(self, n: int) -> None:
        # one batch rollout per energy check interval: controls per step (waveforms) or held
        # (fields), every step's contact sensors and time recorded; a simulation that warns stops
        # there (mujoco.batch), so each check sees the step at which it happened
        fields = None
        if self._waveforms is not None:
            ts = self.time + self.timestep * np.arange(n)
            fields = np.stack([w.sample(ts) for w in self._waveforms], axis=1)  # (n, nsim, 2)
        T = int(mujoco.mjtState.mjSTATE_TIME)
        record = (T, "sensordata") if self._contact else (T,)
        prev = mujoco.get_mju_user_warning()
        warned = []
        mujoco.set_mju_user_warning(warned.append)
        done = 0
        try:
            while done < n:
                k = min(n - done, self.check_every - self.nstep % self.check_every)
                control = None if fields is None else self._native_controls(fields[done:done + k])
                try:
                    rec = self.batch.rollout(k, control, NATIVE_CONTROL_SPEC, record=record)
                except mjbatch.SimulationError as err:
                    raise self._batch_failure(err) from err
                n0 = self.nstep
                self.nstep += k
                self.time += k * self.timestep
                done += k
                if fields is not None:
                    self._fields[:] = fields[done - 1]
                # steps each simulation took: one that warned stops, its records repeat from there
                t_rec = rec[T][..., 0]
                stalled = np.diff(t_rec, axis=1) == 0.0
                took = np.where(stalled.any(axis=1), stalled.argmax(axis=1) + 1, k)
                counts = self._warning_counts()
                warn_ids = np.nonzero((counts > self._warn0).any(axis=1))[0]
                w_step = int(took[warn_ids].min()) if warn_ids.size else k + 1  # 1-based, within the chunk
                if self._contact:
                    dist = rec["sensordata"][:, :, self.template._sensor_adr]
                    if self._scene_depth is not None:
                        dist = np.minimum(dist, rec["sensordata"][:, :, self.template._feature_adr])
                    # only the steps each took before a warning stopped the batch (a per-step loop stops there)
                    valid = np.arange(k)[None, :] < np.minimum(took, w_step - 1)[:, None]
                    broke = (dist < self._dist_limit[:, None]) & valid
                    p_step = int(broke.any(axis=0).argmax()) + 1 if broke.any() else k + 1
                    upto = min(p_step, w_step - 1, k)
                    if upto > 0:
                        seen = np.where(valid[:, :upto], dist[:, :upto], np.inf).min(axis=1)
                        np.minimum(self._min_dist, seen, out=self._min_dist)
                    if p_step < w_step:
                        self._fail_penetration(dist[:, p_step - 1], at=self._at(n0, p_step))
                if warn_ids.size:
                    self._check(energy=False, text=warned, at=self._at(n0, w_step))
                if self.nstep % self.check_every == 0:
                    self.batch.forward(stage=mujoco.mjtStage.mjSTAGE_POS)  # the mass matrices of the state now
                    self._check(energy=True)
        finally:
            mujoco.set_mju_user_warning(prev)
        self.batch.forward(stage=mujoco.mjtStage.mjSTAGE_VEL)  # readouts of the state now, as mj_step1 leaves them
        self._check(energy=False, text=warned)

    @property
    def qpos(self) -> np.ndarray:
        """Joint positions, shape ``(nsim, nq)`` (live view; write to set states)."""
        return self._qpos

    @property
    def qvel(self) -> np.ndarray:
        """Joint velocities, shape ``(nsim, nv)`` (live view)."""
        return self._qvel

    def centerline(self) -> tuple[np.ndarray, np.ndarray]:
        """Centerline points (m) of every simulation, each of shape ``(nsim, N + 2)``.

        As :meth:`Simulator.centerline`: base end, every hinge, tip.
        """
        t = self.template
        ids = t._bodies
        p = self._xpos[:, ids]
        tipmat = self._xmat[:, ids[-1]]
        tip = p[:, -1] + t._tip_len * tipmat[:, [0, 3, 6]]
        x = np.concatenate([p[:, :, 0], tip[:, None, 0]], axis=1)
        z = np.concatenate([p[:, :, 2], tip[:, None, 2]], axis=1)
        return x, z

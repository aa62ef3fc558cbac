"""Many copies of one rod stepped together with ``mujoco.batch``, magnetic couples every step.

The couples are the same as :class:`~magsoft_env.sim.Simulator`'s (``tau = (R m) x B`` from
the orientations of the current state): each step asks ``mujoco.batch`` for the
position stage at the new state (``stage=mjSTAGE_VEL``, which a persistent batch reuses,
as ``mj_step1`` / ``mj_step2`` do), and each simulation's generalized magnetic force goes
into its ``qfrc_applied`` by the same matrix-vector products as the simulator's, so the
results are bit-identical to a loop of :class:`Simulator` objects.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
from mujoco import batch as mjbatch

from ..spec import Beam
from .simulator import SimulationError, Simulator
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
    Stability: after every call to :meth:`step` a non-finite state raises
    :class:`SimulationError` naming the simulations (``quantity`` lists their ids); MuJoCo
    keeps failed simulations at their state before the call.

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

    def __init__(self, beam: Beam, options=None, *, nsim: int = 16, nthread: int = 1):
        for name, v, lo in (("nsim", nsim, 1), ("nthread", nthread, 0)):
            if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or v < lo:
                raise ValueError(f"{name} must be an integer >= {lo}, got {v!r}.")
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
        self._b0, self._b1 = t._b0, t._b1
        self._fields = np.zeros((self.nsim, 2))
        self._waveforms = None
        self.time = 0.0
        self.reset()

    @property
    def timestep(self) -> float:
        """Simulation step (s)."""
        return float(self.model.opt.timestep)

    def reset(self) -> None:
        """Every simulation: straight beam at rest (as :meth:`Simulator.reset`), time zero."""
        self.batch.reset()
        self.batch.forward()
        self.time = 0.0

    def set_fields(self, fields) -> None:
        """Hold constant fields, shape ``(nsim, 2)`` of ``(B_x, B_z)`` (T), from now on."""
        f = np.asarray(fields, dtype=float)
        if f.shape != (self.nsim, 2) or not np.all(np.isfinite(f)):
            raise ValueError(f"fields must be a finite array of shape ({self.nsim}, 2) in T, got shape {f.shape}.")
        self._fields[:] = f
        self._waveforms = None

    def set_waveforms(self, waveforms) -> None:
        """Let simulation ``i`` follow ``waveforms[i](t)`` (T), ``t`` the batch time (s)."""
        wfs = list(waveforms)
        if len(wfs) != self.nsim:
            raise ValueError(f"waveforms must hold {self.nsim} waveforms, got {len(wfs)}.")
        self._waveforms = [as_waveform(w, f"waveforms[{i}]") for i, w in enumerate(wfs)]

    def step(self, n: int = 1) -> None:
        """Advance every simulation ``n`` steps with the couples updated each step.

        Raises
        ------
        SimulationError
            If a simulation's state turned non-finite or MuJoCo failed on it.
        """
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
        for k in range(int(n)):
            for s in range(self.nsim):  # the simulator's own products, so the arithmetic is identical
                if fields is None:
                    dot(x[s], G[s], out=q[s])
                else:
                    dot(x[s], gzx, out=v[s])
                    dot(bs[k, s], v2[s], out=q[s])
            try:
                self.batch.step(stage=stage)
            except mjbatch.SimulationError as err:
                ids = list(getattr(err, "ids", []))
                raise SimulationError(
                    f"batch step failed at t = {self.time:.6g} s in simulations {ids}: {err}",
                    step=k, time=self.time, quantity=f"simulations {ids}",
                ) from err
            self.time += self.timestep
        if fields is not None:
            self._fields[:] = fields[-1]
        bad = np.nonzero(~np.all(np.isfinite(self._qpos), axis=1) | ~np.all(np.isfinite(self._qvel), axis=1))[0]
        if bad.size:
            raise SimulationError(
                f"non-finite state at t = {self.time:.6g} s in simulations {bad.tolist()}; use a smaller timestep.",
                step=int(n), time=self.time, quantity=f"simulations {bad.tolist()}", value=math.nan,
            )

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

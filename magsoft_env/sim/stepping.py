"""How a rod backend runs a block of steps: natively in MuJoCo, or with couples written from Python each step.

A rod backend's :meth:`~magsoft_env.sim.backend.RodBackend.advance` runs ``k`` steps under a held field or one
field per step, and books the field's work with the health monitor. Two ways exist, one class each:

- :class:`NativeSteps`: the couples are MuJoCo's own forces (actuators whose controls are the field's inputs).
  A held field runs as ``mj_step(m, d, k)``; fields that change run as one ``mujoco.rollout`` call with per-step
  inputs, bit for bit what ``k`` single steps with the inputs set before each give.
- :class:`PythonSteps`: the couples depend on the state in a way MuJoCo cannot apply by itself (the 3D strip's
  transverse magnetization needs the material frames): before every step the backend writes them, the field's
  work is booked with the net moment they used, and after it the backend records what its checks read.
"""

from __future__ import annotations

import mujoco
import numpy as np


class NativeSteps:
    """Blocks of steps inside MuJoCo for a backend whose couples MuJoCo applies itself.

    Parameters
    ----------
    model : mujoco.MjModel
    control_spec : int
        ``mujoco.mjtState`` spec of the per-step input rows.
    controls : callable
        ``fields (k, 3) -> (k, ncontrol)``: the input rows of per-step fields ``(B_x, B_y, B_z)`` (T).
    """

    def __init__(self, model: mujoco.MjModel, control_spec: int, controls):
        self.model = model
        self.control_spec = int(control_spec)
        self._controls = controls
        #: the field (T) whose inputs are in the data now
        self.inputs = np.zeros(3)
        self._rollout = None  # mujoco.rollout.Rollout, made on the first block with per-step inputs
        self._state0 = np.empty((1, mujoco.mj_stateSize(model, int(mujoco.mjtState.mjSTATE_FULLPHYSICS))))
        self._warm0 = np.empty((1, model.nv))
        self._buffers: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def written(self, field3: np.ndarray) -> None:
        """The inputs of ``field3`` were just written into the data."""
        self.inputs[:] = field3

    def advance(self, data: mujoco.MjData, field3: np.ndarray, fields: np.ndarray | None, k: int, health) -> None:
        """``k`` steps: the held field ``field3`` (``fields`` None, or every row the field whose inputs are set
        and, with the energy balance on, the one the last step applied) as ``mj_step(m, d, k)``; per-step fields
        ``(k, 3)`` as one ``mujoco.rollout``, their work booked from the recorded states."""
        if fields is None or not (np.any(fields != self.inputs)
                                  or health.energy_valid and np.any(fields[0] != health.b_applied)):
            mujoco.mj_step(self.model, data, k)
            return
        q0 = data.qpos.copy() if health.energy_valid else None
        states = self._roll(data, self._controls(fields))
        health.book_work(q0, states, fields)
        self.inputs[:] = fields[-1]

    def _roll(self, data: mujoco.MjData, controls: np.ndarray) -> np.ndarray:
        """``len(controls)`` steps with per-step inputs in one ``mujoco.rollout`` call on ``data`` itself, which
        ends where as many ``mj_step`` calls with the inputs set before each leave it (state, warm start, contact
        history: tested bit for bit); returns the recorded full-physics states after each step, ``(k, nstate)``."""
        m = self.model
        k = controls.shape[0]
        if self._rollout is None:
            from mujoco import rollout as mjrollout

            self._rollout = mjrollout.Rollout(nthread=0)
        if k not in self._buffers:
            self._buffers[k] = (np.empty((1, k, self._state0.shape[1])), np.empty((1, k, m.nsensordata)))
        states, sens = self._buffers[k]
        mujoco.mj_getState(m, data, self._state0[0], int(mujoco.mjtState.mjSTATE_FULLPHYSICS))
        self._warm0[0] = data.qacc_warmstart
        self._rollout.rollout([m], [data], self._state0, np.ascontiguousarray(controls[None]),
                              control_spec=self.control_spec, skip_checks=True, nstep=k,
                              initial_warmstart=self._warm0, state=states, sensordata=sens)
        return states[0]


class PythonSteps:
    """Steps one at a time with the couples written from Python before each (see the module docstring).

    Parameters
    ----------
    model : mujoco.MjModel
    backend
        Its ``write_field(data, field3)`` writes the couples of the state in ``data`` and leaves their net moment in
        ``backend.moment``; ``before_step(data)`` and ``after_step(data)`` record what its readouts and checks read
        (the state a step starts from; the contacts that step found).
    records : bool
        Call ``before_step`` and ``after_step``. False for a backend whose readouts are MuJoCo's own sensors with
        history buffers (:mod:`~magsoft_env.sim.histories`), which every step fills in C whoever steps it.
    """

    def __init__(self, model: mujoco.MjModel, backend, *, records: bool = True):
        self.model = model
        self.backend = backend
        self.records = bool(records)

    def written(self, field3: np.ndarray) -> None:
        """Nothing to remember: the couples are written before every step."""

    def advance(self, data: mujoco.MjData, field3: np.ndarray, fields: np.ndarray | None, k: int, health) -> None:
        """``k`` steps under the held ``field3`` or the per-step ``fields`` ``(k, 3)`` (T)."""
        m, backend = self.model, self.backend
        write, book, moment, records = backend.write_field, health.book_step, backend.moment, self.records
        for i in range(k):
            b = field3 if fields is None else fields[i]
            write(data, b)
            book(moment, b)
            if records:
                backend.before_step(data)
            mujoco.mj_step(m, data)
            if records:
                backend.after_step(data)


__all__ = ["NativeSteps", "PythonSteps"]

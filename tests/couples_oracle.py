"""Test oracles for the simulator: magnetic couples written by Python, one step at a time.

The library applies the magnetic couples as MuJoCo's own forces (pole actuators) and steps in native blocks.
These oracles do it the plain way, so the tests can prove the native forces and the block engine exact:

- :class:`PythonCouples` builds the same rod without pole actuators and writes every piece's couple
  ``(R m) x B`` as a generalized force (``mj_applyFT``) between ``mj_step1`` and ``mj_step2``;
- :func:`per_step_loop` drives a native model one ``mj_step`` at a time with the field's inputs set before each
  step, and reports the first step that breaks the penetration bound or raises a MuJoCo warning.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from magsoft_env.sim import RodOptions, build_model
from magsoft_env.sim.health import WARNING_IDS
from magsoft_env.sim.magnetics import body_moments_3d
from magsoft_env.sim.model import field_control


class PythonCouples:
    """The rod with couples from Python: ``tau_i = (R_i m_i) x B`` at every piece, each step."""

    def __init__(self, beam, options: RodOptions):
        self.rod = build_model(beam, dataclasses.replace(options, magnetics="python"))
        self.model = self.rod.model
        self.data = mujoco.MjData(self.model)
        self.m_body = body_moments_3d(self.rod.disc.moment)
        self.field = np.zeros(3)
        self.min_dist = 0.0
        mujoco.mj_forward(self.model, self.data)

    def couples_into(self, out: np.ndarray) -> None:
        """Generalized forces of the couples of the orientations in ``xmat``, into ``out`` (nv,)."""
        d = self.data
        out[:] = 0.0
        for body, m in zip(self.rod.body_ids, self.m_body, strict=True):
            tau = np.cross(d.xmat[body].reshape(3, 3) @ m, self.field)
            mujoco.mj_applyFT(self.model, d, np.zeros(3), tau, d.xipos[body], int(body), out)

    def step(self, fields) -> None:
        """One step per field ``(B_x, B_z)`` (T), couples of each step's start."""
        m, d = self.model, self.data
        adr = self.rod.contact_sensor
        for bx, bz in np.asarray(fields, dtype=float).reshape(-1, 2):
            self.field[:] = bx, 0.0, bz
            mujoco.mj_step1(m, d)
            self.couples_into(d.qfrc_applied)
            mujoco.mj_step2(m, d)
            if adr >= 0:
                self.min_dist = min(self.min_dist, float(d.sensordata[adr]))


def per_step_loop(sim_model, rod, data, fields, *, limit: float | None = None, initial=(0.0, 0.0)):
    """Step ``data`` once per field with the native inputs set before each step; returns ``(steps, cause, work,
    min_dist)``: the steps taken (stopping at the first failure, counted as the simulator counts it), the cause
    (``""``, ``"penetration"`` or ``"warning"``), the field's work ``-sum M_j . dB_j`` (M of each step's start,
    from ``xmat`` after the step; ``dB`` from ``initial`` on) and the deepest floor contact seen."""
    m = sim_model
    adr = rod.contact_sensor
    bodies = rod.body_ids
    m_body = body_moments_3d(rod.disc.moment)
    warn0 = data.warning.number[WARNING_IDS].copy()
    work, low = 0.0, 0.0
    previous_field = tuple(initial)
    for k, (bx, bz) in enumerate(np.asarray(fields, dtype=float).reshape(-1, 2), start=1):
        mag, w, y = field_control(bx, bz)
        data.ctrl[:] = mag
        data.mocap_quat[rod.field_mocap] = (w, 0.0, y, 0.0)
        mujoco.mj_step(m, data)
        if np.any(data.warning.number[WARNING_IDS] > warn0):
            return k, "warning", work, low
        mom = sum(data.xmat[b].reshape(3, 3) @ mb for b, mb in zip(bodies, m_body, strict=True))
        work -= float(mom[0] * (bx - previous_field[0]) + mom[2] * (bz - previous_field[1]))
        previous_field = (bx, bz)
        if adr >= 0:
            low = min(low, float(data.sensordata[adr]))
            if limit is not None and low < -limit:
                return k, "penetration", work, low
    return len(fields), "", work, low

"""Readers of what every step of the last block did: MuJoCo's sensor history buffers, or a record kept from Python.

A block of steps run inside MuJoCo (``mj_step(m, d, k)``, ``mujoco.rollout``) is checked step by step afterwards
from the history buffers of MuJoCo's sensors: :class:`SensorHistory` (a scalar, e.g. the deepest contact) and
:class:`PointsHistory` (the centreline points, ``framepos`` sensors). A rod stepped from Python one step at a time
keeps the same record itself: :class:`Ring`. Every reader answers ``nsample`` and ``last(k)``, oldest first.
"""

from __future__ import annotations

import mujoco
import numpy as np


class SensorHistory:
    """The last samples of a scalar MuJoCo sensor from its history buffer (``nsample > 0``), oldest first.

    MuJoCo appends every step's value (the sensor of the state the step started from, as
    ``sensordata`` after the step) to a ring buffer in ``mjData.history``: per sensor a user slot, the
    index of the newest sample, ``nsample`` timestamps, then the values. This reads the values of
    the last ``k`` steps, so that a block of steps run inside MuJoCo (``mj_step(m, d, k)``,
    ``mujoco.batch``) is checked step by step afterwards.

    Parameters
    ----------
    model : mujoco.MjModel
    sensor : int
        Sensor id (a dimension-1 sensor with ``nsample > 0``).
    history : ndarray, shape (nhistory,) or (nsim, nhistory)
        ``mjData.history``, or a ``mujoco.batch`` binding of it (one row per simulation).
    """

    def __init__(self, model, sensor: int, history: np.ndarray):
        adr, ns = int(model.sensor_historyadr[sensor]), int(model.sensor_history[sensor, 0])
        if adr < 0 or ns < 1 or int(model.sensor_dim[sensor]) != 1:
            raise ValueError(f"sensor {sensor} must be a scalar sensor with a history buffer (nsample > 0).")
        self.nsample = ns
        self._history = history
        self._cursor = adr + 1
        #: the buffer's values in ring order (a view): the last nsample steps, in no particular order
        self.values = history[..., adr + 2 + ns: adr + 2 + 2 * ns]
        self._offsets = np.arange(1 - ns, 1)

    def last(self, k: int) -> np.ndarray:
        """The values of the last ``k`` (<= nsample) steps, oldest first: shape ``(k,)``, or ``(nsim, k)``."""
        if not 1 <= k <= self.nsample:
            raise ValueError(f"k must lie in [1, {self.nsample}], got {k!r}.")
        cursor = self._history[..., self._cursor].astype(int)
        idx = (np.asarray(cursor)[..., None] + self._offsets[self.nsample - k:]) % self.nsample
        return np.take_along_axis(self.values, idx, axis=-1)


class PointsHistory:
    """The centreline at every step of the last native block, from MuJoCo's own ``framepos`` sensors.

    The model carries a ``framepos`` sensor on each centreline point, named ``prefix + index``, each with a
    history buffer of ``nsample`` steps; after ``mj_step(m, d, k)`` (or a ``mujoco.rollout`` block) the buffers
    hold the centreline of the state each of the ``k`` steps started from.
    """

    def __init__(self, model, data, prefix: str):
        ids = []
        while (sid := mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SENSOR, f"{prefix}{len(ids)}")) >= 0:
            ids.append(sid)
        if len(ids) < 2:
            raise ValueError(f"the model has no centreline sensors ({prefix}0, ...): a contact scene builds them.")
        ns = int(model.sensor_history[ids[0], 0])
        adr = model.sensor_historyadr[ids].astype(int)
        stride = 2 + ns + 3 * ns  # user slot, cursor, nsample timestamps, nsample 3-vectors
        if ns < 1 or np.any(model.sensor_history[ids, 0] != ns) or np.any(adr != adr[0] + stride * np.arange(len(ids))):
            raise ValueError("the centreline sensors must be consecutive 3-vectors with equal history buffers.")
        #: samples each buffer holds: the longest block it covers (steps)
        self.nsample = ns
        rows = data.history[adr[0]: adr[0] + stride * len(ids)].reshape(len(ids), stride)  # a view
        self._cursor = rows[0, 1:2]
        self._values = rows[:, 2 + ns:].reshape(len(ids), ns, 3)

    def last(self, k: int) -> np.ndarray:
        """The centreline points (m) at the start of each of the last ``k`` steps, oldest first: shape
        ``(npoints, k, 3)`` (a view where the samples lie in one piece of the ring)."""
        if not 1 <= k <= self.nsample:
            raise ValueError(f"k must lie in [1, {self.nsample}], got {k!r}.")
        end = int(self._cursor[0]) + 1
        if end >= k:
            return self._values[:, end - k:end]
        return self._values[:, (end + np.arange(-k, 0)) % self.nsample]


class Ring:
    """The last ``nsample`` values pushed, oldest first: what a history buffer holds, for a rod stepped from
    Python one step at a time. Values are scalars (``shape=()``) or arrays of ``shape``; :meth:`last` returns
    the step axis where :class:`SensorHistory` (first) and :class:`PointsHistory` (second, ``step_axis=1``) have it.
    """

    def __init__(self, nsample: int, shape: tuple = (), *, step_axis: int = 0):
        self.nsample = int(nsample)
        self._step_axis = int(step_axis)
        #: the values in ring order (the last ``nsample`` steps, in no particular order)
        self.values = np.zeros((self.nsample, *shape))
        self._cursor = self.nsample - 1

    def push(self, value) -> None:
        self._cursor = (self._cursor + 1) % self.nsample
        self.values[self._cursor] = value

    def last(self, k: int) -> np.ndarray:
        """The values of the last ``k`` (<= nsample) steps, oldest first."""
        if not 1 <= k <= self.nsample:
            raise ValueError(f"k must lie in [1, {self.nsample}], got {k!r}.")
        v = self.values[(self._cursor + np.arange(1 - k, 1)) % self.nsample]
        return np.moveaxis(v, 0, self._step_axis) if self._step_axis else v


__all__ = ["PointsHistory", "Ring", "SensorHistory"]

"""Health checks of a MuJoCo rod simulation, shared by :class:`~magsoft_env.sim.Simulator` and
:class:`~magsoft_env.sim.RodBatch`: the error types, the MuJoCo warnings that stop a run, the
runaway-energy bound, the physical bounds of the contact scenes (penetration, tunnelling,
launch), the work bound of one call, and the reader of MuJoCo's sensor history buffers that lets
blocks of steps run inside MuJoCo keep the per-step penetration check.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

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
#: tumbles at 2-3 mT, and the silent failure of issue 12 (100 mT) 2.1 h in its first step.
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


def runaway_hint(energy_scale: float, where: str = "") -> str:
    """The message tail of a runaway-energy failure."""
    return f"It exceeds {RUNAWAY_FACTOR:g} x the energy scale {energy_scale:.3g} J{where}. {STABILITY_HINT}"


__all__ = ["ENERGY_DRIFT_LIMIT", "MAX_STEPS", "PENETRATION_LIMIT", "RUNAWAY_FACTOR", "STABILITY_HINT", "WARNINGS",
           "WARNING_IDS", "SensorHistory", "SimulationError", "UnphysicalError", "check_steps", "new_warning",
           "runaway", "runaway_hint"]

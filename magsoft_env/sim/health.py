"""Health checks of a MuJoCo rod simulation, shared by :class:`~magsoft_env.sim.Simulator` and
:class:`~magsoft_env.sim.RodBatch`: the error type, the MuJoCo warnings that stop a run, the
runaway-energy bound.
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


__all__ = ["RUNAWAY_FACTOR", "STABILITY_HINT", "WARNINGS", "WARNING_IDS", "SimulationError", "new_warning",
           "runaway", "runaway_hint"]

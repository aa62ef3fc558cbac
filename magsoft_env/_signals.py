"""Periodic drive signals shared by the simulator's waveforms and the gait presets (numpy only).

Kept apart from :mod:`magsoft_env.sim.waveforms` so that :mod:`magsoft_env.gaits` can sample a
drive without importing MuJoCo.
"""

from __future__ import annotations

import math

import numpy as np


def switched_square(t, amplitude: float, frequency: float, phase: float = 0.0, time_constant: float = 0.0):
    """A square drive of ``amplitude`` through a first-order coil, in its periodic steady state.

    The coil is driven towards ``+amplitude`` while ``sin(2 pi f t + phase) >= 0`` and towards
    ``-amplitude`` otherwise (the switch happens at the zero crossings of that sine, so
    ``time_constant = 0`` is the ideal square ``amplitude * sign(sin(2 pi f t + phase))``). With a
    time constant ``tau`` > 0 (an RL coil: tau = L / R) the field relaxes exponentially after each
    switch: with half period ``h = 1 / (2 f)`` it starts each positive half at
    ``-amplitude * tanh(h / (2 tau))`` and approaches ``+amplitude`` as
    ``amplitude + (b0 - amplitude) exp(-t' / tau)`` (and the mirror image in the negative half), so
    the signal is continuous and periodic from ``t = 0``.

    Parameters
    ----------
    t : array_like
        Times (s).
    amplitude : float
        Drive amplitude (the field the coil settles to), any unit; signed.
    frequency : float
        Switching frequency (Hz), > 0.
    phase : float
        Phase (rad) of the switching sine.
    time_constant : float
        Coil time constant (s), >= 0.

    Examples
    --------
    >>> switched_square([0.1, 0.3], 2.0, 2.0).tolist()
    [2.0, -2.0]
    >>> round(float(switched_square(0.0, 1.0, 1.0, 0.0, 1e6)), 6)  # a very slow coil barely moves
    -0.0
    """
    t = np.asarray(t, dtype=float)
    u = np.mod(frequency * t + phase / (2.0 * math.pi), 1.0)
    positive_half = u < 0.5
    if time_constant <= 0.0:
        return np.where(positive_half, amplitude, -amplitude)
    h = 0.5 / frequency
    b0 = -amplitude * math.tanh(h / (2.0 * time_constant))
    since = np.where(positive_half, u, u - 0.5) / frequency
    decay = np.exp(-since / time_constant)
    return np.where(positive_half, amplitude + (b0 - amplitude) * decay, -amplitude + (amplitude - b0) * decay)

"""Periodic drives of the applied field (numpy only): the switched-square signal and :class:`Waveparams`.

The simulator's waveforms (:mod:`magsoft_env.sim.waveforms`) and the gait cases share these
definitions; :func:`magsoft_env.sim.as_waveform` turns a :class:`Waveparams` into a simulator
waveform. Everything is SI: T, Hz, rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..units import MT
from ..validate import finite_number, nonnegative, positive
from .field import field_component

#: Drive shapes of :class:`Waveparams`.
WAVE_SHAPES = ("sine", "square")


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
    amplitude = finite_number("switched_square amplitude", amplitude)
    frequency = positive("switched_square frequency", frequency, unit="Hz")
    phase = finite_number("switched_square phase", phase, unit="rad")
    time_constant = nonnegative("switched_square time_constant", time_constant, unit="s")
    u = np.mod(frequency * t + phase / (2.0 * math.pi), 1.0)
    positive_half = u < 0.5
    if time_constant <= 0.0:
        return np.where(positive_half, amplitude, -amplitude)
    h = 0.5 / frequency
    b0 = -amplitude * math.tanh(h / (2.0 * time_constant))
    since = np.where(positive_half, u, u - 0.5) / frequency
    decay = np.exp(-since / time_constant)
    return np.where(positive_half, amplitude + (b0 - amplitude) * decay, -amplitude + (amplitude - b0) * decay)


@dataclass(frozen=True)
class Waveparams:
    """A periodic field, sinusoidal or switched.

    ``shape="sine"`` (the presets): ``B_x = amplitude_x sin(2 pi f t + phase)``,
    ``B_z = amplitude_z sin(2 pi f t)``.
    ``shape="square"``: each axis switched between its +- amplitude at the zero crossings of the
    same sines, through a coil with time constant ``coil_time`` (s; 0 = an ideal square; see
    :class:`magsoft_env.sim.SwitchedSquare`). The paper does not say which waveform drove its
    crawlers; docs/envs.md ("The drive waveform") measures what the choice changes.

    Attributes
    ----------
    amplitude_x, amplitude_z : float
        Amplitudes (T); signed.
    frequency : float
        Frequency f (Hz).
    phase : float
        Phase of B_x ahead of B_z (rad).
    shape : str
        ``"sine"`` or ``"square"``.
    coil_time : float
        First-order coil time constant (s) of the square drive; must be 0 for ``"sine"``.
    amplitude_y, phase_y : float
        A third axis (T, rad): ``B_y = amplitude_y sin(2 pi f t + phase_y)`` (square: switched at its zero
        crossings). Non-zero only for the 3D rod (``RodOptions(rod="cable")``); the planar rod refuses it.
    """

    amplitude_x: float
    amplitude_z: float
    frequency: float
    phase: float = 0.0
    shape: str = "sine"
    coil_time: float = 0.0
    amplitude_y: float = 0.0
    phase_y: float = 0.0

    def __post_init__(self):
        if not isinstance(self.shape, str) or self.shape not in WAVE_SHAPES:
            raise ValueError(f"Waveparams.shape must be one of {list(WAVE_SHAPES)}, got {self.shape!r}.")
        for name in ("amplitude_x", "amplitude_z", "amplitude_y"):
            object.__setattr__(self, name, field_component(f"Waveparams.{name}", getattr(self, name)))
        object.__setattr__(self, "phase_y", finite_number("Waveparams.phase_y", self.phase_y, unit="rad"))
        object.__setattr__(self, "frequency", positive("Waveparams.frequency", self.frequency, unit="Hz"))
        object.__setattr__(self, "phase", finite_number("Waveparams.phase", self.phase, unit="rad"))
        object.__setattr__(self, "coil_time", nonnegative("Waveparams.coil_time", self.coil_time, unit="s"))
        if self.shape == "sine" and self.coil_time != 0.0:
            raise ValueError(
                f"Waveparams.coil_time applies to shape='square' only (a coil only delays a sine), got "
                f"{self.coil_time!r} s with shape='sine'."
            )

    @classmethod
    def rotating(cls, magnitude: float, frequency: float, axis: str = "z") -> Waveparams:
        """A field of ``magnitude`` (T) turning right-handed about the world ``axis`` (``"x"``, ``"y"`` or
        ``"z"``) at ``frequency`` (Hz): about z ``(B cos wt, B sin wt, 0)`` (it turns a strip lying on the floor
        in place), about x ``(0, B cos wt, B sin wt)`` (a strip lying along x turns into the y-z plane and tumbles
        along y), about y ``(-B cos wt, 0, B sin wt)`` (planar: end over end along x). x and z have a y
        component: 3D rod only."""
        if axis not in ("x", "y", "z"):
            raise ValueError(f"axis must be 'x', 'y' or 'z', got {axis!r}.")
        b = field_component("magnitude", magnitude)
        if b < 0.0:
            raise ValueError(f"magnitude must be >= 0 T, got {magnitude!r}.")
        half = 0.5 * math.pi
        if axis == "z":
            return cls(amplitude_x=b, amplitude_z=0.0, frequency=frequency, phase=half, amplitude_y=b, phase_y=0.0)
        if axis == "x":
            return cls(amplitude_x=0.0, amplitude_z=b, frequency=frequency, amplitude_y=b, phase_y=half)
        return cls(amplitude_x=b, amplitude_z=b, frequency=frequency, phase=-half)

    @property
    def components(self) -> int:
        """2 (``B_x, B_z``), or 3 (``B_x, B_y, B_z``) with a y amplitude (a drive for the 3D rod only)."""
        return 3 if self.amplitude_y else 2

    def sample(self, t) -> np.ndarray:
        """Field (T) at times ``t`` (s), shape ``(n, 2)``: B_x, B_z; ``(n, 3)`` B_x, B_y, B_z with a y amplitude."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        if self.shape == "square":
            cols = [switched_square(t, self.amplitude_x, self.frequency, self.phase, self.coil_time),
                    switched_square(t, self.amplitude_z, self.frequency, 0.0, self.coil_time)]
            if self.amplitude_y:
                cols.insert(1, switched_square(t, self.amplitude_y, self.frequency, self.phase_y, self.coil_time))
            return np.stack(cols, axis=1)
        w = 2.0 * np.pi * self.frequency * t
        cols = [self.amplitude_x * np.sin(w + self.phase), self.amplitude_z * np.sin(w)]
        if self.amplitude_y:
            cols.insert(1, self.amplitude_y * np.sin(w + self.phase_y))
        return np.stack(cols, axis=1)

    def describe(self) -> str:
        """One line in mT, Hz and deg, e.g. ``"sine B_z 2 mT, 2 Hz"``."""
        parts = []
        if self.amplitude_x:
            other = self.amplitude_z or self.amplitude_y  # the phase is relative to the other axes
            ph = f" {math.degrees(self.phase):+.0f} deg" if self.phase and other else ""
            parts.append(f"B_x {self.amplitude_x / MT:+g}{ph}")
        if self.amplitude_y:
            ph = f" {math.degrees(self.phase_y):+.0f} deg" if self.phase_y else ""
            parts.append(f"B_y {self.amplitude_y / MT:+g}{ph}")
        if self.amplitude_z:
            parts.append(f"B_z {self.amplitude_z / MT:g}")
        coil = f" (coil {self.coil_time * 1e3:g} ms)" if self.coil_time else ""
        return f"{self.shape}{coil} " + ", ".join(parts) + f" mT, {self.frequency:g} Hz"

    @property
    def peak(self) -> tuple[float, float]:
        """Peak |B_x|, |B_z| (T)."""
        return (abs(self.amplitude_x), abs(self.amplitude_z))


__all__ = ["WAVE_SHAPES", "Waveparams", "switched_square"]

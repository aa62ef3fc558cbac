"""Applied-field waveforms B(t) = (B_x(t), B_z(t)) in tesla, as functions of time (s).

Every waveform is a frozen dataclass, callable as ``wf(t) -> (B_x, B_z)`` for a scalar time
and ``wf.sample(t)`` for an array of times (shape ``(n, 2)``). ``duration`` (s) is the
natural length of the waveform (``None``: unbounded, e.g. a sine); a :class:`Sequence`
plays parts one after another, each with its own clock starting at zero.

Examples
--------
>>> wf = Sequence((Ramp((0, 0), (0, 0.013), duration=0.5), Hold((0, 0.013), duration=1.0)))
>>> wf(0.25)
(0.0, 0.0065)
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from ..spec import MAX_FIELD, as_field
from ..spec.drive import Waveparams, switched_square
from ..spec.field import planar_field
from ..validate import finite_number, positive


def _pair(name: str, value) -> tuple[float, float]:
    f = planar_field(as_field(value, name), f"{name} (a waveform of the MuJoCo hinge-chain rod, (B_x, B_z))")
    return (f.Bx, f.Bz)


def _check_peak(name: str, peak: float) -> None:
    if peak > MAX_FIELD:
        raise ValueError(
            f"{name} peak field must be <= {MAX_FIELD:g} T, got {peak:.4g} T (fields are in tesla: 13 mT is 0.013)."
        )


class Waveform(ABC):
    """A field as a function of time. Subclasses implement :meth:`sample`."""

    duration: float | None = None

    @abstractmethod
    def sample(self, t) -> np.ndarray:
        """Field at times ``t`` (s), shape ``(n, 2)``: columns B_x, B_z (T)."""

    def __call__(self, t: float) -> tuple[float, float]:
        b = self.sample(np.array([float(t)]))[0]
        return (float(b[0]), float(b[1]))


@dataclass(frozen=True)
class Hold(Waveform):
    """A constant field ``field`` (T) held for ``duration`` (s; ``None``: for ever)."""

    field: tuple = (0.0, 0.0)
    duration: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "field", _pair("Hold.field", self.field))
        if self.duration is not None:
            object.__setattr__(self, "duration", positive("Hold.duration", self.duration, unit="s"))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        return np.tile(np.asarray(self.field), (t.size, 1))


@dataclass(frozen=True)
class Ramp(Waveform):
    """Linear ramp from ``start`` to ``end`` (pairs in T) over ``duration`` (s), then held."""

    start: tuple = (0.0, 0.0)
    end: tuple = (0.0, 0.0)
    duration: float = 1.0

    def __post_init__(self):
        object.__setattr__(self, "start", _pair("Ramp.start", self.start))
        object.__setattr__(self, "end", _pair("Ramp.end", self.end))
        object.__setattr__(self, "duration", positive("Ramp.duration", self.duration, unit="s"))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        u = np.clip(t / self.duration, 0.0, 1.0)[:, None]
        a, b = np.asarray(self.start), np.asarray(self.end)
        return a + (b - a) * u


@dataclass(frozen=True)
class PhaseShifted(Waveform):
    """Sinusoids on each axis with their own amplitude and phase:

    ``B_x = offset_x + amplitude_x sin(2 pi f t + phase_x)``,
    ``B_z = offset_z + amplitude_z sin(2 pi f t + phase_z)``.

    Amplitudes and offsets in T, ``frequency`` in Hz, phases in rad. A phase difference of
    pi/2 with equal amplitudes gives a rotating field.
    """

    amplitude_x: float = 0.0
    amplitude_z: float = 0.0
    frequency: float = 1.0
    phase_x: float = 0.0
    phase_z: float = 0.0
    offset: tuple = (0.0, 0.0)
    duration: float | None = None

    def __post_init__(self):
        for name in ("amplitude_x", "amplitude_z", "phase_x", "phase_z"):
            object.__setattr__(self, name, finite_number(f"{type(self).__name__}.{name}", getattr(self, name)))
        object.__setattr__(self, "frequency", positive(f"{type(self).__name__}.frequency", self.frequency, unit="Hz"))
        object.__setattr__(self, "offset", _pair(f"{type(self).__name__}.offset", self.offset))
        if self.duration is not None:
            object.__setattr__(self, "duration", positive(f"{type(self).__name__}.duration", self.duration, unit="s"))
        ox, oz = self.offset
        _check_peak(type(self).__name__, math.hypot(abs(ox) + abs(self.amplitude_x), abs(oz) + abs(self.amplitude_z)))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = 2.0 * np.pi * self.frequency * t
        out = np.empty((t.size, 2))
        out[:, 0] = self.offset[0] + self.amplitude_x * np.sin(w + self.phase_x)
        out[:, 1] = self.offset[1] + self.amplitude_z * np.sin(w + self.phase_z)
        return out


def Sine(amplitude, frequency: float, *, phase: float = 0.0, offset=(0.0, 0.0), duration=None) -> PhaseShifted:
    """``B(t) = offset + amplitude sin(2 pi f t + phase)``: ``amplitude`` a pair (B_x, B_z) in T."""
    ax, az = _pair("Sine.amplitude", amplitude)
    return PhaseShifted(ax, az, frequency, phase, phase, offset, duration)


@dataclass(frozen=True)
class Square(Waveform):
    """Square wave: ``offset + amplitude`` for the first ``duty`` fraction of each period
    (``1 / frequency`` s), ``offset - amplitude`` for the rest. Pairs in T."""

    amplitude: tuple = (0.0, 0.0)
    frequency: float = 1.0
    duty: float = 0.5
    offset: tuple = (0.0, 0.0)
    duration: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "amplitude", _pair("Square.amplitude", self.amplitude))
        object.__setattr__(self, "offset", _pair("Square.offset", self.offset))
        object.__setattr__(self, "frequency", positive("Square.frequency", self.frequency, unit="Hz"))
        d = finite_number("Square.duty", self.duty)
        if not 0.0 < d < 1.0:
            raise ValueError(f"Square.duty must lie in (0, 1), got {self.duty!r}.")
        object.__setattr__(self, "duty", d)
        if self.duration is not None:
            object.__setattr__(self, "duration", positive("Square.duration", self.duration, unit="s"))
        a, o = self.amplitude, self.offset
        _check_peak("Square", math.hypot(abs(o[0]) + abs(a[0]), abs(o[1]) + abs(a[1])))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        phase = np.mod(t * self.frequency, 1.0)
        sign = np.where(phase < self.duty, 1.0, -1.0)[:, None]
        return np.asarray(self.offset) + sign * np.asarray(self.amplitude)


@dataclass(frozen=True)
class SwitchedSquare(Waveform):
    """A switched (square) drive on each axis through a coil with a first-order time constant:

    ``B_x`` is driven towards ``+amplitude_x`` while ``sin(2 pi f t + phase_x) >= 0`` and towards
    ``-amplitude_x`` otherwise, ``B_z`` likewise with ``phase_z``; after each switch the field
    relaxes with ``time_constant`` (s; an RL coil's L / R; 0 = an ideal square). The signal is
    the periodic steady state, continuous from ``t = 0`` (see
    :func:`magsoft_env.spec.drive.switched_square`). Amplitudes in T, ``frequency`` in Hz, phases in rad.

    With ``time_constant = 0`` and equal phases this is :class:`Square` with duty 0.5; the
    phases allow a phase-shifted B_x as in :class:`PhaseShifted`.
    """

    amplitude_x: float = 0.0
    amplitude_z: float = 0.0
    frequency: float = 1.0
    phase_x: float = 0.0
    phase_z: float = 0.0
    time_constant: float = 0.0
    duration: float | None = None

    def __post_init__(self):
        n = type(self).__name__
        for name in ("amplitude_x", "amplitude_z", "phase_x", "phase_z"):
            object.__setattr__(self, name, finite_number(f"{n}.{name}", getattr(self, name)))
        object.__setattr__(self, "frequency", positive(f"{n}.frequency", self.frequency, unit="Hz"))
        tc = finite_number(f"{n}.time_constant", self.time_constant, unit="s")
        if tc < 0.0:
            raise ValueError(f"{n}.time_constant must be >= 0 s (0: an ideal square), got {self.time_constant!r}.")
        object.__setattr__(self, "time_constant", tc)
        if self.duration is not None:
            object.__setattr__(self, "duration", positive(f"{n}.duration", self.duration, unit="s"))
        _check_peak(n, math.hypot(self.amplitude_x, self.amplitude_z))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((t.size, 2))
        out[:, 0] = switched_square(t, self.amplitude_x, self.frequency, self.phase_x, self.time_constant)
        out[:, 1] = switched_square(t, self.amplitude_z, self.frequency, self.phase_z, self.time_constant)
        return out


@dataclass(frozen=True)
class Sequence(Waveform):
    """Parts played one after another; every part except the last needs a ``duration``.
    After the last part ends its final value is held."""

    parts: tuple = ()

    def __post_init__(self):
        parts = tuple(self.parts)
        if not parts:
            raise ValueError("Sequence.parts must contain at least one Waveform, got none.")
        for i, p in enumerate(parts):
            if not isinstance(p, Waveform):
                raise ValueError(f"Sequence.parts[{i}] must be a Waveform, got {type(p).__name__}.")
            if p.duration is None and i < len(parts) - 1:
                raise ValueError(
                    f"Sequence.parts[{i}] needs a finite duration (s): only the last part may be unbounded."
                )
        object.__setattr__(self, "parts", parts)

    @property
    def duration(self) -> float | None:  # type: ignore[override]
        if self.parts[-1].duration is None:
            return None
        return float(sum(p.duration for p in self.parts))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((t.size, 2))
        t0 = 0.0
        done = np.zeros(t.size, dtype=bool)
        for i, p in enumerate(self.parts):
            last = i == len(self.parts) - 1
            m = ~done if last else (~done & (t < t0 + p.duration))
            if np.any(m):
                out[m] = p.sample(t[m] - t0)
            done |= m
            if not last:
                t0 += p.duration
        return out


def as_waveform(value, name: str = "field") -> Waveform:
    """A :class:`Waveform`, a Field or a pair (B_x, B_z) in T (held constant), a callable
    ``t -> (B_x, B_z)``, or a :class:`~magsoft_env.spec.drive.Waveparams` (its
    :class:`PhaseShifted` sine or :class:`SwitchedSquare`, starting at t = 0)."""
    if isinstance(value, Waveform):
        return value
    if isinstance(value, Waveparams):
        w = value
        if w.shape == "square":
            return SwitchedSquare(w.amplitude_x, w.amplitude_z, w.frequency, w.phase, 0.0, w.coil_time)
        return PhaseShifted(w.amplitude_x, w.amplitude_z, w.frequency, w.phase, 0.0)
    if callable(value):
        return _Callable(value)
    return Hold(_pair(name, value))


@dataclass(frozen=True)
class _Callable(Waveform):
    func: object = None

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.array([_pair("waveform(t)", self.func(float(ti))) for ti in t])
        return out.reshape(t.size, 2)


__all__ = ["Hold", "PhaseShifted", "Ramp", "Sequence", "Sine", "Square", "SwitchedSquare", "Waveform", "as_waveform"]


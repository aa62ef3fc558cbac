"""Applied-field waveforms B(t) in tesla, as functions of time (s): planar ``(B_x(t), B_z(t))`` for every rod, and
three-axis ``(B_x, B_y, B_z)`` (:class:`Conical`, :func:`Rotating`, :class:`PhaseShifted` with ``amplitude_y``,
:class:`Hold` of a field with a y component) for the 3D rod (``RodOptions(rod="cable")``).

Every waveform is a frozen dataclass, callable as ``wf(t) -> (B_x, B_z)`` (three-axis: ``(B_x, B_y, B_z)``) for a
scalar time and ``wf.sample(t)`` for an array of times (shape ``(n, components)``, :attr:`Waveform.components`
2 or 3). ``duration`` (s) is the
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


def _field3(name: str, value) -> tuple[float, ...]:
    """A field (T) as ``(B_x, B_z)`` when its y component is 0, else ``(B_x, B_y, B_z)``."""
    f = as_field(value, name)
    return (f.Bx, f.Bz) if f.By == 0.0 else (f.Bx, f.By, f.Bz)


def lift3(samples: np.ndarray) -> np.ndarray:
    """Waveform samples as ``(n, 3)`` rows ``(B_x, B_y, B_z)``: planar rows ``(B_x, B_z)`` get ``B_y = 0``."""
    s = np.asarray(samples, dtype=float)
    if s.ndim != 2 or s.shape[1] not in (2, 3):
        raise ValueError(f"a waveform's samples must have shape (n, 2) or (n, 3), got {s.shape}.")
    if s.shape[1] == 3:
        return s
    out = np.zeros((s.shape[0], 3))
    out[:, 0], out[:, 2] = s[:, 0], s[:, 1]
    return out


def _unit(name: str, v) -> np.ndarray:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or not np.any(a):
        raise ValueError(f"{name} must be a finite non-zero 3-vector (x, y, z), got {v!r}.")
    return a / np.linalg.norm(a)


def _check_peak(name: str, peak: float) -> None:
    if peak > MAX_FIELD:
        raise ValueError(
            f"{name} peak field must be <= {MAX_FIELD:g} T, got {peak:.4g} T (fields are in tesla: 13 mT is 0.013)."
        )


class Waveform(ABC):
    """A field as a function of time. Subclasses implement :meth:`sample`."""

    duration: float | None = None

    @property
    def components(self) -> int:
        """Columns of :meth:`sample`: 2 (``B_x, B_z``, planar) or 3 (``B_x, B_y, B_z``)."""
        return 2

    @abstractmethod
    def sample(self, t) -> np.ndarray:
        """Field at times ``t`` (s), shape ``(n, 2)``: columns B_x, B_z (T); ``(n, 3)`` (B_x, B_y, B_z) for a
        three-axis waveform."""

    def __call__(self, t: float) -> tuple[float, ...]:
        b = self.sample(np.array([float(t)]))[0]
        return tuple(float(v) for v in b)


@dataclass(frozen=True)
class Hold(Waveform):
    """A constant field ``field`` (T) held for ``duration`` (s; ``None``: for ever): a pair ``(B_x, B_z)``, or a
    Field / triple with a y component (a three-axis waveform)."""

    field: tuple = (0.0, 0.0)
    duration: float | None = None

    @property
    def components(self) -> int:
        return len(self.field)

    def __post_init__(self):
        object.__setattr__(self, "field", _field3("Hold.field", self.field))
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
    ``B_z = offset_z + amplitude_z sin(2 pi f t + phase_z)``,
    and, three-axis when ``amplitude_y`` or the offset's y component is non-zero,
    ``B_y = offset_y + amplitude_y sin(2 pi f t + phase_y)``.

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
    amplitude_y: float = 0.0
    phase_y: float = 0.0

    @property
    def components(self) -> int:
        return 3 if self.amplitude_y or len(self.offset) == 3 else 2

    def __post_init__(self):
        for name in ("amplitude_x", "amplitude_z", "phase_x", "phase_z", "amplitude_y", "phase_y"):
            object.__setattr__(self, name, finite_number(f"{type(self).__name__}.{name}", getattr(self, name)))
        object.__setattr__(self, "frequency", positive(f"{type(self).__name__}.frequency", self.frequency, unit="Hz"))
        object.__setattr__(self, "offset", _field3(f"{type(self).__name__}.offset", self.offset))
        if self.duration is not None:
            object.__setattr__(self, "duration", positive(f"{type(self).__name__}.duration", self.duration, unit="s"))
        o = lift3(np.array([self.offset]))[0]
        amp = (self.amplitude_x, self.amplitude_y, self.amplitude_z)
        _check_peak(type(self).__name__, math.sqrt(sum((abs(a) + abs(b)) ** 2 for a, b in zip(o, amp, strict=True))))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        w = 2.0 * np.pi * self.frequency * t
        k = self.components  # (B_x, B_z) rows, or (B_x, B_y, B_z) with a y drive
        o = lift3(np.array([self.offset]))[0]
        out = np.empty((t.size, k))
        out[:, 0] = o[0] + self.amplitude_x * np.sin(w + self.phase_x)
        out[:, -1] = o[2] + self.amplitude_z * np.sin(w + self.phase_z)
        if k == 3:
            out[:, 1] = o[1] + self.amplitude_y * np.sin(w + self.phase_y)
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
    amplitude_y: float = 0.0
    phase_y: float = 0.0

    @property
    def components(self) -> int:
        return 3 if self.amplitude_y else 2

    def __post_init__(self):
        n = type(self).__name__
        for name in ("amplitude_x", "amplitude_z", "phase_x", "phase_z", "amplitude_y", "phase_y"):
            object.__setattr__(self, name, finite_number(f"{n}.{name}", getattr(self, name)))
        object.__setattr__(self, "frequency", positive(f"{n}.frequency", self.frequency, unit="Hz"))
        tc = finite_number(f"{n}.time_constant", self.time_constant, unit="s")
        if tc < 0.0:
            raise ValueError(f"{n}.time_constant must be >= 0 s (0: an ideal square), got {self.time_constant!r}.")
        object.__setattr__(self, "time_constant", tc)
        if self.duration is not None:
            object.__setattr__(self, "duration", positive(f"{n}.duration", self.duration, unit="s"))
        _check_peak(n, math.sqrt(self.amplitude_x**2 + self.amplitude_y**2 + self.amplitude_z**2))

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        out = np.empty((t.size, self.components))
        out[:, 0] = switched_square(t, self.amplitude_x, self.frequency, self.phase_x, self.time_constant)
        out[:, -1] = switched_square(t, self.amplitude_z, self.frequency, self.phase_z, self.time_constant)
        if self.amplitude_y:
            out[:, 1] = switched_square(t, self.amplitude_y, self.frequency, self.phase_y, self.time_constant)
        return out


@dataclass(frozen=True)
class Conical(Waveform):
    """A field of constant magnitude precessing about an axis on a cone (three-axis):

    ``B(t) = magnitude (cos(cone) a + sin(cone) (cos(2 pi f t + phase) e1 + sin(2 pi f t + phase) e2))``

    with ``a`` the unit ``axis``, ``e1`` the unit part of ``reference`` normal to it (default: the world axis
    least aligned with ``a``, x before y before z) and ``e2 = a x e1``: it turns right-handed about ``axis`` (a
    negative ``frequency`` turns it the other way). ``cone_angle`` (rad) from the axis: pi / 2 is a field rotating
    in the plane normal to the axis (:func:`Rotating`), small angles a precessing field that leans off a held one.
    ``magnitude`` in T, ``frequency`` in Hz. Samples are ``(n, 3)``; a component that the geometry makes zero is
    exactly zero (a field rotating about y has no y component).
    """

    magnitude: float = 0.0
    frequency: float = 1.0
    axis: tuple = (0.0, 0.0, 1.0)
    cone_angle: float = math.pi / 2
    phase: float = 0.0
    reference: tuple | None = None
    duration: float | None = None

    @property
    def components(self) -> int:
        return 3

    def __post_init__(self):
        n = type(self).__name__
        mag = finite_number(f"{n}.magnitude", self.magnitude, unit="T")
        if mag < 0.0:
            raise ValueError(f"{n}.magnitude must be >= 0 T, got {self.magnitude!r}.")
        _check_peak(n, mag)
        object.__setattr__(self, "magnitude", mag)
        f = finite_number(f"{n}.frequency", self.frequency, unit="Hz")
        if f == 0.0:
            raise ValueError(f"{n}.frequency must be non-zero (Hz; negative turns the other way), got 0.")
        object.__setattr__(self, "frequency", f)
        a = _unit(f"{n}.axis", self.axis)
        object.__setattr__(self, "axis", tuple(float(v) for v in a))
        object.__setattr__(self, "cone_angle", finite_number(f"{n}.cone_angle", self.cone_angle, unit="rad"))
        object.__setattr__(self, "phase", finite_number(f"{n}.phase", self.phase, unit="rad"))
        if self.reference is None:
            ref = np.eye(3)[int(np.argmin(np.abs(a)))]
        else:
            ref = _unit(f"{n}.reference", self.reference)
        e1 = ref - (ref @ a) * a
        if np.linalg.norm(e1) < 1e-9:
            raise ValueError(f"{n}.reference must not be parallel to the axis, got {self.reference!r}.")
        object.__setattr__(self, "reference", tuple(float(v) for v in ref))
        if self.duration is not None:
            object.__setattr__(self, "duration", positive(f"{n}.duration", self.duration, unit="s"))

    def basis(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(a, e1, e2)``: the unit axis and the two directions the field turns through (see the class)."""
        a = np.asarray(self.axis)
        ref = np.asarray(self.reference)
        e1 = ref - (ref @ a) * a
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(a, e1)
        # exact zeros where the geometry has them (a rotation about y stays in x-z to the last bit)
        e1[np.abs(e1) < 1e-15] = 0.0
        e2[np.abs(e2) < 1e-15] = 0.0
        return a, e1, e2

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        a, e1, e2 = self.basis()
        w = 2.0 * np.pi * self.frequency * t + self.phase
        ca = 0.0 if self.cone_angle == math.pi / 2 else math.cos(self.cone_angle)
        sa = math.sin(self.cone_angle)
        return self.magnitude * (ca * a[None, :] + sa * (np.cos(w)[:, None] * e1[None, :]
                                                          + np.sin(w)[:, None] * e2[None, :]))


#: The same waveform under the name the steering literature uses for it.
Precessing = Conical


def Rotating(magnitude: float, frequency: float, *, axis=(0.0, 0.0, 1.0), phase: float = 0.0, reference=None,
             duration=None) -> Conical:
    """A field of ``magnitude`` (T) rotating at ``frequency`` (Hz) about ``axis`` (right-handed), in the plane
    normal to it, from ``reference`` (see :class:`Conical`) at ``t = 0``: ``Conical`` with ``cone_angle = pi / 2``.
    About y (``axis=(0, 1, 0)``, from x) it is planar: ``(B cos wt, 0, -B sin wt)``."""
    return Conical(magnitude, frequency, axis, math.pi / 2, phase, reference, duration)





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

    @property
    def components(self) -> int:
        return max(p.components for p in self.parts)

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        k = self.components  # the widest part's: planar parts are lifted to (B_x, 0, B_z) beside a 3D one
        out = np.empty((t.size, k))
        t0 = 0.0
        done = np.zeros(t.size, dtype=bool)
        for i, p in enumerate(self.parts):
            last = i == len(self.parts) - 1
            m = ~done if last else (~done & (t < t0 + p.duration))
            if np.any(m):
                part = p.sample(t[m] - t0)
                out[m] = part if part.shape[1] == k else lift3(part)
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
            return SwitchedSquare(w.amplitude_x, w.amplitude_z, w.frequency, w.phase, 0.0, w.coil_time,
                                  amplitude_y=w.amplitude_y, phase_y=w.phase_y)
        return PhaseShifted(w.amplitude_x, w.amplitude_z, w.frequency, w.phase, 0.0, amplitude_y=w.amplitude_y,
                            phase_y=w.phase_y)
    if callable(value):
        return _Callable(value)
    return Hold(_field3(name, value))


@dataclass(frozen=True)
class _Callable(Waveform):
    """``t -> (B_x, B_z)`` or ``t -> (B_x, B_y, B_z)`` (a Field or a sequence, T); rows of ``(n, 3)`` when any has a
    y component."""

    func: object = None

    def sample(self, t):
        t = np.atleast_1d(np.asarray(t, dtype=float))
        rows = [_field3("waveform(t)", self.func(float(ti))) for ti in t]
        if any(len(r) == 3 for r in rows):
            return lift3(np.array([r if len(r) == 3 else (r[0], 0.0, r[1]) for r in rows]).reshape(t.size, 3))
        return np.array(rows).reshape(t.size, 2)


__all__ = ["Conical", "Hold", "PhaseShifted", "Precessing", "Ramp", "Rotating", "Sequence", "Sine", "Square",
           "SwitchedSquare", "Waveform", "as_waveform", "lift3"]


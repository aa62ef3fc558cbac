"""The hard-magnetic beam: geometry, material, volume-fraction and magnetization profiles."""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from ..validate import MAX_ANGLE, AngleRangeError, checked_replace, degrees_message, nonnegative, positive
from .field import as_field
from .material import MAX_VOLUME_FRACTION, Material
from .profiles import (
    DIRECTION_COMPONENTS,
    Constant,
    Direction,
    Function,
    PiecewiseConstant,
    PiecewiseLinear,
    Profile,
    Sampled,
    as_magnetization,
    as_profile,
)

_PROBE = 257  # samples used to check that the magnetization is finite
_PHI_PROBE = 16385  # samples used to check the range of a volume fraction given as a function
# magnetization profiles whose values are angles the caller typed (checked for degrees given as radians); a
# jig's tangent angle and a design family's profile may wind further and are bounded where they are made
_GIVEN_ANGLES = (Constant, PiecewiseConstant, PiecewiseLinear, Sampled, Function)

#: Largest length, width and thickness accepted (m). These robots are millimetres to centimetres long;
#: a size past a metre is almost surely in the wrong unit (mm given as m).
MAX_SIZE = 1.0
#: Smallest slenderness L/h accepted: a "beam" shorter than it is thick is a block, outside any beam theory.
MIN_SLENDERNESS = 1.0
#: Below this slenderness L/h the beam is accepted with a warning: the model (Euler-Bernoulli, no shear)
#: is accurate for slender beams only; shear adds about 0.9 (h/L)^2 of the bending deflection (4 % at L/h = 5).
SLENDER = 5.0
#: Relative size (of the sum) below which the Saint-Venant torsion series stops.
_TORSION_RTOL = 1e-16


@dataclass(frozen=True)
class Beam:
    """A slender rectangular beam of hard-magnetic composite.

    Parameters
    ----------
    length, width, thickness : float
        Reference length L, width w and thickness h (m), each in (0, 1] m. Planar bending is about the
        width axis, so ``I = w h^3 / 12``; the 3D rod also bends about the thickness axis
        (:attr:`second_moments`) and twists (:attr:`torsion_constant`). The beam must be slender:
        L/h >= 1 is required and L/h < 5 warns (the model neglects shear, which grows as (h/L)^2). In
        the planar model the width only scales A and I; a strip wider than it is long is a plate, up
        to 1/(1 - nu^2) = 4/3 stiffer than the beam model says, so it is not refused.
    material : Material
        Matrix and particle properties (paper values by default).
    volume_fraction : float, callable or Profile
        Particle volume fraction phi(s), in [0, 0.5].
    magnetization : float, callable, Profile, Direction or sequence of three
        Angle beta(s) (rad) of the remanent magnetization in the undeformed beam, measured
        from +x toward +z (planar). A callable takes s in metres. Or its direction in 3D:
        a :class:`~magsoft_env.spec.profiles.Direction`, or ``(axial, width, thickness)``, each a
        number, callable of s or Profile: the components along the undeformed strip (x), across its
        width (y) and through its thickness (z). Only the direction counts (normalized pointwise; the
        magnitude comes from the volume fraction and M_p); a zero vector anywhere is refused. The
        angle beta is the direction ``(cos beta, 0, sin beta)``.

    Examples
    --------
    >>> beam = Beam(length=25e-3, width=5e-3, thickness=1.13e-3, volume_fraction=0.2)
    >>> round(beam.nondimensional_groups((0, 13e-3))["Lambda"], 1)
    71.4
    """

    length: float
    width: float
    thickness: float
    material: Material = field(default_factory=Material)
    volume_fraction: float | Profile = 0.2
    magnetization: float | Profile | Direction = 0.0

    def __post_init__(self):
        for name in ("length", "width", "thickness"):
            v = positive(f"Beam.{name}", getattr(self, name), unit="m")
            if v > MAX_SIZE:
                raise ValueError(
                    f"Beam.{name} must lie in (0, {MAX_SIZE:g}] m, got {getattr(self, name)!r} "
                    f"(lengths are in metres: {v:g} mm is {v * 1e-3:g})."
                )
            object.__setattr__(self, name, v)
        ratio = self.length / self.thickness
        if ratio < MIN_SLENDERNESS:
            raise ValueError(
                f"Beam.thickness must not exceed Beam.length (slenderness L/h >= {MIN_SLENDERNESS:g}; a beam model "
                f"needs a beam much longer than it is thick), got L = {self.length!r} m, h = {self.thickness!r} m, "
                f"L/h = {ratio:.3g}. Are both in metres?"
            )
        if ratio < SLENDER:
            warnings.warn(
                f"Beam slenderness L/h = {ratio:.3g} is below {SLENDER:g}: the model neglects shear, which adds "
                f"about {90 / ratio**2:.0f} % to the bending deflection here; results are rough.",
                UserWarning, stacklevel=3,
            )
        if not isinstance(self.material, Material):
            raise ValueError(f"Beam.material must be a Material, got {self.material!r}.")
        phi = as_profile(self.volume_fraction, "Beam.volume_fraction")
        beta = as_magnetization(self.magnetization, "Beam.magnetization")
        phi.check_covers(self.length, "Beam.volume_fraction")
        beta.check_covers(self.length, "Beam.magnetization")
        object.__setattr__(self, "volume_fraction", phi)
        object.__setattr__(self, "magnetization", beta)
        phis = self._phi_probe(phi)
        if not np.all(np.isfinite(phis)):
            raise ValueError("Beam.volume_fraction must be finite along the beam; got non-finite values.")
        lo, hi = float(phis.min()), float(phis.max())
        if lo < 0.0 or hi > MAX_VOLUME_FRACTION:
            raise ValueError(
                f"Beam.volume_fraction must lie in [0, {MAX_VOLUME_FRACTION}] along the beam "
                f"(the modulus law diverges at 0.74), got values in [{lo:.4g}, {hi:.4g}]."
            )
        if isinstance(beta, Direction):
            self._check_direction(beta)
            return
        betas = _sample(beta, self._probe_points(_PROBE), self.length, "Beam.magnetization")
        if not np.all(np.isfinite(betas)):
            raise ValueError("Beam.magnetization must be a finite angle (rad) along the beam; got non-finite values.")
        largest = float(np.max(np.abs(betas)))
        if type(beta) in _GIVEN_ANGLES and largest > MAX_ANGLE:
            kind = type(beta).__name__
            got = repr(beta.value) if type(beta) is Constant else f"a {kind} with |beta| up to {largest:g}"
            raise AngleRangeError(degrees_message("Beam.magnetization", got, largest), largest)

    def _check_direction(self, direction: Direction) -> None:
        """Each component finite on the probe points, and the vector nowhere zero."""
        s = self._probe_points(_PROBE)
        cols = []
        for c, p in zip(DIRECTION_COMPONENTS, direction.components, strict=True):
            v = _sample(p, s, self.length, f"Beam.magnetization {c}")
            if not np.all(np.isfinite(v)):
                raise ValueError(f"Beam.magnetization {c} must be finite along the beam; got non-finite values.")
            cols.append(v)
        # the largest magnitude, not the norm: |(1e-200, 0, 0)| underflows to 0 but is a valid direction
        zero = np.flatnonzero(np.max(np.abs(np.stack(cols, axis=-1)), axis=-1) == 0.0)
        if zero.size:
            raise ValueError(
                f"Beam.magnetization (axial, width, thickness) must be a non-zero vector everywhere (it gives only "
                f"the direction), got (0, 0, 0) at s = {s[zero[0]] * 1e3:.6g} mm."
            )

    def _probe_points(self, n: int) -> np.ndarray:
        L = self.length
        bps = np.asarray(self.breakpoints(), dtype=float)
        eps = 1e-9 * L
        return np.unique(np.concatenate([np.linspace(0.0, L, n), bps, bps - eps, bps + eps]).clip(0.0, L))

    def _phi_probe(self, phi: Profile) -> np.ndarray:
        """Volume fractions that bound phi(s) on [0, L]: exact for constants, cells and knots, else a dense grid."""
        L = self.length
        if type(phi) is Constant:
            return np.array([phi.value])
        if type(phi) is PiecewiseConstant:
            return np.asarray(phi.levels, dtype=float)
        if type(phi) is PiecewiseLinear:
            knots = np.asarray(phi.s_knots)
            return np.concatenate([np.asarray(phi.knot_values)[knots <= L], phi.values(np.array([L]), L)])
        return _sample(phi, self._probe_points(_PHI_PROBE), L, "Beam.volume_fraction")

    # geometry -------------------------------------------------------------------------
    @property
    def area(self) -> float:
        """Cross-section area A = w h (m^2)."""
        return self.width * self.thickness

    @property
    def second_moment(self) -> float:
        """Second moment of area I = w h^3 / 12 (m^4)."""
        return self.width * self.thickness**3 / 12.0

    @property
    def second_moments(self) -> tuple[float, float]:
        """Second moments of area (I_w, I_s) = (w h^3 / 12, h w^3 / 12) (m^4): bending about the width axis
        (d1, the weak one of a strip lying flat) and about the thickness axis (d2)."""
        w, h = self.width, self.thickness
        return (w * h**3 / 12.0, h * w**3 / 12.0)

    @property
    def torsion_constant(self) -> float:
        """Saint-Venant torsion constant J of the w x h rectangle (m^4).

        With a = max(w, h) and b = min(w, h)::

            J = a b^3 [1/3 - (64 / pi^5) (b / a) sum_{n = 1, 3, 5, ...} tanh(n pi a / (2 b)) / n^5]

        summed over odd n while the terms stay above 1e-16 of the first one (n up to about 1600). A square gives
        0.1406 a^4; a thin strip a b^3 / 3 (1 - 0.630 b / a); the paper's 5 x 1.13 mm strip 2.062e-12 m^4.
        """
        a, b = max(self.width, self.thickness), min(self.width, self.thickness)
        n = np.arange(1.0, 2.0 * math.ceil(_TORSION_RTOL ** -0.2) + 3.0, 2.0)
        terms = np.tanh(n * math.pi * a / (2.0 * b)) / n**5
        terms = terms[terms >= _TORSION_RTOL * terms[0]]
        series = float(np.sum(terms[::-1]))  # smallest first
        return a * b**3 * (1.0 / 3.0 - 64.0 / math.pi**5 * (b / a) * series)

    @property
    def slenderness(self) -> float:
        """Aspect ratio l/h as the paper reports it."""
        return self.length / self.thickness

    # profiles along s ---------------------------------------------------------------------
    def breakpoints(self) -> tuple[float, ...]:
        """Interior arc lengths (m) where any profile is not smooth, sorted and merged."""
        pts = sorted(
            set(self.volume_fraction.breakpoints(self.length)) | set(self.magnetization.breakpoints(self.length))
        )
        merged: list[float] = []
        tol = 1e-9 * self.length
        for p in pts:
            if tol < p < self.length - tol and (not merged or p - merged[-1] > tol):
                merged.append(float(p))
        return tuple(merged)

    def spline_knots(self) -> tuple[float, ...]:
        """Interior spline knots (m) of the profiles (see :meth:`Profile.spline_knots`), sorted."""
        pts = set(self.volume_fraction.spline_knots(self.length)) | set(self.magnetization.spline_knots(self.length))
        return tuple(sorted(p for p in pts if 0.0 < p < self.length))

    def phi(self, s) -> np.ndarray:
        """Volume fraction phi(s); raises ValueError if any value sampled leaves [0, MAX_VOLUME_FRACTION].

        Construction checks phi on a dense grid; this check makes sure no value outside the range
        (a spike between the grid points) ever reaches the material laws."""
        s = np.asarray(s, dtype=float)
        v = self.volume_fraction.values(s, self.length)
        if np.size(v) and not (np.min(v) >= 0.0 and np.max(v) <= MAX_VOLUME_FRACTION):  # NaN fails too
            vv = np.asarray(v, dtype=float).ravel()
            i = int(np.flatnonzero(~((vv >= 0.0) & (vv <= MAX_VOLUME_FRACTION)))[0])
            si = np.broadcast_to(s, np.shape(v)).ravel()[i]
            raise ValueError(
                f"Beam.volume_fraction must lie in [0, {MAX_VOLUME_FRACTION}] along the beam (the modulus law "
                f"diverges at 0.74), got {float(vv[i])!r} at s = {si * 1e3:.6g} mm (between the points checked "
                "when the beam was made)."
            )
        return v

    @property
    def is_planar(self) -> bool:
        """True when the magnetization has no component across the width: an angle profile beta(s), or a
        :class:`~magsoft_env.spec.profiles.Direction` whose width component is identically zero."""
        m = self.magnetization
        return not (isinstance(m, Direction) and m.has_width)

    def require_planar(self, what: str) -> Beam:
        """This beam if :attr:`is_planar`, else a ValueError naming ``what`` (the planar part that would take it,
        e.g. "the MuJoCo hinge-chain rod")."""
        if not self.is_planar:
            raise ValueError(
                f"{what} is planar (x-z plane), but this beam's magnetization has a component across the width "
                f"({self.magnetization!r}). The 3D analytical model (solve_equilibrium) takes it."
            )
        return self

    def beta(self, s) -> np.ndarray:
        """Magnetization angle beta(s) (rad) from +x toward +z in the undeformed beam, at arc lengths ``s`` (m).

        For a :class:`~magsoft_env.spec.profiles.Direction` without a width component it is
        ``atan2(thickness, axial)``; with one, a ValueError (the planar model cannot take it)."""
        s = np.asarray(s, dtype=float)
        m = self.magnetization
        if not isinstance(m, Direction):
            return m.values(s, self.length)
        if m.has_width:
            raise ValueError("this beam's magnetization has a component across the width; the planar model "
                             "(x-z plane) cannot take it: use the 3D solver (Beam.magnetization_direction gives the "
                             "direction).")
        v = m.vectors(s, self.length)
        return np.arctan2(v[..., 2], v[..., 0])

    def magnetization_direction(self, s) -> np.ndarray:
        """Unit vectors of the remanent magnetization in the undeformed beam's frame (axial, width, thickness) at
        arc lengths ``s`` (m), shape (n, 3) (``s.shape + (3,)``); for an angle profile ``(cos beta, 0, sin beta)``."""
        s = np.asarray(s, dtype=float)
        m = self.magnetization
        if isinstance(m, Direction):
            return m.vectors(s, self.length)
        b = np.asarray(m.values(s, self.length), dtype=float)
        return np.stack([np.cos(b), np.zeros_like(b), np.sin(b)], axis=-1)

    def youngs_modulus(self, s) -> np.ndarray:
        return self.material.youngs_modulus(self.phi(s))

    def bending_stiffness(self, s) -> np.ndarray:
        """E(s) I (N m^2)."""
        return self.youngs_modulus(s) * self.second_moment

    def shear_modulus(self, s) -> np.ndarray:
        """G(s) = E(s) / (2 (1 + nu)) (Pa)."""
        return self.material.shear_modulus(self.phi(s))

    def stiffnesses(self, s) -> np.ndarray:
        """Stiffnesses of the 3D rod at arc lengths ``s`` (m), shape (n, 3) (``s.shape + (3,)``):
        ``[E I_w, E I_s, G J]`` (N m^2), in the material frame's order (d1 across the width, d2 through the
        thickness, d3 the tangent): bending about d1 (E I_w), about d2 (E I_s), and twisting (G J)."""
        phi = self.phi(s)
        E = np.asarray(self.material.youngs_modulus(phi), dtype=float)
        i_w, i_s = self.second_moments
        return np.stack([E * i_w, E * i_s, E / (2.0 * (1.0 + self.material.poisson_ratio)) * self.torsion_constant],
                        axis=-1)

    def axial_stiffness(self, s) -> np.ndarray:
        """E(s) A (N)."""
        return self.youngs_modulus(s) * self.area

    def remanence(self, s) -> np.ndarray:
        """B_r(s) (T)."""
        return self.material.remanence(self.phi(s))

    def moment_per_length(self, s) -> np.ndarray:
        """Magnitude of the magnetic moment per unit length, A B_r / mu0 (A m)."""
        return self.area * self.material.magnetization(self.phi(s))

    def mass_per_length(self, s) -> np.ndarray:
        """rho(s) A (kg/m)."""
        return self.material.density_at(self.phi(s)) * self.area

    def mass(self) -> float:
        s = np.linspace(0.0, self.length, 2001)
        return float(np.trapezoid(self.mass_per_length(s), s))

    # dimensionless groups ---------------------------------------------------------------
    def nondimensional_groups(self, field=(0.0, 0.0), *, gravity: float = 9.81) -> dict[str, float]:
        """Lambda = A M |B_a| L^2 / (E I) and G = rho A g L^3 / (E I), at the mean of each profile.

        Lambda is the paper's normalized field P for a uniform beam; |B_a| is the norm of all three
        components, ``alpha_deg`` the angle of the field's projection on the x-z plane (deg).
        """
        f = as_field(field)
        g = nonnegative("gravity", gravity, unit="m/s^2")
        s = np.linspace(0.0, self.length, 513)
        EI = float(np.mean(self.bending_stiffness(s)))
        AM = float(np.mean(self.moment_per_length(s)))
        rhoA = float(np.mean(self.mass_per_length(s)))
        L = self.length
        return {
            "Lambda": AM * f.magnitude * L**2 / EI,
            "G": rhoA * abs(g) * L**3 / EI,
            "alpha_deg": math.degrees(f.angle),
        }

    def replace(self, **changes) -> Beam:
        """A copy with some fields changed (validated again)."""
        return checked_replace(self, changes, "Beam.replace")


def _sample(profile: Profile, s: np.ndarray, length: float, name: str) -> np.ndarray:
    """``profile`` at ``s``, as a float array of the same shape; any failure is a ValueError naming ``name``."""
    try:
        v = profile.values(s, length)
    except ValueError as exc:
        msg = str(exc)
        raise ValueError(msg if name in msg else f"{name}: {msg}") from None
    except Exception as exc:  # a user function: any failure is bad input
        raise ValueError(f"{name} could not be evaluated along the beam: {type(exc).__name__}: {exc}") from None
    try:
        v = np.asarray(v, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must give one number per arc length s, got {type(v).__name__}.") from None
    if v.shape != s.shape:
        raise ValueError(f"{name} must give one number per arc length s: expected shape {s.shape}, got {v.shape}.")
    return v

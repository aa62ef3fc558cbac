"""The hard-magnetic beam: geometry, material, volume-fraction and magnetization profiles."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..validate import finite_number, positive
from .field import as_field
from .material import MAX_VOLUME_FRACTION, Material
from .profiles import Profile, as_profile

_PROBE = 257  # samples used to check a profile's range


@dataclass(frozen=True)
class Beam:
    """A slender rectangular beam of hard-magnetic composite.

    Parameters
    ----------
    length, width, thickness : float
        Reference length L, width w and thickness h (m). Bending is about the width axis,
        so ``I = w h^3 / 12``.
    material : Material
        Matrix and particle properties (paper values by default).
    volume_fraction : float, callable or Profile
        Particle volume fraction phi(s), in [0, 0.5].
    magnetization : float, callable or Profile
        Angle beta(s) (rad) of the remanent magnetization in the undeformed beam, measured
        from +x toward +z. A callable takes s in metres.

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
    magnetization: float | Profile = 0.0

    def __post_init__(self):
        for name in ("length", "width", "thickness"):
            object.__setattr__(self, name, positive(f"Beam.{name}", getattr(self, name), unit="m"))
        if not isinstance(self.material, Material):
            raise ValueError(f"Beam.material must be a Material, got {self.material!r}.")
        phi = as_profile(self.volume_fraction, "Beam.volume_fraction")
        beta = as_profile(self.magnetization, "Beam.magnetization")
        phi.check_covers(self.length, "Beam.volume_fraction")
        beta.check_covers(self.length, "Beam.magnetization")
        object.__setattr__(self, "volume_fraction", phi)
        object.__setattr__(self, "magnetization", beta)
        s = self._probe_points()
        phis = phi.values(s, self.length)
        if not np.all(np.isfinite(phis)):
            raise ValueError("Beam.volume_fraction must be finite along the beam; got non-finite values.")
        lo, hi = float(phis.min()), float(phis.max())
        if lo < 0.0 or hi > MAX_VOLUME_FRACTION:
            raise ValueError(
                f"Beam.volume_fraction must lie in [0, {MAX_VOLUME_FRACTION}] along the beam "
                f"(the modulus law diverges at 0.74), got values in [{lo:.4g}, {hi:.4g}]."
            )
        betas = beta.values(s, self.length)
        if not np.all(np.isfinite(betas)):
            raise ValueError("Beam.magnetization must be a finite angle (rad) along the beam; got non-finite values.")

    def _probe_points(self) -> np.ndarray:
        L = self.length
        bps = np.asarray(self.breakpoints(), dtype=float)
        eps = 1e-9 * L
        return np.unique(np.concatenate([np.linspace(0.0, L, _PROBE), bps - eps, bps + eps]).clip(0.0, L))

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

    def phi(self, s) -> np.ndarray:
        return self.volume_fraction.values(np.asarray(s, dtype=float), self.length)

    def beta(self, s) -> np.ndarray:
        return self.magnetization.values(np.asarray(s, dtype=float), self.length)

    def youngs_modulus(self, s) -> np.ndarray:
        return self.material.youngs_modulus(self.phi(s))

    def bending_stiffness(self, s) -> np.ndarray:
        """E(s) I (N m^2)."""
        return self.youngs_modulus(s) * self.second_moment

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
        """Lambda = A M B_a L^2 / (E I) and G = rho A g L^3 / (E I), at the mean of each profile.

        Lambda is the paper's normalized field P for a uniform beam.
        """
        f = as_field(field)
        g = finite_number("gravity", gravity, unit="m/s^2")
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
        import dataclasses

        return dataclasses.replace(self, **changes)

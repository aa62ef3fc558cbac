"""Material laws of an NdFeB-silicone composite (paper eqs. 2-3), in SI units."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..validate import finite_number, positive

MU0 = 4e-7 * math.pi  # vacuum permeability (T m / A)

#: Largest particle volume fraction accepted. The modulus law (eq. 3) diverges at
#: phi = 1/1.35 = 0.74; dense NdFeB-silicone composites stop being castable well below
#: that, and the paper's data span 0.05-0.3.
MAX_VOLUME_FRACTION = 0.5

NDFEB_DENSITY = 7600.0  # kg/m^3
ECOFLEX_DENSITY = 1070.0  # kg/m^3

#: Accepted ranges, wide around every elastomer composite and magnetic powder, narrow enough to
#: catch a unit mistake (MPa given as Pa, kA/m as A/m times 1e3, g/cm^3 as kg/m^3).
E0_RANGE = (1e2, 1e10)  # Pa: a soft gel to a stiff plastic; Ecoflex 00-10 is 6.2e4
MAX_PARTICLE_MAGNETIZATION = 2e6  # A/m: NdFeB saturates near 1.3e6, iron at 1.7e6
DENSITY_RANGE = (100.0, 30000.0)  # kg/m^3: a foam to tungsten; NdFeB is 7600
#: Accepted Poisson ratios: an isotropic elastomer has nu in [0, 0.5] (0.5: incompressible), and a particle-filled
#: silicone is not auxetic, so a negative value (allowed down to -1 for isotropic solids in general) is a mistake.
POISSON_RANGE = (0.0, 0.5)


@dataclass(frozen=True)
class Material:
    """A hard-magnetic composite: silicone matrix filled with magnetized NdFeB particles.

    Parameters
    ----------
    E0 : float
        Young's modulus of the unfilled elastomer (Pa). Paper: 0.062 MPa (Ecoflex 00-10).
    particle_magnetization : float
        Magnetization M_p of the particles (A/m); the composite's remanence is
        ``B_r = mu0 * M_p * phi`` (paper eq. 2, ``B_p^r = mu0 M_p``). Paper: 575 kA/m.
    density : float or callable
        Density of the composite (kg/m^3): a number used as is (the paper's 1940 for its
        phi = 0.2 beams), or a function of the volume fraction phi, for beams whose
        fraction varies. :meth:`rule_of_mixtures` builds the latter.
    poisson_ratio : float
        Poisson ratio nu of the composite (dimensionless), in [0, 0.5]: an isotropic elastomer lies in that
        range (0.5 is incompressible) and the filled silicone is not auxetic. Default 0.49 (silicone, nearly
        incompressible). It sets the shear modulus ``G = E / (2 (1 + nu))`` (torsion of the 3D rod).

    Notes
    -----
    Modulus law (paper eq. 3)::

        E(phi) = E0 * exp(2.5 phi / (1 - 1.35 phi))

    Examples
    --------
    >>> m = Material()
    >>> round(float(m.youngs_modulus(0.2)) / 1e6, 4)   # MPa
    0.123
    """

    E0: float = 0.062e6
    particle_magnetization: float = 575e3
    density: float | Callable[[float], float] = 1940.0
    poisson_ratio: float = 0.49

    def __post_init__(self):
        nu = finite_number("Material.poisson_ratio", self.poisson_ratio)
        if not POISSON_RANGE[0] <= nu <= POISSON_RANGE[1]:
            raise ValueError(
                f"Material.poisson_ratio must lie in [{POISSON_RANGE[0]:g}, {POISSON_RANGE[1]:g}] (dimensionless: an "
                f"isotropic elastomer, 0.5 incompressible; the composite is not auxetic), got {self.poisson_ratio!r}."
            )
        object.__setattr__(self, "poisson_ratio", nu)
        e0 = positive("Material.E0", self.E0, unit="Pa")
        if not E0_RANGE[0] <= e0 <= E0_RANGE[1]:
            raise ValueError(
                f"Material.E0 must lie in [{E0_RANGE[0]:g}, {E0_RANGE[1]:g}] Pa, got {self.E0!r} "
                "(E0 is in pascals: 0.062 MPa is 62000)."
            )
        object.__setattr__(self, "E0", e0)
        object.__setattr__(
            self,
            "particle_magnetization",
            finite_number("Material.particle_magnetization", self.particle_magnetization, unit="A/m"),
        )
        if self.particle_magnetization < 0:
            raise ValueError(
                "Material.particle_magnetization must be >= 0 (A/m); give the direction with the "
                f"magnetization profile instead. Got {self.particle_magnetization!r}."
            )
        if self.particle_magnetization > MAX_PARTICLE_MAGNETIZATION:
            raise ValueError(
                f"Material.particle_magnetization must lie in [0, {MAX_PARTICLE_MAGNETIZATION:g}] A/m (NdFeB "
                f"saturates near 1.3e6), got {self.particle_magnetization!r} (575 kA/m is 575e3)."
            )
        lo, hi = DENSITY_RANGE
        if callable(self.density):
            if isinstance(self.density, type):
                raise ValueError(
                    f"Material.density must be a number (kg/m^3) or a function of phi, got {self.density!r}."
                )
            try:
                probe = self.density_at(np.linspace(0.0, MAX_VOLUME_FRACTION, 11))
            except Exception as exc:  # a user function: any failure is bad input
                raise ValueError(
                    f"Material.density as a function of phi must return one number (kg/m^3) per phi, and raised "
                    f"{type(exc).__name__}: {exc}"
                ) from None
            if not np.all(np.isfinite(probe)) or np.any(probe <= 0):
                raise ValueError(
                    "Material.density as a function of phi must return finite positive values (kg/m^3) "
                    f"for phi in [0, {MAX_VOLUME_FRACTION}], got {probe!r}."
                )
            if np.any(probe < lo) or np.any(probe > hi):
                raise ValueError(
                    f"Material.density as a function of phi must return values in [{lo:g}, {hi:g}] kg/m^3 for phi in "
                    f"[0, {MAX_VOLUME_FRACTION}], got {probe.min():.4g} to {probe.max():.4g}."
                )
        else:
            rho = positive("Material.density", self.density, unit="kg/m^3")
            if not lo <= rho <= hi:
                raise ValueError(
                    f"Material.density must lie in [{lo:g}, {hi:g}] kg/m^3, got {self.density!r} "
                    "(densities are in kg/m^3: 1.94 g/cm^3 is 1940)."
                )
            object.__setattr__(self, "density", rho)

    @classmethod
    def rule_of_mixtures(
        cls,
        *,
        particle_density: float = NDFEB_DENSITY,
        matrix_density: float = ECOFLEX_DENSITY,
        E0: float = 0.062e6,
        particle_magnetization: float = 575e3,
        poisson_ratio: float = 0.49,
    ) -> Material:
        """Material whose density follows ``rho = phi rho_p + (1 - phi) rho_m`` (kg/m^3).

        With NdFeB (7600) and Ecoflex (1070) this gives 2376 kg/m^3 at phi = 0.2, not the
        paper's measured 1940 (porosity, or a lighter powder).
        """
        rp = positive("particle_density", particle_density, unit="kg/m^3")
        rm = positive("matrix_density", matrix_density, unit="kg/m^3")
        return cls(E0=E0, particle_magnetization=particle_magnetization, density=_Mixture(rp, rm),
                   poisson_ratio=poisson_ratio)

    def youngs_modulus(self, phi):
        """E(phi) in Pa (eq. 3); accepts scalars or arrays."""
        phi = np.asarray(phi, dtype=float)
        return self.E0 * np.exp(2.5 * phi / (1.0 - 1.35 * phi))

    def shear_modulus(self, phi):
        """Shear modulus G(phi) = E(phi) / (2 (1 + nu)) in Pa (isotropic); accepts scalars or arrays."""
        return self.youngs_modulus(phi) / (2.0 * (1.0 + self.poisson_ratio))

    def remanence(self, phi):
        """Remanent flux density B_r(phi) = mu0 M_p phi in T (eq. 2)."""
        return MU0 * self.particle_magnetization * np.asarray(phi, dtype=float)

    def magnetization(self, phi):
        """Composite magnetization M = B_r / mu0 in A/m."""
        return self.particle_magnetization * np.asarray(phi, dtype=float)

    def density_at(self, phi):
        """Density (kg/m^3) at volume fraction phi."""
        phi = np.asarray(phi, dtype=float)
        if callable(self.density):
            return np.asarray(np.vectorize(self.density, otypes=[float])(phi), dtype=float)
        return np.full_like(phi, self.density, dtype=float)


@dataclass(frozen=True)
class _Mixture:
    """Rule-of-mixtures density, a picklable callable of phi."""

    particle_density: float
    matrix_density: float

    def __call__(self, phi):
        return phi * self.particle_density + (1.0 - phi) * self.matrix_density

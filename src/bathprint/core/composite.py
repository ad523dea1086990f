"""Co-extrusion: the inner fluids, their pinch-off into inclusions, and composite properties.

Rules (each stated with its source; SI units):

- **Volume fraction.** Both fluids leave the needle together, so a segment's inner-fluid
  fraction is phi = (inner volume extruded) / (total volume extruded) over the interval in
  which that segment's material left the needle; the exit speed is (Q_o + Q_i) / (pi d^2/4).
- **Pinch-off** (Rayleigh 1878; Eggers 1997, Rev. Mod. Phys. 69, 865). The inner thread has
  radius r_i = r sqrt(phi) (plug flow of the core) and breaks at the fastest-growing
  Rayleigh-Plateau wavelength lambda = 2 pi r_i / 0.697 = 9.02 r_i (inviscid thread;
  the viscosity ratio, Tomotika 1935, shifts it by tens of percent and is neglected).
  Droplet volume pi r_i^2 lambda gives the equivalent diameter n = (6 r_i^2 lambda)^(1/3)
  = 3.78 r_i and the spacing m = lambda. When n exceeds ``slug_fraction`` x 2r the drops
  cannot fit: the inner fluid runs as slugs (a fluid core of radius r_i); between
  (slug_fraction - 0.2) x 2r and that, the two estimates below are blended linearly.
- **Stiffness.** Drops (n small): Mori-Tanaka estimate (Mori & Tanaka 1973; Benveniste 1987)
  for incompressible inclusions with no shear stiffness in an incompressible matrix,
  E_c / E_m = (1 - phi) / (1 + 2 phi / 3), for bending and stretching alike. Liquid drops
  larger than the elastocapillary length gamma / E (~10 um here) act as such inclusions
  (Style et al. 2015, Nat. Phys. 11, 82); gas at ~1 bar has a bulk modulus (~1e5 Pa) far
  above the gel's shear modulus, so bubbles are effectively incompressible too. Slugs: a
  tube with a fluid core, stretching 1 - phi and bending 1 - phi^2 (r_i^2 = phi r^2); as
  phi -> 1 gas slugs drop the bending stiffness by orders of magnitude.
- **Density.** The volume-weighted mean rho_c = (1 - phi) rho_gel + phi rho_inner (exact).
- **Curvature.** Inclusions off the axis by Delta = (r1 - r2) / r give a natural curvature
  kappa0 = C Delta phi / r, in the plane of the offset (phenomenological: linear in the
  offset and in the amount of inner fluid, zero for a centred inclusion; the paper shows
  the effect (Fig. 3B) but gives no law, so C is a scene parameter).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from bathprint.core.jit import KERNEL

RAYLEIGH_WAVELENGTH = 2.0 * math.pi / 0.697  # lambda / r_i
DROP_DIAMETER = (6.0 * RAYLEIGH_WAVELENGTH) ** (1.0 / 3.0)  # n / r_i


@dataclass(frozen=True)
class InnerFluid:
    """A fluid co-extruded inside the alginate."""

    name: str
    density_kg_m3: float
    viscosity_pa_s: float
    kind: str  # "liquid" or "gas"
    note: str


INNER_FLUIDS: dict[str, InnerFluid] = {
    "silicone_oil": InnerFluid(
        "silicone_oil",
        910.0,
        0.091,
        "liquid",
        "100 cSt silicone oil, the paper's Materials and Methods",
    ),
    "silicone_oil_972": InnerFluid(
        "silicone_oil_972", 972.0, 0.0972, "liquid", "the 972 kg/m^3 variant of the Fig. 3C caption"
    ),
    "nitrogen": InnerFluid("nitrogen", 1.16, 1.76e-5, "gas", "N2 at 23 C and 1 bar"),
    "ferrofluid": InnerFluid(
        "ferrofluid",
        1210.0,
        0.006,
        "liquid",
        "FF310-type; density set by inclusions.ferrofluid_density_kg_m3",
    ),
}


@njit(**KERNEL)
def stiffness_factors(phi: float, slug_fraction: float) -> tuple[float, float, float, float]:
    """(bend factor, stretch factor, drop diameter / r, spacing / r) for inner fraction phi."""
    if phi <= 0.0:
        return 1.0, 1.0, 0.0, 0.0
    ri = math.sqrt(phi)  # in units of r
    n = DROP_DIAMETER * ri
    m = RAYLEIGH_WAVELENGTH * ri
    f_mt = (1.0 - phi) / (1.0 + 2.0 * phi / 3.0)
    # drops elongate into slugs as they approach the tube's width: blend linearly over
    # n / 2r in [slug_fraction - 0.2, slug_fraction] so the properties stay continuous
    w = min(max((0.5 * n - (slug_fraction - 0.2)) / 0.2, 0.0), 1.0)
    bend = (1.0 - w) * f_mt + w * (1.0 - phi * phi)
    stretch = (1.0 - w) * f_mt + w * (1.0 - phi)
    return bend, stretch, n, m


def composite_properties(
    phi: float,
    rho_gel: float,
    rho_inner: float,
    radius: float,
    offset: float = 0.0,
    curvature_coefficient: float = 0.0,
    slug_fraction: float = 0.8,
) -> dict[str, float]:
    """The rules above for one inner fraction (for reports, tables and tests)."""
    bend, stretch, n, m = stiffness_factors(phi, slug_fraction)
    return {
        "inner_volume_fraction": phi,
        "flow_ratio": 1.0 - 2.0 * phi,  # (Q_o - Q_i) / (Q_o + Q_i)
        "density_kg_m3": (1.0 - phi) * rho_gel + phi * rho_inner,
        "bend_stiffness_factor": bend,
        "stretch_stiffness_factor": stretch,
        "inclusion_size_m": n * radius,
        "inclusion_spacing_m": m * radius,
        "slugs": bool(n > 2.0 * slug_fraction),  # fully slugs (blended just below)
        "natural_curvature_1_m": curvature_coefficient * offset * phi / radius,
    }

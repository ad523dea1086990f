"""Gravity and buoyancy: net weight (rho - rho_bath(z)) A g per length, along -z.

The bath density is rho_top at the free surface (z = P_BATH_SURFACE_Z) and grows linearly
with depth at ``P_BATH_DENSITY_GRADIENT`` (kg/m^3 per m; zero for a uniform bath), which is
the density-gradient column of the paper's Fig. 3E. Above the surface is air: over one
filament radius the density ramps down to AIR_DENSITY, so a light filament floats at the
surface instead of rising forever. Each segment's rest volume is lumped half on each of
its nodes, so the weight is that of the material actually printed.
"""

from __future__ import annotations

import math

from numba import njit

from bathprint.core.effects._band import add_diag
from bathprint.core.jit import KERNEL
from bathprint.core.layout import MAT_DENSITY, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes

AIR_DENSITY = 1.2  # kg/m^3


@njit(**KERNEL, inline="always")
def bath_density(p, z: float, ramp: float = 0.0) -> tuple[float, float]:
    """Bath density (kg/m^3) at height z (m) and its z-derivative; ``ramp`` (m) is the
    width of the transition to air above the surface (0: no air, the bath goes on).
    ``p`` is the model's parameter record."""
    zs = p.bath_surface_z
    grad = p.bath_density_gradient
    rho = p.bath_density_top + grad * (zs - z)
    if ramp <= 0.0 or z <= zs:
        return rho, -grad
    top = p.bath_density_top
    if z >= zs + ramp:
        return AIR_DENSITY, 0.0
    f = (z - zs) / ramp
    return top + f * (AIR_DENSITY - top), (AIR_DENSITY - top) / ramp


@njit(**KERNEL)
def accumulate(model, rod, stage, out) -> float:
    """Add net weight (and its z-Jacobian); return the gravitational potential energy (J)."""
    p = model.params[0]
    pos, seg_rest, seg_mat = rod.pos, rod.seg_rest, rod.seg_mat
    force, band = out.force, out.band
    cx, do_jac = stage.cx, stage.jac
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    g = p.gravity
    grad = p.bath_density_gradient
    rho_top = p.bath_density_top
    zs = p.bath_surface_z
    energy = 0.0
    for j in range(n_seg):
        r = seg_mat[j, MAT_RADIUS]
        half_vol = 0.5 * math.pi * r * r * seg_rest[j]
        rho = seg_mat[j, MAT_DENSITY]
        for side in range(2):
            i = j + side
            z = pos[3 * i + 2]
            rho_b, drho_dz = bath_density(p, z, r)
            force[3 * i + 2] -= half_vol * g * (rho - rho_b)
            # potential g V [rho z - int rho_b dz], exact below the surface (reference z = 0)
            energy += half_vol * g * (rho * z - (rho_top * z + grad * (zs * z - 0.5 * z * z)))
            if do_jac and drho_dz != 0.0:
                add_diag(band, n_free, i, 2, -cx * half_vol * g * drho_dz)
    return energy

"""Floor: penalty contact with the container floor and regularised Coulomb friction.

A node of radius r whose centre is below z_floor + r is pushed up with N = k dl p
(p the penetration, k the contact stiffness in Pa, dl the node's rest Voronoi length),
smoothed over the first 0.02 r of penetration (N = k dl p^2 / (0.04 r) there) so that
force and stiffness switch on continuously and Newton does not cycle at contact.
Tangential friction opposes the sliding velocity: F = -mu_f N u / sqrt(|u|^2 + u_eps^2),
a smooth Coulomb law that keeps the implicit Jacobian finite at rest. Rope coiling on the
floor needs both.
"""

from __future__ import annotations

import math

from numba import njit

from bathprint.core.effects._band import add_block, add_diag
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes


@njit(**KERNEL, inline="always")
def friction_block(blk, mu_n: float, ux: float, uy: float, s: float) -> None:
    """-dF/du of the regularised friction F = -mu_n u / s (s = sqrt(|u|^2 + u_eps^2)) on the
    horizontal velocity u, into the 3x3 ``blk`` (z row and column zero)."""
    s3 = s * s * s
    u = (ux, uy)
    for a in range(3):
        for b in range(3):
            blk[a, b] = 0.0
    for a in range(2):
        for b in range(2):
            blk[a, b] = mu_n * ((1.0 if a == b else 0.0) / s - u[a] * u[b] / s3)


@kernel
def accumulate(model, rod, stage, out) -> float:
    """Add contact and friction forces (with Jacobian); return the contact energy (J)."""
    p = model.params[0]
    pos, vel, seg_rest, seg_mat = rod.pos, rod.vel, rod.seg_rest, rod.seg_mat
    force, band = out.force, out.band
    cx, cv, do_jac = stage.cx, stage.cv, stage.jac
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    zf = p.floor_z
    kf = p.floor_stiffness
    mu_f = p.friction_coefficient
    eps = p.friction_velocity
    blk = out.scratch.blk_a
    energy = 0.0
    for i in range(n_free):
        ja = i - 1 if i > 0 else i  # the node's segments (one at either end)
        jb = i if i < n_seg else i - 1
        r = 0.5 * (seg_mat[ja, MAT_RADIUS] + seg_mat[jb, MAT_RADIUS])
        dl = (0.5 * seg_rest[i] if i < n_seg else 0.0) + (0.5 * seg_rest[i - 1] if i > 0 else 0.0)
        depth = zf + r - pos[3 * i + 2]
        if depth <= 0.0:
            continue
        # C1 penalty: quadratic over the first `band_width` of penetration, linear beyond,
        # so the contact stiffness switches on continuously and Newton does not cycle
        width = 0.02 * r
        k_full = kf * dl
        if depth < width:
            normal = 0.5 * k_full * depth * depth / width
            kn = k_full * depth / width
            energy += k_full * depth * depth * depth / (6.0 * width)
        else:
            normal = k_full * (depth - 0.5 * width)
            kn = k_full
            energy += k_full * (0.5 * depth * depth - 0.5 * width * depth + width * width / 6.0)
        force[3 * i + 2] += normal
        if do_jac:
            add_diag(band, n_free, i, 2, cx * kn)
        if mu_f > 0.0:
            ux = vel[3 * i]
            uy = vel[3 * i + 1]
            s = math.sqrt(ux * ux + uy * uy + eps * eps)
            force[3 * i] -= mu_f * normal * ux / s
            force[3 * i + 1] -= mu_f * normal * uy / s
            if do_jac:
                friction_block(blk, mu_f * normal, ux, uy, s)
                # dF/dz through N: dN/dz = -kn  ->  -dF_a/dz = -mu_f kn u_a / s
                blk[0, 2] = -cx / cv * mu_f * kn * ux / s if cv != 0.0 else 0.0
                blk[1, 2] = -cx / cv * mu_f * kn * uy / s if cv != 0.0 else 0.0
                add_block(band, n_free, i, i, blk, cv)
    return energy

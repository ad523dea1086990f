"""Inertia: filament mass plus transverse added mass, F = -M a.

Per segment, lumped half on each node: M = (l0 A / 2) [rho I + C_a rho_bath (I - t t^T)],
the added mass of a cylinder moving across its axis (C_a = 1 for a circular section)
and none along it. The tangent's dependence of M is left out of the Jacobian (it is
O(a) and Newton still converges); the force itself is exact at the stage.
"""

from __future__ import annotations

import math

from bathprint.core.effects._band import add_block
from bathprint.core.effects.gravity import bath_density
from bathprint.core.jit import kernel
from bathprint.core.layout import MAT_DENSITY, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes


@kernel
def accumulate(model, rod, stage, out) -> float:
    """Add -M a (and ca * M); return the kinetic energy 1/2 v.M v (J)."""
    p = model.params[0]
    pos, vel, acc, seg_rest, seg_mat = rod.pos, rod.vel, rod.acc, rod.seg_rest, rod.seg_mat
    force, band = out.force, out.band
    ca, do_jac = stage.ca, stage.jac
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    c_a = p.added_mass_coefficient
    blk = out.scratch.blk_a
    kinetic = 0.0
    for j in range(n_seg):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        tt = (ex / length, ey / length, ez / length)
        r = seg_mat[j, MAT_RADIUS]
        half_vol = 0.5 * math.pi * r * r * seg_rest[j]
        rho = seg_mat[j, MAT_DENSITY]
        rho_b, _ = bath_density(p, 0.5 * (pos[3 * j + 2] + pos[3 * j + 5]), r)
        if not do_jac:  # force only, in scalars: M u = half_vol (rho u + c_a rho_b P u)
            m_full = half_vol * (rho + c_a * rho_b)
            m_axis = half_vol * c_a * rho_b  # removed along the tangent: no axial added mass
            for side in range(2):
                b = 3 * (j + side)
                ta = tt[0] * acc[b] + tt[1] * acc[b + 1] + tt[2] * acc[b + 2]
                tv = tt[0] * vel[b] + tt[1] * vel[b + 1] + tt[2] * vel[b + 2]
                vv = vel[b] * vel[b] + vel[b + 1] * vel[b + 1] + vel[b + 2] * vel[b + 2]
                for a in range(3):
                    force[b + a] -= m_full * acc[b + a] - m_axis * ta * tt[a]
                kinetic += 0.5 * (m_full * vv - m_axis * tv * tv)
            continue
        for a in range(3):
            for b in range(3):
                eye = 1.0 if a == b else 0.0
                blk[a, b] = half_vol * (rho * eye + c_a * rho_b * (eye - tt[a] * tt[b]))
        for side in range(2):
            i = j + side
            for a in range(3):
                ma = 0.0
                mv = 0.0
                for b in range(3):
                    ma += blk[a, b] * acc[3 * i + b]
                    mv += blk[a, b] * vel[3 * i + b]
                force[3 * i + a] -= ma
                kinetic += 0.5 * vel[3 * i + a] * mv
            if do_jac:
                add_block(band, n_free, i, i, blk, ca)
    return kinetic

"""Drag: local slender-body (resistive-force) drag of the bath on the filament.

``drag.model`` = ``cox`` or ``constant``: F = -mu_s (2 u_perp + u_par) per length, u the
velocity relative to the bath (which may flow uniformly). Edge-based and lumped: each
filament segment of current length l and tangent t gives each of its two nodes
-mu_s (l/2) (2 u - (u.t) t), so a straight rod translating at v feels exactly mu_s v L
along its axis and 2 mu_s v L across it. mu_s is constant or Cox's 2 pi mu / ln(L/r)
(chosen when the scene is compiled). The Jacobian includes the dependence on the
tangent and length, so Newton converges fast even when h v exceeds the node spacing.

``drag.model = "finite_re"``: each node's share of a segment is (l/2) F(u, t) with the
finite-Reynolds-number law of :mod:`._drag_laws` (normal drag from the cylinder drag curve
at the Reynolds number of the normal relative velocity on the segment's diameter, tangential
drag from the laminar axial boundary layer; bath viscosity and density from the scene, the
length scale L = ``drag.length_scale_mm``). It is nonlinear in the speed; its Jacobian is
exact (dF/du, and dF/dt chained through t = e/|e| and the length factor).

When the scene lists ``hydrodynamics`` this kernel is not called: that effect evaluates the
drag law itself, with its local slender-body window and the nonlocal flow
(:mod:`bathprint.core.effects.hydrodynamics`).
"""

from __future__ import annotations

import math

from numba import njit

from bathprint.core.effects._band import add_block
from bathprint.core.effects._drag_laws import law
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import DRAG_FINITE_RE, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes


@njit(**KERNEL, inline="always")
def segment_mu_s(p, radius: float) -> float:
    """mu_s (Pa s) of a segment of the given radius: the compiled one, or with the liquid
    effect (radii change) and Cox's law, 2 pi mu / ln(L/r) at that radius (ln >= 1)."""
    if p.liquid and p.drag_cox:
        return 2.0 * math.pi * p.bath_viscosity / max(math.log(p.drag_length / radius), 1.0)
    return p.mu_s


@njit(**KERNEL)
def accumulate(model, rod, stage, out) -> float:
    """Add drag forces (and -cv dF/dv - cx dF/dx); return the dissipation rate (W)."""
    p = model.params[0]
    if p.drag_model == DRAG_FINITE_RE:
        return _accumulate_finite_re(model, rod, stage, out)
    pos, vel = rod.pos, rod.vel
    force, band = out.force, out.band
    cx, cv, do_jac = stage.cx, stage.cv, stage.jac
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    mu_s = p.mu_s
    fx, fy, fz = p.bath_flow[0], p.bath_flow[1], p.bath_flow[2]
    blk_v = out.scratch.blk_a
    blk_x = out.scratch.blk_b
    power = 0.0
    for j in range(n_seg):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        tt = (ex / length, ey / length, ez / length)
        if p.liquid:
            mu_s = segment_mu_s(p, rod.seg_mat[j, MAT_RADIUS])
        half = 0.5 * mu_s * length
        if do_jac:
            for a in range(3):
                for b in range(3):
                    blk_v[a, b] = half * ((2.0 if a == b else 0.0) - tt[a] * tt[b])
        for side in range(2):
            i = j + side  # the tip's share is computed too (a reaction; the solver ignores it)
            u = (vel[3 * i] - fx, vel[3 * i + 1] - fy, vel[3 * i + 2] - fz)
            ut = u[0] * tt[0] + u[1] * tt[1] + u[2] * tt[2]
            for a in range(3):
                fa = -half * (2.0 * u[a] - ut * tt[a])
                force[3 * i + a] += fa
                power -= fa * u[a]
            if do_jac:
                add_block(band, n_free, i, i, blk_v, cv)
                # dF_i/de = -(mu_s/2) [(2u - (u.t) t) t^T - t (P u)^T - (u.t) P]
                pu = (u[0] - ut * tt[0], u[1] - ut * tt[1], u[2] - ut * tt[2])
                for a in range(3):
                    va = 2.0 * u[a] - ut * tt[a]
                    for b in range(3):
                        pab = (1.0 if a == b else 0.0) - tt[a] * tt[b]
                        blk_x[a, b] = 0.5 * mu_s * (va * tt[b] - tt[a] * pu[b] - ut * pab)
                # J += -cx dF_i/dx, with de/dx_{j+1} = I and de/dx_j = -I
                add_block(band, n_free, i, j + 1, blk_x, cx)
                add_block(band, n_free, i, j, blk_x, -cx)
    return power


@njit(**KERNEL, inline="always")
def add_law_share(
    out, n_free: int, i: int, j: int, half: float, tt, force3, du, dt, cx: float, cv: float
) -> None:
    """Node i's share (half = l/2) of segment j's law force F (``force3``, per length) and,
    given du = dF/du and dt = dF/dt, its Jacobian: -(l/2) dF/du (cv) at (i, i) and
    -dF_i/de = -(dF/dt (I - t t^T) + F t^T)/2 (cx) at (i, j+1), minus it at (i, j)."""
    blk = out.scratch.blk_a
    for a in range(3):
        for b in range(3):
            blk[a, b] = -half * du[a, b]
    add_block(out.band, n_free, i, i, blk, cv)
    for a in range(3):
        dtt = dt[a, 0] * tt[0] + dt[a, 1] * tt[1] + dt[a, 2] * tt[2]
        for b in range(3):
            blk[a, b] = -0.5 * (dt[a, b] - dtt * tt[b] + force3[a] * tt[b])
    add_block(out.band, n_free, i, j + 1, blk, cx)
    add_block(out.band, n_free, i, j, blk, -cx)


@kernel
def _accumulate_finite_re(model, rod, stage, out) -> float:
    """The finite_re law: each node gets (l/2) F(u, t) of each of its segments."""
    p = model.params[0]
    pos, vel, seg_mat = rod.pos, rod.vel, rod.seg_mat
    force = out.force
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    fx, fy, fz = p.bath_flow[0], p.bath_flow[1], p.bath_flow[2]
    mu, rho, length = p.bath_viscosity, p.bath_density_top, p.drag_length
    sc = out.scratch
    f3, du, dt = sc.law_force, sc.law_du, sc.law_dt
    power = 0.0
    for j in range(n_seg):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        seg_len = math.sqrt(ex * ex + ey * ey + ez * ez)
        tt = (ex / seg_len, ey / seg_len, ez / seg_len)
        half = 0.5 * seg_len
        diameter = 2.0 * seg_mat[j, MAT_RADIUS]
        for side in range(2):
            i = j + side  # the tip's share is computed too (a reaction; the solver ignores it)
            power += half * law(
                vel[3 * i] - fx,
                vel[3 * i + 1] - fy,
                vel[3 * i + 2] - fz,
                tt[0],
                tt[1],
                tt[2],
                diameter,
                mu,
                rho,
                length,
                length,
                f3,
                du,
                dt,
            )
            for a in range(3):
                force[3 * i + a] += half * f3[a]
            if stage.jac:
                add_law_share(out, n_free, i, j, half, tt, f3, du, dt, stage.cx, stage.cv)
    return power

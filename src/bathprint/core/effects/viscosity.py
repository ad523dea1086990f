"""Viscosity: the viscous stress of the alginate solution in the rod (a Kelvin-Voigt rod).

Where it leaves the needle the jet is a viscous liquid, and it stays one inside until the
gel has set; its extensional viscosity resists stretching and bending at the rates the drag
imposes. Viscous threads (Trouton 1906; Ribe 2004; Bergou et al. 2010, "Discrete viscous
threads") carry a stretching resistance eta_e A and a bending resistance eta_e I, eta_e =
Tr eta the extensional viscosity (Trouton ratio Tr = 3 for a Newtonian liquid). Here they
act beside the elastic stress, sigma = E eps + eta_e d(eps)/dt, from the Rayleigh
dissipation

    D = sum_j 1/2 (eta_e A_j / l0_j) (l0_j d(l_j/l0_j)/dt)^2 + sum_i 1/2 (eta_e I_i / dl_i) |w_i|^2,

F = -dD/dv. The first term is the rate of strain of each segment (the inlet segment's rest
length grows at the exit speed: its strain rate is dl/dt - (l/l0) dl0/dt, with the tip's
own motion, not the jet velocity it carries with inertia). The second is the co-rotational
rate of the curvature binormal kb of elasticity's bending stencil,
w = dkb/dt - omega x kb, omega = (t1 x dt1/dt + t2 x dt2/dt) / 2 the mean angular velocity
of the stencil's edges: a rotation in the stencil's plane costs nothing, a tumbling one
costs O(kb^2), and only a spin about the tangent (which a rod without a material frame
cannot tell from deformation) is resisted. A and I are the alginate's section outside a
concentric column of co-extruded inner fluid of volume fraction phi: A = pi r^2 (1 - phi),
I = pi r^4 (1 - phi^2) / 4. Strains are measured on the rest section and length (the law
is a small-strain one, as the elastic one is). The Jacobian is exact in the velocities;
in the positions it is exact for stretching and, for bending, central differences of each
stencil's force (twelve per stencil, two per coordinate, relative step 1e-6). Returns the
dissipation rate 2D (W), as drag does.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.effects._band import add_block
from bathprint.core.effects.elasticity import add_bend_hessian, add_stencil_force
from bathprint.core.extrusion import flow_rate
from bathprint.core.jit import KERNEL
from bathprint.core.layout import MAT_INNER_FRACTION, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes

FD_STEP = 1e-6  # relative step of the central differences of the bending x-Jacobian


@njit(**KERNEL, inline="always")
def _section(seg_mat: np.ndarray, j: int) -> tuple[float, float]:
    """(A, I) of segment j's alginate (m^2, m^4), outside its inner fluid column."""
    r = seg_mat[j, MAT_RADIUS]
    phi = seg_mat[j, MAT_INNER_FRACTION]
    return math.pi * r * r * (1.0 - phi), 0.25 * math.pi * r**4 * (1.0 - phi * phi)


@njit(**KERNEL)
def bend_rate_grad(
    e1: np.ndarray,
    e2: np.ndarray,
    u1: np.ndarray,
    u2: np.ndarray,
    k: float,
    grad: np.ndarray,
    jhat: np.ndarray,
) -> float:
    """The stencil's dissipation 1/2 k |w|^2 (W); its gradient k Jh^T w in the edge
    velocities (``grad``, 6) and Jh = dw/du (``jhat``, flat 3 x 6, row m at 6 m).

    w = Jh u with Jh_s = J_s + [kb]x [e_s]x / (2 |e_s|^2), J_s = dkb/de_s =
    (2/D) C_s - kb g_s^T / D (D = |e1||e2| + e1.e2, g_s = dD/de_s, C_1 = [-e2]x,
    C_2 = [e1]x), since -omega x kb = [kb]x omega and t x dt/dt = e x u / |e|^2."""
    l1 = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    l2 = math.sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2])
    inv_d = 1.0 / (l1 * l2 + e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2])
    kb = (
        2.0 * (e1[1] * e2[2] - e1[2] * e2[1]) * inv_d,
        2.0 * (e1[2] * e2[0] - e1[0] * e2[2]) * inv_d,
        2.0 * (e1[0] * e2[1] - e1[1] * e2[0]) * inv_d,
    )
    for s in range(2):
        e = e1 if s == 0 else e2
        o = e2 if s == 0 else e1
        ratio = l2 / l1 if s == 0 else l1 / l2
        sign = -2.0 * inv_d if s == 0 else 2.0 * inv_d  # C_1 = -[e2]x, C_2 = [e1]x
        half_inv_l2 = 0.5 / (e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        # [kb]x [e]x = e kb^T - (kb.e) I
        kbe = kb[0] * e[0] + kb[1] * e[1] + kb[2] * e[2]
        for m in range(3):
            for a in range(3):
                g_a = ratio * e[a] + o[a]
                cross = 0.0  # ([c]x)(m, a) = -eps_mab c_b, c = o (the other edge)
                if m == 0 and a == 1:
                    cross = -o[2]
                elif m == 0 and a == 2:
                    cross = o[1]
                elif m == 1 and a == 0:
                    cross = o[2]
                elif m == 1 and a == 2:
                    cross = -o[0]
                elif m == 2 and a == 0:
                    cross = -o[1]
                elif m == 2 and a == 1:
                    cross = o[0]
                rot = e[m] * kb[a] - (kbe if m == a else 0.0)
                jhat[6 * m + 3 * s + a] = sign * cross - kb[m] * g_a * inv_d + half_inv_l2 * rot
    w0 = 0.0
    w1 = 0.0
    w2 = 0.0
    for c in range(6):
        uc = u1[c] if c < 3 else u2[c - 3]
        w0 += jhat[c] * uc
        w1 += jhat[6 + c] * uc
        w2 += jhat[12 + c] * uc
    for c in range(6):
        grad[c] = k * (jhat[c] * w0 + jhat[6 + c] * w1 + jhat[12 + c] * w2)
    return 0.5 * k * (w0 * w0 + w1 * w1 + w2 * w2)


@njit(**KERNEL)
def accumulate(model, rod, stage, out) -> float:
    """Add the viscous forces of stretching and bending (and their Jacobian); return the
    dissipation rate (W)."""
    p = model.params[0]
    pos, vel, n_nodes, seg_rest, seg_mat = rod.pos, rod.vel, rod.n_nodes, rod.seg_rest, rod.seg_mat
    force, band = out.force, out.band
    cx, cv, do_jac = stage.cx, stage.cv, stage.jac
    n_free = free_nodes(n_nodes, p)
    n_seg = filament_segments(n_nodes, p)
    eta_e = p.trouton_ratio * p.solution_viscosity
    sc = out.scratch
    blk = sc.blk_a
    power = 0.0
    # the inlet segment (clamped: the last one) grows at the exit speed; with inertia the
    # tip and the ghost carry the jet's velocity along the needle direction d
    # (extrusion.set_boundary), which is not their motion: it is taken off their velocity
    inlet = n_seg - 1 if p.clamped else -1
    growth = 0.0
    carried = 0.0
    d_hat = sc.edges[2]
    for a in range(3):
        d_hat[a] = 0.0
    if p.clamped:
        qo, qi = flow_rate(model.flow, stage.t)
        growth = (qo + qi) / p.needle_area
        carried = growth if p.inertial else 0.0
        tip = 3 * (n_nodes - 2)
        dn = 0.0
        for a in range(3):
            d_hat[a] = pos[tip + a] - pos[tip + 3 + a]
            dn += d_hat[a] * d_hat[a]
        for a in range(3):
            d_hat[a] /= math.sqrt(dn)
    # --- stretching: tension (eta_e A / l0) l0 d(l/l0)/dt along each segment ---
    for j in range(n_seg):
        area, _ = _section(seg_mat, j)
        l0 = seg_rest[j]
        k = eta_e * area / l0
        e = (
            pos[3 * j + 3] - pos[3 * j],
            pos[3 * j + 4] - pos[3 * j + 1],
            pos[3 * j + 5] - pos[3 * j + 2],
        )
        u = (
            vel[3 * j + 3] - vel[3 * j],
            vel[3 * j + 4] - vel[3 * j + 1],
            vel[3 * j + 5] - vel[3 * j + 2],
        )
        shrink = 0.0  # (dl0/dt) / l0: the inlet's growth
        if j == inlet:
            u = (u[0] - carried * d_hat[0], u[1] - carried * d_hat[1], u[2] - carried * d_hat[2])
            shrink = growth / l0
        length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        tt = (e[0] / length, e[1] / length, e[2] / length)
        ut = tt[0] * u[0] + tt[1] * u[1] + tt[2] * u[2]  # dl/dt
        rate = ut - shrink * length  # l0 d(l/l0)/dt
        tension = k * rate
        power += tension * rate
        for a in range(3):
            force[3 * j + a] += tension * tt[a]
            force[3 * j + 3 + a] -= tension * tt[a]
        if do_jac:
            # F_j = k (t.u - shrink l) t = k (t.u) t - k shrink e: dF_j/du = k t t^T,
            # dF_j/de = k [t (P u)^T + (t.u) P] / l - k shrink I
            pu = (u[0] - ut * tt[0], u[1] - ut * tt[1], u[2] - ut * tt[2])
            for a in range(3):
                for b in range(3):
                    eye = 1.0 if a == b else 0.0
                    pab = eye - tt[a] * tt[b]
                    blk[a, b] = cv * k * tt[a] * tt[b] + cx * k * (
                        (tt[a] * pu[b] + ut * pab) / length - shrink * eye
                    )
            add_block(band, n_free, j, j, blk, 1.0)
            add_block(band, n_free, j + 1, j + 1, blk, 1.0)
            add_block(band, n_free, j, j + 1, blk, -1.0)
            add_block(band, n_free, j + 1, j, blk, -1.0)
    # --- bending: the co-rotational rate of the curvature binormal at nodes 1..n-2 ---
    e1 = sc.edges[0]
    e2 = sc.edges[1]
    u1 = sc.edge_rates[0]
    u2 = sc.edge_rates[1]
    grad = sc.bend_grad
    hess = sc.bend_hess
    work = sc.bend_work
    jhat = work[0:18]
    jtmp = work[18:36]
    gp = work[36:42]
    gm = work[42:48]
    for i in range(1, n_nodes - 1):
        ja = i - 1
        jb = i if i < n_seg else i - 1  # the ghost segment carries the inlet's material
        dl = 0.5 * (seg_rest[i - 1] + seg_rest[i])  # (as elasticity: the ghost has none)
        k = eta_e * 0.5 * (_section(seg_mat, ja)[1] + _section(seg_mat, jb)[1]) / dl
        for a in range(3):
            e1[a] = pos[3 * i + a] - pos[3 * i - 3 + a]
            e2[a] = pos[3 * i + 3 + a] - pos[3 * i + a]
            u1[a] = vel[3 * i + a] - vel[3 * i - 3 + a]
            u2[a] = vel[3 * i + 3 + a] - vel[3 * i + a]
            if i == inlet:  # e2 ends at the tip
                u2[a] -= carried * d_hat[a]
            elif i == inlet + 1:  # e1 ends at the tip (e2: tip to ghost, both carried)
                u1[a] -= carried * d_hat[a]
        power += 2.0 * bend_rate_grad(e1, e2, u1, u2, k, grad, jhat)
        add_stencil_force(force, i, grad)  # (the edge forces are -grad, as elasticity's)
        if not do_jac:
            continue
        # edge forces F = -grad: -dF/du = k Jh^T Jh (cv), -dF/de = d grad/de (cx, central
        # differences of the stencil's gradient, column by column)
        for r in range(6):
            for c in range(6):
                hess[r, c] = (
                    cv
                    * k
                    * (jhat[r] * jhat[c] + jhat[6 + r] * jhat[6 + c] + jhat[12 + r] * jhat[12 + c])
                )
        if cx != 0.0:
            for c in range(6):
                e = e1 if c < 3 else e2
                a = c % 3
                saved = e[a]
                h = FD_STEP * math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
                e[a] = saved + h
                bend_rate_grad(e1, e2, u1, u2, k, gp, jtmp)
                e[a] = saved - h
                bend_rate_grad(e1, e2, u1, u2, k, gm, jtmp)
                e[a] = saved
                for r in range(6):
                    hess[r, c] += cx * (gp[r] - gm[r]) / (2.0 * h)
        add_bend_hessian(band, n_free, i, hess, 1.0)
    return power

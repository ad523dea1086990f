"""Elasticity: stretching and bending of a twist-free discrete elastic rod.

Stretching, per segment j:  E_s = 1/2 (E A / l0) (l - l0)^2.
Bending, per interior node i (between segments i-1 and i):
    E_b = 1/2 (B / dl) |kb - dl kappa0|^2,  kb = 2 e1 x e2 / (|e1||e2| + e1.e2),
the discrete curvature binormal of discrete elastic rods (Bergou et al. 2008), with
B = f_B E pi r^4 / 4 averaged over the two segments (f_B, f_S: composite factors), dl
their mean rest length and kappa0
the natural curvature vector (1/m). Exact gradients and Hessians (no twist, so no
reference frame is needed); at the needle the ghost segment clamps the tangent.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.effects._band import add_block
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import (
    KL,
    MAT_BEND_FACTOR,
    MAT_KAPPA_X,
    MAT_RADIUS,
    MAT_STRETCH_FACTOR,
    MAT_YOUNGS_MODULUS,
)
from bathprint.core.topology import filament_segments, free_nodes


@njit(**KERNEL, inline="always")
def segment_bending_stiffness(seg_mat: np.ndarray, j: int) -> float:
    """B = f_B E pi r^4 / 4 of segment j (N m^2)."""
    r = seg_mat[j, MAT_RADIUS]
    return seg_mat[j, MAT_YOUNGS_MODULUS] * seg_mat[j, MAT_BEND_FACTOR] * math.pi * r**4 / 4.0


@njit(**KERNEL, inline="always")
def bend_energy_grad_hess(
    e1: np.ndarray,
    e2: np.ndarray,
    kbar: np.ndarray,
    k: float,
    grad: np.ndarray,
    hess: np.ndarray,
    sc: np.ndarray,
    want_hess: bool,
) -> float:
    """Energy 1/2 k |kb(e1, e2) - kbar|^2, its gradient (6) and Hessian (6x6) in (e1, e2).

    With D = |e1||e2| + e1.e2, w = kb - kbar, g_s = dD/de_s and C_s = d(e1 x e2)/de_s
    ([-e2]x, [e1]x): J_s = dkb/de_s = (2/D) C_s - kb g_s^T / D, gradient k J_s^T w and
    Hessian k (J_s^T J_q + sum_m w_m d2kb_m/de_s de_q). ``sc`` is scratch (>= 42 slots)."""
    a0 = e1[0]
    a1 = e1[1]
    a2 = e1[2]
    c0 = e2[0]
    c1 = e2[1]
    c2 = e2[2]
    l1 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    l2 = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    inv_d = 1.0 / (l1 * l2 + a0 * c0 + a1 * c1 + a2 * c2)
    # flat scratch: kb 0:3, w 3:6, g1 6:9, g2 9:12, cw1 12:15, cw2 15:18, t1 18:21, t2 21:24,
    # J1 24:33, J2 33:42 (row m, column a at 3 m + a)
    sc[0] = 2.0 * (a1 * c2 - a2 * c1) * inv_d
    sc[1] = 2.0 * (a2 * c0 - a0 * c2) * inv_d
    sc[2] = 2.0 * (a0 * c1 - a1 * c0) * inv_d
    for m in range(3):
        sc[3 + m] = sc[m] - kbar[m]
    w0 = sc[3]
    w1 = sc[4]
    w2 = sc[5]
    energy = 0.5 * k * (w0 * w0 + w1 * w1 + w2 * w2)
    wk = w0 * sc[0] + w1 * sc[1] + w2 * sc[2]
    r12 = l2 / l1
    r21 = l1 / l2
    for m in range(3):
        sc[6 + m] = r12 * e1[m] + e2[m]
        sc[9 + m] = r21 * e2[m] + e1[m]
        sc[18 + m] = e1[m] / l1
        sc[21 + m] = e2[m] / l2
    # C1^T w = e2 x w, C2^T w = w x e1
    sc[12] = c1 * w2 - c2 * w1
    sc[13] = c2 * w0 - c0 * w2
    sc[14] = c0 * w1 - c1 * w0
    sc[15] = w1 * a2 - w2 * a1
    sc[16] = w2 * a0 - w0 * a2
    sc[17] = w0 * a1 - w1 * a0
    s2 = 2.0 * inv_d
    for b in range(3):
        grad[b] = k * (s2 * sc[12 + b] - wk * inv_d * sc[6 + b])
        grad[3 + b] = k * (s2 * sc[15 + b] - wk * inv_d * sc[9 + b])
    if not want_hess:
        return energy
    # J1 = (2/D) [-e2]x - kb g1^T / D ;  J2 = (2/D) [e1]x - kb g2^T / D
    for m in range(3):
        for a in range(3):
            sc[24 + 3 * m + a] = -sc[m] * sc[6 + a] * inv_d
            sc[33 + 3 * m + a] = -sc[m] * sc[9 + a] * inv_d
    # [v]x: (0,1) = -v2, (0,2) = v1, (1,0) = v2, (1,2) = -v0, (2,0) = -v1, (2,1) = v0
    sc[24 + 1] += s2 * c2
    sc[24 + 2] -= s2 * c1
    sc[24 + 3] -= s2 * c2
    sc[24 + 5] += s2 * c0
    sc[24 + 6] += s2 * c1
    sc[24 + 7] -= s2 * c0
    sc[33 + 1] -= s2 * a2
    sc[33 + 2] += s2 * a1
    sc[33 + 3] += s2 * a2
    sc[33 + 5] -= s2 * a0
    sc[33 + 6] -= s2 * a1
    sc[33 + 7] += s2 * a0
    inv_d2 = inv_d * inv_d
    c_gg = 2.0 * inv_d2 * wk
    c_g = wk * inv_d
    for sq in range(3):
        s = 0 if sq < 2 else 1
        q = 0 if sq == 0 else 1
        js = 24 + 9 * s
        jq = 24 + 9 * q
        gs = 6 + 3 * s
        gq = 6 + 3 * q
        cs = 12 + 3 * s
        cq = 12 + 3 * q
        for a in range(3):
            for b in range(a if s == q else 0, 3):
                jj = (
                    sc[js + a] * sc[jq + b]
                    + sc[js + 3 + a] * sc[jq + 3 + b]
                    + sc[js + 6 + a] * sc[jq + 6 + b]
                )
                hw = -2.0 * inv_d2 * (sc[cs + a] * sc[gq + b] + sc[gs + a] * sc[cq + b])
                hw += c_gg * sc[gs + a] * sc[gq + b]
                delta = 1.0 if a == b else 0.0
                if sq == 0:
                    gsq = r12 * (delta - sc[18 + a] * sc[18 + b])
                elif sq == 2:
                    gsq = r21 * (delta - sc[21 + a] * sc[21 + b])
                else:
                    gsq = delta + sc[18 + a] * sc[21 + b]
                    # -(2/D) [w]x (a, b)
                    if a == 0 and b == 1:
                        hw += s2 * w2
                    elif a == 0 and b == 2:
                        hw -= s2 * w1
                    elif a == 1 and b == 0:
                        hw -= s2 * w2
                    elif a == 1 and b == 2:
                        hw += s2 * w0
                    elif a == 2 and b == 0:
                        hw += s2 * w1
                    elif a == 2 and b == 1:
                        hw -= s2 * w0
                hw -= c_g * gsq
                value = k * (jj + hw)
                hess[3 * s + a, 3 * q + b] = value
                hess[3 * q + b, 3 * s + a] = value
    return energy


@njit(**KERNEL, inline="always")
def add_stencil_force(force: np.ndarray, i: int, grad: np.ndarray) -> None:
    """Add -dE/dx of node i's bending stencil from ``grad`` = dE/d(e1, e2) (e1 = x_i -
    x_{i-1}, e2 = x_{i+1} - x_i): +g1 on node i-1, g2 - g1 on node i, -g2 on node i+1."""
    b3 = 3 * i
    for a in range(3):
        force[b3 - 3 + a] += grad[a]
        force[b3 + a] += grad[3 + a] - grad[a]
        force[b3 + 3 + a] -= grad[3 + a]


@njit(**KERNEL, inline="always")
def add_bend_hessian(band: np.ndarray, n_free: int, i: int, hess: np.ndarray, cx: float) -> None:
    """Add cx * d2E/dx2 of node i's bending stencil to ``band``, from the edge Hessian
    ``hess`` = [[H11, H12], [H21, H22]] (e1 = x_i - x_{i-1}, e2 = x_{i+1} - x_i): the node
    blocks are (i-1, i-1) = H11, (i-1, i) = H12 - H11, (i-1, i+1) = -H12,
    (i, i) = H11 - H12 - H21 + H22, (i, i+1) = H12 - H22, (i+1, i+1) = H22, and transposes.
    Prescribed nodes (>= n_free) are skipped."""
    for p in range(3):
        node_p = i - 1 + p
        if node_p >= n_free:
            continue
        for q in range(3):
            node_q = i - 1 + q
            if node_q >= n_free:
                continue
            for a in range(3):
                row = 3 * node_p + a
                off = 3 * node_q - row + KL
                for b in range(3):
                    h11 = hess[a, b]
                    h12 = hess[a, 3 + b]
                    h21 = hess[3 + a, b]
                    h22 = hess[3 + a, 3 + b]
                    if p == 0:
                        v = h11 if q == 0 else (h12 - h11 if q == 1 else -h12)
                    elif p == 1:
                        v = (
                            h21 - h11
                            if q == 0
                            else (h11 - h12 - h21 + h22 if q == 1 else h12 - h22)
                        )
                    else:
                        v = -h21 if q == 0 else (h21 - h22 if q == 1 else h22)
                    band[row, off + b] += cx * v


@kernel
def accumulate(model, rod, stage, out) -> float:
    """Add stretching and bending forces (and cx * Hessian); return the elastic energy (J)."""
    p = model.params[0]
    pos, n_nodes, seg_rest, seg_mat = rod.pos, rod.n_nodes, rod.seg_rest, rod.seg_mat
    force, band = out.force, out.band
    cx = stage.cx
    n_free = free_nodes(n_nodes, p)
    n_seg = filament_segments(n_nodes, p)
    do_jac = stage.jac and cx != 0.0  # elasticity has no velocity or acceleration dependence
    energy = 0.0
    sc = out.scratch
    blk = sc.blk_a
    # --- stretching ---
    for j in range(n_seg):
        l0 = seg_rest[j]
        r = seg_mat[j, MAT_RADIUS]
        ks = seg_mat[j, MAT_YOUNGS_MODULUS] * seg_mat[j, MAT_STRETCH_FACTOR] * math.pi * r * r / l0
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        tx, ty, tz = ex / length, ey / length, ez / length
        strain = length - l0
        energy += 0.5 * ks * strain * strain
        fmag = ks * strain  # tension
        force[3 * j] += fmag * tx
        force[3 * j + 1] += fmag * ty
        force[3 * j + 2] += fmag * tz
        force[3 * j + 3] -= fmag * tx
        force[3 * j + 4] -= fmag * ty
        force[3 * j + 5] -= fmag * tz
        if do_jac:
            tt = (tx, ty, tz)
            ratio = 1.0 - l0 / length
            for a in range(3):
                for b in range(3):
                    blk[a, b] = ks * ((1.0 - ratio) * tt[a] * tt[b] + (ratio if a == b else 0.0))
            add_block(band, n_free, j, j, blk, cx)
            add_block(band, n_free, j + 1, j + 1, blk, cx)
            add_block(band, n_free, j, j + 1, blk, -cx)
            add_block(band, n_free, j + 1, j, blk, -cx)
    # --- bending at nodes 1..n_nodes-2 (the last is the needle tip, clamped by the ghost) ---
    e1 = sc.edges[0]
    e2 = sc.edges[1]
    kbar = sc.edges[2]
    grad = sc.bend_grad
    hess = sc.bend_hess
    scratch = sc.bend_work
    for i in range(1, n_nodes - 1):
        ja = i - 1
        jb = i if i < n_seg else i - 1  # the ghost segment carries the inlet's material
        dl = 0.5 * (seg_rest[i - 1] + seg_rest[i])
        bend_a = segment_bending_stiffness(seg_mat, ja)
        bend = 0.5 * (bend_a + segment_bending_stiffness(seg_mat, jb))
        k = bend / dl
        for a in range(3):
            e1[a] = pos[3 * i + a] - pos[3 * i - 3 + a]
            e2[a] = pos[3 * i + 3 + a] - pos[3 * i + a]
            kbar[a] = 0.5 * dl * (seg_mat[ja, MAT_KAPPA_X + a] + seg_mat[jb, MAT_KAPPA_X + a])
        energy += bend_energy_grad_hess(e1, e2, kbar, k, grad, hess, scratch, do_jac)
        # e1 = x_i - x_{i-1}, e2 = x_{i+1} - x_i: forces and Hessian blocks by node
        add_stencil_force(force, i, grad)
        if do_jac:
            add_bend_hessian(band, n_free, i, hess, cx)
    return energy

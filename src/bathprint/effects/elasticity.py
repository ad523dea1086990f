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

from bathprint.effects._band import add_block
from bathprint.layout import (
    MAT_BEND_FACTOR,
    MAT_KAPPA_X,
    MAT_RADIUS,
    MAT_STRETCH_FACTOR,
    MAT_YOUNGS_MODULUS,
)
from bathprint.topology import filament_segments, free_nodes


@njit(cache=True, inline="always")
def _bending_stiffness(seg_mat: np.ndarray, j: int) -> float:
    r = seg_mat[j, MAT_RADIUS]
    return seg_mat[j, MAT_YOUNGS_MODULUS] * seg_mat[j, MAT_BEND_FACTOR] * math.pi * r**4 / 4.0


@njit(cache=True, inline="always")
def _cross_matrix(w0: float, w1: float, w2: float, out: np.ndarray) -> None:
    """out = [w]x, so that out @ u = w x u."""
    out[0, 0] = 0.0
    out[0, 1] = -w2
    out[0, 2] = w1
    out[1, 0] = w2
    out[1, 1] = 0.0
    out[1, 2] = -w0
    out[2, 0] = -w1
    out[2, 1] = w0
    out[2, 2] = 0.0


@njit(cache=True)
def bend_energy_grad_hess(
    e1: np.ndarray,
    e2: np.ndarray,
    kbar: np.ndarray,
    k: float,
    grad: np.ndarray,
    hess: np.ndarray,
    work: np.ndarray,
    want_hess: bool,
) -> float:
    """Energy 1/2 k |kb(e1, e2) - kbar|^2, its gradient (6) and Hessian (6x6) in (e1, e2)."""
    l1 = math.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2)
    l2 = math.sqrt(e2[0] ** 2 + e2[1] ** 2 + e2[2] ** 2)
    c0 = e1[1] * e2[2] - e1[2] * e2[1]
    c1 = e1[2] * e2[0] - e1[0] * e2[2]
    c2 = e1[0] * e2[1] - e1[1] * e2[0]
    dot = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2]
    D = l1 * l2 + dot
    kb = work[0:3]
    kb[0] = 2.0 * c0 / D
    kb[1] = 2.0 * c1 / D
    kb[2] = 2.0 * c2 / D
    w = work[3:6]
    for a in range(3):
        w[a] = kb[a] - kbar[a]
    energy = 0.5 * k * (w[0] ** 2 + w[1] ** 2 + w[2] ** 2)
    # g_a = dD/de_a ; C_a = dc/de_a ; J_a = dkb/de_a = (2/D) C_a - kb g_a^T / D
    g = work[6:12].reshape((2, 3))
    for a in range(3):
        g[0, a] = (l2 / l1) * e1[a] + e2[a]
        g[1, a] = (l1 / l2) * e2[a] + e1[a]
    C = work[12:30].reshape((2, 3, 3))
    _cross_matrix(-e2[0], -e2[1], -e2[2], C[0])
    _cross_matrix(e1[0], e1[1], e1[2], C[1])
    J = work[30:48].reshape((2, 3, 3))
    for s in range(2):
        for a in range(3):
            for b in range(3):
                J[s, a, b] = (2.0 / D) * C[s, a, b] - kb[a] * g[s, b] / D
    # gradient: k J_s^T w
    for s in range(2):
        for b in range(3):
            acc = 0.0
            for a in range(3):
                acc += J[s, a, b] * w[a]
            grad[3 * s + b] = k * acc
    if not want_hess:
        return energy
    # Hessian blocks: k [J_a^T J_b + Hw_ab]
    Ctw = work[48:54].reshape((2, 3))  # C_a^T w
    for s in range(2):
        for b in range(3):
            acc = 0.0
            for a in range(3):
                acc += C[s, a, b] * w[a]
            Ctw[s, b] = acc
    wk = w[0] * kb[0] + w[1] * kb[1] + w[2] * kb[2]
    W = work[54:63].reshape((3, 3))
    _cross_matrix(w[0], w[1], w[2], W)
    t1 = work[63:66]
    t2 = work[66:69]
    for a in range(3):
        t1[a] = e1[a] / l1
        t2[a] = e2[a] / l2
    inv_d = 1.0 / D
    inv_d2 = inv_d * inv_d
    for s in range(2):
        for q in range(2):
            for a in range(3):
                for b in range(3):
                    jj = 0.0
                    for m in range(3):
                        jj += J[s, m, a] * J[q, m, b]
                    hw = -2.0 * inv_d2 * (Ctw[s, a] * g[q, b] + g[s, a] * Ctw[q, b])
                    hw += 2.0 * inv_d2 * wk * g[s, a] * g[q, b]
                    # G_sq = d^2 D / de_s de_q
                    if s == 0 and q == 0:
                        gsq = (l2 / l1) * ((1.0 if a == b else 0.0) - t1[a] * t1[b])
                    elif s == 1 and q == 1:
                        gsq = (l1 / l2) * ((1.0 if a == b else 0.0) - t2[a] * t2[b])
                    elif s == 0:
                        gsq = (1.0 if a == b else 0.0) + t1[a] * t2[b]
                    else:
                        gsq = (1.0 if a == b else 0.0) + t2[a] * t1[b]
                    hw -= inv_d * wk * gsq
                    if s == 0 and q == 1:
                        hw -= 2.0 * inv_d * W[a, b]
                    elif s == 1 and q == 0:
                        hw += 2.0 * inv_d * W[a, b]
                    hess[3 * s + a, 3 * q + b] = k * (jj + hw)
    return energy


# node <- edge incidence for a bending stencil (nodes i-1, i, i+1; edges e1, e2)
_S = np.array([[-1.0, 0.0], [1.0, -1.0], [0.0, 1.0]])


@njit(cache=True)
def accumulate(
    pos, vel, acc, n_nodes, seg_rest, seg_mat, params, t, cx, cv, ca, force, band, work, do_jac
) -> float:
    """Add stretching and bending forces (and cx * Hessian); return the elastic energy (J)."""
    n_free = free_nodes(n_nodes, params)
    n_seg = filament_segments(n_nodes, params)
    do_jac = do_jac and cx != 0.0  # elasticity has no velocity or acceleration dependence
    energy = 0.0
    blk = work[100:109].reshape((3, 3))
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
    e1 = work[110:113]
    e2 = work[113:116]
    kbar = work[116:119]
    grad = work[120:126]
    hess = work[130:166].reshape((6, 6))
    scratch = work[200:300]
    for i in range(1, n_nodes - 1):
        ja = i - 1
        jb = i if i < n_seg else i - 1  # the ghost segment carries the inlet's material
        dl = 0.5 * (seg_rest[i - 1] + seg_rest[i])
        bend = 0.5 * (_bending_stiffness(seg_mat, ja) + _bending_stiffness(seg_mat, jb))
        k = bend / dl
        for a in range(3):
            e1[a] = pos[3 * i + a] - pos[3 * i - 3 + a]
            e2[a] = pos[3 * i + 3 + a] - pos[3 * i + a]
            kbar[a] = 0.5 * dl * (seg_mat[ja, MAT_KAPPA_X + a] + seg_mat[jb, MAT_KAPPA_X + a])
        energy += bend_energy_grad_hess(e1, e2, kbar, k, grad, hess, scratch, do_jac)
        for p in range(3):
            node = i - 1 + p
            for a in range(3):
                force[3 * node + a] -= _S[p, 0] * grad[a] + _S[p, 1] * grad[3 + a]
        if do_jac:
            for p in range(3):
                for q in range(3):
                    for a in range(3):
                        for b in range(3):
                            h = 0.0
                            for s in range(2):
                                if _S[p, s] == 0.0:
                                    continue
                                for u in range(2):
                                    if _S[q, u] != 0.0:
                                        h += _S[p, s] * _S[q, u] * hess[3 * s + a, 3 * u + b]
                            blk[a, b] = h
                    add_block(band, n_free, i - 1 + p, i - 1 + q, blk, cx)
    return energy

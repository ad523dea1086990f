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
    KL,
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


@njit(cache=True, inline="always")
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
    # the Hessian is symmetric: blocks (0, 0), (0, 1), (1, 1), upper triangles of the diagonal ones
    for sq in range(3):
        s = 0 if sq < 2 else 1
        q = 0 if sq == 0 else 1
        for a in range(3):
            for b in range(a if s == q else 0, 3):
                jj = J[s, 0, a] * J[q, 0, b] + J[s, 1, a] * J[q, 1, b] + J[s, 2, a] * J[q, 2, b]
                hw = -2.0 * inv_d2 * (Ctw[s, a] * g[q, b] + g[s, a] * Ctw[q, b])
                hw += 2.0 * inv_d2 * wk * g[s, a] * g[q, b]
                # G_sq = d^2 D / de_s de_q
                delta = 1.0 if a == b else 0.0
                if sq == 0:
                    gsq = (l2 / l1) * (delta - t1[a] * t1[b])
                elif sq == 2:
                    gsq = (l1 / l2) * (delta - t2[a] * t2[b])
                else:
                    gsq = delta + t1[a] * t2[b]
                    hw -= 2.0 * inv_d * W[a, b]
                hw -= inv_d * wk * gsq
                value = k * (jj + hw)
                hess[3 * s + a, 3 * q + b] = value
                hess[3 * q + b, 3 * s + a] = value
    return energy


@njit(cache=True, inline="always")
def _bend_force(pos: np.ndarray, i: int, kbar: np.ndarray, k: float, force: np.ndarray) -> float:
    """Bending force of node i's stencil (nodes i-1, i, i+1) added to ``force``; returns
    the energy. The gradient of :func:`bend_energy_grad_hess` in scalars:
    dE/de1 = k [(2/D) e2 x w - (kb.w / D) g1], dE/de2 = k [(2/D) w x e1 - (kb.w / D) g2],
    w = kb - kbar, g1 = (l2/l1) e1 + e2, g2 = (l1/l2) e2 + e1."""
    b = 3 * i
    a0 = pos[b] - pos[b - 3]
    a1 = pos[b + 1] - pos[b - 2]
    a2 = pos[b + 2] - pos[b - 1]
    c0 = pos[b + 3] - pos[b]
    c1 = pos[b + 4] - pos[b + 1]
    c2 = pos[b + 5] - pos[b + 2]
    l1 = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
    l2 = math.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    inv_d = 1.0 / (l1 * l2 + a0 * c0 + a1 * c1 + a2 * c2)
    w0 = 2.0 * (a1 * c2 - a2 * c1) * inv_d
    w1 = 2.0 * (a2 * c0 - a0 * c2) * inv_d
    w2 = 2.0 * (a0 * c1 - a1 * c0) * inv_d
    kw = w0 * w0 + w1 * w1 + w2 * w2  # kb.kb so far
    w0 -= kbar[0]
    w1 -= kbar[1]
    w2 -= kbar[2]
    kw -= (w0 + kbar[0]) * kbar[0] + (w1 + kbar[1]) * kbar[1] + (w2 + kbar[2]) * kbar[2]
    energy = 0.5 * k * (w0 * w0 + w1 * w1 + w2 * w2)
    s = 2.0 * k * inv_d
    q = k * kw * inv_d  # k (kb.w) / D
    r12 = l2 / l1
    r21 = l1 / l2
    # gradients with respect to the two edges
    g10 = s * (c1 * w2 - c2 * w1) - q * (r12 * a0 + c0)
    g11 = s * (c2 * w0 - c0 * w2) - q * (r12 * a1 + c1)
    g12 = s * (c0 * w1 - c1 * w0) - q * (r12 * a2 + c2)
    g20 = s * (w1 * a2 - w2 * a1) - q * (r21 * c0 + a0)
    g21 = s * (w2 * a0 - w0 * a2) - q * (r21 * c1 + a1)
    g22 = s * (w0 * a1 - w1 * a0) - q * (r21 * c2 + a2)
    # e1 = x_i - x_{i-1}, e2 = x_{i+1} - x_i: force = -dE/dx
    force[b - 3] += g10
    force[b - 2] += g11
    force[b - 1] += g12
    force[b] += g20 - g10
    force[b + 1] += g21 - g11
    force[b + 2] += g22 - g12
    force[b + 3] -= g20
    force[b + 4] -= g21
    force[b + 5] -= g22
    return energy


@njit(cache=True, inline="always")
def _add_bend_hessian(band: np.ndarray, n_free: int, i: int, hess: np.ndarray, cx: float) -> None:
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
        if not do_jac:  # residual only: the scalar form, no Hessian work
            energy += _bend_force(pos, i, kbar, k, force)
            continue
        energy += bend_energy_grad_hess(e1, e2, kbar, k, grad, hess, scratch, True)
        # e1 = x_i - x_{i-1}, e2 = x_{i+1} - x_i: forces and Hessian blocks by node
        b3 = 3 * i
        for a in range(3):
            force[b3 - 3 + a] += grad[a]
            force[b3 + a] += grad[3 + a] - grad[a]
            force[b3 + 3 + a] -= grad[3 + a]
        _add_bend_hessian(band, n_free, i, hess, cx)
    return energy

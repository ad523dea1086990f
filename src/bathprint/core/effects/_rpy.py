"""Rotne-Prager-Yamakawa kernels of the hydrodynamics effect (``hydrodynamics.kernel = "rpy"``).

Each node carries a blob of radius b (``hydrodynamics.rpy_radii`` x its radius) and the
force F_j = w_j f_j its share w_j of the filament pushes on the fluid. The RPY tensor (Rotne &
Prager 1969, J. Chem. Phys. 50, 4831; Yamakawa 1970, J. Chem. Phys. 53, 436), for unequal and
overlapping blobs as Zuk, Wajnryb, Mizerski & Szymczak (2014, J. Fluid Mech. 741, R5) give it,
is positive semi-definite for every configuration, which Lighthill's Stokeslet segments
(:mod:`._stokeslet`) are not. With R = |x_i - x_j|, B2 = b_i^2 + b_j^2:

* R > b_i + b_j:  8 pi mu M = [(1 + B2/(3R^2)) I + (1 - B2/R^2) RR] / R;
* |b_i - b_j| < R <= b_i + b_j:  6 pi mu b_i b_j M = [16 R^3 (b_i + b_j) - ((b_i - b_j)^2 +
  3 R^2)^2] / (32 R^3) I + 3 ((b_i - b_j)^2 - R^2)^2 / (32 R^3) RR;
* R <= |b_i - b_j|:  M = I / (6 pi mu max(b_i, b_j))

(RR the unit vector's outer product), continuous in R. The local drag law already holds the
filament within arclength a of a node (its window), so the flow at node i leaves out the
blobs' share of it:

    u_nl,i = g_i [sum_j g_j S_ij F_j - sum_{|s_j - s_i| < a} g_j S_ij F_i]
           = g_i [sum_{|s_j - s_i| >= a} g_j S_ij F_j
                  + sum_{0 < |s_j - s_i| < a} g_j S_ij (F_j - F_i)],

S the RPY tensor, g_i in [0, 1] each node's gate (:func:`rpy_gates`). The total mobility is
Xi^-1 + G S G - D', D' the block diagonal of the gated window sums: G S G is positive
semi-definite, and the gates keep each node's window mobility Xi_i^-1 above D'_i, so the total
is positive definite for any configuration. Xi_i is the law's resistance to the flow: Stokes'
(``drag.model = "cox"``), or the finite_re law linearised about the motion relative to the
bath (:func:`._drag_laws.oseen_law`: symmetric, and known before the flow is); with finite_re
each pair is screened by :func:`screening_factor`, which keeps S positive semi-definite
whatever the nodes' Oseen lengths. Where the Stokes window's mobility
exceeds the blobs' share with room (:func:`window_margin`, checked when the scene compiles)
the gates are 1; on a straight filament the window law is shifted by the RPY tensor's
difference from the Stokeslet beyond the window (:func:`window_shift`), so that far from the
window the flow is the Stokeslet's up to b^2 / R^2. Flat arrays pos[3 i + a]; SI units.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.effects._stokeslet import window_coefficients
from bathprint.core.jit import KERNEL

#: the smallest share of a node's window mobility its gate leaves beyond the blobs' share
GATE_MARGIN = 0.05


@njit(**KERNEL, inline="always")
def rpy_coefficients(dist: float, bi: float, bj: float):
    """(c_iso, c_rr) in 1/m with 8 pi mu M = c_iso I + c_rr RR at distance ``dist`` (m)
    between blobs of radii ``bi``, ``bj`` (m): Zuk et al. (2014)."""
    big = max(bi, bj)
    diff = abs(bi - bj)
    if dist > bi + bj:
        b2 = (bi * bi + bj * bj) / (dist * dist)
        return (1.0 + b2 / 3.0) / dist, (1.0 - b2) / dist
    if dist <= diff:
        return 4.0 / (3.0 * big), 0.0
    r3 = dist * dist * dist
    q = diff * diff + 3.0 * dist * dist
    c_iso = (16.0 * r3 * (bi + bj) - q * q) / (32.0 * r3)
    e = diff * diff - dist * dist
    c_rr = 3.0 * e * e / (32.0 * r3)
    scale = 4.0 / (3.0 * bi * bj)  # 8 pi mu / (6 pi mu bi bj)
    return scale * c_iso, scale * c_rr


@njit(**KERNEL, inline="always")
def screening_factor(dist: float, li: float, lj: float) -> float:
    """The factor (-) on the RPY tensor between blobs at distance ``dist`` (m) with Oseen
    lengths ``li``, ``lj`` (m; inf: not screened): Paciorek & Schervish's (2006,
    Environmetrics 17, 483) nonstationary exponential kernel in three dimensions,
    (l_i l_j / m^2)^(3/2) exp(-R / m), m^2 = (l_i^2 + l_j^2) / 2. Positive definite for any
    lengths, so the screened tensor (a Schur product) stays positive semi-definite; with equal
    lengths it is exp(-R / l), the slender_body kernel's screening; with unequal ones it also
    weakens the pair, by (2 q / (1 + q^2))^(3/2) at length ratio q, however long both are
    (so a node at rest relative to the bath, l = inf, is cut off from every moving one, and
    slow nodes of different speeds are not coupled as Stokes flow would couple them)."""
    big = max(li, lj)
    small = min(li, lj)
    if big <= 0.0:  # (both fully screened: a node's own blob only)
        return 1.0 if dist <= 0.0 else 0.0
    if small == big:
        return 1.0 if big == math.inf else math.exp(-dist / big)
    if big == math.inf:
        return 0.0
    q = small / big
    amp = 2.0 * q / (1.0 + q * q)
    return amp * math.sqrt(amp) * math.exp(-dist / (big * math.sqrt(0.5 * (1.0 + q * q))))


@njit(**KERNEL)
def rpy_flow(targets, target_s, n_targets, pos, node_s, n_src, force, blob, gate, screen,
             mu, a_cut, out_vel):  # fmt: skip
    """Velocities (m/s) at nodes 0..n_targets-1 (positions ``targets``, material arclengths
    ``target_s``, m) from the forces ``force`` (N, per node) of nodes 0..n_src-1 of the same
    filament at ``pos`` (m, arclengths ``node_s``; segment j joins nodes j and j + 1), the
    blobs' share of each target's window |s_j - s_i| < ``a_cut`` left out (see the module).
    ``blob``: each node's blob radius (m); ``gate``: each node's g_i (:func:`rpy_gates`);
    ``screen``: each node's Oseen length (m, inf: none; :func:`screening_factor`).
    Direct O(N M) sum into ``out_vel`` (overwritten); allocates nothing."""
    c = 1.0 / (8.0 * math.pi * mu)
    for i in range(n_targets):
        y0 = targets[3 * i]
        y1 = targets[3 * i + 1]
        y2 = targets[3 * i + 2]
        si = target_s[i]
        own0 = force[3 * i] if i < n_src else 0.0
        own1 = force[3 * i + 1] if i < n_src else 0.0
        own2 = force[3 * i + 2] if i < n_src else 0.0
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        for j in range(n_src):
            f0 = force[3 * j]
            f1 = force[3 * j + 1]
            f2 = force[3 * j + 2]
            if abs(node_s[j] - si) < a_cut:  # inside the window: only the difference
                if j == i:
                    continue
                f0 -= own0
                f1 -= own1
                f2 -= own2
            if f0 == 0.0 and f1 == 0.0 and f2 == 0.0:
                continue  # contributes exactly nothing
            r0 = y0 - pos[3 * j]
            r1 = y1 - pos[3 * j + 1]
            r2 = y2 - pos[3 * j + 2]
            dist = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            scale = gate[i] * gate[j] * screening_factor(dist, screen[i], screen[j])
            c_iso, c_rr = rpy_coefficients(dist, blob[i], blob[j])
            if dist > 0.0:
                rf = c_rr * (r0 * f0 + r1 * f1 + r2 * f2) / (dist * dist)
            else:
                rf = 0.0
            u0 += scale * (c_iso * f0 + rf * r0)
            u1 += scale * (c_iso * f1 + rf * r1)
            u2 += scale * (c_iso * f2 + rf * r2)
        out_vel[3 * i] = c * u0
        out_vel[3 * i + 1] = c * u1
        out_vel[3 * i + 2] = c * u2


@njit(**KERNEL, inline="always")
def _sym3_max_eig(a00, a01, a02, a11, a12, a22) -> float:
    """The largest eigenvalue of a symmetric 3x3 matrix (Smith 1961, Commun. ACM 4, 168)."""
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    q = (a00 + a11 + a22) / 3.0
    b00, b11, b22 = a00 - q, a11 - q, a22 - q
    p2 = b00 * b00 + b11 * b11 + b22 * b22 + 2.0 * p1
    if p2 <= 0.0:
        return q
    pp = math.sqrt(p2 / 6.0)
    det = (
        b00 * (b11 * b22 - a12 * a12)
        - a01 * (a01 * b22 - a12 * a02)
        + a02 * (a01 * a12 - b11 * a02)
    )
    half = det / (2.0 * pp * pp * pp)
    phi = math.acos(min(max(half, -1.0), 1.0)) / 3.0
    return q + 2.0 * pp * math.cos(phi)


@njit(**KERNEL)
def rpy_gates(pos, node_s, n_src, blob, resist, screen, a_cut, mu, gate) -> None:
    """Each node's gate g_i = min(1, (1 - GATE_MARGIN) / lambda_max(R_i D_i)) into ``gate``:
    D_i the RPY sum over its window's blobs (its own included, screened as ``screen`` says,
    m/(N s)), R_i (``resist``, N s/m, its symmetric part) its drag law's resistance to the
    flow. With the blobs' forces and flows scaled by g (the flow G S G, a congruence: still
    positive semi-definite), a node's window keeps more mobility than the blobs' share of
    it: the total mobility stays positive definite where a bend brings the window's blobs
    closer than a straight line does, or a law resists more than Stokes' window. 1 wherever
    a straight window's margin holds (:func:`window_margin`). O(N x the window's nodes)."""
    c = 1.0 / (8.0 * math.pi * mu)
    for i in range(n_src):
        d00 = d11 = d22 = d01 = d02 = d12 = 0.0
        si = node_s[i]
        lo = hi = i  # the window's nodes are contiguous (arclength increases with index)
        while lo > 0 and si - node_s[lo - 1] < a_cut:
            lo -= 1
        while hi < n_src - 1 and node_s[hi + 1] - si < a_cut:
            hi += 1
        for j in range(lo, hi + 1):
            r0 = pos[3 * i] - pos[3 * j]
            r1 = pos[3 * i + 1] - pos[3 * j + 1]
            r2 = pos[3 * i + 2] - pos[3 * j + 2]
            dist = math.sqrt(r0 * r0 + r1 * r1 + r2 * r2)
            c_iso, c_rr = rpy_coefficients(dist, blob[i], blob[j])
            cs = c * screening_factor(dist, screen[i], screen[j])
            k = cs * c_rr / (dist * dist) if dist > 0.0 else 0.0
            d00 += cs * c_iso + k * r0 * r0
            d11 += cs * c_iso + k * r1 * r1
            d22 += cs * c_iso + k * r2 * r2
            d01 += k * r0 * r1
            d02 += k * r0 * r2
            d12 += k * r1 * r2
        rb = resist[i]
        # Cholesky R = L L^T of R's symmetric part, then L^T D L (symmetric, same spectrum)
        r00 = rb[0, 0]
        r01 = 0.5 * (rb[0, 1] + rb[1, 0])
        r02 = 0.5 * (rb[0, 2] + rb[2, 0])
        r11 = rb[1, 1]
        r12 = 0.5 * (rb[1, 2] + rb[2, 1])
        r22 = rb[2, 2]
        if r00 <= 0.0:
            gate[i] = 1.0  # no resistance (a node the law does not hold): nothing to guard
            continue
        l00 = math.sqrt(r00)
        l10 = r01 / l00
        l20 = r02 / l00
        l11 = math.sqrt(max(r11 - l10 * l10, 0.0))
        l21 = (r12 - l20 * l10) / l11 if l11 > 0.0 else 0.0
        l22 = math.sqrt(max(r22 - l20 * l20 - l21 * l21, 0.0))
        # M = D L (columns of L: (l00, l10, l20), (0, l11, l21), (0, 0, l22))
        m00 = d00 * l00 + d01 * l10 + d02 * l20
        m10 = d01 * l00 + d11 * l10 + d12 * l20
        m20 = d02 * l00 + d12 * l10 + d22 * l20
        m01 = d01 * l11 + d02 * l21
        m11 = d11 * l11 + d12 * l21
        m21 = d12 * l11 + d22 * l21
        m02 = d02 * l22
        m12 = d12 * l22
        m22 = d22 * l22
        # A = L^T M (rows of L^T: (l00, l10, l20), (0, l11, l21), (0, 0, l22))
        a00 = l00 * m00 + l10 * m10 + l20 * m20
        a01 = l00 * m01 + l10 * m11 + l20 * m21
        a02 = l00 * m02 + l10 * m12 + l20 * m22
        a11 = l11 * m11 + l21 * m21
        a12 = l11 * m12 + l21 * m22
        a22 = l22 * m22
        lam = _sym3_max_eig(a00, a01, a02, a11, a12, a22)
        gate[i] = min(1.0, (1.0 - GATE_MARGIN) / lam) if lam > 0.0 else 1.0


def window_shift(cutoff: float, blob: float) -> tuple[float, float]:
    """(shift_par, shift_perp): how much a full side of the window law's logarithm Lam grows
    so that, on a straight filament, the window plus the blobs beyond it have the Stokeslet
    line's mobility: the side's integral from the cutoff a (m) to infinity of the Stokeslet
    minus the RPY tensor of two blobs of radius ``blob`` (m), along (8 pi mu u = 2 Lam f:
    half of it) and across (8 pi mu u = (Lam + 2) f) the filament. Beyond R = 2b in closed
    form (2 b^2 / (3 x^2) along, -b^2 / (3 x^2) across), between a and 2b by 32-point
    Gauss-Legendre."""
    far = max(cutoff, 2.0 * blob)
    along = 2.0 * blob * blob / (3.0 * far * far)
    across = -blob * blob / (3.0 * far * far)
    if cutoff < far:
        x, w = np.polynomial.legendre.leggauss(32)
        half = 0.5 * (far - cutoff)
        for xk, wk in zip(x, w, strict=True):
            dist = cutoff + half * (xk + 1.0)
            c_iso, c_rr = rpy_coefficients(dist, blob, blob)
            along += wk * half * (2.0 / dist - c_iso - c_rr)
            across += wk * half * (1.0 / dist - c_iso)
    return 0.5 * float(along), float(across)


def window_margin(spacing: float, cutoff: float, radius: float, blob: float) -> float:
    """The smallest ratio 1 - lambda(Xi_i D_i) over the nodes of a long straight filament
    (interior and end windows) and the two directions (along and across it), with Xi_i the
    window law's zero-speed resistance (Lighthill's, shifted by :func:`window_shift`) times
    the node's length ``spacing`` and D_i the RPY sum over the window's blobs; positive: the
    total mobility is positive definite (see the module). Lengths in m."""
    mu = 1.0 / (8.0 * math.pi)  # 8 pi mu = 1
    shift_par, shift_perp = window_shift(cutoff, blob)
    worst = math.inf
    inside = 0  # the window's nodes on one side (as :func:`hydrodynamics._discrete_sides`)
    while (inside + 1) * spacing < cutoff:
        inside += 1
    side = (inside + 0.5) * spacing
    for end in (False, True):
        a_minus = 0.0 if end else side
        full = 1.0 if end else 2.0
        xi_par, xi_perp = window_coefficients(
            a_minus, side, radius, mu, full * shift_par, full * shift_perp
        )
        w = 0.5 * spacing if end else spacing
        d_par = d_perp = 4.0 / (3.0 * blob)  # the node's own blob
        for k in range(1, inside + 1):
            c_iso, c_rr = rpy_coefficients(k * spacing, blob, blob)
            copies = 1 if end else 2
            d_par += copies * (c_iso + c_rr)
            d_perp += copies * c_iso
        worst = min(worst, 1.0 - xi_par * w * d_par, 1.0 - xi_perp * w * d_perp)
    return worst

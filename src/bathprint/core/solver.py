"""The linear solves of Newton's method: banded LU, and GMRES for couplings off the band.

Forces of the local effects couple nodes at most two apart (bending), so the Newton matrix
is banded (8 sub- and super-diagonals in 3 unknowns per node) and its LU
(:mod:`bathprint.core.banded`, partial pivoting, in place in ``ws.band``) costs O(N). That
is the whole path while nothing couples distant nodes: :func:`solve` is then one banded
back-substitution, exactly as without this module.

Effects may add couplings between distant nodes (self-contact: 3x3 blocks between the nodes
of two segments about a coil turn apart, ``ws.cpl``). The Newton matrix is then
A = B + C, B its band and C the off-band blocks, and :func:`solve` runs restarted GMRES
(Saad & Schultz 1986) on A, right-preconditioned by the banded LU of B: the iterations
needed grow with the strength of C relative to B, not with N. Newton needs its updates only
to the accuracy of its own contraction (an inexact Newton method, Dembo, Eisenstat &
Steihaug 1982: local convergence for any constant forcing term below 1), so a solve stops at
a residual ``numerics.krylov_tolerance`` (default 0.05) of its right-hand side. One that
does not get there in ``KRYLOV_MAX_RESTARTS`` cycles returns False; the integrator treats
it as a Newton failure (a shorter step), never passes it on.

The hydrodynamics effect with its implicit coupling makes the Newton matrix dense: A = B +
R M_nl W^-1 J_other, whose second part :func:`matvec` applies matrix-free (one evaluation of
the nonlocal flow per GMRES iteration); the preconditioner is still the banded LU of B.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.banded import (
    add_blocks_matvec,
    band_lu,
    band_lu_diagonal,
    band_matvec,
    band_solve,
    band_solve_by_columns,
    band_solve_diagonal,
    merge_blocks,
)
from bathprint.core.effects.hydrodynamics import apply_nonlocal
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import C_KRYLOV_FAILURES, C_KRYLOV_ITERATIONS, KL, KU
from bathprint.core.records import COARSE_KL

KRYLOV_MAX_RESTARTS = 10  # restarts of KRYLOV_RESTART iterations each before a solve stalls
PIVOT_THRESHOLD = 0.1  # GMRES's LU swaps rows only where a diagonal pivot is this much smaller


@njit(**KERNEL, inline="always")
def off_band(ws) -> bool:
    """True when the last assembled Newton matrix has blocks off the band (or a nonlocal
    part: hydrodynamics with the implicit coupling)."""
    return ws.cpl.count[0] > 0 or ws.hydro.memory[0].linearized


@njit(**KERNEL)
def factor(ws, nd: int) -> bool:
    """Factorise the assembled Newton matrix's band (``ws.band``); False if singular.

    With couplings off the band the LU only preconditions GMRES, and it is taken without
    row swaps (:func:`~bathprint.core.banded.band_lu_diagonal`, half the work) unless a
    diagonal pivot falls below PIVOT_THRESHOLD of its column, when partial pivoting factors
    ``ws.band`` in place (with the axial coarse correction, its coarse matrix is factorised
    too). The LU without row swaps goes into ``krylov.lu``, which holds only the KL + KU + 1
    columns it uses: GMRES streams it in every iteration, and the fill-in columns that
    partial pivoting needs made a tall stack's back-substitution 1.2x (3x10^4 nodes) to 1.4x
    (10^5) slower per node (``python experiments/preconditioner/preconditioner.py --part blocks``).
    The off-band blocks are summed by node block into rows
    (:func:`~bathprint.core.banded.merge_blocks`) for GMRES's products. Without couplings
    off the band the LU solves Newton's equations directly, in place, with partial pivoting
    as always."""
    kr = ws.krylov
    if off_band(ws):
        merge_blocks(ws.cpl, nd // 3)
        a = kr.band_a  # the assembled entries only: the slots partial pivoting fills stay 0
        lu = kr.lu
        for i in range(nd):
            for k in range(KL + KU + 1):
                a[i, k] = ws.band[i, k]
                lu[i, k] = ws.band[i, k]
        if kr.coarse[0] > 0:
            _coarse_factor(ws, nd)
        status = band_lu_diagonal(lu, nd, ws.piv, kr.inv_diag, PIVOT_THRESHOLD)
        kr.diagonal[0] = 1 if status == 0 else 0
        if status >= 0:
            return status == 0
        # a row swap is due: partial pivoting, in ws.band (still as assembled)
    kr.diagonal[0] = 0
    return band_lu(ws.band, nd, KL, KU, ws.piv) == 0


@njit(**KERNEL, inline="always")
def _hat(i: int, spacing: int):
    """Node i's coarse nodes and weights (c, w_c, w_c+1): piecewise linear along the node
    index between coarse nodes every ``spacing`` nodes."""
    c = i // spacing
    f = (i - c * spacing) / spacing
    return c, 1.0 - f, f


@njit(**KERNEL)
def _coarse_add(cb, kc: int, ci: int, wi0: float, wi1: float, cj: int, wj0: float, wj1: float,
                value: float) -> None:  # fmt: skip
    """Add value w_i w_j into the coarse band (row storage, kl = ku = kc) at the coarse
    nodes of fine nodes i and j; pairs further apart than kc are left out."""
    for a in range(2):
        wa = wi0 if a == 0 else wi1
        if wa == 0.0:
            continue
        for b in range(2):
            wb = wj0 if b == 0 else wj1
            if wb == 0.0:
                continue
            r = ci + a
            c = cj + b
            if abs(c - r) <= kc:
                cb[r, c - r + kc] += wa * wb * value


@njit(**KERNEL)
def _coarse_factor(ws, nd: int) -> None:
    """The axial coarse matrix A_c = P^T A P (P: the z displacements, piecewise linear
    between every ``coarse``-th node) from the unfactored band and the off-band blocks, its
    half-bandwidth the widest coupling up to COARSE_KL coarse nodes, factorised in place;
    coarse_info holds its size and half-bandwidth (0 when singular: no correction)."""
    kr = ws.krylov
    spacing = kr.coarse[0]
    n = nd // 3
    nc = (n + spacing - 2) // spacing + 1  # coarse nodes 0..ceil((n - 1) / spacing)
    cpl = ws.cpl
    n_blocks = min(cpl.count[0], cpl.row.shape[0])
    kc = 2
    for k in range(n_blocks):
        d = abs(cpl.row[k] - cpl.col[k]) // spacing + 2
        if d > kc:
            kc = d
    kc = min(kc, COARSE_KL)
    cb = kr.coarse_band
    for r in range(nc):
        for k in range(3 * kc + 1):
            cb[r, k] = 0.0
    a = kr.band_a
    for i in range(n):
        ci, wi0, wi1 = _hat(i, spacing)
        for j in range(max(0, i - 2), min(n, i + 3)):
            value = a[3 * i + 2, 3 * (j - i) + KL]
            if value != 0.0:
                cj, wj0, wj1 = _hat(j, spacing)
                _coarse_add(cb, kc, ci, wi0, wi1, cj, wj0, wj1, value)
    for k in range(n_blocks):
        i = cpl.row[k]
        j = cpl.col[k]
        ci, wi0, wi1 = _hat(i, spacing)
        cj, wj0, wj1 = _hat(j, spacing)
        _coarse_add(cb, kc, ci, wi0, wi1, cj, wj0, wj1, cpl.block[k, 2, 2])
    ok = band_lu(cb, nc, kc, kc, kr.coarse_piv) == 0
    kr.coarse_info[0] = nc if ok else 0
    kr.coarse_info[1] = kc


@njit(**KERNEL)
def _coarse_correct(ws, nd: int, v: np.ndarray, z: np.ndarray, y: np.ndarray) -> None:
    """With y = A z for z = B^-1 v: z += P A_c^-1 P^T (v - y) and y += A (that correction),
    the axial coarse correction after the banded LU."""
    kr = ws.krylov
    nc = kr.coarse_info[0]
    if nc == 0:
        return
    spacing = kr.coarse[0]
    n = nd // 3
    xc = kr.coarse_x
    for c in range(nc):
        xc[c] = 0.0
    for i in range(n):  # restriction of the z residuals
        ci, w0, w1 = _hat(i, spacing)
        r = v[3 * i + 2] - y[3 * i + 2]
        xc[ci] += w0 * r
        if w1 != 0.0:
            xc[ci + 1] += w1 * r
    band_solve(kr.coarse_band, nc, kr.coarse_info[1], kr.coarse_info[1], kr.coarse_piv, xc)
    e = kr.e[0]  # its x and y stay zero (from the allocation): only z is written
    ae = kr.e[1]
    for i in range(n):  # prolongation
        ci, w0, w1 = _hat(i, spacing)
        ez = w0 * xc[ci] + (w1 * xc[ci + 1] if w1 != 0.0 else 0.0)
        e[3 * i + 2] = ez
        z[3 * i + 2] += ez
    matvec(ws, nd, e, ae)
    for k in range(nd):
        y[k] += ae[k]


@njit(**KERNEL)
def solve(ws, nd: int, rhs: np.ndarray, counters: np.ndarray, rtol: float) -> bool:
    """Overwrite ``rhs`` with the Newton matrix's inverse applied to it (with couplings off
    the band: to a residual ``rtol`` of the right-hand side); False if GMRES stalled."""
    if not off_band(ws):
        band_solve(ws.band, nd, KL, KU, ws.piv, rhs)
        return True
    return _gmres(ws, nd, rhs, counters, rtol)


@kernel
def damping_times(ws, nd: int, x: np.ndarray, y: np.ndarray) -> None:
    """y = D x with D the damping / mass matrix assembled into ``ws.band2`` and, off the
    band, ``ws.cpl_filter`` (contact's dashpot and friction between distant nodes)."""
    band_matvec(ws.band2, nd, KL, KU, x, y)
    add_blocks_matvec(ws.cpl_filter, x, y)


@kernel
def matvec(ws, nd: int, x: np.ndarray, y: np.ndarray) -> None:
    """y = A x, A = the unfactored band (``ws.krylov.band_a``) plus the off-band blocks (and
    the nonlocal part of hydrodynamics, :func:`bathprint.core.effects.hydrodynamics.
    apply_nonlocal`)."""
    band_matvec(ws.krylov.band_a, nd, KL, KU, x, y)
    add_blocks_matvec(ws.cpl, x, y)
    if ws.hydro.memory[0].linearized:  # the nonlocal flow's part, matrix-free
        apply_nonlocal(ws, nd, x, y)


@kernel
def _off_band_times(ws, nd: int, v: np.ndarray, z: np.ndarray, y: np.ndarray) -> None:
    """y = A z for z = M^-1 v: since M is the LU of the band B, B z = v (to the LU's
    round-off), and A z = v + (A - B) z needs only the blocks off the band and the nonlocal
    part."""
    for k in range(nd):
        y[k] = v[k]
    add_blocks_matvec(ws.cpl, z, y)
    if ws.hydro.memory[0].linearized:
        apply_nonlocal(ws, nd, z, y)


@njit(**KERNEL)
def _dot(a: np.ndarray, b: np.ndarray, nd: int) -> float:
    s = 0.0
    for k in range(nd):
        s += a[k] * b[k]
    return s


@kernel
def _gmres(ws, nd: int, b: np.ndarray, counters: np.ndarray, rtol: float) -> bool:
    """Restarted GMRES for A x = b, right-preconditioned by the banded LU:
        minimise |b - A M^-1 u| over the Krylov space, x = M^-1 u. The preconditioned vectors
        z_j = M^-1 v_j are kept (as flexible GMRES keeps them, Saad 1993), so that x = sum y_j z_j
        costs no further back-substitution. ``b`` is overwritten by x. The back-substitutions go
    by columns, through U's KU super-diagonals where the LU took no row swaps
    (:func:`~bathprint.core.banded.band_solve_diagonal`), else through its KL + KU
    (:func:`~bathprint.core.banded.band_solve_by_columns`)."""
    kr = ws.krylov
    basis = kr.basis
    zbasis = kr.zbasis
    hess = kr.hess
    g = kr.small[0]
    cs = kr.small[1]
    sn = kr.small[2]
    y = kr.small[3]
    x = kr.z
    m = hess.shape[1]
    beta0 = math.sqrt(_dot(b, b, nd))
    for k in range(nd):
        x[k] = 0.0
    if beta0 == 0.0:  # an exactly zero right-hand side has the exact solution 0
        return True
    r = basis[0]
    for k in range(nd):
        r[k] = b[k]
    beta = beta0
    converged = False
    for _restart in range(KRYLOV_MAX_RESTARTS):
        for k in range(nd):
            basis[0, k] = r[k] / beta
        g[0] = beta
        for i in range(1, m + 1):
            g[i] = 0.0
        n_used = 0
        for j in range(m):
            # z_j = M^-1 v_j, then v_{j+1} = A z_j, orthogonalised (modified Gram-Schmidt)
            vj = basis[j]
            zj = zbasis[j]
            for k in range(nd):
                zj[k] = vj[k]
            if kr.diagonal[0]:  # the LU took no row swaps
                band_solve_diagonal(kr.lu, nd, kr.inv_diag, zj)
            else:
                band_solve_by_columns(ws.band, nd, ws.piv, zj)
            v_new = basis[j + 1]
            _off_band_times(ws, nd, vj, zj, v_new)
            if kr.coarse[0] > 0:  # z_j += the axial coarse correction, v_new with it
                _coarse_correct(ws, nd, vj, zj, v_new)
            for i in range(j + 1):
                h = _dot(v_new, basis[i], nd)
                hess[i, j] = h
                vi = basis[i]
                for k in range(nd):
                    v_new[k] -= h * vi[k]
            h_next = math.sqrt(_dot(v_new, v_new, nd))
            hess[j + 1, j] = h_next
            if h_next > 0.0:
                for k in range(nd):
                    v_new[k] /= h_next
            # the earlier Givens rotations, then a new one that zeroes hess[j + 1, j]
            for i in range(j):
                t = cs[i] * hess[i, j] + sn[i] * hess[i + 1, j]
                hess[i + 1, j] = -sn[i] * hess[i, j] + cs[i] * hess[i + 1, j]
                hess[i, j] = t
            den = math.hypot(hess[j, j], hess[j + 1, j])
            if den == 0.0:
                break
            cs[j] = hess[j, j] / den
            sn[j] = hess[j + 1, j] / den
            hess[j, j] = den
            hess[j + 1, j] = 0.0
            g[j + 1] = -sn[j] * g[j]
            g[j] = cs[j] * g[j]
            n_used = j + 1
            counters[C_KRYLOV_ITERATIONS] += 1
            if abs(g[j + 1]) <= rtol * beta0 or h_next == 0.0:
                converged = True
                break
        # y = H^-1 g (upper triangular), x += M^-1 V y = Z y
        for i in range(n_used - 1, -1, -1):
            s = g[i]
            for q in range(i + 1, n_used):
                s -= hess[i, q] * y[q]
            y[i] = s / hess[i, i]
        for i in range(n_used):
            zi = zbasis[i]
            yi = y[i]
            for k in range(nd):
                x[k] += yi * zi[k]
        if converged:
            break
        # the true residual for the restart
        matvec(ws, nd, x, r)
        for k in range(nd):
            r[k] = b[k] - r[k]
        beta = math.sqrt(_dot(r, r, nd))
        if beta <= rtol * beta0:
            converged = True
            break
    finite = True
    for k in range(nd):
        if not np.isfinite(x[k]):
            finite = False
            break
    if not converged or not finite:
        counters[C_KRYLOV_FAILURES] += 1
        return False
    for k in range(nd):
        b[k] = x[k]
    return True

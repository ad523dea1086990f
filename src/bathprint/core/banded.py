"""Banded LU with partial pivoting, in numba, O(n kl (kl + ku)) work.

Row-oriented storage: entry A[i, j] lives at ``band[i, j - i + kl]``; each row keeps
``2 kl + ku + 1`` slots so that row swaps of partial pivoting (which widen the upper
band to ``ku + kl``) fit in place. No allocation: the pivot array is passed in.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import KL, KU


@njit(**KERNEL)
def band_clear(band: np.ndarray, n: int) -> None:
    """Zero the first ``n`` rows of a band matrix."""
    w = band.shape[1]
    for i in range(n):
        for k in range(w):
            band[i, k] = 0.0


@njit(**KERNEL)
def band_lu(band: np.ndarray, n: int, kl: int, ku: int, piv: np.ndarray) -> int:
    """Factor the leading n x n band matrix in place. Returns 0, or k+1 for a zero pivot.

    Rows far enough from the end (k + kl + ku < n) take loops of fixed length with offsets
    into the row (which the compiler can unroll and vectorise); the last kl + ku rows the
    bounded loops. Both do the same operations in the same order as the textbook loops
    (``tests/test_banded.py``): the factors are the same bit for bit."""
    ku2 = ku + kl
    for k in range(n):
        interior = k + ku2 < n
        # choose the pivot in column k among rows k..k+kl
        last = min(n - 1, k + kl)
        p = k
        best = abs(band[k, kl])
        for m in range(1, last - k + 1):
            a = abs(band[k + m, kl - m])
            if a > best:
                best = a
                p = k + m
        piv[k] = p
        if best == 0.0 or not np.isfinite(best):
            return k + 1
        jmax = min(n - 1, k + ku2)
        if p != k:
            for j in range(k, jmax + 1):
                tmp = band[k, j - k + kl]
                band[k, j - k + kl] = band[p, j - p + kl]
                band[p, j - p + kl] = tmp
        pivot = band[k, kl]
        for m in range(1, last - k + 1):
            # row i = k + m: A[i, j] at band[i, j - k - m + kl], row k's at band[k, j - k + kl]
            lik = band[k + m, kl - m] / pivot
            band[k + m, kl - m] = lik
            if lik != 0.0:
                # the same loop twice: with the fixed trip count of an interior row it is
                # faster (one loop with the bound jmax - k gave back the whole gain in the
                # scenes of experiments/kernel_ab/ab.py, the default scene's 0.83 to 1.08)
                if interior:
                    for q in range(1, ku2 + 1):
                        band[k + m, kl - m + q] -= lik * band[k, kl + q]
                else:
                    for q in range(1, jmax - k + 1):
                        band[k + m, kl - m + q] -= lik * band[k, kl + q]
    return 0


@njit(**KERNEL)
def band_lu_diagonal(
    band: np.ndarray, n: int, piv: np.ndarray, inv_diag: np.ndarray, threshold: float
) -> int:
    """:func:`band_lu` without row swaps, for the simulator's Newton band (``layout.KL``,
    ``layout.KU``): each column's pivot is its diagonal entry, and ``inv_diag`` receives the
    pivots' reciprocals (for :func:`band_solve_diagonal`). Returns 0; k+1 for a zero or
    non-finite pivot; -1 (the band left part-factorised) at the first column whose diagonal
    is below ``threshold`` times the largest entry under it, where a row swap is due.

    Without swaps U keeps KU super-diagonals (partial pivoting may widen it to KL + KU and
    updates all of them), so the elimination does half the work: 2.8-3.2x faster on the band
    of a coil pile's Newton matrix (``python experiments/preconditioner/preconditioner.py --part
    diagonal``). It fills ``piv`` with the identity, so the
    solves of :func:`band_solve` and :func:`band_solve_by_columns` apply too (the slots
    beyond KU stay as assembled, zero). The threshold test is that of threshold partial
    pivoting (Duff, Erisman & Reid, Direct Methods for Sparse Matrices, 1986): with 0.1 no
    multiplier exceeds 10, so an entry grows at most 11-fold per column eliminated."""
    for k in range(n):
        piv[k] = k
        pivot = band[k, KL]
        last = min(n - 1, k + KL)
        below = 0.0
        for m in range(1, last - k + 1):
            below = max(below, abs(band[k + m, KL - m]))
        if pivot == 0.0 or not np.isfinite(pivot):
            return k + 1 if below == 0.0 or not np.isfinite(below) else -1
        if abs(pivot) < threshold * below:
            return -1
        inv_diag[k] = 1.0 / pivot
        if k + KL + KU < n:  # interior: loops of fixed length
            for m in range(1, KL + 1):
                lik = band[k + m, KL - m] / pivot
                band[k + m, KL - m] = lik
                for q in range(1, KU + 1):
                    band[k + m, KL - m + q] -= lik * band[k, KL + q]
        else:
            for m in range(1, last - k + 1):
                lik = band[k + m, KL - m] / pivot
                band[k + m, KL - m] = lik
                for q in range(1, min(KU, n - 1 - k) + 1):
                    band[k + m, KL - m + q] -= lik * band[k, KL + q]
    return 0


@njit(**KERNEL, inline="always")
def _forward(band: np.ndarray, n: int, kl: int, piv: np.ndarray, b: np.ndarray) -> None:
    """The forward half of a solve: the row swaps and L, in the order they were made."""
    for k in range(n):
        p = piv[k]
        if p != k:
            tmp = b[k]
            b[k] = b[p]
            b[p] = tmp
        _l_column(band, n, kl, k, b)


@njit(**KERNEL, inline="always")
def _l_column(band: np.ndarray, n: int, kl: int, k: int, b: np.ndarray) -> None:
    """Subtract L's column k times b[k] from the rows below it (a step of the forward
    substitution)."""
    bk = b[k]
    if k + kl < n:
        for m in range(1, kl + 1):
            b[k + m] -= band[k + m, kl - m] * bk
    else:
        for m in range(1, n - k):
            b[k + m] -= band[k + m, kl - m] * bk


@njit(**KERNEL)
def band_solve(band: np.ndarray, n: int, kl: int, ku: int, piv: np.ndarray, b: np.ndarray) -> None:
    """Solve A x = b in place (b overwritten by x) with the factors from :func:`band_lu`.

    As there, loops of fixed length away from the end, in the same order of operations."""
    ku2 = ku + kl
    _forward(band, n, kl, piv, b)
    # backward: U has ku + kl super-diagonals
    for i in range(n - 1, -1, -1):
        s = b[i]
        if i + ku2 < n:
            for q in range(1, ku2 + 1):
                s -= band[i, kl + q] * b[i + q]
        else:
            for q in range(1, n - i):
                s -= band[i, kl + q] * b[i + q]
        b[i] = s / band[i, kl]


@njit(**KERNEL)
def band_solve_by_columns(band: np.ndarray, n: int, piv: np.ndarray, b: np.ndarray) -> None:
    """:func:`band_solve` for the simulator's Newton band (``layout.KL``, ``layout.KU``), with
    the backward substitution by columns: each x_i, once known, is subtracted from the
    KL + KU rows above it (independent updates) instead of each row summing its KL + KU
    terms (a chain of dependent subtractions, bound by the adder's latency). The widths are
    compile-time constants, so the loops unroll wherever it is called from. The same solve
    to round-off, in another order of operations: 2.1-2.3x faster than :func:`band_solve`
    from 300 to 9000 unknowns, 1.7x at 30000 (``python experiments/preconditioner/preconditioner.py
    --part backsub``). GMRES's preconditioner, whose round-off nothing needs to match, uses
    it where its LU took row swaps (else :func:`band_solve_diagonal`)."""
    _forward(band, n, KL, piv, b)
    for i in range(n - 1, -1, -1):
        xi = b[i] / band[i, KL]
        b[i] = xi
        if i >= KL + KU:
            for q in range(1, KL + KU + 1):
                b[i - q] -= band[i - q, KL + q] * xi
        else:
            for q in range(1, i + 1):
                b[i - q] -= band[i - q, KL + q] * xi


@njit(**KERNEL)
def band_solve_diagonal(band: np.ndarray, n: int, inv_diag: np.ndarray, b: np.ndarray) -> None:
    """Solve A x = b in place with the factors from :func:`band_lu_diagonal` (no row swaps):
    forward through L's KL sub-diagonals, backward by columns (as
    :func:`band_solve_by_columns`) through U's KU super-diagonals only, multiplying by the
    pivots' reciprocals. The same solve to round-off; 1.4x faster than
    :func:`band_solve_by_columns` on the factors of a coil pile's band, whose backward loop
    also runs over the KL slots that swaps would have filled."""
    for k in range(n):
        _l_column(band, n, KL, k, b)
    for i in range(n - 1, -1, -1):
        xi = b[i] * inv_diag[i]
        b[i] = xi
        if i >= KU:
            for q in range(1, KU + 1):
                b[i - q] -= band[i - q, KL + q] * xi
        else:
            for q in range(1, i + 1):
                b[i - q] -= band[i - q, KL + q] * xi


@njit(**KERNEL)
def band_matvec(band: np.ndarray, n: int, kl: int, ku: int, x: np.ndarray, y: np.ndarray) -> None:
    """y = A x for an unfactored band matrix (kl sub-, ku super-diagonals)."""
    for i in range(n):
        s = 0.0
        for j in range(max(0, i - kl), min(n, i + ku + 1)):
            s += band[i, j - i + kl] * x[j]
        y[i] = s


@kernel
def merge_blocks(cpl, n_rows: int) -> None:
    """Sum the assembled blocks of ``cpl`` that share a node block into rows (CSR of 3x3
    blocks: ``m_start``, ``m_col``, ``m_block``), each row's in the order of assembly, for
    :func:`add_blocks_matvec`. A counting sort by row, then a scan of the row's merged
    columns (a few: a node touches about two turns): O(K + n_rows)."""
    n = min(cpl.count[0], cpl.row.shape[0])
    start = cpl.m_start
    if n_rows + 1 > start.shape[0]:
        cpl.merged[0] = -1
        return
    for r in range(n_rows + 1):
        start[r] = 0
    for k in range(n):
        start[cpl.row[k] + 1] += 1
    for r in range(n_rows):
        start[r + 1] += start[r]
    order = cpl.order
    for k in range(n):  # start[r] ends at row r's end, then shifts back to its start
        r = cpl.row[k]
        order[start[r]] = k
        start[r] += 1
    for r in range(n_rows, 0, -1):
        start[r] = start[r - 1]
    start[0] = 0
    m = 0
    m_col = cpl.m_col
    m_block = cpl.m_block
    lo = 0
    for r in range(n_rows):
        hi = start[r + 1]
        first = m
        for q in range(lo, hi):
            k = order[q]
            c = cpl.col[k]
            s = first
            while s < m and m_col[s] != c:
                s += 1
            if s == m:
                m_col[m] = c
                for a in range(3):
                    for b in range(3):
                        m_block[m, a, b] = cpl.block[k, a, b]
                m += 1
            else:
                for a in range(3):
                    for b in range(3):
                        m_block[s, a, b] += cpl.block[k, a, b]
        start[r] = first
        lo = hi
    start[n_rows] = m
    cpl.merged[0] = m
    cpl.merged[1] = n_rows


@kernel
def add_blocks_matvec(cpl, x: np.ndarray, y: np.ndarray) -> None:
    """y += B x for the off-band 3x3 blocks ``cpl`` (:class:`bathprint.core.records.
    Couplings`): by rows of merged blocks when :func:`merge_blocks` has summed them since
    their assembly (half as many on a pressed stack, each row's sum in registers), else
    block k at node block (row[k], col[k]) one by one."""
    if cpl.merged[0] >= 0:
        start = cpl.m_start
        m_col = cpl.m_col
        blk = cpl.m_block
        for r in range(cpl.merged[1]):
            y0 = y1 = y2 = 0.0
            for s in range(start[r], start[r + 1]):
                c = 3 * m_col[s]
                x0, x1, x2 = x[c], x[c + 1], x[c + 2]
                y0 += blk[s, 0, 0] * x0 + blk[s, 0, 1] * x1 + blk[s, 0, 2] * x2
                y1 += blk[s, 1, 0] * x0 + blk[s, 1, 1] * x1 + blk[s, 1, 2] * x2
                y2 += blk[s, 2, 0] * x0 + blk[s, 2, 1] * x1 + blk[s, 2, 2] * x2
            y[3 * r] += y0
            y[3 * r + 1] += y1
            y[3 * r + 2] += y2
        return
    for k in range(min(cpl.count[0], cpl.row.shape[0])):
        r = 3 * cpl.row[k]
        c = 3 * cpl.col[k]
        blk = cpl.block[k]
        for a in range(3):
            y[r + a] += blk[a, 0] * x[c] + blk[a, 1] * x[c + 1] + blk[a, 2] * x[c + 2]

"""Helpers the effect kernels share: writing 3x3 blocks into the banded Jacobian."""

from __future__ import annotations

import numpy as np
from numba import njit

from bathprint.core.jit import KERNEL
from bathprint.core.layout import KL


@njit(**KERNEL, inline="always")
def add_block(band: np.ndarray, n_free: int, i: int, j: int, blk: np.ndarray, scale: float) -> None:
    """Add ``scale * blk`` (3x3) at node block (i, j); prescribed nodes (>= n_free) are skipped."""
    if i >= n_free or j >= n_free:
        return
    for a in range(3):
        r = 3 * i + a
        for b in range(3):
            band[r, 3 * j + b - r + KL] += scale * blk[a, b]


@njit(**KERNEL, inline="always")
def add_diag(band: np.ndarray, n_free: int, i: int, a: int, value: float) -> None:
    """Add ``value`` to the diagonal entry of node i, component a."""
    if i >= n_free:
        return
    band[3 * i + a, KL] += value


@njit(**KERNEL, inline="always")
def add_coupling(
    band: np.ndarray, cpl, n_free: int, i: int, j: int, blk: np.ndarray, scale: float
) -> None:
    """Add ``scale * blk`` at node block (i, j): into the band when |i - j| <= 2, else as a
    coupling off the band (``cpl``, see :class:`bathprint.core.records.Couplings`; counted
    even beyond its capacity, so the caller can grow it). Prescribed nodes are skipped."""
    if i >= n_free or j >= n_free:
        return
    if abs(i - j) <= 2:
        add_block(band, n_free, i, j, blk, scale)
        return
    k = cpl.count[0]
    cpl.count[0] = k + 1
    if k < cpl.row.shape[0]:
        cpl.row[k] = i
        cpl.col[k] = j
        for a in range(3):
            for b in range(3):
                cpl.block[k, a, b] = scale * blk[a, b]

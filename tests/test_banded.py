"""The banded LU with partial pivoting against a dense solve."""

from __future__ import annotations

import numpy as np
import pytest

from bathprint.core.banded import (
    band_lu,
    band_lu_diagonal,
    band_matvec,
    band_solve,
    band_solve_by_columns,
    band_solve_diagonal,
)
from bathprint.core.layout import BAND_WIDTH, KL, KU


def _random_band(n: int, seed: int, diag_shift: float) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    dense = np.zeros((n, n))
    band = np.zeros((n, BAND_WIDTH))
    for i in range(n):
        for j in range(max(0, i - KL), min(n, i + KU + 1)):
            v = rng.normal() + (diag_shift if i == j else 0.0)
            dense[i, j] = v
            band[i, j - i + KL] = v
    return dense, band


@pytest.mark.parametrize("shift", [0.0, 10.0])  # 0: needs pivoting; 10: diagonally dominant
@pytest.mark.parametrize("n", [1, 5, 30, 300])
def test_band_solve_matches_dense(n: int, shift: float) -> None:
    dense, band = _random_band(n, seed=n, diag_shift=shift)
    b = np.random.default_rng(7).normal(size=n)
    y = np.zeros(n)
    band_matvec(band, n, KL, KU, b, y)
    np.testing.assert_allclose(y, dense @ b, rtol=1e-12, atol=1e-12)
    piv = np.zeros(n, dtype=np.int64)
    assert band_lu(band, n, KL, KU, piv) == 0
    x = b.copy()
    band_solve(band, n, KL, KU, piv, x)
    np.testing.assert_allclose(x, np.linalg.solve(dense, b), rtol=1e-8, atol=1e-10)
    x_col = b.copy()
    band_solve_by_columns(band, n, piv, x_col)
    np.testing.assert_allclose(x_col, x, rtol=1e-12, atol=1e-12 * np.max(np.abs(x)))


@pytest.mark.parametrize("n", [1, 5, 17, 30, 300])
def test_band_lu_without_row_swaps_solves_a_diagonally_dominant_band(n: int) -> None:
    """Diagonal pivots (GMRES's preconditioner): the same solution as partial pivoting, with
    the identity in ``piv`` and U within KU super-diagonals (the fill slots untouched)."""
    dense, band = _random_band(n, seed=n, diag_shift=10.0)
    piv = np.full(n, -7, dtype=np.int64)
    inv_diag = np.zeros(n)
    assert band_lu_diagonal(band, n, piv, inv_diag, 0.1) == 0
    np.testing.assert_allclose(inv_diag * band[:n, KL], 1.0, rtol=1e-15)
    assert np.array_equal(piv, np.arange(n))
    assert not np.any(band[:n, KL + KU + 1 :])
    b = np.random.default_rng(3).normal(size=n)
    x = b.copy()
    band_solve(band, n, KL, KU, piv, x)
    np.testing.assert_allclose(x, np.linalg.solve(dense, b), rtol=1e-10, atol=1e-12)
    for solve in (
        lambda v: band_solve_by_columns(band, n, piv, v),
        lambda v: band_solve_diagonal(band, n, inv_diag, v),
    ):
        x_other = b.copy()
        solve(x_other)
        np.testing.assert_allclose(x_other, x, rtol=1e-12, atol=1e-12 * np.max(np.abs(x)))


def test_band_lu_without_row_swaps_stops_where_a_swap_is_due() -> None:
    """A diagonal below the threshold times the column under it returns -1 (the caller
    starts again with partial pivoting); a zero column returns its number + 1, as band_lu."""
    n = 40
    _, band = _random_band(n, seed=1, diag_shift=10.0)
    below = max(abs(band[m, KL - m]) for m in range(1, KL + 1))
    band[0, KL] = 1e-3 * below  # the first column's diagonal, tiny against the entries under it
    work = (np.zeros(n, np.int64), np.zeros(n))
    assert band_lu_diagonal(band.copy(), n, *work, 0.1) == -1
    assert band_lu_diagonal(np.zeros((n, BAND_WIDTH)), n, *work, 0.1) == 1


def test_singular_matrix_is_reported() -> None:
    n = 10
    band = np.zeros((n, BAND_WIDTH))
    piv = np.zeros(n, dtype=np.int64)
    assert band_lu(band, n, KL, KU, piv) == 1


def _reference_lu(band: np.ndarray, n: int, kl: int, ku: int, piv: np.ndarray) -> int:
    """The textbook banded LU with partial pivoting (the loops with bounds on every row), in
    plain Python: the operations the compiled LU must do, in the same order."""
    ku2 = ku + kl
    for k in range(n):
        last = min(n - 1, k + kl)
        p, best = k, abs(band[k, kl])
        for i in range(k + 1, last + 1):
            if abs(band[i, k - i + kl]) > best:
                p, best = i, abs(band[i, k - i + kl])
        piv[k] = p
        if best == 0.0:
            return k + 1
        jmax = min(n - 1, k + ku2)
        if p != k:
            for j in range(k, jmax + 1):
                a, b = band[k, j - k + kl], band[p, j - p + kl]
                band[k, j - k + kl], band[p, j - p + kl] = b, a
        for i in range(k + 1, last + 1):
            lik = band[i, k - i + kl] / band[k, kl]
            band[i, k - i + kl] = lik
            if lik != 0.0:
                for j in range(k + 1, jmax + 1):
                    band[i, j - i + kl] -= lik * band[k, j - k + kl]
    return 0


def _reference_solve(band: np.ndarray, n: int, kl: int, ku: int, piv, b: np.ndarray) -> None:
    for k in range(n):
        p = piv[k]
        b[k], b[p] = b[p], b[k]
        for i in range(k + 1, min(n - 1, k + kl) + 1):
            b[i] -= band[i, k - i + kl] * b[k]
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, min(n - 1, i + ku + kl) + 1):
            s -= band[i, j - i + kl] * b[j]
        b[i] = s / band[i, kl]


@pytest.mark.parametrize("shift", [0.0, 10.0])
@pytest.mark.parametrize("n", [1, 2, 8, 16, 17, 18, 25, 40])  # around kl + ku = 16
def test_band_lu_and_solve_do_the_reference_operations_bit_for_bit(n: int, shift: float) -> None:
    """The compiled LU runs rows away from the end in loops of fixed length; its factors,
    pivots and solutions equal the reference loops' exactly (same operations, same order),
    with and without row swaps, on both sides of the switch between the two kinds of row."""
    _, band = _random_band(n, seed=100 + n, diag_shift=shift)
    ref = band.copy()
    piv, piv_ref = np.zeros(n, dtype=np.int64), np.zeros(n, dtype=np.int64)
    assert band_lu(band, n, KL, KU, piv) == _reference_lu(ref, n, KL, KU, piv_ref) == 0
    assert np.array_equal(piv, piv_ref)
    assert np.array_equal(band, ref)
    b = np.random.default_rng(n).normal(size=n)
    x, x_ref = b.copy(), b.copy()
    band_solve(band, n, KL, KU, piv, x)
    _reference_solve(ref, n, KL, KU, piv_ref, x_ref)
    assert np.array_equal(x, x_ref)

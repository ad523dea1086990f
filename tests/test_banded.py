"""The banded LU with partial pivoting against a dense solve."""

from __future__ import annotations

import numpy as np
import pytest

from bathprint.core.banded import band_lu, band_matvec, band_solve
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


def test_singular_matrix_is_reported() -> None:
    n = 10
    band = np.zeros((n, BAND_WIDTH))
    piv = np.zeros(n, dtype=np.int64)
    assert band_lu(band, n, KL, KU, piv) == 1

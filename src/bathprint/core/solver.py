"""The linear solves of Newton's method: the banded LU of the local Jacobian.

Forces couple nodes at most two apart (bending), so the Newton matrix is banded (8 sub- and
super-diagonals in 3 unknowns per node) and :func:`factor` / :func:`solve` cost O(N):
:mod:`bathprint.core.banded`, partial pivoting, in place in ``ws.band``.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bathprint.core.banded import band_lu, band_matvec, band_solve
from bathprint.core.layout import KL, KU


@njit(cache=True)
def factor(ws, nd: int) -> bool:
    """Factorise the assembled Newton matrix (``ws.band``) in place; False if singular."""
    return band_lu(ws.band, nd, KL, KU, ws.piv) == 0


@njit(cache=True)
def solve(ws, nd: int, rhs: np.ndarray) -> None:
    """Overwrite ``rhs`` with the Newton matrix's inverse applied to it."""
    band_solve(ws.band, nd, KL, KU, ws.piv, rhs)


@njit(cache=True)
def damping_times(ws, nd: int, x: np.ndarray, y: np.ndarray) -> None:
    """y = D x with D the damping / mass matrix assembled into ``ws.band2``."""
    band_matvec(ws.band2, nd, KL, KU, x, y)

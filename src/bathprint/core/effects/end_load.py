"""End load: a dead force (N) on the free end of the filament (column buckling tests)."""

from __future__ import annotations

from numba import njit

from bathprint.core.layout import P_END_LOAD_X


@njit(cache=True)
def accumulate(
    pos, vel, acc, n_nodes, seg_rest, seg_mat, params, t, cx, cv, ca, force, band, work, do_jac
) -> float:
    """Add the end load to node 0; return its potential energy -P.x0 (J)."""
    energy = 0.0
    for a in range(3):
        force[a] += params[P_END_LOAD_X + a]
        energy -= params[P_END_LOAD_X + a] * pos[a]
    return energy

"""Sum the forces (and the Newton Jacobian) of the effects a scene lists.

Every effect is called through the same signature; an effect whose ``enabled`` flag is
0 is never called (``calls`` counts the calls of each, which tests and benchmarks read).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bathprint.core.banded import band_clear
from bathprint.core.effects import drag, elasticity, end_load, floor, gravity, inertia
from bathprint.core.freezing import accumulate_tail
from bathprint.core.layout import (
    E_DRAG,
    E_ELASTICITY,
    E_END_LOAD,
    E_FLOOR,
    E_GRAVITY,
    E_INERTIA,
    W_TAIL,
)
from bathprint.core.topology import free_nodes


@njit(cache=True)
def assemble(
    pos: np.ndarray,
    vel: np.ndarray,
    acc: np.ndarray,
    n_nodes: int,
    seg_rest: np.ndarray,
    seg_mat: np.ndarray,
    params: np.ndarray,
    t: float,
    cx: float,
    cv: float,
    ca: float,
    force: np.ndarray,
    band: np.ndarray,
    work: np.ndarray,
    do_jac: bool,
    enabled: np.ndarray,
    calls: np.ndarray,
    energies: np.ndarray,
) -> None:
    """Total force on every node into ``force``; ``-(cx dF/dx + cv dF/dv + ca dF/da)``
    on the free nodes into ``band`` when ``do_jac``; each effect's energy into ``energies``."""
    for k in range(3 * n_nodes):
        force[k] = 0.0
    if do_jac:
        band_clear(band, 3 * free_nodes(n_nodes, params))
    args = (pos, vel, acc, n_nodes, seg_rest, seg_mat, params, t, cx, cv, ca, force, band, work)
    if enabled[E_ELASTICITY]:
        calls[E_ELASTICITY] += 1
        energies[E_ELASTICITY] = elasticity.accumulate(*args, do_jac)
    if enabled[E_DRAG]:
        calls[E_DRAG] += 1
        energies[E_DRAG] = drag.accumulate(*args, do_jac)
    if enabled[E_GRAVITY]:
        calls[E_GRAVITY] += 1
        energies[E_GRAVITY] = gravity.accumulate(*args, do_jac)
    if enabled[E_FLOOR]:
        calls[E_FLOOR] += 1
        energies[E_FLOOR] = floor.accumulate(*args, do_jac)
    if enabled[E_INERTIA]:
        calls[E_INERTIA] += 1
        energies[E_INERTIA] = inertia.accumulate(*args, do_jac)
    if enabled[E_END_LOAD]:
        calls[E_END_LOAD] += 1
        energies[E_END_LOAD] = end_load.accumulate(*args, do_jac)
    if work[W_TAIL] > 0.0:  # a frozen tail (numerics.freeze_beyond_mm): part of the drag
        energies[E_DRAG] += accumulate_tail(*args, do_jac)

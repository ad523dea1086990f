"""Sum the forces (and the Newton Jacobian) of the effects a scene lists.

Every effect is called through the same signature, ``accumulate(model, rod, stage, out)``;
an effect whose ``enabled`` flag is 0 is never called (``calls`` counts the calls of each,
which tests and benchmarks read). With hydrodynamics listed, drag's law runs inside it, after
the other effects (whose forces drive the nonlocal flow).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from bathprint.core.banded import band_clear
from bathprint.core.effects import (
    contact,
    drag,
    elasticity,
    end_load,
    floor,
    gravity,
    hydrodynamics,
    inertia,
    viscosity,
)
from bathprint.core.freezing import accumulate_joint, accumulate_tail
from bathprint.core.jit import KERNEL
from bathprint.core.layout import (
    E_CONTACT,
    E_DRAG,
    E_ELASTICITY,
    E_END_LOAD,
    E_FLOOR,
    E_GRAVITY,
    E_HYDRODYNAMICS,
    E_INERTIA,
    E_VISCOSITY,
)
from bathprint.core.topology import free_nodes


@njit(**KERNEL)
def assemble(model, rod, stage, out, calls: np.ndarray, energies: np.ndarray) -> None:
    """Total force on every node into ``out.force``; ``-(cx dF/dx + cv dF/dv + ca dF/da)``
    on the free nodes into ``out.band`` when ``stage.jac``; each effect's energy into
    ``energies``."""
    enabled = model.enabled
    force = out.force
    for k in range(3 * rod.n_nodes):
        force[k] = 0.0
    if stage.jac:
        band_clear(out.band, 3 * free_nodes(rod.n_nodes, model.params[0]))
        out.cpl.count[0] = 0
        out.cpl.merged[0] = -1  # merged again when factorised
    if enabled[E_ELASTICITY]:
        calls[E_ELASTICITY] += 1
        energies[E_ELASTICITY] = elasticity.accumulate(model, rod, stage, out)
    if enabled[E_DRAG] and not enabled[E_HYDRODYNAMICS]:
        calls[E_DRAG] += 1
        energies[E_DRAG] = drag.accumulate(model, rod, stage, out)
    if enabled[E_GRAVITY]:
        calls[E_GRAVITY] += 1
        energies[E_GRAVITY] = gravity.accumulate(model, rod, stage, out)
    if enabled[E_FLOOR]:
        calls[E_FLOOR] += 1
        energies[E_FLOOR] = floor.accumulate(model, rod, stage, out)
    if enabled[E_VISCOSITY]:
        calls[E_VISCOSITY] += 1
        energies[E_VISCOSITY] = viscosity.accumulate(model, rod, stage, out)
    if enabled[E_INERTIA]:
        calls[E_INERTIA] += 1
        energies[E_INERTIA] = inertia.accumulate(model, rod, stage, out)
    if enabled[E_END_LOAD]:
        calls[E_END_LOAD] += 1
        energies[E_END_LOAD] = end_load.accumulate(model, rod, stage, out)
    if enabled[E_HYDRODYNAMICS]:  # J_other for the nonlocal flow's Newton matrix: before contact
        hydrodynamics.linearise(model, rod, stage, out)
    if enabled[E_CONTACT]:
        calls[E_CONTACT] += 1
        energies[E_CONTACT] = contact.accumulate(model, rod, stage, out)
    if enabled[E_HYDRODYNAMICS]:  # the drag law with the nonlocal flow, which the forces
        calls[E_DRAG] += 1  # above drive: after them
        calls[E_HYDRODYNAMICS] += 1
        energies[E_DRAG] = hydrodynamics.accumulate(model, rod, stage, out)
    if out.tail[0].on:  # a frozen tail (numerics.freeze_beyond_mm): part of the drag
        energies[E_DRAG] += accumulate_tail(model, rod, stage, out)
        energies[E_ELASTICITY] += accumulate_joint(model, rod, stage, out)

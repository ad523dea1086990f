"""End load: a dead force (N) on the free end of the filament (column buckling tests)."""

from __future__ import annotations

from bathprint.core.jit import kernel


@kernel
def accumulate(model, rod, stage, out) -> float:
    """Add the end load to node 0; return its potential energy -P.x0 (J)."""
    load = model.params[0].end_load
    energy = 0.0
    for a in range(3):
        out.force[a] += load[a]
        energy -= load[a] * rod.pos[a]
    return energy

"""The lagged coupling of the hydrodynamics effect: the nonlocal flow of a step is the flow at
its start (Tornberg & Shelley 2004, J. Comput. Phys. 196, 8), and the error that leaves is
estimated and added to the step's error norm.

Lagging is first order: the flow the filament feels during a step of h is u_nl(t) instead of
u_nl(t + tau), a velocity error growing to |u_nl(t + h) - u_nl(t)|, so a position error of
about e_lag = (h/2) |u_nl(t + h) - u_nl(t)|, which the integrator's own estimate cannot see
(both of its solutions share the frozen flow). :func:`check` evaluates the flow at the end of
every attempted step; its RMS difference from the flow at the start gives e_lag (scaled like
the error norm), and, when the step is accepted, it is the next step's flow (:func:`prepare`
finds it), so the estimate costs one evaluation per step, as lagging does anyway.

(Separate from :mod:`.hydrodynamics` because it calls :func:`bathprint.core.assemble.
assemble`, which imports that module.)
"""

from __future__ import annotations

import math

from bathprint.core.assemble import assemble
from bathprint.core.effects.hydrodynamics import flow
from bathprint.core.jit import kernel
from bathprint.core.layout import HYDRO_LAGGED
from bathprint.core.records import Stage
from bathprint.core.topology import filament_segments, free_nodes


@kernel
def _flow_at_state(model, rod, out, state, t: float, target) -> None:
    """The nonlocal flow at the rod's current state (time t) into ``target``: one force
    evaluation of the listed effects, in which the hydrodynamics kernel records the sources
    (the other effects' forces), then the flow of those."""
    p = model.params[0]
    assemble(model, rod, Stage(t, 0.0, 0.0, 0.0, False), out, state.calls, state.energies)
    n_seg = filament_segments(rod.n_nodes, p)
    flow(rod.pos, rod.node_s, n_seg + 1, n_seg, out.hydro, target)


@kernel
def prepare(model, rod, out, state) -> None:
    """At a step's start: the flow at the current state into ``out.hydro.u_nl``, taken from
    the last attempted step when that was accepted and no node was born since (else
    evaluated)."""
    p = model.params[0]
    if p.hydro_coupling != HYDRO_LAGGED:
        return
    hyd = out.hydro
    mem = hyd.memory[0]
    t = state.clock[0]
    n = rod.n_nodes
    if mem.next_valid and mem.next_time == t and mem.next_nodes == n:
        for k in range(3 * n):
            hyd.u_nl[k] = hyd.u_next[k]
        mem.u_valid = True
        mem.u_time = t
        mem.u_nodes = n
        mem.next_valid = False
        return
    if mem.u_valid and mem.u_time == t and mem.u_nodes == n:
        return  # (a retried step: the state is the one the flow was evaluated at)
    _flow_at_state(model, rod, out, state, t, hyd.u_nl)
    mem.u_valid = True
    mem.u_time = t
    mem.u_nodes = n


@kernel
def check(model, rod, out, state, h: float, norm_extra: float) -> float:
    """After an attempted step of h to the rod's current state: the flow there (kept for
    the next step) and the lag error (h/2) RMS(u_nl(t + h) - u_nl(t)) in units of the error
    tolerance (``numerics.tolerance`` x the node spacing); 0 for the implicit coupling."""
    p = model.params[0]
    if p.hydro_coupling != HYDRO_LAGGED:
        return 0.0
    hyd = out.hydro
    mem = hyd.memory[0]
    _flow_at_state(model, rod, out, state, state.clock[0] + h, hyd.u_next)
    mem.next_valid = True
    mem.next_time = state.clock[0] + h
    mem.next_nodes = rod.n_nodes
    nd = 3 * free_nodes(rod.n_nodes, p)
    s = 0.0
    for k in range(nd):
        d = hyd.u_next[k] - hyd.u_nl[k]
        s += d * d
    err = 0.5 * h * math.sqrt(s / max(nd + norm_extra, 1.0)) / (p.tolerance * p.node_spacing)
    mem.lag_error = err
    return err

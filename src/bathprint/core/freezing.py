"""Frozen tail: settled material far behind the needle, out of the solve, as one lumped load.

With ``numerics.freeze_beyond_mm`` > 0 the nodes more than that arclength of material
behind the needle are frozen (:func:`bathprint.core.integrators.advance`): the steps work on
array views that start at the first active node, and the frozen nodes translate with it,
so the tail keeps its shape and stays attached. Far from the needle the filament moves as
a rigid body (a laid helix sinks or is pushed away as a whole), so what the tail does to
the active filament is its total drag at the velocity of that node, and its net weight:

    F_tail = W - D (v_a - u_bath) - M a_a,   D = sum_j mu_s l_j (2 I - t_j t_j^T),
    W = -sum_j (rho_j - rho_bath(z_j)) A_j l_j g e_z     (only when gravity is listed),
    M = sum_j A_j l_j [rho_j I + C_a rho_bath (I - t_j t_j^T)]   (only with inertia)

summed over the frozen segments (the one joining the tail to the active end included): a
rigid tail translating with the active end at its velocity v_a has that drag, and, when
inertia is listed, that mass (with the transverse added mass of effects.inertia), which
follows the end's acceleration a_a.

With the floor listed, only material resting on the floor freezes, and the tail slides
with the active end horizontally (its height stays): its weight is carried by the floor
and it acts on the active end through its horizontal drag and the floor's friction on it,
-mu_f N u_h / sqrt(|u_h|^2 + u_eps^2) with N its total net weight, the law of
:mod:`bathprint.core.effects.floor` (a rope-coiling pile is pushed over the floor as a whole).
D and W are computed at the start of each step (O(frozen nodes), no Newton work) and
applied to the active end with the Jacobian block D, the same drag law as
:mod:`bathprint.core.effects.drag`. In a density gradient W is thus lagged by one step and has no
Jacobian; its restoring time mu_s / (g A drho/dz) (~0.2 s in BuoyantLayers-v0) is longer than
the largest step, so this stays stable.
With ``numerics.freeze_joint = "clamped"`` (the default without the floor) the tail, which
translates without turning, holds the end's tangent through the bending of the joining
node (:func:`accumulate_joint`), as the continuing filament would if the tail did not
turn. With ``"free"`` (the default with the floor, where the tail stays at its height while
the end rises and falls) it takes no moment: the active end turns freely. On a steady
inertial coil the free joint widens the turns above the tail by 5-6% and, frozen beyond
60 mm, those at the needle by 3.1%; the clamped one changes them by at most 2.3% and by
-1.5% (``experiments/freezing/freezing.py --part turns``). The error
and Newton norms stay RMS over the whole filament, as without freezing (the frozen nodes
count with zero error: they only follow the active end), so freezing does not tighten the
step-size control.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.effects._band import add_block
from bathprint.core.effects.drag import segment_mu_s
from bathprint.core.effects.elasticity import bend_energy_grad_hess, segment_bending_stiffness
from bathprint.core.effects.floor import friction_block
from bathprint.core.effects.gravity import bath_density
from bathprint.core.jit import KERNEL
from bathprint.core.layout import MAT_DENSITY, MAT_KAPPA_X, MAT_RADIUS
from bathprint.core.topology import free_nodes


@njit(**KERNEL)
def tail_load(model, rod, n_frozen: int, gravity_on: bool, on_floor: bool, ws) -> None:
    """Lumped drag tensor and net weight of the frozen segments 0..n_frozen-1 of the whole
    rod into ``ws.tail`` (``on`` is False when nothing is frozen). ``on_floor``: the tail
    rests on the floor, which carries its weight (stored as the normal force for
    friction); drag acts on its horizontal motion only."""
    p = model.params[0]
    tail = ws.tail[0]
    pos, seg_rest, seg_mat = rod.pos, rod.seg_rest, rod.seg_mat
    tail.on = False
    for a in range(3):
        tail.force[a] = 0.0
        for b in range(3):
            tail.drag[a, b] = 0.0
            tail.mass[a, b] = 0.0
    ws.solver[0].norm_extra = 3.0 * n_frozen
    tail.normal = 0.0
    tail.on_floor = on_floor
    tail.clamped = False
    if n_frozen <= 0:
        return
    tail.on = True
    if p.freeze_clamped and not on_floor:  # the joining segment n_frozen - 1, as it is now
        j = n_frozen - 1
        tail.clamped = True
        for a in range(3):
            tail.edge[a] = pos[3 * j + 3 + a] - pos[3 * j + a]
            tail.kappa[a] = seg_mat[j, MAT_KAPPA_X + a]
        tail.bend = segment_bending_stiffness(seg_mat, j)
        tail.rest = seg_rest[j]
    mu_s = p.mu_s
    g = p.gravity
    weight = 0.0
    for j in range(n_frozen):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        tt = (ex / length, ey / length, ez / length)
        if p.liquid:
            mu_s = segment_mu_s(p, seg_mat[j, MAT_RADIUS])
        for a in range(3):
            for b in range(3):
                tail.drag[a, b] += mu_s * length * ((2.0 if a == b else 0.0) - tt[a] * tt[b])
        if p.inertial:
            r = seg_mat[j, MAT_RADIUS]
            vol = math.pi * r * r * seg_rest[j]
            rho_b, _ = bath_density(p, 0.5 * (pos[3 * j + 2] + pos[3 * j + 5]), r)
            rho = seg_mat[j, MAT_DENSITY]
            c_a = p.added_mass_coefficient
            for a in range(3):
                for b in range(3):
                    eye = 1.0 if a == b else 0.0
                    tail.mass[a, b] += vol * (rho * eye + c_a * rho_b * (eye - tt[a] * tt[b]))
        if gravity_on:
            r = seg_mat[j, MAT_RADIUS]
            half_vol = 0.5 * math.pi * r * r * seg_rest[j]
            rho = seg_mat[j, MAT_DENSITY]
            for side in range(2):
                rho_b, _ = bath_density(p, pos[3 * (j + side) + 2], r)
                weight += half_vol * g * (rho - rho_b)
    if on_floor:  # the tail moves horizontally only: D P_h; the floor carries the weight
        for a in range(3):
            tail.drag[a, 2] = 0.0
            tail.mass[a, 2] = 0.0
        tail.normal = max(weight, 0.0)
        weight = 0.0
    # drag of a tail at rest in the bath's flow: D u_bath
    for a in range(3):
        push = 0.0
        for b in range(3):
            push += tail.drag[a, b] * p.bath_flow[b]
        tail.force[a] = push
    tail.force[2] -= weight


@njit(**KERNEL)
def accumulate_tail(model, rod, stage, out) -> float:
    """Add the frozen tail's load to the active end (node 0 of the active views) and
    cv D + ca M to its Jacobian block; returns the tail drag's dissipation rate
    (v - u) D (v - u) (W), u the bath's flow."""
    tail = out.tail[0]
    if not tail.on:
        return 0.0
    p = model.params[0]
    vel, acc, force = rod.vel, rod.acc, out.force
    drag = tail.drag
    mass = tail.mass
    flow = p.bath_flow
    power = 0.0
    for a in range(3):
        f = tail.force[a]
        for b in range(3):
            f -= drag[a, b] * vel[b]
            power += (vel[a] - flow[a]) * drag[a, b] * (vel[b] - flow[b])
            if p.inertial:
                f -= mass[a, b] * acc[b]
        force[a] += f
    n_free = free_nodes(rod.n_nodes, p)
    if stage.jac:
        add_block(out.band, n_free, 0, 0, drag, stage.cv)
        if p.inertial:
            add_block(out.band, n_free, 0, 0, mass, stage.ca)
    normal = tail.normal
    mu_f = p.friction_coefficient
    if tail.on_floor and normal > 0.0 and mu_f > 0.0:
        eps = p.friction_velocity
        ux, uy = vel[0], vel[1]
        s = math.sqrt(ux * ux + uy * uy + eps * eps)
        force[0] -= mu_f * normal * ux / s
        force[1] -= mu_f * normal * uy / s
        power += mu_f * normal * (ux * ux + uy * uy) / s
        if stage.jac:
            blk = out.scratch.blk_a
            friction_block(blk, mu_f * normal, ux, uy, s)
            add_block(out.band, n_free, 0, 0, blk, stage.cv)
    return power


@njit(**KERNEL)
def accumulate_joint(model, rod, stage, out) -> float:
    """With ``numerics.freeze_joint = "clamped"``: the bending of the node that joins the
    frozen tail to the active filament (active node 0), E = 1/2 (B / dl) |kb - dl kappa0|^2
    of :mod:`bathprint.core.effects.elasticity` between the joining segment e1, constant
    while the tail translates with node 0, and the first active segment e2 = x_1 - x_0.
    Since x_(f-1) moves with x_0, dE/dx_0 = -dE/de2: the tail takes the moment, as a clamp
    does. Adds the forces and cx * Hessian; returns E (J)."""
    tail = out.tail[0]
    if not tail.clamped:
        return 0.0
    pos, seg_rest, seg_mat = rod.pos, rod.seg_rest, rod.seg_mat
    sc = out.scratch
    e1, e2, kbar = sc.edges[0], sc.edges[1], sc.edges[2]
    grad, hess = sc.bend_grad, sc.bend_hess
    dl = 0.5 * (tail.rest + seg_rest[0])
    k = 0.5 * (tail.bend + segment_bending_stiffness(seg_mat, 0)) / dl
    for a in range(3):
        e1[a] = tail.edge[a]
        e2[a] = pos[3 + a] - pos[a]
        kbar[a] = 0.5 * dl * (tail.kappa[a] + seg_mat[0, MAT_KAPPA_X + a])
    do_jac = stage.jac and stage.cx != 0.0
    energy = bend_energy_grad_hess(e1, e2, kbar, k, grad, hess, sc.bend_work, do_jac)
    force = out.force
    for a in range(3):
        force[a] += grad[3 + a]
        force[3 + a] -= grad[3 + a]
    if do_jac:
        blk = sc.blk_a
        n_free = free_nodes(rod.n_nodes, model.params[0])
        for a in range(3):
            for b in range(3):
                blk[a, b] = hess[3 + a, 3 + b]
        add_block(out.band, n_free, 0, 0, blk, stage.cx)
        add_block(out.band, n_free, 1, 1, blk, stage.cx)
        add_block(out.band, n_free, 0, 1, blk, -stage.cx)
        add_block(out.band, n_free, 1, 0, blk, -stage.cx)
    return energy


def tail_is_frozen(tail: np.ndarray) -> bool:
    """True when a tail load is set (``ws.tail``; for tests)."""
    return bool(tail[0]["on"])

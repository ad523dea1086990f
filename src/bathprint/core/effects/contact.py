"""Contact: self-contact between non-adjacent segments of the filament (effect 'contact').

Two segments A, B at distance d (their centre lines, :mod:`._segment_geometry`) repel when
d < delta = f (r_A + r_B) (f = ``contact.distance_factor``, the radii from the material
records), through a penalty on the penetration p = delta - d in the incremental-potential
style of IMC (Choi, Tong, Jawed & Joo 2021, J. Appl. Mech. 88, 051010; DisMech):

    E = k l_c p^3 / (6 w)            for p < w (soft onset over w = ``width_fraction`` delta)
    E = k l_c (p^2/2 - w p/2 + w^2/6) beyond,

k = ``contact.stiffness_pa`` (force per length per penetration, like the floor's) and l_c the
mean rest length of the two segments. The energy is C2 in d; its exact gradient and Hessian
(with the closest points' dependence on the positions) go into Newton: the Hessian blocks
between the nodes of A and B, about a coil turn apart along the rod, are couplings off the
band (``out.cpl``, solved by GMRES in :mod:`bathprint.core.solver`).

Optional friction between touching segments (``contact.friction_coefficient`` mu > 0):
regularised Coulomb on the tangential relative velocity u_t of the closest points,
F = -mu N u_t / sqrt(|u_t|^2 + u_eps^2) on A (and the opposite on B), N = dE/dp the normal
force, distributed to the nodes by the closest-point weights. Its velocity Jacobian is exact
with the geometry (normal, closest points, N) held at the iterate (as the floor holds N).

Candidate pairs come from a uniform spatial hash, rebuilt at the start of every step
(:func:`prepare`) with a search distance delta_max + skin; an accepted step must keep
every pair's relative node displacement below its start distance, and every node's motion
relative to the common motion below half the skin (:func:`check`, the no-pass-through
bound): otherwise it is retried shorter, never accepted. The skin follows the motion (2.5x
the last step's, between 0.25 and 4 delta_max), so few pairs are searched where turns are
far apart.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.effects._band import add_coupling
from bathprint.core.effects._segment_geometry import (
    D_FLOOR_REL,
    _distance_derivs,
    build_candidate_pairs,
    closest_params,
    penalty,
    step_bound,
)
from bathprint.core.layout import MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes

SKIN_GROWTH = 2.5  # skin = SKIN_GROWTH x the last accepted step's relative node motion
SKIN_MIN = 0.25  # ... at least this many largest contact distances
SKIN_MAX = 4.0  # ... at most this many
TARGET_RATIO = 0.6  # steps are sized to keep the no-pass-through ratio near this (< 1)


def min_separation_for(delta: float, dl: float) -> int:
    """Segments i < j pair only if j - i > this: max(2, ceil(1.6 delta / dl)).

    A rod of radius r = delta/2 cannot bend tighter than a radius of curvature of about r;
    on such a tightest arc two centre-line points an arclength L apart are delta sin(L /
    delta) <= delta apart, so every pair within pi delta / 2 of arclength would always be
    "in contact". Segments i and j are (j - i - 1) dl apart along the rod: j - i >
    min_separation keeps (j - i - 1) dl >= 1.6 delta > pi delta / 2; the floor of 2 drops
    neighbours and next neighbours, which share a node or a segment."""
    return max(2, math.ceil(1.6 * delta / dl))


@njit(cache=True)
def _delta_max(model, rod) -> float:
    """The largest contact distance on the rod (m)."""
    p = model.params[0]
    r_max = 0.0
    for j in range(filament_segments(rod.n_nodes, p)):
        r_max = max(r_max, rod.seg_mat[j, MAT_RADIUS])
    return 2.0 * p.contact_distance_factor * r_max


@njit(cache=True)
def prepare(model, whole, frozen: int, contact) -> bool:
    """Candidate pairs at the start of a step (search distance delta_max + skin), over the
    whole filament: active segments with each other and with the frozen tail (an obstacle),
    in whole-filament segment numbers; False when they do not fit in ``contact.pairs``
    (grow it and call again)."""
    p = model.params[0]
    mem = contact.memory[0]
    n_seg = filament_segments(whole.n_nodes, p)
    delta_max = _delta_max(model, whole)
    if mem.skin <= 0.0 or mem.delta_max != delta_max:
        mem.skin = delta_max  # the first step, or the rod's radius changed
    mem.delta_max = delta_max
    mem.min_separation = max(2, math.ceil(1.6 * delta_max / p.node_spacing))
    n = build_candidate_pairs(
        whole.pos,
        whole.n_nodes,
        0,
        n_seg,
        delta_max + mem.skin,
        mem.min_separation,
        contact.cell_start,
        contact.seg_order,
        contact.seg_cell,
        contact.seen,
        contact.pairs,
        frozen,
    )
    contact.count[0] = n
    return n <= contact.pairs.shape[0]


@njit(cache=True)
def check(whole, pos0, frozen: int, contact, work, x) -> float:
    """The no-pass-through ratio of a step from ``pos0`` (the active nodes at its start) to
    the whole rod's positions (< 1: no segments can have crossed and the candidate list
    missed no contact); the worst pair and the nodes' relative motion go into
    ``contact.memory``. ``work`` (3,), ``x`` (12,): scratch."""
    mem = contact.memory[0]
    n_pairs = min(contact.count[0], contact.pairs.shape[0])
    ratio = step_bound(
        pos0, whole.pos, frozen, contact.pairs, n_pairs, whole.n_nodes, mem.skin, work, x
    )
    mem.ratio = ratio
    mem.pair_i = int(work[0])
    mem.pair_j = int(work[1])
    mem.max_step_disp = work[2]
    return ratio


@njit(cache=True)
def accepted(contact, h: float) -> None:
    """After an accepted step of h (s): the next skin follows the motion of this one."""
    mem = contact.memory[0]
    mem.last_ratio = mem.ratio
    mem.last_step = h
    mem.skin = min(
        max(SKIN_GROWTH * 2.0 * mem.max_step_disp, SKIN_MIN * mem.delta_max),
        SKIN_MAX * mem.delta_max,
    )


@njit(cache=True)
def step_limit(contact) -> float:
    """A bound on the next step (s) from the last one's no-pass-through ratio r: steps scale
    the relative motion, so a step of TARGET_RATIO / r times the last keeps the ratio near
    TARGET_RATIO instead of running into the bound and being retried (inf while r is low)."""
    mem = contact.memory[0]
    if mem.last_step <= 0.0 or mem.last_ratio <= 0.5 * TARGET_RATIO:
        return np.inf
    return mem.last_step * TARGET_RATIO / mem.last_ratio


@njit(cache=True)
def accumulate(model, rod, stage, out) -> float:
    """Add contact (and friction) forces of the candidate pairs, and their Jacobian with the
    blocks between distant nodes into ``out.cpl``; return the contact energy (J).

    Pairs are in whole-filament numbers (``out.whole``). A frozen tail is an obstacle that
    follows the first active node (as it does after each step): its nodes sit at their
    places plus that node's displacement in the step, and the force on them goes to that
    node, so in the Jacobian their rows and columns are its."""
    p = model.params[0]
    whole = out.whole
    f = out.frozen
    pos, vel, seg_rest, seg_mat = whole.pos, whole.vel, whole.seg_rest, whole.seg_mat
    force = out.force
    contact = out.contact
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(whole.n_nodes, p)
    do_jac = stage.jac
    cx, cv = stage.cx, stage.cv
    grad = out.scratch.pair_grad
    hess = out.scratch.pair_hess
    blk = out.scratch.blk_a
    k_pa = p.contact_stiffness
    factor = p.contact_distance_factor
    mu_f = p.contact_friction
    eps = p.contact_friction_velocity
    exact = p.contact_exact_hessian
    energy = 0.0
    x = out.scratch.pair_x
    for q in range(min(contact.count[0], contact.pairs.shape[0])):
        i = contact.pairs[q, 0]
        j = contact.pairs[q, 1]
        if i >= n_seg or j >= n_seg:
            continue
        delta = factor * (seg_mat[i, MAT_RADIUS] + seg_mat[j, MAT_RADIUS])
        # the pair's nodes: a frozen node sits at its place plus the first active node's
        # displacement in this step (the tail follows it)
        nodes = (i - f, i + 1 - f, j - f, j + 1 - f)  # active-rod numbers, < 0: frozen
        whole_nodes = (i, i + 1, j, j + 1)
        for a in range(4):
            g = whole_nodes[a]
            for c in range(3):
                shift = rod.pos[c] - out.start[c] if nodes[a] < 0 else 0.0
                x[3 * a + c] = pos[3 * g + c] + shift
        # bounding spheres first: midpoints farther than delta + half of both lengths apart
        # cannot touch (most candidates, far from contact, stop here)
        reach = delta + 0.5 * (seg_rest[i] + seg_rest[j]) * 1.5  # (segments may stretch)
        mid2 = 0.0
        for c in range(3):
            dm = 0.5 * (x[c] + x[3 + c] - x[6 + c] - x[9 + c])
            mid2 += dm * dm
        if mid2 > reach * reach:
            continue
        s, t, s_free, t_free, dist2 = closest_params(x, 0, 1, 2, 3)
        if dist2 >= delta * delta:
            continue
        d = _distance_derivs(x, 0, 1, 2, 3, s, t, s_free, t_free, D_FLOOR_REL * delta, grad, hess)
        k_c = k_pa * 0.5 * (seg_rest[i] + seg_rest[j])
        e, e_p, e_pp = penalty(delta - d, k_c, p.contact_width_fraction * delta)
        energy += e
        # E(d) = P(delta - d): force -dE/dx = P' grad d; Hessian P'' gd gd^T - P' Hess d.
        # A frozen node's row and column are the first active node's (it follows that node).
        for a in range(4):
            node = max(nodes[a], 0)
            for c in range(3):
                force[3 * node + c] += e_p * grad[3 * a + c]
        if do_jac and cx != 0.0:
            for a in range(4):
                for b in range(4):
                    for r in range(3):
                        for c in range(3):
                            blk[r, c] = e_pp * grad[3 * a + r] * grad[3 * b + c]
                            if exact:
                                blk[r, c] -= e_p * hess[3 * a + r, 3 * b + c]
                    row = max(nodes[a], 0)
                    col = max(nodes[b], 0)
                    add_coupling(out.band, out.cpl, n_free, row, col, blk, cx)
        if mu_f > 0.0:
            _friction(vel, i, j, nodes, s, t, grad, e_p, mu_f, eps, force, out, n_free, cv, do_jac)
    return energy


@njit(cache=True, inline="always")
def _friction(vel, i, j, nodes, s, t, grad, normal, mu_f, eps, force, out, n_free, cv, do_jac):
    """Regularised Coulomb friction on the tangential relative velocity of the closest
    points of segments i, j (whole-filament numbers; ``nodes``: active-rod numbers, < 0 in
    the frozen tail); normal direction from the distance gradient (grad d at node i0 is
    (1 - s) n)."""
    w = ((1.0 - s), s, -(1.0 - t), -t)  # closest point of A minus that of B
    # the unit normal: grad d of the pair = alpha_k n with alpha = (1-s, s, t-1, -t)
    n0 = grad[0] + grad[3]
    n1 = grad[1] + grad[4]
    n2 = grad[2] + grad[5]
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if nn == 0.0:
        return
    n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
    whole_nodes = (i, i + 1, j, j + 1)
    u0 = u1 = u2 = 0.0
    for a in range(4):
        b = 3 * whole_nodes[a]
        u0 += w[a] * vel[b]
        u1 += w[a] * vel[b + 1]
        u2 += w[a] * vel[b + 2]
    un = u0 * n0 + u1 * n1 + u2 * n2
    t0, t1, t2 = u0 - un * n0, u1 - un * n1, u2 - un * n2
    sq = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2 + eps * eps)
    mag = mu_f * normal / sq
    ft = (-mag * t0, -mag * t1, -mag * t2)  # on A's closest point; -ft on B's
    for a in range(4):
        b = 3 * max(nodes[a], 0)
        for c in range(3):
            force[b + c] += w[a] * ft[c]
    if not do_jac:
        return
    # dF_A/du = -mu N [P / sq - (P u)(P u)^T / sq^3], P = I - n n^T; node blocks w_a w_b
    ut = (t0, t1, t2)
    nv = (n0, n1, n2)
    blk = out.scratch.blk_b
    for a in range(4):
        for b in range(4):
            ww = w[a] * w[b]
            for r in range(3):
                for c in range(3):
                    proj = (1.0 if r == c else 0.0) - nv[r] * nv[c]
                    dfdu = -mu_f * normal * (proj / sq - ut[r] * ut[c] / (sq * sq * sq))
                    blk[r, c] = -ww * dfdu
            add_coupling(out.band, out.cpl, n_free, max(nodes[a], 0), max(nodes[b], 0), blk, cv)

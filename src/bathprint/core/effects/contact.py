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
def prepare(model, rod, contact) -> bool:
    """Candidate pairs of the active rod at the start of a step (search distance delta_max +
    skin); False when they do not fit in ``contact.pairs`` (grow it and call again)."""
    p = model.params[0]
    mem = contact.memory[0]
    n_seg = filament_segments(rod.n_nodes, p)
    delta_max = _delta_max(model, rod)
    if mem.skin <= 0.0 or mem.delta_max != delta_max:
        mem.skin = delta_max  # the first step, or the rod's radius changed
    mem.delta_max = delta_max
    mem.min_separation = max(2, math.ceil(1.6 * delta_max / p.node_spacing))
    n = build_candidate_pairs(
        rod.pos,
        rod.n_nodes,
        0,
        n_seg,
        delta_max + mem.skin,
        mem.min_separation,
        contact.cell_start,
        contact.seg_order,
        contact.seg_cell,
        contact.seen,
        contact.pairs,
    )
    contact.count[0] = n
    return n <= contact.pairs.shape[0]


@njit(cache=True)
def check(rod, pos0, contact, work) -> float:
    """The no-pass-through ratio of a step from ``pos0`` to the rod's positions (< 1: no
    segments can have crossed and the candidate list missed no contact); the worst pair and
    the nodes' relative motion go into ``contact.memory``. ``work``: (3,) scratch."""
    mem = contact.memory[0]
    n_pairs = min(contact.count[0], contact.pairs.shape[0])
    ratio = step_bound(pos0, rod.pos, contact.pairs, n_pairs, rod.n_nodes, mem.skin, work)
    mem.ratio = ratio
    mem.pair_i = int(work[0])
    mem.pair_j = int(work[1])
    mem.max_step_disp = work[2]
    return ratio


@njit(cache=True)
def accepted(contact) -> None:
    """After an accepted step: the next skin follows the motion of this one."""
    mem = contact.memory[0]
    mem.skin = min(
        max(SKIN_GROWTH * 2.0 * mem.max_step_disp, SKIN_MIN * mem.delta_max),
        SKIN_MAX * mem.delta_max,
    )


@njit(cache=True)
def accumulate(model, rod, stage, out) -> float:
    """Add contact (and friction) forces of the candidate pairs, and their Jacobian with the
    blocks between distant nodes into ``out.cpl``; return the contact energy (J)."""
    p = model.params[0]
    pos, vel, seg_rest, seg_mat = rod.pos, rod.vel, rod.seg_rest, rod.seg_mat
    force = out.force
    contact = out.contact
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    do_jac = stage.jac
    cx, cv = stage.cx, stage.cv
    grad = out.scratch.pair_grad
    hess = out.scratch.pair_hess
    blk = out.scratch.blk_a
    k_pa = p.contact_stiffness
    factor = p.contact_distance_factor
    mu_f = p.contact_friction
    eps = p.contact_friction_velocity
    energy = 0.0
    for q in range(min(contact.count[0], contact.pairs.shape[0])):
        i = contact.pairs[q, 0]
        j = contact.pairs[q, 1]
        if i >= n_seg or j >= n_seg:
            continue
        delta = factor * (seg_mat[i, MAT_RADIUS] + seg_mat[j, MAT_RADIUS])
        s, t, s_free, t_free, dist2 = closest_params(pos, i, i + 1, j, j + 1)
        if dist2 >= delta * delta:
            continue
        d = _distance_derivs(
            pos, i, i + 1, j, j + 1, s, t, s_free, t_free, D_FLOOR_REL * delta, grad, hess
        )
        k_c = k_pa * 0.5 * (seg_rest[i] + seg_rest[j])
        e, e_p, e_pp = penalty(delta - d, k_c, p.contact_width_fraction * delta)
        energy += e
        nodes = (i, i + 1, j, j + 1)
        # E(d) = P(delta - d): force -dE/dx = P' grad d; Hessian P'' gd gd^T - P' Hess d
        for a in range(4):
            for c in range(3):
                force[3 * nodes[a] + c] += e_p * grad[3 * a + c]
        if do_jac and cx != 0.0:
            for a in range(4):
                for b in range(4):
                    for r in range(3):
                        for c in range(3):
                            blk[r, c] = (
                                e_pp * grad[3 * a + r] * grad[3 * b + c]
                                - e_p * hess[3 * a + r, 3 * b + c]
                            )
                    add_coupling(out.band, out.cpl, n_free, nodes[a], nodes[b], blk, cx)
        if mu_f > 0.0:
            _friction(vel, nodes, s, t, grad, e_p, mu_f, eps, force, out, n_free, cv, do_jac)
    return energy


@njit(cache=True, inline="always")
def _friction(vel, nodes, s, t, grad, normal, mu_f, eps, force, out, n_free, cv, do_jac):
    """Regularised Coulomb friction on the tangential relative velocity of the closest
    points; normal direction from the distance gradient (grad d at node i0 is (1 - s) n)."""
    w = ((1.0 - s), s, -(1.0 - t), -t)  # closest point of A minus that of B
    # the unit normal: grad d of the pair = alpha_k n with alpha = (1-s, s, t-1, -t)
    n0 = grad[0] + grad[3]
    n1 = grad[1] + grad[4]
    n2 = grad[2] + grad[5]
    nn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
    if nn == 0.0:
        return
    n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
    u0 = u1 = u2 = 0.0
    for a in range(4):
        b = 3 * nodes[a]
        u0 += w[a] * vel[b]
        u1 += w[a] * vel[b + 1]
        u2 += w[a] * vel[b + 2]
    un = u0 * n0 + u1 * n1 + u2 * n2
    t0, t1, t2 = u0 - un * n0, u1 - un * n1, u2 - un * n2
    sq = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2 + eps * eps)
    mag = mu_f * normal / sq
    ft = (-mag * t0, -mag * t1, -mag * t2)  # on A's closest point; -ft on B's
    for a in range(4):
        b = 3 * nodes[a]
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
            add_coupling(out.band, out.cpl, n_free, nodes[a], nodes[b], blk, cv)

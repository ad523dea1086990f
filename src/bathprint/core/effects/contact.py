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
band (``out.cpl``, solved by GMRES in :mod:`bathprint.core.solver`). Nearly parallel
segments (below ``contact.parallel_angle_deg``, blended up to twice it) touch at the middle
of their overlap instead of their closest points, that point held in the derivatives
(:func:`~bathprint.core.effects._segment_geometry.contact_params`): their closest points
slide ~1/sin(angle) as fast as they move across each other, and Newton with them.

Optional friction between touching segments (``contact.friction_coefficient`` mu > 0):
regularised Coulomb on the tangential relative velocity u_t of the closest points,
F = -mu N u_t / sqrt(|u_t|^2 + u_eps^2) on A (and the opposite on B), N = dE/dp the normal
force, distributed to the nodes by the closest-point weights. Its velocity Jacobian is exact
with the geometry (normal, closest points, N) held at the iterate (as the floor holds N).

Optional damping of touching segments (``contact.damping_time_s`` beta > 0): a normal
dashpot F = -beta E''(p) (dd/dt) grad d, the linear spring-dashpot of the discrete element
method (Cundall & Strack 1979, Geotechnique 29, 47) with the penalty's own stiffness, so a
pressed contact relaxes over beta, and its damping grows from zero with the penetration, so
a first touch meets no damping force (the point of Hunt & Crossley's law, 1975, J. Appl.
Mech. 42, 440). PyElastica's rod contact carries such a damping (its ``nu``). It stands,
roughly, for what dissipates when two turns press together in the bath, the squeeze film
first; it matters with ``inertia``, where touching turns are otherwise a spring between
masses with almost no damping (overdamped, its couplings stall GMRES on a pile).

Candidate pairs come from a uniform spatial hash with a search distance delta_max + skin,
kept as a Verlet list (:func:`prepare`): rebuilt when two nodes may have closed half the
skin since (twice the largest motion relative to the common motion), when nodes are born or
freeze, or when the radius changes. An accepted step must keep every pair's relative node
displacement below its start distance, and every node's motion relative to the common
motion below half the skin (:func:`check`, the no-pass-through bound): otherwise it is
retried shorter, never accepted. The skin follows the motion (SKIN_STEPS x the last
step's, between SKIN_MIN and SKIN_MAX delta_max), so few pairs are searched where turns are
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
    _start_distance,
    build_candidate_pairs,
    contact_params,
    penalty,
    segment_distance,
)
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import E_FLOOR, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes

SKIN_STEPS = 8.0  # the hash's skin covers about this many steps of relative node motion
SKIN_MIN = 0.25  # ... and at least this many largest contact distances
SKIN_MAX = 2.0  # ... at most this many
MARGIN_STEPS = 1.5  # near pairs: closer than delta + this many steps' relative motion
OWN_MARGIN_STEPS = 3.0  # a pair's own margin: this many times its nodes' motion in the last step
TARGET_RATIO = 0.6  # steps are sized to keep the no-pass-through ratio near this (< 1)
BOUND_SAFETY = 1.0 + 1e-9  # widens the bound on a pair's motion past round-off


def min_separation_for(delta: float, dl: float) -> int:
    """Segments i < j pair only if j - i > this: max(2, ceil(1.6 delta / dl)).

    A rod of radius r = delta/2 cannot bend tighter than a radius of curvature of about r;
    on such a tightest arc two centre-line points an arclength L apart are delta sin(L /
    delta) <= delta apart, so every pair within pi delta / 2 of arclength would always be
    "in contact". Segments i and j are (j - i - 1) dl apart along the rod: j - i >
    min_separation keeps (j - i - 1) dl >= 1.6 delta > pi delta / 2; the floor of 2 drops
    neighbours and next neighbours, which share a node or a segment."""
    return max(2, math.ceil(1.6 * delta / dl))


@kernel
def _delta_max(model, rod) -> float:
    """The largest contact distance on the rod (m)."""
    p = model.params[0]
    r_max = 0.0
    for j in range(filament_segments(rod.n_nodes, p)):
        r_max = max(r_max, rod.seg_mat[j, MAT_RADIUS])
    return 2.0 * p.contact_distance_factor * r_max


@njit(**KERNEL)
def _motion(pos, ref, n_nodes: int, first: int, shift0, shift1, shift2) -> float:
    """max_i |(pos_i + s_i) - ref_i - c| over nodes 0..n-1, c the centre of the displacement
    box, s_i = (shift0, shift1, shift2) for nodes before ``first`` (the frozen tail's pending
    translation) and 0 after: the largest node motion relative to the common motion (m)."""
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    for g in range(n_nodes):
        s0, s1, s2 = (shift0, shift1, shift2) if g < first else (0.0, 0.0, 0.0)
        d0 = pos[3 * g] + s0 - ref[3 * g]
        d1 = pos[3 * g + 1] + s1 - ref[3 * g + 1]
        d2 = pos[3 * g + 2] + s2 - ref[3 * g + 2]
        lo0, hi0 = min(lo0, d0), max(hi0, d0)
        lo1, hi1 = min(lo1, d1), max(hi1, d1)
        lo2, hi2 = min(lo2, d2), max(hi2, d2)
    c0, c1, c2 = 0.5 * (lo0 + hi0), 0.5 * (lo1 + hi1), 0.5 * (lo2 + hi2)
    m2 = 0.0
    for g in range(n_nodes):
        s0, s1, s2 = (shift0, shift1, shift2) if g < first else (0.0, 0.0, 0.0)
        d0 = pos[3 * g] + s0 - ref[3 * g] - c0
        d1 = pos[3 * g + 1] + s1 - ref[3 * g + 1] - c1
        d2 = pos[3 * g + 2] + s2 - ref[3 * g + 2] - c2
        m2 = max(m2, d0 * d0 + d1 * d1 + d2 * d2)
    return math.sqrt(m2)


@njit(**KERNEL)
def prepare(model, whole, frozen: int, contact) -> bool:
    """At the start of a step: the candidate pairs (rebuilt only when needed), each pair's
    allowance (how far its nodes may move relative to each other in the step), and the
    pairs near enough to touch within the step; False when the pairs do not fit in
    ``contact.pairs`` (grow it and call again).

    The candidate pairs, whole-filament segment numbers (active segments with each other
    and with the frozen tail, an obstacle), are every pair within delta_max + skin when the
    spatial hash was built; they stay valid while no node has moved more than skin / 2
    relative to the common motion since (a Verlet list), and are rebuilt when that fails,
    when nodes are born or freeze, or when the radius changes. Of them, the pairs closer
    than their delta + margin are near: only those are evaluated in Newton's iterations.
    Each pair's margin comes from its own nodes' motion in the last step: any choice is
    safe (:func:`check` rejects a step that brings a pair left out within delta), a tight
    one is cheap where the coil has settled."""
    p = model.params[0]
    mem = contact.memory[0]
    n_nodes = whole.n_nodes
    n_seg = filament_segments(n_nodes, p)
    delta_max = _delta_max(model, whole)
    rebuild = mem.built_nodes != n_nodes or mem.built_frozen != frozen or mem.delta_max != delta_max
    if not rebuild:  # half the skin used up: rebuild now rather than retry the step
        m = _motion(whole.pos, contact.build_pos, n_nodes, 0, 0.0, 0.0, 0.0)
        rebuild = 2.0 * m >= 0.5 * mem.skin
    if rebuild:
        mem.built_nodes = -1
        mem.delta_max = delta_max
        mem.skin = min(
            max(SKIN_STEPS * 2.0 * mem.max_step_disp, SKIN_MIN * delta_max),
            SKIN_MAX * delta_max,
        )
        mem.min_separation = max(2, math.ceil(1.6 * delta_max / p.node_spacing))
        n = build_candidate_pairs(
            whole.pos,
            n_nodes,
            0,
            n_seg,
            delta_max + mem.skin,
            mem.min_separation,
            contact.cell_start,
            contact.seg_order,
            contact.seg_cell,
            contact.stamp,
            contact.boxes,
            contact.pairs,
            frozen,
        )
        contact.count[0] = n
        if n > contact.pairs.shape[0]:
            return False
        for k in range(3 * n_nodes):
            contact.build_pos[k] = whole.pos[k]
        mem.built_nodes = n_nodes
        mem.built_frozen = frozen
        mem.builds += 1
    # each pair's margin: OWN_MARGIN_STEPS times a bound on its relative motion in the last
    # step (the nodes' own motions; nodes born since take the largest), at least
    # ``contact.near_gap_fraction`` delta_max and at most the global margin: the settled
    # part of a coil, which hardly moves, is evaluated only near where it touches, while a
    # fast stem keeps a wide margin. The floor matters: a pair left out bounds the step by
    # the gap it may close, and a margin from the last step alone would shrink with the
    # steps it shortens, so an approaching pair would keep the steps short until it touched
    margin = mem.margin if mem.margin > 0.0 else mem.skin
    own = mem.margin > 0.0 and mem.motion_nodes > 0
    nm = contact.motion[0]
    if own:
        for g in range(mem.motion_nodes, n_nodes):
            nm[0, g] = mem.max_step_disp
            nm[1, g] = np.inf
    margin_min = p.contact_near_gap * delta_max
    factor = p.contact_distance_factor
    seg_mat = whole.seg_mat
    pos = whole.pos
    for k in range(3 * n_nodes):
        contact.start_pos[k] = pos[k]
    mid = contact.seg_mid
    half = contact.seg_half
    for k in range(n_seg):
        e2 = 0.0
        for c in range(3):
            mid[3 * k + c] = 0.5 * (pos[3 * k + c] + pos[3 * k + 3 + c])
            e = pos[3 * k + 3 + c] - pos[3 * k + c]
            e2 += e * e
        half[k] = 0.5 * math.sqrt(e2)
    n_near = 0
    for q in range(contact.count[0]):
        i = contact.pairs[q, 0]
        j = contact.pairs[q, 1]
        delta = factor * (seg_mat[i, MAT_RADIUS] + seg_mat[j, MAT_RADIUS])
        m_q = margin
        if own:
            u_q = _pair_motion(nm, i, j)
            m_q = min(max(OWN_MARGIN_STEPS * u_q, margin_min), margin)
        near = delta + m_q
        # bounding spheres: every point of a segment is within half its length of its
        # midpoint, so d >= |m_i - m_j| - h_i - h_j; a pair whose bound is beyond ``near``
        # is not near, and keeps minus that bound (check computes the distance only if
        # the bound cannot settle the pair)
        reach = near + half[i] + half[j]
        dm2 = 0.0
        for c in range(3):
            dm = mid[3 * i + c] - mid[3 * j + c]
            dm2 += dm * dm
        if dm2 >= reach * reach:
            contact.allowance[q] = -(math.sqrt(dm2) - half[i] - half[j] - delta)
            continue
        d = segment_distance(pos, i, i + 1, j, j + 1)
        if d < near:
            contact.allowance[q] = d
            contact.near[n_near] = q
            n_near += 1
        else:
            contact.allowance[q] = d - delta
    mem.n_near = n_near
    return True


@kernel
def check(model, whole, pos0, frozen: int, contact) -> float:
    """The no-pass-through ratio of a step from ``pos0`` (the active nodes at its start) to
    the whole rod's positions now: < 1 when no segments can have crossed and no pair outside
    the near list came within its contact distance. The worst pair and this step's relative
    motion go into ``contact.memory``.

    With u a pair's largest relative node displacement and d0 its start distance (the
    distance is 1-Lipschitz in the relative displacement, so d >= d0 - u along the step):
    a near pair must keep u < d0 (no crossing), any other u < d0 - delta (it was left out of
    Newton's iterations); and no node may have moved skin / 2 relative to the common motion
    since the pairs were found (so no pair missing from the list came within delta; if
    that fails the pairs are found again before the step is retried). The frozen tail
    moves with the first active node."""
    p = model.params[0]
    mem = contact.memory[0]
    n_nodes = whole.n_nodes
    pos = whole.pos
    f = frozen
    sh0 = pos[3 * f] - pos0[0]
    sh1 = pos[3 * f + 1] - pos0[1]
    sh2 = (pos[3 * f + 2] - pos0[2]) * _tail_z(model, f)
    # this step's motion (pos0 holds the active nodes, from f; the tail moves with node f)
    nm = contact.motion[0]
    m_step = _step_motion(pos, pos0, n_nodes, f, sh0, sh1, sh2, nm)
    m_build = _motion(pos, contact.build_pos, n_nodes, f, sh0, sh1, sh2)
    worst = 2.0 * m_build / mem.skin
    worst_i = -1
    worst_j = -1
    factor = p.contact_distance_factor
    seg_mat = whole.seg_mat
    for q in range(contact.count[0]):
        i = contact.pairs[q, 0]
        j = contact.pairs[q, 1]
        # a bound on the pair's relative motion u from the nodes' own motions; a pair whose
        # bound cannot beat the worst ratio so far is settled without the exact u (the worst
        # ratio is the exact one)
        u_bound = _pair_motion(nm, i, j) * BOUND_SAFETY
        gap = contact.allowance[q]
        if gap < 0.0:  # minus a lower bound of the allowance (a pair that was not near)
            if u_bound <= worst * -gap:
                continue
            delta = factor * (seg_mat[i, MAT_RADIUS] + seg_mat[j, MAT_RADIUS])
            gap = _start_distance(pos0, pos, f, i, j, contact.pair_x) - delta
            contact.allowance[q] = gap
        if u_bound <= worst * gap:
            continue
        u2 = 0.0
        for a in (i, i + 1):
            for b in (j, j + 1):
                w2 = 0.0
                for c in range(3):
                    sa = (sh0, sh1, sh2)[c] if a < f else 0.0
                    sb = (sh0, sh1, sh2)[c] if b < f else 0.0
                    da = (pos[3 * a + c] + sa) - (
                        pos0[3 * (a - f) + c] if a >= f else pos[3 * a + c]
                    )
                    db = (pos[3 * b + c] + sb) - (
                        pos0[3 * (b - f) + c] if b >= f else pos[3 * b + c]
                    )
                    w2 += (da - db) * (da - db)
                u2 = max(u2, w2)
        if u2 == 0.0:
            continue
        ratio = math.sqrt(u2) / gap if gap > 0.0 else np.inf
        if ratio > worst:
            worst = ratio
            worst_i = i
            worst_j = j
    mem.ratio = worst
    mem.pair_i = worst_i
    mem.pair_j = worst_j
    mem.max_step_disp = m_step
    mem.motion_nodes = n_nodes
    if worst >= 1.0 and worst_i < 0:
        mem.built_nodes = -1  # the list ran out of skin: find the pairs again for the retry
    return worst


@njit(**KERNEL)
def _step_motion(pos, pos0, n_nodes: int, f: int, sh0, sh1, sh2, motion) -> float:
    """The largest node displacement of the step relative to the common motion (m): active
    nodes from pos0 (from f) to pos, frozen nodes by the tail's pending translation; each
    node's into ``motion`` (2, cap) (m): relative to the common motion, and absolute."""
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    for g in range(n_nodes):
        if g < f:
            d0, d1, d2 = sh0, sh1, sh2
        else:
            k = 3 * (g - f)
            d0 = pos[3 * g] - pos0[k]
            d1 = pos[3 * g + 1] - pos0[k + 1]
            d2 = pos[3 * g + 2] - pos0[k + 2]
        lo0, hi0 = min(lo0, d0), max(hi0, d0)
        lo1, hi1 = min(lo1, d1), max(hi1, d1)
        lo2, hi2 = min(lo2, d2), max(hi2, d2)
    c0, c1, c2 = 0.5 * (lo0 + hi0), 0.5 * (lo1 + hi1), 0.5 * (lo2 + hi2)
    m2 = 0.0
    for g in range(n_nodes):
        if g < f:
            d0, d1, d2 = sh0 - c0, sh1 - c1, sh2 - c2
        else:
            k = 3 * (g - f)
            d0 = pos[3 * g] - pos0[k] - c0
            d1 = pos[3 * g + 1] - pos0[k + 1] - c1
            d2 = pos[3 * g + 2] - pos0[k + 2] - c2
        w2 = d0 * d0 + d1 * d1 + d2 * d2
        motion[0, g] = math.sqrt(w2)
        d0, d1, d2 = d0 + c0, d1 + c1, d2 + c2
        motion[1, g] = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        m2 = max(m2, w2)
    return math.sqrt(m2)


@njit(**KERNEL, inline="always")
def _pair_motion(motion, i: int, j: int) -> float:
    """A bound (m) on the relative displacement of the nodes of segments i and j:
    |dx_a - dx_b| <= |dx_a - c| + |dx_b - c| for any c, taken with c the common motion
    (``motion[0]``) and with c = 0 (``motion[1]``: where a fast stem moves the common motion
    away from a pile at rest)."""
    common = max(motion[0, i], motion[0, i + 1]) + max(motion[0, j], motion[0, j + 1])
    still = max(motion[1, i], motion[1, i + 1]) + max(motion[1, j], motion[1, j + 1])
    return min(common, still)


@kernel
def accepted(model, contact, h: float) -> None:
    """After an accepted step of h (s): remember its ratio and step for the next step's
    size, and set the near margin from its motion."""
    mem = contact.memory[0]
    mem.last_ratio = mem.ratio
    mem.last_step = h
    near_gap = model.params[0].contact_near_gap * mem.delta_max
    mem.margin = min(max(MARGIN_STEPS * 2.0 * mem.max_step_disp, near_gap), mem.skin)


@kernel
def step_limit(contact) -> float:
    """A bound on the next step (s) from the last one's no-pass-through ratio r: steps scale
    the relative motion, so a step of TARGET_RATIO / r times the last keeps the ratio near
    TARGET_RATIO instead of running into the bound and being retried (inf while r is low)."""
    mem = contact.memory[0]
    if mem.last_step <= 0.0 or mem.last_ratio <= 0.5 * TARGET_RATIO:
        return np.inf
    return mem.last_step * TARGET_RATIO / mem.last_ratio


@njit(**KERNEL)
def accumulate(model, rod, stage, out) -> float:
    """Add contact (and its dashpot's and friction's) forces of the candidate pairs, and their
    Jacobian with the blocks between distant nodes into ``out.cpl``; return the contact
    energy (J).

    Pairs are in whole-filament numbers (``out.whole``). A frozen tail is an obstacle that
    follows the first active node (as it does after each step): its nodes sit at their
    places plus that node's displacement in the step, and the force on them goes to that
    node, so in the Jacobian their rows and columns are its. On the floor the tail follows
    it horizontally only (its height stays, the floor carries its vertical load): the
    frozen nodes' vertical displacement, velocity, force and Jacobian entries are zero."""
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
    beta = p.contact_damping_time
    exact = p.contact_exact_hessian
    energy = 0.0
    hess_needed = do_jac and cx != 0.0 and exact
    x = out.scratch.pair_x
    # each node's motion since the step's start: a near pair that started farther apart
    # than delta plus the bound on its nodes' relative motion cannot touch (d >= d0 - u),
    # and is passed over without its distance
    nm = contact.motion[1]
    sh0 = rod.pos[0] - out.start[0]
    sh1 = rod.pos[1] - out.start[1]
    tail_z = _tail_z(model, f)
    sh2 = (rod.pos[2] - out.start[2]) * tail_z
    _step_motion(pos, contact.start_pos[3 * f :], whole.n_nodes, f, sh0, sh1, sh2, nm)
    for k in range(contact.memory[0].n_near):
        q = contact.near[k]
        i = contact.pairs[q, 0]
        j = contact.pairs[q, 1]
        if i >= n_seg or j >= n_seg:
            continue
        delta = factor * (seg_mat[i, MAT_RADIUS] + seg_mat[j, MAT_RADIUS])
        u_bound = _pair_motion(nm, i, j) * BOUND_SAFETY
        if contact.allowance[q] - u_bound >= delta * BOUND_SAFETY:
            continue
        # the pair's nodes: a frozen node sits at its place plus the first active node's
        # displacement in this step (the tail follows it)
        nodes = (i - f, i + 1 - f, j - f, j + 1 - f)  # active-rod numbers, < 0: frozen
        whole_nodes = (i, i + 1, j, j + 1)
        for a in range(4):
            g = whole_nodes[a]
            for c in range(3):
                shift = rod.pos[c] - out.start[c] if nodes[a] < 0 else 0.0
                x[3 * a + c] = pos[3 * g + c] + shift * _follows(nodes, a, c, tail_z)
        # bounding spheres first: midpoints farther than delta + half of both lengths apart
        # cannot touch (most candidates, far from contact, stop here)
        reach = delta + 0.5 * (seg_rest[i] + seg_rest[j]) * 1.5  # (segments may stretch)
        mid2 = 0.0
        for c in range(3):
            dm = 0.5 * (x[c] + x[3 + c] - x[6 + c] - x[9 + c])
            mid2 += dm * dm
        if mid2 > reach * reach:
            continue
        s, t, s_free, t_free, dist2 = contact_params(
            x, 0, 1, 2, 3, p.contact_parallel_sin2, p.contact_sliding_sin2
        )
        if dist2 >= delta * delta:
            continue
        d = _distance_derivs(
            x, 0, 1, 2, 3, s, t, s_free, t_free, D_FLOOR_REL * delta, grad, hess, hess_needed
        )
        k_c = k_pa * 0.5 * (seg_rest[i] + seg_rest[j])
        e, e_p, e_pp = penalty(delta - d, k_c, p.contact_width_fraction * delta)
        energy += e
        # E(d) = P(delta - d): force -dE/dx = P' grad d; Hessian P'' gd gd^T - P' Hess d.
        # A frozen node's row and column are the first active node's (it follows that node).
        for a in range(4):
            node = max(nodes[a], 0)
            for c in range(3):
                force[3 * node + c] += e_p * grad[3 * a + c] * _follows(nodes, a, c, tail_z)
        if do_jac and cx != 0.0:
            for a in range(4):
                for b in range(4):
                    for r in range(3):
                        for c in range(3):
                            blk[r, c] = e_pp * grad[3 * a + r] * grad[3 * b + c]
                            if exact:
                                blk[r, c] -= e_p * hess[3 * a + r, 3 * b + c]
                    _add_pair_block(out, n_free, nodes, a, b, tail_z, blk, cx)
        if beta > 0.0 and e_pp > 0.0:
            c_d = beta * e_pp
            _dashpot(rod.vel, vel, whole_nodes, nodes, tail_z, grad, c_d, out, n_free, cv, do_jac)
        if mu_f > 0.0:
            _friction(
                rod.vel,
                vel,
                whole_nodes,
                nodes,
                tail_z,
                s,
                t,
                grad,
                e_p,
                mu_f,
                eps,
                out,
                n_free,
                cv,
                do_jac,
            )
    return energy


@njit(**KERNEL, inline="always")
def _tail_z(model, frozen: int) -> float:
    """1 where a frozen tail follows the first active node vertically too; 0 on the floor,
    where it slides at its height (:mod:`bathprint.core.freezing`)."""
    return 0.0 if frozen > 0 and model.enabled[E_FLOOR] > 0 else 1.0


@njit(**KERNEL, inline="always")
def _follows(nodes, a: int, c: int, tail_z: float) -> float:
    """How component c of the pair's node a follows the first active node: 1, except the
    vertical component of a frozen node on the floor (``tail_z`` 0)."""
    return tail_z if nodes[a] < 0 and c == 2 else 1.0


@njit(**KERNEL, inline="always")
def _add_pair_block(out, n_free: int, nodes, a: int, b: int, tail_z: float, blk, coeff: float):
    """Add coeff * blk, the Jacobian block of the pair's nodes a (rows) and b (columns), at
    their node block; a frozen node's rows and columns are the first active node's, its
    vertical ones zero on the floor (:func:`_follows`)."""
    for r in range(3):
        for c in range(3):
            blk[r, c] *= _follows(nodes, a, r, tail_z) * _follows(nodes, b, c, tail_z)
    add_coupling(out.band, out.cpl, n_free, max(nodes[a], 0), max(nodes[b], 0), blk, coeff)


@njit(**KERNEL, inline="always")
def _node_velocity(active_vel, vel, nodes, whole_nodes, tail_z, a: int, c: int) -> float:
    """Component c (m/s) of the velocity of the pair's node a: a frozen node (``nodes[a]`` <
    0) moves with the first active node (``active_vel``; on the floor horizontally only),
    the others at their own."""
    if nodes[a] < 0:
        return active_vel[c] * _follows(nodes, a, c, tail_z)
    return vel[3 * whole_nodes[a] + c]


@njit(**KERNEL, inline="always")
def _dashpot(active_vel, vel, whole_nodes, nodes, tail_z, grad, c_d, out, n_free, cv, do_jac):
    """Kelvin-Voigt normal dashpot of a touching pair: F_a = -c_d (grad d . v) grad_a d on
    node a, c_d = beta E''(p) (N s/m), so a pressed contact relaxes in beta as a linear
    spring-dashpot does (Cundall & Strack 1979), and its damping starts at zero with the soft
    onset. It dissipates c_d (dd/dt)^2. A frozen node moves with the first active node
    (``active_vel``, the stage's; ``tail_z`` as :func:`_follows`); its velocity Jacobian
    holds c_d and grad d at the iterate."""
    force = out.force
    ddot = 0.0
    for a in range(4):
        for c in range(3):
            v = _node_velocity(active_vel, vel, nodes, whole_nodes, tail_z, a, c)
            ddot += grad[3 * a + c] * v
    for a in range(4):
        node = max(nodes[a], 0)
        for c in range(3):
            force[3 * node + c] -= c_d * ddot * grad[3 * a + c] * _follows(nodes, a, c, tail_z)
    if not (do_jac and cv != 0.0):
        return
    blk = out.scratch.blk_b
    for a in range(4):
        for b in range(4):
            for r in range(3):
                for c in range(3):
                    blk[r, c] = c_d * grad[3 * a + r] * grad[3 * b + c]
            _add_pair_block(out, n_free, nodes, a, b, tail_z, blk, cv)


@njit(**KERNEL, inline="always")
def _friction(
    active_vel,
    vel,
    whole_nodes,
    nodes,
    tail_z,
    s,
    t,
    grad,
    normal,
    mu_f,
    eps,
    out,
    n_free,
    cv,
    do_jac,
):
    """Regularised Coulomb friction on the tangential relative velocity of the closest
    points of the pair's segments (``whole_nodes``: their nodes' whole-filament numbers;
    ``nodes``: active-rod numbers, < 0 in the frozen tail, whose nodes move with the first
    active node, ``active_vel``); normal direction from the distance gradient (grad d at
    node i0 is (1 - s) n)."""
    force = out.force
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
        u0 += w[a] * _node_velocity(active_vel, vel, nodes, whole_nodes, tail_z, a, 0)
        u1 += w[a] * _node_velocity(active_vel, vel, nodes, whole_nodes, tail_z, a, 1)
        u2 += w[a] * _node_velocity(active_vel, vel, nodes, whole_nodes, tail_z, a, 2)
    un = u0 * n0 + u1 * n1 + u2 * n2
    t0, t1, t2 = u0 - un * n0, u1 - un * n1, u2 - un * n2
    sq = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2 + eps * eps)
    mag = mu_f * normal / sq
    ft = (-mag * t0, -mag * t1, -mag * t2)  # on A's closest point; -ft on B's
    for a in range(4):
        b = 3 * max(nodes[a], 0)
        for c in range(3):
            force[b + c] += w[a] * ft[c] * _follows(nodes, a, c, tail_z)
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
            _add_pair_block(out, n_free, nodes, a, b, tail_z, blk, cv)

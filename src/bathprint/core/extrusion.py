"""Extrusion: flow and needle schedules, the clamped inlet, and continuous growth.

Material leaves a needle of area A = pi d^2/4 at v(t) = Q(t)/A. The extruded arclength
S(t) = int Q/A dt is known in closed form from the piecewise-linear flow table, and each
node carries the value of S at which it left the needle. The inlet segment (from the last
free node to the needle tip) has rest length S(t) - s_last, so material grows continuously;
when it reaches twice the node spacing it is split in two equal halves. No segment is
ever shorter than the node spacing at birth, and the rest lengths always add up to the
printed length: printed volume = A (S(t) - S(0)) + initial volume, exactly.

Tables (all SI):
- ``flow``: (K, 3) rows [t_s, q_outer_m3_s, q_inner_m3_s], linear between knots, held
  constant outside; ``flow_cum``: (K, 2) rows [S, inner volume] at each knot (m, m^3).
- ``needle``: (M, 7) rows [t_s, x, y, z, dx, dy, dz], position linear, direction linear
  then normalised.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.composite import stiffness_factors
from bathprint.core.effects.gelation import set_material
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import (
    GEL_SURFACE,
    MAT_BEND_FACTOR,
    MAT_BIRTH_TIME,
    MAT_DENSITY,
    MAT_INCLUSION_SIZE,
    MAT_INCLUSION_SPACING,
    MAT_INNER_FRACTION,
    MAT_KAPPA_X,
    MAT_RADIUS,
    MAT_STRETCH_FACTOR,
    MAT_YOUNGS_MODULUS,
    N_MAT,
)


@njit(**KERNEL)
def _interval(table: np.ndarray, t: float) -> int:
    """Index k of the knot interval [t_k, t_k+1) holding t (-1 before the first knot): the
    smallest k with t < t_k+1, or the last knot's index; by bisection, since environments
    append a knot per action and query the table several times per step."""
    n = table.shape[0]
    if t < table[0, 0]:
        return -1
    lo = 0
    hi = n - 1  # (n - 1: no knot after t)
    while lo < hi:
        mid = (lo + hi) // 2
        if t < table[mid + 1, 0]:
            hi = mid
        else:
            lo = mid + 1
    return lo


@njit(**KERNEL)
def flow_rate(flow: np.ndarray, t: float) -> tuple[float, float]:
    """(Q_outer, Q_inner) in m^3/s at time t."""
    k = _interval(flow, t)
    if k < 0:
        return flow[0, 1], flow[0, 2]
    if k == flow.shape[0] - 1:
        return flow[k, 1], flow[k, 2]
    f = (t - flow[k, 0]) / (flow[k + 1, 0] - flow[k, 0])
    return (
        flow[k, 1] + f * (flow[k + 1, 1] - flow[k, 1]),
        flow[k, 2] + f * (flow[k + 1, 2] - flow[k, 2]),
    )


@njit(**KERNEL)
def extruded_length(flow: np.ndarray, flow_cum: np.ndarray, area: float, t: float) -> float:
    """S(t) = int_0^t (Q_o + Q_i)/A dt (m), exact for the piecewise-linear table."""
    k = _interval(flow, t)
    if k < 0:
        return flow_cum[0, 0] - (flow[0, 0] - t) * (flow[0, 1] + flow[0, 2]) / area
    qo, qi = flow_rate(flow, t)
    qk = flow[k, 1] + flow[k, 2]
    return flow_cum[k, 0] + 0.5 * (qk + qo + qi) * (t - flow[k, 0]) / area


@njit(**KERNEL)
def inner_volume(flow: np.ndarray, flow_cum: np.ndarray, t: float) -> float:
    """int_0^t Q_i dt (m^3), exact for the piecewise-linear table."""
    k = _interval(flow, t)
    if k < 0:
        return flow_cum[0, 1] - (flow[0, 0] - t) * flow[0, 2]
    _, qi = flow_rate(flow, t)
    return flow_cum[k, 1] + 0.5 * (flow[k, 2] + qi) * (t - flow[k, 0])


@njit(cache=True, error_model="numpy")
def flow_step(
    flow: np.ndarray, flow_cum: np.ndarray, area: float, t: float, qo: float, qi: float
) -> tuple[np.ndarray, np.ndarray]:
    """New (flow, flow_cum) tables for a step change of the flow rates to (qo, qi) m^3/s at
    time t (:meth:`bathprint.Simulation.set_flow`, which checks the values): the knots
    before t, a knot at t, the new flow 1 us later (knot times stay strictly rising), the
    last 64 kept (older ones are summarised in the cumulative table), and the cumulative
    table rebuilt from the first knot as :func:`bathprint.core.model.flow_cumulative` does."""
    n_old = flow.shape[0]
    n_keep = 0
    for i in range(n_old):
        if flow[i, 0] < t:
            n_keep += 1
    qo_now, qi_now = flow_rate(flow, t)
    n_all = n_keep + 2
    skip = max(n_all - 64, 0)
    n = n_all - skip
    new = np.empty((n, 3))
    r = 0
    k = 0
    for i in range(n_old):
        if flow[i, 0] < t:
            if k >= skip:
                new[r, 0], new[r, 1], new[r, 2] = flow[i, 0], flow[i, 1], flow[i, 2]
                r += 1
            k += 1
    new[r, 0], new[r, 1], new[r, 2] = t, qo_now, qi_now
    new[r + 1, 0], new[r + 1, 1], new[r + 1, 2] = t + 1e-6, qo, qi
    first = new[0, 0]
    cum = np.empty((n, 2))
    cum[0, 0] = extruded_length(flow, flow_cum, area, first)
    cum[0, 1] = inner_volume(flow, flow_cum, first)
    s0 = s1 = 0.0  # running sums, as np.cumsum (which starts from the first term)
    for i in range(1, n):
        dt = new[i, 0] - new[i - 1, 0]
        term0 = 0.5 * ((new[i - 1, 1] + new[i - 1, 2]) + (new[i, 1] + new[i, 2])) * dt
        term1 = 0.5 * (new[i - 1, 2] + new[i, 2]) * dt
        s0 = term0 if i == 1 else s0 + term0
        s1 = term1 if i == 1 else s1 + term1
        cum[i, 0] = cum[0, 0] + s0 / area
        cum[i, 1] = cum[0, 1] + s1
    return new, cum


@njit(**KERNEL)
def time_at_extruded_length(
    flow: np.ndarray, flow_cum: np.ndarray, area: float, s: float, t_hi: float
) -> float:
    """Earliest time (<= t_hi) at which S(t) reached s, by bisection on the monotone S."""
    if extruded_length(flow, flow_cum, area, t_hi) <= s:
        return t_hi
    width = 1.0
    t_lo = t_hi - width
    for _ in range(40):
        if extruded_length(flow, flow_cum, area, t_lo) <= s:
            break
        width *= 2.0
        t_lo = t_hi - width
    else:
        return t_hi - width  # never extruded that far back (no flow before t = 0): ~-1e12 s
    for _ in range(80):
        mid = 0.5 * (t_lo + t_hi)
        if extruded_length(flow, flow_cum, area, mid) < s:
            t_lo = mid
        else:
            t_hi = mid
    return 0.5 * (t_lo + t_hi)


@njit(**KERNEL)
def needle_state(needle: np.ndarray, t: float, p: np.ndarray, d: np.ndarray, v: np.ndarray) -> None:
    """Needle tip position p (m), unit direction d and tip velocity v (m/s) at time t."""
    k = _interval(needle, t)
    n = needle.shape[0]
    if k < 0 or k == n - 1:
        row = 0 if k < 0 else n - 1
        for a in range(3):
            p[a] = needle[row, 1 + a]
            d[a] = needle[row, 4 + a]
            v[a] = 0.0
    else:
        dt = needle[k + 1, 0] - needle[k, 0]
        f = (t - needle[k, 0]) / dt
        for a in range(3):
            p[a] = needle[k, 1 + a] + f * (needle[k + 1, 1 + a] - needle[k, 1 + a])
            d[a] = needle[k, 4 + a] + f * (needle[k + 1, 4 + a] - needle[k, 4 + a])
            v[a] = (needle[k + 1, 1 + a] - needle[k, 1 + a]) / dt
    nd = math.sqrt(d[0] ** 2 + d[1] ** 2 + d[2] ** 2)
    for a in range(3):
        d[a] /= nd


@njit(**KERNEL)
def set_boundary(model, rod, t: float, scratch) -> None:
    """Place the needle tip and the ghost node at time t and grow the inlet segment.

    Does nothing once the filament has been released from the needle.
    """
    prm = model.params[0]
    if not prm.clamped:
        return
    pos, vel, node_s, seg_rest = rod.pos, rod.vel, rod.node_s, rod.seg_rest
    p = scratch.needle[0]
    d = scratch.needle[1]
    v = scratch.needle[2]
    needle_state(model.needle, t, p, d, v)
    tip = rod.n_nodes - 2
    ghost = rod.n_nodes - 1
    dl = prm.node_spacing
    # with inertia the tip and the ghost carry the material's velocity: the needle's plus
    # the exit speed (Q_o + Q_i)/A along d, so that nodes born at the inlet leave with the
    # jet's momentum (at rest, every birth would brake the rod by rho A v^2)
    u = 0.0
    if prm.inertial:
        qo, qi = flow_rate(model.flow, t)
        u = (qo + qi) / prm.needle_area
    for a in range(3):
        pos[3 * tip + a] = p[a]
        pos[3 * ghost + a] = p[a] - dl * d[a]
        vel[3 * tip + a] = v[a] + u * d[a]
        vel[3 * ghost + a] = v[a] + u * d[a]
    s_tip = extruded_length(model.flow, model.flow_cum, prm.needle_area, t)
    node_s[tip] = s_tip
    seg_rest[tip - 1] = s_tip - node_s[tip - 1]
    if prm.liquid:  # its volume pi r_exit^2 (s_tip - s) at its present (relaxed) radius
        seg_rest[tip - 1] *= (prm.exit_radius / rod.seg_mat[tip - 1, MAT_RADIUS]) ** 2
    # The ghost segment only fixes the clamp direction. Its rest length enters nothing
    # but the tip's Voronoi length, which must be half the inlet segment alone so that
    # the rod is clamped at the tip itself (with dl here it would be clamped dl/2 inside
    # the needle: a first-order error of dl/2 in every length).
    seg_rest[tip] = 0.0


@njit(**KERNEL)
def material_row(
    phi: float, birth: float, t_now: float, direction: np.ndarray, p, row: np.ndarray
) -> None:
    """Material record of gel with inner fraction phi born at ``birth`` (s), seen at t_now.

    ``direction`` is the needle's unit direction at birth (for the offset's plane).
    Pure gel unless the inclusions effect is on; modulus from the gelation law if it is on
    (with gelation's surface model, also the shell's stiffness factors).
    ``p`` is the model's parameter record.
    """
    for c in range(N_MAT):
        row[c] = 0.0
    row[MAT_BIRTH_TIME] = birth
    if p.gelation:
        e0 = p.gel_initial_modulus
        e1 = p.gel_final_modulus
        row[MAT_YOUNGS_MODULUS] = e1 - (e1 - e0) * math.exp(-p.gel_rate * max(t_now - birth, 0.0))
    else:
        row[MAT_YOUNGS_MODULUS] = p.exit_youngs_modulus
    r = p.exit_radius
    row[MAT_RADIUS] = r
    if not p.inclusions:
        phi = 0.0
    bend, stretch, n, m = stiffness_factors(phi, p.slug_fraction)
    row[MAT_INNER_FRACTION] = phi
    row[MAT_DENSITY] = (1.0 - phi) * p.exit_density + phi * p.inner_density
    row[MAT_BEND_FACTOR] = bend
    row[MAT_STRETCH_FACTOR] = stretch
    row[MAT_INCLUSION_SIZE] = n * r
    row[MAT_INCLUSION_SPACING] = m * r
    if p.gelation and p.gel_model == GEL_SURFACE:  # a set shell around a liquid core
        set_material(row, t_now - birth, p)
    mag = p.curvature_coefficient * p.inclusion_offset * phi / r
    if mag != 0.0:
        d0, d1, d2 = direction[0], direction[1], direction[2]
        # e1 = d x (least-aligned axis), e2 = d x e1: the offset's frame around the needle
        if abs(d0) < 0.9:
            e10, e11, e12 = 0.0, d2, -d1
        else:
            e10, e11, e12 = -d2, 0.0, d0
        ne = math.sqrt(e10 * e10 + e11 * e11 + e12 * e12)
        e10, e11, e12 = e10 / ne, e11 / ne, e12 / ne
        e20, e21, e22 = d1 * e12 - d2 * e11, d2 * e10 - d0 * e12, d0 * e11 - d1 * e10
        ca = math.cos(p.offset_angle)
        sa = math.sin(p.offset_angle)
        u0, u1, u2 = ca * e10 + sa * e20, ca * e11 + sa * e21, ca * e12 + sa * e22
        # binormal t_up x u with t_up = -d, the segment's edge direction at birth
        row[MAT_KAPPA_X] = mag * (-(d1 * u2 - d2 * u1))
        row[MAT_KAPPA_X + 1] = mag * (-(d2 * u0 - d0 * u2))
        row[MAT_KAPPA_X + 2] = mag * (-(d0 * u1 - d1 * u0))


@kernel
def segment_material(s_a: float, s_b: float, t_now: float, model, row: np.ndarray, scratch) -> None:
    """Material record of the gel that left the needle between extruded lengths s_a < s_b.

    Its inner fraction is the inner volume extruded in that interval over the total, so
    the inner volume of all segments adds up to int Q_i dt exactly.
    """
    p = model.params[0]
    flow, flow_cum = model.flow, model.flow_cum
    area = p.needle_area
    t_a = time_at_extruded_length(flow, flow_cum, area, s_a, t_now)
    t_b = time_at_extruded_length(flow, flow_cum, area, s_b, t_now)
    t_mid = time_at_extruded_length(flow, flow_cum, area, 0.5 * (s_a + s_b), t_now)
    phi = 0.0
    if p.inclusions and s_b > s_a:
        dv_in = inner_volume(flow, flow_cum, t_b) - inner_volume(flow, flow_cum, t_a)
        phi = min(max(dv_in / (area * (s_b - s_a)), 0.0), 1.0)
    d = scratch.birth[1]
    pb = scratch.birth[0]
    v = scratch.birth[2]
    needle_state(model.needle, t_mid, pb, d, v)
    material_row(phi, t_mid, t_now, d, p, row)


@njit(**KERNEL)
def _hash_unit(seed: float, counter: int, salt: int) -> float:
    """Counter-based pseudo-random number in [-1, 1): same value whatever the chunking."""
    x = (int(seed) * 2654435761 + counter * 97531 + salt * 1013904223 + 12345) & 0xFFFFFFFF
    for _ in range(4):
        x ^= (x << 13) & 0xFFFFFFFF
        x ^= x >> 17
        x ^= (x << 5) & 0xFFFFFFFF
    return (x & 0xFFFFFF) / float(0x800000) - 1.0


@kernel
def split_inlet(model, rod, t: float, split_count: int, scratch) -> int:
    """Split the inlet segment of the (whole) rod in two; returns the new node count.

    The caller guarantees room for one more node. The outer half keeps the inlet's
    material with the birth time of its centre; the new inlet gets the exit material.
    """
    p = model.params[0]
    pos, vel, node_s, seg_rest, seg_mat = rod.pos, rod.vel, rod.node_s, rod.seg_rest, rod.seg_mat
    n_nodes = rod.n_nodes
    out = n_nodes - 3
    tip = n_nodes - 2
    # move tip and ghost one slot down the arrays
    for node in range(n_nodes - 1, tip - 1, -1):
        for a in range(3):
            pos[3 * (node + 1) + a] = pos[3 * node + a]
            vel[3 * (node + 1) + a] = vel[3 * node + a]
        node_s[node + 1] = node_s[node]
    seg_rest[tip + 1] = seg_rest[tip]  # ghost
    for c in range(N_MAT):
        seg_mat[tip + 1, c] = seg_mat[tip, c]
    new = tip
    s_out = node_s[out]
    s_tip = node_s[new + 1]
    dl = p.node_spacing
    # halves when the inlet is 2..3 node spacings long; after a long step, peel off
    # one spacing at a time so that no segment is left much longer than the others
    outer = 0.5 * (s_tip - s_out) if s_tip - s_out < 3.0 * dl else dl
    s_new = s_out + outer
    f = outer / (s_tip - s_out)
    node_s[new] = s_new
    for a in range(3):
        pos[3 * new + a] = pos[3 * out + a] + f * (pos[3 * (new + 1) + a] - pos[3 * out + a])
        vel[3 * new + a] = vel[3 * out + a] + f * (vel[3 * (new + 1) + a] - vel[3 * out + a])
    # imperfection: a tiny transverse offset, perpendicular to the local chord
    amp = p.imperfection
    if amp > 0.0:
        cx = pos[3 * (new + 1)] - pos[3 * out]
        cy = pos[3 * (new + 1) + 1] - pos[3 * out + 1]
        cz = pos[3 * (new + 1) + 2] - pos[3 * out + 2]
        nc = math.sqrt(cx * cx + cy * cy + cz * cz)
        cx, cy, cz = cx / nc, cy / nc, cz / nc
        # first perpendicular: cross with the least-aligned axis
        if abs(cx) < 0.9:
            ux, uy, uz = 0.0, cz, -cy
        else:
            ux, uy, uz = -cz, 0.0, cx
        nu = math.sqrt(ux * ux + uy * uy + uz * uz)
        ux, uy, uz = ux / nu, uy / nu, uz / nu
        wx, wy, wz = cy * uz - cz * uy, cz * ux - cx * uz, cx * uy - cy * ux
        r1 = amp * _hash_unit(p.seed, split_count, 1)
        r2 = amp * _hash_unit(p.seed, split_count, 2)
        pos[3 * new] += r1 * ux + r2 * wx
        pos[3 * new + 1] += r1 * uy + r2 * wy
        pos[3 * new + 2] += r1 * uz + r2 * wz
    seg_rest[out] = s_new - s_out
    seg_rest[new] = s_tip - s_new
    row = scratch.mat_row
    r_inlet = seg_mat[out, MAT_RADIUS]
    segment_material(s_out, s_new, t, model, row, scratch)
    for c in range(N_MAT):
        seg_mat[out, c] = row[c]
    segment_material(s_new, s_tip, t, model, row, scratch)
    for c in range(N_MAT):
        seg_mat[new, c] = row[c]
        seg_mat[new + 1, c] = row[c]  # the ghost mirrors the inlet's material
    if p.liquid:  # both halves keep the inlet's (relaxed) section and their volumes
        f = (p.exit_radius / r_inlet) ** 2
        seg_rest[out] *= f
        seg_rest[new] *= f
        for k in (out, new, new + 1):
            seg_mat[k, MAT_RADIUS] = r_inlet
    return n_nodes + 1


@kernel
def refresh_inlet_material(model, rod, t: float, scratch) -> None:
    """Re-derive the growing inlet segment's record from everything extruded into it."""
    if not model.params[0].clamped:
        return
    node_s, seg_mat, n_nodes = rod.node_s, rod.seg_mat, rod.n_nodes
    out = n_nodes - 3
    if node_s[n_nodes - 2] <= max(node_s[out], 0.0):
        return  # nothing extruded into it yet: it is still initial material
    row = scratch.mat_row
    r_inlet = seg_mat[out, MAT_RADIUS]
    segment_material(node_s[out], node_s[n_nodes - 2], t, model, row, scratch)
    if model.params[0].liquid:  # the liquid effect owns its section (it relaxes at volume)
        row[MAT_RADIUS] = r_inlet
    for c in range(N_MAT):
        seg_mat[out, c] = row[c]
        seg_mat[out + 1, c] = row[c]


@njit(**KERNEL)
def transport_curvature(
    pos_old: np.ndarray, pos_new: np.ndarray, n_seg: int, seg_mat: np.ndarray
) -> None:
    """Carry each segment's natural-curvature vector with the rotation of its tangent.

    The minimal rotation taking the old tangent to the new one (parallel transport in
    time), applied after each accepted step: curvature set in the material rotates with it.
    """
    for j in range(n_seg):
        kx = seg_mat[j, MAT_KAPPA_X]
        ky = seg_mat[j, MAT_KAPPA_X + 1]
        kz = seg_mat[j, MAT_KAPPA_X + 2]
        if kx == 0.0 and ky == 0.0 and kz == 0.0:
            continue
        a0 = pos_old[3 * j + 3] - pos_old[3 * j]
        a1 = pos_old[3 * j + 4] - pos_old[3 * j + 1]
        a2 = pos_old[3 * j + 5] - pos_old[3 * j + 2]
        b0 = pos_new[3 * j + 3] - pos_new[3 * j]
        b1 = pos_new[3 * j + 4] - pos_new[3 * j + 1]
        b2 = pos_new[3 * j + 5] - pos_new[3 * j + 2]
        na = math.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        nb = math.sqrt(b0 * b0 + b1 * b1 + b2 * b2)
        a = (a0 / na, a1 / na, a2 / na)
        b = (b0 / nb, b1 / nb, b2 / nb)
        ax = a[1] * b[2] - a[2] * b[1]
        ay = a[2] * b[0] - a[0] * b[2]
        az = a[0] * b[1] - a[1] * b[0]
        cos = a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
        if 1.0 + cos < 1e-12:
            continue
        # Rodrigues with axis*sin = a x b:  R k = cos k + (a x b) x k + (a x b)((a x b).k)/(1+cos)
        dot = ax * kx + ay * ky + az * kz
        f = dot / (1.0 + cos)
        seg_mat[j, MAT_KAPPA_X] = cos * kx + (ay * kz - az * ky) + f * ax
        seg_mat[j, MAT_KAPPA_X + 1] = cos * ky + (az * kx - ax * kz) + f * ay
        seg_mat[j, MAT_KAPPA_X + 2] = cos * kz + (ax * ky - ay * kx) + f * az

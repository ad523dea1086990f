"""Geometry of pairs of rod segments: closest points, the distance with its exact gradient
and Hessian, candidate pairs by a uniform spatial hash, and a no-pass-through step bound.

All numba kernels on the flat position array (node i at ``pos[3*i : 3*i + 3]``, m); the
self-contact effect (:mod:`bathprint.core.effects.contact`) is built on them.

1. **Distance.** Segments A = (x0, x1) and B = (x2, x3): d = min over (s, t) in [0, 1]^2 of
   |x0 + s (x1 - x0) - x2 - t (x3 - x2)|. Its gradient and *exact* Hessian with respect to
   the 12 coordinates include the motion of the closest-point parameters (s, t): with
   D = d^2 = min g(x, s, t), grad D = g_x (envelope theorem) and Hess D = g_xx - g_xy
   g_yy^-1 g_yx over the free (unclamped) parameters y. The Hessian of d is assembled in a
   form without the cancellation of ``(Hess D / 2 - grad d grad d^T) / d`` (see
   ``_distance_derivs``), so it stays exact as d -> 0 for crossing segments; the
   point-segment and point-point cones (Hessian ~ 1/d) are cut off at ``D_FLOOR_REL * delta``.
   Contact acts at these closest points but for nearly parallel segments, whose closest
   points slide along them ~1/sin(angle) as fast as they move across each other (and the
   distance's Hessian grows ~1/sin^2): below ``PARALLEL_ANGLE_DEG`` contact acts at the
   middle of their overlap, blended smoothly into the closest points up to
   ``SLIDING_ANGLE_DEG`` (:func:`contact_params`), with that point held in the derivatives.
   The turns of a coil touch at a few degrees; with the closest points Newton's iterations
   on a pressed stack wander with them (8 per step at 300 nodes, and a stack of 10^4 nodes
   stalls), with the middle of the overlap they do not.
2. **Candidate pairs.** A uniform spatial hash (cell = search distance + the largest
   per-axis segment extent, counting sort by cell, 27 neighbour cells) finds in O(N) every
   pair of segments whose bounding boxes are within the search distance on every axis.
   Segments close along the rod are excluded (``min_separation_for``).
3. **Step bound.** The distance between segments is 1-Lipschitz in the relative displacement
   of their nodes, so a step is crossing-free for the candidate pairs when every pair's
   largest relative node displacement u is below its start distance d0, and the candidate
   list stays valid while twice the largest node displacement relative to the common motion
   is below the search distance's skin.

Closest points follow Lumelsky (1985), "On fast computation of distance between line
segments", Inf. Process. Lett. 21, 55-61, in an equivalent form (the unconstrained line-line
minimiser if it lies in the unit square, otherwise the best of the four edge problems; exact
because g is convex). The incremental-potential contact is that of Choi, Tong, Jawed & Joo
(2021), "Implicit contact model for discrete elastic rods in knot tying", J. Appl. Mech. 88,
051010 (IMC), as in DisMech (Choi et al., IEEE RA-L 2024), with the exact piecewise distance
instead of IMC's smoothed blend of the distance cases, and for nearly parallel segments a
one-point line contact (Meier, Popp & Wall (2016), "A finite element approach for the
line-to-line contact interaction of thin beams with arbitrary orientation", Comput. Methods
Appl. Mech. Eng. 308, 377-413: point contact is ill-posed at small angles); the
spatial-hash primes are those of
Teschner et al. (2003), "Optimized spatial hashing for collision detection of deformable
objects", VMV.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.jit import KERNEL

PARALLEL_TOL = 1e-6
"""sin^2 of the angle between two segments below which the line-line minimiser is not
computed (its determinant would be round-off) and, at d = 0, the normal is not taken from
the edges' cross product."""

PARALLEL_ANGLE_DEG = 10.0
"""Below this angle contact between two overlapping segments acts at the middle of their
overlap (:func:`contact_params`)."""

SLIDING_ANGLE_DEG = 20.0
"""From this angle on contact acts at the closest points; between PARALLEL_ANGLE_DEG and
this one at a smooth blend of the two."""

PARALLEL_SIN2 = math.sin(math.radians(PARALLEL_ANGLE_DEG)) ** 2
SLIDING_SIN2 = math.sin(math.radians(SLIDING_ANGLE_DEG)) ** 2

D_FLOOR_REL = 1e-9
"""The 1/d factor of the point-segment and point-point Hessians uses max(d, D_FLOOR_REL *
delta); below that (centre lines practically coincident) the Hessian is not exact."""

_DEGENERATE_REL = 1e-30  # a segment with |e|^2 below this fraction of the scale is a point

_H1 = 73856093  # Teschner et al. (2003) spatial-hash primes
_H2 = 19349663
_H3 = 83492791


# ---------------------------------------------------------------------------------------
# closest points and distance


@njit(**KERNEL, inline="always")
def _clamp01(v: float) -> float:
    return 0.0 if v < 0.0 else (1.0 if v > 1.0 else v)


@njit(**KERNEL, inline="always")
def _exact_params(rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, a_ok, b_ok):
    """The exact closest-point parameters (s, t, s_free, t_free, dist2) of the segments
    x0 + s e_A and x2 + t e_B (r = x0 - x2; aa, bb, cc, da, db the dot products of e_A, e_B
    and r): the line-line minimiser if it lies in the unit square (and the lines are not
    parallel to PARALLEL_TOL), otherwise the best of the four edge problems."""
    if a_ok and b_ok:
        det = aa * cc - bb * bb
        if det > PARALLEL_TOL * aa * cc:
            s = (bb * db - cc * da) / det
            t = (aa * db - bb * da) / det
            if 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0:
                px = rx + s * ax - t * bx
                py = ry + s * ay - t * by
                pz = rz + s * az - t * bz
                return s, t, 0.0 < s < 1.0, 0.0 < t < 1.0, px * px + py * py + pz * pz
    # the minimum lies on the boundary of the unit square: best of its four edges
    best = np.inf
    s_best = 0.0
    t_best = 0.0
    for edge in range(4):
        if edge < 2:
            s = float(edge)
            t = _clamp01((db + s * bb) / cc) if b_ok else 0.0
        else:
            t = float(edge - 2)
            s = _clamp01((t * bb - da) / aa) if a_ok else 0.0
        px = rx + s * ax - t * bx
        py = ry + s * ay - t * by
        pz = rz + s * az - t * bz
        d2 = px * px + py * py + pz * pz
        if d2 < best:
            best = d2
            s_best = s
            t_best = t
    s_free = a_ok and 0.0 < s_best < 1.0
    t_free = b_ok and 0.0 < t_best < 1.0
    return s_best, t_best, s_free, t_free, best


@njit(**KERNEL, inline="always")
def _pair_vectors(pos, i0: int, i1: int, i2: int, i3: int):
    """e_A, e_B, r = x_i0 - x_i2 and their dot products aa, bb, cc, da, db, with whether
    each segment has a length (not degenerate)."""
    ax = pos[3 * i1] - pos[3 * i0]
    ay = pos[3 * i1 + 1] - pos[3 * i0 + 1]
    az = pos[3 * i1 + 2] - pos[3 * i0 + 2]
    bx = pos[3 * i3] - pos[3 * i2]
    by = pos[3 * i3 + 1] - pos[3 * i2 + 1]
    bz = pos[3 * i3 + 2] - pos[3 * i2 + 2]
    rx = pos[3 * i0] - pos[3 * i2]
    ry = pos[3 * i0 + 1] - pos[3 * i2 + 1]
    rz = pos[3 * i0 + 2] - pos[3 * i2 + 2]
    aa = ax * ax + ay * ay + az * az
    bb = ax * bx + ay * by + az * bz
    cc = bx * bx + by * by + bz * bz
    da = ax * rx + ay * ry + az * rz
    db = bx * rx + by * ry + bz * rz
    tiny = _DEGENERATE_REL * (aa + cc + rx * rx + ry * ry + rz * rz)
    return rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, aa > tiny, cc > tiny


@njit(**KERNEL)
def closest_params(pos, i0: int, i1: int, i2: int, i3: int):
    """Closest-point parameters of segments A = (x_i0, x_i1) and B = (x_i2, x_i3).

    Returns ``(s, t, s_free, t_free, dist2)``: the closest points are x_i0 + s (x_i1 - x_i0)
    and x_i2 + t (x_i3 - x_i2), s and t in [0, 1]; ``s_free`` / ``t_free`` say whether the
    parameter is strictly inside (0, 1) (an unclamped, stationary parameter: it enters the
    Hessian's Schur complement), ``dist2`` is the squared distance (m^2). The line-line
    minimiser if it lies in the unit square (and the lines are not parallel to
    PARALLEL_TOL), otherwise, and for degenerate (zero-length) segments, the best of the edge
    cases, ties broken in the order s=0, s=1, t=0, t=1.
    """
    rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, a_ok, b_ok = _pair_vectors(
        pos, i0, i1, i2, i3
    )
    return _exact_params(rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, a_ok, b_ok)


@njit(**KERNEL)
def contact_params(
    pos,
    i0: int,
    i1: int,
    i2: int,
    i3: int,
    parallel_sin2: float = PARALLEL_SIN2,
    sliding_sin2: float = SLIDING_SIN2,
):
    """The points of segments A = (x_i0, x_i1) and B = (x_i2, x_i3) where contact acts, as
    ``(s, t, s_free, t_free, dist2)`` like :func:`closest_params`.

    Segments at an angle whose sin^2 is at least ``sliding_sin2`` (default: that of
    SLIDING_ANGLE_DEG), or whose projections do not overlap, take the closest points.
    Nearly parallel overlapping segments take s at the middle of the overlap of B's
    projection on A (below ``parallel_sin2``, PARALLEL_ANGLE_DEG's), or blended smoothly (a
    smoothstep in sin^2 of the angle) from there to the closest point's s (between the
    two), held (not free), and t the projection of that point on B. The
    closest points of nearly parallel segments slide along them ~1/sin(angle) as fast as the
    segments move across each other, and the Hessian of their distance grows ~1/sin^2:
    held, the force moves with the segments and its Jacobian stays of the size of the
    distance's own (a one-point line contact, as beam-contact formulations take for small
    angles: Meier, Popp & Wall 2016, Comput. Methods Appl. Mech. Eng. 308, 377-413). The
    distance so measured exceeds the minimum by at most |e_A| sin(angle), and between
    crossing lines by (|e_A| ds sin)^2 / (2 d) for the step ds in s (< 1e-10 m where the
    0.3 mm segments of a coil cross 0.6 mm apart at 3-4 degrees); the no-pass-through bound
    uses the minimum (:func:`segment_distance`).
    """
    rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, a_ok, b_ok = _pair_vectors(
        pos, i0, i1, i2, i3
    )
    if a_ok and b_ok:
        sin2 = max(aa * cc - bb * bb, 0.0) / (aa * cc)
        if sin2 < sliding_sin2:
            # nearly parallel: the overlap of B's projection on A
            s_b0 = -da / aa
            s_b1 = (bb - da) / aa
            lo = max(0.0, min(s_b0, s_b1))
            hi = min(1.0, max(s_b0, s_b1))
            if lo <= hi:
                s = 0.5 * (lo + hi)
                if sin2 > parallel_sin2:  # blend towards the closest point's s
                    s_e = _exact_params(
                        rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, a_ok, b_ok
                    )[0]
                    w = (sin2 - parallel_sin2) / (sliding_sin2 - parallel_sin2)
                    s += w * w * (3.0 - 2.0 * w) * (s_e - s)
                t = _clamp01((db + s * bb) / cc)
                px = rx + s * ax - t * bx
                py = ry + s * ay - t * by
                pz = rz + s * az - t * bz
                return s, t, False, 0.0 < t < 1.0, px * px + py * py + pz * pz
    return _exact_params(rx, ry, rz, ax, ay, az, bx, by, bz, aa, bb, cc, da, db, a_ok, b_ok)


@njit(**KERNEL)
def segment_distance(pos, i0: int, i1: int, i2: int, i3: int) -> float:
    """Minimum distance (m) between segments (x_i0, x_i1) and (x_i2, x_i3)."""
    return math.sqrt(closest_params(pos, i0, i1, i2, i3)[4])


@njit(**KERNEL, inline="always")
def _pick3(k: int, v0: float, v1: float, v2: float) -> float:
    """v_k for k in 0..2 (a select, not a tuple indexed at run time)."""
    return v0 if k == 0 else (v1 if k == 1 else v2)


@njit(**KERNEL, inline="always")
def _pick4(k: int, v0: float, v1: float, v2: float, v3: float) -> float:
    """v_k for k in 0..3."""
    return v0 if k == 0 else (v1 if k == 1 else (v2 if k == 2 else v3))


@njit(**KERNEL)
def _distance_derivs(
    pos, i0, i1, i2, i3, s, t, s_free, t_free, d_floor, grad, hess, with_hess=True
) -> float:
    """Distance d (m) with its gradient (12) and Hessian (12x12, 1/m) into grad and hess
    (``with_hess`` False: the gradient only, for evaluations without the Jacobian).

    Coordinates are ordered [x_i0, x_i1, x_i2, x_i3]. With r = x_A(s) - x_B(t) = J x,
    J = [a0 I, a1 I, a2 I, a3 I], a = (1-s, s, t-1, -t), n = r/d, the free parameters' edge
    vectors F (columns e_A for s, -e_B for t), H = F^T F and the parameter-node couplings
    beta_s = (-1, 1, 0, 0), beta_t = (0, 0, 1, -1) (the derivative of e_A, -e_B with
    respect to the nodes), the envelope theorem and the Schur complement give

        grad d = J^T n,
        Hess d = J^T M J / d - (J^T G Q^T + Q G^T J) - d Q H^-1 Q^T,

    where M = I - n n^T - F H^-1 F^T projects onto the directions orthogonal to n and to the
    free edges (M = 0 when both parameters are free), G = F H^-1 and Q = [beta_k (x) n]. This
    is (Hess D / 2 - grad d grad d^T) / d expanded so that the cancelling parts never meet.
    With both parameters free n is taken as +-(e_A x e_B)/|e_A x e_B| (exact as d -> 0; at
    d = 0 the + sign, one of the two one-sided limits of a crossing).
    """
    r0x, r0y, r0z, ax, ay, az, bx, by, bz, aa, bb, cc, _, _, _, _ = _pair_vectors(
        pos, i0, i1, i2, i3
    )
    rx = r0x + s * ax - t * bx
    ry = r0y + s * ay - t * by
    rz = r0z + s * az - t * bz
    dist2 = rx * rx + ry * ry + rz * rz
    d = math.sqrt(dist2)
    mx = ay * bz - az * by
    my = az * bx - ax * bz
    mz = ax * by - ay * bx
    m2 = mx * mx + my * my + mz * mz
    if s_free and t_free:
        # r is parallel to e_A x e_B: take the direction from the edges, which is accurate
        # however small d is (r/d carries the rounding of the positions divided by d)
        m = math.sqrt(m2)
        sign = -1.0 if rx * mx + ry * my + rz * mz < 0.0 else 1.0
        nx, ny, nz = sign * mx / m, sign * my / m, sign * mz / m
    elif dist2 > 1e-300:
        nx, ny, nz = rx / d, ry / d, rz / d
    else:
        # centre lines touch: the normal of the two edges, or any direction perpendicular
        # to the longer edge if they are parallel
        if m2 > PARALLEL_TOL * aa * cc and m2 > 0.0:
            m = math.sqrt(m2)
            nx, ny, nz = mx / m, my / m, mz / m
        else:
            vx, vy, vz = (ax, ay, az) if aa >= cc else (bx, by, bz)
            if abs(vx) <= abs(vy) and abs(vx) <= abs(vz):
                mx, my, mz = 0.0, -vz, vy  # v x e_x
            elif abs(vy) <= abs(vz):
                mx, my, mz = vz, 0.0, -vx  # v x e_y
            else:
                mx, my, mz = -vy, vx, 0.0  # v x e_z
            m = math.sqrt(mx * mx + my * my + mz * mz)
            if m > 0.0:
                nx, ny, nz = mx / m, my / m, mz / m
            else:
                nx, ny, nz = 1.0, 0.0, 0.0
    n = (nx, ny, nz)
    alpha = (1.0 - s, s, t - 1.0, -t)
    for i in range(4):
        for c in range(3):
            grad[3 * i + c] = alpha[i] * n[c]
    if not with_hess:  # (forces only: the Hessian is left as it was)
        return d

    # H^-1 entries (hss, hst, htt), G columns (g_s, g_t), M = mcoef (I - n n^T - pf f f^T)
    hss = 0.0
    hst = 0.0
    htt = 0.0
    gs = (0.0, 0.0, 0.0)
    gt = (0.0, 0.0, 0.0)
    mcoef = 1.0 / max(d, d_floor)
    f = (0.0, 0.0, 0.0)
    pf = 0.0
    if s_free and t_free:
        det = aa * cc - bb * bb
        hss = cc / det
        hst = bb / det
        htt = aa / det
        gs = ((cc * ax - bb * bx) / det, (cc * ay - bb * by) / det, (cc * az - bb * bz) / det)
        gt = ((bb * ax - aa * bx) / det, (bb * ay - aa * by) / det, (bb * az - aa * bz) / det)
        mcoef = 0.0
    elif s_free:
        hss = 1.0 / aa
        gs = (ax / aa, ay / aa, az / aa)
        f = (ax, ay, az)
        pf = 1.0 / aa
    elif t_free:
        htt = 1.0 / cc
        gt = (-bx / cc, -by / cc, -bz / cc)
        f = (bx, by, bz)
        pf = 1.0 / cc
    # w_i = sum_k beta_{k,i} g_k per node: w = (-g_s, g_s, g_t, -g_t). Every per-node and
    # per-component factor is picked from scalars (_pick4, _pick3) rather than indexed out
    # of a tuple: numba copies a tuple to the stack at each runtime index, which made the
    # distance's derivatives 5x slower; the entries are the same expressions, bit for bit
    n0, n1, n2 = n
    f0, f1, f2 = f
    gs0, gs1, gs2 = gs
    gt0, gt1, gt2 = gt
    al0, al1, al2, al3 = alpha
    for i in range(4):
        al_i = _pick4(i, al0, al1, al2, al3)
        bs_i = _pick4(i, -1.0, 1.0, 0.0, 0.0)  # beta_s
        bt_i = _pick4(i, 0.0, 0.0, 1.0, -1.0)  # beta_t
        wi0 = _pick4(i, -gs0, gs0, gt0, -gt0)
        wi1 = _pick4(i, -gs1, gs1, gt1, -gt1)
        wi2 = _pick4(i, -gs2, gs2, gt2, -gt2)
        for j in range(4):
            al_j = _pick4(j, al0, al1, al2, al3)
            bs_j = _pick4(j, -1.0, 1.0, 0.0, 0.0)
            bt_j = _pick4(j, 0.0, 0.0, 1.0, -1.0)
            wj0 = _pick4(j, -gs0, gs0, gt0, -gt0)
            wj1 = _pick4(j, -gs1, gs1, gt1, -gt1)
            wj2 = _pick4(j, -gs2, gs2, gt2, -gt2)
            sij = hss * bs_i * bs_j + hst * (bs_i * bt_j + bt_i * bs_j) + htt * bt_i * bt_j
            aij = al_i * al_j * mcoef
            for a in range(3):
                na = _pick3(a, n0, n1, n2)
                fa = _pick3(a, f0, f1, f2)
                wja = _pick3(a, wj0, wj1, wj2)
                for b in range(3):
                    nb = _pick3(b, n0, n1, n2)
                    mab = (1.0 if a == b else 0.0) - na * nb - pf * fa * _pick3(b, f0, f1, f2)
                    hess[3 * i + a, 3 * j + b] = (
                        aij * mab
                        - al_i * wja * nb
                        - al_j * na * _pick3(b, wi0, wi1, wi2)
                        - d * sij * na * nb
                    )
    return d


@njit(**KERNEL)
def segment_distance_derivs(pos, i0: int, i1: int, i2: int, i3: int, d_floor: float, grad, hess):
    """Contact distance d (m) between segments (x_i0, x_i1), (x_i2, x_i3) (between the points
    of :func:`contact_params`: the minimum distance but for nearly parallel segments), its
    gradient into grad (12) and Hessian (1/m) into hess (12x12), coordinates ordered
    [x_i0, x_i1, x_i2, x_i3].

    ``d_floor`` (m) bounds the 1/d of the point-segment and point-point cones from below.
    """
    s, t, s_free, t_free, _ = contact_params(pos, i0, i1, i2, i3)
    return _distance_derivs(pos, i0, i1, i2, i3, s, t, s_free, t_free, d_floor, grad, hess)


@njit(**KERNEL, inline="always")
def penalty(p: float, k_c: float, width: float):
    """Penalty energy (J) and its first two derivatives with respect to the penetration p (m).

    E = k p^3 / (6 w) for 0 < p < w, k (p^2/2 - w p/2 + w^2/6) for p >= w, 0 for p <= 0: C2 in
    p, the force k p^2 / (2 w) ramping into k (p - w/2) as in the floor kernel.
    """
    if p <= 0.0:
        return 0.0, 0.0, 0.0
    if p < width:
        return k_c * p * p * p / (6.0 * width), 0.5 * k_c * p * p / width, k_c * p / width
    return (
        k_c * (0.5 * p * p - 0.5 * width * p + width * width / 6.0),
        k_c * (p - 0.5 * width),
        k_c,
    )


@njit(**KERNEL)
def segment_pair_energy(
    pos, i0: int, i1: int, i2: int, i3: int, delta: float, k_c: float, width: float, grad, hess
):
    """Contact energy of segments A = (x_i0, x_i1) and B = (x_i2, x_i3); returns (energy, d).

    pos: flat positions (m), node i at pos[3*i : 3*i+3]; i0..i3: node indices. delta (m):
    contact distance r_A + r_B. k_c (N/m): the pair's penalty stiffness, force per
    penetration -- for a stiffness K in Pa (force per length per penetration) pass
    k_c = K * l_c with a contact length l_c, e.g. the mean rest length of the two segments.
    width (m, >= 0): penetration over which the stiffness ramps up (cubic onset). grad (12)
    and hess (12x12) receive dE/dx (N) and d2E/dx2 (N/m) over [x_i0, x_i1, x_i2, x_i3];
    both are zeroed when d >= delta. The force on the nodes is -grad.
    """
    s, t, s_free, t_free, dist2 = contact_params(pos, i0, i1, i2, i3)
    if dist2 >= delta * delta:
        for a in range(12):
            grad[a] = 0.0
            for b in range(12):
                hess[a, b] = 0.0
        return 0.0, math.sqrt(dist2)
    d = _distance_derivs(pos, i0, i1, i2, i3, s, t, s_free, t_free, D_FLOOR_REL * delta, grad, hess)
    energy, e_p, e_pp = penalty(delta - d, k_c, width)
    # E(d) = P(delta - d): dE/dd = -P', d2E/dd2 = P''
    for a in range(12):
        for b in range(12):
            hess[a, b] = e_pp * grad[a] * grad[b] - e_p * hess[a, b]
    for a in range(12):
        grad[a] = -e_p * grad[a]
    return energy, d


# ---------------------------------------------------------------------------------------
# candidate pairs


def min_separation_for(delta: float, dl: float) -> int:
    """Smallest index gap j - i that may be a contact pair is ``min_separation + 1``.

    A rod of radius r = delta/2 cannot bend tighter than a radius of curvature of about r
    (its inner side would fold onto itself). On such a tightest arc, two centre-line points
    an arclength L apart are a chord delta sin(L / delta) <= delta apart: every pair within
    pi delta / 2 of arclength is always "in contact" by the distance criterion and must not
    be, while beyond it (the far side of a ring of radius r) contact is genuine. Segments i
    and j are (j - i - 1) dl apart along the rod, so requiring j - i > min_separation with
    min_separation = max(2, ceil(1.6 delta / dl)) keeps (j - i - 1) dl >= 1.6 delta > pi
    delta / 2; the floor of 2 also drops neighbours and next neighbours, which share a node
    or a segment. delta and dl in m.
    """
    if not (math.isfinite(delta) and delta > 0.0):
        raise ValueError(f"delta = {delta!r} is not allowed; it must be finite and > 0 m")
    if not (math.isfinite(dl) and dl > 0.0):
        raise ValueError(f"dl = {dl!r} is not allowed; it must be finite and > 0 m")
    return max(2, math.ceil(1.6 * delta / dl))


@njit(**KERNEL, inline="always")
def _bucket(cx: int, cy: int, cz: int, n_buckets: int) -> int:
    h = (cx * _H1) ^ (cy * _H2) ^ (cz * _H3)
    b = h % n_buckets
    return b + n_buckets if b < 0 else b


@njit(**KERNEL, inline="always")
def _boxes_near(pos, i: int, j: int, gap: float) -> bool:
    """True if the bounding boxes of segments i and j are within ``gap`` on every axis."""
    for c in range(3):
        pi0 = pos[3 * i + c]
        pi1 = pos[3 * i + 3 + c]
        pj0 = pos[3 * j + c]
        pj1 = pos[3 * j + 3 + c]
        if min(pj0, pj1) - max(pi0, pi1) > gap or min(pi0, pi1) - max(pj0, pj1) > gap:
            return False
    return True


@njit(**KERNEL)
def build_candidate_pairs(
    pos,
    n_nodes: int,
    seg_first: int,
    seg_last: int,
    search_dist: float,
    min_separation: int,
    cell_start,
    seg_order,
    seg_cell,
    stamp,
    boxes,
    pairs_out,
    query_first: int = 0,
) -> int:
    """Candidate contact pairs by a uniform spatial hash; returns the number of pairs found.

    Segments j = (nodes j, j+1) for j in [seg_first, seg_last); pairs (i, j), i < j, with
    j - i > min_separation and j >= query_first (pairs of two segments before
    ``query_first``, a frozen tail, are not wanted), whose bounding boxes are within
    ``search_dist`` (m) of each other
    on every axis (so every pair at distance <= search_dist is included). Work arrays
    (reused between calls, :class:`bathprint.core.records.Contact`): cell_start (int64,
    n_buckets + 1), seg_order (int64, >= n_seg), seg_cell (int64, >= 3 n_seg), stamp (int64,
    n_buckets), boxes (float, (2, >= 6 n_seg)); pairs_out (capacity, 2) receives the pairs,
    ordered by i. If the return value exceeds the capacity, only that many pairs were
    written: grow pairs_out and call again.

    Grid: cell size h = search_dist + the largest per-axis extent of any segment; each
    segment sits in the cell of its midpoint, and two candidates' midpoints differ by at most
    h per axis, so their cells are neighbours. Cells hash into n_buckets buckets (collisions
    only cost extra box tests); a counting sort groups segments by bucket; each segment scans
    the distinct buckets of its 27 neighbour cells (``stamp`` marks a bucket scanned) for
    partners j > i, whose bounding boxes (``boxes[0]`` by segment, lows then highs) are
    copied in bucket order (``boxes[1]``) so that the scan reads them in sequence.
    O(N + n_buckets).
    """
    if seg_first < 0 or seg_last > n_nodes - 1:
        raise ValueError("segment range must lie in [0, n_nodes - 1)")
    n_seg = seg_last - seg_first
    if n_seg <= 0:
        return 0
    n_buckets = cell_start.shape[0] - 1
    capacity = pairs_out.shape[0]
    box = boxes[0]
    sbox = boxes[1]
    lo0 = np.inf
    lo1 = np.inf
    lo2 = np.inf
    extent = 0.0
    for i in range(seg_first, seg_last + 1):
        lo0 = min(lo0, pos[3 * i])
        lo1 = min(lo1, pos[3 * i + 1])
        lo2 = min(lo2, pos[3 * i + 2])
    for k in range(n_seg):
        i = seg_first + k
        for c in range(3):
            a = pos[3 * i + c]
            b = pos[3 * i + 3 + c]
            box[6 * k + c] = min(a, b)
            box[6 * k + 3 + c] = max(a, b)
            extent = max(extent, abs(b - a))
    h = (search_dist + extent) * (1.0 + 1e-9)  # margin against rounding in the cell index
    if not h > 0.0:
        h = 1.0
    # counting sort of segments by bucket
    for b in range(n_buckets + 1):
        cell_start[b] = 0
    for k in range(n_seg):
        i = seg_first + k
        for c in range(3):
            mid = 0.5 * (pos[3 * i + c] + pos[3 * i + 3 + c])
            low = lo0 if c == 0 else (lo1 if c == 1 else lo2)
            seg_cell[3 * k + c] = int(math.floor((mid - low) / h))
        b = _bucket(seg_cell[3 * k], seg_cell[3 * k + 1], seg_cell[3 * k + 2], n_buckets)
        cell_start[b] += 1
    for b in range(1, n_buckets):
        cell_start[b] += cell_start[b - 1]  # now the end of each bucket
    for k in range(n_seg - 1, -1, -1):
        b = _bucket(seg_cell[3 * k], seg_cell[3 * k + 1], seg_cell[3 * k + 2], n_buckets)
        cell_start[b] -= 1
        seg_order[cell_start[b]] = k
    cell_start[n_buckets] = n_seg
    for idx in range(n_seg):
        k = seg_order[idx]
        for q in range(6):
            sbox[6 * idx + q] = box[6 * k + q]
    for b in range(n_buckets):
        stamp[b] = -1
    # scan neighbours
    n_pairs = 0
    for k in range(n_seg):
        i = seg_first + k
        if i < query_first:
            continue
        for dx in range(-1, 2):
            for dy in range(-1, 2):
                for dz in range(-1, 2):
                    b = _bucket(
                        seg_cell[3 * k] + dx,
                        seg_cell[3 * k + 1] + dy,
                        seg_cell[3 * k + 2] + dz,
                        n_buckets,
                    )
                    if stamp[b] == k:  # scanned already (two cells hash to it)
                        continue
                    stamp[b] = k
                    for idx in range(cell_start[b], cell_start[b + 1]):
                        j = seg_first + seg_order[idx]
                        if j >= query_first:  # both query segments: each pair once, i < j
                            if j - i <= min_separation:
                                continue
                            first, second = i, j
                        else:  # a partner before query_first (it never queries)
                            if i - j <= min_separation:
                                continue
                            first, second = j, i
                        if _sorted_boxes_near(box, k, sbox, idx, search_dist):
                            if n_pairs < capacity:
                                pairs_out[n_pairs, 0] = first
                                pairs_out[n_pairs, 1] = second
                            n_pairs += 1
    return n_pairs


@njit(**KERNEL, inline="always")
def _sorted_boxes_near(box, k: int, sbox, idx: int, gap: float) -> bool:
    """:func:`_boxes_near` on precomputed boxes (lows then highs, 6 per segment): segment k
    of ``box`` and entry idx of ``sbox``, with the same comparisons."""
    for c in range(3):
        if sbox[6 * idx + c] - box[6 * k + 3 + c] > gap:
            return False
        if box[6 * k + c] - sbox[6 * idx + 3 + c] > gap:
            return False
    return True


@njit(**KERNEL)
def brute_force_pairs(
    pos, seg_first: int, seg_last: int, search_dist: float, min_separation: int, pairs_out
) -> int:
    """O(N^2) reference for ``build_candidate_pairs`` (same test, same return convention)."""
    capacity = pairs_out.shape[0]
    n_pairs = 0
    for i in range(seg_first, seg_last):
        for j in range(i + min_separation + 1, seg_last):
            if _boxes_near(pos, i, j, search_dist):
                if n_pairs < capacity:
                    pairs_out[n_pairs, 0] = i
                    pairs_out[n_pairs, 1] = j
                n_pairs += 1
    return n_pairs


@njit(**KERNEL, inline="always")
def _disp(pos0, pos, frozen: int, g: int, c: int) -> float:
    """Displacement of coordinate c of node g over a step: pos0 holds the active nodes (from
    ``frozen``); a frozen node moves with the first active node (the tail's translation)."""
    k = g - frozen if g >= frozen else 0
    return pos[3 * (k + frozen) + c] - pos0[3 * k + c]


@njit(**KERNEL)
def step_bound(pos0, pos, frozen: int, pairs, n_pairs: int, n_nodes: int, skin: float, out, x):
    """How close a step comes to letting segments pass through each other: a ratio, < 1
    when the step is provably crossing-free. ``pos``: the whole rod's positions (m, flat)
    after the step, ``pos0``: the active nodes' (from ``frozen``) at its start; frozen nodes
    move with the first active node. ``out`` (3,) receives the worst pair (i, j; -1 when the
    skin set the ratio) and the largest node displacement relative to the common motion (m);
    ``x`` (12,) is scratch.

    - Candidate pairs: with d0 a pair's distance at the start and u = max_{a in A, b in B}
      |dx_a - dx_b|, the distance along the linear motion is d(tau) >= d0 - tau u (distance
      is 1-Lipschitz in the relative displacement of the nodes), so u / d0 < 1 means no
      crossing.
    - Every other pair started farther than delta + skin apart (the list was built at the
      start with that search distance). With m = max_i |dx_i - c| for the centre c of the
      nodes' displacement box, any two points moved by at most 2 m relative to each other,
      so such a pair is still farther than delta if 2 m / skin < 1: the list missed nothing.
    """
    lo0 = lo1 = lo2 = np.inf
    hi0 = hi1 = hi2 = -np.inf
    for g in range(frozen, n_nodes):
        d0 = _disp(pos0, pos, frozen, g, 0)
        d1 = _disp(pos0, pos, frozen, g, 1)
        d2 = _disp(pos0, pos, frozen, g, 2)
        lo0, hi0 = min(lo0, d0), max(hi0, d0)
        lo1, hi1 = min(lo1, d1), max(hi1, d1)
        lo2, hi2 = min(lo2, d2), max(hi2, d2)
    c0, c1, c2 = 0.5 * (lo0 + hi0), 0.5 * (lo1 + hi1), 0.5 * (lo2 + hi2)
    m2 = 0.0
    for g in range(frozen, n_nodes):
        d0 = _disp(pos0, pos, frozen, g, 0) - c0
        d1 = _disp(pos0, pos, frozen, g, 1) - c1
        d2 = _disp(pos0, pos, frozen, g, 2) - c2
        m2 = max(m2, d0 * d0 + d1 * d1 + d2 * d2)
    m = math.sqrt(m2)
    worst = 2.0 * m / skin if skin > 0.0 else (np.inf if m > 0.0 else 0.0)
    out[0] = -1.0
    out[1] = -1.0
    out[2] = m
    for p in range(n_pairs):
        i = pairs[p, 0]
        j = pairs[p, 1]
        u2 = 0.0
        for a in (i, i + 1):
            for b in (j, j + 1):
                w2 = 0.0
                for c in range(3):
                    du = _disp(pos0, pos, frozen, a, c) - _disp(pos0, pos, frozen, b, c)
                    w2 += du * du
                u2 = max(u2, w2)
        if u2 == 0.0:
            continue
        d_start = _start_distance(pos0, pos, frozen, i, j, x)
        ratio = math.sqrt(u2) / d_start if d_start > 0.0 else np.inf
        if ratio > worst:
            worst = ratio
            out[0] = i
            out[1] = j
    return worst


@njit(**KERNEL)
def _start_distance(pos0, pos, frozen: int, i: int, j: int, x) -> float:
    """Distance of segments i, j at the start of the step (frozen nodes had not moved);
    ``x`` (12,) scratch."""
    nodes = (i, i + 1, j, j + 1)
    for a in range(4):
        g = nodes[a]
        for c in range(3):
            x[3 * a + c] = pos0[3 * (g - frozen) + c] if g >= frozen else pos[3 * g + c]
    return segment_distance(x, 0, 1, 2, 3)

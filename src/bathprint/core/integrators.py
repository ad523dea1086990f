"""Time integration: implicit SDIRK2 / backward Euler with Newton, and an explicit reference.

The equations of motion of every scene have one form: the total force of the listed
effects vanishes, F(x, v, a, t) = 0, where drag depends on v and inertia on a (an
overdamped scene has no inertia and no velocity state). A diagonally implicit stage
with coefficient h*gamma fixes v = (X - Sx)/(h gamma) and a = (v - Sv)/(h gamma) as
functions of the stage positions X, so each stage is a Newton solve for X with the
banded Jacobian  -(dF/dx + dF/dv / (h gamma) + dF/da / (h gamma)^2),  O(N) per iteration.

``implicit`` is Alexander's two-stage SDIRK (order 2, L-stable, stiffly accurate),
gamma = 1 - 1/sqrt(2); its local error is estimated by X2 - x_n - h V1 (the embedded
first-order solution) and controls the step. ``sdirk4`` is Hairer & Wanner's five-stage
SDIRK (order 4, L-stable, stiffly accurate, gamma = 1/4, embedded order 3): all stages share
h gamma, so one factorised Jacobian serves the whole step; it pays where accuracy is dear
(tight tolerances, lightly damped oscillations). ``implicit_euler`` is one stage with
gamma = 1 and the predictor-corrector estimate (X - x_n - h v_n)/2. ``explicit`` is
forward Euler (overdamped: solve F(x_n, V) = 0 for V, a block-diagonal solve) or
symplectic Euler (with inertia), at a fixed step: the reference for verification.

Everything runs inside one numba call per output interval: no Python and no
allocation per step. Failures return a status code and ``info`` = [time, node, value].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.assemble import assemble
from bathprint.core.banded import band_lu, band_matvec, band_solve
from bathprint.core.effects import gelation
from bathprint.core.extrusion import (
    extruded_length,
    flow_rate,
    refresh_inlet_material,
    set_boundary,
    split_inlet,
    transport_curvature,
)
from bathprint.core.freezing import tail_load
from bathprint.core.layout import (
    C_FACTORIZATIONS,
    C_FAIL_NODE,
    C_NEWTON_FAILURES,
    C_NEWTON_ITERATIONS,
    C_REJECTED,
    C_SPLITS,
    C_STEPS,
    E_FLOOR,
    E_GELATION,
    E_GRAVITY,
    E_INCLUSIONS,
    INTEGRATOR_EXPLICIT,
    INTEGRATOR_IMPLICIT_EULER,
    INTEGRATOR_SDIRK4,
    KL,
    KU,
    MAT_BEND_FACTOR,
    MAT_DENSITY,
    MAT_RADIUS,
    MAT_STRETCH_FACTOR,
    MAT_YOUNGS_MODULUS,
    P_ADDED_MASS_COEFFICIENT,
    P_BATH_DENSITY_TOP,
    P_BUCKLING_STEPS,
    P_CLAMPED,
    P_FIXED_STEP,
    P_FLOOR_Z,
    P_FREEZE_BEYOND,
    P_INERTIA,
    P_MAX_INLET_GROWTH,
    P_MAX_NEWTON,
    P_MAX_STEP,
    P_MAX_STRAIN,
    P_MAX_STRAIN_CHANGE,
    P_MIN_STEP,
    P_MU_S,
    P_NEEDLE_AREA,
    P_NEWTON_REUSE,
    P_NEWTON_TOL,
    P_NODE_SPACING,
    P_STRETCH_LIMIT,
    P_TOLERANCE,
    STATUS_CAPACITY,
    STATUS_ERROR,
    STATUS_NAN,
    STATUS_NEWTON,
    STATUS_OK,
    STATUS_STEP_LIMIT,
    STATUS_STRAIN,
    STATUS_STRETCH,
    W_FULL_NEWTON_STEPS,
    W_LU_HG,
    W_LU_ND,
    W_LU_VALID,
    W_NEWTON_ETA,
    W_NEWTON_SLOW,
    W_NORM_EXTRA,
    W_TAIL,
)
from bathprint.core.topology import filament_segments, free_nodes

GAMMA = 1.0 - 1.0 / math.sqrt(2.0)
MIN_ACTIVE_NODES = 6  # freezing leaves at least this many nodes (tip and ghost included)

# Butcher tableaux of the SDIRK methods: lower-triangular A (equal diagonal gamma), nodes c
# and the weights b_hat of the embedded solution whose difference estimates the local error.
# Both are stiffly accurate (the step's result is the last stage) and L-stable.
# Alexander's SDIRK2 (order 2, embedded order 1).
SDIRK2_A = np.array([[GAMMA, 0.0], [1.0 - GAMMA, GAMMA]])
SDIRK2_C = np.array([GAMMA, 1.0])
SDIRK2_BHAT = np.array([1.0, 0.0])
# Hairer & Wanner's SDIRK4 (Solving ODEs II, Table IV.6.5: order 4, embedded order 3,
# gamma = 1/4): four times the stages of SDIRK2's work per step, error O(h^5).
SDIRK4_A = np.array(
    [
        [1.0 / 4.0, 0.0, 0.0, 0.0, 0.0],
        [1.0 / 2.0, 1.0 / 4.0, 0.0, 0.0, 0.0],
        [17.0 / 50.0, -1.0 / 25.0, 1.0 / 4.0, 0.0, 0.0],
        [371.0 / 1360.0, -137.0 / 2720.0, 15.0 / 544.0, 1.0 / 4.0, 0.0],
        [25.0 / 24.0, -49.0 / 48.0, 125.0 / 16.0, -85.0 / 12.0, 1.0 / 4.0],
    ]
)
SDIRK4_C = np.array([1.0 / 4.0, 3.0 / 4.0, 11.0 / 20.0, 1.0 / 2.0, 1.0])
SDIRK4_BHAT = np.array([59.0 / 48.0, -17.0 / 96.0, 225.0 / 32.0, -85.0 / 12.0, 0.0])
MAX_STAGES = 5
REUSE_THETA = 0.05  # Newton contraction below which a step's Jacobian serves the next

# rows of the vector workspace ``vecs`` (each 3 * capacity long)
V_POS0 = 0
V_VEL0 = 1
V_SX = 2
V_SV = 3
V_ACC = 4
V_FORCE = 5
V_RHS = 6
V_ERR = 7
V_KV = 8  # stage velocities, MAX_STAGES rows
V_KA = V_KV + MAX_STAGES  # stage accelerations, MAX_STAGES rows
N_VECS = V_KA + MAX_STAGES


@njit(cache=True, inline="always")
def _error_root(err: float, integrator: int) -> float:
    """err^(1/(p_hat + 1)), p_hat the order of the embedded solution: the factor by which
    the error norm scales the next step."""
    if integrator == INTEGRATOR_SDIRK4:
        return math.sqrt(math.sqrt(err))
    return math.sqrt(err)


@njit(cache=True)
def _worst_node(vec: np.ndarray, nd: int) -> int:
    best = -1.0
    node = 0
    for k in range(nd):
        a = abs(vec[k])
        if not np.isfinite(a):
            return k // 3
        if a > best:
            best = a
            node = k // 3
    return node


@njit(cache=True)
def _stage_solve(
    hg,
    t_stage,
    n_nodes,
    pos,
    vel,
    node_s,
    seg_rest,
    seg_mat,
    params,
    enabled,
    flow,
    flow_cum,
    needle,
    vecs,
    band,
    piv,
    work,
    calls,
    counters,
    energies,
    info,
) -> bool:
    """Newton solve of one implicit stage for the free node positions ``pos``."""
    nd = 3 * free_nodes(n_nodes, params)
    inertial = params[P_INERTIA] > 0.0
    sx = vecs[V_SX]
    sv = vecs[V_SV]
    acc = vecs[V_ACC]
    force = vecs[V_FORCE]
    rhs = vecs[V_RHS]
    scale = params[P_TOLERANCE] * params[P_NODE_SPACING]
    ca = 1.0 / (hg * hg) if inertial else 0.0
    # after a Newton failure (e.g. contacts switching) full Newton for a while
    modified = params[P_NEWTON_REUSE] > 0.0 and work[W_FULL_NEWTON_STEPS] <= 0.0
    refresh = False
    previous = np.inf
    relax = 1.0  # fraction of the Newton update applied
    # Hairer & Wanner's stopping test (Radau5): stop once eta * |dX| < newton_tol, where
    # eta = theta / (1 - theta) bounds the error left after the update dX from the
    # contraction rate theta; before a rate is measured in this step, eta = 1 (the plain
    # test |dX| < newton_tol). With a fast contraction later stages stop after one
    # iteration.
    eta = work[W_NEWTON_ETA] if work[W_NEWTON_ETA] > 0.0 else 1.0
    for it in range(int(params[P_MAX_NEWTON])):
        set_boundary(
            pos, vel, node_s, seg_rest, n_nodes, t_stage, flow, flow_cum, needle, params, work
        )
        for k in range(nd):
            vel[k] = (pos[k] - sx[k]) / hg
            acc[k] = (vel[k] - sv[k]) / hg if inertial else 0.0
        # full Newton, or modified Newton: factorise once per step (both stages share
        # h gamma) and again only when the iteration stops contracting fast
        need_jac = (not modified) or work[W_LU_VALID] == 0.0 or refresh
        assemble(
            pos,
            vel,
            acc,
            n_nodes,
            seg_rest,
            seg_mat,
            params,
            t_stage,
            1.0,
            1.0 / hg,
            ca,
            force,
            band,
            work,
            need_jac,
            enabled,
            calls,
            energies,
        )
        for k in range(nd):
            rhs[k] = force[k]
        if need_jac:
            work[W_LU_VALID] = 0.0
            if band_lu(band, nd, KL, KU, piv) != 0:
                info[1] = _worst_node(force, nd)
                return False
            work[W_LU_VALID] = 1.0
            counters[C_FACTORIZATIONS] += 1
            work[W_LU_HG] = hg
            work[W_LU_ND] = nd
            refresh = False
        band_solve(band, nd, KL, KU, piv, rhs)
        counters[C_NEWTON_ITERATIONS] += 1
        norm = 0.0
        for k in range(nd):
            norm += rhs[k] * rhs[k]
        norm = math.sqrt(norm / max(nd + work[W_NORM_EXTRA], 1.0)) / scale
        if not np.isfinite(norm) or norm > 1e12:
            info[1] = _worst_node(rhs, nd)
            return False
        if it > 0 and norm >= 0.95 * previous and need_jac:
            # no contraction with a Jacobian of this very iterate: Newton itself stagnates
            # or cycles, as on the regularised Coulomb friction of the floor, whose force
            # saturates with the sliding speed; the friction is monotone in the velocity,
            # so a damped update breaks the cycle. (A stale Jacobian is refreshed instead.)
            relax *= 0.5
        for k in range(nd):
            pos[k] += relax * rhs[k]
        if modified and not need_jac and norm > 0.3 * previous:
            refresh = True
        if it > 0:
            theta = norm / previous
            if theta > REUSE_THETA:
                work[W_NEWTON_SLOW] = 1.0
            # eta is capped at 1: a slow contraction (contacts switching) must not make the
            # test stricter than |dX| < newton_tol, or Newton runs out of iterations
            eta = min(theta / (1.0 - theta), 1.0) if theta < 1.0 else 1.0
            work[W_NEWTON_ETA] = eta
        previous = norm
        if eta * norm < params[P_NEWTON_TOL]:
            for k in range(nd):
                vel[k] = (pos[k] - sx[k]) / hg
                acc[k] = (vel[k] - sv[k]) / hg if inertial else 0.0
            return True
    info[1] = _worst_node(rhs, nd)
    return False


@njit(cache=True)
def _filtered_norm(
    hg,
    t,
    n_nodes,
    pos,
    vel,
    seg_rest,
    seg_mat,
    params,
    enabled,
    vecs,
    band,
    band2,
    piv,
    work,
    calls,
    energies,
) -> float:
    """RMS of the error estimate filtered through the stage matrix (Shampine's filter).

    e_f = A^{-1} D e, with A = D + K the Newton matrix (its LU is still in ``band``) and
    D = dF/dv / (h gamma) + dF/da / (h gamma)^2 its damping and mass part. Resolved modes
    pass unchanged (A ~ D); stiff transients, which the L-stable stage damps anyway and
    which a split or an imperfection excites, are scaled by D/K << 1 instead of forcing
    the step down to their time scale.
    """
    nd = 3 * free_nodes(n_nodes, params)
    inertial = params[P_INERTIA] > 0.0
    evec = vecs[V_ERR]
    rhs = vecs[V_RHS]
    acc = vecs[V_ACC]
    force = vecs[V_FORCE]
    ca = 1.0 / (hg * hg) if inertial else 0.0
    assemble(
        pos,
        vel,
        acc,
        n_nodes,
        seg_rest,
        seg_mat,
        params,
        t,
        0.0,
        1.0 / hg,
        ca,
        force,
        band2,
        work,
        True,
        enabled,
        calls,
        energies,
    )
    band_matvec(band2, nd, KL, KU, evec, rhs)
    band_solve(band, nd, KL, KU, piv, rhs)
    err = 0.0
    for k in range(nd):
        err += rhs[k] * rhs[k]
    return math.sqrt(err / max(nd + work[W_NORM_EXTRA], 1.0))


@njit(cache=True)
def _implicit_step(
    h,
    t,
    n_nodes,
    integrator,
    pos,
    vel,
    node_s,
    seg_rest,
    seg_mat,
    params,
    enabled,
    flow,
    flow_cum,
    needle,
    vecs,
    band,
    band2,
    piv,
    work,
    calls,
    counters,
    energies,
    info,
) -> float:
    """One SDIRK step (SDIRK2, SDIRK4, or backward Euler); returns the scaled error norm,
    or -1 on failure.

    Stage i solves for X_i with X_i = Sx_i + h gamma V_i and V_i = Sv_i + h gamma A_i,
    Sx_i = x_n + h sum_{j<i} a_ij V_j, Sv_i = v_n + h sum_{j<i} a_ij A_j. The first stage
    starts from x_n + c_1 h v_n, later ones from the last stage's rate: V_i ~ V_{i-1}
    (overdamped) or A_i ~ A_{i-1} (inertia). The result is the last stage (stiffly accurate);
    the error estimate is X_s - x_n - h sum_i b_hat_i V_i, filtered (:func:`_filtered_norm`).
    """
    nd = 3 * free_nodes(n_nodes, params)
    pos0 = vecs[V_POS0]
    vel0 = vecs[V_VEL0]
    sx = vecs[V_SX]
    sv = vecs[V_SV]
    acc = vecs[V_ACC]
    evec = vecs[V_ERR]
    scale = params[P_TOLERANCE] * params[P_NODE_SPACING]
    if integrator == INTEGRATOR_SDIRK4:
        a_mat, c_vec, b_hat = SDIRK4_A, SDIRK4_C, SDIRK4_BHAT
    else:
        a_mat, c_vec, b_hat = SDIRK2_A, SDIRK2_C, SDIRK2_BHAT
    euler = integrator == INTEGRATOR_IMPLICIT_EULER
    inertial = params[P_INERTIA] > 0.0
    n_stages = 1 if euler else a_mat.shape[0]
    gamma = 1.0 if euler else a_mat[0, 0]
    hg = h * gamma
    # The factorised Jacobian of the last step serves this one too (modified Newton across
    # steps, as Radau5) if h gamma and the unknowns are the same and no stage there measured
    # a contraction slower than REUSE_THETA; otherwise it is refreshed at the first
    # iteration. The contraction that Newton's stopping test uses is measured afresh in each
    # step, with the matrix actually used, and then serves the later stages. Carried over
    # from earlier steps (as Radau5 does) a stale estimate let stages stop early: extruding
    # draft runs moved the environments' metrics by ~0.08, and with inertia (velocities
    # (X - Sx)/(h gamma) amplify Newton's position error) SDIRK4's error on the inertial
    # cantilever grew to 5x its truncation error; measured per step, reuse changes it <10%.
    if not (
        abs(work[W_LU_HG] - hg) <= 1e-9 * hg and work[W_LU_ND] == nd and work[W_NEWTON_SLOW] == 0.0
    ):
        work[W_LU_VALID] = 0.0
    work[W_NEWTON_SLOW] = 0.0
    work[W_NEWTON_ETA] = 0.0
    for i in range(n_stages):
        c_i = 1.0 if euler else c_vec[i]
        for k in range(nd):
            sx[k] = pos0[k]
            sv[k] = vel0[k]
        for j in range(i):
            ha = h * a_mat[i, j]
            kv = vecs[V_KV + j]
            ka = vecs[V_KA + j]
            for k in range(nd):
                sx[k] += ha * kv[k]
                sv[k] += ha * ka[k]
        if i == 0:
            for k in range(nd):
                pos[k] = pos0[k] + h * c_i * vel0[k]
        elif inertial:  # A_i ~ A_{i-1}
            a_prev = vecs[V_KA + i - 1]
            for k in range(nd):
                pos[k] = sx[k] + hg * (sv[k] + hg * a_prev[k])
        else:  # V_i ~ V_{i-1}
            v_prev = vecs[V_KV + i - 1]
            for k in range(nd):
                pos[k] = sx[k] + hg * v_prev[k]
        ok = _stage_solve(
            hg,
            t + c_i * h,
            n_nodes,
            pos,
            vel,
            node_s,
            seg_rest,
            seg_mat,
            params,
            enabled,
            flow,
            flow_cum,
            needle,
            vecs,
            band,
            piv,
            work,
            calls,
            counters,
            energies,
            info,
        )
        if not ok:
            return -1.0
        kv = vecs[V_KV + i]
        ka = vecs[V_KA + i]
        for k in range(nd):
            kv[k] = vel[k]
            ka[k] = acc[k]
    if params[P_FIXED_STEP] > 0.0:  # a fixed step needs no error estimate
        return 0.0
    if euler:  # predictor-corrector estimate
        for k in range(nd):
            evec[k] = 0.5 * (pos[k] - pos0[k] - h * vel0[k])
    else:
        for k in range(nd):
            evec[k] = pos[k] - pos0[k]
        for i in range(n_stages):
            hb = h * b_hat[i]
            kv = vecs[V_KV + i]
            for k in range(nd):
                evec[k] -= hb * kv[k]
    return (
        _filtered_norm(
            hg,
            t + h,
            n_nodes,
            pos,
            vel,
            seg_rest,
            seg_mat,
            params,
            enabled,
            vecs,
            band,
            band2,
            piv,
            work,
            calls,
            energies,
        )
        / scale
    )


@njit(cache=True)
def _explicit_step(
    h,
    t,
    n_nodes,
    pos,
    vel,
    node_s,
    seg_rest,
    seg_mat,
    params,
    enabled,
    flow,
    flow_cum,
    needle,
    vecs,
    band,
    piv,
    work,
    calls,
    counters,
    energies,
    info,
) -> float:
    """Forward Euler (overdamped) or symplectic Euler (inertial); returns 0, or -1."""
    nd = 3 * free_nodes(n_nodes, params)
    work[W_LU_VALID] = 0.0  # ``band`` is used below for another matrix
    inertial = params[P_INERTIA] > 0.0
    acc = vecs[V_ACC]
    force = vecs[V_FORCE]
    rhs = vecs[V_RHS]
    pos0 = vecs[V_POS0]
    vel0 = vecs[V_VEL0]
    set_boundary(pos, vel, node_s, seg_rest, n_nodes, t, flow, flow_cum, needle, params, work)
    if inertial:
        for k in range(nd):
            acc[k] = 0.0
            vel[k] = vel0[k]
        assemble(
            pos,
            vel,
            acc,
            n_nodes,
            seg_rest,
            seg_mat,
            params,
            t,
            0.0,
            0.0,
            1.0,
            force,
            band,
            work,
            True,
            enabled,
            calls,
            energies,
        )
        for k in range(nd):
            rhs[k] = force[k]
        if band_lu(band, nd, KL, KU, piv) != 0:
            info[1] = _worst_node(force, nd)
            return -1.0
        band_solve(band, nd, KL, KU, piv, rhs)
        for k in range(nd):
            vel[k] = vel0[k] + h * rhs[k]
            pos[k] = pos0[k] + h * vel[k]
        return 0.0
    scale = params[P_TOLERANCE] * params[P_NODE_SPACING]
    for _it in range(int(params[P_MAX_NEWTON])):
        assemble(
            pos,
            vel,
            acc,
            n_nodes,
            seg_rest,
            seg_mat,
            params,
            t,
            0.0,
            1.0,
            0.0,
            force,
            band,
            work,
            True,
            enabled,
            calls,
            energies,
        )
        for k in range(nd):
            rhs[k] = force[k]
        if band_lu(band, nd, KL, KU, piv) != 0:
            info[1] = _worst_node(force, nd)
            return -1.0
        band_solve(band, nd, KL, KU, piv, rhs)
        norm = 0.0
        for k in range(nd):
            vel[k] += rhs[k]
            norm += (h * rhs[k]) ** 2
        if math.sqrt(norm / max(nd + work[W_NORM_EXTRA], 1.0)) / scale < params[P_NEWTON_TOL]:
            break
    for k in range(nd):
        pos[k] = pos0[k] + h * vel[k]
    return 0.0


@njit(cache=True)
def _max_strain_change(pos0, pos, seg_rest, n_nodes, params) -> float:
    """Largest change of a segment's length over the step, relative to its rest length;
    a strain beyond ``numerics.max_strain`` counts as a change beyond the bound.

    A large strain means the implicit step may have stabilised a physical instability (a
    rod pushed into the floor compresses instead of buckling when h is much longer than
    the buckling time), so the step is retried shorter; a filament that really strains
    more (very soft slugs, very fast jets) needs a larger ``numerics.max_strain``. The
    inlet segment is left out: its rest length grows during the step.
    """
    worst = 0.0
    n_check = filament_segments(n_nodes, params) - (1 if params[P_CLAMPED] > 0.0 else 0)
    for j in range(n_check):
        a = 0.0
        b = 0.0
        for c in range(3):
            a += (pos0[3 * j + 3 + c] - pos0[3 * j + c]) ** 2
            b += (pos[3 * j + 3 + c] - pos[3 * j + c]) ** 2
        change = abs(math.sqrt(b) - math.sqrt(a)) / seg_rest[j]
        worst = max(worst, change)
        s_new = abs(math.sqrt(b) / seg_rest[j] - 1.0)
        if s_new > params[P_MAX_STRAIN]:
            # a strain beyond numerics.max_strain is reported as a change of the same
            # relative size, so the step is retried shorter
            worst = max(worst, params[P_MAX_STRAIN_CHANGE] * s_new / params[P_MAX_STRAIN])
    return worst


@njit(cache=True)
def _check_state(pos, vel, seg_rest, n_nodes, params, info) -> int:
    """Non-finite values or stretch past the bound: a status code, with the node in info."""
    nd = 3 * free_nodes(n_nodes, params)
    for k in range(nd):
        if not (np.isfinite(pos[k]) and np.isfinite(vel[k])):
            info[1] = k // 3
            info[2] = pos[k]
            return STATUS_NAN
    limit = params[P_STRETCH_LIMIT]
    for j in range(filament_segments(n_nodes, params)):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        strain = math.sqrt(ex * ex + ey * ey + ez * ez) / seg_rest[j] - 1.0
        if abs(strain) > limit:
            info[1] = j
            info[2] = strain
            return STATUS_STRETCH
    return STATUS_OK


@njit(cache=True)
def _buckling_step(pos, seg_rest, seg_mat, n_nodes, params) -> float:
    """Time over which the fastest buckling mode of the most compressed segment grows by e:
    1 / sigma, where sigma is the largest root of m sigma^2 + 2 mu_s sigma = Delta with
    Delta = max_k (P k^2 - B k^4) = P^2 / (4 B) (P = E A |strain| the axial compression, B
    the bending stiffness, 2 mu_s the transverse drag, m the mass per length with added
    mass when inertia is on, else 0: sigma = P^2 / (8 B mu_s)). Implicit steps much longer
    than this damp a growing buckle (an L-stable stage maps h sigma >> 1 to decay) and hold a
    compressed rod straight; inf when nothing is compressed."""
    mu_s = params[P_MU_S]
    inertial = params[P_INERTIA] > 0.0
    best = np.inf
    for j in range(filament_segments(n_nodes, params)):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        strain = math.sqrt(ex * ex + ey * ey + ez * ez) / seg_rest[j] - 1.0
        if strain >= 0.0:
            continue
        r = seg_mat[j, MAT_RADIUS]
        e = seg_mat[j, MAT_YOUNGS_MODULUS]
        p_axial = e * seg_mat[j, MAT_STRETCH_FACTOR] * math.pi * r * r * (-strain)
        bend = e * seg_mat[j, MAT_BEND_FACTOR] * math.pi * r**4 / 4.0
        delta = p_axial * p_axial / (4.0 * bend)
        if inertial:
            area = math.pi * r * r
            m = area * (
                seg_mat[j, MAT_DENSITY]
                + params[P_ADDED_MASS_COEFFICIENT] * params[P_BATH_DENSITY_TOP]
            )
            sigma = (math.sqrt(mu_s * mu_s + m * delta) - mu_s) / m
        else:
            sigma = delta / (2.0 * mu_s)
        if sigma > 0.0:  # (rounds to 0 for a vanishing compression)
            best = min(best, 1.0 / sigma)
    return best


@njit(cache=True)
def _rests_on_floor(pos, seg_mat, node: int, params) -> bool:
    """Node within 5% of its radius of the floor contact height (z_floor + r)."""
    r = seg_mat[node, MAT_RADIUS]
    return pos[3 * node + 2] <= params[P_FLOOR_Z] + 1.05 * r


@njit(cache=True)
def advance(
    t_end: float,
    max_steps: int,
    integrator: int,
    pos: np.ndarray,
    vel: np.ndarray,
    node_s: np.ndarray,
    seg_rest: np.ndarray,
    seg_mat: np.ndarray,
    istate: np.ndarray,
    fstate: np.ndarray,
    params: np.ndarray,
    enabled: np.ndarray,
    flow: np.ndarray,
    flow_cum: np.ndarray,
    needle: np.ndarray,
    vecs: np.ndarray,
    band: np.ndarray,
    band2: np.ndarray,
    piv: np.ndarray,
    work: np.ndarray,
    calls: np.ndarray,
    counters: np.ndarray,
    energies: np.ndarray,
    info: np.ndarray,
) -> int:
    """Integrate from fstate[0] to t_end. istate = [n_nodes, n_splits, n_frozen];
    fstate = [t, h_next].

    The first n_frozen nodes (material more than params[P_FREEZE_BEYOND] behind the needle)
    are out of the solve: each step works on array views that start at the first active
    node, whose end is free, and the frozen nodes are translated with that node, so the
    settled tail keeps its shape and stays attached at no cost per Newton iteration.
    Returns a STATUS_* code; on failure ``info`` holds [time, node, value].
    """
    capacity = pos.shape[0] // 3
    n_nodes = istate[0]
    t = fstate[0]
    fixed = params[P_FIXED_STEP]
    h_min = params[P_MIN_STEP]
    h_max = params[P_MAX_STEP]
    dl = params[P_NODE_SPACING]
    area = params[P_NEEDLE_AREA]
    pos0 = vecs[V_POS0]
    vel0 = vecs[V_VEL0]
    freeze_beyond = params[P_FREEZE_BEYOND]
    on_floor = enabled[E_FLOOR] > 0  # only material resting on the floor freezes
    n_moving = 2 if on_floor else 3  # a frozen tail on the floor slides, at its height
    steps = 0
    eps = 1e-12 * max(1.0, abs(t_end))
    while t < t_end - eps:
        if steps >= max_steps:
            fstate[0] = t
            istate[0] = n_nodes
            return STATUS_STEP_LIMIT
        if n_nodes + 2 > capacity:
            fstate[0] = t
            istate[0] = n_nodes
            return STATUS_CAPACITY
        if fixed > 0.0:
            h = fixed
        else:
            h = min(fstate[1], h_max)
            qo, qi = flow_rate(flow, t)
            v_exit = (qo + qi) / area
            if v_exit > 0.0 and params[P_CLAMPED] > 0.0:
                h = min(h, params[P_MAX_INLET_GROWTH] * dl / v_exit)
            if params[P_BUCKLING_STEPS] > 0.0:
                f = istate[2]
                h = min(
                    h,
                    _buckling_step(pos[3 * f :], seg_rest[f:], seg_mat[f:], n_nodes - f, params)
                    / params[P_BUCKLING_STEPS],
                )
        h_taken = min(h, t_end - t)
        if t_end - t - h_taken < 1e-3 * h_taken:
            h_taken = t_end - t
        # views of the active part (no copies): node `frozen` is its free end
        frozen = istate[2]
        if frozen > 0 or work[W_TAIL] > 0.0:
            tail_load(
                pos, seg_rest, seg_mat, frozen, params, enabled[E_GRAVITY] > 0, on_floor, work
            )
        n_act = n_nodes - frozen
        a_pos = pos[3 * frozen :]
        a_vel = vel[3 * frozen :]
        a_node_s = node_s[frozen:]
        a_seg_rest = seg_rest[frozen:]
        a_seg_mat = seg_mat[frozen:]
        nall = 3 * n_act
        for k in range(nall):
            pos0[k] = a_pos[k]
            vel0[k] = a_vel[k]
        info[0] = t
        if integrator == INTEGRATOR_EXPLICIT:
            err = _explicit_step(
                h_taken,
                t,
                n_act,
                a_pos,
                a_vel,
                a_node_s,
                a_seg_rest,
                a_seg_mat,
                params,
                enabled,
                flow,
                flow_cum,
                needle,
                vecs,
                band,
                piv,
                work,
                calls,
                counters,
                energies,
                info,
            )
        else:
            err = _implicit_step(
                h_taken,
                t,
                n_act,
                integrator,
                a_pos,
                a_vel,
                a_node_s,
                a_seg_rest,
                a_seg_mat,
                params,
                enabled,
                flow,
                flow_cum,
                needle,
                vecs,
                band,
                band2,
                piv,
                work,
                calls,
                counters,
                energies,
                info,
            )
        strained = False
        if err >= 0.0 and fixed <= 0.0:
            # a jump in strain means Newton found a spurious (folded) branch: step back
            jump = (
                _max_strain_change(pos0, a_pos, a_seg_rest, n_act, params)
                / params[P_MAX_STRAIN_CHANGE]
            )
            if jump > 1.0:
                strained = 16.0 * jump > err
                err = max(err, 16.0 * jump)
        if err < 0.0:
            info[1] += frozen  # node numbers of the whole filament
        if err < 0.0 or (fixed <= 0.0 and err > 1.0):
            for k in range(nall):
                a_pos[k] = pos0[k]
                a_vel[k] = vel0[k]
            counters[C_REJECTED] += 1
            if err < 0.0:
                counters[C_NEWTON_FAILURES] += 1
                work[W_FULL_NEWTON_STEPS] = 20.0
                work[W_NEWTON_ETA] = 0.0  # the contraction rate is no longer known
                work[W_NEWTON_SLOW] = 1.0
            if fixed > 0.0:
                info[0] = t
                counters[C_FAIL_NODE] = int(info[1])
                fstate[0] = t
                istate[0] = n_nodes
                return STATUS_NEWTON
            if err < 0.0:
                fstate[1] = 0.25 * h_taken
            else:
                fstate[1] = h_taken * max(0.2, 0.9 / _error_root(err, integrator))
            if fstate[1] < h_min:
                info[0] = t
                info[2] = fstate[1]
                fstate[0] = t
                istate[0] = n_nodes
                if err < 0.0:
                    return STATUS_NEWTON
                return STATUS_STRAIN if strained else STATUS_ERROR
            continue
        t += h_taken
        steps += 1
        if work[W_FULL_NEWTON_STEPS] > 0.0:
            work[W_FULL_NEWTON_STEPS] -= 1.0
        counters[C_STEPS] += 1
        info[0] = t
        status = _check_state(a_pos, a_vel, a_seg_rest, n_act, params, info)
        if status != STATUS_OK:
            info[1] += frozen
            fstate[0] = t
            istate[0] = n_nodes
            return status
        transport_curvature(pos0, a_pos, filament_segments(n_act, params), a_seg_mat)
        if frozen > 0:  # the frozen tail moves with the active end, rigidly
            for c in range(n_moving):
                d = a_pos[c] - pos0[c]
                for j in range(frozen):
                    pos[3 * j + c] += d
                    vel[3 * j + c] = a_vel[c]
        if fixed <= 0.0 and h_taken >= 0.999 * h:
            fstate[1] = h * min(5.0, 0.9 / _error_root(max(err, 1e-10), integrator))
        s_tip = extruded_length(flow, flow_cum, area, t)
        while (
            params[P_CLAMPED] > 0.0
            and s_tip - node_s[n_nodes - 3] >= 2.0 * dl
            and n_nodes + 1 <= capacity
        ):
            set_boundary(
                pos, vel, node_s, seg_rest, n_nodes, t, flow, flow_cum, needle, params, work
            )
            n_nodes = split_inlet(
                pos,
                vel,
                node_s,
                seg_rest,
                seg_mat,
                n_nodes,
                t,
                flow,
                flow_cum,
                needle,
                params,
                istate[1],
                work,
            )
            istate[1] += 1
            counters[C_SPLITS] += 1
            work[W_LU_VALID] = 0.0  # the unknowns changed
            if enabled[E_INCLUSIONS]:
                calls[E_INCLUSIONS] += 1
        set_boundary(pos, vel, node_s, seg_rest, n_nodes, t, flow, flow_cum, needle, params, work)
        refresh_inlet_material(node_s, seg_mat, n_nodes, t, flow, flow_cum, needle, params, work)
        if enabled[E_GELATION]:
            calls[E_GELATION] += 1
            gelation.update(t, n_nodes, pos, seg_rest, seg_mat, params, work)
        if freeze_beyond > 0.0 and params[P_CLAMPED] > 0.0:
            frozen = istate[2]
            limit = s_tip - freeze_beyond
            while (
                n_nodes - frozen > MIN_ACTIVE_NODES
                and node_s[frozen] < limit
                and (not on_floor or _rests_on_floor(pos, seg_mat, frozen, params))
            ):
                if on_floor:
                    vel[3 * frozen + 2] = 0.0
                frozen += 1
                work[W_LU_VALID] = 0.0  # the unknowns changed
            istate[2] = frozen
    fstate[0] = t_end
    istate[0] = n_nodes
    return STATUS_OK

"""Time integration: implicit SDIRK2 / SDIRK4 / backward Euler with Newton, and an explicit
reference.

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

Every kernel takes the records of :mod:`bathprint.core.records` (model, state, workspace).
Everything runs inside one numba call per output interval: no Python and no allocation
per step. Failures return a status code and ``state.info`` = [time, node, value].
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core import solver
from bathprint.core.assemble import assemble
from bathprint.core.effects import _hydro_lag, contact, gelation, liquid
from bathprint.core.extrusion import (
    extruded_length,
    flow_rate,
    refresh_inlet_material,
    set_boundary,
    split_inlet,
    transport_curvature,
)
from bathprint.core.freezing import tail_load
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import (
    C_BACKTRACKS,
    C_CONTACT_REJECTIONS,
    C_DAMPED_NEWTON,
    C_FACTORIZATIONS,
    C_FAIL_NODE,
    C_NEWTON_FAILURES,
    C_NEWTON_ITERATIONS,
    C_REJECTED,
    C_SPLITS,
    C_STEPS,
    E_CONTACT,
    E_FLOOR,
    E_GELATION,
    E_GRAVITY,
    E_HYDRODYNAMICS,
    E_INCLUSIONS,
    E_LIQUID,
    INTEGRATOR_EXPLICIT,
    INTEGRATOR_IMPLICIT_EULER,
    INTEGRATOR_SDIRK4,
    MAT_BEND_FACTOR,
    MAT_DENSITY,
    MAT_RADIUS,
    MAT_STRETCH_FACTOR,
    MAT_YOUNGS_MODULUS,
    STATUS_CAPACITY,
    STATUS_CONTACT,
    STATUS_ERROR,
    STATUS_KRYLOV,
    STATUS_NAN,
    STATUS_NEWTON,
    STATUS_OK,
    STATUS_STEP_LIMIT,
    STATUS_STRAIN,
    STATUS_STRETCH,
)
from bathprint.core.records import Out, Rod, Stage
from bathprint.core.topology import filament_segments, free_nodes

GAMMA = 1.0 - 1.0 / math.sqrt(2.0)
MIN_ACTIVE_NODES = 6  # freezing leaves at least this many nodes (tip and ghost included)
# why a step attempt ended as it did (integrators._attempt)
CAUSE_ERROR = 0  # the error estimate (or a Newton failure)
CAUSE_STRAIN = 1  # a strain bound
CAUSE_CONTACT = 2  # the no-pass-through bound of self-contact
CAUSE_CAPACITY = 3  # the contact pairs do not fit: grow and call again (nothing was done)
FILTER_OVERFLOW = -2.0  # the error filter's blocks off the band did not fit: grow them

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

# rows of the vector workspace ``ws.vecs`` (each 3 * capacity long)
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
V_DX = V_KA + MAX_STAGES  # the last Newton update (the line search's direction)
N_VECS = V_DX + 1
ARMIJO = 1e-4  # sufficient decrease of the force residual per unit of the update applied
MAX_BACKTRACKS = 5  # halvings of an update before its Jacobian is refreshed


@njit(**KERNEL, inline="always")
def active_rod(state, ws, frozen: int) -> Rod:
    """The rod past the ``frozen`` tail nodes, as views (no copies); node 0 is its free end."""
    f = frozen
    return Rod(
        state.pos[3 * f :],
        state.vel[3 * f :],
        ws.vecs[V_ACC],
        state.ints[0] - f,
        state.node_s[f:],
        state.seg_rest[f:],
        state.seg_mat[f:],
    )


@njit(**KERNEL, inline="always")
def _out(state, ws, band, cpl) -> Out:
    """Where a force evaluation of the current step writes."""
    whole = active_rod(state, ws, 0)
    start = ws.vecs[V_POS0]
    return Out(
        ws.vecs[V_FORCE],
        band,
        ws.tail,
        ws.scratch,
        cpl,
        ws.contact,
        whole,
        state.ints[2],
        start,
        ws.hydro,
    )


@njit(**KERNEL, inline="always")
def _error_root(err: float, integrator: int) -> float:
    """err^(1/(p_hat + 1)), p_hat the order of the embedded solution: the factor by which
    the error norm scales the next step."""
    if integrator == INTEGRATOR_SDIRK4:
        return math.sqrt(math.sqrt(err))
    return math.sqrt(err)


@njit(**KERNEL)
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


@kernel
def _rms(vec: np.ndarray, nd: int, ws) -> float:
    """RMS over the whole filament: the frozen tail counts with zero (``norm_extra``)."""
    s = 0.0
    for k in range(nd):
        s += vec[k] * vec[k]
    return math.sqrt(s / max(nd + ws.solver[0].norm_extra, 1.0))


@njit(**KERNEL, inline="always")
def _stage_rates(model, rod, ws, nd: int, hg: float, t_stage: float, inertial: bool) -> None:
    """The stage's boundary nodes at ``t_stage``, and its velocities and accelerations from
    the free positions (v = (x - x_s) / (h gamma), a = (v - v_s) / (h gamma))."""
    set_boundary(model, rod, t_stage, ws.scratch)
    pos, vel, acc = rod.pos, rod.vel, rod.acc
    sx = ws.vecs[V_SX]
    sv = ws.vecs[V_SV]
    for k in range(nd):
        vel[k] = (pos[k] - sx[k]) / hg
        acc[k] = (vel[k] - sv[k]) / hg if inertial else 0.0


@njit(**KERNEL, inline="always")
def _norm(vec: np.ndarray, nd: int) -> float:
    """Euclidean norm of the first ``nd`` entries."""
    s = 0.0
    for k in range(nd):
        s += vec[k] * vec[k]
    return math.sqrt(s)


@kernel
def _stage_solve(model, rod, state, ws, hg: float, t_stage: float) -> bool:
    """Newton solve of one implicit stage for the free node positions ``rod.pos``."""
    p = model.params[0]
    sol = ws.solver[0]
    pos, vel, acc = rod.pos, rod.vel, rod.acc
    nd = 3 * free_nodes(rod.n_nodes, p)
    inertial = p.inertial
    sx = ws.vecs[V_SX]
    sv = ws.vecs[V_SV]
    rhs = ws.vecs[V_RHS]
    out = _out(state, ws, ws.band, ws.cpl)
    force = out.force
    scale = p.tolerance * p.node_spacing
    stage = Stage(t_stage, 1.0, 1.0 / hg, 1.0 / (hg * hg) if inertial else 0.0, False)
    jac_stage = Stage(stage.t, stage.cx, stage.cv, stage.ca, True)
    # after a Newton failure (e.g. contacts switching) full Newton for a while
    modified = p.newton_reuse and sol.full_newton_steps <= 0.0
    refresh = False
    previous = np.inf
    relax = 1.0  # fraction of the Newton update applied
    # Hairer & Wanner's stopping test (Radau5): stop once eta * |dX| < newton_tol, where
    # eta = theta / (1 - theta) bounds the error left after the update dX from the
    # contraction rate theta; before a rate is measured in this step, eta = 1 (the plain
    # test |dX| < newton_tol). With a fast contraction later stages stop after one
    # iteration.
    eta = sol.newton_eta if sol.newton_eta > 0.0 else 1.0
    # line search (p.line_search): the last update dx, the fraction alpha of it applied, and
    # the force residual |F| where it started; an update that does not decrease |F| by
    # ARMIJO alpha is halved (Armijo backtracking on |F|, Dennis & Schnabel 1996, sec. 6.3)
    dx = ws.vecs[V_DX]
    alpha = 1.0
    f_start = 0.0
    for it in range(p.max_newton):
        _stage_rates(model, rod, ws, nd, hg, t_stage, inertial)
        # full Newton, or modified Newton: factorise once per step (all stages share
        # h gamma) and again only when the iteration stops contracting fast
        need_jac = (not modified) or (not sol.lu_valid) or refresh
        assemble(model, rod, jac_stage if need_jac else stage, out, state.calls, state.energies)
        if p.line_search:
            f_norm = _norm(force, nd)
            backtracks = 0
            while it > 0 and f_norm > (1.0 - ARMIJO * alpha) * f_start:
                if backtracks == MAX_BACKTRACKS:
                    # no descent along dx: a stale Jacobian's direction, or a kink of the
                    # force; take the shortest trial and a fresh Jacobian here
                    need_jac = need_jac or modified
                    break
                alpha *= 0.5
                for k in range(nd):
                    pos[k] -= alpha * dx[k]
                _stage_rates(model, rod, ws, nd, hg, t_stage, inertial)
                assemble(model, rod, stage, out, state.calls, state.energies)
                f_norm = _norm(force, nd)
                backtracks += 1
                state.counters[C_BACKTRACKS] += 1
            if backtracks > 0:
                state.counters[C_DAMPED_NEWTON] += 1
                if need_jac:
                    assemble(model, rod, jac_stage, out, state.calls, state.energies)
            f_start = f_norm
        for k in range(nd):
            rhs[k] = force[k]
        if need_jac:
            sol.lu_valid = False
            if not solver.factor(ws, nd):
                state.info[1] = _worst_node(force, nd)
                return False
            sol.lu_valid = True
            state.counters[C_FACTORIZATIONS] += 1
            sol.lu_hg = hg
            sol.lu_nd = nd
            refresh = False
        if not solver.solve(ws, nd, rhs, state.counters, p.krylov_tolerance):
            sol.krylov_failed = True
            state.info[1] = _worst_node(force, nd)
            return False
        state.counters[C_NEWTON_ITERATIONS] += 1
        norm = _rms(rhs, nd, ws) / scale
        if not np.isfinite(norm) or norm > 1e12:
            state.info[1] = _worst_node(rhs, nd)
            return False
        if it > 0 and norm >= 0.95 * previous and need_jac and not p.line_search:
            # no contraction with a Jacobian of this very iterate: Newton itself stagnates
            # or cycles, as on the regularised Coulomb friction of the floor, whose force
            # saturates with the sliding speed; the friction is monotone in the velocity,
            # so a damped update breaks the cycle. (A stale Jacobian is refreshed instead.)
            relax *= 0.5
        if relax < 1.0:
            state.counters[C_DAMPED_NEWTON] += 1
        for k in range(nd):
            pos[k] += relax * rhs[k]
            dx[k] = rhs[k]
        alpha = 1.0
        if modified and not need_jac and norm > 0.3 * previous:
            refresh = True
        if it > 0:
            theta = norm / previous
            if theta > REUSE_THETA:
                sol.newton_slow = True
            # eta is capped at 1: a slow contraction (contacts switching) must not make the
            # test stricter than |dX| < newton_tol, or Newton runs out of iterations
            eta = min(theta / (1.0 - theta), 1.0) if theta < 1.0 else 1.0
            sol.newton_eta = eta
        previous = norm
        if eta * norm < p.newton_tolerance:
            for k in range(nd):
                vel[k] = (pos[k] - sx[k]) / hg
                acc[k] = (vel[k] - sv[k]) / hg if inertial else 0.0
            return True
    state.info[1] = _worst_node(rhs, nd)
    return False


@kernel
def _filtered_norm(model, rod, state, ws, hg: float, t: float) -> float:
    """RMS of the error estimate filtered through the stage matrix (Shampine's filter).

    e_f = A^{-1} D e, with A = D + K the Newton matrix (its LU is still in ``band``) and
    D = dF/dv / (h gamma) + dF/da / (h gamma)^2 its damping and mass part. Resolved modes
    pass unchanged (A ~ D); stiff transients, which the L-stable stage damps anyway and
    which a split or an imperfection excites, are scaled by D/K << 1 instead of forcing
    the step down to their time scale.
    """
    p = model.params[0]
    nd = 3 * free_nodes(rod.n_nodes, p)
    evec = ws.vecs[V_ERR]
    rhs = ws.vecs[V_RHS]
    ca = 1.0 / (hg * hg) if p.inertial else 0.0
    stage = Stage(t, 0.0, 1.0 / hg, ca, True)
    # D and A^-1 both whole: contact's dashpot and friction add D's blocks between
    # distant nodes (``ws.cpl_filter``), as they add A's
    cpl = ws.cpl_filter
    assemble(model, rod, stage, _out(state, ws, ws.band2, cpl), state.calls, state.energies)
    if cpl.count[0] > cpl.row.shape[0]:
        return FILTER_OVERFLOW
    solver.damping_times(ws, nd, evec, rhs)
    if not solver.solve(ws, nd, rhs, state.counters, p.krylov_tolerance):
        ws.solver[0].krylov_failed = True  # a failure at the smallest step says so
        return np.inf
    return _rms(rhs, nd, ws)


@kernel
def _implicit_step(model, rod, state, ws, h: float, t: float) -> float:
    """One SDIRK step (SDIRK2, SDIRK4, or backward Euler); returns the scaled error norm,
    or -1 on failure.

    Stage i solves for X_i with X_i = Sx_i + h gamma V_i and V_i = Sv_i + h gamma A_i,
    Sx_i = x_n + h sum_{j<i} a_ij V_j, Sv_i = v_n + h sum_{j<i} a_ij A_j. The first stage
    starts from x_n + c_1 h v_n, later ones from the last stage's rate: V_i ~ V_{i-1}
    (overdamped) or A_i ~ A_{i-1} (inertia). The result is the last stage (stiffly accurate);
    the error estimate is X_s - x_n - h sum_i b_hat_i V_i, filtered (:func:`_filtered_norm`).
    """
    p = model.params[0]
    sol = ws.solver[0]
    vecs = ws.vecs
    pos, vel, acc = rod.pos, rod.vel, rod.acc
    nd = 3 * free_nodes(rod.n_nodes, p)
    pos0 = vecs[V_POS0]
    vel0 = vecs[V_VEL0]
    sx = vecs[V_SX]
    sv = vecs[V_SV]
    evec = vecs[V_ERR]
    scale = p.tolerance * p.node_spacing
    integrator = p.integrator
    if integrator == INTEGRATOR_SDIRK4:
        a_mat, c_vec, b_hat = SDIRK4_A, SDIRK4_C, SDIRK4_BHAT
    else:
        a_mat, c_vec, b_hat = SDIRK2_A, SDIRK2_C, SDIRK2_BHAT
    euler = integrator == INTEGRATOR_IMPLICIT_EULER
    inertial = p.inertial
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
    if not (abs(sol.lu_hg - hg) <= 1e-9 * hg and sol.lu_nd == nd and not sol.newton_slow):
        sol.lu_valid = False
    sol.newton_slow = False
    sol.krylov_failed = False
    sol.newton_eta = 0.0
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
        if not _stage_solve(model, rod, state, ws, hg, t + c_i * h):
            return -1.0
        kv = vecs[V_KV + i]
        ka = vecs[V_KA + i]
        for k in range(nd):
            kv[k] = vel[k]
            ka[k] = acc[k]
    if p.fixed_step > 0.0:  # a fixed step needs no error estimate
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
    err = _filtered_norm(model, rod, state, ws, hg, t + h)
    return err if err == FILTER_OVERFLOW else err / scale


@njit(**KERNEL)
def explicit_step(model, rod, state, ws, h: float, t: float) -> float:
    """Forward Euler (overdamped) or symplectic Euler (inertial); returns 0, or -1.

    With h = 0 it gives an overdamped state its consistent velocity (D v = F)."""
    p = model.params[0]
    sol = ws.solver[0]
    pos, vel, acc = rod.pos, rod.vel, rod.acc
    nd = 3 * free_nodes(rod.n_nodes, p)
    sol.lu_valid = False  # ``band`` is used below for another matrix
    rhs = ws.vecs[V_RHS]
    pos0 = ws.vecs[V_POS0]
    vel0 = ws.vecs[V_VEL0]
    out = _out(state, ws, ws.band, ws.cpl)
    force = out.force
    set_boundary(model, rod, t, ws.scratch)
    if p.inertial:
        for k in range(nd):
            acc[k] = 0.0
            vel[k] = vel0[k]
        assemble(model, rod, Stage(t, 0.0, 0.0, 1.0, True), out, state.calls, state.energies)
        for k in range(nd):
            rhs[k] = force[k]
        if not solver.factor(ws, nd) or not solver.solve(
            ws, nd, rhs, state.counters, p.krylov_tolerance
        ):
            state.info[1] = _worst_node(force, nd)
            return -1.0
        for k in range(nd):
            vel[k] = vel0[k] + h * rhs[k]
            pos[k] = pos0[k] + h * vel[k]
        return 0.0
    scale = p.tolerance * p.node_spacing
    stage = Stage(t, 0.0, 1.0, 0.0, True)
    for _it in range(p.max_newton):
        assemble(model, rod, stage, out, state.calls, state.energies)
        for k in range(nd):
            rhs[k] = force[k]
        if not solver.factor(ws, nd) or not solver.solve(
            ws, nd, rhs, state.counters, p.krylov_tolerance
        ):
            state.info[1] = _worst_node(force, nd)
            return -1.0
        norm = 0.0
        for k in range(nd):
            vel[k] += rhs[k]
            norm += (h * rhs[k]) ** 2
        if math.sqrt(norm / max(nd + sol.norm_extra, 1.0)) / scale < p.newton_tolerance:
            break
    for k in range(nd):
        pos[k] = pos0[k] + h * vel[k]
    return 0.0


@kernel
def _max_strain_change(pos0, rod, p) -> tuple[float, int]:
    """Largest change of a segment's length over the step, relative to its rest length;
    a strain beyond ``numerics.max_strain`` counts as a change beyond the bound.

    A large strain means the implicit step may have stabilised a physical instability (a
    rod pushed into the floor compresses instead of buckling when h is much longer than
    the buckling time), so the step is retried shorter; a filament that really strains
    more (very soft slugs, very fast jets) needs a larger ``numerics.max_strain``. The
    inlet segment is left out: its rest length grows during the step. Returns the change
    and the segment that has it.
    """
    pos, seg_rest = rod.pos, rod.seg_rest
    worst = 0.0
    worst_seg = 0
    n_check = filament_segments(rod.n_nodes, p) - (1 if p.clamped else 0)
    for j in range(n_check):
        a = 0.0
        b = 0.0
        for c in range(3):
            a += (pos0[3 * j + 3 + c] - pos0[3 * j + c]) ** 2
            b += (pos[3 * j + 3 + c] - pos[3 * j + c]) ** 2
        change = abs(math.sqrt(b) - math.sqrt(a)) / seg_rest[j]
        s_new = abs(math.sqrt(b) / seg_rest[j] - 1.0)
        if s_new > p.max_strain:
            # a strain beyond numerics.max_strain is reported as a change of the same
            # relative size, so the step is retried shorter
            change = max(change, p.max_strain_change * s_new / p.max_strain)
        if change > worst:
            worst = change
            worst_seg = j
    return worst, worst_seg


@kernel
def _check_state(rod, p, info) -> int:
    """Non-finite values or stretch past the bound: a status code, with the node in info."""
    pos, vel, seg_rest = rod.pos, rod.vel, rod.seg_rest
    nd = 3 * free_nodes(rod.n_nodes, p)
    for k in range(nd):
        if not (np.isfinite(pos[k]) and np.isfinite(vel[k])):
            info[1] = k // 3
            info[2] = pos[k]
            return STATUS_NAN
    limit = p.stretch_limit
    for j in range(filament_segments(rod.n_nodes, p)):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        strain = math.sqrt(ex * ex + ey * ey + ez * ez) / seg_rest[j] - 1.0
        if abs(strain) > limit:
            info[1] = j
            info[2] = strain
            return STATUS_STRETCH
    return STATUS_OK


@njit(**KERNEL)
def buckling_time(rod, p) -> float:
    """Time over which the fastest buckling mode of the most compressed segment grows by e:
    1 / sigma, where sigma is the largest root of m sigma^2 + 2 mu_s sigma = Delta with
    Delta = max_k (P k^2 - B k^4) = P^2 / (4 B) (P = E A |strain| the axial compression, B
    the bending stiffness, 2 mu_s the transverse drag, m the mass per length with added
    mass when inertia is on, else 0: sigma = P^2 / (8 B mu_s)). Implicit steps much longer
    than this damp a growing buckle (an L-stable stage maps h sigma >> 1 to decay) and hold a
    compressed rod straight; inf when nothing is compressed."""
    pos, seg_rest, seg_mat = rod.pos, rod.seg_rest, rod.seg_mat
    mu_s = p.mu_s
    best = np.inf
    for j in range(filament_segments(rod.n_nodes, p)):
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
        if p.inertial:
            area = math.pi * r * r
            m = area * (seg_mat[j, MAT_DENSITY] + p.added_mass_coefficient * p.bath_density_top)
            sigma = (math.sqrt(mu_s * mu_s + m * delta) - mu_s) / m
        else:
            sigma = delta / (2.0 * mu_s)
        if sigma > 0.0:  # (rounds to 0 for a vanishing compression)
            best = min(best, 1.0 / sigma)
    return best


@njit(**KERNEL)
def _rests_on_floor(pos, seg_mat, node: int, p) -> bool:
    """Node within 5% of its radius of the floor contact height (z_floor + r)."""
    r = seg_mat[node, MAT_RADIUS]
    return pos[3 * node + 2] <= p.floor_z + 1.05 * r


@kernel
def _proposed_step(model, state, ws) -> float:
    """The next step: fixed, or the controller's, bounded by the largest step, the inlet's
    growth (``numerics.max_inlet_growth`` node spacings), the buckling rate and, with
    contact, the relative motion that keeps segments from passing through each other."""
    p = model.params[0]
    if p.fixed_step > 0.0:
        return p.fixed_step
    t = state.clock[0]
    h = min(state.clock[1], p.max_step)
    qo, qi = flow_rate(model.flow, t)
    v_exit = (qo + qi) / p.needle_area
    if v_exit > 0.0 and p.clamped:
        h = min(h, p.max_inlet_growth * p.node_spacing / v_exit)
    if p.buckling_steps > 0.0:
        f = state.ints[2]
        n = state.ints[0]
        rod = Rod(
            state.pos[3 * f :],
            state.vel[3 * f :],
            state.vel[3 * f :],
            n - f,
            state.node_s[f:],
            state.seg_rest[f:],
            state.seg_mat[f:],
        )
        h = min(h, buckling_time(rod, p) / p.buckling_steps)
    if model.enabled[E_CONTACT]:
        h = min(h, contact.step_limit(ws.contact))
    return h


@kernel
def _attempt(model, state, ws, h: float) -> tuple[float, int]:
    """Take one step of size h on the active rod; returns (scaled error, or -1 on failure;
    which bound set it: CAUSE_*)."""
    p = model.params[0]
    t = state.clock[0]
    frozen = state.ints[2]
    if frozen > 0 or ws.tail[0].on:
        whole = active_rod(state, ws, 0)
        gravity_on = model.enabled[E_GRAVITY] > 0
        tail_load(model, whole, frozen, gravity_on, model.enabled[E_FLOOR] > 0, ws)
    rod = active_rod(state, ws, frozen)
    contact_on = model.enabled[E_CONTACT] > 0
    if contact_on and not contact.prepare(model, active_rod(state, ws, 0), frozen, ws.contact):
        return -1.0, CAUSE_CAPACITY
    hydro_on = model.enabled[E_HYDRODYNAMICS] > 0
    if hydro_on:  # lagged coupling: the nonlocal flow at the step's start
        _hydro_lag.prepare(model, rod, _out(state, ws, ws.band2, ws.cpl_drop), state)
    pos0 = ws.vecs[V_POS0]
    vel0 = ws.vecs[V_VEL0]
    for k in range(3 * rod.n_nodes):
        pos0[k] = rod.pos[k]
        vel0[k] = rod.vel[k]
    state.info[0] = t
    if p.integrator == INTEGRATOR_EXPLICIT:
        err = explicit_step(model, rod, state, ws, h, t)
    else:
        err = _implicit_step(model, rod, state, ws, h, t)
        if err == FILTER_OVERFLOW:  # undo the step: grow the filter's blocks, then retry
            for k in range(3 * rod.n_nodes):
                rod.pos[k] = pos0[k]
                rod.vel[k] = vel0[k]
            return -1.0, CAUSE_CAPACITY
    cause = CAUSE_ERROR
    if err >= 0.0 and p.fixed_step <= 0.0:
        # a jump in strain means Newton found a spurious (folded) branch: step back
        change, seg = _max_strain_change(pos0, rod, p)
        jump = change / p.max_strain_change
        if jump > 1.0:
            if 16.0 * jump > err:
                cause = CAUSE_STRAIN
                state.info[1] = seg + frozen
            err = max(err, 16.0 * jump)
    if err >= 0.0 and hydro_on:  # lagged coupling: the lag's error joins the estimate
        lag = _hydro_lag.check(
            model, rod, _out(state, ws, ws.band2, ws.cpl_drop), state, h, ws.solver[0].norm_extra
        )
        if p.fixed_step <= 0.0:
            err += lag
    if err >= 0.0 and contact_on:
        whole = active_rod(state, ws, 0)
        ratio = contact.check(model, whole, pos0, frozen, ws.contact)
        if ratio >= 1.0:
            # segments may have passed through each other: never accepted; the retry is
            # about 0.5 / ratio as long (the controller's factor 0.9 / sqrt(err))
            state.counters[C_CONTACT_REJECTIONS] += 1
            state.info[1] = ws.contact.memory[0].pair_i
            state.info[2] = ws.contact.memory[0].pair_j
            cause = CAUSE_CONTACT
            err = max(err, 3.24 * ratio * ratio) if p.fixed_step <= 0.0 else -1.0
    if err < 0.0 and cause != CAUSE_CONTACT:
        state.info[1] += frozen  # node numbers of the whole filament
    return err, cause


@kernel
def _reject(model, state, ws, h: float, err: float, cause: int) -> int:
    """Restore the state of the step's start and shrink the next step; a status code."""
    p = model.params[0]
    sol = ws.solver[0]
    rod = active_rod(state, ws, state.ints[2])
    pos0 = ws.vecs[V_POS0]
    vel0 = ws.vecs[V_VEL0]
    for k in range(3 * rod.n_nodes):
        rod.pos[k] = pos0[k]
        rod.vel[k] = vel0[k]
    state.counters[C_REJECTED] += 1
    if err < 0.0 and cause != CAUSE_CONTACT:
        state.counters[C_NEWTON_FAILURES] += 1
        sol.full_newton_steps = 20.0
        sol.newton_eta = 0.0  # the contraction rate is no longer known
        sol.newton_slow = True
    t = state.clock[0]
    if p.fixed_step > 0.0:
        state.info[0] = t
        if cause == CAUSE_CONTACT:
            return STATUS_CONTACT
        state.counters[C_FAIL_NODE] = int(state.info[1])
        return STATUS_KRYLOV if sol.krylov_failed else STATUS_NEWTON
    if err < 0.0:
        state.clock[1] = 0.25 * h
    else:
        state.clock[1] = h * max(0.2, 0.9 / _error_root(err, p.integrator))
    if state.clock[1] < p.min_step:
        state.info[0] = t
        if cause == CAUSE_CONTACT:
            return STATUS_CONTACT
        state.info[2] = state.clock[1]
        if err < 0.0 or (cause == CAUSE_ERROR and sol.krylov_failed):
            return STATUS_KRYLOV if sol.krylov_failed else STATUS_NEWTON
        return STATUS_STRAIN if cause == CAUSE_STRAIN else STATUS_ERROR
    return STATUS_OK


@kernel
def _accept(model, state, ws, h: float, h_taken: float, err: float) -> int:
    """After an accepted step: check the state, carry the curvature and the frozen tail
    along, set the next step, give birth to nodes at the inlet, update the material, and
    freeze settled material. A status code."""
    p = model.params[0]
    enabled = model.enabled
    sol = ws.solver[0]
    frozen = state.ints[2]
    rod = active_rod(state, ws, frozen)
    pos0 = ws.vecs[V_POS0]
    t = state.clock[0] + h_taken
    state.clock[0] = t
    if sol.full_newton_steps > 0.0:
        sol.full_newton_steps -= 1.0
    state.counters[C_STEPS] += 1
    state.info[0] = t
    status = _check_state(rod, p, state.info)
    if status != STATUS_OK:
        state.info[1] += frozen
        return status
    transport_curvature(pos0, rod.pos, filament_segments(rod.n_nodes, p), rod.seg_mat)
    on_floor = enabled[E_FLOOR] > 0  # only material resting on the floor freezes
    if frozen > 0:  # the frozen tail moves with the active end, rigidly
        n_moving = 2 if on_floor else 3  # a frozen tail on the floor slides, at its height
        for c in range(n_moving):
            d = rod.pos[c] - pos0[c]
            for j in range(frozen):
                state.pos[3 * j + c] += d
                state.vel[3 * j + c] = rod.vel[c]
    if p.fixed_step <= 0.0 and h_taken >= 0.999 * h:
        state.clock[1] = h * min(5.0, 0.9 / _error_root(max(err, 1e-10), p.integrator))
    if enabled[E_CONTACT]:
        contact.accepted(model, ws.contact, h_taken)
    s_tip = extruded_length(model.flow, model.flow_cum, p.needle_area, t)
    capacity = state.pos.shape[0] // 3
    whole = active_rod(state, ws, 0)
    while (
        p.clamped
        and s_tip - state.node_s[state.ints[0] - 3] >= 2.0 * p.node_spacing
        and state.ints[0] + 1 <= capacity
    ):
        set_boundary(model, whole, t, ws.scratch)
        state.ints[0] = split_inlet(model, whole, t, state.ints[1], ws.scratch)
        whole = active_rod(state, ws, 0)
        state.ints[1] += 1
        state.counters[C_SPLITS] += 1
        sol.lu_valid = False  # the unknowns changed
        if enabled[E_INCLUSIONS]:
            state.calls[E_INCLUSIONS] += 1
    set_boundary(model, whole, t, ws.scratch)
    refresh_inlet_material(model, whole, t, ws.scratch)
    if enabled[E_GELATION]:
        state.calls[E_GELATION] += 1
        gelation.update(model, whole, t, ws.scratch)
    if enabled[E_LIQUID]:
        state.calls[E_LIQUID] += 1
        liquid.update(model, whole, t, h_taken, ws.scratch)
    if p.freeze_beyond > 0.0 and p.clamped:
        limit = s_tip - p.freeze_beyond
        while (
            state.ints[0] - frozen > MIN_ACTIVE_NODES
            and state.node_s[frozen] < limit
            and (not on_floor or _rests_on_floor(state.pos, state.seg_mat, frozen, p))
        ):
            if on_floor:
                state.vel[3 * frozen + 2] = 0.0
            frozen += 1
            sol.lu_valid = False  # the unknowns changed
        state.ints[2] = frozen
    return STATUS_OK


@njit(**KERNEL)
def advance(model, state, ws, t_end: float, max_steps: int) -> int:
    """Integrate from ``state.clock[0]`` to t_end; returns a STATUS_* code (on failure
    ``state.info`` holds [time, node, value]).

    The first ``state.ints[2]`` nodes (material further than ``numerics.freeze_beyond_mm``
    behind the needle) are out of the solve: each step works on array views that start at
    the first active node, whose end is free, and the frozen nodes are translated with it,
    so the settled tail keeps its shape and stays attached at no cost per Newton iteration.
    """
    capacity = state.pos.shape[0] // 3
    eps = 1e-12 * max(1.0, abs(t_end))
    steps = 0
    while state.clock[0] < t_end - eps:
        if steps >= max_steps:
            return STATUS_STEP_LIMIT
        if state.ints[0] + 2 > capacity:
            return STATUS_CAPACITY
        t = state.clock[0]
        h = _proposed_step(model, state, ws)
        h_taken = min(h, t_end - t)
        if t_end - t - h_taken < 1e-3 * h_taken:
            h_taken = t_end - t
        if ws.cpl.count[0] > ws.cpl.row.shape[0]:
            return STATUS_CAPACITY  # couplings off the band overflowed: grow them
        err, cause = _attempt(model, state, ws, h_taken)
        if cause == CAUSE_CAPACITY:
            return STATUS_CAPACITY
        if err < 0.0 or (model.params[0].fixed_step <= 0.0 and err > 1.0):
            status = _reject(model, state, ws, h_taken, err, cause)
            if status != STATUS_OK:
                return status
            continue
        steps += 1
        status = _accept(model, state, ws, h, h_taken, err)
        if status != STATUS_OK:
            return status
    state.clock[0] = t_end
    return STATUS_OK

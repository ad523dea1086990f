"""Compiled kernels of the version-1 environments (numba): recording the printed samples as
they become scored, their squared errors, and the observation vector."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.envs._kernels import circle_curvature, interp_rows, metric_errors, step_at


@njit(cache=True)
def record_samples(
    u: np.ndarray,
    x: np.ndarray,
    rho: np.ndarray,
    origin: float,
    h: float,
    j0: int,
    j1: int,
    pts: np.ndarray,
    dens: np.ndarray,
) -> None:
    """pts[j], dens[j] for j0 <= j < j1: the position (interpolated along the material
    coordinate u) and the density (of the segment holding it) at u = origin + j h."""
    m = j1 - j0
    if m <= 0:
        return
    uq = np.empty(m)
    for i in range(m):
        uq[i] = origin + (j0 + i) * h
    out = np.empty((m, 3))
    interp_rows(u, x, uq, out)
    d = np.empty(m)
    step_at(u, rho, uq, d)
    for i in range(m):
        for a in range(3):
            pts[j0 + i, a] = out[i, a]
        dens[j0 + i] = d[i]


@njit(cache=True)
def squared_sum(errors: np.ndarray, n: int) -> float:
    """sum_{j < n} errors[j]^2, in order."""
    acc = 0.0
    for j in range(n):
        acc += errors[j] * errors[j]
    return acc


@njit(cache=True, error_model="numpy")
def observe_v1(
    x: np.ndarray,
    v: np.ndarray,
    u: np.ndarray,
    rho: np.ndarray,
    query: np.ndarray,
    n_tip: int,
    n_vel: int,
    curv_idx: np.ndarray,
    dens_off: np.ndarray,
    sc: np.ndarray,
    tfeat: np.ndarray,
    tgt_off: np.ndarray,
    s_now: float,
    h: float,
    extra: np.ndarray,
    clip: float,
) -> np.ndarray:
    """The version-1 observation (float32, NaN -> 0, clipped to +-clip): filament positions
    relative to the tip and velocities at the query offsets behind the tip, the curvature of
    the back sampling at ``curv_idx``, densities at ``dens_off`` (none if empty), the target
    features ``tfeat`` (N, F) at printed arclength ``s_now`` + ``tgt_off`` (none if F = 0),
    then ``extra`` as is. ``sc`` = [length, speed, curvature, density ref, density scale]."""
    n = x.shape[0]
    u_tip = u[n - 1]
    m = query.shape[0]
    uq = np.empty(m)
    for i in range(m):
        uq[i] = u_tip - query[i]
    xi = np.empty((m, 3))
    vi = np.empty((n_vel, 3))
    interp_rows(u, x, uq, xi)
    interp_rows(u, v, uq[n_tip : n_tip + n_vel], vi)
    back = np.ascontiguousarray(xi[n_tip + n_vel :])
    kap = np.empty(back.shape[0])
    circle_curvature(back, 2, kap)
    nd = dens_off.shape[0]
    ud = np.empty(nd)
    for i in range(nd):
        ud[i] = u_tip - dens_off[i]
    rd = np.empty(nd)
    if nd > 0:
        step_at(u, rho, ud, rd)
    nf = tfeat.shape[1]
    nt = tgt_off.shape[0] if nf > 0 else 0
    size = 3 * n_tip + 3 * n_vel + curv_idx.shape[0] + nd + nt * nf + extra.shape[0]
    obs = np.empty(size)
    o = 0
    for i in range(n_tip):
        for a in range(3):
            obs[o] = (xi[i, a] - x[n - 1, a]) / sc[0]
            o += 1
    for i in range(n_vel):
        for a in range(3):
            obs[o] = vi[i, a] / sc[1]
            o += 1
    for i in range(curv_idx.shape[0]):
        obs[o] = kap[curv_idx[i]] * sc[2]
        o += 1
    for i in range(nd):
        obs[o] = (rd[i] - sc[3]) / sc[4]
        o += 1
    n_tgt = tfeat.shape[0]
    for i in range(nt):
        r = (s_now + tgt_off[i]) / h
        f = math.floor(r)  # round half to even, as np.round
        if r - f > 0.5 or (r - f == 0.5 and f % 2.0 != 0.0):
            f += 1.0
        k = min(max(int(f), 0), n_tgt - 1)
        for a in range(nf):
            obs[o] = tfeat[k, a]
            o += 1
    for i in range(extra.shape[0]):
        obs[o] = extra[i]
        o += 1
    out = np.empty(size, np.float32)
    for i in range(size):
        y = obs[i]
        if y != y:
            y = 0.0
        elif y > clip:
            y = clip
        elif y < -clip:
            y = -clip
        out[i] = y
    return out


@njit(cache=True)
def _split_goal(g, size, shape_on, density_on, free_lo, free_hi):
    """A goal vector's samples (size x 3), densities lo and hi, count and previous count
    (:meth:`bathprint.envs.goals.GoalLayout.split`); views of ``g`` where it holds
    them, new arrays only for what it does not score."""
    k = 3 * size if shape_on else 0
    if shape_on:
        pts = np.ascontiguousarray(g[:k]).reshape(size, 3)
    else:
        pts = np.zeros((size, 3))
    if density_on:
        lo = np.ascontiguousarray(g[k : k + size])
        hi = np.ascontiguousarray(g[k + size : k + 2 * size])
    else:
        lo = np.full(size, free_lo)
        hi = np.full(size, free_hi)
    return pts, lo, hi, int(np.rint(g[g.shape[0] - 2])), int(np.rint(g[g.shape[0] - 1]))


@njit(cache=True)
def _goal_sse(a_pts, a_rho, count, tpts, tcurv, tlo, thi, half, k, w, reflect, b_lo, b_hi):
    """Sum of squared errors of the first ``count`` achieved samples against the desired
    goal's (:meth:`bathprint.envs.goals.GoalLayout.sse`)."""
    j = min(count, tpts.shape[0])
    errors = metric_errors(
        a_pts[:j], a_rho[:j], tpts, tcurv, tlo, thi, half, k, w, reflect, b_lo, b_hi
    )[0]
    return squared_sum(errors, j)


@njit(cache=True)
def goal_rewards(
    achieved: np.ndarray,
    desired: np.ndarray,
    size: int,
    shape_on: bool,
    density_on: bool,
    free_lo: float,
    free_hi: float,
    half: int,
    k: int,
    curvature_on: bool,
    w: np.ndarray,
    reflect: bool,
    bath_lo: float,
    bath_hi: float,
    out: np.ndarray,
) -> None:
    """out[i]: the reward of reaching ``achieved[i]`` for ``desired[i]`` (rows of goal
    vectors), the decrease of the scored samples' sum of squared errors from the achieved
    goal's previous count to its count, over the desired goal's count; the operations of
    :meth:`bathprint.envs.v1.BathprintEnvV1.goal_reward` sample by sample, in one compiled
    loop (hindsight replay asks for a batch at every gradient step)."""
    for i in range(achieved.shape[0]):
        a_pts, a_rho, _, n, n_prev = _split_goal(
            achieved[i], size, shape_on, density_on, free_lo, free_hi
        )
        d_pts, d_lo, d_hi, n_d, _ = _split_goal(
            desired[i], size, shape_on, density_on, free_lo, free_hi
        )
        if n_d <= 0:
            out[i] = 0.0
            continue
        tpts = d_pts[:n_d]
        tcurv = np.zeros(0)
        if curvature_on:
            tcurv = np.empty(n_d)
            circle_curvature(tpts, k, tcurv)
        tlo, thi = d_lo[:n_d], d_hi[:n_d]
        before = _goal_sse(
            a_pts, a_rho, n_prev, tpts, tcurv, tlo, thi, half, k, w, reflect, bath_lo, bath_hi
        )
        after = _goal_sse(
            a_pts, a_rho, n, tpts, tcurv, tlo, thi, half, k, w, reflect, bath_lo, bath_hi
        )
        out[i] = (before - after) / n_d

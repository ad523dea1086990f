"""Compiled kernels of the environments (numba): the windowed Kabsch RMSD of the metric, and
the per-step fast path (flow table update, state read, printed samples, metric, observation).

The fast-path kernels reproduce the numpy expressions they replace operation by operation
(same order, numpy's pairwise summation for means), so their results are bit-identical.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _sym3_eigen_top2(s00, s01, s02, s11, s12, s22):  # noqa: ANN001, ANN202
    """The two largest eigenvalues of a symmetric 3x3 matrix (closed form)."""
    q = (s00 + s11 + s22) / 3.0
    p1 = s01 * s01 + s02 * s02 + s12 * s12
    p2 = (s00 - q) ** 2 + (s11 - q) ** 2 + (s22 - q) ** 2 + 2.0 * p1
    p = math.sqrt(p2 / 6.0)
    if p <= 0.0:
        return q, q
    b00, b11, b22 = (s00 - q) / p, (s11 - q) / p, (s22 - q) / p
    b01, b02, b12 = s01 / p, s02 / p, s12 / p
    det = (
        b00 * (b11 * b22 - b12 * b12)
        - b01 * (b01 * b22 - b12 * b02)
        + b02 * (b01 * b12 - b11 * b02)
    )
    r = min(max(0.5 * det, -1.0), 1.0)
    phi = math.acos(r) / 3.0
    l1 = q + 2.0 * p * math.cos(phi)
    l3 = q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)
    return l1, 3.0 * q - l1 - l3


@njit(cache=True)
def windowed_kabsch(
    p: np.ndarray, q: np.ndarray, half: int, reflect: bool, out: np.ndarray
) -> None:
    """out[j] = RMS distance of p and q ((n, 3) each) over the window [j - half, j + half]
    (cut to [0, n)) after the optimal rigid alignment (also mirror images if ``reflect``).

    Prefix sums make it O(n); the singular values of the 3x3 cross-covariance H come from
    the eigenvalues of H^T H in closed form, the smallest one from det(H) = s1 s2 s3.
    """
    n = p.shape[0]
    cp = np.zeros((n + 1, 3))
    cq = np.zeros((n + 1, 3))
    cpp = np.zeros(n + 1)
    cqq = np.zeros(n + 1)
    cpq = np.zeros((n + 1, 9))
    mp = np.zeros(3)
    mq = np.zeros(3)
    for i in range(n):
        for a in range(3):
            mp[a] += p[i, a] / n
            mq[a] += q[i, a] / n
    for i in range(n):
        sp = 0.0
        sq = 0.0
        for a in range(3):
            x = p[i, a] - mp[a]
            y = q[i, a] - mq[a]
            cp[i + 1, a] = cp[i, a] + x
            cq[i + 1, a] = cq[i, a] + y
            sp += x * x
            sq += y * y
            for b in range(3):
                cpq[i + 1, 3 * a + b] = cpq[i, 3 * a + b] + x * (q[i, b] - mq[b])
        cpp[i + 1] = cpp[i] + sp
        cqq[i + 1] = cqq[i] + sq
    h = np.zeros(9)
    for j in range(n):
        lo = max(j - half, 0)
        hi = min(j + half + 1, n)
        m = hi - lo
        e0 = cpp[hi] - cpp[lo] + cqq[hi] - cqq[lo]
        for a in range(3):
            spa = cp[hi, a] - cp[lo, a]
            sqa = cq[hi, a] - cq[lo, a]
            e0 -= (spa * spa + sqa * sqa) / m
            for b in range(3):
                h[3 * a + b] = (
                    cpq[hi, 3 * a + b] - cpq[lo, 3 * a + b] - spa * (cq[hi, b] - cq[lo, b]) / m
                )
        # S = H^T H (symmetric)
        s = np.zeros(6)
        k = 0
        for a in range(3):
            for b in range(a, 3):
                acc = 0.0
                for c in range(3):
                    acc += h[3 * c + a] * h[3 * c + b]
                s[k] = acc
                k += 1
        l1, l2 = _sym3_eigen_top2(s[0], s[1], s[2], s[3], s[4], s[5])
        s1 = math.sqrt(max(l1, 0.0))
        s2 = math.sqrt(max(l2, 0.0))
        det = (
            h[0] * (h[4] * h[8] - h[5] * h[7])
            - h[1] * (h[3] * h[8] - h[5] * h[6])
            + h[2] * (h[3] * h[7] - h[4] * h[6])
        )
        s3 = min(abs(det) / (s1 * s2), s2) if s1 * s2 > 0.0 else 0.0
        if det < 0.0 and not reflect:
            s3 = -s3
        msd = (e0 - 2.0 * (s1 + s2 + s3)) / m
        out[j] = math.sqrt(max(msd, 0.0))


@njit(cache=True)
def interp_rows(u: np.ndarray, x: np.ndarray, uq: np.ndarray, out: np.ndarray) -> None:
    """out[i] = x linearly interpolated at uq[i] along the increasing u (clamped at the ends);
    x is (n, k), out (m, k)."""
    n = u.shape[0]
    k = x.shape[1]
    for i in range(uq.shape[0]):
        t = uq[i]
        if t <= u[0]:
            for c in range(k):
                out[i, c] = x[0, c]
            continue
        if t >= u[n - 1]:
            for c in range(k):
                out[i, c] = x[n - 1, c]
            continue
        lo = 0
        hi = n - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if u[mid] <= t:
                lo = mid
            else:
                hi = mid
        du = u[hi] - u[lo]
        f = (t - u[lo]) / du if du > 0.0 else 0.0
        for c in range(k):
            out[i, c] = x[lo, c] + f * (x[hi, c] - x[lo, c])


@njit(cache=True)
def circle_curvature(points: np.ndarray, k: int, out: np.ndarray) -> None:
    """out[j] = curvature of the circle through samples j-k, j, j+k (the ends take the
    nearest interior value; 0 for degenerate triples or fewer than 2k+1 samples)."""
    n = points.shape[0]
    if k < 1 or n < 2 * k + 1:
        for j in range(n):
            out[j] = 0.0
        return
    for j in range(n):
        m = min(max(j, k), n - 1 - k)
        a0, a1, a2 = points[m - k, 0], points[m - k, 1], points[m - k, 2]
        b0, b1, b2 = points[m, 0], points[m, 1], points[m, 2]
        c0, c1, c2 = points[m + k, 0], points[m + k, 1], points[m + k, 2]
        ab0, ab1, ab2 = b0 - a0, b1 - a1, b2 - a2
        bc0, bc1, bc2 = c0 - b0, c1 - b1, c2 - b2
        ac0, ac1, ac2 = c0 - a0, c1 - a1, c2 - a2
        x0 = ab1 * ac2 - ab2 * ac1
        x1 = ab2 * ac0 - ab0 * ac2
        x2 = ab0 * ac1 - ab1 * ac0
        area2 = math.sqrt(x0 * x0 + x1 * x1 + x2 * x2)
        den = math.sqrt(
            (ab0 * ab0 + ab1 * ab1 + ab2 * ab2)
            * (bc0 * bc0 + bc1 * bc1 + bc2 * bc2)
            * (ac0 * ac0 + ac1 * ac1 + ac2 * ac2)
        )
        out[j] = 2.0 * area2 / den if den > 1e-30 else 0.0


@njit(cache=True)
def _block_sum(a: np.ndarray, lo: int, n: int) -> float:
    """Sum of a[lo:lo + n], n <= 128, in numpy's order (8 accumulators when n >= 8)."""
    if n < 8:
        res = 0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = lo + 8
    end8 = lo + n - n % 8
    while i < end8:
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < lo + n:
        res += a[i]
        i += 1
    return res


@njit(cache=True)
def pairwise_sum(a: np.ndarray, lo: int, n: int) -> float:
    """Sum of a[lo:lo + n] in numpy's order (``np.add.reduce``: blocks of <= 128 summed 8-way
    unrolled, halves (cut at a multiple of 8) added pairwise). Iterative: numba's cache does
    not take recursive functions."""
    if n <= 128:
        return _block_sum(a, lo, n)
    # post-order walk of numpy's recursion with explicit stacks (depth <= log2(n))
    s_lo = np.empty(64, np.int64)
    s_n = np.empty(64, np.int64)
    s_stage = np.empty(64, np.int64)
    partial = np.empty(64)
    s_lo[0], s_n[0], s_stage[0] = lo, n, 0
    sp = 1
    rp = 0
    while sp > 0:
        top = sp - 1
        m = s_n[top]
        if m <= 128:
            partial[rp] = _block_sum(a, s_lo[top], m)
            rp += 1
            sp -= 1
            continue
        half = m // 2
        half -= half % 8
        if s_stage[top] == 0:  # left half first
            s_stage[top] = 1
            s_lo[sp], s_n[sp], s_stage[sp] = s_lo[top], half, 0
            sp += 1
        elif s_stage[top] == 1:  # then the right half
            s_stage[top] = 2
            s_lo[sp], s_n[sp], s_stage[sp] = s_lo[top] + half, m - half, 0
            sp += 1
        else:  # both done: left + right
            partial[rp - 2] = partial[rp - 2] + partial[rp - 1]
            rp -= 1
            sp -= 1
    return partial[0]


@njit(cache=True, error_model="numpy")
def read_state(x: np.ndarray, v: np.ndarray, rest: np.ndarray, scale: float) -> tuple:
    """x /= scale, v /= scale in place; returns (u, finite): u = [0, cumsum(rest)] / scale
    and whether x, u and v are all finite."""
    ok = True
    for i in range(x.shape[0]):
        for a in range(3):
            x[i, a] = x[i, a] / scale
            v[i, a] = v[i, a] / scale
            ok = ok and math.isfinite(x[i, a]) and math.isfinite(v[i, a])
    u = np.empty(rest.shape[0] + 1)
    u[0] = 0.0 / scale
    c = 0.0
    for i in range(rest.shape[0]):
        c = rest[0] if i == 0 else c + rest[i]
        u[i + 1] = c / scale
        ok = ok and math.isfinite(u[i + 1])
    return u, ok


@njit(cache=True)
def step_at(u: np.ndarray, values: np.ndarray, uq: np.ndarray, out: np.ndarray) -> None:
    """out[i] = values[k] for the last k with u[k] <= uq[i] (clipped to values' range), as
    ``values[clip(searchsorted(u, uq, 'right') - 1, 0, len(values) - 1)]``."""
    n = u.shape[0]
    last = values.shape[0] - 1
    for i in range(uq.shape[0]):
        t = uq[i]
        lo = 0
        hi = n  # first index with u[index] > t, by bisection
        while lo < hi:
            mid = (lo + hi) // 2
            if u[mid] <= t:
                lo = mid + 1
            else:
                hi = mid
        out[i] = values[min(max(lo - 1, 0), last)]


@njit(cache=True)
def printed_at(
    u: np.ndarray, x: np.ndarray, rho: np.ndarray, u0: float, h: float, j: int
) -> tuple[np.ndarray, np.ndarray]:
    """Positions (interpolated) and densities (per segment) at u0 + i h, i < j."""
    uq = np.empty(j)
    for i in range(j):
        uq[i] = u0 + i * h
    pts = np.empty((j, 3))
    dens = np.empty(j)
    interp_rows(u, x, uq, pts)
    step_at(u, rho, uq, dens)
    return pts, dens


@njit(cache=True, error_model="numpy")
def metric_errors(
    pts: np.ndarray,
    rho: np.ndarray,
    tpts: np.ndarray,
    tcurv: np.ndarray,
    tlo: np.ndarray,
    thi: np.ndarray,
    half: int,
    k: int,
    w: np.ndarray,
    reflect: bool,
    bath_lo: float,
    bath_hi: float,
) -> tuple:
    """Per-sample errors and the parts of :func:`bathprint.envs.metric.evaluate`.

    ``w`` = [w_shape, w_curvature, w_density, length_scale, density_scale, missing^2].
    Returns (errors, value, shape_rms, curvature_rms, density_rms).
    """
    w_shape, w_curv, w_dens, ls, ds, m2 = w[0], w[1], w[2], w[3], w[4], w[5]
    n_all = tpts.shape[0]
    n = min(pts.shape[0], n_all)
    err2 = np.full(n_all, m2)
    shape = curv = dens = 0.0
    if n > 0:
        e2 = np.zeros(n)
        tmp = np.empty(n)
        if w_shape > 0:
            d = np.zeros(n)
            windowed_kabsch(pts[:n], tpts[:n], half, reflect, d)
            for i in range(n):
                r = d[i] / ls
                e2[i] += w_shape * (r * r)
                tmp[i] = d[i] * d[i]
            shape = math.sqrt(pairwise_sum(tmp, 0, n) / n)
        if w_curv > 0:
            kap = np.empty(n)
            circle_curvature(pts[:n], k, kap)
            for i in range(n):
                dk = kap[i] - tcurv[i] if n >= 2 * k + 1 else 0.0
                r = ls * dk
                e2[i] += w_curv * (r * r)
                tmp[i] = dk * dk
            curv = math.sqrt(pairwise_sum(tmp, 0, n) / n)
        if w_dens > 0:
            for i in range(n):
                r = rho[i]
                if r < bath_lo:
                    r = bath_lo
                if r > bath_hi:
                    r = bath_hi
                below = tlo[i] - r
                above = r - thi[i]
                if below < 0.0:
                    below = 0.0
                if above < 0.0:
                    above = 0.0
                dr = below + above
                q = dr / ds
                e2[i] += w_dens * (q * q)
                tmp[i] = dr * dr
            dens = math.sqrt(pairwise_sum(tmp, 0, n) / n)
        for i in range(n):
            err2[i] = e2[i] if e2[i] <= m2 else m2  # NaN too
    value = math.sqrt(pairwise_sum(err2, 0, n_all) / n_all)
    errors = np.sqrt(err2)
    return errors, value, shape, curv, dens


@njit(cache=True, error_model="numpy")
def observe(
    x: np.ndarray,
    v: np.ndarray,
    u: np.ndarray,
    rho: np.ndarray,
    layout: tuple,
    tfeat: np.ndarray,
    progress: np.ndarray,
    controls: np.ndarray,
    errors: np.ndarray,
    clip: float,
) -> np.ndarray:
    """The observation vector (float32, ``bathprint.envs.observation.OBS_LAYOUT``), NaN -> 0 and
    clipped to +-clip.

    ``layout`` = (query offsets behind the tip (tip | velocity | back sampling), n_tip, n_vel,
    curvature indices into the back sampling, density offsets, target offsets, scales
    [length, speed, curvature, density ref, density scale], recent-sample count).
    ``tfeat``: (N, 3) target features; ``progress`` = [printed, spacing, episode length,
    scored fraction, metric, missing error, scored count]; ``controls``: the 6 entries.
    """
    query, n_tip, n_vel, curv_idx, dens_off, tgt_off, sc, n_recent = layout
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
    step_at(u, rho, ud, rd)
    nt = tgt_off.shape[0]
    size = 3 * n_tip + 3 * n_vel + curv_idx.shape[0] + nd + 3 * nt + controls.shape[0] + 4
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
    printed, h, n_tgt = progress[0], progress[1], tfeat.shape[0]
    for i in range(nt):
        r = (printed + tgt_off[i]) / h
        f = math.floor(r)  # round half to even, as np.round
        if r - f > 0.5 or (r - f == 0.5 and f % 2.0 != 0.0):
            f += 1.0
        k = min(max(int(f), 0), n_tgt - 1)
        for a in range(3):
            obs[o] = tfeat[k, a]
            o += 1
    for i in range(controls.shape[0]):
        obs[o] = controls[i]
        o += 1
    miss = progress[5]
    j = int(progress[6])
    lo = max(0, j - n_recent)
    obs[o] = printed / progress[2]
    obs[o + 1] = progress[3]
    obs[o + 2] = progress[4] / miss
    obs[o + 3] = pairwise_sum(errors, lo, j - lo) / (j - lo) / miss if j > lo else 1.0
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

"""Compiled kernels of the environments (numba): the windowed Kabsch RMSD of the metric."""

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

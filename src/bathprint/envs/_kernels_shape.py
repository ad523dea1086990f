"""Compiled kernel of the shape environments' reward: the squared distances of a written
prefix to the target's after the family's best rigid motion (as
:func:`bathprint.envs.shape_metric.align`, without numpy's per-call overhead: the reward
needs it every step)."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

#: motion codes: rotation about the vertical + any translation (floor); any proper rotation
#: + any translation (free); rotation about the vertical + horizontal translation (buoyant)
MOTIONS = {"floor": 0, "free": 1, "buoyant": 2}


@njit(cache=True)
def aligned_squared_distances(w: np.ndarray, t: np.ndarray, motion: int, d2: np.ndarray) -> None:
    """d2[i] = |R (w_i - w_c) + t_c - t_i|^2 for the best motion of code ``motion``
    (:data:`MOTIONS`) of the (n, 3) polyline ``w`` onto ``t`` (mm^2)."""
    n = w.shape[0]
    wc = np.zeros(3)
    tc = np.zeros(3)
    naxes = 2 if motion == 2 else 3
    for i in range(n):
        for k in range(naxes):
            wc[k] += w[i, k]
            tc[k] += t[i, k]
    for k in range(naxes):
        wc[k] /= n
        tc[k] /= n
    r = np.eye(3)
    if motion == 1:
        h = np.zeros((3, 3))
        for i in range(n):
            for a in range(3):
                for b in range(3):
                    h[a, b] += (w[i, a] - wc[a]) * (t[i, b] - tc[b])
        u, _, vt = np.linalg.svd(h)
        m = vt.T @ u.T
        det = np.linalg.det(m)
        d = 1.0 if det >= 0.0 else -1.0
        dm = np.eye(3)
        dm[2, 2] = d
        r = vt.T @ dm @ u.T
    else:
        num = 0.0
        den = 0.0
        for i in range(n):
            px, py = w[i, 0] - wc[0], w[i, 1] - wc[1]
            qx, qy = t[i, 0] - tc[0], t[i, 1] - tc[1]
            num += px * qy - py * qx
            den += px * qx + py * qy
        a = math.atan2(num, den)
        c, s = math.cos(a), math.sin(a)
        r[0, 0], r[0, 1], r[1, 0], r[1, 1] = c, -s, s, c
    for i in range(n):
        acc = 0.0
        for a in range(3):
            x = tc[a] - t[i, a]
            for b in range(3):
                x += r[a, b] * (w[i, b] - wc[b])
            acc += x * x
        d2[i] = acc


@njit(cache=True)
def prefix_error_sums(
    w: np.ndarray, t: np.ndarray, motion: int, cap2: float, d2: np.ndarray
) -> tuple[float, float, float]:
    """(sum of d2, largest d2, sum of min(d2, cap2)) of :func:`aligned_squared_distances`
    (mm^2): what the reward's potential needs, in one call."""
    aligned_squared_distances(w, t, motion, d2)
    total = 0.0
    largest = 0.0
    capped = 0.0
    for i in range(d2.shape[0]):
        x = d2[i]
        total += x
        if x > largest:
            largest = x
        capped += x if x < cap2 else cap2
    return total, largest, capped

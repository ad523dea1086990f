"""The knot tables of flow and needle schedules (bathprint.core.extrusion)."""

from __future__ import annotations

import numpy as np

from bathprint.core.extrusion import _interval


def _linear_scan(table: np.ndarray, t: float) -> int:
    if t < table[0, 0]:
        return -1
    for k in range(table.shape[0] - 1):
        if t < table[k + 1, 0]:
            return k
    return table.shape[0] - 1


def test_bisection_finds_the_interval_a_linear_scan_finds_with_repeated_knots() -> None:
    # step changes put two knots at one time: the interval is the first with t < t_k+1
    rng = np.random.default_rng(0)
    for _ in range(2000):
        n = int(rng.integers(1, 12))
        table = np.zeros((n, 3))
        table[:, 0] = np.sort(np.round(rng.uniform(0.0, 5.0, n), 1))
        for t in [*table[:, 0], *rng.uniform(-1.0, 6.0, 4)]:
            assert _interval(table, float(t)) == _linear_scan(table, float(t))

"""Aggregate scores with confidence intervals, in the manner of Agarwal et al. (2021).

Scores are matrices of shape (runs, targets): the final metric M (lower is better) of each
seed of an agent on each test target; a deterministic baseline is one run. Every interval
is a 95% percentile interval of rliable's stratified bootstrap over runs *and* targets
(``task_bootstrap=True``: the spread a different draw of seeds and of test targets would
give), with the baselines' per-target values resampled together with the agent's, so
paired quantities stay paired. rliable draws its indices from numpy's global generator;
:func:`bootstrap_ci` seeds it (and restores it), so the same scores give the same
intervals.

- :func:`iqm`: interquartile mean over all (run, target) scores (rliable's
  ``aggregate_iqm``), robust to a few diverged runs;
- :func:`summary`: IQM and mean of M, success rate, normalised score
  (M̄_constant − M̄) / (M̄_constant − M̄_oracle), the paired difference against a reference
  (M_agent − M_reference per target, averaged), the fraction of the gap from the reference
  to the oracle closed, and the targets won, each with its interval.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

CONFIDENCE = 0.95


def _check(name: str, m: Any) -> np.ndarray:
    a = np.asarray(m, dtype=float)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2 or a.size == 0:
        raise ValueError(f"{name}: scores of shape {a.shape}; expected (runs, targets)")
    if not np.isfinite(a).all():
        raise ValueError(f"{name}: scores hold NaN or inf")
    return a


def iqm(scores: np.ndarray) -> float:
    """Interquartile mean of all entries (the mean of the middle 50%, rliable's
    ``aggregate_iqm``)."""
    return iqm_raw(_check("scores", scores))


def bootstrap_ci(
    func: Callable[..., float],
    *arrays: np.ndarray,
    reps: int = 2000,
    seed: int = 0,
    size: float = CONFIDENCE,
) -> tuple[float, float, float]:
    """(point estimate, low, high) of ``func(*arrays)`` under rliable's stratified
    bootstrap over runs and targets; ``arrays`` share the shape (runs, targets) and are
    resampled with the same indices.

    The replicates are rliable's own, drawn without arch's generic bootstrap machinery
    (and without importing rliable, about 2 s): each draws the run of every (run, target)
    cell, then the targets, from numpy's global generator seeded with ``seed``, as
    ``StratifiedBootstrap.update_indices`` does; the interval is ``np.percentile`` of the
    replicates at the percentile method's levels, as ``IIDBootstrap.conf_int`` takes them.
    :func:`rliable_bootstrap_ci` runs rliable itself; the tests hold the two equal bit for
    bit."""
    arrays = _same_shape(arrays)
    runs, n = arrays[0].shape
    point = float(func(*arrays))
    results = np.empty(reps)
    state = np.random.get_state()  # noqa: NPY002
    np.random.seed(seed)  # noqa: NPY002
    try:
        for r in range(reps):
            # np.random.choice(k, shape, replace=True) is randint(0, k, shape) (the same
            # draws), without choice's argument checks
            rows = np.random.randint(0, runs, (runs, n))  # noqa: NPY002
            cols = np.random.randint(0, n, (1, n))  # noqa: NPY002
            results[r] = func(*(a[rows, cols] for a in arrays))
    finally:
        np.random.set_state(state)  # noqa: NPY002
    alpha = (1.0 - size) / 2
    levels = [100 * q for q in np.array([alpha, 1.0 - alpha])]
    lo, hi = np.percentile(results, levels)
    return point, float(lo), float(hi)


def rliable_bootstrap_ci(
    func: Callable[..., float],
    *arrays: np.ndarray,
    reps: int = 2000,
    seed: int = 0,
    size: float = CONFIDENCE,
) -> tuple[float, float, float]:
    """:func:`bootstrap_ci` through rliable's ``StratifiedBootstrap`` (the reference)."""
    from rliable.library import StratifiedBootstrap

    arrays = _same_shape(arrays)
    point = float(func(*arrays))
    # rliable's update_indices draws from numpy's global generator (random_state unused)
    state = np.random.get_state()  # noqa: NPY002
    np.random.seed(seed)  # noqa: NPY002
    try:
        bs = StratifiedBootstrap(*arrays, task_bootstrap=True)
        ci = bs.conf_int(lambda *a: np.array([func(*a)]), reps=reps, size=size,
                         method="percentile")
    finally:
        np.random.set_state(state)  # noqa: NPY002
    lo, hi = float(np.ravel(ci[0])[0]), float(np.ravel(ci[1])[0])
    return point, lo, hi


def _same_shape(arrays: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    arrays = tuple(_check(f"array {k}", a) for k, a in enumerate(arrays))
    shape = arrays[0].shape
    if any(a.shape != shape for a in arrays):
        raise ValueError(f"arrays of shapes {[a.shape for a in arrays]}; expected one shape")
    return arrays


def iqm_raw(m: np.ndarray) -> float:
    """:func:`iqm` without the checks (inside the bootstrap): scipy's ``trim_mean`` of the
    flattened scores at 0.25 (rliable's ``aggregate_iqm``), the same numpy operations
    without scipy's per-call wrapper."""
    a = np.ravel(m)
    cut = int(0.25 * a.shape[0])
    upper = a.shape[0] - cut
    return float(np.mean(np.partition(a, (cut, upper - 1), 0)[cut:upper], axis=0))


def summary(
    metric: np.ndarray,
    success: np.ndarray | None,
    constant: np.ndarray | None,
    oracle: np.ndarray | None,
    reference: np.ndarray | None = None,
    reps: int = 2000,
    seed: int = 0,
) -> dict[str, Any]:
    """Every aggregate of one policy's (runs, targets) metrics. ``constant``, ``oracle``
    and ``reference`` (the calibrated feedforward) are per-target metrics (targets,) of the
    baselines on the same targets, in the same order; without ``constant`` and ``oracle``
    there is no normalised score (and without ``oracle`` no gap closed)."""
    m = _check("metric", metric)
    runs, n = m.shape

    def per_target(name: str, v: np.ndarray) -> np.ndarray:
        a = np.asarray(v, float).ravel()
        if a.shape != (n,):
            raise ValueError(f"{name}: {a.shape[0]} targets; the policy has {n}")
        return np.repeat(a[None, :], runs, axis=0)

    def ci(func: Callable[..., float], *arrays: np.ndarray) -> list[float]:
        return list(bootstrap_ci(func, *arrays, reps=reps, seed=seed))

    out: dict[str, Any] = {
        "runs": runs,
        "targets": n,
        "mean_metric": ci(lambda x: x.mean(), m),
        "iqm_metric": ci(iqm_raw, m),
    }
    o = per_target("oracle", oracle) if oracle is not None else None
    if constant is not None and o is not None:
        c = per_target("constant", constant)
        out["normalised_score"] = ci(
            lambda x, c_, o_: (c_.mean() - x.mean()) / (c_.mean() - o_.mean()), m, c, o
        )
    if success is not None:
        s = _check("success", success)
        out["success_rate"] = ci(lambda x: x.mean(), s)
    if reference is not None:
        r = per_target("reference", reference)
        out["paired_difference"] = ci(lambda x, r_: (x - r_).mean(), m, r)
        if o is not None:
            out["gap_closed"] = ci(
                lambda x, r_, o_: (r_.mean() - x.mean()) / (r_.mean() - o_.mean()), m, r, o
            )
        wins = (m.mean(axis=0) < r[0] - 1e-12).sum()
        out["targets_won"] = int(wins)
    return out

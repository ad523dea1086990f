"""``bathprint baselines fit``: the best constant action and the scaling law's prefactor.

Both are fitted on *training* targets (drawn with seeds ``seed, seed + 1, ...`` from the
training family, which never yields a held-out target), never on the evaluation set:

- best constant: every action of a grid (``--grid-q-outer`` values of Q_o, ``--grid-q-inner``
  of Q_i, ``--grid-offset`` of the inclusion offset, each evenly spaced over [-1, 1] in
  action units; a grid of one value is mid-range, or Q_i = 0 for Q_i) is held for whole
  episodes on ``--targets`` targets; the one with the lowest mean final metric wins.
- prefactor: in the runs with Q_i = 0 and no offset, the median radius R of the osculating
  helix of the printed (scored) filament is measured, and c in R = c (B / (mu v))^(1/3) is
  the geometric mean of R / (B / (mu v))^(1/3) over them (B, mu, v as in
  :class:`bathprint.agents.policies.FeedforwardPolicy`).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np
from tqdm import tqdm

from bathprint.agents.policies import ConstantPolicy, LawConstants, law_radius_m
from bathprint.agents.rollout import run_episode
from bathprint.envs.targets import discrete_curvature, discrete_torsion


def _grid(n: int, single: float = 0.0) -> list[float]:
    """n values evenly spaced over [-1, 1] in action units; one value is ``single``."""
    if n < 1:
        raise ValueError(f"grid size {n!r}; must be >= 1")
    return [single] if n == 1 else [float(x) for x in np.linspace(-1.0, 1.0, n)]


def printed_coil_radius_mm(env: Any) -> float:
    """Median radius (mm) of the osculating helix R = kappa / (kappa^2 + tau^2) over the
    scored printed filament (NaN if fewer than 9 samples are scored)."""
    p = env.unwrapped.printed_samples().points_mm
    if len(p) < 9:
        return math.nan
    k = discrete_curvature(p, 2)
    t = discrete_torsion(p, 2)
    den = k * k + t * t
    good = den > 1e-12
    return float(np.median(k[good] / den[good])) if good.any() else math.nan


def fit_baselines(
    env_id: str,
    accuracy: str = "draft",
    n_targets: int = 4,
    grid_q_outer: int = 8,
    grid_q_inner: int = 4,
    grid_offset: int = 3,
    seed: int = 1000,
    progress: bool = True,
) -> dict[str, Any]:
    """Run the search; returns the ``baselines.yml`` entry (with the table of every action)."""
    from bathprint.envs import make, resolve_id

    env_id = resolve_id(env_id)
    env = make(env_id, accuracy=accuracy, target_set="train")
    u = env.unwrapped
    names = u.action_names
    axes = [_grid(grid_q_outer)]
    axes.append(_grid(grid_q_inner, -1.0) if "q_inner" in names else [])  # one value: Q_i = 0
    axes.append(_grid(grid_offset) if "inclusion_offset" in names else [])
    grids = [ax for ax in axes if ax]
    actions = [np.array(a, np.float32) for a in itertools.product(*grids)]
    dim = env.action_space.shape[0]
    if dim != len(grids):  # needle velocity components stay 0
        actions = [np.concatenate([a, np.zeros(dim - len(grids), np.float32)]) for a in actions]
    law = LawConstants.from_env(env)
    i_off = names.index("inclusion_offset") if "inclusion_offset" in names else None
    table: list[dict[str, Any]] = []
    ratios: list[float] = []
    bar = tqdm(total=len(actions) * n_targets, desc=f"fit {env_id}", disable=not progress)
    for a in actions:
        policy = ConstantPolicy(a)
        metrics, radii = [], []
        ctl = u.action_to_controls(a)
        plain = ctl["q_inner_ml_min"] == 0.0 and (i_off is None or a[i_off] == 0.0)
        for k in range(n_targets):
            ep = run_episode(env, policy, seed + k)
            metrics.append(ep.metrics["metric"])
            if plain and not ep.truncated:
                radii.append(printed_coil_radius_mm(env))
            bar.update()
        row = {
            "action": [round(float(x), 6) for x in a],
            "q_outer_ml_min": round(float(ctl["q_outer_ml_min"]), 6),
            "q_inner_ml_min": round(float(ctl["q_inner_ml_min"]), 6),
            "mean_metric": round(float(np.mean(metrics)), 6),
        }
        if radii and np.isfinite(radii).any():
            r_mm = float(np.nanmedian(radii))
            row["coil_radius_mm"] = round(r_mm, 4)
            unit = law_radius_m(ctl["q_outer_ml_min"], 0.0, law, prefactor=1.0) * 1e3
            ratios.append(r_mm / unit)
        table.append(row)
    bar.close()
    env.close()
    best = min(table, key=lambda r: r["mean_metric"])
    if not ratios:
        raise RuntimeError(f"{env_id}: no run measured a coil radius; cannot fit the prefactor")
    prefactor = float(np.exp(np.mean(np.log(ratios))))
    return {
        "accuracy": accuracy,
        "training_targets": n_targets,
        "seeds": [seed, seed + n_targets - 1],
        "constant_action": best["action"],
        "constant_q_outer_ml_min": best["q_outer_ml_min"],
        "constant_q_inner_ml_min": best["q_inner_ml_min"],
        "constant_mean_metric": best["mean_metric"],
        "feedforward_prefactor": round(prefactor, 5),
        "feedforward_prefactor_spread": round(float(np.std(np.log(ratios))), 5),
        "grid": table,
    }

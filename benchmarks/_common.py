"""Helpers shared by the benchmark scripts: timing and result files."""

from __future__ import annotations

import csv
import time
from collections.abc import Callable
from pathlib import Path

RESULTS = Path(__file__).resolve().parent / "results"


def best_of(fn: Callable[[], object], repeats: int = 3) -> float:
    """Smallest wall time (s) of ``repeats`` calls: the least noisy estimate on a shared machine."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def write_csv(name: str, rows: list[dict]) -> Path:
    """Write rows (dicts with the same keys) to benchmarks/results/NAME.csv."""
    RESULTS.mkdir(exist_ok=True)
    path = RESULTS / f"{name}.csv"
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    return path


def sagging_filament(n: int, time_step_s: float = 2e-3):
    """A clamped horizontal filament of n segments (0.5 mm) sagging under its net weight
    (elasticity, drag, gravity; a 1 mm first-mode perturbation), advanced at a fixed step:
    the state of the scaling and profile benchmarks."""
    from bathprint import Simulation

    spacing_mm = 0.5
    return Simulation(
        "paper_simulation",
        {
            "flow.q_outer_ml_min": 0.0,
            "initial.length_mm": n * spacing_mm,
            "numerics.node_spacing_mm": spacing_mm,
            "needle.direction": [1.0, 0.0, 0.0],
            "initial.perturbation_mm": 1.0,
            "numerics.time_step_s": time_step_s,
            "duration_s": 100.0,
        },
    )

"""Runs for the paper's Figs. 1C and 2: one scene per (needle diameter, flow rate).

Each run's resolution follows the physics it has to resolve: the node spacing is a tenth
of the drag buckling scale (B/(mu v))^(1/3) (at least 0.1 mm and 0.2 radii, at most 0.5 mm)
and the duration covers the onset (50 scale lengths of extrusion) and several coiling
periods 2 pi / omega (omega from the paper's scaling law),
or ``max_segments`` of filament, whichever is shorter. The gel sets (gelation from
2.7 kPa to 30 kPa at 0.5 /s, with curvature memory), as in the experiments. Runs go
through :func:`bathprint.studies.sweep.run_sweep`, so they are resumable, run in parallel, and
failed runs are recorded rather than lost.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from bathprint.analysis import theory
from bathprint.studies.sweep import read_results, run_sweep

E_THEORY = 2700.0  # Pa, the paper's theory modulus
MU = 1e-3  # Pa s


def run_overrides(
    diameter_mm: float,
    q_ml_min: float,
    height_mm: float | None = None,
    turns: float = 6.0,
    max_duration_s: float = 4.0,
    max_segments: float = 600.0,
    physics: str = "custom",
) -> dict[str, Any]:
    """Scene overrides for one (d, Q) point of the phase diagram; ``physics`` a preset of
    :data:`bathprint.core.scene.PHYSICS_PRESETS` (or "custom": the effects below only)."""
    d = diameter_mm * 1e-3
    r = d / 2
    v = theory.exit_speed(q_ml_min * 1e-6 / 60, d)
    b = theory.bending_stiffness(E_THEORY, r)
    scale = theory.buckling_length_scale(b, MU, v)
    omega = theory.coil_frequency(b, MU, v)
    spacing = min(max(scale / 10.0, 0.2 * r * 1.0001, 0.1e-3), 0.5e-3)
    period = 2 * math.pi / omega
    startup = 50.0 * scale / v  # extrude well past the onset before counting turns
    # at most ``max_segments`` segments of filament: fast, thin jets are cut short rather
    # than letting one point of a phase diagram cost minutes
    duration = min(startup + turns * period, max_duration_s, max_segments * spacing / v)
    # frames 12 per coiling period (60 per run at most), to the microsecond; the fastest jets
    # of the phase diagram (v ~ 50 m/s) turn faster than that: the scene's smallest interval
    frame_interval = round(min(duration / 60.0, period / 12.0), 6)
    if frame_interval <= 1e-6:
        frame_interval = 2e-6
    over: dict[str, Any] = {
        # the gel sets as in the experiments (coils stay regular instead of unravelling);
        # at the buckling point it is still at E_THEORY, the modulus the scalings use
        "effects": ["elasticity", "drag", "gravity", "gelation"],
        "gelation.initial_modulus_pa": E_THEORY,
        "gelation.final_modulus_pa": 30000.0,
        "gelation.rate_1_s": 0.5,
        "needle.imperfection_um": 20.0,
        "needle.inner_diameter_mm": diameter_mm,
        "flow.q_outer_ml_min": q_ml_min,
        "numerics.node_spacing_mm": round(spacing * 1e3, 6),
        "numerics.tolerance": 3e-3,
        "duration_s": round(duration, 4),
        "outputs.frame_interval_s": frame_interval,
        "outputs.plot": False,
    }
    if height_mm is not None:
        over["effects"] = ["elasticity", "drag", "gravity", "floor", "gelation"]
        over["needle.position_mm"] = [0.0, 0.0, -125.0 + height_mm]
    if physics != "custom":
        over["physics"] = physics
    return over


def run_grid(
    points: list[tuple[float, float]],
    results: Path,
    height_mm: float | None,
    workers: int | None,
    scheduler: str | None = None,
    progress: bool = True,
    turns: float = 6.0,
    max_duration_s: float = 4.0,
    max_segments: float = 600.0,
    physics: str = "custom",
) -> list[dict]:
    """Run (d_mm, Q_ml_min) points on the drag-coiling scene; return one row per point."""
    grid = [
        run_overrides(d, q, height_mm, turns, max_duration_s, max_segments, physics)
        for d, q in points
    ]
    run_sweep(
        "drag_coiling_22G", grid, results, workers=workers, scheduler=scheduler, progress=progress
    )
    rows = {}
    for row in read_results(results):
        rows[
            (row["overrides"]["needle.inner_diameter_mm"], row["overrides"]["flow.q_outer_ml_min"])
        ] = row
    return [rows[p] for p in points if p in rows]

"""A run's time loop, its summary and its trajectory file: the parts of a run the simulator
owns (:func:`advance_frames`, :func:`summarize`, :func:`load_trajectory`).

:func:`bathprint.simulate` (:mod:`bathprint.run`) composes them with the measurements and
the picture into a run's outputs; this module imports nothing above :mod:`bathprint.core`.
"""

from __future__ import annotations

import math
import time
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.core import layout as L
from bathprint.core.extrusion import extruded_length
from bathprint.core.model import ML_MIN, contact_damping_time, effective_numerics
from bathprint.core.simulation import Simulation
from bathprint.provenance import code_version


def write_trajectory(
    path: str | Path, time_s: np.ndarray, frames: list[np.ndarray], material: np.ndarray
) -> Path:
    """Write a run's frames as ``trajectory.npz``: ``positions_m`` (all frames' nodes
    stacked, shape (total, 3)), ``frame_start`` (frame k is rows
    frame_start[k]:frame_start[k+1]), ``time_s``, ``material`` (final per-segment records)
    and ``material_columns``. :func:`load_trajectory` reads it back."""
    path = Path(path)
    counts = [len(f) for f in frames]
    np.savez_compressed(
        path,
        positions_m=np.concatenate(frames) if frames else np.zeros((0, 3)),
        frame_start=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
        time_s=time_s,
        material=material,
        material_columns=np.array(L.MATERIAL_COLUMNS),
    )
    return path


def load_trajectory(path: str | Path) -> tuple[np.ndarray, list[np.ndarray], np.ndarray]:
    """(time_s, frames, material) from a trajectory.npz."""
    with np.load(Path(path)) as z:
        pos = z["positions_m"]
        start = z["frame_start"]
        frames = [pos[start[k] : start[k + 1]] for k in range(len(start) - 1)]
        return z["time_s"], frames, z["material"]


def _gelation_summary(sim: Simulation, v: float) -> dict[str, Any] | None:
    """The paper's scaled gelation rate k d / v, and the modulus range along the filament."""
    if "gelation" not in sim.scene.effects:
        return None
    k = sim.scene.gelation.rate_1_s
    d = sim.scene.needle.inner_diameter_mm * 1e-3
    e = sim.material()[:, L.MAT_YOUNGS_MODULUS]
    return {
        "rate_1_s": k,
        "scaled_rate_kd_over_v": k * d / v if v > 0 else None,
        "modulus_min_pa": float(e.min()),
        "modulus_max_pa": float(e.max()),
    }


def integrated_flow_volume(sim: Simulation, t: float, inner_only: bool = False) -> float:
    """int_0^t (Q_o + Q_i) dt (or Q_i alone) (m^3), trapezoid rule on a fine grid through the
    knots.

    Independent of the simulator's own bookkeeping; exact for piecewise-linear schedules.
    """
    m = sim.model
    flow = m.flow
    t0 = max(0.0, float(flow[0, 0]))
    # history before the table's first knot (trimmed by set_flow) is carried in flow_cum
    before = 0.0
    if flow[0, 0] > 0.0 and len(m.flow_cum):
        before = float(m.flow_cum[0, 1] if inner_only else m.flow_cum[0, 0] * m.needle_area)
    knots = flow[:, 0][(flow[:, 0] > t0) & (flow[:, 0] < t)]
    grid = np.unique(np.concatenate([np.linspace(t0, t, 2001), knots]))
    q = np.interp(grid, flow[:, 0], flow[:, 2] if inner_only else flow[:, 1] + flow[:, 2])
    return before + float(np.sum(0.5 * (q[1:] + q[:-1]) * np.diff(grid)))


def summarize(sim: Simulation, wall_s: float) -> dict[str, Any]:
    """The summary.json of a run (measurements are added by the analysis modules)."""
    c = sim.centerline()
    seg = np.linalg.norm(np.diff(c, axis=0), axis=1)
    printed = sim.printed_volume()
    expected = sim.initial_volume + integrated_flow_volume(sim, sim.t)
    m = sim.model
    v = m.exit_speed(0.0)
    return {
        "scene": sim.scene.name,
        "time_s": sim.t,
        "wall_time_s": wall_s,
        "wall_s_per_simulated_s": wall_s / sim.t if sim.t > 0 else math.nan,
        **sim.counts(),
        "nodes": len(c),
        "frozen_nodes": sim.n_frozen,
        "node_steps_per_s": _node_steps(sim) / wall_s if wall_s > 0 else math.nan,
        "final_length_m": float(seg.sum()),
        "printed_length_m": float(sim.rest_lengths().sum()),
        "mass_balance": {
            "printed_volume_ml": printed * 1e6,
            "expected_volume_ml": expected * 1e6,
            "relative_error": (printed - expected) / expected if expected > 0 else 0.0,
            "inner_volume_ml": sim.inner_volume() * 1e6,
            "expected_inner_volume_ml": integrated_flow_volume(sim, sim.t, inner_only=True) * 1e6,
        },
        "gelation": _gelation_summary(sim, v),
        "effects": list(sim.scene.effects),
        "numerics": {
            "accuracy": sim.scene.numerics.accuracy,
            "integrator": sim.scene.numerics.integrator,
            **effective_numerics(sim.scene),
        },
        "effect_calls": sim.effect_calls(),
        **_contact_law(sim),
        "exit_speed_m_s": v,
        "slender_body_coefficient_pa_s": m.mu_s,
        "bending_stiffness_n_m2": m.bending_stiffness,
        "extruded_length_m": float(extruded_length(m.flow, m.flow_cum, m.needle_area, sim.t)),
        "q_outer_ml_min_at_end": float(np.interp(sim.t, m.flow[:, 0], m.flow[:, 1]) / ML_MIN),
        "measurements": {},
        "code": code_version(),
    }


def _contact_law(sim: Simulation) -> dict[str, Any]:
    """Where ``contact`` is listed, the law the run used, its ``"auto"`` resolved: a summary
    then says which law computed it whatever the defaults were."""
    if "contact" not in sim.scene.effects:
        return {}
    c = sim.scene.contact
    law = {
        "stiffness_pa": c.stiffness_pa,
        "distance_factor": c.distance_factor,
        "width_fraction": c.width_fraction,
        "damping_time_s": contact_damping_time(sim.scene),
        "friction_coefficient": c.friction_coefficient,
    }
    return {"contact": law}


def _node_steps(sim: Simulation) -> float:
    # accumulated during the run by advance_frames(); fall back to steps x current nodes
    return float(getattr(sim, "_node_steps", sim.counts()["steps"] * sim.n_nodes))


def advance_frames(
    sim: Simulation, progress: bool | None = None
) -> tuple[np.ndarray, list[np.ndarray], float]:
    """Advance ``sim`` to its scene's duration, saving the centreline every
    ``outputs.frame_interval_s``: returns (frame times (s), frames (m), wall seconds of the
    loop). Records the node-steps the loop took for :func:`summarize`. A progress bar is
    shown when ``progress`` is true (None: when stderr is a TTY)."""
    sc = sim.scene
    n_frames = max(1, int(math.ceil(sc.duration_s / sc.outputs.frame_interval_s - 1e-9)))
    times = np.minimum(np.arange(1, n_frames + 1) * sc.outputs.frame_interval_s, sc.duration_s)
    frames = [sim.centerline()]
    t_out = [0.0]
    bar = _progress(progress, sc.duration_s)
    wall0 = time.perf_counter()
    node_steps = 0.0
    try:
        for t in times:
            s0 = sim.counts()["steps"]
            sim.advance(float(t))
            node_steps += (sim.counts()["steps"] - s0) * (sim.n_nodes - sim.n_frozen)
            frames.append(sim.centerline())
            t_out.append(float(t))
            if bar is not None:
                bar.update(float(t) - bar.n)
    finally:
        if bar is not None:
            bar.close()
    wall = time.perf_counter() - wall0
    sim._node_steps = node_steps
    return np.array(t_out), frames, wall


def _progress(progress: bool | None, total: float):
    import sys

    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        return None
    from tqdm import tqdm

    return tqdm(
        total=total,
        unit="sim s",
        bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s [{elapsed}<{remaining}]",
    )

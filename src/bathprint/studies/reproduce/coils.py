"""Steady coiling over many turns: with gelation and curvature memory, and without.

The paper's own simulation made regular coils at first, then they unravelled at the
free end; the authors suspected missing nonlocal hydrodynamics and the build-up of
stiffness and natural curvature as the gel sets. Here the drag-coiling scene is run long
enough for 10-19 turns (8 s) with and without the gelation effect, and the radius and pitch of
every turn (:func:`bathprint.analysis.measure.coil_geometry`) are plotted from the needle down.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from bathprint.analysis.measure import coil_geometry
from bathprint.core.simulation import Simulation
from bathprint.viz.plotting import plt

CASES = {
    "elastic (no gelation)": ("drag_coiling_22G", {}),
    "gelation + curvature memory": ("gelation_coiling_22G", {}),
}


def run(out_dir: str | Path, quick: bool = False) -> dict:
    """Write coils.png and coils.csv; return turns counted and the spread of their radii."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    duration = 3.0 if quick else 8.0
    rows, summary = [], {}
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), gridspec_kw={"width_ratios": [1.2, 1.2, 1.0]})
    for label, (scene, over) in CASES.items():
        sim = Simulation(scene, {**over, "duration_s": duration})
        sim.advance(duration)
        c = sim.centerline()
        needle = sim.model.needle[0]
        geo = coil_geometry(c, needle[1:4], needle[4:7])
        radii = np.array(geo.radii if geo else [])
        pitches = np.array(geo.pitches if geo else [])
        for k, (r, p) in enumerate(zip(radii, pitches, strict=False)):
            rows.append({"case": label, "turn_from_needle": k + 1, "radius_m": r, "pitch_m": p})
        core = np.array(geo.core_radii) if geo else np.array([])
        summary[label] = {
            "turns": len(radii),
            "core_turns": len(core),
            "median_radius_m": float(np.median(core)) if len(core) else None,
            "radius_spread": float((core.max() - core.min()) / np.median(core))
            if len(core)
            else None,
        }
        axes[0].plot(np.arange(1, len(radii) + 1), radii * 1e3, "o-", ms=3, label=label)
        axes[1].plot(np.arange(1, len(pitches) + 1), np.abs(pitches) * 1e3, "o-", ms=3, label=label)
        axes[2].plot(c[:, 0] * 1e3, c[:, 2] * 1e3, lw=0.8, label=label)
    axes[0].set_xlabel("turn (counted from the needle)")
    axes[0].set_ylabel("coil radius (mm)")
    axes[0].set_title(f"radius of every turn after {duration:g} s")
    axes[0].legend(fontsize=8)
    axes[1].set_xlabel("turn (counted from the needle)")
    axes[1].set_ylabel("pitch (mm)")
    axes[1].set_title("pitch of every turn")
    axes[2].set_xlabel("x (mm)")
    axes[2].set_ylabel("z (mm)")
    axes[2].set_aspect("equal")
    axes[2].set_title("side view")
    fig.tight_layout()
    fig.savefig(out / "coils.png", dpi=110)
    plt.close(fig)
    with (out / "coils.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["case", "turn_from_needle", "radius_m", "pitch_m"])
        w.writeheader()
        w.writerows(rows)
    return summary

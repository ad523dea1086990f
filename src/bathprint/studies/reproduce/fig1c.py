"""Fig. 1C of the paper: the regime phase diagram over flow rate and needle diameter.

Each point is a simulated run of the experiment model (``physics = "experiment"``: with
self-contact between turns; the floor 30 mm below the needle, so rope coiling can occur)
over the paper's range of flow rates (0.1-20 ml/min) and needle diameters (0.09-1.9 mm),
classified by :func:`bathprint.analysis.measure.classify_regime`; the paper's four example
points of Fig. 1B are marked with the regime the paper reports there.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from bathprint.studies.reproduce.runs import run_grid
from bathprint.viz.plotting import plt

PAPER_POINTS = [  # (d mm, Q_o ml/min, regime in the paper's Fig. 1B)
    (0.84, 0.5, "rope_coiling"),
    (0.41, 0.5, "drag_coiling"),
    (0.41, 5.0, "period_doubling"),
    (0.41, 20.0, "chaotic_crumpling"),
]
COLORS = {
    "straight": "tab:gray",
    "rope_coiling": "gold",
    "drag_coiling": "tab:red",
    "period_doubling": "tab:green",
    "chaotic_crumpling": "tab:purple",
    None: "black",
}
HEIGHT_MM = 30.0
PHYSICS = "experiment"  # the preset the map is drawn with


def run(
    out_dir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
) -> dict:
    """Write fig1c.png and fig1c.csv; return agreement with the paper's four points."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    if quick:
        points = [(0.84, 0.5), (0.41, 0.5)]
    else:
        diameters = [0.09, 0.21, 0.41, 0.84, 1.9]
        flows = [0.1, 0.5, 2.0, 5.0, 20.0]
        points = sorted(
            {(d, q) for d in diameters for q in flows} | {(d, q) for d, q, _ in PAPER_POINTS}
        )
    rows = run_grid(
        points,
        out / "fig1c_runs.jsonl",
        HEIGHT_MM,
        workers,
        scheduler,
        turns=4.0 if quick else 6.0,
        max_duration_s=1.5 if quick else 6.0,
        max_segments=600.0 if quick else 1500.0,
        physics=PHYSICS,
    )
    table = []
    for row in rows:
        o = row["overrides"]
        res = row.get("result") or {}
        table.append(
            {
                "diameter_mm": o["needle.inner_diameter_mm"],
                "q_outer_ml_min": o["flow.q_outer_ml_min"],
                "status": row["status"],
                "regime": res.get("measurements.regime"),
                "error": (row.get("error") or {}).get("message"),
            }
        )
    with (out / "fig1c.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    fig, ax = plt.subplots(figsize=(8.5, 5))
    for r in table:
        ax.scatter(
            r["q_outer_ml_min"],
            r["diameter_mm"],
            s=90,
            color=COLORS.get(r["regime"]),
            edgecolor="k",
            zorder=3,
        )
    for d, q, regime in PAPER_POINTS:
        ax.scatter(q, d, s=320, facecolor="none", edgecolor=COLORS[regime], lw=2.5, zorder=2)
    for name, color in COLORS.items():
        label = name.replace("_", " ") if name else "failed (error in fig1c.csv)"
        ax.scatter([], [], color=color, edgecolor="k", label=label)
    ax.scatter([], [], facecolor="none", edgecolor="k", s=200, lw=2, label="paper's Fig. 1B point")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlim(0.1, 30)
    ax.set_ylim(0.08, 2.2)
    ax.set_xlabel("Q_o (ml/min)")
    ax.set_ylabel("needle inner diameter d (mm)")
    ax.set_title(f"Fig. 1C, {PHYSICS} model: simulated (filled), paper's examples (rings)")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(out / "fig1c.png", dpi=110)
    plt.close(fig)
    lookup = {(r["diameter_mm"], r["q_outer_ml_min"]): r["regime"] for r in table}
    agreement = {
        f"d={d} mm, Q={q} ml/min": {"paper": reg, "simulated": lookup.get((d, q))}
        for d, q, reg in PAPER_POINTS
        if (d, q) in lookup
    }
    return {
        "points": len(table),
        "paper_points": agreement,
        "regimes": {k: int(np.sum([r["regime"] == k for r in table])) for k in COLORS if k},
    }

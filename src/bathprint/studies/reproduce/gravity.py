"""The universal scaling with gravity (the paper's SI Fig. S4): does the simulated buckling
length collapse onto l ~ (B / (mu v + drho g r^2))^(1/3)?

The density difference drho between the filament and the bath is swept from neutral (0) to
heavy (100 kg/m^3) at needle diameters and flow rates of the paper's range, with the floor
30 mm below the needle as in Fig. 1C (heavy filaments fall and coil on it: gravity-induced
coiling; neutral ones coil by drag). The buckled length is measured as the paper does for
drag coiling, the depth below the needle where the filament leaves the axis
(:func:`bathprint.analysis.measure.buckling_length`), and for rope coiling as the height of
that point above the floor (the straight part above it hangs in tension: what buckles is
the part near the floor). It is fitted through the origin against the universal scale
L_u = (B / (mu v + drho g r^2))^(1/3) and against the drag scale L_d = (B / (mu v))^(1/3);
the scatter of each fit (RMS of log(l / fit)) says which collapses the runs. The coil
radius R is treated the same way. Runs as for Fig. 1C (:func:`bathprint.studies.reproduce.
runs.run_overrides`, a longer budget), through the resumable sweep. Outputs: gravity.csv,
gravity.png, gravity_runs.jsonl.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from bathprint.analysis import theory
from bathprint.studies.reproduce.fig1c import HEIGHT_MM
from bathprint.studies.reproduce.runs import E_THEORY, MU, run_overrides
from bathprint.studies.sweep import run_id, run_sweep

SCENE = "drag_coiling_22G"
BATH_DENSITY = 1051.0  # kg/m^3, 150 mM CaCl2 (the scene's bath)
FULL = {
    "points": [(0.41, 0.5), (0.6, 1.0), (0.84, 0.5), (0.84, 2.0)],
    "drho": [0.0, 1.0, 3.0, 10.0, 30.0, 100.0],
    "budget": (10.0, 12.0, 3000.0),  # turns, max_duration_s, max_segments
}
QUICK = {"points": [(0.41, 0.5)], "drho": [0.0, 30.0], "budget": (1.0, 0.4, 100.0)}


def overrides(diameter_mm: float, q_ml_min: float, drho: float, budget: tuple) -> dict:
    """The run of one (d, Q, drho): Fig. 1C's, with the filament drho denser than the bath."""
    over = run_overrides(diameter_mm, q_ml_min, HEIGHT_MM, *budget)
    over["bath.density_kg_m3"] = BATH_DENSITY
    over["material.density_kg_m3"] = BATH_DENSITY + drho
    return over


def scales(diameter_mm: float, q_ml_min: float, drho: float) -> tuple[float, float]:
    """(L_u, L_d) in m: the universal and the drag-only buckling scales (B of the theory
    modulus, r = d/2, mu of the bath)."""
    d = diameter_mm * 1e-3
    v = theory.exit_speed(q_ml_min * 1e-6 / 60, d)
    b = theory.bending_stiffness(E_THEORY, d / 2)
    return (
        theory.gravity_drag_length(b, MU, v, drho, d / 2),
        theory.buckling_length_scale(b, MU, v),
    )


def buckled_length(depth: float | None, regime: str | None) -> float | None:
    """The buckled length (m) from the depth of the departure below the needle: the depth
    itself, or with rope coiling the height of the departure above the floor."""
    if depth is None:
        return None
    return HEIGHT_MM * 1e-3 - depth if regime == "rope_coiling" else depth


QUANTITIES = {  # fitted quantity: its label
    "buckled_length_m": "buckled length l (mm)",
    "coil_radius_m": "coil radius R (mm)",
}


def _fit(x: np.ndarray, y: np.ndarray) -> dict:
    """Slope through the origin and the RMS of log(y / (slope x)) (0: a perfect collapse)."""
    if len(x) == 0:
        return {"slope": math.nan, "log_rms": math.nan, "points": 0}
    slope = float(np.sum(x * y) / np.sum(x * x))
    return {
        "slope": slope,
        "log_rms": float(np.sqrt(np.mean(np.log(y / (slope * x)) ** 2))),
        "points": len(x),
    }


def run(
    out_dir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict:
    """Write gravity.csv and gravity.png (and gravity_runs.jsonl); return the fits."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cfg = QUICK if quick else FULL
    cases = [(d, q, drho) for d, q in cfg["points"] for drho in cfg["drho"]]
    grid = [overrides(d, q, drho, cfg["budget"]) for d, q, drho in cases]
    rows = run_sweep(
        SCENE,
        grid,
        out / "gravity_runs.jsonl",
        workers=workers,
        scheduler=scheduler,
        progress=progress,
    )
    by_id = {r["run_id"]: r for r in rows}
    table = []
    for (d, q, drho), over in zip(cases, grid, strict=True):
        row = by_id[run_id(SCENE, over)]
        res = row.get("result") or {}
        regime = res.get("measurements.regime")
        depth = res.get("measurements.buckling_length_m")
        l_u, l_d = scales(d, q, drho)
        table.append(
            {
                "diameter_mm": d,
                "q_outer_ml_min": q,
                "drho_kg_m3": drho,
                "status": row["status"],
                "regime": regime,
                "buckling_depth_m": depth,
                "buckled_length_m": buckled_length(depth, regime),
                "coil_radius_m": res.get("measurements.coil_radius_m"),
                "universal_scale_m": l_u,
                "drag_scale_m": l_d,
                "gravity_over_drag": drho
                * theory.GRAVITY
                * (d * 5e-4) ** 2
                / (MU * theory.exit_speed(q * 1e-6 / 60, d * 1e-3)),
                "error": (row.get("error") or {}).get("message"),
            }
        )
    with (out / "gravity.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    fits = {}
    for quantity in QUANTITIES:
        ok = [
            r for r in table if r[quantity] is not None and r[quantity] > 0 and r["status"] == "ok"
        ]
        y = np.array([r[quantity] for r in ok], dtype=float)
        fits[quantity] = {
            scale: _fit(np.array([r[scale] for r in ok], dtype=float), y)
            for scale in ("universal_scale_m", "drag_scale_m")
        }
    _plot(out / "gravity.png", table, fits)
    return {"runs": len(table), "fits": fits}


def _plot(path: Path, table: list[dict], fits: dict) -> None:
    from bathprint.viz.plotting import plt

    fig, axes = plt.subplots(2, 2, figsize=(12, 9))
    points = sorted({(r["diameter_mm"], r["q_outer_ml_min"]) for r in table})
    markers = dict(zip(points, "osd^v<>", strict=False))
    universal = "(B/(mu v + drho g r^2))^(1/3)"
    panels = [
        (axes[0, 0], "buckled_length_m", "universal_scale_m", universal),
        (axes[0, 1], "buckled_length_m", "drag_scale_m", "(B/(mu v))^(1/3) (no gravity)"),
        (axes[1, 0], "coil_radius_m", "universal_scale_m", universal),
        (axes[1, 1], "coil_radius_m", "drag_scale_m", "(B/(mu v))^(1/3) (no gravity)"),
    ]
    cmap = plt.get_cmap("viridis")
    drhos = sorted({r["drho_kg_m3"] for r in table})
    for ax, quantity, scale, xlabel in panels:
        top = 0.0
        for r in table:
            if r[quantity] is None or r["status"] != "ok":
                continue
            c = cmap(drhos.index(r["drho_kg_m3"]) / max(len(drhos) - 1, 1))
            mk = markers[(r["diameter_mm"], r["q_outer_ml_min"])]
            x, y = r[scale] * 1e3, r[quantity] * 1e3
            ax.scatter(x, y, color=c, marker=mk, edgecolor="k")
            tag = "rope" if r["regime"] == "rope_coiling" else ""
            ax.annotate(tag, (x, y), fontsize=6, xytext=(3, 3), textcoords="offset points")
            top = max(top, x)
        f = fits[quantity][scale]
        if f["points"]:
            xx = np.linspace(0, 1.1 * top, 10)
            label = f"slope {f['slope']:.2f}, log-RMS scatter {f['log_rms']:.2f}"
            ax.plot(xx, f["slope"] * xx, "k-", lw=0.8, label=label)
            ax.legend(fontsize=8, loc="upper left")
        ax.set_xlabel(xlabel + " (mm)")
        ax.set_ylabel(QUANTITIES[quantity])
    for (d, q), mk in markers.items():
        axes[1, 1].scatter([], [], marker=mk, color="w", edgecolor="k", label=f"d={d} mm, Q={q}")
    for k, drho in enumerate(drhos):
        color = cmap(k / max(len(drhos) - 1, 1))
        axes[1, 1].scatter([], [], color=color, label=f"drho={drho:g} kg/m^3")
    axes[1, 1].legend(fontsize=6, loc="lower right")
    axes[0, 0].set_title("SI Fig. S4: l against the universal scale ('rope': rope coiling)")
    axes[0, 1].set_title("l against the drag scale alone")
    axes[1, 0].set_title("R against the universal scale")
    axes[1, 1].set_title("R against the drag scale alone")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

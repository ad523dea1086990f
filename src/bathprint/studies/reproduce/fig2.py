"""Fig. 2 of the paper: buckling length, coil radius and coiling frequency laws.

Simulated drag-coiling runs over needle diameters and flow rates; for each, the buckling
length l, coil radius R and frequency omega are measured as the paper's Fig. 2 insets
define them (:mod:`bathprint.analysis.measure`), and the three fits of the paper are redone:
l = a R (paper: 2.6), R = b (B/(mu v))^(1/3) (0.4), omega = c v^(4/3) (mu/B)^(1/3) (1.1),
each a least-squares slope through the origin.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from bathprint.analysis import theory
from bathprint.studies.reproduce.runs import E_THEORY, MU, run_grid
from bathprint.viz.plotting import plt

PAPER = {"l_over_R": 2.6, "R_prefactor": 0.4, "omega_prefactor": 1.1}


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.sum(x * y) / np.sum(x * x)) if len(x) else float("nan")


def law_row(overrides: dict, result: dict | None) -> dict:
    """One run's Fig. 2 quantities and the paper's scales (B from the theory modulus)."""
    res = result or {}
    d = overrides["needle.inner_diameter_mm"] * 1e-3
    v = theory.exit_speed(overrides["flow.q_outer_ml_min"] * 1e-6 / 60, d)
    b = theory.bending_stiffness(E_THEORY, d / 2)
    return {
        "diameter_mm": overrides["needle.inner_diameter_mm"],
        "q_outer_ml_min": overrides["flow.q_outer_ml_min"],
        "regime": res.get("measurements.regime"),
        "buckling_length_m": res.get("measurements.buckling_length_m"),
        "coil_radius_m": res.get("measurements.coil_radius_m"),
        "coil_frequency_rad_s": res.get("measurements.coil_frequency_rad_s"),
        "scale_B_mu_v_m": theory.buckling_length_scale(b, MU, v),
        "scale_omega_rad_s": v ** (4 / 3) * (MU / b) ** (1 / 3),
    }


def law_columns(table: list[dict], *keys: str) -> list[np.ndarray]:
    """The columns ``keys`` of the rows where all of them are measured."""
    ok = [r for r in table if all(r.get(k) is not None for k in keys)]
    return [np.array([r[k] for r in ok], dtype=float) for k in keys]


def fit_laws(table: list[dict]) -> dict:
    """The paper's three fits redone on rows of :func:`law_row`: slopes through the origin of
    l against R, R against (B/(mu v))^(1/3) and omega against v^(4/3) (mu/B)^(1/3), and the
    number of points in each (NaN slopes without points)."""
    l_, r_ = law_columns(table, "buckling_length_m", "coil_radius_m")
    r2, s2 = law_columns(table, "coil_radius_m", "scale_B_mu_v_m")
    w3, s3 = law_columns(table, "coil_frequency_rad_s", "scale_omega_rad_s")
    return {
        "l_over_R": _slope(r_, l_),
        "R_prefactor": _slope(s2, r2),
        "omega_prefactor": _slope(s3, w3),
        "points": {"l_R": len(l_), "R": len(r2), "omega": len(w3)},
    }


def run(
    out_dir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
) -> dict:
    """Write fig2.png and fig2.csv (and the runs' fig2_runs.jsonl); return the slopes."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    diameters = [0.41, 0.6] if quick else [0.26, 0.41, 0.6, 0.84]
    flows = [0.5, 1.0] if quick else [0.3, 0.5, 1.0, 2.0]
    points = [(d, q) for d in diameters for q in flows]
    rows = run_grid(
        points,
        out / "fig2_runs.jsonl",
        None,
        workers,
        scheduler,
        turns=4.0 if quick else 6.0,
        max_duration_s=2.0 if quick else 6.0,
        max_segments=600.0 if quick else 4000.0,
    )
    table = []
    for row in rows:
        law = law_row(row["overrides"], row.get("result"))
        table.append({**{k: law[k] for k in list(law)[:2]}, "status": row["status"], **law})
    with (out / "fig2.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)

    l_, r_ = law_columns(table, "buckling_length_m", "coil_radius_m")
    r2, s2 = law_columns(table, "coil_radius_m", "scale_B_mu_v_m")
    w3, s3 = law_columns(table, "coil_frequency_rad_s", "scale_omega_rad_s")
    slopes = fit_laws(table)
    fig, axes = plt.subplots(1, 3, figsize=(13, 4))
    for ax, (x, y, key, xl, yl, scale) in zip(
        axes,
        [
            (r_, l_, "l_over_R", "R (mm)", "l (mm)", 1e3),
            (s2, r2, "R_prefactor", "(B/(mu v))^(1/3) (mm)", "R (mm)", 1e3),
            (s3, w3, "omega_prefactor", "v^(4/3) (mu/B)^(1/3) (rad/s)", "omega (rad/s)", 1.0),
        ],
        strict=True,
    ):
        ax.plot(x * scale, y * scale, "o", label="simulated")
        if len(x):
            xx = np.linspace(0, x.max() * scale * 1.1, 10)
            ax.plot(xx, slopes[key] * xx, "-", label=f"fit: slope {slopes[key]:.2f}")
            ax.plot(xx, PAPER[key] * xx, "--", color="gray", label=f"paper: {PAPER[key]}")
        ax.set_xlabel(xl)
        ax.set_ylabel(yl)
        ax.legend(fontsize=8)
    axes[0].set_title("Fig. 2A: l against R")
    axes[1].set_title("Fig. 2B: R against (B/(mu v))^(1/3)")
    axes[2].set_title("Fig. 2C: omega against v^(4/3)(mu/B)^(1/3)")
    fig.tight_layout()
    fig.savefig(out / "fig2.png", dpi=110)
    plt.close(fig)
    return slopes

"""Fig. 2 of the paper: buckling length, coil radius and coiling frequency laws.

Simulated drag-coiling runs over needle diameters and flow rates; for each, the buckling
length l, coil radius R and frequency omega are measured as the paper's Fig. 2 insets
define them (:mod:`bathprint.analysis.measure`), and the three fits of the paper are redone:
l = a R (paper: 2.6), R = b (B/(mu v))^(1/3) (0.4), omega = c v^(4/3) (mu/B)^(1/3) (1.1),
each a least-squares slope through the origin.

Two of the paper's conventions are open, so the fits are given under each:

- l: the inset's definition (:func:`bathprint.analysis.measure.buckling_length`) and the
  three alternatives of :func:`bathprint.analysis.measure.buckling_length_definitions`
  (departure by 2r, by a quarter of the largest excursion, where the coil reaches 0.9 R);
- B: bathprint's B = E pi r^4 / 4 (a solid rod's), and the paper's own B = E r^4: its text
  takes "B ~ E r^4 (E = 2.7 kPa, r ~ 0.1-2 mm)" for the experimental fits, and its worked
  example, a line its LaTeX source keeps as a comment (l ~ 22 mm at E = 2.7 kPa,
  r = 0.5 mm, mu = 1 mPa s, v = 15 mm/s), holds with B = E r^4 (22.4 mm; 20.7 mm with
  E pi r^4 / 4). With the paper's B, b is (pi/4)^(1/3) = 0.92 of bathprint's and c is
  (4/pi)^(1/3) = 1.08 times it; l / R does not depend on B.
"""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np

from bathprint.analysis import theory
from bathprint.studies.reproduce.runs import E_THEORY, MU, run_grid
from bathprint.viz.plotting import plt

PAPER = {"l_over_R": 2.6, "R_prefactor": 0.4, "omega_prefactor": 1.1}

# l under each definition: (name in the fits, measurement key, label)
L_DEFINITIONS = (
    ("inset", "buckling_length_m", "inset: max(r, quarter)"),
    ("two_radii", "buckling_length_2r_m", "departure by 2r"),
    ("quarter", "buckling_length_quarter_m", "quarter of the excursion"),
    ("full_radius", "buckling_length_full_radius_m", "coil at 0.9 R"),
)


def paper_bending_stiffness(E: float, r: float) -> float:
    """The paper's bending stiffness B = E r^4 in N m^2 (E in Pa, r in m), as its experimental
    fits take it (module docstring); bathprint's own is :func:`theory.bending_stiffness`."""
    return E * r**4


def _slope(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.sum(x * y) / np.sum(x * x)) if len(x) else float("nan")


def law_row(overrides: dict, result: dict | None) -> dict:
    """One run's Fig. 2 quantities and the paper's scales (B from the theory modulus)."""
    res = result or {}
    d = overrides["needle.inner_diameter_mm"] * 1e-3
    v = theory.exit_speed(overrides["flow.q_outer_ml_min"] * 1e-6 / 60, d)
    b = theory.bending_stiffness(E_THEORY, d / 2)
    b_paper = paper_bending_stiffness(E_THEORY, d / 2)
    return {
        "diameter_mm": overrides["needle.inner_diameter_mm"],
        "q_outer_ml_min": overrides["flow.q_outer_ml_min"],
        "regime": res.get("measurements.regime"),
        **{key: res.get(f"measurements.{key}") for _, key, _ in L_DEFINITIONS},
        "coil_radius_m": res.get("measurements.coil_radius_m"),
        "coil_frequency_rad_s": res.get("measurements.coil_frequency_rad_s"),
        "coil_frequency_hz": res.get("measurements.coil_frequency_hz"),
        "omega_r_over_v": res.get("measurements.omega_r_over_v"),
        "scale_B_mu_v_m": theory.buckling_length_scale(b, MU, v),
        "scale_omega_rad_s": v ** (4 / 3) * (MU / b) ** (1 / 3),
        "scale_B_mu_v_paper_B_m": theory.buckling_length_scale(b_paper, MU, v),
        "scale_omega_paper_B_rad_s": v ** (4 / 3) * (MU / b_paper) ** (1 / 3),
    }


def law_columns(table: list[dict], *keys: str) -> list[np.ndarray]:
    """The columns ``keys`` of the rows where all of them are measured."""
    ok = [r for r in table if all(r.get(k) is not None for k in keys)]
    return [np.array([r[k] for r in ok], dtype=float) for k in keys]


def fit_laws(table: list[dict]) -> dict:
    """The paper's three fits redone on rows of :func:`law_row`: slopes through the origin of
    l against R, R against (B/(mu v))^(1/3) and omega against v^(4/3) (mu/B)^(1/3), and the
    number of points in each (NaN slopes without points). Also l / R under each of
    :data:`L_DEFINITIONS` (``l_over_R_by_definition``, with its points), b and c with the
    paper's B = E r^4 (``*_paper_B``), and the median of omega R / v over the rows."""
    l_, r_ = law_columns(table, "buckling_length_m", "coil_radius_m")
    r2, s2 = law_columns(table, "coil_radius_m", "scale_B_mu_v_m")
    w3, s3 = law_columns(table, "coil_frequency_rad_s", "scale_omega_rad_s")
    r4, s4 = law_columns(table, "coil_radius_m", "scale_B_mu_v_paper_B_m")
    w5, s5 = law_columns(table, "coil_frequency_rad_s", "scale_omega_paper_B_rad_s")
    by_definition, definition_points = {}, {}
    for name, key, _ in L_DEFINITIONS:
        ld, rd = law_columns(table, key, "coil_radius_m")
        by_definition[name] = _slope(rd, ld)
        definition_points[name] = len(ld)
    (kin,) = law_columns(table, "omega_r_over_v")
    return {
        "l_over_R": _slope(r_, l_),
        "R_prefactor": _slope(s2, r2),
        "omega_prefactor": _slope(s3, w3),
        "points": {"l_R": len(l_), "R": len(r2), "omega": len(w3)},
        "l_over_R_by_definition": by_definition,
        "l_over_R_points": definition_points,
        "R_prefactor_paper_B": _slope(s4, r4),
        "omega_prefactor_paper_B": _slope(s5, w5),
        "omega_R_over_v_median": float(np.median(kin)) if len(kin) else float("nan"),
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

    slopes = fit_laws(table)
    plot(out / "fig2.png", table, slopes)
    return slopes


def plot(path: Path, table: list[dict], slopes: dict) -> None:
    """fig2.png: the three panels of the paper's Fig. 2 from the rows of :func:`law_row`, with
    l under each definition in 2A, and the paper's fits drawn on bathprint's B = E pi r^4 / 4
    both as printed and converted from its B = E r^4 (module docstring)."""
    to_paper_b = (4.0 / math.pi) ** (1.0 / 3.0)  # (B_paper / B)^(1/3)
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.3))
    ax = axes[0]
    r_max = 0.0
    for (name, key, label), marker in zip(L_DEFINITIONS, "osd^", strict=True):
        y, x = law_columns(table, key, "coil_radius_m")
        if not len(x):
            continue
        r_max = max(r_max, float(x.max()))
        a = slopes["l_over_R_by_definition"][name]
        (line,) = ax.plot(x * 1e3, y * 1e3, marker, label=f"{label}: l / R = {a:.2f}")
        xx = np.linspace(0, x.max() * 1.1e3, 10)
        ax.plot(xx, a * xx, "-", color=line.get_color(), lw=0.8)
    if r_max > 0:
        xx = np.linspace(0, r_max * 1.1e3, 10)
        ax.plot(xx, PAPER["l_over_R"] * xx, "--", color="gray", label="paper: 2.6")
    ax.set_xlabel("R (mm)")
    ax.set_ylabel("l (mm)")
    ax.set_title("Fig. 2A: l against R, per definition of l")
    for ax, (xkey, ykey, fit, paper, unit, xl, yl, title) in zip(
        axes[1:],
        [
            (
                "scale_B_mu_v_m",
                "coil_radius_m",
                "R_prefactor",
                PAPER["R_prefactor"] * to_paper_b,
                1e3,
                "(B/(mu v))^(1/3) (mm)",
                "R (mm)",
                "Fig. 2B: R against (B/(mu v))^(1/3)",
            ),
            (
                "scale_omega_rad_s",
                "coil_frequency_rad_s",
                "omega_prefactor",
                PAPER["omega_prefactor"] / to_paper_b,
                1.0,
                "v^(4/3) (mu/B)^(1/3) (rad/s)",
                "omega (rad/s)",
                "Fig. 2C: omega against v^(4/3)(mu/B)^(1/3)",
            ),
        ],
        strict=True,
    ):
        y, x = law_columns(table, ykey, xkey)
        ax.plot(x * unit, y * unit, "o", label="simulated")
        if len(x):
            xx = np.linspace(0, x.max() * unit * 1.1, 10)
            ax.plot(
                xx,
                slopes[fit] * xx,
                "-",
                label=f"fit: slope {slopes[fit]:.2f} "
                f"({slopes[fit + '_paper_B']:.2f} with B = E r^4)",
            )
            ax.plot(xx, PAPER[fit] * xx, "--", color="gray", label=f"paper: {PAPER[fit]}")
            ax.plot(
                xx, paper * xx, ":", color="gray", label=f"paper's {PAPER[fit]} with its B = E r^4"
            )
        ax.set_xlabel(xl + ", B = E pi r^4 / 4")
        ax.set_ylabel(yl)
        ax.set_title(title)
    for ax in axes:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

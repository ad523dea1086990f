"""Fig. 3 of the paper from simulated composite segments.

- 3D: E_c / E_alg against (Q_o - Q_i)/(Q_o + Q_i), read off a simulated stretching test;
- 3F: rho_c / rho_alg against the same flow ratio, from simulated segments;
- 3E: settling heights of four composite filaments (the paper's 1006, 1018, 1021 and
  1045 kg/m^3) released in the density-gradient column (1010 kg/m^3 at the top, 1050 at
  the bottom), against the height where the column is as dense as each filament.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from bathprint.analysis import lab
from bathprint.viz.plotting import plt

PAPER_DENSITIES = (1006.0, 1018.0, 1021.0, 1045.0)  # kg/m^3, Fig. 3E, filaments 1-4
PAPER_ALGINATE_DENSITY = 1054.0
COLUMN = (1010.0, 1050.0)  # top, bottom (kg/m^3)
COLUMN_DEPTH_MM = 125.0


def _write_csv(path: Path, rows: list[dict]) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def composite_curves(out: Path, quick: bool = False) -> list[dict]:
    """Fig. 3D and 3F: PNG and CSV in ``out``."""
    ratios = np.linspace(1.0, -0.6, 5 if quick else 17)
    rows = lab.composite_curve(ratios)
    _write_csv(out / "fig3df_composites.csv", rows)
    x = [r["flow_ratio"] for r in rows]
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot(x, [r["E_c_over_E_alg"] for r in rows], "o-", label="simulated stretching test")
    a.set_xlabel("(Q_o - Q_i) / (Q_o + Q_i)")
    a.set_ylabel("E_c / E_alg")
    a.set_title("Fig. 3D: stiffness (silicone oil inclusions)")
    a.invert_xaxis()
    a.legend()
    b.plot(x, [r["rho_c_over_rho_alg"] for r in rows], "o-", label="simulated segments")
    for k, rho in enumerate(PAPER_DENSITIES, start=1):
        b.axhline(rho / PAPER_ALGINATE_DENSITY, color="gray", lw=0.8, ls=":")
        b.text(
            x[-1],
            rho / PAPER_ALGINATE_DENSITY,
            f" paper {k}: {rho:.0f}",
            va="bottom",
            fontsize=8,
            color="gray",
        )
    b.set_xlabel("(Q_o - Q_i) / (Q_o + Q_i)")
    b.set_ylabel("rho_c / rho_alg")
    b.set_title("Fig. 3F: density")
    b.invert_xaxis()
    b.legend()
    fig.tight_layout()
    fig.savefig(out / "fig3df_composites.png", dpi=110)
    plt.close(fig)
    return rows


def settling(out: Path, quick: bool = False) -> list[dict]:
    """Fig. 3E: settled heights in the gradient column, PNG and CSV in ``out``."""
    rows = []
    for k, rho in enumerate(PAPER_DENSITIES, start=1):
        z, expected, spacing = lab.settling_height(
            rho, column=COLUMN, depth_mm=COLUMN_DEPTH_MM, duration_s=12.0 if quick else 20.0
        )
        rows.append(
            {
                "filament": k,
                "density_kg_m3": rho,
                "settled_height_m": z,
                "expected_height_m": expected,
                "difference_m": z - expected,
                "node_spacing_m": spacing,
            }
        )
    _write_csv(out / "fig3e_settling.csv", rows)
    fig, ax = plt.subplots(figsize=(4.5, 6))
    depth = COLUMN_DEPTH_MM
    zz = np.linspace(-depth, 0, 50)
    rho_col = COLUMN[0] + (COLUMN[1] - COLUMN[0]) * (-zz) / depth
    ax2 = ax.twiny()
    ax2.plot(rho_col, zz, color="tab:blue", alpha=0.4)
    ax2.set_xlabel("column density (kg/m^3)", color="tab:blue")
    for r in rows:
        ax.plot(
            [r["filament"] - 0.3, r["filament"] + 0.3],
            [1e3 * r["settled_height_m"]] * 2,
            lw=4,
            color="tab:red",
        )
        ax.plot(r["filament"], 1e3 * r["expected_height_m"], "k_", ms=25)
        ax.text(
            r["filament"],
            1e3 * r["settled_height_m"] + 3,
            f"{r['density_kg_m3']:.0f}",
            ha="center",
            fontsize=8,
        )
    ax.set_xlim(0.3, 4.7)
    ax.set_ylim(-depth, 8)
    ax.set_xticks([1, 2, 3, 4])
    ax.set_xlabel("filament (red: simulated, black: where the column matches its density)")
    ax.set_ylabel("height (mm, surface at 0)")
    ax.set_title("Fig. 3E: settling in the gradient column", fontsize=10)
    fig.tight_layout()
    fig.savefig(out / "fig3e_settling.png", dpi=110)
    plt.close(fig)
    return rows


def run(out_dir: str | Path, quick: bool = False) -> dict[str, list[dict]]:
    """Both parts of Fig. 3 into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return {"composites": composite_curves(out, quick), "settling": settling(out, quick)}

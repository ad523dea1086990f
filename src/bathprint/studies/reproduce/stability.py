"""The linear stability of the extruded rod: theory against simulated onsets.

The growth rate sigma of the paper's eigenvalue problem, in units of B / (mu_s L^4), is a
function of beta = mu_s v L^3 / B alone (:func:`bathprint.analysis.theory.growth_rate`). The
simulator's growth rate of a small perturbation (:func:`bathprint.analysis.validation.
extruded_rod_growth_rate`, the rod in the frame of its material) is measured for several
extrusion speeds v and bending stiffnesses B and put on the same axes; the onset is where
sigma changes sign, beta_c = 3.4766.
"""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from bathprint.analysis import theory
from bathprint.analysis.validation import extruded_rod_growth_rate_for
from bathprint.viz.plotting import plt


def run(out_dir: str | Path, quick: bool = False) -> dict:
    """Write stability.png and stability.csv; return the onsets found."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    betas_theory = np.linspace(0.5, 8.0, 120)
    s_theory = np.array([theory.growth_rate(b) for b in betas_theory])
    cases = (
        [(5e4, 1.0), (5e4, 0.5), (2e4, 1.0)]
        if quick
        else [(5e4, 1.0), (5e4, 0.5), (2e4, 1.0), (1e5, 0.8), (2e4, 0.25)]
    )
    betas_sim = [2.5, 3.3, 3.7, 4.5] if quick else [1.5, 2.5, 3.0, 3.3, 3.48, 3.7, 4.0, 5.0, 6.0]
    rows = []
    for modulus, diameter_mm in cases:
        for beta in betas_sim:
            sigma, scale, v = extruded_rod_growth_rate_for(beta, modulus, diameter_mm)
            rows.append(
                {
                    "youngs_modulus_pa": modulus,
                    "diameter_mm": diameter_mm,
                    "beta": beta,
                    "speed_m_s": v,
                    "sigma_1_s": sigma,
                    "sigma_scaled": sigma / scale,
                    "theory_sigma_scaled": theory.growth_rate(beta),
                }
            )
    with (out / "stability.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    onsets = {}
    for modulus, diameter_mm in cases:
        pts = [
            (r["beta"], r["sigma_scaled"])
            for r in rows
            if r["youngs_modulus_pa"] == modulus and r["diameter_mm"] == diameter_mm
        ]
        b, s = np.array(pts).T
        k = int(np.argmax(s > 0))
        onsets[f"E={modulus:g} Pa, d={diameter_mm:g} mm"] = float(
            b[k - 1] + (b[k] - b[k - 1]) * (-s[k - 1]) / (s[k] - s[k - 1])
        )
    beta_c = theory.beta_critical()
    fig, (a, b2) = plt.subplots(1, 2, figsize=(11, 4.2))
    a.plot(betas_theory, s_theory, "k-", label="theory (Chebyshev collocation)")
    markers = "osd^v"
    for (modulus, diameter_mm), mk in zip(cases, markers, strict=False):
        pts = [
            r for r in rows if r["youngs_modulus_pa"] == modulus and r["diameter_mm"] == diameter_mm
        ]
        a.plot(
            [r["beta"] for r in pts],
            [r["sigma_scaled"] for r in pts],
            mk,
            mfc="none",
            label=f"simulated, E = {modulus / 1e3:g} kPa, d = {diameter_mm:g} mm",
        )
    a.axhline(0, color="gray", lw=0.6)
    a.axvline(beta_c, color="tab:red", lw=0.8, ls="--")
    a.text(beta_c, a.get_ylim()[0] * 0.9, f" beta_c = {beta_c:.4f}", color="tab:red")
    a.set_xlabel("beta = mu_s v L^3 / B")
    a.set_ylabel("growth rate sigma mu_s L^4 / B")
    a.set_title("Growth rate of the extruded rod")
    a.legend(fontsize=7)
    lengths = betas_theory ** (1 / 3)
    b2.plot(lengths, s_theory / betas_theory ** (4 / 3), "k-")
    b2.axhline(0, color="gray", lw=0.6)
    b2.axvline(beta_c ** (1 / 3), color="tab:red", lw=0.8, ls="--")
    b2.set_xlabel("L / (B / (mu_s v))^(1/3)")
    b2.set_ylabel("sigma / (v / (B / (mu_s v))^(1/3))")
    b2.set_title(f"against length: onset at L = {beta_c ** (1 / 3):.4f} (B/(mu_s v))^(1/3)")
    fig.tight_layout()
    fig.savefig(out / "stability.png", dpi=110)
    plt.close(fig)
    return {"beta_c": beta_c, "simulated_onsets": onsets}

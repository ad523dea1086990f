"""Measurements as in the lab, on simulated filament segments.

- :func:`cantilever_method`: the paper's bending measurement (Materials and Methods): a
  segment overhangs a ledge by lambda and sags by delta under its own weight in air;
  Euler-Bernoulli gives lambda^4 = (2 E r^2 / (rho g)) delta, so E comes from the slope
  of lambda^4 against delta.
- :func:`stretching_test`: a hanging segment pulled by a small weight; E_c = F L / (A dL)
  with A the full cross-section, as the paper's stress-strain curves (Fig. 3D).
- :func:`settling_height`: a free composite filament released in the density-gradient
  column settles where the bath is as dense as it is (Fig. 3E).

Each builds a :class:`~bathprint.core.simulation.Simulation` of a short filament whose
material is set, per segment, by the same rules as extruded material
(:func:`bathprint.core.extrusion.material_row`), then lets it come to rest.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from bathprint.core import layout as L
from bathprint.core.extrusion import material_row
from bathprint.core.simulation import Simulation

G = 9.81
# weighed in air, as on the lab bench; the viscosity only sets how fast a segment comes to
# rest (the measured sag is static), so water's keeps the transient well resolved
AIR = {"bath.density_kg_m3": 1.2, "bath.viscosity_pa_s": 1e-3}


def _segment_sim(overrides: dict[str, Any], phi: float, age_s: float = 0.0) -> Simulation:
    """A straight filament out of a needle, at rest, whose segments all have fraction phi."""
    base = {
        "flow.q_outer_ml_min": 0.0,
        "needle.imperfection_um": 0.0,
        "effects": ["elasticity", "drag", "gravity", "inclusions"],
        "numerics.tolerance": 1e-6,
    }
    sim = Simulation("paper_simulation", {**base, **overrides})
    row = np.empty(L.N_MAT)
    d = sim.model.needle[0, 4:7].copy()
    material_row(phi, -age_s, 0.0, d, sim.model.p, row)
    n = sim.n_nodes
    sim.seg_mat[: n - 1] = row  # every segment and the ghost
    return sim


@dataclass
class CantileverMeasurement:
    """Result of the cantilever method."""

    youngs_modulus_pa: float  # E from the slope of lambda^4 against delta
    overhang_m: np.ndarray
    deflection_m: np.ndarray
    slope_m3: float  # d(lambda^4)/d(delta)


def cantilever_method(
    youngs_modulus_pa: float = 4800.0,
    density_kg_m3: float = 1054.0,
    diameter_mm: float = 1.0,
    phi: float = 0.0,
    overhangs_mm: tuple[float, ...] = (1.5, 2.0, 2.5, 3.0),
    segments: int = 15,
    extra: dict[str, Any] | None = None,
) -> CantileverMeasurement:
    """Sag of overhangs in air, then E = slope rho g / (2 r^2) as the paper does.

    ``phi`` > 0 measures a composite (with the inclusions' rules); the returned modulus is
    then the effective bending modulus f_B E.
    """
    lam, delta = [], []
    rho_c = None
    for overhang in overhangs_mm:
        over = {
            **AIR,
            "material.youngs_modulus_pa": youngs_modulus_pa,
            "material.density_kg_m3": density_kg_m3,
            "needle.inner_diameter_mm": diameter_mm,
            "needle.direction": [1.0, 0.0, 0.0],
            "initial.length_mm": overhang,
            "numerics.node_spacing_mm": overhang / segments,
            **(extra or {}),
        }
        sim = _segment_sim(over, phi)
        rho_c = float(sim.seg_mat[0, L.MAT_DENSITY])
        t = 0.0
        previous = None
        for _ in range(40):  # advance until the tip stops moving
            t += 0.05
            sim.advance(t)
            c = sim.centerline()
            sag = float(c[-1, 2] - c[0, 2])
            if previous is not None and abs(sag - previous) < 1e-9 * abs(sag) + 1e-15:
                break
            previous = sag
        lam.append(overhang * 1e-3)
        delta.append(sag)
    lam_arr, delta_arr = np.array(lam), np.array(delta)
    slope = float(np.sum(lam_arr**4 * delta_arr) / np.sum(delta_arr**2))  # through the origin
    r = diameter_mm * 1e-3 / 2
    net = rho_c - AIR["bath.density_kg_m3"]  # the weight in air (the paper writes rho)
    return CantileverMeasurement(slope * net * G / (2 * r * r), lam_arr, delta_arr, slope)


def stretching_test(
    phi: float,
    youngs_modulus_pa: float = 4800.0,
    fluid: str = "silicone_oil",
    length_mm: float = 10.0,
    strain: float = 1e-3,
    segments: int = 20,
) -> float:
    """E_c / E_alg read off a simulated hanging segment pulled to ~``strain``."""
    r = 0.5e-3
    force = strain * youngs_modulus_pa * math.pi * r * r  # would give `strain` in pure gel
    sim = _segment_sim(
        {
            "effects": ["elasticity", "drag", "end_load", "inclusions"],
            "inclusions.fluid": fluid,
            "material.youngs_modulus_pa": youngs_modulus_pa,
            "needle.direction": [0.0, 0.0, -1.0],
            "initial.length_mm": length_mm,
            "numerics.node_spacing_mm": length_mm / segments,
            "end_load.force_n": [0.0, 0.0, -force],
        },
        phi,
    )
    sim.advance(1.0)
    c = sim.centerline()
    stretched = float(np.sum(np.linalg.norm(np.diff(c, axis=0), axis=1)))
    e_c = force * (length_mm * 1e-3) / (math.pi * r * r * (stretched - length_mm * 1e-3))
    return e_c / youngs_modulus_pa


def settling_height(
    density_kg_m3: float,
    column: tuple[float, float] = (1010.0, 1050.0),
    depth_mm: float = 125.0,
    start_depth_mm: float = 60.0,
    length_mm: float = 10.0,
    node_spacing_mm: float = 0.5,
    fluid: str = "silicone_oil",
    duration_s: float = 20.0,
) -> tuple[float, float, float]:
    """(settled height, expected height, node spacing) in m for a free composite filament.

    The composite's inner fraction is chosen to give ``density_kg_m3`` by the volume-weighted
    rule; it is released horizontally at ``start_depth_mm`` in a column whose density goes
    linearly from ``column[0]`` at the surface (z = 0) to ``column[1]`` at the floor.
    """
    from bathprint.core.composite import INNER_FLUIDS

    rho_alg = 1054.0
    rho_in = INNER_FLUIDS[fluid].density_kg_m3
    phi = (rho_alg - density_kg_m3) / (rho_alg - rho_in)
    sim = _segment_sim(
        {
            "effects": ["elasticity", "drag", "gravity", "inclusions"],
            "inclusions.fluid": fluid,
            "material.density_kg_m3": rho_alg,
            "bath.density_kg_m3": column[0],
            "bath.density_bottom_kg_m3": column[1],
            "bath.depth_mm": depth_mm,
            "needle.direction": [1.0, 0.0, 0.0],
            "needle.position_mm": [0.0, 0.0, -start_depth_mm],
            "needle.release_s": 1e-6,
            "initial.length_mm": length_mm,
            "numerics.node_spacing_mm": node_spacing_mm,
            "numerics.tolerance": 1e-5,
            "duration_s": duration_s,
        },
        phi,
    )
    sim.advance(duration_s)
    z = float(np.mean(sim.centerline()[:, 2]))
    grad = (column[1] - column[0]) / (depth_mm * 1e-3)
    expected = -(density_kg_m3 - column[0]) / grad  # where rho_bath(z) = rho_c
    expected = min(expected, 0.0)  # lighter than the top: floats at the surface
    return z, expected, node_spacing_mm * 1e-3


def composite_curve(
    flow_ratios: np.ndarray, fluid: str = "silicone_oil", youngs_modulus_pa: float = 4800.0
) -> list[dict[str, float]]:
    """E_c/E_alg (stretching test) and rho_c/rho_alg (a simulated segment) against
    (Q_o - Q_i)/(Q_o + Q_i), as in the paper's Fig. 3D and 3F."""
    rows = []
    for x in flow_ratios:
        phi = (1.0 - float(x)) / 2.0
        sim = _segment_sim({"inclusions.fluid": fluid}, phi)
        rho_c = float(sim.seg_mat[0, L.MAT_DENSITY])
        rows.append(
            {
                "flow_ratio": float(x),
                "inner_volume_fraction": phi,
                "E_c_over_E_alg": stretching_test(phi, youngs_modulus_pa, fluid),
                "rho_c_over_rho_alg": rho_c / 1054.0,
                "density_kg_m3": rho_c,
                "inclusion_size_m": float(sim.seg_mat[0, L.MAT_INCLUSION_SIZE]),
                "inclusion_spacing_m": float(sim.seg_mat[0, L.MAT_INCLUSION_SPACING]),
            }
        )
    return rows

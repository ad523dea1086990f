"""Analytic checks of the simulator: each returns the simulated and the exact value.

Used by the test suite (with the tolerances stated there), by ``bathprint validate``
(which prints the table in the README) and by the benchmarks.

- cantilever under its own net weight: tip deflection q L^4 / (8 E I);
- clamped-free column under a dead end load: critical load pi^2 E I / (4 L^2);
- straight rod translating through the bath: drag mu_s v L along, 2 mu_s v L across;
- extruded rod: onset of buckling at beta = mu_s v L^3 / B = beta_c (3.4768...), the root
  of 0F1(4/3; -beta/9) = (beta/4) 0F1(7/3; -beta/9) (the paper's linear stability).
  In the frame of the extruded material the paper's problem is a rod of fixed length L,
  clamped at the needle, in a uniform flow of speed v from the free end toward the needle
  (relative velocity -v along the axis, compression T = -mu_s v x): that is what is run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.optimize import brentq
from scipy.special import hyp0f1

from bathprint.core.simulation import Simulation

CANTILEVER = {
    # the cantilever in water of the benchmarks: L = 10 mm, r = 0.5 mm, E = 50 kPa,
    # drho = 3 kg/m^3, mu = 1e-3 Pa s, rho_bath = 1003 kg/m^3
    "effects": ["elasticity", "drag", "gravity"],
    "needle.direction": [1.0, 0.0, 0.0],
    "needle.position_mm": [0.0, 0.0, -20.0],
    "needle.inner_diameter_mm": 1.0,
    "needle.imperfection_um": 0.0,
    "flow.q_outer_ml_min": 0.0,
    "initial.length_mm": 10.0,
    "material.youngs_modulus_pa": 5e4,
    "material.density_kg_m3": 1006.0,
    "bath.density_kg_m3": 1003.0,
    "bath.viscosity_pa_s": 1e-3,
}


def beta_critical() -> float:
    """Root of 0F1(4/3; -b/9) = (b/4) 0F1(7/3; -b/9): the onset of the extruded rod's buckling."""
    f = lambda b: hyp0f1(4.0 / 3.0, -b / 9.0) - 0.25 * b * hyp0f1(7.0 / 3.0, -b / 9.0)  # noqa: E731
    return float(brentq(f, 1.0, 6.0, xtol=1e-14))


@dataclass
class Check:
    """One analytic comparison."""

    name: str
    simulated: float
    exact: float
    tolerance: float  # relative
    detail: str = ""

    @property
    def relative_error(self) -> float:
        return abs(self.simulated - self.exact) / abs(self.exact)

    @property
    def passed(self) -> bool:
        return self.relative_error <= self.tolerance


def cantilever_deflection(
    n_segments: int = 50, tolerance: float = 1e-7, integrator: str = "implicit"
) -> tuple[float, float, Simulation]:
    """(simulated, exact) steady tip deflection (m) of the benchmark cantilever."""
    length_mm = CANTILEVER["initial.length_mm"]
    sim = Simulation(
        "paper_simulation",
        {
            **CANTILEVER,
            "numerics.node_spacing_mm": length_mm / n_segments,
            "numerics.tolerance": tolerance,
            "numerics.integrator": integrator,
            "duration_s": 0.3,
        },
    )
    sim.advance(0.3)
    c = sim.centerline()
    deflection = c[-1, 2] - c[0, 2]
    m = sim.model
    drho = CANTILEVER["material.density_kg_m3"] - CANTILEVER["bath.density_kg_m3"]
    q = drho * 9.81 * math.pi * m.radius**2
    exact = q * (length_mm * 1e-3) ** 4 / (8.0 * m.bending_stiffness)
    return float(deflection), float(exact), sim


def _lateral_growth_rate(sim: Simulation, t_end: float, n_samples: int = 80) -> float:
    """Exponential rate (1/s) of the lateral amplitude while it is still linear.

    Samples up to ``t_end`` or until the amplitude reaches 1% of the length, drops the
    first third of that window (decay of the other modes) and fits log-amplitude.
    """
    axis = sim.model.needle[0, 4:7]
    length = float(np.sum(sim.rest_lengths()))
    times, amps = [], []
    for t in np.linspace(t_end / n_samples, t_end, n_samples):
        sim.advance(float(t))
        c = sim.centerline()
        rel = c - c[-1]
        lateral = rel - np.outer(rel @ axis, axis)
        amp = float(np.linalg.norm(lateral, axis=1).max())
        times.append(t)
        amps.append(amp)
        if amp > 1e-2 * length:
            break
    k0 = len(times) // 3
    return float(np.polyfit(times[k0:], np.log(amps[k0:]), 1)[0])


def column_growth_rate(load_ratio: float, n_segments: int = 40) -> float:
    """Growth rate (1/s) of a perturbation of a vertical clamped-free column loaded at
    ``load_ratio`` times the Euler load pi^2 E I / (4 L^2): negative below, positive above."""
    length_mm = 10.0
    sim = Simulation(
        "paper_simulation",
        {
            **CANTILEVER,
            "effects": ["elasticity", "drag", "end_load"],
            "needle.direction": [0.0, 0.0, 1.0],
            "initial.length_mm": length_mm,
            "initial.perturbation_mm": 1e-4,
            "numerics.node_spacing_mm": length_mm / n_segments,
            "numerics.tolerance": 1e-6,
            "duration_s": 2.0,
        },
    )
    p_c = math.pi**2 * sim.model.bending_stiffness / (4.0 * (length_mm * 1e-3) ** 2)
    sim.model.p.end_load = (0.0, 0.0, -load_ratio * p_c)
    return _lateral_growth_rate(sim, 1.0)


def extruded_rod_growth_rate_for(
    beta: float,
    youngs_modulus_pa: float = 5e4,
    diameter_mm: float = 1.0,
    n_segments: int = 40,
    length_mm: float = 10.0,
    extra: dict[str, Any] | None = None,
    time_step_scale: float | None = None,
) -> tuple[float, float, float]:
    """(growth rate 1/s, its scale B / (mu_s L^4) in 1/s, speed v m/s) of a perturbation of
    the extruded rod at beta = mu_s v L^3 / B, for a given modulus and diameter.

    ``extra``: further scene overrides (numerics); ``time_step_scale``: a fixed step of that
    many units of mu_s L^4 / B (None: adaptive, tolerance 1e-6 unless ``extra`` sets one).
    """
    overrides: dict[str, Any] = {
        **CANTILEVER,
        "effects": ["elasticity", "drag"],
        "drag.model": "constant",
        "needle.direction": [0.0, 0.0, -1.0],
        "needle.inner_diameter_mm": diameter_mm,
        "material.youngs_modulus_pa": youngs_modulus_pa,
        "initial.length_mm": length_mm,
        "initial.perturbation_mm": 1e-5 * length_mm,
        "numerics.node_spacing_mm": length_mm / n_segments,
        "numerics.tolerance": 1e-6,
        "duration_s": 1e3,
        **(extra or {}),
    }
    sim = Simulation("paper_simulation", overrides)
    m = sim.model
    length = length_mm * 1e-3
    scale = m.bending_stiffness / (m.mu_s * length**4)
    if time_step_scale is not None:
        overrides["numerics.time_step_s"] = time_step_scale / scale
        sim = Simulation("paper_simulation", overrides)
        m = sim.model
    v = beta * m.bending_stiffness / (m.mu_s * length**3)
    m.p.bath_flow = (0.0, 0.0, v)  # from the free end toward the needle
    return _lateral_growth_rate(sim, 10.0 / scale), scale, v


def extruded_rod_growth_rate(beta: float, n_segments: int = 40) -> float:
    """Growth rate (1/s) of a perturbation of the extruded rod at beta = mu_s v L^3 / B."""
    return extruded_rod_growth_rate_for(beta, n_segments=n_segments)[0]


def onset_beta(lo: float = 3.0, hi: float = 4.0, n_segments: int = 40) -> float:
    """beta at which the simulated growth rate changes sign (linear interpolation)."""
    s_lo = extruded_rod_growth_rate(lo, n_segments)
    s_hi = extruded_rod_growth_rate(hi, n_segments)
    return lo + (hi - lo) * (-s_lo) / (s_hi - s_lo)


def translating_rod_drag(
    axis: tuple[float, float, float], velocity: tuple[float, float, float]
) -> tuple[np.ndarray, float, float]:
    """Total drag (N) on a straight 20 mm rod moving rigidly at ``velocity`` (m/s).

    Returns (force, mu_s, L); the exact answer is -mu_s L (2 v_perp + v_par).
    """
    from bathprint.core.effects import drag

    sim = Simulation(
        "paper_simulation",
        {"initial.length_mm": 20.0, "flow.q_outer_ml_min": 0.0, "needle.direction": list(axis)},
    )
    n = sim.n_nodes
    vel = np.tile(np.asarray(velocity, dtype=float), sim.capacity)
    inputs = sim.kernel_inputs(0.0, 0.0, 0.0, False, vel=vel)
    drag.accumulate(*inputs)
    force = inputs[3].force
    total = force[: 3 * (n - 1)].reshape(-1, 3).sum(axis=0)  # every filament node, tip included
    length = float(np.sum(np.linalg.norm(np.diff(sim.centerline(), axis=0), axis=1)))
    return total, sim.model.mu_s, length


def column_critical_load_ratio(n_segments: int = 40) -> float:
    """Simulated critical load / Euler load, from the zero of the growth rate (interpolated)."""
    lo, hi = 0.98, 1.02
    s_lo = column_growth_rate(lo, n_segments)
    s_hi = column_growth_rate(hi, n_segments)
    return lo + (hi - lo) * (-s_lo) / (s_hi - s_lo)


def inertial_cantilever_frequency(tolerance: float = 1e-5) -> tuple[float, float]:
    """(simulated, exact) damped first-mode frequency (rad/s) of the cantilever with inertia.

    Drag per length is uniform like the mass, so the damping is modal:
    omega_d = sqrt(omega_1^2 - (c/2m)^2), omega_1 = 1.8751^2 sqrt(B / (m L^4)), c = 2 mu_s,
    m = (rho + C_a rho_bath) A.
    """
    sim = Simulation(
        "cantilever_water",
        {"effects": ["elasticity", "drag", "gravity", "inertia"], "numerics.tolerance": tolerance},
    )
    times = np.linspace(0.0, 0.5, 2001)[1:]
    z = np.empty(len(times))
    for k, t in enumerate(times):
        sim.advance(float(t))
        c = sim.centerline()
        z[k] = c[0, 2] - c[-1, 2]
    m = sim.model
    mass = math.pi * m.radius**2 * (1006.0 + 1003.0)
    omega_1 = 1.8751**2 * math.sqrt(m.bending_stiffness / (mass * 0.01**4))
    omega_d = math.sqrt(omega_1**2 - (2 * m.mu_s / (2 * mass)) ** 2)
    dev = z - z[-400:].mean()
    crossings = times[1:][np.diff(np.sign(dev)) != 0]
    return float(2 * math.pi / (2 * np.mean(np.diff(crossings)))), omega_d


def run_all() -> list[Check]:
    """Every analytic check, with the tolerance the test suite asserts."""
    checks = []
    sim_d, exact_d, _ = cantilever_deflection(50)
    checks.append(
        Check("cantilever tip deflection q L^4/(8EI), 50 segments", sim_d, exact_d, 0.01, "m")
    )
    sim_d, exact_d, _ = cantilever_deflection(100)
    checks.append(Check("cantilever tip deflection, 100 segments", sim_d, exact_d, 0.01, "m"))
    checks.append(
        Check(
            "column critical load / (pi^2 EI / 4L^2), 40 segments",
            column_critical_load_ratio(),
            1.0,
            0.02,
            "-",
        )
    )
    for label, vel, factor in (
        ("along the axis: mu_s v L", (0.0, 0.0, -0.01), 1.0),
        ("across the axis: 2 mu_s v L", (0.01, 0.0, 0.0), 2.0),
    ):
        force, mu_s, length = translating_rod_drag((0.0, 0.0, -1.0), vel)
        speed = float(np.linalg.norm(vel))
        checks.append(
            Check(
                f"translating rod drag {label}",
                float(np.linalg.norm(force)),
                factor * mu_s * length * speed,
                1e-9,
                "N",
            )
        )
    beta_c = beta_critical()
    checks.append(
        Check(
            "extruded rod onset beta = mu_s v L^3 / B, 40 segments",
            onset_beta(0.95 * beta_c, 1.05 * beta_c),
            beta_c,
            0.05,
            "-",
        )
    )
    w_sim, w_exact = inertial_cantilever_frequency()
    checks.append(Check("inertial cantilever damped frequency", w_sim, w_exact, 0.02, "rad/s"))
    return checks

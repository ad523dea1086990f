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
  (relative velocity -v along the axis, compression T = -mu_s v x): that is what is run;
- viscous thread (effect ``viscosity``): pulled by a force F it stretches at
  dL/dt = F L0 / (Tr eta A) (Trouton 1906);
- Kelvin-Voigt rod (``elasticity`` and ``viscosity`` on one section): every deformation of
  a straight rod relaxes as exp(-t E / (Tr eta)), whatever its shape.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
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


def beta_critical_for_ratio(rho: float) -> float:
    """beta_c = zeta_t v L^3 / B of the extruded rod's onset with normal / tangential drag
    ratio rho: the static mode of B y'''' + zeta_t v (x y'' + rho y') = 0 (compression
    -zeta_t v x from the free end x = 0, and the normal drag's advection term
    (zeta_n - zeta_t) v y'), free at x = 0, clamped at x = L; rho = 2 is the paper's
    condition (3.4766)."""
    from scipy.integrate import solve_ivp

    def slope_at_needle(beta: float) -> float:
        def rhs(x: float, y: np.ndarray) -> list[float]:
            return [y[1], y[2], -beta * (x * y[1] + rho * y[0])]

        sol = solve_ivp(rhs, (0.0, 1.0), [1.0, 0.0, 0.0], rtol=1e-10, atol=1e-12)
        return float(sol.y[0, -1])

    return float(brentq(slope_at_needle, 0.5, 20.0, xtol=1e-10))


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


# nearly no drag (mu_s = 1e-6 Pa s, 1e-4 of the viscous stress or less) and a still needle:
# the rod's own viscous stress is all that resists
VISCOUS_ROD = {
    "flow.q_outer_ml_min": 0.0,
    "drag.model": "constant",
    "drag.coefficient_pa_s": 1e-6,
    "needle.imperfection_um": 0.0,
    "numerics.node_spacing_mm": 1.0,
    "numerics.tolerance": 1e-6,
}


def _filament_length(sim: Simulation) -> float:
    x = sim.centerline()
    return float(np.linalg.norm(np.diff(x, axis=0), axis=1).sum())


def viscous_thread_stretch_rate(
    eta: float = 2.0, trouton: float = 3.0, force: float = 1e-5, strain: float = 0.05
) -> tuple[float, float]:
    """(simulated, exact) mean stretching rate dL/dt (m/s) of a 20 mm thread of radius
    0.5 mm, clamped at the needle and pulled along it by ``force`` (N) until ``strain``:
    F L0 / (Tr eta A), the extensional viscosity Tr eta acting on the rest section."""
    sim = Simulation(
        "paper_simulation",
        {
            **VISCOUS_ROD,
            "effects": ["drag", "viscosity", "end_load"],
            "initial.length_mm": 20.0,
            "viscosity.solution_viscosity_pa_s": eta,
            "viscosity.trouton_ratio": trouton,
            "end_load.force_n": [0.0, 0.0, -force],
        },
    )
    length0 = _filament_length(sim)
    rate = force * length0 / (trouton * eta * math.pi * sim.model.radius**2)
    t_end = strain * length0 / rate
    sim.advance(t_end)
    return (_filament_length(sim) - length0) / t_end, rate


def kelvin_voigt_relaxation(
    perturbation_mm: float = 0.05, eta: float = 20.0, modulus: float = 4800.0
) -> tuple[float, float]:
    """(simulated, exact) deflection of the free end of a 10 mm rod (E = ``modulus``, a sine
    perturbation of ``perturbation_mm``) after one relaxation time Tr eta / E, over its
    initial deflection: exp(-1)."""
    sim = Simulation(
        "paper_simulation",
        {
            **VISCOUS_ROD,
            "effects": ["elasticity", "drag", "viscosity"],
            "initial.length_mm": 10.0,
            "initial.perturbation_mm": perturbation_mm,
            "material.youngs_modulus_pa": modulus,
            "viscosity.solution_viscosity_pa_s": eta,
        },
    )
    axis = np.asarray(sim.model.scene.needle.direction, dtype=float)
    axis /= np.linalg.norm(axis)

    def deflection() -> float:
        c = sim.centerline()
        tip = c[0] - c[-1]
        return float(np.linalg.norm(tip - (tip @ axis) * axis))

    d0 = deflection()
    sim.advance(sim.model.scene.viscosity.trouton_ratio * eta / modulus)
    return deflection() / d0, math.exp(-1.0)


@dataclass
class HangingThread:
    """A viscous thread hanging under its net weight, simulated and exact, at some times:
    ``times_s`` (s), total lengths (m) and each segment's stretch (length over its length at
    t = 0, top segment last), and the analytic blow-up time ``blowup_s``."""

    times_s: list[float]
    length_m: list[float]
    exact_length_m: list[float]
    stretch: list[np.ndarray]
    exact_stretch: list[np.ndarray]
    blowup_s: float


def hanging_thread_exact(
    t: float, edges_m: np.ndarray, length_m: float, drho: float, g: float, eta_e: float
) -> tuple[float, np.ndarray]:
    """(total length, each element's mean stretch) of Trouton's viscous thread hanging from
    a fixed top under its net weight, without inertia or surface tension, at time t (s).

    In the Lagrangian coordinate u (m of unstretched thread above the free end) the weight
    below is W = drho g A0 u; the tension W = eta_e A dln(l)/dt with A = A0 / lambda gives
    d(1/lambda)/dt = -W / (eta_e A0), so lambda = 1 / (1 - c u t), c = drho g / eta_e, and
    the length int_0^L lambda du = ln(1 / (1 - c L t)) / (c t). ``edges_m`` are the elements'
    edges in u (rising); an element's mean stretch is ln((1 - c t u_a) / (1 - c t u_b)) /
    (c t (u_b - u_a))."""
    ct = drho * g / eta_e * t
    if ct * length_m >= 1.0:
        raise ValueError(f"t = {t!r} s is at or past the blow-up time")
    total = -math.log1p(-ct * length_m) / ct
    ua, ub = edges_m[:-1], edges_m[1:]
    stretch = (np.log1p(-ct * ua) - np.log1p(-ct * ub)) / (ct * (ub - ua))
    return total, stretch


def viscous_thread_under_gravity(
    fractions: tuple[float, ...] = (0.25, 0.5, 0.75),
    spacing_mm: float = 0.5,
    tolerance: float = 1e-6,
    time_step_s: float = 0.0,
    eta: float = 100.0,
    length_mm: float = 20.0,
) -> HangingThread:
    """The liquid limit of the ``liquid`` effect: a thread of ``length_mm`` (radius 0.5 mm,
    drho = 100 kg/m^3, E = 2 Pa relaxed with tau = 1e-7 s, so tau << every step) hanging from
    the needle with ``elasticity``, ``gravity``, ``viscosity`` and ``liquid`` (a drag of
    1e-6 Pa s keeps the overdamped equations regular), at the given fractions of the blow-up
    time eta_e / (drho g L), against :func:`hanging_thread_exact`."""
    sim = Simulation(
        "paper_simulation",
        {
            **VISCOUS_ROD,
            "effects": ["elasticity", "drag", "gravity", "viscosity", "liquid"],
            "initial.length_mm": length_mm,
            "numerics.node_spacing_mm": spacing_mm,
            "numerics.tolerance": tolerance,
            "numerics.time_step_s": time_step_s,
            "numerics.max_strain": 1.0,
            "numerics.stretch_limit": 1.0,
            "bath.density_kg_m3": 1000.0,
            "material.density_kg_m3": 1100.0,
            "material.youngs_modulus_pa": 2.0,
            "liquid.viscosity_pa_s": 2e-7,
            "viscosity.solution_viscosity_pa_s": eta,
            "viscosity.trouton_ratio": 3.0,
        },
    )
    scene = sim.model.scene
    drho = scene.material.density_kg_m3 - scene.bath.density_kg_m3
    g = scene.bath.gravity_m_s2
    eta_e = scene.viscosity.trouton_ratio * eta
    from bathprint.core.layout import MAT_RADIUS

    n_seg = sim.n_segments
    r0 = sim.model.radius
    l_start = np.linalg.norm(np.diff(sim.centerline(), axis=0), axis=1)[:n_seg]
    vol = sim.rest_lengths()[:n_seg] * sim.material()[:n_seg, MAT_RADIUS] ** 2 / r0**2
    edges = np.concatenate([[0.0], np.cumsum(vol)])  # u of each node, free end first
    length0 = float(edges[-1])
    blowup = eta_e / (drho * g * length0)
    out = HangingThread([], [], [], [], [], blowup)
    for f in fractions:
        t = f * blowup
        sim.advance(t)
        seg = np.linalg.norm(np.diff(sim.centerline(), axis=0), axis=1)[:n_seg]
        total, stretch = hanging_thread_exact(t, edges, length0, drho, g, eta_e)
        out.times_s.append(t)
        out.length_m.append(float(seg.sum()))
        out.exact_length_m.append(total)
        out.stretch.append(seg / l_start)
        out.exact_stretch.append(stretch)
    return out


def viscosity_checks() -> list[Check]:
    """The viscosity effect: Trouton's thread and the Kelvin-Voigt rod."""
    sim_rate, rate = viscous_thread_stretch_rate()
    checks = [Check("viscous thread stretch rate F L / (3 eta A)", sim_rate, rate, 1e-3, "m/s")]
    for amp in (0.05, 0.2):
        sim_ratio, ratio = kelvin_voigt_relaxation(amp)
        checks.append(
            Check(
                f"Kelvin-Voigt rod relaxation after 3 eta / E ({amp} mm)",
                sim_ratio,
                ratio,
                0.005,
                "-",
            )
        )
    return checks


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
    checks.extend(finite_re_checks())
    checks.extend(hydrodynamics_checks())
    checks.extend(viscosity_checks())
    return checks


def finite_re_checks() -> list[Check]:
    """drag.model = 'finite_re': the cylinder drag curve against the experimental data."""
    from bathprint.core.effects._drag_laws import cd_cylinder

    return [
        Check(
            f"finite_re cylinder C_D at Re = {re:g} vs experiment",
            float(cd_cylinder(re)[0]),
            cylinder_drag_data(re),
            0.10,
            "-",
        )
        for re in (0.1, 1.0, 10.0, 100.0)
    ]


def hydro_onset_beta() -> tuple[float, float]:
    """(simulated, predicted) onset beta = mu_s v L^3 / B of the extruded rod (L/r = 20) with
    hydrodynamics, mu_s Cox's of the rod's length; predicted: the linear theory with the
    tangential and normal drag of a slender cylinder (Tirado & Garcia de la Torre) in place
    of mu_s and 2 mu_s (the next order in 1/ln(L/r))."""
    extra = {
        "effects": ["elasticity", "drag", "hydrodynamics"],
        "drag.model": "cox",
        "drag.length_scale_mm": 10.0,
    }
    lo, hi = 3.6, 4.2
    s_lo = extruded_rod_growth_rate_for(lo, extra=extra)[0]
    s_hi = extruded_rod_growth_rate_for(hi, extra=extra)[0]
    onset = lo + (hi - lo) * (-s_lo) / (s_hi - s_lo)
    zeta_t, zeta_n = cylinder_drag_tirado(10.0, 1.0, 1.0)
    mu_s = 2.0 * math.pi / math.log(20.0)
    return onset, beta_critical_for_ratio(zeta_n / zeta_t) * mu_s / zeta_t


def hydrodynamics_checks() -> list[Check]:
    """The hydrodynamics effect: rigid slender bodies in Stokes flow, the sedimenting filament,
    the extruded rod's onset."""
    mu = 1e-3
    checks = []
    rods = (
        ("cylinder L/d = 50", hydro_rod(50, 100), cylinder_drag_tirado(50, mu, 10e-3), "Tirado"),
        (
            "spheroid a/b = 50",
            spheroid_rod(50, 100),
            spheroid_drag_exact(5e-3, 0.1e-3, mu),
            "exact",
        ),
    )
    for body, sim, exact, source in rods:
        for label, vel, axis, ref in (
            ("along", (0.0, 0.0, 1e-3), 2, exact[0]),
            ("across", (1e-3, 0.0, 0.0), 0, exact[1]),
        ):
            force = -rigid_body_drag(sim, vel)[axis] / 1e-3
            name = f"hydro: {body} drag {label} vs {source}"
            checks.append(Check(name, force, ref, 0.03, "N s/m"))
    broad, edge = ring_drag(0.03)
    jw_broad, jw_edge = torus_drag_johnson_wu(1e-3, 0.03, mu)
    checks.append(
        Check("hydro: ring eps = 0.03 broadside vs Johnson & Wu", broad, jw_broad, 0.03, "N s/m")
    )
    checks.append(
        Check("hydro: ring eps = 0.03 edgewise vs Johnson & Wu", edge, jw_edge, 0.03, "N s/m")
    )
    sed = sedimenting_filament(aspect=50.0, deflection_scale=0.2, n_segments=60)
    checks.append(
        Check(
            "hydro: sedimenting filament speed vs rigid rod",
            sed["speed"],
            sed["rigid_speed_tirado"],
            0.01,
            "m/s",
        )
    )
    lag = sed["lag"]
    checks.append(
        Check(
            "hydro: sedimenting filament end lag vs Xu & Nadim",
            0.5 * float(lag[0] + lag[-1]),
            float(xu_nadim_shape(np.array([1.0]))[0]) * sed["D"],
            0.20,
            "m (leading order in 1/ln kappa)",
        )
    )
    onset, predicted = hydro_onset_beta()
    checks.append(
        Check("hydro: extruded rod onset vs corrected linear theory", onset, predicted, 0.05, "-")
    )
    return checks


# ---- finite_re: the cylinder drag curve ---------------------------------------------------

# Experimental C_D of circular cylinders in cross-flow, as (log10 Re, log10 C_D): the points
# within +-0.25 to 0.4 decades of each Re of the compilation figure "drag coefficient of a
# circular cylinder" in Panton, Incompressible Flow (Wiley), as digitised by P. Sharpe
# (github.com/peterdsharpe/CylinderDragFits, Fig_from_incompressible_flow_wiley.csv). The
# figure combines several experiments (Tritton 1959, J. Fluid Mech. 6:547, for 0.5 < Re < 100,
# and Wieselsberger 1921 above); the points scatter by about +-15% between experiments.
CYLINDER_DRAG_DATA = {
    0.1: [
        (-0.93402, 1.69914),
        (-0.92636, 1.73283),
        (-0.8369, 1.62958),
        (-0.75482, 1.55104),
        (-0.73572, 1.6229),
        (-0.67249, 1.52189),
        (-0.6353, 1.46353),
    ],
    1.0: [
        (-0.24628, 1.29084),
        (-0.20852, 1.34476),
        (-0.20199, 1.15165),
        (-0.17948, 1.15615),
        (-0.14217, 1.12024),
        (-0.1346, 1.13372),
        (-0.11213, 1.12924),
        (-0.10477, 1.1023),
        (-0.08219, 1.12028),
        (-0.05985, 1.08885),
        (-0.02952, 1.15623),
        (0.01488, 1.03949),
        (0.05228, 1.02155),
        (0.06002, 1.07095),
        (0.08961, 0.99013),
        (0.10447, 0.96319),
        (0.11953, 0.97668),
        (0.14941, 0.95424),
        (0.18683, 0.94079),
        (0.21676, 0.92733),
        (0.23918, 0.91387),
    ],
    10.0: [
        (0.75538, 0.68512),
        (0.8, 0.61329),
        (0.81498, 0.6088),
        (0.85983, 0.58188),
        (0.86717, 0.55045),
        (0.89714, 0.54598),
        (0.92713, 0.54599),
        (0.94951, 0.52355),
        (0.9571, 0.54152),
        (0.98671, 0.46519),
        (0.98695, 0.51459),
        (1.02435, 0.49665),
        (1.04675, 0.47869),
        (1.05414, 0.45624),
        (1.07652, 0.4338),
        (1.09161, 0.45177),
        (1.10644, 0.42034),
        (1.13643, 0.42036),
        (1.14384, 0.4024),
        (1.16634, 0.40241),
        (1.17388, 0.4114),
        (1.18881, 0.39794),
    ],
    100.0: [
        (1.76491, 0.15574),
        (1.83976, 0.12884),
        (1.98208, 0.10197),
        (2.01986, 0.16038),
        (2.06453, 0.09753),
        (2.11726, 0.14696),
        (2.19958, 0.11557),
    ],
}


def cylinder_drag_data(re: float) -> float:
    """The experimental C_D at re (0.1, 1, 10 or 100) from a local log-log straight line
    through the points of its window of :data:`CYLINDER_DRAG_DATA`."""
    pts = np.array(CYLINDER_DRAG_DATA[re])
    slope, intercept = np.polyfit(pts[:, 0], pts[:, 1], 1)
    return 10.0 ** (slope * math.log10(re) + intercept)


# ---- hydrodynamics: rigid slender bodies in Stokes flow ------------------------------------


def hydro_rod(
    aspect: float,
    n_segments: int,
    diameter_mm: float = 0.2,
    cutoff_radii: float = 3.0,
    drag_model: str = "cox",
    kernel: str = "slender_body",
) -> Simulation:
    """A free straight rod of length ``aspect`` x its diameter along z, with the
    hydrodynamics effect (Stokes with drag.model = 'cox'; its nonlocal ``kernel``), bath
    viscosity 1e-3 Pa s."""
    length_mm = aspect * diameter_mm
    sim = Simulation(
        "paper_simulation",
        {
            "effects": ["elasticity", "drag", "hydrodynamics"],
            "needle.inner_diameter_mm": diameter_mm,
            "needle.imperfection_um": 0.0,
            "initial.length_mm": length_mm,
            "flow.q_outer_ml_min": 0.0,
            "numerics.node_spacing_mm": length_mm / n_segments,
            "hydrodynamics.cutoff_radii": cutoff_radii,
            "hydrodynamics.coupling": "implicit",  # (rigid_body_drag evaluates its kernel)
            "bath.viscosity_pa_s": 1e-3,
            "drag.model": drag_model,
            "hydrodynamics.kernel": kernel,
        },
    )
    sim.release()
    return sim


def rigid_body_drag(sim: Simulation, velocity: tuple[float, float, float]) -> np.ndarray:
    """Total drag (N) of the bath on the filament of ``sim`` moving rigidly at ``velocity``
    (m/s), with the scene's drag law and hydrodynamics: the resistance problem solved with the
    effect's own kernel. Its force is F + F_drag(v; F) with F the other effects' force (the
    sources of the nonlocal flow), affine in F; the applied force that holds the filament at
    v solves F + F_drag = 0 (a dense solve of 3N unknowns, then chord iterations for the
    finite_re law, which is not affine), and the drag is minus its total."""
    from bathprint.core.effects import hydrodynamics

    if sim.clamped:
        raise ValueError("rigid_body_drag needs a free filament (sim.release())")
    n = sim.n_nodes
    nd = 3 * n
    vel = np.tile(np.asarray(velocity, dtype=float), sim.capacity)
    model, rod, stage, out = sim.kernel_inputs(0.0, 0.0, 0.0, False, vel=vel)
    if model.params[0]["hydro_coupling"] != 0:
        raise ValueError("rigid_body_drag evaluates the implicit coupling's kernel")

    def total(applied: np.ndarray) -> np.ndarray:
        out.force[:] = 0.0
        out.force[:nd] = applied
        hydrodynamics.accumulate(model, rod, stage, out)
        return out.force[:nd].copy()

    base = total(np.zeros(nd))
    matrix = np.empty((nd, nd))
    unit = np.zeros(nd)
    # columns from forces small against the drag (the finite_re law is not affine), then
    # chord iterations on the nonlinear residual (one for a linear law)
    scale = 1e-3 * float(np.abs(base).max())
    for k in range(nd):
        unit[k] = scale
        matrix[:, k] = (total(unit) - base) / scale
        unit[k] = 0.0
    lu = scipy.linalg.lu_factor(matrix)
    applied = scipy.linalg.lu_solve(lu, -base)
    for _ in range(30):
        residual = total(applied)
        if np.abs(residual).max() <= 1e-11 * np.abs(base).max():
            break
        applied -= scipy.linalg.lu_solve(lu, residual)
    return -applied.reshape(n, 3).sum(axis=0)


def cylinder_drag_tirado(aspect: float, mu: float, length: float) -> tuple[float, float]:
    """Stokes drag per unit speed (N s/m) of a circular cylinder of length L = p d moving
    along and across its axis: 2 pi mu L / (ln p + g_par), 4 pi mu L / (ln p + g_perp), with
    the end corrections of Tirado & Garcia de la Torre (1979, J. Chem. Phys. 71, 2581, Table I)
    as fitted by Tirado, Martinez & Garcia de la Torre (1984, J. Chem. Phys. 81, 2047):
    g_par = -0.207 + 0.980/p - 0.133/p^2, g_perp = 0.839 + 0.185/p + 0.233/p^2 (their
    p -> inf limits, -0.20 and 0.84, are the long-cylinder values of the 1979 table)."""
    g_par = -0.207 + 0.980 / aspect - 0.133 / aspect**2
    g_perp = 0.839 + 0.185 / aspect + 0.233 / aspect**2
    lp = math.log(aspect)
    return 2 * math.pi * mu * length / (lp + g_par), 4 * math.pi * mu * length / (lp + g_perp)


def spheroid_drag_exact(a: float, b: float, mu: float) -> tuple[float, float]:
    """Exact Stokes drag per unit speed (N s/m) of a prolate spheroid, semi-axes a > b, along
    and across its axis (Oberbeck 1876; in the form of Chwang & Wu 1975, J. Fluid Mech. 67,
    787, e the eccentricity, L_e = ln((1+e)/(1-e))): 16 pi mu a e^3 / ((1 + e^2) L_e - 2e),
    32 pi mu a e^3 / ((3 e^2 - 1) L_e + 2e)."""
    e = math.sqrt(1.0 - (b / a) ** 2)
    le = math.log((1.0 + e) / (1.0 - e))
    return (
        16.0 * math.pi * mu * a * e**3 / ((1.0 + e * e) * le - 2.0 * e),
        32.0 * math.pi * mu * a * e**3 / ((3.0 * e * e - 1.0) * le + 2.0 * e),
    )


def spheroid_rod(aspect: float, n_segments: int, diameter_mm: float = 0.2) -> Simulation:
    """:func:`hydro_rod` with the radius of a prolate spheroid (semi-axes L/2 and d/2) at each
    segment's middle."""
    sim = hydro_rod(aspect, n_segments, diameter_mm)
    from bathprint.core.layout import MAT_RADIUS

    x = sim.centerline()
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    mid = 0.5 * (s[1:] + s[:-1]) / s[-1]
    r0 = 0.5e-3 * diameter_mm
    sim.seg_mat[: len(mid), MAT_RADIUS] = r0 * np.sqrt(np.clip(1 - (2 * mid - 1) ** 2, 0, None))
    return sim


def torus_drag_johnson_wu(b: float, eps: float, mu: float) -> tuple[float, float]:
    """Slender-body drag per unit speed (N s/m) of a torus of centreline radius b and
    cross-section radius eps b (Johnson & Wu 1979, J. Fluid Mech. 95, 263; L = ln(8/eps)):
    broadside (along its axis) 8 pi^2 mu b / (L + 1/2), edgewise (in its plane)
    2 pi^2 mu b (3L - 17/2) / ((L - 1/2)(L - 2) - 2)."""
    lg = math.log(8.0 / eps)
    return (
        8.0 * math.pi**2 * mu * b / (lg + 0.5),
        2.0 * math.pi**2 * mu * b * (3.0 * lg - 8.5) / ((lg - 0.5) * (lg - 2.0) - 2.0),
    )


def ring_drag(
    eps: float, n_segments: int = 128, cutoff_radii: float = 3.0, mu: float = 1e-3
) -> tuple[float, float]:
    """(broadside, edgewise) drag per unit speed (N s/m) of a rigid ring (centreline radius
    b = 1 mm, cross-section eps b) with the hydrodynamics effect's kernels on a closed loop:
    the same window law (edge-based lumping, Lighthill's window with a_- = a_+ = a) and
    Stokeslet segments (periodic arclength), the resistance problem solved densely."""
    from bathprint.core.effects._stokeslet import nonlocal_flow, window_coefficients

    b = 1e-3
    r = eps * b
    a_cut = cutoff_radii * r
    n = n_segments
    th = 2.0 * np.pi * np.arange(n) / n
    x = np.stack([b * np.cos(th), b * np.sin(th), np.zeros(n)], 1)
    pos = x.ravel().copy()
    seg = np.roll(x, -1, axis=0) - x
    lengths = np.linalg.norm(seg, axis=1)
    tang = seg / lengths[:, None]
    node_s = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    period = float(lengths.sum())
    xp, xn = window_coefficients(a_cut, a_cut, r, mu, 0.0, 0.0)
    # R_i = sum over its two segments of (l/2) Xi(t_j); W_i = (l_{i-1} + l_i)/2
    resist = np.zeros((n, 3, 3))
    weight = np.zeros(n)
    for j in range(n):
        xi = xn * np.eye(3) + (xp - xn) * np.outer(tang[j], tang[j])
        for i in (j, (j + 1) % n):
            resist[i] += 0.5 * lengths[j] * xi
            weight[i] += 0.5 * lengths[j]
    # M: node velocities per unit force per length on each segment (mean of its two nodes')
    mob = np.zeros((3 * n, 3 * n))
    screen = np.full(n, np.inf)
    unit = np.zeros(3 * n)
    col = np.zeros(3 * n)
    for k in range(3 * n):
        unit[k] = 1.0
        nonlocal_flow(pos, node_s, n, pos, node_s, n, unit, screen, mu, 0.0, a_cut, period, col)
        mob[:, k] = col
        unit[k] = 0.0
    to_seg = np.zeros((3 * n, 3 * n))
    for j in range(n):
        for c in range(3):
            to_seg[3 * j + c, 3 * j + c] += 0.5
            to_seg[3 * j + c, 3 * ((j + 1) % n) + c] += 0.5
    r_big = np.zeros((3 * n, 3 * n))
    for i in range(n):
        r_big[3 * i : 3 * i + 3, 3 * i : 3 * i + 3] = resist[i]
    w_inv = np.repeat(1.0 / weight, 3)
    # applied F: F = R (U - M P W^-1 F), the drag -F
    system = np.eye(3 * n) + r_big @ mob @ to_seg @ np.diag(w_inv)
    out = []
    for axis in (2, 0):
        u = np.zeros(3 * n)
        u[axis::3] = 1.0
        applied = np.linalg.solve(system, r_big @ u)
        out.append(float(applied[axis::3].sum()))
    return out[0], out[1]


def xu_nadim_shape(xi: np.ndarray) -> np.ndarray:
    """Xu & Nadim (1994, Phys. Fluids 6, 2889): the steady shape of a weakly flexible
    filament sedimenting broadside, to leading order in 1/ln(kappa): the lag behind its
    middle, in units of D = 2 pi mu U l^4 / (E I ln^2 kappa) (l the half-length, kappa = l/r,
    U the speed), at xi = s/l in [-1, 1]:
    Y = -(1/24) [(1+xi)^4 ln(1+xi) + (1-xi)^4 ln(1-xi) - (13/6 + 2 ln 2) xi^4
    - (1 + 12 ln 2) xi^2]. It solves E I y'''' = q with free ends, q the departure of the
    slender-body force density from its mean, (2 pi mu U / ln^2 kappa) [ln(1 - xi^2) + 2 -
    2 ln 2]: the ends, which push on less disturbed fluid, lag behind (a U shape)."""
    xi = np.asarray(xi, dtype=float)
    a, b = 1.0 + xi, 1.0 - xi
    with np.errstate(divide="ignore", invalid="ignore"):
        la = np.where(a > 0, a**4 * np.log(np.where(a > 0, a, 1.0)), 0.0)
        lb = np.where(b > 0, b**4 * np.log(np.where(b > 0, b, 1.0)), 0.0)
    c4 = 13.0 / 6.0 + 2.0 * math.log(2.0)
    c2 = 1.0 + 12.0 * math.log(2.0)
    return -(la + lb - c4 * xi**4 - c2 * xi**2) / 24.0


def sedimenting_filament(
    aspect: float = 50.0,
    deflection_scale: float = 0.2,
    n_segments: int = 40,
    coupling: str = "implicit",
    duration_relaxations: float = 6.0,
    tolerance: float = 1e-6,
    hydrodynamics: bool = True,
    kernel: str = "slender_body",
) -> dict[str, Any]:
    """A free filament of length 2l = 20 mm and aspect l/r = ``aspect`` sedimenting broadside
    under its net weight, with hydrodynamics (Stokes): run for ``duration_relaxations``
    relaxation times of its first bending mode, then its speed U and its shape (the lag
    behind the middle, against xi = s/l) with Xu & Nadim's scale D = 2 pi mu U l^4 /
    (E I ln^2 kappa). The modulus is set so that D = ``deflection_scale`` x l (small: a
    weakly flexible filament). Returns speed, D, xi, lag (m), and the rigid-rod speed of
    Tirado & Garcia de la Torre's cylinder drag for comparison. ``hydrodynamics=False``: the
    same with local drag only (Cox's mu_s); ``kernel``: the nonlocal flow's."""
    half = 10e-3
    r = half / aspect
    mu = 1e-3
    drho = 3.0
    w = drho * 9.81 * math.pi * r * r  # net weight per length (N/m)
    lk = math.log(aspect)
    speed_est = w * lk / (4.0 * math.pi * mu)
    bend = 2.0 * math.pi * mu * speed_est * half**3 / (lk * lk * deflection_scale)
    youngs = bend / (math.pi * r**4 / 4.0)
    zeta = 4.0 * math.pi * mu / lk
    relax = zeta * (2.0 * half) ** 4 / (4.730**4 * bend)
    duration = duration_relaxations * relax
    sim = Simulation(
        "paper_simulation",
        {
            "effects": ["elasticity", "drag", "gravity"]
            + (["hydrodynamics"] if hydrodynamics else []),
            "needle.inner_diameter_mm": 2e3 * r,
            "needle.direction": [1.0, 0.0, 0.0],
            "needle.position_mm": [-10.0, 0.0, -50.0],
            "needle.imperfection_um": 0.0,
            "needle.release_s": 1e-9,
            "initial.length_mm": 2e3 * half,
            "flow.q_outer_ml_min": 0.0,
            "material.youngs_modulus_pa": youngs,
            "material.density_kg_m3": 1000.0 + drho,
            "bath.density_kg_m3": 1000.0,
            "bath.depth_mm": 1e4,
            "bath.viscosity_pa_s": mu,
            "numerics.node_spacing_mm": 2e3 * half / n_segments,
            "numerics.tolerance": tolerance,
            "numerics.max_step_s": relax / 5.0,
            "hydrodynamics.coupling": coupling,
            "hydrodynamics.kernel": kernel,
            "duration_s": duration,
        },
    )
    sim.advance(duration - 0.05 * relax)
    z0 = sim.centerline()[:, 2].mean()
    t0 = sim.t
    sim.advance(duration)
    c = sim.centerline()
    speed = (z0 - c[:, 2].mean()) / (sim.t - t0)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))])
    xi = s / s[-1] * 2.0 - 1.0
    z_mid = float(np.interp(0.0, xi, c[:, 2]))
    d_scale = 2.0 * math.pi * mu * speed * half**4 / (bend * lk * lk)
    _, drag_perp = cylinder_drag_tirado(aspect, mu, 2.0 * half)
    return {
        "speed": float(speed),
        "rigid_speed_tirado": w * 2.0 * half / drag_perp,
        "D": float(d_scale),
        "xi": xi,
        "lag": c[:, 2] - z_mid,
        "sim": sim,
    }


def hydro_fixed_step_errors(
    step_factors: tuple[float, ...] = (1.0, 0.5, 0.25),
    n_segments: int = 30,
    integrator: str = "implicit",
) -> dict[str, list[float]]:
    """Error at t = T of the relaxation of a bent free filament with hydrodynamics at fixed
    steps h = factor x T / 20, for each coupling: max node distance (m) from a reference
    (implicit coupling, adaptive, tolerance 1e-9). A stiff filament (E = 50 kPa, d = 0.4 mm,
    10 mm) bent in the first clamped-free mode shape by 0.5 mm, released at once; T = a
    tenth of the relaxation time of its first free-free mode."""
    length = 10e-3
    r = 0.2e-3
    bend = 5e4 * math.pi * r**4 / 4.0
    zeta = 4.0 * math.pi * 1e-3 / math.log(0.5 * length / r)
    t_end = 0.1 * zeta * length**4 / (4.730**4 * bend)
    base = {
        "effects": ["elasticity", "drag", "hydrodynamics"],
        "needle.inner_diameter_mm": 0.4,
        "needle.direction": [1.0, 0.0, 0.0],
        "needle.imperfection_um": 0.0,
        "needle.release_s": 1e-12,
        "initial.length_mm": 10.0,
        "initial.perturbation_mm": 0.5,
        "flow.q_outer_ml_min": 0.0,
        "material.youngs_modulus_pa": 5e4,
        "numerics.node_spacing_mm": 10.0 / n_segments,
        "numerics.integrator": integrator,
        "numerics.max_step_s": t_end / 20.0,
        "duration_s": t_end,
    }

    def run(extra: dict[str, Any]) -> np.ndarray:
        sim = Simulation("paper_simulation", {**base, **extra})
        sim.advance(t_end)
        return sim.centerline()

    ref = run({"numerics.tolerance": 1e-9, "hydrodynamics.coupling": "implicit"})
    out: dict[str, list[float]] = {}
    for coupling in ("lagged", "implicit"):
        out[coupling] = []
        for f in step_factors:
            x = run(
                {
                    "numerics.time_step_s": f * t_end / 20.0,
                    "numerics.tolerance": 1e-9,  # (Newton's tolerance: well below the error)
                    "hydrodynamics.coupling": coupling,
                }
            )
            out[coupling].append(float(np.max(np.linalg.norm(x - ref, axis=1))))
    return out


def mobility_operator(sim: Simulation, assemble: bool = True) -> np.ndarray:
    """I + R M_nl W^-1 (dense, 3 n_free square) at ``sim``'s state, with the implicit
    nonlocal flow: a Newton-matrix assembly linearises it (``assemble``; else the last
    linearisation, as a solve in progress uses it), and its matrix-free product with J_other
    set to the identity gives the columns; J_other is put back. Its eigenvalues have positive
    real parts when the filament's mobility is positive definite."""
    from bathprint.core import layout as L
    from bathprint.core.effects import hydrodynamics

    if assemble:
        sim.forces(1.0, 1.0, 1.0, True)
    hyd = sim.ws.hydro
    nd = 3 * int(hyd.memory[0]["lin_free"])
    saved = hyd.band_other.copy()
    hyd.band_other[:] = 0.0
    hyd.band_other[:nd, L.KL] = 1.0
    op = np.eye(nd)
    unit, col = np.zeros(nd), np.zeros(nd)
    try:
        for k in range(nd):
            unit[k], col[:] = 1.0, 0.0
            hydrodynamics.apply_nonlocal(sim.ws, nd, unit, col)
            op[:, k] += col
            unit[k] = 0.0
    finally:
        hyd.band_other[:] = saved
    return op


def filament_mobility(sim: Simulation) -> np.ndarray:
    """The filament's total mobility R^-1 + M_nl W^-1 (m/(N s), dense, 3 n_free square) at
    ``sim``'s state: :func:`mobility_operator` with each node's linearised resistance R_i
    divided out. Symmetric and positive definite for a physical (dissipative) flow."""
    op = mobility_operator(sim)
    resist = scipy.linalg.block_diag(*sim.ws.hydro.resist[: op.shape[0] // 3])
    return np.linalg.solve(resist, op)


def pressed_turns(pitch_mm: float, n: int = 60) -> np.ndarray:
    """Three turns of radius 3 mm at ``pitch_mm`` (m, (n, 3)): for a filament of radius
    0.5 mm, 0.85 presses the turns onto each other and 0 puts them through each other."""
    phi = np.linspace(0.0, 2 * math.pi * 3, n)
    return np.column_stack(
        [3e-3 * np.cos(phi), 3e-3 * np.sin(phi), pitch_mm * 1e-3 * phi / (2 * math.pi)]
    )


def turns_mobility(
    pitch_mm: float, kernel: str, drag_model: str = "cox", speed_m_s: float = 0.0
) -> dict[str, float]:
    """On :func:`pressed_turns` (r = 0.5 mm) with the scene's ``drag_model`` and the implicit
    flow of the nonlocal ``kernel``, the turns rotating about their axis at ``speed_m_s``:
    the smallest real part of eig(I + R M W^-1), the filament mobility's symmetric part's
    smallest over largest eigenvalue, its asymmetry |M - M^T| / |M| and the smallest gate
    (the RPY kernel's, else 1)."""
    points = pressed_turns(pitch_mm)
    sim = Simulation.from_points(
        points,
        "paper_simulation",
        {
            "effects": ["elasticity", "drag", "hydrodynamics"],
            "hydrodynamics.coupling": "implicit",
            "needle.inner_diameter_mm": 1.0,
            "drag.model": drag_model,
            "hydrodynamics.kernel": kernel,
        },
    )
    phi = np.arctan2(points[:, 1], points[:, 0])
    spin = np.column_stack([-np.sin(phi), np.cos(phi), np.zeros(len(phi))]) * speed_m_s
    sim.vel[: spin.size] = spin.ravel()
    op = mobility_operator(sim)
    mob = filament_mobility(sim)
    sym = np.linalg.eigvalsh(0.5 * (mob + mob.T))
    nf = op.shape[0] // 3
    return {
        "eig_real_min": float(np.linalg.eigvals(op).real.min()),
        "mobility_min_over_max": float(sym.min() / sym.max()),
        "asymmetry": float(np.linalg.norm(mob - mob.T) / np.linalg.norm(mob)),
        "gate_min": float(sim.ws.hydro.gate[:nf].min()) if kernel == "rpy" else 1.0,
    }

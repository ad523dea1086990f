"""Hard cases that must stay numerically stable (quick versions; long ones in
experiments/hard_cases/hard_cases.py).

Each case runs to completion with no NaN, a bounded stretch error |l/l0 - 1|, no collapse of
the time step, and mass balance (printed volume = initial + integral of Q). Failure modes
that are real simulator bugs are xfail(strict=True) with the reason, so they turn into
regression tests once fixed.
"""

from __future__ import annotations

import numpy as np
import pytest

from bathprint import Simulation, SimulationError
from bathprint.core import layout as L
from bathprint.core.run import integrated_flow_volume

BASE = ["elasticity", "drag", "gravity"]
THIN = {"needle.inner_diameter_mm": 0.21, "flow.q_outer_ml_min": 20.0}
# numerics.max_strain (default 0.25): adaptive steps ending with a larger segment strain
# are retried shorter (a long implicit step can crush a rod instead of letting it buckle).
# Filaments that really strain more (0.9 gas slugs) need it raised; the run then completes.
STRAIN_BOUND = "segments strain past numerics.max_strain (0.25), so every step is retried"
N2_SWITCH = [[0, 0.5, 0], [0.3, 0.5, 0], [0.3001, 0.5, 4.5], [0.6, 0.5, 4.5], [0.6001, 0.5, 0]]


def stretch_error(sim: Simulation) -> float:
    seg = np.linalg.norm(np.diff(sim.centerline(), axis=0), axis=1)
    return float(np.max(np.abs(seg / sim.rest_lengths() - 1.0)))


def run_and_check(
    scene: str,
    overrides: dict,
    t_end: float,
    *,
    max_stretch: float = 0.1,
    max_steps_per_s: float = 2e5,
    max_steps: int = 10**7,
) -> Simulation:
    """Run to t_end and check completion, finiteness, stretch, step rate and mass balance."""
    sim = Simulation(scene, overrides)
    sim.advance(t_end, max_steps=max_steps)
    assert sim.t == pytest.approx(t_end, rel=1e-9, abs=1e-12), "did not reach t_end"
    c = sim.centerline()
    assert np.all(np.isfinite(c)) and np.all(np.isfinite(sim.velocities()))
    assert stretch_error(sim) < max_stretch
    steps = sim.counts()["steps"]
    assert steps / t_end < max_steps_per_s, f"time step collapsed: {steps} steps in {t_end} s"
    expected = sim.initial_volume + integrated_flow_volume(sim, sim.t)
    assert sim.printed_volume() == pytest.approx(expected, rel=1e-9)
    return sim


# ------------------------------------------------------------------ chaotic crumpling
def test_chaotic_crumpling_22G():
    sim = run_and_check("chaotic_crumpling_22G", {}, 0.03, max_stretch=0.1, max_steps_per_s=1e5)
    assert sim.n_nodes > 200


@pytest.mark.parametrize(
    "extra",
    [
        {},
        {"numerics.accuracy": "draft"},
        {"numerics.node_spacing_mm": 0.5},
        pytest.param(
            {"needle.imperfection_um": 0.0},
            marks=pytest.mark.xfail(
                strict=True,
                raises=SimulationError,
                reason="without the needle imperfection nothing seeds the buckling of the "
                "perfectly straight 9.6 m/s jet: it is compressed straight until segments pass "
                "numerics.max_strain at t = 3.4e-4 s (reported as such); resolving the "
                "buckling rate (numerics.buckling_steps) cannot help without a seed",
            ),
        ),
        {"numerics.min_step_s": 1e-12},
        {"numerics.integrator": "implicit_euler"},
        {"numerics.tolerance": 0.1},
    ],
    ids=["default", "draft", "spacing_0.5", "no_imperfection", "min_step_1e-12", "euler", "tol"],
)
def test_thinnest_needle_highest_flow(extra):
    # v = 9.6 m/s: half a node spacing of extrusion per step (numerics.max_inlet_growth)
    # alone asks for ~2e5 steps/s; a collapse would be orders of magnitude more.
    # The largest strain at t_end is a snapshot of a buckling jet: at 0.5 mm spacing it
    # ranges over 0.15-0.20 as the tolerance goes from 7e-4 to 1.3e-3 (measured with the
    # Newton of before and after the Jacobian reuse across steps alike; 0.201 at 1.2e-3
    # before), so that case is held to 0.22, the others to 0.2. (In draft, the snapshot
    # ranges over 0.14-0.20 as numerics.krylov_tolerance goes from 0.01 to 0.2.)
    coarse = extra.get("numerics.node_spacing_mm", 0.0) >= 0.5
    run_and_check(
        "chaotic_crumpling_22G",
        {**THIN, **extra},
        0.002,
        max_stretch=0.22 if coarse else 0.2,
        max_steps_per_s=1e6,
    )


def test_chaotic_crumpling_22G_with_the_solution_viscosity():
    # 20 ml/min through 22G (2.5 m/s) with the viscous stress, at the default and at a 20x
    # larger buckling seed (whose kinks a viscous rod holds for eta_e / E = 2.2 ms)
    for seed_um in (1.0, 20.0):
        over = {"effects": [*BASE, "viscosity"], "needle.imperfection_um": seed_um}
        sim = run_and_check("chaotic_crumpling_22G", over, 0.03, max_stretch=0.1)
        assert sim.effect_calls()["viscosity"] > 0


@pytest.mark.xfail(
    strict=True,
    reason="the solution's viscous stress damps the short buckling modes of the 9.6 m/s jet "
    "(at a 1 mm wavelength eta_e I k^4 is about 400 times the drag 2 mu_s), which is "
    "compressed instead of buckling: next to the needle its strain reaches -0.24 at "
    "2 ms (bound 0.2; in draft numerics.max_strain stops it at 1.8 ms). A liquid jet would "
    "thicken; a small-strain rod cannot",
)
def test_thinnest_needle_highest_flow_with_the_solution_viscosity():
    run_and_check(
        "chaotic_crumpling_22G",
        {**THIN, "effects": [*BASE, "viscosity"]},
        0.002,
        max_stretch=0.2,
        max_steps_per_s=1e6,
    )


def test_thinnest_needle_highest_flow_fixed_step():
    """The same case at a fixed 1e-7 s step runs: the dynamics are stable."""
    run_and_check(
        "chaotic_crumpling_22G",
        {**THIN, "numerics.time_step_s": 1e-7},
        0.0005,
        max_stretch=0.2,
        max_steps_per_s=1.01e7,
    )


def test_thinnest_needle_flow_ramped_up():
    """Ramping Q_o from 0 (to 20 ml/min at 50 ms) gets the thin needle going adaptively."""
    run_and_check(
        "chaotic_crumpling_22G",
        {**THIN, "flow.schedule": [[0, 0, 0], [0.05, 20, 0]]},
        0.005,
        max_stretch=0.1,
    )


# ------------------------------------------------------------------ modulus ratio >= 100
def test_gelation_modulus_ratio_100():
    overrides = {
        "effects": [*BASE, "gelation"],
        "gelation.initial_modulus_pa": 300.0,
        "gelation.final_modulus_pa": 300000.0,
        "gelation.rate_1_s": 1.0,
    }
    sim = run_and_check("drag_coiling_22G", overrides, 1.5, max_stretch=0.05)
    e = sim.material()[:, L.MAT_YOUNGS_MODULUS]
    assert e.max() / e.min() >= 100.0  # set far end vs fresh gel at the needle


# ------------------------------------------------------------------ gas inclusions
def test_inclusions_moderate_fraction():
    """phi = 0.5 nitrogen switched on and off abruptly runs."""
    sched = [[0, 0.5, 0], [0.3, 0.5, 0], [0.3001, 0.5, 0.5], [0.6, 0.5, 0.5], [0.6001, 0.5, 0]]
    overrides = {
        "effects": [*BASE, "inclusions"],
        "inclusions.fluid": "nitrogen",
        "flow.schedule": sched,
    }
    sim = run_and_check("drag_coiling_22G", overrides, 0.65, max_stretch=0.05)
    inner = integrated_flow_volume(sim, sim.t, inner_only=True)
    assert sim.inner_volume() == pytest.approx(inner, rel=1e-6)


@pytest.mark.xfail(
    strict=True,
    raises=SimulationError,
    reason="inner fraction 0.9 (Q_o 0.5, Q_i 4.5 ml/min; slug stretching factor 0.1): just "
    "after Q_i switches on (t = 0.30134 s, node 40) " + STRAIN_BOUND + " (reported as such)",
)
@pytest.mark.parametrize("fluid", ["nitrogen", "silicone_oil"])
def test_inclusions_fraction_0_9(fluid):
    overrides = {
        "effects": [*BASE, "inclusions"],
        "inclusions.fluid": fluid,
        "flow.schedule": N2_SWITCH,
    }
    run_and_check("drag_coiling_22G", overrides, 0.35, max_stretch=0.1)


@pytest.mark.parametrize("fluid", ["nitrogen", "silicone_oil"])
def test_inclusions_fraction_0_9_with_a_raised_strain_bound(fluid):
    overrides = {
        "effects": [*BASE, "inclusions"],
        "inclusions.fluid": fluid,
        "flow.schedule": N2_SWITCH,
        "numerics.max_strain": 1.0,
    }
    run_and_check("drag_coiling_22G", overrides, 0.35, max_stretch=0.5)


def test_flow_jump_without_inclusions():
    """The total-flow jump of the phi = 0.9 case (0.5 -> 5 ml/min), pure gel: runs."""
    sched = [[0, 0.5, 0], [0.3, 0.5, 0], [0.3001, 5, 0], [0.6, 5, 0], [0.6001, 0.5, 0]]
    run_and_check("drag_coiling_22G", {"flow.schedule": sched}, 0.4, max_stretch=0.05)


# ------------------------------------------------------------------ floor
def test_rope_coiling_floor_pile_up():
    sim = run_and_check("rope_coiling_18G", {}, 1.5, max_stretch=0.05)
    floor_z = float(sim.model.p.floor_z)
    z = sim.centerline()[:, 2]
    r = float(sim.material()[:, L.MAT_RADIUS].max())
    assert z.min() > floor_z - 2 * r  # penalty contact: no tunnelling through the floor
    assert np.sum(z < floor_z + 4 * r) >= 3  # the filament reached the floor and lies on it


@pytest.mark.parametrize("imperfection_um", [1.0, 10.0])
def test_rope_coiling_at_a_tight_tolerance(imperfection_um: float) -> None:
    """Regression (found with freezing on the floor): at tolerance 1e-4 the straight rod
    landed end-on with ~12 ms steps, too large for a 1 um imperfection to grow into buckling
    (an L-stable stage damps a mode growing with h sigma >> 1); it was compressed straight
    (all segments -24%) and stopped at the strain bound at t = 0.797 s. The step bound of
    ``numerics.buckling_steps`` (one step per e-folding of the fastest buckling mode) fixed
    it; with it off the failure returns (checked below)."""
    run_and_check(
        "rope_coiling_18G",
        {"numerics.tolerance": 1e-4, "needle.imperfection_um": imperfection_um},
        1.0,
        max_stretch=0.05,
    )


def test_without_the_buckling_bound_steps_outrun_the_buckling_mode() -> None:
    """At tolerance 1e-4 the falling rod is compressed by its drag from 0.5 s on. With the
    buckling step bound every accepted step h satisfies h sigma <= 1 (sigma: growth rate of
    the fastest buckling mode at the step's start) and the rod buckles (lateral excursion
    2.7 mm at 0.7 s). Without it the adaptive steps reach h sigma of several hundred, where
    an L-stable stage damps the mode instead of letting it grow: that is what held the rod
    straight. Whether it then stays straight (~4e-8 m at 0.7 s with the default Newton) or
    buckles late (1e-3 m with full Newton) depends on how exactly the stages are solved,
    i.e. on chance, so the test asserts the step sizes, not that outcome."""
    from bathprint.core.integrators import buckling_time
    from bathprint.core.records import Rod

    def lateral(sim: Simulation) -> float:
        c = sim.centerline()
        return float(np.max(np.hypot(c[:, 0] - c[-1, 0], c[:, 1] - c[-1, 1])))

    h_sigma, out = {}, {}
    for steps in (1.0, 0.0):
        sim = Simulation(
            "rope_coiling_18G",
            {
                "numerics.tolerance": 1e-4,
                "numerics.buckling_steps": steps,
            },
        )
        worst = 0.0
        while sim.t < 0.7 - 1e-9:  # one accepted step per call: same steps as advance(0.7)
            f = sim.n_frozen
            x = sim.pos[3 * f :]
            rod = Rod(x, x, x, sim.n_nodes - f, sim.node_s[f:], sim.seg_rest[f:], sim.seg_mat[f:])
            e_fold = buckling_time(rod, sim.model.params[0])
            t = sim.t
            sim.advance(0.7, max_steps=1)
            assert sim.t > t  # a step was taken
            worst = max(worst, (sim.t - t) / e_fold)
        h_sigma[steps], out[steps] = worst, lateral(sim)
    assert h_sigma[1.0] <= 1.001  # the bound (the last step may stretch 0.1 % to t_end)
    assert out[1.0] > 1e-3  # m: buckled
    assert h_sigma[0.0] > 10.0  # steps far beyond the mode's e-folding time: damped


# ------------------------------------------------------------------ inertia on and off
@pytest.mark.parametrize("scene", ["paper_simulation", "drag_coiling_22G"])
def test_without_inertia(scene):
    run_and_check(scene, {"effects": BASE}, 0.5, max_stretch=0.05)


def test_inertia_drag_coiling():
    run_and_check("drag_coiling_22G", {"effects": [*BASE, "inertia"]}, 0.5, max_stretch=0.05)


def test_inertia_paper_simulation():
    run_and_check("paper_simulation", {"effects": [*BASE, "inertia"]}, 0.2, max_stretch=0.1)


@pytest.mark.parametrize(
    "extra", [{"numerics.integrator": "implicit_euler"}, {"numerics.accuracy": "draft"}]
)
def test_inertia_paper_simulation_workarounds(extra):
    overrides = {"effects": [*BASE, "inertia"], **extra}
    run_and_check("paper_simulation", overrides, 0.5, max_stretch=0.05)


# ------------------------------------------------------------------ size, length, motion
def test_ten_thousand_nodes_energy_non_increasing():
    """2.5 m of filament (10^4 nodes), no flow: overdamped, unforced, energy only decreases."""
    overrides = {
        "initial.length_mm": 2500.0,
        "flow.q_outer_ml_min": 0.0,
        "numerics.node_spacing_mm": 0.25,
        "initial.perturbation_mm": 5.0,
        "bath.depth_mm": 5000.0,
    }
    sim = Simulation("drag_coiling_22G", overrides)
    assert sim.n_nodes >= 10**4
    energies = []
    for t in (0.002, 0.005, 0.01):
        sim.advance(t)
        e = sim.energies_now()
        energies.append(e["elasticity"] + e["gravity"])
    assert np.all(np.isfinite(sim.centerline()))
    assert stretch_error(sim) < 0.01
    assert np.all(np.diff(energies) <= 1e-9 * abs(energies[0]) + 1e-15)


def test_cantilever_energy_non_increasing():
    sim = Simulation("cantilever_water")
    energies = []
    for t in np.linspace(0.02, 0.5, 12):
        sim.advance(float(t))
        e = sim.energies_now()
        energies.append(e["elasticity"] + e["gravity"])
    assert np.all(np.diff(energies) <= 1e-12 * abs(energies[0]) + 1e-18)


def test_ten_thousand_steps():
    sim = run_and_check(
        "drag_coiling_22G", {"numerics.time_step_s": 1e-4}, 1.0, max_steps_per_s=1.01e4
    )
    assert sim.counts()["steps"] == 10**4


def test_needle_moving():
    path = [[0, 0, 0, -10, 0, 0, -1], [0.5, 5, 0, -10, 0, 0, -1], [1.0, 5, 5, -10, 0, 0, -1]]
    run_and_check("paper_simulation", {"needle.path": path}, 1.0, max_stretch=0.05)


def test_flow_rates_jump():
    sched = [[0, 0.5, 0], [0.5, 0.5, 0], [0.5001, 5, 0], [1.0, 5, 0], [1.0001, 0.2, 0]]
    run_and_check("paper_simulation", {"flow.schedule": sched}, 1.5, max_stretch=0.05)


def test_state_consistent_after_simulation_error():
    # the step collapse of the straight jet (see the xfail above) as the failing run
    sim = Simulation("chaotic_crumpling_22G", {**THIN, "needle.imperfection_um": 0.0})
    with pytest.raises(SimulationError) as info:
        sim.advance(0.002)
    assert sim.t == pytest.approx(info.value.time_s, rel=1e-6)
    expected = sim.initial_volume + integrated_flow_volume(sim, sim.t)
    assert sim.printed_volume() == pytest.approx(expected, rel=1e-6)


def test_buckling_step_is_the_growth_time_of_the_fastest_mode() -> None:
    """The step bound against the linear theory of a compressed rod in a viscous bath:
    transverse modes w ~ exp(sigma t + i k s) grow at 2 mu_s sigma = P k^2 - B k^4, fastest
    sigma = P^2 / (8 B mu_s); with inertia m sigma^2 + 2 mu_s sigma = P^2 / (4 B)."""
    import math

    from bathprint.core.integrators import buckling_time
    from bathprint.core.records import Rod

    sim = Simulation("rope_coiling_18G", {})
    params = sim.model.params.copy()
    p = params.view(np.recarray)[0]
    p.clamped = False  # a free 3-node rod: both segments count
    seg_rest = np.array([1e-3, 1e-3, 0.0])
    seg_mat = sim.seg_mat[:3].copy()
    strain = -0.02
    pos = np.array([0.0, 0.0, 0.0, 0.0, 0.0, 1e-3 * (1 + strain), 0.0, 0.0, 2e-3 * (1 + strain)])
    r = seg_mat[0, L.MAT_RADIUS]
    e = seg_mat[0, L.MAT_YOUNGS_MODULUS]
    force = e * seg_mat[0, L.MAT_STRETCH_FACTOR] * math.pi * r * r * (-strain)
    bend = e * seg_mat[0, L.MAT_BEND_FACTOR] * math.pi * r**4 / 4
    mu_s = p.mu_s
    sigma = force**2 / (8 * bend * mu_s)

    def bound(x):
        return buckling_time(Rod(x, x, x, 3, seg_rest, seg_rest, seg_mat), params[0])

    assert bound(pos) == pytest.approx(1 / sigma, rel=1e-9)
    p.inertial = True
    m = (
        math.pi
        * r
        * r
        * (seg_mat[0, L.MAT_DENSITY] + p.added_mass_coefficient * p.bath_density_top)
    )
    s_in = bound(pos)
    assert m / s_in**2 + 2 * mu_s / s_in == pytest.approx(force**2 / (4 * bend), rel=1e-9)
    stretched = pos.copy()
    stretched[5], stretched[8] = 1.01e-3, 2.02e-3
    assert bound(stretched) == math.inf

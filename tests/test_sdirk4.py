"""SDIRK4 (``numerics.integrator = "sdirk4"``) and the Newton iteration's economies.

The inertial cantilever released straight rings in its bending modes; on a linear system an
SDIRK step is exactly y -> R y + s, so the error an integrator makes at a fixed step is
predicted mode by mode from its Butcher tableau (:func:`theory.cantilever_release_error`).
The simulated errors must match that prediction, for SDIRK2 and SDIRK4.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint.analysis import validation as V
from bathprint.analysis.theory import cantilever_release_error
from bathprint.core import integrators as I
from bathprint.core import layout as L
from bathprint.core.run import integrated_flow_volume
from bathprint.core.simulation import Simulation

INERTIAL = ["elasticity", "drag", "gravity", "inertia"]
SAMPLES = 2.5e-3 * np.arange(1, 201)  # s, as experiments/pyelastica/cantilever.py
TABLEAUX = {"implicit": I.SDIRK2_A, "sdirk4": I.SDIRK4_A}


def _tip_history(
    integrator: str, h: float, newton: str = "modified"
) -> tuple[np.ndarray, Simulation]:
    sim = Simulation(
        "cantilever_water",
        {
            "effects": INERTIAL,
            "numerics.integrator": integrator,
            "numerics.time_step_s": h,
            "numerics.newton": newton,
        },
    )
    out = np.empty(len(SAMPLES))
    for k, t in enumerate(SAMPLES):
        sim.advance(float(t))
        c = sim.centerline()
        out[k] = c[-1, 2] - c[0, 2]
    return out, sim


@pytest.fixture(scope="module")
def reference() -> np.ndarray:
    # SDIRK4 at 1/16 of the tested step: modal prediction 2.6e-6, against 3.9e-4 tested
    return _tip_history("sdirk4", 2.5e-3 / 16, newton="full")[0]


def _modal_scales(sim: Simulation) -> tuple[float, float, float]:
    """(omega_1 rad/s, drag decay rate 1/s, static tip deflection m) of the scene."""
    m = sim.model
    p = m.p
    area = math.pi * m.radius**2
    rho = float(sim.material()[0, L.MAT_DENSITY])
    rho_bath = float(p.bath_density_top)
    mass = (rho + p.added_mass_coefficient * rho_bath) * area  # kg/m, transverse
    length = 10e-3
    omega_1 = 1.8751040687**2 * math.sqrt(m.bending_stiffness / (mass * length**4))
    static = (rho - rho_bath) * 9.81 * area * length**4 / (8.0 * m.bending_stiffness)
    return omega_1, float(p.mu_s) / mass, static


@pytest.mark.parametrize("integrator", ["implicit", "sdirk4"])
def test_fixed_step_error_matches_the_modal_prediction(integrator: str, reference) -> None:
    h = 1.25e-3
    tip, sim = _tip_history(integrator, h)
    omega_1, decay, static = _modal_scales(sim)
    measured = float(np.max(np.abs(tip - reference))) / static
    a_mat = TABLEAUX[integrator]
    predicted = cantilever_release_error(a_mat, a_mat[-1], h, omega_1, decay, SAMPLES)
    # measured (50 segments, nonlinear rod) against the continuum modes: within 20%
    assert 0.8 < measured / predicted < 1.25, (measured, predicted)


def test_sdirk4_is_more_accurate_than_sdirk2_at_the_same_step(reference) -> None:
    err = {k: np.max(np.abs(_tip_history(k, 1.25e-3)[0] - reference)) for k in TABLEAUX}
    assert err["sdirk4"] < err["implicit"] / 10.0  # measured: 16x


def test_sdirk4_static_cantilever_within_1_percent() -> None:
    # overdamped, adaptive: q L^4 / (8 E I) as for SDIRK2 (test_validation.py)
    sim_delta, exact, sim = V.cantilever_deflection(n_segments=50, integrator="sdirk4")
    assert abs(sim_delta / exact - 1.0) < 0.01
    implicit, _, _ = V.cantilever_deflection(n_segments=50, integrator="implicit")
    assert sim_delta == pytest.approx(implicit, rel=1e-5)  # same discretisation


def test_sdirk4_extrudes_the_default_scene() -> None:
    """Adaptive SDIRK4 on the paper's simulation: runs, conserves mass, and agrees with
    SDIRK2 at a tight tolerance before the coil sets in."""
    ends = {}
    for integrator in TABLEAUX:
        sim = Simulation(
            "paper_simulation", {"numerics.integrator": integrator, "numerics.tolerance": 1e-5}
        )
        sim.advance(0.15)
        expected = sim.initial_volume + integrated_flow_volume(sim, sim.t)
        assert sim.printed_volume() == pytest.approx(expected, rel=1e-9)
        ends[integrator] = sim.centerline()[0]
    assert np.linalg.norm(ends["sdirk4"] - ends["implicit"]) < 1e-5  # m


def test_an_overdamped_fixed_step_run_reuses_the_jacobian() -> None:
    """Modified Newton across steps: far fewer factorisations than steps, and the result
    equals full Newton's to well within the tolerance (overdamped cantilever, fixed steps)."""
    out = {}
    for newton in ("modified", "full"):
        sim = Simulation(
            "cantilever_water",
            {"numerics.time_step_s": 2e-3, "numerics.newton": newton, "numerics.tolerance": 1e-6},
        )
        sim.advance(0.1)
        out[newton] = (sim.centerline(), sim.counts())
    counts = out["modified"][1]
    assert counts["jacobians"] < counts["steps"] / 5
    assert out["full"][1]["jacobians"] == out["full"][1]["newton_iterations"]
    dl = 0.2e-3
    assert np.abs(out["modified"][0] - out["full"][0]).max() < 1e-6 * dl * 10


def test_an_inertial_run_reuses_the_jacobian_without_losing_accuracy(reference) -> None:
    """With inertia Newton's position error reaches the velocities amplified by 1/(h gamma);
    reusing the factorised Jacobian across steps must not add to the truncation error (it
    did, 5x, while the contraction estimate was carried over from earlier steps)."""
    tip, sim = _tip_history("sdirk4", 1.25e-3)
    full, sim_full = _tip_history("sdirk4", 1.25e-3, newton="full")
    counts = sim.counts()
    assert counts["jacobians"] < counts["steps"] / 2
    err = np.max(np.abs(tip - reference))
    err_full = np.max(np.abs(full - reference))
    assert abs(err / err_full - 1.0) < 0.1, (err, err_full)


@pytest.mark.parametrize("integrator", ["implicit", "sdirk4"])
def test_a_large_fixed_step_from_rest_converges(integrator: str) -> None:
    """Regression: the overdamped 100-element cantilever released straight at a 2.5 ms
    fixed step. Newton's damping for cycles once halved the updates while the stale
    Jacobian of the predictor was being refreshed, and ran out of iterations at t = 0."""
    sim = Simulation(
        "cantilever_water",
        {
            "numerics.node_spacing_mm": 0.1,
            "numerics.time_step_s": 2.5e-3,
            "numerics.tolerance": 1e-3,
            "numerics.integrator": integrator,
        },
    )
    sim.advance(0.02)
    assert sim.counts()["newton_failures"] == 0

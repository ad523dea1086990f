"""The simulator against analytic results. Tolerances are stated in each assertion."""

from __future__ import annotations

import numpy as np
import pytest

from bathprint.analysis import validation as V


def test_cantilever_tip_deflection_within_1_percent() -> None:
    # q L^4 / (8 E I), small deflection (delta / L ~ 1e-3); 50 segments
    sim_delta, exact, _ = V.cantilever_deflection(n_segments=50)
    assert abs(sim_delta / exact - 1.0) < 0.01
    # and the discretisation converges: 100 segments are closer still
    sim_delta_100, _, _ = V.cantilever_deflection(n_segments=100)
    assert abs(sim_delta_100 / exact - 1.0) < abs(sim_delta / exact - 1.0)


def test_column_buckles_at_euler_load_within_2_percent() -> None:
    # clamped-free column under a dead end load: P_c = pi^2 E I / (4 L^2)
    assert V.column_growth_rate(0.98) < 0.0  # stays straight 2% below
    assert V.column_growth_rate(1.02) > 0.0  # buckles 2% above


@pytest.mark.parametrize(
    "velocity, factor",
    [((0.0, 0.0, -0.01), 1.0), ((0.01, 0.0, 0.0), 2.0), ((0.0, -0.004, 0.0), 2.0)],
)
def test_translating_rod_drag_is_slender_body_drag(velocity, factor) -> None:
    # along the axis (z): mu_s v L; across: 2 mu_s v L (exact for a straight rod)
    force, mu_s, length = V.translating_rod_drag((0.0, 0.0, -1.0), velocity)
    expected = -factor * mu_s * length * np.asarray(velocity)
    np.testing.assert_allclose(force, expected, rtol=1e-12, atol=1e-18)


def test_beta_critical_from_the_hypergeometric_condition() -> None:
    # the paper: beta ~ 3.48; 4 significant figures
    assert round(V.beta_critical(), 3) == 3.477


def test_extruded_rod_onset_within_5_percent_of_beta_c() -> None:
    beta_c = V.beta_critical()
    assert V.extruded_rod_growth_rate(0.95 * beta_c) < 0.0  # straight below
    assert V.extruded_rod_growth_rate(1.05 * beta_c) > 0.0  # buckles above
    onset = V.onset_beta(0.95 * beta_c, 1.05 * beta_c)
    assert abs(onset / beta_c - 1.0) < 0.05

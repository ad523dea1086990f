"""Freezing settled material (``numerics.freeze_beyond_mm``, :mod:`bathprint.freezing`).

Material further behind the needle than the set arclength leaves the solve; it moves
rigidly with the active end and acts on it through its lumped drag and net weight. The
checks: the tail keeps its shape and stays attached, mass balance holds, the answer of a
steady coil changes by less than the preset's tolerance allows (the change from tightening
the tolerance ten times), and bad settings are refused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint import SceneError, Simulation
from bathprint.bench_accuracy import coil_run
from bathprint.freezing import tail_is_frozen

COIL = "gelation_coiling_22G"  # 22G, 0.5 ml/min, gelation with curvature memory


def _pairwise(x: np.ndarray) -> np.ndarray:
    return np.linalg.norm(x[:, None, :] - x[None, :, :], axis=-1)


def test_tail_freezes_keeps_its_shape_and_stays_attached() -> None:
    sim = Simulation(COIL, {"numerics.accuracy": "draft", "numerics.freeze_beyond_mm": 20.0})
    sim.advance(1.0)
    k = sim.n_frozen
    assert k > 10 and tail_is_frozen(sim.work)
    # every frozen node is more than 20 mm of material behind the needle, no active one is
    # (node_s: extruded length at each node; the tip is the last filament node)
    s_tip = sim.node_s[sim.n_segments]
    assert np.all(s_tip - sim.node_s[:k] > 20e-3)
    assert np.all(s_tip - sim.node_s[k : sim.n_segments + 1] <= 20e-3 + 2 * 0.6e-3)
    before = sim.centerline()[:k]
    sim.advance(1.05)  # a short interval: fewer new nodes freeze
    after = sim.centerline()[:k]
    # the tail moved (it sinks with the coil) but kept its shape exactly
    assert np.max(np.linalg.norm(after - before, axis=1)) > 1e-6
    np.testing.assert_allclose(_pairwise(after), _pairwise(before), atol=1e-12)
    # and is attached: the joining segment keeps its rest length
    x = sim.centerline()
    j = sim.n_frozen - 1
    strain = np.linalg.norm(x[j + 1] - x[j]) / sim.rest_lengths()[j] - 1.0
    assert abs(strain) < 0.05
    assert np.isfinite(x).all()


def test_mass_balance_with_a_frozen_tail() -> None:
    sim = Simulation(COIL, {"numerics.accuracy": "draft", "numerics.freeze_beyond_mm": 20.0})
    sim.advance(1.0)
    assert sim.n_frozen > 0
    q = sim.scene.flow.q_outer_ml_min * 1e-6 / 60
    area = math.pi * (sim.scene.needle.inner_diameter_mm * 1e-3) ** 2 / 4
    expected = sim.initial_volume + q * 1.0
    assert sim.printed_volume() == pytest.approx(expected, rel=1e-3)
    assert area > 0


def test_freezing_changes_a_steady_coil_less_than_the_tolerance_does() -> None:
    """Coil radius and frequency (draft preset, 3 s): freezing everything beyond 40 mm
    (about 1.7 turns) changes them by less than tightening the tolerance from the preset's
    1e-2 to 1e-3 does, i.e. by less than the error the preset already accepts."""
    dx = 2 * Simulation(COIL).scene.numerics.node_spacing_mm  # draft doubles the spacing
    draft = {"numerics.accuracy": "draft"}
    tighter = {
        "numerics.tolerance": 1e-3,
        "numerics.max_inlet_growth": 2.0,
        "numerics.node_spacing_mm": dx,
    }
    r0, om0 = coil_run(draft)
    r_f, om_f = coil_run({**draft, "numerics.freeze_beyond_mm": 40.0})
    r_t, om_t = coil_run(tighter)
    tol_r, tol_om = abs(r_t / r0 - 1), abs(om_t / om0 - 1)
    assert abs(r_f / r0 - 1) < tol_r, (r0, r_f, r_t)
    assert abs(om_f / om0 - 1) < tol_om, (om0, om_f, om_t)


def test_without_freezing_nothing_is_frozen() -> None:
    sim = Simulation(COIL, {"numerics.accuracy": "draft"})
    sim.advance(0.5)
    assert sim.n_frozen == 0 and not tail_is_frozen(sim.work)


@pytest.mark.parametrize(
    ("overrides", "match"),
    [
        ({"numerics.freeze_beyond_mm": 1.0}, "shorter than 8 node spacings"),
        ({"numerics.freeze_beyond_mm": -1.0}, "freeze_beyond_mm"),
        (
            {"numerics.freeze_beyond_mm": 30.0, "effects": ["elasticity", "drag", "inertia"]},
            "inertia",
        ),
        (
            {"numerics.freeze_beyond_mm": 30.0, "effects": ["elasticity", "drag", "floor"]},
            "floor",
        ),
    ],
)
def test_bad_freezing_settings_are_refused(overrides: dict, match: str) -> None:
    with pytest.raises(SceneError, match=match):
        Simulation(COIL, overrides)


def test_release_unfreezes() -> None:
    sim = Simulation(
        COIL,
        {"numerics.accuracy": "draft", "numerics.freeze_beyond_mm": 20.0, "needle.release_s": 0.8},
    )
    sim.advance(1.0)
    assert not sim.clamped and sim.n_frozen == 0 and not tail_is_frozen(sim.work)
    assert np.isfinite(sim.centerline()).all()

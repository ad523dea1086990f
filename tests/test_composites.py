"""Gelation and co-extrusion: each test asserts a number against theory or conservation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint import SceneError, Simulation, load_scene, simulate
from bathprint.analysis import lab
from bathprint.core import layout as L
from bathprint.core.composite import INNER_FLUIDS, composite_properties
from bathprint.core.run import integrated_flow_volume

COMPOSITE = {"effects": ["elasticity", "drag", "gravity", "contact", "inclusions"]}


def test_inner_and_outer_volumes_equal_the_integrals_of_the_flows() -> None:
    schedule = [[0.0, 1.0, 0.0], [0.2, 1.0, 0.3], [0.5, 0.6, 0.5], [0.7, 1.2, 0.1]]
    sim = Simulation(
        "drag_coiling_22G",
        {**COMPOSITE, "flow.schedule": schedule, "duration_s": 0.9, "numerics.tolerance": 1e-2},
    )
    initial = sim.printed_volume()
    sim.advance(0.9)
    t = np.linspace(0.0, 0.9, 90001)
    table = np.array(schedule)
    qo = np.interp(t, table[:, 0], table[:, 1]) * 1e-6 / 60
    qi = np.interp(t, table[:, 0], table[:, 2]) * 1e-6 / 60
    inner_expected = np.trapezoid(qi, t)
    outer_expected = np.trapezoid(qo, t) + initial
    inner = sim.inner_volume()
    outer = sim.printed_volume() - inner
    assert inner == pytest.approx(inner_expected, rel=1e-3)
    assert outer == pytest.approx(outer_expected, rel=1e-3)
    assert sim.printed_volume() == pytest.approx(
        initial + integrated_flow_volume(sim, 0.9), rel=1e-3
    )


def test_composite_density_is_the_volume_weighted_mean() -> None:
    sim = Simulation(
        "drag_coiling_22G",
        {**COMPOSITE, "flow.q_outer_ml_min": 0.4, "flow.q_inner_ml_min": 0.1, "duration_s": 0.5},
    )
    sim.advance(0.5)
    mat = sim.material()[5:-1]  # away from the initial stub and the growing inlet
    phi = mat[:, L.MAT_INNER_FRACTION]
    assert phi == pytest.approx(0.2, rel=1e-9)
    expected = (1 - phi) * 1054.0 + phi * INNER_FLUIDS["silicone_oil"].density_kg_m3
    np.testing.assert_allclose(mat[:, L.MAT_DENSITY], expected, rtol=1e-12)


@pytest.mark.parametrize("density", [1006.0, 1018.0, 1021.0, 1045.0])  # the paper's Fig. 3E
def test_settling_height_in_the_gradient_column_within_one_node_spacing(density) -> None:
    z, expected, spacing = lab.settling_height(density)
    if expected < 0:
        assert abs(z - expected) < spacing
    else:  # lighter than the top of the column: it floats, within a radius of the surface
        assert abs(z) < 0.5e-3


def test_cantilever_method_recovers_the_input_modulus_within_2_percent() -> None:
    m = lab.cantilever_method(youngs_modulus_pa=4800.0)
    assert m.youngs_modulus_pa == pytest.approx(4800.0, rel=0.02)
    # and on a composite it reads the rule's effective bending modulus
    phi = 0.1
    m = lab.cantilever_method(youngs_modulus_pa=4800.0, phi=phi)
    expected = composite_properties(phi, 1054.0, 910.0, 0.5e-3)["bend_stiffness_factor"]
    assert m.youngs_modulus_pa / 4800.0 == pytest.approx(expected, rel=0.02)


@pytest.mark.parametrize("phi", [0.05, 0.15, 0.3, 0.6])
def test_stretching_test_reads_the_rules_stiffness(phi) -> None:
    expected = composite_properties(phi, 1054.0, 910.0, 0.5e-3)["stretch_stiffness_factor"]
    assert lab.stretching_test(phi) == pytest.approx(expected, rel=0.01)


def _free_arc(offset: float) -> tuple[float, float]:
    """A released composite filament with offset inclusions: (mean curvature, rule's)."""
    phi = 0.1
    sim = lab._segment_sim(
        {
            **COMPOSITE,
            "effects": ["elasticity", "drag", "inclusions"],
            "inclusions.offset": offset,
            "inclusions.curvature_coefficient": 0.5,
            "needle.direction": [1.0, 0.0, 0.0],
            "initial.length_mm": 20.0,
            "numerics.node_spacing_mm": 0.5,
            "needle.release_s": 1e-6,
            "numerics.tolerance": 1e-6,
        },
        phi,
    )
    sim.advance(3.0)
    c = sim.centerline()
    e = np.diff(c, axis=0)
    t = e / np.linalg.norm(e, axis=1)[:, None]
    turning = np.arccos(np.clip(np.sum(t[1:] * t[:-1], axis=1), -1, 1))
    kappa = turning / np.linalg.norm(e, axis=1)[1:]
    return float(np.mean(kappa[2:-2])), 0.5 * abs(offset) * phi / 0.5e-3


def test_off_axis_inclusions_bend_the_filament_to_the_rules_curvature() -> None:
    measured, rule = _free_arc(0.6)
    assert measured == pytest.approx(rule, rel=0.02)


def test_centred_inclusions_leave_the_filament_straight() -> None:
    measured, _ = _free_arc(0.0)
    assert measured < 1e-6  # 1/m: straight


def test_gelation_modulus_grows_monotonically_to_its_limit() -> None:
    over = {
        "effects": ["elasticity", "drag", "gravity", "gelation"],
        "gelation.rate_1_s": 2.0,
        "gelation.initial_modulus_pa": 300.0,
        "gelation.final_modulus_pa": 30000.0,
        "duration_s": 4.0,
    }
    sim = Simulation("drag_coiling_22G", over)
    moduli = []
    for t in np.linspace(0.2, 4.0, 20):
        sim.advance(float(t))
        moduli.append(sim.material()[0, L.MAT_YOUNGS_MODULUS])  # the oldest material point
    assert np.all(np.diff(moduli) >= 0)
    assert moduli[-1] == pytest.approx(30000.0, rel=1e-3)
    mat = sim.material()
    age = sim.t - mat[:, L.MAT_BIRTH_TIME]
    law = 30000.0 - (30000.0 - 300.0) * np.exp(-2.0 * age)
    np.testing.assert_allclose(mat[:, L.MAT_YOUNGS_MODULUS], law, rtol=1e-9)
    assert mat[-1, L.MAT_YOUNGS_MODULUS] / mat[0, L.MAT_YOUNGS_MODULUS] < 0.05  # soft at needle


def _median_curvature(sim: Simulation) -> float:
    c = sim.centerline()
    e = np.diff(c, axis=0)
    t = e / np.linalg.norm(e, axis=1)[:, None]
    turning = np.arccos(np.clip(np.sum(t[1:] * t[:-1], axis=1), -1, 1))
    return float(np.median(turning / np.linalg.norm(e, axis=1)[1:]))


def _coil_then_release(memory: bool) -> tuple[float, float]:
    """Coil by extrusion for 1 s while the gel sets, cut free, wait 2 s: curvature before/after."""
    over = {
        "effects": ["elasticity", "drag", "gelation"],
        "gelation.rate_1_s": 3.0,
        "gelation.curvature_memory": memory,
        "needle.release_s": 1.0,
        "duration_s": 3.0,
        "flow.q_outer_ml_min": 1.0,
        "numerics.tolerance": 1e-2,
    }
    sim = Simulation("drag_coiling_22G", over)
    sim.advance(1.0)
    before = _median_curvature(sim)
    sim.advance(3.0)  # released: no extrusion, so no drag-driven compression any more
    return before, _median_curvature(sim)


def test_curvature_memory_keeps_a_coil_after_the_drag_is_gone() -> None:
    before, after = _coil_then_release(memory=True)
    assert before > 100.0  # 1/m: it coiled (radius of a few mm)
    assert after == pytest.approx(before, rel=0.05)
    before_nm, after_nm = _coil_then_release(memory=False)
    assert after_nm < 0.75 * before_nm  # without memory it relaxes back toward straight


def test_zero_inner_flow_gives_exactly_the_pure_alginate_filament() -> None:
    pure = simulate("drag_coiling_22G", {"duration_s": 0.3, "outputs.plot": False})
    comp = simulate(
        "drag_coiling_22G",
        {**COMPOSITE, "duration_s": 0.3, "flow.q_inner_ml_min": 0.0, "outputs.plot": False},
    )
    np.testing.assert_array_equal(pure.final, comp.final)
    np.testing.assert_array_equal(pure.material, comp.material)


def test_set_flow_step_by_step_matches_a_schedule() -> None:
    schedule = [[0.0, 0.5, 0.0], [0.3, 0.5, 0.0], [0.3 + 1e-6, 1.0, 0.2]]
    a = Simulation("drag_coiling_22G", {**COMPOSITE, "flow.schedule": schedule})
    a.advance(0.6)
    b = Simulation("drag_coiling_22G", {**COMPOSITE, "flow.q_outer_ml_min": 0.5})
    b.advance(0.3)
    b.set_flow(1.0e-6 / 60, 0.2e-6 / 60)
    b.advance(0.6)
    assert b.inner_volume() == pytest.approx(a.inner_volume(), rel=1e-6)
    assert b.printed_volume() == pytest.approx(a.printed_volume(), rel=1e-9)
    # the material printed after the switch carries the new inner fraction
    phi_b = b.material()[-5:-1, L.MAT_INNER_FRACTION]
    np.testing.assert_allclose(phi_b, 0.2 / 1.2, rtol=1e-9)


@pytest.mark.parametrize(
    "overrides, words",
    [
        (
            {**COMPOSITE, "flow.q_outer_ml_min": 1.0, "flow.q_inner_ml_min": 12.0},
            ["flow.q_inner_ml_min", "12.0", "needle allows", "<= 9"],
        ),
        ({**COMPOSITE, "flow.q_inner_ml_min": -0.5}, ["flow.q_inner_ml_min", "-0.5"]),
        ({"flow.q_inner_ml_min": 0.5}, ["inclusions"]),
        ({**COMPOSITE, "inclusions.fluid": "honey"}, ["inclusions.fluid", "honey", "nitrogen"]),
        ({**COMPOSITE, "inclusions.offset": 1.5}, ["inclusions.offset", "1.5", "[-1, 1]"]),
        (
            {**COMPOSITE, "flow.schedule": [[0.0, 1.0, 0.1], [-2.0, 1.0, 0.1]]},
            ["flow.schedule[1]", "negative"],
        ),
        (
            {**COMPOSITE, "flow.schedule": [[0.0, 1.0, 0.1], [0.5, 1.0, math.nan]]},
            ["flow.schedule[1]", "non-finite"],
        ),
    ],
)
def test_bad_co_extrusion_input_is_one_clear_error(overrides, words) -> None:
    with pytest.raises(SceneError) as err:
        load_scene("drag_coiling_22G", overrides)
    for w in words:
        assert w in str(err.value), str(err.value)


def test_schedule_from_csv(tmp_path) -> None:
    path = tmp_path / "flows.csv"
    path.write_text("t_s,q_outer_ml_min,q_inner_ml_min\n0,1.0,0.0\n0.2,1.0,0.25\n")
    sim = Simulation(
        "drag_coiling_22G", {**COMPOSITE, "flow.schedule_csv": str(path), "duration_s": 0.4}
    )
    sim.advance(0.4)
    expected = (0.5 * 0.25 * 0.2 + 0.25 * 0.2) * 1e-6 / 60
    assert sim.inner_volume() == pytest.approx(expected, rel=1e-3)
    path.write_text("t_s,q_outer_ml_min,q_inner_ml_min\n0,1.0,0.0\n0.1,1.0,\n")
    with pytest.raises(SceneError, match="not numeric"):
        load_scene("drag_coiling_22G", {**COMPOSITE, "flow.schedule_csv": str(path)})

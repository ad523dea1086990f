"""Conservation, determinism, stability and failure reporting of the stepper."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest

from bathprint import Simulation, SimulationError, simulate
from bathprint.analysis.stability import explicit_step_limit
from bathprint.analysis.validation import CANTILEVER
from bathprint.core import layout as L

SHORT = {"duration_s": 0.4, "outputs.frame_interval_s": 0.1, "outputs.plot": False}


def test_mass_is_conserved_under_a_varying_schedule() -> None:
    schedule = [[0.0, 2.0, 0.0], [0.1, 10.0, 0.0], [0.25, 10.0, 0.0], [0.3, 4.0, 0.0]]
    res = simulate("paper_simulation", {**SHORT, "flow.schedule": schedule})
    assert res.summary["code"]["bathprint"]  # which code computed it
    mb = res.summary["mass_balance"]
    assert abs(mb["relative_error"]) < 1e-3  # the issue asks for 0.1%
    # and independently of the bookkeeping: trapezoid of the schedule by hand
    t = np.array([r[0] for r in schedule] + [0.4])
    q = np.array([r[1] for r in schedule] + [4.0]) * 1e-6 / 60
    volume = np.trapezoid(q, t)
    initial = 2 * 1e-3 * math.pi * 0.5e-3**2  # the stub of two 1 mm segments
    assert mb["printed_volume_ml"] * 1e-6 == pytest.approx(volume + initial, rel=1e-3)


def test_no_segment_is_born_tiny() -> None:
    sim = Simulation("drag_coiling_22G", {"duration_s": 0.5})
    sim.advance(0.5)
    rest = sim.rest_lengths()
    spacing = sim.model.node_spacing
    assert rest.min() >= spacing * (1 - 1e-9)
    assert rest[:-1].max() <= 1.5 * spacing * (1 + 1e-9)
    assert rest[-1] < 2.0 * spacing  # the inlet, still growing


def test_same_scene_twice_gives_identical_trajectories() -> None:
    a = simulate("period_doubling_22G", {**SHORT, "duration_s": 0.1})
    b = simulate("period_doubling_22G", {**SHORT, "duration_s": 0.1})
    assert len(a.frames) == len(b.frames)
    for fa, fb in zip(a.frames, b.frames, strict=True):
        np.testing.assert_array_equal(fa, fb)


def test_chunking_of_advance_does_not_change_fixed_step_results() -> None:
    over = {"numerics.time_step_s": 1e-3, "duration_s": 0.2}
    a = Simulation("drag_coiling_22G", over)
    a.advance(0.2)
    b = Simulation("drag_coiling_22G", over)
    for t in np.linspace(0.02, 0.2, 10):
        b.advance(float(t))
    np.testing.assert_allclose(a.centerline(), b.centerline(), rtol=0, atol=1e-12)


def test_unlisted_effects_are_never_called() -> None:
    sim = Simulation("paper_simulation", {"effects": ["elasticity", "drag"], "duration_s": 0.1})
    sim.advance(0.1)
    calls = sim.effect_calls()
    assert calls["elasticity"] > 0 and calls["drag"] > 0
    for name in ("gravity", "floor", "inertia", "end_load"):
        assert calls[name] == 0, name
    sim2 = Simulation("rope_coiling_18G", {"duration_s": 0.1})
    sim2.advance(0.1)
    assert sim2.effect_calls()["floor"] > 0 and sim2.effect_calls()["inertia"] == 0


def test_overdamped_relaxation_never_increases_energy() -> None:
    sim = Simulation(
        "paper_simulation",
        {
            **CANTILEVER,
            "initial.perturbation_mm": 3.0,
            "numerics.node_spacing_mm": 0.4,
            "numerics.tolerance": 1e-4,
        },
    )
    elastic0 = sim.energies_now()["elasticity"]
    energies = []
    for _ in range(150):
        sim.advance(1.0, max_steps=1)
        e = sim.energies_now()
        energies.append(e["elasticity"] + e["gravity"])
    diffs = np.diff(energies)
    assert diffs.max() <= 1e-12 * abs(energies[0])
    assert sim.energies_now()["elasticity"] < 0.01 * elastic0  # and it did relax


def test_inertial_cantilever_oscillates_at_the_damped_beam_frequency() -> None:
    # released straight, with mass + added mass and (uniform, hence modal) drag damping:
    # omega_d = sqrt(omega_1^2 - (c / 2m)^2), omega_1 = 1.8751^2 sqrt(B / (m L^4)), c = 2 mu_s
    sim = Simulation(
        "cantilever_water",
        {"effects": ["elasticity", "drag", "gravity", "inertia"], "numerics.tolerance": 1e-5},
    )
    times = np.linspace(0.0, 0.5, 2001)[1:]
    z = []
    for t in times:
        sim.advance(float(t))
        c = sim.centerline()
        z.append(c[0, 2] - c[-1, 2])
    z = np.array(z)
    m = sim.model
    area = math.pi * m.radius**2
    mass = area * (1006.0 + 1003.0)
    omega_1 = 1.8751**2 * math.sqrt(m.bending_stiffness / (mass * 0.01**4))
    zeta_omega = 2 * m.mu_s / (2 * mass)
    omega_d = math.sqrt(omega_1**2 - zeta_omega**2)
    dev = z - z[-400:].mean()
    crossings = times[1:][np.diff(np.sign(dev)) != 0]
    period = 2 * np.mean(np.diff(crossings))
    assert 2 * math.pi / period == pytest.approx(omega_d, rel=0.02)


def test_implicit_is_stable_at_1e4_times_the_explicit_limit_on_the_default_scene() -> None:
    sim = Simulation("paper_simulation")
    sim.advance(0.3)
    h_explicit = explicit_step_limit(sim)
    state = pickle.dumps(sim)
    # the limit is real: explicit just below it runs, just above it diverges
    below = pickle.loads(state)
    below.model.p.fixed_step = 0.9 * h_explicit
    below.model.p.integrator = L.INTEGRATOR_EXPLICIT
    below.advance(0.3 + 300 * 0.9 * h_explicit)
    above = pickle.loads(state)
    above.model.p.fixed_step = 1.1 * h_explicit
    above.model.p.integrator = L.INTEGRATOR_EXPLICIT
    with pytest.raises(SimulationError):
        above.advance(0.3 + 3000 * 1.1 * h_explicit)
    # implicit at 1e4 x the limit: runs on through buckling with bounded stretch
    implicit = pickle.loads(state)
    implicit.model.p.fixed_step = 1e4 * h_explicit
    implicit.advance(1.0)
    c = implicit.centerline()
    assert np.isfinite(c).all()
    strain = np.linalg.norm(np.diff(c, axis=0), axis=1) / implicit.rest_lengths() - 1
    assert np.abs(strain).max() < 0.05
    lateral = np.hypot(c[:, 0], c[:, 1]).max()
    assert lateral > 1e-3  # it did buckle and coil


def test_divergence_raises_simulation_error_naming_time_node_and_cause() -> None:
    sim = Simulation(
        "paper_simulation", {"numerics.integrator": "explicit", "numerics.time_step_s": 1e-4}
    )
    with pytest.raises(SimulationError) as err:
        sim.advance(0.1)
    e = err.value
    assert 0.0 <= e.time_s < 0.1
    assert 0 <= e.node < sim.n_nodes
    assert e.cause in L.STATUS_MESSAGES.values()
    assert f"node {e.node}" in str(e) and "t =" in str(e)


def test_newton_failure_at_fixed_step_is_reported() -> None:
    # 0.1 s: the longest fixed step whose extrusion (21 mm) is within a coil turn (24.7 mm),
    # the bound bathprint.core.resolution puts on a fixed step; far beyond what Newton's
    # single iteration can take
    sim = Simulation(
        "paper_simulation", {"numerics.time_step_s": 0.1, "numerics.max_newton_iterations": 1}
    )
    with pytest.raises(SimulationError, match="Newton"):
        sim.advance(10.0)


def test_capacity_grows_without_losing_state() -> None:
    sim = Simulation("drag_coiling_22G", {"duration_s": 0.05})
    cap0 = sim.capacity
    sim.advance(1.0)  # beyond the scene's duration: arrays must grow
    assert sim.capacity > cap0
    assert sim.rest_lengths().min() > 0
    assert np.isfinite(sim.centerline()).all()


def test_moving_needle_is_followed_by_the_clamp() -> None:
    path = [[0.0, 0.0, 0.0, -10.0, 0.0, 0.0, -1.0], [0.5, 5.0, 0.0, -10.0, 0.0, 0.0, -1.0]]
    sim = Simulation("drag_coiling_22G", {"needle.path": path, "duration_s": 0.5})
    sim.advance(0.25)
    tip = sim.centerline()[-1]
    np.testing.assert_allclose(tip, [2.5e-3, 0.0, -10e-3], atol=1e-12)


def test_implicit_agrees_with_the_explicit_reference() -> None:
    # a bent cantilever relaxing under its weight: the explicit integrator at half its
    # stability limit is the reference; implicit SDIRK2 and backward Euler must match it
    over = {
        **CANTILEVER,
        "initial.perturbation_mm": 1.0,
        "numerics.node_spacing_mm": 1.0,
        "duration_s": 0.002,
    }
    probe = Simulation("paper_simulation", over)
    h_explicit = explicit_step_limit(probe)
    ref = Simulation(
        "paper_simulation",
        {**over, "numerics.integrator": "explicit", "numerics.time_step_s": 0.5 * h_explicit},
    )
    ref.advance(0.002)
    travel = np.abs(ref.centerline() - probe.centerline()).max()
    # (tolerance, how many times fewer steps than the explicit reference at least)
    for integrator, tol, fewer in (("implicit", 1e-6, 100), ("implicit_euler", 1e-7, 20)):
        sim = Simulation(
            "paper_simulation",
            {**over, "numerics.integrator": integrator, "numerics.tolerance": tol},
        )
        sim.advance(0.002)
        diff = np.abs(sim.centerline() - ref.centerline()).max()
        assert diff < 2e-3 * travel, (integrator, diff, travel)
        assert sim.counts()["steps"] * fewer < ref.counts()["steps"]


@pytest.mark.parametrize("q_ml_min", [0.2, 0.5])
def test_floor_contact_does_not_stall_newton(q_ml_min: float) -> None:
    # regressions: contacts switching made the reused Jacobian fail every step (h ~ 1e-6 s
    # forever), and so did friction regularised over 0.1 mm/s; after a Newton failure the
    # stepper now uses full Newton for a while, and the default regularisation is 1 mm/s
    from bathprint.studies.reproduce.runs import run_overrides

    sim = Simulation("drag_coiling_22G", run_overrides(0.41, q_ml_min, 30.0, 6.0, 6.0))
    sim.advance(3.0, max_steps=3000)
    assert sim.t == pytest.approx(3.0)
    assert sim.centerline()[:, 2].min() < -0.124  # it did reach the floor


def test_rope_pushed_into_the_floor_buckles_instead_of_crushing() -> None:
    # regression: at long implicit steps the filament end pushed into the floor compressed
    # by 50% (the step stabilised the buckling) until the stretch bound stopped the run;
    # large strains now shorten the step
    sim = Simulation("rope_coiling_18G", {"duration_s": 3.0})
    sim.advance(3.0, max_steps=20000)
    c = sim.centerline()
    strain = np.linalg.norm(np.diff(c, axis=0), axis=1) / sim.rest_lengths() - 1
    assert sim.t == pytest.approx(3.0)
    assert np.abs(strain[:-1]).max() < 0.1


def test_inertial_jet_faster_than_its_elastic_waves_leaves_the_needle_unbraked() -> None:
    # regression: with inertia, nodes were born at the inlet at rest (the tip's velocity was
    # the needle's), so every birth braked the rod by rho A v^2; at 20 ml/min through a
    # 0.41 mm needle (v = 2.5 m/s above sqrt(E / rho) = 1.6 m/s) the inlet compressed by
    # 55% within 63 us. The jet now leaves with the exit speed (Q_o + Q_i) / A along d.
    sim = Simulation(
        "drag_coiling_22G",
        {
            "effects": ["elasticity", "drag", "gravity", "inertia"],
            "needle.inner_diameter_mm": 0.41,
            "flow.q_outer_ml_min": 20.0,
            "material.youngs_modulus_pa": 2700.0,
            "numerics.node_spacing_mm": 0.114,
            "numerics.tolerance": 3e-3,
        },
    )
    exit_speed = 20e-6 / 60 / (math.pi * 0.205e-3**2)
    assert exit_speed > math.sqrt(2700.0 / 1000.0)
    sim.advance(2e-3)
    c = sim.centerline()
    strain = np.linalg.norm(np.diff(c, axis=0), axis=1) / sim.rest_lengths() - 1
    speed = np.linalg.norm(sim.velocities(), axis=1)
    assert sim.t == pytest.approx(2e-3)
    assert np.abs(strain[:-1]).max() < 0.05
    assert np.median(speed) == pytest.approx(exit_speed, rel=0.05)


def test_a_pickled_simulation_still_writes_its_parameters() -> None:
    # Model.p is a cached view of the parameter record; a copy must not detach it
    sim = Simulation("drag_coiling_22G")
    sim.model.p.inclusion_offset  # noqa: B018  (fills the cache)
    for copy in (pickle.loads(pickle.dumps(sim)),):
        copy.set_inclusion_offset(0.25)
        assert copy.model.params[0]["inclusion_offset"] == pytest.approx(0.25)
    assert sim.model.params[0]["inclusion_offset"] == pytest.approx(0.0)


def test_the_kernel_entry_point_follows_the_workspace_and_leaves_results_unchanged() -> None:
    # Simulation.advance calls the compiled kernel directly, resolved once per workspace;
    # a grown workspace is resolved again, a pickle drops the entry point, and the
    # trajectory is the dispatcher's, bit for bit
    a = Simulation("drag_coiling_22G", {"duration_s": 0.05})
    b = Simulation("drag_coiling_22G", {"duration_s": 0.05})
    cap0 = a.capacity
    a.advance(0.01)  # (the first call may go through the dispatcher, which loads the kernel)
    a.advance(0.02)
    ws_before = a.ws
    assert a._advance_entry[0] is ws_before
    for t in np.linspace(0.02, 1.0, 50)[1:]:  # grows: a new workspace
        a.advance(float(t))
    assert a.capacity > cap0 and a.ws is not ws_before and a._advance_entry[0] is a.ws
    copy = pickle.loads(pickle.dumps(a))
    assert "_advance_entry" not in copy.__dict__
    copy.advance(1.01)
    a.advance(1.01)
    np.testing.assert_array_equal(copy.centerline(), a.centerline())
    # the same run through numba's dispatcher on every call
    from bathprint.core.integrators import advance

    b.advance(0.01)
    b.advance(0.02)
    for t in list(np.linspace(0.02, 1.0, 50)[1:]) + [1.01]:
        while True:
            before = int(b.counters[L.C_STEPS])
            status = advance(b.model.record, b.state, b.ws, float(t), 10**9)
            if status == L.STATUS_CAPACITY:
                b.make_room()
                continue
            assert status == L.STATUS_OK, before
            break
    np.testing.assert_array_equal(b.centerline(), a.centerline())


def test_damped_newton_updates_are_counted() -> None:
    """A buckling jet stalls some full Newton updates (they are then halved, and counted);
    a cantilever relaxing to its sag never does."""
    jet = Simulation("paper_simulation", {})
    jet.advance(0.3)
    c = jet.counts()
    assert 0 < c["damped_newton_iterations"] < c["newton_iterations"]
    beam = Simulation("cantilever_water", {})
    beam.advance(0.3)
    assert beam.counts()["damped_newton_iterations"] == 0
    assert beam.counts()["newton_iterations"] > 0


def test_the_compiled_entry_point_is_found_again_by_the_layout_of_the_records() -> None:
    """A second simulation of the same layout reuses the entry point (no typeof of its
    records) and steps exactly as the first; the key tells layouts numba types apart."""
    from bathprint.core import simulation as simulation_module
    from bathprint.core.simulation import _layout_key

    over = {"duration_s": 0.05, "effects": ["elasticity", "drag", "gravity"]}
    first = Simulation("paper_simulation", over)
    first.advance(0.05)
    known = len(simulation_module._ENTRY_POINTS)
    second = Simulation("paper_simulation", over)
    second.advance(0.05)
    assert len(simulation_module._ENTRY_POINTS) == known
    assert second._advance_entry[1] is first._advance_entry[1]
    np.testing.assert_array_equal(first.centerline(), second.centerline())
    a = np.zeros(4)
    frozen = np.zeros(4)
    frozen.flags.writeable = False
    keys = {_layout_key(x) for x in (a, frozen, np.zeros(4, np.int64), np.zeros((2, 2)))}
    assert len(keys) == 4
    assert _layout_key((a, 1.0)) != _layout_key((a, 1))


def test_off_band_is_true_where_the_scene_solves_by_gmres() -> None:
    """``Simulation.off_band``: contact (or implicit hydrodynamics) couples distant nodes."""
    assert not Simulation("paper_simulation").off_band
    assert Simulation("period_doubling_22G").off_band
    assert not Simulation("period_doubling_22G", {"effects": ["elasticity", "drag"]}).off_band


def test_make_room_doubles_the_node_arrays_when_the_rod_fills_them() -> None:
    sim = Simulation("paper_simulation")
    cap = sim.capacity
    pos = sim.pos[: 3 * sim.n_nodes].copy()
    while sim.n_nodes + 2 <= sim.capacity:  # a rod that fills its arrays, as a kernel reports
        sim.istate[0] += 1
    n = sim.n_nodes
    sim.make_room()
    assert sim.capacity == 2 * cap
    np.testing.assert_array_equal(sim.pos[: 3 * n][: pos.size], pos)


"""The contact benchmarks on tiny budgets: their parts run, and their coil stacks are as
their docs say (``contact_cost.py``, ``contact_newton.py``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from bathprint import Simulation
from bathprint.core import layout as L
from bathprint.core.effects import hydrodynamics
from bathprint.studies.reproduce import ablation

BENCH = Path(__file__).resolve().parents[1]  # experiments/


@pytest.fixture
def bench(load_script, monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))  # the scripts import _common and each other
    return lambda name: load_script(BENCH / f"{name}.py")


def test_the_scene_parts_run_and_report_against_the_run_without_contact(bench, monkeypatch):
    mod = bench("contact_newton/contact_newton")
    monkeypatch.setattr(mod, "SCENE_DURATION_S", 0.02)
    monkeypatch.setattr(mod, "NEAR_GAPS", (0.05, 0.3))
    monkeypatch.setattr(mod, "SEEDS", (1,))
    monkeypatch.setattr(mod, "ONSETS", (0.2,))
    monkeypatch.setattr(mod, "ONSETS_BEFORE_CONTACT", ((0.2, 1.02),))
    monkeypatch.setattr(mod, "KRYLOV_TOLERANCES", (0.2,))
    near = mod.near_gap_rows()
    assert [r["variant"] for r in near] == [
        "without contact",
        "contact, near gap 0.05 delta",
        "contact, near gap 0.3 delta",
    ]
    assert [r["near_gap_fraction"] for r in near[1:]] == [0.05, 0.3]
    assert math.isnan(near[0]["near_gap_fraction"])
    seeds = mod.seed_rows()
    assert [r["seed"] for r in seeds] == [1, 1, 1] and len({r["variant"] for r in seeds}) == 3
    onset = mod.onset_rows()
    assert [r["variant"] for r in onset] == [
        "without contact",
        "contact, soft onset 0.2 delta",
        "contact, soft onset 0.2 delta from 1.02 (r_A + r_B)",
    ]
    for r in onset:  # the touching segments' gaps at the end: none without turns touching
        n = r["touching_segments_final"]
        assert n >= 0 and (n == 0) == math.isnan(r["touching_gap_median_final"])
    krylov = mod.krylov_rows()
    assert [r["variant"] for r in krylov] == ["without contact", "contact, GMRES to 0.2"]
    for rows in (near, seeds, onset, krylov):
        assert rows[0]["wall_ratio"] == pytest.approx(1.0)
        for r in rows:
            assert r["steps"] > 0 and r["newton_per_step"] >= 1.0 and r["wall_s"] > 0.0
            assert r["wall_ratio"] == pytest.approx(r["wall_s"] / rows[0]["wall_s"])


def test_the_ratio_part_pairs_each_seed_and_summarises_the_ratios(bench, monkeypatch):
    """``--part ratio`` on a tiny budget: without and with contact for each seed, back to
    back, each contact run's ratio against its own seed's run without; the summary's mean
    lies in its interval and the count within the goal is the count of such seeds."""
    mod = bench("contact_newton/contact_newton")
    monkeypatch.setattr(mod, "SCENE_DURATION_S", 0.02)
    monkeypatch.setattr(mod, "RATIO_SEEDS", (1, 2))
    rows = mod.ratio_report()  # the rows, with their summary printed
    assert [(r["seed"], r["variant"]) for r in rows] == [
        (1, "without contact"),
        (1, "contact"),
        (2, "without contact"),
        (2, "contact"),
    ]
    for without, contact in (rows[0:2], rows[2:4]):
        assert contact["wall_ratio"] == pytest.approx(contact["wall_s"] / without["wall_s"])
        for r in (without, contact):  # what the pile looks like, beside what it costs
            assert isinstance(r["regime"], str) and r["regime"]
            assert set(mod.OBSERVABLES) <= set(r)
            assert r["buckling_length_m"] > 0.0 or math.isnan(r["buckling_length_m"])
    synthetic = [
        {"variant": v, "wall_ratio": x}
        for x in (2.5, 3.5, 4.0)
        for v in ("without contact", "contact")
    ]
    m = mod.ratio_summary(synthetic)
    assert m["seeds"] == 3 and m["within_goal"] == 1  # only 2.5 is within 3x
    assert m["mean"] == pytest.approx(10.0 / 3.0)
    assert m["min"] == 2.5 and m["max"] == 4.0
    assert 2.5 <= m["low"] < m["mean"] < m["high"] <= 4.0


def test_the_observable_comparison_pairs_the_seeds_both_onsets_ran(bench):
    """What the pile looks like under two contact settings: the paired relative change over
    the seeds both ran (a seed missing from one set, or without the observable, drops out),
    its bootstrap interval, the first set's seed spread, and how many seeds keep the regime."""
    mod = bench("contact_newton/contact_newton")

    def row(seed, variant, radius_mm, regime="drag_coiling"):
        r = {"seed": seed, "variant": variant, "regime": regime}
        r |= {k: math.nan for k in mod.OBSERVABLES}
        r["coil_radius_m"] = radius_mm * 1e-3
        return r

    a = [row(0, "contact", 2.0), row(1, "contact", 2.2), row(2, "contact", 2.4)]
    a += [row(3, "contact", 9.9)]  # only in a: not paired
    a += [row(0, "without contact", 5.0)]  # another label: ignored
    b = [row(0, "soft", 2.2), row(1, "soft", 2.42), row(2, "soft", 2.4, "period_doubling")]
    out = {r["observable"]: r for r in mod.observable_comparison(a, "contact", b, "soft")}
    assert set(out) == {"coil_radius_m", "regime"}  # the all-NaN observables drop out
    r = out["coil_radius_m"]
    assert r["seeds"] == 3
    assert r["mean contact"] == pytest.approx(2.2e-3)
    assert r["mean soft"] == pytest.approx((2.2 + 2.42 + 2.4) * 1e-3 / 3)
    assert r["paired_change"] == pytest.approx(0.2 / 3)  # +10%, +10%, 0%
    assert (
        0.0
        <= r["paired_change_low"]
        <= r["paired_change"]
        <= r["paired_change_high"]
        <= 0.1 + 1e-12
    )
    assert r["seed_spread"] == pytest.approx(0.2 / 2.2)
    assert out["regime"] == {"observable": "regime", "seeds": 3, "same_regime": 2}


def _spy_scene_rows(mod, monkeypatch) -> list[tuple[dict, dict | None]]:
    """(variants, law) of each call of the bench's ``_scene_rows``, in order (it still runs)."""
    seen: list[tuple[dict, dict | None]] = []
    scene_rows = mod._scene_rows

    def spy(variants, seed=None, law=None):
        seen.append((variants, law))
        return scene_rows(variants, seed, law)

    monkeypatch.setattr(mod, "_scene_rows", spy)
    return seen


def test_the_ratio_parts_run_contact_by_its_defaults_and_by_its_sharp_onset(bench, monkeypatch):
    """``--part ratio`` runs contact's defaults (no law over them); ``--part ratio_sharp``
    the same pairing with the law before the onset before contact (SHARP_CONTACT), which
    the studies of the solver name. The onset before contact is the default law."""
    from bathprint import Simulation

    mod = bench("contact_newton/contact_newton")
    monkeypatch.setattr(mod, "SCENE_DURATION_S", 0.02)
    monkeypatch.setattr(mod, "RATIO_SEEDS", (3,))
    seen = _spy_scene_rows(mod, monkeypatch)
    mod.ratio_report()
    mod.ratio_wide_report()
    rows = mod.ratio_sharp_report()
    assert [law for _, law in seen] == [{}, mod.WIDE_AT_CONTACT, mod.SHARP_CONTACT]
    assert mod.WIDE_AT_CONTACT["contact.width_fraction"] == 0.2  # the default's width ...
    assert mod.WIDE_AT_CONTACT["contact.distance_factor"] == 1.0  # ... from r_A + r_B
    assert [(r["seed"], r["variant"]) for r in rows] == [
        (3, "without contact"),
        (3, mod.SHARP_LABEL),
    ]
    assert mod.SHARP_CONTACT["contact.width_fraction"] == 0.02
    assert mod.SHARP_CONTACT["contact.distance_factor"] == 1.0
    default = Simulation(mod.SCENE).scene.contact
    law = {"contact.width_fraction": default.width_fraction}
    law["contact.distance_factor"] = default.distance_factor
    assert law == mod.ONSET_BEFORE_CONTACT
    assert rows[1]["wall_ratio"] == pytest.approx(rows[1]["wall_s"] / rows[0]["wall_s"])
    assert mod.ratio_summary(rows, mod.SHARP_LABEL)["seeds"] == 1


def test_the_inertia_ratio_part_lists_inertia_in_every_run(bench, monkeypatch):
    """``--part ratio_inertia``: the paired seeds with ``inertia`` in every run, without
    contact, with contact's defaults (its dashpot on, by "auto") and with its sharp onset
    and no dashpot."""
    mod = bench("contact_newton/contact_newton")
    monkeypatch.setattr(mod, "SCENE_DURATION_S", 0.02)
    monkeypatch.setattr(mod, "RATIO_SEEDS", (2,))
    seen = _spy_scene_rows(mod, monkeypatch)
    rows = mod.inertia_report()
    labels = ["without contact", "contact", mod.SHARP_NO_DASHPOT_LABEL]
    assert [(r["seed"], r["variant"]) for r in rows] == [(2, label) for label in labels]
    variants, law = seen[0]
    assert law == {}
    assert all("inertia" in variants[label]["effects"] for label in labels)
    assert "contact" not in variants["without contact"]["effects"]
    assert variants["contact"] == {"effects": variants[mod.SHARP_NO_DASHPOT_LABEL]["effects"]}
    assert variants[mod.SHARP_NO_DASHPOT_LABEL]["contact.damping_time_s"] == 0.0
    for r in rows[1:]:
        assert r["wall_ratio"] == pytest.approx(r["wall_s"] / rows[0]["wall_s"])


def test_the_overdamped_dashpot_part_reports_how_far_each_run_gets(bench, monkeypatch):
    """``--part dashpot_overdamped``: one row per dashpot, the time reached, and no failure
    on a short run."""
    mod = bench("contact_newton/contact_newton")
    monkeypatch.setattr(mod, "SCENE_DURATION_S", 0.02)
    rows = mod.dashpot_overdamped_rows()
    assert [r["damping_time_s"] for r in rows] == list(mod.OVERDAMPED_DASHPOTS_S)
    for r in rows:
        assert r["reached_s"] == pytest.approx(0.02) and r["failure"] == ""
        assert r["steps"] > 0 and r["wall_s"] > 0.0


def test_every_coil_stack_stands_under_the_bath_surface(bench):
    """The tallest stack (10^4 nodes, pitch 1.5 contact distances, about 98 mm) keeps its top
    5 mm under the surface; a short one stands at 50 mm below it."""
    mod = bench("contact_cost/contact_cost")
    tall = mod.coil_stack(10_000, False, 1.5).centerline()
    surface = 0.0  # the free surface is at z = 0 (m)
    assert tall[:, 2].max() == pytest.approx(surface - 5e-3, abs=1e-9)
    short = mod.coil_stack(300, False, 1.5).centerline()
    assert short[:, 2].min() == pytest.approx(-50e-3, abs=1e-9)


def test_the_whole_run_part_lists_every_contact_scene_and_measures_its_gap(bench):
    """``--part whole`` on a tiny fraction of two scenes' durations: one row per scene with
    its frames' smallest gap (turns not yet touching: well above the contact distance)."""
    mod = bench("contact_cost/contact_cost")
    scenes = mod.contact_scenes()
    assert {"drag_coiling_22G", "period_doubling_22G", "chaotic_crumpling_22G"} <= set(scenes)
    assert "paper_simulation" not in scenes  # the minimal model lists no contact
    rows = mod.whole_runs(["drag_coiling_22G", "rope_coiling_18G"], fraction=0.02)
    assert [r["scene"] for r in rows] == ["drag_coiling_22G", "rope_coiling_18G"]
    for r in rows:
        assert r["frames"] >= 1 and r["steps"] > 0 and r["wall_s"] > 0.0
        assert r["min_gap_ratio"] > 0.9 and r["frames_below_0.9"] == 0


def test_the_late_part_starts_every_contact_variant_from_the_same_pile(bench, monkeypatch):
    """``--part late`` on a tiny budget: every field it changes exists in the compiled
    parameter record, the copies of one state give the same counts when nothing changes,
    and a changed field reaches the kernels."""
    from bathprint.core.layout import PARAMS_DTYPE

    mod = bench("contact_newton/contact_newton")
    fields = {f for v in mod.LATE_VARIANTS.values() for f in (v or {})}
    assert fields and fields <= set(PARAMS_DTYPE.names)
    monkeypatch.setattr(mod, "LATE_START_S", 0.15)  # the first turns touch
    monkeypatch.setattr(mod, "LATE_WINDOW_S", 0.01)
    monkeypatch.setattr(
        mod,
        "LATE_VARIANTS",
        {
            "without contact": None,
            "contact": {},
            "contact again": {},
            "full Newton": {"newton_reuse": 0.0},
        },
    )
    rows = mod.late_rows()
    assert [r["variant"] for r in rows] == list(mod.LATE_VARIANTS)
    assert rows[0]["wall_ratio"] == pytest.approx(1.0)
    same = ("steps", "newton_per_step", "jacobians_per_step", "krylov_per_newton")
    assert [rows[1][k] for k in same] == [rows[2][k] for k in same]
    assert rows[1]["nodes"] == rows[3]["nodes"]
    assert rows[3]["jacobians_per_step"] == pytest.approx(rows[3]["newton_per_step"])
    assert rows[1]["jacobians_per_step"] < rows[1]["newton_per_step"]  # modified Newton
    assert rows[0]["krylov_per_newton"] == 0.0 and rows[1]["krylov_per_newton"] > 0.5


def test_the_settled_part_times_its_window_at_the_steps_it_names(bench):
    """``--part settled``'s runs: the warm-up and the largest step reach the stack (the
    window takes at least as many steps as its length over that step)."""
    mod = bench("contact_cost/contact_cost")
    rows = mod.scaling([100], 1e-3, 0.98, "band", warm_up=1e-3, max_step=2.5e-4)
    (r,) = rows
    assert r["warm_up_s"] == 1e-3 and r["max_step_s"] == 2.5e-4 and r["window_s"] == 1e-3
    steps = r["wall_s_contact"] / (1e-6 * r["us_per_step_contact"])
    assert steps >= 1e-3 / 2.5e-4 - 1e-9
    assert r["newton_per_step_contact"] >= 1.0 and r["krylov_per_newton"] >= 1.0


def test_the_stacks_hold_the_sharp_onset_unless_given_contacts_defaults(bench):
    """The stacks are measured with the sharp onset (SHARP_CONTACT); ``law={}`` builds them
    with contact's defaults (``--part scaling_default``), and the rows say which."""
    mod = bench("contact_cost/contact_cost")
    sharp = mod.coil_stack(100, True, 0.98).model.p
    default = mod.coil_stack(100, True, 0.98, law={}).model.p
    assert (sharp.contact_width_fraction, sharp.contact_distance_factor) == (0.02, 1.0)
    assert (default.contact_width_fraction, default.contact_distance_factor) == (0.2, 1.02)
    (r,) = mod.scaling([100], 1e-3, 0.98, "band", warm_up=1e-3, law={})
    assert r["law"] == "default" and r["newton_per_step_contact"] >= 1.0


def test_the_stack_model_bounds_gmres_whatever_the_height(bench):
    """``stack_coupling``: a free stack's translation stretches no contact, so the condition
    number of the banded LU's preconditioned stack is near 1 + 4 a at every height; the
    iteration bound min(T, 1/2 sqrt(kappa) ln(2 / eps)) grows with the turns T up to the
    crossover and then stays; ``stack_turns`` counts the turns that ``coil_stack`` winds."""
    import numpy as np

    mod = bench("contact_cost/contact_cost")
    sim = mod.coil_stack(300, True, 0.98)
    centre = sim.centerline()
    angle = np.unwrap(np.arctan2(centre[:, 1], centre[:, 0]))
    turns = mod.stack_turns(300, 0.98)
    assert turns == pytest.approx((angle[-1] - angle[0]) / (2 * math.pi), rel=1e-6)
    h = 2.5e-4
    p = sim.model.params[0]
    a = float(p["contact_stiffness"]) * h / (2.0 * float(p["mu_s"]))
    eps = float(p["krylov_tolerance"])
    tall = mod.stack_coupling(sim, h, 1000.0)
    assert tall["stiffness_over_drag"] == pytest.approx(a, rel=1e-12)
    assert tall["kappa_model"] == pytest.approx(1.0 + 4.0 * a, rel=1e-3)
    assert tall["crossover_turns"] == pytest.approx(
        0.5 * math.sqrt(1.0 + 4.0 * a) * math.log(2.0 / eps), rel=1e-12
    )
    assert tall["krylov_bound"] == pytest.approx(tall["crossover_turns"], rel=1e-3)
    for t in (2, 5, 16):  # short stacks: the translation keeps kappa near its limit
        m = mod.stack_coupling(sim, h, t)
        assert 0.4 * (1.0 + 4.0 * a) < m["kappa_model"] < 1.0 + 4.0 * a
        # the translation's Rayleigh quotient bounds the smallest eigenvalue by 1 / (1 + 2a
        # (T - 1) / T), and the eigenvalues average 1 (the model's diagonal is 1)
        assert m["kappa_model"] >= (1.0 + 2.0 * a * (t - 1) / t) * (1.0 - 1e-9)
        assert m["krylov_bound"] == pytest.approx(float(t))
    finite_re = mod.coil_stack(100, True, 0.98, {"drag.model": "finite_re"})
    with pytest.raises(ValueError, match="drag model"):
        mod.stack_coupling(finite_re, h, 10.0)


def test_the_saturation_part_times_each_step_from_the_same_relaxed_stack(bench):
    """``--part saturation`` on a tiny stack: a row per step bound, each window's steps no
    longer than its bound, the model's columns filled."""
    mod = bench("contact_cost/contact_cost")
    rows = mod.saturation_rows([100], (2.5e-4, 1e-4), 1e-3, 1e-3, 1)
    assert [r["max_step_s"] for r in rows] == [2.5e-4, 1e-4]
    for r in rows:
        assert r["mean_step_s"] <= r["max_step_s"] * (1.0 + 1e-9)
        assert r["steps_contact"] >= 1e-3 / r["max_step_s"] - 1e-9
        assert r["krylov_per_newton"] >= 1.0 and r["newton_per_step_contact"] >= 1.0
        assert r["krylov_over_bound"] == pytest.approx(r["krylov_per_newton"] / r["krylov_bound"])
        assert r["pairs_per_segment"] >= r["near_per_segment"] > 0.0
        assert r["off_band_blocks_per_node"] > r["merged_blocks_per_node"] > 0.0
        assert r["ratio"] == pytest.approx(
            r["ns_per_node_step_contact"] / r["ns_per_node_step_none"]
        )


def test_the_hessian_part_runs_each_scene_with_both_hessians(bench):
    """``--part hessian`` on a tiny fraction of one scene: a row per Hessian, the default's
    first, the wall-time ratio against it, the scene's gaps kept."""
    mod = bench("contact_cost/contact_cost")
    rows = mod.hessian_rows(["drag_coiling_22G"], 0.02, 1)
    assert [r["hessian"] for r in rows] == ["exact", "gauss_newton"]
    assert rows[0]["wall_ratio"] == pytest.approx(1.0)
    assert rows[1]["wall_ratio"] == pytest.approx(rows[1]["wall_s"] / rows[0]["wall_s"])
    for r in rows:
        assert r["steps"] > 0 and r["newton_iterations"] >= r["steps"]
        assert r["min_gap_ratio"] > 0.9


def test_the_hydrodynamics_all_effects_part_changes_one_thing_per_variant(bench, monkeypatch):
    """``hydrodynamics.py all_effects``: the ablation's "all" run at d = 0.41 mm,
    0.5 ml/min as planned (the RPY kernel, finite-Re drag), and with contact's dashpot off,
    no contact, the lagged nonlocal flow, no hydrodynamics, Stokes drag or Stokeslet
    segments, each differing from it in that key only, and the Stokeslet segments without
    contact and with Stokes drag; on a tiny budget every variant runs to its end and counts
    its iterations."""
    mod = bench("hydrodynamics/hydrodynamics")
    monkeypatch.setattr(mod, "ALL_EFFECTS_DURATION_S", 0.004)
    variants = mod.all_effects_variants()
    base = variants["as in the ablation"]
    assert base["hydrodynamics.coupling"] == "implicit" and "inertia" in base["effects"]
    assert "contact" in base["effects"] and base["drag.model"] == "finite_re"
    assert base["hydrodynamics.kernel"] == "rpy"
    changed = {
        label: {k for k in {*over, *base} if over.get(k) != base.get(k)}
        for label, over in variants.items()
    }
    assert changed == {
        "as in the ablation": set(),
        "no dashpot": {"contact.damping_time_s"},
        "no contact": {"effects"},
        "lagged nonlocal flow": {"hydrodynamics.coupling"},
        "no hydrodynamics": {"effects"},
        "Stokes drag": {"drag.model"},
        "Stokeslet segments": {"hydrodynamics.kernel"},
        "Stokeslet segments, no contact": {"hydrodynamics.kernel", "effects"},
        "Stokeslet segments, Stokes drag": {"hydrodynamics.kernel", "drag.model"},
    }
    assert variants["Stokeslet segments"]["hydrodynamics.kernel"] == "slender_body"
    assert set(base["effects"]) - set(variants["no contact"]["effects"]) == {"contact"}
    assert set(base["effects"]) - set(variants["no hydrodynamics"]["effects"]) == {"hydrodynamics"}
    rows = mod.all_effects_rows()
    assert [r["variant"] for r in rows] == list(variants)
    assert all(r["failure"] == "" and r["reached_s"] == pytest.approx(0.004) for r in rows)
    for r in rows:
        assert r["steps"] > 0 and r["newton_iterations"] >= r["steps"]
        assert r["smallest_gap_ratio"] > 1.0  # a straight young jet: nothing near itself
    by = {r["variant"]: r for r in rows}
    assert by["as in the ablation"]["krylov_iterations"] > 0  # GMRES: the implicit flow


def test_the_hydrodynamics_mobility_part_takes_the_operator_and_puts_j_other_back(bench):
    """``hydrodynamics.py mobility``: I + R M W^-1 from the matrix-free product equals
    the nonlocal part of the Newton matrix with J_other the identity, and J_other is as it
    was afterwards (the run goes on as it would). Stokes drag here: with finite-Re drag the
    fast young jet screens its nonlocal flow (I + R M W^-1 is then the identity)."""
    mod = bench("hydrodynamics/hydrodynamics")
    over = {
        **mod.all_effects_variants()["Stokeslet segments, no contact"],
        "duration_s": 0.05,
        "drag.model": "cox",
    }
    sim = Simulation(ablation.SCENE, over)
    sim.advance(0.05)
    sim.forces(1.0, 1.0, 1.0, True)
    band_other = sim.ws.hydro.band_other.copy()
    op = mod.mobility_operator(sim)  # (the bench imports it from analysis.validation)
    np.testing.assert_array_equal(sim.ws.hydro.band_other, band_other)
    nd = op.shape[0]
    x = np.random.default_rng(5).normal(size=nd)
    y = np.zeros(nd)
    hydrodynamics.apply_nonlocal(sim.ws, nd, x, y)  # R M W^-1 J_other x
    j_other = np.zeros((nd, nd))
    for i in range(nd):
        for j in range(max(0, i - L.KL), min(nd, i + L.KU + 1)):
            j_other[i, j] = band_other[i, j - i + L.KL]
    jx = j_other @ x
    np.testing.assert_allclose(op @ jx, jx + y, rtol=1e-9, atol=1e-9 * np.abs(jx + y).max())
    assert np.abs(op - np.eye(nd)).max() > 1e-6  # the nonlocal flow is there


def test_the_onset_buckling_part_pairs_the_two_onsets_seed_by_seed(bench, monkeypatch):
    """``contact_newton.py --part onset_buckling``: per seed, the onset widened at the
    sum of the radii and the default's (started before contact), the buckling length of the
    last frame and its mean over the frames from the average's start; the comparison pairs
    them seed by seed."""
    mod = bench("contact_newton/contact_newton")
    monkeypatch.setattr(mod, "SCENE_DURATION_S", 0.3)
    monkeypatch.setattr(mod, "RATIO_SEEDS", (1, 2))
    monkeypatch.setattr(mod, "ONSET_FRAME_INTERVAL_S", 0.1)
    monkeypatch.setattr(mod, "ONSET_AVERAGE_FROM_S", 0.1)
    first, second = mod.ONSET_LAWS.values()
    assert first["contact.distance_factor"] == 1.0 and first["contact.width_fraction"] == 0.2
    assert second == {}  # contact's defaults: the onset from 1.02 (r_A + r_B)
    rows = mod.onset_buckling_rows()
    assert [(r["seed"], r["onset"]) for r in rows] == [
        (s, label) for s in (1, 2) for label in mod.ONSET_LAWS
    ]
    for r in rows:
        assert r["frames_averaged"] == 3  # 0.1, 0.2 and 0.3 s: the jet has buckled
        assert 0 < r["buckling_length_final_m"] < 0.05
        assert 0 < r["buckling_length_mean_m"] < 0.05
    comp = {c["quantity"]: c for c in mod.onset_buckling_comparison(rows)}
    rel = [
        rows[2 * i + 1]["buckling_length_mean_m"] / rows[2 * i]["buckling_length_mean_m"] - 1
        for i in range(2)
    ]
    assert comp["buckling_length_mean_m"]["paired_change"] == pytest.approx(np.mean(rel))
    c = comp["buckling_length_final_m"]
    assert (
        c["seeds"] == 2 and c["paired_change_low"] <= c["paired_change"] <= c["paired_change_high"]
    )


def test_the_hydrodynamics_kernels_part_compares_both_kernels(bench, monkeypatch):
    """``hydrodynamics.py kernels`` on a tiny budget: a rod's drags over Tirado's and
    the coil's mobility for each kernel (turns through each other: the Stokeslet segments'
    operator has an eigenvalue of negative real part, the RPY blobs' does not), and the
    times of one evaluation of each."""
    mod = bench("hydrodynamics/hydrodynamics")
    monkeypatch.setattr(mod, "KERNEL_RODS", ((20, 1),))
    monkeypatch.setattr(mod, "KERNEL_PITCHES_MM", (0.0,))
    monkeypatch.setattr(mod, "KERNEL_COST_N", (100,))
    drag = mod.kernel_drag_rows()
    assert [r["kernel"] for r in drag] == ["slender_body", "rpy"]
    for r in drag:
        assert abs(r["along_over_tirado"] - 1) < 0.1 and abs(r["across_over_tirado"] - 1) < 0.1
    mob = {r["kernel"]: r for r in mod.kernel_mobility_rows()}
    assert mob["slender_body"]["eig_real_min"] < 0 < mob["rpy"]["eig_real_min"]
    assert mob["rpy"]["mobility_min_over_max"] > 0 and mob["rpy"]["asymmetry"] < 1e-12
    (cost,) = mod.kernel_cost_rows()
    assert cost["N"] == 100 and min(cost["slender_body_s"], cost["rpy_s"]) > 0
    assert cost["rpy_over_slender_body"] == pytest.approx(
        (cost["rpy_s"] + cost["rpy_gates_s"]) / cost["slender_body_s"]
    )


def test_the_failing_solve_parts_stokes_window_is_the_finite_re_law_at_rest(bench):
    """``hydrodynamics.py failing_solve`` compares each node's linearised resistance
    with its Stokes window's: at rest (relative velocity zero) the finite_re law's
    linearisation is that window's resistance, node by node."""
    mod = bench("hydrodynamics/hydrodynamics")
    phi = np.linspace(0.0, 4 * math.pi, 40)
    points = np.column_stack([3e-3 * np.cos(phi), 3e-3 * np.sin(phi), 0.5e-3 * phi])
    sim = Simulation.from_points(
        points,
        "paper_simulation",
        {
            "effects": ["elasticity", "drag", "hydrodynamics"],
            "hydrodynamics.coupling": "implicit",
            "drag.model": "finite_re",
        },
    )
    sim.model.enabled[L.E_ELASTICITY] = 0  # no force: no flow, nothing moves relative to it
    sim.vel[:] = 0.0
    sim.forces(1.0, 1.0, 1.0, True)
    nf = int(sim.ws.hydro.memory[0]["lin_free"])
    stokes = mod._stokes_window_resistance(sim, nf)
    resist = sim.ws.hydro.resist[:nf]
    np.testing.assert_allclose(resist, stokes, rtol=1e-6, atol=1e-9 * np.abs(stokes).max())


def test_the_hydrodynamics_kernel_coils_part_runs_each_kernel_at_each_point(bench, monkeypatch):
    """``hydrodynamics.py kernel_coils`` on a tiny budget: the ablation's contact +
    finite-Re + nonlocal run at one point, with each kernel (differing in the kernel only),
    records its steps and measurements."""
    mod = bench("hydrodynamics/hydrodynamics")
    monkeypatch.setattr(mod, "KERNEL_COIL_POINTS", ((0.41, 1.0),))
    monkeypatch.setattr(mod, "KERNEL_COIL_DURATION_S", 0.004)
    rows = mod.kernel_coil_rows()
    assert [r["kernel"] for r in rows] == ["slender_body", "rpy"]
    for r in rows:
        assert r["steps"] > 0 and r["wall_s"] > 0
        assert r["regime"] == "straight" and r["coil_radius_m"] is None  # a young jet

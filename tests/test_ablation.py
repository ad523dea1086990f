"""`bathprint reproduce ablation` and `reproduce gravity` in quick mode (tiny budgets), and the
study's pieces on rows with known answers."""

from __future__ import annotations

import csv
import json
import math

import pytest

from bathprint.analysis import theory
from bathprint.cli import main
from bathprint.studies.reproduce import ablation, fast_jets, fig2, gravity
from bathprint.studies.reproduce.ablation import Variant


def _read_csv(path) -> list[dict]:
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def test_quick_ablation_writes_its_outputs_and_resumes(tmp_path) -> None:
    argv = ["reproduce", "ablation", "--quick", "--out", str(tmp_path), "--scheduler", "serial"]
    assert main(argv) == 0
    rows = _read_csv(tmp_path / "ablation.csv")
    n_points = sum(len(pts) for pts, _ in ablation.QUICK.values())
    names = [v.name for v in (*ablation.VARIANTS, *ablation.COMBINATIONS)]
    names += [ablation.ALL, ablation.ALL_LIQUID]
    assert len(rows) == n_points * len(names)
    assert [r["variant"] for r in rows[: len(names)]] == names
    planned, missing = ablation.plan(quick=True)
    pair = [r for r in planned if r["variant"] == "finite_re_hydrodynamics"]
    assert pair and all(r["overrides"]["drag.model"] == "finite_re" for r in pair)
    for r in planned:  # "all" is built from VARIANTS only: the combination adds no entry
        if r["variant"] == ablation.ALL:
            effects = r["overrides"]["effects"]
            assert len(effects) == len(set(effects)), effects
    base = set(ablation.BASE_EFFECTS)
    available = [v for v in ablation.VARIANTS if v.name not in missing]
    for r in rows:
        if r["variant"] in missing:  # the scene refuses the variant's keys: said so
            assert r["status"] == "not available" and r["error"] == missing[r["variant"]]
            continue
        assert r["status"] == "ok", r
        effects = set(r["effects"].split())
        assert base <= effects
        if r["variant"] == "finite_re_hydrodynamics":
            assert effects - base - {"floor"} == {"hydrodynamics"}
        if r["variant"] == "contact_finite_re_hydrodynamics":
            assert effects - base - {"floor"} == {"contact", "hydrodynamics"}
        if r["variant"] in (ablation.ALL, ablation.ALL_LIQUID):
            liquid = {"liquid"} if r["variant"] == ablation.ALL_LIQUID else set()
            assert effects == base | {e for v in available for e in v.effects} | liquid | (
                {"floor"} if r["set"] == "fig1b" else set()
            )
        gap = float(r["min_gap_ratio"])
        assert 0.0 <= gap <= 2.0
        assert r["interpenetrates"] == str(gap < ablation.INTERPENETRATION_RATIO)
    md = (tmp_path / "ablation.md").read_text()
    assert "## Relative change against the baseline" in md and "## Every run" in md
    for v in (*ablation.VARIANTS, *ablation.COMBINATIONS):
        assert v.label in md
    assert (tmp_path / "ablation.png").stat().st_size > 10_000
    report = json.loads((tmp_path / "reproduce.json").read_text())
    assert report["ablation"]["result"]["not_available"] == missing

    runs = (tmp_path / "ablation_runs.jsonl").read_text()
    before = (tmp_path / "ablation.csv").read_text()
    assert main(argv) == 0  # resumed: every run is in the results file already
    assert (tmp_path / "ablation_runs.jsonl").read_text() == runs
    assert (tmp_path / "ablation.csv").read_text() == before


def test_a_variant_the_scene_refuses_is_not_available_and_left_out_of_all(monkeypatch) -> None:
    bogus = Variant("bogus", "+ bogus", ("no_such_effect",))
    keyed = Variant("keyed", "+ keyed", (), {"drag.no_such_key": 1.0})
    monkeypatch.setattr(ablation, "VARIANTS", (*ablation.VARIANTS[:2], bogus, keyed))
    runs, missing = ablation.plan(quick=True)
    assert "no_such_effect" in missing["bogus"] and "drag.no_such_key" in missing["keyed"]
    assert ablation.ALL not in missing
    # without the viscosity effect in "all" the scene refuses liquid: said so, not run
    assert "'liquid' needs 'viscosity'" in missing[ablation.ALL_LIQUID]
    for r in runs:
        if r["variant"] in ("bogus", "keyed", ablation.ALL_LIQUID):
            assert r["overrides"] is None
        elif r["variant"] == ablation.ALL:
            assert r["overrides"]["effects"][-1] == "inertia"
            assert "drag.no_such_key" not in r["overrides"]
        elif r["variant"] == "inertia":
            assert r["overrides"]["effects"][-1] == "inertia"
        elif r["variant"] in ("finite_re_hydrodynamics", "contact_finite_re_hydrodynamics"):
            assert r["overrides"]["effects"][-1] == "hydrodynamics"  # a combination
        else:
            assert r["overrides"]["effects"][-1] in ("gravity", "floor")


def test_all_liquid_is_all_plus_the_liquid_effect_at_its_defaults() -> None:
    runs, missing = ablation.plan()
    assert ablation.ALL_LIQUID not in missing
    by_key = {(r["set"], r["point"], r["variant"]): r for r in runs}
    liquid_runs = [r for r in runs if r["variant"] == ablation.ALL_LIQUID]
    assert len(liquid_runs) == sum(len(pts) for pts, _ in ablation.FULL.values())
    for r in liquid_runs:
        same = by_key[(r["set"], r["point"], ablation.ALL)]
        assert r["skipped"] == same["skipped"]  # nonlocal: the same points as "all"
        if r["overrides"] is None:
            continue
        assert r["overrides"]["effects"] == [*same["overrides"]["effects"], "liquid"]
        assert {k: v for k, v in r["overrides"].items() if k != "effects"} == {
            k: v for k, v in same["overrides"].items() if k != "effects"
        }
        assert not any(k.startswith("liquid.") for k in r["overrides"])  # its defaults
    others = [r for r in runs if r["variant"] != ablation.ALL_LIQUID and r["overrides"]]
    assert others and all("liquid" not in r["overrides"]["effects"] for r in others)


def _table_row(variant: str, point: float, **values) -> dict:
    row = {
        "set": "fig2",
        "diameter_mm": point,
        "q_outer_ml_min": 1.0,
        "variant": variant,
        "status": "ok",
        "regime": "drag_coiling",
        "interpenetrates": False,
    }
    row.update({column: None for column, _ in ablation.QUANTITIES})
    row.update(values)
    return row


def test_effect_table_reports_relative_changes_against_the_baseline() -> None:
    table = [
        _table_row("stokes", 1, l_m=10.0, R_m=4.0, interpenetrates=True),
        _table_row("contact", 1, l_m=12.0, R_m=4.0),
        _table_row("stokes", 2, l_m=20.0, R_m=None),
        _table_row("contact", 2, l_m=18.0, R_m=5.0, regime="period_doubling"),
        _table_row("stokes", 3, l_m=5.0, status="failed", regime=None),
        _table_row("contact", 3, l_m=10.0, interpenetrates=True),
    ]
    effects = ablation.effect_table(table)
    assert effects["stokes"]["l_m"] is None  # the baseline against itself
    assert effects["stokes"]["interpenetrating_runs"] == 1 and effects["stokes"]["runs_ok"] == 2
    l_change = effects["contact"]["l_m"]
    assert l_change["n"] == 3
    assert l_change["min"] == pytest.approx(-0.1) and l_change["max"] == pytest.approx(1.0)
    assert l_change["median"] == pytest.approx(0.2)
    assert effects["contact"]["R_m"] == {"median": 0.0, "min": 0.0, "max": 0.0, "n": 1}
    assert effects["contact"]["regime_changes"] == 1  # the failed baseline is not compared
    assert effects["contact"]["interpenetrating_runs"] == 1


def test_fig2_fits_recover_known_prefactors() -> None:
    table = []
    for d, q in [(0.26, 0.3), (0.41, 1.0), (0.84, 2.0)]:
        over = {"needle.inner_diameter_mm": d, "flow.q_outer_ml_min": q}
        scales = fig2.law_row(over, None)
        r = 0.5 * scales["scale_B_mu_v_m"]
        result = {
            "measurements.buckling_length_m": 3.0 * r,
            "measurements.buckling_length_2r_m": 0.5 * r,
            "measurements.buckling_length_quarter_m": 1.0 * r,
            "measurements.coil_radius_m": r,
            "measurements.coil_frequency_rad_s": 2.0 * scales["scale_omega_rad_s"],
            "measurements.omega_r_over_v": 0.9 + 0.1 * len(table),
        }
        table.append(fig2.law_row(over, result))
    fits = fig2.fit_laws(table)
    assert fits["l_over_R"] == pytest.approx(3.0)
    assert fits["R_prefactor"] == pytest.approx(0.5)
    assert fits["omega_prefactor"] == pytest.approx(2.0)
    assert fits["points"] == {"l_R": 3, "R": 3, "omega": 3}
    # l under the other definitions; the full-radius one was not measured
    by_def = fits["l_over_R_by_definition"]
    assert by_def["inset"] == pytest.approx(3.0)
    assert by_def["two_radii"] == pytest.approx(0.5)
    assert by_def["quarter"] == pytest.approx(1.0)
    assert math.isnan(by_def["full_radius"])
    assert fits["l_over_R_points"] == {"inset": 3, "two_radii": 3, "quarter": 3, "full_radius": 0}
    # the paper's B = E r^4 is 4/pi times bathprint's E pi r^4 / 4: b scales by (pi/4)^(1/3),
    # c by (4/pi)^(1/3), each fitted on its own scale
    assert fits["R_prefactor_paper_B"] == pytest.approx(0.5 * (math.pi / 4) ** (1 / 3))
    assert fits["omega_prefactor_paper_B"] == pytest.approx(2.0 * (4 / math.pi) ** (1 / 3))
    assert fits["omega_R_over_v_median"] == pytest.approx(1.0)
    assert math.isnan(fig2.fit_laws([])["l_over_R"])


def test_the_paper_b_convention_reproduces_its_worked_example() -> None:
    """The paper's l ~ 22 mm at E = 2.7 kPa, r = 0.5 mm, mu = 1 mPa s, v = 15 mm/s holds with
    its B = E r^4 and not with E pi r^4 / 4 (fig2's docstring)."""
    scale = theory.buckling_length_scale(fig2.paper_bending_stiffness(2700.0, 5e-4), 1e-3, 0.015)
    ours = theory.buckling_length_scale(theory.bending_stiffness(2700.0, 5e-4), 1e-3, 0.015)
    assert abs(scale * 1e3 - 22.0) < 0.5  # 22.4 mm
    assert abs(ours * 1e3 - 22.0) > 1.0  # 20.7 mm


def test_quick_gravity_writes_its_outputs(tmp_path) -> None:
    argv = ["reproduce", "gravity", "--quick", "--out", str(tmp_path), "--scheduler", "serial"]
    assert main(argv) == 0
    rows = _read_csv(tmp_path / "gravity.csv")
    assert len(rows) == len(gravity.QUICK["points"]) * len(gravity.QUICK["drho"])
    for r in rows:
        assert r["status"] == "ok"
        l_u, l_d = float(r["universal_scale_m"]), float(r["drag_scale_m"])
        if float(r["drho_kg_m3"]) == 0.0:
            assert l_u == pytest.approx(l_d, rel=1e-12)
        else:  # gravity adds to the drag: a shorter scale, by the stated ratio
            ratio = float(r["gravity_over_drag"])
            assert l_u / l_d == pytest.approx((1.0 + ratio) ** (-1 / 3), rel=1e-9)
    assert (tmp_path / "gravity.png").stat().st_size > 10_000


def test_scales_of_the_gravity_study() -> None:
    l_u, l_d = gravity.scales(0.84, 0.5, 3.0)
    # B = E pi r^4 / 4 with E = 2.7 kPa, r = 0.42 mm; v = Q / (pi d^2 / 4)
    b = 2700.0 * math.pi * 0.42e-3**4 / 4
    v = 0.5e-6 / 60 / (math.pi * 0.84e-3**2 / 4)
    assert l_d == pytest.approx((b / (1e-3 * v)) ** (1 / 3), rel=1e-12)
    assert l_u == pytest.approx((b / (1e-3 * v + 3.0 * 9.81 * 0.42e-3**2)) ** (1 / 3), rel=1e-12)


def test_the_studies_refuse_bad_options(capsys) -> None:
    for study in ("ablation", "gravity"):
        assert main(["reproduce", study, "--workers", "0"]) == 2
        err = capsys.readouterr().err
        assert "--workers" in err and err.count("\n") == 1


def test_the_cost_probe_times_every_variant_at_one_point() -> None:
    costs = ablation.time_variants("fig2", ablation.QUICK["fig2"][0][0], quick=True)
    _, missing = ablation.plan(quick=True)
    variants = (*ablation.VARIANTS, *ablation.COMBINATIONS)
    assert list(costs) == [v.name for v in variants] + [ablation.ALL, ablation.ALL_LIQUID]
    for name, c in costs.items():
        if name in missing:
            assert c["error"].startswith("not available")
        else:
            assert c["wall_s"] > 0 and c["nodes"] > 2 and c["regime"]
            assert c["simulated_s"] == pytest.approx(costs[ablation.BASELINE]["simulated_s"])
    with pytest.raises(ValueError, match="not in the 'fig2' set"):
        ablation.time_variants("fig2", (9.0, 9.0), quick=True)


def test_quick_fast_jets_writes_its_table(tmp_path) -> None:
    argv = ["reproduce", "fast_jets", "--quick", "--out", str(tmp_path), "--scheduler", "serial"]
    assert main(argv) == 0
    rows = _read_csv(tmp_path / "fast_jets.csv")
    assert [r["variant"] for r in rows] == list(fast_jets.QUICK_NAMES)
    for r in rows:
        assert r["status"] == "ok" and r["imperfection_um"] == "1.0"
    text = (tmp_path / "fast_jets.md").read_text()
    assert "+ solution viscosity" in text and "paper: period_doubling" in text
    # the full plan: every combination at both points with both seeds, the seed set as asked
    full = fast_jets.plan()
    assert len(full) == 2 * 2 * len(fast_jets.COMBINATIONS)
    assert {r["over"]["needle.imperfection_um"] for r in full} == {1.0, 20.0}
    assert all("viscosity" in r["over"]["effects"] for r in full if "viscosity" in r["name"])


def test_a_failure_message_gives_time_node_and_cause() -> None:
    msg = (
        "simulation diverged at t = 0.00341 s, node 70: segment strain beyond "
        "numerics.max_strain even at the smallest allowed time step"
    )
    t, node, cause = fast_jets.failure(msg)
    assert t == pytest.approx(0.00341) and node == 70
    assert cause.startswith("segment strain beyond")
    assert fast_jets.failure(None) == (None, None, None)
    assert fast_jets.failure("something else") == (None, None, "something else")

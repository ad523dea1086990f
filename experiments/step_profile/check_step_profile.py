"""The step profile (``step_profile.py``) on tiny budgets: it replays the
integrator's Python source with counting wrappers (which breaks silently when a kernel it
does not replay calls a patched one), and its breakdown adds up."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1]  # experiments/


@pytest.fixture
def bench(load_script, monkeypatch):
    monkeypatch.syspath_prepend(str(BENCH))  # the script imports _common
    mod = load_script(BENCH / "step_profile" / "step_profile.py")
    monkeypatch.setattr(mod, "ROUNDS", 1)
    return mod


def _by_component(rows: list[dict]) -> dict[str, dict]:
    return {r["component"]: r for r in rows}


def _adds_up(rows: dict[str, dict]) -> None:
    """The parts and "other" make the whole step; every count and cost is finite."""
    whole = rows["whole step"]["us_per_step"]
    assert whole > 0.0
    parts = sum(r["us_per_step"] for k, r in rows.items() if k != "whole step")
    assert parts == pytest.approx(whole, rel=1e-6, abs=0.05)
    for k, r in rows.items():
        if k not in ("other", "whole step"):
            assert math.isfinite(r["calls_per_step"]) and r["calls_per_step"] >= 0.0, k
            assert math.isfinite(r["us_per_call"]) and r["us_per_call"] >= 0.0, k


def test_a_pile_with_contact_is_profiled_with_its_krylov_iterations(bench, monkeypatch):
    monkeypatch.setattr(bench, "PILE_T_S", 0.08)  # the first turns touch at about 0.07 s
    make, _ = bench.CASES["pile, contact"]
    base = make()
    rows = _by_component(bench.profile("pile, contact", base, 0.003))
    _adds_up(rows)
    assert rows["contact: prepare"]["calls_per_step"] >= 1.0  # one per attempt
    assert rows["contact: check"]["calls_per_step"] >= 1.0
    assert rows["contact: rebuild"]["calls_per_step"] > 0.0  # nodes are born: pairs found anew
    assert rows["assemble+J: contact"]["us_per_call"] > 0.0
    assert rows["krylov iterations"]["calls_per_step"] > 0.0  # GMRES: couplings off the band
    assert rows["krylov iterations"]["us_per_call"] > 0.0
    assert rows["solve (Newton)"]["calls_per_step"] == 0.0  # counted as Krylov iterations
    assert rows["whole step"]["newton_per_step"] >= 1.0


def test_a_fixed_step_state_without_contact_solves_on_the_band(bench):
    base = bench._sagging(100)
    base.advance(base.t + 2 * bench.STEP_S)
    rows = _by_component(bench.profile("sag N=100", base, 3 * bench.STEP_S))
    _adds_up(rows)
    assert "contact: prepare" not in rows
    assert rows["krylov iterations"]["calls_per_step"] == 0.0
    assert rows["solve (Newton)"]["calls_per_step"] >= 1.0
    assert rows["whole step"]["newton_per_step"] >= 1.0

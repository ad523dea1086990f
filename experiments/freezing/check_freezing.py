"""Hand-run checks of freezing.py's parts on fake runs (``python -m pytest
check_freezing.py``; not part of the test suite)."""

from __future__ import annotations

from pathlib import Path

import pytest


def _bench_freezing(load_script, monkeypatch):
    """``freezing.py`` as a module (it imports contact_newton.py)."""
    here = Path(__file__).resolve().parent
    monkeypatch.syspath_prepend(str(here.parent))
    return load_script(here / "freezing.py")


def test_the_damping_part_pairs_freezing_and_the_tolerance_with_each_variant(
    load_script, monkeypatch
):
    """``bench_freezing.py --part damping``: for each variant and seed, the draft, frozen and
    tighter runs carry the variant's contact keys and inertia (or not), and the changes are
    ratios to the draft run (fake radii)."""
    mod = _bench_freezing(load_script, monkeypatch)
    calls = []

    def fake(over: dict, duration_s: float) -> float:
        calls.append(over)
        if over.get("numerics.tolerance") == 1e-3:
            return 1.02e-3
        return 0.99e-3 if over.get("numerics.freeze_beyond_mm") == 100.0 else 1.0e-3

    monkeypatch.setattr(mod, "_near_needle_radius", fake)
    rows = mod.damping_table(n_seeds=2, duration_s=1.0)
    assert [(r["variant"], r["seed"]) for r in rows] == [
        (label, seed) for label, _, _ in mod.DAMPING_VARIANTS for seed in (0, 1)
    ]
    for r in rows:
        assert r["frozen_100mm_change"] == pytest.approx(-0.01)
        assert r["tighter_change"] == pytest.approx(0.02)
    assert len(calls) == 3 * len(rows)
    for k, (label, inertia, contact) in enumerate(mod.DAMPING_VARIANTS):
        mine = calls[6 * k : 6 * (k + 1)]
        assert all(("inertia" in c["effects"]) == inertia for c in mine), label
        assert all(c[key] == v for c in mine for key, v in contact.items()), label


def test_the_onset_part_pairs_each_measurement_with_its_own_onset(load_script, monkeypatch):
    """``bench_freezing.py --part onset``: for each onset and seed, every run gets the
    onset's contact keys, inertia and the seed; the changes are the ratios to the runs
    without freezing of the same joint (fake radii); and one real draft run measures the
    coil at the needle."""
    mod = _bench_freezing(load_script, monkeypatch)
    calls = []

    def fake(over: dict, duration_s: float) -> float:
        calls.append(over)
        if over.get("numerics.tolerance") == 1e-3:
            return 1.02e-3  # the tighter run
        mm = over["numerics.freeze_beyond_mm"]
        return {0.0: 1.0e-3, 60.0: 1.04e-3, 100.0: 0.99e-3, 150.0: 1.005e-3}[mm]

    real = mod._near_needle_radius
    monkeypatch.setattr(mod, "_near_needle_radius", fake)
    rows = mod.onset_table(n_seeds=2, duration_s=1.0)
    assert [(r["onset"], r["seed"]) for r in rows] == [
        (label, seed) for label, _ in mod.ONSET_VARIANTS for seed in (0, 1)
    ]
    for r in rows:
        assert r["frozen_100mm_change"] == pytest.approx(-0.01)
        assert r["tighter_change"] == pytest.approx(0.02)
        assert r["free_60mm_change"] == pytest.approx(0.04)
        assert r["clamped_60mm_change"] == pytest.approx(0.04)
    assert len(calls) == 7 * len(rows)
    for label, onset in mod.ONSET_VARIANTS:
        mine = [c for c in calls if all(c.get(k) == v for k, v in onset.items())]
        assert len(mine) >= 14 and all("inertia" in c["effects"] for c in mine), label
    assert {c["numerics.freeze_joint"] for c in calls} == {"auto", "free", "clamped"}
    radius = real({"numerics.accuracy": "draft", "seed": 0}, 3.0)
    assert 1e-3 < radius < 5e-3  # the 22G coil at 0.5 ml/min: about 2.3 mm
    calls.clear()  # --part onset_wide: the onset widened at the sum of the radii
    wide = mod.onset_table(n_seeds=1, duration_s=1.0, variants=mod.ONSET_WIDE_VARIANTS)
    assert [r["onset"] for r in wide] == [label for label, _ in mod.ONSET_WIDE_VARIANTS]
    assert {c["contact.width_fraction"] for c in calls} == {0.2}
    assert {c["contact.distance_factor"] for c in calls} == {1.0}

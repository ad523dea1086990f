"""Hand-run check of inertia_impact.py on a tiny budget (``python -m pytest
check_inertia_impact.py``; not part of the test suite)."""

from __future__ import annotations

import pytest


def test_inertia_impact_traces_the_fast_jets_frame_by_frame(tmp_path, load_script):
    """inertia_impact.py with a tiny budget: the four '+ inertia' runs of the
    fast-jets study, each recorded at every frame (tip height above the floor, tip speed)."""
    import csv
    from pathlib import Path

    mod = load_script(Path(__file__).resolve().parent / "inertia_impact.py")
    out = tmp_path / "impact.csv"
    assert mod.main(["--duration-s", "0.003", "--out", str(out)]) == 0
    rows = list(csv.DictReader(out.open()))
    assert {(r["q_outer_ml_min"], r["seed_um"]) for r in rows} == {
        ("5.0", "1.0"), ("5.0", "20.0"), ("20.0", "1.0"), ("20.0", "20.0")
    }
    assert all(r["end"] == "completed" for r in rows)
    for q, speed in (("5.0", 0.63), ("20.0", 2.52)):  # the exit speed Q / (pi d^2 / 4)
        first = next(r for r in rows if r["q_outer_ml_min"] == q)
        assert float(first["tip_speed_m_s"]) == pytest.approx(speed, rel=0.03)
        assert 0.025 < float(first["tip_height_m"]) < 0.030  # needle 30 mm above the floor

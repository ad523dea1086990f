"""hindsight.py on a tiny batch: one row per version-1 environment, the
compiled hindsight rewards identical to the sample-by-sample ones."""

from __future__ import annotations

from pathlib import Path

BENCH = Path(__file__).resolve().parents[1]  # experiments/


def test_the_hindsight_benchmark_compares_identical_rewards(load_script, monkeypatch) -> None:
    monkeypatch.syspath_prepend(str(BENCH))
    mod = load_script(BENCH / "hindsight" / "hindsight.py")
    rows = mod.rows(batch=8, repeats=1)
    assert [r["env_id"] for r in rows] == list(mod.V1)
    for r in rows:
        assert r["identical"] and r["batch"] == 8
        assert r["python_ms"] > 0.0 and r["compiled_ms"] > 0.0

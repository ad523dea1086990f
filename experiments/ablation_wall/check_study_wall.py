"""study_wall.py: a study's wall time and worker time from its run log, and the
runs whose measurements match the reference study's."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parent / "study_wall.py"


def _log(path: Path, runs: list[tuple[str, str, float, float]]) -> None:
    """runs: (run_id, finished_at, wall_time_s, a measurement)."""
    path.mkdir(parents=True, exist_ok=True)
    lines = [
        json.dumps({"run_id": rid, "status": "ok", "error": None, "wall_time_s": wall,
                    "finished_at": end, "result": {"wall_time_s": wall / 2, "m": m}})
        for rid, end, wall, m in runs
    ]  # fmt: skip
    (path / "ablation_runs.jsonl").write_text("\n".join(lines) + "\n")


def test_wall_span_worker_time_and_identical_measurements(tmp_path, load_script):
    mod = load_script(SCRIPT)
    _log(tmp_path / "ref", [("a", "2026-01-01T10:00:10+00:00", 9.0, 1.0),
                            ("b", "2026-01-01T10:00:20+00:00", 5.0, 2.0)])  # fmt: skip
    # two workers: a runs 0-10 s, b 5-15 s (timings differ from the reference's, b's value too)
    _log(tmp_path / "new", [("a", "2026-01-01T12:00:10+00:00", 10.0, 1.0),
                            ("b", "2026-01-01T12:00:15+00:00", 10.0, 2.5)])  # fmt: skip
    ref = {r["run_id"]: r for r in mod.read_runs(tmp_path / "ref", "ablation")}
    row = mod.summarise("pool", mod.read_runs(tmp_path / "new", "ablation"), ref)
    assert row["wall_s"] == pytest.approx(15.0)
    assert row["worker_s"] == pytest.approx(20.0)
    assert row["same_as_reference"] == 1 and row["runs"] == 2


def test_a_log_of_two_sessions_is_refused(tmp_path, load_script):
    mod = load_script(SCRIPT)
    _log(tmp_path / "x", [("a", "2026-01-01T10:00:10+00:00", 10.0, 1.0),
                          ("b", "2026-01-02T10:00:10+00:00", 10.0, 1.0)])  # fmt: skip
    runs = mod.read_runs(tmp_path / "x", "ablation")
    with pytest.raises(SystemExit, match="more than one session"):
        mod.summarise("x", runs, {})

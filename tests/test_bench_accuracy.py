"""A tiny run of the work-precision study (``bathprint bench accuracy --quick``)."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest

import bathprint.studies.accuracy as B
from bathprint.studies.accuracy import QUICK, Row, curve, is_monotone, main, plan_size


def _rows(path: Path) -> list[Row]:
    with path.open() as f:
        return [
            Row(
                r["problem"],
                r["integrator"],
                r["refine"],
                r["knob"],
                float(r["value"]),
                float(r["wall_s"]),
                float(r["error"]),
            )
            for r in csv.DictReader(f)
        ]


def test_quick_run_writes_files_converges_and_resumes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    assert main(["--quick", "--out", str(tmp_path)]) == 0
    for name in ("accuracy.csv", "presets.csv", "accuracy.png"):
        assert (tmp_path / name).stat().st_size > 0
    # every point is stored as it finishes, so that an interrupted study resumes
    points = (tmp_path / "points_quick.jsonl").read_text().splitlines()
    assert len(points) == plan_size(QUICK)
    rows = _rows(tmp_path / "accuracy.csv")
    for integrator in ("implicit", "sdirk4", "implicit_euler"):
        # tighter tolerance: the error may not grow by more than 10 % (it converges, from
        # below, to the spatial error; loose tolerances land up to ~4 % closer by chance)
        tol = curve(rows, "cantilever", integrator, "tolerance")
        assert len(tol) >= 2
        assert is_monotone(tol, rel_slack=0.1), [r.error for r in tol]
        # finer nodes: the error falls (second order, so strictly)
        dx = curve(rows, "cantilever", integrator, "node_spacing")
        assert is_monotone(dx, rel_slack=0.0)
        assert dx[-1].error < 0.2 * dx[0].error

    # a second run measures nothing again and writes the same table
    def no_timing(*_a: object, **_k: object) -> None:
        raise AssertionError("a stored point was measured again")

    monkeypatch.setattr(B, "timed", no_timing)
    assert main(["--quick", "--out", str(tmp_path)]) == 0
    again = _rows(tmp_path / "accuracy.csv")
    assert [(r.problem, r.knob, r.value) for r in again] == [
        (r.problem, r.knob, r.value) for r in rows
    ]
    np.testing.assert_array_equal([r.error for r in again], [r.error for r in rows])
    np.testing.assert_array_equal([r.wall_s for r in again], [r.wall_s for r in rows])

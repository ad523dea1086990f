"""A tiny run of the work-precision study (``bathprint bench accuracy --quick``)."""

from __future__ import annotations

import csv
from pathlib import Path

from bathprint.bench_accuracy import Row, curve, is_monotone, main


def test_quick_run_writes_files_and_converges(tmp_path: Path) -> None:
    assert main(["--quick", "--out", str(tmp_path)]) == 0
    for name in ("accuracy.csv", "presets.csv", "accuracy.png"):
        assert (tmp_path / name).stat().st_size > 0
    with (tmp_path / "accuracy.csv").open() as f:
        rows = [
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
    for integrator in ("implicit", "implicit_euler"):
        # tighter tolerance: the error may not grow by more than 10 % (it converges, from
        # below, to the spatial error; loose tolerances land up to ~4 % closer by chance)
        tol = curve(rows, "cantilever", integrator, "tolerance")
        assert len(tol) >= 2
        assert is_monotone(tol, rel_slack=0.1), [r.error for r in tol]
        # finer nodes: the error falls (second order, so strictly)
        dx = curve(rows, "cantilever", integrator, "node_spacing")
        assert is_monotone(dx, rel_slack=0.0)
        assert dx[-1].error < 0.2 * dx[0].error

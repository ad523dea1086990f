"""A tiny run of the work-precision study (``bathprint bench accuracy --quick``)."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
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


# a tiny plan, each point slowed down so that a signal lands in the middle of the study
TINY_STUDY = """
import sys, time
import bathprint.studies.accuracy as B
from bathprint.cli import main
B.QUICK = B.Plan(
    cant_tol=(1e-2, 1e-3, 1e-4), cant_dt=(), cant_n=(), cant_explicit_n=(), onset_tol=(),
    onset_dt=(), onset_n=(), coil_tol=(), coil_sdirk4_tol=(), coil_spacing=(),
    coil_duration=0.6, coil_reference="draft",
)
real_timed, pause = B.timed, float(sys.argv[2])
def timed(fn, repeats=2):
    time.sleep(pause)
    return real_timed(fn, repeats)
B.timed = timed
sys.exit(main(["bench", "accuracy", "--quick", "--out", sys.argv[1]]))
"""
TINY_POINTS = 16  # 3 integrators x 3 tolerances + 3 presets (cantilever), 3 (onset), 1 (coil)


def _tiny_study(out: Path, pause: float) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(Path(B.__file__).parents[1])}
    return subprocess.Popen(
        [sys.executable, "-c", TINY_STUDY, str(out), str(pause)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )


def test_sigterm_keeps_the_points_and_a_rerun_measures_only_the_rest(tmp_path: Path) -> None:
    points = tmp_path / "points_quick.jsonl"
    proc = _tiny_study(tmp_path, 0.25)
    try:
        deadline = time.monotonic() + 300
        while not (points.exists() and points.read_bytes().count(b"\n") >= 1):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no point written"
            time.sleep(0.05)
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, err
    assert "Traceback" not in err, err
    assert "interrupted (SIGTERM)" in err and "resume" in err, err
    kept = points.read_bytes().splitlines(keepends=True)
    assert 1 <= len(kept) < TINY_POINTS
    assert not (tmp_path / "accuracy.csv").exists()  # the study did not finish

    rerun = _tiny_study(tmp_path, 0.0)
    out, err = rerun.communicate(timeout=300)
    assert rerun.returncode == 0, err
    assert f"resuming: {len(kept)} points" in out
    lines = points.read_bytes().splitlines(keepends=True)
    assert lines[: len(kept)] == kept  # kept points were not measured again
    keys = [json.loads(x)["key"] for x in lines]
    assert len(keys) == TINY_POINTS == len(set(keys))
    assert (tmp_path / "accuracy.csv").stat().st_size > 0


def test_points_file_cut_by_a_crash_is_repaired(tmp_path: Path) -> None:
    path = tmp_path / "points.jsonl"
    good = json.dumps({"key": "a", "wall_s": 0.5, "result": [1.0, 2.0]}) + "\n"
    path.write_text(good + '{"key": "b", "wall')  # the last line was being written
    pts = B.Points(path, 3)
    try:
        assert pts.done == {"a": (0.5, (1.0, 2.0))}
        assert path.read_text() == good
        assert pts.measure("b", lambda: 3.0, repeats=1)[1] == 3.0
    finally:
        pts.close()
    assert [json.loads(x)["key"] for x in path.read_text().splitlines()] == ["a", "b"]


def test_out_is_checked_first(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    (tmp_path / "f").write_text("x")
    assert main(["--out", str(tmp_path / "f")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--out" in err and "existing file" in err

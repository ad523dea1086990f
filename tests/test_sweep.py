"""Parameter sweeps: grid, run ids, results file, resume, failures, backends, CLI parsing."""

from __future__ import annotations

import argparse
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

import bathprint
from bathprint import executor
from bathprint.provenance import code_version
from bathprint.studies import sweep
from bathprint.studies.reproduce.cli import add_arguments
from bathprint.studies.sweep import (
    expand_grid,
    latest_rows,
    parse_grid_arg,
    read_results,
    rows_to_csv,
    run_id,
    run_sweep,
)

SCENE = "drag_coiling_22G"
TINY = {"duration_s": 0.05, "outputs.plot": False}


def _lines(path) -> list[bytes]:
    return path.read_bytes().splitlines(keepends=True)


def _check_ok_row(row: dict) -> None:
    assert row["status"] == "ok" and row["error"] is None
    assert row["scene"] == SCENE
    assert row["wall_time_s"] > 0
    res = row["result"]
    assert res["steps"] > 0 and res["rejected_steps"] >= 0
    assert res["wall_time_s"] > 0 and res["final_length_m"] > 0


def test_expand_grid_order_and_run_id_stability() -> None:
    grid = expand_grid({"a": [1, 2], "b.c": ["x", "y", "z"], "d": 0.5})
    assert grid == [
        {"a": a, "b.c": c, "d": 0.5} for a in (1, 2) for c in ("x", "y", "z")
    ]  # first key slowest
    assert expand_grid({}) == [{}]
    arr = expand_grid({"a": np.array([0.5, 1.0]), "b": range(2)})
    assert arr == [{"a": 0.5, "b": 0}, {"a": 0.5, "b": 1}, {"a": 1.0, "b": 0}, {"a": 1.0, "b": 1}]
    assert type(arr[0]["a"]) is float
    assert expand_grid([{"a": 1}, {"a": 2, "b": [1, 0]}]) == [{"a": 1}, {"a": 2, "b": [1, 0]}]
    with pytest.raises(ValueError):
        expand_grid({"a": []})

    rid = run_id(SCENE, {"flow.q_outer_ml_min": 1.0, "duration_s": 0.1, "v": [1, 0]})
    assert rid == run_id(SCENE, {"v": [1, 0], "duration_s": 0.1, "flow.q_outer_ml_min": 1.0})
    assert rid == run_id(SCENE, {"v": (1, 0), "duration_s": 0.1, "flow.q_outer_ml_min": 1.0})
    assert len(rid) == 16 and int(rid, 16) >= 0
    assert rid != run_id(
        "rope_coiling_18G", {"v": [1, 0], "duration_s": 0.1, "flow.q_outer_ml_min": 1.0}
    )
    assert rid != run_id(SCENE, {"v": [1, 0], "duration_s": 0.1, "flow.q_outer_ml_min": 2.0})


def test_parse_grid_arg_values() -> None:
    assert parse_grid_arg("flow.q_outer_ml_min=0.5,1,2e-1") == (
        "flow.q_outer_ml_min",
        [0.5, 1, 0.2],
    )
    assert parse_grid_arg("bath.fluid=water, glycerol") == ("bath.fluid", ["water", "glycerol"])
    assert parse_grid_arg('name="a,b","c"') == ("name", ["a,b", "c"])
    assert parse_grid_arg("outputs.plot=true,false") == ("outputs.plot", [True, False])
    lists = ("needle.direction", [[1, 0, 0], [0, 1, 0]])
    assert parse_grid_arg("needle.direction=[1,0,0];[0,1,0]") == lists
    assert parse_grid_arg("needle.direction=[1,0,0],[0,1,0]") == lists
    assert parse_grid_arg("needle.direction=[1,0,0]") == ("needle.direction", [[1, 0, 0]])
    for bad in ("novalue", "=1,2", "a=1,,2"):
        with pytest.raises(sweep.SceneError):
            parse_grid_arg(bad)


def test_main_parses_grid_and_set(tmp_path, monkeypatch, capsys) -> None:
    seen = {}

    def fake_run_sweep(scene, grid, results_path, **kw):
        seen.update(scene=scene, grid=grid, path=results_path, **kw)
        return [
            {"run_id": run_id(scene, {**kw["base_overrides"], **p}), "status": "ok", "overrides": p}
            for p in expand_grid(grid)
        ]

    monkeypatch.setattr(sweep, "run_sweep", fake_run_sweep)
    out = tmp_path / "r.jsonl"
    code = sweep.main(
        [
            SCENE,
            "--grid",
            "flow.q_outer_ml_min=0.5,1.5",
            "--grid",
            "needle.direction=[0,0,-1];[1,0,-1]",
            "--grid",
            "name=a,'b c'",
            "--set",
            "duration_s=0.1",
            "--set",
            "outputs.plot=false",
            "--out",
            str(out),
            "--workers",
            "3",
            "--scheduler",
            "local-dask",
            "--no-progress",
        ]
    )
    assert code == 0
    assert seen["scene"] == SCENE and str(seen["path"]) == str(out)
    assert seen["grid"] == {
        "flow.q_outer_ml_min": [0.5, 1.5],
        "needle.direction": [[0, 0, -1], [1, 0, -1]],
        "name": ["a", "b c"],
    }
    assert seen["base_overrides"] == {"duration_s": 0.1, "outputs.plot": False}
    assert seen["workers"] == 3 and seen["scheduler"] == "local-dask"
    assert seen["progress"] is False and seen["retry_failed"] is False
    assert "8 points" in capsys.readouterr().out
    assert sweep.main([SCENE, "--grid", "a=1", "--grid", "a=2", "--out", str(out)]) == 2


def test_sweep_writes_one_ok_row_per_point_and_csv(tmp_path) -> None:
    out = tmp_path / "sub" / "results.jsonl"
    grid = {"flow.q_outer_ml_min": [0.5, 1.0]}
    rows = run_sweep(SCENE, grid, out, workers=2, progress=False, base_overrides=TINY)
    on_disk = read_results(out)
    assert len(on_disk) == 2 and len(_lines(out)) == 2
    assert {r["run_id"] for r in rows} == {r["run_id"] for r in on_disk}
    assert [r["overrides"]["flow.q_outer_ml_min"] for r in rows] == [0.5, 1.0]  # grid order
    for row in on_disk:
        _check_ok_row(row)
        assert row["overrides"] == {
            **TINY,
            "flow.q_outer_ml_min": row["overrides"]["flow.q_outer_ml_min"],
        }
        assert row["run_id"] == run_id(SCENE, row["overrides"])
    by_q = {r["overrides"]["flow.q_outer_ml_min"]: r["result"] for r in on_disk}
    assert by_q[1.0]["final_length_m"] > by_q[0.5]["final_length_m"]  # twice the flow

    assert rows_to_csv(out, tmp_path / "results.csv") == 2
    with open(tmp_path / "results.csv", newline="") as f:
        table = list(csv.DictReader(f))
    assert {t["overrides.flow.q_outer_ml_min"] for t in table} == {"0.5", "1.0"}
    assert all(t["status"] == "ok" and int(t["result.steps"]) > 0 for t in table)
    assert table[0]["overrides.outputs.plot"] == "false"
    assert {t["code.bathprint"] for t in table} == {bathprint.__version__}


def test_failing_run_is_recorded_and_the_sweep_goes_on(tmp_path) -> None:
    out = tmp_path / "results.jsonl"
    grid = [{"flow.q_outer_ml_min": -1}, {"flow.q_outer_ml_min": 0.5}, {"flow.q_outer_ml_min": 0.7}]
    rows = run_sweep(SCENE, grid, out, workers=2, progress=False, base_overrides=TINY)
    assert [r["status"] for r in rows] == ["failed", "ok", "ok"]
    assert len(read_results(out)) == 3
    failed = rows[0]
    assert failed["error"]["type"] == "SceneError"
    assert "flow.q_outer_ml_min" in failed["error"]["message"] and failed["result"] is None
    # failed points are recorded, not retried ...
    assert run_sweep(SCENE, grid, out, workers=2, progress=False, base_overrides=TINY) == rows
    assert len(_lines(out)) == 3
    # ... unless asked to: the retry appends a row for that run_id (still failing here)
    again = run_sweep(
        SCENE, grid, out, workers=2, progress=False, base_overrides=TINY, retry_failed=True
    )
    assert len(_lines(out)) == 4 and again[0]["run_id"] == failed["run_id"]
    assert len(latest_rows(read_results(out))) == 3


def test_resume_skips_recorded_points_and_reruns_a_truncated_one(tmp_path) -> None:
    out = tmp_path / "results.jsonl"
    qs = [0.4, 0.5, 0.6, 0.7]
    grid = {"flow.q_outer_ml_min": qs}
    ids = [run_id(SCENE, {**TINY, "flow.q_outer_ml_min": q}) for q in qs]

    def fake_row(k: int, status: str) -> bytes:
        row = {
            "run_id": ids[k],
            "scene": SCENE,
            "overrides": {**TINY, "flow.q_outer_ml_min": qs[k]},
            "status": status,
            "error": None,
            "wall_time_s": 1.0,
            "result": {"marker": "pre-written"},
        }
        return (json.dumps(row) + "\n").encode()

    pre = [fake_row(0, "ok"), fake_row(1, "failed")]
    truncated = fake_row(2, "ok")[:57]  # a crash in the middle of writing point 2
    out.write_bytes(b"".join(pre) + truncated)

    with pytest.warns(RuntimeWarning, match="truncated"):
        rows = run_sweep(SCENE, grid, out, workers=2, progress=False, base_overrides=TINY)
    lines = _lines(out)
    assert lines[:2] == pre  # byte-identical: recorded points were not rerun or rewritten
    assert len(lines) == 4 and all(line.endswith(b"\n") for line in lines)
    on_disk = read_results(out)
    assert sorted(r["run_id"] for r in on_disk) == sorted(ids)  # none lost, none repeated
    assert [r["run_id"] for r in rows] == ids
    assert [r["result"].get("marker") for r in rows[:1]] == ["pre-written"]
    for row in on_disk[2:]:
        _check_ok_row(row)
        assert "marker" not in row["result"]

    # a complete sweep has nothing left to run
    assert run_sweep(SCENE, grid, out, workers=2, progress=False, base_overrides=TINY) == rows
    assert _lines(out) == lines


def test_rows_record_their_code_and_a_resume_reruns_stale_rows_only_when_asked(
    tmp_path, capsys
) -> None:
    """Every row records the code that computed it; resuming over rows another version
    computed (or that record none) keeps them and says so, and with ``rerun_stale`` runs
    them again."""
    out = tmp_path / "results.jsonl"
    grid = {"flow.q_outer_ml_min": [0.4, 0.5]}
    rows = run_sweep(SCENE, grid, out, workers=1, progress=False, base_overrides=TINY)
    here = code_version()
    assert all(r["code"] == here for r in read_results(out))
    assert here["bathprint"] and (here["commit"] is None or len(here["commit"]) >= 7)
    # the same code: silent, nothing rerun
    capsys.readouterr()
    assert run_sweep(SCENE, grid, out, workers=1, progress=False, base_overrides=TINY) == rows
    assert "another version" not in capsys.readouterr().err
    # one row from another commit, one that records no code
    recorded = read_results(out)
    recorded[0]["code"] = {"bathprint": "0.0.1", "commit": "abcdef0"}
    recorded[0]["result"]["marker"] = "old"
    del recorded[1]["code"]
    out.write_text("".join(json.dumps(r) + "\n" for r in recorded))
    kept = run_sweep(SCENE, grid, out, workers=1, progress=False, base_overrides=TINY)
    err = capsys.readouterr().err
    assert "2 of the 2 points" in err and "0.0.1 at abcdef0" in err and "not recorded" in err
    assert kept[0]["result"]["marker"] == "old" and len(read_results(out)) == 2
    rerun = run_sweep(
        SCENE, grid, out, workers=1, progress=False, base_overrides=TINY, rerun_stale=True
    )
    assert "are run again" in capsys.readouterr().err
    assert all(r["code"] == here and "marker" not in r["result"] for r in rerun)
    assert [r["run_id"] for r in rerun] == [r["run_id"] for r in rows]
    # bathprint reproduce --rerun-stale: the same for every sweep inside the context
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    assert parser.parse_args(["ablation", "--rerun-stale"]).rerun_stale
    recorded = sweep.latest_rows(read_results(out))
    recorded[1]["code"] = {"bathprint": "0.0.1", "commit": None}
    out.write_text("".join(json.dumps(r) + "\n" for r in recorded))
    with sweep.rerunning_stale():
        again = run_sweep(SCENE, grid, out, workers=1, progress=False, base_overrides=TINY)
    assert "1 of the 2 points" in capsys.readouterr().err
    assert again[0] == rerun[0] and again[1]["code"] == here


def test_ctrl_c_keeps_written_rows_and_resume_completes(tmp_path) -> None:
    out = tmp_path / "results.jsonl"
    grid = {"flow.q_outer_ml_min": [0.4, 0.5, 0.6]}
    calls = []

    def interrupting_extract(summary):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return sweep.default_extract(summary)

    with pytest.raises(KeyboardInterrupt):
        run_sweep(
            SCENE,
            grid,
            out,
            workers=2,
            progress=False,
            base_overrides=TINY,
            extract=interrupting_extract,
        )
    assert len(read_results(out)) == 1
    rows = run_sweep(SCENE, grid, out, workers=2, progress=False, base_overrides=TINY)
    assert len(read_results(out)) == 3 and all(r["status"] == "ok" for r in rows)


def test_one_writer_per_results_file(tmp_path) -> None:
    out = tmp_path / "results.jsonl"
    first = sweep._ResultsFile(out)
    try:
        with pytest.raises(RuntimeError, match="another sweep"):
            sweep._ResultsFile(out)
    finally:
        first.close()
    (tmp_path / "scene.toml").write_text('name = "x"\nduration_s = 1.0\n')
    with pytest.raises(ValueError, match="not a bathprint sweep results file"):
        run_sweep(SCENE, {}, tmp_path / "scene.toml", progress=False)


def test_local_dask_sweep_writes_rows(tmp_path) -> None:
    pytest.importorskip("distributed")
    out = tmp_path / "results.jsonl"
    grid = {"flow.q_outer_ml_min": [0.5, 1.0]}
    rows = run_sweep(
        SCENE, grid, out, scheduler="local-dask", workers=2, progress=False, base_overrides=TINY
    )
    on_disk = read_results(out)
    assert len(on_disk) == 2 and {r["run_id"] for r in on_disk} == {r["run_id"] for r in rows}
    for row in on_disk:
        _check_ok_row(row)


# --------------------------------------------------------------------------- signals, checks

SIGNAL_GRID = "flow.q_outer_ml_min=0.30,0.35,0.40,0.45,0.50,0.55,0.60,0.65"
SIGNAL_ARGS = [SCENE, "--grid", SIGNAL_GRID, "--set", "duration_s=0.4", "--set"]
SIGNAL_ARGS += ["outputs.plot=false", "--workers", "2", "--no-progress"]


def _session_alive(sid: int) -> list[int]:
    """Pids of the live (not zombie) processes of session ``sid``."""
    alive = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[3]) == sid and fields[0] != "Z":  # fields: state, ppid, pgrp, session
            alive.append(int(stat.parent.name))
    return alive


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs Linux /proc")
@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_real_signal_keeps_rows_stops_workers_and_a_rerun_resumes(tmp_path, signum) -> None:
    out = tmp_path / "results.jsonl"
    env = {**os.environ, "PYTHONPATH": str(Path(sweep.__file__).parents[1])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "bathprint.cli", "sweep", *SIGNAL_ARGS, "--out", str(out)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        start_new_session=True,  # its own session: its workers can be found afterwards
    )
    try:
        deadline = time.monotonic() + 300
        while not (out.exists() and out.read_bytes().count(b"\n") >= 1):
            assert proc.poll() is None, proc.communicate()
            assert time.monotonic() < deadline, "no row written"
            time.sleep(0.05)
        proc.send_signal(signum)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 128 + signum, err
    assert "Traceback" not in err, err
    assert "interrupted" in err and err.strip().count("\n") == 0, err
    kept = _lines(out)
    assert 1 <= len(kept) < 8, "the sweep was not interrupted before its end"
    assert all(r["status"] == "ok" for r in read_results(out))
    deadline = time.monotonic() + 10
    while _session_alive(proc.pid) and time.monotonic() < deadline:
        time.sleep(0.1)
    assert not _session_alive(proc.pid), "worker processes outlived the sweep"

    # the same command again: runs only the missing points, the kept rows stay as they are
    assert sweep.main([*SIGNAL_ARGS, "--out", str(out)]) == 0
    lines = _lines(out)
    assert lines[: len(kept)] == kept
    assert len(lines) == 8 and len({json.loads(x)["run_id"] for x in lines}) == 8


def test_pool_workers_ignore_sigint_and_sigterm() -> None:
    old = {s: signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        executor.ignore_signals()
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        assert signal.getsignal(signal.SIGTERM) is signal.SIG_IGN
    finally:
        for s, h in old.items():
            signal.signal(s, h)


def _refusal(capsys, argv: list[str], *words: str) -> None:
    assert sweep.main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def test_bad_options_and_grid_points_are_refused_before_anything_runs(
    tmp_path, capsys, monkeypatch
) -> None:
    def no_run(*a, **k):
        raise AssertionError("the sweep started")

    monkeypatch.setattr(sweep, "run_sweep", no_run)
    out = tmp_path / "r.jsonl"
    base = [SCENE, "--grid", "flow.q_outer_ml_min=0.5,1"]
    _refusal(capsys, [*base, "--out", str(tmp_path)], "--out", str(tmp_path), "is a directory")
    (tmp_path / "file").write_text("x")
    _refusal(capsys, [*base, "--out", str(tmp_path / "file" / "r.jsonl")], "--out", "below a file")
    _refusal(capsys, [*base, "--out", str(out), "--csv", str(tmp_path)], "--csv", "directory")
    _refusal(capsys, [*base, "--out", str(out), "--csv", str(out)], "--csv", "results file")
    _refusal(capsys, [*base, "--out", str(out), "--workers", "0"], "--workers", "0", ">= 1")
    _refusal(capsys, [*base, "--out", str(out), "--scheduler", "nowhere"], "--scheduler", "nowhere")
    _refusal(
        capsys,
        [SCENE, "--grid", "flow.q_outer_ml_min=0.5,-1", "--out", str(out)],
        "grid point 2 of 2",
        "flow.q_outer_ml_min = -1",
        "[0, 1000]",
        "--allow-invalid",
    )
    _refusal(capsys, [SCENE, "--grid", "effects=drag", "--out", str(out)], 'effects=["drag", ...]')
    _refusal(capsys, [SCENE, "--set", "bath=1", "--out", str(out)], "bath = 1", "table of keys")
    _refusal(capsys, ["no_such_scene", "--out", str(out)], "no_such_scene")
    assert not out.exists()


def test_allow_invalid_records_invalid_points_as_failed(tmp_path, monkeypatch) -> None:
    seen = {}

    def fake_run_sweep(scene, grid, results_path, **kw):
        seen["grid"] = grid
        return []

    monkeypatch.setattr(sweep, "run_sweep", fake_run_sweep)
    argv = [SCENE, "--grid", "flow.q_outer_ml_min=0.5,-1", "--out", str(tmp_path / "r.jsonl")]
    assert sweep.main([*argv, "--allow-invalid"]) == 0
    assert seen["grid"] == {"flow.q_outer_ml_min": [0.5, -1]}


def test_check_points_names_the_point_and_the_key() -> None:
    assert sweep.check_points(SCENE, {"flow.q_outer_ml_min": [0.5, 1.0]}, TINY) == 2
    with pytest.raises(sweep.SceneError, match=r"grid point 1 of 1 .*drag\.length_scale_mm"):
        sweep.check_points(SCENE, [{"drag.length_scale_mm": 0.2}])  # L < e r: compile_model
    with pytest.raises(sweep.OptionError, match="workers"):
        run_sweep(SCENE, {}, "unused.jsonl", workers=0, progress=False)

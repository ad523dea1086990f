"""The bathprint command: simulate, scenes, show; and the Python simulate() API."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

import bathprint
from bathprint.cli import main
from bathprint.core.run import load_trajectory


def test_simulate_writes_trajectory_summary_and_picture(tmp_path) -> None:
    out = tmp_path / "run"
    code = main(
        [
            "simulate",
            "drag_coiling_22G",
            "--set",
            "duration_s=0.3",
            "--set",
            "flow.q_outer_ml_min=1.0",
            "--out",
            str(out),
            "--quiet",
        ]
    )
    assert code == 0
    summary = json.loads((out / "summary.json").read_text())
    for key in (
        "wall_time_s",
        "steps",
        "rejected_steps",
        "final_length_m",
        "mass_balance",
        "measurements",
    ):
        assert key in summary
    assert summary["time_s"] == 0.3
    assert abs(summary["mass_balance"]["relative_error"]) < 1e-3
    assert summary["q_outer_ml_min_at_end"] == 1.0
    times, frames, material = load_trajectory(out / "trajectory.npz")
    assert times[-1] == 0.3 and len(frames) == len(times)
    assert material.shape == (len(frames[-1]) - 1, bathprint.core.layout.N_MAT)
    assert (out / "filament.png").stat().st_size > 10_000


def test_python_api_returns_the_same_as_the_cli(tmp_path) -> None:
    res = bathprint.simulate(
        "drag_coiling_22G", {"duration_s": 0.3, "flow.q_outer_ml_min": 1.0, "outputs.plot": False}
    )
    main(
        [
            "simulate",
            "drag_coiling_22G",
            "--set",
            "duration_s=0.3",
            "--set",
            "flow.q_outer_ml_min=1.0",
            "--set",
            "outputs.plot=false",
            "--out",
            str(tmp_path),
            "--quiet",
        ]
    )
    _, frames, _ = load_trajectory(tmp_path / "trajectory.npz")
    np.testing.assert_array_equal(frames[-1], res.final)
    assert res.summary["steps"] == json.loads((tmp_path / "summary.json").read_text())["steps"]


def test_bad_override_exits_with_a_clear_message(capsys) -> None:
    code = main(["simulate", "paper_simulation", "--set", "flow.q_outer_ml_min=-3", "--quiet"])
    assert code == 2
    err = capsys.readouterr().err
    assert "flow.q_outer_ml_min" in err and "-3" in err


def test_scenes_lists_builtins(capsys) -> None:
    assert main(["scenes"]) == 0
    out = capsys.readouterr().out
    assert "paper_simulation" in out and "chaotic_crumpling_22G" in out


def test_console_script_is_installed() -> None:
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "bathprint.cli",
            "show",
            "paper_simulation",
            "--set",
            "duration_s=1.5",
        ],
        capture_output=True,
        text=True,
        check=True,
    )
    assert json.loads(proc.stdout)["duration_s"] == 1.5

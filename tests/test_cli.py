"""The bathprint command: simulate, scenes, show; and the Python simulate() API."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import bathprint
from bathprint.cli import main
from bathprint.core.run import load_trajectory
from bathprint.core.scene import builtin_scene_names, load_scene, scene_to_toml
from bathprint.core.simulation import Simulation
from bathprint.errors import OptionError
from bathprint.paths import check_output_dir, check_output_file


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


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "bathprint.cli", *args], capture_output=True, text=True
    )


def test_show_writes_toml_that_simulate_reads_back(tmp_path) -> None:
    proc = _cli("show", "paper_simulation", "--set", "duration_s=1.5")
    assert proc.returncode == 0, proc.stderr
    assert tomllib.loads(proc.stdout)["duration_s"] == 1.5
    path = tmp_path / "mine.toml"
    path.write_text(proc.stdout)
    assert load_scene(path) == load_scene("paper_simulation", {"duration_s": 1.5})
    assert "TOML" in _cli("show", "--help").stdout
    assert json.loads(_cli("show", "paper_simulation", "--json").stdout)["name"] == (
        "paper_simulation"
    )


@pytest.mark.parametrize("name", builtin_scene_names())
def test_show_round_trips_every_builtin_scene(name: str, tmp_path, capsys) -> None:
    overrides = {
        "needle.path": [[0.0, 0.0, 0.0, -5.0, 0.0, 0.0, -1.0], [1.0, 2.0, 0.0, -5.0, 0.5, 0, -1]],
        "flow.schedule": [(0.0, 0.5, 0.0), (0.5, 1.5, 0.0)],
        "description": 'quotes " and \\ and\nnew lines',
        "seed": 7,
    }
    scene = load_scene(name, overrides)
    assert main(["show", name, "--set", "seed=7"]) == 0
    assert load_scene(tomllib.loads(capsys.readouterr().out)) == load_scene(name, {"seed": 7})
    path = tmp_path / "scene.toml"
    path.write_text(scene_to_toml(scene))
    assert load_scene(path) == scene


def test_version(capsys) -> None:
    with pytest.raises(SystemExit) as exit_:
        main(["--version"])
    assert exit_.value.code == 0
    pyproject = Path(__file__).parents[1] / "pyproject.toml"
    version = tomllib.loads(pyproject.read_text())["project"]["version"]
    assert (
        capsys.readouterr().out.strip()
        == f"bathprint {version}"
        == (f"bathprint {bathprint.__version__}")
    )


def test_bench_without_a_benchmark_prints_its_help() -> None:
    proc = _cli("bench")
    assert proc.returncode == 2  # as argparse does for a missing sub-command
    assert "Traceback" not in proc.stderr
    assert "usage: bathprint bench" in proc.stderr and "accuracy" in proc.stderr
    assert "work-precision" in _cli("bench", "--help").stdout
    nonsense = _cli("bench", "nonsense")
    assert nonsense.returncode == 2 and "Traceback" not in nonsense.stderr


def _one_line_refusal(capsys, argv: list[str], *words: str) -> str:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err
    return err


@pytest.fixture
def no_simulation(monkeypatch):
    """Fail the test if a simulation would advance: refusals come before any work."""

    def advance(self, *a, **k):
        raise AssertionError("the simulation ran")

    monkeypatch.setattr(Simulation, "advance", advance)


def test_simulate_out_is_checked_before_simulating(tmp_path, capsys, no_simulation) -> None:
    a_file = tmp_path / "a_file"
    a_file.write_text("keep me")
    base = ["simulate", "drag_coiling_22G", "--quiet", "--out"]
    _one_line_refusal(capsys, [*base, str(a_file)], "--out", str(a_file), "existing file")
    _one_line_refusal(capsys, [*base, str(a_file / "sub")], "--out", "below a file")
    assert a_file.read_text() == "keep me"
    if Path("/proc/self").exists():
        _one_line_refusal(capsys, [*base, "/proc/bathprint-test/out"], "cannot be written")
    with pytest.raises(OptionError, match="out_dir"):
        bathprint.simulate("drag_coiling_22G", out_dir=a_file)


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes anywhere")
def test_simulate_out_unwritable_directory(tmp_path, capsys, no_simulation) -> None:
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        _one_line_refusal(
            capsys,
            ["simulate", "drag_coiling_22G", "--quiet", "--out", str(locked / "run")],
            "--out",
            "cannot be written",
        )
    finally:
        locked.chmod(0o700)


def test_check_output_paths_leave_nothing_behind(tmp_path) -> None:
    target = tmp_path / "a" / "b" / "c"
    assert check_output_dir(target, "--out") == target
    assert check_output_file(tmp_path / "x" / "r.jsonl", "--out") == tmp_path / "x" / "r.jsonl"
    assert list(tmp_path.iterdir()) == []  # the probes removed what they made
    with pytest.raises(OptionError, match="empty"):
        check_output_dir("", "--out")


def test_effects_given_as_a_string_is_refused_with_the_list_form(capsys, no_simulation) -> None:
    err = _one_line_refusal(
        capsys, ["simulate", "--set", "effects=drag", "--quiet"], "effects", "'drag'"
    )
    assert 'effects=["drag", ...]' in err
    err = _one_line_refusal(capsys, ["show", "paper_simulation", "--set", "effects=drag,gravity"])
    assert 'effects=["drag", "gravity"]' in err


@pytest.mark.parametrize(
    "argv, words",
    [
        (["reproduce", "fig2", "--workers", "0"], ["--workers", "0", ">= 1"]),
        (["reproduce", "fig2", "--scheduler", "nowhere"], ["--scheduler", "nowhere"]),
        (["reproduce", "fig2", "--out", "{file}"], ["--out", "existing file"]),
        (["composites", "--out", "{file}"], ["--out", "existing file"]),
        (["bench", "accuracy", "--out", "{file}"], ["--out", "existing file"]),
        (["bench", "accuracy", "--out", "{file}/sub"], ["--out", "below a file"]),
        (["sweep", "paper_simulation", "--out", "{dir}"], ["--out", "is a directory"]),
        (["simulate", "--set", "needle.path=5"], ["needle.path = 5", "list of rows"]),
        (["simulate", "--set", "flow.schedule=[0,1,0]"], ["one row", "[[0, 1, 0]]"]),
        (["simulate", "--set", "bath=3"], ["bath = 3", "table of keys"]),
        (["simulate", "{dir}"], ["is a directory"]),
    ],
)
def test_every_command_refuses_bad_options_in_one_line(
    argv: list[str], words: list[str], tmp_path, capsys, no_simulation
) -> None:
    a_file = tmp_path / "a_file"
    a_file.write_text("x")
    argv = [a.format(file=a_file, dir=tmp_path) for a in argv]
    _one_line_refusal(capsys, argv, *words)


def test_an_interrupted_simulation_exits_with_one_line(tmp_path, capsys, monkeypatch) -> None:
    from bathprint.interrupt import Interrupted

    def advance(self, *a, **k):
        raise Interrupted(signal.SIGTERM)

    monkeypatch.setattr(Simulation, "advance", advance)
    code = main(["simulate", "drag_coiling_22G", "--quiet", "--out", str(tmp_path / "r")])
    assert code == 143
    err = capsys.readouterr().err
    assert err == "bathprint simulate: interrupted (SIGTERM)\n"

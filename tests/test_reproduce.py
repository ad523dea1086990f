"""End-to-end `bathprint reproduce all --quick`: outputs exist and hold sane numbers."""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

from bathprint.analysis.theory import beta_critical
from bathprint.cli import main
from bathprint.interrupt import Interrupted
from bathprint.studies.reproduce.cli import FIGURES, MARKER


def test_reproduce_quick_writes_every_figure_with_sane_numbers(tmp_path) -> None:
    assert main(["reproduce", "all", "--quick", "--out", str(tmp_path), "--workers", "2"]) == 0
    for name in ("stability", "fig3df_composites", "fig3e_settling", "coils", "fig2", "fig1c"):
        assert (tmp_path / f"{name}.png").stat().st_size > 10_000, name
        assert (tmp_path / f"{name}.csv").stat().st_size > 50, name
    report = json.loads((tmp_path / "reproduce.json").read_text())
    beta_c = beta_critical()
    for onset in report["stability"]["result"]["simulated_onsets"].values():
        assert abs(onset / beta_c - 1) < 0.05
    for row in report["fig3"]["result"]["settling"]:
        assert abs(row["difference_m"]) < row["node_spacing_m"]
    slopes = report["fig2"]["result"]
    for key in ("l_over_R", "R_prefactor", "omega_prefactor"):
        value = slopes[key]
        assert value is None or math.isnan(value) or 0.01 < value < 100, (key, value)
    fig1c = report["fig1c"]["result"]
    assert fig1c["points"] == 2
    assert sum(fig1c["regimes"].values()) <= fig1c["points"]


def test_theory_json_has_the_onset_constants(capsys) -> None:
    assert main(["theory", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert round(data["beta_c"], 3) == 3.477
    assert abs(data["beta_c_spectral"] - data["beta_c"]) < 1e-6
    assert math.isclose(data["critical_length_prefactor"], data["beta_c"] ** (1 / 3))
    assert math.isclose(data["onset_frequency_prefactor"], data["beta_c"] ** (-1 / 3))


def _fake_figures(monkeypatch, calls: list[str], stop: dict) -> None:
    """Replace the figures by quick fakes; the one named in stop["at"] is interrupted."""
    from bathprint.studies.reproduce import coils, fig1c, fig2, fig3, stability

    modules = {"stability": stability, "fig3": fig3, "coils": coils, "fig2": fig2}
    modules["fig1c"] = fig1c
    for name, module in modules.items():

        def run(out, quick, *args, name=name):
            calls.append(name)
            if stop.get("at") == name:
                raise Interrupted(signal.SIGTERM)
            return {"figure": name}

        monkeypatch.setattr(module, "run", run)


def test_interrupted_reproduce_resumes_after_the_finished_figures(
    tmp_path, monkeypatch, capsys
) -> None:
    calls: list[str] = []
    stop = {"at": "coils"}
    _fake_figures(monkeypatch, calls, stop)
    argv = ["reproduce", "all", "--quick", "--out", str(tmp_path)]
    assert main(argv) == 143
    err = capsys.readouterr().err
    assert "interrupted (SIGTERM) during coils" in err and "done: stability, fig3" in err
    assert "Traceback" not in err and err.count("\n") == 1
    assert calls == ["stability", "fig3", "coils"]
    report = json.loads((tmp_path / "reproduce.json").read_text())
    assert set(report) == {"stability", "fig3"}
    assert (tmp_path / MARKER).exists()

    calls.clear()
    stop.clear()
    assert main(argv) == 0
    assert calls == ["coils", "fig2", "fig1c"]  # the finished figures are not redone
    assert "resuming an interrupted run: stability, fig3" in capsys.readouterr().out
    assert set(json.loads((tmp_path / "reproduce.json").read_text())) == set(FIGURES)
    assert not (tmp_path / MARKER).exists()

    calls.clear()
    assert main(argv) == 0
    assert calls == list(FIGURES)  # after a complete run, a new run does everything


def test_reproduce_refuses_bad_options_before_running(tmp_path, monkeypatch, capsys) -> None:
    calls: list[str] = []
    _fake_figures(monkeypatch, calls, {})
    (tmp_path / "f").write_text("x")
    for argv, word in [
        (["--workers", "0"], "--workers"),
        (["--workers", "-2"], "--workers"),
        (["--scheduler", "nowhere"], "--scheduler"),
        (["--out", str(tmp_path / "f")], "--out"),
    ]:
        assert main(["reproduce", "fig2", *argv]) == 2
        err = capsys.readouterr().err
        assert word in err and err.count("\n") == 1, err
    assert calls == []


SLOW_REPRODUCE = """
import sys, time
from bathprint.cli import main
from bathprint.studies.reproduce import stability, fig3
def slow(out, quick, *a):
    time.sleep(0.2)
    return {"ok": True}
def forever(out, quick, *a):
    print("fig3 started", flush=True)
    time.sleep(60)
stability.run, fig3.run = slow, forever
sys.exit(main(["reproduce", "all", "--quick", "--out", sys.argv[1]]))
"""


def test_a_real_sigterm_stops_reproduce_cleanly(tmp_path) -> None:
    src = Path(__import__("bathprint").__file__).parents[1]
    env = {**os.environ, "PYTHONPATH": str(src)}
    proc = subprocess.Popen(
        [sys.executable, "-c", SLOW_REPRODUCE, str(tmp_path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
    )
    try:
        for line in proc.stdout:
            if "fig3 started" in line:
                break
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 143, err
    assert "Traceback" not in err and "interrupted (SIGTERM) during fig3" in err, err
    assert json.loads((tmp_path / MARKER).read_text())["done"] == ["stability"]

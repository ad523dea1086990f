"""Compilation before timed work: announced once when numba's cache is cold, kept out of a
run's wall time, and the ``bathprint warmup`` command."""

from __future__ import annotations

import pytest

import bathprint
from bathprint import warmup
from bathprint.cli import main


def test_cold_cache_is_announced_once_and_timed_apart(monkeypatch, capsys) -> None:
    monkeypatch.setattr(warmup, "kernels_cached", lambda: False)
    monkeypatch.setattr(warmup, "_DONE", False)
    result = bathprint.simulate("paper_simulation", {"duration_s": 0.01, "outputs.plot": False})
    err = capsys.readouterr().err
    assert err.count("compiling the numba kernels") == 1
    assert "kernels compiled in" in err
    s = result.summary
    assert s["compile_s"] > 0.0
    # the run's own wall time excludes the warm-up: it is what the stepping took
    assert s["wall_s_per_simulated_s"] == pytest.approx(s["wall_time_s"] / s["time_s"])
    bathprint.simulate("paper_simulation", {"duration_s": 0.01, "outputs.plot": False})
    assert "compiling" not in capsys.readouterr().err  # once per process
    assert warmup.ensure_compiled() == 0.0


def test_warm_cache_says_nothing(monkeypatch, capsys) -> None:
    monkeypatch.setattr(warmup, "kernels_cached", lambda: True)
    monkeypatch.setattr(warmup, "_DONE", False)
    assert warmup.ensure_compiled() >= 0.0
    assert capsys.readouterr().err == ""


def test_kernels_cached_reads_numba_cache() -> None:
    assert warmup.kernels_cached() in (True, False, None)
    warmup.ensure_compiled(announce=False)
    # after a compile in a writable tree the stepper's cache index exists
    assert warmup.kernels_cached() in (True, None)


def test_warmup_command(capsys) -> None:
    assert main(["warmup"]) == 0
    assert "kernels" in capsys.readouterr().out

"""One runner for independent tasks: serially, on a process pool or on Dask; every result
handed back with its task's index, errors as values, and an early exit stopping the workers."""

from __future__ import annotations

import operator
import subprocess
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import pytest

import bathprint
from bathprint import executor
from bathprint._extras import MissingExtraError
from bathprint.errors import OptionError

TASKS = [(6, 3), (1, 0), (9, 2)]  # operator.truediv: 2.0, ZeroDivisionError, 4.5


def _collect(scheduler: str | None, workers: int = 2) -> dict[int, object]:
    got: dict[int, object] = {}
    executor.run_tasks(operator.truediv, TASKS, got.__setitem__, scheduler, workers)
    return got


def _check(got: dict[int, object]) -> None:
    assert sorted(got) == [0, 1, 2]
    assert got[0] == 2.0 and got[2] == 4.5
    assert isinstance(got[1], ZeroDivisionError)  # an error is a result; the run goes on


def test_serial_runs_in_task_order_in_this_process() -> None:
    order: list[int] = []
    executor.run_tasks(operator.truediv, TASKS, lambda i, r: order.append(i), "serial")
    assert order == [0, 1, 2]
    _check(_collect("serial"))


def test_a_process_pool_gives_the_same_results() -> None:
    _check(_collect(None, workers=2))


def test_local_dask_gives_the_same_results() -> None:
    pytest.importorskip("distributed")
    _check(_collect("local-dask", workers=2))


def test_an_interruption_in_serial_is_not_swallowed() -> None:
    def stop(*_: object) -> None:
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        executor.run_tasks(stop, [()], lambda i, r: None, "serial")


def test_an_early_exit_cancels_the_rest_and_kills_the_workers(monkeypatch) -> None:
    """The callback raising (as Ctrl-C does between results) stops the pool at once: the
    slow tasks do not finish, and no worker outlives the call."""
    pools: list[ProcessPoolExecutor] = []
    real = executor.ProcessPoolExecutor

    def recording(*args, **kwargs):
        pools.append(real(*args, **kwargs))
        return pools[-1]

    monkeypatch.setattr(executor, "ProcessPoolExecutor", recording)
    tasks = [(0.0,)] + [(30.0,)] * 3

    pids: list[int] = []

    def interrupt(i: int, result: object) -> None:
        pids.extend((pools[0]._processes or {}).keys())  # the workers, running the rest
        raise KeyboardInterrupt

    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        executor.run_tasks(time.sleep, tasks, interrupt, None, workers=2)
    assert time.monotonic() - t0 < 20.0  # the 30 s tasks did not run to their end
    assert pids
    for pid in pids:
        assert not Path(f"/proc/{pid}").exists(), f"worker {pid} outlived the run"


def test_workers_and_schedulers_are_checked() -> None:
    assert executor.check_workers(3, "--workers") == 3
    assert executor.check_workers(None, "--workers") >= 1
    for bad in (0, -1, 2.5, True, "2"):
        with pytest.raises(OptionError, match="--workers"):
            executor.check_workers(bad, "--workers")
    for ok in (None, "serial"):
        executor.check_scheduler(ok, "--scheduler")
    with pytest.raises(OptionError, match=r"--scheduler = 'dask'; allowed: 'local-dask'"):
        executor.check_scheduler("dask", "--scheduler")


def test_dask_missing_names_the_extra(monkeypatch) -> None:
    def missing(module: str, purpose: str, extra: str | None = None):
        raise MissingExtraError(f"{purpose} needs 'dask' ... the 'dask' extra")

    monkeypatch.setattr(executor, "require", missing)
    with pytest.raises(OptionError, match=r"--scheduler = 'local-dask': running on Dask .*'dask'"):
        executor.check_scheduler("local-dask", "--scheduler")
    executor.check_scheduler(None, "--scheduler")  # the pool needs no Dask
    with pytest.raises(MissingExtraError):
        list(executor.iter_results(operator.neg, [(1,)], "local-dask"))


def test_dask_is_imported_only_when_used() -> None:
    src = Path(bathprint.__file__).resolve().parents[1]
    code = (
        "import sys\n"
        "import bathprint.executor, bathprint.studies.sweep, bathprint.agents.campaign\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        env={"PYTHONPATH": str(src), "PATH": "/usr/bin:/bin"},
        timeout=300,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "[]"

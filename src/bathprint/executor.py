"""Run independent tasks serially, on a local process pool or on Dask, one result at a time.

:func:`run_tasks` calls ``fn(*args)`` for each task and hands every finished result to a
callback in this process as it arrives (so a caller can write it at once, and a rerun can
resume from what was written); :func:`iter_results` is the same as an iterator. The sweeps
(:mod:`bathprint.studies.sweep`, and through them ``bathprint reproduce``) and the agents'
campaigns (:mod:`bathprint.agents.campaign`) run their work through it.

``scheduler``:

- ``None``: a local process pool of ``workers`` processes, started with ``forkserver``
  (else ``spawn``), so a script that uses it must guard its entry point with
  ``if __name__ == "__main__":``;
- ``"serial"``: the calling process, in task order;
- ``"local-dask"``: a temporary local Dask cluster of ``workers`` single-threaded processes;
- any other string: the address of a running Dask scheduler (``tcp://host:8786``).

Dask is an optional dependency (the ``dask`` extra), imported only for the last two.
Results arrive in completion order with the task's index; a task that raised arrives as its
exception (the run goes on). On an early exit (Ctrl-C, or SIGTERM inside
:func:`bathprint.interrupt.signals_interrupt`, or the callback raising) queued tasks are
cancelled and the pool's workers are killed, so none outlives its driver.
"""

from __future__ import annotations

import logging
import multiprocessing
import operator
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor
from concurrent.futures import as_completed as futures_as_completed
from typing import Any

from bathprint._extras import MissingExtraError, require
from bathprint.errors import OptionError

__all__ = [
    "LOCAL_DASK",
    "SERIAL",
    "check_scheduler",
    "check_workers",
    "ignore_signals",
    "iter_results",
    "mp_context",
    "run_tasks",
    "stop_pool",
]

#: Special values of ``scheduler`` (None: a local process pool; anything else: a Dask address).
LOCAL_DASK = "local-dask"
SERIAL = "serial"

Task = Sequence[Any]  # the arguments of one call of ``fn``


def check_workers(workers: Any, option: str = "workers") -> int:
    """``workers`` as an int >= 1 (None: the number of CPUs); OptionError naming ``option``
    otherwise."""
    if workers is None:
        return os.cpu_count() or 1
    try:
        n = operator.index(workers)  # ints and numpy ints; not 2.5, not True
    except TypeError:
        n = 0
    if isinstance(workers, bool) or n < 1:
        raise OptionError(f"{option} = {workers!r}; allowed: an integer >= 1")
    return n


def check_scheduler(scheduler: Any, option: str = "scheduler") -> None:
    """Refuse a ``scheduler`` that cannot be one: None, ``"local-dask"``, ``"serial"`` or a
    Dask address (``tcp://host:port``, ``host:port``); Dask must be installed for the last two.
    Whether a scheduler answers at the address is found when the work connects."""
    if scheduler is None or scheduler == SERIAL:
        return
    allowed = f"{LOCAL_DASK!r}, {SERIAL!r} or a Dask scheduler address such as tcp://host:8786"
    if not isinstance(scheduler, str) or ":" not in scheduler and scheduler != LOCAL_DASK:
        raise OptionError(f"{option} = {scheduler!r}; allowed: {allowed}")
    try:
        _dask()
    except MissingExtraError as exc:
        raise OptionError(
            f"{option} = {scheduler!r}: {exc}; allowed without it: the default local process "
            f"pool or {SERIAL!r}"
        ) from None


def _dask() -> Any:
    """``dask.distributed``, or MissingExtraError naming the extra that brings it."""
    return require("dask.distributed", "running on Dask", "dask")


def ignore_signals() -> None:
    """A pool worker's initializer: Ctrl-C and SIGTERM (also when sent to the whole process
    group) are the driver's business; it cancels pending work and kills the workers."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_IGN)


def mp_context() -> multiprocessing.context.BaseContext:
    """The start method of the pool's workers: ``forkserver`` where there is one, else
    ``spawn`` (never ``fork``: the driver may hold threads and numba's state)."""
    method = "forkserver" if "forkserver" in multiprocessing.get_all_start_methods() else "spawn"
    return multiprocessing.get_context(method)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Stop a process pool now: drop its queued work, kill its workers, and wait for its
    management thread.

    The workers are killed by pid: they may ignore SIGTERM, and when a SIGTERM to the process
    group has ended the forkserver, ``proc.is_alive()`` wrongly says False. The management
    thread closes its wake-up pipe when it sees the workers gone; left running, it can
    close it while the interpreter's exit hook writes to it (``OSError: Bad file
    descriptor``, printed as an ignored exception after a clean stop, Python 3.11).
    """
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        try:
            os.kill(proc.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError, TypeError, ValueError):
            pass
    for proc in procs:
        try:
            proc.join(timeout=5.0)
        except (ValueError, AssertionError):  # closed by the pool / not our child
            pass
    manager = getattr(pool, "_executor_manager_thread", None)
    if manager is not None and manager.is_alive():
        manager.join(timeout=5.0)


def iter_results(
    fn: Callable[..., Any],
    tasks: Sequence[Task],
    scheduler: str | None = None,
    workers: int = 1,
    *,
    initializer: Callable[[], None] | None = None,
    dashboard: str | None = None,
) -> Iterator[tuple[int, Any]]:
    """(task index, ``fn(*task)`` or the exception it raised), as each task finishes.

    ``initializer`` runs once in each pool worker (e.g. :func:`ignore_signals`).
    ``dashboard``: on a local Dask cluster, open its dashboard (when bokeh is installed) and
    print its address on stderr after this label. Closing the iterator early cancels the
    queued tasks and stops the workers. A pool whose worker died (a crash or out of memory)
    gives :class:`concurrent.futures.process.BrokenProcessPool` for each task left.
    """
    if scheduler == SERIAL:
        return _iter_serial(fn, tasks)
    if scheduler is None:
        return _iter_pool(fn, tasks, workers, initializer)
    return _iter_dask(fn, tasks, scheduler, workers, dashboard)


def run_tasks(
    fn: Callable[..., Any],
    tasks: Sequence[Task],
    on_result: Callable[[int, Any], None],
    scheduler: str | None = None,
    workers: int = 1,
    *,
    initializer: Callable[[], None] | None = None,
    dashboard: str | None = None,
) -> None:
    """Run ``fn(*task)`` for every task (see :func:`iter_results`) and call
    ``on_result(index, result or exception)`` in this process as each one finishes. Whatever
    ends it early (an interruption, ``on_result`` raising) cancels the rest and stops the
    workers before it propagates."""
    results = iter_results(
        fn, tasks, scheduler, workers, initializer=initializer, dashboard=dashboard
    )
    try:
        for i, outcome in results:
            on_result(i, outcome)
    finally:
        results.close()


def _iter_serial(fn: Callable[..., Any], tasks: Sequence[Task]) -> Iterator[tuple[int, Any]]:
    for i, args in enumerate(tasks):
        try:
            outcome = fn(*args)
        except Exception as exc:  # KeyboardInterrupt and SystemExit end the run
            outcome = exc
        yield i, outcome


def _iter_pool(
    fn: Callable[..., Any],
    tasks: Sequence[Task],
    workers: int,
    initializer: Callable[[], None] | None,
) -> Iterator[tuple[int, Any]]:
    if not tasks:
        return
    pool = ProcessPoolExecutor(
        max_workers=max(1, min(workers, len(tasks))),
        mp_context=mp_context(),
        initializer=initializer,
    )
    finished = False
    try:
        futures = {pool.submit(fn, *args): i for i, args in enumerate(tasks)}
        for fut in futures_as_completed(futures):
            try:
                outcome = fut.result()
            except Exception as exc:  # the task's own error, or BrokenProcessPool
                outcome = exc
            yield futures.pop(fut), outcome
        finished = True
    finally:
        if finished:
            pool.shutdown(wait=True)
        else:  # interrupted or failed: drop queued work and stop the running tasks now
            stop_pool(pool)


def _iter_dask(
    fn: Callable[..., Any],
    tasks: Sequence[Task],
    scheduler: str,
    workers: int,
    dashboard: str | None,
) -> Iterator[tuple[int, Any]]:
    if not tasks:
        return
    distributed = _dask()
    cluster = None
    if scheduler == LOCAL_DASK:
        address: str | None = None
        if dashboard is not None:
            try:
                import bokeh  # noqa: F401 - the dashboard needs it

                address = ":0"
            except ImportError:
                pass
        cluster = distributed.LocalCluster(
            n_workers=max(1, min(workers, len(tasks))),
            threads_per_worker=1,
            processes=True,
            dashboard_address=address,
            silence_logs=logging.ERROR,
        )
        client = distributed.Client(cluster, set_as_default=False)
        if address is not None:
            print(f"{dashboard}: dask dashboard at {client.dashboard_link}", file=sys.stderr)
    else:
        try:
            client = distributed.Client(scheduler, set_as_default=False)
        except (OSError, TimeoutError, ValueError, TypeError) as exc:
            raise OptionError(
                f"scheduler = {scheduler!r}: cannot connect ({exc}); allowed: the address of "
                f"a running Dask scheduler (tcp://host:8786), {LOCAL_DASK!r} or {SERIAL!r}"
            ) from None
    futures: dict[Any, int] = {}
    try:
        for i, args in enumerate(tasks):
            futures[client.submit(fn, *args, pure=False)] = i
        for fut in distributed.as_completed(list(futures), loop=client.loop):
            try:
                outcome = fut.result()
            except Exception as exc:  # e.g. KilledWorker: the task took its worker down
                outcome = exc
            i = futures.pop(fut)
            fut.release()
            yield i, outcome
    finally:
        if futures:
            try:
                client.cancel(list(futures))
            except Exception:  # the cluster may already be gone
                pass
        client.close()
        if cluster is not None:
            cluster.close()

"""Parameter sweeps: run a scene over a grid of overrides, in parallel, resumably.

Every finished run appends one JSON object (a *row*) to a JSON Lines results file,
flushed and fsync'd at once, so an interrupted sweep loses at most the runs in flight.
Rerunning the same sweep skips every point whose ``run_id`` is already in the file.
``bathprint sweep`` checks every option and every grid point's scene before it runs
anything, and treats SIGTERM like Ctrl-C: pending runs are cancelled, the workers stopped,
the rows written are kept, and it exits with 130 (SIGINT) or 143 (SIGTERM).

Row fields::

    run_id       16 hex digits: sha256 of the scene argument and the canonical JSON of the
                 overrides (sorted keys), so the same point always gets the same id
    scene        the scene argument as given (built-in name or TOML path)
    overrides    the overrides the run used: base overrides updated by the grid point
    status       "ok" or "failed"
    error        null, or {"type", "message"} (plus "traceback" for unexpected errors)
    wall_time_s  seconds the whole task took in its worker (scene loading and JIT included)
    finished_at  UTC time the driver recorded the row (ISO 8601)
    code         the code that computed it: {"bathprint": version, "commit": short hash, or
                 null outside a git checkout} (:func:`bathprint.provenance.code_version`);
                 resuming says how many recorded rows another version computed, and
                 ``rerun_stale`` runs them again
    result       the fields ``extract(summary)`` returned (null when failed); by default
                 steps, rejected_steps, wall_time_s (of the time loop), final_length_m and
                 ``measurements.<name>`` for everything under summary["measurements"]

Non-finite floats are written as null. If the same ``run_id`` appears twice (a failed
run retried with ``retry_failed=True``) the last row is the one that counts.

Backends (:mod:`bathprint.executor`): a local process pool (default), a Dask cluster
(``scheduler="tcp://host:8786"``), a temporary local Dask cluster (``"local-dask"``) or the
calling process (``"serial"``). The process pool uses the ``forkserver`` (else ``spawn``)
start method, so a script that calls :func:`run_sweep` must guard its entry point with
``if __name__ == "__main__":``. Dask (the ``dask`` extra) workers need bathprint installed;
the scene file is read by the driver and sent to them, so TOML paths need not exist on the
workers.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import json
import math
import os
import signal
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from concurrent.futures.process import BrokenProcessPool
from contextlib import contextmanager
from contextvars import ContextVar
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from bathprint.core.scene import parse_override, read_scene_data
from bathprint.errors import OptionError, SceneError, SimulationError
from bathprint.executor import check_scheduler, check_workers, ignore_signals, run_tasks
from bathprint.interrupt import atomic, exit_code, signals_interrupt
from bathprint.paths import check_output_file
from bathprint.provenance import code_version

__all__ = [
    "add_arguments",
    "check_points",
    "default_extract",
    "expand_grid",
    "latest_rows",
    "main",
    "parse_grid_arg",
    "read_results",
    "rows_to_csv",
    "run_args",
    "run_id",
    "run_sweep",
]

Grid = Mapping[str, Any] | Sequence[Mapping[str, Any]]
Extract = Callable[[dict[str, Any]], Mapping[str, Any]]

# --------------------------------------------------------------------------- grid, ids


def expand_grid(axes: Grid) -> list[dict[str, Any]]:
    """The Cartesian product of override values, or a copy of an explicit list of points.

    ``axes`` maps dotted override keys to sequences of values (lists, tuples, ranges, numpy
    arrays; a list-valued key takes a list of lists); the first key varies slowest
    (``itertools.product`` order). A scalar or string is a one-value axis. A list of dicts
    is taken as the points themselves, in order.
    """
    if isinstance(axes, Mapping):
        keys = list(axes)
        columns = []
        for key in keys:
            values = axes[key]
            if hasattr(values, "tolist"):  # numpy array (or scalar)
                values = values.tolist()
            if isinstance(values, str | bytes | Mapping) or not isinstance(values, Iterable):
                values = [values]
            values = list(values)
            if not values:
                raise ValueError(f"grid axis {key!r} has no values")
            columns.append(values)
        return [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*columns)]
    points = []
    for k, point in enumerate(axes):
        if not isinstance(point, Mapping):
            raise TypeError(f"grid point {k} is {type(point).__name__}, not a dict of overrides")
        points.append(dict(point))
    return points


def _jsonable(obj: Any) -> Any:
    """Plain JSON types: numpy scalars/arrays unwrapped, tuples as lists, NaN/inf as None."""
    if obj is None or isinstance(obj, bool | str | int):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, Mapping):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [_jsonable(v) for v in obj]
    if hasattr(obj, "tolist"):  # numpy scalar or array
        return _jsonable(obj.tolist())
    return str(obj)


def _canonical(obj: Any) -> str:
    return json.dumps(
        _jsonable(obj), sort_keys=True, separators=(",", ":"), ensure_ascii=False, allow_nan=False
    )


def run_id(scene: str | os.PathLike, overrides: Mapping[str, Any]) -> str:
    """Stable id of one run: a hash of the scene argument and the canonical overrides JSON.

    Key order does not matter; value types do (``1`` and ``1.0`` are different points).
    """
    text = _canonical({"scene": str(scene), "overrides": dict(overrides)})
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _flatten(data: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    for key, value in data.items():
        name = f"{prefix}{key}"
        if isinstance(value, Mapping) and value:
            out.update(_flatten(value, f"{name}."))
        else:
            out[name] = value
    return out


def default_extract(summary: Mapping[str, Any]) -> dict[str, Any]:
    """steps, rejected_steps, wall_time_s, final_length_m and the flattened measurements."""
    out = {k: summary.get(k) for k in ("steps", "rejected_steps", "wall_time_s", "final_length_m")}
    out.update(_flatten(summary.get("measurements") or {}, "measurements."))
    return out


# --------------------------------------------------------------------------- results file


def _parse_row(line: bytes) -> dict[str, Any] | None:
    try:
        row = json.loads(line)
    except ValueError:
        return None
    if not isinstance(row, dict) or not isinstance(row.get("run_id"), str):
        return None
    if row.get("status") not in ("ok", "failed"):
        return None
    return row


def _scan(data: bytes, path: Path) -> tuple[list[dict[str, Any]], int | None]:
    """Rows in ``data`` and, if the last line is an unterminated fragment, where it starts."""
    rows: list[dict[str, Any]] = []
    bad = 0
    lines = data.split(b"\n")
    tail = lines.pop()  # b"" when data ends with a newline
    for line in lines:
        if not line.strip():
            continue
        row = _parse_row(line)
        if row is None:
            bad += 1
        else:
            rows.append(row)
    cut = None
    if tail.strip():
        row = _parse_row(tail)
        if row is None:
            cut = len(data) - len(tail)
        else:
            rows.append(row)
    if bad and not rows:
        raise ValueError(f"{path} is not a bathprint sweep results file (no valid rows)")
    if bad:
        warnings.warn(f"{path}: ignored {bad} malformed line(s)", RuntimeWarning, stacklevel=3)
    return rows, cut


def read_results(path: str | os.PathLike) -> list[dict[str, Any]]:
    """All rows of a results file, in file order; a truncated last line is ignored.

    A missing file has no rows. Use :func:`latest_rows` to keep one row per ``run_id``.
    """
    p = Path(path)
    if not p.exists():
        return []
    rows, _ = _scan(p.read_bytes(), p)
    return rows


def latest_rows(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """One row per ``run_id``: the last one, at the position where the id first appeared."""
    by_id: dict[str, dict[str, Any]] = {}
    for row in rows:
        by_id[row["run_id"]] = dict(row)
    return list(by_id.values())


class _ResultsFile:
    """The single writer of a results file: locked, repaired on open, fsync'd per row."""

    def __init__(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._f = open(path, "a+b")  # closed in close()
        try:
            self._lock()
            self._f.seek(0)
            data = self._f.read()
            self.rows, cut = _scan(data, path)
            if cut is not None:
                warnings.warn(
                    f"{path}: dropped a truncated last line ({len(data) - cut} bytes) "
                    "left by an interrupted write; that point will run again",
                    RuntimeWarning,
                    stacklevel=3,
                )
                self._f.truncate(cut)
            elif data and not data.endswith(b"\n"):
                self._f.write(b"\n")
                self._sync()
        except BaseException:
            self._f.close()
            raise

    def _lock(self) -> None:
        try:
            import fcntl
        except ImportError:  # not POSIX: no advisory lock
            return
        try:
            fcntl.flock(self._f.fileno(), fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise RuntimeError(f"{self.path} is being written by another sweep") from exc

    def _sync(self) -> None:
        self._f.flush()
        os.fsync(self._f.fileno())

    def append(self, row: Mapping[str, Any]) -> None:
        line = json.dumps(_jsonable(row), ensure_ascii=False, allow_nan=False) + "\n"
        with atomic():  # a SIGINT/SIGTERM now is raised after the row is on disk
            self._f.write(line.encode())
            self._sync()

    def close(self) -> None:
        self._f.close()  # closing releases the lock


# --------------------------------------------------------------------------- workers


def _error_info(exc: BaseException) -> dict[str, Any]:
    info: dict[str, Any] = {"type": type(exc).__name__, "message": str(exc)}
    if not isinstance(exc, SceneError | SimulationError):
        info["traceback"] = "".join(traceback.format_exception(exc)[-6:])
    return info


def _run_point(scene_data: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """Run one point (in a worker); every error is returned, never raised."""
    t0 = time.perf_counter()
    try:
        from bathprint.run import simulate

        result = simulate(scene_data, overrides, progress=False)
    except Exception as exc:
        return {
            "status": "failed",
            "error": _error_info(exc),
            "wall_time_s": time.perf_counter() - t0,
            "summary": None,
        }
    return {
        "status": "ok",
        "error": None,
        "wall_time_s": time.perf_counter() - t0,
        "summary": result.summary,
    }


Outcome = dict[str, Any]  # what _run_point returns


def _outcome(result: Outcome | BaseException) -> Outcome:
    """A task's outcome; an error the worker could not return itself (a task that could not
    be sent, a Dask worker lost) is a failed run. A dead pool worker ends the sweep: its
    points were not run, so they are not recorded and a rerun resumes them."""
    if isinstance(result, BrokenProcessPool):
        raise RuntimeError(
            "a sweep worker process died (crash or out of memory); the rows written "
            "so far are kept: rerun the sweep to resume"
        ) from result
    if isinstance(result, BaseException):
        return {"status": "failed", "error": _error_info(result), "wall_time_s": None}
    return result


# --------------------------------------------------------------------------- sweep


def check_points(
    scene: str | os.PathLike,
    grid: Grid,
    base_overrides: Mapping[str, Any] | None = None,
) -> int:
    """Validate the scene of every grid point (as :func:`bathprint.core.scene.load_scene` and
    :func:`bathprint.core.model.compile_model` do, without running anything); returns the number
    of points. Raises :class:`SceneError` for the first invalid point, naming it."""
    from bathprint.core.model import compile_model
    from bathprint.core.scene import load_scene

    data = read_scene_data(scene)
    base = dict(base_overrides or {})
    points = expand_grid(grid)
    for k, point in enumerate(points):
        overrides = _jsonable({**base, **point})
        try:
            compile_model(load_scene(data, overrides))
        except SceneError as exc:
            where = f"grid point {k + 1} of {len(points)} {_canonical(point)}: " if point else ""
            raise SceneError(f"{where}{exc}") from None
    return len(points)


def run_sweep(
    scene: str | os.PathLike,
    grid: Grid,
    results_path: str | os.PathLike,
    *,
    scheduler: str | None = None,
    workers: int | None = None,
    extract: Extract | None = None,
    progress: bool = True,
    base_overrides: Mapping[str, Any] | None = None,
    retry_failed: bool = False,
    rerun_stale: bool | None = None,
) -> list[dict[str, Any]]:
    """Run ``simulate(scene, {**base_overrides, **point})`` for every grid point.

    ``grid`` is an axes dict or a list of points (see :func:`expand_grid`). Points whose
    ``run_id`` is already in ``results_path`` are skipped (failed ones too, unless
    ``retry_failed``, and those another version of the code computed, if ``rerun_stale``;
    None: as :func:`rerunning_stale` sets it, by default False);
    every other run appends one row as it finishes, in completion order. A failing run is
    recorded and the sweep goes on. ``scheduler``: None (local process pool of ``workers``
    processes, default ``os.cpu_count()``), ``"local-dask"``, ``"serial"`` or a Dask
    scheduler address. ``extract(summary)`` runs in this process.
    On Ctrl-C pending runs are cancelled, the workers stopped, written rows kept and
    KeyboardInterrupt re-raised (inside :func:`bathprint.interrupt.signals_interrupt`, as
    the command line runs it, SIGTERM does the same).

    Returns one row per distinct point of the grid, in grid order (the latest row for
    points that were skipped).
    """
    from tqdm import tqdm

    extract = extract or default_extract
    scene_name = str(scene)
    scene_data = read_scene_data(scene)  # a bad scene fails here, before any run
    base = dict(base_overrides or {})
    points: dict[str, dict[str, Any]] = {}
    for point in expand_grid(grid):
        overrides = _jsonable({**base, **point})  # plain types: what runs is what is recorded
        points.setdefault(run_id(scene_name, overrides), overrides)
    workers = check_workers(workers, "workers")

    out = _ResultsFile(Path(results_path))
    try:
        done = {r["run_id"]: r for r in out.rows if not retry_failed or r["status"] == "ok"}
        if rerun_stale is None:
            rerun_stale = _RERUN_STALE.get()
        done = _without_stale(done, points, out.path, rerun_stale)
        todo = [rid for rid in points if rid not in done]
        rows = {rid: done[rid] for rid in points if rid in done}
        if progress and len(todo) < len(points):
            print(
                f"sweep: {len(points) - len(todo)} of {len(points)} points already in "
                f"{out.path}; running {len(todo)}",
                file=sys.stderr,
            )
        if not todo:
            return [rows[rid] for rid in points]
        counts = {"ok": 0, "failed": 0}
        bar = tqdm(total=len(todo), unit="run", desc="sweep", disable=not progress)

        def record(k: int, result: Outcome | BaseException) -> None:
            rid = todo[k]
            row = _make_row(rid, scene_name, points[rid], _outcome(result), extract)
            out.append(row)
            rows[rid] = row
            counts[row["status"]] += 1
            bar.set_postfix(counts, refresh=False)
            bar.update(1)

        try:  # an early exit cancels the pending runs and stops the workers
            run_tasks(
                _run_point,
                [(scene_data, points[rid]) for rid in todo],
                record,
                scheduler,
                workers,
                initializer=ignore_signals,
                dashboard="sweep" if progress else None,
            )
        finally:
            bar.close()
        return [rows[rid] for rid in points]
    finally:
        out.close()


_RERUN_STALE: ContextVar[bool] = ContextVar("rerun_stale", default=False)


@contextmanager
def rerunning_stale(on: bool = True) -> Iterator[None]:
    """Within it, every :func:`run_sweep` that is not told otherwise runs again the rows
    another version of the code computed (``bathprint reproduce --rerun-stale``: the
    studies' sweeps)."""
    token = _RERUN_STALE.set(on)
    try:
        yield
    finally:
        _RERUN_STALE.reset(token)


def _without_stale(
    done: dict[str, dict[str, Any]], points: Mapping[str, Any], path: Path, rerun_stale: bool
) -> dict[str, dict[str, Any]]:
    """The recorded rows of this grid that another version of the code computed (or that
    carry no version): say how many, and leave them out of ``done`` if ``rerun_stale``."""
    here = code_version()
    stale = [rid for rid in points if rid in done and done[rid].get("code") != here]
    if not stale:
        return done
    versions = sorted({_version_label(done[rid].get("code")) for rid in stale})
    what = "are run again" if rerun_stale else "are kept (--rerun-stale runs them again)"
    print(
        f"sweep: {len(stale)} of the {len(points)} points were recorded in {path} by another "
        f"version of bathprint ({', '.join(versions)}; this one: {_version_label(here)}); "
        f"they {what}",
        file=sys.stderr,
    )
    if not rerun_stale:
        return done
    return {rid: row for rid, row in done.items() if rid not in stale}


def _version_label(code: Any) -> str:
    if not isinstance(code, dict):
        return "not recorded"
    commit = code.get("commit")
    return f"{code.get('bathprint')}" + (f" at {commit}" if commit else "")


def _make_row(
    rid: str, scene: str, overrides: dict[str, Any], outcome: Outcome, extract: Extract
) -> dict[str, Any]:
    status, error, result = outcome["status"], outcome["error"], None
    if status == "ok":
        try:
            result = dict(extract(outcome["summary"]))
        except Exception as exc:
            status, error = "failed", _error_info(exc)
            error["type"] = f"extract: {error['type']}"
    return {
        "run_id": rid,
        "scene": scene,
        "overrides": overrides,
        "status": status,
        "error": error,
        "wall_time_s": outcome.get("wall_time_s"),
        "finished_at": datetime.now(UTC).isoformat(timespec="seconds"),
        "code": code_version(),
        "result": result,
    }


# --------------------------------------------------------------------------- CSV


_FIXED_COLUMNS = ["run_id", "scene", "status", "error_type", "error_message", "wall_time_s"]


def _cell(value: Any) -> Any:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list | dict):
        return json.dumps(value, ensure_ascii=False)
    return value


def rows_to_csv(jsonl_path: str | os.PathLike, csv_path: str | os.PathLike) -> int:
    """Write a results file as CSV: one line per run_id (its latest row); returns the count.

    Columns: run_id, scene, status, error_type, error_message, wall_time_s, then
    ``code.<key>``, ``overrides.<key>`` and ``result.<key>`` (nested values flattened with
    dots, lists as JSON), like ``pandas.json_normalize`` of the rows.
    """
    rows = latest_rows(read_results(jsonl_path))
    flat_rows = []
    columns = dict.fromkeys(_FIXED_COLUMNS)
    for row in rows:
        error = row.get("error") or {}
        flat = {
            "run_id": row["run_id"],
            "scene": row.get("scene"),
            "status": row["status"],
            "error_type": error.get("type"),
            "error_message": error.get("message"),
            "wall_time_s": row.get("wall_time_s"),
        }
        flat.update(_flatten(row.get("code") or {}, "code."))
        flat.update(_flatten(row.get("overrides") or {}, "overrides."))
        flat.update(_flatten(row.get("result") or {}, "result."))
        columns.update(dict.fromkeys(flat))
        flat_rows.append(flat)
    Path(csv_path).parent.mkdir(parents=True, exist_ok=True)
    with open(csv_path, "w", newline="", encoding="utf-8") as f:
        writer = csv.DictWriter(f, fieldnames=list(columns))
        writer.writeheader()
        for flat in flat_rows:
            writer.writerow({c: _cell(flat.get(c)) for c in columns})
    return len(flat_rows)


# --------------------------------------------------------------------------- command line


def _split_values(text: str) -> list[str]:
    """Split on ';' if one occurs outside brackets and quotes, else on such ','."""
    pieces: dict[str, list[str]] = {";": [], ",": []}
    depth, quote, escaped = 0, "", False
    starts: dict[str, int] = {";": 0, ",": 0}
    for k, ch in enumerate(text):
        if quote:
            if escaped:
                escaped = False
            elif ch == "\\" and quote == '"':
                escaped = True
            elif ch == quote:
                quote = ""
        elif ch in "\"'":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch in ";," and depth == 0:
            pieces[ch].append(text[starts[ch] : k])
            starts[ch] = k + 1
    sep = ";" if pieces[";"] else ","
    return [*pieces[sep], text[starts[sep] :]]


def parse_grid_arg(text: str) -> tuple[str, list[Any]]:
    """Parse ``key=v1,v2,...`` (each value TOML, like ``--set``) into (key, values).

    Commas inside ``[...]``, ``{...}`` or quotes do not split, so
    ``needle.direction=[1,0,0],[0,1,0]`` gives two lists; when a ``;`` occurs outside
    brackets and quotes the values are split on ``;`` instead (``a=[1,0,0];[0,1,0]``).
    """
    if "=" not in text:
        raise SceneError(f"--grid {text!r} must look like key=v1,v2,... (e.g. duration_s=1,2)")
    key, raw = text.split("=", 1)
    key = key.strip()
    if not key:
        raise SceneError(f"--grid {text!r} has no key before '='")
    values = []
    for piece in _split_values(raw):
        if not piece.strip():
            raise SceneError(f"--grid {text!r} has an empty value")
        values.append(parse_override(f"{key}={piece}")[1])
    return key, values


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the sweep arguments to ``parser`` (for a ``bathprint sweep`` sub-command)."""
    parser.add_argument("scene", help="built-in scene name or TOML path")
    parser.add_argument(
        "--grid",
        action="append",
        default=[],
        metavar="KEY=V1,V2,...",
        help="a sweep axis; values are TOML (numbers, strings, [lists]); commas inside "
        "[...] or quotes do not split; use ';' to separate values explicitly. Repeat "
        "for more axes: the sweep runs their Cartesian product",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="override a scene value for every run, e.g. duration_s=0.5",
    )
    parser.add_argument(
        "--out",
        required=True,
        help="results file (JSON Lines); an existing file is resumed: recorded points are skipped",
    )
    parser.add_argument(
        "--scheduler",
        metavar="ADDRESS|local-dask",
        help="run on a Dask cluster (scheduler address, e.g. tcp://host:8786) or on a "
        "temporary local one ('local-dask'); default: a local process pool",
    )
    parser.add_argument("--workers", type=int, help="worker processes (default: number of CPUs)")
    parser.add_argument(
        "--retry-failed", action="store_true", help="run again the points recorded as failed"
    )
    parser.add_argument(
        "--rerun-stale",
        action="store_true",
        help="run again the points that another version of bathprint computed",
    )
    parser.add_argument("--csv", metavar="PATH", help="also write all results as CSV to PATH")
    parser.add_argument(
        "--allow-invalid",
        action="store_true",
        help="record grid points whose scene is invalid as failed rows and run the rest "
        "(default: refuse the sweep before running anything)",
    )
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")


def run_args(args: argparse.Namespace) -> int:
    """Run a sweep from parsed arguments: 0 if no point failed, 1 if some did, 2 on bad input
    (checked before anything runs), 130 / 143 when interrupted by SIGINT / SIGTERM."""
    with signals_interrupt():
        try:
            return _run_args(args)
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM
            out = Path(args.out)
            kept = len(latest_rows(read_results(out))) if out.is_file() else 0
            print(
                f"bathprint sweep: interrupted ({_signal_name(exc)}); {kept} points kept in "
                f"{out}; run the same command again to resume",
                file=sys.stderr,
            )
            return exit_code(exc)


def _check_args(args: argparse.Namespace) -> tuple[dict[str, list[Any]], dict[str, Any]]:
    """(grid axes, base overrides), every option checked; raises SceneError / OptionError."""
    check_output_file(args.out, "--out")
    if args.csv is not None:
        check_output_file(args.csv, "--csv")
        if Path(args.csv).resolve() == Path(args.out).resolve():
            raise OptionError(f"--csv = {args.csv!r} is the results file; allowed: another path")
    check_workers(args.workers, "--workers")
    check_scheduler(args.scheduler, "--scheduler")
    axes: dict[str, list[Any]] = {}
    for text in args.grid:
        key, values = parse_grid_arg(text)
        if key in axes:
            raise SceneError(f"--grid {key} is given twice")
        axes[key] = values
    base = dict(parse_override(s) for s in args.set)
    if not getattr(args, "allow_invalid", False):
        try:
            check_points(args.scene, axes, base)
        except SceneError as exc:
            hint = " (--allow-invalid records invalid points as failed and runs the rest)"
            raise SceneError(f"{exc}{hint if axes else ''}") from None
    return axes, base


def _run_args(args: argparse.Namespace) -> int:
    out = Path(args.out)
    try:
        axes, base = _check_args(args)
        existing = {r["run_id"]: r["status"] for r in read_results(out)}
        rows = run_sweep(
            args.scene,
            axes,
            out,
            scheduler=args.scheduler,
            workers=args.workers,
            progress=not args.no_progress,
            base_overrides=base,
            retry_failed=args.retry_failed,
            rerun_stale=args.rerun_stale,
        )
    except (SceneError, ValueError) as exc:  # OptionError is a ValueError
        print(f"bathprint sweep: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:  # results file locked, or a worker process died
        print(f"bathprint sweep: {exc}", file=sys.stderr)
        return 1
    skipped = {
        rid
        for rid, status in existing.items()
        if status == "ok" or (status == "failed" and not args.retry_failed)
    }
    ran = [r for r in rows if r["run_id"] not in skipped]
    ran_ok = sum(r["status"] == "ok" for r in ran)
    failed = [r for r in rows if r["status"] == "failed"]
    print(
        f"sweep {args.scene}: {len(rows)} points: ran {len(ran)} ({ran_ok} ok, "
        f"{len(ran) - ran_ok} failed), skipped {len(rows) - len(ran)} already recorded; "
        f"total {len(rows) - len(failed)} ok, {len(failed)} failed; results: {out}"
    )
    for r in failed[:5]:
        err = r.get("error") or {}
        print(
            f"  failed {r['run_id']} {json.dumps(r['overrides'])}: "
            f"{err.get('type')}: {err.get('message')}"
        )
    if len(failed) > 5:
        print(f"  ... and {len(failed) - 5} more failed")
    if args.csv:
        n = rows_to_csv(out, args.csv)
        print(f"wrote {n} rows to {args.csv}")
    return 1 if failed else 0


def _signal_name(exc: BaseException) -> str:
    return signal.Signals(exit_code(exc) - 128).name


def main(argv: Sequence[str] | None = None) -> int:
    """``bathprint sweep SCENE --grid KEY=V1,V2 ... --out results.jsonl``."""
    parser = argparse.ArgumentParser(
        prog="bathprint sweep",
        description="Run a scene over a grid of overrides in parallel; resumable.",
    )
    add_arguments(parser)
    return run_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())

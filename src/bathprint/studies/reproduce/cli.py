"""``bathprint reproduce fig1c|fig2|fig3|stability|coils|all|ablation|gravity|fast_jets --out DIR
[--quick]``.

``all`` runs the paper's figures; the studies (``ablation``: which effect moves which
quantity; ``gravity``: the universal scaling with gravity; ``fast_jets``: what stops the
effects at the fast points) run by name.

Options are checked before anything runs (exit code 2). Ctrl-C and SIGTERM stop the run
cleanly (exit 130 / 143): the figures finished so far stay in ``reproduce.json``, the
simulation runs of fig2 and fig1c in their ``*_runs.jsonl``, and the same command then
resumes: it skips the figures the interrupted run had finished and the recorded runs.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path
from typing import Any

from bathprint.errors import OptionError
from bathprint.interrupt import atomic, exit_code, signals_interrupt

FIGURES = ("stability", "fig3", "coils", "fig2", "fig1c")
STUDIES = ("ablation", "gravity", "fast_jets")  # not part of "all"
SIMULATION_RUNS = ("fig2", "fig1c", *STUDIES)  # their finished runs are kept when interrupted
MARKER = "reproduce.interrupted.json"  # what an interrupted run had finished


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "figure",
        choices=(*FIGURES, "all", *STUDIES),
        help="coils: steady coiling over 8 s (10-19 turns), with and without gelation; all: the "
        "figures; ablation: the effects switched on one at a time and together at the Fig. 1B "
        "points and over the Fig. 2 range; gravity: l against (B/(mu v + drho g r^2))^(1/3); "
        "fast_jets: inertia and finite-Re drag with and without the solution's viscosity at the "
        "fast Fig. 1B points",
    )
    p.add_argument("--out", default="runs/reproduce", help="output directory")
    p.add_argument("--quick", action="store_true", help="small grids: every figure, roughly")
    p.add_argument("--workers", type=int, default=None, help="parallel runs (default: cores)")
    p.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address (or local-dask) for the simulation runs",
    )
    p.add_argument(
        "--rerun-stale",
        action="store_true",
        help="run again the recorded simulation runs that another version of bathprint "
        "computed (by default they are kept, and counted on stderr)",
    )


def check_args(args: argparse.Namespace) -> Path:
    """The output directory, once every option is known to be usable (OptionError if not)."""
    from bathprint.executor import check_scheduler, check_workers
    from bathprint.paths import check_output_dir

    out = check_output_dir(args.out, "--out")
    if args.workers is not None:
        check_workers(args.workers, "--workers")
    check_scheduler(args.scheduler, "--scheduler")
    return out


def _write_json(path: Path, data: Any) -> None:
    """Write ``data`` as JSON to ``path`` whole or not at all (temporary file, then rename)."""
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=2, default=float))
    os.replace(tmp, path)


def _read_json(path: Path) -> dict:
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def run_args(args: argparse.Namespace) -> int:
    """Run the figures asked for: 0 done, 2 bad options, 130 / 143 interrupted."""
    try:
        out = check_args(args)
    except OptionError as exc:
        print(f"bathprint reproduce: {exc}", file=sys.stderr)
        return 2
    from bathprint.studies.sweep import rerunning_stale

    names = FIGURES if args.figure == "all" else (args.figure,)
    marker_path = out / MARKER
    run_key = {"figures": list(names), "quick": bool(args.quick)}
    marker = _read_json(marker_path)
    resumed = list(marker.get("done", [])) if marker.get("run") == run_key else []
    done: list[str] = [n for n in names if n in resumed]
    current = None
    with signals_interrupt():
        try:
            out.mkdir(parents=True, exist_ok=True)
            report_path = out / "reproduce.json"
            report = _read_json(report_path)
            if done:
                print(f"resuming an interrupted run: {', '.join(done)} already done in {out}")
            for name in names:
                if name in done:
                    continue
                current = name
                t0 = time.perf_counter()
                with rerunning_stale(args.rerun_stale):
                    result = _run_figure(name, out, args)
                report[name] = {
                    "wall_time_s": time.perf_counter() - t0,
                    "quick": args.quick,
                    "result": result,
                }
                with atomic():  # the report and the list of finished figures agree
                    _write_json(report_path, report)
                    done.append(name)
                current = None
                written = sorted(p.name for p in out.glob(f"{name}*") if p.is_file())
                wall = report[name]["wall_time_s"]
                print(f"{name}: {wall:.1f} s -> {out}/: {', '.join(written)}")
                print(json.dumps(result, indent=2, default=float)[:1500])
            if marker_path.exists():
                marker_path.unlink()
            return 0
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM
            _write_json(marker_path, {"run": run_key, "done": done})
            kept = current in SIMULATION_RUNS
            runs = " (its finished simulation runs are kept)" if kept else ""
            print(
                f"bathprint reproduce: interrupted ({signal.Signals(exit_code(exc) - 128).name}) "
                f"during {current or 'the write-up'}{runs}; done: {', '.join(done) or 'none'}; "
                "run the same command again to resume",
                file=sys.stderr,
            )
            return exit_code(exc)


def _run_figure(name: str, out: Path, args: argparse.Namespace) -> dict:
    from bathprint.studies.reproduce import (
        ablation,
        coils,
        fast_jets,
        fig1c,
        fig2,
        fig3,
        gravity,
        stability,
    )

    if name == "ablation":
        return ablation.run(out, args.quick, args.workers, args.scheduler)
    if name == "gravity":
        return gravity.run(out, args.quick, args.workers, args.scheduler)
    if name == "fast_jets":
        return fast_jets.run(out, args.quick, args.workers, args.scheduler)
    if name == "stability":
        return stability.run(out, args.quick)
    if name == "fig3":
        return fig3.run(out, args.quick)
    if name == "coils":
        return coils.run(out, args.quick)
    if name == "fig2":
        return fig2.run(out, args.quick, args.workers, args.scheduler)
    return fig1c.run(out, args.quick, args.workers, args.scheduler)

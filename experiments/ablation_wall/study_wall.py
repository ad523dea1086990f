"""Wall time of a whole reproduction study, from its run log, and whether its measurements
are those of the committed study.

A study's ``<name>_runs.jsonl`` (one line per run, :mod:`bathprint.studies.sweep`) holds each
run's worker wall time and the second it finished. The study's wall time is the span from
the first run's start (its finish less its wall time) to the last finish; the worker time
is the sum of the runs' wall times. Each run's result, without its timings, is compared
with the run of the same ``run_id`` in ``--reference`` (the committed study).

    bathprint reproduce ablation --out runs/abl_pool --workers 2
    bathprint reproduce ablation --out runs/abl_dask --scheduler tcp://HOST:8786
    python experiments/ablation_wall/study_wall.py "process pool, 2 workers=runs/abl_pool" \\
        "Dask, 2 workers=runs/abl_dask" --name ablation_wall

Writes results/<name>.csv (+ .meta.json). Only runs one study run wrote count:
a study resumed from an earlier log spans both sessions and is refused.
"""

from __future__ import annotations

import argparse
import json
import sys
from datetime import datetime
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import EXPERIMENTS, write_csv  # noqa: E402

TIMING_KEYS = ("wall_time_s",)  # result fields that are timings, not measurements


def read_runs(directory: Path, study: str) -> list[dict]:
    path = directory / f"{study}_runs.jsonl"
    if not path.is_file():
        raise SystemExit(f"{path}: no such run log (run `bathprint reproduce {study}` first)")
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _measurements(run: dict) -> tuple:
    res = run.get("result") or {}
    err = run.get("error") or {}
    kept = {k: v for k, v in res.items() if k not in TIMING_KEYS}
    return run["status"], json.dumps(kept, sort_keys=True), err.get("message")


def summarise(label: str, runs: list[dict], reference: dict[str, dict]) -> dict:
    starts, ends = [], []
    for r in runs:
        end = datetime.fromisoformat(r["finished_at"]).timestamp()
        ends.append(end)
        starts.append(end - float(r["wall_time_s"]))
    wall = max(ends) - min(starts)
    worker = sum(float(r["wall_time_s"]) for r in runs)
    if wall > 2.0 * worker + 60.0:
        raise SystemExit(
            f"{label}: the runs span {wall:.0f} s but took {worker:.0f} s of worker time: "
            "the log holds runs of more than one session; run the study into a fresh --out"
        )
    same = sum(
        1
        for r in runs
        if r["run_id"] in reference and _measurements(r) == _measurements(reference[r["run_id"]])
    )
    return {
        "study": label,
        "runs": len(runs),
        "failed": sum(r["status"] != "ok" for r in runs),
        "wall_s": wall,
        "worker_s": worker,
        "worker_over_wall": worker / wall,
        "longest_run_s": max(float(r["wall_time_s"]) for r in runs),
        "same_as_reference": same,
        "reference_runs": len(reference),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("studies", nargs="+", help="LABEL=DIR: a study's output directory")
    ap.add_argument("--study", default="ablation", help="the study's name (its run log)")
    ap.add_argument("--reference", default=str(EXPERIMENTS / "ablation" / "results"),
                    help="the committed study's directory")  # fmt: skip
    ap.add_argument("--name", default="ablation_wall", help="result file name")
    args = ap.parse_args(argv)
    ref = {r["run_id"]: r for r in read_runs(Path(args.reference), args.study)}
    rows = []
    for item in args.studies:
        label, sep, directory = item.partition("=")
        if not sep:
            raise SystemExit(f"{item!r}: expected LABEL=DIR")
        rows.append(summarise(label, read_runs(Path(directory), args.study), ref))
        r = rows[-1]
        print(
            f"{label}: {r['runs']} runs ({r['failed']} failed) in {r['wall_s'] / 60:.1f} min "
            f"wall, {r['worker_s'] / 60:.1f} worker-min; {r['same_as_reference']} of "
            f"{r['reference_runs']} measurements identical to the reference"
        )
    print(f"wrote {write_csv(args.name, rows)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

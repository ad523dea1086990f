"""``bathprint reproduce fig1c|fig2|fig3|stability|coils|all --out DIR [--quick]``."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

FIGURES = ("stability", "fig3", "coils", "fig2", "fig1c")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "figure",
        choices=(*FIGURES, "all"),
        help="coils: steady coiling over 20+ turns, with and without gelation",
    )
    p.add_argument("--out", default="runs/reproduce", help="output directory")
    p.add_argument("--quick", action="store_true", help="small grids: about 2 minutes in all")
    p.add_argument("--workers", type=int, default=None, help="parallel runs (default: cores)")
    p.add_argument(
        "--scheduler",
        default=None,
        help="Dask scheduler address (or local-dask) for the simulation runs",
    )


def run_args(args: argparse.Namespace) -> int:
    from bathprint.studies.reproduce import coils, fig1c, fig2, fig3, stability

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    names = FIGURES if args.figure == "all" else (args.figure,)
    report_path = out / "reproduce.json"
    report = json.loads(report_path.read_text()) if report_path.exists() else {}
    for name in names:
        t0 = time.perf_counter()
        if name == "stability":
            result = stability.run(out, args.quick)
        elif name == "fig3":
            result = fig3.run(out, args.quick)
        elif name == "coils":
            result = coils.run(out, args.quick)
        elif name == "fig2":
            result = fig2.run(out, args.quick, args.workers, args.scheduler)
        else:
            result = fig1c.run(out, args.quick, args.workers, args.scheduler)
        report[name] = {
            "wall_time_s": time.perf_counter() - t0,
            "quick": args.quick,
            "result": result,
        }
        report_path.write_text(json.dumps(report, indent=2, default=float))
        print(f"{name}: {report[name]['wall_time_s']:.1f} s -> {out}/{name}*.png, .csv")
        print(json.dumps(result, indent=2, default=float)[:1500])
    return 0

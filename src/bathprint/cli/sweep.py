"""``bathprint sweep SCENE --grid KEY=V1,V2 ... --out FILE``: a grid of scenes, serially,
on a process pool (the core alone) or on Dask (the ``dask`` extra); see
:mod:`bathprint.studies.sweep`."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint.cli._common import guarded, scheduler_needs_dask
from bathprint.studies import sweep


def add_parser(sub: Any) -> argparse.ArgumentParser:
    sw = sub.add_parser("sweep", help="run a grid of scenes; resumable; process pool or Dask")
    sweep.add_arguments(sw)
    sw.set_defaults(run=run)
    return sw


@guarded("bathprint sweep")
def run(args: argparse.Namespace) -> int:
    scheduler_needs_dask(args.scheduler)
    return sweep.run_args(args)

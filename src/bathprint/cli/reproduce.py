"""``bathprint reproduce FIGURE``: the paper's figures and studies (see
:mod:`bathprint.studies.reproduce.cli`)."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint.cli._common import guarded, scheduler_needs_dask
from bathprint.studies.reproduce import cli as reproduce_cli


def add_parser(sub: Any) -> argparse.ArgumentParser:
    rp = sub.add_parser(
        "reproduce",
        help="the paper's figures and studies: "
        "fig1c|fig2|fig3|stability|coils|all|ablation|gravity|fast_jets",
    )
    reproduce_cli.add_arguments(rp)
    rp.set_defaults(run=run)
    return rp


@guarded("bathprint reproduce")
def run(args: argparse.Namespace) -> int:
    scheduler_needs_dask(args.scheduler)
    return reproduce_cli.run_args(args)

"""``bathprint bench BENCHMARK``: the simulator's benchmarks (``accuracy``, the
work-precision study of :mod:`bathprint.studies.accuracy`)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from bathprint.studies import accuracy


def add_parser(sub: Any) -> argparse.ArgumentParser:
    b = sub.add_parser(
        "bench",
        help="benchmarks: bathprint bench accuracy --out DIR [--quick]",
        description="Benchmarks of the simulator.",
    )
    bsub = b.add_subparsers(dest="benchmark", metavar="BENCHMARK")
    a = bsub.add_parser(
        "accuracy",
        help="work-precision study: error against wall time per integrator and refinement "
        "(bathprint bench accuracy --help)",
        description=accuracy.__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    accuracy.add_arguments(a)
    a.set_defaults(run=accuracy.run_args)
    b.set_defaults(run=run, bench_parser=b)
    return b


def run(args: argparse.Namespace) -> int:
    """``bathprint bench`` without a benchmark: its help, on stderr, and exit code 2 (as
    argparse does for a missing sub-command)."""
    args.bench_parser.print_help(sys.stderr)
    print("bathprint bench: error: name a benchmark (accuracy)", file=sys.stderr)
    return 2

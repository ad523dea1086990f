"""``bathprint theory [--json] [--n N]``: scaling laws and linear stability
(:mod:`bathprint.analysis.theory`)."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint.analysis import theory


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "theory",
        help="scaling laws and linear stability: bathprint theory [--json]",
        description=theory.DESCRIPTION,
    )
    theory.add_arguments(p)
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    return theory.run_args(args)

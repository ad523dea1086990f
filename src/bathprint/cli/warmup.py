"""``bathprint warmup``: compile the numba kernels now (:mod:`bathprint.warmup`)."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint import warmup


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "warmup",
        help="compile the numba kernels now (once after an install)",
        description=warmup.DESCRIPTION,
    )
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    return warmup.run_args(args)

"""The ``bathprint`` command: one module per command, each with ``add_parser(subparsers)``
(its options and help) and ``run(args) -> int`` (its work and exit code); :func:`main`
parses the command line with argparse and calls the chosen command's ``run``.

Every command checks its options (output paths included) before it starts working and
refuses bad input with one line on stderr and exit code 2; a command that needs an extra
that is not installed says which, with its ``pip install`` line, and exits 2; a diverged
simulation exits 3; an interrupted command (Ctrl-C or SIGTERM) exits 130 / 143.

Building the parser imports no optional dependency (torch, stable-baselines3, plotly, dask
and the rest load inside the commands that use them).
"""

from __future__ import annotations

import argparse
import importlib
import sys
from collections.abc import Sequence

#: the commands, in the order ``bathprint --help`` lists them (modules of this package)
COMMANDS = (
    "simulate",
    "scenes",
    "show",
    "validate",
    "view",
    "theory",
    "warmup",
    "play",
    "train",
    "evaluate",
    "write",
    "baselines",
    "bench",
    "sweep",
    "reproduce",
    "composites",
)


def _version() -> str:
    from bathprint import __version__

    return __version__


def build_parser() -> argparse.ArgumentParser:
    """The whole command line: every command's sub-parser, each added by its module."""
    p = argparse.ArgumentParser(
        prog="bathprint",
        description="Simulate soft gelling filaments extruded into a reacting bath.",
    )
    p.add_argument("--version", action="version", version=f"bathprint {_version()}")
    sub = p.add_subparsers(dest="command", required=True)
    for name in COMMANDS:
        importlib.import_module(f"bathprint.cli.{name}").add_parser(sub)
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Parse ``argv`` (default: the process's arguments) and run the command; its exit code."""
    args = build_parser().parse_args(sys.argv[1:] if argv is None else list(argv))
    return int(args.run(args))


__all__ = ["COMMANDS", "build_parser", "main"]

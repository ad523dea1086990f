"""``bathprint play ENV --policy random|constant|zero --out DIR``: one episode of an
environment to a GIF (:mod:`bathprint.envs.play`)."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint.envs import play


def add_parser(sub: Any) -> argparse.ArgumentParser:
    p = sub.add_parser(
        "play",
        help="one episode of an environment to a GIF: bathprint play ENV ...",
        description=play.DESCRIPTION,
    )
    play.add_arguments(p)
    p.set_defaults(run=run)
    return p


def run(args: argparse.Namespace) -> int:
    return play.run_args(args)

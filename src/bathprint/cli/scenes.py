"""``bathprint scenes``: one line per built-in scene."""

from __future__ import annotations

import argparse
from typing import Any

from bathprint.cli._common import guarded


def add_parser(sub: Any) -> argparse.ArgumentParser:
    sc = sub.add_parser("scenes", help="list the built-in scenes")
    sc.set_defaults(run=run)
    return sc


@guarded("bathprint scenes")
def run(args: argparse.Namespace) -> int:
    from bathprint.core.scene import builtin_scene_names, load_scene, scene_summary_line

    for name in builtin_scene_names():
        print(scene_summary_line(load_scene(name)))
    return 0

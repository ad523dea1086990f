"""``bathprint show SCENE [--set KEY=VALUE]... [--json]``: a scene as TOML that
``bathprint simulate`` reads back."""

from __future__ import annotations

import argparse
import json
from typing import Any

from bathprint.cli._common import guarded

HELP = (
    "print a scene, with overrides applied, as TOML: `bathprint show SCENE > my.toml` "
    "then `bathprint simulate my.toml` runs exactly that scene"
)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    sh = sub.add_parser("show", help=HELP, description=HELP)
    sh.add_argument("scene", help="built-in scene name or a TOML path")
    sh.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a value")
    sh.add_argument("--json", action="store_true", help="JSON instead of TOML (not read back)")
    sh.set_defaults(run=run)
    return sh


@guarded("bathprint show")
def run(args: argparse.Namespace) -> int:
    from bathprint.core.scene import load_scene, parse_override, scene_to_toml

    overrides = dict(parse_override(s) for s in args.set or [])
    scene = load_scene(args.scene, overrides)
    if args.json:
        print(json.dumps(scene.to_dict(), indent=2))
    else:
        print(scene_to_toml(scene), end="")
    return 0

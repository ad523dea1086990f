"""``python -m bathprint.envs.shapes write [DIR]``: write every named shape (CSV) and
``index.json`` (default DIR: ``envs/targets/shapes``); ``... list``: print the index."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path


def main(argv: Sequence[str] | None = None) -> int:
    from bathprint.envs import shapes

    ap = argparse.ArgumentParser(prog="python -m bathprint.envs.shapes", description=__doc__)
    ap.add_argument("action", choices=("write", "list"))
    ap.add_argument("directory", nargs="?", default=None)
    args = ap.parse_args(argv)
    if args.action == "write":
        paths = shapes.write(Path(args.directory) if args.directory else None)
        print(f"wrote {len(paths)} files under {paths[-1].parent}")
        return 0
    for row in shapes.index():
        mark = "" if row["writable"] else "  NOT WRITABLE: " + "; ".join(row["issues"])
        print(
            f"{row['family']:8s} {row['set']:10s} {row['name']:22s} "
            f"{row['length_mm']:6.1f} mm{mark}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())

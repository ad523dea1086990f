"""``bathprint simulate [SCENE] [--set KEY=VALUE]... [--out DIR]``: run a scene and write
its trajectory, summary and picture."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from bathprint.cli._common import guarded


def add_parser(sub: Any) -> argparse.ArgumentParser:
    s = sub.add_parser("simulate", help="run a scene and write trajectory, summary and picture")
    s.add_argument(
        "scene",
        nargs="?",
        default="paper_simulation",
        help="built-in scene name (see `bathprint scenes`) or a TOML path "
        "(default: paper_simulation)",
    )
    s.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a scene value by dotted key, e.g. flow.q_outer_ml_min=5",
    )
    s.add_argument("--out", help="output directory (default runs/SCENE)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.add_argument(
        "--accuracy",
        choices=("draft", "balanced", "fine", "custom"),
        help="accuracy preset (same as --set numerics.accuracy=...)",
    )
    s.set_defaults(run=run)
    return s


@guarded("bathprint simulate")
def run(args: argparse.Namespace) -> int:
    from bathprint import simulate
    from bathprint.core.scene import load_scene, parse_override
    from bathprint.paths import check_output_dir

    overrides = dict(parse_override(s) for s in args.set or [])
    if args.accuracy:
        overrides["numerics.accuracy"] = args.accuracy
    load_scene(args.scene, overrides)  # a bad scene is refused first
    out = check_output_dir(args.out or f"runs/{Path(args.scene).stem}", "--out")
    result = simulate(args.scene, overrides, out_dir=out, progress=not args.quiet)
    s = result.summary
    mb = s["mass_balance"]
    print(
        f"{s['scene']}: {s['time_s']:.3g} s simulated in {s['wall_time_s']:.2f} s wall "
        f"({s['steps']} steps, {s['rejected_steps']} rejected, {s['nodes']} nodes); "
        f"mass balance error {mb['relative_error']:.2e}"
    )
    print(
        f"wrote {out}/trajectory.npz, summary.json"
        + (", filament.png" if result.scene.outputs.plot else "")
    )
    return 0

"""``bathprint view RUN_DIR [--out FILE] [--png]`` and ``bathprint view --env ENV``: a run
(or one episode of an environment) as an interactive 3D page (HTML; the ``viewer`` extra),
or a run's last frame as a PNG picture (the core alone)."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from bathprint.cli._common import guarded

HELP = (
    "an interactive 3D page (HTML, opens without a network) of a run directory, or of "
    "one episode of an environment with its target (--env); --png: a picture of the run"
)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    vw = sub.add_parser("view", help=HELP, description=HELP)
    vw.add_argument("run_dir", nargs="?", help="a directory written by bathprint simulate")
    vw.add_argument(
        "--out",
        help="the page (default RUN_DIR/view.html, or episode.html); with --png or a name "
        "ending in .png, the picture (default RUN_DIR/view.png)",
    )
    vw.add_argument(
        "--png",
        action="store_true",
        help="a PNG picture of the run's last frame (as filament.png) instead of the page; "
        "needs no optional dependency",
    )
    vw.add_argument(
        "--colour",
        "--color",
        dest="colour",
        default="age",
        choices=("age", "modulus", "density", "inner_fraction"),
        help="material column the page starts with (it can be changed on the page)",
    )
    vw.add_argument("--env", help="play an episode of this environment instead of a run")
    vw.add_argument(
        "--policy",
        default="random",
        help="with --env: a baseline (random, constant, feedforward, feedforward_calibrated), "
        "a trained run directory or a model .zip",
    )
    vw.add_argument("--seed", type=int, default=0, help="with --env: the episode's seed")
    vw.add_argument("--target-index", type=int, default=0, help="with --env: held-out target")
    vw.add_argument("--accuracy", choices=("draft", "balanced", "fine"), help="with --env: preset")
    vw.set_defaults(run=run)
    return vw


def _wants_png(args: argparse.Namespace) -> bool:
    return bool(args.png) or (args.out is not None and Path(args.out).suffix.lower() == ".png")


def _png(args: argparse.Namespace) -> int:
    from bathprint.errors import OptionError
    from bathprint.paths import check_output_file
    from bathprint.viz.plotting import plot_run

    if args.env is not None:
        raise OptionError(
            f"--png with --env {args.env}: an episode is drawn as a page only; allowed: "
            "bathprint view RUN_DIR --png, or bathprint view --env ENV --out FILE.html"
        )
    if args.colour != "age":
        raise OptionError(
            f"--colour = {args.colour!r} with --png: the picture colours segments by "
            "material age; allowed with --png: age (the page offers every column)"
        )
    out = check_output_file(args.out or Path(args.run_dir) / "view.png", "--out")
    path = plot_run(args.run_dir, out)
    print(f"wrote {path}")
    return 0


@guarded("bathprint view")
def run(args: argparse.Namespace) -> int:
    from bathprint._extras import MissingExtraError, require_extra
    from bathprint.errors import OptionError

    if (args.run_dir is None) == (args.env is None):
        raise OptionError(
            "bathprint view takes a RUN_DIR or --env ENV (one of them); allowed: "
            "bathprint view RUN_DIR [--out FILE.html] or bathprint view --env ENV --policy P"
        )
    if _wants_png(args):
        return _png(args)
    try:
        require_extra("viewer", "the interactive page (HTML)")
    except MissingExtraError as exc:
        hint = "; a picture needs only the core: --png" if args.run_dir is not None else ""
        raise MissingExtraError(f"{exc}{hint}") from None
    from bathprint.viz import view

    if args.run_dir is not None:
        path = view.run_page(args.run_dir, args.out, colour=args.colour)
    else:
        from bathprint.agents.episode_view import episode_page
        from bathprint.paths import check_output_file

        out = check_output_file(args.out or "episode.html", "--out")
        path, info = episode_page(
            args.env,
            args.policy,
            out,
            seed=args.seed,
            target_index=args.target_index,
            accuracy=args.accuracy,
        )
        print(f"episode: metric {info.get('metric', float('nan')):.4f}")
    print(f"wrote {path} (open it in a browser)")
    return 0

"""``bathprint evaluate RUN_DIR_OR_POLICY [...] --env ENV [--episodes N] [--seed S]
[--out DIR]``: deterministic rollouts on the held-out targets
(:mod:`bathprint.agents.evaluate`). Needs the ``rl`` extra."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from typing import Any, TypeVar

from bathprint.cli._common import interrupted, needs_extra

PROG = "bathprint evaluate"
T = TypeVar("T")


def add_parser(sub: Any) -> argparse.ArgumentParser:
    ap = sub.add_parser(
        "evaluate",
        help="held-out rollouts: bathprint evaluate POLICY... --env ENV",
        description="Deterministic rollouts of policies on the held-out targets.",
    )
    ap.add_argument(
        "policies",
        nargs="+",
        help="run directories, model .zip files, baselines (random, constant, feedforward, "
        "feedforward_calibrated; controller: version 1 on) or planners (oracle, mpc, cem: "
        "version 1 on)",
    )
    ap.add_argument("--env", required=True)
    ap.add_argument(
        "--target-set",
        choices=("eval", "validation", "test", "ood_test"),
        default=None,
        help="the held-out set (default: test; version 0: eval; ood_test: the shape "
        "environments' shapes of kinds never trained on)",
    )
    ap.add_argument("--episodes", type=int, default=16)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="runs/evaluate")
    ap.add_argument(
        "--accuracy",
        choices=("draft", "balanced", "fine"),
        default=None,
        help="accuracy preset (default: the run's own, else draft)",
    )
    ap.add_argument("--images", type=int, default=3, help="episodes to draw as PNG")
    ap.add_argument("--no-animation", action="store_true", help="skip the GIF of episode 0")
    ap.add_argument(
        "--side-by-side",
        default=None,
        metavar="GIF",
        help="also write episode 0 of every policy side by side (in the order given, each "
        "captioned with its final metric; 0.6 of the size, every second frame) to this .gif",
    )
    ap.add_argument(
        "--target-files",
        nargs="+",
        default=None,
        metavar="CSV",
        help="score on these shapes (x_mm,y_mm,z_mm) instead of the test set: one episode "
        "each, whole-shape error in mm, rows in OUT/targets.csv",
    )
    ap.add_argument(
        "--shape-family",
        choices=("floor", "free", "buoyant"),
        default=None,
        help="--target-files: the shapes' family (default: the environment's)",
    )
    ap.add_argument(
        "--allow-overlap",
        action="store_true",
        help="--target-files: score free shapes whose strands overlap instead of refusing them",
    )
    ap.add_argument("--quiet", action="store_true")
    ap.set_defaults(run=run)
    return ap


@needs_extra(PROG, "rl", "evaluating policies")
def run(args: argparse.Namespace) -> int:
    from bathprint.agents.evaluate import (
        evaluate_many,
        evaluate_target_files,
        format_table,
        format_target_rows,
    )

    if args.images < 0:
        print(f"{PROG}: --images = {args.images}; must be >= 0", file=sys.stderr)
        return 2
    if args.target_files:  # one row per shape and policy
        rows = _stoppable(
            "targets.csv was not written",
            lambda: evaluate_target_files(
                args.policies,
                args.env,
                args.target_files,
                seed=args.seed,
                out=args.out,
                accuracy=args.accuracy,
                family=args.shape_family,
                progress=not args.quiet,
                allow_overlap=args.allow_overlap,
            ),
        )
        if isinstance(rows, int):
            return rows
        print(format_target_rows(rows), end="")
        print(f"wrote {args.out}/targets.csv")
        return 0
    summaries = _stoppable(
        "the policy being evaluated wrote nothing",
        lambda: evaluate_many(
            args.policies,
            args.env,
            episodes=args.episodes,
            seed=args.seed,
            out=args.out,
            accuracy=args.accuracy,
            images=args.images,
            animate=not args.no_animation,
            progress=not args.quiet,
            target_set=args.target_set,
            side_by_side=args.side_by_side,
        ),
    )
    if isinstance(summaries, int):
        return summaries
    print(format_table(summaries), end="")
    print(f"wrote {args.out}/table.md and one directory per policy")
    return 0


def _stoppable(lost: str, work: Callable[[], T]) -> T | int:
    """``work()`` under SIGINT / SIGTERM handling: its result, or the exit code after an
    interruption (saying what ``lost``) or a refused value (2), each said in one line."""
    from bathprint.signals import SignalStop, exit_code

    try:
        with SignalStop(deferred=False):
            return work()
    except KeyboardInterrupt as exc:
        print(interrupted("evaluate", exc, lost), file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError, RuntimeError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2

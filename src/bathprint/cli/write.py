"""``bathprint write SHAPE.csv [--policy controller] [--family floor] [--env ID]
[--accuracy draft] [--seed 0] --out DIR [--overwrite]``: print a shape of your own with a
policy and write the curve written, the target, the error in mm, a picture and the
interactive page (:mod:`bathprint.agents.write`)."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from bathprint.cli._common import guarded

PROG = "bathprint write"
HELP = (
    "print a shape of your own (a CSV of x_mm,y_mm,z_mm) with a policy and write the curve "
    "written, the error in mm, a picture and an interactive page"
)


def add_parser(sub: Any) -> argparse.ArgumentParser:
    w = sub.add_parser("write", help=HELP, description=HELP)
    w.add_argument("shape", metavar="SHAPE.csv", help="the shape: a CSV with x_mm,y_mm,z_mm")
    w.add_argument(
        "--policy",
        default="controller",
        help="controller (the family's tuned controller; default), cem (plans on the "
        "simulator itself, far slower), constant, feedforward, feedforward_calibrated, "
        "random, a trained run directory or a model .zip",
    )
    w.add_argument(
        "--family",
        choices=("floor", "free", "buoyant"),
        default=None,
        help="the shape's family: floor (drawn on the bath's floor by a moving needle), free "
        "(coils in the bath), buoyant (parts settling at heights); default floor, or a "
        "trained policy's own",
    )
    w.add_argument(
        "--env",
        default=None,
        help="the environment to write on (a shape environment, spec version 3); default: "
        "the family's (WriteShape-v3, CoilRadius-v2, BuoyantLayers-v2)",
    )
    w.add_argument(
        "--accuracy",
        choices=("draft", "balanced", "fine"),
        default=None,
        help="accuracy preset (default: a trained policy's own, else draft)",
    )
    w.add_argument("--seed", type=int, default=0, help="the episode's seed (its start state)")
    w.add_argument("--out", required=True, help="output directory")
    w.add_argument(
        "--overwrite",
        action="store_true",
        help="replace the files of an earlier print in --out (else such a directory is refused)",
    )
    w.set_defaults(run=run)
    return w


@guarded(PROG)
def run(args: argparse.Namespace) -> int:
    from bathprint.agents.write import write_shape

    res = write_shape(
        args.shape,
        policy=args.policy,
        out=args.out,
        family=args.family,
        env_id=args.env,
        accuracy=args.accuracy,
        seed=args.seed,
        overwrite=args.overwrite,
    )
    r = res.result
    verdict = "a success" if r["success"] else "not a success"
    bound = f"RMS <= {r['rms_max_mm']:g} mm" + (
        f", max <= {r['max_max_mm']:g} mm" if r["max_max_mm"] is not None else ""
    )
    names = ", ".join(p.name for p in res.files)
    diverged = (
        ""
        if r["complete"]
        else f"; the simulation diverged ({r['sim_error']}): the errors are of the "
        f"{r['written_samples']} of {r['target_samples']} samples written"
    )
    print(
        f"{r['shape_file']} with {r['policy_label']} on {r['env_id']}: RMS "
        f"{r['rms_mm']:.2f} mm, max {r['max_mm']:.2f} mm, {verdict} ({r['family']}: {bound})"
        f"{diverged}; wrote {names} to {res.out}"
    )
    if res.view_missing:
        print(f"{PROG}: view.html not written: {res.view_missing}", file=sys.stderr)
    return 0 if r["complete"] else 3

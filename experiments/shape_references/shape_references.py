"""Every reference policy on every named shape of the shapes benchmark, scored by the
whole-shape error (mm): the rows behind the references table of docs/shapes.md.

    python experiments/shape_references/shape_references.py            # everything (~30 min)
    python experiments/shape_references/shape_references.py --policies controller cem \
        --families floor --sets validation

One deterministic episode (seed 0) per (family, set, shape, policy) in the family's
environment (bathprint.agents.controller.FAMILY_ENVS) at the draft preset. Rows are
appended to results/references.csv as each finishes; a run resumes where it stopped (a row
already there for the same code version is kept). Shapes marked not writable are scored
too (the planners' error on them is what the physics attains).
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import RESULTS, write_meta  # noqa: E402

from bathprint.agents.controller import FAMILY_ENVS, family_shapes, score_shapes  # noqa: E402
from bathprint.agents.policies import load_policy  # noqa: E402
from bathprint.envs import make  # noqa: E402
from bathprint.envs.shapes import index  # noqa: E402

POLICIES = ("constant", "feedforward", "controller", "cem", "mpc")
SETS = ("validation", "test", "ood_test")
COLUMNS = (
    "family",
    "set",
    "shape",
    "writable",
    "policy",
    "rms_mm",
    "max_mm",
    "success",
    "metric",
    "truncated",
    "cpu_s",
    "env_id",
    "accuracy",
)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--policies", nargs="+", default=list(POLICIES))
    ap.add_argument("--families", nargs="+", default=list(FAMILY_ENVS))
    ap.add_argument("--sets", nargs="+", default=list(SETS))
    ap.add_argument("--accuracy", default="draft")
    ap.add_argument("--out", type=Path, default=RESULTS / "references.csv")
    args = ap.parse_args()

    done: set[tuple[str, ...]] = set()
    if args.out.is_file():
        with args.out.open() as f:
            done = {(r["family"], r["set"], r["shape"], r["policy"]) for r in csv.DictReader(f)}
    else:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with args.out.open("w", newline="") as f:
            csv.DictWriter(f, fieldnames=COLUMNS).writeheader()
    writable = {(r["family"], r["set"], r["name"]): r["writable"] for r in index()}
    jobs = [
        (fam, st, name, pts, pol)
        for fam in args.families
        for st in args.sets
        for name, pts in family_shapes(fam, st)
        for pol in args.policies
        if (fam, st, name, pol) not in done
    ]
    envs: dict[str, object] = {}
    policies: dict[tuple[str, str], object] = {}
    for fam, st, name, pts, pol in tqdm(jobs, desc="shape references"):
        env_id = FAMILY_ENVS[fam]
        if env_id not in envs:
            envs[env_id] = make(env_id, accuracy=args.accuracy)
        env = envs[env_id]
        if (env_id, pol) not in policies:
            policies[(env_id, pol)] = load_policy(pol, env, env_id)[0]
        c0 = time.process_time()
        row = score_shapes(env, policies[(env_id, pol)], fam, [(name, pts)])[0]
        cpu = time.process_time() - c0
        out = {
            "family": fam,
            "set": st,
            "shape": name,
            "writable": writable[(fam, st, name)],
            "policy": pol,
            "rms_mm": round(row["rms_mm"], 4) if math.isfinite(row["rms_mm"]) else "nan",
            "max_mm": round(row["max_mm"], 4) if math.isfinite(row["max_mm"]) else "nan",
            "success": row["success"],
            "metric": round(row["metric"], 5),
            "truncated": row["truncated"],
            "cpu_s": round(cpu, 2),
            "env_id": env_id,
            "accuracy": args.accuracy,
        }
        with args.out.open("a", newline="") as f:
            csv.DictWriter(f, fieldnames=COLUMNS).writerow(out)
    write_meta(args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

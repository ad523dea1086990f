"""Agents on the shape environments against the tuned controller, on the test shapes and on
the held-out kinds (ood_test): each run's model selected on validation, every reference,
one deterministic episode per shape (seed 0), the whole-shape RMS error in mm.

    python experiments/shape_agents/shape_agents.py --campaign runs/campaign_shapes \
        --env CoilRadius-v2

For every trained run under CAMPAIGN/<Env>/<group>/seed<S>/ (its validation-selected model,
``bathprint evaluate RUN_DIR``) and every reference (controller, cem), plays each shape of
``test`` and ``ood_test``; writes results/<Env>.csv (one row per policy, run, set, shape) and
results/<Env>_summary.csv (per group and set: mean RMS error, shapes written, and the paired
difference group - controller with a 95% bootstrap interval over seeds and shapes, 10,000
resamples stratified by shape, seed 0).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import write_csv  # noqa: E402

from bathprint.agents.evaluate import evaluate_policy_spec  # noqa: E402
from bathprint.envs import make, resolve_id, target_set_size  # noqa: E402

REFERENCES = ("controller", "cem")
SETS = ("test", "ood_test")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--campaign", type=Path, default=Path("runs/campaign_shapes"))
    ap.add_argument("--env", default="CoilRadius-v2")
    args = ap.parse_args()
    env_id = resolve_id(args.env)
    short = env_id.split("/")[1]
    runs = sorted(p for p in (args.campaign / short).glob("*/seed*") if (p / "run.json").is_file())
    if not runs:
        raise SystemExit(f"no runs under {args.campaign / short}")
    policies = [(name, name, 0) for name in REFERENCES] + [
        (str(r), r.parent.name, int(r.name.removeprefix("seed"))) for r in runs
    ]
    rows = []
    for spec, group, seed in policies:
        for st in SETS:
            env = make(env_id, accuracy="draft", target_set=st)
            n = target_set_size(env.unwrapped, st)
            env.close()
            _, _, eps = evaluate_policy_spec(
                spec, env_id, n, 0, None, progress=False, target_set=st
            )
            for k, ep in enumerate(eps):
                rows.append(
                    {
                        "group": group,
                        "run_seed": seed,
                        "set": st,
                        "shape_index": k,
                        "target_key": ep.target_key,
                        "rms_mm": round(ep.metrics["rms_mm"], 4),
                        "max_mm": round(ep.metrics["max_mm"], 4),
                        "success": bool(ep.is_success == 1.0),
                        "truncated": ep.truncated,
                    }
                )
            print(group, seed, st, np.mean([r["rms_mm"] for r in rows[-n:]]).round(3), flush=True)
    write_csv(short, rows)
    rng = np.random.default_rng(0)
    summary = []
    for st in SETS:
        ctl = {r["shape_index"]: r["rms_mm"] for r in rows if r["group"] == "controller"
               and r["set"] == st}  # fmt: skip
        for group in dict.fromkeys(r["group"] for r in rows):
            rs = [r for r in rows if r["group"] == group and r["set"] == st]
            seeds = sorted({r["run_seed"] for r in rs})
            shapes = sorted(ctl)
            d = np.array([[next(r["rms_mm"] for r in rs if r["run_seed"] == s and
                                r["shape_index"] == k) - ctl[k] for k in shapes]
                          for s in seeds])  # fmt: skip
            boot = []
            for _ in range(10_000):  # stratified by shape: resample seeds within each shape
                pick = rng.integers(0, len(seeds), (len(shapes),))
                boot.append(np.mean(d[pick, np.arange(len(shapes))]))
            lo, hi = np.percentile(boot, [2.5, 97.5])
            summary.append(
                {
                    "set": st,
                    "group": group,
                    "runs": len(seeds),
                    "shapes": len(shapes),
                    "mean_rms_mm": round(float(np.mean([r["rms_mm"] for r in rs])), 4),
                    "success_rate": round(float(np.mean([r["success"] for r in rs])), 3),
                    "minus_controller_mm": round(float(d.mean()), 4),
                    "minus_controller_lo": round(float(lo), 4),
                    "minus_controller_hi": round(float(hi), 4),
                }
            )
            print(summary[-1], flush=True)
    write_csv(f"{short}_summary", summary)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

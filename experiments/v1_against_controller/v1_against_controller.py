"""The version-1 headline agents against the strongest classical reference: the one of
``constant``, ``feedforward_calibrated`` and the tuned ``controller`` with the lowest mean
metric on the *validation* targets, its test metric beside the agent chosen on validation,
and their paired difference with a 95% bootstrap interval.

    python experiments/v1_against_controller/v1_against_controller.py   # ~1 min

Plays ``controller`` (bathprint.agents.controller, gains tuned on the shape families'
validation shapes) on each version-1 environment's 16 test targets exactly as the campaign
plays its baselines (bathprint.agents.campaign.evaluate_one: seed 0, episode k on target k)
into agents/results/<Env>/baselines/controller/, plays the three classical references on
the 16 validation targets (seed 0) to choose among them, then reads the campaign's
per-target test scores (agents/results/<Env>/scores.csv) of the chosen reference and of the
agent group with the best mean validation metric (runs.csv). The difference agent -
reference is averaged over the agent's seeds per target; its interval is a percentile
bootstrap over targets (10,000 resamples, seed 0).
Writes results/v1_against_controller.csv.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import ROOT, write_csv  # noqa: E402

from bathprint.agents.campaign import evaluate_one  # noqa: E402
from bathprint.agents.evaluate import evaluate_policy_spec  # noqa: E402

CLASSICAL = ("constant", "feedforward_calibrated", "controller")

ENVS = ("BuoyantLayers-v1", "CoilRadius-v1", "WriteShape-v1", "WriteShape-v2")
RESULTS = ROOT / "agents" / "results"


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open() as f:
        return list(csv.DictReader(f))


def chosen_agent(env_dir: Path) -> str:
    """The agent group with the lowest mean validation metric of its selected models."""
    val: dict[str, list[float]] = {}
    for r in _rows(env_dir / "runs.csv"):
        if r["selection_target_set"] == "validation" and r["selected_validation_metric"]:
            val.setdefault(r["name"], []).append(float(r["selected_validation_metric"]))
    return min(val, key=lambda k: sum(val[k]) / len(val[k]))


def main() -> int:
    out = []
    rng = np.random.default_rng(0)
    for short in ENVS:
        env_dir = RESULTS / short
        env_id = f"bathprint/{short}"
        found = evaluate_one("controller", env_id, env_dir / "baselines" / "controller", 16, 0)
        for extra in [found.parent / "episodes.json", *found.parent.glob("*.png")]:
            extra.unlink(missing_ok=True)  # the exported layout: summary.json, episodes.csv
        ctl = {r["target_key"]: float(r["metric"]) for r in _rows(found.parent / "episodes.csv")}
        validation = {
            name: evaluate_policy_spec(
                name, env_id, 16, 0, progress=False, target_set="validation"
            )[1]["mean_metric"]
            for name in CLASSICAL
        }
        reference = min(CLASSICAL, key=lambda n: validation[n])
        agent = chosen_agent(env_dir)
        per: dict[str, list[float]] = {}
        test: dict[str, dict[str, float]] = {"controller": ctl}
        for r in _rows(env_dir / "scores.csv"):
            if r["policy"] == agent:
                per.setdefault(r["target_key"], []).append(float(r["metric"]))
            elif not r["run"]:
                test.setdefault(r["policy"], {})[r["target_key"]] = float(r["metric"])
        mpc = test["mpc"]
        keys = sorted(ctl)
        a = np.array([np.mean(per[k]) for k in keys])
        c = np.array([test[reference][k] for k in keys])
        d = a - c
        boot = d[rng.integers(0, len(d), (10_000, len(d)))].mean(axis=1)
        lo, hi = np.percentile(boot, [2.5, 97.5])
        out.append(
            {
                "env": short,
                "agent": agent,
                "reference": reference,
                **{f"{n}_validation_metric": round(float(validation[n]), 4) for n in CLASSICAL},
                "agent_mean_metric": round(float(a.mean()), 4),
                "reference_mean_metric": round(float(c.mean()), 4),
                "controller_mean_metric": round(float(np.mean([ctl[k] for k in keys])), 4),
                "mpc_mean_metric": round(float(np.mean([mpc[k] for k in keys])), 4),
                "difference": round(float(d.mean()), 4),
                "difference_lo": round(float(lo), 4),
                "difference_hi": round(float(hi), 4),
                "targets_agent_better": int((d < 0).sum()),
                "targets": len(keys),
            }
        )
        print(out[-1])
    write_csv("v1_against_controller", out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

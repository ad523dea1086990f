"""The fast jets: what stops the effects of the ablation study at the paper's fast points.

At 22G and 5 or 20 ml/min (exit speeds 0.63 and 2.5 m/s) the ablation's inertia and
finite-Reynolds variants fail by the strain bound (docs/reproduction.md). One explanation
is that the model has no viscous stress in the rod, which a still-liquid jet has. This
study tests it: at the two points it runs inertia and finite-Re drag with and without the
``viscosity`` effect, the viscosity alone and with contact, and the baseline. Each runs
with the ablation's buckling seed (``needle.imperfection_um`` = 20: a transverse offset
of every node born at the needle, 0.2 of its node spacing) and with the default seed of
1 um, since a viscous rod holds the kinks of a large seed for eta_e / E (2.2 ms; a node is
born every 46 us at 20 ml/min). Per run: status, regime, and for a failed run its time,
node and cause (the ``SimulationError``). Budgets, resolution and floor: the ablation's
Fig. 1B runs (:func:`bathprint.studies.reproduce.ablation.base_overrides`). Resumable
through the sweep. Outputs: fast_jets.csv, fast_jets.md, fast_jets_runs.jsonl.
"""

from __future__ import annotations

import csv
import re
from pathlib import Path
from typing import Any

from bathprint.studies.reproduce import ablation
from bathprint.studies.sweep import run_id, run_sweep

SCENE = ablation.SCENE
# (name, label, effects added to the base, scene overrides)
COMBINATIONS: tuple[tuple[str, str, tuple[str, ...], dict[str, Any]], ...] = (
    ("stokes", "local Stokes drag only", (), {}),
    ("viscosity", "+ solution viscosity", ("viscosity",), {}),
    ("contact_viscosity", "+ contact + solution viscosity", ("contact", "viscosity"), {}),
    ("inertia", "+ inertia", ("inertia",), {}),
    ("inertia_viscosity", "+ inertia + solution viscosity", ("inertia", "viscosity"), {}),
    ("finite_re", "+ finite-Re drag", (), {"drag.model": "finite_re"}),
    (
        "finite_re_viscosity",
        "+ finite-Re drag + solution viscosity",
        ("viscosity",),
        {"drag.model": "finite_re"},
    ),
)
FULL = {"points": [(0.41, 5.0), (0.41, 20.0)], "seeds_um": (20.0, 1.0)}
QUICK = {"points": [(0.41, 5.0)], "seeds_um": (1.0,)}
QUICK_NAMES = ("stokes", "viscosity")
_FAILURE = re.compile(r"at t = ([0-9.eE+-]+) s, node (\d+): (.*)")


def plan(quick: bool = False) -> list[dict[str, Any]]:
    """The runs: point, seed, combination name and label, and the scene overrides."""
    cfg = QUICK if quick else FULL
    budget = ablation.QUICK_BUDGET if quick else ablation.FULL["fig1b"][1]
    runs = []
    for d, q in cfg["points"]:
        base = ablation.base_overrides(d, q, True, budget)
        for seed in cfg["seeds_um"]:
            for name, label, effects, over in COMBINATIONS:
                if quick and name not in QUICK_NAMES:
                    continue
                o = ablation.variant_overrides(base, effects, over)
                o["needle.imperfection_um"] = seed
                runs.append(
                    {"point": (d, q), "seed_um": seed, "name": name, "label": label, "over": o}
                )
    return runs


def failure(message: str | None) -> tuple[float | None, int | None, str | None]:
    """(time s, node, cause) of a ``SimulationError`` message, as far as it says them."""
    if not message:
        return None, None, None
    m = _FAILURE.search(message)
    if m is None:
        return None, None, message
    return float(m.group(1)), int(m.group(2)), m.group(3)


def run(
    out_dir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict:
    """Write fast_jets.csv and fast_jets.md (and fast_jets_runs.jsonl); return the table."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    runs = plan(quick)
    rows = run_sweep(
        SCENE,
        [r["over"] for r in runs],
        out / "fast_jets_runs.jsonl",
        workers=workers,
        scheduler=scheduler,
        extract=ablation.extract,
        progress=progress,
    )
    by_id = {row["run_id"]: row for row in rows}
    table = []
    for r in runs:
        row = by_id[run_id(SCENE, r["over"])]
        res = row.get("result") or {}
        t_fail, node, cause = failure((row.get("error") or {}).get("message"))
        d, q = r["point"]
        table.append(
            {
                "diameter_mm": d,
                "q_outer_ml_min": q,
                "imperfection_um": r["seed_um"],
                "variant": r["name"],
                "label": r["label"],
                "status": row["status"],
                "regime": res.get("measurements.regime"),
                "paper_regime": ablation.PAPER_REGIME.get((d, q)),
                "simulated_s": res.get("time_s"),
                "duration_s": r["over"]["duration_s"],
                "failure_time_s": t_fail,
                "failure_node": node,
                "failure_cause": cause,
                "wall_time_s": row.get("wall_time_s"),
            }
        )
    with (out / "fast_jets.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)
    (out / "fast_jets.md").write_text(markdown(table))
    return {"runs": len(table), "table": table}


def markdown(table: list[dict]) -> str:
    """One row per variant and seed, one column per point: the regime, or where the run
    failed and why."""
    points = sorted({(r["diameter_mm"], r["q_outer_ml_min"]) for r in table})
    head = ["variant", "seed (um)"] + [
        f"d = {d} mm, {q} ml/min (paper: {ablation.PAPER_REGIME.get((d, q))})" for d, q in points
    ]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    keys = []
    for r in table:
        k = (r["label"], r["imperfection_um"])
        if k not in keys:
            keys.append(k)
    for label, seed in keys:
        cells = [label, f"{seed:g}"]
        for d, q in points:
            hit = [
                r
                for r in table
                if (r["label"], r["imperfection_um"], r["diameter_mm"], r["q_outer_ml_min"])
                == (label, seed, d, q)
            ]
            cells.append(_cell(hit[0]) if hit else "")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"


def _cell(r: dict) -> str:
    if r["status"] == "ok":
        return str(r["regime"])
    if r["failure_time_s"] is None:
        return f"failed: {r['failure_cause']}"
    cause = str(r["failure_cause"]).split(" (")[0].split(" even")[0]
    return f"failed at {r['failure_time_s'] * 1e3:.3g} ms, node {r['failure_node']}: {cause}"

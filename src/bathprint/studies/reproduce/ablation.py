"""The ablation study: which effect moves which quantity of the paper's experiments, and by how
much.

Points: the paper's four Fig. 1B examples (floor 30 mm below the needle, as for Fig. 1C) and
the 16 points of bathprint's Fig. 2 grid, d = 0.26-0.84 mm by Q = 0.3-2 ml/min (no floor, as
for Fig. 2; the middle of the paper's d = 0.1-2 mm by Q = 0.2-20 ml/min, where the slow
jets of wide needles take long to buckle and the fast ones of thin needles crumple).
Variants: local slender-body
(Stokes) drag with elasticity and gravity only, then one effect added at a time (inertia,
self-contact, finite-Reynolds drag, nonlocal hydrodynamics, surface gelation, the solution's
viscous stress), the two that tighten the coils together (finite-Re drag with nonlocal
hydrodynamics, ``COMBINATIONS``), all of them together, and all of them with the ``liquid``
effect at its defaults (``all_liquid``: the jet's rest state flows while it is liquid,
docs/physics/index.md#liquid). A variant whose scene keys this build does not know (probed
by loading its scene) gets "not available" rows and is left out of "all". Per run: l (the
paper's inset definition and the other three of
:func:`bathprint.analysis.measure.buckling_length_definitions`), R, Lambda, omega (rad/s and
Hz), omega R / v, the regime, and the smallest gap between non-adjacent segments over the
saved frames (:func:`bathprint.analysis.measure.min_gap_ratio`; below
``INTERPENETRATION_RATIO`` the turns interpenetrate). On the Fig. 2 points the paper's three
fits are redone per variant (:func:`bathprint.studies.reproduce.fig2.fit_laws`).

Budgets: each run's node spacing, duration and frame interval follow
:func:`bathprint.studies.reproduce.runs.run_overrides` (onset plus ``turns`` coiling periods,
capped by ``max_duration_s`` and ``max_segments`` of filament). The full study's budget and
its measured cost are stated in docs/reproduction.md. The runs go through
:func:`bathprint.studies.sweep.run_sweep` (process pool or Dask; resumable: the same command
skips the runs already in ``ablation_runs.jsonl``).

Outputs: ``ablation.csv`` (one row per point and variant), ``ablation.md`` (the tables) and
``ablation.png`` (the relative change of each quantity per effect, the Fig. 2 prefactors per
variant, the Fig. 1B regimes per variant).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import SceneError
from bathprint.studies.reproduce.fig1c import HEIGHT_MM, PAPER_POINTS
from bathprint.studies.reproduce.fig2 import PAPER, fit_laws, law_row
from bathprint.studies.reproduce.runs import E_THEORY, run_overrides
from bathprint.studies.sweep import default_extract, run_id, run_sweep

SCENE = "drag_coiling_22G"
BASE_EFFECTS = ("elasticity", "drag", "gravity")
INTERPENETRATION_RATIO = 0.8  # min gap / contact distance below which turns interpenetrate


@dataclass(frozen=True)
class Variant:
    """Effects added to the base (elasticity, drag, gravity [, floor]) and scene overrides."""

    name: str
    label: str
    effects: tuple[str, ...] = ()
    overrides: dict[str, Any] = field(default_factory=dict)


VARIANTS = (
    Variant("stokes", "local Stokes drag only"),
    Variant("inertia", "+ inertia", ("inertia",)),
    Variant("contact", "+ contact", ("contact",)),
    Variant("finite_re", "+ finite-Re drag", (), {"drag.model": "finite_re"}),
    Variant("hydrodynamics", "+ nonlocal hydrodynamics", ("hydrodynamics",)),
    Variant("surface_gel", "+ surface gelation", ("gelation",), {"gelation.model": "surface"}),
    Variant("viscosity", "+ solution viscosity", ("viscosity",)),
)
# effects measured together (not one at a time, and not part of "all", which is built from
# VARIANTS): the two that tighten the coils, without the inertia that stops the fast points;
# does their product reach the paper's R prefactor (docs/reproduction.md)? Without contact
# their turns pass through each other, so they are measured with it too.
COMBINATIONS = (
    Variant(
        "finite_re_hydrodynamics",
        "+ finite-Re drag + nonlocal hydrodynamics",
        ("hydrodynamics",),
        {"drag.model": "finite_re"},
    ),
    Variant(
        "contact_finite_re_hydrodynamics",
        "+ contact + finite-Re drag + nonlocal hydrodynamics",
        ("contact", "hydrodynamics"),
        {"drag.model": "finite_re"},
    ),
)
ALL = "all"
# "all" plus the liquid jet (the Maxwell relaxation of the rest state while the material is
# liquid, with the defaults of the ``liquid`` keys): does a jet that can flow pass the strain
# bound where "all" fails, and does its slowing move omega R / v? A row of its own, not part
# of "all", so the runs of "all" keep their scenes (and their run ids).
ALL_LIQUID = "all_liquid"
LIQUID_EFFECTS = ("liquid",)
BASELINE = "stokes"


@dataclass(frozen=True)
class Budget:
    """Per-run budget (:func:`bathprint.studies.reproduce.runs.run_overrides`)."""

    turns: float
    max_duration_s: float
    max_segments: float


# points per set and their budgets: Fig. 1C's and Fig. 2's grids and segment budgets, with
# longer caps on the simulated time (slow, thick jets take seconds to buckle; they are cheap:
# few nodes). Measured cost: docs/reproduction.md.
FULL = {
    "fig1b": ([(d, q) for d, q, _ in PAPER_POINTS], Budget(6.0, 12.0, 1500.0)),
    "fig2": (
        [(d, q) for d in (0.26, 0.41, 0.6, 0.84) for q in (0.3, 0.5, 1.0, 2.0)],
        Budget(6.0, 20.0, 4000.0),
    ),
}
# nonlocal hydrodynamics costs O(N^2) per evaluation (260-450 s for a Fig. 1B run at the
# full budget, measured): these variants with it run on the Fig. 1B points and on this row
# of the Fig. 2 grid only; their other Fig. 2 rows say "not run". With contact the nonlocal
# flow is cheap enough for the whole grid (12 s to 8 min per run on the d = 0.41 mm row,
# against 25-75 min for the pair without contact), so that combination runs everywhere.
NONLOCAL = ("hydrodynamics", "finite_re_hydrodynamics", ALL, ALL_LIQUID)
FIG2_NONLOCAL = [(0.41, q) for q in (0.3, 0.5, 1.0, 2.0)]
NOT_RUN = "not run: nonlocal hydrodynamics runs on the d = 0.41 mm row of the Fig. 2 grid only"
QUICK_BUDGET = Budget(turns=1.0, max_duration_s=0.12, max_segments=60.0)
QUICK = {"fig1b": ([(0.41, 0.5)], QUICK_BUDGET), "fig2": ([(0.6, 1.0)], QUICK_BUDGET)}

# the quantities compared across variants: (csv column, label in the tables)
QUANTITIES = (
    ("l_m", "l"),
    ("R_m", "R"),
    ("Lambda_m", "Lambda"),
    ("omega_rad_s", "omega"),
    ("omega_R_over_v", "omega R / v"),
)
MEASURED = {  # csv column: measurement key
    "regime": "regime",
    "l_m": "buckling_length_m",
    "l_2r_m": "buckling_length_2r_m",
    "l_quarter_m": "buckling_length_quarter_m",
    "l_full_radius_m": "buckling_length_full_radius_m",
    "R_m": "coil_radius_m",
    "Lambda_m": "coil_pitch_m",
    "omega_rad_s": "coil_frequency_rad_s",
    "omega_hz": "coil_frequency_hz",
    "omega_R_over_v": "omega_r_over_v",
    "min_gap_ratio": "min_gap_ratio",
}


def base_overrides(diameter_mm: float, q_ml_min: float, floor: bool, budget: Budget) -> dict:
    """The run's resolution and budget (as for Figs. 1C and 2), on a constant modulus (the
    paper's theory value) with the base effects; the variants add to these."""
    over = run_overrides(
        diameter_mm,
        q_ml_min,
        HEIGHT_MM if floor else None,
        budget.turns,
        budget.max_duration_s,
        budget.max_segments,
    )
    over = {k: v for k, v in over.items() if not k.startswith("gelation.")}
    over["effects"] = [*BASE_EFFECTS, "floor"] if floor else list(BASE_EFFECTS)
    over["material.youngs_modulus_pa"] = E_THEORY
    return over


def variant_overrides(base: dict, effects: Sequence[str], overrides: dict[str, Any]) -> dict:
    """``base`` with ``effects`` added (in the order given) and ``overrides`` set."""
    return {**base, **overrides, "effects": [*base["effects"], *effects]}


def _probe(over: dict) -> str | None:
    """Why a scene cannot be built (the SceneError's message), or None if it can."""
    from bathprint.core.model import compile_model
    from bathprint.core.scene import load_scene

    try:
        compile_model(load_scene(SCENE, over))
    except SceneError as exc:
        return str(exc)
    return None


def plan(quick: bool = False) -> tuple[list[dict], dict[str, str]]:
    """(the runs: dicts with set, point, variant, label, overrides; the variants that are not
    available, with the reason). "all" combines the variants that are available."""
    sets = QUICK if quick else FULL
    pts2, budget2 = sets["fig2"]
    probe_base = base_overrides(*pts2[0], False, budget2)
    missing: dict[str, str] = {}
    available = []
    for v in (*VARIANTS, *COMBINATIONS):
        why = _probe(variant_overrides(probe_base, v.effects, v.overrides))
        if why is None:
            if v in VARIANTS:
                available.append(v)
        else:
            missing[v.name] = why
    effects = [e for v in available for e in v.effects]
    merged = {k: val for v in available for k, val in v.overrides.items()}
    if "inertia" in effects and "hydrodynamics" in effects:
        # the lagged nonlocal flow (the default) is explicit in the flow; with inertia it
        # loses stability within 0.05 s at d = 0.41 mm, 1 ml/min (step below 1e-12 s):
        # the combination takes the flow inside Newton
        merged["hydrodynamics.coupling"] = "implicit"
        # and its blobs (the RPY kernel): with Stokeslet segments, finite-Re drag and a pile
        # the mobility is indefinite and GMRES stalls (7 of the 8 runs failed, 4 of them so;
        # docs/reproduction.md, experiments/hydrodynamics/hydrodynamics.py failing_solve)
        merged["hydrodynamics.kernel"] = "rpy"
    combined = Variant(ALL, "all", tuple(effects), merged)
    liquid = Variant(ALL_LIQUID, "all + liquid", (*effects, *LIQUID_EFFECTS), merged)
    for v in (combined, liquid):
        why = _probe(variant_overrides(probe_base, v.effects, v.overrides))
        if why is not None:
            missing[v.name] = why
    runs = []
    for set_name, (pts, budget) in sets.items():
        for d, q in pts:
            base = base_overrides(d, q, set_name == "fig1b", budget)
            for v in (*VARIANTS, *COMBINATIONS, combined, liquid):
                skipped = (
                    not quick
                    and set_name == "fig2"
                    and v.name in NONLOCAL
                    and (d, q) not in FIG2_NONLOCAL
                )
                runs.append(
                    {
                        "set": set_name,
                        "point": (d, q),
                        "variant": v.name,
                        "label": v.label,
                        "skipped": NOT_RUN if skipped else None,
                        "overrides": None
                        if v.name in missing or skipped
                        else variant_overrides(base, v.effects, v.overrides),
                    }
                )
    return runs, missing


def time_variants(
    set_name: str = "fig2", point: tuple[float, float] = (0.41, 1.0), quick: bool = False
) -> dict[str, dict[str, Any]]:
    """The cost probe: each available variant's run at one point of the study, one after the
    other in this process (kernels compiled first): wall time (s), simulated time (s), nodes,
    steps and regime, or the error. For choosing budgets before the full study."""
    import time

    from bathprint.errors import SimulationError
    from bathprint.run import simulate

    runs, missing = plan(quick)
    chosen = [r for r in runs if r["set"] == set_name and r["point"] == tuple(point)]
    if not chosen:
        raise ValueError(f"point {point!r} is not in the {set_name!r} set of the study")
    simulate(SCENE, {**chosen[0]["overrides"], "duration_s": 1e-3}, progress=False)
    out: dict[str, dict[str, Any]] = {}
    for r in chosen:
        if r["overrides"] is None:
            why = r["skipped"] or f"not available: {missing[r['variant']]}"
            out[r["variant"]] = {"error": why}
            continue
        t0 = time.perf_counter()
        try:
            summary = simulate(SCENE, r["overrides"], progress=False).summary
        except (SceneError, SimulationError) as exc:
            out[r["variant"]] = {"wall_s": time.perf_counter() - t0, "error": str(exc)}
            continue
        out[r["variant"]] = {
            "wall_s": time.perf_counter() - t0,
            "simulated_s": summary["time_s"],
            "nodes": summary["nodes"],
            "steps": summary["steps"],
            "regime": summary["measurements"]["regime"],
        }
    return out


def extract(summary: dict) -> dict:
    """The sweep's default fields, the exit speed and the simulated time."""
    out = default_extract(summary)
    out["exit_speed_m_s"] = summary.get("exit_speed_m_s")
    out["time_s"] = summary.get("time_s")
    out["nodes"] = summary.get("nodes")
    return out


PAPER_REGIME = {(d, q): regime for d, q, regime in PAPER_POINTS}


def _row(run: dict, missing: dict[str, str], result_row: dict | None) -> dict:
    d, q = run["point"]
    row: dict[str, Any] = {
        "set": run["set"],
        "diameter_mm": d,
        "q_outer_ml_min": q,
        "paper_regime": PAPER_REGIME.get((d, q)) if run["set"] == "fig1b" else None,
        "variant": run["variant"],
        "label": run["label"],
        "effects": None if run["overrides"] is None else " ".join(run["overrides"]["effects"]),
    }
    res = (result_row or {}).get("result") or {}
    if run["variant"] in missing:
        row["status"] = "not available"
    elif run.get("skipped"):
        row["status"] = "not run"
    else:
        row["status"] = result_row["status"] if result_row else "missing"
    for column, key in MEASURED.items():
        row[column] = res.get(f"measurements.{key}")
    gap = row["min_gap_ratio"]
    row["interpenetrates"] = None if gap is None else bool(gap < INTERPENETRATION_RATIO)
    row["simulated_s"] = res.get("time_s")
    row["wall_time_s"] = (result_row or {}).get("wall_time_s")
    err = (result_row or {}).get("error") or {}
    row["error"] = missing.get(run["variant"]) or run.get("skipped") or err.get("message")
    return row


def run(
    out_dir: str | Path,
    quick: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    progress: bool = True,
) -> dict:
    """Run the study into ``out_dir`` (ablation_runs.jsonl, .csv, .md, .png); return its
    summary (variants not available, the effects table, the Fig. 2 fits per variant)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    runs, missing = plan(quick)
    todo = [r["overrides"] for r in runs if r["overrides"] is not None]
    rows = run_sweep(
        SCENE,
        todo,
        out / "ablation_runs.jsonl",
        workers=workers,
        scheduler=scheduler,
        extract=extract,
        progress=progress,
    )
    by_id = {row["run_id"]: row for row in rows}
    found = [None if r["overrides"] is None else by_id[run_id(SCENE, r["overrides"])] for r in runs]
    table = [_row(r, missing, row) for r, row in zip(runs, found, strict=True)]
    _write_csv(out / "ablation.csv", table)
    effects = effect_table(table)
    fits = fig2_fits(runs, found, missing)
    regimes = fig1b_regimes(table)
    cost = cost_table(table)
    (out / "ablation.md").write_text(
        markdown(table, effects, fits, regimes, cost, missing, QUICK if quick else FULL, quick)
    )
    plot(out / "ablation.png", effects, fits, regimes, missing)
    return {
        "runs": len(todo),
        "not_available": missing,
        "effects": effects,
        "fig2_fits": fits,
        "fig1b_regimes": regimes,
        "cost": cost,
    }


def _write_csv(path: Path, table: list[dict]) -> None:
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(table[0]))
        w.writeheader()
        w.writerows(table)


def _variant_names(table: list[dict]) -> list[str]:
    return list(dict.fromkeys(r["variant"] for r in table))


def effect_table(table: list[dict]) -> dict[str, dict[str, Any]]:
    """Per variant other than the baseline: for each quantity, the relative changes
    (variant / baseline - 1) over the points where both were measured (median, min, max,
    count); the points whose regime differs from the baseline's; the runs whose turns
    interpenetrate (the baseline included)."""
    by_point = {}
    for r in table:
        by_point.setdefault((r["set"], r["diameter_mm"], r["q_outer_ml_min"]), {})[r["variant"]] = r
    out: dict[str, dict[str, Any]] = {}
    for name in _variant_names(table):
        entry: dict[str, Any] = {}
        for column, _ in QUANTITIES:
            changes = []
            for variants in by_point.values():
                base, row = variants.get(BASELINE), variants.get(name)
                if not base or not row or base[column] is None or row[column] is None:
                    continue
                if base[column] != 0:
                    changes.append(row[column] / base[column] - 1.0)
            entry[column] = (
                {
                    "median": float(np.median(changes)),
                    "min": float(np.min(changes)),
                    "max": float(np.max(changes)),
                    "n": len(changes),
                }
                if changes and name != BASELINE
                else None
            )
        ran = [v[name] for v in by_point.values() if name in v and v[name]["status"] == "ok"]
        entry["regime_changes"] = sum(
            1
            for v in by_point.values()
            if name in v
            and BASELINE in v
            and v[name]["status"] == "ok"
            and v[BASELINE]["status"] == "ok"
            and v[name]["regime"] != v[BASELINE]["regime"]
        )
        entry["interpenetrating_runs"] = sum(1 for r in ran if r["interpenetrates"])
        entry["runs_ok"] = len(ran)
        entry["runs_failed"] = sum(
            1 for v in by_point.values() if name in v and v[name]["status"] == "failed"
        )
        out[name] = entry
    return out


def fig2_fits(
    runs: list[dict], rows: list[dict | None], missing: dict[str, str]
) -> dict[str, dict]:
    """The paper's three Fig. 2 fits per variant, on the Fig. 2 points (``rows``: each run's
    sweep row, None for the variants not available)."""
    per_variant: dict[str, list[dict]] = {}
    for r, row in zip(runs, rows, strict=True):
        if row is not None and r["set"] == "fig2" and row["status"] == "ok":
            per_variant.setdefault(r["variant"], []).append(
                law_row(row["overrides"], row.get("result"))
            )
    names = list(dict.fromkeys(r["variant"] for r in runs))
    return {n: fit_laws(per_variant.get(n, [])) for n in names if n not in missing}


def fig1b_regimes(table: list[dict]) -> dict[str, dict[str, Any]]:
    """Per variant: the regime at each Fig. 1B point and how many match the paper's."""
    out: dict[str, dict[str, Any]] = {}
    for name in _variant_names(table):
        rows = [r for r in table if r["set"] == "fig1b" and r["variant"] == name]
        out[name] = {
            "regimes": {
                f"d={r['diameter_mm']} mm, Q={r['q_outer_ml_min']} ml/min": r["regime"]
                for r in rows
            },
            "paper": {
                f"d={r['diameter_mm']} mm, Q={r['q_outer_ml_min']} ml/min": r["paper_regime"]
                for r in rows
            },
            "matches": sum(1 for r in rows if r["regime"] and r["regime"] == r["paper_regime"]),
            "points": len(rows),
        }
    return out


def cost_table(table: list[dict]) -> dict[str, dict[str, float]]:
    """Per variant: wall time (s) summed over its runs and per simulated second."""
    out = {}
    for name in _variant_names(table):
        rows = [r for r in table if r["variant"] == name and r["wall_time_s"] is not None]
        wall = float(sum(r["wall_time_s"] for r in rows))
        sim = float(sum(r["simulated_s"] or 0.0 for r in rows))
        out[name] = {
            "runs": len(rows),
            "wall_time_s": wall,
            "wall_s_per_simulated_s": wall / sim if sim > 0 else math.nan,
        }
    return out


# --------------------------------------------------------------------------- write-up


def _pct(x: float | None) -> str:
    return "" if x is None or not math.isfinite(x) else f"{100 * x:+.0f}%"


def _num(x: float | None, scale: float = 1.0, digits: int = 3) -> str:
    if x is None or not isinstance(x, int | float) or not math.isfinite(x):
        return ""
    return f"{x * scale:.{digits}g}"


def markdown(
    table: list[dict],
    effects: dict,
    fits: dict,
    regimes: dict,
    cost: dict,
    missing: dict[str, str],
    sets: dict[str, tuple[list, Budget]],
    quick: bool,
) -> str:
    """ablation.md: the tables of the study."""
    labels = {r["variant"]: r["label"] for r in table}
    mode = "quick (tiny budgets: a test of the machinery, not a result)" if quick else "full"
    lines = [
        "# Ablation: which effect moves which quantity",
        "",
        f"Mode: {mode}. Per run "
        + "; ".join(
            f"({name}) at most {b.max_duration_s:g} s simulated and {b.max_segments:g} "
            f"segments of filament, onset plus {b.turns:g} coiling periods"
            for name, (_, b) in sets.items()
        )
        + ". Baseline: "
        f"{labels.get(BASELINE, BASELINE)} ({', '.join(BASE_EFFECTS)}; floor at the Fig. 1B "
        f"points), E = {E_THEORY:g} Pa. Interpenetration: the smallest distance between "
        f"non-adjacent segments over the saved frames below {INTERPENETRATION_RATIO:g} contact "
        "distances (2r).",
        "",
        "## Relative change against the baseline (median over the points [min, max], n)",
        "",
        "| variant | " + " | ".join(q for _, q in QUANTITIES) + " | regime changes "
        "| interpenetrating runs | runs ok / failed |",
        "|---" * (len(QUANTITIES) + 4) + "|",
    ]
    for name, entry in effects.items():
        if name in missing:
            cells = ["not available"] + [""] * (len(QUANTITIES) + 2)
        else:
            cells = []
            for column, _ in QUANTITIES:
                e = entry[column]
                cells.append(
                    ""
                    if e is None
                    else f"{_pct(e['median'])} [{_pct(e['min'])}, {_pct(e['max'])}], {e['n']}"
                )
            cells += [
                str(entry["regime_changes"]) if name != BASELINE else "",
                str(entry["interpenetrating_runs"]),
                f"{entry['runs_ok']} / {entry['runs_failed']}",
            ]
        lines.append(f"| {labels.get(name, name)} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "## The paper's Fig. 2 fits per variant (paper: l = 2.6 R, R = 0.4 (B/(mu v))^(1/3), "
        "omega = 1.1 v^(4/3) (mu/B)^(1/3))",
        "",
        "| variant | l / R | R prefactor | omega prefactor | points (l-R, R, omega) |",
        "|---|---|---|---|---|",
        f"| paper | {PAPER['l_over_R']} | {PAPER['R_prefactor']} | {PAPER['omega_prefactor']} | |",
    ]
    for name, f in fits.items():
        pts = f["points"]
        lines.append(
            f"| {labels.get(name, name)} | {_num(f['l_over_R'])} | {_num(f['R_prefactor'])} | "
            f"{_num(f['omega_prefactor'])} | {pts['l_R']}, {pts['R']}, {pts['omega']} |"
        )
    lines += [
        "",
        "## The same fits under the paper's other conventions",
        "",
        "l / R with l under each definition (`fig2.L_DEFINITIONS`; the table above uses the "
        "inset's), b and c with the paper's B = E r^4 instead of E pi r^4 / 4 (the "
        "`bathprint.studies.reproduce.fig2` docstring), and the median of omega R / v "
        "(the paper's fits give b c = 0.4 x 1.1 = 0.44).",
        "",
        "| variant | l / R: departure by 2r | quarter of the excursion | coil at 0.9 R "
        "| b, B = E r^4 | c, B = E r^4 | omega R / v (median) |",
        "|---|---|---|---|---|---|---|",
        f"| paper | {PAPER['l_over_R']} | {PAPER['l_over_R']} | {PAPER['l_over_R']} "
        f"| {PAPER['R_prefactor']} | {PAPER['omega_prefactor']} "
        f"| {_num(PAPER['R_prefactor'] * PAPER['omega_prefactor'])} |",
    ]
    for name, f in fits.items():
        by_def, n_def = f["l_over_R_by_definition"], f["l_over_R_points"]
        cells = [
            f"{_num(by_def[k])} ({n_def[k]})" for k in ("two_radii", "quarter", "full_radius")
        ]
        cells += [
            _num(f["R_prefactor_paper_B"]),
            _num(f["omega_prefactor_paper_B"]),
            _num(f["omega_R_over_v_median"]),
        ]
        lines.append(f"| {labels.get(name, name)} | " + " | ".join(cells) + " |")
    points = list(next(iter(regimes.values()))["paper"]) if regimes else []
    lines += [
        "",
        "## Regimes at the paper's Fig. 1B points",
        "",
        "| variant | " + " | ".join(points) + " | matches |",
        "|---" * (len(points) + 2) + "|",
        "| paper | "
        + " | ".join(str(v) for v in (next(iter(regimes.values()))["paper"].values()))
        + " | |"
        if regimes
        else "",
    ]
    for name, reg in regimes.items():
        if name in missing:
            continue
        lines.append(
            f"| {labels.get(name, name)} | "
            + " | ".join(str(reg["regimes"].get(p)) for p in points)
            + f" | {reg['matches']} / {reg['points']} |"
        )
    lines += [
        "",
        "## Every run",
        "",
        "| set | d (mm) | Q (ml/min) | variant | status | regime | l (mm) | l 2r / quarter / "
        "full R (mm) | R (mm) | Lambda (mm) | omega (rad/s) | omega (Hz) | omega R / v | "
        "min gap | wall (s) |",
        "|---" * 15 + "|",
    ]
    for r in table:
        ells = " / ".join(_num(r[k], 1e3) for k in ("l_2r_m", "l_quarter_m", "l_full_radius_m"))
        lines.append(
            f"| {r['set']} | {r['diameter_mm']} | {r['q_outer_ml_min']} | {r['label']} | "
            f"{r['status']} | {r['regime'] or ''} | {_num(r['l_m'], 1e3)} | {ells} | "
            f"{_num(r['R_m'], 1e3)} | {_num(r['Lambda_m'], 1e3)} | {_num(r['omega_rad_s'])} | "
            f"{_num(r['omega_hz'])} | {_num(r['omega_R_over_v'])} | {_num(r['min_gap_ratio'])} "
            f"| {_num(r['wall_time_s'])} |"
        )
    lines += [
        "",
        "## Cost (wall time of the runs)",
        "",
        "| variant | runs | wall (s) | wall s per simulated s |",
        "|---|---|---|---|",
    ]
    for name, c in cost.items():
        if name in missing:
            continue
        lines.append(
            f"| {labels.get(name, name)} | {c['runs']} | {c['wall_time_s']:.1f} | "
            f"{_num(c['wall_s_per_simulated_s'])} |"
        )
    if missing:
        lines += ["", "## Not available in this build", ""]
        lines += [f"- {labels.get(n, n)}: {why}" for n, why in missing.items()]
    return "\n".join(lines) + "\n"


def plot(path: Path, effects: dict, fits: dict, regimes: dict, missing: dict[str, str]) -> None:
    """ablation.png: relative changes (heat map), Fig. 2 prefactors, Fig. 1B regimes."""
    from bathprint.studies.reproduce.fig1c import COLORS
    from bathprint.viz.plotting import plt

    names = [n for n in effects if n != BASELINE]
    fig, axes = plt.subplots(1, 3, figsize=(17, 5.2), gridspec_kw={"width_ratios": [1.3, 1, 1.1]})
    ax = axes[0]
    grid = np.full((len(names), len(QUANTITIES)), np.nan)
    for i, n in enumerate(names):
        for j, (column, _) in enumerate(QUANTITIES):
            e = effects[n][column]
            if e is not None:
                grid[i, j] = e["median"]
    ax.imshow(np.clip(grid, -1, 1), cmap="RdBu_r", vmin=-1, vmax=1, aspect="auto")
    for i, n in enumerate(names):
        for j, (column, _) in enumerate(QUANTITIES):
            e = effects[n][column]
            text = "n/a" if n in missing else ("" if e is None else _pct(e["median"]))
            ax.text(j, i, text, ha="center", va="center", fontsize=9)
    ax.set_xticks(range(len(QUANTITIES)), [q for _, q in QUANTITIES])
    ax.set_yticks(range(len(names)), names)
    ax.set_title("median relative change against local Stokes drag only")
    ax = axes[1]
    keys = ("l_over_R", "R_prefactor", "omega_prefactor")
    shown = [n for n in fits if n not in missing]
    width = 0.8 / max(len(shown), 1)
    for k, n in enumerate(shown):
        ratios = [fits[n][key] / PAPER[key] for key in keys]
        # the ten colours of the cycle, then greys: no two variants share a colour
        color = f"C{k}" if k < 10 else str(0.15 + 0.3 * ((k - 10) % 3))
        ax.bar(np.arange(3) + k * width, ratios, width, label=n, color=color)
    ax.axhline(1.0, color="k", lw=0.8, ls="--")
    ax.set_xticks(np.arange(3) + 0.4 - width / 2, ["l / R", "R\nprefactor", "omega\nprefactor"])
    ax.set_ylabel("fitted / paper's value")
    ax.set_title("Fig. 2 fits per variant (1 = the paper's)")
    ax.legend(fontsize=7)
    ax = axes[2]
    shown = [n for n in regimes if n not in missing]
    points = list(regimes[shown[0]]["paper"]) if shown else []
    for i, n in enumerate(shown):
        for j, p in enumerate(points):
            reg = regimes[n]["regimes"].get(p)
            ax.scatter(j, i, s=260, color=COLORS.get(reg, "black"), edgecolor="k")
    for j, p in enumerate(points):
        paper = regimes[shown[0]]["paper"][p]
        ax.scatter(j, len(shown), s=260, facecolor="none", edgecolor=COLORS[paper], lw=2.5)
    ax.set_xticks(range(len(points)), [p.replace(", ", "\n") for p in points], fontsize=7)
    ax.set_yticks(range(len(shown) + 1), [*shown, "paper"])
    for name, color in COLORS.items():
        if name:
            ax.scatter([], [], color=color, edgecolor="k", label=name.replace("_", " "))
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    ax.set_title("regimes at the Fig. 1B points")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)

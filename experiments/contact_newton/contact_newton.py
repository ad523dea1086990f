"""Why Newton needs many iterations on a pressed coil stack: the linear solve or the penalty?

The pressed stack of ``contact_cost.py`` (300 nodes, turns at 0.98 of the contact
distance, 20 ms of settling under gravity, adaptive steps) takes 8 Newton iterations per
step with contact against 2 without. Each row changes one thing and counts steps, Newton
iterations per step and Krylov iterations per Newton iteration, with the wall time as a
ratio to the default in the same run:

- the globalisation: no line search (``numerics.line_search = "off"``: a solve that
  stalls halves its updates for the rest of the solve) instead of the residual line search;
- the linear solve: GMRES to 1e-3 and 1e-6 instead of 0.05 (inexact Newton's forcing term);
  full Newton (a new Jacobian every iteration);
- the step: at most 0.3 ms;
- the penalty: a wider and a narrower soft onset (``contact.width_fraction``), a softer
  stiffness (these change the result: the contact distance is held less exactly).

It also classifies the near pairs' closest points after 5 ms (both parameters inside their
segments, or clamped to an end) and counts the pairs whose class changes over the next
2 ms: switches between interior and end points make the distance's Hessian jump.

Then the line search against the stack's size: N = 100 .. 3000 with and without it; and
in a coiling scene, ``period_doubling_22G`` for 1 s (a pile of about 30 turns) without
contact, and with it, with and without the line search.

Last, ``contact.near_gap_fraction`` in that scene: the pairs within this gap of touching are
always evaluated in Newton's iterations, and every other pair bounds the step by the gap it
may close (``--part near_gap``); and the cost of contact there over three seeds of the
needle imperfection (``--part seeds``: the pile is a weakly chaotic outcome), and against
the penalty's soft onset, ``contact.width_fraction``, also starting before contact
(``contact.distance_factor`` > 1) (``--part onset``: what holding the contact distance more
exactly costs; the final frame's touching segments' gaps, 10th percentile and median, say
how exactly it is held either way), and against GMRES's stopping tolerance
(``--part krylov``: Newton's forcing term); ``--part ratio`` measures contact's cost there
over ten seeds, paired seed by seed, with a bootstrap interval, with contact's defaults (the
soft onset of 0.2 delta from 1.02 (r_A + r_B)), and ``--part ratio_sharp`` the same with its
law before that (SHARP_CONTACT), ``--part ratio_wide`` with the default's width of onset
started at the sum of the radii (WIDE_AT_CONTACT: the two changes one at a time),
``--part ratio_inertia`` with ``inertia`` listed in every
run (contact's defaults then add its 10 ms dashpot), and ``--part dashpot_overdamped`` that
dashpot without inertia. ``--part onset_buckling`` runs the ratio parts' ten seeds again
with the onset 0.2 delta from r_A + r_B and the default's from 1.02 (r_A + r_B), frames every
ONSET_FRAME_INTERVAL_S, and compares the buckling length at 1 s (another frame schedule
than the ratio parts', so another path on a chaotic pile) and averaged over the frames from
ONSET_AVERAGE_FROM_S. ``--part late`` starts from the pile's state at 0.8 s, where
contact costs most, and changes one thing at a time for 60 ms more: the Newton policy, the
linear solve, the soft onset. Every part but ``ratio``, ``ratio_wide`` (SHARP_CONTACT with
the wider onset) and ``ratio_inertia`` holds
SHARP_CONTACT, the law it was measured with (``default`` in its labels means that law).

    python experiments/contact_newton/contact_newton.py
        [--part variants|sizes|scene|near_gap|seeds|onset|krylov|late|ratio|ratio_sharp|
                ratio_wide|ratio_inertia|dashpot_overdamped|onset_buckling]
"""

from __future__ import annotations

import argparse
import math
import pickle
import sys
import time
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import SHARP_CONTACT, experiment, write_csv  # noqa: E402

from bathprint import Simulation, SimulationError, simulate
from bathprint.analysis.measure import MEASURE_KEYS, buckling_length, coil_geometry, touching_gaps
from bathprint.core.effects._segment_geometry import PARALLEL_SIN2, SLIDING_SIN2, closest_params

_stack = experiment("contact_cost")  # the pressed coil stacks
R_FIL, coil_stack, law_or_sharp = _stack.R_FIL, _stack.coil_stack, _stack.law_or_sharp

N_NODES = 300
DURATION_S = 0.02
VARIANTS: dict[str, dict] = {
    "default (GMRES to 0.05, modified Newton, line search)": {},
    "no line search (a stalled solve halves its updates)": {"numerics.line_search": "off"},
    "GMRES to 1e-3": {"numerics.krylov_tolerance": 1e-3},
    "GMRES to 1e-6": {"numerics.krylov_tolerance": 1e-6},
    "full Newton": {"numerics.newton": "full"},
    "steps of at most 0.3 ms": {"numerics.max_step_s": 3e-4},
    "soft onset 0.1 delta (default 0.02)": {"contact.width_fraction": 0.1},
    "soft onset 0.005 delta": {"contact.width_fraction": 0.005},
    "stiffness 100 Pa (default 1000)": {"contact.stiffness_pa": 100.0},
    "Gauss-Newton Hessian": {"contact.hessian": "gauss_newton"},
    "contact at the closest points (parallel angle 0 deg)": {"contact.parallel_angle_deg": 0.0},
    "closest points, Gauss-Newton Hessian": {
        "contact.parallel_angle_deg": 0.0,
        "contact.hessian": "gauss_newton",
    },
    "parallel angle 5 deg (default 10)": {"contact.parallel_angle_deg": 5.0},
}


def _newton_counts(c: dict[str, int]) -> dict[str, float]:
    """Steps and Newton's counts from a difference of ``Simulation.counts()``."""
    newton = max(c["newton_iterations"], 1)
    return {
        "steps": c["steps"],
        "rejected_steps": c["rejected_steps"],
        "newton_failures": c["newton_failures"],
        "newton_per_step": c["newton_iterations"] / max(c["steps"], 1),
        "krylov_per_newton": c["krylov_iterations"] / newton,
        "damped_share": c["damped_newton_iterations"] / newton,
    }


def newton_rows() -> list[dict]:
    coil_stack(N_NODES, True, 0.98).advance(1e-3)  # compile
    rows, base = [], None
    for label, extra in VARIANTS.items():
        sim = coil_stack(N_NODES, True, 0.98, extra)
        t0 = time.perf_counter()
        sim.advance(DURATION_S)
        wall = time.perf_counter() - t0
        c = sim.counts()
        base = base or wall
        rows.append(
            {
                "variant": label,
                **_newton_counts(c),
                "jacobians": c["jacobians"],
                "wall_s": wall,
                "wall_ratio": wall / base,
            }
        )
        r = rows[-1]
        print(
            f"{label:>42}: {r['steps']} steps ({r['rejected_steps']} rejected), "
            f"{r['newton_per_step']:.2f} Newton per step, {r['krylov_per_newton']:.2f} Krylov "
            f"per Newton, {100 * r['damped_share']:.0f}% of updates damped, "
            f"wall x{r['wall_ratio']:.2f}"
        )
    return rows


def _classes(sim, pos: np.ndarray) -> dict[tuple[int, int], tuple[bool, bool, float, float]]:
    """Near pair -> (s inside, t inside, distance / contact distance, sin^2 of the angle)."""
    c = sim.ws.contact
    out = {}
    for k in range(int(c.count[0])):
        if not c.near[k]:
            continue
        i, j = (int(v) for v in c.pairs[k])
        _, _, s_free, t_free, d2 = closest_params(pos, i, i + 1, j, j + 1)
        a = pos[3 * i + 3 : 3 * i + 6] - pos[3 * i : 3 * i + 3]
        b = pos[3 * j + 3 : 3 * j + 6] - pos[3 * j : 3 * j + 3]
        sin2 = 1.0 - (a @ b) ** 2 / ((a @ a) * (b @ b))
        out[(i, j)] = (bool(s_free), bool(t_free), math.sqrt(d2) / (2 * R_FIL), sin2)
    return out


def closest_point_rows() -> list[dict]:
    sim = coil_stack(N_NODES, True, 0.98)
    sim.advance(0.005)
    before = _classes(sim, sim.pos.copy())
    sim.advance(0.007)
    after = _classes(sim, sim.pos.copy())
    common = set(before) & set(after)
    touching = [v for v in after.values() if v[2] < 1.0]
    kinds = Counter((v[0], v[1]) for v in after.values())
    row = {
        "near_pairs": len(after),
        "both_inside": kinds[(True, True)],
        "one_inside": kinds[(True, False)] + kinds[(False, True)],
        "both_clamped": kinds[(False, False)],
        "touching": len(touching),
        "touching_both_inside": sum(1 for v in touching if v[0] and v[1]),
        # touching at the middle of their overlap (below PARALLEL_ANGLE_DEG) or at the blend
        # (below SLIDING_ANGLE_DEG): the contact point held (contact_params)
        "touching_middle": sum(1 for v in touching if v[3] < PARALLEL_SIN2),
        "touching_held": sum(1 for v in touching if v[3] < SLIDING_SIN2),
        "class_changes_over_2_ms": sum(before[k][:2] != after[k][:2] for k in common),
        "pairs_compared": len(common),
        "median_angle_deg_touching": math.degrees(
            math.asin(math.sqrt(float(np.median([v[3] for v in touching]))))
        )
        if touching
        else math.nan,
    }
    print(
        f"near pairs {row['near_pairs']}: {row['both_inside']} both inside, {row['one_inside']} "
        f"one, {row['both_clamped']} both clamped; touching {row['touching']} "
        f"({row['touching_both_inside']} both inside, median angle "
        f"{row['median_angle_deg_touching']:.1f} deg; {row['touching_middle']} below 10 deg, "
        f"{row['touching_held']} below 20 deg); class changes over 2 ms: "
        f"{row['class_changes_over_2_ms']} of {row['pairs_compared']}"
    )
    return [row]


def line_search_rows(sizes: list[int]) -> list[dict]:
    """The pressed stack of N nodes for DURATION_S with and without the line search."""
    for mode in ("off", "residual"):  # load the kernels outside the timing
        coil_stack(sizes[0], True, 0.98, {"numerics.line_search": mode}).advance(1e-3)
    rows = []
    for n in sizes:
        row: dict = {"nodes": n}
        for key, mode in (("off", "off"), ("on", "residual")):
            sim = coil_stack(n, True, 0.98, {"numerics.line_search": mode})
            t0 = time.perf_counter()
            sim.advance(DURATION_S)
            row[f"wall_s_{key}"] = time.perf_counter() - t0
            c = sim.counts()
            row[f"steps_{key}"] = c["steps"]
            row[f"rejected_{key}"] = c["rejected_steps"]
            row[f"newton_failures_{key}"] = c["newton_failures"]
            row[f"newton_per_step_{key}"] = c["newton_iterations"] / c["steps"]
            row[f"newton_{key}"] = c["newton_iterations"]
        row["backtracks_on"] = c["line_search_backtracks"]
        row["newton_ratio"] = row["newton_on"] / row["newton_off"]
        row["wall_ratio"] = row["wall_s_on"] / row["wall_s_off"]
        rows.append(row)
        print(
            f"N = {n:>5}: Newton per step {row['newton_per_step_off']:.2f} without the line "
            f"search, {row['newton_per_step_on']:.2f} with; steps {row['steps_off']} / "
            f"{row['steps_on']}; Newton failures {row['newton_failures_off']} / "
            f"{row['newton_failures_on']}; wall x{row['wall_ratio']:.2f}"
        )
    return rows


SCENE = "period_doubling_22G"
SCENE_DURATION_S = 1.0


def _scene_rows(
    variants: dict[str, dict], seed: int | None = None, law: dict | None = None
) -> list[dict]:
    """SCENE for SCENE_DURATION_S under each variant's overrides (and the needle
    imperfection's ``seed``); wall times as ratios to the first variant's. ``law``: contact's
    law under the variants' overrides, SHARP_CONTACT unless given (the studies of Newton,
    GMRES and the onset measured with it; ``{}``: contact's defaults)."""
    law = law_or_sharp(law)
    rows, base = [], None
    model = Simulation(SCENE).model
    radius, needle = model.radius, model.needle[0, 1:7].copy()
    for label, extra in variants.items():
        over = {"duration_s": SCENE_DURATION_S, "outputs.plot": False, **law, **extra}
        if seed is not None:
            over["seed"] = seed
        simulate(SCENE, {**over, "duration_s": 0.01})  # compile this combination
        t0 = time.perf_counter()
        res = simulate(SCENE, over)
        wall = time.perf_counter() - t0
        s = res.summary
        gaps = touching_gaps(res.final, radius) or {}
        base = base or wall
        rows.append(
            {
                "scene": SCENE,
                "duration_s": SCENE_DURATION_S,
                **({} if seed is None else {"seed": seed}),
                "variant": label,
                "near_gap_fraction": extra.get("contact.near_gap_fraction", math.nan),
                "steps": s["steps"],
                "rejected_steps": s["rejected_steps"],
                "contact_rejections": s["contact_rejections"],
                "newton_failures": s["newton_failures"],
                "newton_per_step": s["newton_iterations"] / s["steps"],
                "jacobians_per_step": s["jacobians"] / s["steps"],
                "krylov_per_newton": s["krylov_iterations"] / max(s["newton_iterations"], 1),
                "backtracks": s["line_search_backtracks"],
                "min_gap_ratio": s["measurements"]["min_gap_ratio"],
                "touching_segments_final": gaps.get("touching", 0),
                "touching_gap_p10_final": gaps.get("p10", math.nan),
                "touching_gap_median_final": gaps.get("median", math.nan),
                **_observables(s["measurements"]),
                **_needle_turns(res.final, needle),
                "wall_s": wall,
                "wall_ratio": wall / base,
            }
        )
        r = rows[-1]
        print(
            f"{label:>32}: {r['steps']} steps ({r['rejected_steps']} rejected, "
            f"{r['contact_rejections']} by contact), {r['newton_per_step']:.2f} Newton and "
            f"{r['jacobians_per_step']:.2f} Jacobians per step, {r['krylov_per_newton']:.2f} "
            f"Krylov per Newton, {r['newton_failures']} Newton failures, smallest gap "
            f"{r['min_gap_ratio']:.3f} delta, wall {wall:.1f} s (x{r['wall_ratio']:.2f})",
            flush=True,
        )
    return rows


#: what the pile looks like at the end of a run, SI units: the turns next to the stem
#: (:func:`_needle_turns`) and the run's own measurements (``measure_all``)
OBSERVABLES = (
    "needle_turns_radius_m",
    "needle_turns_pitch_m",
    "coil_radius_m",
    "coil_pitch_m",
    "coil_frequency_rad_s",
    "buckling_length_m",
    "plume_opening_angle_rad",
    "curvature_variance_1_m2",
)


def _observables(m: dict) -> dict:
    """The regime and OBSERVABLES of a run's measurements (NaN where not measured)."""
    out: dict = {"regime": m.get("regime") or ""}
    for key in (k for k in OBSERVABLES if k in MEASURE_KEYS):
        v = m.get(key)
        out[key] = math.nan if v is None else float(v)
    return out


#: full turns below the stem that :func:`_needle_turns` measures (as tests/test_freezing.py)
NEEDLE_TURNS = 3


def _needle_turns(frame: np.ndarray, needle: np.ndarray) -> dict:
    """The coil being written: the median radius and mean |pitch| (m) of the NEEDLE_TURNS
    full turns next to the stem in ``frame`` (``coil_geometry``, whatever the regime), and
    how many full turns it counts (NaN and 0 without as many)."""
    g = coil_geometry(frame, needle[:3], needle[3:])
    if g is None or g.full_turns < NEEDLE_TURNS:
        return {
            "needle_turns_radius_m": math.nan,
            "needle_turns_pitch_m": math.nan,
            "full_turns": 0,
        }
    return {
        "needle_turns_radius_m": float(np.median(g.radii[:NEEDLE_TURNS])),
        "needle_turns_pitch_m": float(np.mean(np.abs(g.pitches[:NEEDLE_TURNS]))),
        "full_turns": g.full_turns,
    }


def _without_contact() -> dict:
    return {"effects": [e for e in Simulation(SCENE).scene.effects if e != "contact"]}


def scene_rows() -> list[dict]:
    """Without contact, and with it, with and without the line search (the near gap of the
    first measurement, 0.05 delta)."""
    return _scene_rows(
        {
            "without contact": _without_contact(),
            "contact, line search (default)": {
                "numerics.line_search": "residual",
                "contact.near_gap_fraction": 0.05,
            },
            "contact, no line search": {
                "numerics.line_search": "off",
                "contact.near_gap_fraction": 0.05,
            },
        }
    )


NEAR_GAPS = (0.05, 0.15, 0.3, 0.6, 1.0)
SEEDS = (0, 1, 2)


def near_gap_rows() -> list[dict]:
    """Without contact, then with contact at every ``contact.near_gap_fraction`` of
    NEAR_GAPS: the pairs always evaluated in Newton's iterations."""
    variants = {"without contact": _without_contact()}
    for g in NEAR_GAPS:
        variants[f"contact, near gap {g:g} delta"] = {"contact.near_gap_fraction": g}
    return _scene_rows(variants)


ONSETS = (0.02, 0.05, 0.1, 0.2)
#: (soft onset, contact distance factor f): onsets that start before contact, at f (r_A + r_B)
ONSETS_BEFORE_CONTACT = ((0.1, 1.01), (0.2, 1.02), (0.4, 1.04))


def onset_rows() -> list[dict]:
    """Without contact, then with the soft onset ``contact.width_fraction`` of ONSETS (the
    penetration over which the penalty's stiffness grows from zero), then with onsets that
    start before contact (``contact.distance_factor`` f > 1, ONSETS_BEFORE_CONTACT): what
    holding the contact distance more exactly costs."""
    variants = {"without contact": _without_contact()}
    for w in ONSETS:
        variants[f"contact, soft onset {w:g} delta"] = {"contact.width_fraction": w}
    for w, f in ONSETS_BEFORE_CONTACT:
        variants[f"contact, soft onset {w:g} delta from {f:g} (r_A + r_B)"] = {
            "contact.width_fraction": w,
            "contact.distance_factor": f,
        }
    return _scene_rows(variants)


KRYLOV_TOLERANCES = (0.02, 0.05, 0.1, 0.2)


def krylov_rows() -> list[dict]:
    """Without contact, then with it at each ``numerics.krylov_tolerance`` of
    KRYLOV_TOLERANCES (the residual, relative to the right-hand side, at which GMRES stops:
    Newton's forcing term): fewer GMRES iterations against more Newton iterations."""
    variants = {"without contact": _without_contact()}
    for tol in KRYLOV_TOLERANCES:
        variants[f"contact, GMRES to {tol:g}"] = {"numerics.krylov_tolerance": tol}
    return _scene_rows(variants)


RATIO_SEEDS = tuple(range(10))
RATIO_GOAL = 3.0  # the goal for contact's cost where turns touch (docs/performance.md)


#: the soft onset that starts before contact (contact's default law; the studies of the onset
#: and of freezing name it beside SHARP_CONTACT): its scene overrides
ONSET_BEFORE_CONTACT = {"contact.width_fraction": 0.2, "contact.distance_factor": 1.02}
#: the rows of --part ratio_sharp: contact with its law before the onset before contact
SHARP_LABEL = "contact, sharp onset (0.02 delta from r_A + r_B)"
#: --part ratio_wide: the default's width of onset, started at the sum of the radii (the
#: two changes from the sharp onset to the default, one at a time)
WIDE_AT_CONTACT = {**SHARP_CONTACT, "contact.width_fraction": 0.2}
WIDE_LABEL = "contact, soft onset 0.2 delta from r_A + r_B"


def ratio_rows(law: dict | None = None, label: str = "contact") -> list[dict]:
    """Without and with contact (its defaults, or the ``law`` overrides, rows labelled
    ``label``) for each needle-imperfection seed of RATIO_SEEDS, back to back: the
    wall-time ratio of contact, seed by seed (paired)."""
    variants = {"without contact": _without_contact(), label: {}}
    rows = []
    for seed in RATIO_SEEDS:
        rows += _scene_rows(variants, seed, law or {})
    return rows


def ratio_summary(rows: list[dict], label: str = "contact") -> dict[str, float]:
    """The mean over seeds of the paired ratio (the wall of the rows labelled ``label`` over
    the wall without contact, same seed) with its 95% bootstrap interval over seeds, and how
    many seeds are within RATIO_GOAL."""
    from bathprint.agents.statistics import bootstrap_ci

    ratios = np.array([float(r["wall_ratio"]) for r in rows if r["variant"] == label])
    mean, lo, hi = bootstrap_ci(np.mean, ratios[:, None])
    return {
        "seeds": len(ratios),
        "mean": mean,
        "low": lo,
        "high": hi,
        "min": float(ratios.min()),
        "max": float(ratios.max()),
        "within_goal": int((ratios <= RATIO_GOAL).sum()),
    }


def observable_comparison(rows_a: list[dict], label_a: str, rows_b: list[dict], label_b: str):
    """Per observable of OBSERVABLES, over the seeds both sets ran: the mean of each set's
    rows labelled ``label_a`` and ``label_b``, the seed-paired relative difference b / a - 1
    with its 95% bootstrap interval, and the seed-to-seed spread of a (its coefficient of
    variation). What the pile looks like, beside what it costs."""
    from bathprint.agents.statistics import bootstrap_ci

    a = {r["seed"]: r for r in rows_a if r["variant"] == label_a}
    b = {r["seed"]: r for r in rows_b if r["variant"] == label_b}
    seeds = sorted(set(a) & set(b))
    out = []
    for key in OBSERVABLES:
        pairs = [(float(a[s][key]), float(b[s][key])) for s in seeds]
        pairs = [(x, y) for x, y in pairs if math.isfinite(x) and math.isfinite(y) and x > 0]
        if len(pairs) < 2:
            continue
        xa, xb = np.array(pairs).T
        rel, lo, hi = bootstrap_ci(np.mean, (xb / xa - 1.0)[:, None])
        out.append(
            {
                "observable": key,
                "seeds": len(pairs),
                f"mean {label_a}": float(xa.mean()),
                f"mean {label_b}": float(xb.mean()),
                "paired_change": rel,
                "paired_change_low": lo,
                "paired_change_high": hi,
                "seed_spread": float(xa.std(ddof=1) / xa.mean()),
            }
        )
    regimes = [(a[s]["regime"], b[s]["regime"]) for s in seeds]
    same = sum(x == y for x, y in regimes)
    out.append({"observable": "regime", "seeds": len(seeds), "same_regime": same})
    return out


def ratio_report(law: dict | None = None, label: str = "contact") -> list[dict]:
    """:func:`ratio_rows`, with their summary printed."""
    rows = ratio_rows(law, label)
    r = ratio_summary(rows, label)
    print(
        f"{label} / without over {r['seeds']} seeds: mean {r['mean']:.2f}x "
        f"[{r['low']:.2f}, {r['high']:.2f}] (95% bootstrap), {r['min']:.2f} "
        f"to {r['max']:.2f}; {r['within_goal']} within {RATIO_GOAL:g}x"
    )
    return rows


#: the rows of --part ratio_inertia with contact's law before the onset before contact (and so
#: without the dashpot that its default, "auto", gives with inertia)
SHARP_NO_DASHPOT_LABEL = "contact, sharp onset, no dashpot"


def inertia_rows() -> list[dict]:
    """The ten seeds of :func:`ratio_rows` with ``inertia`` listed in every run (the
    experiments' regime: its number (rho + rho_f) A v^2 S^2 / B is about 97 at 5 ml/min):
    without contact, with contact's defaults (the onset before contact and, with inertia, its
    10 ms dashpot) and with SHARP_CONTACT."""
    effects = [*Simulation(SCENE).scene.effects, "inertia"]
    without = [e for e in effects if e != "contact"]
    variants = {
        "without contact": {"effects": without},
        "contact": {"effects": effects},
        SHARP_NO_DASHPOT_LABEL: {"effects": effects, **SHARP_CONTACT},
    }
    rows = []
    for seed in RATIO_SEEDS:
        rows += _scene_rows(variants, seed, {})
    return rows


def inertia_report() -> list[dict]:
    """:func:`inertia_rows`, with the summary of each contact variant printed."""
    rows = inertia_rows()
    for label in ("contact", SHARP_NO_DASHPOT_LABEL):
        r = ratio_summary(rows, label)
        print(
            f"with inertia, {label} / without over {r['seeds']} seeds: mean {r['mean']:.2f}x "
            f"[{r['low']:.2f}, {r['high']:.2f}], {r['min']:.2f} to {r['max']:.2f}"
        )
    return rows


#: --part dashpot_overdamped: contact's dashpot (s) on the overdamped pile
OVERDAMPED_DASHPOTS_S = (0.0, 1e-3, 1e-2)


def dashpot_overdamped_rows(seed: int = 0) -> list[dict]:
    """SCENE (overdamped) with contact's dashpot at each of OVERDAMPED_DASHPOTS_S: how far
    it gets in SCENE_DURATION_S, its counts, and the failure it reports where GMRES stalls
    (the dashpot's couplings between turns, beta E'' / (h gamma), dwarf the band)."""
    rows = []
    for beta in OVERDAMPED_DASHPOTS_S:
        over = {**SHARP_CONTACT, "seed": seed, "contact.damping_time_s": beta}
        Simulation(SCENE, {**over, "duration_s": 0.01}).advance(0.01)  # compile
        sim = Simulation(SCENE, over)
        failure = ""
        t0 = time.perf_counter()
        try:
            sim.advance(SCENE_DURATION_S)
        except SimulationError as e:
            failure = str(e)
        wall = time.perf_counter() - t0
        c = sim.counts()
        rows.append(
            {
                "scene": SCENE,
                "seed": seed,
                "damping_time_s": beta,
                "reached_s": sim.t,
                "steps": c["steps"],
                "newton_per_step": c["newton_iterations"] / max(c["steps"], 1),
                "krylov_per_newton": c["krylov_iterations"] / max(c["newton_iterations"], 1),
                "wall_s": wall,
                "failure": failure,
            }
        )
        r = rows[-1]
        print(
            f"dashpot {beta * 1e3:g} ms: reached {r['reached_s']:.3f} s in {wall:.1f} s, "
            f"{r['steps']} steps, {r['krylov_per_newton']:.2f} Krylov per Newton"
            + (f"; {failure[:160]}" if failure else ""),
            flush=True,
        )
    return rows


def ratio_sharp_report() -> list[dict]:
    """:func:`ratio_report` with contact's law before the onset before contact."""
    return ratio_report(SHARP_CONTACT, SHARP_LABEL)


def ratio_wide_report() -> list[dict]:
    """:func:`ratio_report` with the default's onset width started at the sum of the radii
    (WIDE_AT_CONTACT): beside ``ratio_sharp`` and ``ratio``, which of the two changes moves
    what the pile looks like."""
    return ratio_report(WIDE_AT_CONTACT, WIDE_LABEL)


def seed_rows() -> list[dict]:
    """Without and with contact (SHARP_CONTACT, and with the Gauss-Newton Hessian) for each
    needle-imperfection seed of SEEDS: the pile, and so the cost, is a weakly chaotic
    outcome."""
    rows = []
    for seed in SEEDS:
        variants = {"without contact": _without_contact(), "contact": {}}
        variants["contact, Gauss-Newton Hessian"] = {"contact.hessian": "gauss_newton"}
        rows += _scene_rows(variants, seed)
    return rows


LATE_START_S = 0.8  # the pile's state the late variants start from
LATE_WINDOW_S = 0.06  # simulated time each late variant runs from it
#: label: fields of the compiled parameter record (``bathprint.core.layout.PARAMS_FIELDS``)
#: changed on a copy of the state at LATE_START_S; None: the run without contact, from its
#: own state at LATE_START_S
LATE_VARIANTS: dict[str, dict[str, float] | None] = {
    "without contact": None,
    "contact (default)": {},
    "Newton tolerance 0.03 (default 0.01)": {"newton_tolerance": 0.03},
    "no line search": {"line_search": 0.0},
    "full Newton": {"newton_reuse": 0.0},
    "full Newton, GMRES to 1e-9": {"newton_reuse": 0.0, "krylov_tolerance": 1e-9},
    "GMRES to 0.02": {"krylov_tolerance": 0.02},
    "soft onset 0.1 delta": {"contact_width_fraction": 0.1},
    "soft onset 0.2 delta from 1.02 (r_A + r_B)": {
        "contact_width_fraction": 0.2,
        "contact_distance_factor": 1.02,
    },
}


def late_rows() -> list[dict]:
    """The pile late in its run, where contact costs most: SCENE (seed 0) advanced to
    LATE_START_S with and without contact, then LATE_WINDOW_S more from copies of that state
    (pickled), each with the fields of LATE_VARIANTS changed in its compiled parameter
    record (the scene keys they come from: numerics.newton_tolerance, numerics.line_search,
    numerics.newton, numerics.krylov_tolerance, contact.width_fraction,
    contact.distance_factor). Every contact variant starts from the same state, so the
    counts compare Newton on the same pile; the run without contact has its own pile."""
    states = {}
    for contact in (False, True):
        sim = Simulation(SCENE, SHARP_CONTACT if contact else _without_contact())
        sim.advance(LATE_START_S)
        states[contact] = pickle.dumps(sim)
    rows, base = [], None
    for label, fields in LATE_VARIANTS.items():
        sim = pickle.loads(states[fields is not None])
        for field, value in (fields or {}).items():
            sim.model.params[0][field] = value
        start = sim.counts()
        t0 = time.perf_counter()
        sim.advance(LATE_START_S + LATE_WINDOW_S)
        wall = time.perf_counter() - t0
        end = sim.counts()
        c = {k: end[k] - start[k] for k in end}
        base = base or wall
        steps = max(c["steps"], 1)
        rows.append(
            {
                "scene": SCENE,
                "start_s": LATE_START_S,
                "window_s": LATE_WINDOW_S,
                "variant": label,
                "nodes": sim.n_nodes,
                **_newton_counts(c),
                "jacobians_per_step": c["jacobians"] / steps,
                "backtracks_per_step": c["line_search_backtracks"] / steps,
                "wall_s": wall,
                "wall_ratio": wall / base,
            }
        )
        r = rows[-1]
        print(
            f"{label:>44}: {r['steps']} steps, {r['newton_per_step']:.2f} Newton and "
            f"{r['jacobians_per_step']:.2f} Jacobians per step, {r['krylov_per_newton']:.2f} "
            f"Krylov per Newton, {r['backtracks_per_step']:.2f} backtracks per step, "
            f"{r['newton_failures']} Newton failures, wall {wall:.2f} s "
            f"(x{r['wall_ratio']:.2f} without contact)",
            flush=True,
        )
    return rows


#: --part onset_buckling: frames (s) and the start of the average (s)
ONSET_FRAME_INTERVAL_S = 0.05
ONSET_AVERAGE_FROM_S = 0.5
ONSET_LAWS = {"0.2 delta from r_A + r_B": WIDE_AT_CONTACT, "0.2 delta from 1.02 (r_A + r_B)": {}}


def onset_buckling_rows() -> list[dict]:
    """SCENE for SCENE_DURATION_S per seed of RATIO_SEEDS and law of ONSET_LAWS (the second,
    contact's default), frames every ONSET_FRAME_INTERVAL_S: the buckling length (its
    default definition) of the last frame and its mean over the frames from
    ONSET_AVERAGE_FROM_S (:func:`onset_buckling_comparison` pairs them)."""
    needle = Simulation(SCENE).model.needle[0, 1:7].copy()
    rows = []
    for seed in RATIO_SEEDS:
        for label, law in ONSET_LAWS.items():
            over = {
                "duration_s": SCENE_DURATION_S,
                "outputs.plot": False,
                "outputs.frame_interval_s": ONSET_FRAME_INTERVAL_S,
                "seed": seed,
                **law,
            }
            res = simulate(SCENE, over)
            ls = [
                buckling_length(f, needle[:3], needle[3:])
                for t, f in zip(res.time_s, res.frames, strict=True)
                if t >= ONSET_AVERAGE_FROM_S - 1e-9
            ]
            final = ls[-1] if ls and ls[-1] is not None else math.nan
            ls = [x for x in ls if x is not None]
            rows.append(
                {
                    "seed": seed,
                    "onset": label,
                    "buckling_length_final_m": final,
                    "buckling_length_mean_m": float(np.mean(ls)) if ls else math.nan,
                    "frames_averaged": len(ls),
                }
            )
            print(rows[-1], flush=True)
    return rows


def onset_buckling_comparison(rows: list[dict]) -> list[dict]:
    """For the buckling length at the last frame and averaged: each law's mean over the
    seeds and the seed-paired relative difference of the second law of ONSET_LAWS against
    the first, with its 95% bootstrap interval."""
    from bathprint.agents.statistics import bootstrap_ci

    first, second = (
        {int(r["seed"]): r for r in rows if r["onset"] == label} for label in ONSET_LAWS
    )
    seeds = sorted(set(first) & set(second))
    out = []
    for key in ("buckling_length_final_m", "buckling_length_mean_m"):
        a = np.array([float(first[s][key]) for s in seeds])
        b = np.array([float(second[s][key]) for s in seeds])
        rel, lo, hi = bootstrap_ci(np.mean, (b / a - 1.0)[:, None])
        out.append(
            {
                "quantity": key,
                "seeds": len(seeds),
                "mean_first_m": float(a.mean()),
                "mean_second_m": float(b.mean()),
                "paired_change": rel,
                "paired_change_low": lo,
                "paired_change_high": hi,
            }
        )
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--part",
        choices=(
            "all",
            "variants",
            "sizes",
            "scene",
            "near_gap",
            "seeds",
            "onset",
            "krylov",
            "late",
            "ratio",
            "ratio_sharp",
            "ratio_wide",
            "ratio_inertia",
            "dashpot_overdamped",
            "onset_buckling",
        ),
        default="all",
    )
    part = ap.parse_args().part
    scene = f"{SCENE}, {SCENE_DURATION_S:g} s"
    parts = {  # part: (title, [(result file, rows)])
        "variants": (
            f"pressed stack, N = {N_NODES}, {DURATION_S * 1e3:g} ms:",
            [("contact_newton", newton_rows), ("contact_closest_points", closest_point_rows)],
        ),
        "sizes": (
            f"the line search against N ({DURATION_S * 1e3:g} ms):",
            [("contact_line_search", lambda: line_search_rows([100, 300, 1000, 3000]))],
        ),
        "scene": (f"{scene}:", [("contact_line_search_scene", scene_rows)]),
        "near_gap": (
            f"{scene}, against contact.near_gap_fraction:",
            [("contact_near_gap", near_gap_rows)],
        ),
        "seeds": (f"{scene}, seeds {SEEDS}:", [("contact_seeds", seed_rows)]),
        "onset": (
            f"{scene}, against contact.width_fraction:",
            [("contact_onset", onset_rows)],
        ),
        "krylov": (
            f"{scene}, against numerics.krylov_tolerance:",
            [("contact_krylov_tolerance", krylov_rows)],
        ),
        "late": (
            f"{SCENE} from {LATE_START_S:g} s for {LATE_WINDOW_S:g} s:",
            [("contact_late", late_rows)],
        ),
        "ratio": (f"{scene}, seeds {RATIO_SEEDS}:", [("contact_ratio_seeds", ratio_report)]),
        "ratio_sharp": (
            f"{scene}, seeds {RATIO_SEEDS}, {SHARP_LABEL}:",
            [("contact_ratio_seeds_sharp", ratio_sharp_report)],
        ),
        "ratio_wide": (
            f"{scene}, seeds {RATIO_SEEDS}, {WIDE_LABEL}:",
            [("contact_ratio_seeds_wide", ratio_wide_report)],
        ),
        "ratio_inertia": (
            f"{scene} with inertia, seeds {RATIO_SEEDS}:",
            [("contact_ratio_seeds_inertia", inertia_report)],
        ),
        "dashpot_overdamped": (
            f"{scene}, contact's dashpot {OVERDAMPED_DASHPOTS_S} s:",
            [("contact_dashpot_overdamped", dashpot_overdamped_rows)],
        ),
        "onset_buckling": (
            f"{scene}, seeds {RATIO_SEEDS}, frames every {ONSET_FRAME_INTERVAL_S:g} s:",
            [("contact_onset_buckling", onset_buckling_rows)],
        ),
    }
    for name, (title, outputs) in parts.items():
        if part in ("all", name):
            print(title)
            for csv_name, rows in outputs:
                print("wrote", write_csv(csv_name, rows()))

"""What freezing settled material (``numerics.freeze_beyond_mm``) costs in accuracy and
saves in time.

    python experiments/freezing/freezing.py
        [--part coil|seeds|turns|onset|onset_wide|damping|rope|envs]
        [--episodes 8]

(1) A steady coil (scene ``gelation_coiling_22G``, 3 s; draft and balanced presets, and draft
    with ``inertia``): coil
    radius and frequency and wall time with the material beyond 20, 40, 60, 100 and 150 mm
    frozen, against the same run without freezing; beside it, how much the coil varies by
    itself: the change that tightening the tolerance ten times makes (the error the preset
    already accepts) and the change from three other seeds of the needle imperfection.
(1b) ``--part seeds``: the same coil, draft, with ``inertia``, and with ``inertia`` but not
    ``contact``, frozen beyond 100 mm (what ``tests/test_freezing.py`` asserts), 150 and
    200 mm and not, for each of ``SEED_PAIRS`` seeds of the needle imperfection: freezing's
    change paired by seed, beside how much R varies from seed to seed. One seed's change
    can hide a bias that every seed shares.
(1c) ``--part onset``: what ``tests/test_freezing.py`` asserts of the coil at the needle
    with ``inertia`` (the three turns next to the needle at 6 s, draft, seeds 0-5), with
    contact's sharp onset (SHARP_CONTACT) and with the onset that starts before contact
    (``contact.width_fraction = 0.2``, ``contact.distance_factor = 1.02``), each without and
    with contact's normal dashpot (``contact.damping_time_s``, DASHPOT_S): freezing beyond
    100 mm against a tenfold tighter tolerance, and the free and clamped joints
    (freezing_onset.csv).
    ``--part onset_wide``: the same with the default's onset width (0.2 delta) started at the
    sum of the radii, without and with the dashpot (freezing_onset_wide.csv).
(1d) ``--part damping``: the same comparison at the needle, freezing beyond 100 mm against
    the tenfold tolerance, overdamped with each onset, and with inertia, the onset before
    contact and shorter dashpots (1 and 3 ms) (freezing_damping.csv).
(2) Rope coiling on the floor (scene ``rope_coiling_18G``, 6 s, or as far as 20 times the
    steps of the run without freezing take it): the RMS change of the last
    30 mm of material next to the needle and of the pile's centre, with the material resting
    on the floor beyond 15, 30 and 60 mm frozen, beside tightening the tolerance 3x.
(3) The environments at their ``draft`` preset (which freezes beyond 20 mm) under random
    actions: the final metric of ``--episodes`` seeded episodes with and without freezing,
    beside the difference between the draft and balanced presets (both without freezing),
    and environment steps per CPU second of each.

Every part holds contact's law before the onset before contact became its default
(``_common.SHARP_CONTACT``: "default onset" in the labels), which it was measured
with; ``--part onset`` and ``--part damping`` set the onset before contact beside it.

Writes results/freezing_coil.csv, freezing_seeds.csv, freezing_onset.csv,
freezing_damping.csv, freezing_rope.csv and freezing_envs.csv. Times
are ratios to the run without freezing measured in the same process.
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, SHARP_CONTACT, experiment, write_csv  # noqa: E402

import bathprint.envs as E
from bathprint.analysis.measure import buckling_length, coil_geometry
from bathprint.core.simulation import Simulation
from bathprint.errors import SimulationError
from bathprint.studies.accuracy import coil_run

_onsets = experiment("contact_newton")  # contact's onsets as it measured them
ONSET_BEFORE_CONTACT, WIDE_AT_CONTACT = _onsets.ONSET_BEFORE_CONTACT, _onsets.WIDE_AT_CONTACT

COIL = "gelation_coiling_22G"
FREEZE_MM = (20.0, 40.0, 60.0, 100.0, 150.0)
SEEDS = (1, 2, 3)


def _coil(overrides: dict, duration_s: float = 3.0) -> tuple[float, float, float]:
    t0 = time.perf_counter()
    r, om = coil_run({**SHARP_CONTACT, **overrides}, duration_s)
    return r, om, time.perf_counter() - t0


def coil_table() -> list[dict]:
    """Radius / frequency changes and wall-time ratios of the steady coil."""
    scene = Simulation(COIL).scene
    dx = scene.numerics.node_spacing_mm
    inertial = {"effects": [*scene.effects, "inertia"]}
    rows = []
    for preset, extra, factor, tol, growth in (
        ("draft", {}, 2.0, 1e-2, 2.0),
        ("balanced", {}, 1.0, 1e-3, 0.5),
        ("draft + inertia", inertial, 2.0, 1e-2, 2.0),
    ):
        base = {"numerics.accuracy": preset.split()[0], **extra}
        tighter = {
            **extra,
            "numerics.tolerance": tol / 10,
            "numerics.max_inlet_growth": growth,
            "numerics.node_spacing_mm": dx * factor,
        }
        _coil({**base, "duration_s": 0.3})  # load the kernels
        r0, om0, w0 = _coil(base)
        rt, omt, wt = _coil(tighter)
        rows.append(
            {
                "preset": preset,
                "variant": "tolerance / 10",
                "radius_change": rt / r0 - 1,
                "frequency_change": omt / om0 - 1,
                "wall_ratio": wt / w0,
            }
        )
        variants = [(f"imperfection seed {k}", {"seed": k}) for k in SEEDS]
        variants += [
            (f"frozen beyond {fb:g} mm", {"numerics.freeze_beyond_mm": fb}) for fb in FREEZE_MM
        ]
        for label, extra in variants:
            r, om, w = _coil({**base, **extra})
            rows.append(
                {
                    "preset": preset,
                    "variant": label,
                    "radius_change": r / r0 - 1,
                    "frequency_change": om / om0 - 1,
                    "wall_ratio": w / w0,
                }
            )
    return rows


SEED_PAIRS = 8  # seeds of the paired comparison (--part seeds)
SEEDS_FREEZE_MM = (100.0, 125.0, 150.0)
# the coil at 3 s (as tests/test_freezing.py) and at 4.5 s: the filament reaches 150 mm at
# about 2.3 s, so at 3 s the farthest freezing has acted for under two turns of the coil
SEEDS_DURATION_S = (3.0, 4.5)


def seeds_table(n_seeds: int = SEED_PAIRS) -> list[dict]:
    """R and omega of the steady coil at each of SEEDS_DURATION_S with and without freezing
    beyond each of SEEDS_FREEZE_MM, per seed: draft, draft with inertia, and draft with
    inertia but without contact (whether the frozen tail acts through contact); the free
    joint (``numerics.freeze_joint``), where ``--part turns`` compares both."""
    scene = Simulation(COIL).scene
    effects = list(scene.effects)
    rows = []
    for label, chosen in (
        ("draft", effects),
        ("draft + inertia", [*effects, "inertia"]),
        ("draft + inertia - contact", [*(e for e in effects if e != "contact"), "inertia"]),
    ):
        base = {"numerics.accuracy": "draft", "effects": chosen, "numerics.freeze_joint": "free"}
        for duration, k in itertools.product(SEEDS_DURATION_S, range(n_seeds)):
            r0, om0, _ = _coil({**base, "seed": k}, duration)
            for freeze_mm in SEEDS_FREEZE_MM:
                frozen = {**base, "seed": k, "numerics.freeze_beyond_mm": freeze_mm}
                rf, omf, _ = _coil(frozen, duration)
                rows.append(
                    {
                        "preset": label,
                        "duration_s": duration,
                        "seed": k,
                        "freeze_beyond_mm": freeze_mm,
                        "coil_radius_m": r0,
                        "coil_radius_frozen_m": rf,
                        "radius_change": rf / r0 - 1,
                        "frequency_rad_s": om0,
                        "frequency_frozen_rad_s": omf,
                        "frequency_change": omf / om0 - 1,
                    }
                )
    return rows


TURNS_DURATION_S = 6.0  # about 380 mm of filament: freezing beyond 200 mm holds 12 turns
TURNS_FREEZE_MM = (60.0, 100.0, 150.0, 200.0)
TURNS_SEEDS = 6
NEAR_NEEDLE_TURNS = 3  # the first full turns below the stem
TURNS_EARLIER_S = 4.0  # the coil at the needle is also measured then (its drift to 6 s)


def turns_table(n_seeds: int = TURNS_SEEDS) -> list[dict]:
    """The radius of each full turn of the steady coil at TURNS_DURATION_S, counted from the
    needle, with and without freezing beyond each of TURNS_FREEZE_MM, per seed: draft and
    with inertia, each with the free and the default (clamped) joint
    (``numerics.freeze_joint``), and with the free joint without contact or gelation (which
    effects its change needs).
    ``coil_run``'s R is the median over the core turns, the frozen ones among them; the
    turns next to the needle are the coil being written."""
    effects_of = list(Simulation(COIL).scene.effects)
    rows = []
    free = {"numerics.freeze_joint": "free"}
    for label, effects, joint in (
        ("draft, free joint", effects_of, free),
        ("draft, clamped joint", effects_of, {}),
        ("draft + inertia, free joint", [*effects_of, "inertia"], free),
        ("draft + inertia, clamped joint", [*effects_of, "inertia"], {}),
        ("draft - contact, free joint", [e for e in effects_of if e != "contact"], free),
        ("draft - gelation, free joint", [e for e in effects_of if e != "gelation"], free),
    ):
        for k in range(n_seeds):
            for freeze_mm in (0.0, *TURNS_FREEZE_MM):
                over = {"numerics.accuracy": "draft", "effects": effects, "seed": k}
                over["numerics.freeze_beyond_mm"] = freeze_mm
                over["duration_s"] = TURNS_DURATION_S
                joint_over = joint if freeze_mm > 0.0 else {}
                sim = Simulation(COIL, {**SHARP_CONTACT, **over, **joint_over})
                pos, axis = sim.model.needle[0, 1:4].copy(), sim.model.needle[0, 4:7].copy()
                t0 = time.perf_counter()
                sim.advance(TURNS_EARLIER_S)
                earlier = coil_geometry(sim.centerline(), pos, axis)
                sim.advance(TURNS_DURATION_S)
                wall = time.perf_counter() - t0
                geom = coil_geometry(sim.centerline(), pos, axis)
                stem = buckling_length(sim.centerline(), pos, axis)
                if geom is None or len(geom.radii) < NEAR_NEEDLE_TURNS:
                    raise RuntimeError(f"{label}, seed {k}, frozen beyond {freeze_mm} mm: no coil")
                few = earlier is None or len(earlier.radii) < NEAR_NEEDLE_TURNS
                rows.append(
                    {
                        "preset": label,
                        "seed": k,
                        "freeze_beyond_mm": freeze_mm,
                        "frozen_nodes": sim.n_frozen,
                        "wall_s": wall,
                        "nodes": sim.n_nodes,
                        "near_needle_radius_m": float(np.median(geom.radii[:NEAR_NEEDLE_TURNS])),
                        "near_needle_radius_earlier_m": float("nan")
                        if few
                        else float(np.median(earlier.radii[:NEAR_NEEDLE_TURNS])),
                        "buckling_length_m": float("nan") if stem is None else stem,
                        "coil_radius_m": geom.radius,
                        "turn_radii_m": " ".join(f"{r:.6e}" for r in geom.radii),
                        "turn_lengths_m": " ".join(f"{t:.6e}" for t in geom.turn_lengths),
                    }
                )
    return rows


def turns_summary(rows: list[dict]) -> list[dict]:
    """Per preset and freeze distance, freezing's change paired by seed: of the radius next
    to the needle, of the core median, and per turn (means over the seeds)."""
    base = {(r["preset"], r["seed"]): r for r in rows if float(r["freeze_beyond_mm"]) == 0.0}
    out = []
    for preset in dict.fromkeys(r["preset"] for r in rows):
        mine = [base[k] for k in base if k[0] == preset]
        near0 = np.array([float(r["near_needle_radius_m"]) for r in mine])
        for freeze_mm in TURNS_FREEZE_MM:
            sel = [
                r
                for r in rows
                if r["preset"] == preset and float(r["freeze_beyond_mm"]) == freeze_mm
            ]
            near, core, per_turn, wall, stem, drift = [], [], [], [], [], []
            for r in sel:
                b = base[(preset, r["seed"])]
                wall.append(float(r["wall_s"]) / float(b["wall_s"]))
                stem.append(float(r["buckling_length_m"]) / float(b["buckling_length_m"]) - 1)
                drift.append(
                    float(r["near_needle_radius_m"]) / float(r["near_needle_radius_earlier_m"]) - 1
                )
                near.append(float(r["near_needle_radius_m"]) / float(b["near_needle_radius_m"]) - 1)
                core.append(float(r["coil_radius_m"]) / float(b["coil_radius_m"]) - 1)
                ra = np.array(str(r["turn_radii_m"]).split(), dtype=float)
                rb = np.array(str(b["turn_radii_m"]).split(), dtype=float)
                n = min(len(ra), len(rb))
                per_turn.append(ra[:n] / rb[:n] - 1)
            n = min(len(t) for t in per_turn)
            turn_mean = np.mean([t[:n] for t in per_turn], axis=0)
            drift0 = [
                float(b["near_needle_radius_m"]) / float(b["near_needle_radius_earlier_m"]) - 1
                for b in mine
            ]
            worst = int(np.argmax(np.abs(turn_mean)))
            out.append(
                {
                    "preset": preset,
                    "freeze_beyond_mm": freeze_mm,
                    "seeds": len(sel),
                    "near_needle_change_mean": float(np.mean(near)),
                    "near_needle_change_min": float(np.min(near)),
                    "near_needle_change_max": float(np.max(near)),
                    "near_needle_seed_spread": float(np.std(near0) / np.mean(near0)),
                    "core_median_change_mean": float(np.mean(core)),
                    "largest_turn_change": float(turn_mean[worst]),
                    "largest_turn_index": worst,
                    "wall_ratio": float(np.mean(wall)),
                    "buckling_length_change_mean": float(np.mean(stem)),
                    "near_needle_drift_mean": float(np.mean(drift)),
                    "near_needle_drift_not_frozen_mean": float(np.mean(drift0)),
                    "turn_change_mean": " ".join(f"{x:.5f}" for x in turn_mean),
                }
            )
    return out


def plot_turns(summary: list[dict]) -> Path:
    """Freezing's mean change of each turn's radius against its index from the needle."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    presets = list(dict.fromkeys(r["preset"] for r in summary))
    fig, axes = plt.subplots(3, 2, figsize=(10, 10.4), sharey=True)
    for ax, preset in zip(axes.ravel(), presets, strict=True):
        for r in (r for r in summary if r["preset"] == preset):
            y = 100 * np.array(str(r["turn_change_mean"]).split(), dtype=float)
            ax.plot(
                np.arange(len(y)), y, marker="o", ms=3, label=f"beyond {r['freeze_beyond_mm']:g} mm"
            )
        ax.axhline(0.0, color="k", lw=0.6)
        ax.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax.set_title(f"{COIL}, {preset}, {TURNS_DURATION_S:g} s")
        ax.set_xlabel("full turn, counted from the needle")
    for ax in axes[:, 0]:
        ax.set_ylabel("radius change by freezing (%),\nmean over seeds")
    axes[0, 0].legend(fontsize=8)
    fig.tight_layout()
    path = RESULTS / "freezing_turns.png"
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


ROPE_STEP_BUDGET = 20  # a variant may take this many times the steps of the run without freezing


ONSET_SEEDS = 6
ONSET_DURATION_S = 6.0
#: the normal dashpot of --part onset (``contact.damping_time_s``, s): a touching pair of
#: 22G turns is a spring of k = ``contact.stiffness_pa`` (1 kPa) between masses of
#: m = (rho + C_a rho_bath) A per length, omega = sqrt(2 k / m) ~ 2700 rad/s at full
#: stiffness and 540-760 rad/s at 4-8% of it (the onset before contact's resting gaps), which
#: the bath's drag damps by under 1%; beta omega / 2 > 1 damps it critically at both
DASHPOT_S = 0.01
_DASHPOT = {"contact.damping_time_s": DASHPOT_S}
#: contact's onset variants of --part onset: label, scene overrides
ONSET_VARIANTS = (
    ("default onset", {}),
    ("onset before contact (0.2 delta from 1.02 (r_A + r_B))", ONSET_BEFORE_CONTACT),
    (f"default onset, dashpot {DASHPOT_S * 1e3:g} ms", _DASHPOT),
    (
        f"onset before contact, dashpot {DASHPOT_S * 1e3:g} ms",
        {**ONSET_BEFORE_CONTACT, **_DASHPOT},
    ),
)


#: --part onset_wide: the default's onset width started at the sum of the radii (what
#: ``contact_newton.py --part ratio_wide`` measures on the pile), without and with the
#: dashpot
ONSET_WIDE_VARIANTS = (
    ("onset 0.2 delta from r_A + r_B", WIDE_AT_CONTACT),
    (
        f"onset 0.2 delta from r_A + r_B, dashpot {DASHPOT_S * 1e3:g} ms",
        {**WIDE_AT_CONTACT, **_DASHPOT},
    ),
)


def _near_needle_radius(over: dict, duration_s: float) -> float:
    """Median radius (m) of the NEAR_NEEDLE_TURNS full turns below the stem at
    ``duration_s`` of COIL with ``over``."""
    sim = Simulation(COIL, {**SHARP_CONTACT, **over, "duration_s": duration_s})
    pos, axis = sim.model.needle[0, 1:4].copy(), sim.model.needle[0, 4:7].copy()
    sim.advance(duration_s)
    geom = coil_geometry(sim.centerline(), pos, axis)
    if geom is None or len(geom.radii) < NEAR_NEEDLE_TURNS:
        raise RuntimeError(f"{COIL} with {over}: no coil at the needle")
    return float(np.median(geom.radii[:NEAR_NEEDLE_TURNS]))


def _draft_and_tight(base: dict, spacing_mm: float) -> tuple[dict, dict]:
    """``base`` at the draft preset, and at a tenfold tighter tolerance with half the draft's
    node spacing (twice the scene's ``spacing_mm``): the draft preset's own error."""
    draft = {**base, "numerics.accuracy": "draft"}
    tight = {
        **base,
        "numerics.tolerance": 1e-3,
        "numerics.max_inlet_growth": 2.0,
        "numerics.node_spacing_mm": 2 * spacing_mm,
    }
    return draft, tight


def onset_table(
    n_seeds: int = ONSET_SEEDS,
    duration_s: float = ONSET_DURATION_S,
    variants: tuple = ONSET_VARIANTS,
) -> list[dict]:
    """Per contact onset and seed, with ``inertia``: the change of the coil at the needle
    that freezing beyond 100 mm (clamped joint, the default) makes, beside that of a tenfold
    tighter tolerance at half the node spacing (the draft preset's own error), and those of
    the free joint beyond 60 and 150 mm and the clamped joint beyond 60 mm (what
    ``tests/test_freezing.py`` asserts with the default onset, there over seeds 0-5 and
    0-1), for each of ``variants`` (label, contact's overrides)."""
    scene = Simulation(COIL).scene
    effects = [*scene.effects, "inertia"]
    spacing = scene.numerics.node_spacing_mm
    rows = []
    for label, onset in variants:
        for seed in range(n_seeds):
            base = {"effects": effects, "seed": seed, **onset}
            draft, tight = _draft_and_tight(base, spacing)

            def radius(over: dict, freeze_mm: float = 0.0, joint: str = "auto") -> float:
                frozen = {"numerics.freeze_beyond_mm": freeze_mm, "numerics.freeze_joint": joint}
                return _near_needle_radius({**over, **frozen}, duration_s)

            r0, r0_free = radius(draft), radius(draft, 0.0, "free")
            rows.append(
                {
                    "onset": label,
                    "seed": seed,
                    "radius_m": r0,
                    "frozen_100mm_change": radius(draft, 100.0) / r0 - 1,
                    "tighter_change": radius(tight) / r0 - 1,
                    "free_60mm_change": radius(draft, 60.0, "free") / r0_free - 1,
                    "free_150mm_change": radius(draft, 150.0, "free") / r0_free - 1,
                    "clamped_60mm_change": radius(draft, 60.0, "clamped") / r0_free - 1,
                }
            )
            r = rows[-1]
            print(
                f"{label}, seed {seed}: frozen beyond 100 mm {100 * r['frozen_100mm_change']:+.2f}%"
                f", tighter {100 * r['tighter_change']:+.2f}%; free joint beyond 60 / 150 mm "
                f"{100 * r['free_60mm_change']:+.2f}% / {100 * r['free_150mm_change']:+.2f}%, "
                f"clamped beyond 60 mm {100 * r['clamped_60mm_change']:+.2f}%",
                flush=True,
            )
    return rows


def rope_table(duration_s: float = 6.0) -> list[dict]:
    """Changes of the rope-coiling run near the needle and of the pile, and wall ratios. A
    variant whose steps collapse stops at ROPE_STEP_BUDGET times the steps of the run without
    freezing; it reports the time it reached, and no changes."""

    def run(extra: dict, max_steps: int = 10**9) -> tuple[Simulation, float]:
        sim = Simulation("rope_coiling_18G", {**SHARP_CONTACT, **extra})
        t0 = time.perf_counter()
        try:
            sim.advance(duration_s, max_steps=max_steps)
        except SimulationError as exc:  # reported as the time it reached
            print(f"  {extra}: {exc}")
        return sim, time.perf_counter() - t0

    run({"duration_s": 0.5})  # load the kernels
    base, w0 = run({})
    budget = ROPE_STEP_BUDGET * base.counts()["steps"]
    rows = []
    for label, extra in [("tolerance / 3", {"numerics.tolerance": 3e-4})] + [
        (f"frozen beyond {fb:g} mm", {"numerics.freeze_beyond_mm": fb}) for fb in (15.0, 30.0, 60.0)
    ]:
        sim, w = run(extra, budget)
        finished = sim.t >= duration_s * (1 - 1e-9)
        near = pile = float("nan")
        if finished:
            d = sim.newest_material(30e-3) - base.newest_material(30e-3)
            near = float(np.sqrt(np.mean(np.sum(d**2, axis=1))))
            pile = float(np.linalg.norm(sim.centerline().mean(0) - base.centerline().mean(0)))
        rows.append(
            {
                "variant": label,
                "reached_s": sim.t,
                "frozen_nodes": sim.n_frozen,
                "nodes": sim.n_nodes,
                "near_needle_rms_mm": near * 1e3,
                "pile_centre_shift_mm": pile * 1e3,
                "steps": sim.counts()["steps"],
                "rejected": sim.counts()["rejected_steps"],
                "wall_ratio": w / w0,
            }
        )
    return rows


def _episodes(
    env_id: str, accuracy: str, freeze_mm: float | None, n: int
) -> tuple[np.ndarray, float]:
    """Final metrics of n seeded random-action episodes, and steps per CPU second."""
    extra = {} if freeze_mm is None else {"numerics.freeze_beyond_mm": freeze_mm}
    env = E.make(env_id, accuracy=accuracy, scene_overrides=extra)
    env.reset(seed=0)  # warm-up states and kernels, outside the timing
    finals, steps, cpu = [], 0, 0.0
    for ep in range(n):
        env.action_space.seed(100 + ep)
        env.reset(seed=100 + ep)
        c0, done, info = time.process_time(), False, {}
        while not done:
            _, _, term, trunc, info = env.step(env.action_space.sample())
            done, steps = term or trunc, steps + 1
        cpu += time.process_time() - c0
        finals.append(info["metric"])
    env.close()
    return np.array(finals), steps / cpu


#: --part damping: label, with inertia, contact's overrides (what --part onset leaves out)
DAMPING_VARIANTS = (
    ("overdamped, default onset", False, {}),
    ("overdamped, onset before contact", False, ONSET_BEFORE_CONTACT),
    (
        "inertia, onset before contact, dashpot 1 ms",
        True,
        {**ONSET_BEFORE_CONTACT, "contact.damping_time_s": 1e-3},
    ),
    (
        "inertia, onset before contact, dashpot 3 ms",
        True,
        {**ONSET_BEFORE_CONTACT, "contact.damping_time_s": 3e-3},
    ),
)


def damping_table(n_seeds: int = ONSET_SEEDS, duration_s: float = ONSET_DURATION_S) -> list[dict]:
    """Per DAMPING_VARIANTS row and seed, the comparison ``tests/test_freezing.py`` makes at
    the needle: the change of the coil there by freezing beyond 100 mm and by a tenfold
    tighter tolerance at half the node spacing, each against the draft run."""
    scene = Simulation(COIL).scene
    spacing = scene.numerics.node_spacing_mm
    rows = []
    for label, inertia, contact in DAMPING_VARIANTS:
        effects = [*scene.effects, *(["inertia"] if inertia else [])]
        for seed in range(n_seeds):
            base = {"effects": effects, "seed": seed, **contact}
            draft, tight = _draft_and_tight(base, spacing)
            r0 = _near_needle_radius(draft, duration_s)
            frozen = {**draft, "numerics.freeze_beyond_mm": 100.0}
            rows.append(
                {
                    "variant": label,
                    "seed": seed,
                    "radius_m": r0,
                    "frozen_100mm_change": _near_needle_radius(frozen, duration_s) / r0 - 1,
                    "tighter_change": _near_needle_radius(tight, duration_s) / r0 - 1,
                }
            )
            r = rows[-1]
            print(
                f"{label}, seed {seed}: frozen beyond 100 mm "
                f"{100 * r['frozen_100mm_change']:+.2f}%, "
                f"tighter {100 * r['tighter_change']:+.2f}%",
                flush=True,
            )
    return rows


def env_table(episodes: int) -> list[dict]:
    rows = []
    for env_id in E.ENV_IDS:
        bal, _ = _episodes(env_id, "balanced", 0.0, episodes)
        off, rate_off = _episodes(env_id, "draft", 0.0, episodes)
        on, rate_on = _episodes(env_id, "draft", None, episodes)  # the preset: beyond 20 mm
        rows.append(
            {
                "env": env_id,
                "episodes": episodes,
                "mean_final_metric_draft": float(off.mean()),
                "freezing_change": float(np.abs(on - off).mean()),
                "draft_vs_balanced": float(np.abs(off - bal).mean()),
                "steps_per_cpu_s_frozen": rate_on,
                "steps_per_cpu_s_not_frozen": rate_off,
                "speedup": rate_on / rate_off,
            }
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--episodes", type=int, default=8)
    ap.add_argument(
        "--part",
        choices=("coil", "seeds", "turns", "onset", "onset_wide", "damping", "rope", "envs"),
        default=None,
        help="only this",
    )
    args = ap.parse_args()
    if args.part in (None, "coil"):
        coil_part()
    if args.part in (None, "seeds"):
        seeds_part()
    if args.part in (None, "turns"):
        turns_part()
    if args.part in (None, "onset"):
        print("->", write_csv("freezing_onset", onset_table()))
    if args.part in (None, "onset_wide"):
        rows = onset_table(variants=ONSET_WIDE_VARIANTS)
        print("->", write_csv("freezing_onset_wide", rows))
    if args.part in (None, "damping"):
        print("->", write_csv("freezing_damping", damping_table()))
    if args.part in (None, "rope"):
        rope_part()
    if args.part in (None, "envs"):
        envs_part(args.episodes)


def coil_part() -> None:
    coil = coil_table()
    print(f"{'preset':9s} {'variant':22s} {'dR/R':>9s} {'domega/omega':>13s} {'wall ratio':>10s}")
    for r in coil:
        print(
            f"{r['preset']:9s} {r['variant']:22s} {r['radius_change']:+9.4f} "
            f"{r['frequency_change']:+13.4f} {r['wall_ratio']:10.2f}"
        )
    print("->", write_csv("freezing_coil", coil))


def seeds_part() -> None:
    rows = seeds_table()
    print("\nfreezing, paired by seed: dR/R (%)")
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        groups.setdefault((r["preset"], r["duration_s"], r["freeze_beyond_mm"]), []).append(r)
    for (preset, duration, freeze_mm), sel in groups.items():
        change = np.array([r["radius_change"] for r in sel]) * 100
        radius = np.array([r["coil_radius_m"] for r in sel])
        print(
            f"{preset:26s} {duration:3.1f} s, beyond {freeze_mm:3.0f} mm: {change.mean():+.2f} "
            f"(min {change.min():+.2f}, max {change.max():+.2f}); R over seeds: std "
            f"{100 * radius.std() / radius.mean():.2f}"
        )
    print("->", write_csv("freezing_seeds", rows))


def turns_part() -> None:
    rows = turns_table()
    print("->", write_csv("freezing_turns_runs", rows))
    summary = turns_summary(rows)
    print(f"\nat {TURNS_DURATION_S:g} s, paired by seed: radius change (%)")
    for r in summary:
        print(
            f"{r['preset']:30s} beyond {r['freeze_beyond_mm']:3.0f} mm: near the needle "
            f"{100 * r['near_needle_change_mean']:+.2f} ({100 * r['near_needle_change_min']:+.2f}"
            f" to {100 * r['near_needle_change_max']:+.2f}; seeds' spread "
            f"{100 * r['near_needle_seed_spread']:.2f}), core median "
            f"{100 * r['core_median_change_mean']:+.2f}, largest "
            f"{100 * r['largest_turn_change']:+.2f} at turn {r['largest_turn_index']}; wall "
            f"{r['wall_ratio']:.2f}x; stem {100 * r['buckling_length_change_mean']:+.1f}; R "
            f"{TURNS_EARLIER_S:g} -> {TURNS_DURATION_S:g} s "
            f"{100 * r['near_needle_drift_mean']:+.2f} (not frozen "
            f"{100 * r['near_needle_drift_not_frozen_mean']:+.2f})"
        )
    print("->", write_csv("freezing_turns", summary))
    print("->", plot_turns(summary))


def rope_part() -> None:
    rope = rope_table()
    print(
        f"\n{'rope coiling, 6 s':24s} {'frozen':>10s} {'near rms mm':>11s} {'pile mm':>8s} "
        f"{'steps/rej':>12s} {'wall ratio':>10s}"
    )
    for r in rope:
        print(
            f"{r['variant']:24s} {r['frozen_nodes']:4d}/{r['nodes']:<5d} "
            f"{r['near_needle_rms_mm']:11.4f} {r['pile_centre_shift_mm']:8.4f} "
            f"{r['steps']:6d}/{r['rejected']:<5d} {r['wall_ratio']:10.2f} "
            f"(reached {r['reached_s']:.3g} s)"
        )
    print("->", write_csv("freezing_rope", rope))


def envs_part(episodes: int) -> None:
    envs = env_table(episodes)
    print(
        f"\n{'env':28s} {'mean M':>7s} {'|dM| freeze':>11s} {'|dM| draft-bal':>14s} "
        f"{'steps/cpu-s off -> on':>22s}"
    )
    for r in envs:
        print(
            f"{r['env']:28s} {r['mean_final_metric_draft']:7.3f} {r['freezing_change']:11.4f} "
            f"{r['draft_vs_balanced']:14.4f} {r['steps_per_cpu_s_not_frozen']:9.0f} -> "
            f"{r['steps_per_cpu_s_frozen']:5.0f} ({r['speedup']:.2f}x)"
        )
    print("->", write_csv("freezing_envs", envs))


if __name__ == "__main__":
    main()

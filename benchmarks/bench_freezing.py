"""What freezing settled material (``numerics.freeze_beyond_mm``) costs in accuracy and
saves in time.

    python benchmarks/bench_freezing.py [--part coil|seeds|rope|envs] [--episodes 8]

(1) A steady coil (scene ``gelation_coiling_22G``, 3 s; draft and balanced presets, and draft
    with ``inertia``): coil
    radius and frequency and wall time with the material beyond 20, 40, 60, 100 and 150 mm
    frozen, against the same run without freezing; beside it, how much the coil varies by
    itself: the change that tightening the tolerance ten times makes (the error the preset
    already accepts) and the change from three other seeds of the needle imperfection.
(1b) ``--part seeds``: the same coil, draft, with and without ``inertia``, frozen beyond
    100 mm (what ``tests/test_freezing.py`` asserts) and not, for each of ``SEED_PAIRS``
    seeds of the needle imperfection: freezing's change paired by seed, beside how much R
    varies from seed to seed. One seed's change can hide a bias that every seed shares.
(2) Rope coiling on the floor (scene ``rope_coiling_18G``, 6 s, or as far as 20 times the
    steps of the run without freezing take it): the RMS change of the last
    30 mm of material next to the needle and of the pile's centre, with the material resting
    on the floor beyond 15, 30 and 60 mm frozen, beside tightening the tolerance 3x.
(3) The environments at their ``draft`` preset (which freezes beyond 20 mm) under random
    actions: the final metric of ``--episodes`` seeded episodes with and without freezing,
    beside the difference between the draft and balanced presets (both without freezing),
    and environment steps per CPU second of each.

Writes benchmarks/results/freezing_coil.csv, freezing_seeds.csv, freezing_rope.csv and
freezing_envs.csv. Times
are ratios to the run without freezing measured in the same process.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from _common import write_csv

import bathprint.envs as E
from bathprint.core.simulation import Simulation
from bathprint.errors import SimulationError
from bathprint.studies.accuracy import coil_run

COIL = "gelation_coiling_22G"
FREEZE_MM = (20.0, 40.0, 60.0, 100.0, 150.0)
SEEDS = (1, 2, 3)


def _coil(overrides: dict) -> tuple[float, float, float]:
    t0 = time.perf_counter()
    r, om = coil_run(overrides)
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
SEEDS_FREEZE_MM = 100.0


def seeds_table(n_seeds: int = SEED_PAIRS) -> list[dict]:
    """R and omega of the steady coil with and without freezing beyond SEEDS_FREEZE_MM, per
    seed, draft, with and without inertia."""
    scene = Simulation(COIL).scene
    rows = []
    for label, effects in (
        ("draft", list(scene.effects)),
        ("draft + inertia", [*scene.effects, "inertia"]),
    ):
        base = {"numerics.accuracy": "draft", "effects": effects}
        for k in range(n_seeds):
            r0, om0, _ = _coil({**base, "seed": k})
            rf, omf, _ = _coil({**base, "seed": k, "numerics.freeze_beyond_mm": SEEDS_FREEZE_MM})
            rows.append(
                {
                    "preset": label,
                    "seed": k,
                    "freeze_beyond_mm": SEEDS_FREEZE_MM,
                    "coil_radius_m": r0,
                    "coil_radius_frozen_m": rf,
                    "radius_change": rf / r0 - 1,
                    "frequency_rad_s": om0,
                    "frequency_frozen_rad_s": omf,
                    "frequency_change": omf / om0 - 1,
                }
            )
    return rows


ROPE_STEP_BUDGET = 20  # a variant may take this many times the steps of the run without freezing


def rope_table(duration_s: float = 6.0) -> list[dict]:
    """Changes of the rope-coiling run near the needle and of the pile, and wall ratios. A
    variant whose steps collapse stops at ROPE_STEP_BUDGET times the steps of the run without
    freezing; it reports the time it reached, and no changes."""

    def run(extra: dict, max_steps: int = 10**9) -> tuple[Simulation, float]:
        sim = Simulation("rope_coiling_18G", extra)
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
        "--part", choices=("coil", "seeds", "rope", "envs"), default=None, help="only this"
    )
    args = ap.parse_args()
    if args.part in (None, "coil"):
        coil_part()
    if args.part in (None, "seeds"):
        seeds_part()
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
    print(f"\nfrozen beyond {SEEDS_FREEZE_MM:g} mm, paired by seed: dR/R (%)")
    for preset in dict.fromkeys(r["preset"] for r in rows):
        sel = [r for r in rows if r["preset"] == preset]
        change = np.array([r["radius_change"] for r in sel]) * 100
        radius = np.array([r["coil_radius_m"] for r in sel])
        print(
            f"{preset:16s} freezing {change.mean():+.2f} (min {change.min():+.2f}, max "
            f"{change.max():+.2f}); R over seeds: std {100 * radius.std() / radius.mean():.2f}"
        )
    print("->", write_csv("freezing_seeds", rows))


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

"""Environment steps per second: every environment (versions 0 and 1) and accuracy preset,
in 1 process and in 2 processes (``gymnasium.make_vec`` async, 2 environments), under random
actions (episode resets included). Writes results/envs.csv, and the ratio of
version 1 to version 0 (steps per CPU second, one process, measured back to back in the
same run) to results/envs_v1_ratio.csv.

    python experiments/env_speed/env_speed.py [--seconds 5] [--envs CoilRadius ...]
                                    [--presets draft ...]
                                    [--versions v0 v1] [--processes 1 2] [--pool 64]
                                    [--matched]

Version 1 draws its training targets from a pool printed on first use (one episode each at
the print preset); the benchmark prints the first ``--pool`` of them before it measures
and draws from those (``target.train_pool``), so that the rates are those of stepping.
Random actions are not the same physics in both versions (version 1's log flow prints more
often at low flows, where a millimetre takes longer; WriteShape-v1 moves the needle):
``--matched`` also measures both at the same random physical controls (flows, and the
needle in x, y for WriteShape, where version 0 then moves it too), the environments' own cost.

Each measurement runs for at least ``--seconds`` of wall time after a warm-up episode (which
also fills the per-process cache of warm-up states and loads the numba kernels). On a shared
machine wall-clock rates depend on the load (1-minute average recorded beside each figure);
the single-process rows also give steps per CPU second of the process (``steps_per_cpu_s``),
the per-core figure that does not.
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import gymnasium
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import write_csv  # noqa: E402

import bathprint.envs as E

PRESETS = ("draft", "balanced", "fine")


def _kwargs(env_id: str, pool: int) -> dict:
    """Version 1: draw training targets from the first ``pool`` (printed beforehand)."""
    return {"spec_overrides": {"target": {"train_pool": pool}}} if E.printed_targets(env_id) else {}


def _print_pool(env_id: str, pool: int) -> float:
    """Print (or load) the first ``pool`` training targets of a v1 environment; seconds."""
    if not E.printed_targets(env_id):
        return 0.0
    t0 = time.perf_counter()
    fam = E.make(env_id, accuracy="draft", **_kwargs(env_id, pool)).unwrapped.printed
    for seed in range(pool):
        fam.get(seed)
    return time.perf_counter() - t0


def matched_controls(base: str, n: int = 20_000, seed: int = 0) -> list[tuple]:
    """Random physical controls both versions can set: (Q_o, Q_i ml/min, needle velocity
    mm/s), drawn as version 0's random actions (Q_i = 0 where version 1 has no oil; the
    inner fraction capped at version 1's; the needle in x, y at version 0's speed)."""
    v0 = E.make(f"{base}-v0", accuracy="draft", needle_velocity="xy").unwrapped
    v1 = E.make(f"{base}-v1", accuracy="draft").unwrapped
    rng = np.random.default_rng(seed)
    out = []
    for a in rng.uniform(-1.0, 1.0, (n, v0.action_space.shape[0])):
        c = v0.action_to_controls(a)
        qo, qi = c["q_outer_ml_min"], c["q_inner_ml_min"]
        if "q_inner" not in v1.action_names:
            qi = 0.0
        elif v1.inner_as_fraction:
            qi = min(qi, v1.inner_fraction_range[1] / (1 - v1.inner_fraction_range[1]) * qo)
        out.append((qo, qi, c["vel"][:2].copy()))
    return out


def _action(u, control: tuple) -> np.ndarray:
    """The action of environment ``u`` that sets these physical controls."""
    qo, qi, vel = control
    a = u.controls_to_action(qo, qi)
    if "inclusion_offset" in u.action_names:  # offset 0 (mid-range)
        a[u.action_names.index("inclusion_offset")] = 0.0
    for k, axis in enumerate("xy"):
        name = f"needle_v{axis}"
        if name in u.action_names:
            a[u.action_names.index(name)] = vel[k] / u.needle_speed_mm_s
    return np.clip(a, -1.0, 1.0)


def _one_process(
    env_id: str,
    accuracy: str,
    seconds: float,
    seed: int = 0,
    pool: int = 64,
    controls: list[tuple] | None = None,
) -> tuple[int, float, float]:
    """Steps, wall time and CPU time of this process (s). With ``controls``, the actions set
    those physical controls in turn (``matched_controls``), else they are random."""
    kwargs = _kwargs(env_id, pool)
    if controls is not None and env_id.endswith("-v0") and "WriteShape" in env_id:
        kwargs["needle_velocity"] = "xy"  # the same needle motion as version 1's
    env = E.make(env_id, accuracy=accuracy, **kwargs)
    u = env.unwrapped
    env.action_space.seed(seed)
    k = 0

    def act() -> np.ndarray:
        nonlocal k
        if controls is None:
            return env.action_space.sample()
        k += 1
        return _action(u, controls[(k - 1) % len(controls)])

    env.reset(seed=seed)
    done = False
    while not done:  # warm-up episode
        _, _, term, trunc, _ = env.step(act())
        done = term or trunc
    env.reset()
    steps, t0, c0 = 0, time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < seconds or steps < 20:
        _, _, term, trunc, _ = env.step(act())
        steps += 1
        if term or trunc:
            env.reset()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    env.close()
    return steps, wall, cpu


def _two_processes(
    env_id: str, accuracy: str, seconds: float, seed: int = 0, pool: int = 64
) -> tuple[int, float, float]:
    """Steps (both environments), wall time, and NaN (the workers' CPU time is not read)."""
    E.register_envs()
    venv = gymnasium.make_vec(
        env_id,
        num_envs=2,
        vectorization_mode="async",
        accuracy=accuracy,
        **_kwargs(env_id, pool),
    )  # autoreset: next step
    venv.action_space.seed(seed)
    venv.reset(seed=seed)
    episode = E.make(env_id, accuracy=accuracy, **_kwargs(env_id, pool)).unwrapped
    episode.reset(seed=seed)
    for _ in range(episode.episode_steps + 2):  # warm-up: imports, kernels, warm-up states
        venv.step(venv.action_space.sample())
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds or steps < 40:
        venv.step(venv.action_space.sample())
        steps += 2
    wall = time.perf_counter() - t0
    venv.close()
    return steps, wall, float("nan")


def main() -> None:
    import warnings

    warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=5.0, help="wall time per measurement")
    ap.add_argument("--envs", nargs="*", default=["CoilRadius", "WriteShape", "BuoyantLayers"])
    ap.add_argument("--presets", nargs="*", default=list(PRESETS))
    ap.add_argument("--versions", nargs="*", default=["v0", "v1"])
    ap.add_argument("--processes", nargs="*", type=int, default=[1, 2])
    ap.add_argument("--pool", type=int, default=64, help="v1 training targets to draw from")
    ap.add_argument(
        "--matched",
        action="store_true",
        help="also the ratio at the same physical controls (one process)",
    )
    args = ap.parse_args()
    rows, ratios = [], []
    print(
        f"{'environment':<28} {'accuracy':<9} {'proc':>4} {'steps':>6} {'steps/s':>8} "
        f"{'per proc':>8} {'per CPU s':>9} {'load':>5}"
    )
    for name in args.envs:
        base = name.removeprefix("bathprint/").split("-v")[0]
        ids = [E.resolve_id(f"{base}-{v}") for v in args.versions]
        for env_id in ids:
            took = _print_pool(env_id, args.pool)
            if took > 0:
                print(f"{env_id}: {args.pool} training targets ready in {took:.1f} s", flush=True)
        for accuracy in args.presets:
            seconds = args.seconds * (2.0 if accuracy == "fine" else 1.0)
            per_cpu: dict[str, float] = {}
            for procs in args.processes:
                for env_id in ids:  # versions back to back: the same machine state
                    fn = _one_process if procs == 1 else _two_processes
                    steps, wall, cpu = fn(env_id, accuracy, seconds, pool=args.pool)
                    rate = steps / wall
                    load = os.getloadavg()[0]
                    rows.append(
                        {
                            "env": env_id,
                            "accuracy": accuracy,
                            "processes": procs,
                            "steps": steps,
                            "wall_s": round(wall, 3),
                            "steps_per_s": round(rate, 1),
                            "steps_per_s_per_process": round(rate / procs, 1),
                            "steps_per_cpu_s": round(steps / cpu, 1) if cpu == cpu else "",
                            "load_avg_1min": round(load, 2),
                            "cpus": os.cpu_count(),
                        }
                    )
                    if procs == 1:
                        per_cpu[env_id[-2:]] = steps / cpu
                    shown = f"{steps / cpu:9.1f}" if cpu == cpu else f"{'-':>9}"
                    print(
                        f"{env_id:<28} {accuracy:<9} {procs:>4} {steps:>6} {rate:>8.1f} "
                        f"{rate / procs:>8.1f} {shown} {load:>5.2f}",
                        flush=True,
                    )
            if "v0" in per_cpu and "v1" in per_cpu:
                row = {
                    "env": base,
                    "accuracy": accuracy,
                    "v0_steps_per_cpu_s": round(per_cpu["v0"], 1),
                    "v1_steps_per_cpu_s": round(per_cpu["v1"], 1),
                    "v1_over_v0": round(per_cpu["v1"] / per_cpu["v0"], 3),
                }
                print(f"  {base} {accuracy}: v1 / v0 = {row['v1_over_v0']:.2f} (random actions)")
                if args.matched:
                    controls = matched_controls(base)
                    same = {}
                    for env_id in ids:
                        steps, _, cpu = _one_process(
                            env_id, accuracy, seconds, pool=args.pool, controls=controls
                        )
                        same[env_id[-2:]] = steps / cpu
                    row["matched_v0_steps_per_cpu_s"] = round(same["v0"], 1)
                    row["matched_v1_steps_per_cpu_s"] = round(same["v1"], 1)
                    row["matched_v1_over_v0"] = round(same["v1"] / same["v0"], 3)
                    print(
                        f"  {base} {accuracy}: v1 / v0 = {row['matched_v1_over_v0']:.2f} "
                        f"(the same physical controls: v0 {same['v0']:.0f}, v1 {same['v1']:.0f})"
                    )
                ratios.append(row)
    path = write_csv("envs", rows)
    print(f"wrote {path}")
    if ratios:
        print(f"wrote {write_csv('envs_v1_ratio', ratios)}")
        for r in ratios:
            extra = f"  matched {r['matched_v1_over_v0']:.2f}" if "matched_v1_over_v0" in r else ""
            print(
                f"{r['env']:<14} {r['accuracy']:<9} v0 {r['v0_steps_per_cpu_s']:>7.0f}  "
                f"v1 {r['v1_steps_per_cpu_s']:>7.0f}  ratio {r['v1_over_v0']:.2f}{extra}"
            )
    best = max((r for r in rows if r["processes"] == 1), key=lambda r: r["steps_per_s"])
    print(
        f"fastest single process: {best['env']} {best['accuracy']}: "
        f"{best['steps_per_s']:.0f} steps/s"
    )


if __name__ == "__main__":
    main()

"""Environment steps per second: every environment and accuracy preset, in 1 process and in
2 processes (``gymnasium.make_vec`` async, 2 environments), under random actions (episode
resets included). Writes benchmarks/results/envs.csv.

    python benchmarks/bench_envs.py [--seconds 5] [--envs CoilRadius ...] [--presets draft ...]

Each measurement runs for at least ``--seconds`` of wall time after a warm-up episode (which
also fills the per-process cache of warm-up states and loads the numba kernels). On a shared
machine wall-clock rates depend on the load (1-minute average recorded beside each figure);
the single-process rows also give steps per CPU second of the process (``steps_per_cpu_s``),
the per-core figure that does not.
"""

from __future__ import annotations

import argparse
import os
import time

import gymnasium
from _common import write_csv

import bathprint.envs as E

PRESETS = ("draft", "balanced", "fine")


def _one_process(
    env_id: str, accuracy: str, seconds: float, seed: int = 0
) -> tuple[int, float, float]:
    """Steps, wall time and CPU time of this process (s)."""
    env = E.make(env_id, accuracy=accuracy)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    done = False
    while not done:  # warm-up episode
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        done = term or trunc
    env.reset()
    steps, t0, c0 = 0, time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < seconds or steps < 20:
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        steps += 1
        if term or trunc:
            env.reset()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    env.close()
    return steps, wall, cpu


def _two_processes(
    env_id: str, accuracy: str, seconds: float, seed: int = 0
) -> tuple[int, float, float]:
    """Steps (both environments), wall time, and NaN (the workers' CPU time is not read)."""
    E.register_envs()
    venv = gymnasium.make_vec(
        env_id, num_envs=2, vectorization_mode="async", accuracy=accuracy
    )  # autoreset: next step
    venv.action_space.seed(seed)
    venv.reset(seed=seed)
    episode = E.make(env_id, accuracy=accuracy).unwrapped
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
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=5.0, help="wall time per measurement")
    ap.add_argument("--envs", nargs="*", default=list(E.ENV_IDS))
    ap.add_argument("--presets", nargs="*", default=list(PRESETS))
    ap.add_argument("--processes", nargs="*", type=int, default=[1, 2])
    args = ap.parse_args()
    rows = []
    print(
        f"{'environment':<28} {'accuracy':<9} {'proc':>4} {'steps':>6} {'steps/s':>8} "
        f"{'per proc':>8} {'per CPU s':>9} {'load':>5}"
    )
    for name in args.envs:
        env_id = E.resolve_id(name)
        for accuracy in args.presets:
            seconds = args.seconds * (2.0 if accuracy == "fine" else 1.0)
            for procs in args.processes:
                fn = _one_process if procs == 1 else _two_processes
                steps, wall, cpu = fn(env_id, accuracy, seconds)
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
                per_cpu = f"{steps / cpu:9.1f}" if cpu == cpu else f"{'-':>9}"
                print(
                    f"{env_id:<28} {accuracy:<9} {procs:>4} {steps:>6} {rate:>8.1f} "
                    f"{rate / procs:>8.1f} {per_cpu} {load:>5.2f}",
                    flush=True,
                )
    path = write_csv("envs", rows)
    print(f"wrote {path}")
    best = max((r for r in rows if r["processes"] == 1), key=lambda r: r["steps_per_s"])
    print(
        f"fastest single process: {best['env']} {best['accuracy']}: "
        f"{best['steps_per_s']:.0f} steps/s (issue target: 2000 per core)"
    )


if __name__ == "__main__":
    main()

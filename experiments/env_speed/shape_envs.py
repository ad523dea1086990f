"""Steps per CPU second of the shape environments against their version-1 counterparts,
measured back to back in one process under random actions (episode resets included), at the
draft preset: the issue's "at least version 1's".

    python experiments/env_speed/shape_envs.py [--steps 3000] [--repeats 3]

Writes results/shape_envs_ratio.csv: per pair, the best-of-repeats rate of each and their
ratio (shape / version 1), measured interleaved so that the machine's load falls on both.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from _common import write_csv  # noqa: E402

from bathprint.envs import make  # noqa: E402

PAIRS = (
    ("bathprint/WriteShape-v2", "bathprint/WriteShape-v3"),
    ("bathprint/CoilRadius-v1", "bathprint/CoilRadius-v2"),
    ("bathprint/BuoyantLayers-v1", "bathprint/BuoyantLayers-v2"),
)


def rate(env, steps: int) -> float:
    """Steps per CPU second of ``steps`` random steps (resets included)."""
    env.reset(seed=0)
    env.action_space.seed(0)
    c0 = time.process_time()
    for _ in range(steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    return steps / (time.process_time() - c0)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=3000)
    ap.add_argument("--repeats", type=int, default=3)
    args = ap.parse_args()
    warnings.simplefilter("ignore", DeprecationWarning)
    rows = []
    for old_id, new_id in PAIRS:
        old, new = make(old_id, accuracy="draft"), make(new_id, accuracy="draft")
        rate(old, 200), rate(new, 200)  # warm-up states, kernels loaded
        a, b = [], []
        for _ in range(args.repeats):
            a.append(rate(old, args.steps))
            b.append(rate(new, args.steps))
        rows.append(
            {
                "version_1": old_id,
                "shape": new_id,
                "version_1_steps_per_cpu_s": round(max(a)),
                "shape_steps_per_cpu_s": round(max(b)),
                "ratio": round(max(b) / max(a), 3),
            }
        )
        print(rows[-1], flush=True)
    write_csv("shape_envs_ratio", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""What hindsight replay's rewards cost: the goal environments' ``compute_reward`` on a batch
of relabelled samples, compiled (one numba loop, :func:`bathprint.envs._kernels_v1.goal_rewards`)
against the same operations sample by sample in Python (the environment's
``_goal_reward_one_by_one``), on each version-1 environment. Both give the same rewards bit
for bit (checked here and in tests/test_envs_v1.py); the ratio is measured in the same run.

    python experiments/hindsight/hindsight.py [--batch 256] [--repeats 5]
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import best_of, write_csv  # noqa: E402

from bathprint.envs import make

V1 = ("bathprint/CoilRadius-v1", "bathprint/BuoyantLayers-v1", "bathprint/WriteShape-v1")


def relabelled(env_id: str, batch: int, seed: int = 0) -> tuple:
    """An episode of random actions and ``batch`` random (achieved, desired) pairs of it."""
    env = make(env_id, goal_conditioned=True)
    rng = np.random.default_rng(seed)
    achieved, desired = [], []
    obs, _ = env.reset(seed=seed)
    done = False
    while not done:
        obs, _, term, trunc, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        done = term or trunc
    a, d = np.array(achieved), np.array(desired)
    i, j = rng.integers(0, len(a), batch), rng.integers(0, len(a), batch)
    return env, a[i], d[j]


def rows(batch: int, repeats: int) -> list[dict]:
    out = []
    for env_id in V1:
        env, a, d = relabelled(env_id, batch)
        compiled = env.unwrapped.compute_reward(a, d, None)
        python = env.unwrapped._goal_reward_one_by_one(a, d)
        identical = bool(np.array_equal(compiled, python))
        t_py = best_of(lambda u=env.unwrapped, a=a, d=d: u._goal_reward_one_by_one(a, d), repeats)
        t_c = best_of(lambda env=env, a=a, d=d: env.unwrapped.compute_reward(a, d, None), repeats)
        row = {
            "env_id": env_id,
            "batch": batch,
            "goal_size": a.shape[1],
            "python_ms": 1e3 * t_py,
            "compiled_ms": 1e3 * t_c,
            "speedup": t_py / t_c,
            "identical": identical,
        }
        out.append(row)
        print(
            f"{env_id}: {batch} relabelled samples, sample by sample {row['python_ms']:.1f} ms, "
            f"compiled {row['compiled_ms']:.2f} ms ({row['speedup']:.1f}x), identical: {identical}"
        )
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--batch", type=int, default=256, help="samples per call (TQC's batch)")
    p.add_argument("--repeats", type=int, default=5)
    args = p.parse_args()
    warnings.filterwarnings("ignore", category=DeprecationWarning)
    print("wrote", write_csv("hindsight_rewards", rows(args.batch, args.repeats)))


if __name__ == "__main__":
    main()

"""Record (``--write``) or replay v0 episodes: the observations, rewards and final metrics of
fixed-seed, fixed-action episodes of every v0 environment, so that ``tests/test_envs_v0_pinned.py``
can check that v0 behaves exactly as when it was recorded.

    python tests/data/v0_episodes.py --write     # rewrite tests/data/v0_episodes.npz

Re-record only when the simulator's results change on purpose (and say so in the commit).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

PATH = Path(__file__).with_name("v0_episodes.npz")

#: (name, env id, make kwargs, reset seed, reset options, action seed, steps)
CASES: tuple[tuple[str, str, dict, int, dict, int, int], ...] = (
    ("coil_train", "bathprint/CoilRadius-v0", {}, 0, {}, 1, 80),
    (
        "coil_eval_needle",
        "bathprint/CoilRadius-v0",
        {"target_set": "eval", "needle_velocity": True},
        5,
        {"target_index": 3},
        2,
        40,
    ),
    ("shape_train", "bathprint/WriteShape-v0", {}, 1, {}, 3, 60),
    (
        "shape_eval_needle",
        "bathprint/WriteShape-v0",
        {"target_set": "eval", "needle_velocity": "xy"},
        2,
        {"target_index": 7},
        4,
        40,
    ),
    ("layers_train", "bathprint/BuoyantLayers-v0", {}, 3, {}, 5, 63),
    (
        "layers_eval",
        "bathprint/BuoyantLayers-v0",
        {"target_set": "eval"},
        4,
        {"target_index": 2},
        6,
        30,
    ),
)


def run_case(
    env_id: str, kwargs: dict, seed: int, options: dict, action_seed: int, steps: int
) -> dict[str, np.ndarray]:
    """Observations (steps + 1, obs_dim), rewards, metrics and the actions of one episode."""
    import bathprint.envs as E

    env = E.make(env_id, accuracy="draft", **kwargs)
    rng = np.random.default_rng(action_seed)
    obs, info = env.reset(seed=seed, options=options)
    observations, rewards, metrics, actions = [obs], [], [info["metric"]], []
    for _ in range(steps):
        a = rng.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        obs, r, term, trunc, info = env.step(a)
        observations.append(obs)
        rewards.append(r)
        metrics.append(info["metric"])
        actions.append(a)
        if term or trunc:
            break
    env.close()
    return {
        "obs": np.array(observations, np.float32),
        "reward": np.array(rewards, np.float64),
        "metric": np.array(metrics, np.float64),
        "action": np.array(actions, np.float32),
    }


def record() -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name, env_id, kwargs, seed, options, action_seed, steps in CASES:
        for key, value in run_case(env_id, kwargs, seed, options, action_seed, steps).items():
            out[f"{name}/{key}"] = value
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--write", action="store_true")
    args = ap.parse_args()
    data = record()
    if args.write:
        np.savez_compressed(PATH, **data)
        print(f"wrote {PATH}")
    else:
        ref = np.load(PATH)
        bad = [k for k in ref.files if not np.array_equal(ref[k], data[k])]
        print("identical" if not bad else f"differ: {bad}")

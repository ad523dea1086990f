"""Record (``--write VERSION``) or replay pinned episodes: the observations, rewards and final
metrics of fixed-seed, fixed-action episodes of every registered environment of a version,
so that ``tests/test_envs_pinned.py`` can check that each version behaves exactly as when it
was recorded (a registered version never changes its results; a change is a new version).

    python tests/data/pinned_episodes.py              # replay every version: identical?
    python tests/data/pinned_episodes.py --write v1   # rewrite tests/data/v1_episodes.npz

Re-record a version only when its results change on purpose (and say so in the commit).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

#: (name, env id, make kwargs, reset seed, reset options, action seed, steps)
Case = tuple[str, str, dict, int, dict, int, int]

V0: tuple[Case, ...] = (
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

V1: tuple[Case, ...] = (
    ("coil_train", "bathprint/CoilRadius-v1", {}, 0, {}, 1, 80),
    ("coil_test", "bathprint/CoilRadius-v1", {"target_set": "test"}, 5, {"target_index": 3}, 2, 40),
    ("shape_train", "bathprint/WriteShape-v1", {}, 1, {}, 3, 60),
    (
        "shape_validation",
        "bathprint/WriteShape-v1",
        {"target_set": "validation"},
        2,
        {"target_index": 7},
        4,
        40,
    ),
    ("layers_train", "bathprint/BuoyantLayers-v1", {}, 3, {}, 5, 63),
    (
        "layers_test",
        "bathprint/BuoyantLayers-v1",
        {"target_set": "test"},
        4,
        {"target_index": 2},
        6,
        30,
    ),
)

V2: tuple[Case, ...] = (
    ("shape_train", "bathprint/WriteShape-v2", {}, 1, {}, 3, 60),
    (
        "shape_test",
        "bathprint/WriteShape-v2",
        {"target_set": "test"},
        2,
        {"target_index": 7},
        4,
        40,
    ),
)

#: version -> (recording, cases)
VERSIONS: dict[str, tuple[Path, tuple[Case, ...]]] = {
    "v0": (Path(__file__).with_name("v0_episodes.npz"), V0),
    "v1": (Path(__file__).with_name("v1_episodes.npz"), V1),
    "v2": (Path(__file__).with_name("v2_episodes.npz"), V2),
}


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


def record(cases: tuple[Case, ...]) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for name, env_id, kwargs, seed, options, action_seed, steps in cases:
        for key, value in run_case(env_id, kwargs, seed, options, action_seed, steps).items():
            out[f"{name}/{key}"] = value
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--write", choices=sorted(VERSIONS), default=None,
                    help="re-record this version's episodes")  # fmt: skip
    args = ap.parse_args()
    for version, (path, cases) in VERSIONS.items():
        if args.write not in (None, version):
            continue
        data = record(cases)
        if args.write:
            np.savez_compressed(path, **data)
            print(f"wrote {path}")
        else:
            ref = np.load(path)
            bad = [k for k in ref.files if not np.array_equal(ref[k], data[k])]
            print(f"{version}: " + ("identical" if not bad else f"differ: {bad}"))

"""Every registered environment version behaves exactly as recorded
(``tests/data/v0_episodes.npz``, ``v1_episodes.npz``; ``tests/data/pinned_episodes.py``):
same seed and actions, same observations, rewards and metrics, bit for bit. A version's
results stay reproducible; a change of task or physics is a new version."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_spec = importlib.util.spec_from_file_location(
    "pinned_episodes", Path(__file__).with_name("data") / "pinned_episodes.py"
)
assert _spec is not None and _spec.loader is not None
pinned = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pinned)

CASES = [(version, case) for version, (_, cases) in pinned.VERSIONS.items() for case in cases]


@pytest.mark.parametrize(("version", "case"), CASES, ids=[f"{v}-{c[0]}" for v, c in CASES])
def test_episode_is_bit_identical_to_the_recording(version: str, case) -> None:
    name, env_id, kwargs, seed, options, action_seed, steps = case
    ref = np.load(pinned.VERSIONS[version][0])
    got = pinned.run_case(env_id, kwargs, seed, options, action_seed, steps)
    for key, value in got.items():
        expected = ref[f"{name}/{key}"]
        assert value.shape == expected.shape, (name, key)
        assert np.array_equal(value, expected), (name, key)

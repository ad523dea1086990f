"""The v0 environments behave exactly as recorded (``tests/data/v0_episodes.npz``): same seed
and actions, same observations, rewards and metrics, bit for bit. v0 results stay
reproducible; a change of task is a new version (v1)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_spec = importlib.util.spec_from_file_location(
    "v0_episodes", Path(__file__).with_name("data") / "v0_episodes.py"
)
assert _spec is not None and _spec.loader is not None
v0 = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(v0)


@pytest.mark.parametrize("case", v0.CASES, ids=[c[0] for c in v0.CASES])
def test_v0_episode_is_bit_identical_to_the_recording(case) -> None:
    name, env_id, kwargs, seed, options, action_seed, steps = case
    ref = np.load(v0.PATH)
    got = v0.run_case(env_id, kwargs, seed, options, action_seed, steps)
    for key, value in got.items():
        expected = ref[f"{name}/{key}"]
        assert value.shape == expected.shape, (name, key)
        assert np.array_equal(value, expected), (name, key)

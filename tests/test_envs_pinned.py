"""Every registered environment version behaves exactly as recorded
(``tests/data/v0_episodes.npz``, ``v1_episodes.npz``, ``v2_episodes.npz``;
``tests/data/pinned_episodes.py``): same seed and actions, same observations, rewards and
metrics, bit for bit; and every info dict, goal, goal reward, cloned state, rendered frame and
printed target hashes as recorded (``tests/data/pinned_infos.json``;
``tests/data/pinned_infos.py``). A version's results stay reproducible; a change of task or
physics is a new version."""

from __future__ import annotations

import importlib.util
import json
import warnings
from pathlib import Path

import numpy as np
import pytest


def _load(name: str):
    spec = importlib.util.spec_from_file_location(name, Path(__file__).with_name("data") / name)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


pinned = _load("pinned_episodes.py")
pinned_infos = _load("pinned_infos.py")

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


@pytest.mark.parametrize("name", list(pinned_infos.CASES))
def test_infos_and_methods_hash_as_recorded(name: str) -> None:
    ref = json.loads(pinned_infos.PATH.read_text())[name]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # older versions are pinned too
        got = pinned_infos.run(name)
    assert sorted(got) == sorted(ref)
    assert {k: v for k, v in got.items() if ref[k] != v} == {}

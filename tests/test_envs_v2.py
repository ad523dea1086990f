"""WriteShape-v2: version 1's task with the target's positions near the needle observed.

Its first 79 entries, its rewards and its metric are WriteShape-v1's, step for step; the
21 new ones are the target's centreline at the spec's arclength offsets, relative to the
needle; bad offsets are refused with the key named."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import bathprint.envs as E
from bathprint.envs.observation import OBS_CLIP, OBS_LENGTH_MM
from bathprint.envs.spec import SpecError

V2 = "bathprint/WriteShape-v2"
OFFSETS_MM = (-10.0, -5.0, 0.0, 5.0, 10.0, 15.0, 20.0)


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory, monkeypatch):
    """Printed training targets go to a temporary disk cache, not the user's."""
    monkeypatch.setenv("BATHPRINT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


def make(env_id: str, **kwargs):
    with warnings.catch_warnings():  # gymnasium calls v1 out of date beside v2
        warnings.simplefilter("ignore", DeprecationWarning)
        return E.make(env_id, accuracy="draft", **kwargs)


def test_v2_is_registered_with_version_1s_protocol() -> None:
    assert V2 in E.register_envs()
    assert E.resolve_id("writeshape-v2") == V2
    assert E.printed_targets(V2) and E.printed_targets("WriteShape-v1")
    assert not E.printed_targets("WriteShape-v0")
    env = make(V2)
    assert env.unwrapped.spec_data.version == 2
    assert env.observation_space.shape == (100,)
    assert env.unwrapped.obs_layout[-1] == ("target_positions", 3 * len(OFFSETS_MM))
    gym_check_env(env.unwrapped, skip_render_check=True)


def test_v2_is_v1_plus_the_target_positions_step_for_step() -> None:
    v1, v2 = make("WriteShape-v1", target_set="validation"), make(V2, target_set="validation")
    o1, _ = v1.reset(seed=0, options={"target_index": 2})
    o2, _ = v2.reset(seed=0, options={"target_index": 2})
    u = v2.unwrapped
    # the same target (the two environments ship the same sets, each under its own name)
    np.testing.assert_array_equal(u.target.points_mm, v1.unwrapped.target.points_mm)
    np.testing.assert_array_equal(u.target.actions, v1.unwrapped.target.actions)
    rng = np.random.default_rng(0)
    checked = 0
    for _ in range(200):
        np.testing.assert_array_equal(o2[:79], o1)
        # the positions, computed here from the target and the needle
        s = (u._printed_mm - u.lead_in_mm + np.array(OFFSETS_MM)) / u.target.spacing_mm
        k = np.clip(np.rint(s), 0, u.target.n_samples - 1).astype(int)
        want = (u.target.points_mm[k] - u._needle_mm) / OBS_LENGTH_MM
        np.testing.assert_allclose(o2[79:], np.clip(want.ravel(), -OBS_CLIP, OBS_CLIP), atol=1e-6)
        checked += 1
        a = rng.uniform(-1, 1, 3).astype(np.float32)
        o1, r1, te1, tr1, i1 = v1.step(a)
        o2, r2, te2, tr2, i2 = v2.step(a)
        assert (r1, te1, tr1) == (r2, te2, tr2)
        if te1 or tr1:
            break
    assert te1 and checked > 50
    assert i1["metric"] == pytest.approx(i2["metric"], rel=1e-12)
    # the positions move: the needle and the sample it extrudes do
    assert np.ptp(np.asarray(o2[79:])) > 0.1


def test_the_goal_form_has_version_1s_observation() -> None:
    g1 = make("WriteShape-v1", goal_conditioned=True).observation_space
    g2 = make(V2, goal_conditioned=True).observation_space
    assert g2["observation"].shape == g1["observation"].shape
    assert g2["desired_goal"].shape == g1["desired_goal"].shape


@pytest.mark.parametrize(
    "value", [[], "near", [0.0, float("nan")], [True], [2000.0], list(range(33))]
)
def test_bad_target_offsets_are_refused_with_the_key_named(value) -> None:
    with pytest.raises(SpecError, match="observation.target_positions_mm"):
        make(V2, spec_overrides={"observation": {"target_positions_mm": value}})

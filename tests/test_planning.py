"""The planners (bathprint.agents.planning): the CEM oracle and its cache, MPC, the
normalised score, and their use through ``bathprint evaluate``."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

import bathprint.envs as E
from bathprint.agents import planning
from bathprint.agents.evaluate import evaluate_many
from bathprint.errors import ConfigError

ENV = "bathprint/CoilRadius-v1"


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("BATHPRINT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


def make(env_id: str = ENV, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return E.make(env_id, accuracy="draft", **kwargs)


def test_cem_minimises_a_quadratic_and_keeps_the_incumbent() -> None:
    goal = np.array([[0.3, -0.2], [0.5, 0.1]])

    def f(x):
        return float(np.sum((x - goal) ** 2))

    s = planning.CEMSettings(samples=16, iterations=15, elites=4, init_std=0.5)
    best, val, hist = planning.cem(f, np.zeros((2, 2)), s)
    assert val < 1e-2 and np.all(np.diff(hist) <= 0)
    # an incumbent better than anything sampled stays: no candidate is returned
    best, val, _ = planning.cem(f, np.zeros((2, 2)), s, incumbents=[(-1.0, None)])
    assert best is None and val == -1.0


def test_blocks_expand_and_average_back() -> None:
    blocks = np.array([[0.1], [0.5], [-0.3]])
    steps = planning.expand(blocks, 10, 4)
    assert steps.shape == (10, 1) and steps[3, 0] == 0.1 and steps[4, 0] == 0.5
    np.testing.assert_allclose(planning.block_means(steps, 4), blocks)


def test_the_oracle_improves_on_the_constant_policy_on_a_cheap_target(tmp_path) -> None:
    env = make(target_set="validation")
    settings = planning.CEMSettings(samples=6, iterations=3, elites=2)
    rec = planning.optimise_target(env, ENV, 0, {"target_index": 0}, settings)
    assert rec["metric_cem"] < rec["metric_constant"]
    assert rec["metric_cem"] <= min(rec["metric_constant"], rec["metric_feedforward"])
    assert rec["rollouts"] == 2 + 6 * 3
    # the target is printed: replaying its controls reaches it, so the oracle's metric is ~0
    assert rec["metric"] == min(rec["metric_cem"], rec["metric_replay"]) < 1e-4
    # the stored action sequence reproduces the oracle's metric
    out = planning.rollout(env, np.array(rec["actions"], np.float32), 0, {"target_index": 0})
    assert math.isclose(out["metric"], rec["metric"], rel_tol=1e-9, abs_tol=1e-12)


def test_the_oracle_cache_is_written_per_target_and_resumed(tmp_path) -> None:
    s = planning.CEMSettings(samples=2, iterations=1, elites=1)
    data = planning.run_oracle(
        ENV, "validation", "draft", s, [0], directory=tmp_path, progress=False
    )
    path = planning.oracle_path(ENV, "draft", tmp_path)
    assert path.is_file() and len(data["targets"]) == 1
    stamp = path.stat().st_mtime_ns
    planning.run_oracle(ENV, "validation", "draft", s, [0], directory=tmp_path, progress=False)
    assert path.stat().st_mtime_ns == stamp  # nothing recomputed
    data = planning.run_oracle(
        ENV, "validation", "draft", s, [0, 1], directory=tmp_path, progress=False
    )
    assert len(data["targets"]) == 2
    rec = next(iter(json.loads(path.read_text())["targets"].values()))
    assert {"metric", "metric_constant", "actions", "cpu_s", "data"} <= set(rec)


def test_normalised_score_is_zero_for_the_constant_and_one_for_the_oracle(tmp_path) -> None:
    data = {
        "targets": {
            "a": {"metric_constant": 0.4, "metric": 0.1},
            "b": {"metric_constant": 0.2, "metric": 0.0},
        }
    }
    planning._save_oracle(planning.oracle_path(ENV, "draft", tmp_path), data)
    score = planning.normalised_score
    assert score({"a": 0.4, "b": 0.2}, ENV, "draft", tmp_path)["normalised_score"] == 0.0
    assert score({"a": 0.1, "b": 0.0}, ENV, "draft", tmp_path)["normalised_score"] == 1.0
    half = score({"a": 0.25, "b": 0.1, "c": 9.0}, ENV, "draft", tmp_path)
    assert math.isclose(half["normalised_score"], 0.5) and half["normalised_episodes"] == 2
    assert math.isnan(score({"c": 1.0}, ENV, "draft", tmp_path)["normalised_score"])


def test_mpc_branches_from_the_current_state_and_beats_the_constant() -> None:
    env = make(target_set="validation", target_index=1)
    settings = planning.MPCSettings(horizon_mm=24, replan_mm=8, samples=6, iterations=2, elites=2)
    mpc = planning.MPCPolicy(env, ENV, settings)
    obs, _ = env.reset(seed=0)
    done = False
    while not done:
        a, _ = mpc.predict(obs)
        obs, _, term, trunc, info = env.step(a)
        done = term or trunc
    assert mpc.plans >= env.unwrapped.episode_steps // 8
    from bathprint.agents.policies import load_policy

    const = load_policy("constant", env, ENV)[0]
    m_const, _ = planning.policy_actions(env, const, 0, {})
    assert info["metric"] < m_const


def test_planner_options_are_checked() -> None:
    assert planning.parse_options("mpc:samples=8,horizon_mm=30", planning.MPCSettings).samples == 8
    with pytest.raises(ConfigError, match="samplez"):
        planning.parse_options("mpc:samplez=8", planning.MPCSettings)
    with pytest.raises(ConfigError, match="elites = 9"):
        planning.CEMSettings(samples=4, elites=9)
    with pytest.raises(ConfigError, match="version-1"):
        evaluate_many(["mpc"], "bathprint/CoilRadius-v0", episodes=1, progress=False)


def test_evaluate_reports_success_and_the_normalised_score(tmp_path, monkeypatch) -> None:
    from bathprint.agents.evaluate import evaluate_policy_spec

    s = planning.CEMSettings(samples=2, iterations=1, elites=1)
    planning.run_oracle(ENV, "test", "draft", s, [0, 1], directory=tmp_path, progress=False)
    monkeypatch.setattr(planning, "oracle_dir", lambda: tmp_path)
    _, summary, eps = evaluate_policy_spec("constant", ENV, episodes=2, progress=False)
    _, osum, _ = evaluate_policy_spec("oracle", ENV, episodes=2, progress=False)
    assert summary["target_set"] == "test"
    assert math.isclose(summary["normalised_score"], 0.0, abs_tol=1e-9)
    assert math.isclose(osum["normalised_score"], 1.0, abs_tol=1e-9)
    assert osum["success_rate"] == 1.0  # the oracle replays the printing controls: M ~ 0
    assert 0.0 <= summary["success_rate"] <= 1.0 and "is_success" in eps[0].metrics

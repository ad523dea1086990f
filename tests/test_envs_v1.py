"""The version-1 environments: checkers in both observation forms, goal rewards, target sets,
scoring, reachability by construction, actions, observation, success, state cloning."""

from __future__ import annotations

import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import bathprint.envs as E
from bathprint.envs.printed import TEST_SEED0, VALIDATION_SEED0
from bathprint.errors import ConfigError, SimulationError

V1 = ("bathprint/CoilRadius-v1", "bathprint/WriteShape-v1", "bathprint/BuoyantLayers-v1")
DRAFT = {"accuracy": "draft"}


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory, monkeypatch):
    """Printed training targets go to a temporary disk cache, not the user's."""
    monkeypatch.setenv("BATHPRINT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


def make(env_id: str, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return E.make(env_id, **{**DRAFT, **kwargs})


def episode(env, actions=None, seed=0, options=None):
    """Run to the end (``actions``: a sequence, or None for the target's own); returns the
    rewards, the last info and the observations."""
    obs, info = env.reset(seed=seed, options=options)
    u = env.unwrapped
    if actions is None:
        actions = u.actions_for(u.target)
    rewards, observations = [], [obs]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        rewards.append(r)
        observations.append(obs)
        if term or trunc:
            break
    return rewards, info, observations


# ------------------------------------------------------------------ registration, checkers
def test_v1_ids_are_registered_beside_v0() -> None:
    ids = E.register_envs()
    for env_id in V1:
        assert env_id in ids and env_id in gymnasium.registry
        assert env_id.replace("-v1", "-v0") in ids
    assert E.resolve_id("coilradius-v1") == "bathprint/CoilRadius-v1"
    assert E.resolve_id("CoilRadius") == "bathprint/CoilRadius-v2"  # a bare name: the newest


@pytest.mark.parametrize("goal", [False, True], ids=["flat", "goal"])
@pytest.mark.parametrize("env_id", V1)
def test_gymnasium_and_sb3_checkers_pass(env_id: str, goal: bool) -> None:
    env = make(env_id, goal_conditioned=goal)
    gym_check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(make(env_id, goal_conditioned=goal).unwrapped, warn=False)
    if goal:
        assert set(env.observation_space.spaces) == {"observation", "achieved_goal", "desired_goal"}


# ------------------------------------------------------------------ rewards
@pytest.mark.parametrize("env_id", V1)
def test_compute_reward_agrees_with_the_step_reward(env_id: str) -> None:
    env = make(env_id, goal_conditioned=True)
    rng = np.random.default_rng(3)
    obs, _ = env.reset(seed=2)
    achieved, desired, rewards = [], [], []
    done = False
    while not done:
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        assert env.unwrapped.compute_reward(obs["achieved_goal"], obs["desired_goal"], info) == r
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        rewards.append(r)
        done = term or trunc
    batch = env.unwrapped.compute_reward(np.array(achieved), np.array(desired), [{}] * len(desired))
    assert batch.shape == (len(rewards),)
    np.testing.assert_array_equal(batch, rewards)
    # relabelled with the final achieved goal (HER's 'final'): printing exactly what was
    # printed has return 0 (the rewards telescope; recorded samples never change)
    final = np.array([achieved[-1]] * len(achieved))
    relabel = env.unwrapped.compute_reward(np.array(achieved), final, None)
    assert np.all(np.isfinite(relabel)) and abs(relabel.sum()) < 1e-12
    assert any(r != 0 for r in rewards)


@pytest.mark.parametrize("env_id", V1)
def test_the_compiled_batch_of_hindsight_rewards_is_the_sample_by_sample_one(env_id: str) -> None:
    """HER's relabelled batches (achieved goals of one episode against desired goals of
    another target, in random pairs) score bit for bit as one sample at a time does."""
    env = make(env_id, goal_conditioned=True)
    rng = np.random.default_rng(5)
    achieved, desired = [], []
    for seed in (1, 2):
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            obs, _, term, trunc, _ = env.step(rng.uniform(-1, 1, env.action_space.shape))
            achieved.append(obs["achieved_goal"])
            desired.append(obs["desired_goal"])
            done = term or trunc
    ag, dg = np.array(achieved), np.array(desired)
    i, j = rng.integers(0, len(ag), 64), rng.integers(0, len(ag), 64)
    batch = env.unwrapped.compute_reward(ag[i], dg[j], None)
    reference = env.unwrapped._goal_reward_one_by_one(ag[i], dg[j])
    np.testing.assert_array_equal(batch, reference)  # the same operations, bit for bit
    assert np.count_nonzero(reference) > 10


@pytest.mark.parametrize("env_id", V1)
def test_return_is_minus_the_final_squared_error(env_id: str) -> None:
    env = make(env_id)
    rng = np.random.default_rng(0)
    acts = rng.uniform(-1, 1, (200, env.action_space.shape[0])).astype(np.float32)
    rewards, info, _ = episode(env, acts, seed=1)
    assert info["scored_fraction"] == 1.0
    assert math.isclose(sum(rewards), -(info["metric"] ** 2), rel_tol=1e-9, abs_tol=1e-12)
    assert math.isclose(info["scored_squared_error"], info["metric"] ** 2, rel_tol=1e-9)
    # no constant progress term: the first rewards (nothing scored yet) are exactly 0
    assert rewards[0] == 0.0


def test_a_diverged_episode_returns_minus_the_squared_error_with_missing_samples(monkeypatch):
    env = make("bathprint/CoilRadius-v1")
    env.reset(seed=0)
    u = env.unwrapped
    total = 0.0
    for _ in range(40):
        total += env.step(np.zeros(1, np.float32))[1]

    def boom(*args, **kwargs):
        raise SimulationError("forced", 0.0, 3)

    monkeypatch.setattr(u.sim, "advance", boom)
    _, r, term, trunc, info = env.step(np.zeros(1, np.float32))
    assert trunc and not term and "forced" in info["sim_error"]
    # the samples never scored count missing_error: the return is -M^2 of the diverged print
    assert math.isclose(total + r, -(info["metric"] ** 2), rel_tol=1e-9)
    assert info["metric"] > info["shape_rms_mm"] / 3  # the missing samples are in M
    assert info["is_success"] is False


# ------------------------------------------------------------------ target sets
@pytest.mark.parametrize("env_id", V1)
def test_the_three_target_sets_are_fixed_and_disjoint_by_key(env_id: str) -> None:
    env = make(env_id, target_set="test")
    fam = env.unwrapped.printed
    assert fam.uses_sets_file()  # the shipped file matches the spec
    keys = {}
    for name in ("validation", "test"):
        keys[name] = [
            make(env_id, target_set=name).unwrapped.fixed_set_target(name, k).key
            for k in range(fam.sizes[name])
        ]
        assert len(set(keys[name])) == fam.sizes[name]
    # the whole training pool's keys, from the parameters (start state drawn, first attempt)
    train = {E.targets.params_key(fam.draw(s)[0]) for s in range(fam.train_pool)}
    assert len(train) == fam.train_pool
    assert not train & set(keys["validation"]) and not train & set(keys["test"])
    assert not set(keys["validation"]) & set(keys["test"])
    # training draws come from the pool; the fixed sets by index, the same each time
    _, info = make(env_id).reset(seed=5)
    assert info["target_key"] in train and info["target_set"] == "train"
    _, info = make(env_id, target_set="test", target_index=3).reset(seed=0)
    assert info["target_key"] == keys["test"][3]
    assert fam.seeds("test")[0] == TEST_SEED0 and fam.seeds("validation")[0] == VALIDATION_SEED0


def test_target_set_arguments_are_refused_with_the_argument_named() -> None:
    env_id = "bathprint/CoilRadius-v1"
    cases = [
        ({"target_set": "eval"}, "target_set = 'eval'"),
        ({"target_set": "held-out"}, "'train', 'validation', 'test'"),
        ({"target_index": 2}, "target_set='validation' or 'test'"),
        ({"target_set": "test", "target_index": 16}, "allowed 0..15"),
        ({"target_set": "test", "target_index": 1.5}, "target_index = 1.5"),
        ({"goal_conditioned": "yes"}, "goal_conditioned = 'yes'"),
        ({"needle_velocity": "z"}, "needle_velocity = 'z'"),
        ({"accuracy": "rough"}, "accuracy = 'rough'"),
        ({"scene_overrides": {"bath.viscosity_pa_s": -1.0}}, "scene_overrides = {"),
        ({"scene_overrides": [("bath.viscosity_pa_s", 1.0)]}, "scene_overrides = [("),
        ({"target_file": "/nonexistent.csv"}, "target_file = '/nonexistent.csv'"),
        ({"spec_file": 5}, "spec_file = 5"),
        ({"needle_velocity": np.array([1, 0])}, "needle_velocity = array"),
        ({"spec_overrides": {"target": {"eval_size": 4}}}, "target.eval_size"),
        ({"spec_overrides": {"control": {"q_outer_scale": "cubic"}}}, "q_outer_scale"),
        (
            {"spec_overrides": {"target": {"params": {"q_outer": {"kind": "walk"}}}}},
            "target.params.q_outer",
        ),
    ]
    for kwargs, needle in cases:
        with pytest.raises(ConfigError, match=None) as exc:
            make(env_id, **kwargs)
        assert needle in str(exc.value), (kwargs, str(exc.value))
    with pytest.raises(ConfigError, match="version-1"):
        make("bathprint/CoilRadius-v0", spec_overrides={"episode": {"lead_in_mm": 2.0}})


# ------------------------------------------------------------------ scoring
@pytest.mark.parametrize("accuracy", ["draft", "balanced", "fine"])
def test_no_sample_is_scored_from_material_printed_before_the_first_action(accuracy) -> None:
    env = make("bathprint/CoilRadius-v1", accuracy=accuracy, target_set="test", target_index=0)
    env.reset(seed=0)
    u = env.unwrapped
    u0 = u._u0_mm
    for _ in range(u.steps_for_length(0.0) + 4):  # until a few samples are scored
        env.step(np.zeros(1, np.float32))
    assert u._n_scored > 0
    s = np.concatenate([[0.0], np.cumsum(u.sim.rest_lengths())]) / 1e-3  # segment ends, mm
    first = u._origin_mm  # material coordinate of sample 0
    k = np.searchsorted(s, first, side="right") - 1  # the segment holding it
    assert s[k] >= u0 - 1e-9, (s[k], u0)


def test_densities_scored_are_those_of_the_first_actions_flow() -> None:
    # without the lag, a constant inner fraction from the first action: every scored sample
    # has exactly the composite's density (version 0 mixes warm-up gel into sample 0)
    env = make("bathprint/BuoyantLayers-v1", spec_overrides={"control": {"inner_lag_s": 0.0}})
    a = np.array([0.0, 0.0], np.float32)  # phi = 0.16
    _, info, _ = episode(env, [a] * 200, seed=0)
    u = env.unwrapped
    _, rho = u.recorded_samples()
    phi = 0.16
    expected = (1 - phi) * u.rho_gel + phi * u.sim.model.p.inner_density
    np.testing.assert_allclose(rho, expected, rtol=0, atol=1e-9)


@pytest.mark.parametrize("env_id", V1)
def test_a_printed_target_replayed_with_its_own_controls_scores_near_zero(env_id) -> None:
    env = make(env_id, target_set="validation")
    for k in (0, 1):
        rewards, info, _ = episode(env, options={"target_index": k})
        assert info["metric"] < 1e-3, (k, info["metric"])
        assert info["is_success"] is True
        assert abs(sum(rewards)) < 1e-6
    # the same controls on another target score clearly worse
    other = env.unwrapped.fixed_set_target("validation", 1)
    rewards, info, _ = episode(env, env.unwrapped.actions_for(other), options={"target_index": 0})
    assert info["metric"] > 0.02


def test_recorded_samples_match_the_final_filament_closely() -> None:
    env = make("bathprint/CoilRadius-v1", target_set="test", target_index=2)
    _, info, _ = episode(env, [np.zeros(1, np.float32)] * 100)
    # the metric of the filament as it is at the end, v0's way, is close to the recorded one
    assert abs(info["metric_final_shape"] - info["metric"]) < 0.05


# ------------------------------------------------------------------ actions, observation
def test_actions_are_the_log_flow_and_the_inner_fraction() -> None:
    u = make("bathprint/BuoyantLayers-v1").unwrapped
    lo, hi = u.q_outer_range
    for a0, q in ((-1.0, lo), (1.0, hi), (0.0, math.sqrt(lo * hi))):
        c = u.action_to_controls(np.array([a0, -1.0], np.float32))
        assert math.isclose(c["q_outer_ml_min"], q, rel_tol=1e-12)
        assert c["q_inner_ml_min"] == 0.0
    c = u.action_to_controls(np.array([0.3, 0.5], np.float32))
    p_lo, p_hi = u.inner_fraction_range
    assert math.isclose(c["inner_fraction"], p_lo + 0.75 * (p_hi - p_lo), rel_tol=1e-9)
    back = u.controls_to_action(c["q_outer_ml_min"], c["q_inner_ml_min"])
    np.testing.assert_allclose(back, [0.3, 0.5], atol=1e-6)
    # equal action steps are equal ratios of flow
    qs = [u.action_to_controls(np.array([a, -1.0]))["q_outer_ml_min"] for a in (-0.5, 0.0, 0.5)]
    assert math.isclose(qs[1] / qs[0], qs[2] / qs[1], rel_tol=1e-12)
    with pytest.raises(ValueError, match="NaN"):
        u.action_to_controls(np.array([np.nan, 0.0]))


def test_the_oil_flow_follows_its_command_with_the_lag() -> None:
    env = make("bathprint/BuoyantLayers-v1")
    env.reset(seed=0)
    u = env.unwrapped
    tau = u.inner_lag_s
    a = np.array([0.0, 1.0], np.float32)
    q_cmd = u.action_to_controls(a)["q_inner_ml_min"]
    q, t = 0.0, u.sim.t
    for _ in range(10):
        env.step(a)
        dt = u.sim.t - t
        t = u.sim.t
        q = q_cmd + (q - q_cmd) * math.exp(-dt / tau)
        assert math.isclose(u._inner_now_ml_min, q, rel_tol=1e-9)
    assert 0.2 * q_cmd < q < q_cmd  # well under way, not there yet
    sl = u.obs_slices()["inner_fraction_now"]
    phi = q / (u._controls["q_outer_ml_min"] + q)
    p_lo, p_hi = u.inner_fraction_range
    assert math.isclose(
        float(u._last_obs[sl][0]), 2 * (phi - p_lo) / (p_hi - p_lo) - 1, rel_tol=1e-6
    )


def test_the_observation_shows_both_bounds_of_the_density_band() -> None:
    env = make("bathprint/BuoyantLayers-v1", target_set="test", target_index=4)
    obs, _ = env.reset(seed=0)
    u = env.unwrapped
    for _ in range(30):
        obs, *_ = env.step(np.zeros(2, np.float32))
    ahead = u.target_ahead(obs, 10.0)
    j = int(round((u._printed_mm - u.lead_in_mm + 10.0) / u.target.spacing_mm))
    assert math.isclose(ahead["density_lo_kg_m3"], u.target.density_lo_kg_m3[j], abs_tol=1e-4)
    assert math.isclose(ahead["density_hi_kg_m3"], u.target.density_hi_kg_m3[j], abs_tol=1e-4)


@pytest.mark.parametrize("env_id", V1)
def test_no_observation_entry_is_constant(env_id: str) -> None:
    env = make(env_id)
    rng = np.random.default_rng(1)
    seen = []
    for seed in (0, 1):
        _, _, observations = episode(
            env, rng.uniform(-1, 1, (200, env.action_space.shape[0])), seed=seed
        )
        seen += observations
    spread = np.ptp(np.array(seen), axis=0)
    names = [name for name, n in env.unwrapped.obs_layout for _ in range(n)]
    constant = [names[i] for i in np.nonzero(spread == 0)[0]]
    assert not constant, constant


def test_writeshape_moves_the_needle_by_default() -> None:
    env = make("bathprint/WriteShape-v1")
    u = env.unwrapped
    assert u.action_names == ["q_outer", "needle_vx", "needle_vy"]
    assert make("bathprint/WriteShape-v1", needle_velocity="xyz").action_space.shape == (4,)
    env.reset(seed=0)
    for _ in range(10):
        _, _, _, _, info = env.step(np.array([-1.0, 1.0, 0.0], np.float32))
    assert info["needle_mm"][0] > u.needle_start_mm[0] + 1.0


# ------------------------------------------------------------------ success, state
def test_success_is_reported_at_the_end_with_the_spec_threshold() -> None:
    env = make("bathprint/CoilRadius-v1", target_set="validation", target_index=0)
    obs, info = env.reset(seed=0)
    assert info["is_success"] is False
    u = env.unwrapped
    assert u.success_metric_max == pytest.approx(0.1)
    for a in [np.ones(1, np.float32)] * 200:  # the largest flow: the smallest coils
        obs, r, term, trunc, info = env.step(a)
        if term:
            break
        assert info["is_success"] is False
    assert info["is_success"] == (info["metric"] <= u.success_metric_max)


def test_a_cloned_state_continues_identically_in_another_instance() -> None:
    env_id = "bathprint/WriteShape-v1"
    a_env, b_env = make(env_id).unwrapped, make(env_id).unwrapped
    rng = np.random.default_rng(4)
    acts = rng.uniform(-1, 1, (60, 3)).astype(np.float32)
    a_env.reset(seed=3)
    for a in acts[:25]:
        a_env.step(a)
    state = a_env.get_state()
    b_env.reset(seed=99)
    b_env.set_state(state)
    for a in acts[25:]:
        ra = a_env.step(a)
        rb = b_env.step(a)
        np.testing.assert_array_equal(ra[0], rb[0])
        assert ra[1] == rb[1]


def test_hindsight_experience_replay_trains_on_the_goal_form() -> None:
    from stable_baselines3 import SAC, HerReplayBuffer

    env = make("bathprint/BuoyantLayers-v1", goal_conditioned=True)
    model = SAC(
        "MultiInputPolicy",
        env,
        replay_buffer_class=HerReplayBuffer,
        replay_buffer_kwargs={"n_sampled_goal": 2, "goal_selection_strategy": "future"},
        learning_starts=70,
        batch_size=16,
        policy_kwargs={"net_arch": [16]},
        seed=0,
        device="cpu",
    )
    model.learn(80)  # relabelled batches go through compute_reward
    assert model.replay_buffer.size() == 80

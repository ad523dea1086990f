"""Robustness options of the version-1 environments (bathprint.envs.robust): off is the bare
environment, draws follow the seed, each option changes what it names, bad values are refused,
and the agents' wrapper machinery selects and replays the wrapper."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest

import bathprint.envs as E
from bathprint.core.layout import MAT_YOUNGS_MODULUS
from bathprint.envs.robust import _SEED_TAG, Robustness, RobustnessWrapper, apply_physics
from bathprint.errors import ConfigError

V1 = (
    "bathprint/CoilRadius-v1",
    "bathprint/WriteShape-v1",
    "bathprint/WriteShape-v2",
    "bathprint/BuoyantLayers-v1",
    "bathprint/WriteShape-v3",
    "bathprint/CoilRadius-v2",
    "bathprint/BuoyantLayers-v2",
)
COIL, BUOYANT = "bathprint/CoilRadius-v1", "bathprint/BuoyantLayers-v1"
STEPS = 6


@pytest.fixture(autouse=True)
def _private_cache(tmp_path_factory, monkeypatch):
    """Printed training targets go to a temporary disk cache, not the user's."""
    monkeypatch.setenv("BATHPRINT_CACHE_DIR", str(tmp_path_factory.getbasetemp() / "cache"))


def make(env_id: str, **kwargs):
    """A draft environment on a shipped validation target (nothing to print)."""
    kw = {"accuracy": "draft", "target_set": "validation", "target_index": 0, **kwargs}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        return E.make(env_id, **kw)


def actions(env, n: int = STEPS, seed: int = 1) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    return [rng.uniform(-0.8, 0.8, env.action_space.shape).astype(np.float32) for _ in range(n)]


def rollout(env, seed: int, acts) -> tuple[list, list, list]:
    """(observations, rewards, infos) of a reset and the actions."""
    obs, info = env.reset(seed=seed)
    observations, rewards, infos = [obs], [], [info]
    for a in acts:
        obs, r, _, _, info = env.step(a)
        observations.append(obs)
        rewards.append(r)
        infos.append(info)
    return observations, rewards, infos


def flat(obs):
    return obs["observation"] if isinstance(obs, dict) else obs


# ------------------------------------------------------------------ off by default
@pytest.mark.parametrize("env_id", V1)
def test_off_by_default_is_the_bare_environment_bit_for_bit(env_id: str) -> None:
    bare, wrapped = make(env_id), RobustnessWrapper(make(env_id))
    assert not wrapped.robustness.enabled and wrapped.robustness == Robustness()
    acts = actions(bare)
    obs_b, rew_b, _ = rollout(bare, 3, acts)
    obs_w, rew_w, infos = rollout(wrapped, 3, acts)
    for a, b in zip(obs_b, obs_w, strict=True):
        np.testing.assert_array_equal(a, b)
        assert a.dtype == b.dtype
    assert rew_b == rew_w
    assert all(info["robustness"] == {} for info in infos)
    np.testing.assert_array_equal(
        bare.unwrapped.sim.centerline(), wrapped.unwrapped.sim.centerline()
    )


def test_off_by_default_goal_conditioned_too() -> None:
    bare, wrapped = (
        make(COIL, goal_conditioned=True),
        RobustnessWrapper(make(COIL, goal_conditioned=True)),
    )
    acts = actions(bare)
    for a, b in zip(rollout(bare, 0, acts)[0], rollout(wrapped, 0, acts)[0], strict=True):
        for key in a:
            np.testing.assert_array_equal(a[key], b[key])


# ------------------------------------------------------------------ determinism
ALL_ON = {
    "bath_viscosity_spread": 0.5,
    "gel_modulus_spread": 0.5,
    "pump_lag_s": (0.05, 0.3),
    "flow_noise": 0.1,
    "observation_noise": 0.05,
}


def test_same_seed_same_draws_and_episode_other_seed_other_draws() -> None:
    acts = actions(make(BUOYANT))
    runs = [rollout(RobustnessWrapper(make(BUOYANT), **ALL_ON), seed, acts) for seed in (7, 7, 8)]
    (obs_a, rew_a, inf_a), (obs_b, rew_b, inf_b), (obs_c, _, inf_c) = runs
    assert inf_a[0]["robustness"] == inf_b[0]["robustness"]
    assert set(inf_a[0]["robustness"]) >= {
        "bath_viscosity_pa_s",
        "gel_modulus_factor",
        "gel_initial_modulus_pa",
        "gel_final_modulus_pa",
        "pump_lag_s",
    }
    for a, b in zip(obs_a, obs_b, strict=True):
        np.testing.assert_array_equal(a, b)
    assert rew_a == rew_b
    assert [i["robustness"] for i in inf_a] == [i["robustness"] for i in inf_b]
    for key in ("bath_viscosity_pa_s", "gel_modulus_factor", "pump_lag_s"):
        assert inf_c[0]["robustness"][key] != inf_a[0]["robustness"][key], key
    assert not np.array_equal(obs_c[0], obs_a[0])  # other observation noise


@pytest.mark.parametrize("goal", [False, True], ids=["flat", "goal"])
def test_checkers_pass_with_every_option_on(goal: bool) -> None:
    import gymnasium
    from gymnasium.utils.env_checker import check_env as gym_check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    env = RobustnessWrapper(make(BUOYANT, goal_conditioned=goal), **ALL_ON)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(env.action_space.sample())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # "different from the unwrapped version"
        gym_check_env(env, skip_render_check=True)  # (which remakes it from env.spec)
        sb3_check_env(env, warn=False)  # with goals: the wrapper's compute_reward
    assert gymnasium.make(env.spec).robustness == env.robustness


def test_unseeded_resets_continue_the_seeded_stream() -> None:
    envs = [RobustnessWrapper(make(COIL), bath_viscosity_spread=1.0) for _ in range(2)]
    draws = []
    for env in envs:
        env.reset(seed=11)
        draws.append([env.reset()[1]["robustness"]["bath_viscosity_pa_s"] for _ in range(3)])
    assert draws[0] == draws[1] and len(set(draws[0])) == 3


def test_an_option_switched_on_leaves_the_others_draws_alone() -> None:
    one = RobustnessWrapper(make(COIL), bath_viscosity_spread=0.3)
    more = RobustnessWrapper(
        make(COIL), bath_viscosity_spread=0.3, gel_modulus_spread=0.3, observation_noise=0.1
    )
    assert (
        one.reset(seed=5)[1]["robustness"]["bath_viscosity_pa_s"]
        == more.reset(seed=5)[1]["robustness"]["bath_viscosity_pa_s"]
    )


# ------------------------------------------------------------------ each option's physics
def _positions_after(env, n: int = 8) -> np.ndarray:
    for a in actions(env, n):
        env.step(a)
    return env.unwrapped.sim.centerline()


def test_bath_viscosity_sets_the_drag_and_changes_the_print() -> None:
    bare, env = make(COIL), make(COIL)
    bare.reset(seed=0)
    env.reset(seed=0)
    p0, p = bare.unwrapped.sim.model.p, env.unwrapped.sim.model.p
    out = apply_physics(env, bath_viscosity_factor=2.0)
    assert p.bath_viscosity == 2.0 * p0.bath_viscosity == out["bath_viscosity_pa_s"]
    assert p.mu_s == pytest.approx(2.0 * p0.mu_s, rel=1e-12)  # Cox's mu_s, derived again
    assert env.unwrapped.sim.scene.bath.viscosity_pa_s == p.bath_viscosity
    x0, x = _positions_after(bare), _positions_after(env)
    assert x.shape != x0.shape or not np.allclose(x, x0, atol=1e-5)


def test_drawn_viscosity_lies_in_its_log_uniform_range() -> None:
    bare, env = make(COIL), RobustnessWrapper(make(COIL), bath_viscosity_spread=0.5)
    bare.reset(seed=0)
    mu0 = float(bare.unwrapped.sim.model.p.bath_viscosity)
    for seed in range(4):
        info = env.reset(seed=seed)[1]["robustness"]
        assert mu0 / 1.5 <= info["bath_viscosity_pa_s"] <= mu0 * 1.5
        assert env.unwrapped.sim.model.p.bath_viscosity == info["bath_viscosity_pa_s"]


def test_gel_modulus_scales_the_law_and_the_printed_material_and_changes_the_print() -> None:
    bare, env = make(COIL), make(COIL)
    bare.reset(seed=0)
    env.reset(seed=0)
    p0, p = bare.unwrapped.sim.model.p, env.unwrapped.sim.model.p
    out = apply_physics(env, gel_modulus_factor=2.0)
    assert p.gel_initial_modulus == 2.0 * p0.gel_initial_modulus == out["gel_initial_modulus_pa"]
    assert p.gel_final_modulus == 2.0 * p0.gel_final_modulus == out["gel_final_modulus_pa"]
    e0 = bare.unwrapped.sim.material()[:, MAT_YOUNGS_MODULUS]
    np.testing.assert_array_equal(env.unwrapped.sim.material()[:, MAT_YOUNGS_MODULUS], 2.0 * e0)
    x0, x = _positions_after(bare), _positions_after(env)
    assert x.shape != x0.shape or not np.allclose(x, x0, atol=1e-5)


def test_gel_modulus_scales_the_exit_modulus_without_gelation() -> None:
    over = {"effects": ["elasticity", "drag", "gravity"]}
    env = make(COIL, scene_overrides=over)
    env.reset(seed=0)
    e_exit = float(env.unwrapped.sim.model.p.exit_youngs_modulus)
    out = apply_physics(env, gel_modulus_factor=0.5)
    assert out["youngs_modulus_pa"] == env.unwrapped.sim.model.p.exit_youngs_modulus == 0.5 * e_exit
    env.step(np.zeros(1, np.float32))  # new material has the episode's modulus
    assert env.unwrapped.sim.material()[-1, MAT_YOUNGS_MODULUS] == 0.5 * e_exit


def test_pump_lag_changes_the_inner_flow_trajectory() -> None:
    nominal, slow = make(BUOYANT), make(BUOYANT)
    a = np.array([0.0, 0.8], np.float32)  # a step up of the oil fraction
    flows = []
    for env, lag in ((nominal, None), (slow, 0.5)):
        env.reset(seed=0)
        apply_physics(env, pump_lag_s=lag)
        trajectory = []
        for _ in range(5):
            env.step(a)
            trajectory.append(env.unwrapped.inner_flow_now_ml_min)
        flows.append(trajectory)
    assert nominal.unwrapped.inner_lag_s == 0.1 and slow.unwrapped.inner_lag_s == 0.5
    assert all(s < n for n, s in zip(*flows, strict=True))  # the slower pump lags further


def test_drawn_pump_lag_lies_in_its_range() -> None:
    env = RobustnessWrapper(make(BUOYANT), pump_lag_s=[0.2, 0.4])
    for seed in range(3):
        lag = env.reset(seed=seed)[1]["robustness"]["pump_lag_s"]
        assert 0.2 <= lag <= 0.4 and env.unwrapped.inner_lag_s == lag


@pytest.mark.parametrize("scale", ["log", "linear"])
def test_flow_noise_is_exactly_its_relative_change_of_q_outer(scale: str) -> None:
    sigma, seed = 0.1, 4
    env = RobustnessWrapper(
        make(COIL, spec_overrides={"control": {"q_outer_scale": scale}}), flow_noise=sigma
    )
    bare = make(COIL, spec_overrides={"control": {"q_outer_scale": scale}})
    u = env.unwrapped
    assert u.q_outer_log == (scale == "log")
    env.reset(seed=seed)
    bare.reset(seed=seed)
    # the stream the module doc describes: the episode's seed, then its flow stream
    rng = np.random.default_rng([seed, _SEED_TAG])
    rng.random(3)
    flow = np.random.default_rng([int(rng.integers(2**63)), 1])
    for a in actions(env, 5):
        q_cmd = u.action_to_controls(a)["q_outer_ml_min"]
        obs, _, _, _, info = env.step(a)
        z = float(np.clip(flow.standard_normal(), -3.0, 3.0))
        assert info["q_outer_ml_min"] == pytest.approx(q_cmd * (1.0 + sigma * z), rel=1e-12)
        assert info["robustness"]["flow_noise_factor"] == pytest.approx(1.0 + sigma * z, rel=1e-12)
        # the observation shows the agent's command, as the bare environment's does
        obs_b = bare.step(a)[0]
        sl = u.obs_slices()["controls"]
        np.testing.assert_array_equal(obs[sl], obs_b[sl])


@pytest.mark.parametrize("goal", [False, True], ids=["flat", "goal"])
def test_observation_noise_stays_in_the_observation_space(goal: bool) -> None:
    env = RobustnessWrapper(make(COIL, goal_conditioned=goal), observation_noise=8.0)
    bare = make(COIL, goal_conditioned=goal)
    obs_w, _, _ = rollout(env, 2, actions(env))
    obs_b, _, _ = rollout(bare, 2, actions(env))
    space = env.observation_space
    for w, b in zip(obs_w, obs_b, strict=True):
        assert space.contains(w)
        assert np.abs(flat(w)).max() == 10.0  # sigma 8 reaches the clip at +-10
        assert not np.array_equal(flat(w), flat(b))
        if goal:  # the goals stay exact
            np.testing.assert_array_equal(w["desired_goal"], b["desired_goal"])


# ------------------------------------------------------------------ refusals
@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("bath_viscosity_spread", -0.1),
        ("bath_viscosity_spread", 10.0),
        ("bath_viscosity_spread", math.nan),
        ("bath_viscosity_spread", True),
        ("gel_modulus_spread", "0.2"),
        ("pump_lag_s", (0.0, 0.1)),
        ("pump_lag_s", (0.3, 0.1)),
        ("pump_lag_s", [0.1]),
        ("pump_lag_s", "slow"),
        ("flow_noise", 0.5),
        ("flow_noise", -0.01),
        ("observation_noise", -1.0),
        ("observation_noise", math.inf),
    ],
)
def test_bad_values_are_refused_with_the_key_named(key: str, value) -> None:
    with pytest.raises(ConfigError, match=key) as exc:
        Robustness(**{key: value})
    assert repr(value) in str(exc.value) and "allowed" in str(exc.value)


def test_unknown_options_and_wrong_environments_are_refused() -> None:
    with pytest.raises(ConfigError, match="'viscosity_spread'"):
        Robustness.from_mapping({"viscosity_spread": 0.2})
    with pytest.raises(ConfigError, match="pump_lag_s.*no inner flow"):
        RobustnessWrapper(make(COIL), pump_lag_s=(0.05, 0.2))
    with pytest.raises(ConfigError, match="version 1 on"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            v0 = E.make("bathprint/CoilRadius-v0", accuracy="draft")
        RobustnessWrapper(v0)
    with pytest.raises(ConfigError, match="give one"):
        RobustnessWrapper(make(COIL), Robustness(flow_noise=0.1), flow_noise=0.1)


# ------------------------------------------------------------------ agents' machinery
ENTRY = [{"bathprint.envs.robust.RobustnessWrapper": {"bath_viscosity_spread": 0.2}}]


def test_agents_files_select_it_and_evaluation_replays_it(tmp_path) -> None:
    from bathprint.agents.evaluate import run_settings
    from bathprint.agents.hyperparams import split_hyperparams
    from bathprint.agents.wrappers import wrapper_factory, wrapper_spec

    assert wrapper_spec(ENTRY) == {"name": "robustness", "bath_viscosity_spread": 0.2}
    hp = {"env_kwargs": {"accuracy": "draft"}, "env_wrapper": ENTRY}
    assert split_hyperparams(hp)[0]["wrapper"]["name"] == "robustness"
    run = {"algo": "ppo", "env_id": COIL, "seed": 0, "hyperparams": hp, "n_timesteps": 1}
    (tmp_path / "run.json").write_text(json.dumps(run))
    kwargs, wrapper = run_settings(str(tmp_path), None, COIL)  # what `bathprint evaluate` reads
    env = wrapper_factory(wrapper)(make(COIL, **kwargs))
    assert isinstance(env, RobustnessWrapper)
    assert env.robustness == Robustness(bath_viscosity_spread=0.2)
    assert "bath_viscosity_pa_s" in env.reset(seed=0)[1]["robustness"]


def test_agents_files_with_bad_robustness_values_are_refused() -> None:
    from bathprint.agents.hyperparams import validate_hyperparams

    good = [{"bathprint.envs.robust.RobustnessWrapper": {"pump_lag_s": [0.05, 0.2]}}]
    validate_hyperparams("ppo", {"env_wrapper": good}, "ppo.yml")
    bad = [{"bathprint.envs.robust.RobustnessWrapper": {"flow_noise": 2.0}}]
    with pytest.raises(ConfigError, match=r"ppo.yml: wrapper.flow_noise = 2.0; allowed"):
        validate_hyperparams("ppo", {"env_wrapper": bad}, "ppo.yml")
    typo = [{"bathprint.envs.robust.RobustnessWrapper": {"flow_nosie": 0.1}}]
    with pytest.raises(ConfigError, match="did you mean 'flow_noise'"):
        validate_hyperparams("ppo", {"env_wrapper": typo}, "ppo.yml")

"""Behaviour-cloning pretraining (bathprint.agents.imitation): demonstrations come from the
training targets only, fitting lowers the action error to them, ``bathprint train`` applies
it and records it (the pretrained model is evaluated at step 0), and bad settings are
refused naming the key."""

from __future__ import annotations

import json

import numpy as np
import pytest

from bathprint.agents.hyperparams import agents_dir, load_hyperparams, validate_hyperparams
from bathprint.agents.imitation import (
    action_mse,
    bc_settings,
    collect_demonstrations,
    fit_policy,
)
from bathprint.agents.train import train
from bathprint.envs import make
from bathprint.errors import ConfigError

ENV = "bathprint/CoilRadius-v1"
KW = {"accuracy": "draft"}


def _ppo(seed: int = 0):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    venv = DummyVecEnv([lambda: make(ENV, **KW)])
    return PPO("MlpPolicy", venv, seed=seed, device="cpu", n_steps=64, batch_size=32,
               policy_kwargs={"net_arch": [128, 128], "log_std_init": -1.0})


@pytest.fixture(scope="module")
def demos():
    return collect_demonstrations(ENV, KW, 3, seed=0, action_noise=0.15)


def test_demonstrations_come_from_the_training_set_only(demos, monkeypatch):
    env = make(ENV, **KW)
    family = env.unwrapped.printed
    held_out = set(family.seeds("validation")) | set(family.seeds("test"))
    assert demos.target_seeds == [0, 1, 2]
    assert not set(demos.target_seeds) & held_out
    assert demos.target_sets == ["train"] * 3
    # collecting never reads a fixed (validation or test) target
    import bathprint.envs.v1 as v1

    def refuse(self, target_set, index):
        raise AssertionError(f"read {target_set} target {index}")

    monkeypatch.setattr(v1.BathprintEnvV1, "fixed_set_target", refuse)
    again = collect_demonstrations(ENV, KW, 1, seed=0)
    # the labels are the training target's own printing actions
    n = len(env.unwrapped.actions_for(family.get(0)))
    expected = env.unwrapped.actions_for(family.get(0))
    assert len(again.obs) == len(again.actions) >= n
    np.testing.assert_allclose(again.actions[:n], expected, atol=1e-6)
    env.close()


def test_demonstrations_are_deterministic(demos):
    again = collect_demonstrations(ENV, KW, 3, seed=0, action_noise=0.15)
    np.testing.assert_array_equal(again.obs, demos.obs)
    np.testing.assert_array_equal(again.actions, demos.actions)


def _episodes(d):
    """The demonstrations split into episodes (an episode starts at the first observation)."""
    starts = [i for i in range(len(d.obs)) if np.array_equal(d.obs[i], d.obs[0])] + [len(d.obs)]
    return [d.obs[a:b] for a, b in zip(starts[:-1], starts[1:], strict=True)]


def test_replays_play_each_target_again_alternating_clean_and_noisy(demos):
    two = collect_demonstrations(ENV, KW, 1, seed=0, action_noise=0.15, replays=2)
    clean, noisy = _episodes(two)  # one target: its clean replay, then its noisy one
    one = collect_demonstrations(ENV, KW, 1, seed=0)
    np.testing.assert_array_equal(clean, one.obs)  # the first replay is the clean one
    assert len(noisy) >= 2 and not np.allclose(noisy[1:], clean[1 : len(noisy)], atol=1e-6)
    np.testing.assert_array_equal(two.actions[: len(clean)], two.actions[len(clean) :])
    # one replay is the collection as it was (every other target noisy)
    again = collect_demonstrations(ENV, KW, 3, seed=0, action_noise=0.15, replays=1,
                                   noise_correlation=0.0)  # fmt: skip
    np.testing.assert_array_equal(again.obs, demos.obs)


def _played_noise(monkeypatch, **kwargs):
    """The noise of each noisy episode (what collect_demonstrations played minus its label,
    recorded at the environment's step) and every played action."""
    import gymnasium as gym

    import bathprint.envs as envs

    played: list[list[np.ndarray]] = []

    class Record(gym.Wrapper):
        def reset(self, **kw):
            played.append([])
            return self.env.reset(**kw)

        def step(self, action):
            played[-1].append(np.array(action, np.float64))
            return self.env.step(action)

    real = envs.make
    monkeypatch.setattr(envs, "make", lambda *a, **k: Record(real(*a, **k)))
    d = collect_demonstrations(ENV, KW, 4, seed=0, replays=2, **kwargs)
    labels = np.split(d.actions.astype(np.float64), np.cumsum([len(e) for e in played])[:-1])
    noise = [np.stack(e) - a for e, a in zip(played, labels, strict=True)]
    assert not any(np.any(e) for e in noise[0::2])  # replay 0 of each target is clean
    return noise[1::2], np.concatenate([np.stack(e) for e in played])


@pytest.mark.parametrize("rho", [0.0, 0.9])
def test_action_noise_has_the_asked_std_and_step_to_step_correlation(monkeypatch, rho):
    noisy, played = _played_noise(monkeypatch, action_noise=0.15, noise_correlation=rho)
    assert len(noisy) == 4
    lag0, lag1, n = 0.0, 0.0, 0
    for e in noisy:
        lag0 += float(np.sum(e[:-1] * e[:-1]))
        lag1 += float(np.sum(e[:-1] * e[1:]))
        n += e[:-1].size
    assert np.sqrt(lag0 / n) == pytest.approx(0.15, rel=0.3)
    assert lag1 / lag0 == pytest.approx(rho, abs=0.15)
    assert np.all(np.abs(played) <= 1.0)


def test_fitting_lowers_the_action_error_and_is_deterministic(demos):
    import torch

    torch.set_num_threads(1)
    a, b = _ppo(), _ppo()
    value_before = [p.detach().clone() for p in a.policy.value_net.parameters()]
    fit = fit_policy(a.policy, demos, epochs=20, batch_size=64, learning_rate=1e-3, seed=3)
    assert fit["mse_after"] < 0.5 * fit["mse_before"], fit
    assert fit["mse_after"] == pytest.approx(action_mse(a.policy, demos), rel=1e-6)
    for p, q in zip(a.policy.value_net.parameters(), value_before, strict=True):
        assert torch.equal(p, q)  # the value net is PPO's
    fit_b = fit_policy(b.policy, demos, epochs=20, batch_size=64, learning_rate=1e-3, seed=3)
    assert fit_b["mse_after"] == pytest.approx(fit["mse_after"], rel=1e-9, abs=1e-12)
    for p, q in zip(a.policy.parameters(), b.policy.parameters(), strict=True):
        assert torch.equal(p, q)


def _ensemble_ppo(members: int, seed: int = 0):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv

    from bathprint.agents.ensemble import EnsembleMlpPolicy

    venv = DummyVecEnv([lambda: make(ENV, **KW)])
    return PPO(EnsembleMlpPolicy, venv, seed=seed, device="cpu", n_steps=64, batch_size=32,
               policy_kwargs={"net_arch": [32, 32], "log_std_init": -1.0, "members": members})


def test_an_ensemble_acts_with_its_members_mean_and_fits_each_on_its_own(demos, tmp_path):
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(1)
    model = _ensemble_ppo(3)
    pol = model.policy
    obs = torch.as_tensor(demos.obs[:50], dtype=torch.float32)
    with torch.no_grad():
        heads = pol.member_means(obs)
        assert heads.shape == (3, 50, demos.actions.shape[1])
        assert not torch.allclose(heads[0], heads[1])  # independent initialisations
        for k in range(3):
            assert torch.allclose(pol.member_mean(obs, k), heads[k])
        mean_action = pol.get_distribution(obs).distribution.mean
        assert torch.allclose(mean_action, heads.mean(dim=0), atol=1e-6)
    value_before = [p.detach().clone() for p in pol.value_net.parameters()]
    per_member_before = ((heads - torch.as_tensor(demos.actions[:50])) ** 2).mean(dim=(1, 2))
    fit = fit_policy(pol, demos, epochs=20, batch_size=64, learning_rate=1e-3, seed=3)
    assert fit["mse_after"] < 0.5 * fit["mse_before"], fit
    with torch.no_grad():
        after = pol.member_means(obs)
    per_member_after = ((after - torch.as_tensor(demos.actions[:50])) ** 2).mean(dim=(1, 2))
    assert torch.all(per_member_after < 0.5 * per_member_before)  # every actor is fitted
    for p, q in zip(pol.value_net.parameters(), value_before, strict=True):
        assert torch.equal(p, q)  # the value net is PPO's
    # saved and loaded, it acts the same (the class is found by its import path)
    model.save(tmp_path / "ens.zip")
    loaded = PPO.load(tmp_path / "ens.zip", device="cpu")
    assert loaded.policy.members == 3
    a, _ = model.predict(demos.obs[:5], deterministic=True)
    b, _ = loaded.predict(demos.obs[:5], deterministic=True)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-7)
    # and PPO trains it like any policy
    loaded.set_env(model.get_env())
    loaded.learn(64)


def test_tiny_training_with_bc_pretrain_records_it_and_evaluates_step_0(tmp_path, monkeypatch):
    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_bc.yml")
    assert hp["bc_pretrain"]["targets"] >= 1
    hp.update(n_envs=1, n_steps=82, batch_size=41, n_epochs=1, eval_freq=10_000,
              eval_episodes=1, checkpoint_freq=82, time_budget_s=600,
              bc_pretrain={"targets": 2, "epochs": 5, "batch_size": 32})
    run = train("ppo", ENV, timesteps=82, out=tmp_path / "bc", hyperparams=hp, progress=False)
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "done"
    bc = info["bc_pretrain"]
    assert bc["targets"] == 2 and bc["demonstration_target_set"] == "train"
    assert bc["demonstration_pairs"] >= 2 * 80
    assert bc["mse_after"] < bc["mse_before"]
    assert info["wall_time_s"] >= bc["wall_time_s"] > 0
    with np.load(run / "eval" / "evaluations.npz") as d:
        steps = d["timesteps"].tolist()
    assert steps[0] == 0 and steps[-1] >= 82  # the pretrained model, then the end
    assert (run / "eval" / "best_model.zip").is_file()
    # evaluating the run directory plays the model its validation selected; the final one
    # on request, by its file
    from bathprint.agents.train import trained_files

    _, zip_path, stats, label, _ = trained_files(run)
    assert zip_path == run / "eval" / "best_model.zip" and "selected on validation" in label
    assert stats == run / "eval" / "vecnormalize.pkl"
    assert trained_files(run / "final_model.zip")[1] == run / "final_model.zip"

    # a resume continues the checkpoint: no second behaviour cloning, step 0 kept
    import bathprint.agents.imitation as imitation

    def refuse(*args, **kwargs):
        raise AssertionError("bc_pretrain applied on --resume")

    monkeypatch.setattr(imitation, "pretrain", refuse)
    train("ppo", ENV, timesteps=164, out=run, resume=True, progress=False)
    resumed = json.loads((run / "run.json").read_text())
    assert resumed["status"] == "done" and resumed["timesteps_done"] >= 164
    assert resumed["bc_pretrain"] == bc
    with np.load(run / "eval" / "evaluations.npz") as d:
        assert d["timesteps"].tolist()[:2] == steps[:2] and d["timesteps"][-1] >= 164


def test_tiny_training_with_an_ensemble_saves_a_model_of_its_members(tmp_path):
    from stable_baselines3 import PPO

    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_bc.yml")
    hp.update(n_envs=1, n_steps=82, batch_size=41, n_epochs=1, eval_freq=10_000,
              eval_episodes=1, checkpoint_freq=82, time_budget_s=600,
              policy_kwargs={"net_arch": [16, 16], "log_std_init": -3.0},
              bc_pretrain={"targets": 2, "epochs": 3, "batch_size": 32, "ensemble": 2})
    run = train("ppo", ENV, timesteps=82, out=tmp_path / "ens", hyperparams=hp, progress=False)
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "done" and info["bc_pretrain"]["ensemble"] == 2
    model = PPO.load(run / "eval" / "best_model.zip", device="cpu")
    assert type(model.policy).__name__ == "EnsembleMlpPolicy" and model.policy.members == 2
    hp["policy"] = "CnnPolicy"
    with pytest.raises(ConfigError, match="bc_pretrain.ensemble = 2 with policy = 'CnnPolicy'"):
        train("ppo", ENV, timesteps=82, out=tmp_path / "cnn", hyperparams=hp, progress=False)


@pytest.mark.parametrize(
    ("value", "needle"),
    [
        ({"targets": 0}, "bc_pretrain.targets = 0"),
        ({"epochs": 2.5}, "bc_pretrain.epochs = 2.5"),
        ({"batch_size": True}, "bc_pretrain.batch_size = True"),
        ({"learning_rate": -1.0}, "bc_pretrain.learning_rate = -1.0"),
        ({"action_noise": float("nan")}, "bc_pretrain.action_noise = nan"),
        ({"critic_warmup_steps": -1}, "bc_pretrain.critic_warmup_steps = -1"),
        ({"replays": 0}, "bc_pretrain.replays = 0"),
        ({"ensemble": 0}, "bc_pretrain.ensemble = 0"),
        ({"noise_correlation": 1.0}, "bc_pretrain.noise_correlation = 1.0"),
        ({"noise_correlation": -0.5}, "bc_pretrain.noise_correlation = -0.5"),
        ({"targts": 10}, "unknown bc_pretrain key 'targts'"),
        (160, "bc_pretrain = 160"),
    ],
)
def test_bad_bc_pretrain_values_are_refused_naming_the_key(value, needle):
    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_bc.yml")
    hp["bc_pretrain"] = value
    with pytest.raises(ConfigError) as exc:
        validate_hyperparams("ppo", hp, "hp", ENV)
    assert needle in str(exc.value)


def test_bc_pretrain_is_refused_where_it_cannot_work(tmp_path):
    base = load_hyperparams("ppo", ENV, agents_dir() / "ppo_bc.yml")
    cases = [
        ({"normalize": {"norm_obs": True}}, ENV, "normalize.norm_obs"),
        ({"env_wrapper": [{"bathprint.agents.wrappers.FeedforwardResidual": {"scale": 0.5}}]},
         ENV, "env_wrapper"),
        ({}, "bathprint/CoilRadius-v0", "version-1"),
    ]
    for extra, env_id, needle in cases:
        hp = {**base, **extra}
        with pytest.raises(ConfigError, match="bc_pretrain") as exc:
            validate_hyperparams("ppo", hp, "hp", env_id)
        assert needle in str(exc.value)
    with pytest.raises(ConfigError, match="bc_pretrain.targets = 5000"):
        train("ppo", ENV, timesteps=82, out=tmp_path / "x", progress=False,
              hyperparams={**base, "bc_pretrain": {"targets": 5000}})
    assert not (tmp_path / "x").exists()
    assert bc_settings(False, "hp") is None and bc_settings(None, "hp") is None
    assert bc_settings({"targets": 4}, "hp")["epochs"] == 30


def test_critic_warmup_trains_the_value_net_only_until_its_step():
    import torch

    from bathprint.agents.callbacks import CriticWarmup
    from bathprint.agents.imitation import actor_parameters

    torch.set_num_threads(1)

    def snapshot(params):
        return [p.detach().clone() for p in params]

    model = _ppo()
    actor0 = snapshot(actor_parameters(model.policy))
    value0 = snapshot(model.policy.value_net.parameters())
    warm = CriticWarmup(10_000)
    model.learn(128, callback=warm)
    assert all(torch.equal(p, q) for p, q in zip(actor_parameters(model.policy), actor0,
                                                 strict=True))
    assert not all(torch.equal(p, q) for p, q in zip(model.policy.value_net.parameters(),
                                                     value0, strict=True))
    assert not warm.frozen and all(p.requires_grad for p in actor_parameters(model.policy))
    # past its step the actor learns again
    model = _ppo()
    actor0 = snapshot(actor_parameters(model.policy))
    model.learn(128, callback=CriticWarmup(64))
    assert not all(torch.equal(p, q) for p, q in zip(actor_parameters(model.policy), actor0,
                                                     strict=True))

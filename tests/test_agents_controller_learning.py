"""Learning from the tuned controller on the shape environments: behaviour cloning with
``bc_pretrain.demonstrator: controller`` (bathprint.agents.imitation) and PPO as a residual
on the controller (bathprint.agents.wrappers.ControllerResidual). The demonstrations are
the controller's actions at the states reached, also when a noisy action is played; the
printing actions are refused where the targets have none; a zero residual is the
controller; evaluation replays the wrapper a run was trained with."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

from bathprint.agents.controller import make_controller
from bathprint.agents.hyperparams import agents_dir, load_hyperparams, validate_hyperparams
from bathprint.agents.imitation import action_mse, bc_settings, collect_demonstrations
from bathprint.agents.train import train
from bathprint.agents.wrappers import ControllerResidual, wrapper_factory, wrapper_spec
from bathprint.envs import make
from bathprint.errors import ConfigError

ENV = "bathprint/CoilRadius-v2"
KW = {"accuracy": "draft"}
SHAPE_ENVS = ("bathprint/CoilRadius-v2", "bathprint/WriteShape-v3", "bathprint/BuoyantLayers-v2")
#: a tiny PPO run (one environment, two rollouts of 64 steps)
TINY = {"n_envs": 1, "n_steps": 64, "batch_size": 32, "n_epochs": 1, "eval_freq": 10_000,
        "eval_episodes": 1, "checkpoint_freq": 10_000, "time_budget_s": 600}  # fmt: skip


class _Witness(gym.Wrapper):
    """Records, per episode, the target, each observation before a step, the action played
    and what a controller of its own (fresh each reset) says at that observation."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        self.episodes: list[dict] = []

    def reset(self, **kwargs):
        obs, info = self.env.reset(**kwargs)
        self._obs = obs
        self._controller = make_controller(self.env)
        self.episodes.append({"target": self.env.unwrapped.target.name, "obs": [], "played": [],
                              "controller": []})  # fmt: skip
        return obs, info

    def step(self, action):
        ep = self.episodes[-1]
        ep["obs"].append(np.asarray(self._obs, np.float32))
        ep["played"].append(np.asarray(action, np.float32))
        ep["controller"].append(self._controller.predict(self._obs)[0])
        out = self.env.step(action)
        self._obs = out[0]
        return out


def _witnessed(monkeypatch) -> list[_Witness]:
    import bathprint.envs as envs

    made: list[_Witness] = []
    real = envs.make

    def make_witnessed(*args, **kwargs):
        made.append(_Witness(real(*args, **kwargs)))
        return made[-1]

    monkeypatch.setattr(envs, "make", make_witnessed)
    return made


@pytest.mark.parametrize("env_id", SHAPE_ENVS)
def test_controller_demonstrations_label_every_state_reached_with_the_controllers_action(
    env_id, monkeypatch
):
    made = _witnessed(monkeypatch)
    demos = collect_demonstrations(env_id, KW, 2, seed=0, action_noise=0.15,
                                   demonstrator="controller")  # fmt: skip
    (witness,) = made
    played = [e for e in witness.episodes if e["obs"]]  # drawing a shape resets, no steps
    assert len(played) == 2
    assert demos.target_seeds == [0, 1] and demos.target_sets == ["train", "train"]
    assert demos.demonstrator == "controller"
    # the training shapes that reset seeds 0 and 1 draw (never a named shape)
    fresh = make(env_id, target_set="train", **KW)
    for s, ep in enumerate(played):
        fresh.reset(seed=s)
        assert ep["target"] == fresh.unwrapped.target.name
        named = {t.name for ts in fresh.unwrapped.named.values() for t in ts}
        assert ep["target"] not in named
    fresh.close()
    obs = np.concatenate([np.stack(e["obs"]) for e in played])
    mine = np.concatenate([np.stack(e["controller"]) for e in played])
    np.testing.assert_array_equal(demos.obs, obs)
    np.testing.assert_array_equal(demos.actions, mine)  # the controller's, state by state
    # episode 0 plays the labels; episode 1 plays them with noise (DART), labels unchanged
    n0 = len(played[0]["obs"])
    np.testing.assert_array_equal(np.stack(played[0]["played"]), demos.actions[:n0])
    noise = np.stack(played[1]["played"]) - demos.actions[n0:]
    assert np.abs(noise).max() > 0.05 and np.all(np.abs(np.stack(played[1]["played"])) <= 1)
    # the same call gives the same demonstrations
    again = collect_demonstrations(env_id, KW, 2, seed=0, action_noise=0.15,
                                   demonstrator="controller")  # fmt: skip
    np.testing.assert_array_equal(again.obs, demos.obs)
    np.testing.assert_array_equal(again.actions, demos.actions)


def test_printed_demonstrations_are_refused_where_targets_have_no_actions(tmp_path):
    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_bc_controller.yml")
    assert hp["bc_pretrain"]["demonstrator"] == "controller"
    for printed in ({**hp["bc_pretrain"], "demonstrator": "printed"}, {"targets": 4}):
        bad = {**hp, "bc_pretrain": printed}
        with pytest.raises(ConfigError) as exc:
            validate_hyperparams("ppo", bad, "hp", ENV)
        assert "bc_pretrain.demonstrator = 'printed'" in str(exc.value)
        assert "use demonstrator: controller" in str(exc.value)
        with pytest.raises(ConfigError, match="use demonstrator: controller"):
            train("ppo", ENV, timesteps=64, out=tmp_path / "x", hyperparams=bad,
                  progress=False)  # fmt: skip
        assert not (tmp_path / "x").exists()
    with pytest.raises(ConfigError, match=r"bc_pretrain.demonstrator = 'printed'.*controller"):
        collect_demonstrations(ENV, KW, 1, seed=0)  # the default demonstrator
    with pytest.raises(ConfigError, match="bc_pretrain.demonstrator = 'expert'"):
        bc_settings({"demonstrator": "expert"}, "hp")
    assert bc_settings({}, "hp")["demonstrator"] == "printed"  # version 1 unchanged
    # the version-1 environments take both; version 0 neither
    v1 = load_hyperparams("ppo", "bathprint/CoilRadius-v1", agents_dir() / "ppo_bc.yml")
    for who in ("printed", "controller"):
        validate_hyperparams("ppo", {**v1, "bc_pretrain": {"demonstrator": who}}, "hp",
                             "bathprint/CoilRadius-v1")  # fmt: skip
    with pytest.raises(ConfigError, match="version-1"):
        validate_hyperparams("ppo", {**v1, "bc_pretrain": {"demonstrator": "controller"}},
                             "hp", "bathprint/CoilRadius-v0")  # fmt: skip


def test_tiny_training_clones_the_controller(tmp_path):
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(1)
    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_bc_controller.yml")
    bc = {"demonstrator": "controller", "targets": 2, "epochs": 60, "batch_size": 32,
          "action_noise": 0.15, "critic_warmup_steps": 10_000}  # fmt: skip
    hp.update(TINY, bc_pretrain=bc)
    run = train("ppo", ENV, timesteps=100, out=tmp_path / "bc", hyperparams=hp, progress=False)
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "done" and info["timesteps_done"] >= 100
    rec = info["bc_pretrain"]
    assert rec["demonstrator"] == "controller" and rec["demonstration_target_set"] == "train"
    assert rec["mse_after"] < 0.1 * rec["mse_before"], rec
    with np.load(run / "eval" / "evaluations.npz") as d:
        assert d["timesteps"].tolist()[0] == 0  # the cloned policy, played on validation
    # the actor stays the cloned one through the critic's warm-up: its actions are the
    # controller's on the demonstration observations (collected again: deterministic)
    demos = collect_demonstrations(ENV, KW, 2, seed=0, action_noise=0.15,
                                   demonstrator="controller")  # fmt: skip
    assert len(demos.obs) == rec["demonstration_pairs"]
    model = PPO.load(run / "final_model.zip", device="cpu")
    assert action_mse(model.policy, demos) == pytest.approx(rec["mse_after"], rel=1e-5)
    cloned, _ = model.predict(demos.obs, deterministic=True)
    assert np.sqrt(np.mean((cloned - demos.actions) ** 2)) < 0.15


def _controller_episode(env: gym.Env, seed: int) -> tuple[list[float], float]:
    controller = make_controller(env)
    obs, _ = env.reset(seed=seed)
    rewards, done, info = [], False, {}
    while not done:
        obs, r, term, trunc, info = env.step(controller.predict(obs)[0])
        rewards.append(float(r))
        done = term or trunc
    return rewards, float(info["rms_mm"])


def _zero_residual_episode(env: ControllerResidual, seed: int) -> tuple[list[float], float]:
    env.reset(seed=seed)
    zero = np.zeros(env.action_space.shape, np.float32)
    rewards, done, info = [], False, {}
    while not done:
        _, r, term, trunc, info = env.step(zero)
        rewards.append(float(r))
        done = term or trunc
    return rewards, float(info["rms_mm"])


@pytest.mark.parametrize("env_id", SHAPE_ENVS)
def test_a_zero_residual_is_the_controller(env_id):
    base = make(env_id, **KW)
    witness = _Witness(make(env_id, **KW))
    wrapped = wrapper_factory({"name": "controller_residual", "scale": 0.5})(witness)
    assert isinstance(wrapped, ControllerResidual)
    for seed in (3, 4):  # two episodes in a row: the controller starts afresh on reset
        expected = _controller_episode(base, seed)
        got = _zero_residual_episode(wrapped, seed)
        assert got[0] == expected[0]  # the same rewards, step by step
        assert got[1] == expected[1]  # the same whole-shape error (mm)
    # a correction moves the played action by scale * a, clipped to the action space
    wrapped.reset(seed=3)
    for _ in range(3):
        wrapped.step(np.full(wrapped.action_space.shape, 0.6, np.float32))
    ep = witness.episodes[-1]
    expected_played = np.clip(np.stack(ep["controller"]) + 0.3, -1, 1)
    np.testing.assert_allclose(np.stack(ep["played"]), expected_played, rtol=0, atol=1e-6)
    with pytest.raises(ValueError, match="NaN"):
        wrapped.step(np.full(wrapped.action_space.shape, np.nan, np.float32))
    base.close()
    wrapped.close()


@pytest.mark.filterwarnings("ignore::DeprecationWarning")  # CoilRadius-v0 is superseded
def test_the_residual_wrapper_is_selected_and_checked_by_name(tmp_path):
    cls = "bathprint.agents.wrappers.ControllerResidual"
    assert wrapper_spec([{cls: {"scale": 0.3}}]) == {"name": "controller_residual", "scale": 0.3}
    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_residual_controller.yml")
    assert wrapper_spec(hp["env_wrapper"])["name"] == "controller_residual"
    for bad, needle in (
        ([{cls: {"scael": 0.3}}], "did you mean 'scale'"),
        ([{cls: {"calibrated": True}}], "unknown wrapper key 'calibrated'"),
    ):
        with pytest.raises(ConfigError, match=needle):
            validate_hyperparams("ppo", {**hp, "env_wrapper": bad}, "hp", ENV)
    for scale in ("big", 0.0):  # refused before the run folder is written
        with pytest.raises(ConfigError, match=f"wrapper scale = {scale!r}; allowed"):
            train("ppo", ENV, timesteps=64, out=tmp_path / "x", progress=False,
                  hyperparams={**hp, "env_wrapper": [{cls: {"scale": scale}}]})  # fmt: skip
        assert not (tmp_path / "x").exists()
    with pytest.raises(ValueError, match="scale = 3.0"):
        ControllerResidual(make(ENV, **KW), scale=3.0)
    with pytest.raises(ConfigError, match="version-1"):  # no controller on version 0
        ControllerResidual(make("bathprint/CoilRadius-v0", **KW))


def test_evaluate_replays_the_controller_residual_from_the_run(tmp_path):
    import torch

    from bathprint.agents.evaluate import evaluate_policy_spec
    from bathprint.agents.policies import load_policy
    from bathprint.agents.rollout import run_episode

    torch.set_num_threads(1)
    hp = load_hyperparams("ppo", ENV, agents_dir() / "ppo_residual_controller.yml")
    hp.update(TINY)
    run = train("ppo", ENV, timesteps=64, out=tmp_path / "res", hyperparams=hp, progress=False)
    _, summary, (ep,) = evaluate_policy_spec(str(run), ENV, episodes=1, seed=0,
                                             target_set="validation", progress=False,
                                             animate=False, images=0)  # fmt: skip
    assert summary["wrapper"] == {"name": "controller_residual", "scale": 0.5}
    # the same model on the same wrapper, by hand: the same episode
    env = ControllerResidual(make(ENV, target_set="validation", **KW), scale=0.5)
    policy, _ = load_policy(str(run), env, ENV)
    by_hand = run_episode(env, policy, 0, target_index=0)
    assert by_hand.metrics["metric"] == ep.metrics["metric"]
    assert by_hand.episode_return == ep.episode_return
    # without the wrapper the model alone writes something else
    bare = make(ENV, target_set="validation", **KW)
    alone = run_episode(bare, load_policy(str(run), bare, ENV)[0], 0, target_index=0)
    assert alone.metrics["metric"] != ep.metrics["metric"]

"""Behaviour cloning (BC) of a PPO policy on demonstrations of the training targets.

Two demonstrators label the training targets (``bc_pretrain.demonstrator``):

- ``printed`` (the default): a version-1 environment prints its targets itself
  (:mod:`bathprint.envs.printed`): every target carries the actions that printed it, and
  replaying them from the target's start state prints it again. Those actions are
  demonstrations that cost nothing to label.
- ``controller``: the tuned controller of the environment's shape family
  (:func:`bathprint.agents.controller.make_controller`) plays the training targets and is
  queried at every state reached. The shape environments (spec version 3) need it: their
  targets are shapes with no printing actions.

:func:`collect_demonstrations` plays the first ``targets`` training targets (seeds
0 .. targets-1 of the training pool, or of a shape environment's generator; validation and
test targets are never read) and keeps (observation, action) pairs; :func:`fit_policy`
regresses the PPO policy's deterministic action mean (``mlp_extractor.policy_net`` and
``action_net``) onto the actions by mean squared error, leaving the value network (and the
action noise) to PPO. With
``critic_warmup_steps``, PPO's first updates train the value network only
(:class:`~bathprint.agents.callbacks.CriticWarmup`): an untrained critic's advantages
would otherwise move the pretrained actor at random.

``bc_pretrain`` in the ``bathprint`` section of a hyperparameter file switches it on
(:data:`BC_KEYS`; ``demonstrator: controller`` on the shape environments, whose targets have
no printing actions); ``bathprint train`` applies it to a fresh model before learning. With
``ensemble`` K > 1 the policy is an :class:`~bathprint.agents.ensemble.EnsembleMlpPolicy`
of K actors, each fitted on its own, whose mean is the action.
Everything is deterministic for a seed.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from bathprint.errors import ConfigError

#: keys of ``bc_pretrain`` and their defaults
BC_DEFAULTS: dict[str, Any] = {
    "targets": 160,  # training targets replayed (seeds 0 .. targets-1)
    "epochs": 30,  # passes over the demonstrations
    "batch_size": 256,
    "learning_rate": 1.0e-3,  # Adam
    "action_noise": 0.0,  # std of Gaussian noise on the played action, every other episode
    "noise_correlation": 0.0,  # AR(1) coefficient of that noise from step to step (0: white)
    "replays": 1,  # episodes per training target (clean and noisy alternate over episodes)
    "critic_warmup_steps": 0,  # environment steps of PPO that update the value net only
    "ensemble": 1,  # actors fitted independently; the action is their mean (agents.ensemble)
    "demonstrator": "printed",  # who labels the states: the printing actions or the controller
}
BC_KEYS = tuple(BC_DEFAULTS)
#: values of ``bc_pretrain.demonstrator``
DEMONSTRATORS = ("printed", "controller")


def bc_settings(value: Any, where: str) -> dict[str, Any] | None:
    """``bc_pretrain`` checked and completed with :data:`BC_DEFAULTS`; None when off
    (``false``, ``null`` or absent). Raises ConfigError naming the key."""
    if value is None or value is False:
        return None
    if value is True:
        value = {}
    if not isinstance(value, dict):
        raise ConfigError(
            f"{where}: bc_pretrain = {value!r}; expected false or a mapping of "
            + ", ".join(BC_KEYS)
            + " (e.g. {targets: 160, epochs: 30})"
        )
    out = dict(BC_DEFAULTS)
    for key, v in value.items():
        if key not in BC_DEFAULTS:
            raise ConfigError(
                f"{where}: unknown bc_pretrain key {key!r}; allowed: " + ", ".join(BC_KEYS)
            )
        name = f"bc_pretrain.{key}"
        if key == "demonstrator":
            if not (isinstance(v, str) and v in DEMONSTRATORS):
                raise ConfigError(
                    f"{where}: {name} = {v!r}; allowed: " + ", ".join(map(repr, DEMONSTRATORS))
                )
            out[key] = v
            continue
        if key in ("targets", "epochs", "batch_size", "replays", "critic_warmup_steps", "ensemble"):
            low = 0 if key == "critic_warmup_steps" else 1
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= low):
                raise ConfigError(f"{where}: {name} = {v!r}; allowed: an integer >= {low}")
        else:
            number = isinstance(v, int | float) and not isinstance(v, bool) and np.isfinite(v)
            if key == "learning_rate" and not (number and v > 0):
                raise ConfigError(f"{where}: {name} = {v!r}; allowed: a number > 0")
            if key == "action_noise" and not (number and v >= 0):
                raise ConfigError(f"{where}: {name} = {v!r}; allowed: a number >= 0")
            if key == "noise_correlation" and not (number and 0 <= v < 1):
                raise ConfigError(f"{where}: {name} = {v!r}; allowed: a number in [0, 1)")
            v = float(v)
        out[key] = v
    return out


@dataclass
class Demonstrations:
    """(observation, action) pairs of replayed training targets."""

    obs: np.ndarray  # (n, obs_dim) float32
    actions: np.ndarray  # (n, act_dim) float32, the demonstrator's actions (the labels)
    target_seeds: list[int]  # seeds of the training targets replayed
    target_sets: list[str]  # the set each replayed target belongs to (all "train")
    wall_time_s: float
    demonstrator: str = "printed"  # who labelled them (DEMONSTRATORS)


def refuse_printed(env_id: str) -> ConfigError:
    """The refusal of ``demonstrator: printed`` on an environment whose targets have no
    printing actions (the shape environments)."""
    return ConfigError(
        f"bc_pretrain.demonstrator = 'printed' on {env_id}: its targets have no printing "
        "actions to replay (shapes, not printed curves); use demonstrator: controller (the "
        "tuned controller labels the training shapes)"
    )


class _Tap(gym.Wrapper):
    """Keeps the newest observation of the environment it wraps: the controller reads the
    environment's own observation, whatever ``wrap`` makes of it for the policy."""

    last_obs: Any = None

    def reset(self, **kwargs: Any) -> tuple[Any, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self.last_obs = obs
        return obs, info

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        out = self.env.step(action)
        self.last_obs = out[0]
        return out


def collect_demonstrations(
    env_id: str,
    env_kwargs: dict[str, Any],
    n_targets: int,
    seed: int,
    action_noise: float = 0.0,
    replays: int = 1,
    noise_correlation: float = 0.0,
    wrap: Any = None,
    demonstrator: str = "printed",
) -> Demonstrations:
    """Play training targets 0 .. n_targets-1, ``replays`` times each, in a training
    environment (``env_kwargs`` as training uses them) and record the observation before
    each action with the demonstrator's action as its label.

    ``demonstrator="printed"`` replays each target's own printing actions (version-1
    environments); ``"controller"`` plays the tuned controller of the environment's family
    (:func:`~bathprint.agents.controller.make_controller`, fresh per episode), queried once
    at every state reached. Target s is the printed training target of seed s, or on a
    shape environment the shape its generator draws for ``reset(seed=s)``.

    With ``action_noise`` > 0, every other episode (counted over all replays) plays the
    label plus Gaussian noise of that std (seeded by ``seed``; clipped to [-1, 1]) while the
    label stays the demonstrator's action for the state reached, so that the demonstrations
    also cover states off the demonstrated path (DART, Laskey et al. 2017). The noise is
    white, or with ``noise_correlation`` rho > 0 an AR(1) process of the same stationary
    std, n_t = rho n_(t-1) + sqrt(1 - rho^2) e_t, whose drift resembles the correlated error
    of a cloned policy more than white noise does. ``wrap`` (a callable taking and returning
    an environment, e.g. an observation wrapper) records the observations the policy will
    see through it; the controller reads the environment's own."""
    from bathprint.envs import make

    if demonstrator not in DEMONSTRATORS:
        raise ConfigError(
            f"bc_pretrain.demonstrator = {demonstrator!r}; allowed: "
            + ", ".join(map(repr, DEMONSTRATORS))
        )
    t0 = time.perf_counter()
    tap = _Tap(make(env_id, target_set="train", **env_kwargs))
    env = wrap(tap) if wrap is not None else tap
    try:
        u = env.unwrapped
        family = getattr(u, "printed", None)
        if family is None and demonstrator == "printed":
            if getattr(u, "version", 0) >= 1:
                raise refuse_printed(env_id)
            raise ConfigError(
                f"bc_pretrain: {env_id} does not print its targets (no printing actions to "
                "imitate); behaviour cloning needs a version-1 environment"
            )
        if demonstrator == "controller" and getattr(u, "version", 0) < 1:
            raise ConfigError(
                f"bc_pretrain.demonstrator = 'controller' on {env_id}: the controller needs "
                "an environment of version 1 or later"
            )
        if family is not None and n_targets > family.train_pool:
            raise ConfigError(
                f"bc_pretrain.targets = {n_targets}; the training pool of {env_id} has "
                f"{family.train_pool} targets: allowed 1..{family.train_pool}"
            )
        gains = None
        if demonstrator == "controller":  # the tuned gains, read once (a large file)
            from bathprint.agents.controller import load_gains
            from bathprint.envs.shape_files import env_family

            gains = (env_family(env), load_gains(env_family(env)))
        rng = np.random.default_rng([int(seed), 7])
        obs_rows: list[np.ndarray] = []
        act_rows: list[np.ndarray] = []
        sets: list[str] = []
        keep = float(noise_correlation)
        fresh = float(np.sqrt(1.0 - keep * keep))
        for s in range(n_targets):
            if family is not None:
                sets.append(family.set_of_seed(s))
                target = family.get(s)
            else:  # a shape environment: the training shape its generator draws for seed s
                env.reset(seed=s)
                sets.append(str(u.target_set))
                target = u.target
            if sets[-1] != "train":  # the seed ranges are disjoint; a guard all the same
                raise RuntimeError(f"seed {s} is a {sets[-1]} target, not a training target")
            printed = None
            if demonstrator == "printed":
                printed = np.asarray(u.actions_for(target), np.float32)
            for r in range(int(replays)):
                obs, _ = env.reset(seed=int(seed) * 100_003 + s, options={"target": target})
                label = _labeller(env, tap, printed, gains)
                noisy = action_noise > 0 and (s * int(replays) + r) % 2 == 1
                drift = np.zeros(env.action_space.shape)
                for t in range(_MAX_STEPS):
                    a = label(t)
                    obs_rows.append(np.asarray(obs, np.float32))
                    act_rows.append(a)
                    played = a
                    if noisy:  # AR(1), started from its stationary law (white for rho = 0)
                        e = rng.normal(0.0, action_noise, a.shape)
                        drift = e if t == 0 else keep * drift + fresh * e
                        played = np.clip(a + drift, -1, 1)
                    obs, _, term, trunc, _ = env.step(np.asarray(played, np.float32))
                    if term or trunc:
                        break
    finally:
        env.close()
    return Demonstrations(
        obs=np.stack(obs_rows),
        actions=np.stack(act_rows).astype(np.float32),
        target_seeds=list(range(n_targets)),
        target_sets=sets,
        wall_time_s=time.perf_counter() - t0,
        demonstrator=demonstrator,
    )


#: the longest episode a demonstration plays (the environments end theirs well before)
_MAX_STEPS = 100_000


def _labeller(env: Any, tap: _Tap, printed: np.ndarray | None, gains: Any) -> Any:
    """``t -> label`` of one episode just reset: the printing action of step t (the last
    one past the end), or the controller's action on the environment's observation (a
    controller of ``gains`` = (family, gains) made for this episode, asked once per step:
    it keeps per-episode state)."""
    if printed is not None:
        return lambda t: printed[min(t, len(printed) - 1)]
    from bathprint.agents.controller import make_controller

    controller = make_controller(env, *gains)
    return lambda t: np.asarray(controller.predict(tap.last_obs)[0], np.float32)


def _action_mean(policy: Any, obs: Any) -> Any:
    """The policy's deterministic action (the Gaussian's mean) for a batch of observations."""
    features = policy.extract_features(obs, policy.pi_features_extractor)
    return policy.action_net(policy.mlp_extractor.forward_actor(features))


def action_mse(policy: Any, demos: Demonstrations) -> float:
    """Mean squared error of the policy's action mean to the demonstrations' actions."""
    import torch

    with torch.no_grad():
        obs = torch.as_tensor(demos.obs, dtype=torch.float32, device=policy.device)
        act = torch.as_tensor(demos.actions, dtype=torch.float32, device=policy.device)
        return float(((_action_mean(policy, obs) - act) ** 2).mean())


def fit_policy(
    policy: Any,
    demos: Demonstrations,
    epochs: int,
    batch_size: int,
    learning_rate: float,
    seed: int,
) -> dict[str, float]:
    """Fit the actor of an SB3 ActorCriticPolicy (features extractor, policy net, action
    net) to the demonstrations by MSE with Adam; the value network is left as it is.
    Minibatches are shuffled by a generator seeded with ``seed``. An ensemble policy
    (:class:`bathprint.agents.ensemble.EnsembleMlpPolicy`) fits each actor to its own MSE,
    actor k on minibatches in its own order (seed + k): K independent fits, one optimiser.
    Returns the MSE (of the policy's action mean) before and after, the optimiser steps and
    the wall time (s)."""
    import torch

    t0 = time.perf_counter()
    params = [p for p in actor_parameters(policy) if p is not getattr(policy, "log_std", None)]
    opt = torch.optim.Adam(params, lr=learning_rate)
    obs = torch.as_tensor(demos.obs, dtype=torch.float32, device=policy.device)
    act = torch.as_tensor(demos.actions, dtype=torch.float32, device=policy.device)
    members = int(getattr(policy, "members", 1))  # EnsembleMlpPolicy's actors
    gens = [torch.Generator().manual_seed(int(seed) + k) for k in range(members)]
    before = action_mse(policy, demos)
    was_training = policy.training
    policy.set_training_mode(True)
    n, steps, bs = len(obs), 0, int(batch_size)
    for _ in range(int(epochs)):
        orders = [torch.randperm(n, generator=g) for g in gens]
        for i in range(0, n, bs):
            if members == 1:
                idx = orders[0][i : i + bs]
                loss = ((_action_mean(policy, obs[idx]) - act[idx]) ** 2).mean()
            else:  # each actor on its own minibatch: the sum of K separate losses
                loss = 0.0
                for k, order in enumerate(orders):
                    idx = order[i : i + bs]
                    loss = loss + ((policy.member_mean(obs[idx], k) - act[idx]) ** 2).mean()
            opt.zero_grad()
            loss.backward()
            opt.step()
            steps += 1
    policy.set_training_mode(was_training)
    return {
        "mse_before": before,
        "mse_after": action_mse(policy, demos),
        "optimizer_steps": steps,
        "fit_wall_time_s": time.perf_counter() - t0,
    }


def pretrain(
    model: Any, env_id: str, env_kwargs: dict[str, Any], settings: dict[str, Any], seed: int
) -> dict[str, Any]:
    """Behaviour cloning of ``model`` (a PPO model) with ``settings`` (:func:`bc_settings`):
    collect, fit, and return what ``run.json`` records."""
    venv = model.get_vec_normalize_env()
    if venv is not None and venv.norm_obs:
        raise ConfigError(
            "bc_pretrain with normalize.norm_obs true: the demonstrations would be fitted on "
            "raw observations while the policy sees normalised ones; set norm_obs: false"
        )
    demos = collect_demonstrations(
        env_id,
        env_kwargs,
        int(settings["targets"]),
        seed,
        float(settings["action_noise"]),
        int(settings["replays"]),
        float(settings["noise_correlation"]),
        demonstrator=str(settings["demonstrator"]),
    )
    fit = fit_policy(
        model.policy,
        demos,
        int(settings["epochs"]),
        int(settings["batch_size"]),
        float(settings["learning_rate"]),
        seed,
    )
    return {
        **settings,
        "demonstration_pairs": int(len(demos.obs)),
        "demonstration_target_set": "train",
        "demonstration_seeds": f"0..{len(demos.target_seeds) - 1}",
        "collect_wall_time_s": demos.wall_time_s,
        **fit,
    }


def actor_parameters(policy: Any) -> list[Any]:
    """The parameters of an ActorCriticPolicy's action distribution (features extractor of
    the actor, policy net, action net, log std), each once."""
    import torch

    params = [
        *policy.pi_features_extractor.parameters(),
        *policy.mlp_extractor.policy_net.parameters(),
        *policy.action_net.parameters(),
    ]
    if isinstance(getattr(policy, "log_std", None), torch.nn.Parameter):
        params.append(policy.log_std)
    return list({id(p): p for p in params}.values())

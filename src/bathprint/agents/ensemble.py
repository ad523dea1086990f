"""An actor-critic policy whose action is the mean of an ensemble of actor networks.

Behaviour cloning on WriteShape-v1 is limited by compounding error: a clone's small,
correlated action errors move the filament off the printed states, and a mis-laid piece of
filament stays mis-laid (docs/agents.md). Averaging K actors fitted independently to the
same demonstrations (different initialisations and minibatch orders) cancels the part of
their errors that is not shared: a deep ensemble (Lakshminarayanan, Pritzel & Blundell
2017, NeurIPS), used for imitation as in ensemble DAgger (Menda, Driggs-Campbell &
Kochenderfer 2019, IROS).

:class:`EnsembleMlpPolicy` is a Stable-Baselines3 ``ActorCriticPolicy``: K actor MLPs of
``net_arch``'s policy layers, each with its own linear head, one value MLP, one state-
independent log std. The Gaussian's mean is the mean of the K heads, so PPO fine-tunes the
ensemble like any policy, and a saved model loads with ``PPO.load`` (the class is found by
its import path). :meth:`EnsembleMlpPolicy.member_means` gives the K heads apart, for
:func:`bathprint.agents.imitation.fit_policy`, which fits each head to the demonstrations on
its own.
"""

from __future__ import annotations

from typing import Any

import torch
from stable_baselines3.common.policies import ActorCriticPolicy
from torch import nn

from bathprint.errors import ConfigError


def _mlp(inputs: int, layers: list[int], activation: type[nn.Module]) -> tuple[nn.Module, int]:
    mods: list[nn.Module] = []
    for width in layers:
        mods += [nn.Linear(inputs, width), activation()]
        inputs = width
    return nn.Sequential(*mods), inputs


class EnsembleMlpExtractor(nn.Module):
    """K actor MLPs side by side (their latents concatenated) and one critic MLP, with the
    interface of SB3's ``MlpExtractor`` (``forward_actor``, ``forward_critic``,
    ``latent_dim_pi``, ``latent_dim_vf``, ``policy_net``, ``value_net``)."""

    def __init__(
        self,
        feature_dim: int,
        net_arch: list[int] | dict[str, list[int]],
        activation_fn: type[nn.Module],
        members: int,
    ) -> None:
        super().__init__()
        pi = list(net_arch.get("pi", [])) if isinstance(net_arch, dict) else list(net_arch)
        vf = list(net_arch.get("vf", [])) if isinstance(net_arch, dict) else list(net_arch)
        nets = [_mlp(feature_dim, pi, activation_fn) for _ in range(members)]
        self.policy_net = nn.ModuleList([net for net, _ in nets])
        self.member_dim = nets[0][1]
        self.value_net, self.latent_dim_vf = _mlp(feature_dim, vf, activation_fn)
        self.latent_dim_pi = members * self.member_dim

    def forward(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        return self.forward_actor(features), self.forward_critic(features)

    def forward_actor(self, features: torch.Tensor) -> torch.Tensor:
        return torch.cat([net(features) for net in self.policy_net], dim=1)

    def forward_critic(self, features: torch.Tensor) -> torch.Tensor:
        return self.value_net(features)


class EnsembleMeanHead(nn.Module):
    """K linear heads, head k on the k-th block of the concatenated latent; ``forward`` is
    their mean, :meth:`members` all K ([K, batch, actions])."""

    def __init__(self, member_dim: int, actions: int, members: int) -> None:
        super().__init__()
        self.member_dim = member_dim
        self.heads = nn.ModuleList([nn.Linear(member_dim, actions) for _ in range(members)])

    def members(self, latent: torch.Tensor) -> torch.Tensor:
        d = self.member_dim
        return torch.stack(
            [head(latent[:, k * d : (k + 1) * d]) for k, head in enumerate(self.heads)]
        )

    def forward(self, latent: torch.Tensor) -> torch.Tensor:
        return self.members(latent).mean(dim=0)


class EnsembleMlpPolicy(ActorCriticPolicy):
    """``MlpPolicy`` with ``members`` actors whose mean is the action (module docstring);
    Gaussian (box) actions only."""

    def __init__(self, *args: Any, members: int = 5, **kwargs: Any) -> None:
        if not (isinstance(members, int) and not isinstance(members, bool) and members >= 1):
            raise ConfigError(f"policy_kwargs.members = {members!r}; allowed: an integer >= 1")
        self.members = members
        super().__init__(*args, **kwargs)

    def _build_mlp_extractor(self) -> None:
        self.mlp_extractor = EnsembleMlpExtractor(
            self.features_dim, self.net_arch, self.activation_fn, self.members
        )

    def _build(self, lr_schedule: Any) -> None:
        super()._build(lr_schedule)
        if not isinstance(self.log_std, nn.Parameter):
            raise ConfigError("EnsembleMlpPolicy: only Gaussian (Box) action spaces are allowed")
        actions = int(self.action_net.out_features)
        self.action_net = EnsembleMeanHead(self.mlp_extractor.member_dim, actions, self.members)
        if self.ortho_init:  # as SB3 initialises its action net: orthogonal, gain 0.01
            self.action_net.apply(lambda m: self.init_weights(m, gain=0.01))
        self.optimizer = self.optimizer_class(  # over the new head's parameters too
            self.parameters(), lr=lr_schedule(1), **self.optimizer_kwargs
        )

    def _get_constructor_parameters(self) -> dict[str, Any]:
        return {**super()._get_constructor_parameters(), "members": self.members}

    def member_means(self, obs: torch.Tensor) -> torch.Tensor:
        """The K actors' action means for a batch of observations: [K, batch, actions]."""
        features = self.extract_features(obs, self.pi_features_extractor)
        return self.action_net.members(self.mlp_extractor.forward_actor(features))

    def member_mean(self, obs: torch.Tensor, k: int) -> torch.Tensor:
        """Actor k's action mean for a batch of observations: [batch, actions]."""
        features = self.extract_features(obs, self.pi_features_extractor)
        return self.action_net.heads[k](self.mlp_extractor.policy_net[k](features))

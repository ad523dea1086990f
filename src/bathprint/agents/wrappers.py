"""Residual control: a learned correction on top of a reference controller.

``FeedforwardResidual`` makes the agent's action a *correction*: the environment receives
``clip(a_ff(obs) + scale * a, -1, 1)``, where ``a_ff`` is the
:class:`~bathprint.agents.policies.FeedforwardPolicy` action for the last observation (residual
policy learning, Silver et al. 2018, "Residual policy learning", arXiv:1812.06298; Johannink
et al. 2019, ICRA: the agent starts at the feedforward controller and learns what the law
misses). Select it in ``agents/<algo>.yml`` in rl-zoo3's form (rl-zoo3 imports the class)::

    env_wrapper:
      - bathprint.agents.wrappers.FeedforwardResidual: {scale: 0.5, calibrated: true}

(older files: ``wrapper: {name: feedforward_residual, scale: 0.5}``); evaluation wraps the
environment the same way (read from the run's ``run.json``).

``ControllerResidual`` is the same on the tuned controller of the environment's shape family
(:func:`~bathprint.agents.controller.make_controller`; the strong reference of the shape
environments): ``clip(controller(obs) + scale * a, -1, 1)``, with a fresh controller each
episode (it keeps per-episode state and reads the environment it drives)::

    env_wrapper:
      - bathprint.agents.wrappers.ControllerResidual: {scale: 0.5}

The robustness options of the version-1 environments (:mod:`bathprint.envs.robust`: physics
drawn per episode, flow and observation noise) are selected the same way, by the class or
as ``wrapper: {name: robustness, bath_viscosity_spread: 0.2}``::

    env_wrapper:
      - bathprint.envs.robust.RobustnessWrapper: {bath_viscosity_spread: 0.2, flow_noise: 0.05}
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from bathprint.agents.policies import PAPER_PREFACTOR, FeedforwardPolicy

WRAPPERS = ("feedforward_residual", "controller_residual", "robustness")
#: the classes behind the names (rl-zoo3's ``env_wrapper`` names the class)
WRAPPER_CLASSES = {
    "bathprint.agents.wrappers.FeedforwardResidual": "feedforward_residual",
    "bathprint.agents.wrappers.ControllerResidual": "controller_residual",
    "bathprint.envs.robust.RobustnessWrapper": "robustness",
}


def _check_scale(scale: float) -> float:
    number = isinstance(scale, int | float) and not isinstance(scale, bool)
    if not (number and 0 < scale <= 2):
        raise ValueError(f"wrapper scale = {scale!r}; allowed: 0 < scale <= 2")
    return float(scale)


def _finite(action: np.ndarray) -> np.ndarray:
    a = np.asarray(action, np.float32)
    if not np.isfinite(a).all():
        raise ValueError(f"action {a!r} holds NaN or inf")
    return a


class _Residual(gym.Wrapper):
    """The environment's action = clip(base(obs) + scale * action, -1, 1); a subclass
    names the base policy (``_base``) and what a new episode resets (``_new_episode``)."""

    def __init__(self, env: gym.Env, scale: float) -> None:
        super().__init__(env)
        self.scale = _check_scale(scale)
        self._obs: np.ndarray | None = None

    def _base(self, obs: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _new_episode(self) -> None:
        """Called after the environment's reset, before the first step."""

    def reset(self, **kwargs: Any) -> tuple[np.ndarray, dict[str, Any]]:
        obs, info = self.env.reset(**kwargs)
        self._new_episode()
        self._obs = obs
        return obs, info

    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._obs is None:
            raise RuntimeError("call reset() before step()")
        a = _finite(action)
        full = np.clip(self._base(self._obs) + self.scale * a, -1.0, 1.0)
        obs, reward, terminated, truncated, info = self.env.step(full.astype(np.float32))
        self._obs = obs
        return obs, reward, terminated, truncated, info


class FeedforwardResidual(_Residual):
    """The environment's action = clip(feedforward(obs) + scale * action, -1, 1)."""

    def __init__(self, env: gym.Env, scale: float = 0.5, calibrated: bool = True) -> None:
        super().__init__(env, scale)
        prefactor = PAPER_PREFACTOR
        if calibrated:
            from bathprint.agents.hyperparams import load_baselines

            prefactor = float(load_baselines(env.spec.id)["feedforward_prefactor"])
        self.feedforward = FeedforwardPolicy(env, prefactor=prefactor)

    def _base(self, obs: np.ndarray) -> np.ndarray:
        return self.feedforward.action(obs)


class ControllerResidual(_Residual):
    """The environment's action = clip(controller(obs) + scale * action, -1, 1), the
    controller being the tuned one of the environment's family (module doc)."""

    def __init__(self, env: gym.Env, scale: float = 0.5) -> None:
        from bathprint.agents.controller import load_gains, make_controller
        from bathprint.envs.shape_files import env_family

        super().__init__(env, scale)
        self.family = env_family(env)
        self.gains = load_gains(self.family)  # read once; a fresh controller per episode
        self.controller = make_controller(env, self.family, self.gains)

    def _new_episode(self) -> None:
        from bathprint.agents.controller import make_controller

        self.controller = make_controller(self.env, self.family, self.gains)

    def _base(self, obs: np.ndarray) -> np.ndarray:
        return self.controller.predict(obs)[0]


def wrapper_spec(env_wrapper: Any) -> dict[str, Any] | None:
    """bathprint's wrapper entry (``{name: ..., **kwargs}``) of an rl-zoo3 ``env_wrapper``
    value: a class name, ``{class name: kwargs}``, or a list of one of those. Only the
    wrappers of this module are accepted (ValueError naming the value otherwise)."""
    if env_wrapper is None:
        return None
    items = env_wrapper if isinstance(env_wrapper, list) else [env_wrapper]
    allowed = ", ".join(WRAPPER_CLASSES)
    if len(items) != 1:
        raise ValueError(f"env_wrapper = {env_wrapper!r}; allowed: one wrapper ({allowed})")
    item = items[0]
    kwargs: Any = {}
    if isinstance(item, dict) and len(item) == 1:
        item, kwargs = next(iter(item.items()))
        kwargs = {} if kwargs is None else kwargs
    if not isinstance(item, str) or item not in WRAPPER_CLASSES or not isinstance(kwargs, dict):
        raise ValueError(
            f"env_wrapper = {env_wrapper!r}; allowed: {allowed} (a name, or a mapping of the "
            "name to its arguments)"
        )
    return {"name": WRAPPER_CLASSES[item], **kwargs}


def wrapper_class(name: str) -> type[gym.Wrapper]:
    """The class of a wrapper name of :data:`WRAPPERS` (ValueError naming it otherwise)."""
    if name == "robustness":
        from bathprint.envs.robust import RobustnessWrapper

        return RobustnessWrapper
    if name == "feedforward_residual":
        return FeedforwardResidual
    if name == "controller_residual":
        return ControllerResidual
    raise ValueError(f"wrapper name = {name!r}; allowed: {', '.join(WRAPPERS)}")


def wrapper_factory(spec: dict[str, Any] | None) -> Any:
    """A picklable ``env -> wrapped env`` from a ``wrapper:`` entry (None: no wrapper)."""
    import functools

    if not spec:
        return None
    spec = dict(spec)
    name = spec.pop("name", None)
    if name not in WRAPPERS:
        raise ValueError(f"wrapper name = {name!r}; allowed: {', '.join(WRAPPERS)}")
    return functools.partial(wrapper_class(name), **spec)

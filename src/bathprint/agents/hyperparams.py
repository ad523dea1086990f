"""Hyperparameter and baseline files of the agents (YAML, in the manner of rl-zoo3).

``agents/<algo>.yml`` maps an environment id to the settings of that algorithm on it::

    bathprint/CoilRadius-v0:
      n_timesteps: 300000      # default --timesteps
      n_envs: 2                # default --n-envs
      policy: MlpPolicy
      env_kwargs: {accuracy: draft}
      normalize: {norm_obs: false, norm_reward: true}   # VecNormalize, or false
      eval_freq: 10000         # environment steps between held-out evaluations
      eval_episodes: 16
      checkpoint_freq: 10000   # environment steps between checkpoints
      wrapper: {name: feedforward_residual, scale: 0.5}   # optional, see agents.wrappers
      learning_rate: 0.0003    # ... every other key goes to the algorithm's constructor
      policy_kwargs: {net_arch: [64, 64]}

``agents/baselines.yml`` holds what ``bathprint baselines fit`` found per environment: the
best constant action and the calibrated prefactor of the scaling law.

Files are read from ``$BATHPRINT_AGENTS_DIR`` if set, else from ``agents/`` at the root of
the source checkout.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path
from typing import Any

import yaml

from bathprint._resources import shared_dir

ALGOS = ("ppo", "sac")
#: keys read by bathprint itself; everything else is passed to the SB3 algorithm
RUN_KEYS = (
    "n_timesteps",
    "n_envs",
    "policy",
    "env_kwargs",
    "normalize",
    "eval_freq",
    "eval_episodes",
    "checkpoint_freq",
    "torch_threads",
    "wrapper",
)


def agents_dir() -> Path:
    """``$BATHPRINT_AGENTS_DIR``, the checkout's ``agents/``, or the installed copy
    (:func:`bathprint._resources.shared_dir`)."""
    return shared_dir("agents", "BATHPRINT_AGENTS_DIR")


def _read_yaml(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise FileNotFoundError(
            f"{str(path)!r} does not exist; set BATHPRINT_AGENTS_DIR to a directory holding "
            "the agents' YAML files (the repository's agents/)"
        )
    data = yaml.safe_load(path.read_text()) or {}
    if not isinstance(data, dict):
        raise ValueError(f"{path}: expected a mapping of environment id to settings")
    return data


def load_hyperparams(algo: str, env_id: str, path: str | Path | None = None) -> dict[str, Any]:
    """The settings of ``algo`` on ``env_id`` (a deep copy) from ``agents/<algo>.yml`` or
    from the file ``path`` (same layout, e.g. ``agents/ppo_residual.yml``)."""
    if algo not in ALGOS:
        raise ValueError(f"algo = {algo!r}; allowed: {', '.join(ALGOS)}")
    path = Path(path) if path is not None else agents_dir() / f"{algo}.yml"
    data = _read_yaml(path)
    if env_id not in data:
        raise ValueError(
            f"{path.name} has no entry for {env_id!r}; entries: {', '.join(sorted(data))}"
        )
    return copy.deepcopy(data[env_id])


def split_hyperparams(hp: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(bathprint's run settings, the algorithm's constructor kwargs)."""
    run = {k: hp[k] for k in RUN_KEYS if k in hp}
    algo = {k: v for k, v in hp.items() if k not in RUN_KEYS}
    return run, algo


def baselines_path() -> Path:
    return agents_dir() / "baselines.yml"


def load_baselines(env_id: str) -> dict[str, Any]:
    """The fitted baselines of ``env_id``: ``constant_action``, ``feedforward_prefactor``."""
    path = baselines_path()
    data = _read_yaml(path)
    if env_id not in data:
        raise ValueError(
            f"{path} has no entry for {env_id!r}: run `bathprint baselines fit --env {env_id}`"
        )
    return dict(data[env_id])


def save_baselines(env_id: str, entry: dict[str, Any], path: Path | None = None) -> Path:
    """Write (replace) the entry of ``env_id`` in ``baselines.yml``, keeping the others."""
    path = path or baselines_path()
    data = yaml.safe_load(path.read_text()) if path.is_file() else {}
    data = data or {}
    data[env_id] = json.loads(json.dumps(entry, default=float))  # plain floats for YAML
    header = (
        "# Fitted baselines per environment, written by `bathprint baselines fit` (see\n"
        "# bathprint.agents.fit): the best constant action (grid search on training targets)\n"
        "# and the scaling-law prefactor c in R = c (B/(mu v))^(1/3) fitted to this simulator.\n"
    )
    path.write_text(header + yaml.safe_dump(data, sort_keys=True, default_flow_style=None))
    return path

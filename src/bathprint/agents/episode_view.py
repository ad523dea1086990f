"""``bathprint view --env ENV --policy POLICY``: play one episode of a policy and write the
viewer's page of it (:mod:`bathprint.viz.view`), its target drawn beside the printed
filament.

The policy is a baseline name, a trained run directory or a model ``.zip``, as ``bathprint
evaluate`` takes; a trained one plays on the environment settings and wrapper it was
trained with (:func:`bathprint.agents.evaluate.run_settings`).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import OptionError
from bathprint.viz.view import RecordEpisode, format_value, write_page

__all__ = ["episode_page"]


def episode_page(
    env_id: str,
    policy: str = "random",
    out: str | Path = "episode.html",
    seed: int = 0,
    target_index: int = 0,
    accuracy: str | None = None,
) -> tuple[Path, dict[str, Any]]:
    """Play one deterministic episode of ``policy`` (a baseline name, a run directory or a
    model ``.zip``) on held-out target ``target_index`` (version 0's evaluation set, a later
    version's test set) and write its page; returns the path and the last step's info."""
    from bathprint.agents.evaluate import default_target_set, run_settings
    from bathprint.agents.policies import load_policy
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make, resolve_id, target_set_size

    try:
        env_id = resolve_id(env_id)
    except ValueError as exc:
        raise OptionError(f"--env = {env_id!r}: {exc}") from None
    kwargs, wrapper = run_settings(policy, accuracy, env_id)
    target_set = default_target_set(env_id)
    env = make(env_id, target_set=target_set, **kwargs)
    try:
        if wrapper:
            env = wrapper_factory(wrapper)(env)
        n_eval = target_set_size(env.unwrapped, target_set)
        if not 0 <= target_index < n_eval:
            raise OptionError(
                f"--target-index = {target_index}; the {target_set} set of {env_id} "
                f"has {n_eval} targets: allowed 0..{n_eval - 1}"
            )
        try:
            pol, label = load_policy(policy, env, env_id, seed=seed)
        except FileNotFoundError as exc:
            raise OptionError(f"--policy = {policy!r}: {exc}") from None
        rec = RecordEpisode(env)
        obs, info = env.reset(seed=seed, options={"target_index": target_index})
        rec.capture(info)
        state, start, done = None, np.ones(1, bool), False
        ret = 0.0
        while not done:
            action, state = pol.predict(obs, state=state, episode_start=start, deterministic=True)
            start = np.zeros(1, bool)
            obs, reward, terminated, truncated, info = env.step(action)
            ret += float(reward)
            done = bool(terminated or truncated)
            rec.capture(info)
        data = rec.view_data(
            env_id,
            extra=[
                ("policy", label),
                ("seed", str(seed)),
                ("target index", str(target_index)),
                ("return", format_value(ret)),
            ],
        )
        info = dict(info)
        info["return"] = ret
    finally:
        env.close()
    return write_page(data, Path(out)), info

"""``bathprint view --env ENV --policy POLICY``: play one episode of a policy and write the
viewer's page of it (:mod:`bathprint.viz.view`), its target drawn beside the printed
filament.

The policy is a baseline name, a trained run directory or a model ``.zip``, as ``bathprint
evaluate`` takes; a trained one plays on the environment settings and wrapper it was
trained with (:func:`bathprint.agents.evaluate.run_settings`). :func:`play_recorded` plays
and records an episode on an environment already made (``bathprint write`` uses it with a
target of its own).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import OptionError
from bathprint.viz.view import RecordEpisode, format_value, write_page

__all__ = ["RecordedEpisode", "episode_page", "play_recorded"]


@dataclass
class RecordedEpisode:
    """One deterministic episode played by :func:`play_recorded`: its recording (for the
    viewer's page), the last step's info, the return, the number of steps and the wall time
    of the episode (reset to end, the policy's planning included)."""

    record: RecordEpisode
    info: dict[str, Any]
    ret: float
    steps: int
    wall_s: float


def play_recorded(
    env: Any, policy: Any, seed: int = 0, options: dict[str, Any] | None = None
) -> RecordedEpisode:
    """Play one deterministic episode of ``policy`` (SB3's ``predict``) on ``env`` from
    ``reset(seed=seed, options=options)`` to its end, recording every step."""
    rec = RecordEpisode(env)
    t0 = time.perf_counter()
    obs, info = env.reset(seed=seed, options=options)
    rec.capture(info)
    state, start, done = None, np.ones(1, bool), False
    ret, steps = 0.0, 0
    while not done:
        action, state = policy.predict(obs, state=state, episode_start=start, deterministic=True)
        start = np.zeros(1, bool)
        obs, reward, terminated, truncated, info = env.step(action)
        ret += float(reward)
        steps += 1
        done = bool(terminated or truncated)
        rec.capture(info)
    return RecordedEpisode(rec, dict(info), ret, steps, time.perf_counter() - t0)


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
        ep = play_recorded(env, pol, seed, {"target_index": target_index})
        ret = ep.ret
        data = ep.record.view_data(
            env_id,
            extra=[
                ("policy", label),
                ("seed", str(seed)),
                ("target index", str(target_index)),
                ("return", format_value(ret)),
            ],
        )
        info = ep.info
        info["return"] = ret
    finally:
        env.close()
    return write_page(data, Path(out)), info

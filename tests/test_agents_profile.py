"""`python -m bathprint.agents.profile`: where a training step's time goes, with the
hindsight rewards of HER (the goal environment's compute_reward) apart from the gradient
steps they are computed in."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from bathprint.agents.profile import CATEGORIES, format_profile, profile_training

AGENTS = Path(__file__).resolve().parents[1] / "agents"


def test_the_profile_of_tqc_with_hindsight_replay_splits_out_the_hindsight_rewards(
    tmp_path,
) -> None:
    env_id = "bathprint/CoilRadius-v1"
    hp = yaml.safe_load((AGENTS / "tqc_her.yml").read_text())
    tiny = {
        **hp[env_id],
        "learning_starts": 100,  # past the first episode (about 80 steps): HER needs one
        "batch_size": 16,
        "buffer_size": 1000,
        "gradient_steps": 1,
        "policy_kwargs": {"net_arch": [16, 16], "n_critics": 2},
    }
    path = tmp_path / "tqc_tiny.yml"
    bathprint = {"default": {**hp["bathprint"]["default"], "eval_freq": 10**9}}
    path.write_text(yaml.safe_dump({env_id: tiny, "bathprint": bathprint}))
    rec = profile_training("tqc", env_id, path, 180)
    assert rec["timesteps"] >= 180
    seconds = rec["seconds"]
    assert set(seconds) == set(CATEGORIES)
    assert seconds["hindsight rewards"] > 0.0  # HER relabels through compute_reward
    assert seconds["policy update"] > 0.0
    assert seconds["simulation"] > 0.0
    for key in CATEGORIES:  # each a part of the wall time (timer overhead aside)
        assert seconds[key] >= -0.02 * rec["wall_time_s"], (key, seconds[key])
    assert sum(seconds.values()) == pytest.approx(rec["wall_time_s"], rel=1e-9)
    assert "hindsight rewards" in format_profile(rec)

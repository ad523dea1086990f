"""Slim model files (bathprint.agents.slim): the optimisers' state goes, the weights stay
bit for bit, the file still loads with SB3's load and fine-tunes; the per-run training curve
is drawn again byte for byte from the files an export keeps (bathprint.agents.curves)."""

from __future__ import annotations

import gzip
import json
import os
import shutil
import zipfile

import numpy as np
import pytest
import torch

from bathprint.agents import slim
from bathprint.agents.curves import main as curves_main
from bathprint.agents.ensemble import EnsembleMlpPolicy
from bathprint.agents.evaluate import evaluate_policy_spec
from bathprint.agents.hyperparams import load_hyperparams
from bathprint.agents.train import train

ENV = "bathprint/CoilRadius-v0"


def _tiny_model(algo: str):
    """A model trained for a few updates on Pendulum (its optimisers hold state)."""
    from sb3_contrib import TQC
    from stable_baselines3 import PPO, SAC

    kw = {"seed": 0, "device": "cpu", "policy_kwargs": {"net_arch": [16, 16]}}
    if algo in ("ppo", "ensemble"):
        policy = EnsembleMlpPolicy if algo == "ensemble" else "MlpPolicy"
        if algo == "ensemble":
            kw["policy_kwargs"]["members"] = 3
        model = PPO(policy, "Pendulum-v1", n_steps=64, batch_size=32, n_epochs=1, **kw)
    else:
        cls = SAC if algo == "sac" else TQC
        if algo == "tqc":
            kw["policy_kwargs"]["n_quantiles"] = 5
        model = cls("MlpPolicy", "Pendulum-v1", learning_starts=32, batch_size=16,
                    buffer_size=1000, **kw)  # fmt: skip
    return model.learn(96)


def _algo_class(algo: str):
    from sb3_contrib import TQC
    from stable_baselines3 import PPO, SAC

    return {"ppo": PPO, "ensemble": PPO, "sac": SAC, "tqc": TQC}[algo]


def _optimizers(model) -> dict[str, torch.optim.Optimizer]:
    names = model._get_torch_save_params()[0]
    out = {}
    for name in names:
        obj = model
        for part in name.split("."):
            obj = getattr(obj, part)
        if isinstance(obj, torch.optim.Optimizer):
            out[name] = obj
    return out


@pytest.mark.parametrize("algo", ["ppo", "ensemble", "sac", "tqc"])
def test_slimming_keeps_the_weights_and_the_actions(algo, tmp_path):
    model = _tiny_model(algo)
    path = tmp_path / "model.zip"
    model.save(path)
    before = path.stat().st_size
    optimizers = _optimizers(model)
    assert optimizers and all(o.state_dict()["state"] for o in optimizers.values())
    obs = np.random.default_rng(0).uniform(-1, 1, (64, 3)).astype(np.float32)
    actions = model.predict(obs, deterministic=True)[0]

    result = slim.slim_model(path)
    assert set(result.dropped) == {f"{name}.pth" for name in optimizers}
    assert result.bytes_after == path.stat().st_size < before / 2  # Adam: two moments a weight

    loaded = _algo_class(algo).load(path, device="cpu")  # exact_match: every state dict there
    for name, opt in _optimizers(loaded).items():
        assert opt.state_dict()["state"] == {}
        assert opt.state_dict()["param_groups"] == optimizers[name].state_dict()["param_groups"]
    want, got = model.policy.state_dict(), loaded.policy.state_dict()
    assert list(want) == list(got)
    assert all(torch.equal(want[k], got[k]) for k in want)
    assert np.array_equal(loaded.predict(obs, deterministic=True)[0], actions)
    record = json.loads(slim.record_path(path).read_text())
    assert set(record["dropped"]) == set(result.dropped) and record["bytes_before"] == before
    with zipfile.ZipFile(path) as z:
        kept = z.read("policy.pth")
    assert record["members_kept_sha256"]["policy.pth"] == slim._sha256(kept)

    again = slim.slim_model(path)  # slim already: the file is left as it is
    assert not again.changed and again.bytes_after == result.bytes_after
    loaded.set_env(model.get_env())
    loaded.learn(64)  # fine-tuning starts Adam's moments afresh
    assert all(o.state_dict()["state"] for o in _optimizers(loaded).values())


def test_a_failed_slimming_leaves_the_file(tmp_path, monkeypatch):
    path = tmp_path / "model.zip"
    _tiny_model("ppo").save(path)
    data = path.read_bytes()

    def fail(*args: object) -> None:
        raise OSError("disk full")

    monkeypatch.setattr(slim.os, "replace", fail)
    with pytest.raises(OSError, match="disk full"):
        slim.slim_model(path)
    assert path.read_bytes() == data and os.listdir(tmp_path) == ["model.zip"]
    with pytest.raises(ValueError, match="not a Stable-Baselines3 model"):
        slim.slim_model(tmp_path / "nothing.zip")


def test_an_evaluation_is_the_same_before_and_after(tmp_path):
    hp = load_hyperparams("ppo", ENV)
    hp.update(eval_freq=160, eval_episodes=1, checkpoint_freq=160, n_envs=1, n_steps=80,
              batch_size=40, n_epochs=1)  # fmt: skip
    run = train("ppo", ENV, timesteps=160, out=tmp_path / "run", hyperparams=hp, progress=False)
    assert (run / "eval" / "best_model.zip").is_file()
    _, before, _ = evaluate_policy_spec(str(run), ENV, episodes=1, progress=False)
    assert slim.slim_model(run / "eval" / "best_model.zip").dropped
    _, after, _ = evaluate_policy_spec(str(run), ENV, episodes=1, progress=False)
    keys = [k for k in before if k != "wall_time_s"]
    assert {k: before[k] for k in keys} == {k: after[k] for k in keys}


def test_the_command_slims_a_folder_and_reports_sizes(tmp_path, capsys):
    run = tmp_path / "results" / "Env" / "ppo" / "seed0"
    (run / "eval").mkdir(parents=True)
    _tiny_model("ppo").save(run / "eval" / "best_model.zip")
    (run / "run.json").write_text("{}")
    (run / "episodes.csv.gz").write_bytes(gzip.compress(b"timesteps,metric\n"))
    (run / "training_curve.png").write_bytes(b"png")
    lone = tmp_path / "results" / "Env" / "curve_only" / "training_curve.png"
    lone.parent.mkdir(parents=True)
    lone.write_bytes(b"png")  # no run.json beside it: nothing draws it again, it stays

    root = str(tmp_path / "results")
    assert slim.main([root, "--check", "--drop-curves"]) == 1
    assert "optimiser state in policy.optimizer.pth" in capsys.readouterr().out
    assert slim.main([root, "--drop-curves"]) == 0
    out = capsys.readouterr().out
    assert "(policy.optimizer.pth)" in out and "| model zip |" in out and "| png |" in out
    assert not (run / "training_curve.png").exists() and lone.exists()
    assert (run / "eval" / "best_model.slim.json").is_file()
    assert slim.main([root, "--check", "--drop-curves"]) == 0
    assert slim.main([str(tmp_path / "missing")]) == 2


def test_the_training_curve_is_drawn_again_from_the_gzipped_log(tmp_path):
    run = tmp_path / "run"
    (run / "eval").mkdir(parents=True)
    (run / "run.json").write_text(json.dumps(
        {"algo": "ppo", "env_id": "bathprint/CoilRadius-v1", "seed": 0, "wall_time_s": 12.0}
    ))  # fmt: skip
    rows = ["timesteps,metric"] + [f"{80 * k},{1 / (k + 1):.6f}" for k in range(1, 40)]
    (run / "episodes.csv").write_text("\n".join(rows) + "\n")
    np.savez(run / "eval" / "evaluations.npz", timesteps=np.array([800, 1600]),
             results=np.array([[0.1, 0.2], [0.3, 0.2]]))  # fmt: skip
    assert curves_main([str(run)]) == 0
    drawn = (run / "training_curve.png").read_bytes()
    with gzip.open(run / "episodes.csv.gz", "wb") as f:  # as an export keeps it
        f.write((run / "episodes.csv").read_bytes())
    (run / "episodes.csv").unlink()
    (run / "training_curve.png").unlink()
    assert curves_main([str(run)]) == 0
    assert (run / "training_curve.png").read_bytes() == drawn
    shutil.rmtree(run / "eval")
    assert curves_main([str(tmp_path / "nowhere")]) == 2

"""A campaign keeps a test evaluation only for the model that made it."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

from bathprint.agents import campaign, evaluate


def _zip(path: Path, policy: bytes, optimizer: bytes) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w") as z:
        z.writestr("policy.pth", policy)
        z.writestr("policy.optimizer.pth", optimizer)
    return path


def test_fingerprint_follows_the_weights_and_statistics_not_the_optimiser(tmp_path):
    a = _zip(tmp_path / "a" / "best_model.zip", b"weights", b"adam")
    b = _zip(tmp_path / "b" / "best_model.zip", b"weights", b"")  # slimmed
    c = _zip(tmp_path / "c" / "best_model.zip", b"other weights", b"adam")
    fa = campaign.model_fingerprint(str(a))
    assert fa == campaign.model_fingerprint(str(b)) != campaign.model_fingerprint(str(c))
    (a.parent / "vecnormalize.pkl").write_bytes(b"stats")
    assert campaign.model_fingerprint(str(a)) != fa
    assert campaign.model_fingerprint("controller") is None


def test_an_evaluation_of_another_model_is_played_again(tmp_path, monkeypatch):
    calls = []

    def fake(policy, env_id, episodes, seed, out, **kw):
        calls.append(policy)
        d = Path(out) / "p"
        d.mkdir(parents=True, exist_ok=True)
        (d / "episodes.csv").write_text("seed\n0\n")
        summary = {"episodes": episodes, "target_set": kw["target_set"], "seed": seed}
        (d / "summary.json").write_text(json.dumps(summary))

    monkeypatch.setattr(evaluate, "evaluate_policy_spec", fake)
    model = _zip(tmp_path / "run" / "eval" / "best_model.zip", b"w1", b"adam")
    env = "bathprint/CoilRadius-v2"
    campaign.evaluate_one(str(model), env, tmp_path / "test", 2, 0)
    campaign.evaluate_one(str(model), env, tmp_path / "test", 2, 0)  # kept
    assert len(calls) == 1
    _zip(model, b"w2", b"adam")  # trained further: a new best model
    campaign.evaluate_one(str(model), env, tmp_path / "test", 2, 0)
    assert len(calls) == 2
    summary = json.loads((tmp_path / "test" / "p" / "summary.json").read_text())
    assert summary["model_fingerprint"] == campaign.model_fingerprint(str(model))

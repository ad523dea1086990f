"""Agents: tiny end-to-end training with checkpoints, interruption and resume; evaluation
determinism; every baseline on every environment; the feedforward controller against the
scaling law (bathprint.analysis.theory, an independent implementation)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bathprint.agents import train as train_mod
from bathprint.agents.evaluate import evaluate_many, evaluate_policy_spec
from bathprint.agents.fit import fit_baselines
from bathprint.agents.hyperparams import load_baselines, load_hyperparams
from bathprint.agents.policies import (
    BASELINES,
    FeedforwardPolicy,
    LawConstants,
    law_q_outer_ml_min,
)
from bathprint.agents.train import checkpoints, train
from bathprint.analysis.theory import bending_stiffness, coil_radius
from bathprint.cli import main as cli_main
from bathprint.envs import ENV_IDS, make
from bathprint.envs.observation import (
    OBS_CURVATURE_MM,
    OBS_DENSITY_REF_KG_M3,
    OBS_DENSITY_SCALE_KG_M3,
    OBS_SIZE,
    TARGET_OFFSETS_MM,
    obs_slices,
)
from bathprint.envs.targets import helix_curvature_torsion

ENV = "bathprint/CoilRadius-v0"


def _tiny(algo: str) -> dict:
    hp = load_hyperparams(algo, ENV)
    hp.update(eval_freq=160, eval_episodes=1, checkpoint_freq=160, n_envs=1)
    if algo == "ppo":
        hp.update(n_steps=80, batch_size=40, n_epochs=2)
    else:
        hp.update(learning_starts=80, buffer_size=2000, batch_size=32, gradient_steps=1)
    return hp


@pytest.mark.parametrize("algo", ["ppo", "sac"])
def test_tiny_training_checkpoints_resumes_and_evaluates(algo, tmp_path):
    out = tmp_path / algo
    run = train(algo, ENV, timesteps=320, out=out, hyperparams=_tiny(algo), progress=False)
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "done" and info["timesteps_done"] >= 320
    assert [n for n, _ in checkpoints(run)] == [160, 320]
    assert (run / "final_model.zip").is_file() and (run / "training_curve.png").is_file()
    if algo == "ppo":  # VecNormalize statistics travel with the checkpoints
        assert (run / "checkpoints" / "model_vecnormalize_160_steps.pkl").is_file()
    else:  # and the replay buffer, for SAC
        assert (run / "checkpoints" / "model_replay_buffer_160_steps.pkl").is_file()
    assert any((run / "tb").rglob("events.out.tfevents*"))
    with pytest.raises(FileExistsError):  # never overwrites a run by accident
        train(algo, ENV, timesteps=320, out=out, hyperparams=_tiny(algo), progress=False)

    train(algo, ENV, timesteps=480, out=out, resume=True, progress=False)
    info = json.loads((run / "run.json").read_text())
    assert info["timesteps_done"] >= 480
    with np.load(run / "eval" / "evaluations.npz") as d:  # the pre-resume evaluations kept
        assert list(d["timesteps"]) == [160, 320, 480]
    episodes = train_mod.read_episodes(run)
    assert [r["timesteps"] for r in episodes] == sorted(r["timesteps"] for r in episodes)
    assert len(episodes) == 6 and all(r["episode_length"] == 80 for r in episodes)

    label, summary, eps = evaluate_policy_spec(str(run), ENV, episodes=1, progress=False)
    assert label.startswith(f"{algo}:") and len(eps) == 1 and eps[0].length == 80
    assert math.isfinite(summary["mean_metric"])


def test_interrupted_training_saves_a_checkpoint_and_resumes(tmp_path, monkeypatch):
    from stable_baselines3.common.callbacks import BaseCallback

    class Interrupt(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps >= 200:
                raise KeyboardInterrupt
            return True

    make_callbacks = train_mod._make_callbacks
    monkeypatch.setattr(
        train_mod, "_make_callbacks", lambda *a, **k: [*make_callbacks(*a, **k), Interrupt()]
    )
    out = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        train("ppo", ENV, timesteps=320, out=out, hyperparams=_tiny("ppo"), progress=False)
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted"
    steps = [n for n, _ in checkpoints(out)]
    assert steps == [160, 200]  # the regular one and the one saved on Ctrl-C: nothing lost
    monkeypatch.setattr(train_mod, "_make_callbacks", make_callbacks)
    train("ppo", ENV, out=out, resume=True, progress=False)
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "done" and info["timesteps_done"] >= 320


def test_evaluation_is_deterministic(tmp_path):
    for spec in ("random", "feedforward"):
        a = evaluate_policy_spec(spec, ENV, episodes=2, seed=3, progress=False)[1]
        b = evaluate_policy_spec(spec, ENV, episodes=2, seed=3, progress=False)[1]
        for key in ("mean_metric", "mean_shape_rms_mm", "mean_curvature_rms_1_mm", "mean_reward"):
            assert a[key] == b[key], (spec, key)
    a = evaluate_policy_spec("random", ENV, episodes=2, seed=3, progress=False)[1]
    c = evaluate_policy_spec("random", ENV, episodes=2, seed=4, progress=False)[1]
    assert c["mean_metric"] != a["mean_metric"]  # the seed does reach the policy


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_every_baseline_runs_on_every_environment(env_id, tmp_path):
    summaries = evaluate_many(
        BASELINES, env_id, episodes=1, out=tmp_path, images=1, animate=False, progress=False
    )
    assert [s["policy"] for s in summaries] == list(BASELINES)
    for s in summaries:
        assert math.isfinite(s["mean_metric"]) and s["mean_episode_length"] > 0
        assert (tmp_path / s["policy"] / "episodes.csv").is_file()
        assert (tmp_path / s["policy"] / "episode_0.png").is_file()
    assert "| feedforward |" in (tmp_path / "table.md").read_text()


def test_fitted_baselines_file_has_every_environment():
    for env_id in ENV_IDS:
        entry = load_baselines(env_id)
        assert len(entry["constant_action"]) == make(env_id).action_space.shape[0]
        assert 0.1 < entry["feedforward_prefactor"] < 2.0


def test_fit_baselines_picks_the_best_grid_action():
    entry = fit_baselines(ENV, n_targets=1, grid_q_outer=3, grid_q_inner=1, progress=False)
    grid = entry["grid"]
    assert len(grid) == 3
    best = min(grid, key=lambda r: r["mean_metric"])
    assert entry["constant_action"] == best["action"]
    assert entry["constant_mean_metric"] == best["mean_metric"]
    # coils shrink as the flow grows (the scaling law's sign), and the prefactor is the
    # geometric mean of what was measured
    radii = [r["coil_radius_mm"] for r in grid]
    assert radii[0] > radii[1] > radii[2]
    assert 0.2 < entry["feedforward_prefactor"] < 1.0


def _obs_with_target(env, kappa_1_mm: float, tau_1_mm: float, rho_aim: float) -> np.ndarray:
    obs = np.zeros(OBS_SIZE, np.float32)
    feats = obs[obs_slices()["target_curvature_torsion_density"]].reshape(-1, 3)
    col = TARGET_OFFSETS_MM.index(0.0)
    feats[col] = [
        kappa_1_mm * OBS_CURVATURE_MM,
        tau_1_mm * OBS_CURVATURE_MM,
        (rho_aim - OBS_DENSITY_REF_KG_M3) / OBS_DENSITY_SCALE_KG_M3,
    ]
    obs[obs_slices()["target_curvature_torsion_density"]] = feats.ravel()
    return obs


@pytest.mark.parametrize("radius_mm", [2.5, 3.0, 4.0])
def test_feedforward_q_outer_inverts_the_scaling_law(radius_mm):
    env = make(ENV, accuracy="draft")
    ff = FeedforwardPolicy(env)
    c = LawConstants.from_env(env)
    k, t = helix_curvature_torsion(np.array([radius_mm]), np.array([1.0]))
    ctl = ff.controls(_obs_with_target(env, float(k[0]), float(t[0]), c.rho_gel))
    qo = ctl["q_outer_ml_min"]
    lo, hi = env.unwrapped.q_outer_range
    assert lo < qo < hi  # inside the range, so not clipped
    assert ctl["q_inner_ml_min"] == 0.0  # pure gel: the density is free
    # independent check with bathprint.analysis.theory: R = 0.4 (B / (mu v))^(1/3) at this Q_o
    v = qo * 1e-6 / 60.0 / c.needle_area
    B = bending_stiffness(30000.0, c.filament_radius)  # set gel of gelation_coiling_22G
    assert coil_radius(B, 1.0e-3, v, 0.4) * 1e3 == pytest.approx(radius_mm, rel=1e-3)
    # and the action it sends decodes to that Q_o
    decoded = env.unwrapped.action_to_controls(ff.action(_obs_with_target(env, k[0], t[0], 1e4)))
    assert decoded["q_outer_ml_min"] == pytest.approx(qo, rel=1e-5)


def test_feedforward_sets_the_inner_fraction_for_the_density_aim():
    env = make("bathprint/WriteShape-v0", accuracy="draft")
    ff = FeedforwardPolicy(env)
    c = LawConstants.from_env(env)
    k, t = helix_curvature_torsion(np.array([3.0]), np.array([1.0]))
    aim = c.rho_gel - 20.0
    ctl = ff.controls(_obs_with_target(env, float(k[0]), float(t[0]), aim))
    phi = ctl["q_inner_ml_min"] / (ctl["q_outer_ml_min"] + ctl["q_inner_ml_min"])
    assert (1 - phi) * c.rho_gel + phi * c.rho_inner == pytest.approx(aim, rel=1e-9)
    # the observation is float32, so the radius read back carries ~1e-7 relative error
    assert ctl["q_outer_ml_min"] == pytest.approx(law_q_outer_ml_min(3.0e-3, phi, c), rel=1e-6)
    # the softer composite needs a slower jet for the same radius
    assert ctl["q_outer_ml_min"] < law_q_outer_ml_min(3.0e-3, 0.0, c)


def test_cli_errors_name_the_problem(tmp_path, capsys):
    assert cli_main(["evaluate", "no_such_policy", "--env", "CoilRadius-v0"]) == 2
    assert "no_such_policy" in capsys.readouterr().err
    assert cli_main(["train", "--algo", "ppo", "--env", "CoilRadius-v0", "--timesteps", "0"]) == 2
    assert cli_main(["baselines", "show", "--env", "CoilRadius-v0"]) == 0
    assert "feedforward_prefactor" in capsys.readouterr().out


def test_residual_wrapper_starts_at_the_feedforward_action():
    from bathprint.agents.wrappers import wrapper_factory

    base = make(ENV, accuracy="draft")
    wrapped = wrapper_factory({"name": "feedforward_residual", "scale": 0.5})(
        make(ENV, accuracy="draft")
    )
    obs_b, _ = base.reset(seed=5)
    obs_w, _ = wrapped.reset(seed=5)
    ff = wrapped.feedforward
    for _ in range(3):  # a zero correction is the feedforward controller itself
        a = ff.action(obs_b)
        obs_b, r_b, *_ = base.step(a)
        obs_w, r_w, *_ = wrapped.step(np.zeros(2, np.float32))
        np.testing.assert_array_equal(obs_b, obs_w)
        assert r_b == r_w
    with pytest.raises(ValueError, match="NaN"):
        wrapped.step(np.array([np.nan, 0.0], np.float32))
    with pytest.raises(ValueError, match="wrapper name"):
        wrapper_factory({"name": "nope"})


def test_evaluations_into_one_directory_add_up_to_one_table(tmp_path):
    kw = dict(episodes=1, out=tmp_path, images=0, animate=False, progress=False)
    evaluate_many(["feedforward"], ENV, **kw)
    evaluate_many(["random"], ENV, **kw)
    rows = [ln for ln in (tmp_path / "table.md").read_text().splitlines() if ln.startswith("| ")]
    assert [r.split("|")[1].strip() for r in rows[1:]] == ["random", "feedforward"]

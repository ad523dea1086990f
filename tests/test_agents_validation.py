"""Bad settings are refused before any work, with one line naming the parameter, the value
and what is allowed (exit code 2, no traceback, no run folder); nothing is silently changed:
hyperparameter files, environment arguments, run folders and run.json, ``play`` and
``evaluate`` values, missing VecNormalize statistics."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import yaml

from bathprint.agents import train as train_mod
from bathprint.agents.evaluate import evaluate_policy_spec
from bathprint.agents.hyperparams import load_hyperparams
from bathprint.agents.train import checkpoints, train
from bathprint.cli import main as cli_main
from bathprint.envs import make
from bathprint.errors import ConfigError

ENV = "bathprint/CoilRadius-v0"


def _tiny(**extra) -> dict:
    """PPO on one environment, an update every 80 steps (one episode)."""
    hp = load_hyperparams("ppo", ENV)
    hp.update(eval_freq=160, eval_episodes=1, checkpoint_freq=160, n_envs=1)
    hp.update(n_steps=80, batch_size=40, n_epochs=2)
    hp.update(extra)
    return hp


def _write_hp(tmp_path: Path, hp: dict, name: str = "hp.yml") -> Path:
    path = tmp_path / name
    path.write_text(yaml.safe_dump({ENV: hp}))
    return path


def _refused(capsys, argv: list[str], *needles: str) -> str:
    """Run the CLI; assert exit code 2 and a one-line message holding every needle."""
    assert cli_main(argv) == 2
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bathprint "), err
    assert "Traceback" not in err
    for needle in needles:
        assert needle in err, (needle, err)
    return err


def _train_argv(hp_file: Path, out: Path, *extra: str) -> list[str]:
    return [
        "train",
        "--algo",
        "ppo",
        "--env",
        "CoilRadius-v0",
        "--hyperparams",
        str(hp_file),
        "--out",
        str(out),
        "--quiet",
        *extra,
    ]


# --------------------------------------------------------------- hyperparameter files
def test_a_misspelt_hyperparameter_is_refused_before_the_run_folder_exists(tmp_path, capsys):
    hp = _tiny()
    hp["learning_ratee"] = hp.pop("learning_rate")
    out = tmp_path / "run"
    _refused(
        capsys,
        _train_argv(_write_hp(tmp_path, hp), out),
        "unknown ppo key 'learning_ratee'",
        "did you mean 'learning_rate'?",
    )
    assert not out.exists()


def test_a_yaml_syntax_error_names_the_file_and_the_line(tmp_path, capsys):
    path = tmp_path / "broken.yml"
    path.write_text(f"{ENV}:\n  n_steps: [80\n  batch_size: 40\n")
    out = tmp_path / "run"
    _refused(capsys, _train_argv(path, out), "broken.yml", "not valid YAML", "line 3")
    assert not out.exists()


def test_a_key_written_twice_is_refused(tmp_path, capsys):
    path = tmp_path / "twice.yml"
    path.write_text(f"{ENV}:\n  n_steps: 80\n  batch_size: 40\n  n_steps: 160\n")
    _refused(capsys, _train_argv(path, tmp_path / "run"), "'n_steps' appears twice", "line 4")


def test_merge_keys_may_be_overridden():
    """agents/ppo.yml's entries share settings through ``<<: *anchor``: not duplicates."""
    hp = load_hyperparams("ppo", "bathprint/WriteShape-v0")
    assert hp["n_steps"] == load_hyperparams("ppo", ENV)["n_steps"]


@pytest.mark.parametrize(
    ("key", "value", "needles"),
    [
        ("learning_rate", "3e-4", ["learning_rate = '3e-4' (str)", "write 3.0e-4"]),
        ("n_steps", 80.5, ["n_steps = 80.5", "expected an integer"]),
        ("gamma", 1.5, ["gamma = 1.5", "allowed: a number in (0, 1]"]),
        ("clip_range", -0.2, ["clip_range = -0.2", "allowed: a number > 0"]),
        ("n_envs", 0, ["n_envs = 0", "an integer >= 1"]),
        ("checkpoint_freq", 1e3, ["checkpoint_freq = 1000.0", "an integer >= 1"]),
        ("policy", "LstmPolicy", ["policy = 'LstmPolicy'", "MlpPolicy"]),
        ("seed", 3, ["seed = 3", "bathprint sets seed itself"]),
        ("device", "cuda", ["device = 'cuda'", "bathprint sets device itself"]),
        ("normalize", True, ["normalize = True", "expected false or a mapping"]),
        ("normalize", {"norm_rewards": True}, ["'norm_rewards'", "did you mean 'norm_reward'"]),
        ("normalize", {"gamma": 2.0}, ["normalize.gamma = 2.0", "a number in (0, 1]"]),
        ("policy_kwargs", {"net_arhc": [64]}, ["'net_arhc'", "did you mean 'net_arch'"]),
        ("policy_kwargs", {"log_std_init": "low"}, ["log_std_init = 'low'", "a number"]),
        ("env_kwargs", "draft", ["env_kwargs = 'draft'", "expected a mapping"]),
        ("env_kwargs", {"acuracy": "draft"}, ["'acuracy'", "did you mean 'accuracy'"]),
        ("env_kwargs", {"target_set": "eval"}, ["env_kwargs.target_set", "sets it itself"]),
        ("wrapper", {"name": "feedback"}, ["wrapper = {'name': 'feedback'}", "feedforward"]),
        ("wrapper", {"name": "feedforward_residual", "scale": 5.0}, ["scale = 5.0"]),
        ("eval_episodes", 17, ["eval_episodes = 17", "16 targets", "allowed 1..16"]),
        ("batch_size", 1, ["PPO refuses these settings", "batch_size"]),
    ],
)
def test_bad_hyperparameter_values_are_refused(tmp_path, capsys, key, value, needles):
    out = tmp_path / "run"
    _refused(capsys, _train_argv(_write_hp(tmp_path, _tiny(**{key: value})), out), *needles)
    assert not out.exists()


def test_sac_keys_are_checked_against_sac(tmp_path, capsys):
    hp = load_hyperparams("sac", ENV)
    hp["n_epochs"] = 2  # a PPO argument
    argv = [
        "train",
        "--algo",
        "sac",
        "--env",
        "CoilRadius-v0",
        "--hyperparams",
        str(_write_hp(tmp_path, hp)),
        "--out",
        str(tmp_path / "run"),
    ]
    _refused(capsys, argv, "unknown sac key 'n_epochs'")


def test_validation_is_a_config_error_in_the_api(tmp_path):
    with pytest.raises(ConfigError, match="learning_ratee"):
        train("ppo", ENV, out=tmp_path / "r", hyperparams={**_tiny(), "learning_ratee": 1.0})
    with pytest.raises(ConfigError, match="timesteps = 0"):
        train("ppo", ENV, timesteps=0, out=tmp_path / "r", hyperparams=_tiny())
    assert not (tmp_path / "r").exists()


# ---------------------------------------------------------------- environment kwargs
@pytest.mark.parametrize(
    ("overrides", "needles"),
    [
        ({"control": {"length_mm": -1.0}}, ["control.length_mm = -1.0", "a number > 0"]),
        ({"control": {"length_mm": "1 mm"}}, ["control.length_mm = '1 mm'", "a number > 0"]),
        ({"episode": {"settle_length_mm": -5}}, ["episode.settle_length_mm = -5", ">= 0"]),
        ({"episode": {"start_states": 2.5}}, ["episode.start_states = 2.5", "an integer >= 1"]),
        ({"target": {"eval_size": 0}}, ["target.eval_size = 0", "an integer >= 1"]),
        ({"metric": {"w_shape": -1}}, ["metric.w_shape = -1", ">= 0"]),
        ({"metric": {"allow_reflection": "yes"}}, ["allow_reflection = 'yes'"]),
        ({"control": {"q_inner_ml_min": [-0.1, 0.2]}}, ["q_inner_ml_min = [-0.1, 0.2]"]),
        ({"control": {"needle_box_mm": [[0, 1]]}}, ["needle_box_mm = [[0, 1]]"]),
        ([("control", 1)], ["spec_overrides = [('control', 1)]", "a nested mapping"]),
    ],
)
def test_bad_spec_overrides_name_the_key_and_the_value(overrides, needles):
    with pytest.raises(ValueError) as exc:
        make(ENV, accuracy="draft", spec_overrides=overrides)
    for needle in needles:
        assert needle in str(exc.value)


@pytest.mark.parametrize(
    ("kwargs", "needles"),
    [
        ({"target_index": 1.7}, ["target_index = 1.7", "an integer"]),
        ({"target_index": "3"}, ["target_index = '3'", "an integer"]),
        ({"target_index": True}, ["target_index = True"]),
        ({"target_index": 16}, ["target_index = 16", "allowed 0..15"]),
        ({"target_index": -1}, ["target_index = -1", "allowed 0..15"]),
        ({"target_index": 2, "target_set": "train"}, ["target_set='eval'"]),
        ({"scene_overrides": [("bath.viscosity_pa_s", 1.0)]}, ["scene_overrides = [(", "mapping"]),
        ({"scene_overrides": "draft"}, ["scene_overrides = 'draft'"]),
        ({"accuracy": ["draft"]}, ["accuracy = ['draft']", "'draft', 'balanced', 'fine'"]),
    ],
)
def test_bad_environment_kwargs_are_refused(kwargs, needles):
    kwargs = {"target_set": "eval", "accuracy": "draft", **kwargs}
    with pytest.raises(ValueError) as exc:
        make(ENV, **kwargs)
    for needle in needles:
        assert needle in str(exc.value)


def test_reset_refuses_a_target_index_outside_the_set_instead_of_wrapping():
    env = make(ENV, accuracy="draft", target_set="eval")
    with pytest.raises(ValueError, match=r"target_index'\] = 16; .* allowed 0\.\.15"):
        env.reset(seed=0, options={"target_index": 16})
    with pytest.raises(ValueError, match="an integer"):
        env.reset(seed=0, options={"target_index": 2.5})
    _, info = env.reset(seed=0, options={"target_index": 15})  # the last one is fine
    assert info["target_index"] == 15
    _, info = make(ENV, accuracy="draft", target_set="eval", target_index=3).reset(seed=0)
    assert info["target_index"] == 3


def test_bad_environment_kwargs_in_a_hyperparameter_file_are_refused_before_training(
    tmp_path, capsys
):
    hp = _tiny(env_kwargs={"accuracy": "draft", "spec_overrides": {"control": {"length_mm": 0}}})
    out = tmp_path / "run"
    _refused(
        capsys,
        _train_argv(_write_hp(tmp_path, hp), out),
        "env_kwargs",
        "control.length_mm = 0",
        "a number > 0",
    )
    assert not out.exists()


# --------------------------------------------------------------------- run folders
def test_a_start_that_fails_is_marked_failed_and_a_rerun_starts_over(tmp_path, monkeypatch):
    out = tmp_path / "run"

    def broken(*args, **kwargs):
        raise RuntimeError("workers could not start")

    monkeypatch.setattr(train_mod, "make_vec", broken)
    with pytest.raises(RuntimeError):
        train("ppo", ENV, timesteps=160, out=out, hyperparams=_tiny(), progress=False)
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "failed"
    assert info["error"] == "RuntimeError: workers could not start"
    monkeypatch.undo()
    train("ppo", ENV, timesteps=160, out=out, hyperparams=_tiny(), progress=False)
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "done" and info["timesteps_done"] == 160 and "error" not in info
    assert [n for n, _ in checkpoints(out)] == [160]


def test_a_stuck_folder_says_what_is_wrong_and_how_to_start_over(tmp_path, capsys):
    """A run.json holding a misspelt key and no checkpoint (what a failed start left)."""
    out = tmp_path / "run"
    out.mkdir()
    hp = _tiny()
    hp["learning_ratee"] = hp.pop("learning_rate")
    stuck = {
        "algo": "ppo",
        "env_id": ENV,
        "seed": 0,
        "hyperparams": hp,
        "n_timesteps": 160,
        "wall_time_s": 0.0,
        "status": "failed",
    }
    (out / "run.json").write_text(json.dumps(stuck))
    argv = ["train", "--algo", "ppo", "--env", "CoilRadius-v0", "--out", str(out), "--quiet"]
    _refused(
        capsys,
        [*argv, "--resume"],
        "run.json: hyperparams",
        "'learning_ratee'",
        "start it again without --resume",
    )
    good = _write_hp(tmp_path, _tiny(n_timesteps=160))
    assert cli_main([*argv, "--hyperparams", str(good)]) == 0  # starts over
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "done" and "learning_ratee" not in info["hyperparams"]
    # a run with progress is never started over: a rerun is refused
    _refused(capsys, [*argv, "--hyperparams", str(good)], "already holds a run (done, 160")


def test_resume_refuses_settings_it_would_ignore(tmp_path, capsys):
    out = tmp_path / "run"
    train("ppo", ENV, timesteps=80, out=out, hyperparams=_tiny(), progress=False)
    argv = ["train", "--algo", "ppo", "--env", "CoilRadius-v0", "--out", str(out), "--resume"]
    _refused(
        capsys,
        [*argv, "--hyperparams", str(_write_hp(tmp_path, _tiny()))],
        "--hyperparams cannot change them",
    )
    _refused(capsys, [*argv, "--seed", "5"], "--seed = 5", "started with seed 0")
    _refused(
        capsys,
        ["train", "--algo", "sac", "--env", "CoilRadius-v0", "--out", str(out), "--resume"],
        "is a ppo run",
    )


@pytest.mark.parametrize(
    ("text", "needles"),
    [
        ('{"algo": "ppo", "env_id": ', ["not valid JSON", "line 1, column 27"]),
        ("", ["not valid JSON"]),
        ("[1, 2]", ["holds a list"]),
        ('{"env_id": "bathprint/CoilRadius-v0"}', ["key 'algo' is missing"]),
        (
            '{"algo": "ppo", "env_id": "bathprint/CoilRadius-v0", "seed": "0", '
            '"hyperparams": {}, "n_timesteps": 160}',
            ["seed = '0'", "an integer"],
        ),
    ],
)
def test_a_corrupt_run_json_is_refused_by_resume_rerun_and_evaluate(
    tmp_path, capsys, text, needles
):
    out = tmp_path / "run"
    out.mkdir()
    (out / "run.json").write_text(text)
    argv = ["train", "--algo", "ppo", "--env", "CoilRadius-v0", "--out", str(out), "--quiet"]
    _refused(capsys, [*argv, "--resume"], "run.json", *needles)
    _refused(capsys, argv, "run.json", *needles)
    _refused(
        capsys,
        [
            "evaluate",
            str(out),
            "--env",
            "CoilRadius-v0",
            "--episodes",
            "1",
            "--out",
            str(tmp_path / "eval"),
        ],
        "run.json",
        *needles,
    )


# -------------------------------------------------------------- play and evaluate
@pytest.mark.parametrize(
    ("extra", "needles"),
    [
        (["--target-index", "99"], ["--target-index = 99", "16 targets", "allowed 0..15"]),
        (["--target-index", "-1"], ["--target-index = -1", "allowed 0..15"]),
        (["--episodes", "17"], ["--episodes = 17", "allowed 1..16"]),
        (["--target-index", "3", "--target-set", "train"], ["needs --target-set eval"]),
        (["--frame-every", "0"], ["--frame-every = 0"]),
        (["--fps", "0"], ["--fps = 0.0", "a number > 0"]),
        (["--episodes", "0"], ["--episodes = 0"]),
    ],
)
def test_play_refuses_values_it_would_change(tmp_path, capsys, extra, needles):
    out = tmp_path / "play"
    _refused(
        capsys, ["play", "CoilRadius-v0", "--out", str(out), *extra], "bathprint play:", *needles
    )
    assert not out.exists()


def test_evaluate_refuses_more_episodes_than_held_out_targets(tmp_path, capsys):
    out = tmp_path / "eval"
    _refused(
        capsys,
        ["evaluate", "random", "--env", "CoilRadius-v0", "--episodes", "100", "--out", str(out)],
        "episodes = 100",
        "16 targets",
        "allowed 1..16",
    )
    assert not out.exists()


def test_evaluate_checks_every_policy_before_the_first_runs(tmp_path, capsys):
    out = tmp_path / "eval"
    _refused(
        capsys,
        [
            "evaluate",
            "random",
            "no_such_run",
            "--env",
            "CoilRadius-v0",
            "--episodes",
            "1",
            "--out",
            str(out),
        ],
        "'no_such_run'",
    )
    assert not out.exists()


@pytest.fixture(scope="module")
def obs_normalised_run(tmp_path_factory) -> Path:
    """A tiny run trained with observation normalisation (160 steps)."""
    out = tmp_path_factory.mktemp("norm") / "run"
    hp = _tiny(normalize={"norm_obs": True, "norm_reward": True, "gamma": 0.99})
    train("ppo", ENV, timesteps=160, out=out, hyperparams=hp, progress=False)
    return out


def test_missing_statistics_of_an_observation_normalised_run_are_refused(
    obs_normalised_run, tmp_path, capsys
):
    run = tmp_path / "run"
    shutil.copytree(obs_normalised_run, run)
    label, summary, _ = evaluate_policy_spec(str(run), ENV, episodes=1, progress=False)
    # a run directory plays the model its validation selected, with that model's statistics
    stats = run / "eval" / "vecnormalize.pkl"
    assert summary["obs_normalization"] == f"statistics from {stats}"
    stats.unlink()
    _refused(
        capsys,
        [
            "evaluate",
            str(run),
            "--env",
            "CoilRadius-v0",
            "--episodes",
            "1",
            "--out",
            str(tmp_path / "eval"),
        ],
        "vecnormalize.pkl is missing",
        "normalised observations",
    )
    assert not (tmp_path / "eval").exists()


def test_missing_statistics_are_recorded_when_they_do_not_matter(obs_normalised_run, tmp_path):
    """Rewards-only normalisation (the shipped settings): evaluation needs no statistics,
    and summary.json says so."""
    run = tmp_path / "run"
    shutil.copytree(obs_normalised_run, run)
    info = json.loads((run / "run.json").read_text())
    info["hyperparams"]["normalize"]["norm_obs"] = False
    (run / "run.json").write_text(json.dumps(info))
    (run / "vecnormalize.pkl").unlink()
    (run / "eval" / "vecnormalize.pkl").unlink()  # the validation-selected model's
    assert (
        cli_main(
            [
                "evaluate",
                str(run),
                "--env",
                "CoilRadius-v0",
                "--episodes",
                "1",
                "--images",
                "0",
                "--no-animation",
                "--quiet",
                "--out",
                str(tmp_path / "eval"),
            ]
        )
        == 0
    )
    (summary_path,) = (tmp_path / "eval").glob("*/summary.json")
    note = json.loads(summary_path.read_text())["obs_normalization"]
    assert "vecnormalize.pkl missing" in note and "rewards only" in note


def test_a_bare_model_without_statistics_is_evaluated_with_a_warning(
    obs_normalised_run, tmp_path, capsys
):
    model = tmp_path / "model.zip"
    shutil.copy(obs_normalised_run / "final_model.zip", model)
    assert (
        cli_main(
            [
                "evaluate",
                str(model),
                "--env",
                "CoilRadius-v0",
                "--episodes",
                "1",
                "--images",
                "0",
                "--no-animation",
                "--quiet",
                "--out",
                str(tmp_path / "eval"),
            ]
        )
        == 0
    )
    err = capsys.readouterr().err
    assert "warning" in err and "no VecNormalize statistics" in err
    (summary_path,) = (tmp_path / "eval").glob("*/summary.json")
    assert "raw observations" in json.loads(summary_path.read_text())["obs_normalization"]


def test_evaluate_refuses_a_run_on_another_environment(obs_normalised_run, tmp_path, capsys):
    out = tmp_path / "eval"
    _refused(
        capsys,
        ["evaluate", str(obs_normalised_run), "--env", "WriteShape-v0", "--out", str(out)],
        f"trained on {ENV}, not on bathprint/WriteShape-v0",
        f"--env {ENV}",
    )
    assert not out.exists()


def test_a_damaged_checkpoint_is_named_on_resume(tmp_path, capsys):
    out = tmp_path / "run"
    train("ppo", ENV, timesteps=160, out=out, hyperparams=_tiny(), progress=False)
    (out / "checkpoints" / "model_160_steps.zip").write_bytes(b"not a zip")
    argv = ["train", "--algo", "ppo", "--env", "CoilRadius-v0", "--out", str(out), "--resume"]
    _refused(
        capsys,
        [*argv, "--timesteps", "240", "--quiet"],
        "checkpoint model_160_steps.zip",
        "cannot be loaded",
        "_160_steps.*",
    )
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "failed" and "cannot be loaded" in info["error"]


def test_side_by_side_lays_panels_out_in_order_and_holds_the_shorter_episode():
    import numpy as np

    from bathprint.envs.play import side_by_side

    a = [np.full((20, 30, 3), 10 * k, np.uint8) for k in range(3)]
    b = [np.full((20, 40, 3), 200, np.uint8)]
    frames = side_by_side([("a", a), ("b", b)])
    assert len(frames) == 3 and frames[0].shape == (20 + 18, 70, 3)
    for k, f in enumerate(frames):
        assert np.array_equal(f[18:, :30], a[k])  # panel a, under its caption band
        assert np.array_equal(f[18:, 30:], b[0])  # panel b holds its only frame
    assert (frames[0][:18] < 255).any()  # a caption is drawn
    with pytest.raises(ValueError, match="at least one frame"):
        side_by_side([("a", a), ("b", [])])
    half = side_by_side([("a", a * 2), ("b", b)], scale=0.5, every=2)  # 6 frames: 0, 2, 4, 5
    assert len(half) == 4 and half[0].shape == (10 + 18, 35, 3)


def test_evaluate_writes_the_policies_side_by_side(tmp_path, capsys, monkeypatch):
    import numpy as np
    from PIL import Image

    from bathprint.envs.base import BathprintEnvBase

    # small stand-in frames: the layout is under test here, not the drawing (which costs
    # most of an evaluation's time and is tested with the environments)
    calls = iter(range(10**6))  # each frame differs (a GIF merges identical frames)
    monkeypatch.setattr(
        BathprintEnvBase, "render", lambda self: np.full((40, 60, 3), next(calls) % 256, np.uint8)
    )
    gif = tmp_path / "cmp.gif"
    argv = ["evaluate", "constant", "oracle", "--env", "CoilRadius-v1", "--episodes", "1",
            "--images", "0", "--out", str(tmp_path / "eval"), "--quiet"]  # fmt: skip
    assert cli_main([*argv, "--side-by-side", str(gif)]) == 0
    widths = [Image.open(tmp_path / "eval" / n / "episode_0.gif").size[0]
              for n in ("constant", "oracle")]  # fmt: skip
    from bathprint.agents.evaluate import SIDE_BY_SIDE_SCALE

    with Image.open(gif) as im:
        assert im.size[0] == sum(round(w * SIDE_BY_SIDE_SCALE) for w in widths)
        assert im.n_frames > 1
    capsys.readouterr()
    _refused(capsys, [*argv, "--side-by-side", str(tmp_path / "x.png")], "side_by_side", ".gif")
    _refused(capsys, [*argv, "--no-animation", "--side-by-side", str(gif)], "animate")

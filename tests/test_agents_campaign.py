"""Many runs, one command (bathprint.agents.campaign), the statistics behind its tables
(bathprint.agents.statistics), rl-zoo3's entry point on agents/*.yml, and model selection
that never reads the test targets."""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
import yaml

from bathprint.agents import statistics as st
from bathprint.agents.campaign import export, load_campaign, parse_seeds, run_state
from bathprint.agents.campaign import main as campaign_main
from bathprint.agents.hyperparams import load_hyperparams
from bathprint.errors import ConfigError
from bathprint.provenance import code_version

ROOT = Path(__file__).resolve().parents[1]
ENV = "bathprint/CoilRadius-v1"
SRC = str(ROOT / "src")

#: a tiny residual PPO: one environment, an update every 128 steps, a checkpoint every 128
TINY = {
    "n_steps": 128,
    "batch_size": 64,
    "n_epochs": 1,
    "eval_freq": 256,
    "eval_episodes": 2,
    "checkpoint_freq": 128,
    "policy_kwargs": {"net_arch": [16]},
}


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = SRC + os.pathsep + env.get("PYTHONPATH", "")
    return env


# ----------------------------------------------------------------------- seeds


@pytest.mark.parametrize(
    "text, seeds",
    [("0-4", [0, 1, 2, 3, 4]), ("0,2,5-6", [0, 2, 5, 6]), (3, [3]), ([1, 4], [1, 4])],
)
def test_seed_ranges(text, seeds):
    assert parse_seeds(text) == seeds


@pytest.mark.parametrize("text", ["4-0", "a", "", "-1", "0,0", True, 2.5, "0-"])
def test_bad_seed_ranges_are_refused(text):
    with pytest.raises(ConfigError, match="seeds"):
        parse_seeds(text)


# ------------------------------------------------------------------ statistics


def test_iqm_is_the_mean_of_the_middle_half():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(4, 10))  # 40 scores: the middle 20
    flat = np.sort(x.ravel())
    assert st.iqm(x) == pytest.approx(flat[10:30].mean(), rel=1e-12)
    x[0, 0] = 1e6  # one diverged run moves the mean, not the IQM
    assert abs(st.iqm(x) - flat[10:30].mean()) < 0.2


def test_bootstrap_intervals_hold_the_estimate_and_repeat():
    rng = np.random.default_rng(2)
    m = rng.uniform(0.1, 0.3, size=(5, 16))
    point, lo, hi = st.bootstrap_ci(lambda a: a.mean(), m, reps=500)
    assert lo < point < hi
    assert point == pytest.approx(m.mean(), rel=1e-12)
    assert st.bootstrap_ci(lambda a: a.mean(), m, reps=500) == (point, lo, hi)
    state = np.random.get_state()[1].copy()  # noqa: NPY002
    st.bootstrap_ci(lambda a: a.mean(), m, reps=50, seed=7)
    assert (np.random.get_state()[1] == state).all()  # noqa: NPY002 (restored)


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (3, 1), (2, 2), (3, 16), (5, 7)])
def test_the_bootstrap_is_rliables_bit_for_bit(shape):
    """The replicates drawn directly are rliable's StratifiedBootstrap's (its interval and
    IQM, exactly: the same draws and the same numpy operations)."""
    from rliable import metrics

    rng = np.random.default_rng(sum(shape))
    m = rng.lognormal(-1.5, 1.0, size=shape)
    r = m + rng.normal(0.0, 0.05, size=shape)
    assert st.iqm(m) == float(metrics.aggregate_iqm(m))
    cases = [(lambda a: a.mean(), (m,)), (st.iqm_raw, (m,)),
             (lambda a, r_: (a - r_).mean(), (m, r))]  # fmt: skip
    for func, arrays in cases:
        for reps, seed, size in ((300, 0, 0.95), (97, 11, 0.9)):
            ours = st.bootstrap_ci(func, *arrays, reps=reps, seed=seed, size=size)
            theirs = st.rliable_bootstrap_ci(func, *arrays, reps=reps, seed=seed, size=size)
            assert ours == theirs


def test_paired_difference_and_gap_closed():
    rng = np.random.default_rng(3)
    ref = rng.uniform(0.15, 0.25, size=16)
    oracle = np.zeros(16)
    const = ref + 0.2
    agent = ref[None, :] * 0.5 + rng.normal(0.0, 0.005, size=(3, 16))  # half the gap
    s = st.summary(agent, (agent < 0.1).astype(float), const, oracle, ref, reps=500)
    d, lo, hi = s["paired_difference"]
    assert d == pytest.approx((agent - ref).mean(), rel=1e-12)
    assert lo < d < hi < 0
    g, glo, ghi = s["gap_closed"]
    assert abs(g - 0.5) < 0.05 and glo < g < ghi
    assert s["targets_won"] == 16
    n = s["normalised_score"][0]
    assert n == pytest.approx((const.mean() - agent.mean()) / const.mean(), rel=1e-9)
    with pytest.raises(ValueError, match="targets"):
        st.summary(agent, None, const[:5], oracle)
    with pytest.raises(ValueError, match="NaN"):
        st.summary(np.full((2, 3), np.nan), None, None, None)


# -------------------------------------------------------------------- campaign


def _campaign_file(tmp_path: Path, out: Path) -> Path:
    data = {
        "out": str(out),
        "episodes": 2,
        "baselines": ["constant", "feedforward_calibrated", "oracle"],
        "reference": "feedforward_calibrated",
        "runs": [
            {
                "name": "tiny",
                "env": ENV,
                "algo": "ppo",
                "hyperparams": str(ROOT / "agents" / "ppo_residual.yml"),
                "seeds": "0-1",
                "timesteps": 1024,
                "n_envs": 1,
                "set": TINY,
            }
        ],
    }
    path = tmp_path / "campaign.yml"
    path.write_text(yaml.safe_dump(data))
    return path


@pytest.mark.parametrize(
    "change, needle",
    [
        ({"runs": []}, "runs"),
        ({"episodes": 0}, "episodes"),
        ({"baselines": ["nope"]}, "baselines"),
        ({"reference": "mpc"}, "reference"),
        ({"colour": 1}, "colour"),
        ({"runs": [{"name": "a", "env": ENV, "algo": "ppo", "seeds": "2-1"}]}, "seeds"),
        ({"runs": [{"name": "a", "env": ENV, "algo": "dqn"}]}, "algo"),
        ({"runs": [{"name": "a", "env": ENV, "algo": "ppo", "set": {"n_stepz": 8}}]}, "n_stepz"),
    ],
)
def test_bad_campaign_files_are_refused(tmp_path, change, needle):
    path = _campaign_file(tmp_path, tmp_path / "out")
    data = yaml.safe_load(path.read_text())
    data.update(change)
    path.write_text(yaml.safe_dump(data))
    with pytest.raises(ConfigError, match=needle):
        load_campaign(path)
    assert not (tmp_path / "out").exists()


def test_a_killed_campaign_resumes_and_ends_in_one_table(tmp_path, capsys, monkeypatch):
    """Two tiny runs; the campaign is killed (SIGKILL) during the first run, after its
    first checkpoint; the same command finishes it from there and writes the table."""
    out = tmp_path / "out"
    path = _campaign_file(tmp_path, out)
    camp = load_campaign(path)
    dirs = [Path(r.run_dir) for r in camp.runs]
    cmd = [sys.executable, "-m", "bathprint.agents.campaign", str(path), "--quiet"]
    proc = subprocess.Popen(cmd, env=_env(), cwd=tmp_path, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120
    killed = None
    while time.monotonic() < deadline and proc.poll() is None and killed is None:
        killed = next((d for d in dirs if run_state(d) == "resume"), None)
        time.sleep(0.02)
    assert proc.poll() is None, proc.communicate()[0].decode()
    os.killpg(proc.pid, signal.SIGKILL)  # mid-run: a checkpoint on disk, the run unfinished
    proc.wait()
    assert killed is not None and run_state(killed) == "resume"
    assert not (out / "CoilRadius-v1" / "results.md").exists()

    monkeypatch.chdir(tmp_path)
    assert campaign_main([str(path), "--quiet"]) == 0  # the same command, in this process
    stdout = capsys.readouterr().out
    for spec in camp.runs:
        info = json.loads((Path(spec.run_dir) / "run.json").read_text())
        assert info["status"] == "done" and info["timesteps_done"] == 1024
        (summary,) = (Path(spec.run_dir) / "test").glob("*/summary.json")
        wrapper = json.loads(summary.read_text())["wrapper"]  # played as it was trained
        assert wrapper["name"] == "feedforward_residual", wrapper
    assert "resuming" in stdout and "tiny" in stdout
    record = json.loads((out / "CoilRadius-v1" / "results.json").read_text())
    rows = {r["policy"]: r for r in record["policies"]}
    assert set(rows) == {"constant", "feedforward_calibrated", "oracle", "tiny"}
    assert rows["tiny"]["runs"] == 2 and rows["tiny"]["targets"] == 2
    assert record["target_set"] == "test"
    lo, hi = rows["tiny"]["mean_metric"][1:]
    assert lo <= rows["tiny"]["mean_metric"][0] <= hi
    table = (out / "CoilRadius-v1" / "results.md").read_text()
    assert "| tiny | 2 |" in table
    assert (out / "CoilRadius-v1" / "curves.png").stat().st_size > 0
    scores = (out / "CoilRadius-v1" / "scores.csv").read_text().splitlines()
    assert len(scores) == 1 + 2 * 2 + 3 * 2  # header, 2 seeds x 2 targets, 3 baselines x 2

    assert campaign_main([str(path), "--quiet"]) == 0  # all done: nothing trains again
    assert "resuming" not in capsys.readouterr().out
    assert (out / "CoilRadius-v1" / "results.md").read_text() == table
    kept = export(camp, ENV, tmp_path / "kept")  # what is committed of a campaign
    assert (kept / "results.json").is_file() and (kept / "tiny" / "seed1" / "run.json").is_file()
    assert len(list(kept.glob("tiny/seed*/eval/best_model.zip"))) == 1  # the best on validation
    assert len(list(kept.glob("tiny/seed*/episodes.csv.gz"))) == 2
    assert list(kept.glob("baselines/oracle/*/episodes.csv"))
    assert not list(kept.rglob("checkpoints")) and not list(kept.rglob("model_*_steps.zip"))
    (model,) = kept.glob("tiny/seed*/eval/best_model.zip")  # without the optimiser's state
    with zipfile.ZipFile(model) as z:
        optimizer = torch.load(io.BytesIO(z.read("policy.optimizer.pth")), weights_only=True)
    assert optimizer["state"] == {} and optimizer["param_groups"]
    assert model.with_name("best_model.slim.json").is_file()
    assert not list(kept.rglob("training_curve.png"))  # python -m bathprint.agents.curves
    meta = json.loads((kept / "results.meta.json").read_text())
    assert meta["campaign"] == str(path) and meta["command"].endswith(f"--export {tmp_path}")
    assert set(meta["runs"]) == {"tiny/seed0", "tiny/seed1"}
    assert all(r["commit"] == code_version()["commit"] for r in meta["runs"].values())
    assert list(meta["models"]) == [model.relative_to(kept).as_posix()]
    # the exported copy alone rebuilds the same table (the committed results can be checked)
    shutil.copytree(kept, tmp_path / "copy" / "CoilRadius-v1")
    assert campaign_main([str(path), "--quiet", "--report-only", "--out",
                          str(tmp_path / "copy")]) == 0  # fmt: skip
    assert (tmp_path / "copy" / "CoilRadius-v1" / "results.md").read_text() == table
    again = export(load_campaign(path, tmp_path / "copy"), ENV, tmp_path / "again")
    assert len(list(again.glob("tiny/seed*/episodes.csv.gz"))) == 2  # the copy's, copied
    assert len(list(again.glob("tiny/seed*/eval/best_model.slim.json"))) == 1
    # the campaign itself, pointed at the copy, neither deletes nor retrains its runs (a copy
    # keeps one selected model per group and no final models): a new seed can be added to it
    before = sorted(str(f) for f in (tmp_path / "copy").rglob("*"))
    assert campaign_main([str(path), "--quiet", "--out", str(tmp_path / "copy")]) == 0
    assert "resuming" not in capsys.readouterr().out
    assert sorted(str(f) for f in (tmp_path / "copy").rglob("*")) == before
    assert (tmp_path / "copy" / "CoilRadius-v1" / "results.md").read_text() == table


def test_a_campaign_on_a_local_dask_cluster_ends_in_the_serial_table(tmp_path, monkeypatch):
    """The same two tiny runs, trained one after the other in this process and on a local
    Dask cluster of two worker processes: the same scores (seeded, one torch thread)."""
    results = {}
    for mode, extra in (("serial", []), ("dask", ["--scheduler", "local-dask", "--workers", "2"])):
        where = tmp_path / mode
        where.mkdir()
        path = _campaign_file(where, where / "out")
        data = yaml.safe_load(path.read_text())
        data["baselines"] = ["feedforward_calibrated"]
        path.write_text(yaml.safe_dump(data))
        monkeypatch.chdir(where)
        assert campaign_main([str(path), "--quiet", *extra]) == 0
        record = json.loads((where / "out" / "CoilRadius-v1" / "results.json").read_text())
        results[mode] = {r["policy"]: r for r in record["policies"]}
    assert results["dask"]["tiny"]["runs"] == 2
    assert results["dask"]["tiny"]["mean_metric"] == results["serial"]["tiny"]["mean_metric"]


@pytest.mark.parametrize("algo, hp_file", [("sac", "sac.yml"), ("tqc", "tqc_her.yml")])
def test_off_policy_runs_go_through_a_campaign(tmp_path, monkeypatch, algo, hp_file):
    """SAC and TQC with hindsight replay (goal-conditioned observations) train, and their
    validation-selected models play the test targets in the environment they trained on."""
    tiny = {"learning_starts": 100, "batch_size": 32, "buffer_size": 2000, "train_freq": 8,
            "gradient_steps": 1, "eval_freq": 200, "eval_episodes": 2, "checkpoint_freq": 200,
            "policy_kwargs": {"net_arch": [16]}}
    path = tmp_path / "campaign.yml"
    path.write_text(yaml.safe_dump({
        "out": str(tmp_path / "out"), "episodes": 2, "baselines": ["feedforward_calibrated"],
        "reference": "feedforward_calibrated",
        "runs": [{"name": algo, "env": ENV, "algo": algo, "seeds": 0, "timesteps": 400,
                  "hyperparams": str(ROOT / "agents" / hp_file), "set": tiny}],
    }))
    monkeypatch.chdir(tmp_path)
    assert campaign_main([str(path), "--quiet"]) == 0
    (run,) = load_campaign(path).runs
    (summary,) = (Path(run.run_dir) / "test").glob("*/summary.json")
    played = json.loads(summary.read_text())
    trained = json.loads((Path(run.run_dir) / "run.json").read_text())["hyperparams"]
    assert played["target_set"] == "test" and played["episodes"] == 2
    assert played["env_kwargs"] == trained["env_kwargs"]
    assert played["env_kwargs"].get("goal_conditioned", False) == (algo == "tqc")
    record = json.loads((tmp_path / "out" / "CoilRadius-v1" / "results.json").read_text())
    rows = {r["policy"]: r for r in record["policies"]}
    assert rows[algo]["runs"] == 1 and rows[algo]["targets"] == 2


# ------------------------------------------------------------ test set unread


def test_training_never_plays_the_test_targets(tmp_path, monkeypatch):
    """Every environment training builds, and every target set its validation callback
    plays, is a training or validation set; the callback refuses the test set."""
    import bathprint.envs as envs
    from bathprint.agents import train as train_mod
    from bathprint.agents.callbacks import ValidationCallback

    built: list[str] = []
    make = envs.make

    def recording_make(env_id, *args, **kwargs):
        env = make(env_id, *args, **kwargs)
        built.append(str(env.unwrapped.target_set))
        return env

    monkeypatch.setattr(envs, "make", recording_make)
    made: list[list] = []
    make_callbacks = train_mod._make_callbacks

    def recording_callbacks(*args, **kwargs):
        cbs = make_callbacks(*args, **kwargs)
        made.append(cbs)
        return cbs

    monkeypatch.setattr(train_mod, "_make_callbacks", recording_callbacks)
    hp = load_hyperparams("ppo", ENV, ROOT / "agents" / "ppo_residual.yml")
    hp.update(TINY, n_envs=1)
    train_mod.train("ppo", ENV, timesteps=512, seed=0, out=tmp_path / "run", hyperparams=hp,
                    progress=False)
    (validation,) = [cb for cb in made[0] if isinstance(cb, ValidationCallback)]
    assert validation.target_set == "validation"
    assert validation.target_sets_played == {"validation"}
    assert len(np.load(tmp_path / "run" / "eval" / "evaluations.npz")["timesteps"]) == 2
    assert "test" not in built and set(built) == {"train", "validation"}
    info = json.loads((tmp_path / "run" / "run.json").read_text())
    assert (info["train_target_set"], info["eval_target_set"]) == ("train", "validation")
    with pytest.raises(ValueError, match="test set"):
        ValidationCallback(make(ENV, target_set="test"), 2, 100, tmp_path / "x")


# -------------------------------------------------------------------- rl-zoo3


def test_rl_zoo3_trains_from_the_agents_file(tmp_path):
    """rl-zoo3's own entry point reads agents/ppo_residual.yml unchanged (bathprint's keys
    in their own section, the wrapper imported by rl-zoo3) and trains a few hundred steps."""
    pytest.importorskip("rl_zoo3")
    cmd = [
        sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", ENV,
        "--gym-packages", "bathprint", "-conf", str(ROOT / "agents" / "ppo_residual.yml"),
        "-n", "256", "--eval-freq", "-1", "--save-freq", "-1", "--seed", "0",
        "--log-folder", str(tmp_path / "logs"), "--device", "cpu", "--verbose", "0",
        "-params", "n_envs:1", "n_steps:128", "batch_size:64", "n_epochs:1",
    ]
    done = subprocess.run(cmd, env=_env(), cwd=tmp_path, capture_output=True, text=True,
                          timeout=240)
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-4000:]
    models = list((tmp_path / "logs" / "ppo").glob("*/*.zip"))
    assert models, list((tmp_path / "logs").rglob("*"))
    config = next((tmp_path / "logs" / "ppo").glob("*/*/config.yml")).read_text()
    assert "FeedforwardResidual" in config  # the residual wrapper was used


# ---------------------------------------------------------------------- tuning


def test_the_search_scores_on_validation_and_continues_where_it_stopped(tmp_path):
    """Two trials, then the same search asked for three: one more runs, the first two are
    kept (Optuna's journal file); every score is a validation-set metric."""
    from bathprint.agents.tune import tune

    hp_file = tmp_path / "hp.yml"
    base = load_hyperparams("ppo", ENV, ROOT / "agents" / "ppo_residual.yml")
    base.update(TINY, n_envs=1)
    hp_file.write_text(yaml.safe_dump({ENV: base}))
    first = tune("ppo", ENV, hp_file, trials=2, timesteps=256, out=tmp_path / "tune")
    assert first["trials"] == 2
    second = tune("ppo", ENV, hp_file, trials=3, timesteps=256, out=tmp_path / "tune")
    assert second["trials"] == 3
    rows = (tmp_path / "tune" / "trials.csv").read_text().splitlines()
    assert len(rows) == 4
    for k in range(3):
        best = json.loads((tmp_path / "tune" / f"trial_{k:03d}" / "eval" / "best.json")
                          .read_text())
        assert best["target_set"] == "validation"
    values = [float(r.split(",")[1]) for r in rows[1:]]
    assert second["best_value"] == pytest.approx(min(values), rel=1e-12)


# ------------------------------------------------------------------------ CLI


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--algo", "ppo", "--env", "CoilRadius-v1", "--seeds", "4-0"], "seeds"),
        (["--algo", "ppo", "--env", "CoilRadius-v1", "--seeds", "0-1", "--seed", "3"], "--seed"),
        (["--campaign", "missing.yml"], "missing.yml"),
        (["--campaign", "agents/campaigns/CoilRadius-v1.yml", "--algo", "ppo"], "--algo"),
        (["--algo", "ppo", "--env", "CoilRadius-v1", "--seeds", "0", "--workers", "0"],
         "--workers"),
        (["--env", "CoilRadius-v1"], "--algo"),
    ],
)
def test_many_runs_refusals_are_one_line(argv, needle, capsys, monkeypatch):
    from bathprint.cli import main as cli_main

    monkeypatch.chdir(ROOT)
    assert cli_main(["train", *argv, "--out", "/nonexistent/never-written"]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and needle in err and "Traceback" not in err, err
    assert not Path("/nonexistent/never-written").exists()


def _descendants(pid: int) -> set[int]:
    """Every process below ``pid`` (Linux /proc)."""
    out, todo = set(), [pid]
    while todo:
        p = todo.pop()
        try:
            kids = Path(f"/proc/{p}/task/{p}/children").read_text().split()
        except OSError:
            continue
        for k in map(int, kids):
            if k not in out:
                out.add(k)
                todo.append(k)
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/task").is_dir(), reason="needs Linux /proc")
def test_sigterm_to_the_campaign_stops_its_pool_workers(tmp_path):
    """A SIGTERM to the campaign's process alone (as ``pkill -f``) is handled like Ctrl-C:
    the pool's workers are stopped with it, never left training into the run directories,
    and it exits with 143."""
    out = tmp_path / "out"
    path = _campaign_file(tmp_path, out)
    data = yaml.safe_load(path.read_text())
    data["runs"][0]["timesteps"] = 200_000  # long enough to be killed mid-run
    path.write_text(yaml.safe_dump(data))
    dirs = [Path(r.run_dir) for r in load_campaign(path).runs]
    cmd = [sys.executable, "-m", "bathprint.agents.campaign", str(path), "--quiet",
           "--workers", "2"]  # fmt: skip
    proc = subprocess.Popen(cmd, env=_env(), cwd=tmp_path, start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)  # fmt: skip
    workers: set[int] = set()
    try:
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline and proc.poll() is None:
            if any((d / "run.json").is_file() for d in dirs):
                break
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()[0].decode()
        workers = _descendants(proc.pid)
        assert workers
        proc.send_signal(signal.SIGTERM)  # the campaign's process only, not its group
        output = proc.communicate(timeout=60)[0].decode()
        assert proc.returncode == 143, output
        assert "interrupted (SIGTERM)" in output
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline and any(_alive(p) for p in workers):
            time.sleep(0.1)
        assert not any(_alive(p) for p in workers)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        for p in workers | _descendants(proc.pid):  # never leave a worker behind
            try:
                os.kill(p, signal.SIGKILL)
            except ProcessLookupError:
                pass

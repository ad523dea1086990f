"""SIGTERM and SIGINT on long commands, with real processes and real signals: ``bathprint
train`` saves a checkpoint at the step it was stopped at, marks the run interrupted, closes
its vector-env workers without tracebacks, exits 128 + signal, and ``--resume`` finishes
with nothing lost; ``bathprint evaluate`` exits 143 with a message."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
import yaml

import bathprint
from bathprint.agents.hyperparams import load_hyperparams
from bathprint.agents.signals import Interrupted, SignalStop
from bathprint.agents.train import checkpoints, read_episodes
from bathprint.cli import main as cli_main

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")

ENV = "bathprint/CoilRadius-v0"
SRC = str(Path(bathprint.__file__).resolve().parents[1])
N_STEPS, N_ENVS = 80, 2  # a PPO update every 160 steps; episodes are 80 steps
# how long a training subprocess may take to log its first episodes: a bound on a hung
# process, not a speed target (on a cold numba cache, beside other test workers, compiling
# the environment's kernels alone takes about a minute)
PROGRESS_WAIT_S = 300.0


def _hyperparams_file(tmp_path: Path) -> Path:
    """PPO settings on CoilRadius (draft) with a budget far beyond what the test waits for,
    and no regular checkpoint: the only checkpoint is the one the signal writes."""
    hp = load_hyperparams("ppo", ENV)
    hp.update(
        n_timesteps=1_000_000,
        n_envs=N_ENVS,
        n_steps=N_STEPS,
        batch_size=40,
        n_epochs=2,
        eval_freq=1_000_000,
        eval_episodes=1,
        checkpoint_freq=1_000_000,
    )
    path = tmp_path / "hp.yml"
    path.write_text(yaml.safe_dump({ENV: hp}))
    return path


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = SRC + os.pathsep + env.get("PYTHONPATH", "")
    env["MPLBACKEND"] = "Agg"
    return env


def _start(args: list[str], tmp_path: Path, name: str, **kw) -> tuple[subprocess.Popen, Path]:
    err = tmp_path / f"{name}.err"
    proc = subprocess.Popen(
        [sys.executable, "-m", "bathprint.cli", *args],
        stdout=(tmp_path / f"{name}.out").open("w"),
        stderr=err.open("w"),
        env=_env(),
        cwd=tmp_path,
        **kw,
    )
    return proc, err


def _wait_for_episodes(proc: subprocess.Popen, run: Path, rows: int, timeout_s: float) -> int:
    """Poll episodes.csv until it has ``rows`` episodes; returns the last one's timesteps."""
    t_end = time.monotonic() + timeout_s
    while time.monotonic() < t_end:
        assert proc.poll() is None, "training ended before it was signalled"
        episodes = read_episodes(run) if (run / "episodes.csv").is_file() else []
        if len(episodes) >= rows:
            return int(episodes[-1]["timesteps"])
        time.sleep(0.05)
    proc.kill()
    raise AssertionError(f"no {rows} episodes in {timeout_s} s")


def _descendants(pid: int) -> set[int]:
    """Processes below ``pid`` (Linux /proc): the forkserver, its vector-env workers."""
    parent: dict[int, int] = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        parent[int(stat.parent.name)] = int(fields[1])
    out, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parent.items() if pp in frontier} - out
        out |= frontier
    return out


def _alive(pids: set[int]) -> set[int]:
    alive = set()
    for pid in pids:
        try:
            state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
        except OSError:
            continue
        if state != "Z":
            alive.add(pid)
    return alive


@pytest.mark.timeout(PROGRESS_WAIT_S + 180)
def test_sigterm_saves_at_the_step_marks_interrupted_and_resume_finishes(tmp_path, capsys):
    run = tmp_path / "run"
    args = ["train", "--algo", "ppo", "--env", "CoilRadius-v0", "--out", str(run), "--quiet"]
    proc, err = _start([*args, "--hyperparams", str(_hyperparams_file(tmp_path))], tmp_path, "a")
    seen = _wait_for_episodes(proc, run, 4, PROGRESS_WAIT_S)  # two updates done, training under way
    workers = _descendants(proc.pid) if Path("/proc").is_dir() else set()
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=60) == 143
    stderr = err.read_text()
    assert not any(w in stderr for w in ("Traceback", "ConnectionReset", "BrokenPipe")), stderr
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "interrupted" and info["interrupted_by"] == "SIGTERM"
    stopped = info["timesteps_done"]
    # the only checkpoint is the one saved at the interruption step, with its statistics
    assert [n for n, _ in checkpoints(run)] == [stopped]
    assert (run / "checkpoints" / f"model_vecnormalize_{stopped}_steps.pkl").is_file()
    assert stopped >= seen and stopped % N_ENVS == 0
    assert f"model_{stopped}_steps.zip" in (tmp_path / "a.out").read_text()
    assert not (run / "final_model.zip").exists()
    time.sleep(0.2)
    assert not _alive(workers), "vector-env workers outlived the training process"
    logged = [r["timesteps"] for r in read_episodes(run)]

    total = stopped + 2 * N_STEPS * N_ENVS
    assert cli_main([*args, "--resume", "--timesteps", str(total)]) == 0  # in-process: faster
    resumed = capsys.readouterr()
    assert f"from model_{stopped}_steps.zip ({stopped} of {total} steps)" in resumed.out
    assert "Traceback" not in resumed.err
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "done" and "interrupted_by" not in info
    # PPO collects whole rollouts of n_steps x n_envs from where it stopped
    assert info["timesteps_done"] == stopped + 2 * N_STEPS * N_ENVS
    episodes = [r["timesteps"] for r in read_episodes(run)]
    assert episodes[: len(logged)] == logged  # nothing logged before the signal was lost
    assert episodes == sorted(episodes) and episodes[-1] > stopped
    assert (run / "final_model.zip").is_file()


@pytest.mark.timeout(PROGRESS_WAIT_S + 120)
def test_ctrl_c_to_the_whole_process_group_stops_cleanly(tmp_path):
    """A terminal's Ctrl-C reaches every process of the group, the workers too."""
    run = tmp_path / "run"
    proc, err = _start(
        [
            "train",
            "--algo",
            "ppo",
            "--env",
            "CoilRadius-v0",
            "--out",
            str(run),
            "--quiet",
            "--hyperparams",
            str(_hyperparams_file(tmp_path)),
        ],
        tmp_path,
        "a",
        start_new_session=True,
    )
    _wait_for_episodes(proc, run, 2, PROGRESS_WAIT_S)
    os.killpg(proc.pid, signal.SIGINT)
    assert proc.wait(timeout=60) == 130
    stderr = err.read_text()
    assert not any(w in stderr for w in ("Traceback", "ConnectionReset", "BrokenPipe")), stderr
    info = json.loads((run / "run.json").read_text())
    assert info["status"] == "interrupted" and info["interrupted_by"] == "SIGINT"
    assert [n for n, _ in checkpoints(run)] == [info["timesteps_done"]]


@pytest.mark.timeout(60)
def test_sigterm_ends_evaluate_with_143_and_a_message(tmp_path):
    proc, err = _start(
        [
            "evaluate",
            "random",
            "--env",
            "CoilRadius-v0",
            "--episodes",
            "16",
            "--images",
            "0",
            "--no-animation",
            "--out",
            str(tmp_path / "eval"),
        ],
        tmp_path,
        "e",
    )
    t_end = time.monotonic() + 40
    while "evaluate random" not in err.read_text():  # its progress bar: the episodes started
        assert proc.poll() is None and time.monotonic() < t_end, err.read_text()
        time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    assert proc.wait(timeout=30) == 143
    stderr = err.read_text()
    assert "Traceback" not in stderr
    assert "bathprint evaluate: interrupted by SIGTERM" in stderr
    assert not (tmp_path / "eval" / "random" / "summary.json").exists()


def test_signal_stop_defers_the_first_signal_and_raises_on_the_second():
    with SignalStop(deferred=True) as stop:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)  # the handler runs at the next bytecode
        assert stop.requested and stop.signum == signal.SIGTERM
        with pytest.raises(Interrupted) as exc:
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)
        assert exc.value.signum == signal.SIGINT and exc.value.exit_code == 130
        with stop.shield():  # while files are written, signals only record themselves
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(0.01)
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # handlers restored
    with SignalStop(deferred=False), pytest.raises(Interrupted) as exc:
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)
    assert exc.value.exit_code == 143


@pytest.mark.timeout(120)
def test_sac_stopped_by_sigterm_keeps_every_transition_but_the_one_in_flight(tmp_path, monkeypatch):
    """In-process, with a real SIGTERM sent at step 150: training stops at that step, the
    checkpoint's replay buffer holds the 149 transitions stored before it."""
    from stable_baselines3 import SAC
    from stable_baselines3.common.callbacks import BaseCallback

    from bathprint.agents import train as train_mod

    class SendSigterm(BaseCallback):
        def _on_step(self) -> bool:
            if self.num_timesteps == 150:
                os.kill(os.getpid(), signal.SIGTERM)
            return True

    make_callbacks = train_mod._make_callbacks
    monkeypatch.setattr(
        train_mod, "_make_callbacks", lambda *a, **k: [*make_callbacks(*a, **k), SendSigterm()]
    )
    hp = load_hyperparams("sac", ENV)
    hp.update(eval_freq=10_000, eval_episodes=1, checkpoint_freq=10_000, n_envs=1)
    hp.update(learning_starts=80, buffer_size=2000, batch_size=32, gradient_steps=1)
    out = tmp_path / "sac"
    with pytest.raises(Interrupted) as exc:
        train_mod.train("sac", ENV, timesteps=400, out=out, hyperparams=hp, progress=False)
    assert exc.value.exit_code == 143
    info = json.loads((out / "run.json").read_text())
    assert info["status"] == "interrupted" and info["timesteps_done"] == 150
    assert [n for n, _ in checkpoints(out)] == [150]
    model = SAC.load(out / "checkpoints" / "model_150_steps.zip", device="cpu")
    model.load_replay_buffer(out / "checkpoints" / "model_replay_buffer_150_steps.pkl")
    assert model.replay_buffer.size() == 149
    assert signal.getsignal(signal.SIGTERM) == signal.SIG_DFL  # train restored the handlers

    monkeypatch.setattr(train_mod, "_make_callbacks", make_callbacks)
    train_mod.train("sac", ENV, out=out, resume=True, progress=False)
    info = json.loads((out / "run.json").read_text())
    # SAC collects train_freq steps at a time from where it stopped
    assert info["status"] == "done" and 400 <= info["timesteps_done"] < 400 + hp["train_freq"]


@pytest.mark.timeout(120)
def test_closing_workers_never_hangs_on_a_step_in_flight_or_a_dead_worker():
    import functools

    from bathprint.agents.vecenv import QuietSubprocVecEnv
    from bathprint.envs import make

    venv = QuietSubprocVecEnv(
        [functools.partial(make, ENV, accuracy="draft")] * 2, start_method="forkserver"
    )
    venv.reset()
    venv.step_async(venv.action_space.sample()[None].repeat(2, axis=0))
    venv.processes[1].kill()  # one worker gone (as after an out-of-memory kill)
    venv.processes[1].join(10)
    t0 = time.monotonic()
    venv.close()  # collects worker 0's step, skips the dead one, closes both
    assert time.monotonic() - t0 < 15
    assert not any(p.is_alive() for p in venv.processes)

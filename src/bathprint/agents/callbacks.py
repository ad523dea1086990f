"""Training callbacks that survive a resume: the held-out evaluation log and the per-episode
training log keep what was recorded up to the checkpoint a run resumes from; and the one
that ends training at the next step once SIGINT or SIGTERM has arrived."""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

EPISODE_FIELDS = ("timesteps", "episode_return", "metric", "episode_length", "truncated")


class ResumableEvalCallback(EvalCallback):
    """EvalCallback that, on a resumed run, starts from the evaluations recorded up to the
    checkpoint (``resumed_at`` steps) instead of overwriting them."""

    def __init__(self, *args: Any, resumed_at: int = 0, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.resumed_at = int(resumed_at)

    def _init_callback(self) -> None:
        super()._init_callback()
        path = Path(str(self.log_path))  # EvalCallback's log_path lacks np.savez's suffix
        path = path if path.suffix == ".npz" else path.with_name(path.name + ".npz")
        if self.resumed_at > 0 and path.is_file():
            with np.load(path) as d:
                keep = d["timesteps"] <= self.resumed_at
                self.evaluations_timesteps = [int(t) for t in d["timesteps"][keep]]
                self.evaluations_results = [list(r) for r in d["results"][keep]]
                self.evaluations_length = [list(r) for r in d["ep_lengths"][keep]]
            if self.evaluations_results:
                self.best_mean_reward = float(np.max(np.mean(self.evaluations_results, axis=1)))


class EpisodeLogCallback(BaseCallback):
    """Appends every finished training episode to a CSV: timesteps, return, final metric,
    length, truncated. On a resume, rows past the checkpoint are dropped first."""

    def __init__(self, path: Path, resumed_at: int = 0) -> None:
        super().__init__()
        self.path = Path(path)
        self.resumed_at = int(resumed_at)
        self._file: Any = None
        self._writer: Any = None

    def _init_callback(self) -> None:
        rows: list[dict[str, str]] = []
        if self.resumed_at > 0 and self.path.is_file():
            with self.path.open() as f:
                rows = [r for r in csv.DictReader(f) if float(r["timesteps"]) <= self.resumed_at]
        self._file = self.path.open("w", newline="")
        self._writer = csv.DictWriter(self._file, fieldnames=EPISODE_FIELDS)
        self._writer.writeheader()
        self._writer.writerows(rows)
        self._file.flush()

    def _on_step(self) -> bool:
        for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
            if done and "episode" in info:
                self._writer.writerow(
                    {
                        "timesteps": self.num_timesteps,
                        "episode_return": float(info["episode"]["r"]),
                        "metric": float(info.get("metric", np.nan)),
                        "episode_length": int(info["episode"]["l"]),
                        "truncated": int(bool(info.get("TimeLimit.truncated", False))),
                    }
                )
                self._file.flush()
        return True

    def _on_training_end(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


class RunInfoCallback(BaseCallback):
    """Keeps ``run.json`` current (wall time so far, steps done) every ``every_s`` seconds,
    so a killed run still accounts for the time it spent."""

    def __init__(self, write: Any, info: dict[str, Any], every_s: float = 10.0) -> None:
        super().__init__()
        self.write, self.info, self.every_s = write, info, float(every_s)
        self.base_wall = float(info.get("wall_time_s", 0.0))

    def _init_callback(self) -> None:
        self._t0 = self._last = time.perf_counter()

    def update(self) -> None:
        now = time.perf_counter()
        self.info["wall_time_s"] = self.base_wall + now - self._t0
        self.info["timesteps_done"] = int(self.num_timesteps)
        self.write(self.info)
        self._last = now

    def _on_step(self) -> bool:
        if time.perf_counter() - self._last >= self.every_s:
            self.update()
        return True


class StopOnRequest(BaseCallback):
    """Ends training at the next environment step once ``stop.requested`` (a
    :class:`~bathprint.agents.signals.SignalStop`): SB3 stops when a callback returns False,
    with ``num_timesteps`` counting that step, so a checkpoint saved then loses nothing."""

    def __init__(self, stop: Any) -> None:
        super().__init__()
        self.stop = stop

    def _on_step(self) -> bool:
        return not self.stop.requested

"""Training callbacks that survive a resume: the validation log and the per-episode training
log keep what was recorded up to the checkpoint a run resumes from; the one that ends
training at the next step once SIGINT or SIGTERM has arrived; and the wall-time budget.

Model selection reads only the validation targets (version 1; version 0's held-out
``eval`` set): :class:`ValidationCallback` refuses the test set, and records the target set
it played, so that a test can check that training never saw a test target."""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback

EPISODE_FIELDS = (
    "timesteps",
    "episode_return",
    "metric",
    "episode_length",
    "truncated",
    "is_success",
    "wall_time_s",
)
#: target sets model selection may read (never "test")
SELECTION_SETS = ("validation", "eval")


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

    def __init__(self, path: Path, resumed_at: int = 0, base_wall_s: float = 0.0) -> None:
        super().__init__()
        self.path = Path(path)
        self.resumed_at = int(resumed_at)
        self.base_wall_s = float(base_wall_s)
        self._file: Any = None
        self._writer: Any = None

    def _init_callback(self) -> None:
        rows: list[dict[str, str]] = []
        if self.resumed_at > 0 and self.path.is_file():
            with self.path.open() as f:
                rows = [r for r in csv.DictReader(f) if float(r["timesteps"]) <= self.resumed_at]
        self._t0 = time.perf_counter()
        self._file = self.path.open("w", newline="")
        self._writer = csv.DictWriter(self._file, fieldnames=EPISODE_FIELDS, restval="nan")
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
                        "is_success": float(info.get("is_success", np.nan)),
                        "wall_time_s": self.base_wall_s + time.perf_counter() - self._t0,
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


class TimeBudget(BaseCallback):
    """Ends training once the run's wall time (earlier sessions included) reaches
    ``budget_s``; ``reached`` says whether it did."""

    def __init__(self, budget_s: float, base_wall_s: float = 0.0) -> None:
        super().__init__()
        self.budget_s, self.base_wall_s = float(budget_s), float(base_wall_s)
        self.reached = False

    def _init_callback(self) -> None:
        self._t0 = time.perf_counter()

    def _on_step(self) -> bool:
        if self.base_wall_s + time.perf_counter() - self._t0 >= self.budget_s:
            self.reached = True
            return False
        return True


class ValidationCallback(BaseCallback):
    """Every ``eval_freq`` environment steps, one deterministic episode of the model on
    each of the first ``n_episodes`` targets of ``env``'s fixed set (episode k: target k,
    seed ``seed + k``), and the best model by mean final metric kept.

    Writes ``DIR/evaluations.npz`` (``timesteps``, ``results`` (returns), ``ep_lengths``,
    ``metrics``, ``successes``, ``wall_time_s`` (the run's training wall time then; NaN
    success where the environment has none)) and, whenever the mean metric improves,
    ``DIR/best_model.zip`` with the VecNormalize statistics of that moment
    (``DIR/vecnormalize.pkl``) and ``DIR/best.json``. ``env`` is a plain (not vectorised)
    environment, wrapped as training wraps it; its ``target_set`` must be one of
    :data:`SELECTION_SETS` (a ValueError otherwise: the test set is never read in
    training). On a resume the evaluations up to ``resumed_at`` are kept. With
    ``evaluate_at_start`` the model is also played once when learning starts (step 0)."""

    def __init__(
        self,
        env: Any,
        n_episodes: int,
        eval_freq: int,
        log_dir: Path,
        seed: int = 0,
        resumed_at: int = 0,
        base_wall_s: float = 0.0,
        stop: Any = None,
        evaluate_at_start: bool = False,
    ) -> None:
        super().__init__()
        self.evaluate_at_start = bool(evaluate_at_start)
        self.target_set = str(getattr(env.unwrapped, "target_set", ""))
        if self.target_set not in SELECTION_SETS:
            raise ValueError(
                f"model selection on target_set = {self.target_set!r}; allowed: "
                + ", ".join(SELECTION_SETS)
                + " (the test set is for the reported numbers only)"
            )
        self.eval_env = env
        self.n_episodes, self.eval_freq = int(n_episodes), int(eval_freq)
        self.log_dir = Path(log_dir)
        self.seed, self.resumed_at = int(seed), int(resumed_at)
        self.base_wall_s = float(base_wall_s)
        self.stop = stop
        self.rows: dict[str, list[Any]] = {k: [] for k in _EVAL_KEYS}
        self.best_metric = np.inf
        self.target_sets_played: set[str] = set()

    @property
    def path(self) -> Path:
        return self.log_dir / "evaluations.npz"

    def _init_callback(self) -> None:
        self._t0 = time.perf_counter()
        self.log_dir.mkdir(parents=True, exist_ok=True)
        if self.resumed_at > 0 and self.path.is_file():
            with np.load(self.path) as d:
                keep = d["timesteps"] <= self.resumed_at
                for k in _EVAL_KEYS:
                    if k in d.files:
                        self.rows[k] = [np.asarray(v).tolist() for v in d[k][keep]]
            if self.rows["metrics"]:
                self.best_metric = float(np.min(np.mean(self.rows["metrics"], axis=1)))
        done = self.rows["timesteps"]
        last = int(done[-1]) if done else 0
        self._next = (last // self.eval_freq + 1) * self.eval_freq

    def _play(self) -> dict[str, list[float]]:
        from bathprint.agents.rollout import run_episode

        policy = _ModelPolicy(self.model)
        out: dict[str, list[float]] = {"returns": [], "lengths": [], "metrics": [], "succ": []}
        for k in range(self.n_episodes):
            ep = run_episode(self.eval_env, policy, self.seed + k, target_index=k)
            self.target_sets_played.add(str(self.eval_env.unwrapped.target_set))
            out["returns"].append(ep.episode_return)
            out["lengths"].append(float(ep.length))
            out["metrics"].append(ep.metrics["metric"])
            out["succ"].append(ep.is_success)
        return out

    def evaluate(self) -> float:
        """Play the set now, log it, keep the model if it is the best; the mean metric."""
        wall = self.base_wall_s + time.perf_counter() - self._t0
        r = self._play()
        self.rows["timesteps"].append(int(self.num_timesteps))
        self.rows["results"].append(r["returns"])
        self.rows["ep_lengths"].append(r["lengths"])
        self.rows["metrics"].append(r["metrics"])
        self.rows["successes"].append(r["succ"])
        self.rows["wall_time_s"].append(wall)
        tmp = self.path.with_name(".evaluations.tmp.npz")
        np.savez(tmp, **{k: np.asarray(v, dtype=float if k != "timesteps" else int)
                         for k, v in self.rows.items()})
        tmp.replace(self.path)
        mean = float(np.mean(r["metrics"]))
        if mean < self.best_metric:
            self.best_metric = mean
            self.model.save(self.log_dir / "best_model.zip")
            venv = self.model.get_vec_normalize_env()
            if venv is not None:
                venv.save(str(self.log_dir / "vecnormalize.pkl"))
            (self.log_dir / "best.json").write_text(
                json.dumps(
                    {
                        "timesteps": int(self.num_timesteps),
                        "mean_metric": mean,
                        "target_set": self.target_set,
                        "episodes": self.n_episodes,
                        "wall_time_s": wall,
                    },
                    indent=2,
                )
            )
        return mean

    def _on_training_start(self) -> None:
        """With ``evaluate_at_start``, the model as learning starts (step 0 of a fresh run,
        e.g. a pretrained policy) is evaluated and may be kept as the best."""
        if self.evaluate_at_start and not self.rows["timesteps"]:
            self.evaluate()

    def _on_step(self) -> bool:
        if self.num_timesteps >= self._next:
            self.evaluate()
            self._next = (self.num_timesteps // self.eval_freq + 1) * self.eval_freq
        return True

    def _on_training_end(self) -> None:
        """A last evaluation where training ended between two (a time budget, a total that
        is not a multiple of eval_freq), unless a signal is ending it."""
        done = self.rows["timesteps"]
        if self.stop is not None and self.stop.requested:
            return
        if self.num_timesteps > 0 and (not done or int(done[-1]) < self.num_timesteps):
            self.evaluate()


class CriticWarmup(BaseCallback):
    """Freezes the actor (:func:`~bathprint.agents.imitation.actor_parameters`) while the
    model has run fewer than ``steps`` environment steps, so that PPO's updates then fit the
    value network only; the actor learns again from the first update after that. A resume
    before the end of the warm-up freezes it again until then."""

    def __init__(self, steps: int) -> None:
        super().__init__()
        self.steps = int(steps)
        self.frozen = False

    def _set(self, frozen: bool) -> None:
        from bathprint.agents.imitation import actor_parameters

        for p in actor_parameters(self.model.policy):
            p.requires_grad_(not frozen)
        self.frozen = frozen

    def _on_training_start(self) -> None:
        if self.num_timesteps < self.steps:
            self._set(True)

    def _on_rollout_end(self) -> None:  # called before each update
        if self.frozen and self.model.num_timesteps >= self.steps:
            self._set(False)

    def _on_step(self) -> bool:
        return True

    def _on_training_end(self) -> None:
        if self.frozen:
            self._set(False)


_EVAL_KEYS = ("timesteps", "results", "ep_lengths", "metrics", "successes", "wall_time_s")


class _ModelPolicy:
    """SB3's predict of a model being trained, on observations normalised with the
    training VecNormalize's current statistics (when it normalises observations)."""

    def __init__(self, model: Any) -> None:
        self.model = model
        self.venv = model.get_vec_normalize_env()

    def predict(self, obs: Any, state: Any = None, episode_start: Any = None,
                deterministic: bool = True) -> Any:
        if self.venv is not None and self.venv.norm_obs:
            obs = self.venv.normalize_obs(obs)
        return self.model.predict(obs, state, episode_start, deterministic)

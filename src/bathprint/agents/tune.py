"""Hyperparameter search on the validation targets (Optuna's TPE sampler, as rl-zoo3 does).

Each trial trains one run with the settings of a hyperparameter file (``--hyperparams``)
changed by the sampled values, for ``--timesteps`` environment steps, and scores it by the
best mean final metric its :class:`~bathprint.agents.callbacks.ValidationCallback` measured
on the validation targets (lower is better): the test set is never read. The study lives in
``OUT/study.log`` (Optuna's journal file), so a killed search continues where it stopped
when the same command is run again; ``OUT/trials.csv`` lists every trial (values, score,
steps, wall time) and ``OUT/best.json`` the best one::

    python -m bathprint.agents.tune --algo ppo --env bathprint/CoilRadius-v1 \\
        --hyperparams agents/ppo_residual.yml --trials 8 --timesteps 60000 --out runs/tune

The search space (:data:`SPACES`) is small on purpose: a few settings that matter, over
ranges rl-zoo3's samplers use, for a budget of a handful of trials.
"""

from __future__ import annotations

import argparse
import csv
import json
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from bathprint.errors import ConfigError


def _ppo_space(trial: Any, hp: dict[str, Any]) -> dict[str, Any]:
    out = {
        "learning_rate": trial.suggest_float("learning_rate", 1e-4, 1e-3, log=True),
        "n_epochs": trial.suggest_categorical("n_epochs", [5, 10, 20]),
        "gamma": trial.suggest_categorical("gamma", [0.98, 0.99, 0.995]),
        "clip_range": trial.suggest_categorical("clip_range", [0.1, 0.2, 0.3]),
    }
    pk = dict(hp.get("policy_kwargs") or {})
    pk["log_std_init"] = trial.suggest_float("log_std_init", -2.5, -0.5)
    out["policy_kwargs"] = pk
    return out


def _sac_space(trial: Any, hp: dict[str, Any]) -> dict[str, Any]:
    return {
        "learning_rate": trial.suggest_float("learning_rate", 1e-4, 1e-3, log=True),
        "gamma": trial.suggest_categorical("gamma", [0.98, 0.99, 0.995]),
        "ent_coef": trial.suggest_categorical("ent_coef", ["auto_0.01", "auto_0.05", "auto_0.2"]),
    }


#: algo -> (trial, base settings) -> the settings a trial changes
SPACES: dict[str, Callable[[Any, dict[str, Any]], dict[str, Any]]] = {
    "ppo": _ppo_space,
    "sac": _sac_space,
    "tqc": _sac_space,
}


def _score(run_dir: Path) -> tuple[float, int]:
    best = json.loads((run_dir / "eval" / "best.json").read_text())
    return float(best["mean_metric"]), int(best["timesteps"])


def tune(
    algo: str,
    env_id: str,
    hyperparams_file: str | Path,
    trials: int,
    timesteps: int,
    out: str | Path,
    seed: int = 0,
    n_envs: int | None = None,
) -> dict[str, Any]:
    """Run (or continue) the search until ``trials`` trials are complete; returns the best
    trial's record (also in ``OUT/best.json``)."""
    import optuna

    from bathprint.agents.hyperparams import load_hyperparams
    from bathprint.agents.train import read_run_info, train
    from bathprint.envs import resolve_id

    env_id = resolve_id(env_id)
    if algo not in SPACES:
        raise ConfigError(f"algo = {algo!r}; allowed: {', '.join(SPACES)}")
    for name, value in (("trials", trials), ("timesteps", timesteps)):
        if not (isinstance(value, int) and value >= 1):
            raise ConfigError(f"{name} = {value!r}; allowed: an integer >= 1")
    base = load_hyperparams(algo, env_id, hyperparams_file)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    storage = optuna.storages.JournalStorage(
        optuna.storages.journal.JournalFileBackend(str(out / "study.log"))
    )
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    study = optuna.create_study(
        study_name=f"{algo}-{env_id}",
        storage=storage,
        load_if_exists=True,
        direction="minimize",
        sampler=optuna.samplers.TPESampler(seed=seed, n_startup_trials=min(4, trials)),
    )

    def objective(trial: Any) -> float:
        changes = SPACES[algo](trial, base)
        hp = {**base, **changes}
        hp.pop("time_budget_s", None)  # a trial is a step budget, not a time budget
        run_dir = out / f"trial_{trial.number:03d}"
        if (run_dir / "run.json").exists():  # a trial killed before: start it over
            import shutil

            shutil.rmtree(run_dir)
        train(algo, env_id, timesteps=timesteps, n_envs=n_envs, seed=seed, out=run_dir,
              hyperparams=hp, progress=False)
        score, at = _score(run_dir)
        info = read_run_info(run_dir)
        trial.set_user_attr("best_timesteps", at)
        trial.set_user_attr("wall_time_s", float(info["wall_time_s"]))
        trial.set_user_attr("timesteps_done", int(info["timesteps_done"]))
        return score

    for t in study.trials:  # trials a kill left running are failed: they run again
        if t.state == optuna.trial.TrialState.RUNNING:
            storage.set_trial_state_values(t._trial_id, optuna.trial.TrialState.FAIL)
    t0 = time.perf_counter()
    done = [t for t in study.trials if t.state == optuna.trial.TrialState.COMPLETE]
    if len(done) < trials:
        study.optimize(objective, n_trials=trials - len(done))
    rows = []
    for t in study.trials:
        if t.state != optuna.trial.TrialState.COMPLETE:
            continue
        rows.append(
            {
                "trial": t.number,
                "validation_mean_metric": t.value,
                **t.params,
                **t.user_attrs,
            }
        )
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with (out / "trials.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys, restval="")
        w.writeheader()
        w.writerows(rows)
    best = study.best_trial
    record = {
        "algo": algo,
        "env_id": env_id,
        "hyperparams_file": str(hyperparams_file),
        "trials": len(rows),
        "timesteps_per_trial": timesteps,
        "seed": seed,
        "objective": "best mean final metric on the validation targets (lower is better)",
        "best_trial": best.number,
        "best_value": best.value,
        "best_params": best.params,
        "search_wall_time_s_this_session": time.perf_counter() - t0,
        "total_trial_wall_time_s": sum(float(r.get("wall_time_s", 0.0)) for r in rows),
    }
    (out / "best.json").write_text(json.dumps(record, indent=2))
    return record


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bathprint.agents.tune", description=__doc__)
    ap.add_argument("--algo", required=True, choices=list(SPACES))
    ap.add_argument("--env", required=True)
    ap.add_argument("--hyperparams", required=True, help="the file whose settings are tuned")
    ap.add_argument("--trials", type=int, default=8)
    ap.add_argument("--timesteps", type=int, default=60_000)
    ap.add_argument("--n-envs", type=int, default=None)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="runs/tune")
    args = ap.parse_args(argv)
    from bathprint._extras import MissingExtraError, require_extra

    try:
        require_extra("rl", "tuning hyperparameters")
    except MissingExtraError as exc:
        print(f"tune: {exc}", file=sys.stderr)
        return 2
    try:
        rec = tune(args.algo, args.env, args.hyperparams, args.trials, args.timesteps,
                   args.out, args.seed, args.n_envs)
    except (ValueError, FileNotFoundError) as exc:
        print(f"tune: {exc}", file=sys.stderr)
        return 2
    print(json.dumps(rec, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

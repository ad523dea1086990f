"""Where a training step's time goes: simulation, observation, scoring, policy.

Trains one run (``bathprint.agents.train.train``) with timers around the methods that do
the work and splits the wall time of the training steps into

- ``simulation``: ``Simulation.advance`` and the state snapshot of the environment step;
- ``observation``: the environment's observation (``_observe``);
- ``scoring``: recording the printed samples, the shape metric and the reward
  (``_record``, ``_evaluate``);
- ``env other``: the rest of the environment step and of ``reset`` (action to controls,
  flows, info dicts), Monitor and the residual wrapper's feedforward;
- ``policy forward``: rollout collection outside the vector environment (the policy's
  forward pass, the rollout buffer, VecNormalize);
- ``policy update``: PPO's / SAC's ``train`` (gradient steps), less the hindsight rewards;
- ``hindsight rewards``: the goal environment's ``compute_reward`` that hindsight
  experience replay calls on every relabelled sample it draws (inside ``train``);
- ``validation``: the ValidationCallback's episodes (model selection), kept apart;
- ``rest``: everything else (callbacks, logging, checkpoints, setup).

::

    taskset -c 1 python -m bathprint.agents.profile --env CoilRadius-v1 \\
        --hyperparams agents/ppo_residual.yml --timesteps 20000 --out agents/results/profile

writes ``OUT/<Env>_<name>.json`` and ``.md`` (``name``: the hyperparameter file's, else the
algorithm's; seconds, share, microseconds per environment step).
"""

from __future__ import annotations

import argparse
import functools
import json
import shutil
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

CATEGORIES = (
    "simulation", "observation", "scoring", "env other", "policy forward", "policy update",
    "hindsight rewards", "validation", "rest",
)


class _Timers:
    def __init__(self) -> None:
        self.total: dict[str, float] = {}
        self.in_validation = False

    def wrap(self, owner: Any, name: str, key: str, during_validation: bool = False) -> None:
        original = getattr(owner, name)
        timers = self

        @functools.wraps(original)
        def timed(*args: Any, **kwargs: Any) -> Any:
            if timers.in_validation and not during_validation:
                return original(*args, **kwargs)
            t0 = time.perf_counter()
            try:
                return original(*args, **kwargs)
            finally:
                timers.total[key] = timers.total.get(key, 0.0) + time.perf_counter() - t0

        setattr(owner, name, timed)
        self._undo.append((owner, name, original))

    def __enter__(self) -> _Timers:
        self._undo: list[tuple[Any, str, Callable[..., Any]]] = []
        return self

    def __exit__(self, *exc: Any) -> None:
        for owner, name, original in reversed(self._undo):
            setattr(owner, name, original)


def profile_training(
    algo: str,
    env_id: str,
    hyperparams_file: str | Path | None,
    timesteps: int,
    seed: int = 0,
    n_envs: int | None = None,
) -> dict[str, Any]:
    """Train ``timesteps`` steps in a temporary run folder with timers; returns the split."""
    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
    from stable_baselines3.common.vec_env import DummyVecEnv

    from bathprint.agents.callbacks import ValidationCallback
    from bathprint.agents.hyperparams import algo_class, load_hyperparams
    from bathprint.agents.train import read_run_info, train
    from bathprint.core.simulation import Simulation
    from bathprint.envs import make, resolve_id

    env_id = resolve_id(env_id)
    hp = load_hyperparams(algo, env_id, hyperparams_file)
    hp.pop("time_budget_s", None)
    if n_envs is not None:
        hp["n_envs"] = n_envs
    hp["vec_env"] = "dummy"  # one process: every timer sees every step
    env_cls = type(make(env_id).unwrapped)
    cls = algo_class(algo)
    collect = OnPolicyAlgorithm if issubclass(cls, OnPolicyAlgorithm) else OffPolicyAlgorithm
    tmp = Path(tempfile.mkdtemp(prefix="bathprint-profile-"))
    try:
        with _Timers() as t:
            t.wrap(Simulation, "advance", "sim_advance")
            t.wrap(env_cls, "_snapshot", "sim_snapshot")
            t.wrap(env_cls, "_observe", "observation")
            t.wrap(env_cls, "_record", "record")
            t.wrap(env_cls, "_evaluate", "evaluate_metric")
            t.wrap(env_cls, "step", "env_step")
            t.wrap(env_cls, "reset", "env_reset")
            t.wrap(DummyVecEnv, "step_wait", "vec_step")
            t.wrap(DummyVecEnv, "reset", "vec_reset")
            t.wrap(collect, "collect_rollouts", "collect_rollouts")
            t.wrap(cls, "train", "policy_update")
            if hasattr(env_cls, "goal_reward"):  # HER relabelling calls it inside train
                t.wrap(env_cls, "goal_reward", "goal_reward")
            original_eval = ValidationCallback.evaluate

            def evaluate(self: Any) -> float:
                t.in_validation = True
                t0 = time.perf_counter()
                try:
                    return original_eval(self)
                finally:
                    t.in_validation = False
                    t.total["validation"] = t.total.get("validation", 0.0) + (
                        time.perf_counter() - t0
                    )

            ValidationCallback.evaluate = evaluate  # type: ignore[method-assign]
            t._undo.append((ValidationCallback, "evaluate", original_eval))
            t0 = time.perf_counter()
            run_dir = train(algo, env_id, timesteps=timesteps, seed=seed, out=tmp / "run",
                            hyperparams=hp, progress=False)
            wall = time.perf_counter() - t0
        info = read_run_info(run_dir)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    g = t.total.get
    sim = g("sim_advance", 0.0) + g("sim_snapshot", 0.0)
    env = g("env_step", 0.0) + g("env_reset", 0.0)
    vec = g("vec_step", 0.0) + g("vec_reset", 0.0)
    split = {
        "simulation": sim,
        "observation": g("observation", 0.0),
        "scoring": g("record", 0.0) + g("evaluate_metric", 0.0),
        "env other": env - sim - g("observation", 0.0) - g("record", 0.0)
        - g("evaluate_metric", 0.0) + (vec - env),
        "policy forward": g("collect_rollouts", 0.0) - g("vec_step", 0.0)
        - (g("vec_reset", 0.0) if collect is OffPolicyAlgorithm else 0.0),
        "policy update": g("policy_update", 0.0) - g("goal_reward", 0.0),
        "hindsight rewards": g("goal_reward", 0.0),
        "validation": g("validation", 0.0),
    }
    split["rest"] = wall - sum(split.values())
    steps = int(info["timesteps_done"])
    return {
        "algo": algo,
        "env_id": env_id,
        "hyperparams_file": str(hyperparams_file) if hyperparams_file else None,
        "n_envs": int(info["n_envs"]),
        "timesteps": steps,
        "wall_time_s": wall,
        "steps_per_s_excluding_validation": steps / max(1e-9, wall - split["validation"]),
        "seconds": split,
        "share": {k: v / wall for k, v in split.items()},
        "us_per_step": {k: 1e6 * v / steps for k, v in split.items()},
        "raw_seconds": dict(t.total),
    }


def format_profile(rec: dict[str, Any]) -> str:
    lines = [
        f"{rec['env_id']}, {rec['algo']} ({rec['hyperparams_file']}), {rec['n_envs']} "
        f"environment(s) in one process: {rec['timesteps']} steps in "
        f"{rec['wall_time_s']:.1f} s ({rec['steps_per_s_excluding_validation']:.0f} steps/s "
        "without validation)\n",
        "| part | s | share | µs per env step |",
        "|---|---|---|---|",
    ]
    for k in CATEGORIES:
        lines.append(f"| {k} | {rec['seconds'][k]:.2f} | {100 * rec['share'][k]:.1f}% "
                     f"| {rec['us_per_step'][k]:.0f} |")
    return "\n".join(lines) + "\n"


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bathprint.agents.profile", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--algo", default="ppo")
    ap.add_argument("--env", required=True)
    ap.add_argument("--hyperparams", default=None)
    ap.add_argument("--timesteps", type=int, default=20_000)
    ap.add_argument("--n-envs", type=int, default=None)
    ap.add_argument("--out", default=None, help="directory for <Env>_<algo>.json and .md")
    args = ap.parse_args(argv)
    if args.timesteps < 1:
        print(f"profile: --timesteps = {args.timesteps}; must be >= 1", file=sys.stderr)
        return 2
    try:
        rec = profile_training(args.algo, args.env, args.hyperparams, args.timesteps,
                               n_envs=args.n_envs)
    except (ValueError, FileNotFoundError) as exc:
        print(f"profile: {exc}", file=sys.stderr)
        return 2
    text = format_profile(rec)
    print(text, end="")
    if args.out:
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        name = Path(args.hyperparams).stem if args.hyperparams else args.algo
        stem = f"{rec['env_id'].split('/')[-1]}_{name}"
        (out / f"{stem}.json").write_text(json.dumps(rec, indent=2))
        (out / f"{stem}.md").write_text(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())

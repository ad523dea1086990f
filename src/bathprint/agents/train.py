"""``bathprint train``: Stable-Baselines3 (PPO, SAC) on a bathprint environment.

A run directory holds everything a run writes, and everything ``--resume`` needs::

    run.json                 settings (algorithm, environment, seed, hyperparameters),
                             status (running, done, interrupted, failed: with the reason),
                             the wall time spent so far and, with ``bc_pretrain``, what
                             behaviour cloning did (pairs, action MSE before and after)
    checkpoints/             model_<N>_steps.zip (+ VecNormalize statistics and, for SAC,
                             the replay buffer) every ``checkpoint_freq`` environment steps
    episodes.csv             every training episode: timesteps, return, final metric
    eval/evaluations.npz     held-out evaluations (EvalCallback); eval/best_model.zip
    tb/                      TensorBoard logs (``tensorboard --logdir RUN/tb``)
    final_model.zip          the model at the end (+ vecnormalize.pkl)
    training_curve.png       final metric per training episode and on the held-out set

Everything is checked before the run folder is written: the hyperparameters
(:func:`~bathprint.agents.hyperparams.validate_hyperparams`), the environment's arguments
(one environment is built) and the algorithm's (the model is built on a stand-in of the
environment's spaces); a refusal is a :class:`~bathprint.errors.ConfigError`. A start that
fails later anyway is marked ``failed`` with its reason, and a rerun starts it over.

Ctrl-C (SIGINT) and SIGTERM stop training at the next environment step and save a
checkpoint there (model, VecNormalize statistics, SAC's replay buffer); the run is marked
``interrupted`` and ``--resume`` continues from that step. The vector env's workers ignore
both signals and are closed by the training process. A killed run (SIGKILL) resumes from
its last regular checkpoint and loses at most one checkpoint interval.

With ``bc_pretrain`` (PPO on a version-1 environment; :mod:`bathprint.agents.imitation`) a
freshly built model is first fitted to the training targets' own printing actions (never on
a model loaded from a checkpoint), its wall time counts towards the run's, and the
validation callback evaluates the pretrained model at step 0, so that model selection can
keep it if fine-tuning makes it worse.
"""

from __future__ import annotations

import csv
import functools
import json
import os
import re
import shutil
import signal
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.agents.hyperparams import (
    ALGOS,
    OFF_POLICY,
    agents_dir,
    algo_class,
    algo_kwargs_for,
    load_hyperparams,
    split_hyperparams,
    validate_hyperparams,
)
from bathprint.agents.imitation import bc_settings
from bathprint.agents.signals import Interrupted, SignalStop, signal_name
from bathprint.envs import printed_targets, target_set_size
from bathprint.errors import ConfigError

_CKPT = re.compile(r"model_(\d+)_steps\.zip$")
STATUSES = ("running", "done", "interrupted", "failed")
#: what a run folder holds (removed when a failed start is started over)
_RUN_FILES = (
    "run.json",
    "episodes.csv",
    "final_model.zip",
    "vecnormalize.pkl",
    "training_curve.png",
)
_RUN_DIRS = ("checkpoints", "monitor", "eval", "tb")


def _algo_class(algo: str) -> Any:
    return algo_class(algo)


def make_vec(
    env_id: str,
    n_envs: int,
    seed: int,
    env_kwargs: dict[str, Any],
    monitor_dir: Path | None = None,
    wrapper: dict[str, Any] | None = None,
    vec_env: str = "subproc",
) -> Any:
    """``n_envs`` copies (a :class:`~bathprint.agents.vecenv.QuietSubprocVecEnv` with
    forkserver when more than one and ``vec_env="subproc"``; a DummyVecEnv stepping them in
    turn in this process otherwise), Monitor-wrapped and then wrapped by ``wrapper`` (see
    :mod:`bathprint.agents.wrappers`). Several environments in one process batch the
    policy's forward pass, which costs about as much as an environment step for one."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv

    from bathprint.agents.vecenv import QuietSubprocVecEnv
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make

    if n_envs < 1:
        raise ConfigError(f"n_envs = {n_envs!r}; must be >= 1")
    sub = n_envs > 1 and vec_env == "subproc"
    return make_vec_env(
        functools.partial(make, env_id),
        n_envs=n_envs,
        seed=seed,
        env_kwargs=env_kwargs,
        monitor_dir=str(monitor_dir) if monitor_dir else None,
        monitor_kwargs={"override_existing": False},
        vec_env_cls=QuietSubprocVecEnv if sub else DummyVecEnv,
        vec_env_kwargs={"start_method": "forkserver"} if sub else None,
        wrapper_class=wrapper_factory(wrapper),
    )


def checkpoints(run_dir: Path) -> list[tuple[int, Path]]:
    """(steps, path) of the run's model checkpoints, oldest first."""
    out = []
    for p in (Path(run_dir) / "checkpoints").glob("model_*_steps.zip"):
        m = _CKPT.search(p.name)
        if m:
            out.append((int(m.group(1)), p))
    return sorted(out)


def eval_target_set(env_id: str) -> str:
    """The target set model selection plays: ``validation`` (version 1), ``eval`` (v0)."""
    return "validation" if printed_targets(env_id) else "eval"


def make_eval_env(env_id: str, env_kwargs: dict[str, Any], wrapper: dict[str, Any] | None) -> Any:
    """The environment of model selection: the validation set (v1; v0's ``eval``), wrapped
    as training wraps its environments."""
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make

    env = make(env_id, target_set=eval_target_set(env_id), **env_kwargs)
    factory = wrapper_factory(wrapper)
    return factory(env) if factory else env


def _make_callbacks(
    run_dir: Path,
    env_id: str,
    env_kwargs: dict[str, Any],
    normalize: dict[str, Any] | None,
    n_envs: int,
    run: dict[str, Any],
    resumed_at: int,
    algo: str,
    seed: int,
    base_wall_s: float = 0.0,
    stop: Any = None,
    evaluate_at_start: bool = False,
) -> list[Any]:
    from stable_baselines3.common.callbacks import CheckpointCallback

    from bathprint.agents.callbacks import EpisodeLogCallback, ValidationCallback

    ckpt_freq = max(1, int(run.get("checkpoint_freq", 10_000)) // n_envs)
    evaluator = ValidationCallback(
        make_eval_env(env_id, env_kwargs, run.get("wrapper")),
        n_episodes=int(run.get("eval_episodes", 16)),
        eval_freq=int(run.get("eval_freq", 10_000)),
        log_dir=run_dir / "eval",
        seed=seed + 10_000,
        resumed_at=resumed_at,
        base_wall_s=base_wall_s,
        stop=stop,
        evaluate_at_start=evaluate_at_start,
    )
    return [
        CheckpointCallback(
            ckpt_freq,
            str(run_dir / "checkpoints"),
            name_prefix="model",
            save_replay_buffer=algo in OFF_POLICY,
            save_vecnormalize=bool(normalize),
        ),
        evaluator,
        EpisodeLogCallback(run_dir / "episodes.csv", resumed_at, base_wall_s),
    ]


def _obs_norm(normalize: dict[str, Any]) -> dict[str, Any]:
    return {k: v for k, v in normalize.items() if k in ("norm_obs", "clip_obs", "gamma")}


def save_checkpoint(model: Any, run_dir: Path, algo: str) -> Path:
    """Checkpoint now (the same files CheckpointCallback writes)."""
    d = run_dir / "checkpoints"
    d.mkdir(parents=True, exist_ok=True)
    n = int(model.num_timesteps)
    path = d / f"model_{n}_steps.zip"
    model.save(path)
    if model.get_vec_normalize_env() is not None:
        model.get_vec_normalize_env().save(str(d / f"model_vecnormalize_{n}_steps.pkl"))
    if algo in OFF_POLICY:
        model.save_replay_buffer(d / f"model_replay_buffer_{n}_steps.pkl")
    return path


def _write_run(run_dir: Path, info: dict[str, Any]) -> None:
    """run.json, replaced in one step (a kill while writing leaves the previous one)."""
    path = run_dir / "run.json"
    tmp = path.with_name(f".run.json.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(info, indent=2, default=str))
    os.replace(tmp, path)


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def read_run_info(run_dir: str | Path) -> dict[str, Any]:
    """A run folder's ``run.json``, checked: valid JSON, the keys bathprint wrote, their
    types. Raises FileNotFoundError when there is none, ConfigError when it is damaged."""
    from bathprint.envs import ENV_IDS

    path = Path(run_dir) / "run.json"
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist")
    fix = "repair or restore it (or start a new run with another --out)"
    try:
        info = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ConfigError(
            f"{path}: not valid JSON ({exc.msg} at line {exc.lineno}, column {exc.colno}); {fix}"
        ) from None
    except UnicodeDecodeError as exc:
        raise ConfigError(f"{path}: not text ({exc.reason}); {fix}") from None
    if not isinstance(info, dict):
        raise ConfigError(f"{path}: holds a {type(info).__name__}, not a mapping; {fix}")
    required = {
        "algo": (lambda v: v in ALGOS, "one of " + ", ".join(ALGOS)),
        "env_id": (lambda v: v in ENV_IDS, "one of " + ", ".join(ENV_IDS)),
        "seed": (_is_int, "an integer"),
        "hyperparams": (lambda v: isinstance(v, dict), "a mapping"),
        "n_timesteps": (lambda v: _is_int(v) and v >= 1, "an integer >= 1"),
    }
    optional = {
        "status": (lambda v: v in STATUSES, "one of " + ", ".join(STATUSES)),
        "n_envs": (lambda v: _is_int(v) and v >= 1, "an integer >= 1"),
        "timesteps_done": (lambda v: _is_int(v) and v >= 0, "an integer >= 0"),
        "wall_time_s": (
            lambda v: isinstance(v, int | float) and not isinstance(v, bool) and v >= 0,
            "a number >= 0",
        ),
    }
    for key, (ok, allowed) in {**required, **optional}.items():
        if key not in info:
            if key in required:
                raise ConfigError(f"{path}: key {key!r} is missing ({allowed}); {fix}")
            continue
        if not ok(info[key]):
            raise ConfigError(f"{path}: {key} = {info[key]!r}; allowed: {allowed}; {fix}")
    return info


def _clear_run(run_dir: Path) -> None:
    """Remove what a run writes (only for a failed start without checkpoints)."""
    for name in _RUN_FILES:
        (run_dir / name).unlink(missing_ok=True)
    for name in _RUN_DIRS:
        if (run_dir / name).is_dir():
            shutil.rmtree(run_dir / name)


class _SpacesEnv:
    """A gymnasium environment with given spaces that does nothing (a stand-in for
    building a model or loading VecNormalize statistics)."""

    @staticmethod
    def vec(observation_space: Any, action_space: Any, n_envs: int = 1) -> Any:
        import gymnasium as gym
        from stable_baselines3.common.vec_env import DummyVecEnv

        class Spaces(gym.Env):
            def __init__(self) -> None:
                self.observation_space = observation_space
                self.action_space = action_space

            def reset(self, *, seed: int | None = None, options: Any = None) -> Any:
                return np.zeros(self.observation_space.shape, np.float32), {}

            def step(self, action: Any) -> Any:
                return np.zeros(self.observation_space.shape, np.float32), 0.0, True, False, {}

        return DummyVecEnv([Spaces] * n_envs)


def _preflight(
    algo: str, env_id: str, hp: dict[str, Any], n_envs: int, seed: int, where: str
) -> None:
    """Build what training builds, without touching the run folder: one environment (the
    environment checks its arguments), the VecNormalize, and the model on a stand-in vector
    env with the environment's spaces. Raises ConfigError naming what is wrong."""
    from stable_baselines3.common.vec_env import VecNormalize

    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make

    run, algo_kwargs = split_hyperparams(hp)
    env_kwargs = dict(run.get("env_kwargs", {}))
    failures = (ValueError, TypeError, LookupError, OSError)
    try:
        env = make(env_id, **env_kwargs)
    except failures as exc:
        raise ConfigError(f"{where}: env_kwargs = {env_kwargs!r}: {exc}") from None
    if run.get("wrapper"):
        try:
            env = wrapper_factory(run["wrapper"])(env)
        except failures as exc:
            raise ConfigError(f"{where}: wrapper = {run['wrapper']!r}: {exc}") from None
    u = env.unwrapped
    bc = bc_settings(run.get("bc_pretrain"), where)
    pool = getattr(getattr(u, "printed", None), "train_pool", None)
    if bc is not None and pool is not None and bc["targets"] > pool:
        env.close()
        raise ConfigError(
            f"{where}: bc_pretrain.targets = {bc['targets']}; the training pool of {env_id} "
            f"has {pool} targets: allowed 1..{pool}"
        )
    selection = eval_target_set(env_id)
    n_eval = target_set_size(u, selection)
    obs_space, act_space = env.observation_space, env.action_space
    env.close()
    eval_episodes = int(run.get("eval_episodes", 16))
    if eval_episodes > n_eval:
        name = "held-out" if selection == "eval" else selection
        raise ConfigError(
            f"{where}: eval_episodes = {eval_episodes}; the {name} set of {env_id} has "
            f"{n_eval} targets (one episode each): allowed 1..{n_eval}"
        )
    policy, kwargs = policy_and_kwargs(algo, run, algo_kwargs, where)
    if "buffer_size" in kwargs:  # its value is checked already; no need to allocate it here
        kwargs["buffer_size"] = min(int(kwargs["buffer_size"]), 1024)
    cls = algo_class(algo)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            venv = _SpacesEnv.vec(obs_space, act_space, n_envs)
            if run.get("normalize"):
                venv = VecNormalize(venv, **run["normalize"])
            cls(policy, venv, seed=seed, device="cpu", verbose=0, **kwargs)
        except Exception as exc:  # the constructor's own checks: asserts, TypeErrors, ...
            raise ConfigError(
                f"{where}: {cls.__name__} refuses these settings with {n_envs} environment(s): "
                f"{type(exc).__name__}: {exc}"
            ) from None


def policy_and_kwargs(
    algo: str, run: dict[str, Any], algo_kwargs: dict[str, Any], where: str
) -> tuple[Any, dict[str, Any]]:
    """The policy (the file's ``policy``; with ``bc_pretrain.ensemble`` K > 1 an
    :class:`~bathprint.agents.ensemble.EnsembleMlpPolicy` of K actors in its place) and the
    algorithm's keyword arguments for its constructor."""
    kwargs = algo_kwargs_for(algo, algo_kwargs)
    policy = run.get("policy", "MlpPolicy")
    bc = bc_settings(run.get("bc_pretrain"), where)
    if bc is None or bc["ensemble"] == 1:
        return policy, kwargs
    if policy != "MlpPolicy":
        raise ConfigError(
            f"{where}: bc_pretrain.ensemble = {bc['ensemble']} with policy = {policy!r}; an "
            "ensemble replaces MlpPolicy only: use MlpPolicy or ensemble: 1"
        )
    from bathprint.agents.ensemble import EnsembleMlpPolicy

    kwargs["policy_kwargs"] = {**(kwargs.get("policy_kwargs") or {}), "members": bc["ensemble"]}
    return EnsembleMlpPolicy, kwargs


def _plan(
    algo: str,
    env_id: str,
    run_dir: Path,
    seed: int | None,
    timesteps: int | None,
    resume: bool,
    hyperparams: dict[str, Any] | None,
    hyperparams_file: str | Path | None,
) -> tuple[dict[str, Any], bool, str]:
    """(run.json contents, whether a failed start is started over, where the settings come
    from): everything checked, nothing written."""
    info_path = run_dir / "run.json"
    if resume:
        if hyperparams is not None or hyperparams_file is not None:
            raise ConfigError(
                f"--resume continues {run_dir} with the settings in its run.json; "
                "--hyperparams cannot change them (start a new run with another --out)"
            )
        if not info_path.is_file():
            raise FileNotFoundError(f"--resume: {info_path} does not exist")
        info = read_run_info(run_dir)
        if info["algo"] != algo or info["env_id"] != env_id:
            raise ConfigError(
                f"--resume: {run_dir} is a {info['algo']} run on {info['env_id']}, "
                f"not {algo} on {env_id}"
            )
        if seed is not None and seed != info["seed"]:
            raise ConfigError(
                f"--resume: --seed = {seed}, but {run_dir} was started with seed "
                f"{info['seed']}; leave --seed out to continue it"
            )
        where = f"{info_path}: hyperparams"
        try:
            validate_hyperparams(algo, info["hyperparams"], where, env_id)
        except ConfigError as exc:
            if not checkpoints(run_dir):
                how = "" if info.get("status") == "failed" else f" after deleting {run_dir}"
                raise ConfigError(
                    f"{exc} (the run has no checkpoint yet: start it again without --resume{how})"
                ) from None
            raise
        if timesteps is not None:
            info["n_timesteps"] = int(timesteps)
        for key in ("error", "interrupted_by"):
            info.pop(key, None)
        return info, False, where
    start_over = False
    if info_path.exists():
        old = read_run_info(run_dir)
        status = old.get("status", "running")
        if status == "failed" and not checkpoints(run_dir):
            start_over = True
        else:
            done = old.get("timesteps_done", 0)
            raise FileExistsError(
                f"{run_dir} already holds a run ({status}, {done} of {old['n_timesteps']} "
                "steps); pass --resume to continue it or choose another --out"
            )
    if hyperparams is None:
        hyperparams = load_hyperparams(algo, env_id, hyperparams_file)
        path = Path(hyperparams_file) if hyperparams_file else agents_dir() / f"{algo}.yml"
        where = f"{path} ({env_id})"
    else:
        where = f"hyperparams ({env_id})"
    validate_hyperparams(algo, hyperparams, where, env_id)
    seed = 0 if seed is None else seed
    info = {
        "algo": algo,
        "env_id": env_id,
        "seed": seed,
        "hyperparams": hyperparams,
        "n_timesteps": int(timesteps or hyperparams.get("n_timesteps", 100_000)),
        "wall_time_s": 0.0,
        "status": "running",
    }
    return info, start_over, where


def _resume_files(run_dir: Path, algo: str, normalize: Any) -> tuple[int, Path | None]:
    """(steps, checkpoint) a resume starts from, checked for the files it needs."""
    ckpts = checkpoints(run_dir)
    if not ckpts:
        return 0, None
    n, path = ckpts[-1]
    d = run_dir / "checkpoints"
    stats = d / f"model_vecnormalize_{n}_steps.pkl"
    if normalize and not stats.is_file():
        raise ConfigError(
            f"--resume: {path.name} has no VecNormalize statistics ({stats.name} is missing) "
            "although the run normalises (hyperparams normalize); restore the file or delete "
            f"{path.name} to resume from the checkpoint before it"
        )
    return n, path


def train(
    algo: str,
    env_id: str,
    timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int | None = None,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    hyperparams: dict[str, Any] | None = None,
    hyperparams_file: str | Path | None = None,
) -> Path:
    """Train (or resume) a run; returns the run directory. ``hyperparams`` replaces the
    entry of ``agents/<algo>.yml`` (tests pass tiny budgets this way); ``hyperparams_file``
    reads it from another file of the same layout. ``seed`` defaults to 0 (on a resume, to
    the run's own).

    Raises ConfigError (before writing anything) for settings that cannot work, and
    :class:`~bathprint.agents.signals.Interrupted` (a KeyboardInterrupt) after saving a
    checkpoint when SIGINT or SIGTERM stopped it."""
    from bathprint.envs import resolve_id

    env_id = resolve_id(env_id)
    if algo not in ALGOS:
        raise ConfigError(f"algo = {algo!r}; allowed: {', '.join(ALGOS)}")
    for name, value in (("timesteps", timesteps), ("n_envs", n_envs)):
        if value is not None and not (_is_int(value) and value >= 1):
            raise ConfigError(f"{name} = {value!r}; allowed: an integer >= 1")
    run_dir = Path(out or f"runs/{algo}_{env_id.split('/')[-1]}_seed{seed or 0}")
    with SignalStop(deferred=False) as stop:  # deferred once the run folder is written
        try:
            import torch
            from stable_baselines3.common.vec_env import VecNormalize

            from bathprint.agents.callbacks import RunInfoCallback, StopOnRequest, TimeBudget

            cls = _algo_class(algo)
            info, start_over, where = _plan(
                algo, env_id, run_dir, seed, timesteps, resume, hyperparams, hyperparams_file
            )
            hp = info["hyperparams"]
            seed = int(info["seed"])
            run, algo_kwargs = split_hyperparams(hp)
            n_envs = int(n_envs or info.get("n_envs") or run.get("n_envs", 1))
            info["n_envs"] = n_envs
            env_kwargs = dict(run.get("env_kwargs", {}))
            normalize = run.get("normalize") or None
            total = int(info["n_timesteps"])
            resumed_at, ckpt = _resume_files(run_dir, algo, normalize) if resume else (0, None)
            _preflight(algo, env_id, hp, n_envs, seed, where)
        except KeyboardInterrupt as exc:
            name = signal_name(getattr(exc, "signum", signal.SIGINT))
            print(f"interrupted by {name} before training started: nothing written")
            raise
        torch.set_num_threads(int(run.get("torch_threads", 1)))
        stop.deferred = True
        run_dir.mkdir(parents=True, exist_ok=True)
        if start_over:
            _clear_run(run_dir)
        info["status"] = "running"
        _write_run(run_dir, info)
        venv: Any = None
        callbacks: list[Any] = []
        try:
            venv = make_vec(
                env_id, n_envs, seed, env_kwargs, run_dir / "monitor", run.get("wrapper"),
                str(run.get("vec_env", "subproc")),
            )
            if ckpt is not None:
                d = run_dir / "checkpoints"
                try:
                    if normalize:
                        stats = d / f"model_vecnormalize_{resumed_at}_steps.pkl"
                        venv = VecNormalize.load(str(stats), venv)
                    model = cls.load(
                        ckpt, env=venv, device="cpu", tensorboard_log=str(run_dir / "tb")
                    )
                    buffer = d / f"model_replay_buffer_{resumed_at}_steps.pkl"
                    if algo in OFF_POLICY and buffer.is_file():
                        model.load_replay_buffer(buffer)
                except Exception as exc:  # a damaged file: say which, and what to do
                    raise ConfigError(
                        f"--resume: checkpoint {ckpt.name} (or its statistics or replay "
                        f"buffer) cannot be loaded: {type(exc).__name__}: {exc}; delete "
                        f"{d}/*_{resumed_at}_steps.* to resume from the checkpoint before it"
                    ) from None
                print(f"resuming {run_dir} from {ckpt.name} ({resumed_at} of {total} steps)")
            else:
                if normalize:
                    venv = VecNormalize(venv, **normalize)
                policy, kwargs = policy_and_kwargs(algo, run, algo_kwargs, where)
                model = cls(
                    policy,
                    venv,
                    seed=seed,
                    device="cpu",
                    tensorboard_log=str(run_dir / "tb"),
                    verbose=0,
                    **kwargs,
                )
                bc = bc_settings(run.get("bc_pretrain"), where)
                if bc is not None:  # a fresh model only: a checkpoint keeps its weights
                    from bathprint.agents.imitation import pretrain

                    t_bc = time.perf_counter()
                    info["bc_pretrain"] = pretrain(model, env_id, env_kwargs, bc, seed)
                    info["bc_pretrain"]["wall_time_s"] = time.perf_counter() - t_bc
                    info["wall_time_s"] = float(info.get("wall_time_s", 0.0)) + float(
                        info["bc_pretrain"]["wall_time_s"]
                    )
                    _write_run(run_dir, info)
                    print(
                        f"bc_pretrain: {info['bc_pretrain']['demonstration_pairs']} pairs from "
                        f"{bc['targets']} training targets; action MSE "
                        f"{info['bc_pretrain']['mse_before']:.4f} -> "
                        f"{info['bc_pretrain']['mse_after']:.4f}"
                    )
            callbacks = _make_callbacks(
                run_dir, env_id, env_kwargs, normalize, n_envs, run, resumed_at, algo, seed,
                float(info.get("wall_time_s", 0.0)), stop,
                evaluate_at_start=ckpt is None and "bc_pretrain" in info,
            )
        except BaseException as exc:
            with stop.shield():
                interrupted = isinstance(exc, KeyboardInterrupt)
                info["status"] = "interrupted" if interrupted else "failed"
                if not interrupted:
                    info["error"] = f"{type(exc).__name__}: {exc}"
                _write_run(run_dir, info)
                _close(venv, callbacks)
                if interrupted:
                    name = signal_name(getattr(exc, "signum", signal.SIGINT))
                    print(f"interrupted by {name} while starting: {run_dir} holds no new steps")
            raise
        bc = bc_settings(run.get("bc_pretrain"), where)
        if bc is not None and bc["critic_warmup_steps"] > 0:
            from bathprint.agents.callbacks import CriticWarmup

            callbacks.insert(0, CriticWarmup(bc["critic_warmup_steps"]))
        callbacks.append(RunInfoCallback(functools.partial(_write_run, run_dir), info))
        callbacks.append(StopOnRequest(stop))
        budget = None
        if run.get("time_budget_s"):
            budget = TimeBudget(float(run["time_budget_s"]), float(info.get("wall_time_s", 0.0)))
            callbacks.insert(0, budget)  # before the evaluation, which runs at its end
        info.update(_compute_info(n_envs, int(run.get("torch_threads", 1))))
        info["train_target_set"] = "train"
        info["eval_target_set"] = eval_target_set(env_id)
        cpu0 = _cpu_seconds()
        remaining = max(0, total - int(model.num_timesteps))
        base_wall = float(info.get("wall_time_s", 0.0))  # time spent before this session
        t0 = time.perf_counter()
        signum: int | None = None
        error: BaseException | None = None
        try:
            if remaining > 0 and not stop.requested:
                model.learn(
                    remaining,
                    callback=callbacks,
                    progress_bar=progress,
                    reset_num_timesteps=ckpt is None,
                    tb_log_name="run",
                )
        except KeyboardInterrupt as exc:  # a second signal, or a KeyboardInterrupt raised
            signum = getattr(exc, "signum", None) or stop.signum or signal.SIGINT
        except BaseException as exc:
            error = exc
        if signum is None and stop.requested and int(model.num_timesteps) < total:
            signum = stop.signum
        with stop.shield():
            info["wall_time_s"] = base_wall + time.perf_counter() - t0
            info["cpu_time_s"] = float(info.get("cpu_time_s", 0.0)) + _cpu_seconds() - cpu0
            info["timesteps_done"] = int(model.num_timesteps)
            if budget is not None and budget.reached:
                info["stopped_by"] = "time_budget"
            message = ""
            if error is not None:
                info["status"] = "failed"
                info["error"] = f"{type(error).__name__}: {error}"
            elif signum is not None:
                path = save_checkpoint(model, run_dir, algo)
                info["status"] = "interrupted"
                info["interrupted_by"] = signal_name(signum)
                message = (
                    f"\ninterrupted by {signal_name(signum)}: saved {path} "
                    f"({model.num_timesteps} steps); continue with --resume"
                )
            else:
                info["status"] = "done"
                model.save(run_dir / "final_model.zip")
                if normalize:
                    model.get_vec_normalize_env().save(str(run_dir / "vecnormalize.pkl"))
            _write_run(run_dir, info)
            _close(venv, callbacks)
            if message:
                print(message)
        if error is not None:
            raise error
        from bathprint.agents.curves import plot_training_curve

        plot_training_curve(run_dir)
    if signum is not None:
        raise Interrupted(signum)
    return run_dir


def _cpu_seconds() -> float:
    """CPU time of this process and its finished children (s)."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _compute_info(n_envs: int, torch_threads: int) -> dict[str, Any]:
    """What a run's compute is measured on: cores, load, threads, environments."""
    import platform

    return {
        "machine": {
            "cpus": os.cpu_count(),
            "processor": platform.processor() or platform.machine(),
            "load_average_1min_at_start": os.getloadavg()[0],
        },
        "torch_threads": torch_threads,
        "n_envs": n_envs,
    }


def _close(venv: Any, callbacks: list[Any]) -> None:
    if venv is not None:
        venv.close()
    for cb in callbacks:
        if getattr(cb, "eval_env", None) is not None:
            cb.eval_env.close()


def trained_files(path: str | Path) -> tuple[str, Path, Path, str, str]:
    """(algo, model .zip, VecNormalize statistics path, label, normalisation note) of a run
    directory or a model ``.zip``, checked without loading anything. A run directory gives
    its final model, or its newest checkpoint if it has none yet.

    The note says where the observation statistics come from. A run trained with
    observation normalisation whose statistics file is missing is refused (ConfigError):
    its policy would see observations on another scale. A missing file is harmless when
    only rewards were normalised (the note says so), and a bare ``.zip`` with no run.json
    and no statistics beside it is evaluated on raw observations (the note says that too).
    """
    path = Path(path)
    run_json: Path | None = None
    info: dict[str, Any] | None
    if path.is_dir():
        run_json = path / "run.json"
        info = read_run_info(path)
        algo = info["algo"]
        if (path / "final_model.zip").is_file():
            zip_path, stats = path / "final_model.zip", path / "vecnormalize.pkl"
        else:
            ckpts = checkpoints(path)
            if not ckpts:
                raise FileNotFoundError(f"{path} has neither final_model.zip nor checkpoints")
            n, zip_path = ckpts[-1]
            stats = path / "checkpoints" / f"model_vecnormalize_{n}_steps.pkl"
        label = f"{algo}:{path.name}"
    else:
        zip_path = path
        run_json = _run_json_above(path)
        if run_json is not None:
            info = read_run_info(run_json.parent)
            algo = info["algo"]
        else:
            info = None
            algo = _guess_algo(path)
        m = _CKPT.search(path.name)
        if m:  # a checkpoint: its own statistics
            stats = path.with_name(f"model_vecnormalize_{m.group(1)}_steps.pkl")
        else:  # final_model.zip and others: the statistics beside them
            stats = path.with_name("vecnormalize.pkl")
        label = f"{algo}:{path.stem}"
    normalize = info["hyperparams"].get("normalize") if info is not None else None
    norm_obs = isinstance(normalize, dict) and bool(normalize.get("norm_obs", True))
    if stats.is_file():
        note = f"statistics from {stats}"
    elif info is None:
        note = (
            f"no VecNormalize statistics beside {path} and no run.json above it: evaluated "
            "on raw observations (wrong if training normalised them)"
        )
    elif norm_obs:
        raise ConfigError(
            f"{label}: the run normalised observations (normalize in {run_json}) but "
            f"{stats} is missing; without it the policy would see observations on another "
            "scale: restore the file, or evaluate a checkpoint that has its statistics"
        )
    elif normalize:
        note = f"{stats.name} missing; not needed: the run normalised rewards only (norm_obs false)"
    else:
        note = "not used in training"
    return algo, zip_path, stats, label, note


def load_trained(path: str | Path) -> tuple[Any, Any, str, str]:
    """(model, VecNormalize or None, label, normalisation note) of a run directory or a
    model ``.zip`` (see :func:`trained_files`, which refuses missing statistics)."""
    from stable_baselines3.common.vec_env import VecNormalize

    algo, zip_path, stats, label, note = trained_files(path)
    # Playing needs no replay buffer: the one-slot default buffer stands in for the trained
    # one (a HerReplayBuffer cannot be rebuilt without the training environment).
    unused_buffer = {"replay_buffer_class": None, "replay_buffer_kwargs": {}, "buffer_size": 1}
    model = _algo_class(algo).load(
        zip_path, device="cpu", custom_objects=unused_buffer if algo in OFF_POLICY else None
    )
    normalizer = None
    if stats.is_file():
        normalizer = VecNormalize.load(str(stats), _dummy_venv(model))
        normalizer.training = False
    return model, normalizer, label, note


def _run_json_above(path: Path) -> Path | None:
    return next((p / "run.json" for p in Path(path).parents if (p / "run.json").is_file()), None)


def _guess_algo(path: Path) -> str:
    import zipfile

    try:
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("data"))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError, OSError) as exc:
        raise ConfigError(f"{path}: not a Stable-Baselines3 model file ({exc})") from None
    if "top_quantiles_to_drop_per_net" in data:
        return "tqc"
    return "sac" if "target_entropy" in data else "ppo"


def _dummy_venv(model: Any) -> Any:
    """A VecEnv with the model's spaces, for loading VecNormalize statistics."""
    return _SpacesEnv.vec(model.observation_space, model.action_space)


def read_episodes(run_dir: Path) -> list[dict[str, float]]:
    """Rows of ``episodes.csv`` as floats."""
    path = Path(run_dir) / "episodes.csv"
    if not path.is_file():
        return []
    with path.open() as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]

"""``bathprint train``: Stable-Baselines3 (PPO, SAC) on a bathprint environment.

A run directory holds everything a run writes, and everything ``--resume`` needs::

    run.json                 settings (algorithm, environment, seed, hyperparameters),
                             status (running, done, interrupted, failed: with the reason),
                             the wall time spent so far and, with ``bc_pretrain``, what
                             behaviour cloning did (pairs, action MSE before and after),
                             the code of each session (``code``: version and commit)
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

With ``bc_pretrain`` (PPO on an environment of version 1 or later;
:mod:`bathprint.agents.imitation`) a freshly built model is first fitted to the training
targets' own printing actions, or with ``demonstrator: controller`` to the tuned
controller's actions on the training shapes (never on a model loaded from a checkpoint),
its wall time counts towards the run's, and the
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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.agents.algos import ALGOS, OFF_POLICY
from bathprint.agents.hyperparams import (
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
from bathprint.provenance import code_version

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
    s: RunSettings, base_wall_s: float, stop: Any, evaluate_at_start: bool
) -> list[Any]:
    """The run's checkpoints, validation (model selection) and episode log, in this order
    (tests add theirs after them by replacing this function)."""
    from stable_baselines3.common.callbacks import CheckpointCallback

    from bathprint.agents.callbacks import EpisodeLogCallback, ValidationCallback

    ckpt_freq = max(1, int(s.run.get("checkpoint_freq", 10_000)) // s.n_envs)
    evaluator = ValidationCallback(
        make_eval_env(s.env_id, s.env_kwargs, s.wrapper),
        n_episodes=int(s.run.get("eval_episodes", 16)),
        eval_freq=int(s.run.get("eval_freq", 10_000)),
        log_dir=s.run_dir / "eval",
        seed=s.seed + 10_000,
        resumed_at=s.resumed_at,
        base_wall_s=base_wall_s,
        stop=stop,
        evaluate_at_start=evaluate_at_start,
    )
    return [
        CheckpointCallback(
            ckpt_freq,
            str(s.run_dir / "checkpoints"),
            name_prefix="model",
            save_replay_buffer=s.algo in OFF_POLICY,
            save_vecnormalize=bool(s.normalize),
        ),
        evaluator,
        EpisodeLogCallback(s.run_dir / "episodes.csv", s.resumed_at, base_wall_s),
    ]


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


@dataclass(frozen=True)
class RunSettings:
    """A run's settings, resolved and checked before anything is written: the algorithm,
    the environment, the run folder, the seed and budget, and the hyperparameters split
    into bathprint's own keys (``run``) and the algorithm's (``algo_kwargs``)."""

    algo: str
    env_id: str
    run_dir: Path
    seed: int
    n_envs: int
    total_timesteps: int  # environment steps the run ends at (over every session)
    run: dict[str, Any]
    algo_kwargs: dict[str, Any]
    where: str  # where the settings come from, for messages
    start_over: bool  # a failed start without checkpoints: its files are removed first
    resumed_at: int  # steps of the checkpoint a resume continues (0: a fresh model)
    checkpoint: Path | None  # that checkpoint

    @property
    def env_kwargs(self) -> dict[str, Any]:
        return dict(self.run.get("env_kwargs", {}))

    @property
    def normalize(self) -> dict[str, Any] | None:
        """VecNormalize's arguments, or None without normalisation."""
        return self.run.get("normalize") or None

    @property
    def wrapper(self) -> dict[str, Any] | None:
        return self.run.get("wrapper")

    @property
    def torch_threads(self) -> int:
        return int(self.run.get("torch_threads", 1))

    @property
    def bc(self) -> dict[str, Any] | None:
        """Behaviour cloning's settings (``bc_pretrain``), or None."""
        return bc_settings(self.run.get("bc_pretrain"), self.where)


@dataclass
class Trainer:
    """What a session trains with: the vector env, the model, its callbacks and the time
    budget among them (None without ``time_budget_s``)."""

    venv: Any
    model: Any
    callbacks: list[Any]
    budget: Any = None

    def close(self) -> None:
        _close(self.venv, self.callbacks)


@dataclass(frozen=True)
class Outcome:
    """How a session's ``learn`` ended: the signal that stopped it early, or the error it
    raised (neither: it reached its budget), and its wall and CPU time (s)."""

    signum: int | None
    error: BaseException | None
    wall_s: float
    cpu_s: float


def resolve_settings(
    algo: str,
    env_id: str,
    run_dir: Path,
    seed: int | None,
    timesteps: int | None,
    n_envs: int | None,
    resume: bool,
    hyperparams: dict[str, Any] | None,
    hyperparams_file: str | Path | None,
) -> tuple[RunSettings, dict[str, Any]]:
    """(settings, run.json contents) of a new or resumed run: everything checked (the
    files, the hyperparameters, one environment and the model on its spaces), nothing
    written. Raises ConfigError, FileNotFoundError or FileExistsError."""
    info, start_over, where = _plan(
        algo, env_id, run_dir, seed, timesteps, resume, hyperparams, hyperparams_file
    )
    hp = info["hyperparams"]
    run, algo_kwargs = split_hyperparams(hp)
    n = int(n_envs or info.get("n_envs") or run.get("n_envs", 1))
    info["n_envs"] = n
    normalize = run.get("normalize") or None
    resumed_at, ckpt = _resume_files(run_dir, algo, normalize) if resume else (0, None)
    settings = RunSettings(
        algo=algo,
        env_id=env_id,
        run_dir=run_dir,
        seed=int(info["seed"]),
        n_envs=n,
        total_timesteps=int(info["n_timesteps"]),
        run=run,
        algo_kwargs=algo_kwargs,
        where=where,
        start_over=start_over,
        resumed_at=resumed_at,
        checkpoint=ckpt,
    )
    _preflight(algo, env_id, hp, n, settings.seed, where)
    return settings, info


def _load_model(s: RunSettings, venv: Any) -> Any:
    """The checkpoint a resume continues, on ``venv`` (with its VecNormalize statistics
    and, off-policy, its replay buffer). A damaged file is a ConfigError naming it."""
    from stable_baselines3.common.vec_env import VecNormalize

    assert s.checkpoint is not None
    d = s.run_dir / "checkpoints"
    try:
        if s.normalize:
            stats = d / f"model_vecnormalize_{s.resumed_at}_steps.pkl"
            venv = VecNormalize.load(str(stats), venv)
        model = _algo_class(s.algo).load(
            s.checkpoint, env=venv, device="cpu", tensorboard_log=str(s.run_dir / "tb")
        )
        buffer = d / f"model_replay_buffer_{s.resumed_at}_steps.pkl"
        if s.algo in OFF_POLICY and buffer.is_file():
            model.load_replay_buffer(buffer)
    except Exception as exc:  # a damaged file: say which, and what to do
        raise ConfigError(
            f"--resume: checkpoint {s.checkpoint.name} (or its statistics or replay "
            f"buffer) cannot be loaded: {type(exc).__name__}: {exc}; delete "
            f"{d}/*_{s.resumed_at}_steps.* to resume from the checkpoint before it"
        ) from None
    print(
        f"resuming {s.run_dir} from {s.checkpoint.name} "
        f"({s.resumed_at} of {s.total_timesteps} steps)"
    )
    return model


def _new_model(s: RunSettings, venv: Any, info: dict[str, Any]) -> Any:
    """A fresh model on ``venv`` (VecNormalize-wrapped when the run normalises), fitted
    first by behaviour cloning with ``bc_pretrain`` (recorded in ``info`` and run.json)."""
    from stable_baselines3.common.vec_env import VecNormalize

    if s.normalize:
        venv = VecNormalize(venv, **s.normalize)
    policy, kwargs = policy_and_kwargs(s.algo, s.run, s.algo_kwargs, s.where)
    model = _algo_class(s.algo)(
        policy,
        venv,
        seed=s.seed,
        device="cpu",
        tensorboard_log=str(s.run_dir / "tb"),
        verbose=0,
        **kwargs,
    )
    bc = s.bc
    if bc is not None:  # a fresh model only: a checkpoint keeps its weights
        from bathprint.agents.imitation import pretrain

        t_bc = time.perf_counter()
        info["bc_pretrain"] = pretrain(model, s.env_id, s.env_kwargs, bc, s.seed)
        info["bc_pretrain"]["wall_time_s"] = time.perf_counter() - t_bc
        info["wall_time_s"] = float(info.get("wall_time_s", 0.0)) + float(
            info["bc_pretrain"]["wall_time_s"]
        )
        _write_run(s.run_dir, info)
        print(
            f"bc_pretrain: {info['bc_pretrain']['demonstration_pairs']} pairs from "
            f"{bc['targets']} training targets ({bc['demonstrator']}); action MSE "
            f"{info['bc_pretrain']['mse_before']:.4f} -> {info['bc_pretrain']['mse_after']:.4f}"
        )
    return model


def _build(s: RunSettings, info: dict[str, Any], stop: Any) -> Trainer:
    """The vector env, the model (loaded or new) and the run's callbacks. Whatever stops
    it (an error, a signal) marks the run failed or interrupted, closes what was built and
    is raised again."""
    from bathprint.agents.callbacks import RunInfoCallback, StopOnRequest, TimeBudget

    venv: Any = None
    callbacks: list[Any] = []
    try:
        venv = make_vec(
            s.env_id, s.n_envs, s.seed, s.env_kwargs, s.run_dir / "monitor", s.wrapper,
            str(s.run.get("vec_env", "subproc")),
        )
        model = _load_model(s, venv) if s.checkpoint is not None else _new_model(s, venv, info)
        callbacks = _make_callbacks(
            s, float(info.get("wall_time_s", 0.0)), stop,
            evaluate_at_start=s.checkpoint is None and "bc_pretrain" in info,
        )
    except BaseException as exc:
        with stop.shield():
            interrupted = isinstance(exc, KeyboardInterrupt)
            info["status"] = "interrupted" if interrupted else "failed"
            if not interrupted:
                info["error"] = f"{type(exc).__name__}: {exc}"
            _write_run(s.run_dir, info)
            _close(venv, callbacks)
            if interrupted:
                name = signal_name(getattr(exc, "signum", signal.SIGINT))
                print(f"interrupted by {name} while starting: {s.run_dir} holds no new steps")
        raise
    bc = s.bc
    if bc is not None and bc["critic_warmup_steps"] > 0:
        from bathprint.agents.callbacks import CriticWarmup

        callbacks.insert(0, CriticWarmup(bc["critic_warmup_steps"]))
    callbacks.append(RunInfoCallback(functools.partial(_write_run, s.run_dir), info))
    callbacks.append(StopOnRequest(stop))
    budget = None
    if s.run.get("time_budget_s"):
        budget = TimeBudget(float(s.run["time_budget_s"]), float(info.get("wall_time_s", 0.0)))
        callbacks.insert(0, budget)  # before the evaluation, which runs at its end
    return Trainer(venv, model, callbacks, budget)


def _learn(s: RunSettings, t: Trainer, stop: Any, progress: bool) -> Outcome:
    """Train up to the run's budget; a signal or an error ends it early (recorded in the
    outcome, not raised)."""
    cpu0 = _cpu_seconds()
    remaining = max(0, s.total_timesteps - int(t.model.num_timesteps))
    t0 = time.perf_counter()
    signum: int | None = None
    error: BaseException | None = None
    try:
        if remaining > 0 and not stop.requested:
            t.model.learn(
                remaining,
                callback=t.callbacks,
                progress_bar=progress,
                reset_num_timesteps=s.checkpoint is None,
                tb_log_name="run",
            )
    except KeyboardInterrupt as exc:  # a second signal, or a KeyboardInterrupt raised
        signum = getattr(exc, "signum", None) or stop.signum or signal.SIGINT
    except BaseException as exc:
        error = exc
    if signum is None and stop.requested and int(t.model.num_timesteps) < s.total_timesteps:
        signum = stop.signum
    return Outcome(signum, error, time.perf_counter() - t0, _cpu_seconds() - cpu0)


def _save(
    s: RunSettings, t: Trainer, info: dict[str, Any], outcome: Outcome, base_wall: float
) -> str:
    """Record the session in run.json and save: the final model (done), a checkpoint
    (interrupted) or nothing (failed). Returns the message to print after closing."""
    info["wall_time_s"] = base_wall + outcome.wall_s
    info["cpu_time_s"] = float(info.get("cpu_time_s", 0.0)) + outcome.cpu_s
    info["timesteps_done"] = int(t.model.num_timesteps)
    if t.budget is not None and t.budget.reached:
        info["stopped_by"] = "time_budget"
    message = ""
    if outcome.error is not None:
        info["status"] = "failed"
        info["error"] = f"{type(outcome.error).__name__}: {outcome.error}"
    elif outcome.signum is not None:
        path = save_checkpoint(t.model, s.run_dir, s.algo)
        info["status"] = "interrupted"
        info["interrupted_by"] = signal_name(outcome.signum)
        message = (
            f"\ninterrupted by {signal_name(outcome.signum)}: saved {path} "
            f"({t.model.num_timesteps} steps); continue with --resume"
        )
    else:
        info["status"] = "done"
        t.model.save(s.run_dir / "final_model.zip")
        if s.normalize:
            t.model.get_vec_normalize_env().save(str(s.run_dir / "vecnormalize.pkl"))
    _write_run(s.run_dir, info)
    return message


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

    The steps: :func:`resolve_settings` (checked, nothing written), the run folder and
    run.json, :func:`_build` (environments, model, callbacks), :func:`_learn`, then
    :func:`_save` (final model or checkpoint, run.json) and the training curve.

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

            _algo_class(algo)  # stable-baselines3 loaded before the checks
            s, info = resolve_settings(
                algo, env_id, run_dir, seed, timesteps, n_envs, resume, hyperparams,
                hyperparams_file,
            )
        except KeyboardInterrupt as exc:
            name = signal_name(getattr(exc, "signum", signal.SIGINT))
            print(f"interrupted by {name} before training started: nothing written")
            raise
        torch.set_num_threads(s.torch_threads)
        stop.deferred = True
        run_dir.mkdir(parents=True, exist_ok=True)
        if s.start_over:
            _clear_run(run_dir)
        info["status"] = "running"
        _write_run(run_dir, info)
        trainer = _build(s, info, stop)
        info.update(_compute_info(s.n_envs, s.torch_threads))
        codes = info.setdefault("code", [])  # the code of each session (a resume may differ)
        if code_version() not in codes:
            codes.append(code_version())
        info["train_target_set"] = "train"
        info["eval_target_set"] = eval_target_set(env_id)
        base_wall = float(info.get("wall_time_s", 0.0))  # time spent before this session
        outcome = _learn(s, trainer, stop, progress)
        with stop.shield():
            message = _save(s, trainer, info, outcome, base_wall)
            trainer.close()
            if message:
                print(message)
        if outcome.error is not None:
            raise outcome.error
        from bathprint.agents.curves import plot_training_curve

        plot_training_curve(run_dir)
    if outcome.signum is not None:
        raise Interrupted(outcome.signum)
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
    the model its validation selected (``eval/best_model.zip``, labelled "selected on
    validation"), else its final model, else its newest checkpoint; the final model on
    request is ``RUN_DIR/final_model.zip``.

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
        selected = path / "eval" / "best_model.zip"
        if selected.is_file():
            zip_path, stats = selected, path / "eval" / "vecnormalize.pkl"
        elif (path / "final_model.zip").is_file():
            zip_path, stats = path / "final_model.zip", path / "vecnormalize.pkl"
        else:
            ckpts = checkpoints(path)
            if not ckpts:
                raise FileNotFoundError(f"{path} has neither final_model.zip nor checkpoints")
            n, zip_path = ckpts[-1]
            stats = path / "checkpoints" / f"model_vecnormalize_{n}_steps.pkl"
        label = f"{algo}:{path.name}"
        if zip_path == selected:
            label += " (selected on validation)"
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
    """Rows of ``episodes.csv`` as floats (or of ``episodes.csv.gz``, an exported run's)."""
    import gzip

    path = Path(run_dir) / "episodes.csv"
    gz = path.with_name("episodes.csv.gz")
    if path.is_file():
        f = path.open(newline="")
    elif gz.is_file():
        f = gzip.open(gz, "rt", newline="")
    else:
        return []
    with f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]

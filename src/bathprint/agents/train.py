"""``bathprint train``: Stable-Baselines3 (PPO, SAC) on a bathprint environment.

A run directory holds everything a run writes, and everything ``--resume`` needs::

    run.json                 settings (algorithm, environment, seed, hyperparameters),
                             status and the wall time spent so far
    checkpoints/             model_<N>_steps.zip (+ VecNormalize statistics and, for SAC,
                             the replay buffer) every ``checkpoint_freq`` environment steps
    episodes.csv             every training episode: timesteps, return, final metric
    eval/evaluations.npz     held-out evaluations (EvalCallback); eval/best_model.zip
    tb/                      TensorBoard logs (``tensorboard --logdir RUN/tb``)
    final_model.zip          the model at the end (+ vecnormalize.pkl)
    training_curve.png       final metric per training episode and on the held-out set

Ctrl-C saves a checkpoint at once; a killed run resumes from its last checkpoint
(``--resume``) and loses at most one checkpoint interval.
"""

from __future__ import annotations

import csv
import functools
import json
import re
import time
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.agents.hyperparams import load_hyperparams, split_hyperparams

_CKPT = re.compile(r"model_(\d+)_steps\.zip$")


def _algo_class(algo: str) -> Any:
    from stable_baselines3 import PPO, SAC

    classes = {"ppo": PPO, "sac": SAC}
    if algo not in classes:
        raise ValueError(f"algo = {algo!r}; allowed: {', '.join(classes)}")
    return classes[algo]


def make_vec(
    env_id: str,
    n_envs: int,
    seed: int,
    env_kwargs: dict[str, Any],
    monitor_dir: Path | None = None,
    wrapper: dict[str, Any] | None = None,
) -> Any:
    """``n_envs`` copies (SubprocVecEnv with forkserver when more than one), Monitor-wrapped
    and then wrapped by ``wrapper`` (see :mod:`bathprint.agents.wrappers`)."""
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make

    if n_envs < 1:
        raise ValueError(f"n_envs = {n_envs!r}; must be >= 1")
    sub = n_envs > 1
    return make_vec_env(
        functools.partial(make, env_id),
        n_envs=n_envs,
        seed=seed,
        env_kwargs=env_kwargs,
        monitor_dir=str(monitor_dir) if monitor_dir else None,
        monitor_kwargs={"override_existing": False},
        vec_env_cls=SubprocVecEnv if sub else DummyVecEnv,
        vec_env_kwargs={"start_method": "forkserver"} if sub else None,
        wrapper_class=wrapper_factory(wrapper),
    )


def checkpoints(run_dir: Path) -> list[tuple[int, Path]]:
    """(steps, path) of the run's model checkpoints, oldest first."""
    out = []
    for p in (run_dir / "checkpoints").glob("model_*_steps.zip"):
        m = _CKPT.search(p.name)
        if m:
            out.append((int(m.group(1)), p))
    return sorted(out)


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
) -> list[Any]:
    from stable_baselines3.common.callbacks import CheckpointCallback, EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize

    from bathprint.agents.callbacks import EpisodeLogCallback, ResumableEvalCallback

    eval_kwargs = dict(env_kwargs, target_set="eval")
    eval_env = make_vec(env_id, 1, seed + 10_000, eval_kwargs, wrapper=run.get("wrapper"))
    if normalize:
        eval_env = VecNormalize(eval_env, training=False, norm_reward=False, **_obs_norm(normalize))
    eval_freq = max(1, int(run.get("eval_freq", 10_000)) // n_envs)
    ckpt_freq = max(1, int(run.get("checkpoint_freq", 10_000)) // n_envs)
    evaluator: EvalCallback = ResumableEvalCallback(
        eval_env,
        n_eval_episodes=int(run.get("eval_episodes", 16)),
        eval_freq=eval_freq,
        log_path=str(run_dir / "eval"),
        best_model_save_path=str(run_dir / "eval"),
        deterministic=True,
        verbose=0,
        resumed_at=resumed_at,
    )
    return [
        CheckpointCallback(
            ckpt_freq,
            str(run_dir / "checkpoints"),
            name_prefix="model",
            save_replay_buffer=algo == "sac",
            save_vecnormalize=bool(normalize),
        ),
        evaluator,
        EpisodeLogCallback(run_dir / "episodes.csv", resumed_at),
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
    if algo == "sac":
        model.save_replay_buffer(d / f"model_replay_buffer_{n}_steps.pkl")
    return path


def _write_run(run_dir: Path, info: dict[str, Any]) -> None:
    (run_dir / "run.json").write_text(json.dumps(info, indent=2, default=str))


def train(
    algo: str,
    env_id: str,
    timesteps: int | None = None,
    n_envs: int | None = None,
    seed: int = 0,
    out: str | Path | None = None,
    resume: bool = False,
    progress: bool = True,
    hyperparams: dict[str, Any] | None = None,
    hyperparams_file: str | Path | None = None,
) -> Path:
    """Train (or resume) a run; returns the run directory. ``hyperparams`` replaces the
    entry of ``agents/<algo>.yml`` (tests pass tiny budgets this way); ``hyperparams_file``
    reads it from another file of the same layout."""
    import torch
    from stable_baselines3.common.vec_env import VecNormalize

    from bathprint.envs import resolve_id

    env_id = resolve_id(env_id)
    cls = _algo_class(algo)
    run_dir = Path(out or f"runs/{algo}_{env_id.split('/')[-1]}_seed{seed}")
    info_path = run_dir / "run.json"
    if resume:
        if not info_path.is_file():
            raise FileNotFoundError(f"--resume: {info_path} does not exist")
        info = json.loads(info_path.read_text())
        if info["algo"] != algo or info["env_id"] != env_id:
            raise ValueError(
                f"--resume: {run_dir} is a {info['algo']} run on {info['env_id']}, "
                f"not {algo} on {env_id}"
            )
        hp = info["hyperparams"]
        seed = int(info["seed"])
        if timesteps is not None:
            info["n_timesteps"] = int(timesteps)
    else:
        if info_path.is_file():
            raise FileExistsError(
                f"{run_dir} already holds a run; pass --resume to continue it or choose --out"
            )
        if hyperparams is None:
            hyperparams = load_hyperparams(algo, env_id, hyperparams_file)
        hp = hyperparams
        info = {
            "algo": algo,
            "env_id": env_id,
            "seed": seed,
            "hyperparams": hp,
            "n_timesteps": int(timesteps or hp.get("n_timesteps", 100_000)),
            "wall_time_s": 0.0,
            "status": "running",
        }
    run, algo_kwargs = split_hyperparams(hp)
    n_envs = int(n_envs or info.get("n_envs") or run.get("n_envs", 1))
    info["n_envs"] = n_envs
    env_kwargs = dict(run.get("env_kwargs", {}))
    normalize = run.get("normalize") or None
    total = int(info["n_timesteps"])
    torch.set_num_threads(int(run.get("torch_threads", 1)))
    run_dir.mkdir(parents=True, exist_ok=True)
    _write_run(run_dir, info)

    venv = make_vec(env_id, n_envs, seed, env_kwargs, run_dir / "monitor", run.get("wrapper"))
    ckpts = checkpoints(run_dir) if resume else []
    resumed_at = 0
    if ckpts:
        resumed_at, path = ckpts[-1]
        stats = run_dir / "checkpoints" / f"model_vecnormalize_{resumed_at}_steps.pkl"
        if normalize:
            venv = VecNormalize.load(str(stats), venv)
        model = cls.load(path, env=venv, device="cpu", tensorboard_log=str(run_dir / "tb"))
        buffer = run_dir / "checkpoints" / f"model_replay_buffer_{resumed_at}_steps.pkl"
        if algo == "sac" and buffer.is_file():
            model.load_replay_buffer(buffer)
        print(f"resuming {run_dir} from {path.name} ({resumed_at} of {total} steps)")
    else:
        if normalize:
            venv = VecNormalize(venv, **normalize)
        model = cls(
            run.get("policy", "MlpPolicy"),
            venv,
            seed=seed,
            device="cpu",
            tensorboard_log=str(run_dir / "tb"),
            verbose=0,
            **algo_kwargs,
        )
    from bathprint.agents.callbacks import RunInfoCallback

    callbacks = _make_callbacks(
        run_dir, env_id, env_kwargs, normalize, n_envs, run, resumed_at, algo, seed
    )
    callbacks.append(RunInfoCallback(functools.partial(_write_run, run_dir), info))
    remaining = max(0, total - int(model.num_timesteps))
    base_wall = float(info.get("wall_time_s", 0.0))  # time spent before this session
    t0 = time.perf_counter()
    interrupted = False
    try:
        if remaining > 0:
            model.learn(
                remaining,
                callback=callbacks,
                progress_bar=progress,
                reset_num_timesteps=not ckpts,
                tb_log_name="run",
            )
    except KeyboardInterrupt:
        interrupted = True
        path = save_checkpoint(model, run_dir, algo)
        print(f"\ninterrupted: saved {path} ({model.num_timesteps} steps); continue with --resume")
    finally:
        info["wall_time_s"] = base_wall + time.perf_counter() - t0
        info["timesteps_done"] = int(model.num_timesteps)
        info["status"] = "interrupted" if interrupted else "done"
        if not interrupted:
            model.save(run_dir / "final_model.zip")
            if normalize:
                model.get_vec_normalize_env().save(str(run_dir / "vecnormalize.pkl"))
        _write_run(run_dir, info)
        venv.close()
        for cb in callbacks:
            if hasattr(cb, "eval_env"):
                cb.eval_env.close()
    from bathprint.agents.curves import plot_training_curve

    plot_training_curve(run_dir)
    if interrupted:
        raise KeyboardInterrupt
    return run_dir


def load_trained(path: Path) -> tuple[Any, Any, str]:
    """(model, VecNormalize or None, label) from a run directory or a model ``.zip``.

    A run directory gives its final model, or its newest checkpoint if it has none yet."""
    from stable_baselines3.common.vec_env import VecNormalize

    path = Path(path)
    stats: Path | None = None
    if path.is_dir():
        info = json.loads((path / "run.json").read_text())
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
        algo = _guess_algo(path)
        for cand in (
            path.with_name("vecnormalize.pkl"),
            path.with_name(
                path.name.replace("model_", "model_vecnormalize_").replace(".zip", ".pkl")
            ),
        ):
            if cand.is_file():
                stats = cand
        label = f"{algo}:{path.stem}"
    model = _algo_class(algo).load(zip_path, device="cpu")
    normalizer = None
    if stats is not None and stats.is_file():
        normalizer = VecNormalize.load(str(stats), _dummy_venv(model))
        normalizer.training = False
    return model, normalizer, label


def _guess_algo(path: Path) -> str:
    run_json = next((p / "run.json" for p in path.parents if (p / "run.json").is_file()), None)
    if run_json is not None:
        return str(json.loads(run_json.read_text())["algo"])
    import zipfile

    with zipfile.ZipFile(path) as z:
        data = json.loads(z.read("data"))
    return "sac" if "target_entropy" in data else "ppo"


def _dummy_venv(model: Any) -> Any:
    """A VecEnv with the model's spaces, for loading VecNormalize statistics."""
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv

    class _Spaces(gym.Env):
        def __init__(self) -> None:
            self.observation_space = model.observation_space
            self.action_space = model.action_space

        def reset(self, *, seed: int | None = None, options: Any = None) -> Any:
            return np.zeros(self.observation_space.shape, np.float32), {}

        def step(self, action: Any) -> Any:
            return np.zeros(self.observation_space.shape, np.float32), 0.0, True, False, {}

    return DummyVecEnv([_Spaces])


def read_episodes(run_dir: Path) -> list[dict[str, float]]:
    """Rows of ``episodes.csv`` as floats."""
    path = Path(run_dir) / "episodes.csv"
    if not path.is_file():
        return []
    with path.open() as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]

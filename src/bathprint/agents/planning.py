"""Planners on the simulator itself: the per-target open-loop optimum (``oracle``) and
closed-loop model-predictive control (``mpc``), as baselines ``bathprint evaluate`` accepts.

**Oracle.** For one target (and the start state its episode uses), the cross-entropy method
(CEM) searches open-loop action sequences that are constant over blocks of ``block_mm`` of
printed length: ``samples`` sequences per iteration drawn from a Gaussian over the blocks,
the ``elites`` best refit it (its spread floored at ``min_std``), for ``iterations``
iterations; the mean starts at the better of the constant and the calibrated feedforward
baselines (their own action sequences, block-averaged), with spread ``init_std``. Each
candidate is one whole episode from reset; the objective is the final metric M. The best
sequence ever seen is kept, so the oracle is never worse than either baseline. For a printed
target (reachable by construction) the controls that printed it are replayed too
(``metric_replay``); the oracle's metric is the smaller of the two: at the preset the target
was printed at the replay reaches it (M ~ 0), elsewhere it bounds the attainable error.

Results are cached per target key in ``agents/results/oracle/<Env>-v1.<accuracy>.json``,
written as each target finishes (a run resumes where it stopped; a target whose cached
settings or data differ is computed again). ``python -m bathprint.agents.planning oracle
--env CoilRadius-v1 --target-set test`` fills the cache; the evaluation's normalised score
(:func:`normalised_score`) reads it.

**MPC.** :class:`MPCPolicy` plans from the current state: every ``replan_mm`` of printed
length it clones the episode (:meth:`~bathprint.envs.v1.BathprintEnvV1.get_state`; the
simulation pickles), runs CEM over blocks of the next ``horizon_mm`` on a second instance
(objective: the sum of rewards over the horizon), and applies the first ``replan_mm`` of the
best plan, warm-starting the next search from the rest of it.
"""

from __future__ import annotations

import argparse
import dataclasses
import hashlib
import json
import math
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import ConfigError


def oracle_dir() -> Path:
    """``agents/results/oracle`` of the checkout (or ``$BATHPRINT_AGENTS_DIR``, or the
    installed copy; :func:`bathprint._resources.shared_dir`)."""
    from bathprint._resources import shared_dir

    return shared_dir("agents", "BATHPRINT_AGENTS_DIR") / "results" / "oracle"


@dataclass(frozen=True)
class CEMSettings:
    """Cross-entropy search over blocks of actions."""

    samples: int = 32
    iterations: int = 20
    elites: int = 8
    block_mm: float = 4.0
    init_std: float = 0.5
    min_std: float = 0.05
    seed: int = 0

    def __post_init__(self) -> None:
        for name in ("samples", "iterations", "elites"):
            v = getattr(self, name)
            if not (isinstance(v, int) and not isinstance(v, bool) and v >= 1):
                raise ConfigError(f"{name} = {v!r}; allowed: an integer >= 1")
        if self.elites > self.samples:
            raise ConfigError(f"elites = {self.elites}; allowed: at most samples ({self.samples})")
        for name in ("block_mm", "init_std", "min_std"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and v > 0):
                raise ConfigError(f"{name} = {v!r}; allowed: a number > 0")


def cem_settings_of(settings: Any) -> CEMSettings:
    """The CEM search of a planner's settings (its samples, iterations, elites, blocks,
    spreads and seed), checked."""
    return CEMSettings(
        settings.samples,
        settings.iterations,
        settings.elites,
        settings.block_mm,
        settings.init_std,
        settings.min_std,
        settings.seed,
    )


def _blocks(n_steps: int, steps_per_block: int) -> np.ndarray:
    """Block index of every step."""
    return np.minimum(np.arange(n_steps) // steps_per_block, (n_steps - 1) // steps_per_block)


def expand(blocks: np.ndarray, n_steps: int, steps_per_block: int) -> np.ndarray:
    """(B, A) block actions -> (n_steps, A) step actions."""
    return blocks[_blocks(n_steps, steps_per_block)]


def block_means(actions: np.ndarray, steps_per_block: int) -> np.ndarray:
    """(n, A) step actions -> (B, A) their means per block."""
    idx = _blocks(len(actions), steps_per_block)
    out = np.zeros((idx[-1] + 1, actions.shape[1]))
    np.add.at(out, idx, actions)
    return out / np.bincount(idx)[:, None]


def cem(
    objective: Callable[[np.ndarray], float],
    mean: np.ndarray,
    settings: CEMSettings,
    incumbents: Sequence[tuple[float, np.ndarray]] = (),
    rng: np.random.Generator | None = None,
    on_iteration: Callable[[int, float], None] | None = None,
) -> tuple[np.ndarray | None, float, list[float]]:
    """Minimise ``objective`` over block sequences (B, A) in [-1, 1] from ``mean``; returns
    the best candidate (or None if an incumbent stays best), its value and the best value
    after each iteration. ``incumbents``: (value, anything) already evaluated."""
    rng = rng or np.random.default_rng(settings.seed)
    best_val = min((v for v, _ in incumbents), default=math.inf)
    best: np.ndarray | None = None
    mean = np.clip(np.asarray(mean, np.float64), -1.0, 1.0)
    std = np.full_like(mean, settings.init_std)
    history = []
    for it in range(settings.iterations):
        cand = np.clip(mean + std * rng.standard_normal((settings.samples, *mean.shape)), -1, 1)
        vals = np.array([objective(c) for c in cand])
        order = np.argsort(vals, kind="stable")
        if vals[order[0]] < best_val:
            best_val, best = float(vals[order[0]]), cand[order[0]].copy()
        elite = cand[order[: settings.elites]]
        mean = elite.mean(axis=0)
        std = np.maximum(elite.std(axis=0), settings.min_std)
        history.append(best_val)
        if on_iteration is not None:
            on_iteration(it, best_val)
    return best, best_val, history


# ------------------------------------------------------------------------------ rollouts
def rollout(env: Any, actions: np.ndarray, seed: int, options: dict[str, Any]) -> dict[str, Any]:
    """One episode from reset with an open-loop action sequence (the last action repeats if
    the episode is longer); returns the final info's metric, return and steps."""
    env.reset(seed=seed, options=options)
    ret, k, info = 0.0, 0, {}
    while True:
        a = actions[min(k, len(actions) - 1)]
        _, r, term, trunc, info = env.step(a)
        ret += float(r)
        k += 1
        if term or trunc:
            break
    return {"metric": float(info["metric"]), "return": ret, "steps": k, "truncated": bool(trunc)}


def policy_actions(
    env: Any, policy: Any, seed: int, options: dict[str, Any]
) -> tuple[float, np.ndarray]:
    """Run a policy for one episode; its final metric and the actions it took."""
    obs, _ = env.reset(seed=seed, options=options)
    acts = []
    while True:
        a, _ = policy.predict(obs, deterministic=True)
        a = np.clip(np.asarray(a, np.float32), -1, 1)
        acts.append(a)
        obs, _, term, trunc, info = env.step(a)
        if term or trunc:
            return float(info["metric"]), np.array(acts)


def _steps_per_block(u: Any, block_mm: float) -> int:
    return max(1, int(round(block_mm / u.control_length_mm)))


# ------------------------------------------------------------------------------ oracle
def oracle_path(env_id: str, accuracy: str, directory: Path | None = None) -> Path:
    short = env_id.split("/")[-1]
    return (directory or oracle_dir()) / f"{short}.{accuracy}.json"


def load_oracle(env_id: str, accuracy: str, directory: Path | None = None) -> dict[str, Any]:
    """The oracle cache of an environment and preset ({} if none)."""
    path = oracle_path(env_id, accuracy, directory)
    if not path.is_file():
        return {}
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: not valid JSON ({exc}); delete it to start over") from None


def _save_oracle(path: Path, data: dict[str, Any]) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.{os.getpid()}")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def target_digest(target: Any) -> str:
    """sha1 of a target's data (points and band): a cached result is for these data."""
    h = hashlib.sha1()
    for arr in (target.points_mm, target.density_lo_kg_m3, target.density_hi_kg_m3):
        h.update(np.ascontiguousarray(arr, np.float64).tobytes())
    return h.hexdigest()[:16]


def baseline_policies(env: Any, env_id: str) -> dict[str, Any]:
    """The constant and calibrated feedforward baselines (fitted in agents/baselines.yml)."""
    from bathprint.agents.policies import load_policy

    out = {}
    for name in ("constant", "feedforward_calibrated"):
        out[name] = load_policy(name, env, env_id)[0]
    return out


def optimise_target(
    env: Any,
    env_id: str,
    seed: int,
    options: dict[str, Any],
    settings: CEMSettings,
    progress: Any = None,
) -> dict[str, Any]:
    """The oracle's search for one target (see the module doc); a cache record."""
    u = env.unwrapped
    t0, c0 = time.perf_counter(), time.process_time()
    pols = baseline_policies(env, env_id)
    m_const, a_const = policy_actions(env, pols["constant"], seed, options)
    m_ff, a_ff = policy_actions(env, pols["feedforward_calibrated"], seed, options)
    target = u.target
    n_steps = u.episode_steps
    spb = _steps_per_block(u, settings.block_mm)
    start = a_const if m_const <= m_ff else a_ff
    count = [2]

    def objective(blocks: np.ndarray) -> float:
        count[0] += 1
        return rollout(env, expand(blocks, n_steps, spb), seed, options)["metric"]

    def tick(it: int, best: float) -> None:
        if progress is not None:
            progress.set_postfix_str(f"iter {it + 1}/{settings.iterations} M {best:.4f}")

    best_blocks, m_cem, history = cem(
        objective,
        block_means(start, spb),
        settings,
        incumbents=[(m_const, a_const), (m_ff, a_ff)],
        on_iteration=tick,
    )
    if best_blocks is None:
        a_cem = a_const if m_const <= m_ff else a_ff
    else:
        a_cem = expand(best_blocks, n_steps, spb).astype(np.float32)
    rec: dict[str, Any] = {
        "metric_constant": m_const,
        "metric_feedforward": m_ff,
        "metric_cem": m_cem,
        "cem_history": [round(h, 6) for h in history],
        "rollouts": count[0],
    }
    best_m, best_a = m_cem, a_cem
    replay = None
    if getattr(target, "actions", None) is not None:
        try:
            replay = u.actions_for(target)
        except ValueError:  # printed with needle axes this environment lacks
            replay = None
    if replay is not None:
        m_rep = rollout(env, replay, seed, options)["metric"]
        rec["metric_replay"] = m_rep
        if m_rep < best_m:
            best_m, best_a = m_rep, replay
    rec["metric"] = best_m
    rec["actions"] = np.asarray(best_a, np.float32).astype(float).tolist()
    rec["wall_s"] = round(time.perf_counter() - t0, 2)
    rec["cpu_s"] = round(time.process_time() - c0, 2)
    rec["data"] = target_digest(target)
    return rec


def run_oracle(
    env_id: str,
    target_set: str = "test",
    accuracy: str = "draft",
    settings: CEMSettings | None = None,
    indices: Sequence[int] | None = None,
    seed: int = 0,
    directory: Path | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """Fill the oracle cache for the targets of a fixed set (episode k: target k, seed
    ``seed + k``, as ``bathprint evaluate``); resumable. Returns the cache."""
    from tqdm import tqdm

    from bathprint.envs import make, resolve_id

    env_id = resolve_id(env_id)
    settings = settings or CEMSettings()
    env = make(env_id, accuracy=accuracy, target_set=target_set)
    u = env.unwrapped
    if getattr(u, "version", 0) < 1:
        raise ConfigError(f"{env_id}: the oracle cache is for version-1 environments")
    n = u.printed.sizes[target_set]
    indices = list(range(n)) if indices is None else list(indices)
    path = oracle_path(env_id, accuracy, directory)
    data = load_oracle(env_id, accuracy, directory) or {
        "env_id": env_id,
        "accuracy": accuracy,
        "settings": dataclasses.asdict(settings),
        "targets": {},
    }
    want = dataclasses.asdict(settings)
    bar = tqdm(indices, desc=f"oracle {env_id} {target_set}", disable=not progress)
    for k in bar:
        target = u.fixed_set_target(target_set, k)
        rec = data["targets"].get(target.key)
        if (
            rec is not None
            and rec.get("settings", data.get("settings")) == want
            and rec.get("data") == target_digest(target)
            and rec.get("seed") == seed + k
        ):
            continue
        rec = optimise_target(env, env_id, seed + k, {"target_index": k}, settings, bar)
        rec.update({"target_set": target_set, "index": k, "seed": seed + k, "settings": want})
        data["targets"][target.key] = rec
        _save_oracle(path, data)
    env.close()
    return data


def run_oracle_files(
    env_id: str,
    files: Sequence[str],
    accuracy: str = "draft",
    settings: CEMSettings | None = None,
    seed: int = 0,
    directory: Path | None = None,
    progress: bool = True,
) -> dict[str, Any]:
    """The oracle for target files (``target_file=``, e.g. the showcase polylines), into the
    same cache (keyed by the file's target key); resumable."""
    from tqdm import tqdm

    from bathprint.envs import make, resolve_id

    env_id = resolve_id(env_id)
    settings = settings or CEMSettings()
    want = dataclasses.asdict(settings)
    path = oracle_path(env_id, accuracy, directory)
    data = load_oracle(env_id, accuracy, directory) or {
        "env_id": env_id,
        "accuracy": accuracy,
        "settings": want,
        "targets": {},
    }
    bar = tqdm(list(files), desc=f"oracle {env_id} files", disable=not progress)
    for f in bar:
        env = make(env_id, accuracy=accuracy, target_file=str(f))
        env.reset(seed=seed)
        target = env.unwrapped.target
        rec = data["targets"].get(target.key)
        if rec is None or rec.get("settings") != want or rec.get("seed") != seed:
            rec = optimise_target(env, env_id, seed, {}, settings, bar)
            rec.update(
                {
                    "target_set": "file",
                    "file": Path(f).name,
                    "index": -1,
                    "seed": seed,
                    "settings": want,
                }
            )
            data["targets"][target.key] = rec
            _save_oracle(path, data)
        env.close()
    return data


class OraclePolicy:
    """Replays the oracle's cached action sequence of the episode's target (computing and
    caching it first if it is missing: minutes)."""

    def __init__(
        self,
        env: Any,
        env_id: str,
        settings: CEMSettings | None = None,
        directory: Path | None = None,
    ) -> None:
        self.env = env.unwrapped
        self.env_id = env_id
        self.settings = settings or CEMSettings()
        self.directory = directory
        self._key: str | None = None
        self._actions: np.ndarray | None = None

    def _plan(self) -> np.ndarray:
        u = self.env
        data = load_oracle(self.env_id, u.accuracy, self.directory)
        rec = data.get("targets", {}).get(u._target_key)
        if rec is None or rec.get("data") != target_digest(u.target):
            from bathprint.envs import make

            planner = make(self.env_id, **u.init_kwargs)
            options = {"target": u.target, "start_state": u._start_index}
            rec = optimise_target(planner, self.env_id, 0, options, self.settings)
            rec.update(
                {
                    "target_set": u.target_set,
                    "index": u._target_index,
                    "seed": 0,
                    "settings": dataclasses.asdict(self.settings),
                }
            )
            if not data:
                data = {
                    "env_id": self.env_id,
                    "accuracy": u.accuracy,
                    "settings": dataclasses.asdict(self.settings),
                    "targets": {},
                }
            data["targets"][u._target_key] = rec
            _save_oracle(oracle_path(self.env_id, u.accuracy, self.directory), data)
            planner.close()
        return np.asarray(rec["actions"], np.float32)

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        u = self.env
        if u._steps == 0 or self._key != u._target_key:
            self._key = u._target_key
            self._actions = self._plan()
        assert self._actions is not None
        return self._actions[min(u._steps, len(self._actions) - 1)].copy(), state


# ------------------------------------------------------------------------------ CEM
@dataclass(frozen=True)
class ShapeCEMSettings:
    """The ``cem`` reference's search: CEM over blocks of ``block_mm`` from the best start
    (the controller where the family has one, the constant and feedforward baselines),
    ``samples`` x ``iterations`` episodes per target."""

    samples: int = 24
    iterations: int = 8
    elites: int = 6
    block_mm: float = 4.0
    init_std: float = 0.3
    min_std: float = 0.05
    seed: int = 0

    def cem(self) -> CEMSettings:
        return cem_settings_of(self)

    def __post_init__(self) -> None:
        self.cem()


def episode_objective(env: Any) -> Callable[[dict[str, Any]], float]:
    """What the ``cem`` reference minimises after an episode of ``env``: for a shape target
    (``target.params['shape_family']``) the whole-shape RMS error in mm (the benchmark's
    metric; an episode cut short scores inf), else the environment's final metric M."""
    from bathprint.envs.shape_files import target_reference, written_curve
    from bathprint.envs.shape_metric import shape_error

    u = env.unwrapped
    family = u.target.params.get("shape_family")
    if family is None:
        return lambda info: float(info["metric"])
    reference = target_reference(env, u.target, family)

    def rms(info: dict[str, Any]) -> float:
        w = written_curve(env, family)
        if info.get("truncated") or len(w) != u.target.n_samples:
            return math.inf
        return shape_error(w, reference, family).rms_mm

    return rms


class ShapeCEMPolicy:
    """The ``cem`` reference: plans every new target open loop on a second instance of the
    environment (CEM, :class:`ShapeCEMSettings`) from the best of its starts, then replays
    the best plan. It never reads the controls that printed a target; its objective is
    :func:`episode_objective`. Attributes after a plan: ``last_value`` (the objective),
    ``last_start`` (which start the search began from), ``last_cpu_s``."""

    def __init__(self, env: Any, env_id: str, settings: ShapeCEMSettings | None = None) -> None:
        from bathprint.envs import make

        u = env.unwrapped
        if getattr(u, "version", 0) < 1:
            raise ConfigError(f"cem needs a version-1 environment; got {env_id}")
        self.env = u
        self.env_id = env_id
        self.settings = settings or ShapeCEMSettings()
        self.planner = make(env_id, **u.init_kwargs)
        self._target: Any = None
        self._plan = np.zeros((1, *u.action_space.shape), np.float32)
        self.last_value = math.nan
        self.last_start = ""
        self.last_cpu_s = math.nan

    def _starts(self, options: dict[str, Any], seed: int) -> dict[str, np.ndarray]:
        from bathprint.agents.controller import make_controller
        from bathprint.agents.policies import load_policy

        out = {}
        p = self.planner
        family = self.env.target.params.get("shape_family")
        if family is not None:
            try:
                ctl = make_controller(p, family)
            except ConfigError:
                ctl = None
            if ctl is not None:
                out["controller"] = policy_actions(p, ctl, seed, options)[1]
        for name in ("constant", "feedforward"):
            try:
                pol = load_policy(name, p, self.env_id)[0]
            except (ConfigError, KeyError, ValueError):
                continue
            out[name] = policy_actions(p, pol, seed, options)[1]
        return out

    def _search(self) -> np.ndarray:
        u, p, s = self.env, self.planner, self.settings
        c0 = time.process_time()
        options = {"target": u.target, "start_state": u._start_index}
        seed = 0
        objective_of = None
        values: dict[str, tuple[float, np.ndarray]] = {}
        for name, acts in self._starts(options, seed).items():
            info = _replay(p, acts, seed, options)
            objective_of = objective_of or episode_objective(p)
            values[name] = (objective_of(info), acts)
        if objective_of is None:
            p.reset(seed=seed, options=options)
            objective_of = episode_objective(p)
        start = min(values, key=lambda k: values[k][0]) if values else ""
        n_steps = u.episode_steps
        spb = _steps_per_block(u, s.block_mm)
        dim = u.action_space.shape[0]
        mean = (
            block_means(values[start][1], spb)
            if start
            else np.zeros((-(-n_steps // spb), dim))
        )

        def objective(blocks: np.ndarray) -> float:
            acts = expand(blocks, n_steps, spb).astype(np.float32)  # as replayed
            return objective_of(_replay(p, acts, seed, options))

        best, best_val, _ = cem(
            objective, mean, s.cem(), incumbents=[v for v in values.values()],
            rng=np.random.default_rng(s.seed),
        )
        if best is None:
            self.last_value, plan = values[start][0], values[start][1]
            self.last_start = start
        else:
            self.last_value, plan = best_val, expand(best, n_steps, spb)
            self.last_start = f"cem from {start}" if start else "cem"
        self.last_cpu_s = time.process_time() - c0
        return np.asarray(plan, np.float32)

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        u = self.env
        if u.steps_taken == 0 or u.target is not self._target:
            self._target = u.target
            self._plan = self._search()
        return self._plan[min(u.steps_taken, len(self._plan) - 1)].copy(), state


def _replay(env: Any, actions: np.ndarray, seed: int, options: dict[str, Any]) -> dict[str, Any]:
    """An open-loop episode (the last action repeats); the final info with ``truncated``."""
    env.reset(seed=seed, options=options)
    k, info = 0, {}
    while True:
        _, _, term, trunc, info = env.step(actions[min(k, len(actions) - 1)])
        k += 1
        if term or trunc:
            return {**info, "truncated": bool(trunc)}


# ------------------------------------------------------------------------------ MPC
@dataclass(frozen=True)
class MPCSettings:
    """Closed-loop CEM: horizon, replanning interval, search budget per plan."""

    horizon_mm: float = 24.0
    replan_mm: float = 4.0
    block_mm: float = 4.0
    samples: int = 16
    iterations: int = 3
    elites: int = 4
    init_std: float = 0.4
    min_std: float = 0.05
    seed: int = 0
    #: start each search from the controller's plan over the horizon too (1), not only from
    #: the rest of the previous plan (0); -1: 1 in the shape environments, else 0
    warm_controller: int = -1

    def cem(self) -> CEMSettings:
        return cem_settings_of(self)

    def __post_init__(self) -> None:
        self.cem()  # checks the search settings
        if self.warm_controller not in (-1, 0, 1):
            raise ConfigError(
                f"warm_controller = {self.warm_controller!r}; allowed: -1 (on in the shape "
                "environments), 0, 1"
            )
        for name in ("horizon_mm", "replan_mm"):
            v = getattr(self, name)
            if not (isinstance(v, int | float) and not isinstance(v, bool) and v > 0):
                raise ConfigError(f"{name} = {v!r}; allowed: a number > 0")


class MPCPolicy:
    """Model-predictive control on the simulator itself (module doc)."""

    def __init__(self, env: Any, env_id: str, settings: MPCSettings | None = None) -> None:
        from bathprint.envs import make

        u = env.unwrapped
        if getattr(u, "version", 0) < 1:
            raise ConfigError(f"mpc needs a version-1 environment (get_state); got {env_id}")
        self.env = u
        self.settings = settings or MPCSettings()
        self.planner = make(env_id, **u.init_kwargs).unwrapped
        self.rng = np.random.default_rng(self.settings.seed)
        warm = self.settings.warm_controller
        if warm < 0:
            warm = int(hasattr(u, "shape_target"))
        self.controller: Any = None
        if warm:
            from bathprint.agents.controller import make_controller

            self.controller = make_controller(self.planner)
        self._plan: np.ndarray | None = None
        self._plan_step = 0
        self.plans = 0

    def _replan(self) -> None:
        u, p, s = self.env, self.planner, self.settings
        state = u.get_state()
        spb = _steps_per_block(u, s.block_mm)
        remaining = u.episode_steps - u._steps
        horizon = max(1, min(remaining, int(round(s.horizon_mm / u.control_length_mm))))
        n_blocks = -(-horizon // spb)
        dim = u.action_space.shape[0]
        if self._plan is not None:
            done = u._steps - self._plan_step
            rest = self._plan[done:]
            tail = np.repeat(rest[-1:] if len(rest) else self._plan[-1:], horizon, axis=0)
            warm = np.concatenate([rest, tail])[:horizon]
        else:
            warm = np.repeat(np.asarray(u._controls["action"], np.float64)[None, :], horizon, 0)
        mean = block_means(warm, spb)[:n_blocks].reshape(n_blocks, dim)

        def objective(blocks: np.ndarray) -> float:
            p.set_state(state)
            acts = expand(blocks, horizon, spb)
            total = 0.0
            for a in acts:
                _, r, term, trunc, _ = p.step(a)
                total += r
                if term or trunc:
                    break
            return -total

        base = np.zeros((horizon, dim))
        if self.controller is not None:
            # search corrections to the controller's own plan over the horizon (its actions
            # step by step: a block mean of a tracking controller's actions tracks worse)
            p.set_state(state)
            obs, acts = p._last_obs.copy(), []
            for _ in range(horizon):
                a, _ = self.controller.predict(obs)
                acts.append(np.asarray(a, np.float64))
                obs, _, term, trunc, _ = p.step(a)
                if term or trunc:
                    break
            acts += [acts[-1]] * (horizon - len(acts))
            base = np.asarray(acts)
            mean = np.zeros((n_blocks, dim))

            def objective(blocks: np.ndarray) -> float:
                p.set_state(state)
                plan = np.clip(base + expand(blocks, horizon, spb), -1.0, 1.0)
                total = 0.0
                for a in plan.astype(np.float32):
                    _, r, term, trunc, _ = p.step(a)
                    total += r
                    if term or trunc:
                        break
                return -total

        warm_val = objective(mean)
        best, _, _ = cem(objective, mean, s.cem(), incumbents=[(warm_val, None)], rng=self.rng)
        blocks = mean if best is None else best
        plan = expand(blocks, horizon, spb)
        if self.controller is not None:
            plan = np.clip(base + plan, -1.0, 1.0)
        self._plan = plan.astype(np.float32)
        self._plan_step = u._steps
        self.plans += 1

    def predict(
        self,
        observation: Any,
        state: Any = None,
        episode_start: Any = None,
        deterministic: bool = True,
    ) -> tuple[np.ndarray, Any]:
        u = self.env
        every = max(1, int(round(self.settings.replan_mm / u.control_length_mm)))
        if u._steps == 0:
            self._plan = None
        if (
            self._plan is None
            or (u._steps - self._plan_step) % every == 0
            or (u._steps - self._plan_step) >= len(self._plan)
        ):
            self._replan()
        assert self._plan is not None
        return self._plan[u._steps - self._plan_step].copy(), state


def parse_options(spec: str, cls: type) -> Any:
    """``"mpc:samples=8,horizon_mm=30"`` -> the settings dataclass (keys checked)."""
    _, _, rest = spec.partition(":")
    fields = {f.name: f.type for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for item in filter(None, rest.split(",")):
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or key not in fields:
            raise ConfigError(
                f"policy {spec!r}: {item!r}; allowed: key=value with keys " + ", ".join(fields)
            )
        try:
            kwargs[key] = int(value) if fields[key] in ("int", int) else float(value)
        except ValueError:
            raise ConfigError(f"policy {spec!r}: {key} = {value!r} is not a number") from None
    return cls(**kwargs)


# ------------------------------------------------------------------------------ scores
def normalised_score(
    metrics: dict[str, float], env_id: str, accuracy: str, directory: Path | None = None
) -> dict[str, Any]:
    """(M_constant - M) / (M_constant - M_oracle) from the oracle cache, for the episodes
    whose target it holds: the means over those episodes (aggregate), and per target.
    ``metrics``: target key -> the policy's final metric."""
    data = load_oracle(env_id, accuracy, directory).get("targets", {})
    rows = [(k, m, data[k]) for k, m in metrics.items() if k in data]
    if not rows:
        return {"normalised_score": float("nan"), "normalised_episodes": 0, "per_target": {}}
    m = np.mean([r[1] for r in rows])
    mc = np.mean([r[2]["metric_constant"] for r in rows])
    mo = np.mean([r[2]["metric"] for r in rows])
    per = {}
    for k, mk, rec in rows:
        den = rec["metric_constant"] - rec["metric"]
        per[k] = (rec["metric_constant"] - mk) / den if den > 0 else float("nan")
    return {
        "normalised_score": float((mc - m) / (mc - mo)) if mc > mo else float("nan"),
        "normalised_episodes": len(rows),
        "mean_metric_constant": float(mc),
        "mean_metric_oracle": float(mo),
        "per_target": per,
    }


# ------------------------------------------------------------------------------ tables
def reference_table(
    env_id: str, eval_dir: str | Path, accuracy: str = "draft", directory: Path | None = None
) -> str:
    """Markdown table of the reference scores: the policies of a ``bathprint evaluate``
    output directory (its table.json) and the oracle's CEM search from its cache."""
    rows = json.loads((Path(eval_dir) / "table.json").read_text())
    data = load_oracle(env_id, accuracy, directory)
    recs = [r for r in data.get("targets", {}).values() if r.get("target_set") == "test"]
    lines = [
        "| policy | M (mean ± std) | normalised | success | compute |",
        "|---|---|---|---|---|",
    ]
    thr = next((r["success_threshold"] for r in rows if "success_threshold" in r), None)
    for r in rows:
        name = r["policy"]
        if name == "oracle":
            name = "oracle (the better of CEM and the printing controls' replay)"
            compute = "replays its cached actions"
        elif name.startswith("mpc"):
            compute = f"{r['wall_time_s'] / r['episodes']:.1f} s per episode"
        else:
            compute = f"{r['wall_time_s']:.1f} s for {r['episodes']} episodes"
        norm = r.get("normalised_score", float("nan"))
        lines.append(
            f"| {name} | {r['mean_metric']:.3f} ± {r['std_metric']:.3f} | "
            + (f"{norm:.3f}" if norm == norm else "-")
            + f" | {r.get('success_rate', float('nan')):.2f} | {compute} |"
        )
    if recs and thr is not None:
        cem_m = np.array([r["metric_cem"] for r in recs])
        mc = float(np.mean([r["metric_constant"] for r in recs]))
        mo = float(np.mean([r["metric"] for r in recs]))
        norm = (mc - cem_m.mean()) / (mc - mo) if mc > mo else float("nan")
        cpu = float(np.mean([r["cpu_s"] for r in recs]))
        rollouts = int(np.mean([r["rollouts"] for r in recs]))
        s = data.get("settings", {})
        lines.append(
            f"| CEM alone (open loop, from the better of constant and feedforward) | "
            f"{cem_m.mean():.3f} ± {cem_m.std():.3f} | {norm:.3f} | "
            f"{float(np.mean(cem_m <= thr)):.2f} | {cpu:.0f} CPU s per target "
            f"({rollouts} episodes: {s.get('samples')} x {s.get('iterations')}, "
            f"{s.get('block_mm')} mm blocks) |"
        )
    return "\n".join(lines) + "\n"


# ------------------------------------------------------------------------------ command
def main(argv: Sequence[str] | None = None) -> int:
    """``python -m bathprint.agents.planning oracle --env ENV [--target-set test]
    [--accuracy draft] [--samples 32 --iterations 20 --block-mm 4] [--indices 0 1 ...]
    [--target-files F ...]``; ``... table --env ENV --eval-dir DIR`` prints the reference
    table of a ``bathprint evaluate`` output and the oracle cache."""
    ap = argparse.ArgumentParser(
        prog="python -m bathprint.agents.planning",
        description="Fill the oracle cache of a version-1 environment.",
    )
    ap.add_argument("action", choices=("oracle", "table"))
    ap.add_argument("--eval-dir", default=None, help="table: a bathprint evaluate output")
    ap.add_argument("--env", required=True)
    ap.add_argument("--target-set", default="test", choices=("validation", "test"))
    ap.add_argument("--accuracy", default="draft", choices=("draft", "balanced", "fine"))
    ap.add_argument("--samples", type=int, default=CEMSettings.samples)
    ap.add_argument("--iterations", type=int, default=CEMSettings.iterations)
    ap.add_argument("--elites", type=int, default=CEMSettings.elites)
    ap.add_argument("--block-mm", type=float, default=CEMSettings.block_mm)
    ap.add_argument("--indices", type=int, nargs="*", default=None)
    ap.add_argument(
        "--target-files",
        nargs="*",
        default=None,
        help="target files (e.g. envs/targets/showcase/*.csv) instead of a set",
    )
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default=None, help="cache directory (default agents/results/oracle)")
    ap.add_argument("--quiet", action="store_true")
    args = ap.parse_args(argv)
    if args.action == "table":
        if not args.eval_dir:
            print("bathprint planning: table needs --eval-dir", file=sys.stderr)
            return 2
        from bathprint.envs import resolve_id

        print(
            reference_table(
                resolve_id(args.env),
                args.eval_dir,
                args.accuracy,
                Path(args.out) if args.out else None,
            ),
            end="",
        )
        return 0
    try:
        settings = CEMSettings(args.samples, args.iterations, args.elites, args.block_mm)
        if args.target_files:
            data = run_oracle_files(
                args.env,
                args.target_files,
                args.accuracy,
                settings,
                args.seed,
                Path(args.out) if args.out else None,
                progress=not args.quiet,
            )
            for rec in data["targets"].values():
                if rec.get("target_set") == "file":
                    print(
                        f"{rec['file']}: constant {rec['metric_constant']:.4f}, feedforward "
                        f"{rec['metric_feedforward']:.4f}, CEM {rec['metric_cem']:.4f} "
                        f"({rec['cpu_s']:.0f} CPU s)"
                    )
            return 0
        data = run_oracle(
            args.env,
            args.target_set,
            args.accuracy,
            settings,
            args.indices,
            args.seed,
            Path(args.out) if args.out else None,
            progress=not args.quiet,
        )
    except (ValueError, FileNotFoundError) as exc:
        print(f"bathprint planning: {exc}", file=sys.stderr)
        return 2
    recs = [r for r in data["targets"].values() if r.get("target_set") == args.target_set]
    if recs:
        mean = {
            k: float(np.mean([r[k] for r in recs if k in r]))
            for k in ("metric_constant", "metric_feedforward", "metric_cem", "metric")
        }
        cost = float(np.mean([r["cpu_s"] for r in recs]))
        print(
            f"{data['env_id']} {args.target_set} ({len(recs)} targets, {args.accuracy}): "
            + ", ".join(f"{k} {v:.4f}" for k, v in mean.items())
            + f"; {cost:.0f} CPU s per target"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Many training runs, one command: a campaign of (environment, algorithm, seed) runs.

A campaign file (YAML) lists groups of runs and the baselines to compare them with::

    out: runs/campaign_coil                  # default --out
    episodes: 16                             # test targets each policy plays
    baselines: [random, constant, feedforward, feedforward_calibrated, oracle, mpc]
    reference: feedforward_calibrated        # the paired differences are against it
    runs:
      - {name: ppores, env: bathprint/CoilRadius-v1, algo: ppo,
         hyperparams: agents/ppo_residual.yml, seeds: 0-4, timesteps: 300000}
      - {name: ppo, env: bathprint/CoilRadius-v1, algo: ppo, seeds: 0-2,
         set: {time_budget_s: 240}}      # settings changed for this group only

``python -m bathprint.agents.campaign FILE [--out DIR] [--workers N | --scheduler ADDR]``
(or ``bathprint train --campaign FILE``) trains every run in ``OUT/<Env>/<name>/seed<S>/``
(a local process pool of ``--workers`` processes, the calling process for one worker, or a
Dask cluster as :mod:`bathprint.studies.sweep` uses them), then plays each run's model
*selected on the validation targets* (``eval/best_model.zip``, see
:class:`~bathprint.agents.callbacks.ValidationCallback`) and each baseline on the test
targets (``OUT/<Env>/.../test/``), and writes per environment::

    results.md, results.json   one row per policy: IQM and mean of the final metric, the
                               normalised score, the success rate, the paired difference
                               against the reference, the fraction of the gap from the
                               reference to the oracle closed (95% stratified-bootstrap
                               intervals over seeds and targets, bathprint.agents.statistics),
                               the targets won, training steps and wall time per run
    runs.csv                   the compute of every run (steps, wall and CPU seconds, the
                               step the validation picked, its validation metric)
    scores.csv                 every (policy, seed, target) test metric
    curves.png                 validation metric against environment steps and wall time

Rerunning the command resumes: finished runs and evaluations are kept, runs a kill left
``running`` or ``interrupted`` continue from their last checkpoint (``--resume``), those
without a checkpoint start over. SIGTERM is handled like Ctrl-C
(:func:`bathprint.interrupt.signals_interrupt`): the pool's workers are stopped with the
campaign, which exits with 143.
"""

from __future__ import annotations

import argparse
import csv
import json
import shlex
import shutil
import signal
import sys
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.envs import printed_targets
from bathprint.errors import ConfigError
from bathprint.executor import SERIAL, check_scheduler, run_tasks
from bathprint.interrupt import exit_code, signals_interrupt

#: keys of a campaign file and of one of its run groups
CAMPAIGN_KEYS = ("out", "episodes", "baselines", "reference", "runs", "seed")
GROUP_KEYS = ("name", "env", "algo", "hyperparams", "seeds", "timesteps", "n_envs", "set")


def parse_seeds(text: Any) -> list[int]:
    """``"0-4"`` -> [0, 1, 2, 3, 4]; ``"0,2,5-6"``, an int, or a list of ints also work."""
    if isinstance(text, bool):
        raise ConfigError(f"seeds = {text!r}; allowed: e.g. 0-4, 0,2,5 or a list of integers")
    if isinstance(text, int):
        items: list[Any] = [text]
    elif isinstance(text, list):
        items = text
    elif isinstance(text, str):
        items = [p.strip() for p in text.split(",") if p.strip()]
    else:
        items = []
    seeds: list[int] = []
    for item in items:
        if isinstance(item, int) and not isinstance(item, bool) and item >= 0:
            seeds.append(item)
            continue
        lo, sep, hi = str(item).partition("-")
        if lo.isdigit() and (not sep or hi.isdigit()) and (not sep or int(hi) >= int(lo)):
            seeds.extend(range(int(lo), int(hi if sep else lo) + 1))
            continue
        seeds = []
        break
    if not seeds or len(set(seeds)) != len(seeds):
        raise ConfigError(
            f"seeds = {text!r}; allowed: non-negative integers without repeats, e.g. 0-4, "
            "0,2,5 or a list"
        )
    return seeds


@dataclass(frozen=True)
class RunSpec:
    """One training run of a campaign."""

    name: str
    env_id: str
    algo: str
    seed: int
    run_dir: str
    hyperparams_file: str | None = None
    timesteps: int | None = None
    n_envs: int | None = None
    changes: dict[str, Any] = field(default_factory=dict)


@dataclass
class Campaign:
    out: Path
    episodes: int
    baselines: list[str]
    reference: str | None
    runs: list[RunSpec]
    eval_seed: int = 0
    #: the campaign file it was read from (None: built in code, e.g. --seeds)
    file: str | None = None

    @property
    def envs(self) -> list[str]:
        return list(dict.fromkeys(r.env_id for r in self.runs))


def env_dir(out: Path, env_id: str) -> Path:
    return Path(out) / env_id.split("/")[-1]


def _int_ge1(where: str, key: str, value: Any) -> int:
    if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
        raise ConfigError(f"{where}: {key} = {value!r}; allowed: an integer >= 1")
    return value


def load_campaign(path: str | Path, out: str | Path | None = None) -> Campaign:
    """Read and check a campaign file (ConfigError naming the key otherwise)."""
    import yaml

    from bathprint.agents.hyperparams import ALGOS
    from bathprint.agents.policies import BASELINES, PLANNERS, V1_BASELINES, baseline_name
    from bathprint.envs import resolve_id

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"campaign file {path} does not exist")
    try:
        data = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: holds a {type(data).__name__}, not a mapping")
    for key in data:
        if key not in CAMPAIGN_KEYS:
            raise ConfigError(f"{path}: unknown key {key!r}; allowed: {', '.join(CAMPAIGN_KEYS)}")
    groups = data.get("runs")
    if not isinstance(groups, list) or not groups:
        raise ConfigError(f"{path}: runs = {groups!r}; allowed: a non-empty list of run groups")
    episodes = _int_ge1(str(path), "episodes", data.get("episodes", 16))
    baselines = data.get("baselines", [])
    known = BASELINES + V1_BASELINES + PLANNERS
    if not isinstance(baselines, list) or any(
        not isinstance(b, str) or baseline_name(b) is None for b in baselines
    ):
        raise ConfigError(
            f"{path}: baselines = {baselines!r}; allowed: a list of {', '.join(known)}"
        )
    reference = data.get("reference")
    if reference is not None and reference not in baselines:
        raise ConfigError(
            f"{path}: reference = {reference!r}; allowed: one of the baselines {baselines}"
        )
    out_dir = Path(out or data.get("out") or "runs/campaign")
    runs: list[RunSpec] = []
    names: set[tuple[str, str]] = set()
    for k, g in enumerate(groups):
        where = f"{path}: runs[{k}]"
        if not isinstance(g, dict):
            raise ConfigError(f"{where} = {g!r}; allowed: a mapping with {', '.join(GROUP_KEYS)}")
        for key in g:
            if key not in GROUP_KEYS:
                raise ConfigError(f"{where}: unknown key {key!r}; allowed: {', '.join(GROUP_KEYS)}")
        for key in ("name", "env", "algo"):
            if not isinstance(g.get(key), str) or not g[key]:
                raise ConfigError(f"{where}: {key} = {g.get(key)!r}; allowed: a non-empty string")
        name = g["name"]
        if not all(ch.isalnum() or ch in "-_." for ch in name) or name in known:
            raise ConfigError(
                f"{where}: name = {name!r}; allowed: letters, digits, - _ . (not a baseline's)"
            )
        try:
            env_id = resolve_id(g["env"])
        except (ValueError, LookupError) as exc:
            raise ConfigError(f"{where}: env = {g['env']!r}: {exc}") from None
        if g["algo"] not in ALGOS:
            raise ConfigError(f"{where}: algo = {g['algo']!r}; allowed: {', '.join(ALGOS)}")
        if (env_id, name) in names:
            raise ConfigError(f"{where}: name {name!r} is used twice on {env_id}")
        names.add((env_id, name))
        changes = g.get("set", {})
        if not isinstance(changes, dict):
            raise ConfigError(f"{where}: set = {changes!r}; allowed: a mapping of settings")
        timesteps = g.get("timesteps")
        n_envs = g.get("n_envs")
        if timesteps is not None:
            _int_ge1(where, "timesteps", timesteps)
        if n_envs is not None:
            _int_ge1(where, "n_envs", n_envs)
        hp_file = g.get("hyperparams")
        if hp_file is not None and not Path(hp_file).is_file():
            raise ConfigError(f"{where}: hyperparams = {hp_file!r}: no such file")
        for seed in parse_seeds(g.get("seeds", 0)):
            runs.append(
                RunSpec(
                    name, env_id, g["algo"], seed,
                    str(env_dir(out_dir, env_id) / name / f"seed{seed}"),
                    hp_file, timesteps, n_envs, dict(changes),
                )
            )
    camp = Campaign(out_dir, episodes, list(baselines), reference, runs,
                    int(data.get("seed", 0)), str(path))
    for spec in runs:  # every run's settings checked before the first starts
        _settings(spec)
    return camp


def _settings(spec: RunSpec) -> dict[str, Any]:
    """The run's hyperparameters: its file's entry with the group's ``set`` applied,
    checked."""
    from bathprint.agents.hyperparams import load_hyperparams, validate_hyperparams

    hp = load_hyperparams(spec.algo, spec.env_id, spec.hyperparams_file)
    hp.update(spec.changes)
    validate_hyperparams(spec.algo, hp, f"{spec.run_dir} ({spec.env_id})", spec.env_id)
    return hp


def seeds_campaign(
    algo: str,
    env_id: str,
    seeds: Any,
    out: str | Path | None = None,
    hyperparams_file: str | None = None,
    timesteps: int | None = None,
    n_envs: int | None = None,
    episodes: int = 16,
) -> Campaign:
    """The campaign of ``bathprint train ... --seeds 0-4``: one group, runs in
    ``OUT/<Env>/<algo>/seed<S>`` (default OUT: runs/<algo>_<Env>), the constant and
    calibrated feedforward baselines (and, on version 1, the oracle) beside them."""
    from bathprint.envs import resolve_id

    env_id = resolve_id(env_id)
    short = env_id.split("/")[-1]
    out_dir = Path(out or f"runs/{algo}_{short}")
    v1 = printed_targets(env_id)
    baselines = ["constant", "feedforward_calibrated"] + (["oracle"] if v1 else [])
    runs = [
        RunSpec(algo, env_id, algo, s, str(env_dir(out_dir, env_id) / algo / f"seed{s}"),
                hyperparams_file, timesteps, n_envs)
        for s in parse_seeds(seeds)
    ]
    for spec in runs:
        _settings(spec)
    return Campaign(out_dir, episodes, baselines, "feedforward_calibrated", runs)


# ----------------------------------------------------------------------- running one


def run_state(run_dir: str | Path) -> str:
    """``new``, ``done``, ``resume`` (a checkpoint to continue from) or ``restart``."""
    from bathprint.agents.train import checkpoints, read_run_info

    run_dir = Path(run_dir)
    if not (run_dir / "run.json").is_file():
        return "new"
    try:
        info = read_run_info(run_dir)
    except ConfigError:
        return "restart"
    status = info.get("status", "running")
    # done: the final model is there, or (an exported copy, which keeps no final model) the
    # selected model's test evaluation is
    if status == "done" and (
        (run_dir / "final_model.zip").is_file() or _episodes_file(run_dir / "test") is not None
    ):
        return "done"
    return "resume" if checkpoints(run_dir) else "restart"


def train_one(spec: RunSpec, progress: bool = False) -> dict[str, Any]:
    """Train (or continue, or skip) one run; returns its compute record."""
    from bathprint.agents.train import read_run_info, train

    run_dir = Path(spec.run_dir)
    state = run_state(run_dir)
    if state == "restart":  # a kill before the first checkpoint: nothing worth keeping
        shutil.rmtree(run_dir)
    if state in ("new", "restart"):
        train(spec.algo, spec.env_id, timesteps=spec.timesteps, n_envs=spec.n_envs,
              seed=spec.seed, out=run_dir, progress=progress, hyperparams=_settings(spec))
    elif state == "resume":
        train(spec.algo, spec.env_id, timesteps=spec.timesteps, out=run_dir, resume=True,
              progress=progress)
    info = read_run_info(run_dir)
    return {"state_before": state, "status": info.get("status"), **compute_record(spec)}


def compute_record(spec: RunSpec) -> dict[str, Any]:
    """What a run cost and what the validation picked (from its files)."""
    from bathprint.agents.train import read_run_info

    run_dir = Path(spec.run_dir)
    info = read_run_info(run_dir)
    best_path = run_dir / "eval" / "best.json"
    best = json.loads(best_path.read_text()) if best_path.is_file() else {}
    machine = info.get("machine", {})
    return {
        "env_id": spec.env_id,
        "name": spec.name,
        "algo": spec.algo,
        "seed": spec.seed,
        "run_dir": str(run_dir),
        "n_envs": info.get("n_envs"),
        "timesteps_done": info.get("timesteps_done"),
        "wall_time_s": info.get("wall_time_s"),
        "cpu_time_s": info.get("cpu_time_s"),
        "stopped_by": info.get("stopped_by", "timesteps"),
        "selected_timesteps": best.get("timesteps"),
        "selected_validation_metric": best.get("mean_metric"),
        "selection_target_set": best.get("target_set"),
        "cpus": machine.get("cpus"),
        "load_average_1min_at_start": machine.get("load_average_1min_at_start"),
    }


def _episodes_file(d: Path) -> Path | None:
    """The episodes of the evaluation in ``d``: episodes.json as the evaluation writes it, or
    else the episodes.csv of an exported copy (which keeps no JSON)."""
    found = sorted(d.glob("*/episodes.json")) or sorted(d.glob("*/episodes.csv"))
    return found[0] if found else None


def evaluate_one(policy: str, env_id: str, out: Path, episodes: int, seed: int,
                 progress: bool = False) -> Path:
    """Play ``policy`` on the first ``episodes`` test targets (version 0: the held-out
    ``eval`` set) into ``out``; an evaluation already there with these settings is kept."""
    from bathprint.agents.evaluate import default_target_set, evaluate_policy_spec

    out = Path(out)
    where = default_target_set(env_id)
    print_ = model_fingerprint(policy)
    found = _episodes_file(out)
    if found is not None and (found.parent / "summary.json").is_file():
        summary = json.loads((found.parent / "summary.json").read_text())
        if (summary.get("episodes"), summary.get("target_set"), summary.get("seed"),
                summary.get("model_fingerprint")) == (episodes, where, seed, print_):
            return found
        shutil.rmtree(found.parent)
    evaluate_policy_spec(policy, env_id, episodes, seed, out, images=1, animate=False,
                         progress=progress, target_set=where)
    found = _episodes_file(out)
    assert found is not None
    summary_path = found.parent / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["model_fingerprint"] = print_
    summary_path.write_text(json.dumps(summary, indent=2, default=str))
    return found


def model_fingerprint(policy: str) -> str | None:
    """SHA-256 of what a model file plays with: its policy weights (the zip's
    ``policy.pth``, which slimming keeps byte for byte) and the observation statistics
    beside it; None for a policy given by name. An evaluation is kept only for the model
    that made it: a run trained further, or a model replaced, is evaluated again."""
    import hashlib
    import zipfile

    path = Path(policy)
    if path.suffix != ".zip" or not path.is_file():
        return None
    h = hashlib.sha256()
    with zipfile.ZipFile(path) as z:
        h.update(z.read("policy.pth") if "policy.pth" in z.namelist() else path.read_bytes())
    stats = path.with_name("vecnormalize.pkl")
    if stats.is_file():
        h.update(stats.read_bytes())
    return h.hexdigest()


def _task(kind: str, payload: dict[str, Any]) -> dict[str, Any]:
    """One unit of work in a worker: ``train`` a run then play its selected model on the
    test targets, or play a ``baseline``."""
    import torch

    torch.set_num_threads(1)
    if kind == "train":
        spec = RunSpec(**payload["spec"])
        rec = train_one(spec)
        best = Path(spec.run_dir) / "eval" / "best_model.zip"
        if not best.is_file():
            if _episodes_file(Path(spec.run_dir) / "test") is not None:
                return rec  # an exported copy keeps the test evaluation, not every model
            raise RuntimeError(f"{spec.run_dir}: no validation-selected eval/best_model.zip")
        evaluate_one(str(best), spec.env_id, Path(spec.run_dir) / "test", payload["episodes"],
                     payload["eval_seed"])
        return rec
    evaluate_one(payload["policy"], payload["env_id"], Path(payload["out"]),
                 payload["episodes"], payload["eval_seed"])
    return {"policy": payload["policy"]}


def _tasks(camp: Campaign) -> list[tuple[str, dict[str, Any]]]:
    tasks: list[tuple[str, dict[str, Any]]] = []
    for env_id in camp.envs:
        for b in camp.baselines:
            tasks.append(("baseline", {
                "policy": b, "env_id": env_id, "episodes": camp.episodes,
                "eval_seed": camp.eval_seed,
                "out": str(env_dir(camp.out, env_id) / "baselines" / b.replace(":", "_")),
            }))
    for spec in camp.runs:
        tasks.append(("train", {"spec": asdict(spec), "episodes": camp.episodes,
                                "eval_seed": camp.eval_seed}))
    return tasks


def run_campaign(camp: Campaign, workers: int = 1, scheduler: str | None = None,
                 progress: bool = True) -> dict[str, Path]:
    """Train and evaluate everything not done yet, then write each environment's results;
    returns {env_id: results.md}. A failed run is reported and left out of the table."""
    check_scheduler(scheduler, "--scheduler")
    tasks = _tasks(camp)
    if scheduler is None and workers <= 1:
        scheduler = SERIAL
    failures = []

    def report(i: int, outcome: Any) -> None:
        kind, payload = tasks[i]
        what = payload["spec"]["run_dir"] if kind == "train" else payload["out"]
        if isinstance(outcome, BaseException):
            failures.append(f"{what}: {type(outcome).__name__}: {outcome}")
            print(f"campaign: {what} failed: {type(outcome).__name__}: {outcome}",
                  file=sys.stderr)
        elif progress:
            extra = ""
            if kind == "train":
                extra = (f" ({outcome['timesteps_done']} steps, "
                         f"{outcome['wall_time_s']:.0f} s, {outcome['state_before']})")
            print(f"campaign: {what} done{extra}", flush=True)

    # interrupted: the workers are stopped now (their runs resume from checkpoints)
    run_tasks(_task, tasks, report, scheduler, workers)
    written = {env_id: write_results(camp, env_id) for env_id in camp.envs}
    if failures:
        raise RuntimeError(f"{len(failures)} task(s) failed: " + "; ".join(failures))
    return written


# ------------------------------------------------------------------------- results


def _test_scores(d: Path) -> dict[str, dict[str, float]]:
    """{target_key: {metric, is_success}} of the evaluation in ``d`` (its episodes.json, or
    the episodes.csv that :func:`export` keeps)."""
    found = _episodes_file(d)
    if found is None:
        return {}
    if found.suffix == ".csv":
        with found.open(newline="") as f:
            rows: list[dict[str, Any]] = list(csv.DictReader(f))
    else:
        rows = json.loads(found.read_text())
    return {
        r["target_key"]: {"metric": float(r["metric"]), "is_success": float(r["is_success"])}
        for r in rows
    }


def collect(camp: Campaign, env_id: str) -> dict[str, Any]:
    """Per policy the (runs, targets) test metrics and successes, aligned on targets."""
    ed = env_dir(camp.out, env_id)
    policies: dict[str, dict[str, Any]] = {}
    for b in camp.baselines:
        s = _test_scores(ed / "baselines" / b.replace(":", "_"))
        if s:
            policies[b] = {"kind": "baseline", "scores": [s], "runs": []}
    for spec in camp.runs:
        if spec.env_id != env_id:
            continue
        s = _test_scores(Path(spec.run_dir) / "test")
        if not s:
            continue
        p = policies.setdefault(spec.name, {"kind": "agent", "algo": spec.algo, "scores": [],
                                            "runs": []})
        p["scores"].append(s)
        p["runs"].append(compute_record(spec))
    keys = sorted(set.intersection(*[set(s) for p in policies.values() for s in p["scores"]]),
                  key=lambda k: min(
                      list(s).index(k) for p in policies.values() for s in p["scores"]))
    for p in policies.values():
        p["metric"] = np.array([[s[k]["metric"] for k in keys] for s in p["scores"]])
        p["success"] = np.array([[s[k]["is_success"] for k in keys] for s in p["scores"]])
    return {"targets": keys, "policies": policies}


def _fmt(v: list[float] | None, digits: int = 3) -> str:
    if v is None:
        return "–"
    return f"{v[0]:.{digits}f} [{v[1]:.{digits}f}, {v[2]:.{digits}f}]"


def write_results(camp: Campaign, env_id: str) -> Path:
    """results.md / .json, runs.csv, scores.csv and curves.png of one environment."""
    from bathprint.agents import statistics as st

    ed = env_dir(camp.out, env_id)
    ed.mkdir(parents=True, exist_ok=True)
    data = collect(camp, env_id)
    pol, keys = data["policies"], data["targets"]
    const = pol.get("constant", {}).get("metric")
    oracle = pol.get("oracle", {}).get("metric")
    ref = pol.get(camp.reference, {}).get("metric") if camp.reference else None
    rows = []
    for name, p in pol.items():
        summ = st.summary(
            p["metric"], p["success"],
            None if const is None else const[0], None if oracle is None else oracle[0],
            None if ref is None or name == camp.reference else ref[0],
        )
        runs = p["runs"]
        summ.update({
            "policy": name,
            "kind": p["kind"],
            "algo": p.get("algo"),
            "seeds": [r["seed"] for r in runs],
            "timesteps_per_run": [r["timesteps_done"] for r in runs],
            "wall_time_s_per_run": [r["wall_time_s"] for r in runs],
            "selected_timesteps": [r["selected_timesteps"] for r in runs],
        })
        rows.append(summ)
    record = {
        "env_id": env_id,
        "target_set": "test" if printed_targets(env_id) else "eval",
        "targets": keys,
        "episodes": len(keys),
        "eval_seed": camp.eval_seed,
        "reference": camp.reference,
        "confidence": st.CONFIDENCE,
        "bootstrap": "stratified over runs and targets (rliable, task_bootstrap), percentile",
        "policies": rows,
    }
    (ed / "results.json").write_text(json.dumps(record, indent=2, default=float))
    with (ed / "scores.csv").open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["policy", "run", "target_key", "metric", "is_success"])
        for name, p in pol.items():
            for r in range(p["metric"].shape[0]):
                seed = p["runs"][r]["seed"] if p["runs"] else ""
                for j, k in enumerate(keys):
                    w.writerow([name, seed, k, f"{p['metric'][r, j]:.6g}",
                                int(p["success"][r, j])])
    runs = [r for p in pol.values() for r in p["runs"]]
    if runs:
        with (ed / "runs.csv").open("w", newline="") as f:
            w2 = csv.DictWriter(f, fieldnames=list(runs[0]))
            w2.writeheader()
            w2.writerows(runs)
    (ed / "results.md").write_text(format_results(record))
    plot_curves(camp, env_id, ed / "curves.png")
    return ed / "results.md"


def format_results(record: dict[str, Any]) -> str:
    """The Markdown table of :func:`write_results`."""
    ref = record["reference"]
    head = ("| policy | runs | steps per run | wall min per run | IQM metric | mean metric "
            "| normalised score | success rate | " + f"− {ref} | gap closed | targets won |")
    lines = [
        f"{record['env_id']}: {record['episodes']} {record['target_set']} targets; "
        "95% stratified-bootstrap "
        "intervals over runs and targets in brackets\n",
        head,
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in record["policies"]:
        steps = r["timesteps_per_run"]
        wall = r["wall_time_s_per_run"]
        steps_s = f"{np.mean(steps) / 1e3:.3g}k" if steps else "–"
        wall_s = f"{np.mean(wall) / 60:.1f}" if wall else "–"
        lines.append(
            f"| {r['policy']} | {r['runs']} | {steps_s} | {wall_s} | {_fmt(r.get('iqm_metric'))} "
            f"| {_fmt(r.get('mean_metric'))} | {_fmt(r.get('normalised_score'), 2)} "
            f"| {_fmt(r.get('success_rate'), 2)} | {_fmt(r.get('paired_difference'))} "
            f"| {_fmt(r.get('gap_closed'), 2)} | "
            + (f"{r['targets_won']}/{r['targets']}" if "targets_won" in r else "–")
            + " |"
        )
    return "\n".join(lines) + "\n"


def plot_curves(camp: Campaign, env_id: str, path: Path) -> Path | None:
    """Mean validation metric of every run against environment steps and wall time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    groups: dict[str, list[tuple[np.ndarray, np.ndarray, np.ndarray]]] = {}
    for spec in camp.runs:
        f = Path(spec.run_dir) / "eval" / "evaluations.npz"
        if spec.env_id != env_id or not f.is_file():
            continue
        with np.load(f) as d:
            groups.setdefault(spec.name, []).append(
                (d["timesteps"], d["metrics"].mean(axis=1), d["wall_time_s"])
            )
    if not groups:
        return None
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for k, (name, curves) in enumerate(groups.items()):
        color = f"C{k}"
        for j, (steps, metric, wall) in enumerate(curves):
            label = f"{name} ({len(curves)} seeds)" if j == 0 else None
            dots = {"marker": "o", "ms": 3} if len(steps) < 3 else {}  # 1-2 evaluations
            axes[0].plot(steps / 1e3, metric, color=color, alpha=0.7, lw=1, label=label, **dots)
            axes[1].plot(wall / 60, metric, color=color, alpha=0.7, lw=1, **dots)
    axes[0].set_xlabel("environment steps (thousands)")
    axes[1].set_xlabel("training wall time (min)")
    axes[0].set_ylabel("mean final metric, validation targets")
    axes[0].legend(fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(f"{env_id}: learning curves (validation set; lower is better)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


#: what :func:`export` copies of a run (relative to its folder): enough to check a result
#: later (the validation curve, the test episodes, the selection), no checkpoints; the
#: training episode log gzipped; no training_curve.png (``python -m bathprint.agents.curves
#: RUN_DIR`` draws it again from these files)
EXPORT_FILES = (
    "run.json", "eval/evaluations.npz", "eval/best.json",
    "test/*/summary.json", "test/*/episodes.csv",
)
#: the selected model (slimmed, :mod:`bathprint.agents.slim`), its record and its
#: statistics: copied for one run per group (see export)
MODEL_FILES = ("eval/best_model.zip", "eval/best_model.slim.json", "eval/vecnormalize.pkl")
#: what :func:`export` writes beside the results: the command, campaign file and commits that
#: made them
META = "results.meta.json"


def export(camp: Campaign, env_id: str, dest: str | Path, all_models: bool = False,
           command: str | None = None) -> Path:
    """Copy one environment's results and the small files of its runs and baselines
    (:data:`EXPORT_FILES`, ``episodes.csv`` as ``episodes.csv.gz``, no checkpoints) into
    ``dest`` with the campaign's layout, and the selected model with its VecNormalize
    statistics (:data:`MODEL_FILES`) of every run (``all_models``) or, to keep the copy
    small, of the run of each group with the best validation metric; the models without
    their optimisers' state (:func:`bathprint.agents.slim.slim_model`). ``dest/``
    :data:`META` records ``command`` (what wrote the copy), the campaign file, the code
    commit of the export and of each run (:func:`export_meta`)."""
    import gzip

    from bathprint.agents.slim import slim_model

    src = env_dir(camp.out, env_id)
    dest = Path(dest)
    dest.mkdir(parents=True, exist_ok=True)
    meta = export_meta(camp, env_id, dest, command)  # before the copy: git knows dest's files
    for name in ("results.md", "results.json", "runs.csv", "scores.csv", "curves.png"):
        if (src / name).is_file():
            shutil.copy2(src / name, dest / name)
    runs = [r for r in camp.runs if r.env_id == env_id]
    best: dict[str, tuple[float, str]] = {}
    for r in runs:
        f = Path(r.run_dir) / "eval" / "best.json"
        if f.is_file():
            v = float(json.loads(f.read_text())["mean_metric"])
            if r.name not in best or v < best[r.name][0]:
                best[r.name] = (v, r.run_dir)
    keep = {d for _, d in best.values()}
    sources = [
        (Path(r.run_dir), EXPORT_FILES + (MODEL_FILES if all_models or r.run_dir in keep else ()))
        for r in runs
    ]
    if (src / "baselines").is_dir():
        baseline_files = ("*/summary.json", "*/episodes.csv")
        sources += [(d, baseline_files) for d in sorted((src / "baselines").glob("*"))]
    for d, patterns in sources:
        for pattern in patterns:
            for f in d.glob(pattern):
                target = dest / f.relative_to(src)
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(f, target)
                if f.name == "best_model.zip":
                    slim_model(target)
                    meta["models"][target.relative_to(dest).as_posix()] = target.stat().st_size
        target = dest / d.relative_to(src) / "episodes.csv.gz"
        if (d / "episodes.csv").is_file():
            target.parent.mkdir(parents=True, exist_ok=True)
            with gzip.GzipFile(target, "wb", mtime=0) as z:
                z.write((d / "episodes.csv").read_bytes())
        elif (d / "episodes.csv.gz").is_file() and d / "episodes.csv.gz" != target:
            shutil.copy2(d / "episodes.csv.gz", target)  # an exported copy exported again
    (dest / META).write_text(json.dumps(meta, indent=2) + "\n")
    return dest


def export_meta(camp: Campaign, env_id: str, dest: Path, command: str | None) -> dict[str, Any]:
    """What :func:`export` writes to ``dest/`` :data:`META`: ``command``, the campaign file
    and its SHA-256, the ``date``, the code ``commit`` that wrote the tables and the copy
    (:func:`bathprint.provenance.code_version`), the runs' ``machine``; per run the code
    commits that trained it (run.json's ``code``) or, for runs trained before run.json held
    them, the commit that first committed the run's run.json at ``dest`` (from git:
    the code that trained it is that commit's or an earlier one)."""
    import datetime
    import hashlib

    from bathprint.provenance import code_version, first_commit

    src = env_dir(camp.out, env_id)
    runs: dict[str, dict[str, Any]] = {}
    machines = set()
    for r in camp.runs:
        f = Path(r.run_dir) / "run.json"
        if r.env_id != env_id or not f.is_file():
            continue
        info = json.loads(f.read_text())
        m = info.get("machine", {})
        machines.add(f"{m.get('processor', '?')}, {m.get('cpus', '?')} cores")
        rel = Path(r.run_dir).relative_to(src).as_posix()
        codes = info.get("code") or []
        runs[rel] = {"commit": ", ".join(c["commit"] for c in codes if c.get("commit")) or None}
        if not codes:
            runs[rel]["first_committed"] = first_commit(dest / rel / "run.json")
    file_hash = None
    if camp.file and Path(camp.file).is_file():
        file_hash = hashlib.sha256(Path(camp.file).read_bytes()).hexdigest()
    if command is None:
        where = dest.parent.as_posix()
        command = f"python -m bathprint.agents.campaign {camp.file or '?'} --export {where}"
    return {
        "command": command,
        "campaign": camp.file,
        "campaign_sha256": file_hash,
        "date": datetime.date.today().isoformat(),
        **code_version(),
        "machine": "; ".join(sorted(machines)) or "not recorded",
        "runs": runs,
        "models": {},
    }


# --------------------------------------------------------------------------- command


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="python -m bathprint.agents.campaign",
                                 description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("file", help="campaign file (YAML)")
    ap.add_argument("--out", default=None, help="campaign directory (default: the file's out)")
    ap.add_argument("--workers", type=int, default=1, help="local worker processes")
    ap.add_argument("--scheduler", default=None,
                    help="'serial', 'local-dask' or a Dask scheduler address tcp://host:8786")
    ap.add_argument("--report-only", action="store_true",
                    help="only rebuild the results from what is on disk")
    ap.add_argument("--export", default=None, metavar="DIR",
                    help="then copy the results, the runs' small files (no checkpoints) and "
                    "each group's selected model without optimiser state into DIR/<Env>/, "
                    "with results.meta.json (command, campaign file, commits)")
    ap.add_argument("--quiet", action="store_true")
    return ap


def main(argv: Sequence[str] | None = None) -> int:
    args = _parser().parse_args(argv)
    if args.workers < 1:
        print(f"campaign: --workers = {args.workers}; must be >= 1", file=sys.stderr)
        return 2
    try:
        camp = load_campaign(args.file, args.out)
        if args.report_only:
            written = {e: write_results(camp, e) for e in camp.envs}
        else:
            # SIGTERM as Ctrl-C: the pool's workers are stopped, not left training unseen
            with signals_interrupt():
                written = run_campaign(camp, args.workers, args.scheduler, not args.quiet)
    except KeyboardInterrupt as exc:
        name = signal.Signals(exit_code(exc) - 128).name
        print(f"campaign: interrupted ({name}); the same command resumes it", file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError) as exc:
        print(f"campaign: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:
        print(f"campaign: {exc}", file=sys.stderr)
        return 1
    for env_id, path in written.items():
        print(path.read_text())
        print(f"wrote {path.parent}/ (results.md, results.json, runs.csv, scores.csv, curves.png)")
        if args.export:
            command = " ".join(
                ["python -m bathprint.agents.campaign"]
                + [shlex.quote(a) for a in (sys.argv[1:] if argv is None else argv)]
            )
            dest = export(camp, env_id, Path(args.export) / env_id.split("/")[-1], command=command)
            print(f"copied the results, the runs' small files and the slimmed models to "
                  f"{dest}/ ({META})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

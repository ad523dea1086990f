"""``bathprint evaluate``: deterministic rollouts of policies on a fixed target set.

The set is version 0's held-out ``eval`` set, or version 1's ``test`` set (reported numbers;
``target_set="validation"`` through the API for model selection). Episode k uses target k and
seed ``seed + k`` (which picks the warm-up start state where the target does not fix it), so
the same policy and seeds give the same numbers; more episodes than the set has targets are
refused (they would repeat targets). For each policy (a baseline or planner name, a run
directory or a model ``.zip``) it writes into ``OUT/<label>/``::

    episodes.csv, episodes.json   per episode: metric (the shape metric, see
                                  bathprint.envs.metric), shape_rms_mm, curvature_rms_1_mm,
                                  density_rms_kg_m3 (intrinsic errors), reward, episode
                                  length, wall time, mean flows, divergence message
    summary.json                  means and standard deviations; version 1: the success
                                  rate (final metric <= the spec's success.metric_max)
                                  and the normalised score (M_constant - M) /
                                  (M_constant - M_oracle) over the episodes whose target
                                  the oracle cache holds (bathprint.agents.planning);
                                  for a trained policy, where its observation statistics
                                  came from (``obs_normalization``)
    episode_K.png                 the printed filament over its target (first --images)
    episode_0.gif                 one episode being written (--animate)

and, for all policies together, ``OUT/table.md`` and ``OUT/table.json``.
"""

from __future__ import annotations

import csv
import json
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

from bathprint.agents.hyperparams import split_hyperparams
from bathprint.agents.rollout import METRIC_KEYS, Episode, run_episode
from bathprint.agents.train import read_run_info, trained_files
from bathprint.envs import fixed_target_sets, printed_targets, target_set_size
from bathprint.errors import ConfigError


def run_settings(
    spec: str, accuracy: str | None, env_id: str | None = None
) -> tuple[dict[str, Any], Any]:
    """(environment kwargs, wrapper entry) a policy was trained with (run directories and
    their models), else the preset and no wrapper. With ``env_id``, a run trained on another
    environment is refused."""
    path = Path(spec)
    kwargs: dict[str, Any] = {}
    wrapper = None
    run_json = path / "run.json" if path.is_dir() else None
    if run_json is None and path.suffix == ".zip":
        run_json = next((p / "run.json" for p in path.parents if (p / "run.json").is_file()), None)
    if run_json is not None and run_json.is_file():
        info = read_run_info(run_json.parent)
        if env_id is not None and info["env_id"] != env_id:
            raise ConfigError(
                f"{spec}: trained on {info['env_id']}, not on {env_id}; evaluate it with "
                f"--env {info['env_id']}"
            )
        hp = info["hyperparams"]
        env_kwargs = hp.get("env_kwargs", {})
        if not isinstance(env_kwargs, dict):
            raise ConfigError(f"{run_json}: env_kwargs = {env_kwargs!r}; expected a mapping")
        kwargs.update(env_kwargs)
        wrapper = split_hyperparams(hp)[0].get("wrapper")  # env_wrapper or wrapper
    if accuracy is not None:
        kwargs["accuracy"] = accuracy
    kwargs.setdefault("accuracy", "draft")
    return kwargs, wrapper


def _check_episodes(episodes: Any) -> None:
    if not (isinstance(episodes, int) and not isinstance(episodes, bool) and episodes >= 1):
        raise ConfigError(f"episodes = {episodes!r}; allowed: an integer >= 1")


def _safe_label(label: str) -> str:
    return "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in label)


def default_target_set(env_id: str) -> str:
    """``eval`` for version-0 environments, ``test`` for version 1."""
    return "test" if printed_targets(env_id) else "eval"


def summarize(episodes: list[Episode]) -> dict[str, Any]:
    """Means and standard deviations of the per-episode numbers."""
    out: dict[str, Any] = {"episodes": len(episodes)}
    for key in episodes[0].metrics if episodes else METRIC_KEYS:
        vals = np.array([e.metrics[key] for e in episodes])
        out[f"mean_{key}"] = float(vals.mean())
        out[f"std_{key}"] = float(vals.std())
    out["mean_reward"] = float(np.mean([e.episode_return for e in episodes]))
    out["mean_episode_length"] = float(np.mean([e.length for e in episodes]))
    out["truncated_episodes"] = int(sum(e.truncated for e in episodes))
    out["wall_time_s"] = float(sum(e.wall_time_s for e in episodes))
    return out


def evaluate_policy_spec(
    spec: str,
    env_id: str,
    episodes: int = 16,
    seed: int = 0,
    out: str | Path | None = None,
    accuracy: str | None = None,
    images: int = 3,
    animate: bool = True,
    progress: bool = True,
    target_set: str | None = None,
) -> tuple[str, dict[str, Any], list[Episode]]:
    """Evaluate one policy; returns (label, summary, episodes) and writes the files if
    ``out`` is given."""
    from bathprint.agents.policies import load_policy
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make, resolve_id

    _check_episodes(episodes)
    env_id = resolve_id(env_id)
    target_set = target_set or default_target_set(env_id)
    allowed = fixed_target_sets(env_id)
    if target_set not in allowed:
        raise ConfigError(
            f"target_set = {target_set!r}; allowed for {env_id}: " + ", ".join(map(repr, allowed))
        )
    kwargs, wrapper = run_settings(spec, accuracy, env_id)
    env = make(env_id, render_mode="rgb_array", target_set=target_set, **kwargs)
    if wrapper:
        env = wrapper_factory(wrapper)(env)
    u = env.unwrapped
    n_eval = target_set_size(u, target_set)
    if episodes > n_eval:
        env.close()
        raise ConfigError(
            f"episodes = {episodes}; the {target_set} set of {env_id} has {n_eval} targets "
            f"and episode k plays target k: allowed 1..{n_eval}"
        )
    policy, label = load_policy(spec, env, env_id, seed=seed)
    note = getattr(policy, "normalization", None)
    if note and note.startswith("no VecNormalize statistics"):
        print(f"bathprint evaluate: warning: {label}: {note}", file=sys.stderr)
    eps: list[Episode] = []
    for k in tqdm(range(episodes), desc=f"evaluate {label}", disable=not progress):
        frame_every = 2 if (animate and k == 0 and out is not None) else 0
        ep = run_episode(
            env,
            policy,
            seed + k,
            target_index=k,
            frame_every=frame_every,
            final_frame=out is not None and k < images,
        )
        eps.append(ep)
    summary = summarize(eps)
    summary.update(
        {
            "policy": label,
            "env_id": env_id,
            "target_set": target_set,
            "env_kwargs": kwargs,
            "wrapper": wrapper,
            "seed": seed,
            "spec": spec,
        }
    )
    if getattr(u, "version", 0) >= 1:
        summary.update(_v1_scores(u, eps))
    if note is not None:
        summary["obs_normalization"] = note
    if out is not None:
        _write(Path(out) / _safe_label(label), env, eps, summary, images)
    env.close()
    return label, summary, eps


def _v1_scores(u: Any, eps: list[Episode]) -> dict[str, Any]:
    """Success rate and normalised score of version-1 episodes (set per episode too)."""
    from bathprint.agents.planning import normalised_score

    thr = float(u.success_metric_max)
    for e in eps:
        e.metrics["is_success"] = float(not e.truncated and e.metrics["metric"] <= thr)
    metrics = {e.target_key: e.metrics["metric"] for e in eps}
    norm = normalised_score(metrics, u.env_id, u.accuracy)
    for e in eps:
        e.metrics["normalised_score"] = norm["per_target"].get(e.target_key, float("nan"))
    out = {
        "success_threshold": thr,
        "success_rate": float(np.mean([e.metrics["is_success"] for e in eps])),
    }
    out.update({k: v for k, v in norm.items() if k != "per_target"})
    return out


def _write(d: Path, env: Any, eps: list[Episode], summary: dict[str, Any], images: int) -> None:
    from PIL import Image

    from bathprint.envs.play import write_animation

    d.mkdir(parents=True, exist_ok=True)
    records = [e.record() for e in eps]
    with (d / "episodes.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(records[0]))
        w.writeheader()
        w.writerows(records)
    (d / "episodes.json").write_text(json.dumps(records, indent=2))
    (d / "summary.json").write_text(json.dumps(summary, indent=2, default=str))
    for k, e in enumerate(eps[:images]):
        if e.final_frame is not None:
            Image.fromarray(e.final_frame).save(d / f"episode_{k}.png")
    if eps[0].frames:
        write_animation(eps[0].frames, d / "episode_0.gif", env.metadata["render_fps"])


def format_table(summaries: Sequence[dict[str, Any]]) -> str:
    """Markdown table of several policies' summaries (mean +- std over episodes); with the
    success rate and the normalised score where the summaries have them (version 1)."""
    v1 = any("success_rate" in s for s in summaries)
    shapes = any("mean_rms_mm" in s for s in summaries)  # the shape environments
    head = "| policy | " + ("RMS error (mm) |" if shapes else "metric |")
    rule = "|---|---|"
    if v1:
        head += " normalised | success |"
        rule += "---|---|"
    if shapes:
        lines = [
            head + " max (mm) | local metric | truncated | wall s |",
            rule + "---|---|---|---|",
        ]
    else:
        lines = [
            head + " shape RMS (mm) | curvature RMS (1/mm) | density RMS (kg/m^3) | truncated |"
            " wall s |",
            rule + "---|---|---|---|---|",
        ]
    for s in summaries:
        row = f"| {s['policy']} | {s['mean_metric']:.3f} +- {s['std_metric']:.3f} |"
        if v1:
            norm = s.get("normalised_score", float("nan"))
            row += f" {norm:.3f} |" if norm == norm else " - |"
            rate = s.get("success_rate")
            row += f" {rate:.2f} |" if rate is not None else " - |"
        if shapes:
            lines.append(
                row + f" {s.get('mean_max_mm', float('nan')):.2f} | "
                f"{s.get('mean_local_metric', float('nan')):.3f} | "
                f"{s['truncated_episodes']}/{s['episodes']} | {s['wall_time_s']:.1f} |"
            )
            continue
        lines.append(
            row + f" {s['mean_shape_rms_mm']:.3f} | {s['mean_curvature_rms_1_mm']:.4f} "
            f"| {s['mean_density_rms_kg_m3']:.2f} | {s['truncated_episodes']}/{s['episodes']} "
            f"| {s['wall_time_s']:.1f} |"
        )
    return "\n".join(lines) + "\n"


def collect_summaries(out: str | Path) -> list[dict[str, Any]]:
    """Every ``OUT/*/summary.json``: baselines first (in their usual order), then agents."""
    from bathprint.agents.policies import BASELINES, PLANNERS, V1_BASELINES

    found = [json.loads(p.read_text()) for p in sorted(Path(out).glob("*/summary.json"))]
    order = {name: k for k, name in enumerate(BASELINES + V1_BASELINES + PLANNERS)}
    return sorted(found, key=lambda s: (order.get(s["policy"], len(order)), s["policy"]))


#: the side-by-side GIF of :func:`evaluate_many`: this fraction of the render size, every
#: this many frames of episode 0's (itself every second step), to keep the file small
SIDE_BY_SIDE_SCALE = 0.6
SIDE_BY_SIDE_EVERY = 2


def evaluate_many(
    specs: Sequence[str],
    env_id: str,
    episodes: int = 16,
    seed: int = 0,
    out: str | Path = "runs/evaluate",
    accuracy: str | None = None,
    images: int = 3,
    animate: bool = True,
    progress: bool = True,
    target_set: str | None = None,
    side_by_side: str | Path | None = None,
) -> list[dict[str, Any]]:
    """Evaluate each policy; returns their summaries. ``OUT/table.md`` and ``table.json``
    are rebuilt from every policy evaluated into ``OUT`` so far with the same environment,
    episodes and seed, so evaluations made one at a time add up to one table. With
    ``side_by_side`` (a .gif path), episode 0 of every policy is also written there, the
    policies side by side in the order given, each captioned with its final metric (at
    :data:`SIDE_BY_SIDE_SCALE` of the size, every :data:`SIDE_BY_SIDE_EVERY`-th frame)."""
    from bathprint.agents import planning
    from bathprint.agents.policies import KNOWN, PLANNERS, baseline_name
    from bathprint.envs import resolve_id

    out = Path(out)
    _check_episodes(episodes)
    if side_by_side is not None and (not animate or Path(side_by_side).suffix != ".gif"):
        raise ConfigError(
            f"side_by_side = {str(side_by_side)!r}: needs the animation of episode 0 "
            "(animate true) and a path ending in .gif"
        )
    for spec in specs:  # every policy checked before the first is evaluated
        name = baseline_name(spec)
        if name in PLANNERS:
            cls = {
                "oracle": planning.CEMSettings,
                "mpc": planning.MPCSettings,
                "cem": planning.ShapeCEMSettings,
            }[name]
            planning.parse_options(spec, cls)
            if name in ("mpc", "cem") and not printed_targets(env_id):
                raise ConfigError(f"policy {name!r} needs a version-1 environment, not {env_id}")
            continue
        if name == "controller" and not printed_targets(env_id):
            raise ConfigError(f"policy 'controller' needs a version-1 environment, not {env_id}")
        if name is not None:
            continue
        if not Path(spec).exists():
            raise FileNotFoundError(
                f"policy {spec!r}: neither a baseline ({', '.join(KNOWN)}) nor "
                "an existing run directory or model .zip"
            )
        trained_files(spec)
        run_settings(spec, accuracy, resolve_id(env_id))
    summaries = []
    panels: list[tuple[str, list[np.ndarray]]] = []
    for spec in specs:
        label, summary, eps = evaluate_policy_spec(
            spec, env_id, episodes, seed, out, accuracy, images, animate, progress, target_set
        )
        summaries.append(summary)
        panels.append((f"{label}: metric {eps[0].metrics['metric']:.3f}", eps[0].frames))
    if side_by_side is not None:
        from bathprint.envs.base import BathprintEnvBase
        from bathprint.envs.play import side_by_side as compose
        from bathprint.envs.play import write_animation

        Path(side_by_side).parent.mkdir(parents=True, exist_ok=True)
        fps = float(BathprintEnvBase.metadata["render_fps"])
        frames = compose(panels, scale=SIDE_BY_SIDE_SCALE, every=SIDE_BY_SIDE_EVERY)
        write_animation(frames, Path(side_by_side), fps / SIDE_BY_SIDE_EVERY)
    first = summaries[0]
    where = first.get("target_set", "eval")
    same = [
        s
        for s in collect_summaries(out)
        if (s["env_id"], s["episodes"], s["seed"], s.get("target_set", "eval"))
        == (first["env_id"], episodes, seed, where)
    ]
    label = "held-out" if where == "eval" else where
    (out / "table.md").write_text(
        f"{first['env_id']}: {episodes} {label} episodes, seed {seed}\n\n" + format_table(same)
    )
    (out / "table.json").write_text(json.dumps(same, indent=2, default=str))
    return summaries


#: columns of ``OUT/targets.csv`` (:func:`evaluate_target_files`)
TARGET_COLUMNS = (
    "target",
    "policy",
    "family",
    "length_mm",
    "rms_mm",
    "max_mm",
    "success",
    "metric",
    "metric_success",
    "truncated",
    "seed",
)


def evaluate_target_files(
    specs: Sequence[str],
    env_id: str,
    files: Sequence[str | Path],
    seed: int = 0,
    out: str | Path = "runs/evaluate",
    accuracy: str | None = None,
    family: str | None = None,
    progress: bool = True,
    allow_overlap: bool = False,
) -> list[dict[str, Any]]:
    """Score each policy on each shape file (``x_mm,y_mm,z_mm``; see
    :mod:`bathprint.envs.shape_files`): one deterministic episode per (file, policy), seed
    ``seed``, and one row per pair in ``OUT/targets.csv``: the whole-shape error (RMS and
    maximum distance in mm after the family's rigid motion, success by the family's
    threshold, :mod:`bathprint.envs.shape_metric`) and the local metric M with the
    environment's success. Every file is checked before the first episode runs;
    ``allow_overlap`` accepts free shapes whose strands overlap (the named shapes marked
    not writable for that reason) instead of refusing them."""
    from bathprint.agents.policies import load_policy
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make, printed_targets, resolve_id
    from bathprint.envs.shape_files import (
        env_family,
        load_shape_file,
        place_shape,
        reference_curve,
        written_curve,
    )
    from bathprint.envs.shape_geometry import length_mm
    from bathprint.envs.shape_metric import arclength_axes, shape_error

    env_id = resolve_id(env_id)
    if not printed_targets(env_id):
        raise ConfigError(f"--target-files needs a version-1 environment, not {env_id}")
    if not files:
        raise ConfigError("target files: none given")
    rows: list[dict[str, Any]] = []
    for spec in specs:
        kwargs, wrapper = run_settings(spec, accuracy, env_id)
        env = make(env_id, **kwargs)
        if wrapper:
            env = wrapper_factory(wrapper)(env)
        fam = family or env_family(env)
        shapes = [
            (Path(f), load_shape_file(f, env, fam, allow_overlap)) for f in files
        ]  # all checked first
        policy, label = load_policy(spec, env, env_id, seed=seed)
        for path, pts in tqdm(shapes, desc=f"targets {label}", disable=not progress):
            target = place_shape(pts, env, fam, path.name)
            ep = run_episode(env, policy, seed, options={"target": target})
            written = written_curve(env, fam)
            complete = not ep.truncated and len(written) == target.n_samples
            reference = reference_curve(pts, env, fam)
            err = shape_error(written, reference, fam) if complete else None
            rows.append(
                {
                    "target": str(path),
                    "policy": label,
                    "family": fam,
                    "length_mm": round(length_mm(pts, arclength_axes(fam)), 3),
                    "rms_mm": err.rms_mm if err else float("nan"),
                    "max_mm": err.max_mm if err else float("nan"),
                    "success": bool(err and err.success),
                    # the local metric M (a shape environment reports it as local_metric,
                    # its metric being the whole-shape error) and the environment's success
                    "metric": ep.metrics.get("local_metric", ep.metrics["metric"]),
                    "metric_success": bool(
                        complete
                        and (
                            ep.is_success == 1.0
                            if "local_metric" in ep.metrics
                            else ep.metrics["metric"] <= env.unwrapped.success_metric_max
                        )
                    ),
                    "truncated": ep.truncated,
                    "seed": seed,
                }
            )
        env.close()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    with (out / "targets.csv").open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(TARGET_COLUMNS))
        w.writeheader()
        w.writerows(rows)
    return rows


def format_target_rows(rows: Sequence[dict[str, Any]]) -> str:
    """Markdown table of :func:`evaluate_target_files`'s rows."""
    lines = [
        "| target | policy | family | RMS (mm) | max (mm) | success | M |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        lines.append(
            f"| {Path(r['target']).name} | {r['policy']} | {r['family']} | {r['rms_mm']:.2f} "
            f"| {r['max_mm']:.2f} | {'yes' if r['success'] else 'no'} | {r['metric']:.3f} |"
        )
    return "\n".join(lines) + "\n"

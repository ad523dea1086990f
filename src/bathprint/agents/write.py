"""``bathprint write SHAPE.csv --policy P --out DIR``: print a shape of your own with a
policy, and write the curve written, its error in mm and pictures of it.

The shape is a CSV polyline (``x_mm,y_mm,z_mm``, :mod:`bathprint.envs.shape_files`) written
in one deterministic episode on the shape environment of its family
(:data:`~bathprint.agents.controller.FAMILY_ENVS`: floor WriteShape-v3, free CoilRadius-v2,
buoyant BuoyantLayers-v2; ``env_id`` may name any other environment of spec version 3). A
trained policy plays on the environment and settings it was trained with
(:func:`~bathprint.agents.evaluate.run_settings`). DIR receives::

    written.csv   the curve written, x_mm,y_mm,z_mm, one point per target sample, in the
                  bath as written (buoyant: the target's path at the height each sample's
                  density settles at, as the environment scores it); a shape file itself
    target.csv    the target as the environment placed it in the bath (same frame)
    result.json   the shape file and its sha1, environment, family, policy, accuracy, seed,
                  the whole-shape error (rms_mm, max_mm, success and the family's
                  thresholds) as the environment reported it, the local metric, steps,
                  wall time of the episode, the bathprint version and commit
    written.png   target (grey) and written curve (blue) after the family's best rigid
                  motion (:func:`~bathprint.envs.shape_metric.align`), from the top for
                  floor shapes, in 3D for the others; the errors in the title
    view.html     the episode's filament, interactive (the page of ``bathprint view``; needs
                  the ``viewer`` extra, without which it is left out and the reason said)

Every option, the output directory and the shape file (missing, empty, not numeric, not
finite, too short or too long, wider than the needle's box, crossing itself for ``free``)
are checked before the episode starts; each refusal is a
:class:`~bathprint.errors.ConfigError` naming what is wrong and what is allowed. A DIR that
already holds any of these files is refused unless ``overwrite``; with it, the old files are
removed before the new ones are written, so that a DIR never mixes two prints. An episode
whose simulation diverges still writes every file, for the part written: result.json says
``complete: false``, the error is that of the samples written and ``sim_error`` says why.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import ConfigError

__all__ = ["OUTPUTS", "WriteResult", "check_policy", "choose_env", "check_out", "write_shape"]

#: the files ``bathprint write`` writes into its output directory
OUTPUTS = ("written.csv", "target.csv", "result.json", "written.png", "view.html")


@dataclass
class WriteResult:
    """What :func:`write_shape` wrote: the directory, result.json's content, the files and,
    when view.html was left out, why (else None)."""

    out: Path
    result: dict[str, Any]
    files: list[Path]
    view_missing: str | None


def check_policy(spec: str) -> tuple[bool, str | None]:
    """Refuse a policy that is neither a name :func:`~bathprint.agents.policies.load_policy`
    knows nor an existing path, or whose extra is missing (every policy reads a YAML file of
    the ``rl`` extra: the controller's gains, the baselines' fits; a trained one needs the
    whole extra). Returns whether it is a trained policy (a path) and the environment it
    was trained on (None for a name, or a path without a ``run.json``)."""
    from bathprint._extras import require, require_extra
    from bathprint.agents.policies import KNOWN, baseline_name

    if baseline_name(spec) is not None:
        require("yaml", f"--policy {spec}", "rl")
        return False, None
    path = Path(spec)
    if not path.exists():
        raise ConfigError(
            f"--policy = {spec!r}: neither a policy name nor an existing run directory or "
            f"model .zip; allowed: {', '.join(KNOWN)}, a run directory or a model .zip"
        )
    require_extra("rl", f"--policy {spec} (a trained policy)")
    return True, _trained_env_id(path)


def _trained_env_id(path: Path) -> str | None:
    """The environment of the run a run directory or model ``.zip`` belongs to (its
    ``run.json``, found as :func:`~bathprint.agents.evaluate.run_settings` finds it)."""
    from bathprint.agents.train import read_run_info

    if path.is_dir():
        run_dir = path if (path / "run.json").is_file() else None
    else:
        run_dir = next((p for p in path.parents if (p / "run.json").is_file()), None)
    return None if run_dir is None else str(read_run_info(run_dir)["env_id"])


def _shape_env_ids() -> list[str]:
    from bathprint.envs import ENV_IDS, shape_targets

    return [i for i in ENV_IDS if shape_targets(i)]


def choose_env(
    family: str | None, env_id: str | None, trained_env: str | None = None
) -> tuple[str, str]:
    """(environment id, shape family) of a print: ``env_id`` if given (a shape environment,
    spec version 3, agreeing with ``family`` if that is given too), else the environment of
    ``family``, else the one a trained policy was trained on (``trained_env``), else the
    floor family's. A trained policy writes on its own environment only."""
    from bathprint.agents.controller import FAMILY_ENVS
    from bathprint.envs import resolve_id, shape_targets
    from bathprint.envs.spec import load_spec

    if family is not None and family not in FAMILY_ENVS:
        raise ConfigError(f"--family = {family!r}; allowed: {', '.join(FAMILY_ENVS)}")
    if env_id is None:
        env_id = trained_env if trained_env and family is None else FAMILY_ENVS[family or "floor"]
    try:
        env_id = resolve_id(env_id)
    except ValueError as exc:
        raise ConfigError(f"--env = {env_id!r}: {exc}") from None
    if not shape_targets(env_id):
        raise ConfigError(
            f"--env = {env_id!r} does not write shapes (spec version 3); allowed: "
            + ", ".join(_shape_env_ids())
        )
    env_family = str(load_spec(env_id).target["shape_family"])
    if family is not None and family != env_family:
        raise ConfigError(
            f"--family = {family!r} with --env {env_id}, which writes {env_family} shapes; "
            f"allowed: --family {env_family}, or one of the two options alone"
        )
    if trained_env is not None and resolve_id(trained_env) != env_id:
        raise ConfigError(
            f"--policy was trained on {trained_env}, not on {env_id}; allowed: --env "
            f"{trained_env} (or leave out --env and --family)"
        )
    return env_id, env_family


def check_out(out: str | Path, overwrite: bool = False) -> Path:
    """The output directory, once it can be written and (unless ``overwrite``) holds none of
    :data:`OUTPUTS` of an earlier print."""
    from bathprint.paths import check_output_dir

    path = check_output_dir(out, "--out")
    held = [name for name in OUTPUTS if (path / name).exists()]
    if held and not overwrite:
        raise ConfigError(
            f"--out = {str(path)!r} already holds {', '.join(held)} of an earlier print; "
            "allowed: another --out, or --overwrite to replace them"
        )
    return path


def _finite_or_none(x: Any) -> float | None:
    return float(x) if x is not None and math.isfinite(float(x)) else None


def _plot(
    path: Path,
    reference: np.ndarray,
    written: np.ndarray,
    family: str,
    title: str,
) -> Path:
    """written.png: the written curve moved by the family's rigid motion onto the part of
    the target it covers (as the error compares them)."""
    from bathprint.envs.shape_metric import align
    from bathprint.viz.plotting import plot_written

    n = min(len(written), len(reference))
    shown = align(written[:n], reference[:n], family) if n >= 2 else written[:n]
    return plot_written(reference, shown, path, top_view=family == "floor", title=title)


def write_shape(
    shape: str | Path,
    policy: str = "controller",
    out: str | Path = "runs/write",
    family: str | None = None,
    env_id: str | None = None,
    accuracy: str | None = None,
    seed: int = 0,
    overwrite: bool = False,
) -> WriteResult:
    """Print ``shape`` (a CSV file) with ``policy`` and write :data:`OUTPUTS` to ``out``
    (module doc). ``accuracy``: a preset, default a trained policy's own, else ``draft``."""
    from bathprint._extras import MissingExtraError, require_extra
    from bathprint.agents.episode_view import play_recorded
    from bathprint.agents.policies import load_policy
    from bathprint.agents.wrappers import wrapper_factory
    from bathprint.envs import make
    from bathprint.envs.shape_files import check_shape, read_points
    from bathprint.envs.shape_geometry import length_mm
    from bathprint.envs.shape_metric import THRESHOLDS, arclength_axes
    from bathprint.envs.shapes import write_csv
    from bathprint.provenance import code_version
    from bathprint.viz.view import format_value

    if not (isinstance(seed, int) and not isinstance(seed, bool) and seed >= 0):
        raise ConfigError(f"--seed = {seed!r}; allowed: an integer >= 0")
    if accuracy is not None and accuracy not in ("draft", "balanced", "fine"):
        raise ConfigError(f"--accuracy = {accuracy!r}; allowed: draft, balanced, fine")
    trained, trained_env = check_policy(policy)
    env_id, family = choose_env(family, env_id, trained_env)
    out = check_out(out, overwrite)
    shape = Path(shape)
    points = read_points(shape)  # a bad file is refused before an environment is made
    if not trained:
        kwargs: dict[str, Any] = {"accuracy": accuracy or "draft"}
        wrapper = None
    else:
        from bathprint.agents.evaluate import run_settings

        kwargs, wrapper = run_settings(policy, accuracy, env_id)
    env = make(env_id, **kwargs)
    try:
        if wrapper:
            env = wrapper_factory(wrapper)(env)
        u = env.unwrapped
        check_shape(points, family, env, f"target file {str(shape)!r}")
        target = u.shape_target(points, shape.name)
        try:
            pol, label = load_policy(policy, env, env_id, seed=seed)
        except FileNotFoundError as exc:  # a directory without a model
            raise ConfigError(f"--policy = {policy!r}: {exc}") from None
        ep = play_recorded(env, pol, seed, {"target": target})
        written = u.written_curve()
        reference = u.reference_curve
    finally:
        env.close()

    info = ep.info
    rms, mx, ok = float(info["rms_mm"]), float(info["max_mm"]), bool(info["is_success"])
    sim_error = info.get("sim_error")
    complete = sim_error is None and len(written) == len(reference)
    thr = THRESHOLDS[family]
    try:
        require_extra("viewer", "view.html (the interactive page)")
        view_missing = None
    except MissingExtraError as exc:
        view_missing = str(exc)

    out.mkdir(parents=True, exist_ok=True)
    for name in OUTPUTS:  # overwrite (check_out refused otherwise): no file of the old print
        (out / name).unlink(missing_ok=True)
    files = [out / "written.csv", out / "target.csv"]
    write_csv(files[0], written)
    write_csv(files[1], reference)
    title = (
        f"{shape.name} ({label}): RMS {rms:.2f} mm, max {mx:.2f} mm, "
        + ("a success" if ok else "not a success")
        + ("" if complete else " (diverged: the part written)")
    )
    files.append(_plot(out / "written.png", reference, written, family, title))
    if view_missing is None:
        from bathprint.viz.view import write_page

        data = ep.record.view_data(
            f"{env_id}: {shape.name}",
            extra=[
                ("shape file", str(shape)),
                ("policy", label),
                ("seed", str(seed)),
                ("RMS", format_value(rms, "mm")),
                ("max", format_value(mx, "mm")),
                ("success", "yes" if ok else "no"),
            ],
        )
        files.append(write_page(data, out / "view.html"))
    result: dict[str, Any] = {
        "shape_file": str(shape),
        "shape_sha1": hashlib.sha1(shape.read_bytes()).hexdigest(),
        "shape_points": len(points),
        "shape_length_mm": round(length_mm(points, arclength_axes(family)), 3),
        "env_id": env_id,
        "family": family,
        "policy": policy,
        "policy_label": label,
        "accuracy": kwargs.get("accuracy"),
        "seed": seed,
        "rms_mm": rms,
        "max_mm": mx,
        "success": ok,
        "rms_max_mm": _finite_or_none(thr.rms_max_mm),
        "max_max_mm": _finite_or_none(thr.max_max_mm),
        "local_metric": _finite_or_none(info.get("local_metric")),
        "complete": complete,
        "sim_error": sim_error,
        "steps": ep.steps,
        "target_samples": len(reference),
        "written_samples": len(written),
        "return": ep.ret,
        "wall_s": round(ep.wall_s, 3),
        **code_version(),
        "files": [p.name for p in files] + ["result.json"],
        "view_html_missing": view_missing,
    }
    files.append(out / "result.json")
    files[-1].write_text(json.dumps(result, indent=2, allow_nan=False) + "\n")
    return WriteResult(out, result, files, view_missing)

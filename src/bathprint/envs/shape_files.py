"""Bring your own shape: a polyline file checked against an environment, turned into the
environment's target, and the written curve read back for the whole-shape error.

A shape file is a CSV with a header ``x_mm,y_mm,z_mm`` (other columns ignored) and one point
per row (mm). It is refused with a :class:`~bathprint.errors.ConfigError` naming the file
and the problem when it is missing, empty, not numeric, not finite, shorter than the
environment's metric window or longer than :data:`MAX_LENGTH_MM` (the spec's target length
for a goal-conditioned environment), wider than the needle's box (floor shapes), or when it
passes through itself in a family whose strands cannot cross (``free``).

The family of a shape follows from the environment (:func:`env_family`): a moving needle
writes ``floor`` shapes, a density-scoring environment ``buoyant`` ones, any other ``free``
ones; ``family=`` overrides it.
"""

from __future__ import annotations

import csv
import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.envs.shape_geometry import length_mm, resample, self_contacts
from bathprint.envs.shape_metric import FAMILIES, FILAMENT_DIAMETER_MM, arclength_axes
from bathprint.envs.targets import FREE_DENSITY, Target, discrete_curvature, discrete_torsion
from bathprint.errors import ConfigError

#: the longest shape file an environment takes (mm of filament)
MAX_LENGTH_MM = 80.0
COLUMNS = ("x_mm", "y_mm", "z_mm")


def env_family(env: Any) -> str:
    """The shape family an environment writes: ``floor`` with a moving needle, ``buoyant``
    where the metric scores density, else ``free``."""
    u = env.unwrapped
    if isinstance(getattr(u, "family", None), str):  # a shape environment says
        return str(u.family)
    if getattr(u, "needle_axes", ()):
        return "floor"
    if getattr(u, "scores_density", False):
        return "buoyant"
    return "free"


def length_limits(env: Any) -> tuple[float, float]:
    """(shortest, longest) filament length (mm) of a shape for ``env``: at least one window of
    the local metric; at most :data:`MAX_LENGTH_MM`, or the spec's target length where the
    goal-conditioned form holds the whole target in its observation."""
    u = env.unwrapped
    lo = float(u.metric_params.window_mm)
    hi = float(u.target_length_mm) if getattr(u, "goal_conditioned", False) else MAX_LENGTH_MM
    return lo, hi


def read_points(path: str | Path) -> np.ndarray:
    """The (N, 3) points of a shape CSV; every problem is a ConfigError naming the file."""
    p = Path(path)
    where = f"target file {str(p)!r}"
    if not p.is_file():
        raise ConfigError(f"{where}: does not exist")
    if p.suffix.lower() != ".csv":
        raise ConfigError(f"{where}: a .csv file with columns {', '.join(COLUMNS)} is allowed")
    with p.open(newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        rows = [r for r in reader if any(c.strip() for c in r)]
    if header is None:
        raise ConfigError(f"{where}: is empty; needs a header {','.join(COLUMNS)} and points")
    header = [h.strip() for h in header]
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        raise ConfigError(
            f"{where}: header {','.join(header)!r} lacks {', '.join(missing)}; needs "
            + ",".join(COLUMNS)
        )
    if not rows:
        raise ConfigError(f"{where}: has a header but no points")
    cols = [header.index(c) for c in COLUMNS]
    pts = np.empty((len(rows), 3))
    for i, row in enumerate(rows):
        for k, c in enumerate(cols):
            text = row[c].strip() if c < len(row) else ""
            try:
                pts[i, k] = float(text)
            except ValueError:
                raise ConfigError(
                    f"{where}: row {i + 2}, column {COLUMNS[k]}: {text!r} is not a number"
                ) from None
    bad = np.nonzero(~np.isfinite(pts).all(axis=1))[0]
    if len(bad):
        raise ConfigError(
            f"{where}: row {bad[0] + 2} is not finite ({', '.join(rows[bad[0]])}); every "
            "coordinate must be a finite number"
        )
    return pts


def check_shape(
    points: np.ndarray, family: str, env: Any, where: str, allow_overlap: bool = False
) -> np.ndarray:
    """``points`` checked for ``env`` and ``family`` (see the module doc); returns them.
    ``allow_overlap`` accepts strands that pass through each other (to score the named
    shapes marked not writable for that reason)."""
    if family not in FAMILIES:
        raise ConfigError(f"shape family = {family!r}; allowed: {', '.join(FAMILIES)}")
    axes = arclength_axes(family)
    total = length_mm(points, axes) if len(points) >= 2 else 0.0
    lo, hi = length_limits(env)
    if total < lo:
        raise ConfigError(
            f"{where}: {total:.1f} mm of filament is too short for {env.unwrapped.env_id}; "
            f"allowed {lo:g}-{hi:g} mm"
        )
    if total > hi:
        raise ConfigError(
            f"{where}: {total:.1f} mm of filament is too long for {env.unwrapped.env_id}; "
            f"allowed {lo:g}-{hi:g} mm"
        )
    u = env.unwrapped
    if family == "floor" and getattr(u, "needle_axes", ()):
        box = np.asarray(u.needle_box_mm, float)
        span = points.max(axis=0) - points.min(axis=0)
        for k in range(2):
            if span[k] > box[k, 1] - box[k, 0]:
                raise ConfigError(
                    f"{where}: {span[k]:.1f} mm across in {'xy'[k]}, wider than the needle's "
                    f"{box[k, 1] - box[k, 0]:g} mm box"
                )
    if family == "free" and not allow_overlap:
        hits = self_contacts(points, FILAMENT_DIAMETER_MM)
        if hits:
            s_i, s_j, d = hits[0]
            raise ConfigError(
                f"{where}: intersects itself (s = {s_i:.1f} and {s_j:.1f} mm are {d:.3f} mm "
                f"apart, closer than the {FILAMENT_DIAMETER_MM:g} mm filament); strands of a "
                "free shape cannot pass through each other"
            )
    return points


def load_shape_file(
    path: str | Path, env: Any, family: str | None = None, allow_overlap: bool = False
) -> np.ndarray:
    """The checked points (N, 3) of a shape file for ``env`` (family: the env's; see
    :func:`check_shape`)."""
    pts = read_points(path)
    where = f"target file {str(path)!r}"
    return check_shape(pts, family or env_family(env), env, where, allow_overlap)


def settling_height_mm(env: Any, rho: np.ndarray) -> np.ndarray:
    """Height (mm, surface 0) where material of density ``rho`` settles in ``env``'s
    gradient bath (clipped to the bath)."""
    u = env.unwrapped
    top, bottom = u.bath_range
    return -(np.clip(rho, top, bottom) - top) / (bottom - top) * float(u.depth_mm)


def bath_density(env: Any, z_mm: np.ndarray) -> np.ndarray:
    """Density (kg/m^3) of ``env``'s gradient bath at height ``z_mm`` (clipped to the bath)."""
    u = env.unwrapped
    top, bottom = u.bath_range
    depth = float(u.depth_mm)
    return top + (bottom - top) * np.clip(-np.asarray(z_mm, float), 0.0, depth) / depth


def reference_curve(points: np.ndarray, env: Any, family: str) -> np.ndarray:
    """The shape resampled every ``target_spacing_mm`` of its family's arclength: the curve
    the environment's target holds and the written curve is compared with."""
    h = float(env.unwrapped.target_spacing_mm)
    return resample(points, spacing=h, axes=arclength_axes(family))


def shape_target(points: np.ndarray, env: Any, family: str, name: str) -> Target:
    """The environment's target for a shape (its :func:`reference_curve`); for ``buoyant``
    the centreline is the horizontal path and the density band the bath's density at each
    point's height (exact, as the spec's printed targets)."""
    u = env.unwrapped
    h = float(u.target_spacing_mm)
    pts = reference_curve(points, env, family)
    flat = pts.copy()
    if family == "buoyant":
        if u.bath_range is None:
            raise ConfigError(f"{name}: a buoyant shape needs a gradient bath; {u.env_id} has none")
        flat[:, 2] = 0.0
        lo = hi = bath_density(env, pts[:, 2])
    else:
        lo, hi = np.full(len(pts), FREE_DENSITY[0]), np.full(len(pts), FREE_DENSITY[1])
    k = max(1, int(round(1.0 / h)))
    digest = hashlib.sha1(np.ascontiguousarray(points).tobytes()).hexdigest()[:16]
    return Target(
        name=f"file:{name}",
        params={"family": "file", "file": name, "sha1": digest, "shape_family": family},
        spacing_mm=h,
        points_mm=flat if family == "buoyant" else pts,
        curvature_1_mm=discrete_curvature(flat, k),
        torsion_1_mm=discrete_torsion(flat, 2 * k),
        density_lo_kg_m3=np.asarray(lo, float),
        density_hi_kg_m3=np.asarray(hi, float).copy(),
    )


def place_shape(points: np.ndarray, env: Any, family: str, name: str) -> Target:
    """The target an episode of ``env`` writes for a shape: a shape environment's own
    (:meth:`~bathprint.envs.shape_env.ShapeEnv.shape_target`, which places a floor shape
    under the needle) when the family is its own, else :func:`shape_target`."""
    u = env.unwrapped
    if hasattr(u, "shape_target") and family == getattr(u, "family", None):
        return u.shape_target(points, name)
    return shape_target(points, env, family, name)


def target_reference(env: Any, target: Target, family: str) -> np.ndarray:
    """The curve a shape target (:func:`shape_target`) is the environment's form of: its
    centreline, with the heights its density band settles at for ``buoyant`` (equal to
    :func:`reference_curve` of the shape's points)."""
    pts = np.asarray(target.points_mm, float).copy()
    if family == "buoyant":
        mid = 0.5 * (target.density_lo_kg_m3 + target.density_hi_kg_m3)
        pts[:, 2] = settling_height_mm(env, mid)
    return pts


def written_curve(env: Any, family: str) -> np.ndarray:
    """The curve an episode wrote, sampled every ``target_spacing_mm`` of filament (mm): the
    recorded samples; for ``buoyant`` the target's horizontal path at the same filament
    length with the height each sample's density settles at (the simulator does not move
    parts to their heights: settling takes minutes; the height follows from the density)."""
    u = env.unwrapped
    pts, rho = u.recorded_samples()
    if family == "buoyant":
        pts = u.target.points_mm[: len(pts)].copy()
        pts[:, 2] = settling_height_mm(env, rho)
    return pts

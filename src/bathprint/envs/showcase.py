"""Showcase targets: letters and 3D curves given as polylines, for ``target_file=``.

Unlike the printed families these are not reachable by construction: they are drawn, not
printed, and what a filament in the bath can write is measured (``docs/envs/WriteShape-v1.md``
gives the oracle's error on each). Every curve is 40-60 mm long (a goal-conditioned
environment takes at most its spec's 60 mm), sampled every 0.25 mm or finer (the
environment resamples it at its own spacing); the files are
``envs/targets/showcase/<name>.csv`` (columns x_mm, y_mm, z_mm), written by
``python -m bathprint.envs.showcase``.
"""

from __future__ import annotations

import csv
import math
import sys
from collections.abc import Callable
from pathlib import Path

import numpy as np

STEP_MM = 0.25


def _arc(centre: tuple[float, float], radius: float, a0: float, a1: float) -> np.ndarray:
    n = max(2, int(abs(a1 - a0) * radius / STEP_MM) + 1)
    a = np.linspace(a0, a1, n)
    return np.stack([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)], axis=1)


def _line(p: tuple[float, float], q: tuple[float, float]) -> np.ndarray:
    n = max(2, int(math.dist(p, q) / STEP_MM) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) * np.asarray(p) + t * np.asarray(q)


def _join(*parts: np.ndarray) -> np.ndarray:
    out = [parts[0]]
    for p in parts[1:]:
        out.append(p[1:] if np.allclose(p[0], out[-1][-1]) else p)
    return np.concatenate(out)


def _planar(xy: np.ndarray, depth_mm: float = -20.0) -> np.ndarray:
    return np.column_stack([xy, np.full(len(xy), depth_mm)])


def letter_c() -> np.ndarray:
    """A "C": 270 degrees of a circle of radius 9 mm (42 mm)."""
    return _planar(_arc((0.0, 0.0), 9.0, math.radians(45), math.radians(315)))


def letter_s() -> np.ndarray:
    """An "S": 270 degrees of a circle of radius 6 mm, then 270 degrees turning the other way
    (57 mm)."""
    upper = _arc((0.0, 6.0), 6.0, 0.0, 1.5 * math.pi)  # from (6, 6) over the top to (0, 0)
    lower = _arc((0.0, -6.0), 6.0, 0.5 * math.pi, -math.pi)  # (0, 0) round to (-6, -6)
    return _planar(_join(upper, lower))


def letter_l() -> np.ndarray:
    """An "L": 30 mm down, a corner of radius 3 mm, 15 mm across (48 mm)."""
    down = _line((0.0, 33.0), (0.0, 3.0))
    corner = _arc((3.0, 3.0), 3.0, math.pi, 1.5 * math.pi)
    across = _line((3.0, 0.0), (18.0, 0.0))
    return _planar(_join(down, corner, across))


def conical_helix() -> np.ndarray:
    """A helix whose radius shrinks from 5 to 3 mm over 60 mm, pitch 2 mm (3D)."""
    s = np.arange(0.0, 60.0 + 1e-9, STEP_MM)
    radius = 5.0 - 2.0 * s / 60.0
    theta = np.cumsum(np.r_[0.0, np.diff(s) / radius[1:]])
    z = -2.0 * theta / (2 * math.pi)
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta), z - 15.0])


def trefoil() -> np.ndarray:
    """A trefoil knot scaled to 60 mm of arclength (3D)."""
    t = np.linspace(0.0, 2 * math.pi, 4000)
    p = np.column_stack(
        [
            np.sin(t) + 2 * np.sin(2 * t),
            np.cos(t) - 2 * np.cos(2 * t),
            -np.sin(3 * t),
        ]
    )
    length = float(np.sum(np.linalg.norm(np.diff(p, axis=0), axis=1)))
    return p * (60.0 / length) + np.array([0.0, 0.0, -20.0])


SHOWCASE: dict[str, Callable[[], np.ndarray]] = {
    "letter_C": letter_c,
    "letter_S": letter_s,
    "letter_L": letter_l,
    "conical_helix": conical_helix,
    "trefoil": trefoil,
}


def showcase_dir() -> Path:
    from bathprint.envs.spec import specs_dir

    return specs_dir() / "targets" / "showcase"


def showcase_path(name: str) -> Path:
    """The CSV of a showcase target (``SHOWCASE``'s names)."""
    if name not in SHOWCASE:
        raise ValueError(f"showcase target {name!r}; known: {', '.join(SHOWCASE)}")
    return showcase_dir() / f"{name}.csv"


def write(directory: Path | None = None) -> list[Path]:
    """Write every showcase polyline as CSV; returns the paths."""
    d = directory or showcase_dir()
    d.mkdir(parents=True, exist_ok=True)
    out = []
    for name, build in SHOWCASE.items():
        path = d / f"{name}.csv"
        with path.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["x_mm", "y_mm", "z_mm"])
            w.writerows([[f"{v:.4f}" for v in row] for row in build()])
        out.append(path)
    return out


if __name__ == "__main__":
    for p in write(Path(sys.argv[1]) if len(sys.argv) > 1 else None):
        print(f"wrote {p}")

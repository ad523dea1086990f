"""Shapes a person would recognise, in three families, and the fixed sets that score them.

======== ================================================ ====================================
family   regime (environment)                             kinds (training / held out)
======== ================================================ ====================================
floor    written by the moving needle, the sewing-machine letter, line, meander, loops /
         regime (WriteShape)                              digit
free     coiled freely in the bath (CoilRadius)           barrel, alternating, spiral / cone
buoyant  parts settling at heights in a gradient bath     layers / staircase
         (BuoyantLayers)
======== ================================================ ====================================

Each family module (:mod:`.floor`, :mod:`.free`, :mod:`.buoyant`) has a generator of
training parameters (``sample_params(rng)``: finite grids, deterministic for a seeded
``numpy.random.Generator``), ``build(params)`` (the polyline in mm) and ``NAMED``, the fixed
named shapes of the held-out sets. The sets (:data:`SETS`):

- ``train``: the generators, which never return a held-out shape (:class:`ShapeGenerator`
  rejects their keys) nor a held-out kind;
- ``validation``, ``test``: named shapes of the training kinds (model selection; reported);
- ``ood_test``: named shapes of the held-out kinds (digits, cones, staircases).

Every shape has 30-80 mm of filament. :func:`feasibility` says what the physics cannot
write (a bend tighter than :data:`MIN_BEND_RADIUS_MM`, a reversal, strands passing through
each other where the family forbids it, a height the bath cannot hold); such shapes stay
in their set, marked ``writable = False`` with the reasons. ``python -m bathprint.envs.shapes
write`` writes every named shape to ``envs/targets/shapes/<family>/<set>/<name>.csv``
(``x_mm,y_mm,z_mm``) and their metadata to ``envs/targets/shapes/index.json``.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np

from bathprint.envs.shape_geometry import (
    STEP_MM,
    length_mm,
    min_bend_radius,
    resample,
    reversals,
    self_contacts,
)
from bathprint.envs.shape_metric import FILAMENT_DIAMETER_MM, arclength_axes
from bathprint.envs.shapes import buoyant, floor, free
from bathprint.envs.targets import params_key

FAMILIES: dict[str, ModuleType] = {"floor": floor, "free": free, "buoyant": buoyant}
SETS = ("train", "validation", "test", "ood_test")
HELD_OUT_SETS = ("validation", "test", "ood_test")
#: tightest bend (mm) the filament makes: the coil radius at the largest flow (2.3 mm at
#: 2 ml/min, draft), rounded down
MIN_BEND_RADIUS_MM = 2.0
#: filament length of a shape (mm)
LENGTH_RANGE_MM = (30.0, 80.0)
#: families whose strands may lie across each other (on the floor; parts piling at a height)
CROSSING_ALLOWED = {"floor": True, "free": False, "buoyant": True}


@dataclass(frozen=True, eq=False)
class Shape:
    """A named or generated shape: its polyline (mm, every :data:`STEP_MM` of filament) and
    whether the physics can write it."""

    name: str
    family: str
    kind: str
    params: dict[str, Any]
    points_mm: np.ndarray
    writable: bool
    issues: tuple[str, ...] = field(default=())

    @property
    def key(self) -> str:
        """Hash of the parameters: equal keys, equal shapes."""
        return params_key(self.params)

    @property
    def length_mm(self) -> float:
        """Filament length (mm; horizontal for the buoyant family)."""
        return length_mm(self.points_mm, arclength_axes(self.family))

    def meta(self) -> dict[str, Any]:
        """What ``index.json`` records of the shape."""
        return {
            "name": self.name,
            "family": self.family,
            "kind": self.kind,
            "params": self.params,
            "key": self.key,
            "length_mm": round(self.length_mm, 3),
            "writable": self.writable,
            "issues": list(self.issues),
        }


def family_module(family: str) -> ModuleType:
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}; allowed: {', '.join(FAMILIES)}")
    return FAMILIES[family]


def feasibility(points: np.ndarray, family: str) -> list[str]:
    """What the physics cannot write of a polyline of ``family`` (empty: nothing found)."""
    issues: list[str] = []
    p = np.asarray(points, float)
    flat = p.copy()
    if family == "buoyant":  # the coil is filament; the heights are where parts settle
        flat[:, 2] = 0.0
        z = p[:, 2]
        lo, hi = buoyant.REACHABLE_MM
        if z.min() < lo or z.max() > hi:
            issues.append(
                f"height {z.min():g} to {z.max():g} mm: the bath's oil fractions reach "
                f"{lo:g} to {hi:g} mm"
            )
    r, s = min_bend_radius(flat)
    if r < MIN_BEND_RADIUS_MM:
        issues.append(
            f"bend of radius {r:.2f} mm at s = {s:.1f} mm: the filament bends no tighter "
            f"than {MIN_BEND_RADIUS_MM:g} mm (a corner)"
        )
    rev = reversals(flat)
    if rev:
        issues.append("reversal at s = " + ", ".join(f"{v:.1f}" for v in rev) + " mm")
    if not CROSSING_ALLOWED[family]:
        hits = self_contacts(p, FILAMENT_DIAMETER_MM, min_separation_mm=None)
        if hits:
            s_i, s_j, d = hits[0]
            issues.append(
                f"strands overlap: s = {s_i:.1f} and {s_j:.1f} mm are {d:.3f} mm apart, closer "
                f"than the {FILAMENT_DIAMETER_MM:g} mm filament ({len(hits)} places)"
            )
    return issues


def make_shape(name: str, params: dict[str, Any]) -> Shape:
    """The shape of ``params`` (its family's ``build``), resampled every :data:`STEP_MM`
    of filament, with its feasibility."""
    family = params["family"]
    mod = family_module(family)
    pts = resample(mod.build(params), spacing=STEP_MM, axes=arclength_axes(family))
    issues = feasibility(pts, family)
    return Shape(name, family, params["kind"], params, pts, not issues, tuple(issues))


def named_params(family: str, set_name: str) -> dict[str, dict[str, Any]]:
    """The named shapes' parameters of a held-out set of ``family``."""
    if set_name not in HELD_OUT_SETS:
        raise ValueError(
            f"set = {set_name!r}; named shapes are in {', '.join(HELD_OUT_SETS)} ('train' is "
            "the generator: ShapeGenerator)"
        )
    return dict(family_module(family).NAMED[set_name])


def named_shapes(family: str, set_name: str) -> dict[str, Shape]:
    """The named shapes of a held-out set of ``family``, by name."""
    return {n: make_shape(n, p) for n, p in named_params(family, set_name).items()}


def held_out_keys(family: str) -> frozenset[str]:
    """Keys of every named shape of ``family`` (the generator never returns them)."""
    return frozenset(params_key(p) for s in HELD_OUT_SETS for p in named_params(family, s).values())


class ShapeGenerator:
    """Training shapes of a family: its generator's draws, minus every held-out shape and
    (optionally) every shape the physics cannot write. Deterministic for a seeded
    ``numpy.random.Generator``."""

    MAX_TRIES = 1000

    def __init__(self, family: str, writable_only: bool = True) -> None:
        self.family = family
        self.module = family_module(family)
        self.writable_only = writable_only
        self.excluded = held_out_keys(family)

    def sample_params(self, rng: np.random.Generator) -> dict[str, Any]:
        for _ in range(self.MAX_TRIES):
            p = self.module.sample_params(rng)
            if params_key(p) not in self.excluded:
                return p
        raise RuntimeError(f"the {self.family!r} generator drew only held-out shapes")

    def sample(self, rng: np.random.Generator) -> Shape:
        for _ in range(self.MAX_TRIES):
            p = self.sample_params(rng)
            key = params_key(p)
            shape = _MADE.get(key)
            if shape is None:  # the grids are finite: a shape is built once per process
                shape = make_shape(f"{self.family}:{key}", p)
                if len(_MADE) >= _MADE_MAX:
                    _MADE.pop(next(iter(_MADE)))
                _MADE[key] = shape
            if shape.writable or not self.writable_only:
                return shape
        raise RuntimeError(f"the {self.family!r} generator drew no writable shape")


#: shapes the generators built in this process, by key (oldest dropped first)
_MADE: dict[str, Shape] = {}
_MADE_MAX = 4096


# ------------------------------------------------------------------------------ files
def shapes_dir() -> Path:
    """``envs/targets/shapes`` of the installed specs."""
    from bathprint.envs.spec import specs_dir

    return specs_dir() / "targets" / "shapes"


def shape_path(family: str, set_name: str, name: str, root: Path | None = None) -> Path:
    return (root or shapes_dir()) / family / set_name / f"{name}.csv"


def write_csv(path: Path, points: np.ndarray) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["x_mm", "y_mm", "z_mm"])
        w.writerows([[f"{v:.4f}" for v in row] for row in points])


def index(root: Path | None = None) -> list[dict[str, Any]]:
    """Metadata of every named shape (as ``index.json`` holds it)."""
    rows = []
    for family in FAMILIES:
        mod = family_module(family)
        for set_name in HELD_OUT_SETS:
            for name, shape in named_shapes(family, set_name).items():
                meta = shape.meta()
                meta.update(
                    set=set_name,
                    file=str(shape_path(family, set_name, name, Path("."))),
                    regime=mod.REGIME,
                )
                rows.append(meta)
    return rows


def write(root: Path | None = None) -> list[Path]:
    """Write every named shape's CSV and ``index.json``; returns the paths."""
    root = root or shapes_dir()
    out = []
    for family in FAMILIES:
        for set_name in HELD_OUT_SETS:
            for name, shape in named_shapes(family, set_name).items():
                path = shape_path(family, set_name, name, root)
                write_csv(path, shape.points_mm)
                out.append(path)
    meta = {
        "families": {
            f: {
                "regime": m.REGIME,
                "sources": list(m.SOURCES),
                "train_kinds": list(m.TRAIN_KINDS),
                "ood_kinds": list(m.OOD_KINDS),
            }
            for f, m in FAMILIES.items()
        },
        "shapes": index(root),
    }
    (root / "index.json").write_text(json.dumps(meta, indent=1) + "\n")
    out.append(root / "index.json")
    return out


def family_shapes(
    family: str, set_name: str, writable_only: bool = False
) -> list[tuple[str, np.ndarray]]:
    """The named shapes of a family's set as (name, points mm), from the committed files."""
    from bathprint.envs.shape_files import read_points

    out = []
    for row in index():
        if row["family"] != family or row["set"] != set_name:
            continue
        if writable_only and not row["writable"]:
            continue
        out.append((row["name"], read_points(shape_path(family, set_name, row["name"]))))
    return out

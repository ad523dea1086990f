"""Buoyant family: parts that settle at chosen heights in a density-gradient bath.

Regime: the inner fluid (silicone oil) co-extruded in the alginate sets each part's density,
and a part settles where the bath is as dense as it is (Chakrabarti, Al-Mosleh & Mahadevan,
Fig. 3E, reproduced in docs/paper.md; ``BuoyantLayers``: a 1010-1050 kg/m^3 bath 125 mm deep,
0.32 kg/m^3 per mm, oil fractions 0.04-0.30 reach heights -119 to -4 mm).

A shape is a coil of radius ``radius_mm`` (the needle at rest coils the filament) whose
parts sit at given heights (z, mm, surface 0): the horizontal arclength is filament, the
height is where its density settles, so a change of height costs no length (the metric
measures arclength horizontally for this family). Kinds: ``layers`` (2-4 parts at heights
at least :data:`MIN_GAP_MM` apart, in any order except an evenly stepped monotone run) in
training; ``staircase`` (3-5 evenly stepped monotone parts) held out.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from bathprint.envs.shape_geometry import STEP_MM

FAMILY = "buoyant"
REGIME = (
    "parts settling at heights in a density-gradient bath, the density set by the inner "
    "fluid; environment: BuoyantLayers"
)
SOURCES = (
    "Chakrabarti, Al-Mosleh & Mahadevan, Instability-induced patterning of a jelling jet "
    "(Fig. 3E: composites settle where the column is as dense as they are)",
)
KINDS = ("layers", "staircase")
TRAIN_KINDS = ("layers",)
OOD_KINDS = ("staircase",)

#: settling heights the oil fractions of BuoyantLayers reach (mm)
REACHABLE_MM = (-119.0, -4.0)
MIN_GAP_MM = 15.0
HEIGHTS_MM = tuple(float(z) for z in range(-110, -5, 5))
RADII_MM = (3.0, 3.5, 4.0, 4.5, 5.0)
LENGTHS_MM = (40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0)


def heights_of(params: dict[str, Any]) -> list[float]:
    """The heights of the parts (mm), in printing order."""
    if params["kind"] == "staircase":
        z0, dz, n = float(params["top_mm"]), float(params["step_mm"]), int(params["steps"])
        return [z0 - k * dz for k in range(n)]
    return [float(z) for z in params["heights_mm"]]


def is_staircase(heights: list[float]) -> bool:
    """Three or more parts evenly stepped in one direction."""
    d = np.diff(heights)
    return len(heights) >= 3 and bool(np.allclose(d, d[0])) and d[0] != 0


def build(params: dict[str, Any]) -> np.ndarray:
    """The polyline (N, 3) in mm: a coil about the vertical axis, each equal part of its
    length at its height (the height jumps between two consecutive points)."""
    if params["kind"] not in KINDS:
        raise ValueError(f"buoyant kind {params['kind']!r}; allowed: {', '.join(KINDS)}")
    length, r = float(params["length_mm"]), float(params["radius_mm"])
    z = np.asarray(heights_of(params), float)
    n_parts = len(z)
    pieces = []
    for k in range(n_parts):
        s = np.arange(0.0, length / n_parts + 1e-9, STEP_MM / 4) + k * length / n_parts
        th = s / r
        pieces.append(np.column_stack([r * np.cos(th), r * np.sin(th), np.full(len(s), z[k])]))
    return np.concatenate(pieces)


def sample_params(rng: np.random.Generator) -> dict[str, Any]:
    """Parameters of a training shape: 2-4 layers at least ``MIN_GAP_MM`` apart, never an
    evenly stepped run (those are the held-out staircases)."""
    pick = lambda values: values[int(rng.integers(len(values)))]  # noqa: E731
    while True:
        n = int(rng.integers(2, 5))
        z = [pick(HEIGHTS_MM) for _ in range(n)]
        gaps = np.abs(np.subtract.outer(z, z))[~np.eye(n, dtype=bool)]
        if gaps.min() >= MIN_GAP_MM and not is_staircase(z):
            break
    return {
        "family": FAMILY,
        "kind": "layers",
        "length_mm": pick(LENGTHS_MM),
        "radius_mm": pick(RADII_MM),
        "heights_mm": z,
    }


def _layers(length: float, r: float, *z: float) -> dict[str, Any]:
    return {
        "family": FAMILY,
        "kind": "layers",
        "length_mm": float(length),
        "radius_mm": float(r),
        "heights_mm": [float(v) for v in z],
    }


def _stairs(length: float, r: float, top: float, step: float, n: int) -> dict[str, Any]:
    return {
        "family": FAMILY,
        "kind": "staircase",
        "length_mm": float(length),
        "radius_mm": float(r),
        "top_mm": float(top),
        "step_mm": float(step),
        "steps": int(n),
    }


NAMED: dict[str, dict[str, dict[str, Any]]] = {
    "validation": {
        "layers_30_80": _layers(40, 4.0, -30, -80),
        "layers_100_20_60": _layers(60, 3.0, -100, -20, -60),
    },
    "test": {
        "layers_20_60": _layers(40, 3.0, -20, -60),
        "layers_90_40": _layers(50, 4.0, -90, -40),
        "layers_15_70_35": _layers(60, 3.0, -15, -70, -35),
        "layers_100_50_80_20": _layers(60, 5.0, -100, -50, -80, -20),
        "layers_surface_floor": _layers(40, 3.0, -2, -123),
    },
    "ood_test": {
        "staircase_down_20": _stairs(60, 3.0, -20, 20, 4),
        "staircase_up_30": _stairs(45, 4.0, -100, -30, 3),
        "staircase_down_25": _stairs(70, 4.0, -10, 25, 5),
    },
}

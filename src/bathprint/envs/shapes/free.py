"""Free family: helices and spirals coiled freely in the bath.

Regime: drag coiling of the gelling filament in the viscous bath, the needle at rest; the
coil radius follows the flow (``CoilRadius``: about 5.6 mm at 0.25 ml/min, 2.3 mm at
2 ml/min at the draft preset), the pitch the stacking of coils (Chakrabarti, Al-Mosleh &
Mahadevan, *Instability-induced patterning of a jelling jet*, reproduced in docs/paper.md;
Ribe 2004, Proc. R. Soc. A 460:3223 for viscous coiling).

Kinds: ``barrel`` (radius up then down), ``alternating`` (radius and pitch switching between
two values section by section) and ``spiral`` (a flat Archimedean spiral) in training;
``cone`` (radius changing linearly) held out. Radii 2.5-5.5 mm (the coil radii the flow
range writes), pitches at least 0.5 mm (coils stacked without overlapping the 0.41 mm
filament).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from bathprint.envs.shape_geometry import STEP_MM

FAMILY = "free"
REGIME = "coiled freely in the bath (drag coiling; radius from the flow); environment: CoilRadius"
SOURCES = (
    "Chakrabarti, Al-Mosleh & Mahadevan, Instability-induced patterning of a jelling jet",
    "Ribe 2004, Proc. R. Soc. A 460:3223",
)
KINDS = ("barrel", "alternating", "spiral", "cone")
TRAIN_KINDS = ("barrel", "alternating", "spiral")
OOD_KINDS = ("cone",)

LENGTHS_MM = (40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0)
RADII_MM = (2.5, 3.0, 3.5, 4.0, 4.5, 5.0, 5.5)
PITCHES_MM = (0.5, 1.0, 1.5, 2.0)
SECTIONS = (2, 3, 4)
RAMP_MM = 10.0  # length of the change between two sections (a quicker one bends too tightly)


def helix(radius: np.ndarray, pitch: np.ndarray, step: float) -> np.ndarray:
    """A helix about the vertical axis, descending, whose radius and pitch (mm) are given
    every ``step`` mm of arclength (approximately: the radial drift is neglected)."""
    dtheta = step / np.sqrt(radius**2 + (pitch / (2 * math.pi)) ** 2)
    theta = np.concatenate([[0.0], np.cumsum(0.5 * (dtheta[1:] + dtheta[:-1]))])
    dz = pitch / (2 * math.pi)
    z = -np.concatenate([[0.0], np.cumsum(0.5 * (dz[1:] + dz[:-1]) * np.diff(theta))])
    return np.column_stack([radius * np.cos(theta), radius * np.sin(theta), z])


def _sections(values: list[float], s: np.ndarray, length: float, ramp: float) -> np.ndarray:
    """Piecewise-constant values over equal sections, joined by linear ramps of ``ramp``."""
    n = len(values)
    edges = np.linspace(0.0, length, n + 1)
    ks, kv = [0.0], [values[0]]
    for k in range(1, n):
        ks += [edges[k] - 0.5 * ramp, edges[k] + 0.5 * ramp]
        kv += [values[k - 1], values[k]]
    ks.append(length)
    kv.append(values[-1])
    return np.interp(s, ks, kv)


def build(params: dict[str, Any]) -> np.ndarray:
    """The polyline (N, 3) in mm of a free shape (the axis vertical through the origin)."""
    kind, length = params["kind"], float(params["length_mm"])
    step = STEP_MM / 4
    s = np.arange(0.0, length + 1e-9, step)
    if kind == "barrel":
        r0, r1 = float(params["end_radius_mm"]), float(params["mid_radius_mm"])
        radius = r0 + (r1 - r0) * np.sin(math.pi * s / length)
        pitch = np.full(len(s), float(params["pitch_mm"]))
    elif kind == "cone":
        r0, r1 = float(params["start_radius_mm"]), float(params["end_radius_mm"])
        radius = r0 + (r1 - r0) * s / length
        pitch = np.full(len(s), float(params["pitch_mm"]))
    elif kind == "alternating":
        n = int(params["sections"])
        ra, rb = float(params["radius_a_mm"]), float(params["radius_b_mm"])
        pa, pb = float(params["pitch_a_mm"]), float(params["pitch_b_mm"])
        radius = _sections([ra if k % 2 == 0 else rb for k in range(n)], s, length, RAMP_MM)
        pitch = _sections([pa if k % 2 == 0 else pb for k in range(n)], s, length, RAMP_MM)
    elif kind == "spiral":
        r0, r1 = float(params["start_radius_mm"]), float(params["end_radius_mm"])
        # Archimedean: r = r0 + c theta, arclength ~ integral of r dtheta
        theta_end = 2.0 * length / (r0 + r1)
        c = (r1 - r0) / theta_end
        theta = np.linspace(0.0, theta_end, len(s))
        r = r0 + c * theta
        return np.column_stack([r * np.cos(theta), r * np.sin(theta), np.zeros(len(s))])
    else:
        raise ValueError(f"free kind {kind!r}; allowed: {', '.join(KINDS)}")
    return helix(radius, pitch, step)


def sample_params(rng: np.random.Generator) -> dict[str, Any]:
    """Parameters of a training shape (training kinds only; finite grids)."""
    kind = TRAIN_KINDS[int(rng.integers(len(TRAIN_KINDS)))]
    pick = lambda values: values[int(rng.integers(len(values)))]  # noqa: E731
    p: dict[str, Any] = {"family": FAMILY, "kind": kind, "length_mm": pick(LENGTHS_MM)}
    r = sorted({pick(RADII_MM), pick(RADII_MM)})
    if len(r) == 1:  # two different radii
        r = [r[0], r[0] + 1.0] if r[0] < 5.0 else [r[0] - 1.0, r[0]]
    if kind == "barrel":
        p.update(end_radius_mm=r[0], mid_radius_mm=r[1], pitch_mm=pick(PITCHES_MM))
    elif kind == "alternating":
        if rng.integers(2):
            r = r[::-1]
        p.update(
            sections=pick(SECTIONS),
            radius_a_mm=r[0],
            radius_b_mm=r[1],
            pitch_a_mm=pick(PITCHES_MM),
            pitch_b_mm=pick(PITCHES_MM),
        )
    else:
        if rng.integers(2):
            r = r[::-1]
        p.update(start_radius_mm=r[0], end_radius_mm=r[1])
    return p


def _p(kind: str, length: float, **kw: Any) -> dict[str, Any]:
    return {"family": FAMILY, "kind": kind, "length_mm": float(length), **kw}


def _alt(length: float, n: int, ra: float, rb: float, pa: float, pb: float) -> dict[str, Any]:
    return _p(
        "alternating",
        length,
        sections=n,
        radius_a_mm=ra,
        radius_b_mm=rb,
        pitch_a_mm=pa,
        pitch_b_mm=pb,
    )


NAMED: dict[str, dict[str, dict[str, Any]]] = {
    "validation": {
        "barrel_3_5": _p("barrel", 50, end_radius_mm=3.0, mid_radius_mm=5.0, pitch_mm=1.0),
        "alternating_3_5": _alt(50, 3, 3.0, 5.0, 1.0, 1.0),
        "spiral_2.5_5": _p("spiral", 40, start_radius_mm=2.5, end_radius_mm=5.0),
    },
    "test": {
        "barrel_2.5_4.5": _p("barrel", 60, end_radius_mm=2.5, mid_radius_mm=4.5, pitch_mm=0.5),
        "barrel_3.5_5.5": _p("barrel", 50, end_radius_mm=3.5, mid_radius_mm=5.5, pitch_mm=2.0),
        "barrel_overlapping": _p("barrel", 50, end_radius_mm=3.0, mid_radius_mm=4.5, pitch_mm=0.25),
        "alternating_2.5_4.5": _alt(40, 2, 2.5, 4.5, 1.0, 1.0),
        "alternating_5.5_3": _alt(60, 4, 5.5, 3.0, 2.0, 0.5),
        "spiral_3_5.5": _p("spiral", 50, start_radius_mm=3.0, end_radius_mm=5.5),
        "spiral_5_2.5": _p("spiral", 45, start_radius_mm=5.0, end_radius_mm=2.5),
    },
    "ood_test": {
        "cone_5.5_2.5": _p("cone", 60, start_radius_mm=5.5, end_radius_mm=2.5, pitch_mm=1.0),
        "cone_2.5_5": _p("cone", 50, start_radius_mm=2.5, end_radius_mm=5.0, pitch_mm=0.5),
        "cone_3_5.5": _p("cone", 40, start_radius_mm=3.0, end_radius_mm=5.5, pitch_mm=2.0),
    },
}

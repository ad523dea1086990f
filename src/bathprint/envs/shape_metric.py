"""The whole-shape error of a written curve against its target, in millimetres.

Both curves are resampled to the same number of points equally spaced in arclength, the
written one is moved by the best rigid motion its family allows, and the error is the RMS
and the maximum of the point-to-point distances (mm). The allowed motions:

==========  ============================================================================
family      motion (never a reflection)
==========  ============================================================================
``floor``   a rotation about the vertical axis and any translation: a flat shape's
            orientation and place in the bath are free, its handedness is not
``free``    any proper rotation and any translation (Kabsch with det = +1)
``buoyant`` a rotation about the vertical axis and a horizontal translation: the heights
            are the shape (where each part settles in the gradient bath)
==========  ============================================================================

For ``buoyant`` the arclength is the horizontal one: the height of a part is where its
density settles, not filament, so a change of layer costs no length.

Success is ``rms_mm <= rms_max_mm`` and ``max_mm <= max_max_mm`` of the family
(:data:`THRESHOLDS`; ``buoyant`` bounds the RMS only, see its reason), stated against the
filament's diameter :data:`FILAMENT_DIAMETER_MM`
(0.41 mm: the 22G needle's bore, which the extruded filament keeps; every environment's
scene uses it, ``tests/test_shape_metric.py`` checks).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bathprint.envs.shape_geometry import resample

#: diameter of the extruded filament (mm): the needle's inner diameter in every environment
FILAMENT_DIAMETER_MM = 0.41
#: points both curves are resampled to
N_POINTS = 256
FAMILIES = ("floor", "free", "buoyant")


@dataclass(frozen=True)
class Threshold:
    """Success of a family: RMS and maximum distance (mm) a maker would accept."""

    rms_max_mm: float
    max_max_mm: float
    why: str


THRESHOLDS: dict[str, Threshold] = {
    "floor": Threshold(
        1.5,
        4.0,
        "letters and patterns 15-30 mm across drawn with a 0.41 mm filament: 1.5 mm RMS "
        "(3.7 filament diameters, 5-10 % of the shape's size) keeps a letter legible; a "
        "stray excursion of 4 mm (10 diameters) does not merge two strokes 5 mm apart",
    ),
    "free": Threshold(
        0.8,
        2.0,
        "helices and spirals of 2.5-5.5 mm radius: 0.8 mm RMS (2 filament diameters, a third "
        "of the smallest radius) keeps the radius schedule readable; 2.0 mm at most stays "
        "under the smallest radius, so no coil is skipped or added",
    ),
    "buoyant": Threshold(
        5.0,
        math.inf,
        "parts settling at heights at least 15 mm apart: 5 mm RMS (1.6 kg/m^3 of density in "
        "the 0.32 kg/m^3-per-mm gradient) keeps every part nearer its own height than its "
        "neighbour's; the filament's 0.41 mm is far below this scale. No bound on the "
        "maximum: the oil pump's 0.1 s lag spreads every change of height over at least "
        "4 mm of filament, which hangs between the parts whatever the control (the "
        "planners' largest distance is 18-70 mm on every shape of two parts or more)",
    ),
}


@dataclass(frozen=True)
class ShapeError:
    """Whole-shape error of a written curve (mm) and whether it counts as a success."""

    rms_mm: float
    max_mm: float
    success: bool
    family: str


def _check_family(family: str) -> None:
    if family not in FAMILIES:
        raise ValueError(f"family = {family!r}; allowed: {', '.join(FAMILIES)}")


def arclength_axes(family: str) -> tuple[int, ...]:
    """The coordinates a family's arclength is measured in."""
    _check_family(family)
    return (0, 1) if family == "buoyant" else (0, 1, 2)


def kabsch_rotation(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The proper rotation R (det +1) minimising sum |R p_i - q_i|^2 (p, q centred (N, 3))."""
    u, _, vt = np.linalg.svd(p.T @ q)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    return vt.T @ np.diag([1.0, 1.0, d]) @ u.T


def yaw_rotation(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """The rotation about the vertical (z) axis minimising sum |R p_i - q_i|^2."""
    num = float(np.sum(p[:, 0] * q[:, 1] - p[:, 1] * q[:, 0]))
    den = float(np.sum(p[:, 0] * q[:, 0] + p[:, 1] * q[:, 1]))
    a = np.arctan2(num, den)
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def align(written: np.ndarray, target: np.ndarray, family: str) -> np.ndarray:
    """``written`` (N, 3) moved by the family's best rigid motion onto ``target`` (N, 3)."""
    _check_family(family)
    w, t = np.asarray(written, float), np.asarray(target, float)
    axes = [0, 1, 2] if family != "buoyant" else [0, 1]  # translated coordinates
    wc, tc = np.zeros(3), np.zeros(3)
    wc[axes] = w[:, axes].mean(axis=0)
    tc[axes] = t[:, axes].mean(axis=0)
    rot = kabsch_rotation if family == "free" else yaw_rotation
    r = rot(w - wc, t - tc)
    return (w - wc) @ r.T + tc


def shape_error(
    written: np.ndarray, target: np.ndarray, family: str, n_points: int = N_POINTS
) -> ShapeError:
    """The whole-shape error of ``written`` against ``target`` (polylines (N, 3), (M, 3) in
    mm; any spacing): both resampled to ``n_points`` by arclength, aligned, compared."""
    _check_family(family)
    axes = arclength_axes(family)
    w = resample(np.asarray(written, float).reshape(-1, 3), n=n_points, axes=axes)
    t = resample(np.asarray(target, float).reshape(-1, 3), n=n_points, axes=axes)
    d = np.linalg.norm(align(w, t, family) - t, axis=1)
    rms, mx = float(np.sqrt(np.mean(d * d))), float(d.max())
    thr = THRESHOLDS[family]
    return ShapeError(rms, mx, bool(rms <= thr.rms_max_mm and mx <= thr.max_max_mm), family)

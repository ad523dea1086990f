"""Floor family: flat shapes written by the moving needle.

Regime: the fluid-mechanical sewing machine. A viscous thread falling on a belt that moves
under it lays straight lines, meanders and translated loops according to the belt speed
(Chiu-Webster & Lister 2006, J. Fluid Mech. 569:89; Brun et al. 2015, Phys. Rev. Lett.
114:174501). In bathprint the needle moves instead of the belt (``WriteShape``, horizontal
needle velocity up to 60 mm/s): the trailing filament lays the needle's path into the
horizontal plane, and single-stroke letters and digits are needle paths too.

Kinds: ``letter``, ``line``, ``meander`` (amplitude, wavelength), ``loops`` (loop radius,
advance per loop) in training; ``digit`` held out (the out-of-distribution set). Corners
are rounded to :data:`FILLET_MM`, above the tightest bend the filament makes
(:data:`bathprint.envs.shapes.MIN_BEND_RADIUS_MM`); a shape drawn with sharp corners keeps
them and is marked as not writable.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from bathprint.envs.shape_geometry import STEP_MM, arc, join, length_mm, line, planar, rounded

FAMILY = "floor"
REGIME = (
    "written on the floor by the moving needle (the fluid-mechanical sewing machine regime); "
    "environment: WriteShape"
)
SOURCES = (
    "Chiu-Webster & Lister 2006, J. Fluid Mech. 569:89",
    "Brun, Audoly, Ribe, Eaves & Lister 2015, Phys. Rev. Lett. 114:174501",
)
KINDS = ("letter", "line", "meander", "loops", "digit")
TRAIN_KINDS = ("letter", "line", "meander", "loops")
OOD_KINDS = ("digit",)
FILLET_MM = 2.5  # corner radius of letters and digits (mm)


def _waypoints(*w: tuple[float, float]) -> Callable[[float, float, float], np.ndarray]:
    def build(h: float, shear: float, fillet: float) -> np.ndarray:
        p = np.asarray(w, float) * h
        p[:, 0] += shear * p[:, 1]
        return rounded(p, fillet)

    return build


def _curve(f: Callable[[], np.ndarray]) -> Callable[[float, float, float], np.ndarray]:
    def build(h: float, shear: float, fillet: float) -> np.ndarray:
        p = f() * h
        p[:, 0] += shear * p[:, 1]
        return p

    return build


def _unit_c() -> np.ndarray:
    return arc((0.5, 0.5), 0.5, math.radians(45), math.radians(315), STEP_MM / 50)


def _unit_s() -> np.ndarray:
    upper = arc((0.25, 0.75), 0.25, 0.0, 1.5 * math.pi, STEP_MM / 50)
    lower = arc((0.25, 0.25), 0.25, 0.5 * math.pi, -math.pi, STEP_MM / 50)
    return join(upper, lower)


def _unit_u() -> np.ndarray:
    return join(
        line((0, 1), (0, 0.3)),
        arc((0.3, 0.3), 0.3, math.pi, 2 * math.pi, STEP_MM / 50),
        line((0.6, 0.3), (0.6, 1)),
    )


def _unit_j() -> np.ndarray:
    return join(line((0.5, 1), (0.5, 0.25)), arc((0.25, 0.25), 0.25, 0.0, -math.pi, STEP_MM / 50))


def _unit_0() -> np.ndarray:
    t = np.linspace(0.0, 2 * math.pi, 2000)
    return np.column_stack([0.3 - 0.3 * np.sin(t), 0.5 + 0.5 * np.cos(t)])


def _unit_6() -> np.ndarray:
    top = arc((0.6, 0.3), 0.6, math.radians(100), math.pi, STEP_MM / 50)
    loop = arc((0.3, 0.3), 0.3, math.pi, 3 * math.pi, STEP_MM / 50)
    return join(top, loop)


def _unit_9() -> np.ndarray:
    loop = arc((0.3, 0.7), 0.3, 0.0, -2 * math.pi, STEP_MM / 50)
    return join(loop, line((0.6, 0.7), (0.6, 0.0)))


def _unit_8() -> np.ndarray:
    t = np.linspace(0.0, 2 * math.pi, 3000)
    return np.column_stack([0.35 + 0.35 * np.sin(2 * t), 0.5 + 0.5 * np.cos(t)])


def _unit_3() -> np.ndarray:  # two bowls meeting in a cusp: a reversal
    upper = arc((0.3, 0.75), 0.25, math.radians(150), -0.5 * math.pi, STEP_MM / 50)
    lower = arc((0.3, 0.25), 0.25, 0.5 * math.pi, math.radians(-150), STEP_MM / 50)
    return join(upper, lower)


def _digit_2(h: float, shear: float, fillet: float) -> np.ndarray:
    a_end = math.radians(-40)
    top = arc((0.3, 0.7), 0.3, math.radians(160), a_end, STEP_MM / 50) * h
    end = top[-1]
    tangent = np.array([math.sin(a_end), -math.cos(a_end)])
    foot = end + tangent * (end[1] / -tangent[1])
    tail = rounded([end, foot, (foot[0] + 0.6 * h, 0.0)], fillet)
    p = join(top, tail)
    p[:, 0] += shear * p[:, 1]
    return p


GLYPHS: dict[str, Callable[[float, float, float], np.ndarray]] = {
    "C": _curve(_unit_c),
    "S": _curve(_unit_s),
    "U": _curve(_unit_u),
    "J": _curve(_unit_j),
    "L": _waypoints((0, 1), (0, 0), (0.6, 0)),
    "V": _waypoints((0, 1), (0.35, 0), (0.7, 1)),
    "N": _waypoints((0, 0), (0, 1), (0.7, 0), (0.7, 1)),
    "M": _waypoints((0, 0), (0, 1), (0.4, 0.35), (0.8, 1), (0.8, 0)),
    "W": _waypoints((0, 1), (0.25, 0), (0.5, 0.7), (0.75, 0), (1, 1)),
    "Z": _waypoints((0, 1), (0.7, 1), (0, 0), (0.7, 0)),
    "0": _curve(_unit_0),
    "1": _waypoints((-0.25, 0.75), (0.1, 1), (0.1, 0)),
    "2": _digit_2,
    "3": _curve(_unit_3),
    "6": _curve(_unit_6),
    "7": _waypoints((0, 1), (0.6, 1), (0.2, 0)),
    "8": _curve(_unit_8),
    "9": _curve(_unit_9),
}
LETTERS = ("C", "S", "U", "J", "L", "V", "N", "M", "W", "Z")
DIGITS = ("0", "1", "2", "3", "6", "7", "8", "9")

# training grids (every value a finite choice, so that a shape is identified by its params)
LENGTHS_MM = (35.0, 40.0, 45.0, 50.0, 55.0, 60.0, 65.0, 70.0)
SLANTS_DEG = (-10.0, -5.0, 0.0, 5.0, 10.0)
AMPLITUDES_MM = (1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0)
WAVELENGTHS_MM = (10.0, 12.0, 14.0, 16.0, 18.0, 20.0, 24.0)
LOOP_RADII_MM = (2.5, 3.0, 3.5, 4.0, 4.5)
ADVANCES_MM = (2.0, 3.0, 4.0, 5.0, 6.0, 8.0)


def _glyph(char: str, length: float, slant_deg: float, fillet: float) -> np.ndarray:
    """A glyph scaled so that its stroke is ``length`` mm long."""
    build = GLYPHS[char]
    shear = math.tan(math.radians(slant_deg))
    h = 20.0
    for _ in range(6):  # fillets are in mm: iterate the scale to the length
        h *= length / length_mm(planar(build(h, shear, fillet)))
    return build(h, shear, fillet)


def _cut(xy: np.ndarray, length: float) -> np.ndarray:
    """The first ``length`` mm of a dense 2D polyline."""
    d = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(d)])
    keep = s <= length + 1e-9
    return xy[keep]


def build(params: dict[str, Any]) -> np.ndarray:
    """The polyline (N, 3) in mm of a floor shape (z = 0)."""
    kind, length = params["kind"], float(params["length_mm"])
    if kind in ("letter", "digit"):
        fillet = float(params.get("fillet_mm", FILLET_MM))
        xy = _glyph(params["char"], length, float(params.get("slant_deg", 0.0)), fillet)
    elif kind == "line":
        xy = line((0.0, 0.0), (length, 0.0))
    elif kind == "meander":
        a, lam = float(params["amplitude_mm"]), float(params["wavelength_mm"])
        x = np.arange(0.0, length + 1e-9, STEP_MM / 8)
        xy = _cut(np.column_stack([x, a * np.sin(2 * math.pi * x / lam)]), length)
    elif kind == "loops":
        r, adv = float(params["radius_mm"]), float(params["advance_mm"])
        th = np.arange(0.0, 4 * length / max(r - adv / (2 * math.pi), 0.2), STEP_MM / (8 * r))
        b = adv / (2 * math.pi)
        xy = _cut(np.column_stack([b * th - r * np.sin(th), -r * np.cos(th)]), length)
    else:
        raise ValueError(f"floor kind {kind!r}; allowed: {', '.join(KINDS)}")
    xy = xy - xy.mean(axis=0)
    return planar(xy, 0.0)


def sample_params(rng: np.random.Generator) -> dict[str, Any]:
    """Parameters of a training shape (training kinds only; finite grids)."""
    kind = TRAIN_KINDS[int(rng.integers(len(TRAIN_KINDS)))]
    pick = lambda values: values[int(rng.integers(len(values)))]  # noqa: E731
    p: dict[str, Any] = {"family": FAMILY, "kind": kind, "length_mm": pick(LENGTHS_MM)}
    if kind == "letter":
        p.update(char=pick(LETTERS), slant_deg=pick(SLANTS_DEG))
    elif kind == "meander":
        p.update(amplitude_mm=pick(AMPLITUDES_MM), wavelength_mm=pick(WAVELENGTHS_MM))
    elif kind == "loops":
        p.update(radius_mm=pick(LOOP_RADII_MM), advance_mm=pick(ADVANCES_MM))
    return p


def _p(kind: str, length: float, **kw: Any) -> dict[str, Any]:
    return {"family": FAMILY, "kind": kind, "length_mm": float(length), **kw}


#: the fixed named shapes of each held-out set
NAMED: dict[str, dict[str, dict[str, Any]]] = {
    "validation": {
        "letter_U": _p("letter", 45, char="U", slant_deg=0.0),
        "letter_Z": _p("letter", 55, char="Z", slant_deg=5.0),
        "letter_J": _p("letter", 40, char="J", slant_deg=-5.0),
        "line_45": _p("line", 45),
        "meander_a2_w16": _p("meander", 50, amplitude_mm=2.0, wavelength_mm=16.0),
        "loops_r3_a3": _p("loops", 50, radius_mm=3.0, advance_mm=3.0),
    },
    "test": {
        "letter_C": _p("letter", 45, char="C", slant_deg=0.0),
        "letter_S": _p("letter", 55, char="S", slant_deg=0.0),
        "letter_L": _p("letter", 50, char="L", slant_deg=0.0),
        "letter_N": _p("letter", 60, char="N", slant_deg=0.0),
        "letter_M": _p("letter", 70, char="M", slant_deg=0.0),
        "letter_W": _p("letter", 65, char="W", slant_deg=10.0),
        "letter_V_sharp": _p("letter", 50, char="V", slant_deg=0.0, fillet_mm=0.0),
        "line_60": _p("line", 60),
        "meander_a1.5_w14": _p("meander", 60, amplitude_mm=1.5, wavelength_mm=14.0),
        "meander_a3_w10": _p("meander", 50, amplitude_mm=3.0, wavelength_mm=10.0),
        "loops_r3.5_a4": _p("loops", 60, radius_mm=3.5, advance_mm=4.0),
        "loops_r2.5_a2": _p("loops", 40, radius_mm=2.5, advance_mm=2.0),
    },
    "ood_test": {f"digit_{c}": _p("digit", 60, char=c, slant_deg=0.0) for c in DIGITS},
}

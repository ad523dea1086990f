"""Targets: what a printed filament should become, as functions of printed arclength.

A :class:`Target` is sampled on a uniform grid of printed (material) arclength
``s = 0, h, 2h, ..., L`` (mm, s = 0 is the first material printed in the episode) and holds

- ``points_mm``: the target centreline (its placement in space is irrelevant: the metric
  aligns it rigidly, window by window);
- ``curvature_1_mm``, ``torsion_1_mm``: its intrinsic description;
- ``density_lo_kg_m3``, ``density_hi_kg_m3``: the band the filament's density must lie in
  (0 and 1e4 where it is free).

Targets come from seeded families (:class:`CoilScheduleFamily`, :class:`SectionsFamily`,
:class:`LayersFamily`) or from user files (:func:`load_target_file`). Every family draws its
parameters from finite grids, so that a target is identified exactly by the hash of its
parameters (:attr:`Target.key`). :class:`TargetSampler` holds a FIXED held-out evaluation set
(drawn with the spec's ``eval_seed``) and draws training targets from the environment's
``np_random``, rejecting any whose key is in the evaluation set: training never sees them.
"""

from __future__ import annotations

import csv
import hashlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from bathprint.errors import ConfigError

FREE_DENSITY = (0.0, 1.0e4)  # kg/m^3: a density band that constrains nothing
STRAIGHT_CURVATURE = 1e-9  # 1/length: discrete_torsion is 0 below this curvature


# ------------------------------------------------------------------------------ targets
@dataclass(frozen=True, eq=False)
class Target:
    """A target sampled every ``spacing_mm`` of printed arclength (see the module doc)."""

    name: str
    params: dict[str, Any]
    spacing_mm: float
    points_mm: np.ndarray
    curvature_1_mm: np.ndarray
    torsion_1_mm: np.ndarray
    density_lo_kg_m3: np.ndarray
    density_hi_kg_m3: np.ndarray
    #: the actions (steps, action components) that printed it, for printed targets
    actions: np.ndarray | None = field(default=None, repr=False)
    _cache: dict[str, Any] = field(default_factory=dict, repr=False)

    @property
    def key(self) -> str:
        """Hash of the parameters: equal keys, equal targets."""
        return params_key(self.params)

    @property
    def n_samples(self) -> int:
        return int(self.points_mm.shape[0])

    @property
    def length_mm(self) -> float:
        """Printed arclength the target covers (mm)."""
        return float((self.n_samples - 1) * self.spacing_mm)

    @property
    def s_mm(self) -> np.ndarray:
        return np.arange(self.n_samples) * self.spacing_mm

    def density_aim(self, rho_gel: float) -> np.ndarray:
        """Density to aim for (kg/m^3): pure gel's density projected into the band."""
        return np.clip(rho_gel, self.density_lo_kg_m3, self.density_hi_kg_m3)

    def coil_radius_mm(self) -> np.ndarray:
        """Radius of the osculating helix R = kappa / (kappa^2 + tau^2) (mm; inf if straight)."""
        k, t = self.curvature_1_mm, self.torsion_1_mm
        den = k * k + t * t
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(den > 1e-12, k / np.maximum(den, 1e-300), np.inf)


def params_key(params: dict[str, Any]) -> str:
    """Stable 16-hex-digit hash of a JSON-able parameter dict."""
    text = json.dumps(params, sort_keys=True, separators=(",", ":"))
    return hashlib.sha1(text.encode()).hexdigest()[:16]


# ------------------------------------------------------------------------------ geometry
def curve_from_curvature(
    kappa: np.ndarray, tau: np.ndarray, h: float, axis: tuple[float, float, float] = (0, 0, -1)
) -> np.ndarray:
    """Centreline (N, 3) with curvature ``kappa`` and torsion ``tau`` (1/length) sampled every
    ``h`` of arclength from the origin (Frenet-Serret, exact for curvature and torsion constant
    over each interval). A curve that starts as a helix starts with its coil axis along
    ``axis`` (down: the way coils stack below the needle); a straight start points along it."""
    n = len(kappa)
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    e1 = np.cross(a, [0.0, 1.0, 0.0] if abs(a[1]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    w0 = math.hypot(kappa[0], tau[0])
    if kappa[0] > 1e-9:
        t = (kappa[0] * e1 + tau[0] * a) / w0
        b = (kappa[0] * a - tau[0] * e1) / w0
    else:
        t, b = a, np.cross(a, e1)
    pts = np.zeros((n, 3))
    tx, ty, tz = (float(v) for v in t)
    bx, by, bz = (float(v) for v in b)
    px = py = pz = 0.0
    for j in range(n - 1):
        k = 0.5 * (kappa[j] + kappa[j + 1])
        w_t = 0.5 * (tau[j] + tau[j + 1])
        # Darboux vector: the frame rotates about it at rate |omega|
        ox, oy, oz = w_t * tx + k * bx, w_t * ty + k * by, w_t * tz + k * bz
        w = math.sqrt(ox * ox + oy * oy + oz * oz)
        if w * h < 1e-12:
            px, py, pz = px + h * tx, py + h * ty, pz + h * tz
        else:
            ax, ay, az = ox / w, oy / w, oz / w
            c, s = math.cos(w * h), math.sin(w * h)
            # displacement: integral of the tangent rotating about the axis
            dot = tx * ax + ty * ay + tz * az
            qx, qy, qz = tx - dot * ax, ty - dot * ay, tz - dot * az  # perpendicular part
            cx, cy, cz = ay * qz - az * qy, az * qx - ax * qz, ax * qy - ay * qx
            f1, f2 = s / w, (1.0 - c) / w
            px += h * dot * ax + f1 * qx + f2 * cx
            py += h * dot * ay + f1 * qy + f2 * cy
            pz += h * dot * az + f1 * qz + f2 * cz
            tx, ty, tz = _rotate(tx, ty, tz, ax, ay, az, c, s)
            bx, by, bz = _rotate(bx, by, bz, ax, ay, az, c, s)
        pts[j + 1] = (px, py, pz)
    return pts


def _rotate(
    vx: float, vy: float, vz: float, ax: float, ay: float, az: float, c: float, s: float
) -> tuple[float, float, float]:
    """v rotated by the angle (cos c, sin s) about the unit axis a (Rodrigues)."""
    dot = (vx * ax + vy * ay + vz * az) * (1.0 - c)
    return (
        vx * c + (ay * vz - az * vy) * s + ax * dot,
        vy * c + (az * vx - ax * vz) * s + ay * dot,
        vz * c + (ax * vy - ay * vx) * s + az * dot,
    )


def discrete_curvature(points: np.ndarray, k: int) -> np.ndarray:
    """Curvature (1/length) of the circle through samples j-k, j, j+k (edge samples take the
    nearest interior value); zeros if there are fewer than 2k+1 samples."""
    n = len(points)
    if k < 1 or n < 2 * k + 1:
        return np.zeros(n)
    from bathprint.envs._kernels import circle_curvature

    out = np.empty(n)
    circle_curvature(np.ascontiguousarray(points, np.float64), int(k), out)
    return out


def discrete_torsion(points: np.ndarray, k: int) -> np.ndarray:
    """Torsion (1/length) by central differences over k samples (0 where the curve is straight).

    Straight means |d1 x d2|^2 <= 1e-12 of its largest value on the curve, or a curvature
    kappa = |d1 x d2| / |d1|^3 of at most ``STRAIGHT_CURVATURE`` (1e-9 1/length, as in
    :func:`curve_from_curvature`) or 1e3 times its round-off eps max|x| / h^2 (samples h
    apart). The absolute floor is what makes a wholly straight curve, whose d1 x d2 is
    round-off everywhere (so is its largest value), have zero torsion rather than round-off
    divided by round-off."""
    n = len(points)
    if k < 1 or n < 4 * k + 1:
        return np.zeros(n)
    d1 = np.gradient(points, k, axis=0)
    d2 = np.gradient(d1, k, axis=0)
    d3 = np.gradient(d2, k, axis=0)
    cr = np.cross(d1, d2)
    den = np.einsum("ij,ij->i", cr, cr)
    num = np.einsum("ij,ij->i", cr, d3)
    speed2 = np.einsum("ij,ij->i", d1, d1)  # |d1|^2 = (h / k)^2
    kappa_roundoff = (
        np.finfo(float).eps * float(np.abs(points).max()) / np.maximum(k * k * speed2, 1e-300)
    )
    kappa_min = np.maximum(STRAIGHT_CURVATURE, 1e3 * kappa_roundoff)
    curved = (den > 1e-12 * np.max(den, initial=1e-30)) & (den > kappa_min**2 * speed2**3)
    return np.where(curved, num / np.maximum(den, 1e-300), 0.0)


def helix_curvature_torsion(radius: np.ndarray, pitch: np.ndarray) -> tuple[np.ndarray, ...]:
    """(kappa, tau) of a helix of radius R and pitch p (axial advance per turn)."""
    c = np.asarray(pitch, float) / (2 * math.pi)
    r = np.asarray(radius, float)
    den = r * r + c * c
    return r / den, c / den


# ------------------------------------------------------------------------------ families
def grid(spec: Any) -> list[Any]:
    """Values of a grid: a table {min, max, step} (inclusive), or a list of values as is."""
    if isinstance(spec, dict):
        lo, hi, step = float(spec["min"]), float(spec["max"]), float(spec["step"])
        if not (step > 0 and hi >= lo):
            raise ValueError(f"grid {spec!r}: needs step > 0 and max >= min")
        n = int(math.floor((hi - lo) / step + 1e-9)) + 1
        return [round(lo + i * step, 6) for i in range(n)]
    if not isinstance(spec, list | tuple) or not spec:
        raise ValueError(f"grid {spec!r}: a non-empty list of values or a {{min, max, step}} table")
    return [x if isinstance(x, str) else round(float(x), 6) for x in spec]


class TargetFamily(Protocol):
    """Seeded generator of targets."""

    name: str

    def sample_params(self, rng: np.random.Generator) -> dict[str, Any]: ...

    def build(self, params: dict[str, Any]) -> Target: ...


def _pick(rng: np.random.Generator, values: list[Any]) -> Any:
    return values[int(rng.integers(len(values)))]


def _n_samples(length_mm: float, h: float) -> int:
    return int(round(length_mm / h)) + 1


class CoilScheduleFamily:
    """Helices whose radius and pitch follow a piecewise-constant schedule along the printed
    length (equal sections, linear ramps of ``ramp_mm`` across each change)."""

    name = "coil_schedule"

    def __init__(self, params: dict[str, Any], length_mm: float, spacing_mm: float) -> None:
        self.length_mm = float(length_mm)
        self.h = float(spacing_mm)
        self.n_sections = [int(x) for x in params.get("sections", [1, 3])]
        self.radii = grid(params.get("radius_mm", {"min": 2.25, "max": 4.5, "step": 0.25}))
        self.pitches = grid(params.get("pitch_mm", [0.5]))
        self.ramp_mm = float(params.get("ramp_mm", 4.0))

    def sample_params(self, rng: np.random.Generator) -> dict[str, Any]:
        n = int(rng.integers(self.n_sections[0], self.n_sections[1] + 1))
        return {
            "family": self.name,
            "length_mm": self.length_mm,
            "sections": [[_pick(rng, self.radii), _pick(rng, self.pitches)] for _ in range(n)],
        }

    def build(self, params: dict[str, Any]) -> Target:
        sec = np.array(params["sections"], float).reshape(-1, 2)
        length = float(params["length_mm"])
        s = np.arange(_n_samples(length, self.h)) * self.h
        edges = np.linspace(0.0, length, len(sec) + 1)
        # piecewise constant with linear ramps of ramp_mm centred on the section boundaries
        knots_s, knots_r, knots_p = [0.0], [sec[0, 0]], [sec[0, 1]]
        for k in range(1, len(sec)):
            half = min(0.5 * self.ramp_mm, 0.25 * (edges[1] - edges[0]))
            knots_s += [edges[k] - half, edges[k] + half]
            knots_r += [sec[k - 1, 0], sec[k, 0]]
            knots_p += [sec[k - 1, 1], sec[k, 1]]
        knots_s.append(length)
        knots_r.append(sec[-1, 0])
        knots_p.append(sec[-1, 1])
        radius = np.interp(s, knots_s, knots_r)
        pitch = np.interp(s, knots_s, knots_p)
        kappa, tau = helix_curvature_torsion(radius, pitch)
        return _target_from_intrinsic(
            "coil_schedule", params, self.h, kappa, tau, *_free_band(len(s))
        )


class SectionsFamily:
    """A chain of sections, each a helix (radius, pitch), a straight piece or a planar arc
    (radius), each free, to float or to sink (density below / above the bath's at the
    needle by ``density_margin_kg_m3``)."""

    name = "sections"

    def __init__(
        self, params: dict[str, Any], spacing_mm: float, bath_density_kg_m3: float
    ) -> None:
        self.h = float(spacing_mm)
        self.n_sections = [int(x) for x in params.get("sections", [2, 4])]
        self.lengths = grid(params.get("section_length_mm", [10.0, 15.0, 20.0]))
        self.kinds = list(params.get("kinds", ["helix", "straight", "arc"]))
        self.helix_radii = grid(params.get("helix_radius_mm", [2.5, 3.0, 3.5, 4.0, 4.5]))
        self.helix_pitches = grid(params.get("helix_pitch_mm", [0.5, 2.0, 4.0]))
        self.arc_radii = grid(params.get("arc_radius_mm", [5.0, 8.0, 12.0]))
        self.buoyancy = list(params.get("buoyancy", ["any", "float", "sink"]))
        self.margin = float(params.get("density_margin_kg_m3", 2.0))
        self.rho_bath = float(bath_density_kg_m3)
        for kind in self.kinds:
            if kind not in ("helix", "straight", "arc"):
                raise ValueError(f"target.params.kinds: unknown kind {kind!r}")
        for b in self.buoyancy:
            if b not in ("any", "float", "sink"):
                raise ValueError(f"target.params.buoyancy: unknown value {b!r}")

    def sample_params(self, rng: np.random.Generator) -> dict[str, Any]:
        n = int(rng.integers(self.n_sections[0], self.n_sections[1] + 1))
        sections = []
        for _ in range(n):
            kind = _pick(rng, self.kinds)
            length = _pick(rng, self.lengths)
            a = b = 0.0
            if kind == "helix":
                a, b = _pick(rng, self.helix_radii), _pick(rng, self.helix_pitches)
            elif kind == "arc":
                a = _pick(rng, self.arc_radii)
            sections.append([kind, length, a, b, _pick(rng, self.buoyancy)])
        return {"family": self.name, "sections": sections}

    def band(self, buoyancy: str) -> tuple[float, float]:
        if buoyancy == "float":
            return FREE_DENSITY[0], self.rho_bath - self.margin
        if buoyancy == "sink":
            return self.rho_bath + self.margin, FREE_DENSITY[1]
        return FREE_DENSITY

    def build(self, params: dict[str, Any]) -> Target:
        parts_k, parts_t, parts_lo, parts_hi = [], [], [], []
        for kind, length, a, b, buoyancy in params["sections"]:
            m = max(1, int(round(float(length) / self.h)))
            if kind == "helix":
                k, t = helix_curvature_torsion(np.full(m, a), np.full(m, b))
            elif kind == "arc":
                k, t = np.full(m, 1.0 / a), np.zeros(m)
            else:
                k, t = np.zeros(m), np.zeros(m)
            lo, hi = self.band(buoyancy)
            parts_k.append(k)
            parts_t.append(t)
            parts_lo.append(np.full(m, lo))
            parts_hi.append(np.full(m, hi))
        # one more sample closes the last section (N = total / h + 1)
        for parts in (parts_k, parts_t, parts_lo, parts_hi):
            parts.append(parts[-1][-1:])
        return _target_from_intrinsic(
            "sections",
            params,
            self.h,
            np.concatenate(parts_k),
            np.concatenate(parts_t),
            np.concatenate(parts_lo),
            np.concatenate(parts_hi),
        )


class LayersFamily:
    """Layers: equal sections of the filament that must settle at given heights in a
    density-gradient bath, i.e. whose density must equal the bath's at that height
    (within +-``band_mm`` of height). The centreline is a nominal coil, for display only."""

    name = "layers"

    def __init__(
        self,
        params: dict[str, Any],
        length_mm: float,
        spacing_mm: float,
        bath_top_kg_m3: float,
        bath_gradient_kg_m3_mm: float,
    ) -> None:
        self.length_mm = float(length_mm)
        self.h = float(spacing_mm)
        self.n_layers = [int(x) for x in params.get("layers", [2, 4])]
        self.heights = grid(params.get("height_mm", {"min": -115.0, "max": -15.0, "step": 10.0}))
        self.band_mm = float(params.get("band_mm", 0.0))
        self.coil_radius = float(params.get("coil_radius_mm", 3.5))
        self.coil_pitch = float(params.get("coil_pitch_mm", 0.5))
        self.rho_top = float(bath_top_kg_m3)
        self.grad = float(bath_gradient_kg_m3_mm)
        if self.grad <= 0:
            raise ValueError("the layers family needs a bath denser below (bath.density_bottom)")

    def bath_density(self, z_mm: float | np.ndarray) -> float | np.ndarray:
        """Bath density (kg/m^3) at height z (mm, surface 0, negative below)."""
        return self.rho_top + self.grad * (-np.asarray(z_mm, float))

    def sample_params(self, rng: np.random.Generator) -> dict[str, Any]:
        n = int(rng.integers(self.n_layers[0], self.n_layers[1] + 1))
        heights = [_pick(rng, self.heights) for _ in range(n)]
        return {"family": self.name, "length_mm": self.length_mm, "heights_mm": heights}

    def build(self, params: dict[str, Any]) -> Target:
        length = float(params["length_mm"])
        heights = np.asarray(params["heights_mm"], float)
        n = _n_samples(length, self.h)
        s = np.arange(n) * self.h
        layer = np.minimum((s / length * len(heights)).astype(int), len(heights) - 1)
        z = heights[layer]
        lo = self.bath_density(z + self.band_mm)
        hi = self.bath_density(z - self.band_mm)
        kappa, tau = helix_curvature_torsion(
            np.full(n, self.coil_radius), np.full(n, self.coil_pitch)
        )
        return _target_from_intrinsic("layers", params, self.h, kappa, tau, lo, hi)


def _free_band(n: int) -> tuple[np.ndarray, np.ndarray]:
    return np.full(n, FREE_DENSITY[0]), np.full(n, FREE_DENSITY[1])


def _target_from_intrinsic(
    name: str,
    params: dict[str, Any],
    h: float,
    kappa: np.ndarray,
    tau: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
) -> Target:
    return Target(
        name=name,
        params=params,
        spacing_mm=h,
        points_mm=curve_from_curvature(kappa, tau, h),
        curvature_1_mm=np.asarray(kappa, float),
        torsion_1_mm=np.asarray(tau, float),
        density_lo_kg_m3=np.asarray(lo, float),
        density_hi_kg_m3=np.asarray(hi, float),
    )


# ------------------------------------------------------------------------------ files
def load_target_file(path: str | Path, spacing_mm: float) -> Target:
    """A target from a polyline file, resampled every ``spacing_mm`` of its arclength.

    - ``.npy``: an (N, 3) array of points in mm, or (N, 5) with density_lo, density_hi
      (kg/m^3) as columns 4-5;
    - ``.csv``: a header row with x_mm, y_mm, z_mm and optionally density_lo_kg_m3,
      density_hi_kg_m3 (or a single density_kg_m3 column: an exact density).

    Curvature and torsion are computed from the resampled points.
    """
    p = Path(path)
    if not p.exists():
        raise FileNotFoundError(f"target_file {str(p)!r} does not exist")
    if p.suffix == ".npy":
        arr = np.asarray(np.load(p), float)
        if arr.ndim != 2 or arr.shape[1] not in (3, 5):
            raise ValueError(
                f"target_file {str(p)!r}: shape {arr.shape}; expected (N, 3) or (N, 5)"
            )
        pts = arr[:, :3]
        lo, hi = (arr[:, 3], arr[:, 4]) if arr.shape[1] == 5 else _free_band(len(arr))
    elif p.suffix == ".csv":
        with p.open(newline="") as f:
            rows = list(csv.DictReader(f))
        if not rows or any(c not in rows[0] for c in ("x_mm", "y_mm", "z_mm")):
            raise ValueError(f"target_file {str(p)!r} needs a header with x_mm, y_mm, z_mm")
        pts = np.array([[float(r["x_mm"]), float(r["y_mm"]), float(r["z_mm"])] for r in rows])
        if "density_lo_kg_m3" in rows[0]:
            lo = np.array([float(r["density_lo_kg_m3"]) for r in rows])
            hi = np.array([float(r["density_hi_kg_m3"]) for r in rows])
        elif "density_kg_m3" in rows[0]:
            lo = hi = np.array([float(r["density_kg_m3"]) for r in rows])
        else:
            lo, hi = _free_band(len(rows))
    else:
        raise ValueError(f"target_file {str(p)!r}: allowed suffixes .npy, .csv")
    if len(pts) < 2 or not np.isfinite(pts).all():
        raise ValueError(f"target_file {str(p)!r}: needs at least 2 finite points")
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    if s[-1] < 2 * spacing_mm:
        raise ValueError(f"target_file {str(p)!r} is shorter than two samples ({s[-1]:g} mm)")
    su = np.arange(int(math.floor(s[-1] / spacing_mm + 1e-9)) + 1) * spacing_mm
    res = np.stack([np.interp(su, s, pts[:, a]) for a in range(3)], axis=1)
    k = max(1, int(round(1.0 / spacing_mm)))
    digest = hashlib.sha1(p.read_bytes()).hexdigest()[:16]
    return Target(
        name=f"file:{p.name}",
        params={"family": "file", "file": p.name, "sha1": digest},
        spacing_mm=float(spacing_mm),
        points_mm=res,
        curvature_1_mm=discrete_curvature(res, k),
        torsion_1_mm=discrete_torsion(res, 2 * k),
        density_lo_kg_m3=np.interp(su, s, lo),
        density_hi_kg_m3=np.interp(su, s, hi),
    )


# ------------------------------------------------------------------------------ sampling
class TargetSampler:
    """Training draws from a family, and the fixed held-out evaluation set it never draws.

    The evaluation set is ``eval_size`` distinct targets drawn with
    ``np.random.default_rng(eval_seed)``: fixed by index for a given spec. Training targets
    are drawn with the caller's generator (the environment's ``np_random``); a draw whose
    key is in the evaluation set is rejected and drawn again.
    """

    MAX_TRIES = 10_000

    def __init__(self, family: TargetFamily, eval_size: int, eval_seed: int) -> None:
        self.family = family
        self.eval_size = int(eval_size)
        self.eval_seed = int(eval_seed)
        rng = np.random.default_rng(self.eval_seed)
        params: list[dict[str, Any]] = []
        keys: list[str] = []
        for _ in range(self.MAX_TRIES):
            if len(params) >= self.eval_size:
                break
            p = family.sample_params(rng)
            k = params_key(p)
            if k not in keys:
                params.append(p)
                keys.append(k)
        self.eval_params = params
        self.eval_keys = frozenset(keys)
        self._eval_cache: dict[int, Target] = {}

    def eval_target(self, index: int) -> Target:
        """Evaluation target number ``index`` (0 <= index < eval_size)."""
        if not 0 <= index < len(self.eval_params):
            raise ConfigError(
                f"target_index = {index!r}; allowed: 0 to {len(self.eval_params) - 1} (the "
                f"evaluation set has {len(self.eval_params)} targets)"
            )
        if index not in self._eval_cache:
            self._eval_cache[index] = self.family.build(self.eval_params[index])
        return self._eval_cache[index]

    def train_params(self, rng: np.random.Generator) -> dict[str, Any]:
        """Parameters of a training target (never one of the evaluation set)."""
        for _ in range(self.MAX_TRIES):
            p = self.family.sample_params(rng)
            if params_key(p) not in self.eval_keys:
                return p
        raise RuntimeError(
            f"the {self.family.name!r} family has no targets outside the evaluation set"
        )

    def train_target(self, rng: np.random.Generator) -> Target:
        return self.family.build(self.train_params(rng))

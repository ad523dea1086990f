"""The shape metric M: ONE number for how far a printed filament is from its target, used
for the reward and for evaluation alike. Every version scores with M; the reward differs:

- version 0 (``*-v0``): the reward of a step is M_before - M_after, on the filament as it
  is at each step; an episode's return is M_0 - M_final = ``missing_error`` - M_final.
- versions 1 and 2 (``*-v1``, ``WriteShape-v2``): a sample is recorded once it is scored
  and keeps that value; the reward of a step is the decrease of sum_j e_j^2 / N over the
  recorded samples (S_before - S_after), so an episode's return is -M_final^2, with no
  constant progress term; a diverged episode's last reward counts the unscored samples as
  missing. ``info["metric"]`` is M in every version.

Both curves are sampled at the same printed arclengths s_j = j h, j = 0..N-1 (h: the
target's spacing; the printed curve by its material arclength, so the comparison is
arclength-matched). Only *scored* samples count as printed: those at least
``settle_length_mm`` of material away from the needle tip (the stem near the needle has not
taken its shape yet). Per scored sample j the error is

    e_j^2 = w_shape (d_j / ell)^2 + w_curvature (ell dkappa_j)^2 + w_density (drho_j / rho_s)^2

- d_j (mm): RMS distance between the printed and the target samples of the window of
  arclength ``window_mm`` centred on s_j (cut to the scored range), after the optimal rigid
  alignment of the window (Kabsch; with ``allow_reflection`` also mirror images, since the
  handedness of drag coiling is a spontaneous choice). A window as long as the target gives
  the classic global Kabsch RMSD; a shorter one compares local shape and ignores slow drift.
- dkappa_j (1/mm): difference of the discrete curvatures, each from the circle through the
  samples ``curvature_span_mm`` before and after s_j (same operator on both curves).
- drho_j (kg/m^3): distance of the printed density to the target's band [lo_j, hi_j]; in a
  density-gradient bath the printed density is first clipped to the bath's range (a part
  lighter than the surface floats at the surface, a denser one rests on the floor).

``ell`` = ``length_scale_mm``, ``rho_s`` = ``density_scale_kg_m3``. Samples not yet scored
have e_j = ``missing_error``, and e_j is capped there (a printed sample is never worse than a
missing one, so ending an episode early never pays). The metric is

    M = sqrt( mean_j e_j^2 )   over all N target samples,

so M = missing_error before anything is printed and M is the target's RMS error at the end.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from bathprint.envs.targets import Target, discrete_curvature


@dataclass(frozen=True)
class MetricParams:
    """Parameters of the metric (the ``[metric]`` table of an environment spec)."""

    window_mm: float = 20.0
    length_scale_mm: float = 3.0
    curvature_span_mm: float = 1.0
    density_scale_kg_m3: float = 10.0
    w_shape: float = 1.0
    w_curvature: float = 0.5
    w_density: float = 0.0
    missing_error: float = 2.0
    allow_reflection: bool = True

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> MetricParams:
        return cls(**{k: (bool(v) if k == "allow_reflection" else float(v)) for k, v in d.items()})


@dataclass(frozen=True)
class PrintedSamples:
    """The printed filament sampled at the target's arclengths (scored samples only)."""

    points_mm: np.ndarray  # (J, 3), J = number of scored samples
    density_kg_m3: np.ndarray  # (J,)


@dataclass(frozen=True)
class MetricValue:
    """The metric and its parts (RMS over the scored samples; 0 when none is scored)."""

    value: float
    shape_rms_mm: float
    curvature_rms_1_mm: float
    density_rms_kg_m3: float
    scored_fraction: float
    errors: np.ndarray  # (N,) per-sample e_j (missing_error where not scored)

    def as_info(self) -> dict[str, float]:
        return {
            "metric": self.value,
            "shape_rms_mm": self.shape_rms_mm,
            "curvature_rms_1_mm": self.curvature_rms_1_mm,
            "density_rms_kg_m3": self.density_rms_kg_m3,
            "scored_fraction": self.scored_fraction,
        }


def windowed_kabsch_rmsd(
    p: np.ndarray, q: np.ndarray, half_width: int, allow_reflection: bool
) -> np.ndarray:
    """RMS distance (after optimal rigid alignment) of p and q (both (J, 3)) over the window
    [j - half_width, j + half_width] (cut to [0, J)) of every sample j; O(J) via prefix sums
    (compiled: :func:`bathprint.envs._kernels.windowed_kabsch`)."""
    from bathprint.envs._kernels import windowed_kabsch

    out = np.zeros(len(p))
    if len(p):
        windowed_kabsch(
            np.ascontiguousarray(p, np.float64),
            np.ascontiguousarray(q, np.float64),
            int(half_width),
            bool(allow_reflection),
            out,
        )
    return out


def settle_density(rho: np.ndarray, bath_range: tuple[float, float] | None) -> np.ndarray:
    """Density as it decides where a part settles: clipped to the bath's [top, bottom] range
    in a gradient bath (None: uniform bath, unchanged)."""
    if bath_range is None:
        return rho
    return np.clip(rho, bath_range[0], bath_range[1])


@dataclass(frozen=True)
class PreparedMetric:
    """What :func:`evaluate` needs of a target and the parameters, ready for the compiled
    kernel (:func:`bathprint.envs._kernels.metric_errors`); see :func:`prepare`."""

    args: tuple[Any, ...]  # (points, curvature, density lo, hi, half, k, w, reflect, bath lo, hi)
    n_samples: int
    needs_density: bool


def prepare(
    target: Target, params: MetricParams, bath_range: tuple[float, float] | None = None
) -> PreparedMetric:
    """The per-target constants of the metric (the target's curvature is cached on it)."""
    h = target.spacing_mm
    half = max(1, int(round(0.5 * params.window_mm / h)))
    k = max(1, int(round(params.curvature_span_mm / h)))
    tcurv = np.zeros(0)
    if params.w_curvature > 0:
        key = f"curvature_{k}"
        if key not in target._cache:
            target._cache[key] = discrete_curvature(target.points_mm, k)
        tcurv = np.ascontiguousarray(target._cache[key], np.float64)
    w = np.array(
        [
            params.w_shape,
            params.w_curvature,
            params.w_density,
            params.length_scale_mm,
            params.density_scale_kg_m3,
            params.missing_error**2,
        ],
        np.float64,
    )
    lo, hi = (-math.inf, math.inf) if bath_range is None else bath_range
    args = (
        np.ascontiguousarray(target.points_mm, np.float64),
        tcurv,
        np.ascontiguousarray(target.density_lo_kg_m3, np.float64),
        np.ascontiguousarray(target.density_hi_kg_m3, np.float64),
        half,
        k,
        w,
        bool(params.allow_reflection),
        float(lo),
        float(hi),
    )
    return PreparedMetric(args, target.n_samples, params.w_density > 0)


def evaluate_prepared(
    prepared: PreparedMetric, points_mm: np.ndarray, density_kg_m3: np.ndarray
) -> MetricValue:
    """The metric of the printed samples (C-contiguous float64 arrays) with :func:`prepare`'s
    constants: what :func:`evaluate` returns."""
    from bathprint.envs._kernels import metric_errors

    n_sc = min(len(points_mm), prepared.n_samples)
    if prepared.needs_density and n_sc > 0 and len(density_kg_m3) < n_sc:
        raise ValueError(f"{len(density_kg_m3)} printed densities for {n_sc} scored samples")
    errors, value, shape, curv, dens = metric_errors(points_mm, density_kg_m3, *prepared.args)
    return MetricValue(
        value=value,
        shape_rms_mm=shape,
        curvature_rms_1_mm=curv,
        density_rms_kg_m3=dens,
        scored_fraction=n_sc / prepared.n_samples,
        errors=errors,
    )


def evaluate(
    target: Target,
    printed: PrintedSamples,
    params: MetricParams,
    bath_range: tuple[float, float] | None = None,
) -> MetricValue:
    """The metric of ``printed`` (its first J samples scored) against ``target``."""
    pts = np.ascontiguousarray(np.asarray(printed.points_mm, np.float64).reshape(-1, 3))
    rho = np.ascontiguousarray(np.asarray(printed.density_kg_m3, np.float64).reshape(-1))
    return evaluate_prepared(prepare(target, params, bath_range), pts, rho)

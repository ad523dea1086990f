"""Goals of the goal-conditioned form of versions 1 and 2 (``goal_conditioned=True``).

A goal is ``[points (N x 3) mm | density lo (N) | density hi (N) | n | n_prev]``, N the
spec's number of target samples, padded with zeros: the points only where the metric scores
shape, the band only where it scores density; n samples valid, n_prev of them valid before
the step. The reward of reaching an achieved goal for a desired one is the decrease of the
sum of squared errors (the environment's metric) from n_prev to n samples, over the desired
goal's count: the step reward, so hindsight relabelling (HER) scores as the environment does.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bathprint.envs._kernels import metric_errors
from bathprint.envs._kernels_v1 import goal_rewards, squared_sum
from bathprint.envs.metric import MetricParams
from bathprint.envs.targets import FREE_DENSITY, discrete_curvature


@dataclass(frozen=True)
class GoalLayout:
    """The goals of one environment: their layout and their reward."""

    size: int  # N, the spec's target samples
    scores_shape: bool
    scores_density: bool
    metric_params: MetricParams
    spacing_mm: float  # target sample spacing
    bath_range: tuple[float, float] | None  # densities at the top and floor (gradient bath)

    def vector(
        self, pts: np.ndarray, lo: np.ndarray, hi: np.ndarray, n: int, n_prev: int
    ) -> np.ndarray:
        """The goal of these samples (positions, density band) and counts."""
        size = self.size
        parts = []
        if self.scores_shape:
            p = np.zeros((size, 3))
            p[: len(pts)] = pts[:size]
            parts.append(p.ravel())
        if self.scores_density:
            for band in (lo, hi):
                b = np.zeros(size)
                b[: len(band)] = band[:size]
                parts.append(b)
        parts.append(np.array([float(n), float(n_prev)]))
        return np.concatenate(parts)

    def split(self, g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, int, int]:
        """Positions, density band and counts of a goal (a free band where not scored)."""
        size = self.size
        k = 0
        pts = np.zeros((size, 3))
        lo = np.full(size, FREE_DENSITY[0])
        hi = np.full(size, FREE_DENSITY[1])
        if self.scores_shape:
            pts = np.ascontiguousarray(g[: 3 * size].reshape(size, 3))
            k = 3 * size
        if self.scores_density:
            lo = np.ascontiguousarray(g[k : k + size])
            hi = np.ascontiguousarray(g[k + size : k + 2 * size])
        return pts, lo, hi, int(round(g[-2])), int(round(g[-1]))

    def spans(self) -> tuple[int, int]:
        """The metric's alignment half-window and curvature span, in target samples."""
        mp = self.metric_params
        h = self.spacing_mm
        half = max(1, int(round(0.5 * mp.window_mm / h)))
        return half, max(1, int(round(mp.curvature_span_mm / h)))

    def weights(self) -> np.ndarray:
        """The metric's weights and scales as :func:`metric_errors` takes them."""
        mp = self.metric_params
        return np.array(
            [
                mp.w_shape,
                mp.w_curvature,
                mp.w_density,
                mp.length_scale_mm,
                mp.density_scale_kg_m3,
                mp.missing_error**2,
            ]
        )

    def sse(
        self,
        a_pts: np.ndarray,
        a_rho: np.ndarray,
        n: int,
        d_pts: np.ndarray,
        d_lo: np.ndarray,
        d_hi: np.ndarray,
        n_d: int,
    ) -> float:
        """Sum of squared errors of the first n achieved samples against the desired goal's
        first n_d samples (the metric of the environment)."""
        mp = self.metric_params
        half, k = self.spans()
        tpts = np.ascontiguousarray(d_pts[:n_d])
        tcurv = discrete_curvature(tpts, k) if mp.w_curvature > 0 else np.zeros(0)
        w = self.weights()
        b_lo, b_hi = (-math.inf, math.inf) if self.bath_range is None else self.bath_range
        j = min(n, n_d)
        errors = metric_errors(
            np.ascontiguousarray(a_pts[:j]),
            np.ascontiguousarray(a_rho[:j]),
            tpts,
            tcurv,
            np.ascontiguousarray(d_lo[:n_d]),
            np.ascontiguousarray(d_hi[:n_d]),
            half,
            k,
            w,
            bool(mp.allow_reflection),
            float(b_lo),
            float(b_hi),
        )[0]
        return squared_sum(errors, j)

    def rewards(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """The rewards of rows of achieved and desired goals, in one compiled loop (the
        operations of :meth:`split` and :meth:`sse` per row)."""
        out = np.empty(len(achieved))
        mp = self.metric_params
        half, k = self.spans()
        b_lo, b_hi = (-math.inf, math.inf) if self.bath_range is None else self.bath_range
        goal_rewards(
            achieved,
            desired,
            self.size,
            bool(self.scores_shape),
            bool(self.scores_density),
            float(FREE_DENSITY[0]),
            float(FREE_DENSITY[1]),
            half,
            k,
            bool(mp.w_curvature > 0),
            self.weights(),
            bool(mp.allow_reflection),
            float(b_lo),
            float(b_hi),
            out,
        )
        return out

    def rewards_one_by_one(self, achieved: np.ndarray, desired: np.ndarray) -> np.ndarray:
        """:meth:`rewards` row by row in Python (:meth:`split`, :meth:`sse`): the reference
        the compiled batch matches bit for bit."""
        out = np.empty(len(achieved))
        for i in range(len(achieved)):
            a_pts, a_rho, _, n, n_prev = self.split(achieved[i])
            d_pts, d_lo, d_hi, n_d, _ = self.split(desired[i])
            if n_d <= 0:
                out[i] = 0.0
                continue
            before = self.sse(a_pts, a_rho, n_prev, d_pts, d_lo, d_hi, n_d)
            after = self.sse(a_pts, a_rho, n, d_pts, d_lo, d_hi, n_d)
            out[i] = (before - after) / n_d
        return out

"""Polyline geometry for shapes (all lengths in mm): building blocks (lines, arcs, rounded
corners), resampling by arclength, and the checks that say whether the physics can write a
polyline (tight bends, reversals, strands passing through each other).

Everything is vectorised numpy on (N, 3) float arrays.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

#: spacing of the polylines the families build and write (mm)
STEP_MM = 0.25


# ------------------------------------------------------------------------------ building
def line(p: Sequence[float], q: Sequence[float], step: float = STEP_MM) -> np.ndarray:
    """The segment from p to q (2D or 3D points), sampled at most ``step`` apart."""
    p, q = np.asarray(p, float), np.asarray(q, float)
    n = max(2, int(math.ceil(float(np.linalg.norm(q - p)) / step)) + 1)
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1.0 - t) * p + t * q


def arc(
    centre: Sequence[float], radius: float, a0: float, a1: float, step: float = STEP_MM
) -> np.ndarray:
    """A planar circular arc (2D) from angle a0 to a1 (radians; a1 < a0 turns clockwise)."""
    n = max(2, int(math.ceil(abs(a1 - a0) * radius / step)) + 1)
    a = np.linspace(a0, a1, n)
    return np.stack([centre[0] + radius * np.cos(a), centre[1] + radius * np.sin(a)], axis=1)


def join(*parts: np.ndarray) -> np.ndarray:
    """Concatenate polylines, dropping a part's first point where it repeats the last one."""
    out = [np.asarray(parts[0], float)]
    for p in parts[1:]:
        p = np.asarray(p, float)
        out.append(p[1:] if np.allclose(p[0], out[-1][-1]) else p)
    return np.concatenate(out)


def planar(xy: np.ndarray, z_mm: float = 0.0) -> np.ndarray:
    """2D points (N, 2) in the horizontal plane at height ``z_mm``: (N, 3)."""
    return np.column_stack([xy, np.full(len(xy), float(z_mm))])


def rounded(
    waypoints: Sequence[Sequence[float]], radius: float, step: float = STEP_MM
) -> np.ndarray:
    """The 2D polyline through ``waypoints`` with every corner replaced by a circular fillet of
    ``radius`` mm (0: sharp corners). A fillet that does not fit (a turn too sharp for the
    segments beside it: a reversal) shrinks to fit, so it may end tighter than ``radius``."""
    w = np.asarray(waypoints, float)
    if radius <= 0 or len(w) < 3:
        return join(*[line(w[i], w[i + 1], step) for i in range(len(w) - 1)])
    seg = np.diff(w, axis=0)
    seg_len = np.linalg.norm(seg, axis=1)
    u = seg / seg_len[:, None]
    pieces: list[np.ndarray] = []
    start = w[0]
    for i in range(1, len(w) - 1):
        a, b = u[i - 1], u[i]
        turn = math.atan2(a[0] * b[1] - a[1] * b[0], float(a @ b))
        if abs(turn) < 1e-9:
            continue
        t = radius * math.tan(0.5 * abs(turn))
        t = min(t, 0.5 * seg_len[i - 1], 0.5 * seg_len[i])
        r = t / math.tan(0.5 * abs(turn))
        p_in, p_out = w[i] - a * t, w[i] + b * t
        normal = np.array([-a[1], a[0]]) * math.copysign(1.0, turn)  # towards the centre
        c = p_in + normal * r
        a0 = math.atan2(p_in[1] - c[1], p_in[0] - c[0])
        pieces += [line(start, p_in, step), arc(c, r, a0, a0 + turn, step)]
        start = p_out
    pieces.append(line(start, w[-1], step))
    return join(*pieces)


# ------------------------------------------------------------------------------ arclength
def arclength(points: np.ndarray, axes: Sequence[int] = (0, 1, 2)) -> np.ndarray:
    """Cumulative arclength (N,) of a polyline, measured in the coordinates ``axes``
    (``(0, 1)``: the horizontal length, for parts whose height is not filament)."""
    d = np.diff(np.asarray(points, float)[:, list(axes)], axis=0)
    return np.concatenate([[0.0], np.cumsum(np.sqrt(np.einsum("ij,ij->i", d, d)))])


def resample(
    points: np.ndarray,
    n: int | None = None,
    spacing: float | None = None,
    axes: Sequence[int] = (0, 1, 2),
) -> np.ndarray:
    """The polyline resampled at ``n`` points equally spaced in arclength (ends kept), or
    every ``spacing`` mm from its start (the last piece shorter than ``spacing`` dropped).
    Arclength is measured in ``axes`` (see :func:`arclength`); repeated points are ignored."""
    p = np.asarray(points, float)
    s = arclength(p, axes)
    keep = np.concatenate([[True], np.diff(s) > 0])
    p, s = p[keep], s[keep]
    if len(p) < 2:
        raise ValueError("a polyline needs two distinct points to be resampled")
    if n is not None:
        su = np.linspace(0.0, s[-1], int(n))
    elif spacing is not None:
        su = np.arange(int(math.floor(s[-1] / spacing + 1e-9)) + 1) * spacing
    else:
        raise ValueError("resample needs n or spacing")
    return np.stack([np.interp(su, s, p[:, k]) for k in range(p.shape[1])], axis=1)


def length_mm(points: np.ndarray, axes: Sequence[int] = (0, 1, 2)) -> float:
    """Arclength of a polyline (mm) in ``axes``."""
    return float(arclength(points, axes)[-1])


# ------------------------------------------------------------------------------ checks
def min_bend_radius(points: np.ndarray, span_mm: float = 1.0) -> tuple[float, float]:
    """Smallest radius of curvature (mm) of the polyline, from the circle through the points
    ``span_mm`` of arclength before and after each point, and the arclength (mm) where it
    is. A sharp corner or a reversal gives a radius near 0 (about ``span_mm`` / 2 or less)."""
    p = resample(points, spacing=0.25 * span_mm)
    k = 4
    if len(p) < 2 * k + 1:
        return math.inf, 0.0
    a, b, c = p[: -2 * k], p[k:-k], p[2 * k :]
    ab, bc, ca = b - a, c - b, a - c
    cross = np.linalg.norm(np.cross(ab, bc), axis=1)
    la, lb, lc = (np.linalg.norm(v, axis=1) for v in (ab, bc, ca))
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(cross > 1e-12, la * lb * lc / (2.0 * cross), np.inf)
    j = int(np.argmin(r))
    return float(r[j]), float((j + k) * 0.25 * span_mm)


def reversals(points: np.ndarray, span_mm: float = 1.0, angle_deg: float = 150.0) -> list[float]:
    """Arclengths (mm) where the polyline's direction turns by more than ``angle_deg`` within
    ``span_mm`` (a cusp: the path goes back the way it came)."""
    p = resample(points, spacing=0.25 * span_mm)
    k = 4
    if len(p) < k + 2:
        return []
    t = np.diff(p, axis=0)
    t /= np.maximum(np.linalg.norm(t, axis=1), 1e-300)[:, None]
    cos = np.einsum("ij,ij->i", t[:-k], t[k:])
    idx = np.nonzero(cos < math.cos(math.radians(angle_deg)))[0]
    out: list[float] = []
    for j in idx:  # one arclength per cusp
        s = float((j + 0.5 * k) * 0.25 * span_mm)
        if not out or s - out[-1] > span_mm:
            out.append(s)
    return out


def self_contacts(
    points: np.ndarray, diameter_mm: float, min_separation_mm: float | None = None
) -> list[tuple[float, float, float]]:
    """Places where the polyline passes through itself: pairs of points further apart along
    the curve than ``min_separation_mm`` (default: 4 diameters, at least 1 mm) but closer in
    space than one filament ``diameter_mm`` (two strands there overlap). Returns
    (s_i, s_j, distance) in mm, at most one per 1 mm of s_i."""
    h = min(0.25 * diameter_mm, 0.1)
    p = resample(points, spacing=h)
    sep = max(4.0 * diameter_mm, 1.0) if min_separation_mm is None else min_separation_mm
    gap = int(math.ceil(sep / h))
    from scipy.spatial import cKDTree

    pairs = cKDTree(p).query_pairs(diameter_mm, output_type="ndarray")  # i < j, d <= diameter
    pairs = pairs[pairs[:, 1] - pairs[:, 0] >= gap]
    diff = p[pairs[:, 0]] - p[pairs[:, 1]]
    d2 = np.einsum("ij,ij->i", diff, diff)
    keep = d2 < diameter_mm**2
    pairs, d2 = pairs[keep], d2[keep]
    order = np.lexsort((pairs[:, 1], pairs[:, 0]))  # row by row, as a scan of i then j
    out: list[tuple[float, float, float]] = []
    for (i, j), dd in zip(pairs[order], d2[order], strict=True):
        s_i = float(i) * h
        if not out or s_i - out[-1][0] > 1.0:
            out.append((s_i, float(j) * h, float(math.sqrt(dd))))
    return out


def bend(
    points: np.ndarray, angle_deg: float, axis: Sequence[float] = (0.0, 0.0, 1.0)
) -> np.ndarray:
    """The polyline bent by ``angle_deg`` over its length: each segment's direction turned
    about ``axis`` by the angle times the fraction of the length before it, and the segments
    laid end to end again (same length; a test of whole-shape metrics)."""
    p = np.asarray(points, float)
    s = arclength(p)
    seg = np.diff(p, axis=0)
    theta = np.radians(angle_deg) * (0.5 * (s[:-1] + s[1:]) / s[-1])
    k = np.asarray(axis, float) / np.linalg.norm(axis)
    c, sn = np.cos(theta)[:, None], np.sin(theta)[:, None]
    rot = seg * c + np.cross(k, seg) * sn + k * (seg @ k)[:, None] * (1.0 - c)
    return np.concatenate([p[:1], p[0] + np.cumsum(rot, axis=0)])


def place_in_box(
    points: np.ndarray, start_xy: Sequence[float], box_mm: np.ndarray, step_deg: float = 15.0
) -> np.ndarray:
    """A flat shape's horizontal path (N, 2) moved to start at ``start_xy`` and turned about
    that point (by a multiple of ``step_deg``) to keep the largest margin inside the
    horizontal box ``box_mm`` ([[x_lo, x_hi], [y_lo, y_hi], ...] mm). The floor family's
    rigid motions (rotation about the vertical, translation) leave the shape unchanged, so a
    writer may place it where the needle can follow it. Ties keep the smaller angle."""
    p = np.asarray(points, float)[:, :2]
    p = p - p[0]
    box = np.asarray(box_mm, float)[:2]
    start = np.asarray(start_xy, float)[:2]
    best_margin, best = -math.inf, p + start
    for angle in np.radians(np.arange(0.0, 360.0, step_deg)):
        c, s = math.cos(angle), math.sin(angle)
        q = p @ np.array([[c, s], [-s, c]]) + start
        margin = min(float((q - box[:, 0]).min()), float((box[:, 1] - q).min()))
        if margin > best_margin + 1e-9:
            best_margin, best = margin, q
    return best

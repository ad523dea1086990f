"""Shape measurements of a simulated filament, defined as in the paper's Fig. 2 insets.

Conventions: a *frame* is an (n, 3) array of node positions (m), z up, free end (oldest
material) in row 0 and the needle tip in the LAST row. ``needle_pos`` (m) and the unit
``needle_dir`` (usually (0, 0, -1), the extrusion direction) define the *needle axis*.
Below, "depth" is the axial coordinate ``(x - needle_pos) . needle_dir`` (m, positive
below the needle) and "lateral distance" the distance from the needle axis (m). Curves are
walked from the needle tip towards the free end ("tip-first").

Quantities (all plain floats in SI units or ``None`` when undefined):

- buckling length l (:func:`buckling_length`): depth (or arclength) from the needle tip to
  the first point where the lateral distance exceeds a threshold: the straight part below
  the needle before the first coil.
- coil radius R, coil spacing Lambda (:func:`coil_geometry`, :func:`coil_radius`,
  :func:`coil_pitch`): the part of the filament past the departure point is split into
  full turns by the turning angle of its projection onto the plane normal to the coil
  axis; after trimming irregular end turns (stem transition, unravelling free end) R is
  the median of the per-turn circle fits and Lambda the mean axial advance per turn.
- coiling frequency omega (:func:`coil_frequency`): angular speed (rad/s) of the point at
  a fixed arclength below the needle (just past l) around the needle axis, or 2 pi v /
  (arclength per turn) when the frames cannot resolve the rotation.
- curvature variance (:func:`curvature_variance`): population variance of the discrete
  centreline curvature (1/m^2).
- plume opening angle theta (:func:`plume_angle`): full opening angle (rad) of the cone
  fitted to the lateral envelope of the filament vs depth.
- other definitions of l (:func:`buckling_length_definitions`): where the filament first
  departs from the needle axis by one diameter 2r, by a quarter of its largest excursion,
  and where the coil reaches its full radius (0.9 R); omega in Hz besides rad/s, and the
  kinematic check omega R / v (about 1 for a helix laid on a slow stack; the paper's fits
  give 0.44).
- self-contact (:func:`min_gap_ratio`): the smallest distance between non-adjacent
  segments over the frames, in contact distances 2r (below 1 the tubes overlap).
- regime (:func:`classify_regime`) and everything at once (:func:`measure_all`).

Nothing here raises on odd input (too few nodes, NaN rows, degenerate geometry): the
public functions return ``None`` (or ``"straight"``) for what cannot be measured.
"""

from __future__ import annotations

import functools
import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal, TypeVar

import numpy as np
from numba import njit

from bathprint.core.effects._segment_geometry import segment_distance

__all__ = [
    "REGIMES",
    "MEASURE_KEYS",
    "CoilGeometry",
    "buckling_length",
    "coil_geometry",
    "coil_radius",
    "coil_pitch",
    "coil_frequency",
    "curvature_variance",
    "plume_angle",
    "classify_regime",
    "measure_all",
    "buckling_length_definitions",
    "min_gap_ratio",
]

REGIMES = ("straight", "rope_coiling", "drag_coiling", "period_doubling", "chaotic_crumpling")
MEASURE_KEYS = (
    "regime",
    "buckling_length_m",
    "coil_radius_m",
    "coil_pitch_m",
    "coil_frequency_rad_s",
    "curvature_variance_1_m2",
    "plume_opening_angle_rad",
    "buckling_length_2r_m",
    "buckling_length_quarter_m",
    "buckling_length_full_radius_m",
    "coil_frequency_hz",
    "omega_r_over_v",
    "min_gap_ratio",
)

# Classification / measurement constants (documented in classify_regime).
DEPARTURE_REL = 0.25  # departure threshold as a fraction of the max lateral distance
STRAIGHT_SAGITTA = 0.05  # max distance from the end-to-end chord / chord length
STRAIGHT_TORTUOSITY = 1.1  # coarse arclength / chord length
ROPE_HEIGHT_FRAC = 0.5  # rope coiling: departure in the lower half of the fall height
MIN_TURNS = 2  # full turns needed to judge regularity
COHERENCE_MIN = 0.8  # |net turning| / total turning (smoothed over 1/8 turn)
ROUGHNESS_MAX = 1.0  # var(kappa) * R^2 above which the coil is "rough"
CV_MAX = 0.3  # robust coefficient of variation of per-turn radius / pitch
PD_ALTERNATION = 0.75  # fraction of successive pitch differences that change sign
PD_AMPLITUDE = 0.1  # |mean(even turns) - mean(odd turns)| / mean pitch
N_VOTE = 5  # classify_regime: majority over the last N_VOTE frames
GROWTH_RTOL = 1e-9  # relative arclength growth over the frame window below which nothing grows
ROUNDOFF_RTOL = 1e-9  # lengths below this fraction of their scale (R, extent) are round-off
FULL_RADIUS_FRACTION = 0.9  # "full radius": the lateral distance first reaches this x R
GAP_RATIO_CAP = 2.0  # min_gap_ratio searches pairs within this many contact distances

_DOWN = np.array([0.0, 0.0, -1.0])
_T = TypeVar("_T")


def _never_raise(default: Callable[[], Any]) -> Callable[[Callable[..., _T]], Callable[..., _T]]:
    """Decorator: silence numpy's floating-point errors and all warnings (np.polyfit's
    RankWarning among them) and return ``default()`` instead of raising."""

    def deco(fn: Callable[..., _T]) -> Callable[..., _T]:
        @functools.wraps(fn)
        def wrapper(*args: Any, **kwargs: Any) -> _T:
            try:
                with np.errstate(all="ignore"), warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    return fn(*args, **kwargs)
            except Exception:  # noqa: BLE001 - measurements must never break a run
                return default()

        return wrapper

    return deco


# --------------------------------------------------------------------------- helpers


def _frame(frame: Any) -> np.ndarray | None:
    """(n, 3) float array with non-finite rows dropped, or None."""
    try:
        a = np.asarray(frame, dtype=float)
    except (TypeError, ValueError):
        return None
    if a.ndim == 1 and a.size == 3:
        a = a.reshape(1, 3)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] == 0:
        return None
    a = a[np.isfinite(a).all(axis=1)]
    return a if len(a) else None


def _unit(v: Any, default: np.ndarray = _DOWN) -> np.ndarray:
    try:
        a = np.asarray(v, dtype=float).reshape(3)
    except (TypeError, ValueError):
        return default.copy()
    n = float(np.linalg.norm(a))
    if not np.isfinite(n) or n < 1e-300:
        return default.copy()
    return a / n


def _origin(needle_pos: Any, frame: np.ndarray) -> np.ndarray:
    try:
        o = np.asarray(needle_pos, dtype=float).reshape(3)
        if np.isfinite(o).all():
            return o
    except (TypeError, ValueError):
        pass
    return frame[-1].copy()


def _float(x: Any) -> float | None:
    """Plain finite float or None."""
    try:
        f = float(x)
    except (TypeError, ValueError):
        return None
    return f if math.isfinite(f) else None


def _arclength(p: np.ndarray) -> np.ndarray:
    if len(p) < 2:
        return np.zeros(len(p))
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))])


def _axial(p: np.ndarray, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Depth along the needle axis and lateral distance from it (m)."""
    rel = p - o
    a = rel @ d
    rho = np.linalg.norm(rel - a[:, None] * d, axis=1)
    return a, rho


def _perp_basis(axis: np.ndarray) -> np.ndarray:
    """(3, 2) orthonormal basis of the plane normal to ``axis``."""
    ref = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(axis, ref)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    return np.column_stack([e1, e2])


def _robust_cv(x: Sequence[float], atol: float = 0.0) -> float:
    """1.4826 * MAD / |median|: 0 when the scaled MAD is <= ``atol`` (no scatter), inf when
    only the median is (scatter about nothing). ``atol`` (same units as x) is the size
    below which a value is round-off: a flat coil's per-turn pitches are ~1e-16 R of either
    sign, so with exact comparisons its CV would be 0, O(1) or inf by chance."""
    a = np.asarray(x, dtype=float)
    med = float(np.median(a))
    mad = 1.4826 * float(np.median(np.abs(a - med)))
    if mad <= atol:
        return 0.0
    if abs(med) <= atol:
        return math.inf
    return mad / abs(med)


def _circle_fit(xy: np.ndarray) -> tuple[np.ndarray, float] | None:
    """Algebraic (Kasa) least-squares circle: centre (2,), radius (m)."""
    if len(xy) < 3:
        return None
    c0 = xy.mean(axis=0)
    x, y = (xy - c0).T
    A = np.column_stack([x, y, np.ones_like(x)])
    sol, *_ = np.linalg.lstsq(A, x * x + y * y, rcond=None)
    cx, cy = 0.5 * sol[0], 0.5 * sol[1]
    r2 = sol[2] + cx * cx + cy * cy
    if not np.isfinite(r2) or r2 <= 0:
        return None
    return c0 + np.array([cx, cy]), float(np.sqrt(r2))


def _departure(
    p: np.ndarray, o: np.ndarray, d: np.ndarray, threshold: float | None, rel: float
) -> tuple[int, float] | None:
    """First tip-first crossing of the lateral threshold: (node index i, fraction t in
    [0, 1] from node i-1 to i), or None if the filament never departs."""
    if len(p) < 2:
        return None
    _, rho = _axial(p, o, d)
    rmax = float(rho.max())
    scale = float(np.ptp(p, axis=0).max()) + float(np.linalg.norm(p[0] - o))
    if rmax <= 1e-9 * scale:
        return None
    thr = _float(threshold)
    if thr is None or thr <= 0:
        thr = rel * rmax
    idx = np.flatnonzero(rho > thr)
    if idx.size == 0:
        return None
    i = int(idx[0])
    if i == 0:
        return 0, 1.0
    t = (thr - rho[i - 1]) / (rho[i] - rho[i - 1])
    return i, float(np.clip(t, 0.0, 1.0))


def _interp_at(values: np.ndarray, i: int, t: float) -> Any:
    return values[i] if i == 0 else values[i - 1] + t * (values[i] - values[i - 1])


def _resample(p: np.ndarray, step: float) -> np.ndarray:
    """Points at uniform arclength ``step`` (m) along the polyline p."""
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    p = np.vstack([p[:1], p[1:][seg > 0]])
    s = _arclength(p)
    if len(p) < 2 or s[-1] <= 0:
        return p[:1]
    step = max(step, s[-1] / 200_000)
    grid = np.arange(int(np.floor(s[-1] / step)) + 1) * step
    return np.column_stack([np.interp(grid, s, p[:, k]) for k in range(3)])


def _curvatures(p: np.ndarray, step: float | None = None) -> np.ndarray:
    """Discrete curvature (1/m) at interior nodes: turning angle between the adjacent
    edges over the mean adjacent edge length. Resampled at ``step`` when that is coarser
    than 1.5x the median edge."""
    if len(p) < 3:
        return np.zeros(0)
    seg = np.linalg.norm(np.diff(p, axis=0), axis=1)
    if step is not None and step > 1.5 * float(np.median(seg)):
        p = _resample(p, step)
    e = np.diff(p, axis=0)
    L = np.linalg.norm(e, axis=1)
    keep = L > 1e-12 * max(float(L.max(initial=0.0)), 1e-300)
    e, L = e[keep], L[keep]
    if len(e) < 2:
        return np.zeros(0)
    c = np.linalg.norm(np.cross(e[:-1], e[1:]), axis=1)
    dot = np.einsum("ij,ij->i", e[:-1], e[1:])
    return np.arctan2(c, dot) / (0.5 * (L[:-1] + L[1:]))


# --------------------------------------------------------------------------- coils


@dataclass(frozen=True)
class CoilGeometry:
    """Turn-by-turn description of the coiled part of one frame.

    ``axis``: unit coil axis (oriented with the needle direction when not nearly horizontal,
    else with the net advance from the tip end, else by a fixed convention);
    ``turns``: |net turning| of the projected curve / 2 pi; ``coherence``: |net turning| /
    total absolute turning, smoothed over ~1/8 turn (1 for a helix, ~0 for a random walk).
    Per full turn, in tip-to-free-end order, with the first (stem-to-coil transition) turn
    dropped when at least 3 full turns exist: ``radii`` (m, circle fit), ``pitches`` (m,
    signed axial advance along ``axis``), ``turn_lengths`` (m, arclength per turn).
    ``core`` = (start, stop): the turns left after trimming, from both ends of the list,
    turns whose radius or pitch is an outlier (> max(3 x 1.4826 MAD, 5 % of the median;
    for the pitch also 1 % of the median radius) from the median): the stem transition and
    the unravelling free end. R and Lambda are measured on the core turns.
    """

    axis: tuple[float, float, float]
    turns: float
    coherence: float
    radii: tuple[float, ...]
    pitches: tuple[float, ...]
    turn_lengths: tuple[float, ...]
    core: tuple[int, int] = (0, 0)

    @property
    def full_turns(self) -> int:
        return len(self.radii)

    @property
    def core_radii(self) -> tuple[float, ...]:
        return self.radii[self.core[0] : self.core[1]]

    @property
    def core_pitches(self) -> tuple[float, ...]:
        return self.pitches[self.core[0] : self.core[1]]

    @property
    def core_turn_lengths(self) -> tuple[float, ...]:
        return self.turn_lengths[self.core[0] : self.core[1]]

    @property
    def radius(self) -> float | None:
        """R: median of the core per-turn radii (m)."""
        r = self.core_radii
        return _float(np.median(r)) if r else None

    @property
    def pitch(self) -> float | None:
        """Lambda: |mean of the core per-turn pitches| (m) = axial advance per turn."""
        p = self.core_pitches
        return _float(abs(np.mean(p))) if p else None


def _core_turns(radii: Sequence[float], pitches: Sequence[float]) -> tuple[int, int]:
    """(start, stop) of the turns left after trimming outlier turns from both ends."""
    n = len(radii)
    if n == 0:
        return 0, 0
    r, p = np.asarray(radii, dtype=float), np.asarray(pitches, dtype=float)
    r_med, p_med = float(np.median(r)), float(np.median(p))
    r_tol = max(3 * 1.4826 * float(np.median(np.abs(r - r_med))), 0.05 * abs(r_med))
    p_tol = max(
        3 * 1.4826 * float(np.median(np.abs(p - p_med))), 0.05 * abs(p_med), 0.01 * abs(r_med)
    )
    ok = (np.abs(r - r_med) <= r_tol) & (np.abs(p - p_med) <= p_tol)
    start, stop = 0, n
    while start < n and not ok[start]:
        start += 1
    while stop > start and not ok[stop - 1]:
        stop -= 1
    return start, stop


def _axis_sign(axis: np.ndarray, q: np.ndarray, prefer: np.ndarray) -> float:
    """+1 or -1: orient the coil axis with ``prefer`` (the needle direction) unless it is
    nearly horizontal, then with the tip-to-free-end advance of q, and when that is
    round-off (a flat coil standing on edge) by the first of its components along
    ``prefer`` and the fixed basis normal to it that is not round-off: neither the sign of
    an eigenvector nor one of round-off decides it."""
    c = float(axis @ prefer)
    if abs(c) > 0.3:
        return math.copysign(1.0, c)
    advance = float((q[-1] - q[0]) @ axis)
    if abs(advance) > ROUNDOFF_RTOL * float(np.ptp(q, axis=0).max()):
        return math.copysign(1.0, advance)
    for x in (c, *(axis @ _perp_basis(prefer))):
        if abs(x) > ROUNDOFF_RTOL:
            return math.copysign(1.0, float(x))
    return 1.0


def _analyse_coils(q: np.ndarray, prefer: np.ndarray) -> CoilGeometry | None:
    """Coil analysis of the tip-first polyline q (see :class:`CoilGeometry`)."""
    if len(q) < 4:
        return None
    e = np.diff(q, axis=0)
    L = np.linalg.norm(e, axis=1)
    ok = L > 1e-12 * max(float(L.max()), 1e-300)
    if ok.sum() < 3:
        return None
    # Coil axis: the net turning vector sum(t_i x t_i+1) (straight parts add nothing; for
    # whole turns of a helix the components normal to its axis cancel). If the turning is
    # incoherent, the least-variance direction of the unit tangents instead.
    t = e[ok] / L[ok, None]
    cr = np.cross(t[:-1], t[1:])
    net = cr.sum(axis=0)
    if np.linalg.norm(net) > 0.2 * np.linalg.norm(cr, axis=1).sum():
        axis = net / np.linalg.norm(net)
    else:
        _, vecs = np.linalg.eigh(np.cov(t.T))
        axis = vecs[:, 0] / np.linalg.norm(vecs[:, 0])
    axis = axis * _axis_sign(axis, q, prefer)

    u = q @ _perp_basis(axis)
    h = q @ axis
    s = _arclength(q)
    du = np.diff(u, axis=0)
    pl = np.linalg.norm(du, axis=1)
    # Edges steeper than ~78 deg to the coil plane have ill-defined projected directions.
    K = np.flatnonzero((pl > 0.2 * L) & (pl > 1e-12 * max(float(pl.max()), 1e-300)))
    if len(K) < 3:
        return None
    a, b = du[K[:-1]], du[K[1:]]
    dpsi = np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], np.einsum("ij,ij->i", a, b))
    psi = np.concatenate([[0.0], np.cumsum(dpsi)])
    total = float(psi[-1])
    n_turn_f = abs(total) / (2 * np.pi)
    w = max(1, round(len(dpsi) / (8 * max(1.0, n_turn_f))))
    win = np.add.reduceat(dpsi, np.arange(0, len(dpsi), w))
    coherence = abs(total) / max(float(np.abs(win).sum()), 1e-300)

    # Full turns: first crossings of 2 pi k by the (sign-corrected) turning angle.
    pos_psi = psi * (1.0 if total >= 0 else -1.0)
    n_full = int(np.floor(n_turn_f + 1e-9))
    run_max = np.maximum.accumulate(pos_psi)
    hm = 0.5 * (h[K] + h[K + 1])
    sm = 0.5 * (s[K] + s[K + 1])
    bounds = []
    for k in range(n_full + 1):
        target = 2 * np.pi * k
        j = int(np.searchsorted(run_max, target - 1e-12, side="left"))
        if j >= len(pos_psi):
            break
        if j == 0:
            bounds.append(0.0)
        else:
            den = pos_psi[j] - pos_psi[j - 1]
            bounds.append(j - 1 + (float(np.clip((target - pos_psi[j - 1]) / den, 0, 1))))
    idx = np.arange(len(K), dtype=float)
    radii, pitches, lengths = [], [], []
    for k in range(len(bounds) - 1):
        b0, b1 = bounds[k], bounds[k + 1]
        # Nodes of the turn; a bound within round-off of a node counts as on it (one node
        # more or less would otherwise be fitted by chance).
        lo, hi = K[int(np.floor(b0 + 1e-9))], K[min(int(np.ceil(b1 - 1e-9)), len(K) - 1)] + 1
        fit = _circle_fit(u[lo : hi + 1])
        seg_len = float(np.interp(b1, idx, sm) - np.interp(b0, idx, sm))
        radius = fit[1] if fit is not None else float(pl[lo:hi].sum()) / (2 * np.pi)
        radii.append(radius)
        pitches.append(float(np.interp(b1, idx, hm) - np.interp(b0, idx, hm)))
        lengths.append(seg_len)
    if len(radii) >= 3:
        radii, pitches, lengths = radii[1:], pitches[1:], lengths[1:]
    return CoilGeometry(
        axis=(float(axis[0]), float(axis[1]), float(axis[2])),
        turns=float(n_turn_f),
        coherence=float(coherence),
        radii=tuple(radii),
        pitches=tuple(pitches),
        turn_lengths=tuple(lengths),
        core=_core_turns(radii, pitches),
    )


def _floor_tol(o: np.ndarray, z_floor: float, radius: float | None, tol: float | None) -> float:
    t = _float(tol)
    if t is not None and t > 0:
        return t
    return max(2.5 * (_float(radius) or 0.0), 0.01 * abs(float(o[2]) - z_floor))


def _coiled_part(
    p: np.ndarray,
    o: np.ndarray,
    d: np.ndarray,
    threshold: float | None,
    z_floor: float | None,
    floor_tol: float | None,
) -> np.ndarray | None:
    """Tip-first nodes from the departure point on (up to the first floor contact when
    z_floor is given)."""
    dep = _departure(p, o, d, threshold, DEPARTURE_REL)
    if dep is None:
        return None
    q = p[max(dep[0] - 1, 0) :]
    zf = _float(z_floor)
    if zf is not None:
        contact = np.flatnonzero(q[:, 2] - zf <= _floor_tol(o, zf, None, floor_tol))
        if contact.size:
            q = q[: contact[0]]
    return q


@_never_raise(lambda: None)
def coil_geometry(
    frame: np.ndarray,
    needle_pos: Any = None,
    needle_dir: Any = None,
    threshold: float | None = None,
    z_floor: float | None = None,
    floor_tol: float | None = None,
) -> CoilGeometry | None:
    """Turn-by-turn coil geometry of the part past the departure point (see
    :func:`buckling_length` for ``threshold``).

    Coil axis: direction of the net turning vector sum(t_i x t_i+1) of the unit edge
    tangents of that part (straight parts add nothing); if that is incoherent (< 0.2 of
    sum |t_i x t_i+1|), the least-variance direction of the tangents. The projection onto
    the plane normal to the axis is unwrapped by the turning angle of the projected tangent
    (centre-free, so robust to a drifting stack; edges steeper than ~78 deg to the plane
    are skipped); each 2 pi of turning is one turn.
    Per turn: radius = Kasa circle fit of the projected nodes, pitch = axial advance. When
    ``z_floor`` (m) is given, material from the first node within ``floor_tol`` (m) of the
    floor onwards is excluded (the pile on the floor). None if fewer than 4 nodes remain.
    """
    f = _frame(frame)
    if f is None or len(f) < 4:
        return None
    d, o = _unit(needle_dir), _origin(needle_pos, f)
    q = _coiled_part(f[::-1], o, d, threshold, z_floor, floor_tol)
    return None if q is None else _analyse_coils(q, d)


@_never_raise(lambda: None)
def coil_radius(
    frame: np.ndarray,
    needle_pos: Any = None,
    needle_dir: Any = None,
    threshold: float | None = None,
    z_floor: float | None = None,
) -> float | None:
    """Coil radius R (m): median over the core full turns of a circle fitted to each turn
    projected onto the plane normal to the coil axis (:func:`coil_geometry`). None without
    a full turn."""
    g = coil_geometry(frame, needle_pos, needle_dir, threshold, z_floor)
    return None if g is None else g.radius


@_never_raise(lambda: (None, []))
def coil_pitch(
    frame: np.ndarray,
    needle_pos: Any = None,
    needle_dir: Any = None,
    threshold: float | None = None,
    z_floor: float | None = None,
) -> tuple[float | None, list[float]]:
    """Coil spacing Lambda (m) and the per-turn axial advances (m, tip to free end).

    Lambda = |mean per-turn advance along the coil axis| over the core full turns, each
    turn being 2 pi of turning of the projected curve (:func:`coil_geometry`); the list
    holds those core turns' signed advances. (None, []) without a full turn.
    """
    g = coil_geometry(frame, needle_pos, needle_dir, threshold, z_floor)
    if g is None:
        return None, []
    return g.pitch, [float(x) for x in g.core_pitches]


# --------------------------------------------------------------------------- scalars


@_never_raise(lambda: None)
def buckling_length(
    frame: np.ndarray,
    needle_pos: Any = None,
    needle_dir: Any = None,
    threshold: float | None = None,
    *,
    rel_threshold: float = DEPARTURE_REL,
    along: Literal["axial", "arclength"] = "axial",
) -> float | None:
    """Buckling length l (m): the straight part below the needle before the first coil.

    Walking from the needle tip, the departure point is the first point (linearly
    interpolated between nodes) whose distance from the needle axis exceeds ``threshold``
    (m; default ``rel_threshold`` x the largest lateral distance of the frame). l is its
    depth along the needle axis (``along="axial"``, as read off a side view) or the
    arclength from the tip to it (``along="arclength"``). None if the filament never
    leaves the axis (straight) or the frame has < 2 nodes.
    """
    f = _frame(frame)
    if f is None or len(f) < 2:
        return None
    d, o = _unit(needle_dir), _origin(needle_pos, f)
    p = f[::-1]
    dep = _departure(p, o, d, threshold, rel_threshold)
    if dep is None:
        return None
    i, t = dep
    if along == "arclength":
        return _float(_interp_at(_arclength(p), i, t))
    a, _ = _axial(p, o, d)
    return _float(max(float(_interp_at(a, i, t)), 0.0))


@_never_raise(lambda: None)
def curvature_variance(frame: np.ndarray, spacing: float | None = None) -> float | None:
    """Variance (population, 1/m^2) of the discrete centreline curvature of the frame.

    kappa_i = turning angle between the two edges at node i / mean length of those edges,
    over the interior nodes. If ``spacing`` (m) exceeds 1.5x the median edge length the
    centreline is first resampled at that arclength step (curvature at a coarser scale);
    otherwise the nodes are used as they are. None with fewer than 3 usable nodes.
    """
    f = _frame(frame)
    if f is None:
        return None
    k = _curvatures(f, _float(spacing))
    return _float(np.var(k)) if k.size else None


@_never_raise(lambda: None)
def plume_angle(
    frame: np.ndarray,
    needle_pos: Any = None,
    needle_dir: Any = None,
    *,
    quantile: float = 0.95,
    start_depth: float = 0.0,
    n_bins: int | None = None,
) -> float | None:
    """Full opening angle theta (rad) of the cone holding the filament below the needle.

    Nodes deeper than ``start_depth`` (m) are binned by depth (``n_bins``, default
    n/20 clipped to [3, 30]); the envelope in each bin is the ``quantile`` of the lateral
    distance from the needle axis; a straight line rho = c + a tan(theta/2) is fitted to
    envelope vs bin-centre depth (the intercept lets the apex sit off the needle tip) and
    theta = 2 atan(max(slope, 0)). Measured about the needle axis. None with < 3 nodes,
    nodes all at one depth (to 1e-9 of their distance from the needle) or < 2 populated bins.
    """
    f = _frame(frame)
    if f is None or len(f) < 3:
        return None
    d, o = _unit(needle_dir), _origin(needle_pos, f)
    a, rho = _axial(f, o, d)
    m = a > max(_float(start_depth) or 0.0, 0.0)
    a, rho = a[m], rho[m]
    # All at one depth (a pile on a plane normal to the needle): the spread of a is then
    # round-off, ~1e-17 m with a tilted needle and 0 with an axis-aligned one.
    if len(a) < 3 or np.ptp(a) <= ROUNDOFF_RTOL * max(float(np.abs(a).max()), float(rho.max())):
        return None
    nb = int(n_bins) if n_bins else int(np.clip(len(a) // 20, 3, 30))
    edges = np.linspace(a.min(), a.max(), nb + 1)
    which = np.clip(np.searchsorted(edges, a, side="right") - 1, 0, nb - 1)
    xs, ys = [], []
    for b in range(nb):
        sel = which == b
        if sel.any():
            xs.append(0.5 * (edges[b] + edges[b + 1]))
            ys.append(float(np.quantile(rho[sel], quantile)))
    if len(xs) < 2:
        return None
    slope = float(np.polyfit(xs, ys, 1)[0])
    return _float(2.0 * math.atan(max(slope, 0.0)))


def _valid_frames(frames: Any, times: Any) -> tuple[list[np.ndarray], np.ndarray | None]:
    """Valid frames and their times (None if times are missing or inconsistent)."""
    try:
        raw = list(frames)
    except TypeError:
        return [], None
    fr = [_frame(f) for f in raw]
    tt: np.ndarray | None
    try:
        tt = np.asarray(times, dtype=float).ravel()
        if len(tt) != len(raw):
            tt = None
    except (TypeError, ValueError):
        tt = None
    keep = [i for i, f in enumerate(fr) if f is not None]
    good = [fr[i] for i in keep]
    return good, (tt[keep] if tt is not None else None)


@_never_raise(lambda: None)
def coil_frequency(
    frames: Sequence[np.ndarray],
    times: Any,
    needle_pos: Any = None,
    needle_dir: Any = None,
    *,
    probe_arclength: float | None = None,
    v: float | None = None,
    threshold: float | None = None,
    method: Literal["auto", "track", "turns"] = "auto",
) -> float | None:
    """Coiling frequency omega (rad/s, >= 0).

    ``"track"`` (the paper's definition): the probe is the point at fixed arclength
    ``probe_arclength`` (m) from the needle tip (default: arclength to the departure point
    of the last frame + R/2, or 1.25 x that arclength without a coil radius), i.e. just past
    the buckling length. Its projection onto the plane normal to the needle axis is
    followed over the frames; a circle is fitted to that trajectory, the polar angle about
    its centre is unwrapped and omega = |slope| of a least-squares line angle(time). Needs
    >= 3 frames; rejected if the median angle step between frames exceeds pi/2.
    ``"turns"``: omega = 2 pi v / (median arclength per core coil turn of the last frame),
    the rate at which coils are laid down at exit speed ``v`` (m/s; if not given, the
    growth rate of the filament's length over the last <= 10 frames).
    ``"auto"``: the tracked value, unless it is missing or differs from the turns value by
    more than 25 % (frames too sparse: a rotation of 2 pi k + x per frame looks like x),
    in which case the turns value.
    """
    fr, tt = _valid_frames(frames, times)
    if not fr:
        return None
    last = fr[-1]
    d, o = _unit(needle_dir), _origin(needle_pos, last)
    tracked: float | None = None
    if method in ("auto", "track") and tt is not None and len(fr) >= 3:
        s_probe = _float(probe_arclength)
        if s_probe is None:
            s_dep = buckling_length(last, o, d, threshold, along="arclength")
            r = coil_radius(last, o, d, threshold)
            if s_dep is not None:
                s_probe = s_dep + 0.5 * r if r else 1.25 * s_dep
        if s_probe is not None and s_probe > 0:
            tracked = _track_probe(fr, tt, o, d, s_probe)
    if method == "track":
        return _float(tracked)
    turns: float | None = None
    speed = abs(_float(v) or 0.0) or (_length_rate(fr, tt) if tt is not None else None)
    if speed:
        g = coil_geometry(last, o, d, threshold)
        if g is not None and g.core_turn_lengths:
            s_turn = float(np.median(g.core_turn_lengths))
            if s_turn > 0:
                turns = 2 * np.pi * speed / s_turn
    if method == "turns" or tracked is None:
        return _float(turns)
    if turns is not None and abs(tracked - turns) > 0.25 * turns:
        return _float(turns)
    return _float(tracked)


def _length_rate(frames: list[np.ndarray], times: np.ndarray, n: int = 10) -> float | None:
    """Growth rate (m/s) of the filament's arclength over the last <= n frames, or None if
    it does not grow: a fitted growth over the window below ``GROWTH_RTOL`` of the length
    is round-off (a constant length fits to a slope of ~1e-18 m/s of either sign, the sign
    depending on the CPU's BLAS), not extrusion."""
    t = np.asarray(times[-n:], dtype=float)
    lengths = np.array([_arclength(f)[-1] if len(f) > 1 else 0.0 for f in frames[-n:]])
    ok = np.isfinite(t)
    if ok.sum() < 2:
        return None
    span = float(np.ptp(t[ok]))
    scale = float(np.max(np.abs(lengths[ok])))
    if span <= 0.0 or scale <= 0.0:
        return None
    rate = float(np.polyfit(t[ok], lengths[ok], 1)[0])
    return rate if rate * span > GROWTH_RTOL * scale else None


def _track_probe(
    frames: list[np.ndarray], times: np.ndarray, o: np.ndarray, d: np.ndarray, s_probe: float
) -> float | None:
    basis = _perp_basis(d)
    ts, xy = [], []
    for f, t in zip(frames, times, strict=True):
        if not np.isfinite(t) or len(f) < 2:
            continue
        p = f[::-1]
        s = _arclength(p)
        if s[-1] < s_probe:
            continue
        x = np.array([np.interp(s_probe, s, p[:, k]) for k in range(3)])
        ts.append(float(t))
        xy.append((x - o) @ basis)
    if len(ts) < 3:
        return None
    order = np.argsort(ts)
    ts_a, xy_a = np.asarray(ts)[order], np.asarray(xy)[order]
    if np.ptp(ts_a) <= 0:
        return None
    fit = _circle_fit(xy_a)
    spread = float(np.ptp(xy_a, axis=0).max())
    centre = xy_a.mean(axis=0)
    if fit is not None and fit[1] < 1e3 * max(spread, 1e-300):
        centre = fit[0]
    rel = xy_a - centre
    if float(np.linalg.norm(rel, axis=1).max()) <= 1e-12 * (s_probe + spread):
        return None
    ang = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    if float(np.median(np.abs(np.diff(ang)))) > 0.5 * np.pi:
        return None  # < 4 frames per turn: the angle is likely aliased
    return abs(float(np.polyfit(ts_a, ang, 1)[0]))


# --------------------------------------------------------------------------- definitions


@_never_raise(lambda: dict.fromkeys(("two_radii", "quarter", "full_radius"), None))
def buckling_length_definitions(
    frame: np.ndarray,
    needle_pos: Any = None,
    needle_dir: Any = None,
    *,
    radius: float | None = None,
    coil_radius: float | None = None,
) -> dict[str, float | None]:
    """The buckling length l (m, depth along the needle axis) under three definitions, each
    the first tip-first point whose lateral distance from the needle axis exceeds a threshold:

    - ``two_radii``: one filament diameter, 2 ``radius`` (the first visible departure);
    - ``quarter``: a quarter of the frame's largest lateral distance;
    - ``full_radius``: ``FULL_RADIUS_FRACTION`` (0.9) x ``coil_radius`` R, where the coil
      has reached its full radius (0.9 rather than 1: per-turn radii scatter by a few
      percent, and a coil off the axis by c swings by +-c about R).

    A definition is None when its input is missing (``radius``, ``coil_radius``) or the
    filament never departs that far. :func:`buckling_length` with ``rel_threshold`` is the
    general form.
    """
    r = _float(radius)
    big_r = _float(coil_radius)
    return {
        "two_radii": buckling_length(frame, needle_pos, needle_dir, 2.0 * r)
        if r is not None and r > 0
        else None,
        "quarter": buckling_length(frame, needle_pos, needle_dir, None, rel_threshold=0.25),
        "full_radius": buckling_length(frame, needle_pos, needle_dir, FULL_RADIUS_FRACTION * big_r)
        if big_r is not None and big_r > 0
        else None,
    }


@njit(cache=True)
def _nearest_pair_distances(pos: np.ndarray, pairs: np.ndarray, out: np.ndarray) -> None:
    """out[i] = the smallest distance (m) from segment i to any segment it is paired with in
    ``pairs`` (rows (i, j)) of the flat positions; segments in no pair keep their value."""
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        d = segment_distance(pos, i, i + 1, j, j + 1)
        if d < out[i]:
            out[i] = d
        if d < out[j]:
            out[j] = d


def _segment_gaps(f: np.ndarray, delta: float) -> np.ndarray | None:
    """Per segment of one frame, the distance to its nearest non-adjacent segment / delta,
    capped at GAP_RATIO_CAP (pairs further apart are not searched); None for a frame of
    fewer than 4 nodes or with a zero-length segment."""
    from scipy.spatial import cKDTree

    from bathprint.core.effects.contact import min_separation_for

    if len(f) < 4:
        return None
    seg = np.linalg.norm(np.diff(f, axis=0), axis=1)
    if not np.all(seg > 0):
        return None
    min_sep = min_separation_for(delta, float(np.median(seg)))
    mid = 0.5 * (f[1:] + f[:-1])
    # two segments closer than c have midpoints closer than c + (l_i + l_j) / 2
    reach = GAP_RATIO_CAP * delta + float(seg.max())
    pairs = cKDTree(mid).query_pairs(reach, output_type="ndarray")
    gaps = np.full(len(seg), GAP_RATIO_CAP * delta)
    if len(pairs):
        pairs = pairs[np.abs(pairs[:, 1] - pairs[:, 0]) > min_sep]
        pos = np.ascontiguousarray(f, dtype=np.float64).ravel()
        _nearest_pair_distances(pos, pairs.astype(np.int64), gaps)
    return np.minimum(gaps / delta, GAP_RATIO_CAP)


def _frame_gap(f: np.ndarray, delta: float) -> float | None:
    """Smallest distance between non-adjacent segments of one frame / delta, capped at
    GAP_RATIO_CAP."""
    gaps = _segment_gaps(f, delta)
    return None if gaps is None else float(gaps.min())


TOUCHING_GAP_RATIO = 1.1  # touching_gaps counts the segments within this many 2r


@_never_raise(lambda: None)
def touching_gaps(frame: np.ndarray, radius: float | None) -> dict[str, float | int] | None:
    """How exactly one frame's touching segments hold the contact distance 2 ``radius`` (m):
    per segment, the distance to its nearest non-adjacent segment / 2r; over the segments
    closer than TOUCHING_GAP_RATIO (1.1), their number (``touching``), the smallest, the
    10th percentile and the median. A penalty lets loaded pairs sink below 1; a penalty
    whose onset starts before contact holds light ones above it. None without a radius,
    a frame of >= 4 nodes, or any touching segment."""
    r = _float(radius)
    if r is None or r <= 0:
        return None
    gaps = _segment_gaps(np.asarray(frame, dtype=float), 2.0 * r)
    if gaps is None:
        return None
    g = gaps[gaps < TOUCHING_GAP_RATIO]
    if not len(g):
        return None
    return {
        "touching": int(len(g)),
        "min": float(g.min()),
        "p10": float(np.percentile(g, 10)),
        "median": float(np.median(g)),
    }


@_never_raise(lambda: None)
def min_gap_ratio(frames: Sequence[np.ndarray], radius: float | None) -> float | None:
    """Smallest distance between non-adjacent segments over all frames, divided by the
    contact distance 2 ``radius`` (m): below 1 the two tubes overlap, near 0 the centrelines
    cross. Pairs closer along the filament than about pi r of arclength are adjacent
    (:func:`bathprint.core.effects.contact.min_separation_for`), so a straight filament
    gives about 1.6-1.8 (its nearest pair that is not adjacent) and a value there means no
    turn comes near another; it saturates at GAP_RATIO_CAP (2) when no pair comes within
    that. Segments are straight between the nodes, as in the contact effect. None without a
    radius or a frame of >= 4 nodes."""
    r = _float(radius)
    if r is None or r <= 0:
        return None
    fr, _ = _valid_frames(frames, None)
    gaps = [g for g in (_frame_gap(f, 2.0 * r) for f in fr) if g is not None]
    return _float(min(gaps)) if gaps else None


# --------------------------------------------------------------------------- regimes


def _is_straight(p: np.ndarray) -> bool:
    chord = p[-1] - p[0]
    cl = float(np.linalg.norm(chord))
    if cl <= 0:
        return float(_arclength(p)[-1]) <= 0
    sagitta = float(np.linalg.norm(np.cross(p - p[0], chord / cl), axis=1).max())
    stride = max(1, len(p) // 64)
    coarse = np.vstack([p[::stride], p[-1:]])
    tortuosity = float(_arclength(coarse)[-1]) / cl
    return sagitta <= STRAIGHT_SAGITTA * cl and tortuosity <= STRAIGHT_TORTUOSITY


def _alternates(pitches: Sequence[float], atol: float = 0.0) -> bool:
    """Period doubling of the per-turn pitches (m): see :func:`classify_regime`, step 5.
    Differences of at most ``atol`` (m) count as no change (they are round-off for a flat
    coil), and a mean |pitch| of at most ``atol`` has no alternation to measure."""
    p = np.asarray(pitches, dtype=float)
    if len(p) < 4:
        return False
    dp = np.diff(p)
    sg = np.sign(np.where(np.abs(dp) > atol, dp, 0.0))
    if np.mean(sg[1:] * sg[:-1] < 0) < PD_ALTERNATION:
        return False
    even, odd = p[0::2], p[1::2]
    amp = abs(float(even.mean() - odd.mean()))
    mean = float(np.abs(p).mean())
    scatter = 1.4826 * max(
        float(np.median(np.abs(even - np.median(even)))),
        float(np.median(np.abs(odd - np.median(odd)))),
    )
    return mean > atol and amp >= PD_AMPLITUDE * mean and scatter <= 0.5 * amp


def _label_coils(g: CoilGeometry | None, q: np.ndarray) -> str:
    if g is None:
        return "chaotic_crumpling"
    if g.full_turns < MIN_TURNS:
        return "drag_coiling" if g.coherence >= COHERENCE_MIN else "chaotic_crumpling"
    n_core = g.core[1] - g.core[0]
    if g.coherence < COHERENCE_MIN or n_core < max(MIN_TURNS, 0.5 * g.full_turns):
        return "chaotic_crumpling"
    r = g.radius
    if r is None or r <= 0:
        return "chaotic_crumpling"
    k = _curvatures(q, 0.25 * r)
    if k.size >= 3 and float(np.var(k)) * r * r > ROUGHNESS_MAX:
        return "chaotic_crumpling"
    atol = ROUNDOFF_RTOL * r
    if _robust_cv(g.core_radii, atol) > CV_MAX:
        return "chaotic_crumpling"
    if _alternates(g.core_pitches, atol):
        return "period_doubling"
    if _robust_cv(g.core_pitches, atol) <= CV_MAX:
        return "drag_coiling"
    return "chaotic_crumpling"


def _classify_frame(
    f: np.ndarray,
    o: np.ndarray,
    d: np.ndarray,
    radius: float | None,
    z_floor: float | None,
    floor_tol: float | None,
) -> str:
    p = f[::-1]
    if len(p) < 5 or _is_straight(p):
        return "straight"
    _, rho = _axial(p, o, d)
    thr = max(_float(radius) or 0.0, DEPARTURE_REL * float(rho.max()))
    dep = _departure(p, o, d, thr, DEPARTURE_REL)
    if dep is None:
        return "straight"
    i, t = dep
    below = p[max(i - 1, 0) :]
    zf = _float(z_floor)
    if zf is not None:
        tol = _floor_tol(o, zf, radius, floor_tol)
        height = float(o[2]) - zf
        touching = bool((p[:, 2] - zf <= tol).any())
        z_dep = float(_interp_at(p[:, 2], i, t))
        if touching and height > 0 and z_dep - zf <= ROPE_HEIGHT_FRAC * height:
            return "rope_coiling"
        contact = np.flatnonzero(below[:, 2] - zf <= tol)
        if contact.size:
            below = below[: contact[0]]
    return _label_coils(_analyse_coils(below, d), below)


@_never_raise(lambda: "straight")
def classify_regime(
    frames: Sequence[np.ndarray],
    times: Any = None,
    needle_pos: Any = None,
    needle_dir: Any = None,
    *,
    radius: float | None = None,
    z_floor: float | None = None,
    floor_tol: float | None = None,
    n_vote: int = N_VOTE,
) -> str:
    """Regime of the filament: one of :data:`REGIMES`.

    Each of the last ``n_vote`` frames is labelled; the majority wins (ties: the latest
    frame's label). ``times`` is accepted for symmetry and unused. Per frame (tip first):

    1. ``straight``: < 5 nodes, or the largest distance from the tip-to-free-end chord is
       <= 5 % of the chord and the coarse arclength (<= 64 chords) <= 1.1 x the chord.
    2. The departure point is where the lateral distance first exceeds
       max(``radius``, 0.25 x the largest lateral distance) (as in :func:`buckling_length`).
    3. ``rope_coiling`` (only with ``z_floor``): some node is within ``floor_tol`` of the
       floor (default max(2.5 ``radius``, 1 % of the needle height above the floor)) and
       the departure point lies in the lower half of the needle height above the floor
       (the filament is buckled by the floor, not above it). Otherwise material from the
       first floor contact on is ignored.
    4. The suspended part past the departure point is analysed turn by turn
       (:func:`coil_geometry`). Fewer than 2 full turns: ``drag_coiling`` (incipient coil)
       if the turning coherence >= 0.8, else ``chaotic_crumpling``. With >= 2 full turns
       it is ``chaotic_crumpling`` if the coherence < 0.8, or fewer than max(2, half of the
       full turns) are core (regular) turns, or var(kappa) R^2 > 1 (curvature at arclength
       step R/4 over the suspended part), or the robust CV (1.4826 MAD / median) of the
       core radii > 0.3.
    5. ``period_doubling``: >= 4 core turns, >= 75 % of successive core pitch differences
       change sign, |mean(even turns) - mean(odd turns)| >= 10 % of the mean pitch and the
       scatter (1.4826 MAD) within each parity <= half that difference.
    6. ``drag_coiling`` if the robust CV of the core pitches <= 0.3, else
       ``chaotic_crumpling``.

    In 4-6 lengths up to 1e-9 R are round-off (a flat coil's per-turn pitches are ~1e-16 R
    of a sign set by the CPU's BLAS): pitch differences that small are no change, a scatter
    that small is none (CV 0) and a median that small under a larger scatter gives CV inf.
    A flat regular coil is therefore ``drag_coiling`` with zero pitch.
    """
    fr, _ = _valid_frames(frames, times)
    if not fr:
        return "straight"
    d = _unit(needle_dir)
    n = max(1, int(n_vote))
    labels = [
        _classify_frame(f, _origin(needle_pos, f), d, radius, z_floor, floor_tol) for f in fr[-n:]
    ]
    counts = {lab: labels.count(lab) for lab in labels}
    best = max(counts.values())
    return next(lab for lab in reversed(labels) if counts[lab] == best)


@_never_raise(lambda: dict.fromkeys(MEASURE_KEYS, None) | {"regime": "straight"})
def measure_all(
    frames: Sequence[np.ndarray],
    times: Any,
    needle_pos: Any,
    needle_dir: Any,
    spacing: float | None,
    radius: float | None,
    z_floor: float | None = None,
    *,
    v: float | None = None,
) -> dict[str, str | float | None]:
    """All measurements of a run as a JSON-serialisable dict (keys :data:`MEASURE_KEYS`).

    ``regime`` from :func:`classify_regime`; shapes from the last frame, with the
    departure threshold max(``radius``, 0.25 x largest lateral distance):

    - ``curvature_variance_1_m2``: always (:func:`curvature_variance` at ``spacing``);
    - ``straight``: everything else None;
    - ``chaotic_crumpling``: ``buckling_length_m`` and ``plume_opening_angle_rad``
      (fitted below the buckling length); coil radius, pitch and frequency None;
    - coiling regimes: ``buckling_length_m`` (axial), ``coil_radius_m``, ``coil_pitch_m``
      (suspended part for drag coiling / period doubling, everything past the departure
      point, i.e. the floor coils, for rope coiling; None before a full turn exists),
      ``coil_frequency_rad_s`` (only when R exists: probe at the departure arclength + R/2,
      or 2 pi v / turn length if tracking fails and ``v`` (m/s) is given); plume angle None.

    Other definitions (:func:`buckling_length_definitions`), None where the regime has no
    such quantity as above: ``buckling_length_2r_m``, ``buckling_length_quarter_m`` (not
    straight), ``buckling_length_full_radius_m`` (with R); ``coil_frequency_hz`` = omega /
    2 pi; ``omega_r_over_v`` = omega R / v with ``v`` if given, else the growth rate of the
    filament's arclength over the last frames (None when it does not grow). Always (even
    straight): ``min_gap_ratio`` (:func:`min_gap_ratio`, with ``radius``).

    Values are plain floats, None or str; never NaN.
    """
    out: dict[str, str | float | None] = dict.fromkeys(MEASURE_KEYS, None)
    out["regime"] = "straight"
    fr, tt = _valid_frames(frames, times)
    if not fr:
        return out
    last = fr[-1]
    d, o = _unit(needle_dir), _origin(needle_pos, last)
    regime = classify_regime(frames, times, o, d, radius=radius, z_floor=z_floor)
    out["regime"] = regime
    out["curvature_variance_1_m2"] = curvature_variance(last, spacing)
    out["min_gap_ratio"] = min_gap_ratio(fr, radius)
    if regime == "straight" or len(last) < 2:
        return out
    _, rho = _axial(last[::-1], o, d)
    thr = max(_float(radius) or 0.0, DEPARTURE_REL * float(rho.max()))
    ell = buckling_length(last, o, d, thr)
    out["buckling_length_m"] = ell
    if regime == "chaotic_crumpling":
        out["plume_opening_angle_rad"] = plume_angle(last, o, d, start_depth=ell or 0.0)
    else:
        zf = None if regime == "rope_coiling" else z_floor
        g = coil_geometry(
            last, o, d, thr, zf, None if zf is None else _floor_tol(o, float(zf), radius, None)
        )
        r = g.radius if g is not None else None
        out["coil_radius_m"] = r
        out["coil_pitch_m"] = g.pitch if g is not None else None
        s_dep = buckling_length(last, o, d, thr, along="arclength")
        if r is not None and s_dep is not None:
            out["coil_frequency_rad_s"] = coil_frequency(
                frames, times, o, d, probe_arclength=s_dep + 0.5 * r, v=v, threshold=thr
            )
    _other_definitions(out, fr, tt, o, d, radius, v)
    return {k: (val if isinstance(val, str) else _float(val)) for k, val in out.items()}


def _other_definitions(
    out: dict[str, Any],
    frames: list[np.ndarray],
    times: np.ndarray | None,
    o: np.ndarray,
    d: np.ndarray,
    radius: float | None,
    v: float | None,
) -> None:
    """measure_all's keys from buckling_length_2r_m on (see there), into ``out``; ``frames``
    are the valid frames and ``times`` theirs (or None)."""
    big_r = _float(out["coil_radius_m"])
    ells = buckling_length_definitions(frames[-1], o, d, radius=radius, coil_radius=big_r)
    out["buckling_length_2r_m"] = ells["two_radii"]
    out["buckling_length_quarter_m"] = ells["quarter"]
    out["buckling_length_full_radius_m"] = ells["full_radius"]
    omega = _float(out["coil_frequency_rad_s"])
    if omega is None:
        return
    out["coil_frequency_hz"] = omega / (2.0 * math.pi)
    speed = abs(_float(v) or 0.0) or (_length_rate(frames, times) if times is not None else None)
    if big_r is not None and speed:
        out["omega_r_over_v"] = omega * big_r / speed

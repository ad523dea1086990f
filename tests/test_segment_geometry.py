"""The geometry of segment pairs behind self-contact: distance derivatives against finite
differences in every distance case, continuity, momentum, the spatial hash against brute
force, and the no-pass-through step bound (``-s`` shows the printed timings)."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from numba import njit

from bathprint.core.effects import _segment_geometry as cm
from bathprint.core.effects.contact import min_separation_for

L = 1e-3  # segment length scale (m): a 1 mm rod discretisation
K_C = 50.0  # pair stiffness (N/m)


def candidate_pairs(
    pos, n_nodes, seg_first, seg_last, search_dist, min_sep, capacity=None, buckets=None
):
    """All candidate pairs of the hash (grown until they fit)."""
    n_seg = max(seg_last - seg_first, 1)
    if buckets is None:
        buckets = 1 << max(4, int(2 * n_seg - 1).bit_length())
    cap = 8 * n_seg if capacity is None else capacity
    while True:
        cell_start = np.zeros(buckets + 1, np.int64)
        seg_order = np.zeros(n_seg, np.int64)
        seg_cell = np.zeros(3 * n_seg, np.int64)
        pairs = np.zeros((cap, 2), np.int64)
        args = (pos, n_nodes, seg_first, seg_last, search_dist, min_sep)
        work = (np.zeros(buckets, np.int64), np.zeros((2, 6 * n_seg)))
        n = cm.build_candidate_pairs(*args, cell_start, seg_order, seg_cell, *work, pairs)
        if n <= cap:
            return pairs[:n]
        cap = n


def step_bound(pos0, pos1, pairs, skin):
    """(ratio, worst pair i, j, relative motion) of a step of the whole rod (none frozen)."""
    out = np.zeros(3)
    ratio = cm.step_bound(pos0, pos1, 0, pairs, len(pairs), pos0.size // 3, skin, out, np.zeros(12))
    return ratio, int(out[0]), int(out[1]), out[2]


# first calls: numba compiles (or loads from its cache) here
_FIRST_CALL: dict[str, float] = {}


def _first_calls() -> None:
    pos = np.array([0, 0, 0, 1, 0, 0, 0.3, -0.5, 0.2, 0.4, 0.5, 0.25]) * L
    g = np.zeros(12)
    h = np.zeros((12, 12))
    calls = {
        "segment_pair_energy": lambda: cm.segment_pair_energy(
            pos, 0, 1, 2, 3, 0.5 * L, K_C, 0.01 * L, g, h
        ),
        "segment_distance_derivs": lambda: cm.segment_distance_derivs(pos, 0, 1, 2, 3, 1e-12, g, h),
        "build_candidate_pairs": lambda: candidate_pairs(pos, 4, 0, 3, 0.1 * L, 0),
        "brute_force_pairs": lambda: cm.brute_force_pairs(
            pos, 0, 3, 0.1 * L, 0, np.zeros((4, 2), np.int64)
        ),
        "step_bound": lambda: step_bound(pos, pos, np.zeros((0, 2), np.int64), 0.1 * L),
    }
    for name, call in calls.items():
        t0 = time.perf_counter()
        call()
        _FIRST_CALL[name] = time.perf_counter() - t0


_first_calls()


def test_print_first_call_times() -> None:
    """Not a check: the first-call (compile, or cache load) times."""
    for name, dt in _FIRST_CALL.items():
        print(f"first call {name}: {dt:.2f} s")
    assert all(dt >= 0.0 for dt in _FIRST_CALL.values())


# ---------------------------------------------------------------------------------------
# configurations, one per distance case (canonical coordinates in units of L, then a fixed
# rotation and translation so that nothing is axis-aligned)


def _rotation(seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    return q if np.linalg.det(q) > 0 else -q


def _place(nodes, seed: int = 7) -> np.ndarray:
    rot = _rotation(seed)
    shift = np.array([0.3, -1.2, 2.1])
    return ((np.asarray(nodes, float) @ rot.T + shift) * L).ravel()


def _twisted_parallel(theta: float, tilt: float = 0.0) -> list:
    """A on the x axis, B above it at height 0.4 (overlapping), rotated by theta about z
    (skew lines crossing in projection) and tilted by ``tilt`` in the x-z plane (which
    breaks the tie between the endpoint cases of exactly parallel segments)."""
    c, s = math.cos(theta), math.sin(theta)
    b0 = np.array([-0.4 * c, -0.4 * s, 0.4 - 0.4 * tilt]) + [0.07, 0.0, 0.0]
    b1 = np.array([0.6 * c, 0.6 * s, 0.4 + 0.6 * tilt]) + [0.07, 0.0, 0.0]
    return [[-0.5, 0, 0], [0.5, 0, 0], b0, b1]


# name: (canonical nodes, expected (s_free, t_free), expected clamped values (s, t) or None)
CASES = {
    "interior": (
        [[-0.5, 0, 0], [0.6, 0.05, 0], [0.1, -0.4, 0.4], [-0.05, 0.5, 0.45]],
        (True, True),
        (None, None),
    ),
    "s0_edge": (
        [[0.1, 0.05, 0.4], [0.4, 0.15, 1.3], [-0.5, 0, 0], [0.5, 0.1, 0]],
        (False, True),
        (0.0, None),
    ),
    "s1_edge": (
        [[0.4, 0.15, 1.3], [0.1, 0.05, 0.4], [-0.5, 0, 0], [0.5, 0.1, 0]],
        (False, True),
        (1.0, None),
    ),
    "t0_edge": (
        [[-0.5, 0, 0], [0.5, 0.1, 0], [0.1, 0.05, 0.4], [0.4, 0.15, 1.3]],
        (True, False),
        (None, 0.0),
    ),
    "t1_edge": (
        [[-0.5, 0, 0], [0.5, 0.1, 0], [0.4, 0.15, 1.3], [0.1, 0.05, 0.4]],
        (True, False),
        (None, 1.0),
    ),
    "point_point": (
        [[-0.9, -0.2, 0.1], [0, 0, 0], [0.2, 0.3, 0.1], [1.0, 0.5, 0.6]],
        (False, False),
        (1.0, 0.0),
    ),
    # below PARALLEL_ANGLE_DEG: s held at the middle of the overlap, t its projection on B
    "nearly_parallel_3e-3": (_twisted_parallel(3e-3), (False, True), (None, None)),
    "nearly_parallel_1e-6": (_twisted_parallel(1e-6), (False, True), (None, None)),
    # between PARALLEL_ANGLE_DEG and SLIDING_ANGLE_DEG: s held, blended towards the exact one
    "blend_15deg": (_twisted_parallel(math.radians(15.0)), (False, True), (None, None)),
    # from SLIDING_ANGLE_DEG on: the exact closest points
    "sliding_25deg": (_twisted_parallel(math.radians(25.0)), (True, True), (None, None)),
    "right_angle_crossing": (
        [[-0.5, 0.05, 0], [0.5, 0.05, 0], [0.1, -0.5, 0.35], [0.1, 0.5, 0.35]],
        (True, True),
        (None, None),
    ),
    "right_angle_crossing_d_1e-4": (
        [[-0.5, 0.05, 0], [0.5, 0.05, 0], [0.1, -0.5, 1e-4], [0.1, 0.5, 1e-4]],
        (True, True),
        (None, None),
    ),
}


def _check_case(name: str, pos: np.ndarray) -> None:
    _, free, clamped = CASES[name]
    s, t, s_free, t_free, _ = cm.contact_params(pos, 0, 1, 2, 3)
    assert (s_free, t_free) == free, (s, t)
    for value, want in zip((s, t), clamped, strict=True):
        if want is not None:
            assert value == want


def _fd_gradient(f, x: np.ndarray, h: float) -> np.ndarray:
    out = np.zeros_like(x)
    for a in range(x.size):
        xp = x.copy()
        xm = x.copy()
        xp[a] += h
        xm[a] -= h
        out[a] = (f(xp) - f(xm)) / (2.0 * h)
    return out


def _fd_jacobian(fvec, x: np.ndarray, h: float) -> np.ndarray:
    out = np.zeros((x.size, x.size))
    for a in range(x.size):
        xp = x.copy()
        xm = x.copy()
        xp[a] += h
        xm[a] -= h
        out[:, a] = (fvec(xp) - fvec(xm)) / (2.0 * h)
    return out


def _distance_fns(pos):
    def value(x):
        return math.sqrt(cm.contact_params(x, 0, 1, 2, 3)[4])

    def deriv(x):
        g = np.zeros(12)
        h = np.zeros((12, 12))
        d = cm.segment_distance_derivs(x, 0, 1, 2, 3, 1e-300, g, h)
        return d, g, h

    return value, deriv


def _energy_fns(delta: float, width: float):
    def value(x):
        g = np.zeros(12)
        h = np.zeros((12, 12))
        return cm.segment_pair_energy(x, 0, 1, 2, 3, delta, K_C, width, g, h)[0]

    def deriv(x):
        g = np.zeros(12)
        h = np.zeros((12, 12))
        e, _ = cm.segment_pair_energy(x, 0, 1, 2, 3, delta, K_C, width, g, h)
        return e, g, h

    return value, deriv


def _assert_close(got: np.ndarray, want: np.ndarray, rtol: float, what: str) -> None:
    scale = np.max(np.abs(want))
    err = np.max(np.abs(got - want))
    assert err <= rtol * scale, f"{what}: max error {err:.3e} vs scale {scale:.3e}"


# the finite-difference step relative to L; the nearly parallel interior case has curvature
# ~ 1/(theta L) and needs a smaller step to keep the truncation error below the tolerance
_FD_STEP = {
    "nearly_parallel_3e-3": 1e-9,
    "nearly_parallel_1e-6": 1e-9,
    "blend_15deg": 1e-9,
    "right_angle_crossing_d_1e-4": 1e-9,
}

# Cases whose closest point on A is held (not a stationary point of the distance): the
# gradient and Hessian are exactly those of the distance from the held point x_A(s) to B,
# while the distance used, d(x), moves s with x (the middle of the overlap, and the blend),
# so its gradient differs by (dd/ds) (ds/dx): at most this fraction of the largest component
# here (segments 2.5 times as long as their distance; measured 1e-7, 3e-7 and 1e-2)
_HELD_GRADIENT_ERROR = {
    "nearly_parallel_1e-6": 1e-6,
    "nearly_parallel_3e-3": 1e-6,
    "blend_15deg": 2e-2,
}


def _held_distance_fns(s_held: float):
    """The distance from x_A(s_held) to segment B (numpy, t the clamped projection), and
    the kernel's derivatives with s held there and t free where interior."""

    def t_of(x):
        x0, x1, x2, x3 = x.reshape(4, 3)
        p, eb = x0 + s_held * (x1 - x0), x3 - x2
        return min(max((p - x2) @ eb / (eb @ eb), 0.0), 1.0)

    def value(x):
        x0, x1, x2, x3 = x.reshape(4, 3)
        return float(np.linalg.norm(x0 + s_held * (x1 - x0) - x2 - t_of(x) * (x3 - x2)))

    def deriv(x):
        g = np.zeros(12)
        h = np.zeros((12, 12))
        t = t_of(x)
        d = cm._distance_derivs(x, 0, 1, 2, 3, s_held, t, False, 0.0 < t < 1.0, 1e-300, g, h)
        return d, g, h

    return value, deriv


@pytest.mark.parametrize("quantity", ["distance", "energy_quadratic", "energy_cubic"])
@pytest.mark.parametrize("name", list(CASES))
def test_derivatives_match_finite_differences(name: str, quantity: str) -> None:
    pos = _place(CASES[name][0])
    _check_case(name, pos)
    d0 = cm.segment_distance(pos, 0, 1, 2, 3)
    if quantity == "distance":
        value, deriv = _distance_fns(pos)
    else:
        width = 0.05 * d0
        p = 0.3 * d0 if quantity == "energy_quadratic" else 0.4 * width
        value, deriv = _energy_fns(d0 + p, width)
    step = _FD_STEP.get(name, 1e-7) * L
    f0, grad, hess = deriv(pos)
    assert f0 > 0.0
    _assert_close(hess, hess.T, 1e-12, "Hessian symmetry")
    if name in _HELD_GRADIENT_ERROR:
        fd = _fd_gradient(value, pos, step)
        _assert_close(grad, fd, _HELD_GRADIENT_ERROR[name], "gradient of the distance used")
        if quantity == "distance":  # exact for the held point
            value, deriv = _held_distance_fns(cm.contact_params(pos, 0, 1, 2, 3)[0])
            _assert_close(grad, _fd_gradient(value, pos, step), 1e-6, "held gradient")
            hess_fd = _fd_jacobian(lambda x: deriv(x)[1], pos, step)
            _assert_close(hess, hess_fd, 1e-6, "held Hessian")
        return
    _assert_close(grad, _fd_gradient(value, pos, step), 1e-6, "gradient")
    _assert_close(hess, _fd_jacobian(lambda x: deriv(x)[1], pos, step), 1e-6, "Hessian")


def test_distance_hessian_exact_as_crossing_segments_meet() -> None:
    """Two crossing segments: d = |h| with h smooth, so Hess d stays bounded as d -> 0 and
    equals its value at moderate separation up to O(d); at d = 0 exactly it is finite."""
    hessians = []
    for height in (1e-2, 1e-6, 1e-10, 0.0):
        nodes = [[-0.5, 0.05, 0], [0.5, 0.05, 0], [0.1, -0.5, height], [0.1, 0.5, height]]
        pos = _place(nodes)
        g = np.zeros(12)
        h = np.zeros((12, 12))
        d = cm.segment_distance_derivs(pos, 0, 1, 2, 3, 1e-300, g, h)
        assert np.isfinite(h).all() and np.isfinite(g).all()
        assert abs(d - height * L) <= 1e-12 * L
        hessians.append(h)
    ref = hessians[1]
    _assert_close(hessians[2], ref, 1e-5, "Hess d at small separation")
    # at d = 0 the normal is the edges' cross product, either side of the crossing
    h0 = hessians[3]
    sign = 1.0 if np.sum(h0 * ref) > 0 else -1.0
    _assert_close(sign * h0, ref, 1e-5, "Hess d at d = 0")
    # and it matches finite differences at d = 1e-6 L with a step far below d
    pos = _place([[-0.5, 0.05, 0], [0.5, 0.05, 0], [0.1, -0.5, 1e-6], [0.1, 0.5, 1e-6]])
    value, deriv = _distance_fns(pos)
    _assert_close(ref, _fd_jacobian(lambda x: deriv(x)[1], pos, 1e-9 * L), 1e-6, "FD")


def test_point_contact_at_zero_distance_is_finite() -> None:
    """A node exactly on the other segment: normal from the edge cross product, Hessian
    cut off at D_FLOOR_REL * delta, nothing NaN."""
    pos = _place([[0.1, 0.0, 0.0], [0.4, 0.2, 1.0], [-0.5, 0, 0], [0.5, 0, 0]])
    g = np.zeros(12)
    h = np.zeros((12, 12))
    e, d = cm.segment_pair_energy(pos, 0, 1, 2, 3, 0.5 * L, K_C, 0.01 * L, g, h)
    assert d <= 1e-15
    assert np.isfinite(e) and np.isfinite(g).all() and np.isfinite(h).all()
    assert np.linalg.norm(g) > 0.0  # a definite push even at zero distance


# ---------------------------------------------------------------------------------------
# the closest points are the global minimum


def _random_segment_pairs(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = rng.normal(size=(n, 12)) * L
    # every fourth pair nearly parallel, every tenth with a degenerate segment
    for k in range(0, n, 4):
        e = out[k, 3:6] - out[k, 0:3]
        out[k, 9:12] = out[k, 6:9] + e * rng.uniform(-1.5, 1.5) + rng.normal(size=3) * 1e-7 * L
    for k in range(1, n, 10):
        out[k, 9:12] = out[k, 6:9]
    return out


def _to_segment(x: np.ndarray, a: np.ndarray, e: np.ndarray) -> float:
    ee = e @ e
    u = min(max((x - a) @ e / ee, 0.0), 1.0) if ee > 1e-30 * L * L else 0.0
    return float(np.linalg.norm(x - a - u * e))


SEARCH_TOL = 1e-10 * L  # how far above the minimum :func:`_min_distance` may stop


def _min_distance(x0, ea, x2, eb, grid: np.ndarray) -> float:
    """The minimum distance of the segments, by search: the distance from x_A(s) to B is
    convex in s; a grid, then a finer one around its best point."""
    d_s = [_to_segment(x0 + u * ea, x2, eb) for u in grid]
    best = int(np.argmin(d_s))
    fine = np.linspace(grid[max(best - 1, 0)], grid[min(best + 1, grid.size - 1)], 2001)
    ends = (_to_segment(x2, x0, ea), _to_segment(x2 + eb, x0, ea))
    return min(*ends, *(_to_segment(x0 + u * ea, x2, eb) for u in fine))


def test_closest_params_satisfy_kkt_and_beat_a_grid() -> None:
    pairs = _random_segment_pairs(2000, seed=3)
    grid = np.linspace(0.0, 1.0, 301)
    for k, pos in enumerate(pairs):
        s, t, s_free, t_free, dist2 = cm.closest_params(pos, 0, 1, 2, 3)
        x0, x1, x2, x3 = pos.reshape(4, 3)
        ea, eb = x1 - x0, x3 - x2
        r = x0 + s * ea - x2 - t * eb
        assert abs(dist2 - r @ r) <= 1e-12 * (dist2 + L * L)
        tol = 1e-9 * L * L
        cross2 = np.sum(np.cross(ea, eb) ** 2)
        both = (ea @ ea) > 1e-20 * L * L and (eb @ eb) > 1e-20 * L * L
        sin2 = cross2 / ((ea @ ea) * (eb @ eb)) if both else 1.0
        _check_contact_params(pos, sin2, grid)
        if both and sin2 <= cm.PARALLEL_TOL:
            # parallel to PARALLEL_TOL: the best of the edge cases, within the documented
            # bound of the minimum
            d_true = _min_distance(x0, ea, x2, eb, grid)
            length2 = max(ea @ ea, eb @ eb)
            bound = cm.PARALLEL_TOL * length2 / max(d_true, 1e-3 * L) + 1e-12 * L
            assert d_true - SEARCH_TOL <= np.sqrt(dist2) <= d_true + bound
            continue
        g_s, g_t = r @ ea, -(r @ eb)
        for val, free, gv, length2 in ((s, s_free, g_s, ea @ ea), (t, t_free, g_t, eb @ eb)):
            assert 0.0 <= val <= 1.0
            if length2 < 1e-20 * L * L:
                continue
            if free:
                assert abs(gv) <= tol
            elif val == 0.0:
                assert gv >= -tol
            else:
                assert val == 1.0 and gv <= tol
        if k < 100:  # global optimality against a dense sample of the unit square
            pa = x0 + grid[:, None] * ea
            pb = x2 + grid[:, None] * eb
            dmin2 = np.min(np.sum((pa[:, None, :] - pb[None, :, :]) ** 2, axis=2))
            assert dist2 <= dmin2 * (1.0 + 1e-12) + 1e-30


def _check_contact_params(pos: np.ndarray, sin2: float, grid: np.ndarray) -> None:
    """The contact points are the closest points unless the segments are nearly parallel
    (below SLIDING_ANGLE_DEG) and overlap; then s is held (the middle of the overlap, or
    blended towards the closest point's), t is its clamped projection on B, and since d
    changes along s, t following, at most as fast as x_A moves across B (|e_A| sin), the
    distance exceeds the minimum by at most |e_A| sin (a parameter step of at most 1)."""
    s, t, s_free, t_free, dist2 = cm.contact_params(pos, 0, 1, 2, 3)
    exact = cm.closest_params(pos, 0, 1, 2, 3)
    if not (sin2 < cm.SLIDING_SIN2 and not s_free and (s, t) != exact[:2]):
        assert (s, t, s_free, t_free, dist2) == exact
        return
    x0, x1, x2, x3 = pos.reshape(4, 3)
    ea, eb = x1 - x0, x3 - x2
    assert 0.0 <= s <= 1.0 and 0.0 <= t <= 1.0
    t_proj = min(max((x0 + s * ea - x2) @ eb / (eb @ eb), 0.0), 1.0)
    assert abs(t - t_proj) <= 1e-9 and t_free == (0.0 < t < 1.0)
    d_true = _min_distance(x0, ea, x2, eb, grid)
    bound = d_true + np.sqrt((ea @ ea) * sin2) + 1e-12 * L
    assert d_true - SEARCH_TOL <= np.sqrt(dist2) <= bound


# ---------------------------------------------------------------------------------------
# energy range and continuity


def _crossing_at_height(height: float) -> np.ndarray:
    return _place([[-0.5, 0.05, 0], [0.5, 0.05, 0], [0.1, -0.5, height], [0.1, 0.5, height]])


def test_energy_zero_beyond_delta_and_smooth_across_it() -> None:
    delta, width = 0.5 * L, 0.01 * L
    value, deriv = _energy_fns(delta, width)
    for height in (0.5, 0.5 + 1e-9, 0.7, 3.0):
        e, g, h = deriv(_crossing_at_height(height))
        assert e == 0.0 and not g.any() and not h.any()
    eps = 1e-6  # in units of L
    e_in, g_in, h_in = deriv(_crossing_at_height(0.5 - eps))
    e_out, g_out, h_out = deriv(_crossing_at_height(0.5 + eps))
    p = eps * L
    # cubic onset: E ~ k p^3 / (6 w), |grad| ~ k p^2 / (2 w), |Hess| ~ k p / w -> 0 (C2)
    assert 0.0 < e_in <= 1.01 * K_C * p**3 / (6 * width)
    assert np.max(np.abs(g_in)) <= 1.01 * K_C * p**2 / (2 * width)
    assert np.max(np.abs(h_in)) <= 2.0 * K_C * p / width
    assert e_out == 0.0
    # across the end of the cubic onset (p = width) E, E' and E'' are continuous
    h1 = (0.5 - 0.01) * L
    _, g_a, h_a = deriv(_crossing_at_height(h1 / L - 1e-9))
    _, g_b, h_b = deriv(_crossing_at_height(h1 / L + 1e-9))
    _assert_close(g_a, g_b, 1e-6, "gradient across p = width")
    _assert_close(h_a, h_b, 1e-5, "Hessian across p = width")


def _slide(lam: float, end_offset: float = 0.0) -> np.ndarray:
    """B crosses A's line (A from 0 to 1 on x) at x = lam, 0.3 above it."""
    return _place([[0, 0, 0], [1, 0, 0], [lam, -0.5 + end_offset, 0.3], [lam, 0.5, 0.3]])


def _switch_point(family, lo: float, hi: float) -> float:
    """Bisect the parameter where the free flags change."""
    flags = lambda lam: cm.closest_params(family(lam), 0, 1, 2, 3)[2:4]  # noqa: E731
    f_lo = flags(lo)
    assert flags(hi) != f_lo
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if flags(mid) == f_lo:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


@pytest.mark.parametrize(
    "family, lo, hi",
    [
        (_slide, 0.5, 1.5),  # interior -> A's endpoint on B (point-edge)
        (lambda lam: _slide(1.4, end_offset=lam), -0.5, 0.9),  # point-edge -> point-point
    ],
    ids=["interior_to_point_edge", "point_edge_to_point_point"],
)
def test_energy_and_gradient_continuous_across_case_switch(family, lo, hi) -> None:
    lam = _switch_point(family, lo, hi)
    value, deriv = _energy_fns(0.6 * L, 0.01 * L)
    eps = 1e-7
    pa, pb = family(lam - eps), family(lam + eps)
    assert cm.closest_params(pa, 0, 1, 2, 3)[2:4] != cm.closest_params(pb, 0, 1, 2, 3)[2:4]
    e_a, g_a, _ = deriv(pa)
    e_b, g_b, _ = deriv(pb)
    assert e_a > 0.0
    # E changes by O(eps), grad by O(eps) (the Hessian may jump): far below the scales
    assert abs(e_a - e_b) <= 1e-5 * e_a
    _assert_close(g_a, g_b, 1e-5, "gradient across the case switch")


def test_parallel_threshold_changes_distance_by_at_most_its_bound() -> None:
    """Below sin^2(theta) = PARALLEL_TOL the edge cases replace the interior solution; the
    distance moves by <= PARALLEL_TOL |e|^2 / d there (the force location may move)."""
    theta_c = math.asin(math.sqrt(cm.PARALLEL_TOL))
    above = _place(_twisted_parallel(theta_c * (1 + 1e-6)))
    below = _place(_twisted_parallel(theta_c * (1 - 1e-6)))
    ca, cb = cm.closest_params(above, 0, 1, 2, 3), cm.closest_params(below, 0, 1, 2, 3)
    assert ca[2] and ca[3] and not (cb[2] and cb[3])
    da, db = math.sqrt(ca[4]), math.sqrt(cb[4])
    assert db >= da - 1e-15 * L  # the interior minimum is the smaller one
    assert db - da <= 2.0 * cm.PARALLEL_TOL * L * L / da


def test_closest_points_move_continuously_through_the_parallel_blend() -> None:
    """Overlapping segments whose crossing (in projection) lies near A's end, far from the
    middle of the overlap, swept from 0 to 30 degrees: the closest points go from the middle
    of the overlap (below PARALLEL_ANGLE_DEG) through the blend to the exact ones (from
    SLIDING_ANGLE_DEG) without a jump at either threshold, and the distance used exceeds the
    exact one by at most |e_A| sin(theta)."""
    rows = []
    for deg in np.linspace(0.0, 30.0, 3001):
        th = math.radians(deg)
        u = np.array([math.cos(th), math.sin(th), 0.0])
        centre = np.array([0.35, 0.0, 0.4])  # B crosses over A at s = 0.85
        pos = _place([[-0.5, 0, 0], [0.5, 0, 0], centre - 0.6 * u, centre + 0.4 * u])
        s, t, s_free, t_free, dist2 = cm.contact_params(pos, 0, 1, 2, 3)
        exact = cm.closest_params(pos, 0, 1, 2, 3)
        rows.append((deg, s, t, math.sqrt(dist2), math.sqrt(exact[4]), s_free))
    deg, s, t, d, d_exact, s_free = (np.array(c) for c in zip(*rows, strict=True))
    assert abs(s[0] - 0.625) < 1e-9  # the middle of the overlap [0.25, 1]
    assert abs(s[-1] - 0.85) < 1e-9 and s_free[-1]  # the crossing
    assert not s_free[deg < cm.SLIDING_ANGLE_DEG - 1e-9].any()
    assert s_free[deg >= cm.SLIDING_ANGLE_DEG + 1e-9].all()
    # 0.01 degree steps: s moves by at most 1e-3 per step (a jump would be 0.225), d by at
    # most 1e-4 L (the middle's excess at 10 degrees, which a jump would drop, is 2e-3 L)
    assert np.max(np.abs(np.diff(s))) < 1e-3 and np.max(np.abs(np.diff(t))) < 1e-3
    assert np.max(np.abs(np.diff(d))) < 1e-4 * L
    assert np.max(d - d_exact) > 1e-3 * L
    # the distance used: never below the exact one, above it by at most |e_A| sin(theta)
    sin = np.sin(np.radians(deg))
    assert np.all(d >= d_exact - 1e-12 * L)
    assert np.all(d - d_exact <= L * sin + 1e-12 * L)


# ---------------------------------------------------------------------------------------
# momentum


def test_gradient_and_hessian_are_translation_and_rotation_invariant() -> None:
    rng = np.random.default_rng(11)
    checked = 0
    for pos in _random_segment_pairs(300, seed=5):
        pos = pos * 0.5 + np.tile(rng.normal(size=3) * 4 * L, 4)
        d0 = cm.segment_distance(pos, 0, 1, 2, 3)
        g = np.zeros(12)
        h = np.zeros((12, 12))
        cm.segment_pair_energy(pos, 0, 1, 2, 3, 1.2 * d0 + 1e-6 * L, K_C, 0.01 * d0, g, h)
        nodes = pos.reshape(4, 3)
        force = g.reshape(4, 3)
        gscale = np.max(np.abs(g))
        assert gscale > 0.0
        assert np.max(np.abs(force.sum(axis=0))) <= 1e-12 * gscale
        torque = np.cross(nodes - nodes.mean(axis=0), force).sum(axis=0)
        assert np.max(np.abs(torque)) <= 1e-12 * gscale * L * 10
        # a rigid translation of all four nodes leaves the gradient unchanged: H T = 0
        hscale = np.max(np.abs(h))
        for c in range(3):
            assert np.max(np.abs(h[:, c::3].sum(axis=1))) <= 1e-9 * hscale
        checked += 1
    assert checked == 300


# ---------------------------------------------------------------------------------------
# spatial hash


def random_walk(n_nodes: int, dl: float, box: float, seed: int) -> np.ndarray:
    """A random-walk polymer of bond length dl reflected into a cube of side ``box``."""
    rng = np.random.default_rng(seed)
    steps = rng.normal(size=(n_nodes - 1, 3))
    steps *= dl / np.linalg.norm(steps, axis=1, keepdims=True)
    pts = np.zeros((n_nodes, 3))
    for k, st in enumerate(steps):
        p = pts[k] + st
        for c in range(3):
            if abs(p[c]) > 0.5 * box:
                p[c] = pts[k, c] - st[c]
        pts[k + 1] = p
    return pts.ravel()


def helix(n_nodes: int, dl: float, radius: float, pitch: float) -> np.ndarray:
    """A tight helix: consecutive turns ``pitch`` apart (m)."""
    dphi = dl / math.hypot(radius, pitch / (2 * math.pi))
    phi = dphi * np.arange(n_nodes)
    pts = np.stack(
        [radius * np.cos(phi), radius * np.sin(phi), pitch * phi / (2 * math.pi)], axis=1
    )
    return pts.ravel()


def _pair_set(pairs: np.ndarray) -> set[tuple[int, int]]:
    out = {(int(i), int(j)) for i, j in pairs}
    assert len(out) == len(pairs), "duplicate pairs"
    return out


@njit(cache=True)
def _all_pairs_within(pos, seg_first, seg_last, dist, min_sep, out) -> int:
    n = 0
    for i in range(seg_first, seg_last):
        for j in range(i + min_sep + 1, seg_last):
            if cm.segment_distance(pos, i, i + 1, j, j + 1) <= dist:
                if n < out.shape[0]:
                    out[n, 0] = i
                    out[n, 1] = j
                n += 1
    return n


def _brute(pos, seg_first, seg_last, search_dist, min_sep, kernel=cm.brute_force_pairs):
    buf = np.zeros((16, 2), np.int64)
    n = kernel(pos, seg_first, seg_last, search_dist, min_sep, buf)
    if n > buf.shape[0]:
        buf = np.zeros((n, 2), np.int64)
        kernel(pos, seg_first, seg_last, search_dist, min_sep, buf)
    return buf[:n]


ROD_CASES = {
    "random_walk_2000": (lambda: random_walk(2000, L, 12 * L, seed=1), 0.8 * L, L),
    "tight_helix_2000": (lambda: helix(2000, 0.5 * L, 3 * L, 1.05 * L), 1.0 * L, 0.5 * L),
}


@pytest.mark.parametrize("name", list(ROD_CASES))
@pytest.mark.parametrize("seg_range", ["all", "sub"])
def test_hash_pairs_equal_brute_force(name: str, seg_range: str) -> None:
    make, delta, dl = ROD_CASES[name]
    pos = make()
    n_nodes = pos.size // 3
    seg_first, seg_last = (0, n_nodes - 1) if seg_range == "all" else (137, n_nodes - 301)
    search_dist = 1.5 * delta
    min_sep = min_separation_for(delta, dl)
    got = _pair_set(candidate_pairs(pos, n_nodes, seg_first, seg_last, search_dist, min_sep))
    want = _pair_set(_brute(pos, seg_first, seg_last, search_dist, min_sep))
    assert len(want) > 100  # a dense case, not a trivial one
    assert got == want
    assert all(seg_first <= i and j - i > min_sep and j < seg_last for i, j in got)
    # a superset of the pairs that really are within search_dist
    close = _pair_set(_brute(pos, seg_first, seg_last, search_dist, min_sep, _all_pairs_within))
    assert close <= got and len(close) > 0


def test_hash_pairs_with_few_buckets_equal_brute_force() -> None:
    """With 16 buckets for a 2000-node helix nearly every bucket holds many cells, and the 27
    neighbour cells of a segment share buckets: each bucket is scanned once per segment (no
    pair twice) and the pairs are still the brute-force set."""
    make, delta, dl = ROD_CASES["tight_helix_2000"]
    pos = make()
    min_sep = min_separation_for(delta, dl)
    got = _pair_set(candidate_pairs(pos, 2000, 0, 1999, 1.5 * delta, min_sep, buckets=16))
    assert got == _pair_set(_brute(pos, 0, 1999, 1.5 * delta, min_sep))


def test_hash_reports_a_too_small_output() -> None:
    pos = helix(600, 0.5 * L, 2 * L, 1.05 * L)
    small = candidate_pairs(pos, 600, 0, 599, 1.5 * L, 4, capacity=3)  # grown by the helper
    assert len(small) > 3
    assert _pair_set(small) == _pair_set(_brute(pos, 0, 599, 1.5 * L, 4))


def test_frozen_segments_are_partners_but_never_query() -> None:
    """Pairs with a frozen tail (segments before query_first) come out as (frozen, active);
    pairs of two frozen segments never do."""
    pos = helix(800, 0.5 * L, 2 * L, 1.05 * L)
    n_seg, first = 799, 300
    buckets = 1 << 11
    pairs = np.zeros((20000, 2), np.int64)
    n = cm.build_candidate_pairs(
        pos, 800, 0, n_seg, 1.5 * L, 4, np.zeros(buckets + 1, np.int64),
        np.zeros(n_seg, np.int64), np.zeros(3 * n_seg, np.int64), np.zeros(buckets, np.int64),
        np.zeros((2, 6 * n_seg)), pairs, first,
    )  # fmt: skip
    got = _pair_set(pairs[:n])
    want = {(i, j) for i, j in _pair_set(_brute(pos, 0, n_seg, 1.5 * L, 4)) if j >= first}
    assert got == want and any(i < first for i, _ in got)


def test_min_separation_rule() -> None:
    assert min_separation_for(1e-3, 1e-3) == 2
    assert min_separation_for(1e-3, 0.25e-3) == 7  # ceil(6.4)
    # on the tightest arc (radius delta/2) the excluded gaps lie within pi delta / 2
    delta, dl = 1e-3, 0.2e-3
    m = min_separation_for(delta, dl)
    assert m * dl >= 1.6 * delta > math.pi * delta / 2


def test_hash_timing_scales_linearly() -> None:
    """Not a check of speed: prints the build time for N = 1e3, 1e4, 1e5 nodes (a confined
    random walk at a fixed, rod-like density), the pair-energy loop and the step bound over
    the pairs, and the brute force for comparison (best of 3 after a warm-up)."""

    def best_of(fn, *args) -> float:
        fn(*args)
        best = np.inf
        for _ in range(3):
            t0 = time.perf_counter()
            fn(*args)
            best = min(best, time.perf_counter() - t0)
        return best

    delta, search_dist = 0.8 * L, 1.2 * L
    g = np.zeros(12)
    h = np.zeros((12, 12))
    for n_nodes in (1_000, 10_000, 100_000):
        box = 30 * L * (n_nodes / 2000) ** (1 / 3)
        pos = random_walk(n_nodes, L, box, seed=2)
        n_seg = n_nodes - 1
        t_hash = best_of(candidate_pairs, pos, n_nodes, 0, n_seg, search_dist, 2)
        pairs = candidate_pairs(pos, n_nodes, 0, n_seg, search_dist, 2).copy()
        n_pairs = len(pairs)
        t_energy = best_of(_energy_loop, pos, pairs, n_pairs, delta, K_C, 0.01 * L, g, h)
        t_bound = best_of(step_bound, pos, pos, pairs, search_dist - delta)
        line = (
            f"N = {n_nodes:>6}: hash {t_hash * 1e3:7.2f} ms "
            f"({t_hash / n_nodes * 1e9:5.0f} ns/node), {n_pairs / n_nodes:4.1f} pairs/node, "
            f"pair energies {t_energy * 1e3:7.2f} ms, step bound {t_bound * 1e3:7.2f} ms"
        )
        if n_nodes <= 10_000:
            t0 = time.perf_counter()
            brute = _brute(pos, 0, n_nodes - 1, search_dist, 2)
            line += f", brute force {(time.perf_counter() - t0) * 1e3:8.1f} ms"
            assert len(brute) == len(pairs)
        print(line)


@njit(cache=True)
def _energy_loop(pos, pairs, n_pairs, delta, k_c, width, g, h) -> float:
    total = 0.0
    for p in range(n_pairs):
        i = pairs[p, 0]
        j = pairs[p, 1]
        total += cm.segment_pair_energy(pos, i, i + 1, j, j + 1, delta, k_c, width, g, h)[0]
    return total


# ---------------------------------------------------------------------------------------
# step bound


def test_step_bound_ratio_and_lipschitz_bound() -> None:
    pos0 = random_walk(800, L, 8 * L, seed=4)
    n_nodes = pos0.size // 3
    delta, search_dist = 0.8 * L, 1.5 * L
    pairs = candidate_pairs(pos0, n_nodes, 0, n_nodes - 1, search_dist, 2).copy()
    rng = np.random.default_rng(9)
    pos1 = pos0 + rng.normal(size=pos0.size) * 0.05 * L
    skin = search_dist - delta
    worst, _, _, m = step_bound(pos0, pos1, pairs, skin)
    dx = (pos1 - pos0).reshape(-1, 3)
    centre = 0.5 * (dx.min(axis=0) + dx.max(axis=0))
    assert m == pytest.approx(np.max(np.linalg.norm(dx - centre, axis=1)), rel=1e-12)
    ratios = [2 * m / skin]
    for i, j in pairs:
        u = max(np.linalg.norm(dx[a] - dx[b]) for a in (i, i + 1) for b in (j, j + 1))
        d0 = cm.segment_distance(pos0, i, i + 1, j, j + 1)
        ratios.append(u / d0)
        for tau in np.linspace(0.0, 1.0, 6):  # d(tau) >= d0 - tau u along the motion
            d_tau = cm.segment_distance(pos0 + tau * (pos1 - pos0), i, i + 1, j, j + 1)
            assert d_tau >= d0 - tau * u - 1e-15
    assert worst == pytest.approx(max(ratios), rel=1e-12)


def test_step_bound_flags_a_crossing() -> None:
    """Segment B moves straight through A: the ratio must reach 1, and name the pair; a
    small step does not."""
    pos0 = _place([[-0.5, 0, 0], [0.5, 0, 0], [0.1, -0.5, 0.3], [0.1, 0.5, 0.3]])
    pairs = np.array([[0, 2]], np.int64)  # segment 0 = nodes (0, 1), segment 2 = (2, 3)
    down = _place([[-0.5, 0, 0], [0.5, 0, 0], [0.1, -0.5, -0.3], [0.1, 0.5, -0.3]])
    worst, i, j, _ = step_bound(pos0, down, pairs, 10.0 * L)
    assert worst >= 1.0 and (i, j) == (0, 2)
    small = _place([[-0.5, 0, 0], [0.5, 0, 0], [0.1, -0.5, 0.2], [0.1, 0.5, 0.2]])
    worst, _, _, _ = step_bound(pos0, small, pairs, 10.0 * L)
    assert worst < 1.0


def test_step_bound_with_the_skin_keeps_other_pairs_beyond_delta() -> None:
    """A step whose ratio is below 1 leaves no pair outside the list within delta."""
    pos0 = random_walk(1500, L, 9 * L, seed=6)
    n_nodes = pos0.size // 3
    delta, search_dist = 0.8 * L, 1.2 * L
    min_sep = 2
    pairs = candidate_pairs(pos0, n_nodes, 0, n_nodes - 1, search_dist, min_sep).copy()
    rng = np.random.default_rng(8)
    dirs = rng.normal(size=(n_nodes, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    pos1 = pos0 + (dirs * 0.099 * L).ravel()  # |dx - c| <= ~0.2 L = (search - delta) / 2
    _, _, _, m = step_bound(pos0, pos1, pairs, search_dist - delta)
    assert 2 * m < search_dist - delta  # the skin's part of the bound holds
    within = _pair_set(_brute(pos1, 0, n_nodes - 1, delta, min_sep, _all_pairs_within))
    assert len(within) > 0
    assert within <= _pair_set(pairs)

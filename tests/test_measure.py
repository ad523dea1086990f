"""bathprint.analysis.measure on synthetic curves with known answers."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from bathprint.analysis.measure import (
    MEASURE_KEYS,
    REGIMES,
    buckling_length,
    classify_regime,
    coil_frequency,
    coil_pitch,
    coil_radius,
    curvature_variance,
    measure_all,
    plume_angle,
)

NEEDLE = np.zeros(3)
DOWN = np.array([0.0, 0.0, -1.0])
R, P, ELL, H = 5e-3, 6e-3, 20e-3, 0.25e-3  # coil radius, pitch, stem, node spacing (m)
R_FIL = 0.2e-3  # filament radius (m)
OMEGA = 2.0  # rad/s


def helix_frame(
    pitches, radius=R, stem=ELL, h=H, phase=0.0, drift=0.0, z_flat=None, noise=0.0, rng=None
):
    """Needle at the origin pointing -z: a straight stem of length ``stem``, a horizontal
    radial arm out to ``radius`` and then coils of the given per-turn pitches, all rotated
    by ``phase`` about the needle axis. ``z_flat``: coils lie flat at that height; ``drift``:
    lateral (x) shift of the coil centre per turn. Returned free end first."""
    n_stem = round(stem / h)
    stem_pts = np.column_stack(
        [np.zeros(n_stem + 1), np.zeros(n_stem + 1), -np.linspace(0.0, stem, n_stem + 1)]
    )
    n_arm = round(radius / h)
    x_arm = np.linspace(0.0, radius, n_arm + 1)[1:]
    z0 = -stem if z_flat is None else z_flat
    arm = np.column_stack([x_arm, np.zeros_like(x_arm), np.full_like(x_arm, z0)])
    n_turn = len(pitches)
    n_coil = int(np.ceil(2 * np.pi * n_turn * radius / h))
    phi = np.linspace(0.0, 2 * np.pi * n_turn, n_coil + 1)[1:]
    k = np.minimum((phi // (2 * np.pi)).astype(int), n_turn - 1)
    cum = np.concatenate([[0.0], np.cumsum(pitches)])
    dz = cum[k] + (phi / (2 * np.pi) - k) * np.asarray(pitches)[k]
    z = np.full_like(phi, z0) if z_flat is not None else z0 - dz
    coil = np.column_stack(
        [radius * np.cos(phi) + drift * phi / (2 * np.pi), radius * np.sin(phi), z]
    )
    pts = np.vstack([stem_pts, arm, coil])
    c, s = math.cos(phase), math.sin(phase)
    pts = pts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    if noise:
        pts = pts + rng.normal(scale=noise, size=pts.shape)
    return pts[::-1].copy()


def coil_on_edge(n_turn=6, drift=0.3e-3, yaw=0.4):
    """Needle at the origin pointing -z: a straight stem of length ELL, then flat coils of
    radius R in a VERTICAL plane (horizontal coil axis, no advance along it) that drift by
    ``drift`` per turn within that plane, all turned by ``yaw`` about the needle axis (so
    the zero advance along the axis comes out as round-off). Returned free end first."""
    n_stem = round(ELL / H)
    stem = np.column_stack(
        [np.zeros(n_stem + 1), np.zeros(n_stem + 1), -np.linspace(0.0, ELL, n_stem + 1)]
    )
    n = int(np.ceil(2 * np.pi * n_turn * R / H))
    phi = np.linspace(0.0, 2 * np.pi * n_turn, n + 1)[1:]
    x = R - R * np.cos(phi) + drift * phi / (2 * np.pi)
    coil = np.column_stack([x, np.zeros_like(phi), -ELL - R * np.sin(phi)])
    c, s = math.cos(yaw), math.sin(yaw)
    pts = np.vstack([stem, coil]) @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return pts[::-1].copy()


def rotating(pitches, n=40, t_end=3.0, **kw):
    times = np.linspace(0.0, t_end, n)
    return [helix_frame(pitches, phase=OMEGA * t, **kw) for t in times], times


def test_regular_helix_recovers_l_R_pitch_omega():
    frames, times = rotating([P] * 6)
    last = frames[-1]
    assert buckling_length(last, NEEDLE, DOWN) == pytest.approx(ELL, rel=0.02)
    assert coil_radius(last, NEEDLE, DOWN) == pytest.approx(R, rel=0.02)
    lam, per_turn = coil_pitch(last, NEEDLE, DOWN)
    assert lam == pytest.approx(P, rel=0.02)
    assert len(per_turn) >= 4 and np.allclose(per_turn, P, rtol=0.02)
    assert coil_frequency(frames, times, NEEDLE, DOWN) == pytest.approx(OMEGA, rel=0.02)
    assert classify_regime(frames, times, NEEDLE, DOWN) == "drag_coiling"

    m = measure_all(frames, times, NEEDLE, DOWN, H, R_FIL)
    assert tuple(m) == MEASURE_KEYS
    assert m["regime"] == "drag_coiling"
    assert m["buckling_length_m"] == pytest.approx(ELL, rel=0.02)
    assert m["coil_radius_m"] == pytest.approx(R, rel=0.02)
    assert m["coil_pitch_m"] == pytest.approx(P, rel=0.02)
    assert m["coil_frequency_rad_s"] == pytest.approx(OMEGA, rel=0.02)
    assert m["plume_opening_angle_rad"] is None
    json.dumps(m, allow_nan=False)


def test_frequency_from_turn_rate_and_arclength_option():
    frame = helix_frame([P] * 6)
    v = 0.01
    s_turn = math.hypot(2 * np.pi * R, P)
    omega = coil_frequency([frame], [0.0], NEEDLE, DOWN, v=v)  # one frame: cannot track
    assert omega == pytest.approx(2 * np.pi * v / s_turn, rel=0.02)
    s = buckling_length(frame, NEEDLE, DOWN, threshold=0.5 * R, along="arclength")
    assert s == pytest.approx(ELL + 0.5 * R, rel=0.01)


def test_undersampled_frames_are_not_tracked():
    times = np.linspace(0.0, 3.0, 8)
    frames = [helix_frame([P] * 4, phase=6.0 * t) for t in times]  # 2.6 rad per frame
    assert coil_frequency(frames, times, NEEDLE, DOWN) is None  # aliased: rejected
    v = 0.01
    omega = coil_frequency(frames, times, NEEDLE, DOWN, v=v)  # falls back to 2 pi v / s_turn
    assert omega == pytest.approx(2 * np.pi * v / math.hypot(2 * np.pi * R, P), rel=0.02)


def test_aliased_rotation_is_replaced_by_the_turn_rate():
    v, times = 0.01, np.linspace(0.0, 1.0, 11)
    frames = []
    for t in times:  # turns 2 pi + 0.1 rad per frame; the free-end tail grows at v
        f = helix_frame([P] * 6, phase=(2 * np.pi + 0.1) * 10 * t)
        tail = f[0] - np.outer(np.arange(1, round(v * t / H) + 1) * H, [0.0, 0.0, 1.0])
        frames.append(np.vstack([tail[::-1], f]))
    expected = 2 * np.pi * v / math.hypot(2 * np.pi * R, P)
    assert coil_frequency(frames, times, NEEDLE, DOWN, method="track") == pytest.approx(1.0)
    assert coil_frequency(frames, times, NEEDLE, DOWN) == pytest.approx(expected, rel=0.03)


def test_noisy_drifting_helix_is_still_drag_coiling():
    rng = np.random.default_rng(1)
    frames = [helix_frame([P] * 6, drift=0.3e-3, noise=0.02 * H, rng=rng) for _ in range(3)]
    assert classify_regime(frames, None, NEEDLE, DOWN, radius=R_FIL) == "drag_coiling"
    assert coil_radius(frames[-1], NEEDLE, DOWN) == pytest.approx(R, rel=0.05)
    assert coil_pitch(frames[-1], NEEDLE, DOWN)[0] == pytest.approx(P, rel=0.05)


def test_irregular_free_end_turns_are_trimmed():
    frame = helix_frame([P] * 6 + [3 * P, 0.2 * P])  # unravelled last turns
    lam, per_turn = coil_pitch(frame, NEEDLE, DOWN)
    assert lam == pytest.approx(P, rel=0.02) and len(per_turn) == 5
    assert classify_regime([frame], None, NEEDLE, DOWN) == "drag_coiling"
    mixed = helix_frame([P, 3 * P, 0.2 * P, 2 * P, P, 0.5 * P, 4 * P, P])  # irregular
    assert classify_regime([mixed], None, NEEDLE, DOWN) == "chaotic_crumpling"


def test_period_doubling():
    p1, p2 = 4e-3, 8e-3
    frames, times = rotating([p1, p2] * 5, n=6)
    assert classify_regime(frames, times, NEEDLE, DOWN) == "period_doubling"
    lam, per_turn = coil_pitch(frames[-1], NEEDLE, DOWN)
    assert lam == pytest.approx(0.5 * (p1 + p2), rel=0.05)
    diffs = np.diff(per_turn)
    assert np.all(diffs[1:] * diffs[:-1] < 0)  # alternating
    m = measure_all(frames, times, NEEDLE, DOWN, H, R_FIL)
    assert m["regime"] == "period_doubling"
    assert m["coil_pitch_m"] == pytest.approx(0.5 * (p1 + p2), rel=0.05)


def test_straight_line():
    frames = [
        np.column_stack([np.zeros(n), np.zeros(n), -np.arange(n)[::-1] * H]) for n in (10, 50, 100)
    ]
    times = [0.0, 1.0, 2.0]
    assert classify_regime(frames, times, NEEDLE, DOWN) == "straight"
    assert buckling_length(frames[-1], NEEDLE, DOWN) is None
    assert coil_radius(frames[-1], NEEDLE, DOWN) is None
    m = measure_all(frames, times, NEEDLE, DOWN, H, R_FIL)
    assert m["regime"] == "straight"
    assert m["coil_radius_m"] is None and m["coil_frequency_rad_s"] is None
    assert m["curvature_variance_1_m2"] == pytest.approx(0.0, abs=1e-12)


def random_walk(rng, n=600, stem=40, bias=0.0):
    """Stem then a freely jointed walk of n steps H (``bias``: downward drift per step)."""
    steps = rng.normal(size=(n, 3)) + bias * DOWN
    steps *= H / np.linalg.norm(steps, axis=1, keepdims=True)
    walk = -stem * H * np.array([0, 0, 1.0]) + np.cumsum(steps, axis=0)
    stem_pts = np.column_stack([np.zeros(stem), np.zeros(stem), -np.arange(stem) * H])
    return np.vstack([stem_pts, walk])[::-1].copy()


def test_random_walk_is_chaotic():
    rng = np.random.default_rng(0)
    for _ in range(5):  # undirected crumpled blobs
        assert classify_regime([random_walk(rng)], None, NEEDLE, DOWN) == "chaotic_crumpling"
    frames = [random_walk(rng, bias=0.5) for _ in range(5)]  # a descending, widening plume
    times = np.arange(5.0)
    assert classify_regime(frames, times, NEEDLE, DOWN) == "chaotic_crumpling"
    m = measure_all(frames, times, NEEDLE, DOWN, H, R_FIL)
    assert m["regime"] == "chaotic_crumpling"
    assert m["coil_radius_m"] is None and m["coil_pitch_m"] is None
    assert m["plume_opening_angle_rad"] is not None and m["plume_opening_angle_rad"] > 0
    assert m["curvature_variance_1_m2"] > 100 / R**2  # rough at the node scale
    assert curvature_variance(helix_frame([P] * 4)[:400]) < 1e-6 / R**2  # helix: constant kappa
    json.dumps(m, allow_nan=False)


def test_plume_angle_of_points_in_a_cone():
    rng = np.random.default_rng(3)
    half, depth, n = 0.25, 0.05, 4000
    a0 = 0.1 * depth
    a = (a0**3 + rng.random(n) * (depth**3 - a0**3)) ** (1 / 3)  # uniform in volume
    rho = a * math.tan(half) * np.sqrt(rng.random(n))
    ang = rng.random(n) * 2 * np.pi
    pts = np.column_stack([rho * np.cos(ang), rho * np.sin(ang), -a])
    assert plume_angle(pts, NEEDLE, DOWN) == pytest.approx(2 * half, rel=0.1)
    line = np.column_stack([np.zeros(20), np.zeros(20), -np.linspace(0.05, 0, 20)])
    assert plume_angle(line, NEEDLE, DOWN) == pytest.approx(0.0, abs=1e-12)


def test_rope_coiling_on_floor():
    z_floor = -ELL - R_FIL  # coils at z_floor + r, below a vertical stem
    frames, times = rotating([0.0] * 4, n=8, stem=ELL, z_flat=-ELL, drift=1e-3)
    assert classify_regime(frames, times, NEEDLE, DOWN, radius=R_FIL, z_floor=z_floor) == (
        "rope_coiling"
    )
    # Without a floor the same shape is a flat suspended coil: drag coiling, zero pitch.
    assert classify_regime(frames, times, NEEDLE, DOWN) == "drag_coiling"
    m = measure_all(frames, times, NEEDLE, DOWN, H, R_FIL, z_floor=z_floor)
    assert m["regime"] == "rope_coiling"
    assert m["buckling_length_m"] == pytest.approx(ELL, rel=0.02)
    assert m["coil_radius_m"] == pytest.approx(R, rel=0.05)
    assert m["coil_pitch_m"] == pytest.approx(0.0, abs=1e-6)


def test_filament_bent_over_onto_the_floor_is_rope_coiling_without_a_coil_yet():
    z_floor = -ELL - R_FIL
    x = np.arange(1, 80) * H
    foot = np.column_stack([x, np.zeros_like(x), np.full_like(x, -ELL)])
    stem = np.column_stack([np.zeros(81), np.zeros(81), -np.linspace(0, ELL, 81)])
    frame = np.vstack([stem, foot])[::-1]
    m = measure_all([frame], [0.0], NEEDLE, DOWN, H, R_FIL, z_floor=z_floor)
    assert m["regime"] == "rope_coiling"
    assert m["buckling_length_m"] == pytest.approx(ELL, rel=0.02)
    assert m["coil_radius_m"] is None and m["coil_frequency_rad_s"] is None


def test_drag_coils_above_a_distant_floor_are_not_rope_coiling():
    frames, times = rotating([P] * 6, n=5)
    z_floor = -ELL - 6 * P - 2e-3  # floor well below the coil stack
    assert classify_regime(frames, times, NEEDLE, DOWN, z_floor=z_floor) == "drag_coiling"


def test_curvature_variance_circle_and_known_distribution():
    rc = 0.01
    th = np.linspace(0.0, 2 * np.pi, 400)
    circle = np.column_stack([rc * np.cos(th), rc * np.sin(th), np.zeros_like(th)])
    assert curvature_variance(circle) == pytest.approx(0.0, abs=1e-6 / rc**2)
    # kappa(s) = k0 + k1 sin(2 pi s / lam) over whole periods: variance k1^2 / 2.
    k0, k1, lam, ds = 50.0, 30.0, 0.05, 0.05 / 1000
    s_mid = (np.arange(4000) + 0.5) * ds
    theta = k0 * s_mid - k1 * lam / (2 * np.pi) * np.cos(2 * np.pi * s_mid / lam)
    steps = np.column_stack([np.cos(theta), np.sin(theta), np.zeros_like(theta)]) * ds
    pts = np.vstack([np.zeros(3), np.cumsum(steps, axis=0)])
    assert curvature_variance(pts) == pytest.approx(k1**2 / 2, rel=0.02)
    assert curvature_variance(pts, spacing=10 * ds) == pytest.approx(k1**2 / 2, rel=0.03)


@pytest.mark.parametrize(
    "frames",
    [
        [],
        [np.array([[0.0, 0.0, -H], [0.0, 0.0, 0.0]])],
        [np.array([[0.0, 0.0, 0.0]])],
        [np.array([[1e-3, 0.0, -H], [0.0, 2e-4, -0.5 * H], [0.0, 0.0, 0.0]])],
        [np.full((10, 3), np.nan)],
        [np.zeros((5, 3))],
        [np.array([[np.nan, 0, 0], [0, 0, -H], [1e-4, 0, -2 * H], [0, 0, 0]])],
        [np.zeros((0, 3)), "junk", np.ones((4, 2))],
    ],
)
def test_robust_on_degenerate_input(frames):
    for z_floor in (None, -1e-3):
        m = measure_all(frames, [0.0] * len(frames), NEEDLE, DOWN, H, R_FIL, z_floor=z_floor)
        assert tuple(m) == MEASURE_KEYS and m["regime"] in REGIMES
        json.dumps(m, allow_nan=False)
        for k, val in m.items():
            assert val is None or isinstance(val, str if k == "regime" else float)


def test_odd_arguments_do_not_raise():
    f = helix_frame([P] * 3)
    assert measure_all([f], None, None, None, None, None)["regime"] in REGIMES
    assert measure_all([f], [0.0, 1.0], NEEDLE, [0, 0, 0], -1.0, float("nan"))["regime"]
    assert coil_frequency([f, f], [0.0, 0.0], NEEDLE, DOWN) is None
    assert coil_pitch(None) == (None, [])
    assert buckling_length("x") is None and curvature_variance(np.ones(7)) is None
    assert plume_angle(np.zeros((4, 3))) is None
    assert classify_regime(None) == "straight"


@pytest.mark.parametrize("roundoff_slope_m_s", [1.7e-18, -1.7e-18, 0.0])
def test_constant_length_is_not_growth_whatever_the_roundoff(monkeypatch, roundoff_slope_m_s):
    """A rotating coil of constant length: whatever sign the round-off of the length fit
    takes on a CPU (np.polyfit returned +1.7e-18 m/s on one, about -1e-18 on another), no
    growth rate is read from it, so the tracked frequency stands and aliased frames give
    None instead of a turn rate of ~0."""
    import bathprint.analysis.measure as measure

    real_polyfit = np.polyfit

    def polyfit(x, y, deg):  # the fit of a constant (the length) returns the round-off slope
        fit = real_polyfit(x, y, deg)
        y = np.asarray(y, dtype=float)
        if deg == 1 and np.ptp(y) <= 1e-12 * np.max(np.abs(y)):
            fit[0] = roundoff_slope_m_s
        return fit

    monkeypatch.setattr(measure.np, "polyfit", polyfit)
    frames, times = rotating([P] * 6)
    assert measure._length_rate(frames, times) is None
    assert coil_frequency(frames, times, NEEDLE, DOWN) == pytest.approx(OMEGA, rel=0.02)
    t8 = np.linspace(0.0, 3.0, 8)
    aliased = [helix_frame([P] * 4, phase=6.0 * t) for t in t8]
    assert coil_frequency(aliased, t8, NEEDLE, DOWN) is None


def test_length_rate_reads_real_growth():
    """A filament growing at v: the fitted rate is v (the threshold only removes round-off)."""
    import bathprint.analysis.measure as measure

    v, times = 0.01, np.linspace(0.0, 1.0, 11)
    frames = []
    for t in times:
        f = helix_frame([P] * 6)
        tail = f[0] - np.outer(np.arange(1, round(v * t / H) + 1) * H, [0.0, 0.0, 1.0])
        frames.append(np.vstack([tail[::-1], f]))
    assert measure._length_rate(frames, times) == pytest.approx(v, rel=0.1)


def tilted(frames, angle=0.3):
    """Frames and the needle direction rotated by ``angle`` (rad) about x: a generic
    orientation, in which exact zeros (a flat coil's pitch) come out as round-off."""
    c, s = math.cos(angle), math.sin(angle)
    rot = np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])
    return [f @ rot.T for f in frames], rot @ DOWN


def ulp_perturbed(frame, rng):
    """Every coordinate moved by 0 or 1 ulp towards a random side."""
    side = rng.choice([-np.inf, np.inf], size=frame.shape)
    return np.where(rng.random(frame.shape) < 0.5, frame, np.nextafter(frame, side))


def test_flat_coil_has_one_label_whatever_the_roundoff():
    """Flat coils (zero pitch) seen from a tilted needle: each per-turn pitch is round-off
    (~1e-18 m, its sign set by the BLAS kernels), which once labelled the frames
    drag_coiling, chaotic_crumpling or period_doubling by chance (period_doubling overall
    with OpenBLAS's Prescott and Sandybridge kernels, drag_coiling with Haswell and
    SkylakeX). Every frame and every 1-ulp perturbation of it is now a drag coil."""
    frames, times = rotating([0.0] * 6, n=8, stem=ELL, z_flat=-ELL, drift=0.3e-3)
    frames, d = tilted(frames)
    rng = np.random.default_rng(7)
    labels = set()
    for f in frames:
        for g in [f] + [ulp_perturbed(f, rng) for _ in range(4)]:
            labels.add(classify_regime([g], None, NEEDLE, d, n_vote=1))
            lam, per_turn = coil_pitch(g, NEEDLE, d)
            assert lam == pytest.approx(0.0, abs=1e-12) and len(per_turn) >= 4
    assert labels == {"drag_coiling"}
    m = measure_all(frames, times, NEEDLE, d, H, R_FIL)
    assert m["regime"] == "drag_coiling"
    assert m["coil_radius_m"] == pytest.approx(R, rel=0.05)
    assert m["coil_pitch_m"] == pytest.approx(0.0, abs=1e-12)
    assert m["coil_frequency_rad_s"] == pytest.approx(OMEGA, rel=0.05)


def test_coil_on_edge_axis_and_radius_do_not_depend_on_roundoff():
    """A horizontal coil axis with no advance along it: the axis's sign was read from the
    round-off of the end-to-end advance and flipped under 1-ulp perturbations, and a turn
    ending exactly on a node took one more node into its circle fit by chance (R moved by
    4e-5 of itself). Both are now the same for every perturbation."""
    from bathprint.analysis.measure import coil_geometry

    frame = coil_on_edge()
    rng = np.random.default_rng(3)
    variants = [frame] + [ulp_perturbed(frame, rng) for _ in range(8)]
    geos = [coil_geometry(g, NEEDLE, DOWN) for g in variants]
    axis = np.array(geos[0].axis)
    assert abs(axis @ DOWN) < 1e-9 and geos[0].full_turns >= 4  # horizontal, several turns
    np.testing.assert_allclose([g.axis for g in geos], [axis] * len(geos), rtol=0, atol=1e-12)
    radii = [g.radius for g in geos]
    assert radii == pytest.approx([R] * len(geos), rel=0.01)
    assert np.ptp(radii) <= 1e-9 * R
    assert [g.pitch for g in geos] == pytest.approx([0.0] * len(geos), abs=1e-12)
    assert classify_regime([frame], None, NEEDLE, DOWN) == "drag_coiling"


def test_a_pile_at_one_depth_has_no_plume_angle_whatever_the_needle_tilt():
    """Points on one plane normal to the needle: their depths are equal (exactly with an
    axis-aligned needle, to ~1e-17 m with a tilted one). A line fitted across that
    round-off spread gave an angle of ~0.24 rad and a RankWarning; it is None either way."""
    import warnings

    rng = np.random.default_rng(5)
    r, th = R * np.sqrt(rng.random(200)), rng.random(200) * 2 * np.pi
    disc = np.column_stack([r * np.cos(th), r * np.sin(th), np.full(200, -ELL)])
    (tilted_disc,), d = tilted([disc])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert plume_angle(disc, NEEDLE, DOWN) is None
        assert plume_angle(tilted_disc, NEEDLE, d) is None
        # a real cone seen from the same tilted needle is still measured
        (tilted_cone,), _ = tilted([disc * [1.0, 1.0, 0.0] + np.outer(-r / 0.2, [0, 0, 1.0])])
        assert plume_angle(tilted_cone, NEEDLE, d) == pytest.approx(2 * math.atan(0.2), rel=0.1)
    assert not caught

"""The measurements' other definitions on synthetic curves with known answers: the buckling
length by 2r, by a quarter of the largest excursion and at the coil's full radius, omega in
Hz and omega R / v, and the smallest gap between non-adjacent segments."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from bathprint.analysis.measure import (
    FULL_RADIUS_FRACTION,
    GAP_RATIO_CAP,
    MEASURE_KEYS,
    buckling_length_definitions,
    measure_all,
    min_gap_ratio,
    touching_gaps,
)
from bathprint.core.effects.contact import min_separation_for

NEEDLE = np.zeros(3)
DOWN = np.array([0.0, 0.0, -1.0])
R, P, ELL, H = 5e-3, 6e-3, 20e-3, 0.1e-3  # coil radius, pitch, stem, node spacing (m)
R_FIL = 0.2e-3  # filament radius (m)
OMEGA = 2.0  # rad/s
FLARE_TURNS, FLARE_PITCH = 1.5, 8e-3  # the coil widens from the axis to R over 1.5 turns


def flared_helix(phase: float = 0.0, turns: int = 8, tail: float = 0.0) -> np.ndarray:
    """Needle at the origin pointing -z: a straight stem of length ELL, a flare whose lateral
    distance grows linearly in the turning angle phi from 0 to R over FLARE_TURNS turns while
    it descends FLARE_PITCH per turn, then a helix of radius R and pitch P; all rotated by
    ``phase``; ``tail``: a straight vertical piece of that length hanging from the free end.
    Nodes are uniform in phi on the flare, so lateral distance and depth are both linear
    between nodes there. Returned free end first."""
    n_stem = round(ELL / H)
    stem = np.column_stack([np.zeros(n_stem), np.zeros(n_stem), -np.arange(n_stem) * H])
    phi_f = 2 * np.pi * FLARE_TURNS
    n_f = 600
    phi = np.linspace(0.0, phi_f, n_f + 1)
    rho = R * phi / phi_f
    flare = np.column_stack(
        [rho * np.cos(phi), rho * np.sin(phi), -ELL - FLARE_PITCH * phi / (2 * np.pi)]
    )
    n_c = int(np.ceil(2 * np.pi * turns * R / H))
    psi = phi_f + np.linspace(0.0, 2 * np.pi * turns, n_c + 1)[1:]
    z0 = -ELL - FLARE_PITCH * FLARE_TURNS
    coil = np.column_stack([R * np.cos(psi), R * np.sin(psi), z0 - P * (psi - phi_f) / (2 * np.pi)])
    pts = np.vstack([stem, flare, coil])
    if tail > 0:
        n_t = max(1, round(tail / H))
        pts = np.vstack([pts, pts[-1] + np.outer(np.arange(1, n_t + 1) * H, DOWN)])
    c, s = math.cos(phase), math.sin(phase)
    pts = pts @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return pts[::-1].copy()


def depth_at_lateral_distance(rho: float) -> float:
    """Depth (m) where the flare's lateral distance is rho (0 < rho < R)."""
    return ELL + FLARE_PITCH * FLARE_TURNS * rho / R


def test_three_definitions_of_the_buckling_length_on_a_flared_helix() -> None:
    frame = flared_helix()
    ells = buckling_length_definitions(frame, NEEDLE, DOWN, radius=R_FIL, coil_radius=R)
    assert ells["two_radii"] == pytest.approx(depth_at_lateral_distance(2 * R_FIL), rel=1e-9)
    assert ells["quarter"] == pytest.approx(depth_at_lateral_distance(0.25 * R), rel=1e-9)
    full = depth_at_lateral_distance(FULL_RADIUS_FRACTION * R)
    assert ells["full_radius"] == pytest.approx(full, rel=1e-9)
    assert ells["two_radii"] < ells["quarter"] < ells["full_radius"]
    none = buckling_length_definitions(frame, NEEDLE, DOWN)
    assert none["two_radii"] is None and none["full_radius"] is None
    assert none["quarter"] == ells["quarter"]


def test_measure_all_reports_the_definitions_with_its_own_coil_radius() -> None:
    times = np.linspace(0.0, 2.0, 41)
    frames = [flared_helix(phase=OMEGA * t) for t in times]
    m = measure_all(frames, times, NEEDLE, DOWN, H, R_FIL)
    assert tuple(m) == MEASURE_KEYS
    assert m["regime"] == "drag_coiling"
    assert m["coil_radius_m"] == pytest.approx(R, rel=0.01)  # the per-turn fits
    assert m["buckling_length_2r_m"] == pytest.approx(
        depth_at_lateral_distance(2 * R_FIL), rel=1e-9
    )
    assert m["buckling_length_quarter_m"] == pytest.approx(
        depth_at_lateral_distance(0.25 * R), rel=1e-9
    )
    assert m["buckling_length_full_radius_m"] == pytest.approx(
        depth_at_lateral_distance(FULL_RADIUS_FRACTION * m["coil_radius_m"]), rel=1e-9
    )
    # the paper-inset l uses max(r, a quarter of the largest excursion): here the quarter
    assert m["buckling_length_m"] == pytest.approx(m["buckling_length_quarter_m"], rel=1e-12)
    assert m["coil_frequency_rad_s"] == pytest.approx(OMEGA, rel=0.02)
    assert m["coil_frequency_hz"] == pytest.approx(m["coil_frequency_rad_s"] / (2 * math.pi))
    assert m["omega_r_over_v"] is None  # a rigid rotation: the length does not grow


def test_omega_r_over_v_with_a_given_speed_and_from_the_growing_length() -> None:
    v = 0.012  # m/s
    times = np.linspace(0.0, 1.0, 41)
    rigid = [flared_helix(phase=OMEGA * t) for t in times]
    m = measure_all(rigid, times, NEEDLE, DOWN, H, R_FIL, v=v)
    omega, big_r = m["coil_frequency_rad_s"], m["coil_radius_m"]
    assert m["omega_r_over_v"] == pytest.approx(omega * big_r / v, rel=1e-12)
    assert m["omega_r_over_v"] == pytest.approx(OMEGA * R / v, rel=0.02)
    # without v: the growth rate of the arclength (a tail growing at v at the free end)
    growing = [flared_helix(phase=OMEGA * t, tail=1e-3 + v * t) for t in times]
    g = measure_all(growing, times, NEEDLE, DOWN, H, R_FIL)
    assert g["omega_r_over_v"] == pytest.approx(OMEGA * R / v, rel=0.03)


def helix_gap(radius: float, pitch: float) -> float:
    """Smallest distance between points of successive turns of a helix (m)."""

    def d2(delta: float) -> float:
        return 2 * radius**2 * (1 - math.cos(delta)) + (pitch * (1 + delta / (2 * np.pi))) ** 2

    return math.sqrt(minimize_scalar(d2, bounds=(-1.0, 1.0), method="bounded").fun)


def helix(pitch: float, turns: int = 5) -> np.ndarray:
    n = int(np.ceil(2 * np.pi * turns * R / H))
    phi = np.linspace(0.0, 2 * np.pi * turns, n + 1)
    return np.column_stack([R * np.cos(phi), R * np.sin(phi), -pitch * phi / (2 * np.pi)])


@pytest.mark.parametrize("pitch_over_2r", [0.5, 1.0, 1.5])
def test_min_gap_ratio_of_a_helix_is_its_pitch_over_the_contact_distance(
    pitch_over_2r: float,
) -> None:
    pitch = pitch_over_2r * 2 * R_FIL
    frame = helix(pitch)
    expected = helix_gap(R, pitch) / (2 * R_FIL)
    assert expected == pytest.approx(pitch_over_2r, rel=1e-3)
    # chords of the helix: the turns move inward alike, so the gap holds to the sagitta
    assert min_gap_ratio([frame], R_FIL) == pytest.approx(expected, rel=1e-3)
    assert min_gap_ratio([helix(3 * pitch), frame], R_FIL) == pytest.approx(expected, rel=1e-3)


def test_touching_gaps_of_a_helix_with_one_sunken_turn() -> None:
    # a helix at pitch 2r: every segment with a turn below or above touches at 1; then one
    # turn sunk by 4% of 2r onto the one below (its neighbours' gaps: 0.96 and 1.04)
    frame = helix(2 * R_FIL)
    g = touching_gaps(frame, R_FIL)
    exact = helix_gap(R, 2 * R_FIL) / (2 * R_FIL)
    assert g["touching"] == len(frame) - 1
    for key in ("min", "p10", "median"):
        assert g[key] == pytest.approx(exact, rel=1e-3), key
    sunk = frame.copy()
    turn = np.floor(-frame[:, 2] / (2 * R_FIL))  # the turning angle / 2 pi
    sunk[turn == 2, 2] -= 0.04 * 2 * R_FIL
    g = touching_gaps(sunk, R_FIL)
    assert g["min"] == pytest.approx(0.96 * exact, rel=2e-3)
    assert g["median"] == pytest.approx(exact, rel=1e-3)  # most turns are untouched
    assert touching_gaps(helix(3 * 2 * R_FIL), R_FIL) is None  # nothing within 1.1 x 2r
    assert touching_gaps(frame, None) is None


def test_min_gap_ratio_of_crossing_and_distant_segments() -> None:
    # two straight legs joined far away, crossing at 90 degrees 0.05 r apart
    a = np.column_stack([np.linspace(-5e-3, 5e-3, 101), np.zeros(101), np.zeros(101)])
    link = np.array([[5e-3, 0.0, 2e-3], [0.0, 5e-3, 2e-3]])
    b = np.column_stack([np.zeros(101), np.linspace(5e-3, -5e-3, 101), np.full(101, 1e-5)])
    frame = np.vstack([a, link, b])
    assert min_gap_ratio([frame], R_FIL) == pytest.approx(1e-5 / (2 * R_FIL), rel=1e-6)
    # a straight filament: the nearest pair that is not adjacent (min_separation_for
    # segments apart along it), no pair within GAP_RATIO_CAP contact distances: the cap
    line = np.column_stack([np.zeros(200), np.zeros(200), -np.arange(200) * H])
    nearest = min_separation_for(2 * R_FIL, H) * H / (2 * R_FIL)
    assert 1.6 <= nearest < GAP_RATIO_CAP
    assert min_gap_ratio([line], R_FIL) == pytest.approx(nearest, rel=1e-9)
    sparse = line[::10]  # segments 5 r long: no pair within reach
    assert min_gap_ratio([sparse], R_FIL) == GAP_RATIO_CAP
    assert min_gap_ratio([line], None) is None and min_gap_ratio([line[:3]], R_FIL) is None


def test_a_straight_filament_has_no_lengths_but_a_gap() -> None:
    line = np.column_stack([np.zeros(100), np.zeros(100), -np.arange(100)[::-1] * H])
    m = measure_all([line, line], [0.0, 1.0], NEEDLE, DOWN, H, R_FIL)
    assert m["regime"] == "straight"
    for key in MEASURE_KEYS[7:-1]:
        assert m[key] is None, key
    assert m["min_gap_ratio"] == pytest.approx(min_separation_for(2 * R_FIL, H) * H / (2 * R_FIL))

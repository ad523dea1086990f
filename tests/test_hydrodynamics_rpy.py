"""The hydrodynamics effect's RPY kernel (``hydrodynamics.kernel = "rpy"``): the tensor
against Zuk et al. (2014) and its limits, its positive definiteness where Lighthill's
Stokeslet segments lose it (turns pressed onto and through each other), its gates, and a
straight rod's drag against Tirado's cylinder."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from bathprint import Simulation
from bathprint.analysis import validation as V
from bathprint.core.effects import _rpy

MM = 1e-3
MU = 1e-3


def _rpy_matrix(points: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """8 pi mu x the RPY mobility of blobs at ``points`` (dense 3n square)."""
    n = len(points)
    out = np.zeros((3 * n, 3 * n))
    for i in range(n):
        for j in range(n):
            r = points[i] - points[j]
            dist = float(np.linalg.norm(r))
            c_iso, c_rr = _rpy.rpy_coefficients(dist, radii[i], radii[j])
            rr = np.outer(r, r) / dist**2 if dist > 0 else np.zeros((3, 3))
            out[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] = c_iso * np.eye(3) + c_rr * rr
    return out


def test_the_rpy_tensor_is_continuous_and_has_its_limits() -> None:
    """Zuk et al.'s three regimes meet: at R = b_i + b_j and at R = |b_i - b_j| (then the
    larger blob's self-mobility, isotropic); equal blobs give Rotne-Prager's overlapping
    form (1 - 9R/(32b)) I + (3R/(32b)) RR over 6 pi mu b; far away the Stokeslet."""
    bi, bj = 1.0, 0.6
    for dist in (bi + bj, bi - bj):
        below = _rpy.rpy_coefficients(dist * (1 - 1e-9), bi, bj)
        above = _rpy.rpy_coefficients(dist * (1 + 1e-9), bi, bj)
        np.testing.assert_allclose(below, above, rtol=1e-6, atol=1e-9)
    iso, rr = _rpy.rpy_coefficients(0.99 * (bi - bj), bi, bj)
    assert iso == pytest.approx(4.0 / (3.0 * bi), rel=1e-12) and abs(rr) < 1e-15
    b, dist = 0.7, 0.9
    iso, rr = _rpy.rpy_coefficients(dist, b, b)
    assert iso == pytest.approx(4.0 / (3.0 * b) * (1 - 9 * dist / (32 * b)), rel=1e-12)
    assert rr == pytest.approx(4.0 / (3.0 * b) * 3 * dist / (32 * b), rel=1e-12)
    far = 1e4
    iso, rr = _rpy.rpy_coefficients(far, bi, bj)
    assert iso * far == pytest.approx(1.0, rel=1e-7) and rr * far == pytest.approx(1.0, rel=1e-7)


def test_the_rpy_matrix_is_positive_semi_definite_for_overlapping_clusters() -> None:
    """Forty blobs of unequal radii packed so that many overlap, some inside others: the
    RPY mobility is symmetric and positive semi-definite (Zuk et al. 2014)."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        points = rng.normal(size=(40, 3)) * rng.uniform(0.3, 3.0)
        radii = rng.uniform(0.2, 1.5, size=40)
        mob = _rpy_matrix(points, radii)
        np.testing.assert_allclose(mob, mob.T, rtol=0, atol=1e-14 * np.abs(mob).max())
        eig = np.linalg.eigvalsh(mob)
        assert eig.min() > -1e-12 * eig.max()


def test_screening_by_paciorek_kernel_keeps_the_mobility_positive_semi_definite() -> None:
    """Why the RPY kernel screens each pair with Paciorek & Schervish's nonstationary kernel
    (:func:`_rpy.screening_factor`): on clusters of blobs with Oseen lengths that differ from
    node to node by up to 1000 times (some unscreened), the screened mobility stays positive
    semi-definite, while screening each pair by exp(-R / min(l_i, l_j)), the symmetric form
    closest to the slender-body kernel's, makes some of the same clusters indefinite."""
    rng = np.random.default_rng(1)
    worst_min, worst_paciorek = np.inf, np.inf
    for trial in range(10):
        points = rng.normal(size=(40, 3)) * rng.uniform(0.5, 5.0)
        lengths = np.exp(rng.uniform(math.log(0.05), math.log(50.0), size=40))
        if trial % 2:
            lengths[rng.uniform(size=40) < 0.3] = np.inf
        mob = _rpy_matrix(points, np.ones(40))
        dist = np.linalg.norm(points[:, None] - points[None], axis=2)
        shorter = np.exp(-dist / np.minimum(lengths[:, None], lengths[None]))
        paciorek = np.array(
            [
                [_rpy.screening_factor(dist[i, j], lengths[i], lengths[j]) for j in range(40)]
                for i in range(40)
            ]
        )
        for screen in (shorter, paciorek):
            eig = np.linalg.eigvalsh(mob * np.kron(screen, np.ones((3, 3))))
            ratio = eig.min() / eig.max()
            if screen is shorter:
                worst_min = min(worst_min, ratio)
            else:
                worst_paciorek = min(worst_paciorek, ratio)
    assert worst_min < -1e-3
    assert worst_paciorek > -1e-12


def test_paciorek_screening_is_the_slender_body_kernels_for_equal_lengths() -> None:
    """Equal Oseen lengths: exp(-R / l) (the slender_body kernel's screening, which makes a
    long rod feel Lamb's drag); unequal ones weaken the pair by (2 q / (1 + q^2))^(3/2) at
    R = 0 (q their ratio); unscreened pairs 1; a screened node and an unscreened one 0."""
    assert _rpy.screening_factor(2.0, 3.0, 3.0) == pytest.approx(math.exp(-2.0 / 3.0), rel=1e-14)
    q = 0.25
    assert _rpy.screening_factor(0.0, 1.0, 4.0) == pytest.approx((2 * q / (1 + q * q)) ** 1.5)
    assert _rpy.screening_factor(5.0, math.inf, math.inf) == 1.0
    assert _rpy.screening_factor(5.0, 1.0, math.inf) == 0.0
    assert _rpy.screening_factor(1.0, 2.0, 2.000001) == pytest.approx(math.exp(-0.5), rel=1e-6)
    assert _rpy.screening_factor(0.0, 0.0, 0.0) == 1.0  # infinite speeds: the own blob only
    assert _rpy.screening_factor(1.0, 0.0, 0.0) == 0.0
    for big in (1e-300, 1e300):  # no overflow or underflow to NaN
        assert math.isfinite(_rpy.screening_factor(1.0, big, 0.5 * big))


@pytest.mark.parametrize("aspect", [20, 50, 100])
def test_straight_cylinder_drag_with_the_rpy_kernel_against_tirado(aspect: int) -> None:
    """A rigid cylinder along and across its axis with the RPY kernel (blobs of twice the
    radius, two segments per diameter): within 5% of Tirado's drags, and within 1.5% from
    aspect 50 (the slender-body kernel: 3%, its own test)."""
    sim = V.hydro_rod(aspect, 2 * aspect, kernel="rpy")
    length = aspect * 0.2e-3
    f_par, f_perp = V.cylinder_drag_tirado(aspect, MU, length)
    along = V.rigid_body_drag(sim, (0.0, 0.0, 1e-3))
    across = V.rigid_body_drag(sim, (1e-3, 0.0, 0.0))
    tol = 0.05 if aspect < 50 else 0.015
    assert abs(-along[2] / (f_par * 1e-3) - 1.0) < tol
    assert abs(-across[0] / (f_perp * 1e-3) - 1.0) < tol
    assert sim.ws.hydro.gate[: sim.n_nodes].min() == 1.0  # a straight rod: gates open


@pytest.mark.parametrize("drag_model", ["cox", "finite_re"])
@pytest.mark.parametrize("pitch_mm", [0.85, 0.0])
def test_the_rpy_mobility_is_positive_definite_on_turns_the_slender_body_one_is_not(
    pitch_mm: float, drag_model: str
) -> None:
    """Three turns pressed onto each other (pitch 0.85 (2r)) and through each other (pitch
    0), the implicit flow, Stokes or finite-Re drag: with Stokeslet segments the filament's
    mobility R^-1 + M W^-1 is not symmetric and has negative eigenvalues, and
    I + R M W^-1, which multiplies J_other in the Newton matrix, has eigenvalues of negative
    real part; with the RPY kernel the mobility is symmetric and positive definite and those
    real parts stay above 0.2 (Stokes drag) and 0.1 (finite-Re drag), also with the turns
    spinning at 0.02 and 0.2 m/s (Re_d = 20 and 200 in water: finite-Re drag's resistance
    and screening at work, gates closing)."""
    sb = V.turns_mobility(pitch_mm, "slender_body", drag_model)
    assert sb["eig_real_min"] < 0 and sb["mobility_min_over_max"] < 0 and sb["asymmetry"] > 1e-2
    speeds = (0.0,) if drag_model == "cox" else (0.0, 0.02, 0.2)
    for speed in speeds:
        rpy = V.turns_mobility(pitch_mm, "rpy", drag_model, speed)
        assert rpy["eig_real_min"] > (0.2 if drag_model == "cox" else 0.1)
        assert rpy["mobility_min_over_max"] > 0
        assert rpy["asymmetry"] < 1e-12
    assert drag_model == "cox" or rpy["gate_min"] < 1.0  # (at 0.2 m/s)


@pytest.mark.parametrize("screened", [False, True])
def test_the_gates_keep_the_mobility_positive_definite_where_the_law_resists_more(
    screened: bool,
) -> None:
    """Where a node's drag law resists more than the Stokes window (ten times here, as the
    finite-Re law does at speed), the blobs' share of its window would exceed its mobility:
    with the gates open (g = 1) the mobility R^-1 + M W^-1 of the pressed coil is
    indefinite; with the gates rpy_gates sets, the flow G S G less its window sums, it is
    positive definite, every gate below 1; unscreened, and screened with Oseen lengths from
    0.2 to 20 radii that differ from node to node."""
    pts = V.pressed_turns(0.85)
    n = len(pts)
    lengths = np.exp(np.random.default_rng(3).uniform(math.log(0.1), math.log(10.0), size=n))
    free = lengths * MM if screened else np.full(n, np.inf)
    r = 0.5 * MM
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    node_s = np.concatenate([[0.0], np.cumsum(seg)])
    weight = np.zeros(n)
    weight[:-1] += 0.5 * seg
    weight[1:] += 0.5 * seg
    a_cut = 3 * r
    blob = np.full(n, 2 * r)
    xi_par, xi_perp = 4 * math.pi * MU / 2.58, 8 * math.pi * MU / (2.58 + 2)  # Stokes window
    tang = np.gradient(pts, axis=0)
    tang /= np.linalg.norm(tang, axis=1)[:, None]
    resist = np.array(
        [
            10 * weight[i] * (xi_par * np.outer(t, t) + xi_perp * (np.eye(3) - np.outer(t, t)))
            for i, t in enumerate(tang)
        ]
    )
    pos = pts.ravel().copy()

    def mobility(gate: np.ndarray) -> np.ndarray:
        flow = np.zeros((3 * n, 3 * n))
        unit, out = np.zeros(3 * n), np.zeros(3 * n)
        for k in range(3 * n):
            unit[:] = 0.0
            unit[k] = 1.0
            _rpy.rpy_flow(pos, node_s, n, pos, node_s, n, unit, blob, gate, free, MU, a_cut, out)
            flow[:, k] = out
        return flow + np.linalg.inv(scipy.linalg.block_diag(*resist))

    opened = mobility(np.ones(n))
    assert np.linalg.eigvalsh(0.5 * (opened + opened.T)).min() < 0
    gate = np.ones(n)
    _rpy.rpy_gates(pos, node_s, n, blob, resist, free, a_cut, MU, gate)
    assert gate.max() < 1.0 and gate.min() > 0.0
    gated = mobility(gate)
    np.testing.assert_allclose(gated, gated.T, rtol=0, atol=1e-12 * np.abs(gated).max())
    assert np.linalg.eigvalsh(gated).min() > 0


def test_window_margin_and_shift() -> None:
    """The window's margin over the blobs' share grows with the blob radius and, at the
    default (blobs of twice the radius, window 3 r), stays above the gates' 5% for node
    spacings from 0.2 to 5 radii; the shift that matches the Stokeslet beyond the window
    lengthens the window along the filament and shortens it across (the blobs' flow is
    smoother there)."""
    margins = [_rpy.window_margin(s, 3.0, 1.0, 2.0) for s in (0.2, 0.5, 1.0, 1.9, 2.5, 5.0)]
    assert min(margins) > _rpy.GATE_MARGIN
    assert _rpy.window_margin(1.0, 3.0, 1.0, 3.0) > _rpy.window_margin(1.0, 3.0, 1.0, 2.0)
    along, across = _rpy.window_shift(3.0, 2.0)
    assert along > 0 > across
    # beyond 2b the closed form: 2b^2/(3x^2) along (halved in Lam), -b^2/(3x^2) across
    along, across = _rpy.window_shift(5.0, 2.0)
    assert along == pytest.approx(4.0 / 75.0, rel=1e-12)
    assert across == pytest.approx(-4.0 / 75.0, rel=1e-12)


def test_a_sedimenting_filament_with_the_rpy_kernel() -> None:
    """The weakly flexible filament of the slender-body kernel's test (l/r = 50) sedimenting
    broadside with the RPY kernel: its speed within 1% of the rigid cylinder's (Tirado),
    its U shape within 3% of Xu & Nadim's everywhere, and both couplings, lagged and
    implicit, at the same steady state. (Its end lag exceeds Xu & Nadim's leading order by
    22%, the slender-body kernel's by 11%: docs/physics/hydrodynamics.md.)"""
    runs = {
        c: V.sedimenting_filament(
            aspect=50.0, deflection_scale=0.2, n_segments=60, coupling=c, kernel="rpy"
        )
        for c in ("implicit", "lagged")
    }
    r = runs["implicit"]
    assert abs(r["speed"] / r["rigid_speed_tirado"] - 1.0) < 0.01
    lag = r["lag"]
    end = 0.5 * (lag[0] + lag[-1])
    y_end = float(V.xu_nadim_shape(np.array([1.0]))[0])
    assert end > 0.0
    assert np.max(np.abs(lag / end - V.xu_nadim_shape(r["xi"]) / y_end)) < 0.03
    other = runs["lagged"]
    assert abs(other["speed"] / r["speed"] - 1.0) < 1e-4
    assert abs(0.5 * (other["lag"][0] + other["lag"][-1]) / end - 1.0) < 1e-3


@pytest.mark.slow
def test_the_ablations_all_passes_the_pile_where_the_stokeslet_segments_stall() -> None:
    """The hard case: the ablation's "all" at d = 0.41 mm, 0.5 ml/min (inertia, contact,
    finite-Re drag, the implicit nonlocal flow of the RPY kernel) advanced through its frames
    to 2 s, past the pile where the Stokeslet segments' GMRES stalls (1.82 s) and where a
    version with the law at the velocity relative to the flow stalled (0.81 s): no Krylov
    solve fails, the turns stay apart (smallest gap above 0.9 of the sum of the radii)."""
    from bathprint.analysis.measure import min_gap_ratio
    from bathprint.studies.reproduce import ablation

    runs, _ = ablation.plan()
    over = next(
        r["overrides"]
        for r in runs
        if r["set"] == "fig2" and r["point"] == (0.41, 0.5) and r["variant"] == "all"
    )
    assert over["hydrodynamics.kernel"] == "rpy" and over["drag.model"] == "finite_re"
    sim = Simulation(ablation.SCENE, {**over, "outputs.plot": False})
    frame = over["outputs.frame_interval_s"]
    gaps = []
    for t in np.arange(1, int(round(2.0 / frame)) + 1) * frame:
        sim.advance(float(t))
        gap = min_gap_ratio([sim.centerline()], float(sim.model.radius))
        gaps.append(math.inf if gap is None else gap)
    counts = sim.counts()
    assert sim.t > 1.9 and counts["krylov_failures"] == 0
    assert min(gaps) > 0.9

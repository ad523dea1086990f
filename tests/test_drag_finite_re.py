"""drag.model = 'finite_re': the cylinder drag curve against experiment, the law's limits and
smoothness, its exact Jacobians, the kernel in a scene, and its bad input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint import Simulation
from bathprint.analysis import validation as V
from bathprint.core.effects import _drag_laws as C
from bathprint.core.effects import drag
from bathprint.errors import SceneError

MU, RHO, LENGTH = 1.0e-3, 1051.0, 0.020  # the CaCl2 bath; L = 20 mm (drag.length_scale_mm)


@pytest.mark.parametrize("re", [0.1, 1.0, 10.0, 100.0])
def test_cylinder_drag_curve_within_10_percent_of_experiment(re: float) -> None:
    """The normal law's C_D (infinite cylinder) against the experimental drag curve."""
    law = C.cd_cylinder(re)[0]
    data = V.cylinder_drag_data(re)
    assert abs(law / data - 1.0) < 0.10, (re, law, data)


def test_lamb_below_the_blend_and_cheng_above() -> None:
    for re in (1e-3, 0.01, 0.2):
        assert C.cd_cylinder(re)[0] == pytest.approx(C.cd_lamb(re), rel=1e-12)
    for re in (1.0, 10.0, 1e3, 1e5):
        assert C.cd_cylinder(re)[0] == pytest.approx(C.cd_cheng(re), rel=1e-12)


def _fd(fun, x: float, h: float) -> float:
    return (fun(x + h) - fun(x - h)) / (2.0 * h)


@pytest.mark.parametrize("l_over_a", [np.inf, 20.0, 97.56, 400.0])
def test_normal_law_continuous_and_differentiable_across_the_blend(l_over_a: float) -> None:
    for re0 in (C.RE_BLEND_LO, C.RE_BLEND_HI):
        for side in (-1.0, 1.0):
            re = re0 * (1.0 + side * 1e-3)
            dg = C.normal_g(re, l_over_a)[1]
            assert dg == pytest.approx(
                _fd(lambda r: C.normal_g(r, l_over_a)[0], re, re * 1e-6), rel=1e-6
            )
        below = C.normal_g(re0 * (1.0 - 1e-9), l_over_a)
        above = C.normal_g(re0 * (1.0 + 1e-9), l_over_a)
        assert below[0] == pytest.approx(above[0], rel=1e-7)
        assert below[1] == pytest.approx(above[1], rel=1e-6)


@pytest.mark.parametrize("d", [0.1e-3, 0.41e-3, 2.0e-3])
@pytest.mark.parametrize("fun", [C.normal_drag, C.tangential_drag])
def test_drag_per_length_derivative_matches_finite_differences(d: float, fun) -> None:
    worst = 0.0
    for u in np.geomspace(1e-9, 10.0, 200):
        fd = _fd(lambda x: fun(x, d, MU, RHO, LENGTH)[0], u, u * 1e-5)
        worst = max(worst, abs(fun(u, d, MU, RHO, LENGTH)[1] / fd - 1.0))
    assert worst < 1e-7


def test_tangential_switch_at_z_one_is_smooth() -> None:
    u0 = 4.0 / math.e * MU / (RHO * LENGTH)  # z = sqrt(e Re_L)/2 = 1
    lo = C.tangential_coefficients(u0 * (1.0 - 1e-9), 0.41e-3, MU, RHO, LENGTH)
    hi = C.tangential_coefficients(u0 * (1.0 + 1e-9), 0.41e-3, MU, RHO, LENGTH)
    assert lo[0] == pytest.approx(hi[0], rel=1e-8)
    assert lo[1] == pytest.approx(hi[1], rel=1e-7)


@pytest.mark.parametrize("d", [0.1e-3, 0.41e-3, 2.0e-3])
def test_zero_speed_limit_is_cox(d: float) -> None:
    """At Re -> 0 the law is Cox's slender-body drag: normal 2 mu_s, tangential mu_s."""
    mu_s = 2.0 * math.pi * MU / math.log(2.0 * LENGTH / d)
    assert C.normal_coefficients(0.0, d, MU, RHO, LENGTH)[0] == pytest.approx(2 * mu_s, rel=1e-12)
    assert C.tangential_coefficients(0.0, d, MU, RHO, LENGTH)[0] == pytest.approx(mu_s, rel=1e-12)
    fn = C.normal_drag(1e-10, d, MU, RHO, LENGTH)[0]  # Re ~ 1e-8
    assert fn / (2.0 * mu_s * 1e-10) == pytest.approx(1.0, abs=0.01)


def test_long_filament_recovers_lamb() -> None:
    d, u = 0.41e-3, 1e-4
    re = RHO * u * d / MU
    lamb = 0.5 * MU * u * re * C.cd_lamb(re)
    assert C.normal_drag(u, d, MU, RHO, 1e3)[0] == pytest.approx(lamb, rel=1e-3)


def test_drag_is_increasing_and_never_below_stokes() -> None:
    d = 0.41e-3
    mu_s = 2.0 * math.pi * MU / math.log(2.0 * LENGTH / d)
    us = np.geomspace(1e-9, 10.0, 300)
    fn = np.array([C.normal_drag(u, d, MU, RHO, LENGTH)[0] for u in us])
    ft = np.array([C.tangential_drag(u, d, MU, RHO, LENGTH)[0] for u in us])
    assert np.all(np.diff(fn) > 0.0) and np.all(np.diff(ft) > 0.0)
    assert np.all(fn / (2.0 * mu_s * us) > 1.0 - 1e-12)
    assert np.all(ft / (mu_s * us) > 1.0 - 1e-12)


def _law(u, t, d, len_n=LENGTH, len_t=LENGTH):
    force, du, dt = np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3))
    power = C.law(*u, *t, d, MU, RHO, len_n, len_t, force, du, dt)
    return force, du, dt, power


def _cases(n: int, seed: int):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        d = 10.0 ** rng.uniform(-4.0, math.log10(2e-3))
        speed = 10.0 ** rng.uniform(-3.0, 3.0) * MU / (RHO * d)  # Re from 1e-3 to 1e3
        u = rng.normal(size=3)
        t = rng.normal(size=3)
        yield u * speed / np.linalg.norm(u), t / np.linalg.norm(t), d


def _central(fun, x: np.ndarray, h: float) -> np.ndarray:
    jac = np.zeros((3, 3))
    for b in range(3):
        e = np.zeros(3)
        e[b] = h
        jac[:, b] = (fun(x + e) - fun(x - e)) / (2.0 * h)
    return jac


@pytest.mark.parametrize("case", list(_cases(40, seed=1)))
def test_law_jacobians_match_central_differences(case) -> None:
    u, t, d = case
    force, du, dt, power = _law(u, t, d)
    assert np.dot(force, u) < 0.0 and power == pytest.approx(-np.dot(force, u), rel=1e-12)
    fd_u = _central(lambda x: _law(x, t, d)[0], u, 1e-6 * np.linalg.norm(u))
    fd_t = _central(lambda x: _law(u, x, d)[0], t, 1e-6)
    assert np.max(np.abs(du - fd_u)) < 1e-6 * np.max(np.abs(du))
    assert np.max(np.abs(dt - fd_t)) < 1e-6 * np.max(np.abs(dt))


def _oseen(b, u, t, d):
    force, du, dt, xi = np.zeros(3), np.zeros((3, 3)), np.zeros((3, 3)), np.zeros((3, 3))
    power = C.oseen_law(*b, *u, *t, d, MU, RHO, LENGTH, LENGTH, force, du, dt, xi)
    return force, du, dt, xi, power


def _clamped(b, u, t) -> bool:
    """Whether oseen_law's Jacobian clamps a component ratio of u to b."""
    sb, su = b @ t, u @ t
    wb, wu = b - sb * t, u - su * t
    top = C.OSEEN_JAC_RATIO_MAX
    return np.linalg.norm(wu) > top * np.linalg.norm(wb) or abs(su) > top * abs(sb)


def test_oseen_law_is_the_law_without_a_flow_and_linear_in_the_flow() -> None:
    """The law linearised about the motion relative to the bath: with no local flow (u = b)
    exactly :func:`law` (force and Jacobians); its resistance to a flow is
    g_n (I - t t^T) + g_t t t^T at b's speeds (symmetric, positive definite), and the force
    is affine in the flow with that slope."""
    worst = 0.0
    for b, t, d in _cases(20, seed=4):
        f_law, du_law, dt_law, p_law = _law(b, t, d)
        f, du, dt, xi, power = _oseen(b, b, t, d)
        np.testing.assert_array_equal(f, f_law)
        np.testing.assert_allclose(du, du_law, rtol=0, atol=1e-12 * np.abs(du_law).max())
        np.testing.assert_allclose(dt, dt_law, rtol=0, atol=1e-12 * np.abs(dt_law).max())
        assert power == pytest.approx(p_law, rel=1e-12)
        np.testing.assert_allclose(xi, xi.T, rtol=0, atol=1e-14 * np.abs(xi).max())
        assert np.linalg.eigvalsh(xi).min() > 0.0
        flow = np.random.default_rng(5).normal(size=3) * np.linalg.norm(b)
        f_flow = _oseen(b, b - flow, t, d)[0]
        worst = max(worst, np.abs(f_flow - (f + xi @ flow)).max() / np.abs(f).max())
    assert worst < 1e-12


def _oseen_cases(n: int, seed: int) -> list:
    """(b, u, t, d): _cases' velocities b with a random flow of b's size, where the
    Jacobian's component ratio is not clamped (most of them)."""
    out = []
    for b, t, d in _cases(n, seed):
        flow = np.random.default_rng(int(1e6 * d)).normal(size=3) * np.linalg.norm(b)
        if not _clamped(b, b - flow, t):
            out.append((b, b - flow, t, d))
    assert len(out) > 0.8 * n
    return out


@pytest.mark.parametrize("case", _oseen_cases(40, seed=2))
def test_oseen_law_jacobians_match_central_differences(case) -> None:
    """dF/dv (b and u move together, the flow held) and dF/dt against central differences
    (the cases where the Jacobian's component ratio is not clamped)."""
    b, u, t, d = case
    flow = b - u
    force, du, dt, xi, power = _oseen(b, u, t, d)
    assert power == pytest.approx(-np.dot(force, u), rel=1e-12)
    fd_u = _central(lambda x: _oseen(x, x - flow, t, d)[0], b, 1e-6 * np.linalg.norm(b))
    fd_t = _central(lambda x: _oseen(b, u, x, d)[0], t, 1e-6)
    assert np.max(np.abs(du - fd_u)) < 1e-5 * np.max(np.abs(du))
    assert np.max(np.abs(dt - fd_t)) < 1e-5 * np.max(np.abs(dt))


def test_oseen_law_where_the_jacobian_is_clamped_or_a_component_of_b_vanishes() -> None:
    """Where u's component is more than OSEEN_JAC_RATIO_MAX times b's, the coefficients'
    derivative enters as if it were that many times (finite, bounded by the clamp); where
    b's normal or tangential component is zero, it drops out (the exact derivative does not
    exist there) and dF/dv is -Xi on that component. The force is the linearised law
    throughout."""
    t = np.array([0.0, 0.6, 0.8])
    d = 0.41e-3
    n = np.array([1.0, 0.0, 0.0])  # normal to t
    top = C.OSEEN_JAC_RATIO_MAX
    b = 0.01 * n + 1e-6 * t  # tangential speed 1e-6 m/s
    u = 0.01 * n + 0.05 * t  # tangential ratio 5e4: clamped
    force, du, dt, xi, _ = _oseen(b, u, t, d)
    assert np.all(np.isfinite(du)) and np.all(np.isfinite(dt))
    np.testing.assert_allclose(force, -xi @ u, rtol=1e-12, atol=0)
    gt, fpt = C.tangential_coefficients(1e-6, d, MU, RHO, LENGTH)
    along = t @ du @ t  # -g_t - (f_t' - g_t) x the clamped ratio
    assert along == pytest.approx(-gt - (fpt - gt) * top, rel=1e-9)
    for b0 in (0.02 * t, 0.02 * n):  # no normal, then no tangential component
        force, du, dt, xi, _ = _oseen(b0, u, t, d)
        assert np.all(np.isfinite(du)) and np.all(np.isfinite(dt))
        np.testing.assert_allclose(force, -xi @ u, rtol=1e-12, atol=0)
        gone = n if b0 @ n == 0.0 else t  # the component whose derivative drops out
        assert gone @ du @ gone == pytest.approx(-(gone @ xi @ gone), rel=1e-12)


def test_law_is_linear_and_stokes_at_rest() -> None:
    t = np.array([0.0, 0.6, 0.8])
    d = 0.41e-3
    mu_s = 2.0 * math.pi * MU / math.log(2.0 * LENGTH / d)
    stokes = -mu_s * (2.0 * (np.eye(3) - np.outer(t, t)) + np.outer(t, t))
    force, du, dt, power = _law(np.zeros(3), t, d)
    assert np.all(force == 0.0) and power == 0.0
    np.testing.assert_allclose(du, stokes, rtol=1e-12, atol=0.0)
    np.testing.assert_allclose(dt, 0.0, atol=0.0)


def _rod(model: str, **extra) -> Simulation:
    return Simulation(
        "drag_coiling_22G",
        {
            "drag.model": model,
            "initial.length_mm": 10.0,
            "flow.q_outer_ml_min": 0.0,
            "needle.direction": [1.0, 0.0, 0.0],
            **extra,
        },
    )


def _translating_drag(sim: Simulation, velocity) -> np.ndarray:
    vel = np.tile(np.asarray(velocity, dtype=float), sim.capacity)
    inputs = sim.kernel_inputs(0.0, 0.0, 0.0, False, vel=vel)
    drag.accumulate(*inputs)
    return inputs[3].force[: 3 * (sim.n_nodes - 1)].reshape(-1, 3).sum(axis=0)


def test_finite_re_kernel_slow_rod_is_cox_and_fast_rod_is_the_law() -> None:
    """A straight 10 mm rod of d = 0.41 mm translating rigidly: at 10 nm/s (Re_d ~ 4e-6; the
    axial law's screening correction goes as sqrt(Re_L)) the finite_re kernel gives Cox's drag
    within 1%; at the exit speed of 22G at 0.5 ml/min
    (63 mm/s, Re_d = 27) across the axis it gives the law's f_n L (the kernel sums the law
    over the segments exactly), several times Cox's."""
    cox, fre = _rod("cox"), _rod("finite_re")
    length = float(np.sum(fre.rest_lengths()))
    for v in ((0.0, 1e-8, 0.0), (-1e-8, 0.0, 0.0)):
        np.testing.assert_allclose(
            _translating_drag(fre, v),
            _translating_drag(cox, v),
            rtol=0.01,
            atol=1e-3 * np.abs(_translating_drag(cox, v)).max(),
        )
    v_exit = 0.5e-6 / 60.0 / (math.pi * 0.41e-3**2 / 4.0)
    force = _translating_drag(fre, (0.0, v_exit, 0.0))
    f_n = C.normal_drag(v_exit, 0.41e-3, 1e-3, 1051.0, 0.020)[0]
    assert force[1] == pytest.approx(-f_n * length, rel=1e-9)
    assert -force[1] > 4.0 * 2.0 * cox.model.mu_s * v_exit * length


@pytest.mark.parametrize(
    "key, value",
    [
        ("drag.model", "stokes"),
        ("drag.model", 3),
        ("bath.viscosity_pa_s", 0.0),
        ("bath.viscosity_pa_s", -1e-3),
        ("bath.viscosity_pa_s", float("nan")),
        ("bath.density_kg_m3", 0.0),
        ("bath.density_kg_m3", -1051.0),
        ("bath.density_kg_m3", 1e6),
        ("drag.length_scale_mm", 0.3),  # L < e r: no slender body
    ],
)
def test_bad_drag_input_is_one_scene_error_naming_the_key(key: str, value) -> None:
    with pytest.raises(SceneError, match=key.split(".")[-1]):
        Simulation("drag_coiling_22G", {"drag.model": "finite_re", key: value})

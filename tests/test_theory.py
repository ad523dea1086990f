"""Scaling laws and the extruded rod's linear stability (bathprint.analysis.theory)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import lambertw

from bathprint.analysis import theory as T


def test_beta_critical_to_four_significant_figures() -> None:
    assert round(T.beta_critical(), 3) == 3.477
    assert abs(T.onset_condition(T.beta_critical())) < 1e-14


def test_spectral_onset_agrees_with_hypergeometric_condition() -> None:
    beta_c = T.beta_critical()
    assert abs(T.onset_beta_spectral() / beta_c - 1.0) < 1e-10
    # the ill-conditioned differentiation-matrix variant still agrees to 1e-6
    assert abs(T.onset_beta_spectral(24, "differentiation") / beta_c - 1.0) < 1e-6


def test_growth_rate_changes_sign_at_the_onset() -> None:
    beta_c = T.beta_critical()
    assert T.growth_rate(0.9 * beta_c) < -0.1
    assert T.growth_rate(1.1 * beta_c) > 0.1
    assert abs(T.growth_rate(beta_c)) < 1e-10
    # the crossing eigenvalue is real (no oscillatory onset)
    s = T.leading_eigenvalue(beta_c)
    assert abs(s.imag) <= 1e-12 * max(1.0, abs(s.real))


def test_second_mode_crosses_at_the_second_hypergeometric_root() -> None:
    beta_2 = brentq(T.onset_condition, 40.0, 48.0, xtol=1e-14)
    second = T.spectrum(beta_2)[1]
    assert abs(second) < 1e-9


def test_spectral_convergence_in_n() -> None:
    assert abs(T.growth_rate(5.0, 24) - T.growth_rate(5.0, 48)) < 1e-8
    assert abs(T.growth_rate(5.0, 32) - T.growth_rate(5.0, 64)) < 1e-8
    # the two discretisations agree (differentiation limited by round-off at ~1e-8)
    assert abs(T.growth_rate(5.0, 24, "differentiation") - T.growth_rate(5.0)) < 1e-6


@pytest.mark.parametrize("method", ["integration", "differentiation"])
def test_beta_zero_gives_cantilever_eigenvalues(method: str) -> None:
    # 2 s eta + eta'''' = 0, free-clamped: s = -k^4 / 2 with 1 + cos k cosh k = 0
    roots = [brentq(lambda k: 1.0 + math.cos(k) * math.cosh(k), a, b) for a, b in [(1, 3), (4, 5)]]
    assert abs(roots[0] - 1.8751040687) < 1e-9
    s = T.spectrum(0.0, 24, method)
    np.testing.assert_allclose(s[:2].real, [-(k**4) / 2 for k in roots], rtol=1e-8)
    assert np.all(np.abs(s[:2].imag) <= 1e-12 * np.maximum(1.0, np.abs(s[:2].real)))


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_infinite_eigenvalue_is_dropped_whatever_qz_leaves_in_beta(monkeypatch, sign) -> None:
    """The integration pencil has one infinite eigenvalue (its clamp row of M is zero).
    LAPACK's QZ returns its beta as exactly 0 here; a QZ that left round-off in it (~eps ||M||,
    either sign) would make it a finite s ~ 1e17 that leads the spectrum or trails it. It is
    dropped by number, so the spectrum is the same either way."""
    import scipy.linalg

    exact = T.spectrum(5.0, 24)
    real_eigvals = scipy.linalg.eigvals

    def eigvals(a, b=None, *args, homogeneous_eigvals=False, **kw):
        alpha, beta = real_eigvals(a, b, *args, homogeneous_eigvals=True, **kw)
        zero = beta == 0
        assert zero.sum() == 1  # what LAPACK gives: the premise of this emulation
        # round-off in place of the zero, signed so that alpha / beta has Re > 0
        side = np.where(alpha.real >= 0.0, sign, -sign)
        beta = np.where(zero, side * np.finfo(float).eps * np.abs(b).max(), beta.real)
        return np.vstack((alpha, beta)) if homogeneous_eigvals else alpha / beta

    monkeypatch.setattr(scipy.linalg, "eigvals", eigvals)
    got = T.spectrum(5.0, 24)
    assert len(got) == len(exact) == 24  # n + 1 nodes, one infinite eigenvalue dropped
    np.testing.assert_array_equal(got, exact)
    assert T.growth_rate(5.0, 24) == pytest.approx(exact[0].real, rel=1e-14)


def test_prefactors() -> None:
    assert T.critical_length_prefactor() == pytest.approx(1.514906, abs=1e-6)
    assert T.onset_frequency_prefactor() == pytest.approx(0.660107, abs=1e-6)
    assert T.critical_length(1e-9, 1e-3, 1e-3) == pytest.approx(0.1514906, rel=1e-6)


def test_scaling_laws_on_a_hand_computed_case() -> None:
    # B/(mu v) = 1e-9 / (1e-3 * 1e-3) = 1e-3 m^3 -> l = 0.1 m, v/l = 0.01 1/s
    assert T.buckling_length_scale(1e-9, 1e-3, 1e-3) == pytest.approx(0.1, rel=1e-12)
    assert T.coil_radius(1e-9, 1e-3, 1e-3) == pytest.approx(0.04, rel=1e-12)
    assert T.coil_frequency(1e-9, 1e-3, 1e-3) == pytest.approx(0.011, rel=1e-12)
    # mu v + drho g r^2 = 1e-6 + 50 * 9.81 * 1e-6 = 4.915e-4
    assert T.gravity_drag_length(1e-9, 1e-3, 1e-3, 50.0, 1e-3) == pytest.approx(
        (1e-9 / 4.915e-4) ** (1 / 3), rel=1e-12
    )
    # 2.7 kPa, r = 0.5 mm: 2700 * pi * 6.25e-14 / 4
    assert T.bending_stiffness(2.7e3, 5e-4) == pytest.approx(1.32536e-10, rel=1e-5)
    # 1 ml/min through a 1 mm needle: 1.6667e-8 / 7.854e-7
    assert T.exit_speed(1e-6 / 60, 1e-3) == pytest.approx(0.0212207, rel=1e-5)
    assert T.cox_coefficient(1e-3, math.e**2 * 1e-3, 1e-3) == pytest.approx(math.pi * 1e-3)
    assert T.beta_parameter(1e-9, 1e-3, 1e-3, 0.2) == pytest.approx(8.0)


def test_dimensional_growth_rate_and_curve() -> None:
    B, mu_s, v, L = 1e-9, 1e-3, 1e-3, 0.2  # beta = 8
    sigma = T.growth_rate_dimensional(B, mu_s, v, L)
    assert sigma == pytest.approx(T.growth_rate(8.0) * B / (mu_s * L**4), rel=1e-14)
    curve = T.growth_rate_curve([1.0, 8.0], B=B, mu_s=mu_s, v=v)
    np.testing.assert_allclose(curve.length_m, [0.1, 0.2], rtol=1e-12)
    assert curve.sigma_per_s[1] == pytest.approx(sigma, rel=1e-12)
    assert curve.sigma_scaled[1] == pytest.approx(curve.s[1] / 16.0, rel=1e-12)


def test_cox_fixed_point_matches_lambert_w_closed_form() -> None:
    # L^3 = a ln(L/r), a = beta_c B / (2 pi mu v): L = r exp(u/3), u = -W_{-1}(-3 r^3 / a)
    B, mu, v, r = T.bending_stiffness(2.7e3, 5e-4), 1e-3, 15e-3, 5e-4
    a = T.beta_critical() * B / (2 * math.pi * mu * v)
    exact = r * math.exp(-lambertw(-3 * r**3 / a, -1).real / 3)
    assert T.cox_critical_length(B, mu, v, r) == pytest.approx(exact, rel=1e-12)
    f = T.paper_prefactor_with_cox(B, mu, v, r)
    assert f == pytest.approx(1.3016, abs=1e-4)
    assert f == pytest.approx((T.beta_critical() * math.log(exact / r) / (2 * math.pi)) ** (1 / 3))


def test_main_json_output(capsys: pytest.CaptureFixture[str]) -> None:
    assert T.main(["--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    for key in (
        "beta_c",
        "beta_c_spectral",
        "critical_length_prefactor",
        "onset_frequency_prefactor",
        "paper_prefactor_with_cox_mean",
        "paper",
    ):
        assert key in d
    assert d["paper"]["LC_PREFACTOR"] == 1.41
    assert abs(d["beta_c_spectral"] / d["beta_c"] - 1) < 1e-10
    assert 1.2 < d["paper_prefactor_with_cox_mean"] < 1.4
    assert T.main([]) == 0
    assert "beta_c" in capsys.readouterr().out


def test_cantilever_modes_sum_to_the_static_deflection() -> None:
    """Eigenvalues of the clamped-free beam (tabulated 1.8751, 4.6941, 7.8548, 10.9955) and
    the uniform-load expansion: the tip amplitudes sum to the static q L^4 / (8 B)."""
    from bathprint.analysis.theory import cantilever_modes

    modes = cantilever_modes(5)
    np.testing.assert_allclose(
        [m[0] for m in modes[:4]], [1.8751041, 4.6940911, 7.8547574, 10.9955407], rtol=1e-7
    )
    assert modes[1][1] == pytest.approx(6.2669, rel=1e-4)
    assert sum(m[2] for m in modes) == pytest.approx(1.0, abs=1e-4)
    assert abs(modes[1][2]) == pytest.approx(0.0143, rel=1e-2)  # mode 2: 1.4 % of the tip

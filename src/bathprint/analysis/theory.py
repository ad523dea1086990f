"""Scaling laws and linear stability theory of an elastic rod extruded into a viscous bath.

Reference: "Instability-induced patterning of a jelling jet", section "Scaling analysis and
stability theory". All quantities are SI (m, s, Pa, Pa s, N m^2) unless a name says otherwise.

Scaling laws. Balancing the bending torque B/l with the viscous torque mu v l^2 gives the
buckling length l ~ (B/(mu v))^(1/3), the coil radius R ~ l and the coiling frequency
omega ~ v/l ~ v^(4/3) (mu/B)^(1/3); the paper's fits are R = 0.4 (B/(mu v))^(1/3),
omega = 1.1 v^(4/3) (mu/B)^(1/3) and l = 2.6 R.

Stability. A rod of length L (free end at x = 0, clamped at the needle x = L) is pushed
through the fluid at speed v. The tension is T = -mu_s v x (compressive, growing towards the
needle) and a lateral perturbation Y = eta(x) exp(sigma t) obeys the paper's Eq. (4)::

    2 mu_s sigma eta + 2 v mu_s eta' + B eta'''' + mu_s v x eta'' = 0,
    eta''(0) = eta'''(0) = 0,   eta(L) = eta'(L) = 0,

with mu_s the tangential slender-body drag coefficient (normal drag 2 mu_s). With x = L xi
and sigma = s B/(mu_s L^4) this is ``2 s eta + beta (2 eta' + xi eta'') + eta'''' = 0`` with
beta = mu_s v L^3 / B the only parameter. Two independent routes to the onset are provided:

* :func:`beta_critical`: at s = 0 the free-end solution is eta = A + C xi 0F1(4/3; -beta xi^3/9)
  and the clamped end requires 0F1(4/3; -beta/9) = (beta/4) 0F1(7/3; -beta/9), beta_c = 3.4766.
* :func:`growth_rate`: the full eigenvalue problem solved by Chebyshev collocation; its leading
  eigenvalue changes sign at :func:`onset_beta_spectral`, which agrees with beta_c to ~1e-14.

Run ``python -m bathprint.analysis.theory [--json]`` (or ``bathprint theory``) for a summary.
"""

from __future__ import annotations

import argparse
import functools
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
import scipy.linalg
from numpy.polynomial import chebyshev as cheb
from scipy.optimize import brentq
from scipy.special import hyp0f1, lambertw

from bathprint.core.resolution import gravity_drag_length

__all__ = [
    "DEFAULT_N",
    "GRAVITY",
    "PAPER_BETA_C",
    "PAPER_E_PA",
    "PAPER_L_OVER_R",
    "PAPER_LC_PREFACTOR",
    "PAPER_MU_PA_S",
    "PAPER_OMEGA_C_PREFACTOR",
    "PAPER_OMEGA_PREFACTOR",
    "PAPER_R_PREFACTOR",
    "PAPER_R_RANGE_M",
    "PAPER_V_RANGE_M_S",
    "GrowthRateCurve",
    "beta_critical",
    "beta_parameter",
    "bending_stiffness",
    "buckling_length_scale",
    "coil_frequency",
    "coil_radius",
    "cox_coefficient",
    "cox_critical_length",
    "cox_prefactor_statistics",
    "critical_length",
    "critical_length_prefactor",
    "exit_speed",
    "gravity_drag_length",
    "growth_rate",
    "growth_rate_curve",
    "growth_rate_dimensional",
    "leading_eigenvalue",
    "main",
    "onset_beta_spectral",
    "onset_condition",
    "onset_frequency_prefactor",
    "paper_lambert_w_prefactor",
    "paper_parameter_grid",
    "paper_prefactor_with_cox",
    "spectrum",
    "summary_dict",
]

# --- constants quoted in the paper -----------------------------------------------------------
PAPER_L_OVER_R = 2.6  # Fig. 2A: buckling length l = 2.6 R
PAPER_R_PREFACTOR = 0.4  # Fig. 2B: R = 0.4 (B/(mu v))^(1/3)
PAPER_OMEGA_PREFACTOR = 1.1  # Fig. 2C: omega = 1.1 v^(4/3) (mu/B)^(1/3)
PAPER_BETA_C = 3.48  # onset of the hypergeometric condition, Eq. (7)
PAPER_LC_PREFACTOR = 1.41  # l = 1.41 (B/(mu v))^(1/3), Eq. (8)
PAPER_OMEGA_C_PREFACTOR = 0.71  # omega_c = 0.71 v^(4/3) (mu/B)^(1/3)
PAPER_E_PA = 2.7e3  # Young's modulus of the alginate filament
PAPER_MU_PA_S = 1.0e-3  # bath viscosity
PAPER_R_RANGE_M = (1.0e-4, 2.0e-3)  # filament radius range
PAPER_V_RANGE_M_S = (2.0e-3, 70.0e-3)  # extrusion speed range

GRAVITY = 9.81  # m/s^2
DEFAULT_N = 32  # Chebyshev polynomial degree; the onset is converged to ~1e-14 already at 16

Method = Literal["integration", "differentiation"]


def _require_positive(**values: float | np.ndarray) -> None:
    for name, value in values.items():
        if np.any(np.asarray(value) <= 0):
            raise ValueError(f"{name} must be positive, got {value!r}")


# --- scaling laws ----------------------------------------------------------------------------
def buckling_length_scale(B: float, mu: float, v: float) -> float:
    """Viscous buckling length (B/(mu v))^(1/3) in m; B in N m^2, mu in Pa s, v in m/s."""
    _require_positive(B=B, mu=mu, v=v)
    return (B / (mu * v)) ** (1.0 / 3.0)


def coil_radius(B: float, mu: float, v: float, prefactor: float = PAPER_R_PREFACTOR) -> float:
    """Coil radius R = prefactor (B/(mu v))^(1/3) in m (paper's Fig. 2B fit: 0.4)."""
    return prefactor * buckling_length_scale(B, mu, v)


def coil_frequency(
    B: float, mu: float, v: float, prefactor: float = PAPER_OMEGA_PREFACTOR
) -> float:
    """Coiling frequency omega = prefactor v^(4/3) (mu/B)^(1/3) in rad/s (Fig. 2C fit: 1.1)."""
    _require_positive(B=B, mu=mu, v=v)
    return prefactor * v ** (4.0 / 3.0) * (mu / B) ** (1.0 / 3.0)


def bending_stiffness(E: float, r: float) -> float:
    """Bending stiffness B = E pi r^4 / 4 in N m^2 of a solid rod (E in Pa, radius r in m)."""
    _require_positive(E=E, r=r)
    return E * math.pi * r**4 / 4.0


def exit_speed(q_m3_s: float, d_m: float) -> float:
    """Mean extrusion speed v = q / (pi d^2 / 4) in m/s from flow rate q (m^3/s), needle d (m)."""
    _require_positive(q_m3_s=q_m3_s, d_m=d_m)
    return q_m3_s / (math.pi * d_m**2 / 4.0)


def cox_coefficient(mu: float, L: float, r: float) -> float:
    """Cox's tangential drag per length and speed mu_s = 2 pi mu / ln(L/r) in Pa s (L > r)."""
    _require_positive(mu=mu, L=L, r=r)
    if L <= r:
        raise ValueError("slender-body theory needs L > r")
    return 2.0 * math.pi * mu / math.log(L / r)


# --- onset from the hypergeometric condition -------------------------------------------------
def onset_condition(beta: float) -> float:
    """0F1(4/3; -beta/9) - (beta/4) 0F1(7/3; -beta/9): zero where eta'(1) = 0 at s = 0."""
    return float(hyp0f1(4.0 / 3.0, -beta / 9.0) - 0.25 * beta * hyp0f1(7.0 / 3.0, -beta / 9.0))


def beta_critical() -> float:
    """First root beta_c = mu_s v L_c^3 / B = 3.47662 of :func:`onset_condition` (dimensionless)."""
    return float(brentq(onset_condition, 1.0, 6.0, xtol=1e-15, rtol=4 * np.finfo(float).eps))


def beta_parameter(B: float, mu_s: float, v: float, L: float) -> float:
    """Dimensionless rod length beta = mu_s v L^3 / B (mu_s in Pa s, L in m)."""
    _require_positive(B=B, mu_s=mu_s, v=v, L=L)
    return mu_s * v * L**3 / B


def critical_length_prefactor(beta_c: float | None = None) -> float:
    """L_c / (B/(mu_s v))^(1/3) = beta_c^(1/3) = 1.51491 (mu_s the drag coefficient itself).

    The paper quotes 1.41 with mu in place of mu_s. Its commented-out derivation takes
    mu_s = 2 pi mu / ln(L_c/r) (Cox) and averages L_c/(B/(mu v))^(1/3) over its data to get
    1.41; :func:`paper_prefactor_with_cox` redoes that computation.
    """
    return (beta_critical() if beta_c is None else beta_c) ** (1.0 / 3.0)


def onset_frequency_prefactor(beta_c: float | None = None) -> float:
    """omega_c / (v^(4/3) (mu_s/B)^(1/3)) = beta_c^(-1/3) = 0.66011, with omega_c = v / L_c.

    The paper's 0.71 is 1/1.41, i.e. the reciprocal of its Cox-averaged length prefactor.
    """
    return 1.0 / critical_length_prefactor(beta_c)


def critical_length(B: float, mu_s: float, v: float) -> float:
    """Critical extruded length L_c = beta_c^(1/3) (B/(mu_s v))^(1/3) in m."""
    return critical_length_prefactor() * buckling_length_scale(B, mu_s, v)


# --- Chebyshev collocation for the growth rate -----------------------------------------------
def cantilever_modes(n_modes: int = 4) -> list[tuple[float, float, float]]:
    """Clamped-free Euler-Bernoulli modes and how a uniform load excites them.

    For each mode n: (beta_n L, omega_n / omega_1, tip amplitude / static tip deflection)
    of a uniformly loaded cantilever released from straight, i.e. the coefficients of the
    static deflection q L^4 / (8 B) expanded in the modes (they sum to 1). beta_n L are the
    roots of cos(x) cosh(x) = -1, omega_n ~ (beta_n L)^2. Used to judge which modes an
    integrator must resolve on the inertial cantilever (experiments/pyelastica/cantilever.py).
    """
    x = np.linspace(0.0, 1.0, 4001)
    out = []
    for n in range(1, n_modes + 1):
        guess = (n - 0.5) * math.pi
        b = brentq(lambda z: math.cos(z) * math.cosh(z) + 1.0, guess - 1.0, guess + 1.0)
        sig = (math.sinh(b) - math.sin(b)) / (math.cosh(b) + math.cos(b))
        phi = np.cosh(b * x) - np.cos(b * x) - sig * (np.sinh(b * x) - np.sin(b * x))
        coeff = np.trapezoid(phi, x) / np.trapezoid(phi * phi, x) / b**4  # of q L^4 / B
        out.append((b, (b / out[0][0]) ** 2 if out else 1.0, float(coeff * phi[-1] * 8.0)))
    return out


def cantilever_release_error(
    a_mat: np.ndarray,
    b: np.ndarray,
    h: float,
    omega_1: float,
    decay: float,
    sample_times: np.ndarray,
    n_modes: int = 6,
) -> float:
    """Error of a Runge-Kutta method (Butcher matrix ``a_mat``, weights ``b``) at fixed step
    h on the released cantilever of :func:`cantilever_modes`, in units of the static tip
    deflection: the largest |tip error| at ``sample_times`` (multiples of h, s).

    Each mode n is the damped oscillator q'' + 2 decay q' + omega_n^2 q = omega_n^2 a_n,
    q(0) = q'(0) = 0 (a_n its tip amplitude, omega_n = omega_1 * its frequency ratio; drag
    damps all modes at the same rate ``decay``, 1/s). On this linear system one step is
    y -> R y + s exactly, so the prediction has no error of its own beyond the modal
    truncation. It tells how an integrator's stability function treats each mode.
    """
    s_count = len(b)
    steps = np.rint(np.asarray(sample_times) / h).astype(int)
    if np.any(np.abs(steps * h - sample_times) > 1e-9 * h):
        raise ValueError("sample_times must be multiples of h")
    total = np.zeros(len(steps))
    for _, ratio, amp in cantilever_modes(n_modes):
        w = omega_1 * ratio
        lin = np.array([[0.0, 1.0], [-w * w, -2.0 * decay]])
        force = np.array([0.0, w * w * amp])
        # stages K = (I - h A (x) L)^-1 (1 (x) (L y + f)); y+ = y + h sum b_i K_i
        solve = np.linalg.inv(np.eye(2 * s_count) - h * np.kron(a_mat, lin))
        spread = np.kron(np.ones((s_count, 1)), np.eye(2))
        gather = h * np.kron(np.asarray(b)[None, :], np.eye(2))
        step = gather @ solve @ spread
        r_mat = np.eye(2) + step @ lin
        s_vec = step @ force
        y = np.zeros(2)
        numeric = np.empty(len(steps))
        k = 0
        for n in range(1, int(steps.max()) + 1):
            y = r_mat @ y + s_vec
            while k < len(steps) and steps[k] == n:
                numeric[k] = y[0]
                k += 1
        wd = math.sqrt(w * w - decay * decay)
        t = steps * h
        exact = amp * (1.0 - np.exp(-decay * t) * (np.cos(wd * t) + decay / wd * np.sin(wd * t)))
        total += numeric - exact
    return float(np.max(np.abs(total)))


def _nodes(n: int) -> np.ndarray:
    """Chebyshev-Lobatto points of degree n on [-1, 1], ascending (symmetric sine form)."""
    if n < 6:
        raise ValueError("need a Chebyshev degree n >= 6")
    j = np.arange(n + 1)
    return np.sin(np.pi * (2 * j - n) / (2 * n))


@functools.cache
def _integration_matrices(n: int) -> tuple[np.ndarray, ...]:
    """xi on [0, 1] and J_k (k = 2, 3, 4): values of w -> values of the k-fold integral from 0."""
    x = _nodes(n)
    to_coeffs = np.linalg.inv(cheb.chebvander(x, n))
    out = [(x + 1.0) / 2.0]
    for k in (2, 3, 4):
        coeffs = cheb.chebint(to_coeffs, m=k, lbnd=-1.0, scl=0.5, axis=0)
        out.append(cheb.chebvander(x, n + k) @ coeffs)
    for a in out:
        a.flags.writeable = False
    return tuple(out)


@functools.cache
def _differentiation_matrices(n: int) -> tuple[np.ndarray, ...]:
    """xi on [0, 1] and d^k/dxi^k (k = 1..4) collocation matrices (Trefethen's cheb, mapped)."""
    x = _nodes(n)
    c = np.ones(n + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** np.arange(n + 1)
    dx = x[:, None] - x[None, :]
    d = np.outer(c, 1.0 / c) / (dx + np.eye(n + 1))
    d -= np.diag(d.sum(axis=1))
    d1 = 2.0 * d  # d/dxi = 2 d/dx
    out = [(x + 1.0) / 2.0, d1]
    for _ in range(3):
        out.append(out[-1] @ d1)
    for a in out:
        a.flags.writeable = False
    return tuple(out)


def _pencil(beta: float, n: int, method: Method) -> tuple[np.ndarray, np.ndarray, int]:
    """Matrices (A, M) with A u = s M u discretising 2 s eta + beta (xi eta)'' + eta'''' = 0,
    and how many of the pencil's eigenvalues are infinite by construction."""
    if method == "integration":
        # Unknown w = eta'''' at the nodes. Integrating from the free end makes eta''(0) and
        # eta'''(0) vanish; the clamp fixes the remaining linear part:
        # eta = J4 w - (J4 w)(1) + (1 - xi) (J3 w)(1),  eta' = J3 w - (J3 w)(1),  eta'' = J2 w.
        xi, j2, j3, j4 = _integration_matrices(n)
        eta = j4 - j4[-1] + np.outer(1.0 - xi, j3[-1])
        deta = j3 - j3[-1]
        a = np.eye(n + 1) + beta * (2.0 * deta + xi[:, None] * j2)
        return a, -2.0 * eta, 1  # the clamp row eta(1) = 0 has no s term: one infinite s
    if method == "differentiation":
        # Unknown eta at the nodes; the four boundary conditions are solved for the values at
        # the two nodes next to each end, and those equations' rows are dropped.
        xi, d1, d2, d3, d4 = _differentiation_matrices(n)
        op = d4 + beta * (2.0 * d1 + xi[:, None] * d2)
        bc = np.vstack([d2[0], d3[0], np.eye(n + 1)[n], d1[n]])
        edge = np.array([0, 1, n - 1, n])
        inner = np.arange(2, n - 1)
        elim = -np.linalg.solve(bc[:, edge], bc[:, inner])
        a = op[np.ix_(inner, inner)] + op[np.ix_(inner, edge)] @ elim
        return a, -2.0 * np.eye(inner.size), 0
    raise ValueError(f"unknown method {method!r}")


def spectrum(beta: float, n: int = DEFAULT_N, method: Method = "integration") -> np.ndarray:
    """Dimensionless growth rates s = sigma mu_s L^4 / B, sorted by decreasing real part (the
    finite eigenvalues of the discretised pencil; its infinite one, if any, is left out).

    ``method="integration"`` (default) collocates the equation for w = eta'''' with the
    boundary conditions built into spectral integration matrices: well conditioned, converged
    to machine precision for n >= 16. ``method="differentiation"`` is the classical
    differentiation-matrix collocation with boundary conditions eliminated; its round-off grows
    steeply with n (errors ~1e-9..1e-8 at n = 16..32, ~1e-5 at n = 64). Only the first few
    eigenvalues are resolved; the tail (|s| ~ n^4) is discretisation-dependent.
    """
    if not math.isfinite(beta) or beta < 0:
        raise ValueError(f"beta must be finite and >= 0, got {beta!r}")
    a, m, n_infinite = _pencil(beta, n, method)
    # The infinite eigenvalues are dropped by number, not by a test on round-off: they are
    # the n_infinite pairs (alpha, beta) nearest to beta = 0, whether QZ returns their beta
    # as exactly 0 (as LAPACK does here) or as round-off of either sign.
    alpha, beta_h = scipy.linalg.eigvals(a, m, homogeneous_eigvals=True)
    denom = beta_h.real
    to_infinity = np.abs(denom) / np.maximum(np.hypot(np.abs(alpha), np.abs(denom)), 1e-300)
    keep = np.sort(np.argsort(to_infinity, kind="stable")[n_infinite:])
    with np.errstate(divide="ignore", invalid="ignore"):
        values = alpha[keep] / denom[keep]
    values = values[np.isfinite(values)]
    return values[np.lexsort((-values.imag, -values.real))]


def leading_eigenvalue(beta: float, n: int = DEFAULT_N, method: Method = "integration") -> complex:
    """Eigenvalue s with the largest real part (dimensionless, units B/(mu_s L^4))."""
    return complex(spectrum(beta, n, method)[0])


def growth_rate(beta: float, n: int = DEFAULT_N, method: Method = "integration") -> float:
    """Largest Re s, s = sigma mu_s L^4 / B, at beta = mu_s v L^3 / B; negative means stable.

    The leading eigenvalue is real for beta below about 49 (so it covers the onset); beyond it
    merges with the second mode into a complex pair.
    """
    return leading_eigenvalue(beta, n, method).real


def growth_rate_dimensional(B: float, mu_s: float, v: float, L: float, n: int = DEFAULT_N) -> float:
    """Largest Re sigma in 1/s of a rod of length L (m); mu_s the tangential drag (Pa s)."""
    return growth_rate(beta_parameter(B, mu_s, v, L), n) * B / (mu_s * L**4)


def onset_beta_spectral(
    n: int = DEFAULT_N,
    method: Method = "integration",
    bracket: tuple[float, float] = (2.0, 5.0),
) -> float:
    """Zero of :func:`growth_rate` in ``bracket`` by brentq: the spectral estimate of beta_c."""
    return float(brentq(lambda b: growth_rate(b, n, method), *bracket, xtol=1e-14, rtol=1e-14))


@dataclass(frozen=True)
class GrowthRateCurve:
    """Leading growth rate against rod length.

    ``beta``: mu_s v L^3 / B; ``s``: Re sigma in units B/(mu_s L^4); ``length_scaled``:
    L / l_s = beta^(1/3) with l_s = (B/(mu_s v))^(1/3); ``sigma_scaled``: Re sigma in units
    v / l_s, = s beta^(-4/3) (-inf at beta = 0). ``length_m`` and ``sigma_per_s`` are the
    dimensional values (m, 1/s) when B, mu_s and v were given, else None.
    """

    beta: np.ndarray
    s: np.ndarray
    length_scaled: np.ndarray
    sigma_scaled: np.ndarray
    length_m: np.ndarray | None = None
    sigma_per_s: np.ndarray | None = None


def growth_rate_curve(
    betas: Sequence[float] | np.ndarray,
    n: int = DEFAULT_N,
    *,
    B: float | None = None,
    mu_s: float | None = None,
    v: float | None = None,
) -> GrowthRateCurve:
    """Leading growth rate over ``betas``; pass B, mu_s, v for dimensional L (m), sigma (1/s)."""
    beta = np.asarray(betas, dtype=float).ravel()
    s = np.array([growth_rate(float(b), n) for b in beta])
    length_scaled = np.cbrt(beta)
    with np.errstate(divide="ignore"):
        sigma_scaled = s * beta ** (-4.0 / 3.0)
    length_m = sigma_per_s = None
    given = [p is not None for p in (B, mu_s, v)]
    if any(given):
        if not all(given):
            raise ValueError("give all of B, mu_s and v, or none")
        scale = buckling_length_scale(B, mu_s, v)
        length_m = length_scaled * scale
        sigma_per_s = sigma_scaled * v / scale
    return GrowthRateCurve(beta, s, length_scaled, sigma_scaled, length_m, sigma_per_s)


# --- the paper's prefactor with Cox's logarithm ----------------------------------------------
def cox_critical_length(
    B: float, mu: float, v: float, r: float, tol: float = 1e-13, max_iter: int = 500
) -> float:
    """Critical length L_c (m) with mu_s = 2 pi mu / ln(L_c / r), by fixed-point iteration.

    Iterates L <- (beta_c B ln(L/r) / (2 pi mu v))^(1/3); the map contracts (slope
    1/(3 ln(L/r))) onto the slender root, which exists when 3 r^3 / a < 1/e with
    a = beta_c B / (2 pi mu v). Raises ValueError if L_c is not slender (ln(L_c/r) <= 1/3).
    """
    _require_positive(B=B, mu=mu, v=v, r=r)
    a = beta_critical() * B / (2.0 * math.pi * mu * v)
    if 3.0 * r**3 / a >= math.exp(-1.0):
        raise ValueError("no slender critical length: (B/(mu v))^(1/3) is too small against r")
    length = max(critical_length_prefactor() * buckling_length_scale(B, mu, v), 3.0 * r)
    for _ in range(max_iter):
        new = (a * math.log(length / r)) ** (1.0 / 3.0)
        if abs(new - length) <= tol * new:
            return new
        length = new
    raise RuntimeError("fixed-point iteration for L_c did not converge")


def paper_prefactor_with_cox(B: float, mu: float, v: float, r: float) -> float:
    """L_c / (B/(mu v))^(1/3) with Cox's mu_s = 2 pi mu / ln(L_c/r) (dimensionless).

    Equals (beta_c ln(L_c/r) / (2 pi))^(1/3); the paper states this averages 1.41 over its data.
    """
    return cox_critical_length(B, mu, v, r) / buckling_length_scale(B, mu, v)


def paper_lambert_w_prefactor(B: float, mu: float, v: float, r: float) -> float:
    """The paper's commented-out closed form, evaluated literally (dimensionless).

    (3 beta_c B / (2 pi mu v W(y)))^(1/3) / (B/(mu v))^(1/3), y = 3 beta_c B / (2 pi mu v r^3),
    W the principal Lambert function. It solves L^3 = beta_c B / (2 pi mu v ln(L/r)), i.e. the
    log on the other side of mu_s = 2 pi mu ln(L/r); kept for comparison only (gives ~0.5).
    """
    _require_positive(B=B, mu=mu, v=v, r=r)
    y = 3.0 * beta_critical() * B / (2.0 * math.pi * mu * v)
    w = float(lambertw(y / r**3).real)
    return (y / w) ** (1.0 / 3.0) / buckling_length_scale(B, mu, v)


def paper_parameter_grid(
    n_r: int = 15, n_v: int = 15, E: float = PAPER_E_PA
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(B, v, r) on a log-spaced grid of the paper's r = 0.1-2 mm, v = 2-70 mm/s; B = E pi r^4/4."""
    r, v = np.meshgrid(np.geomspace(*PAPER_R_RANGE_M, n_r), np.geomspace(*PAPER_V_RANGE_M_S, n_v))
    r, v = r.ravel(), v.ravel()
    return bending_stiffness(E, r), v, r


def cox_prefactor_statistics(
    n_r: int = 15, n_v: int = 15, mu: float = PAPER_MU_PA_S
) -> dict[str, float]:
    """Mean, coefficient of variation, min and max of :func:`paper_prefactor_with_cox` (grid)."""
    B, v, r = paper_parameter_grid(n_r, n_v)
    f = np.array(
        [paper_prefactor_with_cox(b, mu, vv, rr) for b, vv, rr in zip(B, v, r, strict=True)]
    )
    return {
        "mean": float(f.mean()),
        "cv": float(f.std() / f.mean()),
        "min": float(f.min()),
        "max": float(f.max()),
    }


# --- summary and command line ----------------------------------------------------------------
def summary_dict(n: int = DEFAULT_N) -> dict[str, object]:
    """JSON-serialisable summary of the theory: onsets both ways, prefactors, paper constants."""
    beta_c = beta_critical()
    beta_s = onset_beta_spectral(n)
    cox = cox_prefactor_statistics()
    B, v, r = paper_parameter_grid()
    w_mean = float(
        np.mean(
            [
                paper_lambert_w_prefactor(b, PAPER_MU_PA_S, vv, rr)
                for b, vv, rr in zip(B, v, r, strict=True)
            ]
        )
    )
    return {
        "beta_c": beta_c,
        "beta_c_spectral": beta_s,
        "beta_c_relative_difference": abs(beta_s - beta_c) / beta_c,
        "chebyshev_degree": n,
        "critical_length_prefactor": critical_length_prefactor(beta_c),
        "onset_frequency_prefactor": onset_frequency_prefactor(beta_c),
        "growth_rate_beta_0": growth_rate(0.0, n),
        "paper_prefactor_with_cox_mean": cox["mean"],
        "paper_prefactor_with_cox_cv": cox["cv"],
        "paper_prefactor_with_cox_min": cox["min"],
        "paper_prefactor_with_cox_max": cox["max"],
        "paper_lambert_w_prefactor_mean": w_mean,
        "paper_grid": {
            "E_Pa": PAPER_E_PA,
            "mu_Pa_s": PAPER_MU_PA_S,
            "r_m": list(PAPER_R_RANGE_M),
            "v_m_s": list(PAPER_V_RANGE_M_S),
            "points": int(B.size),
            "bending_stiffness": "E pi r^4 / 4",
        },
        "paper": {
            "L_OVER_R": PAPER_L_OVER_R,
            "R_PREFACTOR": PAPER_R_PREFACTOR,
            "OMEGA_PREFACTOR": PAPER_OMEGA_PREFACTOR,
            "BETA_C": PAPER_BETA_C,
            "LC_PREFACTOR": PAPER_LC_PREFACTOR,
            "OMEGA_C_PREFACTOR": PAPER_OMEGA_C_PREFACTOR,
        },
    }


def _format_summary(d: dict[str, object]) -> str:
    paper = d["paper"]
    rows = [
        ("beta_c (hypergeometric, Eq. 7)", d["beta_c"], paper["BETA_C"]),
        ("beta_c (Chebyshev growth rate = 0)", d["beta_c_spectral"], paper["BETA_C"]),
        ("  relative difference", d["beta_c_relative_difference"], None),
        ("L_c / (B/(mu_s v))^(1/3) = beta_c^(1/3)", d["critical_length_prefactor"], None),
        ("omega_c / (v^(4/3)(mu_s/B)^(1/3))", d["onset_frequency_prefactor"], None),
        ("L_c / (B/(mu v))^(1/3), Cox mu_s, mean", d["paper_prefactor_with_cox_mean"], 1.41),
        ("  coefficient of variation", d["paper_prefactor_with_cox_cv"], 0.01),
        ("  min over grid", d["paper_prefactor_with_cox_min"], None),
        ("  max over grid", d["paper_prefactor_with_cox_max"], None),
        ("paper's commented W formula, mean", d["paper_lambert_w_prefactor_mean"], 0.51),
        ("1 / Cox mean (omega_c prefactor, mu)", 1.0 / d["paper_prefactor_with_cox_mean"], 0.71),
        ("growth rate at beta = 0 (cantilever)", d["growth_rate_beta_0"], None),
    ]
    lines = [f"{'quantity':<44}{'value':>16}{'paper':>10}"]
    for name, value, ref in rows:
        ref_text = "" if ref is None else f"{ref:g}"
        lines.append(f"{name:<44}{value:>16.10g}{ref_text:>10}")
    grid = d["paper_grid"]
    lines.append(
        f"grid: {grid['points']} points, r = {grid['r_m'][0] * 1e3:g}-{grid['r_m'][1] * 1e3:g} mm,"
        f" v = {grid['v_m_s'][0] * 1e3:g}-{grid['v_m_s'][1] * 1e3:g} mm/s, E = {grid['E_Pa']:g} Pa,"
        f" mu = {grid['mu_Pa_s']:g} Pa s, B = {grid['bending_stiffness']}"
    )
    return "\n".join(lines)


def _chebyshev_degree(text: str) -> int:
    n = int(text)
    if n < 6:
        raise argparse.ArgumentTypeError(f"must be >= 6 (got {n})")
    return n


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``theory [--json] [--n N]``."""
    parser.add_argument("--json", action="store_true", help="print JSON instead of a table")
    parser.add_argument(
        "--n", type=_chebyshev_degree, default=DEFAULT_N, help="Chebyshev degree (>= 6)"
    )


def run_args(args: argparse.Namespace) -> int:
    """Print the summary (a table, or JSON with ``--json``); returns the exit code."""
    d = summary_dict(args.n)
    print(json.dumps(d, indent=2) if args.json else _format_summary(d))
    return 0


DESCRIPTION = "Scaling laws and onset of the extruded-rod buckling."


def main(argv: Sequence[str] | None = None) -> int:
    """Command line ``theory [--json] [--n N]``: print the summary; returns the exit code."""
    parser = argparse.ArgumentParser(prog="bathprint theory", description=DESCRIPTION)
    add_arguments(parser)
    return run_args(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())

"""The finite-Reynolds-number drag law of a filament (``drag.model = "finite_re"``).

Force per length on an element of tangent t moving at u relative to the bath (SI units),
by the independence (cross-flow) principle:

    F(u, t) = -(f_n(|u_n|) u_n/|u_n| + f_t(|u_t|) u_t/|u_t|),  u_t = (u.t) t,  u_n = u - u_t,

written F = -g_n u_n - g_t u_t with g = f/U (Pa s), finite at U = 0 (g_n -> 2 mu_s,
g_t -> mu_s with mu_s = 2 pi mu / ln(L/a), Cox), so F is linear at u = 0 and its Jacobian
is continuous there. d is the diameter, a = d/2, L the slender-body length scale
(``drag.length_scale_mm``), nu = mu/rho, Re = U d / nu, Re_L = U L / nu, gamma = 0.5772.

Normal (cross-flow) drag, f_n = (1/2) mu U G(Re), G = Re C_D:

* Re <= 0.3: Lamb (1911, Phil. Mag. (6) 21:112), the Oseen drag of a circular cylinder,
  4 pi mu U / (1/2 - gamma - ln(Re/8)), with the Stokes-paradox logarithm cut off at the
  finite length: G = 8 pi / D_n, D_n = ln(L/a) - Ein(Re_L / (4 sqrt e)), the slender-body
  logarithm int_a^L ds/s with the Stokeslet screened beyond the Oseen length 4 sqrt(e) nu/U.
  Both limits are exact: D_n -> ln(L/a) (Cox 1970, J. Fluid Mech. 44:791) as Re_L -> 0 and
  D_n -> ln(7.4055/Re) (Lamb) as Re_L -> inf; the crossover in between is modelled (a
  composite in the spirit of Khayat & Cox 1989, J. Fluid Mech. 209:435).
* Re >= 1: Cheng (2013, J. Hydraul. Eng. 139(6):602), isolated circular cylinder,
  C_D = 11 Re^-0.75 + 0.9 (1 - exp(-1000/Re)) + 1.2 (1 - exp(-(Re/4500)^0.7)), Re < 2e5.
* 0.3 < Re < 1: a quintic smoothstep in ln Re between the two (C^2, monotone).

Tangential (axial) drag, f_t = 2 pi mu U / D_t (skin friction; no pressure drag of the ends):
the laminar axial boundary layer of a long thin cylinder (Glauert & Lighthill 1955, Proc. R.
Soc. Lond. A 230:188) averaged over a length L from the leading edge,
D_inf(y) = ln(1 + y k(y)), k = K_INF + (K_0 - K_INF)(1 + B y)^-Q, y = (2/a) sqrt(nu L/U);
K_0 = 1/(4 x 0.332057) is Blasius's flat-plate value (thin boundary layer), K_INF, B, Q a
fit (0.1% for 1e-5 < xi < 1e6) to a numerical solution of the same boundary-layer equations.
With the finite length the same cut-off as above, D_t = ln(L/a) - Ein(z) + (1 - e^-z) delta(y),
z = sqrt(e Re_L)/2, delta = D_inf - (ln y - gamma - 1/2): D_t -> ln(L/a) (mu_s U) as
Re_L -> 0 and D_t -> D_inf as Re_L -> inf. Laminar only (Re_L below ~1e5 at the paper's speeds).

Ein(z) = int_0^z (1 - e^-t)/t dt = gamma + ln z + E1(z). The C_D of the normal law is within
10% of the experimental cylinder drag curve at Re = 0.1, 1, 10 and 100 (tests/
test_drag_finite_re.py, with the data set it cites).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.jit import KERNEL

EULER_GAMMA = 0.5772156649015329
SQRT_E = math.sqrt(math.e)
RE_STAR = 8.0 * math.exp(0.5 - EULER_GAMMA)  # Lamb: D = ln(RE_STAR / Re), 7.4055
# Cheng (2013) isolated-cylinder correlation
CHENG_A, CHENG_P = 11.0, -0.75
CHENG_B, CHENG_RB = 0.9, 1000.0
CHENG_C, CHENG_RC, CHENG_PC = 1.2, 4500.0, 0.7
# Lamb -> Cheng blend (Re on the diameter)
RE_BLEND_LO = 0.3
RE_BLEND_HI = 1.0
# Tangential: Blasius mean skin friction and the fit to the boundary-layer solution
BLASIUS = 0.332057
K_0 = 1.0 / (4.0 * BLASIUS)
K_INF = 0.476442
B_T = 1.360453
Q_T = 0.288122


@njit(**KERNEL)
def _ein_series(z: float) -> float:
    """Ein(z) by its power series sum (-1)^(k+1) z^k / (k k!) (used for 0 <= z <= 1)."""
    term = z
    total = z
    for k in range(2, 60):
        term *= -z / k
        add = term / k
        total += add
        if abs(add) <= 1e-17 * abs(total):
            break
    return total


@njit(**KERNEL)
def _e1_fraction(z: float) -> float:
    """E1(z) by its continued fraction (modified Lentz; used for z > 1)."""
    tiny = 1e-300
    b = z + 1.0
    c = 1.0 / tiny
    dd = 1.0 / b
    h = dd
    for i in range(1, 300):
        an = -float(i * i)
        b += 2.0
        dd = 1.0 / (an * dd + b)
        c = b + an / c
        de = c * dd
        h *= de
        if abs(de - 1.0) < 1e-16:
            break
    return h * math.exp(-z)


@njit(**KERNEL)
def e1(z: float) -> float:
    """Exponential integral E1(z) for z > 0."""
    if z <= 1.0:
        return -EULER_GAMMA - math.log(z) + _ein_series(z)
    return _e1_fraction(z)


@njit(**KERNEL)
def ein(z: float) -> float:
    """Ein(z) = int_0^z (1 - e^-t)/t dt for z >= 0 (= gamma + ln z + E1(z))."""
    if z <= 1.0:
        return _ein_series(z)
    return EULER_GAMMA + math.log(z) + _e1_fraction(z)


@njit(**KERNEL)
def _smootherstep(s: float) -> tuple[float, float]:
    """Quintic smoothstep w(s) = 6s^5 - 15s^4 + 10s^3 on [0, 1] and dw/ds (C^2 at ends)."""
    if s <= 0.0:
        return 0.0, 0.0
    if s >= 1.0:
        return 1.0, 0.0
    return s * s * s * (10.0 + s * (-15.0 + 6.0 * s)), 30.0 * s * s * (1.0 - s) * (1.0 - s)


@njit(**KERNEL)
def cheng_g(re: float) -> tuple[float, float]:
    """G = Re C_D of Cheng (2013) and dG/dRe (Re > 0)."""
    g1 = CHENG_A * re ** (1.0 + CHENG_P)
    dg1 = CHENG_A * (1.0 + CHENG_P) * re**CHENG_P
    e_b = math.exp(-CHENG_RB / re)
    g2 = CHENG_B * re * (1.0 - e_b)
    dg2 = CHENG_B * (1.0 - e_b * (1.0 + CHENG_RB / re))
    p = (re / CHENG_RC) ** CHENG_PC
    e_c = math.exp(-p)
    g3 = CHENG_C * re * (1.0 - e_c)
    dg3 = CHENG_C * (1.0 - e_c * (1.0 - CHENG_PC * p))
    return g1 + g2 + g3, dg1 + dg2 + dg3


@njit(**KERNEL)
def lamb_g(re: float, l_over_a: float) -> tuple[float, float]:
    """G = Re C_D = 8 pi / D_n of Lamb's law with the finite-length cut-off, and dG/dRe.

    l_over_a = inf gives Lamb's infinite cylinder (D = ln(RE_STAR/Re), Re > 0).
    """
    if math.isinf(l_over_a):
        dn = math.log(RE_STAR / re)
        ddn = -1.0 / re
    else:
        scale = l_over_a / (8.0 * SQRT_E)  # z = Re_L / (4 sqrt e) = Re (L/a) / (8 sqrt e)
        z = re * scale
        dn = math.log(l_over_a) - ein(z)
        dein = 1.0 if z <= 0.0 else -math.expm1(-z) / z
        ddn = -dein * scale
    g = 8.0 * math.pi / dn
    return g, -g * ddn / dn


@njit(**KERNEL)
def normal_g(re: float, l_over_a: float) -> tuple[float, float]:
    """Blended G(Re) = Re C_D for the normal drag and dG/dRe (Re >= 0; Re > 0 if L = inf)."""
    if re <= RE_BLEND_LO:
        return lamb_g(re, l_over_a)
    if re >= RE_BLEND_HI:
        return cheng_g(re)
    span = math.log(RE_BLEND_HI / RE_BLEND_LO)
    w, dw = _smootherstep(math.log(re / RE_BLEND_LO) / span)
    gl, dgl = lamb_g(re, l_over_a)
    gh, dgh = cheng_g(re)
    return (1.0 - w) * gl + w * gh, (1.0 - w) * dgl + w * dgh + dw / (re * span) * (gh - gl)


@njit(**KERNEL)
def normal_coefficients(u: float, d: float, mu: float, rho: float, length: float):
    """(f_n/U, df_n/dU) in Pa s for normal relative speed u >= 0; f_n/U -> 4 pi mu/ln(L/a)."""
    re = rho * u * d / mu
    g, dg = normal_g(re, 2.0 * length / d)
    return 0.5 * mu * g, 0.5 * mu * (g + re * dg)


@njit(**KERNEL)
def normal_drag(u: float, d: float, mu: float, rho: float, length: float):
    """Normal drag per length f_n (N/m) at normal relative speed u >= 0, and df_n/dU."""
    g, fp = normal_coefficients(u, d, mu, rho, length)
    return g * u, fp


@njit(**KERNEL)
def tangential_log(re_l: float, l_over_a: float) -> tuple[float, float]:
    """D_t (f_t = 2 pi mu U / D_t) and U dD_t/dU, from Re_L = U L / nu >= 0 and L/a."""
    if re_l <= 0.0:
        return math.log(l_over_a), 0.0
    sq = math.sqrt(re_l)
    y = 2.0 * l_over_a / sq
    z = 0.5 * SQRT_E * sq
    base = (1.0 + B_T * y) ** (-Q_T)
    k = K_INF + (K_0 - K_INF) * base
    yk1 = -Q_T * B_T * y * (K_0 - K_INF) * base / (1.0 + B_T * y)  # y dk/dy
    one_yk = 1.0 + y * k
    d_inf = math.log1p(y * k)
    y_dinf = y * (k + yk1) / one_yk  # y dD_inf/dy
    delta = math.log(k + 1.0 / y) + EULER_GAMMA + 0.5
    y_ddelta = (y * yk1 - 1.0) / one_yk  # y d(delta)/dy
    ez = math.exp(-z)
    if z < 1.0:
        om = -math.expm1(-z)
        dt = math.log(l_over_a) - ein(z) + om * delta
        u_dt = -0.5 * om + 0.5 * ez * z * delta - 0.5 * om * y_ddelta
    else:
        dt = d_inf - e1(z) - ez * delta
        u_dt = -0.5 * y_dinf + 0.5 * ez + 0.5 * ez * z * delta + 0.5 * ez * y_ddelta
    return dt, u_dt


@njit(**KERNEL)
def tangential_coefficients(u: float, d: float, mu: float, rho: float, length: float):
    """(f_t/U, df_t/dU) in Pa s for tangential relative speed u >= 0; f_t/U -> mu_s."""
    dt, u_dt = tangential_log(rho * u * length / mu, 2.0 * length / d)
    g = 2.0 * math.pi * mu / dt
    return g, g * (dt - u_dt) / dt


@njit(**KERNEL)
def tangential_drag(u: float, d: float, mu: float, rho: float, length: float):
    """Tangential drag per length f_t (N/m) at tangential relative speed u >= 0, and df_t/dU."""
    g, fp = tangential_coefficients(u, d, mu, rho, length)
    return g * u, fp


@njit(**KERNEL)
def law(ux, uy, uz, tx, ty, tz, d, mu, rho, len_n, len_t, force, jac_u, jac_t) -> float:
    """Force per length F (N/m) of the finite_re law into ``force`` (3,), dF/du and dF/dt
    (Pa s; N/m per unit of t) into ``jac_u``, ``jac_t`` (3, 3); returns -F.u (W/m).

    u (m/s) velocity relative to the bath, t the unit tangent (taken as a free vector: chain
    dF/de = dF/dt (I - t t^T)/|e|), d the diameter (m), mu (Pa s), rho (kg/m^3), ``len_n``,
    ``len_t`` the lengths L of the normal and the tangential laws' logarithms (m; both the
    scene's length scale without hydrodynamics). No allocation.

    With s = u.t, w = u_n, w^ = w/|w|:
      dF/du = -f_t' t t^T - g_n (I - t t^T) - (f_n' - g_n) w^ (w^ - (w^.t) t)^T
      dF/dt = -(g_t s I + f_t' t u^T) + g_n (s I + t u^T) + (f_n' - g_n) w^ (s w^ + (w^.t) u)^T
    """
    u = (ux, uy, uz)
    t = (tx, ty, tz)
    s = ux * tx + uy * ty + uz * tz
    w = (ux - s * tx, uy - s * ty, uz - s * tz)
    un = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    gn, fpn = normal_coefficients(un, d, mu, rho, len_n)
    gt, fpt = tangential_coefficients(abs(s), d, mu, rho, len_t)
    if un > 0.0:
        wh = (w[0] / un, w[1] / un, w[2] / un)
    else:
        wh = (0.0, 0.0, 0.0)
    wt = wh[0] * tx + wh[1] * ty + wh[2] * tz
    extra = fpn - gn  # U_n g_n'(U_n): vanishes at U_n = 0
    power = 0.0
    for a in range(3):
        fa = -gn * w[a] - gt * s * t[a]
        force[a] = fa
        power -= fa * u[a]
        for b in range(3):
            delta = 1.0 if a == b else 0.0
            jac_u[a, b] = (
                -fpt * t[a] * t[b]
                - gn * (delta - t[a] * t[b])
                - extra * wh[a] * (wh[b] - wt * t[b])
            )
            jac_t[a, b] = (
                -(gt * s * delta + fpt * t[a] * u[b])
                + gn * (s * delta + t[a] * u[b])
                + extra * wh[a] * (s * wh[b] + wt * u[b])
            )
    return power


#: :func:`oseen_law`'s Jacobian: the largest ratio of a relative speed component to the same
#: component of the speed relative to the bath with which the coefficients' derivative enters
OSEEN_JAC_RATIO_MAX = 10.0


@njit(**KERNEL)
def oseen_law(bx, by, bz, ux, uy, uz, tx, ty, tz, d, mu, rho, len_n, len_t, force, jac_u,
              jac_t, resist) -> float:  # fmt: skip
    """The finite_re law linearised about the motion relative to the bath, as Oseen's
    equations are (Oseen 1910; Lamb 1911): its coefficients g_n, g_t at the velocity b (m/s)
    relative to the bath, applied to the velocity u relative to the local flow,

        F = -g_n(|b_n|) u_n - g_t(|b.t|) (u.t) t,

    so that F is linear in the flow (the flows of distant forces superpose) and its
    resistance to that flow, Xi = g_n (I - t t^T) + g_t t t^T (Pa s, into ``resist``), is
    symmetric and known before the flow is. With u = b it is :func:`law`. F (N/m) into
    ``force``; dF/dv (b and u both move with the filament's velocity v; Pa s) into
    ``jac_u`` and dF/dt into ``jac_t``: the coefficients' derivatives enter with the ratio of
    u's component to b's, clamped to OSEEN_JAC_RATIO_MAX (the exact derivative is unbounded
    where b's component vanishes and u's does not: tangentially g_t' ~ U^-1/2). Returns -F.u
    (W/m). Other arguments as :func:`law`'s. No allocation."""
    t = (tx, ty, tz)
    sb = bx * tx + by * ty + bz * tz
    wb = (bx - sb * tx, by - sb * ty, bz - sb * tz)
    su = ux * tx + uy * ty + uz * tz
    wu = (ux - su * tx, uy - su * ty, uz - su * tz)
    u = (ux, uy, uz)
    b = (bx, by, bz)
    un = math.sqrt(wb[0] * wb[0] + wb[1] * wb[1] + wb[2] * wb[2])
    ut = abs(sb)
    gn, fpn = normal_coefficients(un, d, mu, rho, len_n)
    gt, fpt = tangential_coefficients(ut, d, mu, rho, len_t)
    extra_n = fpn - gn  # U g'(U): vanishes at U = 0
    extra_t = fpt - gt
    top = OSEEN_JAC_RATIO_MAX
    wh = (0.0, 0.0, 0.0)
    rho_n = (0.0, 0.0, 0.0)
    if un > 0.0:
        wh = (wb[0] / un, wb[1] / un, wb[2] / un)
        size = math.sqrt(wu[0] * wu[0] + wu[1] * wu[1] + wu[2] * wu[2]) / un
        cut = top / size if size > top else 1.0
        rho_n = (cut * wu[0] / un, cut * wu[1] / un, cut * wu[2] / un)
    sign_t = 0.0
    rho_t = 0.0
    if ut > 0.0:
        sign_t = 1.0 if sb > 0.0 else -1.0
        rho_t = min(max(su / ut, -top), top)
    power = 0.0
    for a in range(3):
        fa = -gn * wu[a] - gt * su * t[a]
        force[a] = fa
        power -= fa * u[a]
        for c in range(3):
            delta = 1.0 if a == c else 0.0
            resist[a, c] = gn * (delta - t[a] * t[c]) + gt * t[a] * t[c]
            jac_u[a, c] = (
                -resist[a, c] - extra_n * rho_n[a] * wh[c] - extra_t * sign_t * rho_t * t[a] * t[c]
            )
            jac_t[a, c] = (
                (gn - gt) * (su * delta + t[a] * u[c])
                + extra_n * sb * rho_n[a] * wh[c]
                - extra_t * sign_t * rho_t * t[a] * b[c]
            )
    return power


# ---- plain numpy helpers (tests, docs, validation) ---------------------------------------


def cd_lamb(re: np.ndarray) -> np.ndarray:
    """Lamb (1911) C_D of an infinite cylinder, 8 pi / (Re ln(RE_STAR/Re)), Re << 1."""
    re = np.asarray(re, dtype=float)
    return 8.0 * np.pi / (re * np.log(RE_STAR / re))


def cd_cheng(re: np.ndarray) -> np.ndarray:
    """Cheng (2013) C_D of an isolated cylinder (Re < 2e5)."""
    re = np.asarray(re, dtype=float)
    return (
        CHENG_A * re**CHENG_P
        + CHENG_B * (1.0 - np.exp(-CHENG_RB / re))
        + CHENG_C * (1.0 - np.exp(-((re / CHENG_RC) ** CHENG_PC)))
    )


def cd_cylinder(re: np.ndarray, l_over_a: float = np.inf) -> np.ndarray:
    """C_D of the finite_re normal law (blend of Lamb and Cheng); l_over_a = inf is the
    infinite cylinder, finite L/a includes the slender-body cut-off of the logarithm."""
    re = np.atleast_1d(np.asarray(re, dtype=float))
    out = np.array([normal_g(r, l_over_a)[0] / r for r in re])
    return out

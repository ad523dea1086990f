"""Stokeslet-segment kernels of the hydrodynamics effect (Lighthill's slender-body theory).

f(s) is the force per length the filament exerts on the fluid (minus the drag per length).
Lighthill (1976, SIAM Rev. 18, 161), as coupled to discrete elastic rods by Jawed, Khouri, Da,
Grinspun & Reis (2015, PRL 115, 168101): the centreline moves with the fluid velocity

    8 pi mu u(s) = 2 (I - t t) f(s) + int_{|s'-s| > delta} G(x(s) - x(s')) f(s') ds',
    G(R) = I/|R| + R R^T/|R|^3,   delta = r sqrt(e) / 2,

which for a straight rod is Keller & Rubinow's (1976, J. Fluid Mech. 75, 705) local operator
(I + t t) ln(4 s (L - s) / r^2) + (I - 3 t t) to all orders in 1/ln(L/r). Split at an arclength
a (delta < a << the radius of curvature):

* local, |s' - s| < a, the rod taken straight and f uniform: 8 pi mu u = [2 (I - t t) +
  (I + t t) Lam] f with Lam = ln(max(a_-, delta)/delta) + ln(max(a_+, delta)/delta), a_-/a_+
  the window on either side, clipped at the filament's ends. Inverted, a local resistance
  f = xi_par (u.t) t + xi_perp (u - (u.t) t), xi_par = 4 pi mu / Lam, xi_perp =
  8 pi mu / (Lam + 2) (for an interior point 2 pi mu / (ln(2a/r) - 1/2) and
  4 pi mu / (ln(2a/r) + 1/2): Cox's mu_s with L = 2a to leading order);
* nonlocal, |s' - s| > a: the exact line integral of G over the straight segments between
  nodes, each carrying a uniform f, the part inside the window clipped off in arclength.
  Optionally regularised (Cortez 2018, J. Comput. Phys. 375, 783: G_eps = (R^2 + 2 eps^2) I /
  (R^2 + eps^2)^{3/2} + R R^T / (R^2 + eps^2)^{3/2}), and optionally screened beyond an Oseen
  length l per source segment (a factor exp(-R/l), see hydrodynamics.py).

On a segment x(l) = A + l t, target y: p = (y - A).t, d = y - A - p t, D^2 = |d|^2 + eps^2,
sigma = l - p, Rs = sqrt(D^2 + sigma^2); with J0 = int dsigma/Rs, J1 = int dsigma/Rs^3,
J2 = int sigma dsigma/Rs^3, J3 = int sigma^2 dsigma/Rs^3 = J0 - [sigma/Rs]:
8 pi mu u = (J0 + eps^2 J1) f + J1 d (d.f) - J2 [d (t.f) + t (d.f)] + J3 t (t.f), evaluated
without cancellation for targets on the segment's own line. Pieces farther than ``FAR_RATIO``
times their length use 2-point Gauss-Legendre quadrature of G instead (relative error
~ (l/R)^4/270). Flat arrays pos[3 i + a]; segment j joins nodes j and j + 1; with
s_period > 0 the rod is a closed loop and segment n - 1 joins node n - 1 to node 0.
SI units.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.jit import KERNEL

SQRT_E_HALF = 0.5 * math.sqrt(math.e)  # delta = r sqrt(e)/2 (Lighthill 1976)
GL2 = 0.5 / math.sqrt(3.0)  # 2-point Gauss-Legendre nodes at 1/2 -+ GL2 of the unit interval
FAR_RATIO = 6.0  # pieces beyond this many lengths: the 2-point Gauss rule
LAM_MIN = 1.0  # floor of the local window's logarithm (a window shorter than e delta)


@njit(**KERNEL, inline="always")
def _seg_integrals(y0, y1, y2, a0, a1, a2, t0, t1, t2, lo, hi, eps2):
    """J0..J3 and the perpendicular offset d of target y from the line A + l t, l in [lo, hi]."""
    w0 = y0 - a0
    w1 = y1 - a1
    w2 = y2 - a2
    p = w0 * t0 + w1 * t1 + w2 * t2
    d0 = w0 - p * t0
    d1 = w1 - p * t1
    d2 = w2 - p * t2
    dd = d0 * d0 + d1 * d1 + d2 * d2 + eps2
    s1 = lo - p
    s2 = hi - p
    r1 = math.sqrt(dd + s1 * s1)
    r2 = math.sqrt(dd + s2 * s2)
    if s1 >= 0.0:
        j0 = math.log((s2 + r2) / (s1 + r1))
    elif s2 <= 0.0:
        j0 = math.log((r1 - s1) / (r2 - s2))
    else:
        j0 = math.log((s2 + r2) * (r1 - s1) / dd)
    if s1 * s2 > 0.0:
        # [sigma/(D^2 Rs)] without the 0/0 of a collinear target
        j1 = (s2 - s1) * (s2 + s1) / (r1 * r2 * (s2 * r1 + s1 * r2))
    else:
        j1 = (s2 / r2 - s1 / r1) / dd
    j2 = 1.0 / r1 - 1.0 / r2
    j3 = j0 - (s2 / r2 - s1 / r1)
    return j0, j1, j2, j3, d0, d1, d2


@njit(**KERNEL, inline="always")
def point_velocity(r0, r1, r2, f0, f1, f2, eps2):
    """8 pi mu x the velocity at R of a (regularised) point Stokeslet of strength f."""
    rr = r0 * r0 + r1 * r1 + r2 * r2
    q = rr + eps2
    inv3 = 1.0 / (q * math.sqrt(q))
    rf = (r0 * f0 + r1 * f1 + r2 * f2) * inv3
    iso = (rr + 2.0 * eps2) * inv3
    return iso * f0 + rf * r0, iso * f1 + rf * r1, iso * f2 + rf * r2


@njit(**KERNEL, inline="always")
def _screen(dist2: float, screen: float) -> float:
    """exp(-R / l), 1 without screening (l = inf)."""
    if screen >= 1e300:
        return 1.0
    return math.exp(-math.sqrt(dist2) / screen)


@njit(**KERNEL, inline="always")
def add_piece(y0, y1, y2, a0, a1, a2, t0, t1, t2, ln, lo, hi, f0, f1, f2, eps2, far2, screen):
    """8 pi mu x the velocity at y of the fraction [lo, hi] of a segment (A, tangent t, length
    ln) carrying f: exact, or the 2-point Gauss rule when far; screened by exp(-R/l) (at the
    Gauss points, or at the piece's middle for the exact integral)."""
    hl = 0.5 * (hi - lo) * ln
    m = 0.5 * (lo + hi) * ln
    r0 = y0 - (a0 + m * t0)
    r1 = y1 - (a1 + m * t1)
    r2 = y2 - (a2 + m * t2)
    dist2 = r0 * r0 + r1 * r1 + r2 * r2
    piece = 2.0 * hl
    if dist2 > far2 * piece * piece:
        g = GL2 * piece
        q0, q1, q2 = r0 - g * t0, r1 - g * t1, r2 - g * t2
        p0, p1, p2 = r0 + g * t0, r1 + g * t1, r2 + g * t2
        u0, u1, u2 = point_velocity(q0, q1, q2, f0, f1, f2, eps2)
        v0, v1, v2 = point_velocity(p0, p1, p2, f0, f1, f2, eps2)
        su = _screen(q0 * q0 + q1 * q1 + q2 * q2, screen)
        sv = _screen(p0 * p0 + p1 * p1 + p2 * p2, screen)
        return hl * (su * u0 + sv * v0), hl * (su * u1 + sv * v1), hl * (su * u2 + sv * v2)
    j0, j1, j2, j3, d0, d1, d2 = _seg_integrals(
        y0, y1, y2, a0, a1, a2, t0, t1, t2, lo * ln, hi * ln, eps2
    )
    df = d0 * f0 + d1 * f1 + d2 * f2
    tf = t0 * f0 + t1 * f1 + t2 * f2
    iso = j0 + eps2 * j1
    sc = _screen(dist2, screen)
    return (
        sc * (iso * f0 + j1 * d0 * df - j2 * (d0 * tf + t0 * df) + j3 * t0 * tf),
        sc * (iso * f1 + j1 * d1 * df - j2 * (d1 * tf + t1 * df) + j3 * t1 * tf),
        sc * (iso * f2 + j1 * d2 * df - j2 * (d2 * tf + t2 * df) + j3 * t2 * tf),
    )


@njit(**KERNEL)
def nonlocal_flow(
    targets, target_s, n_targets, pos, node_s, n_seg, seg_force, screen, mu, eps, a_cut,
    s_period, out_vel,
):  # fmt: skip
    """Velocities (m/s) at ``n_targets`` points (arclength ``target_s``) from segments
    0..n_seg-1 of the rod ``pos`` (m) carrying ``seg_force`` (N/m), except the parts within
    arclength ``a_cut`` of each target (m). ``screen``: each segment's screening length (m,
    inf: none); ``eps``: Cortez's blob (m, 0: singular); ``s_period`` > 0: a closed loop of
    that length (segment n_seg-1 then joins the last node to node 0). Direct O(N M) sum into
    ``out_vel`` (overwritten); allocates nothing."""
    n_nodes = n_seg if s_period > 0.0 else n_seg + 1
    eps2 = eps * eps
    far2 = FAR_RATIO * FAR_RATIO
    c = 1.0 / (8.0 * math.pi * mu)
    for k in range(n_targets):
        y0 = targets[3 * k]
        y1 = targets[3 * k + 1]
        y2 = targets[3 * k + 2]
        sk = target_s[k]
        u0 = 0.0
        u1 = 0.0
        u2 = 0.0
        for j in range(n_seg):
            f0 = seg_force[3 * j]
            f1 = seg_force[3 * j + 1]
            f2 = seg_force[3 * j + 2]
            if f0 == 0.0 and f1 == 0.0 and f2 == 0.0:
                continue  # contributes exactly nothing
            jn = j + 1 if j + 1 < n_nodes else 0
            a0 = pos[3 * j]
            a1 = pos[3 * j + 1]
            a2 = pos[3 * j + 2]
            e0 = pos[3 * jn] - a0
            e1 = pos[3 * jn + 1] - a1
            e2 = pos[3 * jn + 2] - a2
            sa = node_s[j]
            sb = node_s[jn] if jn > 0 else s_period
            cc = sk
            if s_period > 0.0:  # the window copy nearest the segment's middle
                cc = sk + s_period * math.floor(((sa + sb) * 0.5 - sk) / s_period + 0.5)
            ee = e0 * e0 + e1 * e1 + e2 * e2
            r0 = y0 - a0 - 0.5 * e0
            r1 = y1 - a1 - 0.5 * e1
            r2 = y2 - a2 - 0.5 * e2
            scr = screen[j]
            if (sb <= cc - a_cut or sa >= cc + a_cut) and (r0 * r0 + r1 * r1 + r2 * r2 > far2 * ee):
                # the whole segment, far: 2-point Gauss-Legendre
                hl = 0.5 * math.sqrt(ee)
                g0 = GL2 * e0
                g1 = GL2 * e1
                g2 = GL2 * e2
                q0, q1, q2 = r0 - g0, r1 - g1, r2 - g2
                p0, p1, p2 = r0 + g0, r1 + g1, r2 + g2
                v0, v1, v2 = point_velocity(q0, q1, q2, f0, f1, f2, eps2)
                w0, w1, w2 = point_velocity(p0, p1, p2, f0, f1, f2, eps2)
                if scr < 1e300:
                    sv = hl * _screen(q0 * q0 + q1 * q1 + q2 * q2, scr)
                    sw = hl * _screen(p0 * p0 + p1 * p1 + p2 * p2, scr)
                else:
                    sv = hl
                    sw = hl
                u0 += sv * v0 + sw * w0
                u1 += sv * v1 + sw * w1
                u2 += sv * v2 + sw * w2
                continue
            ln = math.sqrt(ee)
            t0 = e0 / ln
            t1 = e1 / ln
            t2 = e2 / ln
            ds = sb - sa
            hi1 = min(sb, cc - a_cut)
            lo2 = max(sa, cc + a_cut)
            if hi1 > sa:
                v0, v1, v2 = add_piece(
                    y0, y1, y2, a0, a1, a2, t0, t1, t2, ln, 0.0, (hi1 - sa) / ds,
                    f0, f1, f2, eps2, far2, scr,
                )  # fmt: skip
                u0 += v0
                u1 += v1
                u2 += v2
            if sb > lo2:
                v0, v1, v2 = add_piece(
                    y0, y1, y2, a0, a1, a2, t0, t1, t2, ln, (lo2 - sa) / ds, 1.0,
                    f0, f1, f2, eps2, far2, scr,
                )  # fmt: skip
                u0 += v0
                u1 += v1
                u2 += v2
        out_vel[3 * k] = c * u0
        out_vel[3 * k + 1] = c * u1
        out_vel[3 * k + 2] = c * u2


@njit(**KERNEL, inline="always")
def window_log(a_minus: float, a_plus: float, r: float) -> float:
    """Lam = ln(max(a_-, delta)/delta) + ln(max(a_+, delta)/delta), delta = r sqrt(e)/2, at
    least LAM_MIN (a window shorter than e delta is not slender)."""
    delta = SQRT_E_HALF * r
    lam = math.log(max(a_minus, delta) / delta) + math.log(max(a_plus, delta) / delta)
    return max(lam, LAM_MIN)


@njit(**KERNEL, inline="always")
def window_coefficients(
    a_minus: float, a_plus: float, r: float, mu: float, shift_par: float, shift_perp: float
):
    """(xi_par, xi_perp) in Pa s: the local resistance of the straight window (a_-, a_+) of a
    filament of radius r, f = xi_par (u.t) t + xi_perp (u - (u.t) t): 4 pi mu / Lam_par and
    8 pi mu / (Lam_perp + 2), Lam_par = Lam + ``shift_par``, Lam_perp = Lam + ``shift_perp``
    (the RPY kernel's, :func:`._rpy.window_shift`; 0 for Stokeslet segments), each at least
    LAM_MIN."""
    lam = window_log(a_minus, a_plus, r)
    lam_par = max(lam + shift_par, LAM_MIN)
    lam_perp = max(lam + shift_perp, LAM_MIN)
    return 4.0 * math.pi * mu / lam_par, 8.0 * math.pi * mu / (lam_perp + 2.0)


@njit(**KERNEL, inline="always")
def window_lengths(a_minus: float, a_plus: float, r: float, shift_par: float, shift_perp: float):
    """(L_n, L_t): the lengths of the finite_re law's normal and tangential logarithms
    ln(L/r) that make its zero-speed limit the window's resistance: xi_perp = 4 pi mu /
    ln(L_n/r), xi_par = 2 pi mu / ln(L_t/r), i.e. L_n = r e^(Lam_perp/2 + 1), L_t =
    r e^(Lam_par/2) (shifts as in :func:`window_coefficients`)."""
    lam = window_log(a_minus, a_plus, r)
    lam_par = max(lam + shift_par, LAM_MIN)
    lam_perp = max(lam + shift_perp, LAM_MIN)
    return r * math.exp(0.5 * lam_perp + 1.0), r * math.exp(0.5 * lam_par)


# ---- the fast multipole method (fmm3dpy, outside numba) ----------------------------------


@njit(**KERNEL)
def gauss_sources(pos, n_seg, seg_force, src, charge) -> None:
    """Two Gauss points per segment: src[3, 2 n_seg] (m) and charge[3, 2 n_seg] = (l/2) f (N)."""
    for j in range(n_seg):
        hl = 0.0
        for a in range(3):
            e = pos[3 * j + 3 + a] - pos[3 * j + a]
            hl += e * e
        hl = 0.5 * math.sqrt(hl)
        for a in range(3):
            e = pos[3 * j + 3 + a] - pos[3 * j + a]
            m = pos[3 * j + a] + 0.5 * e
            src[a, 2 * j] = m - GL2 * e
            src[a, 2 * j + 1] = m + GL2 * e
            charge[a, 2 * j] = hl * seg_force[3 * j + a]
            charge[a, 2 * j + 1] = hl * seg_force[3 * j + a]


@njit(**KERNEL)
def near_correction(pos, node_s, n_targets, n_seg, seg_force, mu, eps, a_cut, out) -> None:
    """At each target node, replace the Gauss points of the segments near in arclength
    (within a_cut + FAR_RATIO x the longest segment) by the exact clipped integral."""
    c = 1.0 / (8.0 * math.pi * mu)
    eps2 = eps * eps
    far2 = FAR_RATIO * FAR_RATIO
    l_max = 0.0
    for j in range(n_seg):
        l_max = max(l_max, node_s[j + 1] - node_s[j])
    reach = a_cut + FAR_RATIO * 1.5 * l_max  # (segments may stretch)
    for i in range(n_targets):
        y0 = pos[3 * i]
        y1 = pos[3 * i + 1]
        y2 = pos[3 * i + 2]
        si = node_s[i]
        j = min(i, n_seg - 1)
        while j > 0 and node_s[j] > si - reach:
            j -= 1
        while j < n_seg and node_s[j] < si + reach:
            a0 = pos[3 * j]
            a1 = pos[3 * j + 1]
            a2 = pos[3 * j + 2]
            e0 = pos[3 * j + 3] - a0
            e1 = pos[3 * j + 4] - a1
            e2 = pos[3 * j + 5] - a2
            ln = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
            f0 = seg_force[3 * j]
            f1 = seg_force[3 * j + 1]
            f2 = seg_force[3 * j + 2]
            r0 = y0 - a0 - 0.5 * e0
            r1 = y1 - a1 - 0.5 * e1
            r2 = y2 - a2 - 0.5 * e2
            g0 = GL2 * e0
            g1 = GL2 * e1
            g2 = GL2 * e2
            v0, v1, v2 = point_velocity(r0 - g0, r1 - g1, r2 - g2, f0, f1, f2, eps2)
            w0, w1, w2 = point_velocity(r0 + g0, r1 + g1, r2 + g2, f0, f1, f2, eps2)
            hl = 0.5 * ln
            out[3 * i] -= c * hl * (v0 + w0)
            out[3 * i + 1] -= c * hl * (v1 + w1)
            out[3 * i + 2] -= c * hl * (v2 + w2)
            sa = node_s[j]
            sb = node_s[j + 1]
            t0 = e0 / ln
            t1 = e1 / ln
            t2 = e2 / ln
            hi1 = min(sb, si - a_cut)
            lo2 = max(sa, si + a_cut)
            if hi1 > sa:
                v0, v1, v2 = add_piece(
                    y0, y1, y2, a0, a1, a2, t0, t1, t2, ln, 0.0, (hi1 - sa) / (sb - sa),
                    f0, f1, f2, eps2, far2, np.inf,
                )  # fmt: skip
                out[3 * i] += c * v0
                out[3 * i + 1] += c * v1
                out[3 * i + 2] += c * v2
            if sb > lo2:
                v0, v1, v2 = add_piece(
                    y0, y1, y2, a0, a1, a2, t0, t1, t2, ln, (lo2 - sa) / (sb - sa), 1.0,
                    f0, f1, f2, eps2, far2, np.inf,
                )  # fmt: skip
                out[3 * i] += c * v0
                out[3 * i + 1] += c * v1
                out[3 * i + 2] += c * v2
            j += 1


def fmm_flow(
    pos: np.ndarray,
    node_s: np.ndarray,
    n_targets: int,
    n_seg: int,
    seg_force: np.ndarray,
    mu: float,
    eps: float,
    a_cut: float,
    precision: float,
    out: np.ndarray,
) -> None:
    """The nonlocal flow at nodes 0..n_targets-1 by fmm3dpy's Stokes FMM (``stfmm3d``): two
    point Stokeslets per segment, one FMM call, then the segments near in arclength by their
    exact clipped integrals (:func:`near_correction`). Unscreened; ``eps`` enters the near
    correction only (the FMM's Stokeslets are singular). Python (numba calls it in objmode)."""
    import fmm3dpy

    src = np.empty((3, 2 * n_seg))
    charge = np.empty((3, 2 * n_seg))
    gauss_sources(pos, n_seg, seg_force, src, charge)
    targ = np.ascontiguousarray(pos[: 3 * n_targets].reshape(n_targets, 3).T)
    res = fmm3dpy.stfmm3d(eps=precision, sources=src, stoklet=charge, targets=targ, ifppregtarg=1)
    # stfmm3d's Stokeslet carries 1/(8 pi): divide by mu only
    out[: 3 * n_targets] = (np.asarray(res.pottarg).reshape(3, n_targets) / mu).T.ravel()
    near_correction(pos, node_s, n_targets, n_seg, seg_force, mu, eps, a_cut, out)

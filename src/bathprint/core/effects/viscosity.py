"""Viscosity: the viscous stress of the alginate solution in the rod (a Kelvin-Voigt rod).

Where it leaves the needle the jet is a viscous liquid, and it stays one inside until the
gel has set; its extensional viscosity resists stretching and bending at the rates the drag
imposes. Viscous threads (Trouton 1906; Ribe 2004; Bergou et al. 2010, "Discrete viscous
threads") carry a stretching resistance eta_e A and a bending resistance eta_e I, eta_e =
Tr eta the extensional viscosity (Trouton ratio Tr = 3 for a Newtonian liquid). Here they
act beside the elastic stress, sigma = E eps + eta_e d(eps)/dt, from the Rayleigh
dissipation

    D = sum_j 1/2 (eta_e A_j / l0_j) (l0_j d(l_j/l0_j)/dt)^2 + sum_i 1/2 (eta_e I_i / dl_i) |w_i|^2,

F = -dD/dv. The first term is the rate of strain of each segment (the inlet segment's rest
length grows at the exit speed: its strain rate is dl/dt - (l/l0) dl0/dt, with the tip's
own motion, not the jet velocity it carries with inertia). The second is the co-rotational
rate of the curvature binormal kb of elasticity's bending stencil,
w = dkb/dt - omega x kb, omega = (t1 x dt1/dt + t2 x dt2/dt) / 2 the mean angular velocity
of the stencil's edges: a rotation in the stencil's plane costs nothing, a tumbling one
costs O(kb^2), and only a spin about the tangent (which a rod without a material frame
cannot tell from deformation) is resisted. A and I are the alginate's section outside a
concentric column of co-extruded inner fluid of volume fraction phi: A = pi r^2 (1 - phi),
I = pi r^4 (1 - phi^2) / 4. Strains are measured on the rest section and length (the law
is a small-strain one, as the elastic one is). The Jacobian is exact, in the velocities
and in the positions (for bending, the derivative of each stencil's force in its edges is
analytic: ``bend_rate_grad_hess``). Returns the dissipation rate 2D (W), as drag does.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.effects._band import add_block
from bathprint.core.effects.elasticity import add_bend_hessian, add_stencil_force
from bathprint.core.extrusion import flow_rate
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import MAT_INNER_FRACTION, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes


@njit(**KERNEL, inline="always")
def _section(seg_mat: np.ndarray, j: int) -> tuple[float, float]:
    """(A, I) of segment j's alginate (m^2, m^4), outside its inner fluid column."""
    r = seg_mat[j, MAT_RADIUS]
    phi = seg_mat[j, MAT_INNER_FRACTION]
    return math.pi * r * r * (1.0 - phi), 0.25 * math.pi * r**4 * (1.0 - phi * phi)


@njit(**KERNEL)
def bend_rate_grad(
    e1: np.ndarray,
    e2: np.ndarray,
    u1: np.ndarray,
    u2: np.ndarray,
    k: float,
    grad: np.ndarray,
    jhat: np.ndarray,
) -> float:
    """The stencil's dissipation 1/2 k |w|^2 (W); its gradient k Jh^T w in the edge
    velocities (``grad``, 6) and Jh = dw/du (``jhat``, flat 3 x 6, row m at 6 m).

    w = Jh u with Jh_s = J_s + [kb]x [e_s]x / (2 |e_s|^2), J_s = dkb/de_s =
    (2/D) C_s - kb g_s^T / D (D = |e1||e2| + e1.e2, g_s = dD/de_s, C_1 = [-e2]x,
    C_2 = [e1]x), since -omega x kb = [kb]x omega and t x dt/dt = e x u / |e|^2."""
    l1 = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    l2 = math.sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2])
    inv_d = 1.0 / (l1 * l2 + e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2])
    kb = (
        2.0 * (e1[1] * e2[2] - e1[2] * e2[1]) * inv_d,
        2.0 * (e1[2] * e2[0] - e1[0] * e2[2]) * inv_d,
        2.0 * (e1[0] * e2[1] - e1[1] * e2[0]) * inv_d,
    )
    for s in range(2):
        e = e1 if s == 0 else e2
        o = e2 if s == 0 else e1
        ratio = l2 / l1 if s == 0 else l1 / l2
        sign = -2.0 * inv_d if s == 0 else 2.0 * inv_d  # C_1 = -[e2]x, C_2 = [e1]x
        half_inv_l2 = 0.5 / (e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        # [kb]x [e]x = e kb^T - (kb.e) I
        kbe = kb[0] * e[0] + kb[1] * e[1] + kb[2] * e[2]
        for m in range(3):
            for a in range(3):
                g_a = ratio * e[a] + o[a]
                cross = 0.0  # ([c]x)(m, a) = -eps_mab c_b, c = o (the other edge)
                if m == 0 and a == 1:
                    cross = -o[2]
                elif m == 0 and a == 2:
                    cross = o[1]
                elif m == 1 and a == 0:
                    cross = o[2]
                elif m == 1 and a == 2:
                    cross = -o[0]
                elif m == 2 and a == 0:
                    cross = -o[1]
                elif m == 2 and a == 1:
                    cross = o[0]
                rot = e[m] * kb[a] - (kbe if m == a else 0.0)
                jhat[6 * m + 3 * s + a] = sign * cross - kb[m] * g_a * inv_d + half_inv_l2 * rot
    w0 = 0.0
    w1 = 0.0
    w2 = 0.0
    for c in range(6):
        uc = u1[c] if c < 3 else u2[c - 3]
        w0 += jhat[c] * uc
        w1 += jhat[6 + c] * uc
        w2 += jhat[12 + c] * uc
    for c in range(6):
        grad[c] = k * (jhat[c] * w0 + jhat[6 + c] * w1 + jhat[12 + c] * w2)
    return 0.5 * k * (w0 * w0 + w1 * w1 + w2 * w2)


# offsets in the scratch of bend_rate_grad_hess (flat float64, BEND_HESS_WORK entries)
_J, _W, _E, _U, _T, _G, _DQ, _GP, _EJ = 0, 18, 36, 42, 48, 54, 60, 66, 72
_KB, _JU, _WV, _N = 84, 87, 90, 93
BEND_HESS_WORK = 96


@njit(**KERNEL, inline="always")
def _add_skew(mat: np.ndarray, row: int, col: int, c: np.ndarray, off: int, scale: float) -> None:
    """mat[row:row+3, col:col+3] += scale [c]x, c = c[off:off+3] ([c]x v = c x v)."""
    mat[row, col + 1] -= scale * c[off + 2]
    mat[row, col + 2] += scale * c[off + 1]
    mat[row + 1, col] += scale * c[off + 2]
    mat[row + 1, col + 2] -= scale * c[off]
    mat[row + 2, col] -= scale * c[off + 1]
    mat[row + 2, col + 1] += scale * c[off]


@njit(**KERNEL)
def bend_rate_grad_hess(
    e1: np.ndarray,
    e2: np.ndarray,
    u1: np.ndarray,
    u2: np.ndarray,
    k: float,
    grad: np.ndarray,
    jhat: np.ndarray,
    work: np.ndarray,
    dgrad_de: np.ndarray,
) -> float:
    """``bend_rate_grad`` (its return value, ``grad`` and ``jhat``) and the exact derivative
    of ``grad`` in the edges at fixed u: ``dgrad_de[c, q]`` = d grad_c / d e_q (6 x 6, over
    [e1, e2]); ``work`` is scratch of ``BEND_HESS_WORK`` or more entries.

    d grad/de = k (Jh^T W + M), W = d(Jh u)/de at fixed u (3 x 6) and
    M = d(Jh^T lam)/de at fixed lam = w (6 x 6). With J = dkb/de, g = dD/de, q = g.u,
    h_s = 1/(2|e_s|^2), A = sum_s h_s (e_s u_s^T - u_s e_s^T) = -[n]x (n = sum_s h_s e_s x
    u_s), R_s = e_s (kb.u_s) - u_s (kb.e_s), H_D = d2D/de2 (blocks (l2/l1)(I - t1 t1^T),
    I + t1 t2^T, I + t2 t1^T, (l1/l2)(I - t2 t2^T)) and kb.lam = 2 (e1 x e2).lam / D:

    W_r = (-(J u) g_r^T + 2 P_r - q J_r - kb (dq/de_r)^T) / D + A J_r
          + h_r ((kb.u_r) I - u_r kb^T) - 4 h_r^2 R_r e_r^T,   P_1 = -[u2]x, P_2 = [u1]x;
    M = (2 H_psi - (kb.lam) H_D - J^T lam g^T - g lam^T J) / D   (the Hessian of kb.lam;
          H_psi = d2((e1 x e2).lam)/de2: -[lam]x in block (1, 2), [lam]x in (2, 1))
        + blocks (s, r): h_s ((e_s.lam) I - lam e_s^T) J_r
          + [r = s] (h_s (kb lam^T - lam kb^T) - 4 h_s^2 (kb (e_s.lam) - lam (e_s.kb)) e_s^T).
    """
    for a in range(3):
        work[_E + a] = e1[a]
        work[_E + 3 + a] = e2[a]
        work[_U + a] = u1[a]
        work[_U + 3 + a] = u2[a]
    l1 = math.sqrt(e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    l2 = math.sqrt(e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2])
    inv_d = 1.0 / (l1 * l2 + e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2])
    work[_KB] = 2.0 * (e1[1] * e2[2] - e1[2] * e2[1]) * inv_d
    work[_KB + 1] = 2.0 * (e1[2] * e2[0] - e1[0] * e2[2]) * inv_d
    work[_KB + 2] = 2.0 * (e1[0] * e2[1] - e1[1] * e2[0]) * inv_d
    r21 = l2 / l1
    r12 = l1 / l2
    h1 = 0.5 / (e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2])
    h2 = 0.5 / (e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2])
    kbe1 = kbe2 = 0.0
    for a in range(3):
        kbe1 += work[_KB + a] * e1[a]
        kbe2 += work[_KB + a] * e2[a]
    for a in range(3):
        work[_T + a] = e1[a] / l1
        work[_T + 3 + a] = e2[a] / l2
        work[_G + a] = r21 * e1[a] + e2[a]
        work[_G + 3 + a] = r12 * e2[a] + e1[a]
    # J = dkb/de = (2 [C_1, C_2] - kb g^T) / D and Jh = J + h_s [kb]x [e_s]x, flat 3 x 6
    # (row m at 6 m), evaluated as bend_rate_grad does: the same jhat, grad and energy
    # to the bit
    jm = work[_J : _J + 18].reshape((3, 6))
    for m in range(3):
        for c in range(6):
            jm[m, c] = -(work[_KB + m] * work[_G + c] * inv_d)
    _add_skew(jm, 0, 0, work, _E + 3, -2.0 * inv_d)
    _add_skew(jm, 0, 3, work, _E, 2.0 * inv_d)
    for s in range(2):
        h = h1 if s == 0 else h2
        kbe = kbe1 if s == 0 else kbe2
        for m in range(3):
            for a in range(3):
                rot = work[_E + 3 * s + m] * work[_KB + a] - (kbe if m == a else 0.0)
                jhat[6 * m + 3 * s + a] = jm[m, 3 * s + a] + h * rot
    # J u, w = Jh u, the gradient k Jh^T w, dq/de, n
    for m in range(3):
        sj = 0.0
        sw = 0.0
        for c in range(6):
            sj += jm[m, c] * work[_U + c]
            sw += jhat[6 * m + c] * work[_U + c]
        work[_JU + m] = sj
        work[_WV + m] = sw
    w0 = work[_WV]
    w1 = work[_WV + 1]
    w2 = work[_WV + 2]
    for c in range(6):
        grad[c] = k * (jhat[c] * w0 + jhat[6 + c] * w1 + jhat[12 + c] * w2)
    energy = 0.5 * k * (w0 * w0 + w1 * w1 + w2 * w2)
    t1u1 = 0.0
    t2u2 = 0.0
    q = 0.0  # g.u = dD/dt
    kbu1 = kbu2 = 0.0
    for a in range(3):
        t1u1 += work[_T + a] * u1[a]
        t2u2 += work[_T + 3 + a] * u2[a]
        q += work[_G + a] * u1[a] + work[_G + 3 + a] * u2[a]
        kbu1 += work[_KB + a] * u1[a]
        kbu2 += work[_KB + a] * u2[a]
    for a in range(3):
        t1a = work[_T + a]
        t2a = work[_T + 3 + a]
        work[_DQ + a] = r21 * (u1[a] - t1a * t1u1) + u2[a] + t1a * t2u2
        work[_DQ + 3 + a] = r12 * (u2[a] - t2a * t2u2) + u1[a] + t2a * t1u1
    work[_N] = h1 * (e1[1] * u1[2] - e1[2] * u1[1]) + h2 * (e2[1] * u2[2] - e2[2] * u2[1])
    work[_N + 1] = h1 * (e1[2] * u1[0] - e1[0] * u1[2]) + h2 * (e2[2] * u2[0] - e2[0] * u2[2])
    work[_N + 2] = h1 * (e1[0] * u1[1] - e1[1] * u1[0]) + h2 * (e2[0] * u2[1] - e2[1] * u2[0])
    n0 = work[_N]
    n1 = work[_N + 1]
    n2 = work[_N + 2]
    # --- W = d(Jh u)/de, flat 3 x 6 ---
    wm = work[_W : _W + 18].reshape((3, 6))
    for r in range(2):
        h = h1 if r == 0 else h2
        kbu = kbu1 if r == 0 else kbu2
        kbe = kbe1 if r == 0 else kbe2
        for a in range(3):
            col = 3 * r + a
            c0 = jm[0, col]
            c1 = jm[1, col]
            c2 = jm[2, col]
            # (A J_r)[:, a] = -n x J_r[:, a]
            wm[0, col] = n2 * c1 - n1 * c2
            wm[1, col] = n0 * c2 - n2 * c0
            wm[2, col] = n1 * c0 - n0 * c1
            ga = work[_G + col]
            dqa = work[_DQ + col]
            kba = work[_KB + a]
            ea = work[_E + col]
            for m in range(3):
                rm = work[_E + 3 * r + m] * kbu - work[_U + 3 * r + m] * kbe
                wm[m, col] += inv_d * (
                    -work[_JU + m] * ga - q * jm[m, col] - work[_KB + m] * dqa
                ) - h * (work[_U + 3 * r + m] * kba + 4.0 * h * rm * ea)
            wm[a, col] += h * kbu
    _add_skew(wm, 0, 0, work, _U + 3, -2.0 * inv_d)
    _add_skew(wm, 0, 3, work, _U, 2.0 * inv_d)
    # --- d grad/de = k (Jh^T W + M), M = d(Jh^T w)/de at fixed w: the Hessian of kb.w,
    # then the rotation part ---
    phi = 0.0
    el1 = el2 = 0.0
    for a in range(3):
        phi += work[_KB + a] * work[_WV + a]
        el1 += e1[a] * work[_WV + a]
        el2 += e2[a] * work[_WV + a]
    for c in range(6):  # J^T w = d(kb.w)/de, and e_s^T J
        work[_GP + c] = jm[0, c] * work[_WV] + jm[1, c] * work[_WV + 1] + jm[2, c] * work[_WV + 2]
        work[_EJ + c] = e1[0] * jm[0, c] + e1[1] * jm[1, c] + e1[2] * jm[2, c]
        work[_EJ + 6 + c] = e2[0] * jm[0, c] + e2[1] * jm[1, c] + e2[2] * jm[2, c]
    for s in range(2):
        hs = h1 if s == 0 else h2
        el = el1 if s == 0 else el2
        for r in range(2):
            # H_D's block (s, r): c_sr I + d_sr t_s t_r^T
            d_sr = (-r21 if s == 0 else -r12) if r == s else 1.0
            for m in range(3):
                row = 3 * s + m
                pt = phi * d_sr * work[_T + row]
                gpr = work[_GP + row]
                gr = work[_G + row]
                wv = work[_WV + m]
                j0 = jhat[row]
                j1 = jhat[6 + row]
                j2 = jhat[12 + row]
                for a in range(3):
                    col = 3 * r + a
                    v = -inv_d * (pt * work[_T + col] + gpr * work[_G + col] + gr * work[_GP + col])
                    v += hs * (el * jm[m, col] - wv * work[_EJ + 6 * s + col])
                    v += j0 * wm[0, col] + j1 * wm[1, col] + j2 * wm[2, col]
                    dgrad_de[row, col] = k * v
    for s in range(2):
        hs = h1 if s == 0 else h2
        el = el1 if s == 0 else el2
        ek = kbe1 if s == 0 else kbe2
        c_ss = r21 if s == 0 else r12
        for m in range(3):
            row = 3 * s + m
            kbm = work[_KB + m]
            wv = work[_WV + m]
            rot = 4.0 * hs * (kbm * el - wv * ek)
            for a in range(3):
                v = kbm * work[_WV + a] - wv * work[_KB + a] - rot * work[_E + 3 * s + a]
                dgrad_de[row, 3 * s + a] += k * hs * v
        for a in range(3):  # the identities of H_D
            dgrad_de[3 * s + a, 3 * s + a] -= k * inv_d * phi * c_ss
            dgrad_de[3 * s + a, 3 - 3 * s + a] -= k * inv_d * phi
    _add_skew(dgrad_de, 0, 3, work, _WV, -2.0 * k * inv_d)
    _add_skew(dgrad_de, 3, 0, work, _WV, 2.0 * k * inv_d)
    return energy


@kernel
def accumulate(model, rod, stage, out) -> float:
    """Add the viscous forces of stretching and bending (and their Jacobian); return the
    dissipation rate (W)."""
    p = model.params[0]
    pos, vel, n_nodes, seg_rest, seg_mat = rod.pos, rod.vel, rod.n_nodes, rod.seg_rest, rod.seg_mat
    force, band = out.force, out.band
    cx, cv, do_jac = stage.cx, stage.cv, stage.jac
    n_free = free_nodes(n_nodes, p)
    n_seg = filament_segments(n_nodes, p)
    eta_e = p.trouton_ratio * p.solution_viscosity
    sc = out.scratch
    blk = sc.blk_a
    power = 0.0
    # the inlet segment (clamped: the last one) grows at the exit speed; with inertia the
    # tip and the ghost carry the jet's velocity along the needle direction d
    # (extrusion.set_boundary), which is not their motion: it is taken off their velocity
    inlet = n_seg - 1 if p.clamped else -1
    growth = 0.0
    carried = 0.0
    d_hat = sc.edges[2]
    for a in range(3):
        d_hat[a] = 0.0
    if p.clamped:
        qo, qi = flow_rate(model.flow, stage.t)
        growth = (qo + qi) / p.needle_area
        carried = growth if p.inertial else 0.0
        tip = 3 * (n_nodes - 2)
        dn = 0.0
        for a in range(3):
            d_hat[a] = pos[tip + a] - pos[tip + 3 + a]
            dn += d_hat[a] * d_hat[a]
        for a in range(3):
            d_hat[a] /= math.sqrt(dn)
    # --- stretching: tension (eta_e A / l0) l0 d(l/l0)/dt along each segment ---
    for j in range(n_seg):
        area, _ = _section(seg_mat, j)
        l0 = seg_rest[j]
        k = eta_e * area / l0
        e = (
            pos[3 * j + 3] - pos[3 * j],
            pos[3 * j + 4] - pos[3 * j + 1],
            pos[3 * j + 5] - pos[3 * j + 2],
        )
        u = (
            vel[3 * j + 3] - vel[3 * j],
            vel[3 * j + 4] - vel[3 * j + 1],
            vel[3 * j + 5] - vel[3 * j + 2],
        )
        shrink = 0.0  # (dl0/dt) / l0: the inlet's growth
        if j == inlet:
            u = (u[0] - carried * d_hat[0], u[1] - carried * d_hat[1], u[2] - carried * d_hat[2])
            shrink = growth / l0
        length = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        tt = (e[0] / length, e[1] / length, e[2] / length)
        ut = tt[0] * u[0] + tt[1] * u[1] + tt[2] * u[2]  # dl/dt
        rate = ut - shrink * length  # l0 d(l/l0)/dt
        tension = k * rate
        power += tension * rate
        for a in range(3):
            force[3 * j + a] += tension * tt[a]
            force[3 * j + 3 + a] -= tension * tt[a]
        if do_jac:
            # F_j = k (t.u - shrink l) t = k (t.u) t - k shrink e: dF_j/du = k t t^T,
            # dF_j/de = k [t (P u)^T + (t.u) P] / l - k shrink I
            pu = (u[0] - ut * tt[0], u[1] - ut * tt[1], u[2] - ut * tt[2])
            for a in range(3):
                for b in range(3):
                    eye = 1.0 if a == b else 0.0
                    pab = eye - tt[a] * tt[b]
                    blk[a, b] = cv * k * tt[a] * tt[b] + cx * k * (
                        (tt[a] * pu[b] + ut * pab) / length - shrink * eye
                    )
            add_block(band, n_free, j, j, blk, 1.0)
            add_block(band, n_free, j + 1, j + 1, blk, 1.0)
            add_block(band, n_free, j, j + 1, blk, -1.0)
            add_block(band, n_free, j + 1, j, blk, -1.0)
    # --- bending: the co-rotational rate of the curvature binormal at nodes 1..n-2 ---
    e1 = sc.edges[0]
    e2 = sc.edges[1]
    u1 = sc.edge_rates[0]
    u2 = sc.edge_rates[1]
    grad = sc.bend_grad
    hess = sc.bend_hess
    work = sc.bend_work
    jhat = work[0:18]
    hwork = work[18 : 18 + BEND_HESS_WORK]
    for i in range(1, n_nodes - 1):
        ja = i - 1
        jb = i if i < n_seg else i - 1  # the ghost segment carries the inlet's material
        dl = 0.5 * (seg_rest[i - 1] + seg_rest[i])  # (as elasticity: the ghost has none)
        k = eta_e * 0.5 * (_section(seg_mat, ja)[1] + _section(seg_mat, jb)[1]) / dl
        for a in range(3):
            e1[a] = pos[3 * i + a] - pos[3 * i - 3 + a]
            e2[a] = pos[3 * i + 3 + a] - pos[3 * i + a]
            u1[a] = vel[3 * i + a] - vel[3 * i - 3 + a]
            u2[a] = vel[3 * i + 3 + a] - vel[3 * i + a]
            if i == inlet:  # e2 ends at the tip
                u2[a] -= carried * d_hat[a]
            elif i == inlet + 1:  # e1 ends at the tip (e2: tip to ghost, both carried)
                u1[a] -= carried * d_hat[a]
        if not do_jac or cx == 0.0:
            power += 2.0 * bend_rate_grad(e1, e2, u1, u2, k, grad, jhat)
        else:  # hess = d grad/de, exact
            power += 2.0 * bend_rate_grad_hess(e1, e2, u1, u2, k, grad, jhat, hwork, hess)
        add_stencil_force(force, i, grad)  # (the edge forces are -grad, as elasticity's)
        if not do_jac:
            continue
        # edge forces F = -grad: -dF/du = k Jh^T Jh (cv), -dF/de = d grad/de (cx)
        for r in range(6):
            for c in range(6):
                jtj = jhat[r] * jhat[c] + jhat[6 + r] * jhat[6 + c] + jhat[12 + r] * jhat[12 + c]
                hess[r, c] = cv * k * jtj + (cx * hess[r, c] if cx != 0.0 else 0.0)
        add_bend_hessian(band, n_free, i, hess, 1.0)
    return power

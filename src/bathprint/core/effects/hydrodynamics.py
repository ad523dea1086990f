"""Hydrodynamics: nonlocal slender-body flow (effect 'hydrodynamics').

Every part of the filament pushes on the fluid, and the fluid it moves carries the rest of
the filament along. Lighthill's slender-body theory (:mod:`._stokeslet`) gives the velocity
of the centreline from the force per length f on the fluid; split at an arclength a
(``hydrodynamics.cutoff_radii`` x the radius) it reads

    v_i - u_bath = u_nl,i + Xi_i^-1 f_i,   u_nl = sum_j int_{|s'-s_i| > a} G f_j ds' / (8 pi mu),

the local resistance Xi_i of the straight window |s' - s_i| < a (clipped at the filament's
ends) plus the flow u_nl of the Stokeslet segments beyond it. The filament's force on the
fluid is the sum of its other forces (elastic, gravity, floor, contact, inertia: everything
but drag), so at node i with its share w_i of the length

    f_i = F_other,i / w_i,      F_drag,i = -sum_{j at i} (l_j/2) Xi_ij (v_i - u_bath - u_nl,i):

the drag law is the local part, seen at the velocity relative to the flow the rest of the
filament makes (the mobility form: u_nl comes from F_other, not from the drag being
solved for, so no fixed point has to be found). Segment j carries the mean of its nodes' f;
a prescribed node (the needle tip) pushes with its local drag; the segment inside the needle
pushes nothing. At convergence F_drag = -F_other node by node, so the forces on the fluid
total minus the net drag (momentum balance).

**Kernel** (``hydrodynamics.kernel``). ``slender_body``: u_nl from Lighthill's Stokeslet
segments beyond each node's window (:mod:`._stokeslet`). ``rpy``: from Rotne-Prager-Yamakawa
blobs at the nodes, less the blobs' share of each window, with gates that keep the
filament's mobility positive definite for any shape (:mod:`._rpy`), where the Stokeslet
segments' is not once turns touch.

**What drag does when hydrodynamics is listed.** The drag kernel is not called; this effect
evaluates the scene's drag law on its windows instead (``calls`` counts both):
``drag.model = "cox"``: Lighthill's window resistance xi_par = 4 pi mu / Lam, xi_perp =
8 pi mu / (Lam + 2), Lam = ln(max(a_-, delta)/delta) + ln(max(a_+, delta)/delta),
delta = r sqrt(e)/2 (Cox's mu_s and ``drag.length_scale_mm`` are not used: the rod's own
length enters through the nonlocal part). ``drag.model = "finite_re"``: the finite-Reynolds
law with the window's lengths L_n = r e^(Lam/2 + 1), L_t = r e^(Lam/2) in its logarithms (its
zero-speed limit is then the same window resistance), and the Stokeslets screened beyond the
Oseen length l_O = 2 nu / |u| of each source segment (a factor exp(-R / l_O); the constant
makes a long straight rod in cross-flow at Re_d << 1 feel Lamb's drag). Where
l_O < a the nonlocal part vanishes and the local finite_re law is what remains. With the RPY
kernel, two things differ so that the mobility stays positive definite: each pair of blobs
is screened by Paciorek & Schervish's kernel of the two nodes' Oseen lengths
(:func:`._rpy.screening_factor`: exp(-R / l_O) where they are equal), and the law is
linearised about the motion relative to the bath, as Oseen's equations are (its
coefficients at the velocity relative to the bath, applied to the velocity relative to the
flow: :func:`._drag_laws.oseen_law`), so that its resistance to the flow, which the gates
need, is known before the flow is. ``constant`` is refused.

**Coupling** (``hydrodynamics.coupling``). ``implicit``: u_nl is a function of the stage's
positions, evaluated at every Newton iterate; the Newton matrix gains the dense part
R M_nl W^-1 J_other (R = -dF_drag/du, J_other the Newton matrix of the other effects but
contact), which GMRES applies matrix-free (:func:`apply_nonlocal`) with the banded LU as
preconditioner (:mod:`bathprint.core.solver`). Leaving contact out makes Newton's matrix
inexact, not its residual: the flow of contact's forces is in u_nl at every iterate. With
contact's blocks in J_other (its dashpot's, beta E''/(h gamma), among them) GMRES stalled
sooner on a pile: the ablation's "all" at d = 0.41 mm, 0.5 ml/min at 1.52 s rather than
2.20 s (CHANGELOG; ``python experiments/hydrodynamics/hydrodynamics.py all_effects``).
``lagged``: u_nl of a step is the flow at its start (Tornberg & Shelley 2004, J. Comput.
Phys. 196, 8); first order, so its error, about
(h/2) |u_nl(t + h) - u_nl(t)|, is added to the step's error estimate (:mod:`._hydro_lag`).

Where the Stokes far field holds: within the Oseen length nu / |u| of a moving segment. With
``drag.model = "finite_re"`` the Stokeslets are screened beyond it (a heuristic with the right
leading logarithm, not the Oseen tensor's wake); with ``cox`` the flow is Stokes flow.
Further limits: no wall images (the floor), no frozen tail (refused), the needle is not a body.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, objmode

from bathprint.core.banded import band_matvec
from bathprint.core.effects._drag_laws import law, oseen_law
from bathprint.core.effects._rpy import rpy_flow, rpy_gates
from bathprint.core.effects._stokeslet import (
    fmm_flow,
    nonlocal_flow,
    window_coefficients,
    window_lengths,
)
from bathprint.core.effects.drag import add_law_share
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import DRAG_FINITE_RE, HYDRO_IMPLICIT, HYDRO_RPY, KL, KU, MAT_RADIUS
from bathprint.core.topology import filament_segments, free_nodes

# l_O = OSEEN_FACTOR nu / |u|: with it the window (Lam = 2 ln(a/delta)) and the screened
# Stokeslets of a long straight rod in cross-flow give 8 pi mu U = 2 f [1 + ln(l_O/delta) -
# gamma] (the nonlocal integral is 2 E1(a/l_O) ~ 2 (ln(l_O/a) - gamma)), which is Lamb's
# 8 pi mu U = 2 f ln(7.4055/Re_d) exactly when l_O = 2 nu / U
OSEEN_FACTOR = 2.0


@njit(**KERNEL, inline="always")
def _oseen_length(nu: float, speed: float) -> float:
    """The Oseen length OSEEN_FACTOR nu / |u| (m) at relative speed ``speed`` (inf at rest)."""
    return OSEEN_FACTOR * nu / speed if speed > 0.0 else np.inf


@kernel
def geometry(p, rod, n_seg: int, hyd, sc) -> None:
    """Each filament node's share of the length (``hyd.weight``) and its window sides
    (``hyd.sides``: a_-, a_+, clipped at the ends; arclength is the material coordinate);
    for the RPY kernel also its blob radius (``hyd.blob``: ``rpy_radii`` x the mean radius
    of its segments), its Oseen length (``hyd.screen``, with screening; inf: none), its window
    law's resistance at its velocity relative to the bath (``hyd.resist_window``, N s/m) and
    its gate (:func:`._rpy.rpy_gates`)."""
    pos, vel, node_s = rod.pos, rod.vel, rod.node_s
    a_cut = p.hydro_cutoff
    rpy = p.hydro_kernel == HYDRO_RPY
    if rpy:
        _discrete_sides(node_s, n_seg, a_cut, hyd)
    else:
        s0 = node_s[0]
        s1 = node_s[n_seg]
        for i in range(n_seg + 1):
            hyd.sides[0, i] = min(a_cut, node_s[i] - s0)
            hyd.sides[1, i] = min(a_cut, s1 - node_s[i])
    w, blob, rw = hyd.weight, hyd.blob, hyd.resist_window
    ratio = 0.5 * p.hydro_rpy_radii
    fx, fy, fz = p.bath_flow[0], p.bath_flow[1], p.bath_flow[2]
    nu = p.bath_viscosity / p.bath_density_top
    for i in range(n_seg + 1):
        w[i] = 0.0
        blob[i] = 0.0
        for a in range(3):
            for b in range(3):
                rw[i, a, b] = 0.0
        if rpy:
            u0, u1, u2 = vel[3 * i] - fx, vel[3 * i + 1] - fy, vel[3 * i + 2] - fz
            speed = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
            hyd.screen[i] = _oseen_length(nu, speed) if p.hydro_screening else np.inf
    for j in range(n_seg):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        length = math.sqrt(ex * ex + ey * ey + ez * ez)
        w[j] += 0.5 * length
        w[j + 1] += 0.5 * length
        if not rpy:
            continue
        r = rod.seg_mat[j, MAT_RADIUS]
        tt = (ex / length, ey / length, ez / length)
        for i in range(j, j + 2):
            blob[i] += ratio * r
            rel = (vel[3 * i] - fx, vel[3 * i + 1] - fy, vel[3 * i + 2] - fz)
            _window_law(p, hyd, i, r, rel, rel[0], rel[1], rel[2], tt, sc)
            for a in range(3):
                for b in range(3):
                    rw[i, a, b] += 0.5 * length * sc.law_xi[a, b]
    if not rpy:
        return
    if n_seg > 0:  # the end nodes have one segment
        blob[0] *= 2.0
        blob[n_seg] *= 2.0
    rpy_gates(pos, node_s, n_seg + 1, blob, rw, hyd.screen, a_cut, p.bath_viscosity, hyd.gate)


@kernel
def _discrete_sides(node_s, n_seg: int, a_cut: float, hyd) -> None:
    """The RPY kernel's windows: each side ends halfway between the last node within
    arclength a of node i and the next one (so the law's window and the blobs beyond it
    share the filament without gap or overlap, whichever side of a a node falls on), or at
    the filament's end; ``hyd.beyond`` counts the sides with blobs beyond them."""
    for i in range(n_seg + 1):
        si = node_s[i]
        j = i
        while j > 0 and si - node_s[j - 1] < a_cut:
            j -= 1
        full = 0.0
        if j > 0:
            hyd.sides[0, i] = si - 0.5 * (node_s[j] + node_s[j - 1])
            full += 1.0
        else:
            hyd.sides[0, i] = si - node_s[0]
        j = i
        while j < n_seg and node_s[j + 1] - si < a_cut:
            j += 1
        if j < n_seg:
            hyd.sides[1, i] = 0.5 * (node_s[j] + node_s[j + 1]) - si
            full += 1.0
        else:
            hyd.sides[1, i] = node_s[n_seg] - si
        hyd.beyond[i] = full


@njit(**KERNEL, inline="always")
def _window_law(p, hyd, i: int, r: float, b, u0, u1, u2, tt, sc) -> float:
    """The drag law on node i's window for a segment of radius r and tangent tt, the node
    moving at b relative to the bath and at u relative to the local flow: force per length
    into ``sc.law_force``, dF/dv, dF/dt into ``sc.law_du``, ``sc.law_dt``, the resistance to
    the flow -dF/du_nl into ``sc.law_xi``; returns -F.u (W/m). finite_re with the RPY
    kernel: the law linearised about the motion relative to the bath
    (:func:`._drag_laws.oseen_law`, so that its resistance is known before the flow is, as
    the gates need); otherwise the law at u."""
    f3, du, dt, xi = sc.law_force, sc.law_du, sc.law_dt, sc.law_xi
    am = hyd.sides[0, i]
    ap = hyd.sides[1, i]
    shift_par = shift_perp = 0.0
    if p.hydro_kernel == HYDRO_RPY:  # each side with blobs beyond it (not clipped at an end)
        shift_par = hyd.beyond[i] * p.hydro_rpy_shift_par
        shift_perp = hyd.beyond[i] * p.hydro_rpy_shift_perp
    if p.drag_model == DRAG_FINITE_RE:
        len_n, len_t = window_lengths(am, ap, r, shift_par, shift_perp)
        if p.hydro_kernel == HYDRO_RPY:
            return oseen_law(
                b[0], b[1], b[2], u0, u1, u2, tt[0], tt[1], tt[2], 2.0 * r, p.bath_viscosity,
                p.bath_density_top, len_n, len_t, f3, du, dt, xi,
            )  # fmt: skip
        power = law(
            u0, u1, u2, tt[0], tt[1], tt[2], 2.0 * r, p.bath_viscosity, p.bath_density_top,
            len_n, len_t, f3, du, dt,
        )  # fmt: skip
        for a in range(3):
            for c in range(3):
                xi[a, c] = -du[a, c]
        return power
    xp, xn = window_coefficients(am, ap, r, p.bath_viscosity, shift_par, shift_perp)
    s = u0 * tt[0] + u1 * tt[1] + u2 * tt[2]
    u = (u0, u1, u2)
    power = 0.0
    for a in range(3):
        fa = -xn * u[a] - (xp - xn) * s * tt[a]
        f3[a] = fa
        power -= fa * u[a]
        for b in range(3):
            delta = 1.0 if a == b else 0.0
            du[a, b] = -xn * delta - (xp - xn) * tt[a] * tt[b]
            dt[a, b] = -(xp - xn) * (s * delta + tt[a] * u[b])
            xi[a, b] = -du[a, b]
    return power


@kernel
def sources(model, rod, out, n_free: int, n_seg: int) -> None:
    """The force per length on the fluid: at free nodes the other effects' force (in
    ``out.force`` when this runs, after them) over the node's share of the length; at a
    prescribed node its local drag at the velocity relative to the bath; each segment the
    mean of its nodes'. With screening, each segment's Oseen length from its mean velocity
    (the slender_body kernel's; the RPY kernel's are its nodes', from :func:`geometry`)."""
    p = model.params[0]
    hyd = out.hydro
    pos, vel, seg_mat = rod.pos, rod.vel, rod.seg_mat
    force = out.force
    f_node, f_seg, w = hyd.f_node, hyd.f_seg, hyd.weight
    fx, fy, fz = p.bath_flow[0], p.bath_flow[1], p.bath_flow[2]
    for i in range(n_free):
        for a in range(3):
            f_node[3 * i + a] = force[3 * i + a] / w[i]
    sc = out.scratch
    for i in range(n_free, n_seg + 1):  # the needle tip: its local drag, pushed on the fluid
        for a in range(3):
            f_node[3 * i + a] = 0.0
        for j in range(max(i - 1, 0), min(i + 1, n_seg)):
            ex = pos[3 * j + 3] - pos[3 * j]
            ey = pos[3 * j + 4] - pos[3 * j + 1]
            ez = pos[3 * j + 5] - pos[3 * j + 2]
            seg_len = math.sqrt(ex * ex + ey * ey + ez * ez)
            tt = (ex / seg_len, ey / seg_len, ez / seg_len)
            u = (vel[3 * i] - fx, vel[3 * i + 1] - fy, vel[3 * i + 2] - fz)
            r = seg_mat[j, MAT_RADIUS]
            _window_law(p, hyd, i, r, u, u[0], u[1], u[2], tt, sc)
            for a in range(3):
                f_node[3 * i + a] -= 0.5 * seg_len * sc.law_force[a] / w[i]
    mem = hyd.memory[0]
    nu = p.bath_viscosity / p.bath_density_top
    re_max = 0.0
    oseen_min = np.inf
    for j in range(n_seg):
        for a in range(3):
            f_seg[3 * j + a] = 0.5 * (f_node[3 * j + a] + f_node[3 * j + 3 + a])
        speed = 0.0
        for a in range(3):
            uj = 0.5 * (vel[3 * j + a] + vel[3 * j + 3 + a]) - p.bath_flow[a]
            speed += uj * uj
        speed = math.sqrt(speed)
        re_max = max(re_max, 2.0 * seg_mat[j, MAT_RADIUS] * speed / nu)
        oseen = _oseen_length(nu, speed)
        oseen_min = min(oseen_min, oseen)
        if p.hydro_kernel != HYDRO_RPY:  # (the RPY kernel's are the nodes', from geometry)
            hyd.screen[j] = oseen if p.hydro_screening else np.inf
    for a in range(3):  # the segment inside the needle pushes nothing
        f_seg[3 * n_seg + a] = 0.0
    mem.reynolds_max = re_max
    mem.oseen_min = oseen_min


@njit(cache=True)  # objmode (the FMM) boxes arrays: reference counting kept
def flow(pos, node_s, n_targets: int, n_seg: int, hyd, out_vel) -> None:
    """The nonlocal flow of the segment forces ``hyd.f_seg`` at nodes 0..n_targets-1 into
    ``out_vel``: the direct sum, or fmm3dpy's FMM from ``fmm_nodes`` segments on (without
    screening; one Python call in objmode); with the RPY kernel the blobs' flow of the node
    forces ``hyd.f_node`` x ``hyd.weight`` (:mod:`._rpy`). Counts the evaluation."""
    mem = hyd.memory[0]
    mem.evaluations += 1
    if mem.kernel == HYDRO_RPY:
        f_blob = hyd.f_blob
        for i in range(n_seg + 1):
            for a in range(3):
                f_blob[3 * i + a] = hyd.f_node[3 * i + a] * hyd.weight[i]
        rpy_flow(
            pos, node_s, n_targets, pos, node_s, n_seg + 1, f_blob, hyd.blob, hyd.gate,
            hyd.screen, mem.mu, mem.cutoff, out_vel,
        )  # fmt: skip
        return
    if 0 < mem.fmm_nodes <= n_seg and not mem.screening:
        mu, eps, a_cut, prec = mem.mu, mem.blob, mem.cutoff, mem.fmm_precision
        f_seg = hyd.f_seg
        with objmode():
            fmm_flow(pos, node_s, n_targets, n_seg, f_seg, mu, eps, a_cut, prec, out_vel)
        return
    nonlocal_flow(
        pos, node_s, n_targets, pos, node_s, n_seg, hyd.f_seg, hyd.screen, mem.mu, mem.blob,
        mem.cutoff, 0.0, out_vel,
    )  # fmt: skip


@kernel
def remember(model, hyd) -> None:
    """Copy what the operator needs of the model into ``hyd.memory``."""
    p = model.params[0]
    mem = hyd.memory[0]
    mem.mu = p.bath_viscosity
    mem.cutoff = p.hydro_cutoff
    mem.blob = p.hydro_blob
    mem.screening = p.hydro_screening
    mem.fmm_nodes = p.hydro_fmm_nodes
    mem.fmm_precision = p.hydro_fmm_precision
    mem.kernel = p.hydro_kernel
    mem.rpy_radii = p.hydro_rpy_radii


@njit(**KERNEL, inline="always")
def _newton_matrix(stage, out) -> bool:
    """Whether this evaluation assembles a Newton matrix whose nonlocal part GMRES applies:
    not one that keeps only the band (couplings of zero capacity), nor the error filter's,
    which assembles the damping part alone (cx = 0) and solves with the Newton matrix's."""
    return stage.jac and stage.cx != 0.0 and out.cpl.row.shape[0] > 0


@njit(**KERNEL)
def linearise(model, rod, stage, out) -> None:
    """With the implicit coupling, keep what GMRES needs of the Newton matrix's nonlocal part
    R M W^-1 J_other: J_other is the band assembled so far (the assembler calls this before
    contact: its Jacobian is left out of J_other, see the module's docstring). An evaluation
    that keeps only the band (couplings of zero capacity) keeps none, and so does the error
    filter's, which assembles the damping part alone (cx = 0)."""
    p = model.params[0]
    if p.hydro_coupling != HYDRO_IMPLICIT or not _newton_matrix(stage, out):
        return
    hyd = out.hydro
    mem = hyd.memory[0]
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    for k in range(3 * n_free):
        for c in range(out.band.shape[1]):
            hyd.band_other[k, c] = out.band[k, c]
    for k in range(3 * (n_seg + 1)):
        hyd.lin_pos[k] = rod.pos[k]
    for i in range(n_seg + 1):
        hyd.lin_s[i] = rod.node_s[i]
        for a in range(3):
            for b in range(3):
                hyd.resist[i, a, b] = 0.0
    mem.linearized = True
    mem.lin_nodes = rod.n_nodes
    mem.lin_free = n_free
    mem.lin_seg = n_seg


@njit(**KERNEL)
def accumulate(model, rod, stage, out) -> float:
    """Add the drag of the local windows at the velocity relative to the nonlocal flow (and
    its Jacobian); with the implicit coupling evaluate that flow from the other effects'
    forces now (they are in ``out.force``: this runs after them) and keep the linearisation
    for GMRES; with the lagged one use ``out.hydro.u_nl`` (from the step's start) and only
    record the sources. Returns the local law's dissipation rate (W)."""
    p = model.params[0]
    hyd = out.hydro
    pos, vel, seg_mat = rod.pos, rod.vel, rod.seg_mat
    force = out.force
    n_free = free_nodes(rod.n_nodes, p)
    n_seg = filament_segments(rod.n_nodes, p)
    remember(model, hyd)
    geometry(p, rod, n_seg, hyd, out.scratch)
    sources(model, rod, out, n_free, n_seg)
    implicit = p.hydro_coupling == HYDRO_IMPLICIT
    u_nl = hyd.u_nl
    if implicit:
        flow(pos, rod.node_s, n_seg + 1, n_seg, hyd, u_nl)
    fx, fy, fz = p.bath_flow[0], p.bath_flow[1], p.bath_flow[2]
    sc = out.scratch
    f3, du, dt = sc.law_force, sc.law_du, sc.law_dt
    keep = implicit and _newton_matrix(stage, out)  # (as linearise: R_i with J_other)
    cx, cv = stage.cx, stage.cv
    power = 0.0
    for j in range(n_seg):
        ex = pos[3 * j + 3] - pos[3 * j]
        ey = pos[3 * j + 4] - pos[3 * j + 1]
        ez = pos[3 * j + 5] - pos[3 * j + 2]
        seg_len = math.sqrt(ex * ex + ey * ey + ez * ez)
        tt = (ex / seg_len, ey / seg_len, ez / seg_len)
        half = 0.5 * seg_len
        r = seg_mat[j, MAT_RADIUS]
        for side in range(2):
            i = j + side
            rel = (vel[3 * i] - fx, vel[3 * i + 1] - fy, vel[3 * i + 2] - fz)
            u0 = rel[0] - u_nl[3 * i]
            u1 = rel[1] - u_nl[3 * i + 1]
            u2 = rel[2] - u_nl[3 * i + 2]
            power += half * _window_law(p, hyd, i, r, rel, u0, u1, u2, tt, sc)
            for a in range(3):
                force[3 * i + a] += half * f3[a]
            if stage.jac:
                add_law_share(out, n_free, i, j, half, tt, f3, du, dt, cx, cv)
            if keep:
                for a in range(3):
                    for b in range(3):
                        hyd.resist[i, a, b] += half * sc.law_xi[a, b]
    return power


@njit(**KERNEL)
def apply_nonlocal(ws, nd: int, x: np.ndarray, y: np.ndarray) -> None:
    """y += R M_nl W^-1 J_other x: the Newton matrix's nonlocal part at the last
    linearisation (implicit coupling), matrix-free: the other effects' Newton matrix (their
    band; contact, the only source of couplings off the band, is left out) on x, as forces
    per length at the free nodes, their segment means, the nonlocal flow of those at the free
    nodes (one evaluation), times each node's linearised resistance R_i."""
    hyd = ws.hydro
    mem = hyd.memory[0]
    n_free = mem.lin_free
    n_seg = mem.lin_seg
    z = hyd.work[0]
    u = hyd.work[1]
    band_matvec(hyd.band_other, nd, KL, KU, x, z)
    f_node = hyd.f_node  # (scratch here: the sources are recomputed at every evaluation)
    for i in range(n_free):
        for a in range(3):
            f_node[3 * i + a] = z[3 * i + a] / hyd.weight[i]
    for i in range(n_free, n_seg + 1):
        for a in range(3):
            f_node[3 * i + a] = 0.0
    for j in range(n_seg):
        for a in range(3):
            hyd.f_seg[3 * j + a] = 0.5 * (f_node[3 * j + a] + f_node[3 * j + 3 + a])
    flow(hyd.lin_pos, hyd.lin_s, n_free, n_seg, hyd, u)
    for i in range(n_free):
        rb = hyd.resist[i]
        for a in range(3):
            y[3 * i + a] += rb[a, 0] * u[3 * i] + rb[a, 1] * u[3 * i + 1] + rb[a, 2] * u[3 * i + 2]

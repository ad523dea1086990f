"""Liquid: while the material is liquid, each segment's rest state relaxes toward its
current one (a Maxwell element in series with the elastic spring), at constant volume.

The jet leaves the needle as a liquid and sets into a gel. A Maxwell element (spring E in
series with a dashpot eta_m) carries the tension T = E A (l - l0) / l0 of its spring while
its rest length flows, eta_m A (dl0/dt) / l0 = T, so
    dl0/dt = (l - l0) / tau,   tau = eta_m / E,
and likewise the natural curvature relaxes toward the current one (the viscous-thread
rods of Bergou, Audoly, Vouga, Wardetzky & Grinspun 2010, "Discrete viscous threads", and
Audoly, Clauvelin, Brun, Bergou, Grinspun & Wardetzky 2013, J. Comput. Phys. 253, whose
rest state follows the current one; here at the finite rate of a viscoelastic liquid). Over
an accepted step h at the step's end configuration the relaxation is integrated exactly,
    l0 <- l + (l0 - l) exp(-h / tau),   kappa0 <- kappa + (kappa0 - kappa) exp(-h / tau),
and the radius follows so that the segment's volume pi r^2 l0 is unchanged (mass balance
stays exact; every effect reads the segment's radius). With the ``viscosity`` effect (a
Kelvin-Voigt dashpot eta_e beside the spring) and tau << h, the spring's stress relaxes
within every step and the rod is a viscous thread with tension eta_e A (dl/dt) / l,
A = V / l: Trouton's law in the true strain rate.

When the liquid sets (tau -> infinity) is read off gelation:

- no ``gelation`` listed: the material never sets, tau = eta_m / E of the segment;
- ``bulk`` gelation: the crosslinking conversion X(a) = 1 - exp(-k a) of the modulus law
  reaches the gel point X_c = X(t_set) at the age ``liquid.set_time_s``; the liquid's
  viscosity diverges there as eta_m (1 - X/X_c)^(-s) (the critical scaling of a gelling
  liquid's viscosity: de Gennes 1979, Scaling Concepts in Polymer Physics, ch. V;
  Stauffer, Coniglio & Adam 1982, Adv. Polym. Sci. 44, 103, with s between 0.7 and 1.3),
  so 1/tau = E(a) (1 - X/X_c)^s / eta_m before the gel point and 0 after it;
- ``surface`` gelation: the set shell does not flow and the core (modulus E_c, radius
  xi r) is the liquid; one rest length per segment takes the core's share of the
  stiffness, 1/tau = (E_c / eta_m) E_c xi^2 / (E_s f_S) for stretching and
  (E_c / eta_m) E_c xi^4 / (E_s f_B) for bending (f_S, f_B the shell-and-core factors), so
  the rest state freezes once a shell thicker than about E_c / E_s of the section has set.

The inlet segment flows too: extrusion keeps its section (its rest length is its volume
pi r_exit^2 (S - s) over that section, so new material joins it at the inlet's radius, not
the exit's), and when it splits both halves keep it. A material effect: it runs once per
accepted step on the whole rod, after gelation.
"""

from __future__ import annotations

import math

from numba import njit

from bathprint.core.effects.gelation import _segment_curvature, core_fraction, shell_factors
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import (
    GEL_SURFACE,
    MAT_BIRTH_TIME,
    MAT_KAPPA_X,
    MAT_RADIUS,
    MAT_YOUNGS_MODULUS,
)
from bathprint.core.topology import filament_segments


@njit(**KERNEL)
def relaxation_rates(seg_mat, j: int, age: float, p) -> tuple[float, float]:
    """(stretching, bending) relaxation rates 1/tau (1/s) of segment j at ``age`` (s):
    0 once the material has set (see the module docstring for the laws)."""
    eta = p.liquid_viscosity
    if not p.gelation:
        rate = seg_mat[j, MAT_YOUNGS_MODULUS] / eta
        return rate, rate
    if p.gel_model == GEL_SURFACE:
        xi = core_fraction(age, seg_mat[j, MAT_RADIUS], p)
        if xi <= 0.0:
            return 0.0, 0.0
        bend, stretch = shell_factors(xi, p)
        ratio = p.gel_core_modulus / p.gel_shell_modulus
        base = p.gel_core_modulus / eta
        x2 = xi * xi
        return base * ratio * x2 / stretch, base * ratio * x2 * x2 / bend
    t_set = p.liquid_set_time
    if age >= t_set:
        return 0.0, 0.0
    k = p.gel_rate
    conv = -math.expm1(-k * max(age, 0.0))
    conv_set = -math.expm1(-k * t_set)
    rate = seg_mat[j, MAT_YOUNGS_MODULUS] / eta * (1.0 - conv / conv_set) ** p.liquid_exponent
    return rate, rate


@kernel
def update(model, rod, t: float, h: float, scratch) -> None:
    """Relax each liquid segment's rest length and natural curvature over the accepted step
    h toward the current ones (exactly at fixed configuration) and scale its radius to keep
    its volume. Called once per accepted step on the whole rod, after gelation."""
    p = model.params[0]
    pos, n_nodes, seg_rest, seg_mat = rod.pos, rod.n_nodes, rod.seg_rest, rod.seg_mat
    n_seg = filament_segments(n_nodes, p)
    ka = scratch.curvature[0]
    kb = scratch.curvature[1]
    for j in range(n_seg):
        rate_s, rate_b = relaxation_rates(seg_mat, j, t - seg_mat[j, MAT_BIRTH_TIME], p)
        if rate_s <= 0.0 and rate_b <= 0.0:
            continue
        f_s = math.exp(-h * rate_s)
        f_b = math.exp(-h * rate_b)
        if f_b < 1.0 and _segment_curvature(pos, seg_rest, n_nodes, j, ka, kb):
            for c in range(3):
                seg_mat[j, MAT_KAPPA_X + c] = kb[c] + (seg_mat[j, MAT_KAPPA_X + c] - kb[c]) * f_b
        if f_s < 1.0:
            ex = pos[3 * j + 3] - pos[3 * j]
            ey = pos[3 * j + 4] - pos[3 * j + 1]
            ez = pos[3 * j + 5] - pos[3 * j + 2]
            length = math.sqrt(ex * ex + ey * ey + ez * ez)
            l0 = seg_rest[j]
            l0_new = length + (l0 - length) * f_s
            seg_mat[j, MAT_RADIUS] *= math.sqrt(l0 / l0_new)
            seg_rest[j] = l0_new
    if p.clamped and n_seg > 0:  # the ghost mirrors the inlet's record
        seg_mat[n_seg, MAT_RADIUS] = seg_mat[n_seg - 1, MAT_RADIUS]
        for c in range(3):
            seg_mat[n_seg, MAT_KAPPA_X + c] = seg_mat[n_seg - 1, MAT_KAPPA_X + c]

"""Gelation: the modulus grows with material age, and curvature freezes in as gel sets.

Modulus law (first-order crosslinking kinetics at rate k):
    E(a) = E_final - (E_final - E_initial) exp(-k a),
from hundreds of Pa seconds after leaving the needle to tens of kPa after minutes
(the paper's measurements by gravity-driven bending, its SI Fig. S1). Material at the
needle is soft, set gel far away is stiff: modulus ratios of 100 along one filament.

Curvature memory: crosslinks formed while the filament is bent are stress-free in the bent
shape, so the natural curvature is the modulus-weighted history of the curvature,
E kappa0 = int kappa dE (a network that cures in its current configuration). Over a step
with E_old -> E_new at fixed current curvature kappa this is exactly
    kappa0_new = kappa + (kappa0_old - kappa) E_old / E_new,
so shapes freeze in as E grows, which is what the paper suspects keeps real coils from
unravelling. A material effect: it runs once per accepted step, not in Newton.

Two material models (``gelation.model``, ``p.gel_model``):

- ``bulk`` (default): the whole cross-section has the modulus of the law above.
- ``surface``: calcium from the bath sets the gel from the surface inward. A set shell of
  modulus E_s grows around an ungelled core of radius r_c and modulus E_c << E_s, the
  front moving by diffusion of Ca2+ (diffusivity D, bath concentration c0) through the
  shell to where it is bound (c_b per volume of gel). With xi = r_c / r, the front obeys
  the cylinder's shrinking-core law with the Neumann rate (:func:`core_fraction`),
      t = r^2 / (8 lambda^2 D) (1 - xi^2 + 2 xi^2 ln xi),
      sqrt(pi) lambda exp(lambda^2) erf(lambda) = c0 / c_b,
  whose short-time limit is the planar moving front r - r_c = 2 lambda sqrt(D t). The
  segment's modulus is E_s and its bending and stretching factors (relative to a full rod
  of E_s) are those of the shell plus the core,
      f_B = 1 - xi^4 + (E_c / E_s) xi^4,   f_S = 1 - xi^2 + (E_c / E_s) xi^2,
  multiplied by the co-extruded inclusions' factors (:mod:`bathprint.core.composite`),
  which are properties of the gel matrix. Core and shell are the same alginate solution
  (the density is unchanged). Curvature memory then weighs by the bending stiffness
  E f_B instead of E. docs/physics/gelation.md gives the derivation, its accuracy against
  the full moving-boundary problem, and the sources of the default values.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.composite import stiffness_factors
from bathprint.core.jit import KERNEL, kernel
from bathprint.core.layout import (
    GEL_SURFACE,
    MAT_BEND_FACTOR,
    MAT_BIRTH_TIME,
    MAT_INNER_FRACTION,
    MAT_KAPPA_X,
    MAT_RADIUS,
    MAT_STRETCH_FACTOR,
    MAT_YOUNGS_MODULUS,
)
from bathprint.core.topology import filament_segments


@njit(**KERNEL)
def modulus(age: float, p) -> float:
    """E (Pa) of gel of the given age (s); ``p`` is the model's parameter record."""
    e0 = p.gel_initial_modulus
    e1 = p.gel_final_modulus
    return e1 - (e1 - e0) * math.exp(-p.gel_rate * max(age, 0.0))


def neumann_lambda(beta: float) -> float:
    """lambda with sqrt(pi) lambda exp(lambda^2) erf(lambda) = beta = c0 / c_b (> 0): the
    moving front of a bound reactant fed by diffusion from a fixed surface concentration
    (Neumann's similarity solution of the one-phase Stefan problem; Crank, The Mathematics
    of Diffusion, 1975, ch. 13) is 2 lambda sqrt(D t) deep. Small beta: lambda = sqrt(beta/2)."""
    if not beta > 0.0 or not math.isfinite(beta):
        raise ValueError(f"beta = {beta!r}; allowed: a finite number > 0")

    def g(x: float) -> float:
        return math.sqrt(math.pi) * x * math.exp(x * x) * math.erf(x) - beta

    lo, hi = 0.0, 1.0
    while g(hi) < 0.0:
        lo, hi = hi, 2.0 * hi
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if g(mid) < 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-15 * hi:
            break
    return 0.5 * (lo + hi)


@njit(**KERNEL)
def _front_function(eps: float) -> tuple[float, float]:
    """F(eps) = 1 - xi^2 + 2 xi^2 ln xi with xi = 1 - eps, and dF/d eps = -4 xi ln xi.
    Small eps by the series F = 2 eps^2 - sum_{k >= 3} 4 eps^k / (k (k-1) (k-2)), which
    the closed form loses to cancellation."""
    xi = 1.0 - eps
    if eps <= 0.0:
        return 0.0, 0.0
    if xi <= 0.0:
        return 1.0, 0.0
    log_xi = math.log1p(-eps)
    deriv = -4.0 * xi * log_xi
    if eps < 0.1:
        f = 2.0 * eps * eps
        term = eps * eps
        for k in range(3, 24):
            term *= eps
            f -= 4.0 * term / (k * (k - 1) * (k - 2))
        return f, deriv
    return 1.0 - xi * xi + 2.0 * xi * xi * log_xi, deriv


@njit(**KERNEL)
def core_fraction(age: float, radius: float, p) -> float:
    """xi = r_c / r, the ungelled core's share of the radius after ``age`` (s) in the bath,
    from t = r^2 / (8 lambda^2 D) F(1 - xi) (see the module docstring): 1 at age 0, 0 once
    the whole section has set. Safeguarded Newton on the shell thickness eps = 1 - xi."""
    if age <= 0.0:
        return 1.0
    tau = 8.0 * p.gel_front_lambda**2 * p.gel_diffusivity * age / (radius * radius)
    if tau >= 1.0:
        return 0.0
    lo = 0.0
    hi = 1.0
    eps = min(math.sqrt(0.5 * tau), 0.5)
    for _ in range(100):
        f, df = _front_function(eps)
        g = f - tau
        if g > 0.0:
            hi = eps
        else:
            lo = eps
        step = g / df if df > 0.0 else 2.0 * hi
        new = eps - step
        if not (lo < new < hi):
            new = 0.5 * (lo + hi)
        if abs(new - eps) <= 1e-15 * max(new, 1e-300) or hi - lo <= 1e-16:
            eps = new
            break
        eps = new
    return 1.0 - eps


@njit(**KERNEL)
def shell_factors(xi: float, p) -> tuple[float, float]:
    """(bend, stretch) factors of a set shell around a core of radius xi r, relative to a
    full rod of the shell's modulus: 1 - xi^4 + (E_c/E_s) xi^4 and 1 - xi^2 + (E_c/E_s) xi^2."""
    ratio = p.gel_core_modulus / p.gel_shell_modulus
    x2 = xi * xi
    x4 = x2 * x2
    return 1.0 - x4 + ratio * x4, 1.0 - x2 + ratio * x2


@njit(**KERNEL)
def set_material(row: np.ndarray, age: float, p) -> None:
    """Fill the gelation fields of a material record ``row`` of the given age (s): its
    modulus (bulk law), or with the surface model the shell's modulus and the bending and
    stretching factors of shell and core times those of the inclusions (from the record's
    inner fraction). The other fields must already be set."""
    if p.gel_model == GEL_SURFACE:
        xi = core_fraction(age, row[MAT_RADIUS], p)
        bend, stretch = shell_factors(xi, p)
        inc_bend, inc_stretch, _, _ = stiffness_factors(row[MAT_INNER_FRACTION], p.slug_fraction)
        row[MAT_YOUNGS_MODULUS] = p.gel_shell_modulus
        row[MAT_BEND_FACTOR] = inc_bend * bend
        row[MAT_STRETCH_FACTOR] = inc_stretch * stretch
    else:
        row[MAT_YOUNGS_MODULUS] = modulus(age, p)


@njit(**KERNEL)
def node_curvature(pos: np.ndarray, seg_rest: np.ndarray, i: int, out: np.ndarray) -> None:
    """Curvature vector kb / dl (1/m) at interior node i (same dl as the bending energy)."""
    e1x = pos[3 * i] - pos[3 * i - 3]
    e1y = pos[3 * i + 1] - pos[3 * i - 2]
    e1z = pos[3 * i + 2] - pos[3 * i - 1]
    e2x = pos[3 * i + 3] - pos[3 * i]
    e2y = pos[3 * i + 4] - pos[3 * i + 1]
    e2z = pos[3 * i + 5] - pos[3 * i + 2]
    l1 = math.sqrt(e1x * e1x + e1y * e1y + e1z * e1z)
    l2 = math.sqrt(e2x * e2x + e2y * e2y + e2z * e2z)
    den = l1 * l2 + e1x * e2x + e1y * e2y + e1z * e2z
    dl = 0.5 * (seg_rest[i - 1] + seg_rest[i])
    f = 2.0 / (den * dl)
    out[0] = f * (e1y * e2z - e1z * e2y)
    out[1] = f * (e1z * e2x - e1x * e2z)
    out[2] = f * (e1x * e2y - e1y * e2x)


@njit(**KERNEL)
def update(model, rod, t: float, scratch) -> None:
    """Set each segment's modulus from its age; with memory, relax kappa0 toward kappa.
    A material effect: called once per accepted step on the whole rod (frozen tail too)."""
    p = model.params[0]
    if p.gel_model == GEL_SURFACE:
        _update_surface(model, rod, t, scratch)
        return
    pos, n_nodes, seg_rest, seg_mat = rod.pos, rod.n_nodes, rod.seg_rest, rod.seg_mat
    n_seg = filament_segments(n_nodes, p)
    memory = p.curvature_memory
    ka = scratch.curvature[0]
    kb = scratch.curvature[1]
    for j in range(n_seg):
        e_new = modulus(t - seg_mat[j, MAT_BIRTH_TIME], p)
        e_old = seg_mat[j, MAT_YOUNGS_MODULUS]
        if memory and e_new > e_old and _segment_curvature(pos, seg_rest, n_nodes, j, ka, kb):
            f = e_old / e_new
            for c in range(3):
                seg_mat[j, MAT_KAPPA_X + c] = kb[c] + (seg_mat[j, MAT_KAPPA_X + c] - kb[c]) * f
        seg_mat[j, MAT_YOUNGS_MODULUS] = e_new


@njit(**KERNEL)
def _segment_curvature(pos, seg_rest, n_nodes: int, j: int, ka, kb) -> bool:
    """Mean curvature vector of segment j's interior end nodes into ``kb``; False if none."""
    count = 0
    for c in range(3):
        kb[c] = 0.0
    for node in (j, j + 1):
        if 1 <= node <= n_nodes - 2:
            node_curvature(pos, seg_rest, node, ka)
            for c in range(3):
                kb[c] += ka[c]
            count += 1
    if count == 0:
        return False
    for c in range(3):
        kb[c] /= count
    return True


@kernel
def _update_surface(model, rod, t: float, scratch) -> None:
    """The surface model's update: the shell's factors from each segment's age; with memory,
    kappa0 relaxes toward kappa by the ratio of the old to the new bending stiffness."""
    p = model.params[0]
    pos, n_nodes, seg_rest, seg_mat = rod.pos, rod.n_nodes, rod.seg_rest, rod.seg_mat
    n_seg = filament_segments(n_nodes, p)
    memory = p.curvature_memory
    row = scratch.mat_row
    ka = scratch.curvature[0]
    kb = scratch.curvature[1]
    for j in range(n_seg):
        b_old = seg_mat[j, MAT_YOUNGS_MODULUS] * seg_mat[j, MAT_BEND_FACTOR]
        for c in range(row.shape[0]):
            row[c] = seg_mat[j, c]
        set_material(row, t - seg_mat[j, MAT_BIRTH_TIME], p)
        b_new = row[MAT_YOUNGS_MODULUS] * row[MAT_BEND_FACTOR]
        if memory and b_new > b_old and _segment_curvature(pos, seg_rest, n_nodes, j, ka, kb):
            f = b_old / b_new
            for c in range(3):
                seg_mat[j, MAT_KAPPA_X + c] = kb[c] + (seg_mat[j, MAT_KAPPA_X + c] - kb[c]) * f
        seg_mat[j, MAT_YOUNGS_MODULUS] = row[MAT_YOUNGS_MODULUS]
        seg_mat[j, MAT_BEND_FACTOR] = row[MAT_BEND_FACTOR]
        seg_mat[j, MAT_STRETCH_FACTOR] = row[MAT_STRETCH_FACTOR]

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
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from bathprint.core.layout import MAT_BIRTH_TIME, MAT_KAPPA_X, MAT_YOUNGS_MODULUS
from bathprint.core.topology import filament_segments


@njit(cache=True)
def modulus(age: float, p) -> float:
    """E (Pa) of gel of the given age (s); ``p`` is the model's parameter record."""
    e0 = p.gel_initial_modulus
    e1 = p.gel_final_modulus
    return e1 - (e1 - e0) * math.exp(-p.gel_rate * max(age, 0.0))


@njit(cache=True)
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


@njit(cache=True)
def update(model, rod, t: float, scratch) -> None:
    """Set each segment's modulus from its age; with memory, relax kappa0 toward kappa.
    A material effect: called once per accepted step on the whole rod (frozen tail too)."""
    p = model.params[0]
    pos, n_nodes, seg_rest, seg_mat = rod.pos, rod.n_nodes, rod.seg_rest, rod.seg_mat
    n_seg = filament_segments(n_nodes, p)
    memory = p.curvature_memory
    ka = scratch.curvature[0]
    kb = scratch.curvature[1]
    for j in range(n_seg):
        e_new = modulus(t - seg_mat[j, MAT_BIRTH_TIME], p)
        e_old = seg_mat[j, MAT_YOUNGS_MODULUS]
        if memory and e_new > e_old:
            # the segment's curvature: mean over its interior end nodes (1 .. n_nodes-2)
            count = 0
            for c in range(3):
                kb[c] = 0.0
            for node in (j, j + 1):
                if 1 <= node <= n_nodes - 2:
                    node_curvature(pos, seg_rest, node, ka)
                    for c in range(3):
                        kb[c] += ka[c]
                    count += 1
            if count > 0:
                f = e_old / e_new
                for c in range(3):
                    kappa = kb[c] / count
                    seg_mat[j, MAT_KAPPA_X + c] = kappa + (seg_mat[j, MAT_KAPPA_X + c] - kappa) * f
        seg_mat[j, MAT_YOUNGS_MODULUS] = e_new

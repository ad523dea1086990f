"""The explicit integrator's stability limit at a state, from the linearised dynamics.

Overdamped: x' = D^{-1} F(x) with D the drag matrix and K = -dF/dx the stiffness;
forward Euler is stable while h < 2 / max|eig(D^{-1} K)|. With inertia: symplectic
Euler is stable while h < 2 / omega_max, omega^2 = max eig(M^{-1} K). Dense
eigenvalues: meant for diagnostics and tests on up to a few thousand nodes.
"""

from __future__ import annotations

import numpy as np

from bathprint.core import layout as L
from bathprint.core.simulation import Simulation


def _dense(sim: Simulation, cx: float, cv: float, ca: float) -> np.ndarray:
    nd = 3 * (sim.n_nodes - 2)
    _, band = sim.forces(cx, cv, ca, jacobian=True, acc=np.zeros_like(sim.vel))
    dense = np.zeros((nd, nd))
    for i in range(nd):
        lo, hi = max(0, i - L.KL), min(nd, i + L.KU + 1)
        dense[i, lo:hi] = band[i, lo - i + L.KL : hi - i + L.KL]
    return dense


def explicit_step_limit(sim: Simulation) -> float:
    """Largest stable step (s) of the explicit integrator at the simulation's current state."""
    stiffness = _dense(sim, 1.0, 0.0, 0.0)
    inertial = bool(sim.model.p.inertial)
    damping_or_mass = _dense(sim, 0.0, 0.0 if inertial else 1.0, 1.0 if inertial else 0.0)
    lam = np.linalg.eigvals(np.linalg.solve(damping_or_mass, stiffness))
    lam_max = float(np.max(np.abs(lam)))
    return 2.0 / np.sqrt(lam_max) if inertial else 2.0 / lam_max

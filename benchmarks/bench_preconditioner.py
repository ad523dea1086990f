"""Which preconditioner would make GMRES cheaper on a Newton matrix with contact?

The simulator solves A = B + C (B the band of the local effects, C the 3x3 blocks between
touching segments about a coil turn apart) by GMRES right-preconditioned by the banded LU
of B (src/bathprint/core/solver.py). This benchmark takes the Newton matrix of the last
factorisation of two states, (1) a coil stack of 1000 nodes with every turn pressed onto
the next (a chain of contacts as high as the stack) after 10 ms, (2) period_doubling_22G
after 0.5 s (a pile of about 30 turns), and counts GMRES(30) iterations (scipy, the same
restart length) to a relative residual of 0.05 (the default ``numerics.krylov_tolerance``)
and 1e-6 for a fixed random right-hand side, with:

- ``band``: the simulator's preconditioner, the LU of B;
- ``two_level_M``: that, then a coarse correction on aggregates of M consecutive nodes
  (their three translations; P^T A P solved exactly), applied multiplicatively: the
  classical remedy when the slow modes are rigid motions of whole turns against each other
  (a chain of contacts);
- ``exact``: the LU of A itself (one iteration: checks the set-up).

    python benchmarks/bench_preconditioner.py
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla
from _common import write_csv

from bathprint import Simulation
from bathprint.core import layout as L
from bathprint.core.topology import free_nodes

MM = 1e-3
R_FIL = 0.205 * MM  # 22G
SPACING = 0.3 * MM
AGGREGATES = (4, 16, 64)


def pressed_stack(n: int) -> Simulation:
    """A stress-free coil stack (radius 3 mm) whose turns touch (pitch 0.98 delta), sinking."""
    radius, pitch = 3 * MM, 0.98 * 2 * R_FIL
    dphi = SPACING / math.hypot(radius, pitch / (2 * math.pi))
    phi = dphi * np.arange(n)
    pts = np.column_stack(
        [radius * np.cos(phi), radius * np.sin(phi), -50 * MM + pitch * phi / (2 * math.pi)]
    )
    effects = ["elasticity", "drag", "gravity", "contact"]
    return Simulation.from_points(
        pts, "drag_coiling_22G", {"effects": effects, "duration_s": 1e3}, relaxed=True
    )


def newton_matrix(sim: Simulation) -> sp.csr_matrix:
    """The Newton matrix of the last factorisation: its band (kept unfactored for GMRES)
    plus the blocks off the band."""
    nd = 3 * free_nodes(sim.n_nodes, sim.model.record.params[0])
    band = sim.ws.krylov.band_a
    rows, cols, vals = [], [], []
    for i in range(nd):
        for j in range(max(0, i - L.KL), min(nd, i + L.KU + 1)):
            if band[i, j - i + L.KL] != 0.0:
                rows.append(i)
                cols.append(j)
                vals.append(band[i, j - i + L.KL])
    cpl = sim.ws.cpl
    for q in range(int(cpl.count[0])):
        for a in range(3):
            for b in range(3):
                rows.append(3 * int(cpl.row[q]) + a)
                cols.append(3 * int(cpl.col[q]) + b)
                vals.append(cpl.block[q, a, b])
    return sp.csr_matrix((vals, (rows, cols)), shape=(nd, nd))


def band_part(a: sp.csr_matrix) -> sp.csr_matrix:
    """The entries within the band (|i - j| <= KL)."""
    coo = a.tocoo()
    keep = np.abs(coo.row - coo.col) <= L.KL
    return sp.csr_matrix((coo.data[keep], (coo.row[keep], coo.col[keep])), shape=a.shape)


def gmres_iterations(a, m, b: np.ndarray, rtol: float) -> int:
    count = [0]

    def callback(_res: float) -> None:
        count[0] += 1

    sla.gmres(
        a, b, M=m, rtol=rtol, restart=30, maxiter=50, callback=callback, callback_type="pr_norm"
    )
    return count[0]


def preconditioners(a: sp.csr_matrix) -> dict[str, tuple[sla.LinearOperator, int]]:
    nd = a.shape[0]
    lu_b = sla.splu(band_part(a).tocsc())
    out = {"band": (sla.LinearOperator((nd, nd), lu_b.solve), 0)}
    nn = nd // 3
    for m in AGGREGATES:
        agg = np.arange(nn) // m
        n_agg = int(agg.max()) + 1
        cols = 3 * np.repeat(agg, 3) + np.tile(np.arange(3), nn)
        p = sp.csr_matrix((np.ones(nd), (np.arange(nd), cols)), shape=(nd, 3 * n_agg))
        lu_c = sla.splu((p.T @ a @ p).tocsc())

        def apply(r, p=p, lu_c=lu_c):
            x = lu_b.solve(r)
            return x + p @ lu_c.solve(p.T @ (r - a @ x))

        out[f"two_level_{m}"] = (sla.LinearOperator((nd, nd), apply), 3 * n_agg)
    lu_a = sla.splu(a.tocsc())
    out["exact"] = (sla.LinearOperator((nd, nd), lu_a.solve), nd)
    return out


def main() -> None:
    states = {}
    stack = pressed_stack(1000)
    stack.advance(1e-2)
    states["pressed_stack_1000"] = stack
    pd = Simulation("period_doubling_22G")
    pd.advance(0.5)
    states["period_doubling_22G_0.5s"] = pd
    rows = []
    rng = np.random.default_rng(0)
    for name, sim in states.items():
        a = newton_matrix(sim)
        b = rng.standard_normal(a.shape[0])
        blocks = int(sim.ws.cpl.count[0])
        for label, (m, coarse) in preconditioners(a).items():
            row = {
                "state": name,
                "unknowns": a.shape[0],
                "off_band_blocks": blocks,
                "preconditioner": label,
                "coarse_unknowns": coarse,
                "iterations_rtol_0.05": gmres_iterations(a, m, b, 0.05),
                "iterations_rtol_1e-6": gmres_iterations(a, m, b, 1e-6),
            }
            rows.append(row)
            print(
                f"{name:>26} {label:>14}: {row['iterations_rtol_0.05']:3d} iterations to 0.05, "
                f"{row['iterations_rtol_1e-6']:3d} to 1e-6 (coarse unknowns {coarse})"
            )
    print("wrote", write_csv("preconditioners", rows))


if __name__ == "__main__":
    main()

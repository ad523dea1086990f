"""Which preconditioner would make GMRES cheaper on a Newton matrix with contact?

The simulator solves A = B + C (B the band of the local effects, C the 3x3 blocks between
touching segments about a coil turn apart) by GMRES right-preconditioned by the banded LU
of B (src/bathprint/core/solver.py). Two parts:

``--part random``: the Newton matrix of the last factorisation of two states, (1) a coil
stack of 1000 nodes with every turn pressed onto the next (a chain of contacts as high as
the stack) after 10 ms, (2) period_doubling_22G after 0.5 s (a pile of about 30 turns);
GMRES(30) iterations (scipy, the same restart length) to a relative residual of 0.05 (the
default ``numerics.krylov_tolerance``) and 1e-6 for a fixed random right-hand side, with:

- ``band``: the simulator's preconditioner, the LU of B;
- ``two_level_M``: that, then a coarse correction on aggregates of M consecutive nodes
  (their three translations; P^T A P solved exactly), applied multiplicatively;
- ``exact``: the LU of A itself (one iteration: checks the set-up).

``--part newton``: the systems the integrator itself solves, whose right-hand sides are
the Newton residuals (the iteration count depends on the right-hand side, and a random
one is not representative). For each N, the pressed coil stack of contact_cost.py
(``coil_stack(N, True, 0.98)``, node spacing 0.3 mm, radius 3 mm: about 63 nodes a turn)
is advanced 1 ms, then the integrator is replayed from its Python source (numba's
``py_func``, as step_profile.py does) with the solver's ``factor`` and ``solve``
wrapped, and the first Newton solve after each of the next ``--solves`` (3) factorisations
is captured: the unfactored band ``ws.krylov.band_a``, the off-band blocks ``ws.cpl``, the
right-hand side, and the simulator's own GMRES iteration count for it (the error filter's
solves are skipped). Each captured system is solved again by flexible GMRES as
``solver._gmres`` (restart ``records.KRYLOV_RESTART``, at most
``solver.KRYLOV_MAX_RESTARTS`` restarts, the same stopping test) to relative residuals
0.05 and 1e-3 with:

- ``band``: the simulator's preconditioner (its ``band_lu`` / ``band_solve_by_columns``); its
  count at 0.05 is recorded beside the simulator's (``simulator_iterations_rtol_0.05``),
  which it reproduces;
- ``hat_4_z``: ``band``, then a coarse correction (P^T A P solved exactly) on the axial
  displacement interpolated piecewise linearly along the node index between coarse nodes
  every 4 nodes (z only), applied multiplicatively;
- ``hat_4_z_symmetric``: the same coarse space applied as B, coarse, B;
- ``axial``: multiplicative, with every node's z displacement as coarse unknown (the whole
  axial problem).

With ``band`` the iterations grow with N (slow modes along the stack's axis, where the
contacts chain the turns); the smooth coarse space removes part of the growth, the whole
axial problem all of it, at a coarse LU dearer than B's. One row per (N, preconditioner)
in results/preconditioner_newton.csv: iterations per solve (mean over the captured solves,
and each, ``_each``), solves that did not converge, the coarse unknowns and the coarse
matrix's bandwidth (in coarse unknowns), and the time (ms) of its factorisation and of
B's, and their ratio (mean over the solves): both timed with the simulator's own banded LU
(:func:`bathprint.core.banded.band_lu`, partial pivoting, O(n kl (kl + ku)) work), each
restoring the band from a copy first as ``solver.factor`` copies it, best of 3. Assembling
P^T A P is not timed.

A run with the default sizes N = 300, 1000, 3000, 10000 takes about 1.5 minutes on one
core (most of it N = 10000).

``--part amg`` (needs pyamg: ``pip install -e ".[bench]"``): the same captured systems at
N = 1000, 3000, 10000, solved with ``band`` and with the banded LU followed by one V-cycle
of an algebraic multigrid hierarchy (pyamg) of the axial problem (every node's z: the block
``axial`` solves exactly), smoothed aggregation (``axial_sa``) or Ruge-Stueben
(``axial_rs``), or one smoothed-aggregation V-cycle of the whole matrix alone
(``whole_sa``); per solve and hierarchy, the iterations, the V-cycle's own convergence
factor, and its time and set-up time against the banded solve and LU
(results/preconditioner_amg.csv).

``--part settled``: consecutive Newton solves (``--solves``, 30) of the pressed stacks after
they have relaxed (``coil_stack(N, True, 0.98)`` with contact's default law, 20 ms at steps
of at most 0.25 ms, as contact_cost.py's settled parts), N = 300 to 10^4, each solved again
by flexible GMRES to the simulator's tolerance with ``band``, ``axial`` and ``hat_4_z`` (as
above, multiplicative), ``lines`` (after the band, the axial problem with its couplings a
turn apart lumped onto each node's strongest partner up the stack and those along the
filament onto the diagonal: the lines of contacts up the stack, a forest solved exactly in
O(N)), and ``recycled_K`` (the band, each solve started from the best point in the span of
the last K preconditioned directions of earlier solves of the same matrix: Fischer 1998,
"Projection techniques for iterative solution of Ax = b with successive right-hand sides",
Comput. Methods Appl. Mech. Eng. 163), K = 10 and 40: mean and largest iterations per solve
(results/preconditioner_settled.csv), and the work each adds to the band's per iteration.

``--part backsub``: what one application of the preconditioner costs, by the order of the
back-substitution: ``band_solve`` (each row sums its 16 terms of U: the banded path's
solve) against ``band_solve_by_columns`` (each solved unknown is subtracted from the rows
above it: GMRES's), on the LU of random diagonally dominant band matrices of 3 N unknowns
(the simulator's 8 sub- and super-diagonals), N = 10^2 to 10^4; best of 7 timings of 200
solves each, the two alternating, and the largest difference of their solutions.

``--part blocks``: the two kernels that take most of a pressed stack's step, the product
with the blocks off the band (``add_blocks_matvec``, 16 random blocks per node in a stack's
pattern: each node with the 4 nearest nodes a turn up, both ways, each node block written
twice as a contact pass writes it; block by block as assembled, and by rows of the 8 merged
blocks per node that ``merge_blocks`` sums, with the merge's own time) and GMRES's
back-substitution (``band_solve_diagonal``, on a random diagonally dominant band: in the
band's storage with the fill-in columns of partial pivoting, and in the copy of the
KL + KU + 1 columns it uses, as GMRES keeps it), each alone, N = 300 to 10^5: the cost per
block and per node against N, best of 7 (results/stack_kernels.csv).

``--part diagonal``: GMRES's LU, with partial pivoting (``band_lu``, its solve by columns)
against diagonal pivots (``band_lu_diagonal``, its solve through U's 8 super-diagonals
only), on the same random diagonally dominant band matrices, N = 10^2 to 10^4, and on the
band of the pile's Newton matrix (``period_doubling_22G`` at 0.8 s); best of 7 timings of
20 LUs and of 200 solves each, alternating, the largest difference of the solutions, the
rows partial pivoting swaps and whether every diagonal pivot passes the threshold
(results/lu_diagonal.csv).

    python experiments/preconditioner/preconditioner.py                      # both parts
    python experiments/preconditioner/preconditioner.py --part newton --sizes 100,1000 --solves 1
    python experiments/preconditioner/preconditioner.py --part random --out /tmp/results  # CSV dir
    python experiments/preconditioner/preconditioner.py --part amg                       # pyamg
    python experiments/preconditioner/preconditioner.py --part settled  # consecutive solves
    python experiments/preconditioner/preconditioner.py --part backsub  # back-substitutions
    python experiments/preconditioner/preconditioner.py --part diagonal  # LU without row swaps
    python experiments/preconditioner/preconditioner.py --part blocks    # the stack's two kernels
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import SimpleNamespace
from typing import Any, NamedTuple

import numpy as np
import scipy.linalg as sla_dense
import scipy.sparse as sp
import scipy.sparse.linalg as sla

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, SHARP_CONTACT, best_of, experiment, write_csv  # noqa: E402
from numba import njit  # noqa: E402
from rich.progress import Progress  # noqa: E402

import bathprint.core.integrators as integ
from bathprint import Simulation
from bathprint.core import layout as L
from bathprint.core import solver
from bathprint.core.banded import (
    add_blocks_matvec,
    band_lu,
    band_lu_diagonal,
    band_solve,
    band_solve_by_columns,
    band_solve_diagonal,
    merge_blocks,
)
from bathprint.core.records import KRYLOV_RESTART, new_couplings

_stack = experiment("contact_cost")  # the pressed coil stacks
COIL_RADIUS, MM, R_FIL, SPACING = _stack.COIL_RADIUS, _stack.MM, _stack.R_FIL, _stack.SPACING
coil_stack = _stack.coil_stack
_profile = experiment("step_profile")  # the replay of the time loop
REPLAYED, replay_records = _profile.REPLAYED, _profile.replay_records

AGGREGATES = (4, 16, 64)

NEWTON_SIZES = (300, 1000, 3000, 10000)  # at 100 nodes the stack soon stops touching
WARM_S = 1e-3  # the stack is advanced this long (s) before solves are captured
SOLVES = 3  # captured Newton solves per N
RTOLS = (0.05, 1e-3)  # relative residuals; the first is the simulator's krylov_tolerance
# label: (coarse node spacing (None: no coarse space), how the coarse correction is applied)
NEWTON_PRECONDITIONERS: dict[str, tuple[int | None, str]] = {
    "band": (None, ""),
    "hat_4_z": (4, "multiplicative"),
    "hat_4_z_symmetric": (4, "symmetric"),
    "axial": (1, "multiplicative"),
}

Vector = np.ndarray
Apply = Callable[[Vector], tuple[Vector, Vector]]  # v -> (z = M^-1 v, A z)


# ------------------------------------------------------------------ matrices
def assemble_matrix(
    band: np.ndarray, rows: np.ndarray, cols: np.ndarray, blocks: np.ndarray, nd: int
) -> sp.csr_matrix:
    """A = B + C from the band (row storage of :mod:`bathprint.core.banded`, kl = KL) and the
    off-band 3x3 blocks at node blocks (rows[k], cols[k])."""
    i = np.repeat(np.arange(nd), L.KL + L.KU + 1)
    off = np.tile(np.arange(-L.KL, L.KU + 1), nd)
    j = i + off
    inside = (j >= 0) & (j < nd)
    vals = band[i[inside], off[inside] + L.KL]
    keep = vals != 0.0
    a = np.arange(3)
    r = (3 * rows[:, None, None] + a[None, :, None] + 0 * a[None, None, :]).ravel()
    c = (3 * cols[:, None, None] + a[None, None, :] + 0 * a[None, :, None]).ravel()
    return sp.csr_matrix(
        (
            np.concatenate([vals[keep], blocks.ravel()]),
            (np.concatenate([i[inside][keep], r]), np.concatenate([j[inside][keep], c])),
        ),
        shape=(nd, nd),
    )


def newton_matrix(sim: Simulation) -> sp.csr_matrix:
    """The Newton matrix of the last factorisation: its band (kept unfactored for GMRES)
    plus the blocks off the band, in that factorisation's unknowns (nodes born since, at
    the end of the step, are not in it)."""
    nd = int(sim.ws.solver[0]["lu_nd"])
    cpl = sim.ws.cpl
    k = int(cpl.count[0])
    return assemble_matrix(sim.ws.krylov.band_a, cpl.row[:k], cpl.col[:k], cpl.block[:k], nd)


def band_part(a: sp.csr_matrix) -> sp.csr_matrix:
    """The entries within the band (|i - j| <= KL)."""
    coo = a.tocoo()
    keep = np.abs(coo.row - coo.col) <= L.KL
    return sp.csr_matrix((coo.data[keep], (coo.row[keep], coo.col[keep])), shape=a.shape)


def bandwidth(a: sp.spmatrix) -> int:
    """The largest |i - j| of a nonzero entry."""
    coo = a.tocoo()
    nz = coo.data != 0.0
    return int(np.max(np.abs(coo.row[nz] - coo.col[nz]))) if nz.any() else 0


def to_band(a: sp.spmatrix, kl: int, ku: int) -> np.ndarray:
    """``a`` in the row storage of :mod:`bathprint.core.banded` (2 kl + ku + 1 slots a row:
    room for the fill-in of partial pivoting)."""
    coo = a.tocoo()
    out = np.zeros((a.shape[0], 2 * kl + ku + 1))
    out[coo.row, coo.col - coo.row + kl] = coo.data
    return out


class BandedLU:
    """The simulator's banded LU (partial pivoting) of a band matrix, and its solve (the
    preconditioner's, by columns, for the Newton band's widths)."""

    def __init__(self, band: np.ndarray, n: int, kl: int, ku: int) -> None:
        self.lu = np.ascontiguousarray(band[:n], dtype=np.float64).copy()
        self.piv = np.zeros(n, dtype=np.int64)
        self.n, self.kl, self.ku = n, kl, ku
        if band_lu(self.lu, n, kl, ku, self.piv) != 0:
            raise ValueError("singular band matrix")

    def solve(self, v: Vector) -> Vector:
        z = np.array(v, dtype=np.float64)
        if (self.kl, self.ku) == (L.KL, L.KU):
            band_solve_by_columns(self.lu, self.n, self.piv, z)
        else:
            band_solve(self.lu, self.n, self.kl, self.ku, self.piv, z)
        return z


@njit
def _lu_loop(reps: int, work: np.ndarray, saved: np.ndarray, n: int, kl: int, ku: int,
             piv: np.ndarray) -> None:  # fmt: skip
    """Restore the band from ``saved`` and factorise it, ``reps`` times."""
    for _ in range(reps):
        work[:n] = saved[:n]
        band_lu(work, n, kl, ku, piv)


def lu_seconds(band: np.ndarray, n: int, kl: int, ku: int) -> float:
    """Seconds of one banded LU (the band restored from a copy first), best of 3."""
    saved = np.ascontiguousarray(band[:n], dtype=np.float64)
    work = saved.copy()
    piv = np.zeros(n, dtype=np.int64)
    once = best_of(lambda: _lu_loop(1, work, saved, n, kl, ku, piv), 2)
    reps = max(1, int(0.02 / max(once, 1e-7)))
    return best_of(lambda: _lu_loop(reps, work, saved, n, kl, ku, piv), 3) / reps


def gmres_iterations(a, m, b: np.ndarray, rtol: float) -> int:
    count = [0]

    def callback(_res: float) -> None:
        count[0] += 1

    sla.gmres(
        a, b, M=m, rtol=rtol, restart=30, maxiter=50, callback=callback, callback_type="pr_norm"
    )
    return count[0]


def fgmres(a: sp.csr_matrix, b: Vector, apply: Apply, rtol: float) -> tuple[int, bool]:
    """Iterations of right-preconditioned flexible GMRES on A x = b to |b - A x| <= rtol |b|,
    step by step as ``solver._gmres`` (modified Gram-Schmidt, Givens rotations, restarts of
    ``KRYLOV_RESTART`` with the true residual, at most ``KRYLOV_MAX_RESTARTS``), and whether
    it got there. ``apply(v)`` returns z = M^-1 v and A z."""
    its, ok, _x = fgmres_solution(a, b, apply, rtol)
    return its, ok


def fgmres_solution(
    a: sp.csr_matrix, b: Vector, apply: Apply, rtol: float
) -> tuple[int, bool, Vector]:
    """:func:`fgmres`, and the solution it found. The vectors ``apply`` returns are copied
    before GMRES orthogonalises A z in place (the caller may keep them)."""
    m, nd = KRYLOV_RESTART, b.size
    beta0 = float(np.linalg.norm(b))
    if beta0 == 0.0:
        return 0, True, np.zeros(nd)
    x = np.zeros(nd)
    r = b.copy()
    beta = beta0
    its = 0
    converged = False
    for _restart in range(solver.KRYLOV_MAX_RESTARTS):
        basis = np.zeros((m + 1, nd))
        zbasis = np.zeros((m, nd))
        hess = np.zeros((m + 1, m))
        g, cs, sn = np.zeros(m + 1), np.zeros(m), np.zeros(m)
        basis[0] = r / beta
        g[0] = beta
        n_used = 0
        for j in range(m):
            zbasis[j], w = apply(basis[j])
            w = np.array(w, dtype=np.float64)  # orthogonalised in place below
            for i in range(j + 1):
                hess[i, j] = w @ basis[i]
                w -= hess[i, j] * basis[i]
            h_next = float(np.linalg.norm(w))
            hess[j + 1, j] = h_next
            if h_next > 0.0:
                w /= h_next
            basis[j + 1] = w
            for i in range(j):
                t = cs[i] * hess[i, j] + sn[i] * hess[i + 1, j]
                hess[i + 1, j] = -sn[i] * hess[i, j] + cs[i] * hess[i + 1, j]
                hess[i, j] = t
            den = math.hypot(hess[j, j], hess[j + 1, j])
            if den == 0.0:
                break
            cs[j], sn[j] = hess[j, j] / den, hess[j + 1, j] / den
            hess[j, j], hess[j + 1, j] = den, 0.0
            g[j + 1] = -sn[j] * g[j]
            g[j] = cs[j] * g[j]
            n_used = j + 1
            its += 1
            if abs(g[j + 1]) <= rtol * beta0 or h_next == 0.0:
                converged = True
                break
        if n_used:
            y = sla_dense.solve_triangular(hess[:n_used, :n_used], g[:n_used])
            x += y @ zbasis[:n_used]
        if converged:
            break
        r = b - a @ x
        beta = float(np.linalg.norm(r))
        if beta <= rtol * beta0:
            converged = True
            break
    return its, converged and bool(np.isfinite(x).all()), x


# ------------------------------------------------------------------ part random
def pressed_stack(n: int) -> Simulation:
    """A stress-free coil stack (radius 3 mm) whose turns touch (pitch 0.98 delta), sinking,
    with the contact law it was measured with (SHARP_CONTACT)."""
    radius, pitch = 3 * MM, 0.98 * 2 * R_FIL
    dphi = SPACING / math.hypot(radius, pitch / (2 * math.pi))
    phi = dphi * np.arange(n)
    pts = np.column_stack(
        [radius * np.cos(phi), radius * np.sin(phi), -50 * MM + pitch * phi / (2 * math.pi)]
    )
    effects = ["elasticity", "drag", "gravity", "contact"]
    return Simulation.from_points(
        pts,
        "drag_coiling_22G",
        {"effects": effects, "duration_s": 1e3, **SHARP_CONTACT},
        relaxed=True,
    )


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


def random_part(out_dir: Path) -> Path:
    states = {}
    stack = pressed_stack(1000)
    stack.advance(1e-2)
    states["pressed_stack_1000"] = stack
    pd = Simulation("period_doubling_22G", SHARP_CONTACT)
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
    path = write_csv(out_dir / "preconditioners.csv", rows)
    print("wrote", path)
    return path


# ------------------------------------------------------------------ part newton
class Captured(NamedTuple):
    """One Newton system A x = rhs as the simulator solved it."""

    nd: int
    band: np.ndarray  # (nd, BAND_WIDTH): B, unfactored
    rows: np.ndarray  # node blocks of C
    cols: np.ndarray
    blocks: np.ndarray  # (k, 3, 3)
    rhs: np.ndarray
    rtol: float  # the simulator's krylov_tolerance
    iterations: int  # the simulator's GMRES iterations for it
    converged: bool
    factorisation: int = 0  # which factorisation (matrix) of the run it was solved with

    def matrix(self) -> sp.csr_matrix:
        return assemble_matrix(self.band, self.rows, self.cols, self.blocks, self.nd)

    def off_band(self) -> sp.csr_matrix:
        z = np.zeros_like(self.band)
        return assemble_matrix(z, self.rows, self.cols, self.blocks, self.nd)


def capture(
    sim: Simulation, n_solves: int, max_rounds: int = 200, every: bool = False
) -> list[Captured]:
    """The first Newton solve (with blocks off the band) after each of the next ``n_solves``
    factorisations of ``sim`` (``every``: each of its next ``n_solves`` Newton solves),
    advancing it by replaying the integrator's Python source in rounds of 0.2 ms. The
    compiled record builders (``active_rod``, ``_out``) run as Python too: Python must never
    hold the views a kernel compiled without reference counting builds."""
    caps: list[Captured] = []
    ctx = {"filter": False, "fresh": False, "factorisations": 0}
    real_solver, real_filtered = integ.solver, integ._filtered_norm
    real_replayed = {name: getattr(integ, name) for name in REPLAYED}

    def capturing_factor(ws, nd: int) -> bool:
        ctx["fresh"] = True
        ctx["factorisations"] += 1
        return solver.factor(ws, nd)

    def capturing_solve(ws, nd: int, rhs: np.ndarray, counters: np.ndarray, rtol: float):
        take = (ctx["fresh"] or every) and not ctx["filter"] and len(caps) < n_solves
        take = take and bool(solver.off_band(ws))
        ctx["fresh"] = False
        if not take:
            return solver.solve(ws, nd, rhs, counters, rtol)
        k = int(ws.cpl.count[0])
        b = rhs[:nd].copy()
        before = int(counters[L.C_KRYLOV_ITERATIONS])
        ok = solver.solve(ws, nd, rhs, counters, rtol)
        caps.append(
            Captured(
                nd=nd,
                band=ws.krylov.band_a[:nd].copy(),
                rows=ws.cpl.row[:k].copy(),
                cols=ws.cpl.col[:k].copy(),
                blocks=ws.cpl.block[:k].copy(),
                rhs=b,
                rtol=float(rtol),
                iterations=int(counters[L.C_KRYLOV_ITERATIONS]) - before,
                converged=bool(ok),
                factorisation=ctx["factorisations"],
            )
        )
        return ok

    def filtered(*args: object) -> float:  # the error filter's solve is not captured
        ctx["filter"] = True
        try:
            return real_replayed["_filtered_norm"].py_func(*args)
        finally:
            ctx["filter"] = False

    wrapper = SimpleNamespace(
        solve=capturing_solve,
        factor=capturing_factor,
        damping_times=solver.damping_times,
        off_band=solver.off_band,
    )
    model, named_ws = replay_records(sim)

    try:
        integ.solver = wrapper
        for name, fn in real_replayed.items():
            setattr(integ, name, fn.py_func)
        integ._filtered_norm = filtered
        for _round in range(max_rounds):
            if len(caps) >= n_solves:
                break
            status = integ.advance.py_func(model, sim.state, named_ws(), sim.t + 2e-4, 10**9)
            if status == L.STATUS_CAPACITY:  # grow the arrays as Simulation.advance does
                sim.make_room()
            elif status != L.STATUS_OK:
                raise RuntimeError(f"replay stopped: status {status} ({L.STATUS_MESSAGES[status]})")
    finally:
        integ.solver = real_solver
        for name, fn in real_replayed.items():
            setattr(integ, name, fn)
        integ._filtered_norm = real_filtered
    if len(caps) < n_solves:
        raise RuntimeError(f"captured {len(caps)} of {n_solves} solves")
    return caps


def hat_basis(n_free: int, spacing: int) -> sp.csr_matrix:
    """P (3 n_free x coarse): z displacements interpolated piecewise linearly along the node
    index between coarse nodes every ``spacing`` nodes (a partition of unity); spacing 1
    gives every node's z."""
    nodes = np.arange(n_free)
    centres = np.arange(int(np.ceil((n_free - 1) / spacing)) + 1) * spacing
    w = np.clip(1.0 - np.abs(nodes[:, None] - centres[None, :]) / spacing, 0.0, None)
    w /= w.sum(axis=1, keepdims=True)
    i, c = np.nonzero(w > 1e-14)
    p = sp.csr_matrix((w[i, c], (3 * i + 2, c)), shape=(3 * n_free, len(centres)))
    used = np.asarray(abs(p).sum(axis=0)).ravel() > 0.0
    return p[:, used].tocsr()


class Preconditioner(NamedTuple):
    """z = M^-1 v and A z, and the coarse space's size, bandwidth and LU time (s)."""

    apply: Apply
    coarse_unknowns: int = 0
    coarse_bandwidth: int = 0
    coarse_lu_s: float = 0.0


def newton_preconditioners(
    cap: Captured, a: sp.csr_matrix, c: sp.csr_matrix, b_lu: BandedLU
) -> dict[str, Preconditioner]:
    """The preconditioners of ``NEWTON_PRECONDITIONERS`` for one captured system."""

    def band_apply(v: Vector) -> tuple[Vector, Vector]:
        z = b_lu.solve(v)
        return z, v + c @ z  # A z = B z + C z, B z = v: as solver._off_band_times

    out = {}
    for label, (spacing, mode) in NEWTON_PRECONDITIONERS.items():
        if spacing is None:
            out[label] = Preconditioner(band_apply)
            continue
        p = hat_basis(cap.nd // 3, spacing)
        pt = p.T.tocsr()
        ac = (pt @ a @ p).tocsr()
        bw = bandwidth(ac)
        ac_band = to_band(ac, bw, bw)
        coarse = BandedLU(ac_band, ac.shape[0], bw, bw)

        def correct(r: Vector, p=p, pt=pt, coarse=coarse) -> Vector:
            return p @ coarse.solve(pt @ r)

        if mode == "multiplicative":

            def apply(v: Vector, correct=correct) -> tuple[Vector, Vector]:
                z = b_lu.solve(v)
                z = z + correct(v - a @ z)
                return z, a @ z

        elif mode == "symmetric":

            def apply(v: Vector, correct=correct) -> tuple[Vector, Vector]:
                z = b_lu.solve(v)
                z = z + correct(v - a @ z)
                z = z + b_lu.solve(v - a @ z)
                return z, a @ z

        else:
            raise ValueError(mode)
        out[label] = Preconditioner(
            apply, ac.shape[0], bw, lu_seconds(ac_band, ac.shape[0], bw, bw)
        )
    return out


def _tol(rtol: float) -> str:
    return f"{rtol:g}"


def _say(progress: Progress, line: str) -> None:
    """A progress line above the bar, unwrapped."""
    progress.console.print(line, markup=False, highlight=False, soft_wrap=True)


def newton_size(n: int, n_solves: int, progress: Progress, task: int) -> list[dict]:
    """Rows of one N (one per preconditioner), means over its captured solves."""
    t0 = time.perf_counter()
    sim = coil_stack(n, True, 0.98)
    sim.advance(WARM_S)
    caps = capture(sim, n_solves)
    _say(
        progress,
        f"N={n}: captured {len(caps)} solves at t = {sim.t * 1e3:.2f} ms in "
        f"{time.perf_counter() - t0:.1f} s; simulator iterations {[c.iterations for c in caps]}",
    )
    progress.advance(task)
    per: dict[str, dict[str, list]] = {k: {} for k in NEWTON_PRECONDITIONERS}
    for s, cap in enumerate(caps):
        if cap.rtol != RTOLS[0]:
            raise ValueError(f"the scene's krylov_tolerance is {cap.rtol}, not {RTOLS[0]}")
        a, c = cap.matrix(), cap.off_band()
        b_lu = BandedLU(cap.band, cap.nd, L.KL, L.KU)
        band_s = lu_seconds(cap.band, cap.nd, L.KL, L.KU)
        for label, pc in newton_preconditioners(cap, a, c, b_lu).items():
            d = per[label]
            for rtol in RTOLS:
                its, ok = fgmres(a, cap.rhs, pc.apply, rtol)
                d.setdefault(_tol(rtol), []).append(its)
                d.setdefault("unconverged", []).append(not ok)
            d.setdefault("nc", []).append(pc.coarse_unknowns)
            d.setdefault("bw", []).append(pc.coarse_bandwidth)
            d.setdefault("band_s", []).append(band_s)
            d.setdefault("coarse_s", []).append(pc.coarse_lu_s)
        counts = {k: (d[_tol(RTOLS[0])][-1], d[_tol(RTOLS[1])][-1]) for k, d in per.items()}
        _say(
            progress,
            f"N={n} solve {s + 1}/{len(caps)} (simulator {cap.iterations} iterations, "
            f"{len(cap.rows)} off-band blocks): iterations to {RTOLS[0]:g}, {RTOLS[1]:g}: "
            + ", ".join(f"{k} {u} {v}" for k, (u, v) in counts.items()),
        )
        progress.advance(task)
    rows = []
    code = [cap.iterations for cap in caps]
    for label, d in per.items():
        rows.append(
            {
                "nodes": n,
                "unknowns": caps[0].nd,
                "off_band_blocks": float(np.mean([len(cap.rows) for cap in caps])),
                "solves": len(caps),
                "preconditioner": label,
                "coarse_unknowns": int(np.max(d["nc"])),
                "coarse_bandwidth": int(np.max(d["bw"])),
                f"simulator_iterations_rtol_{_tol(RTOLS[0])}": float(np.mean(code)),
                **{f"iterations_rtol_{_tol(r)}": float(np.mean(d[_tol(r)])) for r in RTOLS},
                f"simulator_iterations_rtol_{_tol(RTOLS[0])}_each": " ".join(map(str, code)),
                **{
                    f"iterations_rtol_{_tol(r)}_each": " ".join(map(str, d[_tol(r)])) for r in RTOLS
                },
                "unconverged_solves": int(np.sum(d["unconverged"])),
                "band_lu_ms": 1e3 * float(np.mean(d["band_s"])),
                "coarse_lu_ms": 1e3 * float(np.mean(d["coarse_s"])),
                "coarse_lu_over_band_lu": float(
                    np.mean(np.array(d["coarse_s"]) / np.array(d["band_s"]))
                ),
            }
        )
    band = per["band"][_tol(RTOLS[0])]
    if band != code:
        progress.console.print(f"N={n}: band {band} differs from the simulator's {code}")
    return rows


def newton_part(sizes: Sequence[int], n_solves: int, out_dir: Path) -> Path:
    rows: list[dict] = []
    t0 = time.perf_counter()
    with Progress() as progress:
        task = progress.add_task("newton", total=len(sizes) * (1 + n_solves))
        for n in sizes:
            rows += newton_size(n, n_solves, progress, task)
    hi, lo = (f"iterations_rtol_{_tol(r)}" for r in RTOLS)
    print(f"\n{'N':>6} {'preconditioner':>18} {hi:>20} {lo:>21} {'coarse':>7} {'bw':>4} "
          f"{'LU cost':>8}")  # fmt: skip
    for r in rows:
        print(
            f"{r['nodes']:>6} {r['preconditioner']:>18} {r[hi]:>20.2f} {r[lo]:>21.2f} "
            f"{r['coarse_unknowns']:>7} {r['coarse_bandwidth']:>4} "
            f"{r['coarse_lu_over_band_lu']:>7.2f}x"
        )
    path = write_csv(out_dir / "preconditioner_newton.csv", rows)
    print("wrote", path, f"({time.perf_counter() - t0:.0f} s)")
    return path


# ------------------------------------------------------------------ part settled
SETTLED_SIZES = (300, 1000, 3000, 10000)
SETTLED_SOLVES = 30  # consecutive Newton solves captured per N, after the warm-up
SETTLED_WARM_UP_S = 0.02  # as contact_cost.py's settled parts
SETTLED_MAX_STEP_S = 2.5e-4
RECYCLED = (10, 40)  # Krylov directions (z, A z) the variants recycled_K keep
PROJECTED = (2, 8)  # earlier solutions (x, A x) the variants projected_K keep


class Forest(NamedTuple):
    """The axial problem with its couplings a turn apart lumped onto one partner a node:
    a forest (each node at most one parent, of higher index), solved exactly in O(N)."""

    diagonal: np.ndarray
    parent: np.ndarray  # -1: a root
    up: np.ndarray  # the node's entry in its parent's column
    down: np.ndarray  # the parent's entry in the node's column


def line_forest(az: sp.csr_matrix, reach: int = L.KL // 3) -> Forest:
    """From the axial matrix (every node's z): the entries within ``reach`` nodes along the
    filament lumped onto the diagonal (row sums kept, as for a displacement smooth along
    the filament), each node's entries further up (the turn above) summed onto the
    strongest of them, and their transposes onto the same pair: the lines of contacts up
    the stack, one tridiagonal-like chain (a tree where two nodes share a partner)."""
    n = az.shape[0]
    coo = az.tocoo()
    diagonal = np.zeros(n)
    up, down = np.zeros(n), np.zeros(n)
    parent = -np.ones(n, dtype=np.int64)
    strongest = np.zeros(n)
    near = np.abs(coo.row - coo.col) <= reach
    np.add.at(diagonal, coo.row[near], coo.data[near])
    far = ~near & (coo.col > coo.row)
    for i, j, v in zip(coo.row[far], coo.col[far], coo.data[far], strict=True):
        up[i] += v
        down[i] += az[j, i]
        if abs(v) > strongest[i]:
            strongest[i], parent[i] = abs(v), j
    return Forest(diagonal, parent, up, down)


def forest_solve(f: Forest, r: Vector) -> Vector:
    """x with F x = r: children eliminated into their parents (a parent's index is higher),
    then back-substitution from the roots."""
    d, b = f.diagonal.copy(), np.array(r, dtype=np.float64)
    for i in range(d.size):
        if not d[i] > 0.0:
            raise ValueError(f"forest pivot {i} is {d[i]:g}: the lumped problem is not definite")
        p = f.parent[i]
        if p >= 0:
            m = f.down[i] / d[i]
            d[p] -= m * f.up[i]
            b[p] -= m * b[i]
    x = np.zeros_like(b)
    for i in range(d.size - 1, -1, -1):
        p = f.parent[i]
        x[i] = (b[i] - (f.up[i] * x[p] if p >= 0 else 0.0)) / d[i]
    return x


class Recycler:
    """Fischer's (1998) projection for successive right-hand sides of one matrix: pairs
    (w, A w) kept from earlier solves, the A w orthonormalised, at most ``keep`` of them; a
    solve starts from x0 = W (AW)^T b, the point of their span with the smallest residual
    |b - A x0|. When pairs would overfill it, it starts anew from them, as Fischer's
    restarts. ``passes`` counts the passes over a vector of the system's length (a dot
    product, a scaling or an axpy each) that keeping and projecting take."""

    def __init__(self, keep: int) -> None:
        self.keep = keep
        self.w: list[Vector] = []
        self.aw: list[Vector] = []
        self.passes = 0

    def start(self, b: Vector) -> tuple[Vector, Vector]:
        """x0 and its residual b - A x0."""
        x0, r = np.zeros_like(b), np.array(b, dtype=np.float64)
        for w, aw in zip(self.w, self.aw, strict=True):
            c = aw @ r
            x0 += c * w
            r -= c * aw
        self.passes += 3 * len(self.w)
        return x0, r

    def add(self, pairs: list[tuple[Vector, Vector]]) -> None:
        """Keep pairs (z, A z) (the first ``keep`` of them), each orthogonalised against
        those kept (modified Gram-Schmidt on the A z); one whose A z is lost to round-off in
        that (already in the span) is dropped."""
        if len(self.w) + len(pairs) > self.keep:
            self.w, self.aw = [], []
        for z0, y0 in pairs[: self.keep]:
            z, y = np.array(z0, dtype=np.float64), np.array(y0, dtype=np.float64)
            size = float(np.linalg.norm(y))
            for w, aw in zip(self.w, self.aw, strict=True):
                h = aw @ y
                y -= h * aw
                z -= h * w
            norm = float(np.linalg.norm(y))
            self.passes += 1 + 3 * len(self.w) + 1
            if norm > 1e-8 * size:
                self.w.append(z / norm)
                self.aw.append(y / norm)
                self.passes += 2


def settled_stack(n: int) -> Simulation:
    """The pressed stack of N nodes after it has relaxed (as contact_cost.py's settled
    parts)."""
    sim = coil_stack(n, True, 0.98, {"numerics.max_step_s": SETTLED_MAX_STEP_S}, {})
    sim.advance(SETTLED_WARM_UP_S)
    return sim


def coil_pile() -> Simulation:
    """``period_doubling_22G`` (seed 0) at PILE_T_S: the coil's pile, with contact."""
    sim = Simulation("period_doubling_22G", {"seed": 0, "outputs.plot": False})
    sim.advance(PILE_T_S)
    return sim


def settled_case(
    case: str, sim: Simulation, n_solves: int, progress: Progress, task: int
) -> list[dict]:
    """Rows of one state: GMRES iterations per solve (to the simulator's tolerance) of its
    next ``n_solves`` consecutive Newton solves, per variant."""
    t0 = time.perf_counter()
    n = sim.n_nodes
    caps = capture(sim, n_solves, every=True)
    factorisations = len({cap.factorisation for cap in caps})
    _say(
        progress,
        f"{case}, N={n}: captured {len(caps)} solves ({factorisations} matrices) at "
        f"t = {sim.t * 1e3:.2f} ms in {time.perf_counter() - t0:.1f} s",
    )
    kept_variants = {f"recycled_{k}": k for k in RECYCLED} | {
        f"projected_{k}": k for k in PROJECTED
    }
    variants = ["band", "axial", "hat_4_z", "lines", *kept_variants]
    its: dict[str, list[int]] = {v: [] for v in variants}
    failed = dict.fromkeys(variants, 0)
    passes: dict[str, list[int]] = {v: [] for v in kept_variants}
    keepers: dict[str, Recycler] = {}
    last = None
    for cap in caps:
        a, c = cap.matrix(), cap.off_band()
        b_lu = BandedLU(cap.band, cap.nd, L.KL, L.KU)
        rtol = cap.rtol
        if cap.factorisation != last:  # a new matrix: what was kept no longer applies
            keepers = {label: Recycler(k) for label, k in kept_variants.items()}
            last = cap.factorisation
            p1 = hat_basis(cap.nd // 3, 1)
            axial = (p1.T @ a @ p1).tocsr()
            axial_lu = sla.splu(axial.tocsc())
            forest = line_forest(axial)
            p4 = hat_basis(cap.nd // 3, 4)
            hat_lu = sla.splu((p4.T @ a @ p4).tocsc())

        def band_apply(v: Vector, b_lu=b_lu, c=c) -> tuple[Vector, Vector]:
            z = b_lu.solve(v)
            return z, v + c @ z

        def after(correct: Callable[[Vector], Vector], a=a, b_lu=b_lu) -> Apply:
            def corrected(v: Vector) -> tuple[Vector, Vector]:
                z = b_lu.solve(v)
                z = z + correct(v - a @ z)
                return z, a @ z

            return corrected

        applies = {
            "band": band_apply,
            "axial": after(lambda r, p=p1, lu=axial_lu: p @ lu.solve(p.T @ r)),
            "hat_4_z": after(lambda r, p=p4, lu=hat_lu: p @ lu.solve(p.T @ r)),
            "lines": after(lambda r, p=p1, f=forest: p @ forest_solve(f, p.T @ r)),
        }
        for name, fn in applies.items():
            try:
                n_its, ok = fgmres(a, cap.rhs, fn, rtol)
            except (ValueError, np.linalg.LinAlgError):  # a forest pivot not positive
                failed[name] += 1
                continue
            its[name].append(n_its)
            failed[name] += not ok
        scale = float(np.linalg.norm(cap.rhs))
        for name, rec in keepers.items():
            before = rec.passes
            x0, r = rec.start(cap.rhs)
            kept: list[tuple[Vector, Vector]] = []

            def keeping(v: Vector, kept=kept, band_apply=band_apply) -> tuple[Vector, Vector]:
                z, y = band_apply(v)
                kept.append((z.copy(), y.copy()))
                return z, y

            left = float(np.linalg.norm(r))
            # the same target as the others: |b - A x| <= rtol |b|
            if left <= rtol * scale:
                n_its, ok, e = 0, True, np.zeros_like(x0)
            else:
                n_its, ok, e = fgmres_solution(a, r, keeping, rtol * scale / left)
            x = x0 + e
            ok = ok and float(np.linalg.norm(cap.rhs - a @ x)) <= rtol * scale * (1 + 1e-9)
            its[name].append(n_its)
            failed[name] += not ok
            if name.startswith("recycled"):
                rec.add(kept)
            else:  # A x = A x0 + A e: from the kept A w and GMRES's own A z (n_its + 1 axpys)
                rec.add([(x, a @ x)])
                rec.passes += n_its + 1
            passes[name].append(rec.passes - before)
        progress.advance(task)
    _say(
        progress,
        f"{case}, N={n}: mean iterations "
        + ", ".join(f"{v} {np.mean(its[v]):.2f}" for v in variants)
        + f" (simulator {np.mean([cap.iterations for cap in caps]):.2f})",
    )
    rows = []
    for v in variants:
        rows.append(
            {
                "case": case,
                "nodes": n,
                "solves": len(caps),
                "matrices": factorisations,
                "variant": v,
                "simulator_iterations": float(np.mean([cap.iterations for cap in caps])),
                "iterations": float(np.mean(its[v])) if its[v] else math.nan,
                "iterations_max": int(np.max(its[v])) if its[v] else -1,
                "unconverged_solves": failed[v],
                # work beyond band's per iteration: one more product with A (a
                # multiplicative correction)
                "extra_products_per_iteration": 1 if v in applies and v != "band" else 0,
                # and per solve: passes over a vector (projection and keeping)
                "vector_passes_per_solve": float(np.mean(passes[v])) if v in passes else 0.0,
                "kept": kept_variants.get(v, 0),
            }
        )
    return rows


def settled_part(sizes: Sequence[int], n_solves: int, out_dir: Path, pile: bool = True) -> Path:
    """Consecutive Newton solves of settled pressed stacks (and of the coil's pile): what
    other preconditioners, or what earlier solves of the same matrix kept, would save."""
    rows: list[dict] = []
    with Progress() as progress:
        task = progress.add_task("settled", total=(len(sizes) + pile) * n_solves)
        for n in sizes:
            rows += settled_case("pressed stack", settled_stack(n), n_solves, progress, task)
        if pile:
            case = f"period_doubling_22G at {PILE_T_S:g} s"
            rows += settled_case(case, coil_pile(), n_solves, progress, task)
    path = write_csv(out_dir / "preconditioner_settled.csv", rows)
    print("wrote", path)
    return path


# ------------------------------------------------------------------ part amg
AMG_SIZES = (1000, 3000, 10000)


def _amg_builders(a: sp.csr_matrix) -> dict[str, tuple[Callable[[], Any], np.ndarray | None]]:
    """Algebraic multigrid hierarchies (pyamg) for the captured Newton matrix ``a``, each as
    a builder (so that its set-up is timed alone) with the unknowns it acts on (None: all):
    on the axial problem (every node's z, the block that ``axial`` solves exactly) by
    smoothed aggregation and by Ruge-Stueben, and on the whole matrix by smoothed
    aggregation with the three translations as near-null space."""
    import pyamg

    nd = a.shape[0]
    z = np.arange(2, nd, 3)
    azz = a[z][:, z]
    azz = ((azz + azz.T) * 0.5).tocsr()
    whole = ((a + a.T) * 0.5).tocsr()
    gs2 = ("gauss_seidel", {"sweep": "symmetric", "iterations": 2})
    translations = np.zeros((nd, 3))
    for c in range(3):
        translations[c::3, c] = 1.0
    return {
        "axial_sa": (
            lambda: pyamg.smoothed_aggregation_solver(
                azz,
                strength=("symmetric", {"theta": 0.1}),
                presmoother=gs2,
                postsmoother=gs2,
                max_coarse=50,
            ),
            z,
        ),
        "axial_rs": (lambda: pyamg.ruge_stuben_solver(azz, max_coarse=50), z),
        "whole_sa": (
            lambda: pyamg.smoothed_aggregation_solver(
                whole, B=translations, strength=("symmetric", {"theta": 0.0}), max_coarse=200
            ),
            None,
        ),
    }


def _cycle_factor(ml: Any, n: int) -> float:
    """Mean residual reduction per V-cycle of ``ml`` alone (30 cycles, random start)."""
    res: list[float] = []
    ml.solve(np.random.default_rng(0).standard_normal(n), tol=1e-10, maxiter=30, residuals=res)
    return float((res[-1] / res[0]) ** (1.0 / (len(res) - 1)))


def _iterations(a: sp.csr_matrix, b: Vector, apply: Apply) -> dict[str, int]:
    """FGMRES iterations to each of RTOLS."""
    return {f"iterations_rtol_{_tol(r)}": fgmres(a, b, apply, r)[0] for r in RTOLS}


def amg_size(n: int, n_solves: int, progress: Progress, task: int) -> list[dict]:
    """Rows of one N: for each captured solve and hierarchy, FGMRES iterations with the
    banded LU then one V-cycle on its unknowns (multiplicative; whole_sa: the V-cycle
    alone), the cycle's own convergence factor, and its set-up and cycle time against the
    banded LU's factorisation and solve."""
    sim = coil_stack(n, True, 0.98)
    sim.advance(WARM_S)
    caps = capture(sim, n_solves)
    progress.advance(task)
    rows = []
    for s, cap in enumerate(caps):
        a = cap.matrix()
        b_lu = BandedLU(cap.band, cap.nd, L.KL, L.KU)
        lu_ms = 1e3 * lu_seconds(cap.band, cap.nd, L.KL, L.KU)
        solve_ms = 1e3 * best_of(lambda b_lu=b_lu, cap=cap: b_lu.solve(cap.rhs), 5)

        def band_apply(v: Vector, b_lu=b_lu, a=a) -> tuple[Vector, Vector]:
            z = b_lu.solve(v)
            return z, a @ z

        base = {
            "nodes": n,
            "unknowns": cap.nd,
            "solve": s,
            "simulator_iterations_rtol_0.05": cap.iterations,
            "band_lu_ms": lu_ms,
            "band_solve_ms": solve_ms,
        }
        rows.append(
            {
                **base,
                "preconditioner": "band",  # set-up: its LU; cycle: its solve
                **_iterations(a, cap.rhs, band_apply),
                "levels": 1,
                "cycle_factor": float("nan"),
                "setup_ms": lu_ms,
                "cycle_ms": solve_ms,
            }
        )
        for label, (build, unknowns) in _amg_builders(a).items():
            t0 = time.perf_counter()
            ml = build()
            setup_ms = 1e3 * (time.perf_counter() - t0)
            cycle = ml.aspreconditioner(cycle="V")

            def apply(v: Vector, cycle=cycle, unknowns=unknowns, a=a, b_lu=b_lu):
                if unknowns is None:
                    z = cycle.matvec(v)
                else:
                    z = b_lu.solve(v)
                    r = v - a @ z
                    z[unknowns] += cycle.matvec(r[unknowns])
                return z, a @ z

            probe = cap.rhs if unknowns is None else cap.rhs[unknowns]
            rows.append(
                {
                    **base,
                    "preconditioner": label,
                    **_iterations(a, cap.rhs, apply),
                    "levels": len(ml.levels),
                    "cycle_factor": _cycle_factor(ml, probe.size),
                    "setup_ms": setup_ms,
                    "cycle_ms": 1e3 * best_of(lambda c=cycle, v=probe: c.matvec(v), 5),
                }
            )
        _say(
            progress,
            f"N={n} solve {s + 1}: "
            + ", ".join(
                f"{r['preconditioner']} {r['iterations_rtol_0.05']}/{r['iterations_rtol_0.001']}"
                for r in rows
                if r["solve"] == s
            ),
        )
        progress.advance(task)
    return rows


def amg_part(sizes: Sequence[int], n_solves: int, out_dir: Path) -> Path:
    try:
        import pyamg
    except ImportError as exc:
        raise SystemExit(
            f"--part amg needs pyamg ({exc}); install it with pip install -e '.[bench]'"
        ) from exc
    rows: list[dict] = []
    with Progress() as progress:
        task = progress.add_task("amg", total=len(sizes) * (1 + n_solves))
        for n in sizes:
            rows += amg_size(n, n_solves, progress, task)
    hi, lo = (f"iterations_rtol_{_tol(r)}" for r in RTOLS)
    print(f"\n{'N':>6} {'preconditioner':>14} {hi:>20} {lo:>21} {'factor':>7} {'set-up ms':>9}")
    for n in sizes:
        for label in dict.fromkeys(r["preconditioner"] for r in rows):
            sel = [r for r in rows if r["nodes"] == n and r["preconditioner"] == label]
            print(
                f"{n:>6} {label:>14} {np.mean([r[hi] for r in sel]):>20.2f} "
                f"{np.mean([r[lo] for r in sel]):>21.2f} "
                f"{np.mean([r['cycle_factor'] for r in sel]):>7.2f} "
                f"{np.mean([r['setup_ms'] for r in sel]):>9.2f}"
            )
    path = write_csv(out_dir / "preconditioner_amg.csv", rows)
    print("wrote", path, f"(pyamg {pyamg.__version__})")
    return path


BACKSUB_SIZES = (100, 300, 1000, 3000, 10000)  # nodes (3 unknowns each)


@njit
def _solve_loop(by_columns: bool, reps: int, lu: np.ndarray, n: int, piv: np.ndarray,
                b0: np.ndarray, b: np.ndarray) -> None:  # fmt: skip
    """Restore b from b0 and solve with the factors, ``reps`` times, in either order."""
    for _ in range(reps):
        b[:n] = b0[:n]
        if by_columns:
            band_solve_by_columns(lu, n, piv, b)
        else:
            band_solve(lu, n, L.KL, L.KU, piv, b)


def _dominant_band(rng: np.random.Generator, n: int) -> np.ndarray:
    """A random band matrix of n unknowns (the simulator's widths), diagonally dominant."""
    band = np.zeros((n, L.BAND_WIDTH))
    band[:, : L.KL + L.KU + 1] = rng.standard_normal((n, L.KL + L.KU + 1))
    band[:, L.KL] += 2.0 * (L.KL + L.KU)
    return band


def backsub_part(out_dir: Path, sizes: Sequence[int] = BACKSUB_SIZES) -> Path:
    """Time the two orders of the banded back-substitution (rows, columns) on the same LU."""
    rng = np.random.default_rng(0)
    rows = []
    for nodes in sizes:
        n = 3 * nodes
        lu = _dominant_band(rng, n)
        piv = np.zeros(n, dtype=np.int64)
        if band_lu(lu, n, L.KL, L.KU, piv) != 0:
            raise RuntimeError("the random band matrix came out singular")
        b0 = rng.standard_normal(n)
        x_rows, x_cols = b0.copy(), b0.copy()
        _solve_loop(False, 1, lu, n, piv, b0, x_rows)
        _solve_loop(True, 1, lu, n, piv, b0, x_cols)
        best = {False: np.inf, True: np.inf}
        work = b0.copy()
        for _ in range(7):
            for by_columns in (False, True):
                t0 = time.perf_counter()
                _solve_loop(by_columns, 200, lu, n, piv, b0, work)
                best[by_columns] = min(best[by_columns], (time.perf_counter() - t0) / 200)
        diff = float(np.max(np.abs(x_cols - x_rows)) / np.max(np.abs(x_rows)))
        rows.append(
            {
                "nodes": nodes,
                "unknowns": n,
                "rows_us": 1e6 * best[False],
                "columns_us": 1e6 * best[True],
                "speed_up": best[False] / best[True],
                "max_rel_difference": diff,
            }
        )
        print(
            f"{nodes:>6} nodes: rows {rows[-1]['rows_us']:8.1f} us, columns "
            f"{rows[-1]['columns_us']:8.1f} us ({rows[-1]['speed_up']:.2f}x), "
            f"difference {diff:.1e}"
        )
    path = write_csv(out_dir / "backsub.csv", rows)
    print("wrote", path)
    return path


@njit
def _diagonal_loops(diagonal: bool, reps: int, solves: int, saved: np.ndarray, work: np.ndarray,
                    n: int, piv: np.ndarray, inv: np.ndarray, b0: np.ndarray,
                    b: np.ndarray) -> None:  # fmt: skip
    """``reps`` LUs of ``saved`` (restored into ``work`` first) or, with reps = 0, ``solves``
    solves of b0 with the factors in ``work``, with partial or diagonal pivots."""
    for _ in range(reps):
        work[:n] = saved[:n]
        if diagonal:
            band_lu_diagonal(work, n, piv, inv, 0.1)
        else:
            band_lu(work, n, L.KL, L.KU, piv)
    for _ in range(solves):
        b[:n] = b0[:n]
        if diagonal:
            band_solve_diagonal(work, n, inv, b)
        else:
            band_solve_by_columns(work, n, piv, b)


def _diagonal_row(label: str, nodes: int, saved: np.ndarray, b0: np.ndarray) -> dict:
    """Both LUs of the band ``saved`` (n = len(b0) unknowns) and their solves of b0 timed,
    alternating (best of 7 of 20 LUs and of 200 solves), with the rows partial pivoting
    swaps and whether every diagonal pivot passes the threshold."""
    n = b0.shape[0]
    work = {d: saved.copy() for d in (False, True)}
    piv = {d: np.zeros(n, dtype=np.int64) for d in (False, True)}
    inv = np.zeros(n)
    x = {d: b0.copy() for d in (False, True)}
    passes = band_lu_diagonal(saved.copy(), n, np.zeros(n, dtype=np.int64), inv, 0.1) == 0
    for d in (False, True):
        _diagonal_loops(d, 1, 1, saved, work[d], n, piv[d], inv, b0, x[d])
    best = {(d, what): np.inf for d in (False, True) for what in ("lu", "solve")}
    scratch = b0.copy()
    for _ in range(7):
        for d in (False, True):
            for what, reps, solves in (("lu", 20, 0), ("solve", 0, 200)):
                t0 = time.perf_counter()
                _diagonal_loops(d, reps, solves, saved, work[d], n, piv[d], inv, b0, scratch)
                per = (time.perf_counter() - t0) / (reps or solves)
                best[d, what] = min(best[d, what], per)
    diff = float(np.max(np.abs(x[True] - x[False])) / np.max(np.abs(x[False])))
    row = {
        "matrix": label,
        "nodes": nodes,
        "unknowns": n,
        "rows_swapped_by_partial_pivoting": int(np.count_nonzero(piv[False] != np.arange(n))),
        "diagonal_pivots_pass": bool(passes),
        "lu_partial_us": 1e6 * best[False, "lu"],
        "lu_diagonal_us": 1e6 * best[True, "lu"],
        "lu_speed_up": best[False, "lu"] / best[True, "lu"],
        "solve_partial_us": 1e6 * best[False, "solve"],
        "solve_diagonal_us": 1e6 * best[True, "solve"],
        "solve_speed_up": best[False, "solve"] / best[True, "solve"],
        "max_rel_difference": diff,
    }
    print(
        f"{label:>8} {nodes:>6} nodes: LU {row['lu_partial_us']:8.1f} -> "
        f"{row['lu_diagonal_us']:8.1f} us ({row['lu_speed_up']:.2f}x), solve "
        f"{row['solve_partial_us']:7.1f} -> {row['solve_diagonal_us']:7.1f} us "
        f"({row['solve_speed_up']:.2f}x), difference {diff:.1e}, "
        f"{row['rows_swapped_by_partial_pivoting']} rows swapped"
    )
    return row


PILE_T_S = 0.8  # the pile of period_doubling_22G (seed 0) whose Newton matrix part diagonal times


def diagonal_part(out_dir: Path, sizes: Sequence[int] = BACKSUB_SIZES, pile: bool = True) -> Path:
    """Time GMRES's LU and solve with partial pivoting against diagonal pivots: on random
    diagonally dominant bands, and (``pile``) on the band of the last Newton matrix GMRES
    factorised in ``period_doubling_22G`` at PILE_T_S (its unfactored copy)."""
    rng = np.random.default_rng(0)
    rows = []
    for nodes in sizes:
        n = 3 * nodes
        rows.append(_diagonal_row("random", nodes, _dominant_band(rng, n), rng.standard_normal(n)))
    if pile:
        over = {"seed": 0, "outputs.plot": False, **SHARP_CONTACT}
        sim = Simulation("period_doubling_22G", over)
        sim.advance(PILE_T_S)
        nd = int(sim.ws.solver[0]["lu_nd"])
        band = np.ascontiguousarray(sim.ws.krylov.band_a[:nd])
        rows.append(_diagonal_row("pile", nd // 3, band, rng.standard_normal(nd)))
    path = write_csv(out_dir / "lu_diagonal.csv", rows)
    print("wrote", path)
    return path


# ------------------------------------------------------------------ part blocks
BLOCK_SIZES = (300, 1000, 3000, 10000, 30000, 100000)  # nodes
TURN_NODES = round(2 * math.pi * COIL_RADIUS / SPACING)  # nodes per turn of coil_stack's (63)
TURN_OFFSETS = (-2, -1, 0, 1)  # the nodes of the next turn a node's blocks reach
WRITES = 2  # each node block is written by this many segment pairs


def stack_couplings(nodes: int, rng: np.random.Generator):
    """Random 3x3 blocks with a pressed stack's pattern: each node coupled to the 4 nearest
    nodes one turn up, both ways, each node block written twice (16 blocks per node and 8
    distinct, as the relaxed stacks of ``bench_contact --part saturation`` hold 15.7 and 7.8
    at 3000 nodes: two segments share each node), in the order a contact pass writes them."""
    pairs = [
        (i, i + TURN_NODES + d)
        for i in range(nodes)
        for d in TURN_OFFSETS
        if 0 <= i + TURN_NODES + d < nodes
    ]
    k = 2 * WRITES * len(pairs)
    cpl = new_couplings(k)
    q = 0
    for i, j in pairs:
        for _ in range(WRITES):
            cpl.row[q], cpl.col[q] = i, j
            cpl.row[q + 1], cpl.col[q + 1] = j, i
            q += 2
    cpl.block[:] = rng.standard_normal((k, 3, 3))
    cpl.count[0] = k
    return cpl


@njit
def _product_loop(reps: int, cpl, x: np.ndarray, y: np.ndarray) -> None:
    for _ in range(reps):
        add_blocks_matvec(cpl, x, y)


@njit
def _merge_loop(reps: int, cpl, n_rows: int) -> None:
    for _ in range(reps):
        merge_blocks(cpl, n_rows)


@njit
def _backsub_loop(reps: int, lu: np.ndarray, n: int, inv: np.ndarray, b0, b) -> None:
    for _ in range(reps):
        b[:n] = b0[:n]
        band_solve_diagonal(lu, n, inv, b)


def blocks_part(out_dir: Path, sizes: Sequence[int] = BLOCK_SIZES) -> Path:
    """The two kernels that take most of a pressed stack's step (the product with the blocks
    off the band, GMRES's back-substitution), each timed alone on arrays of a stack's sizes:
    whether their cost per block and per node grows with N when nothing else runs."""
    rng = np.random.default_rng(0)
    rows = []
    for nodes in sizes:
        n = 3 * nodes
        cpl = stack_couplings(nodes, rng)
        k = int(cpl.count[0])
        x, y = rng.standard_normal(n), np.zeros(n)
        lu = _dominant_band(rng, n)
        inv = np.zeros(n)
        if band_lu_diagonal(lu, n, np.zeros(n, dtype=np.int64), inv, 0.1) != 0:
            raise RuntimeError("the random band matrix needed row swaps")
        lu_used = np.ascontiguousarray(lu[:, : L.KL + L.KU + 1])  # as GMRES keeps it (krylov.lu)
        b0, b = rng.standard_normal(n), np.zeros(n)
        reps = max(3, 2_000_000 // k)
        _product_loop(1, cpl, x, y)
        _merge_loop(1, cpl, nodes)
        merged = int(cpl.merged[0])
        cpl.merged[0] = -1
        _backsub_loop(1, lu, n, inv, b0, b)
        _backsub_loop(1, lu_used, n, inv, b0, b)
        product = product_merged = merge = backsub = backsub_used = np.inf
        for _ in range(7):
            cpl.merged[0] = -1  # block by block, as assembled
            t0 = time.perf_counter()
            _product_loop(reps, cpl, x, y)
            product = min(product, (time.perf_counter() - t0) / reps)
            t0 = time.perf_counter()
            _merge_loop(reps, cpl, nodes)
            merge = min(merge, (time.perf_counter() - t0) / reps)
            t0 = time.perf_counter()
            _product_loop(reps, cpl, x, y)  # by merged rows
            product_merged = min(product_merged, (time.perf_counter() - t0) / reps)
            t0 = time.perf_counter()
            _backsub_loop(reps, lu, n, inv, b0, b)
            backsub = min(backsub, (time.perf_counter() - t0) / reps)
            t0 = time.perf_counter()
            _backsub_loop(reps, lu_used, n, inv, b0, b)
            backsub_used = min(backsub_used, (time.perf_counter() - t0) / reps)
        rows.append(
            {
                "nodes": nodes,
                "blocks": k,
                "blocks_mb": k * (cpl.block.itemsize * 9 + 2 * cpl.row.itemsize) / 1e6,
                "band_mb": lu.nbytes / 1e6,
                "product_us": 1e6 * product,
                "ns_per_block": 1e9 * product / k,
                "merged_blocks": merged,
                "merge_us": 1e6 * merge,
                "product_merged_us": 1e6 * product_merged,
                "merged_over_assembled": product_merged / product,
                "backsub_us": 1e6 * backsub,
                "ns_per_node_backsub": 1e9 * backsub / nodes,
                "lu_used_mb": lu_used.nbytes / 1e6,
                "ns_per_node_backsub_used_columns": 1e9 * backsub_used / nodes,
            }
        )
        r = rows[-1]
        print(
            f"{nodes:>6} nodes: product {r['ns_per_block']:.2f} ns per block "
            f"({r['blocks_mb']:.1f} MB of blocks), by merged rows "
            f"{r['merged_over_assembled']:.2f}x that (merging {r['merge_us']:.0f} us), "
            "back-substitution "
            f"{r['ns_per_node_backsub']:.1f} ns per node ({r['band_mb']:.1f} MB of band), "
            f"{r['ns_per_node_backsub_used_columns']:.1f} through the {L.KL + L.KU + 1} columns "
            f"it uses ({r['lu_used_mb']:.1f} MB)",
            flush=True,
        )
    path = write_csv(out_dir / "stack_kernels.csv", rows)
    print("wrote", path)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument(
        "--part",
        choices=("all", "random", "newton", "amg", "settled", "backsub", "diagonal", "blocks"),
        default="all",
    )
    ap.add_argument(
        "--sizes",
        type=lambda s: [int(x) for x in s.split(",")],
        default=list(NEWTON_SIZES),
        help="part newton: node counts N, comma-separated",
    )
    ap.add_argument(
        "--solves",
        type=int,
        default=None,
        help=f"parts newton and amg: solves per N ({SOLVES}); settled: ({SETTLED_SOLVES})",
    )
    ap.add_argument("--out", type=Path, default=RESULTS, help="directory of the CSV files")
    args = ap.parse_args(argv)
    if args.part in ("all", "random"):
        random_part(args.out)
    if args.part in ("all", "newton"):
        newton_part(args.sizes, args.solves or SOLVES, args.out)
    if args.part in ("all", "backsub"):
        backsub_part(args.out)
    if args.part in ("all", "diagonal"):
        diagonal_part(args.out)
    if args.part in ("all", "blocks"):
        blocks_part(args.out)
    if args.part in ("all", "settled"):
        sizes = args.sizes if args.sizes != list(NEWTON_SIZES) else list(SETTLED_SIZES)
        settled_part(sizes, args.solves or SETTLED_SOLVES, args.out)
    if args.part == "amg":
        sizes = args.sizes if args.sizes != list(NEWTON_SIZES) else list(AMG_SIZES)
        amg_part(sizes, args.solves or SOLVES, args.out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

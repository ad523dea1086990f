"""Where the time of one implicit step goes: kernel costs composed into a per-step breakdown.

States: a horizontal clamped filament of N = 100, 1000, 10000 nodes sagging under its
net weight (as bench_scaling.py), and the default scene (paper_simulation) at t = 1.8 s
(as bench_effects.py); all at a fixed 2 ms step. On each state, after a 20 ms warm-up:

(1) the whole step: a fixed-step ``advance`` over a window of steps on identical copies
    of the state, divided by the steps (and by the Newton iterations, from the counters);
(2) the kernels, called directly on copies of the simulation's own arrays from a numba
    loop (no Python call overhead, best of several repeats, per call): each effect's
    ``accumulate`` alone with the Jacobian, ``assemble``'s own clearing of force and band,
    ``assemble`` without the Jacobian, ``assemble`` as the filtered error norm calls it
    (Jacobian with cx = 0, which elasticity skips), ``band_lu``, ``band_solve``,
    ``band_matvec`` and ``set_boundary``; (1) and (2) alternate over 5 rounds and keep their best;
(3) how often each kernel runs per step. The counters record Newton iterations but not
    factorisations (modified Newton factorises once per step unless the iteration stops
    contracting), so a fresh copy replays the same window through the integrator's own
    Python source (numba's ``py_func``) with counting wrappers around the kernels; its
    Newton iterations are checked against the timed run's counters.

Per step, component = (calls per step) x (cost per call); "other" (vector updates, error
norms, checks, extrusion and gelation bookkeeping) is the whole step minus the parts.
The headline is the share of a step (%): absolute times are noisy on a shared machine.

    python benchmarks/bench_profile.py
"""

from __future__ import annotations

import copy
import time
from collections.abc import Callable
from types import ModuleType

import matplotlib
import numpy as np
from _common import RESULTS, best_of, sagging_filament, write_csv
from numba import njit

import bathprint.core.integrators as integ
from bathprint import Simulation
from bathprint.core import layout as L
from bathprint.core.assemble import assemble
from bathprint.core.banded import band_lu, band_matvec, band_solve
from bathprint.core.effects import drag, elasticity, end_load, floor, gravity, inertia
from bathprint.core.extrusion import set_boundary
from bathprint.core.topology import free_nodes

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STEP_S = 2e-3
ROUNDS = 5  # rounds of (whole step, kernels)
EFFECTS: dict[int, ModuleType] = {
    L.E_ELASTICITY: elasticity,
    L.E_DRAG: drag,
    L.E_GRAVITY: gravity,
    L.E_FLOOR: floor,
    L.E_INERTIA: inertia,
    L.E_END_LOAD: end_load,
}
# kernels the replay counts: the names under which bathprint.core.integrators calls them
COUNTED = ("assemble", "band_lu", "band_solve", "band_matvec", "set_boundary")
# integrator functions replayed from their Python source so the counted kernels are seen
REPLAYED = ("_stage_solve", "_filtered_norm", "_implicit_step", "_explicit_step")


# ------------------------------------------------------------------ states
def _sagging(n: int) -> Simulation:
    """A clamped horizontal filament of n segments sagging under its weight (bench_scaling)."""
    return sagging_filament(n, STEP_S)


def _default_scene() -> Simulation:
    """The default scene, extruding, at t = 1.8 s (bench_effects' state), fixed steps."""
    sim = Simulation("paper_simulation", {"duration_s": 5.0, "numerics.time_step_s": STEP_S})
    sim.advance(1.8)
    return sim


# ------------------------------------------------------------------ kernel loops (numba)
def _effect_loop(fn: Callable) -> Callable:
    """A numba loop calling one effect's ``accumulate(*args)`` ``reps`` times."""

    @njit
    def run(reps, *args):
        e = 0.0
        for _ in range(reps):
            e += fn(*args)
        return e

    return run


@njit
def _assemble_loop(reps, *args):
    for _ in range(reps):
        assemble(*args)


@njit
def _lu_loop(reps, band, saved, nd, piv, factor):
    """Restore the band from ``saved`` and (if ``factor``) factorise it, ``reps`` times."""
    for _ in range(reps):
        band[:nd] = saved[:nd]
        if factor:
            band_lu(band, nd, L.KL, L.KU, piv)


@njit
def _solve_loop(reps, band, nd, piv, b, saved, solve):
    """Restore the right-hand side and (if ``solve``) solve with the factors, ``reps`` times."""
    for _ in range(reps):
        b[:nd] = saved[:nd]
        if solve:
            band_solve(band, nd, L.KL, L.KU, piv, b)


@njit
def _matvec_loop(reps, band, nd, x, y):
    for _ in range(reps):
        band_matvec(band, nd, L.KL, L.KU, x, y)


@njit
def _boundary_loop(reps, *args):
    for _ in range(reps):
        set_boundary(*args)


_LOOPS = {k: _effect_loop(mod.accumulate) for k, mod in EFFECTS.items()}


def _per_call(loop: Callable, reps: int, *args: object, repeats: int = 3) -> float:
    """Seconds per kernel call: best of ``repeats`` numba loops of ``reps`` calls."""
    loop(1, *args)  # compile and warm the caches
    return best_of(lambda: loop(reps, *args), repeats) / reps


def kernel_costs(sim: Simulation) -> dict[str, float]:
    """Seconds per call of every kernel of a step, on copies of ``sim``'s arrays."""
    m = sim.model
    n = sim.n_nodes
    nd = 3 * free_nodes(n, m.params)
    reps = max(5, 100_000 // n)
    gamma = 1.0 if m.integrator == L.INTEGRATOR_IMPLICIT_EULER else integ.GAMMA
    hg = STEP_S * gamma
    ca = 1.0 / hg**2 if m.params[L.P_INERTIA] > 0.0 else 0.0
    pos, vel = sim.pos.copy(), sim.vel.copy()
    acc = np.zeros_like(vel)
    force = np.zeros_like(pos)
    band = np.zeros_like(sim.band)
    work = sim.work.copy()
    calls = np.zeros_like(sim.calls)
    energies = np.zeros_like(sim.energies)
    state = (pos, vel, acc, n, sim.seg_rest, sim.seg_mat, m.params, sim.t, 1.0, 1.0 / hg, ca)
    out: dict[str, float] = {}
    for k in np.flatnonzero(m.enabled[: len(EFFECTS)]):
        out[f"assemble+J: {L.EFFECT_NAMES[k]}"] = _per_call(
            _LOOPS[int(k)], reps, *state, force, band, work, True
        )
    no_effects = np.zeros_like(m.enabled)
    out["assemble+J: clear"] = _per_call(
        _assemble_loop, reps, *state, force, band, work, True, no_effects, calls, energies
    )
    out["assemble+J (whole)"] = _per_call(
        _assemble_loop, reps, *state, force, band, work, True, m.enabled, calls, energies
    )
    out["assemble, no J"] = _per_call(
        _assemble_loop, reps, *state, force, band, work, False, m.enabled, calls, energies
    )
    # the filtered error norm assembles with cx = 0 (no stiffness: elasticity skips its
    # Jacobian there) into the second band
    filt = (*state[:8], 0.0, *state[9:], force, band, work, True, m.enabled, calls, energies)
    out["filter: assemble (cx=0)"] = _per_call(_assemble_loop, reps, *filt)
    # the stage matrix of a Newton iteration, its factors, and a right-hand side
    assemble(*state, force, band, work, True, m.enabled, calls, energies)
    saved_band = band.copy()
    piv = np.zeros_like(sim.piv)
    lu_and_copy = _per_call(_lu_loop, reps, band, saved_band, nd, piv, True)
    out["band_lu"] = lu_and_copy - _per_call(_lu_loop, reps, band, saved_band, nd, piv, False)
    _lu_loop(1, band, saved_band, nd, piv, True)
    rhs, saved_rhs = force.copy(), force.copy()
    solve_and_copy = _per_call(_solve_loop, reps, band, nd, piv, rhs, saved_rhs, True)
    out["band_solve"] = solve_and_copy - _per_call(
        _solve_loop, reps, band, nd, piv, rhs, saved_rhs, False
    )
    out["band_matvec"] = _per_call(_matvec_loop, reps, saved_band, nd, vel.copy(), rhs)
    out["set_boundary"] = _per_call(
        _boundary_loop,
        reps,
        pos,
        vel,
        sim.node_s.copy(),
        sim.seg_rest.copy(),
        n,
        sim.t,
        m.flow,
        m.flow_cum,
        m.needle,
        m.params,
        work,
    )
    return out


# ------------------------------------------------------------------ whole step and counts
def step_time(base: Simulation, steps: int, copies: int) -> tuple[float, Simulation]:
    """Best wall time per step of ``steps`` fixed steps over identical copies of ``base``;
    returns it and one of the advanced copies."""
    sims = [copy.deepcopy(base) for _ in range(copies)]
    it = iter(sims)

    def run() -> None:
        s = next(it)
        s.advance(s.t + steps * STEP_S)

    return best_of(run, copies) / steps, sims[0]


def replay_counts(sim: Simulation, steps: int) -> tuple[dict[str, float], dict[str, int]]:
    """Kernel calls per step over ``steps`` steps, replaying ``advance`` from its Python source.

    Returns the calls per step (assemble split into Newton with and without the Jacobian
    and the filtered error norm's) and the simulation's counter deltas over the replay."""
    calls = dict.fromkeys(("assemble+J", "assemble, no J", "filter", *COUNTED[1:]), 0)
    real = {name: getattr(integ, name) for name in COUNTED + REPLAYED}

    def counting(name: str) -> Callable:
        fn = real[name]

        def wrapper(*args: object) -> object:
            key = name
            if name == "assemble":  # do_jac, and cx = 0 for the filtered error norm
                key = (
                    ("filter" if args[8] == 0.0 else "assemble+J") if args[14] else "assemble, no J"
                )
            calls[key] += 1
            return fn(*args)

        return wrapper

    m = sim.model
    before = sim.counts()
    try:
        for name in COUNTED:
            setattr(integ, name, counting(name))
        for name in REPLAYED:
            setattr(integ, name, real[name].py_func)
        status = integ.advance.py_func(
            sim.t + steps * STEP_S,
            10**9,
            m.integrator,
            sim.pos,
            sim.vel,
            sim.node_s,
            sim.seg_rest,
            sim.seg_mat,
            sim.istate,
            sim.fstate,
            m.params,
            m.enabled,
            m.flow,
            m.flow_cum,
            m.needle,
            sim.vecs,
            sim.band,
            sim.band2,
            sim.piv,
            sim.work,
            sim.calls,
            sim.counters,
            sim.energies,
            sim.info,
        )
    finally:
        for name, fn in real.items():
            setattr(integ, name, fn)
    if status != L.STATUS_OK:
        raise RuntimeError(f"replay stopped with status {status} (capacity or divergence)")
    after = sim.counts()
    done = after["steps"] - before["steps"]
    return {k: v / done for k, v in calls.items()}, {k: after[k] - before[k] for k in after}


# ------------------------------------------------------------------ one case
def profile(label: str, base: Simulation, steps: int) -> list[dict]:
    """Breakdown of a step of ``base``'s scene (``base`` is only copied, never advanced)."""
    # alternate whole steps and kernels so a burst of load on the shared machine is less
    # likely to hit one and not the other; keep the best of every number over the rounds
    per_step = float("inf")
    cost: dict[str, float] = {}
    for _ in range(ROUNDS):
        t_step, sim = step_time(base, steps, 2)
        per_step = min(per_step, t_step)
        for k, v in kernel_costs(sim).items():
            cost[k] = min(cost.get(k, v), v)
    per_call, counted = replay_counts(copy.deepcopy(base), steps)
    timed_newton = sim.counts()["newton_iterations"] - base.counts()["newton_iterations"]
    if timed_newton != counted["newton_iterations"]:
        print(
            f"  note: replay {counted['newton_iterations']} Newton iterations, timed {timed_newton}"
        )
    newton = counted["newton_iterations"] / counted["steps"]
    n = base.n_nodes
    print(
        f"{label}: N={n}, {1e6 * per_step:.0f} us/step, {newton:.2f} Newton iterations/step "
        f"({1e6 * per_step / newton:.0f} us each); per step: {per_call['band_lu']:.2f} LU, "
        f"{per_call['filter']:.2f} filtered norm, "
        f"{per_call['assemble+J']:.2f} assemble+J, {per_call['assemble, no J']:.2f} assemble "
        f"no J, {per_call['band_solve']:.2f} solves, {per_call['band_matvec']:.2f} matvec, "
        f"{per_call['set_boundary']:.2f} set_boundary, "
        f"{counted['nodes_born'] / counted['steps']:.2f} splits"
    )
    parts_sum = sum(v for k, v in cost.items() if k.startswith("assemble+J:"))
    print(
        f"  check: assemble+J whole {1e6 * cost['assemble+J (whole)']:.1f} us/call, "
        f"effects + clear {1e6 * parts_sum:.1f} us/call"
    )
    # component: (calls per step, seconds per call)
    newton_solves = per_call["band_solve"] - per_call["filter"]  # the filter solves once
    parts = {k: (per_call["assemble+J"], v) for k, v in cost.items() if k.startswith("assemble+J:")}
    parts |= {
        "assemble, no J": (per_call["assemble, no J"], cost["assemble, no J"]),
        "band_lu": (per_call["band_lu"], cost["band_lu"]),
        "band_solve (Newton)": (newton_solves, cost["band_solve"]),
        "set_boundary": (per_call["set_boundary"], cost["set_boundary"]),
        "filter: assemble (cx=0)": (per_call["filter"], cost["filter: assemble (cx=0)"]),
        "filter: matvec + solve": (per_call["filter"], cost["band_matvec"] + cost["band_solve"]),
    }
    rows = [(comp, k, c, k * c) for comp, (k, c) in parts.items()]
    used = sum(r[3] for r in rows)
    rows.append(("other", float("nan"), float("nan"), per_step - used))
    rows.append(("whole step", 1.0, per_step, per_step))
    return [
        {
            "case": label,
            "nodes": n,
            "component": comp,
            "calls_per_step": round(k, 3),
            "us_per_call": round(1e6 * c, 3),
            "us_per_step": round(1e6 * t, 2),
            "pct_of_step": round(100 * t / per_step, 2),
            "newton_per_step": round(newton, 3),
        }
        for comp, k, c, t in rows
    ]


# ------------------------------------------------------------------ output
def plot(rows: list[dict]) -> None:
    """Stacked horizontal bars: the share of a step of each component, one bar per case.

    A negative "other" (kernels timed slower alone than within the step: noise) is drawn
    as zero and the bar then passes 100 %; the label gives its value."""
    cases = list(dict.fromkeys(r["case"] for r in rows))
    comps = list(dict.fromkeys(r["component"] for r in rows if r["component"] != "whole step"))
    colors = plt.get_cmap("tab20").colors
    fig, ax = plt.subplots(figsize=(10, 1.0 * len(cases) + 2.4))
    labels = []
    right = 100.0
    for y, case in enumerate(cases):
        mine = [r for r in rows if r["case"] == case]
        pct = {r["component"]: r["pct_of_step"] for r in mine}
        labels.append(f"{case}\n({mine[0]['nodes']} nodes, other {pct['other']:.0f} %)")
        left = 0.0
        for i, comp in enumerate(comps):
            w = max(pct.get(comp, 0.0), 0.0)
            color = colors[(2 * i) % 20 + (2 * i) // 20]
            ax.barh(y, w, left=left, color=color, label=comp if y == 0 else None)
            if w >= 4:
                ax.text(left + w / 2, y, f"{w:.0f}", ha="center", va="center", fontsize=8)
            left += w
        right = max(right, left)
    ax.axvline(100.0, color="k", lw=0.8)
    ax.set_yticks(range(len(cases)), labels, fontsize=9)
    ax.invert_yaxis()
    ax.set_xlabel("% of one implicit step (fixed 2 ms step, SDIRK2, modified Newton)")
    ax.set_xlim(0, right)
    ax.legend(ncol=4, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13))
    ax.set_title("Where the time of one implicit step goes")
    fig.tight_layout()
    path = RESULTS / "profile.png"
    fig.savefig(path, dpi=120)
    print("wrote", path)


def main() -> None:
    t0 = time.perf_counter()
    cases: list[tuple[str, Callable[[], Simulation], int]] = [
        ("sag N=100", lambda: _sagging(100), 50),
        ("sag N=1000", lambda: _sagging(1000), 50),
        ("sag N=10000", lambda: _sagging(10000), 20),
        ("default scene", _default_scene, 50),
    ]
    rows: list[dict] = []
    for label, make, steps in cases:
        base = make()
        base.advance(base.t + 10 * STEP_S)  # leave the start-up transient
        rows += profile(label, base, steps)
    print()
    print(f"{'case':>14} {'N':>6}  {'component':<24} {'calls/step':>10} {'us/step':>10} {'%':>6}")
    for r in rows:
        print(
            f"{r['case']:>14} {r['nodes']:>6}  {r['component']:<24} {r['calls_per_step']:>10.2f} "
            f"{r['us_per_step']:>10.1f} {r['pct_of_step']:>6.1f}"
        )
    print("wrote", write_csv("profile", rows))
    plot(rows)
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()

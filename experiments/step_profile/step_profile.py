"""Where the time of one implicit step goes: kernel costs composed into a per-step breakdown.

States: a horizontal clamped filament of N = 100, 1000, 10000 nodes sagging under its
net weight (as scaling.py), and the default scene (paper_simulation) at t = 1.8 s
(as effects.py), all at a fixed 2 ms step after a 20 ms warm-up; and the coil of
``period_doubling_22G`` piling onto itself at t = 0.8 s, with and without its ``contact``,
in adaptive steps (as the scene runs). On each state:

(1) the whole step: an ``advance`` over a window of simulated time on identical copies
    of the state, divided by the accepted steps (and by the Newton iterations, from the
    counters);
(2) the kernels, called directly on the records of a copy of the simulation (the ``Rod``,
    ``Stage`` and ``Out`` the integrator builds) from a numba loop (no Python call
    overhead, best of several repeats, per call): each effect's ``accumulate`` alone with
    the Jacobian, ``assemble``'s own clearing of force and band, ``assemble`` without the
    Jacobian, ``assemble`` as the filtered error norm calls it (Jacobian with cx = 0, which
    elasticity skips, into the second band), and the linear algebra of
    :mod:`bathprint.core.solver`: ``factor`` (banded LU), ``solve`` (one banded
    back-substitution, or with couplings off the band one GMRES solve, divided by its
    iterations: the cost of a Krylov iteration), ``damping_times`` (the filter's banded
    product), ``set_boundary``, and with contact its ``prepare`` (start of a step, the pair
    list kept), what finding the pairs anew adds to it (the spatial hash, at births and
    when the skin is used up: "contact: rebuild") and ``check`` (end of a step); (1) and
    (2) alternate over 5 rounds and keep their best;
(3) how often each kernel runs per step. A fresh copy replays the same window through the
    integrator's own Python source (numba's ``py_func`` of ``advance``, ``_attempt``,
    ``_implicit_step``, ``_stage_solve``, ``_stage_rates``, ``_filtered_norm``,
    ``explicit_step``, ``_accept``, ``_reject`` and ``_proposed_step``) with counting
    wrappers around ``assemble``, ``set_boundary``, ``solver.factor`` / ``solve`` /
    ``damping_times`` and
    ``contact.prepare`` / ``check`` (the record builders ``active_rod`` and ``_out`` run as
    Python too: Python must never hold arrays from a kernel compiled without reference
    counting); the structured records (parameters,
    solver memory, frozen tail, contact memory) are passed as ``np.recarray`` views, which
    numba types as the plain arrays, so the Python source reads their fields by name. Its
    Newton iterations and factorisations are checked against the timed run's counters, and
    its GMRES (Krylov) iterations per step are reported (zero without couplings off the
    band), each at the cost per iteration of (2).

Per step, component = (calls per step) x (cost per call); "other" (vector updates, error
norms, checks, extrusion and gelation bookkeeping) is the whole step minus the parts.
The headline is the share of a step (%): absolute times are noisy on a shared machine.

    python experiments/step_profile/step_profile.py                       # every case
    python experiments/step_profile/step_profile.py --cases "pile, contact" --out profile_pile
"""

from __future__ import annotations

import argparse
import copy
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType, SimpleNamespace

import matplotlib
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, SHARP_CONTACT, best_of, sagging_filament, write_csv  # noqa: E402
from numba import njit  # noqa: E402

import bathprint.core.integrators as integ
from bathprint import Simulation
from bathprint.core import layout as L
from bathprint.core import solver
from bathprint.core.assemble import assemble
from bathprint.core.effects import contact, drag, elasticity, end_load, floor, gravity, inertia
from bathprint.core.extrusion import set_boundary
from bathprint.core.freezing import accumulate_tail
from bathprint.core.records import Stage
from bathprint.core.topology import free_nodes

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

STEP_S = 2e-3
PILE_SCENE = "period_doubling_22G"  # a coil piling onto itself (a pile of about 25 turns)
PILE_T_S = 0.8  # ... profiled from here (adaptive steps), where contact costs most
PILE_WINDOW_S = 0.05
ROUNDS = 5  # rounds of (whole step, kernels)
EFFECTS: dict[int, ModuleType] = {
    L.E_ELASTICITY: elasticity,
    L.E_DRAG: drag,
    L.E_GRAVITY: gravity,
    L.E_FLOOR: floor,
    L.E_INERTIA: inertia,
    L.E_END_LOAD: end_load,
    L.E_CONTACT: contact,
}
# what the replay counts: calls of assemble (split by stage), the solver and set_boundary
COUNTED = (
    "assemble+J",
    "assemble, no J",
    "filter",
    "factor",
    "solve",
    "damping_times",
    "set_boundary",
    "contact: prepare",
    "contact: rebuild",
    "contact: check",
)
# integrator functions replayed from their Python source so the counted kernels are seen
REPLAYED = (
    "active_rod",  # record builders: their compiled forms must not hand arrays to Python
    "_out",
    "_attempt",
    "_implicit_step",
    "_stage_solve",
    "_stage_rates",
    "_filtered_norm",
    "explicit_step",
    "_accept",
    "_reject",
    "_proposed_step",
)
KRYLOV = "krylov iterations"  # a line of the breakdown: GMRES iterations (off-band scenes)


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
    """A numba loop calling one effect's ``accumulate(model, rod, stage, out)`` ``reps``
    times."""

    @njit
    def run(reps, model, rod, stage, out):
        e = 0.0
        for _ in range(reps):
            e += fn(model, rod, stage, out)
        return e

    return run


@njit
def _assemble_loop(reps, model, rod, stage, out, calls, energies):
    for _ in range(reps):
        assemble(model, rod, stage, out, calls, energies)


@njit
def _lu_loop(reps, ws, saved, nd, factor):
    """Restore the band from ``saved`` and (if ``factor``) factorise it, ``reps`` times."""
    band = ws.band
    for _ in range(reps):
        band[:nd] = saved[:nd]
        if factor:
            solver.factor(ws, nd)


@njit
def _solve_loop(reps, ws, nd, b, saved, counters, rtol, solve):
    """Restore the right-hand side and (if ``solve``) solve with the factors, ``reps`` times."""
    for _ in range(reps):
        b[:nd] = saved[:nd]
        if solve:
            solver.solve(ws, nd, b, counters, rtol)


@njit
def _damping_loop(reps, ws, nd, x, y):
    for _ in range(reps):
        solver.damping_times(ws, nd, x, y)


@njit
def _prepare_loop(reps, model, whole, frozen, contact_ws, rebuild):
    """``contact.prepare`` ``reps`` times, each (if ``rebuild``) finding the pairs anew."""
    for _ in range(reps):
        if rebuild:
            contact_ws.memory[0].built_nodes = -1
        contact.prepare(model, whole, frozen, contact_ws)


@njit
def _check_loop(reps, model, whole, pos0, frozen, contact_ws):
    for _ in range(reps):
        contact.check(model, whole, pos0, frozen, contact_ws)


@njit
def _boundary_loop(reps, model, rod, t, scratch):
    for _ in range(reps):
        set_boundary(model, rod, t, scratch)


_LOOPS = {k: _effect_loop(mod.accumulate) for k, mod in EFFECTS.items()}
_TAIL_LOOP = _effect_loop(accumulate_tail)


def _per_call(loop: Callable, reps: int, *args: object, repeats: int = 3) -> float:
    """Seconds per kernel call: best of ``repeats`` numba loops of ``reps`` calls."""
    loop(1, *args)  # compile and warm the caches
    return best_of(lambda: loop(reps, *args), repeats) / reps


def _gamma(integrator: int) -> float:
    """The SDIRK diagonal coefficient: h gamma is the stage's implicit step."""
    if integrator == L.INTEGRATOR_IMPLICIT_EULER:
        return 1.0
    if integrator == L.INTEGRATOR_SDIRK4:
        return float(integ.SDIRK4_A[0, 0])
    return integ.GAMMA


def _python_records(builder: Callable, *args: object) -> object:
    """The record an integrator function (``active_rod``, ``_out``) builds, built by its Python
    source: plain NumPy views. The compiled functions run without reference counting and must
    not hand arrays to Python (bathprint.core.jit)."""
    real = integ.active_rod
    integ.active_rod = real.py_func  # _out builds the whole rod through it
    try:
        return builder.py_func(*args)
    finally:
        integ.active_rod = real


def kernel_costs(sim: Simulation) -> dict[str, float]:
    """Seconds per call of every kernel of a step, on the records of a copy of ``sim``."""
    s = copy.deepcopy(sim)
    m = s.model
    model, p = m.record, m.p
    state, ws = s.state, s.ws
    rod = _python_records(integ.active_rod, state, ws, s.n_frozen)  # views of the copy's arrays
    n = rod.n_nodes
    nd = 3 * free_nodes(n, p)
    reps = max(5, 100_000 // n)
    h = STEP_S if float(p.fixed_step) > 0 else float(s.state.clock[1])  # the next step
    hg = h * _gamma(m.integrator)
    ca = 1.0 / hg**2 if p.inertial else 0.0
    jac = Stage(s.t, 1.0, 1.0 / hg, ca, True)
    no_jac = jac._replace(jac=False)
    # the filtered error norm assembles with cx = 0 (no stiffness: elasticity skips its
    # Jacobian there) into the second band, dropping couplings off the band
    filt = jac._replace(cx=0.0)
    out = _python_records(integ._out, state, ws, ws.band, ws.cpl)
    out_filter = _python_records(integ._out, state, ws, ws.band2, ws.cpl_drop)
    calls = np.zeros_like(s.calls)
    energies = np.zeros_like(s.energies)
    res: dict[str, float] = {}
    for k in np.flatnonzero(m.enabled):
        if int(k) in _LOOPS:
            res[f"assemble+J: {L.EFFECT_NAMES[k]}"] = _per_call(
                _LOOPS[int(k)], reps, model, rod, jac, out
            )
    if ws.tail[0]["on"]:
        res["assemble+J: frozen tail"] = _per_call(_TAIL_LOOP, reps, model, rod, jac, out)
    tail_off = ws.tail.copy()
    tail_off[0]["on"] = False
    no_effects = model._replace(enabled=np.zeros_like(m.enabled))
    res["assemble+J: clear"] = _per_call(
        _assemble_loop, reps, no_effects, rod, jac, out._replace(tail=tail_off), calls, energies
    )
    res["assemble+J (whole)"] = _per_call(
        _assemble_loop, reps, model, rod, jac, out, calls, energies
    )
    res["assemble, no J"] = _per_call(
        _assemble_loop, reps, model, rod, no_jac, out, calls, energies
    )
    res["filter: assemble (cx=0)"] = _per_call(
        _assemble_loop, reps, model, rod, filt, out_filter, calls, energies
    )
    # the stage matrix of a Newton iteration, its factors, and a right-hand side
    assemble(model, rod, jac, out, calls, energies)
    saved_band = ws.band.copy()
    lu_and_copy = _per_call(_lu_loop, reps, ws, saved_band, nd, True)
    res["factor"] = lu_and_copy - _per_call(_lu_loop, reps, ws, saved_band, nd, False)
    _lu_loop(1, ws, saved_band, nd, True)
    rhs, saved_rhs = out.force.copy(), out.force.copy()
    counters = np.zeros_like(s.counters)
    rtol = float(p.krylov_tolerance)
    solve_and_copy = _per_call(_solve_loop, reps, ws, nd, rhs, saved_rhs, counters, rtol, True)
    res["solve"] = solve_and_copy - _per_call(
        _solve_loop, reps, ws, nd, rhs, saved_rhs, counters, rtol, False
    )
    # band2 holds the filter's damping matrix (assembled above)
    res["damping_times"] = _per_call(_damping_loop, reps, ws, nd, rod.vel.copy(), rhs)
    if s.off_band:  # the solve is GMRES: its cost per iteration (one solve's iterations)
        counters[:] = 0
        rhs[:nd] = saved_rhs[:nd]
        solver.solve(ws, nd, rhs, counters, rtol)
        res["krylov iteration"] = res["solve"] / max(int(counters[L.C_KRYLOV_ITERATIONS]), 1)
    if m.enabled[L.E_CONTACT]:
        # at the step's start (a list built, no rebuild in the loop) and at its end
        whole = _python_records(integ.active_rod, state, ws, 0)
        frozen = s.n_frozen
        pos0 = ws.vecs[integ.V_POS0]
        pos0[: 3 * n] = rod.pos[: 3 * n]
        res["contact: prepare"] = _per_call(
            _prepare_loop, reps, model, whole, frozen, ws.contact, False
        )
        res["contact: rebuild"] = (  # what finding the pairs adds to a prepare
            _per_call(_prepare_loop, reps, model, whole, frozen, ws.contact, True)
            - res["contact: prepare"]
        )
        res["contact: check"] = _per_call(_check_loop, reps, model, whole, pos0, frozen, ws.contact)
    res["set_boundary"] = _per_call(_boundary_loop, reps, model, rod, s.t, ws.scratch)
    return res


# ------------------------------------------------------------------ whole step and counts
def step_time(base: Simulation, window_s: float, copies: int) -> tuple[float, Simulation]:
    """Best wall time per accepted step of ``window_s`` of simulated time over identical
    copies of ``base`` (fixed or adaptive steps); returns it and one of the advanced copies."""
    sims = [copy.deepcopy(base) for _ in range(copies)]
    it = iter(sims)

    def run() -> None:
        s = next(it)
        s.advance(s.t + window_s)

    wall = best_of(run, copies)
    return wall / (sims[0].counts()["steps"] - base.counts()["steps"]), sims[0]


def _named(records: np.ndarray) -> np.ndarray:
    """A structured record array as ``np.recarray`` (fields as attributes, same memory);
    numba types it as the plain array, so compiled kernels take it unchanged."""
    return records.view(np.recarray)


def replay_records(sim: Simulation) -> tuple[object, object]:
    """(model, a function returning the workspace) of ``sim`` for kernels replayed from their
    Python source: the parameter, solver, tail and contact-memory records as ``np.recarray``
    (Python reads their fields by attribute; the same memory as the simulation's)."""
    model = sim.model.record._replace(params=_named(sim.model.params))

    def named_ws() -> object:
        ws = sim.ws
        return ws._replace(
            solver=_named(ws.solver),
            tail=_named(ws.tail),
            contact=ws.contact._replace(memory=_named(ws.contact.memory)),
        )

    return model, named_ws


def replay_counts(sim: Simulation, window_s: float) -> tuple[dict[str, float], dict[str, int]]:
    """Kernel calls per step over ``window_s``, replaying ``advance`` from its Python source.

    Returns the calls per step (assemble split into Newton with and without the Jacobian
    and the filtered error norm's) and the simulation's counter deltas over the replay."""
    calls = dict.fromkeys(COUNTED, 0)
    real_assemble, real_boundary, real_solver = integ.assemble, integ.set_boundary, integ.solver
    real_contact = integ.contact
    real_replayed = {name: getattr(integ, name) for name in REPLAYED}

    def counting_assemble(model, rod, stage, out, c, e) -> None:
        # do_jac, and cx = 0 for the filtered error norm
        key = ("filter" if stage.cx == 0.0 else "assemble+J") if stage.jac else "assemble, no J"
        calls[key] += 1
        real_assemble(model, rod, stage, out, c, e)

    def counting(name: str, fn: Callable) -> Callable:
        def wrapper(*args: object) -> object:
            calls[name] += 1
            return fn(*args)

        return wrapper

    counting_solver = SimpleNamespace(
        **{name: counting(name, getattr(solver, name)) for name in COUNTED[3:6]}
    )
    counting_contact = SimpleNamespace(
        **{name: getattr(contact, name) for name in ("step_limit", "accepted")},
        prepare=counting("contact: prepare", contact.prepare),
        check=counting("contact: check", contact.check),
    )
    model, named_ws = replay_records(sim)
    before = sim.counts()
    builds = int(sim.ws.contact.memory[0]["builds"])
    t_end = sim.t + window_s
    try:
        integ.assemble = counting_assemble
        integ.set_boundary = counting("set_boundary", real_boundary)
        integ.solver = counting_solver
        integ.contact = counting_contact
        for name, fn in real_replayed.items():
            setattr(integ, name, fn.py_func)
        while True:
            status = integ.advance.py_func(model, sim.state, named_ws(), t_end, 10**9)
            if status != L.STATUS_CAPACITY:
                break
            # full arrays: grow them as Simulation.advance does, and go on
            sim.make_room()
    finally:
        integ.assemble, integ.set_boundary, integ.solver = (
            real_assemble,
            real_boundary,
            real_solver,
        )
        integ.contact = real_contact
        for name, fn in real_replayed.items():
            setattr(integ, name, fn)
    if status != L.STATUS_OK:
        raise RuntimeError(f"replay stopped with status {status} ({L.STATUS_MESSAGES[status]})")
    after = sim.counts()
    done = after["steps"] - before["steps"]
    calls["contact: rebuild"] = int(sim.ws.contact.memory[0]["builds"]) - builds
    return {k: v / done for k, v in calls.items()}, {k: after[k] - before[k] for k in after}


# ------------------------------------------------------------------ one case
def profile(label: str, base: Simulation, window_s: float) -> list[dict]:
    """Breakdown of a step of ``base``'s scene over ``window_s`` of simulated time (``base``
    is only copied, never advanced)."""
    # alternate whole steps and kernels so a burst of load on the shared machine is less
    # likely to hit one and not the other; keep the best of every number over the rounds
    per_step = float("inf")
    cost: dict[str, float] = {}
    for _ in range(ROUNDS):
        t_step, sim = step_time(base, window_s, 2)
        per_step = min(per_step, t_step)
        for k, v in kernel_costs(sim).items():
            cost[k] = min(cost.get(k, v), v)
    per_call, counted = replay_counts(copy.deepcopy(base), window_s)
    timed = {k: sim.counts()[k] - base.counts()[k] for k in counted}
    for key in ("newton_iterations", "jacobians", "krylov_iterations"):
        if timed[key] != counted[key]:
            print(f"  note: replay {counted[key]} {key}, timed {timed[key]}")
    if counted["jacobians"] != round(per_call["factor"] * counted["steps"]):
        print(f"  note: {counted['jacobians']} jacobians counted, factor called otherwise")
    newton = counted["newton_iterations"] / counted["steps"]
    krylov = counted["krylov_iterations"] / counted["steps"]
    n = base.n_nodes
    print(
        f"{label}: N={n}, {1e6 * per_step:.0f} us/step, {newton:.2f} Newton iterations/step "
        f"({1e6 * per_step / newton:.0f} us each); per step: {per_call['factor']:.2f} LU, "
        f"{per_call['filter']:.2f} filtered norm, "
        f"{per_call['assemble+J']:.2f} assemble+J, {per_call['assemble, no J']:.2f} assemble "
        f"no J, {per_call['solve']:.2f} solves, {per_call['damping_times']:.2f} "
        f"damping_times, {per_call['set_boundary']:.2f} set_boundary, "
        f"{counted['nodes_born'] / counted['steps']:.2f} splits, {krylov:.2f} Krylov iterations"
    )
    parts_sum = sum(v for k, v in cost.items() if k.startswith("assemble+J:"))
    print(
        f"  check: assemble+J whole {1e6 * cost['assemble+J (whole)']:.1f} us/call, "
        f"effects + clear {1e6 * parts_sum:.1f} us/call"
    )
    # component: (calls per step, seconds per call)
    newton_solves = per_call["solve"] - per_call["filter"]  # the filter solves once
    parts = {k: (per_call["assemble+J"], v) for k, v in cost.items() if k.startswith("assemble+J:")}
    parts |= {
        "assemble, no J": (per_call["assemble, no J"], cost["assemble, no J"]),
        "factor (band LU)": (per_call["factor"], cost["factor"]),
        "solve (Newton)": (0.0 if krylov > 0 else newton_solves, cost["solve"]),
        "set_boundary": (per_call["set_boundary"], cost["set_boundary"]),
        "filter: assemble (cx=0)": (per_call["filter"], cost["filter: assemble (cx=0)"]),
        "filter: damping_times + solve": (
            per_call["damping_times"],
            cost["damping_times"] + (0.0 if krylov > 0 else cost["solve"]),
        ),
    }
    if "contact: prepare" in cost:
        for key in ("contact: prepare", "contact: rebuild", "contact: check"):
            parts[key] = (per_call[key], cost[key])
    rows = [(comp, k, c, k * c) for comp, (k, c) in parts.items()]
    used = sum(r[3] for r in rows)
    # with couplings off the band every solve (Newton's and the filter's) is GMRES: its
    # iterations, each at the cost per iteration of one timed solve
    c_krylov = cost.get("krylov iteration", 0.0)
    rows.append((KRYLOV, krylov, c_krylov, krylov * c_krylov))
    used += krylov * c_krylov
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
def plot(rows: list[dict], name: str = "profile") -> None:
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
    ax.set_xlabel("% of one implicit step (SDIRK2, modified Newton; 2 ms steps, the pile adaptive)")
    ax.set_xlim(0, right)
    ax.legend(ncol=4, fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.13))
    ax.set_title("Where the time of one implicit step goes")
    fig.tight_layout()
    path = RESULTS / f"{name}.png"
    fig.savefig(path, dpi=120)
    print("wrote", path)


def _pile(contact_on: bool) -> Callable[[], Simulation]:
    """``PILE_SCENE`` at ``PILE_T_S`` (adaptive steps), with or without its ``contact``."""

    def make() -> Simulation:
        over: dict = {"outputs.plot": False, **SHARP_CONTACT}  # the law it was measured with
        if not contact_on:
            over["effects"] = [e for e in Simulation(PILE_SCENE).scene.effects if e != "contact"]
        sim = Simulation(PILE_SCENE, over)
        sim.advance(PILE_T_S)
        return sim

    return make


CASES: dict[str, tuple[Callable[[], Simulation], float]] = {
    # label: (the state, the window of simulated time (s) the step is averaged over)
    "sag N=100": (lambda: _sagging(100), 50 * STEP_S),
    "sag N=1000": (lambda: _sagging(1000), 50 * STEP_S),
    "sag N=10000": (lambda: _sagging(10000), 20 * STEP_S),
    "default scene": (_default_scene, 50 * STEP_S),
    "pile, no contact": (_pile(False), PILE_WINDOW_S),
    "pile, contact": (_pile(True), PILE_WINDOW_S),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", choices=list(CASES), default=list(CASES))
    ap.add_argument("--out", default="profile", help="result name (results/NAME.csv)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    rows: list[dict] = []
    for label in args.cases:
        make, window_s = CASES[label]
        base = make()
        if float(base.model.p.fixed_step) > 0:
            base.advance(base.t + 10 * STEP_S)  # leave the start-up transient
        rows += profile(label, base, window_s)
    print()
    print(f"{'case':>14} {'N':>6}  {'component':<24} {'calls/step':>10} {'us/step':>10} {'%':>6}")
    for r in rows:
        print(
            f"{r['case']:>14} {r['nodes']:>6}  {r['component']:<24} {r['calls_per_step']:>10.2f} "
            f"{r['us_per_step']:>10.1f} {r['pct_of_step']:>6.1f}"
        )
    print("wrote", write_csv(args.out, rows))
    plot(rows, args.out)
    print(f"total {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()

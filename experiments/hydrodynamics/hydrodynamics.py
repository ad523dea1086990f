"""What hydrodynamics costs, and how accurate each coupling is for its cost.

    python experiments/hydrodynamics/hydrodynamics.py eval      # one nonlocal evaluation vs N
    python experiments/hydrodynamics/hydrodynamics.py step      # one step vs N, both couplings
    python experiments/hydrodynamics/hydrodynamics.py coiling  # drag_coiling_22G, 6 s, each drag
    python experiments/hydrodynamics/hydrodynamics.py workprec  # error vs step and vs wall time
    python experiments/hydrodynamics/hydrodynamics.py all_effects  # the ablation's "all" on a pile
    python experiments/hydrodynamics/hydrodynamics.py mobility  # I + R M W^-1 on that pile
    python experiments/hydrodynamics/hydrodynamics.py failing_solve  # the first failed GMRES solve
    python experiments/hydrodynamics/hydrodynamics.py kernels   # Stokeslet segments vs RPY blobs
    python experiments/hydrodynamics/hydrodynamics.py kernel_coils  # the coil each kernel gives
    python experiments/hydrodynamics/hydrodynamics.py all

(1) eval: the nonlocal flow of a coil (node spacing 0.5 mm, radius 1.5 mm, pitch 0.9 mm,
r = 0.2 mm, a = 0.6 mm) of N nodes, by the direct numba sum and by fmm3dpy (precision 1e-3
and 1e-6); direct sums beyond ``--max-direct`` are extrapolated as (ns per pair) x N^2 and
flagged; the crossover is the smallest N where the FMM is faster. (2) step: a bent free
filament of N segments relaxing with hydrodynamics at a fixed step, wall time per step and
evaluations per step for each coupling; larger N extrapolated from the evaluations per step
and (1). (3) coiling: drag_coiling_22G for 6 s with drag cox, constant and finite_re, and
with hydrodynamics (both couplings with cox, the lagged one with finite_re): wall time,
steps, evaluations, nodes, the coil's radius and pitch (analysis.measure), and the ratio
to the local-drag run. (4) workprec: the error of
lagging against the step size (fixed steps), and error against wall time for both couplings
at adaptive tolerances (the relaxing filament and drag_coiling_22G for 0.5 s, against a
reference at tolerance 1e-9 with the implicit coupling). (5) all_effects: the ablation's
"all" run at d = 0.41 mm, 0.5 ml/min (Fig. 2's set: inertia, contact with its dashpot, the
nonlocal flow of the RPY kernel inside Newton, finite-Re drag, surface gelation, viscosity;
its turns pile up) for its planned 5.2 s, as planned and with one thing changed at a time
(:func:`all_effects_variants`); how far each gets, its steps, Newton and Krylov iterations
and wall time. (6) mobility: on some of those, at MOBILITY_TIMES_S, the eigenvalues of
I + R M_nl W^-1 (the operator the implicit flow adds to the Newton matrix, which the mass
term multiplies at small steps; dense, from its matrix-free product) and the smallest gap
between turns. (7) failing_solve: the Stokeslet segments' runs at their first failed GMRES
solve. (8) kernels: a cylinder's drag, pressed turns' mobility and one evaluation's cost
with each kernel. (9) kernel_coils: the ablation's contact + finite-Re + nonlocal runs at
d = 0.41 mm, 0.5 and 1 ml/min (no inertia: the segments run there) with each kernel, the
coil each measures.
Results: results/hydro_*.csv.
Single-threaded numba; the machine is shared, so wall times carry ~30% noise.
"""

from __future__ import annotations

import argparse
import csv
import math
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, best_of, experiment, write_csv  # noqa: E402

from bathprint import Simulation, SimulationError, simulate
from bathprint.analysis import validation as V
from bathprint.analysis.measure import coil_pitch, coil_radius, min_gap_ratio
from bathprint.analysis.validation import mobility_operator
from bathprint.core import layout as L
from bathprint.core.effects import _rpy, _stokeslet
from bathprint.studies.reproduce import ablation

MU = 1e-3
A_CUT = 0.6e-3


def coil(n: int, h: float = 0.5e-3) -> tuple[np.ndarray, np.ndarray]:
    radius, pitch = 1.5e-3, 0.9e-3
    c = math.sqrt(radius**2 + (pitch / (2 * math.pi)) ** 2)
    th = h * np.arange(n) / c
    x = np.stack([radius * np.cos(th), radius * np.sin(th), pitch * th / (2 * math.pi)], 1)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(x, axis=0), axis=1))])
    return x.ravel().copy(), s


def _fmm_available() -> bool:
    try:
        import fmm3dpy  # noqa: F401
    except ImportError:
        return False
    return True


def evaluation_costs(max_direct: int, max_fmm: int) -> list[dict]:
    rng = np.random.default_rng(0)
    sizes = [100, 300, 1_000, 3_000, 10_000, 30_000, 100_000]
    pos, s = coil(50)
    _stokeslet.nonlocal_flow(
        pos,
        s,
        50,
        pos,
        s,
        49,
        np.ones(147),
        np.full(50, np.inf),
        MU,
        0.0,
        A_CUT,
        0.0,
        np.zeros(150),
    )
    rows = []
    per_pair = None
    direct: dict[int, float] = {}
    for n in sizes:
        pos, s = coil(n)
        f = rng.normal(size=3 * (n - 1))
        out = np.zeros(3 * n)
        screen = np.full(n, np.inf)
        if n <= max_direct:

            def call(pos=pos, s=s, n=n, f=f, screen=screen, out=out) -> None:
                _stokeslet.nonlocal_flow(
                    pos, s, n, pos, s, n - 1, f, screen, MU, 0.0, A_CUT, 0.0, out
                )

            t = best_of(call, 3 if n < 10_000 else 1)
            per_pair = t / n**2
            direct[n] = t
            rows.append(
                {"N": n, "method": "direct", "precision": "", "wall_s": t, "extrapolated": False}
            )
        else:
            rows.append(
                {
                    "N": n,
                    "method": "direct",
                    "precision": "",
                    "wall_s": per_pair * n**2,
                    "extrapolated": True,
                }
            )
        print(
            f"direct N = {n:>6}: {rows[-1]['wall_s']:.3e} s"
            + (" (extrapolated)" if rows[-1]["extrapolated"] else ""),
            flush=True,
        )
        if not _fmm_available() or n < 1_000 or n > max_fmm:
            continue
        for prec in (1e-3, 1e-6):
            ref = np.zeros(3 * n)
            _stokeslet.fmm_flow(pos, s, n, n - 1, f, MU, 0.0, A_CUT, prec, ref)  # warm-up

            def fcall(pos=pos, s=s, n=n, f=f, prec=prec, out=out) -> None:
                _stokeslet.fmm_flow(pos, s, n, n - 1, f, MU, 0.0, A_CUT, prec, out)

            t = best_of(fcall, 2 if n < 30_000 else 1)
            diff = ""
            if n in direct:
                _stokeslet.nonlocal_flow(
                    pos, s, n, pos, s, n - 1, f, screen, MU, 0.0, A_CUT, 0.0, ref
                )
                diff = float(np.max(np.abs(out - ref)) / np.max(np.abs(ref)))
            rows.append(
                {
                    "N": n,
                    "method": "fmm",
                    "precision": prec,
                    "wall_s": t,
                    "extrapolated": False,
                    "max_rel_diff_vs_direct": diff,
                }
            )
            print(f"   fmm {prec:g}: {t:.3e} s  (max rel. diff. vs direct {diff})", flush=True)
    for r in rows:
        r.setdefault("max_rel_diff_vs_direct", "")
    for prec in (1e-3, 1e-6):
        cross = [
            r["N"]
            for r in rows
            if r["method"] == "fmm"
            and r["precision"] == prec
            and r["wall_s"]
            < next(d["wall_s"] for d in rows if d["method"] == "direct" and d["N"] == r["N"])
        ]
        print(f"crossover (precision {prec:g}): FMM faster from N = {min(cross) if cross else '-'}")
    return rows


def _relaxing(n_segments: int, coupling: str, fmm_nodes: int = 0, **extra) -> Simulation:
    """A bent free filament with hydrodynamics (V.hydro_fixed_step_errors' problem), N
    segments at 0.3 mm."""
    length_mm = 0.3 * n_segments
    return Simulation(
        "paper_simulation",
        {
            "effects": ["elasticity", "drag", "hydrodynamics"],
            "needle.inner_diameter_mm": 0.4,
            "needle.direction": [1.0, 0.0, 0.0],
            "needle.imperfection_um": 0.0,
            "needle.release_s": 1e-12,
            "initial.length_mm": length_mm,
            "initial.perturbation_mm": 0.05 * length_mm,
            "flow.q_outer_ml_min": 0.0,
            "material.youngs_modulus_pa": 5e4,
            "numerics.node_spacing_mm": 0.3,
            "numerics.time_step_s": 1e-4,
            "hydrodynamics.coupling": coupling,
            "hydrodynamics.fmm_min_nodes": fmm_nodes,
            "duration_s": 10.0,
            **extra,
        },
    )


def step_costs(max_n: int, fmm_n: int) -> list[dict]:
    rows = []
    for coupling in ("lagged", "implicit"):
        _relaxing(20, coupling).advance(2e-4)  # compile
        for n in (100, 300, 1_000, 3_000):
            if n > max_n:
                break
            sim = _relaxing(n, coupling)
            sim.advance(1e-4)  # the first step (lagged: the flow at the start is evaluated)
            e0 = sim.counts()["hydro_evaluations"]
            steps = 3 if n >= 1_000 else 10
            t0 = time.perf_counter()
            sim.advance((1 + steps) * 1e-4)
            wall = (time.perf_counter() - t0) / steps
            evals = (sim.counts()["hydro_evaluations"] - e0) / steps
            rows.append(
                {
                    "N": n,
                    "coupling": coupling,
                    "method": "direct",
                    "wall_per_step_s": wall,
                    "evaluations_per_step": evals,
                    "extrapolated": False,
                }
            )
            print(
                f"{coupling:>8} N = {n:>5}: {wall:.3e} s per step, {evals:.1f} evaluations",
                flush=True,
            )
    if _fmm_available():
        for n in (1_000, 3_000, 10_000):
            if n > fmm_n:
                break
            sim = _relaxing(n, "lagged", fmm_nodes=1, **{"hydrodynamics.fmm_precision": 1e-3})
            sim.advance(1e-4)
            e0 = sim.counts()["hydro_evaluations"]
            t0 = time.perf_counter()
            sim.advance(3e-4)
            wall = (time.perf_counter() - t0) / 2
            evals = (sim.counts()["hydro_evaluations"] - e0) / 2
            rows.append(
                {
                    "N": n,
                    "coupling": "lagged",
                    "method": "fmm 1e-3",
                    "wall_per_step_s": wall,
                    "evaluations_per_step": evals,
                    "extrapolated": False,
                }
            )
            print(
                f"  lagged fmm N = {n:>5}: {wall:.3e} s per step, {evals:.1f} evaluations",
                flush=True,
            )
    return rows


COILING_VARIANTS = {
    "cox (local)": {},
    "constant (local)": {"drag.model": "constant"},
    "finite_re (local)": {"drag.model": "finite_re"},
    "cox + hydrodynamics, lagged": {"hydrodynamics.coupling": "lagged"},
    "finite_re + hydrodynamics, lagged": {
        "drag.model": "finite_re",
        "hydrodynamics.coupling": "lagged",
    },
    "cox + hydrodynamics, implicit": {"hydrodynamics.coupling": "implicit"},
}


COILING_STEP_CHUNK = 200  # steps between the wall-time cap's checks (the run is the same)


def coiling_costs(
    duration: float, only: list[str] | None, max_wall_s: float = math.inf
) -> list[dict]:
    """drag_coiling_22G for ``duration`` with each variant of COILING_VARIANTS (those whose
    label contains one of ``only``, and local Cox drag, the base of the ratios): wall time,
    counts and the coil. A variant that takes longer than ``max_wall_s`` stops there, its
    row saying where (advanced by step budgets, so the steps are those of one call)."""
    rows = []
    base = None
    previous = {}
    path = RESULTS / "hydro_coiling.csv"
    if only and path.exists():  # a partial rerun replaces its variants' rows, keeps the rest
        with path.open() as f:
            previous = {r["variant"]: r for r in csv.DictReader(f)}
    for label, extra in COILING_VARIANTS.items():
        if only and label != "cox (local)" and not any(o in label for o in only):
            continue  # (the local-drag run is the base of the ratios: always run)
        # every variant without contact (the slender-body kernel's mobility is indefinite on
        # touching turns), the local ones as the nonlocal ones
        over = {"effects": ["elasticity", "drag", "gravity"], **extra}
        if "hydrodynamics" in label:
            over["effects"] = [*over["effects"], "hydrodynamics"]
        Simulation("drag_coiling_22G", {**over, "duration_s": 0.02}).advance(0.02)  # compile
        sim = Simulation("drag_coiling_22G", {**over, "duration_s": duration})
        t0 = time.perf_counter()
        status = "ok"
        try:
            while sim.t < duration:
                sim.advance(duration, max_steps=COILING_STEP_CHUNK)
                if sim.t < duration and time.perf_counter() - t0 > max_wall_s:
                    status = f"stopped by the {max_wall_s:g} s wall cap at t = {sim.t:.3g} s"
                    break
        except Exception as exc:  # a failed run is a result too
            status = f"{type(exc).__name__}: {exc}"[:200]
        wall = time.perf_counter() - t0
        base = base if base is not None else wall
        c = sim.counts()
        x = sim.centerline()
        tip, axis = sim.model.needle[0, 1:4], sim.model.needle[0, 4:7]
        radius = coil_radius(x, tip, axis)
        pitch = coil_pitch(x, tip, axis)[0]
        rows.append(
            {
                "variant": label,
                "simulated_s": sim.t,
                "wall_s": wall,
                "ratio_to_cox": wall / base,
                "steps": c["steps"],
                "rejected": c["rejected_steps"],
                "newton": c["newton_iterations"],
                "krylov": c["krylov_iterations"],
                "evaluations": c["hydro_evaluations"],
                "nodes": sim.n_nodes,
                "coil_radius_mm": 1e3 * radius if radius else "",
                "coil_pitch_mm": 1e3 * pitch if pitch else "",
                "status": status,
            }
        )
        print(rows[-1], flush=True)
        done = {r["variant"] for r in rows}
        kept = [r for v, r in previous.items() if v not in done]
        write_csv("hydro_coiling", kept + rows)  # (each run is long: keep what is done)
    done = {r["variant"] for r in rows}
    return [r for v, r in previous.items() if v not in done] + rows


def work_precision() -> tuple[list[dict], list[dict]]:
    fixed = []
    factors = (2.0, 1.0, 0.5, 0.25, 0.125)
    errs = V.hydro_fixed_step_errors(factors)
    for coupling, values in errs.items():
        for f, e in zip(factors, values, strict=True):
            fixed.append({"coupling": coupling, "step_over_T": f / 20.0, "max_error_m": e})
            print(f"fixed step {f / 20:.4f} T, {coupling:>8}: error {e:.3e} m", flush=True)
    adaptive = []
    problems = {
        "relaxing filament": (lambda extra: _relaxing(30, extra.pop("coupling"), **extra), 1e-3),
        "drag_coiling_22G 0.5 s": (
            lambda extra: Simulation(
                "drag_coiling_22G",
                {
                    "effects": ["elasticity", "drag", "gravity", "hydrodynamics"],
                    "hydrodynamics.coupling": extra.pop("coupling"),
                    "duration_s": 0.5,
                    **extra,
                },
            ),
            0.5,
        ),
    }
    for name, (make, t_end) in problems.items():

        def run(coupling: str, tol: float, make=make, t_end=t_end):
            extra = {"coupling": coupling, "numerics.tolerance": tol, "numerics.time_step_s": 0.0}
            sim = make(extra)
            t0 = time.perf_counter()
            sim.advance(t_end)
            wall = time.perf_counter() - t0
            return sim, wall

        run("implicit", 1e-3)  # compile
        run("lagged", 1e-3)
        ref, _ = run("implicit", 1e-9)
        ref_x = ref.newest_material(0.01) if "coiling" in name else ref.centerline()
        for coupling in ("lagged", "implicit"):
            for tol in (1e-2, 1e-3, 1e-4, 1e-5, 1e-6):
                sim, wall = run(coupling, tol)
                x = sim.newest_material(0.01) if "coiling" in name else sim.centerline()
                err = float(np.max(np.linalg.norm(x - ref_x, axis=1)))
                c = sim.counts()
                adaptive.append(
                    {
                        "problem": name,
                        "coupling": coupling,
                        "tolerance": tol,
                        "max_error_m": err,
                        "wall_s": wall,
                        "steps": c["steps"],
                        "evaluations": c["hydro_evaluations"],
                    }
                )
                print(adaptive[-1], flush=True)
    return fixed, adaptive


#: all_effects: the ablation run (set, d in mm, Q in ml/min, variant) and how far it runs
ALL_EFFECTS_RUN = ("fig2", (0.41, 0.5), "all")
ALL_EFFECTS_DURATION_S: float | None = None  # None: the ablation's own duration


def all_effects_variants() -> dict[str, dict]:
    """The ablation's ALL_EFFECTS_RUN overrides (to ALL_EFFECTS_DURATION_S if set; the RPY
    kernel, finite-Re drag), and with one thing changed: contact's dashpot off, no contact,
    the lagged nonlocal flow, Stokes drag (cox), no hydrodynamics; and Lighthill's Stokeslet
    segments instead of the RPY blobs (an indefinite mobility on piles), as planned, without
    contact and with Stokes drag."""
    runs, _ = ablation.plan()
    set_name, point, variant = ALL_EFFECTS_RUN
    over = next(
        r["overrides"]
        for r in runs
        if r["set"] == set_name and r["point"] == point and r["variant"] == variant
    )
    over = {**over, "outputs.plot": False}
    if ALL_EFFECTS_DURATION_S is not None:
        over["duration_s"] = ALL_EFFECTS_DURATION_S
    no_contact = [e for e in over["effects"] if e != "contact"]
    segments = {**over, "hydrodynamics.kernel": "slender_body"}
    return {
        "as in the ablation": over,
        "no dashpot": {**over, "contact.damping_time_s": 0.0},
        "no contact": {**over, "effects": no_contact},
        "lagged nonlocal flow": {**over, "hydrodynamics.coupling": "lagged"},
        "Stokes drag": {**over, "drag.model": "cox"},
        "Stokeslet segments": segments,
        "Stokeslet segments, no contact": {**segments, "effects": no_contact},
        "Stokeslet segments, Stokes drag": {**segments, "drag.model": "cox"},
        "no hydrodynamics": {
            **over,
            "effects": [e for e in over["effects"] if e != "hydrodynamics"],
        },
    }


def all_effects_rows() -> list[dict]:
    """Each of :func:`all_effects_variants`, advanced through its frames as ``simulate``
    advances it: how far it gets, its steps, Newton and Krylov iterations and failures,
    the smallest gap between non-adjacent segments over the sum of the radii at any frame
    (whether it piled), wall time, and a failure's cause."""
    rows = []
    variants = all_effects_variants()
    simulate(ablation.SCENE, {**variants["as in the ablation"], "duration_s": 0.002})  # compile
    for label, over in variants.items():
        t0 = time.perf_counter()
        sim = Simulation(ablation.SCENE, over)
        frame, end = over["outputs.frame_interval_s"], over["duration_s"]
        n_frames = max(1, int(math.ceil(end / frame - 1e-9)))
        gap, cause, reached = math.inf, "", end
        for t in np.minimum(np.arange(1, n_frames + 1) * frame, end):
            try:
                sim.advance(float(t))
            except SimulationError as e:
                cause, reached = e.cause, e.time_s
                break
            near = min_gap_ratio([sim.centerline()], float(sim.model.radius))
            gap = gap if near is None else min(gap, near)  # (None: no two segments near)
        counts = sim.counts()
        keys = ("steps", "rejected_steps", "newton_iterations", "krylov_iterations")
        rows.append(
            {
                "variant": label,
                "duration_s": end,
                "reached_s": reached,
                "failure": cause,
                **{k: counts[k] for k in (*keys, "krylov_failures")},
                "smallest_gap_ratio": gap,
                "wall_s": time.perf_counter() - t0,
            }
        )
        print(rows[-1], flush=True)
    return rows


#: mobility: the times (s) at which I + R M W^-1 is taken on the all_effects run
MOBILITY_TIMES_S = (0.5, 0.8, 1.1, 1.5, 1.9)
#: ... and the all_effects variants it is taken on
MOBILITY_VARIANTS = (
    "as in the ablation",
    "Stokes drag",
    "Stokeslet segments",
    "Stokeslet segments, no contact",
    "Stokeslet segments, Stokes drag",
)


def mobility_rows() -> list[dict]:
    """The all_effects variants MOBILITY_VARIANTS, each advanced through MOBILITY_TIMES_S:
    the eigenvalues of :func:`mobility_operator` (smallest and largest real part, smallest
    singular value) and the smallest gap between non-adjacent segments over the sum of the
    radii; a failure's time and cause where a run stops."""
    variants = all_effects_variants()
    rows = []
    keys = ("free_nodes", "eig_real_min", "eig_real_max", "singular_min", "min_gap_ratio")
    nan = dict.fromkeys(keys, math.nan)
    for label in MOBILITY_VARIANTS:
        sim = Simulation(ablation.SCENE, variants[label])
        for t in MOBILITY_TIMES_S:
            try:
                sim.advance(t)
            except SimulationError as e:
                rows.append({"variant": label, "time_s": e.time_s, "failure": e.cause, **nan})
                print(rows[-1], flush=True)
                break
            op = mobility_operator(sim)
            eig = np.linalg.eigvals(op)
            rows.append(
                {
                    "variant": label,
                    "time_s": sim.t,
                    "failure": "",
                    "free_nodes": op.shape[0] // 3,
                    "eig_real_min": float(eig.real.min()),
                    "eig_real_max": float(eig.real.max()),
                    "singular_min": float(np.linalg.svd(op, compute_uv=False).min()),
                    "min_gap_ratio": min_gap_ratio([sim.centerline()], float(sim.model.radius)),
                }
            )
            print(rows[-1], flush=True)
    return rows


#: failing_solve: each all_effects variant replayed to its first failed GMRES solve, from the
#: last frame (of the all_effects run's schedule) before this time (s)
FAILING_SOLVE_FROM_S = {"Stokeslet segments": 1.7, "Stokeslet segments, no contact": 1.9}


def _stokes_window_resistance(sim: Simulation, nf: int) -> np.ndarray:
    """Each free node's window resistance at zero speed (N s/m, (nf, 3, 3)): Lighthill's
    window coefficients on its segments' halves, the finite_re law's Stokes limit."""
    hyd, x = sim.ws.hydro, sim.pos[: 3 * sim.n_nodes].reshape(-1, 3)
    mu = float(sim.model.p["bath_viscosity"])
    out = np.zeros((nf, 3, 3))
    for j in range(min(nf, sim.n_nodes - 1)):
        e = x[j + 1] - x[j]
        length = float(np.linalg.norm(e))
        tt = np.outer(e, e) / length**2
        r = float(sim.seg_mat[j, L.MAT_RADIUS])
        for i in (j, j + 1):
            if i < nf:
                xp, xn = _stokeslet.window_coefficients(
                    hyd.sides[0, i], hyd.sides[1, i], r, mu, 0.0, 0.0
                )
                out[i] += 0.5 * length * (xp * tt + xn * (np.eye(3) - tt))
    return out


def failing_solve_row(label: str, start_s: float) -> dict:
    """The all_effects variant ``label`` advanced (compiled) through its frames to the last
    before ``start_s``, then replayed from the integrator's Python source (as bench_profile
    replays it) until a GMRES solve fails; at that solve: the time, whether Newton's or the
    error filter's, the smallest real part of eig(I + R M W^-1), the smallest and largest
    eigenvalue of the filament's mobility R^-1 + M W^-1 (symmetric part), and the largest
    eigenvalue of each node's linearised resistance R_i over its Stokes window's (the
    finite_re law at the velocity relative to the flow against its zero-speed limit)."""
    from types import SimpleNamespace

    bench_profile = experiment("step_profile")

    import bathprint.core.integrators as integ
    from bathprint.core import solver

    over = all_effects_variants()[label]
    sim = Simulation(ablation.SCENE, over)
    frame = over["outputs.frame_interval_s"]
    k = 1
    while (k + 1) * frame <= start_s:
        k += 1
    for j in range(1, k + 1):
        sim.advance(j * frame)
    start = sim.t
    caught: dict = {}
    where = {"filter": False}

    def solve(ws, nd, rhs, counters, rtol) -> bool:
        ok = solver.solve(ws, nd, rhs, counters, rtol)
        if not ok and not caught:
            op = V.mobility_operator(sim, assemble=False)
            nf = nd // 3
            resist = sim.ws.hydro.resist[:nf]
            mob = np.linalg.solve(scipy.linalg.block_diag(*resist), op)
            sym = np.linalg.eigvalsh(0.5 * (mob + mob.T))
            stokes = _stokes_window_resistance(sim, nf)
            ratio = max(
                np.linalg.eigvalsh(0.5 * (resist[i] + resist[i].T)).max()
                / np.linalg.eigvalsh(stokes[i]).max()
                for i in range(nf)
            )
            caught.update(
                time_s=sim.t,
                solve="error filter" if where["filter"] else "Newton",
                free_nodes=nf,
                eig_real_min=float(np.linalg.eigvals(op).real.min()),
                mobility_min=float(sym.min()),
                mobility_max=float(sym.max()),
                resistance_over_stokes_max=float(ratio),
                min_gap_ratio=min_gap_ratio([sim.centerline()], float(sim.model.radius)),
            )
        return ok

    real = {name: getattr(integ, name) for name in bench_profile.REPLAYED}

    def filtered(*args):
        where["filter"] = True
        try:
            return real["_filtered_norm"].py_func(*args)
        finally:
            where["filter"] = False

    real_solver = integ.solver
    model, named_ws = bench_profile.replay_records(sim)
    wrapper = SimpleNamespace(
        solve=solve,
        factor=solver.factor,
        damping_times=solver.damping_times,
        off_band=solver.off_band,
    )
    try:
        integ.solver = wrapper
        for name, fn in real.items():
            setattr(integ, name, fn.py_func)
        integ._filtered_norm = filtered
        while not caught and sim.t < over["duration_s"]:
            k += 1
            target = min(k * frame, over["duration_s"])
            while sim.t < target and not caught:
                status = integ.advance.py_func(model, sim.state, named_ws(), target, 10**9)
                if status == L.STATUS_CAPACITY:
                    sim.make_room()
                    model, named_ws = bench_profile.replay_records(sim)
                elif status != L.STATUS_OK:
                    break
            if not caught and sim.t < target:
                break
    finally:
        integ.solver = real_solver
        for name, fn in real.items():
            setattr(integ, name, fn)
    return {"variant": label, "replayed_from_s": start, **caught} if caught else {"variant": label}


def failing_solve_rows() -> list[dict]:
    """:func:`failing_solve_row` for each of FAILING_SOLVE_FROM_S."""
    rows = []
    for label, start in FAILING_SOLVE_FROM_S.items():
        rows.append(failing_solve_row(label, start))
        print(rows[-1], flush=True)
    return rows


#: kernels: the straight rods (aspect L/d, segments per diameter) and the coils' pitches (mm;
#: three turns of radius 3 mm, r = 0.5 mm: 0.85 presses the turns together, 0 puts them
#: through each other) on which both kernels are compared, and the sizes of the timed flows
KERNEL_RODS = ((20, 2), (50, 2), (100, 2), (50, 1), (50, 0.5))
KERNEL_PITCHES_MM = (0.85, 0.5, 0.2, 0.0)
KERNEL_COST_N = (300, 1_000, 3_000)


def kernel_drag_rows() -> list[dict]:
    """A rigid cylinder's drag along and across its axis with each nonlocal kernel, over
    Tirado's (validation.cylinder_drag_tirado)."""
    rows = []
    for kernel in L.HYDRO_KERNELS:
        for aspect, per_d in KERNEL_RODS:
            sim = V.hydro_rod(aspect, int(per_d * aspect), kernel=kernel)
            f_par, f_perp = V.cylinder_drag_tirado(aspect, MU, aspect * 0.2e-3)
            along = V.rigid_body_drag(sim, (0.0, 0.0, 1e-3))
            across = V.rigid_body_drag(sim, (1e-3, 0.0, 0.0))
            rows.append(
                {
                    "kernel": kernel,
                    "aspect": aspect,
                    "segments_per_diameter": per_d,
                    "along_over_tirado": -along[2] / (f_par * 1e-3),
                    "across_over_tirado": -across[0] / (f_perp * 1e-3),
                }
            )
            print(rows[-1], flush=True)
    return rows


def kernel_mobility_rows() -> list[dict]:
    """On three turns at each of KERNEL_PITCHES_MM, Stokes drag, each kernel: the smallest
    real part of eig(I + R M W^-1), the smallest eigenvalue of the filament's mobility's
    symmetric part over its largest, its asymmetry, and the smallest gate (RPY)."""
    rows = []
    for pitch in KERNEL_PITCHES_MM:
        for kernel in L.HYDRO_KERNELS:
            rows.append({"pitch_mm": pitch, "kernel": kernel, **V.turns_mobility(pitch, kernel)})
            print(rows[-1], flush=True)
    return rows


def kernel_cost_rows() -> list[dict]:
    """One nonlocal evaluation on a coil of N nodes (:func:`coil`) with each kernel: the
    Stokeslet segments' direct sum; the RPY blobs' sum and their gates (an O(N x window)
    pass); the RPY sum's time over the segments' in the same run."""
    rows = []
    for n in KERNEL_COST_N:
        pos, s = coil(n)
        f = np.random.default_rng(1).normal(size=3 * n)
        out = np.zeros(3 * n)
        screen = np.full(n, np.inf)
        blob = np.full(n, 2 * A_CUT / 3)  # blobs of 2 r (A_CUT = 3 r)
        gate = np.ones(n)
        resist = np.tile(np.eye(3) * 1e-6, (n, 1, 1))

        def segments(pos=pos, s=s, n=n, f=f, screen=screen, out=out) -> None:
            _stokeslet.nonlocal_flow(pos, s, n, pos, s, n - 1, f, screen, MU, 0.0, A_CUT, 0.0, out)

        def blobs(pos=pos, s=s, n=n, f=f, blob=blob, gate=gate, screen=screen, out=out) -> None:
            _rpy.rpy_flow(pos, s, n, pos, s, n, f, blob, gate, screen, MU, A_CUT, out)

        def gates(pos=pos, s=s, n=n, blob=blob, resist=resist, screen=screen, gate=gate) -> None:
            _rpy.rpy_gates(pos, s, n, blob, resist, screen, A_CUT, MU, gate)

        for call in (segments, blobs, gates):
            call()  # compiled
        t_seg, t_rpy, t_gate = (best_of(c, 3) for c in (segments, blobs, gates))
        rows.append(
            {
                "N": n,
                "slender_body_s": t_seg,
                "rpy_s": t_rpy,
                "rpy_gates_s": t_gate,
                "rpy_over_slender_body": (t_rpy + t_gate) / t_seg,
            }
        )
        print(rows[-1], flush=True)
    return rows


#: kernel_coils: the ablation's contact + finite-Re + nonlocal combination (no inertia, where
#: the Stokeslet segments run) at these Fig. 2 points (d mm, Q ml/min), with each kernel
KERNEL_COIL_VARIANT = "contact_finite_re_hydrodynamics"
KERNEL_COIL_POINTS = ((0.41, 0.5), (0.41, 1.0))
KERNEL_COIL_DURATION_S: float | None = None  # None: the ablation's own duration


def kernel_coil_rows() -> list[dict]:
    """Each KERNEL_COIL_POINTS run of KERNEL_COIL_VARIANT with the Stokeslet segments and
    with the RPY blobs (the law linearised about the motion relative to the bath, the pairs
    screened by Paciorek's kernel): the measured coil (regime, l, R, pitch, omega, smallest
    gap), steps and wall time, to read what the kernel changes where both run."""
    runs, _ = ablation.plan()
    rows = []
    for point in KERNEL_COIL_POINTS:
        over = next(
            r["overrides"]
            for r in runs
            if r["set"] == "fig2" and r["point"] == point and r["variant"] == KERNEL_COIL_VARIANT
        )
        over = {**over, "outputs.plot": False}
        if KERNEL_COIL_DURATION_S is not None:
            over["duration_s"] = KERNEL_COIL_DURATION_S
        for kernel in ("slender_body", "rpy"):
            t0 = time.perf_counter()
            summary = simulate(ablation.SCENE, {**over, "hydrodynamics.kernel": kernel}).summary
            m = summary["measurements"]
            rows.append(
                {
                    "diameter_mm": point[0],
                    "q_outer_ml_min": point[1],
                    "kernel": kernel,
                    "duration_s": over["duration_s"],
                    "regime": m.get("regime"),
                    "buckling_length_m": m.get("buckling_length_m"),
                    "coil_radius_m": m.get("coil_radius_m"),
                    "coil_pitch_m": m.get("coil_pitch_m"),
                    "coil_frequency_rad_s": m.get("coil_frequency_rad_s"),
                    "min_gap_ratio": m.get("min_gap_ratio"),
                    "steps": summary["steps"],
                    "wall_s": time.perf_counter() - t0,
                }
            )
            print(rows[-1], flush=True)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parts = (
        "eval",
        "step",
        "coiling",
        "workprec",
        "all_effects",
        "mobility",
        "failing_solve",
        "kernels",
        "kernel_coils",
        "all",
    )
    ap.add_argument("what", choices=parts)
    ap.add_argument("--max-direct", type=int, default=10_000)
    ap.add_argument("--max-fmm", type=int, default=100_000)
    ap.add_argument("--max-step-n", type=int, default=3_000)
    ap.add_argument("--fmm-step-n", type=int, default=10_000)
    ap.add_argument("--duration", type=float, default=6.0)
    ap.add_argument("--only", nargs="*", help="coiling: variants whose label contains these")
    ap.add_argument(
        "--max-wall-s", type=float, default=600.0, help="coiling: a variant's wall-time cap (s)"
    )
    args = ap.parse_args()
    if args.what in ("eval", "all"):
        print("wrote", write_csv("hydro_eval", evaluation_costs(args.max_direct, args.max_fmm)))
    if args.what in ("step", "all"):
        print("wrote", write_csv("hydro_step", step_costs(args.max_step_n, args.fmm_step_n)))
    if args.what in ("workprec", "all"):
        fixed, adaptive = work_precision()
        print("wrote", write_csv("hydro_fixed_step", fixed))
        print("wrote", write_csv("hydro_work_precision", adaptive))
    if args.what in ("coiling", "all"):
        rows = coiling_costs(args.duration, args.only, args.max_wall_s)
        print("wrote", write_csv("hydro_coiling", rows))
    if args.what in ("all_effects", "all"):
        print("wrote", write_csv("hydro_all_effects", all_effects_rows()))
    if args.what in ("mobility", "all"):
        print("wrote", write_csv("hydro_mobility", mobility_rows()))
    if args.what in ("failing_solve", "all"):
        print("wrote", write_csv("hydro_failing_solve", failing_solve_rows()))
    if args.what in ("kernels", "all"):
        print("wrote", write_csv("hydro_kernel_drag", kernel_drag_rows()))
        print("wrote", write_csv("hydro_kernel_mobility", kernel_mobility_rows()))
        print("wrote", write_csv("hydro_kernel_cost", kernel_cost_rows()))
    if args.what in ("kernel_coils", "all"):
        print("wrote", write_csv("hydro_kernel_coils", kernel_coil_rows()))


if __name__ == "__main__":
    main()

"""bathprint against PyElastica on the cantilever in water: wall time at equal error.

    python experiments/pyelastica/cantilever.py            # full sweep (about 7 min on 2 cores)
    python experiments/pyelastica/cantilever.py --quick    # reduced sweep (under 2 min)

The problem
-----------
A rod of length L = 10 mm and radius r = 0.5 mm (E = 50 kPa, density 1006 kg/m^3) in a
bath of density 1003 kg/m^3 and viscosity 1e-3 Pa s, clamped at x = 0 and lying along +x,
is released straight at t = 0 and sags under its net weight (3 kg/m^3 * A * g per length,
g = 9.81 m/s^2 along -z).

(a) Steady tip deflection. Beam theory: q L^4 / (8 E I) with q = drho g pi r^2. Error of a
    run: |deflection - converged| / converged, "converged" being the same code at the same
    resolution run to its floor (bathprint: tolerance 1e-9; PyElastica: a damped relaxation
    to t = 1 s, decayed by e^-40). The beam-theory error of the converged answers is printed.
(b) With inertia: the tip deflection z_clamp - z_tip at 200 evenly spaced times in (0, 0.5]
    s (lightly damped oscillation at ~43.8 rad/s). Error of a run: max over the samples of
    |d - d_ref| divided by the beam-theory steady deflection, d_ref being the same code at
    the same resolution and a much finer time discretisation (bathprint: SDIRK4 at a fixed
    step of 2.5 ms / 64, full Newton; PyElastica: dt_max / 32). Spatial discretisation
    error is therefore not part of these errors; the difference between the two codes'
    references is printed instead.

Each code's accuracy knob is swept at 50 and 100 elements and every (wall time, error)
point goes to ``results/pyelastica.csv`` and ``.png``. Wall time is the best of
3 repeats of the integration call only (``Simulation.advance`` / ``elastica.integrate``;
building the systems is not timed), after a warm-up run that loads numba's compiled code.

Knobs
-----
- bathprint: (a) ``numerics.tolerance`` (adaptive SDIRK2), run overdamped (effects
  elasticity, drag, gravity) to t = 0.3 s, about 270 relaxation times. (b) adds inertia and
  calls ``advance(t)`` at each sample time, which clips steps at the 2.5 ms sample spacing;
  it sweeps four settings a user can pick: SDIRK2 and SDIRK4 (``numerics.integrator``),
  each adaptive (``numerics.tolerance``) and at a fixed step (``numerics.time_step_s`` =
  2.5 ms / m). The comparison takes the cheapest bathprint run at each accuracy over all of
  them (and states each setting's own ratio at PyElastica's dt_max).
- PyElastica: ``PositionVerlet`` with a fixed dt. dt_max is found for each resolution by
  halving dt from 4 dl / c (c = sqrt(E / rho), the axial wave speed) until the 0.5 s run of
  (b) stays finite and bounded, then bisecting between the last unstable and the first stable
  dt; dt is kept a whole fraction of the 2.5 ms sample spacing. (b) sweeps dt_max, /2, /4.
  In (a) dt does not change the static equilibrium (v = 0 there), so PyElastica's error is
  set by how long it relaxes, not by dt: the knob is the simulated time t_end at dt_max,
  read at checkpoints of one run (the cost is linear in the number of steps); the error at
  a checkpoint is the largest |deflection - converged| over the following period 2 pi /
  omega_1, so that a zero crossing of the oscillation cannot flatter it. Two relaxations
  are run: "pyelastica" adds an ``AnalyticalLinearDamper`` that (with the drag) critically
  damps the first mode, which is the fastest way PyElastica gets to a static answer, and
  "pyelastica_drag_only" keeps the physical drag alone (decay rate ~1.08 1/s, ~10 s). A
  dt_max / 2, / 4 sweep of the damped relaxation at t_end = 0.4 s shows dt buys nothing.

"At equal error" takes the error E of a PyElastica point and the wall time bathprint needs
to reach E, interpolated in log-log along bathprint's Pareto front (cheapest run at each
accuracy); when bathprint's cheapest run is already more accurate than E, that run is used.
For (b) E is PyElastica's error at dt_max (its floor: smaller errors only cost more); for
(a) there is no dt floor, so the ratio is given at E = 1e-3, 1e-4 and 1e-6 of PyElastica's
relaxation curve. Targets (from the issue): >= 100x for (a), >= 10x for (b).

Physics: how the PyElastica model differs from bathprint's
----------------------------------------------------------
- Drag: identical law, a custom ``elastica.NoForces`` subclass: each element of current
  length l and tangent t gives each of its two nodes -(mu_s l / 2) (2 u - (u.t) t), with
  mu_s = 2 pi mu / ln(L_ref / r), L_ref = 20 mm (bathprint's lumping exactly). PyElastica
  evaluates it with the velocity at the start of the step (position Verlet), which makes
  the scheme first order in dt for this velocity-dependent force.
- Gravity: ``GravityForces`` with the effective acceleration g (rho - rho_bath) /
  (rho + rho_bath), so node mass * g_eff is the net weight drho A l g, lumped half per node
  at both ends as in bathprint.
- Inertia: bathprint's node mass is rho A l plus the transverse added mass C_a rho_bath A l
  (C_a = 1), none along the axis. PyElastica's rod has density rho + rho_bath, isotropic:
  the axial mass differs (irrelevant to sagging) and the rotary inertia of the sections,
  (rho + rho_bath) I per length, has no counterpart in bathprint (Kirchhoff rod, ~0.1 % of
  the frequency here).
- Shear and twist: PyElastica is a Cosserat rod (shear modulus E / 3 from Poisson ratio
  0.5, its shear coefficient 27/28; twist stiffness G J); bathprint has neither. Shear adds
  E r^2 / (alpha_c G L^2) ~ 0.8 % to the static deflection: small, but not negligible at
  bathprint's 0.04 % level. Twist is not excited (planar bending).
- Clamp: bathprint clamps the position and the tangent at the needle tip (x = 0) through a
  ghost node. PyElastica's ``OneEndFixedBC`` fixes node 0 and the frame of element 0; with
  the shear stiffness that element is nearly rigid, so its converged deflection is that of a
  rod about half an element shorter (-3 % at 50 elements, first order in dl): see the
  printed beam-theory errors.
- Bending: both use discrete curvatures of the same small-angle limit (bathprint 2 tan
  (phi / 2) per Voronoi length; PyElastica the rotation vector between element frames).
- (a): bathprint drops inertia (overdamped relaxation); PyElastica cannot, so it reaches the
  equilibrium through damped dynamics. The equilibria are the same physics.
"""

from __future__ import annotations

import argparse
import contextlib
import csv
import io
import logging
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import elastica as ea
import matplotlib
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import write_meta  # noqa: E402
from numba import njit  # noqa: E402

from bathprint import Simulation

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

RESULTS = Path(__file__).resolve().parent / "results"

# ---------------------------------------------------------------- the physical problem
LENGTH = 10e-3  # m
RADIUS = 0.5e-3  # m
YOUNGS = 5e4  # Pa
RHO = 1006.0  # kg/m^3
RHO_BATH = 1003.0  # kg/m^3
MU = 1e-3  # Pa s
GRAVITY = 9.81  # m/s^2
L_REF = 20e-3  # m, Cox's length scale in ln(L/r)
AREA = math.pi * RADIUS**2
BENDING = YOUNGS * math.pi * RADIUS**4 / 4.0  # E I, N m^2
Q_NET = (RHO - RHO_BATH) * GRAVITY * AREA  # net weight per length, N/m
DEFLECTION_BEAM = Q_NET * LENGTH**4 / (8.0 * BENDING)  # m
MU_S = 2.0 * math.pi * MU / math.log(L_REF / RADIUS)  # Pa s
MASS_PER_LENGTH = (RHO + RHO_BATH) * AREA  # rod plus (transverse) added mass, kg/m
OMEGA_1 = 1.8751040687**2 * math.sqrt(BENDING / (MASS_PER_LENGTH * LENGTH**4))  # rad/s
DRAG_DECAY = 2.0 * MU_S / (2.0 * MASS_PER_LENGTH)  # transverse amplitude decay rate, 1/s
PERIOD_1 = 2.0 * math.pi / OMEGA_1
WAVE_SPEED = math.sqrt(YOUNGS / (RHO + RHO_BATH))  # axial, m/s

T_STEADY = 0.3  # s, bathprint's overdamped run for (a)
T_DYNAMIC = 0.5  # s, (b)
N_SAMPLES = 200
SAMPLE_DT = T_DYNAMIC / N_SAMPLES
SAMPLE_TIMES = SAMPLE_DT * np.arange(1, N_SAMPLES + 1)
ERROR_FLOOR = 1e-16  # errors are clipped to this for logarithms and plots

INERTIAL = ["elasticity", "drag", "gravity", "inertia"]
OVERDAMPED = ["elasticity", "drag", "gravity"]


@dataclass
class Config:
    """What one mode (full or quick) runs."""

    elements: list[int]
    bp_tolerances_a: list[float]
    bp_settings_b: dict[str, tuple[str, str, list[float]]]  # label: integrator, knob, values
    bp_reference_tolerance_a: float
    bp_reference_divisor_b: int  # SDIRK4 at SAMPLE_DT / this
    pe_dt_divisors_b: list[int]  # dt = dt_max / divisor
    pe_reference_divisor_b: int
    pe_dt_divisors_a: list[int]
    pe_relax_checkpoints: np.ndarray  # s, damped relaxation
    pe_drag_only_checkpoints: np.ndarray  # s, drag-only relaxation
    repeats: int
    drag_only_repeats: int
    suffix: str = ""
    rows: list[dict[str, Any]] = field(default_factory=list)


FULL = Config(
    elements=[50, 100],
    bp_tolerances_a=[1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8],
    bp_settings_b={
        "SDIRK2, tolerance": ("implicit", "tolerance", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]),
        "SDIRK4, tolerance": ("sdirk4", "tolerance", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9]),
        "SDIRK2, fixed step": ("implicit", "steps_per_sample", [1, 2, 4, 8, 16]),
        "SDIRK4, fixed step": ("sdirk4", "steps_per_sample", [1, 2, 3, 4, 6, 8]),
    },
    bp_reference_tolerance_a=1e-9,
    bp_reference_divisor_b=64,
    pe_dt_divisors_b=[1, 2, 4],
    pe_reference_divisor_b=32,
    pe_dt_divisors_a=[1, 2, 4],
    pe_relax_checkpoints=np.round(np.arange(1, 25) * 0.025, 6),
    pe_drag_only_checkpoints=np.round(np.arange(1, 21) * 0.5, 6),
    repeats=3,
    drag_only_repeats=1,
)

QUICK = Config(
    elements=[50],
    bp_tolerances_a=[1e-2, 1e-4, 1e-6],
    bp_settings_b={
        "SDIRK2, tolerance": ("implicit", "tolerance", [1e-4, 1e-6, 1e-7]),
        "SDIRK4, tolerance": ("sdirk4", "tolerance", [1e-5, 1e-7, 1e-8]),
        "SDIRK2, fixed step": ("implicit", "steps_per_sample", [2, 8]),
        "SDIRK4, fixed step": ("sdirk4", "steps_per_sample", [1, 2, 4]),
    },
    bp_reference_tolerance_a=1e-8,
    bp_reference_divisor_b=32,
    pe_dt_divisors_b=[1, 2],
    pe_reference_divisor_b=8,
    pe_dt_divisors_a=[1, 2],
    pe_relax_checkpoints=np.round(np.arange(1, 17) * 0.025, 6),
    pe_drag_only_checkpoints=np.round(np.arange(1, 7) * 0.5, 6),
    repeats=1,
    drag_only_repeats=1,
    suffix="_quick",
)


def log(msg: str) -> None:
    print(msg, flush=True)


def relative(err: float) -> float:
    return max(float(err), ERROR_FLOOR)


# ================================================================== bathprint
def bp_simulation(
    n: int,
    tolerance: float,
    inertia: bool,
    integrator: str = "implicit",
    time_step: float = 0.0,
    newton: str = "modified",
) -> Simulation:
    return Simulation(
        "cantilever_water",
        {
            "effects": INERTIAL if inertia else OVERDAMPED,
            "numerics.node_spacing_mm": LENGTH * 1e3 / n,
            "numerics.tolerance": tolerance,
            "numerics.integrator": integrator,
            "numerics.time_step_s": time_step,
            "numerics.newton": newton,
        },
    )


def bp_deflection(sim: Simulation) -> float:
    c = sim.centerline()  # free end first, needle tip (the clamp) last
    return float(c[-1, 2] - c[0, 2])


def bp_steady(n: int, tolerance: float) -> tuple[float, float, dict[str, int]]:
    """(wall s, steady deflection m, counters) of the overdamped run to T_STEADY."""
    sim = bp_simulation(n, tolerance, inertia=False)
    t0 = time.perf_counter()
    sim.advance(T_STEADY)
    wall = time.perf_counter() - t0
    return wall, bp_deflection(sim), sim.counts()


def bp_dynamic(
    n: int, integrator: str, knob: str, value: float, newton: str = "modified"
) -> tuple[float, np.ndarray, dict[str, int]]:
    """(wall s, deflection at SAMPLE_TIMES, counters) of the inertial run; knob is
    "tolerance" (adaptive) or "steps_per_sample" (fixed step SAMPLE_DT / value)."""
    if knob == "tolerance":
        sim = bp_simulation(n, value, True, integrator)
    else:
        sim = bp_simulation(n, 1e-6, True, integrator, SAMPLE_DT / value, newton)
    out = np.empty(N_SAMPLES)
    t0 = time.perf_counter()
    for k, t in enumerate(SAMPLE_TIMES):
        sim.advance(float(t))
        c = sim.centerline()
        out[k] = c[-1, 2] - c[0, 2]
    wall = time.perf_counter() - t0
    return wall, out, sim.counts()


def bp_warm_up(n: int) -> None:
    for inertia in (False, True):
        for integrator in ("implicit", "sdirk4"):
            bp_simulation(n, 1e-3, inertia, integrator).advance(0.02)
            bp_simulation(n, 1e-3, inertia, integrator, SAMPLE_DT).advance(0.02)


# ================================================================== PyElastica
logging.getLogger().setLevel(logging.ERROR)  # PyElastica warns about SI-sized inertias


@njit(cache=True)
def _slender_body_drag(
    vel: np.ndarray, tangents: np.ndarray, lengths: np.ndarray, mu_s: float, out: np.ndarray
) -> None:
    """out[:, i] -= (mu_s l_j / 2) (2 u_i - (u_i.t_j) t_j) for both nodes i of each element j."""
    for j in range(lengths.shape[0]):
        half = 0.5 * mu_s * lengths[j]
        t0, t1, t2 = tangents[0, j], tangents[1, j], tangents[2, j]
        for i in (j, j + 1):
            u0, u1, u2 = vel[0, i], vel[1, i], vel[2, i]
            ut = u0 * t0 + u1 * t1 + u2 * t2
            out[0, i] -= half * (2.0 * u0 - ut * t0)
            out[1, i] -= half * (2.0 * u1 - ut * t1)
            out[2, i] -= half * (2.0 * u2 - ut * t2)


class SlenderBodyDrag(ea.NoForces):
    """Local resistive-force drag -mu_s (2 u_perp + u_par) per length, lumped as bathprint."""

    def __init__(self, mu_s: float) -> None:
        super().__init__()
        self.mu_s = float(mu_s)

    def apply_forces(self, system: Any, time: float = 0.0) -> None:
        _slender_body_drag(
            system.velocity_collection,
            system.tangents,
            system.lengths,
            self.mu_s,
            system.external_forces,
        )


class Recorder(ea.CallBackBaseClass):
    """Every ``every`` steps: time, wall time since ``clock[0]`` and tip deflection."""

    def __init__(
        self, every: int, store: list[tuple[float, float, float]], clock: list[float]
    ) -> None:
        super().__init__()
        self.every = every
        self.store = store
        self.clock = clock

    def make_callback(self, system: Any, time: np.float64, current_step: int) -> None:
        if current_step % self.every == 0:
            p = system.position_collection
            wall = _perf_counter() - self.clock[0]
            self.store.append((float(time), wall, float(p[2, 0] - p[2, -1])))


_perf_counter = time.perf_counter


class _Simulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping, ea.CallBacks):
    pass


@dataclass
class PeRun:
    """One PyElastica run: wall time of ``integrate`` and the recorded samples."""

    wall: float
    times: np.ndarray
    walls: np.ndarray
    deflection: np.ndarray

    @property
    def finite(self) -> bool:
        return bool(np.all(np.isfinite(self.deflection)))


def pe_run(n: int, dt: float, t_end: float, every: int, damping: float = 0.0) -> PeRun:
    """Integrate the PyElastica cantilever to t_end with PositionVerlet at a fixed dt."""
    sim = _Simulator()
    rod = ea.CosseratRod.straight_rod(
        n,
        np.zeros(3),
        np.array([1.0, 0.0, 0.0]),
        np.array([0.0, 0.0, 1.0]),
        LENGTH,
        RADIUS,
        RHO + RHO_BATH,
        youngs_modulus=YOUNGS,
        shear_modulus=YOUNGS / (2.0 * (1.0 + 0.5)),
    )
    sim.append(rod)
    sim.constrain(rod).using(
        ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
    )
    g_eff = GRAVITY * (RHO - RHO_BATH) / (RHO + RHO_BATH)
    sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array([0.0, 0.0, -g_eff]))
    sim.add_forcing_to(rod).using(SlenderBodyDrag, mu_s=MU_S)
    if damping > 0.0:
        sim.dampen(rod).using(
            ea.AnalyticalLinearDamper, uniform_damping_constant=damping, time_step=dt
        )
    store: list[tuple[float, float, float]] = []
    clock = [time.perf_counter()]
    sim.collect_diagnostics(rod).using(Recorder, every=every, store=store, clock=clock)
    sim.finalize()
    store.clear()  # drop the t = 0 sample taken by finalize()
    n_steps = int(round(t_end / dt))
    stepper = ea.PositionVerlet()
    with contextlib.redirect_stdout(io.StringIO()), np.errstate(all="ignore"):
        t0 = time.perf_counter()
        clock[0] = t0
        ea.integrate(stepper, sim, n_steps * dt, n_steps, progress_bar=False)
        wall = time.perf_counter() - t0
    a = np.array(store, dtype=float).reshape(-1, 3)
    return PeRun(wall, a[:, 0], a[:, 1], a[:, 2])


def pe_dynamic(n: int, per_sample: int) -> PeRun:
    """(b) with dt = SAMPLE_DT / per_sample, recording at the sample times."""
    run = pe_run(n, SAMPLE_DT / per_sample, T_DYNAMIC, per_sample)
    if run.deflection.shape[0] != N_SAMPLES:
        raise RuntimeError(f"PyElastica recorded {run.deflection.shape[0]} samples")
    return run


def pe_stable(run: PeRun) -> bool:
    return run.finite and float(np.max(np.abs(run.deflection))) < 4.0 * DEFLECTION_BEAM


def pe_find_dt_max(n: int) -> tuple[int, list[tuple[float, bool]]]:
    """Smallest samples-per-step divisor m (dt = SAMPLE_DT / m) whose (b) run is stable."""
    dl = LENGTH / n
    m = max(1, math.ceil(SAMPLE_DT / (4.0 * dl / WAVE_SPEED)))
    trials: list[tuple[float, bool]] = []

    def stable(m: int) -> bool:
        ok = pe_stable(pe_dynamic(n, m))
        trials.append((SAMPLE_DT / m, ok))
        log(
            f"  [pyelastica] n={n:<3d} stability trial dt={SAMPLE_DT / m:.4g} s: "
            + ("stable" if ok else "blows up")
        )
        return ok

    if stable(m):
        return m, trials
    lo = m  # unstable
    hi = 2 * m
    while not stable(hi):  # halve dt until stable
        lo, hi = hi, 2 * hi
    while hi - lo > max(1, hi // 64):  # bisect to ~2 %
        mid = (lo + hi) // 2
        if stable(mid):
            hi = mid
        else:
            lo = mid
    return hi, trials


def envelope_error(run: PeRun, checkpoints: np.ndarray, converged: float) -> np.ndarray:
    """Largest |d - converged| / converged over [t, t + PERIOD_1] at each checkpoint."""
    dev = np.abs(run.deflection - converged) / abs(converged)
    out = np.empty(len(checkpoints))
    for k, tc in enumerate(checkpoints):
        window = (run.times >= tc - 1e-12) & (run.times <= tc + PERIOD_1)
        out[k] = float(np.max(dev[window]))
    return out


def wall_at(run: PeRun, checkpoints: np.ndarray) -> np.ndarray:
    idx = np.searchsorted(run.times, checkpoints - 1e-12)
    return run.walls[np.minimum(idx, len(run.walls) - 1)]


def pe_relax(
    n: int, dt: float, damping: float, checkpoints: np.ndarray, repeats: int
) -> tuple[np.ndarray, list[PeRun]]:
    """Wall time to each checkpoint (best over repeats) and the runs."""
    every = max(1, int(round(2.5e-4 / dt)))
    t_end = float(checkpoints[-1]) + PERIOD_1 + 2 * every * dt
    runs = [pe_run(n, dt, t_end, every, damping) for _ in range(repeats)]
    for r in runs:
        if not pe_stable(r):
            raise RuntimeError(f"PyElastica relaxation blew up at n = {n}, dt = {dt:g}")
    walls = np.min([wall_at(r, checkpoints) for r in runs], axis=0)
    return walls, runs


# ================================================================== comparison
def pareto(points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """(wall, error) points that no cheaper point beats in accuracy, by rising wall time."""
    front: list[tuple[float, float]] = []
    for w, e in sorted((w, relative(e)) for w, e in points):
        if not front or e < front[-1][1]:
            front.append((w, e))
    return front


def cost_at_error(points: Sequence[tuple[float, float]], target: float) -> tuple[float, str]:
    """Wall time to reach error <= target, interpolated log-log along the Pareto front."""
    front = pareto(points)
    target = relative(target)
    if target >= front[0][1]:
        return front[0][0], "cheapest run already more accurate"
    if target < front[-1][1]:
        return math.nan, "not reached"
    for (w0, e0), (w1, e1) in zip(front[:-1], front[1:], strict=True):
        if e0 >= target >= e1:
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(w0) + f * (math.log(w1) - math.log(w0))), "interpolated"
    return math.nan, "not reached"


def add_row(
    cfg: Config, problem: str, code: str, n: int, knob: str, value: float, wall: float, err: float
) -> None:
    cfg.rows.append(
        {
            "problem": problem,
            "code": code,
            "elements": n,
            "knob": knob,
            "knob_value": f"{value:.6g}",
            "wall_s": f"{wall:.6g}",
            "error": f"{err:.6g}",
        }
    )


def best_of(fn: Any, repeats: int) -> tuple[float, Any]:
    """Run fn() ``repeats`` times; smallest wall (first return value) and the last result."""
    best = math.inf
    result: Any = None
    for _ in range(repeats):
        result = fn()
        best = min(best, result[0])
    return best, result


# ================================================================== the benchmark
@dataclass
class Resolution:
    """Everything measured at one element count."""

    n: int
    bp_a: list[tuple[float, float]] = field(default_factory=list)
    bp_b: dict[str, list[tuple[float, float]]] = field(default_factory=dict)  # by setting
    pe_a: list[tuple[float, float]] = field(default_factory=list)
    pe_a_drag_only: list[tuple[float, float]] = field(default_factory=list)
    pe_b: list[tuple[float, float, float]] = field(default_factory=list)  # dt, wall, error
    dt_max: float = math.nan
    bp_converged: float = math.nan
    pe_converged: float = math.nan
    bp_ref_b: np.ndarray | None = None
    pe_ref_b: np.ndarray | None = None


def run_bathprint(cfg: Config, res: Resolution) -> None:
    n = res.n
    bp_warm_up(n)
    _, res.bp_converged, counts = bp_steady(n, cfg.bp_reference_tolerance_a)
    log(
        f"[bathprint] (a) n={n} reference tol={cfg.bp_reference_tolerance_a:g}: "
        f"deflection {res.bp_converged:.10e} m, {counts['steps']} steps"
    )
    for tol in cfg.bp_tolerances_a:
        wall, (_, d, counts) = best_of(lambda tol=tol: bp_steady(n, tol), cfg.repeats)
        err = abs(d - res.bp_converged) / res.bp_converged
        res.bp_a.append((wall, err))
        add_row(cfg, "a_steady", "bathprint", n, "tolerance", tol, wall, err)
        log(
            f"[bathprint] (a) n={n} tol={tol:.0e}: {wall * 1e3:8.2f} ms  error {err:.2e}  "
            f"steps {counts['steps']} newton {counts['newton_iterations']}"
        )
    t0 = time.perf_counter()
    div = cfg.bp_reference_divisor_b
    _, res.bp_ref_b, counts = bp_dynamic(n, "sdirk4", "steps_per_sample", div, newton="full")
    log(
        f"[bathprint] (b) n={n} reference SDIRK4 at h = {SAMPLE_DT / div:.3g} s: "
        f"{time.perf_counter() - t0:.1f} s, {counts['steps']} steps"
    )
    for label, (integrator, knob, values) in cfg.bp_settings_b.items():
        points = res.bp_b.setdefault(label, [])
        for value in values:
            wall, (_, z, counts) = best_of(
                lambda v=value, i=integrator, k=knob: bp_dynamic(n, i, k, v), cfg.repeats
            )
            err = float(np.max(np.abs(z - res.bp_ref_b))) / DEFLECTION_BEAM
            points.append((wall, err))
            knob_name, knob_value = (
                (f"{integrator} tolerance", value)
                if knob == "tolerance"
                else (f"{integrator} time_step_s", SAMPLE_DT / value)
            )
            add_row(cfg, "b_dynamic", "bathprint", n, knob_name, knob_value, wall, err)
            log(
                f"[bathprint] (b) n={n} {label} {knob_name.split()[1]}={knob_value:.3g}: "
                f"{wall * 1e3:8.2f} ms  error {err:.2e}  steps {counts['steps']} rejected "
                f"{counts['rejected_steps']} newton {counts['newton_iterations']} "
                f"jacobians {counts['jacobians']}"
            )


def run_pyelastica(cfg: Config, res: Resolution) -> None:
    n = res.n
    pe_run(n, 1e-5, 1e-3, 10, damping=1.0)  # warm-up: load numba's compiled kernels
    m_max, _ = pe_find_dt_max(n)
    res.dt_max = SAMPLE_DT / m_max
    log(
        f"[pyelastica] n={n} dt_max = {res.dt_max:.4g} s "
        f"({res.dt_max / (LENGTH / n / WAVE_SPEED):.3f} dl/c)"
    )
    # (b)
    t0 = time.perf_counter()
    res.pe_ref_b = pe_dynamic(n, m_max * cfg.pe_reference_divisor_b).deflection
    log(
        f"[pyelastica] (b) n={n} reference dt_max/{cfg.pe_reference_divisor_b}: "
        f"{time.perf_counter() - t0:.1f} s"
    )
    for div in cfg.pe_dt_divisors_b:
        runs = [pe_dynamic(n, m_max * div) for _ in range(cfg.repeats)]
        wall = min(r.wall for r in runs)
        err = float(np.max(np.abs(runs[-1].deflection - res.pe_ref_b))) / DEFLECTION_BEAM
        dt = res.dt_max / div
        res.pe_b.append((dt, wall, err))
        add_row(cfg, "b_dynamic", "pyelastica", n, "dt", dt, wall, err)
        log(
            f"[pyelastica] (b) n={n} dt=dt_max/{div} ({dt:.3g} s): {wall * 1e3:8.1f} ms  "
            f"error {err:.2e}"
        )
    # (a): converged equilibrium, then the damped and drag-only relaxations
    damping = max(0.0, 2.0 * OMEGA_1 - 2.0 * DRAG_DECAY)
    ref = pe_run(n, res.dt_max, 1.0, 1, damping)
    res.pe_converged = float(ref.deflection[-1])
    drift = abs(ref.deflection[-1] - ref.deflection[-int(0.1 / res.dt_max)]) / res.pe_converged
    log(
        f"[pyelastica] (a) n={n} converged deflection {res.pe_converged:.10e} m "
        f"(change over the last 0.1 s: {drift:.1e})"
    )
    cps = cfg.pe_relax_checkpoints
    walls, runs = pe_relax(n, res.dt_max, damping, cps, cfg.repeats)
    errs = envelope_error(runs[-1], cps, res.pe_converged)
    for tc, w, e in zip(cps, walls, errs, strict=True):
        res.pe_a.append((float(w), float(e)))
        add_row(cfg, "a_steady", "pyelastica", n, "t_end", tc, w, e)
    log(
        f"[pyelastica] (a) n={n} damped relaxation (nu = {damping:.1f}/s) at dt_max: "
        + ", ".join(
            f"t={tc:g}s {w * 1e3:.0f}ms {e:.1e}"
            for tc, w, e in zip(cps[3::4], walls[3::4], errs[3::4], strict=True)
        )
    )
    t_dt = 0.4 if 0.4 <= cps[-1] + 1e-9 else float(cps[-1])
    for div in cfg.pe_dt_divisors_a:
        dt = res.dt_max / div
        w, rr = pe_relax(n, dt, damping, np.array([t_dt]), cfg.repeats)
        e = float(envelope_error(rr[-1], np.array([t_dt]), res.pe_converged)[0])
        add_row(cfg, "a_steady", "pyelastica_dt_sweep", n, "dt", dt, float(w[0]), e)
        log(
            f"[pyelastica] (a) n={n} damped, t_end={t_dt:g} s, dt=dt_max/{div}: "
            f"{w[0] * 1e3:8.1f} ms  error {e:.2e}"
        )
    cps = cfg.pe_drag_only_checkpoints
    walls, runs = pe_relax(n, res.dt_max, 0.0, cps, cfg.drag_only_repeats)
    errs = envelope_error(runs[-1], cps, res.pe_converged)
    for tc, w, e in zip(cps, walls, errs, strict=True):
        res.pe_a_drag_only.append((float(w), float(e)))
        add_row(cfg, "a_steady", "pyelastica_drag_only", n, "t_end", tc, w, e)
    log(
        f"[pyelastica] (a) n={n} drag-only relaxation at dt_max: "
        + ", ".join(
            f"t={tc:g}s {w:.1f}s {e:.1e}"
            for tc, w, e in zip(cps[1::4], walls[1::4], errs[1::4], strict=True)
        )
    )


@dataclass
class Ratio:
    problem: str
    n: int
    setting: str
    pe_error: float
    pe_wall: float
    bp_wall: float
    note: str

    @property
    def ratio(self) -> float:
        return self.pe_wall / self.bp_wall if self.bp_wall > 0 else math.nan


def ratios(res: Resolution) -> list[Ratio]:
    out: list[Ratio] = []
    for level in (1e-3, 1e-4, 1e-6):
        for label, pts in (("damped", res.pe_a), ("drag only", res.pe_a_drag_only)):
            pe_wall, how = cost_at_error(pts, level)
            if math.isnan(pe_wall):
                continue
            bp_wall, note = cost_at_error(res.bp_a, level)
            out.append(Ratio("(a)", res.n, f"relax, {label}", level, pe_wall, bp_wall, note))
    every = [p for pts in res.bp_b.values() for p in pts]
    for k, (dt, wall, err) in enumerate(res.pe_b):
        bp_wall, note = cost_at_error(every, err)
        label = "dt_max" if k == 0 else f"dt_max/{round(res.dt_max / dt)}"
        out.append(
            Ratio("(b)", res.n, f"{label} = {dt:.3g} s", err, wall, bp_wall, f"best; {note}")
        )
        if k == 0:  # each bathprint setting on its own, at dt_max
            for setting, pts in res.bp_b.items():
                bp_wall, note = cost_at_error(pts, err)
                out.append(
                    Ratio("(b)", res.n, f"{label} = {dt:.3g} s", err, wall, bp_wall, setting)
                )
    return out


def print_table(all_ratios: list[Ratio]) -> None:
    head = (
        f"{'problem':<8}{'elem':>5}  {'PyElastica setting':<26}{'error':>9}"
        f"{'PyE s':>9}{'bathprint s':>13}{'ratio':>9}  note"
    )
    log("\n" + head)
    log("-" * len(head))
    for r in all_ratios:
        bp = f"{r.bp_wall:13.4g}" if not math.isnan(r.bp_wall) else f"{'n/a':>13}"
        ratio = f"{r.ratio:9.3g}" if not math.isnan(r.ratio) else f"{'n/a':>9}"
        log(
            f"{r.problem:<8}{r.n:>5}  {r.setting:<26}{r.pe_error:9.2e}{r.pe_wall:9.4g}"
            f"{bp}{ratio}  {r.note}"
        )


def plot(cfg: Config, resolutions: list[Resolution], all_ratios: list[Ratio], path: Path) -> None:
    fig, axes = plt.subplots(1, 2, figsize=(12, 5))
    colors = {50: "tab:blue", 100: "tab:red"}
    for res in resolutions:
        c = colors.get(res.n, "k")
        markers = {"SDIRK2, tolerance": "o-", "SDIRK4, tolerance": "D-"}
        markers |= {"SDIRK2, fixed step": "o:", "SDIRK4, fixed step": "D:"}
        series = [
            (axes[0], res.bp_a, "o-", "bathprint (SDIRK2)"),
            (axes[0], res.pe_a, "s--", "PyElastica, damped relaxation"),
            (axes[0], res.pe_a_drag_only, "^:", "PyElastica, drag only"),
        ]
        series += [
            (axes[1], pts, markers.get(k, "o-"), f"bathprint {k}") for k, pts in res.bp_b.items()
        ]
        series.append((axes[1], [(w, e) for _, w, e in res.pe_b], "s--", "PyElastica"))
        for ax, pts, style, label in series:
            if pts:
                w, e = zip(*pts, strict=True)
                ax.loglog(
                    w, [relative(x) for x in e], style, color=c, ms=4, label=f"{label}, {res.n} el."
                )
    for r in all_ratios:
        ax = axes[0] if r.problem == "(a)" else axes[1]
        if not math.isnan(r.bp_wall) and r.note.startswith("best"):
            ax.plot([r.bp_wall, r.pe_wall], [r.pe_error, r.pe_error], color="0.6", lw=0.8)
    axes[0].set_title("(a) steady tip deflection: error vs same-code converged answer")
    axes[1].set_title("(b) z_tip(t), 0-0.5 s: max error / steady deflection")
    for ax in axes:
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.suptitle(
        "cantilever in water: bathprint (SDIRK2 / SDIRK4) vs PyElastica (PositionVerlet); "
        "grey lines: equal-error comparisons (cheapest bathprint setting)",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="reduced sweep, 50 elements only")
    args = ap.parse_args()
    cfg = QUICK if args.quick else FULL
    start = time.perf_counter()
    log(
        f"mu_s = {MU_S:.6g} Pa s, EI = {BENDING:.6g} N m^2, beam deflection "
        f"{DEFLECTION_BEAM:.6e} m, omega_1 = {OMEGA_1:.2f} rad/s, drag decay "
        f"{DRAG_DECAY:.3f} 1/s"
    )
    resolutions = []
    for n in cfg.elements:
        res = Resolution(n)
        run_bathprint(cfg, res)
        run_pyelastica(cfg, res)
        resolutions.append(res)
    RESULTS.mkdir(exist_ok=True)
    csv_path = RESULTS / f"pyelastica{cfg.suffix}.csv"
    with csv_path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(cfg.rows[0]))
        w.writeheader()
        w.writerows(cfg.rows)
    write_meta(csv_path)
    log(
        "\nconverged answers (a), beam theory q L^4 / 8 E I = "
        f"{DEFLECTION_BEAM:.6e} m; reference trajectories (b):"
    )
    for res in resolutions:
        log(
            f"  {res.n:>3} el.  bathprint {res.bp_converged:.6e} m "
            f"({(res.bp_converged / DEFLECTION_BEAM - 1) * 100:+.3f} %)   PyElastica "
            f"{res.pe_converged:.6e} m ({(res.pe_converged / DEFLECTION_BEAM - 1) * 100:+.3f} %)"
            f"   dt_max {res.dt_max:.4g} s   (b) max |bathprint ref - PyElastica ref| / "
            f"deflection {np.max(np.abs(res.bp_ref_b - res.pe_ref_b)) / DEFLECTION_BEAM:.3f}"
        )
    if len(resolutions) > 1:
        a, b = resolutions[0], resolutions[-1]
        for name, ra, rb in (
            ("bathprint", a.bp_ref_b, b.bp_ref_b),
            ("PyElastica", a.pe_ref_b, b.pe_ref_b),
        ):
            diff = np.max(np.abs(ra - rb)) / DEFLECTION_BEAM
            log(f"  (b) {name}: max |ref({a.n} el.) - ref({b.n} el.)| / deflection = {diff:.2e}")
    all_ratios = [r for res in resolutions for r in ratios(res)]
    print_table(all_ratios)
    log(
        "targets: (a) >= 100x, (b) >= 10x (ratio = PyElastica wall / bathprint wall at "
        "PyElastica's error)"
    )
    png_path = RESULTS / f"pyelastica{cfg.suffix}.png"
    plot(cfg, resolutions, all_ratios, png_path)
    log(f"\nwrote {csv_path} and {png_path}; total wall time {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()

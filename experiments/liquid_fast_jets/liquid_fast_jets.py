"""Do the fast jets pass the strain bound with every effect on plus ``liquid``?

Runs the fast-jets study's points (d = 0.41 mm at 5 and 20 ml/min, the ablation's Fig. 1B
budget, floor and 20 um seed) with the ablation's "all" variant (inertia, contact,
finite-Re drag, nonlocal hydrodynamics with the RPY kernel inside Newton, surface
gelation, viscosity) plus ``liquid``, each capped at ``--cap-s`` seconds of wall time.
Per run: status (completed, failed with its cause, or stopped at the cap), simulated time,
wall time, nodes, the regime of a completed run (as ``simulate`` measures it), and the
jet's radius over the exit radius at 1, 2 and 5 mm of arclength
from the needle. Writes ``results/liquid_fast_jets.json``.

    python experiments/liquid_fast_jets/liquid_fast_jets.py [--q 20 5] [--cap-s 540]
        [--liquid-viscosity 1.0 | --without-liquid]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

from bathprint.core.layout import MAT_RADIUS
from bathprint.core.simulation import Simulation
from bathprint.errors import SimulationError
from bathprint.run import measure_run
from bathprint.studies.reproduce import ablation

ALL_EFFECTS = ("inertia", "contact", "hydrodynamics", "gelation", "viscosity", "liquid")
ALL_OVERRIDES = {
    "drag.model": "finite_re",
    "gelation.model": "surface",
    "hydrodynamics.coupling": "implicit",
    "hydrodynamics.kernel": "rpy",
}


def overrides(d: float, q: float, eta_m: float | None, seed_um: float = 20.0) -> dict:
    """The ablation's "all" at (d, q) plus ``liquid`` with eta_m (None: without it)."""
    base = ablation.base_overrides(d, q, True, ablation.FULL["fig1b"][1])
    base["needle.imperfection_um"] = seed_um
    effects = ALL_EFFECTS if eta_m is not None else ALL_EFFECTS[:-1]
    over = ablation.variant_overrides(base, effects, ALL_OVERRIDES)
    if eta_m is not None:
        over["liquid.viscosity_pa_s"] = eta_m
    return over


def radius_profile(sim: Simulation, at_mm: tuple[float, ...]) -> dict[str, float]:
    """The segments' radius over the exit radius at the given arclengths from the needle."""
    x = sim.centerline()
    seg = np.linalg.norm(np.diff(x, axis=0), axis=1)
    s_from_tip = np.cumsum(seg[::-1]) - 0.5 * seg[::-1]  # segment midpoints, tip first
    r = sim.material()[::-1, MAT_RADIUS] / sim.model.radius
    return {f"{a:g}": float(np.interp(a * 1e-3, s_from_tip, r)) for a in at_mm}


def run(d: float, q: float, eta_m: float | None, cap_s: float, seed_um: float = 20.0) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sim = Simulation(ablation.SCENE, overrides(d, q, eta_m, seed_um))
    sc = sim.model.scene
    t_end = sc.duration_s
    out: dict = {
        "diameter_mm": d,
        "q_ml_min": q,
        "liquid_viscosity_pa_s": eta_m,
        "imperfection_um": seed_um,
    }
    start = time.perf_counter()
    status = "completed"
    times, frames = [0.0], [sim.centerline()]
    chunk = min(1e-3, sc.outputs.frame_interval_s)
    regime = None
    try:
        while sim.t < t_end - 1e-12:
            sim.advance(min(sim.t + chunk, t_end))
            next_frame = len(times) * sc.outputs.frame_interval_s
            if sim.t >= min(next_frame, t_end) - 1e-12:
                times.append(sim.t)
                frames.append(sim.centerline())
            if time.perf_counter() - start > cap_s:
                status = f"stopped at the {cap_s:g} s wall-time cap"
                break
    except SimulationError as exc:
        status = f"failed: {exc}"
    if status == "completed":
        regime = measure_run(sim, frames, np.array(times)).get("regime")
    out.update(
        status=status,
        regime=regime,
        paper_regime=ablation.PAPER_REGIME.get((d, q)),
        simulated_s=sim.t,
        duration_s=t_end,
        wall_s=time.perf_counter() - start,
        nodes=sim.n_nodes,
        counts=sim.counts(),
        radius_over_exit_at_mm=radius_profile(sim, (1.0, 2.0, 5.0, 10.0)),
        min_radius_over_exit=float(sim.material()[:, MAT_RADIUS].min() / sim.model.radius),
        max_radius_over_exit=float(sim.material()[:, MAT_RADIUS].max() / sim.model.radius),
    )
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--q", type=float, nargs="+", default=[20.0, 5.0])
    ap.add_argument("--cap-s", type=float, default=540.0)
    ap.add_argument("--liquid-viscosity", type=float, default=1.0)
    ap.add_argument("--without-liquid", action="store_true", help="the ablation's all alone")
    ap.add_argument("--seed-um", type=float, default=20.0, help="needle.imperfection_um")
    ap.add_argument("--out", default=str(Path(__file__).with_name("results")))
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / "liquid_fast_jets.json"
    rows = json.loads(path.read_text()) if path.exists() else []
    for q in args.q:
        eta_m = None if args.without_liquid else args.liquid_viscosity
        row = run(0.41, q, eta_m, args.cap_s, args.seed_um)
        print(json.dumps(row), flush=True)
        rows = [r for r in rows if (r["q_ml_min"], r["liquid_viscosity_pa_s"]) != (q, eta_m)]
        rows.append(row)
        path.write_text(json.dumps(rows, indent=1) + "\n")


if __name__ == "__main__":
    main()

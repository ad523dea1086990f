"""Hard cases that must stay numerically stable: long versions of tests/test_hard_cases.py.

Each case is run to its end time (or until it raises); the table gives steps, rejected
steps, wall time, worst stretch error |l/l0 - 1|, mass-balance error, mean step and the
result (ok, or the SimulationError). Writes results/hard_cases.csv.

    python experiments/hard_cases/hard_cases.py            # all cases (several minutes)
    python experiments/hard_cases/hard_cases.py --quick    # the tests' end times (no CSV)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import write_csv  # noqa: E402

from bathprint import Simulation, SimulationError
from bathprint.core.run import integrated_flow_volume

BASE = ["elasticity", "drag", "gravity"]
THIN = {"needle.inner_diameter_mm": 0.21, "flow.q_outer_ml_min": 20.0}
INC = [*BASE, "inclusions"]


def _switch(q_o: float, q_i: float) -> list[list[float]]:
    return [[0, q_o, 0], [0.3, q_o, 0], [0.3001, q_o, q_i], [0.6, q_o, q_i], [0.6001, q_o, 0]]


# name: (scene, overrides, t_end long, t_end quick)
CASES: dict[str, tuple[str, dict, float, float]] = {
    "chaotic_crumpling_22G": ("chaotic_crumpling_22G", {}, 0.3, 0.03),
    "thin_0.21mm_20ml": ("chaotic_crumpling_22G", THIN, 0.01, 0.002),
    "thin_draft": ("chaotic_crumpling_22G", {**THIN, "numerics.accuracy": "draft"}, 0.01, 0.002),
    "thin_spacing_0.5": (
        "chaotic_crumpling_22G",
        {**THIN, "numerics.node_spacing_mm": 0.5},
        0.01,
        0.002,
    ),
    "thin_min_step_1e-12": (
        "chaotic_crumpling_22G",
        {**THIN, "numerics.min_step_s": 1e-12},
        0.01,
        0.002,
    ),
    "thin_fixed_1e-7": (
        "chaotic_crumpling_22G",
        {**THIN, "numerics.time_step_s": 1e-7},
        0.005,
        0.0005,
    ),
    "thin_ramp_50ms": (
        "chaotic_crumpling_22G",
        {**THIN, "flow.schedule": [[0, 0, 0], [0.05, 20, 0]]},
        0.05,
        0.005,
    ),
    "gelation_ratio_100+": (
        "drag_coiling_22G",
        {
            "effects": [*BASE, "gelation"],
            "gelation.initial_modulus_pa": 300.0,
            "gelation.final_modulus_pa": 300000.0,
            "gelation.rate_1_s": 1.0,
        },
        4.0,
        1.5,
    ),
    "n2_phi_0.5": (
        "drag_coiling_22G",
        {"effects": INC, "inclusions.fluid": "nitrogen", "flow.schedule": _switch(0.5, 0.5)},
        1.0,
        0.65,
    ),
    "n2_phi_0.9": (
        "drag_coiling_22G",
        {"effects": INC, "inclusions.fluid": "nitrogen", "flow.schedule": _switch(0.5, 4.5)},
        1.0,
        0.35,
    ),
    "oil_phi_0.9": (
        "drag_coiling_22G",
        {"effects": INC, "inclusions.fluid": "silicone_oil", "flow.schedule": _switch(0.5, 4.5)},
        1.0,
        0.35,
    ),
    "q_jump_0.5_to_5": (
        "drag_coiling_22G",
        {"flow.schedule": _switch(0.5, 0.0)[:2] + [[0.3001, 5, 0], [0.6, 5, 0], [0.6001, 0.5, 0]]},
        1.0,
        0.4,
    ),
    "rope_coiling_18G_floor": ("rope_coiling_18G", {}, 5.0, 1.5),
    "paper_no_inertia": ("paper_simulation", {"effects": BASE}, 3.0, 0.5),
    "paper_inertia": ("paper_simulation", {"effects": [*BASE, "inertia"]}, 3.0, 0.2),
    "paper_inertia_euler": (
        "paper_simulation",
        {"effects": [*BASE, "inertia"], "numerics.integrator": "implicit_euler"},
        3.0,
        0.5,
    ),
    "drag_no_inertia": ("drag_coiling_22G", {"effects": BASE}, 3.0, 0.5),
    "drag_inertia": ("drag_coiling_22G", {"effects": [*BASE, "inertia"]}, 3.0, 0.5),
    "10k_nodes_q0": (
        "drag_coiling_22G",
        {
            "initial.length_mm": 2500.0,
            "flow.q_outer_ml_min": 0.0,
            "numerics.node_spacing_mm": 0.25,
            "initial.perturbation_mm": 5.0,
            "bath.depth_mm": 5000.0,
        },
        0.5,
        0.01,
    ),
    "1e5_steps_fixed_1e-4": ("drag_coiling_22G", {"numerics.time_step_s": 1e-4}, 10.0, 1.0),
    "needle_moving": (
        "paper_simulation",
        {
            "needle.path": [
                [0, 0, 0, -10, 0, 0, -1],
                [0.5, 5, 0, -10, 0, 0, -1],
                [1.0, 5, 5, -10, 0, 0, -1],
                [2.0, -5, 5, -10, 0.3, 0, -1],
            ]
        },
        3.0,
        1.0,
    ),
    "flow_jumps": (
        "paper_simulation",
        {
            "flow.schedule": [
                [0, 0.5, 0],
                [0.5, 0.5, 0],
                [0.5001, 5, 0],
                [1.0, 5, 0],
                [1.0001, 0.2, 0],
            ]
        },
        3.0,
        1.5,
    ),
}


def run_case(name: str, scene: str, overrides: dict, t_end: float) -> dict:
    t0 = time.perf_counter()
    result = "ok"
    sim = None
    try:
        sim = Simulation(scene, overrides)
        sim.advance(t_end)
    except SimulationError as e:
        result = f"FAIL: {e}"
    wall = time.perf_counter() - t0
    row = {"case": name, "scene": scene, "t_end_s": t_end, "t_reached_s": np.nan}
    row.update(steps=0, rejected=0, nodes=0, wall_s=round(wall, 3))
    row.update(stretch_err=np.nan, mass_err=np.nan, mean_step_s=np.nan, result=result)
    if sim is not None and result != "ok":
        c = sim.counts()  # the state at the failure is not kept: only the counts are reported
        row.update(steps=c["steps"], rejected=c["rejected_steps"])
    elif sim is not None:
        c = sim.counts()
        row.update(t_reached_s=sim.t, steps=c["steps"], rejected=c["rejected_steps"])
        row["nodes"] = sim.n_nodes
        if np.all(np.isfinite(sim.centerline())):
            seg = np.linalg.norm(np.diff(sim.centerline(), axis=0), axis=1)
            row["stretch_err"] = float(np.max(np.abs(seg / sim.rest_lengths() - 1.0)))
        else:
            row["result"] = "FAIL: NaN in the centreline"
        expected = sim.initial_volume + integrated_flow_volume(sim, sim.t)
        if expected > 0:
            row["mass_err"] = (sim.printed_volume() - expected) / expected
        if c["steps"]:
            row["mean_step_s"] = sim.t / c["steps"]
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the shorter end times of the tests")
    ap.add_argument("--only", nargs="*", help="case names to run")
    args = ap.parse_args()
    rows = []
    head = (
        f"{'case':24s} {'t_end':>7s} {'steps':>7s} {'rej':>6s} {'nodes':>6s} {'wall s':>7s} "
        f"{'stretch':>8s} {'mass err':>9s} {'mean dt':>9s}  result"
    )
    print(head)
    for name, (scene, ov, t_long, t_quick) in CASES.items():
        if args.only and name not in args.only:
            continue
        r = run_case(name, scene, ov, t_quick if args.quick else t_long)
        rows.append(r)
        print(
            f"{name:24s} {r['t_end_s']:7.4g} {r['steps']:7d} {r['rejected']:6d} {r['nodes']:6d} "
            f"{r['wall_s']:7.2f} {r['stretch_err']:8.2g} {r['mass_err']:9.1e} "
            f"{r['mean_step_s']:9.2e}  {r['result']}",
            flush=True,
        )
    if not args.quick and not args.only:
        print(f"wrote {write_csv('hard_cases', rows)}")


if __name__ == "__main__":
    main()

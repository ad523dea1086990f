"""What each effect costs: kernel time per call, and whole-run wall time with it on.

(1) On a 400-node state of the default scene, each effect kernel is called alone
(force and Jacobian) and timed per call and per node. (2) The default scene is run with
the minimal effect set (elasticity, drag) and with each optional effect added; the wall
time is reported as a ratio to the minimal run measured in the same process.

    python benchmarks/bench_effects.py
"""

from __future__ import annotations

import numpy as np
from _common import best_of, write_csv

from bathprint import Simulation
from bathprint import layout as L
from bathprint.effects import drag, elasticity, end_load, floor, gravity, inertia

KERNELS = {
    "elasticity": elasticity,
    "drag": drag,
    "gravity": gravity,
    "floor": floor,
    "inertia": inertia,
    "end_load": end_load,
}


def kernel_costs() -> list[dict]:
    sim = Simulation("paper_simulation", {"effects": list(KERNELS), "duration_s": 5.0})
    sim.advance(1.8)
    # put the lowest nodes on the floor so the contact branch is exercised
    sim.model.params[L.P_FLOOR_Z] = float(np.min(sim.centerline()[:, 2])) + 0.02
    n = sim.n_nodes
    acc = np.zeros_like(sim.vel)
    force = np.zeros_like(sim.pos)
    work = np.zeros(400)
    rows = []
    for name, mod in KERNELS.items():

        def call(mod=mod) -> None:
            for _ in range(200):
                mod.accumulate(
                    sim.pos,
                    sim.vel,
                    acc,
                    n,
                    sim.seg_rest,
                    sim.seg_mat,
                    sim.model.params,
                    sim.t,
                    1.0,
                    100.0,
                    1e4,
                    force,
                    sim.band,
                    work,
                    True,
                )

        call()
        per_call = best_of(call, 5) / 200
        rows.append(
            {
                "effect": name,
                "nodes": n,
                "us_per_call": 1e6 * per_call,
                "ns_per_node": 1e9 * per_call / n,
            }
        )
        print(f"{name:>10}: {1e6 * per_call:8.1f} us per call ({1e9 * per_call / n:6.1f} ns/node)")
    return rows


def run_costs() -> list[dict]:
    base_effects = ["elasticity", "drag"]
    variants = {
        "elasticity+drag": base_effects,
        "+gravity": base_effects + ["gravity"],
        "+floor": base_effects + ["gravity", "floor"],
        "+inertia": base_effects + ["gravity", "inertia"],
    }
    rows = []
    base = None
    for label, effects in variants.items():
        over = {"effects": effects, "duration_s": 1.0, "numerics.time_step_s": 2e-3}
        Simulation("paper_simulation", over).advance(0.01)  # compile this combination

        def run(over=over) -> None:
            Simulation("paper_simulation", over).advance(1.0)

        wall = best_of(run, 3)
        base = base or wall
        rows.append({"effects": label, "wall_s": wall, "ratio": wall / base})
        print(f"{label:>18}: {wall:.3f} s for 1 s of the default scene (x{wall / base:.2f})")
    return rows


if __name__ == "__main__":
    print("kernel cost per call, 400-node state of the default scene:")
    write_csv("effects_kernels", kernel_costs())
    print("whole run, fixed step 2 ms, same process:")
    print("wrote", write_csv("effects_runs", run_costs()))

"""What each effect costs: kernel time per call, and whole-run wall time with it on.

(1) On a 400-node state of the default scene, each effect kernel is called alone
(force and Jacobian) and timed per call and per node. (2) The default scene is run with
the minimal effect set (elasticity, drag) and with each optional effect added; the wall
time is reported as a ratio to the minimal run measured in the same process.

    python experiments/effects/effects.py
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import best_of, write_csv  # noqa: E402

from bathprint import Simulation
from bathprint.core.effects import (
    drag,
    elasticity,
    end_load,
    floor,
    gravity,
    inertia,
    viscosity,
)

KERNELS = {
    "elasticity": elasticity,
    "drag": drag,
    "gravity": gravity,
    "floor": floor,
    "inertia": inertia,
    "viscosity": viscosity,
    "end_load": end_load,
}


def kernel_costs() -> list[dict]:
    sim = Simulation("paper_simulation", {"effects": list(KERNELS), "duration_s": 5.0})
    sim.advance(1.8)
    # put the lowest nodes on the floor so the contact branch is exercised
    sim.model.p.floor_z = float(np.min(sim.centerline()[:, 2])) + 0.02
    n = sim.n_nodes
    inputs = sim.kernel_inputs(1.0, 100.0, 1e4, True)
    rows = []
    for name, mod in KERNELS.items():

        def call(mod=mod) -> None:
            for _ in range(200):
                mod.accumulate(*inputs)

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
    """Whole runs of the default scene, fixed 2 ms steps. Effects change the dynamics (and so
    the Newton iterations), so the cost is also given per Newton iteration."""
    base_effects = ["elasticity", "drag"]
    variants = {
        "elasticity+drag": ({"effects": base_effects}),
        "+gravity": {"effects": base_effects + ["gravity"]},
        "+floor": {"effects": base_effects + ["gravity", "floor"]},
        "+inertia": {"effects": base_effects + ["gravity", "inertia"]},
        "+viscosity": {"effects": base_effects + ["gravity", "viscosity"]},
        "+gelation": {"effects": base_effects + ["gravity", "gelation"]},
        "+inclusions (Q_i = 2 ml/min)": {
            "effects": base_effects + ["gravity", "inclusions"],
            "flow.q_inner_ml_min": 2.0,
        },
    }
    rows = []
    base = None
    for label, extra in variants.items():
        over = {**extra, "duration_s": 1.0, "numerics.time_step_s": 2e-3}
        Simulation("paper_simulation", over).advance(0.01)  # compile this combination
        sims = [Simulation("paper_simulation", over) for _ in range(3)]
        it = iter(sims)

        def run(it=it) -> None:
            next(it).advance(1.0)

        wall = best_of(run, 3)
        newton = sims[0].counts()["newton_iterations"]
        per_it = wall / newton
        base = base or per_it
        rows.append(
            {
                "effects": label,
                "wall_s": wall,
                "newton_iterations": newton,
                "us_per_newton_iteration": 1e6 * per_it,
                "ratio_per_iteration": per_it / base,
            }
        )
        print(
            f"{label:>30}: {wall:.3f} s for 1 s, {newton} Newton iterations, "
            f"{1e6 * per_it:7.1f} us each (x{per_it / base:.2f})"
        )
    return rows


if __name__ == "__main__":
    print("kernel cost per call, 400-node state of the default scene:")
    write_csv("effects_kernels", kernel_costs())
    print("whole run, fixed step 2 ms, same process:")
    print("wrote", write_csv("effects_runs", run_costs()))

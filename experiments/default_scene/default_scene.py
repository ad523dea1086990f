"""Speed on the default scene: wall seconds per simulated second, node-steps per second,
and the mean implicit step as a multiple of the explicit stability limit.

    python experiments/default_scene/default_scene.py [--scene NAME] [--duration S]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import write_csv  # noqa: E402

from bathprint import Simulation
from bathprint.analysis.stability import explicit_step_limit


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scene", default="paper_simulation")
    ap.add_argument("--duration", type=float, default=3.0)
    args = ap.parse_args()
    Simulation(args.scene).advance(0.01)  # compile
    sim = Simulation(args.scene, {"duration_s": args.duration})
    t0 = time.perf_counter()
    node_steps = 0
    n_chunks = 30
    for k in range(1, n_chunks + 1):
        before = sim.counts()["steps"]
        sim.advance(args.duration * k / n_chunks)
        node_steps += (sim.counts()["steps"] - before) * sim.n_nodes
    wall = time.perf_counter() - t0
    c = sim.counts()
    h_explicit = explicit_step_limit(sim)
    mean_h = args.duration / c["steps"]
    row = {
        "scene": args.scene,
        "simulated_s": args.duration,
        "wall_s": wall,
        "wall_s_per_simulated_s": wall / args.duration,
        "node_steps_per_s": node_steps / wall,
        "steps": c["steps"],
        "rejected": c["rejected_steps"],
        "final_nodes": sim.n_nodes,
        "explicit_limit_s": h_explicit,
        "mean_step_s": mean_h,
        "mean_step_over_explicit_limit": mean_h / h_explicit,
    }
    for k, v in row.items():
        print(f"{k:>30}: {v:.4g}" if isinstance(v, float) else f"{k:>30}: {v}")
    print("wrote", write_csv(f"default_{args.scene}", [row]))


if __name__ == "__main__":
    main()

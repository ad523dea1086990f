"""Cost per step against the number of nodes N (10^2 .. 10^4): it must grow linearly.

A horizontal clamped filament of N segments sagging under its net weight (elasticity,
drag, gravity), advanced at a fixed step; we time steps and Newton iterations and report
microseconds per Newton iteration per node, and the ratio of the cost per step to N=100's
(linear scaling means that ratio equals N/100).

    python experiments/scaling/scaling.py [--quick]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import best_of, sagging_filament, write_csv  # noqa: E402

from bathprint import Simulation


def _make(n: int) -> Simulation:
    return sagging_filament(n)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="N up to 3000, fewer steps")
    args = ap.parse_args()
    sizes = [100, 300, 1000, 3000] if args.quick else [100, 300, 1000, 3000, 10000]
    steps = 20 if args.quick else 50
    _make(100).advance(
        0.01
    )  # compile (a 10-node stub with a 1 mm perturbation fails Newton at 2 ms)
    rows = []
    base = None
    for n in sizes:
        sims = [_make(n) for _ in range(3)]
        for s in sims:
            s.advance(0.02)  # leave the start-up transient
        it = iter(sims)

        def run(sims_iter=it) -> None:
            s = next(sims_iter)
            s.advance(s.t + steps * 2e-3)

        wall = best_of(run, 3)
        c = sims[0].counts()
        newton_per_step = c["newton_iterations"] / c["steps"]
        per_step = wall / steps
        base = base or per_step
        rows.append(
            {
                "nodes": n,
                "us_per_step": 1e6 * per_step,
                "newton_per_step": newton_per_step,
                "us_per_newton_per_node": 1e6 * per_step / newton_per_step / n,
                "cost_ratio_vs_100": per_step / base,
                "linear_ratio": n / 100,
            }
        )
        r = rows[-1]
        print(
            f"N={n:>6}: {r['us_per_step']:10.1f} us/step, {newton_per_step:4.1f} Newton/step, "
            f"{r['us_per_newton_per_node']:.3f} us per Newton iteration per node, "
            f"cost x{r['cost_ratio_vs_100']:.1f} vs N=100 (linear: x{n / 100:.0f})"
        )
    print("wrote", write_csv("scaling", rows))


if __name__ == "__main__":
    main()

"""The fixed cost of one call from Python into the time loop (what a short call pays, as an
environment's control step makes): ``Simulation.advance`` to the current time (no step
taken), against the same call through numba's dispatcher, which resolves the types of the
nested records on every call. Same process, interleaved rounds, best of each.

    python benchmarks/bench_call_overhead.py
"""

from __future__ import annotations

import time

from _common import write_csv

from bathprint import Simulation
from bathprint.core.integrators import advance

CALLS = 20000
ROUNDS = 5


def per_call_us(fn) -> float:
    t0 = time.perf_counter()
    for _ in range(CALLS):
        fn()
    return 1e6 * (time.perf_counter() - t0) / CALLS


def main() -> None:
    sim = Simulation("paper_simulation", {"duration_s": 10.0})
    sim.advance(0.005)
    sim.advance(0.01)
    t = sim.t

    def through_simulation() -> None:
        sim.advance(t)

    def through_dispatcher() -> None:
        advance(sim.model.record, sim.state, sim.ws, t, 10**9)

    best = {"simulation": float("inf"), "dispatcher": float("inf")}
    for _ in range(ROUNDS):
        best["simulation"] = min(best["simulation"], per_call_us(through_simulation))
        best["dispatcher"] = min(best["dispatcher"], per_call_us(through_dispatcher))
    row = {
        "us_per_call_simulation": best["simulation"],
        "us_per_call_dispatcher": best["dispatcher"],
        "ratio": best["dispatcher"] / best["simulation"],
    }
    print(
        f"a call that takes no step: {row['us_per_call_simulation']:.1f} us through "
        f"Simulation.advance, {row['us_per_call_dispatcher']:.1f} us through numba's "
        f"dispatcher (x{row['ratio']:.2f})"
    )
    print("wrote", write_csv("call_overhead", [row]))


if __name__ == "__main__":
    main()

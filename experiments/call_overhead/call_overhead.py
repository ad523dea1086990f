"""The fixed costs of calls: (1) from Python into the time loop (what a short call pays, as
an environment's control step makes): ``Simulation.advance`` to the current time (no step
taken), against the same call through numba's dispatcher, which resolves the types of the
nested records on every call, and the unboxing of its arguments alone (the same records
into a compiled function that does nothing); (2) between compiled kernels: a cached kernel
that reads two counters, called from a compiled loop with the whole workspace record, with
the two sub-records that hold the counters, and with the two arrays themselves (the cost
grows with the number of arrays the argument holds, for the reference counts numba keeps),
and the first again compiled as the simulator's kernels are, without reference counting
(``bathprint.core.jit.KERNEL``). Same process, interleaved rounds, best of each.

    python experiments/call_overhead/call_overhead.py
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import write_csv  # noqa: E402
from numba import njit  # noqa: E402
from numba.core.typing.typeof import Purpose, typeof  # noqa: E402

from bathprint import Simulation
from bathprint.core.integrators import advance
from bathprint.core.jit import KERNEL

CALLS = 20000
ROUNDS = 5


@njit(cache=True)
def _reads_workspace(ws) -> bool:
    return ws.cpl.count[0] > 0 or ws.hydro.memory[0].linearized


@njit(cache=True)
def _reads_parts(cpl, hydro) -> bool:
    return cpl.count[0] > 0 or hydro.memory[0].linearized


@njit(cache=True)
def _reads_arrays(count, memory) -> bool:
    return count[0] > 0 or memory[0].linearized


@njit(cache=True)
def _takes_records(model, state, ws, t_end: float, budget: int) -> int:
    return 0


@njit(**KERNEL)
def _reads_workspace_uncounted(ws) -> bool:
    return ws.cpl.count[0] > 0 or ws.hydro.memory[0].linearized


@njit(cache=True)
def _loop_workspace_uncounted(ws, n: int) -> int:
    s = 0
    for _ in range(n):
        s += _reads_workspace_uncounted(ws)
    return s


@njit(cache=True)
def _loop_workspace(ws, n: int) -> int:
    s = 0
    for _ in range(n):
        s += _reads_workspace(ws)
    return s


@njit(cache=True)
def _loop_parts(ws, n: int) -> int:
    s = 0
    for _ in range(n):
        s += _reads_parts(ws.cpl, ws.hydro)
    return s


@njit(cache=True)
def _loop_arrays(ws, n: int) -> int:
    s = 0
    for _ in range(n):
        s += _reads_arrays(ws.cpl.count, ws.hydro.memory)
    return s


def _arrays_in(record) -> int:
    """Arrays in a (nested) record."""
    if isinstance(record, tuple):
        return sum(_arrays_in(x) for x in record)
    return 1


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

    # the same arguments into a compiled function that does nothing: their unboxing
    args = (sim.model.record, sim.state, sim.ws, float(t), 10**9)
    _takes_records(*args)
    sig = tuple(typeof(a, Purpose.argument) for a in args)
    unbox_entry = _takes_records.overloads[sig].entry_point

    def unboxing_only() -> None:
        unbox_entry(*args)

    calls = {"simulation": through_simulation, "dispatcher": through_dispatcher,
             "unboxing": unboxing_only}  # fmt: skip
    best = dict.fromkeys(calls, float("inf"))
    for _ in range(ROUNDS):
        for name, fn in calls.items():
            best[name] = min(best[name], per_call_us(fn))
    inner = {
        "workspace": _loop_workspace,
        "parts": _loop_parts,
        "arrays": _loop_arrays,
        "workspace_uncounted": _loop_workspace_uncounted,
    }
    ns = {}
    for name, loop in inner.items():
        loop(sim.ws, 10)
        best_s = float("inf")
        for _ in range(ROUNDS):
            t0 = time.perf_counter()
            loop(sim.ws, 10 * CALLS)
            best_s = min(best_s, time.perf_counter() - t0)
        ns[name] = 1e9 * best_s / (10 * CALLS)
    row = {
        "us_per_call_simulation": best["simulation"],
        "us_per_call_dispatcher": best["dispatcher"],
        "ratio": best["dispatcher"] / best["simulation"],
        "us_per_call_unboxing_records": best["unboxing"],
        "record_arrays": _arrays_in(args),
        "workspace_arrays": _arrays_in(sim.ws),
        "parts_arrays": _arrays_in(sim.ws.cpl) + _arrays_in(sim.ws.hydro),
        "ns_per_kernel_call_workspace": ns["workspace"],
        "ns_per_kernel_call_parts": ns["parts"],
        "ns_per_kernel_call_arrays": ns["arrays"],
        "ns_per_kernel_call_workspace_uncounted": ns["workspace_uncounted"],
    }
    print(
        f"a call that takes no step: {row['us_per_call_simulation']:.1f} us through "
        f"Simulation.advance, {row['us_per_call_dispatcher']:.1f} us through numba's "
        f"dispatcher (x{row['ratio']:.2f}); unboxing its arguments "
        f"({row['record_arrays']} arrays) alone {row['us_per_call_unboxing_records']:.1f} us"
    )
    print(
        f"a kernel called from a kernel: {ns['workspace']:.0f} ns with the workspace "
        f"({row['workspace_arrays']} arrays), {ns['parts']:.0f} ns with two of its parts "
        f"({row['parts_arrays']} arrays), {ns['arrays']:.0f} ns with two arrays; "
        f"{ns['workspace_uncounted']:.1f} ns with the workspace without reference counting"
    )
    print("wrote", write_csv("call_overhead", [row]))


if __name__ == "__main__":
    main()

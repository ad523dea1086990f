"""Where the time of a step goes, sampled: Linux ``perf`` on the compiled kernels.

``step_profile.py`` composes a step from kernels timed apart; what it cannot see (a kernel
that costs more in the run than on its own, work between the kernels) lands in "other".
This script measures instead: each case runs in a child process under ``perf record``
(999 samples per second of CPU time), counting only while the case's window of simulated
time runs (perf's control FIFO), and every sample is attributed to the compiled function
it lands in. Numba compiles afresh for the child, into a throwaway cache, so that the
address range of every function is known; the child writes them to perf's symbol map
(``/tmp/perf-PID.map``). A function that numba inlines counts toward its caller (self
time). The cases are ``step_profile.py``'s pile of ``period_doubling_22G`` at 0.8 s with
and without its ``contact``, in adaptive steps.

Each row: the share (%) of the window's samples in one kernel; "Python and the rest" is
what is not in a compiled kernel (the interpreter between ``advance`` calls, the kernel of
the operating system). Needs ``perf`` (Debian: ``linux-perf``) and permission to sample
(``/proc/sys/kernel/perf_event_paranoid`` at most 2); each case compiles the kernels
(about 100 s).

    python experiments/step_profile/sampled_profile.py
    python experiments/step_profile/sampled_profile.py --cases "pile, contact" --window-s 0.02

The pressed stacks of ``contact_cost.py --part saturation`` (3000 and 3x10^4 nodes, relaxed
20 ms), 50 ms each at the settled step, show where a tall stack's step goes as N grows:

    python experiments/step_profile/sampled_profile.py --cases "pressed stack, 3000 nodes" \
        "pressed stack, 30000 nodes" --out sampled_profile_stacks
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import experiment, write_csv  # noqa: E402

CASES = ("pile, no contact", "pile, contact")
WINDOW_S = 0.06  # simulated time sampled after the pile's state (0.8 s)
STACK_SIZES = (3000, 30000)  # nodes of the pressed stacks (``--cases "pressed stack, N nodes"``)
STACK_CASES = tuple(f"pressed stack, {n} nodes" for n in STACK_SIZES)
STACK_WINDOW_S = 0.05  # 200 steps at the settled step


def stack_state(case: str):
    """``contact_cost.py``'s pressed stack of the case's size (pitch 0.98 contact distances),
    relaxed for its settled part's 20 ms at steps of at most 0.25 ms."""
    stacks = experiment("contact_cost")

    n = int(re.fullmatch(r"pressed stack, (\d+) nodes", case).group(1))
    sim = stacks.coil_stack(n, True, 0.98, {"numerics.max_step_s": stacks.SETTLED_MAX_STEP_S})
    sim.advance(stacks.SETTLED_WARM_UP_S)
    return sim


FREQUENCY_HZ = 999
REST = "Python and the rest"


def kernel_name(symbol: str) -> str | None:
    """The dotted name of a numba function from its mangled symbol, without the package
    prefix (``_ZN9bathprint4core6banded7band_luB4v241B36...`` -> ``core.banded.band_lu``);
    None for a symbol that is not one of bathprint's functions."""
    if not symbol.startswith("_ZN"):
        return None
    parts = []
    rest = symbol[3:]
    while rest and rest[0].isdigit():
        m = re.match(r"\d+", rest)
        assert m is not None
        size = int(m.group())
        start = len(m.group())
        parts.append(rest[start : start + size])
        rest = rest[start + size :]
    if len(parts) < 2 or parts[0] != "bathprint":
        return None
    return ".".join(parts[1:])


def parse_report(text: str) -> dict[str, int]:
    """Samples per function from ``perf report --stdio --no-children --sort sym -g none
    -F overhead,sample,sym``: kernels by :func:`kernel_name`, everything else under
    REST."""
    counts: dict[str, int] = {}
    for line in text.splitlines():
        m = re.match(r"\s*[\d.]+%\s+(\d+)\s+\[[.k]\]\s+(\S+)", line)
        if not m:
            continue
        name = kernel_name(m.group(2)) or REST
        counts[name] = counts.get(name, 0) + int(m.group(1))
    return counts


def write_symbol_map(pid: int) -> int:
    """Write perf's symbol map for this process: every function numba compiled here, from
    its address to the next one's. Returns the number of functions."""
    import gc

    from numba.core.registry import CPUDispatcher

    addresses: dict[int, str] = {}
    for obj in gc.get_objects():
        # the type, not isinstance: isinstance of a weak proxy whose object has died raises
        if not issubclass(type(obj), CPUDispatcher):
            continue
        for cres in obj.overloads.values():
            lib = cres.library
            module = getattr(lib, "_final_module", None)
            if module is None:
                continue
            engine = lib._codegen._engine
            for fn in module.functions:
                if fn.is_declaration:
                    continue
                address = engine.get_function_address(fn.name)
                if address:
                    addresses[address] = fn.name
    starts = sorted(addresses)
    ends = [*starts[1:], starts[-1] + 4096] if starts else []
    with open(f"/tmp/perf-{pid}.map", "w") as out:
        for a, b in zip(starts, ends, strict=True):
            out.write(f"{a:x} {min(b - a, 1 << 20):x} {addresses[a]}\n")
    return len(starts)


def child(case: str, window_s: float, ctl: str, ack: str) -> None:
    """Build the case's state, sample its window (enable and disable perf around it), then
    write the symbol map."""
    if case in STACK_CASES:
        sim = stack_state(case)
    else:
        PROFILE_CASES = experiment("step_profile").CASES

        make, _ = PROFILE_CASES[case]
        sim = make()
    sim.advance(sim.t + 1e-3)  # every kernel of the window compiled and warm
    t_end = sim.t + window_s
    with open(ctl, "w") as c, open(ack) as a:
        c.write("enable\n")
        c.flush()
        a.readline()
        t0 = time.perf_counter()
        steps0 = sim.counts()["steps"]
        sim.advance(t_end)
        wall = time.perf_counter() - t0
        c.write("disable\n")
        c.flush()
        a.readline()
    n = write_symbol_map(os.getpid())
    print(
        f"pid {os.getpid()}: window {wall:.2f} s, {sim.counts()['steps'] - steps0} steps, "
        f"{n} functions mapped"
    )


def sample(case: str, window_s: float) -> dict[str, int]:
    """Run the case in a child under perf; samples per function."""
    if shutil.which("perf") is None:
        raise SystemExit("perf is not installed (Debian: apt install linux-perf)")
    with tempfile.TemporaryDirectory() as tmp:
        ctl, ack, data = f"{tmp}/ctl", f"{tmp}/ack", f"{tmp}/perf.data"
        os.mkfifo(ctl)
        os.mkfifo(ack)
        env = {**os.environ, "NUMBA_CACHE_DIR": f"{tmp}/numba"}
        env["PYTHONPATH"] = os.pathsep.join(
            [str(Path(__file__).resolve().parent), env.get("PYTHONPATH", "")]
        )
        cmd = ["perf", "record", "-q", "-F", str(FREQUENCY_HZ), "-D", "-1"]
        cmd += [f"--control=fifo:{ctl},{ack}", "-o", data, "--", sys.executable]
        cmd += [__file__, "--child", case, "--window-s", str(window_s), "--ctl", ctl, "--ack", ack]
        out = subprocess.run(cmd, check=True, env=env, capture_output=True, text=True).stdout
        print(out.strip())
        pid = re.search(r"pid (\d+):", out)
        report = subprocess.run(
            ["perf", "report", "-i", data, "--stdio", "--no-children", "--sort", "sym"]
            + ["-g", "none", "-F", "overhead,sample,sym"],
            check=True,
            capture_output=True,
            text=True,
        ).stdout
        if pid:
            Path(f"/tmp/perf-{pid.group(1)}.map").unlink(missing_ok=True)
    return parse_report(report)


def rows_of(case: str, counts: dict[str, int]) -> list[dict]:
    """One row per function: samples and share of the window (%), largest first."""
    total = sum(counts.values())
    ordered = sorted(counts.items(), key=lambda kv: (kv[0] == REST, -kv[1]))
    return [
        {"case": case, "function": name, "samples": n, "pct_of_window": 100.0 * n / total}
        for name, n in ordered
    ]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--cases", nargs="+", choices=CASES + STACK_CASES, default=list(CASES))
    ap.add_argument(
        "--window-s", type=float, help=f"default {WINDOW_S} (pile), {STACK_WINDOW_S} (stacks)"
    )
    ap.add_argument("--out", default="sampled_profile")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    ap.add_argument("--ctl", help=argparse.SUPPRESS)
    ap.add_argument("--ack", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child, args.window_s, args.ctl, args.ack)
        return
    rows: list[dict] = []
    for case in args.cases:
        t0 = time.perf_counter()
        window = args.window_s or (STACK_WINDOW_S if case in STACK_CASES else WINDOW_S)
        case_rows = rows_of(case, sample(case, window))
        rows += case_rows
        print(f"{case} ({time.perf_counter() - t0:.0f} s):")
        for r in case_rows:
            if r["pct_of_window"] >= 0.5:
                print(f"  {r['pct_of_window']:5.1f}%  {r['function']}")
    print("wrote", write_csv(args.out, rows))


if __name__ == "__main__":
    main()

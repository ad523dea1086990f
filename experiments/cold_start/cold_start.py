"""What a cold start costs: numba's compilation of the simulator's kernels, with and without
the CPython wrappers of the kernels that take the records.

Each variant runs the default scene for 10 ms in a fresh process with an empty numba cache
(``NUMBA_CACHE_DIR``): the import, the first ``advance`` (every effect's kernel compiles,
since the effects are chosen at run time) and the total; then the same in a second process
on the cache the first one wrote (a warm start). ``wrappers`` is the baseline
(``BATHPRINT_KERNEL_WRAPPERS=1``: every kernel compiled with its CPython wrapper);
``callees`` is the default (:func:`bathprint.core.jit.kernel`: the kernels that take the
records and are called only from other kernels have none). The variants run at the same
time, one per core (``--jobs 1`` runs them one after the other).

    python experiments/cold_start/cold_start.py
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import write_csv  # noqa: E402

SRC = Path(__file__).resolve().parents[1] / "src"
VARIANTS = {"wrappers": "1", "callees": "0"}  # BATHPRINT_KERNEL_WRAPPERS

PROBE = """
import json, time
t0 = time.perf_counter()
from bathprint import Simulation
t1 = time.perf_counter()
sim = Simulation("paper_simulation")
sim.advance(0.01)
t2 = time.perf_counter()
print(json.dumps({"import_s": t1 - t0, "first_advance_s": t2 - t1, "steps": sim.counts()["steps"],
                  "pos_sum": float(sim.pos[: 3 * sim.n_nodes].sum())}))
"""


def probe(wrapped: str, cache_dir: str) -> dict:
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": cache_dir,
        "BATHPRINT_KERNEL_WRAPPERS": wrapped,
        "PYTHONPATH": os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]),
    }
    out = subprocess.run(
        [sys.executable, "-c", PROBE], env=env, capture_output=True, text=True, check=True
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(variant: str) -> dict:
    with tempfile.TemporaryDirectory(prefix=f"numba-{variant}-") as cache:
        cold = probe(VARIANTS[variant], cache)
        warm = probe(VARIANTS[variant], cache)
    print(
        f"{variant:>9}: cold {cold['import_s'] + cold['first_advance_s']:.1f} s, "
        f"warm {warm['import_s'] + warm['first_advance_s']:.2f} s",
        flush=True,
    )
    return {"variant": variant, "cold": cold, "warm": warm}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--jobs", type=int, default=2, choices=(1, 2))
    args = ap.parse_args()
    print("compiling from an empty cache (a few minutes per variant) ...", flush=True)
    with ThreadPoolExecutor(args.jobs) as pool:
        results = {r["variant"]: r for r in pool.map(measure, list(VARIANTS))}
    base = results["wrappers"]
    rows = []
    for name, r in results.items():
        cold = r["cold"]["import_s"] + r["cold"]["first_advance_s"]
        warm = r["warm"]["import_s"] + r["warm"]["first_advance_s"]
        base_cold = base["cold"]["import_s"] + base["cold"]["first_advance_s"]
        rows.append(
            {
                "variant": name,
                "cold_import_s": round(r["cold"]["import_s"], 2),
                "cold_first_advance_s": round(r["cold"]["first_advance_s"], 1),
                "cold_total_s": round(cold, 1),
                "cold_vs_wrappers": round(cold / base_cold, 3),
                "warm_total_s": round(warm, 2),
                "steps": r["cold"]["steps"],
                "same_result": r["cold"]["pos_sum"] == base["cold"]["pos_sum"]
                and r["warm"]["pos_sum"] == base["cold"]["pos_sum"],
                "jobs": args.jobs,
            }
        )
    print(write_csv("compile", rows))
    for row in rows:
        print(row)


if __name__ == "__main__":
    main()

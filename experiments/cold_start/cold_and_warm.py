"""What a cold start costs a user: each task in a fresh process with an empty numba cache,
then again in a second process on the cache the first one wrote.

Tasks: the default scene (``Simulation("paper_simulation").advance(0.01)``), the first step
of the newest version of each environment (``make``, ``reset``, one ``step`` at ``draft``),
and ``bathprint warmup``. Each runs in its own temporary ``NUMBA_CACHE_DIR``, so the cold
time is that of a fresh install; compilation is cold minus warm. Timings include the
interpreter's start and bathprint's import (seconds, wall clock).

    python experiments/cold_start/cold_and_warm.py           # every task
    python experiments/cold_start/cold_and_warm.py --quick   # default scene, one environment
    python experiments/cold_start/cold_and_warm.py --src OTHER/src  # another checkout's code

Standalone: it needs only the Python that runs bathprint.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SRC = Path(__file__).resolve().parents[2] / "src"

DEFAULT_SCENE = """
from bathprint import Simulation
sim = Simulation("paper_simulation")
sim.advance(0.01)
"""

ENV_STEP = """
import warnings
import gymnasium
import bathprint  # registers the environments
with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)
    env = gymnasium.make({env_id!r}, accuracy="draft")
env.reset(seed=0)
env.step(env.action_space.sample())
env.close()
"""

WARMUP = """
import sys
from bathprint.cli import main
sys.exit(main(["warmup"]))
"""

NEWEST_ENVS = """
import json
from bathprint.envs import ENV_IDS
newest = {}
for env_id in ENV_IDS:
    name, _, version = env_id.rpartition("-v")
    if int(version) >= newest.get(name, (-1, ""))[0]:
        newest[name] = (int(version), env_id)
print(json.dumps([env_id for _, env_id in newest.values()]))
"""


def _env(src: Path, cache_dir: str) -> dict[str, str]:
    return {
        **os.environ,
        "NUMBA_CACHE_DIR": cache_dir,
        "PYTHONPATH": os.pathsep.join([str(src), os.environ.get("PYTHONPATH", "")]),
        "MPLBACKEND": "Agg",
    }


def run_probe(code: str, src: Path, cache_dir: str) -> float:
    """Wall seconds of ``python -c code`` in a fresh process on ``cache_dir``."""
    t0 = time.perf_counter()
    out = subprocess.run(
        [sys.executable, "-c", code], env=_env(src, cache_dir), capture_output=True, text=True
    )
    seconds = time.perf_counter() - t0
    if out.returncode != 0:
        raise RuntimeError(f"probe failed (exit {out.returncode}):\n{out.stderr[-2000:]}")
    return seconds


def newest_envs(src: Path) -> list[str]:
    """The newest version of each registered environment, as ids."""
    with tempfile.TemporaryDirectory(prefix="numba-ids-") as cache:
        out = subprocess.run(
            [sys.executable, "-c", NEWEST_ENVS],
            env=_env(src, cache),
            capture_output=True,
            text=True,
            check=True,
        )
    return json.loads(out.stdout.strip().splitlines()[-1])


def measure(name: str, code: str, src: Path) -> dict[str, float | str]:
    """Cold (empty cache) and warm (second process, same cache) seconds of one task."""
    with tempfile.TemporaryDirectory(prefix="numba-cold-") as cache:
        cold = run_probe(code, src, cache)
        warm = run_probe(code, src, cache)
    return {"task": name, "cold_s": cold, "warm_s": warm, "compile_s": cold - warm}


def tasks(src: Path, quick: bool) -> list[tuple[str, str]]:
    """(name, code) of every task to time."""
    envs = newest_envs(src)
    if quick:
        envs = envs[:1]
    out = [("default scene, 10 ms", DEFAULT_SCENE)]
    out += [(f"first step {env_id}", ENV_STEP.format(env_id=env_id)) for env_id in envs]
    if not quick:
        out.append(("bathprint warmup", WARMUP))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the default scene and one environment")
    ap.add_argument("--src", type=Path, default=SRC, help="the bathprint source tree to time")
    ap.add_argument("--json", type=Path, default=None, help="also write the rows to this file")
    args = ap.parse_args(argv)
    src = args.src.resolve()
    if not (src / "bathprint").is_dir():
        ap.error(f"--src: {src} holds no bathprint package (expected {src}/bathprint)")
    print(f"source: {src}; {os.cpu_count()} CPUs; load average {os.getloadavg()[0]:.1f}")
    print(f"{'task':<40} {'cold (s)':>9} {'warm (s)':>9} {'compile (s)':>12}")
    rows = []
    for name, code in tasks(src, args.quick):
        row = measure(name, code, src)
        rows.append(row)
        print(
            f"{name:<40} {row['cold_s']:>9.1f} {row['warm_s']:>9.1f} {row['compile_s']:>12.1f}",
            flush=True,
        )
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

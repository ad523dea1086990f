"""Compile (or load from numba's cache) the simulator's kernels before timed work.

numba compiles a kernel at its first call and caches the machine code on disk
(``cache=True``), so only the first run after an install or an upgrade pays for it.
:func:`ensure_compiled` does that work up front, on a throwaway two-millisecond
simulation, says so once when the cache is cold, and returns the seconds it took
(``summary.json``: ``compile_s``), so that a run's own wall time never counts compilation.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from bathprint._cache import ensure_fresh_cache

_DONE = False  # the kernels are in this process's memory


def kernels_cached() -> bool | None:
    """True if numba's on-disk cache holds the stepper's kernel, False if not, None if that
    cannot be told (numba's cache layout is private API)."""
    try:
        from bathprint.core.integrators import advance

        return Path(advance._cache._cache_file._index_path).exists()
    except Exception:  # noqa: BLE001 - any change of numba's internals means "unknown"
        return None


def _run_tiny() -> None:
    """A throwaway run that calls every kernel a simulation, its measurements and the
    environments use, with the same argument types (so nothing compiles again later)."""
    from bathprint.core.simulation import Simulation

    for effects in (
        ["elasticity", "drag", "gravity", "floor", "gelation", "inclusions"],
        ["elasticity", "drag", "gravity", "inertia"],
    ):
        sim = Simulation(
            "paper_simulation",
            {"duration_s": 0.004, "effects": effects, "outputs.plot": False},
        )
        sim.advance(0.002)
        sim.energies_now()


def ensure_compiled(announce: bool = True, environments: bool = False) -> float:
    """Compile or load the kernels once per process; returns the seconds it took (0.0 when
    they were already loaded). With a cold cache and ``announce``, one line on stderr says
    what is happening. ``environments`` also compiles the Gymnasium environments' kernels."""
    global _DONE
    if _DONE and not environments:
        return 0.0
    ensure_fresh_cache()  # a stale cache is wiped first, and then reads as cold
    cold = kernels_cached() is False
    if cold and announce:
        print(
            "bathprint: compiling the numba kernels (once after an install or an upgrade; "
            "cached afterwards) ...",
            file=sys.stderr,
            flush=True,
        )
    t0 = time.perf_counter()
    if not _DONE:
        _run_tiny()
        _DONE = True
    if environments:
        _run_environments()
    seconds = time.perf_counter() - t0
    if cold and announce:
        print(f"bathprint: kernels compiled in {seconds:.0f} s", file=sys.stderr, flush=True)
    return seconds


def _run_environments() -> None:
    """One step of an environment of each kernel set (the v1 environments share theirs,
    as the v0 ones do)."""
    import warnings

    import gymnasium

    import bathprint  # noqa: F401 - registers the environments

    for env_id in ("bathprint/CoilRadius-v1", "bathprint/CoilRadius-v0", "bathprint/WriteShape-v0"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # the v0 versions say so
            env = gymnasium.make(env_id, accuracy="draft")
        env.reset(seed=0)
        env.step(env.action_space.sample())
        env.close()


DESCRIPTION = (
    "Compile the numba kernels now (simulator and environments), so that the first "
    "simulation, environment or training run after an install starts at once."
)


def run_args(args: object = None) -> int:
    """``bathprint warmup``: compile every kernel now (simulation and environments)."""
    cached = kernels_cached()
    seconds = ensure_compiled(announce=False, environments=True)
    state = {True: "loaded from the cache", False: "compiled", None: "compiled or loaded"}[cached]
    print(f"bathprint: kernels {state} in {seconds:.1f} s")
    return 0


def main(argv: list[str] | None = None) -> int:
    """``bathprint warmup`` as its own program (it takes no options)."""
    import argparse

    argparse.ArgumentParser(prog="bathprint warmup", description=DESCRIPTION).parse_args(argv)
    return run_args()

"""The quick mode of benchmarks/run_quick.sh: benchmarks too long to prove the suite works
(the cold start) skip themselves when ``BATHPRINT_BENCH_QUICK`` is set."""

from __future__ import annotations

import os


def skip_in_quick_mode() -> None:
    """Raise NotImplementedError (asv's way to skip a benchmark from its setup) in quick mode."""
    if os.environ.get("BATHPRINT_BENCH_QUICK"):
        raise NotImplementedError("skipped in quick mode (BATHPRINT_BENCH_QUICK is set)")

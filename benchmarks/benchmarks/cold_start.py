"""A cold start: a fresh process with an empty numba cache runs the default scene for 10 ms
(the import and the compilation of every kernel the scene uses)."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time

from ._quick import skip_in_quick_mode

CODE = "from bathprint import Simulation; Simulation('paper_simulation').advance(0.01)"


class ColdStart:
    timeout = 1800
    number = 1
    repeat = 1

    def setup(self) -> None:
        skip_in_quick_mode()

    def track_cold_start_s(self) -> float:
        with tempfile.TemporaryDirectory() as cache:
            env = {**os.environ, "NUMBA_CACHE_DIR": cache}
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-c", CODE], env=env, check=True)
            return time.perf_counter() - t0

    track_cold_start_s.unit = "s"

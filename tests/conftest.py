"""Shared fixtures. Scenes are kept small so that the whole suite runs in minutes."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def load_script():
    """A loader of a Python file (a benchmark script) as a module: ``load_script(path)``."""
    import importlib.util

    def load(path):
        spec = importlib.util.spec_from_file_location(Path(path).stem, path)
        assert spec is not None and spec.loader is not None
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        return mod

    return load


def pytest_configure(config: pytest.Config) -> None:
    """Under pytest-xdist, the controller compiles (or loads) the kernels once, with
    ``bathprint warmup``, before the workers start. Otherwise, on a cold numba cache,
    every worker and every process a test starts (training workers, campaign pools)
    compiles the same kernels at the same time: in a fresh CI run that cost the suite
    about 2.5 minutes."""
    if hasattr(config, "workerinput") or not getattr(config.option, "numprocesses", None):
        return
    import subprocess
    import sys
    import time

    t0 = time.perf_counter()
    proc = subprocess.run(
        [sys.executable, "-m", "bathprint.cli", "warmup"], capture_output=True, text=True
    )
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:  # the tests will show why; the warm-up only saves time
        print(f"conftest: bathprint warmup failed ({proc.stderr.strip()[-500:]})")
    else:
        print(f"conftest: {proc.stdout.strip()} (this process: {seconds:.0f} s)")

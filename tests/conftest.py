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


"""Optional dependencies: import one, or say which ``pip install`` line brings it.

The core (simulate, view as PNG, sweeps serially or on a process pool, the Gymnasium
environments) needs only numpy, numba, scipy, matplotlib, gymnasium and tqdm. Everything
else belongs to an extra of ``pyproject.toml``: ``rl`` (torch, stable-baselines3,
sb3-contrib, rliable, optuna, tensorboard), ``dask``, ``viewer`` (plotly).
"""

from __future__ import annotations

import importlib
import importlib.util
from types import ModuleType

#: the extra of ``pyproject.toml`` that brings each optional top-level module
EXTRA_OF_MODULE: dict[str, str] = {
    "torch": "rl",
    "stable_baselines3": "rl",
    "sb3_contrib": "rl",
    "rliable": "rl",
    "optuna": "rl",
    "tensorboard": "rl",
    "yaml": "rl",
    "rich": "rl",
    "dask": "dask",
    "distributed": "dask",
    "plotly": "viewer",
}


class MissingExtraError(ImportError):
    """An optional dependency is not installed; the message names the extra that brings it."""


def install_line(extra: str) -> str:
    """The command that installs ``extra`` with the pinned versions, from a checkout."""
    return f'pip install -c requirements/constraints.txt -e ".[{extra}]"'


def require(module: str, purpose: str, extra: str | None = None) -> ModuleType:
    """Import ``module``, or raise :class:`MissingExtraError` naming ``purpose`` and the
    ``pip install`` line of the extra that brings it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:  # a missing package, or one of its own missing parts
        top = module.split(".")[0]
        name = extra or EXTRA_OF_MODULE.get(top, "all")
        raise MissingExtraError(
            f"{purpose} needs {top!r}, which is not installed: it comes with the "
            f"{name!r} extra ({install_line(name)}, or pip install 'bathprint[{name}]')"
        ) from exc


def available(module: str) -> bool:
    """Whether ``module`` can be imported (without importing it)."""
    return importlib.util.find_spec(module) is not None

"""Optional dependencies: import one, or say which ``pip install`` line brings it.

The core (simulate, view as PNG, sweeps serially or on a process pool, the Gymnasium
environments) needs only numpy, numba, scipy, matplotlib, gymnasium, tqdm and tomli-w.
Everything else belongs to an extra of ``pyproject.toml``: ``rl`` (torch,
stable-baselines3, sb3-contrib, rliable, optuna, tensorboard, pyyaml, rich), ``dask``,
``viewer`` (plotly).
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


def _missing_message(top: str, purpose: str, extra: str) -> str:
    return (
        f"{purpose} needs {top!r}, which is not installed: it comes with the "
        f"{extra!r} extra ({install_line(extra)}, or pip install 'bathprint[{extra}]')"
    )


def require(module: str, purpose: str, extra: str | None = None) -> ModuleType:
    """Import ``module``, or raise :class:`MissingExtraError` naming ``purpose`` and the
    ``pip install`` line of the extra that brings it."""
    try:
        return importlib.import_module(module)
    except ImportError as exc:  # a missing package, or one of its own missing parts
        top = module.split(".")[0]
        name = extra or EXTRA_OF_MODULE.get(top, "all")
        raise MissingExtraError(_missing_message(top, purpose, name)) from exc


def require_extra(extra: str, purpose: str) -> None:
    """Raise :class:`MissingExtraError` (as :func:`require` does) unless every module that
    ``extra`` brings can be imported; imports none of them (a command checks its extra
    before it starts, without paying for importing torch)."""
    modules = [m for m, e in EXTRA_OF_MODULE.items() if e == extra]
    if not modules:
        known = sorted(set(EXTRA_OF_MODULE.values()))
        raise ValueError(f"extra = {extra!r}; allowed: {', '.join(known)}")
    for module in modules:
        if not available(module):
            raise MissingExtraError(_missing_message(module, purpose, extra))


def available(module: str) -> bool:
    """Whether ``module`` can be imported (without importing it)."""
    try:
        return importlib.util.find_spec(module) is not None
    except (ImportError, ValueError):  # a missing parent package, or a finder that refuses
        return False

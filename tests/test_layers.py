"""The package's layers: the simulator (``bathprint.core``) imports nothing above it, the
viewer and the studies do not import the agents, the task runner (``bathprint.executor``)
imports none of the layers and a scene's run (``bathprint.run``) nothing of learning. Every
import statement counts, those inside functions too (parsed with :mod:`ast`, nothing
imported)."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "bathprint"

#: what each layer must not import (a package, or a module and what is below it)
FORBIDDEN: dict[str, tuple[str, ...]] = {
    "core": (
        "bathprint.envs",
        "bathprint.agents",
        "bathprint.analysis",
        "bathprint.studies",
        "bathprint.viz",
        "bathprint.warmup",
        "bathprint.run",
        "bathprint.cli",
        "bathprint.executor",
    ),
    "viz": ("bathprint.agents", "bathprint.studies"),
    "studies": ("bathprint.agents",),
    "envs": ("bathprint.agents", "bathprint.studies", "bathprint.viz"),
    # the runner of independent tasks knows no task: sweeps and campaigns hand it theirs
    "executor.py": (
        "bathprint.core",
        "bathprint.envs",
        "bathprint.agents",
        "bathprint.analysis",
        "bathprint.studies",
        "bathprint.viz",
    ),
    # a scene's run: the simulator, its measurements and its picture, nothing of learning
    "run.py": ("bathprint.envs", "bathprint.agents", "bathprint.studies"),
}


def imported_modules(source: str, module_name: str) -> list[tuple[int, str]]:
    """(line, module) of every import in the source of module ``module_name`` (dotted; a
    package's ``__init__`` ends in ``.__init__``), relative imports resolved."""
    tree = ast.parse(source)
    package = tuple(module_name.split("."))[:-1]
    found: list[tuple[int, str]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join(base + ((node.module,) if node.module else ()))
            else:
                module = node.module or ""
            found.append((node.lineno, module))
            # ``from bathprint import agents`` imports the package bathprint.agents
            found += [(node.lineno, f"{module}.{alias.name}") for alias in node.names]
        elif isinstance(node, ast.Call) and _is_import_call(node):
            arg = node.args[0] if node.args else None
            if isinstance(arg, ast.Constant) and isinstance(arg.value, str):
                found.append((node.lineno, arg.value))
    return found


def _is_import_call(node: ast.Call) -> bool:
    """``importlib.import_module(...)``, ``import_module(...)``, ``__import__(...)`` or
    bathprint's ``require(...)``."""
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
    return name in ("import_module", "__import__", "require")


def violations(layer: str, source: str, module_name: str) -> list[str]:
    """The imports of one module of ``layer`` that reach above it, as ``module:line imports
    name`` (the first such name of each import statement)."""
    bad: dict[int, str] = {}
    for line, module in imported_modules(source, module_name):
        if any(module == b or module.startswith(b + ".") for b in FORBIDDEN[layer]):
            bad.setdefault(line, f"{module_name}:{line} imports {module}")
    return list(bad.values())


def _violations(layer: str) -> list[str]:
    bad = []
    where = PACKAGE / layer
    for path in sorted(where.rglob("*.py")) if where.is_dir() else [where]:
        name = ".".join(path.relative_to(PACKAGE.parent).with_suffix("").parts)
        bad += violations(layer, path.read_text(), name)
    return bad


@pytest.mark.parametrize("layer", sorted(FORBIDDEN))
def test_layer_imports_nothing_above_it(layer: str) -> None:
    assert (PACKAGE / layer).exists()
    assert _violations(layer) == []


def test_the_check_sees_lazy_relative_and_package_imports() -> None:
    """An import inside a function, a relative one, ``from bathprint import x`` and
    ``importlib.import_module`` all count; the layer's own imports do not."""
    source = (
        "import numpy\n"
        "from bathprint.core.scene import load_scene\n"
        "from . import layout\n"
        "def f():\n"
        "    from bathprint.viz.plotting import plot_filament\n"
        "    from ..agents import train\n"
        "    from bathprint import studies\n"
        "    importlib.import_module('bathprint.envs')\n"
    )
    found = violations("core", source, "bathprint.core.probe")
    assert found == [
        "bathprint.core.probe:5 imports bathprint.viz.plotting",
        "bathprint.core.probe:6 imports bathprint.agents",
        "bathprint.core.probe:7 imports bathprint.studies",
        "bathprint.core.probe:8 imports bathprint.envs",
    ]

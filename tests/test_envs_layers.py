"""The environments sit below the agents: no module of ``bathprint.envs`` imports
``bathprint.agents`` (a static check of every import statement, those inside functions too)."""

from __future__ import annotations

import ast
from pathlib import Path

import bathprint.envs

ENVS_DIR = Path(bathprint.envs.__file__).parent


def _imported_modules(path: Path) -> list[str]:
    """Absolute names of the modules a file imports (relative imports resolved)."""
    package = ["bathprint", "envs"]
    out = []
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out += [alias.name for alias in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            out.append(module)
            out += [f"{module}.{alias.name}" for alias in node.names]
    return out


def test_no_envs_module_imports_the_agents() -> None:
    files = sorted(ENVS_DIR.rglob("*.py"))
    assert len(files) > 10
    leaks = {
        str(f.relative_to(ENVS_DIR)): m
        for f in files
        for m in _imported_modules(f)
        if m == "bathprint.agents" or m.startswith("bathprint.agents.")
    }
    assert leaks == {}


def test_the_check_sees_an_agents_import(tmp_path: Path) -> None:
    src = tmp_path / "x.py"
    src.write_text("def f():\n    from bathprint import agents\n    from ..agents import signals\n")
    mods = _imported_modules(src)
    assert "bathprint.agents" in mods and "bathprint.agents.signals" in mods

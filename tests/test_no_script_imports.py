"""The test suite tests the library: no test imports an experiment's or a benchmark's script
(those are checked by hand: experiments/<question>/check_*.py, benchmarks/run_quick.sh)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

TESTS = Path(__file__).resolve().parent
ROOT = TESTS.parent
SCRIPT_DIRS = ("benchmarks", "experiments")
# a path built to one of the script folders: "benchmarks", / "experiments", ...
PATH_TO_SCRIPTS = re.compile(r"""["'/](benchmarks|experiments)\b["'/]""")


def _script_modules() -> set[str]:
    """Top-level names a test could import from the script folders: their files' stems and
    their subfolders' names."""
    names: set[str] = set()
    for d in SCRIPT_DIRS:
        for p in (ROOT / d).glob("**/*.py"):
            names.add(p.stem)
        names |= (
            {p.name for p in (ROOT / d).iterdir() if p.is_dir()} if (ROOT / d).is_dir() else set()
        )
    return names - {"conftest", "__init__"}


def _offences(path: Path, scripts: set[str]) -> list[str]:
    src = path.read_text()
    found = []
    for node in ast.walk(ast.parse(src)):
        if isinstance(node, ast.Import):
            mods = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            mods = [node.module]
        else:
            mods = []
        for m in mods:
            top = m.split(".")[0]
            if top in SCRIPT_DIRS or top in scripts:
                found.append(f"line {node.lineno}: imports {m}")
    for n, line in enumerate(src.splitlines(), 1):
        code = line.split("#", 1)[0]
        if PATH_TO_SCRIPTS.search(code) and (
            "Path(" in code or "sys.path" in code or "load_script" in code or "parents[" in code
        ):
            found.append(f"line {n}: a path into a script folder: {line.strip()}")
    return found


def test_no_test_imports_an_experiment_or_benchmark_script() -> None:
    scripts = _script_modules()
    assert "contact_newton" in scripts  # the scan sees the experiments' scripts
    bad = {
        p.relative_to(ROOT).as_posix(): o
        for p in sorted(TESTS.glob("**/*.py"))
        if p.name != Path(__file__).name and (o := _offences(p, scripts))
    }
    assert not bad, f"tests that import scripts (move them to experiments/<q>/check_*.py): {bad}"


def test_the_scan_finds_an_import_and_a_path(tmp_path: Path) -> None:
    """The scan is not vacuous: it flags a script import and a path built into experiments/."""
    bad = tmp_path / "test_bad.py"
    bad.write_text(
        "import contact_newton\n"
        "from pathlib import Path\n"
        'BENCH = Path(__file__).parents[1] / "experiments"\n'
    )
    found = _offences(bad, _script_modules())
    assert len(found) == 2, found

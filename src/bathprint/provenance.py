"""Which code produced a result: the bathprint version and, in a git checkout, its commit.

Resumable work (sweeps, the reproductions) records this with every row, so that rows a
different version of the code computed can be told apart from new ones when it resumes.
"""

from __future__ import annotations

import functools
import subprocess
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent


def _git(*args: str) -> str | None:
    try:
        out = subprocess.run(
            ["git", *args], cwd=_PACKAGE, capture_output=True, text=True, check=True, timeout=10
        )
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip()


@functools.cache
def code_version() -> dict[str, str | None]:
    """``{"bathprint": version, "commit": hash}``. The commit is the short hash of HEAD, with
    ``-dirty`` when the package's tracked files differ from it, or None outside a git
    checkout that tracks this package (an installed wheel)."""
    from bathprint import __version__

    commit = None
    if _git("ls-files", "--error-unmatch", "__init__.py") is not None:
        # seven hex digits always: --short grows with the repository's object count
        head = (_git("rev-parse", "HEAD") or "")[:7]
        if head:
            dirty = _git("status", "--porcelain", "--untracked-files=no", "--", ".")
            commit = head + ("-dirty" if dirty else "")
    return {"bathprint": __version__, "commit": commit}


def first_commit(path: str | Path) -> str | None:
    """``"YYYY-MM-DD abcdef1"``: the date and commit that first added ``path`` to the git
    repository holding it (seven hex digits, as :func:`code_version`), or None when git does
    not track it."""
    path = Path(path).resolve()
    if not path.parent.is_dir():
        return None
    try:
        out = subprocess.run(
            ["git", "log", "--diff-filter=A", "--format=%cs %H", "--", path.name],
            cwd=path.parent, capture_output=True, text=True, check=True, timeout=10,
        ).stdout.split()
    except (OSError, subprocess.SubprocessError):
        return None
    return f"{out[-2]} {out[-1][:7]}" if len(out) >= 2 else None

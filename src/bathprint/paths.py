"""Output paths, checked before long work starts: a run must not end in a path it cannot write.

:func:`check_output_dir` and :func:`check_output_file` really try: they create the missing
directories and a temporary file, then remove what they created, so that permissions,
read-only file systems and paths below a regular file are all found (also as root, where
``os.access`` says yes to everything). They raise :class:`~bathprint.errors.OptionError`
naming the option, the path and what is allowed.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from bathprint.errors import OptionError

__all__ = ["check_output_dir", "check_output_file"]


def _refuse(option: str, path: Path, why: str, allowed: str) -> OptionError:
    return OptionError(f"{option} = {str(path)!r} {why}; allowed: {allowed}")


def _probe_dir(option: str, path: Path, target: Path, allowed: str) -> None:
    """Make ``path`` (a directory) if missing, write and delete a file in it, then remove the
    directories made here. ``target`` is the path the user gave (for the message)."""
    missing: list[Path] = []
    p = path
    while not p.exists() and not p.is_symlink():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    if p.exists() and not p.is_dir():
        why = "is below a file" if p != target else "is an existing file, not a directory"
        raise _refuse(option, target, f"{why} ({str(p)!r})" if p != target else why, allowed)
    made: list[Path] = []
    try:
        for d in reversed(missing):
            d.mkdir()
            made.append(d)
        fd, tmp = tempfile.mkstemp(prefix=".bathprint-write-test-", dir=path)
        os.close(fd)
        os.unlink(tmp)
    except OSError as exc:
        why = f"cannot be written ({exc.strerror or exc})"
        raise _refuse(option, target, why, allowed) from None
    finally:
        for d in reversed(made):  # deepest first
            try:
                d.rmdir()
            except OSError:
                pass


def check_output_dir(path: str | os.PathLike, option: str = "out_dir") -> Path:
    """``path`` as a Path, once it is known to be a writable directory or one that can be
    created; ``option`` names it in the error (``"--out"`` on the command line)."""
    allowed = "a writable directory, or a path where one can be created"
    if str(path).strip() == "":
        raise OptionError(f"{option} = {str(path)!r} is empty; allowed: {allowed}")
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise _refuse(option, p, "is an existing file, not a directory", allowed)
    _probe_dir(option, p, p, allowed)
    return p


def check_output_file(path: str | os.PathLike, option: str = "path") -> Path:
    """``path`` as a Path, once it is known to be a writable file or one that can be created
    (its directory included); an existing file is opened for appending, not changed."""
    allowed = "a writable file path (its directory is created if missing)"
    if str(path).strip() == "":
        raise OptionError(f"{option} = {str(path)!r} is empty; allowed: {allowed}")
    p = Path(path)
    if p.is_dir():
        raise _refuse(option, p, "is a directory", allowed)
    if p.exists():
        try:
            with open(p, "ab"):
                pass
        except OSError as exc:
            raise _refuse(
                option, p, f"cannot be written ({exc.strerror or exc})", allowed
            ) from None
        return p
    _probe_dir(option, p.parent, p, allowed)
    return p

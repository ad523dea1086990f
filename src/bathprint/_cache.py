"""Keep numba's on-disk cache consistent with the kernel sources.

numba invalidates a cached function only when its own file changes, not when a kernel
it calls (in another module) does. Before the first kernel of a process compiles or loads
(:func:`bathprint.core.model.compile_model`, which every simulation and environment goes
through, and :func:`bathprint.warmup.ensure_compiled`), :func:`ensure_fresh_cache` hashes
the kernel source files and wipes the package's cached machine code when the hash differs
from the one stored beside it, so an edited or upgraded install never runs stale kernels.
A kernel that calls none in another module needs no check (numba invalidates it itself);
those that do (the simulator's, the environments' step) run on a compiled model, after the
check. Importing bathprint reads and deletes nothing.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_STAMP_NAME = "kernel_sources.sha1"  # in the package's top __pycache__
_CHECKED = False  # this process has checked the cache (once is enough: sources are loaded)


@functools.cache
def _sources_hash() -> str:
    """Hash of the kernel sources: modules with numba functions, and the index layout
    and the records (their constants and types are compiled into the kernels), and the
    kernels' compile options (core/jit.py). Other modules do not invalidate. Computed once
    per process (it reads every source file, and the environments' target caches key on it
    at every reset)."""
    h = hashlib.sha1()
    for path in sorted(_PACKAGE.rglob("*.py")):
        text = path.read_bytes()
        if b"njit" in text or path.name in ("layout.py", "records.py", "jit.py"):
            h.update(path.relative_to(_PACKAGE).as_posix().encode())
            h.update(text)
    return h.hexdigest()


def wipe_if_stale(package: Path, digest: str) -> bool:
    """Delete the cached numba code (``*.nbi``, ``*.nbc``) under ``package`` unless the
    stamp in ``package/__pycache__`` holds ``digest``; then store ``digest`` there.
    Returns whether it wiped."""
    stamp = package / "__pycache__" / _STAMP_NAME
    if stamp.exists() and stamp.read_text() == digest:
        return False
    for pattern in ("*.nbi", "*.nbc"):
        for f in package.rglob(pattern):
            f.unlink(missing_ok=True)
    stamp.parent.mkdir(exist_ok=True)
    stamp.write_text(digest)
    return True


def ensure_fresh_cache() -> None:
    """Once per process, before any kernel loads: delete the package's cached numba code if
    any kernel source changed since it was built (:func:`wipe_if_stale`)."""
    global _CHECKED
    if _CHECKED:
        return
    _CHECKED = True
    try:
        wipe_if_stale(_PACKAGE, _sources_hash())
    except OSError:
        # a read-only install: numba falls back to its own cache locations
        pass

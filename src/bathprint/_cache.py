"""Keep numba's on-disk cache consistent with the kernel sources.

numba invalidates a cached function only when its own file changes, not when a kernel
it calls (in another module) does. At import we hash the kernel source files and wipe
the package's cached machine code when the hash differs from the one stored beside it,
so an edited or upgraded install never runs stale kernels.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_STAMP = _PACKAGE / "__pycache__" / "kernel_sources.sha1"


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


def ensure_fresh_cache() -> None:
    """Delete cached numba code (*.nbi, *.nbc) if any kernel source changed since it was built."""
    try:
        digest = _sources_hash()
        if _STAMP.exists() and _STAMP.read_text() == digest:
            return
        for pattern in ("*.nbi", "*.nbc"):
            for f in _PACKAGE.rglob(pattern):
                f.unlink(missing_ok=True)
        _STAMP.parent.mkdir(exist_ok=True)
        _STAMP.write_text(digest)
    except OSError:
        # a read-only install: numba falls back to its own cache locations
        pass

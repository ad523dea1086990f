"""tests/test_measure.py and tests/test_theory.py with other CPUs' BLAS kernels.

numpy and scipy ship OpenBLAS built with DYNAMIC_ARCH: ``OPENBLAS_CORETYPE`` makes it run
another CPU's kernels on this machine, whose different blocking and FMA use change the
round-off of every matrix product, fit and eigenvalue. The measurements and the linear
stability theory must not decide anything by that round-off, so the two test files run again
in subprocesses with the Prescott (SSE3, no FMA) and SkylakeX (AVX-512) kernels. A variant is
skipped, with the reason, when the CPU lacks the instructions the kernels use (by its
/proc/cpuinfo flags), or when the loaded BLAS does not report running the requested kernels
(not OpenBLAS, no DYNAMIC_ARCH, no way to ask).
"""

from __future__ import annotations

import functools
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

import bathprint

ROOT = Path(__file__).resolve().parents[1]
FILES = ("tests/test_measure.py", "tests/test_theory.py")
# Core names OpenBLAS reports for a requested core type it runs under another name (without
# DYNAMIC_OLDER the Prescott kernels are the Katmai table).
ALIASES = {"prescott": {"prescott", "katmai"}}
# Instruction-set flags (Linux /proc/cpuinfo) a core type's kernels execute: OpenBLAS honours
# OPENBLAS_CORETYPE even on a CPU without them, and the subprocess then dies of SIGILL.
REQUIRED_FLAGS = {
    "prescott": {"pni"},  # SSE3, as Linux names it
    "skylakex": {"avx512f", "avx512bw", "avx512cd", "avx512dq", "avx512vl"},
}


def _missing_flags(coretype: str) -> set[str] | None:
    """The flags ``coretype``'s kernels need that this CPU lacks (None: flags unknown)."""
    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return None
    flags = next((line.split(":", 1)[1].split() for line in text.splitlines()
                  if line.startswith("flags")), None)  # fmt: skip
    if flags is None:
        return None
    return REQUIRED_FLAGS.get(coretype.lower(), set()) - set(flags)


# Prints a JSON list of the core names reported by every OpenBLAS library loaded by numpy and
# scipy.linalg (numpy and scipy each bundle their own), or an error string.
_PROBE = r"""
import ctypes, json
import numpy, scipy.linalg
names = []
try:
    import threadpoolctl
    names = [i.get("architecture") for i in threadpoolctl.threadpool_info()
             if i.get("internal_api") == "openblas"]
except ImportError:
    pass
if not names:
    try:
        with open("/proc/self/maps") as f:
            paths = sorted({ln.split(None, 5)[5].strip() for ln in f
                            if len(ln.split(None, 5)) == 6 and "openblas" in ln.lower()})
    except OSError:
        paths = []
    for p in paths:
        try:
            lib = ctypes.CDLL(p)
        except OSError:
            continue
        for fn in ("openblas_get_corename", "openblas_get_corename64_",
                   "scipy_openblas_get_corename64_", "scipy_openblas_get_corename"):
            try:
                f = getattr(lib, fn)
            except AttributeError:
                continue
            f.restype = ctypes.c_char_p
            names.append(f().decode())
            break
print(json.dumps(names))
"""


def _env(coretype: str | None) -> dict[str, str]:
    """This environment, with this test run's bathprint first on the path."""
    env = dict(os.environ)
    env.pop("OPENBLAS_CORETYPE", None)
    if coretype is not None:
        env["OPENBLAS_CORETYPE"] = coretype
    src = str(Path(bathprint.__file__).resolve().parents[1])
    env["PYTHONPATH"] = os.pathsep.join([src, *filter(None, [env.get("PYTHONPATH")])])
    return env


@functools.cache
def _core_names(coretype: str) -> tuple[str, ...] | str:
    """Core names the loaded OpenBLAS libraries report under OPENBLAS_CORETYPE=coretype, or
    why they cannot be read."""
    proc = subprocess.run(
        [sys.executable, "-c", _PROBE],
        env=_env(coretype),
        capture_output=True,
        text=True,
        timeout=60,
    )
    if proc.returncode != 0:
        return f"the probe exited with {proc.returncode}: {proc.stderr.strip()[-300:]}"
    names = json.loads(proc.stdout.strip().splitlines()[-1])
    if not names:
        return "no OpenBLAS library reporting its core name is loaded by numpy/scipy"
    return tuple(names)


@pytest.mark.parametrize("coretype", ["Prescott", "SkylakeX"])
def test_measure_and_theory_pass_with_other_blas_kernels(coretype: str) -> None:
    missing = _missing_flags(coretype)
    if missing:
        pytest.skip(f"OPENBLAS_CORETYPE={coretype}: this CPU lacks {sorted(missing)}")
    names = _core_names(coretype)
    if isinstance(names, str):
        pytest.skip(f"OPENBLAS_CORETYPE={coretype} cannot be checked: {names}")
    wanted = ALIASES.get(coretype.lower(), {coretype.lower()})
    if not all(n.lower() in wanted for n in names):
        pytest.skip(
            f"OPENBLAS_CORETYPE={coretype} is not honoured here (the BLAS runs {list(names)}: "
            "no DYNAMIC_ARCH build, or a CPU that cannot run those kernels)"
        )
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *FILES],
        cwd=ROOT,
        env=_env(coretype),
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, (
        f"with OPENBLAS_CORETYPE={coretype} ({names}):\n{proc.stdout[-4000:]}{proc.stderr[-2000:]}"
    )

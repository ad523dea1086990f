"""numba's on-disk cache is wiped when a kernel source changed, before the first kernel of a
process loads, and never by ``import bathprint``."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import bathprint
from bathprint import _cache, warmup
from bathprint.core.model import compile_model
from bathprint.core.scene import load_scene

SRC = Path(bathprint.__file__).resolve().parents[1]


def test_import_deletes_nothing() -> None:
    """An audit hook sees every file removal of ``import bathprint`` (and of the modules
    the commands import) and every opening of the cache's stamp: there is none (a removal
    would be refused by the hook, so the test itself never wipes the cache)."""
    code = (
        "import sys\n"
        "seen = []\n"
        "def hook(event, args):\n"
        "    if event in ('os.remove', 'os.unlink', 'os.rmdir', 'shutil.rmtree'):\n"
        "        seen.append(args[0])\n"
        "        raise PermissionError('no removal at import')\n"
        "    if event == 'open' and str(args[0]).endswith('kernel_sources.sha1'):\n"
        "        seen.append(args[0])\n"
        "sys.addaudithook(hook)\n"
        "import bathprint, bathprint.run, bathprint.cli\n"
        "assert seen == [], seen\n"
        "print('clean')\n"
    )
    env = {"PYTHONPATH": str(SRC), "PATH": "/usr/bin:/bin"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "clean"


def _tree(root: Path) -> list[Path]:
    files = [
        root / "__pycache__" / "a.f-10.py311.nbi",
        root / "__pycache__" / "a.f-10.py311.1.nbc",
        root / "core" / "__pycache__" / "b.g-3.py311.nbi",
        root / "core" / "__pycache__" / "b.cpython-311.pyc",
        root / "core" / "b.py",
    ]
    for f in files:
        f.parent.mkdir(parents=True, exist_ok=True)
        f.write_text("x")
    return files


def test_a_stale_cache_is_wiped_and_a_fresh_one_kept(tmp_path: Path) -> None:
    nbi, nbc, nested, pyc, source = _tree(tmp_path)
    stamp = tmp_path / "__pycache__" / "kernel_sources.sha1"
    assert _cache.wipe_if_stale(tmp_path, "old")  # no stamp: unknown age, wiped
    assert not nbi.exists() and not nbc.exists() and not nested.exists()
    assert pyc.exists() and source.exists()  # only numba's files go
    assert stamp.read_text() == "old"
    nbi.write_text("rebuilt")
    assert not _cache.wipe_if_stale(tmp_path, "old")  # the same sources: kept
    assert nbi.read_text() == "rebuilt"
    assert _cache.wipe_if_stale(tmp_path, "new")  # a kernel source changed: wiped
    assert not nbi.exists()
    assert stamp.read_text() == "new"


def test_the_first_model_checks_the_cache_once(monkeypatch) -> None:
    """compile_model (every simulation and environment) and the warm-up check the cache
    before any kernel loads, once per process, on the package's own sources."""
    calls: list[tuple[Path, str]] = []
    monkeypatch.setattr(_cache, "_CHECKED", False)
    monkeypatch.setattr(_cache, "wipe_if_stale", lambda p, d: calls.append((p, d)) or False)
    scene = load_scene("paper_simulation")
    compile_model(scene)
    compile_model(scene)
    monkeypatch.setattr(warmup, "_DONE", False)
    monkeypatch.setattr(warmup, "_run_tiny", lambda: None)
    warmup.ensure_compiled(announce=False)
    assert calls == [(_cache._PACKAGE, _cache._sources_hash())]
    assert _cache._PACKAGE == Path(bathprint.__file__).resolve().parent


def test_a_read_only_install_is_left_alone(monkeypatch) -> None:
    def refuse(package: Path, digest: str) -> bool:
        raise PermissionError(f"{package} is read-only")

    monkeypatch.setattr(_cache, "_CHECKED", False)
    monkeypatch.setattr(_cache, "wipe_if_stale", refuse)
    _cache.ensure_fresh_cache()  # numba falls back to its own cache locations
    assert _cache._CHECKED

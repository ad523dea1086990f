"""Where the top-level ``envs/`` specs and ``agents/`` files are read from.

In a source checkout (and an editable install) they are the repository's own directories;
a regular ``pip install .`` installs copies under ``<prefix>/share/bathprint/`` (the
``data-files`` of pyproject.toml). An environment variable overrides both.
"""

from __future__ import annotations

import os
import sysconfig
from pathlib import Path

_CHECKOUT = Path(__file__).resolve().parents[2]  # src/bathprint/ -> repository root


def shared_dir(name: str, env_var: str) -> Path:
    """``$env_var`` if set; else the checkout's ``name/`` if it exists; else the installed
    copy in ``<prefix>/share/bathprint/name`` (returned even if missing, for the error)."""
    override = os.environ.get(env_var)
    if override:
        return Path(override)
    checkout = _CHECKOUT / name
    if checkout.is_dir():
        return checkout
    return Path(sysconfig.get_path("data")) / "share" / "bathprint" / name

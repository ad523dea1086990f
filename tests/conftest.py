"""Shared fixtures. Scenes are kept small so that the whole suite runs in minutes."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")

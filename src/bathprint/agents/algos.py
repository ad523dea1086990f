"""The algorithms ``bathprint train`` offers, named without importing any of them (the
command line lists them in its help with only the core installed)."""

from __future__ import annotations

#: the algorithms bathprint trains (``tqc`` from sb3-contrib)
ALGOS = ("ppo", "sac", "tqc")
#: off-policy algorithms (a replay buffer travels with their checkpoints)
OFF_POLICY = ("sac", "tqc")

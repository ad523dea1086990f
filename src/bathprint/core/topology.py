"""Which nodes move and which segments are filament: clamped to the needle, or free.

Clamped (the usual case): nodes 0..n-3 are free, node n-2 is the needle tip and node n-1
a ghost inside the needle that fixes the tangent; segments 0..n-3 are filament and
segment n-2 is the ghost's. Free (after ``needle.release_s``): every node moves and
segments 0..n-2 are all filament. ``p`` is the model's parameter record.
"""

from __future__ import annotations

from numba import njit

from bathprint.core.jit import KERNEL


@njit(**KERNEL, inline="always")
def free_nodes(n_nodes: int, p) -> int:
    """Number of nodes the integrator moves."""
    return n_nodes - 2 if p.clamped else n_nodes


@njit(**KERNEL, inline="always")
def filament_segments(n_nodes: int, p) -> int:
    """Number of material segments (the ghost segment excluded)."""
    return n_nodes - 2 if p.clamped else n_nodes - 1

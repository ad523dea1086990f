"""Moving the needle step by step: rewrite the simulation's needle table in place."""

from __future__ import annotations

import numpy as np

from bathprint.core.extrusion import needle_state
from bathprint.core.simulation import Simulation

KEEP_ROWS = 8  # past rows kept: material records look up the needle direction at birth


def needle_at(sim: Simulation, t: float) -> tuple[np.ndarray, np.ndarray]:
    """Needle tip position (m) and unit direction at time t (s)."""
    p, d, v = np.empty(3), np.empty(3), np.empty(3)
    needle_state(sim.model.needle, float(t), p, d, v)
    return p, d


def move_needle(sim: Simulation, velocity_m_s: np.ndarray, t_end: float) -> None:
    """From now (``sim.t``) to ``t_end`` (s) the needle tip moves at ``velocity_m_s`` (m/s,
    direction unchanged); after ``t_end`` it stays where it arrived.

    The table ``sim.model.needle`` ([t, x, y, z, dx, dy, dz] rows, times strictly rising,
    last row held) is rebuilt: the last ``KEEP_ROWS`` rows before now, a row now, a row at
    ``t_end``.
    """
    t = sim.t
    if not t_end > t:
        raise ValueError(f"t_end = {t_end!r} must be after the current time {t!r}")
    p, d = needle_at(sim, t)
    table = sim.model.needle
    # rows before now (times strictly rising: the first k), the last KEEP_ROWS of them
    k = int(np.searchsorted(table[:, 0], t, side="left"))
    past = table[max(0, k - KEEP_ROWS) : k]
    m = len(past)
    rows = np.empty((m + 2, 7))
    rows[:m] = past
    rows[m, 0] = t
    rows[m, 1:4] = p
    rows[m, 4:7] = d
    rows[m + 1, 0] = t_end
    rows[m + 1, 1:4] = p + np.asarray(velocity_m_s, float) * (t_end - t)
    rows[m + 1, 4:7] = d
    sim.model.needle = rows

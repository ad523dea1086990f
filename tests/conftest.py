"""Shared fixtures. Scenes are kept small so that the whole suite runs in minutes."""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


@pytest.fixture
def pressed_stack():
    """A builder ``pressed_stack(n, **overrides)`` of a stress-free coil stack of n nodes
    (22G, radius 3 mm, 0.3 mm spacing) whose turns overlap by 2% of the sum of the radii:
    every turn is pressed onto the next, a chain of contacts as high as the stack (the stack
    of ``experiments/contact_cost/contact_cost.py``, with its contact
    law, the sharp onset of 0.02 delta
    from r_A + r_B that the tests' counts were measured with), with ``overrides`` as scene
    keys."""
    import math

    import numpy as np

    from bathprint import Simulation

    mm = 1e-3
    radius, pitch = 3 * mm, 0.98 * 2 * 0.205 * mm

    def build(n: int, **overrides: object) -> Simulation:
        dphi = 0.3 * mm / math.hypot(radius, pitch / (2 * math.pi))
        phi = dphi * np.arange(n)
        z = -50 * mm + pitch * phi / (2 * math.pi)
        pts = np.column_stack([radius * np.cos(phi), radius * np.sin(phi), z])
        scene = {"effects": ["elasticity", "drag", "gravity", "contact"], "duration_s": 1e3}
        scene |= {"contact.width_fraction": 0.02, "contact.distance_factor": 1.0}
        return Simulation.from_points(pts, "drag_coiling_22G", {**scene, **overrides}, relaxed=True)

    return build

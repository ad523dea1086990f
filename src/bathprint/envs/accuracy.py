"""Accuracy presets of the environments: named sets of ``numerics.*`` scene overrides.

The environments' ``accuracy`` argument picks one. They trade the simulator's fidelity for
speed; the task (control interval, target, metric) is the same under every preset.

=========  =================  =========  ===============  ============  ===========  ==========
preset     integrator         tolerance  node spacing mm  inlet growth  Newton tol.  frozen mm
=========  =================  =========  ===============  ============  ===========  ==========
draft      implicit (SDIRK2)  0.1        0.8              4             0.1 (full)   beyond 20
balanced   implicit (SDIRK2)  0.03       0.6              4             0.1 (full)   beyond 60
fine       implicit (SDIRK2)  1e-3       0.3              0.5           0.01         never
=========  =================  =========  ===============  ============  ===========  ==========

(tolerance: local error per step relative to the node spacing; inlet growth: node spacings
extruded per adaptive step at most; see the README's Scenes table; "(full)": full Newton
where the core offers the choice, ``numerics.newton``; fine keeps the core's default;
"frozen": ``numerics.freeze_beyond_mm``, material further behind the needle leaves the
solve and moves with the active filament as one lumped drag and weight, see
:mod:`bathprint.core.freezing`. On random-action episodes draft's freezing changes the final
metric 2.0-5.9x less than the draft preset differs from balanced
(``experiments/freezing/freezing.py``); balanced freezes beyond 60 mm, where the steady coil
moves less than the balanced tolerance admits. Draft also bounds steps at 8 e-folding times
of the fastest buckling mode (``numerics.buckling_steps`` = 1/8, the core's default being
1): up to h sigma = 11.7 an SDIRK2 step still amplifies a growing buckle, so buckling is
not suppressed, only its growth less accurate; against 1/8 the final metric moves by
0.002-0.013.)
Draft and balanced pin ``numerics.freeze_joint = "free"`` (the tail takes no moment), the
joint every registered environment version was measured with; the core's default joint
is clamped. ``fine`` is the built-in scenes' own resolution. Coil radius of CoilRadius-v0
at constant Q_o = 0.5 / 1 / 2 ml/min (median over the scored part): fine 3.70 / 2.77 / 2.11 mm,
balanced +2.1 / -2.2 / +0.2 %, draft +1.5 / +0.5 / +9.8 % (with the freezing and buckling
bounds above; without them balanced was within 2 %, draft 2-11 % too large). Measured
costs: ``experiments/env_speed/env_speed.py``.
"""

from __future__ import annotations

import dataclasses
from typing import Any

ACCURACY_PRESETS: dict[str, dict[str, Any]] = {
    "draft": {
        "numerics.integrator": "implicit",
        "numerics.tolerance": 0.1,
        "numerics.newton_tolerance": 0.1,
        "numerics.node_spacing_mm": 0.8,
        "numerics.max_inlet_growth": 4.0,
        "numerics.min_step_s": 1e-7,
        "numerics.freeze_beyond_mm": 20.0,
        "numerics.freeze_joint": "free",
        "numerics.buckling_steps": 0.125,
    },
    "balanced": {
        "numerics.integrator": "implicit",
        "numerics.tolerance": 0.03,
        "numerics.newton_tolerance": 0.1,
        "numerics.node_spacing_mm": 0.6,
        "numerics.max_inlet_growth": 4.0,
        "numerics.min_step_s": 1e-8,
        "numerics.freeze_beyond_mm": 60.0,
        "numerics.freeze_joint": "free",
    },
    "fine": {
        "numerics.integrator": "implicit",
        "numerics.tolerance": 1e-3,
        "numerics.newton_tolerance": 0.01,
        "numerics.node_spacing_mm": 0.3,
        "numerics.max_inlet_growth": 0.5,
    },
}


def accuracy_overrides(accuracy: str) -> dict[str, Any]:
    """Scene overrides of a preset (a copy). Raises ValueError for an unknown name."""
    if accuracy not in ACCURACY_PRESETS:
        raise ValueError(
            f"accuracy = {accuracy!r}; allowed: " + ", ".join(repr(k) for k in ACCURACY_PRESETS)
        )
    out = dict(ACCURACY_PRESETS[accuracy])
    # Keys of newer cores: keep the core's own preset switch on "custom" (the raw keys above
    # are what runs); draft and balanced use full Newton (a factorisation per iteration):
    # modified Newton fails to converge on about every other step at their loose tolerances
    # and 4-spacing steps (2.5x slower on CoilRadius-v0 draft), while at fine it is 2x faster.
    from bathprint.core.scene import Numerics

    fields = {f.name for f in dataclasses.fields(Numerics)}
    if "accuracy" in fields:
        out["numerics.accuracy"] = "custom"
    if "newton" in fields and accuracy in ("draft", "balanced"):
        out["numerics.newton"] = "full"
    return out

"""Numerics that cannot resolve the scene's buckling are refused when the scene loads.

The length a scene must resolve is the buckling length of the paper's scaling analysis
("Instability-induced patterning of a jelling jet", section "Scaling analysis and stability
theory"), drag and gravity together: l = (B / (mu v + drho g r^2))^(1/3). B is the bending
stiffness of the material as it leaves the needle (age 0: ``material.youngs_modulus_pa``,
or gelation's initial or core modulus: the softest the scene extrudes, so the shortest l),
v the fastest exit speed of the flow schedule, mu the bath's viscosity (the constant of
``drag.model = "constant"``), drho the density difference of the alginate and the bath
(either end of a gradient) and r the filament's radius. A coil has radius R = 0.4 l (the
paper's Fig. 2B fit), so one turn is 2 pi R = 2.5 l of filament.

* Node spacing (after the accuracy preset): the rod bends only at its nodes, so a segment
  longer than a coil turn cannot coil at all and is refused (:class:`SceneError`); one
  longer than l / 2, fewer than 5 segments per turn, runs but coarsely and is warned about
  (:class:`CoarseNumericsWarning`). The built-in scenes and the environments' presets use at
  most 0.47 l.
* Fixed step (``numerics.time_step_s`` > 0): the inlet segment grows straight during a step
  and is cut into node spacings when the step is accepted
  (:func:`bathprint.core.extrusion.split_inlet` peels one spacing off at a time, so a step
  that extrudes several spacings keeps the spacing). A fixed step that extrudes more than
  a coil turn, v dt > 2.5 l, lays that turn down straight: refused. Adaptive steps are
  bounded by the extrusion (``numerics.max_inlet_growth``), the buckling rate
  (``numerics.buckling_steps``) and the error controller; ``numerics.max_step_s`` only caps
  them, so it is not checked.
* No duration is refused: a run shorter than the onset of buckling is a valid question
  (the straight jet, the first millimetres of a print, a test).

The inlet's own lower bound, a node spacing of at least 0.2 filament radii, is checked with
the other scene keys (:mod:`bathprint.core.scene`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

from bathprint.errors import CoarseNumericsWarning, SceneError

if TYPE_CHECKING:
    from bathprint.core.scene import Scene

MM = 1e-3  # m per mm
ML_MIN = 1e-6 / 60.0  # m^3/s per ml/min

PAPER_R_PREFACTOR = 0.4  # coil radius R = 0.4 (B/(mu v))^(1/3), the paper's Fig. 2B fit
TURN_LENGTHS = 2.0 * math.pi * PAPER_R_PREFACTOR  # one coil turn, 2 pi R, in buckling lengths
COARSE_FRACTION = 0.5  # a piece longer than this many buckling lengths: fewer than 5 per turn


def gravity_drag_length(
    B: float, mu: float, v: float, drho: float, r: float, g: float = 9.81
) -> float:
    """Buckling length (B/(mu v + drho g r^2))^(1/3) in m interpolating drag and gravity coiling.

    drho is the filament-bath density difference in kg/m^3 and r the filament radius in m.
    """
    if B <= 0:
        raise ValueError(f"B must be positive, got {B!r}")
    denominator = mu * v + drho * g * r**2
    if denominator <= 0:
        raise ValueError("mu v + drho g r^2 must be positive")
    return (B / denominator) ** (1.0 / 3.0)


def _below(x: float) -> str:
    """``x`` to 3 significant digits, rounded down (a limit quoted as allowed must be)."""
    if x <= 0.0 or not math.isfinite(x):
        return f"{x:g}"
    scale = 10.0 ** (math.floor(math.log10(x)) - 2)
    return f"{math.floor(x / scale) * scale:.3g}"


@dataclass(frozen=True)
class BucklingLength:
    """The scene's buckling length ``l_m`` (m; inf when nothing buckles the filament: no
    flow and no weight), its fastest exit speed ``v_m_s`` (m/s) and the scene keys they were
    computed from, as ``key = value`` text."""

    l_m: float
    v_m_s: float
    inputs: tuple[str, ...]

    def describe(self) -> str:
        """``l = ... mm (B / (mu v + drho g r^2))^(1/3) from key = value, ...)``."""
        return (
            f"the buckling length l = (B/(mu v + drho g r^2))^(1/3) = {self.l_m / MM:.3g} mm "
            f"(from {', '.join(self.inputs)})"
        )


def _exit_modulus(scene: Scene) -> tuple[float, str]:
    """Young's modulus of the material as it leaves the needle (age 0), and its key."""
    gel = scene.gelation
    if "gelation" in scene.effects and gel.model == "surface":  # no shell yet: the core
        return gel.core_modulus_pa, f"gelation.core_modulus_pa = {gel.core_modulus_pa:g}"
    if "gelation" in scene.effects:
        return gel.initial_modulus_pa, f"gelation.initial_modulus_pa = {gel.initial_modulus_pa:g}"
    e = scene.material.youngs_modulus_pa
    return e, f"material.youngs_modulus_pa = {e:g}"


def _flow_keys(scene: Scene) -> str:
    """The keys that set the flow: the schedule, or the constant rates."""
    if scene.flow.schedule_csv:
        return "flow.schedule_csv"
    if scene.flow.schedule:
        return "flow.schedule"
    if scene.flow.q_inner_ml_min > 0.0:
        return "flow.q_outer_ml_min + flow.q_inner_ml_min"
    return "flow.q_outer_ml_min"


def buckling_length(scene: Scene, flow_rows: list[list[float]]) -> BucklingLength:
    """The shortest buckling length of ``scene`` (see the module's docstring); ``flow_rows``
    its flow schedule as rows [t_s, q_outer_ml_min, q_inner_ml_min]."""
    d = scene.needle.inner_diameter_mm * MM
    r = scene.material.radius_mm * MM or d / 2.0
    e, e_key = _exit_modulus(scene)
    bending = e * math.pi * r**4 / 4.0
    inputs = [e_key, f"needle.inner_diameter_mm = {scene.needle.inner_diameter_mm:g}"]
    if scene.material.radius_mm:
        inputs.append(f"material.radius_mm = {scene.material.radius_mm:g}")
    q = max(qo + qi for _, qo, qi in flow_rows) * ML_MIN
    v = q / (math.pi * d * d / 4.0)  # the fastest exit speed, m/s
    mu = drho = 0.0
    g = scene.bath.gravity_m_s2
    if "drag" in scene.effects:
        mu = scene.bath.viscosity_pa_s
        if scene.drag.model == "constant" and scene.drag.coefficient_pa_s > 0.0:
            mu = scene.drag.coefficient_pa_s
            inputs.append(f"drag.coefficient_pa_s = {mu:g}")
        else:
            inputs.append(f"bath.viscosity_pa_s = {mu:g}")
        inputs.append(f"{_flow_keys(scene)}: v = {v / MM:.3g} mm/s at most")
    if "gravity" in scene.effects and g > 0.0:
        baths = [scene.bath.density_kg_m3]
        if scene.bath.density_bottom_kg_m3:
            baths.append(scene.bath.density_bottom_kg_m3)
        drho = max(abs(scene.material.density_kg_m3 - rho) for rho in baths)
        if drho > 0.0:
            inputs.append(
                f"material.density_kg_m3 = {scene.material.density_kg_m3:g}, bath.density_kg_m3"
                f" = {scene.bath.density_kg_m3:g}, bath.gravity_m_s2 = {g:g}"
            )
            if scene.bath.density_bottom_kg_m3:
                inputs.append(f"bath.density_bottom_kg_m3 = {scene.bath.density_bottom_kg_m3:g}")
    if mu * v + drho * g * r * r <= 0.0:
        return BucklingLength(math.inf, v, tuple(inputs))
    return BucklingLength(gravity_drag_length(bending, mu, v, drho, r, g), v, tuple(inputs))


def check_resolution(
    scene: Scene, spacing_mm: float, flow_rows: list[list[float]]
) -> BucklingLength:
    """Refuse (:class:`SceneError`) numerics that cannot resolve ``scene``'s buckling length
    and warn (:class:`CoarseNumericsWarning`) where they resolve it coarsely; see the
    module's docstring. ``spacing_mm`` is the node spacing after the accuracy preset,
    ``flow_rows`` the flow schedule as rows [t_s, q_outer_ml_min, q_inner_ml_min]. Returns
    the buckling length."""
    bl = buckling_length(scene, flow_rows)
    if not math.isfinite(bl.l_m):
        return bl
    turn = TURN_LENGTHS * bl.l_m  # one coil turn, m
    n = scene.numerics
    factor = spacing_mm / n.node_spacing_mm  # the accuracy preset's scaling of the spacing
    preset = f" (x {factor:g} by numerics.accuracy = {n.accuracy!r})" if factor != 1.0 else ""
    spacing = spacing_mm * MM
    if spacing > turn:
        raise SceneError(
            f"numerics.node_spacing_mm = {n.node_spacing_mm!r}{preset} cannot resolve "
            f"{bl.describe()}: one segment is longer than a coil turn, 2 pi R = 2.5 l = "
            f"{_below(turn / MM)} mm (R = 0.4 l, the paper's Fig. 2B), so the filament cannot "
            f"coil; allowed: numerics.node_spacing_mm <= {_below(turn / factor / MM)} here"
        )
    if scene.numerics.time_step_s > 0.0:
        _check_fixed_step(scene, bl, turn)
    if spacing > COARSE_FRACTION * bl.l_m:
        warnings.warn(
            f"numerics.node_spacing_mm = {n.node_spacing_mm!r}{preset} resolves "
            f"{bl.describe()} coarsely: fewer than {TURN_LENGTHS / COARSE_FRACTION:.0f} "
            "segments per coil turn, so coil shapes carry a large discretisation error; "
            f"numerics.node_spacing_mm <= {_below(COARSE_FRACTION * bl.l_m / factor / MM)} "
            "resolves it",
            CoarseNumericsWarning,
            stacklevel=4,
        )
    return bl


def _check_fixed_step(scene: Scene, bl: BucklingLength, turn: float) -> None:
    """A fixed step extrudes v dt, one straight piece: at most a coil turn."""
    dt = scene.numerics.time_step_s
    if bl.v_m_s * dt > turn:
        raise SceneError(
            f"numerics.time_step_s = {dt!r} extrudes {bl.v_m_s * dt / MM:.3g} mm per step, "
            f"which leaves the needle straight: longer than a coil turn, 2 pi R = 2.5 l = "
            f"{_below(turn / MM)} mm, with {bl.describe()}, so the filament cannot coil; "
            f"allowed: numerics.time_step_s <= {_below(turn / bl.v_m_s)} here (or 0: adaptive)"
        )

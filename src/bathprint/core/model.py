"""Compile a :class:`~bathprint.core.scene.Scene` into SI arrays the numba kernels read.

The model (static: parameters, effect flags, schedules) is kept apart from the state
(dynamic: node positions, velocities, material records), in the manner of MuJoCo's
MjModel / MjData.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from bathprint.core import layout as L
from bathprint.core.composite import INNER_FLUIDS
from bathprint.core.scene import ACCURACY_PRESETS, Scene, flow_rows
from bathprint.errors import SceneError

ML_MIN = 1e-6 / 60.0  # m^3/s per ml/min
MM = 1e-3  # m per mm


@dataclass
class Model:
    """Static, compiled description of a scene (SI units throughout)."""

    scene: Scene
    params: np.ndarray  # (N_PARAMS,) float64
    enabled: np.ndarray  # (N_EFFECTS,) int64, 1 for the effects the scene lists
    flow: np.ndarray  # (K, 3): t_s, q_outer_m3_s, q_inner_m3_s
    flow_cum: np.ndarray  # (K, 2): extruded length S (m) and inner volume (m^3) at each knot
    needle: np.ndarray  # (M, 7): t_s, position (m), direction
    integrator: int

    @property
    def node_spacing(self) -> float:
        return float(self.params[L.P_NODE_SPACING])

    @property
    def needle_area(self) -> float:
        return float(self.params[L.P_NEEDLE_AREA])

    @property
    def radius(self) -> float:
        return float(self.params[L.P_EXIT_RADIUS])

    @property
    def mu_s(self) -> float:
        return float(self.params[L.P_MU_S])

    @property
    def bending_stiffness(self) -> float:
        """B = E pi r^4 / 4 of the exit material (N m^2)."""
        return float(self.params[L.P_EXIT_YOUNGS_MODULUS] * math.pi * self.radius**4 / 4)

    def exit_speed(self, t: float = 0.0) -> float:
        """v = (Q_o + Q_i) / (pi d^2 / 4) at time t (m/s)."""
        from bathprint.core.extrusion import flow_rate

        qo, qi = flow_rate(self.flow, t)
        return (qo + qi) / self.needle_area


def slender_body_coefficient(scene: Scene, radius: float) -> float:
    """mu_s (Pa s): Cox's 2 pi mu / ln(L/r), or the scene's constant."""
    mu = scene.bath.viscosity_pa_s
    if scene.drag.model == "constant":
        return scene.drag.coefficient_pa_s or mu
    ratio = scene.drag.length_scale_mm * MM / radius
    if ratio < math.e:
        raise SceneError(
            f"drag.length_scale_mm = {scene.drag.length_scale_mm!r} gives ln(L/r) = "
            f"{math.log(ratio):.3g} < 1 for r = {radius / MM:g} mm; allowed: L > e r "
            "(slender-body theory needs L >> r)"
        )
    return 2.0 * math.pi * mu / math.log(ratio)


def _flow_table(scene: Scene) -> np.ndarray:
    table = np.array(flow_rows(scene), dtype=np.float64).reshape(-1, 3)
    table[:, 1:] *= ML_MIN
    return table


def flow_cumulative(flow: np.ndarray, area: float, start: tuple[float, float] | None = None):
    """[S, inner volume] at each knot; S(0) = 0 and a constant rate before the first knot,
    unless ``start`` gives the values at the first knot (vectorised: set_flow calls it)."""
    q = flow[:, 1] + flow[:, 2]
    dt = np.diff(flow[:, 0])
    cum = np.empty((len(flow), 2))
    cum[0] = start if start is not None else (flow[0, 0] * q[0] / area, flow[0, 0] * flow[0, 2])
    cum[1:, 0] = cum[0, 0] + np.cumsum(0.5 * (q[:-1] + q[1:]) * dt) / area
    cum[1:, 1] = cum[0, 1] + np.cumsum(0.5 * (flow[:-1, 2] + flow[1:, 2]) * dt)
    return cum


def _needle_table(scene: Scene) -> np.ndarray:
    n = scene.needle
    rows = n.path or [[0.0, *n.position_mm, *n.direction]]
    table = np.array(rows, dtype=np.float64).reshape(-1, 7)
    table[:, 1:4] *= MM
    for row in table:
        norm = np.linalg.norm(row[4:7])
        if norm < 1e-9:
            raise SceneError(f"needle.path row at t = {row[0]:g} s has a zero direction")
        row[4:7] /= norm
    return table


def effective_numerics(scene: Scene) -> dict[str, float]:
    """Tolerance, inlet growth and node spacing after the accuracy preset (if any)."""
    n = scene.numerics
    if n.accuracy == "custom":
        return {
            "tolerance": n.tolerance,
            "max_inlet_growth": n.max_inlet_growth,
            "node_spacing_mm": n.node_spacing_mm,
        }
    tol, growth, factor = ACCURACY_PRESETS[n.accuracy]
    return {
        "tolerance": tol,
        "max_inlet_growth": growth,
        "node_spacing_mm": n.node_spacing_mm * factor,
    }


MIN_ACTIVE_SPACINGS = 8  # the active filament keeps at least this many node spacings


def _freeze_beyond(scene: Scene, node_spacing_mm: float) -> float:
    """``numerics.freeze_beyond_mm``, checked: 0 (off) or at least ``MIN_ACTIVE_SPACINGS``
    node spacings, and not with end_load or inertia (the lumped tail of
    :mod:`bathprint.core.freezing` carries drag, net weight and floor friction only)."""
    value = scene.numerics.freeze_beyond_mm
    if value == 0.0:
        return 0.0
    if value < MIN_ACTIVE_SPACINGS * node_spacing_mm:
        raise SceneError(
            f"numerics.freeze_beyond_mm = {value!r} is shorter than {MIN_ACTIVE_SPACINGS} node "
            f"spacings ({MIN_ACTIVE_SPACINGS * node_spacing_mm:g} mm); allowed: 0 (off) or "
            "at least that"
        )
    if scene.initial.length_mm > value:
        raise SceneError(
            f"numerics.freeze_beyond_mm = {value!r} is shorter than initial.length_mm = "
            f"{scene.initial.length_mm!r}: the initial filament would freeze before it settles; "
            "allowed: at least initial.length_mm"
        )
    clash = [e for e in ("end_load", "inertia") if e in scene.effects]
    if clash:
        raise SceneError(
            f"numerics.freeze_beyond_mm = {value!r} with the {clash[0]} effect: the frozen tail "
            "is lumped into drag, net weight and floor friction at the active end (no end load "
            f"or tail mass); allowed: 0 with {clash[0]}"
        )
    return value


def compile_model(scene: Scene) -> Model:
    """Turn a validated scene into the arrays of a :class:`Model`."""
    p = np.zeros(L.N_PARAMS)
    d = scene.needle.inner_diameter_mm * MM
    area = math.pi * d * d / 4.0
    radius = (scene.material.radius_mm or scene.needle.inner_diameter_mm / 2.0) * MM
    depth = scene.bath.depth_mm * MM
    p[L.P_GRAVITY] = scene.bath.gravity_m_s2
    p[L.P_BATH_DENSITY_TOP] = scene.bath.density_kg_m3
    bottom = scene.bath.density_bottom_kg_m3
    p[L.P_BATH_DENSITY_GRADIENT] = (bottom - scene.bath.density_kg_m3) / depth if bottom else 0.0
    p[L.P_BATH_SURFACE_Z] = 0.0
    p[L.P_MU_S] = slender_body_coefficient(scene, radius)
    p[L.P_FLOW_X : L.P_FLOW_X + 3] = np.array(scene.bath.flow_velocity_mm_s) * MM
    p[L.P_FLOOR_Z] = -depth
    p[L.P_FLOOR_STIFFNESS] = scene.floor.stiffness_pa
    p[L.P_FRICTION_COEFFICIENT] = scene.floor.friction_coefficient
    p[L.P_FRICTION_VELOCITY] = scene.floor.friction_velocity_mm_s * MM
    p[L.P_ADDED_MASS_COEFFICIENT] = scene.inertia.added_mass_coefficient
    p[L.P_END_LOAD_X : L.P_END_LOAD_X + 3] = scene.end_load.force_n
    num = effective_numerics(scene)
    p[L.P_NODE_SPACING] = num["node_spacing_mm"] * MM
    p[L.P_NEEDLE_AREA] = area
    p[L.P_EXIT_YOUNGS_MODULUS] = scene.material.youngs_modulus_pa
    p[L.P_EXIT_RADIUS] = radius
    p[L.P_EXIT_DENSITY] = scene.material.density_kg_m3
    p[L.P_TOLERANCE] = num["tolerance"]
    p[L.P_FIXED_STEP] = scene.numerics.time_step_s
    p[L.P_MIN_STEP] = scene.numerics.min_step_s
    p[L.P_MAX_STEP] = scene.numerics.max_step_s
    p[L.P_STRETCH_LIMIT] = scene.numerics.stretch_limit
    p[L.P_MAX_STRAIN_CHANGE] = scene.numerics.max_strain_change
    p[L.P_MAX_STRAIN] = scene.numerics.max_strain
    p[L.P_MAX_INLET_GROWTH] = num["max_inlet_growth"]
    p[L.P_CLAMPED] = 1.0
    p[L.P_FREEZE_BEYOND] = _freeze_beyond(scene, num["node_spacing_mm"]) * MM
    p[L.P_BUCKLING_STEPS] = scene.numerics.buckling_steps
    gel = scene.gelation
    if "gelation" in scene.effects and gel.final_modulus_pa < gel.initial_modulus_pa:
        raise SceneError(
            f"gelation.final_modulus_pa = {gel.final_modulus_pa!r} is below "
            f"gelation.initial_modulus_pa = {gel.initial_modulus_pa!r}; gel only stiffens"
        )
    p[L.P_GELATION] = 1.0 if "gelation" in scene.effects else 0.0
    p[L.P_GEL_INITIAL_MODULUS] = gel.initial_modulus_pa
    p[L.P_GEL_FINAL_MODULUS] = gel.final_modulus_pa
    p[L.P_GEL_RATE] = gel.rate_1_s
    p[L.P_CURVATURE_MEMORY] = 1.0 if gel.curvature_memory else 0.0
    inc = scene.inclusions
    p[L.P_INCLUSIONS] = 1.0 if "inclusions" in scene.effects else 0.0
    fluid = INNER_FLUIDS[inc.fluid]
    p[L.P_INNER_DENSITY] = (
        inc.ferrofluid_density_kg_m3 if inc.fluid == "ferrofluid" else fluid.density_kg_m3
    )
    p[L.P_INCLUSION_OFFSET] = inc.offset
    p[L.P_OFFSET_ANGLE] = math.radians(inc.offset_angle_deg)
    p[L.P_CURVATURE_COEFFICIENT] = inc.curvature_coefficient
    p[L.P_SLUG_FRACTION] = inc.slug_fraction
    p[L.P_NEWTON_TOL] = scene.numerics.newton_tolerance
    p[L.P_MAX_NEWTON] = scene.numerics.max_newton_iterations
    p[L.P_NEWTON_REUSE] = 1.0 if scene.numerics.newton == "modified" else 0.0
    p[L.P_INERTIA] = 1.0 if "inertia" in scene.effects else 0.0
    p[L.P_IMPERFECTION] = scene.needle.imperfection_um * 1e-6
    p[L.P_SEED] = scene.seed
    p[L.P_INITIAL_AGE] = scene.initial.age_s
    enabled = np.array([1 if e in scene.effects else 0 for e in L.EFFECT_NAMES], dtype=np.int64)
    flow = _flow_table(scene)
    return Model(
        scene=scene,
        params=p,
        enabled=enabled,
        flow=flow,
        flow_cum=flow_cumulative(flow, area),
        needle=_needle_table(scene),
        integrator=L.INTEGRATOR_NAMES.index(scene.numerics.integrator),
    )

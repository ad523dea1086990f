"""Compile a :class:`~bathprint.core.scene.Scene` into SI arrays the numba kernels read.

The model (static: parameters, effect flags, schedules) is kept apart from the state
(dynamic: node positions, velocities, material records), in the manner of MuJoCo's
MjModel / MjData.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from bathprint._cache import ensure_fresh_cache
from bathprint.core import layout as L
from bathprint.core import records
from bathprint.core.composite import INNER_FLUIDS
from bathprint.core.effects._rpy import GATE_MARGIN, window_margin, window_shift
from bathprint.core.scene import Scene, effective_numerics, flow_rows
from bathprint.errors import SceneError

ML_MIN = 1e-6 / 60.0  # m^3/s per ml/min
MM = 1e-3  # m per mm


@dataclass
class Model:
    """Static, compiled description of a scene (SI units throughout).

    ``params`` is the scalar-parameter record (``layout.PARAMS_DTYPE``); :attr:`p` reads and
    writes its fields by name (``model.p.mu_s``), and :attr:`record` is the numba-side
    :class:`bathprint.core.records.Model` the kernels take.
    """

    scene: Scene
    params: np.ndarray  # (1,) PARAMS_DTYPE
    enabled: np.ndarray  # (N_EFFECTS,) int64, 1 for the effects the scene lists
    flow: np.ndarray  # (K, 3): t_s, q_outer_m3_s, q_inner_m3_s
    flow_cum: np.ndarray  # (K, 2): extruded length S (m) and inner volume (m^3) at each knot
    needle: np.ndarray  # (M, 7): t_s, position (m), direction

    @cached_property
    def p(self) -> np.record:
        """The parameters by name, as a writable view (``model.p.fixed_step = 1e-3``); made
        once (a recarray view costs microseconds, and environments read it every step)."""
        return self.params.view(np.recarray)[0]

    def __getstate__(self) -> dict:
        """Pickled and copied without the cached view :attr:`p` (a copy of it would no
        longer write into ``params``)."""
        state = self.__dict__.copy()
        state.pop("p", None)
        return state

    @property
    def record(self) -> records.Model:
        """The arrays the kernels take."""
        return records.Model(self.params, self.enabled, self.flow, self.flow_cum, self.needle)

    @property
    def integrator(self) -> int:
        return int(self.params[0]["integrator"])

    @property
    def node_spacing(self) -> float:
        return float(self.params[0]["node_spacing"])

    @property
    def needle_area(self) -> float:
        return float(self.params[0]["needle_area"])

    @property
    def radius(self) -> float:
        return float(self.params[0]["exit_radius"])

    @property
    def mu_s(self) -> float:
        return float(self.params[0]["mu_s"])

    @property
    def bending_stiffness(self) -> float:
        """B = E pi r^4 / 4 of the exit material (N m^2)."""
        e = float(self.params[0]["exit_youngs_modulus"])
        return float(e * math.pi * self.radius**4 / 4)

    def exit_speed(self, t: float = 0.0) -> float:
        """v = (Q_o + Q_i) / (pi d^2 / 4) at time t (m/s)."""
        from bathprint.core.extrusion import flow_rate

        qo, qi = flow_rate(self.flow, t)
        return (qo + qi) / self.needle_area


def slender_body_coefficient(scene: Scene, radius: float) -> float:
    """mu_s (Pa s): Cox's 2 pi mu / ln(L/r), or the scene's constant (finite_re: Cox's, its
    limit at zero speed)."""
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


MIN_ACTIVE_SPACINGS = 8  # the active filament keeps at least this many node spacings


def _freeze_beyond(scene: Scene, node_spacing_mm: float) -> float:
    """``numerics.freeze_beyond_mm``, checked: 0 (off) or at least ``MIN_ACTIVE_SPACINGS``
    node spacings, and not with end_load (the lumped tail of :mod:`bathprint.core.freezing`
    carries drag, net weight, mass and floor friction, but no end load)."""
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
    if "end_load" in scene.effects:
        raise SceneError(
            f"numerics.freeze_beyond_mm = {value!r} with the end_load effect: the end load acts "
            "on the filament's free end, which freezing takes out of the solve; allowed: 0 with "
            "end_load"
        )
    if scene.numerics.freeze_joint == "clamped" and "floor" in scene.effects:
        raise SceneError(
            "numerics.freeze_joint = 'clamped' with the floor effect: a tail resting on the "
            "floor slides at its height while the active end rises and falls, so it cannot "
            "hold the end's tangent; allowed: 'free' with floor"
        )
    return value


def _gel_surface(scene: Scene, p: np.record) -> None:
    """The surface model's parameters (:mod:`bathprint.core.effects.gelation`); checked only
    when a listed gelation effect selects it."""
    from bathprint.core.effects.gelation import neumann_lambda

    gel = scene.gelation
    p.gel_model = L.GEL_MODEL_NAMES.index(gel.model)
    p.gel_diffusivity = gel.calcium_diffusivity_m2_s
    p.gel_bath_calcium = gel.bath_calcium_mol_m3
    p.gel_binding_capacity = gel.binding_capacity_mol_m3
    p.gel_shell_modulus = gel.shell_modulus_pa
    p.gel_core_modulus = gel.core_modulus_pa
    if "gelation" in scene.effects and gel.model == "surface":
        if gel.core_modulus_pa >= gel.shell_modulus_pa:
            raise SceneError(
                f"gelation.core_modulus_pa = {gel.core_modulus_pa!r} is not below "
                f"gelation.shell_modulus_pa = {gel.shell_modulus_pa!r}; allowed: a core "
                "softer than the set shell (the core is ungelled solution)"
            )
    p.gel_front_lambda = neumann_lambda(gel.bath_calcium_mol_m3 / gel.binding_capacity_mol_m3)


# contact.damping_time_s = "auto" with inertia: touching turns are a spring between masses
# that the bath's drag damps by under 1% of critical, so a pile rattles; 10 ms keeps freezing
# at the needle within the draft preset's error with the soft onset before contact (of 1, 3
# and 10 ms, 3 and 10 ms do, 10 ms the more damped: docs/performance.md, "Freezing and
# contact's damping", `python experiments/freezing/freezing.py --part onset` and `--part
# damping`). Overdamped there is no such spring, and the dashpot's couplings cost GMRES many
# iterations on a pile (16x the time at 10 ms), so "auto" gives 0.
CONTACT_DAMPING_WITH_INERTIA_S = 0.01


def contact_damping_time(scene: Scene) -> float:
    """The contact dashpot's Kelvin-Voigt time in s: ``contact.damping_time_s``, its "auto"
    resolved by whether ``inertia`` is listed."""
    value = scene.contact.damping_time_s
    if value == "auto":
        return CONTACT_DAMPING_WITH_INERTIA_S if "inertia" in scene.effects else 0.0
    return float(value)


def _check_rpy(h, spacing: float, radius: float) -> None:
    """The RPY kernel: direct sums of point blobs (no FMM, no Cortez blob), and
    blobs large enough that a straight filament's windows keep GATE_MARGIN of their mobility
    beyond the blobs' share (:func:`window_margin`: its gates are then 1)."""
    if h.fmm_min_nodes > 0 or h.regularization_radii > 0.0:
        key, value = (
            ("fmm_min_nodes", h.fmm_min_nodes)
            if h.fmm_min_nodes > 0
            else ("regularization_radii", h.regularization_radii)
        )
        raise SceneError(
            f"hydrodynamics.{key} = {value!r} with hydrodynamics.kernel = 'rpy': it applies to "
            "the slender_body kernel's Stokeslet segments; allowed: 0 with 'rpy'"
        )
    cutoff = h.cutoff_radii * radius
    if window_margin(spacing, cutoff, radius, h.rpy_radii * radius) > GATE_MARGIN:
        return
    ratio = h.rpy_radii
    while ratio < 20.0 and window_margin(spacing, cutoff, radius, ratio * radius) <= GATE_MARGIN:
        ratio = round(ratio + 0.05, 2)
    raise SceneError(
        f"hydrodynamics.rpy_radii = {h.rpy_radii!r}: with node spacing {spacing * 1e3:g} mm, "
        f"cutoff {cutoff * 1e3:g} mm and radius {radius * 1e3:g} mm the blobs' share of a "
        f"straight filament's window leaves it less than {GATE_MARGIN:g} of its own mobility, "
        "so the gates that keep the mobility positive definite would cut even a straight "
        f"filament's flow; allowed: hydrodynamics.rpy_radii >= {ratio:g} here"
    )


def _hydrodynamics(scene: Scene, p: np.record, radius: float) -> None:
    """The hydrodynamics parameters (cutoff, coupling, regularisation, FMM)."""
    h = scene.hydrodynamics
    p.hydro_cutoff = h.cutoff_radii * radius
    p.hydro_coupling = L.HYDRO_COUPLINGS.index(h.coupling)
    p.hydro_blob = h.regularization_radii * radius
    p.hydro_screening = scene.drag.model == "finite_re"
    p.hydro_fmm_nodes = h.fmm_min_nodes
    p.hydro_fmm_precision = h.fmm_precision
    p.hydro_kernel = L.HYDRO_KERNELS.index(h.kernel)
    p.hydro_rpy_radii = h.rpy_radii
    p.hydro_rpy_shift_par, p.hydro_rpy_shift_perp = window_shift(
        h.cutoff_radii * radius, h.rpy_radii * radius
    )
    if "hydrodynamics" in scene.effects and h.kernel == "rpy":
        _check_rpy(h, p.node_spacing, radius)
    if "hydrodynamics" in scene.effects and h.fmm_min_nodes > 0:
        if scene.drag.model == "finite_re":
            raise SceneError(
                f"hydrodynamics.fmm_min_nodes = {h.fmm_min_nodes!r} with drag.model = "
                "'finite_re': the FMM sums unscreened Stokeslets, finite_re screens them beyond "
                "the Oseen length; allowed: 0 (direct sums) with finite_re"
            )
        try:
            import fmm3dpy  # noqa: F401
        except ImportError as exc:
            raise SceneError(
                f"hydrodynamics.fmm_min_nodes = {h.fmm_min_nodes!r} needs fmm3dpy, which is not "
                "installed (pip install 'bathprint[hydro]'); allowed: 0 (direct sums) "
                "without it"
            ) from exc


def compile_model(scene: Scene) -> Model:
    """Turn a validated scene into the arrays of a :class:`Model`."""
    ensure_fresh_cache()  # before any kernel of this process loads from numba's cache
    params = records.new_params()
    p = params.view(np.recarray)[0]
    d = scene.needle.inner_diameter_mm * MM
    area = math.pi * d * d / 4.0
    radius = (scene.material.radius_mm or scene.needle.inner_diameter_mm / 2.0) * MM
    depth = scene.bath.depth_mm * MM
    p.gravity = scene.bath.gravity_m_s2
    p.bath_density_top = scene.bath.density_kg_m3
    bottom = scene.bath.density_bottom_kg_m3
    p.bath_density_gradient = (bottom - scene.bath.density_kg_m3) / depth if bottom else 0.0
    p.bath_surface_z = 0.0
    p.mu_s = slender_body_coefficient(scene, radius)
    p.bath_flow = np.array(scene.bath.flow_velocity_mm_s) * MM
    p.floor_z = -depth
    p.floor_stiffness = scene.floor.stiffness_pa
    p.friction_coefficient = scene.floor.friction_coefficient
    p.friction_velocity = scene.floor.friction_velocity_mm_s * MM
    p.added_mass_coefficient = scene.inertia.added_mass_coefficient
    p.solution_viscosity = scene.viscosity.solution_viscosity_pa_s
    p.trouton_ratio = scene.viscosity.trouton_ratio
    p.liquid = "liquid" in scene.effects
    p.liquid_viscosity = scene.liquid.viscosity_pa_s
    p.liquid_set_time = scene.liquid.set_time_s
    p.liquid_exponent = scene.liquid.viscosity_exponent
    p.drag_cox = scene.drag.model != "constant"
    p.end_load = scene.end_load.force_n
    num = effective_numerics(scene)
    p.node_spacing = num["node_spacing_mm"] * MM
    p.needle_area = area
    p.exit_youngs_modulus = scene.material.youngs_modulus_pa
    p.exit_radius = radius
    p.exit_density = scene.material.density_kg_m3
    p.tolerance = num["tolerance"]
    p.fixed_step = scene.numerics.time_step_s
    p.min_step = scene.numerics.min_step_s
    p.max_step = scene.numerics.max_step_s
    p.stretch_limit = scene.numerics.stretch_limit
    p.max_strain_change = scene.numerics.max_strain_change
    p.max_strain = scene.numerics.max_strain
    p.max_inlet_growth = num["max_inlet_growth"]
    p.clamped = True
    p.freeze_beyond = _freeze_beyond(scene, num["node_spacing_mm"]) * MM
    joint = scene.numerics.freeze_joint
    p.freeze_clamped = joint == "clamped" or (joint == "auto" and "floor" not in scene.effects)
    p.buckling_steps = scene.numerics.buckling_steps
    gel = scene.gelation
    if "gelation" in scene.effects and gel.final_modulus_pa < gel.initial_modulus_pa:
        raise SceneError(
            f"gelation.final_modulus_pa = {gel.final_modulus_pa!r} is below "
            f"gelation.initial_modulus_pa = {gel.initial_modulus_pa!r}; gel only stiffens"
        )
    p.gelation = "gelation" in scene.effects
    p.gel_initial_modulus = gel.initial_modulus_pa
    p.gel_final_modulus = gel.final_modulus_pa
    p.gel_rate = gel.rate_1_s
    p.curvature_memory = bool(gel.curvature_memory)
    _gel_surface(scene, p)
    inc = scene.inclusions
    p.inclusions = "inclusions" in scene.effects
    fluid = INNER_FLUIDS[inc.fluid]
    p.inner_density = (
        inc.ferrofluid_density_kg_m3 if inc.fluid == "ferrofluid" else fluid.density_kg_m3
    )
    p.inclusion_offset = inc.offset
    p.offset_angle = math.radians(inc.offset_angle_deg)
    p.curvature_coefficient = inc.curvature_coefficient
    p.slug_fraction = inc.slug_fraction
    p.newton_tolerance = scene.numerics.newton_tolerance
    p.max_newton = scene.numerics.max_newton_iterations
    p.newton_reuse = scene.numerics.newton == "modified"
    ls = scene.numerics.line_search
    p.line_search = ls == "residual" or (ls == "auto" and "contact" in scene.effects)
    p.inertial = "inertia" in scene.effects
    p.imperfection = scene.needle.imperfection_um * 1e-6
    p.seed = scene.seed
    p.initial_age = scene.initial.age_s
    p.integrator = L.INTEGRATOR_NAMES.index(scene.numerics.integrator)
    p.krylov_tolerance = scene.numerics.krylov_tolerance
    p.drag_model = L.DRAG_FINITE_RE if scene.drag.model == "finite_re" else L.DRAG_MU_S
    p.bath_viscosity = scene.bath.viscosity_pa_s
    p.drag_length = scene.drag.length_scale_mm * MM
    _hydrodynamics(scene, p, radius)
    c = scene.contact
    p.contact_stiffness = c.stiffness_pa
    p.contact_distance_factor = c.distance_factor
    p.contact_width_fraction = c.width_fraction
    p.contact_near_gap = c.near_gap_fraction
    p.contact_parallel_sin2 = math.sin(math.radians(c.parallel_angle_deg)) ** 2
    p.contact_sliding_sin2 = math.sin(math.radians(min(2.0 * c.parallel_angle_deg, 90.0))) ** 2
    p.contact_friction = c.friction_coefficient
    p.contact_friction_velocity = c.friction_velocity_mm_s * MM
    p.contact_damping_time = contact_damping_time(scene)
    p.contact_exact_hessian = c.hessian == "exact"
    enabled = np.array([1 if e in scene.effects else 0 for e in L.EFFECT_NAMES], dtype=np.int64)
    flow = _flow_table(scene)
    return Model(
        scene=scene,
        params=params,
        enabled=enabled,
        flow=flow,
        flow_cum=flow_cumulative(flow, area),
        needle=_needle_table(scene),
    )

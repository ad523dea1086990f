"""Scenes: what the user asks for, as TOML or as Python dataclasses, validated on load.

A scene names its bath, needle, material, flow schedule, the effects to simulate, the
numerics, the duration and the outputs. Values crossing this boundary carry their unit
in their name (``flow.q_outer_ml_min``); :mod:`bathprint.core.model` converts to SI.

Overrides use dotted keys, the same from the CLI (``--set flow.q_outer_ml_min=5``) and
from Python (``overrides={"flow.q_outer_ml_min": 5}``). Every key is checked: unknown
keys and effects, missing or non-finite values, and values outside the physical range
(the paper's range widened by orders of magnitude) raise one :class:`SceneError` that
names the key, the value and what is allowed; so do numerics that cannot resolve the
scene's buckling length (:mod:`bathprint.core.resolution`).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from bathprint.core.composite import INNER_FLUIDS
from bathprint.core.layout import (
    DRAG_MODELS,
    EFFECT_NAMES,
    GEL_MODEL_NAMES,
    HYDRO_COUPLINGS,
    HYDRO_KERNELS,
    INTEGRATOR_NAMES,
)
from bathprint.core.resolution import check_resolution
from bathprint.errors import SceneError

# accuracy presets: (tolerance, max_inlet_growth, node spacing factor); "custom" uses the
# raw numerics keys as given. Measured error and cost of each: README, "Accuracy".
ACCURACY_PRESETS: dict[str, tuple[float, float, float]] = {
    "draft": (1e-2, 2.0, 2.0),
    "balanced": (1e-3, 0.5, 1.0),
    "fine": (1e-5, 0.25, 0.5),
}


# physics presets (``Scene.physics``): which of the effects a preset decides are on, and the
# drag law; a scene's other effects (floor, gelation, inclusions, end load, ...) stay as
# listed. "custom" applies nothing. docs/reproduction.md says why each contains what it does.
PRESET_EFFECTS = ("inertia", "contact", "hydrodynamics")  # the effects a preset decides
PHYSICS_PRESETS: dict[str, dict[str, Any]] = {
    # the paper's minimal model: elasticity, local slender-body (Cox) drag, gravity
    "minimal": {"effects": (), "drag.model": "cox"},
    # what reproduces the experiments best with no parameter fitted to them (the ablation
    # study): self-contact between turns on the local Stokes drag
    "experiment": {"effects": ("contact",), "drag.model": "cox"},
}


def apply_physics_preset(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` (a raw scene dict, not modified) with its ``physics`` preset applied: the
    effects of :data:`PRESET_EFFECTS` the preset lists replace those the scene lists, and
    the preset's keys are set. Idempotent, so a scene written out reads back the same."""
    name = data.get("physics", "custom")
    if name == "custom" or not isinstance(name, str) or name not in PHYSICS_PRESETS:
        return data  # (an unknown name is refused by the field's choices)
    preset = PHYSICS_PRESETS[name]
    out = apply_overrides(data, {k: v for k, v in preset.items() if k != "effects"})
    listed = out.get("effects", ["elasticity", "drag", "gravity"])
    if isinstance(listed, list):
        kept = [e for e in listed if e not in PRESET_EFFECTS]
        out["effects"] = kept + [e for e in PRESET_EFFECTS if e in preset["effects"]]
    return out


def _num(
    default: float | str,
    lo: float,
    hi: float,
    *,
    lo_open: bool = False,
    doc: str = "",
    auto: bool = False,
) -> Any:
    """A float field with its allowed range [lo, hi] (or (lo, hi] when lo_open); with
    ``auto`` it also takes the word "auto", which :mod:`bathprint.core.model` resolves."""
    md = {"range": (lo, hi), "lo_open": lo_open, "doc": doc, "auto": auto}
    return field(default=default, metadata=md)


def _vec(default: tuple[float, ...], lo: float, hi: float, doc: str = "") -> Any:
    return field(default=default, metadata={"range": (lo, hi), "vector": 3, "doc": doc})


@dataclass
class Bath:
    """The CaCl2 bath: viscosity, density (optionally a linear gradient with depth)."""

    viscosity_pa_s: float = _num(1e-3, 1e-5, 1e2, lo_open=True, doc="dynamic viscosity mu")
    density_kg_m3: float = _num(
        1051.0, 0.5, 3000.0, doc="density at the free surface (air, ~1.2, for lab tests)"
    )
    density_bottom_kg_m3: float = _num(
        0.0, 0.0, 3000.0, doc="density at the floor; 0 means uniform (no gradient)"
    )
    depth_mm: float = _num(125.0, 1.0, 1e4, doc="free surface to floor")
    gravity_m_s2: float = _num(9.81, 0.0, 100.0, doc="gravitational acceleration")
    flow_velocity_mm_s: tuple[float, float, float] = _vec(
        (0.0, 0.0, 0.0), -1e4, 1e4, doc="uniform bath flow"
    )


@dataclass
class Needle:
    """The needle: inner diameter, tip position (z up, free surface at z = 0) and direction."""

    inner_diameter_mm: float = _num(1.0, 0.01, 20.0, lo_open=True, doc="inner diameter d")
    position_mm: tuple[float, float, float] = _vec((0.0, 0.0, -10.0), -1e4, 1e4)
    direction: tuple[float, float, float] = _vec((0.0, 0.0, -1.0), -1.0, 1.0)
    path: list = field(
        default_factory=list,
        metadata={
            "rows": 7,
            "doc": "optional waypoints [[t_s, x_mm, y_mm, z_mm, dx, dy, dz], ...]",
        },
    )
    imperfection_um: float = _num(
        1.0, 0.0, 1e3, doc="transverse offset given to each node born at the needle"
    )
    release_s: float = _num(0.0, 0.0, 1e6, doc="> 0: cut the filament free at this time")


@dataclass
class Material:
    """The gel as it leaves the needle (pure 2% alginate unless inclusions say otherwise)."""

    youngs_modulus_pa: float = _num(4800.0, 1.0, 1e8, lo_open=True, doc="Young's modulus E")
    density_kg_m3: float = _num(1054.0, 100.0, 20000.0, lo_open=True, doc="density rho")
    radius_mm: float = _num(0.0, 0.0, 20.0, doc="filament radius; 0 means d / 2")


@dataclass
class Flow:
    """Flow rates through the needle: constant, or a piecewise-linear schedule."""

    q_outer_ml_min: float = _num(10.0, 0.0, 1000.0, doc="alginate flow rate Q_o")
    q_inner_ml_min: float = _num(0.0, 0.0, 1000.0, doc="co-extruded inner flow rate Q_i")
    schedule: list = field(
        default_factory=list,
        metadata={
            "rows": 3,
            "doc": "optional [[t_s, q_outer_ml_min, q_inner_ml_min], ...], times rising",
        },
    )
    schedule_csv: str = field(
        default="",
        metadata={"doc": "CSV with columns t_s, q_outer_ml_min, q_inner_ml_min (header row)"},
    )


@dataclass
class Gelation:
    """The gel setting (effect 'gelation'), with optional curvature memory.

    ``model = "bulk"``: the modulus grows with material age (initial_modulus_pa,
    final_modulus_pa, rate_1_s). ``model = "surface"``: a set shell grows inward from the
    surface as Ca2+ diffuses in from the bath, around a liquid core (the keys below the
    model's; docs/physics/gelation.md gives the sources of their defaults).
    """

    initial_modulus_pa: float = _num(300.0, 1.0, 1e7, lo_open=True, doc="E at age 0")
    final_modulus_pa: float = _num(30000.0, 1.0, 1e8, lo_open=True, doc="E of set gel")
    rate_1_s: float = _num(1.0 / 60.0, 1e-6, 1e4, lo_open=True, doc="crosslinking rate k")
    curvature_memory: bool = True
    model: str = field(
        default="bulk",
        metadata={
            "choices": GEL_MODEL_NAMES,
            "doc": "bulk: modulus from the age law; surface: a set shell growing inward by "
            "Ca2+ diffusion around a liquid core",
        },
    )
    calcium_diffusivity_m2_s: float = _num(
        0.7e-9, 1e-13, 1e-6, lo_open=True, doc="Ca2+ diffusivity D in the gel (surface)"
    )
    bath_calcium_mol_m3: float = _num(
        150.0, 1e-3, 1e4, doc="Ca2+ in the bath, mol/m^3 = mM (surface)"
    )
    binding_capacity_mol_m3: float = _num(
        53.0, 1e-3, 1e4, doc="Ca2+ bound per volume of set gel (surface)"
    )
    shell_modulus_pa: float = _num(
        30000.0, 1.0, 1e8, lo_open=True, doc="E of the set shell (surface)"
    )
    core_modulus_pa: float = _num(
        30.0, 0.0, 1e8, lo_open=True, doc="E of the ungelled core, a viscous liquid (surface)"
    )


@dataclass
class Inclusions:
    """Co-extruded inner fluid (effect 'inclusions'); its flow is flow.q_inner_ml_min."""

    fluid: str = field(default="silicone_oil", metadata={"choices": tuple(INNER_FLUIDS)})
    ferrofluid_density_kg_m3: float = _num(1210.0, 500.0, 5000.0, lo_open=True)
    offset: float = _num(0.0, -1.0, 1.0, doc="Delta = (r1 - r2) / r of the inclusions")
    offset_angle_deg: float = _num(0.0, -360.0, 360.0, doc="direction of the offset")
    curvature_coefficient: float = _num(
        0.1, 0.0, 10.0, doc="C in kappa0 = C Delta phi / r (phenomenological)"
    )
    max_inner_fraction: float = _num(
        0.9, 0.01, 0.99, lo_open=True, doc="largest Q_i / (Q_o + Q_i) the needle allows"
    )
    slug_fraction: float = _num(
        0.8, 0.1, 1.0, lo_open=True, doc="drops wider than this x 2r run as slugs"
    )


@dataclass
class Drag:
    """Slender-body drag: mu_s = 2 pi mu / ln(L/r) (Cox), a constant, or the finite-Reynolds
    law (finite_re: cylinder drag curve across the axis, laminar boundary layer along it, from
    the bath's viscosity and density and the local relative velocity)."""

    model: str = field(default="cox", metadata={"choices": DRAG_MODELS})
    length_scale_mm: float = _num(
        20.0, 0.1, 1e5, lo_open=True, doc="L in Cox's ln(L/r) (finite_re: its length cut-off)"
    )
    coefficient_pa_s: float = _num(
        0.0, 0.0, 1e3, doc="mu_s for model = 'constant'; 0 means the bath viscosity"
    )


@dataclass
class Floor:
    """The container floor (at z = -bath.depth_mm): penalty contact and friction."""

    stiffness_pa: float = _num(1e4, 1.0, 1e9, lo_open=True, doc="contact force/length/depth")
    friction_coefficient: float = _num(0.3, 0.0, 10.0, doc="Coulomb mu_f")
    friction_velocity_mm_s: float = _num(
        1.0, 1e-6, 1e3, lo_open=True, doc="regularisation (smaller: sharper, harder for Newton)"
    )


@dataclass
class Contact:
    """Self-contact between non-adjacent segments (effect 'contact'): a penalty on the
    penetration of the centre-line distance below the contact distance f (r_A + r_B)."""

    stiffness_pa: float = _num(
        1e3, 1e-3, 1e9, lo_open=True, doc="force per length per penetration (as the floor's)"
    )
    distance_factor: float = _num(
        1.02,
        0.0,
        10.0,
        lo_open=True,
        doc="where the penalty starts / the sum of the two radii (> 1: its soft onset begins "
        "before the surfaces touch, so touching turns rest near the sum of the radii)",
    )
    width_fraction: float = _num(
        0.2, 1e-4, 1.0, lo_open=True, doc="penetration of the soft onset, in contact distances"
    )
    friction_coefficient: float = _num(0.0, 0.0, 2.0, doc="Coulomb mu between touching turns")
    friction_velocity_mm_s: float = _num(
        1.0, 1e-6, 1e3, lo_open=True, doc="regularisation of that friction"
    )
    damping_time_s: float | str = _num(
        "auto",
        0.0,
        1.0,
        doc="Kelvin-Voigt time of a normal dashpot between touching segments, the penalty's "
        "stiffness times this on the rate the distance closes (0: none; auto: 0.01 s with "
        "inertia, where touching turns are otherwise an undamped spring between masses, 0 "
        "without, where it only slows GMRES)",
        auto=True,
    )
    near_gap_fraction: float = _num(
        0.3,
        0.0,
        2.0,
        doc="pairs within this gap of touching (in contact distances; at most the candidate "
        "list's skin) are evaluated in Newton's iterations; a pair further out bounds the "
        "step by the gap it may close",
    )
    parallel_angle_deg: float = _num(
        10.0,
        0.0,
        45.0,
        doc="segments at a smaller angle touch at the middle of their overlap, blended into "
        "the closest points up to twice the angle (0: at the closest points)",
    )
    hessian: str = field(
        default="exact",
        metadata={
            "choices": ("exact", "gauss_newton"),
            "doc": "Newton matrix of the penalty: the exact Hessian, or its Gauss-Newton part "
            "P'' grad d grad d^T (positive semi-definite; Newton then converges linearly)",
        },
    )


@dataclass
class Hydrodynamics:
    """Nonlocal slender-body flow (effect 'hydrodynamics'): Lighthill's slender-body theory
    split at an arclength a = cutoff_radii x the filament radius into the local drag (the
    drag law on the window |s' - s| < a) and the flow of the rest of the filament: Stokeslet
    segments beyond the window (kernel 'slender_body') or Rotne-Prager-Yamakawa blobs at the
    nodes less their share of the window (kernel 'rpy', positive definite on touching turns;
    docs/physics/index.md#hydrodynamics)."""

    kernel: str = field(
        default="slender_body",
        metadata={
            "choices": HYDRO_KERNELS,
            "doc": "slender_body: Lighthill's Stokeslet segments; rpy: Rotne-Prager-Yamakawa "
            "blobs at the nodes, a mobility positive definite for any configuration (with "
            "finite_re: the law linearised about the motion relative to the bath)",
        },
    )
    rpy_radii: float = _num(
        2.0,
        0.5,
        20.0,
        doc="rpy: each node's blob radius over its radius (its window's "
        "mobility must exceed the blobs' share: checked when the scene compiles)",
    )

    coupling: str = field(
        default="lagged",
        metadata={
            "choices": HYDRO_COUPLINGS,
            "doc": "lagged: the nonlocal flow from the step's start, its error added to the "
            "estimate (cheaper at equal accuracy in coiling runs); implicit: inside Newton "
            "(GMRES), second order",
        },
    )
    cutoff_radii: float = _num(
        3.0, 1.7, 100.0, doc="a / r: the window of the local part (>= 1.7: a > 2 delta)"
    )
    regularization_radii: float = _num(
        0.0, 0.0, 10.0, doc="Cortez's blob eps / r of the nonlocal Stokeslets (0: singular)"
    )
    fmm_min_nodes: int = field(
        default=0,
        metadata={
            "range": (0, 10**9),
            "doc": "active nodes from which fmm3dpy sums the far field (0: always direct)",
        },
    )
    fmm_precision: float = _num(
        1e-6, 1e-12, 1e-2, doc="requested relative precision of the FMM (fmm3dpy eps)"
    )


@dataclass
class Inertia:
    """Filament mass plus added mass C_a rho_bath A across the axis."""

    added_mass_coefficient: float = _num(1.0, 0.0, 10.0, doc="C_a")


@dataclass
class Viscosity:
    """The viscous stress of the alginate solution in the rod (effect 'viscosity'):
    stretching resistance Tr eta A and bending resistance Tr eta I beside the elastic ones
    (a Kelvin-Voigt rod; docs/physics/index.md#viscosity gives the sources of the defaults)."""

    solution_viscosity_pa_s: float = _num(
        2.0, 0.0, 1e5, lo_open=True, doc="shear viscosity eta of the 2% alginate solution"
    )
    trouton_ratio: float = _num(
        3.0, 0.0, 1e4, lo_open=True, doc="extensional / shear viscosity (3: Newtonian, Trouton)"
    )


@dataclass
class Liquid:
    """The liquid jet's Maxwell relaxation (effect 'liquid'): while liquid, rest lengths and
    curvatures relax toward the current ones at the rate E / eta_m, at constant volume, until
    the gel sets (docs/physics/index.md#liquid gives the laws and the sources)."""

    viscosity_pa_s: float = _num(
        1e-3, 0.0, 1e5, lo_open=True, doc="extensional viscosity eta_m of the Maxwell element"
    )
    set_time_s: float = _num(
        0.5, 0.0, 1e4, lo_open=True, doc="age at the gel point, where the liquid sets (bulk gel)"
    )
    viscosity_exponent: float = _num(
        1.0, 0.5, 3.0, doc="s of the viscosity's divergence (1 - X/X_c)^-s at the gel point"
    )


@dataclass
class EndLoad:
    """A dead force on the free end (validation scenes: column buckling)."""

    force_n: tuple[float, float, float] = _vec((0.0, 0.0, 0.0), -1e3, 1e3)


@dataclass
class Initial:
    """The filament at t = 0: a straight rod out of the needle, optionally perturbed."""

    length_mm: float = _num(0.0, 0.0, 1e5, doc="0 means a stub of two node spacings")
    age_s: float = _num(0.0, 0.0, 1e7, doc="age of that material at t = 0")
    perturbation_mm: float = _num(0.0, 0.0, 1e3, doc="amplitude of a transverse sine mode")


@dataclass
class Numerics:
    """Resolution and time stepping. The node spacing (after the accuracy preset) and a fixed
    step's extrusion v dt must each be at most one coil turn, 2.5 l, of the scene's buckling
    length l = (B/(mu v + drho g r^2))^(1/3) (the paper's scaling, R = 0.4 l from its Fig. 2B);
    a spacing above l/2 warns (bathprint.core.resolution)."""

    accuracy: str = field(
        default="custom",
        metadata={
            "choices": ("custom", *ACCURACY_PRESETS),
            "doc": "a preset sets tolerance, inlet growth and scales the node spacing",
        },
    )
    node_spacing_mm: float = _num(
        0.5, 1e-3, 100.0, lo_open=True, doc="segment rest length; at most a coil turn, 2.5 l"
    )
    integrator: str = field(default="implicit", metadata={"choices": INTEGRATOR_NAMES})
    tolerance: float = _num(1e-3, 1e-10, 1.0, lo_open=True, doc="local error / node spacing")
    time_step_s: float = _num(
        0.0, 0.0, 10.0, doc="> 0: fixed step, extruding at most a coil turn (2.5 l); 0: adaptive"
    )
    max_step_s: float = _num(0.05, 1e-9, 100.0, lo_open=True)
    min_step_s: float = _num(1e-10, 1e-15, 1.0, lo_open=True)
    stretch_limit: float = _num(0.5, 1e-3, 10.0, lo_open=True, doc="bound on |l/l0 - 1|")
    max_strain: float = _num(
        0.25, 1e-3, 10.0, lo_open=True, doc="adaptive steps ending with a larger strain are retried"
    )
    max_strain_change: float = _num(
        0.05, 1e-4, 10.0, lo_open=True, doc="adaptive steps changing a strain more are retried"
    )
    max_inlet_growth: float = _num(
        0.5, 1e-3, 100.0, lo_open=True, doc="node spacings extruded per adaptive step, at most"
    )
    newton: str = field(
        default="modified",
        metadata={
            "choices": ("modified", "full"),
            "doc": "modified: factorise the Jacobian once per step; full: every iteration",
        },
    )
    max_newton_iterations: int = field(default=12, metadata={"range": (1, 100)})
    line_search: str = field(
        default="auto",
        metadata={
            "choices": ("auto", "residual", "off"),
            "doc": "residual: a Newton update is halved until the force residual decreases "
            "(Armijo); off: a stalled solve halves its updates for good; auto: residual "
            "when contact is listed",
        },
    )
    buckling_steps: float = _num(
        1.0,
        0.0,
        100.0,
        doc="adaptive steps per e-folding time of the fastest buckling mode of the most "
        "compressed segment (0: no such bound)",
    )
    freeze_beyond_mm: float = _num(
        0.0,
        0.0,
        1e6,
        doc="material further than this behind the needle (arclength) leaves the solve and "
        "follows the active filament's end rigidly; 0: off",
    )
    freeze_joint: str = field(
        default="auto",
        metadata={
            "choices": ("auto", "clamped", "free"),
            "doc": "how the frozen tail holds the active end: clamped, the tail does not turn "
            "and the bending of the node that joins them holds the end's tangent (not with "
            "the floor effect); free, it takes no moment; auto: clamped, or free with floor",
        },
    )
    newton_tolerance: float = _num(0.01, 1e-8, 1.0, lo_open=True, doc="in units of tolerance")
    krylov_tolerance: float = _num(
        0.05,
        1e-12,
        0.5,
        lo_open=True,
        doc="GMRES residual relative to the right-hand side, with couplings off the band "
        "(contact, implicit hydrodynamics): the forcing term of inexact Newton, whose own "
        "iteration corrects the rest",
    )
    preconditioner: str = field(
        default="band",
        metadata={
            "choices": ("band", "axial_coarse"),
            "doc": "GMRES's preconditioner with couplings off the band: the banded LU of the "
            "local part, or that followed by a coarse correction of the displacements along "
            "z on every fourth node (piecewise linear; the stack modes of pressed coils)",
        },
    )


@dataclass
class Outputs:
    """What a run writes."""

    frame_interval_s: float = _num(0.05, 1e-6, 1e4, lo_open=True)
    plot: bool = True


@dataclass
class Scene:
    """A complete scene. ``effects`` lists what is simulated; nothing else is computed."""

    name: str = "custom"
    description: str = ""
    duration_s: float = _num(2.0, 0.0, 1e6, lo_open=True, doc="simulated time")
    seed: int = field(default=0, metadata={"range": (0, 2**31 - 1)})
    physics: str = field(
        default="custom",
        metadata={
            "choices": ("custom", *PHYSICS_PRESETS),
            "doc": "a preset decides inertia, contact, hydrodynamics and the drag law",
        },
    )
    effects: list = field(
        default_factory=lambda: ["elasticity", "drag", "gravity"],
        metadata={"effects": True, "doc": "what is simulated; nothing else is computed"},
    )
    bath: Bath = field(default_factory=Bath)
    needle: Needle = field(default_factory=Needle)
    material: Material = field(default_factory=Material)
    flow: Flow = field(default_factory=Flow)
    drag: Drag = field(default_factory=Drag)
    gelation: Gelation = field(default_factory=Gelation)
    inclusions: Inclusions = field(default_factory=Inclusions)
    floor: Floor = field(default_factory=Floor)
    contact: Contact = field(default_factory=Contact)
    inertia: Inertia = field(default_factory=Inertia)
    viscosity: Viscosity = field(default_factory=Viscosity)
    liquid: Liquid = field(default_factory=Liquid)
    end_load: EndLoad = field(default_factory=EndLoad)
    initial: Initial = field(default_factory=Initial)
    numerics: Numerics = field(default_factory=Numerics)
    outputs: Outputs = field(default_factory=Outputs)
    hydrodynamics: Hydrodynamics = field(default_factory=Hydrodynamics)

    def to_dict(self) -> dict[str, Any]:
        """Plain nested dict (TOML-serialisable)."""
        return dataclasses.asdict(self)


# ------------------------------------------------------------------------------------
def _allowed(f: dataclasses.Field) -> str:
    md = f.metadata
    if "rows" in md:
        doc = md["doc"]
        return "a list of rows " + doc[doc.index("[[") :]
    if "effects" in md:
        return 'a list of effect names, e.g. effects=["elasticity", "drag"]; names: ' + (
            ", ".join(EFFECT_NAMES)
        )
    if "choices" in md:
        return "one of " + ", ".join(repr(c) for c in md["choices"])
    if "range" in md:
        lo, hi = md["range"]
        left = "(" if md.get("lo_open") else "["
        kind = f"a list of 3 numbers each in {left}{lo:g}, {hi:g}]" if "vector" in md else None
        if f.type == "int":
            return f"an integer in [{int(lo)}, {int(hi)}]"
        number = kind or f"a number in {left}{lo:g}, {hi:g}]"
        return number + ' or "auto"' if md.get("auto") else number
    return f"a value of type {type(f.default).__name__}"


def _check_number(key: str, value: Any, f: dataclasses.Field) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(f"{key} = {value!r} is not a number; allowed: {_allowed(f)}")
    try:
        v = float(value)
    except OverflowError:  # an int beyond the float range
        v = math.inf
    lo, hi = f.metadata["range"]
    bad = not math.isfinite(v) or v < lo or v > hi or (f.metadata.get("lo_open") and v <= lo)
    if bad:
        raise SceneError(f"{key} = {value!r} is outside the physical range; allowed: {_allowed(f)}")
    return v


def _toml_list(words: list[str]) -> str:
    return "[" + ", ".join(f'"{w}"' for w in words) + "]"


def _coerce_effects(key: str, value: Any, f: dataclasses.Field) -> list[str]:
    if isinstance(value, str):  # --set effects=drag: a string, not a list of its letters
        words = [w for w in value.replace(",", " ").split() if w] or ["drag"]
        example = _toml_list(words) if len(words) > 1 else f'["{words[0]}", ...]'
        raise SceneError(
            f"{key} = {value!r} is a string; allowed: a TOML list of effect names, e.g. "
            f"{key}={example} (names: {', '.join(EFFECT_NAMES)})"
        )
    if not isinstance(value, list | tuple):
        raise SceneError(f"{key} = {value!r} is not a list; allowed: {_allowed(f)}")
    for e in value:
        if not isinstance(e, str):
            raise SceneError(
                f"{key} = {list(value)!r} holds {e!r}, not an effect name; allowed: {_allowed(f)}"
            )
    return list(value)


def _coerce_rows(key: str, value: Any, f: dataclasses.Field) -> list:
    """A list of rows (lists of numbers), rows as lists; the numbers are checked later."""
    if not isinstance(value, list | tuple):
        raise SceneError(f"{key} = {value!r} is not a list; allowed: {_allowed(f)}")
    if value and all(isinstance(x, int | float) for x in value):
        raise SceneError(
            f"{key} = {list(value)!r} is one row, not a list of rows (write [{list(value)!r}]); "
            f"allowed: {_allowed(f)}"
        )
    return [list(r) if isinstance(r, list | tuple) else r for r in value]


def _coerce(key: str, value: Any, f: dataclasses.Field) -> Any:
    md = f.metadata
    if "effects" in md:
        return _coerce_effects(key, value, f)
    if "rows" in md:
        return _coerce_rows(key, value, f)
    if "choices" in md:
        if isinstance(value, list | dict) or value not in md["choices"]:
            raise SceneError(f"{key} = {value!r} is unknown; allowed: {_allowed(f)}")
        return value
    if "vector" in md:
        if not isinstance(value, list | tuple) or len(value) != 3:
            raise SceneError(f"{key} = {value!r} must be {_allowed(f)}")
        try:
            return tuple(_check_number(key, x, f) for x in value)
        except SceneError as exc:  # name the whole vector, not only the bad component
            raise SceneError(f"{key} = {list(value)!r} must be {_allowed(f)}") from exc
    if f.type == "int":
        v = _check_number(key, value, f)
        if v != int(v):
            raise SceneError(f"{key} = {value!r} must be an integer; allowed: {_allowed(f)}")
        return int(v)
    if "range" in md:
        if md.get("auto") and value == "auto":
            return value
        return _check_number(key, value, f)
    if isinstance(f.default, bool):
        if not isinstance(value, bool):
            raise SceneError(f"{key} = {value!r} must be true or false")
        return value
    if isinstance(f.default, str):
        if not isinstance(value, str):
            raise SceneError(f"{key} = {value!r} must be a string")
        return value
    raise SceneError(f"{key} = {value!r}: no rule to read this key")  # a field without one


def _build(cls: type, data: dict[str, Any], prefix: str) -> Any:
    names = {f.name: f for f in dataclasses.fields(cls)}
    kwargs: dict[str, Any] = {}
    for key, value in data.items():
        full = f"{prefix}{key}"
        if key not in names:
            raise SceneError(
                f"unknown key {full!r} (value {value!r}); allowed keys here: "
                + ", ".join(f"{prefix}{n}" for n in names)
            )
        f = names[key]
        if value is None:
            raise SceneError(f"{full} is missing a value; allowed: {_allowed(f)}")
        if isinstance(f.default_factory, type) and dataclasses.is_dataclass(f.default_factory):
            if not isinstance(value, dict):
                sub = ", ".join(f"{full}.{g.name}" for g in dataclasses.fields(f.default_factory))
                raise SceneError(f"{full} = {value!r} is a value; allowed: a table of keys ({sub})")
            kwargs[key] = _build(f.default_factory, value, f"{full}.")
        else:
            kwargs[key] = _coerce(full, value, f)
    return cls(**kwargs)


def _check_tables(scene: Scene) -> None:
    for e in scene.effects:
        if e not in EFFECT_NAMES:
            raise SceneError(f"effects: unknown effect {e!r}; allowed: {', '.join(EFFECT_NAMES)}")
    if len(set(scene.effects)) != len(scene.effects):
        raise SceneError(f"effects = {scene.effects!r} lists an effect twice")
    if "drag" not in scene.effects and "inertia" not in scene.effects:
        raise SceneError(
            f"effects = {scene.effects!r}: an overdamped scene needs 'drag' "
            "(without drag or inertia the equations of motion are singular)"
        )
    if "hydrodynamics" in scene.effects:
        _check_hydrodynamics(scene)
    if "contact" in scene.effects and "elasticity" not in scene.effects:
        raise SceneError(
            f"effects = {scene.effects!r}: 'contact' needs 'elasticity' (a filament without "
            "elastic forces cannot hold its segments apart); allowed: add 'elasticity'"
        )
    if "liquid" in scene.effects:
        _check_liquid(scene)
    d = scene.needle.direction
    if math.hypot(*d) < 1e-6:
        raise SceneError(f"needle.direction = {list(d)!r} must be a non-zero vector")
    if scene.flow.schedule and scene.flow.schedule_csv:
        raise SceneError("flow.schedule and flow.schedule_csv are both set; give one of them")
    rows = flow_rows(scene)
    key = "flow.schedule_csv" if scene.flow.schedule_csv else "flow.schedule"
    if len(rows) > 1 or scene.flow.schedule or scene.flow.schedule_csv:
        _check_schedule(key, rows, 3, (1000.0, 1000.0))
    _check_inner_flow(scene, rows, key)
    if scene.needle.path:
        _check_schedule("needle.path", scene.needle.path, 7, None)
        _check_path(scene.needle.path)
    if scene.bath.density_bottom_kg_m3 and scene.bath.density_bottom_kg_m3 < 500.0:
        raise SceneError(
            f"bath.density_bottom_kg_m3 = {scene.bath.density_bottom_kg_m3!r}; allowed: 0 "
            "(uniform bath) or a number in [500, 3000]"
        )
    if 0.0 < scene.material.radius_mm < 1e-3:  # (r^4 of 1e-311 mm underflows to 0)
        raise SceneError(
            f"material.radius_mm = {scene.material.radius_mm!r}; allowed: 0 (d / 2) or a "
            "number in [0.001, 20]"
        )
    if 0.0 < scene.initial.length_mm < 1e-3:
        raise SceneError(
            f"initial.length_mm = {scene.initial.length_mm!r}; allowed: 0 (a stub of two node "
            "spacings) or a number in [0.001, 1e5]"
        )
    if scene.numerics.min_step_s >= scene.numerics.max_step_s:
        raise SceneError(
            f"numerics.min_step_s = {scene.numerics.min_step_s!r} must be below "
            f"numerics.max_step_s = {scene.numerics.max_step_s!r}"
        )
    r_mm = scene.material.radius_mm or scene.needle.inner_diameter_mm / 2
    if scene.numerics.node_spacing_mm < 0.2 * r_mm:
        source = (
            f"material.radius_mm = {r_mm!r}"
            if scene.material.radius_mm
            else f"needle.inner_diameter_mm / 2 = {r_mm:g}"
        )
        raise SceneError(
            f"numerics.node_spacing_mm = {scene.numerics.node_spacing_mm!r} is below 0.2 times "
            f"the filament radius ({source} mm); allowed: numerics.node_spacing_mm >= "
            f"{0.2 * r_mm:g} (a rod model needs segments at least that long)"
        )


def _check_liquid(scene: Scene) -> None:
    """What the liquid effect needs: the elastic spring whose rest state it relaxes, the
    viscous stress of the liquid, and (with bulk gelation) a gel point that crosslinking
    reaches."""
    if "elasticity" not in scene.effects:
        raise SceneError(
            f"effects = {scene.effects!r}: 'liquid' needs 'elasticity' (it relaxes the rest "
            "lengths and curvatures of the elastic spring); allowed: add 'elasticity'"
        )
    if "viscosity" not in scene.effects:
        raise SceneError(
            f"effects = {scene.effects!r}: 'liquid' needs 'viscosity' (the liquid's viscous "
            "stress is that effect's; without it a liquid segment's stress would be its "
            "spring's over one time step, E h d(eps)/dt, which depends on the step); allowed: "
            "add 'viscosity'"
        )
    gel = scene.gelation
    if "gelation" in scene.effects and gel.model == "bulk":
        conv = -math.expm1(-gel.rate_1_s * scene.liquid.set_time_s)
        if not conv > 1e-9:
            raise SceneError(
                f"liquid.set_time_s = {scene.liquid.set_time_s!r} with gelation.rate_1_s = "
                f"{gel.rate_1_s!r}: the crosslinking conversion at the gel point, "
                f"1 - exp(-k t_set) = {conv:.3g}, is too small to resolve; allowed: "
                f"liquid.set_time_s >= {1e-9 / gel.rate_1_s:.3g} s"
            )


def _check_hydrodynamics(scene: Scene) -> None:
    """What the hydrodynamics effect needs: the drag effect (whose law it uses locally), a
    law from slender-body theory (not a constant), and no frozen tail."""
    if "drag" not in scene.effects:
        raise SceneError(
            f"effects = {scene.effects!r}: 'hydrodynamics' needs 'drag' (it evaluates the drag "
            "law on its local window and adds the nonlocal flow); allowed: add 'drag'"
        )
    if scene.drag.model == "constant":
        raise SceneError(
            "drag.model = 'constant' with the hydrodynamics effect: the local drag then comes "
            "from slender-body theory on the window, not from a constant; allowed: "
            "drag.model = 'cox' or 'finite_re'"
        )
    if scene.numerics.freeze_beyond_mm > 0.0:
        raise SceneError(
            f"numerics.freeze_beyond_mm = {scene.numerics.freeze_beyond_mm!r} with the "
            "hydrodynamics effect: the frozen tail is a lumped load, not a source of flow; "
            "allowed: 0 with hydrodynamics"
        )


def flow_rows(scene: Scene) -> list[list[float]]:
    """The flow schedule as rows [t_s, q_outer_ml_min, q_inner_ml_min] (from the table, the
    CSV file, or the constant rates)."""
    if scene.flow.schedule_csv:
        path = Path(scene.flow.schedule_csv)
        if not path.is_file():
            why = "is a directory" if path.is_dir() else "does not exist"
            raise SceneError(f"flow.schedule_csv = {str(path)!r} {why}; allowed: a CSV file")
        import csv

        need = ["t_s", "q_outer_ml_min", "q_inner_ml_min"]
        rows = []
        try:
            with path.open(newline="", encoding="utf-8") as f:
                reader = csv.DictReader(f)
                if reader.fieldnames is None or any(c not in reader.fieldnames for c in need):
                    raise SceneError(
                        f"flow.schedule_csv = {str(path)!r} has columns {reader.fieldnames!r}; "
                        f"allowed: a header with {', '.join(need)}"
                    )
                for k, rec in enumerate(reader):
                    try:
                        rows.append([float(rec[c]) for c in need])
                    except (TypeError, ValueError) as exc:
                        raise SceneError(
                            f"flow.schedule_csv = {str(path)!r} row {k + 1}: {rec!r} is not numeric"
                        ) from exc
        except (OSError, UnicodeDecodeError, csv.Error) as exc:
            raise SceneError(
                f"flow.schedule_csv = {str(path)!r} cannot be read as CSV text ({exc})"
            ) from exc
        if not rows:
            raise SceneError(f"flow.schedule_csv = {str(path)!r} holds no rows")
        return rows
    if scene.flow.schedule:
        return [list(r) for r in scene.flow.schedule]
    return [[0.0, scene.flow.q_outer_ml_min, scene.flow.q_inner_ml_min]]


def _check_inner_flow(scene: Scene, rows: list, key: str) -> None:
    phi_max = scene.inclusions.max_inner_fraction
    tabled = bool(scene.flow.schedule or scene.flow.schedule_csv)
    for k, (_, qo, qi) in enumerate(rows):
        where = f"{key}[{k}]" if tabled else "flow.q_inner_ml_min"
        if qi > 0 and "inclusions" not in scene.effects:
            raise SceneError(
                f"{where}: q_inner_ml_min = {qi!r} > 0 but effects = {scene.effects!r} does not "
                "list 'inclusions'; allowed: add 'inclusions', or set the inner flow to 0"
            )
        if qi > 0 and qi > phi_max / (1.0 - phi_max) * qo:
            raise SceneError(
                f"{where}: q_inner_ml_min = {qi!r} is more than the needle allows with "
                f"q_outer_ml_min = {qo!r}: the inner fluid may take at most "
                f"{phi_max:g} of the flow (inclusions.max_inner_fraction), i.e. "
                f"q_inner_ml_min <= {phi_max / (1.0 - phi_max) * qo:.4g}"
            )


def _check_schedule(key: str, rows: list, width: int, limits: tuple | None) -> None:
    last = -math.inf
    for k, row in enumerate(rows):
        if not isinstance(row, list | tuple) or len(row) != width:
            raise SceneError(f"{key}[{k}] = {row!r} must be a list of {width} numbers")
        for x in row:
            if isinstance(x, bool) or not isinstance(x, int | float) or not _finite(x):
                raise SceneError(
                    f"{key}[{k}] = {row!r} holds {x!r}, a non-finite or non-number value; allowed: "
                    "finite numbers only"
                )
        t = row[0]
        if t < 0:
            raise SceneError(f"{key}[{k}] time = {t!r} s is negative; times must be >= 0")
        if t <= last:
            raise SceneError(f"{key}[{k}] time = {t!r} s does not rise after {last!r} s")
        last = t
        if limits is not None:
            for x, hi in zip(row[1:], limits, strict=True):
                if x < 0 or x > hi:
                    raise SceneError(
                        f"{key}[{k}] flow = {x!r} ml/min; allowed: a number in [0, {hi:g}]"
                    )


def _finite(x: float) -> bool:
    try:
        return math.isfinite(x)
    except OverflowError:  # an int beyond the float range
        return False


def _check_path(rows: list) -> None:
    """Waypoints: positions within +-1e4 mm, direction components in [-1, 1], not zero."""
    for k, row in enumerate(rows):
        for name, x in zip(("x_mm", "y_mm", "z_mm"), row[1:4], strict=True):
            if abs(x) > 1e4:
                raise SceneError(
                    f"needle.path[{k}] {name} = {x!r}; allowed: a number in [-10000, 10000]"
                )
        for name, x in zip(("dx", "dy", "dz"), row[4:7], strict=True):
            if abs(x) > 1.0:
                raise SceneError(f"needle.path[{k}] {name} = {x!r}; allowed: a number in [-1, 1]")
        if math.hypot(*row[4:7]) < 1e-6:
            raise SceneError(f"needle.path[{k}] direction = {row[4:7]!r} must be a non-zero vector")


def scene_from_dict(data: dict[str, Any]) -> Scene:
    """Build and validate a scene from a nested dict (as read from TOML)."""
    scene = _build(Scene, apply_physics_preset(data), "")
    _check_tables(scene)
    num = effective_numerics(scene)
    check_resolution(scene, num["node_spacing_mm"], flow_rows(scene))
    return scene


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


def parse_override(text: str) -> tuple[str, Any]:
    """Parse ``key=value`` from the CLI; the value is read as TOML (number, list, string)."""
    if "=" not in text:
        raise SceneError(f"override {text!r} must look like key=value (e.g. duration_s=1.5)")
    key, raw = text.split("=", 1)
    key = key.strip()
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw  # a bare word: a string
    return key, value


def apply_overrides(data: dict[str, Any], overrides: dict[str, Any] | None) -> dict[str, Any]:
    """Set dotted keys in a nested dict (a copy); unknown keys fail at validation."""
    out = _deep_copy(data)
    if overrides is not None and not isinstance(overrides, dict):
        raise SceneError(f"overrides = {overrides!r}; allowed: a dict of dotted keys to values")
    for key, value in (overrides or {}).items():
        if not isinstance(key, str):
            raise SceneError(f"override key {key!r} is not a string; allowed: dotted keys")
        parts = key.split(".")
        node = out
        for p in parts[:-1]:
            nxt = node.setdefault(p, {})
            if not isinstance(nxt, dict):
                raise SceneError(f"override {key!r}: {p!r} is a value, not a table of keys")
            node = nxt
        node[parts[-1]] = value
    return out


def _deep_copy(d: Any) -> Any:
    if isinstance(d, dict):
        return {k: _deep_copy(v) for k, v in d.items()}
    if isinstance(d, list):
        return [_deep_copy(v) for v in d]
    return d


def builtin_scene_names() -> list[str]:
    """Names of the scenes shipped with bathprint."""
    files = resources.files("bathprint") / "scenes"
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def read_scene_data(name_or_path: str | Path) -> dict[str, Any]:
    """Raw dict of a built-in scene (by name) or a TOML file (by path)."""
    p = Path(name_or_path)
    if p.suffix == ".toml" or p.exists():
        if not p.is_file():
            why = "is a directory" if p.is_dir() else "does not exist"
            raise SceneError(f"scene file {str(p)!r} {why}; allowed: a TOML file")
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise SceneError(f"scene file {str(p)!r} cannot be read as text ({exc})") from exc
    else:
        names = builtin_scene_names()
        if str(name_or_path) not in names:
            raise SceneError(
                f"scene {str(name_or_path)!r} is neither a TOML file nor a built-in scene; "
                f"built-in scenes: {', '.join(names)}"
            )
        text = (resources.files("bathprint") / "scenes" / f"{name_or_path}.toml").read_text()
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(f"scene {str(name_or_path)!r} is not valid TOML: {exc}") from exc


def load_scene(
    name_or_path: str | Path | Scene | dict, overrides: dict[str, Any] | None = None
) -> Scene:
    """A validated :class:`Scene` from a built-in name, a TOML path, a dict or a Scene."""
    if isinstance(name_or_path, Scene):
        data = name_or_path.to_dict()
    elif isinstance(name_or_path, dict):
        data = name_or_path
    elif isinstance(name_or_path, str | Path):
        data = read_scene_data(name_or_path)
    else:
        raise SceneError(
            f"scene = {name_or_path!r}; allowed: a built-in scene name, a TOML path, a dict "
            "or a Scene"
        )
    merged = apply_overrides(data, overrides)
    _check_effects_against_preset(merged, overrides)
    return scene_from_dict(merged)


def _check_effects_against_preset(data: dict[str, Any], overrides: dict[str, Any] | None) -> None:
    """Refuse overridden ``effects`` that the scene's physics preset would change: a preset
    decides inertia, contact and hydrodynamics, and silently dropping or adding one of them
    to a list given explicitly would run another model than the one asked for. (Overriding
    ``physics`` too applies the preset to the list on purpose.)"""
    name = data.get("physics", "custom")
    listed = (overrides or {}).get("effects")
    if name not in PHYSICS_PRESETS or not isinstance(listed, list) or "physics" in overrides:
        return
    chosen = sorted(e for e in listed if e in PRESET_EFFECTS)
    wanted = sorted(PHYSICS_PRESETS[name]["effects"])
    if chosen != wanted:
        raise SceneError(
            f"effects = {listed!r} lists {chosen or 'none'} of {', '.join(PRESET_EFFECTS)}, "
            f"which physics = {name!r} decides (it has: {wanted or 'none'}); allowed: the "
            "preset's choice, or physics = 'custom' to choose them yourself"
        )


def scene_to_toml(scene: Scene) -> str:
    """The scene as TOML text that :func:`load_scene` reads back to an equal Scene
    (``bathprint show``)."""
    import tomli_w

    return tomli_w.dumps(scene.to_dict())


def scene_summary_line(scene: Scene) -> str:
    """One line for ``bathprint scenes``."""
    return f"{scene.name:<24} {scene.description}"

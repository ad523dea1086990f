"""Layout of the arrays and records the numba kernels share.

The scalar parameters of a model and the stepper's memory are numpy structured records
(fields by name, see :mod:`bathprint.core.records`); per-segment material records and the
counters are plain arrays addressed by the integer constants below.
"""

from __future__ import annotations

import numpy as np

# --- material record: one row per segment (``seg_mat[j, COL]``) -------------------
MAT_BIRTH_TIME = 0  # s, time the segment's material centre left the needle
MAT_YOUNGS_MODULUS = 1  # Pa
MAT_RADIUS = 2  # m
MAT_DENSITY = 3  # kg/m^3
MAT_KAPPA_X = 4  # natural curvature vector, 1/m (lab frame, transported with the material)
MAT_KAPPA_Y = 5
MAT_KAPPA_Z = 6
MAT_INNER_FRACTION = 7  # volume fraction of co-extruded inner fluid (0 for pure gel)
MAT_BEND_FACTOR = 8  # -, bending stiffness / that of pure gel of the same modulus and radius
MAT_STRETCH_FACTOR = 9  # -, stretching stiffness / that of pure gel
MAT_INCLUSION_SIZE = 10  # m, equivalent diameter n of the droplets (0: none)
MAT_INCLUSION_SPACING = 11  # m, centre-to-centre spacing m of the droplets along the filament
N_MAT = 12

MATERIAL_COLUMNS = (
    "birth_time_s",
    "youngs_modulus_pa",
    "radius_m",
    "density_kg_m3",
    "natural_curvature_x_1_m",
    "natural_curvature_y_1_m",
    "natural_curvature_z_1_m",
    "inner_volume_fraction",
    "bend_stiffness_factor",
    "stretch_stiffness_factor",
    "inclusion_size_m",
    "inclusion_spacing_m",
)

# --- scalar parameters: one record (``model.params[0]``, a numpy structured scalar) ------
# Kernels read them by name (``p = model.params[0]; p.mu_s``); Python reads and writes the
# same fields through ``Model.p`` (``sim.model.p.fixed_step = 1e-3``). SI units throughout.
PARAMS_FIELDS: tuple[tuple[str, str, str], ...] = (
    # (name, numpy type, meaning and unit)
    ("gravity", "f8", "m/s^2, magnitude; gravity points along -z"),
    ("bath_density_top", "f8", "kg/m^3 at the free surface"),
    ("bath_density_gradient", "f8", "kg/m^3 per m of depth (>= 0: denser below)"),
    ("bath_surface_z", "f8", "m"),
    ("mu_s", "f8", "Pa s, slender-body drag coefficient (tangential; normal is 2 mu_s)"),
    ("bath_flow", "3f8", "m/s, uniform bath flow velocity"),
    ("floor_z", "f8", "m"),
    ("floor_stiffness", "f8", "Pa, force per length per penetration depth"),
    ("friction_coefficient", "f8", "-, Coulomb coefficient of the floor"),
    ("friction_velocity", "f8", "m/s, regularisation of Coulomb friction"),
    ("added_mass_coefficient", "f8", "-, transverse added mass C_a rho_bath A"),
    ("end_load", "3f8", "N, dead load on the free end"),
    ("node_spacing", "f8", "m, target rest length of a segment"),
    ("needle_area", "f8", "m^2, pi d^2 / 4"),
    ("exit_youngs_modulus", "f8", "Pa, modulus of material as it leaves the needle"),
    ("exit_radius", "f8", "m"),
    ("exit_density", "f8", "kg/m^3"),
    ("tolerance", "f8", "-, local error per step relative to the node spacing"),
    ("fixed_step", "f8", "s, > 0 selects fixed steps"),
    ("min_step", "f8", "s"),
    ("max_step", "f8", "s"),
    ("stretch_limit", "f8", "-, |l/l0 - 1| above this is divergence"),
    ("newton_tolerance", "f8", "-, Newton update norm in units of the error tolerance"),
    ("max_newton", "i8", "-, Newton iterations per stage"),
    ("inertial", "?", "the state carries velocities (the inertia effect is listed)"),
    ("imperfection", "f8", "m, transverse offset given to each node born at the needle"),
    ("seed", "i8", "-, seed of the (counter-based, chunking-independent) imperfections"),
    ("initial_age", "f8", "s, age of the material of the initial filament at t = 0"),
    ("max_strain_change", "f8", "-, adaptive steps changing a segment's strain more are retried"),
    ("max_inlet_growth", "f8", "-, node spacings the inlet may grow in one adaptive step"),
    ("clamped", "?", "the filament hangs from the needle (tip and ghost prescribed)"),
    ("gelation", "?", "the gelation effect is listed"),
    ("gel_initial_modulus", "f8", "Pa, E of gel at age 0"),
    ("gel_final_modulus", "f8", "Pa, E of fully set gel"),
    ("gel_rate", "f8", "1/s, crosslinking rate k"),
    ("curvature_memory", "?", "natural curvature follows the current one as the gel sets"),
    ("inclusions", "?", "the inclusions effect is listed"),
    ("inner_density", "f8", "kg/m^3 of the co-extruded inner fluid"),
    ("inclusion_offset", "f8", "-, Delta = (r1 - r2) / r"),
    ("offset_angle", "f8", "rad, direction of the offset around the needle axis"),
    ("curvature_coefficient", "f8", "-, kappa0 = C Delta phi / r"),
    ("slug_fraction", "f8", "-, drops wider than this fraction of the diameter are slugs"),
    ("newton_reuse", "?", "modified Newton (reuse the factorised Jacobian)"),
    ("max_strain", "f8", "-, adaptive steps ending with a larger |l/l0 - 1| are retried"),
    ("freeze_beyond", "f8", "m, material further behind the needle is frozen (0: off)"),
    ("freeze_clamped", "?", "the frozen tail holds the active end's tangent (joint bending)"),
    ("buckling_steps", "f8", "-, adaptive steps per e-folding of the fastest buckling mode"),
    ("integrator", "i8", "-, one of INTEGRATOR_*"),
    ("contact_stiffness", "f8", "Pa, self-contact force per length per penetration"),
    ("contact_distance_factor", "f8", "-, contact distance / the sum of the two radii"),
    ("contact_width_fraction", "f8", "-, penetration (in contact distances) of the soft onset"),
    ("contact_near_gap", "f8", "-, pairs within this gap (contact distances) are near"),
    ("contact_parallel_sin2", "f8", "-, sin^2 of the angle below which contact is mid-overlap"),
    ("contact_sliding_sin2", "f8", "-, sin^2 of the angle from which it is at closest points"),
    ("contact_friction", "f8", "-, Coulomb coefficient between touching segments"),
    ("contact_friction_velocity", "f8", "m/s, regularisation of that friction"),
    ("contact_damping_time", "f8", "s, Kelvin-Voigt time of the normal dashpot (0: none)"),
    ("krylov_tolerance", "f8", "-, GMRES residual relative to the right-hand side"),
    ("contact_exact_hessian", "?", "contact's Newton matrix: exact Hessian (else Gauss-Newton)"),
    ("gel_model", "i8", "-, one of GEL_* (gelation's material model)"),
    ("gel_diffusivity", "f8", "m^2/s, Ca2+ diffusivity D in the gel (surface model)"),
    ("gel_bath_calcium", "f8", "mol/m^3, Ca2+ concentration c0 of the bath (surface model)"),
    ("gel_binding_capacity", "f8", "mol/m^3, Ca2+ bound per volume of set gel c_b"),
    ("gel_front_lambda", "f8", "-, Neumann constant: the front is 2 lambda sqrt(D t) deep early"),
    ("gel_shell_modulus", "f8", "Pa, E of the set gel shell (surface model)"),
    ("gel_core_modulus", "f8", "Pa, E of the ungelled core (surface model; > 0)"),
    ("drag_model", "i8", "-, DRAG_MU_S (cox, constant: mu_s) or DRAG_FINITE_RE"),
    ("bath_viscosity", "f8", "Pa s, dynamic viscosity of the bath"),
    ("drag_length", "f8", "m, L of the slender-body logarithm ln(L/r) (finite_re's cut-off)"),
    ("hydro_cutoff", "f8", "m, arclength a splitting slender-body flow into local and nonlocal"),
    ("hydro_coupling", "i8", "-, HYDRO_IMPLICIT or HYDRO_LAGGED"),
    ("hydro_blob", "f8", "m, regularisation eps of the nonlocal Stokeslets (0: singular)"),
    ("hydro_screening", "?", "nonlocal Stokeslets screened beyond the Oseen length (finite_re)"),
    ("hydro_fmm_nodes", "i8", "-, active nodes from which the FMM sums the far field (0: never)"),
    ("hydro_fmm_precision", "f8", "-, requested relative precision of the FMM"),
    ("hydro_kernel", "i8", "-, HYDRO_SLENDER_BODY or HYDRO_RPY: the nonlocal flow's kernel"),
    ("hydro_rpy_radii", "f8", "-, RPY kernel: each node's blob radius over its radius"),
    ("hydro_rpy_shift_par", "f8", "-, RPY kernel: a full window side's shift of Lam along"),
    ("hydro_rpy_shift_perp", "f8", "-, ... and across the filament (effects._rpy.window_shift)"),
    ("solution_viscosity", "f8", "Pa s, shear viscosity eta of the alginate solution"),
    ("trouton_ratio", "f8", "-, extensional / shear viscosity of the solution (3: Newtonian)"),
    ("line_search", "?", "Newton updates backtrack until the force residual decreases"),
    ("liquid", "?", "the liquid effect is listed: rest lengths and curvatures relax (Maxwell)"),
    ("liquid_viscosity", "f8", "Pa s, extensional viscosity eta_m of the Maxwell element"),
    ("liquid_set_time", "f8", "s, age at the gel point (bulk gelation): the liquid sets"),
    ("liquid_exponent", "f8", "-, s of eta_m (1 - X/X_c)^-s as the gel point nears"),
    ("drag_cox", "?", "mu_s is Cox's 2 pi mu / ln(L/r) (not a constant)"),
)
PARAMS_DTYPE = np.dtype([(name, kind) for name, kind, _ in PARAMS_FIELDS])

# --- effects ------------------------------------------------------------------------
E_ELASTICITY = 0
E_DRAG = 1
E_GRAVITY = 2
E_FLOOR = 3
E_INERTIA = 4
E_END_LOAD = 5
E_GELATION = 6  # a material effect: updates modulus and natural curvature after each step
E_INCLUSIONS = 7  # a material effect: composite properties of material at its birth
E_CONTACT = 8  # self-contact between non-adjacent segments (couplings off the band)
E_HYDRODYNAMICS = 9  # nonlocal slender-body flow (the drag's local law with a nonlocal part)
E_VISCOSITY = 10  # viscous stress of the alginate solution in the rod (Kelvin-Voigt)
E_LIQUID = 11  # a material effect: rest lengths and curvatures relax while liquid (Maxwell)
N_EFFECTS = 12

EFFECT_NAMES = (
    "elasticity",
    "drag",
    "gravity",
    "floor",
    "inertia",
    "end_load",
    "gelation",
    "inclusions",
    "contact",
    "hydrodynamics",
    "viscosity",
    "liquid",
)

# --- gelation's material models (``p.gel_model``) -------------------------------------
GEL_BULK = 0  # modulus from the material's age (first-order crosslinking)
GEL_SURFACE = 1  # a set shell growing inward by Ca2+ diffusion around a liquid core
GEL_MODEL_NAMES = ("bulk", "surface")
# --- drag laws and the coupling of the nonlocal flow ------------------------------------
DRAG_MU_S = 0  # cox or constant: -mu_s (2 u_perp + u_par)
DRAG_FINITE_RE = 1  # the finite-Reynolds-number law (effects/_drag_laws.py)
DRAG_MODELS = ("cox", "constant", "finite_re")
HYDRO_IMPLICIT = 0  # the nonlocal flow inside Newton: its Jacobian's action in the GMRES solve
HYDRO_LAGGED = 1  # the nonlocal flow from the step's start (Tornberg & Shelley 2004)
HYDRO_COUPLINGS = ("implicit", "lagged")
HYDRO_SLENDER_BODY = 0  # Lighthill's Stokeslet segments beyond the window (effects._stokeslet)
HYDRO_RPY = 1  # Rotne-Prager-Yamakawa blobs at the nodes (effects._rpy): positive definite
HYDRO_KERNELS = ("slender_body", "rpy")

# --- integrators ----------------------------------------------------------------------
INTEGRATOR_IMPLICIT = 0  # SDIRK2, Newton on the banded Jacobian
INTEGRATOR_EXPLICIT = 1  # forward / symplectic Euler (reference)
INTEGRATOR_IMPLICIT_EULER = 2  # backward Euler, Newton on the banded Jacobian
INTEGRATOR_SDIRK4 = 3  # Hairer-Wanner SDIRK4 (order 4, 5 stages), Newton as SDIRK2
INTEGRATOR_NAMES = ("implicit", "explicit", "implicit_euler", "sdirk4")

# --- status of a call to the stepper ---------------------------------------------------
STATUS_OK = 0
STATUS_CAPACITY = 1  # node arrays are full; grow and call again
STATUS_NAN = 2
STATUS_NEWTON = 3  # Newton failed at the smallest allowed step
STATUS_STRETCH = 4
STATUS_STEP_LIMIT = 5  # step budget of this call used up; call again
STATUS_ERROR = 6  # the error estimate stays above tolerance down to the smallest step
STATUS_STRAIN = 7  # strains stay beyond numerics.max_strain (or change too fast) at every step
STATUS_CONTACT = 8  # steps would let segments pass through each other even at the smallest step
STATUS_KRYLOV = 9  # the Krylov solve of Newton's linear systems stalled at the smallest step
STATUS_MESSAGES = {
    STATUS_NAN: "non-finite position or velocity",
    STATUS_NEWTON: "Newton iteration failed to converge at the smallest allowed time step",
    STATUS_STRETCH: "segment stretch beyond the allowed bound",
    STATUS_ERROR: "local error above tolerance even at the smallest allowed time step",
    STATUS_STRAIN: "segment strain beyond numerics.max_strain (or changing faster than "
    "numerics.max_strain_change) even at the smallest allowed time step: the filament is "
    "too soft for its load at this resolution; raise numerics.max_strain to accept it",
    STATUS_CONTACT: "self-contact: a step would let two segments pass through each other even "
    "at the smallest allowed time step (or at the fixed step)",
    STATUS_KRYLOV: "the Krylov solve of Newton's linear systems (couplings off the band) "
    "stalled even at the smallest allowed time step",
}

# --- integer counters (``counters[C_*]``) ----------------------------------------------
C_STEPS = 0
C_REJECTED = 1
C_NEWTON_ITERATIONS = 2
C_FAIL_NODE = 3
C_SPLITS = 4
C_NEWTON_FAILURES = 5
C_FACTORIZATIONS = 6  # Jacobians assembled and LU-factorised
C_KRYLOV_ITERATIONS = 7  # GMRES iterations (only with couplings off the band)
C_KRYLOV_FAILURES = 8  # GMRES solves that stalled (each a Newton failure)
C_CONTACT_REJECTIONS = 9  # steps retried because segments could have passed through each other
C_DAMPED_NEWTON = 10  # Newton iterations that applied a damped (shortened) update
C_BACKTRACKS = 11  # line-search backtracks (each one force evaluation, no solve)
N_COUNTERS = 12

# --- band storage -------------------------------------------------------------------------
# A node's force depends on nodes i-2..i+2 (bending), so the Jacobian has 8 sub- and
# super-diagonals in the 3-per-node numbering. Row-oriented storage with room for the
# fill-in of partial pivoting: A[i, j] lives at band[i, j - i + KL], 0 <= . < BAND_WIDTH.
KL = 8
KU = 8
BAND_WIDTH = 2 * KL + KU + 1

# --- what the stepper remembers between steps: one record (``ws.solver[0]``) -----------
SOLVER_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("lu_valid", "?", "the LU in ``band`` matches the current h gamma and unknowns"),
    ("full_newton_steps", "f8", "accepted steps still to take with full Newton after a failure"),
    ("newton_eta", "f8", "Newton contraction eta = theta / (1 - theta) of this step (0: none)"),
    ("lu_hg", "f8", "s, h gamma of the factorised Jacobian"),
    ("lu_nd", "i8", "unknowns of the factorised Jacobian"),
    ("newton_slow", "?", "a stage of this step contracted slower than REUSE_THETA"),
    ("norm_extra", "f8", "degrees of freedom of the frozen tail, counted in the RMS norms"),
    ("krylov_failed", "?", "the last Newton failure was a stalled Krylov solve"),
)
SOLVER_DTYPE = np.dtype([(name, kind) for name, kind, _ in SOLVER_FIELDS])

# --- the frozen tail's lumped load (bathprint.core.freezing): one record (``ws.tail[0]``) ---
TAIL_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("on", "?", "a tail is frozen"),
    ("force", "3f8", "N, its net weight and the drag of the bath's flow on it"),
    ("drag", "(3,3)f8", "N s/m, its drag tensor: force -drag (v - u_bath) at the active end"),
    ("mass", "(3,3)f8", "kg, its mass with added mass (with inertia): force -mass a at the end"),
    ("normal", "f8", "N, the weight the floor carries (floor mode)"),
    ("on_floor", "?", "the tail rests on the floor and slides at its height"),
    ("clamped", "?", "the joint bends: the tail holds the active end's tangent"),
    ("edge", "3f8", "m, the joining segment x_f - x_(f-1): constant while the tail translates"),
    ("bend", "f8", "N m^2, bending stiffness of the joining segment"),
    ("rest", "f8", "m, rest length of the joining segment"),
    ("kappa", "3f8", "1/m, natural curvature of the joining segment"),
)
TAIL_DTYPE = np.dtype([(name, kind) for name, kind, _ in TAIL_FIELDS])

# --- what self-contact remembers between steps: one record (``ws.contact.memory[0]``) ------
CONTACT_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("delta_max", "f8", "m, the largest contact distance on the rod"),
    ("skin", "f8", "m, search distance beyond delta_max (a Verlet skin)"),
    ("min_separation", "i8", "segments closer than this along the rod never pair"),
    ("ratio", "f8", "-, the last step's worst displacement / allowance (>= 1: retried)"),
    ("pair_i", "i8", "segments of the pair that set the last violation (active-rod indices)"),
    ("pair_j", "i8", ""),
    ("max_step_disp", "f8", "m, largest relative node displacement of the last accepted step"),
    ("last_ratio", "f8", "-, the no-pass-through ratio of the last accepted step"),
    ("last_step", "f8", "s, the last accepted step"),
    ("built_nodes", "i8", "nodes of the rod when the pairs were found (-1: never)"),
    ("built_frozen", "i8", "frozen nodes then"),
    ("margin", "f8", "m, how much closer than delta + margin a pair is near (this step)"),
    ("motion_nodes", "i8", "nodes whose motion in the last step checked is in contact.motion[0]"),
    ("n_near", "i8", "pairs near enough to touch within the step"),
    ("builds", "i8", "spatial-hash builds so far"),
)
CONTACT_DTYPE = np.dtype([(name, kind) for name, kind, _ in CONTACT_FIELDS])

# --- what the hydrodynamics effect remembers: one record (``ws.hydro.memory[0]``) ----------
HYDRO_FIELDS: tuple[tuple[str, str, str], ...] = (
    ("linearized", "?", "implicit: the Newton matrix has a nonlocal part (GMRES applies it)"),
    ("lin_nodes", "i8", "active nodes of that linearisation"),
    ("lin_free", "i8", "... its free nodes"),
    ("lin_seg", "i8", "... its filament segments"),
    ("mu", "f8", "Pa s, the bath's viscosity (what the operator needs of the model)"),
    ("cutoff", "f8", "m, the arclength a of the split"),
    ("blob", "f8", "m, the regularisation eps"),
    ("screening", "?", "the Stokeslets are screened beyond the Oseen length (finite_re)"),
    ("fmm_nodes", "i8", "-, segments from which the FMM sums (0: never)"),
    ("fmm_precision", "f8", "-"),
    ("kernel", "i8", "-, HYDRO_SLENDER_BODY or HYDRO_RPY"),
    ("rpy_radii", "f8", "-, RPY kernel: blob radius over the node's radius"),
    ("evaluations", "i8", "-, evaluations of the nonlocal flow (direct: O(N^2) each)"),
    ("u_valid", "?", "lagged: u_nl is the flow at the state of u_time with u_nodes nodes"),
    ("u_time", "f8", "s"),
    ("u_nodes", "i8", ""),
    ("next_valid", "?", "lagged: u_next is the flow at the end of the last attempted step"),
    ("next_time", "f8", "s"),
    ("next_nodes", "i8", ""),
    ("lag_error", "f8", "-, lagged: the last step's lag error estimate (error-norm units)"),
    ("reynolds_max", "f8", "-, largest Re_d = |u| d / nu of the last evaluation"),
    ("oseen_min", "f8", "m, smallest Oseen length 2 nu / |u| of the last evaluation"),
)
HYDRO_DTYPE = np.dtype([(name, kind) for name, kind, _ in HYDRO_FIELDS])

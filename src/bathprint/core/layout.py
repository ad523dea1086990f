"""Index layout of the flat arrays that the numba kernels share.

The compiled model is a handful of flat float64 arrays (see :mod:`bathprint.core.model`).
Kernels address them through the integer constants below, so that every effect
has the same signature and nothing but arrays crosses into numba.
"""

from __future__ import annotations

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

# --- scalar parameters (``params[P_*]``) -------------------------------------------
P_GRAVITY = 0  # m/s^2, magnitude; gravity points along -z
P_BATH_DENSITY_TOP = 1  # kg/m^3 at the free surface
P_BATH_DENSITY_GRADIENT = 2  # kg/m^3 per m of depth (>= 0: denser below)
P_BATH_SURFACE_Z = 3  # m
P_MU_S = 4  # Pa s, slender-body drag coefficient (tangential; normal is 2 mu_s)
P_FLOW_X = 5  # m/s, uniform bath flow velocity
P_FLOW_Y = 6
P_FLOW_Z = 7
P_FLOOR_Z = 8  # m
P_FLOOR_STIFFNESS = 9  # Pa (force per length per penetration depth)
P_FRICTION_COEFFICIENT = 10  # -
P_FRICTION_VELOCITY = 11  # m/s, regularisation of Coulomb friction
P_ADDED_MASS_COEFFICIENT = 12  # -, transverse added mass C_a rho_bath A
P_END_LOAD_X = 13  # N, dead load on the free end
P_END_LOAD_Y = 14
P_END_LOAD_Z = 15
P_NODE_SPACING = 16  # m, target rest length of a segment
P_NEEDLE_AREA = 17  # m^2, pi d^2 / 4
P_EXIT_YOUNGS_MODULUS = 18  # Pa, modulus of material as it leaves the needle
P_EXIT_RADIUS = 19  # m
P_EXIT_DENSITY = 20  # kg/m^3
P_TOLERANCE = 21  # -, local error per step relative to the node spacing
P_FIXED_STEP = 22  # s, > 0 selects fixed steps
P_MIN_STEP = 23  # s
P_MAX_STEP = 24  # s
P_STRETCH_LIMIT = 25  # -, |l/l0 - 1| above this is divergence
P_NEWTON_TOL = 26  # -, Newton update norm (in units of the error tolerance)
P_MAX_NEWTON = 27  # -, iterations per stage
P_INERTIA = 28  # 1.0 when the state carries velocities
P_IMPERFECTION = 29  # m, transverse offset amplitude given to each node born at the needle
P_SEED = 30  # -, seed of the (counter-based, chunking-independent) imperfections
P_INITIAL_AGE = 31  # s, age of the material of the initial filament at t = 0
P_MAX_STRAIN_CHANGE = 32  # -, adaptive steps changing a segment's strain more are rejected
P_MAX_INLET_GROWTH = 33  # -, node spacings the inlet may grow in one adaptive step
P_CLAMPED = 34  # 1: the filament hangs from the needle (tip and ghost prescribed); 0: free
P_GELATION = 35  # 1 when the gelation effect is listed
P_GEL_INITIAL_MODULUS = 36  # Pa, E of gel at age 0
P_GEL_FINAL_MODULUS = 37  # Pa, E of fully set gel
P_GEL_RATE = 38  # 1/s, k
P_CURVATURE_MEMORY = 39  # 1: natural curvature follows the current one as the gel sets
P_INCLUSIONS = 40  # 1 when the inclusions effect is listed
P_INNER_DENSITY = 41  # kg/m^3
P_INCLUSION_OFFSET = 42  # -, Delta = (r1 - r2) / r
P_OFFSET_ANGLE = 43  # rad, direction of the offset around the needle axis
P_CURVATURE_COEFFICIENT = 44  # -, kappa0 = C Delta phi / r
P_SLUG_FRACTION = 45  # -, droplets wider than this fraction of the filament diameter are slugs
P_NEWTON_REUSE = 46  # 1: modified Newton (reuse the factorised Jacobian within a step)
P_MAX_STRAIN = 47  # -, adaptive steps ending with a larger |l/l0 - 1| are retried shorter
P_FREEZE_BEYOND = 48  # m, material further behind the needle is frozen (0: off)
P_BUCKLING_STEPS = 49  # -, adaptive steps per e-folding of the fastest buckling mode (0: off)
N_PARAMS = 50

# --- effects ------------------------------------------------------------------------
E_ELASTICITY = 0
E_DRAG = 1
E_GRAVITY = 2
E_FLOOR = 3
E_INERTIA = 4
E_END_LOAD = 5
E_GELATION = 6  # a material effect: updates modulus and natural curvature after each step
E_INCLUSIONS = 7  # a material effect: composite properties of material at its birth
N_EFFECTS = 8

EFFECT_NAMES = (
    "elasticity",
    "drag",
    "gravity",
    "floor",
    "inertia",
    "end_load",
    "gelation",
    "inclusions",
)

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
STATUS_MESSAGES = {
    STATUS_NAN: "non-finite position or velocity",
    STATUS_NEWTON: "Newton iteration failed to converge at the smallest allowed time step",
    STATUS_STRETCH: "segment stretch beyond the allowed bound",
    STATUS_ERROR: "local error above tolerance even at the smallest allowed time step",
    STATUS_STRAIN: "segment strain beyond numerics.max_strain (or changing faster than "
    "numerics.max_strain_change) even at the smallest allowed time step: the filament is "
    "too soft for its load at this resolution; raise numerics.max_strain to accept it",
}

# --- integer counters (``counters[C_*]``) ----------------------------------------------
C_STEPS = 0
C_REJECTED = 1
C_NEWTON_ITERATIONS = 2
C_FAIL_NODE = 3
C_SPLITS = 4
C_NEWTON_FAILURES = 5
C_FACTORIZATIONS = 6  # Jacobians assembled and LU-factorised
N_COUNTERS = 7

# --- band storage -------------------------------------------------------------------------
# A node's force depends on nodes i-2..i+2 (bending), so the Jacobian has 8 sub- and
# super-diagonals in the 3-per-node numbering. Row-oriented storage with room for the
# fill-in of partial pivoting: A[i, j] lives at band[i, j - i + KL], 0 <= . < BAND_WIDTH.
KL = 8
KU = 8
BAND_WIDTH = 2 * KL + KU + 1

# slot of the scratch array ``work`` that says the LU in ``band`` matches the current h gamma
W_LU_VALID = 390
# slot counting accepted steps still to take with full Newton after a Newton failure
W_FULL_NEWTON_STEPS = 391
# slot with the Newton contraction estimate eta = theta / (1 - theta) measured in the current
# step (0: not yet, taken as 1); it lets the step's later stages stop after one iteration
W_NEWTON_ETA = 392
# h gamma and the size of the factorised Jacobian in ``band`` (reused by the next step when
# both match and Newton contracted fast: see integrators._implicit_step)
W_LU_HG = 393
W_LU_ND = 394
# 1 if a stage of the current step measured a Newton contraction slower than REUSE_THETA
W_NEWTON_SLOW = 395
# 13 slots from here: the frozen tail's lumped load (bathprint.core.freezing)
W_TAIL = 400
# degrees of freedom of the frozen tail: error and Newton norms are RMS over the whole
# filament (frozen nodes contribute zero), so freezing does not tighten the step control
W_NORM_EXTRA = 413
# the frozen tail on the floor: its supported weight (N) and the floor-mode flag
W_TAIL_NORMAL = 414
W_TAIL_ON_FLOOR = 415

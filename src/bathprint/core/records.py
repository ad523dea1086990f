"""The records every kernel takes, in the manner of MuJoCo's ``MjModel`` / ``MjData``.

- :class:`Model`: what the scene compiled into (static while a simulation runs, except
  the flow table that :meth:`~bathprint.Simulation.set_flow` replaces);
- :class:`State`: the rod (node positions and velocities, material records, the inlet's
  bookkeeping) and the counters;
- :class:`Workspace`: preallocated scratch: the stepper's vectors, the Jacobian and its
  factors, the solver's memory between steps, and small named scratch arrays;
- :class:`Rod`, :class:`Stage`, :class:`Out`: what one force evaluation sees: the active rod
  (array views past the frozen tail), the stage's time and Jacobian coefficients, and where
  the forces, the Jacobian and any couplings off the band go.

All are NamedTuples of numpy arrays and scalars, which numba takes as arguments and builds
inside kernels at no cost; the scalar parameters are one numpy structured record
(``model.params[0]``), read by name (``p.mu_s``). Every effect has the same signature,
``accumulate(model, rod, stage, out) -> energy``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from bathprint.core.layout import BAND_WIDTH, HYDRO_DTYPE


class Model(NamedTuple):
    """The compiled scene (SI)."""

    params: np.ndarray  # (1,) PARAMS_DTYPE: the scalar parameters, by name
    enabled: np.ndarray  # (N_EFFECTS,) int64: 1 for the effects the scene lists
    flow: np.ndarray  # (K, 3): t_s, q_outer_m3_s, q_inner_m3_s (linear between knots)
    flow_cum: np.ndarray  # (K, 2): extruded length S (m) and inner volume (m^3) at each knot
    needle: np.ndarray  # (M, 7): t_s, tip position (m), direction


class State(NamedTuple):
    """The filament: nodes from the free end (0, oldest material) to the needle tip and the
    ghost node inside the needle; arrays have spare capacity beyond ``ints[0]`` nodes."""

    pos: np.ndarray  # (3 cap,) m
    vel: np.ndarray  # (3 cap,) m/s
    node_s: np.ndarray  # (cap,) m, extruded length S at which each node left the needle
    seg_rest: np.ndarray  # (cap,) m, rest length of each segment
    seg_mat: np.ndarray  # (cap, N_MAT) material record of each segment (layout.MAT_*)
    ints: np.ndarray  # (3,) int64: n_nodes, n_splits (node births), n_frozen
    clock: np.ndarray  # (2,): t (s), next step size (s)
    counters: np.ndarray  # (N_COUNTERS,) int64 (layout.C_*)
    calls: np.ndarray  # (N_EFFECTS,) int64: kernel calls of each effect
    energies: np.ndarray  # (N_EFFECTS,) J (drag, viscosity: W) of the last force evaluation
    info: np.ndarray  # (3,): time, node, value of the last failure


class Scratch(NamedTuple):
    """Small named scratch arrays of the kernels (no allocation in a step)."""

    blk_a: np.ndarray  # (3, 3) a Jacobian block
    blk_b: np.ndarray  # (3, 3) a second one
    needle: np.ndarray  # (3, 3) rows: needle tip position, direction, velocity now
    birth: np.ndarray  # (3, 3) the same at a segment's birth
    mat_row: np.ndarray  # (N_MAT,) a material record being built
    curvature: np.ndarray  # (2, 3) curvature vectors (gelation's curvature memory)
    edges: np.ndarray  # (3, 3) rows: e1, e2 and the natural curvature of a bending stencil
    bend_grad: np.ndarray  # (6,) gradient of a bending stencil in (e1, e2)
    bend_hess: np.ndarray  # (6, 6) its Hessian
    bend_work: np.ndarray  # (128,) scratch of elasticity's and viscosity's bending stencils
    pair_grad: np.ndarray  # (12,) gradient of a segment pair's distance (contact)
    pair_hess: np.ndarray  # (12, 12) its Hessian
    step_work: np.ndarray  # (3,) scratch of the contact step bound
    pair_x: np.ndarray  # (12,) the four node positions of a segment pair
    law_force: np.ndarray  # (3,) force per length of a drag law (drag, hydrodynamics)
    law_du: np.ndarray  # (3, 3) its derivative in the relative velocity
    law_dt: np.ndarray  # (3, 3) ... and in the tangent
    law_xi: np.ndarray  # (3, 3) its resistance to the local flow (hydrodynamics)
    edge_rates: np.ndarray  # (2, 3) edge velocities of a bending stencil (viscosity)


class Couplings(NamedTuple):
    """Jacobian blocks between nodes further apart than the band holds (contact pairs):
    block k adds ``block[k]`` (3x3) at node block (row[k], col[k]), as assembled (one per
    pair and pair of nodes; several land on one node block). :func:`bathprint.core.banded.
    merge_blocks` sums those of each node block into rows (``merged``), which the products
    stream: half as many blocks on a pressed stack, and each row's sum kept in registers."""

    count: np.ndarray  # (1,) int64: blocks written (may exceed the capacity: grow, retry)
    row: np.ndarray  # (K,) int64 node
    col: np.ndarray  # (K,) int64 node
    block: np.ndarray  # (K, 3, 3)
    merged: np.ndarray  # (2,) int64: merged blocks (-1: not merged since assembly) and rows
    m_start: np.ndarray  # (K + 1,) int64: row r's merged blocks are m_start[r]:m_start[r + 1]
    m_col: np.ndarray  # (K,) int64 node
    m_block: np.ndarray  # (K, 3, 3)
    order: np.ndarray  # (K,) int64: scratch, the blocks in row order


class Krylov(NamedTuple):
    """GMRES workspace of :mod:`bathprint.core.solver` (empty when nothing is off the band)."""

    band_a: np.ndarray  # (3 cap, BAND_WIDTH): the Newton matrix's band, unfactored
    basis: np.ndarray  # (m + 1, 3 cap): Arnoldi vectors
    zbasis: np.ndarray  # (m, 3 cap): the same, preconditioned
    hess: np.ndarray  # (m + 1, m): the Hessenberg matrix
    small: np.ndarray  # (4, m + 1): g, Givens cosines, sines, y
    z: np.ndarray  # (3 cap,)
    coarse: np.ndarray  # (1,) int64: the coarse spacing (nodes) of the axial correction, 0: none
    coarse_band: np.ndarray  # (coarse cap, 3 COARSE_KL + 1): its matrix, band LU in place
    coarse_piv: np.ndarray  # (coarse cap,) int64
    coarse_x: np.ndarray  # (coarse cap,)
    coarse_info: np.ndarray  # (2,) int64: coarse unknowns and half-bandwidth of its LU (0: none)
    e: np.ndarray  # (2, 3 cap): the coarse correction, and its product with the Newton matrix
    inv_diag: np.ndarray  # (3 cap,): reciprocals of the LU's pivots when it took no row swaps
    diagonal: np.ndarray  # (1,) int64: 1 when the LU took no row swaps (then it is in ``lu``)
    lu: np.ndarray  # (3 cap, KL + KU + 1): the LU without row swaps, only the columns it uses


class Contact(NamedTuple):
    """Candidate pairs of self-contact (:mod:`bathprint.core.effects.contact`), rebuilt at the
    start of every step, and the spatial hash that finds them."""

    pairs: np.ndarray  # (P, 2) int64: segments i < j of the active rod
    count: np.ndarray  # (1,) int64: pairs found (may exceed P: grow, rebuild)
    cell_start: np.ndarray  # (buckets + 1,) int64
    seg_order: np.ndarray  # (cap,) int64
    seg_cell: np.ndarray  # (3 cap,) int64
    stamp: np.ndarray  # (buckets,) int64: the segment that last scanned each bucket
    boxes: np.ndarray  # (2, 6 cap) m: segments' bounding boxes, by segment and in bucket order
    memory: np.ndarray  # (1,) CONTACT_DTYPE: search distance, skin, the last violation
    build_pos: np.ndarray  # (3 cap,) m: the whole rod's positions when the pairs were found
    allowance: np.ndarray  # (P,) m: how far each pair's nodes may move relative to each other
    # in the step: its start distance if near, else that minus delta (< 0: minus a lower
    # bound of the latter, for pairs whose bounding spheres are beyond their near distance)
    near: np.ndarray  # (P,) int64: the pairs near enough to touch within the step
    seg_mid: np.ndarray  # (3 cap,) m: each segment's midpoint at the start of the step
    seg_half: np.ndarray  # (cap,) m: ... and its half length
    motion: np.ndarray  # (2, 2, cap) m: each node's motion relative to the common motion and
    # absolute, [0] in the last step checked (sets each pair's near margin), [1] since the
    # step's start at Newton's iterate
    pair_x: np.ndarray  # (12,) m: scratch, the four nodes of a pair
    start_pos: np.ndarray  # (3 cap,) m: the whole rod's positions at the step's start


class Hydro(NamedTuple):
    """Nonlocal slender-body flow (:mod:`bathprint.core.effects.hydrodynamics`): the flow
    the filament's forces make at its nodes, and, with the implicit coupling, the Newton
    matrix's nonlocal part as an operator (the linearisation GMRES applies). Arrays are
    sized to the state's capacity, or empty when the scene does not list the effect."""

    u_nl: np.ndarray  # (3 cap,) m/s: the nonlocal flow at each active node (lagged: at the
    # step's start)
    u_next: np.ndarray  # (3 cap,) m/s: lagged: the same at the end of the last attempted step
    f_node: np.ndarray  # (3 cap,) N/m: force per length on the fluid at each node
    f_seg: np.ndarray  # (3 cap,) N/m: ... on each segment (the mean of its two nodes')
    weight: np.ndarray  # (cap,) m: each node's share of the filament's length
    sides: np.ndarray  # (2, cap) m: the local window a_-, a_+ of each node
    blob: np.ndarray  # (cap,) m: RPY kernel: each node's blob radius
    f_blob: np.ndarray  # (3 cap,) N: RPY kernel: the force each node's blob pushes
    beyond: np.ndarray  # (cap,) -: RPY kernel: sides of each node's window with blobs beyond
    gate: np.ndarray  # (cap,) -: RPY kernel: each node's gate g_i in [0, 1] (effects._rpy)
    resist_window: np.ndarray  # (cap, 3, 3) N s/m: RPY kernel: its window law's resistance
    screen: np.ndarray  # (cap,) m: each segment's (RPY: node's) Oseen length (inf: none)
    resist: np.ndarray  # (cap, 3, 3) N s/m: each node's resistance to the flow, -dF_drag/du_nl
    band_other: np.ndarray  # (3 cap, BAND_WIDTH): the Newton matrix of the other effects
    lin_pos: np.ndarray  # (3 cap,) m: node positions of the linearisation
    lin_s: np.ndarray  # (cap,) m: their material arclengths
    work: np.ndarray  # (2, 3 cap): scratch of the operator
    memory: np.ndarray  # (1,) HYDRO_DTYPE


def new_hydro(capacity: int) -> Hydro:
    """Workspace of the hydrodynamics effect for ``capacity`` nodes (0: the effect is off)."""
    n = capacity
    return Hydro(
        u_nl=np.zeros(3 * n),
        u_next=np.zeros(3 * n),
        f_node=np.zeros(3 * n),
        f_seg=np.zeros(3 * n),
        weight=np.zeros(n),
        sides=np.zeros((2, n)),
        blob=np.zeros(n),
        f_blob=np.zeros(3 * n),
        beyond=np.zeros(n),
        gate=np.ones(n),
        resist_window=np.zeros((n, 3, 3)),
        screen=np.full(n, np.inf),
        resist=np.zeros((n, 3, 3)),
        band_other=np.zeros((3 * n, BAND_WIDTH)),
        lin_pos=np.zeros(3 * n),
        lin_s=np.zeros(n),
        work=np.zeros((2, 3 * n)),
        memory=np.zeros(1, dtype=HYDRO_DTYPE),
    )


# what an evaluation without hydrodynamics sees (zero-size arrays; never written)
NO_HYDRO = new_hydro(0)


class Workspace(NamedTuple):
    """Preallocated scratch of the stepper (sized to the state's capacity)."""

    vecs: np.ndarray  # (N_VECS, 3 cap): stage vectors (integrators.V_*)
    band: np.ndarray  # (3 cap, BAND_WIDTH): the Newton matrix, then its LU factors
    band2: np.ndarray  # (3 cap, BAND_WIDTH): the damping / mass matrix of the error filter
    piv: np.ndarray  # (3 cap,) int64: LU pivots
    solver: np.ndarray  # (1,) SOLVER_DTYPE: what Newton remembers between steps
    tail: np.ndarray  # (1,) TAIL_DTYPE: the frozen tail's lumped load
    scratch: Scratch
    cpl: Couplings  # off-band Jacobian blocks of the Newton matrix
    cpl_filter: Couplings  # off-band blocks of the error filter's damping / mass matrix
    cpl_drop: Couplings  # zero capacity: where evaluations that keep only the band write
    krylov: Krylov
    contact: Contact
    hydro: Hydro


class Rod(NamedTuple):
    """The active rod one force evaluation sees: views starting at the first active node."""

    pos: np.ndarray  # (3 n,) m
    vel: np.ndarray  # (3 n,) m/s
    acc: np.ndarray  # (3 n,) m/s^2 (zero in overdamped scenes)
    n_nodes: int  # active nodes, needle tip and ghost included while clamped
    node_s: np.ndarray
    seg_rest: np.ndarray
    seg_mat: np.ndarray


class Stage(NamedTuple):
    """Time and Jacobian coefficients of one force evaluation: effects add
    -(cx dF/dx + cv dF/dv + ca dF/da) to the Jacobian when ``jac``."""

    t: float
    cx: float
    cv: float
    ca: float
    jac: bool


class Out(NamedTuple):
    """Where a force evaluation writes (and what it reads besides the rod)."""

    force: np.ndarray  # (3 cap,) N, on each node
    band: np.ndarray  # (3 cap, BAND_WIDTH) the Jacobian's band
    tail: np.ndarray  # (1,) TAIL_DTYPE (read by the frozen tail's load)
    scratch: Scratch
    cpl: Couplings  # Jacobian blocks off the band (a zero-capacity one drops them)
    contact: Contact  # the candidate pairs of self-contact
    whole: Rod  # the whole filament, frozen tail included (the rod is its view from frozen)
    frozen: int  # nodes in the frozen tail
    start: np.ndarray  # the active nodes' positions at the step's start (the frozen tail
    # follows the first active node: it is at its start position + that node's displacement)
    hydro: Hydro = NO_HYDRO  # the nonlocal flow (hydrodynamics); zero-size when off


def new_params() -> np.ndarray:
    """A zeroed parameter record, ``(1,) PARAMS_DTYPE``."""
    from bathprint.core.layout import PARAMS_DTYPE

    return np.zeros(1, dtype=PARAMS_DTYPE)


def new_scratch() -> Scratch:
    from bathprint.core.layout import N_MAT

    return Scratch(
        blk_a=np.zeros((3, 3)),
        blk_b=np.zeros((3, 3)),
        needle=np.zeros((3, 3)),
        birth=np.zeros((3, 3)),
        mat_row=np.zeros(N_MAT),
        curvature=np.zeros((2, 3)),
        edges=np.zeros((3, 3)),
        bend_grad=np.zeros(6),
        bend_hess=np.zeros((6, 6)),
        bend_work=np.zeros(128),
        pair_grad=np.zeros(12),
        pair_hess=np.zeros((12, 12)),
        step_work=np.zeros(3),
        pair_x=np.zeros(12),
        law_force=np.zeros(3),
        law_du=np.zeros((3, 3)),
        law_dt=np.zeros((3, 3)),
        law_xi=np.zeros((3, 3)),
        edge_rates=np.zeros((2, 3)),
    )


def new_couplings(capacity: int) -> Couplings:
    return Couplings(
        count=np.zeros(1, dtype=np.int64),
        row=np.zeros(capacity, dtype=np.int64),
        col=np.zeros(capacity, dtype=np.int64),
        block=np.zeros((capacity, 3, 3)),
        merged=np.full(2, -1, dtype=np.int64),
        m_start=np.zeros(capacity + 1, dtype=np.int64),
        m_col=np.zeros(capacity, dtype=np.int64),
        m_block=np.zeros((capacity, 3, 3)),
        order=np.zeros(capacity, dtype=np.int64),
    )


COARSE_SPACING = 4  # nodes between the axial coarse nodes of preconditioner "axial_coarse"
COARSE_KL = 24  # couplings further apart (in coarse nodes) are left out of its matrix


def new_krylov(n_dof: int, restart: int, coarse: int = 0) -> Krylov:
    """GMRES workspace for ``n_dof`` unknowns; ``coarse``: the spacing (nodes) of the axial
    coarse correction, 0 for none."""
    from bathprint.core.layout import BAND_WIDTH, KL, KU

    n_coarse = n_dof // (3 * coarse) + 2 if coarse > 0 else 0
    n_fine = n_dof if coarse > 0 else 0
    return Krylov(
        band_a=np.zeros((n_dof, BAND_WIDTH)),
        basis=np.zeros((restart + 1, n_dof)),
        zbasis=np.zeros((restart, n_dof)),
        hess=np.zeros((restart + 1, max(restart, 1))),
        small=np.zeros((4, restart + 1)),
        z=np.zeros(n_dof),
        coarse=np.array([coarse], dtype=np.int64),
        coarse_band=np.zeros((n_coarse, 3 * COARSE_KL + 1)),
        coarse_piv=np.zeros(n_coarse, dtype=np.int64),
        coarse_x=np.zeros(n_coarse),
        coarse_info=np.zeros(2, dtype=np.int64),
        e=np.zeros((2, n_fine)),
        inv_diag=np.zeros(n_dof),
        diagonal=np.zeros(1, dtype=np.int64),
        lu=np.zeros((n_dof, KL + KU + 1)),
    )


def new_contact(capacity: int, pairs: int) -> Contact:
    from bathprint.core.layout import CONTACT_DTYPE

    buckets = 1 << max(4, int(2 * max(capacity, 1) - 1).bit_length())
    return Contact(
        pairs=np.zeros((pairs, 2), dtype=np.int64),
        count=np.zeros(1, dtype=np.int64),
        cell_start=np.zeros(buckets + 1, dtype=np.int64),
        seg_order=np.zeros(capacity, dtype=np.int64),
        seg_cell=np.zeros(3 * capacity, dtype=np.int64),
        stamp=np.zeros(buckets, dtype=np.int64),
        boxes=np.zeros((2, 6 * capacity)),
        memory=np.zeros(1, dtype=CONTACT_DTYPE),
        build_pos=np.zeros(3 * capacity),
        allowance=np.zeros(pairs),
        near=np.zeros(pairs, dtype=np.int64),
        seg_mid=np.zeros(3 * capacity),
        seg_half=np.zeros(capacity),
        motion=np.zeros((2, 2, capacity)),
        pair_x=np.zeros(12),
        start_pos=np.zeros(3 * capacity),
    )


# GMRES restart length; the Krylov workspace exists only where couplings off the band can
KRYLOV_RESTART = 30


def new_workspace(
    capacity: int,
    n_vecs: int,
    off_band: bool = False,
    hydro: bool = False,
    coarse: int = 0,
    velocity_couplings: bool = False,
) -> Workspace:
    """Scratch for a state of ``capacity`` nodes; ``off_band``: room for couplings off the
    band (contact), their GMRES workspace and the contact pairs (else zero-size arrays);
    ``velocity_couplings``: room for them in the error filter too (contact's dashpot or
    friction; else none, grown if they appear);
    ``hydro``: the hydrodynamics effect's arrays (else zero-size); ``coarse``: the spacing of
    GMRES's axial coarse correction (0: none)."""
    from bathprint.core.layout import BAND_WIDTH, SOLVER_DTYPE, TAIL_DTYPE

    n_dof = 3 * capacity
    return Workspace(
        vecs=np.zeros((n_vecs, n_dof)),
        band=np.zeros((n_dof, BAND_WIDTH)),
        band2=np.zeros((n_dof, BAND_WIDTH)),
        piv=np.zeros(n_dof, dtype=np.int64),
        solver=np.zeros(1, dtype=SOLVER_DTYPE),
        tail=np.zeros(1, dtype=TAIL_DTYPE),
        scratch=new_scratch(),
        cpl=new_couplings(16 * capacity if off_band else 0),
        cpl_filter=new_couplings(16 * capacity if off_band and velocity_couplings else 0),
        cpl_drop=new_couplings(0),
        krylov=new_krylov(n_dof, KRYLOV_RESTART, coarse) if off_band else new_krylov(0, 0),
        contact=new_contact(capacity, 8 * capacity) if off_band else new_contact(0, 0),
        hydro=new_hydro(capacity if hydro else 0),
    )

"""Self-contact (effect 'contact') and the solver for couplings off the band.

Rods pressed across each other stop at the contact distance and the contact carries the
load; a coil collapsing under its weight never interpenetrates and its energy never grows;
contact forces balance pairwise; the Jacobian, blocks off the band included, equals finite
differences; GMRES solves what a dense solve does; without couplings off the band the path
is the banded one, bit for bit; the built-in scenes that list contact keep their turns apart.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest
from numba import njit

from bathprint import SceneError, Simulation, SimulationError, simulate
from bathprint.core import layout as L
from bathprint.core import records, solver
from bathprint.core.assemble import assemble
from bathprint.core.banded import add_blocks_matvec, band_lu_diagonal, band_matvec, merge_blocks
from bathprint.core.effects import contact, hydrodynamics
from bathprint.core.effects._segment_geometry import segment_distance
from bathprint.core.model import CONTACT_DAMPING_WITH_INERTIA_S
from bathprint.core.records import Rod, Stage, new_couplings, new_krylov, new_workspace
from bathprint.core.scene import Contact, parse_override, scene_to_toml
from bathprint.core.topology import free_nodes

MM = 1e-3


@njit(cache=True)
def min_gap_ratio(pos, n_nodes, radius, min_sep) -> float:
    """min over segment pairs i < j - min_sep of distance / (r_i + r_j) (brute force)."""
    best = np.inf
    for i in range(n_nodes - 1):
        for j in range(i + min_sep + 1, n_nodes - 1):
            d = segment_distance(pos, i, i + 1, j, j + 1)
            best = min(best, d / (radius[i] + radius[j]))
    return best


def gap_ratio(points: np.ndarray, radius: float, spacing: float) -> float:
    r = np.full(len(points), radius)
    sep = contact.min_separation_for(2 * radius, spacing)
    return min_gap_ratio(np.ascontiguousarray(points).ravel(), len(points), r, sep)


def free_filament(
    points: np.ndarray, overrides: dict, soft: tuple[int, ...] = (), relaxed: bool = False
) -> Simulation:
    """A free filament through ``points`` (m) (:meth:`Simulation.from_points`); segments in
    ``soft`` get a modulus 1e-6 of the rest and the bath's density (links that carry no
    load)."""
    sim = Simulation.from_points(points, "paper_simulation", overrides, relaxed=relaxed)
    for j in soft:  # weightless too, or their own weight would stretch them
        sim.seg_mat[j, L.MAT_YOUNGS_MODULUS] *= 1e-6
        sim.seg_mat[j, L.MAT_DENSITY] = sim.scene.bath.density_kg_m3
    if soft:
        sim._consistent_velocity()
    return sim


# ------------------------------------------------------------------ crossed rods
def _crossed_rods() -> tuple[Simulation, slice, float]:
    """Rods A1 (y = -2.5 mm) and A2 (y = +2.5 mm) along x on the floor, rod B along y
    resting across both, joined into one filament by soft links far away (r = 0.5 mm,
    delta = 1 mm)."""
    r, dl = 0.5 * MM, 0.5 * MM
    z0 = -20 * MM + r  # on the floor (bath.depth_mm = 20)
    n = 17  # nodes per rod: 8 mm
    x = np.linspace(-4 * MM, 4 * MM, n)
    a1 = np.column_stack([x[::-1], np.full(n, -2.5 * MM), np.full(n, z0)])
    b = np.column_stack([np.full(n, 0.3 * MM), x, np.full(n, z0 + 2 * r * 1.02)])
    a2 = np.column_stack([x[::-1], np.full(n, 2.5 * MM), np.full(n, z0)])
    lift = np.array([0.0, 0.0, 6 * MM])
    link1 = np.array([a1[-1] + lift, b[0] + lift])
    link2 = np.array([b[-1] + lift, a2[0] + lift])
    pts = np.vstack([a1, link1, b, link2, a2])
    k = np.cumsum([0, n, 2, n, 2])  # first node of each part
    # links and the rods' end segments on either side (their nodes' bending couples the two)
    soft = tuple(range(k[1] - 2, k[2] + 1)) + tuple(range(k[3] - 2, k[4] + 1))
    sim = free_filament(
        pts,
        {
            "effects": ["elasticity", "drag", "gravity", "floor", "contact"],
            "bath.depth_mm": 20.0,
            "needle.inner_diameter_mm": 2 * r / MM,
            "material.youngs_modulus_pa": 5e5,
            "material.density_kg_m3": 1300.0,
            "contact.stiffness_pa": 1e4,
            "floor.friction_coefficient": 0.0,
            "numerics.max_strain": 10.0,  # the soft links may stretch freely
            "numerics.stretch_limit": 10.0,
            "duration_s": 10.0,
        },
        soft=soft,
    )
    assert dl > 0
    return sim, slice(int(k[2]) + 1, int(k[3]) - 1), 2 * r  # B's loaded nodes


def _rods_side_by_side(gap: float, near_gap: float) -> Simulation:
    """Two parallel rods resting on the floor with their centre lines (1 + ``gap``) delta
    apart, joined by soft links far away (r = 0.5 mm, delta = 1 mm)."""
    r = 0.5 * MM
    z0 = -20 * MM + r
    n = 17
    x = np.linspace(-4 * MM, 4 * MM, n)
    y = r * (1 + gap)
    a = np.column_stack([x, np.full(n, -y), np.full(n, z0)])
    b = np.column_stack([x[::-1], np.full(n, y), np.full(n, z0)])
    lift = np.array([0.0, 0.0, 6 * MM])
    pts = np.vstack([a, [a[-1] + lift, b[0] + lift], b])
    overrides = {
        "effects": ["elasticity", "drag", "gravity", "floor", "contact"],
        "bath.depth_mm": 20.0,
        "needle.inner_diameter_mm": 2 * r / MM,
        "material.youngs_modulus_pa": 5e5,
        "material.density_kg_m3": 1300.0,
        "contact.near_gap_fraction": near_gap,
        "numerics.max_strain": 10.0,
        "numerics.stretch_limit": 10.0,
        "duration_s": 10.0,
    }
    return free_filament(pts, overrides, soft=tuple(range(n - 2, n + 3)))


def test_pairs_within_the_near_gap_are_evaluated_and_the_answer_does_not_depend_on_it() -> None:
    """Rods 0.2 delta apart, at rest: their pairs are near (evaluated in Newton) with
    ``contact.near_gap_fraction`` 0.3 and not with 0.1; as they do not touch, the motion is
    the same either way."""
    runs = {}
    for near_gap in (0.1, 0.3):
        sim = _rods_side_by_side(0.2, near_gap)
        sim.advance(0.2)
        runs[near_gap] = (int(sim.ws.contact.memory[0]["n_near"]), sim.centerline())
    assert runs[0.1][0] == 0 and runs[0.3][0] > 10
    np.testing.assert_allclose(runs[0.1][1], runs[0.3][1], rtol=0, atol=1e-9)


def test_crossed_rods_stop_at_the_contact_distance_and_carry_the_load() -> None:
    sim, b_nodes, delta = _crossed_rods()
    sim.advance(1.5)
    x = sim.centerline()
    a_nodes = np.r_[0:16, len(x) - 16 : len(x)]
    gaps = [
        segment_distance(x.ravel(), i, i + 1, j, j + 1)
        for i in range(b_nodes.start, b_nodes.stop - 1)
        for j in a_nodes[:-1]
        if j + 1 in a_nodes
    ]
    assert min(gaps) == pytest.approx(delta, rel=0.02)  # stopped at the contact distance
    # the contact forces on B carry B's net weight (the soft links carry nothing)
    model, rod, _, out = sim.kernel_inputs(1.0, 0.0, 0.0, False)
    contact.accumulate(model, rod, Stage(sim.t, 0.0, 0.0, 0.0, False), out)
    f_contact = out.force[: 3 * len(x)].reshape(-1, 3)
    mat = sim.material()
    vol = math.pi * mat[:, L.MAT_RADIUS] ** 2 * sim.rest_lengths()
    rho_b = sim.scene.bath.density_kg_m3
    weight = vol * (mat[:, L.MAT_DENSITY] - rho_b) * sim.scene.bath.gravity_m_s2
    segs_b = range(b_nodes.start, b_nodes.stop - 1)  # B's stiff, loaded segments
    w_b = sum(weight[j] for j in segs_b)
    lift = f_contact[b_nodes.start - 1 : b_nodes.stop + 1, 2].sum()
    assert lift == pytest.approx(w_b, rel=0.03)
    assert abs(f_contact.sum(axis=0)).max() <= 1e-12 * abs(lift)  # action = reaction


# ------------------------------------------------------------------ a coil collapsing onto itself
def _collapsing_coil(with_contact: bool, **extra) -> Simulation:
    """A soft, heavy helical spring (4 turns of radius 3 mm, pitch 1.3 delta), stress-free
    as drawn, standing on the floor: it collapses under its weight, turn onto turn."""
    r, radius, pitch, turns, dl = 0.5 * MM, 3 * MM, 1.3 * MM, 4, 0.5 * MM
    n = int(turns * 2 * math.pi * radius / dl) + 1
    phi = np.linspace(0.0, 2 * math.pi * turns, n)
    z = -30 * MM + r + pitch * phi / (2 * math.pi)
    pts = np.column_stack([radius * np.cos(phi), radius * np.sin(phi), z])
    effects = ["elasticity", "drag", "gravity", "floor"] + (["contact"] if with_contact else [])
    return free_filament(
        pts,
        {
            "effects": effects,
            "bath.depth_mm": 30.0,
            "needle.inner_diameter_mm": 2 * r / MM,
            "material.youngs_modulus_pa": 300.0,
            "material.density_kg_m3": 1400.0,
            "duration_s": 10.0,
            **extra,
        },
        relaxed=True,
    )


def test_a_coil_collapsing_onto_itself_never_interpenetrates_and_loses_energy() -> None:
    sim = _collapsing_coil(True)
    energy, ratios = [], []
    for k in range(1, 21):
        sim.advance(0.05 * k)
        ratios.append(gap_ratio(sim.centerline(), 0.5 * MM, 0.5 * MM))
        energy.append(
            sum(sim.energies_now()[e] for e in ("elasticity", "gravity", "floor", "contact"))
        )
    assert min(ratios) >= 0.9  # never interpenetrating, at every saved frame
    drop = energy[0] - energy[-1]
    assert drop > 0.0
    assert np.all(np.diff(energy) <= 1e-9 * abs(drop))  # overdamped: never increasing
    # the same coil without contact passes through itself: the check can fail
    free = _collapsing_coil(False)
    free.advance(1.0)
    assert gap_ratio(free.centerline(), 0.5 * MM, 0.5 * MM) < 0.5


def _pair_alone(sim: Simulation, i: int, j: int):
    """The contact records with the pair (i, j) alone, near, evaluated whatever its
    allowance."""
    mem = sim.ws.contact.memory.copy()
    mem[0]["n_near"] = 1
    return sim.ws.contact._replace(
        pairs=np.array([[i, j]]),
        count=np.array([1]),
        near=np.array([0]),
        allowance=np.zeros(1),
        memory=mem,
    )


def test_contact_forces_balance_pairwise() -> None:
    sim = _collapsing_coil(True)
    sim.advance(0.6)
    model, rod, _, out = sim.kernel_inputs(1.0, 0.0, 0.0, False)
    pairs = sim.ws.contact.pairs[: sim.ws.contact.count[0]].copy()
    total = np.zeros(3)
    touching = 0
    for i, j in pairs:  # each pair on its own: what A gets, B gets with the opposite sign
        one = _pair_alone(sim, i, j)
        o = out._replace(force=np.zeros_like(out.force), contact=one)
        contact.accumulate(model, rod, Stage(sim.t, 0.0, 0.0, 0.0, False), o)
        f = o.force.reshape(-1, 3)
        on_a, on_b = f[i : i + 2].sum(axis=0), f[j : j + 2].sum(axis=0)
        if np.abs(on_a).max() > 0:
            touching += 1
            np.testing.assert_allclose(on_a, -on_b, rtol=1e-12, atol=1e-15 * np.abs(on_a).max())
        total += f.sum(axis=0)
    assert touching > 10
    assert np.abs(total).max() < 1e-9 * 1e-6  # N: zero to round-off


@pytest.mark.parametrize(
    "key, field, value",
    [
        ("contact.friction_coefficient", "contact_friction", 0.5),
        ("contact.damping_time_s", "contact_damping_time", 1e-3),
    ],
    ids=["friction", "dashpot"],
)
def test_friction_and_the_dashpot_between_touching_turns_balance_pairwise_and_dissipate(
    key: str, field: str, value: float
) -> None:
    """The collapsing coil's turns slide on and press into each other: per pair, the force
    of friction (``contact.friction_coefficient`` 0.5) or of the normal dashpot
    (``contact.damping_time_s`` 1 ms), with it less without, on segment A is minus that on
    B, and its power on the nodes' velocities is never positive (regularised Coulomb friction
    opposes the tangential sliding, the dashpot the rate the distance closes or opens), and
    negative where turns move."""
    sim = _collapsing_coil(True, **{key: value})
    sim.advance(0.6)
    model, rod, _, out = sim.kernel_inputs(1.0, 0.0, 0.0, False)
    pairs = sim.ws.contact.pairs[: sim.ws.contact.count[0]].copy()
    v = rod.vel.reshape(-1, 3)
    params = model.params
    assert params[0][field] == pytest.approx(value)
    sliding, powers = 0, []
    for i, j in pairs:
        one = _pair_alone(sim, i, j)
        forces = {}
        for x in (value, 0.0):
            params[0][field] = x
            o = out._replace(force=np.zeros_like(out.force), contact=one)
            contact.accumulate(model, rod, Stage(sim.t, 0.0, 0.0, 0.0, False), o)
            forces[x] = o.force.reshape(-1, 3)
        params[0][field] = value
        fric = forces[value] - forces[0.0]
        on_a, on_b = fric[i : i + 2].sum(axis=0), fric[j : j + 2].sum(axis=0)
        scale = np.abs(forces[value]).max()
        if np.abs(on_a).max() <= 1e-12 * max(scale, 1e-300):
            continue
        sliding += 1
        np.testing.assert_allclose(on_a, -on_b, rtol=1e-9, atol=1e-12 * scale)
        idx = [i, i + 1, j, j + 1]
        powers.append(float(np.sum(fric[idx] * v[idx])))
    assert sliding > 10
    top = max(abs(x) for x in powers)
    assert all(x <= 1e-9 * top for x in powers)  # W: never feeds the sliding
    assert sum(powers) < -0.5 * top  # it takes energy out


# ------------------------------------------------------------------ the Jacobian
def _squeezed_coil(n: int) -> np.ndarray:
    """Three turns of radius 3 mm squeezed to a pitch of 0.85 mm (0.85 delta for r = 0.5 mm):
    many pairs touch, every one nearly parallel (contact at the middle of the overlap)."""
    phi = np.linspace(0.0, 2 * math.pi * 3, n)
    return np.column_stack([3 * MM * np.cos(phi), 3 * MM * np.sin(phi), 0.85 * MM * phi / 6.283])


def _crossing_figure_eight(n: int) -> np.ndarray:
    """A figure eight (lemniscate of Gerono, 6 mm) whose branches cross at right angles
    0.85 mm apart (0.85 delta for r = 0.5 mm): the pairs at the crossing touch, at angles far
    above SLIDING_ANGLE_DEG (contact at the closest points)."""
    t = np.linspace(0.1, 2 * math.pi - 0.1, n)
    a = 6 * MM
    return np.column_stack([a * np.cos(t), a * np.sin(t) * np.cos(t), 0.425 * MM * np.sin(t)])


# what the Jacobian leaves out: nothing at the closest points; for nearly parallel pairs the
# motion of the contact point (the middle of the overlap) with the nodes, whose share of the
# largest entry the squeezed coil measures at 2.8% (its force is that of the held point)
_JACOBIAN_ERROR = {"crossing": 2e-5, "squeezed_coil": 5e-2}


#: a velocity-dependent part of contact: none, friction, or the normal dashpot
_VELOCITY_TERMS = {
    "none": {},
    "friction": {"contact.friction_coefficient": 0.5},
    "dashpot": {"contact.damping_time_s": 1e-3},
}


def _newton_matrix(out, nd: int) -> np.ndarray:
    """The dense nd x nd matrix of an evaluation's band and its blocks off the band."""
    dense = np.zeros((nd, nd))
    for i in range(nd):
        for j in range(max(0, i - L.KL), min(nd, i + L.KU + 1)):
            dense[i, j] = out.band[i, j - i + L.KL]
    for k in range(out.cpl.count[0]):
        a, b = 3 * out.cpl.row[k], 3 * out.cpl.col[k]
        dense[a : a + 3, b : b + 3] += out.cpl.block[k]
    return dense


def _central_differences(force, x0: np.ndarray, nd: int, h: float) -> np.ndarray:
    """-d force / dx at x0 in its first nd components, by central differences of step h
    (``force`` maps a copy of x0 to nd forces): the dense Newton matrix it should match."""
    fd = np.zeros((nd, nd))
    for k in range(nd):
        xp, xm = x0.copy(), x0.copy()
        xp[k] += h
        xm[k] -= h
        fd[:, k] = -(force(xp) - force(xm)) / (2 * h)
    return fd


@pytest.mark.parametrize("shape", ["crossing", "squeezed_coil"])
@pytest.mark.parametrize("velocity_term", list(_VELOCITY_TERMS))
def test_contact_jacobian_with_its_off_band_blocks_matches_finite_differences(
    velocity_term: str, shape: str
) -> None:
    """A figure eight crossing itself and a coil squeezed below the contact distance (many
    pairs touch): the assembled Newton matrix (band and off-band blocks) against central
    differences of the force, in positions without a velocity term, in velocities with
    friction or the dashpot (their Jacobians hold the geometry, as the floor's does: exact
    in the velocities only). Exact where contact acts at the closest points; for the nearly
    parallel turns of the coil the positions' Jacobian holds the contact point
    (``_JACOBIAN_ERROR``)."""
    r = 0.5 * MM
    n = 120
    pts = _crossing_figure_eight(n) if shape == "crossing" else _squeezed_coil(n)
    sim = free_filament(
        pts,
        {
            "effects": ["elasticity", "drag", "contact"],
            "needle.inner_diameter_mm": 2 * r / MM,
            "contact.hessian": "exact",
            **_VELOCITY_TERMS[velocity_term],
        },
    )
    rng = np.random.default_rng(4)
    sim.vel[: 3 * n] = rng.normal(scale=1e-3, size=3 * n)
    whole = Rod(sim.pos, sim.vel, sim.vel, n, sim.node_s, sim.seg_rest, sim.seg_mat)
    while not contact.prepare(sim.model.record, whole, 0, sim.ws.contact):
        sim._grow_off_band()  # more pairs than room: grown as the simulation does

    def pairs_in_use():
        return sim.ws.contact.pairs[: sim.ws.contact.count[0]]

    def assembled(pos, vel, cx, cv, jac):
        model, _, _, out = sim.kernel_inputs(cx, cv, 0.0, jac)
        rod = Rod(pos, vel, np.zeros_like(vel), n, sim.node_s, sim.seg_rest, sim.seg_mat)
        out = out._replace(whole=rod, start=pos, cpl=new_couplings(16 * len(pairs_in_use())))
        calls = np.zeros(L.N_EFFECTS, np.int64)
        assemble(model, rod, Stage(0.0, cx, cv, 0.0, jac), out, calls, np.zeros(L.N_EFFECTS))
        return out

    nd = 3 * n
    for which, coeffs, x0 in (("x", (1.0, 0.0), sim.pos), ("v", (0.0, 1.0), sim.vel)):
        if (which == "v") != (velocity_term != "none"):
            continue
        out = assembled(sim.pos.copy(), sim.vel.copy(), *coeffs, True)
        assert out.cpl.count[0] > 0  # there are couplings off the band
        dense = _newton_matrix(out, nd)

        def force(x: np.ndarray, which: str = which) -> np.ndarray:
            args = (x, sim.vel.copy()) if which == "x" else (sim.pos.copy(), x)
            return assembled(*args, 0.0, 0.0, False).force[:nd]

        fd = _central_differences(force, x0, nd, 1e-9 if which == "x" else 1e-8)
        far = np.abs(np.subtract.outer(np.arange(n), np.arange(n))) > 2
        assert np.abs(fd[np.kron(far, np.ones((3, 3), bool))]).max() > 0  # truly off the band
        tol = _JACOBIAN_ERROR[shape] if which == "x" else 2e-5
        np.testing.assert_allclose(dense, fd, atol=tol * np.abs(fd).max(), rtol=0)


@pytest.mark.parametrize("velocity_term", ["friction", "dashpot"])
def test_the_error_filter_damps_with_contacts_blocks_off_the_band(velocity_term: str) -> None:
    """The error filter (Shampine's, A^-1 D e) takes D = cv dF/dv whole: the blocks that
    friction or the dashpot add between touching turns of a squeezed coil are in
    ``solver.damping_times`` (``ws.cpl_filter``) as they are in A, against central
    differences of the force in the velocities; without them D x misses a part of the
    product that the assertion below sees."""
    n = 120
    sim = free_filament(
        _squeezed_coil(n),
        {
            "effects": ["elasticity", "drag", "contact"],
            "needle.inner_diameter_mm": 1.0,
            **_VELOCITY_TERMS[velocity_term],
        },
    )
    rng = np.random.default_rng(7)
    sim.vel[: 3 * n] = rng.normal(scale=1e-3, size=3 * n)
    whole = Rod(sim.pos, sim.vel, sim.vel, n, sim.node_s, sim.seg_rest, sim.seg_mat)
    while not contact.prepare(sim.model.record, whole, 0, sim.ws.contact):
        sim._grow_off_band()
    cv = 1.0 / 2e-4  # 1 / (h gamma) of a 0.2 ms stage
    nd = 3 * n
    calls, energies = np.zeros(L.N_EFFECTS, np.int64), np.zeros(L.N_EFFECTS)
    while True:  # more blocks than room: grown as the simulation does
        model, rod, _, out = sim.kernel_inputs(0.0, cv, 0.0, True)
        ws = sim.ws
        out = out._replace(band=ws.band2, cpl=ws.cpl_filter)
        assemble(model, rod, Stage(0.0, 0.0, cv, 0.0, True), out, calls, energies)
        if ws.cpl_filter.count[0] <= len(ws.cpl_filter.row):
            break
        sim._grow_off_band()
    assert ws.cpl_filter.count[0] > 0
    x = rng.normal(size=nd)
    dx = np.zeros(nd)
    solver.damping_times(ws, nd, x, dx)

    def force(vel: np.ndarray) -> np.ndarray:
        model, rod, _, out = sim.kernel_inputs(0.0, 0.0, 0.0, False, vel=vel)
        assemble(model, rod, Stage(0.0, 0.0, 0.0, 0.0, False), out, calls, energies)
        return out.force[:nd].copy()

    expected = cv * _central_differences(force, sim.vel, nd, 1e-8) @ x
    np.testing.assert_allclose(dx, expected, atol=2e-5 * np.abs(expected).max(), rtol=0)
    band_only = np.zeros(nd)
    band_matvec(ws.band2, nd, L.KL, L.KU, x, band_only)
    assert np.abs(band_only - expected).max() > 0.01 * np.abs(expected).max()


def _coil_with_implicit_flow() -> Simulation:
    """A squeezed coil (60 nodes) with contact (its 1 ms dashpot) and the nonlocal flow inside
    Newton, its contact pairs found."""
    sim = free_filament(
        _squeezed_coil(60),
        {
            "effects": ["elasticity", "drag", "contact", "hydrodynamics"],
            "hydrodynamics.coupling": "implicit",
            "needle.inner_diameter_mm": 1.0,
            "contact.damping_time_s": 1e-3,
        },
    )
    whole = Rod(sim.pos, sim.vel, sim.vel, 60, sim.node_s, sim.seg_rest, sim.seg_mat)
    while not contact.prepare(sim.model.record, whole, 0, sim.ws.contact):
        sim._grow_off_band()
    return sim


def test_the_error_filters_assembly_keeps_the_nonlocal_flows_linearisation() -> None:
    """With the nonlocal flow inside Newton, the Newton matrix's nonlocal part is linearised
    at each Newton-matrix assembly. The error filter assembles the damping part alone
    (cx = 0) into a room for the dashpot's blocks: that must leave the linearisation (J_other
    and the resistances R_i), which the filter's own solve and the next Newton solves use, as
    it was."""
    sim = _coil_with_implicit_flow()
    calls, energies = np.zeros(L.N_EFFECTS, np.int64), np.zeros(L.N_EFFECTS)
    model, rod, _, out = sim.kernel_inputs(1.0, 5e3, 0.0, True)
    assemble(
        model, rod, Stage(0.0, 1.0, 5e3, 0.0, True), out._replace(cpl=sim.ws.cpl), calls, energies
    )
    hyd = sim.ws.hydro
    assert hyd.memory[0]["linearized"]
    band_other = hyd.band_other.copy()
    resist = hyd.resist.copy()
    assert np.abs(band_other).max() > 0 and np.abs(resist).max() > 0
    model, rod, _, out = sim.kernel_inputs(0.0, 5e3, 0.0, True)
    filt = out._replace(band=sim.ws.band2, cpl=sim.ws.cpl_filter)
    assemble(model, rod, Stage(0.0, 0.0, 5e3, 0.0, True), filt, calls, energies)
    assert sim.ws.cpl_filter.count[0] > 0  # the filter wrote the dashpot's blocks
    np.testing.assert_array_equal(hyd.band_other, band_other)
    # the linearised resistances R_i too: not the filter's law added on top
    np.testing.assert_array_equal(hyd.resist, resist)


def test_the_nonlocal_flows_newton_matrix_leaves_contact_out() -> None:
    """With the nonlocal flow inside Newton, its part of the Newton matrix, R M W^-1 J_other,
    takes J_other without contact (its in-band and off-band blocks, the dashpot's included):
    the same product with contact switched off, while the local Newton matrix keeps
    contact's blocks and the residual keeps the flow of contact's forces."""
    sim = _coil_with_implicit_flow()
    nd = 3 * free_nodes(sim.n_nodes, sim.model.p)
    x = np.random.default_rng(3).normal(size=nd)
    products, flows = [], []
    for on in (1, 0):
        sim.model.enabled[L.E_CONTACT] = on
        calls, energies = np.zeros(L.N_EFFECTS, np.int64), np.zeros(L.N_EFFECTS)
        model, rod, _, out = sim.kernel_inputs(1.0, 5e3, 0.0, True)
        stage = Stage(0.0, 1.0, 5e3, 0.0, True)
        assemble(model, rod, stage, out._replace(cpl=sim.ws.cpl), calls, energies)
        assert (sim.ws.cpl.count[0] > 0) == bool(on)  # contact's blocks in the Newton matrix
        assert sim.ws.hydro.memory[0]["lin_free"] == nd // 3
        y = np.zeros(nd)
        hydrodynamics.apply_nonlocal(sim.ws, nd, x, y)
        products.append(y)
        flows.append(sim.ws.hydro.u_nl[:nd].copy())
    scale = np.abs(products[1]).max()
    assert scale > 0
    np.testing.assert_allclose(products[0], products[1], rtol=0, atol=1e-12 * scale)
    # the flow itself is driven by contact's forces: switching contact off changes it
    assert np.abs(flows[0] - flows[1]).max() > 1e-3 * np.abs(flows[0]).max()


def _coil_with_frozen_tail(n: int, f: int, floor: bool, over: dict):
    """A squeezed coil of n nodes (radius 0.5 mm) with scene keys ``over``, the floor listed
    or not (only contact is evaluated), and its contact pairs found with the first f nodes
    frozen: (sim, the whole rod, the pairs)."""
    sim = free_filament(
        _squeezed_coil(n),
        {"effects": ["elasticity", "drag", "contact"], "needle.inner_diameter_mm": 1.0, **over},
    )
    sim.model.enabled[L.E_FLOOR] = int(floor)
    whole = Rod(sim.pos, sim.vel, sim.vel, n, sim.node_s, sim.seg_rest, sim.seg_mat)
    while not contact.prepare(sim.model.record, whole, f, sim.ws.contact):
        sim._grow_off_band()  # more pairs than room: grown as the simulation does
    pairs = sim.ws.contact.pairs[: sim.ws.contact.count[0]]
    assert ((pairs[:, 0] < f) & (pairs[:, 1] >= f)).any()  # active turns touch the tail
    return sim, whole, pairs


def _accumulate_on_active(model, out, whole: Rod, f: int, n_pairs: int, stage, start):
    """Contact's evaluation on the active rod (a view of ``whole`` from node f, as in a
    step) with the first f nodes frozen and ``start`` the active nodes' step-start
    positions; its own force, band and off-band blocks."""
    n_act = whole.n_nodes - f
    nd = 3 * n_act
    rod = Rod(
        whole.pos[3 * f :],
        whole.vel[3 * f :],
        np.zeros(nd),
        n_act,
        whole.node_s[f:],
        whole.seg_rest[f:],
        whole.seg_mat[f:],
    )
    o = out._replace(
        force=np.zeros(nd),
        band=np.zeros((nd, out.band.shape[1])),
        cpl=new_couplings(16 * n_pairs),
        whole=whole,
        frozen=f,
        start=start,
    )
    contact.accumulate(model, rod, stage, o)
    return o


@pytest.mark.parametrize(
    "key, field, value",
    [
        ("contact.damping_time_s", "contact_damping_time", 1e-3),
        ("contact.friction_coefficient", "contact_friction", 0.5),
    ],
    ids=["dashpot", "friction"],
)
@pytest.mark.parametrize("floor", [False, True], ids=["free_tail", "tail_on_floor"])
def test_velocity_terms_on_a_frozen_tail_move_it_with_the_first_active_node(
    key: str, field: str, value: float, floor: bool
) -> None:
    """A squeezed coil whose first 20 nodes are a frozen tail (an obstacle that follows the
    first active node; on the floor horizontally only): the force of the dashpot (or of
    friction) on the active nodes, frozen nodes moving at that node's velocity, against
    central differences in the active velocities, with the frozen nodes' rows and columns
    in that node's; and it vanishes when the whole coil translates (on the floor:
    horizontally)."""
    n, f = 120, 20
    sim, whole, pairs = _coil_with_frozen_tail(n, f, floor, {key: value})
    n_act = n - f
    nd = 3 * n_act
    vel0 = np.random.default_rng(5).normal(scale=1e-3, size=nd)

    def dashpot(vel: np.ndarray, jac: bool):
        """Contact's force on the active nodes with the velocity term, less that without."""
        model, _, _, out = sim.kernel_inputs(0.0, 1.0, 0.0, jac)
        params = model.params
        forces = []
        # the active rod is a view of the whole one, as in a step; the frozen nodes' own
        # velocities (here NaN) are never read: they move with the first active node
        whole_vel = np.full(3 * n, np.nan)
        whole_vel[3 * f :] = vel
        moving = whole._replace(vel=whole_vel)
        stage = Stage(0.0, 0.0, 1.0, 0.0, jac)
        start = sim.pos[3 * f :].copy()
        for x in (value, 0.0):
            params[0][field] = x
            forces.append(_accumulate_on_active(model, out, moving, f, len(pairs), stage, start))
        params[0][field] = value
        return forces[0].force - forces[1].force, forces[0]

    _, out = dashpot(vel0.copy(), True)
    dense = _newton_matrix(out, nd)
    fd = _central_differences(lambda v: dashpot(v, False)[0], vel0, nd, 1e-8)
    assert np.abs(fd[:3, :3]).max() > 0  # the tail's pairs reach the first active node
    np.testing.assert_allclose(dense, fd, atol=2e-5 * np.abs(fd).max(), rtol=0)
    common = np.tile([1e-3, -2e-3, 0.0 if floor else 5e-4], n_act)  # the tail moves with it
    drift, _ = dashpot(common, False)
    assert np.abs(drift).max() < 1e-9 * np.abs(dashpot(vel0, False)[0]).max()


@pytest.mark.parametrize("floor", [False, True], ids=["free_tail", "tail_on_floor"])
def test_contact_with_a_frozen_tail_matches_finite_differences_in_the_active_positions(
    floor: bool,
) -> None:
    """The penalty's force on the active nodes of a squeezed coil whose first 20 nodes are
    a frozen tail, the tail following the first active node's displacement (on the floor
    horizontally only, its vertical load on the floor), against central differences in the
    active positions; off the floor a rigid translation leaves it unchanged, on the floor a
    vertical one of the active nodes changes it (the tail stays at its height)."""
    r, n, f = 0.5 * MM, 120, 20
    # at the closest points: an exact Jacobian
    sim, whole, pairs = _coil_with_frozen_tail(n, f, floor, {"contact.parallel_angle_deg": 0.0})
    n_act = n - f
    nd = 3 * n_act
    start = sim.pos[3 * f : 3 * n].copy()

    def force(active: np.ndarray, jac: bool):
        model, _, _, out = sim.kernel_inputs(1.0, 0.0, 0.0, jac)
        sim.pos[3 * f : 3 * n] = active  # the active rod is a view of the whole one
        stage = Stage(0.0, 1.0, 0.0, 0.0, jac)
        o = _accumulate_on_active(model, out, whole, f, len(pairs), stage, start)
        sim.pos[3 * f : 3 * n] = start
        return o

    out = force(start.copy(), True)
    assert np.abs(out.force[:3]).max() > 0  # the tail's pairs push the first active node
    dense = _newton_matrix(out, nd)
    fd = _central_differences(lambda x: force(x, False).force, start, nd, 1e-9)
    np.testing.assert_allclose(dense, fd, atol=1e-5 * np.abs(fd).max(), rtol=0)
    lift = start + np.tile([0.0, 0.0, 0.05 * r], n_act)  # the active coil lifted
    change = np.abs(force(lift, False).force - out.force).max()
    if floor:
        assert change > 1e-3 * np.abs(out.force).max()  # it lifts off the tail
    else:
        assert change < 1e-9 * np.abs(out.force).max()  # the tail lifts with it


# ------------------------------------------------------------------ the solver
@pytest.mark.parametrize("shift", [12.0, 0.0], ids=["diagonal_pivots", "row_swaps"])
@pytest.mark.parametrize("coarse", [0, 4], ids=["band", "axial_coarse"])
def test_gmres_solves_band_plus_off_band_blocks_like_a_dense_solve(
    coarse: int, shift: float
) -> None:
    """With the banded LU as preconditioner, and with the axial coarse correction after it
    (``numerics.preconditioner = "axial_coarse"``): the same solution as a dense solve. The
    LU takes its diagonal pivots (no row swaps) where they pass the threshold, and starts
    again with partial pivoting where they do not (a band with no diagonal shift). The LU
    without row swaps is kept in ``krylov.lu``, only the columns it uses, the same numbers
    as in the band's own storage, and the band stays as assembled."""
    rng = np.random.default_rng(1)
    n_nodes = 60
    nd = 3 * n_nodes
    ws = new_workspace(n_nodes, 1, off_band=True, coarse=coarse)
    dense = np.zeros((nd, nd))
    for i in range(nd):
        for j in range(max(0, i - L.KL), min(nd, i + L.KU + 1)):
            v = rng.normal() + (shift if i == j else 0.0)
            ws.band[i, j - i + L.KL] = v
            dense[i, j] = v
    k = 0
    for _ in range(40):
        i, j = rng.integers(0, n_nodes, 2)
        if abs(i - j) <= 2:
            continue
        blk = rng.normal(size=(3, 3))
        ws.cpl.row[k], ws.cpl.col[k], ws.cpl.block[k] = i, j, blk
        dense[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] += blk
        k += 1
    ws.cpl.count[0] = k
    b = rng.normal(size=nd)
    x = np.zeros(3 * n_nodes)
    x[:nd] = b
    counters = np.zeros(L.N_COUNTERS, np.int64)
    assembled = ws.band[:nd].copy()
    assert solver.factor(ws, nd)
    swapped = np.any(ws.piv[:nd] != np.arange(nd))
    assert swapped == (shift == 0.0) == (ws.krylov.diagonal[0] == 0)
    if not swapped:
        full, inv = assembled.copy(), np.zeros(nd)
        piv = np.zeros(nd, dtype=np.int64)
        assert band_lu_diagonal(full, nd, piv, inv, solver.PIVOT_THRESHOLD) == 0
        np.testing.assert_array_equal(ws.krylov.lu[:nd], full[:, : L.KL + L.KU + 1])
        np.testing.assert_array_equal(ws.band[:nd], assembled)
    assert solver.solve(ws, nd, x, counters, 1e-10)
    exact = np.linalg.solve(dense, b)
    np.testing.assert_allclose(x[:nd], exact, rtol=0, atol=1e-8 * np.abs(exact).max())
    assert counters[L.C_KRYLOV_ITERATIONS] > 0
    if coarse:  # the coarse matrix was built and factorised: 16 coarse nodes for 60 nodes
        assert list(ws.krylov.coarse_info) == [16, int(ws.krylov.coarse_info[1])]
        assert 2 <= ws.krylov.coarse_info[1] <= records.COARSE_KL


def test_merged_blocks_sum_each_node_block_and_give_the_same_product() -> None:
    """merge_blocks sums the blocks that share a node block into rows, each once, in the
    order of assembly; the product over the merged rows equals the one over the blocks as
    assembled (to round-off), and an assembly of the Newton matrix drops the merged rows
    until the next factorisation merges them again."""
    rng = np.random.default_rng(3)
    n_rows, n_blocks = 40, 300
    cpl = new_couplings(n_blocks)
    dense = np.zeros((3 * n_rows, 3 * n_rows))
    for k in range(n_blocks):  # about two blocks per node block
        i, j = rng.integers(0, n_rows, 2)
        cpl.row[k], cpl.col[k], cpl.block[k] = i, j, rng.normal(size=(3, 3))
        dense[3 * i : 3 * i + 3, 3 * j : 3 * j + 3] += cpl.block[k]
    cpl.count[0] = n_blocks
    x = rng.normal(size=3 * n_rows)
    by_block = np.zeros(3 * n_rows)
    add_blocks_matvec(cpl, x, by_block)  # not merged yet: block by block
    merge_blocks(cpl, n_rows)
    m = int(cpl.merged[0])
    distinct = {(int(r), int(c)) for r, c in zip(cpl.row, cpl.col, strict=True)}
    assert m == len(distinct) < n_blocks and cpl.merged[1] == n_rows
    start = cpl.m_start
    for r in range(n_rows):
        cols = cpl.m_col[start[r] : start[r + 1]]
        first = [int(c) for k, c in zip(cpl.row, cpl.col, strict=True) if k == r]
        assert list(cols) == list(dict.fromkeys(first))  # each once, in assembly order
        for s, c in zip(range(start[r], start[r + 1]), cols, strict=True):
            np.testing.assert_allclose(
                cpl.m_block[s], dense[3 * r : 3 * r + 3, 3 * c : 3 * c + 3], rtol=1e-12
            )
    merged = np.zeros(3 * n_rows)
    add_blocks_matvec(cpl, x, merged)
    np.testing.assert_allclose(merged, dense @ x, rtol=0, atol=1e-12 * np.abs(dense @ x).max())
    np.testing.assert_allclose(merged, by_block, rtol=0, atol=1e-12 * np.abs(by_block).max())
    # in a run, the factorisation merges the assembled blocks; the next assembly with the
    # Jacobian drops them (the product goes block by block until they are merged again)
    sim = Simulation("period_doubling_22G", {"duration_s": 0.3})
    sim.advance(0.3)
    cpl = sim.ws.cpl
    assert cpl.count[0] > 0 and 0 < cpl.merged[0] < cpl.count[0]
    model, rod, stage, out = sim.kernel_inputs()
    out = out._replace(cpl=cpl)
    assemble(model, rod, stage, out, np.zeros(L.N_EFFECTS, np.int64), np.zeros(L.N_EFFECTS))
    assert cpl.merged[0] == -1


def test_a_pickled_simulation_keeps_its_axial_coarse_correction(pressed_stack) -> None:
    """The preconditioner comes from the scene when the workspace is rebuilt: a pickled
    stack continues bit for bit, with the same GMRES iterations."""
    import pickle

    a = pressed_stack(300, **{"numerics.preconditioner": "axial_coarse"})
    a.advance(2e-3)
    b = pickle.loads(pickle.dumps(a))
    assert b.ws.krylov.coarse[0] == records.COARSE_SPACING
    a.advance(5e-3)
    b.advance(5e-3)
    np.testing.assert_array_equal(a.pos, b.pos)
    assert a.counts()["krylov_iterations"] == b.counts()["krylov_iterations"] > 0


def test_the_axial_coarse_correction_keeps_gmres_short_on_a_pressed_stack(pressed_stack) -> None:
    """A coil stack of 3000 nodes (48 turns) pressed to 0.98 of the contact distance, 20 ms:
    with the banded LU alone GMRES takes 13.3 iterations per Newton iteration (on the
    machine this was written on), with the axial coarse correction 2.6; Newton's own
    iterations stay as they were (4.7 and 4.4 per step)."""
    counts = {}
    for pc in ("band", "axial_coarse"):
        sim = pressed_stack(3000, **{"numerics.preconditioner": pc})
        sim.advance(0.02)
        counts[pc] = sim.counts()
    per_newton = {pc: c["krylov_iterations"] / c["newton_iterations"] for pc, c in counts.items()}
    assert per_newton["band"] > 8.0
    assert per_newton["axial_coarse"] < 0.4 * per_newton["band"]
    for pc, c in counts.items():
        assert c["newton_iterations"] < 6 * c["steps"], pc
        assert c["krylov_failures"] == 0, pc


def test_a_stalled_gmres_solve_is_reported_not_passed_on() -> None:
    ws = new_workspace(4, 1, off_band=True)._replace(krylov=new_krylov(12, 1))
    nd = 12
    for i in range(nd):
        ws.band[i, L.KL] = 1.0
    # A = I - P with P the cyclic shift of the 4 nodes: singular, and b = ones lies outside
    # its range (the ones are its null vector), so no solve can reach the tolerance
    for i in range(4):
        ws.cpl.row[i], ws.cpl.col[i] = i, (i + 3) % 4
    ws.cpl.block[:4] = -np.eye(3)
    ws.cpl.count[0] = 4
    counters = np.zeros(L.N_COUNTERS, np.int64)
    assert solver.factor(ws, nd)
    x = np.ones(nd)
    ok = solver.solve(ws, nd, x, counters, 1e-14)
    assert not ok and counters[L.C_KRYLOV_FAILURES] == 1


def test_a_krylov_failure_is_reported_with_time_node_pair_and_cause() -> None:
    """At the smallest step a stalled GMRES solve raises a SimulationError that names the
    time, the worst node and the node pair of the strongest off-band coupling."""
    sim = Simulation("period_doubling_22G", {"duration_s": 0.01})
    cpl = sim.ws.cpl
    assert cpl.row.shape[0] >= 2
    cpl.row[:2], cpl.col[:2] = (3, 40), (30, 7)
    cpl.block[:2] = 0.0
    cpl.block[0, 1, 2], cpl.block[1, 0, 0] = -2.0, 5.0  # the second block is the strongest
    cpl.count[0] = 2
    sim.info[:] = (0.25, 12.0, 0.0)
    with pytest.raises(SimulationError, match="Krylov") as info:
        sim._raise(L.STATUS_KRYLOV)
    err = info.value
    assert math.isclose(err.time_s, 0.25) and err.node == 12
    assert "nodes 40 and 7" in err.detail and "of 2 blocks" in err.detail
    cpl.count[0] = 0
    with pytest.raises(SimulationError, match="no couplings off the band"):
        sim._raise(L.STATUS_KRYLOV)


def test_without_couplings_off_the_band_the_path_is_the_banded_one_bit_for_bit(
    monkeypatch,
) -> None:
    """The same scene with the off-band workspace allocated and with none: identical."""
    over = {"duration_s": 0.4, "effects": ["elasticity", "drag", "gravity"]}
    plain = Simulation("drag_coiling_22G", over)
    plain.advance(0.4)
    monkeypatch.setattr(Simulation, "off_band", property(lambda self: True))
    ready = Simulation("drag_coiling_22G", over)
    assert ready.ws.cpl.row.shape[0] > 0
    ready.advance(0.4)
    np.testing.assert_array_equal(plain.centerline(), ready.centerline())
    assert plain.counts() == ready.counts()


def test_contact_listed_but_never_touching_takes_no_krylov_iteration() -> None:
    sim = Simulation("paper_simulation", {"effects": ["elasticity", "drag", "gravity", "contact"]})
    sim.advance(1.0)
    assert sim.counts()["krylov_iterations"] == 0
    assert sim.effect_calls()["contact"] > 0


# ------------------------------------------------------------------ built-in scenes
SCENES = {  # scene: (duration s, minimal gap ratio allowed)
    "drag_coiling_22G": 1.5,
    "period_doubling_22G": 0.15,
    "gelation_coiling_22G": 1.5,
    "composite_oil_22G": 1.3,
    "rope_coiling_18G": 3.0,
    "chaotic_crumpling_22G": 0.01,
}


@pytest.mark.parametrize("scene", list(SCENES))
def test_builtin_scenes_with_contact_keep_their_turns_apart(scene: str) -> None:
    res = simulate(scene, {"duration_s": SCENES[scene], "outputs.plot": False})
    assert "contact" in res.scene.effects
    r = float(res.material[0, L.MAT_RADIUS])
    spacing = res.summary["numerics"]["node_spacing_mm"] * MM
    worst = min(gap_ratio(f, r, spacing) for f in res.frames[1:])
    assert worst >= 0.9
    assert {"krylov_iterations", "krylov_failures"} <= res.summary.keys()  # summary.json


def test_rope_coiling_on_the_floor_lays_turns_beside_turns_instead_of_through_them() -> None:
    """After about 15 s the rope coil's new turns reach the ones already on the floor:
    without contact they pass through them (distance ~0), with contact they stay apart."""
    worst, krylov = {}, {}
    for name, effects in (("contact", ["contact"]), ("none", [])):
        over = {
            "duration_s": 20.0,
            "outputs.plot": False,
            "outputs.frame_interval_s": 1.0,
            "effects": ["elasticity", "drag", "gravity", "floor", *effects],
        }
        res = simulate("rope_coiling_18G", over)
        r = float(res.material[0, L.MAT_RADIUS])
        spacing = res.summary["numerics"]["node_spacing_mm"] * MM
        worst[name] = min(gap_ratio(f, r, spacing) for f in res.frames[1:])
        krylov[name] = res.summary["krylov_iterations"]  # summary.json's count
    assert worst["none"] < 0.5
    # touching turns couple off the band: GMRES runs with contact, never without it
    assert krylov["contact"] > 0 and krylov["none"] == 0
    assert worst["contact"] >= 0.9


def test_the_parallel_angle_sets_where_nearly_parallel_segments_touch() -> None:
    """``contact.parallel_angle_deg`` reaches the kernels: on the squeezed coil's nearly
    parallel turns the force at the default (10 degrees: the middle of the overlap) differs
    from the one at 0 (the closest points). (On a regular helix the turns' segments are
    chords of one circle, which cross near the middle of their overlap: the nodes are
    displaced at random by 0.03 mm.)"""
    rng = np.random.default_rng(2)
    pts = _squeezed_coil(120) + rng.normal(scale=0.03 * MM, size=(120, 3))
    forces = {}
    for angle in (10.0, 0.0):
        sim = free_filament(
            pts,
            {
                "effects": ["elasticity", "drag", "contact"],
                "needle.inner_diameter_mm": 1.0,
                "contact.parallel_angle_deg": angle,
            },
        )
        p = sim.model.params[0]
        assert p["contact_parallel_sin2"] == pytest.approx(math.sin(math.radians(angle)) ** 2)
        model, rod, _, out = sim.kernel_inputs(0.0, 0.0, 0.0, False)
        whole = Rod(sim.pos, sim.vel, sim.vel, sim.n_nodes, sim.node_s, sim.seg_rest, sim.seg_mat)
        while not contact.prepare(sim.model.record, whole, 0, sim.ws.contact):
            sim._grow_off_band()
        model, rod, _, out = sim.kernel_inputs(0.0, 0.0, 0.0, False)
        o = out._replace(force=np.zeros_like(out.force))
        contact.accumulate(model, rod, Stage(0.0, 0.0, 0.0, 0.0, False), o)
        forces[angle] = o.force[: 3 * sim.n_nodes].copy()
    scale = np.abs(forces[0.0]).max()
    assert scale > 0.0
    assert np.abs(forces[10.0] - forces[0.0]).max() > 3e-2 * scale
    # the same total force on each side: only where along the segments it acts differs
    np.testing.assert_allclose(forces[10.0].sum(), forces[0.0].sum(), atol=1e-9 * scale)


# ------------------------------------------------------------------ bad input
@pytest.mark.parametrize(
    "key, value",
    [
        ("contact.stiffness_pa", 0.0),
        ("contact.stiffness_pa", -1.0),
        ("contact.distance_factor", 0.0),
        ("contact.distance_factor", -2.0),
        ("contact.friction_coefficient", 2.5),
        ("contact.friction_coefficient", -0.1),
        ("contact.near_gap_fraction", -0.1),
        ("contact.near_gap_fraction", 2.5),
        ("contact.parallel_angle_deg", -1.0),
        ("contact.parallel_angle_deg", 60.0),
        ("contact.damping_time_s", -1e-3),
        ("contact.damping_time_s", 2.0),
        ("contact.damping_time_s", "automatic"),
        ("contact.stiffness_pa", "auto"),
        ("numerics.preconditioner", "multigrid"),
    ],
)
def test_bad_contact_values_are_refused_by_name(key: str, value: float | str) -> None:
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        Simulation("drag_coiling_22G", {key: value})


def test_the_dashpot_follows_inertia_unless_its_time_is_given() -> None:
    """``contact.damping_time_s = "auto"`` (the default) damps touching turns for 10 ms with
    inertia, where they are otherwise an undamped spring between masses, and not without,
    where the dashpot only slows GMRES; a time given is used as given. The message of a bad
    value says that "auto" is allowed."""

    def damping(over: dict) -> float:
        return float(Simulation("drag_coiling_22G", over).model.p.contact_damping_time)

    inertial = [*Simulation("drag_coiling_22G").scene.effects, "inertia"]
    assert Simulation("drag_coiling_22G").scene.contact.damping_time_s == "auto"
    assert damping({}) == 0.0
    assert damping({"effects": inertial}) == CONTACT_DAMPING_WITH_INERTIA_S == 0.01
    assert damping({"effects": inertial, "contact.damping_time_s": 0.0}) == 0.0
    assert damping({"contact.damping_time_s": 3e-3}) == 3e-3
    key, value = parse_override("contact.damping_time_s=auto")  # --set, bare or quoted
    assert (key, value) == ("contact.damping_time_s", "auto")
    assert parse_override('contact.damping_time_s="auto"') == (key, value)
    written = scene_to_toml(Simulation("drag_coiling_22G", {"effects": inertial}).scene)
    assert damping(tomllib.loads(written)) == CONTACT_DAMPING_WITH_INERTIA_S  # a round trip
    with pytest.raises(SceneError, match='or "auto"'):
        Simulation("drag_coiling_22G", {"contact.damping_time_s": -1.0})
    (f,) = [f for f in dataclasses.fields(Contact) if f.name == "damping_time_s"]
    assert f"auto: {CONTACT_DAMPING_WITH_INERTIA_S:g} s with inertia" in f.metadata["doc"]


def test_a_run_summary_names_the_contact_law_it_used() -> None:
    """summary.json holds contact's law with "auto" resolved (so a result says which law
    computed it whatever the defaults), and no such entry where contact is not listed."""
    effects = [*Simulation("drag_coiling_22G").scene.effects, "inertia"]
    over = {"duration_s": 0.005, "outputs.plot": False}
    law = simulate("drag_coiling_22G", {**over, "effects": effects}).summary["contact"]
    default = Simulation("drag_coiling_22G").scene.contact
    assert law["width_fraction"] == default.width_fraction
    assert law["distance_factor"] == default.distance_factor
    assert law["damping_time_s"] == CONTACT_DAMPING_WITH_INERTIA_S
    plain = [e for e in effects if e not in ("contact", "inertia")]
    assert "contact" not in simulate("drag_coiling_22G", {**over, "effects": plain}).summary


def test_contact_without_elasticity_is_refused() -> None:
    with pytest.raises(SceneError, match="elasticity"):
        Simulation("drag_coiling_22G", {"effects": ["drag", "gravity", "contact"]})


def test_segments_never_pass_through_each_other_even_when_the_penalty_cannot_stop_them() -> None:
    """A contact stiffness far too small to carry B: B sinks into A, the steps shrink as the
    centre lines approach (no step may let them cross), and the run stops with an error
    naming the pair instead of passing one through the other."""
    sim, b_nodes, _ = _crossed_rods()
    sim.model.p.contact_stiffness = 1e-3  # Pa (the scene's 1e4 holds B at the distance)
    sim.model.p.min_step = 1e-7
    sim.model.enabled[L.E_FLOOR] = 0  # no floor: A floats (neutral), B sinks onto it
    n_seg = sim.n_segments
    for j in range(n_seg):
        if not b_nodes.start - 1 <= j < b_nodes.stop:
            sim.seg_mat[j, L.MAT_DENSITY] = sim.scene.bath.density_kg_m3
    sim._consistent_velocity()
    with pytest.raises(SimulationError, match=r"segments \d+ and \d+") as info:
        sim.advance(2.0)
    assert "pass through each other" in str(info.value)
    i, j = (int(k) for k in info.value.detail.split("segments ")[1].split(" (")[0].split(" and "))
    in_b = [b_nodes.start - 1 <= k < b_nodes.stop for k in (i, j)]
    assert sum(in_b) == 1  # one segment of B, one of A
    x = sim.centerline()
    assert x[b_nodes, 2].mean() > x[:16, 2].mean()  # B is still above A


def test_adaptive_steps_shrink_instead_of_passing_through() -> None:
    sim, b_nodes, delta = _crossed_rods()
    for j in range(b_nodes.start - 1, b_nodes.stop):
        sim.seg_mat[j, L.MAT_DENSITY] = 3000.0
    sim.advance(0.3)
    x = sim.centerline()
    assert x[b_nodes, 2].min() > x[:16, 2].max()  # B is still above A
    assert sim.counts()["steps"] > 0


def test_couplings_grow_when_they_do_not_fit() -> None:
    sim = _collapsing_coil(True)
    sim.ws = sim.ws._replace(cpl=new_couplings(4))
    sim.advance(0.3)
    assert sim.ws.cpl.row.shape[0] >= sim.ws.cpl.count[0] > 4


def test_the_error_filters_couplings_grow_when_they_do_not_fit() -> None:
    """With the dashpot, the error filter's blocks off the band overflow a room of 4: the
    step is undone, the room grown and the step taken again, which follows the run that
    had room enough (to 1e-3 of the radius)."""
    over = {"contact.damping_time_s": 1e-2}
    roomy, tight = _collapsing_coil(True, **over), _collapsing_coil(True, **over)
    tight.ws = tight.ws._replace(cpl_filter=new_couplings(4))
    roomy.advance(0.3)
    tight.advance(0.3)
    assert tight.ws.cpl_filter.row.shape[0] >= tight.ws.cpl_filter.count[0] > 4
    assert tight.counts()["steps"] > 0
    gap = np.abs(tight.centerline() - roomy.centerline()).max()
    assert gap < 1e-3 * 0.5 * MM


def test_the_error_filter_has_room_for_blocks_only_with_the_dashpot_or_friction() -> None:
    """Without contact's dashpot or friction the filter writes no blocks off the band, and
    the workspace holds no room for them; a dashpot switched on later grows it from none."""
    plain = _collapsing_coil(True)
    assert len(plain.ws.cpl_filter.row) == 0
    for over in ({"contact.damping_time_s": 1e-2}, {"contact.friction_coefficient": 0.5}):
        assert len(_collapsing_coil(True, **over).ws.cpl_filter.row) > 0
    plain.advance(0.05)
    assert plain.ws.cpl_filter.count[0] == 0
    plain.model.p.contact_damping_time = 1e-2
    plain.advance(0.3)
    assert plain.ws.cpl_filter.row.shape[0] >= plain.ws.cpl_filter.count[0] > 0

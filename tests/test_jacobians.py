"""Each effect's analytic Jacobian against central finite differences of its force,
and the bending gradient/Hessian against finite differences of the energy."""

from __future__ import annotations

import numpy as np
import pytest

from bathprint.core import layout as L
from bathprint.core.assemble import assemble
from bathprint.core.effects.elasticity import bend_energy_grad_hess
from bathprint.core.records import Rod, Stage
from bathprint.core.simulation import Simulation


def _random_rod(effects: list[str], seed: int = 1, **extra) -> Simulation:
    sim = Simulation(
        "paper_simulation",
        {
            "effects": effects,
            "initial.length_mm": 6.0,
            "numerics.node_spacing_mm": 1.0,
            "flow.q_outer_ml_min": 0.0,
            "bath.density_bottom_kg_m3": 1080.0,
            "needle.position_mm": [0.0, 0.0, -124.6],
            "needle.direction": [1.0, 0.2, -0.1],
            **extra,
        },
    )
    rng = np.random.default_rng(seed)
    n = sim.n_nodes
    pos = sim.pos[: 3 * (n - 2)]
    pos += rng.normal(scale=2e-4, size=pos.shape)
    sim.vel[: 3 * (n - 2)] = rng.normal(scale=1e-2, size=3 * (n - 2))
    # natural curvature so that bending is not at its minimum
    sim.seg_mat[: n - 1, L.MAT_KAPPA_X : L.MAT_KAPPA_X + 3] = rng.normal(
        scale=50.0, size=(n - 1, 3)
    )
    return sim


def _assemble(
    sim: Simulation, pos, vel, acc, do_jac: bool, coeffs=(0.0, 0.0, 0.0)
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(force on the free nodes, band, energies) of ``assemble`` at this state."""
    n = sim.n_nodes
    energies = np.zeros(L.N_EFFECTS)
    model, _, _, out = sim.kernel_inputs()
    rod = Rod(pos, vel, acc, n, sim.node_s, sim.seg_rest, sim.seg_mat)
    stage = Stage(0.0, *coeffs, do_jac)
    assemble(model, rod, stage, out, np.zeros(L.N_EFFECTS, np.int64), energies)
    return out.force[: 3 * (n - 2)].copy(), out.band, energies


def _force(sim: Simulation, pos, vel, acc) -> np.ndarray:
    return _assemble(sim, pos, vel, acc, False)[0]


def _dense_jacobian(sim: Simulation, pos, vel, acc, cx, cv, ca) -> np.ndarray:
    nd = 3 * (sim.n_nodes - 2)
    band = _assemble(sim, pos, vel, acc, True, (cx, cv, ca))[1]
    dense = np.zeros((nd, nd))
    for i in range(nd):
        for j in range(max(0, i - L.KL), min(nd, i + L.KU + 1)):
            dense[i, j] = band[i, j - i + L.KL]
    return dense


@pytest.mark.parametrize(
    "effects",
    [
        ["elasticity", "drag"],
        ["drag"],
        ["drag", "gravity"],
        ["drag", "floor"],
        ["drag", "inertia"],
        ["drag", "end_load"],
        ["drag", "viscosity"],
        ["elasticity", "drag", "viscosity", "inertia"],
    ],
)
@pytest.mark.parametrize("which", ["x", "v", "a"])
def test_jacobian_matches_finite_differences(effects: list[str], which: str) -> None:
    sim = _random_rod(effects)
    n = sim.n_nodes
    nd = 3 * (n - 2)
    pos, vel = sim.pos.copy(), sim.vel.copy()
    acc = np.zeros_like(vel)
    if not ("inertia" in effects and which == "x"):
        # the mass matrix's dependence on the tangent (a term O(a)) is left out of the
        # Jacobian by design (see effects/inertia.py), so x is checked at a = 0
        acc[:nd] = np.random.default_rng(3).normal(scale=0.1, size=nd)
    coeff = {"x": (1.0, 0.0, 0.0), "v": (0.0, 1.0, 0.0), "a": (0.0, 0.0, 1.0)}[which]
    jac = _dense_jacobian(sim, pos, vel, acc, *coeff)
    target = {"x": pos, "v": vel, "a": acc}[which]
    step = {"x": 1e-8, "v": 1e-7, "a": 1e-5}[which]
    fd = np.zeros((nd, nd))
    for k in range(nd):
        saved = target[k]
        target[k] = saved + step
        fp = _force(sim, pos, vel, acc)
        target[k] = saved - step
        fm = _force(sim, pos, vel, acc)
        target[k] = saved
        fd[:, k] = -(fp - fm) / (2 * step)
    scale = np.abs(fd).max() + 1e-30
    np.testing.assert_allclose(jac, fd, atol=2e-6 * scale, rtol=0)


def test_force_is_the_same_with_and_without_the_jacobian() -> None:
    """Forces and energies with and without the Jacobian: the residual-only paths (bending
    without its Hessian, inertia's scalar mass product) against the Jacobian paths (the
    3x3 mass blocks)."""
    sim = _random_rod(["elasticity", "drag", "gravity", "inertia", "viscosity"])
    acc = np.random.default_rng(5).normal(scale=0.1, size=sim.vel.shape)
    # coefficients 1: elasticity assembles its Hessian only when cx != 0
    out = [_assemble(sim, sim.pos, sim.vel, acc, j, (1.0, 1.0, 1.0))[::2] for j in (False, True)]
    (f0, e0), (f1, e1) = out
    assert np.abs(f0).max() > 0.0
    np.testing.assert_allclose(f0, f1, rtol=0, atol=1e-12 * np.abs(f1).max())
    np.testing.assert_allclose(e0, e1, rtol=1e-12)


def test_bending_gradient_and_hessian_match_finite_differences() -> None:
    rng = np.random.default_rng(0)
    e1 = rng.normal(size=3)
    e2 = e1 + 0.7 * rng.normal(size=3)
    kbar = rng.normal(scale=0.3, size=3)
    k = 1.7
    g = np.zeros(6)
    h = np.zeros((6, 6))
    work = np.zeros(100)
    bend_energy_grad_hess(e1, e2, kbar, k, g, h, work, True)

    def energy(x: np.ndarray) -> float:
        gg, hh = np.zeros(6), np.zeros((6, 6))
        return bend_energy_grad_hess(
            x[:3].copy(), x[3:].copy(), kbar, k, gg, hh, np.zeros(100), False
        )

    def grad(x: np.ndarray) -> np.ndarray:
        gg, hh = np.zeros(6), np.zeros((6, 6))
        bend_energy_grad_hess(x[:3].copy(), x[3:].copy(), kbar, k, gg, hh, np.zeros(100), False)
        return gg

    x0 = np.concatenate([e1, e2])
    eps = 1e-6
    g_fd = np.array(
        [
            (energy(x0 + eps * np.eye(6)[i]) - energy(x0 - eps * np.eye(6)[i])) / (2 * eps)
            for i in range(6)
        ]
    )
    h_fd = np.array(
        [
            (grad(x0 + eps * np.eye(6)[i]) - grad(x0 - eps * np.eye(6)[i])) / (2 * eps)
            for i in range(6)
        ]
    )
    np.testing.assert_allclose(g, g_fd, rtol=1e-6, atol=1e-8)
    np.testing.assert_allclose(h, h_fd.T, rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(h, h.T, atol=1e-12)


def _check_against_finite_differences(sim: Simulation, which: str, vel_scale: float) -> None:
    n = sim.n_nodes
    nd = 3 * (n - 2)
    pos, vel = sim.pos.copy(), sim.vel.copy() * vel_scale
    acc = np.zeros_like(vel)
    coeff = {"x": (1.0, 0.0, 0.0), "v": (0.0, 1.0, 0.0)}[which]
    jac = _dense_jacobian(sim, pos, vel, acc, *coeff)
    target = {"x": pos, "v": vel}[which]
    step = {"x": 1e-8, "v": 1e-7 * vel_scale}[which]
    fd = np.zeros((nd, nd))
    for k in range(nd):
        saved = target[k]
        target[k] = saved + step
        fp = _force(sim, pos, vel, acc)
        target[k] = saved - step
        fm = _force(sim, pos, vel, acc)
        target[k] = saved
        fd[:, k] = -(fp - fm) / (2 * step)
    scale = np.abs(fd).max() + 1e-30
    np.testing.assert_allclose(jac, fd, atol=2e-6 * scale, rtol=0)


@pytest.mark.parametrize(
    "extra",
    [
        {"drag.model": "finite_re"},
        {"effects": ["drag", "hydrodynamics"], "hydrodynamics.coupling": "lagged"},
        {
            "effects": ["drag", "hydrodynamics"],
            "hydrodynamics.coupling": "lagged",
            "drag.model": "finite_re",
        },
    ],
    ids=["finite_re", "hydrodynamics_cox", "hydrodynamics_finite_re"],
)
@pytest.mark.parametrize("vel_scale", [1e-2, 1.0])  # Re_d ~ 0.1 (Lamb, blend) and ~ 10
@pytest.mark.parametrize("which", ["x", "v"])
def test_drag_law_jacobians_match_finite_differences(extra: dict, vel_scale: float, which: str):
    """The finite-Reynolds law (nonlinear in the speed) and the hydrodynamics effect's local
    window law: exact Jacobians in x (through the tangent and the length) and v. With the
    lagged coupling the nonlocal flow of the step is fixed (here a random one), so the band
    is the whole Jacobian. (Drag alone: the other effects' forces add only round-off to the
    differences.)"""
    effects = extra.get("effects", ["drag"])
    sim = _random_rod(effects, **{k: v for k, v in extra.items() if k != "effects"})
    if "hydrodynamics" in effects:
        n3 = 3 * sim.n_nodes
        sim.ws.hydro.u_nl[:n3] = np.random.default_rng(7).normal(scale=3e-3 * vel_scale, size=n3)
    _check_against_finite_differences(sim, which, vel_scale)

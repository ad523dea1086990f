"""The viscosity effect against the laws of a viscous thread and of a Kelvin-Voigt rod.

- Trouton: a thread pulled by a force F stretches at dL/dt = F L0 / (Tr eta A).
- Kelvin-Voigt: with elastic and viscous stress on the same section, every deformation
  of a straight rod relaxes as exp(-t E / (Tr eta)), independent of its shape.
- The dissipation rate is never negative; bad values name their key.
(The Jacobian against finite differences: tests/test_jacobians.py.)
"""

from __future__ import annotations

import numpy as np
import pytest

from bathprint.analysis import validation as V
from bathprint.core import layout as L
from bathprint.core.assemble import assemble
from bathprint.core.effects.viscosity import BEND_HESS_WORK, bend_rate_grad, bend_rate_grad_hess
from bathprint.core.records import Rod, Stage
from bathprint.core.scene import load_scene
from bathprint.core.simulation import Simulation
from bathprint.errors import SceneError


def test_a_pulled_thread_stretches_at_the_trouton_rate() -> None:
    simulated, exact = V.viscous_thread_stretch_rate()
    assert simulated == pytest.approx(exact, rel=1e-3)  # (the drag left is 1e-4 or less)


@pytest.mark.parametrize("perturbation_mm", [0.05, 0.2])
def test_a_kelvin_voigt_rod_relaxes_at_e_over_trouton_eta(perturbation_mm: float) -> None:
    """Deflection of the free end after one relaxation time tau = Tr eta / E: exp(-1), for
    two amplitudes (the second 4x the first: the relaxation is linear to this precision)."""
    simulated, exact = V.kelvin_voigt_relaxation(perturbation_mm)
    assert simulated == pytest.approx(exact, rel=5e-3)


def _viscous_force_and_power(sim: Simulation, vel: np.ndarray) -> tuple[np.ndarray, float]:
    """(force on every active node, dissipation rate) of the viscosity effect alone."""
    n = sim.n_nodes
    model, _, _, out = sim.kernel_inputs()
    model = model._replace(enabled=np.array([int(e == "viscosity") for e in L.EFFECT_NAMES]))
    energies = np.zeros(L.N_EFFECTS)
    rod = Rod(sim.pos, vel, np.zeros_like(vel), n, sim.node_s, sim.seg_rest, sim.seg_mat)
    assemble(
        model, rod, Stage(0.0, 0.0, 0.0, 0.0, False), out, np.zeros(L.N_EFFECTS, np.int64), energies
    )
    return out.force[: 3 * n].copy(), float(energies[L.E_VISCOSITY])


def _curved_rod() -> Simulation:
    """A planar arc (the first clamped-free mode, 0.3 mm at the free end) of 8 segments."""
    return Simulation(
        "paper_simulation",
        {
            "effects": ["elasticity", "drag", "viscosity"],
            "initial.length_mm": 8.0,
            "numerics.node_spacing_mm": 1.0,
            "flow.q_outer_ml_min": 0.0,
            "initial.perturbation_mm": 0.3,
        },
    )


def test_the_dissipation_rate_is_the_power_of_the_viscous_forces() -> None:
    sim = _curved_rod()
    vel = np.zeros_like(sim.vel)
    n_free = sim.n_nodes - 2
    vel[: 3 * n_free] = np.random.default_rng(4).normal(scale=1e-2, size=3 * n_free)
    force, power = _viscous_force_and_power(sim, vel)
    assert power > 0.0
    assert power == pytest.approx(-(force @ vel[: 3 * sim.n_nodes]), rel=1e-10)


def test_a_rigidly_turning_stencil_keeps_only_its_spin_rate() -> None:
    """The co-rotational rate of a bending stencil turning rigidly at Omega is what the
    mean edge rotation cannot remove, its spin about the tangents:
    w = dkb/dt - omega x kb = 1/2 sum_s (Omega.t_s) t_s x kb (dkb/dt = Omega x kb). So a
    turn in the stencil's plane (Omega along kb, a coil about its axis) costs nothing and
    one about the other in-plane axis O(kb^3); without the co-rotation w = Omega x kb."""
    rng = np.random.default_rng(7)
    for _ in range(20):
        e1 = rng.normal(size=3)
        e2 = e1 + 0.6 * rng.normal(size=3)
        omega = rng.normal(size=3)
        u1, u2 = np.cross(omega, e1), np.cross(omega, e2)
        grad, jhat = np.zeros(6), np.zeros(18)
        bend_rate_grad(e1, e2, u1, u2, 1.0, grad, jhat)
        w = jhat.reshape(3, 6) @ np.concatenate([u1, u2])
        kb = 2.0 * np.cross(e1, e2) / (np.linalg.norm(e1) * np.linalg.norm(e2) + e1 @ e2)
        t1, t2 = e1 / np.linalg.norm(e1), e2 / np.linalg.norm(e2)
        spin = 0.5 * ((omega @ t1) * np.cross(t1, kb) + (omega @ t2) * np.cross(t2, kb))
        np.testing.assert_allclose(w, spin, rtol=0, atol=1e-12 * np.linalg.norm(omega))
        assert np.linalg.norm(np.cross(omega, kb) - spin) > 1e-3 * np.linalg.norm(omega)


def test_the_inlet_segment_is_not_strained_by_its_growth() -> None:
    """The inlet segment grows at the exit speed; its strain rate takes that growth off, so
    extrusion alone strains it no more than without viscosity (the run is a straight jet)."""
    strains = []
    for effects in (["elasticity", "drag"], ["elasticity", "drag", "viscosity"]):
        sim = Simulation(
            "paper_simulation",
            {"effects": effects, "duration_s": 0.1, "needle.imperfection_um": 0.0},
        )
        sim.advance(0.1)
        n_seg = sim.n_segments
        x = sim.centerline()
        inlet = np.linalg.norm(x[n_seg] - x[n_seg - 1]) / sim.rest_lengths()[n_seg - 1] - 1
        strains.append(abs(float(inlet)))
    assert strains[1] < max(2.0 * strains[0], 1e-3)


@pytest.mark.parametrize(
    ("key", "value"),
    [
        ("viscosity.solution_viscosity_pa_s", 0.0),
        ("viscosity.solution_viscosity_pa_s", -1.0),
        ("viscosity.trouton_ratio", 0.0),
        ("viscosity.trouton_ratio", float("nan")),
    ],
)
def test_bad_viscosity_values_name_the_key(key: str, value: float) -> None:
    with pytest.raises(SceneError, match=key.replace(".", r"\.")):
        load_scene("paper_simulation", {"effects": ["elasticity", "drag", "viscosity"], key: value})


def _stencils() -> list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]:
    """(e1, e2, u1, u2): random stencils, nearly straight ones (turning 1e-3 rad) and
    strongly bent ones (turning about 2.6 rad), edges of unequal lengths, u nonzero."""
    rng = np.random.default_rng(11)
    out = []
    for kind in ("random", "straight", "bent"):
        for _ in range(8):
            e1 = rng.normal(size=3) * rng.uniform(0.5, 2.0)
            if kind == "random":
                e2 = rng.normal(size=3)
            else:
                t1 = e1 / np.linalg.norm(e1)
                n = np.cross(t1, rng.normal(size=3))
                n /= np.linalg.norm(n)
                angle = 1e-3 if kind == "straight" else 2.6
                e2 = (np.cos(angle) * t1 + np.sin(angle) * n) * rng.uniform(0.5, 2.0)
            out.append((e1, e2, rng.normal(size=3), rng.normal(size=3)))
    return out


def _central_differences(e1, e2, u1, u2, k, step=1e-6) -> np.ndarray:
    """d grad/de of bend_rate_grad by central differences (relative step ``step``), column
    by column: the oracle of the analytic derivative (and the Jacobian's former method)."""
    out = np.zeros((6, 6))
    gp, gm, jtmp = np.zeros(6), np.zeros(6), np.zeros(18)
    for c in range(6):
        x = [e1.copy(), e2.copy()]
        h = step * np.linalg.norm(x[c // 3])
        x[c // 3][c % 3] += h
        bend_rate_grad(x[0], x[1], u1, u2, k, gp, jtmp)
        x[c // 3][c % 3] -= 2.0 * h
        bend_rate_grad(x[0], x[1], u1, u2, k, gm, jtmp)
        out[:, c] = (gp - gm) / (2.0 * h)
    return out


def test_the_analytic_bending_jacobian_matches_central_differences() -> None:
    """bend_rate_grad_hess: the same energy, gradient and Jh as bend_rate_grad, and
    d grad/de within 1e-7 (relative to its largest entry) of central differences, on
    random, nearly straight and strongly bent stencils."""
    k = 3.7
    for e1, e2, u1, u2 in _stencils():
        grad, jhat, g_ref, j_ref = np.zeros(6), np.zeros(18), np.zeros(6), np.zeros(18)
        work, dgrad = np.full(BEND_HESS_WORK, np.nan), np.full((6, 6), np.nan)
        energy = bend_rate_grad_hess(e1, e2, u1, u2, k, grad, jhat, work, dgrad)
        assert energy == bend_rate_grad(e1, e2, u1, u2, k, g_ref, j_ref)
        np.testing.assert_array_equal(grad, g_ref)
        np.testing.assert_array_equal(jhat, j_ref)
        fd = _central_differences(e1, e2, u1, u2, k)
        scale = np.abs(dgrad).max()
        assert scale > 0.0
        np.testing.assert_allclose(dgrad, fd, rtol=0, atol=1e-7 * scale)

"""Gelation's surface model: a set shell growing inward by Ca2+ diffusion around a liquid core.

The front against the moving-boundary problem it approximates (Neumann's short-time front
2 lambda sqrt(D t), and a numerical solution of the cylinder's one-phase Stefan problem by the
enthalpy method), the factors against the section's geometry, monotone stiffening, curvature
memory weighted by the bending stiffness, a scene that runs with it, and bad keys refused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint import SceneError, Simulation
from bathprint.core import layout as L
from bathprint.core.composite import stiffness_factors
from bathprint.core.effects import gelation
from bathprint.core.extrusion import material_row
from bathprint.core.model import compile_model
from bathprint.core.scene import load_scene

SURFACE = {
    "effects": ["elasticity", "drag", "gravity", "gelation"],
    "gelation.model": "surface",
}


def _params(**over: float) -> np.record:
    scene = load_scene("drag_coiling_22G", {**SURFACE, **over})
    return compile_model(scene).p


def _neumann_residual(lam: float, beta: float) -> float:
    return math.sqrt(math.pi) * lam * math.exp(lam * lam) * math.erf(lam) - beta


def enthalpy_front(beta: float, times: np.ndarray, n_cells: int = 200) -> np.ndarray:
    """xi = r_c / r of the cylinder's moving-boundary problem, numerically (units r = D = c_b
    = 1, bath c0 = beta): total calcium H = free c + bound b, b = min(H, 1), c = max(H - 1, 0),
    dH/dt = (1/rho) d/drho (rho dc/drho), c = beta at rho = 1 (finite volumes, explicit).
    The core is what is not yet bound: xi^2 = 1 - (bound area fraction)."""
    dr = 1.0 / n_cells
    rc = (np.arange(n_cells) + 0.5) * dr
    rf = np.arange(n_cells + 1) * dr
    h = np.zeros(n_cells)
    dt = 0.2 * dr * dr
    out = np.empty(len(times))
    t = 0.0
    flux = np.zeros(n_cells + 1)
    for k, target in enumerate(times):
        while t < target:
            c = np.maximum(h - 1.0, 0.0)
            flux[1:n_cells] = (c[1:] - c[:-1]) / dr
            flux[n_cells] = (beta - c[-1]) / (0.5 * dr)
            h += dt * (rf[1:] * flux[1:] - rf[:-1] * flux[:-1]) / (rc * dr)
            t += dt
        bound = 2.0 * np.sum(np.minimum(h, 1.0) * rc * dr)
        out[k] = math.sqrt(max(1.0 - bound, 0.0))
    return out


# ------------------------------------------------------------------ the front


@pytest.mark.parametrize("beta", [1e-3, 0.1, 150.0 / 53.0, 30.0])
def test_neumann_lambda_solves_its_equation(beta: float) -> None:
    lam = gelation.neumann_lambda(beta)
    assert abs(_neumann_residual(lam, beta)) < 1e-12 * max(beta, 1.0)
    if beta < 0.01:  # the quasi-steady limit lambda = sqrt(beta / 2)
        assert lam == pytest.approx(math.sqrt(beta / 2.0), rel=beta)


def test_neumann_lambda_refuses_a_non_positive_ratio() -> None:
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="beta"):
            gelation.neumann_lambda(bad)


def test_front_follows_two_lambda_sqrt_dt_at_short_times() -> None:
    p = _params()
    r = float(p.exit_radius)
    lam, d = float(p.gel_front_lambda), float(p.gel_diffusivity)
    for age in np.geomspace(1e-7, 1e-3, 9):
        shell = r * (1.0 - gelation.core_fraction(age, r, p))
        neumann = 2.0 * lam * math.sqrt(d * age)
        eps = neumann / r
        assert eps < 0.1
        # planar front plus the cylinder's first correction, (1 + eps/6): within eps^2
        assert shell / neumann == pytest.approx(1.0 + eps / 6.0, abs=eps * eps)


def test_core_fraction_inverts_the_shrinking_core_law() -> None:
    p = _params()
    r = float(p.exit_radius)
    t_set = r * r / (8.0 * p.gel_front_lambda**2 * p.gel_diffusivity)
    for frac in np.linspace(0.001, 0.999, 37):
        xi = gelation.core_fraction(frac * t_set, r, p)
        assert 0.0 < xi < 1.0
        law = 1.0 - xi * xi + 2.0 * xi * xi * math.log(xi)
        assert law == pytest.approx(frac, rel=1e-10, abs=1e-13)
    assert gelation.core_fraction(0.0, r, p) == 1.0
    assert gelation.core_fraction(t_set * 1.0001, r, p) == 0.0


@pytest.mark.parametrize("beta", [1.0, 150.0 / 53.0])
def test_front_against_the_moving_boundary_problem_of_the_cylinder(beta: float) -> None:
    """The closed form against the numerical Stefan problem (converged to 5e-4 at 100
    cells), with the accuracy docs/physics/gelation.md states for c0 / c_b <= 3: the core
    radius within 0.005 r while the shell is thinner than r/5, and the bending and
    stretching factors within 0.012 and 0.04 of the set shell's until the section has set."""
    p = _params(**{"gelation.bath_calcium_mol_m3": 53.0 * beta})
    lam = float(p.gel_front_lambda)
    t_set = 1.0 / (8.0 * lam * lam)  # in units r^2 / D
    times = t_set * np.array([0.002, 0.01, 0.05, 0.2, 0.5, 0.8, 1.0, 1.3])
    numeric = enthalpy_front(beta, times, n_cells=100)
    r = float(p.exit_radius)
    d = float(p.gel_diffusivity)
    model = np.array([gelation.core_fraction(t * r * r / d, r, p) for t in times])
    thin = 1.0 - numeric < 0.2
    assert thin.sum() >= 2
    assert np.max(np.abs(model - numeric)[thin]) < 0.005
    assert np.max(np.abs(model**4 - numeric**4)) < 0.012
    assert np.max(np.abs(model**2 - numeric**2)) < 0.04
    assert model[-2] == 0.0 and numeric[-2] > 0.0  # at t_set the closed form has set, earlier


# ------------------------------------------------------------------ factors


def _section_factors(xi: float, ratio: float) -> tuple[float, float]:
    """Bending and stretching stiffness of a two-material disc (shell E_s, core ratio E_s,
    radius xi) over those of a full disc of E_s, by quadrature over the section."""
    n = 4000
    rho = (np.arange(n) + 0.5) / n  # radius r = 1
    e = np.where(rho < xi, ratio, 1.0)
    area = np.sum(e * 2.0 * np.pi * rho) / n
    inertia = np.sum(e * np.pi * rho**3) / n  # int y^2 dA = pi rho^3 drho
    return inertia / (math.pi / 4.0), area / math.pi


def test_shell_factors_are_those_of_the_section() -> None:
    p = _params(**{"gelation.core_modulus_pa": 300.0})
    ratio = 300.0 / float(p.gel_shell_modulus)
    for xi in (0.0, 0.3, 0.7, 0.95, 1.0):
        bend, stretch = gelation.shell_factors(xi, p)
        q_bend, q_stretch = _section_factors(xi, ratio)
        assert bend == pytest.approx(q_bend, rel=1e-3)
        assert stretch == pytest.approx(q_stretch, rel=1e-3)


def test_material_row_multiplies_the_shell_and_inclusion_factors() -> None:
    over = {**SURFACE, "effects": [*SURFACE["effects"], "inclusions"]}
    p = compile_model(load_scene("drag_coiling_22G", over)).p
    row = np.zeros(L.N_MAT)
    direction = np.array([0.0, 0.0, -1.0])
    age, phi = 0.4, 0.1  # drops (Mori-Tanaka), not slugs
    material_row(phi, -age, 0.0, direction, p, row)
    xi = gelation.core_fraction(age, float(p.exit_radius), p)
    bend, stretch = gelation.shell_factors(xi, p)
    inc_bend, inc_stretch, _, _ = stiffness_factors(phi, float(p.slug_fraction))
    assert 0.1 < xi < 0.99 and inc_bend < 0.9
    assert row[L.MAT_YOUNGS_MODULUS] == float(p.gel_shell_modulus)
    assert row[L.MAT_BEND_FACTOR] == pytest.approx(inc_bend * bend, rel=1e-14)
    assert row[L.MAT_STRETCH_FACTOR] == pytest.approx(inc_stretch * stretch, rel=1e-14)
    assert row[L.MAT_DENSITY] == pytest.approx((1 - phi) * 1054.0 + phi * p.inner_density)


def test_stiffness_grows_monotonically_from_the_core_to_the_set_gel() -> None:
    for radius_mm in (0.1, 0.2, 0.5):
        p = _params(**{"needle.inner_diameter_mm": 2 * radius_mm})
        r = float(p.exit_radius)
        t_set = r * r / (8.0 * p.gel_front_lambda**2 * p.gel_diffusivity)
        ages = np.concatenate([[0.0], np.geomspace(1e-6 * t_set, 2 * t_set, 400)])
        factors = np.array(
            [gelation.shell_factors(gelation.core_fraction(a, r, p), p) for a in ages]
        )
        assert np.all(np.diff(factors[:, 0]) >= 0) and np.all(np.diff(factors[:, 1]) >= 0)
        ratio = p.gel_core_modulus / p.gel_shell_modulus
        assert factors[0] == pytest.approx([ratio, ratio], rel=1e-12)
        assert factors[-1] == pytest.approx([1.0, 1.0], rel=1e-12)
        # bending stiffens ahead of stretching (the shell carries r^4, not r^2)
        assert np.all(factors[1:-1, 0] >= factors[1:-1, 1] - 1e-15)


def test_curvature_memory_weighs_by_the_bending_stiffness() -> None:
    """A bent free filament gaining shell: kappa0 moves to kappa by 1 - B_old / B_new."""
    radius = 8e-3
    arc = np.linspace(0.0, 1.2, 25)
    pts = np.column_stack([radius * np.cos(arc), radius * np.sin(arc), np.zeros_like(arc)])
    sim = Simulation.from_points(pts, "drag_coiling_22G", SURFACE)
    mat = sim.seg_mat
    n_seg = sim.n_segments
    b_old = mat[:n_seg, L.MAT_YOUNGS_MODULUS] * mat[:n_seg, L.MAT_BEND_FACTOR]
    assert np.abs(mat[:n_seg, L.MAT_KAPPA_X : L.MAT_KAPPA_X + 3]).max() == 0.0
    t = 0.05
    gelation.update(sim.model.record, sim._rod(), t, sim.ws.scratch)
    b_new = mat[:n_seg, L.MAT_YOUNGS_MODULUS] * mat[:n_seg, L.MAT_BEND_FACTOR]
    assert np.all(b_new > 2.0 * b_old)
    kappa0 = np.linalg.norm(mat[:n_seg, L.MAT_KAPPA_X : L.MAT_KAPPA_X + 3], axis=1)
    inner = slice(1, n_seg - 1)  # both end nodes interior: the curvature is the arc's
    expected = (1.0 / radius) * (1.0 - b_old / b_new)
    np.testing.assert_allclose(kappa0[inner], expected[inner], rtol=2e-3)


# ------------------------------------------------------------------ scenes


def test_a_scene_with_the_surface_model_runs_and_its_material_follows_the_law() -> None:
    sim = Simulation("drag_coiling_22G", {**SURFACE, "duration_s": 0.25})
    sim.advance(0.25)
    assert sim.n_segments > 20
    mat = sim.material()
    p = sim.model.p
    age = sim.t - mat[:, L.MAT_BIRTH_TIME]
    xi = np.array([gelation.core_fraction(a, float(p.exit_radius), p) for a in age])
    bend = np.array([gelation.shell_factors(x, p)[0] for x in xi])
    np.testing.assert_allclose(mat[:, L.MAT_BEND_FACTOR], bend, rtol=1e-12)
    assert np.all(mat[:, L.MAT_YOUNGS_MODULUS] == float(p.gel_shell_modulus))
    assert np.all(mat[:, L.MAT_DENSITY] == 1054.0)
    # older material (free end, row 0) is stiffer than fresh material at the needle
    assert mat[0, L.MAT_BEND_FACTOR] > 3.0 * mat[-1, L.MAT_BEND_FACTOR]


def test_the_bulk_model_stays_the_default() -> None:
    scene = load_scene("gelation_coiling_22G")
    assert scene.gelation.model == "bulk"
    assert int(compile_model(scene).p.gel_model) == L.GEL_BULK


@pytest.mark.parametrize(
    ("key", "value", "words"),
    [
        ("gelation.model", "shell", "one of 'bulk', 'surface'"),
        ("gelation.calcium_diffusivity_m2_s", -1e-9, "physical range"),
        ("gelation.calcium_diffusivity_m2_s", 0.0, "physical range"),
        ("gelation.bath_calcium_mol_m3", math.nan, "physical range"),
        ("gelation.bath_calcium_mol_m3", 1e-9, "physical range"),
        ("gelation.binding_capacity_mol_m3", 0.0, "physical range"),
        ("gelation.binding_capacity_mol_m3", "53", "not a number"),
        ("gelation.shell_modulus_pa", 1e9, "physical range"),
        ("gelation.core_modulus_pa", 0.0, "physical range"),
        ("gelation.core_modulus_pa", 40000.0, "gelation.shell_modulus_pa"),
        ("gelation.shell_thickness_um", 10.0, "unknown key"),
    ],
)
def test_bad_surface_keys_are_refused_by_name(key: str, value: object, words: str) -> None:
    with pytest.raises(SceneError) as err:
        compile_model(load_scene("drag_coiling_22G", {**SURFACE, key: value}))
    assert key in str(err.value) and words in str(err.value)

"""The environments' compiled step path against the numpy expressions it replaced (kept here
as references): flow table update, numpy-order sums, metric, observation.

Elementwise results (flow tables, per-sample errors, observation entries without a reduction)
are compared bit for bit. Sums and means are compared to within the round-off of a sum
(:func:`sum_rtol`): the kernels add in numpy's pairwise order, so today they agree exactly,
but that order is numpy's undocumented implementation; only
``test_pairwise_sum_follows_numpys_order`` is tied to it (numpy is pinned in
requirements/constraints.txt).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import bathprint.envs as E
from bathprint.core import layout as L
from bathprint.core.extrusion import extruded_length, flow_rate, inner_volume
from bathprint.core.model import flow_cumulative
from bathprint.envs import observation as ob
from bathprint.envs._kernels import pairwise_sum
from bathprint.envs.base import ML_MIN
from bathprint.envs.metric import MetricParams, PrintedSamples, evaluate
from bathprint.envs.targets import Target, discrete_curvature
from bathprint.envs.v0 import BathprintEnvV0


# ------------------------------------------------------------------ references (numpy)
def reference_evaluate(
    target: Target, pts: np.ndarray, dens: np.ndarray, p: MetricParams, bath_range
) -> tuple[np.ndarray, float, float, float, float]:
    """The metric as first written with numpy (errors, value, shape, curvature, density)."""
    from bathprint.envs.metric import settle_density, windowed_kabsch_rmsd

    n_all = target.n_samples
    n_sc = min(len(pts), n_all)
    err2 = np.full(n_all, p.missing_error**2)
    shape = curv = dn = 0.0
    if n_sc > 0:
        h = target.spacing_mm
        e2 = np.zeros(n_sc)
        if p.w_shape > 0:
            half = max(1, int(round(0.5 * p.window_mm / h)))
            d = windowed_kabsch_rmsd(pts[:n_sc], target.points_mm[:n_sc], half, p.allow_reflection)
            e2 += p.w_shape * (d / p.length_scale_mm) ** 2
            shape = float(np.sqrt(np.mean(d * d)))
        if p.w_curvature > 0:
            k = max(1, int(round(p.curvature_span_mm / h)))
            dk = discrete_curvature(pts[:n_sc], k) - discrete_curvature(target.points_mm, k)[:n_sc]
            if n_sc < 2 * k + 1:
                dk = np.zeros(n_sc)
            e2 += p.w_curvature * (p.length_scale_mm * dk) ** 2
            curv = float(np.sqrt(np.mean(dk * dk)))
        if p.w_density > 0:
            rho = settle_density(dens[:n_sc], bath_range)
            lo, hi = target.density_lo_kg_m3[:n_sc], target.density_hi_kg_m3[:n_sc]
            dr = np.maximum(lo - rho, 0.0) + np.maximum(rho - hi, 0.0)
            e2 += p.w_density * (dr / p.density_scale_kg_m3) ** 2
            dn = float(np.sqrt(np.mean(dr * dr)))
        err2[:n_sc] = np.minimum(e2, p.missing_error**2)
    err2 = np.where(np.isfinite(err2), err2, p.missing_error**2)
    return np.sqrt(err2), float(np.sqrt(np.mean(err2))), shape, curv, dn


def reference_observe(env: BathprintEnvV0) -> np.ndarray:
    """The observation as first written with numpy, from the environment's state."""
    tgt = env.target
    u, x, v, rho = env._u, env._x, env._v, env._rho

    def density_at(uq: np.ndarray) -> np.ndarray:
        idx = np.searchsorted(u, uq, side="right") - 1
        return rho[np.clip(idx, 0, len(rho) - 1)]

    xv = env._interp(u[-1] - ob.QUERY_MM, np.concatenate([x, v], axis=1))
    parts = [
        (xv[ob.QUERY_TIP, :3] - x[-1]).ravel() / ob.OBS_LENGTH_MM,
        xv[ob.QUERY_VEL, 3:].ravel() / ob.OBS_SPEED_MM_S,
        discrete_curvature(xv[ob.QUERY_BACK, :3], 2)[ob.CURV_INDEX] * ob.OBS_CURVATURE_MM,
        (density_at(u[-1] - np.array(ob.DENS_OFFSETS_MM)) - ob.OBS_DENSITY_REF_KG_M3)
        / ob.OBS_DENSITY_SCALE_KG_M3,
    ]
    s = env._printed_mm + np.array(ob.TARGET_OFFSETS_MM)
    idx = np.clip(np.round(s / tgt.spacing_mm).astype(int), 0, tgt.n_samples - 1)
    aim = tgt.density_aim(env.rho_gel)[idx]
    feats = np.stack(
        [
            tgt.curvature_1_mm[idx] * ob.OBS_CURVATURE_MM,
            tgt.torsion_1_mm[idx] * ob.OBS_CURVATURE_MM,
            (aim - ob.OBS_DENSITY_REF_KG_M3) / ob.OBS_DENSITY_SCALE_KG_M3,
        ],
        axis=1,
    )
    parts.append(feats.ravel())
    c = env._controls
    off_span = env.offset_range[1] - env.offset_range[0]
    off = c["inclusion_offset"]
    off_obs = 0.0
    if off is not None and off_span > 0:
        off_obs = 2 * (off - env.offset_range[0]) / off_span - 1
    a = env.controls_to_action(c["q_outer_ml_min"], c["q_inner_ml_min"])
    q_in = a[env.action_names.index("q_inner")] if "q_inner" in env.action_names else -1.0
    needle = (env._needle_mm - env.needle_start_mm) / ob.OBS_NEEDLE_MM
    parts.append(np.array([a[0], q_in, off_obs, *needle]))
    m = env._metric
    j = env._scored()
    recent = m.errors[max(0, j - ob.RECENT_SAMPLES) : j]
    miss = env.metric_params.missing_error
    parts.append(
        np.array(
            [
                env._printed_mm / env.episode_length_mm,
                m.scored_fraction,
                m.value / miss,
                recent.mean() / miss if len(recent) else 1.0,
            ]
        )
    )
    obs = np.nan_to_num(np.concatenate(parts), nan=0.0, posinf=ob.OBS_CLIP, neginf=-ob.OBS_CLIP)
    return np.clip(obs, -ob.OBS_CLIP, ob.OBS_CLIP).astype(np.float32)


def sum_rtol(n: int) -> float:
    """Relative bound on the difference between two pairwise-type sums of n non-negative
    terms (numpy's: blocks of <= 128 added 8-way, at most ceil(log2 n) + 16 roundings on any
    path), a division by n and a square root on top."""
    return 2.0 * (math.ceil(math.log2(max(n, 2))) + 16 + 2) * np.finfo(float).eps


F32_RTOL = float(np.finfo(np.float32).eps)  # two doubles within sum_rtol round to <= 1 ulp apart


# ------------------------------------------------------------------ tests
def test_pairwise_sum_is_accurate() -> None:
    """The compiled pairwise sum is within the pairwise error bound of the exact sum."""
    rng = np.random.default_rng(0)
    eps = np.finfo(float).eps
    for n in [*range(300), 1000, 1027, 5000]:
        a = rng.standard_normal(n + 3) * 10.0 ** rng.uniform(-6, 6, n + 3)
        part = a[2 : 2 + n]
        bound = (math.ceil(math.log2(max(n, 2))) + 16) * eps * float(np.abs(part).sum())
        assert abs(pairwise_sum(a, 2, n) - math.fsum(part)) <= bound


def test_pairwise_sum_follows_numpys_order() -> None:
    """Bit-equality with np.sum: the kernel mirrors numpy's pairwise order (blocks of 128
    added with 8 accumulators), so the compiled metric reproduces the numpy one exactly.
    That order is numpy's implementation, not its documented behaviour: if a numpy upgrade
    changes it this test fails without a defect in bathprint, and ``pairwise_sum`` (in
    envs/_kernels.py) should follow the new order."""
    rng = np.random.default_rng(0)
    for n in [*range(300), 1000, 1027, 5000]:
        a = rng.standard_normal(n + 3) * 10.0 ** rng.uniform(-6, 6, n + 3)
        assert pairwise_sum(a, 2, n) == np.sum(a[2 : 2 + n]), f"numpy {np.__version__}, n={n}"


def _reference_set_flow(m, t: float, qo: float, qi: float) -> None:
    """``Simulation.set_flow``'s table update as it was written in numpy (the reference)."""
    flow = m.flow
    keep = flow[:, 0] < t
    qo_now, qi_now = flow_rate(flow, t)
    rows = [flow[keep]] if keep.any() else []
    rows.append(np.array([[t, qo_now, qi_now]]))
    rows.append(np.array([[t + 1e-6, qo, qi]]))
    new = np.concatenate(rows)
    if len(new) > 64:
        new = new[-64:]
    first = new[0, 0]
    start = (
        float(extruded_length(flow, m.flow_cum, m.needle_area, first)),
        float(inner_volume(flow, m.flow_cum, first)),
    )
    m.flow = np.ascontiguousarray(new)
    m.flow_cum = flow_cumulative(m.flow, m.needle_area, start)


def test_compiled_set_flow_equals_the_numpy_reference() -> None:
    envs = [E.make("bathprint/WriteShape-v0", accuracy="draft").unwrapped for _ in range(2)]
    for env in envs:
        env.reset(seed=0)
    a, b = envs[0].sim, envs[1].sim
    rng = np.random.default_rng(1)
    for _ in range(100):  # past 64 knots: the table is cut and its cumulative start moves
        t = a.t + rng.uniform(1e-4, 0.02)
        a.fstate[0] = b.fstate[0] = t  # only the time matters to set_flow
        qo, qi = rng.uniform(0.25, 2.0) * ML_MIN, rng.uniform(0.0, 0.2) * ML_MIN
        a.set_flow(qo, qi)
        _reference_set_flow(b.model, t, qo, qi)
        np.testing.assert_array_equal(b.model.flow, a.model.flow)
        np.testing.assert_array_equal(b.model.flow_cum, a.model.flow_cum)
    assert len(a.model.flow) == 64


@pytest.mark.parametrize("bath", [None, (1010.0, 1050.0)])
def test_metric_equals_the_numpy_reference(bath) -> None:
    env = E.make("bathprint/WriteShape-v0", accuracy="draft").unwrapped
    rng = np.random.default_rng(2)
    params = [
        MetricParams(w_density=0.5),
        MetricParams(window_mm=7.0, w_shape=0.3, w_curvature=0.0, w_density=1.0),
        MetricParams(w_shape=0.0, w_curvature=0.0, w_density=1.0, allow_reflection=False),
        MetricParams(allow_reflection=False, curvature_span_mm=2.0),
    ]
    for trial in range(12):
        target = env.sampler.train_target(rng)
        n = target.n_samples
        for j in (0, 1, 3, 5, 17, n // 2, n, n + 4):
            pts = target.points_mm[: min(j, n)] + 0.3 * rng.standard_normal((min(j, n), 3))
            pts = np.concatenate([pts, rng.standard_normal((j - len(pts), 3))])
            dens = rng.uniform(1000.0, 1060.0, j)
            if trial % 4 == 3 and j > 4:
                pts[2] = np.nan
                dens[3] = np.nan
            p = params[trial % len(params)]
            got = evaluate(target, PrintedSamples(pts, dens), p, bath)
            ref = reference_evaluate(target, pts, dens, p, bath)
            np.testing.assert_array_equal(got.errors, ref[0])
            assert [got.value, got.shape_rms_mm, got.curvature_rms_1_mm, got.density_rms_kg_m3] == (
                pytest.approx(list(ref[1:]), rel=sum_rtol(max(n, j)), abs=0, nan_ok=True)
            )
            assert got.scored_fraction == min(j, n) / n


def assert_observation_equal(obs: np.ndarray, ref: np.ndarray) -> None:
    """Bit-equal, except the last two entries (the metric value and the mean recent error,
    both sums): float32 roundings of doubles within :func:`sum_rtol`, so <= 1 ulp apart."""
    np.testing.assert_array_equal(obs[:-2], ref[:-2])
    np.testing.assert_allclose(obs[-2:], ref[-2:], rtol=F32_RTOL, atol=0)


@pytest.mark.parametrize(
    ("env_id", "kwargs"),
    [
        ("bathprint/CoilRadius-v0", {}),
        ("bathprint/WriteShape-v0", {"needle_velocity": True}),
        ("bathprint/BuoyantLayers-v0", {}),
    ],
)
def test_observation_and_metric_equal_the_numpy_reference(env_id: str, kwargs: dict) -> None:
    env = E.make(env_id, accuracy="draft", **kwargs)
    u = env.unwrapped
    env.action_space.seed(3)
    obs, _ = env.reset(seed=3)
    assert_observation_equal(obs, reference_observe(u))
    for _ in range(u.episode_steps):
        obs, _, term, trunc, _ = env.step(env.action_space.sample())
        assert not trunc
        assert_observation_equal(obs, reference_observe(u))
        p = u.printed_samples()
        ref = reference_evaluate(
            u.target, p.points_mm, p.density_kg_m3, u.metric_params, u.bath_range
        )
        np.testing.assert_array_equal(u._metric.errors, ref[0])
        assert u._metric.value == pytest.approx(ref[1], rel=sum_rtol(u.target.n_samples), abs=0)
        assert u._rho.tolist() == u.sim.material()[:, L.MAT_DENSITY].tolist()
        if term:
            break
    assert term and math.isfinite(u._metric.value)


# ------------------------------------------------------------------ target torsion
@pytest.mark.parametrize("direction", [(0.0, 0.0, -1.0), (0.3, 0.5, -0.8), (-0.7, 0.1, 0.2)])
def test_straight_target_file_has_no_torsion_in_any_direction(tmp_path, direction) -> None:
    """A straight line from a target file: d1 x d2 is round-off everywhere, and with a
    threshold relative to its own largest value the torsion was round-off / round-off (up
    to ~17 1/mm along (0.3, 0.5, -0.8); exactly 0 only along an axis), which reached the
    observation. It is 0, and the osculating coil radius inf, in every direction."""
    from bathprint.envs.targets import load_target_file

    d = np.asarray(direction) / np.linalg.norm(direction)
    path = tmp_path / "line.npy"
    np.save(path, np.array([12.0, -3.0, 40.0]) + np.outer(np.arange(50.0), d))
    target = load_target_file(path, 0.25)
    np.testing.assert_allclose(target.torsion_1_mm, 0.0, rtol=0, atol=1e-9)
    assert np.isinf(target.coil_radius_mm()).all()


@pytest.mark.parametrize("offset_mm", [0.0, 1e3])
def test_helix_torsion_is_kept(offset_mm: float) -> None:
    """The floor only removes round-off: a helix (R 3 mm, pitch 2 mm), near the origin or
    1 m from it, keeps its torsion to the accuracy of the central differences."""
    from bathprint.envs.targets import curve_from_curvature, discrete_torsion
    from bathprint.envs.targets import helix_curvature_torsion as kt

    kappa, tau = (float(x) for x in kt(np.array(3.0), np.array(2.0)))
    pts = curve_from_curvature(np.full(400, kappa), np.full(400, tau), 0.25) + offset_mm
    got = discrete_torsion(pts, 8)
    np.testing.assert_allclose(got[16:-16], tau, rtol=2e-3)

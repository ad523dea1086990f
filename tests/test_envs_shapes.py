"""The shape environments (WriteShape-v3, CoilRadius-v2, BuoyantLayers-v2): named shape
sets, the generator for training, the whole-shape error as the reported metric, and a
reward whose return is a function of it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import bathprint.envs as E
from bathprint.agents.controller import FAMILY_ENVS, make_controller
from bathprint.envs.shape_metric import THRESHOLDS, shape_error
from bathprint.envs.shapes import index
from bathprint.errors import ConfigError

IDS = {fam: env_id for fam, env_id in FAMILY_ENVS.items()}


def make(env_id: str, **kwargs):
    return E.make(env_id, accuracy="draft", **kwargs)


def play(env, policy, **reset) -> tuple[float, dict, list[float]]:
    obs, info = env.reset(**reset)
    total, rewards = 0.0, []
    while True:
        a, _ = policy.predict(obs)
        obs, r, term, trunc, info = env.step(a)
        total += r
        rewards.append(r)
        if term or trunc:
            return total, info, rewards


@pytest.mark.parametrize("family", list(IDS))
def test_registered_newest_and_gymnasium_valid(family):
    env_id = IDS[family]
    assert env_id in E.register_envs()
    assert E.newest_id(env_id) == env_id
    assert E.shape_targets(env_id) and E.printed_targets(env_id)
    assert E.fixed_target_sets(env_id) == ("validation", "test", "ood_test")
    env = make(env_id)
    u = env.unwrapped
    assert u.family == family and u.spec_data.version == 3
    named = [r for r in index() if r["family"] == family]
    for st in ("validation", "test", "ood_test"):
        assert u.set_sizes[st] == sum(r["set"] == st for r in named)
        assert E.target_set_size(u, st) == u.set_sizes[st]
    gym_check_env(u, skip_render_check=True)


@pytest.mark.parametrize("family", list(IDS))
def test_return_is_the_reported_whole_shape_error(family):
    """Return = (m^2 - min(rms^2, m^2)) / L^2 with rms the reported error, which is the
    shape_error of the written curve against the target."""
    env = make(IDS[family], target_set="validation")
    u = env.unwrapped
    ret, info, _ = play(env, make_controller(env), seed=0, options={"target_index": 0})
    m, L = u.missing_error_mm, u.length_scale_mm
    assert info["metric"] == info["rms_mm"]
    assert ret == pytest.approx((m**2 - min(info["rms_mm"] ** 2, m**2)) / L**2, rel=1e-9)
    err = shape_error(u.written_curve(), u._reference, family)
    assert info["rms_mm"] == pytest.approx(err.rms_mm, rel=1e-12)
    assert info["is_success"] == err.success
    assert math.isfinite(info["local_metric"])


def test_floor_shape_is_placed_under_the_needle_inside_the_box():
    env = make(IDS["floor"], target_set="validation")
    u = env.unwrapped
    box = u.needle_box_mm
    for k in range(u.set_sizes["validation"]):
        env.reset(seed=0, options={"target_index": k})
        p = u.target.points_mm
        assert np.allclose(p[0, :2], u.needle_start_mm[:2], atol=1e-9)
        assert (p[:, :2] >= box[:2, 0] - 1e-9).all() and (p[:, :2] <= box[:2, 1] + 1e-9).all()


def test_training_draws_generator_shapes_never_held_out_and_deterministic():
    env = make(IDS["floor"])
    held = {r["key"] for r in index() if r["family"] == "floor"}
    names = []
    for seed in (0, 1):
        _, info = env.reset(seed=seed)
        names.append(info["target_name"])
        assert env.unwrapped.target.params["shape_family"] == "floor"
    assert names[0] != names[1]
    _, again = env.reset(seed=0)
    assert again["target_name"] == names[0]
    keys = {env.unwrapped.generator.sample(np.random.default_rng(s)).key for s in range(20)}
    assert not keys & held


def test_same_seed_same_episode():
    a, b = make(IDS["buoyant"]), make(IDS["buoyant"])
    rng = np.random.default_rng(3)
    acts = rng.uniform(-1, 1, (40, 2)).astype(np.float32)
    oa, _ = a.reset(seed=5)
    ob, _ = b.reset(seed=5)
    for act in acts:
        oa, ra, *_ = a.step(act)
        ob, rb, *_ = b.step(act)
        np.testing.assert_array_equal(oa, ob)
        assert ra == rb


def test_buoyant_success_bounds_the_rms_only():
    thr = THRESHOLDS["buoyant"]
    assert math.isinf(thr.max_max_mm) and "lag" in thr.why


def test_bad_arguments_are_refused_with_the_key_named():
    with pytest.raises(ConfigError, match="target_set = 'eval'"):
        make(IDS["free"], target_set="eval")
    env = make(IDS["free"], target_set="test")
    with pytest.raises(ConfigError, match=r"target_index'\] = 99.*allowed 0..6"):
        env.reset(options={"target_index": 99})
    with pytest.raises(ConfigError, match="named shape"):
        make(IDS["free"], target_index=0)
    with pytest.raises(ConfigError, match="version-3"):
        make(IDS["free"], spec_overrides={"target": {"shape_family": "wall"}})


def test_get_state_set_state_continue_identically():
    env = make(IDS["floor"], target_set="test")
    ctl = make_controller(env)
    obs, _ = env.reset(seed=0, options={"target_index": 1})
    for _ in range(10):
        obs, *_ = env.step(ctl.predict(obs)[0])
    state = env.unwrapped.get_state()
    acts = [np.array([0.1, 0.5, -0.3], np.float32)] * 5
    first = [env.step(a)[:2] for a in acts]
    env.unwrapped.set_state(state)
    second = [env.step(a)[:2] for a in acts]
    for (o1, r1), (o2, r2) in zip(first, second, strict=True):
        np.testing.assert_array_equal(o1, o2)
        assert r1 == r2


@pytest.mark.parametrize("family", ["floor", "free", "buoyant"])
def test_compiled_prefix_alignment_is_shape_metric_align(family):
    from bathprint.envs._kernels_shape import MOTIONS, aligned_squared_distances
    from bathprint.envs.shape_metric import align

    rng = np.random.default_rng(1)
    t = np.cumsum(rng.normal(size=(50, 3)), axis=0)
    c, s = np.cos(0.7), np.sin(0.7)
    w = t @ np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]).T + [3.0, -2.0, 0.5]
    w += rng.normal(scale=0.1, size=w.shape)
    d2 = np.empty(len(t))
    aligned_squared_distances(w, t, MOTIONS[family], d2)
    want = np.sum((align(w, t, family) - t) ** 2, axis=1)
    np.testing.assert_allclose(d2, want, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("family", list(IDS))
def test_reference_curve_is_the_compared_curve_and_a_copy(family):
    """``reference_curve`` refuses before reset, then is the target's form the written curve
    is scored against (buoyant: heights from the density band), a copy the caller may edit."""
    from bathprint.envs.shape_files import target_reference

    env = make(IDS[family], target_set="test")
    u = env.unwrapped
    with pytest.raises(RuntimeError, match="reset"):
        _ = u.reference_curve
    env.reset(seed=0, options={"target_index": 0})
    ref = u.reference_curve
    assert ref.shape == (u.target.n_samples, 3)
    assert np.array_equal(ref, target_reference(u, u.target, family))
    ref[:] = 0.0
    assert not np.array_equal(u.reference_curve, ref)


def test_target_files_on_a_shape_environment(tmp_path):
    """evaluate --target-files on a shape environment: the environment places the shape, the
    error is its whole-shape error and the metric column the local metric."""
    from bathprint.agents.evaluate import evaluate_target_files
    from bathprint.envs.shapes import shape_path

    f = shape_path("floor", "test", "letter_C")
    rows = evaluate_target_files(
        ["controller"], IDS["floor"], [f], out=tmp_path, accuracy="draft", progress=False
    )
    env = make(IDS["floor"])
    pts = np.loadtxt(f, delimiter=",", skiprows=1)
    ret, info, _ = play(
        env, make_controller(env), seed=0, options={"target": env.unwrapped.shape_target(pts, "C")}
    )
    (row,) = rows
    assert row["rms_mm"] == pytest.approx(info["rms_mm"], rel=1e-6)
    assert row["metric"] == pytest.approx(info["local_metric"], rel=1e-9)
    assert row["success"] == info["is_success"] == row["metric_success"]
    assert (tmp_path / "targets.csv").is_file()

"""The Gymnasium environments: spaces, checkers, determinism, targets, reward, robustness."""

from __future__ import annotations

import functools
import json
import warnings
from pathlib import Path

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import bathprint
import bathprint.envs as E
from bathprint import SimulationError
from bathprint.envs.metric import MetricParams, PrintedSamples, evaluate, windowed_kabsch_rmsd
from bathprint.envs.observation import OBS_SIZE
from bathprint.envs.targets import CoilScheduleFamily, TargetSampler, params_key

DRAFT = {"accuracy": "draft"}


def make(env_id: str, **kwargs):
    return E.make(env_id, **{**DRAFT, **kwargs})


def rollout(env, actions) -> tuple[list, list, list]:
    """Step through ``actions`` (resetting at episode ends); observations, rewards, infos."""
    obs_l, rew_l, info_l = [], [], []
    for a in actions:
        obs, rew, term, trunc, info = env.step(a)
        obs_l.append(obs)
        rew_l.append(rew)
        info_l.append(info)
        if term or trunc:
            env.reset()
    return obs_l, rew_l, info_l


# ------------------------------------------------------------------ registration, spaces
def test_register_envs_is_idempotent_and_makes_every_id() -> None:
    assert E.register_envs() == list(E.ENV_IDS)
    assert E.register_envs() == list(E.ENV_IDS)
    for env_id in E.ENV_IDS:
        assert env_id in gymnasium.registry
        assert env_id.startswith("bathprint/")
    assert E.resolve_id("coilradius") == "bathprint/CoilRadius-v2"  # a bare name: the newest
    assert E.resolve_id("writeshape") == "bathprint/WriteShape-v3"
    assert E.resolve_id("CoilRadius-v0") == "bathprint/CoilRadius-v0"
    with pytest.raises(ValueError, match="unknown environment"):
        E.resolve_id("Nope")


@pytest.mark.parametrize(
    ("env_id", "n_actions"),
    [
        ("bathprint/CoilRadius-v0", 2),
        ("bathprint/WriteShape-v0", 3),
        ("bathprint/BuoyantLayers-v0", 2),
    ],
)
def test_spaces(env_id: str, n_actions: int) -> None:
    env = gymnasium.make(env_id, **DRAFT)
    assert env.action_space == gymnasium.spaces.Box(-1, 1, (n_actions,), np.float32)
    assert env.observation_space.shape == (OBS_SIZE,)
    assert env.observation_space.dtype == np.float32
    assert env.metadata["render_fps"] > 0
    assert set(env.metadata["render_modes"]) == {"human", "rgb_array"}
    obs, info = env.reset(seed=0)
    assert obs in env.observation_space and info["metric"] > 0
    for nv, extra in ((True, 3), ("xyz", 3), ("xy", 2)):
        assert gymnasium.make(env_id, needle_velocity=nv, **DRAFT).action_space.shape == (
            n_actions + extra,
        )


@pytest.mark.parametrize("env_id", E.ENV_IDS)
def test_gymnasium_and_sb3_checkers_pass(env_id: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any checker warning fails the test
        # but the notes that an older version has a newer one are the versioning convention
        warnings.filterwarnings("ignore", ".*is out of date", DeprecationWarning)
        warnings.filterwarnings("ignore", ".*is deprecated: ", DeprecationWarning)
        gym_check_env(gymnasium.make(env_id, **DRAFT).unwrapped)  # renders both modes too
        gym_check_env(gymnasium.make(env_id, needle_velocity=True, **DRAFT).unwrapped)
        sb3_check_env(gymnasium.make(env_id, **DRAFT).unwrapped, warn=True)


def test_render_rgb_array_overlays_filament_and_target() -> None:
    env = make("bathprint/WriteShape-v0", render_mode="rgb_array")
    env.reset(seed=3)
    for _ in range(30):
        env.step(env.action_space.sample())
    frame = env.render()
    assert frame.dtype == np.uint8 and frame.ndim == 3 and frame.shape[2] == 3
    assert frame.std() > 10  # not blank
    env.close()


# ------------------------------------------------------------------ determinism
def test_same_seed_same_episode() -> None:
    rng = np.random.default_rng(5)
    actions = rng.uniform(-1, 1, (85, 2)).astype(np.float32)
    runs = []
    for _ in range(2):
        env = make("bathprint/CoilRadius-v0")
        obs0, info0 = env.reset(seed=11)
        runs.append(([obs0], [info0["target_key"]], *rollout(env, actions)))
    (o0, k0, ob_a, rw_a, in_a), (o1, k1, ob_b, rw_b, in_b) = runs
    assert k0 == k1
    np.testing.assert_array_equal(o0[0], o1[0])
    np.testing.assert_array_equal(np.array(ob_a), np.array(ob_b))
    assert rw_a == rw_b
    assert [i["metric"] for i in in_a] == [i["metric"] for i in in_b]
    # another seed: another episode (target or start state)
    env = make("bathprint/CoilRadius-v0")
    keys = {env.reset(seed=s)[1]["target_key"] for s in range(5)}
    assert len(keys) > 1


# ------------------------------------------------------------------ targets
def test_eval_set_is_fixed_and_never_drawn_in_training() -> None:
    a = make("bathprint/CoilRadius-v0").unwrapped
    b = make("bathprint/CoilRadius-v0").unwrapped
    assert a.sampler.eval_params == b.sampler.eval_params
    assert len(a.sampler.eval_keys) == a.sampler.eval_size == 16
    rng = np.random.default_rng(0)
    drawn = {params_key(a.sampler.train_params(rng)) for _ in range(3000)}
    assert not drawn & a.sampler.eval_keys
    # training resets never give an evaluation target; eval resets give them by index
    keys = {a.reset(seed=s)[1]["target_key"] for s in range(20)}
    assert not keys & a.sampler.eval_keys
    ev = make("bathprint/CoilRadius-v0", target_set="eval")
    for k in (0, 5, 15):
        _, info = ev.reset(seed=123, options={"target_index": k})
        assert info["target_key"] == params_key(a.sampler.eval_params[k])
        assert info["target_index"] == k
    # without an index, eval episodes cycle through the set from the last seeded reset
    cyc = [ev.reset(seed=0)[1]["target_index"]] + [ev.reset()[1]["target_index"] for _ in range(2)]
    assert cyc == [0, 1, 2]
    with pytest.raises(ValueError, match="target_set='eval'"):
        a.reset(options={"target_index": 1})


def test_exclusion_bites_on_a_tiny_family() -> None:
    """Two possible targets, one held out: raw draws hit it, training draws never do."""
    fam = CoilScheduleFamily({"sections": [1, 1], "radius_mm": [3.0, 4.0]}, 20.0, 0.5)
    sampler = TargetSampler(fam, eval_size=1, eval_seed=0)
    rng = np.random.default_rng(1)
    raw = [params_key(fam.sample_params(rng)) for _ in range(200)]
    assert sum(k in sampler.eval_keys for k in raw) > 50
    train = {params_key(sampler.train_params(rng)) for _ in range(200)}
    assert len(train) == 1 and not train & sampler.eval_keys
    with pytest.raises(RuntimeError, match="no targets outside"):
        TargetSampler(fam, eval_size=2, eval_seed=0).train_params(rng)


def test_target_file(tmp_path) -> None:
    s = np.linspace(0, 30, 301)
    pts = np.stack([3 * np.cos(s / 3), 3 * np.sin(s / 3), -0.1 * s], axis=1)
    path = tmp_path / "helix.csv"
    lines = ["x_mm,y_mm,z_mm"] + [f"{x},{y},{z}" for x, y, z in pts]
    path.write_text("\n".join(lines))
    env = make("bathprint/CoilRadius-v0", target_file=str(path))
    _, info = env.reset(seed=0)
    tgt = env.unwrapped.target
    assert tgt.name == "file:helix.csv"
    assert abs(tgt.length_mm - 30.0) < 0.6
    assert np.median(tgt.curvature_1_mm) == pytest.approx(1 / 3, rel=0.03)
    np.save(tmp_path / "line.npy", np.stack([np.zeros(50), np.zeros(50), -np.arange(50.0)], 1))
    env = make("bathprint/CoilRadius-v0", target_file=str(tmp_path / "line.npy"))
    env.reset(seed=0)
    assert np.allclose(env.unwrapped.target.curvature_1_mm, 0, atol=1e-9)


# ------------------------------------------------------------------ metric and reward
def test_metric_is_zero_for_the_target_itself_and_mirror_handling() -> None:
    fam = CoilScheduleFamily({"sections": [2, 2], "radius_mm": [2.5, 4.0]}, 40.0, 0.5)
    target = fam.build(
        {"family": "coil_schedule", "length_mm": 40.0, "sections": [[2.5, 1.0], [4.0, 1.0]]}
    )
    theta = 0.7
    rot = np.array(
        [[np.cos(theta), -np.sin(theta), 0], [np.sin(theta), np.cos(theta), 0], [0, 0, 1]]
    )
    moved = target.points_mm @ rot.T + [5.0, -2.0, 1.0]
    dens = np.full(target.n_samples, 1054.0)
    params = MetricParams(w_curvature=0.5)
    m = evaluate(target, PrintedSamples(moved, dens), params)
    assert m.value < 1e-6 and m.scored_fraction == 1.0
    mirror = moved * [1, 1, -1]
    assert evaluate(target, PrintedSamples(mirror, dens), params).value < 1e-6
    strict = MetricParams(allow_reflection=False)
    assert evaluate(target, PrintedSamples(mirror, dens), strict).shape_rms_mm > 0.1
    # nothing printed: the missing error; half printed: in between; others: worse
    assert evaluate(target, PrintedSamples(moved[:0], dens[:0]), params).value == 2.0
    other = fam.build({"family": "coil_schedule", "length_mm": 40.0, "sections": [[4.0, 1.0]] * 2})
    assert evaluate(other, PrintedSamples(moved, dens), params).value > 0.05
    # the batched windowed Kabsch against a direct SVD solution
    rng = np.random.default_rng(0)
    p, q = rng.normal(size=(30, 3)), rng.normal(size=(30, 3))
    pc, qc = p[6:15] - p[6:15].mean(0), q[6:15] - q[6:15].mean(0)
    u, _, vt = np.linalg.svd(pc.T @ qc)
    d = np.sign(np.linalg.det(vt.T @ u.T))
    r = vt.T @ np.diag([1, 1, d]) @ u.T
    direct = np.sqrt(np.mean(np.sum((pc @ r.T - qc) ** 2, axis=1)))
    assert windowed_kabsch_rmsd(p, q, 4, False)[10] == pytest.approx(direct, rel=1e-9)


@pytest.mark.parametrize("env_id", [i for i in E.ENV_IDS if i.endswith("-v0")])
def test_reward_equals_the_metrics_change(env_id: str) -> None:
    # version 0's reward (version 1's: tests/test_envs_v1.py)
    env = make(env_id)
    _, info = env.reset(seed=2)
    m0 = info["metric"]
    assert m0 == env.unwrapped.metric_params.missing_error
    rng = np.random.default_rng(2)
    prev, total, done, steps = m0, 0.0, False, 0
    while not done:
        _, reward, term, trunc, info = env.step(rng.uniform(-1, 1, env.action_space.shape))
        assert reward == pytest.approx(prev - info["metric"], abs=1e-12)
        prev = info["metric"]
        total += reward
        steps += 1
        done = term or trunc
    assert term and not trunc
    assert steps == env.unwrapped.episode_steps
    assert info["scored_fraction"] == 1.0
    assert total == pytest.approx(m0 - info["metric"], abs=1e-9)


# ------------------------------------------------------------------ actions
def test_actions_are_mapped_clipped_and_nan_rejected() -> None:
    env = make("bathprint/CoilRadius-v0").unwrapped
    lo = env.action_to_controls(np.array([-1.0, -1.0]))
    hi = env.action_to_controls(np.array([1.0, 1.0]))
    assert (lo["q_outer_ml_min"], lo["q_inner_ml_min"]) == (0.25, 0.0)
    assert (hi["q_outer_ml_min"], hi["q_inner_ml_min"]) == (2.0, 0.2)
    big = env.action_to_controls(np.array([7.0, -3.0]))
    assert (big["q_outer_ml_min"], big["q_inner_ml_min"]) == (2.0, 0.0)
    a, b = make("bathprint/CoilRadius-v0"), make("bathprint/CoilRadius-v0")
    a.reset(seed=4)
    b.reset(seed=4)
    oa = a.step(np.array([5.0, 9.0], np.float32))[0]
    ob = b.step(np.array([1.0, 1.0], np.float32))[0]
    np.testing.assert_array_equal(oa, ob)
    for bad in (np.array([np.nan, 0.0]), np.array([0.0, np.inf])):
        with pytest.raises(ValueError, match="NaN"):
            a.step(bad)
    with pytest.raises(ValueError, match="shape"):
        a.step(np.zeros(3))
    # the inner fraction never exceeds what the needle allows
    ws = make("bathprint/WriteShape-v0", scene_overrides={"inclusions.max_inner_fraction": 0.2})
    c = ws.unwrapped.action_to_controls(np.array([-1.0, 1.0, 0.0]))
    assert c["q_inner_ml_min"] / (c["q_inner_ml_min"] + c["q_outer_ml_min"]) <= 0.2
    with pytest.raises(ValueError, match="accuracy"):
        E.make("bathprint/CoilRadius-v0", accuracy="sloppy")


@pytest.mark.parametrize("accuracy", ["draft", "balanced", "fine"])
def test_accuracy_presets_set_the_numerics(accuracy: str) -> None:
    env = E.make("bathprint/CoilRadius-v0", accuracy=accuracy).unwrapped
    preset = E.accuracy.ACCURACY_PRESETS[accuracy]
    assert all(env.scene_overrides[k] == v for k, v in preset.items())
    probe = bathprint.Simulation(env.scene_base, env.scene_overrides)
    assert probe.model.node_spacing == pytest.approx(preset["numerics.node_spacing_mm"] * 1e-3)


def test_needle_velocity_moves_the_needle_within_its_box() -> None:
    env = make("bathprint/WriteShape-v0", needle_velocity="xyz")
    env.reset(seed=0)
    u = env.unwrapped
    for _ in range(40):
        # slowest flow (a step lasts 32 ms), needle at full speed along +x and +z
        _, _, _, _, info = env.step(np.array([-1, -1, 0, 1, 0, 1], np.float32))
    pos = info["needle_mm"]
    assert pos[0] == u.needle_box_mm[0, 1] and pos[2] == u.needle_box_mm[2, 1]  # held at the box
    assert pos[1] == u.needle_start_mm[1]
    tip = u.sim.centerline()[-1] / 1e-3
    np.testing.assert_allclose(tip, pos, atol=1e-6)


# ------------------------------------------------------------------ robustness
def test_divergence_truncates_with_the_cause_and_finite_observation(monkeypatch) -> None:
    env = make("bathprint/CoilRadius-v0")
    obs, _ = env.reset(seed=0)
    obs, *_ = env.step(env.action_space.sample())
    sim = env.unwrapped.sim

    def boom(t_end: float, max_steps: int = 0) -> None:
        raise SimulationError("segment stretch beyond the allowed bound", sim.t, 7, "test")

    monkeypatch.setattr(sim, "advance", boom)
    obs2, reward, term, trunc, info = env.step(env.action_space.sample())
    assert trunc and not term and reward == 0.0
    assert "segment stretch" in info["sim_error"] and info["sim_error_cause"]
    assert np.isfinite(obs2).all() and obs2 in env.observation_space
    np.testing.assert_array_equal(obs, obs2)
    assert env.step(env.action_space.sample())[3]  # still truncated
    obs3, _ = env.reset(seed=1)  # a fresh simulation
    assert np.isfinite(obs3).all() and env.step(env.action_space.sample())[3] is False


def test_a_stalled_simulation_is_truncated_too() -> None:
    """Integrator steps far below the control interval use up the per-step budget."""
    env = make("bathprint/CoilRadius-v0", spec_overrides={"episode": {"max_substeps": 5}})
    env.reset(seed=0)
    env.unwrapped.sim.model.p.max_step = 1e-6  # as if the step size collapsed
    _, _, term, trunc, info = env.step(env.action_space.sample())
    assert trunc and not term and "step budget" in info["sim_error"]


@pytest.mark.parametrize("env_id", E.ENV_IDS)
def test_random_extreme_and_alternating_actions_stay_finite(env_id: str) -> None:
    needle = {"bathprint/WriteShape-v0": "xyz", "bathprint/CoilRadius-v0": "xy"}.get(env_id, False)
    env = make(env_id, needle_velocity=needle)
    env.reset(seed=9)
    rng = np.random.default_rng(9)
    n = env.action_space.shape[0]
    actions = np.concatenate(
        [
            rng.uniform(-1, 1, (200, n)),
            rng.choice([-1.0, 1.0], (200, n)),
            np.where(np.arange(200)[:, None] % 2 == 0, 1.0, -1.0) * np.ones((200, n)),
            rng.uniform(-3, 3, (40, n)),  # out of range: clipped
        ]
    ).astype(np.float32)
    obs_l, rew_l, info_l = rollout(env, actions)
    assert all(o in env.observation_space and np.isfinite(o).all() for o in obs_l)
    assert np.isfinite(rew_l).all()
    assert all(np.isfinite(i["metric"]) for i in info_l)


# ------------------------------------------------------------------ vector envs, configs
@pytest.mark.parametrize("mode", ["sync", "async"])
def test_make_vec(mode: str) -> None:
    venv = gymnasium.make_vec(
        "bathprint/BuoyantLayers-v0", num_envs=2, vectorization_mode=mode, **DRAFT
    )
    obs, _ = venv.reset(seed=0)
    assert obs.shape == (2, OBS_SIZE)
    for _ in range(5):
        obs, rew, term, trunc, info = venv.step(venv.action_space.sample())
    assert np.isfinite(obs).all() and rew.shape == (2,) and "metric" in info
    venv.close()


def test_sb3_subproc_vec_env() -> None:
    from stable_baselines3.common.vec_env import SubprocVecEnv

    fns = [functools.partial(E.make, "bathprint/CoilRadius-v0", **DRAFT) for _ in range(2)]
    venv = SubprocVecEnv(fns)  # default start method (forkserver): factories by reference
    venv.seed(0)
    obs = venv.reset()
    for _ in range(5):
        obs, rew, done, infos = venv.step(np.stack([venv.action_space.sample()] * 2))
    assert obs.shape == (2, OBS_SIZE) and np.isfinite(obs).all()
    venv.close()


def test_make_from_config() -> None:
    cfg = {
        "id": "bathprint/WriteShape-v0",
        "kwargs": {"accuracy": "draft", "needle_velocity": "xy"},
    }
    env = E.make_from_config(json.loads(json.dumps(cfg)))  # survives a JSON round trip
    assert env.action_space.shape == (5,)
    assert env.unwrapped.accuracy == "draft"
    assert env.reset(seed=0)[0].shape == (OBS_SIZE,)
    with pytest.raises(ValueError, match="'id'"):
        E.make_from_config({"kwargs": {}})
    with pytest.raises(ValueError, match="unknown keys"):
        E.make_from_config({"id": "bathprint/WriteShape-v0", "kw": {}})


# ------------------------------------------------------------------ play
def test_play_writes_an_animation_and_the_metric(tmp_path) -> None:
    out = tmp_path / "play"
    argv = ["BuoyantLayers-v0", "--policy", "constant", "--seed", "1", "--out", str(out)]
    assert E.play_main([*argv, "--frame-every", "30"]) == 0
    summary = json.loads((out / "metrics.json").read_text())
    (ep,) = summary["episodes"]
    assert ep["terminated"] and ep["steps"] == 63 and ep["target_index"] == 0
    assert ep["return"] == pytest.approx(4.0 - ep["metric"], abs=1e-9)
    assert (out / "episode_0.gif").stat().st_size > 10_000
    assert E.play_main(["Nope", "--out", str(out)]) == 2


def test_specs_are_found_in_a_checkout_an_install_or_the_variable(
    tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Checkout first; a regular install's copy in <prefix>/share/bathprint/ otherwise
    (pyproject's data-files); $BATHPRINT_ENVS_DIR / $BATHPRINT_AGENTS_DIR over both."""
    import sysconfig

    import bathprint._resources as R
    from bathprint.agents.hyperparams import agents_dir
    from bathprint.envs.spec import specs_dir

    monkeypatch.delenv("BATHPRINT_ENVS_DIR", raising=False)
    monkeypatch.delenv("BATHPRINT_AGENTS_DIR", raising=False)
    assert (specs_dir() / "coil_radius.toml").is_file()
    assert (agents_dir() / "ppo.yml").is_file()
    monkeypatch.setattr(R, "_CHECKOUT", tmp_path)  # as if installed: no checkout around
    installed = Path(sysconfig.get_path("data")) / "share" / "bathprint"
    assert specs_dir() == installed / "envs"
    assert agents_dir() == installed / "agents"
    monkeypatch.setenv("BATHPRINT_ENVS_DIR", str(tmp_path / "mine"))
    assert specs_dir() == tmp_path / "mine"

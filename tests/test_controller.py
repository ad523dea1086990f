"""The shape references: the tuned ``controller`` per family and the ``cem`` planner."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint.agents import controller as C
from bathprint.agents.planning import ShapeCEMPolicy, ShapeCEMSettings
from bathprint.agents.policies import ConstantPolicy, load_policy
from bathprint.envs import make
from bathprint.envs.shape_geometry import length_mm, place_in_box
from bathprint.errors import ConfigError


@pytest.fixture(scope="module")
def envs():
    out = {fam: make(env_id, accuracy="draft") for fam, env_id in C.FAMILY_ENVS.items()}
    yield out
    for e in out.values():
        e.close()


def test_place_in_box_keeps_a_long_line_inside_and_unchanged():
    line = np.zeros((181, 3))
    line[:, 0] = np.linspace(0.0, 45.0, 181)  # from the needle toward the box's edge
    box = np.array([[-40.0, 40.0], [-40.0, 40.0]])
    path = place_in_box(line, (0.0, 0.0), box)
    assert np.allclose(path[0], 0.0)
    assert length_mm(np.c_[path, np.zeros(len(path))]) == pytest.approx(45.0, rel=1e-9)
    assert (path >= box[:, 0]).all() and (path <= box[:, 1]).all()
    # 45 mm does not fit along +x from the centre; any turn that keeps it inside is taken
    assert path[-1, 0] < 40.0


def test_gains_default_when_not_tuned(tmp_path):
    assert C.load_gains("floor", tmp_path / "none.yml") == C.FloorGains()
    with pytest.raises(ConfigError, match="family = 'wall'"):
        C.load_gains("wall")


@pytest.mark.parametrize("family", list(C.FAMILY_ENVS))
def test_controller_beats_the_best_constant_action_on_validation(envs, family):
    """The issue's check: on every family's validation shapes the tuned controller's mean
    whole-shape RMS error is below the best constant action's (agents/baselines.yml)."""
    from bathprint.agents.hyperparams import load_baselines

    env = envs[family]
    shapes = C.family_shapes(family, "validation", writable_only=True)
    ctl = C.score_shapes(
        env, load_policy("controller", env, C.FAMILY_ENVS[family])[0], family, shapes
    )
    const = ConstantPolicy(load_baselines(C.FAMILY_ENVS[family])["constant_action"])
    ref = C.score_shapes(env, const, family, shapes)
    m_ctl = np.mean([r["rms_mm"] for r in ctl])
    m_const = np.mean([r["rms_mm"] for r in ref])
    assert math.isfinite(m_ctl)
    assert m_ctl < m_const, (family, m_ctl, m_const)


def test_floor_controller_writes_its_validation_letters(envs):
    """Needle tracking writes every floor validation shape within the family's success
    threshold (RMS 1.5 mm, max 4 mm)."""
    shapes = C.family_shapes("floor", "validation", writable_only=True)
    rows = C.score_shapes(envs["floor"], C.make_controller(envs["floor"]), "floor", shapes)
    assert all(r["success"] for r in rows), rows


def test_controller_refuses_an_environment_it_cannot_drive(envs):
    with pytest.raises(ConfigError, match="needle"):
        C.FloorController(envs["free"])
    with pytest.raises(ConfigError, match="q_inner"):
        C.BuoyantController(envs["floor"])


def test_cem_is_never_worse_than_its_start_and_deterministic(envs):
    env = envs["floor"]
    shapes = C.family_shapes("floor", "validation", writable_only=True)[:1]
    ctl = C.score_shapes(env, C.make_controller(env), "floor", shapes)[0]
    settings = ShapeCEMSettings(samples=4, iterations=1, elites=2)
    runs = []
    for _ in range(2):
        pol = ShapeCEMPolicy(env, C.FAMILY_ENVS["floor"], settings)
        runs.append(C.score_shapes(env, pol, "floor", shapes)[0])
        assert pol.last_start.endswith("controller")
    assert runs[0]["rms_mm"] <= ctl["rms_mm"] + 1e-9
    assert runs[0]["rms_mm"] == pytest.approx(runs[1]["rms_mm"], rel=1e-12)


def test_tune_writes_the_chosen_gains(tmp_path):
    path = tmp_path / "controller.yml"
    entry = C.tune(
        "buoyant",
        grid={"lead_mm": (0.0, 2.0), "gain": (1.0,), "q_outer_ml_min": (0.3,)},
        path=path,
        progress=False,
    )
    assert len(entry["grid"]) == 2
    best = min(entry["grid"], key=lambda r: r["mean_rms_mm"])
    assert entry["gains"]["lead_mm"] == best["lead_mm"]
    assert C.load_gains("buoyant", path) == C.BuoyantGains(**entry["gains"])


def test_mpc_searches_around_the_controller_in_the_shape_environments(envs):
    from bathprint.agents.planning import MPCPolicy, MPCSettings, parse_options

    env = envs["floor"]
    assert MPCPolicy(env, C.FAMILY_ENVS["floor"]).controller is not None
    off = MPCPolicy(env, C.FAMILY_ENVS["floor"], MPCSettings(warm_controller=0))
    assert off.controller is None
    with pytest.raises(ConfigError, match="warm_controller = 2"):
        parse_options("mpc:warm_controller=2", MPCSettings)

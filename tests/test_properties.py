"""Bad input as a test suite (hypothesis): random scene overrides, environment kwargs and
actions. Each draw either works (a short run or an episode step with finite numbers) or is
refused by the project's own error that names what was wrong; never a bare Python
exception, never a NaN passed on."""

from __future__ import annotations

import dataclasses
import math
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, event, given, settings
from hypothesis import strategies as st

from bathprint.core import scene as S
from bathprint.core.layout import EFFECT_NAMES
from bathprint.errors import SceneError, SimulationError
from bathprint.run import simulate

BASE = "paper_simulation"
# a very short run: every example that loads is also simulated
SHORT = {"duration_s": 0.004, "outputs.plot": False, "outputs.frame_interval_s": 0.002}
# valid values of these keys are drawn from a cheap part of their range (a long duration,
# a metre of initial filament or a step bound of 1 ns is valid, but not a test of bad input);
# the default value is always among the valid draws
CHEAP = {
    "duration_s": (1e-4, 0.01),
    "outputs.frame_interval_s": (1e-3, 1.0),
    "initial.length_mm": (0.0, 5.0),
    "initial.age_s": (0.0, 10.0),
    "numerics.max_step_s": (1e-4, 100.0),
    "numerics.time_step_s": (1e-4, 10.0),
    "numerics.tolerance": (1e-6, 1.0),
    "numerics.max_inlet_growth": (1e-2, 100.0),
    "numerics.max_strain_change": (1e-3, 10.0),
    "numerics.max_strain": (1e-2, 10.0),
}


def _leaf_fields(cls: type, prefix: str = "") -> dict[str, dataclasses.Field]:
    out: dict[str, dataclasses.Field] = {}
    for f in dataclasses.fields(cls):
        factory = f.default_factory
        if isinstance(factory, type) and dataclasses.is_dataclass(factory):
            out.update(_leaf_fields(factory, f"{prefix}{f.name}."))
        else:
            out[f"{prefix}{f.name}"] = f
    return out


FIELDS = _leaf_fields(S.Scene)

NASTY = st.sampled_from([math.nan, math.inf, -math.inf, None, True, "", "abc", [], {}, [1, 2]])


def _numbers(key: str, f: dataclasses.Field) -> tuple[st.SearchStrategy, st.SearchStrategy]:
    """(inside the allowed range, in its cheap part (see CHEAP); outside it)."""
    lo, hi = f.metadata["range"]
    lo_open = bool(f.metadata.get("lo_open"))
    c_lo, c_hi = CHEAP.get(key, (lo, hi))
    inside = st.floats(c_lo, c_hi, exclude_min=lo_open and c_lo == lo)
    if isinstance(f.default, int | float) and c_lo <= f.default <= c_hi:
        inside = st.one_of(st.just(f.default), inside)
    if f.metadata.get("auto"):  # the word the model resolves (contact.damping_time_s)
        inside = st.one_of(st.just("auto"), inside)
    span = max(abs(lo), abs(hi), 1.0)
    outside = st.one_of(
        st.floats(max_value=lo, exclude_max=not lo_open, allow_nan=False, allow_infinity=False),
        st.floats(min_value=hi, exclude_min=True, allow_nan=False, allow_infinity=False),
        st.sampled_from([-10 * span, 10 * span, lo - 1e-9 * span, hi + 1e-9 * span]),
    )
    return inside, outside


def _valid_and_invalid(key: str) -> tuple[st.SearchStrategy, st.SearchStrategy]:
    """Strategies of values of ``key`` that load, and of values that may not (most do not)."""
    f = FIELDS[key]
    md = f.metadata
    if "effects" in md:
        names = st.lists(st.sampled_from(EFFECT_NAMES), max_size=4, unique=True)
        valid = names.map(lambda e: ["drag", *[x for x in e if x != "drag"]])
        invalid = st.one_of(
            names,  # may lack drag (and inertia)
            st.sampled_from(EFFECT_NAMES),  # a string: --set effects=drag
            st.lists(st.one_of(st.integers(), st.none(), st.text(max_size=3)), max_size=3),
            NASTY,
        )
        return valid, invalid
    if "rows" in md:
        n = md["rows"]
        row = st.lists(st.floats(-2, 2, allow_nan=False), min_size=n, max_size=n)
        rising = st.lists(row, min_size=1, max_size=3).map(
            lambda rows: [[0.01 * k, *[abs(x) + 0.1 for x in r[1:]]] for k, r in enumerate(rows)]
        )
        anything = st.one_of(st.floats(), st.text(max_size=2), st.none(), st.booleans())
        invalid = st.one_of(
            st.lists(row, max_size=3),
            st.lists(st.lists(anything, max_size=8), max_size=3),
            row,  # one row instead of a list of rows
            NASTY,
            st.floats(),
        )
        return rising, invalid
    if "choices" in md:
        return st.sampled_from(md["choices"]), st.one_of(st.text(max_size=5), NASTY)
    if "range" in md:
        inside, outside = _numbers(key, f)
        if "vector" in md:
            valid = st.lists(inside, min_size=3, max_size=3)
            invalid = st.one_of(
                st.lists(st.one_of(inside, outside), min_size=3, max_size=3),
                st.lists(inside, max_size=5),
                NASTY,
                st.floats(),
            )
            return valid, invalid
        if f.type == "int":
            lo, hi = md["range"]
            return st.integers(int(lo), int(hi)), st.one_of(st.integers(), st.floats(), NASTY)
        return inside, st.one_of(outside, NASTY, st.text(max_size=4))
    if isinstance(f.default, bool):
        return st.booleans(), st.one_of(st.integers(0, 1), NASTY)
    return st.text(max_size=8), st.one_of(st.floats(), NASTY)  # strings: name, paths


def _value(key: str) -> st.SearchStrategy[Any]:
    valid, invalid = _valid_and_invalid(key)
    return st.one_of(valid, valid, invalid)


@st.composite
def overrides(draw: st.DrawFn) -> dict[str, Any]:
    keys = draw(st.lists(st.sampled_from(sorted(FIELDS)), min_size=1, max_size=3, unique=True))
    return {k: draw(_value(k)) for k in keys}


def _finite_result(result: Any) -> None:
    assert np.isfinite(result.final).all()
    assert np.isfinite(result.material).all()
    s = result.summary
    for key in ("time_s", "final_length_m", "printed_length_m"):
        assert math.isfinite(s[key]), (key, s[key])
    assert math.isfinite(s["mass_balance"]["relative_error"])


@settings(
    max_examples=300,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow],
    derandomize=True,
    database=None,
)
@given(overrides())
def test_random_scene_overrides_run_or_name_the_key(over: dict[str, Any]) -> None:
    full = {**SHORT, **over}
    try:
        result = simulate(BASE, full, progress=False)
    except SceneError as exc:
        message = str(exc)
        assert any(k in message for k in over), (over, message)
        event("refused")
        return
    except SimulationError:  # a valid scene that diverged: reported, with time and node
        event("diverged")
        return
    event("ran")
    _finite_result(result)


# --------------------------------------------------------------------------- environments

ENV = "bathprint/CoilRadius-v0"
ENV_IDS = ("bathprint/CoilRadius-v0", "bathprint/WriteShape-v0", "bathprint/BuoyantLayers-v0")
_TMP = Path(tempfile.mkdtemp(prefix="bathprint-properties-"))


def _target_csv() -> str:
    """A valid target file: 70 mm of helix (radius 3 mm, pitch 1 mm)."""
    path = _TMP / "helix.csv"
    if not path.exists():
        t = np.linspace(0.0, 70.0 / (2 * np.pi * 3.0) * 2 * np.pi, 400)
        rows = ["x_mm,y_mm,z_mm"] + [
            f"{3 * math.cos(a):.6f},{3 * math.sin(a):.6f},{-10 - a / (2 * math.pi):.6f}" for a in t
        ]
        path.write_text("\n".join(rows) + "\n")
    return str(path)


def _make(kwargs: dict[str, Any], env_id: str = ENV) -> Any:
    """Through the project's factory (gymnasium.make itself fails on a non-string
    render_mode with an AttributeError before any environment code runs)."""
    from bathprint.envs import make

    return make(env_id, **{"accuracy": "draft", **kwargs})


def _names(exc: BaseException, kwarg: str, inner: dict | None = None) -> bool:
    """The message names the kwarg (or, for a dict kwarg, one of its keys)."""
    message = str(exc)
    return kwarg in message or any(str(k) in message for k in (inner or {}))


def _is_project_refusal(exc: BaseException) -> bool:
    return isinstance(exc, ValueError) and type(exc).__module__.startswith("bathprint")


def _episode_step(env: Any, action: Any = None) -> None:
    obs, info = env.reset(seed=0)
    assert np.isfinite(obs).all()
    a = env.action_space.sample() if action is None else action
    obs, reward, terminated, truncated, info = env.step(a)
    assert np.isfinite(obs).all() and math.isfinite(reward), (obs, reward)


VALID_KWARGS: dict[str, st.SearchStrategy] = {
    "render_mode": st.sampled_from([None, "rgb_array"]),
    "needle_velocity": st.sampled_from([False, True, "xy", "xyz", None]),
    "target_set": st.sampled_from(["train", "eval"]),
    "target_file": st.builds(_target_csv),
    "scene_overrides": st.sampled_from(
        [{}, {"seed": 1}, {"bath.viscosity_pa_s": 2e-3}, {"needle.imperfection_um": 5.0}]
    ),
    "spec_overrides": st.sampled_from([{}, {"episode": {"settle_length_mm": 10.0}}]),
}


@st.composite
def valid_env_kwargs(draw: st.DrawFn) -> dict[str, Any]:
    keys = draw(st.lists(st.sampled_from(sorted(VALID_KWARGS)), max_size=3, unique=True))
    kwargs = {k: draw(VALID_KWARGS[k]) for k in keys}
    if "target_file" not in kwargs and draw(st.booleans()):  # a file is the only target
        kwargs.update(target_set="eval", target_index=draw(st.integers(0, 15)))
    return kwargs


# scene values the environment passes to the simulator: refused by SceneError naming them
BAD_SCENE_VALUES = st.dictionaries(
    st.sampled_from(
        ["bath.viscosity_pa_s", "material.youngs_modulus_pa", "needle.inner_diameter_mm", "seed"]
    ),
    st.one_of(st.sampled_from([math.nan, math.inf, -1.0, 0.0, 1e30, "x", None, [1.0]])),
    min_size=1,
    max_size=2,
)


@settings(max_examples=25, deadline=None, derandomize=True, database=None)
@given(st.one_of(valid_env_kwargs(), BAD_SCENE_VALUES.map(lambda d: {"scene_overrides": d})))
def test_env_kwargs_make_a_working_env_or_name_the_key(kwargs: dict[str, Any]) -> None:
    try:
        env = _make(kwargs)
    except Exception as exc:
        inner = kwargs.get("scene_overrides")
        assert inner and isinstance(exc, SceneError), (kwargs, repr(exc))
        assert _names(exc, "scene_overrides", inner), (kwargs, str(exc))
        return
    try:
        _episode_step(env)
    finally:
        env.close()


ACTION_VALUES = st.one_of(
    st.floats(-1, 1),
    st.floats(allow_nan=False, allow_infinity=False),
    st.sampled_from([math.nan, math.inf, -math.inf, 1e300, -1e300, 1.0000001]),
)


@settings(max_examples=40, deadline=None, derandomize=True, database=None)
@given(
    st.sampled_from(ENV_IDS),
    st.integers(1, 4).flatmap(lambda n: st.lists(ACTION_VALUES, min_size=n, max_size=n)),
    st.sampled_from([np.float32, np.float64]),
)
def test_env_actions_give_finite_observations_or_a_clear_error(
    env_id: str, values: list[float], dtype: type
) -> None:
    env = _make({}, env_id)
    try:
        env.reset(seed=0)
        with np.errstate(over="ignore"):  # 1e300 as float32 is inf: refused below
            action = np.array(values, dtype=dtype)
        try:
            obs, reward, terminated, truncated, info = env.step(action)
        except ValueError as exc:
            assert "action" in str(exc), str(exc)
            bad_shape = action.shape != env.action_space.shape
            assert bad_shape or not np.isfinite(action).all(), (values, str(exc))
            return
        assert action.shape == env.action_space.shape and np.isfinite(action).all()
        assert np.isfinite(obs).all() and math.isfinite(reward), (obs, reward)
        assert env.observation_space.contains(obs)
    finally:
        env.close()


# --------------------------------------------------------------------------- env kwargs the
# environments refuse with a bathprint error class (a ValueError) that names the kwarg
def _case(kwargs: dict[str, Any], kwarg: str) -> Any:
    return pytest.param(kwargs, kwarg, id=f"{kwarg}={kwargs[kwarg]!r}")


NAN = math.nan
BAD_ENV_KWARGS = [
    _case({"scene_overrides": {"nokey": 1}}, "scene_overrides"),
    _case({"scene_overrides": {"bath.viscosity_pa_s": NAN}}, "scene_overrides"),
    _case({"spec_overrides": {"x": 1}}, "spec_overrides"),
    _case({"spec_overrides": {"control": {"length_mm": -1.0}}}, "spec_overrides"),
    _case({"render_mode": "x"}, "render_mode"),
    _case({"render_mode": 3}, "render_mode"),
    _case({"accuracy": "bogus"}, "accuracy"),
    _case({"accuracy": None}, "accuracy"),
    _case({"needle_velocity": "z"}, "needle_velocity"),
    _case({"target_set": "test"}, "target_set"),
    _case({"target_set": "eval", "target_index": -1}, "target_index"),
    _case({"target_set": "eval", "target_index": 16}, "target_index"),
    _case({"target_set": "eval", "target_index": 2.5}, "target_index"),
    _case({"target_set": "eval", "target_index": "a"}, "target_index"),
    _case({"target_index": 3}, "target_index"),
    _case({"target_file": "missing.csv"}, "target_file"),
    _case({"target_file": 5}, "target_file"),
    _case({"scene_overrides": 5}, "scene_overrides"),
    _case({"scene_overrides": "seed=1"}, "scene_overrides"),
    _case({"spec_overrides": 5}, "spec_overrides"),
    _case({"spec_overrides": {"episode": {"settle_length_mm": NAN}}}, "spec_overrides"),
    _case({"spec_file": "missing.toml"}, "spec_file"),
    _case({"spec_file": 5}, "spec_file"),
]


def _refused_as_asked(kwargs: dict[str, Any], kwarg: str) -> None:
    with pytest.raises(Exception) as info:  # noqa: PT011 (any exception: checked below)
        env = _make(kwargs)
        try:
            _episode_step(env)
        finally:
            env.close()
    exc = info.value
    inner = kwargs[kwarg] if isinstance(kwargs[kwarg], dict) else None
    assert _is_project_refusal(exc), repr(exc)
    assert _names(exc, kwarg, inner), str(exc)


@pytest.mark.parametrize("kwargs, kwarg", BAD_ENV_KWARGS)
def test_env_bad_kwarg_is_refused_by_a_project_error_naming_it(
    kwargs: dict[str, Any], kwarg: str
) -> None:
    _refused_as_asked(kwargs, kwarg)


_ANY = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-5, 50),
    st.floats(),
    st.text(max_size=6),
    st.lists(st.integers(), max_size=2),
    st.dictionaries(st.text(max_size=4), st.integers(), max_size=2),
)
_VALID = {
    "render_mode": [None, "human", "rgb_array"],
    "accuracy": ["draft", "balanced", "fine"],
    "needle_velocity": [False, True, "xy", "xyz", None],
    "target_set": ["train", "eval"],
}


@st.composite
def bad_env_kwargs(draw: st.DrawFn) -> tuple[dict[str, Any], str]:
    kwarg = draw(st.sampled_from([*_VALID, "target_index", "target_file", "spec_file"]))
    if kwarg == "target_index":
        value = draw(st.one_of(st.integers(max_value=-1), st.integers(min_value=16), _ANY))
        value = draw(st.integers(-5, -1)) if isinstance(value, int) and 0 <= value < 16 else value
        return {"target_set": "eval", "target_index": value}, kwarg
    value = draw(_ANY.filter(lambda v: v not in _VALID.get(kwarg, [])))
    if kwarg in ("target_file", "spec_file") and value is None:
        value = "missing.file"
    return {kwarg: value}, kwarg


@settings(
    max_examples=20,
    deadline=None,
    derandomize=True,
    database=None,
    phases=[Phase.explicit, Phase.generate],
)
@given(bad_env_kwargs())
def test_env_random_bad_kwargs_are_refused_by_a_project_error(case: tuple) -> None:
    kwargs, kwarg = case
    _refused_as_asked(kwargs, kwarg)

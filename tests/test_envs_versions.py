"""Gymnasium's versioning: a bare name makes the newest version, making an older version
warns and names the newest, the newest makes silently; each version is its own class
(no registered version inherits another's), on a base no version overrides."""

from __future__ import annotations

import warnings

import gymnasium
import pytest

import bathprint.envs as E
from bathprint.envs.base import BathprintEnvBase
from bathprint.envs.coil_radius import CoilRadiusEnv

NEWEST = {
    "CoilRadius": "bathprint/CoilRadius-v2",
    "WriteShape": "bathprint/WriteShape-v3",
    "BuoyantLayers": "bathprint/BuoyantLayers-v2",
}


def test_bare_name_makes_the_newest_version() -> None:
    for name, newest in NEWEST.items():
        assert E.resolve_id(name) == newest
        assert E.resolve_id(f"bathprint/{name.lower()}") == newest
        for env_id in E.ENV_IDS:
            if env_id.startswith(f"bathprint/{name}-"):
                assert E.newest_id(env_id) == newest
    env = E.make("CoilRadius", accuracy="draft")
    assert env.spec.id == "bathprint/CoilRadius-v2"
    assert type(env.unwrapped).env_id == "bathprint/CoilRadius-v2"
    env.close()
    E.register_envs()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium says it picks the latest version
        env = gymnasium.make("bathprint/WriteShape", accuracy="draft")
    assert env.spec.id == "bathprint/WriteShape-v3"
    env.close()


def test_making_an_older_version_warns_and_names_the_newest() -> None:
    with pytest.warns(DeprecationWarning, match="bathprint/CoilRadius-v2") as record:
        E.make("bathprint/CoilRadius-v0", accuracy="draft").close()
    ours = [w for w in record if "is deprecated" in str(w.message)]
    assert len(ours) == 1
    assert "bathprint/CoilRadius-v0 is deprecated" in str(ours[0].message)
    assert ours[0].filename == __file__  # it points at the line that made the environment
    with pytest.warns(DeprecationWarning, match="bathprint/WriteShape-v3"):
        E.make("WriteShape-v1", accuracy="draft").close()
    with pytest.warns(DeprecationWarning, match="bathprint/CoilRadius-v2"):
        CoilRadiusEnv(accuracy="draft").close()  # the class itself, without the registry


def test_making_the_newest_version_does_not_warn() -> None:
    E.register_envs()
    for newest in NEWEST.values():
        with warnings.catch_warnings():
            warnings.simplefilter("error", DeprecationWarning)
            E.make(newest, accuracy="draft").close()
            gymnasium.make(newest, accuracy="draft").close()


def _entry_class(env_id: str) -> type:
    module, _, name = E.ENV_ENTRY_POINTS[env_id].partition(":")
    return getattr(__import__(module, fromlist=[name]), name)


def test_no_version_inherits_another_and_none_overrides_the_base() -> None:
    classes = {env_id: _entry_class(env_id) for env_id in E.ENV_IDS}
    final = {
        "_warn_if_superseded",
        "_init_scene",
        "_start_state",
        "_snapshot",
        "_interp",
        "episode_steps",
        "render",
        "close",
    }
    for env_id, cls in classes.items():
        assert cls.env_id == env_id
        others = [c for i, c in classes.items() if i != env_id]
        assert not any(issubclass(cls, other) for other in others), env_id
        assert issubclass(cls, BathprintEnvBase)
        for klass in cls.__mro__[: cls.__mro__.index(BathprintEnvBase)]:
            assert not final & set(vars(klass)), (env_id, klass, final & set(vars(klass)))

"""Gymnasium environments for printing filaments in a bath.

>>> import gymnasium, bathprint.envs
>>> bathprint.envs.register_envs()          # idempotent; ``import bathprint`` will call it
>>> env = gymnasium.make("bathprint/CoilRadius-v1", accuracy="draft")
>>> obs, info = env.reset(seed=0)
>>> obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

=============================  ===========================================================
id                             task
=============================  ===========================================================
``bathprint/CoilRadius-v1``    track a coil-radius schedule with the flow (newest)
``bathprint/WriteShape-v2``    WriteShape-v1 with the target's positions near the needle (newest)
``bathprint/BuoyantLayers-v1`` parts that settle at target heights, the oil pump lagging (newest)
``bathprint/WriteShape-v1``    write a 3D curve with the needle and the flow (deprecated)
``bathprint/CoilRadius-v0``    a schedule of coil radius (and pitch) (deprecated)
``bathprint/WriteShape-v0``    a 3D curve: helices, straight pieces, arcs (deprecated)
``bathprint/BuoyantLayers-v0`` parts that settle at target heights (deprecated)
=============================  ===========================================================

Versioning follows Gymnasium's: a registered version never changes its results (a change is
a new version); a bare name (``bathprint/CoilRadius``, or ``CoilRadius`` here) makes the
newest version (:func:`newest_id`); making an older one raises a DeprecationWarning naming
the newest (``docs/envs/``, Version History). Each version is its own class:
:mod:`bathprint.envs.v0` and :mod:`bathprint.envs.v1` (the printed-target protocol of
versions 1 and 2) on :mod:`bathprint.envs.base`, which holds what they share. Specs (scene,
ranges, targets, metric) live in ``envs/*.toml``; the metric is in
:mod:`bathprint.envs.metric`. ``bathprint play`` is :func:`play_main`.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

NAMESPACE = "bathprint"

#: id -> entry point (module:class); max_episode_steps is left to the environments, which
#: terminate by themselves when the target's length has been printed.
ENV_ENTRY_POINTS: dict[str, str] = {
    "bathprint/CoilRadius-v0": "bathprint.envs.coil_radius:CoilRadiusEnv",
    "bathprint/WriteShape-v0": "bathprint.envs.write_shape:WriteShapeEnv",
    "bathprint/BuoyantLayers-v0": "bathprint.envs.buoyant_layers:BuoyantLayersEnv",
    "bathprint/CoilRadius-v1": "bathprint.envs.coil_radius:CoilRadiusEnvV1",
    "bathprint/WriteShape-v1": "bathprint.envs.write_shape:WriteShapeEnvV1",
    "bathprint/BuoyantLayers-v1": "bathprint.envs.buoyant_layers:BuoyantLayersEnvV1",
    "bathprint/WriteShape-v2": "bathprint.envs.write_shape:WriteShapeEnvV2",
    "bathprint/WriteShape-v3": "bathprint.envs.write_shape:WriteShapeEnvV3",
    "bathprint/CoilRadius-v2": "bathprint.envs.coil_radius:CoilRadiusEnvV2",
    "bathprint/BuoyantLayers-v2": "bathprint.envs.buoyant_layers:BuoyantLayersEnvV2",
}
ENV_IDS: tuple[str, ...] = tuple(ENV_ENTRY_POINTS)


def register_envs() -> list[str]:
    """Register the environments with Gymnasium (namespace ``bathprint``); idempotent.

    Returns the ids. Cheap: the environment modules are imported only when one is made.
    """
    import gymnasium

    for env_id, entry_point in ENV_ENTRY_POINTS.items():
        if env_id not in gymnasium.registry:
            gymnasium.register(id=env_id, entry_point=entry_point)
    return list(ENV_IDS)


def _name_version(env_id: str) -> tuple[str, int]:
    """``bathprint/CoilRadius-v1`` -> (``bathprint/CoilRadius``, 1)."""
    name, _, version = env_id.rpartition("-v")
    return name, int(version)


def newest_id(env_id: str) -> str:
    """The newest registered version of an environment (a full id, e.g.
    ``bathprint/WriteShape-v0`` -> ``bathprint/WriteShape-v2``)."""
    name = _name_version(env_id)[0]
    versions = [i for i in ENV_IDS if _name_version(i)[0] == name]
    if not versions:
        raise ValueError(f"unknown environment {env_id!r}; known: {', '.join(ENV_IDS)}")
    return max(versions, key=lambda i: _name_version(i)[1])


def resolve_id(name: str) -> str:
    """Full id of an environment given as ``bathprint/CoilRadius-v1``, ``CoilRadius-v1`` or
    ``CoilRadius`` (case-insensitive; a bare name is the newest version, as in Gymnasium)."""
    key = name.lower().removeprefix(f"{NAMESPACE}/")
    for env_id in ENV_IDS:
        if key == env_id.removeprefix(f"{NAMESPACE}/").lower():
            return env_id
    for env_id in ENV_IDS:
        bare = _name_version(env_id)[0].removeprefix(f"{NAMESPACE}/").lower()
        if key == bare:
            return newest_id(env_id)
    raise ValueError(f"unknown environment {name!r}; known: {', '.join(ENV_IDS)}")


def printed_targets(env_id: str) -> bool:
    """Whether an environment has version 1's protocol (printed targets with train,
    validation and test sets): every version from 1 on; version 0 has an eval set."""
    return not resolve_id(env_id).endswith("-v0")


def shape_targets(env_id: str) -> bool:
    """Whether an environment writes the named shapes of a family (spec version 3,
    :mod:`bathprint.envs.shape_env`): held-out sets ``validation``, ``test``, ``ood_test``."""
    from bathprint.envs.spec import load_spec

    return load_spec(resolve_id(env_id)).version >= 3


def fixed_target_sets(env_id: str) -> tuple[str, ...]:
    """The fixed (held-out) target sets of an environment: version 0's ``eval``; versions 1
    and 2's ``validation`` and ``test``; the shape environments' ``validation``, ``test``
    and ``ood_test`` (shapes of kinds never trained on)."""
    if not printed_targets(env_id):
        return ("eval",)
    return ("validation", "test", "ood_test") if shape_targets(env_id) else ("validation", "test")


def target_set_size(env: Any, target_set: str) -> int:
    """How many targets the fixed set ``target_set`` of an (unwrapped) environment holds:
    version 0's ``eval`` set, a later version's ``validation`` or ``test`` set, or a shape
    environment's named ``validation``, ``test`` or ``ood_test`` shapes."""
    if target_set == "eval":
        return int(env.sampler.eval_size)
    if getattr(env, "set_sizes", None) is not None:
        return int(env.set_sizes[target_set])
    return int(env.printed.sizes[target_set])


def make(env_id: str, **kwargs: Any) -> Any:
    """``gymnasium.make`` after :func:`register_envs` (accepts short names, see
    :func:`resolve_id`). Picklable by reference, so ``functools.partial(make, id, ...)`` is a
    safe env factory for subprocess vector envs started with spawn or forkserver."""
    import gymnasium

    from bathprint.errors import ConfigError

    mode = kwargs.get("render_mode")
    if mode is not None and not isinstance(mode, str):  # gymnasium.make would fail on it
        raise ConfigError(f"render_mode = {mode!r}; allowed: None, 'human', 'rgb_array'")
    register_envs()
    return gymnasium.make(resolve_id(env_id), **kwargs)


def make_from_config(config: dict[str, Any]) -> Any:
    """An environment from a plain dict (e.g. sent to a Ray worker)::

        {"id": "bathprint/CoilRadius-v0", "kwargs": {"accuracy": "draft"}}

    Keys: ``id`` (required), ``kwargs`` (dict, optional), ``max_episode_steps`` (optional).
    """
    if not isinstance(config, dict) or "id" not in config:
        raise ValueError(f"config = {config!r}: a dict with at least the key 'id'")
    unknown = set(config) - {"id", "kwargs", "max_episode_steps"}
    if unknown:
        raise ValueError(
            f"config: unknown keys {sorted(unknown)}; allowed: id, kwargs, max_episode_steps"
        )
    kwargs = dict(config.get("kwargs") or {})
    if config.get("max_episode_steps") is not None:
        kwargs["max_episode_steps"] = int(config["max_episode_steps"])
    return make(str(config["id"]), **kwargs)


def play_main(argv: Sequence[str] | None = None) -> int:
    """``bathprint play ENV --policy random|constant|zero --out DIR``; see
    :mod:`bathprint.envs.play`."""
    from bathprint.envs.play import main

    return main(argv)


__all__ = [
    "ENV_IDS",
    "printed_targets",
    "make",
    "make_from_config",
    "newest_id",
    "play_main",
    "register_envs",
    "resolve_id",
    "target_set_size",
    "fixed_target_sets",
    "shape_targets",
]

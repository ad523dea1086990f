"""Hyperparameter and baseline files of the agents (YAML, loadable by rl-zoo3).

``agents/<algo>.yml`` maps an environment id to the settings of that algorithm on it, in
rl-zoo3's layout (``python -m rl_zoo3.train --algo ppo --env ENV --gym-packages bathprint
-conf agents/ppo.yml`` reads the same file unchanged)::

    bathprint/CoilRadius-v1:
      n_timesteps: 300000      # default --timesteps
      n_envs: 2                # default --n-envs
      policy: MlpPolicy
      env_kwargs: {accuracy: draft}
      normalize: {norm_obs: false, norm_reward: true}   # VecNormalize, or false
      env_wrapper:             # optional: rl-zoo3's form, see bathprint.agents.wrappers
        - bathprint.agents.wrappers.FeedforwardResidual: {scale: 0.5, calibrated: true}
      learning_rate: 0.0003    # ... every other key goes to the algorithm's constructor
      policy_kwargs: {net_arch: [64, 64]}

    bathprint:                 # bathprint's own keys (rl-zoo3 reads only the entry of the
      default:                 # environment it trains, so it never sees them)
        eval_freq: 10000       # environment steps between validation evaluations
        eval_episodes: 16
        checkpoint_freq: 10000 # environment steps between checkpoints
        torch_threads: 1
        time_budget_s: 600     # wall-time cap of a run (training stops there, "done")
        bc_pretrain: {targets: 160, epochs: 30}   # PPO: behaviour cloning first (imitation;
                                                  # demonstrator: controller on shapes)
      bathprint/CoilRadius-v1: {eval_freq: 20000}   # per environment, over the default

:func:`load_hyperparams` merges the environment's entry with the ``bathprint`` section
(``default``, then the environment's own); a flat entry holding bathprint's keys itself
(older files) is read too. ``wrapper: {name: feedforward_residual, ...}`` is the older
spelling of ``env_wrapper``.

``agents/baselines.yml`` holds what ``bathprint baselines fit`` found per environment: the
best constant action and the calibrated prefactor of the scaling law.

Files are read from ``$BATHPRINT_AGENTS_DIR`` if set, else from ``agents/`` at the root of
the source checkout. :func:`validate_hyperparams` checks an entry before any work starts:
YAML syntax, unknown keys (against bathprint's keys and the algorithm's constructor), the
types the constructor declares and the ranges of the common numbers; errors are
:class:`bathprint.errors.ConfigError` naming the key, the value and what is allowed.
"""

from __future__ import annotations

import collections.abc
import copy
import difflib
import inspect
import json
import math
import types
import typing
from pathlib import Path
from typing import Any

import yaml

from bathprint._resources import shared_dir
from bathprint.agents.algos import ALGOS
from bathprint.envs import printed_targets, shape_targets
from bathprint.errors import ConfigError

#: the section of a hyperparameter file that holds bathprint's own keys
BATHPRINT_SECTION = "bathprint"
#: keys bathprint reads that rl-zoo3 reads too (the environment's entry)
ZOO_RUN_KEYS = ("n_timesteps", "n_envs", "policy", "env_kwargs", "normalize", "env_wrapper")
#: keys only bathprint reads (the ``bathprint`` section)
OWN_KEYS = (
    "eval_freq",
    "eval_episodes",
    "checkpoint_freq",
    "torch_threads",
    "time_budget_s",
    "vec_env",
    "wrapper",
    "bc_pretrain",
)
#: vector environments (``vec_env``): one process stepping them in turn, or one each
VEC_ENVS = ("dummy", "subproc")
#: keys read by bathprint itself; everything else is passed to the SB3 algorithm
RUN_KEYS = ZOO_RUN_KEYS + OWN_KEYS
#: replay buffer classes a file may name (rl-zoo3 evaluates the string)
REPLAY_BUFFERS = ("HerReplayBuffer", "ReplayBuffer", "DictReplayBuffer")
#: the algorithm's arguments bathprint sets itself (not allowed in a file)
RESERVED_KEYS = ("env", "seed", "device", "tensorboard_log", "verbose", "_init_setup_model")
#: environment arguments bathprint sets itself: training uses the training targets, the
#: held-out evaluation the evaluation set
RESERVED_ENV_KWARGS = ("render_mode", "target_set", "target_index")
#: gymnasium.make's own keyword arguments that may appear in ``env_kwargs``
GYM_MAKE_KWARGS = ("max_episode_steps", "disable_env_checker")

_POSITIVE_INT = (
    "n_timesteps",
    "n_envs",
    "eval_freq",
    "eval_episodes",
    "checkpoint_freq",
    "torch_threads",
    "time_budget_s",
)
# (low, low inclusive, high, high inclusive) of numbers the algorithms take
_RANGES: dict[str, tuple[float | None, bool, float | None, bool]] = {
    "learning_rate": (0.0, False, None, False),
    "n_steps": (1, True, None, False),
    "batch_size": (1, True, None, False),
    "n_epochs": (1, True, None, False),
    "gamma": (0.0, False, 1.0, True),
    "gae_lambda": (0.0, True, 1.0, True),
    "clip_range": (0.0, False, None, False),
    "clip_range_vf": (0.0, False, None, False),
    "ent_coef": (0.0, True, None, False),
    "vf_coef": (0.0, True, None, False),
    "max_grad_norm": (0.0, False, None, False),
    "target_kl": (0.0, False, None, False),
    "buffer_size": (1, True, None, False),
    "learning_starts": (0, True, None, False),
    "tau": (0.0, False, 1.0, True),
    "train_freq": (1, True, None, False),
    "gradient_steps": (-1, True, None, False),
    "target_update_interval": (1, True, None, False),
    "stats_window_size": (1, True, None, False),
    "clip_obs": (0.0, False, None, False),
    "clip_reward": (0.0, False, None, False),
    "epsilon": (0.0, False, None, False),
}


def agents_dir() -> Path:
    """``$BATHPRINT_AGENTS_DIR``, the checkout's ``agents/``, or the installed copy
    (:func:`bathprint._resources.shared_dir`)."""
    return shared_dir("agents", "BATHPRINT_AGENTS_DIR")


class _StrictLoader(getattr(yaml, "CSafeLoader", yaml.SafeLoader)):  # type: ignore[misc]
    """SafeLoader that refuses a key written twice in one mapping (the second would
    silently win); keys brought in by a merge (``<<: *anchor``) may be overridden. It
    parses with libyaml where PyYAML has it (about 10x faster than the pure-Python parser;
    the same documents)."""

    def construct_mapping(self, node: Any, deep: bool = False) -> Any:
        if isinstance(node, yaml.MappingNode):
            seen: set[Any] = set()
            for key_node, _ in node.value:
                if key_node.tag == "tag:yaml.org,2002:merge":
                    continue
                key = self.construct_object(key_node, deep=True)
                if isinstance(key, collections.abc.Hashable) and key in seen:
                    mark = key_node.start_mark
                    raise ConfigError(
                        f"{mark.name}: key {key!r} appears twice in one mapping (line "
                        f"{mark.line + 1}); write it once"
                    )
                seen.add(key)
        return super().construct_mapping(node, deep=deep)


#: parsed YAML documents by their text: a campaign reads the same few files once per run
#: and baseline
_PARSED: dict[str, Any] = {}


def _read_yaml(path: Path) -> dict[str, Any]:
    """The mapping in the YAML file ``path`` (a copy of the parse of its text, which is
    kept); ConfigError when it is not valid YAML or not a mapping."""
    if not path.is_file():
        raise FileNotFoundError(
            f"{str(path)!r} does not exist; set BATHPRINT_AGENTS_DIR to a directory holding "
            "the agents' YAML files (the repository's agents/)"
        )
    text = path.read_text()
    if text not in _PARSED:
        _PARSED[text] = _parse_yaml(path, text)
    return copy.deepcopy(_PARSED[text])


def _parse_yaml(path: Path, text: str) -> dict[str, Any]:
    try:
        data = yaml.load(text, Loader=_StrictLoader) or {}
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        what = ": ".join(x for x in (exc.context, exc.problem) if x)
        raise ConfigError(f"{path}: not valid YAML{where}: {what}") from None
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: not valid YAML: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(
            f"{path}: a {type(data).__name__} at the top; expected a mapping of environment "
            "id to settings"
        )
    return data


def load_hyperparams(algo: str, env_id: str, path: str | Path | None = None) -> dict[str, Any]:
    """The settings of ``algo`` on ``env_id`` (a deep copy) from ``agents/<algo>.yml`` or
    from the file ``path`` (same layout, e.g. ``agents/ppo_residual.yml``)."""
    if algo not in ALGOS:
        raise ValueError(f"algo = {algo!r}; allowed: {', '.join(ALGOS)}")
    path = Path(path) if path is not None else agents_dir() / f"{algo}.yml"
    data = _read_yaml(path)
    if env_id not in data:
        entries = [str(k) for k in data if k != BATHPRINT_SECTION]
        raise ConfigError(
            f"{path.name} has no entry for {env_id!r}; entries: " + ", ".join(sorted(entries))
        )
    entry = data[env_id]
    if not isinstance(entry, dict):
        raise ConfigError(
            f"{path}: the entry of {env_id} is {entry!r}; expected a mapping of settings"
        )
    out = copy.deepcopy(entry)
    section = data.get(BATHPRINT_SECTION, {})
    if not isinstance(section, dict):
        raise ConfigError(
            f"{path}: {BATHPRINT_SECTION} = {section!r}; expected a mapping of 'default' and "
            "environment ids to bathprint's own keys"
        )
    own: dict[str, Any] = {}
    for key in ("default", env_id):
        part = section.get(key, {})
        if not isinstance(part, dict):
            raise ConfigError(
                f"{path}: {BATHPRINT_SECTION}.{key} = {part!r}; expected a mapping of "
                "bathprint's own keys (" + ", ".join(OWN_KEYS) + ")"
            )
        for k in part:
            if k not in OWN_KEYS:
                raise _unknown(k, OWN_KEYS, f"{path}: {BATHPRINT_SECTION}.{key}", "key")
        own.update(copy.deepcopy(part))
    for k, v in own.items():
        out.setdefault(k, v)
    return out


def split_hyperparams(hp: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any]]:
    """(bathprint's run settings, the algorithm's constructor kwargs). The run settings'
    ``wrapper`` is the wrapper entry of either spelling (``env_wrapper`` or ``wrapper``;
    see :func:`bathprint.agents.wrappers.wrapper_spec`)."""
    from bathprint.agents.wrappers import wrapper_spec

    run = {k: hp[k] for k in RUN_KEYS if k in hp}
    algo = {k: v for k, v in hp.items() if k not in RUN_KEYS}
    spec = wrapper_spec(run.pop("env_wrapper", None)) or run.get("wrapper")
    run.pop("wrapper", None)
    if spec:
        run["wrapper"] = spec
    return run, algo


def _describe(ann: Any) -> str:
    """What an annotation allows, in words."""
    origin = typing.get_origin(ann)
    if origin in (typing.Union, types.UnionType):
        return " or ".join(dict.fromkeys(_describe(a) for a in typing.get_args(ann)))
    if ann is type(None) or ann is None:
        return "null"
    names = {bool: "true or false", int: "an integer", float: "a number", str: "a string"}
    if ann in names:
        return names[ann]
    if ann is dict or origin is dict:
        return "a mapping"
    if ann is list or origin is list:
        (item,) = typing.get_args(ann) or (Any,)
        plural = {int: "integers", float: "numbers", str: "strings"}
        return "a list" if item is Any else f"a list of {plural.get(item, _describe(item))}"
    if origin is tuple:
        return "a list [" + ", ".join(_describe(a) for a in typing.get_args(ann)) + "]"
    if origin is collections.abc.Callable:
        return "a schedule (a Python callable)"
    if origin is type:
        (cls,) = typing.get_args(ann)
        return f"a {getattr(cls, '__name__', cls)} class"
    return f"a {getattr(ann, '__name__', ann)}"


def _matches(value: Any, ann: Any) -> bool:
    """Whether a value read from YAML/JSON fits an annotation (unknown forms fit)."""
    origin = typing.get_origin(ann)
    if ann is inspect.Parameter.empty or ann is Any:
        return True
    if origin in (typing.Union, types.UnionType):
        return any(_matches(value, a) for a in typing.get_args(ann))
    if ann is type(None) or ann is None:
        return value is None
    if ann is bool:
        return isinstance(value, bool)
    if ann is int:
        return isinstance(value, int) and not isinstance(value, bool)
    if ann is float:
        return (
            isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)
        )
    if ann is str:
        return isinstance(value, str)
    if ann is dict or origin is dict:
        return isinstance(value, dict)
    if ann is list or origin is list:
        (item,) = typing.get_args(ann) or (Any,)
        return isinstance(value, list) and all(_matches(v, item) for v in value)
    if origin is tuple:
        args = typing.get_args(ann)
        return (
            isinstance(value, list | tuple)
            and len(value) == len(args)
            and all(_matches(v, a) for v, a in zip(value, args, strict=True))
        )
    if origin is collections.abc.Callable:
        return callable(value)
    if origin is type:
        (cls,) = typing.get_args(ann)
        return isinstance(value, type) and (not isinstance(cls, type) or issubclass(value, cls))
    if isinstance(ann, type):
        return isinstance(value, ann)
    return True


def _check_value(key: str, value: Any, ann: Any, where: str) -> None:
    """Type (from the annotation) and range (from :data:`_RANGES`) of one setting."""
    if not _matches(value, ann):
        hint = ""
        if isinstance(value, str) and _matches(1.0, ann):
            try:
                float(value)
                hint = (
                    " (YAML reads a number without a decimal point, like 3e-4, as a "
                    "string: write 3.0e-4)"
                )
            except ValueError:
                pass
        raise ConfigError(
            f"{where}: {key} = {value!r} ({type(value).__name__}); expected {_describe(ann)}" + hint
        )
    name = key.rsplit(".", 1)[-1]  # normalize.gamma has gamma's range
    if name in _RANGES and isinstance(value, int | float) and not isinstance(value, bool):
        lo, lo_in, hi, hi_in = _RANGES[name]
        ok = (lo is None or (value >= lo if lo_in else value > lo)) and (
            hi is None or (value <= hi if hi_in else value < hi)
        )
        if not ok:
            if hi is None:
                allowed = f"{'>=' if lo_in else '>'} {lo:g}"
            else:
                allowed = f"in {'[' if lo_in else '('}{lo:g}, {hi:g}{']' if hi_in else ')'}"
            raise ConfigError(f"{where}: {key} = {value!r}; allowed: a number {allowed}")


def _unknown(key: Any, allowed: Any, where: str, what: str) -> ConfigError:
    close = difflib.get_close_matches(str(key), list(allowed), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    return ConfigError(
        f"{where}: unknown {what} {key!r}{hint}; allowed: " + ", ".join(sorted(allowed))
    )


def _parameters(func: Any, drop: tuple[str, ...] = ()) -> dict[str, Any]:
    """Name -> annotation of a callable's keyword parameters (without ``self``, ``drop``)."""
    return {
        name: p.annotation
        for name, p in inspect.signature(func).parameters.items()
        if name not in ("self", *drop) and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
    }


def algo_class(algo: str) -> Any:
    """The Stable-Baselines3 class of ``algo`` (``ppo``, ``sac``; ``tqc`` from sb3-contrib)."""
    from sb3_contrib import TQC
    from stable_baselines3 import PPO, SAC

    classes = {"ppo": PPO, "sac": SAC, "tqc": TQC}
    if algo not in classes:
        raise ConfigError(f"algo = {algo!r}; allowed: {', '.join(classes)}")
    return classes[algo]


def env_parameters(env_id: str) -> dict[str, Any]:
    """Keyword arguments an environment accepts: its class's, and gymnasium.make's."""
    import importlib

    from bathprint.envs import ENV_ENTRY_POINTS

    module, name = ENV_ENTRY_POINTS[env_id].split(":")
    cls = getattr(importlib.import_module(module), name)
    params = _parameters(cls.__init__)
    params.update({"max_episode_steps": int | None, "disable_env_checker": bool | None})
    return params


def validate_hyperparams(algo: str, hp: Any, where: str, env_id: str | None = None) -> None:
    """Refuse an entry that would fail (or be misread) later: unknown keys, wrong types,
    numbers out of range. ``where`` starts each message (the file or run.json). With
    ``env_id``, the keys of ``env_kwargs`` are checked against the environment's arguments
    (their values are checked by the environment itself)."""
    from stable_baselines3.common.vec_env import VecNormalize

    from bathprint.agents.wrappers import WRAPPERS, wrapper_class

    cls = algo_class(algo)
    if not isinstance(hp, dict):
        raise ConfigError(f"{where}: {hp!r}; expected a mapping of settings")
    algo_params = _parameters(cls.__init__, ("policy", *RESERVED_KEYS))  # policy: a run key
    for key in hp:
        if not isinstance(key, str):
            raise ConfigError(f"{where}: key {key!r} is not a string")
        if key in RESERVED_KEYS:
            hint = " (use --seed)" if key == "seed" else ""
            raise ConfigError(
                f"{where}: {key} = {hp[key]!r}; bathprint sets {key} itself{hint}: remove it"
            )
        if key not in RUN_KEYS and key not in algo_params:
            raise _unknown(key, [*RUN_KEYS, *algo_params], where, f"{algo} key")
    for key in _POSITIVE_INT:
        if key in hp:
            value = hp[key]
            if not (isinstance(value, int) and not isinstance(value, bool) and value >= 1):
                raise ConfigError(f"{where}: {key} = {value!r}; allowed: an integer >= 1")
    if "vec_env" in hp and hp["vec_env"] not in VEC_ENVS:
        raise ConfigError(
            f"{where}: vec_env = {hp['vec_env']!r}; allowed: " + ", ".join(VEC_ENVS)
        )
    policy = hp.get("policy", "MlpPolicy")
    if not isinstance(policy, str) or policy not in cls.policy_aliases:
        raise ConfigError(
            f"{where}: policy = {policy!r}; allowed: " + ", ".join(cls.policy_aliases)
        )
    for key, value in hp.items():
        if key == "replay_buffer_class" and isinstance(value, str):
            if value not in REPLAY_BUFFERS:
                raise ConfigError(
                    f"{where}: replay_buffer_class = {value!r}; allowed: "
                    + ", ".join(REPLAY_BUFFERS)
                )
            continue
        if key in algo_params:
            _check_value(key, value, algo_params[key], where)
    policy_kwargs = hp.get("policy_kwargs") or {}
    allowed_pk = _parameters(
        cls.policy_aliases[policy].__init__, ("observation_space", "action_space", "lr_schedule")
    )
    for key, value in policy_kwargs.items():
        if key not in allowed_pk:
            raise _unknown(key, allowed_pk, where, "policy_kwargs key")
        _check_value(f"policy_kwargs.{key}", value, allowed_pk[key], where)

    env_kwargs = hp.get("env_kwargs", {})
    if not isinstance(env_kwargs, dict):
        raise ConfigError(
            f"{where}: env_kwargs = {env_kwargs!r}; expected a mapping of environment arguments"
        )
    for key in env_kwargs:
        if key in RESERVED_ENV_KWARGS:
            raise ConfigError(
                f"{where}: env_kwargs.{key} = {env_kwargs[key]!r}; bathprint sets it itself "
                "(training on the training targets, evaluation on the held-out set): remove it"
            )
    if env_id is not None:
        allowed_env = {
            k: v for k, v in env_parameters(env_id).items() if k not in RESERVED_ENV_KWARGS
        }
        for key in env_kwargs:
            if key not in allowed_env:
                raise _unknown(key, allowed_env, where, "env_kwargs key")

    normalize = hp.get("normalize", False)
    if normalize not in (False, None):
        if not isinstance(normalize, dict):
            raise ConfigError(
                f"{where}: normalize = {normalize!r}; expected false or a mapping of "
                "VecNormalize arguments, e.g. {norm_obs: false, norm_reward: true}"
            )
        allowed_norm = _parameters(VecNormalize.__init__, ("venv", "training"))
        for key, value in normalize.items():
            if key not in allowed_norm:
                raise _unknown(key, allowed_norm, where, "normalize key")
            _check_value(f"normalize.{key}", value, allowed_norm[key], where)

    _check_bc(algo, hp, where, env_id)

    from bathprint.agents.wrappers import wrapper_spec

    if "env_wrapper" in hp and "wrapper" in hp:
        raise ConfigError(
            f"{where}: env_wrapper and wrapper are two spellings of one setting; give one"
        )
    try:
        wrapper = wrapper_spec(hp.get("env_wrapper")) if "env_wrapper" in hp else hp.get("wrapper")
    except ValueError as exc:
        raise ConfigError(f"{where}: {exc}") from None
    if wrapper is not None:
        if not isinstance(wrapper, dict) or wrapper.get("name") not in WRAPPERS:
            raise ConfigError(
                f"{where}: wrapper = {wrapper!r}; expected null or a mapping with name: one "
                f"of {', '.join(WRAPPERS)} (and its arguments)"
            )
        allowed_w = _parameters(wrapper_class(wrapper["name"]).__init__, ("env", "robustness"))
        for key, value in wrapper.items():
            if key == "name":
                continue
            if key not in allowed_w:
                raise _unknown(key, ["name", *allowed_w], where, "wrapper key")
            _check_value(f"wrapper.{key}", value, allowed_w[key], where)
        if wrapper["name"] == "robustness":  # its values, before any environment is made
            from bathprint.envs.robust import Robustness

            try:
                Robustness.from_mapping({k: v for k, v in wrapper.items() if k != "name"})
            except ConfigError as exc:
                raise ConfigError(f"{where}: wrapper.{exc}") from None


def _check_bc(algo: str, hp: dict[str, Any], where: str, env_id: str | None) -> None:
    """``bc_pretrain`` (see :mod:`bathprint.agents.imitation`): its keys and values, and
    that the run can use it (PPO, no action wrapper, raw observations, a demonstrator the
    environment has: the shape environments' targets have no printing actions)."""
    from bathprint.agents.imitation import bc_settings

    settings = bc_settings(hp.get("bc_pretrain"), where)
    if settings is None:
        return
    if algo != "ppo":
        raise ConfigError(
            f"{where}: bc_pretrain = {hp['bc_pretrain']!r} with algo = {algo!r}; behaviour "
            "cloning pretrains PPO's policy only: remove bc_pretrain or use ppo"
        )
    if env_id is not None and not printed_targets(env_id):
        if settings["demonstrator"] == "controller":
            raise ConfigError(
                f"{where}: bc_pretrain on {env_id}: the controller needs a version-1 "
                "environment or later: remove bc_pretrain"
            )
        raise ConfigError(
            f"{where}: bc_pretrain on {env_id}: only version-1 environments print their "
            "targets (the printing actions are the demonstrations): remove bc_pretrain"
        )
    if env_id is not None and settings["demonstrator"] == "printed" and shape_targets(env_id):
        from bathprint.agents.imitation import refuse_printed

        raise ConfigError(f"{where}: {refuse_printed(env_id)}")
    if hp.get("env_wrapper") or hp.get("wrapper"):
        raise ConfigError(
            f"{where}: bc_pretrain with an env_wrapper: the demonstrations are the "
            "environment's own actions, not a wrapper's: remove one of them"
        )
    normalize = hp.get("normalize")
    if isinstance(normalize, dict) and normalize.get("norm_obs", True):
        raise ConfigError(
            f"{where}: bc_pretrain with normalize.norm_obs = {normalize.get('norm_obs', True)!r}"
            ": behaviour cloning fits raw observations; set normalize.norm_obs: false"
        )


def algo_kwargs_for(algo: str, kwargs: dict[str, Any]) -> dict[str, Any]:
    """The algorithm's keyword arguments as its constructor takes them: lists (all YAML and
    JSON have) become tuples where it declares a tuple (``train_freq: [1, episode]``)."""
    params = _parameters(algo_class(algo).__init__)
    out = dict(kwargs)
    if isinstance(out.get("replay_buffer_class"), str):
        from stable_baselines3 import HerReplayBuffer
        from stable_baselines3.common.buffers import DictReplayBuffer, ReplayBuffer

        named = {"HerReplayBuffer": HerReplayBuffer, "ReplayBuffer": ReplayBuffer,
                 "DictReplayBuffer": DictReplayBuffer}
        out["replay_buffer_class"] = named[out["replay_buffer_class"]]
    for key, value in kwargs.items():
        ann = params.get(key)
        alternatives = (
            typing.get_args(ann)
            if typing.get_origin(ann) in (typing.Union, types.UnionType)
            else (ann,)
        )
        if isinstance(value, list) and any(typing.get_origin(a) is tuple for a in alternatives):
            out[key] = tuple(value)
    return out


def baselines_path() -> Path:
    return agents_dir() / "baselines.yml"


def load_baselines(env_id: str) -> dict[str, Any]:
    """The fitted baselines of ``env_id``: ``constant_action``, ``feedforward_prefactor``."""
    path = baselines_path()
    data = _read_yaml(path)
    if env_id not in data:
        raise ValueError(
            f"{path} has no entry for {env_id!r}: run `bathprint baselines fit --env {env_id}`"
        )
    return dict(data[env_id])


def save_baselines(env_id: str, entry: dict[str, Any], path: Path | None = None) -> Path:
    """Write (replace) the entry of ``env_id`` in ``baselines.yml``, keeping the others."""
    path = path or baselines_path()
    data = yaml.safe_load(path.read_text()) if path.is_file() else {}
    data = data or {}
    data[env_id] = json.loads(json.dumps(entry, default=float))  # plain floats for YAML
    header = (
        "# Fitted baselines per environment, written by `bathprint baselines fit` (see\n"
        "# bathprint.agents.fit): the best constant action (grid search on training targets)\n"
        "# and the scaling-law prefactor c in R = c (B/(mu v))^(1/3) fitted to this simulator.\n"
    )
    path.write_text(header + yaml.safe_dump(data, sort_keys=True, default_flow_style=None))
    return path

"""Environment specifications: one TOML file per environment in the repository's ``envs/``.

A spec names the scene (a built-in scene plus dotted overrides), the controls and their
physical ranges, the episode (warm-up, control interval, settling length), the target family
and its held-out evaluation set, and the parameters of the shape metric. Files are looked up
in ``$BATHPRINT_ENVS_DIR`` if set, else in ``envs/`` at the root of the source checkout.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from bathprint._resources import shared_dir
from bathprint.errors import ConfigError

#: Environment id -> spec file name (in the specs directory).
SPEC_FILES: dict[str, str] = {
    "bathprint/CoilRadius-v0": "coil_radius.toml",
    "bathprint/WriteShape-v0": "write_shape.toml",
    "bathprint/BuoyantLayers-v0": "buoyant_layers.toml",
    "bathprint/CoilRadius-v1": "coil_radius_v1.toml",
    "bathprint/WriteShape-v1": "write_shape_v1.toml",
    "bathprint/BuoyantLayers-v1": "buoyant_layers_v1.toml",
    "bathprint/WriteShape-v2": "write_shape_v2.toml",
    "bathprint/WriteShape-v3": "write_shape_v3.toml",
    "bathprint/CoilRadius-v2": "coil_radius_v2.toml",
    "bathprint/BuoyantLayers-v2": "buoyant_layers_v2.toml",
}

#: Allowed keys of each table (anything else is an error naming the key).
_SCHEMA: dict[str, set[str]] = {
    "": {
        "id",
        "version",
        "entry_point",
        "summary",
        "scene",
        "control",
        "episode",
        "target",
        "metric",
        "observation",
        "success",
        "reward",
    },
    "scene": {"base", "overrides"},
    "control": {
        "actions",
        "length_mm",
        "q_outer_ml_min",
        "q_inner_ml_min",
        "inclusion_offset",
        "needle_speed_mm_s",
        "needle_box_mm",
        "q_outer_scale",
        "q_inner_as",
        "inner_fraction",
        "inner_lag_s",
        "needle",
    },
    "episode": {
        "warmup_length_mm",
        "warmup_q_outer_ml_min",
        "settle_length_mm",
        "start_states",
        "max_substeps",
        "lead_in_mm",
    },
    "target": {
        "family",
        "length_mm",
        "spacing_mm",
        "eval_size",
        "eval_seed",
        "params",
        "print_accuracy",
        "train_pool",
        "validation_size",
        "test_size",
        "sets_file",
        "band_kg_m3",
        "shape_family",
    },
    "metric": {
        "window_mm",
        "length_scale_mm",
        "curvature_span_mm",
        "density_scale_kg_m3",
        "w_shape",
        "w_curvature",
        "w_density",
        "missing_error",
        "allow_reflection",
    },
    "observation": {"density_ref_kg_m3", "density_scale_kg_m3", "target_positions_mm"},
    "success": {"metric_max"},
    "reward": {"length_scale_mm", "missing_error_mm"},
}

#: keys of version-1 specs only (a version-0 spec with one of them is refused), and of
#: version 0 only
V1_ONLY: frozenset[str] = frozenset(
    {
        "observation",
        "success",
        "control.q_outer_scale",
        "control.q_inner_as",
        "control.inner_fraction",
        "control.inner_lag_s",
        "control.needle",
        "episode.lead_in_mm",
        "target.print_accuracy",
        "target.train_pool",
        "target.validation_size",
        "target.test_size",
        "target.sets_file",
        "target.band_kg_m3",
        "target.shape_family",
        "reward",
    }
)
V0_ONLY: frozenset[str] = frozenset({"target.eval_size", "target.eval_seed"})

ACTION_NAMES = ("q_outer", "q_inner", "inclusion_offset")

#: numbers of the spec: "table.key" -> (integer?, lower bound, bound inclusive?)
_NUMBERS: dict[str, tuple[bool, float, bool]] = {
    "control.length_mm": (False, 0.0, False),
    "control.needle_speed_mm_s": (False, 0.0, True),
    "episode.warmup_length_mm": (False, 0.0, True),
    "episode.warmup_q_outer_ml_min": (False, 0.0, False),
    "episode.settle_length_mm": (False, 0.0, True),
    "episode.start_states": (True, 1, True),
    "episode.max_substeps": (True, 1, True),
    "target.length_mm": (False, 0.0, False),
    "target.spacing_mm": (False, 0.0, False),
    "target.eval_size": (True, 1, True),
    "target.eval_seed": (True, 0, True),
    "metric.window_mm": (False, 0.0, False),
    "metric.length_scale_mm": (False, 0.0, False),
    "metric.curvature_span_mm": (False, 0.0, False),
    "metric.density_scale_kg_m3": (False, 0.0, False),
    "metric.w_shape": (False, 0.0, True),
    "metric.w_curvature": (False, 0.0, True),
    "metric.w_density": (False, 0.0, True),
    "metric.missing_error": (False, 0.0, True),
    "control.inner_lag_s": (False, 0.0, True),
    "episode.lead_in_mm": (False, 0.0, True),
    "target.train_pool": (True, 1, True),
    "target.validation_size": (True, 1, True),
    "target.test_size": (True, 1, True),
    "target.band_kg_m3": (False, 0.0, True),
    "observation.density_ref_kg_m3": (False, 0.0, True),
    "observation.density_scale_kg_m3": (False, 0.0, False),
    "success.metric_max": (False, 0.0, False),
    "reward.length_scale_mm": (False, 0.0, False),
    "reward.missing_error_mm": (False, 0.0, False),
}


class SpecError(ConfigError):
    """A spec file is missing, unreadable, or has an unknown or invalid key (a
    :class:`~bathprint.errors.ConfigError`, so a ``ValueError``)."""


@dataclass(frozen=True)
class EnvSpecData:
    """A parsed, validated spec (plain dicts inside, as read from TOML)."""

    id: str
    entry_point: str
    summary: str
    scene: dict[str, Any]
    control: dict[str, Any]
    episode: dict[str, Any]
    target: dict[str, Any]
    metric: dict[str, Any]
    path: str
    version: int = 0
    observation: dict[str, Any] = dataclasses.field(default_factory=dict)
    success: dict[str, Any] = dataclasses.field(default_factory=dict)
    reward: dict[str, Any] = dataclasses.field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """The spec as a nested dict (a deep copy)."""
        return copy.deepcopy(
            {
                "id": self.id,
                "entry_point": self.entry_point,
                "summary": self.summary,
                "scene": self.scene,
                "control": self.control,
                "episode": self.episode,
                "target": self.target,
                "metric": self.metric,
                **({"version": self.version} if self.version else {}),
                **({"observation": self.observation} if self.observation else {}),
                **({"success": self.success} if self.success else {}),
                **({"reward": self.reward} if self.reward else {}),
            }
        )


def specs_dir() -> Path:
    """Directory holding the spec files: ``$BATHPRINT_ENVS_DIR``, the checkout's ``envs/``,
    or the installed copy (:func:`bathprint._resources.shared_dir`)."""
    return shared_dir("envs", "BATHPRINT_ENVS_DIR")


def spec_path(env_id: str) -> Path:
    """Path of the spec file of a registered environment id."""
    if env_id not in SPEC_FILES:
        raise SpecError(f"unknown environment {env_id!r}; known: {', '.join(SPEC_FILES)}")
    path = specs_dir() / SPEC_FILES[env_id]
    if not path.exists():
        raise SpecError(
            f"spec file {str(path)!r} of {env_id} does not exist; set BATHPRINT_ENVS_DIR to the "
            "directory holding the envs/*.toml specs"
        )
    return path


def deep_merge(base: dict[str, Any], extra: dict[str, Any] | None) -> dict[str, Any]:
    """``base`` updated by ``extra`` recursively (tables merge, values replace); a copy."""
    out = copy.deepcopy(base)
    for key, value in (extra or {}).items():
        if isinstance(value, dict) and isinstance(out.get(key), dict) and key != "overrides":
            out[key] = deep_merge(out[key], value)
        elif isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = {**out[key], **copy.deepcopy(value)}  # scene overrides: flat dotted keys
        else:
            out[key] = copy.deepcopy(value)
    return out


def _check_keys(data: dict[str, Any], where: str) -> None:
    for table, allowed in _SCHEMA.items():
        node = data if table == "" else data.get(table, {})
        if not isinstance(node, dict):
            raise SpecError(f"{where}: [{table}] must be a table")
        for key in node:
            if key not in allowed:
                full = key if table == "" else f"{table}.{key}"
                raise SpecError(
                    f"{where}: unknown key {full!r}; allowed: " + ", ".join(sorted(allowed))
                )


def _is_number(x: Any) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def _range(control: dict[str, Any], key: str, where: str) -> tuple[float, float]:
    value = control.get(key, [0.0, 0.0])
    ok = isinstance(value, list | tuple) and len(value) == 2
    if not ok or not all(_is_number(x) for x in value) or value[0] > value[1]:
        raise SpecError(f"{where}: control.{key} = {value!r} must be [low, high] with low <= high")
    return float(value[0]), float(value[1])


def _check_numbers(data: dict[str, Any], where: str) -> None:
    """Every number of :data:`_NUMBERS` that is present: its type and lower bound."""
    for name, (integer, lo, inclusive) in _NUMBERS.items():
        table, key = name.split(".")
        if key not in data.get(table, {}):
            continue
        value = data[table][key]
        kind = "an integer" if integer else "a number"
        ok = (
            (isinstance(value, int) and not isinstance(value, bool))
            if integer
            else (_is_number(value))
        )
        if ok:
            ok = value >= lo if inclusive else value > lo
        if not ok:
            raise SpecError(
                f"{where}: {name} = {value!r}; allowed: {kind} {'>=' if inclusive else '>'} {lo:g}"
            )
    reflect = data["metric"].get("allow_reflection", True)
    if not isinstance(reflect, bool):
        raise SpecError(f"{where}: metric.allow_reflection = {reflect!r}; allowed: true, false")
    box = data["control"].get("needle_box_mm")
    if box is not None:
        rows = box if isinstance(box, list | tuple) else []
        if len(rows) != 3 or not all(
            isinstance(r, list | tuple) and len(r) == 2 and all(map(_is_number, r)) and r[0] <= r[1]
            for r in rows
        ):
            raise SpecError(
                f"{where}: control.needle_box_mm = {box!r}; allowed: three [low, high] pairs "
                "(x, y, z in mm) with low <= high"
            )
    scene = data["scene"]
    if "base" in scene and not isinstance(scene["base"], str):
        raise SpecError(f"{where}: scene.base = {scene['base']!r}; allowed: a scene name")
    if not isinstance(scene.get("overrides", {}), dict):
        raise SpecError(
            f"{where}: scene.overrides = {scene['overrides']!r}; allowed: a table of dotted "
            "scene keys"
        )
    params = data["target"].get("params", {})
    if not isinstance(params, dict):
        raise SpecError(f"{where}: target.params = {params!r}; allowed: a table")


def validate(data: dict[str, Any], where: str) -> EnvSpecData:
    """Check a spec dict (after overrides) and return it frozen."""
    _check_keys(data, where)
    for table in ("scene", "control", "episode", "target", "metric"):
        if table not in data:
            raise SpecError(f"{where}: missing table [{table}]")
    control = data["control"]
    actions = control.get("actions", [])
    if not actions or any(a not in ACTION_NAMES for a in actions) or actions[0] != "q_outer":
        raise SpecError(
            f"{where}: control.actions = {actions!r}; allowed: 'q_outer' first, then any of "
            + ", ".join(ACTION_NAMES[1:])
        )
    q_lo, _ = _range(control, "q_outer_ml_min", where)
    if q_lo <= 0:
        raise SpecError(
            f"{where}: control.q_outer_ml_min = {control.get('q_outer_ml_min')!r} must have a "
            "positive lower bound"
        )
    qi = _range(control, "q_inner_ml_min", where)
    if qi[0] < 0:
        raise SpecError(
            f"{where}: control.q_inner_ml_min = {control['q_inner_ml_min']!r}; flows are >= 0"
        )
    off = _range(control, "inclusion_offset", where)
    if off[0] < -1 or off[1] > 1:
        raise SpecError(
            f"{where}: control.inclusion_offset = {control.get('inclusion_offset')!r} must "
            "lie in [-1, 1]"
        )
    for name in ("control.length_mm", "target.spacing_mm"):
        table, key = name.split(".")
        if key not in data[table]:
            raise SpecError(f"{where}: {name} is missing (a number > 0)")
    _check_numbers(data, where)
    version = _check_version(data, where)
    return EnvSpecData(
        id=str(data.get("id", "")),
        entry_point=str(data.get("entry_point", "")),
        summary=str(data.get("summary", "")),
        scene=data["scene"],
        control=control,
        episode=data["episode"],
        target=data["target"],
        metric=data["metric"],
        path=where,
        version=version,
        observation=dict(data.get("observation", {})),
        success=dict(data.get("success", {})),
        reward=dict(data.get("reward", {})),
    )


def _present(data: dict[str, Any], name: str) -> bool:
    if "." not in name:
        return name in data
    table, key = name.split(".")
    return isinstance(data.get(table), dict) and key in data[table]


def _check_version(data: dict[str, Any], where: str) -> int:
    """The spec's ``version`` (0 when absent) and the keys only one version knows. Versions
    1 and 2 share one protocol (printed targets, train / validation / test sets); version 3
    is the shape environments' (targets of a shape family, :mod:`bathprint.envs.shape_env`).
    A version is the environment's, so that a new observation gets a new number."""
    version = data.get("version", 0)
    if isinstance(version, bool) or version not in (0, 1, 2, 3):
        raise SpecError(f"{where}: version = {version!r}; allowed: 0, 1, 2, 3")
    wrong = V1_ONLY if version == 0 else V0_ONLY
    for name in sorted(wrong):
        if _present(data, name):
            raise SpecError(
                f"{where}: {name} is a key of version-{'0' if version else '1'} specs; this "
                f"spec has "
                f"version = {version}"
            )
    if version == 0:
        return 0
    control, target = data["control"], data["target"]
    choices = {
        "control.q_outer_scale": (control.get("q_outer_scale", "linear"), ("linear", "log")),
        "control.q_inner_as": (control.get("q_inner_as", "flow"), ("flow", "fraction")),
        "control.needle": (control.get("needle", ""), ("", "xy", "xyz")),
        "target.print_accuracy": (
            target.get("print_accuracy", "draft"),
            ("draft", "balanced", "fine"),
        ),
    }
    for name, (value, allowed) in choices.items():
        if value not in allowed:
            raise SpecError(
                f"{where}: {name} = {value!r}; allowed: " + ", ".join(map(repr, allowed))
            )
    lo, hi = _range(control, "inner_fraction", where)
    if lo < 0 or hi >= 1:
        raise SpecError(
            f"{where}: control.inner_fraction = {control.get('inner_fraction')!r} must lie in "
            "[0, 1)"
        )
    if control.get("q_inner_as") == "fraction" and "q_inner_ml_min" in control:
        raise SpecError(
            f"{where}: control.q_inner_ml_min with q_inner_as = 'fraction': the q_inner action "
            "sets control.inner_fraction; give that instead"
        )
    sets_file = target.get("sets_file", "")
    if not isinstance(sets_file, str):
        raise SpecError(f"{where}: target.sets_file = {sets_file!r}; allowed: a relative path")
    if version == 3:
        from bathprint.envs.shape_metric import FAMILIES

        if target.get("family") != "shapes" or target.get("shape_family") not in FAMILIES:
            raise SpecError(
                f"{where}: a version-3 spec needs target.family = 'shapes' and "
                f"target.shape_family one of {', '.join(FAMILIES)}; got "
                f"{target.get('family')!r}, {target.get('shape_family')!r}"
            )
    elif "shape_family" in target or "reward" in data:
        raise SpecError(f"{where}: target.shape_family and [reward] are keys of version-3 specs")
    if "length_mm" not in target:
        raise SpecError(f"{where}: target.length_mm is missing (a number > 0)")
    offsets = data.get("observation", {}).get("target_positions_mm")
    if offsets is not None and not (
        isinstance(offsets, list)
        and 1 <= len(offsets) <= 32
        and all(isinstance(v, int | float) and not isinstance(v, bool) for v in offsets)
        and all(math.isfinite(v) and abs(v) <= 1000 for v in offsets)
    ):
        raise SpecError(
            f"{where}: observation.target_positions_mm = {offsets!r}; allowed: a list of 1 to "
            "32 arclength offsets (mm, finite, |offset| <= 1000) from the needle's sample"
        )
    return int(version)


def read_spec_dict(env_id: str | None = None, path: str | Path | None = None) -> dict[str, Any]:
    """Raw spec dict of an environment id (or of a file path)."""
    p = Path(path) if path is not None else spec_path(str(env_id))
    if not p.exists():
        raise SpecError(f"spec file {str(p)!r} does not exist")
    try:
        return tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(f"spec file {str(p)!r} is not valid TOML: {exc}") from exc


def load_spec(
    env_id: str | None = None,
    path: str | Path | None = None,
    overrides: dict[str, Any] | None = None,
) -> EnvSpecData:
    """The validated spec of ``env_id`` (or the file ``path``), updated by ``overrides``."""
    where = str(path) if path is not None else str(spec_path(str(env_id)))
    if overrides is not None:
        if not isinstance(overrides, dict):
            raise SpecError(
                f"spec_overrides = {overrides!r}; allowed: a nested mapping of spec tables, "
                "e.g. {'target': {'length_mm': 40}}"
            )
    data = deep_merge(read_spec_dict(env_id, path), overrides)
    if overrides is None:
        return validate(data, where)
    return dataclasses.replace(validate(data, f"{where} with spec_overrides"), path=where)

"""Scene loading, overrides and validation: every bad input is one clear error."""

from __future__ import annotations

import math

import pytest

from bathprint import SceneError, builtin_scene_names, load_scene
from bathprint.core.scene import parse_override

REQUIRED_SCENES = {
    "paper_simulation",
    "rope_coiling_18G",
    "drag_coiling_22G",
    "period_doubling_22G",
    "chaotic_crumpling_22G",
}


def test_builtin_scenes_load_and_include_the_paper_regimes() -> None:
    names = set(builtin_scene_names())
    assert REQUIRED_SCENES <= names
    for name in names:
        assert load_scene(name).name == name


def test_paper_simulation_has_the_papers_parameters() -> None:
    s = load_scene("paper_simulation")
    assert s.material.youngs_modulus_pa == 4800.0
    assert s.flow.q_outer_ml_min == 10.0
    assert s.needle.inner_diameter_mm == 1.0
    assert s.material.density_kg_m3 - s.bath.density_kg_m3 == pytest.approx(15.0)


@pytest.mark.parametrize(
    "key, value",
    [
        ("needle.inner_diameter_mm", 0.41),
        ("flow.q_outer_ml_min", 5.0),
        ("flow.q_inner_ml_min", 1.0),
        ("material.youngs_modulus_pa", 2700.0),
        ("bath.viscosity_pa_s", 2e-3),
        ("duration_s", 0.5),
    ],
)
def test_overrides_by_dotted_key(key: str, value: float) -> None:
    extra = {"effects": ["elasticity", "drag", "inclusions"]} if "inner" in key else {}
    s = load_scene("paper_simulation", {key: value, **extra})
    obj = s
    for part in key.split("."):
        obj = getattr(obj, part)
    assert obj == value


def test_cli_and_python_overrides_agree() -> None:
    key, value = parse_override("needle.inner_diameter_mm=0.41")
    assert load_scene("paper_simulation", {key: value}) == load_scene(
        "paper_simulation", {"needle.inner_diameter_mm": 0.41}
    )
    assert parse_override("needle.direction=[1, 0, 0]") == ("needle.direction", [1, 0, 0])
    assert parse_override("numerics.integrator=explicit") == ("numerics.integrator", "explicit")


@pytest.mark.parametrize(
    "overrides, words",
    [
        ({"needle.inner_diameter_mmm": 1.0}, ["needle.inner_diameter_mmm", "unknown"]),
        ({"flow.q_outer_ml_min": -1.0}, ["flow.q_outer_ml_min", "-1.0", "[0, 1000]"]),
        ({"material.youngs_modulus_pa": 0.0}, ["material.youngs_modulus_pa", "0.0", "(1,"]),
        ({"bath.viscosity_pa_s": math.nan}, ["bath.viscosity_pa_s", "nan"]),
        ({"bath.viscosity_pa_s": 1e4}, ["bath.viscosity_pa_s", "10000.0", "1e-05"]),
        ({"needle.inner_diameter_mm": "wide"}, ["needle.inner_diameter_mm", "wide", "number"]),
        ({"effects": ["elasticity", "drag", "magic"]}, ["magic", "allowed", "floor"]),
        ({"effects": ["elasticity"]}, ["drag", "singular"]),
        ({"numerics.integrator": "rk99"}, ["numerics.integrator", "rk99", "implicit"]),
        ({"duration_s": None}, ["duration_s", "missing"]),
        ({"flow.schedule": [[0.0, 1.0, 0.0], [-1.0, 1.0, 0.0]]}, ["flow.schedule[1]"]),
        ({"flow.schedule": [[1.0, 1.0, 0.0], [0.5, 1.0, 0.0]]}, ["does not rise"]),
        ({"needle.direction": [0.0, 0.0, 0.0]}, ["needle.direction", "non-zero"]),
        ({"numerics.node_spacing_mm": 0.01}, ["numerics.node_spacing_mm", "radius"]),
    ],
)
def test_bad_input_is_one_clear_error(overrides: dict, words: list[str]) -> None:
    with pytest.raises(SceneError) as err:
        load_scene("paper_simulation", overrides)
    message = str(err.value)
    for w in words:
        assert w in message, message


def test_unknown_scene_lists_the_builtin_ones() -> None:
    with pytest.raises(SceneError, match="paper_simulation"):
        load_scene("no_such_scene")


def test_toml_file_scene(tmp_path) -> None:
    path = tmp_path / "mine.toml"
    path.write_text(
        'name = "mine"\nduration_s = 0.2\n[flow]\nq_outer_ml_min = 2.5\n'
        "[needle]\ninner_diameter_mm = 0.5\n"
    )
    s = load_scene(path)
    assert s.name == "mine" and s.flow.q_outer_ml_min == 2.5
    path.write_text("duration_s = [")
    with pytest.raises(SceneError, match="not valid TOML"):
        load_scene(path)


def test_scene_round_trips_through_a_dict() -> None:
    s = load_scene("drag_coiling_22G")
    assert load_scene(s.to_dict()) == s


def test_accuracy_presets_set_tolerance_growth_and_resolution() -> None:
    from bathprint.core.model import compile_model, effective_numerics

    base = load_scene("drag_coiling_22G")
    draft = load_scene("drag_coiling_22G", {"numerics.accuracy": "draft"})
    fine = load_scene("drag_coiling_22G", {"numerics.accuracy": "fine"})
    assert effective_numerics(base)["tolerance"] == base.numerics.tolerance  # custom: raw keys
    assert effective_numerics(draft)["tolerance"] > effective_numerics(fine)["tolerance"]
    assert effective_numerics(draft)["node_spacing_mm"] == 2 * base.numerics.node_spacing_mm
    assert compile_model(fine).node_spacing == pytest.approx(0.5e-3 * base.numerics.node_spacing_mm)
    with pytest.raises(SceneError, match="numerics.accuracy"):
        load_scene("drag_coiling_22G", {"numerics.accuracy": "perfect"})


@pytest.mark.parametrize(
    "overrides, words",
    [
        ({"effects": "drag"}, ["effects = 'drag'", "string", 'effects=["drag", ...]']),
        ({"effects": "drag gravity"}, ['effects=["drag", "gravity"]']),
        ({"effects": 3}, ["effects = 3", "not a list"]),
        ({"effects": ["drag", 1]}, ["effects", "holds 1", "effect name"]),
        ({"effects": ["drag", ["gravity"]]}, ["effects", "holds ['gravity']"]),
        ({"needle.path": 5}, ["needle.path = 5", "list of rows"]),
        ({"needle.path": "0,0,0"}, ["needle.path", "not a list"]),
        ({"flow.schedule": [0.0, 1.0, 0.0]}, ["flow.schedule", "one row", "[[0.0, 1.0, 0.0]]"]),
        ({"flow.schedule": 2.0}, ["flow.schedule = 2.0", "list of rows"]),
        ({"flow.schedule": [[0.0, 1.0, "x"]]}, ["flow.schedule[0]", "'x'", "finite numbers"]),
        ({"flow.schedule": [[0.0, 10**400, 0.0]]}, ["flow.schedule[0]", "finite"]),
        ({"flow.schedule": [[0.0, 0.5, 0.1]]}, ["flow.schedule[0]", "inclusions"]),
        ({"bath": 3}, ["bath = 3", "table of keys", "bath.viscosity_pa_s"]),
        ({"numerics": "fine"}, ["numerics = 'fine'", "table of keys"]),
        ({"needle.position_mm": 5.0}, ["needle.position_mm = 5.0", "list of 3 numbers"]),
        ({"needle.position_mm": [0, 0, 1e9]}, ["needle.position_mm = [0, 0, 1000000000.0]"]),
        ({"needle.direction": [0, 0, "down"]}, ["needle.direction", "'down'"]),
        ({"seed": 1.5}, ["seed = 1.5", "integer"]),
        ({"seed": 10**400}, ["seed", "an integer in [0, 2147483647]"]),
        ({"duration_s": 10**400}, ["duration_s", "outside"]),
        ({"outputs.plot": 1}, ["outputs.plot = 1", "true or false"]),
        ({"numerics.integrator": ["implicit"]}, ["numerics.integrator", "unknown"]),
        ({"name": 3}, ["name = 3", "string"]),
        ({"initial.length_mm": 1e-200}, ["initial.length_mm", "0.001"]),
        (
            {"needle.path": [[0, 0, 0, -5, 0, 0, 0]]},
            ["needle.path[0] direction", "non-zero"],
        ),
        ({"needle.path": [[0, 0, 0, -5, 0, 0, -2]]}, ["needle.path[0] dz = -2", "[-1, 1]"]),
        ({"needle.path": [[0, 1e5, 0, -5, 0, 0, -1]]}, ["needle.path[0] x_mm", "10000"]),
        (
            {"needle.inner_diameter_mm": 11.0},
            ["numerics.node_spacing_mm", "needle.inner_diameter_mm", "allowed"],
        ),
    ],
)
def test_wrong_readings_are_refused_by_name(overrides: dict, words: list[str]) -> None:
    with pytest.raises(SceneError) as err:
        load_scene("paper_simulation", overrides)
    for w in words:
        assert w in str(err.value), str(err.value)


def test_rows_are_read_as_lists_and_files_and_types_are_checked(tmp_path) -> None:
    s = load_scene("paper_simulation", {"flow.schedule": [(0.0, 1.0, 0.0), (1.0, 2.0, 0.0)]})
    assert s.flow.schedule == [[0.0, 1.0, 0.0], [1.0, 2.0, 0.0]]
    assert load_scene(s.to_dict()) == s
    s = load_scene("paper_simulation", {"effects": ("elasticity", "drag")})
    assert s.effects == ["elasticity", "drag"]
    with pytest.raises(SceneError, match="is a directory"):
        load_scene("paper_simulation", {"flow.schedule_csv": str(tmp_path)})
    binary = tmp_path / "flow.csv"
    binary.write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(SceneError, match="flow.schedule_csv .* cannot be read"):
        load_scene("paper_simulation", {"flow.schedule_csv": str(binary)})
    with pytest.raises(SceneError, match="is a directory"):
        load_scene(tmp_path)
    with pytest.raises(SceneError, match="scene = 42"):
        load_scene(42)  # type: ignore[arg-type]
    with pytest.raises(SceneError, match="override key 3"):
        load_scene("paper_simulation", {3: 1.0})  # type: ignore[dict-item]
    with pytest.raises(SceneError, match="overrides"):
        load_scene("paper_simulation", [("seed", 1)])  # type: ignore[arg-type]


def test_physics_presets_decide_inertia_contact_hydrodynamics_and_the_drag_law() -> None:
    from bathprint.core.scene import PHYSICS_PRESETS, PRESET_EFFECTS

    base = {"effects": ["elasticity", "drag", "gravity", "floor", "inertia", "hydrodynamics"]}
    for name, preset in PHYSICS_PRESETS.items():
        scene = load_scene({**base, "physics": name})  # a scene file's effects
        assert scene.physics == name
        assert scene.drag.model == preset["drag.model"]
        assert [e for e in scene.effects if e in PRESET_EFFECTS] == list(preset["effects"])
        assert scene.effects[:4] == ["elasticity", "drag", "gravity", "floor"]  # kept
        assert load_scene(scene.to_dict()) == scene  # idempotent: written out, read back
    custom = load_scene(base)
    assert custom.physics == "custom" and custom.effects == base["effects"]


def test_unknown_physics_preset_is_refused_by_name() -> None:
    with pytest.raises(SceneError, match=r"physics = 'paper'.*'minimal'"):
        load_scene("paper_simulation", {"physics": "paper"})


def test_overridden_effects_that_a_preset_would_change_are_refused() -> None:
    preset_scene = {"physics": "experiment", "effects": ["elasticity", "drag", "gravity"]}
    over = {"effects": ["elasticity", "drag", "gravity", "inertia"]}
    with pytest.raises(SceneError, match=r"physics = 'experiment' decides.*'custom'"):
        load_scene(preset_scene, over)
    assert "inertia" in load_scene(preset_scene, {**over, "physics": "custom"}).effects
    agree = {"effects": ["elasticity", "drag", "gravity", "contact"]}
    assert load_scene(preset_scene, agree).effects[-1] == "contact"
    # overriding physics as well applies the preset to the list given
    both = load_scene(preset_scene, {**over, "physics": "experiment"})
    assert both.effects == ["elasticity", "drag", "gravity", "contact"]


@pytest.mark.parametrize(
    ("scene", "preset"),
    [
        ("drag_coiling_22G", "experiment"),
        ("period_doubling_22G", "experiment"),
        ("chaotic_crumpling_22G", "experiment"),
        ("rope_coiling_18G", "experiment"),
        ("paper_simulation", "minimal"),
    ],
)
def test_built_in_scenes_are_the_model_their_docs_name(scene: str, preset: str) -> None:
    # the Fig. 1B scenes are the experiment model, paper_simulation the paper's minimal one:
    # applying the preset changes nothing else
    plain = load_scene(scene)
    with_preset = load_scene(scene, {"physics": preset})
    assert with_preset.effects == plain.effects
    assert with_preset.drag == plain.drag

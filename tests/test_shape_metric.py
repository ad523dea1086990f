"""The whole-shape error (bathprint.envs.shape_metric): invariant under the motions each
family allows, not under a reflection of a helix, independent of the input spacing; a
90-degree bend of a test shape fails."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bathprint.envs import shapes
from bathprint.envs.shape_geometry import bend, resample
from bathprint.envs.shape_metric import (
    FILAMENT_DIAMETER_MM,
    THRESHOLDS,
    shape_error,
)


def _rotation(rng: np.random.Generator) -> np.ndarray:
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    q = q * np.sign(np.diag(r))
    if np.linalg.det(q) < 0:
        q[:, 0] = -q[:, 0]
    return q


def _yaw(a: float) -> np.ndarray:
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def _shape(family: str, name: str) -> np.ndarray:
    return shapes.named_shapes(family, "test")[name].points_mm


@pytest.mark.parametrize("seed", range(5))
def test_invariant_under_allowed_motions(seed: int) -> None:
    rng = np.random.default_rng(seed)
    helix = _shape("free", "barrel_3.5_5.5")
    moved = helix @ _rotation(rng).T + rng.normal(scale=20.0, size=3)
    assert shape_error(moved, helix, "free").rms_mm < 1e-9
    letter = _shape("floor", "letter_S")
    moved = letter @ _yaw(rng.uniform(0, 2 * math.pi)).T + rng.normal(scale=20.0, size=3)
    e = shape_error(moved, letter, "floor")
    assert e.rms_mm < 1e-9 and e.success
    layers = _shape("buoyant", "layers_15_70_35")
    shift = np.r_[rng.normal(scale=20.0, size=2), 0.0]
    moved = layers @ _yaw(rng.uniform(0, 2 * math.pi)).T + shift
    assert shape_error(moved, layers, "buoyant").rms_mm < 1e-9


def test_motions_a_family_does_not_allow_cost() -> None:
    letter = _shape("floor", "letter_S")
    tilted = letter @ np.array([[1, 0, 0], [0, 0, -1], [0, 1, 0]], float).T  # stood upright
    assert not shape_error(tilted, letter, "floor").success
    layers = _shape("buoyant", "layers_20_60")
    assert shape_error(layers + [0, 0, -10.0], layers, "buoyant").rms_mm == pytest.approx(10.0)


def test_reflection_of_a_helix_is_not_a_match() -> None:
    helix = _shape("free", "barrel_3.5_5.5")  # pitch 2 mm: clearly chiral
    mirrored = helix * [1.0, 1.0, -1.0]
    e = shape_error(mirrored, helix, "free")
    assert e.rms_mm > THRESHOLDS["free"].rms_max_mm and not e.success
    letter = _shape("floor", "letter_S")
    assert not shape_error(letter * [-1.0, 1.0, 1.0], letter, "floor").success


@pytest.mark.parametrize("family,axis", [("floor", (0, 0, 1)), ("free", (1, 0, 0))])
def test_ninety_degree_bend_fails(family: str, axis: tuple[float, float, float]) -> None:
    for name, s in shapes.named_shapes(family, "test").items():
        if not s.writable:
            continue
        assert shape_error(s.points_mm, s.points_mm, family).success
        e = shape_error(bend(s.points_mm, 90.0, axis), s.points_mm, family)
        assert not e.success, (name, e)


def test_buoyant_part_at_the_wrong_height_fails() -> None:
    s = _shape("buoyant", "layers_20_60")
    wrong = s.copy()
    wrong[len(s) // 2 :, 2] -= 15.0  # the second layer one gap too deep
    assert not shape_error(wrong, s, "buoyant").success


def test_independent_of_input_spacing() -> None:
    s = _shape("floor", "letter_C")
    written = bend(s, 20.0)
    a = shape_error(written, s, "floor")
    coarse = resample(written, n=len(written) // 4)  # every ~1 mm, ends kept
    rng = np.random.default_rng(0)
    uneven = written[np.sort(rng.choice(len(written), len(written) // 2, replace=False))]
    uneven = np.concatenate([written[:1], uneven, written[-1:]])
    for w in (coarse, uneven, resample(written, n=5 * len(written))):
        b = shape_error(w, s, "floor")
        assert b.rms_mm == pytest.approx(a.rms_mm, rel=0.03, abs=0.02)


def test_thresholds_are_stated_against_the_filament() -> None:
    for thr in THRESHOLDS.values():
        assert thr.rms_max_mm >= FILAMENT_DIAMETER_MM and thr.max_max_mm > thr.rms_max_mm
        assert thr.why


def test_filament_diameter_is_every_environments_needle() -> None:
    import tomllib

    from bathprint.core.scene import load_scene
    from bathprint.envs.spec import specs_dir

    bases = set()
    for spec in specs_dir().glob("*.toml"):
        data = tomllib.loads(spec.read_text())
        bases.add(data.get("scene", {}).get("base", "gelation_coiling_22G"))
        assert "needle.inner_diameter_mm" not in data.get("scene", {}).get("overrides", {})
    for base in bases:
        assert load_scene(base).needle.inner_diameter_mm == pytest.approx(FILAMENT_DIAMETER_MM)


def test_bad_family() -> None:
    s = _shape("floor", "line_60")
    with pytest.raises(ValueError, match="family"):
        shape_error(s, s, "wall")

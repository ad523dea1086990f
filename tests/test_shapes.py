"""Shape families and their sets (bathprint.envs.shapes): valid generators, fixed named
shapes that match the committed files, disjoint sets, feasibility marks."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from bathprint.envs import shapes
from bathprint.envs.shape_geometry import length_mm, self_contacts
from bathprint.envs.shape_metric import arclength_axes

FAMILIES = tuple(shapes.FAMILIES)


@pytest.mark.parametrize("family", FAMILIES)
def test_generator_is_deterministic_and_valid(family: str) -> None:
    gen = shapes.ShapeGenerator(family)
    a = [gen.sample(np.random.default_rng(7)).key for _ in range(2)]
    assert a[0] == a[1]
    rng = np.random.default_rng(0)
    mod = shapes.FAMILIES[family]
    lo, hi = shapes.LENGTH_RANGE_MM
    for _ in range(25):
        s = gen.sample(rng)
        assert s.kind in mod.TRAIN_KINDS
        assert s.writable and not s.issues
        assert lo <= s.length_mm <= hi
        assert np.isfinite(s.points_mm).all() and s.points_mm.shape[1] == 3


@pytest.mark.parametrize("family", FAMILIES)
def test_named_shapes_lengths_and_marks(family: str) -> None:
    lo, hi = shapes.LENGTH_RANGE_MM
    for set_name in shapes.HELD_OUT_SETS:
        named = shapes.named_shapes(family, set_name)
        assert named, (family, set_name)
        for s in named.values():
            assert lo <= s.length_mm <= hi, (s.name, s.length_mm)
            assert s.writable == (not s.issues)


def test_unwritable_shapes_are_marked_not_dropped() -> None:
    test = {n: s for f in FAMILIES for n, s in shapes.named_shapes(f, "test").items()}
    assert not test["letter_V_sharp"].writable
    assert "corner" in test["letter_V_sharp"].issues[0]
    assert any("overlap" in i for i in test["barrel_overlapping"].issues)
    assert any("height" in i for i in test["layers_surface_floor"].issues)
    ood = shapes.named_shapes("floor", "ood_test")
    assert any("reversal" in i for i in ood["digit_3"].issues)
    assert test["letter_C"].writable and test["line_60"].writable


@pytest.mark.parametrize("family", FAMILIES)
def test_sets_are_disjoint(family: str) -> None:
    mod = shapes.FAMILIES[family]
    keys = {
        s: {shapes.params_key(p) for p in shapes.named_params(family, s).values()}
        for s in shapes.HELD_OUT_SETS
    }
    assert not keys["validation"] & keys["test"]
    assert not keys["validation"] & keys["ood_test"]
    assert not keys["test"] & keys["ood_test"]
    names = [n for s in shapes.HELD_OUT_SETS for n in shapes.named_params(family, s)]
    assert len(names) == len(set(names))
    # the out-of-distribution set holds only held-out kinds; the others only training kinds
    assert not set(mod.TRAIN_KINDS) & set(mod.OOD_KINDS)
    for p in shapes.named_params(family, "ood_test").values():
        assert p["kind"] in mod.OOD_KINDS
    for s in ("validation", "test"):
        for p in shapes.named_params(family, s).values():
            assert p["kind"] in mod.TRAIN_KINDS
    # training never draws a held-out shape or kind
    gen = shapes.ShapeGenerator(family)
    rng = np.random.default_rng(1)
    held = shapes.held_out_keys(family)
    for _ in range(500):
        p = gen.sample_params(rng)
        assert shapes.params_key(p) not in held and p["kind"] in mod.TRAIN_KINDS


def test_generator_rejects_held_out_draws() -> None:
    """A family module that draws a held-out shape: the generator draws again."""
    gen = shapes.ShapeGenerator("floor")
    held = shapes.named_params("floor", "test")["line_60"]
    calls = iter([held, held, {**held, "length_mm": 55.0}])
    gen.module = type("M", (), {"sample_params": staticmethod(lambda rng: next(calls))})
    assert gen.sample_params(np.random.default_rng(0))["length_mm"] == 55.0


def test_buoyant_training_has_no_staircase() -> None:
    rng = np.random.default_rng(3)
    for _ in range(300):
        p = shapes.buoyant.sample_params(rng)
        assert not shapes.buoyant.is_staircase(p["heights_mm"])
        z = np.asarray(p["heights_mm"])
        assert np.min(np.abs(np.subtract.outer(z, z))[~np.eye(len(z), dtype=bool)]) >= 15.0


def test_committed_files_match_the_generators() -> None:
    root = shapes.shapes_dir()
    index = json.loads((root / "index.json").read_text())
    rows = {(r["family"], r["set"], r["name"]): r for r in index["shapes"]}
    for family in FAMILIES:
        for set_name in shapes.HELD_OUT_SETS:
            for name, s in shapes.named_shapes(family, set_name).items():
                path = shapes.shape_path(family, set_name, name)
                with path.open() as f:
                    r = list(csv.reader(f))
                assert r[0] == ["x_mm", "y_mm", "z_mm"]
                pts = np.array(r[1:], float)
                np.testing.assert_allclose(pts, s.points_mm, atol=6e-5)
                meta = rows[(family, set_name, name)]
                assert meta["writable"] == s.writable and meta["key"] == s.key
    assert set(index["families"]) == set(FAMILIES)


def test_free_shapes_do_not_overlap_unless_marked() -> None:
    for set_name in shapes.HELD_OUT_SETS:
        for s in shapes.named_shapes("free", set_name).values():
            hits = self_contacts(s.points_mm, 0.41)
            assert bool(hits) == any("overlap" in i for i in s.issues), s.name


def test_buoyant_length_is_horizontal() -> None:
    s = shapes.named_shapes("buoyant", "test")["layers_20_60"]
    assert abs(length_mm(s.points_mm, arclength_axes("buoyant")) - 40.0) < 0.5
    assert length_mm(s.points_mm) > 75.0  # the 40 mm jump of height is no filament


def test_write_command_regenerates_the_committed_files(tmp_path) -> None:
    from bathprint.envs.shapes.__main__ import main

    assert main(["write", str(tmp_path)]) == 0
    root = shapes.shapes_dir()
    written = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    committed = sorted(p.relative_to(root) for p in root.rglob("*") if p.is_file())
    assert written == committed
    for rel in written:
        assert (tmp_path / rel).read_bytes() == (root / rel).read_bytes(), rel

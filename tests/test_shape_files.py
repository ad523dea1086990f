"""Bring your own shape (bathprint.envs.shape_files): bad files are refused with a
ConfigError naming the file and the problem; good ones become targets."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from bathprint.envs import shapes
from bathprint.envs.metric import MetricParams
from bathprint.envs.shape_files import (
    env_family,
    length_limits,
    load_shape_file,
    settling_height_mm,
    shape_target,
)
from bathprint.errors import ConfigError


def _env(**kw: object) -> SimpleNamespace:
    """The attributes of a version-1 environment the checks read (no simulation)."""
    u = SimpleNamespace(
        env_id="bathprint/Fake-v1",
        metric_params=MetricParams(window_mm=15.0),
        target_length_mm=60.0,
        target_spacing_mm=0.5,
        goal_conditioned=False,
        needle_axes=(0, 1),
        needle_box_mm=[[-40.0, 40.0], [-40.0, 40.0], [-40.0, -3.0]],
        scores_density=False,
        bath_range=None,
        depth_mm=125.0,
    )
    for k, v in kw.items():
        setattr(u, k, v)
    u.unwrapped = u
    return u


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def _csv(path: Path, pts: np.ndarray) -> Path:
    shapes.write_csv(path, pts)
    return path


def test_good_file_loads(tmp_path: Path) -> None:
    s = shapes.named_shapes("floor", "test")["letter_C"]
    pts = load_shape_file(_csv(tmp_path / "c.csv", s.points_mm), _env())
    np.testing.assert_allclose(pts, s.points_mm, atol=1e-4)
    t = shape_target(pts, _env(), "floor", "c.csv")
    assert t.spacing_mm == 0.5 and abs(t.length_mm - s.length_mm) < 0.5


def test_committed_shapes_load(tmp_path: Path) -> None:
    env = _env()
    for name in ("letter_S", "line_60"):
        load_shape_file(shapes.shape_path("floor", "test", name), env)
    free = _env(needle_axes=())
    load_shape_file(shapes.shape_path("free", "test", "barrel_3.5_5.5"), free)


@pytest.mark.parametrize(
    "text,problem",
    [
        ("", "is empty"),
        ("x_mm,y_mm,z_mm\n", "no points"),
        ("x,y,z\n0,0,0\n1,1,1\n", "lacks x_mm, y_mm, z_mm"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,abc,0\n", "row 3, column y_mm: 'abc' is not a number"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,nan,0\n", "row 3 is not finite"),
        ("x_mm,y_mm,z_mm\n0,0,0\n1,inf,0\n", "row 3 is not finite"),
        ("x_mm,y_mm,z_mm\n0,0,0\n5,0,0\n", "too short"),
        ("x_mm,y_mm,z_mm\n0,0,0\n", "too short"),
        ("x_mm,y_mm,z_mm\n0,0,0\n0,70,0\n0,0,0\n", "too long"),
        (
            "x_mm,y_mm,z_mm\n0,0,0\n70,0,0\n",
            "70.0 mm across in x, wider than the needle's 60 mm box",
        ),
    ],
)
def test_bad_files_are_refused(tmp_path: Path, text: str, problem: str) -> None:
    path = _write(tmp_path / "bad.csv", text)
    with pytest.raises(ConfigError, match="bad.csv") as info:
        load_shape_file(path, _env(needle_box_mm=[[-30.0, 30.0], [-40.0, 40.0], [-40.0, -3.0]]))
    assert problem in str(info.value)


def test_missing_and_wrong_suffix(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="nope.csv.*does not exist"):
        load_shape_file(tmp_path / "nope.csv", _env())
    path = _write(tmp_path / "shape.txt", "x_mm,y_mm,z_mm\n0,0,0\n30,0,0\n")
    with pytest.raises(ConfigError, match="shape.txt.*a .csv file"):
        load_shape_file(path, _env())


def test_goal_conditioned_takes_at_most_the_spec_length(tmp_path: Path) -> None:
    path = _csv(tmp_path / "line.csv", np.array([[0.0, 0, 0], [70.0, 0, 0]]))
    load_shape_file(path, _env())
    with pytest.raises(ConfigError, match="line.csv': 70.0 mm.*too long.*15-60 mm"):
        load_shape_file(path, _env(goal_conditioned=True))
    assert length_limits(_env(goal_conditioned=True)) == (15.0, 60.0)


def test_self_intersection_refused_where_the_family_forbids_it(tmp_path: Path) -> None:
    figure8 = shapes.named_shapes("floor", "ood_test")["digit_8"].points_mm  # crosses itself
    path = _csv(tmp_path / "eight.csv", figure8)
    load_shape_file(path, _env())  # floor: a strand may lie across another
    with pytest.raises(ConfigError, match="eight.csv': intersects itself"):
        load_shape_file(path, _env(needle_axes=()))  # free
    load_shape_file(path, _env(needle_axes=()), family="floor")
    load_shape_file(path, _env(needle_axes=()), allow_overlap=True)


def test_family_of_the_environment() -> None:
    assert env_family(_env()) == "floor"
    assert env_family(_env(needle_axes=())) == "free"
    assert env_family(_env(needle_axes=(), scores_density=True)) == "buoyant"


def test_buoyant_target_has_the_bath_density_of_each_height() -> None:
    env = _env(needle_axes=(), scores_density=True, bath_range=(1010.0, 1050.0))
    s = shapes.named_shapes("buoyant", "test")["layers_20_60"]
    t = shape_target(s.points_mm, env, "buoyant", "layers")
    rho = t.density_lo_kg_m3
    np.testing.assert_allclose(rho[:10], 1010.0 + 0.32 * 20.0)
    np.testing.assert_allclose(rho[-10:], 1010.0 + 0.32 * 60.0)
    np.testing.assert_allclose(settling_height_mm(env, rho[[0, -1]]), [-20.0, -60.0])
    assert abs(t.length_mm - 40.0) < 1.0  # horizontal arclength
    with pytest.raises(ConfigError, match="gradient bath"):
        shape_target(s.points_mm, _env(needle_axes=()), "buoyant", "layers")

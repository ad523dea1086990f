"""``bathprint evaluate POLICY --env ID --target-files A.csv``: one row per target and
policy in OUT/targets.csv; bad files refused before any episode (draft preset, short
target)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest

from bathprint.agents.evaluate import TARGET_COLUMNS
from bathprint.cli import main as cli_main
from bathprint.envs.shape_metric import THRESHOLDS
from bathprint.envs.shapes import write_csv
from bathprint.envs.shapes.free import helix

ENV = "bathprint/CoilRadius-v1"


def evaluate_main(argv: list[str]) -> int:
    """``bathprint evaluate ARGV``: its exit code."""
    return cli_main(["evaluate", *argv])


def _helix(path: Path, length: float = 22.0, radius: float = 3.5) -> Path:
    n = int(length / 0.25) + 1
    write_csv(path, helix(np.full(n, radius), np.full(n, 0.5), 0.25))
    return path


def test_target_files_rows(tmp_path: Path) -> None:
    f = _helix(tmp_path / "helix.csv")
    out = tmp_path / "out"
    argv = ["constant", "--env", ENV, "--accuracy", "draft", "--quiet", "--out", str(out)]
    assert evaluate_main(argv + ["--target-files", str(f)]) == 0
    with (out / "targets.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 1
    r = rows[0]
    assert tuple(r) == TARGET_COLUMNS
    assert r["target"] == str(f) and r["policy"] == "constant" and r["family"] == "free"
    rms, mx, m = float(r["rms_mm"]), float(r["max_mm"]), float(r["metric"])
    assert math.isfinite(rms) and 0.0 < rms <= mx and math.isfinite(m)
    thr = THRESHOLDS["free"]
    assert (r["success"] == "True") == (rms <= thr.rms_max_mm and mx <= thr.max_max_mm)
    assert r["truncated"] == "False"


@pytest.mark.parametrize(
    "text,problem",
    [("x_mm,y_mm,z_mm\n0,0,0\n1,nan,0\n", "row 3 is not finite"), ("", "is empty")],
)
def test_bad_target_file_exits_2(tmp_path: Path, capsys, text: str, problem: str) -> None:
    good = _helix(tmp_path / "good.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text(text)
    out = tmp_path / "out"
    argv = ["constant", "--env", ENV, "--accuracy", "draft", "--quiet", "--out", str(out)]
    assert evaluate_main(argv + ["--target-files", str(good), str(bad)]) == 2
    err = capsys.readouterr().err
    assert "bad.csv" in err and problem in err
    assert not (out / "targets.csv").exists()


def test_target_files_need_version_1(tmp_path: Path, capsys) -> None:
    f = _helix(tmp_path / "helix.csv")
    argv = ["constant", "--env", "CoilRadius-v0", "--out", str(tmp_path), "--quiet"]
    assert evaluate_main(argv + ["--target-files", str(f)]) == 2
    assert "version-1" in capsys.readouterr().err


@pytest.mark.parametrize(
    "env_id,family",
    [("WriteShape-v2", "floor"), ("CoilRadius-v1", "free"), ("BuoyantLayers-v1", "buoyant")],
)
def test_replaying_a_printed_target_writes_its_shape(env_id: str, family: str) -> None:
    """A printed test target given as a shape file's points, replayed with the controls that
    printed it: the written curve is the shape (whole-shape error near 0), so the written
    curve, the reference and the alignment are the same samples of filament."""
    import bathprint.envs as E
    from bathprint.envs.shape_files import (
        reference_curve,
        settling_height_mm,
        shape_target,
        written_curve,
    )
    from bathprint.envs.shape_metric import shape_error

    env = E.make(env_id, accuracy="draft", target_set="test")
    t = env.unwrapped.fixed_set_target("test", 0)
    pts = t.points_mm.copy()
    if family == "buoyant":  # a nominal coil, each sample at the height it settles at
        z = settling_height_mm(env, 0.5 * (t.density_lo_kg_m3 + t.density_hi_kg_m3))
        th = t.s_mm / 3.0
        pts = np.column_stack([3.0 * np.cos(th), 3.0 * np.sin(th), z])
    target = shape_target(pts, env, family, "replay")
    env.reset(seed=0, options={"target": target, "start_state": t.params["start_state"]})
    for a in t.actions:
        *_, term, trunc, _ = env.step(a)
        if term or trunc:
            break
    assert term and not trunc
    err = shape_error(written_curve(env, family), reference_curve(pts, env, family), family)
    assert err.success and err.rms_mm < 0.3, err
    env.close()

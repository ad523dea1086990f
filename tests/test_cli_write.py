"""``bathprint write SHAPE.csv --policy controller --out DIR``: a shipped test shape written
with the tuned controller (draft preset) gives every output, result.json holds what the
environment reported, and bad files, policies and options are refused before any
simulation; a DIR of an earlier print is refused unless --overwrite."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest

from bathprint.agents.write import OUTPUTS
from bathprint.cli import main
from bathprint.core.simulation import Simulation
from bathprint.envs.shapes import shape_path

LINE = shape_path("floor", "test", "line_60")


@pytest.fixture
def no_simulation(monkeypatch):
    """Fail the test if a simulation would advance: refusals come before any work."""

    def advance(self, *a, **k):
        raise AssertionError("the simulation ran")

    monkeypatch.setattr(Simulation, "advance", advance)


@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict:
    """One print of line_60 with the controller, and the info the environment reported at
    its end (captured from the episode the command played)."""
    import bathprint.agents.episode_view as ev

    out = tmp_path_factory.mktemp("write") / "line"
    reported: list[dict] = []
    play = ev.play_recorded

    def spy(*a, **k):
        ep = play(*a, **k)
        reported.append(dict(ep.info))
        return ep

    mp = pytest.MonkeyPatch()
    mp.setattr(ev, "play_recorded", spy)
    try:
        code = main(
            ["write", str(LINE), "--policy", "controller", "--accuracy", "draft", "--out", str(out)]
        )
    finally:
        mp.undo()
    return {"code": code, "out": out, "info": reported}


def test_write_gives_every_output(written: dict) -> None:
    out = written["out"]
    assert written["code"] == 0
    assert sorted(p.name for p in out.iterdir()) == sorted(OUTPUTS)
    r = json.loads((out / "result.json").read_text())
    assert sorted(r["files"]) == sorted(OUTPUTS)
    assert r["env_id"] == "bathprint/WriteShape-v3" and r["family"] == "floor"
    assert r["policy"] == "controller" and r["accuracy"] == "draft" and r["seed"] == 0
    assert r["shape_sha1"] == hashlib.sha1(LINE.read_bytes()).hexdigest()
    assert r["complete"] and r["sim_error"] is None and r["steps"] > 0 and r["wall_s"] > 0
    assert {"bathprint", "commit"} <= set(r) and r["view_html_missing"] is None
    page = (out / "view.html").read_text()
    assert page.startswith("<!DOCTYPE html>") and 'id="bathprint-data"' in page


def test_result_holds_what_the_environment_reported(written: dict) -> None:
    (info,) = written["info"]
    r = json.loads((written["out"] / "result.json").read_text())
    assert r["rms_mm"] == info["rms_mm"] and r["max_mm"] == info["max_mm"]
    assert r["success"] == info["is_success"] and r["local_metric"] == info["local_metric"]
    assert r["success"] == (r["rms_mm"] <= r["rms_max_mm"] and r["max_mm"] <= r["max_max_mm"])


def test_written_and_target_files_give_the_reported_error(written: dict) -> None:
    """written.csv and target.csv are shape files (bathprint write reads them back) whose
    whole-shape error is the one reported (to the files' 4 decimals), and target.csv is the
    shape as the environment places it."""
    import bathprint.envs as E
    from bathprint.envs.shape_files import read_points
    from bathprint.envs.shape_metric import shape_error

    out = written["out"]
    w, t = read_points(out / "written.csv"), read_points(out / "target.csv")
    r = json.loads((out / "result.json").read_text())
    assert len(w) == len(t) == r["target_samples"] == r["written_samples"]
    err = shape_error(w, t, "floor")
    assert err.rms_mm == pytest.approx(r["rms_mm"], abs=1e-3)
    assert err.max_mm == pytest.approx(r["max_mm"], abs=1e-3)
    env = E.make("WriteShape-v3", accuracy="draft")
    placed = env.unwrapped.shape_target(read_points(LINE), LINE.name).points_mm
    env.close()
    np.testing.assert_allclose(t, placed, atol=1e-4)


def test_picture_is_an_image(written: dict) -> None:
    from matplotlib.image import imread

    png = written["out"] / "written.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    img = imread(png)
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 200
    assert np.ptp(img[..., :3]) > 0.5  # not blank


@pytest.mark.parametrize(
    "name,text,problem",
    [
        ("missing.csv", None, "does not exist"),
        ("nan.csv", "x_mm,y_mm,z_mm\n0,0,0\n1,nan,0\n2,0,0\n", "row 3 is not finite"),
        ("short.csv", "x_mm,y_mm,z_mm\n0,0,0\n1,0,0\n", "too short"),
    ],
)
def test_bad_file_exits_2_and_names_it(
    name: str, text: str | None, problem: str, tmp_path: Path, capsys, no_simulation
) -> None:
    bad = tmp_path / name
    if text is not None:
        bad.write_text(text)
    out = tmp_path / "out"
    assert main(["write", str(bad), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert str(bad) in err and problem in err, err
    assert not out.exists()


@pytest.mark.parametrize(
    "argv,words",
    [
        (["--policy", "nonsense"], ["--policy", "'nonsense'", "controller", "run directory"]),
        (["--env", "CoilRadius-v1"], ["CoilRadius-v1", "spec version 3", "WriteShape-v3"]),
        (["--env", "CoilRadius-v2", "--family", "floor"], ["--family", "writes free shapes"]),
        (["--seed", "-1"], ["--seed", ">= 0"]),
    ],
)
def test_bad_options_exit_2(
    argv: list[str], words: list[str], tmp_path: Path, capsys, no_simulation
) -> None:
    assert main(["write", str(LINE), *argv, "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for w in words:
        assert w in err, err


def test_unknown_family_exits_2(tmp_path: Path, capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["write", str(LINE), "--family", "wavy", "--out", str(tmp_path)])
    assert exc.value.code == 2
    assert "--family" in capsys.readouterr().err


def test_earlier_print_is_refused_unless_overwrite(tmp_path: Path, capsys, monkeypatch) -> None:
    """A DIR holding a file of an earlier print is refused (nothing changes); --overwrite
    replaces every file of it: without the viewer extra no view.html is left from before,
    and the command says which extra the page needs."""
    import bathprint._extras as extras

    out = tmp_path / "out"
    out.mkdir()
    (out / "result.json").write_text("earlier")
    (out / "view.html").write_text("earlier")
    (out / "notes.txt").write_text("mine")
    assert main(["write", str(LINE), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "already holds result.json, view.html" in err and "--overwrite" in err, err
    assert (out / "result.json").read_text() == "earlier"

    real = extras.available
    monkeypatch.setattr(extras, "available", lambda m: m != "plotly" and real(m))
    assert main(["write", str(LINE), "--out", str(out), "--overwrite"]) == 0
    captured = capsys.readouterr()
    assert "RMS" in captured.out and str(out) in captured.out
    assert "view.html not written" in captured.err and "bathprint[viewer]" in captured.err
    assert not (out / "view.html").exists() and (out / "notes.txt").read_text() == "mine"
    r = json.loads((out / "result.json").read_text())
    assert "view.html" not in r["files"] and "'viewer' extra" in r["view_html_missing"]


def test_a_diverged_print_writes_its_part_and_exits_3(tmp_path: Path, capsys, monkeypatch) -> None:
    """The simulation diverging at the 50th step: every file of the part written, and exit
    code 3 (bathprint's code for a diverged simulation)."""
    import bathprint.envs.shape_env as se
    from bathprint.errors import SimulationError

    calls = {"n": 0}
    real = se.advance_to

    def advance_to(sim, t_end, max_substeps):
        calls["n"] += 1
        if calls["n"] == 50:
            raise SimulationError("a test's divergence", t_end, 0)
        real(sim, t_end, max_substeps)

    monkeypatch.setattr(se, "advance_to", advance_to)
    out = tmp_path / "out"
    assert main(["write", str(LINE), "--out", str(out)]) == 3
    assert "diverged" in capsys.readouterr().out
    r = json.loads((out / "result.json").read_text())
    assert not r["complete"] and "a test's divergence" in r["sim_error"]
    assert not r["success"] and r["steps"] == 50 and r["local_metric"] is None
    assert 0 < r["written_samples"] < r["target_samples"]
    assert sorted(p.name for p in out.iterdir()) == sorted(OUTPUTS)


def test_a_trained_policy_writes_on_its_own_environment() -> None:
    """Without --env and --family a trained policy writes on the environment it was trained
    on; another environment is refused, naming the one it needs."""
    from bathprint.agents.write import choose_env
    from bathprint.errors import ConfigError

    assert choose_env(None, None) == ("bathprint/WriteShape-v3", "floor")
    assert choose_env("buoyant", None) == ("bathprint/BuoyantLayers-v2", "buoyant")
    assert choose_env(None, "CoilRadius") == ("bathprint/CoilRadius-v2", "free")
    trained = "bathprint/CoilRadius-v2"
    assert choose_env(None, None, trained) == (trained, "free")
    with pytest.raises(ConfigError, match="trained on bathprint/CoilRadius-v2.*--env"):
        choose_env("floor", None, trained)

"""bathprint view (the interactive 3D page) and filament.png's framing.

The page is opened in a real headless Chromium through Playwright: it must load without
console errors or requests beyond the file itself, draw a canvas that is not blank, and
play, pause, scrub and recolour. Without Playwright or a Chromium on the machine those
tests are skipped with the reason (``.ci/run`` installs Debian's chromium where it can).
"""

from __future__ import annotations

import io
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

from bathprint.cli import main
from bathprint.viz.plotting import region_of_interest, scale_bar_length
from bathprint.viz.view import COLOUR_COLUMNS, ViewData, write_page

CHROMIUM_ARGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]


def _chromium() -> str | None:
    for name in (os.environ.get("BATHPRINT_CHROMIUM", ""), "chromium", "chromium-browser"):
        if name and shutil.which(name):
            return shutil.which(name)
    return None


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    """A short drag-coiling run (a few frames) written by bathprint simulate."""
    out = tmp_path_factory.mktemp("run") / "drag"
    code = main(
        [
            "simulate",
            "drag_coiling_22G",
            "--quiet",
            "--out",
            str(out),
            "--set",
            "duration_s=1.0",
            "--set",
            "outputs.frame_interval_s=0.1",
        ]
    )
    assert code == 0
    return out


@pytest.fixture(scope="module")
def page(run_dir: Path) -> Path:
    out = run_dir / "view.html"
    assert main(["view", str(run_dir), "--out", str(out), "--colour", "density"]) == 0
    return out


def test_run_dir_has_scene_and_picture(run_dir: Path):
    """simulate writes the scene it ran (read back by the viewer) beside the picture."""
    assert (run_dir / "scene.toml").is_file()
    assert (run_dir / "filament.png").stat().st_size > 10_000
    from bathprint.core.scene import load_scene

    scene = load_scene(run_dir / "scene.toml")
    assert scene.name == "drag_coiling_22G" and scene.duration_s == pytest.approx(1.0)


def test_page_is_self_contained(page: Path):
    text = page.read_text(encoding="utf-8")
    assert "<script src" not in text.lower() and "<link" not in text.lower()
    assert "Plotly.newPlot" in text and "bathprint-data" in text
    data = json.loads(text.split('id="bathprint-data">', 1)[1].split("</script>", 1)[0])
    assert data["colour"] == "density"
    assert set(data["columns"]) == set(COLOUR_COLUMNS)
    z = np.load(page.parent / "trajectory.npz")
    assert len(data["time"]) == len(z["time_s"])
    assert data["start"][-1] == len(z["positions_m"])  # every frame's every node
    assert np.allclose(data["x"], 1e3 * z["positions_m"][:, 0], atol=6e-4)  # mm, 3 decimals


def test_png_draws_the_last_frame_as_filament_png_does(run_dir: Path, tmp_path: Path, capsys):
    """view --png (or --out FILE.png) writes the picture simulate writes, from the run
    directory alone; it refuses what only the page can do."""
    import matplotlib.image as mpimg

    assert main(["view", str(run_dir), "--png"]) == 0
    drawn = mpimg.imread(run_dir / "view.png")
    assert drawn.shape == mpimg.imread(run_dir / "filament.png").shape
    assert np.array_equal(drawn, mpimg.imread(run_dir / "filament.png"))
    out = tmp_path / "pic.png"
    assert main(["view", str(run_dir), "--out", str(out)]) == 0 and out.stat().st_size > 10_000
    capsys.readouterr()
    for argv in (
        ["view", "--env", "CoilRadius", "--png"],
        ["view", str(run_dir), "--png", "--colour", "density"],
        ["view", str(tmp_path / "missing"), "--png"],
    ):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("bathprint view:") and "\n" not in err, (argv, err)


def test_view_refusals(tmp_path: Path, capsys):
    for argv in (
        ["view"],  # neither a run nor --env
        ["view", str(tmp_path), "--env", "CoilRadius-v0"],  # both
        ["view", str(tmp_path / "missing")],
        ["view", str(tmp_path)],  # a directory without trajectory.npz
        ["view", "--env", "NoSuchEnv"],
        ["view", "--env", "CoilRadius-v0", "--policy", str(tmp_path / "no_run")],
        ["view", "--env", "CoilRadius-v0", "--target-index", "999"],
    ):
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("bathprint view:") and "\n" not in err, (argv, err)


def test_view_env_plays_a_version_1_test_target(tmp_path: Path, capsys):
    """A version-1 environment's episode page plays its test set (version 0's ``eval`` set
    does not exist there), and its target index is checked against that set."""
    out = tmp_path / "episode.html"
    argv = ["view", "--env", "CoilRadius-v1", "--policy", "constant", "--accuracy", "draft"]
    assert main([*argv, "--out", str(out)]) == 0
    text = out.read_text(encoding="utf-8")
    assert "target" in text and len(text) > 10_000
    capsys.readouterr()
    assert main([*argv, "--target-index", "16", "--out", str(tmp_path / "x.html")]) == 2
    err = capsys.readouterr().err.strip()
    assert "test set of bathprint/CoilRadius-v1 has 16 targets" in err, err


def test_colour_choices_refused_by_argparse(tmp_path: Path):
    with pytest.raises(SystemExit) as exc:
        main(["view", str(tmp_path), "--colour", "stiffness"])
    assert exc.value.code == 2


def _helix_below_stem(turns: float, radius: float = 4.0, stem: float = 10.0) -> np.ndarray:
    """A straight stem from the needle (at z = 0, the last node) into a helix below it;
    free end first. mm."""
    s = np.linspace(0.0, turns * 2 * np.pi * radius, 4000)
    phi = s / radius
    helix = np.stack([radius * np.cos(phi) - radius, radius * np.sin(phi), -stem - 0.2 * s], 1)
    stem_pts = np.stack([np.zeros(50), np.zeros(50), np.linspace(0.0, -stem, 50)], 1)
    return np.vstack([stem_pts, helix])[::-1]


def test_region_of_interest_frames_a_few_turns():
    c = _helix_below_stem(turns=12.0)
    m = {"coil_radius_m": 4e-3, "buckling_length_m": 10e-3}
    keep = region_of_interest(c, m, turns=3.0)
    assert keep[-1] and not keep[0]  # the needle in, the oldest turns out
    seg = np.linalg.norm(np.diff(c, axis=0), axis=1)
    kept_length = seg[keep[1:] & keep[:-1]].sum()
    assert kept_length == pytest.approx(10.0 + 3 * 2 * np.pi * 4.0, rel=0.02)
    # no measured coil: everything
    assert region_of_interest(c, {"coil_radius_m": None}).all()
    assert region_of_interest(c, None).all()


@pytest.mark.parametrize(
    ("span", "bar"), [(100.0, 20.0), (48.0, 5.0), (12.0, 2.0), (3.0, 0.5), (0.7, 0.1)]
)
def test_scale_bar_is_round_and_about_a_fifth(span: float, bar: float):
    assert scale_bar_length(span) == pytest.approx(bar)
    assert span / 10 <= scale_bar_length(span) <= span / 5


def _synthetic(tmp_path: Path) -> Path:
    """A page of a growing straight filament with known birth times."""
    frames = [np.stack([np.zeros(n), np.zeros(n), -np.arange(n)[::-1] - 5.0], 1) for n in (3, 5, 8)]
    birth = np.array([0.0, 0.0, 0.1, 0.2, 0.3, 0.4, 0.5])
    data = ViewData(
        title="synthetic",
        times_s=np.array([0.1, 0.3, 0.6]),
        frames=frames,
        columns={"age": birth, "density": np.linspace(1000.0, 1060.0, 7)},
        needle_direction=np.tile([0.0, 0.0, -1.0], (3, 1)),
        floor_z_mm=-20.0,
        floor_note="floor",
        summary=[("a", "b")],
    )
    return write_page(data, tmp_path / "synthetic.html")


# ---------------------------------------------------------------- in a real browser
@pytest.fixture(scope="module")
def browser():
    sync_api = pytest.importorskip("playwright.sync_api", reason="playwright is not installed")
    exe = _chromium()
    if exe is None:
        pytest.skip("no Chromium found (apt-get install chromium, or set BATHPRINT_CHROMIUM)")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        yield b
        b.close()


def _open(browser, path: Path):
    pg = browser.new_page(viewport={"width": 1200, "height": 760})
    problems: list[str] = []
    pg.on(
        "console",
        lambda m: problems.append(f"console {m.type}: {m.text}") if m.type == "error" else None,
    )
    pg.on("pageerror", lambda e: problems.append(f"page error: {e}"))

    def only_the_file(route):
        if route.request.url.startswith("file://") and route.request.url.endswith(path.name):
            return route.continue_()
        problems.append(f"request: {route.request.url}")
        return route.abort()

    pg.route("**/*", only_the_file)
    pg.goto(path.as_uri())
    pg.wait_for_function("window.bathprintView && window.bathprintView.ready", timeout=60_000)
    pg.wait_for_timeout(300)
    return pg, problems


def _pixels(png: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


def test_page_in_browser_draws_and_animates(browser, page: Path):
    pg, problems = _open(browser, page)
    view = pg.locator("#plot")
    last = _pixels(view.screenshot())
    # not blank: the WebGL canvas exists and the picture has structure and colour
    assert pg.locator("#plot canvas").count() >= 1
    assert last.std() > 10.0
    saturated = (last.max(axis=2) - last.min(axis=2)) > 60  # the filament's colour map
    assert saturated.sum() > 200
    n = pg.evaluate("window.bathprintView.frames")
    assert n == 11 and pg.evaluate("window.bathprintView.frame") == n - 1
    # scrub to the first frame: the picture changes, the label follows
    pg.locator("#scrub").fill("0")
    pg.wait_for_timeout(300)
    assert pg.evaluate("window.bathprintView.frame") == 0
    assert "frame 1 / 11" in pg.locator("#frame-label").inner_text()
    first = _pixels(view.screenshot())
    changed = np.abs(first - last).max(axis=2) > 30
    assert changed.sum() > 200  # the filament of frame 1 is a stub
    # play, then pause (clicked from the page itself: a 10-frame run plays in 1 s)
    pg.evaluate("document.getElementById('play').click()")
    pg.wait_for_function("window.bathprintView.frame >= 2", timeout=10_000)
    k = pg.evaluate("document.getElementById('play').click(), window.bathprintView.frame")
    assert 2 <= k < n - 1 and pg.locator("#play").inner_text() == "Play"
    pg.wait_for_timeout(400)
    assert pg.evaluate("window.bathprintView.frame") == k
    # recolour
    pg.locator("#colour").select_option("age")
    pg.wait_for_timeout(200)
    title = pg.evaluate("document.getElementById('plot').data[0].line.colorbar.title.text")
    assert title.startswith("material age")
    pg.locator("#view-all").click()
    pg.wait_for_timeout(300)
    assert problems == []
    pg.close()


def test_page_colours_follow_material_index(browser, tmp_path: Path):
    """Frame k's node j shows the final record of segment min(j, n_k - 2); ages at the
    frame's time."""
    pg, problems = _open(browser, _synthetic(tmp_path))
    ages = pg.evaluate("window.bathprintView.values(1)")  # 5 nodes at t = 0.3 s
    assert ages == pytest.approx([0.3, 0.3, 0.2, 0.1, 0.1])
    pg.evaluate("window.bathprintView.setColour('density')")
    dens = pg.evaluate("window.bathprintView.values(0)")  # 3 nodes
    assert dens == pytest.approx([1000.0, 1010.0, 1010.0])
    assert problems == []
    pg.close()


def test_episode_page_in_browser(browser, tmp_path: Path):
    """An environment's episode with its target (a baseline policy, draft preset)."""
    out = tmp_path / "episode.html"
    code = main(
        [
            "view",
            "--env",
            "CoilRadius-v0",
            "--policy",
            "constant",
            "--accuracy",
            "draft",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    pg, problems = _open(browser, out)
    names = pg.evaluate("document.getElementById('plot').data.map(t => t.name)")
    assert names[0] == "filament" and names[-1] == "target"
    assert pg.evaluate("window.bathprintView.frames") > 10
    assert _pixels(pg.locator("#plot").screenshot()).std() > 10.0
    assert problems == []
    pg.close()

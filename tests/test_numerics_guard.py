"""Numerics that cannot resolve a scene's buckling length are refused when it loads, coarse
ones warned about, and every scene the project ships or studies loads as before
(:mod:`bathprint.core.resolution`)."""

from __future__ import annotations

import math
import re
import subprocess
import sys
import warnings
from typing import Any

import pytest

from bathprint.analysis import theory
from bathprint.cli import main
from bathprint.core import resolution
from bathprint.core.scene import (
    ACCURACY_PRESETS,
    PHYSICS_PRESETS,
    builtin_scene_names,
    flow_rows,
    load_scene,
)
from bathprint.errors import CoarseNumericsWarning, SceneError

COIL = "drag_coiling_22G"  # d = 0.41 mm, Q_o = 0.5 ml/min, E = 2.7 kPa: l = 3.88 mm


def _l_mm(name: str = COIL) -> float:
    """The scene's buckling length in mm."""
    scene = load_scene(name)
    return resolution.buckling_length(scene, flow_rows(scene)).l_m * 1e3


def _silent(name: str, overrides: dict[str, Any]) -> None:
    """``name`` with ``overrides`` loads with neither an error nor a warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        load_scene(name, overrides)


def _rounded_down(quoted: float, exact: float) -> None:
    """A quoted limit is ``exact`` rounded down to 3 significant digits."""
    assert exact * 0.99 <= quoted <= exact


def _allowed(message: str, key: str) -> float:
    """The largest value of ``key`` a refusal or warning quotes."""
    m = re.search(re.escape(key) + r" <= ([0-9.e+-]+)", message)
    assert m is not None, message
    return float(m.group(1))


def test_the_buckling_length_is_the_papers_with_the_theory_modules_function() -> None:
    assert theory.gravity_drag_length is resolution.gravity_drag_length
    assert resolution.PAPER_R_PREFACTOR == theory.PAPER_R_PREFACTOR
    scene = load_scene(COIL)
    r = 0.205e-3
    v = 0.5e-6 / 60 / (math.pi * 0.41e-3**2 / 4)
    b = theory.bending_stiffness(2700.0, r)
    expected = theory.gravity_drag_length(b, 1e-3, v, 1054.0 - 1051.0, r)
    got = resolution.buckling_length(scene, flow_rows(scene))
    assert got.l_m == pytest.approx(expected, rel=1e-12)
    assert got.l_m == pytest.approx(3.88e-3, rel=1e-2)


def test_a_100_mm_spacing_on_the_041_mm_filament_is_refused_naming_key_value_and_limit() -> None:
    with pytest.raises(SceneError) as err:
        load_scene(COIL, {"numerics.node_spacing_mm": 100.0})
    msg = str(err.value)
    assert "numerics.node_spacing_mm = 100.0" in msg
    assert "3.88 mm" in msg  # the buckling length it cannot resolve
    largest = _allowed(msg, "numerics.node_spacing_mm")
    _rounded_down(largest, 2 * math.pi * 0.4 * _l_mm())  # one coil turn
    with pytest.warns(CoarseNumericsWarning):  # the largest allowed value runs (coarsely)
        load_scene(COIL, {"numerics.node_spacing_mm": largest})
    with pytest.raises(SceneError, match="numerics.node_spacing_mm"):
        load_scene(COIL, {"numerics.node_spacing_mm": largest * 1.01})


def test_the_accuracy_presets_scaling_of_the_spacing_is_counted_and_named() -> None:
    with pytest.raises(SceneError) as err:
        load_scene(COIL, {"numerics.node_spacing_mm": 6.0, "numerics.accuracy": "draft"})
    msg = str(err.value)
    assert "numerics.accuracy = 'draft'" in msg
    largest = _allowed(msg, "numerics.node_spacing_mm")
    _rounded_down(largest, 2 * math.pi * 0.4 * _l_mm() / 2)
    with pytest.warns(CoarseNumericsWarning):
        load_scene(COIL, {"numerics.node_spacing_mm": largest, "numerics.accuracy": "draft"})


def test_a_coarse_but_runnable_spacing_warns_and_names_what_resolves_it() -> None:
    with pytest.warns(CoarseNumericsWarning, match=r"numerics.node_spacing_mm = 3.0") as rec:
        scene = load_scene(COIL, {"numerics.node_spacing_mm": 3.0})
    assert scene.numerics.node_spacing_mm == 3.0  # loaded: only warned
    fine_enough = _allowed(str(rec[0].message), "numerics.node_spacing_mm")
    _rounded_down(fine_enough, _l_mm() / 2)
    _silent(COIL, {"numerics.node_spacing_mm": fine_enough})


def test_a_fixed_step_that_extrudes_more_than_a_coil_turn_is_refused() -> None:
    with pytest.raises(SceneError) as err:
        load_scene(COIL, {"numerics.time_step_s": 1.0})
    msg = str(err.value)
    assert "numerics.time_step_s = 1.0" in msg and "63.1 mm per step" in msg
    largest = _allowed(msg, "numerics.time_step_s")
    scene = load_scene(COIL)
    v_mm_s = resolution.buckling_length(scene, flow_rows(scene)).v_m_s * 1e3
    _rounded_down(largest, 2 * math.pi * 0.4 * _l_mm() / v_mm_s)
    _silent(COIL, {"numerics.time_step_s": largest})
    # without flow nothing is extruded: any fixed step is accepted
    _silent(COIL, {"numerics.time_step_s": 10.0, "flow.q_outer_ml_min": 0.0})


def test_adaptive_step_bounds_and_durations_are_not_refused() -> None:
    # the controller bounds adaptive steps by the inlet growth and the buckling rate
    _silent(COIL, {"numerics.max_step_s": 100.0})
    _silent(COIL, {"duration_s": 1e-6})


def test_a_refusal_names_the_key_that_shortened_the_buckling_length() -> None:
    # a viscous bath shortens l below the scene's own spacing: the message says why
    with pytest.raises(SceneError) as err:
        load_scene("paper_simulation", {"bath.viscosity_pa_s": 100.0})
    assert "bath.viscosity_pa_s = 100" in str(err.value)


@pytest.mark.parametrize("name", builtin_scene_names())
def test_every_builtin_scene_with_every_preset_loads_silently(name: str) -> None:
    for accuracy in ("custom", *ACCURACY_PRESETS):
        for physics in ("custom", *PHYSICS_PRESETS):
            over: dict[str, Any] = {"numerics.accuracy": accuracy}
            if physics != "custom":
                over["physics"] = physics
            _silent(name, over)


def test_every_environment_and_accuracy_preset_loads_silently() -> None:
    from bathprint.envs import ENV_IDS
    from bathprint.envs.accuracy import ACCURACY_PRESETS as ENV_PRESETS
    from bathprint.envs.accuracy import accuracy_overrides
    from bathprint.envs.spec import load_spec

    for env_id in ENV_IDS:
        spec = load_spec(env_id)
        base = str(spec.scene.get("base", "gelation_coiling_22G"))
        warmup = float(spec.episode.get("warmup_q_outer_ml_min", 0.5))
        for preset in ENV_PRESETS:
            over = {
                **spec.scene.get("overrides", {}),
                **accuracy_overrides(preset),
                "flow.schedule": [],
                "flow.q_outer_ml_min": warmup,
                "flow.q_inner_ml_min": 0.0,
            }
            _silent(base, over)


def test_the_studies_runs_load_and_only_the_thinnest_phase_diagram_jets_warn() -> None:
    from bathprint.studies.reproduce import ablation, fast_jets, fig1c, gravity, runs

    for quick in (False, True):
        for run in ablation.plan(quick)[0]:
            if run["overrides"]:
                _silent(ablation.SCENE, run["overrides"])
        for run in fast_jets.plan(quick):
            _silent(fast_jets.SCENE, run["over"])
    for d in (0.26, 0.41, 0.6, 0.84):  # Fig. 2's grid
        for q in (0.3, 0.5, 1.0, 2.0):
            _silent(COIL, runs.run_overrides(d, q, None, 6.0, 6.0, 4000.0))
    for cfg in (gravity.FULL, gravity.QUICK):
        for d, q in cfg["points"]:
            for drho in cfg["drho"]:
                _silent(gravity.SCENE, gravity.overrides(d, q, drho, cfg["budget"]))
    # Fig. 1C's grid: the 0.09 mm needle above 0.1 ml/min buckles on 0.05-0.19 mm, under
    # the runs' 0.1 mm floor of the spacing: run, and warned about as coarse
    points = {(d, q) for d in (0.09, 0.21, 0.41, 0.84, 1.9) for q in (0.1, 0.5, 2.0, 5.0, 20.0)}
    points |= {(d, q) for d, q, _ in fig1c.PAPER_POINTS}
    for d, q in sorted(points):
        over = runs.run_overrides(d, q, fig1c.HEIGHT_MM, physics=fig1c.PHYSICS)
        if d == 0.09 and q > 0.1:
            with pytest.warns(CoarseNumericsWarning):
                load_scene(COIL, over)
        else:
            _silent(COIL, over)


def test_the_cli_exits_2_with_the_message_before_any_work(tmp_path, capsys) -> None:
    """In process (the output folder is never made) and as a command."""
    out = tmp_path / "run"
    code = main(
        [
            "simulate",
            COIL,
            "--set",
            "numerics.node_spacing_mm=100",
            "--quiet",
            "--out",
            str(out),
        ]
    )
    assert code == 2
    err = capsys.readouterr().err
    assert "numerics.node_spacing_mm = 100" in err
    assert "allowed: numerics.node_spacing_mm <= 9.7" in err
    assert not out.exists()
    proc = subprocess.run(
        [sys.executable, "-m", "bathprint.cli", "simulate", COIL, "--set",
         "numerics.node_spacing_mm=100", "--out", str(out)],
        capture_output=True,
        text=True,
    )  # fmt: skip
    assert proc.returncode == 2 and "Traceback" not in proc.stderr
    assert "scene error: numerics.node_spacing_mm = 100.0" in proc.stderr
    assert not out.exists()

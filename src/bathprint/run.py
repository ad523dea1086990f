"""Run a scene to its end and write its outputs: :func:`simulate` and :class:`Result`.

Outputs (``bathprint simulate --out DIR``):
- ``trajectory.npz``: ``positions_m`` (all frames' nodes stacked, shape (total, 3)),
  ``frame_start`` (frame k is rows frame_start[k]:frame_start[k+1]), ``time_s``,
  ``material`` (final per-segment records) and ``material_columns``
  (:func:`bathprint.core.run.load_trajectory` reads it back);
- ``summary.json``: wall time (``compile_s``, numba compiling or loading its kernels
  before the run, is kept apart), steps, rejected steps, final length, mass balance, and
  ``measurements`` (the Fig. 2 measurements, :mod:`bathprint.analysis.measure`);
- ``scene.toml``: the scene as run (``bathprint simulate DIR/scene.toml`` repeats it);
- ``filament.png``: the final filament coloured by material age (``bathprint view DIR``
  makes an interactive 3D page of all frames).

This module composes the layers: the simulator (:mod:`bathprint.core`) runs the scene,
:mod:`bathprint.analysis` measures it and :mod:`bathprint.viz` draws it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.core.run import advance_frames, summarize, write_trajectory
from bathprint.core.scene import Scene, load_scene, scene_to_toml
from bathprint.core.simulation import Simulation

__all__ = ["Result", "measure_run", "simulate"]


@dataclass
class Result:
    """Frames and summary of a finished run."""

    scene: Scene
    time_s: np.ndarray
    frames: list[np.ndarray]
    material: np.ndarray
    summary: dict[str, Any] = field(default_factory=dict)

    @property
    def final(self) -> np.ndarray:
        """Centreline (m) of the last frame, free end first."""
        return self.frames[-1]

    def save(self, out_dir: str | Path, plot: bool = True) -> Path:
        """Write trajectory.npz, summary.json, scene.toml and (optionally) filament.png into
        out_dir."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        write_trajectory(out / "trajectory.npz", self.time_s, self.frames, self.material)
        (out / "summary.json").write_text(json.dumps(self.summary, indent=2))
        (out / "scene.toml").write_text(scene_to_toml(self.scene))  # the scene as run
        if plot:
            from bathprint.viz.plotting import plot_filament

            plot_filament(
                self.final,
                self.material,
                self.summary.get("time_s", 0.0),
                out / "filament.png",
                title=self.scene.name,
                measurements=self.summary.get("measurements"),
            )
        return out


def measure_run(sim: Simulation, frames: list[np.ndarray], times: np.ndarray) -> dict[str, Any]:
    """The Fig. 2 measurements of a run (:mod:`bathprint.analysis.measure`), for summary.json."""
    from bathprint.analysis.measure import measure_all

    needle = sim.model.needle
    z_floor = float(sim.model.p.floor_z) if "floor" in sim.scene.effects else None
    return measure_all(
        frames,
        times,
        needle[0, 1:4].copy(),
        needle[0, 4:7].copy(),
        sim.model.node_spacing,
        sim.model.radius,
        z_floor=z_floor,
    )


def simulate(
    scene: str | Path | Scene | dict,
    overrides: dict[str, Any] | None = None,
    out_dir: str | Path | None = None,
    progress: bool | None = None,
) -> Result:
    """Run a scene (built-in name, TOML path, dict or Scene) to its duration.

    Returns a :class:`Result`; with ``out_dir`` also writes its files (a file there, or a
    directory that cannot be written, raises OptionError before the run). A progress bar is
    shown when ``progress`` is true (default: when the run is long and stderr is a TTY).
    """
    from bathprint.warmup import ensure_compiled

    load_scene(scene, overrides)  # bad input is refused before anything compiles
    if out_dir is not None:  # refused now, not after the run (OptionError)
        from bathprint.paths import check_output_dir

        check_output_dir(out_dir, "out_dir")
    compile_s = ensure_compiled(announce=True)
    sim = Simulation(scene, overrides)
    times, frames, wall = advance_frames(sim, progress)
    summary = summarize(sim, wall)
    summary["compile_s"] = compile_s
    summary["measurements"] = measure_run(sim, frames, times)
    result = Result(sim.scene, times, frames, sim.material(), summary)
    if out_dir is not None:
        result.save(out_dir, plot=sim.scene.outputs.plot)
    return result

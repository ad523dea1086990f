"""The interactive 3D viewer: one self-contained HTML page per run or episode.

``bathprint view RUN_DIR [--out FILE.html]`` reads ``trajectory.npz``, ``summary.json`` and
``scene.toml`` of a run (what ``bathprint simulate`` writes) and writes a page that opens
without a network: plotly.js is inlined. It shows the filament in 3D over the saved frames
(play, pause, scrub), coloured by a material column chosen on the page, with the needle,
the bath's free surface (z = 0) and the container floor (z = -bath.depth_mm), and the run's
summary beside it; the view rotates and zooms with the mouse.

``bathprint view --env ENV --policy POLICY`` plays one episode of an environment (a
baseline, a trained run directory or a model ``.zip``, as ``bathprint evaluate`` takes) and
writes the same page with the episode's target drawn beside the printed filament
(:func:`bathprint.agents.episode_view.episode_page` plays it); :class:`RecordEpisode`
records any episode, played by a policy or stepped by hand.

What the colours are. Material records are saved for the final frame only. Segment j of an
earlier frame is segment j of the final frame (nodes are born at the needle and keep their
index from the free end), so each frame's segments take their final records: exact for the
age (frame time minus birth time), the density and the inner-fluid fraction, which are fixed
when a segment leaves the needle; the modulus is its final value (with ``gelation`` it grows
with age, so earlier frames show it stiffer than it was).
"""

from __future__ import annotations

import html
import json
import math
import tomllib
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import OptionError

__all__ = [
    "COLOUR_COLUMNS",
    "RecordEpisode",
    "ViewData",
    "format_value",
    "load_run",
    "run_page",
    "write_page",
]

#: colour choices on the page: key -> (label, unit, material column, scale to the unit)
COLOUR_COLUMNS: dict[str, tuple[str, str, str, float]] = {
    "age": ("material age", "s", "birth_time_s", 1.0),
    "modulus": ("Young's modulus", "kPa", "youngs_modulus_pa", 1e-3),
    "density": ("density", "kg/m³", "density_kg_m3", 1.0),
    "inner_fraction": ("inner-fluid fraction", "–", "inner_volume_fraction", 1.0),
}
NEEDLE_ABOVE_SURFACE_MM = 3.0  # the needle is drawn from its tip to this far above z = 0
ROI_TURNS = 3.0  # coil turns below the buckling point in the initial framing


@dataclass
class ViewData:
    """Everything a page shows, in mm and s.

    ``frames[k]`` is the centreline (n_k, 3) at ``times_s[k]``, free end first, needle tip
    last; ``columns`` maps a :data:`COLOUR_COLUMNS` key to per-segment values of the final
    frame (ages as birth times); ``needle_direction[k]`` is the needle's unit direction at
    frame k; ``summary`` rows (label, text) go beside the view.
    """

    title: str
    times_s: np.ndarray
    frames: list[np.ndarray]
    columns: dict[str, np.ndarray]
    needle_direction: np.ndarray
    floor_z_mm: float | None
    floor_note: str
    summary: list[tuple[str, str]]
    notes: list[str] = field(default_factory=list)
    target_mm: list[np.ndarray | None] | None = None
    focus: np.ndarray | None = None  # nodes (mm) the initial framing covers
    colour: str = "age"


# --------------------------------------------------------------------- reading a run
def load_run(
    run_dir: str | Path,
) -> tuple[
    np.ndarray, list[np.ndarray], dict[str, np.ndarray], dict[str, Any], dict[str, Any] | None
]:
    """(time_s, frames in m, final material columns by name, summary, scene dict or None)
    from a run directory; a missing or unreadable file raises OptionError naming it."""
    d = Path(run_dir)
    if not d.is_dir():
        why = "is a file, not a run directory" if d.exists() else "does not exist"
        raise OptionError(
            f"RUN_DIR = {str(d)!r} {why}; allowed: a directory written by "
            "bathprint simulate (trajectory.npz, summary.json)"
        )
    traj = d / "trajectory.npz"
    if not traj.is_file():
        raise OptionError(
            f"RUN_DIR = {str(d)!r} holds no trajectory.npz; allowed: a directory "
            "written by bathprint simulate"
        )
    try:
        with np.load(traj) as z:
            pos, start = z["positions_m"], z["frame_start"]
            times, material = z["time_s"], z["material"]
            names = [str(c) for c in z["material_columns"]]
    except (OSError, KeyError, ValueError) as exc:
        why = f"cannot be read as a bathprint trajectory ({exc})"
        raise OptionError(f"{str(traj)!r} {why}") from None
    frames = [pos[start[k] : start[k + 1]] for k in range(len(start) - 1)]
    if not frames or len(frames) != len(times):
        raise OptionError(f"{str(traj)!r} holds {len(frames)} frames for {len(times)} times")
    columns = {n: material[:, i] for i, n in enumerate(names) if i < material.shape[1]}
    summary: dict[str, Any] = {}
    if (d / "summary.json").is_file():
        try:
            summary = json.loads((d / "summary.json").read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise OptionError(f"{str(d / 'summary.json')!r} is not JSON ({exc})") from None
    scene = None
    if (d / "scene.toml").is_file():
        try:
            scene = tomllib.loads((d / "scene.toml").read_text())
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise OptionError(f"{str(d / 'scene.toml')!r} is not TOML ({exc})") from None
    return times, frames, columns, summary, scene


def _final_columns(columns: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    out = {}
    for key, (_, _, name, scale) in COLOUR_COLUMNS.items():
        if name in columns:
            out[key] = np.asarray(columns[name], dtype=float) * scale
    return out


def _needle_directions(
    scene: dict[str, Any] | None, times: np.ndarray, frames: list[np.ndarray]
) -> np.ndarray:
    """Unit needle direction per frame: the scene's needle.path (linear between rows) or
    needle.direction; without a scene, the direction of each frame's last segment."""
    n = len(times)
    needle = (scene or {}).get("needle", {})
    path = needle.get("path") or []
    if path:
        rows = np.asarray(path, dtype=float)
        d = np.stack([np.interp(times, rows[:, 0], rows[:, 4 + i]) for i in range(3)], axis=1)
    elif "direction" in needle:
        d = np.tile(np.asarray(needle["direction"], dtype=float), (n, 1))
    else:
        d = np.array([f[-1] - f[-2] if len(f) > 1 else [0.0, 0.0, -1.0] for f in frames])
    norm = np.linalg.norm(d, axis=1, keepdims=True)
    return np.where(norm > 0, d / np.where(norm > 0, norm, 1.0), [[0.0, 0.0, -1.0]])


def format_value(x: Any, unit: str = "", digits: int = 4) -> str:
    """``x`` for the page's summary table: ``digits`` significant figures and its unit, or a
    dash where there is no finite value."""
    if x is None:
        return "–"
    if isinstance(x, float):
        if not math.isfinite(x):
            return "–"
        return f"{x:.{digits}g}" + (f" {unit}" if unit else "")
    return f"{x}" + (f" {unit}" if unit else "")


def _run_summary(summary: dict[str, Any]) -> list[tuple[str, str]]:
    m = summary.get("measurements") or {}
    mb = summary.get("mass_balance") or {}

    def mm(key: str) -> str:
        v = m.get(key)
        return format_value(1e3 * v if isinstance(v, int | float) else None, "mm")

    rows = [
        ("scene", format_value(summary.get("scene"))),
        ("simulated", format_value(summary.get("time_s"), "s")),
        ("wall time", format_value(summary.get("wall_time_s"), "s", 3)),
        ("steps (rejected)", f"{summary.get('steps', '–')} ({summary.get('rejected_steps', '–')})"),
        ("Newton iterations", format_value(summary.get("newton_iterations"))),
        ("nodes (frozen)", f"{summary.get('nodes', '–')} ({summary.get('frozen_nodes', 0)})"),
        ("effects", ", ".join(summary.get("effects") or []) or "–"),
        (
            "exit speed",
            format_value(1e3 * summary["exit_speed_m_s"], "mm/s")
            if isinstance(summary.get("exit_speed_m_s"), int | float)
            else "–",
        ),
        ("regime", format_value(m.get("regime"))),
        ("buckling length", mm("buckling_length_m")),
        ("coil radius", mm("coil_radius_m")),
        ("coil pitch", mm("coil_pitch_m")),
        ("coil frequency", format_value(m.get("coil_frequency_rad_s"), "rad/s")),
        ("mass balance error", format_value(mb.get("relative_error"), "", 2)),
    ]
    return rows


def _roi_nodes(final_mm: np.ndarray, measurements: dict[str, Any] | None) -> np.ndarray:
    from bathprint.viz.plotting import region_of_interest

    return final_mm[region_of_interest(final_mm, measurements, ROI_TURNS)]


def run_view_data(run_dir: str | Path, colour: str = "age") -> ViewData:
    """The :class:`ViewData` of a run directory."""
    times, frames_m, columns, summary, scene = load_run(run_dir)
    frames = [np.asarray(f, dtype=float) * 1e3 for f in frames_m]
    effects = list((scene or {}).get("effects") or summary.get("effects") or [])
    depth = (scene or {}).get("bath", {}).get("depth_mm")
    if depth is None:
        floor_z, note = None, "floor: unknown (no scene.toml in the run directory)"
    elif "floor" in effects:
        floor_z, note = -float(depth), f"floor at z = {-float(depth):g} mm (contact simulated)"
    else:
        floor_z = -float(depth)
        note = f"floor at z = {-float(depth):g} mm (not in effects: the filament passes it)"
    notes = [
        "Colours: each frame's segments carry the final frame's material records (they are "
        "saved at the end of a run); age, density and inner-fluid fraction are exact, the "
        "modulus is its final value.",
        note,
    ]
    if scene is None:
        notes.append("No scene.toml: the needle direction is taken from the filament.")
    return ViewData(
        title=str(summary.get("scene") or Path(run_dir).name),
        times_s=np.asarray(times, dtype=float),
        frames=frames,
        columns=_final_columns(columns),
        needle_direction=_needle_directions(scene, np.asarray(times), frames),
        floor_z_mm=floor_z,
        floor_note=note,
        summary=_run_summary(summary),
        notes=notes,
        focus=_roi_nodes(frames[-1], summary.get("measurements")),
        colour=colour,
    )


def run_page(run_dir: str | Path, out: str | Path | None = None, colour: str = "age") -> Path:
    """Write the page of a run directory (default ``RUN_DIR/view.html``); returns its path."""
    _check_colour(colour)
    data = run_view_data(run_dir, colour)
    return write_page(data, Path(out) if out is not None else Path(run_dir) / "view.html")


def _check_colour(colour: str) -> None:
    if colour not in COLOUR_COLUMNS:
        raise OptionError(f"--colour = {colour!r}; allowed: {', '.join(COLOUR_COLUMNS)}")


# --------------------------------------------------------------------- episodes
def _kabsch_place(printed: np.ndarray, target: np.ndarray) -> np.ndarray:
    """The target moved by the proper rigid motion that best maps its first len(printed)
    samples onto the printed ones (least squares); unmoved when fewer than 3 are printed."""
    n = min(len(printed), len(target))
    if n < 3:
        return target
    p, q = printed[:n], target[:n]
    pc, qc = p.mean(axis=0), q.mean(axis=0)
    u, _, vt = np.linalg.svd((q - qc).T @ (p - pc))
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return target @ r.T + (pc - qc @ r.T)


class RecordEpisode:
    """Record an episode of a bathprint environment for :func:`write_page`: call
    :meth:`capture` after ``reset`` and after every ``step``, then :meth:`view_data`.

    Reads the environment's simulation (``env.unwrapped.sim``: centreline, material, time),
    its target (``target.points_mm``) and the printed samples it scores
    (``printed_samples().points_mm``), onto which the target is placed by the best rigid
    motion, as the shape metric compares them.
    """

    def __init__(self, env: Any) -> None:
        self.env = env
        self.times: list[float] = []
        self.frames: list[np.ndarray] = []
        self.targets: list[np.ndarray | None] = []
        self.infos: list[dict[str, Any]] = []

    def capture(self, info: dict[str, Any] | None = None) -> None:
        u = self.env.unwrapped
        self.frames.append(np.asarray(u.sim.centerline(), dtype=float) * 1e3)
        self.times.append(float(u.sim.t))
        target = None
        if getattr(u, "target", None) is not None:
            pts = np.asarray(u.target.points_mm, dtype=float)
            try:
                printed = np.asarray(u.printed_samples().points_mm, dtype=float)
            except (AttributeError, ValueError, IndexError):
                printed = np.zeros((0, 3))
            target = _kabsch_place(printed, pts) if len(printed) >= 3 else None
        self.targets.append(target)
        self.infos.append(dict(info or {}))

    def view_data(self, title: str, extra: Sequence[tuple[str, str]] = ()) -> ViewData:
        u = self.env.unwrapped
        names = list(_material_names())
        mat = np.asarray(u.sim.material(), dtype=float)
        columns = {n: mat[:, i] for i, n in enumerate(names) if i < mat.shape[1]}
        info = self.infos[-1] if self.infos else {}
        # the target is placed once enough is printed; earlier frames show the final placement
        last = next((t for t in reversed(self.targets) if t is not None), None)
        targets = [t if t is not None else last for t in self.targets]
        summary = [
            ("environment", title),
            *extra,
            ("steps", str(max(len(self.frames) - 1, 0))),
            ("metric", format_value(info.get("metric"))),
            ("shape RMS", format_value(info.get("shape_rms_mm"), "mm")),
            ("curvature RMS", format_value(info.get("curvature_rms_1_mm"), "1/mm")),
            ("density RMS", format_value(info.get("density_rms_kg_m3"), "kg/m³")),
            ("printed", format_value(info.get("printed_length_mm"), "mm")),
            ("target", format_value(info.get("target_key"))),
            ("simulation error", format_value(info.get("sim_error"))),
        ]
        frames = self.frames
        needle = u.sim.model.needle
        d = np.asarray(needle[0, 4:7], dtype=float)
        depth = getattr(u.sim.scene.bath, "depth_mm", None)
        floor = "floor" in u.sim.scene.effects
        note = (
            (
                f"floor at z = {-depth:g} mm"
                + (" (contact simulated)" if floor else " (not in effects)")
            )
            if depth is not None
            else "floor: unknown"
        )
        return ViewData(
            title=title,
            times_s=np.asarray(self.times),
            frames=frames,
            columns=_final_columns(columns),
            needle_direction=np.tile(d / max(np.linalg.norm(d), 1e-12), (len(frames), 1)),
            floor_z_mm=-float(depth) if depth is not None else None,
            floor_note=note,
            summary=summary,
            notes=[
                "Red dashes: the target, placed on the printed part by the best rigid motion "
                "(as the shape metric compares them).",
                "Colours: the final material records on every frame (see bathprint view).",
                note,
            ],
            target_mm=targets,
            focus=np.vstack(
                [frames[-1][-min(len(frames[-1]), 400) :]] + ([last] if last is not None else [])
            ),
        )


def _material_names() -> tuple[str, ...]:
    from bathprint.core.layout import MATERIAL_COLUMNS

    return tuple(MATERIAL_COLUMNS)


# --------------------------------------------------------------------- the page
def _r(a: np.ndarray, digits: int = 3) -> list[float]:
    return np.round(np.asarray(a, dtype=float), digits).tolist()


def _needle_line(tip: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The needle from its tip back against its direction to just above the surface."""
    dz = -direction[2]
    length = (-tip[2] + NEEDLE_ABOVE_SURFACE_MM) / dz if dz > 1e-3 else 10.0
    length = float(np.clip(length, 2.0, 200.0))
    return np.stack([tip, tip - length * direction])


def _box(points: np.ndarray, pad: float = 0.08) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = points.min(axis=0), points.max(axis=0)
    span = max(float((hi - lo).max()), 1.0)
    lo, hi = lo - pad * span, hi + pad * span
    mid, half = 0.5 * (lo + hi), 0.5 * np.maximum(hi - lo, 0.05 * span)
    return mid - half, mid + half


def _figure(data: ViewData) -> dict[str, Any]:
    import plotly.graph_objects as go

    last = data.frames[-1]
    all_nodes = np.vstack(data.frames)
    xy_lo, xy_hi = _box(all_nodes[:, :2], pad=0.15)
    gx = [xy_lo[0], xy_hi[0]]
    gy = [xy_lo[1], xy_hi[1]]
    tip = last[-1]
    needle = _needle_line(tip, data.needle_direction[-1])
    fig = go.Figure()
    fig.add_trace(
        go.Scatter3d(
            x=last[:, 0],
            y=last[:, 1],
            z=last[:, 2],
            mode="lines",
            name="filament",
            line={
                "width": 6,
                "color": np.zeros(len(last)),
                "colorscale": "Viridis",
                "showscale": True,
                "colorbar": {"title": {"text": ""}, "len": 0.7},
            },
            hovertemplate="x %{x:.2f} mm<br>y %{y:.2f} mm<br>z %{z:.2f} mm<extra></extra>",
        )
    )
    fig.add_trace(
        go.Scatter3d(
            x=needle[:, 0],
            y=needle[:, 1],
            z=needle[:, 2],
            mode="lines",
            name="needle",
            line={"width": 12, "color": "#555555"},
            hoverinfo="skip",
        )
    )
    fig.add_trace(
        go.Surface(
            x=gx,
            y=gy,
            z=[[0.0, 0.0], [0.0, 0.0]],
            name="bath surface (z = 0)",
            showscale=False,
            opacity=0.18,
            colorscale=[[0, "#3a8dde"], [1, "#3a8dde"]],
            hoverinfo="skip",
            showlegend=True,
        )
    )
    if data.floor_z_mm is not None:
        fz = data.floor_z_mm
        fig.add_trace(
            go.Surface(
                x=gx,
                y=gy,
                z=[[fz, fz], [fz, fz]],
                name=f"floor (z = {fz:g} mm)",
                showscale=False,
                opacity=0.35,
                colorscale=[[0, "#8a6d4b"], [1, "#8a6d4b"]],
                hoverinfo="skip",
                showlegend=True,
            )
        )
    if data.target_mm is not None:
        t = data.target_mm[-1]
        t = t if t is not None else np.zeros((0, 3))
        fig.add_trace(
            go.Scatter3d(
                x=t[:, 0],
                y=t[:, 1],
                z=t[:, 2],
                mode="lines",
                name="target",
                line={"width": 4, "color": "#d62728", "dash": "dash"},
                hoverinfo="skip",
            )
        )
    fig.update_layout(
        margin={"l": 0, "r": 0, "t": 30, "b": 0},
        title={"text": html.escape(data.title), "x": 0.02},
        legend={"x": 0.01, "y": 0.98},
        scene={
            "xaxis": {"title": {"text": "x (mm)"}},
            "yaxis": {"title": {"text": "y (mm)"}},
            "zaxis": {"title": {"text": "z (mm)"}},
            "aspectmode": "manual",
        },
        uirevision="keep",
    )
    return json.loads(fig.to_json())


def _ranges(points: np.ndarray) -> dict[str, Any]:
    lo, hi = _box(points)
    span = hi - lo
    ratio = span / span.max()
    return {
        "x": [round(float(lo[0]), 2), round(float(hi[0]), 2)],
        "y": [round(float(lo[1]), 2), round(float(hi[1]), 2)],
        "z": [round(float(lo[2]), 2), round(float(hi[2]), 2)],
        "aspect": {"x": float(ratio[0]), "y": float(ratio[1]), "z": float(ratio[2])},
    }


def _payload(data: ViewData) -> dict[str, Any]:
    counts = [len(f) for f in data.frames]
    start = np.concatenate([[0], np.cumsum(counts)]).astype(int).tolist()
    pos = np.vstack(data.frames)
    needles = [
        _needle_line(f[-1], d) for f, d in zip(data.frames, data.needle_direction, strict=True)
    ]
    columns = {}
    t_end = float(data.times_s[-1])
    for key, values in data.columns.items():
        label, unit, _, _ = COLOUR_COLUMNS[key]
        if key == "age":
            lo, hi = 0.0, max(t_end - float(np.min(values)), 1e-9)
        else:
            lo, hi = float(np.min(values)), float(np.max(values))
            if not hi > lo:
                pad = max(abs(lo) * 1e-3, 1e-9)
                lo, hi = lo - pad, hi + pad
        columns[key] = {
            "label": f"{label} ({unit})",
            "values": _r(values, 6),
            "lo": lo,
            "hi": hi,
            "age": key == "age",
        }
    focus = data.focus if data.focus is not None and len(data.focus) else data.frames[-1]
    everything = [pos, *needles, np.array([[pos[0, 0], pos[0, 1], 0.0]])]
    if data.floor_z_mm is not None:
        everything.append(np.array([[pos[0, 0], pos[0, 1], data.floor_z_mm]]))
    if data.target_mm is not None:
        everything += [t for t in data.target_mm if t is not None]
    out: dict[str, Any] = {
        "title": data.title,
        "time": _r(data.times_s, 6),
        "start": start,
        "x": _r(pos[:, 0]),
        "y": _r(pos[:, 1]),
        "z": _r(pos[:, 2]),
        "needle": [_r(n) for n in needles],
        "columns": columns,
        "colour": data.colour if data.colour in columns else next(iter(columns), ""),
        "views": {
            "coils": _ranges(np.vstack([focus, needles[-1]])),
            "everything": _ranges(np.vstack(everything)),
        },
        "target": None,
    }
    if data.target_mm is not None:
        out["target"] = [
            None if t is None else [_r(t[:, i]) for i in range(3)] for t in data.target_mm
        ]
    return out


_CSS = """
body{margin:0;font-family:system-ui,-apple-system,"Segoe UI",sans-serif;color:#222;
display:flex;height:100vh;overflow:hidden}
#plot{flex:1;min-width:0;height:100vh}
aside{width:330px;padding:12px 14px;overflow-y:auto;border-left:1px solid #ddd;
background:#fafafa;font-size:13px}
aside h1{font-size:16px;margin:4px 0 10px}
.controls{display:flex;gap:6px;align-items:center;margin:6px 0}
.controls button,.controls select{font-size:13px;padding:3px 8px}
#scrub{width:100%}
table{border-collapse:collapse;width:100%;margin-top:8px}
td{padding:2px 4px;border-bottom:1px solid #eee;vertical-align:top}
td:first-child{color:#555;white-space:nowrap}
p.note{color:#555;font-size:12px;line-height:1.35}
"""

_JS = """
(function(){
const D = JSON.parse(document.getElementById('bathprint-data').textContent);
const F = JSON.parse(document.getElementById('bathprint-figure').textContent);
const gd = document.getElementById('plot');
const nF = D.time.length;
let k = nF - 1, colour = D.colour, timer = null;
const scrub = document.getElementById('scrub'), label = document.getElementById('frame-label');
const play = document.getElementById('play'), sel = document.getElementById('colour');
scrub.max = nF - 1; scrub.value = k;
const targetTrace = D.target ? F.data.length - 1 : -1;
function values(i){
  const n = D.start[i+1] - D.start[i], c = D.columns[colour], out = new Array(n);
  if (!c) { out.fill(0); return out; }
  const m = c.values.length;
  for (let j = 0; j < n; j++){
    const s = Math.max(0, Math.min(j, n - 2, m - 1));
    out[j] = c.age ? D.time[i] - c.values[s] : c.values[s];
  }
  return out;
}
function show(i){
  k = i; const a = D.start[i], b = D.start[i+1], c = D.columns[colour];
  const upd = {x:[D.x.slice(a,b)], y:[D.y.slice(a,b)], z:[D.z.slice(a,b)],
    'line.color':[values(i)], 'line.cmin':[c ? c.lo : 0], 'line.cmax':[c ? c.hi : 1],
    'line.colorbar.title.text':[c ? c.label : '']};
  Plotly.restyle(gd, upd, [0]);
  const nd = D.needle[i];
  Plotly.restyle(gd, {x:[[nd[0][0], nd[1][0]]], y:[[nd[0][1], nd[1][1]]],
    z:[[nd[0][2], nd[1][2]]]}, [1]);
  if (targetTrace >= 0 && D.target[i]){
    const t = D.target[i];
    Plotly.restyle(gd, {x:[t[0]], y:[t[1]], z:[t[2]]}, [targetTrace]);
  }
  scrub.value = i;
  label.textContent = 'frame ' + (i + 1) + ' / ' + nF + ', t = ' + D.time[i].toFixed(3) + ' s, '
    + (b - a) + ' nodes';
  window.bathprintView.frame = i;
}
function frame(name){
  const v = D.views[name];
  Plotly.relayout(gd, {'scene.xaxis.range': v.x, 'scene.yaxis.range': v.y,
    'scene.zaxis.range': v.z, 'scene.aspectratio': v.aspect});
}
function stop(){ if (timer){ clearInterval(timer); timer = null; } play.textContent = 'Play'; }
function start(){
  if (k >= nF - 1) show(0);
  play.textContent = 'Pause';
  timer = setInterval(function(){ if (k >= nF - 1){ stop(); return; } show(k + 1); }, 100);
}
window.bathprintView = {frame: k, frames: nF, show: show, play: start, pause: stop, values: values,
  setColour: function(c){ colour = c; sel.value = c; show(k); }, view: frame};
play.addEventListener('click', function(){ timer ? stop() : start(); });
scrub.addEventListener('input', function(){ stop(); show(parseInt(scrub.value, 10)); });
sel.addEventListener('change', function(){ colour = sel.value; show(k); });
document.getElementById('view-coils').addEventListener('click', function(){ frame('coils'); });
document.getElementById('view-all').addEventListener('click', function(){ frame('everything'); });
const v = D.views.coils;
F.layout.scene.xaxis.range = v.x; F.layout.scene.yaxis.range = v.y;
F.layout.scene.zaxis.range = v.z; F.layout.scene.aspectratio = v.aspect;
Plotly.newPlot(gd, F.data, F.layout, {responsive: true, displaylogo: false})
  .then(function(){ show(k); window.bathprintView.ready = true; });
})();
"""


def _json_script(element_id: str, obj: Any) -> str:
    text = json.dumps(obj, separators=(",", ":"), allow_nan=False)
    text = text.replace("<", "\\u003c").replace(">", "\\u003e").replace("&", "\\u0026")
    return f'<script type="application/json" id="{element_id}">{text}</script>'


def write_page(data: ViewData, out: str | Path) -> Path:
    """Write the self-contained HTML page of ``data`` to ``out`` (its directory is made);
    returns the path."""
    from plotly.offline import get_plotlyjs

    from bathprint.paths import check_output_file

    out = check_output_file(out, "--out")
    if len(data.frames) == 0:
        raise OptionError("nothing to show: no frames")
    payload = _payload(data)
    options = "".join(
        f'<option value="{k}"{" selected" if k == payload["colour"] else ""}>'
        f"{html.escape(v['label'])}</option>"
        for k, v in payload["columns"].items()
    )
    rows = "".join(
        f"<tr><td>{html.escape(a)}</td><td>{html.escape(b)}</td></tr>" for a, b in data.summary
    )
    notes = "".join(f'<p class="note">{html.escape(n)}</p>' for n in data.notes)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{html.escape(data.title)} – bathprint view</title>
<style>{_CSS}</style>
<script>{get_plotlyjs()}</script>
</head><body>
<div id="plot"></div>
<aside>
<h1>{html.escape(data.title)}</h1>
<div class="controls"><button id="play" type="button">Play</button>
<span id="frame-label"></span></div>
<input id="scrub" type="range" min="0" max="0" step="1" value="0" aria-label="frame">
<div class="controls"><label for="colour">colour</label><select id="colour">{options}</select></div>
<div class="controls">view <button id="view-coils" type="button">coils</button>
<button id="view-all" type="button">everything</button></div>
<p class="note">Drag to rotate, scroll to zoom, right-drag to pan.</p>
<table>{rows}</table>
{notes}
</aside>
{_json_script("bathprint-data", payload)}
{_json_script("bathprint-figure", _figure(data))}
<script>{_JS}</script>
</body></html>
"""
    out.write_text(page, encoding="utf-8")
    return out

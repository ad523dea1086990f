"""Tables of the documentation, rendered from the code and from the result files.

Every table of numbers in the docs and the README comes from here, so none is typed by
hand: the scene reference from the scene dataclasses (:mod:`bathprint.core.scene`), the
validation table from ``bathprint validate --json``, and the measured figures from the files
the benchmarks and studies write (``experiments/*/results/*.csv`` with their ``*.meta.json``,
``agents/results/*/table.json``), each followed by the command, date and machine that
produced it.

A page asks for a table with a line ``<!-- render: NAME -->``. The mkdocs hook
(``docs/_gen/hooks.py``) replaces such lines at build time. Files outside the site (the
README) keep the rendered text between ``<!-- render: NAME -->`` and ``<!-- end render -->``:

    python docs/_gen/render.py --write README.md    # re-render those blocks in place
    python docs/_gen/render.py --check README.md    # exit 1 if they are out of date (CI)
    python docs/_gen/render.py NAME                 # print one table
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import os
import re
import shutil
import subprocess
import sys
from collections import Counter
from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
EXPERIMENTS = ROOT / "experiments"
AGENTS = ROOT / "agents" / "results"


def result(name: str) -> Path:
    """The result file NAME of the experiment that holds it: experiments/<question>/results/
    NAME (each name is written by one experiment); experiments/*/results/NAME where none
    holds it (the caller reports it missing, or renders without it)."""
    hits = sorted(EXPERIMENTS.glob(f"*/results/{name}"))
    if len(hits) > 1:
        raise RenderError(f"result file {name!r} is in more than one experiment: {hits}")
    return hits[0] if hits else EXPERIMENTS / "*" / "results" / name


DIRECTIVE = re.compile(
    # (a block's body never holds another directive: a bare line before a filled block does
    # not swallow it)
    r"^<!-- render: ([\w-]+) -->$(?:\n(?:((?:(?!<!-- render: ).)*?)\n)??<!-- end render -->$)?",
    re.S | re.M,
)


class RenderError(RuntimeError):
    """A table cannot be rendered (a missing file or column, an unknown table)."""


# ------------------------------------------------------------------ provenance
def _git(*args: str) -> str:
    try:
        out = subprocess.run(
            ["git", *args], cwd=ROOT, capture_output=True, text=True, check=True, timeout=30
        )
    except (OSError, subprocess.CalledProcessError, subprocess.TimeoutExpired):
        return ""
    return out.stdout.strip()


def _rel(path: Path) -> str:
    return path.resolve().relative_to(ROOT).as_posix()


#: hex digits of a commit hash in the docs (fixed: see _committed)
ABBREV = 7


def _committed(path: Path) -> tuple[str, str]:
    """(date, short commit) of the last commit that changed ``path``'s content (a move
    alone does not count); ("", "") if uncommitted."""
    if _git("status", "--porcelain", "--", _rel(path)):
        return "", ""
    out = _git("log", "-1", "--follow", "--diff-filter=AM", "--format=%cs %H", "--", _rel(path))
    out = out.split()
    # the first 7 hex digits of the full hash: git's own abbreviation (%h) grows with the
    # repository's object count, so the same commit would read differently in another clone
    return (out[0], out[1][:ABBREV]) if len(out) == 2 else ("", "")


def provenance(*paths: Path) -> str:
    """One line under a table: the command, date, commit and machine that produced the
    files (from NAME.meta.json when it is as new as the file, else from git)."""
    parts = []
    for path in paths:
        meta_path = path.with_suffix(".meta.json")
        meta: dict[str, Any] = {}
        if meta_path.is_file():
            meta = json.loads(meta_path.read_text())
        date, commit = _committed(path)
        if not date:
            date = "not yet committed"
        stale = bool(meta) and bool(commit) and meta.get("date", "") < date
        cmd = meta.get("command") if meta else None
        machine = meta.get("machine") if meta and not stale else "not recorded"
        when = meta.get("date", date) if meta and not stale else date
        sha = meta.get("commit") or commit if not stale else commit
        text = f"`{_rel(path)}`"
        if cmd:
            text += f", written by `{cmd}`"
        text += f" on {when}" + (f" (commit {sha})" if sha else "") + f"; machine: {machine}"
        parts.append(text)
    return "*Source: " + "; ".join(parts) + ".*"


# ------------------------------------------------------------------ helpers
def _csv(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        raise RenderError(f"{_rel(path)} does not exist (run the command that writes it)")
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _table(head: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def _g(x: Any, digits: int = 3) -> str:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return "–"
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
        m, e = f"{v:.{max(digits - 1, 0)}e}".split("e")
        return f"{m}e{int(e)}"
    text = f"{v:.{digits}g}"
    if "e" in text:  # 100 <= |v| < 1e5 with few digits: round, but print in full
        text = f"{float(text):.0f}"
    return text


def _pct(x: Any, digits: int = 2) -> str:
    return f"{100 * float(x):+.{digits}g}%"


# ------------------------------------------------------------------ scenes
_UNITS = [
    ("_kg_m3", "kg/m³"),
    ("_pa_s", "Pa s"),
    ("_m_s2", "m/s²"),
    ("_mm_s", "mm/s"),
    ("_ml_min", "ml/min"),
    ("_1_s", "1/s"),
    ("_pa", "Pa"),
    ("_mm", "mm"),
    ("_um", "µm"),
    ("_deg", "degrees"),
    ("_s", "s"),
    ("_n", "N"),
]

#: meanings of keys whose dataclass field has no ``doc`` (checked: every entry must be a key)
MEANINGS = {
    "name": "scene name (outputs go to runs/NAME by default)",
    "description": "one line shown by `bathprint scenes`",
    "seed": "seed of the needle imperfections (counter-based, so runs are deterministic)",
    "needle.position_mm": "needle tip; z is up, the bath's free surface is z = 0",
    "needle.direction": "direction the needle points (normalised)",
    "gelation.curvature_memory": "natural curvature follows the current one as the gel sets",
    "inclusions.fluid": "inner fluid (its density is in `bathprint.core.composite`)",
    "inclusions.ferrofluid_density_kg_m3": "density of `fluid = 'ferrofluid'`",
    "end_load.force_n": "dead force on the free end (validation scenes)",
    "numerics.integrator": "`implicit` (SDIRK2), `sdirk4`, `implicit_euler`, `explicit`",
    "numerics.max_step_s": "largest adaptive step",
    "numerics.min_step_s": "smallest adaptive step (below it a failing step is a divergence)",
    "numerics.max_newton_iterations": "Newton iterations per stage before the step is retried",
    "numerics.line_search": "`residual`: Newton updates halved until the force residual "
    "decreases; `off`: a stalled solve halves them for good; `auto`: `residual` with contact",
    "outputs.frame_interval_s": "simulated time between saved frames",
    "outputs.plot": "write filament.png",
}


def _unit(name: str) -> str:
    for suffix, unit in _UNITS:
        if name.endswith(suffix):
            return unit
    return "–"


def _default(f: dataclasses.Field) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:  # type: ignore[misc]
        return f.default_factory()  # type: ignore[misc]
    return None


def _show(v: Any) -> str:
    if isinstance(v, bool):
        return "`true`" if v else "`false`"
    if isinstance(v, str):
        return f'`"{v}"`' if v else '`""`'
    if isinstance(v, tuple | list):
        return "`[" + ", ".join(_g(x, 4) if not isinstance(x, str) else f'"{x}"' for x in v) + "]`"
    if isinstance(v, float):
        return f"`{_g(v, 4)}`"
    return f"`{v}`"


def scene_fields() -> list[tuple[str, dataclasses.Field, str]]:
    """(dotted key, field, table) of every scene key, in the dataclasses' order."""
    from bathprint.core.scene import Scene

    out = []

    def walk(cls: type, prefix: str, table: str) -> None:
        for f in dataclasses.fields(cls):
            factory = f.default_factory  # type: ignore[misc]
            if isinstance(factory, type) and dataclasses.is_dataclass(factory):
                walk(factory, f"{prefix}{f.name}.", f.name)
            else:
                out.append((f"{prefix}{f.name}", f, table))

    walk(Scene, "", "")
    return out


def scene_keys() -> str:
    """The scene reference: every key with unit, default, allowed values and meaning."""
    from bathprint.core import scene as S

    fields = scene_fields()
    keys = {k for k, _, _ in fields}
    unknown = sorted(set(MEANINGS) - keys)
    if unknown:
        raise RenderError(f"docs/_gen/render.py MEANINGS names keys that do not exist: {unknown}")
    docs = {}
    for cls in (S.Scene, *{type(_default(f)) for _, f, _ in []}):
        docs[cls.__name__] = (cls.__doc__ or "").strip().splitlines()[0]
    out = []
    tables: dict[str, list] = {}
    for key, f, table in fields:
        tables.setdefault(table, []).append((key, f))
    for table, rows in tables.items():
        if table:
            cls = type(getattr(S.Scene(), table))
            doc = " ".join((cls.__doc__ or "").split())
            out.append(f"### `[{table}]`\n\n{doc}\n")
        else:
            out.append("### Top level\n")
        body = []
        for key, f in rows:
            meaning = f.metadata.get("doc") or MEANINGS.get(key, "—")
            body.append([f"`{key}`", _unit(f.name), _show(_default(f)), S._allowed(f), meaning])
        out.append(_table(["key", "unit", "default", "allowed", "meaning"], body) + "\n")
    out.append(
        "*Rendered from the dataclasses of `bathprint.core.scene` when the docs are built: "
        "a key, default or range changed there changes here.*"
    )
    return "\n".join(out)


def builtin_scenes() -> str:
    """The built-in scenes: name, duration, effects, description."""
    from bathprint.core.scene import builtin_scene_names, load_scene

    rows = []
    for name in builtin_scene_names():
        s = load_scene(name)
        rows.append(
            [f"`{name}`", _g(s.duration_s), ", ".join(s.effects), s.description.replace("|", "/")]
        )
    return _table(["scene", "duration (s)", "effects", "what"], rows) + (
        "\n\n*Rendered from `src/bathprint/scenes/*.toml` (`bathprint scenes` lists them).*"
    )


# ------------------------------------------------------------------ validation
@cache
def validation_data() -> dict[str, Any]:
    """``bathprint validate --json``, run once per process (or read from the file that
    ``$BATHPRINT_VALIDATION_JSON`` names)."""
    path = os.environ.get("BATHPRINT_VALIDATION_JSON")
    if path:
        return json.loads(Path(path).read_text())
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(ROOT / "src"), env.get("PYTHONPATH", "")])
    proc = subprocess.run(
        [sys.executable, "-m", "bathprint.cli", "validate", "--json"],
        capture_output=True,
        text=True,
        env=env,
        cwd=ROOT,
        timeout=900,
    )
    if proc.returncode not in (0, 1) or not proc.stdout.strip():
        raise RenderError(f"bathprint validate --json failed: {proc.stderr.strip()[-2000:]}")
    return json.loads(proc.stdout)


def validation() -> str:
    data = validation_data()
    rows = []
    for c in data["checks"]:
        unit = c.get("unit", "")
        unit = "" if unit in ("", "-") else f" {unit}"
        rows.append(
            [
                c["name"],
                f"{_g(c['simulated'], 6)}{unit}",
                f"{_g(c['exact'], 6)}{unit}",
                _g(c["relative_error"], 2),
                _g(c["tolerance"], 1),
                "yes" if c["passed"] else "**no**",
            ]
        )
    table = _table(["check", "simulated", "exact", "relative error", "tolerance", "passed"], rows)
    return (
        f"{table}\n\n*Produced by `{data['command']}` (bathprint {data['bathprint']}) on "
        f"{data['date']} in {data['wall_s']:.1f} s; machine: {data['machine']}.*"
    )


# ------------------------------------------------------------------ performance
def default_scene() -> str:
    path = result("default_paper_simulation.csv")
    r = _csv(path)[0]
    rows = [
        ["simulated", f"{_g(r['simulated_s'])} s"],
        ["wall time", f"{_g(r['wall_s'])} s ({_g(r['wall_s_per_simulated_s'])} s per simulated s)"],
        ["steps (rejected)", f"{r['steps']} ({r['rejected']})"],
        ["nodes at the end", r["final_nodes"]],
        ["node-steps per second", _g(r["node_steps_per_s"], 2)],
        ["mean step / explicit stability limit", _g(r["mean_step_over_explicit_limit"], 2)],
    ]
    return _table(["`paper_simulation`", "value"], rows) + "\n\n" + provenance(path)


def scaling() -> str:
    path = result("scaling.csv")
    rows = [
        [
            r["nodes"],
            _g(r["us_per_step"]),
            _g(r["newton_per_step"], 2),
            _g(r["us_per_newton_per_node"], 2),
            f"{_g(r['cost_ratio_vs_100'], 2)} ({_g(r['linear_ratio'])})",
        ]
        for r in _csv(path)
    ]
    head = [
        "N",
        "µs/step",
        "Newton iterations/step",
        "µs per iteration per node",
        "cost vs N = 100 (linear)",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def effects() -> str:
    kpath, rpath = result("effects_kernels.csv"), result("effects_runs.csv")
    k = _table(
        ["effect", "ns per node (force and Jacobian)"],
        [[f"`{r['effect']}`", _g(r["ns_per_node"])] for r in _csv(kpath)],
    )
    r = _table(
        ["effects", "Newton iterations", "µs per Newton iteration"],
        [
            [x["effects"], x["newton_iterations"], _g(x["us_per_newton_iteration"])]
            for x in _csv(rpath)
        ],
    )
    return f"{k}\n\n{provenance(kpath)}\n\n{r}\n\n{provenance(rpath)}"


def _pareto(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    front: list[tuple[float, float]] = []
    for w, e in sorted((w, max(e, 1e-14)) for w, e in points):
        if not front or e < front[-1][1]:
            front.append((w, e))
    return front


def _cost_at(points: list[tuple[float, float]], target: float) -> float:
    """Wall time to reach error <= target, log-log along the Pareto front (as
    pyelastica/cantilever.py computes it)."""
    front = _pareto(points)
    if not front:
        return math.nan
    if target >= front[0][1]:
        return front[0][0]
    for (w0, e0), (w1, e1) in zip(front[:-1], front[1:], strict=True):
        if e0 >= target >= e1:
            f = (math.log(target) - math.log(e0)) / (math.log(e1) - math.log(e0))
            return math.exp(math.log(w0) + f * (math.log(w1) - math.log(w0)))
    return math.nan


def pyelastica(name: str = "pyelastica") -> str:
    path = result(f"{name}.csv")
    data = _csv(path)

    def pts(problem: str, code: str, n: str) -> list[tuple[float, float]]:
        return [
            (float(r["wall_s"]), float(r["error"]))
            for r in data
            if r["problem"] == problem and r["code"] == code and r["elements"] == n
        ]

    rows = []
    for n in sorted({r["elements"] for r in data}, key=int):
        pe = pts("a_steady", "pyelastica", n)
        bp = pts("a_steady", "bathprint", n)
        for level in (1e-3, 1e-4, 1e-6):
            pw, bw = _cost_at(pe, level), _cost_at(bp, level)
            if math.isfinite(pw) and math.isfinite(bw):
                rows.append(
                    [
                        "(a) steady deflection",
                        n,
                        f"error {_g(level)}",
                        _g(pw, 3),
                        _g(bw, 3),
                        f"**{_g(pw / bw, 3)}×**",
                    ]
                )
        pe_b = sorted(
            (float(r["knob_value"]), float(r["wall_s"]), float(r["error"]))
            for r in data
            if r["problem"] == "b_dynamic" and r["code"] == "pyelastica" and r["elements"] == n
        )[::-1]
        bp_b = pts("b_dynamic", "bathprint", n)
        if pe_b:
            dt_max = pe_b[0][0]
            for dt, wall, err in pe_b:
                bw = _cost_at(bp_b, err)
                label = "dt_max" if dt == dt_max else f"dt_max/{round(dt_max / dt)}"
                rows.append(
                    [
                        "(b) motion with inertia",
                        n,
                        f"{label}: error {_g(err, 2)}",
                        _g(wall, 3),
                        _g(bw, 3),
                        f"**{_g(wall / bw, 3)}×**" if math.isfinite(bw) else "–",
                    ]
                )
    head = [
        "problem",
        "elements",
        "PyElastica at",
        "PyElastica wall (s)",
        "bathprint wall (s) at that error",
        "ratio",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def profile() -> str:
    path = result("profile.csv")
    data = _csv(path)
    cases = list(dict.fromkeys(r["case"] for r in data))
    comps = [c for c in dict.fromkeys(r["component"] for r in data) if c != "whole step"]
    # the effects' Jacobians together, the GMRES iterations and "other" last
    last = {"krylov iterations": 1, "other": 2}
    comps.sort(key=lambda c: (last.get(c, 0), not c.startswith("assemble+J:")))
    by = {(r["case"], r["component"]): r for r in data}
    rows = []
    for comp in comps:
        rows.append(
            [comp.replace("\n", " ")]
            + [_g(by[(c, comp)]["pct_of_step"], 2) + "%" if (c, comp) in by else "–" for c in cases]
        )
    rows.append(
        ["**whole step (µs)**"]
        + [
            _g(by[(c, "whole step")]["us_per_step"], 3) if (c, "whole step") in by else "–"
            for c in cases
        ]
    )
    return _table(["component"] + cases, rows) + "\n\n" + provenance(path)


def _failure(text: str) -> str:
    """'FAIL: simulation diverged at t = T s, node N: CAUSE (...)' -> 'stops at t = T s: CAUSE'."""
    m = re.search(r"at t = ([\d.e+-]+) s, node \d+: ([^(]*?)(?: even at| \(|$)", text)
    return f"stops at t = {m.group(1)} s: {m.group(2).strip()}" if m else text[:80]


def hard_cases() -> str:
    path = result("hard_cases.csv")
    rows = []
    for r in _csv(path):
        ok = r["result"] == "ok"
        rows.append(
            [
                f"`{r['case']}`",
                f"`{r['scene']}`",
                _g(r["t_end_s"]),
                f"{r['steps']} / {r['rejected']}",
                r["nodes"] if ok else "–",
                _g(r["wall_s"], 2),
                _g(r["stretch_err"], 2) if ok else "–",
                _g(r["mass_err"], 1) if ok else "–",
                "ok" if ok else _failure(r["result"]),
            ]
        )
    head = [
        "case",
        "scene",
        "simulated (s)",
        "steps / rejected",
        "nodes",
        "wall (s)",
        "worst stretch",
        "mass error",
        "result",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def freezing_coil() -> str:
    path = result("freezing_coil.csv")
    rows = [
        [
            r["preset"],
            r["variant"],
            _pct(r["radius_change"]),
            _pct(r["frequency_change"]),
            f"{_g(r['wall_ratio'], 2)}×",
        ]
        for r in _csv(path)
    ]
    return _table(["preset", "variant", "ΔR/R", "Δω/ω", "wall time vs not frozen"], rows) + (
        "\n\n" + provenance(path)
    )


def freezing_turns() -> str:
    path = result("freezing_turns.csv")
    rows = [
        [
            r["preset"],
            f"{_g(r['freeze_beyond_mm'])} mm",
            f"{_pct(r['near_needle_change_mean'])} ({_pct(r['near_needle_change_min'])} to "
            f"{_pct(r['near_needle_change_max'])})",
            f"{100 * float(r['near_needle_seed_spread']):.2g}%",
            _pct(r["core_median_change_mean"]),
            f"{_pct(r['largest_turn_change'])} (turn {r['largest_turn_index']})",
            f"{_g(r['wall_ratio'], 2)}×",
        ]
        for r in _csv(path)
    ]
    head = [
        "preset",
        "frozen beyond",
        "ΔR of the 3 turns at the needle: mean (seeds' range)",
        "their R from seed to seed (std)",
        "ΔR, median of the core turns",
        "largest mean ΔR of one turn",
        "wall time vs not frozen",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def freezing_onset(name: str = "freezing_onset") -> str:
    """``freezing.py --part onset`` (or ``--part onset_wide``, result file ``name``):
    per contact onset, the mean change over the seeds (and their range) of the coil at the
    needle, with inertia."""
    path = result(f"{name}.csv")
    table = _csv(path)
    cols = [
        "frozen_100mm_change",
        "tighter_change",
        "free_60mm_change",
        "free_150mm_change",
        "clamped_60mm_change",
    ]
    rows = []
    for onset in dict.fromkeys(r["onset"] for r in table):
        mine = [r for r in table if r["onset"] == onset]
        cells = [onset, str(len(mine))]
        for c in cols:
            v = [float(r[c]) for r in mine]
            cells.append(f"{_pct(sum(v) / len(v))} ({_pct(min(v))} to {_pct(max(v))})")
        rows.append(cells)
    head = ["contact onset", "seeds", "frozen beyond 100 mm (clamped)", "tenfold tolerance"]
    head += ["free joint, beyond 60 mm", "free joint, beyond 150 mm", "clamped, beyond 60 mm"]
    return _table(head, rows) + "\n\n" + provenance(path)


def freezing_damping() -> str:
    """``freezing.py --part damping``: per variant, the mean change over the seeds (and
    their range) of the coil at the needle by freezing and by the tenfold tolerance."""
    path = result("freezing_damping.csv")
    table = _csv(path)
    rows = []
    for variant in dict.fromkeys(r["variant"] for r in table):
        mine = [r for r in table if r["variant"] == variant]
        cells = [variant, str(len(mine))]
        for c in ("frozen_100mm_change", "tighter_change"):
            v = [float(r[c]) for r in mine]
            cells.append(f"{_pct(sum(v) / len(v))} ({_pct(min(v))} to {_pct(max(v))})")
        rows.append(cells)
    head = ["variant", "seeds", "frozen beyond 100 mm (clamped)", "tenfold tolerance"]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_dashpot_overdamped() -> str:
    """``contact_newton.py --part dashpot_overdamped``: how far the overdamped pile
    gets with contact's dashpot, and why it stops."""
    path = result("contact_dashpot_overdamped.csv")
    rows = []
    for r in _csv(path):
        failure = r["failure"]
        cause = "–"
        if failure:  # the cause, without its parenthesised (and nested) details
            cause, inner = failure.split(": ", 1)[-1], ""
            while inner != cause:
                inner, cause = cause, re.sub(r"\s*\([^()]*\)", "", cause)
            cause = cause.strip()
        rows.append(
            [
                f"{_g(float(r['damping_time_s']) * 1e3)} ms",
                f"{_g(r['reached_s'], 3)} s",
                r["steps"],
                _g(r["newton_per_step"]),
                _g(r["krylov_per_newton"]),
                _g(r["wall_s"]),
                cause,
            ]
        )
    head = ["dashpot", "reached", "steps", "Newton per step", "Krylov per Newton", "wall (s)"]
    return _table([*head, "failure"], rows) + "\n\n" + provenance(path)


def hydro_all_effects() -> str:
    """``hydrodynamics.py all_effects``: the ablation's "all" run on a pile as planned
    and with one thing changed."""
    path = result("hydro_all_effects.csv")
    rows = []
    for r in _csv(path):
        ok = not r["failure"]
        steps, newton, krylov = (
            float(r[k] or "nan") for k in ("steps", "newton_iterations", "krylov_iterations")
        )
        rows.append(
            [
                r["variant"],
                f"{_g(r['reached_s'], 4)} of {_g(r['duration_s'])} s",
                r["steps"] if ok else "–",
                _g(newton / steps, 3) if ok else "–",
                _g(krylov / newton, 3) if ok else "–",
                r["krylov_failures"] if ok else "–",
                _g(r["smallest_gap_ratio"], 3),
                _g(r["wall_s"]),
                r["failure"] or "–",
            ]
        )
    head = [
        "variant",
        "reached",
        "steps",
        "Newton per step",
        "Krylov per Newton",
        "Krylov failures",
        "smallest gap / (r_A + r_B), any frame",
        "wall (s)",
        "failure",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_mobility() -> str:
    """``hydrodynamics.py mobility``: I + R M W^-1 on the all_effects run, with and
    without contact."""
    path = result("hydro_mobility.csv")
    rows = []
    for r in _csv(path):
        if r["failure"]:
            rows.append([r["variant"], _g(r["time_s"], 4), "–", "–", "–", "–", r["failure"]])
            continue
        rows.append(
            [
                r["variant"],
                _g(r["time_s"], 4),
                r["free_nodes"],
                f"{_g(r['eig_real_min'], 3)} to {_g(r['eig_real_max'], 3)}",
                _g(r["singular_min"], 3),
                _g(r["min_gap_ratio"], 3),
                "–",
            ]
        )
    head = [
        "variant",
        "t (s)",
        "free nodes",
        "real parts of the eigenvalues",
        "smallest singular value",
        "smallest gap / (r_A + r_B)",
        "failure",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_failing_solve() -> str:
    """``hydrodynamics.py failing_solve``: at each variant's first failed GMRES solve."""
    path = result("hydro_failing_solve.csv")
    rows = []
    for r in _csv(path):
        if not r.get("time_s"):
            rows.append([r["variant"], "no failed solve"] + ["–"] * 6)
            continue
        rows.append(
            [
                r["variant"],
                _g(r["time_s"], 5),
                r["solve"],
                r["free_nodes"],
                _g(r["eig_real_min"], 3),
                f"{_g(r['mobility_min'], 3)} to {_g(r['mobility_max'], 3)}",
                _g(r["resistance_over_stokes_max"], 3),
                _g(r["min_gap_ratio"], 3),
            ]
        )
    head = [
        "variant",
        "failed at (s)",
        "solve",
        "free nodes",
        "smallest real part of eig(I + R M W^-1)",
        "mobility's eigenvalues (m/(N s))",
        "largest R_i / Stokes window's",
        "smallest gap / (r_A + r_B)",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_kernel_drag() -> str:
    """``hydrodynamics.py kernels``: a rigid cylinder's drags over Tirado's, each kernel."""
    path = result("hydro_kernel_drag.csv")
    by: dict[tuple[str, str], dict] = {}
    for r in _csv(path):
        by[(r["aspect"], r["segments_per_diameter"])] = {
            **by.get((r["aspect"], r["segments_per_diameter"]), {}),
            r["kernel"]: r,
        }
    rows = []
    for (aspect, per_d), k in by.items():
        cells = [aspect, per_d]
        for kernel in ("slender_body", "rpy"):
            r = k[kernel]
            along = float(r["along_over_tirado"]) - 1
            across = float(r["across_over_tirado"]) - 1
            cells.append(f"{along:+.1%} / {across:+.1%}")
        rows.append(cells)
    head = ["L/d", "segments per diameter", "Stokeslet segments (along / across)", "RPY blobs"]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_kernel_mobility() -> str:
    """``hydrodynamics.py kernels``: the pressed coils' mobility, each kernel."""
    path = result("hydro_kernel_mobility.csv")
    rows = [
        [
            r["pitch_mm"],
            "Stokeslet segments" if r["kernel"] == "slender_body" else "RPY blobs",
            _g(r["eig_real_min"], 3),
            _g(r["mobility_min_over_max"], 3),
            _g(r["asymmetry"], 2),
            _g(r["gate_min"], 3) if r["kernel"] == "rpy" else "–",
        ]
        for r in _csv(path)
    ]
    head = [
        "pitch (mm)",
        "kernel",
        "smallest real part of eig(I + R M W^-1)",
        "mobility: smallest / largest eigenvalue",
        "asymmetry",
        "smallest gate",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_kernel_cost() -> str:
    """``hydrodynamics.py kernels``: one nonlocal evaluation, each kernel."""
    path = result("hydro_kernel_cost.csv")
    rows = [
        [
            r["N"],
            _g(float(r["slender_body_s"]) * 1e3, 3),
            _g(float(r["rpy_s"]) * 1e3, 3),
            _g(float(r["rpy_gates_s"]) * 1e3, 3),
            f"{_g(r['rpy_over_slender_body'], 3)}×",
        ]
        for r in _csv(path)
    ]
    head = [
        "nodes",
        "Stokeslet segments (ms)",
        "RPY blobs (ms)",
        "their gates (ms)",
        "RPY with gates / segments",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_coiling() -> str:
    """``hydrodynamics.py coiling``: drag_coiling_22G with each drag model and
    coupling, wall time against local Cox drag, and the coil each gives."""
    path = result("hydro_coiling.csv")
    rows = [
        [
            r["variant"],
            _g(r["simulated_s"], 3),
            _g(r["wall_s"], 3),
            f"{_g(r['ratio_to_cox'], 3)}×",
            r["steps"],
            r["newton"],
            r["krylov"],
            r["evaluations"],
            _g(r["coil_radius_mm"], 3),
            _g(r["coil_pitch_mm"], 3),
            r["status"],
        ]
        for r in _csv(path)
    ]
    head = [
        "variant",
        "simulated (s)",
        "wall (s)",
        "wall / local Cox",
        "steps",
        "Newton",
        "Krylov",
        "flow evaluations",
        "coil radius (mm)",
        "pitch (mm)",
        "status",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def hydro_kernel_coils() -> str:
    """``hydrodynamics.py kernel_coils``: the coil each kernel measures."""
    path = result("hydro_kernel_coils.csv")
    keys = ("buckling_length_m", "coil_radius_m", "coil_pitch_m", "coil_frequency_rad_s")
    by = {(r["diameter_mm"], r["q_outer_ml_min"], r["kernel"]): r for r in _csv(path)}
    rows = []
    for (d, q, kernel), r in by.items():
        base = by.get((d, q, "slender_body"))
        change = "–"
        if kernel != "slender_body" and base is not None:
            change = " / ".join(
                f"{float(r[k]) / float(base[k]) - 1:+.1%}" if r[k] and base[k] else "–"
                for k in keys
            )
        rows.append(
            [
                d,
                q,
                "Stokeslet segments" if kernel == "slender_body" else "RPY blobs",
                r["regime"],
                *(_g(float(r[k]) * 1e3, 3) if r[k] else "–" for k in keys[:3]),
                _g(r["coil_frequency_rad_s"], 3),
                change,
                _g(r["min_gap_ratio"], 3),
                _g(r["wall_s"], 3),
            ]
        )
    head = [
        "d (mm)",
        "Q (ml/min)",
        "kernel",
        "regime",
        "l (mm)",
        "R (mm)",
        "pitch (mm)",
        "omega (rad/s)",
        "against the segments (l / R / pitch / omega)",
        "smallest gap / (r_A + r_B)",
        "wall (s)",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def freezing_rope() -> str:
    path = result("freezing_rope.csv")
    rows = [
        [
            r["variant"],
            f"{_g(r['reached_s'], 3)} s",
            f"{r['frozen_nodes']} of {r['nodes']}",
            f"{_g(r['near_needle_rms_mm'], 2)} mm" if r["near_needle_rms_mm"] != "nan" else "–",
            f"{_g(r['pile_centre_shift_mm'], 2)} mm" if r["pile_centre_shift_mm"] != "nan" else "–",
            f"{r['steps']} / {r['rejected']}",
            f"{_g(r['wall_ratio'], 2)}×",
        ]
        for r in _csv(path)
    ]
    head = [
        "variant",
        "simulated",
        "frozen nodes",
        "change near the needle (RMS)",
        "pile centre shift",
        "steps / rejected",
        "wall time",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def freezing_envs() -> str:
    path = result("freezing_envs.csv")
    rows = [
        [
            f"`{r['env']}`",
            r["episodes"],
            _g(r["freezing_change"], 2),
            _g(r["draft_vs_balanced"], 2),
            f"{_g(r['speedup'], 2)}×",
        ]
        for r in _csv(path)
    ]
    head = [
        "environment",
        "episodes",
        "final metric change by freezing",
        "draft vs balanced",
        "speed-up",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def accuracy_presets() -> str:
    path = EXPERIMENTS / "accuracy" / "results" / "presets.csv"
    data = _csv(path)
    by = {(r["problem"], r["knob"]): r for r in data}
    rows = []
    for preset in ("draft", "balanced", "fine"):
        row = [f"`{preset}`"]
        for problem in ("cantilever", "onset", "coil_radius"):
            r = by.get((problem, preset))
            if r is None:
                row.append("–")
                continue
            err = float(r["error"])
            wall = float(r["wall_s"])
            e = "reference" if err == 0 and problem.startswith("coil") else _g(err, 2)
            row.append(f"{e} / {_g(wall * 1e3, 2)} ms" if wall < 1 else f"{e} / {_g(wall, 2)} s")
        r = by.get(("coil_frequency", preset))
        row.append("reference" if r and float(r["error"]) == 0 else _g(r["error"], 2) if r else "–")
        rows.append(row)
    head = [
        "preset",
        "cantilever error / wall",
        "onset error / wall",
        "coil radius error / wall",
        "coil frequency error",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def _one_process(rows: list[dict[str, str]]) -> list[dict[str, str]]:
    """Rows of one process (the benchmark also measures two processes in total)."""
    return [r for r in rows if r.get("processes", "1") in ("", "1")]


def envs_speed() -> str:
    path = result("envs.csv")
    data = _one_process(_csv(path))
    envs = list(dict.fromkeys(r["env"] for r in data))
    by = {(r["env"], r["accuracy"]): r for r in data}
    rows = [
        [f"`{e}`"]
        + [
            _g(by[(e, a)]["steps_per_cpu_s"], 4) if (e, a) in by else "–"
            for a in ("draft", "balanced", "fine")
        ]
        for e in envs
    ]
    load = {r["load_avg_1min"] for r in data}
    return _table(["environment", "draft", "balanced", "fine"], rows) + (
        f"\n\nSteps per CPU second of one process, random actions with resets "
        f"(load average {', '.join(sorted(load))}).\n\n" + provenance(path)
    )


# ------------------------------------------------------------------ agents
_POLICY_NAMES = {
    "random": "random",
    "constant": "best constant",
    "feedforward": "feedforward (paper's law)",
    "feedforward_calibrated": "feedforward, calibrated",
}
_RUN_NAMES = {"ppo": "PPO", "sac": "SAC", "ppores": "PPO residual on calibrated feedforward"}


def _agent_rows(env: str) -> tuple[dict[str, tuple[str, str]], Path]:
    path = AGENTS / env / "table.json"
    if not path.is_file():
        raise RenderError(f"{_rel(path)} does not exist (bathprint evaluate ... --out)")
    out: dict[str, tuple[str, str]] = {}
    for r in json.loads(path.read_text()):
        label = r["policy"]
        budget = ""
        if ":" in label:  # algo:run_Env
            run = label.split(":", 1)[1].rsplit("_", 1)[0]
            info = AGENTS / env / f"run_{run}.json"
            name = _RUN_NAMES.get(run, run)
            if info.is_file():
                rj = json.loads(info.read_text())
                steps = rj.get("timesteps_done") or rj.get("n_timesteps")
                budget = f" ({_g(steps / 1e3, 3)}k steps, {_g(rj['wall_time_s'] / 60, 2)} min)"
        else:
            name = _POLICY_NAMES.get(label, label)
        out[name] = (f"{r['mean_metric']:.3f} ± {r['std_metric']:.3f}{budget}", label)
    return out, path


def agents() -> str:
    envs = sorted(p.name for p in AGENTS.iterdir() if (p / "table.json").is_file())
    tables = {e: _agent_rows(e) for e in envs}
    names = list(dict.fromkeys(n for e in envs for n in tables[e][0]))
    best = {}
    for e in envs:
        vals = {n: float(v[0].split(" ")[0]) for n, v in tables[e][0].items()}
        best[e] = min(vals, key=vals.get)
    rows = []
    for n in names:
        row = [n]
        for e in envs:
            v = tables[e][0].get(n)
            row.append("–" if v is None else (f"**{v[0]}**" if best[e] == n else v[0]))
        rows.append(row)
    head = ["policy"] + [f"{e}-v0" for e in envs]
    dates = sorted(
        {" ".join(x for x in _committed(tables[e][1]) if x) or "uncommitted" for e in envs}
    )
    srcs = (
        f"*Source: `agents/results/{{{','.join(envs)}}}/table.json` (committed "
        f"{', '.join(dates)}); machine: not recorded in the files.*"
    )
    return (
        _table(head, rows)
        + "\n\nMean ± standard deviation of the final shape metric over the 16 held-out "
        "targets (seed 0, draft preset; lower is better; best in bold). Training budgets are "
        "environment steps and the wall time `run.json` records (a resumed run counts from "
        "its resume).\n\n"
        + srcs
        + " Command: `bathprint evaluate RUN... random constant feedforward "
        "feedforward_calibrated --env ENV --episodes 16 --seed 0`."
    )


#: the campaigns (version 1 and later) whose tables the docs render
#: (agents/results/<Env>/results.json)
CAMPAIGN_ENVS = (
    "CoilRadius-v1",
    "BuoyantLayers-v1",
    "WriteShape-v1",
    "WriteShape-v2",
    "CoilRadius-v2",
    "WriteShape-v3",
    "BuoyantLayers-v2",
)


def campaign(env: str) -> str:
    """The results table of one version-1 campaign (``bathprint.agents.campaign``'s
    results.md, rebuilt from its results.json), with the command and the runs' machine."""
    from bathprint.agents.campaign import format_results

    path = AGENTS / env / "results.json"
    if not path.is_file():
        raise RenderError(
            f"{_rel(path)} does not exist (python -m bathprint.agents.campaign "
            f"agents/campaigns/{env}.yml --export agents/results)"
        )
    table = format_results(json.loads(path.read_text())).split("\n\n", 1)[1].rstrip()
    machines = set()
    runs_csv = path.with_name("runs.csv")
    for r in _csv(runs_csv) if runs_csv.is_file() else []:
        info = AGENTS / env / r["name"] / f"seed{r['seed']}"
        if (info / "run.json").is_file():
            m = json.loads((info / "run.json").read_text()).get("machine", {})
            machines.add(f"{m.get('processor', '?')}, {m.get('cpus', '?')} cores")
    date, commit = _committed(path)
    when = f"committed {date}, {commit}" if date else "not yet committed"
    return table + (
        f"\n\n*Source: `{_rel(path)}` ({when}), written by `python -m "
        f"bathprint.agents.campaign agents/campaigns/{env}.yml --export agents/results`; "
        f"machine: {'; '.join(sorted(machines)) or 'not recorded'} (`runs.csv`: each run's "
        "cores, load at its start, steps, wall and CPU seconds).*"
    )


# ------------------------------------------------------------------ the paper reproduced
REPRODUCE = EXPERIMENTS / "paper" / "results"


def _reproduce() -> dict[str, Any]:
    path = REPRODUCE / "reproduce.json"
    if not path.is_file():
        raise RenderError(
            f"{_rel(path)} does not exist (bathprint reproduce all --out experiments/paper/results)"
        )
    return json.loads(path.read_text())


def _reproduce_source(*names: str) -> str:
    """Provenance of files of experiments/paper/results: reproduce.meta.json's, or its
    ``files`` entry where one file was rewritten alone (``bathprint reproduce NAME``)."""
    meta = json.loads((REPRODUCE / "reproduce.meta.json").read_text())
    alone = meta.get("files", {})
    if len(names) == 1 and names[0] in alone:
        m = {**meta, **alone[names[0]]}
        return (
            f"*Source: `{_rel(REPRODUCE / names[0])}`, written by `{m['command']}` "
            f"on {m['date']} (commit {m['commit']}); machine: {m['machine']}.*"
        )
    # reproduce.json holds every part and is rewritten when one part runs alone: its
    # provenance is reproduce.meta.json's, with the part run alone named apart
    names = names or ("reproduce.json",)
    files = ", ".join(f"`{_rel(REPRODUCE / n)}`" for n in names)
    text = (
        f"*Source: {files}, written by `{meta['command']}` on {meta['date']} "
        f"(commit {meta['commit']}); machine: {meta['machine']}"
    )
    for name, m in alone.items():
        part = name.split(".")[0]
        if name in names or "reproduce.json" in names:
            text += f"; {part} by `{m['command']}` on {m['date']} (commit {m['commit']})"
    return text + ".*"


def reproduce_times() -> str:
    data = _reproduce()
    rows = [[f"`{k}`", _g(v.get("wall_time_s"), 2)] for k, v in data.items()]
    return _table(["figure", "wall time (s)"], rows) + "\n\n" + _reproduce_source()


def stability_onsets() -> str:
    res = _reproduce()["stability"]["result"]
    bc = res["beta_c"]
    rows = [[k, f"{v:.4f}", _pct(v / bc - 1, 2)] for k, v in res["simulated_onsets"].items()]
    return _table(["simulated rod", "onset β", "vs β_c = " + f"{bc:.4f}"], rows) + (
        "\n\n" + _reproduce_source("stability.csv", "reproduce.json")
    )


def coils() -> str:
    res = _reproduce()["coils"]["result"]
    rows = [
        [
            k,
            str(v["turns"]),
            str(v["core_turns"]),
            f"{1e3 * v['median_radius_m']:.2f} mm",
            f"{100 * v['radius_spread']:.2g}%",
        ]
        for k, v in res.items()
    ]
    head = [
        "filament",
        "turns below the needle",
        "turns in the trimmed core",
        "median coil radius",
        "radius spread (core)",
    ]
    return _table(head, rows) + "\n\n" + _reproduce_source("coils.csv", "reproduce.json")


def _agreement(relative_difference: float) -> str:
    """A relative difference as the docs print it: round-off (which varies between CPUs)
    as a bound, anything larger as its value."""
    if relative_difference < 1e-13:
        return "round-off (below 1e-13)"
    return _g(relative_difference, 1)


def paper_constants() -> str:
    from bathprint.analysis import theory

    th = theory.summary_dict()
    paper = th["paper"]
    fit = _reproduce()["fig2"]["result"]
    rows2 = [
        r
        for r in _csv(REPRODUCE / "fig2.csv")
        if r["regime"] == "drag_coiling" and r["buckling_length_m"]
    ]
    lb = [float(r["buckling_length_m"]) / float(r["scale_B_mu_v_m"]) for r in rows2]
    fig1c = _reproduce()["fig1c"]["result"]["paper_points"]
    sim_regimes = ", ".join(v["simulated"].replace("_", " ") for v in fig1c.values())
    paper_regimes = ", ".join(v["paper"].replace("_", " ") for v in fig1c.values())
    rows = [
        [
            "β_c (onset)",
            _g(paper["BETA_C"]),
            f"{th['beta_c']:.4f} (theory, two methods agree to "
            f"{_agreement(th['beta_c_relative_difference'])})",
        ],
        ["L_c / (B/(μ_s v))^(1/3)", "—", f"{th['critical_length_prefactor']:.4f}"],
        [
            "L_c / (B/(μ v))^(1/3), Cox's μ_s",
            _g(paper["LC_PREFACTOR"]),
            f"{th['paper_prefactor_with_cox_mean']:.2f} (mean over the paper's r, v range; "
            f"{th['paper_prefactor_with_cox_min']:.2f}–{th['paper_prefactor_with_cox_max']:.2f})",
        ],
        [
            "buckling length l / (B/(μv))^(1/3), simulated",
            "1.04 (experiments)",
            f"{min(lb):.2f}–{max(lb):.2f} ({len(lb)} drag-coiling runs)" if lb else "–",
        ],
        ["l = a R", f"a = {_g(paper['L_OVER_R'])}", f"a = {fit['l_over_R']:.2f}"],
        [
            "l = a R, l where the coil reaches 0.9 R",
            f"a = {_g(paper['L_OVER_R'])}",
            f"a = {fit['l_over_R_by_definition']['full_radius']:.2f}",
        ],
        [
            "R = b (B/(μv))^(1/3)",
            f"b = {_g(paper['R_PREFACTOR'])}",
            f"b = {fit['R_prefactor']:.2f} (B = E π r⁴/4); "
            f"{fit['R_prefactor_paper_B']:.2f} (the paper's B = E r⁴)",
        ],
        [
            "ω = c v^(4/3)(μ/B)^(1/3)",
            f"c = {_g(paper['OMEGA_PREFACTOR'])}",
            f"c = {fit['omega_prefactor']:.2f} (B = E π r⁴/4); "
            f"{fit['omega_prefactor_paper_B']:.2f} (the paper's B = E r⁴)",
        ],
        [
            "ω R / v",
            f"{_g(paper['R_PREFACTOR'] * paper['OMEGA_PREFACTOR'])} (b c)",
            f"{fit['omega_R_over_v_median']:.2f} (median over the runs)",
        ],
        ["Fig. 1B regimes at the paper's four points", paper_regimes, sim_regimes],
    ]
    return _table(["constant", "paper", "bathprint"], rows) + (
        "\n\n*The theory column is computed by `bathprint theory --json` when the site is "
        "built; the fits by `bathprint reproduce fig2` and `fig1c`.* "
        + _reproduce_source("fig2.csv", "fig1c.csv", "reproduce.json")
    )


def fig1c_regimes() -> str:
    rows = _csv(REPRODUCE / "fig1c.csv")
    ds = sorted({r["diameter_mm"] for r in rows}, key=float)
    qs = sorted({r["q_outer_ml_min"] for r in rows}, key=float)
    by = {(r["diameter_mm"], r["q_outer_ml_min"]): r for r in rows}
    body = []
    for d in ds:
        line = [f"{d} mm"]
        for q in qs:
            r = by.get((d, q))
            line.append("–" if r is None else (r["regime"] or r["status"]).replace("_", " "))
        body.append(line)
    return _table(["needle d \\ Q_o (ml/min)"] + qs, body) + "\n\n" + _reproduce_source("fig1c.csv")


def fig3_settling() -> str:
    rows = _csv(REPRODUCE / "fig3e_settling.csv")
    comp = _csv(REPRODUCE / "fig3df_composites.csv")
    rho_gel = float(comp[0]["density_kg_m3"])
    body = []
    for r in rows:
        rho = float(r["density_kg_m3"])
        body.append(
            [
                r["filament"],
                f"{rho:.0f}",
                f"{1e3 * float(r['settled_height_m']):+.3f} mm",
                f"{1e3 * float(r['expected_height_m']):+.3f} mm",
                _g(abs(float(r["difference_m"])), 1) + " m",
            ]
        )
    head = [
        "paper's filament (Fig. 3E)",
        "ρ_c (kg/m³)",
        "settled at (simulated)",
        "where the column is as dense",
        "difference",
    ]
    return _table(head, body) + (
        f"\n\nPure alginate is {rho_gel:.0f} kg/m³; heights are below the surface (0), and a "
        "filament lighter than the top of the column floats.\n\n"
        + _reproduce_source("fig3e_settling.csv", "fig3df_composites.csv")
    )


# ------------------------------------------------------------------ the README's headline
def headline() -> str:
    d = _csv(result("default_paper_simulation.csv"))[0]
    env = {(r["env"], r["accuracy"]): r for r in _one_process(_csv(result("envs.csv")))}
    draft = [float(r["steps_per_cpu_s"]) for (e, a), r in env.items() if a == "draft"]
    pe = _csv(result("pyelastica.csv"))

    def pts(problem: str, code: str, n: str) -> list[tuple[float, float]]:
        return [
            (float(r["wall_s"]), float(r["error"]))
            for r in pe
            if r["problem"] == problem and r["code"] == code and r["elements"] == n
        ]

    ratios_b = []
    for n in ("50", "100"):
        pe_b = sorted(
            (float(r["knob_value"]), float(r["wall_s"]), float(r["error"]))
            for r in pe
            if r["problem"] == "b_dynamic" and r["code"] == "pyelastica" and r["elements"] == n
        )
        if pe_b:
            _, wall, err = pe_b[-1]  # dt_max
            ratios_b.append(wall / _cost_at(pts("b_dynamic", "bathprint", n), err))
    ratios_a = [
        _cost_at(pts("a_steady", "pyelastica", n), 1e-4)
        / _cost_at(pts("a_steady", "bathprint", n), 1e-4)
        for n in ("50", "100")
    ]
    v1 = {
        e: AGENTS / e / "results.json"
        for e in ("BuoyantLayers-v1", "CoilRadius-v1", "WriteShape-v1", "WriteShape-v2")
    }

    names = {
        "ppo_residual": "residual PPO",
        "ppo_bc": "PPO pretrained by cloning",
        "ppo_bc_e100": "PPO pretrained by cloning (100 epochs)",
        "ppo_bc_ens5": "PPO pretrained by cloning five actors",
        "ppo": "PPO",
        "sac": "SAC",
        "tqc_her": "TQC+HER",
    }
    against = {r["env"]: r for r in _csv(result("v1_against_controller.csv"))}

    refs = {"controller": "controller", "feedforward_calibrated": "calibrated feedforward"}

    def against_controller(env: str) -> str:
        """The agent chosen on validation against the classical reference chosen on
        validation, on the test targets: both means and their paired difference (95% CI)."""
        r = against[env]
        return (
            f"{env}: {names.get(r['agent'], r['agent'])} {float(r['agent_mean_metric']):.3f}, "
            f"{refs.get(r['reference'], r['reference'])} "
            f"{float(r['reference_mean_metric']):.3f} (difference "
            f"{float(r['difference']):+.2f} [{float(r['difference_lo']):+.2f}, "
            f"{float(r['difference_hi']):+.2f}])"
        )

    def span(values: list[float], digits: int = 2) -> str:
        lo, hi = _g(min(values), digits), _g(max(values), digits)
        return lo if lo == hi else f"{lo}–{hi}"

    _, shape_rows = _shape_rows()

    agent_files = _shape_agent_files()

    def shapes_row(fam: str) -> str:
        cells = []
        for pol in ("controller", "cem"):
            rs = [r for r in shape_rows if (r["family"], r["set"], r["policy"]) ==
                  (fam, "test", pol)]  # fmt: skip
            mean = sum(float(r["rms_mm"]) for r in rs) / len(rs)
            won = sum(r["success"] == "True" for r in rs)
            cells.append(f"{mean:.2f} mm ({won}/{len(rs)})")
        agent = "no agent"
        for f, env, path in agent_files:
            if f == fam:
                group = shape_headline(env)[0]
                r = next(r for r in _csv(path) if (r["set"], r["group"]) == ("test", group))
                agent = (f"{float(r['mean_rms_mm']):.2f} mm "
                         f"({float(r['success_rate']) * 100:.0f}% written; "
                         f"{float(r['minus_controller_mm']):+.2f} "
                         f"[{float(r['minus_controller_lo']):+.2f}, "
                         f"{float(r['minus_controller_hi']):+.2f}])")  # fmt: skip
        return f"{fam} {cells[0]} / {cells[1]} / {agent}"

    rows = [
        [
            "default scene (3 s, buckling and coiling)",
            f"{_g(d['wall_s'], 2)} s wall, {d['steps']} steps, {d['final_nodes']} nodes",
            "[performance](docs/performance.md)",
        ],
        [
            "against PyElastica, steady cantilever (error 1e-4)",
            f"{span(ratios_a)}× faster",
            "[performance](docs/performance.md#against-pyelastica)",
        ],
        [
            "against PyElastica, motion with inertia (its dt_max)",
            f"{span(ratios_b)}× faster",
            "[performance](docs/performance.md#against-pyelastica)",
        ],
        [
            "environments, draft preset",
            f"{span(draft, 3)} steps/s per core",
            "[environments](docs/environments.md)",
        ],
        [
            "shapes benchmark, test shapes: mean whole-shape error and shapes written, tuned "
            "controller / cem planner / the agent chosen on validation (3 seeds; its paired "
            "difference from the controller in the same episodes, 95% CI)",
            "; ".join(shapes_row(f) for f in ("floor", "free", "buoyant")),
            "[shapes](docs/shapes.md#references)",
        ],
        [
            "agents (version 1), test targets: mean metric M of the agent chosen on validation "
            "against the classical reference chosen on validation (the tuned controller, "
            "the calibrated feedforward or the best constant), and their paired difference "
            "(95% CI; lower is better); the targets are random printed curves",
            "; ".join(against_controller(e) for e in v1),
            "[agents](docs/agents.md)",
        ],
    ]
    srcs = [
        result("default_paper_simulation.csv"),
        result("pyelastica.csv"),
        result("envs.csv"),
        result("v1_against_controller.csv"),
        result("references.csv"),
        *(f for _, _, f in agent_files),
    ]
    dates = sorted({_committed(p)[0] or "uncommitted" for p in srcs})
    return _table(["what", "result", "details"], rows) + (
        "\n\nRendered by `python docs/_gen/render.py --write README.md` from "
        + f"{len(srcs)} result files under `experiments/` and `agents/results/` "
        + f"(measured {', '.join(dates)} on the 2-core development machine; the pages linked "
        "give each command and file)."
    )


def contact_scaling(name: str = "contact_scaling") -> str:
    """``contact_cost.py --part scaling`` (the sharp onset), or the result file ``name``
    (``contact_scaling_default``: ``--part scaling_default``, contact's default law)."""
    path = result(f"{name}.csv")
    unit = "δ" if name == "contact_scaling" else "(2r)"  # the sharp onset's δ is 2r
    rows = [
        [
            (
                f"apart (1.5 {unit})"
                if float(r["pitch_over_contact_distance"]) > 1
                else f"pressed (0.98 {unit})"
            )
            + (", axial coarse" if r.get("preconditioner") == "axial_coarse" else ""),
            r["nodes"],
            _g(r["us_per_step_none"]),
            _g(r["us_per_step_contact"]),
            f"{_g(r['ratio'], 3)}×",
            _g(r["ns_per_node_step_contact"]),
            _g(r["newton_per_step_contact"], 2),
            _g(r["krylov_per_newton"], 2),
            _g(r["near_per_segment"], 2),
            _g(r["warm_up_wall_s_contact"]) if r.get("warm_up_wall_s_contact") else "–",
        ]
        for r in _csv(path)
    ]
    head = [
        "turns",
        "nodes",
        "µs/step without",
        "µs/step with",
        "ratio",
        "ns per node-step with",
        "Newton per step",
        "Krylov per Newton",
        "near pairs per segment",
        "first 2 ms with (s)",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_hessian() -> str:
    path = result("contact_hessian.csv")
    rows = [
        [
            f"`{r['scene']}`",
            "exact (default)" if r["hessian"] == "exact" else "Gauss-Newton",
            _g(r["wall_s"]),
            f"{_g(r['wall_ratio'], 3)}×",
            r["steps"],
            _g(float(r["newton_iterations"]) / float(r["steps"]), 3),
            r["newton_failures"],
            _g(float(r["krylov_iterations"]) / float(r["newton_iterations"]), 3),
            _g(r["min_gap_ratio"], 3),
        ]
        for r in _csv(path)
    ]
    head = [
        "scene (as shipped)",
        "Hessian",
        "wall (s)",
        "wall / exact",
        "steps",
        "Newton per step",
        "Newton failures",
        "Krylov per Newton",
        "smallest gap / (r_i + r_j)",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_saturation() -> str:
    path = result("contact_saturation.csv")
    rows = [
        [
            r["nodes"],
            _g(r["turns"]),
            _g(1e3 * float(r["mean_step_s"]), 3),
            _g(r["stiffness_over_drag"], 3),
            _g(r["kappa_model"], 3),
            _g(r["krylov_bound"], 3),
            _g(r["krylov_per_newton"], 3),
            _g(r["krylov_over_bound"], 2),
            _g(r["newton_per_step_contact"], 2),
            _g(r["ns_per_node_step_none"]),
            _g(r["ns_per_node_step_contact"]),
            f"{_g(r['ratio'], 3)}×",
        ]
        for r in _csv(path)
    ]
    head = [
        "nodes",
        "turns T",
        "mean step (ms)",
        "a",
        "model κ",
        "model bound",
        "Krylov per Newton",
        "Krylov / bound",
        "Newton per step",
        "ns per node-step without",
        "with",
        "ratio",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_scaling_settled(name: str = "contact_scaling_settled") -> str:
    """``contact_cost.py --part settled`` (the sharp onset), or the result file ``name``
    (``contact_scaling_settled_default``: ``--part settled_default``, the default law)."""
    path = result(f"{name}.csv")
    rows = [
        [
            "axial coarse" if r["preconditioner"] == "axial_coarse" else "banded LU",
            r["nodes"],
            _g(r["ns_per_node_step_none"]),
            _g(r["ns_per_node_step_contact"]),
            f"{_g(r['ratio'], 3)}×",
            _g(r["newton_per_step_contact"], 2),
            _g(r["krylov_per_newton"], 2),
            _g(
                float(r["ns_per_node_step_contact"])
                / (float(r["newton_per_step_contact"]) * (1.0 + float(r["krylov_per_newton"])))
            ),
            _g(r["warm_up_wall_s_contact"]),
        ]
        for r in _csv(path)
    ]
    head = [
        "preconditioner",
        "nodes",
        "ns per node-step without",
        "with",
        "ratio",
        "Newton per step",
        "Krylov per Newton",
        "ns per node and preconditioner solve",
        "first 20 ms with (s)",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_late() -> str:
    path = result("contact_late.csv")
    rows = [
        [
            r["variant"],
            r["steps"],
            r["newton_failures"],
            _g(r["newton_per_step"]),
            _g(r["jacobians_per_step"]),
            _g(r["krylov_per_newton"]),
            _g(r["backtracks_per_step"]),
            _g(r["wall_s"]),
            f"{_g(r['wall_ratio'])}×",
        ]
        for r in _csv(path)
    ]
    head = ["`period_doubling_22G`, 0.80-0.86 s", "steps", "Newton failures"]
    head += ["Newton per step", "Jacobians per step", "Krylov per Newton"]
    head += ["backtracks per step", "wall (s)", "wall / without contact"]
    return _table(head, rows) + "\n\n" + provenance(path)


def backsub() -> str:
    path = result("backsub.csv")
    rows = [
        [
            r["nodes"],
            r["unknowns"],
            _g(r["rows_us"]),
            _g(r["columns_us"]),
            f"{_g(r['speed_up'])}×",
            _g(r["max_rel_difference"], 2),
        ]
        for r in _csv(path)
    ]
    head = ["nodes", "unknowns", "by rows (µs)", "by columns (µs)", "speed-up"]
    head += ["largest relative difference"]
    return _table(head, rows) + "\n\n" + provenance(path)


def lu_diagonal() -> str:
    path = result("lu_diagonal.csv")
    rows = [
        [
            r["matrix"],
            r["nodes"],
            r["unknowns"],
            r["rows_swapped_by_partial_pivoting"],
            "yes" if r["diagonal_pivots_pass"] == "True" else "no",
            _g(r["lu_partial_us"]),
            _g(r["lu_diagonal_us"]),
            f"{_g(r['lu_speed_up'])}×",
            _g(r["solve_partial_us"]),
            _g(r["solve_diagonal_us"]),
            f"{_g(r['solve_speed_up'])}×",
            _g(r["max_rel_difference"], 2),
        ]
        for r in _csv(path)
    ]
    head = ["matrix", "nodes", "unknowns", "rows swapped by partial pivoting"]
    head += ["diagonal pivots pass", "LU, partial pivoting (µs)", "LU, diagonal pivots (µs)"]
    head += ["speed-up", "solve, partial (µs)", "solve, diagonal (µs)", "speed-up"]
    head += ["largest relative difference"]
    return _table(head, rows) + "\n\n" + provenance(path)


def sampled_profile(name: str = "sampled_profile") -> str:
    """Share of the sampled window per kernel, one column per case; kernels under 1% in
    every case are summed into one row."""
    path = result(f"{name}.csv")
    data = _csv(path)
    cases = list(dict.fromkeys(r["case"] for r in data))
    share = {(r["case"], r["function"]): float(r["pct_of_window"]) for r in data}
    rest = "Python and the rest"
    names = [n for n in dict.fromkeys(r["function"] for r in data) if n != rest]
    names.sort(key=lambda n: -max(share.get((c, n), 0.0) for c in cases))
    shown = [n for n in names if max(share.get((c, n), 0.0) for c in cases) >= 1.0]
    small = [n for n in names if n not in shown]
    rows = [
        [f"`{n}`"] + [f"{_g(share[(c, n)], 2)}%" if (c, n) in share else "–" for c in cases]
        for n in shown
    ]
    if small:
        rows.append(
            [f"{len(small)} more kernels, under 1% each"]
            + [f"{_g(sum(share.get((c, n), 0.0) for n in small), 2)}%" for c in cases]
        )
    rows.append([rest] + [f"{_g(share.get((c, rest), 0.0), 2)}%" for c in cases])
    return _table(["kernel (self time)"] + cases, rows) + "\n\n" + provenance(path)


def contact_line_search() -> str:
    path = result("contact_line_search.csv")
    rows = [
        [
            r["nodes"],
            f"{r['steps_off']} / {r['steps_on']}",
            f"{r['newton_failures_off']} / {r['newton_failures_on']}",
            _g(r["newton_per_step_off"]),
            _g(r["newton_per_step_on"]),
            r["backtracks_on"],
            f"{_g(r['newton_ratio'])}×",
            f"{_g(r['wall_ratio'])}×",
        ]
        for r in _csv(path)
    ]
    head = ["nodes", "steps off / on", "Newton failures off / on", "Newton per step off"]
    head += ["on", "backtracks", "Newton iterations on / off", "wall on / off"]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_line_search_scene() -> str:
    path = result("contact_line_search_scene.csv")
    rows = [
        [
            f"`{r['scene']}`, {_g(r['duration_s'])} s",
            r["variant"],
            f"{r['steps']} / {r['rejected_steps']}",
            r["newton_failures"],
            _g(r["newton_per_step"]),
            _g(r["krylov_per_newton"]),
            _g(r["wall_s"]),
            f"{_g(r['wall_ratio'])}×",
        ]
        for r in _csv(path)
    ]
    head = ["scene", "variant", "steps / rejected", "Newton failures", "Newton per step"]
    head += ["Krylov per Newton", "wall (s)", "wall / without contact"]
    return _table(head, rows) + "\n\n" + provenance(path)


def _contact_scene_table(name: str, label: Any, first: str) -> str:
    """A table of ``contact_newton.py``'s 1 s scene runs; ``label(row)`` names a row."""
    path = result(f"{name}.csv")
    table = _csv(path)
    gaps = "touching_gap_p10_final" in table[0]  # columns of the later runs
    rows = [
        [
            label(r),
            f"{r['steps']} / {r['rejected_steps']}",
            r["contact_rejections"],
            r["newton_failures"],
            _g(r["newton_per_step"]),
            _g(r["jacobians_per_step"]),
            _g(r["krylov_per_newton"]),
            _g(r["min_gap_ratio"], 3),
            *(
                [f"{_g(r['touching_gap_p10_final'], 4)} / {_g(r['touching_gap_median_final'], 4)}"]
                if gaps
                else []
            ),
            _g(r["wall_s"]),
            f"{_g(r['wall_ratio'])}×",
        ]
        for r in table
    ]
    head = [first, "steps / rejected", "rejected by contact"]
    head += ["Newton failures", "Newton per step", "Jacobians per step", "Krylov per Newton"]
    head += ["smallest gap / 2r"]
    head += ["touching gaps / 2r at 1 s, 10th percentile / median"] if gaps else []
    head += ["wall (s)", "wall / without contact"]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_near_gap() -> str:
    return _contact_scene_table(
        "contact_near_gap", lambda r: r["variant"], "`period_doubling_22G`, 1 s"
    )


def contact_onset() -> str:
    return _contact_scene_table(
        "contact_onset", lambda r: r["variant"], "`period_doubling_22G`, 1 s"
    )


def contact_krylov() -> str:
    return _contact_scene_table(
        "contact_krylov_tolerance", lambda r: r["variant"], "`period_doubling_22G`, 1 s"
    )


def contact_seeds() -> str:
    return _contact_scene_table(
        "contact_seeds",
        lambda r: f"seed {r['seed']}, {r['variant']}",
        "`period_doubling_22G`, 1 s",
    )


def _bench_contact_newton():
    """``contact_newton.py`` as a module (its labels and
    summaries)."""
    sys.path.insert(0, str(EXPERIMENTS))  # the script imports _common and contact_cost
    try:
        from _common import experiment

        contact_newton = experiment("contact_newton")
    finally:
        sys.path.pop(0)
    return contact_newton


def _contact_ratio_table(name: str, label: str) -> str:
    """Contact's paired cost over the seeds of a ratio part of ``contact_newton.py``
    (result file ``name``, contact rows labelled ``label``), and the mean with its bootstrap
    interval (the bench's own ``ratio_summary``)."""
    path = result(f"{name}.csv")
    table = _csv(path)
    bench = _bench_contact_newton()
    without = {r["seed"]: r for r in table if r["variant"] == "without contact"}
    rows = []
    for r in table:
        if r["variant"] != label:
            continue
        w = without[r["seed"]]
        rows.append(
            [
                r["seed"],
                _g(w["wall_s"]),
                _g(r["wall_s"]),
                f"{_g(r['wall_ratio'])}×",
                f"{r['steps']} / {w['steps']}",
                f"{_g(r['newton_per_step'])} / {_g(w['newton_per_step'])}",
                f"{_g(r['jacobians_per_step'])} / {_g(w['jacobians_per_step'])}",
                _g(r["krylov_per_newton"]),
                _g(r["min_gap_ratio"], 3),
            ]
        )
    head = ["seed", "wall without (s)", "wall with (s)", "with / without", "steps with / without"]
    head += ["Newton per step", "Jacobians per step", "Krylov per Newton (with)"]
    head += ["smallest gap / 2r (with)"]
    m = bench.ratio_summary(table, label)
    summary = (
        f"Mean over {m['seeds']} seeds: **{_g(m['mean'])}×** [{_g(m['low'])}, {_g(m['high'])}] "
        f"(95% bootstrap interval), from {_g(m['min'])}× to {_g(m['max'])}×; "
        f"{m['within_goal']} of {m['seeds']} seeds within {bench.RATIO_GOAL:g}×."
    )
    return _table(head, rows) + "\n\n" + summary + "\n\n" + provenance(path)


def contact_ratio_seeds() -> str:
    """``contact_newton.py --part ratio``: contact by its defaults."""
    return _contact_ratio_table("contact_ratio_seeds", "contact")


def contact_ratio_seeds_inertia() -> str:
    """``--part ratio_inertia``: contact's cost with inertia listed in every run, by its
    defaults (with its dashpot) and by its former law without the dashpot."""
    bench = _bench_contact_newton()
    text = _contact_ratio_table("contact_ratio_seeds_inertia", "contact")
    table = _csv(result("contact_ratio_seeds_inertia.csv"))
    label = bench.SHARP_NO_DASHPOT_LABEL
    m = bench.ratio_summary(table, label)
    rows = [r for r in table if r["variant"] == label]
    gaps = [float(r["min_gap_ratio"]) for r in rows]
    newton = [float(r["newton_per_step"]) for r in rows]
    krylov = [float(r["krylov_per_newton"]) for r in rows]
    line = (
        f"With the sharp onset and no dashpot: **{_g(m['mean'])}×** "
        f"[{_g(m['low'])}, {_g(m['high'])}], from {_g(m['min'])}× to {_g(m['max'])}×; Newton "
        f"{_g(min(newton))}-{_g(max(newton))} per step, Krylov {_g(min(krylov))}-"
        f"{_g(max(krylov))} per Newton iteration, smallest gap {_g(min(gaps), 3)}-"
        f"{_g(max(gaps), 3)} (2r)."
    )
    head, source = text.rsplit("\n\n", 1)
    return head + "\n\n" + line + "\n\n" + source


def contact_ratio_seeds_sharp() -> str:
    """``--part ratio_sharp``: contact with its former law, the sharp onset."""
    return _contact_ratio_table("contact_ratio_seeds_sharp", _bench_contact_newton().SHARP_LABEL)


#: observable column: (what the table calls it, factor from SI to its unit)
_OBSERVABLE_SHOWN = {
    "needle_turns_radius_m": ("radius of the three turns next to the stem (mm)", 1e3),
    "needle_turns_pitch_m": ("their pitch (mm)", 1e3),
    "coil_radius_m": ("coil radius (mm)", 1e3),
    "coil_pitch_m": ("coil pitch (mm)", 1e3),
    "coil_frequency_rad_s": ("coil frequency (rad/s)", 1.0),
    "buckling_length_m": ("buckling length (mm)", 1e3),
    "plume_opening_angle_rad": ("plume opening angle (deg)", 180.0 / math.pi),
    "curvature_variance_1_m2": ("curvature variance (1/mm²)", 1e-6),
}


def _paired_change(r: dict) -> str:
    """An ``observable_comparison`` row's paired relative change, in % with its interval."""
    pct = [100 * r[k] for k in ("paired_change", "paired_change_low", "paired_change_high")]
    return f"{pct[0]:+.1f}% [{pct[1]:+.1f}, {pct[2]:+.1f}]"


def contact_onset_observables() -> str:
    """What the pile looks like at the end of the ratio parts' runs: without contact, with
    the sharp onset (the former default) and with the onset before contact (the default),
    each change paired seed by seed (``bench_contact_newton.observable_comparison``)."""
    bench = _bench_contact_newton()
    default_path = result("contact_ratio_seeds.csv")
    sharp_path = result("contact_ratio_seeds_sharp.csv")
    default, sharp = _csv(default_path), _csv(sharp_path)
    label = bench.SHARP_LABEL
    by_contact = bench.observable_comparison(default, "without contact", default, "contact")
    by_onset = bench.observable_comparison(sharp, label, default, "contact")
    contact_change = {r["observable"]: r for r in by_contact}

    rows = []
    for r in by_onset:
        key = r["observable"]
        if key == "regime":
            continue
        name, unit = _OBSERVABLE_SHOWN[key]
        c = contact_change.get(key)
        rows.append(
            [
                name,
                str(r["seeds"]),
                _g(c["mean without contact"] * unit) if c else "–",
                _g(r[f"mean {label}"] * unit),
                _g(r["mean contact"] * unit),
                _paired_change(c) if c else "–",
                _paired_change(r),
                f"{100 * r['seed_spread']:.1f}%",
            ]
        )
    head = ["at the end of 1 s", "seeds", "without contact", "sharp onset"]
    head += ["onset before contact (default)", "contact's change (paired)"]
    head += ["the onset's change (paired)", "seed-to-seed spread (sharp onset)"]
    regimes = Counter(r["regime"] for r in sharp if r["variant"] == label)
    regimes_onset = Counter(r["regime"] for r in default if r["variant"] == "contact")
    regimes_without = Counter(r["regime"] for r in default if r["variant"] == "without contact")

    def names(c: Counter) -> str:
        return ", ".join(f"{k.replace('_', ' ')} {n}" for k, n in sorted(c.items()))

    same = next(r for r in by_onset if r["observable"] == "regime")
    line = (
        f"Regime at 1 s: without contact {names(regimes_without)}; sharp onset "
        f"{names(regimes)}; onset before contact {names(regimes_onset)} (the same as the "
        f"sharp onset on {same['same_regime']} of {same['seeds']} seeds)."
    )
    return _table(head, rows) + "\n\n" + line + "\n\n" + provenance(default_path, sharp_path)


def contact_onset_split() -> str:
    """The two changes from the sharp onset to the default one at a time, paired seed by
    seed: the onset widened to 0.2 delta at the sum of the radii (``--part ratio_wide``),
    then started at 1.02 (r_A + r_B) (the default, ``--part ratio``); each set's cost."""
    bench = _bench_contact_newton()
    paths = [result(f"contact_ratio_seeds{s}.csv") for s in ("_sharp", "_wide", "")]
    sharp, wide, default = (_csv(p) for p in paths)
    labels = (bench.SHARP_LABEL, bench.WIDE_LABEL, "contact")
    widen = {
        r["observable"]: r for r in bench.observable_comparison(sharp, labels[0], wide, labels[1])
    }
    start = {
        r["observable"]: r for r in bench.observable_comparison(wide, labels[1], default, labels[2])
    }

    rows = []
    for key, w in widen.items():
        if key == "regime" or key not in start:
            continue
        name, unit = _OBSERVABLE_SHOWN[key]
        s = start[key]
        rows.append(
            [
                name,
                _g(w[f"mean {labels[0]}"] * unit),
                _g(w[f"mean {labels[1]}"] * unit),
                _g(s[f"mean {labels[2]}"] * unit),
                _paired_change(w),
                _paired_change(s),
            ]
        )
    costs = []
    for table, label in zip((sharp, wide, default), labels, strict=True):
        costs.append(f"{_g(bench.ratio_summary(table, label)['mean'])}×")
    rows.append(["with / without contact (mean)", *costs, "", ""])
    head = ["at the end of 1 s (10 seeds)", "sharp onset (0.02 δ from 2r)"]
    head += ["0.2 δ from 2r", "0.2 δ from 1.02 (2r) (default)", "widening (paired)"]
    head += ["starting before contact (paired)"]
    return _table(head, rows) + "\n\n" + provenance(*paths)


def contact_onset_buckling() -> str:
    """``contact_newton.py --part onset_buckling``: the buckling length with the onset
    widened at the sum of the radii and with the default's, at 1 s and averaged over the
    frames from ONSET_AVERAGE_FROM_S, paired seed by seed."""
    bench = _bench_contact_newton()
    path = result("contact_onset_buckling.csv")
    shown = {
        "buckling_length_final_m": "buckling length at 1 s (mm)",
        "buckling_length_mean_m": (
            f"buckling length averaged from {_g(bench.ONSET_AVERAGE_FROM_S)} s to 1 s (mm)"
        ),
    }
    rows = [
        [
            shown[c["quantity"]],
            str(c["seeds"]),
            _g(c["mean_first_m"] * 1e3),
            _g(c["mean_second_m"] * 1e3),
            _paired_change(c),
        ]
        for c in bench.onset_buckling_comparison(_csv(path))
    ]
    head = ["frames every " + f"{_g(bench.ONSET_FRAME_INTERVAL_S)} s", "seeds"]
    head += ["0.2 δ from 2r", "0.2 δ from 1.02 (2r) (default)", "starting before contact (paired)"]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_newton() -> str:
    path = result("contact_newton.csv")
    rows = [
        [
            r["variant"],
            r["steps"],
            _g(r["newton_per_step"]),
            _g(r["krylov_per_newton"]),
            f"{100 * float(r['damped_share']):.0f}%",
            _g(r["wall_ratio"]),
        ]
        for r in _csv(path)
    ]
    head = ["pressed stack, 300 nodes, 20 ms", "steps", "Newton per step", "Krylov per Newton"]
    table = _table([*head, "updates damped", "wall / default"], rows)
    c = _csv(result("contact_closest_points.csv"))[0]
    points = (
        f"Closest points after 5 ms: {c['near_pairs']} near pairs ({c['both_inside']} with both "
        f"parameters inside their segments, {c['both_clamped']} with both at an end); "
        f"{c['touching']} touching ({c['touching_both_inside']} both inside, crossing at a median "
        f"{_g(c['median_angle_deg_touching'], 2)} deg; {c['touching_middle']} below 10 deg and "
        f"{c['touching_held']} below 20 deg, where contact acts at the middle of the overlap or "
        f"the blend); {c['class_changes_over_2_ms']} of "
        f"{c['pairs_compared']} change class over the next 2 ms."
    )
    return table + "\n\n" + points + "\n\n" + provenance(path, result("contact_closest_points.csv"))


def compile_times() -> str:
    path = result("compile.csv")
    label = {
        "wrappers": "every kernel with its CPython wrapper (`BATHPRINT_KERNEL_WRAPPERS=1`)",
        "callees": "kernels called only from kernels without one (default)",
    }
    rows = [
        [
            label.get(r["variant"], r["variant"]),
            r["cold_total_s"],
            f"{float(r['cold_vs_wrappers']):.2f}×",
            r["warm_total_s"],
            "yes" if r["same_result"] == "True" else "**no**",
        ]
        for r in _csv(path)
    ]
    head = ["kernels", "cold start (s)", "vs wrappers", "warm start (s)", "same result"]
    return _table(head, rows) + "\n\n" + provenance(path)


def preconditioners() -> str:
    path = result("preconditioners.csv")
    rows = [
        [
            f"`{r['state']}`",
            r["unknowns"],
            r["off_band_blocks"],
            f"`{r['preconditioner']}`",
            r["coarse_unknowns"],
            r["iterations_rtol_0.05"],
            r["iterations_rtol_1e-6"],
        ]
        for r in _csv(path)
    ]
    head = [
        "Newton matrix of",
        "unknowns",
        "blocks off the band",
        "preconditioner",
        "coarse unknowns",
        "GMRES iterations to 0.05",
        "to 1e-6",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def preconditioner_newton() -> str:
    path = result("preconditioner_newton.csv")
    table = _csv(path)
    names = list(dict.fromkeys(r["preconditioner"] for r in table))
    coarse = [n for n in names if n not in ("band", "hat_4_z_symmetric")]  # its LU: hat_4_z's
    by = {(r["nodes"], r["preconditioner"]): r for r in table}
    rows = []
    for n in dict.fromkeys(r["nodes"] for r in table):
        row = [n, _g(by[(n, "band")]["simulator_iterations_rtol_0.05"], 2)]
        for name in names:
            r = by[(n, name)]
            row.append(f"{_g(r['iterations_rtol_0.05'], 2)} / {_g(r['iterations_rtol_0.001'], 3)}")
        row += [f"{_g(by[(n, c)]['coarse_lu_over_band_lu'], 2)}×" for c in coarse]
        rows.append(row)
    head = ["nodes", "simulator's GMRES iterations"]
    head += [f"`{name}`: to 0.05 / 1e-3" for name in names]
    head += [f"`{c}`: coarse LU / banded LU" for c in coarse]
    return _table(head, rows) + "\n\n" + provenance(path)


def preconditioner_settled() -> str:
    """``preconditioner.py --part settled``: mean (largest) GMRES iterations per
    consecutive Newton solve, a column per variant; for those that keep earlier solves'
    vectors, also their passes over a vector per solve."""
    path = result("preconditioner_settled.csv")
    table = _csv(path)
    names = list(dict.fromkeys(r["variant"] for r in table))
    by = {(r["case"], r["nodes"], r["variant"]): r for r in table}
    rows = []
    for case, n in dict.fromkeys((r["case"], r["nodes"]) for r in table):
        band = by[(case, n, "band")]
        row = [case, n, f"{band['solves']} / {band['matrices']}"]
        for v in names:
            r = by[(case, n, v)]
            cell = f"{_g(r['iterations'], 2)} ({r['iterations_max']})"
            if int(r["kept"]) > 0:
                cell += f", {_g(r['vector_passes_per_solve'], 2)} passes"
            if int(r["unconverged_solves"]) > 0:
                cell += f", {r['unconverged_solves']} unconverged"
            row.append(cell)
        rows.append(row)
    head = ["state", "nodes", "solves / matrices"] + [f"`{v}`" for v in names]
    return _table(head, rows) + "\n\n" + provenance(path)


def preconditioner_amg() -> str:
    path = result("preconditioner_amg.csv")
    table = _csv(path)
    rows = []
    for n in dict.fromkeys(r["nodes"] for r in table):
        band = [r for r in table if r["nodes"] == n and r["preconditioner"] == "band"]
        solve_ms = sum(float(r["cycle_ms"]) for r in band) / len(band)
        lu_ms = sum(float(r["setup_ms"]) for r in band) / len(band)
        for name in dict.fromkeys(r["preconditioner"] for r in table):
            sel = [r for r in table if r["nodes"] == n and r["preconditioner"] == name]

            def mean(key: str, sel: list[dict[str, str]] = sel) -> float:
                return sum(float(r[key]) for r in sel) / len(sel)

            amg = name != "band"
            rows.append(
                [
                    n,
                    f"`{name}`",
                    f"{_g(mean('iterations_rtol_0.05'), 2)} / "
                    f"{_g(mean('iterations_rtol_0.001'), 3)}",
                    _g(mean("cycle_factor"), 2) if amg else "–",
                    f"{_g(mean('cycle_ms') / solve_ms, 2)}×" if amg else "1×",
                    f"{_g(mean('setup_ms') / lu_ms, 2)}×" if amg else "1×",
                ]
            )
    head = [
        "nodes",
        "preconditioner",
        "GMRES iterations to 0.05 / 1e-3",
        "V-cycle's convergence factor",
        "cycle / banded solve",
        "set-up / banded LU",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def profile_tqc_her() -> str:
    """The training-step profile of TQC with hindsight replay (agents.profile's table)."""
    path = AGENTS / "profile" / "CoilRadius-v1_tqc_her.json"
    if not path.is_file():
        raise RenderError(f"{_rel(path)} does not exist (run python -m bathprint.agents.profile)")
    rec = json.loads(path.read_text())
    rows = [
        [k, f"{v:.2f}", f"{100 * rec['share'][k]:.1f}%", f"{rec['us_per_step'][k]:.0f}"]
        for k, v in rec["seconds"].items()
    ]
    head = ["part", "s", "share", "µs per env step"]
    return _table(head, rows) + "\n\n" + provenance(path)


def hindsight_rewards() -> str:
    path = result("hindsight_rewards.csv")
    rows = [
        [
            f"`{r['env_id']}`",
            r["batch"],
            _g(r["python_ms"]),
            _g(r["compiled_ms"]),
            f"{_g(r['speedup'], 2)}×",
            "yes" if r["identical"] == "True" else "no",
        ]
        for r in _csv(path)
    ]
    head = ["environment", "batch", "sample by sample (ms)", "compiled (ms)", "speed-up"]
    head.append("identical")
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_whole_runs() -> str:
    path = result("contact_whole_runs.csv")
    rows = [
        [
            f"`{r['scene']}`",
            _g(r["duration_s"]),
            r["frames"],
            _g(r["wall_s"]),
            r["steps"],
            _g(r["min_gap_ratio"], 3),
            r["frames_below_0.9"],
            r["krylov_iterations"],
        ]
        for r in _csv(path)
    ]
    head = [
        "scene (as shipped)",
        "simulated (s)",
        "frames",
        "wall (s)",
        "steps",
        "smallest gap / (r_i + r_j)",
        "frames below 0.9",
        "Krylov iterations",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


def contact_scenes() -> str:
    path = result("contact_scenes.csv")
    rows = [
        [
            f"`{r['scene']}`",
            _g(r["duration_s"]),
            _g(r["wall_s_none"]),
            _g(r["wall_s_contact"]),
            f"{_g(r['ratio'], 3)}×",
            _g(r["krylov_per_newton"], 2),
            _g(r["min_gap_none"], 2),
            _g(r["min_gap_contact"], 3),
        ]
        for r in _csv(path)
    ]
    head = [
        "scene",
        "simulated (s)",
        "wall without (s)",
        "wall with (s)",
        "ratio",
        "Krylov per Newton",
        "smallest gap / 2r without",
        "with",
    ]
    return _table(head, rows) + "\n\n" + provenance(path)


ABLATION = EXPERIMENTS / "ablation" / "results"


def ablation() -> str:
    """The summary tables of the ablation study, as the study wrote them (ablation.md, up to
    its list of every run), with their headings as bold lines."""
    path = ABLATION / "ablation.md"
    if not path.is_file():
        raise RenderError(f"{_rel(path)} does not exist (run bathprint reproduce ablation)")
    text = path.read_text(encoding="utf-8")
    start = text.index("## Relative change")
    end = text.index("## Every run")
    lines = []
    for line in text[start:end].strip().splitlines():
        lines.append(f"**{line[3:].strip()}**" if line.startswith("## ") else line)
    return "\n".join(lines) + "\n\n" + provenance(ABLATION / "ablation.csv")


GRAVITY = EXPERIMENTS / "gravity" / "results"


def gravity() -> str:
    """The gravity study's fits (reproduce.json of ``bathprint reproduce gravity``)."""
    path = GRAVITY / "reproduce.json"
    if not path.is_file():
        raise RenderError(f"{_rel(path)} does not exist (run bathprint reproduce gravity)")
    fits = json.loads(path.read_text())["gravity"]["result"]["fits"]
    labels = {"buckled_length_m": "buckled length l", "coil_radius_m": "coil radius R"}
    rows = []
    for quantity, by_scale in fits.items():
        u, d = by_scale["universal_scale_m"], by_scale["drag_scale_m"]
        rows.append(
            [
                labels.get(quantity, quantity),
                f"{_g(u['slope'])}, {_g(u['log_rms'], 2)}",
                f"{_g(d['slope'])}, {_g(d['log_rms'], 2)}",
                str(u["points"]),
            ]
        )
    head = ["quantity", "universal scale: slope, log-RMS", "drag scale: slope, log-RMS", "runs"]
    return _table(head, rows) + "\n\n" + provenance(GRAVITY / "gravity.csv")


FAST_JETS = EXPERIMENTS / "fast_jets" / "results"


def fast_jets() -> str:
    """The fast-jets study's table (fast_jets.md of ``bathprint reproduce fast_jets``)."""
    path = FAST_JETS / "fast_jets.md"
    if not path.is_file():
        raise RenderError(f"{_rel(path)} does not exist (run bathprint reproduce fast_jets)")
    return path.read_text().strip() + "\n\n" + provenance(FAST_JETS / "fast_jets.csv")


def kernel_ab(name: str = "kernel_ab_uncounted") -> str:
    """A table of kernel_ab/ab.py's results/NAME.csv."""
    path = result(f"{name}.csv")
    rows = [
        [
            r["workload"],
            _g(r["old_s"]),
            _g(r["new_s"]),
            f"{_g(r['cpu_ratio'], 3)} ± {_g(r['cpu_spread'], 2)}",
            "yes" if r["identical"] == "True" else "no",
        ]
        for r in _csv(path)
    ]
    head = ["workload", "old (s)", "new (s)", "CPU time new / old", "bit-identical"]
    return _table(head, rows) + "\n\n" + provenance(path)


def _noise_kind(correlation: str | None) -> str:
    """'white', or the AR(1) coefficient of correlated noise."""
    rho = float(correlation or 0.0)
    return "white" if rho == 0.0 else f"AR(1), rho {rho:g}"


def bc_search(env: str = "WriteShape-v1") -> str:
    path = result(f"bc_search_{env}.csv")
    rows = [
        [
            r["targets"],
            r.get("replays") or "1",
            r["demonstration_pairs"],
            _g(r["action_noise"], 2),
            _noise_kind(r.get("noise_correlation")),
            f"{r['net_width']} x 2",
            r["epochs"],
            _g(r["mse_after"], 2),
            f"{_g(r['validation_mean_metric'])} [{_g(r['validation_ci_low'])}, "
            f"{_g(r['validation_ci_high'])}]",
            r.get("seed") or "0",
            f"{float(r['collect_wall_s']) + float(r['fit_wall_s']):.0f}",
        ]
        for r in _csv(path)
    ]
    head = ["training targets", "replays", "pairs", "action noise", "noise", "policy",
            "epochs", "action MSE", "validation metric (mean, 95% CI)", "seed",
            "collect + fit (s)"]  # fmt: skip
    out = _table(head, rows) + "\n\n" + provenance(path)
    diag_path = result(f"bc_search_{env}_diagnosis.csv")
    if diag_path.is_file():
        diag = _csv(diag_path)
        replays = ", ".join(
            f"{_g(r['noise_std'], 2)}: {_g(r['value'], 2)}" for r in diag if r["noise_std"]
        )
        out += (
            "\n\nWhere the error comes from "
            "(`python experiments/bc_search/bc_search.py --diagnose 5`,"
            " the 256 x 2 policy of 30 epochs, on the validation targets): teacher-forced on"
            " the printing actions' own states, its actions are within an RMS of "
            f"{_g(diag[0]['value'], 2)} of them; the printing actions replayed with white "
            f"noise of std (noise: mean metric) {replays}.\n\n" + provenance(diag_path)
        )
    return out


def bc_dagger(env: str = "WriteShape-v1") -> str:
    path = result(f"bc_search_{env}_dagger.csv")
    rows = []
    for r in _csv(path):
        if not r["pairs"]:  # the expert itself, played with noise
            rows.append([r["expert"], r["round"], "–", "–", _g(r["validation_mean_metric"]), "–"])
            continue
        rows.append([
            r["expert"], r["round"], r["pairs"], _g(r["mse_after"], 2),
            f"{_g(r['validation_mean_metric'])} [{_g(r['validation_ci_low'])}, "
            f"{_g(r['validation_ci_high'])}]",
            f"{float(r['round_wall_s']):.0f}",
        ])  # fmt: skip
    head = ["expert", "DAgger round", "pairs", "action MSE",
            "validation metric (mean, 95% CI)", "round (s)"]  # fmt: skip
    return _table(head, rows) + "\n\n" + provenance(path)


def bc_ensemble(env: str = "WriteShape-v1") -> str:
    path = result(f"bc_search_{env}_ensemble.csv")
    rows = [
        [
            r["policy"],
            f"{_g(r['validation_mean_metric'])} [{_g(r['validation_ci_low'])}, "
            f"{_g(r['validation_ci_high'])}]",
        ]
        for r in _csv(path)
    ]
    table = _table(["policy", "validation metric (mean, 95% CI)"], rows)
    first = _csv(path)[0]
    fit = (
        f"Search row {first['row']}'s demonstrations ({first['demonstration_pairs']} pairs), "
        f"seed {first['seed']}; fitting the actors took {float(first['fit_wall_s']):.0f} s."
    )
    return table + "\n\n" + fit + "\n\n" + provenance(path)


def bc_frame_stack(env: str = "WriteShape-v1") -> str:
    """The cloned policy on K stacked observations (bc_search.py --frame-stack): per
    K, each seed's validation metric and the mean over seeds."""
    path = result(f"bc_search_{env}_frame_stack.csv")
    by_k: dict[int, list[dict[str, str]]] = {}
    for r in _csv(path):
        by_k.setdefault(int(r["frames"]), []).append(r)
    rows = []
    for k in sorted(by_k):
        rs = sorted(by_k[k], key=lambda r: int(r["seed"]))
        per_seed = "; ".join(
            f"{r['seed']}: {_g(r['validation_mean_metric'])} [{_g(r['validation_ci_low'])}, "
            f"{_g(r['validation_ci_high'])}]"
            for r in rs
        )
        mean = sum(float(r["validation_mean_metric"]) for r in rs) / len(rs)
        rows.append([str(k), rs[0]["demonstration_pairs"], per_seed, _g(mean)])
    head = ["observations stacked", "pairs", "validation metric per seed (95% CI)",
            "mean over seeds"]  # fmt: skip
    return _table(head, rows) + "\n\n" + provenance(path)


def study_wall(name: str = "ablation_wall") -> str:
    path = result(f"{name}.csv")
    rows = [
        [
            r["study"],
            f"{r['runs']} ({r['failed']} fail)",
            f"{float(r['wall_s']) / 60:.1f}",
            f"{float(r['worker_s']) / 60:.1f}",
            _g(r["worker_over_wall"], 3),
            f"{float(r['longest_run_s']):.0f}",
            f"{r['same_as_reference']} of {r['reference_runs']}",
        ]
        for r in _csv(path)
    ]
    head = ["whole study on the 2-core machine", "runs", "wall (min)", "worker time (min)",
            "worker / wall", "longest run (s)", "same as committed"]  # fmt: skip
    return _table(head, rows) + "\n\n" + provenance(path)


SHAPE_POLICIES = ("constant", "feedforward", "controller", "cem", "mpc")
SHAPE_SETS = (("validation", "validation"), ("test", "test"), ("ood_test", "held-out kinds"))


def _shape_rows() -> tuple[Path, list[dict[str, str]]]:
    path = result("references.csv")
    return path, _csv(path)


def v1_against_controller() -> str:
    """experiments/v1_against_controller: each version-1 agent chosen on validation against
    the classical reference chosen on validation, on the test targets."""
    path = result("v1_against_controller.csv")
    rows = [
        [r["env"], r["agent"], f"{float(r['agent_mean_metric']):.3f}", r["reference"],
         f"{float(r['reference_mean_metric']):.3f}",
         f"{float(r['difference']):+.3f} [{float(r['difference_lo']):+.3f}, "
         f"{float(r['difference_hi']):+.3f}]",
         f"{r['targets_agent_better']}/{r['targets']}", f"{float(r['mpc_mean_metric']):.3f}",
         f"{float(r['controller_validation_metric']):.3f} / "
         f"{float(r['feedforward_calibrated_validation_metric']):.3f} / "
         f"{float(r['constant_validation_metric']):.3f}"]
        for r in _csv(path)
    ]  # fmt: skip
    head = ["environment", "agent (chosen on validation)", "agent M", "reference (chosen on "
            "validation)", "reference M", "agent − reference (95% CI)", "targets agent better",
            "MPC M", "validation M: controller / calibrated feedforward / constant"]  # fmt: skip
    return _table(head, rows) + "\n\n" + provenance(path)


#: what each family's held-out kinds are (``bathprint.envs.shapes``: ood_test)
HELD_OUT = {"floor": "digits", "free": "cones", "buoyant": "staircases"}
AGENT_GROUPS = {"ppo_bc_controller": "PPO cloned from the controller",
                "ppo_residual_controller": "PPO residual on the controller"}  # fmt: skip


def _shape_agent_files() -> list[tuple[str, str, Path]]:
    """(family, environment, summary file) of every family whose agents have results."""
    from bathprint.agents.controller import FAMILY_ENVS

    out = []
    for fam, env_id in FAMILY_ENVS.items():
        env = env_id.split("/")[1]
        hits = sorted(EXPERIMENTS.glob(f"*/results/{env}_summary.csv"))
        if hits:
            out.append((fam, env, hits[0]))
    return out


def shape_headline(env: str) -> tuple[str, float]:
    """(group, mean validation error in mm over its seeds) of the environment's agent group
    that validation selects: the lowest mean of the seeds' ``eval/best.json``."""
    best = ("", math.inf)
    for group in sorted(p for p in (AGENTS / env).iterdir() if p.is_dir()):
        vals = [json.loads(f.read_text())["mean_metric"]
                for f in sorted(group.glob("seed*/eval/best.json"))]  # fmt: skip
        if vals and sum(vals) / len(vals) < best[1]:
            best = (group.name, sum(vals) / len(vals))
    return best


def shape_agents() -> str:
    """experiments/shape_agents: each family's agent groups (validation-selected models) and
    the references on the test shapes and the held-out kinds, against the controller."""
    rows = []
    files = _shape_agent_files()
    for fam, env, path in files:
        head_group = shape_headline(env)[0]
        for r in _csv(path):
            diff = "–"
            if r["group"] != "controller":
                diff = (f"{float(r['minus_controller_mm']):+.2f} "
                        f"[{float(r['minus_controller_lo']):+.2f}, "
                        f"{float(r['minus_controller_hi']):+.2f}]")  # fmt: skip
            rows.append(
                [f"{env} ({fam})",
                 "test shapes" if r["set"] == "test" else f"held-out kinds ({HELD_OUT[fam]})",
                 AGENT_GROUPS.get(r["group"], r["group"])
                 + (" (headline: best on validation)" if r["group"] == head_group else ""),
                 r["runs"], r["shapes"],
                 f"{float(r['mean_rms_mm']):.2f}", f"{float(r['success_rate']):.2f}", diff]
            )  # fmt: skip
    head = ["environment", "set", "policy", "runs (seeds)", "shapes", "mean RMS error (mm)",
            "success rate", "− controller (mm, 95% CI)"]  # fmt: skip
    return _table(head, rows) + "\n\n" + provenance(*(f for _, _, f in files))


def shape_references() -> str:
    """experiments/shape_references: every reference on every named shape, per family and
    set: the mean whole-shape RMS error (mm) and the shapes written (success)."""
    from bathprint.agents.controller import FAMILY_ENVS

    path, rows = _shape_rows()
    by: dict[tuple[str, str, str], list[dict[str, str]]] = {}
    for r in rows:
        by.setdefault((r["family"], r["set"], r["policy"]), []).append(r)
    out = []
    for fam, env_id in FAMILY_ENVS.items():
        for st, label in SHAPE_SETS:
            cells = []
            means = {}
            for pol in SHAPE_POLICIES:
                rs = by.get((fam, st, pol), [])
                if not rs:
                    cells.append("–")
                    continue
                rms = [float(r["rms_mm"]) for r in rs]
                means[pol] = sum(rms) / len(rms)
                won = sum(r["success"] == "True" for r in rs)
                cells.append(f"{means[pol]:.2f} ({won}/{len(rs)})")
            norm = "–"
            if {"controller", "cem", "mpc"} <= set(means) and means["controller"] > means["cem"]:
                norm = _g(
                    (means["controller"] - means["mpc"]) / (means["controller"] - means["cem"]),
                    2,
                )
            cpu = [float(r["cpu_s"]) for r in by.get((fam, st, "cem"), [])]
            mpc_cpu = [float(r["cpu_s"]) for r in by.get((fam, st, "mpc"), [])]
            n = len(by.get((fam, st, "controller"), []))
            out.append(
                [f"{fam} ({env_id.split('/')[1]})", label, str(n), *cells, norm,
                 f"{sum(cpu) / max(len(cpu), 1):.1f} / {sum(mpc_cpu) / max(len(mpc_cpu), 1):.0f}"]
            )  # fmt: skip
    head = ["family (environment)", "set", "shapes", *SHAPE_POLICIES,
            "mpc normalised", "CPU s per shape: cem / mpc"]  # fmt: skip
    return _table(head, out) + "\n\n" + provenance(path)


def shape_attainable() -> str:
    """The named shapes marked not writable, and what the best reference writes of them."""
    from bathprint.envs.shapes import index

    path, rows = _shape_rows()
    meta = {(r["family"], r["set"], r["name"]): r for r in index()}
    best: dict[tuple[str, str, str], dict[str, str]] = {}
    for r in rows:
        key = (r["family"], r["set"], r["shape"])
        if meta[key]["writable"] or r["policy"] not in ("controller", "cem", "mpc"):
            continue
        if key not in best or float(r["rms_mm"]) < float(best[key]["rms_mm"]):
            best[key] = r
    out = [
        [fam, name, "; ".join(meta[(fam, st, name)]["issues"]), r["policy"],
         _g(float(r["rms_mm"]), 2), _g(float(r["max_mm"]), 2),
         "yes" if r["success"] == "True" else "no"]
        for (fam, st, name), r in sorted(best.items())
    ]  # fmt: skip
    head = ["family", "shape", "why marked not writable", "best reference", "RMS (mm)",
            "max (mm)", "written (family's threshold)"]  # fmt: skip
    return _table(head, out) + "\n\n" + provenance(path)


TABLES: dict[str, Callable[[], str]] = {
    "scene-keys": scene_keys,
    "builtin-scenes": builtin_scenes,
    "validation": validation,
    "default-scene": default_scene,
    "scaling": scaling,
    "effects": effects,
    "pyelastica": pyelastica,
    "profile": profile,
    "hard-cases": hard_cases,
    "freezing-coil": freezing_coil,
    "freezing-turns": freezing_turns,
    "freezing-onset": freezing_onset,
    "freezing-onset-wide": lambda: freezing_onset("freezing_onset_wide"),
    "freezing-damping": freezing_damping,
    "contact-dashpot-overdamped": contact_dashpot_overdamped,
    "hydro-all-effects": hydro_all_effects,
    "hydro-mobility": hydro_mobility,
    "hydro-failing-solve": hydro_failing_solve,
    "hydro-kernel-drag": hydro_kernel_drag,
    "hydro-kernel-mobility": hydro_kernel_mobility,
    "hydro-kernel-cost": hydro_kernel_cost,
    "hydro-kernel-coils": hydro_kernel_coils,
    "contact-onset-buckling": contact_onset_buckling,
    "freezing-rope": freezing_rope,
    "freezing-envs": freezing_envs,
    "accuracy-presets": accuracy_presets,
    "envs-speed": envs_speed,
    "agents": agents,
    "headline": headline,
    "shape-references": shape_references,
    "shape-agents": shape_agents,
    "v1-against-controller": v1_against_controller,
    "shape-attainable": shape_attainable,
    "reproduce-times": reproduce_times,
    "stability-onsets": stability_onsets,
    "coils": coils,
    "paper-constants": paper_constants,
    "fig1c-regimes": fig1c_regimes,
    "fig3-settling": fig3_settling,
    "contact-scaling": contact_scaling,
    "contact-onset-split": contact_onset_split,
    "contact-scaling-default": lambda: contact_scaling("contact_scaling_default"),
    "contact-scenes": contact_scenes,
    "contact-whole-runs": contact_whole_runs,
    "profile-tqc-her": profile_tqc_her,
    "hindsight-rewards": hindsight_rewards,
    "preconditioners": preconditioners,
    "contact-newton": contact_newton,
    "contact-line-search": contact_line_search,
    "contact-line-search-scene": contact_line_search_scene,
    "contact-near-gap": contact_near_gap,
    "contact-seeds": contact_seeds,
    "contact-ratio-seeds": contact_ratio_seeds,
    "contact-ratio-seeds-sharp": contact_ratio_seeds_sharp,
    "contact-onset-observables": contact_onset_observables,
    "contact-ratio-seeds-inertia": contact_ratio_seeds_inertia,
    "contact-late": contact_late,
    "backsub": backsub,
    "lu-diagonal": lu_diagonal,
    "sampled-profile": sampled_profile,
    "sampled-profile-stacks": lambda: sampled_profile("sampled_profile_stacks"),
    "contact-scaling-settled": contact_scaling_settled,
    "contact-scaling-settled-default": lambda: contact_scaling_settled(
        "contact_scaling_settled_default"
    ),
    "contact-saturation": contact_saturation,
    "contact-hessian": contact_hessian,
    "contact-onset": contact_onset,
    "preconditioner-newton": preconditioner_newton,
    "preconditioner-settled": preconditioner_settled,
    "hydro-coiling": hydro_coiling,
    "preconditioner-amg": preconditioner_amg,
    "contact-krylov": contact_krylov,
    "bc-search": bc_search,
    "bc-dagger": bc_dagger,
    "bc-ensemble": bc_ensemble,
    "bc-search-v2": lambda: bc_search("WriteShape-v2"),
    "bc-frame-stack": bc_frame_stack,
    "study-wall": study_wall,
    "ablation": ablation,
    "gravity": gravity,
    "fast_jets": fast_jets,
    "kernel-ab": kernel_ab,
    "banded-ab": lambda: kernel_ab("banded_ab"),
    "compile": compile_times,
    **{f"campaign-{e}": (lambda e=e: campaign(e)) for e in CAMPAIGN_ENVS},
}


# figures the docs show, copied from the result files that hold them (the docs site serves
# only docs/): docs/img/NAME <- SOURCE
FIGURES: dict[str, Path] = {
    **{f"curves_{e}.png": AGENTS / e / "curves.png" for e in CAMPAIGN_ENVS},
    "BuoyantLayers-v1_residual_vs_oracle.gif": AGENTS
    / "BuoyantLayers-v1"
    / "gif"
    / "test0_residual_vs_oracle.gif",
    "ablation.png": ABLATION / "ablation.png",
    "fig2.png": REPRODUCE / "fig2.png",
    "profile.png": result("profile.png"),
    "freezing_turns.png": result("freezing_turns.png"),
}


def stale_figures() -> list[str]:
    """The docs/img copies that differ from their result files."""
    img = ROOT / "docs" / "img"
    return [
        name
        for name, src in FIGURES.items()
        if not (img / name).exists() or (img / name).read_bytes() != src.read_bytes()
    ]


def render_table(name: str) -> str:
    if name not in TABLES:
        raise RenderError(f"unknown table {name!r}; tables: {', '.join(TABLES)}")
    return TABLES[name]()


def render_markdown(text: str, keep_markers: bool = False) -> str:
    """Replace every ``<!-- render: NAME -->`` (and its old block, if any) by the table;
    with ``keep_markers`` the markers stay around it (for files edited in place)."""

    def sub(m: re.Match) -> str:
        body = render_table(m.group(1))
        if keep_markers:
            return f"<!-- render: {m.group(1)} -->\n{body}\n<!-- end render -->"
        return body

    return DIRECTIVE.sub(sub, text)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("what", nargs="*", help="table names, or files with --write/--check")
    mode = ap.add_mutually_exclusive_group()
    mode.add_argument("--write", action="store_true", help="re-render the files' blocks")
    mode.add_argument("--check", action="store_true", help="exit 1 if a file is out of date")
    args = ap.parse_args(argv)
    try:
        if not (args.write or args.check):
            for name in args.what or list(TABLES):
                print(f"## {name}\n\n{render_table(name)}\n")
            return 0
        stale = []
        failed = False
        for name in stale_figures():  # docs/img copies of result figures
            if args.write:
                shutil.copyfile(FIGURES[name], ROOT / "docs" / "img" / name)
                print(f"copied docs/img/{name}")
            else:
                print(
                    f"out of date: docs/img/{name} (a copy of {_rel(FIGURES[name])})",
                    file=sys.stderr,
                )
                failed = True
        for f in args.what:
            path = Path(f)
            old = path.read_text(encoding="utf-8")
            new = render_markdown(old, keep_markers=True)
            if new != old:
                if args.write:
                    path.write_text(new, encoding="utf-8")
                    print(f"rendered {f}")
                else:
                    stale.append(f)
        if stale:
            print(
                f"out of date: {', '.join(stale)}; run python docs/_gen/render.py --write "
                + " ".join(stale),
                file=sys.stderr,
            )
            return 1
        if failed:
            print("run python docs/_gen/render.py --write", file=sys.stderr)
            return 1
    except RenderError as exc:
        print(f"render.py: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

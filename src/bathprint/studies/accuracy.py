"""What accuracy costs in time: a work-precision study (``bathprint bench accuracy``).

Error against wall time, one curve per integrator and per way of refining (``tolerance``:
``numerics.tolerance``; ``time_step``: ``numerics.time_step_s``; ``node_spacing``:
``numerics.node_spacing_mm``), on reference problems with known answers:

- ``cantilever``: steady tip deflection against beam theory q L^4 / (8 E I);
- ``onset``: onset beta of the extruded rod's buckling against the linear stability's
  beta_c (:func:`bathprint.analysis.theory.beta_critical`);
- ``coil_radius`` / ``coil_frequency``: a steady coil (scene ``gelation_coiling_22G``)
  against a converged reference run (the ``fine`` preset; the ``balanced`` one in
  ``--quick``).

The accuracy presets (``numerics.accuracy``) are run on each problem and shown as labelled
points. Writes ``accuracy.csv``, ``presets.csv`` and ``accuracy.png`` to ``--out`` and
prints the preset table.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import signal
import sys
import time
import warnings
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.analysis.measure import coil_frequency, coil_geometry
from bathprint.analysis.stability import explicit_step_limit
from bathprint.analysis.theory import beta_critical
from bathprint.analysis.validation import CANTILEVER, extruded_rod_growth_rate_for
from bathprint.core.scene import ACCURACY_PRESETS
from bathprint.core.simulation import Simulation
from bathprint.errors import OptionError, SimulationError
from bathprint.interrupt import atomic, exit_code, signals_interrupt

PROBLEMS = ("cantilever", "onset", "coil_radius", "coil_frequency")
CANTILEVER_T_END = 0.1  # s: about 30 relaxation times of the slowest bending mode
ONSET_BRACKET = (3.4, 3.55)  # beta_c = 3.4766 lies inside; linear interpolation between
COIL_SCENE = "gelation_coiling_22G"
REPEAT_BELOW_S = 20.0  # runs shorter than this are timed twice (best of 2)


@dataclass
class Row:
    """One measured point of a work-precision curve."""

    problem: str
    integrator: str
    refine: str  # "tolerance" | "time_step" | "node_spacing" | "preset"
    knob: str  # the scene parameter varied (or the preset name)
    value: float  # its value (for presets: the effective node spacing, mm)
    wall_s: float
    error: float  # relative (nan: the run failed)

    def __post_init__(self) -> None:
        if self.error is None:
            self.error = math.nan


# --------------------------------------------------------------------------- timing


def timed(fn: Callable[[], Any], repeats: int = 2) -> tuple[float, Any]:
    """(best wall time of up to ``repeats`` calls, last result; None if the run failed); a
    call longer than ``REPEAT_BELOW_S`` is not repeated."""
    best, result = math.inf, None
    for _ in range(repeats):
        t0 = time.perf_counter()
        try:
            result = fn()
        except SimulationError:  # a failed run (e.g. Newton at a too large fixed step)
            result = None
        wall = time.perf_counter() - t0
        best = min(best, wall)
        if wall > REPEAT_BELOW_S:
            break
    return best, result


class Points:
    """Measured points, kept in ``points.jsonl`` of the output directory as they finish
    (each line flushed and fsync'd), so that an interrupted study resumes where it stopped
    (``--fresh`` starts over); a line cut by a crash is dropped and measured again. Shows a
    progress bar over the plan's points."""

    def __init__(self, path: Path | None, total: int, fresh: bool = False) -> None:
        from tqdm import tqdm

        self.path = path
        self.done: dict[str, tuple[float, Any]] = {}
        if path is not None and path.exists() and not fresh:
            self._load(path)
        elif path is not None and fresh and path.exists():
            path.unlink()
        self.bar = tqdm(total=total, unit="point", desc="work-precision", disable=path is None)
        self.bar.update(min(len(self.done), total))

    def _load(self, path: Path) -> None:
        data = path.read_bytes()
        lines = data.split(b"\n")
        tail = lines.pop()  # b"" when the file ends with a newline
        if tail.strip():  # a line cut by a crash: drop it (that point is measured again)
            with path.open("r+b") as f:
                f.truncate(len(data) - len(tail))
        bad = 0
        for line in lines:
            if not line.strip():
                continue
            try:
                rec = json.loads(line)
                res = rec["result"]
                self.done[rec["key"]] = (
                    float(rec["wall_s"]),
                    tuple(res) if isinstance(res, list) else res,
                )
            except (ValueError, KeyError, TypeError):
                bad += 1
        if bad:
            warnings.warn(f"{path}: ignored {bad} malformed line(s)", RuntimeWarning, stacklevel=3)

    def measure(self, key: str, fn: Callable[[], Any], repeats: int = 2) -> tuple[float, Any]:
        """(wall s, result) of ``fn``: stored if this key was measured before, else timed."""
        if key in self.done:
            return self.done[key]
        wall, result = timed(fn, repeats)
        with atomic():  # a SIGINT/SIGTERM now is raised once the line is on disk
            self.done[key] = (wall, result)
            if self.path is not None:
                with self.path.open("a") as f:
                    f.write(json.dumps({"key": key, "wall_s": wall, "result": result}) + "\n")
                    f.flush()
                    os.fsync(f.fileno())
        self.bar.set_postfix_str(key, refresh=False)
        self.bar.update(1)
        return wall, result

    def close(self) -> None:
        self.bar.close()


_POINTS = Points(None, 0)  # replaced by main(); the run_* functions measure through it


def measure(key: str, fn: Callable[[], Any], repeats: int = 2) -> tuple[float, Any]:
    return _POINTS.measure(key, fn, repeats)


# --------------------------------------------------------------------------- problems


def cantilever_error(
    n_segments: int = 50,
    integrator: str = "implicit",
    extra: dict[str, Any] | None = None,
    t_end: float = CANTILEVER_T_END,
) -> float:
    """|simulated / exact - 1| of the steady tip deflection of the validation cantilever.

    ``extra``: further overrides (tolerance, fixed step, accuracy preset). For the explicit
    integrator the fixed step is set to 0.5 x its stability limit unless given.
    """
    length_mm = CANTILEVER["initial.length_mm"]
    overrides: dict[str, Any] = {
        **CANTILEVER,
        "numerics.node_spacing_mm": length_mm / n_segments,
        "numerics.integrator": integrator,
        "duration_s": t_end,
        **(extra or {}),
    }
    sim = Simulation("paper_simulation", overrides)
    if integrator == "explicit" and "numerics.time_step_s" not in overrides:
        overrides["numerics.time_step_s"] = 0.5 * explicit_step_limit(sim)
        sim = Simulation("paper_simulation", overrides)
    sim.advance(t_end)
    c = sim.centerline()
    deflection = c[-1, 2] - c[0, 2]
    m = sim.model
    drho = CANTILEVER["material.density_kg_m3"] - CANTILEVER["bath.density_kg_m3"]
    q = drho * 9.81 * math.pi * m.radius**2
    exact = q * (length_mm * 1e-3) ** 4 / (8.0 * m.bending_stiffness)
    return abs(float(deflection) / exact - 1.0)


def extruded_rod_growth_rate(
    beta: float, n_segments: int = 20, extra: dict[str, Any] | None = None
) -> float:
    """Growth rate, in units of B / (mu_s L^4), of a perturbation of the extruded rod at
    beta (:func:`bathprint.analysis.validation.extruded_rod_growth_rate_for`). ``extra``: numerics
    overrides; ``extra["time_step_scale"]``: a fixed step of that many units of
    mu_s L^4 / B."""
    extra = dict(extra or {})
    step_scale = extra.pop("time_step_scale", None)
    rate, scale, _ = extruded_rod_growth_rate_for(
        beta, n_segments=n_segments, extra=extra, time_step_scale=step_scale
    )
    return rate / scale


def onset_error(n_segments: int = 20, extra: dict[str, Any] | None = None) -> float:
    """|onset / beta_c - 1|: the onset is the zero of the growth rate, interpolated
    linearly between the two ends of ``ONSET_BRACKET``."""
    lo, hi = ONSET_BRACKET
    s_lo = extruded_rod_growth_rate(lo, n_segments, extra)
    s_hi = extruded_rod_growth_rate(hi, n_segments, extra)
    onset = lo + (hi - lo) * (-s_lo) / (s_hi - s_lo)
    return abs(onset / beta_critical() - 1.0)


def coil_run(
    extra: dict[str, Any] | None = None, duration: float = 3.0, window: float = 0.5
) -> tuple[float, float]:
    """(coil radius m, frequency rad/s) of ``COIL_SCENE`` at ``duration``: radius from the
    final frame, frequency from frames every 0.02 s over the last ``window`` seconds."""
    sim = Simulation(COIL_SCENE, {"duration_s": duration, **(extra or {})})
    pos, axis = sim.model.needle[0, 1:4].copy(), sim.model.needle[0, 4:7].copy()
    frames, times = [], []
    for t in np.linspace(duration - window, duration, int(round(window / 0.02)) + 1):
        sim.advance(float(t))
        frames.append(sim.centerline().copy())
        times.append(float(t))
    geom = coil_geometry(frames[-1], pos, axis)
    omega = coil_frequency(frames, times, pos, axis)
    radius = geom.radius if geom is not None and geom.radius is not None else math.nan
    return float(radius), float(omega) if omega is not None else math.nan


# --------------------------------------------------------------------------- study


@dataclass
class Plan:
    """What to run (``--quick`` trims every list)."""

    cant_tol: tuple[float, ...]
    cant_dt: tuple[float, ...]
    cant_n: tuple[int, ...]
    cant_explicit_n: tuple[int, ...]
    onset_tol: tuple[float, ...]
    onset_dt: tuple[float, ...]
    onset_n: tuple[int, ...]
    coil_tol: tuple[float, ...]
    coil_sdirk4_tol: tuple[float, ...]  # the coil with numerics.integrator = "sdirk4"
    coil_spacing: tuple[float, ...]
    coil_duration: float
    coil_reference: str  # preset used as the coil's reference


FULL = Plan(
    cant_tol=(1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7),
    cant_dt=(3e-3, 1e-3, 3e-4, 1e-4),
    cant_n=(5, 10, 20, 50, 100),
    cant_explicit_n=(3, 4),
    onset_tol=(1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7),
    onset_dt=(0.3, 0.1, 0.03, 0.01),
    onset_n=(5, 10, 20, 40, 80),
    coil_tol=(1e-2, 3e-3, 1e-3, 3e-4),
    coil_sdirk4_tol=(1e-2, 1e-3, 1e-4),
    coil_spacing=(0.6, 0.45, 0.3, 0.2),
    coil_duration=3.0,
    coil_reference="fine",
)
QUICK = Plan(
    cant_tol=(1e-2, 1e-4, 1e-6),
    cant_dt=(1e-3, 1e-4),
    cant_n=(5, 20, 50),
    cant_explicit_n=(),
    onset_tol=(1e-3, 1e-6),
    onset_dt=(0.1,),
    onset_n=(10, 20),
    coil_tol=(1e-2,),
    coil_sdirk4_tol=(1e-2,),
    coil_spacing=(0.6,),
    coil_duration=1.5,
    coil_reference="balanced",
)
INTEGRATORS = ("implicit", "sdirk4", "implicit_euler")


def plan_size(plan: Plan) -> int:
    """Number of measured points of a plan (for the progress bar)."""
    n_presets = len(ACCURACY_PRESETS)
    cant = len(INTEGRATORS) * (len(plan.cant_tol) + len(plan.cant_dt) + len(plan.cant_n))
    onset = len(INTEGRATORS) * (len(plan.onset_tol) + len(plan.onset_dt) + len(plan.onset_n))
    coil_presets = list(ACCURACY_PRESETS).index(plan.coil_reference) + 1
    coil = len(plan.coil_tol) + len(plan.coil_sdirk4_tol) + len(plan.coil_spacing) + coil_presets
    return cant + len(plan.cant_explicit_n) + n_presets + onset + n_presets + coil


def _log(msg: str) -> None:
    print(msg, flush=True)


def warm_up() -> None:
    """Load (or compile) the numba kernels of every integrator and scene used."""
    for integrator in (*INTEGRATORS, "explicit"):
        cantilever_error(4, integrator, t_end=1e-3)
    extruded_rod_growth_rate(3.5, 5)
    coil_run({"numerics.accuracy": "draft"}, duration=0.3, window=0.1)


def run_cantilever(plan: Plan) -> tuple[list[Row], dict[str, Row]]:
    """Curves and preset points of the cantilever."""
    rows: list[Row] = []
    p = "cantilever"
    for integ in INTEGRATORS:
        for tol in plan.cant_tol:
            w, e = measure(
                f"{p}|{integ}|tol|{tol!r}",
                lambda i=integ, t=tol: cantilever_error(50, i, {"numerics.tolerance": t}),
            )
            rows.append(Row(p, integ, "tolerance", "numerics.tolerance", tol, w, e))
        for dt in plan.cant_dt:
            w, e = measure(
                f"{p}|{integ}|dt|{dt!r}",
                lambda i=integ, d=dt: cantilever_error(50, i, {"numerics.time_step_s": d}),
            )
            rows.append(Row(p, integ, "time_step", "numerics.time_step_s", dt, w, e))
        for n in plan.cant_n:
            w, e = measure(
                f"{p}|{integ}|n|{n}",
                lambda i=integ, k=n: cantilever_error(k, i, {"numerics.tolerance": 1e-3}),
            )
            rows.append(Row(p, integ, "node_spacing", "numerics.node_spacing_mm", 10 / n, w, e))
    for n in plan.cant_explicit_n:
        w, e = measure(f"{p}|explicit|n|{n}", lambda k=n: cantilever_error(k, "explicit"))
        rows.append(Row(p, "explicit", "node_spacing", "numerics.node_spacing_mm", 10 / n, w, e))
    presets: dict[str, Row] = {}
    for name, (_, _, factor) in ACCURACY_PRESETS.items():
        w, e = measure(
            f"{p}|preset|{name}",
            lambda s=name: cantilever_error(50, "implicit", {"numerics.accuracy": s}),
        )
        presets[name] = Row(p, "implicit", "preset", name, 0.2 * factor, w, e)
    return rows, presets


def run_onset(plan: Plan) -> tuple[list[Row], dict[str, Row]]:
    """Curves and preset points of the extruded rod's onset."""
    rows: list[Row] = []
    p = "onset"
    for integ in INTEGRATORS:
        base = {"numerics.integrator": integ}
        for tol in plan.onset_tol:
            w, e = measure(
                f"{p}|{integ}|tol|{tol!r}",
                lambda b=base, t=tol: onset_error(20, {**b, "numerics.tolerance": t}),
            )
            rows.append(Row(p, integ, "tolerance", "numerics.tolerance", tol, w, e))
        for c in plan.onset_dt:
            w, e = measure(
                f"{p}|{integ}|dt|{c!r}",
                lambda b=base, s=c: onset_error(20, {**b, "time_step_scale": s}),
            )
            rows.append(Row(p, integ, "time_step", "time_step_s * B/(mu_s L^4)", c, w, e))
        for n in plan.onset_n:
            w, e = measure(f"{p}|{integ}|n|{n}", lambda b=base, k=n: onset_error(k, b))
            rows.append(Row(p, integ, "node_spacing", "numerics.node_spacing_mm", 10 / n, w, e))
    presets: dict[str, Row] = {}
    for name, (_, _, factor) in ACCURACY_PRESETS.items():
        w, e = measure(
            f"{p}|preset|{name}", lambda s=name: onset_error(20, {"numerics.accuracy": s})
        )
        presets[name] = Row(p, "implicit", "preset", name, 0.5 * factor, w, e)
    return rows, presets


def run_coil(plan: Plan) -> tuple[list[Row], dict[str, Row]]:
    """Curves and preset points of the coil (radius and frequency against the reference)."""
    dur = plan.coil_duration
    ref_name = plan.coil_reference
    _log(f"  coil reference: preset {ref_name!r}, {dur:g} s ...")
    w_ref, (r_ref, om_ref) = measure(
        f"coil|{dur!r}|preset|{ref_name}",
        lambda: coil_run({"numerics.accuracy": ref_name}, dur),
        repeats=1,
    )
    _log(f"  reference R = {r_ref * 1e3:.4f} mm, omega = {om_ref:.4f} rad/s ({w_ref:.1f} s)")

    def rows_for(
        refine: str, knob: str, value: float, wall: float, res: tuple, integ: str = "implicit"
    ) -> list[Row]:
        r, om = res if res is not None else (math.nan, math.nan)
        return [
            Row("coil_radius", integ, refine, knob, value, wall, abs(r / r_ref - 1.0)),
            Row("coil_frequency", integ, refine, knob, value, wall, abs(om / om_ref - 1.0)),
        ]

    rows: list[Row] = []
    for tol in plan.coil_tol:
        w, res = measure(
            f"coil|{dur!r}|tol|{tol!r}", lambda t=tol: coil_run({"numerics.tolerance": t}, dur)
        )
        rows += rows_for("tolerance", "numerics.tolerance", tol, w, res)
        _log(f"  coil tolerance {tol:g}: {w:.1f} s")
    for tol in plan.coil_sdirk4_tol:
        w, res = measure(
            f"coil|{dur!r}|sdirk4|tol|{tol!r}",
            lambda t=tol: coil_run({"numerics.tolerance": t, "numerics.integrator": "sdirk4"}, dur),
        )
        rows += rows_for("tolerance", "numerics.tolerance", tol, w, res, "sdirk4")
        _log(f"  coil sdirk4 tolerance {tol:g}: {w:.1f} s")
    for dx in plan.coil_spacing:
        w, res = measure(
            f"coil|{dur!r}|dx|{dx!r}",
            lambda d=dx: coil_run({"numerics.node_spacing_mm": d}, dur),
        )
        rows += rows_for("node_spacing", "numerics.node_spacing_mm", dx, w, res)
        _log(f"  coil spacing {dx:g} mm: {w:.1f} s")
    presets: dict[str, Row] = {}
    for name, (_, _, factor) in ACCURACY_PRESETS.items():
        if list(ACCURACY_PRESETS).index(name) > list(ACCURACY_PRESETS).index(ref_name):
            continue  # finer than the reference (--quick): not measurable against it
        if name == ref_name:
            w, res = w_ref, (r_ref, om_ref)  # the reference itself: error 0 by construction
        else:
            w, res = measure(
                f"coil|{dur!r}|preset|{name}",
                lambda s=name: coil_run({"numerics.accuracy": s}, dur),
            )
        r_row, om_row = rows_for("preset", name, 0.3 * factor, w, res)
        presets[name] = r_row
        presets[name + "/frequency"] = om_row
        _log(f"  coil preset {name}: {w:.1f} s")
    return rows, presets


def is_monotone(rows: Sequence[Row], rel_slack: float = 1e-6) -> bool:
    """True if, along ``rows`` ordered from coarse to fine, the error never grows (beyond
    ``rel_slack`` relative, for rounding)."""
    errs = [r.error for r in rows]
    return all(b <= a * (1.0 + rel_slack) + 1e-15 for a, b in zip(errs, errs[1:], strict=False))


def curve(rows: Sequence[Row], problem: str, integrator: str, refine: str) -> list[Row]:
    """The rows of one curve, ordered from coarse to fine (decreasing knob value)."""
    sel = [r for r in rows if (r.problem, r.integrator, r.refine) == (problem, integrator, refine)]
    return sorted(sel, key=lambda r: -r.value)


# --------------------------------------------------------------------------- output


def write_csv(path: Path, rows: Sequence[Row]) -> None:
    """Rows to CSV with the fields of :class:`Row`."""
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(asdict(rows[0])))
        w.writeheader()
        for r in rows:
            w.writerow({**asdict(r), "wall_s": f"{r.wall_s:.5g}", "error": f"{r.error:.4e}"})


def plot(path: Path, rows: Sequence[Row], presets: Sequence[Row]) -> None:
    """One log-log panel per problem: a curve per (integrator, refine), presets labelled."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(PROBLEMS), figsize=(5.2 * len(PROBLEMS), 4.6))
    styles = {"tolerance": "o-", "time_step": "s--", "node_spacing": "^-."}
    colors = {"implicit": "C0", "sdirk4": "C3", "implicit_euler": "C1", "explicit": "C2"}
    floor = 1e-16  # errors of exactly 0 (a reference against itself) are not drawn
    for ax, problem in zip(axes, PROBLEMS, strict=True):
        for integ in colors:
            for refine, style in styles.items():
                c = [r for r in curve(rows, problem, integ, refine) if r.error > floor]
                if c:
                    ax.loglog(
                        [r.wall_s for r in c],
                        [r.error for r in c],
                        style,
                        color=colors[integ],
                        label=f"{integ} / {refine}",
                        ms=4,
                    )
        for r in presets:
            if r.problem == problem and r.error > floor:
                ax.loglog(r.wall_s, r.error, "*", color="k", ms=13, zorder=5)
                ax.annotate(
                    r.knob,
                    (r.wall_s, r.error),
                    textcoords="offset points",
                    xytext=(6, 4),
                    fontsize=9,
                    fontweight="bold",
                )
        ax.set_title(problem)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("relative error")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def preset_table(presets: Sequence[Row]) -> str:
    """Markdown table preset -> error and wall time per problem."""
    head = "| preset | " + " | ".join(f"{p} error | {p} wall s" for p in PROBLEMS) + " |"
    sep = "|---" * (1 + 2 * len(PROBLEMS)) + "|"
    lines = [head, sep]
    for name in ACCURACY_PRESETS:
        cells = []
        for p in PROBLEMS:
            r = next((r for r in presets if r.problem == p and r.knob == name), None)
            cells += ["-", "-"] if r is None else [f"{r.error:.2e}", f"{r.wall_s:.3g}"]
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of ``bathprint bench accuracy``."""
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--quick", action="store_true", help="fewer points, shorter coil run")
    ap.add_argument(
        "--fresh", action="store_true", help="discard points measured by an earlier run in --out"
    )


def run_args(args: argparse.Namespace) -> int:
    """Run the study from parsed options. Exit codes: 0 done, 2 bad options (checked first),
    130 / 143 interrupted by SIGINT / SIGTERM (the points measured so far are kept; the
    same command resumes)."""
    from bathprint.paths import check_output_dir

    try:
        out = check_output_dir(args.out, "--out")
    except OptionError as exc:
        print(f"bathprint bench accuracy: {exc}", file=sys.stderr)
        return 2
    plan = QUICK if args.quick else FULL
    name = "points_quick.jsonl" if args.quick else "points.jsonl"
    with signals_interrupt():
        try:
            return _run(out, plan, name, args.fresh)
        except KeyboardInterrupt as exc:  # Ctrl-C or SIGTERM
            kept = len(_POINTS.done)
            _POINTS.close()
            print(
                f"bathprint bench accuracy: interrupted "
                f"({signal.Signals(exit_code(exc) - 128).name}); {kept} points kept in "
                f"{out / name}; run the same command again to resume",
                file=sys.stderr,
            )
            return exit_code(exc)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the study; ``--out DIR`` (required), ``--quick`` (about a minute); see
    :func:`run_args` for the exit codes."""
    ap = argparse.ArgumentParser(
        prog="bathprint bench accuracy",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_arguments(ap)
    return run_args(ap.parse_args(argv))


def _run(out: Path, plan: Plan, name: str, fresh: bool) -> int:
    global _POINTS
    out.mkdir(parents=True, exist_ok=True)
    _POINTS = Points(out / name, plan_size(plan), fresh=fresh)
    if _POINTS.done:
        _log(f"resuming: {len(_POINTS.done)} points already measured in {out / name}")
    t0 = time.perf_counter()
    _log("warming up (numba kernels) ...")
    warm_up()
    rows: list[Row] = []
    presets: list[Row] = []
    for label, fn in (("cantilever", run_cantilever), ("onset", run_onset), ("coil", run_coil)):
        t1 = time.perf_counter()
        _log(f"{label} ...")
        r, p = fn(plan)
        rows += r
        presets += list(p.values())
        _log(f"{label}: {time.perf_counter() - t1:.1f} s")
    _POINTS.close()
    write_csv(out / "accuracy.csv", rows + presets)
    write_csv(out / "presets.csv", presets)
    plot(out / "accuracy.png", rows, presets)
    print()
    print(preset_table(presets))
    print(f"\ncoil reference: preset {plan.coil_reference!r} (its own error is 0 by construction)")
    print(f"total {time.perf_counter() - t0:.1f} s; results in {out}")
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

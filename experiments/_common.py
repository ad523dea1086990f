"""Helpers shared by the experiments' scripts: timing, result files and their provenance."""

from __future__ import annotations

import csv
import importlib.util
import json
import os
import platform
import shlex
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

from bathprint.provenance import code_version

EXPERIMENTS = Path(__file__).resolve().parent
ROOT = EXPERIMENTS.parent
#: experiments/<question>/results of the script being run: an experiment writes its result
#: files beside its script (a script imported by another writes into the runner's folder)
RESULTS = Path(sys.argv[0]).resolve().parent / "results"

#: contact's law before the soft onset before contact became its default (CHANGELOG.md): the
#: penalty's soft onset of 0.02 contact distances from the sum of the two radii, and no
#: dashpot. The studies measured with it (of the solver, the preconditioners, the profiles,
#: freezing, the hard cases) list it, so that their commands still compute their results.
SHARP_CONTACT: dict[str, float] = {
    "contact.width_fraction": 0.02,
    "contact.distance_factor": 1.0,
    "contact.damping_time_s": 0.0,
}


def experiment(question: str) -> ModuleType:
    """The script experiments/<question>/<question>.py as a module, loaded once per process
    from its file (so that no folder on ``sys.path`` can shadow it): the scripts that build
    on another experiment's scenes take them from here."""
    name = f"experiments.{question}"
    if name not in sys.modules:
        path = EXPERIMENTS / question / f"{question}.py"
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise ImportError(f"no experiment script at {path}")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        try:
            spec.loader.exec_module(module)
        except BaseException:
            del sys.modules[name]
            raise
    return sys.modules[name]


def best_of(fn: Callable[[], object], repeats: int = 3) -> float:
    """Smallest wall time (s) of ``repeats`` calls: the least noisy estimate on a shared machine."""
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def machine() -> str:
    """This machine in one line: CPU model, cores, OS, Python."""
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return (
        f"{model}, {os.cpu_count()} CPUs, {platform.system()} {platform.release()}, "
        f"Python {platform.python_version()}"
    )


def write_meta(path: Path) -> Path:
    """Write PATH's provenance beside it (NAME.meta.json): the command that wrote it, the
    date, the machine and the commit. The documentation states them under every table it
    renders from the file (docs/_gen/render.py)."""
    commit = code_version()["commit"] or ""  # "-dirty" if the package differs from it
    script = Path(sys.argv[0])
    try:
        script = script.resolve().relative_to(ROOT)
    except ValueError:
        pass
    meta = {
        "command": shlex.join(["python", str(script), *sys.argv[1:]]),
        "date": time.strftime("%Y-%m-%d", time.gmtime()),
        "machine": machine(),
        "commit": commit,
    }
    out = path.with_suffix(".meta.json")
    out.write_text(json.dumps(meta, indent=2) + "\n")
    return out


def write_csv(name: str | Path, rows: list[dict]) -> Path:
    """Write rows (dicts with the same keys) to RESULTS/NAME.csv (or to the path
    ``name``, when it is a Path), and its provenance to NAME.meta.json."""
    path = name if isinstance(name, Path) else RESULTS / f"{name}.csv"
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    write_meta(path)
    return path


def sagging_filament(n: int, time_step_s: float = 2e-3):
    """A clamped horizontal filament of n segments (0.5 mm) sagging under its net weight
    (elasticity, drag, gravity; a 1 mm first-mode perturbation), advanced at a fixed step:
    the state of the scaling and profile experiments."""
    from bathprint import Simulation

    spacing_mm = 0.5
    return Simulation(
        "paper_simulation",
        {
            "flow.q_outer_ml_min": 0.0,
            "initial.length_mm": n * spacing_mm,
            "numerics.node_spacing_mm": spacing_mm,
            "needle.direction": [1.0, 0.0, 0.0],
            "initial.perturbation_mm": 1.0,
            "numerics.time_step_s": time_step_s,
            "duration_s": 100.0,
        },
    )

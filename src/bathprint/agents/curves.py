"""Training curves: the final metric of training episodes (rolling mean) and of the
held-out evaluations against environment steps, as ``training_curve.png`` in a run.

``python -m bathprint.agents.curves RUN_DIR...`` draws them again, for a run folder or an
exported copy of one (``run.json``, ``episodes.csv`` or ``episodes.csv.gz``,
``eval/evaluations.npz``): the committed results keep no per-run curve
(:mod:`bathprint.agents.slim`).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence
from pathlib import Path

import numpy as np


def _missing_error(run_dir: Path) -> float:
    """M at reset (= the spec's missing_error), to turn evaluation returns into final
    metrics; read from the environment's spec, no environment is built."""
    from bathprint.envs.metric import MetricParams
    from bathprint.envs.spec import load_spec

    info = json.loads((run_dir / "run.json").read_text())
    return MetricParams.from_dict(load_spec(info["env_id"]).metric).missing_error


def eval_curve(run_dir: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """(timesteps, mean final metric on the held-out set) of a run's evaluations.

    An episode's return is M_0 - M_final with M_0 = missing_error, so M_final = M_0 - return.
    """
    run_dir = Path(run_dir)
    path = run_dir / "eval" / "evaluations.npz"
    if not path.is_file():
        return np.zeros(0), np.zeros(0)
    with np.load(path) as d:
        steps, returns = d["timesteps"], d["results"]
    if len(steps) == 0:
        return np.zeros(0), np.zeros(0)
    return steps.astype(float), _missing_error(run_dir) - returns.mean(axis=1)


def plot_training_curve(run_dir: str | Path, window: int = 50) -> Path:
    """Write ``training_curve.png`` into the run directory; returns its path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from bathprint.agents.train import read_episodes

    run_dir = Path(run_dir)
    info = json.loads((run_dir / "run.json").read_text())
    rows = read_episodes(run_dir)
    fig, ax = plt.subplots(figsize=(7, 4))
    if rows:
        t = np.array([r["timesteps"] for r in rows])
        m = np.array([r["metric"] for r in rows])
        ax.plot(t, m, ".", ms=2, alpha=0.25, color="tab:blue")
        w = max(1, min(window, len(m)))
        smooth = np.convolve(m, np.ones(w) / w, mode="valid")
        ax.plot(t[w - 1 :], smooth, color="tab:blue", label=f"training episodes (mean of {w})")
    te, me = eval_curve(run_dir)
    if len(te):
        ax.plot(te, me, "o-", color="tab:red", label="held-out evaluation (mean)")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("final shape metric (lower is better)")
    wall = float(info.get("wall_time_s", 0.0))
    ax.set_title(f"{info['algo'].upper()} on {info['env_id']} (seed {info['seed']}, {wall:.0f} s)")
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    path = run_dir / "training_curve.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bathprint.agents.curves", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("runs", nargs="+", help="run folders (with run.json)")
    args = ap.parse_args(argv)
    missing = [r for r in args.runs if not (Path(r) / "run.json").is_file()]
    if missing:
        print(f"curves: no run.json in {', '.join(missing)}", file=sys.stderr)
        return 2
    for r in args.runs:
        print(f"wrote {plot_training_curve(r)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What stops the fast jets with inertia: the tip's arrival at the floor.

Runs the fast-jets study's "+ inertia" variant (``bathprint reproduce fast_jets``: the
drag-coiling scene with the 22G-like 0.41 mm needle 30 mm above the floor, 5 and 20 ml/min,
buckling seeds of 1 and 20 um) frame by frame as the study does, until it fails or ends,
and records at every frame the free end's height above the floor, its speed and the
largest segment strain. Writes results/inertia_impact.csv (+ .meta.json) and
prints, per run, when the tip reaches the floor and when and where the run fails.

    python experiments/fast_jets/inertia_impact.py
    python experiments/fast_jets/inertia_impact.py --duration-s 0.004 --out /tmp/x.csv  # smoke
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, write_csv  # noqa: E402

FLOOR_TOUCH_M = 0.5e-3  # the tip "reaches the floor" when its centre line is this close


def runs() -> list[tuple[float, float, dict]]:
    """(Q_o in ml/min, seed in um, scene overrides) of the fast-jets study's inertia runs."""
    from bathprint.studies.reproduce import fast_jets

    return [
        (r["point"][1], r["seed_um"], r["over"]) for r in fast_jets.plan() if r["name"] == "inertia"
    ]


def trace(over: dict) -> tuple[list[dict], str]:
    """Frame-by-frame record of one run (the study's frame times) and how it ended."""
    from bathprint import Simulation
    from bathprint.errors import SimulationError

    sim = Simulation("drag_coiling_22G", overrides=over)
    sc = sim.scene
    floor_z = -sc.bath.depth_mm * 1e-3  # the floor is at z = -bath.depth_mm
    n = max(1, int(math.ceil(sc.duration_s / sc.outputs.frame_interval_s - 1e-9)))
    rows: list[dict] = []
    for t in np.minimum(np.arange(1, n + 1) * sc.outputs.frame_interval_s, sc.duration_s):
        try:
            sim.advance(float(t))
        except SimulationError as exc:
            return rows, str(exc).split(":")[0]
        x, v = sim.centerline(), sim.velocities()
        strain = np.linalg.norm(np.diff(x, axis=0), axis=1)[: sim.n_segments]
        strain = strain / sim.rest_lengths() - 1.0
        k = int(np.argmax(np.abs(strain)))
        rows.append({
            "t_s": float(t), "nodes": len(x), "tip_height_m": float(x[0, 2] - floor_z),
            "tip_speed_m_s": float(np.linalg.norm(v[0])), "max_abs_strain": float(abs(strain[k])),
            "max_strain_node": k,
        })  # fmt: skip
    return rows, "completed"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default=str(RESULTS / "inertia_impact.csv"), help="CSV path")
    ap.add_argument("--duration-s", type=float, default=None, help="stop each run at this time (s)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    table = []
    for q, seed, over in runs():
        if args.duration_s is not None:
            over = {**over, "duration_s": args.duration_s}
        rows, end = trace(over)
        touch = next((r for r in rows if r["tip_height_m"] < FLOOR_TOUCH_M), None)
        print(
            f"Q_o {q:g} ml/min, seed {seed:g} um: tip at {rows[0]['tip_speed_m_s']:.2f} m/s "
            f"after one frame; reaches the floor at "
            + (f"{touch['t_s'] * 1e3:.1f} ms at {touch['tip_speed_m_s']:.2f} m/s" if touch
               else "no time")
            + f"; {end} after the frame at {rows[-1]['t_s'] * 1e3:.1f} ms (largest strain then "
            f"{rows[-1]['max_abs_strain']:.2f} at node {rows[-1]['max_strain_node']})",
            flush=True,
        )  # fmt: skip
        table += [{"q_outer_ml_min": q, "seed_um": seed, "end": end, **r} for r in rows]
    print(f"wrote {write_csv(out, table)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

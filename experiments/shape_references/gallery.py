"""What the references write on each named shape: ``controller`` and ``cem`` on every test
and ood_test shape of each family, the target beside what each wrote (a figure per family,
shown in the family's environment page, docs/envs/<Env>.md#gallery).

    python experiments/shape_references/gallery.py          # play what is missing, plot (~5 min)
    python experiments/shape_references/gallery.py --families floor --sets test
    python experiments/shape_references/gallery.py --plot   # redraw from the npz files only

One deterministic episode (seed 0, ``draft`` accuracy) per (family, shape, policy) in the
family's environment (``bathprint.agents.controller.FAMILY_ENVS``). Per family,
results/gallery_<family>.npz holds, per shape, the target and each policy's written curve as
the whole-shape error compares them (resampled by the family's arclength, the written curve
moved onto the target by the family's rigid motion, ``shape_metric.align``; float32, thinned
to ``N_PLOT`` points for the plot), the RMS and largest distance (mm) and success (the
error of ``ShapeEnv.written_curve()`` against ``ShapeEnv.reference_curve``, checked equal to
what the episode reported). The target is drawn in the shape's own frame, as its file gives
it: the floor environment turns and moves a shape in the bath, which its family's rigid
motion undoes. The file is rewritten after every shape; a run keeps the shapes it already
holds from the same code version (``bathprint.provenance.code_version``) and plays the rest.

The plot reads the npz files only: docs/img/gallery_<family>.png, one panel per shape, the
target grey and thick, controller blue, cem orange. ``floor`` is seen from above (x-y, equal
aspect); ``free`` in 3D (the coils' height is stretched to 3 times the horizontal scale,
the title says so, so that stacked turns stand apart); ``buoyant`` as the height against the
horizontal arclength (its shape is the height profile: where each part settles).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
from tqdm import tqdm

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # experiments/: _common
from _common import RESULTS, ROOT, write_meta  # noqa: E402

from bathprint.agents.controller import FAMILY_ENVS, family_shapes, make_controller  # noqa: E402
from bathprint.envs.shape_geometry import arclength, resample  # noqa: E402
from bathprint.envs.shape_metric import N_POINTS, align, arclength_axes, shape_error  # noqa: E402
from bathprint.envs.shapes import index  # noqa: E402
from bathprint.provenance import code_version  # noqa: E402

POLICIES = ("controller", "cem")
COLORS = {"controller": "tab:blue", "cem": "tab:orange"}
SETS = ("test", "ood_test")
SET_LABEL = {"test": "test", "ood_test": "ood", "validation": "validation"}
#: points per stored curve: enough for the plot (every 0.2-0.6 mm of the shapes' 25-80 mm)
N_PLOT = 128
#: the free family's vertical stretch in its 3D panels (its coils are 1-4 mm tall, 5-11 wide)
FREE_Z_STRETCH = 3.0
SEED = 0
IMG = ROOT / "docs" / "img"


# ---------------------------------------------------------------------------- results
def npz_path(family: str) -> Path:
    return RESULTS / f"gallery_{family}.npz"


def version() -> str:
    """The code version results are kept under (the package's commit, '-dirty' if edited)."""
    return str(code_version()["commit"] or "unknown")


def load(family: str) -> dict[str, Any]:
    """A family's stored results as ``{"version", "accuracy", "shapes": {(set, name): row}}``
    (empty when there is no file)."""
    path = npz_path(family)
    out: dict[str, Any] = {"version": "", "accuracy": "", "shapes": {}}
    if not path.is_file():
        return out
    with np.load(path, allow_pickle=False) as z:
        out["version"], out["accuracy"] = str(z["code_version"]), str(z["accuracy"])
        for i, (st, name) in enumerate(zip(z["sets"], z["names"], strict=True)):
            row: dict[str, Any] = {"writable": bool(z["writable"][i]), "target": z["target"][i]}
            for pol in POLICIES:
                row[pol] = {
                    "written": z[f"written_{pol}"][i],
                    "rms_mm": float(z[f"rms_mm_{pol}"][i]),
                    "max_mm": float(z[f"max_mm_{pol}"][i]),
                    "success": bool(z[f"success_{pol}"][i]),
                }
            out["shapes"][(str(st), str(name))] = row
    return out


def save(family: str, shapes: dict[tuple[str, str], dict[str, Any]], accuracy: str) -> Path:
    """Write a family's rows (in set, then index order) and the file's provenance beside it."""
    order = {(r["set"], r["name"]): k for k, r in enumerate(index()) if r["family"] == family}
    keys = sorted(shapes, key=lambda k: order.get(k, len(order)))
    rows = [shapes[k] for k in keys]
    arrays: dict[str, np.ndarray] = {
        "sets": np.array([k[0] for k in keys]),
        "names": np.array([k[1] for k in keys]),
        "writable": np.array([r["writable"] for r in rows], bool),
        "target": np.stack([r["target"] for r in rows]).astype(np.float32),
        "code_version": np.array(version()),
        "accuracy": np.array(accuracy),
        "seed": np.array(SEED),
    }
    arrays.update(policy_arrays(rows, POLICIES))
    path = npz_path(family)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, **arrays)  # type: ignore[arg-type]
    write_meta(path)
    return path


def policy_arrays(rows: list[dict[str, Any]], policies: tuple[str, ...]) -> dict[str, np.ndarray]:
    """Each policy's written curves (float32), RMS and largest distance (mm) and success, one
    entry per row, as the npz files store them (``written_<policy>``, ``rms_mm_<policy>``...)."""
    arrays: dict[str, np.ndarray] = {}
    for pol in policies:
        arrays[f"written_{pol}"] = np.stack([r[pol]["written"] for r in rows]).astype(np.float32)
        for key, dtype in (("rms_mm", np.float32), ("max_mm", np.float32), ("success", bool)):
            arrays[f"{key}_{pol}"] = np.array([r[pol][key] for r in rows], dtype)
    return arrays


def aligned(written: np.ndarray, shape: np.ndarray, family: str) -> np.ndarray:
    """The written curve as ``shape_error`` compares it: both curves resampled to
    ``N_POINTS`` by the family's arclength, the written one moved onto the shape by the
    family's rigid motion; thinned to ``N_PLOT`` points."""
    axes = arclength_axes(family)
    w = resample(written, n=N_POINTS, axes=axes)
    t = resample(shape, n=N_POINTS, axes=axes)
    return resample(align(w, t, family), n=N_PLOT, axes=axes)


def play_family(family: str, sets: list[str], accuracy: str, force: bool) -> dict[str, Any]:
    """Play every missing (shape, policy) of a family, saving after each shape."""
    from bathprint.agents.planning import ShapeCEMPolicy
    from bathprint.agents.rollout import run_episode
    from bathprint.envs import make
    from bathprint.envs.shape_files import reference_curve

    stored = load(family)
    keep = not force and stored["version"] == version() and stored["accuracy"] == accuracy
    shapes: dict[tuple[str, str], dict[str, Any]] = stored["shapes"] if keep else {}
    writable = {(r["set"], r["name"]): r["writable"] for r in index() if r["family"] == family}
    jobs = [
        (st, name, pts)
        for st in sets
        for name, pts in family_shapes(family, st)
        if (st, name) not in shapes
    ]
    if not jobs:
        return {"family": family, "played": 0, "shapes": shapes}
    env_id = FAMILY_ENVS[family]
    env = make(env_id, accuracy=accuracy)
    u = env.unwrapped
    policies = {"controller": make_controller(env), "cem": ShapeCEMPolicy(env, env_id)}
    for st, name, pts in tqdm(jobs, desc=f"gallery {family}"):
        target = u.shape_target(pts, name, writable[(st, name)])
        # drawn in the shape's own frame (a floor target is turned and moved in the bath;
        # the family's rigid motion leaves the error the same)
        shape = reference_curve(pts, env, family)
        row: dict[str, Any] = {
            "writable": writable[(st, name)],
            "target": resample(shape, n=N_PLOT, axes=arclength_axes(family)),
        }
        for pol, policy in policies.items():
            ep = run_episode(env, policy, SEED, options={"target": target})
            written, ref = u.written_curve(), u.reference_curve
            if ep.truncated or len(written) != len(ref):  # diverged: no whole-shape error
                nan = np.full((N_PLOT, 3), np.nan)
                row[pol] = {"written": nan, "rms_mm": math.nan, "max_mm": math.nan}
                row[pol]["success"] = False
                continue
            err = shape_error(written, ref, family)
            if not math.isclose(err.rms_mm, ep.metrics["rms_mm"], rel_tol=1e-9):
                raise RuntimeError(f"{name}: rms {err.rms_mm} != reported {ep.metrics}")
            row[pol] = {
                "written": aligned(written, shape, family),
                "rms_mm": err.rms_mm,
                "max_mm": err.max_mm,
                "success": err.success,
            }
        shapes[(st, name)] = row
        save(family, shapes, accuracy)
    env.close()
    return {"family": family, "played": len(jobs), "shapes": shapes}


def summary(family: str) -> str:
    """Mean RMS (mm) and successes of each policy per set, from the family's npz."""
    stored = load(family)["shapes"]
    lines = []
    for st in (*SETS, "validation"):
        rows = [r for (s, _), r in stored.items() if s == st]
        if not rows:
            continue
        parts = []
        for pol in POLICIES:
            rms = np.array([r[pol]["rms_mm"] for r in rows])
            ok = sum(r[pol]["success"] for r in rows)
            parts.append(f"{pol} {np.nanmean(rms):.2f} mm ({ok}/{len(rows)} succeed)")
        lines.append(f"{family:8s} {st:9s} n={len(rows):2d}: " + ", ".join(parts))
    return "\n".join(lines)


# ---------------------------------------------------------------------------- plot
def _title(name: str, st: str, row: dict[str, Any]) -> str:
    tag = SET_LABEL.get(st, st) + ("" if row["writable"] else ", not writable")
    errs = []
    for pol, short in zip(POLICIES, ("ctl", "cem"), strict=True):
        rms = row[pol]["rms_mm"]
        errs.append(f"{short} {rms:.2f}" if math.isfinite(rms) else f"{short} diverged")
    return f"{name} ({tag})\n{' / '.join(errs)} mm"


def _panel(
    ax: Any,
    family: str,
    row: dict[str, Any],
    policies: tuple[str, ...] = POLICIES,
    colors: dict[str, str] = COLORS,
) -> None:
    """One shape: the target grey and thick under each policy's written curve."""
    from matplotlib.ticker import MaxNLocator

    curves = [("target", row["target"], "0.55", 3.5)]
    curves += [(pol, row[pol]["written"], colors[pol], 1.0) for pol in policies]
    if family == "floor":
        for _, c, color, lw in curves:
            ax.plot(c[:, 0], c[:, 1], color=color, lw=lw, solid_capstyle="round")
        ax.set_aspect("equal", adjustable="datalim")
    elif family == "free":
        for _, c, color, lw in curves:
            ax.plot(c[:, 0], c[:, 1], c[:, 2], color=color, lw=lw)
        t = row["target"]
        span = np.ptp(t, axis=0)
        ax.set_box_aspect((span[0], span[1], max(span[2] * FREE_Z_STRETCH, 0.2 * span[0])))
        ax.view_init(elev=20, azim=-60)
        for axis in (ax.xaxis, ax.yaxis, ax.zaxis):
            axis.pane.fill = False
            axis.set_major_locator(MaxNLocator(4))
        ax.tick_params(labelsize=5, pad=0)
    else:  # buoyant: height against the horizontal arclength
        s = arclength(row["target"], arclength_axes(family))
        for _, c, color, lw in curves:
            ax.plot(s, c[:, 2], color=color, lw=lw)
        ax.set_xlabel("horizontal arclength (mm)", fontsize=6, labelpad=1)
        ax.set_ylabel("height (mm)", fontsize=6, labelpad=1)
    ax.tick_params(labelsize=5)


def plot_family(family: str, out: Path | None = None) -> Path:
    """docs/img/gallery_<family>.png from results/gallery_<family>.npz (module doc)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    stored = load(family)
    shapes = stored["shapes"]
    if not shapes:
        raise SystemExit(f"{npz_path(family)}: no results; run without --plot first")
    ncol = {"floor": 5, "free": 5, "buoyant": 4}[family]
    nrow = math.ceil(len(shapes) / ncol)
    size = {"floor": 2.4, "free": 2.8, "buoyant": 2.8}[family]
    fig = plt.figure(figsize=(ncol * size, nrow * size * 0.95 + 0.7))
    projection = "3d" if family == "free" else None
    for k, ((st, name), row) in enumerate(shapes.items()):
        ax = fig.add_subplot(nrow, ncol, k + 1, projection=projection)
        _panel(ax, family, row)
        ax.set_title(_title(name, st, row), fontsize=6.5, pad=2)
    view = {
        "floor": "top view (x-y, mm)",
        "free": f"3D (mm; height stretched {FREE_Z_STRETCH:g}x)",
        "buoyant": "height against horizontal arclength",
    }[family]
    fig.suptitle(
        f"{FAMILY_ENVS[family].split('/')[-1]} ({family}): {view}; RMS error after the "
        f"family's rigid motion, {stored['accuracy']} accuracy, seed {SEED}",
        fontsize=8,
    )
    handles = [Line2D([], [], color="0.6", lw=3.5, label="target")]
    handles += [Line2D([], [], color=COLORS[p], lw=1.2, label=p) for p in POLICIES]
    fig.legend(handles=handles, loc="lower center", fontsize=7, ncol=3, frameon=False)
    h = fig.get_figheight()
    h_pad = 2.0 if family == "free" else 0.6  # room for the 3D axes' tick labels
    fig.tight_layout(rect=(0, 0.3 / h, 1, 1 - 0.35 / h), h_pad=h_pad, w_pad=0.4)
    path = out or IMG / f"gallery_{family}.png"
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80, metadata={"Software": None})
    plt.close(fig)
    return path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--families", nargs="+", default=list(FAMILY_ENVS), choices=FAMILY_ENVS)
    ap.add_argument("--sets", nargs="+", default=list(SETS), choices=(*SETS, "validation"))
    ap.add_argument("--accuracy", default="draft")
    ap.add_argument("--plot", action="store_true", help="only draw, from the npz files")
    ap.add_argument("--force", action="store_true", help="replay every shape")
    args = ap.parse_args()
    for family in args.families:
        if not args.plot:
            play_family(family, args.sets, args.accuracy, args.force)
        path = plot_family(family)
        print(summary(family))
        print(f"  -> {path.relative_to(ROOT)} ({path.stat().st_size / 1e3:.0f} kB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

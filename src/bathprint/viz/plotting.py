"""Pictures of filaments (matplotlib, Agg backend: no screen needed).

:func:`plot_filament` draws ``filament.png``: the region of interest (from the needle to a
few coil turns below the buckling point, :func:`region_of_interest`) in 3D and from the
side, with scale bars in mm, and the whole filament beside it with that region boxed.
:func:`plot_written` draws ``written.png`` of ``bathprint write``: a shape's target and the
curve written, from the top for flat (``floor``) shapes, else in 3D.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402
from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: E402

from bathprint.core.layout import MAT_BIRTH_TIME  # noqa: E402

__all__ = ["plot_filament", "plot_written", "plt", "region_of_interest", "scale_bar_length"]

ROI_TURNS = 3.0  # coil turns below the buckling point that filament.png frames


def region_of_interest(
    centerline_mm: np.ndarray, measurements: dict[str, Any] | None, turns: float = ROI_TURNS
) -> np.ndarray:
    """Boolean mask of the nodes from the needle (the last node) to ``turns`` coil turns
    below the buckling point, by arclength from the needle: buckling length plus
    ``turns`` x 2 pi R (``measurements`` from summary.json, in m). Without a measured
    coil (straight, irregular or too short), every node."""
    n = len(centerline_mm)
    m = measurements or {}
    radius_m, buckle_m = m.get("coil_radius_m"), m.get("buckling_length_m")
    if n < 3 or not radius_m or not buckle_m:
        return np.ones(n, dtype=bool)
    if not (math.isfinite(radius_m) and math.isfinite(buckle_m)):
        return np.ones(n, dtype=bool)
    seg = np.linalg.norm(np.diff(centerline_mm, axis=0), axis=1)
    from_needle = np.concatenate([np.cumsum(seg[::-1])[::-1], [0.0]])
    keep = from_needle <= 1e3 * (buckle_m + turns * 2.0 * math.pi * radius_m)
    return keep if keep.sum() >= 3 else np.ones(n, dtype=bool)


def scale_bar_length(span_mm: float) -> float:
    """A round length (1, 2 or 5 x 10^k mm) of about a fifth of ``span_mm``."""
    target = max(span_mm, 1e-6) / 5.0
    k = math.floor(math.log10(target))
    for f in (5.0, 2.0, 1.0):
        if f * 10.0**k <= target:
            return f * 10.0**k
    return 10.0**k


def _bar_label(mm: float) -> str:
    return f"{mm:g} mm"


def _box(c: np.ndarray, pad: float = 0.08) -> tuple[np.ndarray, np.ndarray]:
    lo, hi = c.min(axis=0), c.max(axis=0)
    span = max(float((hi - lo).max()), 1.0)
    return lo - pad * span, hi + pad * span


def plot_filament(
    centerline_m: np.ndarray,
    material: np.ndarray,
    time_s: float,
    path: str | Path,
    title: str = "",
    measurements: dict[str, Any] | None = None,
) -> Path:
    """Write ``filament.png``: the region of interest in 3D and from the side (x-z), and
    the whole filament (x-z) with that region boxed; segments coloured by material age (s),
    scale bars in mm."""
    c = np.asarray(centerline_m, dtype=float) * 1e3
    age = time_s - material[: len(c) - 1, MAT_BIRTH_TIME]
    segs = np.stack([c[:-1], c[1:]], axis=1)
    roi = region_of_interest(c, measurements)
    seg_roi = roi[:-1] & roi[1:]
    norm = plt.Normalize(vmin=float(age.min()), vmax=float(max(age.max(), age.min() + 1e-9)))
    lo, hi = _box(c[roi])
    whole = bool(roi.all())

    fig = plt.figure(figsize=(12.5, 5.2))
    grid = fig.add_gridspec(1, 3, width_ratios=(1.25, 1.0, 0.5))
    ax = fig.add_subplot(grid[0], projection="3d")
    lc = Line3DCollection(segs[seg_roi], cmap="viridis", norm=norm, linewidths=1.6)
    lc.set_array(age[seg_roi])
    ax.add_collection(lc)
    ax.set_xlim(lo[0], hi[0])
    ax.set_ylim(lo[1], hi[1])
    ax.set_zlim(lo[2], hi[2])
    ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-9)))
    ax.scatter(*c[-1], color="red", s=24, label="needle tip", depthshade=False)
    bar = scale_bar_length(float((hi - lo)[:2].max()))
    x0, y0, z0 = lo[0] + 0.05 * (hi - lo)[0], lo[1], lo[2] + 0.05 * (hi - lo)[2]
    ax.plot([x0, x0 + bar], [y0, y0], [z0, z0], color="k", lw=2.5)
    ax.text(x0, y0, z0 + 0.04 * (hi - lo)[2], _bar_label(bar), fontsize=8)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title("region of interest" if not whole else "filament", fontsize=10)

    side = fig.add_subplot(grid[1])
    lc2 = LineCollection(segs[seg_roi][:, :, [0, 2]], cmap="viridis", norm=norm, linewidths=1.6)
    lc2.set_array(age[seg_roi])
    side.add_collection(lc2)
    side.plot(c[-1, 0], c[-1, 2], "o", color="red", ms=5)
    side.set_xlim(lo[0], hi[0])
    side.set_ylim(lo[2], hi[2])
    side.set_aspect("equal")
    side.set_xlabel("x (mm)")
    side.set_ylabel("z (mm)")
    side.set_title("side view" + ("" if whole else f", needle to {ROI_TURNS:g} turns"), fontsize=10)
    bar2 = scale_bar_length(float(min(hi[0] - lo[0], hi[2] - lo[2])))
    side.add_artist(
        AnchoredSizeBar(side.transData, bar2, _bar_label(bar2), "lower right", frameon=False)
    )

    full = fig.add_subplot(grid[2])
    lc3 = LineCollection(segs[:, :, [0, 2]], cmap="viridis", norm=norm, linewidths=1.0)
    lc3.set_array(age)
    full.add_collection(lc3)
    flo, fhi = _box(c)
    full.set_aspect("equal", adjustable="datalim")
    full.margins(0.08)
    full.autoscale_view()
    full.plot(c[-1, 0], c[-1, 2], "o", color="red", ms=4)
    if not whole:
        full.add_patch(
            Rectangle((lo[0], lo[2]), hi[0] - lo[0], hi[2] - lo[2], fill=False, ec="0.3", ls="--")
        )
    bar3 = scale_bar_length(float((fhi - flo)[2]))
    full.add_artist(
        AnchoredSizeBar(full.transData, bar3, _bar_label(bar3), "lower right", frameon=False)
    )
    full.set_xlabel("x (mm)")
    full.set_title("whole filament", fontsize=10)
    fig.colorbar(lc3, ax=full, label="material age (s)", fraction=0.12)
    fig.suptitle(f"{title}  t = {time_s:.3g} s, {len(c)} nodes".strip())
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out


def plot_run(run_dir: str | Path, out: str | Path) -> Path:
    """Draw a run directory's last frame as :func:`plot_filament` draws ``filament.png``
    (needs only the core: ``bathprint view RUN_DIR --png``). A missing or unreadable run
    raises :class:`~bathprint.errors.OptionError` naming the file."""
    from bathprint.core import layout
    from bathprint.viz.view import load_run

    times, frames, columns, summary, _ = load_run(run_dir)
    birth = columns.get(layout.MATERIAL_COLUMNS[layout.MAT_BIRTH_TIME])
    if birth is None:
        from bathprint.errors import OptionError

        raise OptionError(
            f"{str(Path(run_dir) / 'trajectory.npz')!r} has no material birth times; allowed: "
            "a trajectory written by bathprint simulate"
        )
    material = np.zeros((len(birth), layout.N_MAT))
    material[:, layout.MAT_BIRTH_TIME] = birth
    return plot_filament(
        frames[-1],
        material,
        float(summary.get("time_s", times[-1])),
        out,
        title=str(summary.get("scene") or Path(run_dir).name),
        measurements=summary.get("measurements"),
    )


def plot_written(
    target_mm: np.ndarray,
    written_mm: np.ndarray,
    path: str | Path,
    top_view: bool,
    title: str = "",
) -> Path:
    """Write a picture of a shape's target (grey) and the curve written (blue), both (N, 3)
    in mm and already in one frame: from the top (x-y) when ``top_view``, else in 3D with
    equal axes; a scale bar in mm, the start of the target marked."""
    t = np.asarray(target_mm, dtype=float).reshape(-1, 3)
    w = np.asarray(written_mm, dtype=float).reshape(-1, 3)
    both = np.vstack([t, w]) if len(w) else t
    lo, hi = _box(both)
    fig = plt.figure(figsize=(6.4, 5.6))
    if top_view:
        ax = fig.add_subplot()
        ax.plot(t[:, 0], t[:, 1], color="0.6", lw=3.0, label="target")
        if len(w):
            ax.plot(w[:, 0], w[:, 1], color="tab:blue", lw=1.4, label="written")
        ax.plot(t[0, 0], t[0, 1], "o", color="0.35", ms=5, label="start")
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        bar = scale_bar_length(float((hi - lo)[:2].max()))
        ax.add_artist(
            AnchoredSizeBar(ax.transData, bar, _bar_label(bar), "lower right", frameon=False)
        )
    else:
        ax = fig.add_subplot(projection="3d")
        ax.plot(*t.T, color="0.6", lw=3.0, label="target")
        if len(w):
            ax.plot(*w.T, color="tab:blue", lw=1.4, label="written")
        ax.scatter(*t[0], color="0.35", s=20, label="start", depthshade=False)
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        ax.set_zlim(lo[2], hi[2])
        ax.set_box_aspect(tuple(np.maximum(hi - lo, 1e-9)))
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_zlabel("z (mm)")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(title, fontsize=10)
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out

"""Pictures of filaments (matplotlib, Agg backend: no screen needed)."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Line3DCollection  # noqa: E402

from bathprint.core.layout import MAT_BIRTH_TIME  # noqa: E402

__all__ = ["plot_filament", "plt"]


def plot_filament(
    centerline_m: np.ndarray,
    material: np.ndarray,
    time_s: float,
    path: str | Path,
    title: str = "",
) -> Path:
    """3D view and side view of a filament, segments coloured by material age (s)."""
    c = centerline_m * 1e3
    age = time_s - material[: len(c) - 1, MAT_BIRTH_TIME]
    segs = np.stack([c[:-1], c[1:]], axis=1)
    fig = plt.figure(figsize=(10, 5.5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    norm = plt.Normalize(vmin=float(age.min()), vmax=float(max(age.max(), age.min() + 1e-9)))
    lc = Line3DCollection(segs, cmap="viridis", norm=norm, linewidths=1.5)
    lc.set_array(age)
    ax.add_collection(lc)
    lo, hi = c.min(axis=0), c.max(axis=0)
    mid, span = 0.5 * (lo + hi), max(float((hi - lo).max()), 1.0)
    for setter, m in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), mid, strict=True):
        setter(m - 0.55 * span, m + 0.55 * span)
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.scatter(*c[-1], color="red", s=20, label="needle")
    ax.legend(loc="upper left")
    ax2 = fig.add_subplot(1, 2, 2)
    lc2 = LineCollection(segs[:, :, [0, 2]], cmap="viridis", norm=norm, linewidths=1.5)
    lc2.set_array(age)
    ax2.add_collection(lc2)
    ax2.set_xlim(mid[0] - 0.55 * span, mid[0] + 0.55 * span)
    ax2.set_ylim(mid[2] - 0.55 * span, mid[2] + 0.55 * span)
    ax2.set_aspect("equal")
    ax2.set_xlabel("x (mm)")
    ax2.set_ylabel("z (mm)")
    fig.colorbar(lc2, ax=ax2, label="material age (s)")
    fig.suptitle(f"{title}  t = {time_s:.3g} s, {len(c)} nodes")
    fig.tight_layout()
    out = Path(path)
    fig.savefig(out, dpi=110)
    plt.close(fig)
    return out

"""Rendering: the printed filament beside (and overlaid with) its target, with matplotlib.

``draw(env)`` returns an RGB array (H, W, 3) uint8 drawn off-screen (Agg); ``show`` puts it
in a window for ``render_mode="human"``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from bathprint.envs.base import BathprintEnvBase as BathprintEnv

FIGSIZE_IN = (9.0, 4.0)
DPI = 80
_NON_INTERACTIVE = {"agg", "pdf", "ps", "svg", "cairo", "template", "pgf"}


def kabsch_align(p: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotation R and translation t (proper) that best map q onto p: p ~ q @ R.T + t."""
    pc, qc = p.mean(axis=0), q.mean(axis=0)
    h = (q - qc).T @ (p - pc)
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(vt.T @ u.T)) or 1.0
    r = vt.T @ np.diag([1.0, 1.0, d]) @ u.T
    return r, pc - qc @ r.T


def _target_placed(env: BathprintEnv) -> np.ndarray:
    """The target centreline placed on the printed one (Kabsch on the scored part)."""
    tgt = env.target
    assert tgt is not None
    printed = env.printed_samples().points_mm
    q = tgt.points_mm
    if len(printed) >= 3:
        r, t = kabsch_align(printed, q[: len(printed)])
        return q @ r.T + t
    start = env._interp(np.array([env._u0_mm]), env._x)[0]
    return q - q[0] + start


def draw(env: BathprintEnv) -> np.ndarray:
    """One frame: 3D view (left) and the target's main quantity along arclength (right)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    if env._figure is None:
        fig = Figure(figsize=FIGSIZE_IN, dpi=DPI)
        FigureCanvasAgg(fig)
        env._figure = fig
    fig = env._figure
    fig.clear()
    ax3 = fig.add_subplot(1, 2, 1, projection="3d")
    ax2 = fig.add_subplot(1, 2, 2)
    x, u = env._x, env._u - env._u0_mm
    old = u <= 0
    ax3.plot(*x[old].T, color="0.7", lw=0.8, label="warm-up")
    ax3.plot(*x[~old].T, color="tab:blue", lw=1.2, label="printed")
    tgt = env.target
    assert tgt is not None
    placed = _target_placed(env)
    ax3.plot(*placed.T, color="tab:red", lw=0.8, ls="--", label="target")
    ax3.scatter(*env._x[-1], color="k", s=10)
    allp = np.vstack([x[~old] if (~old).any() else x, placed])
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    mid, half = 0.5 * (lo + hi), 0.5 * max(float(np.max(hi - lo)), 1.0)
    for setlim, k in ((ax3.set_xlim, 0), (ax3.set_ylim, 1), (ax3.set_zlim, 2)):
        setlim(mid[k] - half, mid[k] + half)
    ax3.set_xlabel("x (mm)")
    ax3.set_ylabel("y (mm)")
    ax3.set_zlabel("z (mm)")
    ax3.legend(loc="upper left", fontsize=7)
    _profile(env, ax2)
    score = (
        f"metric {env._metric.value:.3f}"
        if hasattr(env, "_metric")
        else f"error {env._prefix_rms:.2f} mm"  # a shape environment: the whole-shape error
    )
    fig.suptitle(
        f"{env.env_id}  step {env._steps}  printed {env._printed_mm:.0f}/"
        f"{env.episode_length_mm:.0f} mm  {score}",
        fontsize=9,
    )
    fig.tight_layout()
    canvas = fig.canvas
    canvas.draw()
    return np.asarray(canvas.buffer_rgba())[..., :3].copy()


def _profile(env: BathprintEnv, ax: Any) -> None:
    tgt = env.target
    assert tgt is not None
    s = tgt.s_mm
    printed = env.printed_samples()
    j = len(printed.points_mm)
    if env.metric_params.w_density > 0 and env.bath_range is not None:
        # heights at which the parts settle in the gradient bath
        lo_rho, hi_rho = env.bath_range
        grad = (hi_rho - lo_rho) / env.depth_mm
        mid = 0.5 * (tgt.density_lo_kg_m3 + tgt.density_hi_kg_m3)
        ax.plot(s, -(mid - lo_rho) / grad, color="tab:red", ls="--", label="target")
        rho = np.clip(printed.density_kg_m3, lo_rho, hi_rho)
        ax.plot(s[:j], -(rho - lo_rho) / grad, color="tab:blue", label="printed (settles at)")
        ax.set_ylabel("settling height (mm)")
        ax.set_ylim(-env.depth_mm, 0)
    else:
        from bathprint.envs.targets import discrete_curvature

        k = max(1, int(round(env.metric_params.curvature_span_mm / tgt.spacing_mm)))
        ax.plot(s, discrete_curvature(tgt.points_mm, k), color="tab:red", ls="--", label="target")
        if j:
            ax.plot(
                s[:j], discrete_curvature(printed.points_mm, k), color="tab:blue", label="printed"
            )
        ax.set_ylabel("curvature (1/mm)")
        if env.metric_params.w_density > 0:
            twin = ax.twinx()
            twin.plot(s, tgt.density_aim(env.rho_gel), color="tab:orange", ls=":", lw=0.8)
            twin.plot(s[:j], printed.density_kg_m3, color="tab:green", lw=0.8)
            twin.set_ylabel("density (kg/m^3): aim dotted", fontsize=7)
    ax.axvline(env._printed_mm - env.settle_length_mm, color="0.6", lw=0.6)
    ax.set_xlim(0, max(tgt.length_mm, 1.0))
    ax.set_xlabel("printed arclength s (mm)")
    ax.legend(loc="upper right", fontsize=7)


def show(env: BathprintEnv, frame: np.ndarray) -> None:
    """Show a frame in a window (does nothing with a non-interactive matplotlib backend)."""
    import matplotlib.pyplot as plt

    if plt.get_backend().lower() in _NON_INTERACTIVE:
        return
    win = getattr(env, "_window", None)
    if win is None:
        fig, ax = plt.subplots(figsize=FIGSIZE_IN, dpi=DPI)
        ax.set_axis_off()
        env._window = (fig, ax.imshow(frame))
        plt.show(block=False)
    else:
        win[1].set_data(frame)
    plt.pause(1.0 / env.metadata["render_fps"])


def close(env: BathprintEnv) -> None:
    win = getattr(env, "_window", None)
    if win is not None:
        import matplotlib.pyplot as plt

        plt.close(win[0])
        env._window = None

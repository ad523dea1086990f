"""One episode of a policy in a bathprint environment, with the numbers evaluation keeps."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: per-episode metrics written by evaluation (units in the names)
METRIC_KEYS = ("metric", "shape_rms_mm", "curvature_rms_1_mm", "density_rms_kg_m3")
#: the shape environments' (bathprint.envs.shape_env): metric = rms_mm, the whole-shape error
SHAPE_METRIC_KEYS = ("metric", "rms_mm", "max_mm", "local_metric")


@dataclass
class Episode:
    """What one episode produced."""

    seed: int
    target_index: int
    target_key: str
    metrics: dict[str, float]
    episode_return: float
    length: int
    wall_time_s: float
    terminated: bool
    truncated: bool
    sim_error: str | None
    mean_q_outer_ml_min: float
    mean_q_inner_ml_min: float
    is_success: float = float("nan")  # info["is_success"] at the end (NaN: the env has none)
    frames: list[np.ndarray] = field(default_factory=list, repr=False)
    final_frame: np.ndarray | None = field(default=None, repr=False)

    def record(self) -> dict[str, Any]:
        """A flat dict for CSV / JSON."""
        out: dict[str, Any] = {
            "seed": self.seed,
            "target_index": self.target_index,
            "target_key": self.target_key,
        }
        out.update(self.metrics)
        out.update(
            {
                "reward": self.episode_return,
                "episode_length": self.length,
                "wall_time_s": self.wall_time_s,
                "terminated": self.terminated,
                "truncated": self.truncated,
                "sim_error": self.sim_error or "",
                "mean_q_outer_ml_min": self.mean_q_outer_ml_min,
                "mean_q_inner_ml_min": self.mean_q_inner_ml_min,
            }
        )
        return out


def run_episode(
    env: Any,
    policy: Any,
    seed: int,
    target_index: int | None = None,
    deterministic: bool = True,
    frame_every: int = 0,
    final_frame: bool = False,
    options: dict[str, Any] | None = None,
) -> Episode:
    """Reset with ``seed`` (and evaluation target ``target_index``), run ``policy`` to the end.

    ``frame_every`` > 0 keeps ``env.render()`` every that many steps (and the first and last
    frames); the environment must have ``render_mode="rgb_array"`` then. ``options`` go to
    ``reset`` (e.g. ``{"target": Target}``: a target of one's own).
    """
    options = dict(options or {})
    if target_index is not None:
        options["target_index"] = int(target_index)
    t0 = time.perf_counter()
    obs, info = env.reset(seed=int(seed), options=options)
    frames = [env.render()] if frame_every > 0 else []
    ret, steps, done = 0.0, 0, False
    terminated = truncated = False
    qo_sum = qi_sum = 0.0
    state, episode_start = None, np.ones(1, bool)
    while not done:
        action, state = policy.predict(
            obs, state=state, episode_start=episode_start, deterministic=deterministic
        )
        episode_start = np.zeros(1, bool)
        obs, reward, terminated, truncated, info = env.step(action)
        ret += float(reward)
        steps += 1
        qo_sum += float(info["q_outer_ml_min"])
        qi_sum += float(info["q_inner_ml_min"])
        done = bool(terminated or truncated)
        if frame_every > 0 and (steps % frame_every == 0 or done):
            frames.append(env.render())
    return Episode(
        seed=int(seed),
        target_index=int(info.get("target_index", -1)),
        target_key=str(info.get("target_key", "")),
        metrics={
            k: float(info.get(k, float("nan")))
            for k in (SHAPE_METRIC_KEYS if "rms_mm" in info else METRIC_KEYS)
        },
        episode_return=ret,
        length=steps,
        wall_time_s=time.perf_counter() - t0,
        terminated=bool(terminated),
        truncated=bool(truncated),
        sim_error=info.get("sim_error"),
        mean_q_outer_ml_min=qo_sum / max(steps, 1),
        mean_q_inner_ml_min=qi_sum / max(steps, 1),
        is_success=float(info["is_success"]) if "is_success" in info else float("nan"),
        frames=frames,
        final_frame=env.render() if final_frame else None,
    )

"""``bathprint play``: run a policy in an environment and write an animation and the metric.

    bathprint play CoilRadius-v1 --policy random --episodes 1 --seed 0 --out runs/play

writes ``DIR/episode_K.gif`` (with Pillow, which matplotlib already needs; ``--format mp4``
needs ``imageio[ffmpeg]``): the filament being written beside its target, one frame per
``--frame-every`` steps; and ``DIR/metrics.json``: per episode the final metric and its parts,
the return, the steps and the target.

Policies: ``random`` (uniform actions, seeded), ``zero`` (action 0: mid-range flows),
``constant`` (the flows of the warm-up, held: Q_o = warm-up value, Q_i = 0, offset 0).

On a fixed set (version 0's ``eval``, the default there; version 1's ``validation`` or
``test``, the default there), episode K plays target K unless ``--target-index`` fixes one;
an index outside the set, or more episodes than it has targets, is refused (exit code 2), as
is any other bad value. ``--needle-velocity default`` keeps the environment's own needle
axes (none in version 0 and in CoilRadius-v1 / BuoyantLayers-v1, x and y in WriteShape-v1).
SIGINT and SIGTERM end it with exit code 130 / 143 and a message.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bathprint.errors import ConfigError

POLICIES = ("random", "constant", "zero")


DESCRIPTION = "Run a policy and write an animation and the metric."


def _parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="bathprint play", description=DESCRIPTION)
    add_arguments(ap)
    return ap


def add_arguments(ap: argparse.ArgumentParser) -> None:
    """The options of ``bathprint play``."""
    ap.add_argument("env", help="environment id or short name, e.g. CoilRadius")
    ap.add_argument("--policy", choices=POLICIES, default="random")
    ap.add_argument("--episodes", type=int, default=1)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", required=True, help="output directory")
    ap.add_argument("--accuracy", default="draft", choices=("draft", "balanced", "fine"))
    ap.add_argument(
        "--target-set",
        default=None,
        choices=("train", "eval", "validation", "test"),
        help="default: eval (version 0), test (version 1)",
    )
    ap.add_argument("--target-index", type=int, default=None)
    ap.add_argument("--target-file", default=None)
    ap.add_argument("--needle-velocity", default="default", choices=("default", "no", "xy", "xyz"))
    ap.add_argument("--frame-every", type=int, default=2, help="render every Nth step")
    ap.add_argument("--format", default="gif", choices=("gif", "mp4"))
    ap.add_argument("--fps", type=float, default=None)


def policy_action(name: str, env: Any, rng: np.random.Generator) -> np.ndarray:
    """The action of a built-in policy."""
    shape = env.action_space.shape
    if name == "random":
        return rng.uniform(-1.0, 1.0, shape).astype(np.float32)
    if name == "zero":
        return np.zeros(shape, np.float32)
    u = env.unwrapped
    a = u.controls_to_action(u.warmup_q_outer, 0.0)
    if "inclusion_offset" in u.action_names:
        lo, hi = u.offset_range
        a[u.action_names.index("inclusion_offset")] = 0.0 if hi <= lo else (-lo - hi) / (hi - lo)
    return a


def write_animation(frames: list[np.ndarray], path: Path, fps: float) -> Path:
    """GIF (Pillow) or MP4 (imageio with ffmpeg)."""
    if path.suffix == ".mp4":
        try:
            import imageio.v2 as imageio
        except ImportError as exc:
            raise RuntimeError(
                "--format mp4 needs imageio[ffmpeg] (pip install imageio[ffmpeg])"
            ) from exc
        imageio.mimsave(path, frames, fps=fps)
        return path
    from PIL import Image

    images = [Image.fromarray(f) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=int(1000 / fps), loop=0)
    return path


def side_by_side(
    panels: list[tuple[str, list[np.ndarray]]], scale: float = 1.0, every: int = 1
) -> list[np.ndarray]:
    """Frames of several episodes laid side by side, each panel captioned (``panels``:
    (caption, RGB frames) in order), resized by ``scale`` and keeping every ``every``-th
    frame and the last; a shorter episode holds its last frame. For comparing an agent with
    the oracle on one target."""
    from PIL import Image, ImageDraw

    if not panels or any(not frames for _, frames in panels):
        raise ValueError("side_by_side: every panel needs at least one frame")
    if not (scale > 0 and every >= 1):
        raise ValueError(f"side_by_side: scale = {scale}, every = {every}; need > 0 and >= 1")
    n = max(len(frames) for _, frames in panels)
    steps = [*range(0, n - 1, every), n - 1]
    height = max(round(frames[0].shape[0] * scale) for _, frames in panels)
    band = 18  # caption band (px)
    out: list[np.ndarray] = []
    for t in steps:
        row = []
        for caption, frames in panels:
            pic = Image.fromarray(frames[min(t, len(frames) - 1)][..., :3])
            if scale != 1.0:
                size = (round(pic.width * scale), round(pic.height * scale))
                pic = pic.resize(size, Image.Resampling.LANCZOS)
            img = Image.new("RGB", (pic.width, height + band), "white")
            img.paste(pic, (0, band))
            ImageDraw.Draw(img).text((4, 3), caption, fill="black")
            row.append(np.asarray(img))
        out.append(np.concatenate(row, axis=1))
    return out


FIXED_SETS = ("eval", "validation", "test")


def check_args(args: argparse.Namespace, eval_size: int | None = None) -> None:
    """Refuse values that would be changed or ignored silently (ConfigError). With
    ``eval_size`` (the size of the fixed target set in use), also the target index and
    episodes."""
    if args.episodes < 1:
        raise ConfigError(f"--episodes = {args.episodes}; allowed: an integer >= 1")
    if args.frame_every < 1:
        raise ConfigError(f"--frame-every = {args.frame_every}; allowed: an integer >= 1")
    if args.fps is not None and not (math.isfinite(args.fps) and args.fps > 0):
        raise ConfigError(f"--fps = {args.fps}; allowed: a number > 0")
    v1 = args.env_version >= 1
    if args.target_index is not None:
        if args.target_file:
            raise ConfigError(
                f"--target-index = {args.target_index} with --target-file: the file is the "
                "target; give one of them"
            )
        if args.target_set not in FIXED_SETS:
            needs = "validation or test" if v1 else "eval"
            raise ConfigError(
                f"--target-index = {args.target_index} selects a fixed target; it "
                f"needs --target-set {needs}"
            )
    if eval_size is None or args.target_set not in FIXED_SETS or args.target_file:
        return
    name = f"the {args.target_set} set" if v1 else "the evaluation set"
    if args.target_index is not None and not 0 <= args.target_index < eval_size:
        raise ConfigError(
            f"--target-index = {args.target_index}; {name} has {eval_size} "
            f"targets: allowed 0..{eval_size - 1}"
        )
    if args.target_index is None and args.episodes > eval_size:
        raise ConfigError(
            f"--episodes = {args.episodes}; {name} has {eval_size} targets and "
            f"episode K plays target K: allowed 1..{eval_size} (or fix one with --target-index)"
        )


def _set_size(env: Any, target_set: str) -> int | None:
    from bathprint.envs import target_set_size  # (the package imports this module)

    return target_set_size(env.unwrapped, target_set) if target_set in FIXED_SETS else None


def run(args: argparse.Namespace) -> dict[str, Any]:
    from bathprint.envs import make, printed_targets

    args.env_version = 1 if printed_targets(args.env) else 0
    if args.target_set is None:
        args.target_set = "test" if args.env_version else "eval"
    check_args(args)
    kwargs: dict[str, Any] = {
        "render_mode": "rgb_array",
        "accuracy": args.accuracy,
        "target_set": args.target_set,
    }
    if args.needle_velocity == "no":
        kwargs["needle_velocity"] = False
    elif args.needle_velocity != "default":
        kwargs["needle_velocity"] = args.needle_velocity
    if args.target_file:
        kwargs["target_file"] = args.target_file
    env = make(args.env, **kwargs)
    try:
        check_args(args, _set_size(env, args.target_set))
    except ConfigError:
        env.close()
        raise
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    fps = args.fps or env.metadata["render_fps"]
    rng = np.random.default_rng(args.seed)
    episodes = []
    for ep in range(args.episodes):
        options = {}
        if args.target_set in FIXED_SETS and not args.target_file:
            options["target_index"] = args.target_index if args.target_index is not None else ep
        obs, info = env.reset(seed=args.seed + ep, options=options)
        frames = [env.render()]
        ret, steps, done = 0.0, 0, False
        while not done:
            obs, reward, terminated, truncated, info = env.step(
                policy_action(args.policy, env, rng)
            )
            ret += reward
            steps += 1
            done = terminated or truncated
            if steps % args.frame_every == 0 or done:
                frames.append(env.render())
        path = write_animation(frames, out / f"episode_{ep}.{args.format}", fps)
        record = {
            "episode": ep,
            "seed": args.seed + ep,
            "steps": steps,
            "return": ret,
            "terminated": bool(terminated),
            "truncated": bool(truncated),
            "sim_error": info.get("sim_error"),
            "animation": path.name,
        }
        for key in ("metric", "shape_rms_mm", "curvature_rms_1_mm", "density_rms_kg_m3"):
            record[key] = float(info[key])
        for key in ("scored_fraction", "printed_length_mm", "target_key", "target_index"):
            record[key] = info[key]
        episodes.append(record)
        print(
            f"episode {ep}: {steps} steps, return {ret:.4f}, metric {info['metric']:.4f} -> {path}"
        )
    env.close()
    summary = {
        "env": env.spec.id if env.spec else args.env,
        "policy": args.policy,
        "accuracy": args.accuracy,
        "target_set": args.target_set,
        "episodes": episodes,
        "mean_metric": float(np.mean([e["metric"] for e in episodes])),
    }
    (out / "metrics.json").write_text(json.dumps(summary, indent=2))
    return summary


def run_args(args: argparse.Namespace) -> int:
    """Play from parsed options; returns the exit code (2 for a refused value, 130 / 143
    after SIGINT / SIGTERM)."""
    from bathprint.signals import SignalStop, exit_code, signal_name

    try:
        with SignalStop(deferred=False):
            run(args)
    except KeyboardInterrupt as exc:
        name = signal_name(getattr(exc, "signum", 2))
        print(f"bathprint play: interrupted by {name}", file=sys.stderr)
        return exit_code(exc)
    except (ValueError, RuntimeError, FileNotFoundError) as exc:
        print(f"bathprint play: {exc}", file=sys.stderr)
        return 2
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``bathprint play``; returns the exit code."""
    return run_args(_parser().parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())

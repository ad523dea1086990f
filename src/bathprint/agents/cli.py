"""``bathprint train``, ``bathprint evaluate`` and ``bathprint baselines``.

bathprint train --algo ppo --env bathprint/WriteShape-v0 [--timesteps N] [--n-envs K]
                [--seed S] [--out DIR] [--resume]
bathprint train --algo ppo --env ENV --seeds 0-4 [--workers K | --scheduler ADDR]
bathprint train --campaign agents/campaigns/CoilRadius-v1.yml [--workers K | --scheduler ADDR]
bathprint evaluate RUN_DIR_OR_POLICY [...] --env ENV [--episodes N] [--seed S] [--out DIR]
bathprint baselines fit --env ENV [--targets N] [--write]

Refusals (bad settings, files or values) are one line on stderr and exit code 2, before
any work starts. SIGINT (Ctrl-C) and SIGTERM end a command with 130 and 143; ``train``
saves a checkpoint first (see :mod:`bathprint.agents.train`).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from bathprint.agents.hyperparams import ALGOS
from bathprint.agents.signals import SignalStop, exit_code, signal_name


def _train_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="bathprint train", description="Train a Stable-Baselines3 agent on an environment."
    )
    ap.add_argument("--algo", choices=ALGOS, help="algorithm (required without --campaign)")
    ap.add_argument("--env", help="environment id or short name (required without --campaign)")
    ap.add_argument("--timesteps", type=int, default=None, help="total environment steps")
    ap.add_argument("--n-envs", type=int, default=None, help="parallel environments")
    ap.add_argument("--seed", type=int, default=None, help="seed (default 0; a resume: the run's)")
    ap.add_argument("--out", default=None, help="run directory (default runs/ALGO_ENV_seedS)")
    ap.add_argument("--resume", action="store_true", help="continue the run in --out")
    ap.add_argument(
        "--hyperparams",
        default=None,
        help="YAML file of settings (default agents/ALGO.yml), e.g. agents/ppo_residual.yml",
    )
    ap.add_argument("--quiet", action="store_true", help="no progress bar")
    ap.add_argument(
        "--seeds",
        default=None,
        help="several runs, e.g. 0-4: OUT/<Env>/ALGO/seedS, each scored on the test targets, "
        "and OUT/<Env>/results.md (rerun to resume)",
    )
    ap.add_argument(
        "--campaign", default=None, help="a campaign file of (env, algo, seeds) runs (YAML)"
    )
    ap.add_argument("--workers", type=int, default=1, help="--seeds/--campaign: processes")
    ap.add_argument(
        "--scheduler",
        default=None,
        help="--seeds/--campaign: 'serial', 'local-dask' or a Dask address tcp://host:8786",
    )
    return ap


def _many(args: argparse.Namespace) -> int:
    """``--seeds`` and ``--campaign``: see :mod:`bathprint.agents.campaign`."""
    from bathprint.agents import campaign as cmp

    if args.workers < 1:
        print(f"bathprint train: --workers = {args.workers}; must be >= 1", file=sys.stderr)
        return 2
    try:
        if args.campaign is not None:
            for name in ("algo", "env", "seeds", "seed", "timesteps", "n_envs", "hyperparams"):
                if getattr(args, name) is not None:
                    raise ValueError(
                        f"--{name.replace('_', '-')} = {getattr(args, name)!r}; with --campaign "
                        "the campaign file sets it"
                    )
            camp = cmp.load_campaign(args.campaign, args.out)
        else:
            if args.seed is not None or args.resume:
                raise ValueError("--seeds: leave out --seed and --resume (a rerun resumes)")
            camp = cmp.seeds_campaign(args.algo, args.env, args.seeds, args.out,
                                      args.hyperparams, args.timesteps, args.n_envs)
        with SignalStop(deferred=False):
            written = cmp.run_campaign(camp, args.workers, args.scheduler, not args.quiet)
    except KeyboardInterrupt as exc:
        print(_interrupted("train", exc, "rerun the command to resume"), file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError) as exc:
        print(f"bathprint train: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:
        print(f"bathprint train: {exc}", file=sys.stderr)
        return 1
    for path in written.values():
        print(path.read_text(), end="")
        print(f"wrote {path.parent}/ (results.md, results.json, runs.csv, scores.csv, curves.png)")
    return 0


def train_main(argv: Sequence[str] | None = None) -> int:
    args = _train_parser().parse_args(argv)
    from bathprint.agents.train import train

    if args.seeds is not None or args.campaign is not None:
        return _many(args)
    for name in ("algo", "env"):
        if getattr(args, name) is None:
            print(f"bathprint train: --{name} is required (or --campaign FILE)", file=sys.stderr)
            return 2

    for name in ("timesteps", "n_envs"):
        value = getattr(args, name)
        if value is not None and value < 1:
            print(
                f"bathprint train: --{name.replace('_', '-')} = {value}; must be >= 1",
                file=sys.stderr,
            )
            return 2
    try:
        run_dir = train(
            args.algo,
            args.env,
            timesteps=args.timesteps,
            n_envs=args.n_envs,
            seed=args.seed,
            out=args.out,
            resume=args.resume,
            progress=not args.quiet,
            hyperparams_file=args.hyperparams,
        )
    except KeyboardInterrupt as exc:  # train saved a checkpoint and said so
        return exit_code(exc)
    except (ValueError, FileNotFoundError, FileExistsError) as exc:
        print(f"bathprint train: {exc}", file=sys.stderr)
        return 2
    info = json.loads((run_dir / "run.json").read_text())
    print(
        f"trained {info['timesteps_done']} steps in {info['wall_time_s']:.0f} s; wrote {run_dir}/"
        "final_model.zip, training_curve.png"
    )
    return 0


def _evaluate_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="bathprint evaluate",
        description="Deterministic rollouts of policies on the held-out targets.",
    )
    ap.add_argument(
        "policies",
        nargs="+",
        help="run directories, model .zip files, baselines (random, constant, feedforward, "
        "feedforward_calibrated) or planners (oracle, mpc: version-1 environments)",
    )
    ap.add_argument("--env", required=True)
    ap.add_argument("--episodes", type=int, default=16)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", default="runs/evaluate")
    ap.add_argument(
        "--accuracy",
        choices=("draft", "balanced", "fine"),
        default=None,
        help="accuracy preset (default: the run's own, else draft)",
    )
    ap.add_argument("--images", type=int, default=3, help="episodes to draw as PNG")
    ap.add_argument("--no-animation", action="store_true", help="skip the GIF of episode 0")
    ap.add_argument(
        "--side-by-side",
        default=None,
        metavar="GIF",
        help="also write episode 0 of every policy side by side (in the order given, each "
        "captioned with its final metric; 0.6 of the size, every second frame) to this .gif",
    )
    ap.add_argument(
        "--target-files",
        nargs="+",
        default=None,
        metavar="CSV",
        help="score on these shapes (x_mm,y_mm,z_mm) instead of the test set: one episode "
        "each, whole-shape error in mm, rows in OUT/targets.csv",
    )
    ap.add_argument(
        "--shape-family",
        choices=("floor", "free", "buoyant"),
        default=None,
        help="--target-files: the shapes' family (default: the environment's)",
    )
    ap.add_argument(
        "--allow-overlap",
        action="store_true",
        help="--target-files: score free shapes whose strands overlap instead of refusing them",
    )
    ap.add_argument("--quiet", action="store_true")
    return ap


def evaluate_main(argv: Sequence[str] | None = None) -> int:
    args = _evaluate_parser().parse_args(argv)
    from bathprint.agents.evaluate import evaluate_many, format_table

    if args.images < 0:
        print(f"bathprint evaluate: --images = {args.images}; must be >= 0", file=sys.stderr)
        return 2
    if args.target_files:
        return _evaluate_files(args)
    try:
        with SignalStop(deferred=False):
            summaries = evaluate_many(
                args.policies,
                args.env,
                episodes=args.episodes,
                seed=args.seed,
                out=args.out,
                accuracy=args.accuracy,
                images=args.images,
                animate=not args.no_animation,
                progress=not args.quiet,
                side_by_side=args.side_by_side,
            )
    except KeyboardInterrupt as exc:
        print(
            _interrupted("evaluate", exc, "the policy being evaluated wrote nothing"),
            file=sys.stderr,
        )
        return exit_code(exc)
    except (ValueError, FileNotFoundError, RuntimeError) as exc:
        print(f"bathprint evaluate: {exc}", file=sys.stderr)
        return 2
    print(format_table(summaries), end="")
    print(f"wrote {args.out}/table.md and one directory per policy")
    return 0


def _evaluate_files(args: argparse.Namespace) -> int:
    """``bathprint evaluate ... --target-files``: one row per shape and policy."""
    from bathprint.agents.evaluate import evaluate_target_files, format_target_rows

    try:
        with SignalStop(deferred=False):
            rows = evaluate_target_files(
                args.policies,
                args.env,
                args.target_files,
                seed=args.seed,
                out=args.out,
                accuracy=args.accuracy,
                family=args.shape_family,
                progress=not args.quiet,
                allow_overlap=args.allow_overlap,
            )
    except KeyboardInterrupt as exc:
        print(_interrupted("evaluate", exc, "targets.csv was not written"), file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError, RuntimeError) as exc:
        print(f"bathprint evaluate: {exc}", file=sys.stderr)
        return 2
    print(format_target_rows(rows), end="")
    print(f"wrote {args.out}/targets.csv")
    return 0


def _interrupted(command: str, exc: BaseException, what: str) -> str:
    name = signal_name(getattr(exc, "signum", 2))
    return f"bathprint {command}: interrupted by {name}; {what}"


def _baselines_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="bathprint baselines",
        description="Fit the constant and feedforward baselines on training targets.",
    )
    sub = ap.add_subparsers(dest="action", required=True)
    f = sub.add_parser("fit", help="grid search of constant flows; scaling-law prefactor")
    f.add_argument("--env", required=True)
    f.add_argument("--accuracy", default="draft", choices=("draft", "balanced", "fine"))
    f.add_argument("--targets", type=int, default=4, help="training targets per action")
    f.add_argument("--grid-q-outer", type=int, default=8)
    f.add_argument("--grid-q-inner", type=int, default=4)
    f.add_argument("--grid-offset", type=int, default=3)
    f.add_argument("--seed", type=int, default=1000)
    f.add_argument("--write", action="store_true", help="store the result in agents/baselines.yml")
    f.add_argument("--quiet", action="store_true")
    s = sub.add_parser("show", help="print the fitted baselines")
    s.add_argument("--env", required=True)
    return ap


def baselines_main(argv: Sequence[str] | None = None) -> int:
    args = _baselines_parser().parse_args(argv)
    from bathprint.agents.hyperparams import load_baselines, save_baselines
    from bathprint.envs import resolve_id

    try:
        env_id = resolve_id(args.env)
        if args.action == "show":
            entry = load_baselines(env_id)
            entry.pop("grid", None)
            print(json.dumps(entry, indent=2))
            return 0
        from bathprint.agents.fit import fit_baselines

        for name in ("targets", "grid_q_outer", "grid_q_inner", "grid_offset"):
            if getattr(args, name) < 1:
                raise ValueError(
                    f"--{name.replace('_', '-')} = {getattr(args, name)}; must be >= 1"
                )
        with SignalStop(deferred=False):
            entry = fit_baselines(
                env_id,
                accuracy=args.accuracy,
                n_targets=args.targets,
                grid_q_outer=args.grid_q_outer,
                grid_q_inner=args.grid_q_inner,
                grid_offset=args.grid_offset,
                seed=args.seed,
                progress=not args.quiet,
            )
    except KeyboardInterrupt as exc:
        print(_interrupted("baselines", exc, "nothing written"), file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError, RuntimeError) as exc:
        print(f"bathprint baselines: {exc}", file=sys.stderr)
        return 2
    print(
        f"{env_id}: best constant action {entry['constant_action']} "
        f"(Q_o {entry['constant_q_outer_ml_min']:.3f}, Q_i {entry['constant_q_inner_ml_min']:.3f}"
        f" ml/min; mean metric {entry['constant_mean_metric']:.4f} on training targets); "
        f"scaling-law prefactor c = {entry['feedforward_prefactor']:.4f} (paper 0.4)"
    )
    if args.write:
        print(f"wrote {save_baselines(env_id, entry)}")
    return 0

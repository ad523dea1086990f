"""``bathprint train``: train an agent (:mod:`bathprint.agents.train`), several seeds of
one, or a campaign of them (:mod:`bathprint.agents.campaign`)::

    bathprint train --algo ppo --env bathprint/WriteShape-v0 [--timesteps N] [--n-envs K]
                    [--seed S] [--out DIR] [--resume]
    bathprint train --algo ppo --env ENV --seeds 0-4 [--workers K | --scheduler ADDR]
    bathprint train --campaign agents/campaigns/CoilRadius-v1.yml [--workers K | --scheduler ADDR]

Needs the ``rl`` extra (and ``dask`` for a Dask scheduler). Refusals (bad settings, files or
values, a missing extra) are one line on stderr and exit code 2, before any work starts.
SIGINT (Ctrl-C) and SIGTERM end it with 130 and 143 after saving a checkpoint.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from bathprint.agents.algos import ALGOS
from bathprint.cli._common import needs_extra

PROG = "bathprint train"


def add_parser(sub: Any) -> argparse.ArgumentParser:
    ap = sub.add_parser(
        "train",
        help="train an agent: bathprint train --algo ppo --env ENV ...",
        description="Train a Stable-Baselines3 agent on an environment.",
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
    ap.set_defaults(run=run)
    return ap


@needs_extra(PROG, "rl", "training an agent")
def run(args: argparse.Namespace) -> int:
    if args.seeds is not None or args.campaign is not None:
        return _many(args)
    for name in ("algo", "env"):
        if getattr(args, name) is None:
            print(f"{PROG}: --{name} is required (or --campaign FILE)", file=sys.stderr)
            return 2
    for name in ("timesteps", "n_envs"):
        value = getattr(args, name)
        if value is not None and value < 1:
            print(f"{PROG}: --{name.replace('_', '-')} = {value}; must be >= 1", file=sys.stderr)
            return 2
    from bathprint.agents.signals import exit_code
    from bathprint.agents.train import train

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
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    info = json.loads((run_dir / "run.json").read_text())
    print(
        f"trained {info['timesteps_done']} steps in {info['wall_time_s']:.0f} s; wrote {run_dir}/"
        "final_model.zip, training_curve.png"
    )
    return 0


def _many(args: argparse.Namespace) -> int:
    """``--seeds`` and ``--campaign``: see :mod:`bathprint.agents.campaign`."""
    from bathprint._extras import MissingExtraError
    from bathprint.agents import campaign as cmp
    from bathprint.agents.signals import SignalStop, exit_code
    from bathprint.cli._common import interrupted, scheduler_needs_dask

    if args.workers < 1:
        print(f"{PROG}: --workers = {args.workers}; must be >= 1", file=sys.stderr)
        return 2
    try:
        scheduler_needs_dask(args.scheduler)
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
        print(interrupted("train", exc, "rerun the command to resume"), file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError, MissingExtraError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
        return 1
    for path in written.values():
        print(path.read_text(), end="")
        print(f"wrote {path.parent}/ (results.md, results.json, runs.csv, scores.csv, curves.png)")
    return 0

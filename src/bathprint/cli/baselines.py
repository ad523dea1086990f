"""``bathprint baselines fit --env ENV [--targets N] [--write]`` and ``bathprint baselines
show --env ENV``: the constant and feedforward baselines (:mod:`bathprint.agents.fit`,
stored in ``agents/baselines.yml``). Needs the ``rl`` extra."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from bathprint.cli._common import interrupted, needs_extra

PROG = "bathprint baselines"


def add_parser(sub: Any) -> argparse.ArgumentParser:
    ap = sub.add_parser(
        "baselines",
        help="fit the constant / feedforward baselines: ... fit --env ENV",
        description="Fit the constant and feedforward baselines on training targets.",
    )
    actions = ap.add_subparsers(dest="action", required=True)
    f = actions.add_parser("fit", help="grid search of constant flows; scaling-law prefactor")
    f.add_argument("--env", required=True)
    f.add_argument("--accuracy", default="draft", choices=("draft", "balanced", "fine"))
    f.add_argument("--targets", type=int, default=4, help="training targets per action")
    f.add_argument("--grid-q-outer", type=int, default=8)
    f.add_argument("--grid-q-inner", type=int, default=4)
    f.add_argument("--grid-offset", type=int, default=3)
    f.add_argument("--seed", type=int, default=1000)
    f.add_argument("--write", action="store_true", help="store the result in agents/baselines.yml")
    f.add_argument("--quiet", action="store_true")
    s = actions.add_parser("show", help="print the fitted baselines")
    s.add_argument("--env", required=True)
    ap.set_defaults(run=run)
    return ap


@needs_extra(PROG, "rl", "fitting or reading the baselines")
def run(args: argparse.Namespace) -> int:
    from bathprint.agents.hyperparams import load_baselines, save_baselines
    from bathprint.agents.signals import SignalStop, exit_code
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
        print(interrupted("baselines", exc, "nothing written"), file=sys.stderr)
        return exit_code(exc)
    except (ValueError, FileNotFoundError, RuntimeError) as exc:
        print(f"{PROG}: {exc}", file=sys.stderr)
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

"""The ``bathprint`` command.

Every command checks its options (output paths included) before it starts working and
refuses bad input with one line on stderr and exit code 2; a diverged simulation exits 3;
an interrupted command (Ctrl-C or SIGTERM) exits 130 / 143.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import sys
from pathlib import Path

from bathprint.errors import OptionError, SceneError, SimulationError
from bathprint.interrupt import exit_code, signals_interrupt


def _version() -> str:
    from bathprint import __version__

    return __version__


def _cmd_simulate(args: argparse.Namespace) -> int:
    from bathprint import simulate
    from bathprint.core.scene import load_scene, parse_override
    from bathprint.paths import check_output_dir

    overrides = dict(parse_override(s) for s in args.set or [])
    if args.accuracy:
        overrides["numerics.accuracy"] = args.accuracy
    load_scene(args.scene, overrides)  # a bad scene is refused first
    out = check_output_dir(args.out or f"runs/{Path(args.scene).stem}", "--out")
    result = simulate(args.scene, overrides, out_dir=out, progress=not args.quiet)
    s = result.summary
    mb = s["mass_balance"]
    print(
        f"{s['scene']}: {s['time_s']:.3g} s simulated in {s['wall_time_s']:.2f} s wall "
        f"({s['steps']} steps, {s['rejected_steps']} rejected, {s['nodes']} nodes); "
        f"mass balance error {mb['relative_error']:.2e}"
    )
    print(
        f"wrote {out}/trajectory.npz, summary.json"
        + (", filament.png" if result.scene.outputs.plot else "")
    )
    return 0


def _cmd_scenes(args: argparse.Namespace) -> int:
    from bathprint.core.scene import builtin_scene_names, load_scene, scene_summary_line

    for name in builtin_scene_names():
        print(scene_summary_line(load_scene(name)))
    return 0


def _cmd_show(args: argparse.Namespace) -> int:
    from bathprint.core.scene import load_scene, parse_override, scene_to_toml

    overrides = dict(parse_override(s) for s in args.set or [])
    scene = load_scene(args.scene, overrides)
    if args.json:
        print(json.dumps(scene.to_dict(), indent=2))
    else:
        print(scene_to_toml(scene), end="")
    return 0


def _check_record(c: object) -> dict:
    """One validation check as a JSON object: its fields, relative error and verdict."""
    import dataclasses

    rec = dataclasses.asdict(c)  # type: ignore[call-overload]
    rec["unit"] = rec.pop("detail", "")
    rec["relative_error"] = c.relative_error  # type: ignore[attr-defined]
    rec["passed"] = bool(c.passed)  # type: ignore[attr-defined]
    return rec


def _cmd_validate(args: argparse.Namespace) -> int:
    import platform
    import time

    from bathprint.analysis.validation import run_all

    t0 = time.perf_counter()
    checks = run_all()
    if args.json:
        print(
            json.dumps(
                {
                    "command": "bathprint validate --json",
                    "bathprint": _version(),
                    "date": time.strftime("%Y-%m-%d"),
                    "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, "
                    f"{platform.system()} {platform.release()}, Python "
                    f"{platform.python_version()}",
                    "wall_s": time.perf_counter() - t0,
                    "checks": [_check_record(c) for c in checks],
                },
                indent=2,
            )
        )
        return 0 if all(c.passed for c in checks) else 1
    print(f"{'check':<58} {'simulated':>12} {'exact':>12} {'rel. error':>10} {'tol':>6}  ok")
    for c in checks:
        print(
            f"{c.name:<58} {c.simulated:>12.6g} {c.exact:>12.6g} {c.relative_error:>10.2e} "
            f"{c.tolerance:>6.0e}  {'yes' if c.passed else 'NO'}"
        )
    return 0 if all(c.passed for c in checks) else 1


def _cmd_view(args: argparse.Namespace) -> int:
    from bathprint.viz import view

    if (args.run_dir is None) == (args.env is None):
        raise OptionError(
            "bathprint view takes a RUN_DIR or --env ENV (one of them); allowed: "
            "bathprint view RUN_DIR [--out FILE.html] or bathprint view --env ENV --policy P"
        )
    if args.run_dir is not None:
        path = view.run_page(args.run_dir, args.out, colour=args.colour)
    else:
        from bathprint.agents.episode_view import episode_page
        from bathprint.paths import check_output_file

        out = check_output_file(args.out or "episode.html", "--out")
        path, info = episode_page(
            args.env,
            args.policy,
            out,
            seed=args.seed,
            target_index=args.target_index,
            accuracy=args.accuracy,
        )
        print(f"episode: metric {info.get('metric', float('nan')):.4f}")
    print(f"wrote {path} (open it in a browser)")
    return 0


def _cmd_composites(args: argparse.Namespace) -> int:
    from bathprint.paths import check_output_dir
    from bathprint.studies.reproduce import fig3

    res = fig3.run(check_output_dir(args.out, "--out"), quick=args.quick)
    print(f"{'flow ratio':>10} {'phi':>6} {'E_c/E_alg':>10} {'rho_c (kg/m^3)':>15}")
    for r in res["composites"]:
        print(
            f"{r['flow_ratio']:>10.3f} {r['inner_volume_fraction']:>6.3f} "
            f"{r['E_c_over_E_alg']:>10.4f} {r['density_kg_m3']:>15.1f}"
        )
    print("settling in the gradient column (height in mm, surface at 0):")
    for r in res["settling"]:
        print(
            f"  filament {r['filament']} ({r['density_kg_m3']:.0f} kg/m^3): simulated "
            f"{1e3 * r['settled_height_m']:8.3f}, expected {1e3 * r['expected_height_m']:8.3f}"
        )
    print(f"wrote {args.out}/fig3df_composites.png/.csv, fig3e_settling.png/.csv")
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    """``bathprint bench`` without a benchmark: its help, on stderr, and exit code 2 (as
    argparse does for a missing sub-command)."""
    args.bench_parser.print_help(sys.stderr)
    print("bathprint bench: error: name a benchmark (accuracy)", file=sys.stderr)
    return 2


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="bathprint",
        description="Simulate soft gelling filaments extruded into a reacting bath.",
    )
    p.add_argument("--version", action="version", version=f"bathprint {_version()}")
    sub = p.add_subparsers(dest="command", required=True)
    s = sub.add_parser("simulate", help="run a scene and write trajectory, summary and picture")
    s.add_argument(
        "scene",
        nargs="?",
        default="paper_simulation",
        help="built-in scene name (see `bathprint scenes`) or a TOML path "
        "(default: paper_simulation)",
    )
    s.add_argument(
        "--set",
        action="append",
        metavar="KEY=VALUE",
        help="override a scene value by dotted key, e.g. flow.q_outer_ml_min=5",
    )
    s.add_argument("--out", help="output directory (default runs/SCENE)")
    s.add_argument("--quiet", action="store_true", help="no progress bar")
    s.add_argument(
        "--accuracy",
        choices=("draft", "balanced", "fine", "custom"),
        help="accuracy preset (same as --set numerics.accuracy=...)",
    )
    s.set_defaults(func=_cmd_simulate)
    sc = sub.add_parser("scenes", help="list the built-in scenes")
    sc.set_defaults(func=_cmd_scenes)
    show_help = (
        "print a scene, with overrides applied, as TOML: `bathprint show SCENE > my.toml` "
        "then `bathprint simulate my.toml` runs exactly that scene"
    )
    sh = sub.add_parser("show", help=show_help, description=show_help)
    sh.add_argument("scene", help="built-in scene name or a TOML path")
    sh.add_argument("--set", action="append", metavar="KEY=VALUE", help="override a value")
    sh.add_argument("--json", action="store_true", help="JSON instead of TOML (not read back)")
    sh.set_defaults(func=_cmd_show)
    v = sub.add_parser("validate", help="run the analytic checks and print the table")
    v.add_argument("--json", action="store_true", help="the checks as JSON (with date and machine)")
    v.set_defaults(func=_cmd_validate)
    vw_help = (
        "an interactive 3D page (HTML, opens without a network) of a run directory, or of "
        "one episode of an environment with its target (--env)"
    )
    vw = sub.add_parser("view", help=vw_help, description=vw_help)
    vw.add_argument("run_dir", nargs="?", help="a directory written by bathprint simulate")
    vw.add_argument("--out", help="the page (default RUN_DIR/view.html, or episode.html)")
    vw.add_argument(
        "--colour",
        "--color",
        dest="colour",
        default="age",
        choices=("age", "modulus", "density", "inner_fraction"),
        help="material column the page starts with (it can be changed on the page)",
    )
    vw.add_argument("--env", help="play an episode of this environment instead of a run")
    vw.add_argument(
        "--policy",
        default="random",
        help="with --env: a baseline (random, constant, feedforward, feedforward_calibrated), "
        "a trained run directory or a model .zip",
    )
    vw.add_argument("--seed", type=int, default=0, help="with --env: the episode's seed")
    vw.add_argument("--target-index", type=int, default=0, help="with --env: held-out target")
    vw.add_argument("--accuracy", choices=("draft", "balanced", "fine"), help="with --env: preset")
    vw.set_defaults(func=_cmd_view)
    sub.add_parser("theory", help="scaling laws and linear stability: bathprint theory [--json]")
    sub.add_parser("warmup", help="compile the numba kernels now (once after an install)")
    sub.add_parser("play", help="one episode of an environment to a GIF: bathprint play ENV ...")
    sub.add_parser("train", help="train an agent: bathprint train --algo ppo --env ENV ...")
    sub.add_parser("evaluate", help="held-out rollouts: bathprint evaluate POLICY... --env ENV")
    sub.add_parser("baselines", help="fit the constant / feedforward baselines: ... fit --env ENV")
    b = sub.add_parser(
        "bench",
        help="benchmarks: bathprint bench accuracy --out DIR [--quick]",
        description="Benchmarks of the simulator.",
    )
    bsub = b.add_subparsers(dest="benchmark", metavar="BENCHMARK")
    bsub.add_parser(
        "accuracy",
        help="work-precision study: error against wall time per integrator and refinement "
        "(bathprint bench accuracy --help)",
    )
    b.set_defaults(func=_cmd_bench, bench_parser=b)
    from bathprint.studies import sweep

    sw = sub.add_parser("sweep", help="run a grid of scenes; resumable; process pool or Dask")
    sweep.add_arguments(sw)
    sw.set_defaults(func=sweep.run_args)
    from bathprint.studies.reproduce import cli as reproduce_cli

    rp = sub.add_parser(
        "reproduce",
        help="the paper's figures and studies: "
        "fig1c|fig2|fig3|stability|coils|all|ablation|gravity|fast_jets",
    )
    reproduce_cli.add_arguments(rp)
    rp.set_defaults(func=reproduce_cli.run_args)
    co = sub.add_parser(
        "composites",
        help="Fig. 3 curves: composite stiffness, density, settling in the gradient column",
    )
    co.add_argument("--out", default="runs/fig3")
    co.add_argument("--quick", action="store_true")
    co.set_defaults(func=_cmd_composites)
    return p


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["theory"]:  # the theory module parses its own options
        from bathprint.analysis import theory

        return theory.main(argv[1:])
    if argv[:2] == ["bench", "accuracy"]:  # the work-precision study parses its own options
        from bathprint.studies.accuracy import main as bench_accuracy

        return bench_accuracy(argv[2:])
    if argv[:1] == ["warmup"]:
        from bathprint.warmup import main as warmup_main

        return warmup_main(argv[1:])
    if argv[:1] == ["play"]:  # so does the environments' player
        from bathprint.envs import play_main

        return play_main(argv[1:])
    if argv[:1] in (["train"], ["evaluate"], ["baselines"]):  # and the agents' commands
        from bathprint.agents import cli as agents_cli

        main_of = {
            "train": agents_cli.train_main,
            "evaluate": agents_cli.evaluate_main,
            "baselines": agents_cli.baselines_main,
        }
        return main_of[argv[0]](argv[1:])
    parser = build_parser()
    args = parser.parse_args(argv)
    if not hasattr(args, "func"):  # a command without its own handler: show the help
        parser.print_help(sys.stderr)
        return 2
    prog = f"bathprint {args.command}"
    with signals_interrupt():
        try:
            return int(args.func(args))
        except SceneError as exc:
            print(f"{prog}: scene error: {exc}", file=sys.stderr)
            return 2
        except OptionError as exc:
            print(f"{prog}: {exc}", file=sys.stderr)
            return 2
        except SimulationError as exc:
            print(f"{prog}: {exc}", file=sys.stderr)
            return 3
        except KeyboardInterrupt as exc:
            name = signal.Signals(exit_code(exc) - 128).name
            print(f"{prog}: interrupted ({name})", file=sys.stderr)
            return exit_code(exc)


if __name__ == "__main__":
    sys.exit(main())

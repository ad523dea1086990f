"""``bathprint validate [--json]``: the analytic checks, as a table or JSON."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
from typing import Any

from bathprint.cli._common import guarded


def add_parser(sub: Any) -> argparse.ArgumentParser:
    v = sub.add_parser("validate", help="run the analytic checks and print the table")
    v.add_argument("--json", action="store_true", help="the checks as JSON (with date and machine)")
    v.set_defaults(run=run)
    return v


def check_record(c: Any) -> dict[str, Any]:
    """One validation check as a JSON object: its fields, relative error and verdict."""
    rec = dataclasses.asdict(c)
    rec["unit"] = rec.pop("detail", "")
    rec["relative_error"] = c.relative_error
    rec["passed"] = bool(c.passed)
    return rec


@guarded("bathprint validate")
def run(args: argparse.Namespace) -> int:
    import platform
    import time

    from bathprint import __version__
    from bathprint.analysis.validation import run_all

    t0 = time.perf_counter()
    checks = run_all()
    if args.json:
        print(
            json.dumps(
                {
                    "command": "bathprint validate --json",
                    "bathprint": __version__,
                    "date": time.strftime("%Y-%m-%d"),
                    "machine": f"{platform.machine()}, {os.cpu_count()} CPUs, "
                    f"{platform.system()} {platform.release()}, Python "
                    f"{platform.python_version()}",
                    "wall_s": time.perf_counter() - t0,
                    "checks": [check_record(c) for c in checks],
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

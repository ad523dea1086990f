"""What the commands share: the common refusal and interruption policy, and the check for
an extra before a command starts."""

from __future__ import annotations

import argparse
import functools
import signal
import sys
from collections.abc import Callable

from bathprint._extras import MissingExtraError, require_extra
from bathprint.errors import OptionError, SceneError, SimulationError
from bathprint.interrupt import exit_code, signals_interrupt

Run = Callable[[argparse.Namespace], int]


def guarded(prog: str) -> Callable[[Run], Run]:
    """Run a command inside :func:`~bathprint.interrupt.signals_interrupt` and turn its
    errors into one line on stderr and an exit code: a bad scene or option or a missing
    extra 2, a diverged simulation 3, SIGINT / SIGTERM 130 / 143. For commands that do not
    handle these themselves."""

    def wrap(run: Run) -> Run:
        @functools.wraps(run)
        def guarded_run(args: argparse.Namespace) -> int:
            with signals_interrupt():
                try:
                    return int(run(args))
                except SceneError as exc:
                    print(f"{prog}: scene error: {exc}", file=sys.stderr)
                    return 2
                except (OptionError, MissingExtraError) as exc:
                    print(f"{prog}: {exc}", file=sys.stderr)
                    return 2
                except SimulationError as exc:
                    print(f"{prog}: {exc}", file=sys.stderr)
                    return 3
                except KeyboardInterrupt as exc:
                    name = signal.Signals(exit_code(exc) - 128).name
                    print(f"{prog}: interrupted ({name})", file=sys.stderr)
                    return exit_code(exc)

        return guarded_run

    return wrap


def needs_extra(prog: str, extra: str, purpose: str) -> Callable[[Run], Run]:
    """Refuse a command (one line naming the extra and its pip line, exit code 2) before it
    starts when ``extra`` is not installed."""

    def wrap(run: Run) -> Run:
        @functools.wraps(run)
        def checked_run(args: argparse.Namespace) -> int:
            try:
                require_extra(extra, purpose)
            except MissingExtraError as exc:
                print(f"{prog}: {exc}", file=sys.stderr)
                return 2
            return int(run(args))

        return checked_run

    return wrap


def scheduler_needs_dask(scheduler: str | None, option: str = "--scheduler") -> None:
    """Raise :class:`~bathprint._extras.MissingExtraError` when ``scheduler`` is a Dask one
    (``local-dask`` or an address) and the ``dask`` extra is not installed."""
    if scheduler not in (None, "serial"):
        require_extra("dask", f"{option} {scheduler}")


def interrupted(command: str, exc: BaseException, what: str) -> str:
    """The line an agents' command prints when SIGINT or SIGTERM stopped it."""
    from bathprint.agents.signals import signal_name

    name = signal_name(getattr(exc, "signum", 2))
    return f"bathprint {command}: interrupted by {name}; {what}"

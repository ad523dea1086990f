"""SIGTERM handled like Ctrl-C, for the long commands (sweep, bench accuracy, reproduce).

Inside :func:`signals_interrupt` both SIGINT and SIGTERM raise :class:`Interrupted` (a
``KeyboardInterrupt``) in the main thread, so the code that already cleans up after
Ctrl-C (cancel pending work, stop worker processes, keep what was written) does so for a
``kill`` or a scheduler's stop as well. The first signal wins; later ones are ignored while
the clean-up runs. Writes inside :func:`atomic` are never cut: a signal arriving there is
raised when the block ends. Exit with :func:`exit_code`: 130 after SIGINT, 143 after SIGTERM.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["Interrupted", "atomic", "exit_code", "signals_interrupt"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A SIGINT or SIGTERM received inside :func:`signals_interrupt`; ``signum`` says which."""

    def __init__(self, signum: int) -> None:
        self.signum = int(signum)
        super().__init__(signal.Signals(self.signum).name)


def exit_code(exc: BaseException) -> int:
    """128 + the signal number: 143 for SIGTERM, 130 for SIGINT (and a plain Ctrl-C)."""
    return 128 + getattr(exc, "signum", signal.SIGINT)


_state: dict[str, int | None] = {"depth": 0, "pending": None, "fired": 0}


def _handler(signum: int, frame: object) -> None:
    if _state["fired"]:
        return  # the first signal's clean-up is running
    if _state["depth"]:
        _state["pending"] = signum  # raised when the atomic block ends
        return
    _state["fired"] = 1
    raise Interrupted(signum)


@contextmanager
def signals_interrupt() -> Iterator[None]:
    """SIGINT and SIGTERM raise :class:`Interrupted` in the block (main thread only; in other
    threads this does nothing). The previous handlers are restored on exit."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = {s: signal.signal(s, _handler) for s in SIGNALS}
    _state.update(depth=0, pending=None, fired=0)
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        _state.update(depth=0, pending=None, fired=0)


@contextmanager
def atomic() -> Iterator[None]:
    """A block that a signal must not cut (writing and syncing a result line)."""
    _state["depth"] = (_state["depth"] or 0) + 1
    ok = False
    try:
        yield
        ok = True
    finally:
        _state["depth"] = (_state["depth"] or 1) - 1
        pending = _state["pending"]
        if ok and not _state["depth"] and pending is not None and not _state["fired"]:
            _state["pending"] = None
            _state["fired"] = 1
            raise Interrupted(pending)

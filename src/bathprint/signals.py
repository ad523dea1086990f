"""SIGINT and SIGTERM end long commands the way Ctrl-C does, never silently.

Below every layer that runs a command (``envs`` for ``bathprint play``, ``agents`` for
training and evaluation); :mod:`bathprint.interrupt` is the sweeps' variant (the first signal
wins, writes are never cut).

- :class:`SignalStop` (a context manager) handles both signals in the main process. In
  *deferred* mode (``bathprint train``) the first signal only records itself: training
  stops at the next environment step, where the run is consistent, and saves a checkpoint.
  In *immediate* mode (``bathprint evaluate``, ``play``, ``baselines fit``) it raises
  :class:`Interrupted` at once. A second signal always raises at once.
- :class:`IgnoreSignals` wraps the environment factory of a subprocess vector-env worker
  so that the worker ignores both signals: a Ctrl-C in a terminal (SIGINT to the whole
  process group) or a SIGTERM from a batch system reaches the workers too, and without it
  they die mid-step with tracebacks while the parent is still saving. The parent closes them.

Exit codes follow the shell's convention, 128 + signal number: 130 for SIGINT, 143 for SIGTERM.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class Interrupted(KeyboardInterrupt):
    """A command was stopped by SIGINT or SIGTERM (``signum``); a KeyboardInterrupt, so code
    that handles Ctrl-C handles both."""

    def __init__(self, signum: int = signal.SIGINT) -> None:
        self.signum = int(signum)
        super().__init__(signal.Signals(self.signum).name)

    @property
    def exit_code(self) -> int:
        """128 + the signal number (130 for SIGINT, 143 for SIGTERM)."""
        return 128 + self.signum


def signal_name(signum: int) -> str:
    return signal.Signals(int(signum)).name


def exit_code(exc: BaseException) -> int:
    """The exit code of a command ended by ``exc`` (a KeyboardInterrupt): 128 + signal."""
    return int(getattr(exc, "exit_code", 128 + signal.SIGINT))


class SignalStop:
    """Handles SIGINT and SIGTERM while active (main thread only; elsewhere it does nothing).

    ``signum`` is the first signal received (None before). Deferred: the first signal is only
    recorded, the caller polls :attr:`requested`; immediate: it raises :class:`Interrupted`.
    A second signal raises :class:`Interrupted`, except inside :meth:`shield` (used while a
    checkpoint is written), where signals are only recorded.
    """

    def __init__(self, deferred: bool = True) -> None:
        self.deferred = bool(deferred)
        self.signum: int | None = None
        self._old: dict[int, Any] = {}
        self._shielded = 0

    @property
    def requested(self) -> bool:
        return self.signum is not None

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        first = self.signum is None
        if first:
            self.signum = signum
        if self._shielded or (self.deferred and first):
            return
        raise Interrupted(signum)

    def __enter__(self) -> SignalStop:
        if threading.current_thread() is threading.main_thread():
            for sig in SIGNALS:
                self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()

    @contextmanager
    def shield(self) -> Iterator[None]:
        """Signals received inside only record themselves (finish writing files first)."""
        self._shielded += 1
        try:
            yield
        finally:
            self._shielded -= 1


class IgnoreSignals:
    """An environment factory that first makes its process ignore SIGINT and SIGTERM (for
    subprocess vector-env workers, which their parent closes). Picklable when ``fn`` is."""

    def __init__(self, fn: Callable[[], Any]) -> None:
        self.fn = fn

    def __call__(self) -> Any:
        for sig in SIGNALS:
            signal.signal(sig, signal.SIG_IGN)
        return self.fn()

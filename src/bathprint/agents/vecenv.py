"""A SubprocVecEnv whose workers ignore SIGINT/SIGTERM and whose close never hangs.

The workers (see :class:`bathprint.agents.signals.IgnoreSignals`) leave ending to the
parent, which closes them when it has saved what it needs: :meth:`QuietSubprocVecEnv.close`
collects a step in flight (with a timeout), sends ``close``, and kills a worker that does not
exit (a worker that ignores SIGTERM would ignore ``Process.terminate`` too). An ``atexit``
hook closes a vector env the program forgot to close, so the interpreter's own clean-up
(which terminates and then joins daemon processes) cannot wait for such workers forever.
"""

from __future__ import annotations

import atexit
import weakref
from collections.abc import Callable, Sequence
from typing import Any

from stable_baselines3.common.vec_env import SubprocVecEnv

from bathprint.agents.signals import IgnoreSignals

RECV_TIMEOUT_S = 5.0  # a step in flight when close() is called
JOIN_TIMEOUT_S = 10.0  # a worker's env.close() and exit


_LIVE: weakref.WeakSet[QuietSubprocVecEnv] = weakref.WeakSet()
_HOOKED = False


def _close_all() -> None:
    for venv in list(_LIVE):
        venv.close()


class QuietSubprocVecEnv(SubprocVecEnv):
    """SubprocVecEnv (same arguments) with signal-ignoring workers and a bounded close."""

    def __init__(
        self, env_fns: Sequence[Callable[[], Any]], start_method: str | None = None
    ) -> None:
        self.processes: list[Any] = []
        self.remotes: Sequence[Any] = ()
        self.closed = False
        try:
            super().__init__([IgnoreSignals(fn) for fn in env_fns], start_method)
        except BaseException:
            self._stop_workers()
            raise
        global _HOOKED
        if not _HOOKED:  # after multiprocessing's own hook, so that it runs before it
            atexit.register(_close_all)
            _HOOKED = True
        _LIVE.add(self)

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        if getattr(self, "waiting", False):
            for remote in self.remotes:
                try:
                    if remote.poll(RECV_TIMEOUT_S):
                        remote.recv()
                except (EOFError, OSError):
                    pass
            self.waiting = False
        for remote in self.remotes:
            try:
                remote.send(("close", None))
            except OSError:  # the worker is gone already
                pass
        self._stop_workers()
        _LIVE.discard(self)

    def _stop_workers(self) -> None:
        for process in self.processes:
            process.join(JOIN_TIMEOUT_S)
            if process.is_alive():
                process.kill()
                process.join(1.0)
        for remote in self.remotes:
            remote.close()

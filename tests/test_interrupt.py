"""SIGTERM handled like Ctrl-C (bathprint.interrupt): raised as Interrupted, deferred out of
atomic writes, handlers restored afterwards."""

from __future__ import annotations

import os
import signal

import pytest

from bathprint.interrupt import Interrupted, atomic, exit_code, signals_interrupt


@pytest.mark.parametrize("signum", [signal.SIGTERM, signal.SIGINT], ids=["SIGTERM", "SIGINT"])
def test_a_signal_raises_interrupted_with_its_exit_code(signum: int) -> None:
    before = signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)
    with pytest.raises(Interrupted) as info, signals_interrupt():
        os.kill(os.getpid(), signum)
        for _ in range(10**6):  # the handler runs at the next bytecode boundary
            pass
    assert isinstance(info.value, KeyboardInterrupt)  # cleaned up like Ctrl-C
    assert exit_code(info.value) == 128 + signum
    assert (signal.getsignal(signal.SIGTERM), signal.getsignal(signal.SIGINT)) == before
    assert exit_code(KeyboardInterrupt()) == 130


def test_a_signal_inside_atomic_is_raised_when_the_block_ends() -> None:
    written = []
    with pytest.raises(Interrupted), signals_interrupt():
        with atomic():
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(10**5):
                pass
            written.append("row")  # not cut
        written.append("after")  # not reached
    assert written == ["row"]


def test_later_signals_are_ignored_during_the_clean_up() -> None:
    cleaned = False
    with signals_interrupt():
        try:
            os.kill(os.getpid(), signal.SIGTERM)
            for _ in range(10**6):
                pass
        except Interrupted:
            os.kill(os.getpid(), signal.SIGTERM)  # a second one while cleaning up
            for _ in range(10**5):
                pass
            cleaned = True
    assert cleaned

"""SIGINT and SIGTERM handling of the agents' commands: :mod:`bathprint.signals` (below
both the environments and the agents, so that ``bathprint play`` uses it too)."""

from bathprint.signals import (
    SIGNALS,
    IgnoreSignals,
    Interrupted,
    SignalStop,
    exit_code,
    signal_name,
)

__all__ = ["SIGNALS", "IgnoreSignals", "Interrupted", "SignalStop", "exit_code", "signal_name"]

"""Errors bathprint raises: bad scenes, bad options and diverging simulations."""

from __future__ import annotations


class SceneError(ValueError):
    """A scene key, value or effect is unknown, missing or non-physical.

    The message names the key, the value given and what is allowed.
    """


class OptionError(ValueError):
    """An option of a command or function (not a scene key) is out of range, or an output
    path is a file or cannot be written. The message names the option, the value and what
    is allowed; it is raised before any long work starts.
    """


class SimulationError(RuntimeError):
    """A simulation diverged: a NaN, Newton failing at the smallest step, or runaway stretch.

    Attributes say where and when: ``time_s``, ``node`` (index from the free end,
    0 = oldest material) and ``cause``.
    """

    def __init__(self, cause: str, time_s: float, node: int, detail: str = "") -> None:
        self.cause = cause
        self.time_s = float(time_s)
        self.node = int(node)
        self.detail = detail
        msg = f"simulation diverged at t = {self.time_s:.6g} s, node {self.node}: {cause}"
        if detail:
            msg += f" ({detail})"
        super().__init__(msg)

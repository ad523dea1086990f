"""Errors bathprint raises: bad scenes, bad settings or options, and diverging simulations."""

from __future__ import annotations


class SceneError(ValueError):
    """A scene key, value or effect is unknown, missing or non-physical.

    The message names the key, the value given and what is allowed.
    """


class ConfigError(ValueError):
    """A setting or option (not a scene key) is unknown, of the wrong type or out of range:
    a hyperparameter file, an environment's keyword arguments, a run folder, a command-line
    option, or an output path that is a file or cannot be written.

    The message names the parameter, the value given and what is allowed; commands print it
    as one line and exit with code 2, before any work starts.
    """


class CoarseNumericsWarning(UserWarning):
    """A scene's numerics resolve its buckling length only coarsely: the run goes ahead,
    its shapes carry a discretisation error (:mod:`bathprint.core.resolution`)."""


OptionError = ConfigError  # the name the commands' option checks raise


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
